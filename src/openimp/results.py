"""Result containers of the analyses: one trajectory type for sweeps and time responses,
and the tables and runs of a deck.

A :class:`Trajectory` stores the joint variables of every solved step (and
their rates when the analysis had them), the quality index, the rank and the
free generalized coordinates; body postures, point positions and body rates
are recomputed from them on demand by a *tracker* that the analysis hands
over (:func:`openimp.kinematics.track.tracker`), and kept once computed.  This
module imports no analysis: results sit at the top of the layers
(docs/architecture.md, Layers).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from enum import IntEnum
from functools import cached_property
from typing import Any

import numpy as np

from openimp.errors import AnalysisError, InputError

#: tracker(Q, QD, QDD, bodies, points) -> (T, p, V, A) in model units (see openimp.kinematics.track)
Tracker = Callable[..., Any]


def screw_to_operator(s: np.ndarray) -> np.ndarray:
    """(..., 6) screws (v, w) to (..., 4, 4) operators [[skew(w), v], [0, 0]]."""
    out = np.zeros((*s.shape[:-1], 4, 4))
    v, w = s[..., :3], s[..., 3:]
    out[..., 0, 1], out[..., 0, 2], out[..., 1, 2] = -w[..., 2], w[..., 1], -w[..., 0]
    out[..., 1, 0], out[..., 2, 0], out[..., 2, 1] = w[..., 2], -w[..., 1], w[..., 0]
    out[..., :3, 3] = v
    return out



class Columns(dict):  # type: ignore[type-arg]
    """What every ``to_table()`` returns: the columns by name (a dict, so that
    ``pandas.DataFrame(res.to_table())`` takes it), printed as an aligned table
    (``print(res.to_table())``), at most :data:`SHOW_ROWS` rows, numbers to six
    significant digits."""

    def __str__(self) -> str:
        cols = {k: _cells(v) for k, v in self.items()}
        n = max((len(v) for v in cols.values()), default=0)
        names = list(cols)
        shown = list(range(n)) if n <= SHOW_ROWS else \
            [*range(SHOW_ROWS // 2), -1, *range(n - SHOW_ROWS // 2, n)]
        rows = [[("..." if r < 0 else (cols[k][r] if r < len(cols[k]) else ""))
                 for k in names] for r in shown]
        width = [max(len(str(k)), *(len(row[i]) for row in rows)) if rows else len(str(k))
                 for i, k in enumerate(names)]
        line = "  ".join(str(k).rjust(w) for k, w in zip(names, width, strict=True))
        body = ["  ".join(c.rjust(w) for c, w in zip(row, width, strict=True)) for row in rows]
        tail = [f"({n} rows)"] if n > SHOW_ROWS else []
        return "\n".join([line, *body, *tail])

    __repr__ = __str__


#: rows a printed :class:`Columns` shows (the first and the last half)
SHOW_ROWS = 20


def _cells(v: Any) -> list[str]:
    """One column's entries as text (a scalar is a column of one)."""
    if isinstance(v, np.ndarray):
        items = v.reshape(len(v), -1).tolist() if v.ndim > 1 else v.tolist()
    elif isinstance(v, (list, tuple)):
        items = list(v)
    else:
        items = [v]
    out = []
    for x in items:
        if isinstance(x, (bool, np.bool_)):
            out.append(str(bool(x)))
        elif isinstance(x, (int, np.integer)):
            out.append(str(int(x)))
        elif isinstance(x, (float, np.floating)):
            out.append(f"{float(x):.6g}")
        elif isinstance(x, (complex, np.complexfloating)):
            out.append(f"{complex(x):.6g}")
        else:
            out.append(str(x))
    return out


def _columns(method: Callable[..., dict[str, Any]]) -> Callable[..., Columns]:
    """Make a ``to_table`` return :class:`Columns`."""
    @functools.wraps(method)
    def wrapped(self: Any) -> Columns:
        return Columns(method(self))

    return wrapped

@dataclass
class Singularity:
    """A singular posture met along a motion (book 6.9), where the rank of the loop
    Jacobian drops.

    ``kind``: ``"change point"`` (the whole Jacobian loses rank: the mechanism
    gains freedoms there and branches of motion meet: change points,
    bifurcations) or ``"dead point"`` (only the drivers lose control: a limit of
    travel or toggle of a driver).  ``step``: the output step at the singular
    posture (``landed``) or the first step after it; ``position``: where it
    lies along the steps (``step - 1 < position <= step``); ``drivers``: the
    driver values there (model units); ``mobility``: the mobility there, against
    ``regular`` elsewhere; ``gained``: the coordinates that are free there beyond
    the specified ones; ``branch``: at a change point, ``"smooth"`` (the branch
    whose tangent continues the incoming motion) or ``"other"`` (the user's
    choice), at a dead point what the sweep did; ``quality``: the quality index
    there.  In a time response ``time`` is when it was passed (s; None in a sweep),
    ``drivers`` the free coordinates there and ``step`` the first output after it.
    """

    step: int
    landed: bool
    position: float
    drivers: dict[str, float]
    kind: str
    mobility: int
    regular: int
    gained: list[str]
    branch: str
    quality: float
    time: float | None = None

    def __str__(self) -> str:
        where = (f"step {self.step}" if self.landed else
                 f"between steps {self.step - 1} and {self.step}")
        if self.time is not None:
            where = f"t = {self.time:.9g} s"
        at = ", ".join(f"{k} = {v:.8g}" for k, v in self.drivers.items())
        free = ", ".join(self.gained[:6]) + (f" and {len(self.gained) - 6} more"
                                             if len(self.gained) > 6 else "")
        text = f"{where} ({at}): {self.kind}, mobility {self.regular} -> {self.mobility}"
        if free:
            text += f" (free there: {free})"
        if self.branch:
            text += f"; {self.branch}"
        return text


@dataclass
class DriverSwitch:
    """The input moved to another joint variable at a dead point of the old one (IMP's
    automatic driver switching): from ``step`` on, ``new`` is driven, starting at
    ``value`` (model units), and ``old`` follows the mechanism."""

    step: int
    old: str
    new: str
    value: float

    def __str__(self) -> str:
        return (f"step {self.step}: the input switched from {self.old} (at its limit of "
                f"travel) to {self.new}, from {self.value:.8g} on")


@dataclass
class CoordinateSwitch:
    """The free generalized coordinates changed during a time response (book 14.4: the
    FGCs are chosen again at every step): at ``time`` (s) the set ``old`` became
    ``new`` (variable names); ``step`` is the first output after it."""

    step: int
    time: float
    old: tuple[str, ...]
    new: tuple[str, ...]

    def __str__(self) -> str:
        return (f"t = {self.time:.6g} s: free coordinates {', '.join(self.old) or 'none'} -> "
                f"{', '.join(self.new) or 'none'}")


@dataclass
class Event:
    """A load law switched at ``time`` (s), located in time: ``name`` the element,
    ``direction`` +1 when its switching function went from negative to positive."""

    time: float
    name: str
    direction: int

    def __str__(self) -> str:
        way = "rising" if self.direction > 0 else "falling"
        return f"t = {self.time:.9g} s: {self.name} switched ({way})"


@dataclass
class IntegrationStats:
    """How a time response was integrated: ``method`` ("rk" or "book"), accepted
    ``steps``, ``rejected`` attempts, equation ``evaluations``, loop ``closures``,
    the ``smallest_step`` and ``largest_step`` taken (s), ``forced`` steps taken at
    the smallest step above the error tolerance, located ``events`` and the wall
    ``seconds``."""

    method: str
    steps: int
    rejected: int
    evaluations: int
    closures: int
    smallest_step: float
    largest_step: float
    forced: int
    events: int
    seconds: float


