"""IMP decks run end to end against closed forms (reference: imp-language.md).

Every deck below is written from the IMP reference (tests/decks/run_*.imp or
inline).  The references are computed here with plain numpy from the link
dimensions given in the decks (no openimp code):

* four-bar: B on the crank circle, C the intersection of the circles about B
  (coupler) and D (rocker), on the branch of the design position;
* slider-crank: x_C = cos(theta) + sqrt(l^2 - (e - sin(theta))^2);
* two-slider 2-DOF: the tip is the intersection of the circles about the two
  slider pins;
* RSUR: the rocker angle solves A cos(psi) + B sin(psi) = C (the coupler
  length equation), the coupler orientation follows from its line and the
  Hooke pin square to it and to the rocker axis;
* gear train: theta2 = -(R1/R2) theta1, theta3 = -(R2/R3) theta2;
* Hooke coupling: tan(phi_out) = tan(phi_in) / cos(beta), the pins square to
  their shafts and to each other.

Rates come from 5-point central differences of the closed forms in the crank
angle: d/dt = f' omega, d2/dt2 = f'' omega^2 + f' alpha.

Each LIST table is checked twice: its printed digits (%.3f, the listing text)
within half a unit of the last digit, and its full-precision rows (the
``Run`` tables, the same ones written by --json) to 1e-7.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

from openimp import Model
from openimp.imp.deck import load
from openimp.imp.interp import DeckError

DECKS = Path(__file__).parent / "decks"
EXAMPLES = Path(__file__).parent.parent / "examples"
TOL = 1e-7


# =============================================================================
# helpers
# =============================================================================
def d1(f, x: float, h: float = 1e-3):
    """5-point first derivative."""
    return (-f(x + 2 * h) + 8 * f(x + h) - 8 * f(x - h) + f(x - 2 * h)) / (12 * h)


def d2(f, x: float, h: float = 1e-3):
    """5-point second derivative."""
    return (-f(x + 2 * h) + 16 * f(x + h) - 30 * f(x) + 16 * f(x - h) - f(x - 2 * h)) / (
        12 * h * h)


def wrap_deg(x):
    return (np.asarray(x) + 180.0) % 360.0 - 180.0


def run_deck(path: Path | str, **kw):
    deck = load(path)
    echo: list[str] = []
    runs = deck.run(echo=echo.append, **kw)
    return deck, runs, echo


def listing_rows(echo: list[str], header: str) -> np.ndarray:
    """The numbers printed under a listing header (the %.3f text)."""
    i = echo.index(header)
    rows = []
    for line in echo[i + 2:]:
        if not line.strip() or not re.match(r"^\s*-?\d", line):
            break
        rows.append([float(x) for x in line.split()])
    return np.array(rows)


def check_table(run, echo, request: str, item: str, expected: np.ndarray,
                angles: bool = False) -> None:
    """Full-precision rows and printed digits of a LIST table against ``expected``
    (steps x columns, without the time column)."""
    t = run.table(request, item)
    got = t.rows[:, 1:]
    assert got.shape == expected.shape, (item, got.shape, expected.shape)
    diff = wrap_deg(got - expected) if angles else got - expected
    assert np.max(np.abs(diff)) < TOL * max(1.0, float(np.max(np.abs(expected)))), \
        (request, item, np.max(np.abs(diff)))
    if request.startswith("LIST"):
        word = {"POSITION": "position", "VELOCITY": "velocity", "ACCEL": "acceleration"}[
            request.split()[1]]
        printed = listing_rows(echo, f"Listing of {word} of {item}")[:, 1:]
        pd = wrap_deg(printed - expected) if angles else printed - expected
        # half a unit of the last printed digit, plus the reference's own
        # finite-difference error on large values (1e-8 relative)
        allow = 0.0005 + 1e-8 * max(1.0, float(np.max(np.abs(expected))))
        assert np.max(np.abs(pd)) <= allow, (request, item, np.max(np.abs(pd)))


# =============================================================================
# four-bar
# =============================================================================
FB_D = np.array([4.0, 0.0])
FB_B0 = np.array([1.0, 0.0])
FB_C0 = np.array([3.0, 3.0])
FB_P0 = np.array([2.5, 4.0])
FB_Q = np.array([0.0, 5.0])
FB_b = float(np.linalg.norm(FB_C0 - FB_B0))
FB_c = float(np.linalg.norm(FB_C0 - FB_D))
PHI0 = math.atan2(FB_C0[1] - FB_B0[1], FB_C0[0] - FB_B0[0])


def rot2(a: float) -> np.ndarray:
    return np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])


def fourbar(th: float) -> dict[str, np.ndarray | float]:
    B = np.array([math.cos(th), math.sin(th)])
    d = FB_D - B
    dist = float(np.linalg.norm(d))
    e = d / dist
    along = (FB_b**2 - FB_c**2 + dist**2) / (2 * dist)
    h = math.sqrt(FB_b**2 - along**2)
    C = B + along * e + h * np.array([-e[1], e[0]])
    phi = math.atan2(C[1] - B[1], C[0] - B[0])
    phi_cd = math.atan2(FB_D[1] - C[1], FB_D[0] - C[0])
    phi_dc = math.atan2(C[1] - FB_D[1], C[0] - FB_D[0])
    P = B + rot2(phi - PHI0) @ (FB_P0 - FB_B0)
    return {"B": B, "C": C, "phi": phi, "P": P,
            "jB": phi - th, "jC": phi_cd - phi, "jD": -phi_dc,
            "L": float(np.linalg.norm(FB_Q - P))}


def fb_scalar(key: str):
    def f(th):
        v = fourbar(th)[key]
        return v
    return f


def ang_fn(key: str, th0: float):
    """An angle of the four-bar as a smooth function near th0 (no wrap)."""
    ref = fourbar(th0)[key]

    def f(th):
        v = fourbar(th)[key]
        return ref + (v - ref + math.pi) % (2 * math.pi) - math.pi
    return f


@pytest.fixture(scope="module")
def fourbar_run():
    return run_deck(DECKS / "run_fourbar.imp")


def test_fourbar_positions(fourbar_run) -> None:
    _deck, runs, echo = fourbar_run
    assert len(runs) == 1 and runs[0].ok and runs[0].mode == "kinematic"
    run = runs[0]
    th = np.radians(np.arange(0, 361, 15.0))
    sol = [fourbar(t) for t in th]
    check_table(run, echo, "LIST POSITION", "joint A", np.degrees(th)[:, None], angles=True)
    for key, name in (("jB", "B"), ("jC", "C"), ("jD", "D")):
        exp = np.degrees([s[key] for s in sol])[:, None]
        check_table(run, echo, "LIST POSITION", f"joint {name}", exp, angles=True)
    P = np.array([[*s["P"], 0.0] for s in sol])
    check_table(run, echo, "LIST POSITION", "point CP", P)
    check_table(run, echo, "LIST POSITION", "spring SP", np.array([[s["L"]] for s in sol]))
    # the coupler's 4x4: rotation by phi - phi0 about z, translation B - R B0
    T = run.table("LIST POSITION", "link COUP").rows[:, 1:].reshape(-1, 3, 4)
    for k, s in enumerate(sol):
        R = rot2(s["phi"] - PHI0)
        assert np.allclose(T[k, :2, :2], R, atol=TOL)
        assert np.allclose(T[k, :2, 3], s["B"] - R @ FB_B0, atol=TOL)
        assert np.allclose(T[k, 2], [0, 0, 1, 0], atol=TOL)


def test_fourbar_rates(fourbar_run) -> None:
    _deck, runs, echo = fourbar_run
    run = runs[0]
    w, al = 10.0, 2.0
    th = np.radians(np.arange(0, 361, 15.0))
    for key, name in (("jB", "B"), ("jC", "C"), ("jD", "D")):
        vel = np.array([[d1(ang_fn(key, t), t) * w] for t in th])
        acc = np.array([[d2(ang_fn(key, t), t) * w * w + d1(ang_fn(key, t), t) * al]
                        for t in th])
        check_table(run, echo, "LIST VELOCITY", f"joint {name}", vel)
        check_table(run, echo, "LIST ACCEL", f"joint {name}", acc)
    P = fb_scalar("P")
    vel = np.array([[*(d1(P, t) * w), 0.0] for t in th])
    acc = np.array([[*(d2(P, t) * w * w + d1(P, t) * al), 0.0] for t in th])
    check_table(run, echo, "LIST VELOCITY", "point CP", vel)
    check_table(run, echo, "LIST ACCEL", "point CP", acc)
    L = fb_scalar("L")
    check_table(run, echo, "LIST VELOCITY", "spring SP", np.array([[d1(L, t) * w] for t in th]))
    check_table(run, echo, "LIST ACCEL", "spring SP",
                np.array([[d2(L, t) * w * w + d1(L, t) * al] for t in th]))


def test_fourbar_link_rates(fourbar_run) -> None:
    """Link velocity: angular velocity + velocity of the body point at the origin;
    acceleration: angular acceleration + d/dt of that velocity (reference §9)."""
    _deck, runs, _echo = fourbar_run
    run = runs[0]
    w, al = 10.0, 2.0
    th = np.radians(np.arange(0, 361, 15.0))

    def U(t):  # velocity of the body point at the origin per unit crank rate
        B = fourbar(t)["B"]
        dphi = d1(ang_fn("phi", t), t)
        return d1(fb_scalar("B"), t) + dphi * np.array([B[1], -B[0]])

    V = run.table("LIST VELOCITY", "link COUP")
    A = run.table("LIST ACCEL", "link COUP")
    assert V.columns[1:] == ["OmegaX", "OmegaY", "OmegaZ", "VX", "VY", "VZ"]
    for k, t in enumerate(th):
        dphi = d1(ang_fn("phi", t), t)
        ddphi = d2(ang_fn("phi", t), t)
        assert np.allclose(V.rows[k, 1:4], [0, 0, dphi * w], atol=1e-7)
        assert np.allclose(V.rows[k, 4:6], U(t) * w, atol=1e-7)
        assert np.allclose(A.rows[k, 1:4], [0, 0, ddphi * w * w + dphi * al], atol=1e-6)
        assert np.allclose(A.rows[k, 4:6], d1(U, t) * w * w + U(t) * al, atol=1e-6)


def test_fourbar_deck_api(fourbar_run) -> None:
    deck, runs, echo = fourbar_run
    assert isinstance(deck.model, Model)
    assert set(deck.model.joints) == {"A", "B", "C", "D"}
    assert deck.model.joints["A"].kind.name == "revolute"
    assert deck.model.ground == "BASE"
    assert [r.keyword for r in deck.requests] == ["LIST POSITION", "LIST VELOCITY",
                                                   "LIST ACCEL"]
    assert deck.statements[0].keyword == "TITLE"
    assert "springs" in deck.model.extras and "SP" in deck.model.extras["springs"]
    assert deck.title == "FOUR-BAR FOR TESTS"
    # the same tables when run again
    again = deck.run()
    assert np.array_equal(again[0].table("LIST POSITION", "joint D").rows,
                          runs[0].table("LIST POSITION", "joint D").rows)
    assert "*** 'DATA TIME = 24.00000, 0.00000, 1.00000' is assumed. ***" in echo
    assert "Listing of position of joint A" in echo


def test_fourbar_example_matches() -> None:
    """The README's example deck gives the same rocker angles."""
    _deck, runs, echo = run_deck(EXAMPLES / "fourbar.imp")
    th = np.radians(np.arange(0, 361, 15.0))
    exp = np.degrees([fourbar(t)["jD"] for t in th])[:, None]
    check_table(runs[0], echo, "LIST POSITION", "joint D", exp, angles=True)


