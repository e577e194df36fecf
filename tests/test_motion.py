"""Motions of the drivers (openimp.motion) and how sweeps take driver rates.

* Every Motion class: velocity and acceleration against fourth-order central
  differences of its own position (and of its velocity), tolerance 1e-8
  relative at dt = 1e-3 (truncation ~dt^4, round-off ~eps/dt^2 ~ 1e-10).
* sweep(motion=..., times=...) gives exactly the same result as
  sweep(drivers, rates, accels) with the values the motions return.
* DATA POSITION-style input (IMP: positions start, start+inc, ...; DATA
  VELOCITY / DATA ACCEL one value or one per step): the rates of each step
  depend only on that step; the joint rates are linear in the driver rate
  and the driver acceleration enters linearly:  qd = G psid,
  qdd = G psidd + H psid^2 (checked to 1e-12 against unit-rate sweeps).
* Bad input (different lengths, non-finite values, rates for a joint that is
  not a driver, malformed motions) raises openimp.InputError.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import openimp
from openimp import InputError, Model
from openimp.motion import ConstantRate, FromCallable, Harmonic, Motion, Polynomial, Tabulated

DEG = math.pi / 180.0


def fd4(f: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Fourth-order central first and second differences at the interior steps 2..n-3."""
    v = (-f[4:] + 8.0 * f[3:-1] - 8.0 * f[1:-3] + f[:-4]) / (12.0 * dt)
    a = (-f[4:] + 16.0 * f[3:-1] - 30.0 * f[2:-2] + 16.0 * f[1:-3] - f[:-4]) / (12.0 * dt * dt)
    return v, a


def relerr(x: np.ndarray, ref: np.ndarray) -> float:
    scale = float(np.max(np.abs(ref)))
    assert scale > 0.0
    return float(np.max(np.abs(x - ref))) / scale


# =============================================================================
# Mechanisms
# =============================================================================


def fourbar(a=1.0, b=3.0, c=2.5, d=3.2, th0=40 * DEG) -> Model:
    """Crank-rocker; joint A's variable is the crank angle measured from th0."""
    B = np.array([a * math.cos(th0), a * math.sin(th0), 0.0])
    D = np.array([d, 0.0, 0.0])
    BD = D - B
    L = float(np.linalg.norm(BD))
    x = (b * b - c * c + L * L) / (2 * L)
    y = math.sqrt(b * b - x * x)
    ex = BD / L
    C = B + x * ex + y * np.array([-ex[1], ex[0], 0.0])
    m = Model("fourbar")
    m.add_joint("revolute", "A", "BASE", "CRANK", origin=(0, 0, 0))
    m.add_joint("revolute", "B", "CRANK", "COUPLER", origin=B)
    m.add_joint("revolute", "C", "COUPLER", "ROCKER", origin=C)
    m.add_joint("revolute", "D", "ROCKER", "BASE", origin=D)
    m.add_point("P", "COUPLER", (B + C) / 2 + [0.0, 0.5, 0.0])
    return m


def fivebar() -> Model:
    """Five-bar with cranks A (origin) and E ((4, 0)): two drivers."""
    A, E = np.zeros(3), np.array([4.0, 0.0, 0.0])
    B = np.array([math.cos(60 * DEG), math.sin(60 * DEG), 0.0])
    D = E + 1.2 * np.array([math.cos(110 * DEG), math.sin(110 * DEG), 0.0])
    BD = D - B
    L = float(np.linalg.norm(BD))
    x = (9.0 - 3.2**2 + L * L) / (2 * L)
    y = math.sqrt(9.0 - x * x)
    ex = BD / L
    C = B + x * ex + y * np.array([-ex[1], ex[0], 0.0])
    m = Model("fivebar")
    m.add_joint("revolute", "A", "BASE", "L1", origin=A)
    m.add_joint("revolute", "B", "L1", "L2", origin=B)
    m.add_joint("revolute", "C", "L2", "L3", origin=C)
    m.add_joint("revolute", "D", "L3", "L4", origin=D)
    m.add_joint("revolute", "E", "L4", "BASE", origin=E)
    m.add_point("P", "L2", (B + C) / 2 + [0.1, 0.4, 0.0])
    return m


