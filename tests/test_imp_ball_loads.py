"""Springs, dampers, motions and initial conditions on the variables of IMP's SPHERE,
OPEN and FLAT joints (issue 25 item 2): IMP's Cardan angles x-y'-z'' and FLAT's
polar form become the solver's coordinates (``gimbal``, ``open_cardan``,
``flat_polar``) when a deck acts on them.

Independent checks, in plain numpy/scipy here: the equilibrium of a bob on a ball
joint with a spring on each angle is the stationary point of its potential energy;
the free vibration about one axis is the damped oscillator's closed form; driven
angles put the points where R = Rx(a) Ry(b) Rz(c) (or Rz(phi1) Tx(r) Rz(phi2))
in the first joint frame puts them.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import root

from helpers.decks import run_deck, write
from helpers.geometry import rot
from openimp.imp.deck import load

#: the joint frames of the decks below: the columns u, v, w in global axes (w along X,
#: u along Y, so a mix-up of axes shows)
FRAME = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
LINKS = """DATA LINK (BASE, S) = 0,0,0; 1,0,0; 0,1,0
DATA LINK (BOB, S) = 0,0,0; 1,0,0; 0,1,0
"""


def _turn(axis: int, a: float) -> np.ndarray:
    """The turn by ``a`` about coordinate axis ``axis`` (0, 1, 2)."""
    return rot(np.eye(3)[axis], a)


def cardan(ang: np.ndarray) -> np.ndarray:
    """R = Rx(a) Ry(b) Rz(c), radians."""
    return _turn(0, ang[0]) @ _turn(1, ang[1]) @ _turn(2, ang[2])


def cardan_axes(ang: np.ndarray) -> np.ndarray:
    """Columns: the axes of the three turns in the first frame."""
    Rx = _turn(0, ang[0])
    return np.stack([np.eye(3)[:, 0], Rx[:, 1], Rx @ _turn(1, ang[1])[:, 2]], axis=1)


# =============================================================================
# Statics: a bob on a ball joint with a spring on each Cardan angle
# =============================================================================
#: springs per degree (numbers in the deck) and free angles (degrees)
K_DEG = np.array([0.5, 0.4, 0.3])
FREE_DEG = np.array([10.0, -20.0, 30.0])
MASS, CENTRE, G = 2.0, np.array([0.05, 0.1, 0.3]), 9.80665

BALL_STATIC = f"""TITLE = BALL SPRINGS
UNIT (MASS) = 1
SPHERE (BASE, BOB) = S
{LINKS}POINT (BOB) = P1
DATA POINT (P1, ABS) = 0.1, 0, 0.3
DATA MASS (BOB, LINK) = {MASS}; {CENTRE[0]}, {CENTRE[1]}, {CENTRE[2]}
DATA INERTIA (BOB, LINK) = 0.21, 0.195, 0.035, 0.01, 0.03, 0.06
DATA GRAVITY = 0, 0, -{G}
DATA SPRING (S) = {K_DEG[0]}, {FREE_DEG[0]}; {K_DEG[1]}, {FREE_DEG[1]}; {K_DEG[2]}, {FREE_DEG[2]}
ZERO (EQUILIBRIUM) = 1E-10
FIND EQUILIBRIUM
PRINT POSITION (S, P1)
PRINT FORCE (S)
EXECUTE
END
"""


def ball_equilibrium() -> np.ndarray:
    """The Cardan angles (radians) where the potential sum k/2 (t - t0)^2 + m g z_c is
    stationary: k (t - t0) + m g e_z . (F a_i x F^T c) = 0."""
    k = K_DEG * 180.0 / math.pi
    t0 = np.radians(FREE_DEG)
    c_local = FRAME.T @ CENTRE  # the centre in the first joint frame at the drawing

    def grad(t: np.ndarray) -> np.ndarray:
        rc = cardan(t) @ c_local
        A = cardan_axes(t)
        dz = np.array([(FRAME @ np.cross(A[:, i], rc))[2] for i in range(3)])
        return k * (t - t0) + MASS * G * dz

    sol = root(grad, t0, tol=1e-14)
    assert np.max(np.abs(grad(sol.x))) < 1e-12, sol
    return sol.x


@pytest.fixture(scope="module")
def ball_static(tmp_path_factory):
    p = write(tmp_path_factory.mktemp("ball"), BALL_STATIC)
    runs, echo = run_deck(p)
    return runs[0], echo


def test_ball_springs_are_on_the_cardan_angles(ball_static) -> None:
    """The equilibrium angles are the stationary point of the potential to 1e-8 deg, the
    bob's point where R puts it to 1e-10, and no spring is dropped."""
    r, echo = ball_static
    assert r.ok and r.mode == "static", (r.failure, r.unsupported)
    assert not any("left out" in ln or "cannot carry" in ln for ln in echo), echo
    t = ball_equilibrium()
    got = r.table("PRINT POSITION", "joint S").rows[0, 1:4]
    np.testing.assert_allclose(got, np.degrees(t), rtol=0, atol=1e-8)
    p1 = r.table("PRINT POSITION", "point P1").rows[0, 2:5]  # after the magnitude
    np.testing.assert_allclose(p1, FRAME @ cardan(t) @ FRAME.T @ [0.1, 0, 0.3], atol=1e-10)


