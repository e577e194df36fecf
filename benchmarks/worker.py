"""One (tool, case) measurement in a fresh process: ``python -m benchmarks.worker TOOL CASE``.

Prints one JSON record on the last line of stdout (see :func:`benchmarks.harness.measure`).
"""

from __future__ import annotations

import argparse
import importlib
import json
import sys
import time
import traceback


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser()
    p.add_argument("tool")
    p.add_argument("case")
    p.add_argument("--save", default=None, help="write the outputs to this .npz")
    p.add_argument("--cold-only", action="store_true")
    p.add_argument("--nvariants", type=int, default=None)
    p.add_argument("--nmillion", type=int, default=1_000_000)
    p.add_argument("--repeats", type=int, default=5)
    p.add_argument("--budget", type=float, default=4.0)
    a = p.parse_args(argv)

    rec: dict = {"tool": a.tool, "case": a.case}
    t0 = time.perf_counter()
    try:
        from benchmarks.harness import CASE_SPECS, Context, measure
        from benchmarks.tools import TOOLS

        tool = TOOLS[a.tool]
        try:
            mod = importlib.import_module(tool.module)
            rec["version"] = mod.version()
        except ImportError as e:
            rec.update(status="missing", reason=f"{type(e).__name__}: {e}")
            print(json.dumps(rec))
            return 0
        rec["import_s"] = time.perf_counter() - t0
        ctx = Context(nvariants=a.nvariants or tool.nvariants, nmillion=a.nmillion,
                      repeats=a.repeats, budget_s=a.budget, extra=dict(tool.extra))
        factory = mod.CASES.get(a.case)
        if factory is None:
            why = getattr(mod, "UNSUPPORTED", {}).get(a.case, "not implemented for this tool")
            rec.update(status="n/a", reason=why)
        else:
            rec.update(measure(factory, CASE_SPECS[a.case], ctx, save_to=a.save,
                               cold_only=a.cold_only))
        rec["nvariants"] = ctx.nvariants
    except Exception as e:  # report, never crash the whole benchmark
        rec.update(status="error", reason=f"{type(e).__name__}: {e}",
                   traceback=traceback.format_exc(limit=6))
    rec["wall_s"] = time.perf_counter() - t0
    print(json.dumps(rec, default=float))
    return 0


if __name__ == "__main__":
    sys.exit(main())
