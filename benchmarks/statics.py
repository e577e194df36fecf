"""Static equilibrium: ``openimp.equilibrium`` against Exudyn's static solver and scipy.

    python -m benchmarks.statics                # seconds (~3 min when numba compiles); updates
                                                # results.md's section and results.json
    python -m benchmarks.statics --repeats 50 --no-write
    python -m benchmarks.statics --profile      # cProfile of openimp's solves, printed only

Cases (SI units; every tool starts from the same posture, the modeling posture, and must
find the same equilibrium):

* ``fourbar``: the four-bar of case (a) with the masses and gravity of
  :data:`benchmarks.mechanisms.FOURBAR_DYN`, and a linear spring (k = 40 N/m, free length
  1 m) from the coupler point P to the ground point (2.5, 4.5); crank free (1 FGC).
  From the modeling posture (crank 40 deg) the one stable equilibrium of the crank turn
  is at about 58 deg (the potential over the turn, closed form, has one minimum).
* ``quarter_car``: a spatial double-wishbone corner, chassis held: lower and upper
  arms on revolutes whose axes are neither parallel nor on the chassis axes, the
  upright on a ball joint at each arm, steering held by a massless tie rod from the
  chassis to the upright (a universal joint at the chassis, a ball at the upright:
  no idle spin), a spring-damper strut (60 kN/m, 3 kN s/m) from the chassis to the
  lower arm, gravity on the arms and the upright + wheel (4, 2.5 and 25 kg) and the
  wheel load (3.5 kN up at the tyre contact point); 1 FGC.

Tools (each in its own process, ``--worker TOOL``):

* openimp: ``openimp.equilibrium(system, forces=False)`` (timed), also with
  ``forces=True`` (the force analysis at the equilibrium: joint reactions and element
  forces); for the quarter car also the tie rod as a ball-ball link (its idle spin is a
  neutral freedom of the search);
* Exudyn: the equivalent multibody model (``ObjectRigidBody2D`` with ``RevoluteJoint2D``
  for the four-bar, built by :class:`benchmarks.vibration.ExudynFourBar`; rigid bodies
  with Euler parameters, ``CreateRevoluteJoint``/``CreateSphericalJoint``, the tie rod a
  ``CreateDistanceConstraint``, the strut ``CreateSpringDamper``, the wheel load
  ``CreateForce`` for the quarter car), solved by ``exu.SolveStatic`` from the modeling
  posture, one load step, Newton tolerances 1e-10; iterations from the stored solver.
  Its Newton matrix leaves out the constraint forces' geometric stiffness (lambda^T
  d2C/dq2; the Jacobian's rotation rows do not change with the multipliers, see
  ``staticSolver.verboseMode = 4``): it converges linearly on the quarter car, where the
  strut dominates, and not at all on the four-bar, where gravity and the soft spring
  act through the pins.  For the four-bar it is also started at the closed-form
  equilibrium (the models agree when it stays there), and timed with the pins as stiff
  penalty springs (``CartesianSpringDamper``, :data:`PENALTY`), which it does solve;
* scipy: ``scipy.optimize.minimize(V, x0, method="BFGS")`` of the potential energy V in
  the minimal coordinate (crank angle; lower-arm angle), the loops closed by hand
  (numpy / Python scalars: circle intersection; for the quarter car the upper-arm
  angle from the ball-joint distance and the upright from three spheres), complex-safe
  so that the gradient is a
  complex step (``jac="cs"``, exact to rounding); also with scipy's default 2-point
  finite-difference gradient and default ``gtol`` (what a user gets without more work).

Timed: one solve from the start posture (openimp: the whole ``equilibrium`` call with its
result; Exudyn: setting the initial coordinates and ``SolveStatic``; scipy:
``minimize``), after a warm-up solve (compilation excluded), median (best) of
``--repeats``.  Compared: link angles and point coordinates of every tool's equilibrium
against openimp's.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import time
from pathlib import Path
from typing import ClassVar

import numpy as np

from benchmarks import mechanisms as mx
from benchmarks import vibration as vib

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
TITLE = "## Static equilibrium"
CASES = ("fourbar", "quarter_car")
TOOLS = ("openimp", "exudyn", "scipy")
CASE_TITLES = {
    "fourbar": "four-bar (case (a), FOURBAR_DYN masses, gravity) with a spring from the "
               "coupler point P to ground; 1 FGC",
    "quarter_car": "spatial double-wishbone quarter car (chassis held): strut spring, "
                   "gravity, 3.5 kN wheel load; 1 FGC",
}
G = mx.G_STD

# ------------------------------------------------------------------ four-bar data
FB_ANCHOR = np.array([2.5, 4.5])  # ground end of the spring
FB_K = 40.0  # N/m
FB_FREE = 1.0  # m


# ------------------------------------------------------------------ quarter-car data
class QuarterCar:
    """Geometry and loads of the double-wishbone corner (global x forward, y outboard,
    z up; m, kg, N), at the modeling posture."""

    LA_P = np.array([0.0, 0.30, 0.20])  # lower arm: a point of its chassis axis
    LA_A = np.array([1.0, 0.0, 0.06])  # ... and the axis (anti-dive)
    UA_P = np.array([0.0, 0.42, 0.52])  # upper arm
    UA_A = np.array([1.0, 0.12, -0.05])
    LBJ = np.array([0.0, 0.76, 0.14])  # lower ball joint
    UBJ = np.array([0.02, 0.70, 0.56])  # upper ball joint
    TRC = np.array([-0.16, 0.36, 0.30])  # tie rod, chassis end (universal joint)
    TRU = np.array([-0.15, 0.73, 0.31])  # tie rod, upright end (ball)
    WC = np.array([0.0, 0.84, 0.32])  # wheel centre
    CP = np.array([0.0, 0.86, 0.0])  # tyre contact point (on the upright)
    SPT = np.array([0.0, 0.52, 0.85])  # strut top (chassis)
    SPB = np.array([0.0, 0.58, 0.17])  # strut bottom (lower arm)
    K = 60000.0  # N/m
    C = 3000.0  # N s/m (no effect on the equilibrium)
    PRELOAD = 0.08  # m: free length = length at the modeling posture + this
    WHEEL_LOAD = 3500.0  # N, up at CP
    MASSES: ClassVar[dict] = {  # body: (mass, centre, principal moments, global axes)
        "LOWER": (4.0, (LA_P + LBJ) / 2, (0.02, 0.08, 0.09)),
        "UPPER": (2.5, (UA_P + UBJ) / 2, (0.01, 0.04, 0.045)),
        "UPRIGHT": (25.0, 0.8 * WC + 0.1 * (LBJ + UBJ), (0.9, 1.3, 0.9)),
    }
    #: points compared between the tools (all on the upright but SPB)
    POINTS = ("LBJ", "UBJ", "TRU", "CP")

    def __init__(self) -> None:
        self.LA_A = self.LA_A / np.linalg.norm(self.LA_A)
        self.UA_A = self.UA_A / np.linalg.norm(self.UA_A)
        self.free_length = float(np.linalg.norm(self.SPT - self.SPB)) + self.PRELOAD


QC = QuarterCar()


def _t(v) -> tuple[float, float, float]:
    v = np.asarray(v, float)
    return (float(v[0]), float(v[1]), float(v[2]) if v.size > 2 else 0.0)


def angle_about(axis_p, axis_a, p0, p) -> np.ndarray:
    """Rotation (rad) about the axis (point, unit direction) taking p0 to p."""
    a = np.asarray(axis_a, float)
    r0 = np.asarray(p0, float) - axis_p
    r0 = r0 - a * (r0 @ a)
    r = np.asarray(p, float) - axis_p
    r = r - a * (r @ a)
    return np.arctan2(np.cross(r0, r) @ a, r0 @ r)


def fourbar_outputs(B, C, P) -> dict:
    """The compared quantities of a four-bar posture: link angles (crank A->B, coupler
    B->C, rocker D->C) and the coupler point P."""
    fb = mx.FOURBAR
    B, C, P = (np.asarray(x, float)[:2] for x in (B, C, P))
    ang = [np.arctan2(*(B - fb.A)[::-1]), np.arctan2(*(C - B)[::-1]),
           np.arctan2(*(C - fb.D)[::-1])]
    return {"crank": float(ang[0]), "coupler": float(ang[1]), "rocker": float(ang[2]),
            "P": P.tolist()}


def quarter_car_outputs(pts: dict) -> dict:
    """The compared quantities of a quarter-car posture: the arm angles (from their ball
    joints), the upright's points and the strut length."""
    q = QC
    out = {"lower arm": float(angle_about(q.LA_P, q.LA_A, q.LBJ, pts["LBJ"])),
           "upper arm": float(angle_about(q.UA_P, q.UA_A, q.UBJ, pts["UBJ"]))}
    for k in q.POINTS:
        out[k] = np.asarray(pts[k], float).tolist()
    out["strut"] = float(np.linalg.norm(q.SPT - np.asarray(pts["SPB"], float)))
    return out


