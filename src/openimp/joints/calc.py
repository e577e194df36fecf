"""One joint evaluation: Phi, Q and dQ of any kind together (book 4.6, 6.3, 8.2).

``Q = (dPhi/dq) Phi^-1`` is the definition of a joint's derivative operator
(docs/architecture.md, Conventions); every kind is tested against central
differences of its own ``Phi``.  Lower and higher pairs share the terms of
their three results, so one call computes as many as ``order`` asks for.
"""

from __future__ import annotations

import numpy as np

from openimp._jit import njit
from openimp.joints.codes import GEAR, nvar
from openimp.joints.higher import higher_calc
from openimp.joints.lower import lower_calc


@njit
def joint_calc(code: int, q: np.ndarray, c: np.ndarray, s: float, Phi: np.ndarray,
               Q: np.ndarray, dQ: np.ndarray, order: int) -> None:
    """Phi(q), and with ``order`` >= 1 every Q_g, with ``order`` 2 every Q_{g,i}.

    code: the kind (:mod:`openimp.joints.codes`); q: the joint's variables
    (nvar,); c: its constants (internal units); s: the load sign sgn(F) of a
    gear or rack (4.28, 4.31; from the state, 0 in kinematics), unused by
    other kinds; Phi: 4x4 output; Q: (>= nvar, 4, 4) output, Q[g] =
    (dPhi/dq_g) Phi^-1; dQ: (>= nvar, >= nvar, 4, 4) output, dQ[g, i] =
    dQ_g/dq_i.  Outputs beyond ``order`` are left untouched.
    """
    nv = nvar(code)
    if order >= 1:
        for g in range(nv):
            for i in range(4):
                for j in range(4):
                    Q[g, i, j] = 0.0
    if order >= 2:
        for g in range(nv):
            for t in range(nv):
                for i in range(4):
                    for j in range(4):
                        dQ[g, t, i, j] = 0.0
    if code >= GEAR:
        higher_calc(code, q, c, s, Phi, Q, dQ, order)
    else:
        lower_calc(code, q, c, Phi, Q, dQ, order)
