"""MuJoCo: kinematic trees from MJCF, loop closure solved by a Newton loop in Python.

Each closed mechanism is modelled as a tree cut at one joint (the four-bar at
D, the slider-crank at the slider pin C, the RSSR at the sphere C); a site on
each side of the cut gives the closure residual r(q) = site1 - site2.  At every
step the crank hinge is set, then Newton iterates

    mj_kinematics -> r(q);  mj_comPos, mj_jacSite -> J = d r / d q(passive);
    solve J dq = -r (minimum-norm for the RSSR, whose coupler spin is idle),

from the previous posture until |r| < 1e-12.  Case (b) adds the velocity
(J qd = 0) and acceleration (J qdd = -Jdot qd, with mj_comVel + mj_jacDot)
solutions.  The 6R chain is plain forward kinematics (mj_kinematics).
All bodies are at the modeling posture when qpos = 0 (MJCF positions are the
global geometry of benchmarks.mechanisms).
"""

from __future__ import annotations

import numpy as np

from benchmarks import mechanisms as mx
from benchmarks.harness import CaseRun, per_variant_batch

NAME = "mujoco"
TOL = 1e-12
MAXIT = 25
_INERTIAL = '<inertial pos="0 0 0" mass="1" diaginertia="0.1 0.1 0.1"/>'


def version() -> str:
    import mujoco

    return mujoco.__version__


def _v(p) -> str:
    p = np.asarray(p, float)
    if p.shape[0] == 2:
        p = np.array([p[0], p[1], 0.0])
    return " ".join(repr(float(x)) for x in p)


def fourbar_xml(fb: mx.FourBar) -> str:
    A, B, C, D, P = fb.A, fb.B0, fb.C0, fb.D, fb.P0
    return f"""
<mujoco model="fourbar"><compiler angle="radian"/><worldbody>
 <body name="crank" pos="{_v(A)}"><joint name="A" type="hinge" axis="0 0 1"/>{_INERTIAL}
  <body name="coupler" pos="{_v(B - A)}"><joint name="B" type="hinge" axis="0 0 1"/>{_INERTIAL}
   <site name="P" pos="{_v(P - B)}"/>
   <body name="rocker" pos="{_v(C - B)}"><joint name="C" type="hinge" axis="0 0 1"/>{_INERTIAL}
    <site name="RC" pos="0 0 0"/><site name="Dtip" pos="{_v(D - C)}"/>
   </body></body></body>
</worldbody></mujoco>"""


class _Loop:
    """Newton on the closure residual of a MuJoCo tree (driver = qpos[0], hinge)."""

    def __init__(self, xml: str, site_a: str, site_b: str | None, target, passive: list[int],
                 ndim: int):
        import mujoco

        self.mj = mujoco
        self.m = mujoco.MjModel.from_xml_string(xml)
        self.d = mujoco.MjData(self.m)
        self.sa = self.m.site(site_a).id
        self.sb = None if site_b is None else self.m.site(site_b).id
        self.target = None if target is None else np.asarray(target, float)[:ndim]
        self.passive = passive
        self.ndim = ndim
        nv = self.m.nv
        self.Ja = np.zeros((3, nv))
        self.Jb = np.zeros((3, nv))

    def residual(self) -> np.ndarray:
        x = self.d.site_xpos
        r = x[self.sa] - (x[self.sb] if self.sb is not None else 0.0)
        r = r[: self.ndim]
        return r - self.target if self.target is not None else r

    def jacobian(self) -> np.ndarray:
        mj, m, d = self.mj, self.m, self.d
        mj.mj_jacSite(m, d, self.Ja, None, self.sa)
        J = self.Ja
        if self.sb is not None:
            mj.mj_jacSite(m, d, self.Jb, None, self.sb)
            J = self.Ja - self.Jb
        return J[: self.ndim]

    def solve(self, q_driver: float) -> int:
        """Newton from the current posture with qpos[0] = q_driver (hinge, nq = nv order)."""
        mj, m, d = self.mj, self.m, self.d
        d.qpos[0] = q_driver
        cols = self.passive
        for it in range(MAXIT):
            mj.mj_kinematics(m, d)
            r = self.residual()
            if np.max(np.abs(r)) < TOL:
                return it
            mj.mj_comPos(m, d)  # the Jacobian needs cdof and subtree_com
            J = self.jacobian()[:, cols]
            if J.shape[0] == J.shape[1]:
                d.qpos[cols] -= np.linalg.solve(J, r)
            else:  # minimum-norm step (idle freedoms), then integrate (quaternions)
                dv = np.zeros(m.nv)
                dv[cols] = -J.T @ np.linalg.solve(J @ J.T, r)
                mj.mj_integratePos(m, d.qpos, dv, 1.0)
        raise RuntimeError(f"MuJoCo Newton did not converge at driver {q_driver}")


