"""One vocabulary of the Python API (docs/python.md, "One vocabulary").

Every analysis reads ``q`` (a posture in model units: the nq joint variables or
a mapping of joint variables to values), ``state=`` (a State, internal units)
and ``specified=`` the same way; a renamed argument keeps working for one
release with a DeprecationWarning naming the new name, and gives the same
result.  References are written here in plain numpy: a double pendulum with
joint springs under gravity, its potential V(a, b) and gradient in closed form.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import openimp
from openimp.errors import InputError
from openimp.system import make_state

G = 9.81
#: link 1 on A (BASE -> L1) at the origin, link 2 on B (L1 -> L2) at (L1, 0); centres
#: c1 on L1 and (L1, 0) + c2 on L2 at the modeling posture; springs kA, kB free at 0
L1, M1, C1, M2, C2, KA, KB = 1.0, 2.0, (0.45, 0.08), 1.5, (0.6, -0.1), 60.0, 25.0


def double_pendulum(units: str = "SI") -> openimp.Model:
    m = openimp.Model("double pendulum")
    m.add_joint("revolute", "A", "BASE", "L1", origin=(0.0, 0.0, 0.0), axis=(0, 0, 1))
    m.add_joint("revolute", "B", "L1", "L2", origin=(L1, 0.0, 0.0), axis=(0, 0, 1))
    assert m.add_mass("L1", M1, center=(*C1, 0.0), inertia=np.diag([0.01, 0.05, 0.06])) == []
    assert m.add_mass("L2", M2, center=(L1 + C2[0], C2[1], 0.0),
                      inertia=np.diag([0.01, 0.04, 0.05])) == []
    m.set_gravity((0.0, -G, 0.0))
    m.set_joint_spring("A", KA, 0.0)
    m.set_joint_spring("B", KB, 0.0)
    return m


def rot(a: float) -> np.ndarray:
    return np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])


def gradient(a: float, b: float) -> np.ndarray:
    """dV/d(a, b) of V = 1/2 kA a^2 + 1/2 kB b^2 + g (m1 y1 + m2 y2) (b relative)."""
    c1, c2, r1 = np.array(C1), np.array(C2), np.array([L1, 0.0])
    perp = np.array([[0.0, -1.0], [1.0, 0.0]])
    d1_da = perp @ rot(a) @ c1
    d2_da = perp @ rot(a) @ (r1 + rot(b) @ c2)
    d2_db = rot(a) @ perp @ rot(b) @ c2
    return np.array([KA * a + G * (M1 * d1_da[1] + M2 * d2_da[1]),
                     KB * b + G * M2 * d2_db[1]])


@pytest.fixture(scope="module")
def dp() -> openimp.System:
    return openimp.compile(double_pendulum())


def test_gradient_reference_by_finite_differences():
    """The closed-form gradient against central differences of V itself."""
    def V(a, b):
        y1 = (rot(a) @ np.array(C1))[1]
        y2 = (rot(a) @ (np.array([L1, 0.0]) + rot(b) @ np.array(C2)))[1]
        return 0.5 * KA * a * a + 0.5 * KB * b * b + G * (M1 * y1 + M2 * y2)
    h = 1e-6
    for a, b in [(0.3, -0.2), (1.1, 0.7)]:
        fd = [(V(a + h, b) - V(a - h, b)) / (2 * h), (V(a, b + h) - V(a, b - h)) / (2 * h)]
        assert np.allclose(gradient(a, b), fd, rtol=0, atol=1e-7)


# ----------------------------------------------------------------------------- sweep
def test_sweep_q_array_and_mapping(dp):
    """q as the nq values and as a mapping (the others at the modeling posture) start
    at the posture given; specified= holds B there while A is driven."""
    drive = {"A": np.linspace(0.0, 0.5, 6)}
    a = openimp.sweep(dp, drive, q=[0.0, 0.3], specified=["B"])
    b = openimp.sweep(dp, drive, q={"B": 0.3}, specified="B")
    assert np.array_equal(a.q, b.q)
    assert np.allclose(a.q[:, 1], 0.3, rtol=0, atol=1e-14)
    assert np.allclose(a.q[:, 0], drive["A"], rtol=0, atol=1e-14)
    with pytest.raises(InputError, match="B"):  # mobility 2, one driver
        openimp.sweep(dp, drive, q={"B": 0.3})


def test_sweep_start_is_deprecated_for_q(dp):
    drive = {"A": np.linspace(0.0, 0.5, 4)}
    new = openimp.sweep(dp, drive, q=[0.0, 0.3], specified="B")
    with pytest.warns(DeprecationWarning, match="use q") as rec:
        old = openimp.sweep(dp, drive, start=[0.0, 0.3], specified="B")
    assert rec[0].filename == __file__  # the user's line, not openimp's
    assert np.array_equal(new.q, old.q)
    with pytest.raises(InputError, match="q only"):
        openimp.sweep(dp, drive, q=[0.0, 0.3], start=[0.0, 0.3])


def test_sweep_state_and_bad_q(dp):
    drive = {"A": np.linspace(0.0, 0.5, 4)}
    S = make_state(dp, dp.to_internal(np.array([0.0, 0.3])))
    a = openimp.sweep(dp, drive, state=S, specified="B")
    b = openimp.sweep(dp, drive, q=[0.0, 0.3], specified="B")
    assert np.array_equal(a.q, b.q)
    with pytest.warns(DeprecationWarning, match="state=") as rec:  # a State as q
        c = openimp.sweep(dp, drive, q=S, specified="B")
    assert rec[0].filename == __file__ and np.array_equal(c.q, b.q)
    for q in ([0.0, 0.3], S):
        with pytest.raises(InputError, match="not both"):
            openimp.sweep(dp, drive, q=q, state=S)
    for bad, words in [({"B": "x"}, "q\\['B'\\]"), ({"Z": 1.0}, "Z"), ([0.0], "q must hold"),
                       ({"B": math.inf}, "finite")]:
        with pytest.raises(InputError, match=words):
            openimp.sweep(dp, drive, q=bad, specified="B")
    with pytest.raises(InputError, match="unknown option"):
        openimp.sweep(dp, drive, strat=[0.0, 0.3])


# ----------------------------------------------------------------------------- equilibrium
def _reference_equilibrium(start=(0.0, 0.0)) -> np.ndarray:
    """The equilibrium of the double pendulum by Newton on the closed-form gradient with a
    finite-difference Hessian (plain numpy)."""
    x = np.array(start, float)
    for _ in range(50):
        h = 1e-6
        H = np.column_stack([(gradient(*(x + h * e)) - gradient(*(x - h * e))) / (2 * h)
                             for e in np.eye(2)])
        dx = np.linalg.solve(H, -gradient(*x))
        x += dx
        if np.abs(dx).max() < 1e-14:
            break
    return x


def test_equilibrium_q_forms_and_state(dp):
    """q as an array, as a mapping, and state= all reach the closed-form equilibrium."""
    ref = _reference_equilibrium()
    assert np.abs(gradient(*ref)).max() < 1e-9
    a = openimp.equilibrium(dp, [0.0, 0.0], forces=False)
    b = openimp.equilibrium(dp, {"A": 0.0}, forces=False)
    c = openimp.equilibrium(dp, state=make_state(dp), forces=False)
    for e in (a, b, c):
        assert e.converged and e.code == openimp.SearchStatus.BALANCED
        np.testing.assert_allclose(e.q, ref, rtol=0, atol=1e-9)
    assert np.array_equal(a.q, b.q) and np.array_equal(a.q, c.q)


def test_equilibrium_specified_holds_at_q(dp):
    """specified=B holds B at its value in q; A balances dV/dA = 0 at that B."""
    e = openimp.equilibrium(dp, {"B": 0.4}, specified="B", forces=False)
    assert e.value("B") == 0.4
    assert abs(gradient(e.value("A"), 0.4)[0]) < 1e-8
    # the holding moment balances the generalized load -dV/dB
    assert e.holding["B.theta" if "B.theta" in e.holding else "B"] == pytest.approx(
        gradient(e.value("A"), 0.4)[1], abs=1e-8)


@pytest.mark.parametrize("old, new", [("rtol", "force_rtol"), ("max_steps", "max_iter")])
def test_equilibrium_deprecated_option_names(dp, old, new):
    """The old names work one more release, warn naming the new one, give the same."""
    value = {"force_rtol": 1e-6, "max_iter": 3}[new]
    got = openimp.equilibrium(dp, [0.0, 0.0], forces=False, **{new: value})
    with pytest.warns(DeprecationWarning, match=f"use {new}") as rec:
        old_got = openimp.equilibrium(dp, [0.0, 0.0], forces=False, **{old: value})
    assert rec[0].filename == __file__
    assert np.array_equal(got.q, old_got.q) and got.steps == old_got.steps
    assert np.array_equal(got.force_tol, old_got.force_tol)
    with pytest.raises(InputError, match=f"give {new} only"):
        openimp.equilibrium(dp, [0.0, 0.0], **{new: value, old: value})
    with pytest.warns(DeprecationWarning, match=f"use {new}"):
        path = openimp.equilibria(dp, {"B": [0.1, 0.2]}, forces=False, **{old: value})
    assert np.array_equal(path.q, openimp.equilibria(dp, {"B": [0.1, 0.2]}, forces=False,
                                                     **{new: value}).q)


def test_equilibrium_max_iter_caps_the_search(dp):
    e = openimp.equilibrium(dp, [1.0, -1.0], max_iter=1, forces=False)
    assert e.steps == 1 and e.code == openimp.SearchStatus.CAPPED and not e.converged
    assert repr(e.code) == "<SearchStatus.CAPPED: 3>" and str(e.code) == e.status


def test_equilibrium_state_as_q_is_deprecated(dp):
    S = make_state(dp, dp.to_internal(np.array([0.2, 0.1])), 1.5)
    new = openimp.equilibrium(dp, state=S, forces=False)
    with pytest.warns(DeprecationWarning, match="state=") as rec:
        old = openimp.equilibrium(dp, S, forces=False)
    assert rec[0].filename == __file__
    assert np.array_equal(new.q, old.q) and new.t == old.t == 1.5


def test_equilibria_progress_is_done_total(dp):
    seen = []
    path = openimp.equilibria(dp, {"B": [0.1, 0.2, 0.3]}, forces=False,
                              progress=lambda done, total: seen.append((done, total)))
    assert seen == [(1.0, 3.0), (2.0, 3.0), (3.0, 3.0)] and len(path.steps) == 3
    assert all(isinstance(x, float) for pair in seen for x in pair)


# ----------------------------------------------------------------------------- forces
def test_forces_of_and_deprecated_forces_of_trajectory(dp):
    """forces(system, drivers) in one pass and forces_of(trajectory) agree; the
    overloaded forces(trajectory) warns naming forces_of and gives the same; the
    drive of B held at 0.3 balances gravity and the spring (the closed-form dV/dB)."""
    drive = {"A": np.linspace(0.0, 0.5, 5)}
    one = openimp.forces(dp, drive, q={"B": 0.3}, specified="B")
    tr = openimp.sweep(dp, drive, q={"B": 0.3}, specified="B")
    two = openimp.forces_of(tr)
    with pytest.warns(DeprecationWarning, match="forces_of") as rec:
        old = openimp.forces(tr)
    assert rec[0].filename == __file__
    for name in ("A.theta", "B.theta"):
        np.testing.assert_allclose(one.drive[name], two.drive[name], rtol=0, atol=1e-10)
        assert np.array_equal(old.drive[name], two.drive[name])
    ref = np.array([gradient(a, 0.3) for a in drive["A"]])
    np.testing.assert_allclose(two.drive["A.theta"], ref[:, 0], rtol=0, atol=1e-9)
    np.testing.assert_allclose(two.drive["B.theta"], ref[:, 1], rtol=0, atol=1e-9)
    with pytest.raises(InputError, match="forces_of"):
        openimp.forces_of(dp)


# ----------------------------------------------------------------------------- workspaces
def test_workspaces_pool_never_shares_and_goes_with_the_system():
    """take hands out a scratch no one holds; give returns it for reuse; the pool of a
    system is dropped when the system is collected."""
    import gc

    from openimp.workspace import Workspaces

    class Sys:  # any weak-referenceable object stands for a System
        pass

    ws, made = Workspaces(), []

    def make(_s):
        made.append(object())
        return made[-1]

    s = Sys()
    assert len(ws) == 0
    a = ws.take(s, "k", make)
    b = ws.take(s, "k", make)  # a is held: a new one
    assert a is not b and len(made) == 2
    ws.give(s, "k", a)
    assert ws.take(s, "k", make) is a and len(made) == 2
    ws.give(s, "k", a)
    ws.give(s, "k", a)  # given twice: kept once
    assert ws.idle(s, "k") == 1
    with ws.use(s, "k", make) as c:
        assert c is a and ws.idle(s, "k") == 0
    assert ws.idle(s, "k") == 1 and ws.idle(s, "other") == 0 and len(ws) == 1
    del s
    gc.collect()
    assert len(ws) == 0


def _serial(dp):
    """The analyses of the re-entry and thread tests, one after the other."""
    path = openimp.equilibria(dp, {"B": [0.1, 0.2, 0.3]}, forces=False)
    single = openimp.equilibrium(dp, [0.8, -0.5], forces=False)
    lin = openimp.linearize(dp, list(single.q))
    tr = openimp.sweep(dp, {"A": np.linspace(0.0, 0.5, 5)}, q={"B": 0.3}, specified="B")
    return path, single, lin, openimp.forces_of(tr)


def test_analyses_reentered_from_a_progress_callback(dp):
    """equilibrium, linearize and forces called from the progress callback of a path on
    the same system (the path's scratch held meanwhile) give what they give alone, and
    the path what it gives alone."""
    from openimp.workspace import WORKSPACES

    path0, single0, lin0, f0 = _serial(dp)
    inner = []
    held = []

    def progress(done, total):
        held.append(WORKSPACES.idle(dp, "equilibrium"))
        _, single, lin, f = _serial(dp)
        inner.append((single, lin, f))

    path = openimp.equilibria(dp, {"B": [0.1, 0.2, 0.3]}, forces=False, progress=progress)
    assert np.array_equal(path.q, path0.q)
    assert [e.steps for e in path.steps] == [e.steps for e in path0.steps]
    for single, lin, f in inner:
        assert np.array_equal(single.q, single0.q)
        assert np.array_equal(lin.K, lin0.K) and np.array_equal(lin.M, lin0.M)
        assert np.array_equal(f.drive["B.theta"], f0.drive["B.theta"])
    assert WORKSPACES.idle(dp, "equilibrium") >= 2  # the path's and the nested ones


def test_two_threads_on_one_system_agree_with_serial(dp):
    """Two threads running the same analyses on one system at once give exactly the
    serial results (each call holds its own scratch)."""
    import threading

    ref = _serial(dp)
    got: list = [None, None]
    errors: list = []

    def work(i):
        try:
            for _ in range(3):
                got[i] = _serial(dp)
        except Exception as exc:  # reported below, with the thread's failure
            errors.append(exc)

    threads = [threading.Thread(target=work, args=(i,)) for i in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors, errors
    for path, single, lin, f in got:
        assert np.array_equal(path.q, ref[0].q) and np.array_equal(single.q, ref[1].q)
        assert np.array_equal(lin.K, ref[2].K) and np.array_equal(lin.D, ref[2].D)
        assert np.array_equal(f.drive["A.theta"], ref[3].drive["A.theta"])


def test_sweep_progress_is_done_total(dp):
    """progress(done, total): steps solved and steps, floats, the last call (n, n)."""
    seen = []
    n = 600
    openimp.sweep(dp, {"A": np.linspace(0.0, 1.0, n)}, specified="B",
                  progress=lambda done, total: seen.append((done, total)))
    assert seen and seen[-1] == (float(n), float(n))
    assert all(isinstance(x, float) and t == n for d, t in seen for x in (d, t))
    assert [d for d, _ in seen] == sorted(d for d, _ in seen)
    with pytest.raises(InputError, match="progress"):
        openimp.sweep(dp, {"A": [0.0]}, specified="B", progress=3)


def test_status_enums_are_the_compiled_codes():
    """SearchStatus and StepKind name the codes of the compiled search (statics)."""
    from openimp.dynamics import statics as st

    assert [int(c) for c in openimp.SearchStatus] == [st.BALANCED, st.NO_FREE, st.CAPPED,
                                                       st.FAILED]
    assert [int(k) for k in openimp.StepKind] == [st.NEWTON, st.DESCENT, st.MODIFIED,
                                                  st.NEUTRAL_STEP, st.ESCAPE]
    assert st.STEPPED not in set(openimp.SearchStatus)  # a step taken, not an end
    assert [str(c) for c in openimp.SearchStatus] == ["balanced", "no free coordinate",
                                                      "step cap", "failed"]
    assert f"{openimp.SearchStatus.CAPPED!r}" == "<SearchStatus.CAPPED: 3>"


def test_inputs_rates_and_postures_in_model_units():
    """kinematics.inputs, the one reading of q, rates and specified: model units in,
    internal out, a mapping filling the named variables (for lengths the internal unit is
    the model's length scale)."""
    from openimp.kinematics.inputs import names_of, per_coordinate, posture_input

    m = openimp.Model("slider")
    m.add_joint("prism", "X", "BASE", "B", origin=(0, 0, 0), axis=(1, 0, 0))
    m.add_joint("revolute", "R", "B", "C", origin=(0, 0, 0))
    m.add_point("P", "C", (4.0, 0, 0))
    sy = openimp.compile(m)
    Ls = sy.length_scale
    assert Ls != 1.0  # the test needs a length scale to see the units
    x, r = sy.var_index("X"), sy.var_index("R")
    q = posture_input(sy, {"X": 2.0})
    assert q[x] == pytest.approx(2.0 / Ls, rel=1e-15) and q[r] == 0.0
    np.testing.assert_allclose(posture_input(sy, [2.0, 0.5][::1 if x == 0 else -1]),
                               np.where(np.arange(2) == x, 2.0 / Ls, 0.5), rtol=1e-15)
    v = per_coordinate(sy, {"X": 3.0, "R": 0.25}, "rates")
    assert v[x] == pytest.approx(3.0 / Ls, rel=1e-15) and v[r] == 0.25
    np.testing.assert_array_equal(per_coordinate(sy, np.array([1.0, 1.0]), "rates"),
                                  np.where(np.arange(2) == x, 1.0 / Ls, 1.0))
    assert names_of("X", "t") == ["X"] and names_of(None, "t") == []
    for bad in ({"X": "a"}, [1.0], {"X": np.nan}):
        with pytest.raises(InputError, match="rates"):
            per_coordinate(sy, bad, "rates")
    with pytest.raises(InputError, match="specified"):
        names_of(5, "t")