def test_ball_joint_load_carries_the_weight_and_its_moment(ball_static) -> None:
    """The bob's load on the base through S: its weight, and the weight's moment about
    the ball centre, which the angle springs carry; force on the first frame's axes."""
    r, _ = ball_static
    t = ball_equilibrium()
    row = r.table("PRINT FORCE", "joint S").rows[0, 1:]
    weight = np.array([0.0, 0.0, -MASS * G])
    np.testing.assert_allclose(row[:3], FRAME.T @ weight, rtol=0, atol=1e-9)
    c = FRAME @ cardan(t) @ FRAME.T @ CENTRE
    moment = np.cross(c, weight)  # global
    # IMP's moment axes of a SPHERE: u, the line of nodes w' x u, w'
    u = FRAME[:, 0]
    w2 = FRAME @ cardan(t) @ FRAME.T @ FRAME[:, 2]
    n = np.cross(w2, u)
    n /= np.linalg.norm(n)
    np.testing.assert_allclose(row[3:], [moment @ u, moment @ n, moment @ w2], rtol=0,
                               atol=1e-9)


# =============================================================================
# Dynamics: damped free vibration about one Cardan axis
# =============================================================================
BALL_VIBRATION = """TITLE = BALL VIBRATION
UNIT (MASS) = 1
SPHERE (BASE, BOB) = S
DATA LINK (BASE, S) = 0,0,0; 0,0,1; 1,0,0
DATA LINK (BOB, S) = 0,0,0; 0,0,1; 1,0,0
DATA MASS (BOB, LINK) = 2.0; 0, 0, 0
DATA INERTIA (BOB, LINK) = 0.2, 0.3, 0.4, 0, 0, 0
DATA SPRING (S) = 0.1, 0; 0.1, 0; 0.1, 0
DATA DAMPER (S) = 0.5; 0.2; 0.2
{integrator}FIND DYNAMICS
DATA IC (S) = 5, 0; 0, 0; 0, 0
DATA TIME = 2, 0, 0.05
LIST POSITION (S)
EXECUTE
END
"""


def damped(t: np.ndarray, a0: float, k: float, c: float, inertia: float) -> np.ndarray:
    """a(t) of I a'' + c a' + k a = 0 from a0 at rest (underdamped)."""
    wn = math.sqrt(k / inertia)
    z = c / (2.0 * math.sqrt(k * inertia))
    wd = wn * math.sqrt(1.0 - z * z)
    return a0 * np.exp(-z * wn * t) * (np.cos(wd * t) + z * wn / wd * np.sin(wd * t))


@pytest.mark.parametrize(("integrator", "tol"), [
    ("REMARK OPENIMP INTEGRATOR = RK, 1E-11\n", 1e-7), ("", 2e-3)], ids=["rk", "book"])