# ------------------------------------------------------------------ openimp models
def openimp_fourbar():
    from benchmarks.tools.openimp_tool import _xyz, fourbar_dynamic_model

    fb = mx.FOURBAR
    m = fourbar_dynamic_model(mx.FOURBAR_DYN)
    m.add_point("ANCHOR", "BASE", _xyz(FB_ANCHOR))
    m.add_point("CB", "CRANK", _xyz(fb.B0))  # for the compared link angles
    m.add_spring("SPRING", "P", "ANCHOR", FB_K, FB_FREE)
    return m


def openimp_quarter_car(tie_rod: str = "universal"):
    """The quarter car; ``tie_rod`` "universal" (a cross body and two revolutes at the
    chassis) or "ball" (balls at both ends: an idle spin)."""
    import openimp

    q = QC
    m = openimp.Model("quarter-car")
    m.add_joint("revolute", "LA", "CHASSIS", "LOWER", origin=_t(q.LA_P), axis=_t(q.LA_A))
    m.add_joint("revolute", "UA", "CHASSIS", "UPPER", origin=_t(q.UA_P), axis=_t(q.UA_A))
    m.add_joint("sphere", "LB", "LOWER", "UPRIGHT", origin=_t(q.LBJ))
    m.add_joint("sphere", "UB", "UPPER", "UPRIGHT", origin=_t(q.UBJ))
    if tie_rod == "ball":
        m.add_joint("sphere", "TC", "CHASSIS", "TIEROD", origin=_t(q.TRC))
    else:
        d = (q.TRU - q.TRC) / np.linalg.norm(q.TRU - q.TRC)
        a1 = np.array([0.0, 0.0, 1.0])
        a2 = np.cross(d, a1)
        m.add_joint("revolute", "TC", "CHASSIS", "CROSS", origin=_t(q.TRC), axis=_t(a1))
        m.add_joint("revolute", "TX", "CROSS", "TIEROD", origin=_t(q.TRC),
                    axis=_t(a2 / np.linalg.norm(a2)))
    m.add_joint("sphere", "TU", "TIEROD", "UPRIGHT", origin=_t(q.TRU))
    m.set_ground("CHASSIS")
    for body, (mass, c, inertia) in q.MASSES.items():
        m.add_mass(body, mass, _t(c), inertia)
    m.set_gravity((0.0, 0.0, -G))
    for name, body in (("SPT", "CHASSIS"), ("SPB", "LOWER"), ("LBJ", "UPRIGHT"),
                       ("UBJ", "UPRIGHT"), ("TRU", "UPRIGHT"), ("CP", "UPRIGHT")):
        m.add_point(name, body, _t(getattr(q, name)))
    m.add_spring("SPRING", "SPT", "SPB", q.K, q.free_length)
    m.add_damper("DAMPER", "SPT", "SPB", q.C)
    m.add_force("WHEEL", "CP", q.WHEEL_LOAD, direction=(0.0, 0.0, 1.0))
    return m


