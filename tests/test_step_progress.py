"""Every loop of the time step ends (issue 30, N1).

The book step with a smallest step that does not divide the output spacing and a
force error it cannot meet there: landing on the next output stretched the step above
the smallest, the finish rejected it as not at the smallest step, halved it, the next
attempt raised it back to the smallest and landing stretched it again, for ever, inside
compiled code (Ctrl-C and ``max_steps`` never reached).  A step whose proposal is the
smallest step is now kept whatever its error (counted in ``forced``), however landing
stretched it; MAX_REJECTS rejections in a row end a run with a message; the run loop
returns to Python every 0.2 s of wall time (progress, Ctrl-C).

The runs are real processes under a CPU-time limit (a cold kernel cache compiles the
book step first), so a busy machine cannot fail them and a regression cannot hang the
suite.  The pendulum is checked against scipy: with a smallest step of 0.03 s the book
steps land on the outputs in steps of 0.025 s (a step kept whatever its error is never
longer than the smallest), every one above the force error; 4.9e-4 rad off.
"""

from __future__ import annotations

import json
import math
import re
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

from helpers.decks import PENDULUM_HEAD, cpu_limit

PENDULUM = textwrap.dedent("""
    import json, math, openimp
    m = openimp.Model("pendulum")
    m.set_units("SI")
    m.add_joint("revolute", "A", "BASE", "ROD", origin=(0, 0, 0))
    m.add_mass("ROD", 2.0, (0, -0.5, 0), (0.04, 0.04, 0.04))
    m.set_gravity((0, -9.81, 0))
    s = openimp.compile(m)
    r = openimp.simulate(s, 1.0, print_step=0.05, q={"A": 1.0}, method="book",
                         min_step=0.03, force_error=(1e-6, 1e-6), progress=False)
    print(json.dumps({"complete": r.complete, "message": r.message, "n": len(r),
                      "forced": r.integration.forced, "steps": r.integration.steps,
                      "rejected": r.integration.rejected, "t": r.time.tolist(),
                      "a": r.variable("A").tolist()}))
""")


def _run(code: str) -> dict:
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                       preexec_fn=cpu_limit)
    assert p.returncode == 0, p.stderr[-2000:]
    return json.loads(p.stdout.strip().splitlines()[-1])


def test_book_step_at_the_smallest_step_ends():
    r = _run(PENDULUM)
    assert r["complete"] and r["message"] == ""
    assert r["n"] == 21
    assert r["forced"] > 0  # steps kept above the force error: at the smallest step
    assert r["rejected"] < 1000
    # the motion: 2 kg with its centre 0.5 m from the pivot, 0.04 kg m^2 about the centre
    inertia = 2.0 * 0.25 + 0.04
    sol = solve_ivp(lambda _, y: [y[1], -2.0 * 9.81 * 0.5 * math.sin(y[0]) / inertia],
                    (0.0, 1.0), [1.0, 0.0], t_eval=np.array(r["t"]), rtol=1e-12, atol=1e-12)
    assert np.abs(np.array(r["a"]) - sol.y[0]).max() < 2e-3


PENDULUM_DECK = PENDULUM_HEAD + """\
FIND DYNAMICS
DATA IC (A) = -60, 1.5
DATA TIME = 1.0, 0.03, 0.05
ZERO (FORCE) = 0.000001, 0.000001
LIST POSITION (A)
EXECUTE
END
"""


def _deck(tmp_path, name: str, text: str) -> subprocess.CompletedProcess:
    deck = tmp_path / name
    deck.write_text(text)
    return subprocess.run([sys.executable, "-m", "openimp.cli", "run", str(deck), "--json",
                           str(tmp_path / "out.json")], capture_output=True, text=True,
                          preexec_fn=cpu_limit, cwd=tmp_path)


def test_decks_with_a_smallest_step_end(tmp_path):
    """The fuzz findings' decks: the pendulum with a tight ZERO (FORCE), and the shipped
    released four-bar and engine run-up with a smallest step that does not divide the
    print step (DATA TIME = 2.0, 0.03, 0.05 and 0.5, 0.015, 0.02)."""
    root = Path(__file__).resolve().parent.parent / "examples"
    decks = {"pendulum.imp": PENDULUM_DECK}
    for name, new in (("fourbar_released.imp", "DATA TIME = 2.0, 0.03, 0.05"),
                      ("engine_runup.imp", "DATA TIME = 0.5, 0.015, 0.02")):
        text = (root / name).read_text()
        old = re.search(r"^DATA TIME *=.*$", text, re.M)
        assert old is not None
        decks[name] = text.replace(old.group(0), new)
    for name, text in decks.items():
        p = _deck(tmp_path, name, text)
        assert p.returncode == 0, (name, p.stdout[-1500:], p.stderr[-1500:])
        out = json.loads((tmp_path / "out.json").read_text())
        assert out, name
