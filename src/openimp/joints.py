"""The joint catalogue (book ch 4, 6, 8; IMP's higher pairs).

Each joint kind has an integer code used inside the compiled kernels, its
variables (names and kinds: ``angle``, ``length`` or ``er`` for an
Euler-Rodrigues parameter), its constants, and four functions of its variables
``q`` and constants ``c``:

``joint_phi``  the joint matrix ``Phi(q)`` (primed frame in the unprimed one),
``joint_Q``    the first-derivative operators ``Q_g = (dPhi/dq_g) Phi^-1``,
``joint_dQ``   their derivatives ``Q_{g,i} = dQ_g/dq_i`` (book 8.2),
``extract``    the inverse: ``q`` from a measured ``Phi`` (used at assembly),

plus a conformity check of the two joint frames against the kind's
conventions.  ``Q`` is the definition (DESIGN.md), so every kind is tested
against central differences of its own ``Phi``.

Conventions that differ from the book's printed ones are documented at each
kind.  Lengths inside the kernels are internal (scaled) lengths; the
:class:`JointType` records which constants and variables are lengths so that
:mod:`openimp.system` can scale them.

Higher pairs
------------
Every higher pair is placed with :meth:`openimp.model.Model.add_joint`: ``origin``,
``axis`` (w) and ``ref`` (u) give the first frame, ``origin2``, ``axis2`` (w') and
``ref2`` (u') the second (each defaults to the first frame's), or ``frame1`` /
``frame2`` give both; the remaining keywords are the kind's constants (angles in
radians, lengths in model units).  The first body is the one named first.

``gear`` (book 4.6.9), variables ``phi1`` (angle), ``phi2``, ``phi3`` (lengths).
    w, w' on the two gear axes, parallel, same sense; ``origin``/``origin2`` on the
    axes, in the gears' mid planes; t = common perpendicular from w to w'; at the
    modeling posture u, u' and t parallel (phi1 = 0; whole turns of t are found).
    phi1 = angle u -> t about w, phi2 = centre distance beyond nominal, phi3 = offset
    of the u'v' plane along w.  Constants: ``radius1=``, ``radius2=`` (signed pitch
    radii, negative = internal gear) or IMP's ``ratio=`` (first / second, + external,
    - internal) with ``distance=`` (centre distance; omitted: taken from the frames),
    ``pressure_angle=`` (20 deg), ``helix_angle=`` (0), ``load_sign=`` (0).  The load
    sign sgn(F) of (4.28) is constant number :data:`GEAR_LOAD_SIGN_SLOT` (6) of the
    joint, 0 for kinematics, to be set to +-1 by force analysis.  Internal pairs: the
    second axis is at +|R + R'| along t (the book's signed R + R' would put it at
    -|R + R'|, which its own extraction (4.29) does not invert).
``rack`` (4.6.10), ``phi1``, ``phi2``, ``phi3`` (lengths).  First body = rack.  u
    along the pitch line, w along the pinion axis, ``origin`` on the pitch line,
    ``origin2`` at the pinion centre; u' parallel to u when the pinion centre is on
    the v axis.  Pinion centre = (phi1, R' + phi2, phi3); theta = -(phi1 + sgn(F)
    phi2 tan a - phi3 tan b)/R'.  Constants ``radius=`` (signed: + pinion on the +v
    side), ``pressure_angle=``, ``helix_angle=``, ``load_sign=`` (slot
    :data:`RACK_LOAD_SIGN_SLOT` = 3).
``bevel`` (4.6.11), ``phi1``, ``phi2`` (angles).  w, w' along the gear axes pointing
    away from the common apex, ``ref`` = ``ref2`` = t = w x w' at phi1 = 0.
    Constants ``gamma1=``, ``gamma2=`` (pitch-cone half-angles; frames at the apex)
    or IMP's ``ratio=`` (> 0; ``shaft_angle=``, default 90 deg); ``radius=`` (pitch
    radius of the second gear) puts the frames at the pitch-circle centres.
    **Decision:** pitch cones roll without slip, phi' = -(sin g1/sin g2) phi1 =
    -(R1/R2) phi1 (digest ch 1-6, section 9 item 8); ``book_ratio=True`` gives the
    book's / IMP's +(tan g1/tan g2) phi1.  The (1,1) entry of (4.34) is corrected.
``point_curve`` (4.6.12), ``t`` (curve parameter, unscaled), ``phi2`` (angle),
    ``phi3`` (length).  First body carries the curve (u(t), v(t)) in its uv plane,
    ``origin2`` = the point, on the curve.  ``line_curve`` (4.6.13): ``t``, ``phi2``
    (distance along +u' from the u'v'w' origin to the contact), ``phi3``; u' along
    the curve's tangent (corrected theta' and Q1 of 6.29).  Curve constants:
    ``curve=f`` (callable t -> (u, v, du, dv, d2u, d2v, d3u, d3v)), ``table=[[u, v],
    ...]`` (equally spaced in t over ``period=`` (2 pi; periodic cubic spline,
    ``closed=True`` if the last row repeats the first) or over ``range=(t0, t1)``
    (not-a-knot spline)), or ``fourier=((au, bu), (av, bv))`` (f = a0 + sum a_k cos
    k w t + b_k sin k w t, w = 2 pi / period).  Tables and Fourier series are stored
    as numbers in the constants and evaluated in nopython mode; callables are
    registered (:func:`register_curve`) and called back through a numba ``objmode``
    block.  :func:`curve_parameter` is the numeric inverse used at assembly.
``cam`` (IMP), ``phi1``, ``phi2`` (angles).  First body = cam.  w, w' normal to the
    pitch-curve plane; ``origin`` on the cam axis, ``origin2`` on the pitch curve;
    phi1 = angle u -> t (t from the cam origin to the follower origin), phi2 = angle
    t -> u'.  Pitch-curve radius r(phi1) over one turn: ``table=[r, ...]`` (n values
    at 2 pi k / n; ``closed=True`` if the last repeats the first;
    ``interpolation="fourier"`` for IMP's trigonometric interpolation instead of the
    periodic cubic spline), ``fourier=(a, b)`` or ``function=f`` (t -> (r, dr, d2r,
    d3r)).
``slot`` (IMP), ``u`` (length), ``phi2`` (angle).  First body = slotted link.  The
    follower origin runs on the centreline v = f(u): ``table=[v, ...]`` equally spaced
    over ``range=(u_start, u_end)`` (both ends sampled) or ``function=f``.
``ujoint`` (IMP's UJOINT), ``phi1``, ``phi2``.  Common origin; ``axis`` = pin of
    the first body, ``axis2`` = pin of the second, perpendicular; t = w x w'; phi1 =
    angle u -> t about w, phi2 = angle t -> u' about w'.
``sphere_plane``, ``x``, ``y`` (lengths), ``e1..e4`` (Euler-Rodrigues, one
    normalisation row).  Ball fixed in the second body on a plane of the first;
    ``origin`` = ball centre, ``axis`` = plane normal from the plane toward the ball.
``sphere_groove``, ``s`` (length), ``e1..e4``.  Ball in a straight groove of the
    first body; ``origin`` = ball centre, ``ref`` = u along the groove.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from openimp._jit import njit
from openimp.errors import InputError
from openimp.limits import MAX_GEAR_RATIO

try:  # object-mode blocks call registered Python curve functions from compiled kernels
    from numba import objmode as _objmode
except ImportError:  # pragma: no cover - only without numba (OPENIMP_NOJIT debugging)
    import contextlib

    def _objmode(**_types: str) -> contextlib.AbstractContextManager[None]:
        return contextlib.nullcontext()

# --- integer codes dispatched inside the kernels -------------------------------
RIGID = 0
REVOLUTE = 1
PRISMATIC = 2
SCREW = 3
CYLINDER = 4
SPHERE = 5
FLAT = 6
OPEN = 7
GEAR = 8
RACK = 9
BEVEL = 10
POINT_CURVE = 11
LINE_CURVE = 12
CAM = 13
SLOT = 14
UJOINT = 15
SPHERE_PLANE = 16
SPHERE_GROOVE = 17

#: Largest number of variables of any joint (the open joint: 3 + 4).
MAXV = 7


# =============================================================================
# Small 4x4 helpers usable inside kernels
# =============================================================================
@njit(inline="always")
def _eye(out: np.ndarray) -> None:
    for i in range(4):
        for j in range(4):
            out[i, j] = 0.0
        out[i, i] = 1.0


@njit(inline="always")
def _rotz(out: np.ndarray, a: float) -> None:
    """Rotation about w by ``a`` into a 4x4 (translation left to the caller)."""
    ca = math.cos(a)
    sa = math.sin(a)
    _eye(out)
    out[0, 0] = ca
    out[0, 1] = -sa
    out[1, 0] = sa
    out[1, 1] = ca


@njit(inline="always")
def _er_rot(out: np.ndarray, e: np.ndarray, k: int) -> None:
    """Theta(e) of book (3.50) from e[k:k+4] into out[:3,:3]."""
    e1 = e[k]
    e2 = e[k + 1]
    e3 = e[k + 2]
    e4 = e[k + 3]
    out[0, 0] = e1 * e1 - e2 * e2 - e3 * e3 + e4 * e4
    out[0, 1] = 2.0 * (e1 * e2 - e3 * e4)
    out[0, 2] = 2.0 * (e1 * e3 + e2 * e4)
    out[1, 0] = 2.0 * (e1 * e2 + e3 * e4)
    out[1, 1] = -e1 * e1 + e2 * e2 - e3 * e3 + e4 * e4
    out[1, 2] = 2.0 * (e2 * e3 - e1 * e4)
    out[2, 0] = 2.0 * (e1 * e3 - e2 * e4)
    out[2, 1] = 2.0 * (e2 * e3 + e1 * e4)
    out[2, 2] = -e1 * e1 - e2 * e2 + e3 * e3 + e4 * e4


@njit
def _er_Q(out: np.ndarray, e: np.ndarray, k: int, g: int) -> None:
    """3x3 block of the Euler-Rodrigues operator Q^g (book 6.22) into out[:3,:3].

    Equal to (dTheta/de_g) Theta^T on the unit sphere |e| = 1.  The symmetric
    part (diagonal 2 e_g) is annihilated by the normalisation row.
    """
    e1 = 2.0 * e[k]
    e2 = 2.0 * e[k + 1]
    e3 = 2.0 * e[k + 2]
    e4 = 2.0 * e[k + 3]
    if g == 0:
        out[0, 0] = e1
        out[0, 1] = e2
        out[0, 2] = e3
        out[1, 0] = -e2
        out[1, 1] = e1
        out[1, 2] = -e4
        out[2, 0] = -e3
        out[2, 1] = e4
        out[2, 2] = e1
    elif g == 1:
        out[0, 0] = e2
        out[0, 1] = -e1
        out[0, 2] = e4
        out[1, 0] = e1
        out[1, 1] = e2
        out[1, 2] = e3
        out[2, 0] = -e4
        out[2, 1] = -e3
        out[2, 2] = e2
    elif g == 2:
        out[0, 0] = e3
        out[0, 1] = -e4
        out[0, 2] = -e1
        out[1, 0] = e4
        out[1, 1] = e3
        out[1, 2] = -e2
        out[2, 0] = e1
        out[2, 1] = e2
        out[2, 2] = e3
    else:
        out[0, 0] = e4
        out[0, 1] = e3
        out[0, 2] = -e2
        out[1, 0] = -e3
        out[1, 1] = e4
        out[1, 2] = e1
        out[2, 0] = e2
        out[2, 1] = -e1
        out[2, 2] = e4


@njit
def _er_dQ(out: np.ndarray, g: int, i: int) -> None:
    """3x3 block of Q^{g,i} = dQ^g/de_i (constant; book 8.13 with its sign repaired).

    Q^g is linear in e, so its derivative along e_i is Q^g evaluated at the
    i-th unit vector.
    """
    unit = np.zeros(4)
    unit[i] = 1.0
    _er_Q(out, unit, 0, g)


# =============================================================================
# Kernels: Phi, Q, dQ for every code
# =============================================================================
@njit
def joint_phi(code: int, q: np.ndarray, c: np.ndarray, out: np.ndarray) -> None:
    """Joint matrix Phi(q) of a joint of kind ``code`` with constants ``c``."""
    if code == REVOLUTE:
        _rotz(out, q[0])
    elif code == PRISMATIC:
        _eye(out)
        out[2, 3] = q[0]
    elif code == SCREW:
        _rotz(out, q[0] / c[0])
        out[2, 3] = q[0]
    elif code == CYLINDER:
        _rotz(out, q[0])
        out[2, 3] = q[1]
    elif code == SPHERE:
        _eye(out)
        _er_rot(out, q, 0)
    elif code == FLAT:
        _rotz(out, q[2])
        out[0, 3] = q[0]
        out[1, 3] = q[1]
    elif code == OPEN:
        _eye(out)
        _er_rot(out, q, 3)
        out[0, 3] = q[0]
        out[1, 3] = q[1]
        out[2, 3] = q[2]
    elif code >= GEAR:
        _higher_phi(code, q, c, out)
    else:  # RIGID
        _eye(out)


@njit
def joint_Q(code: int, q: np.ndarray, c: np.ndarray, out: np.ndarray) -> None:
    """Derivative operators Q_g (g = 0..nvar-1) into ``out[g]`` (shape (MAXV, 4, 4))."""
    nv = _nvar(code)
    for g in range(nv):
        for i in range(4):
            for j in range(4):
                out[g, i, j] = 0.0
    if code == REVOLUTE:
        out[0, 0, 1] = -1.0
        out[0, 1, 0] = 1.0
    elif code == PRISMATIC:
        out[0, 2, 3] = 1.0
    elif code == SCREW:
        out[0, 0, 1] = -1.0 / c[0]
        out[0, 1, 0] = 1.0 / c[0]
        out[0, 2, 3] = 1.0
    elif code == CYLINDER:
        out[0, 0, 1] = -1.0
        out[0, 1, 0] = 1.0
        out[1, 2, 3] = 1.0
    elif code == SPHERE:
        for g in range(4):
            _er_Q(out[g], q, 0, g)
    elif code == FLAT:
        out[0, 0, 3] = 1.0
        out[1, 1, 3] = 1.0
        out[2, 0, 1] = -1.0
        out[2, 1, 0] = 1.0
        out[2, 0, 3] = q[1]
        out[2, 1, 3] = -q[0]
    elif code == OPEN:
        out[0, 0, 3] = 1.0
        out[1, 1, 3] = 1.0
        out[2, 2, 3] = 1.0
        for g in range(4):
            _er_Q(out[3 + g], q, 3, g)
            for i in range(3):
                out[3 + g, i, 3] = -(
                    out[3 + g, i, 0] * q[0] + out[3 + g, i, 1] * q[1] + out[3 + g, i, 2] * q[2]
                )
    elif code >= GEAR:
        _higher_Q(code, q, c, out)


@njit
def joint_dQ(code: int, q: np.ndarray, c: np.ndarray, out: np.ndarray) -> None:
    """Second-derivative operators Q_{g,i} = dQ_g/dq_i into ``out[g, i]`` (MAXV, MAXV, 4, 4)."""
    nv = _nvar(code)
    for g in range(nv):
        for i in range(nv):
            for r in range(4):
                for s in range(4):
                    out[g, i, r, s] = 0.0
    if code == SPHERE:
        for g in range(4):
            for i in range(4):
                _er_dQ(out[g, i], g, i)
    elif code == FLAT:
        out[2, 0, 1, 3] = -1.0
        out[2, 1, 0, 3] = 1.0
    elif code == OPEN:
        for g in range(4):
            for i in range(4):
                _er_dQ(out[3 + g, 3 + i], g, i)
                blk = out[3 + g, 3 + i]
                for r in range(3):
                    blk[r, 3] = -(blk[r, 0] * q[0] + blk[r, 1] * q[1] + blk[r, 2] * q[2])
            # dQ^g/dp_i: column 4 is minus the i-th column of the 3x3 block of Q^g
            tmp = np.zeros((4, 4))
            _er_Q(tmp, q, 3, g)
            for i in range(3):
                for r in range(3):
                    out[3 + g, i, r, 3] = -tmp[r, i]
    elif code >= GEAR:
        _higher_dQ(code, q, c, out)


@njit(inline="always")
def _nvar(code: int) -> int:
    """Number of variables of a joint kind (must agree with :data:`CATALOGUE`)."""
    if code == RIGID:
        return 0
    if code == REVOLUTE or code == PRISMATIC or code == SCREW:
        return 1
    if code == CYLINDER:
        return 2
    if code == SPHERE:
        return 4
    if code == FLAT:
        return 3
    if code == OPEN:
        return 7
    return _higher_nvar(code)


# =============================================================================
# Higher pairs (book 4.6.9-4.6.13, IMP's CAM, SLOT, UJOINT; sphere-plane, sphere-groove)
# =============================================================================
#: index, in a gear's constants, of the load sign sgn(F) of book (4.28); 0 for kinematics,
#: +1/-1 set by force analysis (K.const[K.jc0[h] + GEAR_LOAD_SIGN_SLOT])
GEAR_LOAD_SIGN_SLOT = 6
#: index, in a rack's constants, of its load sign sgn(F) (book 4.31)
RACK_LOAD_SIGN_SLOT = 3

# Function blocks stored in the constants array (curve data evaluated inside kernels).
# Every block starts with [kind, length of the block in slots, ...].
FUN_CALLABLE = 0  # [0, 3, id]: registered Python callable t -> (f, f', f'', f''')
FUN_PERIODIC = 1  # [1, len, n, t0, h, degree, n*(degree+1) coefficients]: periodic spline
FUN_SPLINE = 2  # same layout as FUN_PERIODIC; outside [t0, t0+n h] the end pieces extend
FUN_FOURIER = 3  # [3, len, m, t0, period, a0, a1..am, b1..bm]
CURVE_CALLABLE = 4  # [4, 3, id]: registered callable t -> (u, v, u', v', u'', v'', u''', v''')
#: offset of the curve block in the constants of point_curve / line_curve
#: ([length unit, t_start, t_end, periodic, curve ...])
_CURVE_AT = 4


def _call_registered(ident: float, t: float, n: int) -> np.ndarray:
    """Evaluate the registered curve callable number ``ident`` at ``t`` (object mode)."""
    fn = _CALLABLES[int(ident)]
    res = np.asarray(fn(float(t)), dtype=np.float64).reshape(-1)
    if res.shape[0] < n:
        raise ValueError(f"curve callable {int(ident)} returned {res.shape[0]} values, needs {n}")
    return np.ascontiguousarray(res[:n])


#: registered curve callables by integer id (the id is stored in the joint constants)
_CALLABLES: dict[int, Callable[[float], Any]] = {}


@njit(nogil=False)  # its object-mode block takes the GIL anyway
def _fun_eval(c: np.ndarray, k: int, t: float, out: np.ndarray, o: int, stride: int) -> None:
    """Evaluate the function block at ``c[k]`` at ``t``: value and three derivatives.

    Writes ``out[o + j*stride]`` for j = 0..3 (f, f', f'', f''') or, for a
    parametric callable, j = 0..7 (u, v, u', v', u'', v'', u''', v''').
    """
    kind = int(c[k])
    if kind == FUN_CALLABLE or kind == CURVE_CALLABLE:
        n = 4 if kind == FUN_CALLABLE else 8
        ident = c[k + 2]
        with _objmode(res="float64[:]"):
            res = _call_registered(ident, t, n)
        for j in range(n):
            out[o + j * stride] = res[j]
    elif kind == FUN_FOURIER:
        m = int(c[k + 2])
        t0 = c[k + 3]
        w = 2.0 * math.pi / c[k + 4]
        x = w * (t - t0)
        f0 = c[k + 5]
        f1 = 0.0
        f2 = 0.0
        f3 = 0.0
        for j in range(1, m + 1):
            a = c[k + 5 + j]
            b = c[k + 5 + m + j]
            cj = math.cos(j * x)
            sj = math.sin(j * x)
            kw = j * w
            f0 += a * cj + b * sj
            f1 += kw * (b * cj - a * sj)
            f2 -= kw * kw * (a * cj + b * sj)
            f3 += kw * kw * kw * (a * sj - b * cj)
        out[o] = f0
        out[o + stride] = f1
        out[o + 2 * stride] = f2
        out[o + 3 * stride] = f3
    else:  # piecewise polynomial (spline), highest power first per interval
        n = int(c[k + 2])
        t0 = c[k + 3]
        h = c[k + 4]
        d = int(c[k + 5])
        s = (t - t0) / h
        i = math.floor(s)
        if kind == FUN_PERIODIC:
            i = i % n
            x = (s - math.floor(s)) * h
        else:
            if i < 0:
                i = 0
            elif i > n - 1:
                i = n - 1
            x = t - (t0 + i * h)
        base = k + 6 + i * (d + 1)
        for r in range(4):
            acc = 0.0
            for j in range(d + 1 - r):
                # coefficient of x**(d-j) differentiated r times
                p = d - j
                fac = 1.0
                for m2 in range(r):
                    fac *= p - m2
                acc = acc * x + c[base + j] * fac
            out[o + r * stride] = acc


@njit
def _curve_eval(c: np.ndarray, k: int, t: float, out: np.ndarray) -> None:
    """Parametric planar curve at ``c[k]``: out = (u, v, u', v', u'', v'', u''', v''')."""
    if int(c[k]) == CURVE_CALLABLE:
        _fun_eval(c, k, t, out, 0, 1)
    else:
        _fun_eval(c, k, t, out, 0, 2)
        _fun_eval(c, k + int(c[k + 1]), t, out, 1, 2)


@njit
def _is_planar(code: int) -> bool:
    return (
        code == GEAR or code == RACK or code == POINT_CURVE or code == LINE_CURVE
        or code == CAM or code == SLOT
    )


@njit
def _planar_terms(
    code: int, q: np.ndarray, c: np.ndarray, T: np.ndarray, TG: np.ndarray, TGI: np.ndarray,
    P: np.ndarray, PG: np.ndarray, PGI: np.ndarray,
) -> int:
    """Angle, translation and their derivatives of a planar higher pair.

    Every planar kind has Phi = [[Rz(theta(q)), p(q)], [0, 1]].  Fills
    T[0] = theta, TG[g] = dtheta/dq_g, TGI[g, i], P = p, PG[g] = dp/dq_g,
    PGI[g, i] (all zeroed first) and returns the number of variables.
    """
    nv = _higher_nvar(code)
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
        sg = c[6]
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
        c1 = math.cos(q[0])
        s1 = math.sin(q[0])
        P[0] = C * c1
        P[1] = C * s1
        P[2] = q[2]
        PG[0, 0] = -C * s1
        PG[0, 1] = C * c1
        PG[1, 0] = c1
        PG[1, 1] = s1
        PG[2, 2] = 1.0
        PGI[0, 0, 0] = -C * c1
        PGI[0, 0, 1] = -C * s1
        PGI[0, 1, 0] = -s1
        PGI[0, 1, 1] = c1
        PGI[1, 0, 0] = -s1
        PGI[1, 0, 1] = c1
    elif code == RACK:
        Rp = c[0]
        sg = c[3]
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
        _curve_eval(c, _CURVE_AT, q[0], cv)
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
        _fun_eval(c, 1, q[0], fv, 0, 1)
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
        _fun_eval(c, 3, q[0] / ls, fv, 0, 1)
        T[0] = q[1]
        TG[1] = 1.0
        P[0] = q[0]
        P[1] = fv[0] * ls
        PG[0, 0] = 1.0
        PG[0, 1] = fv[1]
        PGI[0, 0, 1] = fv[2] / ls
    return nv


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
def _elem_rot(axis: int, a: float, order: int, out: np.ndarray) -> None:
    """3x3 rotation about z (axis 2) or x (axis 0) by ``a``, or its 1st/2nd derivative."""
    for i in range(3):
        for j in range(3):
            out[i, j] = 0.0
    ca = math.cos(a)
    sa = math.sin(a)
    # derivative of order k of (cos, sin) is (cos(a + k pi/2), sin(a + k pi/2))
    if order == 0:
        cc, ss, one = ca, sa, 1.0
    elif order == 1:
        cc, ss, one = -sa, ca, 0.0
    else:
        cc, ss, one = -ca, -sa, 0.0
    if axis == 2:
        out[0, 0] = cc
        out[0, 1] = -ss
        out[1, 0] = ss
        out[1, 1] = cc
        out[2, 2] = one
    else:
        out[0, 0] = one
        out[1, 1] = cc
        out[1, 2] = -ss
        out[2, 1] = ss
        out[2, 2] = cc


@njit
def _mm3(A: np.ndarray, B: np.ndarray, out: np.ndarray) -> None:
    for i in range(3):
        for j in range(3):
            out[i, j] = A[i, 0] * B[0, j] + A[i, 1] * B[1, j] + A[i, 2] * B[2, j]


@njit
def _zxz_derivs(ang: np.ndarray, rate: np.ndarray, M: np.ndarray, MG: np.ndarray,
                MGI: np.ndarray) -> None:
    """M = Rz(a) Rx(b) Rz(c), MG[g] = dM/dq_g, MGI[g, i] = d2M/dq_g dq_i (3x3 each)."""
    F = np.empty((3, 3, 3, 3))  # F[factor, order]
    axes = (2, 0, 2)
    for f in range(3):
        for o in range(3):
            _elem_rot(axes[f], ang[f], o, F[f, o])
    tmp = np.empty((3, 3))
    prod = np.empty((3, 3))
    _mm3(F[0, 0], F[1, 0], tmp)
    _mm3(tmp, F[2, 0], M)
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
                _mm3(F[0, o0], F[1, o1], tmp)
                _mm3(tmp, F[2, o2], prod)
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
    """Offset of the Euler-Rodrigues block of a sphere-plane / sphere-groove joint."""
    return 2 if code == SPHERE_PLANE else 1


@njit
def _higher_nvar(code: int) -> int:
    """Number of variables of a higher-pair kind."""
    if code == GEAR or code == RACK or code == POINT_CURVE or code == LINE_CURVE:
        return 3
    if code == BEVEL or code == CAM or code == SLOT or code == UJOINT:
        return 2
    if code == SPHERE_PLANE:
        return 6
    if code == SPHERE_GROOVE:
        return 5
    return 0


@njit(inline="always")
def _higher_phi(code: int, q: np.ndarray, c: np.ndarray, out: np.ndarray) -> None:
    """Phi(q) of a higher pair."""
    if _is_planar(code):
        T = np.empty(1)
        TG = np.empty(3)
        TGI = np.empty((3, 3))
        P = np.empty(3)
        PG = np.empty((3, 3))
        PGI = np.empty((3, 3, 3))
        _planar_terms(code, q, c, T, TG, TGI, P, PG, PGI)
        _rotz(out, T[0])
        out[0, 3] = P[0]
        out[1, 3] = P[1]
        out[2, 3] = P[2]
    elif code == UJOINT or code == BEVEL:
        ang = np.empty(3)
        rate = np.empty((3, 2))
        off = np.empty(2)
        _zxz_terms(code, q, c, ang, rate, off)
        A = np.empty((3, 3))
        B = np.empty((3, 3))
        tmp = np.empty((3, 3))
        _elem_rot(2, ang[0], 0, A)
        _elem_rot(0, ang[1], 0, B)
        _mm3(A, B, tmp)
        _elem_rot(2, ang[2], 0, A)
        _mm3(tmp, A, B)
        _eye(out)
        for i in range(3):
            for j in range(3):
                out[i, j] = B[i, j]
            out[i, 3] = off[1] * B[i, 2]
        out[2, 3] -= off[0]
    elif code == SPHERE_PLANE or code == SPHERE_GROOVE:
        k = _er_trans(code)
        _eye(out)
        _er_rot(out, q, k)
        out[0, 3] = q[0]
        if code == SPHERE_PLANE:
            out[1, 3] = q[1]
    else:
        _eye(out)


@njit(inline="always")
def _higher_Q(code: int, q: np.ndarray, c: np.ndarray, out: np.ndarray) -> None:
    """Q_g of a higher pair into out[g] (already zeroed by joint_Q)."""
    if _is_planar(code):
        T = np.empty(1)
        TG = np.empty(3)
        TGI = np.empty((3, 3))
        P = np.empty(3)
        PG = np.empty((3, 3))
        PGI = np.empty((3, 3, 3))
        nv = _planar_terms(code, q, c, T, TG, TGI, P, PG, PGI)
        # Q_g = [[theta_g Z, p_g - theta_g Z p], [0, 0]], Z p = (-p_v, p_u, 0)
        for g in range(nv):
            tg = TG[g]
            out[g, 0, 1] = -tg
            out[g, 1, 0] = tg
            out[g, 0, 3] = PG[g, 0] + tg * P[1]
            out[g, 1, 3] = PG[g, 1] - tg * P[0]
            out[g, 2, 3] = PG[g, 2]
    elif code == UJOINT or code == BEVEL:
        ang = np.empty(3)
        rate = np.empty((3, 2))
        off = np.empty(2)
        _zxz_terms(code, q, c, ang, rate, off)
        M = np.empty((3, 3))
        MG = np.empty((2, 3, 3))
        MGI = np.empty((2, 2, 3, 3))
        _zxz_derivs(ang, rate, M, MG, MGI)
        V = np.empty((3, 3))
        for g in range(2):
            # W_g = M_g M^T
            for i in range(3):
                for j in range(3):
                    V[i, j] = MG[g, i, 0] * M[j, 0] + MG[g, i, 1] * M[j, 1] + MG[g, i, 2] * M[j, 2]
            _set_ops_block(V, off[0], out[g])
    elif code == SPHERE_PLANE or code == SPHERE_GROOVE:
        k = _er_trans(code)
        out[0, 0, 3] = 1.0
        if code == SPHERE_PLANE:
            out[1, 1, 3] = 1.0
        p0 = q[0]
        p1 = q[1] if code == SPHERE_PLANE else 0.0
        for g in range(4):
            blk = out[k + g]
            _er_Q(blk, q, k, g)
            for i in range(3):
                blk[i, 3] = -(blk[i, 0] * p0 + blk[i, 1] * p1)


@njit(inline="always")
def _higher_dQ(code: int, q: np.ndarray, c: np.ndarray, out: np.ndarray) -> None:
    """Q_{g,i} of a higher pair into out[g, i] (already zeroed by joint_dQ)."""
    if _is_planar(code):
        T = np.empty(1)
        TG = np.empty(3)
        TGI = np.empty((3, 3))
        P = np.empty(3)
        PG = np.empty((3, 3))
        PGI = np.empty((3, 3, 3))
        nv = _planar_terms(code, q, c, T, TG, TGI, P, PG, PGI)
        # d/dq_i [[theta_g Z, p_g - theta_g Z p]]
        for g in range(nv):
            for i in range(nv):
                tgi = TGI[g, i]
                tg = TG[g]
                blk = out[g, i]
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
        V = np.empty((3, 3))
        for g in range(2):
            for i2 in range(2):
                # d(M_g M^T)/dq_i = M_gi M^T + M_g M_i^T
                for i in range(3):
                    for j in range(3):
                        s = 0.0
                        for m in range(3):
                            s += MGI[g, i2, i, m] * M[j, m] + MG[g, i, m] * MG[i2, j, m]
                        V[i, j] = s
                _set_ops_block(V, off[0], out[g, i2])
    elif code == SPHERE_PLANE or code == SPHERE_GROOVE:
        k = _er_trans(code)
        p0 = q[0]
        p1 = q[1] if code == SPHERE_PLANE else 0.0
        tmp = np.zeros((4, 4))
        for g in range(4):
            for i in range(4):
                blk = out[k + g, k + i]
                _er_dQ(blk, g, i)
                for r in range(3):
                    blk[r, 3] = -(blk[r, 0] * p0 + blk[r, 1] * p1)
            # dQ^g/dx, dQ^g/dy: column 4 is minus the matching column of the 3x3 block
            _er_Q(tmp, q, k, g)
            for t in range(k):
                for r in range(3):
                    out[k + g, t, r, 3] = -tmp[r, t]


# =============================================================================
# Python side: the catalogue, extraction and conformity
# =============================================================================
def _angle_of(Phi: np.ndarray) -> float:
    """Rotation angle about w of a 4x4 (book 4.11, robust atan2 form)."""
    return math.atan2(Phi[1, 0] - Phi[0, 1], Phi[0, 0] + Phi[1, 1])


def rotation_to_er(R: np.ndarray, eps: float = 1e-6) -> np.ndarray:
    """Euler-Rodrigues parameters of a rotation (book 3.51-3.55, e4 >= 0)."""
    from openimp.spatial import rotation_to_er as _r2e

    return np.asarray(_r2e(np.asarray(R, dtype=float)[:3, :3], eps=eps), dtype=float)


def _extract_lower(code: int, Phi: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Joint variables of a lower pair from its measured matrix (book 4.x extraction)."""
    if code == REVOLUTE:
        return np.array([_angle_of(Phi)])
    if code == PRISMATIC:
        return np.array([Phi[2, 3]])
    if code == SCREW:
        # The slide is the variable; the rotation must match slide/pitch modulo a turn,
        # so take the turn count that makes them agree best.
        return np.array([Phi[2, 3]])
    if code == CYLINDER:
        return np.array([_angle_of(Phi), Phi[2, 3]])
    if code == SPHERE:
        return rotation_to_er(Phi)
    if code == FLAT:
        return np.array([Phi[0, 3], Phi[1, 3], _angle_of(Phi)])
    if code == OPEN:
        return np.concatenate([Phi[:3, 3], rotation_to_er(Phi)])
    return np.zeros(0)


