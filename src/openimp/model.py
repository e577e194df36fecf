"""The user's description of a mechanism (book ch 4, 9): bodies, joints, points, and
what it carries: mass properties, gravity, units, springs, dampers and loads.

A :class:`Model` is mutable and validated as it is built: every misuse raises
:class:`~openimp.errors.InputError` naming the element and what to change.
All geometry is given in global coordinates at one *modeling posture*: body
frames coincide with the global frame there (unless :meth:`Model.set_body_frame`
moves one), joint frames and points are placed from global data.
:func:`openimp.compile` (:func:`openimp.system.compile_model`) turns it into the
immutable packed :class:`~openimp.system.System`.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from openimp import massprops
from openimp.errors import InputError
from openimp.joints import ALIAS_AXES, JointType, joint_type

Vec = Sequence[float] | np.ndarray


@dataclass
class Joint:
    """One joint as the user placed it: two global frames at the modeling posture."""

    name: str
    kind: JointType
    kind_name: str
    body1: str
    body2: str
    frame1: np.ndarray
    frame2: np.ndarray
    consts: np.ndarray
    const_args: dict[str, Any] = field(default_factory=dict)


@dataclass
class Point:
    """A point fixed in a body, given in global coordinates at the modeling posture."""

    name: str
    body: str
    xyz: np.ndarray


#: a load law: called with one :class:`~openimp.dynamics.loads.LoadState` per step
#: (``s.t``, ``s.length``/``s.rate`` of its own element, ``s.var(key)`` ...), returns a float
Law = Callable[[Any], float]


@dataclass
class Element:
    """A force element between points (book 9.8-9.11), in model units.

    ``kind``: ``"spring"`` (tension ``rate * (length - free)``), ``"damper"``
    (tension ``rate * d length/dt``), ``"force"`` (magnitude ``value`` at point
    ``points[0]`` along ``direction`` or from ``points[1]`` toward ``points[2]``)
    or ``"torque"`` (magnitude ``value`` on ``body`` about ``direction`` or
    ``points[0]`` -> ``points[1]``, right-hand rule).  ``law``, when given,
    replaces the linear expression: it returns the tension (springs, dampers) or
    the magnitude (forces, torques).
    """

    name: str
    kind: str
    points: tuple[str, ...]
    value: float = 0.0
    free: float | None = None
    body: str | None = None
    direction: np.ndarray | None = None
    law: Law | None = None


@dataclass
class JointLoad:
    """Spring, damper and load on one joint variable (book 9.6, 9.7, 9.10), model units
    (radians for angles; rates per radian).

    The load on the variable is ``force - rate * (q - free) - damping * qd``
    (positive tends to increase q); a law replaces its term: ``spring_law(s)``
    returns the spring force ``rate * (q - free)``, ``damper_law(s)`` the damping
    force, ``force_law(s)`` the applied load.
    """

    joint: str
    var: int
    rate: float = 0.0
    free: float | None = None
    #: the free angle means itself modulo a turn: the compiled model takes the one
    #: nearest the joint's angle at the modeling posture (IMP's Cardan and polar angles)
    periodic: bool = False
    damping: float = 0.0
    force: float = 0.0
    spring_law: Law | None = None
    damper_law: Law | None = None
    force_law: Law | None = None


def _fmt(v: Any) -> str:
    """A vector as plain numbers for messages: (1, 0, 0)."""
    return "(" + ", ".join(f"{float(x):.6g}" for x in np.asarray(v).reshape(-1)) + ")"


def _vec3(name: str, what: str, v: Vec | None) -> np.ndarray | None:
    if v is None:
        return None
    try:
        a = np.asarray(v, dtype=float).reshape(-1)
    except (TypeError, ValueError) as exc:
        raise InputError(f"{name}: {what} must be three numbers, got {v!r}") from exc
    if a.shape != (3,) or not np.all(np.isfinite(a)):
        raise InputError(f"{name}: {what} must be three finite numbers, got {v!r}")
    return a


def _unit(name: str, what: str, v: np.ndarray) -> np.ndarray:
    n = float(np.linalg.norm(v))
    if n < 1e-12:
        raise InputError(f"{name}: {what} has zero length; give a non-zero direction")
    return v / n


def frame_from_axes(
    name: str, origin: np.ndarray, w: np.ndarray, u: np.ndarray | None
) -> np.ndarray:
    """A right-handed 4x4 frame with origin, w along ``w`` and u toward ``u``.

    ``u`` is squared off against ``w`` (its component along w is removed, as
    IMP does); when it is missing, or parallel to w, a perpendicular is chosen
    from the global axes (x, else y).
    """
    wn = _unit(name, "axis", w)
    if u is None:
        cand = np.array([1.0, 0.0, 0.0])
        if abs(float(cand @ wn)) > 0.9:
            cand = np.array([0.0, 1.0, 0.0])
        u = cand
    else:
        u = np.asarray(u, dtype=float)
        if float(np.linalg.norm(u)) < 1e-12:
            raise InputError(f"{name}: reference direction has zero length")
    up = u - (u @ wn) * wn
    if float(np.linalg.norm(up)) < 1e-9 * max(1.0, float(np.linalg.norm(u))):
        raise InputError(
            f"{name}: the reference direction {_fmt(u)} is parallel to the axis "
            f"{_fmt(wn)}; give a reference direction that is not along the axis"
        )
    un = up / np.linalg.norm(up)
    vn = np.cross(wn, un)
    T = np.eye(4)
    T[:3, 0] = un
    T[:3, 1] = vn
    T[:3, 2] = wn
    T[:3, 3] = origin
    return T


def _check_frame(name: str, which: str, F: Any) -> np.ndarray:
    try:
        T = np.asarray(F, dtype=float)
    except (TypeError, ValueError) as exc:
        raise InputError(f"joint {name!r}: {which} must be a 4x4 matrix") from exc
    if T.shape != (4, 4) or not np.all(np.isfinite(T)):
        raise InputError(f"joint {name!r}: {which} must be a finite 4x4 matrix")
    R = T[:3, :3]
    if (
        np.max(np.abs(R.T @ R - np.eye(3))) > 1e-9
        or abs(np.linalg.det(R) - 1.0) > 1e-9
        or np.max(np.abs(T[3] - [0, 0, 0, 1])) > 0
    ):
        raise InputError(
            f"joint {name!r}: {which} is not a rigid right-handed transform "
            "(rotation part must be orthonormal with determinant +1, last row 0 0 0 1)"
        )
    return T.copy()


class Model:
    """A mechanism description: bodies, joints and points at one modeling posture.

    Parameters
    ----------
    name:
        Title of the model (optional).
    ground:
        Name of the fixed body (IMP's default ``BASE``).
    """

    def __init__(self, name: str | None = None, ground: str = "BASE") -> None:
        self.name = name or "model"
        self.ground = str(ground)
        self.bodies: list[str] = []
        self.body_frames: dict[str, np.ndarray] = {}
        self.joints: dict[str, Joint] = {}
        self.points: dict[str, Point] = {}
        #: free-form store for statements of later modes (static, dynamic, graphics)
        self.extras: dict[str, Any] = {}
        #: pseudo-inertia J = integral r r^T dm (book 9.2) of every body with mass data,
        #: about the global origin at the modeling posture (model units)
        self.masses: dict[str, np.ndarray] = {}
        #: gravity vector, global axes, length/s^2 (None: no gravity)
        self.gravity: np.ndarray | None = None
        #: the unit system (labels, standard gravity, mass factor)
        self.units: massprops.Units = massprops.units("SI")
        self._units_named = False
        #: springs, dampers, forces and torques by name
        self.elements: dict[str, Element] = {}
        #: joint springs, dampers and loads by (joint, variable index)
        self.joint_loads: dict[tuple[str, int], JointLoad] = {}

    # ------------------------------------------------------------------ bodies
    def add_body(self, name: str) -> str:
        """Create a body by name (joints also create the bodies they name)."""
        name = self._check_name(name, "body")
        if name not in self.body_frames:
            self.bodies.append(name)
            self.body_frames[name] = np.eye(4)
        return name

    def set_body_frame(self, body: str, frame: Any) -> None:
        """Place a body's own frame (global 4x4 at the modeling posture)."""
        if body not in self.body_frames:
            raise InputError(f"body {body!r} does not exist; name it in a joint or add_body first")
        self.body_frames[body] = _check_frame(body, "body frame", frame)

    def set_ground(self, body: str) -> None:
        """Make ``body`` the fixed body (IMP's GROUND; allows kinematic inversion)."""
        self.ground = self._check_name(body, "ground body")

    @staticmethod
    def _check_name(name: Any, what: str) -> str:
        if not isinstance(name, str) or not name.strip():
            raise InputError(f"{what} name must be a non-empty string, got {name!r}")
        return name.strip()

    # ------------------------------------------------------------------ joints
    def add_joint(
        self,
        kind: str,
        name: str,
        body1: str,
        body2: str,
        *,
        origin: Vec | None = None,
        axis: Vec | None = None,
        ref: Vec | None = None,
        ref2: Vec | None = None,
        origin2: Vec | None = None,
        axis2: Vec | None = None,
        frame1: Any = None,
        frame2: Any = None,
        **constants: Any,
    ) -> Joint:
        """Add a joint of ``kind`` named ``name`` from ``body1`` (h-) to ``body2`` (h+).

        The two joint frames are placed at the modeling posture in global
        coordinates: ``origin``; ``axis`` = direction of w (default global z,
        or the alias' axis for xpin/yslide/...); ``ref`` = direction of u on
        body1; ``ref2`` = direction of u' on body2 (default ``ref``, so the
        angle starts at 0); ``origin2``/``axis2`` for joints whose two frames
        do not share origin or axis (gears, cams, universal joints). Or give
        full 4x4 ``frame1``/``frame2``. ``constants`` are the kind's constants
        (``lead=`` for a screw, ``ratio=`` for gears, ...).
        """
        name = self._check_name(name, "joint")
        if not isinstance(kind, str):
            raise InputError(f"joint {name!r}: the kind must be a name such as 'revolute', "
                             f"got {kind!r}")
        jt = joint_type(kind)
        kname = kind.lower()
        if name in self.joints:
            raise InputError(
                f"joint {name!r} already exists; give the new joint another name "
                "or delete the old one first"
            )
        b1 = self._check_name(body1, f"joint {name!r}: first body")
        b2 = self._check_name(body2, f"joint {name!r}: second body")
        if b1 == b2:
            raise InputError(
                f"joint {name!r} joins body {b1!r} to itself; a joint needs two different bodies"
            )
        where = f"joint {name!r}"
        o = _vec3(where, "origin", origin)
        a = _vec3(where, "axis", axis)
        r = _vec3(where, "ref", ref)
        r2 = _vec3(where, "ref2", ref2)
        o2 = _vec3(where, "origin2", origin2)
        a2 = _vec3(where, "axis2", axis2)
        if kname in ALIAS_AXES:
            da, dr = ALIAS_AXES[kname]
            if a is not None and np.linalg.norm(np.cross(_unit(where, "axis", a), da)) > 1e-9:
                raise InputError(
                    f"{where}: a {kname} turns or slides along global {kname[0].upper()}; "
                    f"use kind 'revolute' or 'prismatic' for the axis {_fmt(a)}"
                )
            a = np.asarray(da) if a is None else a
            r = np.asarray(dr) if r is None else r
        if frame1 is not None:
            F1 = _check_frame(name, "frame1", frame1)
        else:
            if o is None:
                raise InputError(f"{where}: give its origin (or frame1/frame2)")
            F1 = frame_from_axes(where, o, np.array([0.0, 0, 1]) if a is None else a, r)
        if frame2 is not None:
            F2 = _check_frame(name, "frame2", frame2)
        else:
            oo = o2 if o2 is not None else (o if o is not None else F1[:3, 3])
            aa = a2 if a2 is not None else (a if a is not None else F1[:3, 2])
            rr = r2 if r2 is not None else (r if r is not None else F1[:3, 0])
            F2 = frame_from_axes(where, oo, aa, rr)
        assert jt.make_consts is not None
        consts = jt.make_consts(name, dict(constants))
        for b in (b1, b2):
            self.add_body(b)
        j = Joint(name, jt, kname, b1, b2, F1, F2, consts, dict(constants))
        self.joints[name] = j
        return j

    def delete_joint(self, name: str) -> None:
        """Remove a joint (bodies and points stay)."""
        if name not in self.joints:
            raise InputError(f"joint {name!r} does not exist")
        del self.joints[name]
        for key in [k for k in self.joint_loads if k[0] == name]:
            del self.joint_loads[key]

    # ------------------------------------------------------------------ points
    def add_point(self, name: str, body: str, xyz: Vec) -> Point:
        """A point fixed in ``body`` at global ``xyz`` (modeling posture)."""
        name = self._check_name(name, "point")
        if name in self.points:
            raise InputError(f"point {name!r} already exists; choose another name")
        if body not in self.body_frames:
            raise InputError(
                f"point {name!r}: body {body!r} does not exist; "
                "name it in a joint (or add_body) before placing points on it"
            )
        p = _vec3(f"point {name!r}", "coordinates", xyz)
        assert p is not None
        pt = Point(name, body, p)
        self.points[name] = pt
        return pt

    # ------------------------------------------------------------ mass (ch 9)
    def set_units(self, units: str | massprops.Units) -> None:
        """Declare the unit system (``"SI"``, ``"in-lbf-s"``, ``"in-lbm"``, ...; see
        :data:`openimp.massprops.UNITS`): printed labels follow it and masses given
        afterwards are multiplied by its mass factor (IMP's lbm: 1/386.088 lbf s^2/in)."""
        self.units = massprops.units(units)
        self._units_named = True

    def set_gravity(self, g: Vec | None) -> None:
        """The gravity field, global axes, length/s^2 (``None`` removes it)."""
        self.gravity = None if g is None else _vec3("gravity", "the gravity vector", g)

    def _body_for_mass(self, body: str, what: str) -> str:
        if body not in self.body_frames:
            raise InputError(f"{what} of body {body!r}: the body does not exist; "
                             "name it in a joint (or add_body) first")
        return body

    def add_mass(
        self, body: str, mass: float, center: Vec | None = None, inertia: Any = None, *,
        axes: Any = None, about: str = "center", origin: Vec | None = None,
    ) -> list[str]:
        """Add mass properties to ``body`` (several contributions add; book 9.3).

        ``mass`` in the model's mass unit (times :attr:`units` ``.mass_factor``);
        ``center``: the centre of mass, global coordinates at the modeling
        posture (default the body frame's origin); ``inertia``: None (a point
        mass), three principal moments on ``axes`` or a 3x3 inertia tensor
        (engineering sign: off-diagonals are minus the products) on ``axes``
        (3x3 rotation, columns the axes; default global axes), about the centre
        of mass (``about="center"``) or about the point ``origin``
        (``about="origin"``).  Mass on the ground has no effect.  Returns the
        warnings of an inertia no rigid body has (triangle inequality), which
        are kept and reported, not refused (IMP uses such data as given).
        """
        body = self._body_for_mass(body, "mass")
        where = f"mass of body {body!r}"
        try:
            m = float(mass) * self.units.mass_factor
        except (TypeError, ValueError):
            raise InputError(f"{where}: the mass must be a number, got {mass!r}") from None
        c = _vec3(where, "centre", center)
        if c is None:
            c = self.body_frames[body][:3, 3].copy()
        o = _vec3(where, "origin", origin)
        I = None if inertia is None else np.asarray(inertia, dtype=float) * self.units.mass_factor
        try:
            J = massprops.pseudo_inertia(m, c, I, axes=axes, about=about, origin=o)
        except InputError as exc:
            raise InputError(f"{where}: {exc}") from None
        total = self.masses.get(body, np.zeros((4, 4))) + J
        warn = [f"{where}: {w}" for w in massprops.check_inertia(total)]
        self.masses[body] = total
        return warn

    def add_solid(self, body: str, kind: str, *, density: float, frame: Any = None,
                  **dims: float) -> list[str]:
        """Add the mass properties of a primitive solid of ``density`` to ``body``.

        ``kind``: box (a, b, c), cylinder (radius, length), tube (r_outer,
        r_inner, length), rod (length; density per length), disc (radius,
        thickness), sphere (radius); placed by ``frame`` (global 4x4 at the
        modeling posture: the solid's centre and axes; its axis along z).
        """
        body = self._body_for_mass(body, f"{kind} solid")
        maker = {"box": massprops.box, "cylinder": massprops.cylinder, "tube": massprops.tube,
                 "rod": massprops.rod, "disc": massprops.disc, "sphere": massprops.sphere}
        if kind not in maker:
            raise InputError(f"solid of body {body!r}: unknown kind {kind!r}; "
                             f"kinds are {', '.join(maker)}")
        F = np.eye(4) if frame is None else _check_frame(f"{kind} of {body}", "frame", frame)
        try:
            J = maker[kind](density=float(density) * self.units.mass_factor, frame=F, **dims)
        except TypeError as exc:
            raise InputError(f"{kind} solid of body {body!r}: {exc}") from None
        except InputError as exc:
            raise InputError(f"{kind} solid of body {body!r}: {exc}") from None
        self.masses[body] = self.masses.get(body, np.zeros((4, 4))) + J
        return []

    def clear_mass(self, body: str) -> None:
        """Remove every mass contribution of ``body``."""
        self.masses.pop(body, None)

    # ------------------------------------------------- springs, dampers, loads
    def _new_element(self, name: str) -> str:
        name = self._check_name(name, "element")
        if name in self.elements:
            raise InputError(f"element {name!r} already exists; choose another name")
        return name

    def _point(self, elem: str, p: str) -> str:
        if p not in self.points:
            known = ", ".join(self.points) or "none yet"
            raise InputError(f"{elem}: point {p!r} does not exist (points: {known}); "
                             "add it with add_point first")
        return p

    @staticmethod
    def _number(where: str, what: str, v: Any) -> float:
        try:
            x = float(v)
        except (TypeError, ValueError):
            raise InputError(f"{where}: {what} must be a number, got {v!r}") from None
        if not np.isfinite(x):
            raise InputError(f"{where}: {what} must be finite, got {v!r}")
        return x

    def _law(self, where: str, law: Any) -> Law | None:
        if law is not None and not callable(law):
            raise InputError(f"{where}: law must be a function of the load state, got {law!r}")
        return law

    def _two_points(self, kind: str, name: str, p1: str, p2: str) -> tuple[str, str]:
        where = f"{kind} {name!r}"
        p1, p2 = self._point(where, p1), self._point(where, p2)
        if p1 == p2:
            raise InputError(f"{where}: both ends are point {p1!r}; a {kind} needs two "
                             "different points")
        return p1, p2

    def add_spring(self, name: str, point1: str, point2: str, rate: float = 0.0,
                   free_length: float | None = None, *, law: Law | None = None) -> Element:
        """A linear spring between two points (book 9.8): tension ``rate * (length -
        free_length)`` (free length default: the length at the modeling posture), or
        ``law(s)`` -> tension."""
        name = self._new_element(name)
        where = f"spring {name!r}"
        p = self._two_points("spring", name, point1, point2)
        k = self._number(where, "the rate", rate)
        fl = None if free_length is None else self._number(where, "the free length",
                                                             free_length)
        if fl is not None and fl < 0:
            raise InputError(f"{where}: the free length must be >= 0, got {fl}")
        e = Element(name, "spring", p, k, fl, law=self._law(where, law))
        self.elements[name] = e
        return e

    def add_damper(self, name: str, point1: str, point2: str, coefficient: float = 0.0, *,
                   law: Law | None = None) -> Element:
        """A viscous damper between two points (book 9.9): tension ``coefficient *
        d length/dt``, or ``law(s)`` -> tension."""
        name = self._new_element(name)
        where = f"damper {name!r}"
        p = self._two_points("damper", name, point1, point2)
        e = Element(name, "damper", p, self._number(where, "the coefficient", coefficient),
                    law=self._law(where, law))
        self.elements[name] = e
        return e

    def _direction(self, where: str, direction: Vec | None, along: Sequence[str] | None
                   ) -> tuple[tuple[str, ...], np.ndarray | None]:
        if (direction is None) == (along is None):
            raise InputError(f"{where}: give either direction=(x, y, z) or along=(point_a, "
                             "point_b)")
        if direction is not None:
            d = _vec3(where, "direction", direction)
            assert d is not None
            return (), _unit(where, "direction", d)
        assert along is not None
        if isinstance(along, str) or len(along) != 2:
            raise InputError(f"{where}: along must be two point names, got {along!r}")
        a, b = self._point(where, along[0]), self._point(where, along[1])
        if a == b:
            raise InputError(f"{where}: the direction runs from point {a!r} to itself; "
                             "give two different points")
        return (a, b), None

    def add_force(self, name: str, point: str, magnitude: float = 0.0, *,
                  direction: Vec | None = None, along: Sequence[str] | None = None,
                  law: Law | None = None) -> Element:
        """A force at ``point`` (on its body) along a fixed global ``direction`` or from
        point ``along[0]`` toward ``along[1]`` (book 9.11); ``law(s)`` -> magnitude.
        The reaction goes to the ground."""
        name = self._new_element(name)
        where = f"force {name!r}"
        p = self._point(where, point)
        pts, d = self._direction(where, direction, along)
        e = Element(name, "force", (p, *pts), self._number(where, "the magnitude", magnitude),
                    direction=d, law=self._law(where, law))
        self.elements[name] = e
        return e

    def add_torque(self, name: str, body: str, magnitude: float = 0.0, *,
                   direction: Vec | None = None, along: Sequence[str] | None = None,
                   law: Law | None = None) -> Element:
        """A torque on ``body`` about a fixed global ``direction`` or about ``along[0]``
        -> ``along[1]`` (right-hand rule; book 9.11); ``law(s)`` -> magnitude."""
        name = self._new_element(name)
        where = f"torque {name!r}"
        if body not in self.body_frames:
            raise InputError(f"{where}: body {body!r} does not exist")
        pts, d = self._direction(where, direction, along)
        e = Element(name, "torque", pts, self._number(where, "the magnitude", magnitude),
                    body=body, direction=d, law=self._law(where, law))
        self.elements[name] = e
        return e

    def delete_element(self, name: str) -> None:
        """Remove a spring, damper, force or torque."""
        if name not in self.elements:
            raise InputError(f"element {name!r} does not exist")
        del self.elements[name]

    def _joint_load(self, joint: str, var: int | str | None, what: str) -> JointLoad:
        if joint not in self.joints:
            known = ", ".join(self.joints) or "none yet"
            raise InputError(f"{what} of joint {joint!r}: no such joint (joints: {known})")
        names = self.joints[joint].kind.var_names
        if var is None:
            if len(names) != 1:
                raise InputError(f"{what} of joint {joint!r}: it has {len(names)} variables "
                                 f"({', '.join(names)}); name one with var=")
            k = 0
        elif isinstance(var, str) and var in names:
            k = names.index(var)
        elif isinstance(var, int | np.integer) and 0 <= int(var) < len(names):
            k = int(var)
        else:
            raise InputError(f"{what} of joint {joint!r}: no variable {var!r}; its variables "
                             f"are {', '.join(names)}")
        if self.joints[joint].kind.var_kinds[k] == "er":
            raise InputError(f"{what} of joint {joint!r}: variable {names[k]!r} is an "
                             "Euler-Rodrigues parameter; springs and loads act on angles "
                             "and lengths")
        return self.joint_loads.setdefault((joint, k), JointLoad(joint, k))

    def set_joint_spring(self, joint: str, rate: float = 0.0, free: float | None = None, *,
                         var: int | str | None = None, law: Law | None = None,
                         periodic: bool = False) -> None:
        """A spring on a joint variable (book 9.6): force ``rate * (q - free)`` against
        q (rate per radian or per length; ``free`` default: the modeling posture).
        ``periodic``: an angle's ``free`` counts modulo a turn, the one nearest the
        joint's angle at the modeling posture is used (a ball's Cardan angle drawn at
        180 deg with a free angle of -180 deg carries no torque)."""
        jl = self._joint_load(joint, var, "spring")
        where = f"spring of joint {joint!r}"
        jl.rate = self._number(where, "the rate", rate)
        jl.free = None if free is None else self._number(where, "the free position", free)
        jl.periodic = bool(periodic)
        jl.spring_law = self._law(where, law)

    def set_joint_damper(self, joint: str, coefficient: float = 0.0, *,
                         var: int | str | None = None, law: Law | None = None) -> None:
        """A viscous damper on a joint variable (book 9.7): force ``coefficient * qd``
        against q."""
        jl = self._joint_load(joint, var, "damper")
        where = f"damper of joint {joint!r}"
        jl.damping = self._number(where, "the coefficient", coefficient)
        jl.damper_law = self._law(where, law)

    def set_joint_force(self, joint: str, force: float = 0.0, *, var: int | str | None = None,
                        law: Law | None = None) -> None:
        """A force or torque on a joint variable (book 9.10; IMP's DATA FORCE on a joint):
        an equal and opposite pair on the two bodies, positive when it tends to
        increase the variable."""
        jl = self._joint_load(joint, var, "load")
        where = f"load of joint {joint!r}"
        jl.force = self._number(where, "the load", force)
        jl.force_law = self._law(where, law)

    def __repr__(self) -> str:
        return (
            f"Model({self.name!r}: {len(self.bodies)} bodies, {len(self.joints)} joints, "
            f"{len(self.points)} points, ground {self.ground!r})"
        )