def openimp_outputs(case: str, eq) -> dict:
    tr = eq.trajectory
    if case == "fourbar":
        return fourbar_outputs(tr.point("CB")[0], tr.point("RC")[0], tr.point("P")[0])
    return quarter_car_outputs({k: tr.point(k)[0] for k in (*QC.POINTS, "SPB")})


# ------------------------------------------------------------------ Exudyn models
class ExudynStatic:
    """An Exudyn model of a case, solved by ``exu.SolveStatic`` from the modeling
    posture."""

    def __init__(self, case: str, penalty: float | None = None):
        import exudyn as exu

        self.exu, self.case = exu, case
        if case == "fourbar":
            self._fourbar(penalty)
        else:
            self._quarter_car()
        ss = self.ss = exu.SimulationSettings()
        ss.staticSolver.verboseMode = 0
        ss.staticSolver.numberOfLoadSteps = 1
        ss.staticSolver.newton.relativeTolerance = 1e-10
        ss.staticSolver.newton.absoluteTolerance = 1e-10
        ss.solution.file.write = False
        ss.solution.sensors.writePeriod = 0.0
        self.q0 = self.mbs.systemData.GetODE2Coordinates(
            configuration=exu.ConfigurationType.Initial).copy()

    def _fourbar(self, penalty: float | None) -> None:
        """:class:`benchmarks.vibration.ExudynFourBar` (case ``rigid_g``: gravity), its
        crank spring set to 0, and the P spring; with ``penalty`` (N/m) every
        ``RevoluteJoint2D`` is switched off and its two markers joined by a
        ``CartesianSpringDamper`` of that stiffness instead."""
        from exudyn import itemInterface as ii  # noqa: N813

        model = self.fourbar_model = vib.ExudynFourBar("rigid_g")
        mbs = self.mbs = model.mbs
        if penalty is not None:
            for i in range(mbs.systemData.NumberOfObjects()):
                o = mbs.GetObject(i)
                if o["objectType"] == "JointRevolute2D":
                    mbs.SetObjectParameter(i, "activeConnector", False)
                    mbs.AddObject(ii.ObjectConnectorCartesianSpringDamper(
                        markerNumbers=o["markerNumbers"], stiffness=[penalty] * 3,
                        damping=[0.0] * 3))
        mbs.SetObjectParameter(model.crank, "stiffness", 0.0)
        self.bodies = [i for i in range(mbs.systemData.NumberOfObjects())
                       if mbs.GetObject(i)["objectType"] == "RigidBody2D"]
        self.G0 = model.G0  # centres (node reference positions) of crank, coupler, rocker
        fb = mx.FOURBAR
        ground = next(i for i in range(mbs.systemData.NumberOfObjects())
                      if mbs.GetObject(i)["objectType"] == "Ground")
        mg = mbs.AddMarker(ii.MarkerBodyPosition(bodyNumber=ground,
                                                 localPosition=list(_t(FB_ANCHOR))))
        self.local = {"B": _t(fb.B0 - self.G0[0]), "P": _t(fb.P0 - self.G0[1]),
                      "C": _t(fb.C0 - self.G0[2])}
        mp = mbs.AddMarker(ii.MarkerBodyPosition(bodyNumber=self.bodies[1],
                                                 localPosition=list(self.local["P"])))
        mbs.AddObject(ii.ObjectConnectorSpringDamper(markerNumbers=[mg, mp], stiffness=FB_K,
                                                     referenceLength=FB_FREE, damping=0.0))
        mbs.Assemble()

    def _quarter_car(self) -> None:
        import exudyn as exu
        from exudyn.utilities import RigidBodyInertia

        q = QC
        SC = self.SC = exu.SystemContainer()
        mbs = self.mbs = SC.AddSystem()
        ground = mbs.CreateGround()
        self.G0, body = {}, {}
        for name, (mass, c, inertia) in q.MASSES.items():
            self.G0[name] = np.asarray(c, float)
            body[name] = mbs.CreateRigidBody(
                inertia=RigidBodyInertia(mass=mass, inertiaTensor=np.diag(inertia)),
                referencePosition=list(c), referenceRotationMatrix=np.eye(3),
                gravity=[0.0, 0.0, -G], nodeType=exu.NodeType.RotationEulerParameters)
        self.body = body
        mbs.CreateRevoluteJoint(itemNumbers=[ground, body["LOWER"]], position=list(q.LA_P),
                                axis=list(q.LA_A), useGlobalFrame=True, show=False)
        mbs.CreateRevoluteJoint(itemNumbers=[ground, body["UPPER"]], position=list(q.UA_P),
                                axis=list(q.UA_A), useGlobalFrame=True, show=False)
        mbs.CreateSphericalJoint(itemNumbers=[body["LOWER"], body["UPRIGHT"]],
                                 position=list(q.LBJ), useGlobalFrame=True, show=False)
        mbs.CreateSphericalJoint(itemNumbers=[body["UPPER"], body["UPRIGHT"]],
                                 position=list(q.UBJ), useGlobalFrame=True, show=False)
        up = self.G0["UPRIGHT"]
        mbs.CreateDistanceConstraint(itemNumbers=[ground, body["UPRIGHT"]],
                                     localPosition0=list(q.TRC),
                                     localPosition1=list(q.TRU - up), show=False)
        mbs.CreateSpringDamper(itemNumbers=[ground, body["LOWER"]], localPosition0=list(q.SPT),
                               localPosition1=list(q.SPB - self.G0["LOWER"]),
                               referenceLength=q.free_length, stiffness=q.K, damping=q.C,
                               show=False)
        mbs.CreateForce(itemNumber=body["UPRIGHT"], loadVector=[0.0, 0.0, q.WHEEL_LOAD],
                        localPosition=list(q.CP - up), show=False)
        mbs.Assemble()

    def solve(self, q0: np.ndarray | None = None) -> bool:
        """SolveStatic from q0 (default the modeling posture); False when it fails."""
        exu = self.exu
        self.mbs.systemData.SetODE2Coordinates(self.q0 if q0 is None else q0,
                                               configuration=exu.ConfigurationType.Initial)
        try:
            return bool(exu.SolveStatic(self.mbs, self.ss))
        except Exception:  # exu raises on a failed solve
            return False

    def fourbar_coordinates(self, theta: float) -> np.ndarray:
        """ODE2 coordinates of the four-bar at the absolute crank angle theta."""
        fb = mx.FOURBAR
        th = np.array([theta])
        km = fb.link_motion(th, 1.0, 0.0)
        return self.fourbar_model.coordinates(theta, km["th"][0], fb.B_at(th)[0])

    def _position(self, body: int, local) -> np.ndarray:
        return np.asarray(self.mbs.GetObjectOutputBody(
            body, self.exu.OutputVariableType.Position, localPosition=list(local),
            configuration=self.exu.ConfigurationType.Current), float)

    def outputs(self) -> dict:
        if self.case == "fourbar":
            b = self.bodies
            return fourbar_outputs(self._position(b[0], self.local["B"]),
                                   self._position(b[2], self.local["C"]),
                                   self._position(b[1], self.local["P"]))
        q, up = QC, self.G0["UPRIGHT"]
        pts = {k: self._position(self.body["UPRIGHT"], getattr(q, k) - up) for k in q.POINTS}
        pts["SPB"] = self._position(self.body["LOWER"], q.SPB - self.G0["LOWER"])
        return quarter_car_outputs(pts)

    def iterations(self) -> dict:
        it = self.mbs.sys["staticSolver"].it
        return {"newton": int(it.newtonStepsCount), "jacobians": int(it.newtonJacobiCount),
                "load_steps": int(self.ss.staticSolver.numberOfLoadSteps)}


