"""Joints whose variables are IMP's own: Cardan angles x-y'-z'' (IMP's SPHERE and OPEN)
and the polar form of IMP's FLAT.

The catalogue's ``sphere`` and ``open`` turn by Euler-Rodrigues parameters,
which never lock, and its ``flat`` slides by (x, y); none of those variables
is an IMP variable, so none can carry a spring, a damper, a load, a motion or
an initial condition on IMP's terms.  These kinds have IMP's variables as
their coordinates (docs/imp-language.md §7.2): ``gimbal`` Phi = [[Rx(a) Ry(b) Rz(c), 0],
[0, 1]], ``open_cardan`` the same turned after a translation (x, y, z) in the
first frame, ``flat_polar`` Phi = Rz(phi1) Tx(r) Rz(phi2).  Like IMP's own
they are singular where IMP's are: the Cardan angles at b = +-90 deg (a and c
turn about one axis), the polar form at r = 0.

With R = Rx(a) Ry(b) Rz(c) the turns are about the axes (in the first frame)
a1 = x, a2 = Rx(a) y, a3 = Rx(a) Ry(b) z, so for a Cardan angle g,
Q_g = [[S(a_g), p x a_g], [0, 0]] (S(v) w = v x w; (dPhi/dq_g) Phi^-1 with p
independent of the angles), and dQ_g/dq_i = [[S(a_i x a_g), p x (a_i x a_g)],
[0, 0]] for an earlier angle i (a_g turns with every earlier turn), e_i x
a_g in the last column for a translation i, zero otherwise.
"""

from __future__ import annotations

import math

import numpy as np

from openimp._jit import njit
from openimp.joints.codes import OPEN_CARDAN


@njit
def _cardan_axes(a: float, b: float, A: np.ndarray) -> None:
    """A[g] = the axis of Cardan turn g in the first frame (3, 3)."""
    ca, sa = math.cos(a), math.sin(a)
    cb, sb = math.cos(b), math.sin(b)
    A[0, 0], A[0, 1], A[0, 2] = 1.0, 0.0, 0.0
    A[1, 0], A[1, 1], A[1, 2] = 0.0, ca, sa
    A[2, 0], A[2, 1], A[2, 2] = sb, -sa * cb, ca * cb


@njit
def _rotation_op(w: np.ndarray, p: np.ndarray, out: np.ndarray) -> None:
    """out += [[S(w), p x w], [0, 0]] (4, 4)."""
    out[0, 1] -= w[2]
    out[0, 2] += w[1]
    out[1, 0] += w[2]
    out[1, 2] -= w[0]
    out[2, 0] -= w[1]
    out[2, 1] += w[0]
    out[0, 3] += p[1] * w[2] - p[2] * w[1]
    out[1, 3] += p[2] * w[0] - p[0] * w[2]
    out[2, 3] += p[0] * w[1] - p[1] * w[0]


@njit
def cardan_calc(code: int, q: np.ndarray, Phi: np.ndarray, Q: np.ndarray, dQ: np.ndarray,
                order: int) -> None:
    """Phi, Q_g, Q_{g,i} of a ``gimbal`` (q = a, b, c) or an ``open_cardan`` (q = x, y,
    z, a, b, c) joint; Q and dQ arrive zeroed (:func:`~openimp.joints.calc.joint_calc`)."""
    nt = 3 if code == OPEN_CARDAN else 0
    a, b, c = q[nt], q[nt + 1], q[nt + 2]
    ca, sa = math.cos(a), math.sin(a)
    cb, sb = math.cos(b), math.sin(b)
    cc, sc = math.cos(c), math.sin(c)
    p = np.zeros(3)
    for k in range(nt):
        p[k] = q[k]
    # R = Rx(a) Ry(b) Rz(c)
    Phi[0, 0] = cb * cc
    Phi[0, 1] = -cb * sc
    Phi[0, 2] = sb
    Phi[1, 0] = ca * sc + sa * sb * cc
    Phi[1, 1] = ca * cc - sa * sb * sc
    Phi[1, 2] = -sa * cb
    Phi[2, 0] = sa * sc - ca * sb * cc
    Phi[2, 1] = sa * cc + ca * sb * sc
    Phi[2, 2] = ca * cb
    for i in range(3):
        Phi[i, 3] = p[i]
        Phi[3, i] = 0.0
    Phi[3, 3] = 1.0
    if order < 1:
        return
    A = np.empty((3, 3))
    _cardan_axes(a, b, A)
    for k in range(nt):
        Q[k, k, 3] = 1.0
    for g in range(3):
        _rotation_op(A[g], p, Q[nt + g])
    if order < 2:
        return
    w = np.empty(3)
    for g in range(3):
        ag = A[g]
        for k in range(nt):  # d(p x a_g)/dx_k = e_k x a_g
            blk = dQ[nt + g, k]
            blk[(k + 1) % 3, 3] -= ag[(k + 2) % 3]
            blk[(k + 2) % 3, 3] += ag[(k + 1) % 3]
        for i in range(g):  # a_g turns with the earlier turn i: da_g/dq_i = a_i x a_g
            ai = A[i]
            w[0] = ai[1] * ag[2] - ai[2] * ag[1]
            w[1] = ai[2] * ag[0] - ai[0] * ag[2]
            w[2] = ai[0] * ag[1] - ai[1] * ag[0]
            _rotation_op(w, p, dQ[nt + g, nt + i])


def cardan_angles(R: np.ndarray) -> np.ndarray:
    """(..., 3) angles (a, b, c) with R = Rx(a) Ry(b) Rz(c) of rotations (..., 3, 3) or
    joint matrices (..., 4, 4), b in [-90, 90] deg; at b = +-90 deg (a lock: only
    a +- c is defined) c = 0."""
    R = np.asarray(R, dtype=float)
    b = np.arctan2(R[..., 0, 2], np.hypot(R[..., 1, 2], R[..., 2, 2]))
    lock = np.hypot(R[..., 0, 0], R[..., 0, 1]) < 1e-12
    a = np.where(lock, np.arctan2(R[..., 2, 1], R[..., 1, 1]),
                 np.arctan2(-R[..., 1, 2], R[..., 2, 2]))
    c = np.where(lock, 0.0, np.arctan2(-R[..., 0, 1], R[..., 0, 0]))
    return np.stack([a, b, c], axis=-1)


def extract_gimbal(Phi: np.ndarray, c: np.ndarray) -> np.ndarray:
    """(a, b, c) of a gimbal joint from its measured ``Phi``; ``c`` is unused."""
    return cardan_angles(Phi)


def extract_open_cardan(Phi: np.ndarray, c: np.ndarray) -> np.ndarray:
    """(x, y, z, a, b, c) of an open_cardan joint from its measured ``Phi``."""
    return np.concatenate([Phi[:3, 3], cardan_angles(Phi)])


def extract_flat_polar(Phi: np.ndarray, c: np.ndarray) -> np.ndarray:
    """(phi1, r, phi2) of a flat_polar joint from its measured ``Phi``: r >= 0, phi1 = 0
    when the origins coincide."""
    x, y = float(Phi[0, 3]), float(Phi[1, 3])
    p1 = math.atan2(y, x) if math.hypot(x, y) > 0.0 else 0.0
    return np.array([p1, math.hypot(x, y), math.atan2(Phi[1, 0], Phi[0, 0]) - p1])