@pytest.fixture(scope="module")
def fb():
    return openimp.compile(fourbar())


@pytest.fixture(scope="module")
def five():
    return openimp.compile(fivebar())


# =============================================================================
# 1. Each motion's derivatives against differences of its position
# =============================================================================


def _vec_fn(t):
    return (0.2 + np.sin(3 * t) * np.exp(-0.3 * t),
            (3 * np.cos(3 * t) - 0.3 * np.sin(3 * t)) * np.exp(-0.3 * t),
            ((0.09 - 9) * np.sin(3 * t) - 1.8 * np.cos(3 * t)) * np.exp(-0.3 * t))


def _scalar_fn(t: float):
    # accepts only a float (math.*), so FromCallable must fall back to per-time calls
    return (math.cos(t) + 0.1 * t * t, -math.sin(t) + 0.2 * t, -math.cos(t) + 0.2)


TAB_T = np.linspace(0.0, 2.0, 9)
TAB_V = np.sin(np.pi * TAB_T) + 0.3 * TAB_T
TAB_VP = np.r_[np.sin(np.pi * TAB_T[:-1]), 0.0]  # periodic: ends on its first value

MOTIONS = {
    "constant-rate": lambda: ConstantRate(0.3, 2.5),
    "polynomial": lambda: Polynomial([0.1, -0.5, 2.0, 0.7, -0.3]),
    "harmonic": lambda: Harmonic(1.2, 2 * math.pi, 0.3, 0.5),
    "tabulated": lambda: Tabulated(TAB_T, TAB_V),
    "tabulated-periodic": lambda: Tabulated(TAB_T, TAB_VP, periodic=True),
    "callable-vectorised": lambda: FromCallable(_vec_fn),
    "callable-scalar-only": lambda: FromCallable(_scalar_fn),
}


@pytest.mark.parametrize("name", list(MOTIONS))
def test_motion_derivatives_match_differences(name):
    """v = dp/dt and a = dv/dt = d2p/dt2 by fourth-order central differences
    (dt = 1e-3, 1e-8 relative).  For the splines only stencils inside one
    knot interval are used (the spline is one cubic there)."""
    mo = MOTIONS[name]()
    dt = 1e-3
    t = np.arange(0.0, 2.0 + dt / 2, dt)
    p, v, a = mo(t)
    assert p.shape == v.shape == a.shape == t.shape
    assert np.all(np.isfinite(p)) and np.all(np.isfinite(v)) and np.all(np.isfinite(a))
    pv, pa = fd4(p, dt)
    vv, _ = fd4(v, dt)
    keep = np.ones(t.size - 4, bool)
    if name.startswith("tabulated"):
        tc = t[2:-2]
        for kn in TAB_T:
            keep &= np.abs(tc - kn) > 2.5 * dt
    if name == "constant-rate":
        assert np.all(a == 0.0)
        assert relerr(pv[keep], v[2:-2][keep]) < 1e-8
        assert np.max(np.abs(pa)) < 1e-6
        return
    assert relerr(pv[keep], v[2:-2][keep]) < 1e-8
    assert relerr(pa[keep], a[2:-2][keep]) < 1e-8
    assert relerr(vv[keep], a[2:-2][keep]) < 1e-8


def test_tabulated_interpolates_and_periodic_closes():
    """The spline passes through its table; the periodic one has equal value,
    slope and curvature at both ends."""
    p, _, _ = Tabulated(TAB_T, TAB_V)(TAB_T)
    np.testing.assert_allclose(p, TAB_V, rtol=0, atol=1e-14)
    p, v, a = Tabulated(TAB_T, TAB_VP, periodic=True)(np.array([TAB_T[0], TAB_T[-1]]))
    assert abs(p[0] - p[1]) < 1e-14 and abs(v[0] - v[1]) < 1e-12 and abs(a[0] - a[1]) < 1e-10