# =============================================================================
# slider-crank
# =============================================================================
SC_C0 = np.array([3.958040, 0.5])
SC_L = float(np.linalg.norm(SC_C0 - np.array([1.0, 0.0])))


def sc_x(th: float) -> float:
    return math.cos(th) + math.sqrt(SC_L**2 - (0.5 - math.sin(th)) ** 2)


def test_slider_crank(tmp_path) -> None:
    _deck, runs, echo = run_deck(DECKS / "run_slidercrank.imp", out_dir=tmp_path)
    run = runs[0]
    assert run.ok
    w, al = 188.5, -30.0
    th = np.radians(np.arange(0, 361, 10.0))
    x = np.array([sc_x(t) for t in th])
    check_table(run, echo, "LIST POSITION", "joint D", (x - SC_C0[0])[:, None])
    check_table(run, echo, "LIST POSITION", "point PC",
                np.column_stack([x, np.full_like(x, 0.5), np.zeros_like(x)]))
    check_table(run, echo, "LIST VELOCITY", "joint D",
                np.array([[d1(sc_x, t) * w] for t in th]))
    check_table(run, echo, "LIST ACCEL", "joint D",
                np.array([[d2(sc_x, t) * w * w + d1(sc_x, t) * al] for t in th]))
    # PRINT HEADING / PRINT POSITION text per position (reference 2.4)
    assert "The Generalized Coordinates are:" in echo
    assert "A 1 user 10.0000 188.500 -30.000" in echo
    k = echo.index("step = 1")  # no DATA TIME: PRINT numbers the steps
    block = echo[k:k + 12]
    assert any(line.startswith("Degree of freedom = 1. Quality index = ") for line in block)
    assert "Joint A 10.0000 0.0000 0.0000 0.0000" in block
    pc = next(line for line in block if line.startswith("Point PC ")).split()
    assert float(pc[3]) == pytest.approx(sc_x(math.radians(10)), abs=5e-5)
    # PRINT tables are in the run too (full precision for --json)
    t = run.table("PRINT POSITION", "point PC")
    assert t.columns == ["Step", "Magnitude", "X", "Y", "Z"]
    # STORE writes its file in the output directory
    store = (tmp_path / "run_slidercrank_store.txt").read_text()
    assert "# STORE POSITION joint D" in store
    rows = [line.split() for line in store.splitlines() if not line.startswith("#")]
    assert len(rows) == 37
    assert float(rows[9][1]) == pytest.approx(sc_x(math.pi / 2) - SC_C0[0], abs=1e-8)


