"""Model, Data and State of a compiled mechanism (book ch 5-6).

Three objects, as in MuJoCo (``mjModel``/``mjData``) and Pinocchio
(``Model``/``Data``), flow through every analysis:

* :class:`System`, the compiled model: :func:`compile_model` checks a
  :class:`~openimp.model.Model`, finds its topology (:mod:`openimp.topology`),
  scales lengths internally (book 6.7: the diagonal of the bounding box of all
  frame origins and points is one internal unit), builds the shape matrices
  ``S`` and extracts the joint variables at the modeling posture with each
  joint's conformity check.  Its arrays are immutable (read-only) and packed
  from one field table, :data:`MODEL_FIELDS`, into three flat buffers ``KP``.
* :class:`Data`, the mutable scratch of one solve (postures, operators, the
  Jacobian and its elimination, rates), packed the same way from
  :data:`DATA_FIELDS`; allocated once per sweep and reused every step.
* :class:`State`: time, joint variables, rates, the SGC/FGC partition and the
  state-dependent signs of gears and racks.

Compiled kernels take ``(KP, DP, state, a few scalars)``: ``KP`` and ``DP``
are tuples of three flat buffers (int64 with a header, float64, bool), and
:func:`model_views` / :func:`data_views` rebuild the named views inside a
kernel.  numba passes every array of a tuple argument as separate words on each
call; three buffers instead of dozens of arrays keep that copying small.
Dynamic quantities will live in a second packed group of each, so the
kinematic kernels keep their signatures and their cache.
"""

from __future__ import annotations

import logging
import math
from collections import namedtuple
from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any, NamedTuple

import numpy as np

from openimp import massprops
from openimp import topology as _topology
from openimp._jit import HEAD, packed_views
from openimp.errors import InputError
from openimp.joints import MAXV, conformity
from openimp.joints.codes import CLOSED_FORM
from openimp.spatial import inverse as _rigid_inverse


# =============================================================================
# Field tables and packing
# =============================================================================
@dataclass(frozen=True)
class Field:
    """One packed array: its name, element type, shape and meaning.

    ``kind`` is ``"i"`` (int64), ``"f"`` (float64) or ``"b"`` (bool); ``shape``
    names the sizes of its dimensions (keys of the sizes mapping, or ints).
    """

    name: str
    kind: str
    shape: tuple[str | int, ...]
    doc: str


#: The kinematic group of the compiled model (internal units).  Sizes: nj joints,
#: nb bodies, nl loops, nc Euler-Rodrigues normalisation rows, nq joint variables,
#: npt points, ngen joints of a general kind, nconst constants.
MODEL_FIELDS: tuple[Field, ...] = (
    Field("jcode", "i", ("nj",), "kind code of joint h (openimp.joints.codes)"),
    Field("jnv", "i", ("nj",), "number of variables of joint h"),
    Field("jq0", "i", ("nj",), "offset of joint h's variables in q"),
    Field("jc0", "i", ("nj",), "offset of joint h's constants in const"),
    Field("jb1", "i", ("nj",), "first body h- of joint h (carries the unprimed frame)"),
    Field("jb2", "i", ("nj",), "second body h+ of joint h (carries the primed frame)"),
    Field("S1", "f", ("nj", 4, 4), "shape matrix S_{h-,h}: joint frame in its first body"),
    Field("S2", "f", ("nj", 4, 4), "shape matrix S_{h+,h}: joint frame in its second body"),
    Field("S1inv", "f", ("nj", 4, 4), "S_{h-,h}^-1"),
    Field("S2inv", "f", ("nj", 4, 4), "S_{h+,h}^-1"),
    Field("const", "f", ("nconst",), "joint constants (a joint's from jc0), one spare 0"),
    Field("order", "i", ("nb",), "bodies in tree order (every body after its parent)"),
    Field("pj", "i", ("nb",), "parent (tree) joint of body b, -1 for reference bodies"),
    Field("pb", "i", ("nb",), "parent body of body b, -1 for reference bodies"),
    Field("psign", "i", ("nb",), "+1 when b is its parent joint's second body, -1 if first"),
    Field("Tref", "f", ("nb", 4, 4), "posture T_0b of every body at the modeling posture"),
    Field("chord", "i", ("nl",), "cut-set joint closing loop i"),
    Field("L", "i", ("nl", "nj"), "loop matrix (ch 2): +-1 where joint h is in loop i"),
    Field("P", "i", ("nb", "nj"), "path matrix (ch 2): +-1 where joint h is on b's path"),
    Field("er", "i", ("nc",), "index in q of the first of every Euler-Rodrigues block"),
    Field("vjoint", "i", ("nq",), "joint of every variable"),
    Field("ptbody", "i", ("npt",), "body of every point"),
    Field("ptlocal", "f", ("npt", 4), "homogeneous body-frame coordinates of every point"),
    Field("gen", "i", ("ngen",), "joints of a kind evaluated by joint_calc (not closed form)"),
)

KModel = namedtuple("KModel", [f.name for f in MODEL_FIELDS])  # type: ignore[misc]

