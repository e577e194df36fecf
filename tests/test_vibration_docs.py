"""docs/vibration.md runs as written, and its numbers are right.

The ```python blocks run in order in one namespace; then, in plain numpy:
the pendulum's M, D, K and frequency against the compound-pendulum closed
forms (I_pivot = m l^2 / 3, stiffness m g l / 2); its animated mode swings the
tip by the amplitude asked; the flexible four-bar's frequency at every crank
angle against sqrt(k / M_EE) with the slide E itself as the coordinate (the
mass matrix of a second choice of coordinates: frequencies at an equilibrium
do not depend on it); the isolator's transfer functions against
1 / (m s^2 + c s + k) and (c s + k) / (m s^2 + c s + k), and its state-space
step response against the static deflection 1 / k.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from helpers.docs import blocks
from openimp.dynamics.eom import equations

DOC = Path(__file__).parent.parent / "docs" / "vibration.md"


def test_vibration_docs_run_and_are_right(tmp_path, monkeypatch, capsys) -> None:
    code = blocks(DOC.read_text())
    assert len(code) >= 5
    monkeypatch.chdir(tmp_path)
    ns: dict = {"__name__": "docs_vibration"}
    for block in code:
        exec(compile(block, str(DOC), "exec"), ns)
    # --- the pendulum: closed forms
    mass, l, c = ns["mass"], ns["l"], ns["c"]
    I_pivot = mass * l * l / 3
    md = ns["md"]
    lin = md.linearization
    np.testing.assert_allclose(lin.M, [[I_pivot]], rtol=1e-12)
    np.testing.assert_allclose(lin.D, [[c]], rtol=1e-12)
    np.testing.assert_allclose(lin.K, [[mass * 9.81 * l / 2]], rtol=1e-12)
    wn = np.sqrt(mass * 9.81 * l / 2 / I_pivot)
    np.testing.assert_allclose(md.frequency[0], wn, rtol=1e-12)
    np.testing.assert_allclose(md.damping[0], c / (2 * np.sqrt(I_pivot * mass * 9.81 * l / 2)),
                               rtol=1e-12)
    assert (tmp_path / "pendulum_mode1.html").stat().st_size > 1000
    tip = ns["tr"].point("TIP")
    swing = np.arctan2(tip[:, 0], -tip[:, 1])          # the rod's angle from hanging
    np.testing.assert_allclose(np.abs(swing).max(), 0.3, rtol=1e-9)
    # --- the flexible four-bar: omega^2 = k / M_EE with E as the coordinate
    fourbar, held, k = ns["fourbar"], ns["held"], ns["k_axial"]
    ref = []
    for q in held.q:
        e = equations(fourbar, q, specified=["A", "E"])
        i = e.coords.index("E.s")
        ref.append(np.sqrt(k / e.M[i, i]))
    np.testing.assert_allclose(ns["freq"], ref, rtol=1e-10)
    np.testing.assert_allclose(ns["fmap"].frequency[:, 0], ns["freq"], rtol=1e-12)
    # --- the isolator
    k, mb, cb = ns["k"], ns["mb"], ns["cb"]
    s = 1j * ns["w"]
    np.testing.assert_allclose(ns["force"](s), 1 / (mb * s**2 + cb * s + k), rtol=1e-10)
    base = (cb * s + k) / (mb * s**2 + cb * s + k)
    np.testing.assert_allclose(ns["base"](s), base, rtol=1e-10)
    H = ns["fr"].H
    np.testing.assert_allclose(H[:, 0], base, rtol=1e-10)
    np.testing.assert_allclose(H[:, 1], s**2 * base, rtol=1e-10)
    # settled after 10 s: the decay exp(-c t / 2m) = exp(-15) leaves 3e-7 of the step
    np.testing.assert_allclose(ns["y"][-1], 1 / k, rtol=1e-5)
