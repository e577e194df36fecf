"""docs/forces.md, "Three conventions side by side": one pin of one held four-bar read in
openimp's three joint-load conventions, and the very numbers of the page's table.

The example: the four-bar of examples/fourbar.imp with three point masses, gravity, a
torsion spring in the pin C = ZPIN (COUPLER, ROCKER) and the crank held at 30 degrees,
nothing moving.  It runs four ways at the same posture: the Python API
(``openimp.forces``), an IMP deck in kinematic mode (DATA POSITION), the same deck in
static mode (FIND EQUILIB with the same DATA POSITION: the only freedom is held) and in
dynamic mode (FIND DYNAMICS, DATA MOTION holding the crank).

The references are plain numpy, never openimp: the posture by circle intersection, the
load in every pin by the free bodies of the three links (nine linear equations), the
crank's holding torque by virtual work, the two joint frames of C from the posture, and
the conversions between the conventions (sign, rotation between the frames, moment
point) as a 6 x 6 matrix.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

import openimp
from helpers.decks import FOURBAR_JOINTS, run_deck, write

DOC = Path(__file__).parent.parent / "docs" / "forces.md"
DEG = math.pi / 180.0

# the example, in numbers (global coordinates at the drawn posture)
A0, B0, C0, D0 = (np.array(p, float) for p in ((0, 0), (1, 0), (3, 3), (4, 0)))
MASSES = {"CRANK": (1.0, (0.5, 0.0)), "COUPLER": (2.0, (2.5, 4.0)),
          "ROCKER": (3.0, (3.5, 1.5))}
G = 9.81
K_DEG, FREE_DEG = 0.25, -90.0  # the spring in C: per degree, free angle
CRANK_DEG = 30.0

DECK = """TITLE = FOUR-BAR HELD STILL
UNIT (MASS) = 1
""" + FOURBAR_JOINTS + """DATA MASS (CRANK, LINK) = 1; 0.5, 0, 0
DATA MASS (COUPLER, LINK) = 2; 2.5, 4, 0
DATA MASS (ROCKER, LINK) = 3; 3.5, 1.5, 0
DATA GRAVITY = 0, -9.81, 0
DATA SPRING (C) = 0.25, -90
{mode}LIST POSITION (C)
LIST FORCE (C, A)
EXECUTE
END
"""
MODES = {
    "kinematic": "DATA POSITION (A) = 30\n",
    "static": "FIND EQUILIB\nDATA POSITION (A) = 30\n",
    "dynamic": "FIND DYNAMICS\nDATA MOTION (A) = 30\nDATA TIME = 0.5, 0.25, 0.25\n",
}

#: the table of docs/forces.md section 7 (None: indeterminate), 4 significant digits
TABLE = {
    "python": (-2.936, -14.29, None, None, None, 8.634),
    "kinematic": (13.43, 5.680, None, None, None, 8.634),
    "static": (2.936, 14.29, None, None, None, -8.634),
}
#: the numbers of the section's text: the joint angle of C (deg), the crank's drive
JOINT_ANGLE_DEG, DRIVE = -124.54, 6.700
COMPONENTS = ("FX", "FY", "FZ", "MX", "MY", "MZ")
INDETERMINATE = np.array([False, False, True, True, True, False])
TOL = 1e-9


# =============================================================================
# references in plain numpy
# =============================================================================
def cross2(a: np.ndarray, b: np.ndarray) -> float:
    return float(a[0] * b[1] - a[1] * b[0])


def perp(a: np.ndarray) -> np.ndarray:
    """z x a."""
    return np.array([-a[1], a[0]])


def rot(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s], [s, c]])


def angle(a: np.ndarray) -> float:
    return math.atan2(a[1], a[0])


def posture(theta: float) -> dict:
    """The four-bar with the crank at theta: pin positions, centres of mass, the joint
    frames of C (u on COUPLER along B -> C, u' on ROCKER along C -> D, as DATA ZPIN (C)
    draws them) and its joint angle phi (u -> u' about z)."""
    B = A0 + rot(theta) @ (B0 - A0)
    lbc, lcd = np.linalg.norm(C0 - B0), np.linalg.norm(C0 - D0)
    d = D0 - B
    L = np.linalg.norm(d)
    a = (lbc**2 - lcd**2 + L**2) / (2 * L)
    h = math.sqrt(lbc**2 - a**2)
    cands = [B + a * d / L + s * h * perp(d) / L for s in (1.0, -1.0)]
    C = min(cands, key=lambda p: np.linalg.norm(p - C0))  # the drawn branch
    beta = angle(C - B) - angle(C0 - B0)  # the coupler's turn from the drawing
    gamma = angle(C - D0) - angle(C0 - D0)  # the rocker's
    centre = {
        "CRANK": A0 + rot(theta) @ (np.array(MASSES["CRANK"][1]) - A0),
        "COUPLER": B + rot(beta) @ (np.array(MASSES["COUPLER"][1]) - B0),
        "ROCKER": D0 + rot(gamma) @ (np.array(MASSES["ROCKER"][1]) - D0),
    }
    u1 = (C - B) / lbc
    u2 = (D0 - C) / lcd
    phi = math.atan2(cross2(u1, u2), float(u1 @ u2))
    return {"B": B, "C": C, "centre": centre, "u1": u1, "u2": u2, "phi": phi}


def spring_moment(phi: float) -> float:
    """k (phi - free): the torsion spring's moment on the COUPLER (minus it on the ROCKER)."""
    return (K_DEG / DEG) * (phi - FREE_DEG * DEG)


def free_bodies(p: dict) -> dict:
    """The free bodies of crank, coupler and rocker (forces and moments about a pin of each):
    F_A BASE on CRANK, F_B CRANK on COUPLER, F_C COUPLER on ROCKER, F_D BASE on ROCKER and
    the torque T of BASE on CRANK, nine unknowns in nine equations."""
    B, C = p["B"], p["C"]
    w = {b: MASSES[b][0] * np.array([0.0, -G]) for b in MASSES}
    c = p["centre"]
    S = spring_moment(p["phi"])
    M = np.zeros((9, 9))
    rhs = np.zeros(9)

    def force_rows(row: int, cols_signs: list[tuple[int, float]], weight: np.ndarray) -> None:
        for col, s in cols_signs:
            M[row, col], M[row + 1, col + 1] = s, s
        rhs[row:row + 2] = -weight

    def moment_row(row: int, terms: list[tuple[int, float, np.ndarray]]) -> None:
        for col, s, r in terms:  # s * (r x F)
            M[row, col] += -s * r[1]
            M[row, col + 1] += s * r[0]

    # unknown columns: F_A 0-1, F_B 2-3, F_C 4-5, F_D 6-7, T 8
    force_rows(0, [(0, 1.0), (2, -1.0)], w["CRANK"])  # crank: F_A - F_B + W1 = 0
    moment_row(2, [(2, -1.0, B - A0)])  # about A
    M[2, 8] = 1.0
    rhs[2] = -cross2(c["CRANK"] - A0, w["CRANK"])
    force_rows(3, [(2, 1.0), (4, -1.0)], w["COUPLER"])  # coupler: F_B - F_C + W2 = 0
    moment_row(5, [(4, -1.0, C - B)])  # about B
    rhs[5] = -cross2(c["COUPLER"] - B, w["COUPLER"]) - S
    force_rows(6, [(4, 1.0), (6, 1.0)], w["ROCKER"])  # rocker: F_C + F_D + W3 = 0
    moment_row(8, [(4, 1.0, C - D0)])  # about D
    rhs[8] = -cross2(c["ROCKER"] - D0, w["ROCKER"]) + S
    x = np.linalg.solve(M, rhs)
    return {"F_C": x[4:6], "M_C": -S, "T": x[8]}


def virtual_work_torque(p: dict) -> float:
    """The crank torque from the power balance at a crank rate of 1: T + sum(m g . v_G)
    - k (phi - free) (w_rocker - w_coupler) = 0, the rates from the loop closure."""
    B, C = p["B"], p["C"]
    vB = perp(B - A0)
    # vB + w2 z x (C - B) = w3 z x (C - D)
    w2, w3 = np.linalg.solve(np.column_stack([perp(C - B), -perp(C - D0)]), -vB)
    c = p["centre"]
    v = {"CRANK": perp(c["CRANK"] - A0), "COUPLER": vB + w2 * perp(c["COUPLER"] - B),
         "ROCKER": w3 * perp(c["ROCKER"] - D0)}
    gravity = sum(MASSES[b][0] * np.array([0.0, -G]) @ v[b] for b in MASSES)
    return float(-gravity + spring_moment(p["phi"]) * (w3 - w2))


def frame(u: np.ndarray) -> np.ndarray:
    """3 x 3 rotation, columns u, v = z x u, w = z."""
    return np.array([[u[0], -u[1], 0.0], [u[1], u[0], 0.0], [0.0, 0.0, 1.0]])


def skew(r: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -r[2], r[1]], [r[2], 0.0, -r[0]], [-r[1], r[0], 0.0]])