@dataclass
class EnergyAudit:
    """The energy balance of a time response at every output (model units).

    ``kinetic``, ``potential`` (gravity and linear springs); since the start:
    ``drive_work`` done on the mechanism by the specified coordinates' drives,
    ``load_work`` done by the loads that have no potential (forces, torques,
    law elements), ``dissipated`` by the dampers; ``balance`` = (T + V) -
    (T0 + V0) - drive_work - load_work + dissipated, which the exact motion
    keeps at zero: it is the integration error.  ``relative`` = |balance| /
    ``scale``, scale the largest of T, |V - V0| and the works over the run.
    The derived columns are computed once (read-only arrays): a listing reads them
    at every output.
    """

    kinetic: np.ndarray
    potential: np.ndarray
    drive_work: np.ndarray
    load_work: np.ndarray
    dissipated: np.ndarray

    @cached_property
    def total(self) -> np.ndarray:
        """T + V."""
        return _frozen(self.kinetic + self.potential)

    @cached_property
    def balance(self) -> np.ndarray:
        """The energy the integration created (+) or lost (-) since the start."""
        if self.kinetic.size == 0:
            return np.zeros(0)
        e = self.total - self.total[0]
        return _frozen(e - self.drive_work - self.load_work + self.dissipated)

    @cached_property
    def scale(self) -> float:
        """The energy scale of the run (see the class)."""
        if self.kinetic.size == 0:
            return 0.0
        parts = (self.kinetic, self.potential - self.potential[0], self.drive_work,
                 self.load_work, self.dissipated)
        return float(max(np.max(np.abs(p)) for p in parts))

    @cached_property
    def relative(self) -> np.ndarray:
        """|balance| / scale (0 when nothing moves)."""
        sc = self.scale
        return _frozen(np.abs(self.balance) / sc if sc > 0 else np.zeros_like(self.kinetic))

    @_columns
    def to_table(self) -> dict[str, Any]:
        """Columns: the energies, the works, the balance and its relative size."""
        return {"kinetic": self.kinetic, "potential": self.potential,
                "drive work": self.drive_work, "load work": self.load_work,
                "dissipated": self.dissipated, "balance": self.balance,
                "relative": self.relative}


def _frozen(a: np.ndarray) -> np.ndarray:
    """``a`` flagged read-only (a cached result handed out many times)."""
    a.setflags(write=False)
    return a