def test_print_position_joint_rows_give_the_second_frames_origin(tmp_path) -> None:
    """PRINT POSITION of a joint lists, after its variable, the global origin of its
    second frame (imp-language.md, settled; the sliding piston's frame here), not the
    first's (fixed on the base at the slider's modeling position)."""
    text = (DECKS / "run_slidercrank.imp").read_text().replace(
        "PRINT POSITION (A, PC)", "PRINT POSITION (A, D, PC)")
    deck = tmp_path / "sc.imp"
    deck.write_text(text)
    _deck, runs, _echo = run_deck(deck, out_dir=tmp_path)
    t = runs[0].table("PRINT POSITION", "joint D")
    x = np.array([sc_x(th) for th in np.radians(np.arange(0, 361, 10.0))])
    cols = {c: np.asarray(t.rows, float)[:, k] for k, c in enumerate(t.columns)}
    np.testing.assert_allclose(cols["X"], x, rtol=0, atol=1e-9)
    np.testing.assert_allclose(cols["Y"], 0.5, rtol=0, atol=1e-12)
    np.testing.assert_allclose(cols["JVar 1"], x - SC_C0[0], rtol=0, atol=1e-9)


# =============================================================================
# two-slider 2-DOF planar linkage
# =============================================================================
TS_A = math.sqrt(1 + 2.5**2)
TS_B = math.sqrt(3**2 + 0.5**2)


