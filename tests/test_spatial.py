"""Tests of openimp.spatial (book chapter 3 and §4.4).

Tolerances: 1e-12 (absolute, on O(1) quantities) where the result is exact in
exact arithmetic; the book's printed values are compared at the number of
digits printed (about 5e-6 for 6 significant digits); Example 3.1 / P3.7 use
2e-3 because the book rounded its data to 3 decimals (digest §8.2).
"""

from __future__ import annotations

import numpy as np
import pytest

from openimp import spatial as sp
from openimp.errors import InputError

EXACT = 1e-12


def rng(seed: int = 0) -> np.random.Generator:
    return np.random.default_rng(seed)


def random_rotations(n: int, seed: int = 0) -> np.ndarray:
    g = rng(seed)
    q = g.normal(size=(n, 4))
    return sp.er_to_rotation(q)


def random_transforms(n: int, seed: int = 0) -> np.ndarray:
    g = rng(seed + 100)
    return sp.transform(random_rotations(n, seed), g.uniform(-5, 5, size=(n, 3)))


def assert_rotation(R: np.ndarray, tol: float = EXACT) -> None:
    R = np.asarray(R)[..., :3, :3]
    eye = np.broadcast_to(np.eye(3), R.shape)
    np.testing.assert_allclose(np.swapaxes(R, -1, -2) @ R, eye, atol=tol)
    np.testing.assert_allclose(np.linalg.det(R), 1.0, atol=tol)


def Rx3(a: float) -> np.ndarray:
    return sp.rot_x(a)[:3, :3]


def Ry3(a: float) -> np.ndarray:
    return sp.rot_y(a)[:3, :3]


def Rz3(a: float) -> np.ndarray:
    return sp.rot_z(a)[:3, :3]


# The digest §8.5 matrices of problems P3.3 and P3.4.
def p33_matrix() -> np.ndarray:
    i1 = np.array([0.0, 1.0, 1.0]) / np.sqrt(2.0)
    j1 = np.array([1.0, -1.0, 1.0]) / np.sqrt(3.0)
    return np.stack([i1, j1, np.cross(i1, j1)], axis=-1)


def p34_matrix() -> np.ndarray:
    # j2, k2 given in frame 1: Θ12 = [i2 j2 k2], Θ21 = Θ12ᵗ.
    j2 = np.array([0.0, 1.0, 1.0]) / np.sqrt(2.0)
    k2 = np.array([1.0, -1.0, 1.0]) / np.sqrt(3.0)
    return np.stack([np.cross(j2, k2), j2, k2], axis=-1).T


# --------------------------------------------------------------------------- basics


class TestBasics:
    def test_skew_cross(self) -> None:
        g = rng(1)
        a, b = g.normal(size=(2, 7, 3))
        np.testing.assert_allclose(
            np.einsum("nij,nj->ni", sp.skew(a), b), np.cross(a, b), atol=EXACT
        )
        S = sp.skew(a)
        np.testing.assert_array_equal(S, -np.swapaxes(S, -1, -2))
        np.testing.assert_array_equal(sp.unskew(S), a)

    def test_skew_explicit(self) -> None:
        np.testing.assert_array_equal(
            sp.skew([1.0, 2.0, 3.0]), [[0, -3, 2], [3, 0, -1], [-2, 1, 0]]
        )

    def test_skew_batch_shape(self) -> None:
        assert sp.skew(np.zeros((2, 5, 3))).shape == (2, 5, 3, 3)
        assert sp.unskew(np.zeros((2, 5, 4, 4))).shape == (2, 5, 3)

    def test_elementary_rotations(self) -> None:
        c, s = np.cos(0.3), np.sin(0.3)
        np.testing.assert_allclose(
            sp.rot_x(0.3), [[1, 0, 0, 0], [0, c, -s, 0], [0, s, c, 0], [0, 0, 0, 1]], atol=EXACT
        )
        np.testing.assert_allclose(
            sp.rot_y(0.3), [[c, 0, s, 0], [0, 1, 0, 0], [-s, 0, c, 0], [0, 0, 0, 1]], atol=EXACT
        )
        np.testing.assert_allclose(
            sp.rot_z(0.3), [[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]], atol=EXACT
        )

    @pytest.mark.parametrize("f", [sp.rot_x, sp.rot_y, sp.rot_z])
    def test_elementary_batch_orthogonal(self, f) -> None:
        a = rng(2).uniform(-7, 7, size=(3, 4))
        T = f(a)
        assert T.shape == (3, 4, 4, 4)
        assert_rotation(T)
        np.testing.assert_array_equal(T[..., 3, :], np.broadcast_to([0, 0, 0, 1.0], (3, 4, 4)))
        np.testing.assert_allclose(T @ f(-a), np.broadcast_to(np.eye(4), T.shape), atol=EXACT)

    def test_transform_translation(self) -> None:
        R = random_rotations(1, 3)[0]
        p = np.array([1.0, -2.0, 3.0])
        T = sp.transform(R, p)
        np.testing.assert_array_equal(T[:3, :3], R)
        np.testing.assert_array_equal(T[:3, 3], p)
        np.testing.assert_array_equal(T[3], [0, 0, 0, 1])
        np.testing.assert_array_equal(sp.translation(p)[:3, 3], p)
        np.testing.assert_array_equal(sp.translation(p)[:3, :3], np.eye(3))
        assert sp.translation(np.zeros((4, 2, 3))).shape == (4, 2, 4, 4)
        # batch broadcast of R (n, 3, 3) against a single p
        assert sp.transform(random_rotations(5), p).shape == (5, 4, 4)

    def test_inverse_round_trip(self) -> None:
        T = random_transforms(20, 4)
        Ti = sp.inverse(T)
        eye = np.broadcast_to(np.eye(4), T.shape)
        np.testing.assert_allclose(T @ Ti, eye, atol=EXACT)
        np.testing.assert_allclose(Ti @ T, eye, atol=EXACT)
        np.testing.assert_allclose(Ti, np.linalg.inv(T), atol=EXACT)
        np.testing.assert_allclose(sp.inverse(Ti), T, atol=EXACT)

    def test_p35_approach_orientation(self) -> None:
        # P3.5: u = approach, v = orientation, w = u × v.
        u, v = np.array([1.0, 0, 0]), np.array([0.0, 0, 1])
        T = sp.transform(np.stack([u, v, np.cross(u, v)], axis=-1), [500.0, 150, 225])
        np.testing.assert_array_equal(
            T, [[1, 0, 0, 500], [0, 0, -1, 150], [0, 1, 0, 225], [0, 0, 0, 1]]
        )
        assert np.linalg.det(T) == pytest.approx(1.0, abs=EXACT)  # P3.6

    def test_shape_errors(self) -> None:
        with pytest.raises(InputError):
            sp.skew([1.0, 2.0])
        with pytest.raises(InputError):
            sp.inverse(np.eye(3))
        with pytest.raises(InputError):
            sp.rotation_to_er(np.eye(2))