@dataclass(frozen=True)
class JointType:
    """One kind of joint: its variables, constants and conventions.

    ``var_kinds`` entries are ``"angle"``, ``"length"`` or ``"er"``;
    ``const_kinds`` entries are ``"length"`` (scaled with the model),
    ``"ratio"`` or ``"angle"`` (not scaled).  ``er_groups`` lists the index of
    the first of each block of four Euler-Rodrigues parameters, each of which
    adds one normalisation row to the Jacobian.
    """

    name: str
    code: int
    var_names: tuple[str, ...]
    var_kinds: tuple[str, ...]
    convention: str
    const_names: tuple[str, ...] = ()
    const_kinds: tuple[str, ...] = ()
    er_groups: tuple[int, ...] = ()
    #: builds the constants array from keyword arguments (validated); None: no constants
    make_consts: Callable[[str, dict[str, Any]], np.ndarray] | None = None
    #: q from a measured Phi (internal units); default: the lower-pair formulas
    extract: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None
    #: kinds whose first body has a mandatory role (rack, cam, slot, curves)
    order_note: str = ""
    aliases: tuple[str, ...] = field(default=())
    #: fills, in place, constants that depend on the modeling posture (a gear's centre
    #: distance taken from its frames); called by :func:`conformity` before extraction
    #: with (joint name, measured Phi, internal constants)
    complete: Callable[[str, np.ndarray, np.ndarray], None] | None = None

    @property
    def nvar(self) -> int:
        """Number of joint variables."""
        return len(self.var_names)

    def extract_q(self, Phi: np.ndarray, c: np.ndarray) -> np.ndarray:
        """Joint variables from a measured joint matrix."""
        if self.extract is not None:
            return np.asarray(self.extract(Phi, c), dtype=float)
        return _extract_lower(self.code, Phi, c)