def _fourbar_loop(fb: mx.FourBar) -> _Loop:
    return _Loop(fourbar_xml(fb), "Dtip", None, fb.D, [1, 2], 2)


def _fourbar_run(loop: _Loop, fb: mx.FourBar):
    inc = fb.crank_angles() - fb.theta0
    n = len(inc)
    sP, sC = loop.m.site("P").id, loop.m.site("RC").id

    def run():
        loop.d.qpos[:] = 0.0
        P = np.empty((n, 2))
        C = np.empty((n, 2))
        for k in range(n):
            loop.solve(inc[k])
            P[k] = loop.d.site_xpos[sP, :2]
            C[k] = loop.d.site_xpos[sC, :2]
        return C, P

    return run


def _fourbar_outputs(fb: mx.FourBar):
    def outputs(res):
        C, P = res
        return {"rocker": np.arctan2(C[:, 1] - fb.D[1], C[:, 0] - fb.D[0]), "P": P}

    return outputs


def case_fourbar(ctx) -> CaseRun:
    fb = mx.FOURBAR
    loop = _fourbar_loop(fb)
    return CaseRun(_fourbar_run(loop, fb), _fourbar_outputs(fb), postures=mx.NSTEPS)


def case_fourbar_rates(ctx) -> CaseRun:
    fb = mx.FOURBAR
    loop = _fourbar_loop(fb)
    mj, m, d = loop.mj, loop.m, loop.d
    inc = fb.crank_angles() - fb.theta0
    n = len(inc)
    sC = m.site("RC").id
    sD = m.site("Dtip").id
    body = m.site_bodyid[sD]
    Jd = np.zeros((3, m.nv))
    w, a = mx.OMEGA, mx.ALPHA

    def run():
        d.qpos[:] = 0.0
        C = np.empty((n, 2))
        qd_all = np.empty((n, 3))
        qdd_all = np.empty((n, 3))
        for k in range(n):
            loop.solve(inc[k])
            mj.mj_comPos(m, d)
            J = loop.jacobian()  # at the converged posture
            Jp = J[:, 1:3]
            qd = np.empty(3)
            qd[0] = w
            qd[1:] = np.linalg.solve(Jp, -J[:, 0] * w)
            d.qvel[:] = qd
            mj.mj_comVel(m, d)
            mj.mj_jacDot(m, d, Jd, None, d.site_xpos[sD], body)
            bias = Jd[:2] @ qd
            qdd = np.empty(3)
            qdd[0] = a
            qdd[1:] = np.linalg.solve(Jp, -J[:, 0] * a - bias)
            C[k] = d.site_xpos[sC, :2]
            qd_all[k] = qd
            qdd_all[k] = qdd
        return C, qd_all, qdd_all

    def outputs(res):
        C, qd, qdd = res
        # planar chain: the rocker's absolute rate is the sum of the hinge rates
        return {"rocker": np.arctan2(C[:, 1] - fb.D[1], C[:, 0] - fb.D[0]),
                "rocker_rate": qd.sum(1), "rocker_accel": qdd.sum(1)}

    return CaseRun(run, outputs, postures=n)


def case_slider(ctx) -> CaseRun:
    sc = mx.SLIDER
    B, C, P = sc.B0, sc.C0, sc.P0
    xml = f"""
<mujoco model="slider"><compiler angle="radian"/><worldbody>
 <body name="crank" pos="0 0 0"><joint name="A" type="hinge" axis="0 0 1"/>{_INERTIAL}
  <body name="rod" pos="{_v(B)}"><joint name="B" type="hinge" axis="0 0 1"/>{_INERTIAL}
   <site name="P" pos="{_v(P - B)}"/><site name="Ctip" pos="{_v(C - B)}"/>
  </body></body>
 <body name="slider" pos="{_v(C)}"><joint name="S" type="slide" axis="1 0 0"/>{_INERTIAL}
  <site name="Cpin" pos="0 0 0"/></body>
</worldbody></mujoco>"""
    loop = _Loop(xml, "Ctip", "Cpin", None, [1, 2], 2)
    inc = sc.crank_angles() - sc.theta0
    n = len(inc)
    sP, sS = loop.m.site("P").id, loop.m.site("Cpin").id

    def run():
        loop.d.qpos[:] = 0.0
        S = np.empty(n)
        Pk = np.empty((n, 2))
        for k in range(n):
            loop.solve(inc[k])
            S[k] = loop.d.site_xpos[sS, 0]
            Pk[k] = loop.d.site_xpos[sP, :2]
        return S, Pk

    def outputs(res):
        return {"slider": res[0], "P": res[1]}

    return CaseRun(run, outputs, postures=n)