def ts_tip(x: float, y: float) -> np.ndarray:
    S1 = np.array([2.0 + x, 0.0])
    S2 = np.array([0.0, 2.0 + y])
    d = S2 - S1
    dist = float(np.linalg.norm(d))
    e = d / dist
    along = (TS_A**2 - TS_B**2 + dist**2) / (2 * dist)
    h = math.sqrt(TS_A**2 - along**2)
    return S1 + along * e - h * np.array([-e[1], e[0]])


def test_two_slider_two_dof() -> None:
    _deck, runs, echo = run_deck(DECKS / "run_twoslider.imp")
    run = runs[0]
    assert run.ok
    k = np.arange(11)
    xs, ys = 0.05 * k, -0.04 * k
    T = np.array([ts_tip(x, y) for x, y in zip(xs, ys)])
    check_table(run, echo, "LIST POSITION", "joint JX", xs[:, None])
    check_table(run, echo, "LIST POSITION", "joint JY", ys[:, None])
    check_table(run, echo, "LIST POSITION", "point T", np.column_stack([T, np.zeros(11)]))
    p1 = np.degrees(np.arctan2(T[:, 1], T[:, 0] - (2 + xs)))
    check_table(run, echo, "LIST POSITION", "joint P1", p1[:, None], angles=True)
    # velocity: (T - S1).(T' - S1') = 0 and (T - S2).(T' - S2') = 0
    V = []
    for (x, y), t in zip(zip(xs, ys), T):
        S1, S2 = np.array([2 + x, 0.0]), np.array([0.0, 2 + y])
        M = np.array([t - S1, t - S2])
        rhs = np.array([(t - S1) @ [0.5, 0.0], (t - S2) @ [0.0, -0.4]])
        V.append([*np.linalg.solve(M, rhs), 0.0])
    check_table(run, echo, "LIST VELOCITY", "point T", np.array(V))


# =============================================================================
# spatial RSUR with SPHERE and UJOINT
# =============================================================================
RS_D = np.array([0.0, 3.0, 2.5])
RS_RHO = 2.5
RS_C0 = np.array([0.0, 0.5, 2.5])
RS_B0 = np.array([1.0, 0.0, 0.0])
RS_L = float(np.linalg.norm(RS_C0 - RS_B0))
X = np.array([1.0, 0.0, 0.0])


def rs_psi(th: float, near: float = math.pi / 2) -> float:
    B = np.array([math.cos(th), math.sin(th), 0.0])
    g = RS_D - B
    A = 2 * RS_RHO * g[2]
    Bs = -2 * RS_RHO * g[1]
    Cc = RS_L**2 - g @ g - RS_RHO**2
    base = math.atan2(Bs, A)
    off = math.acos(Cc / math.hypot(A, Bs))
    cands = [base + off, base - off]
    return min(cands, key=lambda p: abs((p - near + math.pi) % (2 * math.pi) - math.pi))


def rs_C(th: float) -> np.ndarray:
    p = rs_psi(th)
    return RS_D + RS_RHO * np.array([0.0, -math.sin(p), math.cos(p)])


def _unit(v):
    return v / np.linalg.norm(v)


