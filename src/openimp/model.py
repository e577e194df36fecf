"""The user's description of a mechanism (book ch 4, 9): bodies, joints, points.

A :class:`Model` is mutable and validated as it is built: every misuse raises
:class:`~openimp.errors.InputError` naming the element and what to change.
All geometry is given in global coordinates at one *modeling posture*: body
frames coincide with the global frame there (unless :meth:`Model.set_body_frame`
moves one), joint frames and points are placed from global data.
:func:`openimp.compile` (:func:`openimp.system.compile_model`) turns it into the
immutable packed :class:`~openimp.system.System`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

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

    def __repr__(self) -> str:
        return (
            f"Model({self.name!r}: {len(self.bodies)} bodies, {len(self.joints)} joints, "
            f"{len(self.points)} points, ground {self.ground!r})"
        )

