"""IMP's 21 joint keywords mapped onto the openimp joint catalogue.

IMP names a joint by a keyword (docs/imp-language.md §7.2) and places its two
frames by the keyword's own DATA form or by two ``DATA LINK`` statements
(docs/imp-language.md §8.1).  This module holds, for every keyword:

* the openimp catalogue kind it becomes and the fixed re-labelling of the axes
  (an IMP ``XPIN`` turns about its *u* axis, an openimp revolute about *w*, so
  the openimp frame is the IMP frame with its axes permuted);
* the frame rules of its DATA form (:func:`placement_frames`);
* its IMP joint variables (angles in degrees in decks and listings, lengths in
  model units), how each maps onto an openimp variable for driving
  (:attr:`ImpJoint.drive`), and the conversion of openimp variables and their
  rates to IMP's (:func:`imp_variables`): Cardan angles x-y'-z'' for SPHERE and
  OPEN (docs/imp-language.md §7.2, confirmed by ch9), the polar form of FLAT,
  the single variable of GEAR, RACK and BEVEL.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from openimp import spatial as sp
from openimp.errors import InputError
from openimp.joints import CATALOGUE
from openimp.joints.cardan import cardan_angles

__all__ = [
    "IMP_DIRECT",
    "IMP_JOINTS",
    "ImpJoint",
    "cardan_angular_velocity",
    "cardan_to_er",
    "drivable",
    "frame_w",
    "imp_variables",
    "placement_frames",
]

Vec = np.ndarray

_X = np.array([1.0, 0.0, 0.0])
_Y = np.array([0.0, 1.0, 0.0])
_Z = np.array([0.0, 0.0, 1.0])


def _perm(cols: Sequence[int]) -> np.ndarray:
    """4x4 re-labelling: openimp axis k is IMP axis ``cols[k]``."""
    P = np.eye(4)
    P[:3, :3] = 0.0
    for k, c in enumerate(cols):
        P[c, k] = 1.0
    return P


_ID = np.eye(4)
_PERM_X = _perm((1, 2, 0))  # openimp (u, v, w) = IMP (v, w, u): axis along IMP u
_PERM_Y = _perm((2, 0, 1))  # openimp (u, v, w) = IMP (w, u, v): axis along IMP v


@dataclass(frozen=True)
class ImpJoint:
    """One IMP joint keyword.

    Attributes:
        keyword: the IMP keyword (``ZPIN``).
        kind: the openimp catalogue kind it becomes.
        var_kinds: ``angle`` or ``length`` per IMP joint variable.
        perm: 4x4 matrix taking the IMP joint frame to the openimp one
            (``F_openimp = F_imp @ perm``).
        drive: per IMP variable, ``(openimp variable index, sign)`` when the
            variable can be an SGC, else ``None``.
        data_form: True when the keyword has its own ``DATA <keyword>`` form.
        params: the ``DATA`` statement that gives its constants (``DATA GEAR``),
            required at EXECUTE, or ``""``.
        cardan: the index of the first of its three Cardan angles among the IMP
            variables, which is also that of e1 among the openimp ones (SPHERE 0,
            OPEN 3), or -1.
    """

    keyword: str
    kind: str
    var_kinds: tuple[str, ...]
    perm: np.ndarray
    drive: tuple[tuple[int, float] | None, ...]
    data_form: bool = True
    params: str = ""
    cardan: int = -1

    @property
    def nvar(self) -> int:
        """Number of IMP joint variables."""
        return len(self.var_kinds)

    def is_cardan(self, k: int) -> bool:
        """True when IMP variable ``k`` (0-based) is one of the joint's Cardan angles."""
        return self.cardan >= 0 and self.cardan <= k < self.cardan + 3

    @property
    def available(self) -> bool:
        """True when the openimp catalogue has the kind this keyword needs."""
        return self.kind in CATALOGUE


_A, _L = "angle", "length"

