"""Curve and function data of the higher pairs: stored as numbers, evaluated in kernels.

A cam's pitch-curve radius, a slot's centreline and the planar curve of a
point-on-curve or line-on-curve joint are *function blocks* in the joint's
constants: a periodic or open cubic spline of equally spaced samples, a
Fourier series, or a registered Python callable (called back from compiled
code through a numba ``objmode`` block).  :func:`fun_eval` and
:func:`curve_eval` evaluate them with three derivatives inside the kernels;
the builders below check the user's keywords and write the blocks;
:func:`curve_parameter` is the numeric inverse of (4.38) used at assembly.
:class:`ConstArgs` is the keyword checker every kind's constants use.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from openimp._jit import njit
from openimp.errors import InputError

try:  # object-mode blocks call registered Python curve functions from compiled kernels
    from numba import objmode as _objmode
except ImportError:  # pragma: no cover - only without numba (OPENIMP_NOJIT debugging)
    import contextlib

    def _objmode(**_types: str) -> contextlib.AbstractContextManager[None]:
        return contextlib.nullcontext()

# Function blocks stored in the constants array (curve data evaluated inside kernels).
# Every block starts with [kind, length of the block in slots, ...].
FUN_CALLABLE = 0  # [0, 3, id]: registered Python callable t -> (f, f', f'', f''')
FUN_PERIODIC = 1  # [1, len, n, t0, h, degree, n*(degree+1) coefficients]: periodic spline
FUN_SPLINE = 2  # same layout as FUN_PERIODIC; outside [t0, t0+n h] the end pieces extend
FUN_FOURIER = 3  # [3, len, m, t0, period, a0, a1..am, b1..bm]
CURVE_CALLABLE = 4  # [4, 3, id]: registered callable t -> (u, v, u', v', u'', v'', u''', v''')
#: offset of the curve block in the constants of point_curve / line_curve
#: ([length unit, t_start, t_end, periodic, curve ...])
CURVE_AT = 4


def _call_registered(ident: float, t: float, n: int) -> np.ndarray:
    """Evaluate the registered curve callable number ``ident`` at ``t`` (object mode)."""
    fn = _CALLABLES[int(ident)]
    res = np.asarray(fn(float(t)), dtype=np.float64).reshape(-1)
    if res.shape[0] < n:
        raise ValueError(f"curve callable {int(ident)} returned {res.shape[0]} values, needs {n}")
    return np.ascontiguousarray(res[:n])


#: registered curve callables by integer id (the id is stored in the joint constants)
_CALLABLES: dict[int, Callable[[float], Any]] = {}


@njit(nogil=False)  # its object-mode block takes the GIL anyway
def fun_eval(c: np.ndarray, k: int, t: float, out: np.ndarray, o: int, stride: int) -> None:
    """Evaluate the function block at ``c[k]`` at ``t``: value and three derivatives.

    Writes ``out[o + j*stride]`` for j = 0..3 (f, f', f'', f''') or, for a
    parametric callable, j = 0..7 (u, v, u', v', u'', v'', u''', v''').
    """
    kind = int(c[k])
    if kind == FUN_CALLABLE or kind == CURVE_CALLABLE:
        n = 4 if kind == FUN_CALLABLE else 8
        ident = c[k + 2]
        with _objmode(res="float64[:]"):
            res = _call_registered(ident, t, n)
        for j in range(n):
            out[o + j * stride] = res[j]
    elif kind == FUN_FOURIER:
        m = int(c[k + 2])
        t0 = c[k + 3]
        w = 2.0 * math.pi / c[k + 4]
        x = w * (t - t0)
        f0 = c[k + 5]
        f1 = 0.0
        f2 = 0.0
        f3 = 0.0
        for j in range(1, m + 1):
            a = c[k + 5 + j]
            b = c[k + 5 + m + j]
            cj = math.cos(j * x)
            sj = math.sin(j * x)
            kw = j * w
            f0 += a * cj + b * sj
            f1 += kw * (b * cj - a * sj)
            f2 -= kw * kw * (a * cj + b * sj)
            f3 += kw * kw * kw * (a * sj - b * cj)
        out[o] = f0
        out[o + stride] = f1
        out[o + 2 * stride] = f2
        out[o + 3 * stride] = f3
    else:  # piecewise polynomial (spline), highest power first per interval
        n = int(c[k + 2])
        t0 = c[k + 3]
        h = c[k + 4]
        d = int(c[k + 5])
        s = (t - t0) / h
        i = math.floor(s)
        if kind == FUN_PERIODIC:
            i = i % n
            x = (s - math.floor(s)) * h
        else:
            if i < 0:
                i = 0
            elif i > n - 1:
                i = n - 1
            x = t - (t0 + i * h)
        base = k + 6 + i * (d + 1)
        for r in range(4):
            acc = 0.0
            for j in range(d + 1 - r):
                # coefficient of x**(d-j) differentiated r times
                p = d - j
                fac = 1.0
                for m2 in range(r):
                    fac *= p - m2
                acc = acc * x + c[base + j] * fac
            out[o + r * stride] = acc


@njit
def curve_eval(c: np.ndarray, k: int, t: float, out: np.ndarray) -> None:
    """Parametric planar curve at ``c[k]``: out = (u, v, u', v', u'', v'', u''', v''')."""
    if int(c[k]) == CURVE_CALLABLE:
        fun_eval(c, k, t, out, 0, 1)
    else:
        fun_eval(c, k, t, out, 0, 2)
        fun_eval(c, k + int(c[k + 1]), t, out, 1, 2)



_TWO_PI = 2.0 * math.pi


def register_curve(fn: Callable[[float], Any]) -> int:
    """Register a Python curve callable; returns the integer id stored in the constants.

    The kernels call it back through a numba ``objmode`` block, so the same
    compiled kernels serve tabulated and programmed curves.  Ids are valid in
    the current process only (a compiled System holding a callable curve
    cannot be pickled to another process).
    """
    ident = len(_CALLABLES) + 1
    while ident in _CALLABLES:
        ident += 1
    _CALLABLES[ident] = fn
    return ident


class ConstArgs:
    """Keyword constants of one joint, consumed one by one with named errors."""

    def __init__(self, name: str, kind: str, kw: dict[str, Any], accepted: tuple[str, ...]):
        self.name = name
        self.kind = kind
        self.kw = dict(kw)
        self.accepted = accepted
        unknown = sorted(k for k in self.kw if k not in accepted)
        if unknown:
            raise InputError(
                f"{kind} joint {name!r}: unexpected constant(s) {', '.join(unknown)}; "
                f"this kind takes {', '.join(accepted)}"
            )

    def err(self, msg: str) -> InputError:
        return InputError(f"{self.kind} joint {self.name!r}: {msg}")

    def has(self, key: str) -> bool:
        return self.kw.get(key) is not None

    def number(self, key: str, default: float | None = None, *, nonzero: bool = False,
               positive: bool = False) -> float:
        v = self.kw.get(key)
        if v is None:
            if default is None:
                raise self.err(f"give {key}=...")
            return float(default)
        try:
            x = float(v)
        except (TypeError, ValueError):
            raise self.err(f"{key} must be a number, got {v!r}") from None
        if not math.isfinite(x):
            raise self.err(f"{key} must be a finite number, got {v!r}")
        if nonzero and x == 0.0:
            raise self.err(f"{key} must not be zero")
        if positive and x <= 0.0:
            raise self.err(f"{key} must be positive, got {x:g}")
        return x

    def array(self, key: str, value: Any = None, ndim: int = 1) -> np.ndarray:
        v = self.kw.get(key) if value is None else value
        try:
            a = np.asarray(v, dtype=float)
        except (TypeError, ValueError):
            raise self.err(f"{key} must be an array of numbers") from None
        if a.ndim != ndim:
            raise self.err(f"{key} must be a {ndim}-dimensional array of numbers, "
                           f"got shape {a.shape}")
        if not np.all(np.isfinite(a)):
            raise self.err(f"{key} holds non-finite values")
        return a


def _pp_block(kind: int, t0: float, h: float, coef: np.ndarray) -> list[float]:
    """Function block of a piecewise polynomial; ``coef`` is scipy's (degree+1, n)."""
    d = coef.shape[0] - 1
    n = coef.shape[1]
    body = [float(n), t0, h, float(d), *coef.T.reshape(-1).tolist()]
    return [float(kind), float(2 + len(body)), *body]