def rs_coupler(th: float) -> np.ndarray:
    """Rotation of the coupler from the design position."""
    B = np.array([math.cos(th), math.sin(th), 0.0])
    n = _unit(rs_C(th) - B)
    w = _unit(np.cross(X, n))
    n0 = _unit(RS_C0 - RS_B0)
    w0 = _unit(np.cross(X, n0))
    F = np.column_stack([n, w, np.cross(n, w)])
    F0 = np.column_stack([n0, w0, np.cross(n0, w0)])
    return F @ F0.T


def cardan(R: np.ndarray) -> np.ndarray:
    return np.degrees([math.atan2(-R[1, 2], R[2, 2]), math.asin(max(-1, min(1, R[0, 2]))),
                       math.atan2(-R[0, 1], R[0, 0])])


def Rz3(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])


def angle_about(a: np.ndarray, b: np.ndarray, axis: np.ndarray) -> float:
    return math.atan2(np.cross(a, b) @ axis, a @ b)


def test_rsur_sphere_ujoint() -> None:
    _deck, runs, echo = run_deck(DECKS / "run_rsur.imp")
    run = runs[0]
    assert run.ok
    w, al = 2.0, 0.5
    th = np.radians(np.arange(0, 361, 10.0))
    check_table(run, echo, "LIST POSITION", "joint R2",
                np.degrees([rs_psi(t) for t in th])[:, None], angles=True)
    check_table(run, echo, "LIST POSITION", "point C", np.array([rs_C(t) for t in th]))

    def psi_s(t):
        return rs_psi(t)
    check_table(run, echo, "LIST VELOCITY", "joint R2", np.array([[d1(psi_s, t) * w]
                                                                  for t in th]))
    check_table(run, echo, "LIST ACCEL", "joint R2",
                np.array([[d2(psi_s, t) * w * w + d1(psi_s, t) * al] for t in th]))
    check_table(run, echo, "LIST VELOCITY", "point C", np.array([d1(rs_C, t) * w for t in th]))
    check_table(run, echo, "LIST ACCEL", "point C",
                np.array([d2(rs_C, t) * w * w + d1(rs_C, t) * al for t in th]))
    # SPHERE: x-y'-z'' angles of the coupler in the crank (both frames global at design)
    S = np.array([cardan(Rz3(t).T @ rs_coupler(t)) for t in th])
    check_table(run, echo, "LIST POSITION", "joint S", S, angles=True)
    # UJOINT: phi1 = u -> t about w (coupler pin), phi2 = t -> u' about w' (rocker pin)
    n0 = _unit(RS_C0 - RS_B0)
    w10 = _unit(np.cross(X, n0))
    u0 = _unit(np.cross(w10, X))
    U = []
    for t in th:
        Rc = rs_coupler(t)
        w1, u = Rc @ w10, Rc @ u0
        tt = _unit(np.cross(w1, X))
        up = Rz3(0) @ (np.array([[1, 0, 0], [0, math.cos(rs_psi(t) - math.pi / 2),
                                             -math.sin(rs_psi(t) - math.pi / 2)],
                                 [0, math.sin(rs_psi(t) - math.pi / 2),
                                  math.cos(rs_psi(t) - math.pi / 2)]]) @ u0)
        U.append([math.degrees(angle_about(u, tt, w1)), math.degrees(angle_about(tt, up, X))])
    check_table(run, echo, "LIST POSITION", "joint U", np.array(U), angles=True)


def test_sphere_angle_rates_match_differences(tmp_path) -> None:
    """The SPHERE's Cardan-angle rates are the derivatives of its listed angles."""
    text = (DECKS / "run_rsur.imp").read_text()
    text = text.replace("DATA POSITION (R1) = 0, 10, 36", "DATA POSITION (R1) = 20, 0.2, 40")
    text = text.replace("DATA VELOCITY (R1) = 2", f"DATA VELOCITY (R1) = {math.radians(0.2)!r}")
    text = text.replace("DATA ACCEL (R1) = 0.5", "DATA ACCEL (R1) = 0")
    deck_path = tmp_path / "fine.imp"
    deck_path.write_text(text)
    _deck, runs, _echo = run_deck(deck_path)
    run = runs[0]
    p = np.radians(run.table("LIST POSITION", "joint S").rows[:, 1:])
    v = run.table("LIST VELOCITY", "joint S").rows[:, 1:]
    a = run.table("LIST ACCEL", "joint S").rows[:, 1:]
    fd1 = (p[2:] - p[:-2]) / 2.0
    fd2 = p[2:] - 2 * p[1:-1] + p[:-2]
    assert np.max(np.abs(fd1 - v[1:-1])) < 1e-6
    assert np.max(np.abs(fd2 - a[1:-1])) < 1e-6


