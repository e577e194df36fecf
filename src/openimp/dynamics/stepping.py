"""Time stepping of the equations of motion (book ch 14), compiled.

The state between steps is the whole mechanism at one instant: every joint
variable S.q on the closed loops, every joint rate and acceleration, the
free generalized coordinates (FGCs) chosen there and the works done since the
start.  A step integrates the FGCs of its start (positions x_F, rates v_F)
with the loops closed at every stage by the posture solver (ch 6, Newton,
holding the FGCs and the SGCs); the dependent variables never drift.  At the
end of an accepted step the FGCs are chosen again (:func:`choose`) and the
rates carried across a change of coordinates through the joint rates
(qd = phi' psi', 7.16): the state is coordinate-free, so is the first stage
of the next step (full joint accelerations).

Two integrators share the stage (:func:`close_stage`, :func:`evaluate`):

* ``rk``: Dormand-Prince 5(4) (embedded pair, error estimate of order 4,
  FSAL), error per step controlled on x_F and v_F against ``atol + rtol |y|``;
* ``book``: the book's locally linearized exact-exponential step (14.11-14.30,
  the algorithm of the book's section 14.4): M, D, K of ch 11 frozen at the
  step start, the SGC motion over the step as a quadratic in time, the linear
  system solved exactly by the exponential of the augmented matrix (Van Loan;
  no Jordan form), the loops closed at the end, and the step controlled by the
  force error eps = M_FF (psi''_F - v'_F) of section 14.5 (IMP's ZERO (FORCE)).

Works are integrated with the motion: of the drives (SGC forces times SGC
rates), of the loads that have no potential, and the energy the dampers take
out; with the kinetic and potential energies they make the energy audit.

Everything here is in internal units (:mod:`openimp.system`).  A run's arrays
and scalars are the fields of one table, :data:`WORK_FIELDS`, packed into
:class:`Work` and unpacked by name in each kernel (:func:`step_views`).

What only Python can give (the SGC motions of time, the load laws, their
switching functions) is asked for from inside the step through the run's
registered handler (:mod:`~openimp.dynamics.hooks`): the motion rows at an
attempt's stage times, the law values at a stage as soon as its joint rates
are known (one evaluation of the equations per stage), the laws' slopes for
the book's linear model, and after each accepted step whether a switching
function changed sign (the run then returns EVENT and the caller locates the
root with the attempts below).
"""

from __future__ import annotations

import math
from collections import namedtuple
from enum import IntEnum
from typing import NamedTuple

import numpy as np

from openimp._jit import njit, packed_views
from openimp.dynamics import hooks as _hooks
from openimp.dynamics.ballstep import (
    ball_axes,
    ball_blocks,
    ball_marks,
    ball_moments,
    from_local,
    to_local,
)
from openimp.dynamics.eom import eom_loads, eom_rates
from openimp.dynamics.hooks import Hook, call_hook
from openimp.dynamics.linear import (
    H_MOTION,
    LinOptions,
    linearize_kernel,
    make_lin_work,
    make_linearized,
)
from openimp.kinematics.elimination import eliminate, free_columns, jacobian
from openimp.kinematics.position import position
from openimp.kinematics.posture import newton
from openimp.kinematics.singular import NEAR_SINGULAR
from openimp.linalg import cholesky_solve, expm
from openimp.system import (
    DAMPER,
    SPRING,
    Field,
    allocate,
    data_views,
    dyn_data_views,
    dyn_views,
    layout_of,
    views,
)


# ------------------------------------------------------------------ codes
class Stage(IntEnum):
    """What a stage or an attempt found (``Work.why``)."""

    OK = 0
    #: the loops cannot be closed (Newton did not converge)
    NO_CLOSURE = 1
    #: M_FF is singular (IMP's ZERO (INERTIA))
    SINGULAR_MASS = 2
    #: the elimination no longer leaves exactly the FGCs and SGCs
    LOST_COORDINATES = 3
    #: the book's step stays larger than its largest displacement
    TOO_LARGE = 4
    #: the error control asked for a step below the time's resolution
    UNDERFLOW = 5
    #: a motion, a law or a switching function (Python) failed: the run's handler says why
    PYTHON = 6
    #: a stage fell next to a change point (the whole loop Jacobian nearly singular):
    #: the attempt is retried with a length whose stages pass it (:func:`pass_change`)
    NEAR_CHANGE = 7
    #: MAX_REJECTS attempts in a row were rejected: the run makes no progress
    NO_PROGRESS = 8
    #: the state, the accelerations or the force error came out infinite or NaN (an
    #: element value or a rate the arithmetic cannot hold, or a blow-up)
    NOT_FINITE = 9
    #: the error control asked for a step below the floor w.hfloor (a fraction of the
    #: output step: a pole, a growing motion, a rate too high for the outputs asked)
    TINY_STEP = 10


class Attempt(IntEnum):
    """What an attempt decided."""

    ACCEPTED = 0
    REJECTED = 1
    FAILED = 2


class RunEnd(IntEnum):
    """Why a compiled run returned."""

    #: every output done
    REACHED = 0
    #: the FGCs changed at w.t (the caller records it and calls again)
    SWITCHED = 1
    #: a step could not be taken even at the smallest length (w.why says why)
    STOPPED = 2
    #: max_steps steps taken
    CAPPED = 3
    #: the next step's outputs would not fit the rows left
    FULL = 4
    #: a switching function changed sign over the step just accepted (outputs not yet
    #: recorded): the caller locates the root and finishes the step (:func:`after_step`)
    EVENT = 5
    #: the step just accepted passed a change point (outputs recorded; its time and
    #: posture in w.tcross, w.qcross): the caller records it and calls again
    CROSSED = 6
    #: the handler asked for Python (TICK: time to show progress and honour Ctrl-C); the
    #: caller calls again
    PAUSED = 7


# the codes as plain integers for the kernels
OK, NO_CLOSURE, SINGULAR_MASS = int(Stage.OK), int(Stage.NO_CLOSURE), int(Stage.SINGULAR_MASS)
LOST_COORDINATES, TOO_LARGE = int(Stage.LOST_COORDINATES), int(Stage.TOO_LARGE)
UNDERFLOW, PYTHON, NEAR_CHANGE = int(Stage.UNDERFLOW), int(Stage.PYTHON), int(Stage.NEAR_CHANGE)
NO_PROGRESS, NOT_FINITE = int(Stage.NO_PROGRESS), int(Stage.NOT_FINITE)
TINY_STEP = int(Stage.TINY_STEP)
ACCEPTED, REJECTED, FAILED = int(Attempt.ACCEPTED), int(Attempt.REJECTED), int(Attempt.FAILED)
REACHED, SWITCHED, STOPPED = int(RunEnd.REACHED), int(RunEnd.SWITCHED), int(RunEnd.STOPPED)
CAPPED, FULL, EVENT = int(RunEnd.CAPPED), int(RunEnd.FULL), int(RunEnd.EVENT)
CROSSED, PAUSED = int(RunEnd.CROSSED), int(RunEnd.PAUSED)
H_MOTION_ROWS, H_LAWS, H_LAW_TERMS = int(Hook.MOTION), int(Hook.LAWS), int(Hook.LAW_TERMS)
H_SNAP, H_SWITCH, H_TICK = int(Hook.SNAP), int(Hook.SWITCH), int(Hook.TICK)
H_CROSSED, H_TOLD = _hooks.CROSSED, _hooks.TOLD