# ------------------------------------------------------------------ scipy: minimal coordinates
# Vectors of the quarter car's closure are 3-tuples of Python scalars (float, or complex
# under the complex step): a few hundred scalar operations per energy, no small arrays.
def _add(a, b):
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


def _sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def _mul(k, a):
    return (k * a[0], k * a[1], k * a[2])


def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _norm(a):  # complex-safe (no abs)
    return _dot(a, a) ** 0.5


def _cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _rotate(p, a, c, s, x):
    """x turned about the axis (point p, unit a) by the angle of cosine c, sine s."""
    v = _sub(x, p)
    return _add(_add(p, _mul(c, v)), _add(_mul(s, _cross(a, v)), _mul((1.0 - c) * _dot(a, v), a)))


def _vec(v) -> tuple:
    return tuple(float(x) for x in v)


class FourBarEnergy:
    """V(theta): gravity + P spring, theta the absolute crank angle; closure by the circle
    intersection (complex-safe: a complex step gives the exact derivative)."""

    def __init__(self) -> None:
        fd = mx.FOURBAR_DYN
        self.fb = fd.fb
        self.links = fd.links
        self.dist, self.ang = self.fb.p_local

    def posture(self, th):
        fb = self.fb
        B = np.array([fb.a * np.cos(th), fb.a * np.sin(th)])
        d = fb.D - B
        L = np.sqrt(d[0] * d[0] + d[1] * d[1])
        ex = d / L
        ey = np.array([-ex[1], ex[0]])
        x = (fb.b * fb.b - fb.c * fb.c + L * L) / (2 * L)
        C = B + x * ex + np.sqrt(fb.b * fb.b - x * x) * ey  # upper branch (+1)
        return B, C

    def energy(self, x) -> complex | float:
        th = x[0]
        fb = self.fb
        B, C = self.posture(th)
        u = (C - B) / fb.b  # coupler direction
        r = (C - fb.D) / fb.c  # rocker direction
        frames = [(fb.A, np.array([np.cos(th), np.sin(th)])), (B, u), (fb.D, r)]
        V = 0.0
        for (o, e), lk in zip(frames, self.links):
            y = o[1] + e[1] * lk.centre[0] + e[0] * lk.centre[1]
            V = V + lk.mass * G * y
        ca, sa = np.cos(self.ang), np.sin(self.ang)
        P = B + self.dist * np.array([u[0] * ca - u[1] * sa, u[0] * sa + u[1] * ca])
        d = P - FB_ANCHOR
        ell = np.sqrt(d[0] * d[0] + d[1] * d[1])
        return V + 0.5 * FB_K * (ell - FB_FREE) ** 2

    def x0(self) -> np.ndarray:
        return np.array([self.fb.theta0])

    def outputs(self, x) -> dict:
        B, C = self.posture(float(x[0]))
        fb = self.fb
        u = (C - B) / fb.b
        ca, sa = np.cos(self.ang), np.sin(self.ang)
        P = B + self.dist * np.array([u[0] * ca - u[1] * sa, u[0] * sa + u[1] * ca])
        return fourbar_outputs(B, C, P)