def test_ball_spring_and_damper_vibration(tmp_path, integrator, tol) -> None:
    """Turned about the joint's x axis only, a principal axis of the bob, the ball's
    first angle is a damped oscillator: I a'' + c a' + k a = 0, k = 0.1/deg, c = 0.5
    per rad/s, I = 0.2, to 1e-7 deg with rk 1e-11 (2e-3 deg with IMP's step at its
    default tolerance); the other two angles stay 0."""
    p = write(tmp_path, BALL_VIBRATION.format(integrator=integrator))
    runs, echo = run_deck(p)
    r = runs[0]
    assert r.ok and r.mode == "dynamic", (r.failure, r.unsupported, echo)
    rows = r.table("LIST POSITION", "joint S").rows
    t = rows[:, 0]
    assert t[-1] == pytest.approx(2.0) and len(t) == 41
    expect = damped(t, 5.0, 0.1 * 180 / math.pi, 0.5, 0.2)
    np.testing.assert_allclose(rows[:, 1], expect, rtol=0, atol=tol)
    np.testing.assert_allclose(rows[:, 2:4], 0.0, rtol=0, atol=1e-9)


# =============================================================================
# Kinematics: SPHERE, OPEN and FLAT driven on IMP's variables
# =============================================================================
DRIVEN = """TITLE = DRIVEN {keyword}
{keyword} (BASE, BOB) = S
{links}POINT (BOB) = P1
DATA POINT (P1, ABS) = 0.1, 0.05, 0.3
VALUE (V1) = {v1}
VALUE (V2) = {v2}
VALUE (V3) = {v3}
DATA MOTION (S) = {motions}
DATA TIME = 1, 0, 0.1
LIST POSITION (S, P1)
LIST VELOCITY (P1)
EXECUTE
END
"""


def _driven(tmp_path, keyword: str, links: str, motions: str):
    text = DRIVEN.format(keyword=keyword, links=links, motions=motions,
                         v1="0.7*T", v2="-0.5*T*T", v3="0.3+0.4*T")
    runs, echo = run_deck(write(tmp_path, text))
    r = runs[0]
    assert r.ok, (r.failure, r.unsupported, echo)
    t = r.table("LIST POSITION", "joint S").rows[:, 0]
    v = np.stack([0.7 * t, -0.5 * t * t, 0.3 + 0.4 * t], axis=1)
    vd = np.stack([0.7 + 0 * t, -t, 0.4 + 0 * t], axis=1)
    return r, t, v, vd


def _speed(pos, t: np.ndarray, h: float = 1e-6) -> np.ndarray:
    """Central difference of pos(t) (steps, 3)."""
    return (pos(t + h) - pos(t - h)) / (2 * h)


def test_sphere_driven_by_its_cardan_angles(tmp_path) -> None:
    r, t, v, _ = _driven(tmp_path, "SPHERE", LINKS, "V1; V2; V3")
    np.testing.assert_allclose(r.table("LIST POSITION", "joint S").rows[:, 1:4],
                               np.degrees(v), rtol=0, atol=1e-9)
    p0 = FRAME.T @ np.array([0.1, 0.05, 0.3])

    def pos(tt: np.ndarray) -> np.ndarray:  # the drawing is at (0, 0, 0)
        return np.array([FRAME @ cardan([0.7 * s, -0.5 * s * s, 0.3 + 0.4 * s]) @ p0
                         for s in tt])

    np.testing.assert_allclose(r.table("LIST POSITION", "point P1").rows[:, 1:4], pos(t),
                               rtol=0, atol=1e-10)
    np.testing.assert_allclose(r.table("LIST VELOCITY", "point P1").rows[:, 1:4],
                               _speed(pos, t), rtol=0, atol=1e-7)


