"""Quantities of a solved run as IMP prints them: joint variables, points, links,
springs and dampers, VALUEs; the request tables and the PRINT text per step.

Mode-independent: every runner hands its motion over as a
:class:`~openimp.imp.run.solution.Solution`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from openimp.imp.expr import SimulationStop
from openimp.imp.jointmap import ImpJoint, imp_variables, to_degrees
from openimp.imp.listing import tables_from_columns
from openimp.imp.run.prepare import Item, Prepared, plot_driver, stepped
from openimp.imp.run.solution import Solution
from openimp.results import Table


def point_motion(sol: Solution, name: str, which: int | None = None) -> Any:
    """Position, velocity and acceleration of a point (steps x 3 each), or only the
    one ``which`` (0, 1, 2) asks for."""
    get = (sol.traj.point, sol.traj.point_velocity, sol.traj.point_acceleration)
    if which is not None:
        return get[which](name)
    return tuple(f(name) for f in get)


_NAN = math.nan


def _joint_vars(prep: Prepared, sol: Solution, name: str
                ) -> tuple[ImpJoint, np.ndarray, np.ndarray, np.ndarray]:
    ij = prep.built.joints[name][0]
    sl = prep.system.joint_vars(name)
    p, v, a = imp_variables(ij, sol.q[:, sl], sol.qd[:, sl], sol.qdd[:, sl])
    assert v is not None and a is not None
    return ij, p, v, a


def _joint_origin(prep: Prepared, sol: Solution, name: str) -> np.ndarray:
    """The global origin of joint ``name``'s second frame (u'v'w', on its second link)
    at each step (steps, 3): what IMP's Position Results print after the first joint
    variable (docs/imp.md; the two origins differ for a joint that translates)."""
    _, _jd, _, L2 = prep.built.joints[name]
    T = sol.traj.posture(prep.built.model.joints[name].body2)
    return np.einsum("sij,j->si", T, L2[:, 3])[:, :3]


def joint_frames(prep: Prepared, sol: Solution, name: str) -> np.ndarray:
    """The frame (uvw on its first body) of joint ``name`` in global
    coordinates at each step of ``sol``: (steps, 4, 4)."""
    _, _, L1, _ = prep.built.joints[name]
    T = sol.traj.posture(prep.built.model.joints[name].body1)
    return T @ L1


def _spring(prep: Prepared, sol: Solution, kind: str, name: str
            ) -> tuple[np.ndarray, ...]:
    p1, p2 = prep.spec.state.extras[kind + "s"][name]["points"][:2]
    r1, v1, a1 = point_motion(sol, p1)
    r2, v2, a2 = point_motion(sol, p2)
    d, dd, ddd = r2 - r1, v2 - v1, a2 - a1
    L = np.linalg.norm(d, axis=1)
    Ls = np.where(L > 0, L, np.nan)
    Ld = np.einsum("si,si->s", d, dd) / Ls
    Ldd = (np.einsum("si,si->s", dd, dd) + np.einsum("si,si->s", d, ddd) - Ld**2) / Ls
    return L, Ld, Ldd, d, dd, ddd


def _axial(M: np.ndarray) -> np.ndarray:
    return np.stack([M[:, 2, 1], M[:, 0, 2], M[:, 1, 0]], axis=1)


_LEN = "length"


_ANG_UNITS = {"POSITION": "deg", "VELOCITY": "rad/s", "ACCEL": "rad/s^2"}


_LEN_UNITS = {"POSITION": _LEN, "VELOCITY": "length/s", "ACCEL": "length/s^2"}


def value_resolver(prep: Prepared, sol: Solution, k: int, t: float, motions: Any,
              step: int, notes: list[str]) -> Callable[[str, str | None, int], float]:
    """resolve(kind, name, comp) for VALUE expressions at solved step ``k``.

    ``k = -1`` means before the first step: the start posture is not solved
    yet, so model quantities are undefined there except SGCs of DATA POSITION.
    """
    model = prep.built.model
    st = prep.spec.state

    def resolve(kind: str, name: str | None, comp: int) -> float:
        if kind == "TIME":
            return t
        if kind == "FORCE" and sol.forces is not None and 0 <= k < sol.n:
            return sol.forces.value(name or "", comp, k)
        if kind == "FORCE":
            note = ("FORCE(...) in a VALUE is undefined where the VALUE is needed before the "
                    "forces of the step are known (a DATA MOTION, or the data of a spring, "
                    "damper or load: the forces follow from them, a circular evaluation)")
            if note not in notes:
                notes.append(note)
            return _NAN
        assert name is not None
        which = {"POSITION": 0, "VELOCITY": 1, "ACCEL": 2}[kind]
        if motions is not None:  # an SGC set before the VALUE is evaluated (no lag)
            for j, d in enumerate(prep.drivers):
                if d.joint == name and d.var == comp - 1 and d.inp.kind == "POSITION":
                    arr = (motions.p, motions.v, motions.a)[which]
                    return float(arr[step, j] * d.sign)
        if k < 0 or k >= sol.n:
            return _NAN
        if name in model.joints:
            _, p, v, a = _joint_vars(prep, sol.rows(k), name)
            arr = (p, v, a)[which]
            return float(arr[0, comp - 1]) if 1 <= comp <= arr.shape[1] else _NAN
        if name in model.points and 1 <= comp <= 3:
            return float(point_motion(sol, name, which)[k, comp - 1])
        for el in ("springs", "dampers"):
            if name in st.extras.get(el, {}) and 1 <= comp <= 3:
                _, _, _, d, dd, ddd = _spring(prep, sol.rows(k), el[:-1], name)
                return float((d, dd, ddd)[which][0, comp - 1])
        return _NAN

    return resolve


def stop_at_value(prep: Prepared, sol: Solution, notes: list[str]) -> Solution:
    """``sol`` cut before the first step at which a VALUE of the run's requests
    evaluates RETURN or END: IMP stops the simulation there (docs/imp-language.md §5)."""
    st = prep.spec.state
    first: tuple[int, str, SimulationStop] | None = None
    for it in prep.items:
        if it.kind != "value":
            continue
        ex = st.values[it.name]
        for k in range(sol.n if first is None else first[0]):
            try:
                ex.derivatives(st.values, value_resolver(prep, sol, k, sol.times[k], None, k, []))
            except SimulationStop as stop:
                first = (k, it.name, stop)
                break
    if first is None:
        return sol
    k, name, stop = first
    cut = sol.rows(0, k)
    cut.response = sol.response  # its arrays start at step 0 too
    listed = f"the {k} position(s) before it are listed" if k else "no position is listed"
    text = (f"{stop.where[0]}:{stop.where[1]}: VALUE {name} evaluated {stop.kind} at time "
            f"{sol.times[k]:.6f}: the run stops there ")
    if stop.kind == "END":
        cut.stop = text + f"and no further EXECUTE runs (END in a VALUE leaves IMP); {listed}"
        cut.end = True
    else:
        cut.stop = text + f"(RETURN in a VALUE); {listed}"
    return cut


def _values(prep: Prepared, sol: Solution, name: str, notes: list[str]) -> np.ndarray:
    st = prep.spec.state
    ex = st.values[name]
    out = np.full((sol.n, 3), _NAN)
    for k in range(sol.n):
        vnotes: list[str] = []
        try:
            out[k] = ex.derivatives(st.values, value_resolver(prep, sol, k, sol.times[k], None, k,
                                                         notes), notes=vnotes)
        except SimulationStop as stop:
            notes.append(f"{stop.where[0]}:{stop.where[1]}: VALUE {name} evaluated {stop.kind} "
                         f"at time {sol.times[k]:.6f}; IMP would stop the run there (the "
                         "values after it are left undefined)")
            break
        for v in vnotes:
            if v not in notes:
                notes.append(v)
    return out


def make_table(prep: Prepared, sol: Solution, it: Item, notes: list[str]) -> Table:
    """The table of one request item."""
    req = it.request
    fam, q = req.family, req.quantity
    t = sol.times
    request = req.keyword
    cols: list[str] = ["Time"]
    units: list[str] = ["s"]
    data: list[np.ndarray] = [t]
    if stepped(prep.spec.state):  # IMP's assumed time: the step number (goes on after HOLD)
        cols, units = ["Step"], [""]
        d = plot_driver(prep) if fam == "PLOT" else None
        if d is not None:  # the abscissa of the plot: the input's value
            pos = _joint_vars(prep, sol, d.joint)[1][:, d.var]
            cols.append(f"{d.joint} {d.var + 1}")
            units.append(_ANG_UNITS["POSITION"] if d.kind == "angle" else _LEN)
            data.append(np.degrees(pos) if d.kind == "angle" else pos)
    if it.kind == "heading":
        cols += ["DOF", "Quality index", "Iterations"]
        units += ["", "", ""]
        data += [sol.mobility.astype(float), sol.quality, sol.iterations.astype(float)]
        for d in prep.drivers:
            ij, p, v, a = _joint_vars(prep, sol, d.joint)
            pos = p[:, d.var]
            pos = np.degrees(pos) if d.kind == "angle" else pos
            u = _ANG_UNITS if d.kind == "angle" else _LEN_UNITS
            for lab, arr, key in (("", pos, "POSITION"), (" vel", v[:, d.var], "VELOCITY"),
                                  (" acc", a[:, d.var], "ACCEL")):
                cols.append(f"{d.joint} {d.var + 1}{lab}")
                units.append(u[key])
                data.append(arr)
        if sol.equilibria is not None:  # static mode: the FGCs found and the search steps
            _equilibrium_columns(prep, sol, cols, units, data)
        elif sol.response is not None:  # dynamic mode: the FGCs integrated
            _free_columns(prep, sol, cols, units, data, rates=True)
        return tables_from_columns(request, "generalized coordinates", cols, units, data)
    if it.kind == "value":
        vals = _values(prep, sol, it.name, notes)
        cols += ["Value", "d/dt", "d2/dt2"]
        units += ["", "1/s", "1/s^2"]
        data += [vals[:, 0], vals[:, 1], vals[:, 2]]
        return tables_from_columns(request, f"value {it.name}", cols, units, data)
    if q == "FORCE":
        return _force_table(sol, it, request, cols, units, data)
    which = {"POSITION": 0, "VELOCITY": 1, "ACCEL": 2}[q]
    if it.kind == "joint":
        ij, p, v, a = _joint_vars(prep, sol, it.name)
        arr = (p, v, a)[which]
        if which == 0:
            arr = to_degrees(ij, arr)
        for k, kind in enumerate(ij.var_kinds):
            cols.append(f"JVar {k + 1}")
            units.append((_ANG_UNITS if kind == "angle" else _LEN_UNITS)[q])
            data.append(arr[:, k])
        if fam == "PRINT" and which == 0:
            o = _joint_origin(prep, sol, it.name)
            cols += ["X", "Y", "Z"]
            units += [_LEN] * 3
            data += [o[:, 0], o[:, 1], o[:, 2]]
        return tables_from_columns(request, f"joint {it.name}", cols, units, data)
    if it.kind == "point":
        arr = point_motion(sol, it.name, which)
        if fam == "PRINT":
            cols.append("Magnitude")
            units.append(_LEN_UNITS[q])
            data.append(np.linalg.norm(arr, axis=1))
        cols += ["X", "Y", "Z"]
        units += [_LEN_UNITS[q]] * 3
        data += [arr[:, 0], arr[:, 1], arr[:, 2]]
        return tables_from_columns(request, f"point {it.name}", cols, units, data)
    if it.kind == "link":
        if which == 0:
            T = sol.traj.posture(it.name)
            for i in range(3):
                for j in range(4):
                    cols.append(f"T{i + 1}{j + 1}")
                    units.append(_LEN if j == 3 else "")
                    data.append(T[:, i, j])
        else:
            M = (sol.traj.velocity_operator(it.name) if which == 1 else
                 sol.traj.acceleration_operator(it.name))
            ang = _axial(M)
            lab = ("Omega", "V") if which == 1 else ("Alpha", "A")
            au = "rad/s" if which == 1 else "rad/s^2"
            for c in range(3):
                cols.append(f"{lab[0]}{'XYZ'[c]}")
                units.append(au)
                data.append(ang[:, c])
            for c in range(3):
                cols.append(f"{lab[1]}{'XYZ'[c]}")
                units.append(_LEN_UNITS[q])
                data.append(M[:, c, 3])
        return tables_from_columns(request, f"link {it.name}", cols, units, data)
    # spring / damper
    L, Ld, Ldd, d, dd, ddd = _spring(prep, sol, it.kind, it.name)
    scalar = (L, Ld, Ldd)[which]
    vec = (d, dd, ddd)[which]
    if fam != "STORE":
        cols.append({"POSITION": "Length", "VELOCITY": "Length rate",
                     "ACCEL": "Length acceleration"}[q])
        units.append(_LEN_UNITS[q])
        data.append(scalar)
    if fam in ("PRINT", "STORE"):
        cols += ["DX", "DY", "DZ"]
        units += [_LEN_UNITS[q]] * 3
        data += [vec[:, 0], vec[:, 1], vec[:, 2]]
    return tables_from_columns(request, f"{it.kind} {it.name}", cols, units, data)


#: the components of a joint load (docs/imp-language.md §2.3) and their units
FORCE_COLUMNS = ("FX", "FY", "FZ", "MX", "MY", "MZ")
_FORCE, _MOMENT = "force", "force*length"


def _force_table(sol: Solution, it: Item, request: str, cols: list[str], units: list[str],
                 data: list[np.ndarray]) -> Table:
    """The table of a FORCE request item (IMP's kinematic-mode convention, see
    :mod:`openimp.imp.run.forces`): a joint's FX FY FZ MX MY MZ, a spring's or
    damper's axial force (tension positive); NaN where indeterminate."""
    res = sol.forces
    if it.kind == "joint":
        R = res.joints[it.name] if res is not None else np.full((sol.n, 6), _NAN)
        for c, lab in enumerate(FORCE_COLUMNS):
            cols.append(lab)
            units.append(_FORCE if c < 3 else _MOMENT)
            data.append(R[:, c])
    else:
        f = res.elements[(it.kind, it.name)] if res is not None else np.full(sol.n, _NAN)
        cols.append("Force")
        units.append(_FORCE)
        data.append(f)
    return tables_from_columns(request, f"{it.kind} {it.name}", cols, units, data)


