"""Models and plain-numpy references for tests/test_statics.py (book ch 12).

Every builder returns a :class:`helpers.models.Spec` (the Model plus the data the
references need) and the constants of its closed-form potential.  The references
are written from the geometry the builder gave the model, never from openimp:

* :func:`upright_pendulum`: V(theta) = 1/2 k theta^2 + m g l cos theta;
* :func:`double_pendulum`: V(theta1, theta2) of two links with joint springs under
  gravity (:func:`double_pendulum_potential`, its gradient and Hessian);
* :func:`slider_crank`: the book's figure 12.1, a piston force P toward the crank,
  gravity normal to the plane; the piston position x(phi) and the rod angle
  beta(phi) of the crank angle (:func:`slider_crank_kinematics`);
* :func:`vehicle`: a body on a horizontal slider with a vertical sprung slider;
* :func:`truss`: a von Mises truss (two springs to an apex on a vertical slider).

:class:`StaticRef` extends the Newton-Euler balance of :class:`helpers.mechanics.Ref` with
forces given by a load law of t.
"""

from __future__ import annotations

import math

import numpy as np

import openimp
from helpers.mechanics import Ref
from helpers.models import Spec, slider_crank_joints

G = 9.81
DEG = math.pi / 180


# ----------------------------------------------------------------------------- balance
class StaticRef(Ref):
    """:class:`helpers.mechanics.Ref` with forces whose magnitude is a law of the time:
    ``law_forces`` = [(point, f(t) -> magnitude, fixed global direction (3,))]."""

    def __init__(self, spec: Spec, tr: openimp.Trajectory, law_forces=()) -> None:
        super().__init__(spec, tr)
        self.law_forces = list(law_forces)

    def applied(self, body):
        out = super().applied(body)
        t = np.zeros(self.tr.nsteps) if self.tr.time is None else np.asarray(self.tr.time)
        for p, f, d in self.law_forces:
            if self.spec.points[p] == body:
                mag = np.array([f(tk) for tk in t])
                out.append((mag[:, None] * np.asarray(d, float)[None, :], self.tr.point(p)))
        return out


def body_balance(spec: Spec, tr, F, bodies, plane: bool, law_forces=()):
    """The worst Newton-Euler residual of ``bodies`` relative to the largest term of
    each body (forces; moments against the largest moment term or the largest force
    times one length unit): the joint reactions of F, gravity and
    the elements add up to zero at rest.  ``plane``: only Fx, Fy, Mz (the determinate
    components of a planar mechanism of spatial joints)."""
    ref = StaticRef(spec, tr, law_forces)
    worst = 0.0
    for b in bodies:
        fres, mres, sf, sm = ref.balance(F, b)
        if plane:
            fres, mres = fres[:, :2], mres[:, 2:]
        assert np.all(np.isfinite(fres)) and np.all(np.isfinite(mres)), b
        # a two-force member has no moment term: moments are judged against the
        # largest force times one length unit too
        sm = max(sm, sf * 1.0)
        worst = max(worst, float(np.abs(fres).max()) / sf, float(np.abs(mres).max()) / sm)
    return worst


# ----------------------------------------------------------------------------- 1 pendulum
def upright_pendulum(k_ratio: float, m: float = 3.0, l: float = 0.8):
    """A rod standing up along +y on revolute A about z (centre of mass at (0, l, 0)),
    gravity -y, a torsional spring on A, rate ``k_ratio`` m g l, free at 0.

    Returns (spec, k, mgl).  With theta the angle of A (counter-clockwise), the centre
    is at (-l sin theta, l cos theta): V = 1/2 k theta^2 + m g l cos theta,
    F = -V' = m g l sin theta - k theta, K = V'' = k - m g l cos theta."""
    s = Spec(openimp.Model("upright pendulum"))
    s.joint("A", "BASE", "ROD", (0.0, 0.0, 0.0))
    s.add_mass("ROD", m, (0.0, l, 0.0), np.diag([0.02, 0.01, 0.02]))
    s.set_gravity((0.0, -G, 0.0))
    mgl = m * G * l
    k = k_ratio * mgl
    s.joint_spring("A", k, 0.0)
    return s, k, mgl


# ----------------------------------------------------------------------------- 2 double pendulum
#: link 1 from A = 0 to B = (L1, 0), centre c1; link 2 from B, centre B + c2 (modeling
#: posture: both links along +x, centres off the link lines)
DP = dict(L1=1.0, m1=2.0, c1=(0.45, 0.08), m2=1.5, c2=(0.6, -0.1),
          kA=60.0, qA0=0.4, kB=25.0, qB0=-0.3)


