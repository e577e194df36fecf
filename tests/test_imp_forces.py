"""IMP kinematic-mode force analysis: mass, gravity, springs, dampers, loads, FORCE requests.

Reference: imp-language.md §2.3-2.4 (listings, PRINT format, the settled joint-load
convention of kinematic mode: the load of the first-named link on the second, on the
second link's joint axes, moments about that joint origin), §4 (UNIT (MASS)), §7.3,
§8.4 (DATA MASS, DATA INERTIA about the named frame's origin, products +int(xy dm)),
§8.5 (rotational joint spring rates per degree, VALUE rates per radian).

The references are plain numpy: pseudo-inertias computed by hand, closed forms of a
pendulum, a slider and an X-axis pin, and an equivalent model built with the Python
API and analysed with ``openimp.forces``.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest

import openimp
from helpers.decks import FOURBAR_JOINTS
from openimp import Model
from openimp.imp.deck import load
from openimp.imp.interp import DeckError

EXAMPLES = Path(__file__).parent.parent / "examples"
LBM = 1.0 / 386.088  # IMP's default UNIT (MASS), exactly


def write(tmp_path: Path, text: str, name: str = "deck.imp") -> Path:
    p = tmp_path / name
    p.write_text(text)
    return p


def run(tmp_path: Path, text: str):
    p = write(tmp_path, text)
    deck = load(p)
    echo: list[str] = []
    runs = deck.run(echo=echo.append)
    return deck, runs, echo, p


def line_of(text: str, start: str) -> int:
    """1-based number of the first line of ``text`` that starts with ``start``."""
    for i, ln in enumerate(text.splitlines(), start=1):
        if ln.startswith(start):
            return i
    raise AssertionError(start)


def listing(echo: list[str], header: str) -> list[list[str]]:
    """The cells printed under a listing header (text, ???? kept)."""
    i = echo.index(header)
    rows = []
    for ln in echo[i + 2:]:
        if not re.match(r"^\s*-?\d", ln):
            break
        rows.append(ln.split())
    return rows


FOURBAR = """TITLE = FOUR-BAR
""" + FOURBAR_JOINTS + """POINT (COUPLER) = CB, CP, CC
POINT (BASE) = Q, Q2
DATA POINT (CB, ABS) = 1, 0, 0
DATA POINT (CP, ABS) = 2.5, 4, 0
DATA POINT (CC, ABS) = 3, 3, 0
DATA POINT (Q, ABS) = 0, 6, 0
DATA POINT (Q2, ABS) = 0, 6, 1
"""


def fourbar_model() -> Model:
    """The four-bar of FOURBAR built with the Python API (IMP ZPIN frames: w along Z,
    u toward the second point, u' toward the third)."""
    m = Model("four-bar")
    z = (0.0, 0.0, 1.0)
    m.add_joint("revolute", "A", "BASE", "CRANK", origin=(0, 0, 0), axis=z, ref=(1, 0, 0),
                ref2=(1, 0, 0))
    m.add_joint("revolute", "B", "CRANK", "COUP", origin=(1, 0, 0), axis=z, ref=(1, 0, 0),
                ref2=(2, 3, 0))
    m.add_joint("revolute", "C", "COUP", "ROCK", origin=(3, 3, 0), axis=z, ref=(2, 3, 0),
                ref2=(1, -3, 0))
    m.add_joint("revolute", "D", "ROCK", "BASE", origin=(4, 0, 0), axis=z, ref=(-1, 3, 0),
                ref2=(1, 0, 0))
    m.add_point("CP", "COUP", (2.5, 4, 0))
    m.add_point("Q", "BASE", (0, 6, 0))
    return m


# =============================================================================
# statements -> Model
# =============================================================================
def test_data_mass_in_a_joint_frame_and_unit_mass(tmp_path) -> None:
    """DATA MASS: a point mass, centre in the joint frame on that link; UNIT (MASS) is
    applied as the statement is read (default exactly 1/386.088)."""
    text = FOURBAR + """DATA MASS (COUPLER, B) = 2; 1.5, 0.5, 0
DATA MASS (ROCKER, LINK) = 3; 3.5, 1.5, 0.25
UNIT (MASS) = 2
DATA MASS (CRANK, A) = 0.5; 0.5, 0, 0
DATA POSITION (A) = 0
EXECUTE
END
"""
    deck = load(write(tmp_path, text))
    masses = deck.model.masses
    # joint B's frame on the coupler: origin (1, 0, 0), u' toward (3, 3): (2, 3)/sqrt(13)
    u = np.array([2.0, 3.0, 0.0]) / math.sqrt(13.0)
    v = np.array([-3.0, 2.0, 0.0]) / math.sqrt(13.0)
    c = np.array([1.0, 0, 0]) + 1.5 * u + 0.5 * v
    m = 2 * LBM
    J = np.zeros((4, 4))
    J[:3, :3] = m * np.outer(c, c)
    J[:3, 3] = J[3, :3] = m * c
    J[3, 3] = m
    np.testing.assert_allclose(masses["COUP"], J, rtol=1e-12, atol=1e-15)
    c2 = np.array([3.5, 1.5, 0.25])
    np.testing.assert_allclose(masses["ROCK"][3, 3], 3 * LBM, rtol=1e-15)
    np.testing.assert_allclose(masses["ROCK"][:3, 3], 3 * LBM * c2, rtol=1e-12)
    np.testing.assert_allclose(masses["CRAN"][3, 3], 0.5 * 2.0, rtol=1e-15)  # UNIT (MASS) = 2
    assert deck.model.units.mass_factor == 1.0  # applied once, by the interpreter


def test_data_inertia_replaces_the_second_moments_about_the_frame_origin(tmp_path) -> None:
    """DATA INERTIA: about the origin of the named frame, on its axes, products
    +int(x y dm); it replaces the point-mass second moments and keeps the mass and the
    first moments of DATA MASS (given here in another frame)."""
    text = FOURBAR + """UNIT (MASS) = 1
DATA MASS (COUPLER, LINK) = 2; 2.2, 2.3, 0.1
DATA INERTIA (COUPLER, B) = 1.0, 2.0, 2.5, 0.3, -0.2, 0.1
DATA POSITION (A) = 0
EXECUTE
END
"""
    deck = load(write(tmp_path, text))
    J = deck.model.masses["COUP"]
    m, c = 2.0, np.array([2.2, 2.3, 0.1])
    Ixx, Iyy, Izz, Ixy, Ixz, Iyz = 1.0, 2.0, 2.5, 0.3, -0.2, 0.1
    S = np.array([[0.5 * (Iyy + Izz - Ixx), Ixy, Ixz],
                  [Ixy, 0.5 * (Ixx + Izz - Iyy), Iyz],
                  [Ixz, Iyz, 0.5 * (Ixx + Iyy - Izz)]])  # int s s^T dm on B's axes
    u = np.array([2.0, 3.0, 0.0]) / math.sqrt(13.0)
    R = np.column_stack([u, np.cross([0, 0, 1.0], u), [0, 0, 1.0]])
    o = np.array([1.0, 0.0, 0.0])
    # int r r^T = R S R^T + o (m c)^T + (m c) o^T - m o o^T
    sigma = R @ S @ R.T + np.outer(o, m * c) + np.outer(m * c, o) - m * np.outer(o, o)
    np.testing.assert_allclose(J[:3, :3], sigma, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(J[:3, 3], m * c, rtol=1e-12)
    np.testing.assert_allclose(J[3, 3], m)


def test_gravity_springs_dampers_loads_on_the_model(tmp_path) -> None:
    """DATA GRAVITY; SPRING / DAMPER / FORCE / TORQUE elements; joint springs with the
    rate per degree and the free angle in degrees (radians inside), dampers and
    loads on joint variables (an XSLIDE's too)."""
    text = FOURBAR + """POINT (ROCKER) = R1
DATA POINT (R1, ABS) = 3.5, 1.5, 0
DATA GRAVITY = 0, -386.088, 0
SPRING (CP, Q) = SP
DATA SPRING (SP) = 20, 3
DAMPER (CP, Q) = DM
DATA DAMPER (DM) = 0.75
FORCE (R1 / Q, R1) = F1
DATA FORCE (F1) = -100
TORQUE (CRANK / Q, Q2) = T1
DATA TORQUE (T1) = 5
DATA SPRING (D) = 0.05, -108
DATA DAMPER (C) = 0.2
DATA TORQUE (B) = 7.5
DATA POSITION (A) = 0
EXECUTE
END
"""
    deck = load(write(tmp_path, text))
    model = deck.model
    np.testing.assert_allclose(model.gravity, [0, -386.088, 0])
    el = model.elements
    assert (el["SP"].kind, el["SP"].points, el["SP"].value, el["SP"].free) == (
        "spring", ("CP", "Q"), 20.0, 3.0)
    assert (el["DM"].kind, el["DM"].value) == ("damper", 0.75)
    assert (el["F1"].kind, el["F1"].points, el["F1"].value) == ("force", ("R1", "Q", "R1"),
                                                                -100.0)
    assert (el["T1"].kind, el["T1"].body, el["T1"].points, el["T1"].value) == (
        "torque", "CRAN", ("Q", "Q2"), 5.0)
    jl = model.joint_loads
    assert jl[("D", 0)].rate == pytest.approx(0.05 * 180 / math.pi, rel=1e-15)
    assert jl[("D", 0)].free == pytest.approx(math.radians(-108), rel=1e-15)
    assert jl[("C", 0)].damping == 0.2
    assert jl[("B", 0)].force == 7.5
    system = openimp.compile(model)
    Ls = system.length_scale
    c = system.var_index("D.theta")
    assert system.Y.qk[c] * Ls**2 == pytest.approx(0.05 * 180 / math.pi, rel=1e-12)
    assert system.Y.qfree[c] == pytest.approx(math.radians(-108), rel=1e-12)
    np.testing.assert_allclose(system.Y.grav * Ls, [0, -386.088, 0], rtol=1e-12)


def test_xslide_and_value_data(tmp_path) -> None:
    """A translational joint spring stays per length; VALUE rates are per radian."""
    text = """ZPIN (BASE, ARM) = A
XSLIDE (BASE, BLOCK) = S
DATA ZPIN (A) = 0,0,0; 1,0,0; 1,0,0
DATA XSLIDE (S) = 0, 2, 0
VALUE (K) = 3
VALUE (F0) = PI / 6
DATA SPRING (S) = 40, 0.5
DATA SPRING (A) = K, F0
DATA POSITION (A) = 0
DATA POSITION (S) = 0
EXECUTE
END
"""
    deck = load(write(tmp_path, text))
    jl = deck.model.joint_loads
    assert (jl[("S", 0)].rate, jl[("S", 0)].free) == (40.0, 0.5)
    assert jl[("A", 0)].spring_law is not None


def test_value_rates_are_per_radian_numbers_per_degree(tmp_path) -> None:
    """DATA SPRING (D) = 0.05, -100 (per degree, degrees) and = K, F (VALUEs: per radian,
    radians) with K = 0.05 * 180 / PI, F = -100 * PI / 180 give the same loads; so do a
    point spring's rate given by a number and by a VALUE."""
    base = FOURBAR + "DATA MASS (COUPLER, LINK) = 2; 2, 2, 0\nDATA GRAVITY = 0, -386.088, 0\n" \
        "SPRING (CP, Q) = SP\nDATA POSITION (A) = 0, 45, 8\nLIST FORCE (A, SP)\n"
    text = base + "DATA SPRING (D) = 0.05, -100\nDATA SPRING (SP) = 20, 3\nEXECUTE\n" \
        "VALUE (K) = 0.05 * 180 / PI\nVALUE (F) = -100 * PI / 180\nVALUE (KS) = 20\n" \
        "DATA SPRING (D) = K, F\nDATA SPRING (SP) = KS, 3\nEXECUTE\nEND\n"
    _d, runs, _e, _p = run(tmp_path, text)
    for item in ("joint A", "spring SP"):
        a = runs[0].table("LIST FORCE", item).rows
        b = runs[1].table("LIST FORCE", item).rows
        np.testing.assert_allclose(np.nan_to_num(a), np.nan_to_num(b), atol=1e-9)
    assert abs(runs[0].table("LIST FORCE", "joint A").rows[:, 6]).max() > 1.0


# =============================================================================
# closed forms
# =============================================================================
PENDULUM = """TITLE = PENDULUM
ZPIN (BASE, ARM) = A
DATA ZPIN (A) = 0,0,0; 1,0,0; 1,0,0
DATA MASS (ARM, A) = 3; 2, 0, 0
DATA GRAVITY = 0, -386.088, 0
DATA POSITION (A) = 0, 30, 12
"""


def test_pendulum_under_gravity_closed_form(tmp_path) -> None:
    """A point mass m (lbm: weight m lbf) at r on a driven pin: the load of BASE on ARM
    on the arm's axes is (W sin, W cos, 0) and MZ = W r cos(theta), the drive."""
    _d, runs, echo, _p = run(tmp_path, PENDULUM + "LIST FORCE (A)\nEXECUTE\nEND\n")
    t = runs[0].table("LIST FORCE", "joint A")
    assert t.columns == ["Step", "FX", "FY", "FZ", "MX", "MY", "MZ"]
    assert t.units[1:] == ["force"] * 3 + ["force*length"] * 3
    th = np.radians(30.0 * np.arange(13))
    W, r = 3.0, 2.0
    rows = t.rows
    np.testing.assert_allclose(rows[:, 1], W * np.sin(th), atol=1e-9)
    np.testing.assert_allclose(rows[:, 2], W * np.cos(th), atol=1e-9)
    np.testing.assert_allclose(rows[:, 6], W * r * np.cos(th), atol=1e-9)
    # a planar pin in space: the out-of-plane components are determined (one joint)
    np.testing.assert_allclose(rows[:, 3:6], 0.0, atol=1e-9)
    cells = listing(echo, "Listing of force in joint A")
    assert cells[1] == ["1", "1.500", "2.598", "0.000", "0.000", "0.000", "5.196"]


def test_pendulum_at_speed_and_acceleration(tmp_path) -> None:
    """With DATA VELOCITY w and DATA ACCEL a: FX = W sin - m r w^2, FY = W cos + m r a,
    MZ = W r cos + m r^2 a (m in mass units, W = m g)."""
    text = PENDULUM + "DATA VELOCITY (A) = 10\nDATA ACCEL (A) = 50\nLIST FORCE (A)\n" \
                      "EXECUTE\nEND\n"
    _d, runs, _e, _p = run(tmp_path, text)
    rows = runs[0].table("LIST FORCE", "joint A").rows
    th = np.radians(30.0 * np.arange(13))
    m, W, r, w, a = 3.0 * LBM, 3.0, 2.0, 10.0, 50.0
    np.testing.assert_allclose(rows[:, 1], W * np.sin(th) - m * r * w**2, atol=1e-9)
    np.testing.assert_allclose(rows[:, 2], W * np.cos(th) + m * r * a, atol=1e-9)
    np.testing.assert_allclose(rows[:, 6], W * r * np.cos(th) + m * r * r * a, atol=1e-9)


def test_print_force_and_heading_format(tmp_path) -> None:
    """PRINT FORCE: 'through Joint X from Link A onto Link B :' then Forc |F| X Y Z and
    Torq |M| X Y Z (3 decimals, the LIST axes); springs: 'Spg. NAME tension'."""
    text = PENDULUM.replace("DATA POSITION (A) = 0, 30, 12", "DATA POSITION (A) = 30") + \
        "POINT (ARM) = P\nPOINT (BASE) = Q\nDATA POINT (P, ABS) = 2, 0, 0\n" \
        "DATA POINT (Q, ABS) = 2, 5, 0\nSPRING (P, Q) = SP\nDATA SPRING (SP) = 2, 4\n" \
        "PRINT HEADING\nPRINT FORCE (A, SP)\nEXECUTE\nEND\n"
    _d, runs, echo, _p = run(tmp_path, text)
    i = echo.index("Force Results:")
    # the spring: P at 2 (cos 30, sin 30), Q at (2, 5): tension 2 (length - 4)
    P = 2 * np.array([math.cos(math.radians(30)), math.sin(math.radians(30))])
    L = float(np.linalg.norm(np.array([2.0, 5.0]) - P))
    T = 2 * (L - 4)
    # the arm: weight 3 at P, spring pull T toward Q; load of BASE on ARM = -(sum)
    u = (np.array([2.0, 5.0]) - P) / L
    F = -(np.array([0.0, -3.0]) + T * u)
    c, s = math.cos(math.radians(30)), math.sin(math.radians(30))
    Fa = np.array([c * F[0] + s * F[1], -s * F[0] + c * F[1]])
    Mz = -(P[0] * (-3.0) + (P[0] * T * u[1] - P[1] * T * u[0]))
    assert echo[i + 1] == "Magnitude X Y Z"
    assert echo[i + 2] == "through Joint A from Link BASE onto Link ARM :"
    assert echo[i + 3] == (f"Forc {np.hypot(*Fa):.3f} {Fa[0]:.3f} {Fa[1]:.3f} 0.000")
    assert echo[i + 4] == f"Torq {abs(Mz):.3f} 0.000 0.000 {Mz:.3f}"
    assert echo[i + 5] == f"Spg. SP {T:.3f}"
    h = echo.index("The Generalized Coordinates are:")
    assert echo[h + 1] == ("Joint Set by Position Velocity Acceleration [deg, rad/s, rad/s^2 "
                           "or length, length/s, length/s^2]")
    assert echo[h + 2] == "A 1 user 30.0000 0.000 0.000"
    t = runs[0].table("PRINT FORCE", "spring SP")
    assert t.columns == ["Step", "Force"] and t.rows[0, 1] == pytest.approx(T, abs=1e-9)


def test_xslide_block_closed_form(tmp_path) -> None:
    """An XSLIDE (its IMP axes u along X; openimp's prismatic slides along w): a block of
    weight W with its centre h above the slide, accelerated by a along X: FX = m a
    (the drive), FY = W, MZ = -m a h, on the IMP axes."""
    text = """ZPIN (BASE, ARM) = A
XSLIDE (BASE, BLOCK) = S
DATA ZPIN (A) = 0,0,0; 1,0,0; 1,0,0
DATA XSLIDE (S) = 1, 2, 0
DATA MASS (BLOCK, S) = 4; 0, 0.5, 0
DATA GRAVITY = 0, -386.088, 0
DATA POSITION (A) = 0
DATA POSITION (S) = 0, 0.5, 4
DATA VELOCITY (S) = 3
DATA ACCEL (S) = 20
LIST FORCE (S)
EXECUTE
END
"""
    _d, runs, _e, _p = run(tmp_path, text)
    rows = runs[0].table("LIST FORCE", "joint S").rows
    m, W, h, a = 4 * LBM, 4.0, 0.5, 20.0
    np.testing.assert_allclose(rows[:, 1], m * a, atol=1e-9)
    np.testing.assert_allclose(rows[:, 2], W, atol=1e-9)
    np.testing.assert_allclose(rows[:, 6], -m * a * h, atol=1e-9)
    np.testing.assert_allclose(rows[:, [3, 4, 5]], 0.0, atol=1e-9)


def test_xpin_closed_form(tmp_path) -> None:
    """An XPIN turns about its u axis (global X): a point mass at r on +v' and gravity
    along -Z: MX = W r cos(theta), FY = W sin, FZ = W cos on the arm's u' v' w'."""
    text = """XPIN (BASE, ARM) = A
DATA XPIN (A) = 0,0,0; 0,1,0; 0,1,0
DATA MASS (ARM, A) = 2; 0, 1.5, 0
DATA GRAVITY = 0, 0, -386.088
DATA POSITION (A) = 0, 45, 4
LIST FORCE (A)
EXECUTE
END
"""
    _d, runs, _e, _p = run(tmp_path, text)
    rows = runs[0].table("LIST FORCE", "joint A").rows
    th = np.radians(45.0 * np.arange(5))
    W, r = 2.0, 1.5
    np.testing.assert_allclose(rows[:, 4], W * r * np.cos(th), atol=1e-9)
    np.testing.assert_allclose(rows[:, 2], W * np.sin(th), atol=1e-9)
    np.testing.assert_allclose(rows[:, 3], W * np.cos(th), atol=1e-9)
    np.testing.assert_allclose(rows[:, [1, 5, 6]], 0.0, atol=1e-9)


def test_sphere_moments_on_the_euler_axes(tmp_path) -> None:
    """A SPHERE held (no input): its moments are the projections on u (first link),
    the line of nodes and w' (second link) - here w' = (0, 1, 1)/sqrt 2."""
    text = """SPHERE (BASE, ARM) = S
DATA LINK (BASE, S) = 0,0,0; 0,0,1; 1,0,0
DATA LINK (ARM, S) = 0,0,0; 0,1,1; 1,0,0
UNIT (MASS) = 1
DATA MASS (ARM, LINK) = 2; 3, 0, 0
DATA GRAVITY = 0, -10, 0
LIST FORCE (S)
EXECUTE
END
"""
    _d, runs, _e, _p = run(tmp_path, text)
    row = runs[0].table("LIST FORCE", "joint S").rows[0]
    M = 2 * 10 * 3.0  # the holding moment about Z
    s2 = math.sqrt(0.5)
    np.testing.assert_allclose(row[1:], [0, 20 * s2, 20 * s2, 0, -M * s2, M * s2], atol=1e-9)


# =============================================================================
# against the Python API
# =============================================================================
def test_list_force_matches_openimp_forces_of_the_same_model(tmp_path) -> None:
    """The fourbar_spring example against the same model built in Python: masses,
    gravity, a point spring and a torsion spring in D (per degree in the deck, per
    radian in Python); ZPIN frames are openimp's, so 'second' is IMP's convention."""
    _deck, runs, echo, _p = run(tmp_path, (EXAMPLES / "fourbar_spring.imp").read_text())
    m = fourbar_model()
    m.add_mass("CRANK", 0.4 * LBM, center=(0.5, 0, 0))
    I = np.array([[6.948, -6.272, 0], [-6.272, 6.308, 0], [0, 0, 13.256]]) * LBM
    m.add_mass("COUP", 1.2 * LBM, center=(2.2, 2.3, 0), inertia=I, about="origin",
               origin=(0, 0, 0))
    m.add_mass("ROCK", 0.8 * LBM, center=(3.5, 1.5, 0))
    m.set_gravity((0, -386.088, 0))
    m.add_spring("SP", "CP", "Q", 20.0, 3.0)
    m.set_joint_spring("D", 0.05 * 180 / math.pi, math.radians(-108.43495))
    s = openimp.compile(m)
    th = np.radians(30.0 * np.arange(13))
    tr = openimp.sweep(s, {"A": th}, rates={"A": np.zeros(13)}, hold_free=True)
    f = openimp.forces_of(tr)
    for j in ("A", "D"):
        got = runs[0].table("LIST FORCE", f"joint {j}").rows[:, 1:]
        want = f.reaction(j, frame="second")
        assert np.array_equal(np.isnan(got), np.isnan(want)), j
        np.testing.assert_allclose(np.nan_to_num(got), np.nan_to_num(want), atol=1e-9)
    np.testing.assert_allclose(runs[0].table("LIST FORCE", "spring SP").rows[:, 1],
                               f.element("SP"), atol=1e-9)
    # the planar pins in space: FZ, MX, MY indeterminate, printed ????
    cells = listing(echo, "Listing of force in joint A")
    assert all(r[3:6] == ["????"] * 3 for r in cells)


def test_engine_example_against_the_python_model(tmp_path) -> None:
    """engine.imp: a gas FORCE given by a VALUE of the crank angle, masses with an
    inertia, gravity, DATA VELOCITY; crank torque and bearing load against the same
    model built in Python (the gas force as a law of the step)."""
    _deck, runs, _echo, _p = run(tmp_path, (EXAMPLES / "engine.imp").read_text())
    m = Model("engine")
    z = (0.0, 0.0, 1.0)
    m.add_joint("revolute", "A", "BASE", "CRANK", origin=(0, 0, 0), axis=z, ref=(1, 0, 0))
    m.add_joint("revolute", "B", "CRANK", "ROD", origin=(2, 0, 0), axis=z, ref=(1, 0, 0))
    m.add_joint("revolute", "C", "ROD", "PIST", origin=(10, 0, 0), axis=z, ref=(1, 0, 0))
    m.add_joint("prismatic", "D", "BASE", "PIST", origin=(10, 0, 0), axis=(1, 0, 0),
                ref=(0, 1, 0))
    m.add_point("PC", "PIST", (10, 0, 0))
    m.add_point("TOP", "BASE", (14, 0, 0))
    m.add_mass("CRANK", 2.5 * LBM, center=(0.2, 0, 0),
               inertia=np.diag([0.5, 3.0, 3.4]) * LBM, about="origin", origin=(0, 0, 0))
    m.add_mass("ROD", 1.5 * LBM, center=(4.5, 0, 0),
               inertia=np.diag([0.2, 17.375, 17.375]) * LBM, about="origin",
               origin=(2, 0, 0))
    m.add_mass("PIST", 2 * LBM, center=(10, 0, 0))
    m.set_gravity((0, -386.088, 0))
    th = np.radians(15.0 * np.arange(25))

    def gas(s):
        x = math.sin(th[s.step])
        return 1500 * x if x > 0 else 0.0

    m.add_force("GAS", "PC", along=("TOP", "PC"), law=gas)
    s = openimp.compile(m)
    tr = openimp.sweep(s, {"A": th}, rates={"A": np.full(25, 188.5)},
                       accels={"A": np.zeros(25)}, hold_free=True)
    f = openimp.forces_of(tr)
    got = runs[0].table("LIST FORCE", "joint A").rows[:, 1:]
    want = f.reaction("A", frame="second")
    np.testing.assert_allclose(np.nan_to_num(got), np.nan_to_num(want), atol=1e-7)
    assert np.array_equal(np.isnan(got), np.isnan(want))
    # the crank torque (MZ) is the drive torque of the crank
    np.testing.assert_allclose(got[:, 5], f.drive["A.theta"], atol=1e-7)
    # the cylinder wall (XSLIDE, IMP u along the slide; the Python prismatic has w along
    # it and u along Y): its FX along the slide is 0, FY the side thrust
    d = runs[0].table("LIST FORCE", "joint D").rows[:, 1:]
    np.testing.assert_allclose(d[:, 0], 0.0, atol=1e-7)
    np.testing.assert_allclose(d[:, 1], f.reaction("D", frame="second")[:, 0], atol=1e-7)
    np.testing.assert_allclose(d[:, 5], f.reaction("D", frame="second")[:, 4], atol=1e-7)


def test_redundant_example_prints_question_marks_and_json_null(tmp_path) -> None:
    """Four parallel revolutes in space: the out-of-plane components are statically
    indeterminate (???? in the listing, null in JSON); with a SPHERE and a CYLINDER
    every component is determined and the ball carries no moment."""
    _d, runs, echo, _p = run(tmp_path, (EXAMPLES / "redundant.imp").read_text())
    r1, r2 = runs
    t = r1.table("LIST FORCE", "joint A")
    assert np.all(np.isnan(t.rows[:, 3:6])) and np.all(np.isfinite(t.rows[:, [1, 2, 6]]))
    doc = json.loads(json.dumps(r1.to_dict()))
    rows = next(x for x in doc["tables"] if x["item"] == "joint A")["rows"]
    assert rows[0][3:6] == [None, None, None]
    assert listing(echo, "Listing of force in joint A")[0][3:6] == ["????"] * 3
    for j in "ABCD":
        assert np.all(np.isfinite(r2.table("LIST FORCE", f"joint {j}").rows))
    c = r2.table("LIST FORCE", "joint C").rows
    np.testing.assert_allclose(c[:, 4:7], 0.0, atol=1e-9)
    np.testing.assert_allclose(c[:, 3], 1.0, atol=1e-9)  # the rocker's weight, 1 lbf
    a = r2.table("LIST FORCE", "joint A").rows
    np.testing.assert_allclose(a[:, 3], 3.0, atol=1e-9)  # all three weights at A's pin


def test_value_data_and_force_in_a_value(tmp_path) -> None:
    """A VALUE as element data is evaluated per step; FORCE(joint, 6) in a listed VALUE
    is the listed MZ; FORCE(...) in the data of a load is circular: undefined, 0 used."""
    text = PENDULUM + """POINT (ARM) = P
POINT (BASE) = Q, Q2
DATA POINT (P, ABS) = 2, 0, 0
DATA POINT (Q, ABS) = 0, 0, 0
DATA POINT (Q2, ABS) = 0, 0, 1
TORQUE (ARM / Q, Q2) = T1
VALUE (TV) = 10 * TIME
DATA TORQUE (T1) = TV
VALUE (FB) = FORCE(A, 6) + 0
LIST VALUE (FB)
LIST FORCE (A)
EXECUTE
TORQUE (ARM / Q, Q2) = T2
VALUE (CIRC) = FORCE(A, 6)
DATA TORQUE (T2) = CIRC
EXECUTE
END
"""
    _d, runs, _e, _p = run(tmp_path, text)
    rows = runs[0].table("LIST FORCE", "joint A").rows
    th = np.radians(30.0 * np.arange(13))
    k = np.arange(13)  # stepped: TIME is the step number
    np.testing.assert_allclose(rows[:, 6], 3 * 2 * np.cos(th) - 10 * k, atol=1e-9)
    np.testing.assert_allclose(runs[0].table("LIST VALUE", "value FB").rows[:, 1],
                               rows[:, 6], atol=1e-12)
    r2 = runs[1]
    np.testing.assert_allclose(r2.table("LIST FORCE", "joint A").rows[:, 6],
                               3 * 2 * np.cos(th) - 10 * k, atol=1e-9)
    assert any("VALUE CIRC" in m and "undefined" in m and "0 is used" in m
               for m in r2.messages), r2.messages


# =============================================================================
# messages and bad input
# =============================================================================
def test_element_without_data_is_deleted_with_a_located_message(tmp_path) -> None:
    text = FOURBAR + "SPRING (CP, Q) = SP\nDATA POSITION (A) = 0, 30, 2\n" \
                     "LIST POSITION (SP)\nLIST FORCE (SP, A)\nEXECUTE\nEND\n"
    _d, runs, echo, p = run(tmp_path, text)
    n = line_of(text, "SPRING (CP, Q)")
    msg = f"{p}:{n}: Spring SP has no DATA SPRING; it is deleted."
    assert msg in runs[0].messages and f"*** {msg} ***" in echo
    assert runs[0].table("LIST POSITION", "spring SP").rows.shape == (3, 2)  # still measured
    lf = line_of(text, "LIST FORCE")
    assert runs[0].unsupported == [f"{p}:{lf}: LIST FORCE (SP) is not produced: Spring SP "
                                   "has no DATA SPRING; it is deleted."]
    assert runs[0].table("LIST FORCE", "joint A").rows.shape == (3, 7)


@pytest.mark.parametrize("bad, needle", [
    ("DATA MASS (COUPLER, LINK) = -2; 1, 1, 0", "must not be negative"),
    ("SPRING (CP, CP) = S2", "two different points"),
    ("SPRING (CP, Q) = S2\nDATA SPRING (S2) = 10, 2; 5, 1", "takes one pair"),
    ("DATA SPRING (A) = KK, 0", "VALUE KK is not defined"),
    ("DATA TORQUE (B) = 1, 2", "has 1 variable(s) but 2 entries"),
    ("LIST FORCE (CP)", "CP is a point"),
    ("SPRING (CP, Q) = S2\nDATA SPRING (S2) = 10, -2", "free length must be >= 0"),
])
def test_bad_data_is_an_input_error_at_its_line(tmp_path, bad, needle) -> None:
    text = FOURBAR + bad + "\nDATA POSITION (A) = 0\nEXECUTE\nEND\n"
    p = write(tmp_path, text)
    with pytest.raises(DeckError) as ei:
        load(p)
    last = bad.splitlines()[-1]
    where = (str(p), line_of(text, last))
    assert any(e.where == where and needle in str(e) for e in ei.value.errors), \
        [(e.where, str(e)) for e in ei.value.errors]


def test_spring_on_a_sphere_angle_is_kept(tmp_path) -> None:
    """IMP puts springs on SPHERE angles, and so does openimp: the joint's Cardan angles
    become its coordinates, nothing is left out (the values: test_imp_ball_loads)."""
    text = """SPHERE (BASE, ARM) = S
DATA SPHERE (S) = 0, 0, 0
DATA SPRING (S) = NONE, NONE; 1, 0
LIST FORCE (S)
EXECUTE
END
"""
    d, runs, _e, _p = run(tmp_path, text)
    assert not [m for m in runs[0].messages if "SPHERE joint S" in m], runs[0].messages
    assert runs[0].ok
    assert d.built.model.joints["S"].kind_name == "gimbal"
    assert d.built.model.joint_loads[("S", 1)].rate == pytest.approx(180 / math.pi)


def test_warnings_for_implausible_inertia_and_coincident_direction(tmp_path) -> None:
    """What IMP accepts silently is used as given, with a located warning: an inertia
    no rigid body has, a force whose direction points coincide."""
    text = FOURBAR + """DATA MASS (COUPLER, B) = 2; 1.5, 0.5, 0
DATA INERTIA (COUPLER, B) = 0.1, 0.2, 0.3, 0, 0, 0
POINT (COUPLER) = X1
DATA POINT (X1, ABS) = 0, 6, 0
FORCE (CP / Q, X1) = F1
DATA FORCE (F1) = 10
DATA POSITION (A) = 0
LIST FORCE (A)
EXECUTE
END
"""
    _d, runs, _e, p = run(tmp_path, text)
    msgs = runs[0].messages
    ni = line_of(text, "DATA INERTIA")
    nf = line_of(text, "FORCE (CP")
    assert any(m.startswith(f"{p}:{ni}: warning: DATA INERTIA (COUP)") and "negative" in m
               for m in msgs), msgs
    assert any(m.startswith(f"{p}:{nf}: warning: the direction points Q and X1") for m in msgs)
    assert not runs[0].failure


def test_data_density_of_a_file_solid_says_its_mass_is_not_computed(tmp_path) -> None:
    (tmp_path / "cube.stl").write_text(
        "solid CUBE\nfacet normal 0 0 -1\nouter loop\nvertex 0 0 0\nvertex 1 1 0\n"
        "vertex 1 0 0\nendloop\nendfacet\nendsolid\n")
    text = FOURBAR + "SOLID READ (CUBE) = cube.stl\nSHAPE (COUPLER) = CUBE\n" \
                     "DATA DENSITY (CUBE) = 0.28\nDATA POSITION (A) = 0\nEXECUTE\nEND\n"
    deck = load(write(tmp_path, text))
    n = line_of(text, "DATA DENSITY")
    assert any(w.where[1] == n and "mass properties of solid CUBE are not computed" in
               w.message for w in deck.warnings)
    assert "COUP" not in deck.model.masses


def test_data_mass_again_discards_the_inertia(tmp_path) -> None:
    text = FOURBAR + """UNIT (MASS) = 1
DATA MASS (COUPLER, LINK) = 2; 1, 1, 0
DATA INERTIA (COUPLER, LINK) = 5, 5, 5
DATA MASS (COUPLER, LINK) = 2; 1, 1, 0
DATA POSITION (A) = 0
EXECUTE
END
"""
    deck = load(write(tmp_path, text))
    J = deck.model.masses["COUP"]
    np.testing.assert_allclose(J[:3, :3], 2 * np.outer([1, 1, 0], [1, 1, 0]))


def test_old_decks_still_run() -> None:
    """Every example runs to the end with all its requests produced (the new force
    examples included)."""
    for p in sorted(EXAMPLES.glob("*.imp")):
        runs = load(p).run()
        assert runs and all(r.ok for r in runs), (p.name, [r.failure or r.unsupported
                                                           for r in runs])
