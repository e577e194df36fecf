"""The joint catalogue (book ch 4, 6, 8; IMP's higher pairs).

Each joint kind has an integer code used inside the compiled kernels, its
variables (names and kinds: ``angle``, ``length`` or ``er`` for an
Euler-Rodrigues parameter), its constants, and four functions of its variables
``q`` and constants ``c``:

``joint_phi``  the joint matrix ``Phi(q)`` (primed frame in the unprimed one),
``joint_Q``    the first-derivative operators ``Q_g = (dPhi/dq_g) Phi^-1``,
``joint_dQ``   their derivatives ``Q_{g,i} = dQ_g/dq_i`` (book 8.2),
``extract``    the inverse: ``q`` from a measured ``Phi`` (used at assembly),

plus a conformity check of the two joint frames against the kind's
conventions.  ``Q`` is the definition (DESIGN.md), so every kind is tested
against central differences of its own ``Phi``.

Conventions that differ from the book's printed ones are documented at each
kind.  Lengths inside the kernels are internal (scaled) lengths; the
:class:`JointType` records which constants and variables are lengths so that
:mod:`openimp.system` can scale them.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from openimp._jit import njit
from openimp.errors import InputError

# --- integer codes dispatched inside the kernels -------------------------------
RIGID = 0
REVOLUTE = 1
PRISMATIC = 2
SCREW = 3
CYLINDER = 4
SPHERE = 5
FLAT = 6
OPEN = 7
GEAR = 8
RACK = 9
BEVEL = 10
POINT_CURVE = 11
LINE_CURVE = 12
CAM = 13
SLOT = 14
UJOINT = 15
SPHERE_PLANE = 16
SPHERE_GROOVE = 17

#: Largest number of variables of any joint (the open joint: 3 + 4).
MAXV = 7


# =============================================================================
# Small 4x4 helpers usable inside kernels
# =============================================================================
@njit
def _eye(out: np.ndarray) -> None:
    for i in range(4):
        for j in range(4):
            out[i, j] = 0.0
        out[i, i] = 1.0


@njit
def _rotz(out: np.ndarray, a: float) -> None:
    """Rotation about w by ``a`` into a 4x4 (translation left to the caller)."""
    ca = math.cos(a)
    sa = math.sin(a)
    _eye(out)
    out[0, 0] = ca
    out[0, 1] = -sa
    out[1, 0] = sa
    out[1, 1] = ca


@njit
def _er_rot(out: np.ndarray, e: np.ndarray, k: int) -> None:
    """Theta(e) of book (3.50) from e[k:k+4] into out[:3,:3]."""
    e1 = e[k]
    e2 = e[k + 1]
    e3 = e[k + 2]
    e4 = e[k + 3]
    out[0, 0] = e1 * e1 - e2 * e2 - e3 * e3 + e4 * e4
    out[0, 1] = 2.0 * (e1 * e2 - e3 * e4)
    out[0, 2] = 2.0 * (e1 * e3 + e2 * e4)
    out[1, 0] = 2.0 * (e1 * e2 + e3 * e4)
    out[1, 1] = -e1 * e1 + e2 * e2 - e3 * e3 + e4 * e4
    out[1, 2] = 2.0 * (e2 * e3 - e1 * e4)
    out[2, 0] = 2.0 * (e1 * e3 - e2 * e4)
    out[2, 1] = 2.0 * (e2 * e3 + e1 * e4)
    out[2, 2] = -e1 * e1 - e2 * e2 + e3 * e3 + e4 * e4


@njit
def _er_Q(out: np.ndarray, e: np.ndarray, k: int, g: int) -> None:
    """3x3 block of the Euler-Rodrigues operator Q^g (book 6.22) into out[:3,:3].

    Equal to (dTheta/de_g) Theta^T on the unit sphere |e| = 1.  The symmetric
    part (diagonal 2 e_g) is annihilated by the normalisation row.
    """
    e1 = 2.0 * e[k]
    e2 = 2.0 * e[k + 1]
    e3 = 2.0 * e[k + 2]
    e4 = 2.0 * e[k + 3]
    if g == 0:
        out[0, 0] = e1
        out[0, 1] = e2
        out[0, 2] = e3
        out[1, 0] = -e2
        out[1, 1] = e1
        out[1, 2] = -e4
        out[2, 0] = -e3
        out[2, 1] = e4
        out[2, 2] = e1
    elif g == 1:
        out[0, 0] = e2
        out[0, 1] = -e1
        out[0, 2] = e4
        out[1, 0] = e1
        out[1, 1] = e2
        out[1, 2] = e3
        out[2, 0] = -e4
        out[2, 1] = -e3
        out[2, 2] = e2
    elif g == 2:
        out[0, 0] = e3
        out[0, 1] = -e4
        out[0, 2] = -e1
        out[1, 0] = e4
        out[1, 1] = e3
        out[1, 2] = -e2
        out[2, 0] = e1
        out[2, 1] = e2
        out[2, 2] = e3
    else:
        out[0, 0] = e4
        out[0, 1] = e3
        out[0, 2] = -e2
        out[1, 0] = -e3
        out[1, 1] = e4
        out[1, 2] = e1
        out[2, 0] = e2
        out[2, 1] = -e1
        out[2, 2] = e4


@njit
def _er_dQ(out: np.ndarray, g: int, i: int) -> None:
    """3x3 block of Q^{g,i} = dQ^g/de_i (constant; book 8.13 with its sign repaired).

    Q^g is linear in e, so its derivative along e_i is Q^g evaluated at the
    i-th unit vector.
    """
    unit = np.zeros(4)
    unit[i] = 1.0
    _er_Q(out, unit, 0, g)


# =============================================================================
# Kernels: Phi, Q, dQ for every code
# =============================================================================
@njit
def joint_phi(code: int, q: np.ndarray, c: np.ndarray, out: np.ndarray) -> None:
    """Joint matrix Phi(q) of a joint of kind ``code`` with constants ``c``."""
    if code == REVOLUTE:
        _rotz(out, q[0])
    elif code == PRISMATIC:
        _eye(out)
        out[2, 3] = q[0]
    elif code == SCREW:
        _rotz(out, q[0] / c[0])
        out[2, 3] = q[0]
    elif code == CYLINDER:
        _rotz(out, q[0])
        out[2, 3] = q[1]
    elif code == SPHERE:
        _eye(out)
        _er_rot(out, q, 0)
    elif code == FLAT:
        _rotz(out, q[2])
        out[0, 3] = q[0]
        out[1, 3] = q[1]
    elif code == OPEN:
        _eye(out)
        _er_rot(out, q, 3)
        out[0, 3] = q[0]
        out[1, 3] = q[1]
        out[2, 3] = q[2]
    elif code >= GEAR:
        _higher_phi(code, q, c, out)
    else:  # RIGID
        _eye(out)


@njit
def joint_Q(code: int, q: np.ndarray, c: np.ndarray, out: np.ndarray) -> None:
    """Derivative operators Q_g (g = 0..nvar-1) into ``out[g]`` (shape (MAXV, 4, 4))."""
    nv = _nvar(code)
    for g in range(nv):
        for i in range(4):
            for j in range(4):
                out[g, i, j] = 0.0
    if code == REVOLUTE:
        out[0, 0, 1] = -1.0
        out[0, 1, 0] = 1.0
    elif code == PRISMATIC:
        out[0, 2, 3] = 1.0
    elif code == SCREW:
        out[0, 0, 1] = -1.0 / c[0]
        out[0, 1, 0] = 1.0 / c[0]
        out[0, 2, 3] = 1.0
    elif code == CYLINDER:
        out[0, 0, 1] = -1.0
        out[0, 1, 0] = 1.0
        out[1, 2, 3] = 1.0
    elif code == SPHERE:
        for g in range(4):
            _er_Q(out[g], q, 0, g)
    elif code == FLAT:
        out[0, 0, 3] = 1.0
        out[1, 1, 3] = 1.0
        out[2, 0, 1] = -1.0
        out[2, 1, 0] = 1.0
        out[2, 0, 3] = q[1]
        out[2, 1, 3] = -q[0]
    elif code == OPEN:
        out[0, 0, 3] = 1.0
        out[1, 1, 3] = 1.0
        out[2, 2, 3] = 1.0
        for g in range(4):
            _er_Q(out[3 + g], q, 3, g)
            for i in range(3):
                out[3 + g, i, 3] = -(
                    out[3 + g, i, 0] * q[0] + out[3 + g, i, 1] * q[1] + out[3 + g, i, 2] * q[2]
                )
    elif code >= GEAR:
        _higher_Q(code, q, c, out)


@njit
def joint_dQ(code: int, q: np.ndarray, c: np.ndarray, out: np.ndarray) -> None:
    """Second-derivative operators Q_{g,i} = dQ_g/dq_i into ``out[g, i]`` (MAXV, MAXV, 4, 4)."""
    nv = _nvar(code)
    for g in range(nv):
        for i in range(nv):
            for r in range(4):
                for s in range(4):
                    out[g, i, r, s] = 0.0
    if code == SPHERE:
        for g in range(4):
            for i in range(4):
                _er_dQ(out[g, i], g, i)
    elif code == FLAT:
        out[2, 0, 1, 3] = -1.0
        out[2, 1, 0, 3] = 1.0
    elif code == OPEN:
        for g in range(4):
            for i in range(4):
                _er_dQ(out[3 + g, 3 + i], g, i)
                blk = out[3 + g, 3 + i]
                for r in range(3):
                    blk[r, 3] = -(blk[r, 0] * q[0] + blk[r, 1] * q[1] + blk[r, 2] * q[2])
            # dQ^g/dp_i: column 4 is minus the i-th column of the 3x3 block of Q^g
            tmp = np.zeros((4, 4))
            _er_Q(tmp, q, 3, g)
            for i in range(3):
                for r in range(3):
                    out[3 + g, i, r, 3] = -tmp[r, i]
    elif code >= GEAR:
        _higher_dQ(code, q, c, out)


@njit
def _nvar(code: int) -> int:
    """Number of variables of a joint kind (must agree with :data:`CATALOGUE`)."""
    if code == RIGID:
        return 0
    if code == REVOLUTE or code == PRISMATIC or code == SCREW:
        return 1
    if code == CYLINDER:
        return 2
    if code == SPHERE:
        return 4
    if code == FLAT:
        return 3
    if code == OPEN:
        return 7
    return _higher_nvar(code)


# --- higher pairs: filled in by the higher-pair section below ------------------
@njit
def _higher_nvar(code: int) -> int:
    return 0


@njit
def _higher_phi(code: int, q: np.ndarray, c: np.ndarray, out: np.ndarray) -> None:
    _eye(out)


@njit
def _higher_Q(code: int, q: np.ndarray, c: np.ndarray, out: np.ndarray) -> None:
    return


@njit
def _higher_dQ(code: int, q: np.ndarray, c: np.ndarray, out: np.ndarray) -> None:
    return


# =============================================================================
# Python side: the catalogue, extraction and conformity
# =============================================================================
def _angle_of(Phi: np.ndarray) -> float:
    """Rotation angle about w of a 4x4 (book 4.11, robust atan2 form)."""
    return math.atan2(Phi[1, 0] - Phi[0, 1], Phi[0, 0] + Phi[1, 1])


def rotation_to_er(R: np.ndarray, eps: float = 1e-6) -> np.ndarray:
    """Euler-Rodrigues parameters of a rotation (book 3.51-3.55, e4 >= 0)."""
    from openimp.spatial import rotation_to_er as _r2e

    return np.asarray(_r2e(np.asarray(R, dtype=float)[:3, :3], eps=eps), dtype=float)


def _extract_lower(code: int, Phi: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Joint variables of a lower pair from its measured matrix (book 4.x extraction)."""
    if code == REVOLUTE:
        return np.array([_angle_of(Phi)])
    if code == PRISMATIC:
        return np.array([Phi[2, 3]])
    if code == SCREW:
        # The slide is the variable; the rotation must match slide/pitch modulo a turn,
        # so take the turn count that makes them agree best.
        return np.array([Phi[2, 3]])
    if code == CYLINDER:
        return np.array([_angle_of(Phi), Phi[2, 3]])
    if code == SPHERE:
        return rotation_to_er(Phi)
    if code == FLAT:
        return np.array([Phi[0, 3], Phi[1, 3], _angle_of(Phi)])
    if code == OPEN:
        return np.concatenate([Phi[:3, 3], rotation_to_er(Phi)])
    return np.zeros(0)


