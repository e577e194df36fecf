"""Models and plain-numpy / scipy references for tests/test_response.py (book ch 14).

Every builder returns a :class:`helpers.models.Spec` (the Model and, beside it, the data
the references need).  The references are written from the geometry the builder gave
the model, never from openimp:

* :func:`pendulum`: a point bob on revolute A; theta from the downward vertical,
  counter-clockwise, the bob at (l sin theta, -l cos theta); the exact period
  4 sqrt(l / g) K(sin(theta0 / 2)) (:func:`pendulum_period`);
* :func:`fourbar` with :class:`FourBarRef`: uniform bars, released with the crank
  vertical; the loop closed in closed form, the kinetic energy 1/2 m(phi) phi'^2 and
  the potential V(phi) from the velocity and acceleration coefficients of the loop
  (linear 2x2 solves, no differencing), Lagrange's equation
  m phi'' + 1/2 m'(phi) phi'^2 + V'(phi) = 0 for solve_ivp;
* :func:`slider_pendulum`: a pendulum hung from a cart on a driven prismatic joint,
  theta'' = -(g sin theta + x'' cos theta) / l, and the drive force on the cart;
* :func:`spring_mass`: a block on a prismatic joint with a joint spring and a joint
  damper (or load laws), exactly the linear oscillator m x'' + c x' + k x = 0;
* :func:`stiff_pendulum`: a bob on a stiff radial spring along a prismatic joint of
  a pendulum arm;
* :func:`drop`: a block on a vertical prismatic joint falling onto a stop;
* :func:`slider_crank`: a slider-crank driven at its slider (limits of travel);
* :func:`shrinking_pendulum`: a point bob pulled into the pivot by its drive (the mass
  matrix m r^2 vanishes at r = 0).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.special import ellipk

import openimp
from helpers.models import Spec

G = 9.81
DEG = math.pi / 180


def point_mass(s: Spec, body: str, m: float, c) -> None:
    """A point mass m at c (global, modeling posture) on ``body``: no inertia about its
    centre (Spec.add_mass asserts that openimp finds it a valid rigid body)."""
    s.add_mass(body, m, c, np.zeros((3, 3)))


# ----------------------------------------------------------------------------- pendulum
def pendulum(l: float = 0.7, m: float = 2.0, damper: float = 0.0) -> Spec:
    """A point bob m at distance l below revolute A (BASE -> ROD, about z), gravity -y;
    ``damper``: a joint damper on A (torque -c theta')."""
    s = Spec(openimp.Model("pendulum"))
    s.joint("A", "BASE", "ROD", (0.0, 0.0, 0.0))
    point_mass(s, "ROD", m, (0.0, -l, 0.0))
    s.set_gravity((0.0, -G, 0.0))
    s.point("BOB", "ROD", (0.0, -l, 0.0))
    if damper:
        s.joint_damper("A", damper)
    return s


def pendulum_period(l: float, theta0: float) -> float:
    """The exact period of a simple pendulum of amplitude theta0: 4 sqrt(l/g) K(k),
    k = sin(theta0 / 2) (scipy's ellipk takes m = k^2)."""
    return 4.0 * math.sqrt(l / G) * float(ellipk(math.sin(theta0 / 2) ** 2))


# ----------------------------------------------------------------------------- four-bar
#: crank l1 from A = (0, 0), coupler l2, rocker l3 pinned at D = (d, 0); uniform bars
#: of mass rho per length; Grashof (1 + 4 < 3 + 3.5): the crank turns fully
FBR = dict(l1=1.0, l2=3.5, l3=3.0, d=4.0, rho=1.0)


def _circles(P: np.ndarray, r: float, Q: np.ndarray, s: float, sign: float) -> np.ndarray:
    """The intersection of the circles (P, r) and (Q, s) in the plane on the side
    ``sign`` (+1: left of P -> Q)."""
    PQ = Q - P
    L = math.hypot(*PQ)
    x = (r * r - s * s + L * L) / (2 * L)
    h = math.sqrt(r * r - x * x)
    return P + x * PQ / L + sign * h * np.array([-PQ[1], PQ[0]]) / L


def fourbar() -> Spec:
    """Four revolutes about z in the XY plane: A BASE->CRANK at the origin, B
    CRANK->COUPLER at (0, l1) (the crank vertical), C COUPLER->ROCKER, D ROCKER->BASE
    at (d, 0) (D's first body is the rocker: D.theta = -(rocker angle change)).
    Uniform bars (mass rho L, centroidal inertia m L^2 / 12), gravity -y."""
    p = FBR
    A, B, D = np.zeros(2), np.array([0.0, p["l1"]]), np.array([p["d"], 0.0])
    C = _circles(B, p["l2"], D, p["l3"], 1.0)  # the upper assembly: left of B -> D
    assert C[1] > 0
    s = Spec(openimp.Model("four-bar"))
    for name, b1, b2, o in (("A", "BASE", "CRANK", A), ("B", "CRANK", "COUPLER", B),
                            ("C", "COUPLER", "ROCKER", C), ("D", "ROCKER", "BASE", D)):
        s.joint(name, b1, b2, (o[0], o[1], 0.0))
    for body, P, Q in (("CRANK", A, B), ("COUPLER", B, C), ("ROCKER", C, D)):
        L = math.hypot(*(Q - P))
        m = p["rho"] * L
        c = (P + Q) / 2
        s.add_mass(body, m, (c[0], c[1], 0.0), np.diag([1.0, 1.0, 1.0]) * m * L * L / 12)
    s.set_gravity((0.0, -G, 0.0))
    return s


class FourBarRef:
    """The four-bar of :func:`fourbar` as one equation in the crank's absolute angle
    phi (phi = pi/2 + A.theta).  Loop: l1 e^{i phi} + l2 e^{i beta} = d + l3 e^{i gamma}
    (beta the coupler's, gamma the rocker's absolute angle, C on the side of the
    modeling posture).  Velocity coefficients kb = d beta / d phi, kg = d gamma / d phi
    and their derivatives lb, lg from the first and second derivatives of the loop
    (two linear 2x2 solves); the centres c_i(phi), c_i', c_i''; then
    m(phi) = sum m_i |c_i'|^2 + I_i k_i^2, m' = 2 sum m_i c_i'.c_i'' + I_i k_i l_i,
    V' = g sum m_i Im c_i'."""

    def __init__(self) -> None:
        p = FBR
        self.l1, self.l2, self.l3, self.d = p["l1"], p["l2"], p["l3"], p["d"]
        self.m = [p["rho"] * L for L in (self.l1, self.l2, self.l3)]
        self.I = [m * L * L / 12 for m, L in zip(self.m, (self.l1, self.l2, self.l3),
                                                  strict=True)]
        self.phi0 = math.pi / 2

    def angles(self, phi: float) -> tuple[float, float]:
        """beta, gamma at crank angle phi (C left of B -> D, as modeled)."""
        B = self.l1 * np.array([math.cos(phi), math.sin(phi)])
        D = np.array([self.d, 0.0])
        C = _circles(B, self.l2, D, self.l3, 1.0)
        return math.atan2(C[1] - B[1], C[0] - B[0]), math.atan2(C[1], C[0] - self.d)

    def coefficients(self, phi: float):
        """(beta, gamma, kb, kg, lb, lg)."""
        beta, gamma = self.angles(phi)
        ea, eb, eg = (complex(math.cos(x), math.sin(x)) for x in (phi, beta, gamma))
        # i l1 ea + i l2 eb kb - i l3 eg kg = 0 -> [l2 eb, -l3 eg] [kb, kg] = -l1 ea
        Mx = np.array([[(1j * self.l2 * eb).real, (-1j * self.l3 * eg).real],
                       [(1j * self.l2 * eb).imag, (-1j * self.l3 * eg).imag]])
        r1 = -1j * self.l1 * ea
        kb, kg = np.linalg.solve(Mx, [r1.real, r1.imag])
        # -l1 ea - l2 eb kb^2 + i l2 eb lb + l3 eg kg^2 - i l3 eg lg = 0
        r2 = self.l1 * ea + self.l2 * eb * kb**2 - self.l3 * eg * kg**2
        lb, lg = np.linalg.solve(Mx, [r2.real, r2.imag])
        return beta, gamma, kb, kg, lb, lg

    def centres(self, phi: float):
        """Per body (crank, coupler, rocker): centre c, dc/dphi, d2c/dphi2 (complex), the
        body's angular coefficient k and its derivative l."""
        beta, gamma, kb, kg, lb, lg = self.coefficients(phi)
        ea, eb, eg = (complex(math.cos(x), math.sin(x)) for x in (phi, beta, gamma))
        l1, l2, l3 = self.l1, self.l2, self.l3
        crank = (0.5 * l1 * ea, 0.5j * l1 * ea, -0.5 * l1 * ea, 1.0, 0.0)
        coupler = (l1 * ea + 0.5 * l2 * eb, 1j * l1 * ea + 0.5j * l2 * eb * kb,
                   -l1 * ea - 0.5 * l2 * eb * kb**2 + 0.5j * l2 * eb * lb, kb, lb)
        rocker = (self.d + 0.5 * l3 * eg, 0.5j * l3 * eg * kg,
                  -0.5 * l3 * eg * kg**2 + 0.5j * l3 * eg * lg, kg, lg)
        return crank, coupler, rocker

    def mass(self, phi: float) -> tuple[float, float, float, float]:
        """m(phi), m'(phi), V(phi), V'(phi)."""
        M = dM = V = dV = 0.0
        for m, I, (c, c1, c2, k, dk) in zip(self.m, self.I, self.centres(phi), strict=True):
            M += m * abs(c1) ** 2 + I * k * k
            dM += 2 * (m * (c1.conjugate() * c2).real + I * k * dk)
            V += m * G * c.imag
            dV += m * G * c1.imag
        return M, dM, V, dV

    def rhs(self, t: float, y: np.ndarray) -> list[float]:
        """solve_ivp right-hand side of y = (phi, phi')."""
        M, dM, _, dV = self.mass(y[0])
        return [y[1], -(0.5 * dM * y[1] ** 2 + dV) / M]

    def energy(self, phi: float, w: float) -> float:
        """T + V."""
        M, _, V, _ = self.mass(phi)
        return 0.5 * M * w * w + V


# ----------------------------------------------------------------------------- slider pendulum
#: cart mass, bob mass, length
SLP = dict(M=3.0, m=1.5, l=0.8)


def slider_pendulum() -> Spec:
    """A cart on prismatic S (BASE -> CART, along x; S.s the cart's x) and a point bob m
    at l below revolute A (CART -> ROD, about z), gravity -y.  With the cart at x(t):
    theta'' = -(g sin theta + x'' cos theta) / l; the drive force on S
    F = (M + m) x'' + m l (theta'' cos theta - theta'^2 sin theta)."""
    p = SLP
    s = Spec(openimp.Model("pendulum on a cart"))
    s.joint("S", "BASE", "CART", (0.0, 0.0, 0.0), (1.0, 0.0, 0.0), kind="prismatic",
            ref=(0.0, 1.0, 0.0))
    s.joint("A", "CART", "ROD", (0.0, 0.0, 0.0))
    s.add_mass("CART", p["M"], (0.0, 0.0, 0.0), np.diag([0.1, 0.1, 0.1]))
    point_mass(s, "ROD", p["m"], (0.0, -p["l"], 0.0))
    s.set_gravity((0.0, -G, 0.0))
    return s


# ----------------------------------------------------------------------------- spring-mass
def spring_mass(m: float, k: float, c: float = 0.0, spring_law=None, damper_law=None,
                gravity: float = 0.0) -> Spec:
    """Block B (mass m) on prismatic X along x (X.s its displacement), a joint spring k
    free at 0 and a joint damper c on X (or ``spring_law`` / ``damper_law``):
    m x'' + c x' + k x = -m ``gravity`` (gravity along -x)."""
    s = Spec(openimp.Model("spring-mass"))
    s.joint("X", "BASE", "B", (0.0, 0.0, 0.0), (1.0, 0.0, 0.0), kind="prismatic",
            ref=(0.0, 1.0, 0.0))
    s.add_mass("B", m, (0.0, 0.0, 0.0), np.diag([0.1, 0.1, 0.1]))
    s.set_gravity((-gravity, 0.0, 0.0))
    if spring_law is not None:
        s.model.set_joint_spring("X", law=spring_law)
    elif k:
        s.joint_spring("X", k, 0.0)
    if damper_law is not None:
        s.model.set_joint_damper("X", law=damper_law)
    elif c:
        s.joint_damper("X", c)
    return s


def damped_free(t, x0: float, m: float, k: float, c: float) -> tuple[np.ndarray, np.ndarray]:
    """x, x' of m x'' + c x' + k x = 0 released from rest at x0 (under-damped)."""
    t = np.asarray(t, float)
    w = math.sqrt(k / m)
    z = c / (2 * math.sqrt(k * m))
    wd = w * math.sqrt(1 - z * z)
    e = np.exp(-z * w * t)
    x = x0 * e * (np.cos(wd * t) + z * w / wd * np.sin(wd * t))
    v = -x0 * e * (w * w / wd) * np.sin(wd * t)
    return x, v


# ----------------------------------------------------------------------------- stiff pendulum
#: arm length (free length of the radial spring), bob mass, stiffness ratio
STP = dict(l=0.7, m=2.0, ratio=1e6)


def stiff_pendulum() -> Spec:
    """Revolute A (BASE -> ARM, about z) and prismatic P (ARM -> BOB) along the arm
    (axis -y at the modeling posture, P.s the bob's distance from the pivot); a point
    bob m; a joint spring on P of rate ``ratio`` m g / l (``ratio`` times the gravity
    stiffness of the pendulum m g / l per unit length of the arc: the radial mode is
    sqrt(ratio) = 1000 times faster than the swing), free at l."""
    p = STP
    s = Spec(openimp.Model("stiff pendulum"))
    s.joint("A", "BASE", "ARM", (0.0, 0.0, 0.0))
    s.joint("P", "ARM", "BOB", (0.0, 0.0, 0.0), (0.0, -1.0, 0.0), kind="prismatic",
            ref=(1.0, 0.0, 0.0), origin2=(0.0, -p["l"], 0.0))
    point_mass(s, "BOB", p["m"], (0.0, -p["l"], 0.0))
    s.set_gravity((0.0, -G, 0.0))
    s.joint_spring("P", p["ratio"] * p["m"] * G / p["l"], p["l"])
    return s


# ----------------------------------------------------------------------------- drop
def drop(m: float, law) -> Spec:
    """Block B (mass m) on prismatic Y along +y (Y.s its height above the modeling
    posture), gravity -y, the joint spring law ``law`` on Y (a stop)."""
    s = Spec(openimp.Model("drop"))
    s.joint("Y", "BASE", "B", (0.0, 0.0, 0.0), (0.0, 1.0, 0.0), kind="prismatic",
            ref=(1.0, 0.0, 0.0))
    s.add_mass("B", m, (0.0, 0.0, 0.0), np.diag([0.1, 0.1, 0.1]))
    s.set_gravity((0.0, -G, 0.0))
    s.model.set_joint_spring("Y", law=law)
    return s


# ----------------------------------------------------------------------------- failures
def slider_crank(a: float = 1.0, b: float = 2.0) -> Spec:
    """Crank a (A BASE -> CRANK from the origin, at 60 deg), rod b (B CRANK -> ROD), pin
    C (ROD -> SLIDER), prismatic D (BASE -> SLIDER along x; D.s the slider's x): the
    slider reaches at most a + b (the crank and rod in line)."""
    th = 60 * DEG
    B = a * np.array([math.cos(th), math.sin(th), 0.0])
    C = np.array([B[0] + math.sqrt(b * b - B[1] ** 2), 0.0, 0.0])
    s = Spec(openimp.Model("slider-crank"))
    s.joint("A", "BASE", "CRANK", (0.0, 0.0, 0.0))
    s.joint("B", "CRANK", "ROD", B)
    s.joint("C", "ROD", "SLIDER", C)
    s.joint("D", "BASE", "SLIDER", (0.0, 0.0, 0.0), (1.0, 0.0, 0.0), kind="prismatic",
            ref=(0.0, 1.0, 0.0), origin2=C)
    s.add_mass("CRANK", 1.0, 0.5 * B, np.diag([0.1, 0.1, 0.1]))
    s.add_mass("ROD", 1.0, 0.5 * (B + C), np.diag([0.3, 0.3, 0.3]))
    s.add_mass("SLIDER", 1.0, C, np.diag([0.1, 0.1, 0.1]))
    s.set_gravity((0.0, -G, 0.0))
    return s


def shrinking_pendulum(r0: float = 0.5) -> Spec:
    """Revolute A (BASE -> ARM, massless) and prismatic P (ARM -> BOB along the arm, -y
    at the modeling posture, P.s the distance r of the bob from the pivot) carrying a
    point bob: the mass matrix of A is m r^2, singular when P's drive brings r to 0."""
    s = Spec(openimp.Model("shrinking pendulum"))
    s.joint("A", "BASE", "ARM", (0.0, 0.0, 0.0))
    s.joint("P", "ARM", "BOB", (0.0, 0.0, 0.0), (0.0, -1.0, 0.0), kind="prismatic",
            ref=(1.0, 0.0, 0.0), origin2=(0.0, -r0, 0.0))
    point_mass(s, "BOB", 1.0, (0.0, -r0, 0.0))
    s.set_gravity((0.0, -G, 0.0))
    return s
