"""Position stage: postures along the tree, loop residuals, joint operators (book 5, 6).

Stages are compiled functions of ``(KP, DP, S, gen, ...)``: the packed model
and data (:mod:`openimp.system`), the :class:`~openimp.system.State` ``S``
and ``gen``, the joints of a general kind or None.  With ``gen`` None (every
joint a rigid, revolute, prismatic or cylindric one) the kernels are compiled
without the general joint evaluation (:func:`openimp.joints.calc.joint_calc`),
a third of a cold start.

* :func:`position`: T_0b of every body (5.4, 5.5), A_h, and the loop
  residuals with the false-solution guard (6.40, 6.48) and the
  Euler-Rodrigues rows (6.43);
* :func:`screws`: the screw of D_h^g = A_h Q_h^g A_h^-1 (6.14, 6.41) of every
  joint variable, computed once per posture for the Jacobian and the rates.
"""

from __future__ import annotations

import math

import numpy as np

from openimp._jit import njit
from openimp.joints.calc import joint_calc
from openimp.joints.codes import CYLINDER, PRISMATIC, REVOLUTE, RIGID, closed_form
from openimp.mat4 import er_norm2, gen_inv4, inv4, mm4, similar_screw
from openimp.system import data_views, model_views


@njit(nrt=False, forceinline=True)
def right_phi(
    K: tuple, d: tuple, gen: np.ndarray | None, q: np.ndarray, h: int, M: np.ndarray, im: int,
    W: np.ndarray, iw: int, inverse: bool,
) -> None:
    """W[iw] = M[im] Phi_h(q) (or M[im] Phi_h^-1 with ``inverse``) for joint h.

    K, d: the model and data views.  Rigid, revolute, prismatic and
    cylindric joints touch only the columns their Phi moves (two columns
    for a rotation about z, the last for a slide along z); the other kinds
    use d.Phi[h] from :func:`general_joints`.  ``W`` and ``M`` must be
    different arrays (scratch: d.M4[7]).  With ``gen`` None every joint has
    the closed form (the rest is not compiled).
    """
    code = K.jcode[h]
    a0 = K.jq0[h]
    if gen is None or closed_form(code):
        th = 0.0
        sl = 0.0
        if code == PRISMATIC:
            sl = q[a0]
        elif code != RIGID:
            th = q[a0]
            if code == CYLINDER:
                sl = q[a0 + 1]
        if inverse:  # Rz(th) Tz(s) inverts to Rz(-th) Tz(-s): both act along z
            th = -th
            sl = -sl
        ca = math.cos(th)
        sa = math.sin(th)
        for i in range(3):
            m0 = M[im, i, 0]
            m1 = M[im, i, 1]
            m2 = M[im, i, 2]
            W[iw, i, 0] = ca * m0 + sa * m1
            W[iw, i, 1] = ca * m1 - sa * m0
            W[iw, i, 2] = m2
            W[iw, i, 3] = M[im, i, 3] + sl * m2
        W[iw, 3, 0] = 0.0
        W[iw, 3, 1] = 0.0
        W[iw, 3, 2] = 0.0
        W[iw, 3, 3] = 1.0
    elif inverse:
        gen_inv4(d.Phi[h], d.M4[7])
        mm4(M, im, d.M4, 7, W, iw)
    else:
        mm4(M, im, d.Phi, h, W, iw)


@njit(nrt=False, inline="always")
def general_joints(KP: tuple, DP: tuple, S: tuple, gen: np.ndarray, order: int) -> None:
    """Phi_h (and with ``order`` 1 the joint-frame Q_h^g) of every joint in ``gen``.

    Into d.Phi[h] and d.Qj[a0 + g] through :func:`~openimp.joints.calc.joint_calc`,
    with the load sign of gears and racks from the state.
    """
    K = model_views(KP)
    d = data_views(DP)
    for k in range(gen.shape[0]):
        h = gen[k]
        a0 = K.jq0[h]
        nv = K.jnv[h]
        joint_calc(K.jcode[h], S.q[a0:a0 + nv], K.const[K.jc0[h]:], S.load_sign[h], d.Phi[h],
                   d.Qj[a0:a0 + nv], d.dQj, order)