# --------------------------------------------------------------------------- Rodrigues / screw


class TestRodrigues:
    def test_p311(self) -> None:
        # P3.11: 60° about [3, 4, 0] (non-unit axis).
        R = sp.rotation_about([3.0, 4.0, 0.0], np.radians(60.0))
        s3 = np.sqrt(3.0)
        expected = [[0.68, 0.24, 0.4 * s3], [0.24, 0.82, -0.3 * s3], [-0.4 * s3, 0.3 * s3, 0.5]]
        np.testing.assert_allclose(R, expected, atol=EXACT)
        np.testing.assert_allclose(
            R,
            [[0.68, 0.24, 0.69282], [0.24, 0.82, -0.519615], [-0.69282, 0.519615, 0.5]],
            atol=5e-6,
        )
        assert_rotation(R)

    def test_elementwise_340(self) -> None:
        g = rng(5)
        for _ in range(5):
            w = g.normal(size=3)
            w /= np.linalg.norm(w)
            th = g.uniform(-np.pi, np.pi)
            s, v = np.sin(th), 1 - np.cos(th)
            x, y, z = w
            expected = [
                [(x * x - 1) * v + 1, y * x * v - z * s, z * x * v + y * s],
                [x * y * v + z * s, (y * y - 1) * v + 1, z * y * v - x * s],
                [x * z * v - y * s, y * z * v + x * s, (z * z - 1) * v + 1],
            ]
            np.testing.assert_allclose(sp.rotation_about(w, th), expected, atol=EXACT)

    def test_coordinate_axes(self) -> None:
        a = 0.7
        np.testing.assert_allclose(sp.rotation_about([2.0, 0, 0], a), Rx3(a), atol=EXACT)
        np.testing.assert_allclose(sp.rotation_about([0, 0.5, 0], a), Ry3(a), atol=EXACT)
        np.testing.assert_allclose(sp.rotation_about([0, 0, 9.0], a), Rz3(a), atol=EXACT)

    def test_batch_and_orthogonal(self) -> None:
        g = rng(6)
        axes = g.normal(size=(4, 3, 3))
        angles = g.uniform(-4, 4, size=(4, 3))
        R = sp.rotation_about(axes, angles)
        assert R.shape == (4, 3, 3, 3)
        assert_rotation(R)
        # the axis is invariant
        np.testing.assert_allclose(np.einsum("...ij,...j->...i", R, axes), axes, atol=EXACT)

    def test_zero_axis_error(self) -> None:
        with pytest.raises(InputError, match="nonzero"):
            sp.rotation_about([0.0, 0.0, 0.0], 1.0)

    def test_screw_transform_matches_334(self) -> None:
        # (3.34) applied to random points vs the 4x4 (3.39).
        g = rng(7)
        w = g.normal(size=3)
        w /= np.linalg.norm(w)
        P = g.normal(size=3)
        th, phi = 1.1, -0.4
        T = sp.screw_transform(w, P, th, phi)
        R1 = g.normal(size=(6, 3))
        q = R1 - P
        R2 = (
            q * np.cos(th)
            + np.outer(q @ w, w) * (1 - np.cos(th))
            + np.cross(w, q) * np.sin(th)
            + P
            + phi * w
        )
        hom = np.hstack([R1, np.ones((6, 1))])
        np.testing.assert_allclose((hom @ T.T)[:, :3], R2, atol=EXACT)
        # (3.41) elementwise for d
        Th = T[:3, :3]
        d = phi * w - (Th - np.eye(3)) @ P
        np.testing.assert_allclose(T[:3, 3], d, atol=EXACT)
        assert_rotation(T)

    def test_screw_axis_points_fixed_up_to_slide(self) -> None:
        T = sp.screw_transform([0.0, 0, 2], [1.0, 2, 0], 0.9, 0.0)
        np.testing.assert_allclose(T @ [1.0, 2, 5, 1], [1.0, 2, 5, 1], atol=EXACT)