def imp_variable(prep: Prepared, vn: str) -> tuple[int | None, int, str]:
    """The IMP joint variable that openimp's variable ``vn`` (``"joint.var"``) is: (its
    index in the IMP joint's variables, or None when the joint has no such IMP variable,
    its number as IMP prints it, its kind "angle" or "length")."""
    sy = prep.system
    joint = vn.split(".", 1)[0]
    k = sy.var_names[sy.joint_vars(joint)].index(vn)
    ij = prep.built.joints[joint][0] if joint in prep.built.joints else None
    if ij is not None:
        for i, d in enumerate(ij.drive):
            if d is not None and d[0] == k:
                return i, i + 1, ij.var_kinds[i]
    return None, k + 1, sy.var_kinds[sy.var_index(vn)]


def _free_columns(prep: Prepared, sol: Solution, cols: list[str], units: list[str],
                  data: list[np.ndarray], rates: bool) -> None:
    """The heading table's columns of every FGC of some step: its IMP joint variable
    (degrees or length; NaN at steps where it is not free) and, with ``rates``, its
    velocity and acceleration (a dynamic run integrates them)."""
    sy = prep.system
    names: list[str] = []
    for k in range(sol.n):
        for vn in sol.fgc[k]:
            if vn not in names:
                names.append(vn)
    for vn in names:
        joint = vn.split(".", 1)[0]
        i, idx, kind = imp_variable(prep, vn)
        if i is not None:  # the IMP joint variable this openimp variable is (sign)
            _ij, p, v, a = _joint_vars(prep, sol, joint)
            pva = (p[:, i], v[:, i], a[:, i])
        else:
            c = sy.var_index(vn)
            pva = (sol.q[:, c], sol.qd[:, c], sol.qdd[:, c])
        free = np.array([vn in sol.fgc[k] for k in range(sol.n)], bool)
        u = _ANG_UNITS if kind == "angle" else _LEN_UNITS
        pos = np.degrees(pva[0]) if kind == "angle" else pva[0]
        parts = [("", pos, "POSITION"), (" vel", pva[1], "VELOCITY"),
                 (" acc", pva[2], "ACCEL")][:3 if rates else 1]
        for lab, arr, key in parts:
            cols.append(f"{joint} {idx}{lab}")
            units.append(u[key])
            data.append(np.where(free, arr, np.nan))


