"""Linearization and modes (issue 14): a natural-frequency map of the four-bar over 360 postures.

    python -m benchmarks.vibration              # about 1 minute; updates results.md's section
    python -m benchmarks.vibration --repeats 5 --no-write

Cases (masses of :data:`benchmarks.mechanisms.FOURBAR_DYN`, SI units):

* ``rigid_g``: the four-bar, crank free (1 FGC), held by a torsional spring at the
  crank pivot A (k = 500 N m/rad: a position servo), gravity; at each of the 360
  crank angles of case (a) the spring's free angle is the one that balances
  gravity there, so every posture is an equilibrium (away from one the
  linearization depends on the coordinates chosen; see the report).  One compiled
  system per posture, built outside the timing (about 2 ms each).
* ``rigid``: the same without gravity (spring relaxed at the posture).
* ``flex``: the coupler split at its point P (0.5 off the line BC; H) into two links
  (0.6 kg each; with H on the line BC the two halves would be at a toggle)
  joined by a revolute with a joint spring of 2e4 N m/rad; the crank angle is an
  SGC (locked), the FGC is what the elimination leaves; no gravity, H at its free
  angle (the rigid postures), one compiled system.

Tools (each in its own process, ``--worker TOOL``):

* openimp: ``openimp.linearize(system, q_k)`` then ``openimp.modes(lin)``;
* scipy finite differences: what a user without analytic linearization does:
  M, c, Q from ``openimp.dynamics.eom.equations`` (the nonlinear equations of
  motion), K and D by central differences of the residual c - Q in the natural
  coordinate (crank angle A; hinge angle H in ``flex``), each perturbed posture
  re-closed by ``openimp.sweep(..., q=q_k)``, then ``scipy.linalg.eig`` of the
  first-order system;
* Exudyn: ``ObjectRigidBody2D`` links, ``RevoluteJoint2D`` pins, the springs as
  ``CoordinateSpringDamper`` on rotation coordinates, the locked crank of ``flex``
  a ``CoordinateConstraint``; per posture the initial coordinates are set and
  ``mbs.ComputeODE2Eigenvalues`` projects M and K on the null space of the
  constraint Jacobian (SVD).

Timed: the 360 postures (linearization + eigen-solution), after a warm-up pass
(compilation excluded); median and best of ``--repeats`` passes.  Untimed checks
in the openimp worker: K = d2V/dpsi2 by central differences of
``EquationsOfMotion.potential`` over re-closed postures and omega = sqrt(K / M);
M against the closed-form kinetic energy of the four-bar (rigid cases).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from benchmarks import mechanisms as mx

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
TITLE = "## Linearization and modes (issue 14)"
CASES = ("rigid_g", "rigid", "flex")
TOOLS = ("openimp", "scipy-fd", "exudyn")
K_CRANK = 500.0  # N m/rad, torsional spring at the crank pivot
K_HINGE = 2.0e4  # N m/rad, the flexible coupler's hinge
H_FD = 1e-5  # rad, central-difference step of K and D (scipy peer)
H_V = 1e-4  # rad, central-difference step of d2V/dpsi2 (check)
CASE_TITLES = {
    "rigid_g": "four-bar, crank free (1 FGC), crank spring, gravity",
    "rigid": "four-bar, crank free (1 FGC), crank spring, no gravity",
    "flex": "flexible coupler: crank SGC, coupler hinge spring (1 FGC), no gravity",
}
#: the coupler halves of ``flex`` in the coupler frame (origin B, x towards C)
HALVES = (mx.LinkMass(0.6, (0.75, 0.25), (1.0e-3, 0.12, 0.12)),
          mx.LinkMass(0.6, (2.25, 0.25), (1.0e-3, 0.12, 0.12)))


# ----------------------------------------------------------------- geometry
def postures_closed_form() -> dict:
    """Crank angles, link angles (crank, coupler, rocker) and B of the 360 postures."""
    fb = mx.FOURBAR
    th = fb.crank_angles()
    km = fb.link_motion(th, 1.0, 0.0)
    return {"theta": th, "th": km["th"], "w": km["w"], "B": fb.B_at(th)}


def crank_inertia_closed_form() -> np.ndarray:
    """M_AA(theta) = sum m |v_G|^2 + I w^2 at unit crank rate (plain numpy)."""
    fd = mx.FOURBAR_DYN
    p = postures_closed_form()
    n = p["theta"].size
    B = p["B"]
    vo = [np.zeros((n, 2)), np.stack([-B[:, 1], B[:, 0]], 1), np.zeros((n, 2))]
    M = np.zeros(n)
    for i, lk in enumerate(fd.links):
        t, w = p["th"][:, i], p["w"][:, i]
        x, y = lk.centre
        r = np.stack([np.cos(t) * x - np.sin(t) * y, np.sin(t) * x + np.cos(t) * y], 1)
        v = vo[i] + w[:, None] * np.stack([-r[:, 1], r[:, 0]], 1)
        M += lk.mass * np.sum(v * v, 1) + lk.inertia[2] * w * w
    return M


# ----------------------------------------------------------------- openimp models
def _openimp_model(case: str, free: float | None = None):
    from benchmarks.tools.openimp_tool import _xyz, fourbar_dynamic_model

    fd = mx.FOURBAR_DYN
    if case != "flex":
        m = fourbar_dynamic_model(fd)
        if case == "rigid":
            m.set_gravity(None)
        m.set_joint_spring("A", K_CRANK, free=free)
        return m
    import openimp

    fb = fd.fb
    m = openimp.Model("fourbar-flex")
    z = (0.0, 0.0, 1.0)
    H = fb.P0  # the coupler point: B, H, C not in line
    m.add_joint("revolute", "A", "BASE", "CRANK", origin=_xyz(fb.A), axis=z)
    m.add_joint("revolute", "B", "CRANK", "COUPLER1", origin=_xyz(fb.B0), axis=z)
    m.add_joint("revolute", "H", "COUPLER1", "COUPLER2", origin=_xyz(H), axis=z)
    m.add_joint("revolute", "C", "COUPLER2", "ROCKER", origin=_xyz(fb.C0), axis=z)
    m.add_joint("revolute", "D", "ROCKER", "BASE", origin=_xyz(fb.D), axis=z)
    th0 = fb.link_angles0()
    R = mx._rot_z(th0[1])
    for body, lk in zip(("COUPLER1", "COUPLER2"), HALVES):
        c = fb.B0 + R[:2, :2] @ np.asarray(lk.centre)
        m.add_mass(body, lk.mass, _xyz(c), R @ np.diag(lk.inertia) @ R.T)
    for i in (0, 2):
        m.add_mass(fd.names[i], fd.links[i].mass, tuple(float(x) for x in fd.centre0(i)),
                   fd.inertia0(i))
    m.set_joint_spring("H", K_HINGE)
    return m


def openimp_setup(case: str) -> tuple[list, np.ndarray, list[str], np.ndarray]:
    """(systems per posture, postures q (360, nq), specified, offsets) of a case; offsets:
    per posture the crank spring's free angle (rigid cases) or the crank angle (flex),
    from the modeling posture (the offset of Exudyn's crank spring or constraint)."""
    import openimp
    from openimp.dynamics.eom import equations

    fb = mx.FOURBAR
    drv = fb.crank_angles() - fb.theta0
    if case == "flex":
        s = openimp.compile(_openimp_model(case))
        tr = openimp.sweep(s, {"A": drv, "H": np.zeros_like(drv)})
        assert tr.complete, tr.message
        return [s] * len(drv), tr.q.copy(), ["A"], drv.copy()
    s0 = openimp.compile(_openimp_model(case))
    tr = openimp.sweep(s0, {"A": drv})
    assert tr.complete, tr.message
    iA = s0.var_index("A")
    systems, free = [], []
    for q in tr.q:
        # Q_A with the spring relaxed at the posture: the load of gravity on the crank
        relaxed = openimp.compile(_openimp_model(case, free=float(q[iA])))
        gA = equations(relaxed, q, specified=["A"]).Q[0]
        free.append(float(q[iA] - gA / K_CRANK))
        systems.append(relaxed if gA == 0.0 else
                       openimp.compile(_openimp_model(case, free=free[-1])))
    return systems, tr.q.copy(), [], np.array(free)


def _frequency(md) -> float:
    f = md.frequency[np.isfinite(md.frequency)]
    return float(np.min(f)) if f.size else float("nan")


def openimp_run(systems, Q, specified):
    import openimp

    out = np.empty(len(Q))
    for k, (s, q) in enumerate(zip(systems, Q)):
        out[k] = _frequency(openimp.modes(openimp.linearize(s, q, specified=specified)))
    return out


# ------------------------------------------------------- scipy finite differences
def fd_run(systems, Q, specified, coord: str):
    """K, D by central differences of c - Q in ``coord`` (re-closed postures), scipy eig."""
    import scipy.linalg

    import openimp
    from openimp.dynamics.eom import equations

    pin = [*specified, coord]
    out = np.empty(len(Q))
    h = H_FD
    for k, (s, q) in enumerate(zip(systems, Q)):
        e0 = equations(s, q, specified=pin)
        i = e0.coords.index(s.var_names[s.var_index(coord)])
        drv = {coord: [q[s.var_index(coord)] - h, q[s.var_index(coord)] + h]}
        for key in specified:
            drv[key] = [q[s.var_index(key)]] * 2
        tr = openimp.sweep(s, drv, q=q, tol=1e-13)
        rm, rp = (equations(s, qq, specified=pin) for qq in tr.q)
        K = ((rp.c - rp.Q)[i] - (rm.c - rm.Q)[i]) / (2 * h)
        vm, vp = (equations(s, q, {coord: v}, specified=pin) for v in (-h, h))
        D = ((vp.c - vp.Q)[i] - (vm.c - vm.Q)[i]) / (2 * h)
        M = e0.M[i, i]
        A = np.array([[0.0, 1.0], [-K / M, -D / M]])
        lam = scipy.linalg.eig(A, right=False)
        out[k] = float(np.max(np.abs(lam[lam.imag > 0]))) if np.any(lam.imag > 0) else np.nan
    return out


def energy_check(systems, Q, specified, coord: str) -> dict:
    """omega = sqrt(d2V/dpsi2 / M), V = EquationsOfMotion.potential over re-closed postures."""
    import openimp
    from openimp.dynamics.eom import equations

    pin = [*specified, coord]
    h = H_V
    w = np.empty(len(Q))
    Mq = np.empty(len(Q))
    for k, (s, q) in enumerate(zip(systems, Q)):
        x = q[s.var_index(coord)]
        drv = {coord: [x - h, x + h]}
        for key in specified:
            drv[key] = [q[s.var_index(key)]] * 2
        tr = openimp.sweep(s, drv, q=q, tol=1e-13)
        e0 = equations(s, q, specified=pin)
        V = [equations(s, qq, specified=pin).potential for qq in tr.q]
        K = (V[0] - 2 * e0.potential + V[1]) / (h * h)
        i = e0.coords.index(s.var_names[s.var_index(coord)])
        Mq[k] = e0.M[i, i]
        w[k] = np.sqrt(K / Mq[k])
    return {"omega": w, "M": Mq}


# ------------------------------------------------------------------- Exudyn
class ExudynFourBar:
    """The four-bar (``rigid``, ``rigid_g``) or the flexible-coupler four-bar (``flex``)."""

    def __init__(self, case: str):
        import exudyn as exu
        from exudyn import itemInterface as ii  # noqa: N813

        self.exu, self.case = exu, case
        fd = mx.FOURBAR_DYN
        fb = fd.fb
        self.SC = exu.SystemContainer()
        mbs = self.mbs = self.SC.AddSystem()
        ground = mbs.AddObject(ii.ObjectGround())
        th0 = fb.link_angles0()
        # (link frame origin at the modeling posture, link angle index, mass data)
        links = [(fb.A, 0, fd.links[0])]
        if case == "flex":
            links += [(fb.B0, 1, HALVES[0]), (fb.B0, 1, HALVES[1])]
        else:
            links += [(fb.B0, 1, fd.links[1])]
        links += [(fb.D, 2, fd.links[2])]
        self.links = links
        bodies = []
        for origin, ia, lk in links:
            G = origin + mx._rot_z(th0[ia])[:2, :2] @ np.asarray(lk.centre)
            n = mbs.AddNode(ii.NodeRigidBody2D(referenceCoordinates=[G[0], G[1], 0.0],
                                               initialCoordinates=[0.0, 0.0, 0.0]))
            o = mbs.AddObject(ii.ObjectRigidBody2D(nodeNumber=n, mass=lk.mass,
                                                   inertia=lk.inertia[2]))
            bodies.append((n, o, G))
            if case == "rigid_g":
                mm = mbs.AddMarker(ii.MarkerBodyMass(bodyNumber=o))
                mbs.AddLoad(ii.LoadMassProportional(markerNumber=mm,
                                                    loadVector=list(fd.gravity)))
        self.G0 = [b[2] for b in bodies]

        def marker(b, p):
            o, c = (ground, np.zeros(2)) if b is None else (b[1], b[2])
            d = np.asarray(p, float) - c
            return mbs.AddMarker(ii.MarkerBodyPosition(bodyNumber=o,
                                                       localPosition=[d[0], d[1], 0.0]))

        H = fb.P0  # the coupler point: B, H, C not in line
        chain = [None, *bodies, None]
        pins = [fb.A, fb.B0, *([H] if case == "flex" else []), fb.C0, fb.D]
        for j, p in enumerate(pins):
            mbs.AddObject(ii.RevoluteJoint2D(markerNumbers=[marker(chain[j], p),
                                                            marker(chain[j + 1], p)]))

        def rot(b):
            return mbs.AddMarker(ii.MarkerNodeCoordinate(nodeNumber=b[0], coordinate=2))

        ng = mbs.AddNode(ii.NodePointGround())
        mg = mbs.AddMarker(ii.MarkerNodeCoordinate(nodeNumber=ng, coordinate=0))
        if case == "flex":
            mbs.AddObject(ii.CoordinateSpringDamper(markerNumbers=[rot(bodies[1]),
                                                                   rot(bodies[2])],
                                                    stiffness=K_HINGE, offset=0.0))
            self.crank = mbs.AddObject(ii.CoordinateConstraint(
                markerNumbers=[mg, rot(bodies[0])], offset=0.0))
        else:
            self.crank = mbs.AddObject(ii.CoordinateSpringDamper(
                markerNumbers=[mg, rot(bodies[0])], stiffness=K_CRANK, offset=0.0))
        mbs.Assemble()
        self.settings = exu.SimulationSettings()
        self.th0 = th0

    def coordinates(self, theta: float, th: np.ndarray, B: np.ndarray) -> np.ndarray:
        """ODE2 coordinates (displacements from the reference) of the posture."""
        fb = mx.FOURBAR
        out = []
        for (_, ia, lk), G0 in zip(self.links, self.G0):
            origin = {0: fb.A, 1: B, 2: fb.D}[ia]
            c, s = np.cos(th[ia]), np.sin(th[ia])
            x, y = lk.centre
            G = origin + np.array([c * x - s * y, s * x + c * y])
            out += [G[0] - G0[0], G[1] - G0[1], th[ia] - self.th0[ia]]
        return np.array(out)

    def frequency(self, offset: float, coords: np.ndarray) -> float:
        self.mbs.SetObjectParameter(self.crank, "offset", offset)
        self.mbs.systemData.SetODE2Coordinates(coords,
                                               configuration=self.exu.ConfigurationType.Initial)
        ev, _ = self.mbs.ComputeODE2Eigenvalues(self.settings)
        return float(np.sqrt(np.min(ev)))


def exudyn_setup(case: str, offsets: np.ndarray):
    model = ExudynFourBar(case)
    p = postures_closed_form()
    coords = [model.coordinates(p["theta"][k], p["th"][k], p["B"][k])
              for k in range(p["theta"].size)]

    def run():
        return np.array([model.frequency(float(o), c) for o, c in zip(offsets, coords)])

    return run


def exudyn_static_check(case: str, offsets: np.ndarray, every: int = 30) -> dict:
    """Every ``every``-th posture: Exudyn's static solver from it must not move it (the
    posture is an equilibrium of the Exudyn model too), and the eigenvalues with the
    solved Lagrange multipliers in the state."""
    model = ExudynFourBar(case)
    exu, mbs = model.exu, model.mbs
    ss = exu.SimulationSettings()
    ss.staticSolver.verboseMode = 0
    ss.staticSolver.newton.relativeTolerance = 1e-12
    ss.staticSolver.newton.absoluteTolerance = 1e-13
    ss.solution.file.write = False
    ss.solution.sensors.writePeriod = 0.0
    p = postures_closed_form()
    moved, freq = 0.0, []
    for k in range(0, p["theta"].size, every):
        c = model.coordinates(p["theta"][k], p["th"][k], p["B"][k])
        mbs.SetObjectParameter(model.crank, "offset", float(offsets[k]))
        mbs.systemData.SetODE2Coordinates(c, configuration=exu.ConfigurationType.Initial)
        exu.SolveStatic(mbs, ss)
        moved = max(moved, float(np.max(np.abs(mbs.systemData.GetODE2Coordinates() - c))))
        mbs.systemData.SetSystemState(mbs.systemData.GetSystemState(),
                                      configuration=exu.ConfigurationType.Initial)
        ev, _ = mbs.ComputeODE2Eigenvalues(model.settings)
        freq.append(float(np.sqrt(np.min(ev))))
    return {"moved": moved, "every": every, "omega_with_lambda": freq}


# ------------------------------------------------------------------- worker
def _times(run, repeats: int) -> tuple[list[float], np.ndarray]:
    res = run()  # warm-up: compilation, caches
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        res = run()
        times.append(time.perf_counter() - t)
    return times, res


def worker(tool: str, repeats: int) -> dict:
    """Every case for one tool, in this process."""
    out: dict = {"tool": tool, "cases": {}}
    if tool == "exudyn":
        try:
            import exudyn
        except ImportError as e:
            return {"tool": tool, "status": "missing", "reason": str(e)}
        out["version"] = exudyn.__version__
    import openimp

    out.setdefault("version", openimp.__version__)
    if tool == "scipy-fd":
        import scipy

        out["version"] = scipy.__version__
    for case in CASES:
        t0 = time.perf_counter()
        systems, Q, specified, offsets = openimp_setup(case)
        rec: dict = {"postures": len(Q), "build_s": time.perf_counter() - t0}
        coord = "H" if case == "flex" else "A"
        if tool == "openimp":
            run = lambda s=systems, q=Q, sp=specified: openimp_run(s, q, sp)  # noqa: E731
            t = time.perf_counter()
            run()
            rec["first_s"] = time.perf_counter() - t
            if case != "flex":
                drv = {"A": mx.FOURBAR.crank_angles() - mx.FOURBAR.theta0}
                openimp.sweep(systems[0], drv)
                t = time.perf_counter()
                openimp.sweep(systems[0], drv)
                rec["sweep_s"] = time.perf_counter() - t
            chk = energy_check(systems, Q, specified, coord)
            rec["energy_omega"] = chk["omega"].tolist()
            if case != "flex":
                rec["M_closed"] = crank_inertia_closed_form().tolist()
                rec["M_eom"] = chk["M"].tolist()
            rec["fgc"] = openimp.linearize(systems[0], Q[0], specified=specified).coords
            if all(x is systems[0] for x in systems):
                # one system for every posture: the map in one compiled pass
                def batch(s=systems[0], q=Q, sp=specified):
                    return openimp.modes_along(s, q, specified=sp).frequency[:, 0]
                bt, bres = _times(batch, repeats)
                rec.update(batch_times=bt, batch_median_s=statistics.median(bt),
                           batch_best_s=min(bt), batch_omega=np.asarray(bres).tolist())
        elif tool == "scipy-fd":
            run = lambda s=systems, q=Q, sp=specified, c=coord: fd_run(s, q, sp, c)  # noqa: E731
        else:
            run = exudyn_setup(case, offsets)
            if case == "rigid_g":
                rec["static_check"] = exudyn_static_check(case, offsets)
        times, res = _times(run, repeats)
        rec.update(times=times, median_s=statistics.median(times), best_s=min(times),
                   omega=np.asarray(res).tolist())
        out["cases"][case] = rec
    out["status"] = "ok"
    return out


# ------------------------------------------------------------------- report
def run_workers(repeats: int, module: str = "benchmarks.vibration",
                tools: object = None) -> dict:
    """Run ``python -m module --worker TOOL --repeats N`` for every tool, one process
    each (imports and JIT caches of one tool do not touch another); their JSON records."""
    env = dict(os.environ)
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
    recs = {}
    label = module.rsplit(".", 1)[-1]
    for tool in (TOOLS if tools is None else tools):  # type: ignore[attr-defined]
        t = time.perf_counter()
        p = subprocess.run([sys.executable, "-m", module, "--worker", tool,
                            "--repeats", str(repeats)], cwd=ROOT, env=env,
                           capture_output=True, text=True, timeout=600)
        lines = [ln for ln in p.stdout.splitlines() if ln.startswith("{")]
        rec = (json.loads(lines[-1]) if lines else
               {"tool": tool, "status": "error", "reason": p.stderr.strip()[-600:]})
        rec["process_s"] = time.perf_counter() - t
        print(f"  {label} {tool:10s} {rec.get('status')} {rec['process_s']:.1f} s",
              file=sys.stderr, flush=True)
        recs[tool] = rec
    return recs


def summary(recs: dict) -> dict:
    """The records without the per-posture arrays (for results.json)."""
    drop = ("omega", "energy_omega", "M_closed", "M_eom", "batch_omega")
    out = {}
    for tool, r in recs.items():
        out[tool] = {k: v for k, v in r.items() if k != "cases"}
        out[tool]["cases"] = {c: {k: v for k, v in rc.items() if k not in drop}
                              for c, rc in r.get("cases", {}).items()}
    return out


def _rel(a, b) -> float:
    a, b = np.asarray(a, float), np.asarray(b, float)
    return float(np.max(np.abs(a - b) / np.abs(b)))


def section(recs: dict, repeats: int) -> str:
    L = [TITLE, ""]
    L.append(
        "`python -m benchmarks.vibration` (also run at the end of `python -m benchmarks`). "
        "Natural frequency of the four-bar (case (a) geometry, `FOURBAR_DYN` masses) at its "
        "360 crank angles: linearization + eigen-solution per posture, postures given (the "
        "same closed postures for every tool). Times: one process per tool, a warm-up pass "
        f"first (compilation excluded), then {repeats} passes: median (best); the machine "
        "has 2 cores shared with other work. *peer/openimp* = peer time / openimp time "
        "(> 1: openimp faster). *max rel. diff* = max over the postures of "
        "|omega_peer - omega_openimp| / omega_openimp.\n")
    oi = recs.get("openimp", {})
    for case in CASES:
        L.append(f"### {CASE_TITLES[case]}\n")
        L.append("| tool | 360 postures (s) | per posture (us) | peer/openimp | "
                 "max rel. diff in frequency | note |")
        L.append("|---|---:|---:|---:|---:|---|")
        ref = oi.get("cases", {}).get(case)
        for tool in TOOLS:
            r = recs.get(tool, {})
            c = r.get("cases", {}).get(case)
            label = {"openimp": "openimp `linearize` + `modes`",
                     "scipy-fd": "scipy finite differences (openimp EOM + re-closure)",
                     "exudyn": "Exudyn `ComputeODE2Eigenvalues`"}[tool]
            if not c:
                L.append(f"| {label} | {r.get('status', 'not run')} | | | | "
                         f"{r.get('reason', '')[:200]} |")
                continue
            n = c["postures"]
            ratio = diff = "-"
            if tool != "openimp" and ref:
                ratio = f"{c['median_s'] / ref['median_s']:.1f}"
                diff = f"{_rel(c['omega'], ref['omega']):.1e}"
            note = _note(tool, case, c, ref)
            L.append(f"| {label} | {c['median_s']:.3f} ({c['best_s']:.3f}) | "
                     f"{1e6 * c['median_s'] / n:.0f} | {ratio} | {diff} | {note} |")
            if tool == "openimp" and "batch_median_s" in c:
                L.append(f"| openimp `modes_along` (the map in one pass) | "
                         f"{c['batch_median_s']:.4f} ({c['batch_best_s']:.4f}) | "
                         f"{1e6 * c['batch_median_s'] / n:.0f} | "
                         f"{c['batch_median_s'] / c['median_s']:.2f} | "
                         f"{_rel(c['batch_omega'], c['omega']):.1e} | the same linearization, "
                         "all postures in one compiled call, eigenvalues batched |")
        if ref:
            w = np.asarray(ref["omega"])
            L.append("")
            L.append(f"omega over the 360 postures: {w.min():.3f} to {w.max():.3f} rad/s; "
                     f"openimp's FGC at the first posture: {', '.join(ref['fgc'])}. "
                     + _checks(case, ref))
        L.append("")
    return "\n".join(L).rstrip() + "\n"


def _note(tool: str, case: str, c: dict, ref: dict | None) -> str:
    if tool == "openimp":
        s = f"first pass {c['first_s']:.2f} s"
        if "sweep_s" in c:
            s += f"; the 360-posture sweep itself {1e3 * c['sweep_s']:.2f} ms (not in the time)"
        return s
    if tool == "scipy-fd":
        return (f"K, D: central differences, h = {H_FD:g} rad, re-closed with sweep(tol=1e-13); "
                "scipy.linalg.eig")
    if case == "rigid_g":
        sc = c.get("static_check", {})
        lam = sc.get("omega_with_lambda", [])
        d = (_rel(lam, np.asarray(ref["omega"])[::sc["every"]]) if lam and ref else float("nan"))
        return ("**does not apply**: Exudyn projects M and K on the constraint null space but "
                "leaves out the constraint forces' geometric stiffness (lambda^T d2C/dq2), "
                "which gravity makes non-zero; the static solver from each posture moves it by "
                f"{sc.get('moved', float('nan')):.1e} (an equilibrium) and the eigenvalues with "
                f"the solved multipliers in the state differ by {d:.1e} as well")
    return "constrained system: null-space projection of the revolute joints (SVD)" + (
        "; crank locked by a CoordinateConstraint" if case == "flex" else "")


def _checks(case: str, ref: dict) -> str:
    w = np.asarray(ref["omega"])
    s = (f"Check: omega = sqrt(d2V/dpsi2 / M) with V = `EquationsOfMotion.potential` over "
         f"re-closed postures (h = {H_V:g} rad): max rel. diff {_rel(ref['energy_omega'], w):.1e}")
    if "M_closed" in ref:
        s += (f"; M_AA of `equations` against the closed-form kinetic energy: max rel. diff "
              f"{_rel(ref['M_eom'], ref['M_closed']):.1e}")
        if case == "rigid":
            wk = np.sqrt(K_CRANK / np.asarray(ref["M_closed"]))
            s += f"; omega against the closed form sqrt(k / M_AA): {_rel(w, wk):.1e}"
    return s + "."


def write_section(path: Path, text: str, title: str = TITLE) -> None:
    """Replace (or append) the section ``title`` in ``path`` by ``text``."""
    old = path.read_text() if path.exists() else ""
    i = old.find(title)
    if i < 0:
        new = old.rstrip() + "\n\n" + text
    else:
        j = old.find("\n## ", i + len(title))
        new = old[:i] + text + (old[j:] if j >= 0 else "")
    path.write_text(new)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks.vibration",
                                description=__doc__.split("\n")[0])
    p.add_argument("--repeats", type=int, default=3, help="timed passes (default 3)")
    p.add_argument("--out", default=str(HERE / "results.md"),
                   help="the report whose section is replaced (default benchmarks/results.md)")
    p.add_argument("--no-write", action="store_true", help="print only")
    p.add_argument("--worker", choices=TOOLS, help=argparse.SUPPRESS)
    a = p.parse_args(argv)
    if a.worker:
        print(json.dumps(worker(a.worker, a.repeats)))
        return 0
    t = time.perf_counter()
    recs = run_workers(a.repeats)
    text = section(recs, a.repeats)
    print(text)
    print(f"total {time.perf_counter() - t:.0f} s", file=sys.stderr)
    if not a.no_write:
        write_section(Path(a.out), text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
