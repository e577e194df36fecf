"""The force analysis of a solved run, in IMP's conventions (docs/imp-language.md §2.3, §2.4).

After the runner has solved the motion (or, in static mode, the equilibria,
whose FGCs are held there with the residual as their load), :func:`compute` calls
:func:`openimp.forces` on it (inertia loads from the input velocities and
accelerations, gravity, springs, dampers, applied forces and torques; every
SGC and every held FGC carries the drive load it needs) and converts the
results to what IMP lists in **kinematic mode** (settled in docs/imp-language.md §2.4):

* a joint's load is the load of the **first-named** link on the **second**,
  forces FX FY FZ on the axes u', v', w' of the joint frame on the **second**
  link and moments MX MY MZ about those axes, about that frame's origin.
  Joint springs, dampers and loads are part of it; for a driven joint the
  moment about (force along) its axis is the drive.  For a SPHERE joint the
  three moments are the projections on its x-y'-z'' Euler axes (u of the
  first link, the line of nodes, w' of the second).  PRINT FORCE uses the
  same axes as LIST, STORE and PLOT;
* in **static and dynamic mode** the other way round: the load of the
  **second-named** link on the **first**, on the axes of the joint frame on
  the **first** link, moments about that frame's origin (SPHERE moments on
  the same Euler axes);
* springs and dampers: the axial force, tension positive;
* a component that the constraints leave statically indeterminate (the
  compatibility test of book 17.18 against ZERO (INDETERM)) is NaN: ``????``
  in listings and PRINT, ``null`` in JSON, ``0.000002`` in STORE files.

The IMP frames differ from openimp's for some keywords (an XPIN turns about
its u axis, openimp's revolute about w; a BEVEL's u axes are re-aimed), so
the components are rotated from openimp's joint frame to the IMP one here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from openimp.errors import InputError
from openimp.imp.expr import reads
from openimp.imp.run.prepare import Prepared
from openimp.imp.run.solution import Solution

__all__ = ["ForceResults", "compute", "reads_forces", "wants_forces"]


@dataclass
class ForceResults:
    """IMP-convention loads of a solved run (model units, NaN: indeterminate).

    ``joints``: joint -> (steps x 6) FX FY FZ MX MY MZ; ``elements``: (kind,
    name) -> (steps,) the axial force of a spring or damper (tension
    positive), the magnitude of a force or torque.
    """

    joints: dict[str, np.ndarray] = field(default_factory=dict)
    elements: dict[tuple[str, str], np.ndarray] = field(default_factory=dict)
    drive: dict[str, np.ndarray] = field(default_factory=dict)

    def value(self, name: str, comp: int, step: int) -> float:
        """IMP's ``FORCE(name, comp)`` at a step: a joint's component 1-6, a spring's
        or damper's axial force (comp 1); NaN when it is not known."""
        if name in self.joints and 1 <= comp <= 6:
            arr = self.joints[name]
        elif comp == 1 and ("spring", name) in self.elements:
            arr = self.elements[("spring", name)][:, None]
        elif comp == 1 and ("damper", name) in self.elements:
            arr = self.elements[("damper", name)][:, None]
        else:
            return math.nan
        if not 0 <= step < arr.shape[0]:
            return math.nan
        return float(arr[step, max(comp - 1, 0) if arr.shape[1] > 1 else 0])


def reads_forces(prep: Prepared, name: str) -> bool:
    """True when VALUE ``name`` (or a VALUE it uses) reads ``FORCE(...)``."""
    return reads([name], prep.spec.state.values, ("FORCE",))


def wants_forces(prep: Prepared) -> bool:
    """True when a request of the run needs the force analysis (a FORCE request, or
    a VALUE request whose VALUE reads FORCE(...))."""
    for it in prep.items:
        if it.request.quantity == "FORCE":
            return True
        if it.kind == "value" and reads_forces(prep, it.name):
            return True
    return False


def _unit(v: np.ndarray) -> np.ndarray:
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(n > 1e-12, v / np.where(n > 0, n, 1.0), np.nan)


def joint_load(prep: Prepared, sol: Solution, forces: Any, name: str) -> np.ndarray:
    """(steps x 6) the load of joint ``name`` in IMP's convention of the run's mode (see
    the module docstring) from :class:`openimp.results.Forces`."""
    model = prep.built.model
    ij, _jd, L1, L2 = prep.built.joints[name]
    mj = model.joints[name]
    # IMP's joint frames on the first and the second link
    B1 = sol.traj.posture(mj.body1) @ L1
    B2 = sol.traj.posture(mj.body2) @ L2
    axes = None
    if ij.keyword == "SPHERE":  # moments on the Euler axes u, the line of nodes, w'
        e1 = B1[:, :3, 0]
        e3 = B2[:, :3, 2]
        e2 = _unit(np.cross(e3, e1))
        axes = np.stack([e1, e2, e3], axis=1)
    if prep.spec.mode == "kinematic":
        return forces.in_frame(name, B2, axes)
    # static and dynamic mode: the second link's load on the first, on the first link's
    # joint axes, moments about that frame's origin
    return -forces.in_frame(name, B1, axes)


def compute(prep: Prepared, sol: Solution, notes: list[str]) -> ForceResults:
    """The force analysis of a solved kinematic run (see the module docstring).

    VALUE laws (element data given by VALUE names) must already have their
    resolver (:attr:`openimp.imp.dyndata.ValueLaws.resolve_at`).  Raises
    :class:`InputError` when a load law fails.
    """
    from openimp.dynamics import forces_of

    st = prep.spec.state
    itol = st.tolerance("INDETERM")[0]
    ptol = st.tolerance("SYSTEM")[0] if "SYSTEM" in st.zero else 1e-10
    f = forces_of(sol.traj, indeterminate=itol, pivot_tol=ptol)
    out = ForceResults(drive=dict(f.drive))
    model = prep.built.model
    for name in model.joints:
        out.joints[name] = joint_load(prep, sol, f, name)
    for (kind, name), key in prep.built.dyn.names.items():
        out.elements[(kind, name)] = f.element(key)
    for m in f.messages:
        if m not in notes:
            notes.append(m)
    return out


def safe_compute(prep: Prepared, sol: Solution, notes: list[str]) -> tuple[ForceResults | None,
                                                                          str]:
    """:func:`compute`, or None and why (a located message) when it cannot be done."""
    laws = prep.built.dyn.laws
    if laws is not None:
        laws.times = sol.times
    try:
        res = compute(prep, sol, notes)
    except InputError as exc:
        w = prep.spec.where
        return None, (f"{w[0]}:{w[1]}: EXECUTE: the force analysis failed: {exc}; the FORCE "
                      "requests are not produced")
    finally:
        if laws is not None:
            for m in laws.notes:
                if m not in notes:
                    notes.append(m)
            laws.notes.clear()
    return res, ""
