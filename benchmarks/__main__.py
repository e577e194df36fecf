"""Run every benchmark case for every tool and write the Markdown report.

    python -m benchmarks                 # everything (about 5 minutes on 2 cores)
    python -m benchmarks --cases fourbar,slider --tools openimp,mujoco
    python -m benchmarks --quick         # fewer variants and repeats, for a smoke test

Each (tool, case) runs in its own worker process (``benchmarks.worker``) so that
imports, JIT caches and memory peaks of one tool do not affect another.  The
report goes to stdout and to ``benchmarks/results.md`` (raw numbers to
``benchmarks/results.json``); a --quick or partial run writes results-partial.md/.json.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from benchmarks.harness import CASE_SPECS, TOL, max_error
from benchmarks.tools import TOOLS

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
CASE_ORDER = ["fourbar", "fourbar_rates", "slider", "rssr", "chain6r", "batch",
              "fourbar_forces", "chain6r_dynamics"]
TOOL_ORDER = ["openimp", "pylinkage-py", "pylinkage-numba", "exudyn", "mujoco", "pinocchio"]
MILLION_TOOLS = ["openimp", "pylinkage-numba"]


def src_hash() -> str:
    """Hash of openimp's sources (numba's cache is keyed on them: a change means recompiling)."""
    import hashlib
    import importlib.util

    spec = importlib.util.find_spec("openimp")
    if spec is None or spec.origin is None:
        return ""
    h = hashlib.sha1()
    for f in sorted(Path(spec.origin).parent.rglob("*.py")):
        h.update(str(f).encode())
        h.update(f.read_bytes())
    return h.hexdigest()[:12]


def run_worker(tool: str, case: str, args: list[str], env_extra: dict | None = None,
               timeout: float = 600) -> dict:
    env = dict(os.environ)
    env.update(TOOLS[tool].env)
    env.update(env_extra or {})
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
    cmd = [sys.executable, "-m", "benchmarks.worker", tool, case, *args]
    try:
        p = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True,
                           timeout=timeout)
    except subprocess.TimeoutExpired:
        return {"tool": tool, "case": case, "status": "error", "reason": f"timeout {timeout}s"}
    lines = [ln for ln in p.stdout.splitlines() if ln.startswith("{")]
    if not lines:
        return {"tool": tool, "case": case, "status": "error",
                "reason": f"worker exit {p.returncode}: {p.stderr.strip()[-400:]}"}
    return json.loads(lines[-1])


def cross_check(results: dict, outdir: Path) -> None:
    """Compare each peer's outputs with openimp's (tolerance TOL)."""
    for (tool, case), rec in results.items():
        if tool == "openimp" or rec.get("status") not in ("ok", "mismatch"):
            continue
        ref_file = outdir / f"openimp-{case}.npz"
        mine = outdir / f"{tool}-{case}.npz"
        if not ref_file.exists() or not mine.exists():
            rec["err_openimp"] = None
            continue
        with np.load(ref_file) as r, np.load(mine) as g:
            err, _ = max_error({k: g[k] for k in g.files}, {k: r[k] for k in r.files})
        rec["err_openimp"] = err
        if err > TOL:
            rec["status"] = "mismatch"


# ------------------------------------------------------------ openimp extras
def cold_compile(outdir: Path) -> dict:
    """openimp four-bar in a fresh process with an empty numba cache (full JIT compile)."""
    cache = outdir / "numba-cache-empty"
    cache.mkdir(exist_ok=True)
    t = time.perf_counter()
    rec = run_worker("openimp", "fourbar", ["--cold-only"], {"NUMBA_CACHE_DIR": str(cache)})
    rec["process_s"] = time.perf_counter() - t
    return rec


def cli_deck(path: Path) -> None:
    """The benchmark four-bar as an IMP deck (360 positions of the crank)."""
    from benchmarks.mechanisms import FOURBAR

    fb = FOURBAR
    B, C = fb.B0, fb.C0
    path.write_text(f"""TITLE: openimp benchmark four-bar
