"""Load laws: the values of springs, dampers and loads given as functions (Python
callables, IMP VALUE expressions), evaluated per step outside the compiled stages.

A law is called with one :class:`LoadState` and returns a float in model
units: the tension of a spring or damper (positive pulling the ends
together), the magnitude of a force or torque, the spring or damping force
of a joint variable (``rate * (q - free)``, ``c * qd``: positive against an
increase) or the load on it (positive tending to increase it).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from openimp.errors import InputError
from openimp.kinematics.track import tracker
from openimp.results import Trajectory


class LoadState:
    """What a load law may read at one step (model units).

    ``t``: the time (the step index for a sweep without times); ``step``;
    ``x``, ``xd``: the element's own coordinate and its rate (spring or
    damper: length and its rate; joint element: the joint variable and its
    rate; force or torque: 0); ``var(key)``, ``var_rate(key)``: any joint
    variable (``"joint"`` or ``"joint.var"``) and its rate; ``point(name)``,
    ``point_velocity(name)``: a point's global position and velocity;
    ``var_accel(key)``, ``point_acceleration(name)``: accelerations, NaN where the
    loads decide them (while a time response is integrated).

    A law may also have an ``accepted(trajectory)`` attribute: a time response calls
    it with every accepted state (a :class:`~openimp.results.Trajectory` of one step
    with its accelerations and time), once per callable however many laws share it.
    """

    __slots__ = ("_tr", "step", "t", "x", "xd")

    def __init__(self, trajectory: Any, step: int, t: float, x: float, xd: float) -> None:
        self._tr = trajectory
        self.step = step
        self.t = t
        self.x = x
        self.xd = xd

    @property
    def length(self) -> float:
        """The element's length (springs, dampers): the same as ``x``."""
        return self.x

    @property
    def rate(self) -> float:
        """The rate of the element's coordinate: the same as ``xd``."""
        return self.xd

    def var(self, key: Any) -> float:
        """A joint variable at this step (radians or length)."""
        return float(self._tr.q[self.step, self._tr.system.var_index(key)])

    def var_rate(self, key: Any) -> float:
        """The rate of a joint variable at this step (0 without rates)."""
        if not self._tr.has_rates:
            return 0.0
        return float(self._tr.qd[self.step, self._tr.system.var_index(key)])

    def point(self, name: str) -> np.ndarray:
        """Global position (3,) of a point at this step."""
        return self._tr.point(name)[self.step].copy()

    def point_velocity(self, name: str) -> np.ndarray:
        """Global velocity (3,) of a point at this step (0 without rates: at rest)."""
        if not self._tr.has_rates:
            return np.zeros(3)
        return self._tr.point_velocity(name)[self.step].copy()

    def var_accel(self, key: Any) -> float:
        """The acceleration of a joint variable at this step (0 without rates: at rest;
        NaN while integrating, where the loads decide it)."""
        if not getattr(self._tr, "has_accels", self._tr.has_rates):
            return math.nan
        if not self._tr.has_rates:
            return 0.0
        return float(self._tr.qdd[self.step, self._tr.system.var_index(key)])

    def point_acceleration(self, name: str) -> np.ndarray:
        """Global acceleration (3,) of a point at this step (as :meth:`var_accel`)."""
        if not getattr(self._tr, "has_accels", self._tr.has_rates):
            return np.full(3, math.nan)
        if not self._tr.has_rates:
            return np.zeros(3)
        return self._tr.point_acceleration(name)[self.step].copy()


def _scale(system: Any, name: str, col: int) -> float:
    """Factor from a law's model-unit value to internal units: 1 / the compiled table's
    ``gscale`` of its joint variable ``col`` or ``escale`` of its element ``name``."""
    if col >= 0:
        return 1.0 / float(system.Y.gscale[col])
    return 1.0 / float(system.Y.escale[system.elements.index(name)])


def law_values(system: Any, trajectory: Any, times: np.ndarray) -> np.ndarray:
    """(steps x max(nlaw, 1)) values of every law of ``system`` at every step, internal units.

    A law that raises or returns something that is not a finite number is an
    input error naming the element and the step.
    """
    n = trajectory.nsteps
    out = np.zeros((n, max(len(system.laws), 1)))
    if not system.laws:
        return out
    rates = trajectory.has_rates
    for slot, (what, name, _fn, col) in enumerate(system.laws):
        if col >= 0:
            x = trajectory.q[:, col]
            xd = trajectory.qd[:, col] if rates else np.zeros(n)
        elif what in ("spring", "damper"):
            x, xd = _element_kinematics(system, trajectory, system.elements.index(name))
        else:
            x = xd = np.zeros(n)
        for k in range(n):
            s = LoadState(trajectory, k, float(times[k]), float(x[k]), float(xd[k]))
            out[k, slot] = law_value(system, slot, s, f"step {k}")
    return out


