"""Velocity and acceleration analysis (book ch 7-8) against independent references.

References, all computed here with plain numpy (no openimp derivative code):

1. Central finite differences in time of the solved positions (joint
   variables, points, body postures) along a smooth motion over a full cycle.
   The stencil is the fourth-order central one,
   f'  ~ (-f[+2] + 8 f[+1] - 8 f[-1] + f[-2]) / (12 dt),
   f'' ~ (-f[+2] + 16 f[+1] - 30 f[0] + 16 f[-1] - f[-2]) / (12 dt^2),
   whose truncation error (dt^4) and round-off (eps / dt^2) are both near
   1e-9 of the signal at the dt used; the tolerance is 1e-6 relative (error
   divided by the largest magnitude of that quantity over the sweep).
   Body angular velocity and acceleration come from the rotation matrices:
   W = R' R^T, alpha~ = R'' R^T - W W.
2. Closed-form loop-equation derivatives of the planar four-bar (1e-9).
3. The book's Cardan/Hooke joint example (examples 5.1, 7.1-7.4, 8.1-8.4,
   values and formulas as corrected in the digest book-ch07-10.md section 7.1):
   printed values at their printed precision, corrected closed forms to 1e-9.
4. The rigid-body formulas v_P = v_O + w x r, a_P = a_O + alpha x r + w x (w x r)
   from the body results (1e-9).
5. Continuity across changes of the free generalized coordinates / pivot
   order, and flagging of singular postures (res.singular).
"""

from __future__ import annotations

import math
from collections import Counter

import numpy as np
import pytest

import openimp
from openimp import Model

DEG = math.pi / 180.0
FD_TOL = 1e-6
CF_TOL = 1e-9
PRINTED = 5.0e-7 + 1e-12  # half a unit in the 6th decimal: the book's printed precision

# =============================================================================
# Finite-difference helpers (numpy only)
# =============================================================================


