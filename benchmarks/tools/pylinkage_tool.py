"""pylinkage: planar dyad-by-dyad solver.

Two paths, chosen by ``ctx.extra["mode"]``:

* ``numba``: ``Linkage.step_fast`` / ``step_fast_with_kinematics`` (the whole
  sweep in one numba-compiled loop);
* ``python``: ``Linkage.step`` / ``step_with_derivatives`` run in a worker with
  ``NUMBA_DISABLE_JIT=1``, so pylinkage's ``@njit`` leaf solvers are plain Python.

The crank is a ``Crank`` turning 1 degree per step; pylinkage advances the
crank before it yields a posture, so the crank starts 1 step before theta0.
The rocker pin C is an ``RRRDyad`` (circle-circle intersection, nearest to the
previous posture); the coupler point P a ``FixedDyad`` on B->C.  The slider is
an ``RRPDyad`` on the line y = e.  pylinkage is planar only: no RSSR, no 6R chain.
"""

from __future__ import annotations

import numpy as np

from benchmarks import mechanisms as mx
from benchmarks.harness import CaseRun

NAME = "pylinkage"
STEP = np.radians(1.0)


def version() -> str:
    import pylinkage

    return pylinkage.__version__


def fourbar_linkage(fb: mx.FourBar):
    from pylinkage.actuators import Crank
    from pylinkage.components import Ground
    from pylinkage.dyads import FixedDyad, RRRDyad
    from pylinkage.simulation import Linkage

    A = Ground(*fb.A, name="A")
    D = Ground(*fb.D, name="D")
    crank = Crank(anchor=A, radius=fb.a, angular_velocity=STEP,
                  initial_angle=fb.theta0 - STEP, name="B")
    C = RRRDyad(crank.output, D, distance1=fb.b, distance2=fb.c,
                x=float(fb.C0[0]), y=float(fb.C0[1]), name="C")
    dist, ang = fb.p_local
    P = FixedDyad(crank.output, C, distance=dist, angle=ang, name="P")
    comps = [A, D, crank, C, P]
    lk = Linkage(comps, name="fourbar")
    return lk, crank, comps


def slider_linkage(sc: mx.SliderCrank):
    from pylinkage.actuators import Crank
    from pylinkage.components import Ground
    from pylinkage.dyads import FixedDyad, RRPDyad
    from pylinkage.simulation import Linkage

    A = Ground(0.0, 0.0, name="A")
    L1 = Ground(0.0, sc.e, name="L1")
    L2 = Ground(1.0, sc.e, name="L2")
    crank = Crank(anchor=A, radius=sc.a, angular_velocity=STEP,
                  initial_angle=sc.theta0 - STEP, name="B")
    C = RRPDyad(crank.output, L1, L2, distance=sc.b, x=float(sc.C0[0]), y=float(sc.C0[1]),
                name="C")
    dist, ang = sc.p_local
    P = FixedDyad(crank.output, C, distance=dist, angle=ang, name="P")
    comps = [A, L1, L2, crank, C, P]
    return Linkage(comps, name="slider"), crank, comps


def _runner(lk, comps, mode: str, n: int):
    """Sweep from the stored start every time (positions are restored first)."""
    start = [c.position for c in comps]

    if mode == "numba":
        lk.compile()

        def run():
            lk.set_coords(start)
            return lk.step_fast(iterations=n)
    else:
        def run():
            lk.set_coords(start)
            return np.array(list(lk.step(iterations=n)), dtype=float)

    return run


def case_fourbar(ctx) -> CaseRun:
    fb = mx.FOURBAR
    lk, _, comps = fourbar_linkage(fb)
    run = _runner(lk, comps, ctx.extra["mode"], mx.NSTEPS)

    def outputs(traj):
        C, P = traj[:, 3], traj[:, 4]
        return {"rocker": np.arctan2(C[:, 1] - fb.D[1], C[:, 0] - fb.D[0]), "P": P}

    return CaseRun(run, outputs, postures=mx.NSTEPS)


