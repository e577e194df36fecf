"""openimp's mass matrix and joint reactions against the book-notation oracles of
tests/reference/book.py (plain numpy, no openimp inside).

Three mechanisms are built through the Python API (a planar four-bar, a spatial 3R open
chain, an offset slider-crank).  The oracles are fed only what this file gave the
model and its own closed-form geometry: the postures T_0b(psi) of the bodies (each
body frame taken as the global frame at the modeling posture, so T_0b is the motion
from there and J_b the pseudo-inertia of the masses as given), the joint frames as
placed (``model.joints[h].frame1``, global at the modeling posture, carried by the
first body), the loop and path matrices of the sketch, the loads.

* M (11.7) with W_bj by fourth-order central differences of the closed-form postures
  (7.21), against ``dynamics.eom.equations``; and the W_bj of (7.20) from the oracle's
  own loop equations against the same differences (the oracle checks itself);
* every reaction component (17.20) with T''_0b by central differences along the
  motion (8.55), indeterminate components by (17.18), against ``openimp.forces``.

Tolerance 1e-10 relative (M against its largest entry; reactions against the largest
force, or moment, of the mechanism): the differences are accurate to about 1e-12
(truncation and round-off stated in the oracle) and openimp's postures close to
round-off; measured, M agrees to 3.4e-13 and the reactions to 1.0e-12 (2026-11), so
1e-10 leaves a margin of 100 for the differences, not for a wrong term.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import openimp
from helpers.geometry import DEG, circle_intersection, rot
from helpers.models import Spec, slider_crank_joints
from openimp.dynamics.eom import equations
from reference import book

TOL = 1e-10  # relative, see the module docstring
G = 9.81


def turn(o, a, t: float) -> np.ndarray:
    """4x4 rotation by t about the line through o along a."""
    R = rot(a, t)
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = np.asarray(o, float) - R @ np.asarray(o, float)
    return T


def planar(p0, p, t: float) -> np.ndarray:
    """4x4 planar motion turning by t about z and carrying the point p0 to p."""
    T = turn((0.0, 0.0, 0.0), (0.0, 0.0, 1.0), t)
    T[:3, 3] = np.asarray(p, float) - T[:3, :3] @ np.asarray(p0, float)
    return T


def angle(v) -> float:
    return math.atan2(v[1], v[0])


def inertia(p, axis, t: float) -> np.ndarray:
    """A centroidal inertia with principal moments p on axes turned by t about axis."""
    R = rot(axis, t)
    return R @ np.diag(p) @ R.T


# =============================================================================
# Mechanisms: the model, its closed-form postures, its topology and loads
# =============================================================================


class Case:
    """A Spec with what the oracle needs: ``bodies`` (rows of T and P), ``joints``
    (columns of L and P), ``kinds``, ``L``, ``P``, ``gen`` (joint names of the
    generalized coordinates), ``posture(psi) -> (nb, 4, 4)``, ``joint_phi(psi)``:
    joint -> the variable phi_h of each joint with a spring."""

    def __init__(self, spec, bodies, joints, kinds, L, P, gen, posture, joint_phi):
        self.spec, self.bodies, self.joints, self.kinds = spec, bodies, joints, kinds
        self.L, self.P = np.array(L, float).reshape(-1, len(joints)), np.array(P, float)
        self.gen, self.posture, self.joint_phi = gen, posture, joint_phi
        self.system = spec.compile()
        self.J = np.array([book.pseudo_inertia(*spec.mass[b]) for b in bodies])


def fourbar() -> Case:
    """Crank a = 1 at A (BASE->CRANK), coupler b = 3, rocker c = 2.5 pinned at D = (3.2,
    0) (D ROCKER->BASE), crank at 40 deg; masses with inertia products, gravity off the
    axes, a spring and a damper in C, a load in B, a point spring coupler -> ground, a
    point force on the rocker."""
    a, b, c, d, th0 = 1.0, 3.0, 2.5, 3.2, 40 * DEG
    A2, D2 = np.zeros(2), np.array([d, 0.0])

    def pins(t):
        B2 = a * np.array([math.cos(th0 + t), math.sin(th0 + t)])
        return B2, circle_intersection(B2, b, D2, c, left=True)

    B0, C0 = pins(0.0)
    P3 = lambda p2: np.r_[p2, 0.0]  # noqa: E731
    s = Spec(openimp.Model("four-bar"))
    for name, b1, b2, o in (("A", "BASE", "CRANK", A2), ("B", "CRANK", "COUPLER", B0),
                            ("C", "COUPLER", "ROCKER", C0), ("D", "ROCKER", "BASE", D2)):
        s.joint(name, b1, b2, P3(o), ref=(1.0, 0.0, 0.0))
    s.add_mass("CRANK", 2.0, P3(0.45 * B0) + np.array([0.0, 0.05, 0.0]),
               inertia((0.02, 0.15, 0.16), (1, 2, 3), 0.4))
    s.add_mass("COUPLER", 3.0, P3((B0 + C0) / 2) + np.array([0.1, 0.3, 0.02]),
               inertia((0.05, 2.2, 2.24), (0.3, -1, 2), 1.1))
    s.add_mass("ROCKER", 1.5, P3((C0 + D2) / 2) + np.array([-0.1, 0.0, -0.03]),
               inertia((0.03, 0.8, 0.82), (2, 1, 0.5), 0.7))
    s.set_gravity((1.2, -G, 0.0))
    s.point("P1", "COUPLER", P3((B0 + C0) / 2) + np.array([0.2, 0.6, 0.0]))
    s.point("PR", "ROCKER", P3(0.4 * C0 + 0.6 * D2))
    s.point("G1", "BASE", (1.5, 4.0, 0.0))
    s.spring("S", "P1", "G1", 300.0, 1.2)
    s.force("F", "PR", 40.0, (1.0, 0.5, 0.0))
    s.joint_spring("C", 80.0, 0.3)
    s.joint_damper("C", 4.0)
    s.joint_force("B", 7.5)

    def posture(psi):
        B2, C2 = pins(psi[0])
        return np.array([
            turn(P3(A2), (0, 0, 1), psi[0]),
            planar(P3(B0), P3(B2), angle(C2 - B2) - angle(C0 - B0)),
            turn(P3(D2), (0, 0, 1), angle(C2 - D2) - angle(C0 - D2)),
        ])

    def joint_phi(psi):
        B2, C2 = pins(psi[0])  # C's variable: the rocker's turn less the coupler's, 0 as
        # placed (one frame for both bodies)
        return {"C": (angle(C2 - D2) - angle(C0 - D2)) - (angle(C2 - B2) - angle(C0 - B0))}

    return Case(s, ["CRANK", "COUPLER", "ROCKER"], ["A", "B", "C", "D"], ["revolute"] * 4,
                [1, 1, 1, 1], [[1, 0, 0, 0], [1, 1, 0, 0], [0, 0, 0, -1]], ["A"], posture,
                joint_phi)


def arm() -> Case:
    """Spatial 3R open chain BASE -J1-> L1 -J2-> L2 -J3-> L3 on skew axes (every
    reaction determinate); gravity -Z, a spring, damper and load in J2, a load in J3, a
    point spring from L3 to the ground and a point force on L2."""
    o = [np.zeros(3), np.array([0.3, 0.0, 0.5]), np.array([0.9, 0.2, 0.6])]
    ax = [np.array([0.0, 0.0, 1.0]), np.array([0.0, 1.0, 0.2]), np.array([1.0, 0.3, -0.4])]
    s = Spec(openimp.Model("3R arm"))
    for name, b1, b2, k in (("J1", "BASE", "L1", 0), ("J2", "L1", "L2", 1),
                            ("J3", "L2", "L3", 2)):
        s.joint(name, b1, b2, o[k], ax[k])
    s.add_mass("L1", 4.0, (0.1, 0.05, 0.3), inertia((0.05, 0.12, 0.14), (1, 0, 1), 0.3))
    s.add_mass("L2", 2.5, (0.6, 0.15, 0.55), inertia((0.01, 0.2, 0.2), (0.2, 1, 0.1), 0.9))
    s.add_mass("L3", 1.2, (1.3, 0.35, 0.5), inertia((0.02, 0.09, 0.1), (1, -1, 0.4), 1.7))
    s.set_gravity((0.0, 0.0, -G))
    s.point("TIP", "L3", (1.6, 0.4, 0.45))
    s.point("Q2", "L2", (0.5, 0.1, 0.5))
    s.point("GA", "BASE", (1.0, 1.0, 1.5))
    s.spring("S", "TIP", "GA", 150.0, 0.6)
    s.force("F", "Q2", 20.0, (0.3, -1.0, 0.4))
    s.joint_spring("J2", 30.0, 0.2)
    s.joint_damper("J2", 1.5)
    s.joint_force("J2", -4.0)
    s.joint_force("J3", 2.5)

    def posture(psi):
        T1 = turn(o[0], ax[0], psi[0])
        T2 = T1 @ turn(o[1], ax[1], psi[1])
        return np.array([T1, T2, T2 @ turn(o[2], ax[2], psi[2])])

    return Case(s, ["L1", "L2", "L3"], ["J1", "J2", "J3"], ["revolute"] * 3, [],
                [[1, 0, 0], [1, 1, 0], [1, 1, 1]], ["J1", "J2", "J3"], posture,
                lambda psi: {"J2": psi[1]})


def slider_crank() -> Case:
    """Offset slider-crank (helpers.models.slider_crank_joints: crank 1, rod 3.5, offset
    0.4, crank at 30 deg; prismatic D BASE->SLIDER along X): masses, gravity -Y, a spring
    in the slider joint, a point spring rod -> ground, a point force on the rod."""
    a, b, e, th0 = 1.0, 3.5, 0.4, 30 * DEG
    s, B0, C0 = slider_crank_joints("slider-crank", a, b, e, th0)

    def pins(t):
        B = a * np.array([math.cos(th0 + t), math.sin(th0 + t), 0.0])
        return B, np.array([B[0] + math.sqrt(b * b - (e - B[1]) ** 2), e, 0.0])

    s.add_mass("CRANK", 1.5, 0.4 * B0, inertia((0.01, 0.12, 0.13), (0, 0, 1), 0.2))
    s.add_mass("ROD", 2.0, 0.6 * B0 + 0.4 * C0 + [0.0, 0.1, 0.0],
               inertia((0.02, 2.0, 2.02), (0.1, 0.2, 1), 0.3))
    s.add_mass("SLIDER", 3.0, C0 + np.array([0.1, 0.05, 0.0]),
               inertia((0.01, 0.02, 0.025), (1, 1, 1), 0.5))
    s.set_gravity((0.0, -G, 0.0))
    s.point("R", "ROD", 0.5 * (B0 + C0) + [0.0, 0.3, 0.0])
    s.point("G", "BASE", (1.0, 2.5, 0.0))
    s.spring("S", "R", "G", 120.0, 1.5)
    s.force("F", "R", -25.0, (0.6, 0.8, 0.0))
    s.joint_spring("D", 60.0, 3.9)

    def posture(psi):
        B, C = pins(psi[0])
        return np.array([
            turn(np.zeros(3), (0, 0, 1), psi[0]),
            planar(B0, B, angle(C - B) - angle(C0 - B0)),
            planar(C0, C, 0.0),
        ])

    return Case(s, ["CRANK", "ROD", "SLIDER"], ["A", "B", "C", "D"],
                ["revolute"] * 3 + ["prismatic"], [1, 1, 1, -1],
                [[1, 0, 0, 0], [1, 1, 0, 0], [0, 0, 0, 1]], ["A"], posture,
                lambda psi: {"D": pins(psi[0])[1][0]})  # the slide: C's x from (0, e)


CASES = {"fourbar": fourbar, "arm": arm, "slider_crank": slider_crank}

#: (generalized coordinates' offsets from the modeling posture, rates, accelerations)
STATES = {
    "fourbar": ([0.7], [1.7], [-2.3]),
    "arm": ([0.3, -0.4, 1.1], [0.9, -1.3, 2.1], [0.4, 1.1, -0.7]),
    "slider_crank": ([2.1], [-1.4], [3.0]),
}


def solve(case: Case, name: str):
    """openimp's trajectory at the state of ``name`` (one step) and the state."""
    psi, rates, accels = (np.array(x, float) for x in STATES[name])
    q0 = case.system.modeling_q
    idx = [case.system.var_index(g) for g in case.gen]
    tr = openimp.sweep(case.system, {g: [q0[i] + p] for g, i, p in zip(case.gen, idx, psi)},
                       rates={g: [r] for g, r in zip(case.gen, rates)},
                       accels={g: [a] for g, a in zip(case.gen, accels)})
    assert tr.complete, tr.message
    return tr, psi, rates, accels