def fd4(f: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Fourth-order central first and second differences at the interior steps 2..n-3."""
    v = (-f[4:] + 8.0 * f[3:-1] - 8.0 * f[1:-3] + f[:-4]) / (12.0 * dt)
    a = (-f[4:] + 16.0 * f[3:-1] - 30.0 * f[2:-2] + 16.0 * f[1:-3] - f[:-4]) / (12.0 * dt * dt)
    return v, a


def inner(x: np.ndarray) -> np.ndarray:
    """The steps where fd4 gives values."""
    return x[2:-2]


def relerr(x: np.ndarray, ref: np.ndarray, floor: float = 0.0) -> float:
    """max |x - ref| / max |ref| (the relative error used throughout).

    ``floor``: the scale to use when the reference vanishes (a body that does
    not turn), typically the largest joint rate of the sweep.
    """
    scale = max(float(np.max(np.abs(ref))), floor)
    assert scale > 0.0, "reference is identically zero: the check would be vacuous"
    return float(np.max(np.abs(x - ref))) / scale


def axial(M: np.ndarray) -> np.ndarray:
    return np.stack([M[..., 2, 1], M[..., 0, 2], M[..., 1, 0]], axis=-1)


def body_rates_fd(T: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Angular velocity and acceleration vectors from differences of rotation matrices."""
    R = T[:, :3, :3]
    Rd, Rdd = fd4(R, dt)
    Rt = np.swapaxes(inner(R), 1, 2)
    W = Rd @ Rt
    Al = Rdd @ Rt - W @ W
    return axial(W), axial(Al)


def smooth_drive(t: np.ndarray, start: float, travel: float, wobble: float):
    """q = start + travel t + wobble sin(2 pi t) and its two time derivatives.

    A full crank turn for travel = 2 pi with a non-zero driver acceleration.
    """
    w = 2.0 * math.pi
    q = start + travel * t + wobble * np.sin(w * t)
    qd = travel + wobble * w * np.cos(w * t)
    qdd = -wobble * w * w * np.sin(w * t)
    return q, qd, qdd


def check_against_fd(
    res, dt: float, *, points=(), bodies=(), variables=None, mask=None, tol: float = FD_TOL
) -> dict[str, float]:
    """Compare every rate of a sweep with finite differences of its positions.

    ``variables``: column indices of q to compare (default all); ``mask``:
    boolean over the interior steps (default all).  Returns the errors.
    """
    errs: dict[str, float] = {}
    sel = slice(None) if mask is None else mask
    cols = slice(None) if variables is None else list(variables)
    v, a = fd4(res.q, dt)
    errs["qd"] = relerr(v[sel][:, cols], inner(res.qd)[sel][:, cols])
    errs["qdd"] = relerr(a[sel][:, cols], inner(res.qdd)[sel][:, cols])
    for p in points:
        v, a = fd4(res.point(p), dt)
        errs[f"v({p})"] = relerr(v[sel], inner(res.point_velocity(p))[sel])
        errs[f"a({p})"] = relerr(a[sel], inner(res.point_acceleration(p))[sel])
    wfloor = float(np.max(np.abs(res.qd)))
    afloor = float(np.max(np.abs(res.qdd)))
    for b in bodies:
        T = res.posture(b)
        w, al = body_rates_fd(T, dt)
        errs[f"omega({b})"] = relerr(w[sel], inner(res.angular_velocity(b))[sel], wfloor)
        errs[f"alpha({b})"] = relerr(al[sel], inner(res.angular_acceleration(b))[sel], afloor)
        # (a body frame whose origin lies on a fixed axis has v_O = 0: scale by
        # the largest joint rate times the size of the model instead)
        v, a = fd4(T[:, :3, 3], dt)
        vo, ao = inner(res.origin_velocity(b))[sel], inner(res.origin_acceleration(b))[sel]
        Ls = res.system.length_scale
        errs[f"vO({b})"] = relerr(v[sel], vo, wfloor * Ls)
        errs[f"aO({b})"] = relerr(a[sel], ao, afloor * Ls)
        # the 4x4 operators: T' = omega T and T'' = (alpha + omega omega) T (7.23, 8.54)
        Td, Tdd = fd4(T, dt)
        om = inner(res.velocity_operator(b))[sel]
        alo = inner(res.acceleration_operator(b))[sel]
        Ti = inner(T)[sel]
        errs[f"Tdot({b})"] = relerr(Td[sel], om @ Ti)
        errs[f"Tddot({b})"] = relerr(Tdd[sel], (alo + om @ om) @ Ti)
    bad = {k: e for k, e in errs.items() if not e < tol}
    assert not bad, f"rates disagree with finite differences (tol {tol:g}): {bad}"
    return errs


# =============================================================================
# Mechanisms (geometry computed here)
# =============================================================================


def circle_pt(P: np.ndarray, Q: np.ndarray, rp: float, rq: float) -> np.ndarray:
    """Intersection of circle(P, rp) and circle(Q, rq) left of P->Q (planar, xy)."""
    PQ = Q - P
    L = float(np.linalg.norm(PQ))
    x = (rp * rp - rq * rq + L * L) / (2.0 * L)
    y = math.sqrt(rp * rp - x * x)
    ex = PQ / L
    ey = np.array([-ex[1], ex[0], 0.0])
    return P + x * ex + y * ey


def fourbar(a=1.0, b=3.0, c=2.5, d=3.2, th0=40 * DEG):
    """Crank A (BASE->CRANK at the origin), coupler B-C, rocker C-D, ground A-D on x.

    Joint A's variable is the crank angle measured from th0.
    """
    A = np.zeros(3)
    D = np.array([d, 0.0, 0.0])
    B = A + a * np.array([math.cos(th0), math.sin(th0), 0.0])
    C = circle_pt(B, D, b, c)
    m = Model("fourbar")
    m.add_joint("revolute", "A", "BASE", "CRANK", origin=A)
    m.add_joint("revolute", "B", "CRANK", "COUPLER", origin=B)
    m.add_joint("revolute", "C", "COUPLER", "ROCKER", origin=C)
    m.add_joint("revolute", "D", "ROCKER", "BASE", origin=D)
    m.add_point("P", "COUPLER", (B + C) / 2 + [0.0, 0.5, 0.2])
    m.add_point("Q", "ROCKER", (C + D) / 2 + [0.1, -0.2, 0.0])
    return m, dict(A=A, B=B, C=C, D=D)


def slider_crank(a=1.0, b=3.5, e=0.4, th0=30 * DEG):
    """Offset slider-crank: crank A, rod B-C, slider on the line y = e (prismatic D along x)."""
    B = a * np.array([math.cos(th0), math.sin(th0), 0.0])
    C = np.array([B[0] + math.sqrt(b * b - (B[1] - e) ** 2), e, 0.0])
    m = Model("slider-crank")
    m.add_joint("revolute", "A", "BASE", "CRANK", origin=(0, 0, 0))
    m.add_joint("revolute", "B", "CRANK", "ROD", origin=B)
    m.add_joint("revolute", "C", "ROD", "SLIDER", origin=C)
    m.add_joint("prismatic", "D", "BASE", "SLIDER", origin=C, axis=(1, 0, 0), ref=(0, 1, 0))
    m.add_point("P", "ROD", 0.4 * B + 0.6 * C + [0.0, 0.3, 0.1])
    m.add_point("S", "SLIDER", C + np.array([0.2, 0.1, 0.0]))
    return m


def rssr():
    """Spatial RSSR: crank about z at the origin (radius 1), coupler of length 3
    between two ball joints, rocker of radius 1.5 about the x axis through (0, 3, 0).

    Full crank revolution: |C(gamma) - B(theta)|^2 = 3.25 - 3 sin(theta) at
    gamma = 0 and 21.25 - 9 sin(theta) at gamma = pi bracket 9 for every theta.
    The coupler's spin about B-C is a passive freedom (no point on it).
    """
    g = math.acos(3.25 / 9.0)
    B = np.array([1.0, 0.0, 0.0])
    D = np.array([0.0, 3.0, 0.0])
    C = D + 1.5 * np.array([0.0, -math.cos(g), math.sin(g)])
    m = Model("rssr")
    m.add_joint("revolute", "A", "BASE", "CRANK", origin=(0, 0, 0), axis=(0, 0, 1))
    m.add_joint("sphere", "B", "CRANK", "COUPLER", origin=B)
    m.add_joint("sphere", "C", "COUPLER", "ROCKER", origin=C)
    m.add_joint("revolute", "D", "ROCKER", "BASE", origin=D, axis=(1, 0, 0), ref=(0, 1, 0))
    m.add_point("P", "ROCKER", C + np.array([0.2, 0.3, -0.1]))
    m.add_point("K", "CRANK", [0.5, 0.3, 0.4])
    return m


def hooke_book(beta=150 * DEG, h=1.0, psi=30 * DEG, d1=1.0, d2=1.0, r2=(0.3, 0.2, 0.1)):
    """Example 5.1 built from the book's shape matrices at the posture psi.

    Bodies 1 OUT (output shaft), 2 CROSS, 3 IN (input shaft), 4 BASE; joints
    A 4->1, B 1->2, C 2->3, D 3->4, all revolute.  Body frames are the book's
    T_0b at psi (closed form, closure sin(phi_B) < 0), joint frames
    T_0b S_bh; the point R is r_2 on the cross.  Returns (model, phi, T_0b).
    """
    sb, cb = math.sin(beta), math.cos(beta)
    sp, cp = math.sin(psi), math.cos(psi)
    pA = math.atan2(-sp * cb, cp)
    pB = -math.acos(sp * sb)
    pC = math.atan2(1.0, cp * math.tan(beta))

    def M(rows):
        return np.array(rows, dtype=float)

    S = {
        (4, "A"): M([[0, 0, 1, d1], [1, 0, 0, h], [0, 1, 0, 0], [0, 0, 0, 1]]),
        (1, "A"): M([[0, 0, 1, d1], [0, -1, 0, 0], [1, 0, 0, 0], [0, 0, 0, 1]]),
        (1, "B"): M([[0, 1, 0, 0], [0, 0, 1, 0], [1, 0, 0, 0], [0, 0, 0, 1]]),
        (2, "B"): np.eye(4),
        (2, "C"): M([[0, 1, 0, 0], [0, 0, 1, 0], [1, 0, 0, 0], [0, 0, 0, 1]]),
        (3, "C"): M([[0, 0, 1, 0], [0, -1, 0, 0], [1, 0, 0, 0], [0, 0, 0, 1]]),
        (3, "D"): M([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, d2], [0, 0, 0, 1]]),
        (4, "D"): M([[0, -sb, cb, d2 * cb], [1, 0, 0, h], [0, cb, sb, d2 * sb], [0, 0, 0, 1]]),
    }
    sA, cA, sB, cB, sC, cC = (math.sin(pA), math.cos(pA), math.sin(pB), math.cos(pB),
                              math.sin(pC), math.cos(pC))
    T41 = M([[1, 0, 0, 0], [0, sA, cA, h], [0, -cA, sA, 0], [0, 0, 0, 1]])
    T12 = M([[sB, cB, 0, 0], [0, 0, 1, 0], [cB, -sB, 0, 0], [0, 0, 0, 1]])
    T23 = M([[0, -cC, sC, 0], [1, 0, 0, 0], [0, sC, cC, 0], [0, 0, 0, 1]])
    T = {4: np.eye(4), 1: T41}
    T[2] = T[1] @ T12
    T[3] = T[2] @ T23
    names = {1: "OUT", 2: "CROSS", 3: "IN", 4: "BASE"}
    m = Model("cardan")
    for b in (1, 2, 3):
        m.add_body(names[b])
        m.set_body_frame(names[b], T[b])
    for j, (bm, bp) in {"A": (4, 1), "B": (1, 2), "C": (2, 3), "D": (3, 4)}.items():
        m.add_joint("revolute", j, names[bm], names[bp],
                    frame1=T[bm] @ S[bm, j], frame2=T[bp] @ S[bp, j])
    m.add_point("R", "CROSS", (T[2] @ np.r_[r2, 1.0])[:3])
    m.add_point("O1", "OUT", (T[1] @ np.array([0.7, -0.4, 0.5, 1.0]))[:3])
    return m, np.array([pA, pB, pC, psi]), T


def fivebar(l1=1.0, l2=3.0, l3=3.2, l4=1.2, d=4.0, th1=60 * DEG, th4=110 * DEG):
    """Planar five-bar: cranks A (at the origin) and E (at (d, 0)), couplers B-C-D."""
    A = np.zeros(3)
    E = np.array([d, 0.0, 0.0])
    B = A + l1 * np.array([math.cos(th1), math.sin(th1), 0.0])
    D = E + l4 * np.array([math.cos(th4), math.sin(th4), 0.0])
    C = circle_pt(B, D, l2, l3)
    m = Model("fivebar")
    m.add_joint("revolute", "A", "BASE", "L1", origin=A)
    m.add_joint("revolute", "B", "L1", "L2", origin=B)
    m.add_joint("revolute", "C", "L2", "L3", origin=C)
    m.add_joint("revolute", "D", "L3", "L4", origin=D)
    m.add_joint("revolute", "E", "L4", "BASE", origin=E)
    m.add_point("P", "L2", (B + C) / 2 + [0.1, 0.4, 0.3])
    m.add_point("Q", "L3", C + np.array([0.2, 0.1, 0.0]))
    return m