class QuarterCarEnergy:
    """V(phi): phi the lower arm's angle about its axis from the modeling posture.  The
    upper arm's angle from |UBJ - LBJ| (its tangent half-angle: a quadratic), the tie-rod
    end TRU from three spheres (about LBJ, UBJ, TRC), the upright's frame from LBJ, UBJ,
    TRU (its points by their constant coordinates in that frame); complex-safe."""

    def __init__(self) -> None:
        q = QC
        self.LA_P, self.LA_A, self.UA_P, self.UA_A = map(_vec, (q.LA_P, q.LA_A, q.UA_P,
                                                                 q.UA_A))
        self.LBJ, self.TRC, self.SPT, self.SPB = map(_vec, (q.LBJ, q.TRC, q.SPT, q.SPB))
        self.dUL2 = float(np.sum((q.UBJ - q.LBJ) ** 2))
        cU = q.UA_P + q.UA_A * ((q.UBJ - q.UA_P) @ q.UA_A)
        self.rU = float(np.linalg.norm(q.UBJ - cU))
        e1 = (q.UBJ - cU) / self.rU
        self.cU, self.e1, self.e2 = _vec(cU), _vec(e1), _vec(np.cross(q.UA_A, e1))
        self.r1 = float(np.linalg.norm(q.TRU - q.LBJ))
        self.r2 = float(np.linalg.norm(q.TRU - q.UBJ))
        self.r3 = float(np.linalg.norm(q.TRU - q.TRC))
        (self.mL, gL, _), (self.mU, gU, _), (self.mW, gW, _) = (
            q.MASSES[b] for b in ("LOWER", "UPPER", "UPRIGHT"))
        self.gL, self.gU = _vec(gL), _vec(gU)
        # the assembly branches of the modeling posture
        _, B, _ = self._abc(self.LBJ)
        self.sB = 1.0 if B >= 0 else -1.0
        self.sZ = 1.0
        x, y, z, (ex, ey, ez) = self._tri(self.LBJ, _vec(q.UBJ))
        if np.linalg.norm(q.LBJ + x * np.array(ex) + y * np.array(ey) - z * np.array(ez)
                          - q.TRU) < 1e-9:
            self.sZ = -1.0
        # upright points in the LBJ-UBJ-TRU frame of the modeling posture
        F0 = self._frame(self.LBJ, _vec(q.UBJ), _vec(q.TRU))
        self.local = {k: tuple(_dot(f, _vec(v - q.LBJ)) for f in F0)
                      for k, v in (("G", gW), ("CP", q.CP), ("UBJ", q.UBJ), ("TRU", q.TRU))}
        assert np.abs(np.array(self.posture(0.0)[2]) - q.TRU).max() < 1e-9

    def _abc(self, L):
        w = _sub(self.cU, L)
        A = 2 * self.rU * _dot(w, self.e1)
        B = 2 * self.rU * _dot(w, self.e2)
        C = self.dUL2 - _dot(w, w) - self.rU ** 2
        return A, B, C

    def _tri(self, P1, P2):
        P3 = self.TRC
        d12 = _sub(P2, P1)
        d = _norm(d12)
        ex = _mul(1.0 / d, d12)
        d13 = _sub(P3, P1)
        i = _dot(ex, d13)
        t = _sub(d13, _mul(i, ex))
        ey = _mul(1.0 / _norm(t), t)
        j = _dot(ey, d13)
        x = (self.r1 ** 2 - self.r2 ** 2 + d * d) / (2 * d)
        y = (self.r1 ** 2 - self.r3 ** 2 + i * i + j * j) / (2 * j) - i * x / j
        z = self.sZ * (self.r1 ** 2 - x * x - y * y) ** 0.5
        return x, y, z, (ex, ey, _cross(ex, ey))

    @staticmethod
    def _frame(L, U, T):
        """The orthonormal frame (e1, e2, e3) of the upright."""
        d = _sub(U, L)
        e1 = _mul(1.0 / _norm(d), d)
        v = _sub(T, L)
        v = _sub(v, _mul(_dot(e1, v), e1))
        e2 = _mul(1.0 / _norm(v), v)
        return e1, e2, _cross(e1, e2)

    def posture(self, phi):
        L = _rotate(self.LA_P, self.LA_A, np.cos(phi), np.sin(phi), self.LBJ)
        A, B, C = self._abc(L)
        t = (C - A) / (B + self.sB * (A * A + B * B - C * C) ** 0.5)  # tan(psi / 2)
        cpsi, spsi = (1 - t * t) / (1 + t * t), 2 * t / (1 + t * t)
        U = _add(self.cU, _mul(self.rU, _add(_mul(cpsi, self.e1), _mul(spsi, self.e2))))
        x, y, z, (ex, ey, ez) = self._tri(L, U)
        T = _add(L, _add(_mul(x, ex), _add(_mul(y, ey), _mul(z, ez))))
        return L, U, T, self._frame(L, U, T), (cpsi, spsi)

    def _point(self, L, F, key):
        c = self.local[key]
        return _add(L, _add(_mul(c[0], F[0]), _add(_mul(c[1], F[1]), _mul(c[2], F[2]))))

    def energy(self, x):
        q = QC
        phi = x[0]
        L, _, _, F, (cpsi, spsi) = self.posture(phi)
        cphi, sphi = np.cos(phi), np.sin(phi)
        zL = _rotate(self.LA_P, self.LA_A, cphi, sphi, self.gL)[2]
        zU = _rotate(self.UA_P, self.UA_A, cpsi, spsi, self.gU)[2]
        cW, cC = self.local["G"], self.local["CP"]
        zW = L[2] + cW[0] * F[0][2] + cW[1] * F[1][2] + cW[2] * F[2][2]
        zC = L[2] + cC[0] * F[0][2] + cC[1] * F[1][2] + cC[2] * F[2][2]
        ell = _norm(_sub(self.SPT, _rotate(self.LA_P, self.LA_A, cphi, sphi, self.SPB)))
        return (G * (self.mL * zL + self.mU * zU + self.mW * zW)
                + 0.5 * q.K * (ell - q.free_length) ** 2 - q.WHEEL_LOAD * zC)

    def x0(self) -> np.ndarray:
        return np.array([0.0])

    def outputs(self, x) -> dict:
        phi = float(x[0])
        L, U, T, F, _ = self.posture(phi)
        pts = {"LBJ": L, "UBJ": U, "TRU": T, "CP": self._point(L, F, "CP"),
               "SPB": _rotate(self.LA_P, self.LA_A, np.cos(phi), np.sin(phi), self.SPB)}
        return quarter_car_outputs({k: np.array(v, float) for k, v in pts.items()})


