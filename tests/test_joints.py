"""Every joint kind of the catalogue against finite differences of its own Phi.

``Q_g = (dPhi/dq_g) Phi^-1`` is the definition (DESIGN.md), so for every kind,
lower and higher pairs, at random variable values (fixed seeds, Euler-Rodrigues
parameters on the unit sphere):

* ``Q_g`` equals the central difference ``(Phi(q + eps e_g) - Phi(q - eps e_g)) /
  (2 eps) Phi(q)^-1``;
* ``Q_{g,i}`` equals the central difference of ``Q_g`` along ``e_i``; for the
  Euler-Rodrigues blocks the comparison with the derivative of the *true*
  operator ``(dPhi/de_g) Phi^-1`` is made only along directions tangent to the
  unit sphere (off the sphere Theta(e) is a scaled rotation and the book's Q
  differs from it by a multiple of 1 - |e|^2, digest ch 1-6 section 9 item 27);
* extraction round trip: ``Phi(extract(Phi(q))) == Phi(q)``;
* bad constants raise an InputError naming the joint.
"""

from __future__ import annotations

import math
import os
import subprocess
import sys
import textwrap
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

from helpers.decks import cpu_limit
from openimp import joints as J  # noqa: N812
from openimp.errors import InputError

EPS = 1e-6
TOL = 1e-7


# =============================================================================
# curves used by the curve joints
# =============================================================================
def ellipse(t: float) -> tuple[float, ...]:
    """u = 2 cos t, v = sin t + 0.3 and its first three derivatives."""
    c, s = math.cos(t), math.sin(t)
    return (2 * c, s + 0.3, -2 * s, c, -2 * c, -s, 2 * s, -c)


def radius_fn(t: float) -> tuple[float, ...]:
    """r = 1 + 0.2 cos t + 0.05 sin 2t and three derivatives."""
    return (
        1 + 0.2 * math.cos(t) + 0.05 * math.sin(2 * t),
        -0.2 * math.sin(t) + 0.1 * math.cos(2 * t),
        -0.2 * math.cos(t) - 0.2 * math.sin(2 * t),
        0.2 * math.sin(t) - 0.4 * math.cos(2 * t),
    )


def parabola(u: float) -> tuple[float, ...]:
    """v = 0.4 u^2 - 0.1 u."""
    return (0.4 * u * u - 0.1 * u, 0.8 * u - 0.1, 0.8, 0.0)


_TT = np.linspace(0.0, 2 * np.pi, 64, endpoint=False)
ELLIPSE_TABLE = np.stack([2 * np.cos(_TT) + 0.1 * np.cos(2 * _TT), np.sin(_TT)], axis=1)
CAM_TABLE = 1.0 + 0.25 * np.cos(_TT) + 0.05 * np.sin(3 * _TT)
SLOT_TABLE = 0.3 * np.sin(np.linspace(-1.0, 2.0, 25))
OPEN_CURVE = np.stack([np.linspace(0, 3, 30), 0.2 * np.linspace(0, 3, 30) ** 2], axis=1)


# =============================================================================
# the cases: (id, kind, constants, sampler of q)
# =============================================================================
def _unit4(rng: np.random.Generator) -> np.ndarray:
    e = rng.normal(size=4)
    return e / np.linalg.norm(e)


def _ang(rng: np.random.Generator) -> float:
    return float(rng.uniform(-np.pi, np.pi))


def _len(rng: np.random.Generator, a: float = 0.5) -> float:
    return float(rng.uniform(-a, a))


Sampler = Callable[[np.random.Generator], list[float]]

