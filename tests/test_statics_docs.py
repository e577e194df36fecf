"""docs/statics.md runs as written, and its numbers are right.

The ```python blocks run in order in one namespace (from the repository root,
where the IMP example decks are); then, in plain numpy and scipy:

* the spring-held inverted pendulum: k theta = m g l sin theta (brentq), its
  stiffness k - m g l cos theta, potential 1/2 k theta^2 + m g l cos theta, the
  pin's reaction on the rod (m g up, -k theta about the pin), the frequency
  sqrt(K / (m l^2)) about the rest; the upright start
  (an unstable equilibrium, left; or kept, with K = k - m g l); the holding torque
  k theta - m g l sin theta of a held pin;
* the cart: the deflection m g / k and the neutral slide; under a side load no
  rest (the step cap);
* the wound pendulum path: alpha = phi + (m g l / k) sin phi at every step, the
  key's torque m g l sin phi, the fold between the steps the page says, the
  turning points;
* the counterbalanced arm deck: the moment balance by brentq, its joint load and
  spring tension;
* every number the page quotes is the reference's, rounded as printed.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
from scipy.optimize import brentq

from helpers.docs import blocks, squash

ROOT = Path(__file__).parent.parent
DOC = ROOT / "docs" / "statics.md"
DEG = math.pi / 180.0


def test_statics_docs_run_and_are_right(monkeypatch, capsys) -> None:
    text = DOC.read_text()
    flat = squash(text.replace("`", ""))
    code = blocks(text)
    assert len(code) >= 6
    monkeypatch.chdir(ROOT)
    ns: dict = {"__name__": "docs_statics"}
    for block in code:
        exec(compile(block, str(DOC), "exec"), ns)
    capsys.readouterr()

    # --- the spring-held inverted pendulum: k theta = m g l sin theta
    l, mass, g, k = ns["l"], ns["mass"], ns["g"], ns["k"]  # the last values set: the path's
    eq, up, top, held = ns["eq"], ns["up"], ns["top"], ns["held"]
    k1, mgl = 15.0, 2.0 * 9.81 * 1.0
    theta = brentq(lambda t: k1 * t - mgl * math.sin(t), 0.1, 3.0, xtol=1e-15)
    assert eq.converged and eq.status == "balanced" and eq.stability == "stable"
    assert abs(eq.value("A") - theta) < 1e-10
    stiff = k1 - mgl * math.cos(theta)
    np.testing.assert_allclose(eq.eigenvalues, [stiff], rtol=1e-9)
    np.testing.assert_allclose(eq.stiffness, [[stiff]], rtol=1e-9)
    assert eq.unbalance < 1e-10
    assert abs(eq.potential - (0.5 * k1 * theta**2 + mgl * math.cos(theta))) < 1e-9
    reaction = eq.forces.reaction("A")[0]
    np.testing.assert_allclose(reaction, [0, mgl, 0, 0, 0, -k1 * theta], atol=1e-9)
    assert f"{theta:.7f} rad" in flat and f"{theta / DEG:.4f} degrees" in flat
    assert f"[{stiff:.5f}]" in flat and f"{stiff:.5f} N m/rad" in flat
    assert f"{-k1 * theta:.4f}]" in flat and f"{mgl:g}," in flat
    assert f"Equilibrium found after {eq.steps} search steps." == eq.messages[0]
    assert f"True balanced {eq.steps}" in flat
    # the frequency about the rest: sqrt(K / (m l^2)) (a point mass at l)
    w = math.sqrt(stiff / (2.0 * 1.0**2))
    np.testing.assert_allclose(ns["md"].frequency, [w], rtol=1e-9)
    assert f"[{w:.5f}] rad/s" in flat
    # the upright start: an unstable equilibrium, left for the same rest
    assert abs(up.value("A") - theta) < 1e-10 and up.converged
    assert any("unstable equilibrium(s) left" in m for m in up.messages)
    assert top.value("A") == 0.0 and top.stability == "unstable" and top.converged
    np.testing.assert_allclose(top.eigenvalues, [k1 - mgl], rtol=1e-12)
    assert f"[{k1 - mgl:.2f}]" in flat
    assert "potential energy falls along (+1 A.theta)" in top.messages[1]
    # held at 0.5 rad: the holding torque k theta - m g l sin theta
    hold = k1 * 0.5 - mgl * math.sin(0.5)
    assert held.status == "no free coordinate" and held.converged
    assert abs(held.holding["A.theta"] - hold) < 1e-10
    assert abs(held.forces.drive["A.theta"][0] - hold) < 1e-10
    # the rod's free body: the pin's moment (spring and holder) balances gravity
    assert abs(held.forces.reaction("A")[0, 5] + mgl * math.sin(0.5)) < 1e-10
    assert f"{hold:.5f}" in flat

    # --- the cart: neutral along the slider, no rest under a side load
    rest, windy = ns["rest"], ns["windy"]
    assert rest.converged and rest.stability == "neutral"
    assert abs(rest.value("Y") + 50.0 * 9.81 / 1.0e4) < 1e-12
    assert f"{-50.0 * 9.81 / 1.0e4:.5f}" in flat
    assert "neutral equilibrium: no stiffness along (+1 X.s)" in rest.messages[1]
    assert not windy.converged and windy.status == "step cap" and windy.steps == 5
    assert windy.messages[0].startswith("equilibrium not found in 5 search steps (the step cap)")
    assert "X.s" in windy.messages[0] and abs(windy.unbalance - 5.0) < 1e-9
    assert abs(windy.value("Y") - rest.value("Y")) < 1e-12

    # --- the wound pendulum: alpha = phi + (m g l / k) sin phi
    path, alpha, phi, hold = ns["path"], ns["alpha"], ns["phi"], ns["hold"]
    assert (l, mass, g, k) == (1.0, 2.0, 9.81, 8.0)
    mgl = mass * g * l
    assert len(path) == alpha.size == 25 and path.message == ""
    resid = alpha - phi - (mgl / k) * np.sin(phi)
    np.testing.assert_allclose(np.angle(np.exp(1j * resid)), 0.0, atol=1e-9)
    np.testing.assert_allclose(hold, mgl * np.sin(phi), atol=1e-9)
    lam = np.array([e.eigenvalues[0] for e in path.steps])
    np.testing.assert_allclose(lam, k + mgl * np.cos(phi), rtol=1e-8)
    assert path.stability == ["stable"] * 25
    np.testing.assert_allclose(path.forces.reaction("A")[:, 5], hold, atol=1e-9)
    # the quoted values at steps 6, 16, 17
    for i in (6, 16, 17):
        assert f"{np.degrees(phi[i] % (2 * np.pi)):.3f}" in flat
        assert f"{hold[i]:.4f}" in flat
    # the fold: 1 + (m g l / k) cos phi = 0
    phi_f = math.acos(-k / mgl)
    alpha_f = phi_f + (mgl / k) * math.sin(phi_f)
    assert alpha[16] < alpha_f < alpha[17]
    assert f"phi = {phi_f / DEG:.2f} degrees, alpha = {alpha_f / DEG:.2f} degrees" in flat
    assert phi[16] < phi_f and phi[17] % (2 * np.pi) > np.pi  # snapped over the top
    # the holding torque's maximum m g l at phi = 90 degrees
    a90 = (math.pi / 2 + mgl / k) / DEG
    assert f"= {mgl:g} N m" in flat and f"alpha = {a90:.1f} degrees" in flat
    tps = path.turning_points
    assert any("between steps 16 and 17 (" in t and "the equilibrium jumps" in t
               and "a limit point (snap-through)" in t for t in tps)
    top_k = int(np.argmax(hold))
    assert top_k == 15 and any(f"maximum of about {hold[15]:.6g} at step 15" in t for t in tps)
    assert f"{hold[15]:.6g}" in flat
    assert abs(hold[15] / mgl - 1) < 0.004  # "to 0.4 %"
    table = path.to_table()
    np.testing.assert_allclose(table["holding A.theta"], hold)

    # --- the counterbalanced arm deck: the moment balance
    run = ns["run"]
    W, c, b, kk, l0 = 10.0, 8.0, 6.0, 4.0, 6.0
    Q = np.array([-2.0, 10.0])

    def spring(t: float):
        S = b * np.array([math.cos(t), math.sin(t)])
        d = Q - S
        length = float(np.hypot(*d))
        return S, kk * (length - l0) * d / length, kk * (length - l0)

    def moment(t: float) -> float:
        S, f, _ = spring(t)
        return float(S[0] * f[1] - S[1] * f[0]) - W * c * math.cos(t)

    th = brentq(moment, 0.5, 1.2, xtol=1e-15)
    assert run.mode == "static" and run.ok
    assert abs(run.table("PRINT POSITION", "joint A").rows[0, 1] - th / DEG) < 1e-8
    _, f, T = spring(th)
    np.testing.assert_allclose(run.table("PRINT FORCE", "joint A").rows[0, 1:3],
                               [f[0], f[1] - W], atol=1e-8)
    assert abs(run.table("PRINT FORCE", "spring SP").rows[0, 1] - T) < 1e-8
    assert f"{th / DEG:.5f}" in flat and f"{T:.5f}" in flat
    assert f"[{f[0]:.5f} {f[1] - W:.5f}]" in flat


def test_statics_docs_examples_table_names_existing_decks() -> None:
    text = DOC.read_text()
    for name in re.findall(r"`examples/([a-z_]+\.imp)`", text):
        assert (ROOT / "examples" / name).is_file(), name
    for name in ("counterbalanced_arm.imp", "quarter_car.imp", "toggle_clamp.imp"):
        assert f"examples/{name}" in text