# --------------------------------------------------------------------------- Euler / Cardan


class TestEulerAngles:
    def test_zxz_product_and_elements(self) -> None:
        g = rng(8)
        for xi, th, ph in g.uniform(-np.pi, np.pi, size=(10, 3)):
            R = sp.euler_to_rotation(xi, th, ph)
            np.testing.assert_allclose(R, Rz3(xi) @ Rx3(th) @ Rz3(ph), atol=EXACT)
            sx, cx, st, ct, s, c = (
                np.sin(xi),
                np.cos(xi),
                np.sin(th),
                np.cos(th),
                np.sin(ph),
                np.cos(ph),
            )
            expected = [  # (3.44)
                [-sx * ct * s + cx * c, -sx * ct * c - cx * s, sx * st],
                [cx * ct * s + sx * c, cx * ct * c - sx * s, -cx * st],
                [st * s, st * c, ct],
            ]
            np.testing.assert_allclose(R, expected, atol=EXACT)
            # (3.45), corrected: Θ41 = Θ14ᵗ with (3,1) = sξ sϑ; determinant +1 (P3.8)
            assert R.T[2, 0] == pytest.approx(sx * st, abs=EXACT)
            assert_rotation(R)

    def test_cardan_product_and_elements(self) -> None:
        g = rng(9)
        for a, b, c_ in g.uniform(-np.pi, np.pi, size=(10, 3)):
            R = sp.rpy_to_rotation(a, b, c_)
            np.testing.assert_allclose(R, Rx3(a) @ Ry3(b) @ Rz3(c_), atol=EXACT)
            sa, ca, sb, cb, sg, cg = (
                np.sin(a),
                np.cos(a),
                np.sin(b),
                np.cos(b),
                np.sin(c_),
                np.cos(c_),
            )
            expected = [  # (3.46)
                [cb * cg, -cb * sg, sb],
                [sa * sb * cg + ca * sg, -sa * sb * sg + ca * cg, -sa * cb],
                [-ca * sb * cg + sa * sg, ca * sb * sg + sa * cg, ca * cb],
            ]
            np.testing.assert_allclose(R, expected, atol=EXACT)
            assert_rotation(R)

    def test_zyz_variant_corrected(self) -> None:
        # digest §3.7: z-y-z (3,1) entry is -sϑ cφ (book prints +).
        xi, th, ph = 0.3, 0.8, -1.2
        R = Rz3(xi) @ Ry3(th) @ Rz3(ph)
        assert R[2, 0] == pytest.approx(-np.sin(th) * np.cos(ph), abs=EXACT)

    def test_euler_round_trip_random(self) -> None:
        g = rng(10)
        n = 200
        xi = g.uniform(-np.pi, np.pi, n)
        th = g.uniform(0, np.pi, n)
        ph = g.uniform(-np.pi, np.pi, n)
        R = sp.euler_to_rotation(xi, th, ph)
        a, b, c = sp.rotation_to_euler(R)
        assert a.shape == b.shape == c.shape == (n,)
        np.testing.assert_allclose(b, th, atol=1e-9)
        np.testing.assert_allclose(a, xi, atol=1e-9)
        np.testing.assert_allclose(c, ph, atol=1e-9)
        np.testing.assert_allclose(sp.euler_to_rotation(a, b, c), R, atol=EXACT)
        # and from random rotations
        R = random_rotations(200, 11)
        a, b, c = sp.rotation_to_euler(R)
        assert np.all((b >= 0) & (b <= np.pi))
        np.testing.assert_allclose(sp.euler_to_rotation(a, b, c), R, atol=EXACT)

    @pytest.mark.parametrize("th", [0.0, np.pi, 1e-14, np.pi - 1e-14, 1e-7, np.pi - 1e-7])
    def test_euler_gimbal(self, th: float) -> None:
        R = sp.euler_to_rotation(0.4, th, 1.1)
        xi, theta, phi = sp.rotation_to_euler(R)
        np.testing.assert_allclose(sp.euler_to_rotation(xi, theta, phi), R, atol=EXACT)
        if np.sin(th) < 1e-12:
            assert phi == 0.0
            expected = 0.4 + 1.1 if th < 1 else 0.4 - 1.1  # all rotation in ξ
            assert xi == pytest.approx(expected, abs=EXACT)

    def test_euler_from_4x4_and_batch(self) -> None:
        T = random_transforms(6, 12).reshape(2, 3, 4, 4)
        xi, th, ph = sp.rotation_to_euler(T)
        assert xi.shape == (2, 3)
        np.testing.assert_allclose(sp.euler_to_rotation(xi, th, ph), T[..., :3, :3], atol=EXACT)

    def test_p39(self) -> None:
        xi, th, ph = np.degrees(sp.rotation_to_euler(p33_matrix()))
        assert (xi, th, ph) == pytest.approx((116.565, 114.095, 50.768), abs=1e-3)

    def test_rpy_round_trip_random(self) -> None:
        g = rng(13)
        n = 200
        a = g.uniform(-np.pi, np.pi, n)
        b = g.uniform(-np.pi / 2, np.pi / 2, n)
        c = g.uniform(-np.pi, np.pi, n)
        R = sp.rpy_to_rotation(a, b, c)
        a2, b2, c2 = sp.rotation_to_rpy(R)
        np.testing.assert_allclose(a2, a, atol=1e-9)
        np.testing.assert_allclose(b2, b, atol=1e-9)
        np.testing.assert_allclose(c2, c, atol=1e-9)
        R = random_rotations(200, 14)
        a, b, c = sp.rotation_to_rpy(R)
        assert np.all(np.abs(b) <= np.pi / 2)
        np.testing.assert_allclose(sp.rpy_to_rotation(a, b, c), R, atol=EXACT)

    @pytest.mark.parametrize("b", [np.pi / 2, -np.pi / 2, np.pi / 2 - 1e-9, -np.pi / 2 + 1e-15])
    def test_rpy_gimbal(self, b: float) -> None:
        R = sp.rpy_to_rotation(0.5, b, -0.2)
        a2, b2, c2 = sp.rotation_to_rpy(R)
        np.testing.assert_allclose(sp.rpy_to_rotation(a2, b2, c2), R, atol=EXACT)
        if np.cos(b) <= 1e-12:
            assert c2 == 0.0
            assert a2 == pytest.approx(0.5 - 0.2 if b > 0 else 0.5 + 0.2, abs=1e-9)

    def test_p310(self) -> None:
        a, b, c = np.degrees(sp.rotation_to_rpy(p34_matrix()))
        assert (a, b, c) == pytest.approx((-50.768, -24.095, -26.565), abs=1e-3)


