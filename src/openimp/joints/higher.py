"""Higher pairs (book 4.6.9-4.6.13) and IMP's CAM, SLOT and UJOINT; sphere-plane and
sphere-groove joints.

:func:`higher_calc` gives a higher pair's ``Phi``, ``Q_g`` and ``Q_{g,i}``
together from one evaluation of the terms they share: the planar kinds
(gear, rack, point and line on a curve, cam, slot) through
:func:`planar_terms` (Phi = [[Rz(theta(q)), p(q)], [0, 1]]), the universal
joint and the bevel gear through the Z-X-Z angle products of ``_zxz_derivs``,
the ball joints through the Euler-Rodrigues operators of
:mod:`openimp.joints.lower`.  The Python side builds each kind's constants
from the user's keywords and extracts ``q`` from a measured ``Phi``.
Conventions that differ from the book's printed ones are documented in the
catalogue (:mod:`openimp.joints.catalogue`).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from openimp._jit import njit
from openimp.errors import InputError
from openimp.joints.cardan import cardan_calc
from openimp.joints.codes import (
    BEVEL,
    CAM,
    FLAT_POLAR,
    GEAR,
    GIMBAL,
    LINE_CURVE,
    OPEN_CARDAN,
    POINT_CURVE,
    RACK,
    SLOT,
    SPHERE_PLANE,
    UJOINT,
    is_planar,
    nvar,
)
from openimp.joints.curves import (
    CURVE_AT,
    ConstArgs,
    curve_eval,
    curve_parameter,
    curve_points,
    fun_eval,
    refine_root,
    scalar_function,
    search_grid,
    wrap_angle,
)
from openimp.joints.lower import angle_of, er_translation_ops, rotation_to_er
from openimp.limits import MAX_GEAR_RATIO
from openimp.mat4 import elem_rot3, eye4, mm3, rotz4
from openimp.mat4 import er_rotation as _er_rot

_TWO_PI = 2.0 * math.pi


@njit
def planar_terms(
    code: int, q: np.ndarray, c: np.ndarray, s: float, T: np.ndarray, TG: np.ndarray,
    TGI: np.ndarray, P: np.ndarray, PG: np.ndarray, PGI: np.ndarray,
) -> int:
    """Angle, translation and their derivatives of a planar higher pair.

    Every planar kind has Phi = [[Rz(theta(q)), p(q)], [0, 1]].  Fills
    T[0] = theta, TG[g] = dtheta/dq_g, TGI[g, i], P = p, PG[g] = dp/dq_g,
    PGI[g, i] (all zeroed first) and returns the number of variables.  ``s``
    is the load sign sgn(F) of a gear or rack (4.28, 4.31), from the state.
    """
    nv = nvar(code)
    T[0] = 0.0
    for g in range(3):
        TG[g] = 0.0
        P[g] = 0.0
        for i in range(3):
            TGI[g, i] = 0.0
            PG[g, i] = 0.0
            for r in range(3):
                PGI[g, i, r] = 0.0
    if code == GEAR:
        R = c[0]
        Rp = c[1]
        D0 = c[2]
        sg = s
        S = R + Rp
        C = D0 + q[1]
        g0 = 0.0
        g1 = 0.0
        g2 = 0.0
        if sg != 0.0:
            a = D0 * c[3]
            rad = C * C - a * a
            if rad < 1e-300:
                rad = 1e-300
            root = math.sqrt(rad)
            g0 = sg * (root - D0 * c[4])
            g1 = sg * C / root
            g2 = -sg * a * a / (rad * root)
        T[0] = (S * q[0] + g0 + q[2] * c[5]) / Rp
        TG[0] = S / Rp
        TG[1] = g1 / Rp
        TG[2] = c[5] / Rp
        TGI[1, 1] = g2 / Rp
        _polar_point(q[0], C, P, PG, PGI)
        P[2] = q[2]
        PG[2, 2] = 1.0
    elif code == RACK:
        Rp = c[0]
        sg = s
        T[0] = -(q[0] + sg * q[1] * c[1] - q[2] * c[2]) / Rp
        TG[0] = -1.0 / Rp
        TG[1] = -sg * c[1] / Rp
        TG[2] = c[2] / Rp
        P[0] = q[0]
        P[1] = Rp + q[1]
        P[2] = q[2]
        PG[0, 0] = 1.0
        PG[1, 1] = 1.0
        PG[2, 2] = 1.0
    elif code == POINT_CURVE or code == LINE_CURVE:
        ls = c[0]
        cv = np.empty(8)
        curve_eval(c, CURVE_AT, q[0], cv)
        u = cv[0] * ls
        v = cv[1] * ls
        u1 = cv[2] * ls
        v1 = cv[3] * ls
        u2 = cv[4] * ls
        v2 = cv[5] * ls
        PG[2, 2] = 1.0
        if code == POINT_CURVE:
            T[0] = q[1]
            TG[1] = 1.0
            P[0] = u
            P[1] = v
            P[2] = q[2]
            PG[0, 0] = u1
            PG[0, 1] = v1
            PGI[0, 0, 0] = u2
            PGI[0, 0, 1] = v2
        else:
            u3 = cv[6] * ls
            v3 = cv[7] * ls
            N = u1 * v2 - v1 * u2
            D = u1 * u1 + v1 * v1
            if D < 1e-300:
                D = 1e-300
            th = math.atan2(v1, u1)
            t1 = N / D
            N1 = u1 * v3 - v1 * u3
            D1 = 2.0 * (u1 * u2 + v1 * v2)
            t11 = (N1 * D - N * D1) / (D * D)
            ct = math.cos(th)
            st = math.sin(th)
            d = q[1]
            T[0] = th
            TG[0] = t1
            TGI[0, 0] = t11
            P[0] = u - d * ct
            P[1] = v - d * st
            P[2] = q[2]
            PG[0, 0] = u1 + d * st * t1
            PG[0, 1] = v1 - d * ct * t1
            PG[1, 0] = -ct
            PG[1, 1] = -st
            PGI[0, 0, 0] = u2 + d * (ct * t1 * t1 + st * t11)
            PGI[0, 0, 1] = v2 + d * (st * t1 * t1 - ct * t11)
            PGI[0, 1, 0] = st * t1
            PGI[0, 1, 1] = -ct * t1
            PGI[1, 0, 0] = st * t1
            PGI[1, 0, 1] = -ct * t1
    elif code == CAM:
        ls = c[0]
        fv = np.empty(4)
        fun_eval(c, 1, q[0], fv, 0, 1)
        r = fv[0] * ls
        r1 = fv[1] * ls
        r2 = fv[2] * ls
        c1 = math.cos(q[0])
        s1 = math.sin(q[0])
        T[0] = q[0] + q[1]
        TG[0] = 1.0
        TG[1] = 1.0
        P[0] = r * c1
        P[1] = r * s1
        PG[0, 0] = r1 * c1 - r * s1
        PG[0, 1] = r1 * s1 + r * c1
        PGI[0, 0, 0] = r2 * c1 - 2.0 * r1 * s1 - r * c1
        PGI[0, 0, 1] = r2 * s1 + 2.0 * r1 * c1 - r * s1
    elif code == SLOT:
        ls = c[0]
        fv = np.empty(4)
        fun_eval(c, 3, q[0] / ls, fv, 0, 1)
        T[0] = q[1]
        TG[1] = 1.0
        P[0] = q[0]
        P[1] = fv[0] * ls
        PG[0, 0] = 1.0
        PG[0, 1] = fv[1]
        PGI[0, 0, 1] = fv[2] / ls
    elif code == FLAT_POLAR:  # Rz(phi1) Tx(r) Rz(phi2): IMP's FLAT
        T[0] = q[0] + q[2]
        TG[0] = 1.0
        TG[2] = 1.0
        _polar_point(q[0], q[1], P, PG, PGI)
    return nv


@njit(inline="always")
def _polar_point(a: float, r: float, P: np.ndarray, PG: np.ndarray, PGI: np.ndarray) -> None:
    """P[:2] = r (cos a, sin a) with a = q_0 and r moving with q_1 (dr/dq_1 = 1), and its
    first (PG) and second (PGI) derivatives: the gear's centre line, FLAT's polar form."""
    c1 = math.cos(a)
    s1 = math.sin(a)
    P[0] = r * c1
    P[1] = r * s1
    PG[0, 0] = -r * s1
    PG[0, 1] = r * c1
    PG[1, 0] = c1
    PG[1, 1] = s1
    PGI[0, 0, 0] = -r * c1
    PGI[0, 0, 1] = -r * s1
    PGI[0, 1, 0] = -s1
    PGI[0, 1, 1] = c1
    PGI[1, 0, 0] = -s1
    PGI[1, 0, 1] = c1


@njit
def _zxz_terms(code: int, q: np.ndarray, c: np.ndarray, ang: np.ndarray, rate: np.ndarray,
               off: np.ndarray) -> int:
    """Angles of Phi = Tz(-d1) Rz(alpha) Rx(beta) Rz(gamma) Tz(d2) (universal joint, bevel).

    The three angles are affine in q: ang[a] + sum_g rate[a, g] q_g; off = (d1, d2).
    """
    for a in range(3):
        for g in range(2):
            rate[a, g] = 0.0
    if code == UJOINT:
        ang[0] = q[0]
        ang[1] = 0.5 * math.pi
        ang[2] = q[1]
        rate[0, 0] = 1.0
        rate[2, 1] = 1.0
        off[0] = 0.0
        off[1] = 0.0
    else:  # BEVEL: Rz(-phi1) Rx(Sigma0 + phi2) Rz(kappa phi1)
        ang[0] = -q[0]
        ang[1] = c[1] + q[1]
        ang[2] = c[0] * q[0]
        rate[0, 0] = -1.0
        rate[1, 1] = 1.0
        rate[2, 0] = c[0]
        off[0] = c[2]
        off[1] = c[3]
    return 2


@njit
def _zxz_derivs(ang: np.ndarray, rate: np.ndarray, M: np.ndarray, MG: np.ndarray,
                MGI: np.ndarray) -> None:
    """M = Rz(a) Rx(b) Rz(c), MG[g] = dM/dq_g, MGI[g, i] = d2M/dq_g dq_i (3x3 each)."""
    F = np.empty((3, 3, 3, 3))  # F[factor, order]
    axes = (2, 0, 2)
    for f in range(3):
        for o in range(3):
            elem_rot3(axes[f], ang[f], o, F[f, o])
    tmp = np.empty((3, 3))
    prod = np.empty((3, 3))
    mm3(F[0, 0], F[1, 0], tmp)
    mm3(tmp, F[2, 0], M)
    for g in range(2):
        for i in range(3):
            for j in range(3):
                MG[g, i, j] = 0.0
                for g2 in range(2):
                    MGI[g, g2, i, j] = 0.0
    # all orders (o0, o1, o2) with o0 + o1 + o2 <= 2
    for o0 in range(3):
        for o1 in range(3 - o0):
            for o2 in range(3 - o0 - o1):
                tot = o0 + o1 + o2
                if tot == 0:
                    continue
                mm3(F[0, o0], F[1, o1], tmp)
                mm3(tmp, F[2, o2], prod)
                if tot == 1:
                    f = 0 if o0 == 1 else (1 if o1 == 1 else 2)
                    for g in range(2):
                        w = rate[f, g]
                        if w != 0.0:
                            for i in range(3):
                                for j in range(3):
                                    MG[g, i, j] += w * prod[i, j]
                else:
                    # the two differentiations fall on factors fa <= fb
                    if o0 == 2:
                        fa, fb = 0, 0
                    elif o1 == 2:
                        fa, fb = 1, 1
                    elif o2 == 2:
                        fa, fb = 2, 2
                    elif o0 == 1 and o1 == 1:
                        fa, fb = 0, 1
                    elif o0 == 1:
                        fa, fb = 0, 2
                    else:
                        fa, fb = 1, 2
                    for g in range(2):
                        for g2 in range(2):
                            if fa == fb:
                                w = rate[fa, g] * rate[fa, g2]
                            else:
                                w = rate[fa, g] * rate[fb, g2] + rate[fb, g] * rate[fa, g2]
                            if w != 0.0:
                                for i in range(3):
                                    for j in range(3):
                                        MGI[g, g2, i, j] += w * prod[i, j]


@njit
def _set_ops_block(V: np.ndarray, d1: float, out: np.ndarray) -> None:
    """out = Tz(-d1) [[V, 0], [0, 0]] Tz(-d1)^-1 = [[V, d1 V e3], [0, 0]]."""
    for i in range(3):
        for j in range(3):
            out[i, j] = V[i, j]
        out[i, 3] = d1 * V[i, 2]
    for j in range(4):
        out[3, j] = 0.0


@njit
def _er_trans(code: int) -> int:
    """Number of translation variables before the Euler-Rodrigues block (sphere-plane 2,
    sphere-groove 1)."""
    return 2 if code == SPHERE_PLANE else 1


@njit
def higher_calc(code: int, q: np.ndarray, c: np.ndarray, s: float, Phi: np.ndarray,
                Q: np.ndarray, dQ: np.ndarray, order: int) -> None:
    """Phi, and with ``order`` >= 1 the Q_g, with ``order`` 2 the Q_{g,i}, of a higher pair.

    Shapes and zeroing as :func:`openimp.joints.lower.lower_calc`; ``s`` is
    the load sign of a gear or rack (from the state).
    """
    if is_planar(code):
        T = np.empty(1)
        TG = np.empty(3)
        TGI = np.empty((3, 3))
        P = np.empty(3)
        PG = np.empty((3, 3))
        PGI = np.empty((3, 3, 3))
        nv = planar_terms(code, q, c, s, T, TG, TGI, P, PG, PGI)
        rotz4(Phi, T[0])
        Phi[0, 3] = P[0]
        Phi[1, 3] = P[1]
        Phi[2, 3] = P[2]
        if order < 1:
            return
        # Q_g = [[theta_g Z, p_g - theta_g Z p], [0, 0]], Z p = (-p_v, p_u, 0)
        for g in range(nv):
            tg = TG[g]
            Q[g, 0, 1] = -tg
            Q[g, 1, 0] = tg
            Q[g, 0, 3] = PG[g, 0] + tg * P[1]
            Q[g, 1, 3] = PG[g, 1] - tg * P[0]
            Q[g, 2, 3] = PG[g, 2]
        if order < 2:
            return
        # d/dq_i [[theta_g Z, p_g - theta_g Z p]]
        for g in range(nv):
            for i in range(nv):
                tgi = TGI[g, i]
                tg = TG[g]
                blk = dQ[g, i]
                blk[0, 1] = -tgi
                blk[1, 0] = tgi
                blk[0, 3] = PGI[g, i, 0] + tgi * P[1] + tg * PG[i, 1]
                blk[1, 3] = PGI[g, i, 1] - tgi * P[0] - tg * PG[i, 0]
                blk[2, 3] = PGI[g, i, 2]
    elif code == UJOINT or code == BEVEL:
        ang = np.empty(3)
        rate = np.empty((3, 2))
        off = np.empty(2)
        _zxz_terms(code, q, c, ang, rate, off)
        M = np.empty((3, 3))
        MG = np.empty((2, 3, 3))
        MGI = np.empty((2, 2, 3, 3))
        _zxz_derivs(ang, rate, M, MG, MGI)
        eye4(Phi)
        for i in range(3):
            for j in range(3):
                Phi[i, j] = M[i, j]
            Phi[i, 3] = off[1] * M[i, 2]
        Phi[2, 3] -= off[0]
        if order < 1:
            return
        V = np.empty((3, 3))
        for g in range(2):
            # W_g = M_g M^T
            for i in range(3):
                for j in range(3):
                    V[i, j] = MG[g, i, 0] * M[j, 0] + MG[g, i, 1] * M[j, 1] + MG[g, i, 2] * M[j, 2]
            _set_ops_block(V, off[0], Q[g])
        if order < 2:
            return
        for g in range(2):
            for i2 in range(2):
                # d(M_g M^T)/dq_i = M_gi M^T + M_g M_i^T
                for i in range(3):
                    for j in range(3):
                        t = 0.0
                        for m in range(3):
                            t += MGI[g, i2, i, m] * M[j, m] + MG[g, i, m] * MG[i2, j, m]
                        V[i, j] = t
                _set_ops_block(V, off[0], dQ[g, i2])
    elif code == GIMBAL or code == OPEN_CARDAN:
        cardan_calc(code, q, Phi, Q, dQ, order)
    else:  # SPHERE_PLANE, SPHERE_GROOVE: Phi = [[Theta(e), (x, y, 0) or (s, 0, 0)], [0, 1]]
        k = _er_trans(code)
        eye4(Phi)
        _er_rot(Phi, q, k)
        Phi[0, 3] = q[0]
        if code == SPHERE_PLANE:
            Phi[1, 3] = q[1]
        er_translation_ops(Q, dQ, q, k, k, order)


# =============================================================================
# Constants and extraction (Python side)
# =============================================================================
def extract_point_curve(Phi: np.ndarray, c: np.ndarray) -> np.ndarray:
    """(t, phi2, phi3) of a point_curve joint from its measured ``Phi`` (4 x 4)
    and constants ``c``; the u'v'w' origin must lie on the curve."""
    x, y = float(Phi[0, 3]), float(Phi[1, 3])
    t, dist = curve_parameter(c, x, y)
    if dist > 1e-8:
        r = curve_points(c, np.array([t]))[0]
        L = 1.0 / c[0]
        raise InputError(
            f"the u'v'w' origin is not on the curve: it is {dist * L:.6g} length units from "
            f"it (closest curve point at parameter {t:.10g}, u = {r[0] * L:.10g}, "
            f"v = {r[1] * L:.10g} in the first joint frame); place the second frame's origin "
            "on the curve"
        )
    return np.array([t, angle_of(Phi), Phi[2, 3]])


