"""The benchmark mechanisms: geometry shared by every tool and closed-form references.

Every tool builds its model from the numbers here, so all of them compute the
same mechanism at the same input values.  Each mechanism is described at its
*modeling posture* (the posture in which openimp's joint variables are 0) in
global coordinates; the input sweep is given as absolute crank angles and as
increments from the modeling posture.

The closed-form references (`reference_*`) are plain vectorised numpy; every
tool's output is checked against them and against openimp's output before its
timing counts.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

NSTEPS = 360  # postures per sweep (one crank turn in 1 degree steps)


def _circle_intersection(P1: np.ndarray, r1: float, P2: np.ndarray, r2: float, sign: float):
    """Intersection(s) of circle(P1, r1) and circle(P2, r2) in the xy-plane (batched)."""
    P1 = np.asarray(P1, float)
    P2 = np.asarray(P2, float)
    d = P2 - P1
    L = np.linalg.norm(d, axis=-1, keepdims=True)
    ex = d / L
    ey = np.stack([-ex[..., 1], ex[..., 0]], axis=-1)
    x = (r1 * r1 - r2 * r2 + L * L) / (2 * L)
    y = np.sqrt(r1 * r1 - x * x)
    return P1 + x * ex + sign * y * ey


# ----------------------------------------------------------------- four-bar
@dataclass
class FourBar:
    """Planar crank-rocker: ground A-D, crank A-B, coupler B-C, rocker C-D; coupler point P.

    ``theta0`` is the crank angle at the modeling posture; the rocker is on the
    'upper' assembly branch (C to the left of B->D).  ``p_offset`` places P at
    midpoint(B, C) + p_offset (global xy) at the modeling posture.
    """

    a: float = 1.0  # crank
    b: float = 3.0  # coupler
    c: float = 2.5  # rocker
    d: float = 3.2  # ground
    theta0: float = np.radians(40.0)
    p_offset: tuple = (0.0, 0.5)

    @property
    def A(self) -> np.ndarray:
        return np.array([0.0, 0.0])

    @property
    def D(self) -> np.ndarray:
        return np.array([self.d, 0.0])

    def B_at(self, theta):
        theta = np.asarray(theta, float)
        return np.stack([self.a * np.cos(theta), self.a * np.sin(theta)], axis=-1)

    def C_at(self, theta):
        D = np.broadcast_to(self.D, (*np.shape(theta), 2))
        return _circle_intersection(self.B_at(theta), self.b, D, self.c, +1.0)

    @property
    def B0(self) -> np.ndarray:
        return self.B_at(self.theta0)

    @property
    def C0(self) -> np.ndarray:
        return self.C_at(self.theta0)

    @property
    def P0(self) -> np.ndarray:
        return (self.B0 + self.C0) / 2 + np.asarray(self.p_offset)

    @property
    def p_local(self) -> tuple[float, float]:
        """P in the coupler frame (origin B, x along B->C): (distance, angle from B->C)."""
        v = self.P0 - self.B0
        u = self.C0 - self.B0
        ang = np.arctan2(u[0] * v[1] - u[1] * v[0], u @ v)
        return float(np.hypot(*v)), float(ang)

    def grashof_crank_rocker(self) -> bool:
        s = sorted([self.a, self.b, self.c, self.d])
        return s[0] == self.a and s[0] + s[3] < s[1] + s[2]

    def crank_angles(self, n: int = NSTEPS, step_deg: float = 1.0) -> np.ndarray:
        """Absolute crank angles of the sweep (rad)."""
        return self.theta0 + np.radians(step_deg * np.arange(n))

    def reference(self, theta: np.ndarray) -> dict[str, np.ndarray]:
        """Closed form: rocker angle (rad, D->C from +x) and coupler point P (xy)."""
        B = self.B_at(theta)
        C = self.C_at(theta)
        dist, ang = self.p_local
        u = (C - B) / self.b
        ca, sa = np.cos(ang), np.sin(ang)
        dirp = np.stack([u[:, 0] * ca - u[:, 1] * sa, u[:, 0] * sa + u[:, 1] * ca], axis=1)
        P = B + dist * dirp
        rocker = np.arctan2(C[:, 1] - self.D[1], C[:, 0] - self.D[0])
        return {"rocker": rocker, "P": P, "C": C}

    def reference_rates(self, theta, omega, alpha) -> dict[str, np.ndarray]:
        """Closed form: rocker angular velocity and acceleration for crank rate omega, alpha."""
        B = self.B_at(theta)
        C = self.C_at(theta)
        th2 = np.asarray(theta, float)
        th3 = np.arctan2(C[:, 1] - B[:, 1], C[:, 0] - B[:, 0])
        th4 = np.arctan2(C[:, 1] - self.D[1], C[:, 0] - self.D[0])
        a, b, c = self.a, self.b, self.c
        omega = np.broadcast_to(np.asarray(omega, float), th2.shape)
        alpha = np.broadcast_to(np.asarray(alpha, float), th2.shape)

        def perp(t):
            return np.stack([-np.sin(t), np.cos(t)], axis=1)

        def rad(t):
            return np.stack([np.cos(t), np.sin(t)], axis=1)

        # a w2 e2' + b w3 e3' - c w4 e4' = 0   -> unknowns w3, w4
        M = np.stack([b * perp(th3), -c * perp(th4)], axis=2)  # (n, 2, 2)
        rhs = -(a * omega)[:, None] * perp(th2)
        w = np.linalg.solve(M, rhs[..., None])[..., 0]
        w3, w4 = w[:, 0], w[:, 1]
        # a(al2 e2' - w2^2 e2) + b(al3 e3' - w3^2 e3) - c(al4 e4' - w4^2 e4) = 0
        rhs2 = -(a * (alpha[:, None] * perp(th2) - (omega**2)[:, None] * rad(th2))
                 - b * (w3**2)[:, None] * rad(th3) + c * (w4**2)[:, None] * rad(th4))
        al = np.linalg.solve(M, rhs2[..., None])[..., 0]
        return {"rocker_rate": w4, "rocker_accel": al[:, 1]}


# ------------------------------------------------------------ slider-crank
@dataclass
class SliderCrank:
    """Offset slider-crank: crank A-B about the origin, rod B-C, slider C on the line y = e."""

    a: float = 1.0
    b: float = 3.5
    e: float = 0.4
    theta0: float = np.radians(30.0)
    p_offset: tuple = (0.0, 0.3)

    def B_at(self, theta):
        theta = np.asarray(theta, float)
        return np.stack([self.a * np.cos(theta), self.a * np.sin(theta)], axis=-1)

    def C_at(self, theta):
        B = self.B_at(theta)
        x = B[..., 0] + np.sqrt(self.b**2 - (self.e - B[..., 1]) ** 2)
        return np.stack([x, np.full_like(x, self.e)], axis=-1)

    @property
    def B0(self):
        return self.B_at(self.theta0)

    @property
    def C0(self):
        return self.C_at(self.theta0)

    @property
    def P0(self):
        return (self.B0 + self.C0) / 2 + np.asarray(self.p_offset)

    @property
    def p_local(self) -> tuple[float, float]:
        v = self.P0 - self.B0
        u = self.C0 - self.B0
        ang = np.arctan2(u[0] * v[1] - u[1] * v[0], u @ v)
        return float(np.hypot(*v)), float(ang)

    def crank_angles(self, n: int = NSTEPS) -> np.ndarray:
        return self.theta0 + np.radians(np.arange(n))

    def reference(self, theta) -> dict[str, np.ndarray]:
        B = self.B_at(theta)
        C = self.C_at(theta)
        dist, ang = self.p_local
        u = (C - B) / self.b
        ca, sa = np.cos(ang), np.sin(ang)
        dirp = np.stack([u[:, 0] * ca - u[:, 1] * sa, u[:, 0] * sa + u[:, 1] * ca], axis=1)
        return {"slider": C[:, 0], "P": B + dist * dirp}


# --------------------------------------------------------------------- RSSR
@dataclass
class RSSR:
    """Spatial RSSR: input revolute at the origin about z (crank a), spheres at B and C,
    output revolute at D about x (rocker c, C = D + c (0, cos phi, sin phi))."""

    a: float = 1.0
    b: float = 3.25
    c: float = 1.8
    D: tuple = (2.0, 1.0, 1.5)
    theta0: float = np.radians(20.0)
    branch: float = +1.0

    def B_at(self, theta):
        theta = np.asarray(theta, float)
        return np.stack([self.a * np.cos(theta), self.a * np.sin(theta), np.zeros_like(theta)], -1)

    def phi_at(self, theta):
        w = self.B_at(theta) - np.asarray(self.D)
        K = (np.sum(w * w, -1) + self.c**2 - self.b**2) / (2 * self.c)
        R = np.hypot(w[..., 1], w[..., 2])
        psi = np.arctan2(w[..., 2], w[..., 1])
        return psi + self.branch * np.arccos(K / R)

    def C_at(self, theta):
        phi = self.phi_at(theta)
        u = np.stack([np.zeros_like(phi), np.cos(phi), np.sin(phi)], -1)
        return np.asarray(self.D) + self.c * u

    @property
    def B0(self):
        return self.B_at(self.theta0)

    @property
    def C0(self):
        return self.C_at(self.theta0)

    @property
    def phi0(self):
        return float(self.phi_at(self.theta0))

    def crank_angles(self, n: int = NSTEPS) -> np.ndarray:
        return self.theta0 + np.radians(np.arange(n))

    def reference(self, theta) -> dict[str, np.ndarray]:
        return {"rocker": self.phi_at(theta), "C": self.C_at(theta)}


# ------------------------------------------------------------------ 6R chain
@dataclass
class SerialChain6R:
    """Open 6R chain ground -> L1 -> ... -> L6 (an elbow arm with a spherical-ish wrist).

    At the modeling posture (all joint values 0) joint i passes through
    ``origins[i]`` along ``axes[i]`` (global); the tool point P sits on L6.
    """

    origins: np.ndarray = field(default_factory=lambda: np.array([
        [0.0, 0.0, 0.0], [0.0, 0.0, 0.5], [0.0, 0.0, 1.3],
        [0.2, 0.0, 1.3], [0.9, 0.0, 1.3], [1.0, 0.0, 1.3]]))
    axes: np.ndarray = field(default_factory=lambda: np.array([
        [0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [0.0, 1.0, 0.0],
        [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]]))
    P0: np.ndarray = field(default_factory=lambda: np.array([1.15, 0.05, 1.32]))
    amplitudes: tuple = (1.0, 0.8, 0.9, 1.2, 0.7, 1.5)
    phases: tuple = (0.0, 0.5, 1.0, 1.5, 2.0, 2.5)

    def joint_values(self, n: int = NSTEPS) -> np.ndarray:
        """(n, 6) joint values (rad), 0 = modeling posture."""
        t = 2 * np.pi * np.arange(n) / n
        return np.stack([A * np.sin(t + p) for A, p in zip(self.amplitudes, self.phases)], 1)

    def reference(self, q: np.ndarray) -> dict[str, np.ndarray]:
        """Product of exponentials: P = e^{xi1 q1} ... e^{xi6 q6} P0 (space frame)."""
        P = np.broadcast_to(self.P0, (q.shape[0], 3)).copy()
        for i in range(5, -1, -1):
            k = self.axes[i] / np.linalg.norm(self.axes[i])
            o = self.origins[i]
            v = P - o
            th = q[:, i][:, None]
            c, s = np.cos(th), np.sin(th)
            v = v * c + np.cross(k, v) * s + np.outer(v @ k, k) * (1 - c)
            P = o + v
        return {"P": P}


# ------------------------------------------------------------- batch of 4-bars
def fourbar_variants(n: int = 1000, seed: int = 12345) -> list[FourBar]:
    """``n`` Grashof crank-rockers near the base four-bar (same theta0 and P offset)."""
    rng = np.random.default_rng(seed)
    out: list[FourBar] = []
    while len(out) < n:
        fb = FourBar(a=rng.uniform(0.9, 1.1), b=rng.uniform(2.8, 3.2),
                     c=rng.uniform(2.3, 2.7), d=rng.uniform(3.0, 3.4))
        if fb.grashof_crank_rocker():
            out.append(fb)
    return out


FOURBAR = FourBar()
SLIDER = SliderCrank()
RSSR_MECH = RSSR()
CHAIN6R = SerialChain6R()
OMEGA = 10.0  # crank rate for case (b), rad/s
ALPHA = 5.0  # crank acceleration for case (b), rad/s^2