CASES: list[tuple[str, str, dict[str, Any], Sampler]] = [
    ("rigid", "rigid", {}, lambda r: []),
    ("revolute", "revolute", {}, lambda r: [_ang(r)]),
    ("prismatic", "prismatic", {}, lambda r: [_len(r)]),
    ("screw", "screw", {"lead": 0.3}, lambda r: [_len(r)]),
    ("screw-pitch", "screw", {"pitch": -0.05}, lambda r: [_len(r)]),
    ("cylinder", "cylinder", {}, lambda r: [_ang(r), _len(r)]),
    ("sphere", "sphere", {}, lambda r: list(_unit4(r))),
    ("flat", "flat", {}, lambda r: [_len(r), _len(r), _ang(r)]),
    ("open", "open", {}, lambda r: [_len(r), _len(r), _len(r), *_unit4(r)]),
    ("gear", "gear", {"radius1": 2.0, "radius2": 0.7}, lambda r: [_ang(r), _len(r, .1), _len(r)]),
    ("gear-load+", "gear", {"radius1": 2.0, "radius2": 0.7, "load_sign": 1, "helix_angle": 0.3},
     lambda r: [_ang(r), _len(r, .1), _len(r)]),
    ("gear-internal-load-", "gear", {"ratio": -2.5, "distance": 3.0, "load_sign": -1,
                                     "pressure_angle": 0.4, "helix_angle": -0.2},
     lambda r: [_ang(r), _len(r, .1), _len(r)]),
    ("gear-internal-second", "gear", {"ratio": -0.4, "distance": 1.2},
     lambda r: [_ang(r), _len(r, .1), _len(r)]),
    ("rack", "rack", {"radius": 0.6}, lambda r: [_len(r), _len(r, .1), _len(r)]),
    ("rack-load", "rack", {"radius": -0.6, "load_sign": 1, "helix_angle": 0.2},
     lambda r: [_len(r), _len(r, .1), _len(r)]),
    ("bevel-apex", "bevel", {"gamma1": 0.4, "gamma2": 1.0}, lambda r: [_ang(r), _len(r, .2)]),
    ("bevel-radius", "bevel", {"gamma1": 0.4, "gamma2": 0.9, "radius": 0.8},
     lambda r: [_ang(r), _len(r, .2)]),
    ("bevel-imp", "bevel", {"ratio": 2.625, "radius": 2.0}, lambda r: [_ang(r), _len(r, .2)]),
    ("bevel-book", "bevel", {"gamma1": 0.5, "gamma2": 0.8, "book_ratio": True},
     lambda r: [_ang(r), _len(r, .2)]),
    ("point_curve-callable", "point_curve", {"curve": ellipse},
     lambda r: [_ang(r), _ang(r), _len(r)]),
    ("point_curve-periodic", "point_curve", {"table": ELLIPSE_TABLE},
     lambda r: [_ang(r), _ang(r), _len(r)]),
    ("point_curve-range", "point_curve", {"table": OPEN_CURVE, "range": (0.0, 3.0)},
     lambda r: [float(r.uniform(0.1, 2.9)), _ang(r), _len(r)]),
    ("point_curve-fourier", "point_curve",
     {"fourier": (([0.1, 2.0, 0.1], [0.0, 0.2]), ([0.0, 0.05], [1.0])), "period": 2 * np.pi},
     lambda r: [_ang(r), _ang(r), _len(r)]),
    ("line_curve-callable", "line_curve", {"curve": ellipse},
     lambda r: [_ang(r), _len(r), _len(r)]),
    ("line_curve-periodic", "line_curve", {"table": ELLIPSE_TABLE},
     lambda r: [_ang(r), _len(r), _len(r)]),
    ("line_curve-fourier", "line_curve",
     {"fourier": (([0.1, 2.0, 0.1], [0.0, 0.2]), ([0.0, 0.05], [1.0]))},
     lambda r: [_ang(r), _len(r), _len(r)]),
    ("cam-table", "cam", {"table": CAM_TABLE}, lambda r: [_ang(r), _ang(r)]),
    ("cam-fourier-table", "cam", {"table": CAM_TABLE, "interpolation": "fourier"},
     lambda r: [_ang(r), _ang(r)]),
    ("cam-fourier", "cam", {"fourier": ([1.0, 0.2, 0.0], [0.0, 0.05])},
     lambda r: [_ang(r), _ang(r)]),
    ("cam-function", "cam", {"function": radius_fn}, lambda r: [_ang(r), _ang(r)]),
    ("slot-table", "slot", {"table": SLOT_TABLE, "range": (-1.0, 2.0)},
     lambda r: [float(r.uniform(-0.9, 1.9)), _ang(r)]),
    ("slot-function", "slot", {"function": parabola, "range": (-1.0, 1.0)},
     lambda r: [float(r.uniform(-0.9, 0.9)), _ang(r)]),
    ("ujoint", "ujoint", {}, lambda r: [_ang(r), _ang(r)]),
    ("sphere_plane", "sphere_plane", {}, lambda r: [_len(r), _len(r), *_unit4(r)]),
    ("sphere_groove", "sphere_groove", {}, lambda r: [_len(r), *_unit4(r)]),
    ("gimbal", "gimbal", {}, lambda r: [_ang(r), _ang(r), _ang(r)]),
    ("open_cardan", "open_cardan", {},
     lambda r: [_len(r), _len(r), _len(r), _ang(r), _ang(r), _ang(r)]),
    ("flat_polar", "flat_polar", {}, lambda r: [_ang(r), _len(r, .3), _ang(r)]),
]
IDS = [c[0] for c in CASES]
SEEDS = (1, 2, 3)