#: The scratch of one kinematic solve.  Sizes: nb, nj, nq as above, m = 6 nl + nc rows of
#: the loop equations, kk = max(min(m, nq), 1) pivots, nd drivers of a sweep.
DATA_FIELDS: tuple[Field, ...] = (
    Field("T0", "f", ("nb", 4, 4), "posture T_0b of every body (5.4, 5.5)"),
    Field("A", "f", ("nj", 4, 4), "A_h = T_{0,h-} S_{h-,h}: joint frame h in the ground (6.13)"),
    Field("Phi", "f", ("nj", 4, 4), "Phi_h of the joints of a general kind (joint_calc)"),
    Field("Qj", "f", ("nq", 4, 4), "Q_h^g of the variables of a general kind, joint frame"),
    Field("dQj", "f", (MAXV, MAXV, 4, 4), "Q_h^{g,i} of one joint (8.2), joint frame"),
    Field("M4", "f", (8, 4, 4), "4x4 scratch"),
    Field("Dh", "f", ("nq", 6), "screw of D_h^g = A_h Q_h^g A_h^-1 per variable (6.14, 6.41)"),
    Field("Bh", "f", ("nq", MAXV, 6), "screws of A_h Q_h^{g,i} A_h^-1 (8.24), for q-dependent Q"),
    Field("J", "f", ("m", "nq"), "Jacobian of the loop equations (6.45)"),
    Field("E", "f", ("m",), "loop residuals (6.40, 6.48) and normalisation rows (6.43)"),
    Field("T", "f", ("m", "nq1"), "tableau [J | E] reduced by the elimination (6.5.3)"),
    Field("prow", "i", ("kk",), "row of pivot k"),
    Field("pcol", "i", ("kk",), "column (dependent variable) of pivot k"),
    Field("pinv", "f", ("kk",), "1 / pivot k"),
    Field("mult", "f", ("kk", "m"), "multiple of pivot row k taken from row r"),
    Field("used", "b", ("mq1",), "rows and columns already pivoted"),
    Field("dq", "f", ("nq",), "Newton correction"),
    Field("rhs", "f", ("m",), "right-hand side (acceleration equations 8.40)"),
    Field("V", "f", ("nb", 6), "screw of the velocity operator omega_b of every body (7.22)"),
    Field("Ab", "f", ("nb", 6), "screw of the acceleration operator alpha_b (8.52)"),
    Field("Kh", "f", ("nj", 6), "drift screw of every joint (8.26, 8.39)"),
    Field("qlast", "f", ("nq",), "last solved posture of a sweep"),
    Field("qpred", "f", ("nq",), "predicted posture of the step being solved"),
    Field("isdriver", "b", ("nq",), "variables driven in a sweep"),
    Field("loop", "i", (2,), "step loop carried between calls: regular rank, history flag"),
    Field("G", "f", ("nq", "nd"), "first geometric derivatives dq/dpsi of the drivers (7.14)"),
    Field("Gp", "f", ("nq", "nd"), "G one step back (second-order predictor)"),
    Field("dprev", "f", ("nd",), "driver move of the last step"),
    Field("dnew", "f", ("nd",), "driver move of this step"),
)

KWork = namedtuple("KWork", [f.name for f in DATA_FIELDS])  # type: ignore[misc]

#: The dynamic group of the compiled model (book ch 9), internal units: lengths in
#: internal units, masses as given, so energies are the model's divided by
#: length_scale^2.  Sizes: nb, nq as above, ne force elements, nlaw load laws.
DYN_FIELDS: tuple[Field, ...] = (
    Field("Jb", "f", ("nb", 4, 4), "pseudo-inertia J_b = integral r r^T dm, body frame (9.2, 9.6)"),
    Field("grav", "f", (3,), "gravity vector g, global axes (9.11)"),
    Field("qk", "f", ("nq",), "spring rate k_h on every joint variable (9.13)"),
    Field("qfree", "f", ("nq",), "free position phi_h0 of every joint variable"),
    Field("qc", "f", ("nq",), "viscous damping c_h of every joint variable (9.14)"),
    Field("qf", "f", ("nq",), "constant load f_h on every joint variable (9.24)"),
    Field("qlaw", "i", ("nq", 3), "law slot of the spring, damper, load of every variable, -1"),
    Field("ekind", "i", ("ne",), "element kind: 0 spring, 1 damper, 2 force, 3 torque"),
    Field("ept", "i", ("ne", 3), "points of an element (springs: ends; force: at, from, to;"
          " torque: from, to), -1 unused"),
    Field("ebody", "i", ("ne",), "body a force or torque acts on"),
    Field("evalue", "f", ("ne",), "rate, coefficient or magnitude of an element"),
    Field("efree", "f", ("ne",), "free length of a spring"),
    Field("edir", "f", ("ne", 3), "fixed global direction of a force or torque (unit)"),
    Field("elaw", "i", ("ne",), "law slot of an element, -1 for a linear one"),
    Field("gscale", "f", ("nq",), "model units of a generalized force per internal one:"
          " L^2 for an angle, L for a length (L = length_scale)"),
    Field("escale", "f", ("ne",), "model units of an element's tension or magnitude: L^2"
          " for a torque, L otherwise"),
    Field("lscale", "f", (1,), "L = length_scale: lengths and forces times L, moments,"
          " energies and powers times L^2"),
)

KDyn = namedtuple("KDyn", [f.name for f in DYN_FIELDS])  # type: ignore[misc]

