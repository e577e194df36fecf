"""Force analysis of a prescribed motion (book ch 9, 10, 11.14, 17): driving forces, joint
reactions, element forces, energies and powers, each checked against a reference written
here in plain numpy.

The references use only the motion (the trajectory's joint variables, body postures
and velocity / acceleration screws, point positions and velocities: kinematic outputs
tested in the kinematics tests) and the data the test itself gave the model:

* Newton-Euler balance of every moving body at every step: the joint reactions, the
  applied loads (gravity, point springs and dampers, forces, torques) and nothing else
  add up to m a_c and to I_c alpha + w x I_c w about the centre of mass;
* the 1-DOF Lagrange form tau = M theta'' + 1/2 M' theta'^2 + V' with M from the
  kinetic energy of the body velocities and M', V' by finite differences;
* book example 17.1 (Hooke coupling, torque at the input joint);
* potential and kinetic energy, generalized forces = gradients of the potential,
  the balance of power dT/dt = sum of the powers of the drives and the loads.

Conventions (DESIGN.md, ``Forces``): the reaction of joint h is the load of its first
body on its second, forces along and moments about the axes of the joint frame on the
first body, moments about that frame's origin (``frame="global"``: the same on global
axes).  A statically indeterminate component is NaN.  The reaction is *everything the
joint transmits*: about the axis of a revolute it carries the joint's own spring,
damper and load and, on a driven joint, the drive (book 17.20 with the fictitious
rotation about w of the driven joint, whose bodies move as in a unit motion of the
coordinate: the book's example 17.1 computes the input torque exactly so).  So the
balance of a body counts the reactions of its joints and the loads applied to the body,
never the drive or the joint loads a second time.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import openimp
from helpers.geometry import cardan_example_51
from helpers.mechanics import Ref
from helpers.models import Spec, slider_crank_joints
from openimp.motion import Polynomial

DEG = math.pi / 180
G_EARTH = 9.81


# =============================================================================
# Plain-numpy helpers
# =============================================================================


def rot(axis, angle: float) -> np.ndarray:
    """3x3 rotation about ``axis`` by ``angle`` (Rodrigues)."""
    k = np.asarray(axis, float)
    k = k / np.linalg.norm(k)
    K = skew(k)
    return np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * K @ K


def skew(v) -> np.ndarray:
    v = np.asarray(v, float)
    return np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])


def inertia(p1: float, p2: float, p3: float, axis, angle: float) -> np.ndarray:
    """A physical centroidal inertia tensor (engineering sign): principal moments
    p1..p3 (triangle inequality holds) on axes turned by ``angle`` about ``axis``."""
    R = rot(axis, angle)
    return R @ np.diag([p1, p2, p3]) @ R.T


def circles(P, r: float, Q, s: float, left: bool = True) -> np.ndarray:
    """Intersection of the circles (P, r), (Q, s) in the XY plane, left of P->Q."""
    P, Q = np.asarray(P, float), np.asarray(Q, float)
    PQ = Q - P
    L = float(np.linalg.norm(PQ))
    x = (r * r - s * s + L * L) / (2 * L)
    h = math.sqrt(r * r - x * x)
    n = np.array([-PQ[1], PQ[0], 0.0]) / L
    return P + x * PQ / L + (h if left else -h) * n


def d1_central(f: np.ndarray, h: float) -> np.ndarray:
    """First derivative of samples f (uniform step h, along axis 0) at the interior
    points 2..n-3 by the fourth-order central difference
    (-f[k+2] + 8 f[k+1] - 8 f[k-1] + f[k-2]) / (12 h); truncation error
    h^4 / 30 |f^(5)|."""
    return (-f[4:] + 8 * f[3:-1] - 8 * f[1:-3] + f[:-4]) / (12 * h)


# =============================================================================
# Mechanisms
# =============================================================================

#: four-bar: crank a from A = (0, 0), coupler b, rocker c pinned at D = (d, 0); Grashof
#: crank-rocker (s + l = 4.2 < p + q = 5.5): the crank turns fully
FB = dict(a=1.0, b=3.0, c=2.5, d=3.2, th0=40 * DEG)


def fourbar(loads: bool = True) -> Spec:
    """Planar four-bar of spatial revolutes in the XY plane, joints A BASE->CRANK,
    B CRANK->COUPLER, C COUPLER->ROCKER, D ROCKER->BASE (D's first body is the rocker).

    Masses with centres off the link lines and inertias with products (so that the
    motion loads the bodies out of their plane too); gravity with a component along
    X; ``loads``: a point spring coupler -> ground, a damper rocker -> ground, a force
    on the coupler along a fixed direction and one along a body-fixed direction
    (between two coupler points), a torque on the rocker about a direction out of the
    plane, a spring and a damper in joint C, a load in joint B.
    """
    a, b, c, d, th0 = FB["a"], FB["b"], FB["c"], FB["d"], FB["th0"]
    A, D = np.zeros(3), np.array([d, 0.0, 0.0])
    B = a * np.array([math.cos(th0), math.sin(th0), 0.0])
    C = circles(B, b, D, c)
    s = Spec(openimp.Model("four-bar"))
    s.joint("A", "BASE", "CRANK", A)
    s.joint("B", "CRANK", "COUPLER", B)
    s.joint("C", "COUPLER", "ROCKER", C)
    s.joint("D", "ROCKER", "BASE", D)
    s.add_mass("CRANK", 2.0, 0.45 * B + [0.0, 0.05, 0.0],
               inertia(0.02, 0.15, 0.16, (1, 2, 3), 0.4))
    s.add_mass("COUPLER", 3.0, (B + C) / 2 + [0.1, 0.3, 0.02],
               inertia(0.05, 2.2, 2.24, (0.3, -1, 2), 1.1))
    s.add_mass("ROCKER", 1.5, (C + D) / 2 + [-0.1, 0.0, -0.03],
               inertia(0.03, 0.8, 0.82, (2, 1, 0.5), 0.7))
    s.set_gravity((1.2, -G_EARTH, 0.0))
    s.point("PB", "CRANK", B)
    s.point("PC", "COUPLER", C)
    s.point("P1", "COUPLER", (B + C) / 2 + [0.2, 0.6, 0.0])
    s.point("P2", "COUPLER", B + np.array([0.3, -0.4, 0.0]))
    s.point("PR", "ROCKER", 0.4 * C + 0.6 * D)
    s.point("G1", "BASE", (1.5, 4.0, 0.0))
    s.point("G2", "BASE", (4.5, -1.0, 0.0))
    if loads:
        s.spring("S", "P1", "G1", 300.0, 1.2)
        s.damper("K", "PR", "G2", 25.0)
        s.force("F", "P1", 40.0, (1.0, 0.5, 0.0))
        s.force("FB", "P2", -15.0, ("P2", "P1"))
        s.torque("TR", "ROCKER", 12.0, (0.2, -0.1, 1.0))
        s.joint_spring("C", 80.0, 0.3)
        s.joint_damper("C", 4.0)
        s.joint_force("B", 7.5)
    return s


def arm(loads: bool = True) -> Spec:
    """Spatial 3R open chain BASE -J1-> L1 -J2-> L2 -J3-> L3 on skew axes: every joint
    reaction is determinate.  Gravity along -Z; ``loads``: a spring from the tip of L3
    to the ground, a damper L2 -> ground, a force on L3 from a point of L2 toward a
    point of L3, a torque on L2 about a fixed direction and one on L3 about a
    body-fixed direction, a spring, a damper and a load in J2, a load in J3."""
    s = Spec(openimp.Model("3R arm"))
    o1, o2, o3 = np.zeros(3), np.array([0.3, 0.0, 0.5]), np.array([0.9, 0.2, 0.6])
    s.joint("J1", "BASE", "L1", o1, (0.0, 0.0, 1.0))
    s.joint("J2", "L1", "L2", o2, (0.0, 1.0, 0.2))
    s.joint("J3", "L2", "L3", o3, (1.0, 0.3, -0.4))
    s.add_mass("L1", 4.0, (0.1, 0.05, 0.3), inertia(0.05, 0.12, 0.14, (1, 0, 1), 0.3))
    s.add_mass("L2", 2.5, (0.6, 0.15, 0.55), inertia(0.01, 0.2, 0.2, (0.2, 1, 0.1), 0.9))
    s.add_mass("L3", 1.2, (1.3, 0.35, 0.5), inertia(0.02, 0.09, 0.1, (1, -1, 0.4), 1.7))
    s.set_gravity((0.0, 0.0, -G_EARTH))
    s.point("TIP", "L3", (1.6, 0.4, 0.45))
    s.point("Q3", "L3", (1.1, 0.2, 0.7))
    s.point("Q2", "L2", (0.5, 0.1, 0.5))
    s.point("Q2b", "L2", (0.7, 0.3, 0.62))
    s.point("GA", "BASE", (1.0, 1.0, 1.5))
    s.point("GB", "BASE", (-0.5, 0.8, 0.2))
    if loads:
        s.spring("S", "TIP", "GA", 150.0, 0.6)
        s.damper("K", "Q2", "GB", 12.0)
        s.force("F", "Q3", 20.0, ("Q2b", "Q3"))
        s.torque("T2", "L2", 3.0, (1.0, -2.0, 0.5))
        s.torque("T3", "L3", -2.0, ("Q3", "TIP"))
        s.joint_spring("J2", 30.0, 0.2)
        s.joint_damper("J2", 1.5)
        s.joint_force("J2", -4.0)
        s.joint_force("J3", 2.5)
    return s


def slider_crank() -> Spec:
    """Offset slider-crank: crank a = 1 (A BASE->CRANK), rod b = 3.5 (B CRANK->ROD), pin
    C ROD->SLIDER, prismatic D BASE->SLIDER along X on the line y = e = 0.4; masses on
    the three links, gravity -Y, a spring in the slider joint and a point spring from
    the rod to the ground."""
    s, B, C = slider_crank_joints("slider-crank", 1.0, 3.5, 0.4, 30 * DEG)
    s.add_mass("CRANK", 1.5, 0.4 * B, inertia(0.01, 0.12, 0.13, (0, 0, 1), 0.2))
    s.add_mass("ROD", 2.0, 0.6 * B + 0.4 * C + [0.0, 0.1, 0.0],
               inertia(0.02, 2.0, 2.02, (0.1, 0.2, 1), 0.3))
    s.add_mass("SLIDER", 3.0, C + np.array([0.1, 0.05, 0.0]),
               inertia(0.01, 0.02, 0.025, (1, 1, 1), 0.5))
    s.set_gravity((0.0, -G_EARTH, 0.0))
    s.point("R", "ROD", 0.5 * (B + C) + [0.0, 0.3, 0.0])
    s.point("G", "BASE", (1.0, 2.5, 0.0))
    s.spring("S", "R", "G", 120.0, 1.5)
    s.joint_spring("D", 60.0, 3.9)
    return s


def rscr() -> Spec:
    """Spatial four-bar R-S-C-R: crank A BASE->CRANK (axis Z), ball B CRANK->COUPLER,
    cylinder C COUPLER->ROCKER on a skew axis, revolute D ROCKER->BASE on another skew
    axis.  Constraints 5 + 3 + 4 + 5 = 17 = 6 x 3 - 1: mobility 1 with no redundant
    constraint, so every reaction component is determinate.  Masses, gravity off every
    axis, a point spring, a damper, a force and a torque off the axes, a spring and a
    damper in D and a load in the driven joint A."""
    s = Spec(openimp.Model("RSCR"))
    B = np.array([math.cos(0.5), math.sin(0.5), 0.0])
    C, D = np.array([2.6, 2.2, 0.1]), np.array([3.0, 0.5, 0.3])
    s.joint("A", "BASE", "CRANK", np.zeros(3))
    s.joint("B", "CRANK", "COUPLER", B, kind="sphere")
    s.joint("C", "COUPLER", "ROCKER", C, (0.2, -0.3, 1.0), kind="cylinder")
    s.joint("D", "ROCKER", "BASE", D, (0.3, 0.2, 1.0))
    s.add_mass("CRANK", 2.0, 0.5 * B + [0.0, 0.1, 0.05], inertia(0.02, 0.15, 0.16, (1, 2, 3),
                                                                  0.4))
    s.add_mass("COUPLER", 3.0, (B + C) / 2 + [0.1, 0.2, 0.1],
               inertia(0.05, 2.2, 2.24, (0.3, -1, 2), 1.1))
    s.add_mass("ROCKER", 1.5, (C + D) / 2 + [0.0, 0.1, -0.1],
               inertia(0.03, 0.8, 0.82, (2, 1, 0.5), 0.7))
    s.set_gravity((0.5, -G_EARTH, -1.0))
    s.point("P1", "COUPLER", (B + C) / 2 + [0.2, 0.5, 0.3])
    s.point("PR", "ROCKER", (C + D) / 2 + [0.1, 0.0, 0.2])
    s.point("G1", "BASE", (1.5, 4.0, 1.0))
    s.point("G2", "BASE", (4.5, -1.0, 0.0))
    s.spring("S", "P1", "G1", 300.0, 1.2)
    s.damper("K", "PR", "G2", 25.0)
    s.force("F", "P1", 40.0, (1.0, 0.5, -0.7))
    s.torque("TR", "ROCKER", 12.0, (0.2, -0.1, 1.0))
    s.joint_spring("D", 80.0, 0.3)
    s.joint_damper("D", 4.0)
    s.joint_force("A", 5.0)
    return s


def crank_motion(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Crank angles over a full turn with rates and accelerations that vary from step
    to step (each step is an independent state for the balance of forces)."""
    th = np.linspace(0.0, 2 * math.pi, n)
    return th, 2.0 + np.sin(th), 3.0 * np.cos(2 * th) - 1.0


def arm_motion(n: int) -> tuple[dict, dict, dict]:
    x = np.linspace(0.0, 1.0, n)
    q = {"J1": 0.2 + 2.0 * x, "J2": -0.3 + 1.5 * x, "J3": 0.5 - 2.5 * x}
    qd = {"J1": 1.0 + x, "J2": -2.0 + x * x, "J3": 0.5 * np.cos(3 * x)}
    qdd = {"J1": 2.0 * x, "J2": np.full(n, -1.0), "J3": 4.0 * x - 1.0}
    return q, qd, qdd


# =============================================================================
# 1, 6. Newton-Euler balance of every moving body at every step
# =============================================================================

#: relative tolerance of every balance: the residual against the largest force (or
#: moment) term of the body; the sums are of O(10) terms, exact up to round-off
NE_TOL = 1e-9

#: (builder, moving bodies, balanced components: all six, or the in-plane Fx, Fy, Mz)
NE_CASES = {
    "planar four-bar": (fourbar, ("CRANK", "COUPLER", "ROCKER"), "plane"),
    "slider-crank": (slider_crank, ("CRANK", "ROD", "SLIDER"), "plane"),
    "spatial RSCR": (rscr, ("CRANK", "COUPLER", "ROCKER"), "all"),
    "3R arm": (arm, ("L1", "L2", "L3"), "all"),
}


def _sweep_case(name: str, n: int = 60, rates: bool = True):
    build, bodies, comps = NE_CASES[name]
    s = build()
    sy = s.compile()
    if name == "3R arm":
        q, qd, qdd = arm_motion(n)
    else:
        th, w, al = crank_motion(n)
        q, qd, qdd = {"A": th}, {"A": w}, {"A": al}
    tr = openimp.sweep(sy, q, rates=qd, accels=qdd) if rates else openimp.sweep(sy, q)
    assert tr.complete, tr.message
    return s, tr, bodies, comps


@pytest.mark.parametrize("rates", [True, False], ids=["dynamic", "quasi-static"])
@pytest.mark.parametrize("name", list(NE_CASES))
def test_newton_euler_balance_of_every_body(name, rates):
    """Every moving body at every one of 60 steps: the reactions of its joints (global
    axes, moments about the joint frame origin on the first body, +on the second body,
    -on the first) plus gravity, point springs and dampers, forces and torques equal
    m a_c and I_c alpha + w x I_c w about the centre.  Planar mechanisms of spatial
    revolutes: the in-plane components (Fx, Fy, Mz), which are the determinate ones;
    the RSCR and the 3R arm: all six.  Quasi-static: the same with no inertia and no
    damper forces.  Tolerance NE_TOL relative to the largest term of the body."""
    s, tr, bodies, comps = _sweep_case(name, rates=rates)
    F = openimp.forces_of(tr)
    ref = Ref(s, tr)
    for b in bodies:
        fres, mres, sf, sm = ref.balance(F, b)
        if comps == "plane":
            fres, mres = fres[:, :2], mres[:, 2:]
        assert np.all(np.isfinite(fres)) and np.all(np.isfinite(mres)), b
        assert np.max(np.abs(fres)) <= NE_TOL * sf, (b, np.max(np.abs(fres)) / sf)
        assert np.max(np.abs(mres)) <= NE_TOL * sm, (b, np.max(np.abs(mres)) / sm)
    if comps == "all":  # every component of every joint is determinate
        for j in s.model.joints:
            assert F.determinate(j).all(), j


def test_planar_fourbar_out_of_plane_components_are_indeterminate():
    """A planar four-bar of spatial revolutes has three redundant constraints (the
    loop's translation along Z and rotations about X and Y): at every joint and step
    Fw, Mu, Mv are NaN and determinate() is False for exactly them; Fu, Fv, Mw are
    numbers (their values are checked by the balance above).  On global axes the
    unknown components make Fz, Mx, My unknown and leave Fx, Fy, Mz (the joint axes
    are along Z); on the second body's axes likewise."""
    _, tr, _, _ = _sweep_case("planar four-bar", n=30)
    F = openimp.forces_of(tr)
    want = np.array([True, True, False, False, False, True])
    for j in "ABCD":
        assert np.array_equal(F.determinate(j), np.tile(want, (tr.nsteps, 1))), j
        R = F.reaction(j)
        assert np.all(np.isnan(R[:, ~want])) and np.all(np.isfinite(R[:, want])), j
        for frame in ("global", "second"):
            Rg = F.reaction(j, frame)
            assert np.array_equal(np.isfinite(Rg), np.tile(want, (tr.nsteps, 1))), (j, frame)
    table = F.to_table()
    assert np.all(np.isnan(table["A Fw"])) and np.all(np.isfinite(table["A Mw"]))


def test_revolute_axis_moment_is_drive_plus_joint_load_and_free_directions_carry_nothing():
    """What a joint transmits along its own freedoms: about the axis of the driven
    revolute A the drive (plus A's own load), about a revolute with a spring, a damper
    or a load exactly that joint load (+ on the second body: a load that tends to
    increase the variable), along a freedom with no load zero: the ball's three
    moments, the cylinder's slide force and moment.  RSCR with rates, 60 steps;
    tolerance 1e-12 of the largest drive."""
    s, tr, _, _ = _sweep_case("spatial RSCR")
    F = openimp.forces_of(tr)
    tau = F.drive["A.theta"]
    tol = 1e-12 * np.max(np.abs(tau))
    k, q0 = s.jsprings["D"]
    qD, wD = tr.variable("D"), tr.qd[:, tr.system.var_index("D")]
    np.testing.assert_allclose(F.reaction("A")[:, 5], tau + s.jforces["A"], rtol=0, atol=tol)
    np.testing.assert_allclose(F.reaction("D")[:, 5], -k * (qD - q0) - s.jdampers["D"] * wD,
                               rtol=0, atol=tol)
    np.testing.assert_allclose(F.reaction("B")[:, 3:], 0.0, rtol=0, atol=tol)
    np.testing.assert_allclose(F.reaction("C")[:, [2, 5]], 0.0, rtol=0, atol=tol)


def test_reaction_frames():
    """frame="global" turns the joint-frame components by the axes of the joint frame on
    the first body A1 = T_0,first S1; frame="second" gives them on the axes of the frame
    on the second body A2, moments moved to its origin: M2 = M1 + (o1 - o2) x F.  The
    prismatic D of the slider-crank, whose two frame origins differ (the slider's at
    the pin C, the ground's on the slide line at x = 0); 1e-12 relative."""
    s, tr, _, _ = _sweep_case("slider-crank", n=20)
    F = openimp.forces_of(tr)
    J = s.model.joints["D"]
    ref = Ref(s, tr)
    A1 = ref.moved(J.body1) @ J.frame1
    A2 = ref.moved(J.body2) @ J.frame2
    R = F.reaction("D")
    ok = np.isfinite(R)
    R0 = np.where(ok, R, 0.0)
    f1 = np.einsum("nij,nj->ni", A1[:, :3, :3], R0[:, :3])
    m1 = np.einsum("nij,nj->ni", A1[:, :3, :3], R0[:, 3:])
    m2 = m1 + np.cross(A1[:, :3, 3] - A2[:, :3, 3], f1)
    f2 = np.einsum("nji,nj->ni", A2[:, :3, :3], f1)
    m2 = np.einsum("nji,nj->ni", A2[:, :3, :3], m2)
    scale = np.nanmax(np.abs(R))
    for frame, want in (("global", np.c_[f1, m1]), ("second", np.c_[f2, m2])):
        got = F.reaction("D", frame)
        fin = np.isfinite(got)
        assert fin.any(axis=0).sum() >= 3, frame  # the in-plane components
        np.testing.assert_allclose(got[fin], want[fin], rtol=0, atol=1e-12 * scale)


# =============================================================================
# 2. The drive of a 1-DOF mechanism against Lagrange's equation
# =============================================================================

#: crank step of the finite differences (deg): the fourth-order central difference
#: has truncation error h^4/30 |f^(5)|; observed 4e-10 of the largest drive at 0.25 deg,
#: 6e-9 at 0.5 deg, 9e-8 at 1 deg (the h^4 law), so the tolerance below holds a factor 5
LAGRANGE_STEP = 0.25
LAGRANGE_TOL = 2e-9


def _conservative_fourbar() -> Spec:
    s = fourbar(loads=False)
    s.spring("S", "P1", "G1", 300.0, 1.2)
    s.joint_spring("C", 80.0, 0.3)
    return s


@pytest.mark.parametrize("build", [_conservative_fourbar, slider_crank],
                         ids=["four-bar", "slider-crank"])
def test_drive_is_lagrange_of_one_dof(build):
    """Crank driven through a full turn at theta' = 2.5, theta'' = -4 (0.25 deg steps).

    Reference: tau = M(theta) theta'' + 1/2 M'(theta) theta'^2 + V'(theta), with
    M = 2 T / theta'^2 and T = sum 1/2 m |v_c|^2 + 1/2 w . I_c w from the body
    velocity screws, V = -sum m g . c + the point and joint springs' energies, M' and
    V' by fourth-order central differences along the sweep (interior steps).  The
    four-bar carries gravity, a point spring and a spring in the passive joint C; the
    slider-crank gravity, a point spring and a spring in the slider joint D."""
    s = build()
    h = LAGRANGE_STEP * DEG
    th = np.arange(0.0, 360.0 + LAGRANGE_STEP / 2, LAGRANGE_STEP) * DEG
    w, al = 2.5, -4.0
    tr = openimp.sweep(s.compile(), {"A": th}, rates={"A": w}, accels={"A": al})
    assert tr.complete, tr.message
    F = openimp.forces_of(tr)
    ref = Ref(s, tr)
    M = 2.0 * ref.kinetic() / w**2
    V = ref.potential()
    tau = M[2:-2] * al + 0.5 * d1_central(M, h) * w * w + d1_central(V, h)
    got = F.drive["A.theta"][2:-2]
    assert np.max(np.abs(got - tau)) <= LAGRANGE_TOL * np.max(np.abs(tau))


# =============================================================================
# 3. Book example 17.1: the Hooke coupling, torque at the input joint
# =============================================================================


def Rz(t: float) -> np.ndarray:
    c, s = math.cos(t), math.sin(t)
    return np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]])


