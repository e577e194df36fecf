"""IMP linearized vibration in a kinematic run: PRINT FREQUENCY, PRINT / LIST / STORE /
PLOT DYNAMICS (reference imp-language.md §1.1 items 7-8, §1.2, §9).

The references are closed forms written here in plain numpy: the damped compound
pendulum of examples/pendulum.imp (w = sqrt(m g l / I), H = L / (I s^2 + c s + m g l)),
a base-excited spring-mass on a driven slider (an SGC motion input), the frequency
grid rule of LIST DYNAMICS, and every message of a request IMP ignores.
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

from helpers.decks import cpu_limit
from openimp import io
from openimp.imp.deck import load
from openimp.imp.run.prepare import frequency_grid

EXAMPLES = Path(__file__).parent.parent / "examples"
LBM = 1.0 / 386.088  # IMP's default UNIT (MASS)

# the pendulum of examples/pendulum.imp, in plain numbers (in, lbf, s)
L_ROD, M_ROD, C_PIN = 12.0, 3.0 * LBM, 0.5
I_PIV = M_ROD * L_ROD**2 / 3.0  # about the pin
MGL = M_ROD * 386.088 * L_ROD / 2.0


def pendulum_h(w: np.ndarray) -> np.ndarray:
    """Pin angle (degrees) per lbf of the horizontal tip force, at s = j w."""
    s = 1j * np.asarray(w, float)
    return (180.0 / np.pi) * L_ROD / (I_PIV * s**2 + C_PIN * s + MGL)


def write(tmp_path: Path, text: str, name: str = "deck.imp") -> Path:
    p = tmp_path / name
    p.write_text(text)
    return p


def run(path: Path, out_dir: Path | None = None):
    deck = load(path)
    echo: list[str] = []
    runs = deck.run(out_dir=out_dir, echo=echo.append)
    return runs, echo


def line_of(text: str, start: str) -> int:
    """1-based number of the first line of ``text`` that starts with ``start``."""
    for i, ln in enumerate(text.splitlines(), start=1):
        if ln.startswith(start):
            return i
    raise AssertionError(start)


@pytest.fixture(scope="module")
def pendulum(tmp_path_factory):
    out = tmp_path_factory.mktemp("pendulum")
    runs, echo = run(EXAMPLES / "pendulum.imp", out)
    return runs[0], echo, out


# =============================================================================
# PRINT FREQUENCY
# =============================================================================
def test_pendulum_frequency_is_the_closed_form(pendulum) -> None:
    r, echo, _ = pendulum
    assert r.ok, (r.failure, r.unsupported)
    w = math.sqrt(MGL / I_PIV)
    zeta = C_PIN / (2.0 * I_PIV * w)
    assert abs(w - 6.94701) < 1e-5  # the hand value of the deck's comments
    t = r.table("PRINT FREQUENCY", "modes")
    assert t.columns == ["Frequency", "Damping ratio", "Time constant", "Step", "Mode"]
    assert t.units == ["rad/s", "", "s", "", ""]
    assert t.rows.shape == (1, 5)
    assert t.rows[0, 0] == pytest.approx(w, rel=1e-9)
    assert t.rows[0, 1] == pytest.approx(zeta, rel=1e-9)
    assert math.isnan(t.rows[0, 2]) and t.rows[0, 3:].tolist() == [0.0, 1.0]
    i = echo.index("Vibration Results:")
    assert echo[i + 1] == "Mode Frequency (rad/s) Damping ratio"
    assert echo[i + 2] == f"1 {w:.6g} {zeta:.6g}"


# =============================================================================
# PRINT, STORE, LIST and PLOT DYNAMICS
# =============================================================================
def test_print_dynamics_formula_is_the_closed_form(pendulum) -> None:
    r, echo, _ = pendulum
    a = math.degrees(L_ROD) / I_PIV
    b, c = C_PIN / I_PIV, MGL / I_PIV
    lines = [ln for ln in echo if ln.startswith("POSITION A 1 ")]
    assert lines == [f"POSITION A 1 (deg/force) = ({a:.6g})/(S**2 + {b:.6g}*S + {c:.6g})"]
    assert "Transfer functions at the last position (step 0), input force PUSH (force):" in echo
    # the tip moves along X only (dX = L dtheta): Y and Z are exact zeros, not round-off
    assert f"POSITION TIP X (length/force) = ({L_ROD**2 / I_PIV:.6g})/(S**2 + {b:.6g}*S + " \
           f"{c:.6g})" in echo
    assert any(ln.startswith("POSITION TIP Y (length/force) = (0)/(") for ln in echo)
    t = r.table("PRINT DYNAMICS", "force PUSH")
    assert t.columns == ["Power", "Denominator", "Numerator POSITION A 1",
                         "Numerator POSITION TIP X", "Numerator POSITION TIP Y",
                         "Numerator POSITION TIP Z"]
    assert t.units[2:] == ["deg/force"] + ["length/force"] * 3
    assert np.allclose(t.rows[:, 0], [2, 1, 0])
    assert np.allclose(t.rows[:, 1], [1, b, c], rtol=1e-10)
    assert np.allclose(t.rows[:, 2], [0, 0, a], rtol=1e-10)
    assert np.allclose(t.rows[:, 3], [0, 0, L_ROD**2 / I_PIV], rtol=1e-10)
    assert np.all(t.rows[:, 4:] == 0)


def test_list_dynamics_grid_and_response(pendulum) -> None:
    r, echo, _ = pendulum
    t = r.table("LIST DYNAMICS", "force PUSH")
    assert t.columns == ["Frequency", "|POSITION A 1|", "Phase POSITION A 1"]
    assert t.units == ["rad/s", "deg/force", "deg"]
    # LIST DYNAMICS (1, 100, 0.25 / ...): 1, 1.25, then ratio 1.25 below 100, then 100
    w = [1.0]
    while w[-1] * 1.25 < 100.0:
        w.append(w[-1] * 1.25)
    w.append(100.0)
    assert np.allclose(t.rows[:, 0], w, rtol=1e-12)
    h = pendulum_h(t.rows[:, 0])
    assert np.allclose(t.rows[:, 1], np.abs(h), rtol=1e-9)
    assert np.allclose(t.rows[:, 2], np.degrees(np.angle(h)), atol=1e-7)
    i = echo.index("Listing of the frequency response to force PUSH")
    assert echo[i + 2].split() == ["1", f"{abs(h[0]):.6g}", f"{np.degrees(np.angle(h[0])):.6g}"]


def test_frequency_grid_rule() -> None:
    assert np.allclose(frequency_grid(1.0, 10.0, 1.0), [1, 2, 4, 8, 10])
    assert np.allclose(frequency_grid(1.0, 8.0, 1.0), [1, 2, 4, 8])  # wf reached exactly
    assert np.allclose(frequency_grid(2.0, 3.0, 5.0), [2, 3])  # the first step passes wf
    assert np.allclose(frequency_grid(0.5, 100.0, 0.5)[:4], [0.5, 1, 2, 4])


def test_json_png_and_store(pendulum, tmp_path) -> None:
    r, _, out = pendulum
    path = tmp_path / "x.json"
    io.write_json(path, [r])
    tables = {(t["request"], t["item"]): t for t in json.loads(path.read_text())["runs"][0][
        "tables"]}
    modes = tables[("PRINT FREQUENCY", "modes")]
    assert modes["columns"][0] == "Frequency" and modes["rows"][0][2] is None
    lst = tables[("LIST DYNAMICS", "force PUSH")]
    assert lst["columns"][0] == "Frequency" and lst["units"][0] == "rad/s"
    assert ("PLOT DYNAMICS", "force PUSH") in tables
    png = out / "run1_plot_dynamics_force_push.png"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert not [p for p in out.iterdir() if p.name.startswith(".")]  # no temporary left


# the pendulum with its data, for variants
PENDULUM = """TITLE = PENDULUM
ZPIN (BASE, ARM) = A
DATA ZPIN (A) = 0,0,0; 1,0,0; 0,-1,0
POINT (ARM) = TIP
POINT (BASE) = Q1, Q2
DATA POINT (TIP, ABS) = 0, -12, 0
DATA POINT (Q1, ABS) = 0, -12, 0
DATA POINT (Q2, ABS) = 1, -12, 0
DATA MASS (ARM, A) = 3; 6, 0, 0
DATA INERTIA (ARM, A) = 0, 144, 144, 0, 0, 0
DATA GRAVITY = 0, -386.088, 0
DATA DAMPER (A) = 0.5
FORCE (TIP / Q1, Q2) = PUSH
DATA FORCE (PUSH) = 0
"""


def test_store_dynamics_of_a_joint_load(tmp_path) -> None:
    p = write(tmp_path, PENDULUM + "STORE DYNAMICS (FORCE, A, 1) = POSITION, A\n"
              "EXECUTE\nEND\n")
    runs, _ = run(p, tmp_path / "out")
    t = runs[0].table("STORE DYNAMICS", "load on joint A 1")
    # a moment on the pin: (180/pi) / (I s^2 + c s + m g l), monic denominator
    assert np.allclose(t.rows[:, 2], [0, 0, math.degrees(1.0) / I_PIV], rtol=1e-10)
    assert t.units[2] == "deg/(force*length)"
    text = (tmp_path / "out" / "deck_store.txt").read_text()
    assert "# STORE DYNAMICS load on joint A 1" in text
    assert f"0 {MGL / I_PIV:.10g} {math.degrees(1.0) / I_PIV:.10g}" in text


# a cart on a driven slider S1 carries a mass on a sprung, damped slider S2
BASE_EXCITED = """TITLE = BASE-EXCITED SPRING-MASS
XSLIDE (BASE, CART) = S1
XSLIDE (CART, BODY) = S2
DATA XSLIDE (S1) = 0, 0, 0
DATA XSLIDE (S2) = 0, 0, 0
POINT (BODY) = P
DATA POINT (P, ABS) = 0, 0, 0
DATA MASS (BODY, LINK) = 2; 0, 0, 0
DATA SPRING (S2) = 50, 0
DATA DAMPER (S2) = 0.1
DATA POSITION (S1) = 0, 1, 2
PRINT FREQUENCY
PRINT DYNAMICS (MOTION, S1, 1) = POSITION, S2; POSITION, P
EXECUTE
END
"""


def test_motion_input_of_an_sgc(tmp_path) -> None:
    runs, echo = run(write(tmp_path, BASE_EXCITED))
    r = runs[0]
    assert r.ok, (r.failure, r.unsupported)
    m, k, c = 2 * LBM, 50.0, 0.1
    f = r.table("PRINT FREQUENCY", "modes")
    assert f.rows.shape == (3, 5)  # at each of the 3 positions
    assert np.allclose(f.rows[:, 0], math.sqrt(k / m), rtol=1e-9)
    assert np.allclose(f.rows[:, 1], c / (2 * math.sqrt(k * m)), rtol=1e-9)
    t = r.table("PRINT DYNAMICS", "motion of joint S1 1")
    den = np.array([1.0, c / m, k / m])
    assert np.allclose(t.rows[:, 1], den, rtol=1e-10)
    # relative motion x2 / u = -s^2 / (s^2 + c/m s + k/m); absolute X = (c/m s + k/m) / (...)
    assert np.allclose(t.rows[:, 2], [-1, 0, 0], atol=1e-10)
    assert np.allclose(t.rows[:, 3], [0, c / m, k / m], rtol=1e-10)
    assert "Transfer functions at the last position (step 2), input motion of joint S1 1 " \
           "(length):" in echo


# =============================================================================
# Messages: no FGC, singular mass, bad requests
# =============================================================================
def test_no_free_coordinate(tmp_path) -> None:
    text = PENDULUM + ("DATA POSITION (A) = -90, 10, 1\nPRINT FREQUENCY\n"
                       "PRINT DYNAMICS (FORCE, PUSH) = POSITION, A\nEXECUTE\nEND\n")
    p = write(tmp_path, text)
    runs, echo = run(p)
    r = runs[0]
    assert not r.failure and len(r.unsupported) == 2
    why = ("the run has no free generalized coordinate (mobility 1 at the starting posture, 1 "
           "input motion(s)): every coordinate is specified, so nothing can vibrate")
    assert r.unsupported[0] == (f"{p}:{line_of(text, 'PRINT FREQ')}: PRINT FREQUENCY is not "
                                f"produced: {why}")
    assert r.unsupported[1] == (f"{p}:{line_of(text, 'PRINT DYN')}: PRINT DYNAMICS is not "
                                f"produced: {why}")
    msg = [ln for ln in echo if ln.startswith("*** No free generalized coordinates")]
    assert len(msg) == 2  # at each position, as IMP does
    assert not [t for t in r.tables if "FREQUENCY" in t.request or "DYNAMICS" in t.request]


def test_singular_mass_is_located_and_the_run_goes_on(tmp_path) -> None:
    # a second, massless link pinned to the tip swings freely: M_FF is singular
    text = PENDULUM.replace("POINT (ARM) = TIP\n", "POINT (ARM) = TIP\nZPIN (ARM, FLAP) = F\n"
                            "DATA ZPIN (F) = 0,-12,0; 0,-13,0; 0,-13,0\n") + (
        "PRINT POSITION (A)\nPRINT FREQUENCY\nLIST DYNAMICS (1, 10, 1 / FORCE, PUSH) = "
        "POSITION, A\nEXECUTE\nEND\n")
    p = write(tmp_path, text)
    runs, echo = run(p)
    r = runs[0]
    assert not r.failure
    assert r.table("PRINT POSITION", "joint A").rows.shape == (1, 5)  # the rest is produced
    loc = f"{p}:{line_of(text, 'PRINT FREQ')}: PRINT FREQUENCY"
    line = [ln for ln in echo if ln.startswith(f"*** {loc}: ")]
    assert len(line) == 1 and "mass matrix of the free coordinates is singular" in line[0]
    assert "FLAP" in line[0]  # names the body that moves without mass
    assert r.unsupported[0].startswith(f"{loc} is not produced at 1 of 1 position(s); at the "
                                       "first (step 0): the mass matrix")
    assert r.unsupported[1].startswith(f"{p}:{line_of(text, 'LIST DYN')}: LIST DYNAMICS is not "
                                       "produced: at the last position (step 0): the mass")


BAD = [
    ("LIST DYNAMICS (0, 10, 1 / FORCE, PUSH) = POSITION, A",
     "LIST DYNAMICS is not produced: the frequencies w0, wf, winc must all be > 0 rad/s; they "
     "are 0, 10, 1"),
    ("PLOT DYNAMICS (10, 5, 1; FORCE, PUSH) = POSITION, A",
     "PLOT DYNAMICS is not produced: the final frequency wf = 5 must be greater than the first "
     "w0 = 10"),
    ("PRINT DYNAMICS (FORCE, NOPE) = POSITION, A",
     "PRINT DYNAMICS is not produced: the input FORCE NOPE: NOPE is not a FORCE or TORQUE "
     "element or a joint defined by EXECUTE"),
    ("PRINT DYNAMICS (FORCE, PUSH, 2) = POSITION, A",
     "PRINT DYNAMICS is not produced: FORCE element PUSH takes nin = 0, not 2"),
    ("PRINT DYNAMICS (FORCE, A, 2) = POSITION, A",
     "PRINT DYNAMICS is not produced: the input FORCE A 2: joint A (ZPIN) has variable 1; nin "
     "gives the joint variable"),
    ("PRINT DYNAMICS (MOTION, A, 1) = POSITION, A",
     "PRINT DYNAMICS is not produced: the input MOTION A 1: joint A 1 is not an input motion "
     "(SGC) of this run; give it DATA POSITION or DATA MOTION, or use a FORCE input"),
    ("STORE DYNAMICS (FORCE, PUSH) = POSITION, Q9; POSITION, TIP",
     "STORE DYNAMICS: the output POSITION Q9 is dropped: Q9 is not a joint or point defined "
     "by EXECUTE"),
    ("STORE DYNAMICS (FORCE, PUSH) = VELOCITY, ARM",
     "STORE DYNAMICS is not produced: none of its output pairs can be computed"),
]


def test_bad_requests_are_ignored_with_located_messages(tmp_path) -> None:
    text = PENDULUM + "\n".join(stmt for stmt, _ in BAD) + "\nPRINT FREQUENCY\nEXECUTE\nEND\n"
    p = write(tmp_path, text)
    runs, _ = run(p)
    r = runs[0]
    assert not r.failure
    got = list(r.unsupported)
    for stmt, msg in BAD:
        assert f"{p}:{line_of(text, stmt)}: {msg}" in got, (msg, got)
    # the pair VELOCITY ARM (a link) is dropped with its own message too
    assert any("the output VELOCITY ARM is dropped: ARM is not a joint or point" in u
               for u in got)
    # the good pair of the STORE request with a bad one is produced; FREQUENCY too
    assert r.table("STORE DYNAMICS", "force PUSH").columns[2:] == [
        "Numerator POSITION TIP X", "Numerator POSITION TIP Y", "Numerator POSITION TIP Z"]
    assert r.table("PRINT FREQUENCY", "modes").rows.shape == (1, 5)


def test_command_line_check_and_run_agree(tmp_path) -> None:
    """openimp check and run list the same messages, exit 1, no traceback."""
    text = PENDULUM + BAD[2][0] + "\n" + BAD[6][0] + "\nEXECUTE\nEND\n"
    p = write(tmp_path, text)
    env_cmd = [sys.executable, "-m", "openimp.cli"]
    check = subprocess.run([*env_cmd, "check", str(p)], capture_output=True, text=True,
                           preexec_fn=cpu_limit)
    ran = subprocess.run([*env_cmd, "run", str(p)], capture_output=True, text=True,
                         preexec_fn=cpu_limit)
    assert check.returncode == ran.returncode == 1
    for out in (check.stderr, ran.stderr):
        assert "Traceback" not in out
        assert f"{p}:{line_of(text, BAD[2][0])}: {BAD[2][1]}" in out
        assert f"{p}:{line_of(text, BAD[6][0])}: {BAD[6][1]}" in out
    assert re.search(r"INCOMPLETE: 2 request", check.stdout)


def test_fourbar_flex_frequency_at_every_crank_position() -> None:
    """The example runs whole: one mode per position, the knee held straight, the
    frequency a periodic function of the crank angle (step 12 = step 0)."""
    runs, echo = run(EXAMPLES / "fourbar_flex.imp")
    r = runs[0]
    assert r.ok, (r.failure, r.unsupported)
    f = r.table("PRINT FREQUENCY", "modes").rows
    assert f.shape == (13, 5) and np.allclose(f[:, 3], np.arange(13))
    assert np.all((f[:, 0] > 300) & (f[:, 0] < 450)) and np.ptp(f[:, 0]) > 50
    assert f[0, 0] == pytest.approx(f[12, 0], rel=1e-8)
    assert echo.count("E 1 imp 0.0000 0.000 0.000") == 13
    t = r.table("LIST DYNAMICS", "load on joint E 1")
    # the knee's static compliance: 1 / (20 in lbf per degree), in degrees per in lbf
    assert t.rows[0, 3] == pytest.approx(1 / 20.0, rel=2e-3)


@pytest.mark.parametrize("case", ["inverted", "free"])
def test_real_modes_print_time_constants(tmp_path, case) -> None:
    """Upside down the pendulum has two real modes, one growing (a negative time
    constant); without gravity one mode is neutral (lambda = 0): the roots of
    I s^2 + c s + k with k = -m g l or 0."""
    gravity = "0, 386.088, 0" if case == "inverted" else "0, 0, 0"
    text = PENDULUM.replace("0, -386.088, 0", gravity) + "PRINT FREQUENCY\nEXECUTE\nEND\n"
    runs, echo = run(write(tmp_path, text))
    t = runs[0].table("PRINT FREQUENCY", "modes")
    k = -MGL if case == "inverted" else 0.0
    lam = np.roots([I_PIV, C_PIN, k]).real
    i = echo.index("Vibration Results:")
    if case == "inverted":
        tau = np.sort(-1.0 / lam)
        assert np.allclose(np.sort(t.rows[:, 2]), tau, rtol=1e-8)
        assert np.all(np.isnan(t.rows[:, :2]))
        grow = f"Time constant = {tau[0]:.6g} s (over-damped) (unstable)"
        assert any(ln.endswith(grow) for ln in echo[i + 2:i + 4]), echo[i:i + 4]
    else:
        neutral = t.rows[np.isnan(t.rows[:, 2])]
        assert neutral.shape[0] == 1 and neutral[0, 0] == 0.0
        assert np.nanmax(t.rows[:, 2]) == pytest.approx(I_PIV / C_PIN, rel=1e-8)
        assert any(ln.endswith("Neutral: zero frequency, no restoring load")
                   for ln in echo[i + 2:i + 4])
