"""Load stages (book 9.5-9.11, 10.5-10.6): gravity, springs, dampers, applied forces and
torques as wrenches on the bodies and loads on the joint variables.

Every load is reduced to what the virtual work of chapter 10 pairs with the
body operators: a wrench (f, n about the global origin) per body, z.Fext,
and a load per joint variable, z.fq (positive when it tends to increase the
variable).  The generalized force of coordinate j is then
sum_b W_{b,j} . Fext_b + sum_h phi'_{h,j} fq_h, which is (10.12) with its sign
turned and (10.13) term by term.  Law values (Python callables, IMP VALUE
expressions) are evaluated outside and handed in per step (z.law).
"""

from __future__ import annotations

import math

import numpy as np

from openimp._jit import njit
from openimp.system import (
    DAMPER,
    FORCE,
    SPRING,
    TORQUE,
    data_views,
    dyn_data_views,
    dyn_views,
    model_views,
)

#: two element points closer than this (internal units) give no direction: skipped
COINCIDENT = 1e-12


@njit(nrt=False)
def point_motion(KP: tuple, DP: tuple, p: int, out: np.ndarray, vel: np.ndarray) -> int:
    """Global position (out) and velocity (vel) of point p; returns its body."""
    K = model_views(KP)
    d = data_views(DP)
    b = K.ptbody[p]
    T = d.T0[b]
    x = K.ptlocal[p]
    for i in range(3):
        out[i] = T[i, 0] * x[0] + T[i, 1] * x[1] + T[i, 2] * x[2] + T[i, 3]
    V = d.V[b]
    vel[0] = V[0] + V[4] * out[2] - V[5] * out[1]
    vel[1] = V[1] + V[5] * out[0] - V[3] * out[2]
    vel[2] = V[2] + V[3] * out[1] - V[4] * out[0]
    return b


@njit(nrt=False)
def unit_between(r1: np.ndarray, r2: np.ndarray, u: np.ndarray) -> float:
    """u = (r1 - r2) / |r1 - r2| and the length |r1 - r2|; u is left unnormalised when
    the points coincide (length below :data:`COINCIDENT`: the caller skips)."""
    ln = 0.0
    for k in range(3):
        u[k] = r1[k] - r2[k]
        ln += u[k] * u[k]
    ln = math.sqrt(ln)
    if ln >= COINCIDENT:
        for k in range(3):
            u[k] /= ln
    return ln


@njit(nrt=False)
def _add_force(F: np.ndarray, f: np.ndarray, s: float, r: np.ndarray) -> None:
    """F += the wrench of the force s f applied at r (f, r x f)."""
    fx, fy, fz = s * f[0], s * f[1], s * f[2]
    F[0] += fx
    F[1] += fy
    F[2] += fz
    F[3] += r[1] * fz - r[2] * fy
    F[4] += r[2] * fx - r[0] * fz
    F[5] += r[0] * fy - r[1] * fx