def test_hooke_coupling_book_example_17_1():
    """Book example 17.1 (digest 8.1): beta = 150 deg, d1 = d2 = 1, h = 0.5, the joints
    and shape matrices of example 5.1 (the loop A 4->1, B 1->2, C 2->3, D 3->4; body 4
    the frame, psi = phi_D the input), a static load torque P_A = 3 in the output joint
    A (set_joint_force: + tends to increase phi_A, i.e. counter-clockwise about w_A on
    body 1).  Quasi-static sweep of psi over a full turn in 5 deg steps.

    Reference: F_D^theta_w = cos(beta) / (1 - sin^2 beta sin^2 psi) P_A, the moment
    about w_D of body 3 (D's first body) on body 4 (its second), the book's sign
    (17.20: by Delta- on Delta+), which is also openimp's reaction convention (first
    body on second); it is the drive of the coordinate psi as well (the torque that
    tends to increase phi_D: static virtual work tau dpsi + P_A dphi_A = 0 with
    phi'_A = -cos beta / (1 - sin^2 beta sin^2 psi)).  The other five components at D
    are statically indeterminate (17.18): NaN.  Tolerance 1e-10 relative.
    """
    beta, d1, d2, h, PA = 150 * DEG, 1.0, 1.0, 0.5, 3.0
    S = cardan_example_51(beta, d1, d2, h)

    def T(joint, b1, b2, phi):
        return S[(b1, joint)] @ Rz(phi) @ np.linalg.inv(S[(b2, joint)])

    psi0 = 0.7
    pa = math.atan2(-math.sin(psi0) * math.cos(beta), math.cos(psi0))
    pb = -math.acos(math.sin(psi0) * math.sin(beta))
    pc = math.atan2(1.0, math.cos(psi0) * math.tan(beta))
    T0 = {"4": np.eye(4)}
    T0["1"] = T("A", "4", "1", pa)
    T0["2"] = T0["1"] @ T("B", "1", "2", pb)
    T0["3"] = T0["2"] @ T("C", "2", "3", pc)
    assert np.max(np.abs(T0["3"] @ T("D", "3", "4", psi0) - np.eye(4))) < 1e-12
    m = openimp.Model("cardan", ground="4")
    for jn, b1, b2 in (("A", "4", "1"), ("B", "1", "2"), ("C", "2", "3"), ("D", "3", "4")):
        m.add_joint("revolute", jn, b1, b2, frame1=T0[b1] @ S[(b1, jn)],
                    frame2=T0[b2] @ S[(b2, jn)])
    for b in ("1", "2", "3"):
        m.set_body_frame(b, T0[b])
    m.set_joint_force("A", PA)
    sy = openimp.compile(m)
    psi = psi0 + np.radians(np.arange(0.0, 360.0, 5.0))
    tr = openimp.sweep(sy, {"D": psi})
    assert tr.complete, tr.message
    F = openimp.forces_of(tr)
    want = math.cos(beta) / (1.0 - math.sin(beta) ** 2 * np.sin(psi) ** 2) * PA
    np.testing.assert_allclose(F.reaction("D")[:, 5], want, rtol=1e-10, atol=0)
    np.testing.assert_allclose(F.drive["D.theta"], want, rtol=1e-10, atol=0)
    mask = np.tile([False, False, False, False, False, True], (tr.nsteps, 1))
    assert np.array_equal(F.determinate("D"), mask)
    assert np.all(np.isnan(F.reaction("D")[:, :5]))
    # the output joint transmits its own load about its axis
    np.testing.assert_allclose(F.reaction("A")[:, 5], PA, rtol=1e-10, atol=0)