def test_motion_values_against_formulas():
    """Spot values of the closed-form motions (independent evaluation)."""
    t = np.array([0.0, 0.37, 1.5])
    p, v, a = ConstantRate(0.3, 2.5)(t)
    np.testing.assert_allclose(p, 0.3 + 2.5 * t, rtol=1e-15)
    np.testing.assert_array_equal(v, 2.5)
    p, v, a = Polynomial([1.0, 2.0, 3.0])(t)  # 1 + 2t + 3t^2
    np.testing.assert_allclose(p, 1 + 2 * t + 3 * t * t, rtol=1e-15)
    np.testing.assert_allclose(v, 2 + 6 * t, rtol=1e-15)
    np.testing.assert_allclose(a, 6.0, rtol=1e-15)
    p, v, a = Harmonic(2.0, 3.0, 0.5, 1.0)(t)
    np.testing.assert_allclose(p, 1 + 2 * np.sin(3 * t + 0.5), rtol=1e-15)
    np.testing.assert_allclose(v, 6 * np.cos(3 * t + 0.5), rtol=1e-15)
    np.testing.assert_allclose(a, -18 * np.sin(3 * t + 0.5), rtol=1e-15)


# =============================================================================
# 2. sweep(motion=..., times=...) == sweep(drivers, rates, accels)
# =============================================================================


def _same_result(r1, r2) -> None:
    np.testing.assert_array_equal(r1.q, r2.q)
    np.testing.assert_array_equal(r1.qd, r2.qd)
    np.testing.assert_array_equal(r1.qdd, r2.qdd)
    np.testing.assert_array_equal(r1.consistency, r2.consistency)
    np.testing.assert_array_equal(r1.quality, r2.quality)


def test_sweep_motion_equals_arrays_one_driver(fb):
    times = np.linspace(0.0, 1.0, 181)
    mo = Harmonic(2.0, 2 * math.pi, 0.0, 0.0)
    r1 = openimp.sweep(fb, motion={"A": mo}, times=times)
    p, v, a = mo(times)
    r2 = openimp.sweep(fb, {"A": p}, {"A": v}, {"A": a})
    assert r1.complete and r2.complete
    _same_result(r1, r2)
    np.testing.assert_array_equal(r1.time, times)
    assert r2.time is None
    np.testing.assert_array_equal(r1.point_acceleration("P"), r2.point_acceleration("P"))
    np.testing.assert_array_equal(r1.angular_velocity("ROCKER"), r2.angular_velocity("ROCKER"))
    np.testing.assert_array_equal(r1.variable("A"), p)
    np.testing.assert_array_equal(r1.joint_velocity("A")[:, 0], v)
    np.testing.assert_array_equal(r1.joint_acceleration("A")[:, 0], a)
    tab = r1.to_table()
    np.testing.assert_array_equal(tab["time"], times)
    np.testing.assert_array_equal(tab["A.theta'"], v)
    np.testing.assert_array_equal(tab["D.theta''"], r1.qdd[:, 3])


def test_sweep_motion_equals_arrays_two_drivers_mixed_kinds(five):
    """Five-bar: a polynomial crank A, a tabulated E given as a Motion, and
    also with E as a plain function of time (wrapped like FromCallable)."""
    times = np.linspace(0.0, 1.0, 121)
    mA = Polynomial([0.0, 4.0, -1.0, 0.5])
    mE = Tabulated(np.linspace(0.0, 1.0, 11), 0.4 * np.sin(np.linspace(0.0, 1.0, 11) * 5))
    r1 = openimp.sweep(five, motion={"A": mA, "E": mE}, times=times)
    pA, vA, aA = mA(times)
    pE, vE, aE = mE(times)
    r2 = openimp.sweep(five, {"A": pA, "E": pE}, {"A": vA, "E": vE}, {"A": aA, "E": aE})
    assert r1.complete and r2.complete
    _same_result(r1, r2)
    r3 = openimp.sweep(five, motion={"A": mA, "E": lambda t: mE(t)}, times=times)
    _same_result(r1, r3)
    r4 = openimp.sweep(five, motion={"A": mA, "E.theta": FromCallable(lambda t: mE(t))},
                       times=times)
    _same_result(r1, r4)