def _setup(case: tuple[str, str, dict[str, Any], Sampler], seed: int
           ) -> tuple[J.JointType, np.ndarray, np.ndarray]:
    _, kind, kw, sampler = case
    jt = J.joint_type(kind)
    assert jt.make_consts is not None
    c = jt.make_consts("J1", dict(kw))
    q = np.array(sampler(np.random.default_rng(seed)), dtype=float)
    assert q.shape == (jt.nvar,)
    return jt, q, c


def _er_mask(jt: J.JointType) -> np.ndarray:
    m = np.zeros(jt.nvar, bool)
    for e in jt.er_groups:
        m[e:e + 4] = True
    return m


def test_catalogue_complete() -> None:
    """Every integer code has exactly one kind, and every kind is in CASES."""
    kinds = {jt.name: jt for jt in J.CATALOGUE.values()}
    codes = sorted(jt.code for jt in kinds.values())
    assert codes == list(range(21))
    assert {c[1] for c in CASES} == set(kinds)
    for jt in kinds.values():
        assert jt.nvar <= J.MAXV
        assert len(jt.var_kinds) == jt.nvar
        assert jt.convention
        assert sum(k == "er" for k in jt.var_kinds) == 4 * len(jt.er_groups)


@pytest.mark.parametrize("case", CASES, ids=IDS)
def test_nvar_kernel(case: tuple[str, str, dict[str, Any], Sampler]) -> None:
    """The kernels' variable count agrees with the catalogue."""
    jt = J.joint_type(case[1])
    assert J.nvar(jt.code) == jt.nvar


@pytest.mark.parametrize("seed", SEEDS)
@pytest.mark.parametrize("case", CASES, ids=IDS)
def test_Q_finite_differences(case: tuple[str, str, dict[str, Any], Sampler], seed: int) -> None:
    """Q_g == (Phi(q + eps e_g) - Phi(q - eps e_g)) / (2 eps) Phi(q)^-1."""
    jt, q, c = _setup(case, seed)
    Phi = J.phi_of(jt, q, c)
    assert np.allclose(Phi[3], [0, 0, 0, 1])
    assert np.allclose(Phi[:3, :3].T @ Phi[:3, :3], np.eye(3), atol=1e-12)
    Q = J.Q_of(jt, q, c)
    Pinv = np.linalg.inv(Phi)
    for g in range(jt.nvar):
        d = np.zeros(jt.nvar)
        d[g] = EPS
        fd = (J.phi_of(jt, q + d, c) - J.phi_of(jt, q - d, c)) / (2 * EPS) @ Pinv
        assert np.max(np.abs(fd - Q[g])) < TOL, (case[0], g, fd, Q[g])


@pytest.mark.parametrize("seed", SEEDS)
@pytest.mark.parametrize("case", CASES, ids=IDS)
def test_dQ_finite_differences(case: tuple[str, str, dict[str, Any], Sampler], seed: int) -> None:
    """Q_{g,i} == (Q_g(q + eps e_i) - Q_g(q - eps e_i)) / (2 eps)."""
    jt, q, c = _setup(case, seed)
    dQ = J.dQ_of(jt, q, c)
    for i in range(jt.nvar):
        d = np.zeros(jt.nvar)
        d[i] = EPS
        fd = (J.Q_of(jt, q + d, c) - J.Q_of(jt, q - d, c)) / (2 * EPS)
        assert np.max(np.abs(fd - dQ[:, i])) < TOL, (case[0], i)


@pytest.mark.parametrize("seed", SEEDS)
@pytest.mark.parametrize("case", [c for c in CASES if J.joint_type(c[1]).er_groups],
                         ids=[c[0] for c in CASES if J.joint_type(c[1]).er_groups])
