"""docs/dynamics.md runs as written, and its numbers are right.

The ```python blocks run in order in one namespace (in a scratch folder: the
page streams a CSV file); then, in plain numpy and scipy:

* the four-bar of uniform bars released from the crank vertical: its
  one-degree-of-freedom reduction in the crank angle theta, m(theta) theta'' +
  m'(theta) theta'^2 / 2 + V'(theta) = 0, the loop closed by the intersection of
  two circles and the link rates and velocity-product accelerations from the
  2 x 2 loop equations, integrated by scipy (DOP853, 1e-13): the crank angle at
  every output, the stop, the energies, the pin reactions by the Newton-Euler
  equations of the three bars, the start at a rocker rate, the start from a
  sweep, the rigid limit of the stiff coupler hinge;
* the pendulum on the shaken cart: theta'' = -(g/l) sin theta - (x''/l) cos theta
  by scipy, the shaker's force as the rate of horizontal momentum, its work as
  the energy gained;
* the block on the buffer: the landing, leaving and second landing in closed
  form, the buffer's work as minus its elastic energy;
* the rocker driven to its limit of travel: the time at which crank and
  coupler come into line;
* the invariants: loop closure, energy balance, zero drive on a free
  coordinate; and every number the page quotes, rounded as printed.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq, minimize_scalar

from helpers.docs import blocks, squash

ROOT = Path(__file__).parent.parent
DOC = ROOT / "docs" / "dynamics.md"
DEG = math.pi / 180.0

# the four-bar (SI): crank a, coupler b, rocker c, frame d; bars of 1 kg/m
A_, B_, C_, D_, G = 1.0, 3.0, 2.5, 3.2, 9.81
MASS = (A_, B_, C_)
INERTIA = tuple(mm * ll * ll / 12.0 for mm, ll in zip(MASS, (A_, B_, C_), strict=True))


def linkage(th: float) -> dict:
    """The four-bar at crank angle th (from +x): pins as complex numbers, the coupler
    and rocker directions, their rates w2, w3 per unit crank rate and the
    velocity-product accelerations al2, al3 (at unit crank rate, no crank
    acceleration), the bars' centres G, their derivatives dG and ddG in th."""
    eB = complex(math.cos(th), math.sin(th))
    Bp = A_ * eB
    u = D_ - Bp
    L = abs(u)
    e = u / L
    x = (B_ * B_ - C_ * C_ + L * L) / (2 * L)
    Cp = Bp + (x + 1j * math.sqrt(B_ * B_ - x * x)) * e  # upper branch
    e2, e3 = (Cp - Bp) / B_, (Cp - D_) / C_
    p, q = 1j * B_ * e2, -1j * C_ * e3  # columns of the loop's velocity equations
    det = p.real * q.imag - q.real * p.imag

    def solve(r: complex) -> tuple[float, float]:  # p w2 + q w3 = r
        return ((r.real * q.imag - q.real * r.imag) / det,
                (p.real * r.imag - r.real * p.imag) / det)

    w2, w3 = solve(-1j * A_ * eB)
    al2, al3 = solve(A_ * eB + B_ * w2 * w2 * e2 - C_ * w3 * w3 * e3)
    return {
        "B": Bp, "C": Cp, "e2": e2, "e3": e3, "w2": w2, "w3": w3, "al2": al2, "al3": al3,
        "G": (Bp / 2, Bp + B_ / 2 * e2, D_ + C_ / 2 * e3),
        "dG": (1j * A_ / 2 * eB, 1j * A_ * eB + 1j * B_ / 2 * w2 * e2, 1j * C_ / 2 * w3 * e3),
        "ddG": (-A_ / 2 * eB, -A_ * eB + B_ / 2 * (1j * al2 - w2 * w2) * e2,
                C_ / 2 * (1j * al3 - w3 * w3) * e3),
    }


def terms(th: float) -> tuple[float, float, float, float]:
    """m(th), m'(th)/2, V(th), V'(th) of the reduction (V about the global origin)."""
    k = linkage(th)
    w = (1.0, k["w2"], k["w3"])
    al = (0.0, k["al2"], k["al3"])
    M = sum(mm * abs(v) ** 2 + ii * ww * ww
            for mm, ii, v, ww in zip(MASS, INERTIA, k["dG"], w, strict=True))
    hM = sum(mm * (v.conjugate() * a).real + ii * ww * aa
             for mm, ii, v, a, ww, aa in zip(MASS, INERTIA, k["dG"], k["ddG"], w, al, strict=True))
    V = G * sum(mm * p.imag for mm, p in zip(MASS, k["G"], strict=True))
    dV = G * sum(mm * v.imag for mm, v in zip(MASS, k["dG"], strict=True))
    return M, hM, V, dV