class Trajectory:
    """Postures (and rates) of a mechanism along the steps of a sweep or a time response.

    All results are in model units (radians for angles).  ``system`` is the
    compiled model; ``q`` (steps x nq) the joint variables in internal units;
    ``fgc`` (steps x nq) bool, the free generalized coordinates chosen at
    every step (not driven and not eliminated); ``sgc`` (nq,) bool, the
    specified ones (driven or held); ``drivers`` the names of the driven
    variables.
    """

    def __init__(
        self, system: Any, q: np.ndarray, quality: np.ndarray, rank: np.ndarray,
        fgc: np.ndarray, iterations: np.ndarray, drivers: list[str], message: str = "", *,
        tracker: Tracker, sgc: np.ndarray | None = None,
    ) -> None:
        self.system = system
        self._q = q  # internal units
        self.quality = quality
        self.rank = rank
        self._fgc = fgc
        self.iterations = iterations
        self.drivers = drivers
        self._sgc = np.zeros(system.nq, bool) if sgc is None else np.asarray(sgc, bool)
        #: empty when every step was solved; otherwise why the analysis stopped
        self.message = message
        #: times of the steps (None for a sweep driven by values rather than by motions of time)
        self.time: np.ndarray | None = None
        #: rank and quality index at the start posture (the regular values)
        self.rank_ref = 0
        self.quality_ref = 0.0
        self._qd: np.ndarray | None = None
        self._qdd: np.ndarray | None = None
        self.consistency: np.ndarray | None = None
        #: the user interrupted the analysis (Ctrl-C); ``message`` says where
        self.interrupted = False
        #: singular postures met along the motion (:class:`Singularity`), in order
        self.singularities: list[Singularity] = []
        #: driver switches at dead points (:class:`DriverSwitch`), in order
        self.switches: list[DriverSwitch] = []
        self._tracker = tracker
        #: model-unit arrays computed once (a listing reads them step by step)
        self._cache: dict[str, Any] = {}
        self._bodies: dict[int, tuple[np.ndarray, np.ndarray | None, np.ndarray | None]] = {}
        self._points: dict[int, np.ndarray] = {}
        # ---- a time response (openimp.simulate) also carries these (None on a sweep)
        #: the energy audit at every output (:class:`EnergyAudit`)
        self.energy: EnergyAudit | None = None
        #: the largest loop-equation residual at every output (internal units)
        self.closure: np.ndarray | None = None
        #: how it was integrated (:class:`IntegrationStats`)
        self.integration: IntegrationStats | None = None
        #: changes of the free coordinates (:class:`CoordinateSwitch`), in order
        self.coordinate_switches: list[CoordinateSwitch] = []
        #: switchings of load laws located in time (:class:`Event`), in order
        self.events: list[Event] = []

    # ------------------------------------------------------------- building
    def set_rates(self, qd: np.ndarray, qdd: np.ndarray, cons: np.ndarray) -> None:
        """Attach joint velocities and accelerations (steps x nq, internal units) and the
        consistency residual of the acceleration equations per step (8.45)."""
        self._qd = qd
        self._qdd = qdd
        self.consistency = cons
        self._bodies.clear()
        self._cache.pop("qd", None)
        self._cache.pop("qdd", None)

    @classmethod
    def empty(cls, system: Any, tracker: Tracker) -> Trajectory:
        """A trajectory of no steps (with rates) of ``system``."""
        nq = system.nq
        out = cls(system, np.zeros((0, nq)), np.zeros(0), np.zeros(0, np.int64),
                  np.zeros((0, nq), bool), np.zeros(0, np.int64), [], tracker=tracker)
        out.set_rates(np.zeros((0, nq)), np.zeros((0, nq)), np.zeros(0))
        return out

    @classmethod
    def concatenate(cls, parts: Sequence[Trajectory], message: str = "") -> Trajectory:
        """One trajectory of the steps of ``parts`` in order (same system and drivers)."""
        if not parts:
            raise ValueError("concatenate needs at least one part")
        p0 = parts[0]

        def cat(get: Callable[[Trajectory], Any]) -> Any:
            return np.concatenate([get(p) for p in parts], axis=0)

        out = cls(p0.system, cat(lambda p: p._q), cat(lambda p: p.quality),
                  cat(lambda p: p.rank), cat(lambda p: p._fgc), cat(lambda p: p.iterations),
                  p0.drivers, message, tracker=p0._tracker, sgc=p0._sgc)
        out.rank_ref, out.quality_ref = p0.rank_ref, p0.quality_ref
        if all(p._qd is not None for p in parts):
            out.set_rates(cat(lambda p: p._qd), cat(lambda p: p._qdd),
                          cat(lambda p: p.consistency))
        if all(p.time is not None for p in parts):
            out.time = cat(lambda p: p.time)
        offset = 0
        for p in parts:  # the singular postures and switches, renumbered
            out.singularities += [replace(r, step=r.step + offset, position=r.position + offset)
                                  for r in p.singularities]
            out.switches += [replace(w, step=w.step + offset) for w in p.switches]
            offset += p.nsteps
        out.interrupted = any(p.interrupted for p in parts)
        return out

    def steps(self, k0: int, k1: int) -> Trajectory:
        """The steps k0 to k1 - 1 as a trajectory of their own."""
        sl = slice(k0, k1)
        out = Trajectory(self.system, self._q[sl], self.quality[sl], self.rank[sl],
                         self._fgc[sl], self.iterations[sl], self.drivers, self.message,
                         tracker=self._tracker, sgc=self._sgc)
        out.rank_ref, out.quality_ref = self.rank_ref, self.quality_ref
        if self._qd is not None and self._qdd is not None and self.consistency is not None:
            out.set_rates(self._qd[sl], self._qdd[sl], self.consistency[sl])
        if self.time is not None:
            out.time = self.time[sl]
        for b, (T, V, A) in self._bodies.items():
            out._bodies[b] = (T[sl], None if V is None else V[sl], None if A is None else A[sl])
        for p, x in self._points.items():
            out._points[p] = x[sl]
        out.singularities = [replace(r, step=r.step - k0, position=r.position - k0)
                             for r in self.singularities if k0 <= r.step < k1]
        out.switches = [replace(w, step=w.step - k0) for w in self.switches if k0 <= w.step < k1]
        if self.closure is not None:
            out.closure = self.closure[sl]
        if self.energy is not None:
            e = self.energy
            out.energy = EnergyAudit(e.kinetic[sl], e.potential[sl], e.drive_work[sl],
                                     e.load_work[sl], e.dissipated[sl])
        out.integration = self.integration
        out.coordinate_switches = [replace(c, step=c.step - k0) for c in self.coordinate_switches
                                   if k0 <= c.step < k1]
        t0, t1 = ((self.time[k0] if k0 < self.nsteps else math.inf),
                  (self.time[k1 - 1] if 0 < k1 <= self.nsteps else -math.inf)) \
            if self.time is not None and self.nsteps else (math.inf, -math.inf)
        out.events = [e for e in self.events if t0 <= e.time <= t1]
        return out

    # ----------------------------------------------------------------- sizes
    @property
    def nsteps(self) -> int:
        """Number of solved steps."""
        return int(self._q.shape[0])

    def __len__(self) -> int:
        return self.nsteps

    @property
    def complete(self) -> bool:
        """True when every requested step was solved."""
        return not self.message

    # ------------------------------------------------------- joint variables
    def _cached(self, key: str, make: Callable[[], Any]) -> Any:
        if key not in self._cache:
            self._cache[key] = make()
        return self._cache[key]

    @property
    def q(self) -> np.ndarray:
        """All joint variables (steps x nq), model units (read-only)."""
        return self._cached("q", lambda: _frozen(self._q * self.system.var_scale))

    @property
    def mobility(self) -> np.ndarray:
        """Mobility f = n - rank(J) at every step (6.52) (read-only)."""
        return self._cached("mobility", lambda: _frozen(self.system.nq - self.rank))

    @property
    def fgc(self) -> list[list[str]]:
        """Names of the free generalized coordinates at every step: variables neither
        driven nor eliminated (held free coordinates of a kinematic sweep among them).

        Empty lists when every freedom is driven, as in a kinematic sweep of a
        mechanism with as many drivers as its mobility: the generalized
        coordinates are then the drivers (:attr:`sgc`).
        """
        names = self.system.var_names
        return self._cached("fgc", lambda: [[names[c] for c in np.flatnonzero(row)]
                                            for row in self._fgc])

    @property
    def sgc(self) -> list[str]:
        """Names of the specified generalized coordinates: the drivers, then any free
        coordinates held at their values."""
        names = self.system.var_names
        held = [names[c] for c in np.flatnonzero(self._sgc) if names[c] not in self.drivers]
        return [*self.drivers, *held]

    @property
    def generalized(self) -> list[list[str]]:
        """The generalized coordinates at every step (the independent variables the
        elimination left): the specified ones (:attr:`sgc`) and the free ones (:attr:`fgc`)."""
        s = self.sgc
        return [s + [n for n in row if n not in s] for row in self.fgc]

    def joint(self, name: str) -> np.ndarray:
        """Variables of one joint (steps x nvar), model units."""
        return self.q[:, self.system.joint_vars(name)]

    def variable(self, key: Any) -> np.ndarray:
        """One joint variable over the steps (key as in System.var_index)."""
        return self.q[:, self.system.var_index(key)]

    # ------------------------------------------------------------- rates
    @property
    def has_rates(self) -> bool:
        """True when the analysis gave velocities and accelerations."""
        return self._qd is not None

    def _need_rates(self) -> tuple[np.ndarray, np.ndarray]:
        if self._qd is None or self._qdd is None:
            raise InputError(
                "this sweep has no velocities: call sweep(system, drivers, rates=..., "
                "accels=...) or sweep(system, motion=..., times=...)"
            )
        return self._qd, self._qdd

    @property
    def qd(self) -> np.ndarray:
        """All joint velocities (steps x nq), model units per second (read-only)."""
        qd = self._need_rates()[0]
        return self._cached("qd", lambda: _frozen(qd * self.system.var_scale))

    @property
    def qdd(self) -> np.ndarray:
        """All joint accelerations (steps x nq), model units per second squared
        (read-only)."""
        qdd = self._need_rates()[1]
        return self._cached("qdd", lambda: _frozen(qdd * self.system.var_scale))

    def joint_velocity(self, name: str) -> np.ndarray:
        """Velocities of one joint's variables (steps x nvar)."""
        return self.qd[:, self.system.joint_vars(name)]

    def joint_acceleration(self, name: str) -> np.ndarray:
        """Accelerations of one joint's variables (steps x nvar)."""
        return self.qdd[:, self.system.joint_vars(name)]

    @property
    def singular(self) -> np.ndarray:
        """Steps at a singular posture, where rates are not determined by the drivers.

        A step is singular when the rank of the Jacobian is below the regular
        rank (the largest seen at the start posture or along the sweep: an
        extra instantaneous freedom appears, as at a dead centre), when the
        quality index has fallen below ``1e-6`` of its regular value (rates
        there are amplified a million-fold: a near-locking posture), or when
        the acceleration equations are inconsistent there (8.45).  Rates at a
        flagged step are not determined by the drivers: they may be huge (the
        true rates diverge at a locking posture) or leave the extra freedom at
        rest (a change point).
        """
        if self.nsteps == 0:
            return np.zeros(0, bool)
        rank_ref = max(self.rank_ref, int(self.rank.max()))
        q_ref = max(self.quality_ref, float(self.quality.max()))
        sing = (self.rank < rank_ref) | (self.quality < 1e-6 * q_ref)
        if self.consistency is not None:
            sing |= self.consistency > 1e-6
        return sing

    # ------------------------------------------------- bodies and points
    def prefetch(self, bodies: Sequence[str] = (), points: Sequence[str] = ()) -> None:
        """Compute (once) the postures and, with rates, the rates of these bodies and the
        positions of these points in one pass over the steps."""
        bi = [self.system.body_index(b) for b in bodies]
        bi = [b for b in dict.fromkeys(bi) if b not in self._bodies]
        pi = [self.system.point_index(p) for p in points]
        pi = [p for p in dict.fromkeys(pi) if p not in self._points]
        if not bi and not pi:
            return
        rates = self._qd is not None and bool(bi)
        out = self._tracker(self._q, self._qd if rates else None,
                            self._qdd if rates else None, bi, pi)
        for k, b in enumerate(bi):
            self._bodies[b] = (out.T[:, k], out.V[:, k] if rates else None,
                               out.A[:, k] if rates else None)
        for k, p in enumerate(pi):
            self._points[p] = out.p[:, k]

    def _body(self, body: str, rates: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        if rates:
            self._need_rates()
        b = self.system.body_index(body)
        if b not in self._bodies or (rates and self._bodies[b][1] is None):
            self._bodies.pop(b, None)
            self.prefetch([body])
        return self._bodies[b]  # type: ignore[return-value]

    def posture(self, body: str) -> np.ndarray:
        """Global posture T_0b of a body (steps x 4 x 4), model units."""
        return self._body(body, False)[0].copy()

    def point(self, name: str) -> np.ndarray:
        """Global position of a point (steps x 3), model units."""
        p = self.system.point_index(name)
        if p not in self._points:
            self.prefetch(points=[name])
        return self._points[p].copy()

    def velocity_screw(self, body: str) -> np.ndarray:
        """Screw (v, w) of the velocity operator omega_b of a body (steps x 6): w the
        angular velocity, v the velocity of the body point at the global origin."""
        return self._body(body, True)[1].copy()

    def acceleration_screw(self, body: str) -> np.ndarray:
        """Screw of the acceleration operator alpha_b of a body (8.52) (steps x 6)."""
        return self._body(body, True)[2].copy()

    def velocity_operator(self, body: str) -> np.ndarray:
        """The 4x4 velocity operator omega_b of book (7.22) (steps x 4 x 4)."""
        return screw_to_operator(self._body(body, True)[1])

    def acceleration_operator(self, body: str) -> np.ndarray:
        """The 4x4 operator alpha_b of book (8.52) (steps x 4 x 4)."""
        return screw_to_operator(self._body(body, True)[2])

    def angular_velocity(self, body: str) -> np.ndarray:
        """Angular velocity vector of a body, global components (steps x 3), rad/s."""
        return self._body(body, True)[1][:, 3:].copy()

    def angular_acceleration(self, body: str) -> np.ndarray:
        """Angular acceleration vector of a body, global (steps x 3), rad/s^2."""
        return self._body(body, True)[2][:, 3:].copy()

    def _point_rates(self, r: np.ndarray, body: str) -> tuple[np.ndarray, np.ndarray]:
        """Velocity (7.27) and acceleration (8.56) of points r (steps x 3) of a body."""
        _, V, A = self._body(body, True)
        v, w = V[:, :3], V[:, 3:]
        av, aw = A[:, :3], A[:, 3:]
        vel = v + np.cross(w, r)
        acc = av + np.cross(aw, r) + np.cross(w, vel)
        return vel, acc

    def origin_velocity(self, body: str) -> np.ndarray:
        """Velocity of the origin of a body's frame (steps x 3), global."""
        return self._point_rates(self.posture(body)[:, :3, 3], body)[0]

    def origin_acceleration(self, body: str) -> np.ndarray:
        """Acceleration of the origin of a body's frame (steps x 3), global."""
        return self._point_rates(self.posture(body)[:, :3, 3], body)[1]

    def _point_body(self, name: str) -> str:
        return self.system.bodies[int(self.system.K.ptbody[self.system.point_index(name)])]

    def point_velocity(self, name: str) -> np.ndarray:
        """Velocity of a point (steps x 3), global, model units per second (7.27)."""
        return self._point_rates(self.point(name), self._point_body(name))[0]

    def point_acceleration(self, name: str) -> np.ndarray:
        """Acceleration of a point (steps x 3), global (8.56)."""
        return self._point_rates(self.point(name), self._point_body(name))[1]

    def singularity_table(self) -> dict[str, Any]:
        """Columns of :attr:`singularities`: step, position, kind, mobility, free there,
        branch, quality, then one column per driver value."""
        rows = self.singularities
        cols: dict[str, Any] = {
            "step": np.array([r.step for r in rows], np.int64),
            "position": np.array([r.position for r in rows]),
            "kind": [r.kind for r in rows],
            "mobility": np.array([r.mobility for r in rows], np.int64),
            "free": [", ".join(r.gained) for r in rows],
            "branch": [r.branch for r in rows],
            "quality": np.array([r.quality for r in rows]),
        }
        for name in self.drivers:
            cols[name] = np.array([r.drivers.get(name, math.nan) for r in rows])
        return cols

    def internal(self) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None]:
        """The stored joint variables, velocities and accelerations (steps x nq each,
        internal units; None without rates), for analyses that continue from them."""
        return self._q, self._qd, self._qdd

    @property
    def specified(self) -> np.ndarray:
        """(nq,) bool: the specified coordinates (driven or held)."""
        return self._sgc.copy()

    @property
    def free(self) -> np.ndarray:
        """(steps, nq) bool: the free generalized coordinates at every step."""
        return self._fgc

    # ----------------------------------------------------------------- table
    @_columns
    def to_table(self) -> dict[str, Any]:
        """Columns: step (and time), joint variables (and their rates), quality, mobility."""
        cols: dict[str, Any] = {"step": np.arange(self.nsteps)}
        if self.time is not None:
            cols["time"] = self.time
        q = self.q
        for c, n in enumerate(self.system.var_names):
            cols[n] = q[:, c]
        if self.has_rates:
            qd, qdd = self.qd, self.qdd
            for c, n in enumerate(self.system.var_names):
                cols[n + "'"] = qd[:, c]
                cols[n + "''"] = qdd[:, c]
        cols["quality"] = self.quality
        cols["mobility"] = self.mobility
        if self.closure is not None:
            cols["closure"] = self.closure
        if self.energy is not None:
            cols.update(self.energy.to_table())
        return cols

    def __repr__(self) -> str:
        state = "complete" if self.complete else f"stopped: {self.message}"
        rates = ", with rates" if self.has_rates else ""
        gc = ", ".join(self.sgc) or "none"
        sing = f", {len(self.singularities)} singular postures" if self.singularities else ""
        return f"Trajectory({self.nsteps} steps{rates}{sing}, {state}; specified: {gc})"


