"""Book-notation oracles of the dynamics (Uicker, Ravani, Sheth), plain numpy only.

Nothing here imports openimp: the oracles are fed the 4x4 postures T_0b of the bodies,
the global frames of the joints, the pseudo-inertias J_b, the loop and path matrices
L(i, h), P(b, h) and the loads, all written by the test from the geometry it gave.

* :func:`mass_matrix`: M_jk = sum_b trace(W_bj G_b W_bk^T), G_b = T_0b J_b T_0b^T (11.7);
* :func:`by_differences`: T_0b and W_bj = (dT_0b/dpsi_j) T_0b^-1 (7.21) by central
  differences of a closed-form posture function, and T''_0b along a motion (8.55);
* :func:`geometric_derivatives`, :func:`body_operators`: phi' from the loop equations
  sum_h L(i,h) D^_h phi'_h = C^' (7.14, 17.11-17.17) and W_b = sum_h P(b,h) D_h phi'_h
  (7.20), with the direct term P(b, Delta) D_Delta of a fictitious displacement (17.21
  with the digest's erratum D1);
* :func:`reaction`: one component F_Delta of a joint reaction by (17.20).

Conventions (book ch 3, 6, 17): a joint's D_h = E_h Q_h E_h^-1 with E_h its frame on
its first body h- (global); screws D^ = (D14, D24, D34, D32, D13, D21) (6.45); the
reaction component is the load of h- on h+ along or about the axes of E_h, moments
about E_h's origin.
"""

from __future__ import annotations

import numpy as np

R0 = np.array([0.0, 0.0, 0.0, 1.0])  # r_0: the homogeneous origin (9.12)


def _q(entries: dict) -> np.ndarray:
    Q = np.zeros((4, 4))
    for (i, j), v in entries.items():
        Q[i - 1, j - 1] = v
    return Q


#: the fictitious displacements Q_Delta of (17.2)-(17.7), in the order of a reaction
#: (force along u, v, w; moment about u, v, w)
Q_COMPONENTS = (
    _q({(1, 4): 1.0}),
    _q({(2, 4): 1.0}),
    _q({(3, 4): 1.0}),
    _q({(2, 3): -1.0, (3, 2): 1.0}),
    _q({(1, 3): 1.0, (3, 1): -1.0}),
    _q({(1, 2): -1.0, (2, 1): 1.0}),
)

#: the derivative operator Q of a joint's own variable (book 4.x): a revolute turns about
#: w, a prismatic slides along w
Q_JOINT = {"revolute": Q_COMPONENTS[5], "prismatic": Q_COMPONENTS[2]}


def pseudo_inertia(m: float, c, Ic) -> np.ndarray:
    """The 4x4 pseudo-inertia J = int r r^T dm (9.2, 9.3) of a body of mass m, centre c
    (3,) and centroidal inertia tensor Ic (3, 3, engineering sign), all on the axes of
    the frame J is taken in: the second moments int x x^T dm = tr(Ic)/2 I - Ic + m c c^T,
    the first moments m c, the mass."""
    c = np.asarray(c, float)
    Ic = np.asarray(Ic, float)
    J = np.zeros((4, 4))
    J[:3, :3] = 0.5 * np.trace(Ic) * np.eye(3) - Ic + m * np.outer(c, c)
    J[:3, 3] = J[3, :3] = m * c
    J[3, 3] = m
    return J


def screw(D: np.ndarray) -> np.ndarray:
    """D^ = (D14, D24, D34, D32, D13, D21) of a 4x4 operator (6.45)."""
    return np.array([D[0, 3], D[1, 3], D[2, 3], D[2, 1], D[0, 2], D[1, 0]])


def mass_matrix(T: np.ndarray, W: np.ndarray, J: np.ndarray) -> np.ndarray:
    """M_jk = sum_b trace(W_bj T_0b J_b T_0b^T W_bk^T) (11.7).

    T: (nb, 4, 4) postures; W: (nb, n, 4, 4) derivative operators; J: (nb, 4, 4)
    pseudo-inertias in the body frames.  Returns (n, n)."""
    n = W.shape[1]
    M = np.zeros((n, n))
    for b in range(T.shape[0]):
        G = T[b] @ J[b] @ T[b].T  # the body's pseudo-inertia in the global frame
        for j in range(n):
            for k in range(n):
                M[j, k] += np.trace(W[b, j] @ G @ W[b, k].T)
    return M