def case_fourbar_rates(ctx) -> CaseRun:
    fb = mx.FOURBAR
    lk, crank, comps = fourbar_linkage(fb)
    lk.set_input_velocity(crank, omega=mx.OMEGA, alpha=mx.ALPHA)
    start = [c.position for c in comps]
    n = mx.NSTEPS
    if ctx.extra["mode"] == "numba":
        lk.compile()

        def run():
            lk.set_coords(start)
            return lk.step_fast_with_kinematics(iterations=n)
    else:
        def run():
            lk.set_coords(start)
            pos, vel, acc = [], [], []
            for p, v, a in lk.step_with_derivatives(iterations=n):
                pos.append(p)
                vel.append(v)
                acc.append(a)
            return (np.array(pos, float), np.array(vel, float), np.array(acc, float))

    def outputs(res):
        pos, vel, acc = (np.asarray(x, float) for x in res)
        r = pos[:, 3] - fb.D
        c2 = np.sum(r * r, axis=1)
        w = (r[:, 0] * vel[:, 3, 1] - r[:, 1] * vel[:, 3, 0]) / c2
        al = (r[:, 0] * acc[:, 3, 1] - r[:, 1] * acc[:, 3, 0]) / c2
        return {"rocker": np.arctan2(r[:, 1], r[:, 0]), "rocker_rate": w, "rocker_accel": al}

    return CaseRun(run, outputs, postures=n)


def case_slider(ctx) -> CaseRun:
    sc = mx.SLIDER
    lk, _, comps = slider_linkage(sc)
    run = _runner(lk, comps, ctx.extra["mode"], mx.NSTEPS)

    def outputs(traj):
        return {"slider": traj[:, 4, 0], "P": traj[:, 5]}

    return CaseRun(run, outputs, postures=mx.NSTEPS)


def case_batch(ctx) -> CaseRun:
    variants = mx.fourbar_variants(ctx.nvariants)
    runs = []
    for fb in variants:
        lk, _, comps = fourbar_linkage(fb)
        runs.append(_runner(lk, comps, ctx.extra["mode"], mx.NSTEPS))

    def run():
        return [r() for r in runs]

    def outputs(trajs):
        C = np.stack([t[:, 3] for t in trajs])
        return {"rocker": np.stack([np.arctan2(c[:, 1] - fb.D[1], c[:, 0] - fb.D[0])
                                    for c, fb in zip(C, variants)]),
                "P": np.stack([t[:, 4] for t in trajs])}

    note = f"{len(variants)} of 1000 variants" if len(variants) < 1000 else ""
    return CaseRun(run, outputs, postures=mx.NSTEPS * len(variants), note=note)


def case_million(ctx) -> CaseRun:
    if ctx.extra["mode"] != "numba":
        from benchmarks.harness import NotAvailable

        raise NotAvailable("pure-Python path not run for 1e6 postures (minutes)")
    fb = mx.FOURBAR
    from pylinkage.actuators import Crank

    lk, crank, comps = fourbar_linkage(fb)
    assert isinstance(crank, Crank)
    step = np.radians(0.36)
    crank.angular_velocity = step
    crank.set_coord(fb.a * np.cos(fb.theta0 - step), fb.a * np.sin(fb.theta0 - step))
    n = ctx.nmillion
    run = _runner(lk, comps, "numba", n)

    def outputs(traj):
        return {"P": traj[:, 4]}

    return CaseRun(run, outputs, postures=n, note="trajectory of every joint (x, y)")


UNSUPPORTED = {
    "rssr": "planar only: pylinkage solves 2D dyads, no spherical joints",
    "chain6r": "planar closed-loop dyads only: no spatial serial chain",
    "fourbar_forces": "kinematics only: no masses, no force analysis",
    "chain6r_dynamics": "planar closed-loop dyads only: no spatial serial chain, no dynamics",
}

CASES = {
    "fourbar": case_fourbar,
    "fourbar_rates": case_fourbar_rates,
    "slider": case_slider,
    "batch": case_batch,
    "million": case_million,
}