def test_dQ_er_tangent(case: tuple[str, str, dict[str, Any], Sampler], seed: int) -> None:
    """Along directions tangent to the unit sphere, sum_i d_i Q_{g,i} is the derivative
    of the true operator (dPhi/dq_g) Phi^-1 along the great circle through q."""
    jt, q, c = _setup(case, seed)
    er = _er_mask(jt)
    rng = np.random.default_rng(100 + seed)
    dQ = J.dQ_of(jt, q, c)

    def true_Q(qq: np.ndarray) -> np.ndarray:
        # Theta is quadratic in e and p linear: a central difference is exact up to rounding
        h = 1e-3
        Pinv = np.linalg.inv(J.phi_of(jt, qq, c))
        out = np.empty((jt.nvar, 4, 4))
        for g in range(jt.nvar):
            d = np.zeros(jt.nvar)
            d[g] = h
            out[g] = (J.phi_of(jt, qq + d, c) - J.phi_of(jt, qq - d, c)) / (2 * h) @ Pinv
        return out

    for _ in range(3):
        d = rng.normal(size=jt.nvar)
        for e0 in jt.er_groups:  # remove the component along e: tangent to the sphere
            e = q[e0:e0 + 4]
            d[e0:e0 + 4] -= (d[e0:e0 + 4] @ e) * e
        s = 1e-4

        def on_circle(sv: float, d: np.ndarray = d) -> np.ndarray:
            qq = q + sv * d
            for e0 in jt.er_groups:
                e, de = q[e0:e0 + 4], d[e0:e0 + 4]
                nd = np.linalg.norm(de)
                qq[e0:e0 + 4] = e * math.cos(sv * nd) + (de / nd) * math.sin(sv * nd) \
                    if nd > 0 else e
            return qq

        fd = (true_Q(on_circle(s)) - true_Q(on_circle(-s))) / (2 * s)
        an = np.einsum("gijk,i->gjk", dQ, d)
        assert np.max(np.abs(fd - an)) < 1e-6, case[0]
    assert er.any()


@pytest.mark.parametrize("seed", SEEDS)
@pytest.mark.parametrize("case", CASES, ids=IDS)
def test_extraction_round_trip(case: tuple[str, str, dict[str, Any], Sampler], seed: int) -> None:
    """Phi(extract(Phi(q))) == Phi(q)."""
    jt, q, c = _setup(case, seed)
    Phi = J.phi_of(jt, q, c)
    q2 = jt.extract_q(Phi, c)
    assert q2.shape == (jt.nvar,)
    assert np.max(np.abs(J.phi_of(jt, q2, c) - Phi)) < 1e-9, (case[0], q, q2)
    # and through conformity (what compile uses), at a model scale of 1
    q3 = J.conformity(jt, "J1", Phi, c.copy(), 1.0, 1e-7)
    assert np.max(np.abs(J.phi_of(jt, q3, c) - Phi)) < 1e-9


@pytest.mark.parametrize("case", CASES, ids=IDS)
def test_length_scaling(case: tuple[str, str, dict[str, Any], Sampler]) -> None:
    """Scaling the 'length' constants and variables by 1/L scales Phi's translation by 1/L
    (what system.compile does with its internal length unit)."""
    jt, q, c = _setup(case, 7)
    L = 3.7
    cs = c.copy()
    for k, kind in enumerate(jt.const_kinds):
        if kind == "length":
            cs[k] /= L
    qs = q.copy()
    for k, kind in enumerate(jt.var_kinds):
        if kind == "length":
            qs[k] /= L
    P = J.phi_of(jt, q, c)
    Ps = J.phi_of(jt, qs, cs)
    assert np.allclose(Ps[:3, :3], P[:3, :3], atol=1e-12)
    assert np.allclose(Ps[:3, 3] * L, P[:3, 3], atol=1e-12)


# =============================================================================
# formulas and conventions
# =============================================================================
def test_gear_book_values() -> None:
    """Book (4.28): theta = (R + R') phi1 / R' without the load term; Q1 = (6.25)."""
    jt = J.joint_type("gear")
    c = jt.make_consts("G", {"radius1": 2.525, "radius2": 0.25})
    q = np.array([0.3, -0.025, 0.0])
    Phi = J.phi_of(jt, q, c)
    th = 11.1 * 0.3
    assert np.allclose(Phi[:2, :2], [[math.cos(th), -math.sin(th)], [math.sin(th), math.cos(th)]])
    assert np.allclose(Phi[:3, 3], [2.75 * math.cos(0.3), 2.75 * math.sin(0.3), 0.0])
    Q1 = J.Q_of(jt, q, c)[0]
    R, Rp, rho = 2.525, 0.25, 2.75
    book = (1 / Rp) * np.array([[0, -(R + Rp), 0, R * rho * math.sin(0.3)],
                                [R + Rp, 0, 0, -R * rho * math.cos(0.3)], [0, 0, 0, 0],
                                [0, 0, 0, 0]])
    assert np.allclose(Q1, book)


