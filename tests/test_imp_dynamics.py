"""IMP dynamic mode (FIND DYNAMICS): the mode rules, DATA TIME / IC / MOTION, the ZERO
statements of the integrator, listings and JSON, failures, DELETE DYNAMICS, and the
example decks run end to end (reference imp-language.md §1.2, §2.2, §8.6, §10, §13;
book ch 14).

The references are written here in plain numpy and scipy from the numbers in
the decks, never from openimp:

* examples/fourbar_released.imp: Lagrange's equation of the four-bar in its crank
  angle, I(a) a'' + I'(a) a'^2 / 2 + V'(a) + c a' = 0, with I(a) and V(a) from a
  circle-intersection position solution and central differences, integrated by
  scipy; and the energy audit's balance;
* examples/engine_runup.imp: friction-free, the torque's work is the kinetic
  energy, so the crank speed is sqrt(2 tau (a - a0) / I(a)) with I(a) the
  slider-crank's inertia referred to the crank;
* examples/quarter_car_bump.imp: the linear two-mass quarter car (its springs act
  along Y only, so it is linear at any amplitude) integrated by scipy, and the
  static sag at the end;
* a compound pendulum (inline): its equation of motion for DATA IC given as
  numbers and as VALUEs, and the pivot load at release by Newton's law
  (dynamic-mode convention: the second-named link's load on the first).
"""

from __future__ import annotations

import json
import math
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.interpolate import CubicSpline

from helpers.decks import cpu_limit, line_of, run_deck, write
from openimp.imp.deck import load
from openimp.imp.interp import DeckError

ROOT = Path(__file__).parent.parent
EXAMPLES = ROOT / "examples"
G = 9.80665


# =============================================================================
# helpers
# =============================================================================
def errors_of(path: Path) -> list[tuple[int, str]]:
    """(line, message) of every input error of a deck read strictly (a statement IMP
    passed over is an error too: test_imp_tolerance has the default)."""
    with pytest.raises(DeckError) as info:
        load(path, strict=True)
    return [(e.where[1], str(e)) for e in info.value.errors]


def cli(*args: str | Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "openimp.cli", *map(str, args)],
                          capture_output=True, text=True, preexec_fn=cpu_limit,
                          env={**__import__("os").environ, "MPLBACKEND": "Agg"})


def column(run, request: str, item: str, col: str) -> np.ndarray:
    t = run.table(request, item)
    return np.asarray(t.rows)[:, t.columns.index(col)]


def deck_number(text: str, statement: str, k: int = 0) -> float:
    """The k-th number after ``statement =`` in a deck."""
    rest = text.split(statement, 1)[1].split("=", 1)[1].splitlines()[0]
    return float(re.split(r"[,;\s]+", rest.strip())[k])


# =============================================================================
# a compound pendulum (inline): SI units, a uniform bar 0.5 m, 2 kg, pinned at A
# =============================================================================
PEND_L, PEND_M, PEND_IA = 0.5, 2.0, 0.1666667  # inertia about A as the deck gives it
PEND = f"""TITLE = PENDULUM
UNIT (MASS) = 1
ZPIN (BASE, ARM) = A
DATA ZPIN (A) = 0,0,0; 1,0,0; 1,0,0
POINT (ARM) = PIV, TIP
DATA POINT (PIV, ABS) = 0, 0, 0
DATA POINT (TIP, ABS) = {PEND_L}, 0, 0
DATA MASS (ARM, A) = {PEND_M}; {PEND_L / 2}, 0, 0
DATA INERTIA (ARM, A) = 0, {PEND_IA}, {PEND_IA}, 0, 0, 0
DATA GRAVITY = 0, -{G}, 0
ZERO (FORCE) = 0.0001, 0.01
"""


def pendulum(theta0: float, rate0: float, times: np.ndarray) -> np.ndarray:
    """The pin angle (rad) of the pendulum: I_A a'' = -m g (L/2) cos a (a from +X)."""
    def rhs(_t: float, y: np.ndarray) -> list[float]:
        return [y[1], -PEND_M * G * PEND_L / 2 * math.cos(y[0]) / PEND_IA]

    s = solve_ivp(rhs, (times[0], times[-1]), [theta0, rate0], t_eval=times, rtol=1e-11,
                  atol=1e-12)
    return s.y[0]


@pytest.mark.parametrize("ic", ["-60, 1.5", "P0, W0"], ids=["numbers", "values"])
def test_pendulum_ic_in_degrees_or_value_radians(tmp_path, ic) -> None:
    """DATA IC positions in degrees (a VALUE in radians) and rates in rad/s; the
    swing against the pendulum's equation of motion."""
    p = write(tmp_path, PEND + "VALUE (P0) = 0 - PI / 3\nVALUE (W0) = 1.5\nFIND DYNAMICS\n"
              f"DATA IC (A) = {ic}\nDATA TIME = 1.0, 0, 0.05\nLIST POSITION (A)\n"
              "LIST VELOCITY (A)\nEXECUTE\nEND\n")
    runs, _ = run_deck(p)
    run = runs[0]
    assert run.mode == "dynamic" and not run.failure, run.failure
    t = column(run, "LIST POSITION", "joint A", "Time")
    np.testing.assert_allclose(t, np.arange(21) * 0.05, atol=1e-12)
    a = column(run, "LIST POSITION", "joint A", "JVar 1")
    w = column(run, "LIST VELOCITY", "joint A", "JVar 1")
    assert a[0] == pytest.approx(-60.0, abs=1e-9) and w[0] == pytest.approx(1.5, abs=1e-9)
    ref = np.degrees(pendulum(-math.pi / 3, 1.5, t))
    assert np.max(np.abs(a - ref)) < 0.02


