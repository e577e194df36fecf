"""The inputs every analysis reads the same way (docs/python.md, "One vocabulary").

* ``q``: a posture in model units, the nq joint variables or a mapping of
  joints (single-variable) or ``"joint.var"`` to values
  (:func:`posture_input`); ``state=``: a :class:`~openimp.system.State` in
  internal units (:func:`start_state`);
* ``specified``: names of joint variables held or driven (:func:`names_of`);
* ``rates``, ``accels``: model units, the same forms as ``q``
  (:func:`per_coordinate`); along a motion, one value or one per step for
  each named coordinate (:func:`per_step`; :func:`named`: which were named);
* scalars and arrays: :func:`positive` (tolerances, amplitudes),
  :func:`finite` (a time), :func:`floats` (numbers of any shape).

Every message names the analysis and the argument (``where``, ``what``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from openimp.errors import InputError, deprecated
from openimp.system import State, System, make_state


def posture_input(system: System, q: Any, what: str = "q") -> np.ndarray:
    """A posture given in model units, as internal joint variables (nq,): the modeling
    posture for None; a full array of the nq joint variables; or a mapping of joints
    (single-variable) or ``"joint.var"`` to values, the others at the modeling posture.
    The one reading of ``q`` in every analysis (docs/python.md, "One vocabulary"); a
    :class:`~openimp.system.State` is not a posture in model units (``state=`` takes
    it) and is an InputError here."""
    if q is None:
        return system.q0.copy()
    if isinstance(q, State):
        raise InputError(f"{what} is a posture in model units: give the State as state=, "
                         f"or its posture as system.to_model(state.q)")
    if isinstance(q, Mapping):
        qm = system.modeling_q.copy()
        for key, v in q.items():
            qm[system.var_index(key)] = finite(v, f"{what}[{key!r}]")
        return system.to_internal(qm).copy()
    try:
        arr = q.reshape(-1) if type(q) is np.ndarray and q.dtype == float else \
            np.asarray(q, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise InputError(f"{what} must be numbers, the {system.nq} joint variables, or a "
                         f"mapping of joint variables to values, got {q!r}") from None
    if arr.shape != (system.nq,) or not np.isfinite(arr).all():
        raise InputError(
            f"{what} must hold {system.nq} finite numbers, one per joint variable "
            f"({', '.join(system.var_names)}), or map joint variables to values; got "
            f"{arr.size}"
        )
    return arr / system.var_scale  # (a new array: the caller's is not kept)


def given_state(system: System, q: Any, state: Any, where: str, rates: Any = None
                ) -> State | None:
    """The State an analysis starts from, or None when it starts from ``q`` (and
    ``rates``).  A State given as ``q`` still works for one release, with a
    DeprecationWarning naming ``state=``; a State with ``q`` or ``rates`` too, or a
    ``state`` that is not a State of this system, is an InputError.  Not copied."""
    if isinstance(q, State) and state is None:
        deprecated(where, "a State given as q", "state= (q is always a posture in model units)")
        q, state = None, q
    if state is None:
        return None
    if q is not None or rates is not None:
        also = " (and rates)" if rates is not None else ""
        raise InputError(f"{where}: give q (model units){also} or state= (a State), not both")
    if not isinstance(state, State):
        raise InputError(f"{where}: state must be a State (internal units), got "
                         f"{type(state).__name__}; give a posture in model units as q")
    if state.q.shape != (system.nq,) or not np.all(np.isfinite(state.q)):
        raise InputError(f"{where}: the State holds {state.q.shape[0]} joint variables, the "
                         f"system {system.nq}")
    return state


def start_state(system: System, q: Any, state: Any, where: str, t: float = 0.0) -> State:
    """The start of an analysis from its ``q`` (model units, :func:`posture_input`; a new
    State at time ``t``, nothing specified) or ``state`` (a
    :class:`~openimp.system.State`, internal units: a copy; :func:`given_state`)."""
    given = given_state(system, q, state, where)
    if given is None:
        return make_state(system, posture_input(system, q), t)
    return given.copy()


def names_of(specified: Any, where: str) -> list[str]:
    """The ``specified`` coordinates as a list of names (one name alone allowed)."""
    if specified is None:
        return []
    if isinstance(specified, str):
        return [specified]
    try:
        names = list(specified)
    except TypeError:
        raise InputError(f"{where}: specified must be names of joints or 'joint.var', got "
                         f"{specified!r}") from None
    for n in names:
        if not isinstance(n, str | tuple):
            raise InputError(f"{where}: specified must be names of joints or 'joint.var', "
                             f"got {n!r}")
    return names


def per_coordinate(system: System, values: Any, what: str) -> np.ndarray:
    """Rates or accelerations in model units, the nq values or a mapping of joint
    variables to values (the others 0), as an (nq,) internal array."""
    out = np.zeros(system.nq)
    if values is None:
        return out
    if not isinstance(values, Mapping):
        try:
            arr = np.asarray(values, dtype=float).reshape(-1)
        except (TypeError, ValueError):
            arr = np.zeros(0)
        if arr.shape != (system.nq,) or not np.isfinite(arr).all():
            raise InputError(f"{what} must hold {system.nq} finite numbers, one per joint "
                             f"variable, or map joint variables to values, e.g. "
                             "{'crank': 10.0}")
        return arr / system.var_scale
    for key, v in values.items():
        c = system.var_index(key)
        out[c] = finite(v, f"{what}[{key!r}]") / system.var_scale[c]
    return out


def per_step(system: System, values: Any, n: int, what: str) -> np.ndarray:
    """Rates or accelerations along a motion of ``n`` steps in model units: a mapping of
    joint variables to one value or ``n`` of them (the others 0), as (n, nq) internal
    values."""
    out = np.zeros((n, system.nq))
    if values is None:
        return out
    if not isinstance(values, Mapping):
        raise InputError(f"{what} must map joint variables to numbers or arrays of {n}")
    for key, v in values.items():
        c = system.var_index(key)
        arr = floats(v, f"{what}[{key!r}]")
        if arr.ndim > 1 or (arr.ndim == 1 and arr.size != n) or not np.all(np.isfinite(arr)):
            raise InputError(f"{what}[{key!r}] must be a finite number or {n} of them")
        out[:, c] = arr / system.var_scale[c]
    return out


def named(system: System, values: Any) -> np.ndarray:
    """(nq,) bool: the joint variables a mapping of :func:`per_coordinate` or
    :func:`per_step` names, whatever their values (none for None or an array)."""
    out = np.zeros(system.nq, bool)
    if isinstance(values, Mapping):
        for key in values:
            out[system.var_index(key)] = True
    return out


def positive(x: Any, what: str) -> float:
    """``x`` as a finite number > 0 (a tolerance, an amplitude; ``what`` names it)."""
    try:
        v = float(x)
    except (TypeError, ValueError):
        raise InputError(f"{what} must be a positive number, got {x!r}") from None
    if not (math.isfinite(v) and v > 0):
        raise InputError(f"{what} must be a positive number, got {x!r}")
    return v


def finite(x: Any, what: str) -> float:
    """``x`` as one finite number (a time; ``what`` names it)."""
    try:
        v = float(x)
    except (TypeError, ValueError):
        raise InputError(f"{what} must be a number, got {x!r}") from None
    if not math.isfinite(v):
        raise InputError(f"{what} must be finite, got {x!r}")
    return v


def floats(x: Any, what: str) -> np.ndarray:
    """``x`` (a number or nested sequence) as a float array (``what`` names it)."""
    try:
        return np.asarray(x, float)
    except (TypeError, ValueError):
        raise InputError(f"{what} must be numbers, got {x!r}") from None