# =============================================================================
# gear train
# =============================================================================
def test_gear_train() -> None:
    _deck, runs, echo = run_deck(DECKS / "run_gears.imp")
    run = runs[0]
    assert run.ok
    a = np.arange(0, 361, 10.0)
    check_table(run, echo, "LIST POSITION", "joint A", a[:, None])
    check_table(run, echo, "LIST POSITION", "joint B", (-2.125 * a)[:, None], angles=True)
    check_table(run, echo, "LIST POSITION", "joint C", (4.25 * a)[:, None], angles=True)
    check_table(run, echo, "LIST VELOCITY", "joint B", np.full((37, 1), -2.125))
    check_table(run, echo, "LIST VELOCITY", "joint C", np.full((37, 1), 4.25))
    # IMP's GEAR has one variable: the angle from u to the line of centres
    t = run.table("LIST POSITION", "joint M12")
    assert t.columns == ["Step", "JVar 1"]
    assert np.allclose(t.rows[:, 1], -a, atol=1e-7)


# =============================================================================
# Hooke coupling driven by a VALUE through DATA MOTION
# =============================================================================
#: the angle between the shafts, from the output axis as the deck gives it
HOOKE_BETA = math.atan2(0.5, 0.8660254037844386)
#: the Hooke closed form is checked to 1e-9 degrees and 1e-9 (relative) for the
#: speed ratio: the posture solver converges to 1e-10 internal units
HOOKE_TOL = 1e-9


def test_hooke_closed_form() -> None:
    """examples/hooke.imp against the Cardan joint's closed form, in plain numpy.

    With the input yoke's pin in the plane of the shafts at the start,
    tan(phi_out) = tan(phi_in) / cos(beta), and the speed ratio
    w_out / w_in = cos(beta) / (1 - sin(beta)^2 cos(phi_in)^2) swings between
    cos(beta) and 1 / cos(beta).  The pins stay square to their shafts and to
    each other.
    """
    _deck, runs, echo = run_deck(EXAMPLES / "hooke.imp")
    run = runs[0]
    assert run.ok
    times = run.table("LIST POSITION", "joint JIN").rows[:, 0]
    assert len(times) == 37 and times[-1] == pytest.approx(1.0)
    phi = 2 * np.pi * times  # VALUE (SPIN) = 2*PI*T
    cb, sb = math.cos(HOOKE_BETA), math.sin(HOOKE_BETA)
    # the continuous branch of tan(psi) = tan(phi) / cos(beta)
    psi = np.unwrap(np.arctan2(np.sin(phi), np.cos(phi) * cb))
    ratio = cb / (1 - sb**2 * np.cos(phi) ** 2)
    out = run.table("LIST POSITION", "joint JOUT").rows[:, 1]
    err_psi = np.max(np.abs(out - np.degrees(psi)))
    assert err_psi < HOOKE_TOL, err_psi
    # the relation as the comment of the deck states it, where tan is finite
    finite = np.abs(np.cos(phi)) > 1e-3
    assert np.allclose(np.tan(np.radians(out[finite])), np.tan(phi[finite]) / cb,
                       rtol=1e-9, atol=1e-9)
    w_in = run.table("LIST VELOCITY", "joint JIN").rows[:, 1]
    w_out = run.table("LIST VELOCITY", "joint JOUT").rows[:, 1]
    assert np.max(np.abs(w_in - 2 * np.pi)) < 1e-12
    err_ratio = np.max(np.abs(w_out / w_in - ratio))
    assert err_ratio < HOOKE_TOL, err_ratio
    assert np.max(w_out / w_in) == pytest.approx(1 / cb, rel=HOOKE_TOL)  # phi = 0, 180, 360
    assert np.min(w_out / w_in) == pytest.approx(cb, rel=HOOKE_TOL)  # phi = 90, 270
    wr = run.table("LIST VALUE", "value WR").rows[:, 1]
    assert np.max(np.abs(wr - ratio)) < HOOKE_TOL
    # the printed digits (%.3f) of the listing
    check_table(run, echo, "LIST POSITION", "joint JOUT", np.degrees(psi)[:, None])
    check_table(run, echo, "LIST VELOCITY", "joint JOUT", (2 * np.pi * ratio)[:, None])
    check_table(run, echo, "LIST POSITION", "joint JIN", np.degrees(phi)[:, None],
                angles=True)
    # the yokes: the input pin square to X, the output pin square to n, the
    # pins of the cross square to each other
    ip = run.table("LIST POSITION", "point IP").rows[:, 1:]
    op = run.table("LIST POSITION", "point OP").rows[:, 1:]
    n = np.array([cb, sb, 0.0])
    np.testing.assert_allclose(ip, np.stack([0 * phi, np.cos(phi), np.sin(phi)], 1),
                               atol=1e-12)
    assert np.max(np.abs(op @ n)) < 1e-12
    assert np.max(np.abs(np.einsum("si,si->s", ip, op))) < 1e-9