@dataclass(frozen=True)
class JointType:
    """One kind of joint: its variables, constants and conventions.

    ``var_kinds`` entries are ``"angle"``, ``"length"`` or ``"er"``;
    ``const_kinds`` entries are ``"length"`` (scaled with the model),
    ``"ratio"`` or ``"angle"`` (not scaled).  ``er_groups`` lists the index of
    the first of each block of four Euler-Rodrigues parameters, each of which
    adds one normalisation row to the Jacobian.
    """

    name: str
    code: int
    var_names: tuple[str, ...]
    var_kinds: tuple[str, ...]
    convention: str
    const_names: tuple[str, ...] = ()
    const_kinds: tuple[str, ...] = ()
    er_groups: tuple[int, ...] = ()
    #: builds the constants array from keyword arguments (validated); None: no constants
    make_consts: Callable[[str, dict[str, Any]], np.ndarray] | None = None
    #: q from a measured Phi (internal units); default: the lower-pair formulas
    extract: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None
    #: kinds whose first body has a mandatory role (rack, cam, slot, curves)
    order_note: str = ""
    aliases: tuple[str, ...] = field(default=())

    @property
    def nvar(self) -> int:
        """Number of joint variables."""
        return len(self.var_names)

    def extract_q(self, Phi: np.ndarray, c: np.ndarray) -> np.ndarray:
        """Joint variables from a measured joint matrix."""
        if self.extract is not None:
            return np.asarray(self.extract(Phi, c), dtype=float)
        return _extract_lower(self.code, Phi, c)