# --------------------------------------------------------------------------- direction cosines


class TestDirectionCosines:
    def test_p33(self) -> None:
        expected = [
            [0, 0.57735, 0.816497],
            [0.707107, -0.57735, 0.408248],
            [0.707107, 0.57735, -0.408248],
        ]
        np.testing.assert_allclose(p33_matrix(), expected, atol=5e-6)
        assert_rotation(p33_matrix())

    def test_p34(self) -> None:
        expected = [
            [0.816497, 0.408248, -0.408248],
            [0, 0.707107, 0.707107],
            [0.57735, -0.57735, 0.57735],
        ]
        np.testing.assert_allclose(p34_matrix(), expected, atol=5e-6)
        assert_rotation(p34_matrix())


# --------------------------------------------------------------------------- Euler-Rodrigues


class TestEulerRodrigues:
    def test_example_3_2(self) -> None:
        R = np.array([[0.0, 1, 0], [0, 0, -1], [-1, 0, 0]])
        e = sp.rotation_to_er(R)
        np.testing.assert_allclose(e, [0.5, 0.5, -0.5, 0.5], atol=EXACT)
        w, th = sp.er_to_axis_angle(e)
        assert np.degrees(th) == pytest.approx(120.0, abs=1e-10)
        np.testing.assert_allclose(w, np.array([1, 1, -1]) / np.sqrt(3), atol=EXACT)
        np.testing.assert_allclose(sp.er_to_rotation(e), R, atol=EXACT)

    def test_example_3_3(self) -> None:
        R = np.diag([-1.0, -1.0, 1.0])
        e = sp.rotation_to_er(R)
        np.testing.assert_array_equal(e, [0.0, 0.0, 1.0, 0.0])
        w, th = sp.er_to_axis_angle(e)
        assert th == pytest.approx(np.pi, abs=EXACT)
        np.testing.assert_allclose(w, [0, 0, 1], atol=EXACT)

    def test_p312(self) -> None:
        e = sp.rotation_to_er(p33_matrix())
        np.testing.assert_allclose(e, [0.704556, 0.455768, 0.540625, 0.060003], atol=2e-6)
        _, th = sp.er_to_axis_angle(e)
        assert np.degrees(th) == pytest.approx(173.12, abs=5e-3)
        np.testing.assert_allclose(sp.er_to_rotation(e), p33_matrix(), atol=EXACT)

    def test_explicit_350(self) -> None:
        g = rng(15)
        e = g.normal(size=4)
        e /= np.linalg.norm(e)
        e1, e2, e3, e4 = e
        expected = [
            [e1**2 - e2**2 - e3**2 + e4**2, 2 * e1 * e2 - 2 * e3 * e4, 2 * e1 * e3 + 2 * e2 * e4],
            [
                2 * e1 * e2 + 2 * e3 * e4,
                -(e1**2) + e2**2 - e3**2 + e4**2,
                2 * e2 * e3 - 2 * e1 * e4,
            ],
            [
                2 * e1 * e3 - 2 * e2 * e4,
                2 * e2 * e3 + 2 * e1 * e4,
                -(e1**2) - e2**2 + e3**2 + e4**2,
            ],
        ]
        np.testing.assert_allclose(sp.er_to_rotation(e), expected, atol=EXACT)
        # normalisation: any nonzero multiple gives the same rotation
        np.testing.assert_allclose(sp.er_to_rotation(3.7 * e), expected, atol=EXACT)

    def test_er_equals_rodrigues(self) -> None:
        g = rng(16)
        axes = g.normal(size=(50, 3))
        angles = g.uniform(-2 * np.pi, 2 * np.pi, 50)
        np.testing.assert_allclose(
            sp.er_to_rotation(sp.axis_angle_to_er(axes, angles)),
            sp.rotation_about(axes, angles),
            atol=EXACT,
        )

    def test_round_trip_random(self) -> None:
        g = rng(17)
        e = g.normal(size=(500, 4))
        e /= np.linalg.norm(e, axis=-1, keepdims=True)
        e *= np.sign(e[:, 3:])
        R = sp.er_to_rotation(e)
        e2 = sp.rotation_to_er(R)
        assert e2.shape == (500, 4)
        np.testing.assert_allclose(e2, e, atol=EXACT)
        np.testing.assert_allclose(sp.er_to_rotation(e2), R, atol=EXACT)
        np.testing.assert_allclose(np.linalg.norm(e2, axis=-1), 1.0, atol=EXACT)

    @pytest.mark.parametrize("deg", [180.0, 179.9999, 180.0001, 179.999, 179.0, 120.0, 1e-6, 0.0])
    def test_near_180_random_axes(self, deg: float) -> None:
        g = rng(int(deg * 1000) % 1000 + 18)
        axes = g.normal(size=(100, 3))
        axes[:3] = np.eye(3)  # coordinate axes too
        R = sp.rotation_about(axes, np.radians(deg))
        e = sp.rotation_to_er(R)
        np.testing.assert_allclose(sp.er_to_rotation(e), R, atol=EXACT)
        assert np.all(e[:, 3] >= 0.0)
        w, th = sp.er_to_axis_angle(e)
        expected_th = np.radians(deg if deg <= 180 else 360 - deg)
        np.testing.assert_allclose(th, expected_th, atol=1e-9)
        if 0 < deg < 180:
            u = axes / np.linalg.norm(axes, axis=-1, keepdims=True)
            np.testing.assert_allclose(w, u, atol=1e-9)

    def test_exact_180_about_axes(self) -> None:
        for k in range(3):
            R = np.diag([-1.0, -1.0, -1.0])
            R[k, k] = 1.0
            e = sp.rotation_to_er(R)
            np.testing.assert_array_equal(e, np.eye(4)[k])

    def test_identity(self) -> None:
        np.testing.assert_array_equal(sp.rotation_to_er(np.eye(3)), [0, 0, 0, 1])
        w, th = sp.er_to_axis_angle([0.0, 0, 0, 1])
        assert th == 0.0
        np.testing.assert_array_equal(w, [0, 0, 1])

    def test_eps_forces_case_2(self) -> None:
        # with a large threshold the book's Case 2 runs also for small angles
        R = sp.rotation_about([1.0, 2.0, 3.0], 2.0)
        e1 = sp.rotation_to_er(R)
        e2 = sp.rotation_to_er(R, eps=0.9)
        np.testing.assert_allclose(e1, e2, atol=EXACT)

    def test_axis_angle_round_trip(self) -> None:
        g = rng(19)
        axes = g.normal(size=(40, 3))
        axes /= np.linalg.norm(axes, axis=-1, keepdims=True)
        angles = g.uniform(1e-3, 2 * np.pi - 1e-3, 40)
        w, th = sp.er_to_axis_angle(sp.axis_angle_to_er(axes, angles))
        np.testing.assert_allclose(w, axes, atol=EXACT)
        np.testing.assert_allclose(th, angles, atol=EXACT)
        # non-unit axis and broadcast of a single angle
        e = sp.axis_angle_to_er([[0.0, 0, 5], [2.0, 0, 0]], np.pi / 2)
        h = np.sqrt(0.5)
        np.testing.assert_allclose(e, [[0, 0, h, h], [h, 0, 0, h]], atol=EXACT)

    def test_from_4x4_batch(self) -> None:
        T = random_transforms(12, 20).reshape(3, 4, 4, 4)
        e = sp.rotation_to_er(T)
        assert e.shape == (3, 4, 4)
        np.testing.assert_allclose(sp.er_to_rotation(e), T[..., :3, :3], atol=EXACT)

    def test_errors(self) -> None:
        with pytest.raises(InputError):
            sp.er_to_rotation([0.0, 0, 0, 0])
        with pytest.raises(InputError):
            sp.axis_angle_to_er([0.0, 0, 0], 1.0)


