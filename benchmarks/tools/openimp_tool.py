"""openimp: the models of the benchmark mechanisms and the runs timed for each case."""

from __future__ import annotations

import numpy as np

import openimp
from benchmarks import mechanisms as mx
from benchmarks.harness import CaseRun, NotAvailable, Variant

NAME = "openimp"


def version() -> str:
    import openimp

    return openimp.__version__


def _xyz(p2) -> tuple[float, float, float]:
    return (float(p2[0]), float(p2[1]), 0.0)


def fourbar_model(fb: mx.FourBar):
    import openimp

    m = openimp.Model("fourbar")
    z = (0.0, 0.0, 1.0)
    m.add_joint("revolute", "A", "BASE", "CRANK", origin=_xyz(fb.A), axis=z)
    m.add_joint("revolute", "B", "CRANK", "COUPLER", origin=_xyz(fb.B0), axis=z)
    m.add_joint("revolute", "C", "COUPLER", "ROCKER", origin=_xyz(fb.C0), axis=z)
    m.add_joint("revolute", "D", "ROCKER", "BASE", origin=_xyz(fb.D), axis=z)
    m.add_point("P", "COUPLER", _xyz(fb.P0))
    m.add_point("RC", "ROCKER", _xyz(fb.C0))
    return m


def slider_model(sc: mx.SliderCrank):
    import openimp

    m = openimp.Model("slider-crank")
    z = (0.0, 0.0, 1.0)
    m.add_joint("revolute", "A", "BASE", "CRANK", origin=(0.0, 0.0, 0.0), axis=z)
    m.add_joint("revolute", "B", "CRANK", "ROD", origin=_xyz(sc.B0), axis=z)
    m.add_joint("revolute", "C", "ROD", "SLIDER", origin=_xyz(sc.C0), axis=z)
    m.add_joint("prismatic", "S", "SLIDER", "BASE", origin=_xyz(sc.C0), axis=(1.0, 0.0, 0.0))
    m.add_point("P", "ROD", _xyz(sc.P0))
    m.add_point("SC", "SLIDER", _xyz(sc.C0))
    return m


def rssr_model(rs: mx.RSSR):
    import openimp

    m = openimp.Model("rssr")
    m.add_joint("revolute", "A", "BASE", "CRANK", origin=(0.0, 0.0, 0.0), axis=(0.0, 0.0, 1.0))
    m.add_joint("sphere", "B", "CRANK", "COUPLER", origin=tuple(rs.B0))
    m.add_joint("sphere", "C", "COUPLER", "ROCKER", origin=tuple(rs.C0))
    m.add_joint("revolute", "D", "ROCKER", "BASE", origin=tuple(rs.D), axis=(1.0, 0.0, 0.0))
    m.add_point("RC", "ROCKER", tuple(rs.C0))
    return m


def chain_model(ch: mx.SerialChain6R):
    import openimp

    m = openimp.Model("6R")
    bodies = ["BASE"] + [f"L{i + 1}" for i in range(6)]
    for i in range(6):
        m.add_joint("revolute", f"J{i + 1}", bodies[i], bodies[i + 1],
                    origin=tuple(ch.origins[i]), axis=tuple(ch.axes[i]))
    m.add_point("P", "L6", tuple(ch.P0))
    return m


def _rocker_angle(res, fb_D) -> np.ndarray:
    C = res.point("RC")
    return np.arctan2(C[:, 1] - fb_D[1], C[:, 0] - fb_D[0])


def _complete(res):
    if not res.complete:
        raise RuntimeError(f"openimp sweep incomplete: {res.message}")
    return res


# ---------------------------------------------------------------- the cases
def case_fourbar(ctx) -> CaseRun:
    fb = mx.FOURBAR
    s = openimp.compile(fourbar_model(fb))
    drv = {"A": fb.crank_angles() - fb.theta0}

    def run():
        return _complete(openimp.sweep(s, drv))

    def outputs(res):
        return {"rocker": _rocker_angle(res, fb.D), "P": res.point("P")[:, :2]}

    return CaseRun(run, outputs, postures=mx.NSTEPS)


# SweepResult.qd / .qdd (joint rates, model units); the other names are fallbacks
_RATE_NAMES = ("qd", "qdot", "rates", "velocities")
_ACCEL_NAMES = ("qdd", "qddot", "accels", "accelerations")


def _find(res, names):
    for n in names:
        if hasattr(res, n):
            v = getattr(res, n)
            return v() if callable(v) else v
    return None