#: The scratch of one force or equations-of-motion evaluation (internal units).  Sizes:
#: nb, nq, ne, m as above, nf generalized coordinates, nlaw load laws.
DYN_DATA_FIELDS: tuple[Field, ...] = (
    Field("Gb", "f", ("nb", 4, 4), "T_0b J_b T_0b^T: pseudo-inertia in global axes (9.7)"),
    Field("Fin", "f", ("nb", 6), "inertia wrench (f, n about the origin) of every body (10.8)"),
    Field("Fext", "f", ("nb", 6), "applied wrench of gravity and elements on every body"),
    Field("Fb", "f", ("nb", 6), "Fin - Fext: what the joints must supply to every body"),
    Field("fq", "f", ("nq",), "load on every joint variable: springs, dampers, forces"),
    Field("W", "f", ("nb", "nf", 6), "body operators W_{b,j} of the generalized coordinates"),
    Field("sub", "f", ("nb", 6), "sum of Fb over the subtree of every body (tree pass)"),
    Field("Wsum", "f", ("nj", 6), "sum_b P(b,h) Fb_b: the wrench transmitted through joint h"),
    Field("gvar", "f", ("nq",), "D_a . Wsum_h - fq_a: the generalized force of a unit rate of"
          " variable a alone"),
    Field("Xr", "f", ("n6", "m"), "the elimination replayed on every unit loop row: J11^-1"
          " and the dependent rows' remainders, column by column"),
    Field("Yr", "f", ("n6",), "sum_k Xr[r, prow_k] gvar[pcol_k] of every unit loop row"),
    Field("cols", "i", ("nf",), "the generalized coordinates (columns of W)"),
    Field("Gf", "f", ("nq", "nf"), "phi' of the generalized coordinates (7.14)"),
    Field("elen", "f", ("ne",), "length between the points of every element"),
    Field("erate", "f", ("ne",), "its rate of change"),
    Field("eforce", "f", ("ne",), "tension of a spring or damper, magnitude of a load"),
    Field("epower", "f", ("ne",), "power of every element on the mechanism"),
    Field("eskip", "b", ("ne",), "element skipped: its two points coincide"),
    Field("law", "f", ("nlaw",), "values of the load laws at this step"),
    Field("L3", "f", (3, 4), "top rows of one 4x4 operator (scratch)"),
    Field("P6", "f", (6, 3), "points, velocities and a direction of one element (scratch)"),
    Field("h6", "f", (6,), "one wrench (scratch)"),
    Field("s6", "f", (3, 6), "three 6-vectors (scratch)"),
)

KDynData = namedtuple("KDynData", [f.name for f in DYN_DATA_FIELDS])  # type: ignore[misc]

#: element kinds of DYN_FIELDS.ekind
SPRING, DAMPER, FORCE, TORQUE = 0, 1, 2, 3
ELEMENT_KINDS = ("spring", "damper", "force", "torque")

_DTYPES = {"i": np.int64, "f": np.float64, "b": np.bool_}
_BUFFER = {"i": 0, "f": 1, "b": 2}


def _dims(shape: tuple[str | int, ...], sizes: Mapping[str, int]) -> tuple[int, ...]:
    return tuple(int(sizes[d]) if isinstance(d, str) else int(d) for d in shape)


def _layout(table: tuple[Field, ...], shapes: list[tuple[int, ...]]
            ) -> tuple[np.ndarray, list[int]]:
    """The int buffer's header and the length of each buffer for fields of these shapes."""
    head = np.zeros(HEAD * len(table), np.int64)
    used = [head.size, 0, 0]
    for k, (f, shape) in enumerate(zip(table, shapes, strict=True)):
        if len(shape) != len(f.shape) or len(shape) > 4:
            raise ValueError(f"field {f.name}: expected {len(f.shape)} dimensions, got {shape}")
        b = _BUFFER[f.kind]
        head[HEAD * k] = used[b]
        head[HEAD * k + 1:HEAD * (k + 1)] = (*shape, *(1,) * (4 - len(shape)))
        used[b] += math.prod(shape)
    return head, used


