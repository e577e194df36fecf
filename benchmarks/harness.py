"""Timing, memory and correctness harness shared by every tool.

A tool module (``benchmarks/tools/*_tool.py``) exposes ``NAME``, ``version()``
and ``CASES``: a dict from case key to a factory ``f(ctx) -> CaseRun``.  The
factory builds the model (not timed); ``CaseRun.run()`` performs one complete
analysis (timed); ``CaseRun.outputs(result)`` turns its result into the
comparison arrays named in :data:`CASE_SPECS`.  A factory raises
:class:`NotAvailable` when the tool cannot do the case.

:func:`measure` runs in a fresh worker process per (tool, case):

1. the first ``run()`` is the cold / warm-up run (JIT compilation, caches);
2. its outputs are checked against the closed-form reference (tolerance 1e-6);
3. ``repeats`` more runs are timed; the median gives postures per second;
4. one more run under ``tracemalloc`` gives the Python-heap peak, and the
   process's peak-RSS growth during one run is read from ``/proc`` (VmHWM reset
   through ``clear_refs``), which also sees C/C++ and numba allocations.
"""

from __future__ import annotations

import gc
import os
import statistics
import time
import tracemalloc
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from benchmarks import mechanisms as mx

TOL = 1e-6


class NotAvailable(Exception):  # noqa: N818 - reads as a status, not an error
    """The tool cannot do this case (missing feature or API)."""


@dataclass
class Variant:
    """Another way of doing the case, timed alongside the main run (same postures).

    ``outputs`` (optional) checks its result against the reference like the main
    run; without it the variant is timed only (for example the kinematic sweep
    that a force analysis starts from)."""

    key: str
    label: str
    run: Callable[[], Any]
    outputs: Callable[[Any], dict[str, np.ndarray]] | None = None


@dataclass
class CaseRun:
    run: Callable[[], Any]
    outputs: Callable[[Any], dict[str, np.ndarray]]
    postures: int
    note: str = ""
    variants: list[Variant] = field(default_factory=list)


def per_variant_batch(runs: list[Callable[[], Any]],
                      outs: list[Callable[[Any], dict[str, np.ndarray]]]) -> CaseRun:
    """The batch case for a tool that solves one variant at a time from Python."""

    def run() -> list[Any]:
        return [r() for r in runs]

    def outputs(res: list[Any]) -> dict[str, np.ndarray]:
        o = [f(r) for f, r in zip(outs, res)]
        return {k: np.stack([x[k] for x in o]) for k in ("rocker", "P")}

    return CaseRun(run, outputs, postures=mx.NSTEPS * len(runs),
                   note=f"{len(runs)} of 1000 variants")


@dataclass
class Context:
    nvariants: int = 1000  # variants in the batch case (a tool may use fewer: see tools)
    nmillion: int = 1_000_000
    repeats: int = 5
    budget_s: float = 4.0  # extra repeats (beyond `repeats`) while under this budget
    extra: dict = field(default_factory=dict)


# ------------------------------------------------------------ case catalogue
def _ref_fourbar(ctx: Context) -> dict[str, np.ndarray]:
    r = mx.FOURBAR.reference(mx.FOURBAR.crank_angles())
    return {"rocker": r["rocker"], "P": r["P"]}


def _ref_fourbar_rates(ctx: Context) -> dict[str, np.ndarray]:
    th = mx.FOURBAR.crank_angles()
    r = mx.FOURBAR.reference(th)
    rr = mx.FOURBAR.reference_rates(th, mx.OMEGA, mx.ALPHA)
    return {"rocker": r["rocker"], **rr}


def _ref_slider(ctx: Context) -> dict[str, np.ndarray]:
    return mx.SLIDER.reference(mx.SLIDER.crank_angles())


def _ref_rssr(ctx: Context) -> dict[str, np.ndarray]:
    return mx.RSSR_MECH.reference(mx.RSSR_MECH.crank_angles())