def case_fourbar_rates(ctx) -> CaseRun:
    """Positions, velocities and accelerations: system.sweep(drivers, rates=, accels=)."""
    fb = mx.FOURBAR
    s = openimp.compile(fourbar_model(fb))
    drv = {"A": fb.crank_angles() - fb.theta0}
    rates = {"A": np.full(mx.NSTEPS, mx.OMEGA)}
    accels = {"A": np.full(mx.NSTEPS, mx.ALPHA)}
    try:
        probe = openimp.sweep(s, drv, rates=rates, accels=accels)
    except Exception as e:  # the rates API does not exist yet
        raise NotAvailable(f"sweep(rates=, accels=) raised {type(e).__name__}: {e}") from None
    qd = _find(probe, _RATE_NAMES)
    qdd = _find(probe, _ACCEL_NAMES)
    if qd is None or qdd is None:
        raise NotAvailable("sweep(rates=, accels=) ran but its result has none of the "
                           f"attributes {_RATE_NAMES} / {_ACCEL_NAMES}")
    # sign of the rocker angle in joint D's variable (ROCKER is D's first body)
    iD = s.var_index("D")
    rocker = _rocker_angle(probe, fb.D)
    sign = np.sign(np.polyfit(probe.q[:, iD], np.unwrap(rocker), 1)[0])

    def run():
        return _complete(openimp.sweep(s, drv, rates=rates, accels=accels))

    def outputs(res):
        qd = np.asarray(_find(res, _RATE_NAMES))
        qdd = np.asarray(_find(res, _ACCEL_NAMES))
        return {"rocker": _rocker_angle(res, fb.D), "rocker_rate": sign * qd[:, iD],
                "rocker_accel": sign * qdd[:, iD]}

    return CaseRun(run, outputs, postures=mx.NSTEPS)


def case_slider(ctx) -> CaseRun:
    sc = mx.SLIDER
    s = openimp.compile(slider_model(sc))
    drv = {"A": sc.crank_angles() - sc.theta0}

    def run():
        return _complete(openimp.sweep(s, drv))

    def outputs(res):
        return {"slider": res.point("SC")[:, 0], "P": res.point("P")[:, :2]}

    return CaseRun(run, outputs, postures=mx.NSTEPS)


def case_rssr(ctx) -> CaseRun:
    rs = mx.RSSR_MECH
    s = openimp.compile(rssr_model(rs))
    drv = {"A": rs.crank_angles() - rs.theta0}
    opts: dict = {}
    try:
        openimp.sweep(s, {"A": drv["A"][:2]})
    except Exception:  # the coupler's idle spin about B-C: hold it
        opts = {"hold_free": True}

    def run():
        return _complete(openimp.sweep(s, drv, **opts))

    def outputs(res):
        C = res.point("RC")
        D = np.asarray(rs.D)
        return {"rocker": np.arctan2(C[:, 2] - D[2], C[:, 1] - D[1]), "C": C}

    return CaseRun(run, outputs, postures=mx.NSTEPS,
                   note="hold_free=True" if opts else "")


def case_chain(ctx) -> CaseRun:
    ch = mx.CHAIN6R
    s = openimp.compile(chain_model(ch))
    q = ch.joint_values()
    drv = {f"J{i + 1}": q[:, i] for i in range(6)}

    def run():
        return _complete(openimp.sweep(s, drv))

    def outputs(res):
        return {"P": res.point("P")}

    return CaseRun(run, outputs, postures=mx.NSTEPS)


def _sweep_batch(systems, drvs):
    """All variants in one compiled, parallel call (openimp.kinematics.sweep_batch)."""
    from openimp.kinematics import sweep_batch

    batch = sweep_batch(systems, {"A": np.stack([d["A"] for d in drvs])})
    return [batch[v] for v in range(len(systems))]


def case_batch(ctx) -> CaseRun:
    variants = mx.fourbar_variants(ctx.nvariants)
    systems = [openimp.compile(fourbar_model(fb)) for fb in variants]
    drvs = [{"A": fb.crank_angles() - fb.theta0} for fb in variants]
    note = "openimp.kinematics.sweep_batch: one compiled call, parallel over variants"

    def run():
        return [_complete(r) for r in _sweep_batch(systems, drvs)]

    def outputs(results):
        return {"rocker": np.stack([_rocker_angle(r, fb.D) for r, fb in zip(results, variants)]),
                "P": np.stack([r.point("P")[:, :2] for r in results])}

    return CaseRun(run, outputs, postures=mx.NSTEPS * len(variants), note=note)


def case_million(ctx) -> CaseRun:
    """1e6 stored postures of the four-bar: every joint variable and one point."""
    fb = mx.FOURBAR
    s = openimp.compile(fourbar_model(fb))
    n = ctx.nmillion
    drv = {"A": np.radians(np.arange(n) * 0.36)}  # 0.36 deg steps: 1000 turns in 1e6 steps

    def run():
        res = _complete(openimp.sweep(s, drv))
        return res.q, res.point("P")

    def outputs(out):
        return {"P": out[1][:, :2]}

    return CaseRun(run, outputs, postures=n)