def test_value_load_reads_the_posture_while_integrating(tmp_path) -> None:
    """A joint torque given by a VALUE that reads POSITION(A, 1) (radians) acts at every
    instant of the integration: a torsion spring of 3 N m/rad at the pin."""
    k = 3.0
    # the book's step does not see a law's stiffness in its linearization: a tight
    # ZERO (FORCE) takes ~10^5 steps here, so this deck is looser (0.01 N, 0.1 %)
    deck = PEND.replace("ZERO (FORCE) = 0.0001, 0.01", "ZERO (FORCE) = 0.01, 0.1")
    p = write(tmp_path, deck + f"VALUE (TQ) = 0 - {k} * POSITION(A, 1)\nDATA TORQUE (A) = TQ\n"
              "FIND DYNAMICS\nDATA TIME = 1.0, 0, 0.05\nLIST POSITION (A)\nEXECUTE\nEND\n")
    run = run_deck(p)[0][0]
    assert not run.failure and not any("undefined" in m for m in run.messages), run.messages
    t = column(run, "LIST POSITION", "joint A", "Time")

    def rhs(_t: float, y: np.ndarray) -> list[float]:
        return [y[1], (-PEND_M * G * PEND_L / 2 * math.cos(y[0]) - k * y[0]) / PEND_IA]

    ref = solve_ivp(rhs, (0.0, 1.0), [0.0, 0.0], t_eval=t, rtol=1e-11, atol=1e-12).y[0]
    a = column(run, "LIST POSITION", "joint A", "JVar 1")
    assert np.max(np.abs(a - np.degrees(ref))) < 0.2
    free = np.degrees(pendulum(0.0, 0.0, t))  # without the spring it swings far lower
    assert np.max(np.abs(a - free)) > 20


@pytest.mark.parametrize("print_step", ["0.1", "1E100"])
def test_data_time_final_zero_lists_the_start(tmp_path, print_step) -> None:
    """DATA TIME = 0, 0, step: the start alone, from a short run (dynamic.SINGLE_SPAN):
    a print step of 1E100 (a fuzzed deck) is not integrated over 1e100 s."""
    p = write(tmp_path, PEND + "FIND DYNAMICS\nDATA IC (A) = 10, 0\n"
              f"DATA TIME = 0, 0, {print_step}\nLIST POSITION (A)\nPRINT HEADING\nEXECUTE\nEND\n")
    run = run_deck(p)[0][0]
    assert not run.failure, run.failure
    rows = np.asarray(run.table("LIST POSITION", "joint A").rows)
    np.testing.assert_allclose(rows, [[0.0, 10.0]], atol=1e-9)
    assert len(run.table("PRINT HEADING", "energy").rows) == 1


def test_pendulum_pivot_load_at_release_is_the_dynamic_convention(tmp_path) -> None:
    """Released horizontal at rest: the bar's load on BASE (the second-named link on
    the first, on BASE's axes) is -(m g + m alpha L/2) along Y, alpha = -m g (L/2) / I_A."""
    p = write(tmp_path, PEND + "FIND DYNAMICS\nDATA TIME = 0.1, 0, 0.05\nLIST FORCE (A)\n"
              "EXECUTE\nEND\n")
    run = run_deck(p)[0][0]
    alpha = -PEND_M * G * (PEND_L / 2) / PEND_IA
    fy = column(run, "LIST FORCE", "joint A", "FY")[0]
    fx = column(run, "LIST FORCE", "joint A", "FX")[0]
    mz = column(run, "LIST FORCE", "joint A", "MZ")[0]
    assert fy == pytest.approx(-(PEND_M * G + PEND_M * alpha * PEND_L / 2), rel=1e-6)
    assert abs(fx) < 1e-9 and abs(mz) < 1e-6  # a free pin carries no drive