# Dormand-Prince 5(4): nodes, stage weights (row 6 = the 5th-order weights, FSAL) and the
# error weights b - b^ (b^ the 4th-order weights)
RK_C = np.array([0.0, 0.2, 0.3, 0.8, 8.0 / 9.0, 1.0, 1.0])
RK_A = np.array([
    [0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [0.2, 0.0, 0.0, 0.0, 0.0, 0.0],
    [3.0 / 40.0, 9.0 / 40.0, 0.0, 0.0, 0.0, 0.0],
    [44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0, 0.0, 0.0, 0.0],
    [19372.0 / 6561.0, -25360.0 / 2187.0, 64448.0 / 6561.0, -212.0 / 729.0, 0.0, 0.0],
    [9017.0 / 3168.0, -355.0 / 33.0, 46732.0 / 5247.0, 49.0 / 176.0, -5103.0 / 18656.0, 0.0],
    [35.0 / 384.0, 0.0, 500.0 / 1113.0, 125.0 / 192.0, -2187.0 / 6784.0, 11.0 / 84.0],
])
RK_E = np.array([35.0 / 384.0 - 5179.0 / 57600.0, 0.0, 500.0 / 1113.0 - 7571.0 / 16695.0,
                 125.0 / 192.0 - 393.0 / 640.0, -2187.0 / 6784.0 + 92097.0 / 339200.0,
                 11.0 / 84.0 - 187.0 / 2100.0, -1.0 / 40.0])
NSTAGE = 7
#: 3-point Gauss-Legendre nodes on [0, 1] and weights (exact to degree 5)
GL_X = np.array([0.5 - math.sqrt(15.0) / 10.0, 0.5, 0.5 + math.sqrt(15.0) / 10.0])
GL_W = np.array([5.0 / 18.0, 8.0 / 18.0, 5.0 / 18.0])
#: the stage times of the book's step (start, middle, end) as fractions of it
BOOK_C = np.array([0.0, 0.5, 1.0])
#: a step whose stages' smallest pivot (of the closures, FGCs and SGCs held) fell below
#: this fraction of the largest met is searched for a change point (the whole Jacobian's
#: smallest pivot, along the step)
DIP = 0.2
#: a change point is located where the whole Jacobian's smallest pivot falls below this
#: fraction of its regular value (:func:`crossing`)
VANISH = 1e-3
#: a closure whose smallest pivot (FGCs and SGCs held) is below this many times
#: NEAR_SINGULAR is asked whether it is next to a change point (the whole Jacobian's
#: pivots are not the same numbers as the partitioned one's)
WATCH = 10.0
#: stages are placed at least this many times NEAR_SINGULAR of pivot away from a change
#: point (the pivot taken linear in time there)
MARGIN = 1.5
#: attempts rejected in a row after which a run stops (NO_PROGRESS): every loop of the
#: step ends
MAX_REJECTS = 1000
#: attempts between the first two questions to the handler's clock (Hook.TICK); the
#: handler then sets w.tick (an object-mode call costs about as much as an attempt)
TICK_EVERY = 8
#: attempts refused in a row next to a change point before the step is only halved
NEAR_TRIES = 6
#: a step placed to pass a change point is kept up to this error (against the
#: tolerance): the stages next to it carry round-off no shorter step removes
LEAP_ERR = 100.0
#: the book's force error is a difference of inertia terms: below this fraction of
#: the largest of them it is round-off, whatever ZERO (FORCE)'s percentage of the
#: forces met (none, in a free steady spin)
FORCE_ROUNDOFF = 1e-10
#: a step whose stages see the free coordinates' mass matrix this close to singular
#: (the smallest Cholesky pivot of M_FF over its own diagonal entry: the squared sine
#: of the angle between a coordinate's inertia and the others', 6 degrees) is watched
#: for a dip through a singular posture (:func:`mass_dip`)
MASS_WATCH = 1e-2



#: the three works and powers of the energy audit (w.w0, w.pw, ...): of the drives, of
#: the loads without potential, dissipated
DRIVE, LOADS, DISSIPATED = range(3)
#: the row of w.ms at the book step's middle (row 0 its start, the last its end)
BOOK_MID = 1

#: The arrays of one integration (internal units).  Sizes: nq joint variables, ns SGCs,
#: nstage Dormand-Prince stages (7), n = 2 nq + 3 (the book's augmented matrix), nlaw
#: load laws (at least 1).  Scalars are fields of one element.
WORK_FIELDS: tuple[Field, ...] = (
    # the run's settings
    Field("rtol", "f", (1,), "relative tolerance of the rk error per step"),
    Field("atol", "f", (1,), "absolute tolerance of the rk error per step"),
    Field("hmin", "f", (1,), "smallest step (s)"),
    Field("hmax", "f", (1,), "largest step (s)"),
    Field("hcap", "f", (1,), "the book step's cap while switches are watched: a quarter "
          "of the shortest period of the last step's linear model (inf: none)"),
    Field("hfloor", "f", (1,), "without a smallest step: the run stops when the error "
          "control asks for less (s)"),
    Field("ptol", "f", (1,), "pivot tolerance of the elimination"),
    Field("ctol", "f", (1,), "loop-closure tolerance of Newton"),
    Field("mtol", "f", (1,), "singularity test of M_FF (IMP's ZERO (INERTIA))"),
    Field("fabs", "f", (1,), "force error limit of the book's step, model units"),
    Field("fpct", "f", (1,), "force error limit, percent of the largest force met"),
    Field("xmax", "f", (1,), "largest displacement of a book step (internal units)"),
    Field("maxit", "i", (1,), "Newton iterations allowed to close the loops at a stage"),
    Field("hook", "i", (1,), "id of the run's Python handler (dynamics.hooks)"),
    Field("tick", "i", (1,), "attempts between two questions to the handler's clock (the "
          "handler sets it: TICK_EVERY at first, then about TICK_GAP seconds' worth)"),
    Field("driven", "b", (1,), "the SGC motions are Python callables (else held)"),
    Field("laws", "b", (1,), "the system has load laws (Python callables)"),
    Field("events", "b", (1,), "the laws' switching functions are watched"),
    Field("watch", "b", (1,), "a law is told of every accepted step (Hook.SWITCH)"),
    # the coordinates
    Field("gscale", "f", ("nq",), "model units of a generalized force per internal unit"),
    Field("role", "i", ("nq",), "0 dependent, 1 FGC, 2 SGC"),
    Field("nF", "i", (1,), "number of FGCs"),
    Field("fcols", "i", ("nq",), "the FGC columns, ascending (nF used)"),
    Field("scols", "i", ("ns",), "the SGC columns, ascending"),
    # the step start and the step
    Field("t", "f", (1,), "time of the step start"),
    Field("h", "f", (1,), "length of the attempt"),
    Field("hnext", "f", (1,), "proposed length of the next attempt"),
    Field("hprop", "f", (1,), "the proposal before a book step was cut to land"),
    Field("q0", "f", ("nq",), "joint variables at the step start"),
    Field("qd0", "f", ("nq",), "their rates"),
    Field("qdd0", "f", ("nq",), "their accelerations"),
    Field("x0", "f", ("nq",), "FGC positions at the step start"),
    Field("v0", "f", ("nq",), "FGC rates at the step start"),
    Field("w0", "f", (3,), "works at the step start: drive, loads without potential, "
          "dissipated"),
    Field("ke0", "f", (1,), "kinetic energy at the step start"),
    Field("pe0", "f", (1,), "potential energy at the step start"),
    Field("clos0", "f", (1,), "loop-closure residual at the step start"),
    Field("qual0", "f", (1,), "quality index at the step start"),
    Field("law0", "f", ("nlaw",), "law values at the step start"),
    Field("mt", "f", ("nstage",), "times of the SGC motion rows asked of the handler"),
    Field("nmt", "i", (1,), "number of them"),
    Field("ms", "f", ("nstage", "ns", 3), "SGC position, rate, acceleration at each stage "
          "time (the last row also the step end)"),
    # the stages
    Field("kx", "f", ("nstage", "nq"), "stage derivatives of the FGC positions"),
    Field("kv", "f", ("nstage", "nq"), "stage derivatives of the FGC rates"),
    Field("kw", "f", ("nstage", 3), "stage powers"),
    Field("xs", "f", ("nq",), "FGC positions of a stage"),
    Field("vs", "f", ("nq",), "FGC rates of a stage"),
    Field("ws", "f", (3,), "works of a stage"),
    Field("xe", "f", ("nq",), "the book step's predicted end (book_mid)"),
    Field("ve", "f", ("nq",), "its rates"),
    Field("ke", "f", (1,), "kinetic energy of the stage last evaluated"),
    Field("pe", "f", (1,), "potential energy of the stage last evaluated"),
    Field("closure", "f", (1,), "loop-closure residual of the stage last evaluated"),
    Field("quality", "f", (1,), "quality index of the last closure"),
    Field("lscale", "f", (1,), "size of the generalized loads of the last evaluation"),
    Field("mscale", "f", (1,), "largest diagonal of M_FF at the first evaluation with "
          "these coordinates (0: not yet)"),
    # the equations at a stage
    Field("psid", "f", ("nq",), "generalized rates"),
    Field("aF", "f", ("nq",), "FGC accelerations"),
    Field("rhs", "f", ("nq",), "right-hand side"),
    Field("M", "f", ("nq", "nq"), "mass matrix of the generalized coordinates"),
    Field("c", "f", ("nq",), "velocity products"),
    Field("Q", "f", ("nq",), "generalized forces"),
    Field("Lc", "f", ("nq", "nq"), "Cholesky factor of M_FF"),
    Field("pw", "f", (3,), "stage powers"),
    Field("ag", "f", ("nq",), "generalized accelerations (column order)"),
    Field("keep", "b", ("nq",), "scratch"),
    # the book's step
    Field("have_lin", "b", (1,), "the linear model of this step start is made"),
    Field("law_ok", "b", (1,), "its closed postures are whole (the laws' slopes can be "
          "taken)"),
    Field("Ab", "f", ("n", "n"), "the augmented matrix (14.11)"),
    Field("Eb", "f", ("n", "n"), "its exponential"),
    Field("X1", "f", ("n", "n"), "scratch"),
    Field("X2", "f", ("n", "n"), "scratch"),
    Field("X3", "f", ("n", "n"), "scratch"),
    Field("ap", "f", ("nq",), "predicted accelerations at the step end"),
    Field("lcols", "i", ("nq",), "column order of the linearization"),
    Field("iF", "i", ("nq",), "places of the FGCs in it"),
    Field("iS", "i", ("nq",), "places of the SGCs in it"),
    Field("gF", "f", (3, "nq"), "forcing terms of the FGC rows"),
    Field("Minv", "f", ("nq", "nq"), "M_FF^-1"),
    Field("mpiv", "f", (NSTAGE,), "smallest Cholesky pivot of M_FF over its own diagonal "
          "entry at each stage (mass_dip)"),
    Field("mnow", "f", (1,), "the same at the last evaluation (a stage, or an output)"),
    Field("mdiag", "f", ("nq",), "the diagonal of M_FF before its factorization"),
    Field("ball", "i", ("nq", 4), "the ball joints the book's step takes in local rotation "
          "coordinates (ballstep.ball_blocks; -1 in the row after the last, from the start)"),
    Field("bax", "f", ("nq", 3, 3), "per ball of ``ball`` the axes of its angles "
          "(ballstep.ball_axes)"),
    Field("bs", "f", (12, 12), "scratch of the balls' angles"),
    Field("wq", "f", (3,), "powers at the middle (book) or over the Gauss nodes"),
    Field("fscale", "f", (1,), "largest generalized force met (force error percent)"),
    # the step just taken, for the outputs inside it
    Field("tprev", "f", (1,), "its start"),
    Field("xprev", "f", ("nq",), "FGC positions at its start"),
    Field("vprev", "f", ("nq",), "FGC rates at its start"),
    Field("aprev", "f", ("nq",), "FGC accelerations at its start"),
    Field("wprev", "f", (3,), "works at its start"),
    Field("pprev", "f", (3,), "powers at its start"),
    # the run's account
    Field("steps", "i", (1,), "steps taken"),
    Field("rejects", "i", (1,), "attempts rejected"),
    Field("evals", "i", (1,), "evaluations of the equations"),
    Field("closes", "i", (1,), "closures of the loops"),
    Field("forced", "i", (1,), "steps accepted at the smallest length above the tolerance"),
    Field("atmin", "b", (1,), "the attempt's proposal was the smallest step (it is kept "
          "whatever its error, even when stretched to land on an output)"),
    Field("inrow", "i", (1,), "attempts rejected since the last accepted step"),
    Field("err", "f", (1,), "error of the last attempt against its tolerance"),
    Field("smallest", "f", (1,), "smallest step taken"),
    Field("largest", "f", (1,), "largest step taken"),
    Field("qref", "f", (1,), "quality index at the last choice of the FGCs"),
    Field("why", "i", (1,), "why the last attempt failed (Stage)"),
    Field("tfail", "f", (1,), "time of an output that failed (NaN: the step's)"),
    # change points (the whole loop Jacobian singular, branches of motion meeting)
    Field("qpred", "f", ("nq",), "predicted posture of the stage last closed"),
    Field("qkeep", "f", ("nq",), "scratch posture"),
    Field("pmin", "f", (1,), "smallest pivot of the last closure (FGCs, SGCs held)"),
    Field("pmax", "f", (1,), "the largest pmin met (its regular size)"),
    Field("wmax", "f", (1,), "the whole Jacobian's smallest pivot at the last restart "
          "(its regular size; nothing held)"),
    Field("pdip", "f", (1,), "the smallest pmin over the stages of the attempt"),
    Field("tdip", "f", (1,), "the time of that stage"),
    Field("qdip", "f", ("nq",), "its posture"),
    Field("near", "f", (4,), "an attempt refused next to a change point: the time of its "
          "stage nearest it, the whole Jacobian's smallest pivot there and at the step "
          "start, the pivot below which no stage may fall"),
    Field("nears", "i", (1,), "attempts refused in a row next to a change point"),
    Field("leap", "b", (1,), "the attempt's length was chosen to pass a change point (kept "
          "whatever its error)"),
    Field("qprev", "f", ("nq",), "joint variables at the start of the step just taken"),
    Field("qdprev", "f", ("nq",), "their rates"),
    Field("qddprev", "f", ("nq",), "their accelerations"),
    Field("tcross", "f", (1,), "time of the change point last passed"),
    Field("pcross", "f", (1,), "the whole Jacobian's smallest pivot there"),
    Field("qcross", "f", ("nq",), "the posture there"),
)

KStep = namedtuple("KStep", [f.name for f in WORK_FIELDS])  # type: ignore[misc]
#: ``step_views(W.P)``: the :data:`WORK_FIELDS` of a run as named views, inside a kernel
step_views = packed_views(layout_of(WORK_FIELDS), KStep)


class Work(NamedTuple):
    """The scratch of one integration: ``P`` the packed :data:`WORK_FIELDS` (unpacked
    in a kernel by :func:`step_views`), ``lin`` and ``lwork`` the linear model and
    the scratch of :func:`~openimp.dynamics.linear.linearize_kernel`."""

    P: tuple
    lin: tuple
    lwork: tuple


class OutputRows(NamedTuple):
    """The output rows a run writes (internal units; rows of the output times)."""

    #: (rows,) time
    t: np.ndarray
    #: (rows, nq) joint variables, rates, accelerations
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    #: (rows, nq) bool: the FGCs
    fgc: np.ndarray
    #: (rows,) quality index and loop-closure residual
    quality: np.ndarray
    closure: np.ndarray
    #: (rows, 5): kinetic, potential, drive work, load work, dissipated
    energy: np.ndarray


class Outputs(NamedTuple):
    """The outputs of a run: all the times, the next one to record (``k``, (1,)), the
    rows held (``rows``, of the outputs from ``base``, at most ``cap`` of them)."""

    times: np.ndarray
    k: np.ndarray
    rows: OutputRows
    base: int
    cap: int


def work_arrays(W: Work) -> KStep:
    """The fields of W as named numpy views (Python side)."""
    return KStep(*views(WORK_FIELDS, W.P))


def make_work(nq: int, ns: int, nb: int, nlaw: int) -> Work:
    """Zeroed arrays of :class:`Work` for nq joint variables, ns SGCs, nb bodies."""
    lin = make_linearized(nq, nb, max(nlaw, 1))
    lwork = make_lin_work(nq, nb)
    sizes = {"nq": nq, "ns": ns, "nstage": NSTAGE, "n": 2 * nq + 3, "nlaw": max(nlaw, 1)}
    W = Work(allocate(WORK_FIELDS, sizes), lin, lwork)
    work_arrays(W).ball[:] = -1  # no ball stepped locally before the first linearization
    return W


# ------------------------------------------------------------------ the stage
@njit(nrt=False)
def close_stage(KP: tuple, DP: tuple, S: tuple, gen: np.ndarray | None, W: Work,
                dt: float, srow: int, watch: bool) -> int:
    """Close the loops at the stage state: every joint variable predicted from the step
    start over dt (second-order Taylor), the FGCs at w.xs, the SGCs at w.ms[srow];
    Newton holding both.  Returns OK, NO_CLOSURE or, with ``watch`` (the stages of
    an attempt), NEAR_CHANGE (:func:`near_change`)."""
    w = step_views(W.P)
    for a in range(S.q.shape[0]):
        S.q[a] = w.q0[a] + dt * w.qd0[a] + 0.5 * dt * dt * w.qdd0[a]
    return _close(KP, DP, S, gen, W, srow, watch)


@njit(nrt=False)
def close_near(KP: tuple, DP: tuple, S: tuple, gen: np.ndarray | None, W: Work,
               dt: float, srow: int) -> int:
    """:func:`close_stage` predicted from the posture last evaluated in S (its q, qd,
    qdd) over dt: a point near it, not near the step start."""
    for a in range(S.q.shape[0]):
        S.q[a] += dt * S.qd[a] + 0.5 * dt * dt * S.qdd[a]
    return _close(KP, DP, S, gen, W, srow, False)


@njit(nrt=False, inline="always")
def _close(KP: tuple, DP: tuple, S: tuple, gen: np.ndarray | None, W: Work,
           srow: int, watch: bool) -> int:
    """Newton from the predicted S.q holding the FGCs at w.xs and the SGCs at
    w.ms[srow]; the quality index into w.quality[0], the smallest pivot into
    w.pmin[0].  OK, NO_CLOSURE or NEAR_CHANGE (with ``watch``)."""
    w = step_views(W.P)
    d = data_views(DP)
    nq = S.q.shape[0]
    nF = w.nF[0]
    for a in range(nq):
        w.keep[a] = S.sgc[a]
    for j in range(nF):
        S.q[w.fcols[j]] = w.xs[j]
        S.sgc[w.fcols[j]] = True
    for s in range(w.scols.shape[0]):
        S.q[w.scols[s]] = w.ms[srow, s, 0]
    for a in range(nq):
        w.qpred[a] = S.q[a]
    status, _, rank, quality, rest = newton(KP, DP, S, gen, w.ctol[0], w.ptol[0],
                                            w.maxit[0], False)
    for a in range(nq):
        S.sgc[a] = w.keep[a]
    w.closes[0] += 1
    # the smallest pivot; a pivot lost counts as the entry left (the rank the FGCs and
    # SGCs leave is nq - nF - nS)
    p = rest
    if rank == nq - nF - w.scols.shape[0]:
        p = math.inf
        for k in range(rank):
            p = min(p, abs(1.0 / d.pinv[k]))
    w.pmin[0] = p
    if watch and (status != 0 or p < WATCH * NEAR_SINGULAR) and near_change(
            KP, DP, S, gen, W, status != 0):
        return NEAR_CHANGE
    if status != 0:
        return NO_CLOSURE
    w.quality[0] = quality
    if watch:
        w.pmax[0] = max(w.pmax[0], p)
        if p < w.pdip[0]:
            w.pdip[0] = p
            w.tdip[0] = S.t[0]
            for a in range(nq):
                w.qdip[a] = S.q[a]
    return OK


# ------------------------------------------------------------------ change points
@njit(nrt=False)
def whole_pivot(KP: tuple, DP: tuple, S: tuple, gen: np.ndarray | None, W: Work) -> float:
    """The smallest pivot of the whole loop Jacobian at S.q, nothing held: it vanishes at a
    change point, where the mechanism gains freedoms and branches of motion meet (book
    6.9), whatever the coordinates, and not at a dead point of the SGCs (a limit of
    travel of a driven coordinate); a pivot lost counts as the entry left."""
    w = step_views(W.P)
    d = data_views(DP)
    position(KP, DP, S, gen, 1)
    jacobian(KP, DP, S, gen)
    for a in range(S.q.shape[0]):
        w.keep[a] = False
    rank, _, rest = eliminate(DP, w.keep, w.ptol[0])
    if rank < S.q.shape[0] - w.nF[0] - w.scols.shape[0]:
        return rest
    p = math.inf
    for k in range(rank):
        p = min(p, abs(1.0 / d.pinv[k]))
    return p


@njit(nrt=False)
def near_change(KP: tuple, DP: tuple, S: tuple, gen: np.ndarray | None, W: Work,
                failed: bool) -> bool:
    """A stage whose closure failed (``failed``) or came out nearly singular: is it next to
    a change point the step passes?  True when the whole Jacobian's smallest pivot is
    below NEAR_SINGULAR at the stage (closed, or predicted when Newton failed) while the
    step start is regular; its time and both pivots go into w.near for
    :func:`pass_change`.  Nearly singular FGCs alone (a dead point of the coordinates)
    are not: the FGCs are chosen again after the step.  S.q is left as it came."""
    w = step_views(W.P)
    nq = S.q.shape[0]
    for a in range(nq):
        if failed:
            S.q[a] = w.qpred[a]
        w.qkeep[a] = S.q[a]
    ps = whole_pivot(KP, DP, S, gen, W)
    near = False
    if ps < NEAR_SINGULAR:
        for a in range(nq):
            S.q[a] = w.q0[a]
        p0 = whole_pivot(KP, DP, S, gen, W)
        if p0 >= NEAR_SINGULAR and p0 > 1.05 * ps and S.t[0] > w.t[0]:
            w.near[0] = S.t[0]
            w.near[1] = ps
            w.near[2] = p0
            w.near[3] = NEAR_SINGULAR
            near = True
        for a in range(nq):
            S.q[a] = w.qkeep[a]
    return near


@njit(nrt=False)
def near_noise(KP: tuple, DP: tuple, S: tuple, gen: np.ndarray | None, W: Work) -> bool:
    """An attempt rejected by its error whose stages came near a change point (a stage's
    smallest pivot below DIP of the largest met, and the whole Jacobian's there below
    DIP of its regular size, falling from the step start): next to a change point the
    stage derivatives carry the round-off of the small pivots (the velocity products
    through J11^-1 twice: about u / p^2), which no shorter step removes.  True with
    w.near set for :func:`pass_change`, the band doubled from the pivot met (S.q is
    scratch: the attempt is rejected)."""
    w = step_views(W.P)
    nq = S.q.shape[0]
    if not (w.pdip[0] < DIP * w.pmax[0] and w.wmax[0] > 0.0 and w.tdip[0] > w.t[0]):
        return False
    for a in range(nq):
        S.q[a] = w.qdip[a]
    ps = whole_pivot(KP, DP, S, gen, W)
    if ps >= DIP * w.wmax[0]:
        return False
    for a in range(nq):
        S.q[a] = w.q0[a]
    p0 = whole_pivot(KP, DP, S, gen, W)
    if p0 <= 1.05 * ps:
        return False
    w.near[0] = w.tdip[0]
    w.near[1] = ps
    w.near[2] = p0
    w.near[3] = max(NEAR_SINGULAR, 2.0 * ps)
    return True


@njit(nrt=False)
def pass_change(W: Work, nodes: np.ndarray) -> None:
    """The next attempt's length after one refused next to a change point (w.near): the
    whole Jacobian's smallest pivot taken linear in time from the step start to the
    refused stage gives the time d to the change point and the half-width dz of the
    band around it where no stage may fall (MARGIN times NEAR_SINGULAR of pivot).  The
    length is the largest one up to the refused attempt's that puts the band between
    two stage times ``nodes`` (fractions of the step, ascending from 0 to 1); else the
    step to the band's edge; else the shortest length that passes it, kept up to
    LEAP_ERR times its tolerance (w.leap: so short a step is no less accurate than one
    that reached the band).  After NEAR_TRIES refusals in a row the shortest length
    that passes it, kept whatever its error (counted as forced)."""
    w = step_views(W.P)
    h = w.h[0]
    w.leap[0] = False
    w.nears[0] += 1
    rate = (w.near[2] - w.near[1]) / (w.near[0] - w.t[0])
    if not rate > 0.0:
        w.hnext[0] = 0.5 * h
        return
    d = w.near[2] / rate
    dz = MARGIN * w.near[3] / rate
    best = 0.0
    least = math.inf
    for i in range(nodes.shape[0] - 1):
        lo = (d + dz) / nodes[i + 1]
        hi = (d - dz) / nodes[i] if nodes[i] > 0.0 else math.inf
        if lo > hi:
            continue
        if lo <= h:
            best = max(best, min(hi, h))
        least = min(least, lo)
    if best > 0.0 and w.nears[0] < NEAR_TRIES:
        w.hnext[0] = best
    elif d - dz > 1e-12 * max(1.0, abs(w.t[0])) and w.nears[0] < NEAR_TRIES:
        w.hnext[0] = min(d - dz, h)  # to the band's edge
    elif least < math.inf:
        w.hnext[0] = least
        w.leap[0] = True
    else:  # the start already inside the band
        w.hnext[0] = 0.5 * h


@njit(nrt=False)
def hermite_posture(S: tuple, W: Work, tk: float) -> None:
    """S.q = the joint variables at tk inside the step just taken: the quintic Hermite
    interpolant through both ends' positions, rates and accelerations (the loops
    not closed: the error is O(h^6), far below the pivots searched)."""
    w = step_views(W.P)
    t0 = w.tprev[0]
    h = w.t[0] - t0
    h0, h1, h2, h3, h4, h5 = quintic((tk - t0) / h)
    for a in range(S.q.shape[0]):
        S.q[a] = (h0 * w.qprev[a] + h * h1 * w.qdprev[a] + h * h * h2 * w.qddprev[a]
                  + h3 * w.q0[a] + h * h4 * w.qd0[a] + h * h * h5 * w.qdd0[a])


@njit(nrt=False)
def crossing(KP: tuple, DP: tuple, S: tuple, gen: np.ndarray | None, W: Work) -> bool:
    """Did the step just taken pass a change point?  Asked when a stage's closure had its
    smallest pivot below DIP of the largest met (w.pdip): the whole Jacobian's
    smallest pivot along the step (:func:`whole_pivot` at :func:`hermite_posture`) is
    minimised by golden section; a change point when it falls below VANISH of its
    regular size.  Its time, pivot and posture into w.tcross, w.pcross, w.qcross
    (S.q is left at the step end)."""
    w = step_views(W.P)
    nq = S.q.shape[0]
    found = False
    if w.pdip[0] < DIP * w.pmax[0] and w.wmax[0] > 0.0:
        a = w.tprev[0]
        b = w.t[0]
        g = 0.5 * (math.sqrt(5.0) - 1.0)
        x1 = b - g * (b - a)
        x2 = a + g * (b - a)
        hermite_posture(S, W, x1)
        f1 = whole_pivot(KP, DP, S, gen, W)
        hermite_posture(S, W, x2)
        f2 = whole_pivot(KP, DP, S, gen, W)
        for _ in range(60):
            if f1 <= f2:
                b = x2
                x2 = x1
                f2 = f1
                x1 = b - g * (b - a)
                hermite_posture(S, W, x1)
                f1 = whole_pivot(KP, DP, S, gen, W)
            else:
                a = x1
                x1 = x2
                f1 = f2
                x2 = a + g * (b - a)
                hermite_posture(S, W, x2)
                f2 = whole_pivot(KP, DP, S, gen, W)
            if b - a <= 1e-13 * max(1.0, abs(b)):
                break
        tc = x1 if f1 <= f2 else x2
        pc = min(f1, f2)
        # it vanishes inside the step (the step's ends are regular postures)
        hermite_posture(S, W, w.tprev[0])
        ends = whole_pivot(KP, DP, S, gen, W)
        hermite_posture(S, W, w.t[0])
        ends = min(ends, whole_pivot(KP, DP, S, gen, W))
        if pc < VANISH * w.wmax[0] and pc < VANISH * ends:
            hermite_posture(S, W, tc)
            for k in range(nq):
                w.qcross[k] = S.q[k]
            w.tcross[0] = tc
            w.pcross[0] = pc
            found = True
        for k in range(nq):
            S.q[k] = w.q0[k]
    w.pdip[0] = math.inf
    return found


@njit(nrt=False, inline="always")
def _powers(YP: tuple, ZP: tuple, S: tuple, nf: int, cols: np.ndarray, W: Work,
            gp: float) -> None:
    """w.pw = (drive power, power of the loads without potential, dissipation rate)
    at the evaluated stage; w.ag holds the generalized accelerations (cols order), gp
    the power of gravity (:func:`~openimp.dynamics.loads.applied_loads`)."""
    w = step_views(W.P)
    y = dyn_views(YP)
    z = dyn_data_views(ZP)
    M, c, Q = w.M, w.c, w.Q
    drive = 0.0
    applied = 0.0
    for k in range(nf):
        applied += Q[k] * w.psid[cols[k]]
        if w.role[cols[k]] == 2:
            f = c[k] - Q[k]
            for m in range(nf):
                f += M[k, m] * w.ag[m]
            drive += f * w.psid[cols[k]]
    # the power of the loads with a potential: gravity and linear springs (-dV/dt)
    cons = gp
    damp = 0.0
    for a in range(S.q.shape[0]):
        sl = y.qlaw[a]
        if sl[0] < 0:
            cons -= y.qk[a] * (S.q[a] - y.qfree[a]) * S.qd[a]
        dv = z.law[sl[1]] if sl[1] >= 0 else y.qc[a] * S.qd[a]
        damp -= dv * S.qd[a]
    for i in range(y.ekind.shape[0]):
        if y.ekind[i] == SPRING and y.elaw[i] < 0:
            cons += z.epower[i]
        elif y.ekind[i] == DAMPER:
            damp += z.epower[i]
    w.pw[DRIVE] = drive
    w.pw[LOADS] = applied - cons - damp
    w.pw[DISSIPATED] = -damp


@njit(nrt=False, inline="always")
def finite(x: np.ndarray, n: int) -> bool:
    """The first n entries of x are finite numbers (no inf, no NaN)."""
    for i in range(n):
        if not math.isfinite(x[i]):
            return False
    return True


@njit(nrt=False)
def evaluate(KP: tuple, DP: tuple, YP: tuple, ZP: tuple, S: tuple, gen: np.ndarray | None,
             W: Work, srow: int) -> int:
    """The equations of motion at the closed stage posture S.q with FGC rates w.vs and
    the SGC motion w.ms[srow]: w.aF (nF,) from M_FF psi''_F = Q_F - c_F - M_FS psi''_S
    (10.15), S.qd and the full joint accelerations S.qdd, the powers w.pw, and
    w.ke[0], w.pe[0].  The load laws (Python) are asked for their values once the
    elimination has given the joint rates they read (:data:`Hook.LAWS`).  Returns OK,
    SINGULAR_MASS, LOST_COORDINATES (the elimination no longer leaves exactly the FGCs
    and SGCs), NOT_FINITE (loads or accelerations infinite or NaN) or PYTHON (a law
    failed)."""
    w = step_views(W.P)
    z = dyn_data_views(ZP)
    nq = S.q.shape[0]
    nF = w.nF[0]
    nS = w.scols.shape[0]
    for a in range(nq):
        w.psid[a] = 0.0
        w.keep[a] = S.sgc[a]
    for j in range(nF):
        w.psid[w.fcols[j]] = w.vs[j]
        S.sgc[w.fcols[j]] = True
    for s in range(nS):
        w.psid[w.scols[s]] = w.ms[srow, s, 1]
    _, nf = eom_rates(KP, DP, ZP, S, gen, w.ptol[0], w.psid)
    for a in range(nq):
        S.sgc[a] = w.keep[a]
    w.evals[0] += 1
    if nf != nF + nS:
        return LOST_COORDINATES
    if w.laws[0] and call_hook(w.hook[0], H_LAWS) != 0:
        return PYTHON
    ke, pe, gp = eom_loads(KP, DP, YP, ZP, S, nf, (w.M, w.c, w.Q))
    cols = z.cols[:nf]
    # M_FF into Lc, the right-hand side into rhs (FGC order = column order)
    i = 0
    for k in range(nf):
        if w.role[cols[k]] != 1:
            continue
        r = w.Q[k] - w.c[k]
        s = 0
        jj = 0
        for m in range(nf):
            if w.role[cols[m]] == 1:
                w.Lc[i, jj] = w.M[k, m]
                jj += 1
            else:
                r -= w.M[k, m] * w.ms[srow, s, 2]
                s += 1
        w.rhs[i] = r
        i += 1
    if w.mscale[0] <= 0.0:  # the first evaluation with these coordinates
        for i in range(nF):
            w.mscale[0] = max(w.mscale[0], w.Lc[i, i])
    for i in range(nF):
        w.mdiag[i] = w.Lc[i, i]
    if not finite(w.rhs, nF):  # a load or a velocity product beyond the arithmetic
        return NOT_FINITE
    if not cholesky_solve(w.Lc, nF, w.rhs, w.aF, w.mtol[0], w.mscale[0]):
        return SINGULAR_MASS
    if not finite(w.aF, nF):
        return NOT_FINITE
    w.mnow[0] = mass_pivot(w.Lc, w.mdiag, nF)
    i = 0
    s = 0
    for k in range(nf):
        if w.role[cols[k]] == 1:
            w.ag[k] = w.aF[i]
            i += 1
        else:
            w.ag[k] = w.ms[srow, s, 2]
            s += 1
    G = z.Gf
    for a in range(nq):
        acc = S.qdd[a]
        for k in range(nf):
            acc += G[a, k] * w.ag[k]
        S.qdd[a] = acc
    _powers(YP, ZP, S, nf, cols, W, gp)
    # the scale of the generalized loads term by term (the net force vanishes at rest)
    big = 0.0
    for k in range(nf):
        if w.role[cols[k]] != 1:
            continue
        sc = 0.0
        for b in range(z.Fext.shape[0]):
            p = 0.0
            for i6 in range(6):
                p += z.W[b, k, i6] * z.Fext[b, i6]
            sc += abs(p)
        for a in range(nq):
            sc += abs(G[a, k] * z.fq[a])
        big = max(big, sc * w.gscale[cols[k]])
    w.lscale[0] = big
    w.ke[0] = ke
    w.pe[0] = pe
    d = data_views(DP)
    res = 0.0
    for r in range(d.E.shape[0]):
        res = max(res, abs(d.E[r]))
    w.closure[0] = res
    return OK


@njit(nrt=False)
def start_state(S: tuple, W: Work) -> None:
    """Take the evaluated posture S (q, qd, qdd) as the step start and its derivatives
    as the first stage (the FGCs' rates and accelerations, coordinate-free)."""
    w = step_views(W.P)
    nq = S.q.shape[0]
    for a in range(nq):
        w.q0[a] = S.q[a]
        w.qd0[a] = S.qd[a]
        w.qdd0[a] = S.qdd[a]
    for j in range(w.nF[0]):
        c = w.fcols[j]
        w.x0[j] = S.q[c]
        w.v0[j] = S.qd[c]
        w.kx[0, j] = S.qd[c]
        w.kv[0, j] = S.qdd[c]
    for k in range(3):
        w.kw[0, k] = w.pw[k]
    w.ke0[0] = w.ke[0]
    w.pe0[0] = w.pe[0]
    w.clos0[0] = w.closure[0]
    w.qual0[0] = w.quality[0]
    w.have_lin[0] = False


@njit(nrt=False)
def choose(KP: tuple, DP: tuple, S: tuple, gen: np.ndarray | None, W: Work) -> bool:
    """Choose the FGCs again at the step start (the posture S.q = w.q0): the columns the
    elimination leaves free with only the SGCs specified, unless the current set is
    still good (its quality index at least half the best: no switching back and
    forth between equally good coordinates).  The runs call it when the quality
    index of the current set (w.quality[0], from the last closure) has fallen
    below half its value at the last choice (w.qref[0]).  On a change the FGC state is
    re-read from the joint rates and accelerations (w.q0, w.qd0, w.qdd0).
    Returns True when the set changed."""
    w = step_views(W.P)
    nq = S.q.shape[0]
    for a in range(nq):
        S.q[a] = w.q0[a]
    position(KP, DP, S, gen, 1)
    jacobian(KP, DP, S, gen)
    rank, quality, _ = eliminate(DP, S.sgc, w.ptol[0])
    nF = free_columns(DP, S.sgc, rank, w.keep)
    same = True
    for a in range(nq):
        if w.keep[a] and w.role[a] != 1:
            same = False
    if same and nF == w.nF[0]:
        w.qref[0] = quality
        return False
    # the current set held: still regular?
    for j in range(w.nF[0]):
        S.sgc[w.fcols[j]] = True
    rank_c, quality_c, _ = eliminate(DP, S.sgc, w.ptol[0])
    for j in range(w.nF[0]):
        S.sgc[w.fcols[j]] = False
    if rank_c == rank and nF == w.nF[0] and quality_c >= 0.5 * quality:
        w.qref[0] = quality_c
        return False
    w.qref[0] = quality
    # the new set: FGCs are the columns neither specified nor pivoted
    eliminate(DP, S.sgc, w.ptol[0])
    free_columns(DP, S.sgc, rank, w.keep)
    nF = 0
    for a in range(nq):
        if w.role[a] == 1:
            w.role[a] = 0
        if w.keep[a]:
            w.role[a] = 1
            w.fcols[nF] = a
            nF += 1
    w.nF[0] = nF
    w.mscale[0] = 0.0  # the scale of the new M_FF, at its first evaluation
    for j in range(nF):
        c = w.fcols[j]
        w.x0[j] = w.q0[c]
        w.v0[j] = w.qd0[c]
        w.kx[0, j] = w.qd0[c]
        w.kv[0, j] = w.qdd0[c]
    w.have_lin[0] = False
    return True


# ------------------------------------------------------------------ Dormand-Prince 5(4)
@njit(nrt=False)
def rk_stage_state(W: Work, i: int) -> float:
    """w.xs, w.vs, w.ws = the state of stage i of a step of length w.h[0]; returns its
    time offset."""
    w = step_views(W.P)
    h = w.h[0]
    for j in range(w.nF[0]):
        sx = w.x0[j]
        sv = w.v0[j]
        for m in range(i):
            a = RK_A[i, m]
            if a != 0.0:
                sx += h * a * w.kx[m, j]
                sv += h * a * w.kv[m, j]
        w.xs[j] = sx
        w.vs[j] = sv
    for k in range(3):
        s = w.w0[k]
        for m in range(i):
            s += h * RK_A[i, m] * w.kw[m, k]
        w.ws[k] = s
    return RK_C[i] * h


@njit(nrt=False)
def keep_stage(S: tuple, W: Work, i: int) -> None:
    """Store the derivatives of the evaluated stage i (rates, accelerations, powers)."""
    w = step_views(W.P)
    for j in range(w.nF[0]):
        w.kx[i, j] = w.vs[j]
        w.kv[i, j] = w.aF[j]
    for k in range(3):
        w.kw[i, k] = w.pw[k]


@njit(nrt=False)
def rk_stage(KP: tuple, DP: tuple, YP: tuple, ZP: tuple, S: tuple, gen: np.ndarray | None,
             W: Work, i: int) -> int:
    """Stage i of the step: its state, the loops closed, the equations evaluated."""
    w = step_views(W.P)
    dt = rk_stage_state(W, i)
    S.t[0] = w.t[0] + dt
    st = close_stage(KP, DP, S, gen, W, dt, i, True)
    if st != OK:
        return st
    st = evaluate(KP, DP, YP, ZP, S, gen, W, i)
    if st == OK:
        keep_stage(S, W, i)
        w.mpiv[i] = w.mnow[0]
    return st


@njit(nrt=False)
def rk_finish(S: tuple, W: Work) -> int:
    """The error of the step just evaluated (all 7 stages; S at its end): accept it (the
    end becomes the next start) or reject it; propose the next step.  Returns
    ACCEPTED or REJECTED."""
    w = step_views(W.P)
    h = w.h[0]
    err = 0.0
    nF = w.nF[0]
    for j in range(nF):
        ex = 0.0
        ev = 0.0
        for m in range(NSTAGE):
            ex += RK_E[m] * w.kx[m, j]
            ev += RK_E[m] * w.kv[m, j]
        sx = w.atol[0] + w.rtol[0] * max(abs(w.x0[j]), abs(w.xs[j]))
        sv = w.atol[0] + w.rtol[0] * max(abs(w.v0[j]), abs(w.vs[j]))
        err += (h * ex / sx) ** 2 + (h * ev / sv) ** 2
    err = math.sqrt(err / max(2 * nF, 1))
    w.err[0] = err
    if not (math.isfinite(err) and finite(w.xs, nF) and finite(w.vs, nF)):
        w.why[0] = NOT_FINITE  # an unusable step, never kept, even at the smallest length
        w.hnext[0] = 0.2 * h
        w.rejects[0] += 1
        return REJECTED
    leap = w.leap[0] and (err <= LEAP_ERR or w.nears[0] >= NEAR_TRIES)
    if err <= 1.0 or h <= w.hmin[0] * (1.0 + 1e-12) or w.atmin[0] or leap:
        if err > 1.0:
            w.forced[0] += 1
        fac = 5.0 if err == 0.0 else min(5.0, max(0.2, 0.9 * err ** -0.2))
        w.hnext[0] = h * fac
        _accept(S, W, h)
        return ACCEPTED
    w.hnext[0] = h * max(0.2, 0.9 * err ** -0.2)
    w.rejects[0] += 1
    return REJECTED


@njit(nrt=False, inline="always")
def _accept(S: tuple, W: Work, h: float) -> None:
    """The step of length h is taken: S (evaluated at its end, works w.ws) is the next
    start; the old start is kept for the outputs inside the step."""
    w = step_views(W.P)
    w.tprev[0] = w.t[0]
    for a in range(S.q.shape[0]):
        w.qprev[a] = w.q0[a]
        w.qdprev[a] = w.qd0[a]
        w.qddprev[a] = w.qdd0[a]
    w.nears[0] = 0
    w.leap[0] = False
    w.inrow[0] = 0
    w.mpiv[0] = w.mpiv[NSTAGE - 1]
    for j in range(w.nF[0]):
        w.xprev[j] = w.x0[j]
        w.vprev[j] = w.v0[j]
        w.aprev[j] = w.kv[0, j]
    for k in range(3):
        w.wprev[k] = w.w0[k]
        w.pprev[k] = w.kw[0, k]
        w.w0[k] = w.ws[k]
    w.t[0] += h
    w.steps[0] += 1
    w.smallest[0] = min(w.smallest[0], h)
    w.largest[0] = max(w.largest[0], h)
    start_state(S, W)


@njit(nrt=False)
def rk_attempt(KP: tuple, DP: tuple, YP: tuple, ZP: tuple, S: tuple, gen: np.ndarray | None,
               W: Work) -> int:
    """One attempt of a step of length w.h[0] from the start in w (the SGC motion at the
    stage times in w.ms): ACCEPTED, REJECTED (error, or a stage could not be closed or
    evaluated; w.why[0] says which) with w.hnext[0] proposed; FAILED when a motion
    (Python) failed."""
    w = step_views(W.P)
    w.why[0] = OK
    w.pdip[0] = math.inf
    for i in range(NSTAGE):
        w.mt[i] = w.t[0] + RK_C[i] * w.h[0]
    if motion_rows(W, NSTAGE) != OK:
        return FAILED
    for i in range(1, NSTAGE):
        st = rk_stage(KP, DP, YP, ZP, S, gen, W, i)
        if st != OK:
            _refused(W, st, RK_C[:NSTAGE - 1])
            return REJECTED
    if mass_dip(W, RK_C):
        _refused(W, SINGULAR_MASS, RK_C[:NSTAGE - 1])
        return REJECTED
    code = rk_finish(S, W)
    if code == REJECTED and near_noise(KP, DP, S, gen, W):
        pass_change(W, RK_C[:NSTAGE - 1])
    return code


@njit(nrt=False, inline="always")
def mass_pivot(Lc: np.ndarray, mdiag: np.ndarray, n: int) -> float:
    """min_j L_jj^2 / M_jj of the Cholesky factor L (Lc, n x n) of M_FF whose diagonal
    was mdiag (n,): 1 for orthogonal coordinates, the squared sine of the smallest angle
    between a coordinate's inertia and the span of the ones before it."""
    p = 1.0
    for j in range(n):
        if mdiag[j] > 0.0:
            p = min(p, Lc[j, j] * Lc[j, j] / mdiag[j])
    return p


@njit(nrt=False, inline="always")
def _row(nodes: np.ndarray, i: int) -> int:
    """The stage row of the i-th of ``nodes``: rk's seven, or the book's three (start,
    middle, end)."""
    if nodes.shape[0] == NSTAGE:
        return i
    return BOOK_MID if i == 1 else NSTAGE - 1


@njit(nrt=False)
def mass_dip(W: Work, nodes: np.ndarray) -> bool:
    """True when the mass matrix of the free coordinates passes through a singular posture
    inside the step, read from its smallest pivot at the stages (w.mpiv; the stages at
    the fractions ``nodes`` of the step, the last the end).  Next to a singular posture
    the square root s of the pivot is the distance from it, |a + b t|: a V in time whose
    vertex is inside the step exactly when some stage at 0 < c < 1 has
    s_c < max((1 - c) s_0, c s_1) (the line through it and an end reaches zero inside
    the step), which no straight approach passes.  Asked only where a pivot is below
    MASS_WATCH; a regular minimum passes the test once the step is short.  The step is
    then refused as SINGULAR_MASS, so that both methods shorten their steps into the
    singular posture and stop there (the book's long steps passed it silently)."""
    w = step_views(W.P)
    n = nodes.shape[0]
    last = NSTAGE - 1
    lo = min(w.mpiv[0], w.mpiv[last])
    for i in range(1, n - 1):
        lo = min(lo, w.mpiv[_row(nodes, i)])
    if lo >= MASS_WATCH:
        return False
    s0 = math.sqrt(max(w.mpiv[0], 0.0))
    s1 = math.sqrt(max(w.mpiv[last], 0.0))
    for i in range(1, n - 1):
        c = nodes[i]
        if 0.0 < c < 1.0:
            sc = math.sqrt(max(w.mpiv[_row(nodes, i)], 0.0))
            if sc < max((1.0 - c) * s0, c * s1):
                return True
    return False


@njit(nrt=False, inline="always")
def _refused(W: Work, st: int, nodes: np.ndarray) -> None:
    """A stage of the attempt could not be closed or evaluated (``st``): the attempt is
    rejected, the next one halved or, next to a change point, placed to pass it
    (:func:`pass_change`, the stage times ``nodes``)."""
    w = step_views(W.P)
    w.why[0] = st
    w.rejects[0] += 1
    if st == NEAR_CHANGE:
        pass_change(W, nodes)
    else:
        w.hnext[0] = 0.5 * w.h[0]
        w.nears[0] = 0
        w.leap[0] = False


# ------------------------------------------------------------------ the book's step
@njit(nrt=False)
def book_linearize(KP: tuple, DP: tuple, YP: tuple, ZP: tuple, S: tuple,
                   gen: np.ndarray | None, W: Work) -> int:
    """M, D, K, F of ch 11 (11.7-11.10) at the step start, the FGCs and SGCs held, into
    W.lin (rows and columns in the column order w.lcols of the FGCs and SGCs), the
    places of both in w.iF, w.iS and M_FF^-1 in w.Minv.  With laws the closed
    postures are kept in W.lin for the derivatives of the load laws, which the
    handler adds to D and K (:data:`Hook.LAW_TERMS`) when w.law_ok[0].  Returns OK,
    LOST_COORDINATES or SINGULAR_MASS."""
    w = step_views(W.P)
    z = dyn_data_views(ZP)
    nq = S.q.shape[0]
    nF = w.nF[0]
    nS = w.scols.shape[0]
    for a in range(nq):
        S.q[a] = w.q0[a]
        w.psid[a] = 0.0
        w.rhs[a] = 0.0
        w.keep[a] = S.sgc[a]
    for j in range(nF):
        w.psid[w.fcols[j]] = w.v0[j]
        w.rhs[w.fcols[j]] = w.kv[0, j]
        S.sgc[w.fcols[j]] = True
    for s in range(nS):
        w.psid[w.scols[s]] = w.ms[0, s, 1]
        w.rhs[w.scols[s]] = w.ms[0, s, 2]
    # the book's K (11.9) holds at rest; in motion its position derivatives of the
    # inertia and damper terms are added (differences over closed postures), which
    # makes the step second order
    moving = False
    for j in range(nF):
        if w.v0[j] != 0.0 or w.kv[0, j] != 0.0:
            moving = True
    for s in range(nS):
        if w.ms[0, s, 1] != 0.0 or w.ms[0, s, 2] != 0.0:
            moving = True
    # with laws the closed postures are kept, for the laws' slopes
    o = LinOptions(w.ptol[0], w.ctol[0], H_MOTION, moving, w.laws[0])
    nf, _, status = linearize_kernel(KP, DP, YP, ZP, S, gen, o, w.psid, w.rhs, W.lin,
                                     W.lwork)
    # the closed postures (and their rates) are whole only when every closure converged
    w.law_ok[0] = status == 0
    if status != 0:  # a closure of the motion terms failed: the book's K at rest
        for a in range(nq):
            S.q[a] = w.q0[a]
        o = LinOptions(o.pivot_tol, o.close_tol, o.h, False, o.keep)
        nf, _, _ = linearize_kernel(KP, DP, YP, ZP, S, gen, o, w.psid, w.rhs, W.lin, W.lwork)
    if not o.motion:  # at rest the joint rates at the closed postures are zero
        qdpl = W.lin.qdpl
        for i in range(qdpl.shape[0]):
            for p in range(qdpl.shape[1]):
                for a in range(qdpl.shape[2]):
                    qdpl[i, p, a] = 0.0
    for a in range(nq):
        S.sgc[a] = w.keep[a]
    w.evals[0] += 1 + 2 * nf
    if nf != nF + nS:
        return LOST_COORDINATES
    a = 0
    b = 0
    for k in range(nf):
        c = z.cols[k]
        w.lcols[k] = c
        if w.role[c] == 1:
            w.iF[a] = k
            a += 1
        else:
            w.iS[b] = k
            b += 1
    M = W.lin.M
    for j in range(nF):  # M_FF^-1 column by column
        for i in range(nF):
            for m in range(nF):
                w.Lc[i, m] = M[w.iF[i], w.iF[m]]
            w.rhs[i] = 1.0 if i == j else 0.0
        if not cholesky_solve(w.Lc, nF, w.rhs, w.aF, w.mtol[0], w.mscale[0]):
            return SINGULAR_MASS
        for i in range(nF):
            w.Minv[i, j] = w.aF[i]
    for i in range(nF):
        w.mdiag[i] = M[w.iF[i], w.iF[i]]
    w.mpiv[0] = mass_pivot(w.Lc, w.mdiag, nF)
    if ball_blocks(KP, w.role, w.fcols, nF, w.ball) > 0:
        ball_axes(KP, YP, w.q0, w.v0, w.ball, w.bax, w.fcols, w.bs)
    w.have_lin[0] = True
    return OK


@njit(nrt=False)
def book_predict(W: Work) -> int:
    """The linear solution over the step tau = w.h[0] (14.11-14.30, by the exponential
    of the augmented matrix): the FGC state at the step end into w.xs, w.vs, the
    predicted accelerations v'_F there into w.ap.  The forcing is (11.13) with
    the SGC motion over the step as a quadratic in time (rate, acceleration and
    the jerk between the step's ends, w.ms[0] and w.ms[6]): exact for a linear
    system under such an input, where the book freezes it.  Returns OK,
    NOT_FINITE (the exponential overflowed: a step far too long for the stiffness)
    or TOO_LARGE (a displacement above w.xmax[0], the book's step 7)."""
    w = step_views(W.P)
    M, D, K, F = W.lin.M, W.lin.D, W.lin.K, W.lin.F
    nF = w.nF[0]
    nS = w.scols.shape[0]
    tau = w.h[0]
    iF, iS, Minv, g = w.iF, w.iS, w.Minv, w.gF
    # forcing of the FGC rows: G(s) = G0 + G1 s + G2 s^2 / 2 (11.13 over the step)
    for i in range(nF):
        r = iF[i]
        g0 = F[r]
        g1 = 0.0
        g2 = 0.0
        for s in range(nS):
            col = iS[s]
            v_s = w.ms[0, s, 1]
            a_s = w.ms[0, s, 2]
            j_s = (w.ms[NSTAGE - 1, s, 2] - a_s) / tau
            g0 -= M[r, col] * a_s
            g1 -= M[r, col] * j_s + D[r, col] * a_s + K[r, col] * v_s
            g2 -= D[r, col] * j_s + K[r, col] * a_s
        g[0, i] = g0
        g[1, i] = g1
        g[2, i] = g2
    # y = (v, x) and the clock (1, s, s^2/2), all times tau:
    #   v' = -Minv D v - Minv K x + Minv G(s),  x' = v + psi'_F*   (14.11)
    n = 2 * nF + 3
    A = w.Ab
    for i in range(n):
        for j in range(n):
            A[i, j] = 0.0
    for i in range(nF):
        for j in range(nF):
            sd = 0.0
            sk = 0.0
            for m in range(nF):
                sd += Minv[i, m] * D[iF[m], iF[j]]
                sk += Minv[i, m] * K[iF[m], iF[j]]
            A[i, j] = -sd * tau
            A[i, nF + j] = -sk * tau
        A[nF + i, i] = tau
        for p in range(3):
            s = 0.0
            for m in range(nF):
                s += Minv[i, m] * g[p, m]
            A[i, 2 * nF + p] = s * tau
        A[nF + i, 2 * nF] = w.v0[i] * tau
    A[2 * nF + 1, 2 * nF] = tau
    A[2 * nF + 2, 2 * nF + 1] = tau
    if w.events[0] and watched_cap(A, nF, tau, W) and not w.atmin[0]:
        return TOO_LARGE
    balls = w.ball[0, 0] >= 0
    if balls:  # ball joints in their rotation vectors (the e of a steady spin are not linear)
        to_local(A, nF, tau, w.ball, w.bax, w.fcols, w.q0, w.v0, w.bs)
    expm(A, n, w.Eb, w.X2, w.X3)
    E = w.Eb
    big = 0.0
    for i in range(nF):
        w.X1[0, i] = E[i, 2 * nF]  # v(tau)
        w.X1[1, i] = E[nF + i, 2 * nF]  # x(tau)
        w.vs[i] = w.v0[i] + w.X1[0, i]
        w.xs[i] = w.x0[i] + w.X1[1, i]
        big = max(big, abs(w.X1[1, i]))
    # the accelerations the linear model predicts at the end (14.28)
    for i in range(nF):
        acc = 0.0
        for j in range(nF):
            acc += (A[i, j] * w.X1[0, j] + A[i, nF + j] * w.X1[1, j]) / tau
        if balls:  # the forcing as the clock columns of A hold it
            acc += (A[i, 2 * nF] + A[i, 2 * nF + 1] * tau + 0.5 * A[i, 2 * nF + 2] * tau * tau) \
                / tau
        else:
            for m in range(nF):
                acc += Minv[i, m] * (g[0, m] + g[1, m] * tau + 0.5 * g[2, m] * tau * tau)
        w.ap[i] = acc
    if balls:
        from_local(w.ball, w.bax, w.fcols, w.q0, w.v0, w.X1[1], w.X1[0], w.ap,
                   (w.xs, w.vs, w.ap), True, w.bs)
    if not (finite(w.xs, nF) and finite(w.vs, nF) and finite(w.ap, nF)):
        return NOT_FINITE  # max() above passes NaN over: tested apart
    if big > w.xmax[0]:
        return TOO_LARGE
    return OK


#: the largest phase of the fastest mode of a book step's linear model while switching
#: functions are watched: a quarter period, so that a contact's oscillation is never
#: stepped across (the book's step is exact for it, and would land in contact again
#: with the lift-off in between unseen)
WATCHED_PHASE = 0.5 * math.pi


@njit(nrt=False, inline="always")
def watched_cap(A: np.ndarray, nF: int, tau: float, W: Work) -> bool:
    """w.hcap[0] from the step's A (its rows -M^-1 K tau): the fastest mode's omega^2 is
    at most the largest row sum of |M^-1 K|; True when tau is beyond the cap."""
    w = step_views(W.P)
    w2 = 0.0
    for i in range(nF):
        s = 0.0
        for j in range(nF):
            s += abs(A[i, nF + j])
        w2 = max(w2, s / tau)
    w.hcap[0] = WATCHED_PHASE / math.sqrt(w2) if w2 > 0.0 else math.inf
    return tau > w.hcap[0] * (1.0 + 1e-9)


@njit(nrt=False)
def book_mid(W: Work) -> None:
    """After :func:`book_predict`: the linear solution at the step's middle into w.xs,
    w.vs (the exponential of half the augmented matrix, w.Ab scaled in place), the
    end's kept in w.xe, w.ve for :func:`book_end`."""
    w = step_views(W.P)
    nF = w.nF[0]
    n = 2 * nF + 3
    for i in range(nF):
        w.xe[i] = w.xs[i]
        w.ve[i] = w.vs[i]
    for i in range(n):
        for j in range(n):
            w.Ab[i, j] *= 0.5
    expm(w.Ab, n, w.Eb, w.X2, w.X3)
    for i in range(nF):
        w.vs[i] = w.v0[i] + w.Eb[i, 2 * nF]
        w.xs[i] = w.x0[i] + w.Eb[nF + i, 2 * nF]
    if w.ball[0, 0] >= 0:
        from_local(w.ball, w.bax, w.fcols, w.q0, w.v0, w.Eb[nF:2 * nF, 2 * nF],
                   w.Eb[:nF, 2 * nF], w.ap, (w.xs, w.vs, w.ap), False, w.bs)


@njit(nrt=False)
def book_end(W: Work) -> None:
    """The powers evaluated at the step's middle into w.wq (for Simpson's rule in
    :func:`book_finish`); the end's predicted state back into w.xs, w.vs."""
    w = step_views(W.P)
    for k in range(3):
        w.wq[k] = w.pw[k]
    for i in range(w.nF[0]):
        w.xs[i] = w.xe[i]
        w.vs[i] = w.ve[i]


@njit(nrt=False)
def book_finish(S: tuple, W: Work) -> int:
    """The force error of the step just taken (S evaluated at its end, section 14.5):
    eps = M_FF (psi''_F - v'_F) in model units against IMP's ZERO (FORCE) =
    (force, percent of the largest generalized force met so far): above twice the
    limit the step is repeated with half the length; above the limit it is kept
    and the next one halved; below 1/8 of it the next one doubles (up to the
    largest step).  The limit is never below the round-off of eps (FORCE_ROUNDOFF
    of the inertia terms M_FF psi''_F).  Returns ACCEPTED or REJECTED."""
    w = step_views(W.P)
    nF = w.nF[0]
    h = w.h[0]
    M = W.lin.M
    err = 0.0
    fmax = 0.0
    # V[0] the force error, V[1] the inertia force, FGC order; of a ball, both in its
    # rotation vector (its moments), without the velocity products of e (V[3])
    V = w.X2
    balls = w.ball[0, 0] >= 0
    for i in range(nF):
        V[2, i] = 0.0
        V[3, i] = 0.0
        w.keep[i] = False
    if balls:
        from_local(w.ball, w.bax, w.fcols, w.q0, w.v0, w.X1[1], w.X1[0], V[2],
                   (V[4], V[5], V[3]), True, w.bs)
        ball_marks(w.ball, w.keep)
    noise = 0.0  # the force error's round-off: the inertia terms it is the difference of
    for i in range(nF):
        e = 0.0
        f = 0.0
        g = 0.0
        for j in range(nF):
            mij = M[w.iF[i], w.iF[j]]
            e += mij * (w.aF[j] - w.ap[j])
            f += mij * (w.aF[j] - V[3, j])
            g += abs(mij * w.aF[j])
        V[0, i] = e
        V[1, i] = f
        noise = max(noise, FORCE_ROUNDOFF * g * w.gscale[w.fcols[i]])
    if balls:
        ball_moments(w.ball, w.bax, w.fcols, w.q0, w.X1[1], V, w.bs)
    for i in range(nF):
        gs = w.gscale[w.fcols[i]]
        err = max(err, abs(V[0, i]) * gs)
        fmax = max(fmax, abs(V[1, i]) * gs)
        if not w.keep[i]:
            fmax = max(fmax, abs(W.lin.F[w.iF[i]]) * gs)
    w.fscale[0] = max(w.fscale[0], fmax, w.lscale[0])
    tol = w.fabs[0]
    pct = 0.01 * w.fpct[0] * w.fscale[0]
    if pct > 0.0:
        tol = min(tol, pct)
    tol = max(tol, noise)  # a percentage of no force at all (a free steady spin)
    w.err[0] = err / tol
    if not (finite(V[0], nF) and finite(V[1], nF) and math.isfinite(tol)):
        # an unusable step, never kept (max() above passes NaN over)
        w.err[0] = math.inf
        w.why[0] = NOT_FINITE
        w.hnext[0] = 0.5 * h
        w.rejects[0] += 1
        return REJECTED
    if err > 2.0 * tol and h > w.hmin[0] * (1.0 + 1e-12) and not (w.leap[0] or w.atmin[0]):
        w.hnext[0] = 0.5 * h
        w.rejects[0] += 1
        return REJECTED
    if err > 2.0 * tol:
        w.forced[0] += 1
    if err > tol:
        w.hnext[0] = 0.5 * h
    elif err < 0.125 * tol:
        w.hnext[0] = 2.0 * h
    else:
        w.hnext[0] = h
    if err <= tol:  # a step cut to land on an output: back to the proposal before the cut
        w.hnext[0] = max(w.hnext[0], w.hprop[0])
    # works over the step by Simpson's rule: the powers at its ends and its middle
    # (w.wq, :func:`book_end`), the motion there the linear model's
    for k in range(3):
        w.ws[k] = w.w0[k] + h / 6.0 * (w.kw[0, k] + 4.0 * w.wq[k] + w.pw[k])
    _accept(S, W, h)
    return ACCEPTED


@njit(nrt=False)
def book_attempt(KP: tuple, DP: tuple, YP: tuple, ZP: tuple, S: tuple,
                 gen: np.ndarray | None, W: Work) -> int:
    """One attempt of the book's step of length w.h[0] (section 14.4, steps 4-15): the
    linearization at the start (once per start), the exponential solution, the
    loops closed at the middle (for the works) and the end, the equations there,
    the force error.  ACCEPTED or
    REJECTED (w.why[0]: TOO_LARGE, NO_CLOSURE, ... or OK for the error test); FAILED
    when the step start cannot be linearized or a motion or law (Python) failed."""
    w = step_views(W.P)
    w.why[0] = OK
    w.pdip[0] = math.inf
    h = w.h[0]
    for i in range(NSTAGE):  # rows: 0 the start, 1 the middle, the last the end
        w.mt[i] = w.t[0]
    w.mt[BOOK_MID] = w.t[0] + 0.5 * h
    w.mt[NSTAGE - 1] = w.t[0] + h
    if motion_rows(W, NSTAGE) != OK:
        return FAILED
    if not w.have_lin[0]:
        st = book_linearize(KP, DP, YP, ZP, S, gen, W)
        if st == OK and w.laws[0] and w.law_ok[0] and call_hook(w.hook[0], H_LAW_TERMS) != 0:
            st = PYTHON
        if st != OK:
            w.why[0] = st
            return FAILED
    st = book_predict(W)
    big = st == TOO_LARGE and w.atmin[0]
    if big:  # at the smallest step the displacement is kept too
        st = OK
    if st == OK:  # the middle, for the works
        book_mid(W)
        S.t[0] = w.t[0] + 0.5 * h
        st = close_stage(KP, DP, S, gen, W, 0.5 * h, BOOK_MID, True)
    if st == OK:
        st = evaluate(KP, DP, YP, ZP, S, gen, W, BOOK_MID)
        w.mpiv[BOOK_MID] = w.mnow[0]
    if st == OK:
        book_end(W)
        S.t[0] = w.t[0] + h
        st = close_stage(KP, DP, S, gen, W, h, NSTAGE - 1, True)
    if st == OK:
        st = evaluate(KP, DP, YP, ZP, S, gen, W, NSTAGE - 1)
        w.mpiv[NSTAGE - 1] = w.mnow[0]
    if st == OK and mass_dip(W, BOOK_C):
        st = SINGULAR_MASS
    if st != OK:
        _refused(W, st, BOOK_C)
        return REJECTED
    forced = w.forced[0]
    code = book_finish(S, W)
    if code == ACCEPTED and big and w.forced[0] == forced:  # one count per forced step
        w.forced[0] += 1
    return code


# ------------------------------------------------------------------ runs
@njit(nrt=False)
def begin_step(W: Work, t_end: float) -> float:
    """The length of the next attempt toward t_end (the proposal, at most the largest
    step, stretched by up to 10% to land on t_end, never below the smallest step
    unless t_end is nearer); into w.h[0]."""
    w = step_views(W.P)
    t = w.t[0]
    h = min(w.hnext[0], w.hmax[0], w.hcap[0])
    h = max(h, w.hmin[0])
    w.atmin[0] = h <= w.hmin[0] * (1.0 + 1e-12)
    if t + 1.1 * h >= t_end:
        h = t_end - t
    if h < w.hnext[0]:  # cut: no longer placed to pass a change point
        w.leap[0] = False
    w.h[0] = h
    return h


# ------------------------------------------------------------------ outputs
@njit(nrt=False, inline="always")
def quintic(th: float) -> tuple[float, float, float, float, float, float]:
    """The quintic Hermite basis at the fraction th of a step: the weights of the start's
    position, rate x h, acceleration x h^2 and of the end's (exact for quintics)."""
    t2 = th * th
    t3 = t2 * th
    t4 = t3 * th
    t5 = t4 * th
    return (1.0 - 10.0 * t3 + 15.0 * t4 - 6.0 * t5, th - 6.0 * t3 + 8.0 * t4 - 3.0 * t5,
            0.5 * t2 - 1.5 * t3 + 1.5 * t4 - 0.5 * t5, 10.0 * t3 - 15.0 * t4 + 6.0 * t5,
            -4.0 * t3 + 7.0 * t4 - 3.0 * t5, 0.5 * t3 - t4 + 0.5 * t5)


@njit(nrt=False)
def dense_point(W: Work, tk: float) -> float:
    """The FGC state at tk inside the step just taken, into w.xs, w.vs: the quintic
    Hermite interpolant of the positions through the positions, rates and
    accelerations of both ends (error O(h^6), below the step's own), its
    derivative for the rates; the works into w.ws by the cubic Hermite
    interpolant of works and powers.  Returns tk minus the step's end."""
    w = step_views(W.P)
    t0 = w.tprev[0]
    h = w.t[0] - t0
    th = (tk - t0) / h
    t2 = th * th
    t3 = t2 * th
    t4 = t3 * th
    h0, h1, h2, h3, h4, h5 = quintic(th)
    d0 = -30.0 * t2 + 60.0 * t3 - 30.0 * t4
    d1 = 1.0 - 18.0 * t2 + 32.0 * t3 - 15.0 * t4
    d2 = th - 4.5 * t2 + 6.0 * t3 - 2.5 * t4
    d3 = 30.0 * t2 - 60.0 * t3 + 30.0 * t4
    d4 = -12.0 * t2 + 28.0 * t3 - 15.0 * t4
    d5 = 1.5 * t2 - 4.0 * t3 + 2.5 * t4
    for j in range(w.nF[0]):
        p0, v0, a0 = w.xprev[j], w.vprev[j], w.aprev[j]
        p1, v1, a1 = w.x0[j], w.v0[j], w.kv[0, j]
        w.xs[j] = h0 * p0 + h1 * h * v0 + h2 * h * h * a0 + h3 * p1 + h4 * h * v1 \
            + h5 * h * h * a1
        w.vs[j] = (d0 * p0 + d1 * h * v0 + d2 * h * h * a0 + d3 * p1 + d4 * h * v1
                   + d5 * h * h * a1) / h
    c0 = 1.0 - 3.0 * t2 + 2.0 * t3
    c1 = th - 2.0 * t2 + t3
    c2 = 3.0 * t2 - 2.0 * t3
    c3 = -t2 + t3
    for k in range(3):
        w.ws[k] = c0 * w.wprev[k] + c1 * h * w.pprev[k] + c2 * w.w0[k] + c3 * h * w.kw[0, k]
    return tk - w.t[0]


@njit(nrt=False)
def works_change(W: Work) -> bool:
    """The works changed over the step just taken by more than round-off (its end and
    stage powers, its work increments against the energies and works): else an
    output inside it needs no quadrature (a conservative system)."""
    w = step_views(W.P)
    h = w.t[0] - w.tprev[0]
    scale = abs(w.ke0[0]) + abs(w.pe0[0])
    big = 0.0
    for k in range(3):
        scale += abs(w.w0[k])
        big = max(big, abs(w.w0[k] - w.wprev[k]), h * abs(w.pprev[k]))
        for m in range(NSTAGE):
            big = max(big, h * abs(w.kw[m, k]))
    return big > 1e-13 * scale


@njit(nrt=False)
def works_node(W: Work, tk: float, i: int) -> float:
    """Gauss node i of [w.tprev[0], tk]: the FGC state there (:func:`dense_point`);
    returns its time."""
    w = step_views(W.P)
    tn = w.tprev[0] + GL_X[i] * (tk - w.tprev[0])
    dense_point(W, tn)
    return tn


@njit(nrt=False)
def works_add(W: Work, i: int) -> None:
    """Add the powers w.pw evaluated at Gauss node i to w.wq."""
    w = step_views(W.P)
    for k in range(3):
        w.wq[k] += GL_W[i] * w.pw[k]


@njit(nrt=False)
def works_at(W: Work, tk: float, ob: OutputRows, row: int) -> None:
    """The works of output row ``row`` at tk: the step start's plus the Gauss rule of
    the powers over [w.tprev[0], tk] (w.wq; error O(h^7), as the interpolated
    motion's)."""
    w = step_views(W.P)
    for k in range(3):
        ob.energy[row, 2 + k] = w.wprev[k] + (tk - w.tprev[0]) * w.wq[k]


@njit(nrt=False)
def dense_works(KP: tuple, DP: tuple, YP: tuple, ZP: tuple, S: tuple,
                gen: np.ndarray | None, W: Work, tk: float) -> int:
    """The powers at the 3 Gauss nodes of [w.tprev[0], tk] along the interpolated
    motion (loops closed, equations evaluated there; SGCs at w.ms[0]) summed into
    w.wq for :func:`works_at`: the works at an output inside a step, as accurate
    as its motion (the cubic Hermite of the ends' works and powers in
    :func:`dense_point` is O(h^4)).  S is evaluated at tk on entry; the nodes are
    taken back from there, each closed from the last (the step's end may be near
    a limit of travel).  Returns OK or the failure code."""
    w = step_views(W.P)
    for k in range(3):
        w.wq[k] = 0.0
    t_last = tk
    for i in range(2, -1, -1):
        tn = works_node(W, tk, i)
        S.t[0] = tn
        w.mt[0] = tn
        if motion_rows(W, 1) != OK:
            return PYTHON
        st = close_near(KP, DP, S, gen, W, tn - t_last, 0)
        if st == OK:
            st = evaluate(KP, DP, YP, ZP, S, gen, W, 0)
        if st != OK:
            return st
        works_add(W, i)
        t_last = tn
    return OK


@njit(nrt=False)
def record(S: tuple, W: Work, ob: OutputRows, row: int, tk: float, end: bool) -> None:
    """Output row ``row`` of ob at tk: the step's end (``end``: the start state in w) or
    the evaluated S with the works w.ws."""
    w = step_views(W.P)
    ob.t[row] = tk
    nq = S.q.shape[0]
    for a in range(nq):
        ob.q[row, a] = w.q0[a] if end else S.q[a]
        ob.qd[row, a] = w.qd0[a] if end else S.qd[a]
        ob.qdd[row, a] = w.qdd0[a] if end else S.qdd[a]
        ob.fgc[row, a] = w.role[a] == 1
    ob.closure[row] = w.clos0[0] if end else w.closure[0]
    ob.quality[row] = w.qual0[0] if end else w.quality[0]
    ob.energy[row, 0] = w.ke0[0] if end else w.ke[0]
    ob.energy[row, 1] = w.pe0[0] if end else w.pe[0]
    for k in range(3):
        ob.energy[row, 2 + k] = w.w0[k] if end else w.ws[k]


@njit(nrt=False)
def dense_output(KP: tuple, DP: tuple, YP: tuple, ZP: tuple, S: tuple,
                 gen: np.ndarray | None, W: Work, tk: float, ob: OutputRows, row: int) -> int:
    """The output at tk inside the step just taken (the SGC motion at tk in w.ms[0]):
    the interpolated FGCs, the loops closed there, the equations evaluated, the row
    recorded; its works by :func:`dense_works` when they change (kept from the cubic
    of :func:`dense_point` where a node cannot be closed).  Returns OK or the
    failure code of the output."""
    w = step_views(W.P)
    dt = dense_point(W, tk)
    S.t[0] = tk
    w.mt[0] = tk
    st = motion_rows(W, 1)
    if st == OK:
        st = close_stage(KP, DP, S, gen, W, dt, 0, False)
    if st == OK:
        st = evaluate(KP, DP, YP, ZP, S, gen, W, 0)
    if st == OK:
        record(S, W, ob, row, tk, False)
        if works_change(W) and dense_works(KP, DP, YP, ZP, S, gen, W, tk) == OK:
            works_at(W, tk, ob, row)
    return st


@njit(nrt=False)
def outputs(KP: tuple, DP: tuple, YP: tuple, ZP: tuple, S: tuple, gen: np.ndarray | None,
            W: Work, O: Outputs) -> int:
    """Record the outputs O.times[O.k[0]:] that the step just taken reached (rows from
    O.k[0] - O.base); returns OK or the failure code of an interpolated one.  The end
    of the step is recorded from the start state.  The law values of the step's end
    are kept for the next step (an output inside the step evaluates the laws there)."""
    w = step_views(W.P)
    z = dyn_data_views(ZP)
    for i in range(z.law.shape[0]):
        w.law0[i] = z.law[i]
    t1 = w.t[0]
    n = O.times.shape[0]
    st = OK
    while O.k[0] < n:
        tk = O.times[O.k[0]]
        end = abs(tk - t1) <= 1e-12 * max(1.0, abs(t1))
        if not _reached(tk, t1):
            break
        if end:
            record(S, W, O.rows, O.k[0] - O.base, tk, True)
        else:
            st = dense_output(KP, DP, YP, ZP, S, gen, W, tk, O.rows, O.k[0] - O.base)
            if st != OK:
                w.why[0] = st
                w.tfail[0] = tk
                break
        O.k[0] += 1
    for i in range(z.law.shape[0]):
        z.law[i] = w.law0[i]
    return st


@njit(nrt=False, inline="always")
def _reached(tk: float, t1: float) -> bool:
    """Output time tk is reached by a step ending at t1 (the test of :func:`outputs`)."""
    return tk <= t1 + 1e-12 * max(1.0, abs(t1))


@njit(nrt=False)
def land(W: Work, O: Outputs) -> None:
    """The book's steps end on the output times: the time to the next output is cut
    into equal steps of at most 1.1 times the proposed one (no short remainder
    step, whose length would set the next proposal; never below the smallest step
    unless the gap is, or the proposal is the smallest step: then never above it,
    so that a step kept whatever its error is no longer than the smallest; the cut
    proposal kept in w.hprop[0] for :func:`book_finish`).
    Its outputs are then step ends, never interpolated (an interpolant through the
    ends' accelerations carries the stiff modes its step damps)."""
    w = step_views(W.P)
    w.hprop[0] = 0.0
    if O.k[0] < O.times.shape[0] and not w.leap[0]:
        gap = O.times[O.k[0]] - w.t[0]
        h = w.h[0]
        if gap > 0.0 and h > 0.0:
            n = max(1.0, math.ceil(gap / (1.1 * h)))
            if w.hmin[0] > 0.0 and gap / n < w.hmin[0] and not w.atmin[0]:
                n = max(1.0, math.floor(gap / w.hmin[0]))  # never below the smallest step
            w.h[0] = gap / n
            if w.h[0] < h:  # cut to land: the next step may go back to the proposal
                w.hprop[0] = h


@njit(nrt=False)
def fit(W: Work, O: Outputs) -> bool:
    """True when the output rows left hold every output the next step (w.h[0]) may
    reach; with the rows all free the step is shortened to fit them; False when they
    must be flushed first."""
    w = step_views(W.P)
    t1 = w.t[0] + w.h[0]
    k = O.k[0]
    while k < O.times.shape[0] and _reached(O.times[k], t1):
        k += 1
    if k - O.base <= O.cap:
        return True
    if O.k[0] > O.base:
        return False
    w.h[0] = O.times[O.base + O.cap - 1] - w.t[0]
    return True


@njit(nrt=False)
def motion_rows(W: Work, n: int) -> int:
    """The SGC motions at the times w.mt[:n] into the rows w.ms[:n] when they are Python
    callables (the handler's :data:`Hook.MOTION`; held SGCs keep their rows).  OK or
    PYTHON."""
    w = step_views(W.P)
    if not w.driven[0]:
        return OK
    w.nmt[0] = n
    if call_hook(w.hook[0], H_MOTION_ROWS) != 0:
        w.why[0] = PYTHON
        return PYTHON
    return OK


@njit(nrt=False)
def restart(KP: tuple, DP: tuple, YP: tuple, ZP: tuple, S: tuple, gen: np.ndarray | None,
            W: Work) -> int:
    """Evaluate the step start again (at the start of a run, after a change of FGCs with
    laws, after a law's switch): the FGCs at w.x0, w.v0, the SGC motion at w.t, the
    loops closed, the equations (the laws' values there), the start taken from it.
    Returns OK or the failure code."""
    w = step_views(W.P)
    for j in range(w.nF[0]):
        w.xs[j] = w.x0[j]
        w.vs[j] = w.v0[j]
    w.mt[0] = w.t[0]
    st = motion_rows(W, 1)
    if st == OK:
        S.t[0] = w.t[0]
        st = close_stage(KP, DP, S, gen, W, 0.0, 0, True)
    if st == OK:
        st = evaluate(KP, DP, YP, ZP, S, gen, W, 0)
        w.mpiv[0] = w.mnow[0]
    if st == OK:
        start_state(S, W)
        # the regular size of the whole Jacobian's smallest pivot (change points)
        w.wmax[0] = max(w.wmax[0], whole_pivot(KP, DP, S, gen, W))
        for a in range(S.q.shape[0]):
            S.q[a] = w.q0[a]
    return st


@njit(nrt=False)
def after_step(KP: tuple, DP: tuple, YP: tuple, ZP: tuple, S: tuple, gen: np.ndarray | None,
               W: Work, O: Outputs, last: bool) -> int:
    """What follows an accepted step: on the last output time when it is the run's
    last (``last``), the outputs it passed recorded, a change point it passed
    located (:func:`crossing`), the FGCs chosen again when the quality index has
    halved.  -1 to go on, STOPPED (an output failed), SWITCHED (the caller also
    records a change point when w.tcross[0] is not NaN) or CROSSED."""
    w = step_views(W.P)
    if last:
        w.t[0] = O.times[O.times.shape[0] - 1]
    if outputs(KP, DP, YP, ZP, S, gen, W, O) != OK:
        return STOPPED
    w.tcross[0] = math.nan
    crossed = crossing(KP, DP, S, gen, W)
    if w.qual0[0] < 0.5 * w.qref[0] and choose(KP, DP, S, gen, W):
        return SWITCHED
    if crossed:
        return CROSSED
    return -1


@njit(nrt=False, inline="always")
def _after(KP: tuple, DP: tuple, YP: tuple, ZP: tuple, S: tuple, gen: np.ndarray | None,
           W: Work, code: int, O: Outputs, last: bool) -> int:
    """What the run loop does after an attempt of length w.h[0]: -1 to go on, else its
    return code (EVENT: a switching function crossed zero over the accepted step)."""
    w = step_views(W.P)
    if code == FAILED:
        return STOPPED
    if code == REJECTED:
        h = w.h[0]
        w.inrow[0] += 1
        if h <= w.hmin[0] * (1.0 + 1e-12) or w.atmin[0] or h <= 1e-14 * max(1.0, abs(w.t[0])):
            if w.why[0] == OK:
                w.why[0] = UNDERFLOW
            return STOPPED
        if h <= w.hfloor[0]:
            if w.why[0] == OK:
                w.why[0] = TINY_STEP
            return STOPPED
        if w.inrow[0] >= MAX_REJECTS:
            if w.why[0] != NOT_FINITE:
                w.why[0] = NO_PROGRESS
            return STOPPED
        return -1
    if w.events[0] or w.watch[0]:
        st = call_hook(w.hook[0], H_SWITCH)
        if st < 0:
            w.why[0] = PYTHON
            return STOPPED
        if st == H_CROSSED:
            return EVENT
        if st == H_TOLD:  # the laws hold new values from here: the start evaluated again
            st = restart(KP, DP, YP, ZP, S, gen, W)
            if st != OK:
                w.why[0] = st
                return STOPPED
    return after_step(KP, DP, YP, ZP, S, gen, W, O, last)


@njit(nrt=False, inline="always")
def _before(W: Work, O: Outputs, book: bool) -> int:
    """What the run loop does before an attempt: its length (:func:`begin_step`, the
    book's cut by :func:`land`), fitted to the output rows (FULL when they must be
    flushed first), the step start kept for event location.  -1 to go on; STOPPED
    (TINY_STEP) when the proposal fell below w.hfloor[0]."""
    w = step_views(W.P)
    if w.hnext[0] < w.hfloor[0] and w.inrow[0] == 0 and w.nears[0] == 0 and not w.leap[0]:
        # the error control's proposal after an accepted step (not a halving after a
        # refused stage, whose cause _after reports; not a pass of a change point)
        w.why[0] = TINY_STEP
        return STOPPED
    begin_step(W, O.times[O.times.shape[0] - 1])
    if book:
        land(W, O)
    if not fit(W, O):
        return FULL
    if w.events[0] and call_hook(w.hook[0], H_SNAP) != 0:
        w.why[0] = PYTHON
        return STOPPED
    return -1


@njit(nrt=False)
def run_rk(KP: tuple, DP: tuple, YP: tuple, ZP: tuple, S: tuple, gen: np.ndarray | None,
           W: Work, O: Outputs, max_steps: int) -> int:
    """Dormand-Prince steps toward the last output time (hit exactly), recording the
    outputs O.times[O.k[0]:] the steps pass (interpolated, the loops closed there:
    :func:`outputs`) into the rows of O.rows from O.k[0] - O.base (at most O.cap
    rows).  Returns REACHED (every output done); SWITCHED when the FGCs changed at
    w.t[0] (the caller records it and calls again); STOPPED when a step could not be
    taken even at the smallest length or after MAX_REJECTS rejections in a row
    (w.why[0] says why); CAPPED after max_steps steps; FULL when the next step's
    outputs would not fit; EVENT when a switching function changed sign over the step
    just accepted; PAUSED when the handler's clock asks for Python (:data:`Hook.TICK`,
    every w.tick[0] attempts: progress and Ctrl-C)."""
    w = step_views(W.P)
    s0 = w.steps[0]
    t_end = O.times[O.times.shape[0] - 1]
    n = 0
    while O.k[0] < O.times.shape[0]:
        n += 1
        if n >= w.tick[0]:
            n = 0
            if call_hook(w.hook[0], H_TICK) != 0:
                return PAUSED
        code = _before(W, O, False)
        if code >= 0:
            return code
        last = w.t[0] + w.h[0] >= t_end
        code = _after(KP, DP, YP, ZP, S, gen, W, rk_attempt(KP, DP, YP, ZP, S, gen, W), O,
                      last)
        if code >= 0:
            return code
        if w.steps[0] - s0 >= max_steps:
            return CAPPED
    return REACHED


@njit(nrt=False)
def run_book(KP: tuple, DP: tuple, YP: tuple, ZP: tuple, S: tuple, gen: np.ndarray | None,
             W: Work, O: Outputs, max_steps: int) -> int:
    """:func:`run_rk` with the book's steps (compiled apart: a run of one method never
    compiles the other)."""
    w = step_views(W.P)
    s0 = w.steps[0]
    t_end = O.times[O.times.shape[0] - 1]
    n = 0
    while O.k[0] < O.times.shape[0]:
        n += 1
        if n >= w.tick[0]:
            n = 0
            if call_hook(w.hook[0], H_TICK) != 0:
                return PAUSED
        code = _before(W, O, True)
        if code >= 0:
            return code
        last = w.t[0] + w.h[0] >= t_end
        code = _after(KP, DP, YP, ZP, S, gen, W, book_attempt(KP, DP, YP, ZP, S, gen, W), O,
                      last)
        if code >= 0:
            return code
        if w.steps[0] - s0 >= max_steps:
            return CAPPED
    return REACHED