def rhs(_t: float, y: np.ndarray) -> list[float]:
    M, hM, _, dV = terms(y[0])
    return [y[1], -(hM * y[1] ** 2 + dV) / M]


def reduced(t: np.ndarray, th0: float, w0: float = 0.0, **kw) -> object:
    return solve_ivp(rhs, (0.0, float(t[-1])), [th0, w0], method="DOP853", rtol=1e-13,
                     atol=1e-13, t_eval=t, **kw)


def pin_forces(th: float, w: float) -> np.ndarray:
    """Planar Newton-Euler of the three bars at (th, th'): the forces of BASE on CRANK
    at A, CRANK on COUPLER at B, COUPLER on ROCKER at C, BASE on ROCKER at D
    (8 unknowns, 9 consistent equations; least squares)."""
    k = linkage(th)
    acc = rhs(0.0, np.array([th, w]))[1]
    aG = [dg * acc + ddg * w * w for dg, ddg in zip(k["dG"], k["ddG"], strict=True)]
    alpha = (acc, k["w2"] * acc + k["al2"] * w * w, k["w3"] * acc + k["al3"] * w * w)
    pins = (0j, k["B"], k["C"], complex(D_, 0))
    # bar i: (pin, sign) of the forces acting on it
    acts = ([(0, 1), (1, -1)], [(1, 1), (2, -1)], [(2, 1), (3, 1)])
    rows, rhs_ = [], []
    for i in range(3):
        g = k["G"][i]
        fx, fy, mz = np.zeros(8), np.zeros(8), np.zeros(8)
        for j, sgn in acts[i]:
            fx[2 * j], fy[2 * j + 1] = sgn, sgn
            r = pins[j] - g  # r x F = rx Fy - ry Fx
            mz[2 * j], mz[2 * j + 1] = -sgn * r.imag, sgn * r.real
        rows += [fx, fy, mz]
        rhs_ += [MASS[i] * aG[i].real, MASS[i] * (aG[i].imag + G), INERTIA[i] * alpha[i]]
    sol, *_ = np.linalg.lstsq(np.array(rows), np.array(rhs_), rcond=None)
    assert np.allclose(np.array(rows) @ sol, rhs_, atol=1e-9)  # consistent
    return sol.reshape(4, 2)