def law_value(system: Any, slot: int, s: LoadState, where: str) -> float:
    """The value of law ``slot`` of ``system`` at ``s``, internal units.  A law that
    raises or gives something that is not a finite number is an input error naming
    the element and ``where`` ("step 3", "t = 0.25 s")."""
    what, name, fn, col = system.laws[slot]
    label = f"{what} {name!r}" if col < 0 else f"{what} of {system.var_names[col]}"
    try:
        v = float(fn(s))
    except InputError:
        raise
    except Exception as exc:  # the user's function: any failure is bad input
        raise InputError(f"{label}: its law failed at {where}: "
                         f"{type(exc).__name__}: {exc}") from None
    if not math.isfinite(v):
        raise InputError(f"{label}: its law gave {v} at {where}; it must give a finite number")
    return v * _scale(system, name, col)


def _element_kinematics(system: Any, trajectory: Any, i: int) -> tuple[np.ndarray, np.ndarray]:
    """Length and its rate (model units, steps each) of spring or damper i."""
    p1, p2 = (system.points[int(p)] for p in system.Y.ept[i, :2])
    d = trajectory.point(p1) - trajectory.point(p2)
    ln = np.linalg.norm(d, axis=1)
    if not trajectory.has_rates:
        return ln, np.zeros_like(ln)
    dv = trajectory.point_velocity(p1) - trajectory.point_velocity(p2)
    with np.errstate(invalid="ignore", divide="ignore"):
        rate = np.where(ln > 0, np.einsum("ij,ij->i", d, dv) / np.where(ln > 0, ln, 1.0), 0.0)
    return ln, rate


def law_values_at(system: Any, q: np.ndarray, qd: np.ndarray, t: float) -> np.ndarray:
    """:func:`law_values` at states that are not a solved motion: rows of joint
    variables q and rates qd (steps x nq, internal units), all at time t."""
    n = q.shape[0]
    tr = Trajectory(system, q.copy(), np.ones(n), np.zeros(n, np.int64),
                    np.zeros((n, system.nq), bool), np.zeros(n, np.int64), [],
                    tracker=tracker(system))
    tr.set_rates(qd.copy(), np.zeros_like(qd), np.zeros(n))
    return law_values(system, tr, np.full(n, float(t)))