def test_flat_driven_by_its_polar_variables(tmp_path) -> None:
    links = ("DATA LINK (BASE, S) = 0,0,0; 0,0,1; 1,0,0\n"
             "DATA LINK (BOB, S) = 0.3,0,0; 0.3,0,1; 1.3,0,0\n")
    r, t, v, _ = _driven(tmp_path, "FLAT", links, "V1; V3; V2")
    got = r.table("LIST POSITION", "joint S").rows[:, 1:4]
    np.testing.assert_allclose(got, np.stack([np.degrees(v[:, 0]), v[:, 2],
                                              np.degrees(v[:, 1])], axis=1), atol=1e-9)
    p_bob = np.array([0.1 - 0.3, 0.05, 0.3])  # in the second joint frame at the drawing

    def pos(tt: np.ndarray) -> np.ndarray:
        out = []
        for s in tt:
            p1, rr, p2 = 0.7 * s, 0.3 + 0.4 * s, -0.5 * s * s
            out.append(_turn(2, p1) @ (np.array([rr, 0, 0]) + _turn(2, p2) @ p_bob))
        return np.array(out)

    np.testing.assert_allclose(r.table("LIST POSITION", "point P1").rows[:, 1:4], pos(t),
                               rtol=0, atol=1e-10)
    np.testing.assert_allclose(r.table("LIST VELOCITY", "point P1").rows[:, 1:4],
                               _speed(pos, t), rtol=0, atol=1e-7)


def test_open_driven_by_its_six_variables(tmp_path) -> None:
    r, t, v, _ = _driven(tmp_path, "OPEN", LINKS, "V3; 0; V1; V1; V2; 0")
    rows = r.table("LIST POSITION", "joint S").rows[:, 1:7]
    np.testing.assert_allclose(rows[:, 0], v[:, 2], atol=1e-10)
    np.testing.assert_allclose(rows[:, 1], 0.0, atol=1e-10)
    np.testing.assert_allclose(rows[:, 2], v[:, 0], atol=1e-10)
    np.testing.assert_allclose(rows[:, 3:5], np.degrees(v[:, :2]), atol=1e-9)
    np.testing.assert_allclose(rows[:, 5], 0.0, atol=1e-9)
    p0 = FRAME.T @ np.array([0.1, 0.05, 0.3])

    def pos(tt: np.ndarray) -> np.ndarray:
        return np.array([FRAME @ (np.array([0.3 + 0.4 * s, 0.0, 0.7 * s])
                                  + cardan([0.7 * s, -0.5 * s * s, 0.0]) @ p0) for s in tt])

    np.testing.assert_allclose(r.table("LIST POSITION", "point P1").rows[:, 1:4], pos(t),
                               rtol=0, atol=1e-10)


def test_free_angle_is_taken_modulo_a_turn(tmp_path) -> None:
    """A ball drawn at c = 180 deg with a spring whose free angle is -180 deg is held
    where it is drawn (IMP's -180 and 180 are one posture): the joint kind measures
    the angle in (-180, 180] and the free angle follows it."""
    text = BALL_STATIC.replace("DATA LINK (BOB, S) = 0,0,0; 1,0,0; 0,1,0",
                               "DATA LINK (BOB, S) = 0,0,0; 1,0,0; 0,-1,0")
    text = text.replace("DATA GRAVITY = 0, 0, -9.80665\n", "")
    text = text.replace(f"{K_DEG[2]}, {FREE_DEG[2]}", f"{K_DEG[2]}, -180")
    text = text.replace(f"{K_DEG[0]}, {FREE_DEG[0]}", f"{K_DEG[0]}, 0")
    text = text.replace(f"{K_DEG[1]}, {FREE_DEG[1]}", f"{K_DEG[1]}, 0")
    deck = load(write(tmp_path, text))
    mj = deck.built.model.joints["S"]
    assert mj.kind_name == "gimbal"
    jl = deck.built.model.joint_loads[("S", 2)]
    assert jl.periodic and jl.free == pytest.approx(-math.pi)
    r = deck.run()[0]
    assert r.ok, r.failure
    np.testing.assert_allclose(np.abs(r.table("PRINT POSITION", "joint S").rows[0, 1:4]),
                               [0, 0, 180], atol=1e-9)


def test_a_ball_without_loads_keeps_its_euler_parameters(tmp_path) -> None:
    """Only a deck that acts on the angles makes them coordinates: the default ball
    never locks."""
    text = BALL_STATIC.replace("DATA SPRING (S) = ", "REMARK ")
    deck = load(write(tmp_path, text))
    assert deck.built.model.joints["S"].kind_name == "sphere"