def test_motion_sweep_rates_match_differences(fb):
    """The rates of a motion sweep agree with differences of its positions in
    time (fourth-order central, 1e-6 relative)."""
    times = np.linspace(0.0, 1.0, 2001)
    res = openimp.sweep(fb, motion={"A": Polynomial([0.0, 1.0, 5.0, -2.0])}, times=times)
    assert res.complete
    dt = times[1] - times[0]
    v, a = fd4(res.q, dt)
    assert relerr(v, res.qd[2:-2]) < 1e-6
    assert relerr(a, res.qdd[2:-2]) < 1e-6
    v, a = fd4(res.point("P"), dt)
    assert relerr(v, res.point_velocity("P")[2:-2]) < 1e-6
    assert relerr(a, res.point_acceleration("P")[2:-2]) < 1e-6


# =============================================================================
# 3. DATA POSITION-style per-step rates
# =============================================================================


def _data_position(start_deg: float, inc_deg: float, nsteps: int) -> np.ndarray:
    """IMP's DATA POSITION (joint) = start, increment, nsteps: nsteps + 1 positions."""
    return np.radians(start_deg + inc_deg * np.arange(nsteps + 1))


def test_data_position_per_step_rates(fb):
    """DATA POSITION (A) = -90, 15, 24 with per-step DATA VELOCITY / ACCEL.

    With G = qd at psid = 1, psidd = 0 and H = qdd there, every step k must
    give qd = G psid_k and qdd = G psidd_k + H psid_k^2 (1e-12 relative), i.e.
    the rates of a step use that step's values only.  One value stands for all
    steps and equals the same value repeated."""
    pos = _data_position(-90.0, 15.0, 24)
    n = pos.size
    assert n == 25
    unit = openimp.sweep(fb, {"A": pos}, {"A": 1.0}, {"A": 0.0})
    assert unit.complete
    G, H = unit.qd, unit.qdd
    np.testing.assert_array_equal(G[:, 0], 1.0)
    rng = np.random.default_rng(7)
    psid = rng.uniform(-30.0, 30.0, n)
    psidd = rng.uniform(-200.0, 200.0, n)
    res = openimp.sweep(fb, {"A": pos}, {"A": psid}, {"A": psidd})
    np.testing.assert_array_equal(res.q, unit.q)
    assert relerr(res.qd, G * psid[:, None]) < 1e-12
    assert relerr(res.qdd, G * psidd[:, None] + H * (psid**2)[:, None]) < 1e-12
    # body and point rates follow the same rule
    wG = unit.angular_velocity("COUPLER")
    aH = unit.angular_acceleration("COUPLER")
    assert relerr(res.angular_velocity("COUPLER"), wG * psid[:, None]) < 1e-12
    assert relerr(res.angular_acceleration("COUPLER"),
                  wG * psidd[:, None] + aH * (psid**2)[:, None]) < 1e-12
    # the order of the steps does not matter for the rates of a step
    # (the postures are reached along another path: equal to the solver's tolerance)
    rev = openimp.sweep(fb, {"A": pos[::-1]}, {"A": psid[::-1]}, {"A": psidd[::-1]})
    assert relerr(rev.qd[::-1], res.qd) < 1e-10
    assert relerr(rev.qdd[::-1], res.qdd) < 1e-10
    # one value == that value at every step (as a list, a 1-element array, a scalar)
    r1 = openimp.sweep(fb, {"A": pos}, {"A": 2.5}, {"A": -4.0})
    for rate, acc in (([2.5], [-4.0]), (np.array([2.5]), np.array([-4.0])),
                      (np.full(n, 2.5), np.full(n, -4.0))):
        r2 = openimp.sweep(fb, {"A": pos}, {"A": rate}, {"A": acc})
        np.testing.assert_array_equal(r1.qd, r2.qd)
        np.testing.assert_array_equal(r1.qdd, r2.qdd)


def test_rates_or_accels_alone_and_none(fb):
    """Only rates: the driver acceleration is 0 (qdd = H psid^2); only accels: the
    velocities are 0 (qdd = G psidd); neither: no rates, and asking for them is
    an InputError saying how to get them."""
    pos = _data_position(0.0, 10.0, 12)
    unit = openimp.sweep(fb, {"A": pos}, {"A": 1.0}, {"A": 0.0})
    r = openimp.sweep(fb, {"A": pos}, rates={"A": 3.0})
    assert relerr(r.qd, 3.0 * unit.qd) < 1e-12
    assert relerr(r.qdd, 9.0 * unit.qdd) < 1e-12
    r = openimp.sweep(fb, {"A": pos}, accels={"A": 5.0})
    assert np.all(r.qd == 0.0)
    assert relerr(r.qdd, 5.0 * unit.qd) < 1e-12
    r = openimp.sweep(fb, {"A": pos})
    assert not r.has_rates
    with pytest.raises(InputError, match="velocit"):
        _ = r.qd
    with pytest.raises(InputError):
        r.point_velocity("P")
    with pytest.raises(InputError):
        r.angular_acceleration("COUPLER")


