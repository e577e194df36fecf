"""Model builders shared by the tests: each records, beside the Model, what it gave the
model, so that the references are written from that record and never from openimp.

* :class:`Rig`: a Model plus every joint frame placed in it (kinematics tests);
* :class:`Spec`: a Model plus its masses, gravity and force elements (force, statics and
  time-response references, :class:`helpers.mechanics.Ref`);
* the shared mechanisms: :func:`fourbar` (the planar crank-rocker of the model tests),
  :func:`build_fivebar`, :func:`slider_crank_joints`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

import openimp
from helpers.geometry import DEG, circle_intersection, e2, frame, hom
from openimp import Model


class Rig:
    """A Model plus an independent record of every joint frame placed in it."""

    def __init__(self, name: str, ground: str = "BASE") -> None:
        self.m = Model(name, ground=ground)
        self.j: dict[str, tuple[str, str, str, np.ndarray, np.ndarray]] = {}
        self.bf: dict[str, np.ndarray] = {}

    def joint(self, kind, name, b1, b2, F1, F2):
        """A joint given by its two global 4x4 frames."""
        self.m.add_joint(kind, name, b1, b2, frame1=F1, frame2=F2)
        self.j[name] = (kind, b1, b2, np.array(F1, float), np.array(F2, float))

    def pin(self, name, b1, b2, origin, axis, ref, ref2=None, kind="revolute", origin2=None):
        """A joint given by origin/axis/ref (the add_joint keyword path)."""
        kw = {}
        if ref2 is not None:
            kw["ref2"] = ref2
        if origin2 is not None:
            kw["origin2"] = origin2
        self.m.add_joint(kind, name, b1, b2, origin=origin, axis=axis, ref=ref, **kw)
        F1 = frame(origin, axis, ref)
        F2 = frame(origin if origin2 is None else origin2, axis, ref if ref2 is None else ref2)
        self.j[name] = (kind, b1, b2, F1, F2)

    def ball(self, name, b1, b2, centre):
        F = hom(p=centre)
        self.joint("sphere", name, b1, b2, F, F)

    def body_frame(self, body, T):
        self.m.set_body_frame(body, T)
        self.bf[body] = np.array(T, float)

    def size(self) -> float:
        o = np.array([F[:3, 3] for (_, _, _, F1, F2) in self.j.values() for F in (F1, F2)])
        return float(np.linalg.norm(o.max(0) - o.min(0))) or 1.0

    def compile(self):
        return openimp.compile(self.m)


def build_fivebar():
    """Planar five-bar: ground A(0,0)-E(4,0), cranks 1.5 at A and E, couplers 3
    and 3 meeting at C (left of B->D)."""
    A2, E2 = np.zeros(2), np.array([4.0, 0.0])
    l1, l2, l3, l4 = 1.5, 3.0, 3.0, 1.5
    t1, t4 = 70 * DEG, 110 * DEG
    B2, D2 = A2 + l1 * e2(t1), E2 + l4 * e2(t4)
    C2 = circle_intersection(B2, l2, D2, l3, left=True)
    z, x = (0, 0, 1), (1, 0, 0)
    rig = Rig("five-bar")
    rig.pin("A", "BASE", "K1", [*A2, 0], z, x)
    rig.pin("B", "K1", "C1", [*B2, 0], z, x)
    rig.pin("C", "C1", "C2", [*C2, 0], z, x)
    rig.pin("D", "C2", "K2", [*D2, 0], z, x)
    rig.pin("E", "K2", "BASE", [*E2, 0], z, x)
    rig.m.add_point("PC", "C1", [*C2, 0])
    return rig, dict(A=A2, E=E2, l=(l1, l2, l3, l4), t1=t1, t4=t4)


def fourbar(ground: str = "BASE") -> Model:
    """Planar crank-rocker a=1, b=3, c=2.5, d=3.2 at crank angle 40 deg."""
    a, b, c, d = 1.0, 3.0, 2.5, 3.2
    th = math.radians(40)
    B = np.array([a * math.cos(th), a * math.sin(th), 0.0])
    D = np.array([d, 0.0, 0.0])
    BD = D - B
    L = np.linalg.norm(BD)
    x = (b * b - c * c + L * L) / (2 * L)
    y = math.sqrt(b * b - x * x)
    ex = BD / L
    C = B + x * ex + y * np.array([-ex[1], ex[0], 0.0])
    m = Model("four-bar", ground=ground)
    m.add_joint("revolute", "A", "BASE", "CRANK", origin=(0, 0, 0))
    m.add_joint("revolute", "B", "CRANK", "COUPLER", origin=B)
    m.add_joint("revolute", "C", "COUPLER", "ROCKER", origin=C)
    m.add_joint("revolute", "D", "ROCKER", "BASE", origin=D)
    return m


@dataclass
class Spec:
    """A Model and, beside it, the data the references need (model units, global
    coordinates at the modeling posture)."""

    model: openimp.Model
    gravity: np.ndarray = field(default_factory=lambda: np.zeros(3))
    mass: dict = field(default_factory=dict)  # body -> (m, c0 (3,), Ic0 (3, 3))
    points: dict = field(default_factory=dict)  # point -> body
    springs: list = field(default_factory=list)  # (name, p1, p2, k, l0)
    dampers: list = field(default_factory=list)  # (name, p1, p2, c)
    forces: list = field(default_factory=list)  # (name, point, f, dir (3,) | (pa, pb))
    torques: list = field(default_factory=list)  # (name, body, t, dir (3,) | (pa, pb))
    jsprings: dict = field(default_factory=dict)  # joint -> (k, q0)
    jdampers: dict = field(default_factory=dict)  # joint -> c
    jforces: dict = field(default_factory=dict)  # joint -> f

    def joint(self, name, b1, b2, origin, axis=(0, 0, 1), kind="revolute", **kw):
        self.model.add_joint(kind, name, b1, b2, origin=origin, axis=axis, **kw)

    def set_gravity(self, g):
        self.gravity = np.asarray(g, float)
        self.model.set_gravity(g)

    def add_mass(self, body, m, c0, Ic0):
        assert self.model.add_mass(body, m, center=c0, inertia=Ic0) == []
        self.mass[body] = (m, np.asarray(c0, float), np.asarray(Ic0, float))

    def point(self, name, body, xyz):
        self.model.add_point(name, body, xyz)
        self.points[name] = body

    def spring(self, name, p1, p2, k, l0):
        self.model.add_spring(name, p1, p2, k, l0)
        self.springs.append((name, p1, p2, k, l0))

    def damper(self, name, p1, p2, c):
        self.model.add_damper(name, p1, p2, c)
        self.dampers.append((name, p1, p2, c))

    def force(self, name, p, f, direction):
        if isinstance(direction[0], str):
            self.model.add_force(name, p, f, along=direction)
        else:
            self.model.add_force(name, p, f, direction=direction)
        self.forces.append((name, p, f, direction))

    def torque(self, name, body, t, direction):
        if isinstance(direction[0], str):
            self.model.add_torque(name, body, t, along=direction)
        else:
            self.model.add_torque(name, body, t, direction=direction)
        self.torques.append((name, body, t, direction))

    def joint_spring(self, joint, k, q0):
        self.model.set_joint_spring(joint, k, q0)
        self.jsprings[joint] = (k, q0)

    def joint_damper(self, joint, c):
        self.model.set_joint_damper(joint, c)
        self.jdampers[joint] = c

    def joint_force(self, joint, f):
        self.model.set_joint_force(joint, f)
        self.jforces[joint] = f

    def compile(self):
        return openimp.compile(self.model)


def spec_cache():
    """A ``compiled(key, build) -> (spec, system)`` that compiles each spec once per test
    session; one cache per test module (its keys are its own)."""
    cache: dict = {}

    def compiled(key, build):
        if key not in cache:
            spec = build()
            cache[key] = (spec, spec.compile())
        return cache[key]

    return compiled


def slider_crank_joints(name: str, a: float, b: float, e: float, th0: float
                        ) -> tuple[Spec, np.ndarray, np.ndarray]:
    """The joints of a slider-crank: crank a (A BASE->CRANK, from the origin at angle
    th0), rod b (B CRANK->ROD), pin C ROD->SLIDER, prismatic D BASE->SLIDER along X on
    the line y = e.  Returns the spec and the pins B and C."""
    B = a * np.array([math.cos(th0), math.sin(th0), 0.0])
    C = np.array([B[0] + math.sqrt(b * b - (e - B[1]) ** 2), e, 0.0])
    s = Spec(openimp.Model(name))
    s.joint("A", "BASE", "CRANK", np.zeros(3))
    s.joint("B", "CRANK", "ROD", B)
    s.joint("C", "ROD", "SLIDER", C)
    s.joint("D", "BASE", "SLIDER", (0.0, e, 0.0), (1.0, 0.0, 0.0), kind="prismatic",
            ref=(0.0, 1.0, 0.0), origin2=C)
    return s, B, C