# =============================================================================
# Forces along a motion
# =============================================================================
#: reaction components in the order of every reaction array
REACTION_COMPONENTS = ("Fu", "Fv", "Fw", "Mu", "Mv", "Mw")


def nan_apply(Tm: np.ndarray, x: np.ndarray) -> np.ndarray:
    """y = Tm x over leading axes ((..., 6, 6) by (..., 6)) where an unknown (NaN) entry of
    x makes unknown exactly the entries of y it contributes to (coefficient not 0)."""
    unknown = np.isnan(x)
    y = np.einsum("...ij,...j->...i", Tm, np.where(unknown, 0.0, x))
    hit = np.einsum("...ij,...j->...i", (np.abs(Tm) > 1e-12).astype(float),
                    unknown.astype(float)) > 0
    y[hit] = np.nan
    return y


def _skew(v: np.ndarray) -> np.ndarray:
    out = np.zeros((*v.shape[:-1], 3, 3))
    out[..., 0, 1], out[..., 0, 2], out[..., 1, 2] = -v[..., 2], v[..., 1], -v[..., 0]
    out[..., 1, 0], out[..., 2, 0], out[..., 2, 1] = v[..., 2], -v[..., 1], v[..., 0]
    return out


class Forces:
    """What a mechanism carries along a motion (book 10-11.14, ch 17), model units.

    ``drive``: the force or torque each generalized coordinate needs at every
    step (name -> (steps,)); positive when it acts to increase the coordinate.
    Joint reactions (:meth:`reaction`) are the load of the joint's first body
    on its second: forces along u, v, w and moments about u, v, w of the joint
    frame on the first body (``A_h = T_0,h- S_h-,h``), about that frame's
    origin; a statically indeterminate component is NaN (never a number), see
    :meth:`determinate`.  ``element_force`` (steps x ne): tension of every
    spring and damper (positive pulling its ends together), magnitude of every
    force and torque; ``kinetic``, ``potential`` (steps,): energies (the
    potential of gravity about the global origin and of the linear springs);
    ``power``: the power of every load on the mechanism (name -> (steps,)),
    ``"gravity"``, each element, ``"joint J"`` loads, and ``"drive"`` (the sum
    of the drive forces times their rates).  ``messages``: what was skipped.
    """

    def __init__(self, trajectory: Trajectory, drive: dict[str, np.ndarray], R: np.ndarray,
                 frames: Callable[[int], tuple[np.ndarray, np.ndarray]],
                 element_force: np.ndarray, element_skipped: np.ndarray,
                 kinetic: np.ndarray, potential: np.ndarray, power: dict[str, np.ndarray],
                 messages: list[str], reactions: bool) -> None:
        self.trajectory = trajectory
        self.system = trajectory.system
        self.drive = drive
        self._R = R
        self._frames = frames
        self.element_force = element_force
        self.element_skipped = element_skipped
        self.kinetic = kinetic
        self.potential = potential
        self.power = power
        self.messages = messages
        self.has_reactions = reactions

    @property
    def nsteps(self) -> int:
        """Number of steps."""
        return self.kinetic.shape[0]

    def __len__(self) -> int:
        return self.nsteps

    def _h(self, joint: str) -> int:
        if not self.has_reactions:
            raise InputError("the reactions were not computed (forces(..., reactions=False))")
        return self.system.joint_index(joint)

    def reaction(self, joint: str, frame: str = "joint") -> np.ndarray:
        """The load of ``joint``'s first body on its second (steps x 6: forces, then
        moments), NaN where statically indeterminate.

        ``frame="joint"``: on the axes u, v, w of the joint frame on the first
        body, moments about its origin; ``"global"``: global axes, moments about
        the same origin; ``"second"``: on the axes of the joint frame on the
        second body, moments about that frame's origin (IMP's kinematic-mode
        listing convention).  A global or second-frame component is NaN when an
        indeterminate joint-frame component contributes to it.
        """
        h = self._h(joint)
        if frame == "joint":
            return self._R[:, h].copy()
        if frame not in ("global", "second"):
            raise InputError(f"frame must be 'joint', 'global' or 'second', got {frame!r}")
        A1, A2 = self._frames(h)
        if frame == "second":
            return self._in_frame(h, A1, A2, None)
        at_origin = np.zeros_like(A1)  # global axes at the first frame's origin
        at_origin[:] = np.eye(4)
        at_origin[:, :3, 3] = A1[:, :3, 3]
        return self._in_frame(h, A1, at_origin, None)

    def in_frame(self, joint: str, frame: np.ndarray, axes: np.ndarray | None = None
                 ) -> np.ndarray:
        """The load of ``joint``'s first body on its second (steps x 6) re-expressed in any
        frame: forces on the axes of ``frame`` (steps x 4 x 4, global, model units),
        moments about its origin on ``axes`` (steps x 3 x 3, rows the axes; default
        the frame's own).  A component is NaN when an indeterminate joint-frame
        component contributes to it (:func:`nan_apply`)."""
        h = self._h(joint)
        return self._in_frame(h, self._frames(h)[0], frame, axes)

    def _in_frame(self, h: int, A1: np.ndarray, frame: np.ndarray, axes: np.ndarray | None
                  ) -> np.ndarray:
        """:meth:`in_frame` of joint h, whose frame on the first body is A1 (steps x 4 x 4)."""
        R = self._R[:, h]
        R1 = A1[:, :3, :3]
        Ft = np.swapaxes(frame[:, :3, :3], 1, 2)
        # global moment about the new origin: M_o2 = M_o1 + (o1 - o2) x F
        Mrow = np.zeros((R.shape[0], 3, 6))
        Mrow[:, :, :3] = _skew(A1[:, :3, 3] - frame[:, :3, 3]) @ R1
        Mrow[:, :, 3:] = R1
        Tm = np.zeros((R.shape[0], 6, 6))
        Tm[:, :3, :3] = Ft @ R1
        Tm[:, 3:, :] = (Ft if axes is None else axes) @ Mrow
        return nan_apply(Tm, R)

    def determinate(self, joint: str) -> np.ndarray:
        """(steps x 6) bool: the components of :meth:`reaction` (joint frame) that the
        constraints determine (17.18)."""
        return ~np.isnan(self._R[:, self._h(joint)])

    def element(self, name: str) -> np.ndarray:
        """Tension (springs, dampers) or magnitude (forces, torques) of an element (steps,);
        NaN where it was skipped (its two points coincide)."""
        try:
            i = self.system.elements.index(name)
        except ValueError:
            known = ", ".join(self.system.elements) or "none"
            raise InputError(f"unknown element {name!r}; elements are {known}") from None
        out = self.element_force[:, i].copy()
        out[self.element_skipped[:, i]] = np.nan
        return out

    @_columns
    def to_table(self) -> dict[str, Any]:
        """Columns: step (and time), drive forces, the reactions of every joint (joint frame),
        element forces, energies and powers."""
        tr = self.trajectory
        cols: dict[str, Any] = {"step": np.arange(self.nsteps)}
        if tr.time is not None:
            cols["time"] = tr.time[:self.nsteps]
        for n, v in self.drive.items():
            cols[f"drive {n}"] = v
        if self.has_reactions:
            for j in self.system.joints:
                R = self.reaction(j)
                for k, c in enumerate(REACTION_COMPONENTS):
                    cols[f"{j} {c}"] = R[:, k]
        for e in self.system.elements:
            cols[e] = self.element(e)
        cols["kinetic energy"] = self.kinetic
        cols["potential energy"] = self.potential
        for n, v in self.power.items():
            cols[f"power {n}"] = v
        return cols

    def __repr__(self) -> str:
        return (f"Forces({self.nsteps} steps; drives: {', '.join(self.drive) or 'none'}; "
                f"{len(self.system.joints)} joints, {len(self.system.elements)} elements)")