def _no_consts(name: str, kw: dict[str, Any]) -> np.ndarray:
    if kw:
        bad = ", ".join(sorted(kw))
        raise InputError(f"joint {name!r}: unexpected constant(s) {bad}; this kind takes none")
    return np.zeros(0)


def _screw_consts(name: str, kw: dict[str, Any]) -> np.ndarray:
    kw = dict(kw)
    if "lead" in kw:
        lead = float(kw.pop("lead"))
        pitch = lead / (2.0 * math.pi)
    elif "pitch" in kw:
        pitch = float(kw.pop("pitch"))
    else:
        raise InputError(
            f"screw joint {name!r}: give its lead (advance per turn, + right hand) "
            "as lead=..., or pitch=... (advance per radian)"
        )
    _no_consts(name, kw)
    if not math.isfinite(pitch) or abs(pitch) < 1e-300:
        raise InputError(
            f"screw joint {name!r}: lead must be a non-zero number; use a revolute for zero lead"
        )
    return np.array([pitch])


#: Every joint kind by name.  Aliases (xpin, zslide, ...) map to these entries;
#: the higher pairs are registered further below.
CATALOGUE: dict[str, JointType] = {}


def register(jt: JointType) -> None:
    """Add a joint kind (and its aliases) to :data:`CATALOGUE`."""
    for n in (jt.name, *jt.aliases):
        CATALOGUE[n] = jt