def pack(table: tuple[Field, ...], arrays: Mapping[str, np.ndarray]
         ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Pack the arrays of a field table into three flat buffers ``(I, F, B)``.

    ``I`` (int64) starts with a header: per field, its offset in its own
    buffer and its dimensions (:data:`~openimp._jit.HEAD` entries); the int
    fields follow.  ``F`` holds the float64 fields, ``B`` the bool ones, each
    C-ordered.  :func:`views` (Python) and the compiled :func:`model_views` /
    :func:`data_views` rebuild the arrays as views of the buffers.
    """
    arrs = [np.asarray(arrays[f.name]) for f in table]
    head, used = _layout(table, [a.shape for a in arrs])
    bufs = [np.zeros(used[0], np.int64), np.zeros(used[1]), np.zeros(used[2], np.bool_)]
    bufs[0][:head.size] = head
    for k, (f, a) in enumerate(zip(table, arrs, strict=True)):
        o = int(head[HEAD * k])
        bufs[_BUFFER[f.kind]][o:o + a.size] = a.reshape(-1)
    return bufs[0], bufs[1], bufs[2]


_ZEROED: dict[tuple[int, tuple[tuple[str, int], ...]], tuple[np.ndarray, int, int]] = {}


def allocate(table: tuple[Field, ...], sizes: Mapping[str, int]
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Zeroed buffers of a field table for the given sizes (see :func:`pack`).

    The layout is computed once per table and sizes (a sweep allocates its
    data at every call).
    """
    key = (id(table), tuple(sizes.items()))
    hit = _ZEROED.get(key)
    if hit is None:
        head, used = _layout(table, [_dims(f.shape, sizes) for f in table])
        I = np.zeros(used[0], np.int64)
        I[:head.size] = head
        hit = _ZEROED[key] = (I, used[1], used[2])
    I, nf, nb = hit
    return I.copy(), np.zeros(nf), np.zeros(nb, np.bool_)


def view(table: tuple[Field, ...], P: tuple[np.ndarray, ...], name: str) -> np.ndarray:
    """One field of a field table as a numpy view of its packed buffers (Python side)."""
    k = _index(table)[name]
    f = table[k]
    head = P[0][HEAD * k:HEAD * k + 1 + len(f.shape)].tolist()
    return P[_BUFFER[f.kind]][head[0]:head[0] + math.prod(head[1:])].reshape(head[1:])


_INDEX: dict[int, dict[str, int]] = {}


def _index(table: tuple[Field, ...]) -> dict[str, int]:
    idx = _INDEX.get(id(table))
    if idx is None:
        idx = _INDEX[id(table)] = {f.name: k for k, f in enumerate(table)}
    return idx


def views(table: tuple[Field, ...], P: tuple[np.ndarray, ...]) -> list[np.ndarray]:
    """The arrays of a field table as numpy views of its packed buffers (Python side)."""
    head = P[0][:HEAD * len(table)].tolist()
    out = []
    for k, f in enumerate(table):
        o = head[HEAD * k]
        dims = head[HEAD * k + 1:HEAD * k + 1 + len(f.shape)]
        out.append(P[_BUFFER[f.kind]][o:o + math.prod(dims)].reshape(dims))
    return out


def layout_of(table: tuple[Field, ...]) -> tuple[tuple[int, int], ...]:
    """Per field of a table its buffer (0 int, 1 float, 2 bool) and number of dimensions:
    the layout :func:`~openimp._jit.packed_views` unpacks."""
    return tuple((_BUFFER[f.kind], len(f.shape)) for f in table)


#: ``model_views(KP)``: the :data:`MODEL_FIELDS` of a packed model as named views,
#: inside a kernel (:func:`openimp._jit.packed_views`: emitted in place, the views take
#: the kernel's reference-counting mode and LLVM drops the ones it does not read)
model_views = packed_views(layout_of(MODEL_FIELDS), KModel)
#: ``data_views(DP)``: the :data:`DATA_FIELDS` of packed data as named views
data_views = packed_views(layout_of(DATA_FIELDS), KWork)
#: ``dyn_views(YP)``: the :data:`DYN_FIELDS` of a packed model as named views
dyn_views = packed_views(layout_of(DYN_FIELDS), KDyn)
#: ``dyn_data_views(ZP)``: the :data:`DYN_DATA_FIELDS` of packed scratch as named views
dyn_data_views = packed_views(layout_of(DYN_DATA_FIELDS), KDynData)


# =============================================================================
# State
# =============================================================================
class State(NamedTuple):
    """The state of a mechanism at one instant, in internal units (book 6.5.3, 6.9).

    What an analysis reads and writes besides the constant model and its
    scratch.  Kernels take it as it is (a named tuple of arrays).

    t: (1,) time; q: (nq,) joint variables; qd: (nq,) their rates; qdd: (nq,)
    their accelerations; sgc: (nq,) bool, the specified generalized
    coordinates (driven or held; never pivoted); fgc: (nq,) bool, the free
    generalized coordinates left by the last elimination; load_sign: (nj,)
    sgn(F) of every gear and rack (4.28, 4.31; 0 elsewhere and in
    kinematics), set by force analysis.
    """

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    sgc: np.ndarray
    fgc: np.ndarray
    load_sign: np.ndarray

    @property
    def time(self) -> float:
        """The time, a float."""
        return float(self.t[0])

    def copy(self) -> State:
        """An independent copy (every array copied)."""
        return State(*(a.copy() for a in self))


def make_state(system: System, q: np.ndarray | None = None, t: float = 0.0) -> State:
    """A state at joint variables ``q`` (internal units; default the modeling posture),
    at rest, nothing specified, the gears' and racks' initial load signs."""
    nq = system.nq
    q = system.q0 if q is None else np.asarray(q, dtype=float)
    return State(np.array([float(t)]), np.array(q, dtype=float, copy=True), np.zeros(nq),
                 np.zeros(nq), np.zeros(nq, np.bool_), np.zeros(nq, np.bool_),
                 system.load_sign0.copy())


# =============================================================================
# Data
# =============================================================================
class Data:
    """The mutable scratch of one solve (:data:`DATA_FIELDS`), allocated once and reused.

    ``DP`` is the packed form the kernels take; ``v`` the same arrays as
    named numpy views for Python code (``data.v.T``, ``data.v.pcol`` ...),
    made when first asked for.
    """

    def __init__(self, DP: tuple[np.ndarray, np.ndarray, np.ndarray]) -> None:
        self.DP = DP

    @cached_property
    def v(self) -> Any:
        """The fields as named numpy views of ``DP``."""
        return KWork(*views(DATA_FIELDS, self.DP))

    def view(self, name: str) -> np.ndarray:
        """One field as a numpy view of ``DP`` (cheaper than :attr:`v` for one or two)."""
        return view(DATA_FIELDS, self.DP, name)


def data_sizes(system: System, nd: int = 0) -> dict[str, int]:
    """The sizes of :data:`DATA_FIELDS` for ``system`` and ``nd`` drivers."""
    nq, m = system.nq, system.nrows
    return {"nb": len(system.bodies), "nj": len(system.joints), "nq": nq, "m": m,
            "nq1": nq + 1, "mq1": m + nq + 1, "kk": max(min(m, nq), 1), "nd": nd}


def make_data(system: System, nd: int = 0) -> Data:
    """The scratch of one solve of ``system`` with ``nd`` drivers."""
    return Data(allocate(DATA_FIELDS, data_sizes(system, nd)))


class DynData:
    """The scratch of force and equations-of-motion evaluations
    (:data:`DYN_DATA_FIELDS`): ``ZP`` packed, ``v`` as named numpy views."""

    def __init__(self, ZP: tuple[np.ndarray, np.ndarray, np.ndarray]) -> None:
        self.ZP = ZP

    @cached_property
    def v(self) -> Any:
        """The fields as named numpy views of ``ZP``."""
        return KDynData(*views(DYN_DATA_FIELDS, self.ZP))

    def view(self, name: str) -> np.ndarray:
        """One field as a numpy view of ``ZP`` (cheaper than :attr:`v` for one or two)."""
        return view(DYN_DATA_FIELDS, self.ZP, name)


def make_dyn_data(system: System, nf: int) -> DynData:
    """The dynamic scratch of ``system`` for ``nf`` generalized coordinates."""
    sizes = {"nb": len(system.bodies), "nj": len(system.joints), "nq": system.nq,
             "ne": len(system.elements),
             "m": system.nrows, "n6": 6 * system.nloops, "nf": nf,
             "nlaw": max(len(system.laws), 1)}
    return DynData(allocate(DYN_DATA_FIELDS, sizes))


def make_scratch(system: System) -> tuple[Data, DynData]:
    """The kinematic and dynamic scratch of one analysis call of ``system`` (all its
    variables as generalized coordinates), as the analyses keep them in
    :data:`~openimp.workspace.WORKSPACES`."""
    return make_data(system, system.nq), make_dyn_data(system, system.nq)


# =============================================================================
# The compiled model
# =============================================================================
@dataclass(frozen=True, eq=False)
class System:
    """A compiled model: read-only packed arrays, names and the modeling posture.

    Attributes
    ----------
    name: the model's title.
    bodies, joints, points: names in index order.
    ground: index of the fixed body.
    kinds: joint kind name per joint.
    var_names: ``"joint.variable"`` per joint variable (the columns of the Jacobian).
    var_kinds: ``angle``, ``length`` or ``er`` per variable.
    length_scale: one internal length unit in model units (book 6.7).
    q0: joint variables at the modeling posture (internal units).
    load_sign0: initial load sign of every joint (gears and racks; 0 elsewhere).
    KP: the packed kinematic group (:data:`MODEL_FIELDS`), read-only buffers.
    K: the same arrays as named numpy views.
    topology: the :class:`~openimp.topology.Topology`.
    YP, Y: the packed dynamic group (:data:`DYN_FIELDS`) and its views.
    elements: names of the springs, dampers, forces and torques (index order).
    laws: the load laws, one per slot of ``qlaw``/``elaw``: (what, name, callable,
        variable index or -1) with what ``"spring"``, ``"damper"``, ``"force"``,
        ``"torque"``, ``"joint spring"``, ``"joint damper"`` or ``"joint force"``.
    units: the model's :class:`~openimp.massprops.Units`.
    has_mass: whether any moving body has mass data.
    warnings: what the compile noticed and went on with (implausible inertia ...).
    """

    name: str
    bodies: tuple[str, ...]
    joints: tuple[str, ...]
    points: tuple[str, ...]
    ground: int
    kinds: tuple[str, ...]
    var_names: tuple[str, ...]
    var_kinds: tuple[str, ...]
    length_scale: float
    q0: np.ndarray
    load_sign0: np.ndarray
    KP: tuple[np.ndarray, np.ndarray, np.ndarray]
    K: Any
    topology: _topology.Topology
    YP: tuple[np.ndarray, np.ndarray, np.ndarray] = field(default=None, repr=False)  # type: ignore[assignment]
    Y: Any = field(default=None, repr=False)
    elements: tuple[str, ...] = ()
    laws: tuple[tuple[str, str, Any, int], ...] = ()
    units: Any = None
    has_mass: bool = False
    warnings: tuple[str, ...] = ()
    #: results derived from the model alone and kept for the next call (the driver
    #: check of a sweep from the same start, for one): never part of the model itself
    memo: dict[Any, Any] = field(default_factory=dict, compare=False, repr=False)

    # ------------------------------------------------------------- sizes/names
    @property
    def nq(self) -> int:
        """Number of joint variables (columns of the Jacobian)."""
        return len(self.var_names)

    @property
    def nloops(self) -> int:
        """Number of independent loops."""
        return int(self.K.L.shape[0])

    @property
    def nconstraints(self) -> int:
        """Number of Euler-Rodrigues normalisation rows (NC)."""
        return int(self.K.er.shape[0])

    @property
    def nrows(self) -> int:
        """Rows of the Jacobian: 6 per loop plus NC."""
        return 6 * self.nloops + self.nconstraints

    @property
    def gen(self) -> np.ndarray | None:
        """The joints of a general kind (``K.gen``), or None when every joint has a
        closed form: kernels given None never compile the general joint evaluation."""
        return self.K.gen if self.K.gen.size else None

    @cached_property
    def var_scale(self) -> np.ndarray:
        """Factor from internal to model units per variable (read-only)."""
        v = np.array([self.length_scale if k == "length" else 1.0 for k in self.var_kinds])
        v.setflags(write=False)
        return v

    @cached_property
    def var_lookup(self) -> dict[str, int]:
        """Column of every joint variable by ``"joint.var"``, and of every joint of one
        variable by the joint's name (the quick path of :meth:`var_index`)."""
        out = {n: c for c, n in enumerate(self.var_names)}
        for h, j in enumerate(self.joints):
            if int(self.K.jnv[h]) == 1:
                out[j] = int(self.K.jq0[h])
        return out

    def body_index(self, body: str) -> int:
        """Index of a body by name (InputError if unknown)."""
        try:
            return self.bodies.index(body)
        except ValueError:
            raise InputError(
                f"unknown body {body!r}; bodies are {', '.join(self.bodies)}"
            ) from None

    def joint_index(self, joint: str) -> int:
        """Index of a joint by name (InputError if unknown)."""
        try:
            return self.joints.index(joint)
        except ValueError:
            raise InputError(
                f"unknown joint {joint!r}; joints are {', '.join(self.joints)}"
            ) from None

    def point_index(self, point: str) -> int:
        """Index of a point by name (InputError if unknown)."""
        try:
            return self.points.index(point)
        except ValueError:
            known = ", ".join(self.points) or "none"
            raise InputError(f"unknown point {point!r}; points are {known}") from None

    def joint_vars(self, joint: str) -> slice:
        """Slice of ``q`` holding the variables of a joint."""
        h = self.joint_index(joint)
        a = int(self.K.jq0[h])
        return slice(a, a + int(self.K.jnv[h]))

    def var_index(self, key: str | tuple[str, str | int]) -> int:
        """Column of one joint variable.

        ``key`` is a joint name (single-variable joints), ``"joint.var"`` or
        ``(joint, var)`` with the variable's name or 0-based index.
        """
        if type(key) is str:  # the common case, by the table
            c = self.var_lookup.get(key)
            if c is not None:
                return c
        if isinstance(key, tuple):
            joint, var = key
        elif isinstance(key, str) and key in self.joints:
            joint, var = key, None
        elif isinstance(key, str) and "." in key:
            joint, var = key.rsplit(".", 1)
        else:
            raise InputError(f"unknown joint {key!r}; joints are {', '.join(self.joints)}")
        sl = self.joint_vars(joint)
        names = [n.split(".", 1)[1] for n in self.var_names[sl]]
        if var is None:
            if len(names) != 1:
                raise InputError(
                    f"joint {joint!r} has {len(names)} variables ({', '.join(names)}); "
                    f"name one as '{joint}.{names[0] if names else '?'}'"
                )
            return sl.start
        if isinstance(var, int) or (isinstance(var, str) and var.isdigit()):
            k = int(var)
            if not 0 <= k < len(names):
                raise InputError(f"joint {joint!r} has no variable number {k}")
            return sl.start + k
        if var not in names:
            raise InputError(
                f"joint {joint!r} has no variable {var!r}; its variables are {', '.join(names)}"
            )
        return sl.start + names.index(var)

    # ------------------------------------------------------------ conversions
    def to_internal(self, q: np.ndarray) -> np.ndarray:
        """Joint variables from model units to internal units."""
        return np.asarray(q, dtype=float) / self.var_scale

    def to_model(self, q: np.ndarray) -> np.ndarray:
        """Joint variables from internal units to model units."""
        return np.asarray(q, dtype=float) * self.var_scale

    @property
    def modeling_q(self) -> np.ndarray:
        """Joint variables at the modeling posture, model units."""
        return self.to_model(self.q0)

    def __repr__(self) -> str:
        return (
            f"System({self.name!r}: {len(self.bodies)} bodies, {len(self.joints)} joints, "
            f"{self.nq} variables, {self.nloops} loops, {self.nconstraints} constraints)"
        )


def read_only(P: tuple[np.ndarray, ...]) -> tuple[np.ndarray, ...]:
    """The buffers of a packed model, flagged read-only (kernels cannot write them)."""
    for a in P:
        a.setflags(write=False)
    return P


def compile_model(model: Any, log: bool = True) -> System:
    """Check ``model`` (a :class:`~openimp.model.Model`) and build its :class:`System`.

    See the module docstring.  What the compile notices and goes on with (a body
    whose name is one letter from another's, an inertia no rigid body has) is in
    :attr:`System.warnings` and, with ``log``, logged as warnings of the ``openimp``
    logger (stderr by default; ``logging.getLogger("openimp").setLevel(logging.ERROR)``
    silences them).  An IMP deck says them located at its statements instead.
    """
    if not model.joints:
        raise InputError(f"model {model.name!r} has no joints; add joints before compiling")
    bodies = list(model.bodies)
    if model.ground not in bodies:
        raise InputError(
            f"the ground body {model.ground!r} is in no joint; connect it by a joint or "
            f"name another ground (bodies: {', '.join(bodies)})"
        )
    bidx = {b: i for i, b in enumerate(bodies)}
    jlist = list(model.joints.values())
    first = [bidx[j.body1] for j in jlist]
    second = [bidx[j.body2] for j in jlist]
    g = bidx[model.ground]
    # open joints make the best chords: they close a loop without constraining it
    pref = [1.0 if j.kind.name == "open" else 0.0 for j in jlist]
    topo = _topology.analyze(len(bodies), first, second, g, tree_preference=pref)
    if topo.nassemblies > 1:
        loose = [bodies[int(b)] for a in topo.assemblies[1:] for b in a]
        raise InputError(
            "bodies " + ", ".join(loose) + f" are not connected to the ground {model.ground!r}; "
            "connect them by joints (an 'open' joint if they float freely)"
        )

    # --- length scale: diagonal of the bounding box of every origin, point and centre of
    # mass (a mass far from every joint sets how far the mechanism moves: the increment
    # limit of an equilibrium search is one internal length, book 12.4)
    pts = [j.frame1[:3, 3] for j in jlist] + [j.frame2[:3, 3] for j in jlist]
    pts += [p.xyz for p in model.points.values()]
    pts += [model.body_frames[b][:3, 3] for b in bodies]
    for b, J in model.masses.items():
        if b in model.body_frames and J[3, 3] > 0:
            T = model.body_frames[b]
            pts.append(T[:3, :3] @ (J[:3, 3] / J[3, 3]) + T[:3, 3])
    P = np.array(pts)
    diag = float(np.linalg.norm(P.max(axis=0) - P.min(axis=0)))
    Ls = diag if diag > 0 else 1.0

    def scaled(T: np.ndarray) -> np.ndarray:
        out = T.copy()
        out[:3, 3] /= Ls
        return out

    Tb = np.array([scaled(model.body_frames[b]) for b in bodies])
    nj = len(jlist)
    S1 = np.zeros((nj, 4, 4))
    S2 = np.zeros((nj, 4, 4))
    jcode = np.zeros(nj, np.int64)
    jnv = np.zeros(nj, np.int64)
    jq0 = np.zeros(nj, np.int64)
    jc0 = np.zeros(nj, np.int64)
    sign0 = np.zeros(nj)
    consts: list[float] = []
    q0: list[float] = []
    var_names: list[str] = []
    var_kinds: list[str] = []
    er: list[int] = []
    vjoint: list[int] = []
    for h, j in enumerate(jlist):
        jt = j.kind
        F1 = scaled(j.frame1)
        F2 = scaled(j.frame2)
        S1[h] = _rigid_inverse(Tb[first[h]]) @ F1
        S2[h] = _rigid_inverse(Tb[second[h]]) @ F2
        c = np.asarray(j.consts, dtype=float).copy()
        for k, kind in enumerate(jt.const_kinds):
            if kind == "length":
                c[k] /= Ls
        jcode[h] = jt.code
        jnv[h] = jt.nvar
        jq0[h] = len(q0)
        jc0[h] = len(consts)
        Phi = _rigid_inverse(F1) @ F2
        # conformity may complete constants from the frames (a gear's centre distance)
        q = conformity(jt, j.name, Phi, c, Ls, tol=1e-7)
        sign0[h] = jt.load_sign(c)
        consts.extend(c.tolist())
        for e in jt.er_groups:
            er.append(len(q0) + e)
        q0.extend(np.asarray(q, dtype=float).tolist())
        var_names.extend(f"{j.name}.{v}" for v in jt.var_names)
        var_kinds.extend(jt.var_kinds)
        vjoint.extend([h] * jt.nvar)

    ptbody = np.array([bidx[p.body] for p in model.points.values()], np.int64)
    ptlocal = np.zeros((len(model.points), 4))
    for i, p in enumerate(model.points.values()):
        ptlocal[i] = _rigid_inverse(Tb[bidx[p.body]]) @ np.append(p.xyz / Ls, 1.0)

    KP = read_only(pack(MODEL_FIELDS, dict(
        jcode=jcode, jnv=jnv, jq0=jq0, jc0=jc0,
        jb1=np.array(first, np.int64), jb2=np.array(second, np.int64),
        S1=S1, S2=S2, S1inv=_rigid_inverse(S1), S2inv=_rigid_inverse(S2),
        const=np.array([*consts, 0.0]),
        order=np.asarray(topo.order, np.int64),
        pj=np.asarray(topo.parent_joint, np.int64),
        pb=np.asarray(topo.parent_body, np.int64),
        psign=np.asarray(topo.parent_sign, np.int64),
        Tref=Tb,
        chord=np.asarray(topo.chords, np.int64),
        L=np.asarray(topo.loops, np.int64).reshape(-1, nj),
        P=np.asarray(topo.paths, np.int64),
        er=np.array(er, np.int64),
        vjoint=np.array(vjoint, np.int64),
        ptbody=ptbody,
        ptlocal=ptlocal,
        gen=np.array([h for h in range(nj) if jcode[h] not in CLOSED_FORM], np.int64),
    )))
    q0a = np.array(q0, dtype=float)
    q0a.setflags(write=False)
    sign0.setflags(write=False)
    dyn, elements, laws, warnings = _dynamic_group(model, bodies, bidx, g, Tb, Ls, q0a,
                                                   var_kinds, list(model.joints), jq0)
    for b, j, o, ojs in _topology.misspelt_bodies(
            [(x.name, x.body1, x.body2) for x in jlist], model.ground):
        warnings.insert(0, f"body {b!r} appears only in joint {j!r} and its name is one "
                           f"letter from body {o!r} (joint {', '.join(map(repr, ojs))}): a "
                           "misspelt name makes a new body; give one body one name")
    if log:
        for w in warnings:
            logging.getLogger("openimp").warning("model %r: %s", model.name, w)
    YP = read_only(pack(DYN_FIELDS, dyn))
    return System(
        name=model.name,
        bodies=tuple(bodies),
        joints=tuple(j.name for j in jlist),
        points=tuple(model.points),
        ground=g,
        kinds=tuple(j.kind_name for j in jlist),
        var_names=tuple(var_names),
        var_kinds=tuple(var_kinds),
        length_scale=Ls,
        q0=q0a,
        load_sign0=sign0,
        KP=KP,
        K=KModel(*views(MODEL_FIELDS, KP)),
        topology=topo,
        YP=YP,
        Y=KDyn(*views(DYN_FIELDS, YP)),
        elements=elements,
        laws=laws,
        units=model.units,
        has_mass=bool(np.any(dyn["Jb"][[b for b in range(len(bodies)) if b != g]] != 0.0)),
        warnings=tuple(warnings),
    )


def _dynamic_group(
    model: Any, bodies: list[str], bidx: dict[str, int], ground: int, Tb: np.ndarray,
    Ls: float, q0: np.ndarray, var_kinds: list[str], jnames: list[str], jq0s: np.ndarray,
) -> tuple[dict[str, np.ndarray], tuple[str, ...], tuple[tuple[str, str, Any, int], ...],
           list[str]]:
    """The arrays of :data:`DYN_FIELDS` from the model's mass, gravity and load data.

    Internal units (see :data:`DYN_FIELDS`): a length l becomes l / Ls, a force
    f / Ls, a moment or energy m / Ls^2; a rotational rate k / Ls^2, a
    translational one stays.  Mass on the ground is dropped.
    """
    nb, nq = len(bodies), len(q0)
    warnings: list[str] = []
    Jb = np.zeros((nb, 4, 4))
    scale = np.diag([1.0 / Ls, 1.0 / Ls, 1.0 / Ls, 1.0])
    for name, J in model.masses.items():
        if name not in bidx or bidx[name] == ground:
            continue
        b = bidx[name]
        Jg = scale @ J @ scale  # global axes, internal lengths
        Jb[b] = massprops.transform(Jg, _rigid_inverse(Tb[b]))
        warnings += [f"mass of body {name!r}: {w}" for w in massprops.check_inertia(J)]
    grav = np.zeros(3) if model.gravity is None else np.asarray(model.gravity, float) / Ls
    qk, qfree, qc, qf = (np.zeros(nq) for _ in range(4))
    qlaw = -np.ones((nq, 3), np.int64)
    laws: list[tuple[str, str, Any, int]] = []
    jq0 = {name: int(a) for name, a in zip(jnames, jq0s, strict=True)}
    for (jname, k), jl in model.joint_loads.items():
        if jname not in jq0:
            continue
        c = jq0[jname] + k
        rot = var_kinds[c] == "angle"
        e2 = 1.0 / Ls**2  # energy and moment scale
        s_len = 1.0 if rot else 1.0 / Ls  # position scale
        # rate: energy / position^2; damping: energy / (position * rate); load: energy / position
        qk[c] = jl.rate * e2 / s_len**2
        qc[c] = jl.damping * e2 / s_len**2
        qf[c] = jl.force * e2 / s_len
        qfree[c] = q0[c] if jl.free is None else jl.free * s_len
        if jl.periodic and rot and jl.free is not None:  # the turn nearest the drawing
            qfree[c] += 2.0 * math.pi * round((q0[c] - qfree[c]) / (2.0 * math.pi))
        for slot, (what, law) in enumerate((("joint spring", jl.spring_law),
                                            ("joint damper", jl.damper_law),
                                            ("joint force", jl.force_law))):
            if law is not None:
                qlaw[c, slot] = len(laws)
                laws.append((what, jname, law, c))
    elems = list(model.elements.values())
    ne = len(elems)
    pidx = {p: i for i, p in enumerate(model.points)}
    ekind = np.zeros(ne, np.int64)
    ept = -np.ones((ne, 3), np.int64)
    ebody = -np.ones(ne, np.int64)
    evalue, efree = np.zeros(ne), np.zeros(ne)
    edir = np.zeros((ne, 3))
    elaw = -np.ones(ne, np.int64)
    for i, e in enumerate(elems):
        ekind[i] = ELEMENT_KINDS.index(e.kind)
        for k, p in enumerate(e.points):
            ept[i, k] = pidx[p]
        if e.kind in ("spring", "damper"):
            evalue[i] = e.value
            if e.kind == "spring":
                ends = [model.points[p].xyz for p in e.points]
                free = float(np.linalg.norm(ends[0] - ends[1])) if e.free is None else e.free
                efree[i] = free / Ls
        elif e.kind == "force":
            ebody[i] = bidx[model.points[e.points[0]].body]
            evalue[i] = e.value / Ls
        else:
            ebody[i] = bidx[e.body]
            evalue[i] = e.value / Ls**2
        if e.direction is not None:
            edir[i] = e.direction
        if e.law is not None:
            elaw[i] = len(laws)
            laws.append((e.kind, e.name, e.law, -1))
    gscale = np.array([Ls if k == "length" else Ls * Ls for k in var_kinds])
    escale = np.where(ekind == TORQUE, Ls * Ls, Ls)
    dyn = dict(Jb=Jb, grav=grav, qk=qk, qfree=qfree, qc=qc, qf=qf, qlaw=qlaw, ekind=ekind,
               ept=ept, ebody=ebody, evalue=evalue, efree=efree, edir=edir, elaw=elaw,
               gscale=gscale, escale=escale, lscale=np.array([Ls]))
    return dyn, tuple(e.name for e in elems), tuple(laws), warnings