def by_differences(posture, psi, h: float = 1e-3):
    """T_0b (nb, 4, 4) at ``psi`` (n,) and W_bj = (dT_0b/dpsi_j) T_0b^-1 (nb, n, 4, 4)
    (7.21) by the fourth-order central difference
    (-T(+2h) + 8 T(+h) - 8 T(-h) + T(-2h)) / 12h (truncation h^4 / 30 |T^(5)|, about
    1e-13 here; round-off 1e-16 / h).  ``posture(psi) -> (nb, 4, 4)``."""
    psi = np.asarray(psi, float)
    T = posture(psi)
    W = np.zeros((T.shape[0], psi.size, 4, 4))
    for j in range(psi.size):
        e = np.zeros(psi.size)
        e[j] = h
        dT = (-posture(psi + 2 * e) + 8 * posture(psi + e) - 8 * posture(psi - e)
              + posture(psi - 2 * e)) / (12 * h)
        W[:, j] = dT @ np.linalg.inv(T)
    return T, W


def second_by_differences(posture, psi, psid, psidd, h: float = 1e-2) -> np.ndarray:
    """T''_0b (nb, 4, 4) along the motion psi(t) = psi + psid t + psidd t^2 / 2 at t = 0:
    sum_j W_bj psi''_j T + sum_jk (A_bjk + W_bj W_bk) psi'_j psi'_k T (8.55), by the
    eighth-order central second difference of T(psi(t)) (truncation h^8 |T^(10)| / 3150;
    round-off about 7e-16 / h^2: for h = 1e-2 and unit rates the result is good to about
    5e-12 relative, the spread between h = 5e-3, 1e-2 and 1.5e-2)."""
    psi, psid, psidd = (np.asarray(x, float) for x in (psi, psid, psidd))
    w = (-205 / 72, 8 / 5, -1 / 5, 8 / 315, -1 / 560)
    out = w[0] * posture(psi)
    for k in (1, 2, 3, 4):
        for s in (-1, 1):
            t = s * k * h
            out = out + w[k] * posture(psi + psid * t + psidd * t * t / 2)
    return out / (h * h)


def joint_operators(E: np.ndarray, kinds) -> np.ndarray:
    """D_h = E_h Q_h E_h^-1 (nj, 4, 4) of every joint from its frame E_h (global, on its
    first body) and its kind (6.14)."""
    return np.array([E[h] @ Q_JOINT[k] @ np.linalg.inv(E[h]) for h, k in enumerate(kinds)])


def geometric_derivatives(D: np.ndarray, L: np.ndarray, gen, rhs: np.ndarray,
                          tol: float = 1e-9):
    """Solve the loop equations sum_h L(i,h) D^_h phi'_h = C^'_i (7.14, 17.15) for the
    dependent joints' phi' with the generalized coordinates ``gen`` (joint indices)
    held (17.16).  ``rhs``: (6 nl,) the stacked C^'.  Returns phi' (nj,) and whether
    the system is compatible (17.18): a least-squares solve whose residual must vanish
    (relative ``tol``), else the component is statically indeterminate."""
    nj = D.shape[0]
    phi = np.zeros(nj)
    dep = [h for h in range(nj) if h not in set(gen)]
    if L.shape[0] == 0 or not dep:
        return phi, bool(np.all(np.abs(rhs) <= tol))
    Jdep = np.vstack([np.column_stack([L[i, h] * screw(D[h]) for h in dep])
                      for i in range(L.shape[0])])
    x = np.linalg.lstsq(Jdep, rhs, rcond=None)[0]
    phi[dep] = x
    scale = max(np.abs(rhs).max(), np.abs(Jdep).max(), 1.0)
    return phi, bool(np.abs(Jdep @ x - rhs).max() <= tol * scale)


def body_operators(D: np.ndarray, P: np.ndarray, phi: np.ndarray,
                   direct: np.ndarray | None = None) -> np.ndarray:
    """W_b = sum_h P(b,h) D_h phi'_h (7.20) for every body (nb, 4, 4); ``direct``: (nb,
    4, 4) added, P(b, Delta) D_Delta of a fictitious displacement (17.21, erratum D1)."""
    W = np.einsum("bh,hij,h->bij", P, D, phi)
    return W if direct is None else W + direct