register(JointType("rigid", RIGID, (), (), "the two frames coincide",
                   make_consts=_no_consts))
register(JointType(
    "revolute", REVOLUTE, ("theta",), ("angle",),
    "w and w' on the axis, same sense, common origin; theta from u to u' about w",
    make_consts=_no_consts, aliases=("pin", "xpin", "ypin", "zpin"),
))
register(JointType(
    "prismatic", PRISMATIC, ("s",), ("length",),
    "w and w' collinear along the slide, same sense; u parallel u'; s from u to u' along w",
    make_consts=_no_consts, aliases=("slide", "prism", "xslide", "yslide", "zslide"),
))
register(JointType(
    "screw", SCREW, ("s",), ("length",),
    "w and w' on the axis, same sense; s = slide along w, rotation = s / pitch",
    const_names=("pitch",), const_kinds=("length",), make_consts=_screw_consts,
    aliases=("helical",),
))
register(JointType(
    "cylinder", CYLINDER, ("theta", "s"), ("angle", "length"),
    "w and w' on the common axis, same sense; theta about w, s along w",
    make_consts=_no_consts, aliases=("cylindric",),
))
register(JointType(
    "sphere", SPHERE, ("e1", "e2", "e3", "e4"), ("er", "er", "er", "er"),
    "common origin at the ball centre; Euler-Rodrigues parameters of u'v'w' in uvw",
    er_groups=(0,), make_consts=_no_consts, aliases=("spheric", "ball"),
))
register(JointType(
    "flat", FLAT, ("x", "y", "theta"), ("length", "length", "angle"),
    "uv and u'v' planes coincide, w and w' normal on the same side; x, y of the "
    "u'v'w' origin along u, v; theta from u to u' about w",
    make_consts=_no_consts, aliases=("plane", "planar"),
))
register(JointType(
    "open", OPEN, ("x", "y", "z", "e1", "e2", "e3", "e4"),
    ("length", "length", "length", "er", "er", "er", "er"),
    "no constraint: origin of u'v'w' in uvw and Euler-Rodrigues parameters",
    er_groups=(3,), make_consts=_no_consts,
))