def test_two_driver_rates_superpose(five):
    """Five-bar: qd is linear in (psid_A, psid_E); qdd at (psid, 0) is a quadratic
    form: qdd(a + b) + qdd(a - b) = 2 qdd(a) + 2 qdd(b)."""
    pos = {"A": np.radians(np.arange(0.0, 50.0, 5.0)), "E": np.radians(np.arange(0.0, 20.0, 2.0))}
    a = {"A": 1.5, "E": -0.7}
    b = {"A": -0.4, "E": 2.0}

    def run(x, y, sx=1.0, sy=1.0):
        r = {k: sx * x[k] + sy * y[k] for k in x}
        return openimp.sweep(five, pos, r, {"A": 0.0, "E": 0.0})

    ra, rb = run(a, b, 1, 0), run(a, b, 0, 1)
    rp, rm = run(a, b, 1, 1), run(a, b, 1, -1)
    assert relerr(rp.qd, ra.qd + rb.qd) < 1e-12
    assert relerr(rp.qdd + rm.qdd, 2 * ra.qdd + 2 * rb.qdd) < 1e-11


# =============================================================================
# 4. Bad input
# =============================================================================


def test_bad_lengths(five, fb):
    with pytest.raises(InputError, match="same number"):
        openimp.sweep(five, {"A": [0.0, 0.1, 0.2], "E": [0.0, 0.1]})
    pos = [0.0, 0.1, 0.2]
    with pytest.raises(InputError, match="rate"):
        openimp.sweep(fb, {"A": pos}, {"A": [1.0, 2.0]})
    with pytest.raises(InputError, match="acceleration"):
        openimp.sweep(fb, {"A": pos}, {"A": 1.0}, {"A": [1.0, 2.0, 3.0, 4.0]})
    with pytest.raises(InputError):
        openimp.sweep(fb, {"A": pos}, {"A": np.ones((3, 1))})
    with pytest.raises(InputError):
        openimp.sweep(fb, {"A": []})
    with pytest.raises(InputError):
        openimp.sweep(five, motion={"A": ConstantRate(0, 1), "E": ConstantRate(0, 1)},
                   times=np.zeros((2, 3)))


@pytest.mark.filterwarnings("ignore:invalid value encountered:RuntimeWarning")
@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_non_finite_values(fb, bad):
    pos = np.array([0.0, 0.1, 0.2])
    with pytest.raises(InputError):
        openimp.sweep(fb, {"A": np.r_[pos[:2], bad]})
    with pytest.raises(InputError):
        openimp.sweep(fb, {"A": pos}, {"A": [1.0, bad, 1.0]})
    with pytest.raises(InputError):
        openimp.sweep(fb, {"A": pos}, {"A": bad})
    with pytest.raises(InputError):
        openimp.sweep(fb, {"A": pos}, {"A": 1.0}, {"A": [0.0, 0.0, bad]})
    with pytest.raises(InputError):
        openimp.sweep(fb, motion={"A": Harmonic(1.0, 1.0)}, times=[0.0, bad])
    with pytest.raises(InputError):
        openimp.sweep(fb, motion={"A": FromCallable(lambda t: (t, t * bad, 0 * t))},
                      times=[0.0, 1.0])

    class BadRate(Motion):
        def __call__(self, t):
            t = np.asarray(t, float)
            return t, np.full_like(t, bad), np.zeros_like(t)

    with pytest.raises(InputError):
        openimp.sweep(fb, motion={"A": BadRate()}, times=[0.0, 0.5, 1.0])