#: gradient tolerance of the complex-step BFGS (N m per rad): 1e-10 x the loads' size
GTOL = {"fourbar": 1e-10 * 25.0 * 3.0, "quarter_car": 1e-10 * 3500.0 * 0.6}


def scipy_solver(case: str, jac: str):
    from scipy.optimize import minimize

    en = FourBarEnergy() if case == "fourbar" else QuarterCarEnergy()
    opts = {"gtol": GTOL[case]} if jac == "cs" else {}

    def run():
        return minimize(en.energy, en.x0(), method="BFGS", jac=jac, options=opts)

    return en, run


# ------------------------------------------------------------------- worker
def _times(run, repeats: int) -> tuple[list[float], object, float]:
    t = time.perf_counter()
    res = run()  # warm-up: compilation, caches
    first = time.perf_counter() - t
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        res = run()
        times.append(time.perf_counter() - t)
    return times, res, first


def _timing(times: list[float]) -> dict:
    return {"times": times, "median_s": statistics.median(times), "best_s": min(times)}


def _openimp_case(case: str, repeats: int) -> dict:
    import openimp

    t = time.perf_counter()
    s = openimp.compile(openimp_fourbar() if case == "fourbar" else openimp_quarter_car())
    rec: dict = {"build_s": time.perf_counter() - t}
    times, eq, first = _times(lambda: openimp.equilibrium(s, forces=False), repeats)
    rec.update(_timing(times), first_s=first, evaluations=eq.evaluations, steps=eq.steps,
               converged=bool(eq.converged), status=eq.status, stability=eq.stability,
               free=eq.free, unbalance=eq.unbalance, eigenvalues=eq.eigenvalues.tolist(),
               history=[h[0] for h in eq.history], outputs=openimp_outputs(case, eq),
               nq=s.nq)
    ft, eqf, _ = _times(lambda: openimp.equilibrium(s, forces=True), repeats)
    rec["forces"] = _timing(ft)
    rec["forces"]["same_q"] = float(np.max(np.abs(eqf.q - eq.q)))
    if case == "quarter_car":
        s2 = openimp.compile(openimp_quarter_car("ball"))
        bt, eqb, _ = _times(lambda: openimp.equilibrium(s2, forces=False), repeats)
        rec["ball"] = _timing(bt)
        rec["ball"].update(evaluations=eqb.evaluations, steps=eqb.steps,
                           converged=bool(eqb.converged), stability=eqb.stability,
                           free=eqb.free, messages=eqb.messages,
                           outputs=openimp_outputs(case, eqb))
    return rec


#: stiffness of the four-bar's penalty pins in Exudyn (N/m)
PENALTY = 1e7


def _exudyn_case(case: str, repeats: int) -> dict:
    t = time.perf_counter()
    model = ExudynStatic(case)
    rec: dict = {"build_s": time.perf_counter() - t}
    times, ok, first = _times(model.solve, repeats)
    rec.update(_timing(times), first_s=first, converged=ok, **model.iterations())
    if ok:
        rec["outputs"] = model.outputs()
    if case == "fourbar":
        # the closed-form equilibrium (scipy's, complex-step BFGS): from there, and from
        # 0.001 deg off it, with the joints as constraints; then the penalty pins
        en, run = scipy_solver(case, "cs")
        th = float(run().x[0])
        near = {}
        for off in (0.0, 1e-3, 1e-1):
            good = model.solve(model.fourbar_coordinates(th + np.radians(off)))
            near[f"{off:g}"] = dict(converged=good, **model.iterations())
            if good and off == 0.0:
                d = diff(model.outputs(), en.outputs(np.array([th])))
                near["0"].update(moved_rad=d[0], moved_m=d[1])
        rec["from_equilibrium"] = near
        pen = ExudynStatic(case, penalty=PENALTY)
        pt, pok, pfirst = _times(pen.solve, repeats)
        rec["penalty"] = _timing(pt)
        rec["penalty"].update(first_s=pfirst, converged=pok, stiffness=PENALTY,
                              **pen.iterations())
        if pok:
            rec["penalty"]["outputs"] = pen.outputs()
    return rec


def _scipy_case(case: str, repeats: int) -> dict:
    rec: dict = {}
    for jac in ("cs", "2-point"):
        en, run = scipy_solver(case, jac)
        times, res, first = _times(run, repeats)
        r = _timing(times)
        r.update(first_s=first, converged=bool(res.success), message=str(res.message),
                 nfev=int(res.nfev), njev=int(res.njev), nit=int(res.nit),
                 grad=float(np.abs(res.jac).max()), outputs=en.outputs(res.x))
        rec[jac] = r
    rec.update(rec["cs"])
    return rec


def worker(tool: str, repeats: int) -> dict:
    out: dict = {"tool": tool, "cases": {}}
    if tool == "exudyn":
        try:
            import exudyn
        except ImportError as e:
            return {"tool": tool, "status": "missing", "reason": str(e)}
        out["version"] = exudyn.__version__
    elif tool == "scipy":
        import scipy

        out["version"] = scipy.__version__
    else:
        import openimp

        out["version"] = openimp.__version__
    run = {"openimp": _openimp_case, "exudyn": _exudyn_case, "scipy": _scipy_case}[tool]
    for case in CASES:
        try:
            out["cases"][case] = run(case, repeats)
        except Exception as e:  # report, never crash the whole benchmark
            out["cases"][case] = {"status": "error", "reason": f"{type(e).__name__}: {e}"}
    out["status"] = "ok"
    return out


def profile(repeats: int) -> None:
    """cProfile of openimp's solves (warm), printed."""
    import cProfile
    import pstats

    import openimp

    for case in CASES:
        s = openimp.compile(openimp_fourbar() if case == "fourbar" else openimp_quarter_car())
        openimp.equilibrium(s, forces=False)
        pr = cProfile.Profile()
        pr.enable()
        for _ in range(repeats):
            openimp.equilibrium(s, forces=False)
        pr.disable()
        print(f"\n===== {case}: {repeats} solves, forces=False")
        pstats.Stats(pr).sort_stats("tottime").print_stats(18)
        pstats.Stats(pr).sort_stats("cumulative").print_stats(25)


