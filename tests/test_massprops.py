"""Tests of openimp.massprops (book §9.3 pseudo-inertia, §9.4 units).

References are independent plain numpy: J = Σ m r r^t over explicit point
masses, inertia tensors summed by hand, closed-form moments of the solids.
Tolerances: EXACT = 1e-12 relative (to the largest entry compared) where the
result is exact in exact arithmetic; everything here is exact.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from openimp import massprops as mp
from openimp.errors import InputError

EXACT = 1e-12


def close(a, b, rel: float = EXACT) -> None:
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    scale = max(float(np.max(np.abs(b))), 1.0e-300)
    assert a.shape == b.shape
    assert float(np.max(np.abs(a - b))) <= rel * scale, (a, b)


def skew(w: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])


def rotation(seed: int) -> np.ndarray:
    q, r = np.linalg.qr(np.random.default_rng(seed).normal(size=(3, 3)))
    q = q * np.sign(np.diag(r))
    if np.linalg.det(q) < 0:
        q[:, 0] = -q[:, 0]
    return q


def rigid(R: np.ndarray, p) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = p
    return T


def cloud(seed: int = 0, n: int = 7):
    """Point masses: masses (n,), global positions (n, 3)."""
    g = np.random.default_rng(seed)
    return g.uniform(0.5, 2.0, n), g.normal(size=(n, 3)) + np.array([1.0, -2.0, 0.5])


def cloud_J(m: np.ndarray, x: np.ndarray) -> np.ndarray:
    r = np.hstack([x, np.ones((len(m), 1))])
    return np.einsum("i,ij,ik->jk", m, r, r)


def tensor_about(m: np.ndarray, x: np.ndarray, o: np.ndarray) -> np.ndarray:
    """I = Σ m (|s|² E - s s^t), s = x - o, by hand."""
    I = np.zeros((3, 3))
    for mi, xi in zip(m, x):
        s = xi - o
        I += mi * (s @ s * np.eye(3) - np.outer(s, s))
    return I


# ------------------------------------------------------------------ pseudo_inertia


def test_point_mass():
    J = mp.pseudo_inertia(2.0, [1.0, 2.0, 3.0])
    r = np.array([1.0, 2.0, 3.0, 1.0])
    close(J, 2.0 * np.outer(r, r))


def test_point_cloud_about_center_global_axes():
    m, x = cloud(0)
    M = m.sum()
    c = m @ x / M
    J = mp.pseudo_inertia(M, c, tensor_about(m, x, c))
    close(J, cloud_J(m, x))
    assert np.array_equal(J, J.T)


def test_point_cloud_about_center_rotated_axes():
    m, x = cloud(1)
    M = m.sum()
    c = m @ x / M
    R = rotation(3)
    I_local = R.T @ tensor_about(m, x, c) @ R  # the tensor on the columns of R
    close(mp.pseudo_inertia(M, c, I_local, axes=R), cloud_J(m, x))


def test_point_cloud_principal_moments():
    m, x = cloud(2)
    M = m.sum()
    c = m @ x / M
    w, V = np.linalg.eigh(tensor_about(m, x, c))
    if np.linalg.det(V) < 0:
        V[:, 0] = -V[:, 0]
    close(mp.pseudo_inertia(M, c, w, axes=V), cloud_J(m, x))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_point_cloud_about_other_origin(seed):
    m, x = cloud(seed)
    M = m.sum()
    c = m @ x / M
    o = np.array([0.3, 4.0, -1.5])
    R = rotation(seed + 10)
    I_o = tensor_about(m, x, o)
    ref = cloud_J(m, x)
    close(mp.pseudo_inertia(M, c, I_o, about="origin", origin=o), ref)
    close(mp.pseudo_inertia(M, c, R.T @ I_o @ R, axes=R, about="origin", origin=o), ref)
    # about the global origin: the 3x3 block is Σ directly
    I_0 = tensor_about(m, x, np.zeros(3))
    close(mp.pseudo_inertia(M, c, I_0, about="origin", origin=[0, 0, 0]), ref)


def test_parallel_axis_about_center_equals_about_origin():
    I_c = np.array([[2.0, -0.3, 0.1], [-0.3, 3.0, 0.2], [0.1, 0.2, 4.0]])
    c = np.array([1.0, 2.0, -1.0])
    o = np.array([-0.5, 0.7, 2.0])
    m = 3.5
    d = c - o
    I_o = I_c + m * (d @ d * np.eye(3) - np.outer(d, d))  # textbook parallel-axis
    close(
        mp.pseudo_inertia(m, c, I_o, about="origin", origin=o),
        mp.pseudo_inertia(m, c, I_c),
    )


def test_eq_9_6_layout():
    """The 3x3 block is ½(-Ixx+Iyy+Izz)... with products Ixy = ∫xy (no minus sign)."""
    m, x = cloud(4)
    J = cloud_J(m, x)
    Ixx = np.sum(m * (x[:, 1] ** 2 + x[:, 2] ** 2))
    Iyy = np.sum(m * (x[:, 2] ** 2 + x[:, 0] ** 2))
    Izz = np.sum(m * (x[:, 0] ** 2 + x[:, 1] ** 2))
    Ixy = np.sum(m * x[:, 0] * x[:, 1])
    I_0 = np.array(
        [
            [Ixx, -Ixy, -np.sum(m * x[:, 0] * x[:, 2])],
            [-Ixy, Iyy, -np.sum(m * x[:, 1] * x[:, 2])],
            [-np.sum(m * x[:, 0] * x[:, 2]), -np.sum(m * x[:, 1] * x[:, 2]), Izz],
        ]
    )
    M = m.sum()
    Jm = mp.pseudo_inertia(M, m @ x / M, I_0, about="origin", origin=np.zeros(3))
    close(Jm, J)
    close(Jm[0, 0], 0.5 * (-Ixx + Iyy + Izz))
    close(Jm[0, 1], Ixy)


def test_kinetic_energy_trace_form():
    """½ trace(Ω J Ω^t) = ½ m |v_c|² + ½ ω·I_c ω (book 9.6/9.7)."""
    m, x = cloud(5)
    M = m.sum()
    c = m @ x / M
    I_c = tensor_about(m, x, c)
    J = mp.pseudo_inertia(M, c, I_c)
    g = np.random.default_rng(6)
    for _ in range(3):
        w, v = g.normal(size=3), g.normal(size=3)
        Om = np.zeros((4, 4))
        Om[:3, :3] = skew(w)
        Om[:3, 3] = v
        trace_form = 0.5 * np.trace(Om @ J @ Om.T)
        vc = np.cross(w, c) + v
        split = 0.5 * M * vc @ vc + 0.5 * w @ I_c @ w
        particles = 0.5 * sum(mi * np.sum((np.cross(w, xi) + v) ** 2) for mi, xi in zip(m, x))
        assert abs(trace_form - split) <= EXACT * abs(split)
        assert abs(trace_form - particles) <= EXACT * abs(particles)


def test_centroidal_round_trip():
    m, x = cloud(7)
    M = m.sum()
    c = m @ x / M
    I_c = tensor_about(m, x, c)
    mass, cc, II = mp.centroidal(cloud_J(m, x))
    assert abs(mass - M) <= EXACT * M
    close(cc, c)
    close(II, I_c, rel=1e-11)  # Σ - m c c^t cancels O(|c|²) terms


def test_centroidal_massless():
    mass, c, I = mp.centroidal(np.zeros((4, 4)))
    assert mass == 0.0
    assert np.array_equal(c, np.zeros(3))
    assert np.array_equal(I, np.zeros((3, 3)))


def test_transform_matches_points():
    m, x = cloud(8)
    T = rigid(rotation(9), [0.4, -1.0, 2.0])
    xT = x @ T[:3, :3].T + T[:3, 3]
    close(mp.transform(cloud_J(m, x), T), cloud_J(m, xT))
    Tinv = np.linalg.inv(T)
    close(mp.transform(mp.transform(cloud_J(m, x), T), Tinv), cloud_J(m, x))


# ------------------------------------------------------------------ check_inertia


def test_check_inertia_valid():
    assert mp.check_inertia(mp.pseudo_inertia(2.0, [1, 2, 3], [1.0, 2.0, 3.0])) == []
    assert mp.check_inertia(mp.pseudo_inertia(1.0, [1, 2, 3])) == []  # point mass
    assert mp.check_inertia(mp.rod(2.0, 1.0, rigid(rotation(1), [1, 1, 1]))) == []  # 0, a, a
    assert mp.check_inertia(np.zeros((4, 4))) == []  # massless body


def test_check_inertia_triangle():
    msgs = mp.check_inertia(mp.pseudo_inertia(1.0, [0, 0, 0], [1.0, 1.0, 3.0]))
    assert len(msgs) == 1
    assert "triangle inequality I1 + I2 >= I3" in msgs[0]
    assert "1, 1, 3" in msgs[0]


def test_check_inertia_negative_moment():
    msgs = mp.check_inertia(mp.pseudo_inertia(1.0, [1, 0, 0], [-1.0, 3.0, 3.0]))
    assert any("negative" in s for s in msgs)


def test_check_inertia_massless_with_moments():
    J = np.zeros((4, 4))
    J[0, 3] = J[3, 0] = 0.5
    assert any("first moments" in s for s in mp.check_inertia(J))
    J = np.zeros((4, 4))
    J[1, 1] = 0.5
    assert any("moments of inertia" in s for s in mp.check_inertia(J))


# ------------------------------------------------------------------ primitive solids


def placed(m: float, I_local_diag, F: np.ndarray) -> np.ndarray:
    """Reference by hand: [[R Σ R^t + m p p^t, m p], [m p^t, m]]."""
    I = np.diag(I_local_diag)
    sig = 0.5 * np.trace(I) * np.eye(3) - I
    R, p = F[:3, :3], F[:3, 3]
    J = np.zeros((4, 4))
    J[:3, :3] = R @ sig @ R.T + m * np.outer(p, p)
    J[:3, 3] = J[3, :3] = m * p
    J[3, 3] = m
    return J


F1 = rigid(rotation(21), [1.5, -0.5, 2.0])


@pytest.mark.parametrize("F", [np.eye(4), F1])
def test_box(F):
    a, b, c, rho = 0.3, 0.5, 1.1, 7.8
    m = rho * a * b * c
    I = [m / 12 * (b**2 + c**2), m / 12 * (c**2 + a**2), m / 12 * (a**2 + b**2)]
    close(mp.box(a, b, c, rho, F), placed(m, I, F))


def test_box_default_frame_is_identity():
    close(mp.box(1.0, 2.0, 3.0, 2.0), mp.box(1.0, 2.0, 3.0, 2.0, np.eye(4)))


def test_box_matches_point_grid():
    """A box as a grid of equal point masses (2-point Gauss per cell, 8x8x8 points).

    Per axis, n cells of width h with two points at midpoint ± h/(2√3) integrate
    polynomials up to degree 3 exactly, so the point-mass sum is the exact J.
    """
    a, b, c, rho = 2.0, 1.0, 3.0, 1.5
    n = 4

    def nodes(L):
        h = L / n
        mids = -L / 2 + h * (np.arange(n) + 0.5)
        d = h / (2 * math.sqrt(3))
        return np.concatenate([mids - d, mids + d])

    X, Y, Z = np.meshgrid(nodes(a), nodes(b), nodes(c), indexing="ij")
    pts = np.stack([X.ravel(), Y.ravel(), Z.ravel()], axis=1)
    m = rho * a * b * c
    ms = np.full(len(pts), m / len(pts))
    xT = pts @ F1[:3, :3].T + F1[:3, 3]
    close(mp.box(a, b, c, rho, F1), cloud_J(ms, xT))


@pytest.mark.parametrize("F", [np.eye(4), F1])
def test_cylinder_and_disc(F):
    r, L, rho = 0.2, 1.3, 2.7
    m = rho * math.pi * r**2 * L
    Ix = m * (3 * r**2 + L**2) / 12
    ref = placed(m, [Ix, Ix, m * r**2 / 2], F)
    close(mp.cylinder(r, L, rho, F), ref)
    close(mp.disc(r, L, rho, F), ref)


@pytest.mark.parametrize("F", [np.eye(4), F1])
def test_tube(F):
    ro, ri, L, rho = 0.3, 0.25, 2.0, 7.85
    m = rho * math.pi * (ro**2 - ri**2) * L
    Ix = m * (3 * (ro**2 + ri**2) + L**2) / 12
    close(mp.tube(ro, ri, L, rho, F), placed(m, [Ix, Ix, m * (ro**2 + ri**2) / 2], F))
    close(mp.tube(ro, 0.0, L, rho, F), mp.cylinder(ro, L, rho, F))


@pytest.mark.parametrize("F", [np.eye(4), F1])
def test_rod(F):
    L, rho = 1.7, 0.9
    m = rho * L
    close(mp.rod(L, rho, F), placed(m, [m * L**2 / 12, m * L**2 / 12, 0.0], F))


@pytest.mark.parametrize("F", [np.eye(4), F1])
def test_sphere(F):
    r, rho = 0.4, 1000.0
    m = rho * 4 / 3 * math.pi * r**3
    I = 2 / 5 * m * r**2
    close(mp.sphere(r, rho, F), placed(m, [I, I, I], F))


def test_solid_centroidal_values():
    m_, c, I = mp.centroidal(mp.cylinder(0.2, 1.3, 2.7, F1))
    m = 2.7 * math.pi * 0.04 * 1.3
    assert abs(m_ - m) <= EXACT * m
    close(c, F1[:3, 3])
    R = F1[:3, :3]
    Ix = m * (3 * 0.04 + 1.69) / 12
    close(R.T @ I @ R, np.diag([Ix, Ix, m * 0.04 / 2]), rel=1e-11)


# ------------------------------------------------------------------ errors


@pytest.mark.parametrize(
    "call, words",
    [
        (lambda: mp.pseudo_inertia(-1.0, [0, 0, 0]), "mass must not be negative"),
        (lambda: mp.pseudo_inertia(float("nan"), [0, 0, 0]), "finite"),
        (lambda: mp.pseudo_inertia(1.0, [0, 0]), "centre of mass"),
        (lambda: mp.pseudo_inertia(1.0, [0, 0, math.inf]), "finite"),
        (lambda: mp.pseudo_inertia(1.0, [0, 0, 0], [1, 2]), "3 principal moments or a 3x3"),
        (
            lambda: mp.pseudo_inertia(1.0, [0, 0, 0], [[1, 0.1, 0], [0, 1, 0], [0, 0, 1]]),
            "symmetric",
        ),
        (lambda: mp.pseudo_inertia(1.0, [0, 0, 0], [1, 1, 1], axes=2 * np.eye(3)), "rotation"),
        (
            lambda: mp.pseudo_inertia(1.0, [0, 0, 0], [1, 1, 1], axes=np.diag([1, 1, -1])),
            "determinant",
        ),
        (lambda: mp.pseudo_inertia(1.0, [0, 0, 0], [1, 1, 1], about="origin"), "origin"),
        (lambda: mp.pseudo_inertia(1.0, [0, 0, 0], [1, 1, 1], about="joint"), "about must"),
        (lambda: mp.pseudo_inertia(1.0, [0, 0, 0], [1, 1, 1], origin=[1, 0, 0]), "origin"),
        (lambda: mp.box(0.0, 1.0, 1.0, 1.0), "box edge a must be > 0, got 0.0"),
        (lambda: mp.box(1.0, 1.0, 1.0, -2.0), "density must be > 0, got -2.0"),
        (lambda: mp.cylinder(1.0, math.nan, 1.0), "cylinder length"),
        (lambda: mp.tube(1.0, 1.0, 1.0, 1.0), "inner radius"),
        (lambda: mp.tube(1.0, -0.1, 1.0, 1.0), "inner radius"),
        (lambda: mp.rod(-1.0, 1.0), "rod length"),
        (lambda: mp.disc(1.0, 0.0, 1.0), "disc thickness"),
        (lambda: mp.sphere(1.0, 1.0, np.eye(3)), "frame"),
        (lambda: mp.sphere(1.0, 1.0, rigid(2 * np.eye(3), [0, 0, 0])), "rotation"),
        (lambda: mp.transform(np.eye(3), np.eye(4)), "pseudo-inertia"),
        (lambda: mp.check_inertia(np.full((4, 4), np.nan)), "finite"),
        (lambda: mp.units("furlong"), "in-lbm"),
    ],
)
def test_errors(call, words):
    with pytest.raises(InputError) as exc:
        call()
    assert words in str(exc.value)


# ------------------------------------------------------------------ units


def test_unit_presets():
    assert mp.units("si") is mp.UNITS["SI"]
    assert mp.units("SI").g == 9.80665 and mp.units("SI").mass == "kg"
    assert mp.units("MM-n-S").g == pytest.approx(9806.65, rel=EXACT)
    assert mp.units("imp") is mp.UNITS["in-lbm"]
    lbm = mp.units("in-lbm")
    assert lbm.g == pytest.approx(386.088, rel=2e-6)
    assert lbm.mass_factor * lbm.g == pytest.approx(1.0, rel=EXACT)
    # 1 lbm = 0.45359237 kg; 1 lbf s²/in = 4.4482216152605 N / 0.0254 m per s² = 175.1268 kg
    assert lbm.mass_factor * 4.4482216152605 / 0.0254 == pytest.approx(0.45359237, rel=1e-12)
    assert mp.units("ft-lbf-s").g == pytest.approx(32.174, rel=2e-6)
    assert mp.units("in-lbf-s").mass_factor == 1.0
    u = mp.units("in-lbf-s")
    assert mp.units(u) is u
    assert u.labels() == {
        "length": "in",
        "force": "lbf",
        "mass": "lbf s^2/in",
        "time": "s",
        "moment": "lbf in",
        "energy": "lbf in",
        "angle": "rad",
    }
    assert mp.units("SI").labels()["moment"] == "N m"
    with pytest.raises(AttributeError):
        u.g = 1.0  # type: ignore[misc]
