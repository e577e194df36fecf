"""Issue 25 item 7's acceptance from decks: ``REMARK OPENIMP INTEGRATOR = RK, 1E-10``.

``python -m benchmarks.deck_acceptance [--out FILE] [--only pendulum|a02]``

Two IMP decks written here and run as a user runs them (``openimp.imp.deck.load``
then ``run``), each against a high-precision reference integrated with scipy's
DOP853 at 1e-13:

* the fuzz findings' pendulum (2 kg at 0.25 m, 1/6 kg m^2 about the pin), released
  from rest at 60 deg below the horizontal for 2000 s: the bob's position error;
* IFToMM A02 with N = 40 parallelogram four-bars for 20 s (the model of
  ``tests/test_step_accuracy.py``'s ``a02`` written as ZPIN, DATA MASS and DATA
  INERTIA statements), the first crank's tip starting at 1 m/s: the tip's error.

CPU seconds are measured with the kernel cache warm (a first run compiles).
"""

from __future__ import annotations

import argparse
import math
import tempfile
import time
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

from openimp.imp.deck import load

RTOL = "1E-10"
G = 9.80665
PEND_C, PEND_M, PEND_I = 0.25, 2.0, float(f"{1.0 / 6.0:.12f}")


def pendulum_deck(final: float, step: float) -> str:
    return f"""TITLE = PENDULUM {final:g} S
UNIT (MASS) = 1
ZPIN (BASE, ARM) = A
DATA ZPIN (A) = 0,0,0; 1,0,0; 1,0,0
POINT (ARM) = BOB
DATA POINT (BOB, ABS) = {PEND_C}, 0, 0
DATA MASS (ARM, A) = {PEND_M}; {PEND_C}, 0, 0
DATA INERTIA (ARM, A) = 0, {PEND_I:.12f}, {PEND_I:.12f}, 0, 0, 0
DATA GRAVITY = 0, -{G}, 0
REMARK OPENIMP INTEGRATOR = RK, {RTOL}
FIND DYNAMICS
DATA IC (A) = -60, 0
DATA TIME = {final:g}, 0, {step:g}
LIST POSITION (BOB)
EXECUTE
END
"""


def pendulum_reference(t: np.ndarray) -> np.ndarray:
    """Bob (x, y) of I th'' = -m g c cos(th) from th = -60 deg at rest."""
    k = PEND_M * G * PEND_C / PEND_I
    sol = solve_ivp(lambda _, y: [y[1], -k * math.cos(y[0])], (0.0, t[-1]),
                    [math.radians(-60.0), 0.0], t_eval=t, rtol=1e-13, atol=1e-13,
                    method="DOP853")
    return PEND_C * np.stack([np.cos(sol.y[0]), np.sin(sol.y[0])], axis=1)


def a02_deck(n: int, final: float, step: float) -> str:
    third = f"{1.0 / 3.0:.12f}"  # IMP reads columns 1-72: 12 digits fit
    lines = [f"TITLE = A02 N = {n}", "UNIT (MASS) = 1"]
    for i in range(n + 1):
        lines += [f"ZPIN (BASE, C{i}) = P{i}", f"DATA ZPIN (P{i}) = {i},0,0; {i + 1},0,0; "
                  f"{i + 1},0,0", f"DATA MASS (C{i}, P{i}) = 1; 0, 0.5, 0",
                  f"DATA INERTIA (C{i}, P{i}) = {third}, 0, {third}, 0, 0, 0"]
    for i in range(1, n + 1):
        lines += [f"ZPIN (C{i - 1}, K{i}) = A{i}",
                  f"DATA ZPIN (A{i}) = {i - 1},1,0; {i},1,0; {i},1,0",
                  f"ZPIN (K{i}, C{i}) = B{i}", f"DATA ZPIN (B{i}) = {i},1,0; {i + 1},1,0; "
                  f"{i + 1},1,0", f"DATA MASS (K{i}, A{i}) = 1; 0.5, 0, 0",
                  f"DATA INERTIA (K{i}, A{i}) = 0, {third}, {third}, 0, 0, 0"]
    lines += ["POINT (C0) = TIP", "DATA POINT (TIP, ABS) = 0, 1, 0",
              "DATA GRAVITY = 0, -9.81, 0", f"REMARK OPENIMP INTEGRATOR = RK, {RTOL}",
              "FIND DYNAMICS", "DATA IC (P0) = 0, -1", f"DATA TIME = {final:g}, 0, {step:g}",
              "LIST POSITION (TIP)", "EXECUTE", "END"]
    return "\n".join(lines) + "\n"


def a02_reference(n: int, t: np.ndarray) -> np.ndarray:
    """The first tip (x, y): m_eff th'' = -g k cos(th), th(0) = pi/2, th'(0) = -1 (the
    deck's 12-digit thirds in m_eff)."""
    third = float(f"{1.0 / 3.0:.12f}")
    meff, k = (n + 1) * third + n, (n + 1) / 2.0 + n  # the couplers translate
    sol = solve_ivp(lambda _, y: [y[1], -9.81 * k * math.cos(y[0]) / meff], (0.0, t[-1]),
                    [math.pi / 2, -1.0], t_eval=t, rtol=1e-13, atol=1e-13, method="DOP853")
    return np.stack([np.cos(sol.y[0]), np.sin(sol.y[0])], axis=1)


def run(name: str, text: str, warm: str, reference) -> dict[str, object]:
    """Run deck ``text`` after ``warm`` (the same model for 0.1 s: it compiles)."""
    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / f"{name}.imp"
        p.write_text(warm)
        load(p).run()
        p.write_text(text)
        deck = load(p)
        c0 = time.process_time()
        runs = deck.run()
        cpu = time.process_time() - c0
    r = runs[0]
    item = "point BOB" if name == "pendulum" else "point TIP"
    rows = r.table("LIST POSITION", item).rows
    ref = reference(rows[:, 0])
    err = float(np.abs(rows[:, 1:3] - ref).max())
    return {"name": name, "ok": r.ok, "failure": r.failure, "end": float(rows[-1, 0]),
            "rows": len(rows), "cpu": cpu, "error": err}


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(Path(__file__).with_name("deck_acceptance.md")))
    ap.add_argument("--only", choices=("pendulum", "a02"))
    a = ap.parse_args(argv)
    cases = {"pendulum": (pendulum_deck(2000.0, 1.0), pendulum_deck(0.1, 0.05),
                          pendulum_reference),
             "a02": (a02_deck(40, 20.0, 0.1), a02_deck(40, 0.1, 0.05),
                     lambda t: a02_reference(40, t))}
    out = [run(k, *v) for k, v in cases.items() if a.only in (None, k)]
    lines = [f"# Deck acceptance, `REMARK OPENIMP INTEGRATOR = RK, {RTOL}` "
             "(`python -m benchmarks.deck_acceptance`)", "",
             "CPU seconds on the 2-core machine, kernel cache warm; error: the largest "
             "distance of the listed point from the DOP853 1e-13 reference over every "
             "output (m).", "",
             "| deck | completes | end (s) | outputs | CPU (s) | max error (m) |",
             "|---|---|---:|---:|---:|---:|"]
    for o in out:
        lines.append(f"| {o['name']} | {'yes' if o['ok'] else o['failure']} | {o['end']:g} | "
                     f"{o['rows']} | {o['cpu']:.1f} | {o['error']:.2e} |")
    text = "\n".join(lines) + "\n"
    print(text)
    Path(a.out).write_text(text)


if __name__ == "__main__":
    main()