# =============================================================================
# 4. Energies, mass matrix, generalized forces as gradients of the potential
# =============================================================================


def test_energies_along_a_sweep():
    """F.kinetic = sum 1/2 m |v_c|^2 + 1/2 w . I_c w from the body velocities and
    F.potential = -sum m g . c + 1/2 k (l - l0)^2 + 1/2 k (q - q0)^2 (the potential of
    gravity about the global origin, of the point springs and of the joint springs),
    at every step of the RSCR and of the 3R arm with every load; 1e-12 relative."""
    for name in ("spatial RSCR", "3R arm"):
        s, tr, _, _ = _sweep_case(name, n=40)
        F = openimp.forces_of(tr, reactions=False)
        ref = Ref(s, tr)
        T, V = ref.kinetic(), ref.potential()
        np.testing.assert_allclose(F.kinetic, T, rtol=0, atol=1e-12 * np.max(T))
        np.testing.assert_allclose(F.potential, V, rtol=0, atol=1e-12 * np.max(np.abs(V)))


def test_mass_matrix_of_the_arm_from_its_kinetic_energy():
    """The drives of the 3R arm at rest (q' = 0) with q'' = e_j and no gravity or load
    are column j of the mass matrix; the reference M_ij = sum_b m v_c,i . v_c,j +
    w_i . I_c w_j, the Hessian of the kinetic energy in the rates, from the body
    velocities of unit rates q' = e_i (the kinematics' velocity screws).  30 postures;
    1e-12 relative."""
    s = arm(loads=False)
    s.set_gravity((0.0, 0.0, 0.0))
    sy = s.compile()
    q, _, _ = arm_motion(30)
    keys = ("J1", "J2", "J3")
    zero = {k: 0.0 for k in keys}
    vel = []  # per unit rate: {body: (v_c (n, 3), w (n, 3))}
    cols = []
    for j in keys:
        unit = {k: float(k == j) for k in keys}
        tr = openimp.sweep(sy, q, rates=unit, accels=zero)
        ref = Ref(s, tr)
        vel.append({b: (ref.centre(b)[1], tr.velocity_screw(b)[:, 3:]) for b in s.mass})
        tr = openimp.sweep(sy, q, rates=zero, accels=unit)
        F = openimp.forces_of(tr, reactions=False)
        cols.append(np.stack([F.drive[f"{k}.theta"] for k in keys], axis=1))
    Ic = {b: Ref(s, tr).inertia(b) for b in s.mass}
    M = np.zeros((tr.nsteps, 3, 3))
    for i in range(3):
        for j in range(3):
            for b, (m, _, _) in s.mass.items():
                vi, wi = vel[i][b]
                vj, wj = vel[j][b]
                M[:, i, j] += m * np.sum(vi * vj, 1) + np.einsum("ni,nij,nj->n", wi, Ic[b], wj)
    got = np.stack(cols, axis=2)  # got[:, i, j] = drive i for q'' = e_j
    np.testing.assert_allclose(got, M, rtol=0, atol=1e-12 * np.max(np.abs(M)))
    np.testing.assert_allclose(got, np.swapaxes(got, 1, 2), rtol=0,
                               atol=1e-12 * np.max(np.abs(M)))