def extract_line_curve(Phi: np.ndarray, c: np.ndarray) -> np.ndarray:
    """(t, phi2, phi3) of a line_curve joint from its measured ``Phi`` (4 x 4)
    and constants ``c``: t where the curve's tangent lies along +u'."""
    x, y = float(Phi[0, 3]), float(Phi[1, 3])
    th = angle_of(Phi)
    ct, st = math.cos(th), math.sin(th)
    ts, periodic = search_grid(c)
    pts = curve_points(c, ts)
    # tangent parallel to u': h(t) = u' sin(th) - v' cos(th) = 0 with the same sense
    h = pts[:, 2] * st - pts[:, 3] * ct
    same = pts[:, 2] * ct + pts[:, 3] * st > 0.0

    def hf(t: float) -> tuple[float, float]:
        r = curve_points(c, np.array([t]))[0]
        return r[2] * st - r[3] * ct, r[4] * st - r[5] * ct

    n = len(ts)
    idx = range(n) if periodic else range(n - 1)
    best: tuple[float, float, float] | None = None
    for j in idx:
        j2 = (j + 1) % n
        a = float(ts[j])
        b = float(ts[j2]) if j2 > j else float(ts[0]) + (float(c[2]) - float(c[1]))
        if not (same[j] or same[j2]):
            continue
        if h[j] == 0.0:
            t = a
        elif (h[j] < 0.0) == (h[j2] < 0.0):
            continue
        else:
            t = refine_root(hf, a, b)
        r = curve_points(c, np.array([t]))[0]
        if r[2] * ct + r[3] * st <= 0.0:
            continue
        off = ct * (r[1] - y) - st * (r[0] - x)
        if best is None or abs(off) < abs(best[1]):
            best = (t, off, (r[0] - x) * ct + (r[1] - y) * st)
    L = 1.0 / c[0]
    if best is None:
        raise InputError(
            f"no point of the curve has its tangent along +u' (direction {math.degrees(th):.6g} "
            "deg in the first joint frame); turn u' along the line that touches the curve"
        )
    if abs(best[1]) > 1e-8:
        raise InputError(
            f"the line along u' through the u'v'w' origin is not tangent to the curve: the "
            f"curve point with that tangent direction (parameter {best[0]:.10g}) is "
            f"{abs(best[1]) * L:.6g} length units off the line; move the second frame's origin "
            "onto the tangent line"
        )
    return np.array([best[0], best[2], Phi[2, 3]])


