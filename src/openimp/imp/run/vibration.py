"""Linearized vibration of a kinematic run: PRINT FREQUENCY and PRINT / LIST / STORE /
PLOT DYNAMICS (docs/imp-language.md §1.1 items 7-8, §1.2, §9).

The equations of motion are linearized (:func:`openimp.linearize`, book ch 11)
about a solved position of the run: the input motions of the run are the
SGCs, locked, at the rates and accelerations of the step (DATA VELOCITY,
DATA ACCEL); the free coordinates IMP finds are held by the kinematic run, so
their rates are zero.  Then

* PRINT FREQUENCY, at every position: one line per mode (:func:`openimp.modes`,
  ch 13): the natural frequency (rad/s) and damping ratio of an oscillatory
  mode, the time constant (s) of an over-damped one, negative when it grows;
  IMP's message at each position without FGCs, the located modeling error of
  a singular mass matrix at that position (the run goes on);
* DYNAMICS, at the last position solved: transfer functions as formulas in S
  (PRINT), their coefficients (STORE), the frequency response over IMP's
  frequency grid (LIST), a Bode plot (PLOT).  Outputs are in the units the
  listings print (degrees for the position of an angle, radians per second for
  its rates) per unit of the input as the deck gives it (a force, a moment,
  degrees of an angular input motion).

VALUE-given element data are held at their value at the position (the laws
are evaluated there, so their derivatives are those of the time and posture
of that step only).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from openimp.dynamics.frequency import frequency_response, transfer_function
from openimp.dynamics.linearize import linearize
from openimp.dynamics.modes import modes
from openimp.errors import AnalysisError, InputError
from openimp.imp.listing import step_text, tables_from_columns
from openimp.imp.run.prepare import DynSpec, Item, Prepared, stepped
from openimp.imp.run.quantities import value_resolver
from openimp.imp.run.solution import Solution
from openimp.results import FrequencyResponse, Linearization, Modes, Table, TransferFunction

__all__ = ["KINDS", "Vibration", "analyse"]

#: the request items this module answers
KINDS = ("modes", "dynamics")

#: significant digits of frequencies, damping ratios, time constants and coefficients
DIGITS = 6


@dataclass
class Vibration:
    """What the FREQUENCY and DYNAMICS requests of a run produced.

    ``tables``: one PRINT FREQUENCY table and one table per DYNAMICS request;
    ``steps``: the PRINT FREQUENCY lines of each position; ``after``: the
    PRINT DYNAMICS text, printed after the run; ``problems``: one located
    message per request not produced (or not at every position).
    """

    tables: list[Table] = field(default_factory=list)
    steps: dict[int, list[str]] = field(default_factory=dict)
    after: list[str] = field(default_factory=list)
    problems: list[str] = field(default_factory=list)


class _Linearized:
    """The linearizations of a solved run, computed once per position asked for."""

    def __init__(self, prep: Prepared, sol: Solution, notes: list[str]) -> None:
        self.prep, self.sol, self.notes = prep, sol, notes
        self.cache: dict[int, Linearization | Exception] = {}

    def at(self, k: int) -> Linearization:
        """The linearization at step ``k``; raises InputError or AnalysisError."""
        if k not in self.cache:
            try:
                self.cache[k] = self._linearize(k)
            except (InputError, AnalysisError) as exc:
                self.cache[k] = exc
        got = self.cache[k]
        if isinstance(got, Exception):
            raise got
        return got

    def _linearize(self, k: int) -> Linearization:
        prep, sol = self.prep, self.sol
        system = prep.system
        st = prep.spec.state
        names = [system.var_names[d.column] for d in prep.drivers]
        cols = [d.column for d in prep.drivers]
        laws = prep.built.dyn.laws
        if laws is not None:  # VALUE data at this step's posture and time
            laws.times = sol.times
            laws.resolve_at = (lambda _s: value_resolver(prep, sol, k, sol.times[k], None, k,
                                                    self.notes))
        # the FGCs are held by the kinematic run: their accelerations are 0, not those of
        # the equations of motion (linearize's default for a moving set point)
        accels = dict.fromkeys(sol.fgc[k], 0.0)
        accels.update({n: sol.qdd[k, c] for n, c in zip(names, cols)})
        lin = linearize(system, sol.q[k], {n: sol.qd[k, c] for n, c in zip(names, cols)},
                        accels, specified=names,
                        t=float(sol.times[k]),
                        pivot_tol=st.tolerance("SYSTEM")[0] if "SYSTEM" in st.zero else 1e-10,
                        close=True)  # a loose ZERO (POSITION): closed again, not refused
        if laws is not None:
            _note_once(self.notes, laws.notes)
            laws.notes.clear()
        return lin


def _note_once(notes: list[str], new: list[str]) -> None:
    for m in new:
        if m not in notes:
            notes.append(m)


def _loc(item: Item) -> str:
    w = item.request.where
    return f"{w[0]}:{w[1]}: {item.request.keyword}"


def _g(x: float) -> str:
    return f"{x:.{DIGITS}g}"


def _at(prep: Prepared, sol: Solution, k: int) -> str:
    """'step 3' or 'time 0.250000': the position ``k`` as the run counts it."""
    t = sol.times[k]
    return f"step {step_text(t)}" if stepped(prep.spec.state) else f"time {t:.6f}"


# ----------------------------------------------------------------------------- modes
NO_FGC = ("No free generalized coordinates: every coordinate is an input motion or the "
          "mechanism is a structure, so there are no natural frequencies at this position.")


def _mode_lines(m: Modes) -> list[str]:
    """PRINT FREQUENCY lines of one position (one per mode)."""
    out = ["Vibration Results:", "Mode Frequency (rad/s) Damping ratio"]
    for i in range(m.count):
        kind, tau = m.kind[i], m.time_constant[i]
        grow = " (unstable)" if m.unstable[i] else ""
        if kind == "oscillatory":
            out.append(f"{i + 1} {_g(m.frequency[i])} {_g(m.damping[i])}{grow}")
        elif kind == "overdamped":
            out.append(f"{i + 1} Time constant = {_g(tau)} s (over-damped){grow}")
        else:
            out.append(f"{i + 1} Neutral: zero frequency, no restoring load")
    return out


def _mode_rows(m: Modes, t: float) -> np.ndarray:
    """Table rows of one position: frequency (0 for a neutral mode), damping ratio,
    time constant (NaN where it does not apply or is infinite), time, mode."""
    freq = m.frequency
    tau = np.where(np.isfinite(m.time_constant), m.time_constant, np.nan)
    n = m.count
    return np.column_stack([freq, m.damping, tau, np.full(n, t), np.arange(1.0, n + 1)])


def _frequencies(item: Item, prep: Prepared, sol: Solution, lins: _Linearized,
                 out: Vibration) -> None:
    """PRINT FREQUENCY at every position of the run."""
    rows: list[np.ndarray] = []
    failed: list[tuple[int, str]] = []
    for k in range(sol.n):
        try:
            lin = lins.at(k)
            if lin.free.size == 0:
                out.steps.setdefault(k, []).append(f"*** {NO_FGC} ***")
                continue
            m = modes(lin)
        except (InputError, AnalysisError) as exc:
            failed.append((k, str(exc)))
            out.steps.setdefault(k, []).append(f"*** {_loc(item)}: {exc} ***")
            continue
        out.steps.setdefault(k, []).extend(_mode_lines(m))
        rows.append(_mode_rows(m, float(sol.times[k])))
    if failed:
        k, why = failed[0]
        out.problems.append(f"{_loc(item)} is not produced at {len(failed)} of {sol.n} "
                            f"position(s); at the first ({_at(prep, sol, k)}): {why}")
    if rows:
        tcol = "Step" if stepped(prep.spec.state) else "Time"
        out.tables.append(tables_from_columns(
            item.request.keyword, "modes",
            ["Frequency", "Damping ratio", "Time constant", tcol, "Mode"],
            ["rad/s", "", "s", "" if tcol == "Step" else "s", ""], list(np.vstack(rows).T)))


# ----------------------------------------------------------------------------- dynamics
def _ratio(out_unit: str, in_unit: str) -> str:
    """The unit of an output per unit of an input, e.g. ``deg/force``."""
    def wrap(u: str) -> str:
        return f"({u})" if "/" in u or "*" in u else u

    return f"{wrap(out_unit)}/{wrap(in_unit)}"


#: a term or response smaller than this fraction of the largest of its pair is round-off
ROUND_OFF = 1e-10


def _pairs(spec: DynSpec) -> list[list[int]]:
    """The outputs of ``spec`` grouped by request pair (a point's X, Y, Z; a joint's
    variables): one scale, so a component that does not move shows as exact zero."""
    groups: dict[tuple[str, str], list[int]] = {}
    for j, o in enumerate(spec.outputs):
        groups.setdefault((o.label.rsplit(" ", 1)[0], o.unit), []).append(j)
    return list(groups.values())


def _clean_numerators(tfs: list[TransferFunction], spec: DynSpec) -> list[TransferFunction]:
    """Numerator terms a_k S^k that are round-off set to 0: at the frequency scale wc of
    the poles (their geometric mean), a term |a_k| wc^k below ``ROUND_OFF`` of the
    largest term of its pair is round-off."""
    poles = np.abs(tfs[0].poles())
    poles = poles[poles > 0]
    wc = float(np.exp(np.mean(np.log(poles)))) if poles.size else 1.0
    terms = [np.abs(tf.num) * wc ** np.arange(tf.num.size - 1, -1, -1.0) for tf in tfs]
    out = list(tfs)
    for group in _pairs(spec):
        top = max(float(np.max(terms[j])) for j in group)
        for j in group:
            tf = tfs[j]
            num = np.where(terms[j] <= ROUND_OFF * top, 0.0, tf.num)
            k = int(np.argmax(num != 0)) if np.any(num != 0) else num.size - 1
            out[j] = TransferFunction(tf.input, tf.output, num[k:], tf.den)
    return out


def _transfer(item: Item, spec: DynSpec, lin: Linearization, where: str, out: Vibration
              ) -> None:
    """PRINT and STORE DYNAMICS: the transfer functions, as text and coefficients."""
    inp = spec.input
    tfs = []
    for o in spec.outputs:
        tf = transfer_function(lin, (inp.kind, inp.key), (o.kind, o.key))
        tfs.append(TransferFunction(tf.input, tf.output, tf.num * (inp.gain * o.gain),
                                    tf.den))
    tfs = _clean_numerators(tfs, spec)
    if item.request.family == "PRINT":
        out.after.append(f"Transfer functions at the last position ({where}), input "
                         f"{inp.label} ({inp.unit}):")
        for o, tf in zip(spec.outputs, tfs):
            out.after.append(f"{o.label} ({_ratio(o.unit, inp.unit)}) = "
                             f"{tf.formula(DIGITS, 'S')}")
    deg = max(max(tf.num.size, tf.den.size) for tf in tfs) - 1
    power = np.arange(deg, -1, -1, dtype=float)

    def padded(c: np.ndarray) -> np.ndarray:
        return np.concatenate([np.zeros(deg + 1 - c.size), c])

    out.tables.append(tables_from_columns(
        item.request.keyword, inp.label,
        ["Power", "Denominator"] + [f"Numerator {o.label}" for o in spec.outputs],
        ["", ""] + [_ratio(o.unit, inp.unit) for o in spec.outputs],
        [power, padded(tfs[0].den)] + [padded(tf.num) for tf in tfs]))


def _response(item: Item, spec: DynSpec, lin: Linearization, out: Vibration) -> None:
    """LIST and PLOT DYNAMICS: magnitude and phase (degrees) over the frequency grid."""
    inp = spec.input
    assert spec.w is not None
    fr = frequency_response(lin, (inp.kind, inp.key), [(o.kind, o.key) for o in spec.outputs],
                            spec.w)
    H = fr.H * np.array([inp.gain * o.gain for o in spec.outputs])
    for group in _pairs(spec):  # a component that does not move: exact zero
        size = np.abs(H[:, group])
        H[:, group] = np.where(size <= ROUND_OFF * size.max(axis=1, keepdims=True), 0.0,
                               H[:, group])
    fr = FrequencyResponse(fr.w, H, fr.input, fr.outputs)
    mag, ph = fr.magnitude, fr.phase
    cols, units, data = ["Frequency"], ["rad/s"], [fr.w]
    for j, o in enumerate(spec.outputs):
        cols += [f"|{o.label}|", f"Phase {o.label}"]
        units += [_ratio(o.unit, inp.unit), "deg"]
        data += [mag[:, j], ph[:, j]]
    out.tables.append(tables_from_columns(item.request.keyword, inp.label, cols, units, data))


def _dynamics(item: Item, prep: Prepared, sol: Solution, lins: _Linearized,
              out: Vibration) -> None:
    """One DYNAMICS request at the last position of the run."""
    spec = item.dyn
    assert spec is not None
    k = sol.n - 1
    where = _at(prep, sol, k)
    try:
        lin = lins.at(k)
        if lin.free.size == 0:
            raise AnalysisError(NO_FGC.replace("this position", "the last position"))
        if spec.w is None:
            _transfer(item, spec, lin, where, out)
        else:
            _response(item, spec, lin, out)
    except (InputError, AnalysisError) as exc:
        out.problems.append(f"{_loc(item)} is not produced: at the last position ({where}): "
                            f"{exc}")


def analyse(prep: Prepared, sol: Solution, items: list[Item], notes: list[str]) -> Vibration:
    """The FREQUENCY and DYNAMICS ``items`` of a solved kinematic run (see the module
    docstring).  Problems never raise: they are located messages in the result."""
    out = Vibration()
    if sol.n == 0:
        return out
    lins = _Linearized(prep, sol, notes)
    for it in items:
        if it.kind == "modes":
            _frequencies(it, prep, sol, lins, out)
        elif it.kind == "dynamics":
            _dynamics(it, prep, sol, lins, out)
    if prep.built.dyn.laws is not None and lins.cache:
        # the VALUE laws read the solved step, not the nudged postures of the derivatives
        _note_once(notes, ["linearized equations: spring, damper and load data given by "
                           "VALUE expressions are held at their values of each position; "
                           "how they change with a small motion is not included"])
    else:
        approximated = {m for lin in lins.cache.values() if isinstance(lin, Linearization)
                        for m in lin.messages}
        _note_once(notes, [f"linearized equations: {m}" for m in sorted(approximated)])
    return out
