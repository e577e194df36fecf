"""Posture sweeps of the kinematic core against independent closed forms.

Every reference below is computed here with plain numpy from the link
dimensions (no openimp code); the closed forms are derived in the docstrings.
Each sweep is also checked for loop closure from ``res.posture`` of the bodies
and the joint frames this file placed (:func:`assert_loops_close`).

Tolerances: point positions to 1e-9 of the largest link length, angles to
1e-9 rad, loop closure to 1e-10 (rotation entries, and translations divided
by the size of the model).  The solver converges to 1e-10 internal units with
quadratic convergence, so the actual errors are at round-off level.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import openimp
from helpers.geometry import (
    cardan_example_51,
    circle_intersection,
    e2,
    hom,
    rot,
    rssr_geometry,
    rssr_output,
)
from helpers.models import Rig, build_fivebar
from openimp import InputError, Model

DEG = math.pi / 180.0

# =============================================================================
# Independent geometry helpers (numpy only)
# =============================================================================


def Rz(t: float) -> np.ndarray:
    return hom(rot((0, 0, 1), t))


def Rx(t: float) -> np.ndarray:
    return hom(rot((1, 0, 0), t))


def Tx(a: float) -> np.ndarray:
    return hom(p=(a, 0, 0))


def Tz(s: float) -> np.ndarray:
    return hom(p=(0, 0, s))


def inv(T: np.ndarray) -> np.ndarray:
    """Rigid inverse, also of a stack (..., 4, 4)."""
    out = np.zeros_like(T)
    Rt = np.swapaxes(T[..., :3, :3], -1, -2)
    out[..., :3, :3] = Rt
    out[..., :3, 3] = -np.einsum("...ij,...j->...i", Rt, T[..., :3, 3])
    out[..., 3, 3] = 1.0
    return out


def wrap(x):
    """Angle difference folded into (-pi, pi]."""
    return np.angle(np.exp(1j * np.asarray(x, float)))


def er_rotation(e) -> np.ndarray:
    """Rotation of unit Euler-Rodrigues parameters (e1, e2, e3 vector part, e4 scalar)."""
    e = np.asarray(e, float) / np.linalg.norm(e)
    x, y, z, w = e
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


#: joint matrices Phi(q) of the kinds used here, written from the book's
#: definitions (revolute: rotation about w; prismatic: slide along w; sphere:
#: Euler-Rodrigues rotation about the common origin).
PHI = {
    "revolute": lambda q: Rz(q[0]),
    "prismatic": lambda q: Tz(q[0]),
    "sphere": lambda q: hom(er_rotation(q)),
}


class Placement:
    """A rigid placement G of a planar layout: (x, y) -> R (x, y, 0) + t."""

    def __init__(self, R: np.ndarray, t) -> None:
        self.R = np.asarray(R, float)
        self.t = np.asarray(t, float)

    def p(self, x, y=None):
        """Global point(s) of planar coordinates; x may be (n, 2)."""
        if y is None:
            xy = np.atleast_2d(np.asarray(x, float))
            pts = np.c_[xy, np.zeros(len(xy))] @ self.R.T + self.t
            return pts if np.ndim(x) > 1 else pts[0]
        return self.R @ np.array([x, y, 0.0]) + self.t

    def d(self, x, y, z=0.0):
        """Global direction of a local direction."""
        return self.R @ np.array([x, y, z], float)

    @property
    def T(self) -> np.ndarray:
        return hom(self.R, self.t)


PLANAR = Placement(np.eye(3), (0.0, 0.0, 0.0))
#: an arbitrary spatial rotation and translation: all joint axes tilted
TILTED = Placement(rot((1.0, -2.0, 0.7), 1.1), (0.3, -1.7, 2.2))
PLACEMENTS = pytest.mark.parametrize("place", [PLANAR, TILTED], ids=["xy", "tilted"])


def assert_loops_close(rig: Rig, res, tol: float = 1e-10) -> None:
    """Every loop closes at every solved posture.

    For each joint h (tree or chord) the global pose of its two elements is
    T_0(h-) S_(h-,h) and T_0(h+) S_(h+,h), with S = T_0b(model)^-1 F the
    shape matrix of the frame F placed at the modeling posture.  The relative
    transform of the two elements must equal the joint matrix Phi_h(q_h) at the
    reported joint variables.  Holding for every joint, it is exactly the
    statement that the product of T_(h-,h+) = S Phi S^-1 around every loop is
    the identity (book 5.12).  Rotations compared entry-wise, translations
    divided by the model size; e of spheres must be unit.
    """
    assert res.nsteps > 0
    L = rig.size()
    for name, (kind, b1, b2, F1, F2) in rig.j.items():
        S1 = inv(rig.bf.get(b1, np.eye(4))) @ F1
        S2 = inv(rig.bf.get(b2, np.eye(4))) @ F2
        E1 = res.posture(b1) @ S1
        E2 = res.posture(b2) @ S2
        rel = inv(E1) @ E2
        q = res.joint(name)
        want = np.array([PHI[kind](qk) for qk in q])
        erot = np.max(np.abs(rel[:, :3, :3] - want[:, :3, :3]))
        epos = np.max(np.abs(rel[:, :3, 3] - want[:, :3, 3])) / L
        assert erot < tol and epos < tol, (
            f"joint {name}: loop closure error rot {erot:.3g}, pos {epos:.3g} (relative)"
        )
        if kind == "sphere":
            assert np.max(np.abs(np.linalg.norm(q, axis=1) - 1.0)) < tol


# =============================================================================
# 1. Planar four-bar (Freudenstein) and slider-crank, in and out of plane
# =============================================================================


def freudenstein(a, b, c, d, th2, s4, s3):
    """Rocker and coupler angles of the four-bar A(0,0)-B-C-D(d,0).

    Loop: a e^{i th2} + b e^{i th3} = d + c e^{i th4}.
    Isolating b e^{i th3} and squaring gives Freudenstein's equation
        K1 cos th4 - K2 cos th2 + K3 = cos(th2 - th4),
        K1 = d/a, K2 = d/c, K3 = (a^2 - b^2 + c^2 + d^2) / (2 a c);
    isolating c e^{i th4} and squaring gives
        K1 cos th3 + K4 cos th2 + K5 = cos(th2 - th3),
        K4 = d/b, K5 = (c^2 - d^2 - a^2 - b^2) / (2 a b).
    Both have the form P cos x + Q sin x = R with P = K1 - cos th2,
    Q = -sin th2 (R4 = K2 cos th2 - K3, R3 = -K4 cos th2 - K5), so
        x = atan2(Q, P) + s acos(R / hypot(P, Q)),  s = +-1 the assembly branch.
    (P^2 + Q^2 > 0 because K1 > 1 for a crank shorter than the ground.)
    """
    K1, K2, K3 = d / a, d / c, (a * a - b * b + c * c + d * d) / (2 * a * c)
    K4, K5 = d / b, (c * c - d * d - a * a - b * b) / (2 * a * b)
    P = K1 - np.cos(th2)
    Q = -np.sin(th2)
    h = np.hypot(P, Q)
    base = np.arctan2(Q, P)
    th4 = base + s4 * np.arccos((K2 * np.cos(th2) - K3) / h)
    th3 = base + s3 * np.arccos((-K4 * np.cos(th2) - K5) / h)
    return th4, th3


def rot2(t, v):
    """Rotate planar vector(s) v (..., 2) by angle(s) t."""
    t = np.asarray(t, float)
    v = np.asarray(v, float)
    c, s = np.cos(t), np.sin(t)
    return np.stack([c * v[..., 0] - s * v[..., 1], s * v[..., 0] + c * v[..., 1]], -1)


def build_fourbar(place: Placement, a, b, c, d, th0, rocker_ref=False, left=True):
    """Four-bar A(0,0) B C D(d,0) in the planar coordinates of ``place``.

    Joints A BASE->CRANK, B CRANK->COUPLER, C COUPLER->ROCKER, D BASE->ROCKER,
    all revolutes on the local z axis (global axis R z), u along local x, so
    the variables start at 0 (D's u' is along D->C when ``rocker_ref``, so
    that D's variable is the absolute rocker angle).  Points PB (crank pin, on
    CRANK), PC (rocker pin, on ROCKER), P (coupler point, on COUPLER).
    """
    A2, D2 = np.zeros(2), np.array([d, 0.0])
    B2 = a * e2(th0)
    C2 = circle_intersection(B2, b, D2, c, left=left)
    P2 = (B2 + C2) / 2 + 0.6 * rot2(math.pi / 2, (C2 - B2) / b)
    w, u = place.d(0, 0, 1), place.d(1, 0)
    rig = Rig("four-bar")
    rig.pin("A", "BASE", "CRANK", place.p(*A2), w, u)
    rig.pin("B", "CRANK", "COUPLER", place.p(*B2), w, u)
    rig.pin("C", "COUPLER", "ROCKER", place.p(*C2), w, u)
    rig.pin("D", "BASE", "ROCKER", place.p(*D2), w, u,
            ref2=place.d(*(C2 - D2)) if rocker_ref else None)
    rig.m.add_point("PB", "CRANK", place.p(*B2))
    rig.m.add_point("PC", "ROCKER", place.p(*C2))
    rig.m.add_point("P", "COUPLER", place.p(*P2))
    return rig, (A2, B2, C2, D2, P2)


@PLACEMENTS
def test_fourbar_crank_rocker_freudenstein(place):
    """Crank-rocker a=1, b=3, c=2.5, d=3.2 (Grashof, s + l = 4.2 < p + q = 5.5), crank
    driven through a full turn in 1 deg steps from th2 = 40 deg.

    Reference: the crank pin B = a e(th2), the rocker pin C = D + c e(th4) and
    the coupler point P = B + Rot(th3 - th3_0)(P0 - B0), with th4, th3 from
    Freudenstein's equations (:func:`freudenstein`); the branch signs are the
    ones that reproduce the modeling posture built by circle intersection.
    Tolerance 1e-9 x the largest link (3.2).  Mobility is 1 at every step.
    """
    a, b, c, d = 1.0, 3.0, 2.5, 3.2
    th0 = 40 * DEG
    rig, (_, B2, C2, D2, P2) = build_fourbar(place, a, b, c, d, th0)
    sysm = rig.compile()
    q = np.radians(np.arange(361.0))
    res = openimp.sweep(sysm, {"A": q})
    assert res.complete, res.message
    assert res.nsteps == 361
    th2 = th0 + q
    # branch signs from the modeling posture
    th4_0 = math.atan2(C2[1] - D2[1], C2[0] - D2[0])
    th3_0 = math.atan2(C2[1] - B2[1], C2[0] - B2[0])
    s4 = min((1, -1), key=lambda s: abs(wrap(freudenstein(a, b, c, d, th0, s, 1)[0] - th4_0)))
    s3 = min((1, -1), key=lambda s: abs(wrap(freudenstein(a, b, c, d, th0, 1, s)[1] - th3_0)))
    th4, th3 = freudenstein(a, b, c, d, th2, s4, s3)
    B = a * e2(th2)
    C = D2 + c * e2(th4)
    # self-check of the reference: the coupler length and the coupler angle agree
    assert np.max(np.abs(np.linalg.norm(C - B, axis=1) - b)) < 1e-12
    assert np.max(np.abs(B + b * e2(th3) - C)) < 1e-12
    P = B + rot2(th3 - th3_0, P2 - B2)
    tol = 1e-9 * d
    np.testing.assert_allclose(res.point("PB"), place.p(B), rtol=0, atol=tol)
    np.testing.assert_allclose(res.point("PC"), place.p(C), rtol=0, atol=tol)
    np.testing.assert_allclose(res.point("P"), place.p(P), rtol=0, atol=tol)
    # the joint variables: rocker D and the relative angles at B and C
    assert np.max(np.abs(wrap(res.variable("D") - (th4 - th4_0)))) < 1e-9
    assert np.max(np.abs(wrap(res.variable("B") - ((th3 - th3_0) - q)))) < 1e-9
    assert np.max(np.abs(wrap(res.variable("C") - ((th4 - th4_0) - (th3 - th3_0))))) < 1e-9
    assert np.all(res.mobility == 1)
    assert res.fgc == [[]] * res.nsteps
    assert_loops_close(rig, res)


@PLACEMENTS
def test_slider_crank_closed_form(place):
    """Offset slider-crank: crank a=1, rod b=3.5, slider line y = e = 0.4.

    Crank pin B = a e(th), slider pin C = (x_C, e) with |C - B| = b:
        x_C = a cos th + sqrt(b^2 - (e - a sin th)^2)    (slider right of the crank pin).
    The rod angle is th3 = atan2(e - a sin th, x_C - a cos th) and a rod point
    P = B + Rot(th3 - th3_0)(P0 - B0).  The prismatic D (BASE->SLIDER, w along
    the slider line, frame1 origin at (0, e)) reports s = x_C exactly.
    Full turn in 1 deg steps from th = 30 deg; tolerance 1e-9 x b.
    """
    a, b, e = 1.0, 3.5, 0.4
    th0 = 30 * DEG

    def xc(t):
        return a * np.cos(t) + np.sqrt(b * b - (e - a * np.sin(t)) ** 2)

    B2 = a * e2(th0)
    C2 = np.array([xc(th0), e])
    P2 = (B2 + C2) / 2 + 0.5 * rot2(math.pi / 2, (C2 - B2) / b)
    w, u = place.d(0, 0, 1), place.d(1, 0)
    rig = Rig("slider-crank")
    rig.pin("A", "BASE", "CRANK", place.p(0, 0), w, u)
    rig.pin("B", "CRANK", "ROD", place.p(*B2), w, u)
    rig.pin("C", "ROD", "SLIDER", place.p(*C2), w, u)
    rig.pin("D", "BASE", "SLIDER", place.p(0, e), place.d(1, 0), place.d(0, 1),
            kind="prismatic", origin2=place.p(*C2))
    rig.m.add_point("PC", "SLIDER", place.p(*C2))
    rig.m.add_point("P", "ROD", place.p(*P2))
    sysm = rig.compile()
    q = np.radians(np.arange(361.0))
    res = openimp.sweep(sysm, {"A": q})
    assert res.complete, res.message
    th = th0 + q
    x = xc(th)
    B = a * e2(th)
    th3 = np.arctan2(e - B[:, 1], x - B[:, 0])
    th3_0 = math.atan2(e - B2[1], C2[0] - B2[0])
    P = B + rot2(th3 - th3_0, P2 - B2)
    tol = 1e-9 * b
    np.testing.assert_allclose(res.variable("D"), x, rtol=0, atol=tol)
    np.testing.assert_allclose(res.point("PC"), place.p(np.c_[x, np.full_like(x, e)]),
                               rtol=0, atol=tol)
    np.testing.assert_allclose(res.point("P"), place.p(P), rtol=0, atol=tol)
    assert np.all(res.mobility == 1)
    assert_loops_close(rig, res)


# =============================================================================
# 2. Hooke (Cardan) coupling: Denavit-Hartenberg 1955 and book Example 5.1
# =============================================================================


def dh_M(theta: float, alpha: float) -> np.ndarray:
    """The 1955 paper's part matrix (its eq. 6) for a = s = 0, as a 4x4 with the
    homogeneous coordinate last: r_i = M r_(i+1), rotation part
    [[c th, -s th c al, -s th s al], [s th, c th c al, c th s al], [0, -s al, c al]]
    = Rz(theta) Rx(-alpha)."""
    return Rz(theta) @ Rx(-alpha)


def hooke_closed_form(th1, alpha):
    """Denavit & Hartenberg (1955), universal joint, M2 M3 M4 M1 = 1 with the
    part matrices M(th1, alpha1), M(th2, 90), M(th3, 90), M(th4, 90).

    Their nine equations include  cos th3 = cos th1 sin al,
    cos th2 sin th3 = sin th1,  sin th2 sin th3 = cos th1 cos al,
    sin th3 cos th4 = sin th1 sin al,  sin th3 sin th4 = cos al.
    With sin^2 th3 = 1 - cos^2 th1 sin^2 al = cos^2 al + sin^2 th1 sin^2 al (> 0 for
    al < 90 deg, so sin th3 never vanishes and the branch sin th3 > 0 is kept
    through a full turn):
        th2 = atan2(cos th1 cos al, sin th1)      -> tan th2 = cos al / tan th1
        th3 = acos(sin al cos th1)                -> cos th3 = sin al cos th1
        th4 = atan2(cos al, sin th1 sin al)       -> tan th4 = 1 / (tan al sin th1)
    the paper's three relations with their quadrants resolved.
    """
    th2 = np.arctan2(np.cos(th1) * np.cos(alpha), np.sin(th1))
    th3 = np.arccos(np.sin(alpha) * np.cos(th1))
    th4 = np.arctan2(np.cos(alpha), np.sin(th1) * np.sin(alpha))
    return th2, th3, th4


@pytest.mark.parametrize("alpha_deg", [20.0, 45.0, 70.0])
def test_hooke_coupling_denavit_hartenberg(alpha_deg):
    """Universal joint of Denavit & Hartenberg (1955), Fig. 9, for three shaft angles.

    Correspondence with our joint variables: the paper's x_i lies in part i
    along the common perpendicular of z_(i-1) and z_i, and th_i is the angle
    from x_i to x_(i+1) about z_i, part i+1 being placed by
    F_(i+1) = F_i M(th_i, al_i).  Joint Ji (revolute) therefore goes from part
    i to part i+1 with frame1 = F_i (w = z_i, u = x_i, fixed in part i) and
    frame2 = F_i Rz(th_i) (w = z_i, u = x_(i+1), fixed in part i+1); its
    variable is exactly th_i.  Part 2 carries the bearings z1, z2 (angle al1
    between the shafts) and is the frame; J1 (input shaft 1 against the frame)
    is driven through a full turn in 2 deg steps.  The reference posture is
    self-checked: the product of the four part matrices is I.
    """
    al = alpha_deg * DEG
    th1_0 = 0.4
    t2, t3, t4 = hooke_closed_form(th1_0, al)
    ths = [th1_0, t2, t3, t4]
    als = [al, 90 * DEG, 90 * DEG, 90 * DEG]
    G = TILTED.T  # an arbitrary global placement of F_1
    F = [G]
    for i in range(4):
        F.append(F[i] @ dh_M(ths[i], als[i]))
    assert np.max(np.abs(F[4] - F[0])) < 1e-12  # the paper's M2 M3 M4 M1 = 1
    parts = ["SHAFT1", "FRAME", "SHAFT2", "CROSS"]
    rig = Rig("hooke", ground="FRAME")
    for i in range(4):
        rig.joint("revolute", f"J{i + 1}", parts[i], parts[(i + 1) % 4], F[i], F[i] @ Rz(ths[i]))
    sysm = rig.compile()
    np.testing.assert_allclose(sysm.modeling_q, wrap(ths), atol=1e-12)
    th1 = th1_0 + np.radians(np.arange(0.0, 361.0, 2.0))
    res = openimp.sweep(sysm, {"J1": th1})
    assert res.complete, res.message
    w2, w3, w4 = hooke_closed_form(th1, al)
    for name, want in (("J2", w2), ("J3", w3), ("J4", w4)):
        assert np.max(np.abs(wrap(res.variable(name) - want))) < 1e-9, name
    # the paper's relations in their printed form, where they are well conditioned
    g1, g2 = res.variable("J1"), res.variable("J2")
    g3, g4 = res.variable("J3"), res.variable("J4")
    np.testing.assert_allclose(np.cos(g3), np.sin(al) * np.cos(g1), atol=1e-9)
    ok = (np.abs(np.sin(g1)) > 0.1) & (np.abs(np.cos(g1)) > 0.1)
    np.testing.assert_allclose(np.tan(g2[ok]) * np.tan(g1[ok]), np.cos(al), atol=1e-8)
    np.testing.assert_allclose(np.tan(g4[ok]) * np.tan(al) * np.sin(g1[ok]), 1.0, atol=1e-8)
    assert np.all(res.mobility == 1)
    assert_loops_close(rig, res)


def cardan_closed_form(psi, beta):
    """Book Example 5.1: from T34 T41 = (T12 T23)^-1,
    phi_A = atan(-tan psi cos beta), phi_B = acos(sin psi sin beta),
    phi_C = atan(1 / (cos psi tan beta)); the closure with sin phi_B < 0 and
    cos beta < 0 gives the quadrants  phi_A = atan2(-s psi c beta, c psi),
    phi_B = -acos(s psi s beta), phi_C = atan2(1, c psi tan beta)."""
    pa = np.arctan2(-np.sin(psi) * math.cos(beta), np.cos(psi))
    pb = -np.arccos(np.sin(psi) * math.sin(beta))
    pc = np.arctan2(1.0, np.cos(psi) * math.tan(beta))
    return pa, pb, pc


def test_cardan_book_example_51():
    """Book Example 5.1, beta = 150 deg, d1 = d2 = 1, h = 0.5, built from the
    example's shape matrices.

    Modeling posture psi0 = 0.7: T_04 = I, T_41 = S_4A Rz(phi_A) S_1A^-1,
    T_12 = S_1B Rz(phi_B) S_2B^-1, T_23 = S_2C Rz(phi_C) S_3C^-1 (book 5.4), the
    body frames set to these T_0b and each joint's two global frames
    T_0(h-) S_(h-,h), T_0(h+) S_(h+,h).  Sweep psi = phi_D over a full turn in
    3 deg steps: the variables follow the closed form and every body posture
    T_0b equals the product of the closed-form T's (to 1e-9).
    """
    beta, d1, d2, h = 150 * DEG, 1.0, 1.0, 0.5
    S = cardan_example_51(beta, d1, d2, h)

    def T(joint, b1, b2, phi):
        return S[(b1, joint)] @ Rz(phi) @ inv(S[(b2, joint)])

    def postures(psi):
        pa, pb, pc = cardan_closed_form(psi, beta)
        T01 = T("A", "4", "1", pa)
        T02 = T01 @ T("B", "1", "2", pb)
        T03 = T02 @ T("C", "2", "3", pc)
        return {"4": np.eye(4), "1": T01, "2": T02, "3": T03}

    psi0 = 0.7
    T0 = postures(psi0)
    # self-check of the reference: the loop closes through D
    assert np.max(np.abs(T0["3"] @ T("D", "3", "4", psi0) - np.eye(4))) < 1e-12
    rig = Rig("cardan", ground="4")
    joints = [("A", "4", "1"), ("B", "1", "2"), ("C", "2", "3"), ("D", "3", "4")]
    for jn, b1, b2 in joints:
        rig.joint("revolute", jn, b1, b2, T0[b1] @ S[(b1, jn)], T0[b2] @ S[(b2, jn)])
    for b in ("1", "2", "3"):
        rig.body_frame(b, T0[b])
    sysm = rig.compile()
    pa0, pb0, pc0 = cardan_closed_form(psi0, beta)
    np.testing.assert_allclose(sysm.modeling_q, wrap([pa0, pb0, pc0, psi0]), atol=1e-12)
    psi = psi0 + np.radians(np.arange(0.0, 361.0, 3.0))
    res = openimp.sweep(sysm, {"D": psi})
    assert res.complete, res.message
    pa, pb, pc = cardan_closed_form(psi, beta)
    for name, want in (("A", pa), ("B", pb), ("C", pc), ("D", psi)):
        assert np.max(np.abs(wrap(res.variable(name) - want))) < 1e-9, name
    for k in range(0, res.nsteps, 10):
        ref = postures(psi[k])
        for b in ("1", "2", "3", "4"):
            np.testing.assert_allclose(res.posture(b)[k], ref[b], rtol=0, atol=1e-9)
    assert np.all(res.mobility == 1)
    assert_loops_close(rig, res)


# =============================================================================
# 3. Spatial linkages, mobility and driver checks
# =============================================================================


def test_rssr_output_angle_and_passive_freedom():
    """Spatial RSSR four-bar: revolute A (BASE->CRANK, axis z), ball B
    (CRANK->COUPLER), ball C (COUPLER->ROCKER), revolute D (BASE->ROCKER, skew
    axis w2, u along u2 and u' toward the ball so that its variable is phi).

    The output angle follows :func:`rssr_output` to 1e-9 rad and the ball
    centres to 1e-9 x L.  Variables 1 + 4 + 4 + 1 = 10, rows 6 + 2 ER
    normalisations, rank 8: mobility 2, one of which is the passive spin of the
    coupler about the ball-to-ball line; a sweep with the single crank driver is
    accepted without hold_free.  Full turn in 2 deg steps.
    """
    g = rssr_geometry()
    th0 = 0.6
    phi0, B0, C0 = rssr_output(g, th0, +1)
    rig = Rig("rssr")
    rig.pin("A", "BASE", "CRANK", np.zeros(3), (0, 0, 1), (1, 0, 0))
    rig.ball("B", "CRANK", "COUPLER", B0)
    rig.ball("C", "COUPLER", "ROCKER", C0)
    rig.pin("D", "BASE", "ROCKER", g["D0"], g["w2"], g["u2"], ref2=C0 - g["D0"])
    rig.m.add_point("PB", "CRANK", B0)
    rig.m.add_point("PC", "ROCKER", C0)
    sysm = rig.compile()
    assert sysm.nq == 10
    assert abs(sysm.modeling_q[sysm.var_index("D")] - phi0) < 1e-12
    q = np.radians(np.arange(0.0, 361.0, 2.0))
    res = openimp.sweep(sysm, {"A": q})
    assert res.complete, res.message
    phi, B, C = rssr_output(g, th0 + q, +1)
    assert np.max(np.abs(wrap(res.variable("D") - phi))) < 1e-9
    np.testing.assert_allclose(res.point("PB"), B, rtol=0, atol=1e-9 * g["L"])
    np.testing.assert_allclose(res.point("PC"), C, rtol=0, atol=1e-9 * g["L"])
    np.testing.assert_allclose(np.linalg.norm(C - B, axis=1), g["L"], atol=1e-12)
    assert np.all(res.mobility == 2)
    assert all(len(f) == 1 for f in res.fgc)  # the passive spin
    assert_loops_close(rig, res)


def bennett_relation(th1, alpha, beta):
    """Bennett 4R: link lengths a, b, a, b and twists alpha, beta, alpha, beta with
    a / sin(alpha) = b / sin(beta), zero offsets.  With the joint angles of
    F_(i+1) = F_i Rz(th_i) Tx(a_i) Rx(al_i) (closure: the product of the four is I):
        tan(th1/2) tan(th2/2) = sin((beta + alpha)/2) / sin((beta - alpha)/2),
        th3 = -th1,  th4 = -th2   (Bennett 1903; the reference is self-checked
    by the closure of the four DH transforms at every step).
    """
    K = math.sin((beta + alpha) / 2) / math.sin((beta - alpha) / 2)
    th2 = 2 * np.arctan2(K * np.cos(th1 / 2), np.sin(th1 / 2))
    return th2, -th1, -th2


def test_bennett_mobility_and_input_output():
    """Bennett linkage alpha = 35 deg, beta = 70 deg, a = 1, b = a sin(beta)/sin(alpha).

    Gruebler/Kutzbach: 6 (4 - 1) - 5 * 4 = -2, yet the linkage moves: openimp
    must report mobility 1 (from the rank of the Jacobian) at every step and
    follow the closed-form input-output relation through a full turn of joint 1
    (3 deg steps) to 1e-9 rad.
    """
    alpha, beta = 35 * DEG, 70 * DEG
    a = 1.0
    b = a * math.sin(beta) / math.sin(alpha)
    lens, twists = [a, b, a, b], [alpha, beta, alpha, beta]

    def chain(th):
        F = [TILTED.T]
        for i in range(4):
            F.append(F[i] @ Rz(th[i]) @ Tx(lens[i]) @ Rx(twists[i]))
        return F

    th1_0 = 1.0
    th0 = [th1_0, *bennett_relation(th1_0, alpha, beta)]
    F = chain(th0)
    assert np.max(np.abs(F[4] - F[0])) < 1e-12
    links = ["BASE", "L1", "L2", "L3"]
    rig = Rig("bennett")
    for i in range(4):
        rig.joint("revolute", f"J{i + 1}", links[i], links[(i + 1) % 4], F[i], F[i] @ Rz(th0[i]))
    sysm = rig.compile()
    nbodies, njoints = len(sysm.bodies), len(sysm.joints)
    assert 6 * (nbodies - 1) - 5 * njoints == -2
    th1 = th1_0 + np.radians(np.arange(0.0, 361.0, 3.0))
    res = openimp.sweep(sysm, {"J1": th1})
    assert res.complete, res.message
    w2, w3, w4 = bennett_relation(th1, alpha, beta)
    for k in range(0, len(th1), 15):  # the reference closes
        Fk = chain([th1[k], w2[k], w3[k], w4[k]])
        assert np.max(np.abs(Fk[4] - Fk[0])) < 1e-12
    for name, want in (("J2", w2), ("J3", w3), ("J4", w4)):
        assert np.max(np.abs(wrap(res.variable(name) - want))) < 1e-9, name
    assert np.all(res.mobility == 1)
    assert_loops_close(rig, res)


def test_fivebar_mobility_two_drivers():
    """Planar five-bar of revolutes: 5 variables, the planar loop has rank 3, so
    the mobility is 2 at every step.

    One driver is an InputError that mentions the mobility; two drivers sweep.
    Reference: B = A + l1 e(t1 + q_A); joint E goes K2 -> BASE, so its variable
    turns BASE against K2 and the crank K2 turns by -q_E: D = E + l4 e(t4 - q_E);
    C = intersection of the circles (B, l2), (D, l3) left of B->D (the
    modeling branch).  Tolerance 1e-9 x the ground length 4.
    """
    rig, g = build_fivebar()
    sysm = rig.compile()
    with pytest.raises(InputError, match="mobility"):
        openimp.sweep(sysm, {"A": np.radians(np.arange(0.0, 10.0))})
    n = 31
    qa = np.radians(np.linspace(0.0, 30.0, n))
    qe = np.radians(np.linspace(0.0, 20.0, n))
    res = openimp.sweep(sysm, {"A": qa, "E": qe})
    assert res.complete, res.message
    assert np.all(res.mobility == 2)
    l1, l2, l3, l4 = g["l"]
    B = g["A"] + l1 * e2(g["t1"] + qa)
    D = g["E"] + l4 * e2(g["t4"] - qe)
    C = np.array([circle_intersection(B[k], l2, D[k], l3) for k in range(n)])
    np.testing.assert_allclose(res.point("PC")[:, :2], C, rtol=0, atol=1e-9 * 4)
    np.testing.assert_allclose(res.point("PC")[:, 2], 0.0, atol=1e-12)
    assert_loops_close(rig, res)


def test_fivebar_hold_free_keeps_free_coordinate():
    """With hold_free=True one driver suffices for the five-bar (mobility 2): the
    free coordinate is kept at its value, i.e. some joint variable other than the
    driver stays at its modeling value through the whole sweep (the sweep then
    is a four-bar motion), and the FGC reported at each step did not move
    during that step.  The loops close."""
    rig, _ = build_fivebar()
    sysm = rig.compile()
    qa = np.radians(np.linspace(0.0, 20.0, 11))
    res = openimp.sweep(sysm, {"A": qa}, hold_free=True)
    assert res.complete, res.message
    assert np.all(res.mobility == 2)
    assert_loops_close(rig, res)
    q0 = sysm.modeling_q
    held = [n for c, n in enumerate(sysm.var_names)
            if n != "A.theta" and np.all(np.abs(res.q[:, c] - q0[c]) < 1e-12)]
    assert held, "no coordinate was held"
    prev = q0
    for k in range(res.nsteps):
        for name in res.fgc[k]:
            c = sysm.var_index(name)
            assert abs(res.q[k, c] - prev[c]) < 1e-12, (k, name)
        prev = res.q[k]


def test_overspecified_driver_named():
    """Driving both the crank A and the rocker D of a four-bar (mobility 1) is an
    InputError naming the driver that the constraints determine."""
    rig, _ = build_fourbar(PLANAR, 1.0, 3.0, 2.5, 3.2, 40 * DEG)
    sysm = rig.compile()
    q = np.radians(np.arange(5.0))
    with pytest.raises(InputError) as ei:
        openimp.sweep(sysm, {"A": q, "D": q})
    msg = str(ei.value)
    assert "D.theta" in msg or "A.theta" in msg, msg


# =============================================================================
# 4. Toggle / dead centre and change point
# =============================================================================


def test_rocker_driven_toward_toggle():
    """Crank-rocker a=1, b=3, c=2.5, d=3.2 driven by its rocker D (variable = the
    absolute rocker angle phi) from mid-range toward its extreme.

    The rocker extremes are the postures with crank and coupler collinear:
    |C| = b +- a with C = D + c e(phi), so cos phi = ((b +- a)^2 - d^2 - c^2)/(2 d c);
    the extended one (b + a) gives phi_ext = 91.755 deg.  Approaching it as
    phi_ext + delta, delta = 1e-1 ... 1e-9 rad, the quality |det J11| must
    decrease monotonically over these steps and end below 1e-2 of its
    mid-range value; the step beyond (phi_ext - 1e-3) is unreachable: the sweep
    stops with a message, keeping every earlier posture (which match the
    closed form: crank pin B = circle(A, a) x circle(C, b), branch of the
    modeling posture).
    """
    a, b, c, d = 1.0, 3.0, 2.5, 3.2
    phi_ext = math.acos(((b + a) ** 2 - d * d - c * c) / (2 * d * c))
    phi_fold = math.acos(((b - a) ** 2 - d * d - c * c) / (2 * d * c))
    phi0 = 0.5 * (phi_ext + phi_fold)
    D2 = np.array([d, 0.0])
    C2 = D2 + c * e2(phi0)
    # B: circle(A, a) x circle(C, b); the crank-rocker's open branch has B left of C->A
    B2 = circle_intersection(C2, b, np.zeros(2), a, left=True)
    th0 = math.atan2(B2[1], B2[0])
    rig = Rig("toggle")
    z, x = (0, 0, 1), (1, 0, 0)
    rig.pin("A", "BASE", "CRANK", [0, 0, 0], z, x, ref2=[*B2, 0])
    rig.pin("B", "CRANK", "COUPLER", [*B2, 0], z, x)
    rig.pin("C", "COUPLER", "ROCKER", [*C2, 0], z, x)
    rig.pin("D", "BASE", "ROCKER", [*D2, 0], z, x, ref2=[*(C2 - D2), 0])
    rig.m.add_point("PB", "CRANK", [*B2, 0])
    sysm = rig.compile()
    assert abs(sysm.modeling_q[sysm.var_index("D")] - phi0) < 1e-12
    approach = phi_ext + np.logspace(-1, -9, 17)
    mid = np.linspace(phi0, approach[0], 8)[:-1]
    vals = np.concatenate([mid, approach, [phi_ext - 1e-3]])
    res = openimp.sweep(sysm, {"D": vals})
    assert not res.complete
    assert res.message
    assert res.nsteps == len(vals) - 1
    Q = res.quality
    tail = Q[len(mid):]
    assert np.all(np.diff(tail) < 0), tail
    assert tail[-1] < 1e-2 * Q[0]
    # the kept postures follow the closed form
    C = D2 + c * e2(vals[:-1])
    B = np.array([circle_intersection(Ck, b, np.zeros(2), a, left=True) for Ck in C])
    np.testing.assert_allclose(res.point("PB")[:, :2], B, rtol=0, atol=1e-9 * d)
    th = np.arctan2(B[:, 1], B[:, 0])  # A's variable is the absolute crank angle
    assert abs(th[0] - th0) < 1e-12
    assert np.max(np.abs(wrap(res.variable("A") - th))) < 1e-9
    assert_loops_close(rig, res)


def test_parallelogram_change_point():
    """Parallelogram a = c = 1, b = d = 2.5, crank driven from 40 deg in 1 deg steps
    through 180 deg, where all four pins are collinear (change point).

    There the three free revolute screws [p_y, -p_x, 1] have p_y = 0: rank 2,
    so the mobility reported at that step is 2 and a free generalized
    coordinate appears; the sweep goes on without an exception and the loop
    stays closed at every solved step.
    """
    a, b = 1.0, 2.5
    th0 = 40 * DEG
    B2 = a * e2(th0)
    C2 = B2 + np.array([b, 0.0])
    D2 = np.array([b, 0.0])
    rig = Rig("parallelogram")
    z, x = (0, 0, 1), (1, 0, 0)
    rig.pin("A", "BASE", "CRANK", [0, 0, 0], z, x)
    rig.pin("B", "CRANK", "COUPLER", [*B2, 0], z, x)
    rig.pin("C", "COUPLER", "ROCKER", [*C2, 0], z, x)
    rig.pin("D", "BASE", "ROCKER", [*D2, 0], z, x)
    sysm = rig.compile()
    q = np.radians(np.arange(0.0, 161.0))  # crank 40 .. 200 deg
    res = openimp.sweep(sysm, {"A": q})
    k = 140  # crank at 180 deg
    assert res.nsteps > k, res.message
    assert res.mobility[k] == 2
    assert len(res.fgc[k]) >= 1
    assert np.all(res.mobility[:k] == 1)
    assert_loops_close(rig, res)


def test_quality_minimal_at_change_point():
    """Book 6.8: the quality index collapses toward 0 at a singular posture.  At the
    parallelogram's change point (crank 180 deg, step 140 of 1 deg steps from
    40 deg) it must not exceed its value at the neighbouring steps."""
    a, b = 1.0, 2.5
    B2 = a * e2(40 * DEG)
    rig = Rig("parallelogram")
    z, x = (0, 0, 1), (1, 0, 0)
    rig.pin("A", "BASE", "CRANK", [0, 0, 0], z, x)
    rig.pin("B", "CRANK", "COUPLER", [*B2, 0], z, x)
    rig.pin("C", "COUPLER", "ROCKER", [B2[0] + b, B2[1], 0], z, x)
    rig.pin("D", "BASE", "ROCKER", [b, 0, 0], z, x)
    res = openimp.sweep(rig.compile(), {"A": np.radians(np.arange(130.0, 151.0))})
    k = 10
    assert res.mobility[k] == 2
    assert res.quality[k] <= min(res.quality[k - 1], res.quality[k + 1])


# =============================================================================
# Results interface
# =============================================================================


def test_result_table_and_accessors():
    """to_table() columns equal the accessors; iterations are positive."""
    rig, _ = build_fourbar(PLANAR, 1.0, 3.0, 2.5, 3.2, 40 * DEG)
    sysm = rig.compile()
    res = openimp.sweep(sysm, {"A": np.radians(np.arange(0.0, 30.0, 5.0))})
    t = res.to_table()
    assert len(t["step"]) == res.nsteps == 6
    np.testing.assert_array_equal(t["A.theta"], res.variable("A"))
    np.testing.assert_array_equal(t["quality"], res.quality)
    np.testing.assert_array_equal(t["mobility"], res.mobility)
    np.testing.assert_array_equal(res.joint("C")[:, 0], res.variable("C.theta"))
    assert np.all(res.iterations >= 1)


def test_structure_without_drivers():
    """A triangle of three pins is a structure (mobility 0): drivers={} with steps=N
    solves its one posture N times; without steps it is an input error."""
    m = Model("truss")
    m.add_joint("revolute", "J1", "BASE", "A1", origin=(0, 0, 0))
    m.add_joint("revolute", "J2", "A1", "A2", origin=(1, 1, 0))
    m.add_joint("revolute", "J3", "A2", "BASE", origin=(2, 0, 0))
    m.add_point("P", "A1", (0.5, 0.5, 0))
    s = openimp.compile(m)
    res = openimp.sweep(s, {}, steps=3)
    assert res.complete and res.nsteps == 3
    assert np.all(res.mobility == 0)
    np.testing.assert_allclose(res.point("P"), [[0.5, 0.5, 0.0]] * 3, atol=1e-14)
    with pytest.raises(InputError, match="steps"):
        openimp.sweep(s, {})


def _batch_fourbar(b: float, c: float) -> Model:
    """Crank 1, coupler b, rocker c, frame 3.2, drawn with the crank at 40 deg."""
    th = math.radians(40.0)
    A, D = np.zeros(3), np.array([3.2, 0.0, 0.0])
    B = np.array([math.cos(th), math.sin(th), 0.0])
    BD = D - B
    L = float(np.linalg.norm(BD))
    x = (b * b - c * c + L * L) / (2 * L)
    C = B + x * BD / L + math.sqrt(b * b - x * x) * np.array([-BD[1], BD[0], 0.0]) / L
    m = Model("batch")
    m.add_joint("revolute", "A", "BASE", "CRANK", origin=A)
    m.add_joint("revolute", "B", "CRANK", "COUPLER", origin=B)
    m.add_joint("revolute", "C", "COUPLER", "ROCKER", origin=C)
    m.add_joint("revolute", "D", "ROCKER", "BASE", origin=D)
    m.add_point("P", "COUPLER", (B + C) / 2)
    return m


def test_sweep_batch_equals_single_sweeps():
    """sweep_batch over variants (other coupler and rocker lengths, per-variant crank
    values) gives exactly what one sweep per variant gives; a variant of another
    topology, or with a point on another body, is an input error."""
    from openimp.kinematics import sweep_batch

    dims = [(3.0, 2.5), (3.1, 2.6), (2.9, 2.45)]
    systems = [openimp.compile(_batch_fourbar(b, c)) for b, c in dims]
    drv = np.radians(np.arange(1.0, 361.0))
    per_variant = np.stack([drv, -drv, 0.5 * drv])
    batch = sweep_batch(systems, {"A": per_variant})
    assert len(batch) == 3 and np.all(batch.solved == 360)
    for v, s in enumerate(systems):
        single = openimp.sweep(s, {"A": per_variant[v]})
        np.testing.assert_allclose(batch.q[v], single.q, rtol=0, atol=1e-12)
        np.testing.assert_allclose(batch[v].point("P"), single.point("P"), rtol=0, atol=1e-12)
    other = Model("other")
    other.add_joint("revolute", "A", "BASE", "CRANK", origin=(0, 0, 0))
    with pytest.raises(InputError, match="topology"):
        sweep_batch([systems[0], openimp.compile(other)], {"A": drv})
    # same joints and bodies, the point on another body: the packed int arrays differ
    moved = _batch_fourbar(3.0, 2.5)
    moved.points.clear()
    moved.add_point("P", "ROCKER", (2.0, 1.0, 0.0))
    with pytest.raises(InputError, match="variant 1"):
        sweep_batch([systems[0], openimp.compile(moved)], {"A": drv})


def test_replay_applies_the_inverse_of_the_pivoted_block():
    """The row operations kept by the elimination, replayed on a new right-hand side,
    give J11^-1 e in the pivot rows and e - J21 J11^-1 e elsewhere (numpy solve, 1e-12)."""
    from openimp.kinematics.elimination import eliminate, replay
    from openimp.system import DATA_FIELDS, KWork, allocate, views

    rng = np.random.default_rng(3)
    m, n = 6, 4
    J = rng.normal(size=(m, n))
    E = rng.normal(size=m)
    sgc = np.zeros(n, np.bool_)
    sgc[1] = True  # never pivoted: rank 3
    DP = allocate(DATA_FIELDS, dict(nb=1, nj=1, nq=n, m=m, nq1=n + 1, mq1=m + n + 1, kk=n,
                                    nd=0))
    d = KWork(*views(DATA_FIELDS, DP))
    d.J[...] = J
    d.E[...] = E
    rank, det, _ = eliminate(DP, sgc, 1e-12)
    T, prow, pcol = d.T, d.prow, d.pcol
    assert rank == 3 and 1 not in pcol[:rank]
    rows, cols = prow[:rank], pcol[:rank]
    J11 = J[np.ix_(rows, cols)]
    assert det == pytest.approx(abs(np.linalg.det(J11)), rel=1e-12)
    # the elimination's own right-hand side ...
    x = np.linalg.solve(J11, E[rows])
    np.testing.assert_allclose(T[rows, n], x, atol=1e-12)
    # ... and any other one, through the kept row operations
    e2 = rng.normal(size=m)
    e = e2.copy()
    replay(DP, rank, e)
    x2 = np.linalg.solve(J11, e2[rows])
    np.testing.assert_allclose(e[rows], x2, atol=1e-12)
    other = np.setdiff1d(np.arange(m), rows)
    np.testing.assert_allclose(e[other], e2[other] - J[np.ix_(other, cols)] @ x2, atol=1e-12)


def test_simplified_newton_steps_keep_the_accuracy_of_full_steps():
    """Positions-only sweeps finish most steps with simplified-Newton corrections
    (the last elimination replayed); sweeps with rates always end on a fresh
    Jacobian.  On the spatial RSSR (Euler-Rodrigues variables, a general kind) and
    in 10 deg steps both give the same postures to 1e-10 and close every loop."""
    g = rssr_geometry()
    th0 = 0.6
    _, B0, C0 = rssr_output(g, th0, +1)
    rig = Rig("rssr")
    rig.pin("A", "BASE", "CRANK", np.zeros(3), (0, 0, 1), (1, 0, 0))
    rig.ball("B", "CRANK", "COUPLER", B0)
    rig.ball("C", "COUPLER", "ROCKER", C0)
    rig.pin("D", "BASE", "ROCKER", g["D0"], g["w2"], g["u2"], ref2=C0 - g["D0"])
    sysm = rig.compile()
    q = np.radians(np.arange(0.0, 721.0, 10.0))
    fast = openimp.sweep(sysm, {"A": q})
    full = openimp.sweep(sysm, {"A": q}, rates={"A": 1.0})
    assert fast.complete and full.complete
    d = sysm.var_index("D")
    np.testing.assert_allclose(wrap(fast.q[:, d] - full.q[:, d]), 0.0, atol=1e-10)
    phi, _, _ = rssr_output(g, th0 + q, +1)
    assert np.max(np.abs(wrap(fast.variable("D") - phi))) < 1e-10
    assert_loops_close(rig, fast)


def test_sweep_refuses_solver_options_that_cannot_work():
    """tol <= 0, NaN, maxit <= 0 and the like are input errors naming the option, from
    sweep and sweep_batch, before anything is solved (not blamed on the mechanism)."""
    from openimp.kinematics import sweep_batch

    s = openimp.compile(_batch_fourbar(3.0, 2.5))
    drv = {"A": np.radians(np.arange(1.0, 5.0))}
    for kw, word in (({"tol": 0.0}, "tol"), ({"tol": float("nan")}, "tol"),
                     ({"pivot_tol": -1.0}, "pivot_tol"), ({"maxit": 0}, "maxit"),
                     ({"maxhalve": 1000}, "maxhalve")):
        with pytest.raises(InputError, match=word):
            openimp.sweep(s, drv, **kw)
        with pytest.raises(InputError, match=word):
            sweep_batch([s], drv, **kw)
