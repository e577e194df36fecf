"""Pinocchio: kinematic trees built in Python, loop closure solved by a Newton loop in Python.

Same scheme as the MuJoCo driver: the mechanism is a tree cut at one joint,
with an operational frame on each side of the cut; every step sets the crank
joint and iterates

    computeJointJacobians (forward kinematics + joint Jacobians),
    updateFramePlacement -> r(q),  getFrameJacobian(LOCAL_WORLD_ALIGNED) -> J,
    solve J dq = -r (minimum-norm for the RSSR's idle coupler spin, then pin.integrate),

until |r| < 1e-12.  Case (b) adds velocities (J qd = 0) and accelerations
(J qdd = -Jdot qd, with Jdot qd read as the frame's classical acceleration
from forwardKinematics(q, qd, 0)).  The 6R chain is forwardKinematics +
updateFramePlacement.  Joint frames are aligned with the world at q = 0.
"""

from __future__ import annotations

import numpy as np

from benchmarks import mechanisms as mx
from benchmarks.harness import CaseRun, per_variant_batch

NAME = "pinocchio"
TOL = 1e-12
MAXIT = 25


def version() -> str:
    import pinocchio

    return pinocchio.__version__


def _p3(p) -> np.ndarray:
    p = np.asarray(p, float)
    return np.array([p[0], p[1], 0.0]) if p.shape[0] == 2 else p


class _Tree:
    def __init__(self):
        import pinocchio as pin

        self.pin = pin
        self.model = pin.Model()
        self._origin = {0: np.zeros(3)}

    def joint(self, parent: int, jm, origin, name: str, inertia=None) -> int:
        """A joint at ``origin`` (global, frame aligned with the world at q = 0) and its
        body; ``inertia``: (mass, centre (global), 3x3 tensor about the centre on global
        axes), default a unit sphere."""
        pin = self.pin
        o = _p3(origin)
        place = pin.SE3(np.eye(3), o - self._origin[parent])
        jid = self.model.addJoint(parent, jm, place, name)
        if inertia is None:
            I = pin.Inertia.FromSphere(1.0, 0.1)
        else:
            m, c, Ic = inertia
            I = pin.Inertia(float(m), np.asarray(c, float) - o, np.asarray(Ic, float))
        self.model.appendBodyToJoint(jid, I, pin.SE3.Identity())
        self._origin[jid] = o
        return jid

    def frame(self, jid: int, point, name: str) -> int:
        pin = self.pin
        place = pin.SE3(np.eye(3), _p3(point) - self._origin[jid])
        return self.model.addFrame(pin.Frame(name, jid, place, pin.FrameType.OP_FRAME))

    def done(self):
        self.data = self.model.createData()
        return self


class _Loop:
    """Newton on the closure residual frame_a - (frame_b or target); driver = q[0]."""

    def __init__(self, tree: _Tree, fa: int, fb: int | None, target, passive: list[int],
                 ndim: int):
        self.pin = tree.pin
        self.model, self.data = tree.model, tree.data
        self.fa, self.fb = fa, fb
        self.target = None if target is None else _p3(target)[:ndim]
        self.passive = passive  # velocity indices of the unknowns
        self.ndim = ndim
        self.q = self.pin.neutral(self.model)
        self.square = len(passive) == ndim and self.model.nq == self.model.nv
        self.LWA = self.pin.ReferenceFrame.LOCAL_WORLD_ALIGNED

    def residual(self) -> np.ndarray:
        pin, m, d = self.pin, self.model, self.data
        pin.updateFramePlacement(m, d, self.fa)
        r = d.oMf[self.fa].translation.copy()
        if self.fb is not None:
            pin.updateFramePlacement(m, d, self.fb)
            r -= d.oMf[self.fb].translation
        r = r[: self.ndim]
        return r - self.target if self.target is not None else r

    def jacobian(self) -> np.ndarray:
        pin, m, d = self.pin, self.model, self.data
        J = pin.getFrameJacobian(m, d, self.fa, self.LWA)[:3]
        if self.fb is not None:
            J = J - pin.getFrameJacobian(m, d, self.fb, self.LWA)[:3]
        return J[: self.ndim]

    def solve(self, q_driver: float) -> int:
        pin, m, d = self.pin, self.model, self.data
        q = self.q
        q[0] = q_driver
        cols = self.passive
        for it in range(MAXIT):
            pin.computeJointJacobians(m, d, q)
            r = self.residual()
            if np.max(np.abs(r)) < TOL:
                return it
            J = self.jacobian()[:, cols]
            if self.square:
                q[cols] -= np.linalg.solve(J, r)
            else:
                dv = np.zeros(m.nv)
                dv[cols] = -J.T @ np.linalg.solve(J @ J.T, r)
                q[:] = pin.integrate(m, q, dv)
        raise RuntimeError(f"Pinocchio Newton did not converge at driver {q_driver}")