# --------------------------------------------------------------------------- quaternions


class TestQuaternions:
    def test_units(self) -> None:
        i, j, k, one = np.eye(4)
        m = sp.quat_multiply
        np.testing.assert_array_equal(m(i, j), k)
        np.testing.assert_array_equal(m(j, k), i)
        np.testing.assert_array_equal(m(k, i), j)
        np.testing.assert_array_equal(m(j, i), -k)
        np.testing.assert_array_equal(m(k, j), -i)
        np.testing.assert_array_equal(m(i, k), -j)
        for u in (i, j, k):
            np.testing.assert_array_equal(m(u, u), -one)
        np.testing.assert_array_equal(m(one, i), i)

    def test_product_matches_matrix_product(self) -> None:
        g = rng(21)
        p = g.normal(size=(50, 4))
        q = g.normal(size=(50, 4))
        np.testing.assert_allclose(
            sp.quat_to_rotation(sp.quat_multiply(p, q)),
            sp.quat_to_rotation(p) @ sp.quat_to_rotation(q),
            atol=EXACT,
        )

    def test_norm_conjugate_inverse(self) -> None:
        g = rng(22)
        q = g.normal(size=(10, 4))
        n2 = np.sum(q * q, axis=-1)
        qq = sp.quat_multiply(q, sp.quat_conjugate(q))  # (3.60)
        np.testing.assert_allclose(qq[:, :3], 0.0, atol=EXACT)
        np.testing.assert_allclose(qq[:, 3], n2, rtol=EXACT)
        one = np.broadcast_to([0, 0, 0, 1.0], q.shape)
        np.testing.assert_allclose(sp.quat_multiply(q, sp.quat_inverse(q)), one, atol=EXACT)
        np.testing.assert_allclose(sp.quat_multiply(sp.quat_inverse(q), q), one, atol=EXACT)
        with pytest.raises(InputError):
            sp.quat_inverse([0.0, 0, 0, 0])

    def test_rotate(self) -> None:
        g = rng(23)
        q = g.normal(size=(30, 4))
        v = g.normal(size=(30, 3))
        expected = np.einsum("nij,nj->ni", sp.quat_to_rotation(q), v)
        np.testing.assert_allclose(sp.quat_rotate(q, v), expected, atol=EXACT)
        # as q v q⁻¹ with v a pure quaternion
        vq = np.concatenate([v, np.zeros((30, 1))], axis=-1)
        r = sp.quat_multiply(sp.quat_multiply(q, vq), sp.quat_inverse(q))
        np.testing.assert_allclose(r[:, :3], expected, atol=EXACT)
        np.testing.assert_allclose(r[:, 3], 0.0, atol=EXACT)

    def test_rotation_to_quat(self) -> None:
        R = random_rotations(30, 24)
        q = sp.rotation_to_quat(R)
        np.testing.assert_array_equal(q, sp.rotation_to_er(R))
        np.testing.assert_allclose(sp.quat_to_rotation(q), R, atol=EXACT)
        # (3.62): unit quaternion of θ about w equals the ER vector
        np.testing.assert_allclose(
            sp.rotation_to_quat(sp.rotation_about([0.0, 0, 1], 0.5)),
            [0, 0, np.sin(0.25), np.cos(0.25)],
            atol=EXACT,
        )


