"""Equations of motion at one state (book ch 10): M, c and Q of openimp.dynamics.eom
against finite differences of the energies, and against the force analysis.

References are plain numpy: M from the polarisation of the kinetic energy
T(psi') = 1/2 psi'^T M psi' (exact for a quadratic form); c from Lagrange's
form c = dM/dt psi' - 1/2 d(psi'^T M psi')/dpsi with central differences of
M along the coordinates; Q = -dV/dpsi by central differences of the
potential (no dampers or applied loads in those cases).
"""

from __future__ import annotations

import numpy as np
import pytest

import openimp
from openimp.dynamics.eom import equations

H = 1e-6  # central-difference step (rad); truncation ~H^2, round-off ~1e-16/H


def _fourbar() -> openimp.System:
    m = openimp.Model("four-bar")
    m.add_joint("revolute", "A", "BASE", "CRANK", origin=(0, 0, 0))
    m.add_joint("revolute", "B", "CRANK", "COUPLER", origin=(1, 0, 0))
    m.add_joint("revolute", "C", "COUPLER", "ROCKER", origin=(3, 2, 0))
    m.add_joint("revolute", "D", "ROCKER", "BASE", origin=(4, 0, 0))
    m.add_mass("CRANK", 2.0, (0.5, 0, 0), np.diag([0.1, 0.2, 0.3]))
    m.add_mass("COUPLER", 3.0, (2, 1, 0), np.diag([0.1, 0.2, 0.5]))
    m.add_mass("ROCKER", 1.0, (3.5, 1, 0), np.diag([0.1, 0.2, 0.2]))
    m.set_gravity((0, -9.81, 0))
    m.add_point("P", "COUPLER", (2, 1, 0))
    m.add_point("G", "BASE", (2, 3, 0))
    m.add_spring("S", "P", "G", 100.0, 1.0)
    m.set_joint_spring("D", 5.0, free=0.2)
    return openimp.compile(m)


def _arm() -> openimp.System:
    """A spatial 3R arm: axes not parallel, masses off the axes, gravity, a joint spring."""
    m = openimp.Model("arm")
    m.add_joint("revolute", "J1", "BASE", "L1", origin=(0, 0, 0), axis=(0, 0, 1))
    m.add_joint("revolute", "J2", "L1", "L2", origin=(0.1, 0, 0.5), axis=(0, 1, 0))
    m.add_joint("revolute", "J3", "L2", "L3", origin=(0.6, 0.05, 0.5), axis=(1, 0, 1))
    m.add_mass("L1", 4.0, (0.05, 0.02, 0.25), np.diag([0.2, 0.25, 0.1]))
    R = np.linalg.qr(np.array([[1.0, 0.2, 0.1], [0.3, 1.0, -0.2], [0.1, 0.4, 1.0]]))[0]
    R *= np.sign(np.linalg.det(R))
    m.add_mass("L2", 3.0, (0.35, 0.0, 0.52), np.array([0.05, 0.3, 0.28]), axes=R)
    m.add_mass("L3", 1.5, (0.8, 0.1, 0.55), np.diag([0.02, 0.03, 0.04]))
    m.set_gravity((0.5, -1.0, -9.81))
    m.set_joint_spring("J2", 7.0, free=0.1)
    return openimp.compile(m)


def _posture(system: openimp.System, drive: dict[str, float]) -> np.ndarray:
    tr = openimp.sweep(system, {k: [v] for k, v in drive.items()})
    return np.array(tr.q[0])


def _eq(system, q, rates, spec):
    return equations(system, q, rates, specified=spec)


@pytest.mark.parametrize("which", ["fourbar", "arm"])
def test_mass_matrix_velocity_terms_and_forces_against_energies(which):
    if which == "fourbar":
        system, spec, at = _fourbar(), ["A"], {"A": 0.7}
    else:
        system, spec, at = _arm(), ["J1", "J2", "J3"], {"J1": 0.3, "J2": -0.4, "J3": 1.1}
    rates = {"fourbar": [1.7], "arm": [0.9, -1.3, 2.1]}[which]
    q0 = _posture(system, at)
    e = _eq(system, q0, dict(zip(spec, rates, strict=True)), spec)
    n = len(spec)
    w = np.array(rates)
    # M: polarisation of T(psi') at the same posture (T is exactly quadratic)
    M = np.zeros((n, n))
    for i in range(n):
        for j in range(n):
            def T(v):
                return _eq(system, q0, dict(zip(spec, v, strict=True)), spec).kinetic
            ei, ej = np.eye(n)[i], np.eye(n)[j]
            # T(a + b) - T(a - b) = 2 a^T M b for T(v) = 1/2 v^T M v
            M[i, j] = (T(ei + ej) - T(ei - ej)) / 2.0
    np.testing.assert_allclose(e.M, M, rtol=1e-12, atol=1e-12 * np.abs(M).max())
    # c and Q: central differences along every coordinate (posture re-solved)
    dM = np.zeros((n, n, n))
    dV = np.zeros(n)
    for k in range(n):
        plus = {c: at[c] + (H if i == k else 0.0) for i, c in enumerate(spec)}
        minus = {c: at[c] - (H if i == k else 0.0) for i, c in enumerate(spec)}
        ep = _eq(system, _posture(system, plus), {}, spec)
        em = _eq(system, _posture(system, minus), {}, spec)
        dM[:, :, k] = (ep.M - em.M) / (2 * H)
        dV[k] = (ep.potential - em.potential) / (2 * H)
    Mdot = np.einsum("ijk,k->ij", dM, w)
    c_ref = Mdot @ w - 0.5 * np.einsum("jki,j,k->i", dM, w, w)
    scale = np.abs(c_ref).max() + np.abs(e.M).max() * (w @ w)
    np.testing.assert_allclose(e.c, c_ref, atol=1e-7 * scale)
    np.testing.assert_allclose(e.Q, -dV, atol=1e-7 * (np.abs(dV).max() + 1.0))
    # symmetric positive definite
    np.testing.assert_allclose(e.M, e.M.T, atol=0)
    assert np.all(np.linalg.eigvalsh(e.M) > 0)


def test_drive_equals_force_analysis():
    """The S rows of (10.15) give the drive (11.14): the same as openimp.forces."""
    system = _fourbar()
    th = np.linspace(0.2, 1.2, 6)
    tr = openimp.sweep(system, {"A": th}, rates={"A": 1.3}, accels={"A": -0.8})
    F = openimp.forces_of(tr)
    for k in range(len(th)):
        e = _eq(system, tr.q[k], {"A": 1.3}, ["A"])
        np.testing.assert_allclose(e.drive([-0.8]), F.drive["A.theta"][k],
                                   rtol=1e-11, atol=1e-11)


def test_free_coordinate_acceleration_balances():
    """With nothing specified the elimination picks a free coordinate; its acceleration
    from M_FF psi''_F = Q_F - c_F leaves no drive force on it."""
    system = _fourbar()
    q0 = _posture(system, {"A": 0.5})
    e = equations(system, q0)
    assert e.coords and not e.specified.any()
    a = e.free_accelerations()
    np.testing.assert_allclose(e.drive(a), 0.0, atol=1e-12 * np.abs(e.Q).max())
