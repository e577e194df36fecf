"""Mechanisms with higher pairs, built with openimp.Model, compiled and swept.

Every expected value is a closed form derived in the test's docstring (or the
book's printed solution of Example 5.5).  The sweeps use the Newton solver of
:mod:`openimp.kinematics`; tolerances are far above its 1e-10 convergence
tolerance only where a tabulated curve is interpolated.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

import openimp
from openimp.errors import InputError

Z = (0.0, 0.0, 1.0)
X = (1.0, 0.0, 0.0)
Y = (0.0, 1.0, 0.0)
TURN = np.linspace(0.0, 2.0 * np.pi, 73)


def _angle(T: np.ndarray) -> np.ndarray:
    """Unwrapped rotation angle about global z of a stack of postures."""
    return np.unwrap(np.arctan2(T[:, 1, 0], T[:, 0, 0]))


def _complete(res: Any, mobility: int = 1) -> None:
    assert res.complete, res.message
    assert np.all(res.mobility == mobility), res.mobility


Drive = Callable[[np.ndarray], tuple[np.ndarray, np.ndarray, np.ndarray]]


def uniform(t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Driver value t at unit rate and zero acceleration."""
    return t, np.ones_like(t), np.zeros_like(t)


def _check_rates(system: Any, drivers: dict[str, Drive], span: tuple[float, float] = (0, 6.2),
                 centres: tuple[float, ...] = (0.7, 2.0, 3.9, 5.5), h: float = 1e-3) -> None:
    """Joint velocities and accelerations of a sweep with driver rates (the kinematics'
    use of Q_g and Q_{g,i}) against central differences of the joint variables in time,
    at a few instants of a sweep from the modeling posture."""
    cs = [c for c in centres if span[0] + 2 * h < c < span[1] - 2 * h]
    base = np.linspace(span[0], span[1], 37)
    base = base[np.all(np.abs(base[:, None] - np.array(cs)[None, :]) > 3 * h, axis=1)]
    t = np.sort(np.concatenate([base, *[[c - h, c, c + h] for c in cs]]))
    vals = {k: f(t) for k, f in drivers.items()}
    res = openimp.sweep(system, {k: v[0] for k, v in vals.items()},
                        {k: v[1] for k, v in vals.items()}, {k: v[2] for k, v in vals.items()})
    assert res.complete, res.message
    q, qd, qdd = res.q, res.qd, res.qdd
    for c in cs:
        i = int(np.argmin(np.abs(t - c)))
        fd1 = (q[i + 1] - q[i - 1]) / (2 * h)
        fd2 = (q[i + 1] - 2 * q[i] + q[i - 1]) / (h * h)
        assert np.allclose(qd[i], fd1, atol=1e-6, rtol=1e-6), (c, qd[i] - fd1)
        assert np.allclose(qdd[i], fd2, atol=2e-5, rtol=1e-5), (c, qdd[i] - fd2)


# =============================================================================
# gears
# =============================================================================
def ferguson() -> openimp.Model:
    """Book Example 5.5: carrier 1 (input B), planet 2 (10 teeth), suns 3 (101), 4 (99),
    5 (100, fixed); diametral pitch 20: radii 2.525, 2.475, 2.5 and 0.25; the planet axis
    is 2.75 from the sun axis.  All axes along global z, u along x at psi = 0."""
    m = openimp.Model("Ferguson's paradox", ground="SUN5")
    m.add_joint("revolute", "B", "SUN5", "CARRIER", origin=(0, 0, 3), axis=Z, ref=X)
    m.add_joint("revolute", "A", "CARRIER", "PLANET", origin=(2.75, 0, 3), axis=Z, ref=X)
    m.add_joint("revolute", "D", "SUN5", "SUN3", origin=(0, 0, 2), axis=Z, ref=X)
    m.add_joint("revolute", "F", "SUN5", "SUN4", origin=(0, 0, 1), axis=Z, ref=X)
    for name, sun, z, R in (("C", "SUN3", 2.0, 2.525), ("E", "SUN4", 1.0, 2.475),
                            ("G", "SUN5", 0.0, 2.5)):
        m.add_joint("gear", name, sun, "PLANET", origin=(0, 0, z), origin2=(2.75, 0, z),
                    axis=Z, ref=X, radius1=R, radius2=0.25)
    m.add_point("PC", "PLANET", (2.75, 0, 1))  # planet centre
    return m


