"""Singular postures (book 6.9): change points and bifurcations crossed on the right branch,
dead points stopped at or switched through, every one reported.

References in plain numpy: the crank tips of a parallelogram chain (equal cranks
stay parallel), circle intersections of a four-bar (the two assembly modes and
the sign of a triangle's area that tells them apart), loop closure.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import openimp
from openimp.imp.deck import load

DEG = math.pi / 180


def chain(n: int, a: float = 1.0, d: float = 2.0) -> openimp.Model:
    """``n`` parallelograms in a row: cranks of length ``a`` pinned ``d`` apart on the
    ground, their tips joined by couplers of length ``d``; cranks vertical (variable 0)
    at the modeling posture, so the change points are at crank angles 90 + 180 k deg."""
    m = openimp.Model(f"chain{n}")
    for i in range(n + 1):
        m.add_joint("revolute", f"G{i}", "BASE", f"K{i}", origin=(i * d, 0, 0))
    for i in range(n):
        m.add_joint("revolute", f"T{i}a", f"K{i}", f"C{i}", origin=(i * d, a, 0))
        m.add_joint("revolute", f"T{i}b", f"C{i}", f"K{i + 1}", origin=((i + 1) * d, a, 0))
    return m


def fourbar(a: float, b: float, c: float, d: float, th0: float, up: bool = True
            ) -> tuple[openimp.Model, dict[str, np.ndarray]]:
    """Crank a from A=(0,0), coupler b, rocker c pinned at D=(d,0); the crank at th0, C on
    the ``up`` side of BD (circle intersection)."""
    A, D = np.zeros(3), np.array([d, 0.0, 0.0])
    B = np.array([a * math.cos(th0), a * math.sin(th0), 0.0])
    C = _circles(B, b, D, c, up)
    m = openimp.Model("fourbar")
    m.add_joint("revolute", "A", "BASE", "CRANK", origin=A)
    m.add_joint("revolute", "B", "CRANK", "COUPLER", origin=B)
    m.add_joint("revolute", "C", "COUPLER", "ROCKER", origin=C)
    m.add_joint("revolute", "D", "ROCKER", "BASE", origin=D)
    m.add_point("PB", "CRANK", B)
    m.add_point("PC", "ROCKER", C)
    return m, {"A": A, "B": B, "C": C, "D": D}


def _circles(P: np.ndarray, r: float, Q: np.ndarray, s: float, up: bool) -> np.ndarray:
    """The intersection of the circles (P, r) and (Q, s) left (``up``) or right of P->Q."""
    PQ = Q - P
    L = float(np.linalg.norm(PQ))
    x = (r * r - s * s + L * L) / (2 * L)
    h = math.sqrt(max(r * r - x * x, 0.0))
    n = np.array([-PQ[1], PQ[0], 0.0]) / L
    return P + x * PQ / L + (h if up else -h) * n


def crank_tips(res: openimp.Trajectory, n: int, a: float = 1.0, d: float = 2.0
               ) -> np.ndarray:
    """(steps, n + 1, 2) tips of the cranks from their angles (numpy)."""
    th = np.stack([res.variable(f"G{i}") for i in range(n + 1)], axis=1)
    x = np.arange(n + 1) * d - a * np.sin(th)
    y = a * np.cos(th)
    return np.stack([x, y], axis=-1)


# ------------------------------------------------------------------ parallelograms
@pytest.mark.parametrize("step", [1.0, 3.0, 5.0, 7.0])
@pytest.mark.parametrize("sense", [1.0, -1.0])
def test_parallelogram_stays_a_parallelogram_and_reports_every_change_point(step, sense):
    """Four turns in steps of 1, 3, 5, 7 deg, both senses: the two cranks stay equal to
    1e-9 at every step (on the anti-parallelogram they would part by the step and more),
    and every crossing of a change point (cranks horizontal, 90 + 180 k deg) is
    reported as a change point, mobility 1 -> 2, continued on the smooth branch."""
    s = openimp.compile(chain(1))
    th = sense * np.radians(np.arange(0.0, 4 * 360.0 + 1e-9, step))
    res = openimp.sweep(s, {"G0": th})
    assert res.complete, res.message
    assert np.max(np.abs(res.variable("G1") - res.variable("G0"))) < 1e-9
    tips = crank_tips(res, 1)
    coupler = np.linalg.norm(tips[:, 1] - tips[:, 0], axis=1)
    assert np.max(np.abs(coupler - 2.0)) < 1e-9  # the loop closes
    sing = res.singularities
    expect = sense * np.radians(90.0 + 180.0 * np.arange(8))
    assert len(sing) == 8, [str(r) for r in sing]
    got = np.array([r.drivers["G0.theta"] for r in sing])
    np.testing.assert_allclose(got, expect, atol=1e-5)  # located to 1e-5 rad
    for r in sing:
        assert r.kind == "change point" and r.regular == 1 and r.mobility == 2
        assert "tangent continues the motion" in r.branch
    landed = [r.landed for r in sing]
    assert all(landed) == (90.0 % step == 0.0)


def test_anti_parallelogram_start_stays_anti():
    """Started on the anti-parallelogram (crossed) assembly, four turns in 3 deg steps stay
    on it: the second crank's tip is, at every step, the crossed intersection of the
    circles about the first tip (radius 2) and its pivot (radius 1), to 1e-9."""
    a, d = 1.0, 2.0
    th0 = 60 * DEG
    T0 = np.array([-a * math.sin(th0), a * math.cos(th0), 0.0])
    piv = np.array([d, 0.0, 0.0])
    T1 = _circles(T0, d, piv, a, up=False)   # the parallelogram's tip is (d + T0x, T0y)
    assert np.linalg.norm(T1 - (piv + T0)) > 0.1
    m = openimp.Model("anti")
    m.add_joint("revolute", "G0", "BASE", "K0", origin=(0, 0, 0))
    m.add_joint("revolute", "G1", "BASE", "K1", origin=piv)
    m.add_joint("revolute", "T0a", "K0", "C0", origin=T0)
    m.add_joint("revolute", "T0b", "C0", "K1", origin=T1)
    s = openimp.compile(m)
    th = np.radians(np.arange(0.0, 4 * 360.0 + 1e-9, 3.0))
    res = openimp.sweep(s, {"G0": th})
    assert res.complete, res.message
    g0 = th0 + res.variable("G0")
    tip0 = np.stack([-a * np.sin(g0), a * np.cos(g0)], axis=1)
    phi1 = math.atan2(T1[1] - piv[1], T1[0] - piv[0]) + res.variable("G1")
    tip1 = piv[:2] + a * np.stack([np.cos(phi1), np.sin(phi1)], axis=1)
    par = tip0 + piv[:2]   # where the parallelogram would put it
    assert np.max(np.abs(np.linalg.norm(tip1 - tip0, axis=1) - d)) < 1e-9
    away = np.linalg.norm(par - tip1, axis=1)
    far = away > 1e-3   # off the change points, where both assemblies coincide
    for k in np.flatnonzero(far):
        anti = _circles(np.append(tip0[k], 0.0), d, piv, a, up=False)[:2]
        other = _circles(np.append(tip0[k], 0.0), d, piv, a, up=True)[:2]
        cross = anti if np.linalg.norm(anti - par[k]) > np.linalg.norm(other - par[k]) else other
        assert np.linalg.norm(tip1[k] - cross) < 1e-9, k
    assert far.mean() > 0.9


@pytest.mark.parametrize("n", [2, 5, 10, 40])
def test_chains_of_parallelograms_stay_parallelograms(n):
    """N parallelograms in a row driven by the first crank through four turns in 3 deg
    steps: every crank equals the first to 1e-9 at every step, and the change points
    (all cranks horizontal: the mobility jumps from 1 to N + 1) are reported."""
    s = openimp.compile(chain(n))
    th = np.radians(np.arange(0.0, 4 * 360.0 + 1e-9, 3.0))
    res = openimp.sweep(s, {"G0": th})
    assert res.complete, res.message
    g = np.stack([res.variable(f"G{i}") for i in range(n + 1)], axis=1)
    assert np.max(np.abs(g - g[:, :1])) < 1e-9
    sing = res.singularities
    assert len(sing) == 8, [str(r) for r in sing]
    for r, k in zip(sing, range(8)):
        assert r.kind == "change point" and r.mobility == n + 1
        assert r.drivers["G0.theta"] == pytest.approx(np.radians(90 + 180 * k), abs=1e-5)


# ------------------------------------------------------------ change-point four-bars
def _orientation(res: openimp.Trajectory) -> np.ndarray:
    """Sign of the area of the triangle B, C, D (numpy): the assembly mode (0 where the
    three are collinear within 1e-4: a posture next to a change point is accurate to
    about the square root of the tolerance)."""
    B, C = res.point("PB"), res.point("PC")
    D = np.array([2.0, 0.0, 0.0])
    area = np.cross(C - B, D - B)[:, 2]
    return np.where(np.abs(area) > 1e-4, np.sign(area), 0.0)


def _closes(res: openimp.Trajectory, b: float, c: float, d: float = 2.0) -> float:
    """Largest error of the coupler and rocker lengths along the motion (numpy)."""
    B, C = res.point("PB"), res.point("PC")
    D = np.array([d, 0.0, 0.0])
    return float(max(np.max(np.abs(np.linalg.norm(C - B, axis=1) - b)),
                     np.max(np.abs(np.linalg.norm(C - D, axis=1) - c))))


def test_grashof_change_point_smooth_and_other_branch():
    """a + b = c + d (1 + 3 = 2 + 2): the crank passes two change points in two turns
    (5 deg steps).  The smooth continuation keeps the rocker's motion tangent-continuous
    (second differences of its angle bounded) and so changes the assembly mode (the sign
    of the area B, C, D flips at each change point); branch='other' keeps the mode
    instead.  Both are reported, the loops close to 1e-9."""
    m, _ = fourbar(1.0, 3.0, 2.0, 2.0, 40 * DEG)
    s = openimp.compile(m)
    th = np.radians(np.arange(0.0, 720.0 + 1e-9, 5.0))
    smooth = openimp.sweep(s, {"A": th})
    other = openimp.sweep(s, {"A": th}, branch="other")
    for res in (smooth, other):
        assert res.complete, res.message
        assert _closes(res, 3.0, 2.0) < 1e-9
        assert [r.kind for r in res.singularities] == ["change point"] * 2
    assert all("tangent continues" in r.branch for r in smooth.singularities)
    assert all("other branch" in r.branch for r in other.singularities)
    o_s, o_o = _orientation(smooth), _orientation(other)
    flips_s = np.count_nonzero(np.diff(o_s[o_s != 0]))
    flips_o = np.count_nonzero(np.diff(o_o[o_o != 0]))
    assert flips_s == 2 and flips_o == 0
    # smooth: the rocker angle's second difference stays of the order of the step's
    # square; on the other branch it kinks (a first-difference jump) at the change point
    d2s = np.abs(np.diff(smooth.variable("D"), 2))
    d2o = np.abs(np.diff(other.variable("D"), 2))
    assert d2s.max() < 0.05 and d2o.max() > 0.1


def test_kite_through_its_change_points():
    """A kite (crank = ground = 1, coupler = rocker = 2) turned twice by its crank passes
    the change point where the crank's tip meets the rocker's pivot, once a turn: the
    smooth continuation is taken and reported, the loops close to 1e-9.  There the
    other branch is the folded one, on which coupler and rocker turn about the pivot
    while the crank stands still: turning the crank cannot follow it, and
    branch='other' says so and goes on smoothly."""
    m, _ = fourbar(1.0, 2.0, 2.0, 1.0, 40 * DEG)
    s = openimp.compile(m)
    th = np.radians(np.arange(0, 721, 5.0))
    res = openimp.sweep(s, {"A": th})
    assert res.complete, res.message
    assert _closes(res, 2.0, 2.0, d=1.0) < 1e-9
    assert [r.kind for r in res.singularities] == ["change point"] * 2
    assert all("tangent continues" in r.branch for r in res.singularities)
    B = res.point("PB")
    for r in res.singularities:  # the crank's tip is on the rocker's pivot there
        assert np.linalg.norm(B[r.step] - [1.0, 0.0, 0.0]) < 1e-6
    other = openimp.sweep(s, {"A": th}, branch="other")
    assert other.complete and len(other.singularities) == 2
    assert all("does not move the drivers" in r.branch for r in other.singularities)
    np.testing.assert_allclose(other.q, res.q, atol=1e-9)


# ------------------------------------------------------------------- dead points
def test_dead_point_stops_or_switches_the_input():
    """A crank-rocker driven by its rocker reaches the rocker's limit of travel: the sweep
    stops there with its message and reports a dead point; with at_limit='switch' the
    crank takes over (the variable that moves most there), the switch is reported, the
    crank turns on in the same sense and the loop closes (numpy) at every step."""
    m, _ = fourbar(1.0, 3.0, 2.5, 3.2, 40 * DEG)
    s = openimp.compile(m)
    psi = -np.radians(np.arange(0.0, 120.0, 2.0))
    stop = openimp.sweep(s, {"D": psi})
    assert not stop.complete and "limit of travel" in stop.message
    assert [r.kind for r in stop.singularities] == ["dead point"]
    assert "stops" in stop.singularities[0].branch
    go = openimp.sweep(s, {"D": psi}, at_limit="switch")
    assert go.complete, go.message
    (w,) = go.switches
    assert (w.old, w.new) == ("D.theta", "A.theta") and w.step == stop.nsteps
    crank = go.variable("A")[w.step - 1:]
    assert np.all(np.diff(crank) > 0) or np.all(np.diff(crank) < 0)
    B, C = go.point("PB"), go.point("PC")
    D = np.array([3.2, 0.0, 0.0])
    assert np.max(np.abs(np.linalg.norm(C - B, axis=1) - 3.0)) < 1e-9
    assert np.max(np.abs(np.linalg.norm(C - D, axis=1) - 2.5)) < 1e-9
    assert any(r.kind == "dead point" and "switched" in r.branch for r in go.singularities)


def test_options_are_checked():
    m, _ = fourbar(1.0, 3.0, 2.5, 3.2, 40 * DEG)
    s = openimp.compile(m)
    with pytest.raises(openimp.InputError, match="branch"):
        openimp.sweep(s, {"A": [0.0, 0.1]}, branch="left")
    with pytest.raises(openimp.InputError, match="at_limit"):
        openimp.sweep(s, {"A": [0.0, 0.1]}, at_limit="go")


def test_ordinary_sweep_reports_nothing():
    """A crank-rocker turned by its crank has no singular posture: nothing is reported
    and the table of singular postures is empty."""
    m, _ = fourbar(1.0, 3.0, 2.5, 3.2, 40 * DEG)
    res = openimp.sweep(openimp.compile(m), {"A": np.radians(np.arange(0, 721, 1.0))})
    assert res.complete and res.singularities == [] and res.switches == []
    assert len(res.singularity_table()["step"]) == 0


# ------------------------------------------------------------------------ decks
DECK = """TITLE = PARALLELOGRAM
ZPIN (BASE, K0) = G0
ZPIN (BASE, K1) = G1
ZPIN (K0, C) = TA
ZPIN (C, K1) = TB
DATA ZPIN (G0) = 0,0,0; 0,0,1; 1,0,0
DATA ZPIN (G1) = 2,0,0; 2,0,1; 3,0,0
DATA ZPIN (TA) = 0,1,0; 0,1,1; 1,1,0
DATA ZPIN (TB) = 2,1,0; 2,1,1; 3,1,0
{directive}DATA POSITION (G0) = 0, 7, 60
LIST POSITION (G0, G1)
EXECUTE
END
"""


@pytest.mark.parametrize("directive, same", [("", True),
                                             ("REMARK OPENIMP BRANCH = OTHER\n", False)])
def test_deck_reports_change_points_and_takes_the_branch_asked(tmp_path, directive, same):
    """A deck's listing names every change point; REMARK OPENIMP BRANCH = OTHER (a remark
    to IMP itself) takes the other branch, where the cranks part."""
    p = tmp_path / "para.imp"
    p.write_text(DECK.format(directive=directive))
    lines: list[str] = []
    (run,) = load(p).run(echo=lines.append)
    assert run.ok, run.failure
    notes = [m for m in run.messages if m.startswith("Singular posture")]
    assert len(notes) == 2 and all("change point" in m for m in notes)
    g0 = run.table("LIST POSITION", "joint G0").rows[:, 1]
    g1 = run.table("LIST POSITION", "joint G1").rows[:, 1]
    assert (np.max(np.abs(g1 - g0)) < 1e-6) == same
    assert any("Singular posture" in line for line in lines)


def test_unknown_directive_is_an_input_error(tmp_path):
    p = tmp_path / "bad.imp"
    p.write_text(DECK.format(directive="REMARK OPENIMP BRANCH = LEFT\n"))
    with pytest.raises(openimp.InputError, match=r"bad.imp:10: .*BRANCH = SMOOTH or OTHER"):
        load(p)