def ground_is_still(res, ground="BASE") -> None:
    """omega and alpha of the fixed body are zero (digest section 8)."""
    assert np.all(res.velocity_operator(ground) == 0.0)
    assert np.all(res.acceleration_operator(ground) == 0.0)


# =============================================================================
# 1. Finite differences in time over a full motion
# =============================================================================

N_FD = 2001  # dt = 5e-4 over one cycle of unit duration


def test_fd_fourbar_full_revolution():
    """Crank-rocker a=1, b=3, c=2.5, d=3.2, crank turned once with
    q_A = 2 pi t + 0.4 sin(2 pi t), t in [0, 1]."""
    s = openimp.compile(fourbar()[0])
    t = np.linspace(0.0, 1.0, N_FD)
    q, qd, qdd = smooth_drive(t, 0.0, 2 * math.pi, 0.4)
    res = openimp.sweep(s, {"A": q}, {"A": qd}, {"A": qdd})
    assert res.complete, res.message
    np.testing.assert_array_equal(res.variable("A"), q)
    np.testing.assert_array_equal(res.joint_velocity("A")[:, 0], qd)
    np.testing.assert_array_equal(res.joint_acceleration("A")[:, 0], qdd)
    check_against_fd(res, t[1] - t[0], points=("P", "Q"), bodies=("CRANK", "COUPLER", "ROCKER"))
    ground_is_still(res)
    assert not res.singular.any()
    assert np.max(res.consistency) < 1e-9


def test_fd_slider_crank_full_revolution():
    """Offset slider-crank (a=1, b=3.5, e=0.4): joint rates including the slide,
    rod and slider bodies, points on both."""
    s = openimp.compile(slider_crank())
    t = np.linspace(0.0, 1.0, N_FD)
    q, qd, qdd = smooth_drive(t, 0.0, 2 * math.pi, 0.4)
    res = openimp.sweep(s, {"A": q}, {"A": qd}, {"A": qdd})
    assert res.complete, res.message
    check_against_fd(res, t[1] - t[0], points=("P", "S"), bodies=("CRANK", "ROD", "SLIDER"))
    # the slider only translates along x
    assert np.max(np.abs(res.angular_velocity("SLIDER"))) == 0.0
    v = res.joint_velocity("D")[:, 0]
    np.testing.assert_allclose(res.origin_velocity("SLIDER")[:, 0], v, rtol=0,
                               atol=1e-12 * np.max(np.abs(v)))
    assert not res.singular.any()


def test_fd_rssr_full_revolution():
    """Spatial RSSR with ball joints, the coupler's spin about B-C held (a passive
    freedom: the sweep holds the free coordinate that carries it).

    Everything is compared with finite differences at every step: crank and
    rocker angles, the Euler-Rodrigues rates of both balls, all three bodies
    (the coupler's rates include the held spin, so they are consistent only if
    the same coordinate is held all along), points on crank and rocker.  The
    held coordinate keeps its value and has zero rates; the Euler-Rodrigues
    rates keep the parameters on the unit sphere: e.e' = 0, e.e'' = -e'.e'.
    """
    s = openimp.compile(rssr())
    assert s.var_names[0] == "A.theta" and s.var_names[-1] == "D.theta"
    t = np.linspace(0.0, 1.0, N_FD)
    dt = t[1] - t[0]
    q, qd, qdd = smooth_drive(t, 0.0, 2 * math.pi, 0.4)
    res = openimp.sweep(s, {"A": q}, {"A": qd}, {"A": qdd})
    assert res.complete, res.message
    assert np.all(res.mobility == 2)  # the drive and the passive spin
    fg = {tuple(x) for x in res.fgc}
    assert len(fg) == 1 and len(next(iter(fg))) == 1, fg
    held = s.var_index(next(iter(fg))[0])
    assert np.ptp(res.q[:, held]) < 1e-12
    assert np.all(res.qd[:, held] == 0.0) and np.all(res.qdd[:, held] == 0.0)
    check_against_fd(res, dt, points=("P", "K"), bodies=("CRANK", "COUPLER", "ROCKER"))
    for j in ("B", "C"):
        e, ed, edd = res.joint(j), res.joint_velocity(j), res.joint_acceleration(j)
        assert np.max(np.abs(np.sum(e * ed, axis=1))) < 1e-9 * np.max(np.abs(ed))
        assert np.max(np.abs(np.sum(e * edd, axis=1) + np.sum(ed * ed, axis=1))) \
            < 1e-9 * np.max(np.abs(edd))
    ground_is_still(res)
    assert not res.singular.any()


def test_fd_hooke_full_revolution():
    """Cardan coupling of example 5.1 (beta = 150 deg, h = 1), input shaft turned
    once with psi = 30 deg + 2 pi t + 0.3 sin(2 pi t)."""
    m, phi, _ = hooke_book()
    s = openimp.compile(m)
    t = np.linspace(0.0, 1.0, N_FD)
    q, qd, qdd = smooth_drive(t, phi[3], 2 * math.pi, 0.3)
    res = openimp.sweep(s, {"D": q}, {"D": qd}, {"D": qdd})
    assert res.complete, res.message
    check_against_fd(res, t[1] - t[0], points=("R", "O1"), bodies=("OUT", "CROSS", "IN"))
    ground_is_still(res)
    assert not res.singular.any()


# =============================================================================
# 2. Four-bar: closed-form derivatives of the loop equations
# =============================================================================