def _ref_chain(ctx: Context) -> dict[str, np.ndarray]:
    return mx.CHAIN6R.reference(mx.CHAIN6R.joint_values())


def _ref_batch(ctx: Context) -> dict[str, np.ndarray]:
    refs = [fb.reference(fb.crank_angles()) for fb in mx.fourbar_variants(ctx.nvariants)]
    return {"rocker": np.stack([r["rocker"] for r in refs]), "P": np.stack([r["P"] for r in refs])}


def _ref_fourbar_forces(ctx: Context) -> dict[str, np.ndarray]:
    return mx.FOURBAR_DYN.reference(mx.FOURBAR.crank_angles(), mx.OMEGA, mx.ALPHA)


def _ref_chain_dynamics(ctx: Context) -> dict[str, np.ndarray]:
    _, q, qd, qdd = mx.CHAIN6R_DYN.motion()
    return mx.CHAIN6R_DYN.reference(q, qd, qdd)


def _ref_million(ctx: Context) -> dict[str, np.ndarray]:
    th = mx.FOURBAR.theta0 + np.radians(np.arange(ctx.nmillion) * 0.36)
    return {"P": mx.FOURBAR.reference(th)["P"]}


@dataclass
class CaseSpec:
    key: str
    title: str
    reference: Callable[[Context], dict[str, np.ndarray]]


CASE_SPECS: dict[str, CaseSpec] = {
    s.key: s
    for s in [
        CaseSpec("fourbar", "(a) four-bar crank-rocker, 360-step crank sweep, positions",
                 _ref_fourbar),
        CaseSpec("fourbar_rates", "(b) four-bar, 360 steps, positions + velocities + accelerations",
                 _ref_fourbar_rates),
        CaseSpec("slider", "(c) offset slider-crank, 360 steps", _ref_slider),
        CaseSpec("rssr", "(d) spatial RSSR, 360 steps", _ref_rssr),
        CaseSpec("chain6r", "(e) 6R serial chain forward kinematics, 360 joint sets", _ref_chain),
        CaseSpec("batch", "(f) 1000 four-bar variants x 360-step sweep", _ref_batch),
        CaseSpec("fourbar_forces", "(g) four-bar, 360 steps with rates: drive torque + joint "
                 "reactions (masses, gravity)", _ref_fourbar_forces),
        CaseSpec("chain6r_dynamics", "(h) 6R serial chain inverse dynamics, 360 postures "
                 "(q, qd, qdd; masses, gravity)", _ref_chain_dynamics),
        CaseSpec("million", "1e6 stored postures of the four-bar (all joint variables + one point)",
                 _ref_million),
    ]
}

ANGLE_KEYS = {"rocker"}
#: forces and torques: the error is relative, max |difference| / max |reference| of the key
RELATIVE_KEYS = {"tau", "R"}


def max_error(got: dict[str, np.ndarray], ref: dict[str, np.ndarray]) -> tuple[float, str]:
    """Largest difference over the keys of ``ref``: absolute (angles modulo 2 pi), or for
    :data:`RELATIVE_KEYS` relative to the largest magnitude of the reference array."""
    worst, where = 0.0, ""
    for k, r in ref.items():
        if k not in got:
            continue
        g = np.asarray(got[k], float)
        r = np.asarray(r, float)
        if g.shape != r.shape:
            n = min(g.shape[0], r.shape[0])  # a tool may do a subset of the batch
            if g.shape[1:] != r.shape[1:] or n == 0:
                return float("inf"), f"{k}: shape {g.shape} vs {r.shape}"
            g, r = g[:n], r[:n]
        d = g - r
        if k in ANGLE_KEYS:
            d = np.angle(np.exp(1j * d))
        e = float(np.max(np.abs(d))) if d.size else 0.0
        if k in RELATIVE_KEYS and d.size:
            e /= max(float(np.max(np.abs(r))), 1e-300)
        if not np.isfinite(e):
            e = float("inf")
        if e > worst or not where:
            worst, where = e, k
    return worst, where


