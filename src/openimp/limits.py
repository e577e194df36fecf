"""Explicit limits on input, and the checks that enforce them.

Every limit a deck or a Python call can run into lives here, so that a
message can name it and the documentation can list it in one place
(``docs/imp.md``, "Limits").  The numbers are chosen so that nothing a deck
asks for can exhaust memory, run for ever or overflow the 4x4 arithmetic:

* numbers: every number of a statement lies within ``±MAX_NUMBER``; the
  products of two coordinates then stay finite (``1e300``), which is what
  the 4x4 transforms and their norms need;
* input rates (DATA VELOCITY, DATA ACCEL and the derivatives of DATA MOTION
  VALUEs) within ``±MAX_RATE``: accelerations grow as the square of a rate;
* steps: at most ``MAX_STEPS`` output steps per EXECUTE (DATA TIME, DATA
  POSITION) or per Python call (sweeps, equilibrium paths, frequencies, mode
  animations), at most ``MAX_RUN_STEPS`` integration steps per time response
  (the default cap; ZERO (FORCE)'s third number and ``max_steps`` lower it),
  and at most ``MAX_RESULT_BYTES`` of results held per run;
* files: a deck, a recalled file or a TABLE file holds at most
  ``MAX_FILE_BYTES``; a deck and everything it recalls at most
  ``MAX_READ_BYTES`` and ``MAX_STATEMENTS`` statements; RECALL INPUT nests at
  most ``MAX_RECALL_DEPTH`` deep and a file never recalls itself;
* TABLE files hold at most ``MAX_TABLE_ORDINATES`` ordinates;
* VALUE expressions: parentheses nest at most ``MAX_NESTING`` deep, a tree
  is at most ``MAX_EXPRESSION_DEPTH`` deep, VALUEs use VALUEs at most
  ``MAX_VALUE_CHAIN`` deep, and one evaluation descends at most
  ``MAX_EVAL_DEPTH`` levels in all;
* solver options (ZERO statements, :func:`openimp.kinematics.sweep`): a
  tolerance in ``[MIN_TOLERANCE, MAX_TOLERANCE]``, at most
  ``MAX_ITERATIONS`` Newton iterations and ``MAX_HALVINGS`` step halvings.

:func:`check_solver_options` is the one validation of the solver options;
the kinematic core calls it for every sweep.
"""

from __future__ import annotations

import math
import numbers
from typing import Any

import numpy as np

from openimp.errors import InputError

__all__ = [
    "MAX_ERRORS_SHOWN",
    "MAX_EVAL_DEPTH",
    "MAX_EXPRESSION_DEPTH",
    "MAX_FILE_BYTES",
    "MAX_GEAR_RATIO",
    "MAX_HALVINGS",
    "MAX_INPUT_ERRORS",
    "MAX_ITERATIONS",
    "MAX_NESTING",
    "MAX_NUMBER",
    "MAX_RATE",
    "MAX_READ_BYTES",
    "MAX_RECALL_DEPTH",
    "MAX_RESULT_BYTES",
    "MAX_RUN_STEPS",
    "MAX_STATEMENTS",
    "MAX_STEPS",
    "MAX_TABLE_ORDINATES",
    "MAX_TOLERANCE",
    "MAX_VALUE_CHAIN",
    "MIN_TOLERANCE",
    "check_solver_options",
    "number_text",
]

#: Largest magnitude of a number in a statement (coordinates, data, times).
MAX_NUMBER = 1e150
#: Largest magnitude of an input velocity or acceleration (rad/s, length/s, ...).
MAX_RATE = 1e60
#: Most output steps of one EXECUTE (DATA TIME final / print step, DATA POSITION steps).
MAX_STEPS = 100_000
#: Most integration steps of one time response (the default cap of a run).
MAX_RUN_STEPS = 10_000_000
#: Most bytes of results (postures, rates, point motions) one run may hold.
MAX_RESULT_BYTES = 1 << 30
#: Largest deck, recalled file or TABLE file.
MAX_FILE_BYTES = 8 << 20
#: Most bytes a deck and every file it recalls may read in all.
MAX_READ_BYTES = 64 << 20
#: Most statements of a deck, recalled files included.
MAX_STATEMENTS = 100_000
#: Deepest nesting of RECALL INPUT files.
MAX_RECALL_DEPTH = 16
#: Most ordinates of a TABLE file.
MAX_TABLE_ORDINATES = 10_000
#: Parentheses and function calls nested inside one another in a VALUE expression.
MAX_NESTING = 40
#: Depth of one expression tree (chains of operators included).
MAX_EXPRESSION_DEPTH = 200
#: VALUEs that use VALUEs that use VALUEs ...
MAX_VALUE_CHAIN = 50
#: Levels one evaluation descends through trees and VALUEs together.
MAX_EVAL_DEPTH = 220
#: Smallest and largest solver tolerance (ZERO statements, sweep tol and pivot_tol).
MIN_TOLERANCE = 1e-14
MAX_TOLERANCE = 1.0
#: Most Newton iterations per posture (ZERO (POSITION) count, sweep maxit).
MAX_ITERATIONS = 1000
#: Most halvings of a step the solver may try (sweep maxhalve).
MAX_HALVINGS = 30
#: Most input errors gathered from one deck before reading stops.
MAX_INPUT_ERRORS = 1000
#: Largest gear ratio (and smallest, as its inverse) of GEAR and BEVEL joints.
MAX_GEAR_RATIO = 1e6
#: Most input errors the command prints (the count of the others is told).
MAX_ERRORS_SHOWN = 50


