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
        k = self.link_motion(theta, omega, alpha)
        return {"rocker_rate": k["w"][:, 2], "rocker_accel": k["al"][:, 2]}

    def link_angles0(self) -> np.ndarray:
        """Absolute angles of crank (A->B), coupler (B->C) and rocker (D->C) at the
        modeling posture."""
        B, C, D = self.B0, self.C0, self.D
        return np.array([self.theta0, np.arctan2(*(C - B)[::-1]), np.arctan2(*(C - D)[::-1])])

    def link_motion(self, theta, omega, alpha) -> dict[str, np.ndarray]:
        """Closed form: absolute angles ``th``, angular velocities ``w`` and accelerations
        ``al`` (each (n, 3): crank A->B, coupler B->C, rocker D->C) for crank angle
        theta, rate omega and acceleration alpha."""
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
        return {"th": np.stack([th2, th3, th4], 1), "w": np.stack([omega, w3, w4], 1),
                "al": np.stack([alpha, al[:, 0], al[:, 1]], 1)}


# --------------------------------------------------- four-bar mass properties
G_STD = 9.80665  # m/s^2


def _rot_z(t: float) -> np.ndarray:
    c, s = np.cos(t), np.sin(t)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _cross2(r: np.ndarray, f: np.ndarray) -> np.ndarray:
    """z component of r x f for (..., 2) arrays."""
    return r[..., 0] * f[..., 1] - r[..., 1] * f[..., 0]


@dataclass(frozen=True)
class LinkMass:
    """Mass properties of one four-bar link in its own frame: origin at the link's
    first pin (A for the crank, B for the coupler, D for the rocker), x towards its
    second pin (B, C, C), z out of the plane.  ``centre`` (x, y) in that frame,
    ``inertia`` principal moments (Ixx, Iyy, Izz) about the centre on those axes."""

    mass: float
    centre: tuple[float, float]
    inertia: tuple[float, float, float]


