"""Motions of the specified generalized coordinates as functions of time.

A motion is any object with ``__call__(t) -> (position, velocity, acceleration)``
over an array of times ``t``; positions in radians or model lengths.  The
classes here cover the usual inputs of a kinematic analysis: constant rate,
polynomial, harmonic, tabulated (cubic spline) and a user callable.  They feed
``openimp.sweep(system, motion={...}, times=...)``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from openimp.errors import InputError

Triple = tuple[np.ndarray, np.ndarray, np.ndarray]


class Motion:
    """Base class: position, velocity and acceleration of one coordinate over time."""

    def __call__(self, t: np.ndarray) -> Triple:
        """Return (position, velocity, acceleration) at the times ``t``."""
        raise InputError(f"{type(self).__name__} does not define a motion")


class ConstantRate(Motion):
    """q(t) = start + rate t: a crank turning at constant speed."""

    def __init__(self, start: float, rate: float) -> None:
        self.start = float(start)
        self.rate = float(rate)

    def __call__(self, t: np.ndarray) -> Triple:
        """Position, velocity and acceleration at ``t``."""
        t = np.asarray(t, dtype=float)
        return self.start + self.rate * t, np.full_like(t, self.rate), np.zeros_like(t)


class Polynomial(Motion):
    """q(t) = c0 + c1 t + c2 t^2 + ... (coefficients in increasing power)."""

    def __init__(self, coefficients: Sequence[float]) -> None:
        c = np.asarray(coefficients, dtype=float)
        if c.ndim != 1 or c.size == 0 or not np.all(np.isfinite(c)):
            raise InputError("Polynomial motion: give a non-empty list of finite coefficients")
        self.c = np.polynomial.Polynomial(c)

    def __call__(self, t: np.ndarray) -> Triple:
        """Position, velocity and acceleration at ``t``."""
        t = np.asarray(t, dtype=float)
        d1 = self.c.deriv(1)
        d2 = self.c.deriv(2)
        return self.c(t), d1(t), d2(t)


class Harmonic(Motion):
    """q(t) = offset + amplitude sin(omega t + phase)."""

    def __init__(self, amplitude: float, omega: float, phase: float = 0.0,
                 offset: float = 0.0) -> None:
        self.a = float(amplitude)
        self.w = float(omega)
        self.ph = float(phase)
        self.off = float(offset)

    def __call__(self, t: np.ndarray) -> Triple:
        """Position, velocity and acceleration at ``t``."""
        t = np.asarray(t, dtype=float)
        arg = self.w * t + self.ph
        return (self.off + self.a * np.sin(arg), self.a * self.w * np.cos(arg),
                -self.a * self.w * self.w * np.sin(arg))


class Tabulated(Motion):
    """Cubic spline through tabulated (time, position) pairs.

    ``periodic=True`` makes the spline periodic (the last value must equal the
    first); otherwise the spline has not-a-knot ends.  Outside the table the
    spline is extrapolated, which the caller should avoid.
    """

    def __init__(self, times: Sequence[float], values: Sequence[float],
                 periodic: bool = False) -> None:
        from scipy.interpolate import CubicSpline

        t = np.asarray(times, dtype=float)
        v = np.asarray(values, dtype=float)
        if t.ndim != 1 or t.shape != v.shape or t.size < 4:
            raise InputError("Tabulated motion: give at least 4 times and as many values")
        if np.any(np.diff(t) <= 0):
            raise InputError("Tabulated motion: times must increase strictly")
        if periodic and abs(v[-1] - v[0]) > 1e-12 * max(1.0, abs(v[0])):
            raise InputError("Tabulated motion: a periodic table must end on its first value")
        self.spline = CubicSpline(t, v, bc_type="periodic" if periodic else "not-a-knot")

    def __call__(self, t: np.ndarray) -> Triple:
        """Position, velocity and acceleration at ``t``."""
        t = np.asarray(t, dtype=float)
        return self.spline(t), self.spline(t, 1), self.spline(t, 2)


class FromCallable(Motion):
    """Wrap ``fn(t) -> (position, velocity, acceleration)`` (scalars or arrays)."""

    def __init__(self, fn: Callable[[Any], Any]) -> None:
        if not callable(fn):
            raise InputError("FromCallable motion: give a function of time")
        self.fn = fn

    def __call__(self, t: np.ndarray) -> Triple:
        """Position, velocity and acceleration at ``t``."""
        t = np.asarray(t, dtype=float)
        try:
            out = self.fn(t)
            p, v, a = (np.broadcast_to(np.asarray(x, dtype=float), t.shape) for x in out)
        except (TypeError, ValueError):
            # the function may accept only scalars
            name = getattr(self.fn, "__name__", self.fn)
            try:
                rows = [tuple(map(float, self.fn(float(x)))) for x in t.ravel()]
            except Exception as exc:
                raise InputError(
                    f"motion function {name!r} must return "
                    f"(position, velocity, acceleration) for a time t: {exc}"
                ) from exc
            if any(len(r) != 3 for r in rows):
                raise InputError(
                    f"motion function {name!r} must return three values "
                    "(position, velocity, acceleration)"
                ) from None
            arr = np.array(rows).reshape(*t.shape, 3)
            p, v, a = arr[..., 0], arr[..., 1], arr[..., 2]
        if not (np.all(np.isfinite(p)) and np.all(np.isfinite(v)) and np.all(np.isfinite(a))):
            raise InputError("motion function returned non-finite values")
        return np.array(p), np.array(v), np.array(a)


def as_motion(m: Any) -> Motion:
    """A :class:`Motion` from a Motion or a callable."""
    if isinstance(m, Motion):
        return m
    if callable(m):
        return FromCallable(m)
    raise InputError(f"a motion must be a Motion object or a function of time, got {m!r}")