def _fourbar_loop(fb: mx.FourBar):
    import pinocchio as pin

    t = _Tree()
    jA = t.joint(0, pin.JointModelRZ(), fb.A, "A")
    jB = t.joint(jA, pin.JointModelRZ(), fb.B0, "B")
    jC = t.joint(jB, pin.JointModelRZ(), fb.C0, "C")
    fP = t.frame(jB, fb.P0, "P")
    fC = t.frame(jC, fb.C0, "RC")
    fD = t.frame(jC, fb.D, "Dtip")
    t.done()
    return _Loop(t, fD, None, fb.D, [1, 2], 2), fP, fC


def _fourbar_run(loop: _Loop, fP: int, fC: int, fb: mx.FourBar):
    inc = fb.crank_angles() - fb.theta0
    n = len(inc)
    pin, m, d = loop.pin, loop.model, loop.data

    def run():
        loop.q[:] = 0.0
        P = np.empty((n, 2))
        C = np.empty((n, 2))
        for k in range(n):
            loop.solve(inc[k])
            pin.updateFramePlacement(m, d, fP)
            pin.updateFramePlacement(m, d, fC)
            P[k] = d.oMf[fP].translation[:2]
            C[k] = d.oMf[fC].translation[:2]
        return C, P

    return run


def _fourbar_outputs(fb: mx.FourBar):
    def outputs(res):
        C, P = res
        return {"rocker": np.arctan2(C[:, 1] - fb.D[1], C[:, 0] - fb.D[0]), "P": P}

    return outputs


def case_fourbar(ctx) -> CaseRun:
    fb = mx.FOURBAR
    loop, fP, fC = _fourbar_loop(fb)
    return CaseRun(_fourbar_run(loop, fP, fC, fb), _fourbar_outputs(fb), postures=mx.NSTEPS)


def case_fourbar_rates(ctx) -> CaseRun:
    fb = mx.FOURBAR
    loop, _, fC = _fourbar_loop(fb)
    pin, m, d = loop.pin, loop.model, loop.data
    inc = fb.crank_angles() - fb.theta0
    n = len(inc)
    w, a = mx.OMEGA, mx.ALPHA
    zero = np.zeros(m.nv)

    def run():
        loop.q[:] = 0.0
        C = np.empty((n, 2))
        qd_all = np.empty((n, 3))
        qdd_all = np.empty((n, 3))
        for k in range(n):
            loop.solve(inc[k])
            J = loop.jacobian()
            Jp = J[:, 1:3]
            qd = np.empty(3)
            qd[0] = w
            qd[1:] = np.linalg.solve(Jp, -J[:, 0] * w)
            pin.forwardKinematics(m, d, loop.q, qd, zero)
            bias = pin.getFrameClassicalAcceleration(m, d, loop.fa, loop.LWA).linear[:2]
            qdd = np.empty(3)
            qdd[0] = a
            qdd[1:] = np.linalg.solve(Jp, -J[:, 0] * a - bias)
            pin.updateFramePlacement(m, d, fC)
            C[k] = d.oMf[fC].translation[:2]
            qd_all[k] = qd
            qdd_all[k] = qdd
        return C, qd_all, qdd_all

    def outputs(res):
        C, qd, qdd = res
        return {"rocker": np.arctan2(C[:, 1] - fb.D[1], C[:, 0] - fb.D[0]),
                "rocker_rate": qd.sum(1), "rocker_accel": qdd.sum(1)}

    return CaseRun(run, outputs, postures=n)


def case_slider(ctx) -> CaseRun:
    import pinocchio as pin

    sc = mx.SLIDER
    t = _Tree()
    jA = t.joint(0, pin.JointModelRZ(), (0.0, 0.0), "A")
    jB = t.joint(jA, pin.JointModelRZ(), sc.B0, "B")
    jS = t.joint(0, pin.JointModelPX(), sc.C0, "S")
    fP = t.frame(jB, sc.P0, "P")
    fCt = t.frame(jB, sc.C0, "Ctip")
    fCp = t.frame(jS, sc.C0, "Cpin")
    t.done()
    loop = _Loop(t, fCt, fCp, None, [1, 2], 2)
    m, d = loop.model, loop.data
    inc = sc.crank_angles() - sc.theta0
    n = len(inc)

    def run():
        loop.q[:] = 0.0
        S = np.empty(n)
        P = np.empty((n, 2))
        for k in range(n):
            loop.solve(inc[k])
            pin.updateFramePlacement(m, d, fP)
            S[k] = d.oMf[fCp].translation[0]
            P[k] = d.oMf[fP].translation[:2]
        return S, P

    def outputs(res):
        return {"slider": res[0], "P": res[1]}

    return CaseRun(run, outputs, postures=n)