def _fourier_block(t0: float, period: float, a: np.ndarray, b: np.ndarray) -> list[float]:
    m = len(a) - 1
    body = [float(m), t0, period, *a.tolist(), *b.tolist()]
    return [float(FUN_FOURIER), float(2 + len(body)), *body]


def _table_fourier(y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Trigonometric interpolation (IMP's TABLE) of n equally spaced periodic samples."""
    n = len(y)
    F = np.fft.rfft(y) / n
    m = n // 2
    a = np.zeros(m + 1)
    b = np.zeros(m)
    a[0] = F[0].real
    for k in range(1, m + 1):
        scale = 1.0 if (n % 2 == 0 and k == m) else 2.0
        a[k] = scale * F[k].real
        b[k - 1] = -scale * F[k].imag
    if n % 2 == 0:
        b[m - 1] = 0.0  # the Nyquist sine vanishes at every sample
    return a, b


def _spline_block(args: ConstArgs, key: str, y: np.ndarray, t0: float, span: float,
                  periodic: bool) -> list[float]:
    """Cubic spline through equally spaced samples (periodic, or not-a-knot over a range)."""
    from scipy.interpolate import CubicSpline

    n = len(y)
    if periodic:
        if n < 3:
            raise args.err(f"{key} needs at least 3 values over one period, got {n}")
        h = span / n
        x = t0 + h * np.arange(n + 1)
        cs = CubicSpline(x, np.append(y, y[0]), bc_type="periodic")
        return _pp_block(FUN_PERIODIC, t0, h, cs.c)
    if n < 4:
        raise args.err(f"{key} needs at least 4 values over its range, got {n}")
    h = span / (n - 1)
    x = t0 + h * np.arange(n)
    cs = CubicSpline(x, y, bc_type="not-a-knot")
    return _pp_block(FUN_SPLINE, t0, h, cs.c)


def _check_callable(args: ConstArgs, key: str, fn: Any, n: int, lo: float, hi: float) -> None:
    if not callable(fn):
        raise args.err(f"{key} must be a callable t -> {n} numbers, got {fn!r}")
    for t in np.linspace(lo, hi, 5):
        try:
            r = np.asarray(fn(float(t)), dtype=float).reshape(-1)
        except Exception as exc:  # the user's function failed: say where
            raise args.err(f"{key}({t:g}) raised {type(exc).__name__}: {exc}") from None
        if r.shape[0] != n or not np.all(np.isfinite(r)):
            raise args.err(
                f"{key}({t:g}) must return {n} finite numbers "
                f"({'u, v, du, dv, d2u, d2v, d3u, d3v' if n == 8 else 'f, df, d2f, d3f'}), "
                f"got {r.tolist()}"
            )


def _domain(args: ConstArgs, default: tuple[float, float]) -> tuple[float, float]:
    if not args.has("range"):
        return default
    r = args.array("range")
    if r.shape != (2,) or not r[1] > r[0]:
        raise args.err(f"range must be two increasing numbers (start, end), got {r.tolist()}")
    return float(r[0]), float(r[1])


def scalar_function(args: ConstArgs, what: str, periodic: bool,
                     default_range: tuple[float, float]) -> tuple[list[float], tuple[float, float],
                                                                   bool]:
    """Function block of a scalar function given as table=, fourier= or function=.

    Returns (block, (t_start, t_end), periodic).
    """
    forms = [k for k in ("table", "fourier", "function") if args.has(k)]
    if len(forms) != 1:
        raise args.err(
            f"give the {what} as exactly one of table=[...] (equally spaced samples), "
            f"fourier=(a, b) (coefficients) or function=f (callable t -> (f, f', f'', f'''))"
            + (f"; got {', '.join(forms)}" if forms else "")
        )
    form = forms[0]
    t0, t1 = _domain(args, default_range)
    if form == "function":
        fn = args.kw["function"]
        _check_callable(args, "function", fn, 4, t0, t1)
        return [float(FUN_CALLABLE), 3.0, float(register_curve(fn))], (t0, t1), periodic
    if form == "fourier":
        a, b = _fourier_arrays(args, args.kw["fourier"], "fourier")
        return _fourier_block(t0, t1 - t0, a, b), (t0, t1), True
    y = args.array("table")
    if periodic and args.kw.get("closed", False):
        if len(y) < 2 or abs(y[-1] - y[0]) > 1e-9 * max(1.0, float(np.max(np.abs(y)))):
            raise args.err(
                "closed=True says the last table value repeats the first, but they differ "
                f"({y[0]:g} and {y[-1]:g}); drop closed=True or fix the table"
            )
        y = y[:-1]
    interp = str(args.kw.get("interpolation", "spline")).lower()
    if interp not in ("spline", "fourier"):
        raise args.err(f"interpolation must be 'spline' or 'fourier', got {interp!r}")
    if interp == "fourier":
        if not periodic:
            raise args.err("interpolation='fourier' needs a periodic table")
        if len(y) < 3:
            raise args.err(f"table needs at least 3 values over one period, got {len(y)}")
        a, b = _table_fourier(y)
        return _fourier_block(t0, t1 - t0, a, b), (t0, t1), True
    return _spline_block(args, "table", y, t0, t1 - t0, periodic), (t0, t1), periodic


def _fourier_arrays(args: ConstArgs, spec: Any, key: str) -> tuple[np.ndarray, np.ndarray]:
    try:
        a_raw, b_raw = spec
    except (TypeError, ValueError):
        raise args.err(f"{key} must be a pair (a, b) of coefficient lists: "
                       "f = a0 + sum_k a_k cos(k w t) + b_k sin(k w t)") from None
    a = args.array(key, a_raw)
    b = args.array(key, b_raw)
    if len(a) < 1 or len(b) != len(a) - 1:
        raise args.err(
            f"{key}: the cosine list a = [a0, a1, ..., am] must be one longer than the "
            f"sine list b = [b1, ..., bm]; got {len(a)} and {len(b)} values"
        )
    return a, b


# --- curve joints: layout [lscale, t_start, t_end, periodic, curve block ...] ---------
def curve_consts(name: str, kind: str, kw: dict[str, Any]) -> np.ndarray:
    """Constants of a point-on-curve / line-tangent-to-curve joint.

    The curve is one of
    ``curve=f`` a callable t -> (u, v, du, dv, d2u, d2v, d3u, d3v), periodic with
    ``period=P`` (default 2 pi) or open over ``range=(t0, t1)`` (the parameter interval
    searched at assembly);
    ``table=[[u, v], ...]`` samples equally spaced in t: over one period
    ``period=P`` (default 2 pi, periodic cubic spline; ``closed=True`` if the
    last row repeats the first), or over ``range=(t0, t1)`` (first and last
    sample at the ends; not-a-knot cubic spline, not periodic);
    ``fourier=((au, bu), (av, bv))`` IMP's Fourier form over ``period=P``.
    Lengths in model units.
    """
    args = ConstArgs(name, kind, kw, ("curve", "table", "fourier", "period", "range", "closed"))
    forms = [k for k in ("curve", "table", "fourier") if args.has(k)]
    if len(forms) != 1:
        raise args.err(
            "give the curve as exactly one of curve=f (callable t -> (u, v, du, dv, d2u, "
            "d2v, d3u, d3v)), table=[[u, v], ...] (equally spaced samples) or "
            "fourier=((au, bu), (av, bv))" + (f"; got {', '.join(forms)}" if forms else "")
        )
    form = forms[0]
    if args.has("period") and args.has("range"):
        raise args.err("give period= (periodic curve) or range= (open curve), not both")
    period = args.number("period", _TWO_PI, positive=True)
    if form == "curve":
        t0, t1 = _domain(args, (0.0, period))
        _check_callable(args, "curve", args.kw["curve"], 8, t0, t1)
        block = [float(CURVE_CALLABLE), 3.0, float(register_curve(args.kw["curve"]))]
        info = [t0, t1, 0.0 if args.has("range") else 1.0]
    elif form == "fourier":
        spec = args.kw["fourier"]
        try:
            su, sv = spec
        except (TypeError, ValueError):
            raise args.err("fourier must be ((au, bu), (av, bv))") from None
        au, bu = _fourier_arrays(args, su, "fourier (u)")
        av, bv = _fourier_arrays(args, sv, "fourier (v)")
        block = _fourier_block(0.0, period, au, bu) + _fourier_block(0.0, period, av, bv)
        info = [0.0, period, 1.0]
    else:
        tab = args.array("table", ndim=2)
        if tab.shape[1] != 2:
            raise args.err(f"table must have two columns (u, v), got shape {tab.shape}")
        if args.has("range"):
            t0, t1 = _domain(args, (0.0, 1.0))
            block = (_spline_block(args, "table", tab[:, 0], t0, t1 - t0, False)
                     + _spline_block(args, "table", tab[:, 1], t0, t1 - t0, False))
            info = [t0, t1, 0.0]
        else:
            if args.kw.get("closed", False):
                if len(tab) < 2 or np.max(np.abs(tab[-1] - tab[0])) > 1e-9 * max(
                        1.0, float(np.max(np.abs(tab)))):
                    raise args.err("closed=True says the last table row repeats the first, "
                                   "but they differ")
                tab = tab[:-1]
            block = (_spline_block(args, "table", tab[:, 0], 0.0, period, True)
                     + _spline_block(args, "table", tab[:, 1], 0.0, period, True))
            info = [0.0, period, 1.0]
    # [lscale, info(3), curve block]
    return np.array([1.0, *info, *block])


def curve_points(c: np.ndarray, ts: np.ndarray) -> np.ndarray:
    """(len(ts), 8) curve values and derivatives in internal units."""
    out = np.empty((len(ts), 8))
    row = np.empty(8)
    for j, t in enumerate(ts):
        curve_eval(c, CURVE_AT, float(t), row)
        out[j] = row
    return out * c[0]


def wrap_angle(a: float) -> float:
    return (a + math.pi) % _TWO_PI - math.pi


def search_grid(c: np.ndarray) -> tuple[np.ndarray, bool]:
    t0, t1, periodic = float(c[1]), float(c[2]), bool(c[3])
    n = 2048
    if periodic:
        return t0 + (t1 - t0) * np.arange(n) / n, True
    return np.linspace(t0, t1, n), False


def refine_root(fun: Callable[[float], tuple[float, float]], a: float, b: float) -> float:
    """Root of fun (value, slope) bracketed in [a, b]: Newton with bisection safeguard."""
    fa = fun(a)[0]
    t = 0.5 * (a + b)
    for _ in range(100):
        f, df = fun(t)
        if f == 0.0:
            return t
        if (f < 0.0) == (fa < 0.0):
            a, fa = t, f
        else:
            b = t
        tn = t - f / df if df != 0.0 else 0.5 * (a + b)
        if not (min(a, b) < tn < max(a, b)):
            tn = 0.5 * (a + b)
        if abs(tn - t) <= 1e-15 * max(1.0, abs(t)):
            return tn
        t = tn
    return t


def curve_parameter(c: np.ndarray, x: float, y: float) -> tuple[float, float]:
    """Closest point of a curve joint's curve to (x, y) (first joint frame, internal units).

    ``c`` are the joint's internal constants.  Returns (parameter, distance).
    This is the numeric inverse f^-1 of book (4.38) used at assembly.
    """
    ts, periodic = search_grid(c)
    pts = curve_points(c, ts)
    d2 = (pts[:, 0] - x) ** 2 + (pts[:, 1] - y) ** 2
    order = np.argsort(d2)[:8]
    best_t, best_d = float(ts[order[0]]), math.sqrt(float(d2[order[0]]))
    step = float(ts[1] - ts[0])

    def g(t: float) -> tuple[float, float]:
        r = curve_points(c, np.array([t]))[0]
        dx, dy = r[0] - x, r[1] - y
        return dx * r[2] + dy * r[3], r[2] ** 2 + r[3] ** 2 + dx * r[4] + dy * r[5]

    for j in order:
        a, b = float(ts[j]) - step, float(ts[j]) + step
        if not periodic:
            a, b = max(a, float(ts[0])), min(b, float(ts[-1]))
        ga, gb = g(a)[0], g(b)[0]
        cands = [float(ts[j])]
        if ga == 0.0:
            cands.append(a)
        elif gb == 0.0:
            cands.append(b)
        elif (ga < 0.0) != (gb < 0.0):
            cands.append(refine_root(g, a, b))
        for t in cands:
            r = curve_points(c, np.array([t]))[0]
            d = math.hypot(r[0] - x, r[1] - y)
            if d < best_d:
                best_t, best_d = t, d
    return best_t, best_d