#: Every IMP joint keyword (docs/imp-language.md §7.2).
IMP_JOINTS: dict[str, ImpJoint] = {
    "RIGID": ImpJoint("RIGID", "rigid", (), _ID, ()),
    "XPIN": ImpJoint("XPIN", "revolute", (_A,), _PERM_X, ((0, 1.0),)),
    "YPIN": ImpJoint("YPIN", "revolute", (_A,), _PERM_Y, ((0, 1.0),)),
    "ZPIN": ImpJoint("ZPIN", "revolute", (_A,), _ID, ((0, 1.0),)),
    "REVOLUTE": ImpJoint("REVOLUTE", "revolute", (_A,), _ID, ((0, 1.0),)),
    "XSLIDE": ImpJoint("XSLIDE", "prismatic", (_L,), _PERM_X, ((0, 1.0),)),
    "YSLIDE": ImpJoint("YSLIDE", "prismatic", (_L,), _PERM_Y, ((0, 1.0),)),
    "ZSLIDE": ImpJoint("ZSLIDE", "prismatic", (_L,), _ID, ((0, 1.0),)),
    "PRISM": ImpJoint("PRISM", "prismatic", (_L,), _ID, ((0, 1.0),)),
    "GEAR": ImpJoint("GEAR", "gear", (_A,), _ID, ((0, 1.0),), False, "DATA GEAR"),
    "BEVEL": ImpJoint("BEVEL", "bevel", (_A,), _ID, ((0, -1.0),), False, "DATA BEVEL"),
    "RACK": ImpJoint("RACK", "rack", (_L,), _ID, ((0, 1.0),), False, "DATA RACK"),
    "SCREW": ImpJoint("SCREW", "screw", (_L,), _ID, ((0, 1.0),), False, "DATA SCREW"),
    "CAM": ImpJoint("CAM", "cam", (_A, _A), _ID, ((0, 1.0), (1, 1.0)), False, "DATA CAM"),
    "SLOT": ImpJoint("SLOT", "slot", (_L, _A), _ID, ((0, 1.0), (1, 1.0)), False, "DATA SLOT"),
    "CYLINDER": ImpJoint("CYLINDER", "cylinder", (_A, _L), _ID, ((0, 1.0), (1, 1.0))),
    "UJOINT": ImpJoint("UJOINT", "ujoint", (_A, _A), _ID, ((0, 1.0), (1, 1.0))),
    "FLAT": ImpJoint("FLAT", "flat", (_A, _L, _A), _ID, (None, None, None), False),
    "PLANE": ImpJoint("PLANE", "flat", (_L, _L, _A), _ID, ((0, 1.0), (1, 1.0), (2, 1.0)),
                      False),
    "SPHERE": ImpJoint("SPHERE", "sphere", (_A, _A, _A), _ID, (None, None, None),
                       cardan=0),
    "OPEN": ImpJoint("OPEN", "open", (_L, _L, _L, _A, _A, _A), _ID,
                     ((0, 1.0), (1, 1.0), (2, 1.0), None, None, None), False, cardan=3),
}

#: IMP's SPHERE, OPEN and FLAT with IMP's own variables as the solver's coordinates
#: (:mod:`openimp.joints.cardan`): the kind a deck's joint becomes when the deck puts a
#: spring, damper, load, motion or initial condition on a variable the default kind
#: does not have (its Cardan angles, FLAT's polar form).  The defaults stay otherwise:
#: their Euler-Rodrigues parameters never lock, their (x, y) have no pole at r = 0.
IMP_DIRECT: dict[str, ImpJoint] = {
    "SPHERE": ImpJoint("SPHERE", "gimbal", (_A, _A, _A), _ID,
                       ((0, 1.0), (1, 1.0), (2, 1.0))),
    "OPEN": ImpJoint("OPEN", "open_cardan", (_L, _L, _L, _A, _A, _A), _ID,
                     tuple((k, 1.0) for k in range(6)), False),
    "FLAT": ImpJoint("FLAT", "flat_polar", (_A, _L, _A), _ID, ((0, 1.0), (1, 1.0), (2, 1.0)),
                     False),
}


def drivable(keyword: str, k: int) -> bool:
    """True when IMP variable ``k`` (0-based) of a ``keyword`` joint can carry a load, a
    motion or an initial condition (in the default kind or in :data:`IMP_DIRECT`'s)."""
    ij = IMP_DIRECT.get(keyword, IMP_JOINTS[keyword])
    return k < ij.nvar and ij.drive[k] is not None


# =============================================================================
# Frames
# =============================================================================
def _unit(v: Vec) -> Vec | None:
    n = float(np.linalg.norm(v))
    return None if n < 1e-12 else v / n