# =============================================================================
# Tables of a run
# =============================================================================
@dataclass
class Table:
    """One listed table: request, item, columns, units and rows.

    What a request produces: the request that asked for it (``LIST
    POSITION``), the item (``joint JT5``), column names with units and rows of
    numbers in the units the listing prints (degrees where IMP prints degrees).
    """

    request: str
    item: str
    columns: list[str]
    units: list[str]
    rows: np.ndarray

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict (NaN written as null)."""
        arr = np.asarray(self.rows, dtype=float)
        rows = arr.tolist()
        if not np.all(np.isfinite(arr)):
            rows = [[v if math.isfinite(v) else None for v in r] for r in rows]
        return {"request": self.request, "item": self.item, "columns": list(self.columns),
                "units": list(self.units), "rows": rows}


@dataclass
class Run:
    """The output of one EXECUTE: its title, mode, tables and messages."""

    title: str
    mode: str
    tables: list[Table] = field(default_factory=list)
    messages: list[str] = field(default_factory=list)
    #: set when the analysis stopped early (what was computed is still listed)
    failure: str = ""
    #: requests that could not be produced (analyses not built yet), one message each
    unsupported: list[str] = field(default_factory=list)
    #: set when the user interrupted the run (Ctrl-C); what was solved is kept
    interrupted: bool = False
    #: the output times of positions that could not be reached and were skipped (a
    #: kinematic sweep through a limit of travel): no row of any table has them
    missing: list[float] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        """True when the run finished, reached every position and produced every
        request."""
        return not self.failure and not self.unsupported and not self.missing

    def table(self, request: str, item: str) -> Table:
        """The table of a request (``'LIST POSITION'``) and item (``'joint A'``)."""
        for t in self.tables:
            if t.request == request and t.item == item:
                return t
        have = ", ".join(f"{t.request} / {t.item}" for t in self.tables) or "none"
        raise KeyError(f"no table {request} / {item} in run {self.title!r} (tables: {have})")

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict of the run."""
        d: dict[str, Any] = {"title": self.title, "mode": self.mode,
                             "tables": [t.to_dict() for t in self.tables]}
        if self.messages:
            d["messages"] = list(self.messages)
        if self.failure:
            d["failure"] = self.failure
        if self.unsupported:
            d["unsupported"] = list(self.unsupported)
        if self.interrupted:
            d["interrupted"] = True
        if self.missing:
            d["missing"] = list(self.missing)
        return d