def first_derivatives(D: np.ndarray, L: np.ndarray, P: np.ndarray, gen) -> tuple:
    """phi' (nj, n) and W (nb, n, 4, 4) of the generalized coordinates ``gen`` (7.14,
    7.20): phi'_{g,j} = delta_gj, the dependent ones from the loops."""
    nj, n = D.shape[0], len(gen)
    phi = np.zeros((nj, n))
    W = np.zeros((P.shape[0], n, 4, 4))
    for j, g in enumerate(gen):
        rhs = -np.concatenate([L[i, g] * screw(D[g]) for i in range(L.shape[0])]) \
            if L.shape[0] else np.zeros(0)
        phi[:, j], ok = geometric_derivatives(D, L, gen, rhs)
        assert ok, "the generalized coordinates must be independent"
        phi[g, j] = 1.0
        W[:, j] = body_operators(D, P, phi[:, j])
    return phi, W


def reaction(h: int, comp: int, *, E, kinds, L, P, gen, T, Tdd, J, psid, g,
             joint_loads=(), point_springs=(), point_forces=(), tol: float = 1e-9):
    """One component of the reaction of joint ``h`` (the load of h- on h+; ``comp`` 0-2
    force along u, v, w of E_h, 3-5 moment about them through E_h's origin) by (17.20),
    or NaN when it is statically indeterminate (17.18).

    E: (nj, 4, 4) joint frames on their first bodies; kinds: the joints' kinds; L: (nl,
    nj) loop matrix; P: (nb, nj) path matrix; gen: joint indices of the generalized
    coordinates; T, Tdd: (nb, 4, 4) postures and their second time derivatives (8.55);
    J: (nb, 4, 4) pseudo-inertias in the body frames; psid: (n,) generalized rates;
    g: (3,) gravity.  joint_loads: (joint, k, phi - phi0, c, f) of joint springs,
    dampers and loads; point_springs: (body b, R_b (3,), body c, R_c (3,), k, l0) with
    R the global points (b or c may be None: ground); point_forces: (body, R (3,), u (3,),
    f) along the unit u.  Bodies are row indices of T and P.
    """
    D = joint_operators(E, kinds)
    phi1 = first_derivatives(D, L, P, gen)[0]
    DD = E[h] @ Q_COMPONENTS[comp] @ np.linalg.inv(E[h])  # D_Delta (17.9)
    rhs = -np.concatenate([L[i, h] * screw(DD) for i in range(L.shape[0])]) \
        if L.shape[0] else np.zeros(0)
    phiD, ok = geometric_derivatives(D, L, gen, rhs, tol)  # (17.17), (17.18)
    if not ok:
        return np.nan
    WD = body_operators(D, P, phiD, P[:, h, None, None] * DD)  # (17.21) with D1
    phid = phi1 @ np.asarray(psid, float)  # joint rates (7.16)
    g4 = np.r_[np.asarray(g, float), 0.0]
    F = 0.0
    for b in range(T.shape[0]):
        G = T[b] @ J[b] @ T[b].T
        # the two inertia terms of (17.20): sum_j W_bj psi''_j + sum_jk (A + W W) psi' psi'
        # is T''_0b T_0b^-1 (8.55)
        F += np.trace(WD[b] @ G @ (Tdd[b] @ np.linalg.inv(T[b])).T)
        F -= g4 @ WD[b] @ G @ R0
    for j, k, dphi, c, f in joint_loads:
        F += phiD[j] * (c * phid[j] + k * dphi - f)

    def rate(b, R):  # R'_{b,Delta} = W_{b,Delta} R_b (17.22); ground: 0
        return np.zeros(3) if b is None else (WD[b] @ np.r_[R, 1.0])[:3]

    for b, Rb, c, Rc, k, l0 in point_springs:
        d = np.asarray(Rb, float) - np.asarray(Rc, float)
        ln = float(np.linalg.norm(d))
        F += (rate(b, Rb) - rate(c, Rc)) @ (d / ln) * k * (ln - l0)
    for b, R, u, f in point_forces:
        F -= rate(b, R) @ np.asarray(u, float) * f
    return F