# ------------------------------------------------------------------ memory
def _proc_status_kb(key: str) -> int:
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith(key + ":"):
                return int(line.split()[1])
    return -1


def _reset_peak_rss() -> bool:
    try:
        with open("/proc/self/clear_refs", "w") as f:
            f.write("5")
        return True
    except OSError:
        return False


def peak_rss_mb() -> float:
    return _proc_status_kb("VmHWM") / 1024.0


# ----------------------------------------------------------------- measure
def measure(factory: Callable[[Context], CaseRun], spec: CaseSpec, ctx: Context,
            save_to: str | None = None, cold_only: bool = False) -> dict[str, Any]:
    """Build, warm up, check and time one case; return a JSON-able record."""
    rec: dict[str, Any] = {"case": spec.key}
    t = time.perf_counter()
    try:
        cr = factory(ctx)
    except NotAvailable as e:
        rec.update(status="n/a", reason=str(e))
        return rec
    rec["build_s"] = time.perf_counter() - t
    rec["note"] = cr.note
    rec["postures"] = cr.postures

    t = time.perf_counter()
    out = cr.run()
    rec["cold_s"] = time.perf_counter() - t
    got = cr.outputs(out)
    del out
    if cold_only:
        rec["status"] = "ok"
        return rec
    ref = spec.reference(ctx)
    err, where = max_error(got, ref)
    rec["err_ref"] = err
    rec["err_ref_key"] = where
    if save_to:
        np.savez(save_to, **{k: np.asarray(v) for k, v in got.items()})
    del got, ref

    # variants: warm-up and check, then timed round-robin with the main run, so
    # that a change of the machine's load affects them alike
    vrecs: list[dict[str, Any]] = []
    for v in cr.variants:
        vr: dict[str, Any] = {"key": v.key, "label": v.label}
        t = time.perf_counter()
        out = v.run()
        vr["cold_s"] = time.perf_counter() - t
        if v.outputs is not None:
            verr, vwhere = max_error(v.outputs(out), spec.reference(ctx))
            vr["err_ref"] = verr
            vr["err_ref_key"] = vwhere
        del out
        vrecs.append(vr)
    runs = [cr.run] + [v.run for v in cr.variants]
    times_all: list[list[float]] = [[] for _ in runs]
    t_start = time.perf_counter()
    while len(times_all[0]) < ctx.repeats or (time.perf_counter() - t_start < ctx.budget_s
                                              and len(times_all[0]) < 25):
        for j, run in enumerate(runs):
            t = time.perf_counter()
            out = run()
            times_all[j].append(time.perf_counter() - t)
            del out
    times = times_all[0]
    rec["times"] = times
    med = statistics.median(times)
    rec["median_s"] = med
    rec["postures_per_s"] = cr.postures / med
    for vr, vt in zip(vrecs, times_all[1:]):
        vr["times"] = vt
        vr["median_s"] = statistics.median(vt)
        vr["postures_per_s"] = cr.postures / vr["median_s"]
        vr["status"] = "ok" if vr.get("err_ref", 0.0) <= TOL else "mismatch"
    if vrecs:
        rec["variants"] = vrecs

    # memory of one run: process peak-RSS growth, then Python-heap peak
    rec["process_peak_rss_mb"] = peak_rss_mb()  # build + warm-up + timed runs
    gc.collect()
    rss0 = _proc_status_kb("VmRSS") / 1024.0
    if _reset_peak_rss():
        out = cr.run()
        rec["rss_growth_mb"] = max(0.0, peak_rss_mb() - rss0)
        del out
    gc.collect()
    tracemalloc.start()
    out = cr.run()
    rec["pyheap_peak_mb"] = tracemalloc.get_traced_memory()[1] / 2**20
    tracemalloc.stop()
    del out
    rec["status"] = "ok" if err <= TOL else "mismatch"
    return rec


def env_info() -> dict[str, Any]:
    import platform

    return {"python": platform.python_version(), "machine": platform.machine(),
            "cpus": os.cpu_count(), "numpy": np.__version__}