#: step of the quasi-static sweeps (deg) and tolerance of the fourth-order central
#: differences of the potential: truncation h^4/30 |V^(5)|, observed at most 2e-10 of the
#: largest drive at 0.125 deg (the arm's J1; 3e-9 at 0.25 deg, 5e-8 at 0.5 deg: the h^4
#: law, no floor from the posture solution)
STATIC_STEP = 0.125
STATIC_TOL = 1e-9


def test_quasi_static_drive_is_the_gradient_of_the_potential():
    """Quasi-static sweeps (no rates: no inertia, no damping) of mechanisms whose only
    loads have a potential: gravity, point springs and joint springs.  The drive of
    every generalized coordinate equals dV/dq (the static balance of virtual work:
    tau dq = dV), with V = F.potential and dV/dq by fourth-order central differences
    along a sweep of that coordinate alone (0.125 deg steps): the four-bar over a full
    turn, the slider-crank over a full turn, and each of the three coordinates of the
    3R arm over 40 deg with the others held.  Tolerance STATIC_TOL of the largest
    drive."""
    h = STATIC_STEP * DEG
    cases = []
    th = np.arange(0.0, 360.0 + STATIC_STEP / 2, STATIC_STEP) * DEG
    for s in (_conservative_fourbar(), slider_crank()):
        cases.append((s, {"A": th}, "A"))
    s = arm(loads=False)
    s.spring("S", "TIP", "GA", 150.0, 0.6)
    s.joint_spring("J2", 30.0, 0.2)
    q0 = {"J1": 0.3, "J2": -0.2, "J3": 0.4}
    x = np.arange(0.0, 40.0 + STATIC_STEP / 2, STATIC_STEP) * DEG
    for j in q0:
        cases.append((s, {k: (v + x if k == j else np.full_like(x, v)) for k, v in q0.items()},
                      j))
    for s, drivers, j in cases:
        tr = openimp.sweep(s.compile(), drivers)
        assert tr.complete, tr.message
        F = openimp.forces_of(tr, reactions=False)
        np.testing.assert_allclose(F.potential, Ref(s, tr).potential(), rtol=0,
                                   atol=1e-12 * np.max(np.abs(F.potential)))
        tau = F.drive[f"{j}.theta"][2:-2]
        dV = d1_central(F.potential, h)
        assert np.max(np.abs(tau - dV)) <= STATIC_TOL * np.max(np.abs(tau)), (
            s.model.name, j, np.max(np.abs(tau - dV)) / np.max(np.abs(tau)))