def double_pendulum(kA: float | None = None, kB: float | None = None):
    """Two links in series on revolutes A (BASE -> L1) and B (L1 -> L2) about z, gravity
    -y, joint springs kA (free qA0) and kB (free qB0) on the relative angles."""
    d = DP
    kA = d["kA"] if kA is None else kA
    kB = d["kB"] if kB is None else kB
    s = Spec(openimp.Model("double pendulum"))
    s.joint("A", "BASE", "L1", (0.0, 0.0, 0.0))
    s.joint("B", "L1", "L2", (d["L1"], 0.0, 0.0))
    s.add_mass("L1", d["m1"], (*d["c1"], 0.0), np.diag([0.01, 0.05, 0.06]))
    s.add_mass("L2", d["m2"], (d["L1"] + d["c2"][0], d["c2"][1], 0.0),
               np.diag([0.01, 0.04, 0.05]))
    s.set_gravity((0.0, -G, 0.0))
    s.point("TIP", "L2", (d["L1"] + 1.2, 0.0, 0.0))
    s.joint_spring("A", kA, d["qA0"])
    s.joint_spring("B", kB, d["qB0"])
    return s, kA, kB


def _rot2(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s], [s, c]])


def double_pendulum_potential(th, kA=None, kB=None):
    """V(theta1, theta2) of :func:`double_pendulum` (theta2 relative)."""
    d = DP
    kA = d["kA"] if kA is None else kA
    kB = d["kB"] if kB is None else kB
    t1, t2 = float(th[0]), float(th[1])
    p1 = _rot2(t1) @ np.array(d["c1"])
    p2 = _rot2(t1) @ np.array([d["L1"], 0.0]) + _rot2(t1 + t2) @ np.array(d["c2"])
    return (0.5 * kA * (t1 - d["qA0"]) ** 2 + 0.5 * kB * (t2 - d["qB0"]) ** 2
            + G * (d["m1"] * p1[1] + d["m2"] * p2[1]))


def double_pendulum_gradient(th, kA=None, kB=None):
    """dV/d(theta1, theta2), by hand: the y of R(a) c is sin(a) cx + cos(a) cy, whose
    derivative is cos(a) cx - sin(a) cy."""
    d = DP
    kA = d["kA"] if kA is None else kA
    kB = d["kB"] if kB is None else kB
    t1, t2 = float(th[0]), float(th[1])

    def dy(a, c):
        return math.cos(a) * c[0] - math.sin(a) * c[1]

    g1 = dy(t1, d["c1"]) * d["m1"] + d["m2"] * (dy(t1, (d["L1"], 0.0)) + dy(t1 + t2, d["c2"]))
    g2 = d["m2"] * dy(t1 + t2, d["c2"])
    return np.array([kA * (t1 - d["qA0"]) + G * g1, kB * (t2 - d["qB0"]) + G * g2])


def double_pendulum_hessian(th, kA=None, kB=None):
    """d2V/d(theta)^2 by hand (the second derivative of the y of R(a) c is -y)."""
    d = DP
    kA = d["kA"] if kA is None else kA
    kB = d["kB"] if kB is None else kB
    t1, t2 = float(th[0]), float(th[1])

    def y(a, c):
        return math.sin(a) * c[0] + math.cos(a) * c[1]

    h12 = -G * d["m2"] * y(t1 + t2, d["c2"])
    h11 = kA - G * (d["m1"] * y(t1, d["c1"]) + d["m2"] * y(t1, (d["L1"], 0.0))) + h12
    return np.array([[h11, h12], [h12, kB + h12]])


# ----------------------------------------------------------------------------- 3 slider-crank
SC = dict(a=1.0, b=3.0, th0=30 * DEG)