def test_gear_ratio_forms() -> None:
    """IMP's ratio + distance give the signed radii; internal pairs rotate the right way."""
    jt = J.joint_type("gear")
    c = jt.make_consts("G", {"ratio": 2.0, "distance": 3.0})
    assert np.allclose(c[:3], [2.0, 1.0, 3.0])
    c = jt.make_consts("G", {"ratio": -2.5, "distance": 3.0})  # ring 5 around pinion 2
    assert np.allclose(c[:3], [-5.0, 2.0, 3.0])
    # a planet rolling inside a fixed ring of radius 5: it turns -1.5 times the arm
    Phi = J.phi_of(jt, np.array([0.2, 0.0, 0.0]), c)
    assert math.isclose(J.angle_of(Phi), -1.5 * 0.2)
    assert np.allclose(Phi[:2, 3], [3 * math.cos(0.2), 3 * math.sin(0.2)])
    c = jt.make_consts("G", {"ratio": -0.4, "distance": 3.0})  # pinion 2 inside ring 5
    assert np.allclose(c[:3], [2.0, -5.0, 3.0])


def test_gear_distance_from_frames() -> None:
    """Without distance= the centre distance comes from the frames (complete hook)."""
    jt = J.joint_type("gear")
    c = jt.make_consts("G", {"ratio": 3.0})
    assert math.isnan(c[2])
    Phi = np.eye(4)
    Phi[:3, 3] = [0.0, 4.0, 0.5]  # t at 90 deg from u; u' parallel to u
    c2 = c.copy()
    q = J.conformity(jt, "G", Phi, c2, 1.0, 1e-7)
    assert np.allclose(c2[:3], [3.0, 1.0, 4.0])
    # theta = (R + R')/R' phi1 = 4 (pi/2) = 2 pi: u' parallel to u, as given
    assert np.allclose(q, [math.pi / 2, 0.0, 0.5])
    assert np.allclose(J.phi_of(jt, q, c2), Phi)
    coinc = np.eye(4)
    with pytest.raises(InputError, match=r"'G'.*coincide"):
        J.conformity(jt, "G", coinc, c.copy(), 1.0, 1e-7)


def test_gear_extraction_finds_turns() -> None:
    """phi1 is found modulo 2 pi; the turn count that matches u' is chosen."""
    jt = J.joint_type("gear")
    c = jt.make_consts("G", {"radius1": 2.5, "radius2": 1.0})  # theta = 3.5 phi1
    q = np.array([0.4 + 2 * math.pi, 0.0, 0.0])
    Phi = J.phi_of(jt, q, c)
    q2 = jt.extract_q(Phi, c)
    assert np.allclose(J.phi_of(jt, q2, c), Phi)
    # atan2 alone (no whole turn of t) would put u' half a turn off
    assert not np.allclose(J.phi_of(jt, np.array([0.4, 0.0, 0.0]), c), Phi)
    assert math.isclose(abs(q2[0] - 0.4), 2 * math.pi)


def test_rack_rolls_without_slip() -> None:
    """The pinion's contact point (below its centre) has zero velocity along the rack."""
    jt = J.joint_type("rack")
    for R in (0.6, -0.6):
        c = jt.make_consts("K", {"radius": R})
        q = np.array([0.37, 0.0, 0.0])
        Q1 = J.Q_of(jt, q, c)[0]
        contact = np.array([q[0], 0.0, 0.0, 1.0])  # on the pitch line
        assert np.allclose(Q1 @ contact, 0.0, atol=1e-14)


@pytest.mark.parametrize("kw", [{"gamma1": 0.4, "gamma2": 1.0}, {"gamma1": 0.3, "gamma2": 0.6,
                                                                 "radius": 0.7},
                                {"ratio": 0.5, "radius": 2.0}, {"gamma1": -0.3, "gamma2": 1.2}])