# --------------------------------------------------------------------------- Chasles


class TestScrew:
    def test_round_trip_random(self) -> None:
        T = random_transforms(300, 25)
        w, P, th, d = sp.transform_to_screw(T)
        assert w.shape == P.shape == (300, 3)
        assert th.shape == d.shape == (300,)
        np.testing.assert_allclose(np.linalg.norm(w, axis=-1), 1.0, atol=EXACT)
        np.testing.assert_allclose(np.sum(w * P, axis=-1), 0.0, atol=1e-10)
        assert np.all((th >= 0) & (th <= np.pi))
        np.testing.assert_allclose(sp.screw_to_transform(w, P, th, d), T, atol=1e-10)

    def test_forward_backward(self) -> None:
        w0 = np.array([1.0, 2.0, 2.0]) / 3.0
        P0 = np.array([2.0, -1.0, 0.0])  # P0 · w0 = 0: closest to the origin
        T = sp.screw_to_transform(w0, P0, 1.3, 0.75)
        w, P, th, d = sp.transform_to_screw(T)
        np.testing.assert_allclose(w, w0, atol=EXACT)
        np.testing.assert_allclose(P, P0, atol=EXACT)
        assert th == pytest.approx(1.3, abs=EXACT)
        assert d == pytest.approx(0.75, abs=EXACT)

    def test_pure_translation(self) -> None:
        w, P, th, d = sp.transform_to_screw(sp.translation([0.0, 3.0, 4.0]))
        np.testing.assert_allclose(w, [0, 0.6, 0.8], atol=EXACT)
        np.testing.assert_array_equal(P, [0, 0, 0])
        assert th == 0.0
        assert d == pytest.approx(5.0, abs=EXACT)
        w, P, th, d = sp.transform_to_screw(np.eye(4))
        np.testing.assert_array_equal(w, [0, 0, 1])
        assert th == 0.0 and d == 0.0

    def test_half_turn(self) -> None:
        T = sp.screw_to_transform([0.0, 1.0, 0.0], [1.0, 0.0, 2.0], np.pi, -0.5)
        w, P, th, d = sp.transform_to_screw(T)
        assert th == pytest.approx(np.pi, abs=EXACT)
        np.testing.assert_allclose(P, [1.0, 0.0, 2.0], atol=EXACT)
        np.testing.assert_allclose(sp.screw_to_transform(w, P, th, d), T, atol=EXACT)

    def test_pure_rotation_about_origin_axis(self) -> None:
        w, P, th, d = sp.transform_to_screw(sp.rot_x(-0.4))
        np.testing.assert_allclose(w, [-1, 0, 0], atol=EXACT)
        assert th == pytest.approx(0.4, abs=EXACT)
        np.testing.assert_allclose(P, 0.0, atol=EXACT)
        assert d == pytest.approx(0.0, abs=EXACT)


# --------------------------------------------------------------------------- Plücker