def conversion(R1: np.ndarray, o1: np.ndarray, R2: np.ndarray, o2: np.ndarray,
               sign: float) -> np.ndarray:
    """6 x 6: a load on frame 1's axes about o1 -> sign times it on frame 2's axes about
    o2 (M2 = M1 + (o1 - o2) x F)."""
    T = np.zeros((6, 6))
    T[:3, :3] = R2.T @ R1
    T[3:, :3] = R2.T @ skew(o1 - o2) @ R1
    T[3:, 3:] = R2.T @ R1
    return sign * T


def apply(T: np.ndarray, load: np.ndarray) -> np.ndarray:
    """T @ load with the indeterminate (NaN) components: the determinate outputs must not
    depend on them."""
    nan = np.isnan(load)
    out = T @ np.where(nan, 0.0, load)
    out[np.any(T[:, nan] != 0.0, axis=1)] = np.nan
    return out


def sig4(x: float) -> float:
    return float(f"{x:.4g}")


# =============================================================================
# the four runs
# =============================================================================
def python_model() -> openimp.Model:
    """The deck's mechanism in the Python API, the joints given the ZPIN frames."""
    m = openimp.Model("four-bar held still")
    z = (0.0, 0.0, 1.0)
    m.add_joint("revolute", "A", "BASE", "CRANK", origin=(0, 0, 0), axis=z, ref=(1, 0, 0),
                ref2=(1, 0, 0))
    m.add_joint("revolute", "B", "CRANK", "COUPLER", origin=(1, 0, 0), axis=z,
                ref=(1, 0, 0), ref2=(2, 3, 0))
    m.add_joint("revolute", "C", "COUPLER", "ROCKER", origin=(3, 3, 0), axis=z,
                ref=(2, 3, 0), ref2=(1, -3, 0))
    m.add_joint("revolute", "D", "ROCKER", "BASE", origin=(4, 0, 0), axis=z,
                ref=(-1, 3, 0), ref2=(1, 0, 0))
    for body, (mass, (x, y)) in MASSES.items():
        m.add_mass(body, mass, (x, y, 0.0))
    m.set_gravity((0.0, -G, 0.0))
    m.set_joint_spring("C", K_DEG / DEG, free=FREE_DEG * DEG)
    return m


