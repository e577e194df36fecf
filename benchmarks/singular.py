"""What finding singular postures costs an ordinary sweep (issue 12's target: under 5%).

``python -m benchmarks.singular [--repeats N] [--out FILE]``

On the four-bar of case (a) (360 one-degree crank steps, no singular posture)
and on a parallelogram (720 steps, two change points a turn), in one process:

* the sweep as it is: the step loop's branch guard (tangent held near singular
  postures, the sideways-move check) and the search for singular postures
  after it (:func:`openimp.kinematics.singular.find`);
* the same with the search replaced by one that finds nothing: what the
  Python-side search costs.

The step loop's own guard cannot be switched off at run time; its cost is
measured by running this script on the tree before it (see the report in
``benchmarks/singular.md``).  Medians of alternating runs.
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import numpy as np

import openimp
from benchmarks import mechanisms as mx
from benchmarks.tools.openimp_tool import fourbar_model


def _parallelogram() -> openimp.Model:
    m = openimp.Model("parallelogram")
    m.add_joint("revolute", "G0", "BASE", "K0", origin=(0, 0, 0))
    m.add_joint("revolute", "G1", "BASE", "K1", origin=(2, 0, 0))
    m.add_joint("revolute", "TA", "K0", "C", origin=(0, 1, 0))
    m.add_joint("revolute", "TB", "C", "K1", origin=(2, 1, 0))
    return m


def _time(fn, repeats: int) -> list[float]:
    out = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        out.append(time.perf_counter() - t)
    return out


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--repeats", type=int, default=400)
    p.add_argument("--out", default=str(Path(__file__).with_name("singular.md")))
    a = p.parse_args(argv)
    from openimp.kinematics import singular

    fb = mx.FOURBAR
    cases = {
        "four-bar, 360 steps, no singular posture":
            (openimp.compile(fourbar_model(fb)), {"A": fb.crank_angles() - fb.theta0}),
        "parallelogram, 720 steps, 4 change points":
            (openimp.compile(_parallelogram()), {"G0": np.radians(np.arange(720.0))}),
    }
    real = singular.find
    rows = []
    for name, (s, drv) in cases.items():
        res = openimp.sweep(s, drv)
        assert res.complete, res.message
        nsing = len(res.singularities)
        full, bare = [], []
        for _ in range(a.repeats // 20):
            full += _time(lambda s=s, drv=drv: openimp.sweep(s, drv), 10)
            singular.find = lambda *args, **kw: []
            try:
                bare += _time(lambda s=s, drv=drv: openimp.sweep(s, drv), 10)
            finally:
                singular.find = real
        f, b = statistics.median(full), statistics.median(bare)
        rows.append((name, nsing, f * 1e6, b * 1e6, 100.0 * (f - b) / b))
    lines = ["| case | singular postures | sweep (us) | without the search (us) | "
             "search cost |", "|---|---:|---:|---:|---:|"]
    lines += [f"| {n} | {k} | {f:.1f} | {b:.1f} | {c:+.1f}% |" for n, k, f, b, c in rows]
    text = "\n".join(lines)
    print(text)
    Path(a.out).write_text("# Cost of finding singular postures\n\n"
                           "`python -m benchmarks.singular` (medians, one process).\n\n"
                           + text + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