def test_rates_for_a_non_driver(fb, five):
    pos = [0.0, 0.1, 0.2]
    with pytest.raises(InputError, match="not one of the drivers"):
        openimp.sweep(fb, {"A": pos}, {"B": 1.0})
    with pytest.raises(InputError, match="not one of the drivers"):
        openimp.sweep(fb, {"A": pos}, {"A": 1.0}, {"C": 1.0})
    with pytest.raises(InputError, match="not one of the drivers"):
        openimp.sweep(five, {"A": pos, "E": pos}, {"A": 1.0, "E": 1.0, "D.theta": 0.0})
    with pytest.raises(InputError, match="unknown joint"):
        openimp.sweep(fb, {"A": pos}, {"Z": 1.0})
    with pytest.raises(InputError):
        openimp.sweep(fb, {"A": pos}, {"A": "fast"})


def test_rate_keys_name_the_same_variable_as_the_driver(fb):
    """Rates may name the driver as 'A', 'A.theta' or ('A', 0)."""
    pos = [0.0, 0.1, 0.2]
    ref = openimp.sweep(fb, {"A": pos}, {"A": 2.0}, {"A": 1.0})
    for kr, ka in (("A.theta", ("A", 0)), (("A", "theta"), "A")):
        r = openimp.sweep(fb, {"A": pos}, {kr: 2.0}, {ka: 1.0})
        np.testing.assert_array_equal(r.qd, ref.qd)
        np.testing.assert_array_equal(r.qdd, ref.qdd)


def test_rate_given_twice_is_an_error(fb):
    with pytest.raises(InputError):
        openimp.sweep(fb, {"A": [0.0, 0.1]}, {"A": 1.0, "A.theta": 2.0})


def test_bad_motion_requests(fb):
    times = np.linspace(0, 1, 5)
    with pytest.raises(InputError, match="not both"):
        openimp.sweep(fb, {"A": [0.0]}, motion={"A": ConstantRate(0, 1)}, times=times)
    with pytest.raises(InputError, match="times"):
        openimp.sweep(fb, motion={"A": ConstantRate(0, 1)})
    with pytest.raises(InputError, match="motion"):
        openimp.sweep(fb, motion={"A": 3.0}, times=times)
    with pytest.raises(InputError):
        openimp.sweep(fb, motion={"A": FromCallable(lambda t: "abc")}, times=times)
    with pytest.raises(InputError):
        openimp.sweep(fb, motion={"A": FromCallable(lambda t: (t, t, t[:2]))}, times=times)
    with pytest.raises(InputError):
        openimp.sweep(fb, motion={"B": ConstantRate(0, 1), "A": ConstantRate(0, 1)}, times=times)
    with pytest.raises(InputError):
        openimp.sweep(fb)
    with pytest.raises(InputError):
        Motion()(times)


@pytest.mark.parametrize("arity", [2, 4])
def test_motion_function_with_wrong_number_of_values(fb, arity):
    """A motion function must return (position, velocity, acceleration)."""
    times = np.linspace(0, 1, 5)
    mo = FromCallable(lambda t: (t,) * arity)
    with pytest.raises(InputError, match="position, velocity, acceleration"):
        mo(times)
    with pytest.raises(InputError):
        openimp.sweep(fb, motion={"A": mo}, times=times)


def test_bad_motion_definitions():
    with pytest.raises(InputError):
        Polynomial([])
    with pytest.raises(InputError):
        Polynomial([1.0, math.nan])
    with pytest.raises(InputError):
        Tabulated([0, 1, 2], [0, 1, 2])  # fewer than 4 points
    with pytest.raises(InputError):
        Tabulated([0, 1, 2, 3], [0, 1, 2])  # lengths differ
    with pytest.raises(InputError):
        Tabulated([0, 1, 1, 3], [0, 1, 2, 3])  # not increasing
    with pytest.raises(InputError):
        Tabulated([0, 2, 1, 3], [0, 1, 2, 3])
    with pytest.raises(InputError):
        Tabulated([0, 1, 2, 3], [0, 1, 2, 0.5], periodic=True)
    with pytest.raises(InputError):
        FromCallable(42)


def test_input_error_is_the_public_type():
    assert openimp.InputError is InputError
    assert issubclass(InputError, ValueError)