def slider_crank(P: float = 1000.0, e: float = 0.0, spring: tuple | None = None,
                 block: tuple | None = None, crank_spring: tuple | None = None):
    """Figure 12.1: crank A (BASE -> CRANK, from the origin), rod B (CRANK -> ROD), pin C
    (ROD -> SLIDER), prismatic D (BASE -> SLIDER) along x on the line y = e; modeling
    crank angle 30 deg; masses on every link, gravity along -z (normal to the plane of
    motion: no in-plane effect).  A force P on the piston along -x (toward the crank);
    ``spring`` = (k, x0): a spring in D instead (D.s is the piston's x);
    ``crank_spring`` = (k, free): a spring in A too; ``block`` = (k1, k2, xg, l0): a
    block on prismatic E (SLIDER -> BLOCK, along x, E.s = u its shift on the piston) with
    a spring k1 in E (free at 0) and a point spring k2 (free length l0) from the block
    at the piston pin to the ground point (xg, e): at piston x the energy of the two is
    1/2 k1 u^2 + 1/2 k2 (xg - x - u - l0)^2 (while xg > x + u)."""
    s, B, C = slider_crank_joints("slider-crank 12.1", SC["a"], SC["b"], e, SC["th0"])
    s.add_mass("CRANK", 1.0, 0.5 * B + np.array([0.0, 0.05, 0.0]), np.diag([0.02, 0.08, 0.09]))
    s.add_mass("ROD", 2.0, 0.5 * (B + C), np.diag([0.02, 1.5, 1.52]))
    s.add_mass("SLIDER", 3.0, C + np.array([0.05, 0.02, 0.0]), np.diag([0.01, 0.02, 0.025]))
    s.set_gravity((0.0, 0.0, -G))
    s.point("PS", "SLIDER", C)
    if spring is None and block is None:
        s.force("P", "PS", P, (-1.0, 0.0, 0.0))
    elif spring is not None:
        s.joint_spring("D", *spring)
    if crank_spring is not None:
        s.joint_spring("A", *crank_spring)
    if block is not None:
        k1, k2, xg, l0 = block
        s.joint("E", "SLIDER", "BLOCK", C, (1.0, 0.0, 0.0), kind="prismatic")
        s.add_mass("BLOCK", 0.5, C + np.array([0.0, 0.1, 0.0]), np.diag([0.01, 0.01, 0.01]))
        s.point("PK", "BLOCK", C)
        s.point("GR", "BASE", (xg, e, 0.0))
        s.joint_spring("E", k1, 0.0)
        s.spring("K2", "PK", "GR", k2, l0)
    return s


def slider_crank_kinematics(phi, e: float = 0.0):
    """Piston x and rod angle beta (from +x) at crank angle phi (absolute), the branch
    with the piston to the right of the crank pin."""
    a, b = SC["a"], SC["b"]
    phi = np.asarray(phi, float)
    bx, by = a * np.cos(phi), a * np.sin(phi)
    x = bx + np.sqrt(b * b - (e - by) ** 2)
    return x, np.arctan2(e - by, x - bx)


def slider_crank_coordinate(name: str, phi, e: float = 0.0):
    """The joint variable ``name`` of :func:`slider_crank` as a function of the crank angle
    phi (absolute): A.theta = phi - th0; B.theta = (beta - phi) - (beta0 - th0);
    C.theta = -(beta - beta0) (the slider does not turn); D.s = x."""
    th0 = SC["th0"]
    x, beta = slider_crank_kinematics(phi, e)
    _, beta0 = slider_crank_kinematics(th0, e)
    return {"A.theta": np.asarray(phi) - th0, "B.theta": (beta - phi) - (beta0 - th0),
            "C.theta": -(beta - beta0), "D.s": x}[name]


def d_central(f, x, h):
    """First and second derivatives of f at x, fourth-order central differences."""
    f2, f1, f0, fm1, fm2 = (f(x + 2 * h), f(x + h), f(x), f(x - h), f(x - 2 * h))
    d1 = (-f2 + 8 * f1 - 8 * fm1 + fm2) / (12 * h)
    d2 = (-f2 + 16 * f1 - 30 * f0 + 16 * fm1 - fm2) / (12 * h * h)
    return d1, d2


# ----------------------------------------------------------------------------- 5 vehicle
VEH = dict(m_cart=5.0, m_body=50.0, k=2000.0, h=0.5)