@pytest.mark.parametrize(
    "dims",
    [(1.0, 3.0, 2.5, 3.2, 40.0), (3.0, 3.5, 3.2, 1.0, 75.0)],
    ids=["crank-rocker", "drag-link"],
)
def test_fourbar_closed_form_rates(dims):
    """a cos t2 + b cos t3 - c cos t4 - d = 0 and a sin t2 + b sin t3 - c sin t4 = 0.

    Once: [-b s3, c s4; b c3, -c c4] [w3, w4] = [a s2 w2, -a c2 w2].
    Twice: the same matrix times [al3, al4] = [a (c2 w2^2 + s2 al2) + b c3 w3^2 - c c4 w4^2,
                                               a (s2 w2^2 - c2 al2) + b s3 w3^2 - c s4 w4^2].
    t3, t4 come from the closed-form posture (circle intersection on the
    modeling branch), w2 and al2 are the driver's.  Compared: coupler and
    rocker angular velocity and acceleration (z components; x, y are zero),
    and the joint rates B = w3 - w2, C = w4 - w3 and D = -w4 (D is ROCKER->BASE).
    """
    a, b, c, d, th0 = dims
    th0 *= DEG
    m, _ = fourbar(a, b, c, d, th0)
    s = openimp.compile(m)
    t = np.linspace(0.0, 1.0, 361)
    q, w2, al2 = smooth_drive(t, 0.0, 2 * math.pi, 0.5)
    w2 = w2 * 1.7
    al2 = al2 * 1.7 - 3.0  # decelerating on top of the wobble
    res = openimp.sweep(s, {"A": q}, {"A": w2}, {"A": al2})
    assert res.complete, res.message
    t2 = th0 + q
    Bp = np.stack([a * np.cos(t2), a * np.sin(t2), 0 * t2], axis=1)
    Dp = np.array([d, 0.0, 0.0])
    Cp = np.array([circle_pt(Bk, Dp, b, c) for Bk in Bp])
    t3 = np.arctan2(Cp[:, 1] - Bp[:, 1], Cp[:, 0] - Bp[:, 0])
    t4 = np.arctan2(Cp[:, 1], Cp[:, 0] - d)
    s2, c2, s3, c3, s4, c4 = np.sin(t2), np.cos(t2), np.sin(t3), np.cos(t3), np.sin(t4), np.cos(t4)
    Mx = np.empty((t.size, 2, 2))
    Mx[:, 0, 0], Mx[:, 0, 1], Mx[:, 1, 0], Mx[:, 1, 1] = -b * s3, c * s4, b * c3, -c * c4
    rhs = np.stack([a * s2 * w2, -a * c2 * w2], axis=1)
    w3, w4 = np.linalg.solve(Mx, rhs[..., None])[..., 0].T
    rhs2 = np.stack([a * (c2 * w2**2 + s2 * al2) + b * c3 * w3**2 - c * c4 * w4**2,
                     a * (s2 * w2**2 - c2 * al2) + b * s3 * w3**2 - c * s4 * w4**2], axis=1)
    al3, al4 = np.linalg.solve(Mx, rhs2[..., None])[..., 0].T
    # residuals of the differentiated loop equations (the reference itself)
    assert np.max(np.abs(-a * s2 * w2 - b * s3 * w3 + c * s4 * w4)) < 1e-10
    # the posture matches the closed form (so both sides talk about the same branch)
    R3 = res.posture("COUPLER")
    ang3 = np.arctan2(R3[:, 1, 0], R3[:, 0, 0]) + math.atan2(*(Cp[0] - Bp[0])[1::-1])
    assert np.max(np.abs(np.angle(np.exp(1j * (ang3 - t3))))) < 1e-9
    wC, aC = res.angular_velocity("COUPLER"), res.angular_acceleration("COUPLER")
    wR, aR = res.angular_velocity("ROCKER"), res.angular_acceleration("ROCKER")
    for x in (wC, aC, wR, aR):
        assert np.max(np.abs(x[:, :2])) == 0.0
    assert relerr(wC[:, 2], w3) < CF_TOL
    assert relerr(wR[:, 2], w4) < CF_TOL
    assert relerr(aC[:, 2], al3) < CF_TOL
    assert relerr(aR[:, 2], al4) < CF_TOL
    qd, qdd = res.qd, res.qdd
    assert relerr(qd[:, 1], w3 - w2) < CF_TOL
    assert relerr(qd[:, 2], w4 - w3) < CF_TOL
    assert relerr(qd[:, 3], -w4) < CF_TOL
    assert relerr(qdd[:, 1], al3 - al2) < CF_TOL
    assert relerr(qdd[:, 2], al4 - al3) < CF_TOL
    assert relerr(qdd[:, 3], -al4) < CF_TOL


# =============================================================================
# 3. The book's Cardan/Hooke joint: examples 7.1-7.4 and 8.1-8.4
# =============================================================================


def _mat(rows: str) -> np.ndarray:
    """A 4x4 printed as 'a b c d; e f g h; ...' (a trailing '0' row is the zero row)."""
    out = np.zeros((4, 4))
    for i, r in enumerate(rows.split(";")):
        vals = [float(x) for x in r.split()]
        if len(vals) == 4:
            out[i] = vals
    return out


@pytest.fixture(scope="module")
def cardan_30():
    """The digest's numeric point: beta = 150 deg, h = 1, psi = 30 deg (d1 = d2 = 1)."""
    m, _, _ = hooke_book()
    s = openimp.compile(m)
    psi = 30 * DEG
    unit = openimp.sweep(s, {"D": [psi]}, {"D": 1.0}, {"D": 0.0})  # rates = phi', accels = phi''
    book = openimp.sweep(s, {"D": [psi]}, {"D": 2.0}, {"D": 0.5})  # psi' = 2, psi'' = 0.5
    return s, unit, book


def test_cardan_example_values_positions(cardan_30):
    """Example 5.1 at the numeric point: phi, the quality index sqrt(s2), T_01..T_03, R."""
    _, unit, _ = cardan_30
    assert unit.complete
    phi = np.array([0.463648, -1.318116, 2.034444, 0.523599])
    assert np.max(np.abs(unit.q[0] - phi)) < PRINTED
    assert np.max(np.abs(np.degrees(unit.q[0]) - [26.565051, -75.522488, 116.565051, 30.0])) \
        < PRINTED
    assert abs(unit.quality[0] - 0.968246) < PRINTED
    T01 = _mat("1 0 0 0; 0 0.447214 0.894427 1; 0 -0.894427 0.447214 0; 0 0 0 1")
    T02 = _mat("-0.968246 0.25 0 0; 0.223607 0.866025 0.447214 1; "
               "0.111803 0.433013 -0.894427 0; 0 0 0 1")
    T03 = _mat("0.25 -0.433013 -0.866025 0; 0.866025 0.5 0 1; 0.433013 -0.75 0.5 0; 0 0 0 1")
    for b, T in (("OUT", T01), ("CROSS", T02), ("IN", T03)):
        assert np.max(np.abs(unit.posture(b)[0] - T)) < PRINTED, b
    assert np.max(np.abs(unit.point("R")[0] - [-0.240474, 1.285008, 0.030701])) < PRINTED


def test_cardan_examples_7_first_derivatives(cardan_30):
    """Examples 7.1-7.4: phi', W_{b,1} (rates with psi' = 1), D_h recovered from W,
    and phi' psi' (example 7.2), omega_2 = W_{2,1} psi' (example 7.4), R' for psi' = 2."""
    _, unit, book = cardan_30
    assert np.max(np.abs(unit.qd[0] - [0.923760, 0.447214, -0.230940, 1.0])) < PRINTED
    W1 = _mat("0 0 0 0; 0 0 -0.923760 0; 0 0.923760 0 -0.923760; 0")
    W2 = _mat("0 0.4 0.2 -0.4; -0.4 0 -0.923760 0; -0.2 0.923760 0 -0.923760; 0")
    W3 = _mat("0 0.5 0 -0.5; -0.5 0 -0.866025 0; 0 0.866025 0 -0.866025; 0")
    got = {b: unit.velocity_operator(b)[0] for b in ("OUT", "CROSS", "IN", "BASE")}
    assert np.max(np.abs(got["OUT"] - W1)) < PRINTED
    assert np.max(np.abs(got["CROSS"] - W2)) < PRINTED
    assert np.max(np.abs(got["IN"] - W3)) < PRINTED
    assert np.all(got["BASE"] == 0.0)
    # W_{b,1} = sum over the path of D_h phi'_h (7.20): D_h from consecutive W's
    ph = unit.qd[0]
    D_A = _mat("0 0 0 0; 0 0 -1 0; 0 1 0 -1; 0")
    D_B = _mat("0 0.894427 0.447214 -0.894427; -0.894427 0 0 0; -0.447214 0 0 0; 0")
    D_C = _mat("0 -0.433013 0.866025 0.433013; 0.433013 0 -0.25 0; -0.866025 0.25 0 -0.25; 0")
    D_D = _mat("0 -0.5 0 0.5; 0.5 0 0.866025 0; 0 -0.866025 0 0.866025; 0")
    assert np.max(np.abs(got["OUT"] / ph[0] - D_A)) < 2 * PRINTED
    assert np.max(np.abs((got["CROSS"] - got["OUT"]) / ph[1] - D_B)) < 2 * PRINTED
    assert np.max(np.abs((got["IN"] - got["CROSS"]) / ph[2] - D_C)) < 2 * PRINTED
    assert np.max(np.abs(-got["IN"] - D_D)) < PRINTED  # W_{3,1} = -D_D
    # psi' = 2, psi'' = 0.5
    assert np.max(np.abs(book.qd[0] - [1.847521, 0.894427, -0.461880, 2.0])) < PRINTED
    om2 = _mat("0 0.8 0.4 -0.8; -0.8 0 -1.847521 0; -0.4 1.847521 0 -1.847521; 0")
    assert np.max(np.abs(book.velocity_operator("CROSS")[0] - om2)) < PRINTED
    assert np.max(np.abs(book.point_velocity("R")[0] - [0.240287, 0.135659, 0.622749])) \
        < PRINTED