@pytest.fixture(scope="module")
def runs(tmp_path_factory) -> dict:
    tmp = tmp_path_factory.mktemp("conventions")
    out = {}
    for mode, lines in MODES.items():
        (r,), _ = run_deck(write(tmp, DECK.format(mode=lines), f"{mode}.imp"))
        assert r.ok and r.mode == mode, r.failure
        out[mode] = r
    f = openimp.forces(openimp.compile(python_model()), {"A": [CRANK_DEG * DEG]})
    out["python"] = f
    return out


def deck_rows(run, item: str) -> np.ndarray:
    return run.table(*item.split(":")).rows[:, 1:]


@pytest.fixture(scope="module")
def loads(runs) -> dict:
    """Joint C and the crank's drive in every convention (one row each)."""
    f = runs["python"]
    out = {"python": f.reaction("C")[0], "python second": f.reaction("C", "second")[0],
           "drive": f.drive["A.theta"][0]}
    for mode in MODES:
        rows = deck_rows(runs[mode], "LIST FORCE:joint C")
        assert np.allclose(rows, rows[0], rtol=0, atol=TOL, equal_nan=True)  # held still
        out[mode] = rows[0]
        out[mode + " A"] = deck_rows(runs[mode], "LIST FORCE:joint A")[0]
    return out