# --- gear ------------------------------------------------------------------------------
def _gear_radii(ratio: float, D: float) -> tuple[float, float]:
    """Signed pitch radii (R, R') from IMP's ratio R/R' and the centre distance |R + R'|."""
    rp = D / abs(1.0 + ratio)
    if ratio > 0.0:
        return ratio * rp, rp
    if abs(ratio) > 1.0:  # the first gear is the larger, internal one
        return -abs(ratio) * rp, rp
    return abs(ratio) * rp, -rp


def gear_consts(name: str, kw: dict[str, Any]) -> np.ndarray:
    """Constants of gear joint ``name`` from its keywords ``kw``: (radius1, radius2,
    distance, cos_pressure, sin_pressure, tan_helix, load_sign, ratio)."""
    args = ConstArgs(name, "gear", kw, ("radius1", "radius2", "ratio", "distance",
                                    "pressure_angle", "helix_angle", "load_sign"))
    if args.has("radius1") or args.has("radius2"):
        if args.has("ratio") or args.has("distance"):
            raise args.err("give either radius1= and radius2= (signed pitch radii) or "
                           "ratio= (with optional distance=), not both")
        R = args.number("radius1", nonzero=True)
        Rp = args.number("radius2", nonzero=True)
        if abs(R + Rp) < 1e-12 * max(abs(R), abs(Rp)):
            raise args.err("radius1 + radius2 is zero: the two gear axes would coincide")
        ratio = R / Rp
        D0 = abs(R + Rp)
    else:
        if not args.has("ratio"):
            raise args.err(
                "give ratio= (teeth of the first gear / teeth of the second: + external, "
                "- internal) with optional distance= (centre distance; default: from the "
                "frames), or radius1= and radius2= (signed pitch radii)"
            )
        ratio = args.number("ratio")
        if ratio == 0.0:
            raise args.err("ratio must not be zero (a gear meshing with a rack is a 'rack' "
                           "joint)")
        if ratio == -1.0:
            raise args.err("ratio -1 (internal gear of the same size) has no centre distance")
        if args.has("distance"):
            D0 = args.number("distance", positive=True)
            R, Rp = _gear_radii(ratio, D0)
        else:
            R = Rp = D0 = math.nan  # completed from the frames at assembly
    _check_gear_ratio(args, ratio)
    alpha, beta, sg = _tooth_angles(args)
    return np.array([R, Rp, D0, math.cos(alpha), math.sin(alpha), math.tan(beta), sg, ratio])