def test_cardan_examples_8_second_derivatives(cardan_30):
    """Examples 8.1-8.4 (corrected): phi'', A_{b,1,1} (accelerations with psi' = 1,
    psi'' = 0), C''_{1,1,1} = sum_h D_h phi''_h (8.33), and for psi' = 2, psi'' = 0.5:
    phi'', alpha_2, alpha_3 = 0.5 W_{3,1}, R''."""
    _, unit, book = cardan_30
    assert np.max(np.abs(unit.qdd[0] - [0.213333, -0.206559, -0.453333, 0.0])) < PRINTED
    A1 = _mat("0 0 0 0; 0 0 -0.213333 0; 0 0.213333 0 -0.213333; 0")
    A2 = _mat("0 -0.369504 0.277128 0.369504; 0.369504 0 -0.213333 0; "
              "-0.277128 0.213333 0 -0.213333; 0")
    assert np.max(np.abs(unit.acceleration_operator("OUT")[0] - A1)) < PRINTED
    assert np.max(np.abs(unit.acceleration_operator("CROSS")[0] - A2)) < PRINTED
    assert np.max(np.abs(unit.acceleration_operator("IN")[0])) < 1e-12  # A_{3,1,1} = 0
    assert np.all(unit.acceleration_operator("BASE")[0] == 0.0)
    # C''_{1,1,1} = sum_h L(1,h) D_h phi''_{h,1,1}, L = [1 1 1 1]
    W = {b: unit.velocity_operator(b)[0] for b in ("OUT", "CROSS", "IN")}
    ph, phh = unit.qd[0], unit.qdd[0]
    D = [W["OUT"] / ph[0], (W["CROSS"] - W["OUT"]) / ph[1], (W["IN"] - W["CROSS"]) / ph[2],
         -W["IN"]]
    C = sum(Dh * p for Dh, p in zip(D, phh))
    Cbook = _mat("0 0.011547 -0.484974 -0.011547; -0.011547 0 -0.1 0; "
                 "0.484974 0.1 0 -0.1; 0")
    assert np.max(np.abs(C - Cbook)) < 2 * PRINTED
    assert np.max(np.abs(C[:3, :3] + C[:3, :3].T)) < 1e-12  # problem 8.2: skew
    assert unit.consistency[0] < 1e-12  # (8.45)
    # psi' = 2, psi'' = 0.5
    assert np.max(np.abs(book.qdd[0] - [1.315214, -0.602630, -1.928803, 0.5])) < PRINTED
    al2 = _mat("0 -1.278017 1.208513 1.278017; 1.278017 0 -1.315214 0; "
               "-1.208513 1.315214 0 -1.315214; 0")
    assert np.max(np.abs(book.acceleration_operator("CROSS")[0] - al2)) < PRINTED
    W3 = _mat("0 0.5 0 -0.5; -0.5 0 -0.866025 0; 0 0.866025 0 -0.866025; 0")
    assert np.max(np.abs(book.acceleration_operator("IN")[0] - 0.5 * W3)) < PRINTED
    assert np.max(np.abs(book.point_acceleration("R")[0] - [0.030483, -1.690478, 0.819980])) \
        < PRINTED


@pytest.mark.parametrize("beta_deg,h", [(150.0, 1.0), (120.0, 0.6)])
def test_cardan_corrected_closed_forms_over_a_turn(beta_deg, h):
    """The digest's corrected closed forms (s2 = 1 - sin^2 b sin^2 psi), over a
    whole turn of psi with per-step psi' and psi'':

    phi' = [-cb/s2, sb cpsi/sqrt(s2), sb cb spsi/s2, 1],
    phi'' = (sb cb/s2^2)[-2 sb spsi cpsi, -sqrt(s2) cb spsi, (1 + sb^2 spsi^2) cpsi, 0],
    W_{1,1}, W_{2,1} (corrected (3,1) sign), W_{3,1}, A_{1,1,1} (corrected),
    A_{2,1,1} (corrected), A_{3,1,1} = 0; then phi. = phi' psi', phi.. = phi' psi'' +
    phi'' psi'^2, omega_b = W_b psi', alpha_b = W_b psi'' + A_b psi'^2; Q = sqrt(s2).
    """
    beta = beta_deg * DEG
    m, phi, _ = hooke_book(beta=beta, h=h, d1=2.0, d2=0.7)
    s = openimp.compile(m)
    psi = phi[3] + np.linspace(0.0, 2 * math.pi, 145)
    pd = 1.3 + 0.8 * np.sin(3 * psi)
    pdd = -2.1 + 1.5 * np.cos(psi)
    res = openimp.sweep(s, {"D": psi}, {"D": pd}, {"D": pdd})
    assert res.complete, res.message
    sb, cb = math.sin(beta), math.cos(beta)
    sp, cp = np.sin(psi), np.cos(psi)
    s2 = 1.0 - sb**2 * sp**2
    r2 = np.sqrt(s2)
    z = np.zeros_like(psi)
    one = np.ones_like(psi)
    p1 = np.stack([-cb / s2, sb * cp / r2, sb * cb * sp / s2, one], axis=1)
    p2 = (sb * cb / s2**2)[:, None] * np.stack(
        [-2 * sb * sp * cp, -r2 * cb * sp, (1 + sb**2 * sp**2) * cp, z], axis=1)

    def stack(rows):
        return np.stack([np.stack(r, axis=-1) for r in rows], axis=-2)

    s2p, c2p = np.sin(2 * psi), np.cos(2 * psi)
    M1 = stack([[z, z, z, z], [z, z, one, z], [z, -one, z, h * one], [z, z, z, z]])
    W1 = (cb / s2)[:, None, None] * M1
    W2 = (1 / s2)[:, None, None] * stack([
        [z, sb * cp**2, -sb * cb * sp * cp, -h * sb * cp**2],
        [-sb * cp**2, z, cb * one, z],
        [sb * cb * sp * cp, -cb * one, z, h * cb * one],
        [z, z, z, z]])
    W3 = np.broadcast_to(_mat(f"0 {sb} 0 {-h * sb}; {-sb} 0 {cb} 0; 0 {-cb} 0 {h * cb}; 0"),
                         (psi.size, 4, 4))
    A1 = (sb**2 * cb * s2p / s2**2)[:, None, None] * M1
    g = c2p + sb**2 * sp**2
    A2 = (sb * cb / s2**2)[:, None, None] * stack([
        [z, -cb * s2p, -g, h * cb * s2p],
        [cb * s2p, z, sb * s2p, z],
        [g, -sb * s2p, z, h * sb * s2p],
        [z, z, z, z]])
    assert relerr(res.quality, r2) < CF_TOL
    qd_ref = p1 * pd[:, None]
    qdd_ref = p1 * pdd[:, None] + p2 * (pd**2)[:, None]
    assert relerr(res.qd, qd_ref) < CF_TOL
    assert relerr(res.qdd, qdd_ref) < CF_TOL
    for b, W, A in (("OUT", W1, A1), ("CROSS", W2, A2), ("IN", W3, 0 * W3)):
        om = W * pd[:, None, None]
        al = W * pdd[:, None, None] + A * (pd**2)[:, None, None]
        assert relerr(res.velocity_operator(b), om) < CF_TOL, b
        assert relerr(res.acceleration_operator(b), al) < CF_TOL, b