def test_bevel_pitch_cones_roll(kw: dict[str, Any]) -> None:
    """Decision on the bevel ratio (digest ch 1-6 section 9 item 8): the relative twist of
    the two gears for d phi1 leaves the pitch contact line at rest (no slip), which needs
    phi' = -(sin g1 / sin g2) phi1; the book's +tan g1 / tan g2 slips."""
    jt = J.joint_type("bevel")
    c = jt.make_consts("B", dict(kw))
    g1, d1 = c[4], c[2]
    for phi1 in (0.0, 0.7, -2.0):
        q = np.array([phi1, 0.0])
        Q1 = J.Q_of(jt, q, c)[0]
        # pitch contact line: from the apex, at g1 from w toward w' (in the t frame
        # (t, w x t, w) the direction is (0, -sin g1, cos g1)), turned into uvw by Rz(-phi1)
        ca, sa = math.cos(-phi1), math.sin(-phi1)
        dt = np.array([0.0, -math.sin(g1), math.cos(g1)])
        dirn = np.array([ca * dt[0] - sa * dt[1], sa * dt[0] + ca * dt[1], dt[2]])
        for rho in (0.5, 1.0, 2.0):
            P = np.append(np.array([0.0, 0.0, -d1]) + rho * dirn, 1.0)
            assert np.allclose(Q1 @ P, 0.0, atol=1e-13)
    book = jt.make_consts("B", {**kw, "book_ratio": True})
    Q1 = J.Q_of(jt, np.array([0.3, 0.0]), book)[0]
    assert np.max(np.abs(Q1[:3, :3] - J.Q_of(jt, np.array([0.3, 0.0]), c)[0][:3, :3])) > 1e-3


def test_bevel_imp_ratio_radius() -> None:
    """IMP's `2.625, 2.0`: radii 5.25 and 2.0, 90 deg shafts, frames in the pitch planes."""
    jt = J.joint_type("bevel")
    c = jt.make_consts("B", {"ratio": 2.625, "radius": 2.0})
    assert math.isclose(c[0], -2.625)
    assert math.isclose(c[1], math.pi / 2)
    assert math.isclose(c[2], 2.0) and math.isclose(c[3], 5.25)


def test_line_curve_corrected_theta_prime() -> None:
    """Corrected (6.29): theta' = (u'v'' - v'u'')/(u'^2 + v'^2) and Q1 column 4 uses u, v."""
    jt = J.joint_type("line_curve")
    c = jt.make_consts("L", {"curve": ellipse})
    t = 0.9
    u, v, u1, v1, u2, v2, _, _ = ellipse(t)
    thp = (u1 * v2 - v1 * u2) / (u1 * u1 + v1 * v1)
    Q1 = J.Q_of(jt, np.array([t, 0.4, 0.0]), c)[0]
    assert math.isclose(Q1[1, 0], thp)
    assert np.allclose(Q1[:2, 3], [u1 + thp * v, v1 - thp * u])


def test_ujoint_imp_variables() -> None:
    """w' = (sin phi1, -cos phi1, 0) in uvw: t = w x w' is at phi1 from u; u' at phi2 from t."""
    jt = J.joint_type("ujoint")
    q = np.array([0.4, -1.1])
    Phi = J.phi_of(jt, q, np.zeros(0))
    w, wp, up = np.array([0, 0, 1.0]), Phi[:3, 2], Phi[:3, 0]
    assert math.isclose(w @ wp, 0.0, abs_tol=1e-15)
    t = np.cross(w, wp)
    assert np.allclose(t, [math.cos(0.4), math.sin(0.4), 0.0])
    assert math.isclose(math.atan2(np.cross(t, up) @ wp, t @ up), -1.1)


def test_callable_curve_registry() -> None:
    """A registered callable is evaluated in the kernels through objmode."""
    jt = J.joint_type("point_curve")
    c = jt.make_consts("P", {"curve": lambda t: (t, t * t, 1.0, 2 * t, 0.0, 2.0, 0.0, 0.0),
                             "range": (-2.0, 2.0)})
    Phi = J.phi_of(jt, np.array([1.5, 0.0, 0.0]), c)
    assert np.allclose(Phi[:2, 3], [1.5, 2.25])
    t, d = J.curve_parameter(c, 0.0, 1.0)  # closest point of y = x^2 to (0, 1)
    assert math.isclose(abs(t), math.sqrt(0.5), rel_tol=1e-9)
    assert math.isclose(d, math.sqrt(0.5 + 0.25), rel_tol=1e-9)


def test_periodic_table_spline_accuracy() -> None:
    """A periodic cubic spline through 360 samples of a smooth radius is accurate to 1e-8."""
    jt = J.joint_type("cam")
    tt = np.linspace(0, 2 * np.pi, 360, endpoint=False)
    c = jt.make_consts("C", {"table": [radius_fn(t)[0] for t in tt]})
    closed = jt.make_consts("C", {"table": [radius_fn(t)[0] for t in [*tt, 2 * np.pi]],
                                  "closed": True})
    assert np.array_equal(c, closed)
    for t in np.linspace(-7, 7, 23):
        Phi = J.phi_of(jt, np.array([t, 0.0]), c)
        assert math.isclose(math.hypot(Phi[0, 3], Phi[1, 3]), radius_fn(t)[0], abs_tol=1e-8)


