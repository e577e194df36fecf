"""Exudyn: planar rigid bodies and joints, swept by the static solver's load steps.

Each link is an ``ObjectRigidBody2D`` (its reference posture is the modeling
posture); the pins are ``RevoluteJoint2D``, the slider a ``PrismaticJoint2D``.
The crank is driven by a ``CoordinateConstraint`` on its rotation coordinate
whose offset is set, once per load step, by a pre-step user function to the
step's crank increment.  ``SolveStatic`` with 359 load steps then solves every
posture by Newton's method (the constraint Jacobian is square: no loads needed);
the sensors, stored internally, record the initial posture and the 359 steps.
Exudyn computes no velocities or accelerations in static mode, and the 3D
RSSR / 6R chain would need a different (3D) model: not done.
"""

from __future__ import annotations

import numpy as np

from benchmarks import mechanisms as mx
from benchmarks.harness import CaseRun

NAME = "exudyn"


def version() -> str:
    import exudyn

    return exudyn.__version__


def _settings(nsteps: int):
    import exudyn as exu

    ss = exu.SimulationSettings()
    ss.staticSolver.numberOfLoadSteps = nsteps - 1
    ss.staticSolver.loadStepDuration = 1.0
    ss.staticSolver.verboseMode = 0
    ss.staticSolver.newton.relativeTolerance = 1e-10
    ss.staticSolver.newton.absoluteTolerance = 1e-12
    ss.solution.file.write = False
    ss.solution.sensors.writePeriod = 0.0
    ss.show.computationTime = False
    ss.show.statistics = False
    return ss


class _Planar:
    """Small builder for planar rigid-body mechanisms in one Exudyn system."""

    def __init__(self):
        import exudyn as exu
        from exudyn import itemInterface as ii  # noqa: N813

        self.exu, self.ii = exu, ii
        self.SC = exu.SystemContainer()
        self.mbs = self.SC.AddSystem()
        self.ground = self.mbs.AddObject(ii.ObjectGround())

    def body(self, centre) -> tuple[int, int, np.ndarray]:
        ii = self.ii
        c = np.asarray(centre, float)
        n = self.mbs.AddNode(ii.NodeRigidBody2D(referenceCoordinates=[c[0], c[1], 0.0],
                                                initialCoordinates=[0.0, 0.0, 0.0]))
        o = self.mbs.AddObject(ii.ObjectRigidBody2D(nodeNumber=n, mass=1.0, inertia=0.1))
        return n, o, c

    def marker(self, body, p, rigid: bool = False) -> int:
        o, c = (self.ground, np.zeros(2)) if body is None else (body[1], body[2])
        p = np.asarray(p, float) - c
        kind = self.ii.MarkerBodyRigid if rigid else self.ii.MarkerBodyPosition
        return self.mbs.AddMarker(kind(bodyNumber=o, localPosition=[p[0], p[1], 0.0]))

    def pin(self, b1, b2, p) -> None:
        self.mbs.AddObject(self.ii.RevoluteJoint2D(markerNumbers=[self.marker(b1, p),
                                                                  self.marker(b2, p)]))

    def drive(self, crank, increments: np.ndarray):
        """Crank rotation = increments[k] at load step k (pre-step user function)."""
        ii, mbs = self.ii, self.mbs
        ng = mbs.AddNode(ii.NodePointGround())
        mg = mbs.AddMarker(ii.MarkerNodeCoordinate(nodeNumber=ng, coordinate=0))
        mc = mbs.AddMarker(ii.MarkerNodeCoordinate(nodeNumber=crank[0], coordinate=2))
        cc = mbs.AddObject(ii.CoordinateConstraint(markerNumbers=[mg, mc], offset=0.0))
        n = len(increments) - 1
        inc = [float(v) for v in increments]

        def pre_step(mbs, t):
            mbs.SetObjectParameter(cc, "offset", inc[round(t * n)])
            return True

        mbs.SetPreStepUserFunction(pre_step)

    def sensor(self, body, p) -> int:
        c = body[2]
        return self.mbs.AddSensor(self.ii.SensorBody(
            bodyNumber=body[1], localPosition=[p[0] - c[0], p[1] - c[1], 0.0],
            outputVariableType=self.exu.OutputVariableType.Position, storeInternal=True))