def _no_consts(name: str, kw: dict[str, Any]) -> np.ndarray:
    if kw:
        bad = ", ".join(sorted(kw))
        raise InputError(f"joint {name!r}: unexpected constant(s) {bad}; this kind takes none")
    return np.zeros(0)


def _screw_consts(name: str, kw: dict[str, Any]) -> np.ndarray:
    args = _Args(name, "screw", kw, ("lead", "pitch"))
    if args.has("lead"):
        pitch = args.number("lead", nonzero=True) / (2.0 * math.pi)
    elif args.has("pitch"):
        pitch = args.number("pitch", nonzero=True)
    else:
        raise args.err(
            "give its lead (advance per turn, + right hand) as lead=..., "
            "or pitch=... (advance per radian); use a revolute for zero lead"
        )
    return np.array([pitch])


#: Every joint kind by name.  Aliases (xpin, zslide, ...) map to these entries;
#: the higher pairs are registered further below.
CATALOGUE: dict[str, JointType] = {}


def register(jt: JointType) -> None:
    """Add a joint kind (and its aliases) to :data:`CATALOGUE`."""
    for n in (jt.name, *jt.aliases):
        CATALOGUE[n] = jt


register(JointType("rigid", RIGID, (), (), "the two frames coincide",
                   make_consts=_no_consts))