def frames(case: Case, T: np.ndarray) -> np.ndarray:
    """E_h: each joint's frame as placed, carried by its first body to the posture T."""
    rows = {b: k for k, b in enumerate(case.bodies)}
    out = []
    for j in case.joints:
        Jt = case.spec.model.joints[j]
        Tb = T[rows[Jt.body1]] if Jt.body1 in rows else np.eye(4)
        out.append(Tb @ Jt.frame1)
    return np.array(out)


# =============================================================================
# Tests
# =============================================================================


@pytest.mark.parametrize("name", list(CASES))
def test_mass_matrix_is_the_books_11_7(name):
    """M of dynamics.eom.equations = sum_b trace(W_bj G_b W_bk^T) (11.7), W by
    differences of the closed-form postures; the oracle's (7.20) W agrees with them."""
    case = CASES[name]()
    tr, psi, rates, _ = solve(case, name)
    T, W = book.by_differences(case.posture, psi)
    # the closed-form postures are openimp's (the same mechanism at the same psi)
    for k, b in enumerate(case.bodies):
        Tb = tr.posture(b)[0] @ np.linalg.inv(case.spec.model.body_frames[b])
        np.testing.assert_allclose(Tb, T[k], rtol=0, atol=1e-12)
    D = book.joint_operators(frames(case, T), case.kinds)
    gen = [case.joints.index(g) for g in case.gen]
    _, W720 = book.first_derivatives(D, case.L, case.P, gen)
    np.testing.assert_allclose(W720, W, rtol=0, atol=1e-10 * np.abs(W).max())
    M = book.mass_matrix(T, W, case.J)
    e = equations(case.system, tr.q[0], dict(zip(case.gen, rates)), specified=case.gen)
    assert e.coords == [case.system.var_names[case.system.var_index(g)] for g in case.gen]
    np.testing.assert_allclose(e.M, M, rtol=0, atol=TOL * np.abs(M).max())


