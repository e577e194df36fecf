"""The joint catalogue (book ch 4, 6, 8; IMP's higher pairs).

Each joint kind has an integer code used inside the compiled kernels, its
variables (names and kinds: ``angle``, ``length`` or ``er`` for an
Euler-Rodrigues parameter), its constants, one compiled evaluation of its
variables ``q`` and constants ``c``
(:func:`openimp.joints.calc.joint_calc`: the joint matrix ``Phi(q)``, primed
frame in the unprimed one, the first-derivative operators
``Q_g = (dPhi/dq_g) Phi^-1`` and their derivatives ``Q_{g,i} = dQ_g/dq_i``,
book 8.2, together) and ``extract``, the inverse: ``q`` from a measured
``Phi`` (used at assembly),

plus a conformity check of the two joint frames against the kind's
conventions.  ``Q`` is the definition (docs/architecture.md, Conventions), so
every kind is tested against central differences of its own ``Phi``.

Conventions that differ from the book's printed ones are documented at each
kind.  Lengths inside the kernels are internal (scaled) lengths; the
:class:`JointType` records which constants and variables are lengths so that
:mod:`openimp.system` can scale them.

Higher pairs
------------
Every higher pair is placed with :meth:`openimp.model.Model.add_joint`: ``origin``,
``axis`` (w) and ``ref`` (u) give the first frame, ``origin2``, ``axis2`` (w') and
``ref2`` (u') the second (each defaults to the first frame's), or ``frame1`` /
``frame2`` give both; the remaining keywords are the kind's constants (angles in
radians, lengths in model units).  The first body is the one named first.

``gear`` (book 4.6.9), variables ``phi1`` (angle), ``phi2``, ``phi3`` (lengths).
    w, w' on the two gear axes, parallel, same sense; ``origin``/``origin2`` on the
    axes, in the gears' mid planes; t = common perpendicular from w to w'; at the
    modeling posture u, u' and t parallel (phi1 = 0; whole turns of t are found).
    phi1 = angle u -> t about w, phi2 = centre distance beyond nominal, phi3 = offset
    of the u'v' plane along w.  Constants: ``radius1=``, ``radius2=`` (signed pitch
    radii, negative = internal gear) or IMP's ``ratio=`` (first / second, + external,
    - internal) with ``distance=`` (centre distance; omitted: taken from the frames),
    ``pressure_angle=`` (20 deg), ``helix_angle=`` (0), ``load_sign=`` (0).  The load
    sign sgn(F) of (4.28) starts at that value in a :class:`~openimp.system.State`
    (0 for kinematics) and is set there to +-1 by force analysis, never in the model.
    Internal pairs: the second axis is at +|R + R'| along t (the book's signed R + R'
    would put it at -|R + R'|, which its own extraction (4.29) does not invert).
``rack`` (4.6.10), ``phi1``, ``phi2``, ``phi3`` (lengths).  First body = rack.  u
    along the pitch line, w along the pinion axis, ``origin`` on the pitch line,
    ``origin2`` at the pinion centre; u' parallel to u when the pinion centre is on
    the v axis.  Pinion centre = (phi1, R' + phi2, phi3); theta = -(phi1 + sgn(F)
    phi2 tan a - phi3 tan b)/R'.  Constants ``radius=`` (signed: + pinion on the +v
    side), ``pressure_angle=``, ``helix_angle=``, ``load_sign=`` (initial
    value of the state's sign, as for the gear).
``bevel`` (4.6.11), ``phi1``, ``phi2`` (angles).  w, w' along the gear axes pointing
    away from the common apex, ``ref`` = ``ref2`` = t = w x w' at phi1 = 0.
    Constants ``gamma1=``, ``gamma2=`` (pitch-cone half-angles; frames at the apex)
    or IMP's ``ratio=`` (> 0; ``shaft_angle=``, default 90 deg); ``radius=`` (pitch
    radius of the second gear) puts the frames at the pitch-circle centres.
    **Decision:** pitch cones roll without slip, phi' = -(sin g1/sin g2) phi1 =
    -(R1/R2) phi1 (docs/kinematics.md, "Joint kinds": with the book's ratio of
    (4.34) the pitch cones slip); ``book_ratio=True`` gives the book's / IMP's
    +(tan g1/tan g2) phi1.  The (1,1) entry of (4.34) is corrected.
``point_curve`` (4.6.12), ``t`` (curve parameter, unscaled), ``phi2`` (angle),
    ``phi3`` (length).  First body carries the curve (u(t), v(t)) in its uv plane,
    ``origin2`` = the point, on the curve.  ``line_curve`` (4.6.13): ``t``, ``phi2``
    (distance along +u' from the u'v'w' origin to the contact), ``phi3``; u' along
    the curve's tangent (corrected theta' and Q1 of 6.29).  Curve constants:
    ``curve=f`` (callable t -> (u, v, du, dv, d2u, d2v, d3u, d3v)), ``table=[[u, v],
    ...]`` (equally spaced in t over ``period=`` (2 pi; periodic cubic spline,
    ``closed=True`` if the last row repeats the first) or over ``range=(t0, t1)``
    (not-a-knot spline)), or ``fourier=((au, bu), (av, bv))`` (f = a0 + sum a_k cos
    k w t + b_k sin k w t, w = 2 pi / period).  Tables and Fourier series are stored
    as numbers in the constants and evaluated in nopython mode; callables are
    registered (:func:`register_curve`) and called back through a numba ``objmode``
    block.  :func:`curve_parameter` is the numeric inverse used at assembly.
``cam`` (IMP), ``phi1``, ``phi2`` (angles).  First body = cam.  w, w' normal to the
    pitch-curve plane; ``origin`` on the cam axis, ``origin2`` on the pitch curve;
    phi1 = angle u -> t (t from the cam origin to the follower origin), phi2 = angle
    t -> u'.  Pitch-curve radius r(phi1) over one turn: ``table=[r, ...]`` (n values
    at 2 pi k / n; ``closed=True`` if the last repeats the first;
    ``interpolation="fourier"`` for IMP's trigonometric interpolation instead of the
    periodic cubic spline), ``fourier=(a, b)`` or ``function=f`` (t -> (r, dr, d2r,
    d3r)).
``slot`` (IMP), ``u`` (length), ``phi2`` (angle).  First body = slotted link.  The
    follower origin runs on the centreline v = f(u): ``table=[v, ...]`` equally spaced
    over ``range=(u_start, u_end)`` (both ends sampled) or ``function=f``.
``ujoint`` (IMP's UJOINT), ``phi1``, ``phi2``.  Common origin; ``axis`` = pin of
    the first body, ``axis2`` = pin of the second, perpendicular; t = w x w'; phi1 =
    angle u -> t about w, phi2 = angle t -> u' about w'.
``sphere_plane``, ``x``, ``y`` (lengths), ``e1..e4`` (Euler-Rodrigues, one
    normalisation row).  Ball fixed in the second body on a plane of the first;
    ``origin`` = ball centre, ``axis`` = plane normal from the plane toward the ball.
``sphere_groove``, ``s`` (length), ``e1..e4``.  Ball in a straight groove of the
    first body; ``origin`` = ball centre, ``ref`` = u along the groove.
``gimbal`` (``a``, ``b``, ``c``), ``open_cardan`` (``x``, ``y``, ``z``, ``a``, ``b``,
    ``c``), ``flat_polar`` (``phi1``, ``r``, ``phi2``): IMP's SPHERE, OPEN and FLAT
    with IMP's variables as coordinates (Cardan angles x-y'-z'', the polar form),
    so springs, dampers, loads, motions and initial conditions act on them as IMP's
    do (:mod:`openimp.joints.cardan`); singular where IMP's are (b = +-90 deg, r = 0).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from openimp.errors import InputError
from openimp.joints.calc import joint_calc
from openimp.joints.cardan import extract_flat_polar, extract_gimbal, extract_open_cardan
from openimp.joints.codes import (
    BEVEL,
    CAM,
    CLOSED_FORM,
    CYLINDER,
    FLAT,
    FLAT_POLAR,
    GEAR,
    GEAR_LOAD_SIGN_SLOT,
    GIMBAL,
    LINE_CURVE,
    MAXV,
    OPEN,
    OPEN_CARDAN,
    POINT_CURVE,
    PRISMATIC,
    RACK,
    RACK_LOAD_SIGN_SLOT,
    REVOLUTE,
    RIGID,
    SCREW,
    SLOT,
    SPHERE,
    SPHERE_GROOVE,
    SPHERE_PLANE,
    UJOINT,
)
from openimp.joints.curves import ConstArgs, curve_consts
from openimp.joints.higher import (
    bevel_consts,
    cam_consts,
    extract_bevel,
    extract_cam,
    extract_gear,
    extract_line_curve,
    extract_point_curve,
    extract_rack,
    extract_slot,
    extract_sphere_groove,
    extract_sphere_plane,
    extract_ujoint,
    gear_complete,
    gear_consts,
    rack_consts,
    slot_consts,
)
from openimp.joints.lower import closed_phi, extract_lower


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
    #: fills, in place, constants that depend on the modeling posture (a gear's centre
    #: distance taken from its frames); called by :func:`conformity` before extraction
    #: with (joint name, measured Phi, internal constants)
    complete: Callable[[str, np.ndarray, np.ndarray], None] | None = None

    @property
    def nvar(self) -> int:
        """Number of joint variables."""
        return len(self.var_names)

    def load_sign(self, c: np.ndarray) -> float:
        """The initial load sign sgn(F) of a gear or rack from its constants (0 otherwise)."""
        if self.code == GEAR:
            return float(c[GEAR_LOAD_SIGN_SLOT])
        if self.code == RACK:
            return float(c[RACK_LOAD_SIGN_SLOT])
        return 0.0

    def extract_q(self, Phi: np.ndarray, c: np.ndarray) -> np.ndarray:
        """Joint variables from a measured joint matrix."""
        if self.extract is not None:
            return np.asarray(self.extract(Phi, c), dtype=float)
        return extract_lower(self.code, Phi, c)


def _no_consts(name: str, kw: dict[str, Any]) -> np.ndarray:
    if kw:
        bad = ", ".join(sorted(kw))
        raise InputError(f"joint {name!r}: unexpected constant(s) {bad}; this kind takes none")
    return np.zeros(0)


def _screw_consts(name: str, kw: dict[str, Any]) -> np.ndarray:
    args = ConstArgs(name, "screw", kw, ("lead", "pitch"))
    if args.has("lead"):
        pitch = args.number("lead", nonzero=True) / (2.0 * math.pi)
    elif args.has("pitch"):
        pitch = args.number("pitch", nonzero=True)
    else:
        raise args.err(
            "give its lead (advance per turn, + right hand) as lead=..., "
            "or pitch=... (advance per radian); use a revolute for zero lead"
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

_ER4 = ("e1", "e2", "e3", "e4")

register(JointType(
    "gear", GEAR, ("phi1", "phi2", "phi3"), ("angle", "length", "length"),
    "parallel-axis gear (book 4.6.9). w on the first gear's axis, w' on the second's, "
    "parallel, same sense; t = common perpendicular from w to w'. phi1 = angle from u to t "
    "about w; phi2 = centre distance beyond nominal |R + R'|, along t; phi3 = offset of the "
    "u'v' plane from the uv plane along w. The rotation of u' from u is theta = [(R + R') "
    "phi1 + sgn(F){sqrt((|R+R'| + phi2)^2 - (|R+R'| cos a)^2) - |R+R'| sin a} + phi3 tan b]"
    " / R'; at phi1 = 0 (modulo whole turns of t) u, u' and t are parallel",
    const_names=("radius1", "radius2", "distance", "cos_pressure", "sin_pressure",
                 "tan_helix", "load_sign", "ratio"),
    const_kinds=("length", "length", "length", "ratio", "ratio", "ratio", "ratio", "ratio"),
    make_consts=gear_consts, extract=extract_gear, complete=gear_complete,
    aliases=("spur_gear", "parallel_gear"),
))

register(JointType(
    "rack", RACK, ("phi1", "phi2", "phi3"), ("length", "length", "length"),
    "rack and pinion (book 4.6.10); first body = rack, second = pinion. u along the rack's "
    "pitch line (positive pinion travel), w normal to the pitch plane, v toward the pinion; "
    "w' on the pinion axis, same sense as w. The pinion centre is at (phi1, R' + phi2, phi3) "
    "in uvw (R' signed: + when the pinion is on the +v side) and u' is turned from u by "
    "theta = -[phi1 + sgn(F) phi2 tan a - phi3 tan b] / R', so u' is parallel to u when the "
    "pinion centre is on the v axis",
    const_names=("radius", "tan_pressure", "tan_helix", "load_sign"),
    const_kinds=("length", "ratio", "ratio", "ratio"),
    make_consts=rack_consts, extract=extract_rack,
    order_note="the first body is the rack", aliases=("rack_pinion", "rack_and_pinion"),
))
register(JointType(
    "bevel", BEVEL, ("phi1", "phi2"), ("angle", "angle"),
    "straight bevel gear (book 4.6.11). w, w' on the gear axes, pointing away from the "
    "common apex of the pitch cones; t = w x w'. Phi = Tz(-d1) Rz(-phi1) Rx(gamma1 + "
    "gamma2 + phi2) Rz(kappa phi1) Tz(d2): phi1 = angle from t to u about w, phi2 = shaft "
    "angle beyond gamma1 + gamma2 about t, u' at kappa phi1 from t about w'. Rolling "
    "pitch cones: kappa = -sin(gamma1)/sin(gamma2) = -R1/R2 (the book's and IMP's "
    "+tan(gamma1)/tan(gamma2) only with book_ratio=True). Frames at the apex (d1 = d2 = 0) "
    "or, with radius=, at the centres of the pitch circles (d = cone distance x cos gamma); "
    "at phi1 = 0, u and u' lie along t",
    const_names=("kappa", "shaft_angle", "offset1", "offset2", "gamma1", "gamma2"),
    const_kinds=("ratio", "angle", "length", "length", "angle", "angle"),
    make_consts=bevel_consts, extract=extract_bevel, aliases=("bevel_gear",),
))
register(JointType(
    "point_curve", POINT_CURVE, ("t", "phi2", "phi3"), ("angle", "angle", "length"),
    "point on a planar curve (book 4.6.12); first body carries the curve (u(t), v(t)) in "
    "its uv plane, second the point (origin of u'v'w'); w' parallel to w, same sense. t = "
    "curve parameter (dimensionless, unscaled), phi2 = angle from u to u' about w, phi3 = "
    "offset of the u'v' plane along w",
    const_names=("length_unit", "t_start", "t_end", "periodic", "curve"),
    const_kinds=("length",),
    make_consts=lambda name, kw: curve_consts(name, "point_curve", kw),
    extract=extract_point_curve, order_note="the first body carries the curve",
    aliases=("point_on_curve", "curve_point"),
))
register(JointType(
    "line_curve", LINE_CURVE, ("t", "phi2", "phi3"), ("angle", "length", "length"),
    "line tangent to a planar curve (book 4.6.13); first body carries the curve (u(t), "
    "v(t)), second the line along +u' (a flat-faced follower); w' parallel to w. u' is "
    "along the curve's tangent d(u, v)/dt at the contact (same sense); t = curve parameter "
    "of the contact point, phi2 = distance along +u' from the u'v'w' origin to the contact, "
    "phi3 = offset along w",
    const_names=("length_unit", "t_start", "t_end", "periodic", "curve"),
    const_kinds=("length",),
    make_consts=lambda name, kw: curve_consts(name, "line_curve", kw),
    extract=extract_line_curve, order_note="the first body carries the curve",
    aliases=("line_on_curve", "tangent_line", "flat_follower"),
))
register(JointType(
    "cam", CAM, ("phi1", "phi2"), ("angle", "angle"),
    "IMP's CAM; first body = cam, second = follower. w, w' normal to the pitch-curve plane, "
    "same sense, u v and u' v' in that plane; the u'v'w' origin lies on the pitch curve "
    "r(phi1) (radius from the uvw origin, one full turn, periodic); t = from the uvw origin "
    "to the u'v'w' origin. phi1 = angle from u to t about w, phi2 = angle from t to u' "
    "about w'",
    const_names=("length_unit", "radius_function"), const_kinds=("length",),
    make_consts=cam_consts, extract=extract_cam, order_note="the first body is the cam",
))
register(JointType(
    "slot", SLOT, ("u", "phi2"), ("length", "angle"),
    "IMP's SLOT; first body = slotted link, second = follower. w, w' normal to the slot "
    "plane, same sense; the u'v'w' origin lies on the slot centreline v = f(u), tabulated "
    "over the slot's u range. u = u-coordinate of the u'v'w' origin, phi2 = angle from a "
    "line parallel to u to u' about w'",
    const_names=("length_unit", "u_start", "u_end", "centreline"), const_kinds=("length",),
    make_consts=slot_consts, extract=extract_slot,
    order_note="the first body is the slotted link",
))
register(JointType(
    "ujoint", UJOINT, ("phi1", "phi2"), ("angle", "angle"),
    "universal (Hooke) joint, IMP's UJOINT: common origin at the centre of the cross; w on "
    "the first body's pin, w' on the second's, perpendicular; t = w x w'. phi1 = angle from "
    "u to t about w, phi2 = angle from t to u' about w'. Phi = Rz(phi1) Rx(90 deg) Rz(phi2)",
    make_consts=_no_consts, extract=extract_ujoint,
    aliases=("universal", "hooke", "cardan"),
))
register(JointType(
    "sphere_plane", SPHERE_PLANE, ("x", "y", *_ER4), ("length", "length", "er", "er", "er",
                                                      "er"),
    "sphere fixed in the second body touching a plane of the first. Both frames have their "
    "origin at the sphere centre at the modeling posture; w normal to the plane, pointing "
    "from the plane toward the sphere (the uv plane is the plane of the sphere centre). "
    "x, y = centre in uvw; e1..e4 = Euler-Rodrigues parameters of u'v'w' in uvw. "
    "Phi = [[Theta(e), (x, y, 0)], [0, 1]]",
    er_groups=(2,), make_consts=_no_consts, extract=extract_sphere_plane,
    order_note="the first body carries the plane", aliases=("ball_plane",),
))
register(JointType(
    "sphere_groove", SPHERE_GROOVE, ("s", *_ER4), ("length", "er", "er", "er", "er"),
    "sphere fixed in the second body running in a straight cylindrical groove of the first. "
    "Both frames have their origin at the sphere centre at the modeling posture; u along "
    "the groove (the line of sphere centres). s = centre along u; e1..e4 = Euler-Rodrigues "
    "parameters of u'v'w' in uvw. Phi = [[Theta(e), (s, 0, 0)], [0, 1]]",
    er_groups=(1,), make_consts=_no_consts, extract=extract_sphere_groove,
    order_note="the first body carries the groove", aliases=("ball_groove",),
))
register(JointType(
    "gimbal", GIMBAL, ("a", "b", "c"), ("angle", "angle", "angle"),
    "ball joint turned by Cardan angles x-y'-z'' (IMP's SPHERE variables): common origin; "
    "Phi = Rx(a) Ry(b) Rz(c), a about u, b about the turned v, c about w'. Singular at "
    "b = +-90 deg, where a and c turn about one axis (use sphere, which never locks, "
    "when the angles need not be coordinates)",
    make_consts=_no_consts, extract=extract_gimbal, aliases=("cardan_sphere",),
))
register(JointType(
    "open_cardan", OPEN_CARDAN, ("x", "y", "z", "a", "b", "c"),
    ("length", "length", "length", "angle", "angle", "angle"),
    "no constraint, IMP's OPEN variables: origin of u'v'w' at (x, y, z) in uvw, then the "
    "Cardan turns of gimbal; Phi = T(x, y, z) Rx(a) Ry(b) Rz(c)",
    make_consts=_no_consts, extract=extract_open_cardan,
))
register(JointType(
    "flat_polar", FLAT_POLAR, ("phi1", "r", "phi2"), ("angle", "length", "angle"),
    "flat joint in IMP's polar variables: uv and u'v' planes coincide, w and w' on the same "
    "side; phi1 = angle from u to the line t from the uvw origin to the u'v'w' origin, "
    "r = the distance along t, phi2 = angle from t to u' about w; Phi = Rz(phi1) Tx(r) "
    "Rz(phi2). Singular at r = 0",
    make_consts=_no_consts, extract=extract_flat_polar,
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


def calc_of(jt: JointType, q: np.ndarray, c: np.ndarray, order: int = 2,
            load_sign: float | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(Phi, Q (nvar x 4 x 4), dQ (nvar x nvar x 4 x 4)) of one joint (Python convenience
    over :func:`~openimp.joints.calc.joint_calc`); ``load_sign`` defaults to the kind's
    initial value in ``c``."""
    Phi = np.zeros((4, 4))
    Q = np.zeros((MAXV, 4, 4))
    dQ = np.zeros((MAXV, MAXV, 4, 4))
    c = np.ascontiguousarray(c, float)
    s = jt.load_sign(c) if load_sign is None else float(load_sign)
    joint_calc(jt.code, np.ascontiguousarray(q, dtype=float), c, s, Phi, Q, dQ, order)
    n = jt.nvar
    return Phi, Q[:n].copy(), dQ[:n, :n].copy()


