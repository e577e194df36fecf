"""Angular velocities of ball joints as the rates of their joint variables (book 3.48-3.50).

A SPHERE joint (and the rotation of an OPEN joint) turns through Euler-Rodrigues
parameters e = (e1, e2, e3, e4), e4 = cos(angle / 2), under |e| = 1 (6.43); its joint
rates are e', not an angular velocity.  :func:`ball_rates` converts.  The angular
velocity ``w`` is the one of the joint's second body relative to its first, in the
first body's joint frame (u, v, w): Phi' Phi^-1 has the rotation part [w]x.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from openimp.errors import InputError
from openimp.spatial import er_rates
from openimp.system import System


def ball_columns(system: System, joint: str) -> np.ndarray:
    """The columns (4,) of the Euler-Rodrigues parameters of ball joint ``joint``."""
    if not isinstance(joint, str) or joint not in system.joints:
        raise InputError(f"{joint!r} is not a joint of the model (joints: "
                         f"{', '.join(system.joints)})")
    sl = system.joint_vars(joint)
    cols = np.array([c for c in range(sl.start, sl.stop) if system.var_kinds[c] == "er"],
                    np.int64)
    if cols.size != 4:
        raise InputError(f"joint {joint!r} has no Euler-Rodrigues parameters (an angular "
                         "velocity is given for a SPHERE or an OPEN joint); give the rates "
                         "of its variables")
    return cols


def ball_rates(system: System, joint: str, w: Any, q: Any = None) -> dict[str, float]:
    """The rates of the four Euler-Rodrigues parameters of ball joint ``joint`` when its
    second body turns relative to its first at the angular velocity ``w`` (3,) (rad/s,
    in the first body's joint frame u v w), at the joint variables ``q`` (nq,) (model
    units; default the modeling posture): e' = (w, 0) e / 2
    (:func:`openimp.spatial.er_rates`).  Returns ``{"joint.e1": e1', ...}``; any three
    of them, with the posture, determine the fourth (e . e' = 0)."""
    cols = ball_columns(system, joint)
    try:
        wv = np.asarray(w, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise InputError(f"the angular velocity of {joint!r} must be three numbers, "
                         f"got {w!r}") from None
    if wv.shape != (3,) or not np.all(np.isfinite(wv)):
        raise InputError(f"the angular velocity of {joint!r} must be three finite numbers "
                         f"(wx, wy, wz in its first body's joint frame), got {w!r}")
    qm = system.modeling_q if q is None else np.asarray(q, dtype=float).reshape(-1)
    if qm.shape != (system.nq,):
        raise InputError(f"q must hold the {system.nq} joint variables, got shape {qm.shape}")
    e = qm[cols]
    if not abs(float(e @ e) - 1.0) < 1e-6:
        raise InputError(f"the Euler-Rodrigues parameters of {joint!r} are not normalised "
                         f"(|e|^2 = {float(e @ e):.8g}): assemble the posture first")
    ed = er_rates(e, wv)
    return {system.var_names[c]: float(ed[k]) for k, c in enumerate(cols)}