GROUND = BASE
ZPIN (BASE, CRANK) = A
ZPIN (CRANK, COUPLER) = B
ZPIN (COUPLER, ROCKER) = C
ZPIN (ROCKER, BASE) = D
DATA ZPIN (A) = 0, 0, 0
DATA ZPIN (B) = {B[0]:.12f}, {B[1]:.12f}, 0
DATA ZPIN (C) = {C[0]:.12f}, {C[1]:.12f}, 0
DATA ZPIN (D) = {fb.d:.12f}, 0, 0
DATA POSITION (A) = 0, 1, 359
LIST POSITION (D)
EXECUTE
END
""")


def bench_cli_startup(outdir: Path, warm_runs: int = 5) -> dict:
    """`openimp run DECK` start-up: cold (empty numba cache) and warm (median of runs).

    Skipped while the `openimp` command is missing or does not run a deck.
    """
    exe = shutil.which("openimp")
    if exe is None:
        return {"status": "skipped", "reason": "no `openimp` command on PATH"}
    probe = subprocess.run([exe, "run", "--help"], capture_output=True, text=True)
    if probe.returncode != 0:
        msg = (probe.stderr or probe.stdout).strip().splitlines()
        why = msg[-1] if msg else f"exit {probe.returncode}"
        return {"status": "skipped", "reason": "`openimp run --help` fails: " + why}
    deck = outdir / "fourbar.imp"
    cli_deck(deck)
    env = dict(os.environ, NUMBA_CACHE_DIR=str(outdir / "numba-cache-cli"))

    def once() -> tuple[float, int]:
        t = time.perf_counter()
        p = subprocess.run([exe, "run", str(deck)], capture_output=True, text=True, env=env,
                           cwd=outdir)
        return time.perf_counter() - t, p.returncode

    cold, rc = once()
    if rc != 0:
        return {"status": "skipped", "reason": f"`openimp run` exit {rc} on the benchmark deck",
                "cold_s": cold}
    warm: list[float] = []
    while len(warm) < warm_runs and sum(warm) < 60:
        warm.append(once()[0])
    t = time.perf_counter()
    subprocess.run([sys.executable, "-c", "import openimp"], env=env)
    imp = time.perf_counter() - t
    return {"status": "ok", "cold_s": cold, "warm_s": statistics.median(warm),
            "warm_runs": warm, "python_import_s": imp}


# ------------------------------------------------------------------ report
def _fmt_rate(x: float | None) -> str:
    if x is None:
        return "-"
    if x >= 1e6:
        return f"{x / 1e6:.2f} M"
    if x >= 1e3:
        return f"{x / 1e3:.1f} k"
    return f"{x:.0f}"


def _fmt_err(x) -> str:
    if x is None:
        return "-"
    return f"{x:.1e}"


def _fmt_mb(x) -> str:
    return "-" if x is None else f"{x:.2f}"


def report(results: dict, extras: dict, meta: dict) -> str:
    L: list[str] = []
    L.append("# openimp speed benchmarks\n")
    L.append(f"Run {meta['date']} on {meta['machine']} ({meta['cpus']} CPUs), "
             f"Python {meta['python']}, numpy {meta['numpy']}; total {meta['total_s']:.0f} s.\n")
    if meta.get("openimp_from"):
        L.append(f"openimp imported from `{meta['openimp_from']}`, not from this repository's "
                 f"src/ (source hash {meta.get('openimp_hash', '?')}).\n")
    tree = "repository" if meta.get("openimp_from") else "openimp tree"
    L.append(f"{tree}: {meta['git']}. Load average (1 min) at start / end: "
             f"{meta['load'][0]:.1f} / {meta['load'][1]:.1f} (the machine is shared: "
             "other processes inflate wall times).\n")
    if meta.get("src_changed"):
        L.append("**openimp's sources changed while this ran** (other work on the tree): numba "
                 "recompiled, so cold / first-run figures marked * include that compile; the "
                 "medians are not affected (each worker compiles once, before timing).\n")
    L.append("Versions: " + ", ".join(f"{k} {v}" for k, v in meta["versions"].items()) + ".\n")
    L.append(
        "postures/s = postures of one run / median wall time of >= 5 runs after a warm-up run "
        "(JIT compilation excluded). **openimp/peer** = openimp's postures/s divided by the "
        "peer's (> 1: openimp faster). Memory: *RSS growth* = growth of the process's peak RSS "
        "during one run (sees C/C++ and numba allocations; 0 when the run fits in memory the "
        "process already held), *py-heap* = tracemalloc peak of one run (Python and numpy "
        "allocations only). *err ref* = max |difference| from the closed-form reference, "
        f"*err openimp* = from openimp's output (angles mod 2 pi); timings count only when both "
        f"are <= {TOL:g}.\n")
    for case in CASE_ORDER:
        spec = CASE_SPECS[case]
        rows = [(t, results.get((t, case))) for t in TOOL_ORDER if (t, case) in results]
        if not rows:
            continue
        L.append(f"\n## {spec.title}\n")
        L.append("| tool | postures/s | median run (ms) | runs | openimp/peer | RSS growth (MB) | "
                 "py-heap (MB) | err ref | err openimp | note |")
        L.append("|---|---:|---:|---:|---:|---:|---:|---:|---:|---|")
        oi = results.get(("openimp", case), {})
        oi_rate = oi.get("postures_per_s") if oi.get("status") == "ok" else None
        for tool, r in rows:
            label = TOOLS[tool].label
            st = r.get("status")
            if st in ("n/a", "missing", "error"):
                why = {"n/a": "not available", "missing": "not installed", "error": "error"}[st]
                reason = r.get("reason", "")[:160]
                L.append(f"| {label} | {why} | | | | | | | | {reason} |")
                continue
            rate = r.get("postures_per_s")
            ok = st == "ok"
            ratio = "-"
            if tool != "openimp" and oi_rate and rate and ok:
                ratio = f"{oi_rate / rate:.2f}"
            note = r.get("note", "") or ""
            if not ok:
                note = ("OUTPUT MISMATCH, timing not counted; " + note).strip("; ")
            L.append(
                f"| {label} | {_fmt_rate(rate) if ok else '(' + _fmt_rate(rate) + ')'} | "
                f"{1e3 * r['median_s']:.3f} | {len(r.get('times', []))} | {ratio} | "
                f"{_fmt_mb(r.get('rss_growth_mb'))} | {_fmt_mb(r.get('pyheap_peak_mb'))} | "
                f"{_fmt_err(r.get('err_ref'))} | "
                f"{'-' if tool == 'openimp' else _fmt_err(r.get('err_openimp'))} | {note} |")
            for v in r.get("variants", []) if ok else []:
                vrate = v.get("postures_per_s")
                vok = v.get("status") == "ok"
                vnote = f"{vrate / rate:.2f} x the run above" if rate and vrate else ""
                if not vok:
                    vnote = "OUTPUT MISMATCH; " + vnote
                L.append(
                    f"| {label}: {v['label']} | "
                    f"{_fmt_rate(vrate) if vok else '(' + _fmt_rate(vrate) + ')'} | "
                    f"{1e3 * v['median_s']:.3f} | {len(v.get('times', []))} | - | | | "
                    f"{_fmt_err(v.get('err_ref'))} | - | {vnote} |")

    targets = _targets(results)
    if targets:
        L.append("\n## Targets (issue 13)\n")
        L.append("Timed in the same worker process, round-robin with the main run (see the "
                 "case tables for every figure).\n")
        L.append("| target | openimp (postures/s) | against (postures/s) | ratio | needed | met |")
        L.append("|---|---:|---:|---:|---:|---|")
        L.extend(targets)

    # openimp cold start
    L.append("\n## openimp cold start (fresh process)\n")
    L.append("| case | import (s) | build + compile model (s) | first run (s) | warm run (ms) |")
    L.append("|---|---:|---:|---:|---:|")
    cc = extras.get("cold_compile")
    if cc and cc.get("status") == "ok":
        star = " *" if cc.get("src_changed") else ""
        L.append(f"| (a) four-bar, **empty numba cache** (full JIT compile){star} | "
                 f"{cc.get('import_s', 0):.2f} | {cc.get('build_s', 0):.2f} | "
                 f"{cc.get('cold_s', 0):.2f} | - |")
    elif cc:
        L.append(f"| (a) four-bar, empty numba cache | error: {cc.get('reason', '')[:120]} | | | |")
    for case in CASE_ORDER:
        r = results.get(("openimp", case))
        if r and r.get("status") in ("ok", "mismatch"):
            star = " *" if r.get("src_changed") else ""
            L.append(f"| {CASE_SPECS[case].title.split(',')[0]} (numba cache present){star} | "
                     f"{r.get('import_s', 0):.2f} | {r.get('build_s', 0):.2f} | "
                     f"{r.get('cold_s', 0):.3f} | {1e3 * r['median_s']:.3f} |")

    # one million postures
    mil = [(t, results.get((t, "million"))) for t in MILLION_TOOLS if (t, "million") in results]
    if mil:
        L.append(f"\n## {CASE_SPECS['million'].title}\n")
        L.append("Lower bound for the stored data: 1e6 x (4 joint variables + 3 coordinates) x "
                 "8 B = 56 MB.\n")
        L.append("| tool | run (s, one run) | RSS growth (MB) | py-heap peak (MB) | "
                 "process peak RSS (MB) | err ref | note |")
        L.append("|---|---:|---:|---:|---:|---:|---|")
        for tool, r in mil:
            if r.get("status") not in ("ok", "mismatch"):
                L.append(f"| {TOOLS[tool].label} | {r.get('status')} | | | | | "
                         f"{r.get('reason', '')[:160]} |")
                continue
            L.append(f"| {TOOLS[tool].label} | {r['median_s']:.2f} | "
                     f"{_fmt_mb(r.get('rss_growth_mb'))} | {_fmt_mb(r.get('pyheap_peak_mb'))} | "
                     f"{_fmt_mb(r.get('process_peak_rss_mb'))} | {_fmt_err(r.get('err_ref'))} | "
                     f"{r.get('note', '')} |")

    cli = extras.get("cli")
    L.append("\n## `openimp run` start-up\n")
    if cli is None:
        L.append("not run (--no-cli).")
    elif cli.get("status") == "ok":
        star = " (* sources changed during the measurement)" if cli.get("src_changed") else ""
        L.append(f"`openimp run` on a generated 360-position four-bar deck: cold (empty numba "
                 f"cache) {cli['cold_s']:.2f} s, warm {cli['warm_s']:.2f} s (median of "
                 f"{len(cli['warm_runs'])}), bare `python -c 'import openimp'` "
                 f"{cli['python_import_s']:.2f} s{star}.")
    else:
        L.append(f"skipped: {cli.get('reason')}.")
    return "\n".join(L) + "\n"


def _variant(rec: dict | None, key: str) -> dict | None:
    for v in (rec or {}).get("variants", []):
        if v.get("key") == key and v.get("status") == "ok":
            return v
    return None


def _ok_rate(rec: dict | None) -> float | None:
    return rec.get("postures_per_s") if rec and rec.get("status") == "ok" else None


def _targets(results: dict) -> list[str]:
    """Rows of the issue-13 targets: four-bar forces vs the kinematic sweep, openimp's 6R
    inverse dynamics vs Pinocchio's rnea from Python."""
    rows = []

    def row(what, a, b_label, b, needed, ok):
        if a is None or b is None:
            return
        met = "**yes**" if ok(a / b) else "**no**"
        rows.append(f"| {what} | {_fmt_rate(a)} | {b_label} {_fmt_rate(b)} | {a / b:.2f} | "
                    f"{needed} | {met if needed != '-' else '-'} |")

    fo = results.get(("openimp", "fourbar_forces"))
    kin = _variant(fo, "kinematic")
    row("four-bar: sweep with rates + forces() (drive torque, all joint reactions) at no "
        "less than half the speed of the kinematic sweep with rates",
        _ok_rate(fo), "kinematic sweep", kin and kin["postures_per_s"], ">= 0.5",
        lambda x: x >= 0.5)
    ch = results.get(("openimp", "chain6r_dynamics"))
    pin = _ok_rate(results.get(("pinocchio", "chain6r_dynamics")))
    row("6R inverse dynamics: sweep with rates + forces(reactions=False), faster per "
        "posture than Pinocchio's rnea called from Python", _ok_rate(ch), "Pinocchio rnea",
        pin, "> 1", lambda x: x > 1.0)
    rv = _variant(ch, "reactions")
    row("(information) 6R with reactions=True", rv and rv["postures_per_s"],
        "Pinocchio rnea", pin, "-", lambda x: True)
    mj = _ok_rate(results.get(("mujoco", "chain6r_dynamics")))
    row("(information) 6R inverse dynamics against MuJoCo's mj_inverse from Python",
        _ok_rate(ch), "MuJoCo mj_inverse", mj, "-", lambda x: True)
    return rows