# =============================================================================
# 5. The balance of power
# =============================================================================

#: times of the motions: 0.5 s in 2.5 ms steps; dT/dt by fourth-order central
#: differences (truncation dt^4/30 |T^(5)|: observed <= 2.5e-9 of the largest power term,
#: 16 times less at half the step)
POWER_DT = 2.5e-3
POWER_TOL = 1e-8


def _power_reference(s: Spec, tr, F) -> dict:
    """The power of every load on the mechanism from the motion (n,) each: gravity
    sum m g . v_c, a spring or damper -T l' (tension T pulls its ends together), a
    force f d . v_P, a torque t d . w, a joint load (f - k (q - q0) - c q') q', the
    drives sum tau_j q'_j."""
    ref = Ref(s, tr)
    out = {"gravity": sum(m * ref.centre(b)[1] @ s.gravity for b, (m, _, _) in s.mass.items())}
    for name, p1, p2, k, l0 in s.springs:
        ln, rate, _ = ref.length(p1, p2)
        out[name] = -k * (ln - l0) * rate
    for name, p1, p2, c in s.dampers:
        rate = ref.length(p1, p2)[1]
        out[name] = -c * rate * rate
    for name, p, f, d in s.forces:
        out[name] = f * np.sum(ref.direction(d) * tr.point_velocity(p), 1)
    for name, b, t, d in s.torques:
        out[name] = t * np.sum(ref.direction(d) * tr.angular_velocity(b), 1)
    for j in set(s.jsprings) | set(s.jdampers) | set(s.jforces):
        q, qd = tr.variable(j), tr.qd[:, tr.system.var_index(j)]
        k, q0 = s.jsprings.get(j, (0.0, 0.0))
        load = s.jforces.get(j, 0.0) - k * (q - q0) - s.jdampers.get(j, 0.0) * qd
        out[f"joint {j}"] = load * qd
    out["drive"] = sum(F.drive[j] * tr.qd[:, tr.system.var_index(j)] for j in tr.drivers)
    return out