# =============================================================================
# Equations of motion at one state (book ch 10)
# =============================================================================
@dataclass
class EquationsOfMotion:
    """M psi'' + c = Q (10.15) at one state, of :func:`openimp.equations`, in model units
    (forces, moments per radian, masses as given) over the generalized coordinates
    ``coords`` (f names; ``specified`` (f,) marks the SGCs, the rest are FGCs): ``M``
    (f, f), ``c`` (f,) the velocity-product terms, ``Q`` (f,) the applied generalized
    forces.  ``kinetic``, ``potential``: the energies.  ``singular``: "" or the message
    that names what moves without mass when M_FF is singular (the test of every
    analysis, :data:`openimp.dynamics.eom.SINGULAR_MASS`)."""

    coords: list[str]
    specified: np.ndarray
    M: np.ndarray
    c: np.ndarray
    Q: np.ndarray
    kinetic: float
    potential: float
    singular: str = ""

    def free_accelerations(self, specified_accels: Any = None) -> np.ndarray:
        """psi''_F (nF,) from M_FF psi''_F = Q_F - c_F - M_FS psi''_S (10.15, 11.13);
        ``specified_accels`` (nS,): psi''_S (default 0).  Raises AnalysisError when
        M_FF is singular."""
        F, Sg = ~self.specified, self.specified
        a_s = np.zeros(int(Sg.sum())) if specified_accels is None else np.asarray(
            specified_accels, float)
        if a_s.shape != (int(Sg.sum()),):
            raise InputError(f"free_accelerations: give {int(Sg.sum())} accelerations of "
                             f"the specified coordinates, got shape {a_s.shape}")
        if self.singular:
            raise AnalysisError(self.singular)
        rhs = self.Q[F] - self.c[F] - self.M[np.ix_(F, Sg)] @ a_s
        MFF = self.M[np.ix_(F, F)]
        return np.linalg.solve(MFF, rhs) if MFF.size else np.zeros(0)

    def drive(self, accels: Any) -> np.ndarray:
        """Generalized forces (f,) the coordinates need for accelerations ``accels``
        (f,; all coordinates): M psi'' + c - Q (11.14)."""
        return self.M @ np.asarray(accels, float) + self.c - self.Q

    @_columns
    def to_table(self) -> dict[str, Any]:
        """Columns: coordinate, specified, the rows of M by column coordinate, c and Q."""
        cols: dict[str, Any] = {"coordinate": list(self.coords),
                                "specified": self.specified.copy()}
        for j, name in enumerate(self.coords):
            cols[f"M[{name}]"] = self.M[:, j].copy()
        cols["c"] = self.c.copy()
        cols["Q"] = self.Q.copy()
        return cols


# =============================================================================
# Linearized equations, modes and frequency response (book ch 11, 13)
# =============================================================================
@dataclass
class Linearization:
    """M v' + D v + K x = F about one set point (11.7)-(11.11), in model units.

    Over the generalized coordinates ``coords`` (f names; ``specified`` (f,)
    marks the SGCs, the rest are FGCs): M, D, K (f, f), F (f,) the generalized
    force left at the set point (11.10; the inertia term excluded, so that, as
    in the book, v' is the total acceleration psi'': M psi''* = F in dynamic
    equilibrium).  Rows are
    generalized forces (force, or moment for an angle), columns per unit of
    the coordinate (radian or length) and its rate.  ``phi`` (nq, f): the
    first geometric derivatives of every joint variable (7.14), model units;
    ``q`` (nq,) the posture, ``rates``, ``accels`` (f,) and ``t`` the set
    point.  ``points`` maps a point name to its (3, f) derivatives dR/dpsi;
    ``inputs`` an element name to its generalized direction (f,): the
    generalized force of a unit force or torque.  ``bodies`` (nb, f, 6): the
    screws (v, w) of the body operators W_{b,j} (7.20) per unit of each
    coordinate.  ``rank``: of the loop Jacobian.  ``messages``: what was
    approximated.
    """

    system: Any
    coords: list[str]
    specified: np.ndarray
    M: np.ndarray
    D: np.ndarray
    K: np.ndarray
    F: np.ndarray
    phi: np.ndarray
    q: np.ndarray
    rates: np.ndarray
    accels: np.ndarray
    t: float
    points: dict[str, np.ndarray]
    inputs: dict[str, np.ndarray]
    bodies: np.ndarray
    rank: int
    messages: list[str] = field(default_factory=list)

    @property
    def free(self) -> np.ndarray:
        """Indices of the FGCs among ``coords``."""
        return np.flatnonzero(~self.specified)

    @property
    def sgc(self) -> np.ndarray:
        """Indices of the SGCs among ``coords``."""
        return np.flatnonzero(self.specified)

    def block(self, name: str, part: str) -> np.ndarray:
        """A partition (11.12) of ``M``, ``D`` or ``K``: part ``"FF"``, ``"FS"``, ``"SF"``,
        ``"SS"``; or of ``F``: ``"F"``, ``"S"``."""
        if name not in ("M", "D", "K", "F"):
            raise InputError(f"block: name must be M, D, K or F, got {name!r}")
        X = getattr(self, name)
        idx = {"F": self.free, "S": self.sgc}
        want = ("F", "S") if X.ndim == 1 else ("FF", "FS", "SF", "SS")
        if part not in want:
            raise InputError(f"block({name!r}, ...): part must be one of {', '.join(want)}, "
                             f"got {part!r}")
        if X.ndim == 1:
            return X[idx[part]]
        return X[np.ix_(idx[part[0]], idx[part[1]])]

    def in_coordinates(self, names: Sequence[str]) -> Linearization:
        """The same linearization over the coordinates the user names instead of the FGCs
        the elimination chose (the crank's angle, not the coupler's): ``names``, one
        joint variable (``"joint"`` or ``"joint.var"``) per FGC, in the order of the
        FGCs they replace; the SGCs stay.  With J = d psi / d psi' (the named
        coordinates' first geometric derivatives ``phi``, inverted): M' = J^T M J,
        D' = J^T D J, F' = J^T F, K' = J^T K J, the derivatives ``phi``, ``points``,
        ``bodies`` and ``inputs`` carried over.  K' is exact where the FGCs' generalized
        forces vanish (an equilibrium, at rest); elsewhere the change of coordinates
        adds second-order terms, and it is refused.  :func:`openimp.modes` of the
        result gives frequencies (the same) and mode shapes per unit of the named
        coordinates."""
        free = self.free
        names = [str(n) for n in names]
        if len(names) != free.size:
            raise InputError(f"in_coordinates: give one coordinate per FGC ({free.size}: "
                             f"{', '.join(self.coords[i] for i in free)}), got {len(names)}")
        sysm = self.system
        try:
            rows = [sysm.var_index(n) for n in names]
        except (KeyError, ValueError, InputError) as exc:
            raise InputError(f"in_coordinates: {exc}") from None
        f = len(self.coords)
        T = np.eye(f)
        T[free] = self.phi[rows]  # d(named)/d(psi)
        if np.linalg.cond(T) > 1e12:
            raise InputError(f"in_coordinates: {', '.join(names)} do not determine the "
                             "FGCs at this posture (a dependent set, or a singular posture)")
        scale = max(1.0, float(np.max(np.abs(self.F))) if f else 1.0)
        if np.any(self.rates) or np.any(self.accels) or \
                np.max(np.abs(self.F[free]), initial=0.0) > 1e-9 * scale:
            raise InputError("in_coordinates: the set point is not an equilibrium at rest (its "
                             "FGCs' generalized forces or rates are not 0): the change of "
                             "coordinates would add second-order terms; linearize at an "
                             "equilibrium (openimp.equilibrium)")
        J = np.linalg.inv(T)  # d(psi)/d(psi')
        coords = list(self.coords)
        for i, n in zip(free, names, strict=True):
            coords[i] = sysm.var_names[sysm.var_index(n)]
        return Linearization(
            sysm, coords, self.specified.copy(), J.T @ self.M @ J, J.T @ self.D @ J,
            J.T @ self.K @ J, J.T @ self.F, self.phi @ J, self.q.copy(), T @ self.rates,
            T @ self.accels, self.t, {k: v @ J for k, v in self.points.items()},
            {k: J.T @ v for k, v in self.inputs.items()},
            np.einsum("bfs,fg->bgs", self.bodies, J), self.rank,
            [*self.messages, f"in the coordinates {', '.join(coords[i] for i in free)} "
             "(in_coordinates)"])

    @_columns
    def to_table(self) -> dict[str, Any]:
        """Columns: coordinate, specified, then the rows of M, D and K by column coordinate
        and F."""
        cols: dict[str, Any] = {"coordinate": list(self.coords),
                                "specified": self.specified.copy()}
        for name in ("M", "D", "K"):
            X = getattr(self, name)
            for j, c in enumerate(self.coords):
                cols[f"{name}[{c}]"] = X[:, j].copy()
        cols["F"] = self.F.copy()
        return cols