@dataclass
class FourBarDynamics:
    """Mass properties of the crank, coupler and rocker of :data:`FOURBAR` and gravity
    (case ``fourbar_forces``; SI units: m, kg, s)."""

    fb: FourBar = field(default_factory=FourBar)
    links: tuple = (
        LinkMass(0.40, (0.45, 0.03), (2.0e-4, 0.034, 0.034)),  # crank
        LinkMass(1.20, (1.50, 0.25), (2.0e-3, 0.90, 0.90)),  # coupler
        LinkMass(0.90, (1.20, -0.05), (1.0e-3, 0.47, 0.47)),  # rocker
    )
    gravity: tuple = (0.0, -G_STD, 0.0)
    names: tuple = ("CRANK", "COUPLER", "ROCKER")

    def _origins0(self) -> list[np.ndarray]:
        return [self.fb.A, self.fb.B0, self.fb.D]

    def centre0(self, i: int) -> np.ndarray:
        """Centre of mass of link i, global xyz at the modeling posture."""
        R = _rot_z(self.fb.link_angles0()[i])
        c = self._origins0()[i] + (R[:2, :2] @ np.asarray(self.links[i].centre))
        return np.array([c[0], c[1], 0.0])

    def inertia0(self, i: int) -> np.ndarray:
        """3x3 inertia tensor of link i about its centre, global axes at the modeling posture."""
        R = _rot_z(self.fb.link_angles0()[i])
        return R @ np.diag(self.links[i].inertia) @ R.T

    def reference(self, theta, omega, alpha) -> dict[str, np.ndarray]:
        """Newton-Euler of the three links in the plane (plain numpy, closed-form kinematics).

        Returns ``tau`` (n,): the crank torque about +z (acting on the crank from
        the ground, positive increasing theta) and ``R`` (n, 4, 3): for the joints
        A (BASE, CRANK), B (CRANK, COUPLER), C (COUPLER, ROCKER), D (ROCKER, BASE)
        the load of the first body on the second: global force x, y and the moment
        about z at the pin (the drive torque at A, 0 at the free pins B, C, D).
        Unknowns per step: the pin forces F01 (A), F12 (B), F23 (C), F03 (D, ground
        on rocker) and tau; equations: force and moment about the centre of each link.
        """
        fb = self.fb
        k = fb.link_motion(theta, omega, alpha)
        th, w, al = k["th"], k["w"], k["al"]
        n = th.shape[0]
        A = np.broadcast_to(fb.A, (n, 2))
        D = np.broadcast_to(fb.D, (n, 2))
        B = fb.B_at(theta)
        C = fb.C_at(theta)
        origins = [A, B, D]
        # acceleration of each link's origin: A and D fixed, B on the crank
        aB = al[:, 0, None] * np.stack([-B[:, 1], B[:, 0]], 1) - (w[:, 0] ** 2)[:, None] * B
        a_origin = [np.zeros((n, 2)), aB, np.zeros((n, 2))]
        g = np.asarray(self.gravity[:2], float)
        G, aG = [], []
        for i, lk in enumerate(self.links):
            c, s = np.cos(th[:, i]), np.sin(th[:, i])
            x, y = lk.centre
            r = np.stack([c * x - s * y, s * x + c * y], 1)  # origin -> centre
            G.append(origins[i] + r)
            perp = np.stack([-r[:, 1], r[:, 0]], 1)
            aG.append(a_origin[i] + al[:, i, None] * perp - (w[:, i] ** 2)[:, None] * r)
        # unknown vector: F01x F01y F12x F12y F23x F23y F03x F03y tau
        M = np.zeros((n, 9, 9))
        rhs = np.zeros((n, 9))
        ex, ey = np.array([1.0, 0.0]), np.array([0.0, 1.0])

        def put(row, col, P, sign, body):  # force (col, col+1) applied at P on body
            M[:, row, col] = sign
            M[:, row + 1, col + 1] = sign
            r = P - G[body]
            M[:, row + 2, col] = sign * _cross2(r, ex)
            M[:, row + 2, col + 1] = sign * _cross2(r, ey)

        put(0, 0, A, +1, 0)  # crank: +F01 at A, -F12 at B, +tau
        put(0, 2, B, -1, 0)
        M[:, 2, 8] = 1.0
        put(3, 2, B, +1, 1)  # coupler: +F12 at B, -F23 at C
        put(3, 4, C, -1, 1)
        put(6, 4, C, +1, 2)  # rocker: +F23 at C, +F03 at D
        put(6, 6, D, +1, 2)
        for i, lk in enumerate(self.links):
            rhs[:, 3 * i:3 * i + 2] = lk.mass * (aG[i] - g)
            rhs[:, 3 * i + 2] = lk.inertia[2] * al[:, i]
        x = np.linalg.solve(M, rhs[..., None])[..., 0]
        tau = x[:, 8]
        R = np.zeros((n, 4, 3))
        R[:, 0, :2] = x[:, 0:2]
        R[:, 0, 2] = tau
        R[:, 1, :2] = x[:, 2:4]
        R[:, 2, :2] = x[:, 4:6]
        R[:, 3, :2] = -x[:, 6:8]  # rocker on ground
        return {"tau": tau, "R": R}

    def reference_power(self, theta, omega, alpha) -> np.ndarray:
        """The crank torque again from the power balance (1-DOF Lagrange form):
        tau omega = sum_i m_i (a_Gi - g) . v_Gi + I_i alpha_i omega_i."""
        fb = self.fb
        k = fb.link_motion(theta, omega, alpha)
        th, w, al = k["th"], k["w"], k["al"]
        n = th.shape[0]
        # velocity / acceleration of each link's origin: A, D fixed; B on the crank
        rB = fb.B_at(theta)
        vB = w[:, 0, None] * np.stack([-rB[:, 1], rB[:, 0]], 1)
        aB = al[:, 0, None] * np.stack([-rB[:, 1], rB[:, 0]], 1) - (w[:, 0] ** 2)[:, None] * rB
        vo = [np.zeros((n, 2)), vB, np.zeros((n, 2))]
        ao = [np.zeros((n, 2)), aB, np.zeros((n, 2))]
        g = np.asarray(self.gravity[:2], float)
        p = np.zeros(n)
        for i, lk in enumerate(self.links):
            c, s = np.cos(th[:, i]), np.sin(th[:, i])
            x, y = lk.centre
            r = np.stack([c * x - s * y, s * x + c * y], 1)
            perp = np.stack([-r[:, 1], r[:, 0]], 1)
            v = vo[i] + w[:, i, None] * perp
            a = ao[i] + al[:, i, None] * perp - (w[:, i] ** 2)[:, None] * r
            p += lk.mass * np.sum((a - g) * v, 1) + lk.inertia[2] * al[:, i] * w[:, i]
        return p / np.asarray(omega, float)


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