def case_rssr(ctx) -> CaseRun:
    import pinocchio as pin

    rs = mx.RSSR_MECH
    D = np.asarray(rs.D)
    t = _Tree()
    jA = t.joint(0, pin.JointModelRZ(), (0.0, 0.0, 0.0), "A")
    jB = t.joint(jA, pin.JointModelSpherical(), rs.B0, "B")
    jD = t.joint(0, pin.JointModelRX(), D, "D")
    fCt = t.frame(jB, rs.C0, "Ctip")
    fRC = t.frame(jD, rs.C0, "RC")
    t.done()
    loop = _Loop(t, fCt, fRC, None, [1, 2, 3, 4], 3)  # v: A 0, ball 1-3, D 4
    inc = rs.crank_angles() - rs.theta0
    n = len(inc)
    d = loop.data
    q0 = pin.neutral(loop.model)

    def run():
        loop.q[:] = q0
        Cs = np.empty((n, 3))
        for k in range(n):
            loop.solve(inc[k])
            Cs[k] = d.oMf[fRC].translation
        return Cs

    def outputs(Cs):
        return {"rocker": np.arctan2(Cs[:, 2] - D[2], Cs[:, 1] - D[1]), "C": Cs}

    return CaseRun(run, outputs, postures=n, note="minimum-norm Newton (spherical joint)")


def _chain_tree(ch: mx.SerialChain6R, dyn: mx.Chain6RDynamics | None = None):
    import pinocchio as pin

    kinds = {0: pin.JointModelRX, 1: pin.JointModelRY, 2: pin.JointModelRZ}
    t = _Tree()
    parent = 0
    for i in range(6):
        ax = ch.axes[i]
        k = int(np.argmax(np.abs(ax)))
        jm = kinds[k]() if np.isclose(ax[k], 1.0) else pin.JointModelRevoluteUnaligned(ax)
        inertia = None if dyn is None else (dyn.masses[i], dyn.centres[i], dyn.inertia(i))
        parent = t.joint(parent, jm, ch.origins[i], f"J{i + 1}", inertia)
    fP = t.frame(parent, ch.P0, "P")
    if dyn is not None:
        t.model.gravity = pin.Motion(np.asarray(dyn.gravity, float), np.zeros(3))
    t.done()
    return t, fP


def case_chain(ctx) -> CaseRun:
    import pinocchio as pin

    ch = mx.CHAIN6R
    t, fP = _chain_tree(ch)
    m, d = t.model, t.data
    q = ch.joint_values()
    n = q.shape[0]

    def run():
        out = np.empty((n, 3))
        for k in range(n):
            pin.forwardKinematics(m, d, q[k])
            pin.updateFramePlacement(m, d, fP)
            out[k] = d.oMf[fP].translation
        return out

    def outputs(out):
        return {"P": out}

    return CaseRun(run, outputs, postures=n)


def case_chain_dynamics(ctx) -> CaseRun:
    """pinocchio.rnea(model, data, q, v, a) per posture, called from Python."""
    import pinocchio as pin

    cd = mx.CHAIN6R_DYN
    t, _ = _chain_tree(cd.chain, cd)
    m, d = t.model, t.data
    _, q, qd, qdd = cd.motion()
    n = q.shape[0]
    rnea = pin.rnea

    def run():
        out = np.empty((n, 6))
        for k, (qk, vk, ak) in enumerate(zip(q, qd, qdd)):
            out[k] = rnea(m, d, qk, vk, ak)
        return out

    def outputs(out):
        return {"tau": out}

    return CaseRun(run, outputs, postures=n, note="rnea per posture from Python")


def case_batch(ctx) -> CaseRun:
    variants = mx.fourbar_variants(ctx.nvariants)
    runs, outs = [], []
    for fb in variants:
        loop, fP, fC = _fourbar_loop(fb)
        runs.append(_fourbar_run(loop, fP, fC, fb))
        outs.append(_fourbar_outputs(fb))
    return per_variant_batch(runs, outs)


CASES = {
    "fourbar": case_fourbar,
    "fourbar_rates": case_fourbar_rates,
    "slider": case_slider,
    "rssr": case_rssr,
    "chain6r": case_chain,
    "batch": case_batch,
    "chain6r_dynamics": case_chain_dynamics,
}

UNSUPPORTED = {
    "fourbar_forces": "not measured: the four-bar is a closed loop (Pinocchio's rnea is for "
                      "trees; the case times openimp against its own kinematic sweep)",
}