# =============================================================================
# the example decks
# =============================================================================
def _fourbar_reference(text: str, times: np.ndarray) -> np.ndarray:
    """The crank angle (rad) of examples/fourbar_released.imp by Lagrange's equation in
    the crank angle (the deck's numbers: links along A(0,0) B(0.1,0) C(0.3,0.3) D(0.4,0))."""
    L1, L2, L3 = 0.1, math.hypot(0.2, 0.3), math.hypot(0.1, 0.3)
    D = np.array([0.4, 0.0])
    m = np.array([deck_number(text, f"DATA MASS ({k}") for k in ("CRANK", "COUPLER",
                                                                  "ROCKER")])
    dc = np.array([deck_number(text, f"DATA MASS ({k}", 1) for k in ("CRANK", "COUPLER",
                                                                      "ROCKER")])
    Io = np.array([deck_number(text, f"DATA INERTIA ({k}", 2) for k in ("CRANK", "COUPLER",
                                                                         "ROCKER")])
    Ic = Io - m * dc**2  # about the centres
    c = deck_number(text, "DATA DAMPER (A)")
    a0 = math.radians(deck_number(text, "DATA IC (A)"))

    def pose(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Mass centres (3, n, 2) and link angles (3, n) at crank angles ``a`` (n,)."""
        B = L1 * np.stack([np.cos(a), np.sin(a)], axis=-1)
        e = D - B
        d = np.hypot(e[:, 0], e[:, 1])[:, None]
        x = (d * d + L2 * L2 - L3 * L3) / (2 * d)
        C = B + x * e / d + np.sqrt(L2 * L2 - x * x) * np.stack([-e[:, 1], e[:, 0]], -1) / d
        ang = np.stack([a, np.arctan2(*(C - B).T[::-1]), np.arctan2(*(D - C).T[::-1])])
        cen = np.stack([B / 2, B + dc[1] * (C - B) / L2, C + dc[2] * (D - C) / L3])
        return cen, ang

    # I(a) and V(a) over one turn by central differences, then periodic splines of I,
    # I' and V' (the crank turns fully: a crank-rocker)
    grid = np.linspace(0.0, 2 * math.pi, 4097)
    h = 1e-6
    (c1, t1), (c0, t0) = pose(grid + h), pose(grid - h)
    dang = np.angle(np.exp(1j * (t1 - t0))) / (2 * h)
    inertia = (np.sum(m[:, None] * np.sum(((c1 - c0) / (2 * h)) ** 2, axis=2), axis=0)
               + np.sum(Ic[:, None] * dang**2, axis=0))
    potential = G * np.sum(m[:, None] * pose(grid)[0][:, :, 1], axis=0)
    inertia[-1], potential[-1] = inertia[0], potential[0]  # the same posture, rounded
    I_of = CubicSpline(grid, inertia, bc_type="periodic")
    V_of = CubicSpline(grid, potential, bc_type="periodic")
    dI, dV = I_of.derivative(), V_of.derivative()

    def rhs(_t: float, y: np.ndarray) -> list[float]:
        a, w = y
        return [w, float(-0.5 * dI(a) * w * w - dV(a) - c * w) / float(I_of(a))]

    assert np.allclose(pose(np.zeros(1))[0][2, 0], [0.35, 0.15])  # the drawn branch: C above
    s = solve_ivp(rhs, (times[0], times[-1]), [a0, 0.0], t_eval=times, rtol=1e-10,
                  atol=1e-12)
    return s.y[0]


def test_fourbar_released_against_lagrange_and_energy_balance() -> None:
    path = EXAMPLES / "fourbar_released.imp"
    runs, echo = run_deck(path)
    run = runs[0]
    assert run.mode == "dynamic" and not run.failure and not run.unsupported, run.failure
    t = column(run, "LIST POSITION", "joint A", "Time")
    a = column(run, "LIST POSITION", "joint A", "JVar 1")
    ref = np.degrees(_fourbar_reference(path.read_text(), t))
    assert np.ptp(ref) > 100  # it swings through a large angle
    assert np.max(np.abs(a - ref)) < 0.02  # degrees
    # the energy audit (PRINT HEADING): the balance is ~0, the damper takes energy out
    e = run.table("PRINT HEADING", "energy")
    assert e.columns == ["Time", "Kinetic", "Potential", "Drive work", "Load work",
                         "Dissipated", "Balance"]
    rows = np.asarray(e.rows)
    v0 = rows[0, 2]
    assert np.max(np.abs(rows[:, 6])) < 1e-4 * v0
    assert np.all(np.diff(rows[:, 5]) >= -1e-12) and rows[-1, 5] > 0.1
    np.testing.assert_allclose(rows[:, 1] + rows[:, 2] - v0 + rows[:, 5] - rows[:, 4]
                               - rows[:, 3], rows[:, 6], atol=1e-9)
    # the listing: banner, time lines, the FGC integrated, the energy line, statistics
    assert any(ln.strip() == "Dynamic Mode" for ln in [s.strip("* ") for s in echo])
    assert "time = 0.050000" in echo
    assert "A 1 imp 30.0000 0.000" in " ".join(echo)
    assert any(ln.startswith("Energy (force x length): kinetic 0, potential 3.6") for ln in echo)
    assert any(ln.startswith("Integration (book): ") for ln in echo)
    stats = run.table("PRINT HEADING", "integration")
    assert stats.columns[0] == "Time" and np.asarray(stats.rows)[0, 0] == pytest.approx(2.0)


def _slider_crank_inertia(a: np.ndarray, text: str) -> np.ndarray:
    """The inertia of examples/engine_runup.imp referred to the crank at angles ``a``."""
    r, l = 0.05, 0.2
    Icr = deck_number(text, "DATA INERTIA (CRANK, A)", 2)
    mr = deck_number(text, "DATA MASS (ROD, B)")
    Irc = deck_number(text, "DATA INERTIA (ROD, B)", 2) - mr * (l / 2) ** 2
    mp = deck_number(text, "DATA MASS (PISTON, C)")

    def pose(x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        B = np.stack([r * np.cos(x), r * np.sin(x)], axis=-1)
        xp = r * np.cos(x) + np.sqrt(l * l - (r * np.sin(x)) ** 2)
        C = np.stack([xp, np.zeros_like(x)], axis=-1)
        beta = np.arctan2(C[:, 1] - B[:, 1], C[:, 0] - B[:, 0])
        return (B + C) / 2, beta, xp

    h = 1e-7
    (c1, b1, x1), (c0, b0, x0) = pose(a + h), pose(a - h)
    return (Icr + mr * np.sum(((c1 - c0) / (2 * h)) ** 2, axis=1)
            + Irc * ((b1 - b0) / (2 * h)) ** 2 + mp * ((x1 - x0) / (2 * h)) ** 2)


def test_engine_runup_crank_speed_is_the_torque_work() -> None:
    path = EXAMPLES / "engine_runup.imp"
    text = path.read_text()
    run = run_deck(path)[0][0]
    assert not run.failure, run.failure
    tau = deck_number(text, "DATA TORQUE (A)")
    a = np.radians(column(run, "LIST POSITION", "joint A", "JVar 1"))
    w = column(run, "LIST VELOCITY", "joint A", "JVar 1")
    ref = np.sqrt(2 * tau * (a - a[0]) / _slider_crank_inertia(a, text))
    assert w[-1] > 50 and np.max(np.abs(w - ref)) < 1e-3 * w[-1]
    e = np.asarray(run.table("PRINT HEADING", "energy").rows)
    # the load work (integrated with the motion) is tau (a - a0)
    np.testing.assert_allclose(e[:, 4], tau * (a - a[0]), rtol=1e-5, atol=1e-9)
    np.testing.assert_allclose(e[:, 1], e[:, 4], rtol=1e-4, atol=1e-6)  # kinetic = work


def test_quarter_car_bump_against_the_linear_model_and_the_sag() -> None:
    path = EXAMPLES / "quarter_car_bump.imp"
    text = path.read_text()
    run = run_deck(path)[0][0]
    assert not run.failure, run.failure
    mw = deck_number(text, "DATA MASS (WHEEL, LINK)")
    mb = deck_number(text, "DATA MASS (BODY, LINK)")
    kt, lt = deck_number(text, "DATA SPRING (TYRE)"), deck_number(text, "DATA SPRING (TYRE)", 1)
    k, lc = deck_number(text, "DATA SPRING (COIL)"), deck_number(text, "DATA SPRING (COIL)", 1)
    c = deck_number(text, "DATA DAMPER (SHOCK)")

    def road(t: float) -> float:
        return 0.025 * (1 - math.cos(20 * math.pi * (t - 1))) if 1 < t < 1.1 else 0.0

    def rhs(t: float, y: np.ndarray) -> list[float]:
        w, b, wd, bd = y  # displacements from where they are drawn (0.3, 0.8)
        ft = kt * (0.3 + w - road(t) - lt)  # tension
        fc = k * (0.5 + b - w - lc) + c * (bd - wd)
        return [wd, bd, (fc - ft) / mw - G, -fc / mb - G]

    t = column(run, "LIST POSITION", "joint W", "Time")
    s = solve_ivp(rhs, (0.0, t[-1]), [0, 0, 0, 0], t_eval=t, rtol=1e-10, atol=1e-12,
                  max_step=1e-3)
    w = column(run, "LIST POSITION", "joint W", "JVar 1")
    b = column(run, "LIST POSITION", "joint B", "JVar 1")
    assert np.max(np.abs(s.y[1])) > 0.01  # the bump moves the body by centimetres
    assert np.max(np.abs(w - s.y[0])) < 1e-6 and np.max(np.abs(b - s.y[1])) < 1e-6
    # settled at the static sag of the deck's comment
    sag_w = lt - (mb + mw) * G / kt - 0.3
    sag_b = 0.3 + sag_w + lc - mb * G / k - 0.8
    assert w[-1] == pytest.approx(sag_w, abs=2e-5) and b[-1] == pytest.approx(sag_b, abs=2e-4)
    # the tyre force (tension positive) against its length
    ft = column(run, "LIST FORCE", "spring TYRE", "Force")
    np.testing.assert_allclose(ft, kt * (0.3 + w - [road(x) for x in t] - lt), atol=1e-6)


TWO_RATE = """TITLE = MASS ON A SPRING AND A TWO-RATE DAMPER
UNIT (MASS) = 1
XSLIDE (BASE, MASS) = J
DATA XSLIDE (J) = 0, 0, 0
POINT (BASE) = P0
POINT (MASS) = PM
DATA POINT (P0, ABS) = -1, 0, 0
DATA POINT (PM, ABS) = 0, 0, 0
DATA MASS (MASS, LINK) = 2; 0, 0, 0
SPRING (P0, PM) = S
DATA SPRING (S) = 200, 0.9
DAMPER (P0, PM) = D
VALUE (CDIR) = VELOCITY(D,1)
VALUE (CD) = IF(CDIR:3,3,8)
DATA DAMPER (D) = CD
REMARK OPENIMP INTEGRATOR = RK, 1E-10
FIND DYNAMICS
DATA TIME = 2.0, 0, 0.01
LIST POSITION (J)
LIST FORCE (D)
EXECUTE
END
"""


def test_a_damper_rate_that_reads_the_dampers_velocity(tmp_path) -> None:
    """IMP's idiom of a shock absorber stiffer in extension (manual ch 9 example 4):
    DATA DAMPER (D) = CD, VALUE (CD) = IF(VELOCITY(D,1):3,3,8), the damper's DX rate.
    A 2 kg mass on a slider, a spring of 200 N/m stretched 0.1 m at the start: against
    scipy on m x'' = -k (1 + x - 0.9) - c(x') x' with c = 3 for x' <= 0, else 8, the
    switch located by scipy's event.  Before, VELOCITY of a damper was undefined while
    integrating (0: c = 3 throughout, silently).  The deck asks for Dormand-Prince by
    REMARK OPENIMP INTEGRATOR = RK, 1E-10 (ZERO (FORCE) is not used)."""
    runs, echo = run_deck(write(tmp_path, TWO_RATE, "two_rate.imp"))
    run = runs[0]
    assert not run.failure, run.failure
    assert not any("undefined" in ln for ln in echo), [ln for ln in echo if "undefined" in ln]
    t = column(run, "LIST POSITION", "joint J", "Time")
    x = column(run, "LIST POSITION", "joint J", "JVar 1")
    m, k = 2.0, 200.0

    def reference(c_of) -> np.ndarray:
        def rhs(_t, y):
            return [y[1], (-k * (0.1 + y[0]) - c_of(y[1]) * y[1]) / m]

        def turn(_t, y):
            return y[1]

        out, t0, y0 = [], 0.0, [0.0, 0.0]
        while t0 < t[-1]:
            s = solve_ivp(rhs, (t0, t[-1]), y0, method="DOP853", rtol=1e-12, atol=1e-14,
                          events=turn, dense_output=True)
            ev = s.t_events[0]
            t1 = float(ev[ev > t0 + 1e-9][0]) if np.any(ev > t0 + 1e-9) else t[-1]
            seg = (t >= t0) & (t <= t1)
            out.append((seg, s.sol(t[seg])[0]))
            y0 = list(s.sol(t1))
            t0 = t1
            if t1 >= t[-1]:
                break
        xs = np.zeros_like(t)
        for seg, vals in out:
            xs[seg] = vals
        return xs

    two = reference(lambda v: 3.0 if v <= 0 else 8.0)
    one = reference(lambda v: 3.0)
    assert np.max(np.abs(two - one)) > 1e-3  # the second rate matters
    np.testing.assert_allclose(x, two, rtol=0, atol=1e-7)


@pytest.mark.parametrize("directive, error", [
    ("REMARK OPENIMP INTEGRATOR = RK, 0", "rtol must be a number from 1E-14 to 0.1"),
    ("REMARK OPENIMP INTEGRATOR = RK, X", "rtol must be a number from 1E-14 to 0.1"),
    ("REMARK OPENIMP INTEGRATOR = EULER", "give BOOK (IMP's step and ZERO (FORCE)) or RK"),
])
def test_integrator_directive_errors_are_located(tmp_path, directive, error) -> None:
    text = TWO_RATE.replace("REMARK OPENIMP INTEGRATOR = RK, 1E-10", directive)
    p = write(tmp_path, text, "bad.imp")
    with pytest.raises(DeckError) as exc:
        load(p)
    assert f"bad.imp:{line_of(text, directive)}:" in str(exc.value) and error in str(exc.value)


def test_integrator_directive_rk_then_book(tmp_path) -> None:
    """RK notes that ZERO (FORCE) is not used; BOOK returns to IMP's step (no such note:
    its force error test reads ZERO (FORCE))."""
    text = TWO_RATE.replace("FIND DYNAMICS\n", "FIND DYNAMICS\nZERO (FORCE) = 0.01, 0.1\n")
    text = text.replace("EXECUTE\nEND\n", "EXECUTE\nREMARK OPENIMP INTEGRATOR = BOOK\n"
                        "EXECUTE\nEND\n")
    runs, _echo = run_deck(write(tmp_path, text, "both.imp"))
    assert len(runs) == 2 and not runs[0].failure and not runs[1].failure
    assert any("ZERO (FORCE) = 0.01, 0.1 is not used" in m for m in runs[0].messages)
    assert not any("ZERO (FORCE)" in m for m in runs[1].messages)
    x0 = column(runs[0], "LIST POSITION", "joint J", "JVar 1")
    x1 = column(runs[1], "LIST POSITION", "joint J", "JVar 1")
    # two integrators, one motion: the book's step is exact for this piecewise-linear
    # motion once its switches are located (5e-11 measured)
    assert np.max(np.abs(x0 - x1)) < 1e-8


@pytest.mark.parametrize("name", ["fourbar_released", "engine_runup", "quarter_car_bump"])
def test_examples_run_from_the_command_line(tmp_path, name) -> None:
    """``openimp run examples/X.imp`` exits 0; the JSON holds the dynamic run."""
    js = tmp_path / "o.json"
    p = cli("run", EXAMPLES / f"{name}.imp", "--json", js)
    assert p.returncode == 0, p.stderr
    assert "Traceback" not in p.stderr
    assert "Dynamic Mode" in p.stdout
    run = json.loads(js.read_text())["runs"][0]
    assert run["mode"] == "dynamic" and "failure" not in run


# =============================================================================
# mode rules and messages
# =============================================================================
FOUR = PEND  # any model will do for the statement rules


@pytest.mark.parametrize(("tail", "bad", "words"), [
    ("DATA POSITION (A) = 0, 10, 3\nFIND DYNAMICS\n", "FIND DYNAMICS", "after DATA POSITION"),
    ("DATA IC (A) = 10, 0\nFIND DYNAMICS\n", "DATA IC", "needs FIND DYNAMICS first"),
    ("FIND DYNAMICS\nZERO (FORCE) = 0, 1\n", "ZERO (FORCE)", "both limits must be positive"),
    ("FIND DYNAMICS\nZERO (FORCE) = 0.1, -1\n", "ZERO (FORCE)", "both limits must be positive"),
    ("FIND DYNAMICS\nDATA POSITION (A) = 0\n", "DATA POSITION", "not allowed after FIND "
     "DYNAMICS"),
    ("FIND DYNAMICS\nDATA VELOCITY (A) = 1\n", "DATA VELOCITY", "not allowed after FIND "
     "DYNAMICS"),
    ("DELETE DYNAMICS\n", "DELETE DYNAMICS", "no FIND DYNAMICS to cancel"),
    ("FIND EQUILIB\nFIND DYNAMICS\n", "FIND DYNAMICS", "after FIND EQUILIB"),
    ("FIND DYNAMICS\nDATA IC (A) = 10, 0; 20, 0\n", "DATA IC", "has 1 variable(s) but 2"),
])
def test_mode_rules_refused_at_their_statement(tmp_path, tail, bad, words) -> None:
    text = FOUR + tail + "DATA TIME = 1, 0, 0.1\nEXECUTE\nEND\n"
    errs = errors_of(write(tmp_path, text))
    line = len(FOUR.splitlines()) + [ln.startswith(bad) for ln in tail.splitlines()].index(True)
    assert any(n == line + 1 and words in m for n, m in errs), errs


def test_data_time_missing_names_the_execute_and_exits_2(tmp_path) -> None:
    text = FOUR + "FIND DYNAMICS\nLIST POSITION (A)\nEXECUTE\nEND\n"
    p = write(tmp_path, text)
    r = cli("run", p)
    assert r.returncode == 2 and "Traceback" not in r.stderr
    n = line_of(text, "EXECUTE")
    assert f"{p}:{n}: EXECUTE statement: EXECUTE in dynamic mode (FIND DYNAMICS at {p}:" \
           f"{line_of(text, 'FIND DYNAMICS')}) needs DATA TIME" in r.stderr


def test_ic_and_motion_checked_against_the_model(tmp_path) -> None:
    # more pairs than variables (FLAT's polar variables take ICs: test_imp_ball_loads)
    flat = ("ZPIN (BASE, ARM) = A\nFLAT (ARM, BOB) = F\nFIND DYNAMICS\n"
            "DATA IC (A) = 10, 0; 5, 0\nDATA TIME = 1, 0, 0.1\nEXECUTE\nEND\n")
    errs = errors_of(write(tmp_path, flat, "s.imp"))
    assert any(n == 4 and "has 1 variable(s) but 2 position, velocity pairs" in m
               for n, m in errs), errs
    text = FOUR + "FIND DYNAMICS\nDATA IC (A) = P0, 0\nDATA TIME = 1, 0, 0.1\nEXECUTE\nEND\n"
    p = write(tmp_path, text)
    r = cli("run", p)
    assert r.returncode == 2 and f"{p}:{line_of(text, 'DATA IC')}: DATA IC statement: VALUE " \
                                 "P0 is not defined by EXECUTE" in r.stderr
    text = (FOUR + "YSLIDE (BASE, CAR) = Y\nVALUE (V) = POSITION(A, 1)\nFIND DYNAMICS\n"
            "DATA MOTION (Y) = V\nDATA TIME = 1, 0, 0.1\nEXECUTE\nEND\n")
    p = write(tmp_path, text, "m.imp")
    r = cli("check", p)
    assert r.returncode == 2, r.stderr
    assert f"{p}:{line_of(text, 'DATA MOTION')}: DATA MOTION statement: VALUE V of joint Y " \
           "reads the model" in r.stderr


# =============================================================================
# DATA IC of a ball: IMP's Cardan angles and their rates
# =============================================================================
BALL = """TITLE = BALL IC
UNIT (MASS) = 1
{keyword} (BASE, BOB) = S
DATA LINK (BASE, S) = 0,0,0; 1,0,0; 0,1,0
DATA LINK (BOB, S) = 0,0,0; 1,0,0; 0,1,0
POINT (BOB) = P1, P2
DATA POINT (P1, ABS) = 0.1, 0, 0.3
DATA POINT (P2, ABS) = 0, 0.2, 0.1
DATA MASS (BOB, LINK) = 2.0; 0.05, 0.1, 0.3
DATA INERTIA (BOB, LINK) = 0.21, 0.195, 0.035, 0.01, 0.03, 0.06
DATA GRAVITY = 0, 0, -9.80665
FIND DYNAMICS
DATA IC (S) = {ic}
DATA TIME = 0.01, 0, 0.005
LIST POSITION (S, P1, P2)
LIST VELOCITY (S, P1, P2)
EXECUTE
END
"""
#: the columns u, v, w of both joint frames at the drawing, in global axes (w along X,
#: u along Y: DATA LINK above)
BALL_F = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
BALL_P = {"P1": np.array([0.1, 0.0, 0.3]), "P2": np.array([0.0, 0.2, 0.1])}


def _turn(axis: int, a: float) -> np.ndarray:
    """The rotation by ``a`` about coordinate axis ``axis`` (0, 1, 2: x, y, z)."""
    c, s = math.cos(a), math.sin(a)
    i, j = (axis + 1) % 3, (axis + 2) % 3
    R = np.eye(3)
    R[i, i], R[i, j], R[j, i], R[j, j] = c, -s, s, c
    return R


@pytest.mark.parametrize(("keyword", "ic", "ang", "rate", "shift", "speed"), [
    ("SPHERE", "20, 1.5; -35, -2.0; 50, 3.0", (20, -35, 50), (1.5, -2.0, 3.0), (0, 0, 0),
     (0, 0, 0)),
    ("SPHERE", "20, 1.5; NONE, NONE; 50, 3.0", (20, 0, 50), (1.5, 0.0, 3.0), (0, 0, 0),
     (0, 0, 0)),
    ("OPEN", "0.05,0.4; NONE,NONE; NONE,-0.2; 20,1.5; -35,-2.0; 50,3.0",  # 72 columns
     (20, -35, 50), (1.5, -2.0, 3.0), (0.05, 0, 0), (0.4, 0, -0.2)),
], ids=["sphere", "sphere-none", "open"])
def test_ball_ic_cardan_angles_and_rates(tmp_path, keyword, ic, ang, rate, shift,
                                         speed) -> None:
    """DATA IC of a SPHERE (and of OPEN's variables 4-6): IMP's Cardan angles x-y'-z''
    (degrees) and their rates (rad/s), NONE keeping the drawn angle (0) and a zero rate.
    The first listed row gives them back to 1e-9; and independently, the body's points
    at t = 0 are where R = Rx(t1) Ry(t2) Rz(t3) in the first joint frame puts them and
    move at omega x r, omega = x t1' + Rx y t2' + Rx Ry z t3' in that frame (written
    here; the frame is turned against the global one so that its axes matter)."""
    p = write(tmp_path, BALL.format(keyword=keyword, ic=ic))
    run = run_deck(p)[0][0]
    assert run.mode == "dynamic" and not run.failure, run.failure
    n = 6 if keyword == "OPEN" else 3
    pos = np.asarray(run.table("LIST POSITION", "joint S").rows)[0, 1:]
    vel = np.asarray(run.table("LIST VELOCITY", "joint S").rows)[0, 1:]
    assert pos.shape == vel.shape == (n,)
    np.testing.assert_allclose(pos[n - 3:], ang, rtol=0, atol=1e-9)
    np.testing.assert_allclose(vel[n - 3:], rate, rtol=0, atol=1e-9)
    if keyword == "OPEN":
        np.testing.assert_allclose(pos[:3], shift, rtol=0, atol=1e-9)
        np.testing.assert_allclose(vel[:3], speed, rtol=0, atol=1e-9)
    a, b, c = np.radians(ang)
    Rx, Ry, Rz = _turn(0, a), _turn(1, b), _turn(2, c)
    R = Rx @ Ry @ Rz
    E = np.eye(3)
    w = E[:, 0] * rate[0] + Rx @ E[:, 1] * rate[1] + Rx @ Ry @ E[:, 2] * rate[2]
    F = BALL_F
    for name, p0 in BALL_P.items():
        local = R @ F.T @ p0  # in the first joint frame, from the joint's origin
        r = F @ (np.asarray(shift, float) + local)
        v = F @ (np.asarray(speed, float) + np.cross(w, local))
        got_r = np.asarray(run.table("LIST POSITION", f"point {name}").rows)[0, 1:]
        got_v = np.asarray(run.table("LIST VELOCITY", f"point {name}").rows)[0, 1:]
        np.testing.assert_allclose(got_r, r, rtol=0, atol=1e-12)
        np.testing.assert_allclose(got_v, v, rtol=0, atol=1e-12)

def test_delete_dynamics_returns_to_undefined_mode(tmp_path) -> None:
    """DELETE DYNAMICS: a kinematic run may follow (DATA POSITION allowed again); DATA
    MOTION and DATA TIME are gone (the DATA TIME assumed is reported)."""
    text = (FOUR + "YSLIDE (BASE, CAR) = Y\nDATA MASS (CAR, LINK) = 1; 0, 0, 0\n"
            "FIND DYNAMICS\nDATA MOTION (Y) = 0.25\nDATA TIME = 0.2, 0, 0.1\n"
            "LIST POSITION (A, Y)\nEXECUTE\nDELETE DYNAMICS\nDATA POSITION (A) = 0, 10, 2\n"
            "EXECUTE\nEND\n")
    runs, _ = run_deck(write(tmp_path, text))
    assert [r.mode for r in runs] == ["dynamic", "kinematic"]
    assert not runs[0].failure and not runs[1].failure, (runs[0].failure, runs[1].failure)
    y = column(runs[0], "LIST POSITION", "joint Y", "JVar 1")
    np.testing.assert_allclose(y, 0.25)  # a number in DATA MOTION is held
    assert "'DATA TIME = 2.00000, 0.00000, 1.00000' is assumed." in runs[1].messages
    np.testing.assert_allclose(column(runs[1], "LIST POSITION", "joint A", "JVar 1"),
                               [0, 10, 20])
    np.testing.assert_allclose(column(runs[1], "LIST POSITION", "joint Y", "JVar 1"), 0)
    # and FIND DYNAMICS again needs a new DATA TIME
    again = text.split("DATA POSITION (A) = 0, 10, 2")[0] + "FIND DYNAMICS\nEXECUTE\nEND\n"
    errs = errors_of(write(tmp_path, again, "again.imp"))
    assert any("needs DATA TIME" in m for _, m in errs), errs


def test_ic_on_an_input_motion_and_zero_spring_are_said(tmp_path) -> None:
    text = (FOUR + "ZERO (SPRING) = 0.001\nFIND DYNAMICS\nDATA MOTION (A) = 10\n"
            "DATA IC (A) = 20, 1\nDATA TIME = 0.1, 0.5, 0.05\nLIST POSITION (A)\nEXECUTE\nEND\n")
    run = run_deck(write(tmp_path, text))[0][0]
    assert not run.failure, run.failure
    msgs = " | ".join(run.messages)
    assert "DATA IC of joint A 1 is not used: that variable is an input motion" in msgs
    assert "ZERO (SPRING) = 0.001 is accepted and not needed" in msgs
    assert "the smallest step 0.5 s is larger than the print step 0.05 s" in msgs
    np.testing.assert_allclose(column(run, "LIST POSITION", "joint A", "JVar 1"), 10.0)


# =============================================================================
# listings, JSON, failures
# =============================================================================
def test_print_requests_and_value_in_dynamic_mode(tmp_path) -> None:
    """PRINT POSITION / VELOCITY / ACCEL / FORCE / VALUE at every output time; a VALUE
    reads the solved motion (POSITION(A, 1) in degrees)."""
    text = (PEND + "VALUE (ANG) = POSITION(A, 1)\nFIND DYNAMICS\nDATA TIME = 0.1, 0, 0.05\n"
            "PRINT POSITION (A, TIP)\nPRINT VELOCITY (TIP)\nPRINT ACCEL (A)\n"
            "PRINT FORCE (A)\nPRINT VALUE (ANG)\nSTORE POSITION (A)\nEXECUTE\nEND\n")
    run, echo = (lambda r: (r[0][0], r[1]))(run_deck(write(tmp_path, text)))
    assert not run.failure, run.failure
    assert echo.count("Position Results:") == 3 and echo.count("Force Results:") == 3
    assert "time = 0.100000" in echo
    assert "through Joint A from Link BASE onto Link ARM :" in echo
    a = column(run, "PRINT POSITION", "joint A", "JVar 1")
    val = column(run, "PRINT VALUE", "value ANG", "Value")
    np.testing.assert_allclose(val, np.radians(a), atol=1e-12)
    acc = column(run, "PRINT ACCEL", "joint A", "JVar 1")
    assert acc[0] == pytest.approx(-PEND_M * G * PEND_L / 2 / PEND_IA, rel=1e-9)
    assert run.table("STORE POSITION", "joint A").columns == ["Time", "JVar 1"]


def test_failure_keeps_the_outputs_before_it(tmp_path) -> None:
    """A slider-crank whose piston is driven past the crank's reach: the loops cannot be
    closed after t ~ 0.56 s; the run says so (exit 1) and lists what it solved."""
    text = """TITLE = DRIVEN TOO FAR
UNIT (MASS) = 1
ZPIN (BASE, CRANK) = A
ZPIN (CRANK, ROD) = B
ZPIN (ROD, PISTON) = C
XSLIDE (BASE, PISTON) = D
DATA ZPIN (A) = 0,0,0; 1,0,0; 0,0.05,0
DATA ZPIN (B) = 0,0.05,0; 0,0.1,0; 0.193649,0,0
DATA ZPIN (C) = 0.193649,0,0; 0.3,-0.05,0; 0.3,0,0
DATA XSLIDE (D) = 0.193649, 0, 0
DATA MASS (CRANK, A) = 1; 0.025, 0, 0
DATA MASS (ROD, B) = 0.3; 0.1, 0, 0
DATA MASS (PISTON, C) = 0.5; 0, 0, 0
VALUE (X) = 0.1 * T
FIND DYNAMICS
DATA MOTION (D) = X
DATA TIME = 1.0, 0, 0.05
LIST POSITION (A, D)
EXECUTE
END
"""
    p = write(tmp_path, text)
    js = tmp_path / "o.json"
    r = cli("run", p, "--json", js)
    assert r.returncode == 1 and "Traceback" not in r.stderr
    run = json.loads(js.read_text())["runs"][0]
    assert "failure" in run and f"{p}:{line_of(text, 'EXECUTE')}: EXECUTE: " in run["failure"]
    rows = next(t["rows"] for t in run["tables"] if t["item"] == "joint D")
    assert 5 < len(rows) < 21
    assert rows[-1][0] < 0.6 and rows[-1][1] <= 0.25 - 0.193649 + 1e-9
    assert "Listing of position of joint D" in r.stdout
    assert "output(s) before it are listed" in run["failure"]


def test_animate_and_plot_in_dynamic_mode(tmp_path) -> None:
    text = (PEND + "FIND DYNAMICS\nDATA TIME = 0.2, 0, 0.05\nPLOT POSITION (A)\nANIMATE\n"
            "EXECUTE\nEND\n")
    p = write(tmp_path, text)
    out = tmp_path / "pics"
    r = cli("run", p, "--out", out)
    assert r.returncode == 0, r.stderr
    assert (out / "run1_animation.gif").stat().st_size > 0
    assert (out / "run1_animation.html").stat().st_size > 0
    assert (out / "run1_plot_position_joint_a.png").stat().st_size > 0


def test_execute_hold_continues_in_time(tmp_path) -> None:
    text = (PEND + "FIND DYNAMICS\nDATA TIME = 0.1, 0, 0.05\nLIST POSITION (A)\n"
            "EXECUTE HOLD\nEXECUTE\nEND\n")
    runs, _ = run_deck(write(tmp_path, text))
    t1 = column(runs[0], "LIST POSITION", "joint A", "Time")
    t2 = column(runs[1], "LIST POSITION", "joint A", "Time")
    np.testing.assert_allclose(t1, [0, 0.05, 0.1])
    np.testing.assert_allclose(t2, [0.1, 0.15, 0.2])
    a1 = column(runs[0], "LIST POSITION", "joint A", "JVar 1")
    a2 = column(runs[1], "LIST POSITION", "joint A", "JVar 1")
    assert a2[0] == pytest.approx(a1[-1], abs=1e-9)


# =============================================================================
# a one-sided IF in element data: the switch located (shared/fuzz-findings/liftoff)
# =============================================================================
LIFTOFF = Path(__file__).resolve().parents[2] / "shared" / "fuzz-findings" / "liftoff"


def bounce(t: np.ndarray) -> tuple[np.ndarray, float]:
    """A 1 kg mass thrown up at 5 m/s from y = 0 (g = 10) onto a spring of 1000 N/m that
    acts only below y = 0: flight to t = 1, contact (y = A sin w s + 0.01 cos w s - 0.01)
    until y returns to 0 at 1 + tc with the speed 5 up, flight again.  Returns (y at t,
    the lift-off time 1 + tc)."""
    w = math.sqrt(1000.0)
    a = -5.0 / w

    def contact(s):
        return a * np.sin(w * s) + 0.01 * np.cos(w * s) - 0.01

    from scipy.optimize import brentq
    tc = brentq(contact, 0.5 * math.pi / w, 1.5 * math.pi / w + 0.2 / w, xtol=1e-15)
    y = np.where(t <= 1.0, 5 * t - 5 * t**2, 0.0)
    inside = (t > 1.0) & (t <= 1.0 + tc)
    y = np.where(inside, contact(t - 1.0), y)
    after = t > 1.0 + tc
    s = t - 1.0 - tc
    return np.where(after, 5 * s - 5 * s**2, y), 1.0 + tc


@pytest.mark.parametrize("deck, integrator", [
    ("M07_liftoff_fine.imp", ""),
    ("M07_liftoff_fine.imp", "REMARK OPENIMP INTEGRATOR = RK, 1E-12\n"),
    ("M06_dyn_liftoff.imp", ""),
    ("M06_dyn_liftoff.imp", "REMARK OPENIMP INTEGRATOR = RK, 1E-12\n"),
])
def test_one_sided_value_spring_lands_and_lifts_off_on_time(tmp_path, deck, integrator):
    """VALUE (K) = IF(Y: 1000, 0, 0), DATA SPRING (J) = K, 0: the IF's test value is a
    switching function the integrator locates, as a BumpStop's contact.  Before, the
    run stalled at the lift-off for minutes (outputs every 0.01 s) or finished with wrong
    positions after the bounce (every 0.25 s).  Against the closed form: positions to
    1e-8 at every output, and the two switches listed at their instants."""
    text = (LIFTOFF / deck).read_text().replace("FIND DYNAMICS\n", integrator + "FIND DYNAMICS\n")
    runs, _echo = run_deck(write(tmp_path, text, deck))
    run = runs[0]
    assert not run.failure, run.failure
    t = column(run, "LIST POSITION", "joint J", "Time")
    y = column(run, "LIST POSITION", "joint J", "JVar 1")
    assert t[-1] == pytest.approx(1.5)
    ref, t_off = bounce(t)
    np.testing.assert_allclose(y, ref, rtol=0, atol=1e-8)
    times = [float(m.split()[1].rstrip(":")) for m in run.messages
             if m.startswith("time ") and "switches" in m]
    assert any(abs(x - 1.0) < 2e-6 for x in times), run.messages
    assert any(abs(x - t_off) < 2e-6 for x in times), (t_off, run.messages)


# =============================================================================
# ACCEL and FORCE in element data: 0 at rest; while integrating, a step behind
# =============================================================================
ADDED_MASS = """UNIT (MASS) = 1
XSLIDE (BASE, CAR) = S
DATA XSLIDE (S) = 0, 0, 0
DATA MASS (CAR, LINK) = 2; 0, 0, 0
DATA SPRING (S) = 200, 0
VALUE (F) = 0 - 0.5*ACCEL(S,1)
DATA FORCE (S) = F
REMARK OPENIMP INTEGRATOR = RK, 1E-10
FIND DYNAMICS
DATA IC (S) = 0.1, 0
DATA TIME = 1, 0, 0.05
LIST POSITION (S)
EXECUTE
END
"""


def test_accel_at_rest_is_zero_in_static_mode(tmp_path) -> None:
    """An equilibrium is at rest: ACCEL(...) in element data reads 0, with no message."""
    text = ADDED_MASS.replace("VALUE (F) = 0 - 0.5*ACCEL(S,1)", "VALUE (F) = 3 + ACCEL(S,1)")
    text = text.split("REMARK OPENIMP")[0] + "FIND EQUILIB\nPRINT POSITION (S)\nEXECUTE\nEND\n"
    runs, echo = run_deck(write(tmp_path, text))
    r = runs[0]
    assert r.ok and r.mode == "static", r.failure
    assert r.table("PRINT POSITION", "joint S").rows[0, 1] == pytest.approx(3.0 / 200.0,
                                                                          abs=1e-9)
    assert not any("undefined" in ln for ln in echo), echo


#: a slider on a spring of 100 whose load is minus half the spring's tension, read by
#: FORCE: a spring of 150 in effect
SPRING_FORCE = """UNIT (MASS) = 1
YSLIDE (BASE, CAR) = J
DATA MASS (CAR, J) = 1; 0,0,0
POINT (BASE) = B0
DATA POINT (B0, ABS) = 0, -1, 0
POINT (CAR) = P
DATA POINT (P, ABS) = 0, 0, 0
SPRING (B0, P) = SPR
DATA SPRING (SPR) = 100, 1
VALUE (FF) = 0 - 0.5 * FORCE(SPR, 1)
DATA FORCE (J) = FF
REMARK OPENIMP INTEGRATOR = RK, 1E-9
FIND DYNAMICS
DATA IC (J) = 0.1, 0
DATA TIME = 1, 0, 0.05
LIST POSITION (J)
EXECUTE
END
"""


@pytest.mark.parametrize(("deck", "joint", "omega"), [
    (ADDED_MASS, "S", math.sqrt(200.0 / 2.5)),  # m a = -k y - 0.5 a: a mass of 2.5
    (SPRING_FORCE, "J", math.sqrt(150.0)),
], ids=["accel", "force"])
@pytest.mark.parametrize("method", ["rk", "book"])
def test_accel_and_force_in_element_data_while_integrating(tmp_path, deck, joint, omega,
                                                           method) -> None:
    """ACCEL(...) and FORCE(...) in the data of a load are read a step behind while
    integrating, as IMP read them (extrapolated from the last two accepted steps): the
    oscillator's closed form 0.1 cos(omega t), to 2e-5 with RK (1e-9) and, with IMP's
    step at its default force error, within that method's own error on a linear
    oscillator driven by a function of time (about 1e-3 here, measured); dropping the
    load (the old undefined-as-0) would be off by more than 0.05."""
    text = deck if method == "rk" else deck.replace("REMARK OPENIMP INTEGRATOR = RK, 1E-10\n",
                                                    "").replace(
        "REMARK OPENIMP INTEGRATOR = RK, 1E-9\n", "")
    runs, echo = run_deck(write(tmp_path, text))
    r = runs[0]
    assert r.ok and r.mode == "dynamic", r.failure
    rows = r.table("LIST POSITION", f"joint {joint}").rows
    exact = 0.1 * np.cos(omega * rows[:, 0])
    err = np.max(np.abs(rows[:, 1] - exact))
    assert err < (2e-5 if method == "rk" else 4e-3), err
    assert not any("undefined" in ln for ln in echo), echo
    said = [m for m in r.messages if "read a step behind while integrating" in m]
    assert len(said) == 1, r.messages