# ------------------------------------------------------------------- report
def run_workers(repeats: int) -> dict:
    return vib.run_workers(repeats, "benchmarks.statics", TOOLS)


def _flat(out: dict) -> dict[str, np.ndarray]:
    return {k: np.atleast_1d(np.asarray(v, float)) for k, v in out.items()}


def diff(a: dict, b: dict) -> tuple[float, float]:
    """(max |angle difference| (rad), max |coordinate or length difference| (m))."""
    fa, fb_ = _flat(a), _flat(b)
    da = dl = 0.0
    for k, v in fa.items():
        d = np.abs(v - fb_[k])
        if v.size == 1 and k not in ("strut",):  # an angle
            da = max(da, float(np.max(np.abs(np.angle(np.exp(1j * (v - fb_[k])))))))
        else:
            dl = max(dl, float(np.max(d)))
    return da, dl


def _ms(x: float) -> str:
    return f"{1e3 * x:.3f}"


def meta() -> dict:
    """Date, openimp tree (as the main harness states it: commit, uncommitted changes in
    src/, or where openimp is imported from) and load average."""
    import platform

    from benchmarks.__main__ import _git_state, _openimp_origin, src_hash

    return {"date": time.strftime("%Y-%m-%d %H:%M"), "git": _git_state(),
            "openimp_from": _openimp_origin(), "openimp_hash": src_hash(),
            "load": list(os.getloadavg()[:1]), "machine": platform.machine(),
            "cpus": os.cpu_count(), "python": platform.python_version(),
            "numpy": np.__version__}


def section(recs: dict, repeats: int, info: dict | None = None) -> str:
    info = info or meta()
    L = [TITLE, ""]
    vers = ", ".join(f"{t} {recs[t].get('version', '?')}" for t in TOOLS)
    load = "/".join(f"{x:.1f}" for x in info["load"])
    L.append(
        "`python -m benchmarks.statics`. One static equilibrium per solve, from the modeling "
        "posture, every tool on the equivalent model; times: one process per tool, a warm-up "
        f"solve first (compilation excluded), then {repeats} solves: median (best), ms. "
        f"Run {info['date']} on {info['machine']} ({info['cpus']} cores shared with other "
        f"work; load average at start / end {load}), Python {info['python']}, numpy "
        f"{info['numpy']}; "
        + (f"openimp imported from `{info['openimp_from']}` (source hash "
           f"{info['openimp_hash']}), repository {info['git']}" if info["openimp_from"]
           else f"openimp tree {info['git']}")
        + ("; **openimp's sources changed during the run**" if info.get("src_changed") else "")
        + f"; {vers}. "
        "*peer/openimp* = peer time / openimp time (> 1: openimp faster). *evaluations*: "
        "openimp `Equilibrium.evaluations` (residual evaluations, stiffness ones included); "
        "Exudyn Newton iterations / Jacobian computations of its static solver (one load "
        "step); scipy `nfev` / `njev` (function values / gradients; a complex-step gradient "
        "costs one complex evaluation, a 2-point one an extra real evaluation, both counted "
        "in `nfev`). *max diff*: the largest difference from openimp's equilibrium in the "
        "compared angles (rad) and point coordinates (m).\n")
    oi = recs.get("openimp", {}).get("cases", {})
    for case in CASES:
        L.append(f"### {CASE_TITLES[case]}\n")
        L.append("| tool | solve (ms) | peer/openimp | evaluations | max diff angles (rad) | "
                 "max diff points (m) | note |")
        L.append("|---|---:|---:|---:|---:|---:|---|")
        ref = oi.get(case)
        ok_ref = ref and "median_s" in ref

        def row(label, r, evals, note, ref=ref, ok_ref=ok_ref,
                ref_out=ok_ref and ref["outputs"]):
            if not r or "median_s" not in r:
                why = (r or {}).get("reason", "not run")
                L.append(f"| {label} | {why[:200]} | | | | | |")
                return
            ratio = f"{r['median_s'] / ref['median_s']:.2f}" if ok_ref else "-"
            da = dl = "-"
            if ref_out and r is not ref and "outputs" in r:
                a, b = diff(r["outputs"], ref_out)
                da, dl = f"{a:.1e}", f"{b:.1e}"
            L.append(f"| {label} | {_ms(r['median_s'])} ({_ms(r['best_s'])}) | {ratio} | "
                     f"{evals} | {da} | {dl} | {note} |")

        if ok_ref:
            row("openimp `equilibrium(forces=False)`", ref, ref["evaluations"],
                f"{ref['steps']} steps ({', '.join(ref['history'])}), {ref['status']}, "
                f"{ref['stability']}, FGC {', '.join(ref['free'])}; unbalance "
                f"{ref['unbalance']:.1e}; first call {ref['first_s']:.2f} s")
            f = dict(ref["forces"], outputs=ref["outputs"])
            row("openimp `equilibrium(forces=True)`", f, ref["evaluations"],
                "+ the force analysis at the equilibrium (joint reactions, element forces)")
            if "ball" in ref:
                b = ref["ball"]
                row("openimp, tie rod with two balls (idle spin)", b, b["evaluations"],
                    f"{b['steps']} steps, {b['stability']} (the spin), FGC "
                    f"{', '.join(b['free'])}")
        else:
            row("openimp `equilibrium`", ref, "", "")
        ex = recs.get("exudyn", {})
        e = ex.get("cases", {}).get(case) if ex.get("status") == "ok" else ex
        label = "Exudyn `SolveStatic`"
        how = ("tie rod `CreateDistanceConstraint`, Euler-parameter bodies"
               if case == "quarter_car" else "`ExudynFourBar` (crank spring 0) + "
               "`ObjectConnectorSpringDamper`, pins `RevoluteJoint2D`")
        if e and "median_s" in e and not e.get("converged"):
            fe = e.get("from_equilibrium", {})
            f0 = fe.get("0", {})
            L.append(f"| {label} | **fails** (gives up after {_ms(e['median_s'])}) | - | "
                     f"{e['newton']} / {e['jacobians']} | - | - | {how}; no convergence "
                     "from the start posture (adaptive load-step reduction to its minimum)"
                     + ("; from 0.001 deg off the equilibrium it fails too"
                        if fe.get("0.001", {}).get("converged") is False else "")
                     + (f"; started at the closed-form equilibrium it stays there ("
                        f"{f0['newton']} iteration, moves it by {f0['moved_rad']:.1e} rad, "
                        f"{f0['moved_m']:.1e} m): the models agree" if "moved_m" in f0
                        else "") + " |")
        else:
            row(label, e, f"{e['newton']} / {e['jacobians']}" if e and "newton" in e else "",
                ("converged" if e and e.get("converged") else "**not converged**")
                + f", one load step; {how}")
        if e and "penalty" in e:
            pe = e["penalty"]
            row(f"Exudyn `SolveStatic`, pins as penalty springs ({pe['stiffness']:.0e} N/m)",
                pe, f"{pe['newton']} / {pe['jacobians']}",
                ("converged" if pe.get("converged") else "**not converged**")
                + "; every `RevoluteJoint2D` replaced by a `CartesianSpringDamper`: a "
                "compliant model (pin forces / stiffness ~ 5e-6 m)")
        sc = recs.get("scipy", {}).get("cases", {}).get(case, {})
        for jac, label in (("cs", "scipy `minimize` BFGS, complex-step gradient"),
                           ("2-point", "scipy `minimize` BFGS, default 2-point gradient")):
            r = sc.get(jac)
            row(label, r, f"{r['nfev']} / {r['njev']}" if r else "",
                (f"{r['nit']} iterations, final gradient {r['grad']:.1e}"
                 + ("" if r["converged"] else f", **{r['message']}**")
                 + (f", gtol {GTOL[case]:.1e}" if jac == "cs" else ", default gtol 1e-5"))
                if r else "")
        if ok_ref:
            o = ref["outputs"]
            if case == "fourbar":
                L.append(f"\nopenimp's equilibrium: crank {np.degrees(o['crank']):.4f} deg "
                         f"(start {np.degrees(mx.FOURBAR.theta0):.1f}), coupler "
                         f"{np.degrees(o['coupler']):.4f} deg, rocker "
                         f"{np.degrees(o['rocker']):.4f} deg, P ({o['P'][0]:.6f}, "
                         f"{o['P'][1]:.6f}) m; compared: the three link angles and P.")
            else:
                L.append(f"\nopenimp's equilibrium: lower arm {np.degrees(o['lower arm']):.4f}"
                         f" deg, upper arm {np.degrees(o['upper arm']):.4f} deg from the "
                         f"modeling posture, contact point z {1e3 * o['CP'][2]:.3f} mm, strut "
                         f"{o['strut']:.6f} m (free {QC.free_length:.6f}); compared: both arm "
                         "angles and LBJ, UBJ, TRU, CP.")
                if "ball" in ref:
                    a, b = diff(ref["ball"]["outputs"], o)
                    L[-1] += (f" The two-ball tie rod's equilibrium differs by {a:.1e} rad, "
                              f"{b:.1e} m.")
            L.append(f"openimp's stiffness at the equilibrium (eigenvalue on the FGC "
                     f"{', '.join(ref['free'])}): "
                     f"{', '.join(f'{x:.6g}' for x in ref['eigenvalues'])} N m/rad.")
        L.append("")
    return "\n".join(L).rstrip() + "\n"