# =============================================================================
# 4. Rigid-body formulas for points
# =============================================================================


def _assert_rigid_body(res, body: str, point: str) -> None:
    R = res.point(point)
    T = res.posture(body)
    r = R - T[:, :3, 3]
    w, al = res.angular_velocity(body), res.angular_acceleration(body)
    vO, aO = res.origin_velocity(body), res.origin_acceleration(body)
    vP, aP = res.point_velocity(point), res.point_acceleration(point)
    v_ref = vO + np.cross(w, r)
    a_ref = aO + np.cross(al, r) + np.cross(w, np.cross(w, r))
    assert relerr(vP, v_ref) < CF_TOL, (body, point)
    assert relerr(aP, a_ref) < CF_TOL, (body, point)
    # and the angular parts are the skew blocks of the operators
    om, alo = res.velocity_operator(body), res.acceleration_operator(body)
    assert np.max(np.abs(om[:, :3, :3] + np.swapaxes(om[:, :3, :3], 1, 2))) < 1e-12
    assert np.max(np.abs(alo[:, :3, :3] + np.swapaxes(alo[:, :3, :3], 1, 2))) < 1e-12
    assert np.all(om[:, 3] == 0.0) and np.all(alo[:, 3] == 0.0)
    np.testing.assert_array_equal(axial(om), w)
    np.testing.assert_array_equal(axial(alo), al)


def test_rigid_body_point_formulas_rssr():
    """RSSR: rocker point P (the rocker turns about the x axis through (0, 3, 0),
    so its origin - the global origin at the modeling posture - moves) and crank point K."""
    s = openimp.compile(rssr())
    t = np.linspace(0.0, 1.0, 121)
    q, qd, qdd = smooth_drive(t, 0.3, 2 * math.pi, 0.4)
    res = openimp.sweep(s, {"A": q}, {"A": 3.0 * qd}, {"A": 9.0 * qdd + 2.0})
    assert res.complete, res.message
    _assert_rigid_body(res, "ROCKER", "P")
    _assert_rigid_body(res, "CRANK", "K")


def test_rigid_body_point_formulas_cardan_and_slider_crank():
    """Cardan cross (fully spatial omega and alpha) and the slider-crank rod."""
    m, phi, _ = hooke_book(beta=140 * DEG, h=0.8)
    res = openimp.sweep(openimp.compile(m),
        {"D": phi[3] + np.linspace(0, 2 * math.pi, 91)}, {"D": 2.5}, {"D": -1.5})
    assert res.complete
    _assert_rigid_body(res, "CROSS", "R")
    _assert_rigid_body(res, "OUT", "O1")
    s = openimp.compile(slider_crank())
    q = np.linspace(0, 2 * math.pi, 91)
    res = openimp.sweep(s, {"A": q}, {"A": 4.0 + np.sin(q)}, {"A": np.cos(q)})
    _assert_rigid_body(res, "ROD", "P")
    _assert_rigid_body(res, "SLIDER", "S")


# =============================================================================
# 5. FGC / pivot changes and singular postures
# =============================================================================


def _complete_pivot_order(J: np.ndarray, cols: list[int]) -> tuple[int, ...]:
    """Column order chosen by complete pivoting (book 6.5.3) among ``cols``."""
    J = J.copy()
    rows_used: set[int] = set()
    order: list[int] = []
    for _ in cols:
        best, br, bc = 0.0, -1, -1
        for i in range(J.shape[0]):
            if i in rows_used:
                continue
            for j in cols:
                if j not in order and abs(J[i, j]) > best:
                    best, br, bc = abs(J[i, j]), i, j
        if best < 1e-10:
            break
        rows_used.add(br)
        order.append(bc)
        J[br] /= J[br, bc]
        for i in range(J.shape[0]):
            if i != br:
                J[i] -= J[i, bc] * J[br]
    return tuple(order)


def test_fivebar_two_drivers_pivot_order_changes():
    """Five-bar driven by both cranks (A a full turn, E oscillating): the order in
    which complete pivoting eliminates the dependent revolutes B, C, D changes
    along the sweep (shown with the revolute screws [p_y, -p_x, 0, 0, 0, 1] of the
    current pin positions, in internal units); the rates agree with finite
    differences at every step and are continuous."""
    m = fivebar()
    s = openimp.compile(m)
    t = np.linspace(0.0, 1.0, N_FD)
    dt = t[1] - t[0]
    q1, q1d, q1dd = smooth_drive(t, 0.0, 2 * math.pi, 0.3)
    q4, q4d, q4dd = smooth_drive(t, 0.0, 0.0, 0.5)
    res = openimp.sweep(s, {"A": q1, "E": q4}, {"A": q1d, "E": q4d}, {"A": q1dd, "E": q4dd})
    assert res.complete, res.message
    assert all(not f for f in res.fgc)
    orders = Counter()
    for k in range(0, N_FD, 20):
        cols = []
        for jn in ("A", "B", "C", "D", "E"):
            j = m.joints[jn]
            T = res.posture(j.body2)[k] if j.body2 != "BASE" else np.eye(4)
            p = (T @ j.frame2[:, 3])[:3] / s.length_scale
            cols.append([p[1], -p[0], 0.0, 0.0, 0.0, 1.0])
        orders[_complete_pivot_order(np.array(cols).T, [1, 2, 3])] += 1
    assert len(orders) >= 2, orders
    check_against_fd(res, dt, points=("P", "Q"), bodies=("L1", "L2", "L3", "L4"))
    assert np.max(np.abs(np.diff(res.qd, axis=0))) <= 1.05 * np.max(np.abs(res.qdd)) * dt
    assert not res.singular.any()


def _rocker_to_extreme(decades: int):
    """Crank-rocker a=1, b=3, c=2.5, d=3.2 (crank at 200 deg at the modeling
    posture) driven by its rocker D toward the extreme where crank and coupler
    are collinear, |C| = a + b: cos(phi_ext) = ((a + b)^2 - d^2 - c^2)/(2 d c),
    ending exactly there.  The last ``decades`` steps before it are at
    relative distances 0.05 * 10^-1 ... 10^-decades of the travel."""
    a, b, c, d = 1.0, 3.0, 2.5, 3.2
    m, P = fourbar(a, b, c, d, th0=200 * DEG)
    s = openimp.compile(m)
    C, D = P["C"], P["D"]
    phi0 = math.atan2(C[1] - D[1], C[0] - D[0])
    phi_ext = math.acos(((a + b) ** 2 - d * d - c * c) / (2 * d * c))
    target = -(phi_ext - phi0)  # D is ROCKER -> BASE: its variable is minus the rocker's turn
    deltas = np.logspace(-1, -decades, decades) if decades else np.zeros(0)
    vals = np.r_[np.linspace(0.0, 0.95 * target, 20), target * (1 - 0.05 * deltas), target]
    return openimp.sweep(s, {"D": vals}, {"D": 1.0}, {"D": 0.0})