def phi_of(jt: JointType, q: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Phi(q) as a new 4x4 array."""
    return calc_of(jt, q, c, 0)[0]


def Q_of(jt: JointType, q: np.ndarray, c: np.ndarray) -> np.ndarray:
    """All Q_g as an (nvar, 4, 4) array."""
    return calc_of(jt, q, c, 1)[1]


def dQ_of(jt: JointType, q: np.ndarray, c: np.ndarray) -> np.ndarray:
    """All Q_{g,i} as an (nvar, nvar, 4, 4) array."""
    return calc_of(jt, q, c, 2)[2]


def conformity(
    jt: JointType, name: str, Phi: np.ndarray, c: np.ndarray, length_unit: float, tol: float
) -> np.ndarray:
    """Extract ``q`` from a measured ``Phi`` and check that ``Phi(q)`` reproduces it.

    Returns ``q``.  Kinds with a ``complete`` hook first fill the constants that
    depend on the modeling posture into ``c`` (in place; the caller must store
    ``c`` after this call).  A mismatch means the two joint frames break the kind's
    conventions (a revolute whose axes do not coincide, a prismatic whose
    frames are rotated, ...); that is an :class:`InputError` naming the joint,
    the size of the mismatch and the convention to satisfy.
    """
    if jt.complete is not None:
        jt.complete(name, Phi, c)
    try:
        q = jt.extract_q(Phi, c)
    except InputError as exc:
        raise InputError(f"joint {name!r} ({jt.name}): {exc}") from None
    back = closed_phi(jt.code, q) if jt.code in CLOSED_FORM else phi_of(jt, q, c)
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