# =============================================================================
# checks
# =============================================================================
def test_the_four_runs_are_at_one_posture(runs) -> None:
    p = posture(CRANK_DEG * DEG)
    for mode in MODES:
        phi = deck_rows(runs[mode], "LIST POSITION:joint C")[:, 0]
        np.testing.assert_allclose(phi, p["phi"] / DEG, rtol=0, atol=TOL)
    np.testing.assert_allclose(runs["python"].trajectory.joint("C")[0, 0], p["phi"],
                               rtol=0, atol=TOL)
    assert round(p["phi"] / DEG, 2) == JOINT_ANGLE_DEG


def test_each_convention_is_the_free_body_load(loads) -> None:
    """Python and kinematic deck: COUPLER on ROCKER, on COUPLER's and on ROCKER's joint
    axes; static and dynamic deck: ROCKER on COUPLER on COUPLER's axes; all about C."""
    p = posture(CRANK_DEG * DEG)
    fb = free_bodies(p)
    F = np.array([*fb["F_C"], np.nan])
    Mc = np.array([np.nan, np.nan, fb["M_C"]])
    glob = np.concatenate([F, Mc])  # COUPLER on ROCKER, global axes, about C
    R1, R2 = frame(p["u1"]), frame(p["u2"])
    o = np.array([*p["C"], 0.0])
    want = {
        "python": apply(conversion(np.eye(3), o, R1, o, 1.0), glob),
        "kinematic": apply(conversion(np.eye(3), o, R2, o, 1.0), glob),
        "static": apply(conversion(np.eye(3), o, R1, o, -1.0), glob),
        "dynamic": apply(conversion(np.eye(3), o, R1, o, -1.0), glob),
    }
    for name, w in want.items():
        got = loads[name]
        assert np.array_equal(np.isnan(got), INDETERMINATE), name
        assert np.array_equal(np.isnan(w), INDETERMINATE), name
        np.testing.assert_allclose(got, w, rtol=0, atol=TOL, equal_nan=True, err_msg=name)
    # the pin's MZ is the torsion spring's moment on the rocker
    assert loads["python"][5] == pytest.approx(-K_DEG * (p["phi"] / DEG - FREE_DEG), abs=TOL)


def test_the_conventions_convert_into_each_other(loads, runs) -> None:
    """From Python's (first body's frame) to the kinematic deck's: the rotation by the joint
    angle about w, the moment point unchanged (both frames' origin is the pin's centre);
    to the static and dynamic decks': the sign.  Python's "second" is the kinematic deck."""
    p = posture(CRANK_DEG * DEG)
    phi = math.radians(deck_rows(runs["kinematic"], "LIST POSITION:joint C")[0, 0])
    R1 = frame(p["u1"])
    R2 = R1 @ frame(np.array([math.cos(phi), math.sin(phi)]))  # u' = u turned by phi
    np.testing.assert_allclose(R2, frame(p["u2"]), rtol=0, atol=TOL)
    o = np.array([*p["C"], 0.0])
    to_kin = conversion(R1, o, R2, o, 1.0)
    to_static = conversion(R1, o, R1, o, -1.0)
    py = loads["python"]
    for got, want in ((loads["kinematic"], apply(to_kin, py)),
                      (loads["python second"], apply(to_kin, py)),
                      (loads["static"], apply(to_static, py)),
                      (loads["dynamic"], apply(to_static, py))):
        np.testing.assert_allclose(got, want, rtol=0, atol=TOL, equal_nan=True)
    # the page's formulas for the planar components
    c, s = math.cos(phi), math.sin(phi)
    kin = loads["kinematic"]
    assert kin[0] == pytest.approx(py[0] * c + py[1] * s, abs=TOL)
    assert kin[1] == pytest.approx(-py[0] * s + py[1] * c, abs=TOL)
    assert kin[5] == pytest.approx(py[5], abs=TOL)