def test_rocker_approaching_extreme_rates_grow_like_inverse_sqrt():
    """Approaching the rocker's extreme the true crank rate grows like delta^-1/2
    (one decade of delta per step: ratio sqrt(10)) and the quality index falls;
    these steps are regular and must not be flagged."""
    res = _rocker_to_extreme(4)
    assert res.complete, res.message
    assert not res.singular[:-1].any()
    k = slice(20, 24)
    wA = np.abs(res.joint_velocity("A")[k, 0])
    assert np.all(np.diff(wA) > 0) and np.all(np.diff(res.quality[k]) < 0)
    np.testing.assert_allclose(wA[2:] / wA[1:-1], math.sqrt(10.0), rtol=1e-2)


@pytest.mark.parametrize(
    "decades",
    [0, 4, 8],
    ids=["direct", "4-decades", "8-decades"],
)
def test_singular_rocker_extreme_is_flagged(decades):
    """At the extreme itself the posture is singular for the rocker as driver:
    res.singular flags that step (and only that step), whichever way the sweep
    approached it.  Newton lands within its tolerance of the double root, so
    the rank may stay full there with rates of ~1e8 (the true rates diverge):
    the flag, from the quality index collapsing by more than six decades, is
    what tells the user; the numbers stay finite."""
    res = _rocker_to_extreme(decades)
    assert res.complete, res.message
    assert res.singular[-1], (res.rank[-1], res.quality[-1], np.abs(res.qd[-1]).max())
    assert not res.singular[:-1].any()
    assert np.all(np.isfinite(res.qd[-1])) and np.all(np.isfinite(res.qdd[-1]))
    regular = np.max(np.abs(res.qd[:-1]), axis=1)
    if res.rank[-1] == res.rank[0]:
        assert res.quality[-1] < 1e-6 * res.quality[0]
    else:
        assert np.max(np.abs(res.qd[-1])) < 1e3 * regular.max()


def test_singular_parallelogram_change_point_is_flagged():
    """Parallelogram a = c = 1, b = d = 2.5, crank driven through 180 deg where
    the four pins are collinear (change point, mobility 2 there).  res.singular
    flags that step only; its rates are finite; rates on either side are
    bounded by the crank rate times the link ratios (no blow-up)."""
    a, b = 1.0, 2.5
    th0 = 40 * DEG
    B = a * np.array([math.cos(th0), math.sin(th0), 0.0])
    C = B + np.array([b, 0.0, 0.0])
    D = np.array([b, 0.0, 0.0])
    m = Model("parallelogram")
    m.add_joint("revolute", "A", "BASE", "CRANK", origin=(0, 0, 0))
    m.add_joint("revolute", "B", "CRANK", "COUPLER", origin=B)
    m.add_joint("revolute", "C", "COUPLER", "ROCKER", origin=C)
    m.add_joint("revolute", "D", "ROCKER", "BASE", origin=D)
    m.add_point("P", "COUPLER", (B + C) / 2 + [0.0, 0.3, 0.0])
    s = openimp.compile(m)
    q = np.radians(np.arange(0.0, 161.0))  # crank 40 .. 200 deg
    res = openimp.sweep(s, {"A": q}, {"A": 1.0}, {"A": 0.0})
    assert res.complete, res.message
    k = 140
    assert np.flatnonzero(res.singular).tolist() == [k]
    assert res.mobility[k] == 2
    # the FGC set changes there (a free coordinate appears for that step only)
    assert res.fgc[k] and not res.fgc[k - 1] and not res.fgc[k + 1]
    assert np.all(np.isfinite(res.qd)) and np.all(np.isfinite(res.qdd))
    assert np.max(np.abs(res.qd)) <= 1.0 + 1e-9
    # on the parallelogram branch (before the change point) the coupler only
    # translates: joint rates [1, -1, 1, -1] psi', no joint accelerations
    assert np.max(np.abs(res.angular_velocity("COUPLER")[:k])) < 1e-9
    np.testing.assert_allclose(res.qd[:k], np.tile([1.0, -1.0, 1.0, -1.0], (k, 1)), atol=1e-9)
    assert np.max(np.abs(res.qdd[:k])) < 1e-8


def _parallelogram():
    a, b = 1.0, 2.5
    th0 = 40 * DEG
    B = a * np.array([math.cos(th0), math.sin(th0), 0.0])
    m = Model("parallelogram")
    m.add_joint("revolute", "A", "BASE", "CRANK", origin=(0, 0, 0))
    m.add_joint("revolute", "B", "CRANK", "COUPLER", origin=B)
    m.add_joint("revolute", "C", "COUPLER", "ROCKER", origin=B + np.array([b, 0.0, 0.0]))
    m.add_joint("revolute", "D", "ROCKER", "BASE", origin=(b, 0, 0))
    return openimp.compile(m)


@pytest.mark.parametrize(
    "crank_deg",
    [[140.0], [139.0, 140.0], [138.0, 139.0, 140.0]],
    ids=["1-step", "2-steps", "3-steps"],
)
def test_singular_flag_does_not_depend_on_sweep_length(crank_deg):
    """The parallelogram's change point (crank at 180 deg = 140 deg from the
    modeling posture) is singular whatever the rest of the sweep, and also when
    the driver is at rest there (psi' = 0, psi'' = 1: the joint accelerations
    are not determined by the driver)."""
    s = _parallelogram()
    res = openimp.sweep(s, {"A": np.radians(crank_deg)}, {"A": 0.0}, {"A": 1.0})
    assert res.complete, res.message
    assert res.mobility[-1] == 2
    assert res.singular[-1]
    assert not res.singular[:-1].any()


# =============================================================================
# 1 (continued). Higher pairs: gear train, cam, sphere in a groove
# =============================================================================


def test_fd_ferguson_gear_train():
    """Ferguson's paradox (book example 5.5, digest book-ch01-06 section 8.3):
    carrier 1 (revolute B, the input psi), planet 2 (N = 10, pitch radius 0.25)
    on the carrier (revolute A), suns 3 (N = 101, R = 2.525), 4 (N = 99,
    R = 2.475) on revolutes D, F, fixed sun 5 = BASE (N = 100, R = 2.5); gear
    joints C 3->2, E 4->2, G 5->2, centre distance 2.75 (so C and E run at
    phi2 = -0.025 and +0.025), all axes along z, at heights as in the book's
    shape matrices.

    Book solution: [A, B, C1, C2, C3, D, E1, E2, E3, F, G1, G2, G3] =
    [10 psi, psi, 100/101 psi, -0.025, 0, psi/101, 100/99 psi, 0.025, 0, -psi/99,
    psi, 0, 0]: the rates are these ratios times psi' and psi'' (1e-9), and
    agree with differences of the positions over a turn of the carrier (the
    planet turns 11 times; dt = 2.5e-4)."""
    m = Model("ferguson")
    for b in ("CARRIER", "PLANET", "SUN3", "SUN4"):
        m.add_body(b)
    m.add_joint("revolute", "A", "CARRIER", "PLANET", origin=(2.75, 0, 3))
    m.add_joint("revolute", "B", "BASE", "CARRIER", origin=(0, 0, 3))
    m.add_joint("gear", "C", "SUN3", "PLANET", origin=(0, 0, 2), origin2=(2.75, 0, 2),
                radius1=2.525, radius2=0.25)
    m.add_joint("revolute", "D", "BASE", "SUN3", origin=(0, 0, 2))
    m.add_joint("gear", "E", "SUN4", "PLANET", origin=(0, 0, 1), origin2=(2.75, 0, 1),
                radius1=2.475, radius2=0.25)
    m.add_joint("revolute", "F", "BASE", "SUN4", origin=(0, 0, 1))
    m.add_joint("gear", "G", "BASE", "PLANET", origin=(0, 0, 0), origin2=(2.75, 0, 0),
                radius1=2.5, radius2=0.25)
    m.add_point("PP", "PLANET", (2.95, 0.1, 1.5))
    m.add_point("S3", "SUN3", (1.5, -0.7, 2.0))
    s = openimp.compile(m)
    assert s.var_names == ("A.theta", "B.theta", "C.phi1", "C.phi2", "C.phi3", "D.theta",
                           "E.phi1", "E.phi2", "E.phi3", "F.theta", "G.phi1", "G.phi2",
                           "G.phi3")
    t = np.linspace(0.0, 1.0, 4001)
    q, qd, qdd = smooth_drive(t, 0.0, 2 * math.pi, 0.3)
    res = openimp.sweep(s, {"B": q}, {"B": qd}, {"B": qdd})
    assert res.complete, res.message
    assert np.all(res.mobility == 1) and np.all(res.rank == 12)
    ratio = np.array([10, 1, 100 / 101, 0, 0, 1 / 101, 100 / 99, 0, 0, -1 / 99, 1, 0, 0])
    q0 = np.zeros(13)
    q0[3], q0[7] = -0.025, 0.025
    assert np.max(np.abs(res.q - q0 - q[:, None] * ratio)) < 1e-9
    assert relerr(res.qd, qd[:, None] * ratio) < CF_TOL
    assert relerr(res.qdd, qdd[:, None] * ratio) < CF_TOL
    # the suns turn +psi/101 and -psi/99 (book: T_03, T_04)
    assert relerr(res.angular_velocity("SUN3")[:, 2], qd / 101) < CF_TOL
    assert relerr(res.angular_velocity("SUN4")[:, 2], -qd / 99) < CF_TOL
    assert relerr(res.angular_velocity("PLANET")[:, 2], 11 * qd) < CF_TOL
    assert relerr(res.angular_acceleration("PLANET")[:, 2], 11 * qdd) < CF_TOL
    check_against_fd(res, t[1] - t[0], points=("PP", "S3"),
                     bodies=("CARRIER", "PLANET", "SUN3", "SUN4"))
    assert not res.singular.any()