def test_callable_curve_kernels_are_cached(tmp_path: Any) -> None:
    """The objmode block of callable curves does not prevent numba's on-disk caching."""
    from openimp._jit import JIT_ENABLED

    if not JIT_ENABLED:
        pytest.skip("kernels not compiled (OPENIMP_NOJIT)")
    code = textwrap.dedent("""
        import math, numpy as np
        from openimp import joints as J  # noqa: N812
        jt = J.joint_type("point_curve")
        c = jt.make_consts("P", {"curve": lambda t: (math.cos(t), math.sin(t), -math.sin(t),
                                                    math.cos(t), -math.cos(t), -math.sin(t),
                                                    math.sin(t), -math.cos(t))})
        out = np.zeros((4, 4))
        Q = np.zeros((J.MAXV, 4, 4))
        dQ = np.zeros((J.MAXV, J.MAXV, 4, 4))
        J.joint_calc(jt.code, np.array([0.5, 0.0, 0.0]), c, 0.0, out, Q, dQ, 0)
        assert abs(out[0, 3] - math.cos(0.5)) < 1e-15
        print(sum(J.joint_calc.stats.cache_hits.values()),
              sum(J.joint_calc.stats.cache_misses.values()))
    """)
    env = dict(os.environ)
    env["NUMBA_CACHE_DIR"] = str(tmp_path)
    runs = [subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env,
                           preexec_fn=cpu_limit) for _ in range(2)]
    for r in runs:
        assert r.returncode == 0, r.stderr
    hits, misses = (int(v) for v in runs[1].stdout.split())
    assert hits >= 1 and misses == 0, runs[1].stdout


# =============================================================================
# bad constants: InputError naming the joint
# =============================================================================
BAD: list[tuple[str, dict[str, Any], str]] = [
    ("rigid", {"lead": 1.0}, "unexpected"),
    ("revolute", {"ratio": 2.0}, "unexpected"),
    ("screw", {}, "lead"),
    ("screw", {"lead": 0.0}, "must not be zero"),
    ("screw", {"lead": float("nan")}, "must be a finite number"),
    ("gear", {}, "ratio"),
    ("gear", {"ratio": 0.0}, "zero"),
    ("gear", {"ratio": -1.0}, "centre distance"),
    ("gear", {"ratio": float("inf")}, "finite"),
    ("gear", {"ratio": 2.0, "distance": -1.0}, "positive"),
    ("gear", {"radius1": 1.0, "radius2": -1.0}, "zero"),
    ("gear", {"radius1": 1.0, "radius2": 2.0, "ratio": 0.5}, "not both"),
    ("gear", {"ratio": 2.0, "load_sign": 0.5}, "load_sign"),
    ("gear", {"ratio": 2.0, "pressure_angle": 2.0}, "pressure_angle"),
    ("gear", {"ratio": 2.0, "teeth": 20}, "unexpected"),
    ("rack", {}, "radius"),
    ("rack", {"radius": 0.0}, "zero"),
    ("rack", {"radius": "abc"}, "number"),
    ("bevel", {}, "gamma1"),
    ("bevel", {"ratio": 0.0}, "positive"),
    ("bevel", {"ratio": -2.0}, "positive"),
    ("bevel", {"gamma1": 2.0, "gamma2": 1.5}, "shaft angle"),
    ("bevel", {"gamma1": 0.5, "gamma2": 0.5, "radius": -1.0}, "sign"),
    ("point_curve", {}, "curve"),
    ("point_curve", {"curve": 3.0}, "callable"),
    ("point_curve", {"curve": lambda t: (1.0, 2.0)}, "8 finite"),
    ("point_curve", {"curve": lambda t: 1 / 0}, "ZeroDivisionError"),
    ("point_curve", {"table": [1.0, 2.0, 3.0]}, "2-dimensional"),
    ("point_curve", {"table": [[1.0, 2.0, 3.0]] * 5}, "two columns"),
    ("point_curve", {"table": [[0.0, 0.0], [1.0, 1.0]]}, "at least 3"),
    ("point_curve", {"table": ELLIPSE_TABLE, "period": 0.0}, "positive"),
    ("point_curve", {"table": ELLIPSE_TABLE, "range": (1.0, 0.0)}, "increasing"),
    ("point_curve", {"table": [[np.nan, 0.0]] * 5}, "non-finite"),
    ("line_curve", {"fourier": (([1.0, 2.0], [1.0, 2.0]), ([0.0], []))}, "one longer"),
    ("cam", {}, "table"),
    ("cam", {"table": [1.0, 1.1]}, "at least 3"),
    ("cam", {"table": [1.0, 1.1, 1.2, 1.3], "closed": True}, "closed"),
    ("cam", {"table": CAM_TABLE, "fourier": ([1.0], [])}, "exactly one"),
    ("cam", {"table": CAM_TABLE, "interpolation": "linear"}, "interpolation"),
    ("cam", {"fourier": ([1.0, 0.1], [0.2, 0.3])}, "one longer"),
    ("cam", {"function": lambda t: (1.0,)}, "4 finite"),
    ("slot", {"table": SLOT_TABLE}, "range"),
    ("slot", {"table": [0.0, 1.0, 2.0], "range": (0.0, 1.0)}, "at least 4"),
    ("ujoint", {"angle": 1.0}, "unexpected"),
    ("sphere_plane", {"radius": 1.0}, "unexpected"),
    ("sphere_groove", {"radius": 1.0}, "unexpected"),
]


