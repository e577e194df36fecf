"""Cold start: each analysis's first call in a fresh process on an empty kernel cache.

    python -m benchmarks.coldstart               # every case; about 15-25 min of CPU
    python -m benchmarks.coldstart --cases sweep,forces --label after

Every case runs in a new Python process twice, with its own empty numba cache
directory (``OPENIMP_CACHE_DIR``): the first run compiles what it needs (cold),
the second loads it from that cache (warm).  For each run the table gives the
child's CPU seconds (user + system, from ``resource.getrusage``: the steadier
figure on a shared machine) and its wall seconds, and the kernels numba compiled
(its compile events), with their CPU share.  Cases: the Python API's first
call of each analysis (sweep, forces, equilibrium, linearize + modes, simulate
with RK and with the book's step) and ``openimp run`` of each example deck by mode.
The rows go to ``benchmarks/coldstart.md`` (appended under ``--label``) and the
raw records to ``benchmarks/coldstart.json``.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

#: the Python cases: a statement run after the set-up below
SETUP = """
import numpy as np, openimp
from numba.core import event
class _L(event.Listener):
    n = 0; depth = 0; t0 = 0.0; total = 0.0
    def on_start(self, ev):
        if self.depth == 0:
            self.t0 = __import__("time").process_time()
        self.depth += 1
    def on_end(self, ev):
        self.depth -= 1
        if self.depth == 0:
            self.n += 1
            self.total += __import__("time").process_time() - self.t0
_l = _L(); event.register("numba:compile", _l)
def fourbar(mass=False):
    import math
    a, b, c, d = 1.0, 3.0, 2.5, 3.2
    th = math.radians(40)
    B = np.array([a * math.cos(th), a * math.sin(th), 0.0]); D = np.array([d, 0.0, 0.0])
    BD = D - B; L = np.linalg.norm(BD); x = (b*b - c*c + L*L) / (2*L); y = math.sqrt(b*b - x*x)
    ex = BD / L; C = B + x * ex + y * np.array([-ex[1], ex[0], 0.0])
    m = openimp.Model("four-bar")
    m.add_joint("revolute", "A", "BASE", "CRANK", origin=(0, 0, 0))
    m.add_joint("revolute", "B", "CRANK", "COUPLER", origin=B)
    m.add_joint("revolute", "C", "COUPLER", "ROCKER", origin=C)
    m.add_joint("revolute", "D", "ROCKER", "BASE", origin=D)
    if mass:
        m.add_mass("CRANK", 0.4, B / 2); m.add_mass("COUPLER", 1.2, (B + C) / 2)
        m.add_mass("ROCKER", 0.9, (C + D) / 2); m.set_gravity((0, -9.80665, 0))
        m.set_joint_spring("A", 5.0, 0.0)
    return openimp.compile(m)
"""
PYTHON = {
    "sweep": "s = fourbar(); r = openimp.sweep(s, {'A': np.radians(np.arange(361.))})",
    "sweep_rates": "s = fourbar(); r = openimp.sweep(s, {'A': np.radians(np.arange(361.))}, "
                   "rates={'A': 10.0}, accels={'A': 5.0})",
    "forces": "s = fourbar(True); f = openimp.forces(s, {'A': np.radians(np.arange(361.))}, "
              "rates={'A': 10.0}, accels={'A': 5.0})",
    "equilibrium": "s = fourbar(True); e = openimp.equilibrium(s)",
    "linearize_modes": "s = fourbar(True); e = openimp.equilibrium(s); "
                       "md = openimp.modes(openimp.linearize(s, e.q))",
    "simulate_rk": "s = fourbar(True); r = openimp.simulate(s, times=np.linspace(0, 1, 101), "
                   "method='rk')",
    "simulate_book": "s = fourbar(True); r = openimp.simulate(s, times=np.linspace(0, 1, 101), "
                     "method='book')",
}
TAIL = """
print("COLDSTART", _l.n, round(_l.total, 3))
"""
#: the example decks and their modes
DECKS = {
    "deck_kinematic": "examples/fourbar.imp",
    "deck_forces": "examples/engine.imp",
    "deck_static": "examples/counterbalanced_arm.imp",
    "deck_vibration": "examples/pendulum.imp",
    "deck_spring": "examples/fourbar_spring.imp",
    "deck_dynamic": "examples/fourbar_released.imp",
}


def _child(cmd: list[str], cache: str) -> dict:
    """Run ``cmd`` with the kernel cache ``cache``: CPU and wall seconds, compiles."""
    env = {**os.environ, "OPENIMP_CACHE_DIR": cache, "OPENIMP_NO_WARMUP": "1",
           "MPLBACKEND": "Agg"}
    env.pop("NUMBA_CACHE_DIR", None)
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    p = subprocess.run(cmd, capture_output=True, text=True, env=env, cwd=ROOT)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    rec = {"cpu_s": round(cpu, 2), "wall_s": round(wall, 2), "status": p.returncode}
    for line in p.stdout.splitlines():
        if line.startswith("COLDSTART"):
            _, n, total = line.split()
            rec["kernels"], rec["compile_cpu_s"] = int(n), float(total)
    if p.returncode not in (0, 1):
        rec["stderr"] = p.stderr[-2000:]
    return rec


def run_case(name: str) -> dict:
    """One case cold then warm, each in a new process, on a new empty cache."""
    with tempfile.TemporaryDirectory(prefix="coldstart-") as cache:
        if name in PYTHON:
            cmd = [sys.executable, "-c", SETUP + PYTHON[name] + TAIL]
        else:
            out = Path(cache) / "out"
            cmd = [sys.executable, "-m", "openimp.cli", "run", DECKS[name], "--quiet",
                   "--json", str(out.with_suffix(".json"))]
        cold = _child(cmd, cache)
        warm = _child(cmd, cache)
    return {"case": name, "cold": cold, "warm": warm}


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--cases", default=",".join([*PYTHON, *DECKS]))
    p.add_argument("--label", default="before")
    a = p.parse_args()
    recs = []
    for name in a.cases.split(","):
        rec = run_case(name)
        recs.append(rec)
        c, w = rec["cold"], rec["warm"]
        print(f"{name}: cold {c['cpu_s']} s CPU / {c['wall_s']} s wall "
              f"({c.get('kernels', '-')} kernels, {c.get('compile_cpu_s', '-')} s compiling); "
              f"warm {w['cpu_s']} s CPU / {w['wall_s']} s wall", flush=True)
    js = ROOT / "benchmarks" / "coldstart.json"
    old = json.loads(js.read_text()) if js.exists() else {}
    old[a.label] = recs
    js.write_text(json.dumps(old, indent=1))
    md = ROOT / "benchmarks" / "coldstart.md"
    lines = [f"\n## {a.label} ({time.strftime('%Y-%m-%d %H:%M')}, load "
             f"{os.getloadavg()[0]:.1f})\n",
             "| case | cold CPU s | cold wall s | kernels compiled | their CPU s | "
             "warm CPU s | warm wall s |", "|---|---|---|---|---|---|---|"]
    for r in recs:
        c, w = r["cold"], r["warm"]
        lines.append(f"| {r['case']} | {c['cpu_s']} | {c['wall_s']} | {c.get('kernels', '-')}"
                     f" | {c.get('compile_cpu_s', '-')} | {w['cpu_s']} | {w['wall_s']} |")
    head = "" if md.exists() else ("# Cold start\n\nWritten by `python -m benchmarks.coldstart`"
                                   " (see its docstring).\n")
    with md.open("a") as f:
        f.write(head + "\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
