"""Plain-numpy geometry shared by the tests (no openimp code): 4x4 frames, circle
intersections, and the closed-form geometry of book example 5.1 and of the RSSR."""

from __future__ import annotations

import math

import numpy as np

DEG = math.pi / 180.0


def hom(R: np.ndarray | None = None, p=None) -> np.ndarray:
    T = np.eye(4)
    if R is not None:
        T[:3, :3] = R
    if p is not None:
        T[:3, 3] = p
    return T


def rot(axis, angle: float) -> np.ndarray:
    """Rodrigues' rotation matrix about ``axis`` by ``angle``."""
    k = np.asarray(axis, float)
    k = k / np.linalg.norm(k)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * K @ K


def frame(origin, w, u) -> np.ndarray:
    """Right-handed frame at ``origin`` with w along ``w`` and u toward ``u``."""
    w = np.asarray(w, float) / np.linalg.norm(w)
    u = np.asarray(u, float)
    u = u - (u @ w) * w
    u = u / np.linalg.norm(u)
    T = np.eye(4)
    T[:3, 0], T[:3, 1], T[:3, 2], T[:3, 3] = u, np.cross(w, u), w, origin
    return T


def circle_intersection(P1, r1, P2, r2, left: bool = True) -> np.ndarray:
    """Planar intersection of circle (P1, r1) and (P2, r2), left of P1->P2 or right."""
    P1, P2 = np.asarray(P1, float), np.asarray(P2, float)
    dv = P2 - P1
    L = np.linalg.norm(dv)
    x = (r1 * r1 - r2 * r2 + L * L) / (2 * L)
    y = math.sqrt(r1 * r1 - x * x)
    ex = dv / L
    ey = np.array([-ex[1], ex[0]])
    return P1 + x * ex + (y if left else -y) * ey


def e2(t):
    t = np.asarray(t, float)
    return np.stack([np.cos(t), np.sin(t)], -1)


def cardan_example_51(beta, d1, d2, h):
    """Shape matrices of book Example 5.1 (bodies 4 frame, 1 output shaft,
    2 cross, 3 input shaft; joints A 4->1, B 1->2, C 2->3, D 3->4)."""
    cb, sb = math.cos(beta), math.sin(beta)
    S = {
        ("4", "A"): np.array([[0, 0, 1, d1], [1, 0, 0, h], [0, 1, 0, 0], [0, 0, 0, 1.0]]),
        ("1", "A"): np.array([[0, 0, 1, d1], [0, -1, 0, 0], [1, 0, 0, 0], [0, 0, 0, 1.0]]),
        ("1", "B"): np.array([[0, 1, 0, 0], [0, 0, 1, 0], [1, 0, 0, 0], [0, 0, 0, 1.0]]),
        ("2", "B"): np.eye(4),
        ("2", "C"): np.array([[0, 1, 0, 0], [0, 0, 1, 0], [1, 0, 0, 0], [0, 0, 0, 1.0]]),
        ("3", "C"): np.array([[0, 0, 1, 0], [0, -1, 0, 0], [1, 0, 0, 0], [0, 0, 0, 1.0]]),
        ("3", "D"): np.array([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, d2], [0, 0, 0, 1.0]]),
        ("4", "D"): np.array([[0, -sb, cb, d2 * cb], [1, 0, 0, h], [0, cb, sb, d2 * sb],
                              [0, 0, 0, 1.0]]),
    }
    return S


def rssr_geometry():
    """RSSR: crank on z through O (radius r1 = 1), rocker on a skew axis w2
    through D0 (radius r2 = 2, ball offset h2 = 0.4 along w2), coupler L = 3.75."""
    w2 = np.array([1.0, 0.3, 0.2])
    w2 /= np.linalg.norm(w2)
    u2 = np.cross(w2, [0.0, 0.0, 1.0])
    u2 /= np.linalg.norm(u2)
    v2 = np.cross(w2, u2)
    return dict(r1=1.0, r2=2.0, h2=0.4, L=3.75, D0=np.array([0.5, 3.0, 1.5]),
                w2=w2, u2=u2, v2=v2)


def rssr_output(g, th, sign):
    """Rocker angle phi of the RSSR for crank angle th.

    Ball centres B(th) = r1 (cos th, sin th, 0) and
    C(phi) = D0 + h2 w2 + r2 (cos phi u2 + sin phi v2); the coupler keeps
    |C - B| = L.  With g = D0 + h2 w2 - B (and u2, v2 orthonormal, normal to w2):
        |g|^2 + r2^2 + 2 r2 (g.u2 cos phi + g.v2 sin phi) = L^2
    i.e. P cos phi + Q sin phi = R with P = 2 r2 g.u2, Q = 2 r2 g.v2,
    R = L^2 - |g|^2 - r2^2, so phi = atan2(Q, P) + sign acos(R / hypot(P, Q)).
    (For these dimensions |R / hypot(P, Q)| <= 0.71: the crank turns fully.)
    """
    th = np.asarray(th, float)
    B = g["r1"] * np.stack([np.cos(th), np.sin(th), 0 * th], -1)
    gv = g["D0"] + g["h2"] * g["w2"] - B
    P = 2 * g["r2"] * gv @ g["u2"]
    Q = 2 * g["r2"] * gv @ g["v2"]
    R = g["L"] ** 2 - np.sum(gv * gv, -1) - g["r2"] ** 2
    phi = np.arctan2(Q, P) + sign * np.arccos(R / np.hypot(P, Q))
    C = g["D0"] + g["h2"] * g["w2"] + g["r2"] * (
        np.cos(phi)[..., None] * g["u2"] + np.sin(phi)[..., None] * g["v2"])
    return phi, B, C