@pytest.mark.parametrize("name", ["planar four-bar", "spatial RSCR", "3R arm"])
def test_power_balance_along_a_motion_of_time(name):
    """A motion of time (polynomials with varying acceleration, 0.5 s in 2.5 ms steps)
    with every load.  Each entry of F.power against its plain-numpy power (1e-12 of the
    largest), the damper's power <= 0, and the balance of virtual power: the drives'
    power plus the power of every load = dT/dt, with T from the body velocities and its
    derivative by fourth-order central differences (POWER_TOL of the largest term)."""
    build = NE_CASES[name][0]
    s = build()
    sy = s.compile()
    times = np.arange(0.0, 0.5 + POWER_DT / 2, POWER_DT)
    if name == "3R arm":
        motion = {"J1": Polynomial([0.2, 1.5, -2.0, 3.0]), "J2": Polynomial([-0.3, -1.0, 4.0]),
                  "J3": Polynomial([0.5, 2.0, 0.0, -6.0])}
    else:
        motion = {"A": Polynomial([0.3, 3.0, 4.0, -5.0])}
    tr = openimp.sweep(sy, motion=motion, times=times)
    assert tr.complete, tr.message
    F = openimp.forces_of(tr, reactions=False)
    want = _power_reference(s, tr, F)
    assert set(F.power) == set(want)
    scale = max(float(np.max(np.abs(v))) for v in want.values())
    for key, v in want.items():
        np.testing.assert_allclose(F.power[key], v, rtol=0, atol=1e-12 * scale, err_msg=key)
    for name, *_ in s.dampers:
        assert np.all(F.power[name] <= 0.0) and np.any(F.power[name] < -1e-3 * scale), name
    total = sum(F.power.values())[2:-2]
    dT = d1_central(Ref(s, tr).kinetic(), POWER_DT)
    assert np.max(np.abs(total - dT)) <= POWER_TOL * scale, np.max(np.abs(total - dT)) / scale


# =============================================================================
# 7. Bad input
# =============================================================================


def _crank_model() -> openimp.Model:
    m = openimp.Model("crank")
    m.add_joint("revolute", "A", "BASE", "CRANK", origin=(0.0, 0.0, 0.0))
    m.add_point("P", "CRANK", (1.0, 0.0, 0.0))
    m.add_point("G", "BASE", (0.0, 2.0, 0.0))
    return m


@pytest.mark.parametrize("call, words", [
    (lambda m: m.add_mass("CRANK", -1.0), ["CRANK", "mass", "-1"]),
    (lambda m: m.add_mass("CRANK", float("nan")), ["CRANK", "mass"]),
    (lambda m: m.add_mass("NOBODY", 1.0), ["NOBODY", "does not exist"]),
    (lambda m: m.add_spring("S", "P", "P", 10.0), ["spring 'S'", "'P'", "two different"]),
    (lambda m: m.add_damper("K", "G", "G", 1.0), ["damper 'K'", "'G'", "two different"]),
    (lambda m: m.add_spring("S", "P", "G", 10.0, -1.0), ["spring 'S'", "free length"]),
    (lambda m: m.add_force("F", "P", 1.0, direction=(0, 0, 0)), ["force 'F'", "zero length"]),
    (lambda m: m.add_torque("T", "CRANK", 1.0, direction=(0, 0, 0)),
     ["torque 'T'", "zero length"]),
    (lambda m: m.add_force("F", "P", 1.0, along=("G", "G")), ["force 'F'", "'G'"]),
    (lambda m: m.add_spring("S", "P", "NOPE", 10.0), ["spring 'S'", "'NOPE'", "does not exist"]),
    (lambda m: m.add_damper("K", "NOPE", "G", 1.0), ["damper 'K'", "'NOPE'"]),
    (lambda m: m.add_force("F", "NOPE", 1.0, direction=(1, 0, 0)), ["force 'F'", "'NOPE'"]),
    (lambda m: m.add_force("F", "P", 1.0, along=("G", "NOPE")), ["force 'F'", "'NOPE'"]),
    (lambda m: m.add_torque("T", "NOBODY", 1.0, direction=(0, 0, 1)), ["torque 'T'", "NOBODY"]),
    (lambda m: m.add_force("F", "P", 1.0), ["force 'F'", "direction"]),
    (lambda m: m.add_spring("S", "P", "G", float("inf")), ["spring 'S'", "rate"]),
    (lambda m: m.set_joint_force("Z", 1.0), ["joint 'Z'", "no such joint"]),
    (lambda m: m.set_joint_spring("A", 1.0, var=3), ["joint 'A'", "no variable"]),
    (lambda m: m.add_spring("S", "P", "G", 1.0, law=3.0), ["spring 'S'", "law"]),
], ids=lambda x: None if callable(x) else "-".join(x[:1]))
def test_bad_input_is_an_input_error_naming_the_element(call, words):
    m = _crank_model()
    with pytest.raises(openimp.InputError) as exc:
        call(m)
    for w in words:
        assert w in str(exc.value), (w, str(exc.value))


def test_implausible_inertia_is_a_warning_kept_by_the_system():
    """Principal moments 1, 1, 5 about the centre break the triangle inequality
    I1 + I2 >= I3: add_mass accepts them (IMP uses such data as given) and returns a
    warning naming the body; the compiled System keeps it in its warnings; a
    physical inertia gives none."""
    m = _crank_model()
    assert m.add_mass("CRANK", 1.0, center=(0.5, 0, 0), inertia=(0.1, 0.2, 0.25)) == []
    m2 = _crank_model()
    warn = m2.add_mass("CRANK", 1.0, center=(0.5, 0, 0), inertia=(1.0, 1.0, 5.0))
    assert warn and "CRANK" in warn[0] and "triangle" in warn[0]
    assert openimp.compile(m).warnings == ()
    sw = openimp.compile(m2).warnings
    assert any("CRANK" in w and "triangle" in w for w in sw)


def _bad_law(s):
    if s.step == 3:
        raise ZeroDivisionError("boom")
    return 1.0


@pytest.mark.parametrize("add, words", [
    (lambda m: m.add_spring("S", "P", "G", law=_bad_law),
     ["spring 'S'", "step 3", "ZeroDivisionError", "boom"]),
    (lambda m: m.add_damper("K", "P", "G", law=lambda s: math.nan), ["damper 'K'", "nan"]),
    (lambda m: m.add_force("F", "P", direction=(0, 1, 0), law=lambda s: None), ["force 'F'"]),
    (lambda m: m.add_torque("T", "CRANK", direction=(0, 0, 1), law=lambda s: math.inf),
     ["torque 'T'", "inf"]),
    (lambda m: m.set_joint_spring("A", law=lambda s: 1 / 0), ["A", "ZeroDivisionError"]),
], ids=["raises", "nan", "None", "inf", "joint"])
def test_a_failing_law_is_an_input_error_at_forces_time(add, words):
    """A law is the user's function: when it raises or gives something that is not a
    finite number, forces() raises InputError naming the element (and the step and the
    exception where there is one), not a traceback from inside."""
    m = _crank_model()
    m.add_mass("CRANK", 1.0, center=(0.5, 0, 0))
    add(m)
    tr = openimp.sweep(openimp.compile(m), {"A": np.linspace(0.0, 1.0, 6)}, rates={"A": 1.0})
    with pytest.raises(openimp.InputError) as exc:
        openimp.forces_of(tr)
    for w in words:
        assert w in str(exc.value), (w, str(exc.value))


# =============================================================================
# 8. Element forces
# =============================================================================


