"""Smoke tests of benchmarks/dynamics.py (the time response benchmark): the reference's
equation of motion, the common measures, the peers' models at the release posture and the
report.  The benchmark itself (minutes) is not run here."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks import dynamics as dy


def test_reference_terms_against_complex_step():
    assert dy.RED.complex_step_check() < 1e-12


def test_reference_at_release():
    M, _, dV, V = dy.RED.terms(dy.FB.theta0)
    # uniform bars: crank 1 kg (I = 1/12 about its middle) alone at unit crank rate
    # would give 1/3; the coupler and rocker add to it
    assert M > 1.0 / 3.0
    assert V == pytest.approx(dy.RED.extremes()["V0"])
    # released at rest, the crank falls forward (V decreases with theta past the crest)
    assert dV < 0.0
    xt = dy.RED.extremes()
    assert math.degrees(xt["theta_max"]) == pytest.approx(79.5, abs=0.1)
    assert xt["V_max"] > xt["V0"]  # the crest is above the start: no full turn
    assert dy.E_SCALE == pytest.approx(xt["V0"] - xt["V_min"])


def test_reference_conserves_energy_over_a_second():
    from scipy.integrate import solve_ivp

    sol = solve_ivp(dy.RED.rhs, (0.0, 1.0), [dy.FB.theta0, 0.0], method="DOP853",
                    rtol=1e-12, atol=1e-12)
    E = [dy.RED.energy(a, b) for a, b in sol.y.T]
    assert np.max(np.abs(np.asarray(E) - E[0])) / dy.E_SCALE < 1e-11


def test_measures_at_release():
    z = np.zeros((2, 3))
    t = dy.tree_measures(z, z)
    V0 = dy.RED.extremes()["V0"]
    np.testing.assert_allclose(t["energy"], V0, rtol=1e-14)
    assert np.max(t["gap"]) < 1e-14
    np.testing.assert_allclose(t["crank"], dy.FB.theta0)
    b = dy.body_measures(np.zeros((2, 9)), np.zeros((2, 9)))
    np.testing.assert_allclose(b["energy"], V0, rtol=1e-14)
    assert np.max(b["gap"]) < 1e-14


def test_measures_agree_on_a_moving_posture():
    """The tree and body measures of the same closed, moving posture (closed form)."""
    th, w = np.array([2.0]), 1.5
    km = dy.FB.link_motion(th, w, 0.0)
    phi0 = dy.FB.link_angles0()
    ang, rate = km["th"][0] - phi0, km["w"][0]
    q = np.array([[ang[0], ang[1] - ang[0], ang[2] - ang[1]]])
    qd = np.array([[rate[0], rate[1] - rate[0], rate[2] - rate[1]]])
    t = dy.tree_measures(q, qd)
    assert t["gap"][0] < 1e-12
    x, xd = np.zeros((1, 9)), np.zeros((1, 9))
    B = dy.FB.B_at(th)[0]
    C = dy.FB.C_at(th)[0]
    vB = w * np.array([-B[1], B[0]])
    vC = rate[2] * np.array([-C[1], C[0] - dy.FB.d])
    ends = [(dy.A0, B, np.zeros(2), vB), (B, C, vB, vC), (dy.D0, C, np.zeros(2), vC)]
    for i, (p, r, vp, vr) in enumerate(ends):
        _, _, c0 = dy.bar(i)
        x[0, 3 * i:3 * i + 2] = (p + r) / 2 - c0
        x[0, 3 * i + 2] = ang[i]
        xd[0, 3 * i:3 * i + 2] = (vp + vr) / 2
        xd[0, 3 * i + 2] = rate[i]
    b = dy.body_measures(x, xd)
    assert b["gap"][0] < 1e-12
    assert b["energy"][0] == pytest.approx(t["energy"][0], rel=1e-13)
    M, _, _, V = dy.RED.terms(2.0)
    assert t["energy"][0] == pytest.approx(0.5 * M * w * w + V, rel=1e-13)


def test_pinocchio_model_at_release():
    pytest.importorskip("pinocchio")
    tree = dy.PinocchioTree()
    a = tree.accel(np.zeros(3), np.zeros(3))
    M, _, dV, _ = dy.RED.terms(dy.FB.theta0)
    assert a[0] == pytest.approx(-dV / M, rel=1e-8)


def test_mujoco_model_compiles():
    mujoco = pytest.importorskip("mujoco")
    m = mujoco.MjModel.from_xml_string(dy.mujoco_xml())
    assert m.opt.timestep == 0.002 and m.nv == 3 and m.neq == 1
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    assert np.linalg.norm(d.site_xpos[0, :2] - dy.D0) < 1e-14
    np.testing.assert_allclose(m.body_mass[1:], [dy.bar(i)[0] for i in range(3)])


def _fake(tool: str, labels: list[tuple[str, dict]], err: float, t: float) -> dict:
    th = np.linspace(0.0, 1.0, dy.N_OUT)
    out = []
    for k, (label, params) in enumerate(labels):
        stride = round(params.get("print_step", dy.DT_OUT) / dy.DT_OUT)
        out.append({"label": label, "params": params, "status": "ok", "times": [t],
                    "median_s": t * (k + 1), "best_s": t, "first_s": t, "stride": stride,
                    "crank": (th[::stride] + err / (k + 1)).tolist(), "drift": 1e-6,
                    "gap": 1e-9, "steps": 10, "rejected": 0, "evaluations": 60,
                    "closure": 1e-15, "own_energy": 1e-6, "fgc": ["B.theta"], "newton": 1,
                    "jacobians": 1, "own_energy_diff": 1e-14})
    return {"tool": tool, "status": "ok", "version": "0", "settings": out}


def test_section_renders_and_states_the_targets():
    recs = {
        "reference": dict(_fake("reference", [("ref", {})], 0.0, 0.1),
                          complex_step=1e-15, extremes=dy.RED.extremes()),
        "openimp": _fake("openimp", [("rk a", {"method": "rk"}), ("rk b", {"method": "rk"}),
                                     ("book a", {"method": "book", "print_step": 0.1})],
                         1e-6, 0.01),
        "exudyn": _fake("exudyn", [("1 ms", {"h": 1e-3})], 1e-5, 0.2),
        "mujoco": _fake("mujoco", [("default", {"integrator": "Euler", "h": 2e-3})], 1.0,
                        0.015),
        "pinocchio": {"tool": "pinocchio", "status": "missing", "reason": "not installed"},
    }
    info = {"date": "today", "machine": "x", "cpus": 2, "load": [1.0, 1.0], "git": "abc"}
    text = dy.section(recs, 3, info)
    assert text.startswith(dy.TITLE)
    assert "### Targets (issue 16)" in text
    assert "| 20.00x faster | **yes** |" in text  # Exudyn 0.2 s against openimp rk a, 0.01 s
    assert "| 1.50x faster | **yes** |" in text  # MuJoCo 0.015 s against openimp rk a
    # the book setting has outputs every 0.1 s: information rows only
    assert "book: no setting" in text and "book a" in text
    assert "not installed" in text
    assert "Target 1 (at least 10x faster than Exudyn" in text
    assert "Target 2" in text and "**met**" in text
    assert "crank" not in str(dy.summary(recs))


def test_openimp_remark_and_warmup_text():
    """rk with outputs every 0.01 s and every 0.1 s: the same steps, the extra outputs'
    cost; book's steps at most the spacing; the warm-up times in the run paragraph."""
    recs = {"openimp": _fake("openimp", [
        ("rk 1e-8", {"method": "rk", "rtol": 1e-8}),
        ("rk 1e-8, 0.1 s", {"method": "rk", "rtol": 1e-8, "print_step": 0.1}),
        ("book", {"method": "book", "force_error": (0.1, 1.0)}),
        ("book, 0.1 s", {"method": "book", "print_step": 0.1})], 1e-6, 0.01)}
    a, b = recs["openimp"]["settings"][:2]
    a["median_s"], b["median_s"], a["evaluations"] = 0.019, 0.010, 960
    text = dy._openimp_remark(recs)
    assert "rk takes the same steps" in text
    assert "rtol 1e-8: 10 and 10 steps, 900 more evaluations, 19.00 and 10.00 ms" in text
    assert "10.0 us each" in text  # 9 ms over the 900 extra outputs
    assert "at most the output spacing" in text
    assert "every 0.01 s is" not in text and "us per output" not in text
    assert dy._warmup_text({}) == ""
    recs["openimp"]["warmup_s"] = {"rk": 12.5, "book": "error: boom"}
    assert dy._warmup_text(recs) == "; the warm-up took rk 12.5 s, book: error: boom"


