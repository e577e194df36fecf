"""No silent NaN, no run for minutes, RETURN in element data (issue 30, N4, N5, N7, N9, N11).

* N4: numbers the reader accepts (a spring of 1E150) made the book step produce NaN at
  every output with a success status: ``max()`` passes NaN over, so the force error and
  the largest displacement never saw it.  Every stage now checks that its loads and
  accelerations are finite, the book's linear solution and both errors too; an attempt
  that is not finite is never kept, even at the smallest step, and a run that cannot
  avoid it stops with the time and the cause.
* N5: a negative damper, a torque with a pole, an initial rate of 1E8 rad/s shrank the
  step without bound; only a 10-million-step cap ended them.  Without a smallest step
  the run now stops when the error control asks for a step below 1e-6 of the output
  step (MSC Adams' default HMIN); ZERO (FORCE)'s third number caps the steps of a run;
  a negative damper is warned about at its statement.
* N7: a VALUE overflowing through ``*`` is said, as ``@`` is; an undefined value is
  ``????``, ``null``, ``nan`` (never ``inf``).
* N9: misuses of the Python API raise the package's error naming the argument.
* N11: RETURN (END) evaluated by a VALUE of element data stops a time response there,
  as in a motion, where it was blamed on the integrator.

The deck runs are real processes under a CPU-time limit (a cold kernel cache compiles
the book step first): a regression that runs for minutes fails, a busy machine does not.
The motions before each stop are checked against scipy's solution of the same pendulum.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import openimp
from helpers.decks import PENDULUM_HEAD, cpu_limit
from openimp.errors import InputError
from openimp.io import _csv_text
from openimp.results import Table

#: the pendulum of the fuzz findings: 2 (kg) at 0.25 m, 1/6 kg m^2 about its centre's axes
HEAD = PENDULUM_HEAD
TAIL = """\
FIND DYNAMICS
DATA IC (A) = -60, 1.5
DATA TIME = 1.0, 0, 0.05
LIST POSITION (A)
EXECUTE
END
"""
#: its moment of inertia about the pin (DATA INERTIA replaces the point's second moments)
INERTIA = 0.1666667
MGC = 2.0 * 9.80665 * 0.25


def _run(tmp_path: Path, body: str, tail: str = TAIL, head: str = HEAD
         ) -> tuple[int, str, str, dict | None]:
    deck = tmp_path / "deck.imp"
    deck.write_text(head + body + tail)
    out = tmp_path / "out.json"
    out.unlink(missing_ok=True)
    p = subprocess.run([sys.executable, "-m", "openimp.cli", "run", str(deck), "--json",
                        str(out)], capture_output=True, text=True, preexec_fn=cpu_limit,
                       cwd=tmp_path)
    assert "Traceback" not in p.stderr and "Warning" not in p.stderr, p.stderr[-2000:]
    doc = json.loads(out.read_text()) if out.exists() else None
    return p.returncode, p.stdout, p.stderr, doc


def _rows(doc: dict) -> np.ndarray:
    t = doc["runs"][0]["tables"][0]
    return np.array(t["rows"], dtype=float)


def _scipy(rows: np.ndarray, torque) -> np.ndarray:
    """The pendulum's angle (degrees) at the rows' times, from -60 deg and 1.5 rad/s."""
    def f(t, y):
        return [y[1], (-MGC * math.cos(y[0]) + torque(t, y)) / INERTIA]

    # the arm lies along x at 0: gravity -y gives a moment -m g c cos(theta)
    sol = solve_ivp(f, (0.0, rows[-1, 0]), [math.radians(-60.0), 1.5], t_eval=rows[:, 0],
                    rtol=1e-11, atol=1e-12, method="DOP853")
    return np.degrees(sol.y[0])


def test_a_spring_too_stiff_for_the_arithmetic_stops_with_the_cause(tmp_path):
    rc, out, err, doc = _run(tmp_path, "DATA SPRING (A) = 1E150, 0\n")
    assert rc == 1
    # the stages' loads not finite, or the step at its floor: either says so at t = 0
    assert "t = 0 s:" in err
    assert "infinite or undefined" in err or "1e-6 of the output step" in err
    rows = _rows(doc)
    assert rows.shape[0] == 1 and np.isfinite(rows).all()  # the start only, finite
    assert "????" not in out


@pytest.mark.parametrize("old,new", [
    ("DATA MASS (ARM, A) = 2;", "DATA MASS (ARM, A) = 1E150;"),
    ("DATA GRAVITY = 0, -9.80665, 0", "DATA GRAVITY = 0, -1E150, 0"),
    ("DATA GRAVITY = 0, -9.80665, 0", "DATA GRAVITY = 0, -9.80665, 0\nDATA TORQUE (A) = 1E150"),
    ("DATA TIME = 1.0, 0, 0.05", "DATA TIME = 1E150, 0, 1E146"),
])
def test_numbers_the_reader_takes_never_give_a_silent_nan(tmp_path, old, new):
    """The N4 variants: each run stops with a message (exit 1) and what it lists is
    finite."""
    head, tail = HEAD.replace(old, new), TAIL.replace(old, new)
    assert head + tail != HEAD + TAIL
    rc, out, err, doc = _run(tmp_path, "", tail, head)
    assert rc == 1, (out[-1000:], err[-1000:])
    assert "t = 0 s:" in err
    assert doc is None or np.isfinite(_rows(doc)).all()
    assert "????" not in out


def test_a_load_that_overflows_stops_with_the_cause(tmp_path):
    rc, out, err, doc = _run(tmp_path, "VALUE (V) = 1E140*POSITION(A, 1)\n"
                             "DATA TORQUE (A) = V\n")
    assert rc == 1
    assert "infinite or undefined" in err or "1e-6 of the output step" in err
    assert doc is None or np.isfinite(_rows(doc)).all()
    assert "????" not in out


def test_the_api_never_returns_nan_postures():
    m = openimp.Model("pendulum")
    m.set_units("SI")
    m.add_joint("revolute", "A", "BASE", "ROD", origin=(0, 0, 0))
    m.add_mass("ROD", 2.0, (0, -0.5, 0), (0.04, 0.04, 0.04))
    m.set_gravity((0, -9.81, 0))
    m.set_joint_spring("A", 1e150, free=0.0)
    s = openimp.compile(m)
    for method in ("book", "rk"):
        r = openimp.simulate(s, 1.0, print_step=0.1, q={"A": 0.3}, method=method,
                             progress=False)
        assert not r.complete and r.message.startswith("t = 0 s:"), (method, r.message)
        assert np.isfinite(r.q).all() and len(r) == 1


def test_a_pole_stops_before_it_and_the_motion_there_is_right(tmp_path):
    """A torque 1/(t - 0.5): the deck (the book step, IMP's ZERO (FORCE) 0.1 N m, 1 %)
    stops within 0.01 s of the pole, its outputs before within the force error's reach
    of scipy (0.1 N m on 0.167 kg m^2 over 0.45 s: 0.6 rad/s^2 for 0.45 s bounds it by
    3.5 deg; 0.5 deg found); the same from Python with rk to 1e-5 deg."""
    rc, _out, err, doc = _run(tmp_path, "VALUE (V) = 1/(T-0.5)\nDATA TORQUE (A) = V\n")
    assert rc == 1 and "below 5e-08 s" in err
    t_stop = float(err.split("t = ")[1].split(" s")[0])
    assert 0.49 < t_stop < 0.5, err
    rows = _rows(doc)
    assert rows[-1, 0] == pytest.approx(0.45) and rows.shape[0] == 10
    ref = _scipy(rows, lambda t, y: 1.0 / (t - 0.5))
    assert np.abs(rows[:, 1] - ref).max() < 0.6
    m = openimp.Model("pendulum")
    m.set_units("SI")
    m.add_joint("revolute", "A", "BASE", "ARM", origin=(0, 0, 0))
    m.add_mass("ARM", 2.0, (0.25, 0, 0), (0.0, INERTIA - 2.0 * 0.25**2, INERTIA - 2.0 * 0.25**2))
    m.set_gravity((0, -9.80665, 0))
    m.set_joint_force("A", law=lambda st: 1.0 / (st.t - 0.5))
    r = openimp.simulate(openimp.compile(m), 1.0, print_step=0.05, method="rk",
                         q={"A": math.radians(-60.0)}, rates={"A": 1.5}, rtol=1e-10,
                         progress=False)
    assert not r.complete and "below 5e-08 s" in r.message
    assert 0.49 < float(r.message.split("t = ")[1].split(" s")[0]) <= 0.5
    rows = np.column_stack([r.time, np.degrees(r.variable("A"))])
    assert rows.shape[0] == 10
    assert np.abs(rows[:, 1] - _scipy(rows, lambda t, y: 1.0 / (t - 0.5))).max() < 1e-5


def test_a_negative_damper_is_warned_about_and_the_run_ends(tmp_path):
    rc, out, err, doc = _run(tmp_path, "DATA DAMPER (A) = -0.2\n")
    assert "DATA DAMPER (A): the coefficient -0.2 is negative" in out + err
    assert rc == 0  # a slow growth integrates to the end
    rows = _rows(doc)
    # a torsional damper is per radian (force length s / rad): -0.2 N m s feeds energy in
    ref = _scipy(rows, lambda t, y: 0.2 * y[1])
    assert np.abs(rows[:, 1] - ref).max() < 1.0
    rc, out, err, doc = _run(tmp_path, "DATA DAMPER (A) = -50\n")
    assert rc == 1 and "below 5e-08 s" in err  # about e^(300 t): stopped, not for minutes
    assert np.isfinite(_rows(doc)).all()


def test_a_rate_too_high_for_the_outputs_stops_at_the_start(tmp_path):
    rc, _out, err, _doc = _run(tmp_path, "", TAIL.replace("-60, 1.5", "0, 1E8"))
    # the book's step moves the arm more than its largest displacement at the floor
    assert rc == 1 and "t = 0 s:" in err and "a rate far too high" in err


def test_zero_force_caps_the_steps_of_a_run(tmp_path):
    rc, _out, err, doc = _run(tmp_path, "ZERO (FORCE) = 0.1, 1, 5\n")
    assert rc == 1 and "5 steps taken (max_steps)" in err
    assert 1 <= _rows(doc).shape[0] < 21
    rc, _out, err, doc = _run(tmp_path, "ZERO (FORCE) = 0.1, 1, 0\n")
    assert rc == 2 and "deck.imp:7:" in err and "MAX_RUN_STEPS" in err


def test_return_in_element_data_stops_the_run_there(tmp_path):
    rc, out, err, doc = _run(tmp_path, "VALUE (K) = IF(T-0.5: 0, 0, RETURN)\n"
                             "DATA SPRING (A) = K, 0\n")
    assert rc == 0, err
    assert "deck.imp:7: VALUE K (DATA SPRING of joint A variable 1) evaluated RETURN at " \
           "time 0.5" in out
    assert "the run stops there (RETURN in a VALUE); the 11 output(s) before it" in out
    assert "error control" not in out + err
    rows = _rows(doc)
    assert rows.shape[0] == 11
    np.testing.assert_allclose(rows[:, 1], _scipy(rows, lambda t, y: 0.0), atol=0.05)


def test_end_in_element_data_ends_the_deck(tmp_path):
    tail = TAIL.replace("END\n", "EXECUTE\nEND\n")
    rc, out, err, doc = _run(tmp_path, "VALUE (K) = IF(T-0.2: 0, 0, END)\n"
                             "DATA SPRING (A) = K, 0\n", tail)
    assert rc == 0, err
    assert "evaluated END at time 0.2" in out and "no further EXECUTE runs" in out
    assert len(doc["runs"]) == 1


def test_overflow_through_any_operator_is_said(tmp_path):
    deck = tmp_path / "v.imp"
    deck.write_text("ZPIN (BASE, CRANK) = A\nVALUE (VM) = 1E308*1E308\n"
                    "VALUE (VS) = 1E308+1E308\nVALUE (VP) = 10@400\n"
                    "DATA POSITION (A) = 0, 10, 2\nLIST VALUE (VM, VS, VP)\nEXECUTE\nEND\n")
    p = subprocess.run([sys.executable, "-m", "openimp.cli", "run", str(deck), "--csv",
                        str(tmp_path / "c")], capture_output=True, text=True,
                       preexec_fn=cpu_limit, cwd=tmp_path)
    assert p.returncode == 0
    assert "v.imp:2: VALUE (VM): '*' overflows (1e+308 * 1e+308)" in p.stdout + p.stderr
    assert "v.imp:3: VALUE (VS): '+' overflows" in p.stdout + p.stderr
    assert "v.imp:4: VALUE (VP): '@' overflows" in p.stdout + p.stderr
    for f in (tmp_path / "c").iterdir():
        assert "inf" not in f.read_text() and "nan" in f.read_text()


def test_undefined_is_nan_in_csv_whatever_made_it():
    t = Table("LIST VALUE", "V", ["Step", "Value"], ["", ""],
              np.array([[0.0, math.inf], [1.0, -math.inf], [2.0, math.nan], [3.0, 1.5]]))
    assert _csv_text(t).splitlines()[1:] == ["0.0,nan", "1.0,nan", "2.0,nan", "3.0,1.5"]


def _pendulum() -> openimp.System:
    m = openimp.Model("pendulum")
    m.set_units("SI")
    m.add_joint("revolute", "A", "BASE", "ROD", origin=(0, 0, 0))
    m.add_mass("ROD", 2.0, (0, -0.5, 0), (0.04, 0.04, 0.04))
    m.add_point("TIP", "ROD", (0, -1, 0))
    m.set_gravity((0, -9.81, 0))
    m.add_force("PUSH", "TIP", 1.0, direction=(1, 0, 0))
    return openimp.compile(m)


def test_api_misuse_names_the_argument():
    """The calls of the fuzz findings' N9_api_misuse.py."""
    s = _pendulum()
    f = openimp.forces(s, {"A": [0.0, 1.0]})
    with pytest.raises(InputError, match="drive has no 'NOPE'; it holds: A"):
        f.drive["NOPE"]
    with pytest.raises(KeyError):  # still the KeyError of a mapping
        f.power["NOPE"]
    assert f.drive["A.theta"].shape == (2,)
    cases = [
        (lambda: openimp.simulate(s, times=[[0, 1], [2, 3]]), "times must be one row"),
        (lambda: openimp.linearize(s, t=float("nan")), "linearize: t must be finite"),
        (lambda: openimp.simulate(s, 0.1, print_step=0.01, rates={"A": 1e200}),
         "rates: the value of 'A' is 1E\\+200, beyond ±1E\\+60 \\(limit MAX_RATE\\)"),
        (lambda: openimp.simulate(s, 0.1, max_steps=10**9), "limit MAX_RUN_STEPS"),
        (lambda: openimp.mode_motion(openimp.modes(openimp.linearize(s)), 0, steps=10**8),
         "limit MAX_STEPS"),
        (lambda: openimp.frequency_response(openimp.linearize(s), ("force", "PUSH"),
                                            [("position", "A")], np.linspace(0, 10, 100_001)),
         "100001 frequencies are more than 100000"),
        (lambda: openimp.equilibria(s, {"A": np.zeros(100_001)}), "limit MAX_STEPS"),
    ]
    for call, text in cases:
        with pytest.raises(InputError, match=text):
            call()


#: the fuzz findings' reproducers (shared/fuzz-findings/new-modes) run as shipped: the exit
#: status their README expects and a phrase of the message (N2, N3, N6, N8 and N9 have
#: tests of their own in test_safety.py, test_imp_dynamics.py and above)
FINDINGS = Path(__file__).resolve().parents[2] / "shared" / "fuzz-findings" / "new-modes"
REPRODUCERS: dict[str, tuple[int | tuple[int, ...], str]] = {
    "N1_minstep_pendulum.imp": (0, ""),
    "N1_fourbar_released_minstep.imp": (0, ""),
    # a block whose spring force flips through its coincident points, at DATA TIME's
    # smallest step (0.001 s): a run, or a stop with the book's displacement message
    "N1_coincident_spring.imp": ((0, 1), ""),
    "N4_spring_1e150_dyn.imp": (1, "t = 0 s:"),
    "N5_negative_damper.imp": (1, "1e-6 of the output step"),
    "N5_value_pole.imp": (1, "1e-6 of the output step"),
    "N5_ic_rate_1e8.imp": (1, "a rate far too high"),
    "N7_value_overflow.imp": (0, "'*' overflows"),
}


@pytest.mark.parametrize("name", sorted(REPRODUCERS))
def test_the_reproducers_end_as_expected(tmp_path, name):
    if not (FINDINGS / name).exists():
        pytest.skip("shared/fuzz-findings is not beside the checkout")
    deck = tmp_path / name
    deck.write_bytes((FINDINGS / name).read_bytes())
    out = tmp_path / "o.json"
    p = subprocess.run([sys.executable, "-m", "openimp.cli", "run", str(deck), "--json",
                        str(out), "--csv", str(tmp_path / "c")], capture_output=True,
                       text=True, preexec_fn=cpu_limit, cwd=tmp_path)
    rc, phrase = REPRODUCERS[name]
    assert p.returncode in (rc if isinstance(rc, tuple) else (rc,)), p.stderr[-2000:]
    assert phrase in p.stdout + p.stderr
    assert "Traceback" not in p.stderr
    for run in json.loads(out.read_text())["runs"]:  # nothing undefined in a motion
        for t in run["tables"]:
            if t["request"].startswith(("LIST POSITION", "PRINT POSITION")):
                assert all(v is not None for row in t["rows"] for v in row), name
    for f in (tmp_path / "c").glob("*.csv"):
        assert "inf" not in f.read_text()