def _equilibrium_columns(prep: Prepared, sol: Solution, cols: list[str], units: list[str],
                         data: list[np.ndarray]) -> None:
    """The heading table's columns of a static run: every FGC of some step (its IMP joint
    variable, degrees or length; NaN at steps where it is not free) and the search
    steps of every position."""
    _free_columns(prep, sol, cols, units, data, rates=False)
    steps = [e.steps for e in sol.equilibria.steps if e.converged][:sol.n]
    cols.append("Search steps")
    units.append("")
    data.append(np.asarray(steps, float))


#: the energy audit of a dynamic run (:class:`openimp.results.EnergyAudit`): its columns
ENERGY_COLUMNS = (("Kinetic", "kinetic"), ("Potential", "potential"),
                  ("Drive work", "drive_work"), ("Load work", "load_work"),
                  ("Dissipated", "dissipated"), ("Balance", "balance"))
_ENERGY = "force*length"


def dynamic_tables(sol: Solution, it: Item) -> list[Table]:
    """The tables a HEADING request adds in dynamic mode: the energy audit at every
    output time (item ``energy``) and the integration statistics (item
    ``integration``, one row at the last time reached)."""
    res = sol.response
    if res is None or it.kind != "heading":
        return []
    out = []
    n = sol.n
    if res.energy is not None:
        e = res.energy
        cols, units = ["Time"], ["s"]
        data: list[np.ndarray] = [sol.times]
        for lab, attr in ENERGY_COLUMNS:
            cols.append(lab)
            units.append(_ENERGY)
            data.append(np.asarray(getattr(e, attr), float)[:n])
        out.append(tables_from_columns(it.request.keyword, "energy", cols, units, data))
    st = res.integration
    if st is not None:
        t_end = sol.times[-1] if n else math.nan
        cols = ["Time", "Steps", "Rejected", "Evaluations", "Closures", "Smallest step",
                "Largest step", "Events", "Seconds"]
        units = ["s", "", "", "", "", "s", "s", "", "s"]
        row = [t_end, st.steps, st.rejected, st.evaluations, st.closures, st.smallest_step,
               st.largest_step, st.events, st.seconds]
        out.append(tables_from_columns(it.request.keyword, "integration", cols, units,
                                       [np.array([float(x)]) for x in row]))
    return out