def vehicle(push: float | None = None, push_law=None, vertical_first: bool = False):
    """A cart on prismatic X (BASE -> CART, along x: no stiffness, the book's vehicle on
    a flat road), a body on prismatic Y (CART -> BODY, vertical) with a spring k (free at
    0), gravity -y; ``push``: a constant horizontal force on the body (``push_law``: one
    whose magnitude is a load law); ``vertical_first``: BASE -Y-> CART -X-> BODY instead
    (the spring then holds the cart and the body, the joint variables come Y first)."""
    v = VEH
    s = Spec(openimp.Model("vehicle"))
    if vertical_first:  # the same mechanism with the suspension's variable first
        s.joint("Y", "BASE", "CART", (0.0, 0.0, 0.0), (0.0, 1.0, 0.0), kind="prismatic")
        s.joint("X", "CART", "BODY", (0.0, v["h"], 0.0), (1.0, 0.0, 0.0), kind="prismatic")
    else:
        s.joint("X", "BASE", "CART", (0.0, 0.0, 0.0), (1.0, 0.0, 0.0), kind="prismatic")
        s.joint("Y", "CART", "BODY", (0.0, v["h"], 0.0), (0.0, 1.0, 0.0), kind="prismatic")
    s.add_mass("CART", v["m_cart"], (0.0, 0.0, 0.0), np.diag([0.5, 0.5, 0.5]))
    s.add_mass("BODY", v["m_body"], (0.1, v["h"], 0.0), np.diag([2.0, 3.0, 2.5]))
    s.set_gravity((0.0, -G, 0.0))
    s.joint_spring("Y", v["k"], 0.0)
    s.point("PB", "BODY", (0.0, v["h"] + 0.2, 0.0))
    if push is not None:
        s.force("H", "PB", push, (1.0, 0.0, 0.0))
    if push_law is not None:
        s.model.add_force("H", "PB", law=push_law, direction=(1.0, 0.0, 0.0))
    return s


# ----------------------------------------------------------------------------- 7 truss
VM = dict(a=1.0, h=0.5, k=1000.0)


def truss(load_law=None):
    """A von Mises truss: the apex on prismatic Y (BASE -> APEX, vertical, Y.s = its
    drop below the rest height h ... along +y), two point springs k from the apex to
    supports at (-a, 0) and (a, 0), free at their rest length; no gravity; ``load_law``:
    a downward force W on the apex of magnitude law(s)."""
    a, h, k = VM["a"], VM["h"], VM["k"]
    L0 = math.hypot(a, h)
    s = Spec(openimp.Model("von Mises truss"))
    s.joint("Y", "BASE", "APEX", (0.0, h, 0.0), (0.0, 1.0, 0.0), kind="prismatic")
    s.add_mass("APEX", 1.0, (0.0, h, 0.0), np.diag([0.01, 0.01, 0.01]))
    s.point("P", "APEX", (0.0, h, 0.0))
    s.point("SL", "BASE", (-a, 0.0, 0.0))
    s.point("SR", "BASE", (a, 0.0, 0.0))
    s.spring("KL", "P", "SL", k, L0)
    s.spring("KR", "P", "SR", k, L0)
    if load_law is not None:
        s.model.add_force("W", "P", law=load_law, direction=(0.0, -1.0, 0.0))
    return s


def truss_resistance(y):
    """The upward force of the two springs on the apex at height y (apex at (0, y)):
    tension k (L - L0) along the spring, L = sqrt(a^2 + y^2): R = 2 k (L0 - L) y / L."""
    a, h, k = VM["a"], VM["h"], VM["k"]
    L0 = math.hypot(a, h)
    L = np.hypot(a, y)
    return 2 * k * (L0 - L) * y / L


# ----------------------------------------------------------------------------- ball joint
SPH = dict(m=2.0, l=1.0, k=30.0, gp=(0.8, 0.5, -0.6), l0=0.3)


def spherical_pendulum():
    """A rod hanging along -z from a ball joint S at the origin (centre of mass at
    (0, 0, -l/2)), gravity -z, a point spring k (free length l0) from its tip T to the
    ground point gp."""
    p = SPH
    s = Spec(openimp.Model("spherical pendulum"))
    s.joint("S", "BASE", "ROD", (0.0, 0.0, 0.0), kind="sphere")
    s.add_mass("ROD", p["m"], (0.0, 0.0, -p["l"] / 2), np.diag([0.1, 0.1, 0.01]))
    s.point("T", "ROD", (0.0, 0.0, -p["l"]))
    s.point("GP", "BASE", p["gp"])
    s.spring("K", "T", "GP", p["k"], p["l0"])
    s.set_gravity((0.0, 0.0, -G))
    return s


def spherical_potential(xy):
    """V of :func:`spherical_pendulum` with the rod's direction d = (x, y,
    -sqrt(1 - x^2 - y^2)) (the lower hemisphere): m g (l/2) d_z + 1/2 k (|l d - gp| -
    l0)^2."""
    p = SPH
    x, y = float(xy[0]), float(xy[1])
    d = np.array([x, y, -math.sqrt(max(1.0 - x * x - y * y, 0.0))])
    return (p["m"] * G * 0.5 * p["l"] * d[2]
            + 0.5 * p["k"] * (np.linalg.norm(p["l"] * d - np.array(p["gp"])) - p["l0"]) ** 2)