@dataclass
class Modes:
    """Eigen-solution of the linearized FGC equations with every SGC locked (13.9-13.13).

    ``eigenvalues`` (2 nf,) complex, 1/s.  One entry per mode in the other
    arrays: a complex pair is one oscillatory mode (``frequency`` |lambda| in
    rad/s, ``damping`` ratio -Re lambda / |lambda|, ``damped`` Im lambda); a
    real eigenvalue is one non-oscillatory mode (``time_constant`` -1/lambda
    in s, negative when it grows; ``frequency`` and ``damping`` NaN).
    ``kind``: "oscillatory", "overdamped" or "neutral" (lambda = 0: listed once
    per freedom that has no restoring load, with ``frequency`` 0, ``damping``
    NaN and ``time_constant`` infinite, though a freedom with no damping either
    is a double zero of ``eigenvalues``);
    ``unstable``: Re lambda > 0.  ``shapes`` (nf, modes): the FGC amplitudes
    (complex, largest component 1); ``joint_shapes`` (nq, modes): every joint
    variable (phi' of the FGCs times the shape, model units).
    """

    linearization: Linearization
    coords: list[str]
    eigenvalues: np.ndarray
    mode_eigenvalue: np.ndarray
    frequency: np.ndarray
    damping: np.ndarray
    damped: np.ndarray
    time_constant: np.ndarray
    kind: list[str]
    unstable: np.ndarray
    shapes: np.ndarray
    joint_shapes: np.ndarray
    state_matrix: np.ndarray

    @property
    def count(self) -> int:
        """Number of modes."""
        return len(self.kind)

    @_columns
    def to_table(self) -> dict[str, Any]:
        """Columns: mode, kind, natural frequency (rad/s and Hz), damping ratio, damped
        frequency, time constant, unstable, real and imaginary parts of lambda."""
        lam = self.mode_eigenvalue
        return {"mode": np.arange(1, self.count + 1), "kind": list(self.kind),
                "frequency": self.frequency.copy(), "frequency_hz":
                self.frequency / (2 * math.pi), "damping": self.damping.copy(),
                "damped": self.damped.copy(), "time_constant": self.time_constant.copy(),
                "unstable": self.unstable.copy(), "re": lam.real.copy(),
                "im": lam.imag.copy()}


@dataclass
class TransferFunction:
    """One transfer function H(s) = num(s) / den(s) of the linearized equations (13.18).

    ``num``, ``den``: polynomial coefficients, highest power first (den monic),
    model units of the output per unit of the input.  ``input`` and
    ``output`` describe the pair, e.g. ``("force", "F1")`` and
    ``("position", "B.x")``.
    """

    input: tuple[str, str]
    output: tuple[str, str]
    num: np.ndarray
    den: np.ndarray

    def __call__(self, s: Any) -> Any:
        """H at complex frequency s (scalar or array)."""
        s = np.asarray(s, complex)
        return np.polyval(self.num, s) / np.polyval(self.den, s)

    def formula(self, digits: int = 6, var: str = "S") -> str:
        """The rational function as text, e.g. ``(1)/(S**2 + 0.2*S + 4)``."""
        return f"({_poly_text(self.num, digits, var)})/({_poly_text(self.den, digits, var)})"

    def poles(self) -> np.ndarray:
        """Roots of the denominator."""
        return np.roots(self.den) if self.den.size > 1 else np.zeros(0, complex)

    def zeros(self) -> np.ndarray:
        """Roots of the numerator."""
        return np.roots(self.num) if self.num.size > 1 else np.zeros(0, complex)


def _poly_text(c: np.ndarray, digits: int, var: str) -> str:
    """A polynomial (highest power first) as text in ``var``."""
    n = len(c) - 1
    terms = []
    for k, a in enumerate(c):
        p = n - k
        if a == 0 and len(c) > 1:
            continue
        mag = f"{abs(a):.{digits}g}"
        sign = "-" if a < 0 else "+"
        pw = "" if p == 0 else (var if p == 1 else f"{var}**{p}")
        body = mag if not pw else (pw if mag == "1" else f"{mag}*{pw}")
        terms.append((sign, body))
    if not terms:
        return "0"
    text = ("-" if terms[0][0] == "-" else "") + terms[0][1]
    for sign, body in terms[1:]:
        text += f" {sign} {body}"
    return text


@dataclass
class FrequencyResponse:
    """H(j w) of one input to several outputs over frequencies ``w`` (rad/s) (13.20, 13.21).

    ``H`` (nw, nout) complex; ``magnitude`` |H|, ``phase`` in degrees
    (unwrapped along w).  ``labels``: one per output.
    """

    w: np.ndarray
    H: np.ndarray
    input: tuple[str, str]
    outputs: list[tuple[str, str]]

    @property
    def magnitude(self) -> np.ndarray:
        """|H| (nw, nout)."""
        return np.abs(self.H)

    @property
    def phase(self) -> np.ndarray:
        """Phase of H in degrees (nw, nout), unwrapped along w."""
        return np.degrees(np.unwrap(np.angle(self.H), axis=0))

    @_columns
    def to_table(self) -> dict[str, Any]:
        """Columns: w (rad/s), then magnitude and phase (degrees) of every output."""
        cols: dict[str, Any] = {"w": self.w.copy()}
        mag, ph = self.magnitude, self.phase
        for k, (kind, name) in enumerate(self.outputs):
            cols[f"|{kind} {name}|"] = mag[:, k]
            cols[f"phase {kind} {name}"] = ph[:, k]
        return cols


@dataclass
class StateSpace:
    """x' = A x + B u, y = C x + D u of the linearized FGC equations (13.4-13.7, 14.11).

    The state is (v_F, x_F) of the book (velocities first), shifted by the
    input where an SGC motion drives it (see :func:`openimp.state_space`);
    ``inputs`` and ``outputs`` name the columns of B and rows of C.  Ready for
    ``scipy.signal.StateSpace(A, B, C, D)`` or python-control.
    """

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    states: list[str]
    inputs: list[tuple[str, str]]
    outputs: list[tuple[str, str]]

    @_columns
    def to_table(self) -> dict[str, Any]:
        """Columns: the rows of [A B; C D] by state and input."""
        top = np.hstack([self.A, self.B])
        bot = np.hstack([self.C, self.D])
        full = np.vstack([top, bot])
        names = self.states + [f"{k} {n}" for k, n in self.inputs]
        cols: dict[str, Any] = {"row": self.states + [f"{k} {n}" for k, n in self.outputs]}
        for j, n in enumerate(names):
            cols[n] = full[:, j]
        return cols


@dataclass
class ModeMap:
    """Natural frequencies and damping ratios at every posture of a motion (13.9), every
    SGC locked: a frequency-versus-posture map.

    ``q`` (steps, nq): the postures (model units).  Per step, the modes sorted by
    |lambda|: ``eigenvalues`` (steps, 2 n) complex (n the largest FGC count,
    NaN-padded); ``frequency`` and ``damping`` (steps, n): natural frequency
    (rad/s) and damping ratio of each oscillatory mode, slowest first;
    ``time_constant`` (steps, 2 n): -1/lambda of each real eigenvalue (s);
    ``unstable`` (steps,): a growing mode at that step; ``coords``: the FGCs of
    every step; ``messages``: steps with no result and why.
    """

    system: Any
    q: np.ndarray
    coords: list[list[str]]
    eigenvalues: np.ndarray
    frequency: np.ndarray
    damping: np.ndarray
    time_constant: np.ndarray
    unstable: np.ndarray
    messages: list[str] = field(default_factory=list)

    @property
    def nsteps(self) -> int:
        """Number of postures."""
        return int(self.q.shape[0])

    @_columns
    def to_table(self) -> dict[str, Any]:
        """Columns: step, then the frequency (rad/s) and damping ratio of every mode."""
        cols: dict[str, Any] = {"step": np.arange(self.nsteps)}
        for k in range(self.frequency.shape[1]):
            cols[f"frequency {k + 1}"] = self.frequency[:, k].copy()
            cols[f"damping {k + 1}"] = self.damping[:, k].copy()
        cols["unstable"] = self.unstable.copy()
        return cols