def number_text(x: float) -> str:
    """A number as a message shows it: ``1E+300``, ``0.001``, ``nan``."""
    if not math.isfinite(x):
        return str(x)
    return f"{x:.6G}"


def _is_number(x: Any) -> bool:
    """True for a real number (Python or numpy), not a bool."""
    return isinstance(x, numbers.Real) and not isinstance(x, bool | np.bool_)


def check_tolerance(value: Any, what: str) -> float:
    """``value`` as a float in ``[MIN_TOLERANCE, MAX_TOLERANCE]``, or InputError naming ``what``."""
    if not _is_number(value) or not math.isfinite(float(value)):
        raise InputError(f"{what} must be a finite number, got {value!r}")
    v = float(value)
    if v <= 0.0:
        raise InputError(f"{what} must be positive, got {number_text(v)}")
    if v < MIN_TOLERANCE:
        raise InputError(f"{what} {number_text(v)} is below {number_text(MIN_TOLERANCE)} "
                         "(limit MIN_TOLERANCE): double precision cannot resolve it; give a "
                         f"value between {number_text(MIN_TOLERANCE)} and "
                         f"{number_text(MAX_TOLERANCE)}")
    if v > MAX_TOLERANCE:
        raise InputError(f"{what} {number_text(v)} is above {number_text(MAX_TOLERANCE)} "
                         "(limit MAX_TOLERANCE): every posture would pass; give a value "
                         f"between {number_text(MIN_TOLERANCE)} and "
                         f"{number_text(MAX_TOLERANCE)}")
    return v


def check_count(value: Any, what: str, low: int, high: int, limit: str) -> int:
    """``value`` as an int in ``[low, high]``, or InputError naming ``what`` and ``limit``."""
    if not _is_number(value) or not math.isfinite(float(value)) or float(value) != int(value):
        raise InputError(f"{what} must be a whole number, got {value!r}")
    n = int(value)
    if n < low:
        raise InputError(f"{what} must be at least {low}, got {n}")
    if n > high:
        raise InputError(f"{what} {n} is above {high} (limit {limit})")
    return n


def check_solver_options(tol: Any, pivot_tol: Any, maxit: Any, maxhalve: Any) -> None:
    """Validate the options of a posture sweep; raise InputError naming the bad one.

    ``tol`` (Newton tolerance, internal units) and ``pivot_tol`` (pivot
    tolerance of the elimination) lie in ``[MIN_TOLERANCE, MAX_TOLERANCE]``;
    ``maxit`` (Newton iterations per posture) in ``[1, MAX_ITERATIONS]``;
    ``maxhalve`` (step halvings) in ``[0, MAX_HALVINGS]``.  NaN, infinities,
    zero and negative tolerances are refused, so that a bad option is never
    blamed on the mechanism and no sweep runs for ever.
    """
    if (tol, pivot_tol, maxit, maxhalve) == (1e-10, 1e-10, 25, 12) and type(maxit) is int \
            and type(maxhalve) is int and type(tol) is float and type(pivot_tol) is float:
        return  # the defaults: known good (a sweep of a study is called many times)
    check_tolerance(tol, "tol")
    check_tolerance(pivot_tol, "pivot_tol")
    check_count(maxit, "maxit", 1, MAX_ITERATIONS, "MAX_ITERATIONS")
    check_count(maxhalve, "maxhalve", 0, MAX_HALVINGS, "MAX_HALVINGS")
