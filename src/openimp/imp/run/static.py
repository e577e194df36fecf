"""The static runner: equilibrium postures (FIND EQUILIB, book ch 12).

For every EXECUTE in static mode:

1. the SGC values at every output step come from DATA POSITION and DATA
   MOTION as in kinematic mode (:class:`~openimp.imp.run.kinematic.Motions`;
   no velocities: DATA VELOCITY and ACCEL are refused before FIND EQUILIB);
2. every step's equilibrium is searched from the last one
   (:func:`openimp.dynamics.equilibrium.equilibria`) with IMP's ZERO (EQUILIB)
   step cap and, when the deck sets it, its step tolerance; the force
   tolerance is openimp's (relative 1e-10 of the loads), so that a reported
   equilibrium is balanced, not merely "steps got small";
3. the run's trajectory is the equilibria; the force analysis then follows
   with the FGCs held there (their holding load is the residual, below the
   tolerance) in IMP's static-mode convention (:mod:`~openimp.imp.run.forces`).

A step whose equilibrium is not found (the step cap, or a posture that
cannot be assembled) stops the run there with IMP's message; the steps
before it are kept.  Element data given by VALUE names are evaluated with
the time of the step only while searching (a VALUE that reads the posture
is undefined there and 0 is used, with a message).
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable
from typing import Any

import numpy as np

from openimp.dynamics.equilibrium import MAX_ITER, equilibria, turning_points
from openimp.errors import InputError
from openimp.imp.run.dynamic import state_resolver
from openimp.imp.run.kinematic import Motions, reads_model
from openimp.imp.run.prepare import Prepared
from openimp.imp.run.solution import Solution
from openimp.kinematics.track import tracker
from openimp.results import Trajectory


def solve(prep: Prepared, times: np.ndarray, start: np.ndarray | None,
          notes: list[str], progress: Callable[[int, int], None] | None = None) -> Solution:
    """Solve every step of a static run (see the module docstring)."""
    system = prep.system
    st = prep.spec.state
    drivers = prep.drivers
    empty = Trajectory.empty(system, tracker(system))
    n = len(times)
    if reads_model(st, drivers):
        notes.append("A DATA MOTION VALUE reads model quantities: in static mode they are "
                     "undefined before the equilibrium is found, and 0 is used.")
    motions = Motions(prep, times, notes)
    motions.fill(0, n, None)
    if motions.halt is not None:
        n = motions.halt.step
    opts: dict[str, Any] = {"forces": False}
    tol, cap = st.tolerance("EQUILIB")
    opts["max_iter"] = int(cap or MAX_ITER)
    if "EQUILIB" in st.zero:
        opts["step_tol"] = float(tol)
    if "SYSTEM" in st.zero:
        opts["pivot_tol"] = float(st.tolerance("SYSTEM")[0])
    laws = prep.built.dyn.laws
    if laws is not None:  # while searching, a VALUE reads each posture tried (at rest)
        laws.times = np.asarray(times, float)
        laws.resolve_at = None
        laws.resolve_state = state_resolver(prep, at_rest=True)
    path = {system.var_names[d.column]: motions.p[:n, j] for j, d in enumerate(drivers)}
    if n == 0:
        sol = Solution(empty, times[:0], motions.halt.text if motions.halt else "")
        return sol
    try:
        told = None if progress is None else (
            lambda done, total: progress(int(done), int(total)))  # steps, whole numbers
        res = equilibria(system, path or None, times=np.asarray(times[:n], float),
                         q=start, progress=told, **opts)
    except InputError as exc:
        return Solution(empty, times[:0],
                        _in_imp_terms(f"the run stopped at step 0: {exc}", prep, drivers))
    finally:
        if laws is not None:
            laws.resolve_state = None
    good = res.trajectory.nsteps if res.trajectory is not None else 0
    sol = Solution(res.trajectory if res.trajectory is not None else empty,
                   np.asarray(times[:good], float),
                   _in_imp_terms(_stop_text(res, times), prep, drivers))
    sol.interrupted = res.interrupted
    sol.search = [e.messages[0] if e.status == "balanced" else "" for e in res.steps]
    sol.equilibria = res
    told: set[str] = set()
    for k, e in enumerate(res.steps):
        if not e.converged:
            continue  # its messages are the run's stop message
        for m in e.messages[1 if e.status == "balanced" else 0:]:
            if m not in told:  # once, at the first step that says it
                told.add(m)
                notes.append(f"step {k}: {m}" if n > 1 else m)
    for m in turning_points(res, *_imp_names(prep, drivers)):
        notes.append(f"Turning point: {m}")
    if motions.halt is not None and not sol.message:
        sol.stop = motions.halt.text
    return sol


def _imp_names(prep: Prepared, drivers: list[Any]) -> tuple[str | None, Any, Any]:
    """The path's parameter as IMP lists it (the first input joint, in degrees or
    lengths) and the SGC names of the holding forces as joints."""
    if not drivers:
        return "time", None, lambda name: name.split(".")[0]
    d = drivers[0]
    by_col = {prep.system.var_names[x.column]: _imp_label(x) for x in drivers}
    return _imp_label(d), lambda v: _imp_value(d, v), lambda name: by_col.get(name, name)


def _imp_label(d: Any) -> str:
    """An input as IMP names it: the joint, and the variable number past the first."""
    return d.joint if d.var == 0 else f"{d.joint} {d.var + 1}"


def _imp_value(d: Any, v: float) -> str:
    """An input's value (openimp units, signed) as IMP gives it: degrees or a length."""
    v *= d.sign
    return f"{math.degrees(v):.4f} deg" if d.kind == "angle" else f"{v:.6g}"


def _in_imp_terms(text: str, prep: Prepared, drivers: list[Any]) -> str:
    """``text`` with every ``joint.var = value`` of an input in IMP's terms: the joint
    (and variable number) and the value in degrees or lengths."""
    for d in drivers:
        name = prep.system.var_names[d.column]

        def imp(m: re.Match, d: Any = d) -> str:
            return f"{_imp_label(d)} = {_imp_value(d, float(m.group(1)))}"

        text = re.sub(re.escape(name) + r" = (-?[0-9.]+(?:e[-+]?[0-9]+)?)", imp, text)
    return text


def _stop_text(res: Any, times: np.ndarray) -> str:
    """Why the path stopped early, with what was kept ("" when it did not)."""
    if not res.message:
        return ""
    k = len(res.steps) - (0 if not res.steps or res.steps[-1].converged else 1)
    kept = (f"; the {k} equilibrium position(s) before it are listed" if k > 0 else
            "; no equilibrium was found")
    return f"{res.message}{kept}"