# -------------------------------------------------- 6R chain mass properties
def _rodrigues(rv) -> np.ndarray:
    rv = np.asarray(rv, float)
    t = np.linalg.norm(rv)
    if t == 0.0:
        return np.eye(3)
    k = rv / t
    K = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + np.sin(t) * K + (1.0 - np.cos(t)) * K @ K


@dataclass
class Chain6RDynamics:
    """Mass properties and a smooth motion of :data:`CHAIN6R` (case ``chain6r_dynamics``;
    SI units).

    Link i (L1..L6) is a solid box of ``masses[i]`` and size ``boxes[i]``,
    centred at ``centres[i]`` (global, modeling posture), its edges turned by
    the rotation vector ``turns[i]`` from the global axes: every inertia
    tensor has products of inertia.  Gravity is along -z.  The motion is
    q_i(t) = A_i sin(2 pi t / T + p_i) at t_k = k T / n (the joint values of
    the ``chain6r`` case), with its closed-form rates and accelerations.
    """

    chain: SerialChain6R = field(default_factory=SerialChain6R)
    masses: tuple = (4.0, 3.5, 2.5, 1.5, 1.0, 0.5)
    centres: np.ndarray = field(default_factory=lambda: np.array([
        [0.0, 0.02, 0.25], [0.02, 0.03, 0.9], [0.1, -0.02, 1.32],
        [0.55, 0.01, 1.28], [0.95, -0.01, 1.3], [1.08, 0.02, 1.31]]))
    boxes: np.ndarray = field(default_factory=lambda: np.array([
        [0.15, 0.12, 0.5], [0.12, 0.10, 0.8], [0.25, 0.10, 0.10],
        [0.70, 0.08, 0.08], [0.10, 0.10, 0.10], [0.15, 0.06, 0.06]]))
    turns: np.ndarray = field(default_factory=lambda: np.array([
        [0.1, 0.0, 0.2], [0.0, 0.15, 0.1], [0.2, 0.1, 0.0],
        [0.0, 0.05, 0.3], [0.3, 0.2, 0.1], [0.1, 0.3, 0.0]]))
    gravity: tuple = (0.0, 0.0, -G_STD)
    period: float = 2.0  # s, one turn of the motion

    def inertia(self, i: int) -> np.ndarray:
        """3x3 inertia tensor of link i about its centre, global axes at q = 0
        (engineering convention: off-diagonals are minus the products of inertia)."""
        a, b, c = self.boxes[i]
        m = self.masses[i]
        I = m / 12.0 * np.diag([b * b + c * c, a * a + c * c, a * a + b * b])
        R = _rodrigues(self.turns[i])
        return R @ I @ R.T

    def motion(self, n: int = NSTEPS) -> tuple[np.ndarray, ...]:
        """(t, q, qd, qdd): times (n,) and joint values, rates, accelerations (n, 6)."""
        t = self.period * np.arange(n) / n
        Om = 2 * np.pi / self.period
        A = np.asarray(self.chain.amplitudes)
        ph = Om * t[:, None] + np.asarray(self.chain.phases)
        return t, A * np.sin(ph), A * Om * np.cos(ph), -A * Om * Om * np.sin(ph)

    def reference(self, q, qd, qdd) -> dict[str, np.ndarray]:
        """Joint torques (n, 6) by recursive Newton-Euler in the global frame (plain numpy).

        Forward: joint i's axis k_i and point o_i move with link i-1 (product of
        exponentials as in :meth:`SerialChain6R.reference`);
        w_i = w_{i-1} + k_i qd_i, al_i = al_{i-1} + k_i qdd_i + w_{i-1} x k_i qd_i,
        and the accelerations of o_i and of the centres follow by rigid-body
        transport.  Backward: f_i = m_i (a_ci - g) + f_{i+1},
        n_i = I_i al_i + w_i x I_i w_i + (c_i - o_i) x m_i (a_ci - g) + n_{i+1}
        + (o_{i+1} - o_i) x f_{i+1} (about o_i), tau_i = k_i . n_i.
        """
        ch = self.chain
        n = q.shape[0]
        g = np.asarray(self.gravity, float)
        R = np.broadcast_to(np.eye(3), (n, 3, 3)).copy()  # rotation of link i-1
        p = np.zeros((n, 3))  # translation of link i-1 (x -> R x + p)
        w = np.zeros((n, 3))
        al = np.zeros((n, 3))
        o_prev = np.zeros((n, 3))
        a_prev = np.zeros((n, 3))  # acceleration of o_prev
        ks, os_, cs, Is, ws, als, Fs = [], [], [], [], [], [], []
        for i in range(6):
            k0 = ch.axes[i] / np.linalg.norm(ch.axes[i])
            k = R @ k0
            o = R @ ch.origins[i] + p
            d = o - o_prev
            a_o = a_prev + np.cross(al, d) + np.cross(w, np.cross(w, d))
            al = al + k * qdd[:, i, None] + np.cross(w, k * qd[:, i, None])
            w = w + k * qd[:, i, None]
            # link i's placement: rotate about (k, o) by q_i after link i-1's
            th = q[:, i]
            K = np.zeros((n, 3, 3))
            K[:, 0, 1], K[:, 0, 2], K[:, 1, 2] = -k[:, 2], k[:, 1], -k[:, 0]
            K[:, 1, 0], K[:, 2, 0], K[:, 2, 1] = k[:, 2], -k[:, 1], k[:, 0]
            E = (np.eye(3) + np.sin(th)[:, None, None] * K
                 + (1 - np.cos(th))[:, None, None] * (K @ K))
            R = E @ R
            p = o + np.einsum("nij,nj->ni", E, p - o)
            c = np.einsum("nij,j->ni", R, self.centres[i]) + p
            Iw = R @ self.inertia(i) @ np.swapaxes(R, 1, 2)
            r = c - o
            a_c = a_o + np.cross(al, r) + np.cross(w, np.cross(w, r))
            ks.append(k)
            os_.append(o)
            cs.append(c)
            Is.append(Iw)
            ws.append(w)
            als.append(al)
            Fs.append(self.masses[i] * (a_c - g))
            o_prev, a_prev = o, a_o
        tau = np.zeros((n, 6))
        f = np.zeros((n, 3))
        mom = np.zeros((n, 3))
        o_next = None
        for i in range(5, -1, -1):
            Iw, w, al = Is[i], ws[i], als[i]
            Iwv = np.einsum("nij,nj->ni", Iw, w)
            mom_i = (np.einsum("nij,nj->ni", Iw, al) + np.cross(w, Iwv)
                     + np.cross(cs[i] - os_[i], Fs[i]) + mom)
            if o_next is not None:
                mom_i = mom_i + np.cross(o_next - os_[i], f)
            f = Fs[i] + f
            mom = mom_i
            o_next = os_[i]
            tau[:, i] = np.sum(ks[i] * mom, 1)
        return {"tau": tau}


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
FOURBAR_DYN = FourBarDynamics(FOURBAR)
CHAIN6R_DYN = Chain6RDynamics(CHAIN6R)
