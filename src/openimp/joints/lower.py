"""Lower pairs (book 4.6.1-4.6.8, 6.3): rigid, revolute, prismatic, screw, cylinder,
sphere, flat and open joints.

:func:`lower_calc` gives a lower pair's joint matrix ``Phi(q)`` (primed frame in
the unprimed one), its first-derivative operators ``Q_g = (dPhi/dq_g) Phi^-1``
and their derivatives ``Q_{g,i} = dQ_g/dq_i`` (8.2), together, in one pass over
the shared terms.  :func:`extract_lower` is the inverse used at assembly:
``q`` from a measured ``Phi``.  Spherical rotations use Euler-Rodrigues
parameters (3.48-3.50) with one normalisation row each (6.43).
"""

from __future__ import annotations

import math

import numpy as np

from openimp._jit import njit
from openimp.joints.codes import CYLINDER, FLAT, OPEN, PRISMATIC, REVOLUTE, SCREW, SPHERE
from openimp.mat4 import er_rotation as _er_rot
from openimp.mat4 import eye4, rotz4
from openimp.spatial import rot_z as _rot_z
from openimp.spatial import rotation_to_er as _rotation_to_er
from openimp.spatial import translation as _translation


@njit
def er_Q(out: np.ndarray, e: np.ndarray, k: int, g: int) -> None:
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
def er_dQ(out: np.ndarray, g: int, i: int) -> None:
    """3x3 block of Q^{g,i} = dQ^g/de_i (constant; book 8.13 with its sign repaired).

    Q^g is linear in e, so its derivative along e_i is Q^g evaluated at the
    i-th unit vector.
    """
    unit = np.zeros(4)
    unit[i] = 1.0
    er_Q(out, unit, 0, g)


@njit
def er_translation_ops(Q: np.ndarray, dQ: np.ndarray, q: np.ndarray, k: int, ntr: int,
                       order: int) -> None:
    """Operators of Phi = [[Theta(e), p], [0, 1]] with p = q[:ntr] and e = q[k:k+4].

    The translation variables (the first ``ntr``, along u, v, w) have
    Q_t = [[0, e_t], [0, 0]]; the Euler-Rodrigues ones Q_g = [[E_g, -E_g p],
    [0, 0]] (E_g of :func:`er_Q`), whose derivatives are [[E_gi, -E_gi p]]
    along e_i and -E_g e_t along p_t.  ``Q`` and ``dQ`` must be zeroed.
    """
    if order < 1:
        return
    for t in range(ntr):
        Q[t, t, 3] = 1.0
    for g in range(4):
        blk = Q[k + g]
        er_Q(blk, q, k, g)
        for i in range(3):
            s = 0.0
            for t in range(ntr):
                s += blk[i, t] * q[t]
            blk[i, 3] = -s
    if order < 2:
        return
    for g in range(4):
        for i in range(4):
            blk = dQ[k + g, k + i]
            er_dQ(blk, g, i)
            for r in range(3):
                s = 0.0
                for t in range(ntr):
                    s += blk[r, t] * q[t]
                blk[r, 3] = -s
        # dQ^g/dp_t: column 4 is minus the t-th column of the 3x3 block of Q^g
        for t in range(ntr):
            for r in range(3):
                dQ[k + g, t, r, 3] = -Q[k + g, r, t]