def _openimp_origin() -> str:
    """Where the workers import openimp from, when it is not this repository's src/."""
    import importlib.util

    spec = importlib.util.find_spec("openimp")
    if spec is None or spec.origin is None:
        return ""
    where = Path(spec.origin).resolve().parent.parent
    return "" if where == (ROOT / "src").resolve() else str(where)


def _git_state() -> str:
    try:
        head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT,
                              capture_output=True, text=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--", "src"], cwd=ROOT,
                               capture_output=True, text=True).stdout.strip()
        return head + (" + uncommitted changes in src/" if dirty else "")
    except OSError:
        return "unknown"


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--cases", default=",".join([*CASE_ORDER, "million"]))
    p.add_argument("--tools", default=",".join(TOOL_ORDER))
    p.add_argument("--repeats", type=int, default=5, help="timed runs at least (default 5)")
    p.add_argument("--budget", type=float, default=3.0,
                   help="extra timed runs while a case has used less than this many seconds")
    p.add_argument("--quick", action="store_true", help="smoke test: few variants, 1e5 postures")
    p.add_argument("--no-cold", action="store_true", help="skip the empty-cache JIT compile run")
    p.add_argument("--no-cli", action="store_true", help="skip `openimp run` start-up")
    p.add_argument("--no-vibration", action="store_true",
                   help="skip the linearization/modes benchmark (benchmarks.vibration)")
    p.add_argument("--no-statics", action="store_true",
                   help="skip the static equilibrium benchmark (benchmarks.statics)")
    p.add_argument("--no-dynamics", action="store_true",
                   help="skip the time response benchmark (benchmarks.dynamics)")
    p.add_argument("--out", default=None,
                   help="report file (default benchmarks/results.md for a full run, "
                        "benchmarks/results-partial.md for --quick or a subset)")
    a = p.parse_args(argv)

    cases = [c for c in a.cases.split(",") if c]
    tools = [t for t in a.tools.split(",") if t]
    for c in cases:
        if c not in CASE_SPECS:
            p.error(f"unknown case {c!r}; choose from {', '.join(CASE_SPECS)}")
    for t in tools:
        if t not in TOOLS:
            p.error(f"unknown tool {t!r}; choose from {', '.join(TOOLS)}")

    t0 = time.perf_counter()
    load0 = os.getloadavg()
    hash0 = src_hash()
    results: dict = {}
    extras: dict = {}
    with tempfile.TemporaryDirectory(prefix="openimp-bench-") as td:
        outdir = Path(td)
        if "openimp" in tools:
            # fill openimp's kernel cache first (a no-op when it is warm), so that the
            # cases' first runs are the "numba cache present" figures the report says
            print("  warming openimp's kernel cache", file=sys.stderr, flush=True)
            for case in ("fourbar_rates", "batch", "fourbar_forces", "chain6r_dynamics"):
                if case == "fourbar_rates" or case in cases:
                    run_worker("openimp", case, ["--cold-only"])
        for case in cases:
            these = MILLION_TOOLS if case == "million" else tools
            for tool in [t for t in TOOL_ORDER if t in these and t in tools]:
                args = ["--save", str(outdir / f"{tool}-{case}.npz"),
                        "--repeats", str(a.repeats), "--budget", str(a.budget)]
                if case == "million":
                    args = ["--repeats", "1", "--budget", "0"]
                    if a.quick:
                        args += ["--nmillion", "100000"]
                if a.quick and case == "batch":
                    args += ["--nvariants", "20"]
                t = time.perf_counter()
                h0 = src_hash() if tool == "openimp" else ""
                rec = run_worker(tool, case, args)
                if tool == "openimp" and src_hash() != h0:
                    rec["src_changed"] = True
                print(f"  {case:14s} {tool:16s} {rec.get('status', '?'):8s} "
                      f"{time.perf_counter() - t:6.1f} s  "
                      f"{_fmt_rate(rec.get('postures_per_s'))} postures/s  "
                      f"{rec.get('reason', '')[:100]}", file=sys.stderr, flush=True)
                results[(tool, case)] = rec
        cross_check(results, outdir)
        if "openimp" in tools and not a.no_cold:
            h0 = src_hash()
            extras["cold_compile"] = cold_compile(outdir)
            extras["cold_compile"]["src_changed"] = src_hash() != h0
        if not a.no_cli:
            h0 = src_hash()
            extras["cli"] = bench_cli_startup(outdir)
            extras["cli"]["src_changed"] = src_hash() != h0
        if "openimp" in tools and not a.no_vibration:
            from benchmarks import vibration

            vib_repeats = 1 if a.quick else 3
            vib = vibration.run_workers(vib_repeats)
            vib_text = vibration.section(vib, vib_repeats)
            extras["vibration"] = vibration.summary(vib)
        if "openimp" in tools and not a.no_statics:
            from benchmarks import statics

            st_repeats = 5 if a.quick else 30
            st = statics.run_workers(st_repeats)
            st_text = statics.section(st, st_repeats)
            extras["statics"] = statics.summary(st)
        if "openimp" in tools and not a.no_dynamics:
            from benchmarks import dynamics

            dy_repeats = 1 if a.quick else 3
            dy = dynamics.run_workers(dy_repeats)
            dy_text = dynamics.section(dy, dy_repeats)
            extras["dynamics"] = dynamics.summary(dy)

    from importlib import metadata

    versions = {"numba": metadata.version("numba")}
    for (tool, _), r in results.items():
        if r.get("version"):
            versions[TOOLS[tool].pip] = r["version"]
    meta = {"date": datetime.datetime.now().strftime("%Y-%m-%d %H:%M"),
            "git": _git_state(), "load": (load0[0], os.getloadavg()[0]),
            "src_changed": src_hash() != hash0,
            "openimp_from": _openimp_origin(), "openimp_hash": hash0,
            "machine": platform.machine(), "cpus": os.cpu_count(),
            "python": platform.python_version(), "numpy": np.__version__,
            "versions": versions, "total_s": time.perf_counter() - t0}
    text = report(results, extras, meta)
    if "vibration" in extras:
        text += "\n" + vib_text
    if "statics" in extras:
        text += "\n" + st_text
    if "dynamics" in extras:
        text += "\n" + dy_text
    print(text)
    full = (not a.quick and set(cases) == {*CASE_ORDER, "million"}
            and set(tools) == set(TOOL_ORDER))
    out = Path(a.out) if a.out else HERE / ("results.md" if full else "results-partial.md")
    out.write_text(text)
    raw = {"meta": meta, "extras": extras,
           "results": [dict(r, tool=t, case=c) for (t, c), r in results.items()]}
    out.with_suffix(".json").write_text(json.dumps(raw, indent=1, default=float))
    return 0


if __name__ == "__main__":
    sys.exit(main())