def test_ferguson_paradox() -> None:
    """Book Example 5.5 over a full turn of the carrier psi (book solution, digest 8.3):
    [A, B, C1, C2, C3, D, E1, E2, E3, F, G1, G2, G3] =
    [10 psi, psi, 100/101 psi, -0.025, 0, psi/101, 100/99 psi, 0.025, 0, -psi/99, psi, 0, 0];
    the planet turns 11 psi; sun 3 turns +psi/101 and sun 4 -psi/99 (opposite senses)."""
    system = openimp.compile(ferguson())
    assert system.nq == 13 and system.nloops == 3
    res = openimp.sweep(system, {"B": TURN})
    _complete(res)
    psi = TURN
    want = {
        "A": [10 * psi], "B": [psi], "C": [100 / 101 * psi, -0.025 + 0 * psi, 0 * psi],
        "D": [psi / 101], "E": [100 / 99 * psi, 0.025 + 0 * psi, 0 * psi], "F": [-psi / 99],
        "G": [psi, 0 * psi, 0 * psi],
    }
    for j, cols in want.items():
        assert np.allclose(res.joint(j), np.stack(cols, axis=1), atol=1e-9, rtol=0), j
    assert np.allclose(_angle(res.posture("PLANET")), 11 * psi, atol=1e-9)
    assert np.allclose(_angle(res.posture("SUN3")), psi / 101, atol=1e-12)
    assert np.allclose(_angle(res.posture("SUN4")), -psi / 99, atol=1e-12)
    assert np.allclose(res.point("PC"), np.stack([2.75 * np.cos(psi), 2.75 * np.sin(psi),
                                                  np.ones_like(psi)], axis=1), atol=1e-12)
    _check_rates(system, {"B": uniform})


def test_gear_ratio_and_distance_from_frames() -> None:
    """IMP's DATA GEAR ratio with the centre distance taken from the frames (distance=
    omitted): a planet of radius 1 on a fixed sun of radius 2 (ratio 2, distance 3 from
    the frames) turns 3 times the arm."""
    m = openimp.Model("planet")
    m.add_joint("revolute", "ARM", "BASE", "CARRIER", origin=(0, 0, 0), axis=Z, ref=X)
    m.add_joint("revolute", "P", "CARRIER", "PLANET", origin=(3, 0, 0), axis=Z, ref=X)
    m.add_joint("gear", "G", "BASE", "PLANET", origin=(0, 0, 0), origin2=(3, 0, 0), axis=Z,
                ref=X, ratio=2.0)
    system = openimp.compile(m)
    assert np.all(np.isfinite(system.K.const))
    res = openimp.sweep(system, {"ARM": TURN})
    _complete(res)
    assert np.allclose(_angle(res.posture("PLANET")), 3 * TURN, atol=1e-10)
    assert np.allclose(res.joint("G")[:, 1], 0.0, atol=1e-12)


@pytest.mark.parametrize("R", [0.8, -0.8])
def test_rack_and_pinion(R: float) -> None:
    """Pinion (radius |R|, centre (0, R)) turning psi on a fixed axis; rack on a prismatic
    along x.  Rolling without slip at the contact point (0, 0): the rack moves by
    s = R psi (signed radius: + pinion above the rack, contact at its bottom; - below).
    Rack variables: phi1 = -s (pinion centre seen from the rack), phi2 = phi3 = 0."""
    m = openimp.Model("rack")
    m.add_joint("revolute", "PIN", "BASE", "PINION", origin=(0, R, 0), axis=Z, ref=X)
    m.add_joint("prismatic", "SLIDE", "BASE", "RACK", origin=(0, 0, 0), axis=X, ref=Y)
    m.add_joint("rack", "MESH", "RACK", "PINION", origin=(0, 0, 0), origin2=(0, R, 0), axis=Z,
                ref=X, radius=R)
    res = openimp.sweep(openimp.compile(m), {"PIN": TURN - np.pi})
    _complete(res)
    psi = TURN - np.pi
    assert np.max(np.abs(res.joint("SLIDE")[:, 0] - R * psi)) < 1e-12
    assert np.allclose(res.joint("MESH"), np.stack([-R * psi, 0 * psi, 0 * psi], axis=1),
                       atol=1e-12)
    _check_rates(openimp.compile(m), {"PIN": uniform}, span=(-3.0, 3.0), centres=(-2.0, 0.5, 2.5))


def differential(book_ratio: bool = False) -> openimp.Model:
    """Bevel differential: carrier (cage) turning about the axle x, side gears L (at -x)
    and R (at +x) on the axle, one spider gear on the carrier's y axis; all pitch cones
    45 deg with the apex at the origin.  Side-gear and carrier angles are about +x."""
    m = openimp.Model("differential")
    m.add_joint("revolute", "CAR", "BASE", "CARRIER", origin=(0, 0, 0), axis=X, ref=Y)
    m.add_joint("revolute", "L", "BASE", "SIDE_L", origin=(0, 0, 0), axis=X, ref=Y)
    m.add_joint("revolute", "R", "BASE", "SIDE_R", origin=(0, 0, 0), axis=X, ref=Y)
    m.add_joint("revolute", "SP", "CARRIER", "SPIDER", origin=(0, 0, 0), axis=Y, ref=Z)
    g = math.pi / 4
    # t = w x w': (-x) x y = -z for the left gear, x x y = +z for the right one
    m.add_joint("bevel", "BL", "SIDE_L", "SPIDER", origin=(0, 0, 0), axis=(-1, 0, 0), axis2=Y,
                ref=(0, 0, -1), gamma1=g, gamma2=g, book_ratio=book_ratio)
    m.add_joint("bevel", "BR", "SIDE_R", "SPIDER", origin=(0, 0, 0), axis=X, axis2=Y,
                ref=Z, gamma1=g, gamma2=g, book_ratio=book_ratio)
    return m