class TestPlucker:
    def test_from_points_corrected_sign(self) -> None:
        # digest §9 item 4 example: p1 = (1,0,0), p2 = (1,1,0).
        L = sp.plucker_from_points([1.0, 0, 0], [1.0, 1, 0])
        np.testing.assert_array_equal(L, [0, 0, 1, 0, 1, 0])
        for lam in (-2.0, 0.0, 3.5):
            assert sp.plucker_point(L, lam)[0] == pytest.approx(1.0, abs=EXACT)
        np.testing.assert_allclose(sp.plucker_point(L), [1, 0, 0], atol=EXACT)

    def test_homogeneous_points(self) -> None:
        a = np.array([1.0, 2.0, 3.0])
        b = np.array([-1.0, 0.5, 2.0])
        L = sp.plucker_from_points(a, b)
        L2 = sp.plucker_from_points(np.append(2 * a, 2.0), np.append(3 * b, 3.0))
        np.testing.assert_allclose(L2 / 6.0, L, atol=EXACT)
        # point at infinity = direction
        L3 = sp.plucker_from_points(np.append(a, 1.0), np.append(b - a, 0.0))
        np.testing.assert_allclose(L3, L, atol=EXACT)

    def test_identity_and_points(self) -> None:
        g = rng(26)
        p1, p2 = g.normal(size=(2, 20, 3))
        L = sp.plucker_from_points(p1, p2)
        m, d = L[:, :3], L[:, 3:]
        np.testing.assert_allclose(np.sum(m * d, axis=-1), 0.0, atol=EXACT)  # (3.8)
        np.testing.assert_allclose(d, p2 - p1, atol=EXACT)
        np.testing.assert_allclose(L, sp.plucker_from_point_direction(p1, p2 - p1), atol=EXACT)
        # the points with λ = 0 and λ = 1 lie on the line through p1, p2
        for lam in (0.0, 1.0):
            r = sp.plucker_point(L, lam)
            np.testing.assert_allclose(np.cross(r - p1, p2 - p1), 0.0, atol=1e-10)
        r0 = sp.plucker_point(L)
        np.testing.assert_allclose(np.sum(r0 * d, axis=-1), 0.0, atol=1e-10)
        # (3.10) scalar form
        a, b, c = m.T
        dd, e, f = d.T
        s = dd**2 + e**2 + f**2
        lam = 0.7
        x = np.stack([e * c - f * b, f * a - dd * c, dd * b - e * a], -1) + lam * d * s[:, None]
        np.testing.assert_allclose(x / s[:, None], sp.plucker_point(L, lam), atol=1e-10)

    def test_displace_matches_points_and_similarity(self) -> None:
        g = rng(27)
        T = random_transforms(10, 28)
        p1, p2 = g.normal(size=(2, 10, 3))
        L = sp.plucker_from_points(p1, p2)
        LT = sp.plucker_displace(T, L)

        def apply(T, p):
            return np.einsum("nij,nj->ni", T[:, :3, :3], p) + T[:, :3, 3]

        np.testing.assert_allclose(
            LT, sp.plucker_from_points(apply(T, p1), apply(T, p2)), atol=1e-10
        )

        # (3.56): [[Ω̂̃, Ω], [0, 0]] = T [[σ̂̃, σ], [0, 0]] T⁻¹
        def line_matrix(L):
            M = np.zeros((*L.shape[:-1], 4, 4))
            M[..., :3, :3] = sp.skew(L[..., 3:])
            M[..., :3, 3] = L[..., :3]
            return M

        np.testing.assert_allclose(line_matrix(LT), T @ line_matrix(L) @ sp.inverse(T), atol=1e-10)

    def test_distance(self) -> None:
        # x axis and the line parallel to y through (0, 0, 2): distance 2
        L1 = sp.plucker_from_point_direction([0.0, 0, 0], [3.0, 0, 0])
        L2 = sp.plucker_from_point_direction([5.0, 1, 2], [0.0, -2, 0])
        assert sp.plucker_distance(L1, L2) == pytest.approx(2.0, abs=EXACT)
        # parallel lines
        L3 = sp.plucker_from_point_direction([1.0, 3, 4], [-1.0, 0, 0])
        assert sp.plucker_distance(L1, L3) == pytest.approx(5.0, abs=EXACT)
        assert sp.plucker_distance(L1, L1) == pytest.approx(0.0, abs=EXACT)
        # intersecting
        L4 = sp.plucker_from_points([2.0, 0, 0], [2.0, 1, 1])
        assert sp.plucker_distance(L1, L4) == pytest.approx(0.0, abs=EXACT)

    def test_distance_random_invariant(self) -> None:
        g = rng(29)
        L1 = sp.plucker_from_points(*g.normal(size=(2, 15, 3)))
        L2 = sp.plucker_from_points(*g.normal(size=(2, 15, 3)))
        dist = sp.plucker_distance(L1, L2)
        # brute force: closest points via least squares
        r1, d1 = sp.plucker_point(L1), L1[:, 3:]
        r2, d2 = sp.plucker_point(L2), L2[:, 3:]
        for n in range(15):
            A = np.stack([d1[n], -d2[n]], axis=-1)
            st = np.linalg.lstsq(A, r2[n] - r1[n], rcond=None)[0]
            gap = r1[n] + st[0] * d1[n] - r2[n] - st[1] * d2[n]
            assert dist[n] == pytest.approx(np.linalg.norm(gap), abs=1e-10)
        T = random_transforms(15, 30)
        np.testing.assert_allclose(
            sp.plucker_distance(sp.plucker_displace(T, L1), sp.plucker_displace(T, L2)),
            dist,
            atol=1e-10,
        )

    def test_errors(self) -> None:
        with pytest.raises(InputError, match="coincide"):
            sp.plucker_from_points([1.0, 2, 3], [1.0, 2, 3])
        with pytest.raises(InputError):
            sp.plucker_from_point_direction([1.0, 2, 3], [0.0, 0, 0])
        with pytest.raises(InputError):
            sp.plucker_point(np.zeros(6))


# --------------------------------------------------------------------------- frames from points


