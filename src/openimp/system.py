"""The compiled, immutable flat-array form of a model (book ch 5-6).

:func:`compile_model` checks a :class:`~openimp.model.Model`, finds its
topology (:mod:`openimp.topology`), scales lengths internally (book 6.7: the
diagonal of the bounding box of all frame origins and points is one internal
unit), builds the shape matrices ``S`` and extracts the joint variables at the
modeling posture with each joint's conformity check.  The result,
:class:`System`, holds only numpy arrays in :class:`KData` for the kernels of
:mod:`openimp.kinematics`, plus the name maps that results use.
"""

from __future__ import annotations

from collections import namedtuple
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import TYPE_CHECKING, Any

import numpy as np

from openimp import topology as _topology
from openimp._jit import njit, rows
from openimp.errors import InputError
from openimp.joints import conformity

if TYPE_CHECKING:
    from openimp.kinematics import SweepResult
    from openimp.model import Model

#: The arrays the kernels work on (all internal units).
#:
#: jcode, jnv, jq0, jc0: per joint kind code, number of variables, offset of its
#: variables in q, offset of its constants in ``const``; jb1, jb2: its first and
#: second body; S1 = S_{h-,h}, S2 = S_{h+,h}, S1inv and S2inv their inverses; order: bodies in
#: tree order; pj, pb, psign: parent joint, parent body and orientation sign of
#: each body (-1 for reference bodies); Tref: postures of the reference bodies;
#: chord: the cut-set joint of every loop; L: loop matrix; P: path matrix;
#: er: index in q of the first of every block of 4 Euler-Rodrigues parameters;
#: vjoint: joint of every variable; ptbody, ptlocal: body and body-frame
#: homogeneous coordinates of every point; gen: the joints whose kind is not
#: rigid, revolute, prismatic or cylindric (their Phi and Q go through the
#: general joint functions).
KData = namedtuple(
    "KData",
    "jcode jnv jq0 jc0 jb1 jb2 S1 S2 S1inv S2inv const order pj pb psign Tref chord L P er "
    "vjoint ptbody ptlocal gen",
)

#: Where every :data:`KData` field lives in the packed form, in field order:
#: "i" int64 vectors (KI), "l" int64 rows of nj (KL), "f" float64 vectors
#: (KF), "m" 4x4 float64 matrices (KM), "v" float64 rows of 4 (KV).
KFIELDS = "iiiiii" "mmmm" "f" "iiii" "m" "i" "ll" "iii" "v" "i"
_BUFFERS = "ilfmv"


def pack(fields: Mapping[str, np.ndarray]) -> tuple[tuple[np.ndarray, ...], Any]:
    """The packed form ``KP = (KI, KL, KF, KM, KV)`` of the kernel arrays, and :data:`KData` views.

    Compiled kernels take ``KP``: five arrays instead of 24, because numba
    passes every array of a tuple argument as separate words on each call,
    and that copying cost more than a four-bar's arithmetic.  Each buffer
    stacks the fields of one element type and row shape along its first
    axis, so a field is a slice of rows (no reshape).  ``KI`` starts with a
    header: per field, its first row and its number of rows.
    :func:`unpack` rebuilds the views inside a kernel; the returned
    :data:`KData` holds the same views for Python code.
    """
    arrays = [np.asarray(fields[name]) for name in KData._fields]
    head = np.zeros(2 * len(arrays), np.int64)
    nrows = {k: 0 for k in _BUFFERS}
    nrows["i"] = head.size
    for f, (kind, a) in enumerate(zip(KFIELDS, arrays, strict=True)):
        head[2 * f] = nrows[kind]
        head[2 * f + 1] = a.shape[0]
        nrows[kind] += a.shape[0]
    nj = len(fields["jcode"])
    bufs = {
        "i": np.zeros(nrows["i"], np.int64), "l": np.zeros((nrows["l"], nj), np.int64),
        "f": np.zeros(nrows["f"]), "m": np.zeros((nrows["m"], 4, 4)),
        "v": np.zeros((nrows["v"], 4)),
    }
    bufs["i"][:head.size] = head
    views = []
    for f, (kind, a) in enumerate(zip(KFIELDS, arrays, strict=True)):
        o = int(head[2 * f])
        v = bufs[kind][o:o + a.shape[0]]
        v[...] = a
        views.append(v)
    return tuple(bufs[k] for k in _BUFFERS), KData(*views)