def test_openimp_warmup_runs_each_method_before_any_setting(monkeypatch):
    """openimp_settings: one untimed short simulate per method (compilation) before it
    hands out the settings; their first runs are then guarded, their timed runs not."""
    import types

    calls = []

    class _System:
        var_names = ("A", "B", "C")

        def var_index(self, k):
            return self.var_names.index(k)

    def simulate(system, t_final, **kw):
        calls.append((t_final, kw["method"], kw["progress"]))
        return "res"

    fake = types.SimpleNamespace(compile=lambda m: _System(), simulate=simulate)
    monkeypatch.setitem(sys.modules, "openimp", fake)
    monkeypatch.setattr(dy, "openimp_model", lambda: None)
    settings = dy.openimp_settings()
    assert calls == [(dy.WARMUP_T, "rk", False), (dy.WARMUP_T, "book", False)]
    assert set(dy.WARMUP) == {"rk", "book"}
    assert len(settings) == len(dy.OPENIMP_SETTINGS)
    run = settings[0][1]
    times, res, first = dy.time_setting(run, 2)
    assert res == "res" and len(times) == 2 and first >= 0.0
    # the first run carries the guard (a callable), the timed runs no progress at all
    assert callable(calls[2][2]) and calls[3][2] is False and calls[4][2] is False
    assert all(c[0] == dy.T_FINAL for c in calls[2:])
