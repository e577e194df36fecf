"""IMP static mode (FIND EQUILIB): the example decks and small inline decks, run
end to end (reference imp-language.md §1.2, §2.2, §2.4 and the FIND EQUILIB /
DELETE EQUILIB / ZERO (EQUILIB) rows; book ch 12).

The references are written here in plain numpy and scipy from the numbers in
the decks, never from openimp:

* examples/counterbalanced_arm.imp: the moment balance of an arm under its
  weight and a spring to a fixed anchor, solved by brentq; the joint load by
  the free body of the arm (the weight plus the spring's pull);
* examples/quarter_car.imp: the four-bar of a double-wishbone corner solved by
  circle intersection, its potential (wheel load, unsprung weight, coil spring)
  minimised over the lower arm's angle;
* examples/toggle_clamp.imp: the four-bar of the clamp solved for the arm angle
  at every handle angle, the spindle slide minimising the energy of two springs
  in series, the holding torque dV/dtheta;
* a pendulum wound by a torsion spring (inline): alpha = phi + (m g l / k) sin phi
  and the key's holding torque m g l sin phi.

Static-mode joint loads are the load of the second-named link on the first, on
the first link's joint axes (reference §2.4, settled); kinematic mode the other
way round.  Both are checked on the same equilibrium, with frames turned away
from the global axes so that the axes, not only the signs, are tested.
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
from scipy.optimize import brentq

from helpers.decks import cpu_limit, line_of, run_deck, write
from openimp.imp.deck import load
from openimp.imp.interp import DeckError

ROOT = Path(__file__).parent.parent
EXAMPLES = ROOT / "examples"
DEG = math.pi / 180.0


# =============================================================================
# helpers
# =============================================================================


def search_lines(echo: list[str]) -> list[int]:
    """The N of every 'Equilibrium found after N search steps.' line."""
    out = []
    for ln in echo:
        m = re.fullmatch(r"Equilibrium found after (\d+) search steps\.", ln.strip())
        if m:
            out.append(int(m.group(1)))
    return out


def listing_rows(echo: list[str], header: str) -> np.ndarray:
    """The numbers printed under a LIST header (``????`` as NaN)."""
    i = echo.index(header)
    rows = []
    for line in echo[i + 2:]:
        if not line.strip() or not re.match(r"^\s*-?\d", line):
            break
        rows.append([float("nan") if x == "????" else float(x) for x in line.split()])
    return np.array(rows)


def rot2(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s], [s, c]])


def cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "openimp.cli", *map(str, args)],
                          capture_output=True, text=True, preexec_fn=cpu_limit)


# =============================================================================
# the counterbalanced arm: the moment balance by hand
# =============================================================================
ARM_W, ARM_C, ARM_B, ARM_K, ARM_L0, ARM_TIP = 10.0, 8.0, 6.0, 4.0, 6.0, 12.0
ARM_Q = np.array([-2.0, 10.0])


def arm_spring(theta: float):
    """(S, spring force on the arm (2,), length, tension) at the pin angle theta."""
    S = ARM_B * np.array([math.cos(theta), math.sin(theta)])
    d = ARM_Q - S
    length = float(np.hypot(*d))
    T = ARM_K * (length - ARM_L0)
    return S, T * d / length, length, T


def arm_moment(theta: float) -> float:
    """Moment about the pin of the spring and the weight on the arm."""
    S, f, _, _ = arm_spring(theta)
    return float(S[0] * f[1] - S[1] * f[0]) - ARM_W * ARM_C * math.cos(theta)


def arm_potential(theta: float) -> float:
    _, _, length, _ = arm_spring(theta)
    return ARM_W * ARM_C * math.sin(theta) + 0.5 * ARM_K * (length - ARM_L0) ** 2


ARM_THETA = brentq(arm_moment, 0.5, 1.2, xtol=1e-15)


def test_arm_hand_values_are_the_decks_comments() -> None:
    """The numbers quoted in the deck's $$ comments are the brentq root's."""
    text = (EXAMPLES / "counterbalanced_arm.imp").read_text()
    _, f, length, T = arm_spring(ARM_THETA)
    assert f"theta = {ARM_THETA / DEG:.5f} deg" in text
    h = 1e-4
    d2v = (arm_potential(ARM_THETA + h) - 2 * arm_potential(ARM_THETA)
           + arm_potential(ARM_THETA - h)) / h**2
    assert d2v > 0 and f"+{d2v:.2f} in lbf/rad" in text  # stable
    assert f"l = {length:.5f} in" in text and f"T = {T:.5f} lbf" in text
    assert f"({f[0]:.5f}, {f[1]:.5f}) lbf" in text
    load_ = np.array([0.0, -ARM_W]) + f
    assert f"({load_[0]:.5f}, {load_[1]:.5f}) lbf" in text
    tip = ARM_TIP * np.array([math.cos(ARM_THETA), math.sin(ARM_THETA)])
    assert f"({tip[0]:.5f}, {tip[1]:.5f})" in text
    assert f"{ARM_W * ARM_C * math.cos(ARM_THETA):.4f} in lbf" in text
    # the other roots of the moment balance, and which are stable
    grid = np.linspace(-math.pi, math.pi, 721)
    m = [arm_moment(t) for t in grid]
    roots = [brentq(arm_moment, grid[i], grid[i + 1], xtol=1e-14)
             for i in range(720) if m[i] * m[i + 1] < 0]
    assert len(roots) == 4
    stable = [(arm_potential(t + h) - 2 * arm_potential(t) + arm_potential(t - h)) > 0
              for t in roots]
    assert stable == [False, True, False, True]
    flat = " ".join(text.replace("$$", " ").split())
    assert (f"the other roots: {roots[0] / DEG:.2f} and {roots[2] / DEG:.2f} deg, "
            f"unstable, {roots[3] / DEG:.2f} deg, stable") in flat


@pytest.fixture(scope="module")
def arm():
    runs, echo = run_deck(EXAMPLES / "counterbalanced_arm.imp")
    return runs[0], echo


def test_arm_runs_in_static_mode(arm) -> None:
    r, echo = arm
    assert r.ok, (r.failure, r.unsupported)
    assert r.mode == "static"
    assert any(ln.strip("* ").strip() == "Static Mode" for ln in echo)
    assert not any("Kinematic Mode" in ln for ln in echo)
    steps = search_lines(echo)
    assert len(steps) == 1 and 1 <= steps[0] <= 25


def test_arm_heading_row_is_set_by_imp(arm) -> None:
    _, echo = arm
    i = echo.index("The Generalized Coordinates are:")
    assert echo[i + 1].split()[:6] == ["Joint", "Set", "by", "Position", "Velocity",
                                       "Acceleration"]
    assert echo[i + 1].endswith("[deg, rad/s, rad/s^2 or length, length/s, length/s^2]")
    assert echo[i + 2].split() == ["A", "1", "imp", f"{ARM_THETA / DEG:.4f}", "0.000", "0.000"]
    # the search line follows the heading table, as in the manual's chapter 9
    assert re.fullmatch(r"Equilibrium found after \d+ search steps\.", echo[i + 3])


def test_arm_equilibrium_angle_is_the_moment_balance(arm) -> None:
    r, echo = arm
    row = r.table("PRINT POSITION", "joint A").rows[0]
    assert row[1] == pytest.approx(ARM_THETA / DEG, abs=1e-8)
    assert f"Joint A {ARM_THETA / DEG:.4f} 0.0000 0.0000 0.0000" in echo
    tip = r.table("PRINT POSITION", "point TIP").rows[0]
    np.testing.assert_allclose(tip[2:4], ARM_TIP * np.array([math.cos(ARM_THETA),
                                                            math.sin(ARM_THETA)]), atol=1e-9)


def test_arm_spring_force_and_length(arm) -> None:
    r, echo = arm
    S, _, length, T = arm_spring(ARM_THETA)
    pos = r.table("PRINT POSITION", "spring SP").rows[0]
    assert pos[1] == pytest.approx(length, abs=1e-9)
    np.testing.assert_allclose(pos[2:4], ARM_Q - S, atol=1e-9)  # first end S -> second Q
    force = r.table("PRINT FORCE", "spring SP").rows[0]
    assert force[1] == pytest.approx(T, abs=1e-8)  # tension positive
    assert T > 0 and f"Spg. SP {T:.3f}" in echo


def test_arm_joint_load_is_the_free_body_static_convention(arm) -> None:
    """Load of ARM (second-named) on BASE (first), on BASE's joint axes (global here):
    the arm's weight plus the spring's pull on the arm; no moment about a free pin."""
    r, echo = arm
    _, f, _, _ = arm_spring(ARM_THETA)
    expect = np.array([f[0], f[1] - ARM_W, 0.0, 0.0, 0.0, 0.0])
    row = r.table("PRINT FORCE", "joint A").rows[0]
    np.testing.assert_allclose(row[1:], expect, atol=1e-8)
    mag = float(np.hypot(*expect[:2]))
    i = echo.index("through Joint A from Link BASE onto Link ARM :")
    assert echo[i + 1].split()[:4] == ["Forc", f"{mag:.3f}", f"{expect[0]:.3f}",
                                       f"{expect[1]:.3f}"]


ARM_ROTATED = """TITLE = ARM WITH TURNED FRAMES
ZPIN ({first}, {second}) = A
DATA ZPIN (A) = 0,0,0; {u1}; {u2}
POINT (ARM) = S
POINT (BASE) = Q
DATA POINT (S, ABS) = 6, 0, 0
DATA POINT (Q, ABS) = -2, 10, 0
DATA MASS (ARM, LINK) = 10; 8, 0, 0
DATA GRAVITY = 0, -386.088, 0
SPRING (S, Q) = SP
DATA SPRING (SP) = 4, 6
FIND EQUILIB
PRINT POSITION (A)
PRINT FORCE (A)
EXECUTE HOLD
DELETE EQUILIB
EXECUTE
END
"""


def test_static_joint_load_is_on_the_first_links_axes(tmp_path) -> None:
    """The frame of A on BASE turned by +90 degrees (u along +Y): the static load of
    ARM on BASE is resolved on u = +Y, v = -X; after EXECUTE HOLD and DELETE EQUILIB
    the same posture in kinematic mode gives the load of BASE on ARM on ARM's axes
    (u' along the arm)."""
    p = write(tmp_path, ARM_ROTATED.format(first="BASE", second="ARM", u1="0,1,0",
                                            u2="1,0,0"))
    runs, _ = run_deck(p)
    st, kin = runs
    assert st.ok and kin.ok and st.mode == "static" and kin.mode == "kinematic"
    _, f, _, _ = arm_spring(ARM_THETA)
    F = np.array([f[0], f[1] - ARM_W])  # ARM on BASE, global
    # the joint angle is measured from u (+Y) on BASE: the arm is at theta - 90
    for r in runs:
        assert r.table("PRINT POSITION", "joint A").rows[0, 1] == pytest.approx(
            ARM_THETA / DEG - 90.0, abs=1e-7)
    u, v = np.array([0.0, 1.0]), np.array([-1.0, 0.0])
    np.testing.assert_allclose(st.table("PRINT FORCE", "joint A").rows[0, 1:3],
                               [F @ u, F @ v], atol=1e-8)
    # kinematic mode: BASE on ARM (-F), on ARM's axes u' = along the arm
    u2 = np.array([math.cos(ARM_THETA), math.sin(ARM_THETA)])
    v2 = np.array([-u2[1], u2[0]])
    np.testing.assert_allclose(kin.table("PRINT FORCE", "joint A").rows[0, 1:3],
                               [-F @ u2, -F @ v2], atol=1e-8)


def test_static_joint_load_reversed_joint(tmp_path) -> None:
    """ZPIN (ARM, BASE): the second-named link is now BASE, so the static load is
    BASE's on ARM, on ARM's joint axes (u along the arm), and the joint angle is
    BASE's from ARM (-theta)."""
    p = write(tmp_path, ARM_ROTATED.format(first="ARM", second="BASE", u1="1,0,0",
                                            u2="1,0,0"))
    runs, echo = run_deck(p)
    st = runs[0]
    assert st.ok and st.mode == "static"
    assert st.table("PRINT POSITION", "joint A").rows[0, 1] == pytest.approx(
        -ARM_THETA / DEG, abs=1e-7)
    _, f, _, _ = arm_spring(ARM_THETA)
    F = -np.array([f[0], f[1] - ARM_W])  # BASE on ARM, global
    u = np.array([math.cos(ARM_THETA), math.sin(ARM_THETA)])
    v = np.array([-u[1], u[0]])
    np.testing.assert_allclose(st.table("PRINT FORCE", "joint A").rows[0, 1:3],
                               [F @ u, F @ v], atol=1e-8)
    # the label keeps the definition's order
    assert "through Joint A from Link ARM onto Link BASE :" in echo


def test_arm_json_and_exit_status(tmp_path) -> None:
    out = tmp_path / "arm.json"
    p = cli("run", EXAMPLES / "counterbalanced_arm.imp", "--json", out)
    assert p.returncode == 0, p.stderr
    assert "Traceback" not in p.stderr
    assert "Equilibrium found after" in p.stdout and "Static Mode" in p.stdout
    data = json.loads(out.read_text())
    (run,) = data["runs"]
    assert run["mode"] == "static" and run["title"] == "COUNTERBALANCED ARM"
    assert "failure" not in run
    tables = {(t["request"], t["item"]): t for t in run["tables"]}
    pos = tables[("PRINT POSITION", "joint A")]
    assert pos["columns"][:2] == ["Step", "JVar 1"] and pos["units"][1] == "deg"
    assert pos["rows"][0][1] == pytest.approx(ARM_THETA / DEG, abs=1e-8)
    _, f, _, T = arm_spring(ARM_THETA)
    force = tables[("PRINT FORCE", "joint A")]
    assert force["columns"] == ["Step", "FX", "FY", "FZ", "MX", "MY", "MZ"]
    np.testing.assert_allclose(force["rows"][0][1:3], [f[0], f[1] - ARM_W], atol=1e-8)
    assert tables[("PRINT FORCE", "spring SP")]["rows"][0][1] == pytest.approx(T, abs=1e-8)
    assert ("PRINT HEADING", "generalized coordinates") in tables


# =============================================================================
# EXECUTE HOLD: the next run starts from the equilibrium
# =============================================================================
def test_execute_hold_continues_from_the_equilibrium(tmp_path) -> None:
    text = (EXAMPLES / "counterbalanced_arm.imp").read_text().replace(
        "\nEXECUTE\n", "\nEXECUTE HOLD\nEXECUTE\nDELETE EQUILIB\nEXECUTE\n")
    runs, echo = run_deck(write(tmp_path, text))
    assert [r.mode for r in runs] == ["static", "static", "kinematic"]
    assert all(r.ok for r in runs)
    steps = search_lines(echo)
    assert len(steps) == 2 and steps[0] >= 1
    assert steps[1] == 0  # already at rest: no search step
    assert "*** The current position is set as reference. ***" in echo
    for r in runs:  # the kinematic run holds its free coordinate there too
        assert r.table("PRINT POSITION", "joint A").rows[0, 1] == pytest.approx(
            ARM_THETA / DEG, abs=1e-8)
    np.testing.assert_allclose(runs[1].table("PRINT FORCE", "joint A").rows,
                               runs[0].table("PRINT FORCE", "joint A").rows, atol=1e-9)


# =============================================================================
# the quarter car: a four-bar under the wheel load and a coil spring
# =============================================================================
QC = dict(L0=(0.0, 0.0), L1=(15.0, -1.0), U0=(3.0, 9.0), U1=(13.0, 10.0), SL=(10.0, 0.0),
          SU=(8.0, 16.0), CP=(18.0, -9.0), WC=(18.0, 4.0))
QC_LOAD, QC_K, QC_FREE, QC_MASS = 1000.0, 300.0, 20.5, 90.0


def qc_pose(a: float) -> dict:
    """The corner with the lower arm turned by ``a`` from the drawn position."""
    P = {k: np.array(v) for k, v in QC.items()}
    l1 = P["L0"] + rot2(a) @ (P["L1"] - P["L0"])
    lk = np.linalg.norm(P["U1"] - P["L1"])
    lu = np.linalg.norm(P["U1"] - P["U0"])
    d = np.linalg.norm(P["U0"] - l1)
    x = (lk**2 - lu**2 + d**2) / (2 * d)
    h = math.sqrt(lk**2 - x**2)
    e = (P["U0"] - l1) / d
    n = np.array([-e[1], e[0]])
    # the branch of the drawn position: U1 on the same side of l1 -> U0
    side = np.sign(np.cross(np.append(P["U1"] - P["L1"], 0), np.append(P["U0"] - P["L1"], 0))[2])
    u1 = next(p for p in (l1 + x * e + h * n, l1 + x * e - h * n)
              if np.sign(np.cross(np.append(p - l1, 0), np.append(P["U0"] - l1, 0))[2]) == side)
    g = math.atan2(*(u1 - l1)[::-1]) - math.atan2(*(P["U1"] - P["L1"])[::-1])
    knuckle = lambda p: l1 + rot2(g) @ (p - P["L1"])  # noqa: E731
    sl = P["L0"] + rot2(a) @ (P["SL"] - P["L0"])
    return dict(a=a, cp=knuckle(P["CP"]), wc=knuckle(P["WC"]), sl=sl,
                spring=float(np.linalg.norm(P["SU"] - sl)), u1=u1)


def qc_potential(a: float) -> float:
    p = qc_pose(a)
    return (-QC_LOAD * p["cp"][1] + QC_MASS * p["wc"][1]
            + 0.5 * QC_K * (p["spring"] - QC_FREE) ** 2)


def qc_rest() -> dict:
    h = 1e-6
    dv = lambda a: (qc_potential(a + h) - qc_potential(a - h)) / (2 * h)  # noqa: E731
    return qc_pose(brentq(dv, -0.3, 0.3, xtol=1e-14))


def test_quarter_car_ride_position() -> None:
    runs, echo = run_deck(EXAMPLES / "quarter_car.imp")
    r = runs[0]
    assert r.ok and r.mode == "static", r.failure
    assert len(search_lines(echo)) == 1
    ref = qc_rest()
    text = (EXAMPLES / "quarter_car.imp").read_text()
    flat = " ".join(text.replace("$$", " ").split())
    # the comments' hand values
    lp0 = math.atan2(-1.0, 15.0)
    drawn = math.hypot(10.0 - 8.0, 16.0)
    assert f"spring, {drawn:.4f} in long, pushes with {QC_K * (QC_FREE - drawn):.2f} lbf" in flat
    assert f"a = +{ref['a'] / DEG:.5f} deg" in flat
    assert f"{lp0 / DEG:.5f} + {ref['a'] / DEG:.5f} = {(lp0 + ref['a']) / DEG:.5f} deg" in flat
    assert f"l = {ref['spring']:.5f} in long" in flat
    assert f"300 ({ref['spring']:.5f} - 20.5) = {QC_K * (ref['spring'] - QC_FREE):.2f} lbf" in flat
    assert f"({ref['cp'][0]:.4f}, {ref['cp'][1]:.4f}), {ref['cp'][1] + 9.0:.3f} in above" in flat
    assert r.table("PRINT POSITION", "joint LP").rows[0, 1] == pytest.approx(
        (lp0 + ref["a"]) / DEG, abs=1e-6)
    np.testing.assert_allclose(r.table("PRINT POSITION", "point CP").rows[0, 2:4], ref["cp"],
                               atol=1e-6)
    assert r.table("PRINT POSITION", "spring COIL").rows[0, 1] == pytest.approx(
        ref["spring"], abs=1e-6)
    tension = QC_K * (ref["spring"] - QC_FREE)
    assert tension < 0  # compression
    assert r.table("PRINT FORCE", "spring COIL").rows[0, 1] == pytest.approx(tension, abs=1e-4)
    # the upper arm carries no load of its own: a two-force member, loaded along its
    # line (UBJ's frame on UCA has u toward the inner pivot U0), the same at both ends
    ubj = r.table("PRINT FORCE", "joint UBJ").rows[0]
    assert abs(ubj[2]) < 1e-7 * abs(ubj[1])
    i = echo.index("through Joint UBJ from Link UCA onto Link KNUC :")
    assert echo[i + 1].split()[1] == f"{abs(ubj[1]):.3f}"
    # the lower arm's free body.  Static mode: LP gives LCA's load on BASE on BASE's
    # axes (global); LBJ gives KNUCKLE's load on LCA on LCA's axes at LBJ (u from the
    # ball joint toward the inner pivot, turned with the arm by a); the coil pushes
    # SL away from SU with -T (T < 0, compression)
    lp = r.table("PRINT FORCE", "joint LP").rows[0]
    lbj = r.table("PRINT FORCE", "joint LBJ").rows[0]
    u0 = -np.array(QC["L1"]) / np.linalg.norm(QC["L1"])
    u = rot2(ref["a"]) @ u0
    v = np.array([-u[1], u[0]])
    f_knuckle = lbj[1] * u + lbj[2] * v
    e = (np.array(QC["SU"]) - ref["sl"]) / ref["spring"]
    f_coil = tension * e
    f_base = -lp[1:3]
    np.testing.assert_allclose(f_base + f_knuckle + f_coil, 0.0, atol=1e-6 * QC_LOAD)
    l1 = rot2(ref["a"]) @ np.array(QC["L1"])
    cross = lambda a, b: float(a[0] * b[1] - a[1] * b[0])  # noqa: E731
    moment = cross(l1, f_knuckle) + cross(ref["sl"], f_coil)  # about LP (the origin)
    assert abs(moment) < 1e-6 * QC_LOAD * 15.0
    assert abs(lbj[6]) < 1e-8 * QC_LOAD and abs(lp[6]) < 1e-8 * QC_LOAD  # free pins
    # a planar mechanism of pins: the out-of-plane components are indeterminate
    assert np.isnan(lp[[3, 4, 5]]).all() and np.isfinite(lp[[1, 2, 6]]).all()
    assert "????" in echo[echo.index("through Joint LP from Link BASE onto Link LCA :") + 1]


def test_quarter_car_free_coordinate_is_found_by_imp() -> None:
    _, echo = run_deck(EXAMPLES / "quarter_car.imp")
    i = echo.index("The Generalized Coordinates are:")
    row = echo[i + 2].split()
    assert row[2] == "imp" and row[0] in ("LP", "LBJ", "UBJ", "UP")
    assert echo[i + 3].startswith("Equilibrium found after")


# =============================================================================
# the toggle clamp: a path of handle angles, one equilibrium per position
# =============================================================================
TG_A, TG_C0, TG_AB, TG_BC = np.array([7.0, 2.0]), np.array([2.0, 2.0]), 2.0, 3.0
TG_P0, TG_W = np.array([-8.0, -1.0]), np.array([-8.0, -3.0])
TG_K1, TG_K2, TG_LP = 1000.0, 2000.0, 2.5


def tg_arm(th: float) -> float:
    """The arm's turn from the drawn position at the handle angle th (the branch
    through the toggle at th = pi, arm level)."""
    B = TG_A + TG_AB * np.array([math.cos(th), math.sin(th)])
    f = lambda p: float(np.linalg.norm(rot2(p) @ TG_C0 - B) - TG_BC)  # noqa: E731
    if abs(th - math.pi) < 1e-13:
        return 0.0
    return brentq(f, -0.5, -1e-14, xtol=1e-15)


def tg_tip(th: float, s: float) -> np.ndarray:
    return rot2(tg_arm(th)) @ (TG_P0 + np.array([0.0, s]))


def tg_energy(th: float, s: float) -> float:
    return 0.5 * TG_K1 * s * s + 0.5 * TG_K2 * (np.linalg.norm(tg_tip(th, s) - TG_W) - TG_LP) ** 2


def tg_slide(th: float) -> float:
    """The spindle's rest: dV/ds = 0 (k1 s + pad tension x dl/ds)."""
    R = rot2(tg_arm(th))

    def dv(s: float) -> float:
        d = tg_tip(th, s) - TG_W
        length = np.linalg.norm(d)
        return TG_K1 * s + TG_K2 * (length - TG_LP) * float(d @ (R @ [0.0, 1.0])) / length

    return brentq(dv, -1.0, 1.0, xtol=1e-15)


@pytest.fixture(scope="module")
def toggle():
    runs, echo = run_deck(EXAMPLES / "toggle_clamp.imp")
    return runs[0], echo


def test_toggle_clamp_one_equilibrium_per_position(toggle) -> None:
    r, echo = toggle
    assert r.ok and r.mode == "static", r.failure
    handle = 168.0 + 2.0 * np.arange(9)
    arm = r.table("LIST POSITION", "joint D").rows
    slide = r.table("LIST POSITION", "joint E").rows
    mz = r.table("LIST FORCE", "joint A").rows
    pad = r.table("LIST FORCE", "spring WORK").rows
    for t in (arm, slide, mz, pad):
        np.testing.assert_array_equal(t[:, 0], np.arange(9))  # Step column
    for k, deg in enumerate(handle):
        th = deg * DEG
        s = tg_slide(th)
        # joint D is BASE's angle from ARM: -45 degrees drawn, minus the arm's turn
        assert arm[k, 1] == pytest.approx(-45.0 - tg_arm(th) / DEG, abs=1e-7), deg
        assert slide[k, 1] == pytest.approx(s, abs=1e-8), deg
        length = np.linalg.norm(tg_tip(th, s) - TG_W)
        assert pad[k, 1] == pytest.approx(TG_K2 * (length - TG_LP), abs=1e-5), deg
        h = 1e-5
        hold = (tg_energy(th + h, s) - tg_energy(th - h, s)) / (2 * h)  # dV/dtheta
        # static mode: the load of HAND on BASE, so MZ is minus the hand's torque
        assert mz[k, 6] == pytest.approx(-hold, abs=2e-5 * max(1.0, abs(hold))), deg
    # the clamping force is largest at the toggle: 0.5 in x k1 k2 / (k1 + k2)
    assert pad[6, 1] == pytest.approx(-0.5 * TG_K1 * TG_K2 / (TG_K1 + TG_K2), abs=1e-6)
    assert abs(mz[6, 6]) < 1e-6 and mz[5, 6] < 0 < mz[7, 6]  # zero and over centre
    # the planar pins leave the out-of-plane components indeterminate (????)
    printed = listing_rows(echo, "Listing of force in joint A")
    assert np.isnan(printed[:, 3:6]).all()
    np.testing.assert_allclose(printed[:, 6], mz[:, 6], atol=5e-4)


def test_toggle_clamp_hand_values_and_turning_point(toggle) -> None:
    r, echo = toggle
    text = (EXAMPLES / "toggle_clamp.imp").read_text()
    mz = r.table("LIST FORCE", "joint A").rows[:, 6]
    for k, deg in ((0, 168), (1, 170), (2, 172), (4, 176), (6, 180), (8, 184)):
        th = deg * DEG
        row = (f"{deg}  {tg_arm(th) / DEG:10.5f}  {tg_slide(th):7.5f}  "
               f"{r.table('LIST FORCE', 'spring WORK').rows[k, 1]:9.3f}  {-mz[k]:9.3f}")
        assert " ".join(row.split()) in " ".join(text.split()), row
    # the holding torque peaks at step 2 (172 degrees): reported as a turning point
    k = int(np.argmin(mz))
    assert k == 2
    notes = [ln for ln in echo if "Turning point" in ln and "maximum" in ln]
    assert len(notes) == 1 and "step 2" in notes[0] and f"{-mz[2]:.6g}" in notes[0]


# =============================================================================
# a pendulum wound by a torsion spring: SGC and FGC, paths, the step cap
# =============================================================================
WIND = """TITLE = WOUND PENDULUM
ZPIN (BASE, HUB) = A
ZPIN (HUB, ROD) = B
DATA ZPIN (A) = 0,0,0; 1,0,0; 1,0,0
DATA ZPIN (B) = 0,0,0; 1,0,0; 0,-1,0
DATA MASS (ROD, B) = 2; 10, 0, 0
DATA GRAVITY = 0, -386.088, 0
DATA SPRING (B) = {rate:.10f}, -90
FIND EQUILIB
{zero}
DATA POSITION (A) = 0, 60, 5
PRINT HEADING
LIST POSITION (B)
LIST FORCE (A)
EXECUTE
END
"""
W_MGL, W_K = 2.0 * 10.0, 8.0  # in lbf (2 lbm at 10 in); in lbf per radian


def wind_deck(tmp_path: Path, zero: str = "", name: str = "wind.imp") -> Path:
    return write(tmp_path, WIND.format(rate=W_K * DEG, zero=zero), name)


def wind_check(alpha_deg: np.ndarray, b_deg: np.ndarray, mz: np.ndarray) -> None:
    """alpha = phi + (m g l / k) sin phi (mod 360), the key's torque m g l sin phi."""
    phi = (alpha_deg + b_deg + 90.0) * DEG  # the rod's angle from hanging
    resid = alpha_deg * DEG - phi - (W_MGL / W_K) * np.sin(phi)
    np.testing.assert_allclose(np.angle(np.exp(1j * resid)), 0.0, atol=1e-9)
    np.testing.assert_allclose(mz, -W_MGL * np.sin(phi), atol=1e-8)
    # stable: K = k + m g l cos phi > 0
    assert np.all(W_K + W_MGL * np.cos(phi) > 0)


def test_path_sgc_user_fgc_imp_and_one_equilibrium_per_position(tmp_path) -> None:
    runs, echo = run_deck(wind_deck(tmp_path))
    r = runs[0]
    assert r.ok and r.mode == "static", r.failure
    alpha = 60.0 * np.arange(6)
    user = [ln.split() for ln in echo if re.match(r"^A 1 user ", ln)]
    imp = [ln.split() for ln in echo if re.match(r"^B 1 imp ", ln)]
    assert len(user) == len(imp) == 6
    np.testing.assert_allclose([float(u[3]) for u in user], alpha, atol=5e-5)
    steps = search_lines(echo)
    assert len(steps) == 6 and steps[0] == 0  # the drawn posture hangs at rest
    b = r.table("LIST POSITION", "joint B").rows
    mz = r.table("LIST FORCE", "joint A").rows[:, 6]
    assert b.shape[0] == 6
    np.testing.assert_allclose([float(i[3]) for i in imp], b[:, 1], atol=5e-5)
    wind_check(alpha, b[:, 1], mz)
    # the fold alpha(phi) (1 + (m g l / k) cos phi = 0) lies between 240 and 300:
    # the rod snaps over the top there and lands on the far branch
    phi_f = math.acos(-W_K / W_MGL)
    alpha_f = (phi_f + (W_MGL / W_K) * math.sin(phi_f)) / DEG
    assert 240.0 < alpha_f < 300.0
    phi = (alpha + b[:, 1] + 90.0)
    assert phi[4] < phi_f / DEG and np.sin(phi[5] * DEG) < 0


def test_zero_equilib_step_cap_stops_and_keeps_the_earlier_positions(tmp_path) -> None:
    cap = 2
    full, echo_full = run_deck(wind_deck(tmp_path, name="full.imp"))
    need = search_lines(echo_full)
    k = next(i for i, n in enumerate(need) if n > cap)  # the first step the cap cuts
    p = wind_deck(tmp_path, zero=f"ZERO (EQUILIB) = 0.001, {cap}")
    runs, echo = run_deck(p)
    r = runs[0]
    assert not r.ok and r.mode == "static"
    line = line_of(p.read_text(), "EXECUTE")
    assert r.failure.startswith(f"{p}:{line}: EXECUTE: step {k}: ")
    assert f"equilibrium not found in {cap} search steps (the step cap)" in r.failure
    assert "B.theta" in r.failure  # the free coordinate left unbalanced is named
    assert f"the {k} equilibrium position(s) before it are listed" in r.failure
    assert any(r.failure in ln for ln in echo)
    assert search_lines(echo) == need[:k]
    # the positions before the stop are kept and are those of the uncapped run
    for item in ("LIST POSITION", "joint B"), ("LIST FORCE", "joint A"):
        rows = r.table(*item).rows
        assert rows.shape[0] == k
        np.testing.assert_allclose(rows, full[0].table(*item).rows[:k], atol=1e-9)
    # the command line: exit status 1, the message on stderr, what was solved printed
    c = cli("run", p)
    assert c.returncode == 1, c.stderr
    assert "Traceback" not in c.stderr
    assert "the step cap" in c.stderr and "Listing of position of joint B" in c.stdout


def test_data_motion_values_are_the_sgcs(tmp_path) -> None:
    text = WIND.format(rate=W_K * DEG, zero="VALUE (TURN) = PI*T/3\nDATA TIME = 3, 0, 1").replace(
        "DATA POSITION (A) = 0, 60, 5", "DATA MOTION (A) = TURN")
    runs, echo = run_deck(write(tmp_path, text))
    r = runs[0]
    assert r.ok and r.mode == "static", r.failure
    b = r.table("LIST POSITION", "joint B").rows
    np.testing.assert_allclose(b[:, 0], [0.0, 1.0, 2.0, 3.0])  # Time
    assert r.table("LIST POSITION", "joint B").columns[0] == "Time"
    assert len(search_lines(echo)) == 4
    wind_check(60.0 * np.arange(4), b[:, 1], r.table("LIST FORCE", "joint A").rows[:, 6])


# =============================================================================
# refusals
# =============================================================================
HEAD = """TITLE = REFUSED
ZPIN (BASE, ARM) = A
DATA ZPIN (A) = 0,0,0; 1,0,0; 1,0,0
DATA MASS (ARM, A) = 10; 8, 0, 0
DATA GRAVITY = 0, -386.088, 0
"""


@pytest.mark.parametrize("body,bad,word", [
    ("DATA POSITION (A) = 0, 10, 2\nDATA VELOCITY (A) = 1\nFIND EQUILIB\nEXECUTE\n",
     "FIND EQUILIB", "FIND EQUILIB in kinematic mode"),
    ("FIND EQUILIB\nDATA POSITION (A) = 0, 10, 2\nDATA VELOCITY (A) = 1\nEXECUTE\n",
     "DATA VELOCITY", "not allowed after FIND EQUILIB"),
    ("FIND EQUILIB\nDATA POSITION (A) = 0, 10, 2\nDATA ACCEL (A) = 1\nEXECUTE\n",
     "DATA ACCEL", "not allowed after FIND EQUILIB"),
    ("FIND EQUILIB\nFIND DYNAMICS\nEXECUTE\n", "FIND DYNAMICS", "after FIND EQUILIB"),
], ids=["find-after-velocity", "velocity-after-find", "accel-after-find", "dynamics"])
def test_static_mode_refusals_are_located(tmp_path, body: str, bad: str, word: str) -> None:
    """Refused at their line; FIND in the wrong mode, which IMP passed over with a
    message, only when the deck is read strictly (test_imp_tolerance)."""
    p = write(tmp_path, HEAD + body + "END\n")
    passed = bad.startswith("FIND")
    with pytest.raises(DeckError) as exc:
        load(p, strict=passed)
    line = line_of(p.read_text(), bad)
    assert str(exc.value).startswith(f"{p}:{line}: "), str(exc.value)
    assert word in str(exc.value)
    c = cli("run", *(["--strict"] if passed else []), p)
    assert c.returncode == 2 and f"{p}:{line}: " in c.stderr and c.stdout == ""
    assert "Traceback" not in c.stderr


def test_delete_input_all_then_find_equilib(tmp_path) -> None:
    """After a kinematic run, DELETE INPUT (ALL) lets FIND EQUILIB in: the pendulum
    (a torsion spring of 0.5 in lbf/deg in the pin) then hangs where
    k theta = -W c cos theta."""
    body = ("DATA SPRING (A) = 0.5, 0\nPRINT POSITION (A)\nEXECUTE\nDELETE INPUT (ALL)\n"
            "FIND EQUILIB\nEXECUTE\n")
    runs, echo = run_deck(write(tmp_path, HEAD + body + "END\n"))
    assert [r.mode for r in runs] == ["kinematic", "static"]
    k = 0.5 / DEG
    theta = brentq(lambda t: k * t + 10.0 * 8.0 * math.cos(t), -math.pi / 2, 0.0, xtol=1e-15)
    assert runs[0].table("PRINT POSITION", "joint A").rows[0, 1] == 0.0
    assert runs[1].table("PRINT POSITION", "joint A").rows[0, 1] == pytest.approx(
        theta / DEG, abs=1e-8)
    assert len(search_lines(echo)) == 1


# =============================================================================
# bugs found while writing these tests (fixed): VALUE-of-time loads while searching,
# turning points in the listing's names and units
# =============================================================================
RAMP = """TITLE = ARM UNDER A RAMPED TIP LOAD
ZPIN (BASE, ARM) = A
DATA ZPIN (A) = 0,0,0; 1,0,0; 1,0,0
POINT (ARM) = TIP
POINT (BASE) = F1, F2
DATA POINT (TIP, ABS) = 12, 0, 0
DATA POINT (F1, ABS) = 0, 1, 0
DATA POINT (F2, ABS) = 0, 0, 0
DATA MASS (ARM, A) = 10; 8, 0, 0
DATA GRAVITY = 0, -386.088, 0
DATA SPRING (A) = 1, 0
FORCE (TIP / F1, F2) = PUSH
VALUE (RAMP) = 2*T
DATA FORCE (PUSH) = RAMP
DATA TIME = 3, 0, 1
FIND EQUILIB
LIST POSITION (A)
LIST FORCE (A)
EXECUTE
END
"""


def test_value_of_time_load_is_applied_while_searching(tmp_path) -> None:
    """A tip load 2 T lbf (down) on the arm of a pin with a torsion spring of 1 in lbf
    per degree: the rest at each time solves k theta + (W c + 24 T) cos theta = 0."""
    runs, _ = run_deck(write(tmp_path, RAMP))
    r = runs[0]
    assert r.ok and r.mode == "static", r.failure
    k = 1.0 / DEG
    expect = [brentq(lambda t, P=2.0 * T: k * t + (80.0 + 12.0 * P) * math.cos(t),
                     -math.pi / 2, 0.0, xtol=1e-15) / DEG for T in range(4)]
    got = r.table("LIST POSITION", "joint A").rows[:, 1]
    assert got[0] == pytest.approx(expect[0], abs=1e-6)  # t = 0: no load yet (passes)
    np.testing.assert_allclose(got, expect, atol=1e-6)   # t = 1, 2, 3: the ramp


ONE_SIDED = """TITLE = ARM ON A ONE-SIDED TORSION SPRING
ZPIN (BASE, ARM) = A
DATA ZPIN (A) = 0,0,0; 1,0,0; 1,0,0
DATA MASS (ARM, A) = 10; 8, 0, 0
DATA GRAVITY = 0, -386.088, 0
VALUE (RATE) = IF(POSITION(A,1):{k},0,0)
DATA SPRING (A) = RATE, 0
FIND EQUILIB
LIST POSITION (A)
EXECUTE
END
"""


@pytest.mark.parametrize("k", [1000.0, 300.0])
def test_element_data_read_the_posture_while_searching(tmp_path, k) -> None:
    """A torsion spring that acts only below the horizontal (rate IF(POSITION(A,1):k,0,0)
    per radian, the chapter-9 idiom of tyres and bumpers): the arm (80 in lbf of
    gravity moment at 0) comes to rest where k theta + 80 cos theta = 0.  Before, the
    VALUE was undefined while searching (0 used): the arm hung straight down."""
    runs, echo = run_deck(write(tmp_path, ONE_SIDED.format(k=k)))
    r = runs[0]
    assert r.ok and r.mode == "static", r.failure
    expect = brentq(lambda t: k * t + 80.0 * math.cos(t), -math.pi / 2, 0.0, xtol=1e-15)
    got = r.table("LIST POSITION", "joint A").rows[0, 1]
    assert got == pytest.approx(expect / DEG, abs=1e-6)
    assert not any("undefined" in ln for ln in echo), [ln for ln in echo if "undefined" in ln]


def test_turning_point_note_is_in_the_listings_units(toggle) -> None:
    _, echo = toggle
    note = next(ln for ln in echo if "Turning point" in ln and "maximum" in ln)
    assert "172" in note and "3.00197" not in note


# =============================================================================
# second review: a static path stays on its assembly branch; reach and names
# =============================================================================
def test_a_step_beyond_any_reach_is_refused_not_followed(tmp_path) -> None:
    """DATA POSITION (A) = 9223372036854775808, ... (a fuzzed deck): the first step would
    move the handle by 1.6e17 rad in 0.05 rad sub-steps (a hang); it is refused at once
    with the input in IMP's terms (degrees, the joint's name)."""
    text = re.sub(r"DATA POSITION \(A\) = [^\n]*", "DATA POSITION (A) = 9223372036854775808, "
                  "3.011, 3.267", (EXAMPLES / "toggle_clamp.imp").read_text())
    runs, _ = run_deck(write(tmp_path, text, "far.imp"))
    r = runs[0]
    assert "move too far in one step" in r.failure, r.failure
    assert re.search(r"from A = 180\.0000 deg to A = 922337203\d{10}\.\d{4} deg", r.failure), \
        r.failure
    assert "A.theta" not in r.failure


def test_toggle_path_stays_on_its_branch_and_stops_at_its_reach(tmp_path) -> None:
    """The toggle clamp's handle stepped past 218 degrees: the path flipped to the other
    assembly of the four-bar at 228 (the closure's predictor did not move the dependent
    variables).  The four-bar's D is set by A alone, so a kinematic run of the same deck
    (an independent solution of the loop) must give the same D at every step; past
    the four-bar's reach the run stops with the input in IMP's terms."""
    text = re.sub(r"DATA POSITION \(A\) = [^\n]*", "DATA POSITION (A) = 168, 10, 8",
                  (EXAMPLES / "toggle_clamp.imp").read_text())
    runs, echo = run_deck(write(tmp_path, text, "static.imp"))
    kin, _ = run_deck(write(tmp_path, text.replace("FIND EQUILIB", ""), "kin.imp"))
    r, k = runs[0], kin[0]
    Ds = r.table("LIST POSITION", "joint D").rows
    Dk = k.table("LIST POSITION", "joint D").rows
    assert Ds.shape[0] == 7  # 168 .. 228; 238 is beyond the linkage
    np.testing.assert_allclose(Ds[:, 1], Dk[:7, 1], atol=1e-6)
    assert "cannot be assembled with A = 238.0000 deg" in r.failure
    assert "A.theta" not in r.failure
    # no false limit load from a flipped branch: the hand torque grows to the end
    mz = r.table("LIST FORCE", "joint A").rows[:, 6]
    assert np.all(np.diff(mz[3:]) < 0)
    assert not any("passes a maximum" in ln and "step 5" in ln for ln in echo)


def test_static_heading_json_has_the_free_coordinates(tmp_path) -> None:
    """--json's PRINT HEADING table of a static run carries the FGCs found and the search
    steps, as the printed heading does."""
    runs, echo = run_deck(EXAMPLES / "counterbalanced_arm.imp")
    t = runs[0].table("PRINT HEADING", "generalized coordinates")
    assert "A 1" in t.columns and "Search steps" in t.columns
    row = t.rows[0]
    assert row[t.columns.index("A 1")] == pytest.approx(47.15299306, abs=1e-6)
    assert int(row[t.columns.index("Search steps")]) == search_lines(echo)[0]


@pytest.mark.parametrize("deck", ["counterbalanced_arm.imp", "toggle_clamp.imp",
                                  "fourbar_spring.imp"])
def test_runs_use_the_current_names(deck) -> None:
    """The runners call the analyses by their current names: a static path, a static
    search and a kinematic run with forces print no DeprecationWarning."""
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)
        runs, _ = run_deck(EXAMPLES / deck)
    assert all(r.ok for r in runs), [(r.failure, r.unsupported) for r in runs]
