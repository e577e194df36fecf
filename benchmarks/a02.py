"""IFToMM A02 through its change points: the time step's acceptance case (issue 24 item 8).

``python -m benchmarks.a02 [--n N] [--rtols 1e-8,1e-10,1e-12] [--out FILE]``

A chain of N parallelogram four-bars of uniform 1 m, 1 kg bars under gravity, the
first crank's tip starting at 1 m/s (the model is ``tests/test_step_accuracy.py``'s
``a02``): in 20 s it passes 20 horizontal postures where every parallelogram is at a
change point.  For each rtol the run (rk, the default closure tolerance) must complete;
the report gives its CPU time, steps, the largest error of the first crank's tip against
the one-freedom reference (every crank turns alike: m_eff theta'' = -g k cos theta),
the spread of the crank angles (0 on the parallelogram branch), the change points
reported and the largest error of their times against the reference's event finder.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

import openimp

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
from test_step_accuracy import a02, a02_crossings, a02_reference


def run(n: int, rtol: float) -> dict[str, float | int | str]:
    """One run of A02 with N = n at rtol: what the report shows."""
    s = a02(n)
    t = np.linspace(0.0, 20.0, 201)
    th = a02_reference(n, t)
    c0 = time.process_time()
    tr = openimp.simulate(s, times=t, rates={"P0": -1.0}, rtol=rtol, progress=False)
    cpu = time.process_time() - c0
    k = tr.time.size
    tip = tr.point("TIP")[:, :2]
    err = float(np.abs(tip - np.stack([np.cos(th[:k]), np.sin(th[:k])], 1)).max())
    cranks = np.array([tr.variable(f"P{i}") for i in range(n + 1)])
    ref = a02_crossings(n, 20.0)
    found = np.array([x.time for x in tr.singularities])
    terr = float(np.abs(found - ref[:found.size]).max()) if found.size else math.nan
    st = tr.integration
    return {"rtol": rtol, "complete": "yes" if tr.message == "" else tr.message,
            "end": float(tr.time[-1]), "cpu": cpu, "steps": st.steps, "rejected": st.rejected,
            "forced": st.forced, "tip": err, "spread": float(np.ptp(cranks, axis=0).max()),
            "crossings": found.size, "terr": terr}


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=40)
    ap.add_argument("--rtols", default="1e-8,1e-10,1e-12")
    ap.add_argument("--out", default=str(Path(__file__).with_name("a02.md")))
    a = ap.parse_args(argv)
    rows = []
    for r in (float(x) for x in a.rtols.split(",")):
        rows.append(run(a.n, r))
        print(rows[-1], flush=True)
    lines = [f"# IFToMM A02, N = {a.n}, 20 s, rk (`python -m benchmarks.a02`)", "",
             "| rtol | completes | CPU (s) | steps | rejected | forced | tip error (m) | "
             "crank spread (rad) | change points | their time error (s) |",
             "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for x in rows:
        lines.append(f"| {x['rtol']:g} | {x['complete']} | {x['cpu']:.1f} | {x['steps']} | "
                     f"{x['rejected']} | {x['forced']} | {x['tip']:.2e} | {x['spread']:.1e} | "
                     f"{x['crossings']} | {x['terr']:.1e} |")
    Path(a.out).write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