def fourbar_system(fb: mx.FourBar):
    pl = _Planar()
    A, B, C, D, P = fb.A, fb.B0, fb.C0, fb.D, fb.P0
    crank, coupler, rocker = pl.body((A + B) / 2), pl.body((B + C) / 2), pl.body((C + D) / 2)
    pl.pin(None, crank, A)
    pl.pin(crank, coupler, B)
    pl.pin(coupler, rocker, C)
    pl.pin(rocker, None, D)
    pl.drive(crank, fb.crank_angles() - fb.theta0)
    sC = pl.sensor(rocker, C)
    sP = pl.sensor(coupler, P)
    pl.mbs.Assemble()
    return pl, sC, sP


def _solver(pl, sensors, nsteps: int):
    exu = pl.exu
    ss = _settings(nsteps)

    def run():
        ok = exu.SolveStatic(pl.mbs, ss)
        if not ok:
            raise RuntimeError("Exudyn SolveStatic failed")
        return [pl.mbs.GetSensorStoredData(s)[:, 1:3].copy() for s in sensors]

    return run


def case_fourbar(ctx) -> CaseRun:
    fb = mx.FOURBAR
    pl, sC, sP = fourbar_system(fb)
    run = _solver(pl, [sC, sP], mx.NSTEPS)

    def outputs(res):
        C, P = res
        return {"rocker": np.arctan2(C[:, 1] - fb.D[1], C[:, 0] - fb.D[0]), "P": P}

    return CaseRun(run, outputs, postures=mx.NSTEPS)


def case_slider(ctx) -> CaseRun:
    sc = mx.SLIDER
    pl = _Planar()
    ii = pl.ii
    A, B, C, P = np.zeros(2), sc.B0, sc.C0, sc.P0
    crank, rod, slider = pl.body((A + B) / 2), pl.body((B + C) / 2), pl.body(C)
    pl.pin(None, crank, A)
    pl.pin(crank, rod, B)
    pl.pin(rod, slider, C)
    pl.mbs.AddObject(ii.PrismaticJoint2D(markerNumbers=[pl.marker(None, C, True),
                                                         pl.marker(slider, C, True)],
                                         axisMarker0=[1.0, 0.0, 0.0],
                                         normalMarker1=[0.0, 1.0, 0.0], constrainRotation=True))
    pl.drive(crank, sc.crank_angles() - sc.theta0)
    sS = pl.sensor(slider, C)
    sP = pl.sensor(rod, P)
    pl.mbs.Assemble()
    run = _solver(pl, [sS, sP], mx.NSTEPS)

    def outputs(res):
        S, P = res
        return {"slider": S[:, 0], "P": P}

    return CaseRun(run, outputs, postures=mx.NSTEPS)


def case_batch(ctx) -> CaseRun:
    variants = mx.fourbar_variants(ctx.nvariants)
    runs = []
    for fb in variants:
        pl, sC, sP = fourbar_system(fb)
        runs.append(_solver(pl, [sC, sP], mx.NSTEPS))

    def run():
        return [r() for r in runs]

    def outputs(res):
        return {"rocker": np.stack([np.arctan2(C[:, 1] - fb.D[1], C[:, 0] - fb.D[0])
                                    for (C, _), fb in zip(res, variants)]),
                "P": np.stack([P for _, P in res])}

    return CaseRun(run, outputs, postures=mx.NSTEPS * len(variants),
                   note=f"{len(variants)} of 1000 variants")


UNSUPPORTED = {
    "fourbar_rates": "the static solver gives positions only (no velocity/acceleration analysis)",
    "rssr": "not modelled: needs 3D bodies with spherical joints, and the coupler's idle spin "
            "leaves the static Jacobian singular without an extra constraint",
    "chain6r": "not modelled: open-chain forward kinematics is not a static load-step problem "
               "(Exudyn's KinematicTree would do it)",
    "fourbar_forces": "not modelled: the static load-step model has no prescribed rates "
                      "and accelerations",
    "chain6r_dynamics": "not modelled (Exudyn's KinematicTree has inverse dynamics; not "
                        "wired into this benchmark)",
}

CASES = {"fourbar": case_fourbar, "slider": case_slider, "batch": case_batch}