def test_element_forces_from_the_lengths():
    """Four-bar with every load, 60 steps with rates: spring tension k (l - l0) with l
    from the point positions, damper tension c dl/dt with dl/dt = u . (v1 - v2) from
    the point velocities, force and torque magnitudes as given; 1e-12 relative."""
    s, tr, _, _ = _sweep_case("planar four-bar")
    F = openimp.forces_of(tr, reactions=False)
    ref = Ref(s, tr)
    (_, p1, p2, k, l0), = s.springs
    ln, rate, _ = ref.length(p1, p2)
    np.testing.assert_allclose(F.element("S"), k * (ln - l0), rtol=1e-12, atol=0)
    (_, p1, p2, c), = s.dampers
    rate = ref.length(p1, p2)[1]
    np.testing.assert_allclose(F.element("K"), c * rate, rtol=0,
                               atol=1e-12 * np.max(np.abs(c * rate)))
    for name, _, f, _ in s.forces + s.torques:
        np.testing.assert_allclose(F.element(name), f, rtol=1e-15)
    with pytest.raises(openimp.InputError, match="NOPE"):
        F.element("NOPE")
    assert F.messages == []


def test_element_with_coincident_ends_is_skipped_with_a_message():
    """A crank point P at radius 1 passes over the ground point G = (cos 30, sin 30) at
    crank angle 30 deg (step 6 of 0..60 deg in 5 deg steps): the spring and the damper
    between P and G have no direction there.  They are skipped at that step only: their
    element value is NaN there and finite elsewhere, F.messages names each with the
    step, and the drive there is the one of gravity alone, while elsewhere it balances
    the spring and the damper too (the drive computed by hand from the power)."""
    m = _crank_model()
    m.add_point("H", "BASE", (math.cos(30 * DEG), math.sin(30 * DEG), 0.0))
    m.add_mass("CRANK", 2.0, center=(0.5, 0.0, 0.0))
    m.set_gravity((0.0, -G_EARTH, 0.0))
    m.add_spring("S", "P", "H", 50.0, 0.2)
    m.add_damper("K", "P", "H", 3.0)
    th = np.radians(np.arange(0.0, 61.0, 5.0))
    w = 1.5
    tr = openimp.sweep(openimp.compile(m), {"A": th}, rates={"A": w}, accels={"A": 0.0})
    F = openimp.forces_of(tr)
    k = 6
    assert abs(th[k] - 30 * DEG) < 1e-15
    for name, kind in (("S", "spring"), ("K", "damper")):
        v = F.element(name)
        assert np.isnan(v[k]) and np.all(np.isfinite(np.delete(v, k))), name
        msg = [x for x in F.messages if x.startswith(f"{kind} {name}")]
        assert len(msg) == 1 and "coincide" in msg[0] and "step 6" in msg[0], F.messages
        assert F.element_skipped[k].all()
    # by hand: the centre c = 0.5 (cos th, sin th) turns at constant rate and radius, so
    # T is constant and the drive's power cancels the loads': tau w = m g 0.5 cos th w +
    # T_s l' + c l'^2, l = |P - H|, l' = u . v_P, P = (cos th, sin th), v_P = w P^perp
    P = np.c_[np.cos(th), np.sin(th)]
    d = P - [math.cos(30 * DEG), math.sin(30 * DEG)]
    ln = np.linalg.norm(d, axis=1)
    with np.errstate(invalid="ignore"):
        rate = np.sum(d / ln[:, None] * (w * np.c_[-P[:, 1], P[:, 0]]), 1)
    rate[k] = 0.0  # skipped: no spring, no damper
    want = 2.0 * G_EARTH * 0.5 * np.cos(th) + (50.0 * (ln - 0.2) + 3.0 * rate) * rate / w
    tau = F.drive["A.theta"]
    np.testing.assert_allclose(tau, want, rtol=0, atol=1e-12 * np.max(np.abs(want)))
    assert abs(tau[k] - 2.0 * G_EARTH * 0.5 * math.cos(th[k])) < 1e-12 * G_EARTH
    assert np.all(np.isfinite(tau)) and np.all(np.isfinite(F.reaction("A")[:, [0, 1, 5]]))
    assert np.all(F.power["S"][k] == 0.0) and np.all(F.power["K"][k] == 0.0)


# =============================================================================
# 9. Load laws
# =============================================================================


def test_piecewise_laws_match_their_linear_pieces():
    """A bump-stop spring given as a law: tension k1 (l - l0) below the stop length lb,
    k1 (l - l0) + k2 (l - lb) beyond it; and a joint spring in C with a stop:
    k (q - q0) + k' (q - qb) beyond qb.  Four-bar with masses and gravity, 60 steps
    with rates.  By hand, each step lies on one linear piece: the drive and the
    reactions equal those of the model with the linear spring of that piece (rate
    k1 + k2 and free length (k1 l0 + k2 lb) / (k1 + k2) beyond the stop); the element
    value is the law of the length from the point positions; the law sees the step, the
    length and its rate (and the joint variable) of the motion.  1e-12 relative."""
    k1, l0, k2, lb = 300.0, 1.2, 2000.0, 2.5  # the spring's length runs 1.73 .. 3.22
    kq, q0, kq2, qb = 80.0, 0.3, 500.0, 0.5  # C runs -0.13 .. 0.80 rad
    seen = []

    def bump(st):
        seen.append((st.step, st.length, st.rate))
        return k1 * (st.length - l0) + (k2 * (st.length - lb) if st.length > lb else 0.0)

    def stop(st):
        return kq * (st.x - q0) + (kq2 * (st.x - qb) if st.x > qb else 0.0)

    th, w, al = crank_motion(60)

    def run(spring, jspring):
        s = fourbar(loads=False)
        s.model.add_spring("S", "P1", "G1", *spring[:2], law=spring[2])
        s.model.set_joint_spring("C", *jspring[:2], law=jspring[2])
        tr = openimp.sweep(s.compile(), {"A": th}, rates={"A": w}, accels={"A": al})
        return s, tr, openimp.forces_of(tr)

    s, tr, F = run((0.0, None, bump), (0.0, None, stop))
    ref = Ref(s, tr)
    ln, rate, _ = ref.length("P1", "G1")
    qC = tr.variable("C")
    assert np.any(ln > lb) and np.any(ln < lb) and np.any(qC > qb) and np.any(qC < qb)
    assert [x[0] for x in seen] == list(range(tr.nsteps))
    np.testing.assert_allclose([x[1] for x in seen], ln, rtol=1e-13)
    np.testing.assert_allclose([x[2] for x in seen], rate, rtol=0,
                               atol=1e-13 * np.max(np.abs(rate)))
    want = k1 * (ln - l0) + np.where(ln > lb, k2 * (ln - lb), 0.0)
    np.testing.assert_allclose(F.element("S"), want, rtol=1e-13)
    pieces = {}
    for hi_s in (False, True):
        for hi_q in (False, True):
            sp = (k1 + k2, (k1 * l0 + k2 * lb) / (k1 + k2)) if hi_s else (k1, l0)
            jp = (kq + kq2, (kq * q0 + kq2 * qb) / (kq + kq2)) if hi_q else (kq, q0)
            pieces[hi_s, hi_q] = run((*sp, None), (*jp, None))[2]
    tau = F.drive["A.theta"]
    scale = np.max(np.abs(tau))
    for k in range(tr.nsteps):
        P = pieces[bool(ln[k] > lb), bool(qC[k] > qb)]
        assert abs(tau[k] - P.drive["A.theta"][k]) <= 1e-12 * scale, k
        for j in "ABCD":
            a, b = F.reaction(j)[k], P.reaction(j)[k]
            np.testing.assert_allclose(a[np.isfinite(a)], b[np.isfinite(b)], rtol=0,
                                       atol=1e-12 * scale)


