"""docs/forces.md runs as written, and its numbers are right.

The ```python blocks run in order in one namespace; then, in plain numpy:
the engine's crank torque against the virtual work of the piston (the only
mass, and the gas force), T = (m x'' - F_gas) dx/dtheta with the closed-form
slider-crank x(theta) = r cos(theta) + sqrt(l^2 - r^2 sin^2(theta)); the main
bearing against the balance of forces on the moving parts (bearing + slide
guide + gas = m a of the piston); the quasi-static four-bar's torque against
differences of its potential energy; the Hooke coupling's input torque against
virtual work with the output load, and its indeterminate forces.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from helpers.docs import blocks

DOC = Path(__file__).parent.parent / "docs" / "forces.md"


def test_forces_docs_run_and_are_right(tmp_path, monkeypatch, capsys) -> None:
    code = blocks(DOC.read_text())
    assert len(code) >= 4
    monkeypatch.chdir(tmp_path)
    ns: dict = {"__name__": "docs_forces"}
    for block in code:
        exec(compile(block, str(DOC), "exec"), ns)
    # --- the engine: torque by virtual work of the piston
    r, l, omega, th = ns["r"], ns["l"], ns["omega"], ns["theta"]
    s, c = np.sin(th), np.cos(th)
    D = np.sqrt(l * l - r * r * s * s)
    x1 = -r * s - r * r * s * c / D                     # dx/dtheta
    x2 = -r * c - r * r * (c * c - s * s) / D - r**4 * s * s * c * c / D**3
    acc = x2 * omega**2                                   # constant speed
    gas = -4000.0 * np.maximum(s, 0.0)
    T_ref = (0.5 * acc - gas) * x1
    scale = np.abs(T_ref).max()
    np.testing.assert_allclose(ns["torque"], T_ref, atol=1e-9 * scale)  # solved to 1e-10
    # --- the main bearing: bearing + slide guide + gas = m a (x); the y forces cancel
    f = ns["f"]
    guide = f.reaction("D", "global")[:, :2]
    fx = ns["bearing"][:, 0] + guide[:, 0] + gas
    np.testing.assert_allclose(fx, 0.5 * acc, atol=1e-9 * np.abs(0.5 * acc).max())
    np.testing.assert_allclose(ns["bearing"][:, 1] + guide[:, 1], 0.0,
                               atol=1e-9 * np.abs(ns["bearing"]).max())
    assert np.array_equal(f.determinate("A")[0], [True, True, False, False, False, True])
    # --- the four-bar: tau = dV/dtheta (central differences, 5 deg steps: interior only)
    f4 = ns["f4"]
    thq = np.radians(np.arange(0, 91, 5.0))
    tau = f4.drive["A.theta"]
    dV = np.gradient(f4.potential, thq)
    err = np.abs(tau[1:-1] - dV[1:-1]).max() / np.abs(tau).max()
    assert err < 5e-3, err  # the truncation error of 5-degree central differences
    # finer: the same at one posture with a 1e-6 rad difference
    import openimp
    t0 = np.radians(40.0)
    tt = openimp.sweep(ns["sys4"], {"A": [t0 - 1e-6, t0, t0 + 1e-6]})
    ff = openimp.forces_of(tt)
    np.testing.assert_allclose(ff.drive["A.theta"][1],
                               (ff.potential[2] - ff.potential[0]) / 2e-6, rtol=1e-7)
    # --- the Hooke coupling: virtual work T_in w_in + P w_out = 0 (the sign of
    # the output rate as the joint OUT is oriented: SHAFT2 -> BASE), forces
    # indeterminate and moments determinate at every joint
    trh, fh = ns["trh"], ns["fh"]
    w_out = trh.joint_velocity("OUT")[:, 0]
    np.testing.assert_allclose(fh.drive["IN.theta"] * 1.0 + 10.0 * w_out, 0.0, atol=1e-9)
    for j in ("IN", "P1", "P2", "OUT"):
        assert np.all(fh.determinate(j) == [False] * 3 + [True] * 3), j
    out = capsys.readouterr().out
    assert "peak torque" in out and "main-bearing" in out