@njit(nrt=False)
def applied_loads(KP: tuple, DP: tuple, YP: tuple, ZP: tuple, S: tuple
                  ) -> tuple[float, float]:
    """Applied wrenches on the bodies (z.Fext), loads on the joint variables (z.fq), the
    tension or magnitude and power of every element, and the potential energy.

    Gravity: f = m_b g at the centre, (9.12); joint springs, dampers and loads
    (9.13, 9.14, 9.24): fq = f - k (q - q0) - c qd; point springs and dampers
    (9.8, 9.9): tension T = k (l - l0) or c l', -T u on the first end and +T u
    on the second (u from the second end to the first, 9.17); forces (9.25) and
    torques (9.26) along a fixed direction or from one point toward another.
    A law slot >= 0 replaces the linear term by z.law[slot].  An element whose
    two points coincide is skipped (z.eskip).  Needs d.T0 and d.V at S.q, S.qd
    and z.Gb.  Returns the potential energy V = -sum m g.c +
    the linear springs' energies (the law springs have none known) and the
    power of gravity.
    """
    K = model_views(KP)
    d = data_views(DP)
    y = dyn_views(YP)
    z = dyn_data_views(ZP)
    g = y.grav
    P = z.P6
    pe = 0.0
    gp = 0.0
    for b in range(K.order.shape[0]):
        G = z.Gb[b]
        F = z.Fext[b]
        if G[3, 3] == 0.0:  # no mass, no weight
            for k in range(6):
                F[k] = 0.0
            continue
        F[0] = G[3, 3] * g[0]
        F[1] = G[3, 3] * g[1]
        F[2] = G[3, 3] * g[2]
        F[3] = G[1, 3] * g[2] - G[2, 3] * g[1]
        F[4] = G[2, 3] * g[0] - G[0, 3] * g[2]
        F[5] = G[0, 3] * g[1] - G[1, 3] * g[0]
        pe -= G[0, 3] * g[0] + G[1, 3] * g[1] + G[2, 3] * g[2]
        for k in range(6):
            gp += d.V[b, k] * F[k]
    for a in range(S.q.shape[0]):
        dx = S.q[a] - y.qfree[a]
        sl = y.qlaw[a]
        spring = z.law[sl[0]] if sl[0] >= 0 else y.qk[a] * dx
        damp = z.law[sl[1]] if sl[1] >= 0 else y.qc[a] * S.qd[a]
        load = z.law[sl[2]] if sl[2] >= 0 else y.qf[a]
        z.fq[a] = load - spring - damp
        if sl[0] < 0:
            pe += 0.5 * y.qk[a] * dx * dx
    r1 = P[0]
    r2 = P[1]
    v1 = P[2]
    v2 = P[3]
    u = P[4]
    for i in range(y.ekind.shape[0]):
        kind = y.ekind[i]
        z.eskip[i] = False
        z.epower[i] = 0.0
        if kind == SPRING or kind == DAMPER:
            b1 = point_motion(KP, DP, y.ept[i, 0], r1, v1)
            b2 = point_motion(KP, DP, y.ept[i, 1], r2, v2)
            ln = unit_between(r1, r2, u)
            z.elen[i] = ln
            if ln < COINCIDENT:
                z.eskip[i] = True
                z.erate[i] = 0.0
                z.eforce[i] = 0.0
                continue
            rate = 0.0
            for k in range(3):
                rate += u[k] * (v1[k] - v2[k])
            z.erate[i] = rate
            if y.elaw[i] >= 0:
                t = z.law[y.elaw[i]]
            elif kind == SPRING:
                t = y.evalue[i] * (ln - y.efree[i])
                pe += 0.5 * y.evalue[i] * (ln - y.efree[i]) ** 2
            else:
                t = y.evalue[i] * rate
            z.eforce[i] = t
            z.epower[i] = -t * rate
            _add_force(z.Fext[b1], u, -t, r1)
            _add_force(z.Fext[b2], u, t, r2)
            continue
        mag = z.law[y.elaw[i]] if y.elaw[i] >= 0 else y.evalue[i]
        z.eforce[i] = mag
        first = 1 if kind == FORCE else 0
        if y.ept[i, first] >= 0:  # direction from one point toward another
            point_motion(KP, DP, y.ept[i, first], r2, v2)
            point_motion(KP, DP, y.ept[i, first + 1], r1, v1)
            ln = unit_between(r1, r2, u)
            z.elen[i] = ln
            if ln < COINCIDENT:
                z.eskip[i] = True
                continue
        else:
            for k in range(3):
                u[k] = y.edir[i, k]
        b = y.ebody[i]
        if kind == FORCE:
            point_motion(KP, DP, y.ept[i, 0], r1, v1)
            _add_force(z.Fext[b], u, mag, r1)
            z.epower[i] = mag * (u[0] * v1[0] + u[1] * v1[1] + u[2] * v1[2])
        elif kind == TORQUE:
            for k in range(3):
                z.Fext[b, 3 + k] += mag * u[k]
            z.epower[i] = mag * (u[0] * d.V[b, 3] + u[1] * d.V[b, 4] + u[2] * d.V[b, 5])
    return pe, gp