def _tooth_angles(args: ConstArgs) -> tuple[float, float, float]:
    """A gear's or rack's pressure angle (20 deg), helix angle (0) and initial load sign."""
    alpha = args.number("pressure_angle", math.radians(20.0))
    if not 0.0 <= alpha < 0.5 * math.pi:
        raise args.err(f"pressure_angle must be in [0, pi/2) radians, got {alpha:g}")
    beta = args.number("helix_angle", 0.0)
    if not abs(beta) < 0.5 * math.pi:
        raise args.err(f"helix_angle must be in (-pi/2, pi/2) radians, got {beta:g}")
    sg = args.number("load_sign", 0.0)
    if sg not in (-1.0, 0.0, 1.0):
        raise args.err(f"load_sign must be -1, 0 or +1, got {sg:g}")
    return alpha, beta, sg


def _check_gear_ratio(args: ConstArgs, ratio: float) -> None:
    """Refuse a ratio (R/R') whose gear radii or turn counting would overflow:
    |ratio| and |1 + ratio| within [1/MAX_GEAR_RATIO, MAX_GEAR_RATIO]."""
    low = 1.0 / MAX_GEAR_RATIO
    if not (low <= abs(ratio) <= MAX_GEAR_RATIO and low <= abs(1.0 + ratio)):
        raise args.err(f"the ratio {ratio:g} is out of range: |ratio| must lie between "
                       f"{low:g} and {MAX_GEAR_RATIO:g} and |1 + ratio| be at least {low:g} "
                       "(limit MAX_GEAR_RATIO)")