@pytest.mark.parametrize("kind, kw, what", BAD, ids=[f"{b[0]}-{i}" for i, b in enumerate(BAD)])
def test_bad_constants(kind: str, kw: dict[str, Any], what: str) -> None:
    """Bad constants: an InputError that names the joint and the problem."""
    jt = J.joint_type(kind)
    assert jt.make_consts is not None
    with pytest.raises(InputError) as exc:
        jt.make_consts("JNT7", dict(kw))
    msg = str(exc.value)
    assert "'JNT7'" in msg and what in msg, msg


def test_unknown_kind() -> None:
    """Unknown kinds list the known ones."""
    with pytest.raises(InputError, match="known kinds"):
        J.joint_type("wormgear")


@pytest.mark.parametrize("kind, kw, Phi, what", [
    ("point_curve", {"curve": ellipse}, np.array([[1, 0, 0, 0.0], [0, 1, 0, 0.0], [0, 0, 1, 0],
                                                  [0, 0, 0, 1]]), "not on the curve"),
    ("line_curve", {"curve": ellipse}, np.array([[1, 0, 0, 0.0], [0, 1, 0, 0.0], [0, 0, 1, 0],
                                                 [0, 0, 0, 1]]), "not tangent"),
    ("cam", {"table": CAM_TABLE}, np.array([[1, 0, 0, 2.0], [0, 1, 0, 0.0], [0, 0, 1, 0],
                                            [0, 0, 0, 1]]), "not on the pitch curve"),
    ("slot", {"table": SLOT_TABLE, "range": (-1.0, 2.0)},
     np.array([[1, 0, 0, 5.0], [0, 1, 0, 0.0], [0, 0, 1, 0], [0, 0, 0, 1]]), "outside the slot"),
    ("slot", {"table": SLOT_TABLE, "range": (-1.0, 2.0)},
     np.array([[1, 0, 0, 0.5], [0, 1, 0, 1.0], [0, 0, 1, 0], [0, 0, 0, 1]]), "not on the slot"),
    ("ujoint", {}, np.eye(4), "parallel"),
    ("bevel", {"gamma1": 0.5, "gamma2": 0.5}, np.eye(4), "parallel"),
    ("gear", {"ratio": 2.0, "distance": 3.0}, np.eye(4), "coincide"),
])
def test_assembly_errors(kind: str, kw: dict[str, Any], Phi: np.ndarray, what: str) -> None:
    """Frames that the joint cannot produce: an InputError naming the joint."""
    jt = J.joint_type(kind)
    assert jt.make_consts is not None
    c = jt.make_consts("JX", kw)
    with pytest.raises(InputError) as exc:
        J.conformity(jt, "JX", Phi.astype(float), c, 1.0, 1e-7)
    assert "'JX'" in str(exc.value) and what in str(exc.value), str(exc.value)


def test_conformity_ujoint_not_perpendicular() -> None:
    """A universal joint whose pins are not perpendicular does not conform."""
    jt = J.joint_type("ujoint")
    Phi = np.eye(4)
    a = 1.2  # w' at 1.2 rad from w instead of 90 deg
    Phi[:3, :3] = [[1, 0, 0], [0, math.cos(a), -math.sin(a)], [0, math.sin(a), math.cos(a)]]
    with pytest.raises(InputError, match=r"'U1'.*do not conform"):
        J.conformity(jt, "U1", Phi, np.zeros(0), 1.0, 1e-7)