def test_fd_cam_radial_roller_follower():
    """Disk cam (revolute A about z) with a radial translating follower
    (prismatic P along y through the cam axis) whose roller centre runs on
    the pitch curve r(a) = 2 + 0.3 cos a + 0.1 sin 2a (cam joint K, given as a
    Fourier series; a measured from the cam's u).  With the cam turned by
    theta the roller centre sits at the cam angle pi/2 - theta, so
    y = r(pi/2 - theta),  y' = -r'(.) theta',  y'' = r''(.) theta'^2 - r'(.) theta''
    (1e-9), and all rates agree with differences over a full cam turn."""

    def r(a, k=0):
        return [2 + 0.3 * np.cos(a) + 0.1 * np.sin(2 * a),
                -0.3 * np.sin(a) + 0.2 * np.cos(2 * a),
                -0.3 * np.cos(a) - 0.4 * np.sin(2 * a)][k]

    y0 = r(math.pi / 2)
    m = Model("cam")
    m.add_joint("revolute", "A", "BASE", "CAM", origin=(0, 0, 0))
    m.add_joint("cam", "K", "CAM", "FOLLOWER", origin=(0, 0, 0), origin2=(0, y0, 0),
                fourier=([2.0, 0.3, 0.0], [0.0, 0.1]))
    m.add_joint("prismatic", "P", "BASE", "FOLLOWER", origin=(0, y0, 0), axis=(0, 1, 0),
                ref=(1, 0, 0))
    m.add_point("F", "FOLLOWER", (0.3, y0 + 0.5, 0.0))
    m.add_point("Q", "CAM", (0.5, 0.7, 0.0))
    s = openimp.compile(m)
    t = np.linspace(0.0, 1.0, N_FD)
    q, qd, qdd = smooth_drive(t, 0.0, 2 * math.pi, 0.3)
    res = openimp.sweep(s, {"A": q}, {"A": qd}, {"A": qdd})
    assert res.complete, res.message
    assert np.all(res.mobility == 1)
    a = math.pi / 2 - q
    assert np.max(np.abs(res.variable("P") - (r(a) - y0))) < 1e-9
    assert relerr(res.joint_velocity("P")[:, 0], -r(a, 1) * qd) < CF_TOL
    assert relerr(res.joint_acceleration("P")[:, 0], r(a, 2) * qd**2 - r(a, 1) * qdd) < CF_TOL
    check_against_fd(res, t[1] - t[0], points=("F", "Q"), bodies=("CAM", "FOLLOWER"))
    assert not res.singular.any()


def test_fd_sphere_groove_spatial_yoke():
    """A spatial Scotch yoke: crank A about z carries a ball whose centre runs on
    the circle (cos th, sin th, 0.5); the ball runs in a straight groove of a
    yoke that turns about and slides along the x axis (cylinder C); the groove
    passes radially through the x axis.  So the yoke slides by x = cos th and
    turns to gamma = atan2(0.5, sin th): rates of C from these to 1e-9, and
    every rate (including the groove slide and the ball's Euler-Rodrigues
    parameters) against differences over a full crank turn."""
    th0, hz = 30 * DEG, 0.5
    P0 = np.array([math.cos(th0), math.sin(th0), hz])
    g0 = math.atan2(hz, math.sin(th0))
    m = Model("sphere-groove")
    m.add_joint("revolute", "A", "BASE", "CRANK", origin=(0, 0, 0))
    m.add_joint("sphere_groove", "G", "YOKE", "CRANK", origin=P0, axis=(1, 0, 0),
                ref=(0, math.cos(g0), math.sin(g0)))
    m.add_joint("cylinder", "C", "BASE", "YOKE", origin=(0, 0, 0), axis=(1, 0, 0),
                ref=(0, 1, 0))
    m.add_point("Y", "YOKE", (0.3, 1.0, -0.2))
    m.add_point("K", "CRANK", (0.2, 0.8, 0.4))
    s = openimp.compile(m)
    t = np.linspace(0.0, 1.0, N_FD)
    q, qd, qdd = smooth_drive(t, 0.0, 2 * math.pi, 0.3)
    res = openimp.sweep(s, {"A": q}, {"A": qd}, {"A": qdd})
    assert res.complete, res.message
    assert np.all(res.mobility == 1)
    th = th0 + q
    st, ct = np.sin(th), np.cos(th)
    den = st**2 + hz**2
    xd, xdd = -st * qd, -ct * qd**2 - st * qdd
    gd = -hz * ct * qd / den
    gdd = -hz * (ct * qdd - st * qd**2) / den + hz * ct * qd * (2 * st * ct * qd) / den**2
    assert np.max(np.abs(res.variable("C.s") - (ct - math.cos(th0)))) < 1e-9
    assert np.max(np.abs(res.variable("C.theta") - (np.arctan2(hz, st) - g0))) < 1e-9
    assert relerr(res.joint_velocity("C")[:, 1], xd) < CF_TOL
    assert relerr(res.joint_acceleration("C")[:, 1], xdd) < CF_TOL
    assert relerr(res.joint_velocity("C")[:, 0], gd) < CF_TOL
    assert relerr(res.joint_acceleration("C")[:, 0], gdd) < CF_TOL
    check_against_fd(res, t[1] - t[0], points=("Y", "K"), bodies=("CRANK", "YOKE"))
    e, ed = res.joint("G")[:, 1:], res.joint_velocity("G")[:, 1:]
    assert np.max(np.abs(np.sum(e * ed, axis=1))) < 1e-9 * np.max(np.abs(ed))
    assert not res.singular.any()
