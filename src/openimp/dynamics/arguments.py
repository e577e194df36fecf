"""Arguments of the Python entries of the dynamics, read and checked in one place.

Each function turns what a caller passed into the arrays an analysis works on
(internal units where it says so) or raises :class:`~openimp.errors.InputError`
naming the argument and the value: :func:`positive`, :func:`floats`,
:func:`coordinate_names` (``specified=``), :func:`per_coordinate` (``rates=``,
``accels=`` of one set point) and :func:`per_step` (the same along a motion).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from openimp.errors import InputError
from openimp.system import System


def positive(x: Any, what: str) -> float:
    """``x`` as a finite number > 0 (``what`` names it in the message)."""
    try:
        v = float(x)
    except (TypeError, ValueError):
        raise InputError(f"{what} must be a positive number, got {x!r}") from None
    if not (math.isfinite(v) and v > 0):
        raise InputError(f"{what} must be a positive number, got {x!r}")
    return v


def floats(x: Any, what: str) -> np.ndarray:
    """``x`` (a number or nested sequence) as a float array (``what`` names it)."""
    try:
        return np.asarray(x, float)
    except (TypeError, ValueError):
        raise InputError(f"{what} must be numbers, got {x!r}") from None


def coordinate_names(specified: Any) -> list[str]:
    """The specified coordinates as a list of names (a single name allowed)."""
    if specified is None:
        return []
    if isinstance(specified, str):
        return [specified]
    try:
        return list(specified)
    except TypeError:
        raise InputError(f"specified must be names of joints or 'joint.var', got "
                         f"{specified!r}") from None


def per_coordinate(system: System, values: Any, what: str) -> np.ndarray:
    """A mapping coordinate -> value (model units) as an (nq,) internal array."""
    out = np.zeros(system.nq)
    if values is None:
        return out
    if not hasattr(values, "items"):
        raise InputError(f"{what} must map coordinate names to numbers, e.g. "
                         "{'crank': 10.0}")
    for key, v in values.items():
        c = system.var_index(key)
        try:
            x = float(v)
        except (TypeError, ValueError):
            raise InputError(f"{what}[{key!r}] must be a number, got {v!r}") from None
        if not math.isfinite(x):
            raise InputError(f"{what}[{key!r}] must be finite, got {x}")
        out[c] = x / system.var_scale[c]
    return out


def per_step(system: System, values: Any, n: int, what: str) -> np.ndarray:
    """A mapping coordinate -> value or (steps,) values, model units, as (steps, nq)
    internal values."""
    out = np.zeros((n, system.nq))
    if values is None:
        return out
    if not hasattr(values, "items"):
        raise InputError(f"{what} must map coordinate names to numbers or arrays")
    for key, v in values.items():
        c = system.var_index(key)
        arr = np.asarray(v, float)
        if arr.ndim > 1 or (arr.ndim == 1 and arr.size != n) or not np.all(np.isfinite(arr)):
            raise InputError(f"{what}[{key!r}] must be a finite number or {n} of them")
        out[:, c] = arr / system.var_scale[c]
    return out


def posture(system: System, q: Any, what: str = "q") -> np.ndarray:
    """A posture in model units as its (nq,) joint variables: ``q`` None (the modeling
    posture), an array of all nq joint variables, or a mapping of joint or
    ``"joint.var"`` to values (the others at the modeling posture)."""
    nq = system.nq
    if q is None:
        return system.modeling_q.copy()
    if isinstance(q, Mapping):
        out = system.modeling_q.copy()
        for key, v in q.items():
            c = system.var_index(key)
            try:
                x = float(v)
            except (TypeError, ValueError):
                raise InputError(f"{what}[{key!r}] must be a number, got {v!r}") from None
            if not math.isfinite(x):
                raise InputError(f"{what}[{key!r}] must be finite, got {x}")
            out[c] = x
        return out
    qm = floats(q, what)
    if qm.shape != (nq,) or not np.all(np.isfinite(qm)):
        raise InputError(f"{what} must hold the {nq} joint variables as finite numbers, got "
                         f"shape {qm.shape}")
    return qm


def named(system: System, values: Any) -> np.ndarray:
    """(nq,) bool: the coordinates a mapping of :func:`per_coordinate` or :func:`per_step`
    names (whatever their values; none for None)."""
    out = np.zeros(system.nq, bool)
    if values is not None and hasattr(values, "items"):
        for key in values:
            out[system.var_index(key)] = True
    return out
