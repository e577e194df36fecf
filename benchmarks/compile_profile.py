"""Where a cold first call spends its compile time: numba's own time per function.

    python -m benchmarks.compile_profile forces          # a case of benchmarks.coldstart
    python -m benchmarks.compile_profile simulate_rk --top 30

Runs the case once in a new process on an empty kernel cache and listens to
numba's compile events: each compiled function's own CPU seconds (its compile
less the compiles of the functions it calls), largest first.  The functions on
top are what to cut (a numba-level ``inline="always"`` types the inlined body
again in every caller; a large kernel is typed and lowered as a whole).
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
from pathlib import Path

from benchmarks.coldstart import PYTHON, SETUP

ROOT = Path(__file__).resolve().parents[1]

LISTEN = """
import collections, time
from numba.core import event as _event
_stack, _self, _count = [], collections.Counter(), collections.Counter()
class _Profile(_event.Listener):
    def on_start(self, ev):
        fn = getattr(ev.data.get("dispatcher"), "py_func", None)
        name = f"{fn.__module__}.{fn.__qualname__}" if fn else "?"
        _stack.append([name, time.process_time(), 0.0])
    def on_end(self, ev):
        name, t0, child = _stack.pop()
        dt = time.process_time() - t0
        _self[name] += dt - child; _count[name] += 1
        if _stack:
            _stack[-1][2] += dt
_event.register("numba:compile", _Profile())
"""
REPORT = """
print(f"PROFILE total {{sum(_self.values()):.1f}} s, {{sum(_count.values())}} compiles of "
      f"{{len(_count)}} functions")
for _n, _t in _self.most_common({top}):
    print(f"PROFILE {{_t:8.2f}} s  x{{_count[_n]}}  {{_n}}")
"""


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("case", choices=sorted(PYTHON))
    p.add_argument("--top", type=int, default=20)
    a = p.parse_args()
    with tempfile.TemporaryDirectory(prefix="compile-profile-") as cache:
        env = {**os.environ, "OPENIMP_CACHE_DIR": cache, "OPENIMP_NO_WARMUP": "1"}
        code = LISTEN + SETUP + PYTHON[a.case] + REPORT.format(top=a.top)
        r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                           env=env, cwd=ROOT)
    for line in r.stdout.splitlines():
        if line.startswith("PROFILE "):
            print(line[8:])
    if r.returncode:
        print(r.stderr[-2000:], file=sys.stderr)
        raise SystemExit(r.returncode)


if __name__ == "__main__":
    main()