class Instant:
    """One instant of a time response as a load law reads it: a trajectory of one step
    (``q``, ``qd``, ``point``, ``point_velocity`` in model units) read straight from
    the run's state ``S`` (internal units) and the postures and body rates of its
    scratch ``data`` (the stage just evaluated), with nothing recomputed."""

    has_rates = True
    #: the stage's accelerations follow from the loads being evaluated
    has_accels = False
    nsteps = 1

    def __init__(self, system: Any, S: Any, data: Any) -> None:
        self.system = system
        #: the run's state (set when the run starts)
        self.S = S
        self._T0 = data.v.T0
        self._V = data.v.V

    @property
    def q(self) -> np.ndarray:
        return (self.S.q * self.system.var_scale)[None, :]

    @property
    def qd(self) -> np.ndarray:
        return (self.S.qd * self.system.var_scale)[None, :]

    def _local(self, name: str) -> tuple[int, np.ndarray]:
        K = self.system.K
        p = self.system.point_index(name)
        b = int(K.ptbody[p])
        return b, self._T0[b, :3] @ K.ptlocal[p]

    def motion(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        """Global position and velocity (3,) of a point, model units (7.27)."""
        b, r = self._local(name)
        v, w = self._V[b, :3], self._V[b, 3:]
        # w x r by hand: numpy's cross costs more than the rest of a law for a 3-vector
        vel = np.array((v[0] + w[1] * r[2] - w[2] * r[1], v[1] + w[2] * r[0] - w[0] * r[2],
                        v[2] + w[0] * r[1] - w[1] * r[0]))
        L = self.system.length_scale
        return r * L, vel * L

    def point(self, name: str) -> np.ndarray:
        """Global position (1, 3) of a point."""
        return (self._local(name)[1] * self.system.length_scale)[None, :]

    def point_velocity(self, name: str) -> np.ndarray:
        """Global velocity (1, 3) of a point (7.27)."""
        return self.motion(name)[1][None, :]


def law_coordinate(system: Any, tr: Any, slot: int) -> tuple[float, float]:
    """The coordinate of law ``slot`` and its rate at step 0 of ``tr`` (model units): the
    joint variable of a joint element, the length of a spring or damper, 0 for a
    force or torque."""
    what, name, _fn, col = system.laws[slot]
    if col >= 0:
        return float(tr.q[0, col]), float(tr.qd[0, col])
    if what in ("spring", "damper"):
        i = system.elements.index(name)
        p1, p2 = (system.points[int(p)] for p in system.Y.ept[i, :2])
        if isinstance(tr, Instant):
            (r1, v1), (r2, v2) = tr.motion(p1), tr.motion(p2)
        else:
            r1, r2 = tr.point(p1)[0], tr.point(p2)[0]
            v1, v2 = tr.point_velocity(p1)[0], tr.point_velocity(p2)[0]
        dvec = r1 - r2
        ln = float(np.linalg.norm(dvec))
        return ln, float(dvec @ (v1 - v2) / ln) if ln > 0 else 0.0
    return 0.0, 0.0


def law_values_now(system: Any, tr: Any, t: float, out: np.ndarray) -> None:
    """The value of every law of ``system`` at step 0 of ``tr`` (an :class:`Instant`) at
    time t into out (nlaw,), internal units."""
    for slot in range(len(system.laws)):
        x, xd = law_coordinate(system, tr, slot)
        out[slot] = law_value(system, slot, LoadState(tr, 0, t, x, xd), f"t = {t:.6g} s")


# ----------------------------------------------------------------------------- nonlinear laws
class BumpStop:
    """A spring that acts only beyond a limit of its coordinate x (model units): the
    value ``rate * (x - limit)`` when ``side * (x - limit) > 0``, else 0.

    For a joint spring (``Model.set_joint_spring(..., law=)``) ``side=+1`` stops an
    increase of the joint variable past ``limit``, ``side=-1`` a decrease; for a
    point spring (``Model.add_spring(..., law=)``, x its length, the value its
    tension) ``side=-1`` is a stop in compression, ``side=+1`` a cable.  Its
    :meth:`switch` is ``side * (x - limit)``: :func:`~openimp.simulate` locates
    the instant of contact and of release in time.
    """

    def __init__(self, limit: float, rate: float, side: int = 1) -> None:
        if side not in (1, -1):
            raise InputError(f"BumpStop side must be +1 or -1, got {side!r}")
        self.limit, self.rate, self.side = float(limit), float(rate), int(side)
        if not (math.isfinite(self.limit) and math.isfinite(self.rate) and self.rate >= 0):
            raise InputError("BumpStop needs a finite limit and a finite rate >= 0")

    def switch(self, s: LoadState) -> float:
        """> 0 in contact."""
        return self.side * (s.x - self.limit)

    def __call__(self, s: LoadState) -> float:
        return self.rate * (s.x - self.limit) if self.switch(s) > 0 else 0.0


class LiftOff(BumpStop):
    """A spring that only pushes (a tyre on the road, a part resting on a support): a
    point spring of free length ``free`` whose tension is ``rate * (x - free)`` while
    compressed (x < free) and 0 once the ends part: the lift-off and the landing
    are located in time."""

    def __init__(self, free: float, rate: float) -> None:
        super().__init__(free, rate, side=-1)


class OneWayDamper:
    """A damper with one coefficient for an increasing coordinate (``extension``) and
    another for a decreasing one (``compression``): the value ``c * xd``.  Its
    :meth:`switch` is the rate xd, so the change of coefficient is located in time."""

    def __init__(self, extension: float, compression: float = 0.0) -> None:
        self.ext, self.comp = float(extension), float(compression)
        if not (math.isfinite(self.ext) and math.isfinite(self.comp)):
            raise InputError("OneWayDamper needs finite coefficients")

    def switch(self, s: LoadState) -> float:
        """The rate of the coordinate."""
        return s.xd

    def __call__(self, s: LoadState) -> float:
        return (self.ext if s.xd > 0 else self.comp) * s.xd


# ----------------------------------------------------------------------------- derivatives
def law_derivatives(system: Any, q: np.ndarray, G: np.ndarray, cols: np.ndarray,
                    qpl: np.ndarray, qdpl: np.ndarray, Gl: np.ndarray, psid: np.ndarray,
                    t: float, D: np.ndarray, K: np.ndarray, messages: list[str],
                    sides: tuple[np.ndarray, np.ndarray] | None = None) -> None:
    """Add g_e dlaw_e/dpsi to K and g_e dlaw_e/dpsi' to D (internal units, in place):
    the laws are black boxes, differentiated by Richardson-extrapolated central
    differences over the closed postures of the kernel (positions) and over the
    joint rates phi' (psi' + s e_k) (rates), at the generalized rates of the set point.
    q (nq,): the set point's joint variables; G (nq, nf) its first-order
    coefficients, cols (nf,) its coordinates; qpl, qdpl (nf, 4, nq), Gl (nf, nlaw)
    and D, K (nf, nf) of :func:`~openimp.dynamics.linear.linearize_kernel`; the
    step h of its postures psi* + (-2h, -h, h, 2h) e_l is read from them (the
    coordinate l itself moves by exactly those offsets).
    ``sides`` (the time response): the directions (nf,) in which each coordinate
    and each rate is moving; where a law has a kink inside the stencil (a stop's
    contact, a one-way damper at rest) its slope is then taken on one side
    (:func:`kinked_slopes`), not averaged across the kink."""
    nf = G.shape[1]
    u = psid[cols]
    qd0 = G @ u
    h = 0.5 * float(qpl[0, 2, cols[0]] - qpl[0, 1, cols[0]]) if nf else 1.0
    rows_q, rows_qd = [], []
    for lcol in range(nf):
        for p in range(4):
            rows_q.append(qpl[lcol, p])
            rows_qd.append(qdpl[lcol, p])  # phi'(psi) psi'*: 0 at rest
    s = 1e-4 * max(1.0, float(np.max(np.abs(u))) if nf else 1.0)
    for k in range(nf):
        for off in (-2.0, -1.0, 1.0, 2.0):
            rows_q.append(q.copy())
            rows_qd.append(qd0 + off * s * G[:, k])
    if sides is not None:  # the laws at the set point itself, for one-sided slopes
        rows_q.append(q.copy())
        rows_qd.append(qd0)
    vals = law_values_at(system, np.array(rows_q), np.array(rows_qd), t)
    w = np.array([1.0, -8.0, 8.0, -1.0])
    nl = Gl.shape[1]
    Pq = vals[:4 * nf].reshape(nf, 4, -1)
    Pr = vals[4 * nf:8 * nf].reshape(nf, 4, -1)
    dpos = (w @ Pq) / (12.0 * h)  # (nf, nlaw)
    drat = (w @ Pr) / (12.0 * s)
    if sides is not None:
        dpos = kinked_slopes(Pq, vals[8 * nf], h, sides[0], dpos)
        drat = kinked_slopes(Pr, vals[8 * nf], s, sides[1], drat)
    K -= Gl[:, :nl] @ dpos[:, :nl].T
    D -= Gl[:, :nl] @ drat[:, :nl].T
    messages.append("load laws differentiated numerically (central differences, "
                    "Richardson extrapolation)")


def kinked_slopes(P: np.ndarray, f0: np.ndarray, h: float, direction: np.ndarray,
                   central: np.ndarray) -> np.ndarray:
    """The slopes of laws with a kink in their stencil taken on one side.  P (nf, 4,
    nlaw): the values at offsets (-2h, -h, h, 2h) of each coordinate; f0 (nlaw,) at
    the point; direction (nf,): the sign of the motion; central (nf, nlaw): the
    Richardson slopes, kept for a smooth law.  Where the one-sided slopes jump far
    more than either side bends (the point on the kink: a located switch) the side
    the motion goes to is taken (the central slope at rest); where they differ and
    only one side is straight, that one (the kink lies within h on the other);
    with the kink between h and 2h the inner central difference."""
    fwd1 = (P[:, 2] - f0) / h
    fwd2 = (P[:, 3] - f0) / (2.0 * h)
    bwd1 = (f0 - P[:, 1]) / h
    bwd2 = (f0 - P[:, 0]) / (2.0 * h)
    tiny = 1e-9 * max(float(np.abs(P).max(initial=0.0)) / h, 1e-300)

    def same(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        return np.abs(a - b) <= 1e-3 * np.maximum(np.abs(a), np.abs(b)) + tiny

    differ = ~same(fwd1, bwd1)
    f_ok, b_ok = same(fwd1, fwd2), same(bwd1, bwd2)
    # on the kink (within 1e-3 h of it): the sides jump far more than either bends (a
    # smooth law's one-sided slopes differ by its curvature, as much as each side bends;
    # a point at d h from a kink bends by d / 2 of the jump on that side)
    jump = np.abs(fwd1 - bwd1)
    bend = np.abs(fwd2 - fwd1) + np.abs(bwd1 - bwd2)
    at0 = differ & (jump > 1000.0 * bend + tiny)
    go = np.broadcast_to(np.sign(direction)[:, None], differ.shape)
    use_f = (at0 & (go > 0)) | (differ & ~at0 & f_ok & ~b_ok)
    use_b = (at0 & (go < 0)) | (differ & ~at0 & b_ok & ~f_ok)
    # a kink between h and 2h: the inner points agree, the outer ones are off it
    inner = 0.5 * (fwd1 + bwd1)
    out = np.where(~differ & ~same(central, inner), inner, central)
    return np.where(use_f, fwd1, np.where(use_b, bwd1, out))