# =============================================================================
# deck semantics
# =============================================================================
FOURBAR_HEAD = (DECKS / "run_fourbar.imp").read_text().split("DATA POSITION")[0]


def write(tmp_path: Path, body: str, name: str = "deck.imp") -> Path:
    p = tmp_path / name
    p.write_text(FOURBAR_HEAD + body)
    return p


def test_execute_hold_continues_time_and_posture(tmp_path) -> None:
    p = write(tmp_path, """DATA POSITION (A) = 0, 30, 3
LIST POSITION (A, D)
EXECUTE HOLD
DATA POSITION (A) = 90, 30, 3
EXECUTE
RESET
DATA POSITION (A) = 0, 30, 1
EXECUTE
END
""")
    _deck, runs, echo = run_deck(p)
    assert len(runs) == 3 and all(r.ok for r in runs)
    assert "*** The current position is set as reference. ***" in echo
    t1 = runs[0].table("LIST POSITION", "joint D").rows
    t2 = runs[1].table("LIST POSITION", "joint D").rows
    t3 = runs[2].table("LIST POSITION", "joint D").rows
    assert np.allclose(t1[:, 0], [0, 1, 2, 3]) and np.allclose(t2[:, 0], [3, 4, 5, 6])
    assert np.allclose(t3[:, 0], [0, 1])
    exp = np.degrees([fourbar(math.radians(a))["jD"] for a in (90, 120, 150, 180)])
    assert np.allclose(wrap_deg(t2[:, 1] - exp), 0, atol=1e-7)


def test_static_mode_and_force_requests_are_reported(tmp_path) -> None:
    p = write(tmp_path, """DATA POSITION (A) = 0, 30, 2
LIST POSITION (D)
LIST FORCE (A)
PRINT FREQUENCY
EXECUTE
DELETE INPUT ALL
FIND EQUILIB
DATA POSITION (A) = 0
EXECUTE
DELETE EQUILIB
DATA POSITION (A) = 0, 30, 2
DELETE LIST FORCE
DELETE PRINT FREQUENCY
EXECUTE
END
""")
    _deck, runs, _echo = run_deck(p)
    assert [r.mode for r in runs] == ["kinematic", "static", "kinematic"]
    r1, r2, r3 = runs
    assert not r1.failure and len(r1.unsupported) == 1  # LIST FORCE is produced
    assert r1.unsupported[0].startswith(f"{p}:{FOURBAR_HEAD.count(chr(10)) + 4}: PRINT "
                                        "FREQUENCY")
    assert r1.table("LIST FORCE", "joint A").rows.shape == (3, 7)
    assert r1.table("LIST POSITION", "joint D").rows.shape == (3, 2)
    # static mode with every freedom specified: the posture is the SGCs', the holding
    # forces are computed and said so
    assert not r2.failure and r2.mode == "static"
    assert any("no free generalized coordinate" in m for m in r2.messages)
    assert r2.table("LIST FORCE", "joint A").rows.shape == (1, 7)
    assert any("PRINT FREQUENCY is not produced" in u for u in r2.unsupported)
    assert r3.ok and r3.table("LIST POSITION", "joint D").rows.shape == (3, 2)


def test_messages_redefinitions_echo_and_deletes(tmp_path) -> None:
    p = write(tmp_path, """PRINT INPUT
DATA POSITION (A) = 0, 30, 2
DATA POSITION (A) = 0, 45, 2
GROUND = BASE
ZPIN (CRANK, COUPLER) = B
DATA ZPIN (B) = 1,0,0; 2,0,0; 3,3,0
DATA POINT (CP, ABS) = 2.5, 4, 0
LIST POSITION (B, CP)
DELETE POINT (NOPE)
EXECUTE
END
""")
    _deck, runs, echo = run_deck(p)
    head = FOURBAR_HEAD.count(chr(10))
    # every message is located at the statement that caused it
    assert f"*** {p}:{head + 3}: Input motion for joint A 1 is redefined. ***" in echo
    assert f"*** {p}:{head + 4}: The fixed link is redefined. ***" in echo
    assert any("Joint B is redefined" in line for line in echo)
    assert any("Data for point CP is redefined" in line for line in echo)
    assert any("Point NOPE is not defined; it is skipped." in line for line in echo)
    assert "DATA POSITION (A) = 0, 45, 2" in echo  # PRINT INPUT echo
    t = runs[0].table("LIST POSITION", "joint B").rows
    exp = np.degrees([fourbar(math.radians(a))["jB"] for a in (0, 45, 90)])
    assert np.allclose(wrap_deg(t[:, 1] - exp), 0, atol=1e-7)