#: an energy below this fraction of the run's energy scale prints as 0 (round-off)
NOISE = 1e-12


def energy_line(sol: Solution, k: int) -> str | None:
    """The PRINT HEADING line of the energy audit at step ``k`` of a dynamic run."""
    res = sol.response
    if res is None or res.energy is None or k >= len(res.energy.kinetic):
        return None
    e = res.energy
    floor = NOISE * e.scale  # round-off of a sum of energies is no datum
    parts = []
    for lab, attr in ENERGY_COLUMNS:
        v = float(getattr(e, attr)[k])
        parts.append(f"{lab.lower()} {0.0 if abs(v) <= floor else v:.6g}")
    return "Energy (force x length): " + ", ".join(parts) + "."


def integration_lines(sol: Solution) -> list[str]:
    """The PRINT HEADING lines after a dynamic run: how it was integrated and the
    relative energy balance."""
    res = sol.response
    if res is None or res.integration is None:
        return []
    st = res.integration
    out = [f"Integration ({st.method}): {st.steps} steps, {st.rejected} rejected, "
           f"{st.evaluations} evaluations, {st.closures} loop closures, steps from "
           f"{st.smallest_step:.3g} to {st.largest_step:.3g} s, {st.events} events, "
           f"{st.seconds:.3g} s."]
    if res.energy is not None and len(res.energy.relative):
        worst = float(np.nanmax(np.abs(res.energy.relative))) if sol.n else math.nan
        out.append(f"Energy balance: largest |balance| / energy scale = {worst:.2e}.")
    return out