def test_dynamics_docs_run_and_are_right(monkeypatch, capsys, tmp_path) -> None:
    text = DOC.read_text()
    flat = squash(text.replace("`", ""))
    code = blocks(text)
    assert len(code) >= 8
    monkeypatch.chdir(tmp_path)
    ns: dict = {"__name__": "docs_dynamics"}
    for block in code:
        exec(compile(block, str(DOC), "exec"), ns)
    out = capsys.readouterr().out
    openimp = ns["openimp"]

    # --- section 2: the four-bar released at rest from the crank vertical
    res, crank = ns["res"], ns["crank"]
    t = res.time
    assert len(res) == 301 and res.complete and res.fgc[0] == ["B.theta"]
    np.testing.assert_allclose(t, np.arange(301) * 0.01, atol=1e-12)
    ref = reduced(t, math.pi / 2)
    err = np.abs(np.radians(crank) - ref.y[0])
    assert err.max() < 1e-7  # "to 1e-7 rad at every output"
    assert f"{np.degrees(ref.y[0, -1]):.4f} degrees" in flat
    # the energies against the reduction's
    TV = np.array([terms(th) for th in ref.y[0]])
    np.testing.assert_allclose(res.energy.kinetic, 0.5 * TV[:, 0] * ref.y[1] ** 2, atol=1e-6)
    np.testing.assert_allclose(res.energy.potential, TV[:, 2], atol=1e-6)
    # the invariants
    assert res.closure.max() < 1e-10
    rel = res.energy.relative.max()
    assert rel < 1e-8 and 1e-10 < abs(res.energy.balance[-1]) < 1e-8 * res.energy.scale
    assert res.coordinate_switches == [] and res.events == []
    assert f"{res.energy.balance[-1]:.0e}" == "4e-09" and f"{rel:.0e}" == "2e-09"
    # the stop: theta' = 0 after the trough, 11 degrees short of the crest
    stop = lambda _t, y: y[1]  # noqa: E731
    stop.direction = -1
    ev = solve_ivp(rhs, (0.0, 3.0), [math.pi / 2, 0.0], method="DOP853", rtol=1e-13,
                   atol=1e-13, events=stop)
    t_stop, th_stop = ev.t_events[0][0], ev.y_events[0][0, 0]
    assert f"stops at {np.degrees(th_stop):.2f} degrees, at t = {t_stop:.3f} s" in flat
    assert f"{crank.max():.3f} degrees at {res.time[crank.argmax()]:.2f} s" in flat
    assert abs(crank.max() - np.degrees(th_stop)) < 1e-3
    trough = minimize_scalar(lambda a: terms(a)[2], bracket=(4.3, 4.4, 4.5)).x
    crest = minimize_scalar(lambda a: -terms(a)[2], bracket=(1.3, 1.4, 1.5)).x
    assert f"least at {np.degrees(trough):.1f} degrees" in flat
    assert round(np.degrees(crest) + 360 - np.degrees(th_stop)) == 11
    assert "True ['B.theta']" in out

    # --- the forces of the motion: zero drive on the free coordinate, the pin loads
    f = ns["f"]
    assert np.abs(f.drive["B.theta"]).max() < 1e-10
    F = pin_forces(ref.y[0, -1], ref.y[1, -1])
    RA = f.reaction("A", "global")[-1]
    RD = f.reaction("D", "global")[-1]  # ROCKER on BASE: minus BASE on ROCKER
    np.testing.assert_allclose(RA[:2], F[0], atol=1e-5)
    np.testing.assert_allclose(-RD[:2], F[3], atol=1e-5)
    assert f"[{F[0, 0]:.4f} {F[0, 1]:.4f}] N" in flat
    assert np.array_equal(f.determinate("A")[-1], [True, True, False, False, False, True])

    # --- section 3: the rocker's rate at the start, the switch, the start from a sweep
    spun, level = ns["spun"], ns["level"]
    k0 = linkage(math.pi / 2)
    w0 = 3.0 / -k0["w3"]  # D.theta turns BASE against ROCKER: D' = -w3 theta'
    assert abs(spun.joint_velocity("A")[0, 0] - w0) < 1e-9
    assert f"[{w0:.5f}]" in flat and f"{w0:.5f} rad/s" in flat
    sref = reduced(spun.time, math.pi / 2, w0)
    assert np.abs(np.pi / 2 + spun.variable("A") - sref.y[0]).max() < 1e-7
    assert abs(spun.energy.relative).max() < 1e-8 and spun.closure.max() < 1e-10
    (sw,) = spun.coordinate_switches
    assert sw.old == ("D.theta",) and sw.new == ("B.theta",) and spun.fgc[-1] == ["B.theta"]
    assert f"t = {sw.time:.6g} s: free coordinates D.theta -> B.theta" in flat
    assert f"t = {sw.time:.4f} s" in flat
    th_sw = float(np.interp(sw.time, sref.t, sref.y[0]))
    assert f"from {k0['w3']:.3f} to {linkage(th_sw)['w3']:.3f}" in flat
    # the rocker reverses soon after (w3 = 0 within 0.1 s)
    assert linkage(float(np.interp(0.1, sref.t, sref.y[0])))["w3"] < 0 < linkage(th_sw)["w3"]
    lref = reduced(level.time, 0.0)
    assert abs(level.variable("A")[0] + math.pi / 2) < 1e-12
    assert np.abs(np.pi / 2 + level.variable("A") - lref.y[0]).max() < 1e-7
    assert f"{np.degrees(lref.y[0, -1]):.4f}: from along +x" in flat
    # Newton's reach from the drawing: 30 degrees yes, 45 no
    fourbar = ns["fourbar"]
    openimp.simulate(fourbar, 0.02, print_step=0.01, q0={"A": np.radians(-30)})
    with pytest.raises(openimp.InputError, match="cannot be assembled at the start"):
        openimp.simulate(fourbar, 0.02, print_step=0.01, q0={"A": np.radians(-45)})
    with pytest.raises(openimp.InputError, match="not independent"):
        openimp.simulate(fourbar, 0.02, print_step=0.01, rates={"A": 1.0, "B": 1.0})

    # --- section 4: the pendulum on the shaken cart
    swing, push, shake = ns["swing"], ns["push"], ns["shake"]
    l, mb, mc, amp, om = 0.5, 1.0, 5.0, 0.05, 3 * math.pi

    def cart_rhs(tt: float, y: np.ndarray) -> list[float]:
        xdd = -amp * om * om * math.sin(om * tt)
        return [y[1], -(G / l) * math.sin(y[0]) - xdd / l * math.cos(y[0])]

    cref = solve_ivp(cart_rhs, (0.0, 2.0), [0.3, 0.0], method="DOP853", rtol=1e-13,
                     atol=1e-13, t_eval=swing.time)
    th, w = cref.y
    assert swing.sgc == ["X.s"] and swing.fgc[0] == ["P.theta"]
    assert np.abs(swing.variable("P") - th).max() < 1e-10
    assert f"{th[-1]:.7f} rad at 2 s" in flat
    tt = swing.time
    _, xd, xdd = shake(tt)
    thdd = np.array([cart_rhs(a, b)[1] for a, b in zip(tt, cref.y.T, strict=True)])
    momentum_rate = (mc + mb) * xdd + mb * l * (thdd * np.cos(th) - w * w * np.sin(th))
    np.testing.assert_allclose(push, momentum_rate, atol=1e-7)
    bob_v2 = (xd + l * np.cos(th) * w) ** 2 + (l * np.sin(th) * w) ** 2
    energy = 0.5 * mc * xd**2 + 0.5 * mb * bob_v2 - mb * G * l * np.cos(th)
    gained = energy[-1] - energy[0]
    assert abs(swing.energy.drive_work[-1] - gained) < 2e-6
    assert f"{gained:.6f} J" in flat
    # the balance at rtol 1e-10 and with short steps (section 7)
    fine = ns["fine"]
    assert f"{swing.energy.relative.max():.0e} and {fine.energy.relative.max():.0e}" in flat
    assert fine.energy.relative.max() < 1e-11 < swing.energy.relative.max() < 1e-6
    assert np.abs(fine.variable("P") - th).max() < 1e-10

    # --- section 5: the methods on the four-bar (the table) and the stiff hinge
    ref_deg = np.degrees(ref.y[0, -1])
    table = {"plain": (120, 5), "res": (297, 5), "book": (398, 3), "tight": (2136, 3)}
    for name, (steps, digits) in table.items():
        r = ns[name]
        end = 90 + np.degrees(r.variable("A")[-1])
        row = f"| {steps} | {end:.{digits}f} | {r.energy.relative.max():.1e} |"
        assert r.integration.steps == steps and row in flat, (name, row)
    assert abs(90 + np.degrees(ns["plain"].variable("A")[-1]) - ref_deg) < 1e-5
    assert abs(90 + np.degrees(ns["book"].variable("A")[-1]) - ref_deg) > 1.0  # IMP's default
    assert abs(90 + np.degrees(ns["tight"].variable("A")[-1]) - ref_deg) < 0.05
    assert f"| | {ref_deg:.5f} | |" in flat
    stiff, hinge = ns["stiff"], ns["hinge"]
    assert f"{hinge.frequency[-1]:.0f} rad/s, {hinge.damping[-1]:.3f}" in flat
    rigid = np.degrees(reduced(np.array([0.0, 1.0]), math.pi / 2).y[0, -1])
    assert f"four-bar's is {rigid:.5f} degrees at 1 s" in flat
    runs = {}
    for line in out.splitlines():
        m_ = re.match(r"(rk|book) (1e-0\d) \['B.theta', 'E.theta'\] (\d+) ([\d.]+)$", line)
        if m_:
            runs[(m_[1], m_[2])] = (int(m_[3]), float(m_[4]))
            assert f"# {line[:-len(m_[4])]}{float(m_[4]):.5f}" in text
    assert set(runs) == {("rk", "1e-08"), ("rk", "1e-06"), ("book", "1e-08")}
    assert runs[("book", "1e-08")][0] == 100  # one step per output
    assert runs[("rk", "1e-06")][0] > 0.9 * runs[("rk", "1e-08")][0] > 40 * 100
    assert abs(runs[("rk", "1e-08")][1] - rigid) < 1e-4
    assert 1e-4 < abs(runs[("book", "1e-08")][1] - rigid) < 1e-3
    assert stiff.nq == 5

    # --- section 8: the block on the buffer
    bounce, h, k, mm = ns["bounce"], 0.5, 2.0e4, 2.0
    om = math.sqrt(k / mm)
    t1, v1 = math.sqrt(2 * h / G), math.sqrt(2 * G * h)
    tau = 2 * (math.pi - math.atan(v1 * om / G)) / om
    times = [t1, t1 + tau, 3 * t1 + tau]
    assert [e.direction for e in bounce.events] == [1, -1, 1]
    assert all(e.name == "S" for e in bounce.events)
    np.testing.assert_allclose([e.time for e in bounce.events], times, atol=1e-7)
    for tk in times:
        assert f"{tk:.7f} S" in text
    assert f"t1 = sqrt(2 h / g) = {t1:.7f}" in flat and f"{tau:.7f} s" in flat
    assert f"omega = sqrt(k / m) = {om:.0f} rad/s" in flat
    u = np.minimum(bounce.variable("S") + h, 0.0)
    np.testing.assert_allclose(bounce.energy.load_work, -0.5 * k * u**2, atol=1e-4)
    assert bounce.integration.events == 3
    assert f"{bounce.energy.relative.max():.0e} of {bounce.energy.scale:.1f} J" in text

    # --- section 9: the stream file and keep=False
    long, rows, head, balance = ns["long"], ns["rows"], ns["head"], ns["balance"]
    assert len(long) == 2 and list(long.time) == [0.0, 60.0] and rows.shape == (6001, 20)
    assert head[:5] == ["time", "A.theta", "B.theta", "C.theta", "D.theta"]
    assert head[-7:] == ["kinetic", "potential", "drive work", "load work", "dissipated",
                         "closure", "quality"]
    np.testing.assert_allclose(rows[-1, 1:5], long.q[-1], atol=1e-12)
    assert not (tmp_path / "fourbar.csv.part").exists()
    assert f"about {np.abs(balance).max():.0e} J over a minute" in flat
    assert abs(long.energy.balance[-1] - balance[-1]) < 1e-12
    assert f"about {balance[-1]:.0e} J, at 60 s" in flat
    scale = max(np.abs(col).max() for col in (rows[:, 13], rows[:, 14] - rows[0, 14],
                                               rows[:, 15], rows[:, 16], rows[:, 17]))
    assert np.abs(balance).max() < 1e-6 * scale and scale > 60.0  # the trough's 60.9 J
    assert "of 60 s" in out

    # --- section 10: the rocker driven to its limit of travel; the massless arm
    forced = ns["forced"]
    phi30 = math.atan2(linkage(math.pi / 2)["C"].imag, linkage(math.pi / 2)["C"].real - D_)

    def reach(p: float) -> float:  # |AC| - (a + b): crank and coupler in line
        return abs(D_ + C_ * complex(math.cos(p), math.sin(p))) - (A_ + B_)

    t_lim = (phi30 - brentq(reach, phi30 - 0.5, phi30)) / 2.0  # the rocker turns at -2 rad/s
    assert not forced.complete and len(forced) == 10 and forced.time[-1] == pytest.approx(0.09)
    assert forced.message.startswith(f"t = {t_lim:.6g} s: the loops cannot be closed")
    assert f"at t = {t_lim:.7f} s (by hand" in flat
    assert "t = 0 s: the mass matrix of the free coordinates is singular" in out