#: default direction of w (and of u) for the axis-named aliases
ALIAS_AXES: dict[str, tuple[tuple[float, float, float], tuple[float, float, float]]] = {
    "xpin": ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0)),
    "ypin": ((0.0, 1.0, 0.0), (0.0, 0.0, 1.0)),
    "zpin": ((0.0, 0.0, 1.0), (1.0, 0.0, 0.0)),
    "xslide": ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0)),
    "yslide": ((0.0, 1.0, 0.0), (0.0, 0.0, 1.0)),
    "zslide": ((0.0, 0.0, 1.0), (1.0, 0.0, 0.0)),
}


def joint_type(kind: str) -> JointType:
    """The catalogue entry of a kind name (case-insensitive), or an InputError."""
    key = kind.lower()
    if key not in CATALOGUE:
        known = ", ".join(sorted(CATALOGUE))
        raise InputError(f"unknown joint kind {kind!r}; known kinds: {known}")
    return CATALOGUE[key]


def phi_of(jt: JointType, q: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Phi(q) as a new 4x4 array (Python convenience over :func:`joint_phi`)."""
    out = np.zeros((4, 4))
    joint_phi(jt.code, np.ascontiguousarray(q, dtype=float), np.ascontiguousarray(c, float), out)
    return out


def Q_of(jt: JointType, q: np.ndarray, c: np.ndarray) -> np.ndarray:
    """All Q_g as an (nvar, 4, 4) array."""
    out = np.zeros((MAXV, 4, 4))
    joint_Q(jt.code, np.ascontiguousarray(q, dtype=float), np.ascontiguousarray(c, float), out)
    return out[: jt.nvar].copy()


def dQ_of(jt: JointType, q: np.ndarray, c: np.ndarray) -> np.ndarray:
    """All Q_{g,i} as an (nvar, nvar, 4, 4) array."""
    out = np.zeros((MAXV, MAXV, 4, 4))
    joint_dQ(jt.code, np.ascontiguousarray(q, dtype=float), np.ascontiguousarray(c, float), out)
    n = jt.nvar
    return out[:n, :n].copy()


def conformity(
    jt: JointType, name: str, Phi: np.ndarray, c: np.ndarray, length_unit: float, tol: float
) -> np.ndarray:
    """Extract ``q`` from a measured ``Phi`` and check that ``Phi(q)`` reproduces it.

    Returns ``q``.  A mismatch means the two joint frames break the kind's
    conventions (a revolute whose axes do not coincide, a prismatic whose
    frames are rotated, ...); that is an :class:`InputError` naming the joint,
    the size of the mismatch and the convention to satisfy.
    """
    q = jt.extract_q(Phi, c)
    back = phi_of(jt, q, c)
    # the screw's rotation is only known modulo a turn: check it separately
    drot = float(np.max(np.abs(back[:3, :3] - Phi[:3, :3])))
    dpos = float(np.max(np.abs(back[:3, 3] - Phi[:3, 3])))
    if drot > tol or dpos > tol:
        ang = math.degrees(math.acos(max(-1.0, min(1.0, (np.trace(back[:3, :3].T @ Phi[:3, :3])
                                                         - 1.0) / 2.0))))
        raise InputError(
            f"joint {name!r} ({jt.name}): its two frames do not conform to the joint: "
            f"they differ by a rotation of {ang:.6g} deg and an offset of "
            f"{dpos * length_unit:.6g} length units that the joint cannot produce. "
            f"Convention: {jt.convention}. Check the joint's origin, axis and reference "
            f"directions (or frame1/frame2)."
        )
    return q