def _square(axis: Vec, ref: Vec | None, fallback: Vec) -> Vec:
    """``ref`` squared off against the unit ``axis``; ``fallback`` (then x, y)
    when it is missing or along the axis."""
    for cand in (ref, fallback, _X, _Y):
        if cand is None:
            continue
        p = cand - float(cand @ axis) * axis
        n = float(np.linalg.norm(p))
        if n > 1e-9 * max(1.0, float(np.linalg.norm(cand))):
            return p / n
    raise AssertionError("no perpendicular found")  # pragma: no cover


def _frame(origin: Vec, axes: dict[str, Vec]) -> np.ndarray:
    T = np.eye(4)
    T[:3, 0], T[:3, 1], T[:3, 2] = axes["u"], axes["v"], axes["w"]
    T[:3, 3] = origin
    return T


def frame_w(p1: Vec, p2: Vec | None, p3: Vec | None, what: str) -> np.ndarray:
    """IMP's three-point frame: origin ``p1``, +w toward ``p2``, +u in the
    half-plane of ``p3`` (squared off).  A missing ``p2``/``p3`` is the global
    origin (docs/imp-language.md §8.1); a ``p3`` on the w axis falls back to
    global x (or y)."""
    o = np.asarray(p1, float)
    w = _unit((np.zeros(3) if p2 is None else np.asarray(p2, float)) - o)
    if w is None:
        raise InputError(f"{what}: the point on +w coincides with the origin "
                         f"{tuple(float(x) for x in o)}; give a point on the axis away from it")
    ref = (np.zeros(3) if p3 is None else np.asarray(p3, float)) - o
    u = _square(w, ref, _X)
    return _frame(o, {"u": u, "v": np.cross(w, u), "w": w})


def _pin_frame(origin: Vec, axis: str, ref: Vec | None) -> np.ndarray:
    """A pin frame with ``axis`` (u, v or w) along the global axis of that name
    and the next axis toward ``ref`` (global-parallel when missing)."""
    if axis == "u":
        a, nxt = _X, _square(_X, ref, _Y)
        return _frame(origin, {"u": a, "v": nxt, "w": np.cross(a, nxt)})
    if axis == "v":
        a, nxt = _Y, _square(_Y, ref, _Z)
        return _frame(origin, {"v": a, "w": nxt, "u": np.cross(a, nxt)})
    a, nxt = _Z, _square(_Z, ref, _X)
    return _frame(origin, {"w": a, "u": nxt, "v": np.cross(a, nxt)})


def placement_frames(keyword: str, points: Sequence[Vec | None],
                     what: str) -> tuple[np.ndarray, np.ndarray]:
    """The two IMP joint frames (global 4x4) of a ``DATA <keyword>`` statement.

    ``points`` are the statement's point slots in global coordinates, ``None``
    for a missing one.  The rules are those of docs/imp-language.md §8.1; for X/Y/ZPIN a
    missing second or third point (including a zero-filled ``0,0,0``, as ch9
    requires) leaves that axis parallel to the global one.
    """
    pts = list(points)
    o = np.asarray(pts[0] if pts[0] is not None else np.zeros(3), float)

    def rel(p: Vec | None) -> Vec | None:
        return None if p is None else np.asarray(p, float) - o

    if keyword in ("XPIN", "YPIN", "ZPIN"):
        axis = {"XPIN": "u", "YPIN": "v", "ZPIN": "w"}[keyword]
        return _pin_frame(o, axis, rel(pts[1])), _pin_frame(o, axis, rel(pts[2]))
    if keyword in ("XSLIDE", "YSLIDE", "ZSLIDE", "SPHERE"):
        T = np.eye(4)
        T[:3, 3] = o
        return T, T.copy()
    if keyword == "REVOLUTE":
        F1 = frame_w(o, pts[1], pts[2], what)
        F2 = frame_w(o, pts[1], pts[3], what)
        return F1, F2
    if keyword in ("RIGID", "PRISM", "CYLINDER"):
        F = frame_w(o, pts[1], pts[2], what)
        return F, F.copy()
    if keyword == "UJOINT":
        w1 = _unit((np.zeros(3) if pts[1] is None else np.asarray(pts[1], float)) - o)
        w2 = _unit((np.zeros(3) if pts[2] is None else np.asarray(pts[2], float)) - o)
        if w1 is None or w2 is None:
            raise InputError(f"{what}: the points on the two pins must differ from the centre "
                             f"{tuple(float(x) for x in o)}")
        t = _unit(np.cross(w1, w2))
        if t is None:
            raise InputError(f"{what}: the two cross pins (centre to P2, centre to P3) are "
                             "parallel; a UJOINT's pins are perpendicular")
        F1 = _frame(o, {"u": t, "v": np.cross(w1, t), "w": w1})
        F2 = _frame(o, {"u": t, "v": np.cross(w2, t), "w": w2})
        return F1, F2
    raise InputError(f"{what}: there is no DATA {keyword} form")  # pragma: no cover