def gear_complete(name: str, Phi: np.ndarray, c: np.ndarray) -> None:
    """Take a gear's centre distance from its frames when it was not given."""
    if not math.isnan(c[2]):
        return
    D = math.hypot(Phi[0, 3], Phi[1, 3])
    if D < 1e-12:
        raise InputError(
            f"gear joint {name!r}: the two gear axes coincide at the modeling posture, so the "
            "centre distance cannot be taken from the frames; place the second frame on the "
            "second gear's axis or give distance="
        )
    c[0], c[1] = _gear_radii(float(c[7]), D)
    c[2] = D


def _gear_theta(q: np.ndarray, c: np.ndarray) -> float:
    T = np.empty(1)
    TG = np.empty(3)
    TGI = np.empty((3, 3))
    P = np.empty(3)
    PG = np.empty((3, 3))
    PGI = np.empty((3, 3, 3))
    planar_terms(GEAR, np.asarray(q, float), c, c[6], T, TG, TGI, P, PG, PGI)
    return float(T[0])


def _best_turns(base: float, slope: float, target: float, nturns: int = 2000) -> int:
    """k minimising |wrap(base + slope 2 pi k - target)|, the smallest |k| among ties."""
    if not (math.isfinite(base) and math.isfinite(target)
            and math.isfinite(slope * _TWO_PI * nturns)):
        raise InputError(f"the turn count of a gear cannot be found (angle {base:g}, ratio "
                         f"factor {slope:g}, target {target:g}); check the gear data")
    k = np.arange(-nturns, nturns + 1)
    err = np.abs((base + slope * _TWO_PI * k - target + math.pi) % _TWO_PI - math.pi)
    best = float(err.min())
    ok = np.flatnonzero(err <= best + 1e-9)
    return int(k[ok[np.argmin(np.abs(k[ok]))]])