def test_the_crank_drive_is_the_virtual_work_and_the_balance(loads) -> None:
    """Python's drive = the kinematic deck's MZ of A (BASE on CRANK) = minus the static and
    dynamic decks' (CRANK on BASE) = the free bodies' torque = the virtual work's."""
    p = posture(CRANK_DEG * DEG)
    T = free_bodies(p)["T"]
    assert virtual_work_torque(p) == pytest.approx(T, abs=TOL)
    assert loads["drive"] == pytest.approx(T, abs=TOL)
    assert loads["kinematic A"][5] == pytest.approx(T, abs=TOL)
    assert loads["static A"][5] == pytest.approx(-T, abs=TOL)
    assert loads["dynamic A"][5] == pytest.approx(-T, abs=TOL)
    assert sig4(T) == DRIVE


def doc_section() -> str:
    text = DOC.read_text()
    m = re.search(r"^## \d+\. Three conventions side by side\n(.*?)(?=^## )", text,
                  flags=re.S | re.M)
    assert m, "the section is missing from docs/forces.md"
    return m.group(1)


def test_the_table_is_the_runs(loads) -> None:
    """TABLE holds the runs' numbers to 4 significant digits (NaN where indeterminate)."""
    for col, row in TABLE.items():
        for comp, want, got in zip(COMPONENTS, row, loads[col], strict=True):
            if want is None:
                assert math.isnan(got), (col, comp)
            else:
                assert sig4(got) == want, (col, comp, got)
    # the dynamic deck lists what the static deck does
    np.testing.assert_allclose(loads["dynamic"], loads["static"], rtol=0, atol=TOL,
                               equal_nan=True)


def test_the_page_shows_the_table() -> None:
    """docs/forces.md shows TABLE (NaN in Python, ???? in listings), the joint angle and
    the drive."""
    sec = doc_section()
    rows = {}
    for line in sec.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if cells[0] in COMPONENTS:
            rows[cells[0]] = cells[1:]
    assert list(rows) == list(COMPONENTS)
    for i, (col, values) in enumerate(TABLE.items()):
        blank = "NaN" if col == "python" else "????"
        shown = [rows[comp][i] for comp in COMPONENTS]
        assert shown == [blank if v is None else f"{v:#.4g}" for v in values], col
    flat = " ".join(sec.split())
    assert "| load of | COUPLER on ROCKER | COUPLER on ROCKER | ROCKER on COUPLER |" in flat
    assert "| on the axes | u, v, w on COUPLER | u', v', w' on ROCKER | u, v, w on COUPLER |" \
        in flat
    assert "| moments about | the pin's centre C | C | C |" in flat
    for formula in ("FX' = FX cos(phi) + FY sin(phi)", "FY' = -FX sin(phi) + FY cos(phi)",
                    "MZ' = MZ", "(o1 - o2) x F", "-0.25 (phi + 90)"):
        assert f"`{formula}`" in flat, formula
    assert f"The joint angle of C is {JOINT_ANGLE_DEG:.2f} degrees" in flat
    assert f"are {DRIVE:.3f} (BASE on CRANK)" in flat
    assert f"list {-DRIVE:.3f} (CRANK on BASE)" in flat
    # the example the page describes is the one run here
    for phrase in ("DATA SPRING (C) = 0.25, -90", "ZPIN (COUPLER, ROCKER) = C",
                   "DATA ZPIN (C) = 3,3,0; 5,6,0; 4,0,0", "DATA POSITION (A) = 30",
                   "DATA MOTION (A) = 30", "UNIT (MASS) = 1"):
        assert f"`{phrase}`" in flat and phrase in DECK + "".join(MODES.values()), phrase