@njit
def lower_calc(code: int, q: np.ndarray, c: np.ndarray, Phi: np.ndarray, Q: np.ndarray,
               dQ: np.ndarray, order: int) -> None:
    """Phi, and with ``order`` >= 1 the Q_g, with ``order`` 2 the Q_{g,i}, of a lower pair.

    q: the joint's variables (nvar,); c: its constants; Phi: 4x4;
    Q: (>= nvar, 4, 4) and dQ: (>= nvar, >= nvar, 4, 4), zeroed by the caller
    (:func:`openimp.joints.calc.joint_calc`).
    """
    if code == REVOLUTE:
        rotz4(Phi, q[0])
        if order >= 1:
            Q[0, 0, 1] = -1.0
            Q[0, 1, 0] = 1.0
    elif code == PRISMATIC:
        eye4(Phi)
        Phi[2, 3] = q[0]
        if order >= 1:
            Q[0, 2, 3] = 1.0
    elif code == SCREW:
        rotz4(Phi, q[0] / c[0])
        Phi[2, 3] = q[0]
        if order >= 1:
            Q[0, 0, 1] = -1.0 / c[0]
            Q[0, 1, 0] = 1.0 / c[0]
            Q[0, 2, 3] = 1.0
    elif code == CYLINDER:
        rotz4(Phi, q[0])
        Phi[2, 3] = q[1]
        if order >= 1:
            Q[0, 0, 1] = -1.0
            Q[0, 1, 0] = 1.0
            Q[1, 2, 3] = 1.0
    elif code == SPHERE:
        eye4(Phi)
        _er_rot(Phi, q, 0)
        er_translation_ops(Q, dQ, q, 0, 0, order)
    elif code == FLAT:
        rotz4(Phi, q[2])
        Phi[0, 3] = q[0]
        Phi[1, 3] = q[1]
        if order >= 1:
            Q[0, 0, 3] = 1.0
            Q[1, 1, 3] = 1.0
            Q[2, 0, 1] = -1.0
            Q[2, 1, 0] = 1.0
            Q[2, 0, 3] = q[1]
            Q[2, 1, 3] = -q[0]
        if order >= 2:
            dQ[2, 0, 1, 3] = -1.0
            dQ[2, 1, 0, 3] = 1.0
    elif code == OPEN:
        eye4(Phi)
        _er_rot(Phi, q, 3)
        Phi[0, 3] = q[0]
        Phi[1, 3] = q[1]
        Phi[2, 3] = q[2]
        er_translation_ops(Q, dQ, q, 3, 3, order)
    else:  # RIGID
        eye4(Phi)


# =============================================================================
# Extraction (Python side)
# =============================================================================
def angle_of(Phi: np.ndarray) -> float:
    """Rotation angle about w of a 4x4 (book 4.11, robust atan2 form)."""
    return math.atan2(Phi[1, 0] - Phi[0, 1], Phi[0, 0] + Phi[1, 1])


def rotation_to_er(R: np.ndarray, eps: float = 1e-6) -> np.ndarray:
    """Euler-Rodrigues parameters of a rotation (book 3.51-3.55, e4 >= 0)."""
    return np.asarray(_rotation_to_er(np.asarray(R, dtype=float)[:3, :3], eps=eps), dtype=float)


def closed_phi(code: int, q: np.ndarray) -> np.ndarray:
    """Phi of a rigid, revolute, prismatic or cylindric joint, Rz(theta) Tz(s), in numpy.

    The joint matrices the kernels multiply in closed form
    (:func:`openimp.kinematics.position.right_phi`); assembly checks these
    kinds with it instead of compiling :func:`~openimp.joints.calc.joint_calc`.
    """
    th = q[0] if code in (REVOLUTE, CYLINDER) else 0.0
    s = q[0] if code == PRISMATIC else (q[1] if code == CYLINDER else 0.0)
    return _rot_z(th) @ _translation((0.0, 0.0, s))


def extract_lower(code: int, Phi: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Joint variables of a lower pair from its measured matrix (book 4.x extraction)."""
    if code == REVOLUTE:
        return np.array([angle_of(Phi)])
    if code == PRISMATIC or code == SCREW:
        # a screw's slide is its variable; the rotation (known modulo a turn) is
        # checked by the conformity test
        return np.array([Phi[2, 3]])
    if code == CYLINDER:
        return np.array([angle_of(Phi), Phi[2, 3]])
    if code == SPHERE:
        return rotation_to_er(Phi)
    if code == FLAT:
        return np.array([Phi[0, 3], Phi[1, 3], angle_of(Phi)])
    if code == OPEN:
        return np.concatenate([Phi[:3, 3], rotation_to_er(Phi)])
    return np.zeros(0)