def extract_gear(Phi: np.ndarray, c: np.ndarray) -> np.ndarray:
    """(phi1, phi2, phi3) of a gear joint from its measured ``Phi`` (4 x 4) and
    constants ``c``; phi1 at the whole turn of t that best matches the turn of u'."""
    x, y = float(Phi[0, 3]), float(Phi[1, 3])
    C = math.hypot(x, y)
    if C < 1e-12:
        raise InputError("the two gear axes coincide: the line of centres t is undefined")
    q = np.array([math.atan2(y, x), C - c[2], Phi[2, 3]])
    th0 = _gear_theta(q, c)
    k = _best_turns(th0, (c[0] + c[1]) / c[1], angle_of(Phi))
    q[0] += _TWO_PI * k
    return q


def rack_consts(name: str, kw: dict[str, Any]) -> np.ndarray:
    """Constants of rack joint ``name`` from its keywords ``kw``: (radius,
    tan_pressure, tan_helix, load_sign)."""
    args = ConstArgs(name, "rack", kw, ("radius", "pressure_angle", "helix_angle", "load_sign"))
    if not args.has("radius"):
        raise args.err("give radius= (pinion pitch radius: + if the pinion is on the +v side "
                       "of the rack, - otherwise)")
    Rp = args.number("radius", nonzero=True)
    alpha, beta, sg = _tooth_angles(args)
    return np.array([Rp, math.tan(alpha), math.tan(beta), sg])