@njit(inline="always")
def unpack(KP: tuple) -> Any:
    """The :data:`KData` views of the packed arrays ``KP`` (see :func:`pack`).

    Inlined (numba IR) into each kernel, where the views take the kernel's
    reference-counting mode and LLVM drops the ones the kernel does not
    read.  Each view is a bare array header (:func:`openimp._jit.rows`);
    numba's slicing would add index arithmetic that cost 10 s of a cold
    start over all kernels.
    """
    KI, KL, KF, KM, KV = KP
    return KData(
        rows(KI, KI[0], KI[1]),
        rows(KI, KI[2], KI[3]),
        rows(KI, KI[4], KI[5]),
        rows(KI, KI[6], KI[7]),
        rows(KI, KI[8], KI[9]),
        rows(KI, KI[10], KI[11]),
        rows(KM, KI[12], KI[13]),
        rows(KM, KI[14], KI[15]),
        rows(KM, KI[16], KI[17]),
        rows(KM, KI[18], KI[19]),
        rows(KF, KI[20], KI[21]),
        rows(KI, KI[22], KI[23]),
        rows(KI, KI[24], KI[25]),
        rows(KI, KI[26], KI[27]),
        rows(KI, KI[28], KI[29]),
        rows(KM, KI[30], KI[31]),
        rows(KI, KI[32], KI[33]),
        rows(KL, KI[34], KI[35]),
        rows(KL, KI[36], KI[37]),
        rows(KI, KI[38], KI[39]),
        rows(KI, KI[40], KI[41]),
        rows(KI, KI[42], KI[43]),
        rows(KV, KI[44], KI[45]),
        rows(KI, KI[46], KI[47]),
    )


def _rigid_inverse(T: np.ndarray) -> np.ndarray:
    out = np.eye(4)
    out[:3, :3] = T[:3, :3].T
    out[:3, 3] = -T[:3, :3].T @ T[:3, 3]
    return out


@dataclass(frozen=True)
class System:
    """A compiled model: flat arrays, names and the modeling posture.

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
    K: the kernel arrays (:data:`KData`), views of ``KP``.
    KP: the same arrays packed for the compiled kernels (:func:`pack`).
    topology: the :class:`~openimp.topology.Topology`.
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
    K: Any
    KP: tuple[np.ndarray, ...]
    topology: _topology.Topology

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

    @cached_property
    def var_scale(self) -> np.ndarray:
        """Factor from internal to model units per variable (read-only)."""
        v = np.array([self.length_scale if k == "length" else 1.0 for k in self.var_kinds])
        v.setflags(write=False)
        return v

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

    # ------------------------------------------------------------- analyses
    def sweep(
        self,
        drivers: Mapping[Any, Sequence[float] | np.ndarray] | None = None,
        rates: Mapping[Any, Sequence[float] | np.ndarray] | None = None,
        accels: Mapping[Any, Sequence[float] | np.ndarray] | None = None,
        **options: Any,
    ) -> SweepResult:
        """Move the mechanism through a sequence of driver values.

        See :func:`openimp.kinematics.sweep` for the options.
        """
        from openimp.kinematics import sweep

        return sweep(self, drivers, rates=rates, accels=accels, **options)

    def __repr__(self) -> str:
        return (
            f"System({self.name!r}: {len(self.bodies)} bodies, {len(self.joints)} joints, "
            f"{self.nq} variables, {self.nloops} loops, {self.nconstraints} constraints)"
        )


def compile_model(model: Model) -> System:
    """Check ``model`` and build its :class:`System` (see the module docstring)."""
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

    # --- length scale: diagonal of the bounding box of every origin and point
    pts = [j.frame1[:3, 3] for j in jlist] + [j.frame2[:3, 3] for j in jlist]
    pts += [p.xyz for p in model.points.values()]
    pts += [model.body_frames[b][:3, 3] for b in bodies]
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
    S1inv = np.zeros((nj, 4, 4))
    S2inv = np.zeros((nj, 4, 4))
    jcode = np.zeros(nj, np.int64)
    jnv = np.zeros(nj, np.int64)
    jq0 = np.zeros(nj, np.int64)
    jc0 = np.zeros(nj, np.int64)
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
        S1inv[h] = _rigid_inverse(S1[h])
        S2inv[h] = _rigid_inverse(S2[h])
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

    KP, K = pack(dict(
        jcode=jcode, jnv=jnv, jq0=jq0, jc0=jc0,
        jb1=np.array(first, np.int64), jb2=np.array(second, np.int64),
        S1=S1, S2=S2, S1inv=S1inv, S2inv=S2inv, const=np.array([*consts, 0.0]),
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
        gen=np.array([h for h in range(nj) if jcode[h] not in (0, 1, 2, 4)], np.int64),
    ))
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
        q0=np.array(q0, dtype=float),
        K=K,
        KP=KP,
        topology=topo,
    )