@pytest.mark.parametrize("name", list(CASES))
def test_joint_reactions_are_the_books_17_20(name):
    """Every component of every joint reaction of openimp.forces (joint frame, the load
    of the first body on the second) = F_Delta of (17.20), NaN exactly where (17.18)
    finds the component indeterminate."""
    case = CASES[name]()
    tr, psi, rates, accels = solve(case, name)
    s = case.spec
    T = case.posture(psi)
    Tdd = book.second_by_differences(case.posture, psi, rates, accels)
    E = frames(case, T)
    rows = {b: k for k, b in enumerate(case.bodies)}
    moved = {b: T[k] for b, k in rows.items()}

    def at(p):  # a point as placed, carried to the posture, and its body's row
        b = s.points[p]
        r = moved.get(b, np.eye(4)) @ np.r_[s.model.points[p].xyz, 1.0]
        return rows.get(b), r[:3]

    phi = case.joint_phi(psi)
    for j, v in phi.items():  # the closed form is openimp's posture
        assert abs(tr.variable(j)[0] - v) < 1e-12, j
    loads = [(case.joints.index(j), *s.jsprings.get(j, (0.0, 0.0)), s.jdampers.get(j, 0.0),
              s.jforces.get(j, 0.0)) for j in case.joints]
    loads = [(h, k, phi[case.joints[h]] - q0 if k else 0.0, c, f)
             for h, k, q0, c, f in loads]
    springs = [(*at(p1), *at(p2), k, l0) for _, p1, p2, k, l0 in s.springs]
    forces = [(*at(p), np.asarray(d, float) / np.linalg.norm(d), f)
              for _, p, f, d in s.forces]
    F = openimp.forces_of(tr)
    gen = [case.joints.index(g) for g in case.gen]
    ref = np.array([[book.reaction(h, c, E=E, kinds=case.kinds, L=case.L, P=case.P,
                                   gen=gen, T=T, Tdd=Tdd, J=case.J, psid=rates, g=s.gravity,
                                   joint_loads=loads, point_springs=springs,
                                   point_forces=forces)
                     for c in range(6)] for h in range(len(case.joints))])
    got = np.array([F.reaction(j, "joint")[0] for j in case.joints])
    np.testing.assert_array_equal(np.isnan(got), np.isnan(ref))
    for part in (slice(0, 3), slice(3, 6)):  # forces, moments
        scale = np.nanmax(np.abs(ref[:, part]))
        np.testing.assert_allclose(got[:, part], ref[:, part], rtol=0, atol=TOL * scale)