def test_laws_of_time_and_of_joint_variables():
    """A torque law reading a joint variable (s.var) and a force law of time (s.t) along
    a motion of time: the element values are the laws of the motion, and the joint load
    law in B (a function of its own rate, s.xd) shows in B's reaction about its axis.
    Four-bar, 0.5 s in 10 ms steps; 1e-13 relative."""
    s = fourbar(loads=False)
    s.model.add_torque("T", "ROCKER", direction=(0, 0, 1), law=lambda st: 3.0 * st.var("D"))
    s.model.add_force("F", "P1", direction=(1, 0, 0), law=lambda st: 10.0 * math.sin(4 * st.t))
    s.model.set_joint_force("B", law=lambda st: -0.7 * st.xd)
    times = np.arange(0.0, 0.5 + 5e-3, 1e-2)
    tr = openimp.sweep(s.compile(), motion={"A": Polynomial([0.3, 3.0, 4.0])}, times=times)
    F = openimp.forces_of(tr)
    np.testing.assert_allclose(F.element("T"), 3.0 * tr.variable("D"), rtol=1e-13)
    np.testing.assert_allclose(F.element("F"), 10.0 * np.sin(4 * times), rtol=0, atol=1e-13)
    wB = tr.qd[:, tr.system.var_index("B")]
    np.testing.assert_allclose(F.reaction("B")[:, 5], -0.7 * wB, rtol=0,
                               atol=1e-13 * np.max(np.abs(wB)))


# =============================================================================
# One pass: forces(system, drivers, ...) evaluates every step as the sweep solves it
# =============================================================================


@pytest.mark.parametrize("name", list(NE_CASES))
def test_one_pass_balances_every_body_and_equals_two_passes(name):
    """forces(system, drivers, rates=, accels=) solves the sweep and evaluates each step
    from the same elimination: every body balances (NE_TOL, as above, against its own
    trajectory), and the results equal forces() of the same sweep solved first, to
    the posture tolerance (1e-10 internal units: 1e-8 relative)."""
    s, tr, bodies, comps = _sweep_case(name)
    sy = tr.system
    if name == "3R arm":
        q, qd, qdd = arm_motion(60)
    else:
        th, w, al = crank_motion(60)
        q, qd, qdd = {"A": th}, {"A": w}, {"A": al}
    F1 = openimp.forces(sy, q, rates=qd, accels=qdd)
    assert F1.trajectory.complete and F1.nsteps == 60
    ref = Ref(s, F1.trajectory)
    for b in bodies:
        fres, mres, sf, sm = ref.balance(F1, b)
        if comps == "plane":
            fres, mres = fres[:, :2], mres[:, 2:]
        assert np.max(np.abs(fres)) <= NE_TOL * sf, (b, np.max(np.abs(fres)) / sf)
        assert np.max(np.abs(mres)) <= NE_TOL * sm, (b, np.max(np.abs(mres)) / sm)
    F2 = openimp.forces_of(tr)
    for key, v in F2.drive.items():
        np.testing.assert_allclose(F1.drive[key], v, rtol=0, atol=1e-8 * np.abs(v).max())
    for j in sy.joints:
        a, b = F1.reaction(j), F2.reaction(j)
        assert np.array_equal(np.isnan(a), np.isnan(b)), j
        np.testing.assert_allclose(np.nan_to_num(a), np.nan_to_num(b), rtol=0,
                                   atol=1e-8 * np.nanmax(np.abs(b)))
    np.testing.assert_allclose(F1.kinetic, F2.kinetic, rtol=1e-8)


def test_one_pass_quasi_static_and_with_laws():
    """Without rates the one-pass analysis is quasi-static (zero rates); a model with a
    load law is solved first and evaluated after (the law reads the solved motion):
    both equal the two-pass results."""
    s = fourbar()
    sy = s.compile()
    th = np.linspace(0.1, 2.0, 25)
    F1 = openimp.forces(sy, {"A": th})
    F2 = openimp.forces_of(openimp.sweep(sy, {"A": th}))
    np.testing.assert_allclose(F1.drive["A.theta"], F2.drive["A.theta"], rtol=0,
                               atol=1e-8 * np.abs(F2.drive["A.theta"]).max())
    assert np.all(F1.kinetic == 0.0)
    m = s.model
    m.add_spring("LAWSPRING", *s.springs[0][1:3], law=lambda st: 3.0 * st.length ** 2)
    sy2 = openimp.compile(m)
    F3 = openimp.forces(sy2, {"A": th}, rates={"A": 1.0})
    F4 = openimp.forces_of(openimp.sweep(sy2, {"A": th}, rates={"A": 1.0}))
    np.testing.assert_allclose(F3.drive["A.theta"], F4.drive["A.theta"], rtol=1e-12)
    L = np.linalg.norm(F3.trajectory.point(s.springs[0][1])
                       - F3.trajectory.point(s.springs[0][2]), axis=1)
    np.testing.assert_allclose(F3.element("LAWSPRING"), 3.0 * L**2, rtol=1e-12)
    with pytest.raises(openimp.InputError, match="takes no drivers"):
        openimp.forces(F4.trajectory, {"A": th})


def test_open_chain_fully_driven_needs_no_sweep():
    """A model without loops whose every joint variable is driven has nothing to solve:
    forces(system, ...) evaluates the given motion directly; the same forces as the
    sweep followed by forces(), to round-off (the postures are the given values)."""
    s = arm()
    sy = s.compile()
    q, qd, qdd = arm_motion(40)
    F1 = openimp.forces(sy, q, rates=qd, accels=qdd)
    tr = openimp.sweep(sy, q, rates=qd, accels=qdd)
    F2 = openimp.forces_of(tr)
    for key, v in F2.drive.items():
        np.testing.assert_allclose(F1.drive[key], v, rtol=0, atol=1e-12 * np.abs(v).max())
    for j in sy.joints:
        np.testing.assert_allclose(F1.reaction(j), F2.reaction(j), rtol=0,
                                   atol=1e-12 * np.abs(F2.reaction(j)).max())
    np.testing.assert_allclose(F1.trajectory.q, tr.q, atol=1e-14)
    np.testing.assert_allclose(F1.trajectory.point_velocity(next(iter(s.points))),
                               tr.point_velocity(next(iter(s.points))), atol=1e-12)
    ref = Ref(s, F1.trajectory)
    for b in ("L1", "L2", "L3"):
        fres, mres, sf, sm = ref.balance(F1, b)
        assert np.max(np.abs(fres)) <= NE_TOL * sf and np.max(np.abs(mres)) <= NE_TOL * sm