def extract_rack(Phi: np.ndarray, c: np.ndarray) -> np.ndarray:
    """(phi1, phi2, phi3) of a rack joint from its measured ``Phi`` (4 x 4) and
    constants ``c``: the pinion centre in uvw, less the pitch radius R' along v."""
    return np.array([Phi[0, 3], Phi[1, 3] - c[0], Phi[2, 3]])


# --- bevel -----------------------------------------------------------------------------
def bevel_consts(name: str, kw: dict[str, Any]) -> np.ndarray:
    """Constants of bevel joint ``name`` from its keywords ``kw``: (kappa,
    shaft_angle, offset1, offset2, gamma1, gamma2)."""
    args = ConstArgs(name, "bevel", kw, ("gamma1", "gamma2", "ratio", "shaft_angle", "radius",
                                     "book_ratio"))
    if args.has("gamma1") or args.has("gamma2"):
        if args.has("ratio") or args.has("shaft_angle"):
            raise args.err("give either gamma1= and gamma2= (pitch-cone half-angles) or "
                           "ratio= (with optional shaft_angle=), not both")
        g1 = args.number("gamma1", nonzero=True)
        g2 = args.number("gamma2", nonzero=True)
    elif args.has("ratio"):
        ratio = args.number("ratio", positive=True)
        sigma = args.number("shaft_angle", 0.5 * math.pi)
        if not 0.0 < sigma < math.pi:
            raise args.err(f"shaft_angle must be in (0, pi) radians, got {sigma:g}")
        g1 = math.atan2(ratio * math.sin(sigma), 1.0 + ratio * math.cos(sigma))
        g2 = sigma - g1
    else:
        raise args.err("give gamma1= and gamma2= (pitch-cone half-angles, radians) or "
                       "ratio= (teeth of the first / teeth of the second, > 0) with optional "
                       "shaft_angle= (default pi/2)")
    sigma0 = g1 + g2
    if not 0.0 < sigma0 < math.pi:
        raise args.err(f"the shaft angle gamma1 + gamma2 = {sigma0:g} rad must be in (0, pi)")
    if abs(math.sin(g1)) < 1e-12 or abs(math.sin(g2)) < 1e-12:
        raise args.err("the pitch-cone half-angles must not be multiples of pi")
    if args.kw.get("book_ratio", False):
        kappa = math.tan(g1) / math.tan(g2)
    else:
        kappa = -math.sin(g1) / math.sin(g2)
    d1 = d2 = 0.0
    if args.has("radius"):
        R2 = args.number("radius", nonzero=True)
        rho = R2 / math.sin(g2)
        if rho <= 0.0:
            raise args.err("radius must have the sign of gamma2 (a negative radius marks an "
                           "internal gear)")
        d1 = rho * math.cos(g1)
        d2 = rho * math.cos(g2)
    return np.array([kappa, sigma0, d1, d2, g1, g2])


def extract_bevel(Phi: np.ndarray, c: np.ndarray) -> np.ndarray:
    """(phi1, phi2) of a bevel joint from its measured ``Phi`` (4 x 4) and
    constants ``c``; phi1 at the whole turn that best matches the turn of u'."""
    st = math.hypot(Phi[0, 2], Phi[1, 2])
    if st < 1e-9:
        raise InputError("w and w' are parallel: the common perpendicular t is undefined")
    th = math.atan2(st, Phi[2, 2])
    p1 = math.atan2(-Phi[0, 2], -Phi[1, 2])
    pprime = math.atan2(Phi[2, 0], Phi[2, 1])
    k = _best_turns(c[0] * p1, c[0], pprime)
    return np.array([p1 + _TWO_PI * k, th - c[1]])