# ------------------------------------------------------------- force cases
def fourbar_dynamic_model(fd: mx.FourBarDynamics):
    """The four-bar of :func:`fourbar_model` with the masses of ``fd`` and gravity."""
    m = fourbar_model(fd.fb)
    for i, body in enumerate(fd.names):
        m.add_mass(body, fd.links[i].mass, tuple(float(x) for x in fd.centre0(i)),
                   fd.inertia0(i))
    m.set_gravity(tuple(float(x) for x in fd.gravity))
    return m


def _forces_api():
    if not hasattr(openimp, "forces"):
        raise NotAvailable("openimp.forces does not exist in this tree")


def case_fourbar_forces(ctx) -> CaseRun:
    """sweep(rates=, accels=) then forces(): the crank torque and every joint reaction.

    Timed alongside: the kinematic sweep with rates alone (the ``fourbar_rates``
    run on the same system) and forces() alone on a stored trajectory.
    """
    _forces_api()
    fd = mx.FOURBAR_DYN
    fb = fd.fb
    s = openimp.compile(fourbar_dynamic_model(fd))
    drv = {"A": fb.crank_angles() - fb.theta0}
    rates = {"A": np.full(mx.NSTEPS, mx.OMEGA)}
    accels = {"A": np.full(mx.NSTEPS, mx.ALPHA)}
    joints = ("A", "B", "C", "D")
    drive_key = "A.theta" if "A.theta" in s.var_names else "A"

    def kin():
        return _complete(openimp.sweep(s, drv, rates=rates, accels=accels))

    def run():  # one pass: each step's forces from the sweep's own elimination
        f = openimp.forces(s, drv, rates=rates, accels=accels)
        _complete(f.trajectory)
        return f

    def two_pass():
        return openimp.forces_of(kin())

    stored = kin()

    def forces_only():
        return openimp.forces_of(stored)

    def outputs(f):
        R = np.stack([f.reaction(j, "global")[:, [0, 1, 5]] for j in joints], axis=1)
        return {"tau": f.drive[drive_key], "R": R}

    return CaseRun(run, outputs, postures=mx.NSTEPS, variants=[
        Variant("kinematic", "kinematic sweep with rates only (fourbar_rates)", kin),
        Variant("two_pass", "sweep, then forces() of the stored trajectory", two_pass,
                outputs),
        Variant("forces_only", "forces() alone on a stored trajectory", forces_only, outputs),
    ])


def chain_dynamic_model(cd: mx.Chain6RDynamics):
    """The 6R chain of :func:`chain_model` with link masses, inertias and gravity."""
    m = chain_model(cd.chain)
    for i in range(6):
        m.add_mass(f"L{i + 1}", cd.masses[i], tuple(float(x) for x in cd.centres[i]),
                   cd.inertia(i))
    m.set_gravity(tuple(float(x) for x in cd.gravity))
    return m


def case_chain_dynamics(ctx) -> CaseRun:
    """Inverse dynamics of the 6R chain: sweep with the rates and accelerations of all six
    joints, then forces(reactions=False).  Timed alongside: the same with reactions,
    the kinematic sweep alone and forces() alone on a stored trajectory."""
    _forces_api()
    cd = mx.CHAIN6R_DYN
    s = openimp.compile(chain_dynamic_model(cd))
    _, q, qd, qdd = cd.motion()
    names = [f"J{i + 1}" for i in range(6)]
    drv = {j: q[:, i] for i, j in enumerate(names)}
    rates = {j: qd[:, i] for i, j in enumerate(names)}
    accels = {j: qdd[:, i] for i, j in enumerate(names)}
    keys = [f"{j}.theta" if f"{j}.theta" in s.var_names else j for j in names]

    def kin():
        return _complete(openimp.sweep(s, drv, rates=rates, accels=accels))

    def run():  # one pass
        f = openimp.forces(s, drv, rates=rates, accels=accels, reactions=False)
        _complete(f.trajectory)
        return f

    def run_reactions():
        f = openimp.forces(s, drv, rates=rates, accels=accels, reactions=True)
        _complete(f.trajectory)
        return f

    stored = kin()

    def forces_only():
        return openimp.forces_of(stored, reactions=False)

    def outputs(f):
        return {"tau": np.stack([f.drive[k] for k in keys], axis=1)}

    return CaseRun(run, outputs, postures=q.shape[0], variants=[
        Variant("reactions", "the same with reactions=True (all joint reactions)",
                run_reactions, outputs),
        Variant("kinematic", "kinematic sweep with rates only", kin),
        Variant("forces_only", "forces(reactions=False) alone on a stored trajectory",
                forces_only, outputs),
    ])


CASES = {
    "fourbar": case_fourbar,
    "fourbar_rates": case_fourbar_rates,
    "slider": case_slider,
    "rssr": case_rssr,
    "chain6r": case_chain,
    "batch": case_batch,
    "million": case_million,
    "fourbar_forces": case_fourbar_forces,
    "chain6r_dynamics": case_chain_dynamics,
}