def test_bevel_differential() -> None:
    """Relative to the carrier the two equal side gears turn equally and oppositely (they
    mesh with the same spider at diametrically opposite points): the side-gear angles
    average to the carrier angle, theta_c = (theta_L + theta_R)/2, all about +x.

    The sign decision (kappa = -sin g1/sin g2, rolling pitch cones) shows in the spider:
    in the carrier, the left gear's pitch point rho (-1, 1, 0)/sqrt 2 moves with
    (theta_L - theta_c)' x times it = (theta_L - theta_c)' rho/sqrt 2 z, the spider's with
    sigma' y times it = sigma' rho/sqrt 2 z; no slip: sigma = theta_L - theta_c (45/45
    cones).  The book's +tan g1/tan g2 keeps the average (the two meshes are mirror
    images) but turns the spider the wrong way, sigma = -(theta_L - theta_c): the pitch
    cones slip."""
    system = openimp.compile(differential())
    psi = TURN
    left = 0.4 * np.sin(2 * psi)
    res = openimp.sweep(system, {"CAR": psi, "L": left})
    _complete(res, mobility=2)
    right = res.joint("R")[:, 0]
    assert np.allclose((left + right) / 2, psi, atol=1e-10)
    assert np.allclose(res.joint("SP")[:, 0], left - psi, atol=1e-10)
    assert np.allclose(res.joint("BL")[:, 1], 0.0, atol=1e-12)
    assert np.allclose(res.joint("BR")[:, 1], 0.0, atol=1e-12)
    res_b = openimp.sweep(openimp.compile(differential(book_ratio=True)), {"CAR": psi, "L": left})
    _complete(res_b, mobility=2)
    assert np.allclose(res_b.joint("SP")[:, 0], -(left - psi), atol=1e-10)

    def wobble(t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return 0.4 * np.sin(2 * t), 0.8 * np.cos(2 * t), -1.6 * np.sin(2 * t)

    _check_rates(system, {"CAR": uniform, "L": wobble})


# =============================================================================
# cams, curves and slots
# =============================================================================
E_CAM, R_CAM = 0.3, 1.0


def cam_radius(phi: np.ndarray | float) -> Any:
    """Polar radius of a circle of radius R_CAM centred at (E_CAM, 0): the pitch curve."""
    return E_CAM * np.cos(phi) + np.sqrt(R_CAM ** 2 - (E_CAM * np.sin(phi)) ** 2)


def cam_radius_derivs(phi: float) -> tuple[float, ...]:
    """r, r', r'', r''' of :func:`cam_radius` (closed form, by hand)."""
    e, R = E_CAM, R_CAM
    s, c = math.sin(phi), math.cos(phi)
    w = R * R - e * e * s * s
    sq = math.sqrt(w)
    # g = sqrt(w), w' = -e^2 sin 2phi, w'' = -2 e^2 cos 2phi, w''' = 4 e^2 sin 2phi
    w1 = -e * e * math.sin(2 * phi)
    w2 = -2 * e * e * math.cos(2 * phi)
    w3 = 4 * e * e * math.sin(2 * phi)
    g1 = w1 / (2 * sq)
    g2 = w2 / (2 * sq) - w1 * w1 / (4 * sq ** 3)
    g3 = w3 / (2 * sq) - 3 * w1 * w2 / (4 * sq ** 3) + 3 * w1 ** 3 / (8 * sq ** 5)
    return (e * c + sq, -e * s + g1, -e * c + g2, e * s + g3)


CAM_FORMS = {
    "spline720": {"table": cam_radius(np.linspace(0, 2 * np.pi, 720, endpoint=False))},
    "fourier64": {"table": cam_radius(np.linspace(0, 2 * np.pi, 64, endpoint=False)),
                  "interpolation": "fourier"},
    "function": {"function": cam_radius_derivs},
}


@pytest.mark.parametrize("form", list(CAM_FORMS))
def test_cam_translating_follower(form: str) -> None:
    """Disc cam turning psi about z; pitch curve = circle of radius 1 about (0.3, 0) of the
    cam; roller-follower centre on a prismatic along global y through the cam axis.
    Closed form: the centre (0, y) is 1 from 0.3 (cos psi, sin psi):
    y = 0.3 sin psi + sqrt(1 - 0.09 cos^2 psi); cam variables phi1 = pi/2 - psi (angle of the
    follower point in the cam), phi2 = -pi/2 (u' stays along global x)."""
    y0 = float(cam_radius(np.pi / 2))
    m = openimp.Model("cam")
    m.add_joint("revolute", "A", "BASE", "CAM", origin=(0, 0, 0), axis=Z, ref=X)
    m.add_joint("prismatic", "C", "BASE", "FOL", origin=(0, y0, 0), axis=Y, ref=X)
    m.add_joint("cam", "B", "CAM", "FOL", origin=(0, 0, 0), origin2=(0, y0, 0), axis=Z, ref=X,
                **CAM_FORMS[form])
    m.add_point("ROLLER", "FOL", (0, y0, 0))
    res = openimp.sweep(openimp.compile(m), {"A": TURN})
    _complete(res)
    psi = TURN
    y = E_CAM * np.sin(psi) + np.sqrt(R_CAM ** 2 - (E_CAM * np.cos(psi)) ** 2)
    tol = 1e-8
    assert np.allclose(res.point("ROLLER")[:, 1], y, atol=tol)
    assert np.allclose(res.joint("C")[:, 0], y - y0, atol=tol)
    assert np.allclose(res.joint("B")[:, 0], np.pi / 2 - psi, atol=tol)
    assert np.allclose(res.joint("B")[:, 1], -np.pi / 2, atol=tol)
    _check_rates(openimp.compile(m), {"A": uniform})


def test_cam_oscillating_follower() -> None:
    """The same cam (pitch curve given as an exact function, evaluated through objmode)
    driving an arm of length 1.5 pivoted at (0, 2): its roller centre
    P = (0, 2) + 1.5 (cos chi, sin chi) is 1 from c = 0.3 (cos psi, sin psi), so with
    d = (0, 2) - c:  d . (cos chi, sin chi) = (1 - |d|^2 - 1.5^2) / 3, i.e.
    chi = atan2(d_y, d_x) + acos(K / |d|) (the branch of the modeling posture; |K/|d||
    stays in [0.81, 0.95] so it never changes)."""
    O2, Lf = np.array([0.0, 2.0]), 1.5

    def chi_of(psi: np.ndarray) -> np.ndarray:
        c = E_CAM * np.stack([np.cos(psi), np.sin(psi)], axis=-1)
        d = O2 - c
        nd = np.linalg.norm(d, axis=-1)
        K = (R_CAM ** 2 - nd ** 2 - Lf ** 2) / (2 * Lf)
        return np.arctan2(d[..., 1], d[..., 0]) + np.arccos(K / nd)

    chi0 = float(chi_of(np.array([0.0]))[0])
    P0 = O2 + Lf * np.array([math.cos(chi0), math.sin(chi0)])
    m = openimp.Model("oscillating cam")
    m.add_joint("revolute", "A", "BASE", "CAM", origin=(0, 0, 0), axis=Z, ref=X)
    m.add_joint("revolute", "PIV", "BASE", "ARM", origin=(*O2, 0), axis=Z, ref=X)
    m.add_joint("cam", "B", "CAM", "ARM", origin=(0, 0, 0), origin2=(*P0, 0), axis=Z, ref=X,
                function=cam_radius_derivs)
    res = openimp.sweep(openimp.compile(m), {"A": TURN})
    _complete(res)
    assert np.allclose(res.joint("PIV")[:, 0], chi_of(TURN) - chi0, atol=1e-10)
    _check_rates(openimp.compile(m), {"A": uniform})


def test_point_curve_follower() -> None:
    """The translating roller follower again, with the pitch circle as a parametric curve
    u = 0.3 + cos t, v = sin t on the cam (point_curve, periodic spline through 256
    samples): y as in the cam test, and t = the angle of the follower point about the
    circle centre in cam coordinates: with (u, v) = Rz(-psi) (0, y) = (y sin psi,
    y cos psi), t = atan2(v, u - 0.3) (unwrapped)."""
    tt = np.linspace(0, 2 * np.pi, 256, endpoint=False)
    table = np.stack([E_CAM + np.cos(tt), np.sin(tt)], axis=1)
    y0 = float(cam_radius(np.pi / 2))
    m = openimp.Model("pin follower")
    m.add_joint("revolute", "A", "BASE", "CAM", origin=(0, 0, 0), axis=Z, ref=X)
    m.add_joint("prismatic", "C", "BASE", "FOL", origin=(0, y0, 0), axis=Y, ref=X)
    m.add_joint("point_curve", "B", "CAM", "FOL", origin=(0, 0, 0), origin2=(0, y0, 0), axis=Z,
                ref=X, table=table)
    res = openimp.sweep(openimp.compile(m), {"A": TURN})
    _complete(res)
    psi = TURN
    y = E_CAM * np.sin(psi) + np.sqrt(R_CAM ** 2 - (E_CAM * np.cos(psi)) ** 2)
    assert np.allclose(res.joint("C")[:, 0], y - y0, atol=1e-8)
    u, v = y * np.sin(psi), y * np.cos(psi)  # follower point in cam coordinates
    t = np.unwrap(np.arctan2(v, u - E_CAM))
    assert np.allclose(res.joint("B")[:, 0], t, atol=1e-7)
    assert np.allclose(res.joint("B")[:, 2], 0.0, atol=1e-12)
    _check_rates(openimp.compile(m), {"A": uniform})


def test_flat_faced_follower_book_example_5_2() -> None:
    """Book Example 5.2 (digest 8.3, return branch corrected): disc cam with lift
    s = (L/2pi)(2 phi - sin 2phi) on [0, pi), (L/2pi)(4 pi - 2 phi + sin 2 phi) on
    [pi, 2pi), base radius R0; curve u = r sin phi + r' cos phi, v = r cos phi - r' sin phi
    (r = R0 + s, r' = ds/dphi); flat-faced follower sliding along y at offset e.
    Solution: phi_B = [psi, r'(psi) - e, 0], phi_C = s(psi)."""
    R0, Lift, e = 1.0, 0.5, 0.2

    def s_derivs(p: float) -> list[float]:
        k = Lift / math.pi
        p = p % (2 * math.pi)
        sgn = 1.0 if p < math.pi else -1.0
        base = 0.0 if p < math.pi else 2 * Lift
        s = base + sgn * (Lift / (2 * math.pi)) * (2 * p - math.sin(2 * p))
        return [s, sgn * k * (1 - math.cos(2 * p)), sgn * 2 * k * math.sin(2 * p),
                sgn * 4 * k * math.cos(2 * p), -sgn * 8 * k * math.sin(2 * p)]

    def curve(p: float) -> tuple[float, ...]:
        s, s1, s2, s3, s4 = s_derivs(p)
        r, r1, r2, r3, r4 = R0 + s, s1, s2, s3, s4
        sp, cp = math.sin(p), math.cos(p)
        a, a1, a2 = r + r2, r1 + r3, r2 + r4  # u' = a cos p, v' = -a sin p
        return (r * sp + r1 * cp, r * cp - r1 * sp, a * cp, -a * sp,
                a1 * cp - a * sp, -a1 * sp - a * cp,
                a2 * cp - 2 * a1 * sp - a * cp, -a2 * sp - 2 * a1 * cp + a * sp)

    m = openimp.Model("Example 5.2")
    m.add_joint("revolute", "A", "BASE", "CAM", origin=(0, 0, 0), axis=Z, ref=X)
    m.add_joint("line_curve", "B", "CAM", "FOL", origin=(0, 0, 0), origin2=(e, R0, 0), axis=Z,
                ref=X, curve=curve)
    m.add_joint("prismatic", "C", "BASE", "FOL", origin=(e, R0, 0), axis=Y, ref=X)
    psi = np.linspace(0.0, 2 * np.pi, 145)
    res = openimp.sweep(openimp.compile(m), {"A": psi})
    _complete(res)
    sd = np.array([s_derivs(p) for p in psi])
    assert np.allclose(res.joint("B"), np.stack([psi, sd[:, 1] - e, 0 * psi], axis=1),
                       atol=1e-10)
    assert np.allclose(res.joint("C")[:, 0], sd[:, 0], atol=1e-10)
    _check_rates(openimp.compile(m), {"A": uniform})


def slider_crank(kind: str) -> openimp.Model:
    """Crank 0.5 about the origin, coupler 1.4, coupler end on the line through (1, -0.2)
    at 30 deg: either a SLOT of the ground (centreline v = tan 30 u, u along global x), or
    a slider on a prismatic along the line with a revolute pin."""
    a, b, x0, y0 = 0.5, 1.4, 1.0, -0.2
    k = math.tan(math.radians(30))
    u0 = _slot_u(0.0, a, b, x0, y0, k)
    P0 = (x0 + u0, y0 + k * u0, 0.0)
    m = openimp.Model(f"slider crank ({kind})")
    m.add_joint("revolute", "CRANK", "BASE", "CRANK", origin=(0, 0, 0), axis=Z, ref=X)
    m.add_joint("revolute", "ELBOW", "CRANK", "COUPLER", origin=(a, 0, 0), axis=Z, ref=X)
    if kind == "slot":
        m.add_joint("slot", "S", "BASE", "COUPLER", origin=(x0, y0, 0), origin2=P0, axis=Z,
                    ref=X, table=k * np.linspace(-3, 3, 13), range=(-3.0, 3.0))
    else:
        d = (math.cos(math.radians(30)), math.sin(math.radians(30)), 0.0)
        m.add_joint("prismatic", "S", "BASE", "BLOCK", origin=P0, axis=d, ref=Z)
        m.add_joint("revolute", "PIN", "BLOCK", "COUPLER", origin=P0, axis=Z, ref=X)
    m.add_point("P", "COUPLER", P0)
    return m


def _slot_u(psi: Any, a: float, b: float, x0: float, y0: float, k: float) -> Any:
    """u of the coupler end: (x0 + u - a cos psi)^2 + (y0 + k u - a sin psi)^2 = b^2,
    the larger root."""
    dx = x0 - a * np.cos(psi)
    dy = y0 - a * np.sin(psi)
    A = 1 + k * k
    B = 2 * (dx + k * dy)
    C = dx * dx + dy * dy - b * b
    return (-B + np.sqrt(B * B - 4 * A * C)) / (2 * A)


def test_slot_reproduces_prismatic() -> None:
    """A straight slot tilted 30 deg (table v = tan 30 u) behaves as a prismatic joint along
    the line plus a pin: slot u = the closed-form root of _slot_u, prismatic slide
    = (u - u0)/cos 30, the same coupler-end path, and slot phi2 = the coupler's angle."""
    k = math.tan(math.radians(30))
    u = _slot_u(TURN, 0.5, 1.4, 1.0, -0.2, k)
    rs = openimp.sweep(openimp.compile(slider_crank("slot")), {"CRANK": TURN})
    rp = openimp.sweep(openimp.compile(slider_crank("prismatic")), {"CRANK": TURN})
    _complete(rs)
    _complete(rp)
    assert np.allclose(rs.joint("S")[:, 0], u, atol=1e-10)
    assert np.allclose(rp.joint("S")[:, 0], (u - u[0]) / math.cos(math.radians(30)), atol=1e-10)
    assert np.allclose(rs.point("P"), rp.point("P"), atol=1e-10)
    assert np.allclose(rs.joint("S")[:, 1], _angle(rs.posture("COUPLER")), atol=1e-10)
    _check_rates(openimp.compile(slider_crank("slot")), {"CRANK": uniform})


# =============================================================================
# universal joints
# =============================================================================
def test_universal_joint_30deg() -> None:
    """Input shaft along x, output shaft along (cos 30, sin 30, 0), cross at the origin.
    Input pin w = (0, cos th1, sin th1), output pin w' = cos th2 z - sin th2 (-sin b, cos b, 0);
    w . w' = 0 gives tan th2 = tan th1 / cos b (th2 continuous with th1)."""
    b = math.radians(30)
    axis2 = (math.cos(b), math.sin(b), 0.0)
    m = openimp.Model("hooke")
    m.add_joint("revolute", "IN", "BASE", "SHAFT1", origin=(0, 0, 0), axis=X, ref=Y)
    m.add_joint("revolute", "OUT", "BASE", "SHAFT2", origin=(0, 0, 0), axis=axis2, ref=Z)
    m.add_joint("ujoint", "U", "SHAFT1", "SHAFT2", origin=(0, 0, 0), axis=Y, axis2=Z, ref=X)
    res = openimp.sweep(openimp.compile(m), {"IN": TURN})
    _complete(res)
    th2 = np.unwrap(np.arctan2(np.sin(TURN), np.cos(TURN) * math.cos(b)))
    assert np.allclose(res.joint("OUT")[:, 0], th2, atol=1e-10)
    assert np.allclose(np.tan(res.joint("OUT")[1:-1:4, 0]),
                       np.tan(TURN[1:-1:4]) / math.cos(b), rtol=1e-8, atol=1e-8)
    _check_rates(openimp.compile(m), {"IN": uniform})


def test_double_cardan_constant_velocity() -> None:
    """Z arrangement: input and output shafts parallel (along x), intermediate shaft at 30 deg
    from the origin to (2 cos 30, 2 sin 30, 0), its two yokes in phase (both intermediate
    pins along z at the start).  The first joint gives tan th_m = tan th1 / cos b, the
    second tan th_out = tan th_m cos b: th_out = th1 (constant velocity)."""
    b = math.radians(30)
    P2 = (2 * math.cos(b), 2 * math.sin(b), 0.0)
    m = openimp.Model("double cardan")
    m.add_joint("revolute", "IN", "BASE", "SHAFT1", origin=(0, 0, 0), axis=X, ref=Y)
    m.add_joint("revolute", "OUT", "BASE", "SHAFT2", origin=P2, axis=X, ref=Y)
    m.add_joint("ujoint", "U1", "SHAFT1", "MID", origin=(0, 0, 0), axis=Y, axis2=Z, ref=X)
    m.add_joint("ujoint", "U2", "MID", "SHAFT2", origin=P2, axis=Z, axis2=Y, ref=(-1, 0, 0))
    res = openimp.sweep(openimp.compile(m), {"IN": TURN})
    _complete(res)
    assert np.allclose(res.joint("OUT")[:, 0], TURN, atol=1e-10)
    _check_rates(openimp.compile(m), {"IN": uniform})


# =============================================================================
# sphere on a plane, sphere in a groove
# =============================================================================
def _frame_coords(T: np.ndarray, origin0: np.ndarray, axes0: np.ndarray, B: np.ndarray
                  ) -> np.ndarray:
    """Coordinates of global points B[steps] in a frame fixed in a body of postures T whose
    global placement at the modeling posture (T = I) is (origin0, axes0 columns)."""
    R = np.einsum("sij,jk->sik", T[:, :3, :3], axes0)
    o = np.einsum("sij,j->si", T[:, :3, :3], origin0) + T[:, :3, 3]
    return np.einsum("sji,sj->si", R, B - o)


def test_R_Sp_R() -> None:
    """Plate turning psi about z whose plane contains the z axis; rocker turning phi about
    the line through (0, 0.3, 0.5) along x, ball centre B = (1, 0.3 + 0.8 cos phi,
    0.5 + 0.8 sin phi).  B lies on the plate's plane: psi = atan2(0.3 + 0.8 cos phi, 1).
    In the plane frame (u horizontal in the plane, v = -z): x = h - h0 with
    h = |(1, 0.3 + 0.8 cos phi)|, y = -0.8 sin phi."""
    a, y0, c0, rho = 1.0, 0.3, 0.5, 0.8
    B0 = np.array([a, y0 + rho, c0])
    psi0 = math.atan2(y0 + rho, a)
    n = (-math.sin(psi0), math.cos(psi0), 0.0)
    u = (math.cos(psi0), math.sin(psi0), 0.0)
    m = openimp.Model("R-Sp-R")
    m.add_joint("revolute", "A", "BASE", "PLATE", origin=(0, 0, 0), axis=Z, ref=X)
    m.add_joint("revolute", "C", "BASE", "ROCKER", origin=(0, y0, c0), axis=X, ref=Y)
    m.add_joint("sphere_plane", "SP", "PLATE", "ROCKER", origin=B0, axis=n, ref=u)
    res = openimp.sweep(openimp.compile(m), {"C": TURN})
    _complete(res)
    phi = TURN
    psi = np.arctan2(y0 + rho * np.cos(phi), a)
    assert np.allclose(res.joint("A")[:, 0], psi - psi0, atol=1e-10)
    h = np.hypot(a, y0 + rho * np.cos(phi))
    assert np.allclose(res.joint("SP")[:, 0], h - np.hypot(a, y0 + rho), atol=1e-10)
    assert np.allclose(res.joint("SP")[:, 1], -rho * np.sin(phi), atol=1e-10)
    _check_rates(openimp.compile(m), {"C": uniform})


def test_R_Sp_P_swashplate() -> None:
    """Axial piston pump: swashplate turning psi about z, its ball-centre plane through the
    origin with normal Rz(psi) (sin 20 deg, 0, cos 20 deg); piston on a prismatic along z
    at x = 1, ball centre B = (1, 0, s).  B . n = 0: s = -tan 20 deg cos psi; the piston
    slide is s - s(0).  The ball centre in the plate frame follows from B and Rz(psi)."""
    al, d = math.radians(20), 1.0
    s0 = -d * math.tan(al)
    B0 = np.array([d, 0.0, s0])
    n0 = np.array([math.sin(al), 0.0, math.cos(al)])
    m = openimp.Model("R-Sp-P")
    m.add_joint("revolute", "A", "BASE", "PLATE", origin=(0, 0, 0), axis=Z, ref=X)
    m.add_joint("prismatic", "C", "BASE", "PISTON", origin=B0, axis=Z, ref=X)
    m.add_joint("sphere_plane", "SP", "PLATE", "PISTON", origin=B0, axis=n0, ref=Y)
    res = openimp.sweep(openimp.compile(m), {"A": TURN})
    _complete(res)
    s = -d * math.tan(al) * np.cos(TURN)
    assert np.allclose(res.joint("C")[:, 0], s - s0, atol=1e-10)
    B = np.stack([d + 0 * s, 0 * s, s], axis=1)
    axes0 = np.stack([np.array(Y), np.cross(n0, Y), n0], axis=1)
    xyz = _frame_coords(res.posture("PLATE"), B0, axes0, B)
    assert np.allclose(xyz[:, 2], 0.0, atol=1e-12)
    assert np.allclose(res.joint("SP")[:, :2], xyz[:, :2], atol=1e-10)
    _check_rates(openimp.compile(m), {"A": uniform})


def test_P_Sp_P_wedge() -> None:
    """Wedge cam: a wedge sliding s1 along x whose ball-centre plane has the normal
    (sin 35, 0, cos 35) deg and passes through the origin at s1 = 0; a follower sliding
    along z at (1, 0.25), ball centre (1, 0.25, s2): (1 - s1) sin a + s2 cos a = 0, so the
    follower rises s1 tan a.  In the plane frame (u = (cos a, 0, -sin a), v = y):
    x = -s1 / cos a, y = 0."""
    al, d, e = math.radians(35), 1.0, 0.25
    B0 = np.array([d, e, -d * math.tan(al)])
    n = (math.sin(al), 0.0, math.cos(al))
    m = openimp.Model("P-Sp-P")
    m.add_joint("prismatic", "W", "BASE", "WEDGE", origin=(0, 0, 0), axis=X, ref=Y)
    m.add_joint("prismatic", "F", "BASE", "FOL", origin=B0, axis=Z, ref=X)
    m.add_joint("sphere_plane", "SP", "WEDGE", "FOL", origin=B0, axis=n,
                ref=(math.cos(al), 0.0, -math.sin(al)))
    s1 = np.linspace(-1.0, 1.0, 21)
    res = openimp.sweep(openimp.compile(m), {"W": s1})
    _complete(res)
    assert np.allclose(res.joint("F")[:, 0], s1 * math.tan(al), atol=1e-10)
    assert np.allclose(res.joint("SP")[:, 0], -s1 / math.cos(al), atol=1e-10)
    assert np.allclose(res.joint("SP")[:, 1], 0.0, atol=1e-10)
    e4 = res.joint("SP")[:, 2:]
    assert np.allclose(e4, e4[0], atol=1e-10)  # no relative rotation
    _check_rates(openimp.compile(m), {"W": uniform}, span=(-1.0, 1.0), centres=(-0.5, 0.3))


def test_P_Sp_R() -> None:
    """Rocker turning chi about the line through (0, 0.2, 1) along y, ball centre
    B = (0.6 sin chi, 0.2, 1 + 0.6 cos chi); wedge sliding along x with the plane normal
    (sin 35, 0, cos 35) deg through B at the start.  (B_x - w) sin a + B_z cos a = 0 with w
    the wedge's point on the x axis: w = B_x + B_z / tan a; the wedge slide is w - w(0)."""
    al, L = math.radians(35), 0.6
    Op = np.array([0.0, 0.2, 1.0])
    B0 = Op + np.array([0.0, 0.0, L])
    n = (math.sin(al), 0.0, math.cos(al))
    m = openimp.Model("P-Sp-R")
    m.add_joint("prismatic", "W", "BASE", "WEDGE", origin=(0, 0, 0), axis=X, ref=Y)
    m.add_joint("revolute", "R", "BASE", "ROCKER", origin=Op, axis=Y, ref=Z)
    m.add_joint("sphere_plane", "SP", "WEDGE", "ROCKER", origin=B0, axis=n, ref=Y)
    res = openimp.sweep(openimp.compile(m), {"R": TURN})
    _complete(res)
    Bx = L * np.sin(TURN)
    Bz = Op[2] + L * np.cos(TURN)
    w = Bx + Bz / math.tan(al)
    assert np.allclose(res.joint("W")[:, 0], w - w[0], atol=1e-10)
    _check_rates(openimp.compile(m), {"R": uniform})


def test_R_Sg_C() -> None:
    """Arm turning psi about z with a straight groove through (0, 0, 0.2) along
    (cos psi cos 25, sin psi cos 25, sin 25) deg; a body on a cylinder joint about the
    vertical line through (0.3, 0) carries the ball centre at 0.8 from that line:
    B = (0.3 + 0.8 cos chi, 0.8 sin chi, Z).  B on the groove: 0.8 sin(chi - psi) =
    0.3 sin psi, i.e. chi = psi + asin(0.375 sin psi) (a full turn since 0.8 > 0.3), the
    horizontal distance h = 0.3 cos psi + 0.8 cos(chi - psi), Z = 0.2 + h tan 25 deg;
    the groove variable is s = (h - h0) / cos 25 deg."""
    d, b, hgt, lam = 0.3, 0.8, 0.2, math.radians(25)
    h0 = d + b
    B0 = np.array([d + b, 0.0, hgt + h0 * math.tan(lam)])
    g0 = (math.cos(lam), 0.0, math.sin(lam))
    m = openimp.Model("R-Sg-C")
    m.add_joint("revolute", "A", "BASE", "ARM", origin=(0, 0, 0), axis=Z, ref=X)
    m.add_joint("cylinder", "C", "BASE", "SLIDER", origin=(d, 0, 0), axis=Z, ref=X)
    m.add_joint("sphere_groove", "SG", "ARM", "SLIDER", origin=B0, axis=Y, ref=g0)
    res = openimp.sweep(openimp.compile(m), {"A": TURN})
    _complete(res)
    psi = TURN
    chi = psi + np.arcsin(d / b * np.sin(psi))
    h = d * np.cos(psi) + b * np.cos(chi - psi)
    assert np.allclose(res.joint("C")[:, 0], chi, atol=1e-10)
    assert np.allclose(res.joint("C")[:, 1], (h - h0) * math.tan(lam), atol=1e-10)
    assert np.allclose(res.joint("SG")[:, 0], (h - h0) / math.cos(lam), atol=1e-10)
    _check_rates(openimp.compile(m), {"A": uniform})


# =============================================================================
# bad data
# =============================================================================
def test_bad_gear_ratio_names_joint() -> None:
    """A zero gear ratio is refused at add_joint with the joint's name."""
    m = openimp.Model()
    with pytest.raises(InputError, match=r"'G7'.*zero"):
        m.add_joint("gear", "G7", "BASE", "B2", origin=(0, 0, 0), origin2=(3, 0, 0), ratio=0)


def test_bad_cam_table_names_joint() -> None:
    """A cam table too short for a periodic spline is refused with the joint's name."""
    m = openimp.Model()
    with pytest.raises(InputError, match=r"'CAM9'.*at least 3"):
        m.add_joint("cam", "CAM9", "BASE", "FOL", origin=(0, 0, 0), origin2=(1, 0, 0),
                    table=[1.0, 1.0])


def test_curve_point_not_found_names_joint() -> None:
    """A follower origin off the pitch curve / curve: compile raises an InputError naming
    the joint and saying how far off it is."""
    m = openimp.Model()
    m.add_joint("revolute", "A", "BASE", "CAM", origin=(0, 0, 0))
    m.add_joint("prismatic", "C", "BASE", "FOL", origin=(0, 1.5, 0), axis=Y)
    m.add_joint("cam", "K1", "CAM", "FOL", origin=(0, 0, 0), origin2=(0, 1.5, 0),
                table=cam_radius(np.linspace(0, 2 * np.pi, 90, endpoint=False)))
    with pytest.raises(InputError, match=r"'K1'.*not on the pitch curve"):
        openimp.compile(m)
    m2 = openimp.Model()
    m2.add_joint("revolute", "A", "BASE", "CAM", origin=(0, 0, 0))
    m2.add_joint("prismatic", "C", "BASE", "FOL", origin=(0, 1.5, 0), axis=Y)
    m2.add_joint("point_curve", "K2", "CAM", "FOL", origin=(0, 0, 0), origin2=(0, 1.5, 0),
                 curve=lambda t: (math.cos(t), math.sin(t), -math.sin(t), math.cos(t),
                                  -math.cos(t), -math.sin(t), math.sin(t), -math.cos(t)))
    with pytest.raises(InputError, match=r"'K2'.*not on the curve.*0\.5 length units"):
        openimp.compile(m2)


def test_bad_frames_ujoint_names_joint() -> None:
    """Universal-joint pins that are not perpendicular do not conform."""
    m = openimp.Model()
    m.add_joint("revolute", "IN", "BASE", "S1", origin=(0, 0, 0), axis=X)
    m.add_joint("revolute", "OUT", "BASE", "S2", origin=(0, 0, 0), axis=(1, 1, 0))
    m.add_joint("ujoint", "UJ", "S1", "S2", origin=(0, 0, 0), axis=Y, axis2=(0, 1, 1))
    with pytest.raises(InputError, match=r"'UJ'.*do not conform"):
        openimp.compile(m)