def _magnitude(v: Any) -> float:
    """|v| with the indeterminate (NaN) components counted as zero, as IMP does."""
    a = np.asarray(v, dtype=float)
    return float(np.sqrt(np.sum(np.where(np.isfinite(a), a, 0.0) ** 2)))


def _f4(x: float) -> str:
    return "????" if not math.isfinite(x) else f"{x:.4f}".replace("-0.0000", "0.0000")


def _f3(x: float) -> str:
    """Three decimals; a round-off below them prints 0.000, not -0.000."""
    return "????" if not math.isfinite(x) else f"{x:.3f}".replace("-0.000", "0.000")


def print_step(prep: Prepared, sol: Solution, k: int, tables: dict[tuple[str, str, str], Any],
               items: list[Item]) -> list[str]:
    """The PRINT lines of step ``k``."""
    out: list[str] = []
    heading = [it for it in items if it.kind == "heading"]
    if not heading and sol.search is not None and k < len(sol.search) and sol.search[k]:
        out.append(sol.search[k])
    if heading:
        out.append("The Generalized Coordinates are:")
        out.append("Joint Set by Position Velocity Acceleration" + (
            "" if prep.spec.state.imp_listing else  # IMP printed no units
            " [deg, rad/s, rad/s^2 or length, length/s, length/s^2]"))
        for d in prep.drivers:
            _ij, p, v, a = _joint_vars(prep, sol.rows(k), d.joint)
            pos = p[0, d.var]
            pos = math.degrees(pos) if d.kind == "angle" else pos
            out.append(f"{d.joint} {d.var + 1} user {_f4(pos)} {_f3(v[0, d.var])} "
                       f"{_f3(a[0, d.var])}")
        for vn in sol.fgc[k]:
            joint = vn.split(".", 1)[0]
            c = prep.system.var_index(vn)
            pos, vel, acc = sol.q[k, c], sol.qd[k, c], sol.qdd[k, c]
            i, idx, kind = imp_variable(prep, vn)
            if i is not None:  # the IMP joint variable this openimp variable is (sign)
                _ij, p, v, a = _joint_vars(prep, sol.rows(k), joint)
                pos, vel, acc = p[0, i], v[0, i], a[0, i]
            out.append(f"{joint} {idx} imp {_f4(math.degrees(pos) if kind == 'angle' else pos)}"
                       f" {_f3(vel)} {_f3(acc)}")
        if sol.search is not None and k < len(sol.search) and sol.search[k]:
            out.append(sol.search[k])
        out.append(f"Degree of freedom = {int(sol.mobility[k])}. Quality index = "
                   f"{sol.quality[k]:.2e} with {int(sol.iterations[k])} iterations.")
        energy = energy_line(sol, k)
        if energy is not None:
            out.append(energy)
    for q, title in (("POSITION", "Position Results:"), ("VELOCITY", "Velocity Results:"),
                     ("ACCEL", "Acceleration Results:")):
        its = [it for it in items if it.request.quantity == q and it.kind != "heading"]
        if not its:
            continue
        out.append(title)
        out.append("Item Name Magnitude X Y Z")
        for it in its:
            t = tables[("PRINT", q, f"{it.kind} {it.name}")]
            row = t.rows[k]
            if it.kind == "joint":
                nv = sum(1 for c in t.columns if c.startswith("JVar"))
                vals = [_f4(x) for x in row[1:1 + nv]]
                first = vals[0] if vals else ""
                extra = " " + " ".join(_f4(x) for x in row[1 + nv:]) if q == "POSITION" else ""
                out.append(f"Joint {it.name} {first}{extra}".rstrip())
                out.extend(vals[1:])
            elif it.kind == "point":
                out.append(f"Point {it.name} " + " ".join(_f4(x) for x in row[1:]))
            elif it.kind == "link":
                vals = row[1:]
                if q == "POSITION":
                    out.append(f"Link {it.name}")
                    for i in range(3):
                        out.append(" ".join(_f4(x) for x in vals[4 * i:4 * i + 4]))
                else:
                    w, vv = vals[:3], vals[3:]
                    out.append(f"Link {it.name} {_f4(float(np.linalg.norm(w)))} "
                               + " ".join(_f4(x) for x in w))
                    out.append(f"{_f4(float(np.linalg.norm(vv)))} " + " ".join(_f4(x) for x in vv))
            else:
                lab = "Spg." if it.kind == "spring" else "Dmp."
                out.append(f"{lab} {it.name} " + " ".join(_f4(x) for x in row[1:]))
    forces = [it for it in items if it.request.quantity == "FORCE"]
    if forces:
        out.append("Force Results:")
        out.append("Magnitude X Y Z")
        for it in forces:
            row = tables[("PRINT", "FORCE", f"{it.kind} {it.name}")].rows[k]
            if it.kind == "joint":
                jd = prep.built.joints[it.name][1]
                out.append(f"through Joint {it.name} from Link {jd.link1} onto Link "
                           f"{jd.link2} :")
                F, M = row[1:4], row[4:7]
                out.append(f"Forc {_f3(_magnitude(F))} " + " ".join(_f3(x) for x in F))
                out.append(f"Torq {_f3(_magnitude(M))} " + " ".join(_f3(x) for x in M))
            else:
                lab = "Spg." if it.kind == "spring" else "Dmp."
                out.append(f"{lab} {it.name} {_f3(row[1])}")
    vals = [it for it in items if it.kind == "value"]
    if vals:
        out.append("Value Results:")
        out.append("Name Value Velocity Acceleration")
        for it in vals:
            row = tables[("PRINT", "VALUE", f"value {it.name}")].rows[k]
            out.append(f"{it.name} " + " ".join(_f4(x) for x in row[1:]))
    return out