def bevel_frames(F1: np.ndarray, F2: np.ndarray, what: str) -> tuple[np.ndarray, np.ndarray]:
    """openimp bevel frames from IMP's: u and u' along t = w x w' at the modeling posture.

    IMP places u in the plane of the two axes (toward the pitch point) where the
    openimp bevel starts with u along t; only the w axes and origins are kept.
    """
    t = _unit(np.cross(F1[:3, 2], F2[:3, 2]))
    if t is None:
        raise InputError(f"{what}: the two bevel axes w and w' are parallel")
    G1, G2 = F1.copy(), F2.copy()
    for G in (G1, G2):
        G[:3, 0] = t
        G[:3, 1] = np.cross(G[:3, 2], t)
    return G1, G2


# =============================================================================
# Joint variables
# =============================================================================
def _cardan(R: np.ndarray) -> np.ndarray:
    """(steps, 3) angles a, b, c with R = Rx(a) Ry(b) Rz(c), unwrapped along the steps
    (the gimbal kind's extraction, :func:`openimp.joints.cardan.cardan_angles`)."""
    out = cardan_angles(R)
    return np.unwrap(out, axis=0) if len(out) > 1 else out


def _cardan_axes(ang: np.ndarray) -> np.ndarray:
    """(steps, 3, 3): the columns are the axes of the three Cardan turns of ``ang``
    (steps, 3) in the first frame, x, Rx(a) y, Rx(a) Ry(b) z: the relative angular
    velocity of R = Rx(a) Ry(b) Rz(c) in the first frame is E (a', b', c')."""
    a, b = ang[:, 0], ang[:, 1]
    Rx = sp.rot_x(a)[:, :3, :3]
    e1 = np.broadcast_to(_X, (len(a), 3))
    e2 = Rx[:, :, 1]
    e3 = np.einsum("sij,sj->si", Rx @ sp.rot_y(b)[:, :3, :3], np.broadcast_to(_Z, (len(a), 3)))
    return np.stack([e1, e2, e3], axis=2)


def cardan_to_er(ang: np.ndarray, near: np.ndarray) -> np.ndarray:
    """The Euler-Rodrigues parameters (4,) of R = Rx(a) Ry(b) Rz(c), ``ang`` = (a, b, c)
    in radians: the product of the three turns' parameters (3.57), of the sign nearer
    ``near`` (4,) (the joint's present parameters: the posture moves continuously)."""
    e = sp.quat_multiply(sp.quat_multiply(sp.axis_angle_to_er(_X, ang[0]),
                                          sp.axis_angle_to_er(_Y, ang[1])),
                         sp.axis_angle_to_er(_Z, ang[2]))
    return -e if float(e @ near) < 0.0 else e


def cardan_angular_velocity(ang: np.ndarray, rate: np.ndarray) -> np.ndarray:
    """The relative angular velocity (3,) in the first frame (rad/s) of Cardan angles
    ``ang`` (3,) (radians) turning at ``rate`` (3,): the inverse of the conversion of
    :func:`imp_variables`, omega = x a' + Rx(a) y b' + Rx(a) Ry(b) z c'."""
    return _cardan_axes(np.asarray(ang, float)[None, :])[0] @ np.asarray(rate, float)