class TestFrameFromPoints:
    def test_exact_frame(self) -> None:
        T0 = random_transforms(1, 31)[0]
        p1 = T0[:3, 3]
        p2 = p1 + 2.5 * T0[:3, 2]
        p3 = p1 + 0.7 * T0[:3, 0]
        np.testing.assert_allclose(sp.frame_from_points(p1, p2, p3), T0, atol=EXACT)

    def test_non_perpendicular_p3(self) -> None:
        # p3 anywhere in the +u half-plane (with a w component) gives the same frame
        T0 = random_transforms(1, 32)[0]
        p1 = T0[:3, 3]
        p2 = p1 + 1.5 * T0[:3, 2]
        p3 = p1 + 0.7 * T0[:3, 0] - 3.0 * T0[:3, 2]
        T = sp.frame_from_points(p1, p2, p3)
        np.testing.assert_allclose(T, T0, atol=EXACT)
        assert_rotation(T)

    def test_simple_values(self) -> None:
        T = sp.frame_from_points([1.0, 2, 3], [1.0, 2, 10], [4.0, 2, 3])
        np.testing.assert_allclose(T, sp.translation([1.0, 2, 3]), atol=EXACT)

    def test_batch(self) -> None:
        T0 = random_transforms(8, 33).reshape(2, 4, 4, 4)
        p1 = T0[..., :3, 3]
        T = sp.frame_from_points(p1, p1 + T0[..., :3, 2], p1 + T0[..., :3, 0] + T0[..., :3, 2])
        assert T.shape == (2, 4, 4, 4)
        np.testing.assert_allclose(T, T0, atol=EXACT)

    def test_errors(self) -> None:
        with pytest.raises(InputError, match="point 2"):
            sp.frame_from_points([1.0, 1, 1], [1.0, 1, 1], [2.0, 0, 0])
        with pytest.raises(InputError, match="point 3"):
            sp.frame_from_points([1.0, 1, 1], [1.0, 1, 2], [1.0, 1, 1])
        with pytest.raises(InputError, match="collinear"):
            sp.frame_from_points([0.0, 0, 0], [0.0, 0, 1], [0.0, 0, -3])
        with pytest.raises(InputError, match="batch index"):
            p1 = np.zeros((3, 3))
            p2 = np.array([[0.0, 0, 1]] * 3)
            p3 = np.array([[1.0, 0, 0], [0.0, 1, 0], [0.0, 0, 2]])
            sp.frame_from_points(p1, p2, p3)


# --------------------------------------------------------------------------- three points


class TestThreePoint:
    def test_exact_random(self) -> None:
        T0 = random_transforms(10, 34)
        g = rng(35)
        r = g.normal(size=(10, 3, 3))
        R = np.einsum("nij,nkj->nki", T0[:, :3, :3], r) + T0[:, None, :3, 3]
        T = sp.three_point_displacement(r, R)
        np.testing.assert_allclose(T, T0, atol=1e-10)
        # homogeneous rows with w ≠ 1
        rh = np.concatenate([2 * r, 2 * np.ones((10, 3, 1))], axis=-1)
        Rh = np.concatenate([R, np.ones((10, 3, 1))], axis=-1)
        np.testing.assert_allclose(sp.three_point_displacement(rh, Rh), T0, atol=1e-10)

    def test_example_3_1(self) -> None:
        r = [[0.0, 0, 0], [2.0, 0, 0], [0.0, 5, 0]]
        R = [[2.872, -4.757, 6.469], [1.493, -3.927, 5.281], [6.098, -1.137, 5.251]]
        T = sp.three_point_displacement(r, R)
        book = [
            [-0.68936, 0.64538, 0.32904, 2.87154],
            [0.41461, 0.72396, -0.55134, -4.75653],
            [-0.59404, -0.24366, -0.76668, 6.46932],
            [0, 0, 0, 1],
        ]
        np.testing.assert_allclose(T, book, atol=2e-3)
        assert_rotation(T, tol=2e-3)
        # R4 = T r4 with r4 = [0, 0, 10]
        np.testing.assert_allclose(T @ [0, 0, 10, 1], [6.162, -10.270, -1.197, 1], atol=5e-3)
        # r5 = [2, 5, 0] -> R5 and ΔR5 = (T - I) r5
        np.testing.assert_allclose(T @ [2, 5, 0, 1], [4.720, -0.308, 4.063, 1], atol=2e-3)
        np.testing.assert_allclose(
            (T - np.eye(4)) @ [2, 5, 0, 1], [2.720, -5.308, 4.063, 0], atol=2e-3
        )

    def test_p37(self) -> None:
        r = [[50.0, 0, 0], [0.0, 0, 0], [0.0, 125, 0]]
        R = [[37.325, -98.175, 132.045], [71.800, -118.925, 161.725], [152.450, -28.425, 131.225]]
        T = sp.three_point_displacement(r, R)
        expected = [
            [-0.6895, 0.6452, 0.3285, 71.800],
            [0.4150, 0.7240, -0.5512, -118.925],
            [-0.5936, -0.2440, -0.7670, 161.725],
        ]
        np.testing.assert_allclose(T[:3, :3], np.array(expected)[:, :3], atol=2e-3)
        np.testing.assert_allclose(T[:3, 3], [71.800, -118.925, 161.725], atol=1e-10)

    def test_collinear_error(self) -> None:
        r = [[0.0, 0, 0], [1.0, 1, 1], [2.0, 2, 2]]
        with pytest.raises(InputError, match="collinear"):
            sp.three_point_displacement(r, r)