def summary(recs: dict) -> dict:
    """The records without the per-solve times (for results.json)."""
    out = json.loads(json.dumps(recs))
    for r in out.values():
        for c in r.get("cases", {}).values():
            for sub in (c, c.get("forces", {}), c.get("ball", {}), c.get("cs", {}),
                        c.get("2-point", {}), c.get("penalty", {})):
                sub.pop("times", None)
    return out


def write_section(path: Path, text: str) -> None:
    """Replace (or append) the statics section in ``path``."""
    vib.write_section(path, text, TITLE)


def write_json(path: Path, recs: dict) -> None:
    """Put the records under ``extras.statics`` of the harness's results.json."""
    raw = json.loads(path.read_text()) if path.exists() else {}
    raw.setdefault("extras", {})["statics"] = summary(recs)  # meta has no "cases"
    path.write_text(json.dumps(raw, indent=1, default=float))


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks.statics",
                                description=__doc__.split("\n")[0])
    p.add_argument("--repeats", type=int, default=30, help="timed solves (default 30)")
    p.add_argument("--out", default=str(HERE / "results.md"),
                   help="the report whose section is replaced (default benchmarks/results.md)")
    p.add_argument("--no-write", action="store_true", help="print only")
    p.add_argument("--profile", action="store_true", help="cProfile openimp's solves")
    p.add_argument("--worker", choices=TOOLS, help=argparse.SUPPRESS)
    a = p.parse_args(argv)
    if a.worker:
        print(json.dumps(worker(a.worker, a.repeats), default=float))
        return 0
    if a.profile:
        profile(a.repeats)
        return 0
    t = time.perf_counter()
    info = meta()
    recs = run_workers(a.repeats)
    info["load"].append(os.getloadavg()[0])
    from benchmarks.__main__ import src_hash

    info["src_changed"] = src_hash() != info["openimp_hash"]
    recs_meta = dict(info, total_s=time.perf_counter() - t)
    text = section(recs, a.repeats, info)
    print(text)
    print(f"total {time.perf_counter() - t:.0f} s", file=sys.stderr)
    if not a.no_write:
        write_section(Path(a.out), text)
        write_json(Path(a.out).with_suffix(".json"), dict(recs, meta=recs_meta))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