def case_rssr(ctx) -> CaseRun:
    rs = mx.RSSR_MECH
    B, C, D = rs.B0, rs.C0, np.asarray(rs.D)
    xml = f"""
<mujoco model="rssr"><compiler angle="radian"/><worldbody>
 <body name="crank" pos="0 0 0"><joint name="A" type="hinge" axis="0 0 1"/>{_INERTIAL}
  <body name="coupler" pos="{_v(B)}"><joint name="B" type="ball"/>{_INERTIAL}
   <site name="Ctip" pos="{_v(C - B)}"/></body></body>
 <body name="rocker" pos="{_v(D)}"><joint name="D" type="hinge" axis="1 0 0"/>{_INERTIAL}
  <site name="RC" pos="{_v(C - D)}"/></body>
</worldbody></mujoco>"""
    loop = _Loop(xml, "Ctip", "RC", None, [1, 2, 3, 4], 3)  # dofs: ball 1-3, rocker 4
    inc = rs.crank_angles() - rs.theta0
    n = len(inc)
    sC = loop.m.site("RC").id
    q0 = loop.d.qpos.copy()  # ball quaternion (1, 0, 0, 0)

    def run():
        loop.d.qpos[:] = q0
        Cs = np.empty((n, 3))
        for k in range(n):
            loop.solve(inc[k])
            Cs[k] = loop.d.site_xpos[sC]
        return Cs

    def outputs(Cs):
        return {"rocker": np.arctan2(Cs[:, 2] - D[2], Cs[:, 1] - D[1]), "C": Cs}

    return CaseRun(run, outputs, postures=n, note="minimum-norm Newton (ball joint)")


def chain_xml(ch: mx.SerialChain6R, dyn: mx.Chain6RDynamics | None = None) -> str:
    """The 6R chain; with ``dyn`` its link masses (fullinertia about the centre, body
    axes = global axes at q = 0) and gravity."""
    opt = "" if dyn is None else f'<option gravity="{_v(dyn.gravity)}"/>'
    xml = f'<mujoco model="6R"><compiler angle="radian"/>{opt}<worldbody>'
    prev = np.zeros(3)
    for i in range(6):
        o = ch.origins[i]
        inertial = _INERTIAL
        if dyn is not None:
            I = dyn.inertia(i)
            full = [I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2]]
            inertial = (f'<inertial pos="{_v(dyn.centres[i] - o)}" mass="{dyn.masses[i]!r}" '
                        f'fullinertia="{" ".join(repr(float(x)) for x in full)}"/>')
        xml += (f'<body name="L{i + 1}" pos="{_v(o - prev)}">'
                f'<joint name="J{i + 1}" type="hinge" axis="{_v(ch.axes[i])}"/>{inertial}')
        prev = o
    xml += f'<site name="P" pos="{_v(ch.P0 - prev)}"/>' + "</body>" * 6 + "</worldbody></mujoco>"
    return xml


def case_chain(ctx) -> CaseRun:
    import mujoco

    ch = mx.CHAIN6R
    m = mujoco.MjModel.from_xml_string(chain_xml(ch))
    d = mujoco.MjData(m)
    sP = m.site("P").id
    q = ch.joint_values()
    n = q.shape[0]

    def run():
        out = np.empty((n, 3))
        for k in range(n):
            d.qpos[:] = q[k]
            mujoco.mj_kinematics(m, d)
            out[k] = d.site_xpos[sP]
        return out

    def outputs(out):
        return {"P": out}

    return CaseRun(run, outputs, postures=n)


def case_chain_dynamics(ctx) -> CaseRun:
    """mj_inverse per posture (qpos, qvel, qacc -> qfrc_inverse), called from Python."""
    import mujoco

    cd = mx.CHAIN6R_DYN
    m = mujoco.MjModel.from_xml_string(chain_xml(cd.chain, cd))
    d = mujoco.MjData(m)
    _, q, qd, qdd = cd.motion()
    n = q.shape[0]
    inverse = mujoco.mj_inverse
    qpos, qvel, qacc, qfrc = d.qpos, d.qvel, d.qacc, d.qfrc_inverse

    def run():
        out = np.empty((n, 6))
        for k in range(n):
            qpos[:] = q[k]
            qvel[:] = qd[k]
            qacc[:] = qdd[k]
            inverse(m, d)
            out[k] = qfrc
        return out

    def outputs(out):
        return {"tau": out}

    return CaseRun(run, outputs, postures=n, note="mj_inverse per posture from Python")


def case_batch(ctx) -> CaseRun:
    variants = mx.fourbar_variants(ctx.nvariants)
    runs = [_fourbar_run(_fourbar_loop(fb), fb) for fb in variants]
    outs = [_fourbar_outputs(fb) for fb in variants]
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
    "fourbar_forces": "not measured: the four-bar is a closed loop (mj_inverse would need the "
                      "loop as an equality constraint; the case times openimp against its own "
                      "kinematic sweep)",
}