def test_clear_and_recall(tmp_path) -> None:
    sub = tmp_path / "inputs.dat"
    sub.write_text("DATA POSITION (A) = 0, 60, 2\nLIST POSITION (A)\nRETURN\n")
    p = tmp_path / "deck.imp"
    p.write_text("ZPIN (BASE, X) = J\nCLEAR\n" + FOURBAR_HEAD
                 + "RECALL INPUT = inputs.dat\nEXECUTE\nEND\n")
    deck, runs, _echo = run_deck(p)
    assert set(deck.model.joints) == {"A", "B", "C", "D"}
    assert np.allclose(runs[0].table("LIST POSITION", "joint A").rows[:, 1], [0, 60, 120])


def test_value_reading_the_model_runs_step_by_step(tmp_path) -> None:
    """A DATA MOTION VALUE that reads POSITION(...) is evaluated per step (IMP's lag)."""
    p = write(tmp_path, """VALUE (DRIV) = 2*PI*T + 0*POSITION(D, 1)
DATA MOTION (A) = DRIV
DATA TIME = 0.5, 0, 0.125
LIST POSITION (A, D)
LIST VELOCITY (A)
PRINT VALUE (DRIV)
EXECUTE
END
""")
    _deck, runs, echo = run_deck(p)
    run = runs[0]
    assert run.ok
    t = run.table("LIST POSITION", "joint A").rows
    assert np.allclose(t[:, 0], [0, 0.125, 0.25, 0.375, 0.5])
    assert np.allclose(t[:, 1], [0, 45, 90, 135, 180])
    assert np.allclose(run.table("LIST VELOCITY", "joint A").rows[:, 1], 2 * np.pi)
    exp = np.degrees([fourbar(x)["jD"] for x in np.radians(t[:, 1])])
    assert np.allclose(wrap_deg(run.table("LIST POSITION", "joint D").rows[:, 1] - exp), 0,
                       atol=1e-7)
    assert "Value Results:" in echo


def test_positions_beyond_a_limit_are_skipped() -> None:
    """The crank cannot pass 90 deg: steps 9 to 36 are skipped with one message (IMP went
    on), the 9 positions before are listed, Run.missing has the 28 times."""
    _deck, runs, echo = run_deck(DECKS / "run_fail.imp")
    run = runs[0]
    assert not run.failure and not run.ok
    assert run.missing == [float(k) for k in range(9, 37)]
    said = [ln for ln in echo if "EXECUTE: step" in ln and "cannot be reached" in ln]
    assert len(said) == 1 and "steps 9 to 36 (time 9.000000 to 36.000000; R1 1 = 90 deg" \
        in said[0], said
    assert run.table("LIST POSITION", "joint R1").rows.shape == (9, 2)
    assert "Listing of position of joint R2" in echo


def test_input_errors_are_gathered(tmp_path) -> None:
    p = write(tmp_path, """DATA POSITION (NOPE) = 0, 30, 2
DATA VELOCITY (B) = 3
DATA TIME = 1, 0, 0
EXECUTE
END
""")
    with pytest.raises(DeckError) as ei:
        load(p)
    errs = ei.value.errors
    n = FOURBAR_HEAD.count("\n")
    assert [e.where for e in errs] == [(str(p), n + 1), (str(p), n + 2), (str(p), n + 3)]
    assert "joint NOPE is not defined" in str(errs[0])
    assert "has no DATA POSITION" in str(errs[1])


@pytest.mark.parametrize("name", sorted(p.name for p in EXAMPLES.glob("*.imp")))
def test_examples_run(name: str) -> None:
    _deck, runs, echo = run_deck(EXAMPLES / name)
    assert runs and all(r.ok for r in runs), [r.failure for r in runs]
    assert any(line.startswith("Listing of ") for line in echo)
    text = (EXAMPLES / name).read_text()
    assert text.startswith("$$"), "every example opens with a comment block"


def test_examples_cover_the_brief() -> None:
    texts = {p.name: p.read_text() for p in EXAMPLES.glob("*.imp")}
    assert len(texts) >= 8
    joined = "\n".join(texts.values())
    for word in ("SPHERE", "UJOINT", "GEAR", "CAM", "XSLIDE", "YSLIDE", "PRISM",
                 "DATA MOTION", "ANIMATE", "PLOT", "POINT"):
        assert word in joined, word


def test_structure_deck_runs_without_inputs() -> None:
    """A structure (mobility 0) with no DATA POSITION/MOTION lists its one posture."""
    _deck, runs, echo = run_deck(DECKS / "run_structure.imp")
    assert not runs[0].failure
    rows = listing_rows(echo, "Listing of position of point P1")
    np.testing.assert_allclose(rows[:, 1:], [[0.5, 0.5, 0.0]], atol=5e-4)