register(JointType(
    "revolute", REVOLUTE, ("theta",), ("angle",),
    "w and w' on the axis, same sense, common origin; theta from u to u' about w",
    make_consts=_no_consts, aliases=("pin", "xpin", "ypin", "zpin"),
))
register(JointType(
    "prismatic", PRISMATIC, ("s",), ("length",),
    "w and w' collinear along the slide, same sense; u parallel u'; s from u to u' along w",
    make_consts=_no_consts, aliases=("slide", "prism", "xslide", "yslide", "zslide"),
))
register(JointType(
    "screw", SCREW, ("s",), ("length",),
    "w and w' on the axis, same sense; s = slide along w, rotation = s / pitch",
    const_names=("pitch",), const_kinds=("length",), make_consts=_screw_consts,
    aliases=("helical",),
))
register(JointType(
    "cylinder", CYLINDER, ("theta", "s"), ("angle", "length"),
    "w and w' on the common axis, same sense; theta about w, s along w",
    make_consts=_no_consts, aliases=("cylindric",),
))
register(JointType(
    "sphere", SPHERE, ("e1", "e2", "e3", "e4"), ("er", "er", "er", "er"),
    "common origin at the ball centre; Euler-Rodrigues parameters of u'v'w' in uvw",
    er_groups=(0,), make_consts=_no_consts, aliases=("spheric", "ball"),
))
register(JointType(
    "flat", FLAT, ("x", "y", "theta"), ("length", "length", "angle"),
    "uv and u'v' planes coincide, w and w' normal on the same side; x, y of the "
    "u'v'w' origin along u, v; theta from u to u' about w",
    make_consts=_no_consts, aliases=("plane", "planar"),
))
register(JointType(
    "open", OPEN, ("x", "y", "z", "e1", "e2", "e3", "e4"),
    ("length", "length", "length", "er", "er", "er", "er"),
    "no constraint: origin of u'v'w' in uvw and Euler-Rodrigues parameters",
    er_groups=(3,), make_consts=_no_consts,
))