def _cardan_rates(e: np.ndarray, ed: np.ndarray | None, edd: np.ndarray | None
                  ) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None]:
    """Cardan angles of ER parameters and their first and second time derivatives."""
    ang = _cardan(sp.er_to_rotation(e))
    if ed is None or edd is None:
        return ang, None, None
    # relative angular velocity / acceleration in the first frame:
    # omega = 2 vec(e' (x) e*), alpha = 2 vec(e'' (x) e*) (unit quaternion)
    n2 = np.sum(e * e, axis=1, keepdims=True)
    omega = 2.0 * sp.quat_multiply(ed, sp.quat_conjugate(e))[:, :3] / n2
    alpha = 2.0 * sp.quat_multiply(edd, sp.quat_conjugate(e))[:, :3] / n2
    E = _cardan_axes(ang)
    e1, e2, e3 = E[:, :, 0], E[:, :, 1], E[:, :, 2]
    rate = np.linalg.solve(E, omega[..., None])[..., 0]
    ad, bd = rate[:, 0:1], rate[:, 1:2]
    cd = rate[:, 2:3]
    edot = (bd * np.cross(ad * e1, e2)
            + cd * np.cross(ad * e1 + bd * e2, e3))
    acc = np.linalg.solve(E, (alpha - edot)[..., None])[..., 0]
    return ang, rate, acc


def imp_variables(
    ij: ImpJoint, q: np.ndarray, qd: np.ndarray | None, qdd: np.ndarray | None
) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None]:
    """IMP joint variables from the openimp ones (steps x nvar arrays, radians/lengths).

    ``q``, ``qd``, ``qdd`` are the openimp variables of the joint and their
    time derivatives (``qd``/``qdd`` may be None).  Returns the IMP variables
    and their derivatives in the same form.
    """
    kw = ij.keyword
    n = q.shape[0]
    if ij.cardan >= 0:
        k = ij.cardan
        ang, rate, acc = _cardan_rates(q[:, k:k + 4], None if qd is None else qd[:, k:k + 4],
                                       None if qdd is None else qdd[:, k:k + 4])
        if kw == "SPHERE":
            return ang, rate, acc
        p = np.concatenate([q[:, :3], ang], axis=1)
        v = None if rate is None or qd is None else np.concatenate([qd[:, :3], rate], axis=1)
        a = None if acc is None or qdd is None else np.concatenate([qdd[:, :3], acc], axis=1)
        return p, v, a
    if ij.kind == "flat":  # IMP's polar form of the (x, y, theta) of the default kind
        x, y, th = q[:, 0], q[:, 1], q[:, 2]
        r = np.hypot(x, y)
        p1 = np.unwrap(np.arctan2(y, x)) if n > 1 else np.arctan2(y, x)
        p = np.stack([p1, r, th - p1], axis=1)
        if qd is None or qdd is None:
            return p, None, None
        xd, yd, thd = qd[:, 0], qd[:, 1], qd[:, 2]
        xdd, ydd, thdd = qdd[:, 0], qdd[:, 1], qdd[:, 2]
        rs = np.where(r > 0, r, np.nan)
        rd = (x * xd + y * yd) / rs
        p1d = (x * yd - y * xd) / rs**2
        rdd = (xd * xd + yd * yd + x * xdd + y * ydd) / rs - rd * rd / rs
        p1dd = (x * ydd - y * xdd) / rs**2 - 2.0 * rd * p1d / rs
        v = np.stack([p1d, rd, thd - p1d], axis=1)
        a = np.stack([p1dd, rdd, thdd - p1dd], axis=1)
        return p, v, a
    idx = [d[0] if d is not None else 0 for d in ij.drive]
    sign = np.array([d[1] if d is not None else 1.0 for d in ij.drive])
    if not idx:
        z = np.zeros((n, 0))
        return z, (None if qd is None else z), (None if qdd is None else z)
    p = q[:, idx] * sign
    v = None if qd is None else qd[:, idx] * sign
    a = None if qdd is None else qdd[:, idx] * sign
    return p, v, a


def to_degrees(ij: ImpJoint, values: np.ndarray) -> np.ndarray:
    """Angles of IMP variables (last axis) from radians to degrees."""
    out = np.array(values, dtype=float, copy=True)
    for k, kind in enumerate(ij.var_kinds):
        if kind == "angle":
            out[..., k] = np.degrees(out[..., k])
    return out


def deg_or_len(kind: str, value: float) -> float:
    """A deck value of a joint variable in internal form (degrees -> radians)."""
    return math.radians(value) if kind == "angle" else value