def test_dynamics_docs_examples_name_existing_decks() -> None:
    text = DOC.read_text()
    for name in re.findall(r"`?examples/([a-z_]+\.imp)`?", text):
        assert (ROOT / "examples" / name).is_file(), name


def test_python_docs_time_response_snippet_runs(tmp_path, monkeypatch) -> None:
    """docs/python.md section 5: its indented snippet runs on the model of its first block
    (the page's ```python blocks are run by tests/test_python_docs.py), the four-bar of
    point masses falls with its loops closed and its energy kept."""
    text = (ROOT / "docs" / "python.md").read_text()
    first = blocks(text)[0]
    section = text.split("## 5. Let it move")[1].split("## 6.")[0]
    snippet = "\n".join(line[4:] for line in section.splitlines() if line.startswith("    "))
    assert "openimp.simulate" in snippet
    monkeypatch.chdir(tmp_path)
    ns: dict = {"__name__": "docs_python"}
    exec(compile(first, "docs/python.md", "exec"), ns)
    exec(compile(snippet, "docs/python.md", "exec"), ns)
    res = ns["res"]
    assert res.complete and len(res) == 101 and res.time[-1] == 2.0
    assert res.closure.max() < 1e-10 and res.energy.relative.max() < 1e-6
    # at rest at the start, then moving: the potential energy it lost went into motion
    assert res.energy.kinetic[0] == 0.0 and res.energy.kinetic.max() > 0.0
    ke = res.energy.kinetic
    lost = res.energy.potential[0] - res.energy.potential
    np.testing.assert_allclose(ke, lost, atol=1e-6 * res.energy.scale)