# =============================================================================
# Higher pairs: constants, curve data, extraction (Python side)
# =============================================================================
_TWO_PI = 2.0 * math.pi


def register_curve(fn: Callable[[float], Any]) -> int:
    """Register a Python curve callable; returns the integer id stored in the constants.

    The kernels call it back through a numba ``objmode`` block, so the same
    compiled kernels serve tabulated and programmed curves.  Ids are valid in
    the current process only (a compiled System holding a callable curve
    cannot be pickled to another process).
    """
    ident = len(_CALLABLES) + 1
    while ident in _CALLABLES:
        ident += 1
    _CALLABLES[ident] = fn
    return ident


class _Args:
    """Keyword constants of one joint, consumed one by one with named errors."""

    def __init__(self, name: str, kind: str, kw: dict[str, Any], accepted: tuple[str, ...]):
        self.name = name
        self.kind = kind
        self.kw = dict(kw)
        self.accepted = accepted
        unknown = sorted(k for k in self.kw if k not in accepted)
        if unknown:
            raise InputError(
                f"{kind} joint {name!r}: unexpected constant(s) {', '.join(unknown)}; "
                f"this kind takes {', '.join(accepted)}"
            )

    def err(self, msg: str) -> InputError:
        return InputError(f"{self.kind} joint {self.name!r}: {msg}")

    def has(self, key: str) -> bool:
        return self.kw.get(key) is not None

    def number(self, key: str, default: float | None = None, *, nonzero: bool = False,
               positive: bool = False) -> float:
        v = self.kw.get(key)
        if v is None:
            if default is None:
                raise self.err(f"give {key}=...")
            return float(default)
        try:
            x = float(v)
        except (TypeError, ValueError):
            raise self.err(f"{key} must be a number, got {v!r}") from None
        if not math.isfinite(x):
            raise self.err(f"{key} must be a finite number, got {v!r}")
        if nonzero and x == 0.0:
            raise self.err(f"{key} must not be zero")
        if positive and x <= 0.0:
            raise self.err(f"{key} must be positive, got {x:g}")
        return x

    def array(self, key: str, value: Any = None, ndim: int = 1) -> np.ndarray:
        v = self.kw.get(key) if value is None else value
        try:
            a = np.asarray(v, dtype=float)
        except (TypeError, ValueError):
            raise self.err(f"{key} must be an array of numbers") from None
        if a.ndim != ndim:
            raise self.err(f"{key} must be a {ndim}-dimensional array of numbers, "
                           f"got shape {a.shape}")
        if not np.all(np.isfinite(a)):
            raise self.err(f"{key} holds non-finite values")
        return a


def _pp_block(kind: int, t0: float, h: float, coef: np.ndarray) -> list[float]:
    """Function block of a piecewise polynomial; ``coef`` is scipy's (degree+1, n)."""
    d = coef.shape[0] - 1
    n = coef.shape[1]
    body = [float(n), t0, h, float(d), *coef.T.reshape(-1).tolist()]
    return [float(kind), float(2 + len(body)), *body]


def _fourier_block(t0: float, period: float, a: np.ndarray, b: np.ndarray) -> list[float]:
    m = len(a) - 1
    body = [float(m), t0, period, *a.tolist(), *b.tolist()]
    return [float(FUN_FOURIER), float(2 + len(body)), *body]