@njit(nrt=False)
def position(KP: tuple, DP: tuple, S: tuple, gen: np.ndarray | None, order: int) -> float:
    """Postures, A_h and the loop residuals at the state's joint variables (5.4, 5.5, 6.40).

    T_0b of every body follows its parent joint h: A_h = T_{0h-} S_{h-,h}
    and T_0b = A_h Phi_h S_{h+,h}^-1 (or, against the joint's direction,
    A_h = T_{0h+} S_{h+,h} Phi_h^-1 and T_0b = A_h S_{h-,h}^-1).  Loop i closes
    its chord c from body b to body d: F = T_0b S_{c-,c} Phi_c S_{c+,c}^-1
    T_0d^-1 = I, and d.E holds F - I taken through the false-solution guard
    (6.48), then the Euler-Rodrigues rows 1 - |e|^2 (6.43).  Joints of a
    general kind are evaluated first, with their Q when ``order`` is 1 (for
    :func:`screws`).  Writes d.T0 (nb x 4 x 4), d.A (nj x 4 x 4), d.E (m,);
    returns max |E|.
    """
    K = model_views(KP)
    d = data_views(DP)
    q = S.q
    T0 = d.T0
    A = d.A
    E = d.E
    scr = d.M4
    if gen is not None:
        general_joints(KP, DP, S, gen, order)
    for k in range(K.order.shape[0]):
        b = K.order[k]
        h = K.pj[b]
        if h < 0:
            for r in range(4):
                for c in range(4):
                    T0[b, r, c] = K.Tref[b, r, c]
        elif K.psign[b] > 0:
            mm4(T0, K.jb1[h], K.S1, h, A, h)
            right_phi(K, d, gen, q, h, A, h, scr, 0, False)
            mm4(scr, 0, K.S2inv, h, T0, b)
        else:
            mm4(T0, K.jb2[h], K.S2, h, scr, 0)
            right_phi(K, d, gen, q, h, scr, 0, A, h, True)
            mm4(A, h, K.S1inv, h, T0, b)
    err = 0.0
    for i in range(K.chord.shape[0]):
        ch = K.chord[i]
        mm4(T0, K.jb1[ch], K.S1, ch, A, ch)
        right_phi(K, d, gen, q, ch, A, ch, scr, 0, False)
        mm4(scr, 0, K.S2inv, ch, scr, 0)
        inv4(T0[K.jb2[ch]], scr[2])
        mm4(scr, 0, scr, 2, scr, 1)
        r0 = 6 * i
        E[r0 + 0] = scr[1, 0, 3]
        E[r0 + 1] = scr[1, 1, 3]
        E[r0 + 2] = scr[1, 2, 3]
        # (6.48): the diagonal terms (cos-1, second order near a true closure)
        # push the iteration away from a false solution with 180 deg errors.
        f00 = scr[1, 0, 0] - 1.0
        f11 = scr[1, 1, 1] - 1.0
        f22 = scr[1, 2, 2] - 1.0
        E[r0 + 3] = scr[1, 2, 1] + f11 + f22
        E[r0 + 4] = scr[1, 0, 2] + f00 + f22
        E[r0 + 5] = scr[1, 1, 0] + f11 + f00
        for k in range(6):
            if abs(E[r0 + k]) > err:
                err = abs(E[r0 + k])
    r = 6 * K.chord.shape[0]
    for k in range(K.er.shape[0]):
        E[r + k] = 1.0 - er_norm2(q, K.er[k])
        if abs(E[r + k]) > err:
            err = abs(E[r + k])
    return err


@njit(nrt=False, inline="always")
def screws(KP: tuple, DP: tuple, gen: np.ndarray | None) -> None:
    """Screw coordinates (6.41) of D_h^g = A_h Q_h^g A_h^-1 (6.14) for every variable.

    Into d.Dh (nq x 6), after :func:`position` with ``order`` 1.  Revolute,
    prismatic and cylindric columns in closed form: the unit rotation about
    w = R e3 through p has [p x w, w], the unit slide [w, 0]; the general
    kinds transform their joint-frame Q (:func:`openimp.mat4.similar_screw`).
    """
    K = model_views(KP)
    d = data_views(DP)
    A = d.A
    Dh = d.Dh
    for h in range(K.jcode.shape[0]):
        code = K.jcode[h]
        if code != REVOLUTE and code != PRISMATIC and code != CYLINDER:
            continue
        a0 = K.jq0[h]
        wx = A[h, 0, 2]
        wy = A[h, 1, 2]
        wz = A[h, 2, 2]
        c = a0
        if code != PRISMATIC:
            px = A[h, 0, 3]
            py = A[h, 1, 3]
            pz = A[h, 2, 3]
            Dh[a0, 0] = py * wz - pz * wy
            Dh[a0, 1] = pz * wx - px * wz
            Dh[a0, 2] = px * wy - py * wx
            Dh[a0, 3] = wx
            Dh[a0, 4] = wy
            Dh[a0, 5] = wz
            c = a0 + 1
        if code != REVOLUTE:
            Dh[c, 0] = wx
            Dh[c, 1] = wy
            Dh[c, 2] = wz
            Dh[c, 3] = 0.0
            Dh[c, 4] = 0.0
            Dh[c, 5] = 0.0
    if gen is not None:
        for k in range(gen.shape[0]):
            h = gen[k]
            a0 = K.jq0[h]
            for g in range(K.jnv[h]):
                similar_screw(A[h], d.Qj[a0 + g], Dh, a0 + g, d.M4)
