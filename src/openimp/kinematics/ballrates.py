"""Angular velocities of ball joints as the rates of their joint variables (book 3.48-3.50).

A SPHERE joint (and the rotation of an OPEN, sphere_plane or sphere_groove joint: each
Phi = [[Theta(e), t], [0, 1]]) turns through Euler-Rodrigues parameters e = (e1, e2, e3,
e4), e4 = cos(angle / 2), under |e| = 1 (6.43); its joint rates are e', not an angular
velocity.  :func:`ball_rates` converts.  The angular
velocity ``w`` is the one of the joint's second body relative to its first, in the
first body's joint frame (u, v, w): Phi' Phi^-1 has the rotation part [w]x.
"""

from __future__ import annotations

from collections.abc import Mapping
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


def spin_rates(system: System, rates: Any, q: np.ndarray, what: str = "rates"
               ) -> tuple[Any, dict[str, tuple[np.ndarray, np.ndarray]]]:
    """``rates`` (a mapping of joint variables to rates, model units) with every angular
    velocity of a ball joint, key ``"joint.w"`` and value (wx, wy, wz) (:func:`ball_rates`:
    the second body's relative to the first, rad/s, in the first body's joint frame),
    replaced by the rates of three of its Euler-Rodrigues parameters at the posture ``q``
    (nq,) (model units).  The fourth, the largest in size at ``q``, is left out: it is
    the best pivot of the normalisation |e| = 1, the one the elimination makes dependent
    on an open chain, and its rate follows from e . e' = 0.  ``rates`` that is not a
    mapping, or holds no such key, is returned as it is.  A variable of the ball named
    beside its angular velocity is an InputError (``what`` names the argument).

    Returns the mapping and {joint: (its four columns, e (4,) at q)}: the parameters the
    rates were made at, for a caller that moves the posture to check against."""
    balls: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    if not isinstance(rates, Mapping):
        return rates, balls
    spins = {key: v for key, v in rates.items()
             if isinstance(key, str) and key.endswith(".w") and key not in system.var_names
             and key[:-2] in system.joints}
    if not spins:
        return rates, balls
    out = {key: v for key, v in rates.items() if key not in spins}
    named = set()
    for key in out:
        try:
            named.add(system.var_index(key))
        except (KeyError, ValueError, InputError, TypeError, IndexError):
            pass  # the caller's own reading of the mapping names a bad key
    for key, w in spins.items():
        joint = key[:-2]
        cols = ball_columns(system, joint)
        for c in cols:
            if int(c) in named:
                raise InputError(f"{what}: {system.var_names[c]} is given beside the angular "
                                 f"velocity of {joint!r}")
        ed = ball_rates(system, joint, w, q)
        e = np.asarray(q, dtype=float)[cols]
        dep = int(np.argmax(np.abs(e)))
        for k, c in enumerate(cols):
            if k != dep:
                out[system.var_names[c]] = ed[system.var_names[c]]
        balls[joint] = (cols, e.copy())
    return out, balls