def _table_fourier(y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Trigonometric interpolation (IMP's TABLE) of n equally spaced periodic samples."""
    n = len(y)
    F = np.fft.rfft(y) / n
    m = n // 2
    a = np.zeros(m + 1)
    b = np.zeros(m)
    a[0] = F[0].real
    for k in range(1, m + 1):
        scale = 1.0 if (n % 2 == 0 and k == m) else 2.0
        a[k] = scale * F[k].real
        b[k - 1] = -scale * F[k].imag
    if n % 2 == 0:
        b[m - 1] = 0.0  # the Nyquist sine vanishes at every sample
    return a, b


def _spline_block(args: _Args, key: str, y: np.ndarray, t0: float, span: float,
                  periodic: bool) -> list[float]:
    """Cubic spline through equally spaced samples (periodic, or not-a-knot over a range)."""
    from scipy.interpolate import CubicSpline

    n = len(y)
    if periodic:
        if n < 3:
            raise args.err(f"{key} needs at least 3 values over one period, got {n}")
        h = span / n
        x = t0 + h * np.arange(n + 1)
        cs = CubicSpline(x, np.append(y, y[0]), bc_type="periodic")
        return _pp_block(FUN_PERIODIC, t0, h, cs.c)
    if n < 4:
        raise args.err(f"{key} needs at least 4 values over its range, got {n}")
    h = span / (n - 1)
    x = t0 + h * np.arange(n)
    cs = CubicSpline(x, y, bc_type="not-a-knot")
    return _pp_block(FUN_SPLINE, t0, h, cs.c)


def _check_callable(args: _Args, key: str, fn: Any, n: int, lo: float, hi: float) -> None:
    if not callable(fn):
        raise args.err(f"{key} must be a callable t -> {n} numbers, got {fn!r}")
    for t in np.linspace(lo, hi, 5):
        try:
            r = np.asarray(fn(float(t)), dtype=float).reshape(-1)
        except Exception as exc:  # the user's function failed: say where
            raise args.err(f"{key}({t:g}) raised {type(exc).__name__}: {exc}") from None
        if r.shape[0] != n or not np.all(np.isfinite(r)):
            raise args.err(
                f"{key}({t:g}) must return {n} finite numbers "
                f"({'u, v, du, dv, d2u, d2v, d3u, d3v' if n == 8 else 'f, df, d2f, d3f'}), "
                f"got {r.tolist()}"
            )


def _domain(args: _Args, default: tuple[float, float]) -> tuple[float, float]:
    if not args.has("range"):
        return default
    r = args.array("range")
    if r.shape != (2,) or not r[1] > r[0]:
        raise args.err(f"range must be two increasing numbers (start, end), got {r.tolist()}")
    return float(r[0]), float(r[1])


def _scalar_function(args: _Args, what: str, periodic: bool,
                     default_range: tuple[float, float]) -> tuple[list[float], tuple[float, float],
                                                                   bool]:
    """Function block of a scalar function given as table=, fourier= or function=.

    Returns (block, (t_start, t_end), periodic).
    """
    forms = [k for k in ("table", "fourier", "function") if args.has(k)]
    if len(forms) != 1:
        raise args.err(
            f"give the {what} as exactly one of table=[...] (equally spaced samples), "
            f"fourier=(a, b) (coefficients) or function=f (callable t -> (f, f', f'', f'''))"
            + (f"; got {', '.join(forms)}" if forms else "")
        )
    form = forms[0]
    t0, t1 = _domain(args, default_range)
    if form == "function":
        fn = args.kw["function"]
        _check_callable(args, "function", fn, 4, t0, t1)
        return [float(FUN_CALLABLE), 3.0, float(register_curve(fn))], (t0, t1), periodic
    if form == "fourier":
        a, b = _fourier_arrays(args, args.kw["fourier"], "fourier")
        return _fourier_block(t0, t1 - t0, a, b), (t0, t1), True
    y = args.array("table")
    if periodic and args.kw.get("closed", False):
        if len(y) < 2 or abs(y[-1] - y[0]) > 1e-9 * max(1.0, float(np.max(np.abs(y)))):
            raise args.err(
                "closed=True says the last table value repeats the first, but they differ "
                f"({y[0]:g} and {y[-1]:g}); drop closed=True or fix the table"
            )
        y = y[:-1]
    interp = str(args.kw.get("interpolation", "spline")).lower()
    if interp not in ("spline", "fourier"):
        raise args.err(f"interpolation must be 'spline' or 'fourier', got {interp!r}")
    if interp == "fourier":
        if not periodic:
            raise args.err("interpolation='fourier' needs a periodic table")
        if len(y) < 3:
            raise args.err(f"table needs at least 3 values over one period, got {len(y)}")
        a, b = _table_fourier(y)
        return _fourier_block(t0, t1 - t0, a, b), (t0, t1), True
    return _spline_block(args, "table", y, t0, t1 - t0, periodic), (t0, t1), periodic


def _fourier_arrays(args: _Args, spec: Any, key: str) -> tuple[np.ndarray, np.ndarray]:
    try:
        a_raw, b_raw = spec
    except (TypeError, ValueError):
        raise args.err(f"{key} must be a pair (a, b) of coefficient lists: "
                       "f = a0 + sum_k a_k cos(k w t) + b_k sin(k w t)") from None
    a = args.array(key, a_raw)
    b = args.array(key, b_raw)
    if len(a) < 1 or len(b) != len(a) - 1:
        raise args.err(
            f"{key}: the cosine list a = [a0, a1, ..., am] must be one longer than the "
            f"sine list b = [b1, ..., bm]; got {len(a)} and {len(b)} values"
        )
    return a, b


# --- curve joints: layout [lscale, t_start, t_end, periodic, curve block ...] ---------
def _curve_consts(name: str, kind: str, kw: dict[str, Any]) -> np.ndarray:
    """Constants of a point-on-curve / line-tangent-to-curve joint.

    The curve is one of
    ``curve=f`` a callable t -> (u, v, du, dv, d2u, d2v, d3u, d3v), periodic with
    ``period=P`` (default 2 pi) or open over ``range=(t0, t1)`` (the parameter interval
    searched at assembly);
    ``table=[[u, v], ...]`` samples equally spaced in t: over one period
    ``period=P`` (default 2 pi, periodic cubic spline; ``closed=True`` if the
    last row repeats the first), or over ``range=(t0, t1)`` (first and last
    sample at the ends; not-a-knot cubic spline, not periodic);
    ``fourier=((au, bu), (av, bv))`` IMP's Fourier form over ``period=P``.
    Lengths in model units.
    """
    args = _Args(name, kind, kw, ("curve", "table", "fourier", "period", "range", "closed"))
    forms = [k for k in ("curve", "table", "fourier") if args.has(k)]
    if len(forms) != 1:
        raise args.err(
            "give the curve as exactly one of curve=f (callable t -> (u, v, du, dv, d2u, "
            "d2v, d3u, d3v)), table=[[u, v], ...] (equally spaced samples) or "
            "fourier=((au, bu), (av, bv))" + (f"; got {', '.join(forms)}" if forms else "")
        )
    form = forms[0]
    if args.has("period") and args.has("range"):
        raise args.err("give period= (periodic curve) or range= (open curve), not both")
    period = args.number("period", _TWO_PI, positive=True)
    if form == "curve":
        t0, t1 = _domain(args, (0.0, period))
        _check_callable(args, "curve", args.kw["curve"], 8, t0, t1)
        block = [float(CURVE_CALLABLE), 3.0, float(register_curve(args.kw["curve"]))]
        info = [t0, t1, 0.0 if args.has("range") else 1.0]
    elif form == "fourier":
        spec = args.kw["fourier"]
        try:
            su, sv = spec
        except (TypeError, ValueError):
            raise args.err("fourier must be ((au, bu), (av, bv))") from None
        au, bu = _fourier_arrays(args, su, "fourier (u)")
        av, bv = _fourier_arrays(args, sv, "fourier (v)")
        block = _fourier_block(0.0, period, au, bu) + _fourier_block(0.0, period, av, bv)
        info = [0.0, period, 1.0]
    else:
        tab = args.array("table", ndim=2)
        if tab.shape[1] != 2:
            raise args.err(f"table must have two columns (u, v), got shape {tab.shape}")
        if args.has("range"):
            t0, t1 = _domain(args, (0.0, 1.0))
            block = (_spline_block(args, "table", tab[:, 0], t0, t1 - t0, False)
                     + _spline_block(args, "table", tab[:, 1], t0, t1 - t0, False))
            info = [t0, t1, 0.0]
        else:
            if args.kw.get("closed", False):
                if len(tab) < 2 or np.max(np.abs(tab[-1] - tab[0])) > 1e-9 * max(
                        1.0, float(np.max(np.abs(tab)))):
                    raise args.err("closed=True says the last table row repeats the first, "
                                   "but they differ")
                tab = tab[:-1]
            block = (_spline_block(args, "table", tab[:, 0], 0.0, period, True)
                     + _spline_block(args, "table", tab[:, 1], 0.0, period, True))
            info = [0.0, period, 1.0]
    # [lscale, info(3), curve block]
    return np.array([1.0, *info, *block])


def _curve_points(c: np.ndarray, ts: np.ndarray) -> np.ndarray:
    """(len(ts), 8) curve values and derivatives in internal units."""
    out = np.empty((len(ts), 8))
    row = np.empty(8)
    for j, t in enumerate(ts):
        _curve_eval(c, _CURVE_AT, float(t), row)
        out[j] = row
    return out * c[0]


def _wrap(a: float) -> float:
    return (a + math.pi) % _TWO_PI - math.pi


def _search_grid(c: np.ndarray) -> tuple[np.ndarray, bool]:
    t0, t1, periodic = float(c[1]), float(c[2]), bool(c[3])
    n = 2048
    if periodic:
        return t0 + (t1 - t0) * np.arange(n) / n, True
    return np.linspace(t0, t1, n), False


def _refine(fun: Callable[[float], tuple[float, float]], a: float, b: float) -> float:
    """Root of fun (value, slope) bracketed in [a, b]: Newton with bisection safeguard."""
    fa = fun(a)[0]
    t = 0.5 * (a + b)
    for _ in range(100):
        f, df = fun(t)
        if f == 0.0:
            return t
        if (f < 0.0) == (fa < 0.0):
            a, fa = t, f
        else:
            b = t
        tn = t - f / df if df != 0.0 else 0.5 * (a + b)
        if not (min(a, b) < tn < max(a, b)):
            tn = 0.5 * (a + b)
        if abs(tn - t) <= 1e-15 * max(1.0, abs(t)):
            return tn
        t = tn
    return t


def curve_parameter(c: np.ndarray, x: float, y: float) -> tuple[float, float]:
    """Closest point of a curve joint's curve to (x, y) (first joint frame, internal units).

    ``c`` are the joint's internal constants.  Returns (parameter, distance).
    This is the numeric inverse f^-1 of book (4.38) used at assembly.
    """
    ts, periodic = _search_grid(c)
    pts = _curve_points(c, ts)
    d2 = (pts[:, 0] - x) ** 2 + (pts[:, 1] - y) ** 2
    order = np.argsort(d2)[:8]
    best_t, best_d = float(ts[order[0]]), math.sqrt(float(d2[order[0]]))
    step = float(ts[1] - ts[0])

    def g(t: float) -> tuple[float, float]:
        r = _curve_points(c, np.array([t]))[0]
        dx, dy = r[0] - x, r[1] - y
        return dx * r[2] + dy * r[3], r[2] ** 2 + r[3] ** 2 + dx * r[4] + dy * r[5]

    for j in order:
        a, b = float(ts[j]) - step, float(ts[j]) + step
        if not periodic:
            a, b = max(a, float(ts[0])), min(b, float(ts[-1]))
        ga, gb = g(a)[0], g(b)[0]
        cands = [float(ts[j])]
        if ga == 0.0:
            cands.append(a)
        elif gb == 0.0:
            cands.append(b)
        elif (ga < 0.0) != (gb < 0.0):
            cands.append(_refine(g, a, b))
        for t in cands:
            r = _curve_points(c, np.array([t]))[0]
            d = math.hypot(r[0] - x, r[1] - y)
            if d < best_d:
                best_t, best_d = t, d
    return best_t, best_d


def _extract_point_curve(Phi: np.ndarray, c: np.ndarray) -> np.ndarray:
    x, y = float(Phi[0, 3]), float(Phi[1, 3])
    t, dist = curve_parameter(c, x, y)
    if dist > 1e-8:
        r = _curve_points(c, np.array([t]))[0]
        L = 1.0 / c[0]
        raise InputError(
            f"the u'v'w' origin is not on the curve: it is {dist * L:.6g} length units from "
            f"it (closest curve point at parameter {t:.10g}, u = {r[0] * L:.10g}, "
            f"v = {r[1] * L:.10g} in the first joint frame); place the second frame's origin "
            "on the curve"
        )
    return np.array([t, _angle_of(Phi), Phi[2, 3]])


def _extract_line_curve(Phi: np.ndarray, c: np.ndarray) -> np.ndarray:
    x, y = float(Phi[0, 3]), float(Phi[1, 3])
    th = _angle_of(Phi)
    ct, st = math.cos(th), math.sin(th)
    ts, periodic = _search_grid(c)
    pts = _curve_points(c, ts)
    # tangent parallel to u': h(t) = u' sin(th) - v' cos(th) = 0 with the same sense
    h = pts[:, 2] * st - pts[:, 3] * ct
    same = pts[:, 2] * ct + pts[:, 3] * st > 0.0

    def hf(t: float) -> tuple[float, float]:
        r = _curve_points(c, np.array([t]))[0]
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
            t = _refine(hf, a, b)
        r = _curve_points(c, np.array([t]))[0]
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


def _gear_consts(name: str, kw: dict[str, Any]) -> np.ndarray:
    args = _Args(name, "gear", kw, ("radius1", "radius2", "ratio", "distance",
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
    alpha = args.number("pressure_angle", math.radians(20.0))
    if not 0.0 <= alpha < 0.5 * math.pi:
        raise args.err(f"pressure_angle must be in [0, pi/2) radians, got {alpha:g}")
    beta = args.number("helix_angle", 0.0)
    if not abs(beta) < 0.5 * math.pi:
        raise args.err(f"helix_angle must be in (-pi/2, pi/2) radians, got {beta:g}")
    sg = args.number("load_sign", 0.0)
    if sg not in (-1.0, 0.0, 1.0):
        raise args.err(f"load_sign must be -1, 0 or +1, got {sg:g}")
    return np.array([R, Rp, D0, math.cos(alpha), math.sin(alpha), math.tan(beta), sg, ratio])


def _check_gear_ratio(args: _Args, ratio: float) -> None:
    """Refuse a ratio (R/R') whose gear radii or turn counting would overflow:
    |ratio| and |1 + ratio| within [1/MAX_GEAR_RATIO, MAX_GEAR_RATIO]."""
    low = 1.0 / MAX_GEAR_RATIO
    if not (low <= abs(ratio) <= MAX_GEAR_RATIO and low <= abs(1.0 + ratio)):
        raise args.err(f"the ratio {ratio:g} is out of range: |ratio| must lie between "
                       f"{low:g} and {MAX_GEAR_RATIO:g} and |1 + ratio| be at least {low:g} "
                       "(limit MAX_GEAR_RATIO)")


def _gear_complete(name: str, Phi: np.ndarray, c: np.ndarray) -> None:
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
    _planar_terms(GEAR, np.asarray(q, float), c, T, TG, TGI, P, PG, PGI)
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


def _extract_gear(Phi: np.ndarray, c: np.ndarray) -> np.ndarray:
    x, y = float(Phi[0, 3]), float(Phi[1, 3])
    C = math.hypot(x, y)
    if C < 1e-12:
        raise InputError("the two gear axes coincide: the line of centres t is undefined")
    q = np.array([math.atan2(y, x), C - c[2], Phi[2, 3]])
    th0 = _gear_theta(q, c)
    k = _best_turns(th0, (c[0] + c[1]) / c[1], _angle_of(Phi))
    q[0] += _TWO_PI * k
    return q


def _rack_consts(name: str, kw: dict[str, Any]) -> np.ndarray:
    args = _Args(name, "rack", kw, ("radius", "pressure_angle", "helix_angle", "load_sign"))
    if not args.has("radius"):
        raise args.err("give radius= (pinion pitch radius: + if the pinion is on the +v side "
                       "of the rack, - otherwise)")
    Rp = args.number("radius", nonzero=True)
    alpha = args.number("pressure_angle", math.radians(20.0))
    if not 0.0 <= alpha < 0.5 * math.pi:
        raise args.err(f"pressure_angle must be in [0, pi/2) radians, got {alpha:g}")
    beta = args.number("helix_angle", 0.0)
    if not abs(beta) < 0.5 * math.pi:
        raise args.err(f"helix_angle must be in (-pi/2, pi/2) radians, got {beta:g}")
    sg = args.number("load_sign", 0.0)
    if sg not in (-1.0, 0.0, 1.0):
        raise args.err(f"load_sign must be -1, 0 or +1, got {sg:g}")
    return np.array([Rp, math.tan(alpha), math.tan(beta), sg])


def _extract_rack(Phi: np.ndarray, c: np.ndarray) -> np.ndarray:
    return np.array([Phi[0, 3], Phi[1, 3] - c[0], Phi[2, 3]])


# --- bevel -----------------------------------------------------------------------------
def _bevel_consts(name: str, kw: dict[str, Any]) -> np.ndarray:
    args = _Args(name, "bevel", kw, ("gamma1", "gamma2", "ratio", "shaft_angle", "radius",
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


def _extract_bevel(Phi: np.ndarray, c: np.ndarray) -> np.ndarray:
    st = math.hypot(Phi[0, 2], Phi[1, 2])
    if st < 1e-9:
        raise InputError("w and w' are parallel: the common perpendicular t is undefined")
    th = math.atan2(st, Phi[2, 2])
    p1 = math.atan2(-Phi[0, 2], -Phi[1, 2])
    pprime = math.atan2(Phi[2, 0], Phi[2, 1])
    k = _best_turns(c[0] * p1, c[0], pprime)
    return np.array([p1 + _TWO_PI * k, th - c[1]])


# --- cam and slot ------------------------------------------------------------------------
def _cam_consts(name: str, kw: dict[str, Any]) -> np.ndarray:
    args = _Args(name, "cam", kw, ("table", "fourier", "function", "closed", "interpolation"))
    block, _, _ = _scalar_function(args, "pitch-curve radius r(angle)", True, (0.0, _TWO_PI))
    return np.array([1.0, *block])


def _extract_cam(Phi: np.ndarray, c: np.ndarray) -> np.ndarray:
    x, y = float(Phi[0, 3]), float(Phi[1, 3])
    r = math.hypot(x, y)
    p1 = math.atan2(y, x)
    fv = np.empty(4)
    _fun_eval(c, 1, p1, fv, 0, 1)
    rc = fv[0] * c[0]
    if abs(rc - r) > 1e-8:
        L = 1.0 / c[0]
        raise InputError(
            f"the follower origin is not on the pitch curve: at the cam angle "
            f"{math.degrees(p1):.6g} deg its radius is {r * L:.10g} but the pitch curve's is "
            f"{rc * L:.10g}; place the second frame's origin on the pitch curve"
        )
    return np.array([p1, _wrap(_angle_of(Phi) - p1)])


def _slot_consts(name: str, kw: dict[str, Any]) -> np.ndarray:
    args = _Args(name, "slot", kw, ("table", "function", "range"))
    if not args.has("range"):
        raise args.err("give range=(u_start, u_end), the slot's extent along u "
                       "(the table's first and last samples sit at its ends)")
    block, (u0, u1), _ = _scalar_function(args, "slot centreline v(u)", False, (0.0, 1.0))
    return np.array([1.0, u0, u1, *block])


def _extract_slot(Phi: np.ndarray, c: np.ndarray) -> np.ndarray:
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
    _fun_eval(c, 3, um, fv, 0, 1)
    v = fv[0] * c[0]
    if abs(v - Phi[1, 3]) > 1e-8:
        raise InputError(
            f"the follower origin is not on the slot centreline: at u = {um:.10g} its v is "
            f"{Phi[1, 3] * L:.10g} but the centreline's is {v * L:.10g}"
        )
    return np.array([u, _angle_of(Phi)])


# --- universal joint, sphere-plane, sphere-groove --------------------------------------
def _extract_ujoint(Phi: np.ndarray, c: np.ndarray) -> np.ndarray:
    if math.hypot(Phi[0, 2], Phi[1, 2]) < 1e-9:
        raise InputError("w and w' are parallel: the common perpendicular t is undefined")
    return np.array([math.atan2(Phi[0, 2], -Phi[1, 2]), math.atan2(Phi[2, 0], Phi[2, 1])])


def _extract_sphere_plane(Phi: np.ndarray, c: np.ndarray) -> np.ndarray:
    return np.concatenate([[Phi[0, 3], Phi[1, 3]], rotation_to_er(Phi)])


def _extract_sphere_groove(Phi: np.ndarray, c: np.ndarray) -> np.ndarray:
    return np.concatenate([[Phi[0, 3]], rotation_to_er(Phi)])


_ER4 = ("e1", "e2", "e3", "e4")

register(JointType(
    "gear", GEAR, ("phi1", "phi2", "phi3"), ("angle", "length", "length"),
    "parallel-axis gear (book 4.6.9). w on the first gear's axis, w' on the second's, "
    "parallel, same sense; t = common perpendicular from w to w'. phi1 = angle from u to t "
    "about w; phi2 = centre distance beyond nominal |R + R'|, along t; phi3 = offset of the "
    "u'v' plane from the uv plane along w. The rotation of u' from u is theta = [(R + R') "
    "phi1 + sgn(F){sqrt((|R+R'| + phi2)^2 - (|R+R'| cos a)^2) - |R+R'| sin a} + phi3 tan b]"
    " / R'; at phi1 = 0 (modulo whole turns of t) u, u' and t are parallel",
    const_names=("radius1", "radius2", "distance", "cos_pressure", "sin_pressure",
                 "tan_helix", "load_sign", "ratio"),
    const_kinds=("length", "length", "length", "ratio", "ratio", "ratio", "ratio", "ratio"),
    make_consts=_gear_consts, extract=_extract_gear, complete=_gear_complete,
    aliases=("spur_gear", "parallel_gear"),
))

register(JointType(
    "rack", RACK, ("phi1", "phi2", "phi3"), ("length", "length", "length"),
    "rack and pinion (book 4.6.10); first body = rack, second = pinion. u along the rack's "
    "pitch line (positive pinion travel), w normal to the pitch plane, v toward the pinion; "
    "w' on the pinion axis, same sense as w. The pinion centre is at (phi1, R' + phi2, phi3) "
    "in uvw (R' signed: + when the pinion is on the +v side) and u' is turned from u by "
    "theta = -[phi1 + sgn(F) phi2 tan a - phi3 tan b] / R', so u' is parallel to u when the "
    "pinion centre is on the v axis",
    const_names=("radius", "tan_pressure", "tan_helix", "load_sign"),
    const_kinds=("length", "ratio", "ratio", "ratio"),
    make_consts=_rack_consts, extract=_extract_rack,
    order_note="the first body is the rack", aliases=("rack_pinion", "rack_and_pinion"),
))
register(JointType(
    "bevel", BEVEL, ("phi1", "phi2"), ("angle", "angle"),
    "straight bevel gear (book 4.6.11). w, w' on the gear axes, pointing away from the "
    "common apex of the pitch cones; t = w x w'. Phi = Tz(-d1) Rz(-phi1) Rx(gamma1 + "
    "gamma2 + phi2) Rz(kappa phi1) Tz(d2): phi1 = angle from t to u about w, phi2 = shaft "
    "angle beyond gamma1 + gamma2 about t, u' at kappa phi1 from t about w'. Rolling "
    "pitch cones: kappa = -sin(gamma1)/sin(gamma2) = -R1/R2 (the book's and IMP's "
    "+tan(gamma1)/tan(gamma2) only with book_ratio=True). Frames at the apex (d1 = d2 = 0) "
    "or, with radius=, at the centres of the pitch circles (d = cone distance x cos gamma); "
    "at phi1 = 0, u and u' lie along t",
    const_names=("kappa", "shaft_angle", "offset1", "offset2", "gamma1", "gamma2"),
    const_kinds=("ratio", "angle", "length", "length", "angle", "angle"),
    make_consts=_bevel_consts, extract=_extract_bevel, aliases=("bevel_gear",),
))
register(JointType(
    "point_curve", POINT_CURVE, ("t", "phi2", "phi3"), ("angle", "angle", "length"),
    "point on a planar curve (book 4.6.12); first body carries the curve (u(t), v(t)) in "
    "its uv plane, second the point (origin of u'v'w'); w' parallel to w, same sense. t = "
    "curve parameter (dimensionless, unscaled), phi2 = angle from u to u' about w, phi3 = "
    "offset of the u'v' plane along w",
    const_names=("length_unit", "t_start", "t_end", "periodic", "curve"),
    const_kinds=("length",),
    make_consts=lambda name, kw: _curve_consts(name, "point_curve", kw),
    extract=_extract_point_curve, order_note="the first body carries the curve",
    aliases=("point_on_curve", "curve_point"),
))
register(JointType(
    "line_curve", LINE_CURVE, ("t", "phi2", "phi3"), ("angle", "length", "length"),
    "line tangent to a planar curve (book 4.6.13); first body carries the curve (u(t), "
    "v(t)), second the line along +u' (a flat-faced follower); w' parallel to w. u' is "
    "along the curve's tangent d(u, v)/dt at the contact (same sense); t = curve parameter "
    "of the contact point, phi2 = distance along +u' from the u'v'w' origin to the contact, "
    "phi3 = offset along w",
    const_names=("length_unit", "t_start", "t_end", "periodic", "curve"),
    const_kinds=("length",),
    make_consts=lambda name, kw: _curve_consts(name, "line_curve", kw),
    extract=_extract_line_curve, order_note="the first body carries the curve",
    aliases=("line_on_curve", "tangent_line", "flat_follower"),
))
register(JointType(
    "cam", CAM, ("phi1", "phi2"), ("angle", "angle"),
    "IMP's CAM; first body = cam, second = follower. w, w' normal to the pitch-curve plane, "
    "same sense, u v and u' v' in that plane; the u'v'w' origin lies on the pitch curve "
    "r(phi1) (radius from the uvw origin, one full turn, periodic); t = from the uvw origin "
    "to the u'v'w' origin. phi1 = angle from u to t about w, phi2 = angle from t to u' "
    "about w'",
    const_names=("length_unit", "radius_function"), const_kinds=("length",),
    make_consts=_cam_consts, extract=_extract_cam, order_note="the first body is the cam",
))
register(JointType(
    "slot", SLOT, ("u", "phi2"), ("length", "angle"),
    "IMP's SLOT; first body = slotted link, second = follower. w, w' normal to the slot "
    "plane, same sense; the u'v'w' origin lies on the slot centreline v = f(u), tabulated "
    "over the slot's u range. u = u-coordinate of the u'v'w' origin, phi2 = angle from a "
    "line parallel to u to u' about w'",
    const_names=("length_unit", "u_start", "u_end", "centreline"), const_kinds=("length",),
    make_consts=_slot_consts, extract=_extract_slot,
    order_note="the first body is the slotted link",
))
register(JointType(
    "ujoint", UJOINT, ("phi1", "phi2"), ("angle", "angle"),
    "universal (Hooke) joint, IMP's UJOINT: common origin at the centre of the cross; w on "
    "the first body's pin, w' on the second's, perpendicular; t = w x w'. phi1 = angle from "
    "u to t about w, phi2 = angle from t to u' about w'. Phi = Rz(phi1) Rx(90 deg) Rz(phi2)",
    make_consts=_no_consts, extract=_extract_ujoint,
    aliases=("universal", "hooke", "cardan"),
))
register(JointType(
    "sphere_plane", SPHERE_PLANE, ("x", "y", *_ER4), ("length", "length", "er", "er", "er",
                                                      "er"),
    "sphere fixed in the second body touching a plane of the first. Both frames have their "
    "origin at the sphere centre at the modeling posture; w normal to the plane, pointing "
    "from the plane toward the sphere (the uv plane is the plane of the sphere centre). "
    "x, y = centre in uvw; e1..e4 = Euler-Rodrigues parameters of u'v'w' in uvw. "
    "Phi = [[Theta(e), (x, y, 0)], [0, 1]]",
    er_groups=(2,), make_consts=_no_consts, extract=_extract_sphere_plane,
    order_note="the first body carries the plane", aliases=("ball_plane",),
))
register(JointType(
    "sphere_groove", SPHERE_GROOVE, ("s", *_ER4), ("length", "er", "er", "er", "er"),
    "sphere fixed in the second body running in a straight cylindrical groove of the first. "
    "Both frames have their origin at the sphere centre at the modeling posture; u along "
    "the groove (the line of sphere centres). s = centre along u; e1..e4 = Euler-Rodrigues "
    "parameters of u'v'w' in uvw. Phi = [[Theta(e), (s, 0, 0)], [0, 1]]",
    er_groups=(1,), make_consts=_no_consts, extract=_extract_sphere_groove,
    order_note="the first body carries the groove", aliases=("ball_groove",),
))


#: default direction of w (and of u) for the axis-named aliases
ALIAS_AXES: dict[str, tuple[tuple[float, float, float], tuple[float, float, float]]] = {
    "xpin": ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0)),
    "ypin": ((0.0, 1.0, 0.0), (0.0, 0.0, 1.0)),
    "zpin": ((0.0, 0.0, 1.0), (1.0, 0.0, 0.0)),
    "xslide": ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0)),
    "yslide": ((0.0, 1.0, 0.0), (0.0, 0.0, 1.0)),
    "zslide": ((0.0, 0.0, 1.0), (1.0, 0.0, 0.0)),
}


def joint_type(kind: str) -> JointType:
    """The catalogue entry of a kind name (case-insensitive), or an InputError."""
    key = kind.lower()
    if key not in CATALOGUE:
        known = ", ".join(sorted(CATALOGUE))
        raise InputError(f"unknown joint kind {kind!r}; known kinds: {known}")
    return CATALOGUE[key]


def phi_of(jt: JointType, q: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Phi(q) as a new 4x4 array (Python convenience over :func:`joint_phi`)."""
    out = np.zeros((4, 4))
    joint_phi(jt.code, np.ascontiguousarray(q, dtype=float), np.ascontiguousarray(c, float), out)
    return out


def Q_of(jt: JointType, q: np.ndarray, c: np.ndarray) -> np.ndarray:
    """All Q_g as an (nvar, 4, 4) array."""
    out = np.zeros((MAXV, 4, 4))
    joint_Q(jt.code, np.ascontiguousarray(q, dtype=float), np.ascontiguousarray(c, float), out)
    return out[: jt.nvar].copy()


def dQ_of(jt: JointType, q: np.ndarray, c: np.ndarray) -> np.ndarray:
    """All Q_{g,i} as an (nvar, nvar, 4, 4) array."""
    out = np.zeros((MAXV, MAXV, 4, 4))
    joint_dQ(jt.code, np.ascontiguousarray(q, dtype=float), np.ascontiguousarray(c, float), out)
    n = jt.nvar
    return out[:n, :n].copy()


def conformity(
    jt: JointType, name: str, Phi: np.ndarray, c: np.ndarray, length_unit: float, tol: float
) -> np.ndarray:
    """Extract ``q`` from a measured ``Phi`` and check that ``Phi(q)`` reproduces it.

    Returns ``q``.  Kinds with a ``complete`` hook first fill the constants that
    depend on the modeling posture into ``c`` (in place; the caller must store
    ``c`` after this call).  A mismatch means the two joint frames break the kind's
    conventions (a revolute whose axes do not coincide, a prismatic whose
    frames are rotated, ...); that is an :class:`InputError` naming the joint,
    the size of the mismatch and the convention to satisfy.
    """
    if jt.complete is not None:
        jt.complete(name, Phi, c)
    try:
        q = jt.extract_q(Phi, c)
    except InputError as exc:
        raise InputError(f"joint {name!r} ({jt.name}): {exc}") from None
    back = phi_of(jt, q, c)
    # the screw's rotation is only known modulo a turn: check it separately
    drot = float(np.max(np.abs(back[:3, :3] - Phi[:3, :3])))
    dpos = float(np.max(np.abs(back[:3, 3] - Phi[:3, 3])))
    if drot > tol or dpos > tol:
        ang = math.degrees(math.acos(max(-1.0, min(1.0, (np.trace(back[:3, :3].T @ Phi[:3, :3])
                                                         - 1.0) / 2.0))))
        raise InputError(
            f"joint {name!r} ({jt.name}): its two frames do not conform to the joint: "
            f"they differ by a rotation of {ang:.6g} deg and an offset of "
            f"{dpos * length_unit:.6g} length units that the joint cannot produce. "
            f"Convention: {jt.convention}. Check the joint's origin, axis and reference "
            f"directions (or frame1/frame2)."
        )
    return q