# --- cam and slot ------------------------------------------------------------------------
def cam_consts(name: str, kw: dict[str, Any]) -> np.ndarray:
    """Constants of cam joint ``name`` from its keywords ``kw``: (length unit,
    then the block of the pitch-curve radius r(angle))."""
    args = ConstArgs(name, "cam", kw, ("table", "fourier", "function", "closed", "interpolation"))
    block, _, _ = scalar_function(args, "pitch-curve radius r(angle)", True, (0.0, _TWO_PI))
    return np.array([1.0, *block])


def extract_cam(Phi: np.ndarray, c: np.ndarray) -> np.ndarray:
    """(phi1, phi2) of a cam joint from its measured ``Phi`` (4 x 4) and
    constants ``c``; the follower origin must lie on the pitch curve."""
    x, y = float(Phi[0, 3]), float(Phi[1, 3])
    r = math.hypot(x, y)
    p1 = math.atan2(y, x)
    fv = np.empty(4)
    fun_eval(c, 1, p1, fv, 0, 1)
    rc = fv[0] * c[0]
    if abs(rc - r) > 1e-8:
        L = 1.0 / c[0]
        raise InputError(
            f"the follower origin is not on the pitch curve: at the cam angle "
            f"{math.degrees(p1):.6g} deg its radius is {r * L:.10g} but the pitch curve's is "
            f"{rc * L:.10g}; place the second frame's origin on the pitch curve"
        )
    return np.array([p1, wrap_angle(angle_of(Phi) - p1)])


def slot_consts(name: str, kw: dict[str, Any]) -> np.ndarray:
    """Constants of slot joint ``name`` from its keywords ``kw``: (length unit,
    u_start, u_end, then the block of the centreline v(u))."""
    args = ConstArgs(name, "slot", kw, ("table", "function", "range"))
    if not args.has("range"):
        raise args.err("give range=(u_start, u_end), the slot's extent along u "
                       "(the table's first and last samples sit at its ends)")
    block, (u0, u1), _ = scalar_function(args, "slot centreline v(u)", False, (0.0, 1.0))
    return np.array([1.0, u0, u1, *block])


def extract_slot(Phi: np.ndarray, c: np.ndarray) -> np.ndarray:
    """(u, phi2) of a slot joint from its measured ``Phi`` (4 x 4) and constants
    ``c``; the follower origin must lie on the centreline, inside the slot's range."""
    u = float(Phi[0, 3])
    L = 1.0 / c[0]
    um = u * L
    span = c[2] - c[1]
    if not c[1] - 1e-9 * span <= um <= c[2] + 1e-9 * span:
        raise InputError(
            f"the follower origin is outside the slot: u = {um:.10g} is not in the slot's "
            f"range [{c[1]:.10g}, {c[2]:.10g}]"
        )
    fv = np.empty(4)
    fun_eval(c, 3, um, fv, 0, 1)
    v = fv[0] * c[0]
    if abs(v - Phi[1, 3]) > 1e-8:
        raise InputError(
            f"the follower origin is not on the slot centreline: at u = {um:.10g} its v is "
            f"{Phi[1, 3] * L:.10g} but the centreline's is {v * L:.10g}"
        )
    return np.array([u, angle_of(Phi)])


# --- universal joint, sphere-plane, sphere-groove --------------------------------------
def extract_ujoint(Phi: np.ndarray, c: np.ndarray) -> np.ndarray:
    """(phi1, phi2) of a universal joint from its measured ``Phi`` (4 x 4);
    ``c`` is unused."""
    if math.hypot(Phi[0, 2], Phi[1, 2]) < 1e-9:
        raise InputError("w and w' are parallel: the common perpendicular t is undefined")
    return np.array([math.atan2(Phi[0, 2], -Phi[1, 2]), math.atan2(Phi[2, 0], Phi[2, 1])])


def extract_sphere_plane(Phi: np.ndarray, c: np.ndarray) -> np.ndarray:
    """(x, y, e1..e4) of a sphere_plane joint from its measured ``Phi``
    (4 x 4); ``c`` is unused."""
    return np.concatenate([[Phi[0, 3], Phi[1, 3]], rotation_to_er(Phi)])


def extract_sphere_groove(Phi: np.ndarray, c: np.ndarray) -> np.ndarray:
    """(s, e1..e4) of a sphere_groove joint from its measured ``Phi``
    (4 x 4); ``c`` is unused."""
    return np.concatenate([[Phi[0, 3]], rotation_to_er(Phi)])