class SearchStatus(IntEnum):
    """How an equilibrium search ended (the codes of the compiled search,
    :mod:`openimp.dynamics.statics`); ``str()`` gives the words of
    :attr:`Equilibrium.status`."""

    BALANCED = 1  #: every generalized force on the FGCs within the tolerance
    NO_FREE = 2  #: every freedom is specified: only the holding forces are computed
    CAPPED = 3  #: the cap on search iterations was reached (``max_iter``)
    FAILED = 4  #: the loops could not be closed, or the loads did work against every step

    def __str__(self) -> str:
        return {1: "balanced", 2: "no free coordinate", 3: "step cap", 4: "failed"}[self.value]


class StepKind(IntEnum):
    """The kind of one step of an equilibrium search (the compiled codes); ``str()`` gives
    the word of :attr:`Equilibrium.history`."""

    NEWTON = 0  #: a Newton step (12.3, 12.4)
    DESCENT = 1  #: along the load, steepest descent (12.9)
    MODIFIED = 2  #: Newton with every eigenvalue of an indefinite K_FF by its magnitude
    NEUTRAL = 3  #: a neutral freedom moved along its reduced load (12.6 b)
    ESCAPE = 4  #: leaving an unstable equilibrium along its mode of instability

    def __str__(self) -> str:
        return self.name.lower()


@dataclass
class Equilibrium:
    """A static equilibrium (book ch 12) and how the search reached it, model units.

    ``q`` (nq,): the posture; ``coords`` the generalized coordinates there and
    ``specified`` (f,) which are SGCs (held) rather than FGCs (searched);
    ``converged``, ``status`` (``"balanced"``, ``"step cap"``, ``"no free
    coordinate"``, ``"failed"``; ``code``: the same as a :class:`SearchStatus`),
    ``steps`` (search steps), ``evaluations``
    (residual evaluations, stiffness ones included); ``residual`` (f,) the
    generalized force left on every coordinate (12.1; on the FGCs the
    unbalance, at most ``force_tol`` when converged; on the SGCs minus the
    holding force); ``stiffness`` (f, f) K = -dF/dpsi at rest (12.2);
    ``eigenvalues`` (nF,), ``eigenvectors`` (nF, nF): of the symmetric part of
    K_FF (ascending; the columns are mode shapes over the FGCs); ``stability``:
    ``"stable"``, ``"unstable"``, ``"neutral"`` (or ``"none"`` without FGCs);
    ``holding``: SGC name -> the force or moment that holds it (along the
    coordinate, the drive an actuator must supply); ``potential``: energy of
    gravity and the linear springs; ``history``: (kind, largest |F|, largest
    |dpsi|) per step, kind ``"newton"``, ``"descent"`` (12.9), ``"modified"``
    (indefinite K), ``"neutral"`` (12.6 b) or ``"escape"`` (leaving an
    unstable equilibrium); ``trajectory``: the posture as a one-step
    :class:`Trajectory`; ``forces``: the force analysis there
    (:class:`Forces`: joint reactions, element forces, holding forces as
    drives) or None; ``messages``: what happened, in words.
    """

    system: Any
    q: np.ndarray
    coords: list[str]
    specified: np.ndarray
    converged: bool
    status: str
    steps: int
    evaluations: int
    residual: np.ndarray
    force_tol: np.ndarray
    stiffness: np.ndarray
    eigenvalues: np.ndarray
    eigenvectors: np.ndarray
    stability: str
    holding: dict[str, float]
    potential: float
    history: list[tuple[str, float, float]]
    trajectory: Trajectory
    messages: list[str] = field(default_factory=list)
    t: float = 0.0
    forces: Any = None

    @property
    def code(self) -> SearchStatus:
        """:attr:`status` as a :class:`SearchStatus` (prints by name: ``CAPPED``)."""
        return next(c for c in SearchStatus if str(c) == self.status)

    @property
    def free(self) -> list[str]:
        """Names of the FGCs."""
        return [n for n, s in zip(self.coords, self.specified, strict=True) if not s]

    @property
    def unbalance(self) -> float:
        """The largest generalized force left on an FGC (model units)."""
        return float(np.abs(self.residual[~self.specified]).max(initial=0.0))

    def value(self, key: str) -> float:
        """A joint variable at the equilibrium (model units, radians for angles)."""
        return float(self.q[self.system.var_index(key)])

    @_columns
    def to_table(self) -> dict[str, Any]:
        """Columns per generalized coordinate: name, specified, value, residual
        generalized force, holding force (SGCs; NaN for FGCs)."""
        idx = [self.system.var_index(n) for n in self.coords]
        return {"coordinate": list(self.coords), "specified": self.specified.copy(),
                "value": self.q[idx].copy(), "residual": self.residual.copy(),
                "holding": np.array([self.holding.get(n, np.nan) for n in self.coords])}


@dataclass
class EquilibriumPath:
    """Equilibria along a path of SGC values or load times (12.1), model units.

    ``steps``: the :class:`Equilibrium` of every step reached; ``parameter``:
    the SGC that the path steps (or ``"t"``) and ``values`` its value per
    step; ``trajectory``: every balanced equilibrium posture (None when none
    was; a step that failed is the last of ``steps`` but not in it);
    ``forces``: the force analysis of the path or None;
    ``turning_points``: messages for every change of stability, jump and
    holding-force extremum; ``message``: why the path stopped early ("" when
    it did not).
    """

    system: Any
    steps: list[Equilibrium]
    trajectory: Trajectory | None
    message: str
    parameter: str
    values: np.ndarray
    turning_points: list[str] = field(default_factory=list)
    forces: Any = None
    #: the user pressed Ctrl-C (``message`` says at which step)
    interrupted: bool = False

    def __len__(self) -> int:
        return len(self.steps)

    @property
    def q(self) -> np.ndarray:
        """(steps, nq) the equilibrium postures, model units."""
        if not self.steps:
            return np.zeros((0, self.system.nq))
        return np.array([e.q for e in self.steps])

    def holding(self, name: str) -> np.ndarray:
        """(steps,) the holding force of SGC ``name`` (``"joint"`` or ``"joint.var"``)
        along the path; InputError for a name that is no SGC of it."""
        key = self.system.var_names[self.system.var_index(name)]
        if self.steps and key not in self.steps[0].holding:
            held = ", ".join(self.steps[0].holding) or "none"
            raise InputError(f"holding({name!r}): not an SGC of this path (the SGCs are "
                             f"{held})")
        return np.array([e.holding.get(key, np.nan) for e in self.steps])

    @property
    def stability(self) -> list[str]:
        return [e.stability for e in self.steps]

    @_columns
    def to_table(self) -> dict[str, Any]:
        """Columns: the parameter, every joint variable, the holding force of every SGC,
        the smallest stiffness eigenvalue, stability, search steps."""
        out: dict[str, Any] = {self.parameter: np.asarray(self.values).copy()}
        q = self.q
        for c, name in enumerate(self.system.var_names):
            out[name] = q[:, c]
        for name in (self.steps[0].holding if self.steps else {}):
            out[f"holding {name}"] = np.array([e.holding.get(name, np.nan)
                                               for e in self.steps])
        out["lowest eigenvalue"] = np.array([e.eigenvalues[0] if e.eigenvalues.size
                                             else np.nan for e in self.steps])
        out["stability"] = self.stability
        out["steps"] = np.array([e.steps for e in self.steps])
        return out
