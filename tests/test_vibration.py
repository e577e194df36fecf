"""Linearized vibration (book ch 11 and 13): openimp.linearize, modes, transfer_function,
frequency_response and state_space against references written here in plain numpy.

* closed forms: compound and inverted pendulum, a spring-mass-damper slider
  (under- and over-damped), a two-slider chain against scipy.linalg.eigh(K, M)
  of its hand-derived M and K;
* M, D, K, F against finite differences of the residual
  r(psi, psi', psi'') = M psi'' + c - Q of openimp.dynamics.eom.equations over
  closed postures (a planar four-bar with every kind of load, a spatial RSSR,
  a planar five-bar, a gimballed spinning rotor, a four-bar with load laws);
* transfer functions of a spring-mass-damper, of a pendulum's tip and of a
  base excitation against 1/(k - m w^2 + i c w) and (c s + k)/(m s^2 + c s + k);
* the state space's step response against an independent time integration;
* the errors: a massless moving body, no free coordinate, bad inputs.

Relative errors are max|X - X_ref| / max|X_ref| over the whole matrix.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg
import scipy.signal
from scipy.integrate import solve_ivp

import openimp
from helpers.geometry import rssr_geometry, rssr_output
from helpers.models import Rig, build_fivebar
from openimp.dynamics.eom import equations

G = 9.81


def byfreq(lam):
    """Eigenvalues sorted by |Im|, then Im (a conjugate pair stays together)."""
    lam = np.asarray(lam)
    return lam[np.lexsort((lam.imag, np.round(np.abs(lam.imag), 9)))]


def rel(x, ref) -> float:
    """max |x - ref| / max |ref|."""
    x, ref = np.asarray(x), np.asarray(ref)
    return float(np.abs(x - ref).max() / np.abs(ref).max())


# ------------------------------------------------------------------------------- models
def pendulum(inverted: bool = False, damper: float = 0.0, massless_link: bool = False):
    """A uniform rod (mass 3, length 1.2) on revolute A about z, hanging along -y (or
    standing along +y); a tip point T; a torque element TQ about z."""
    L, m = 1.2, 3.0
    sg = 1.0 if inverted else -1.0
    md = openimp.Model("pendulum")
    md.add_joint("revolute", "A", "BASE", "ROD", origin=(0, 0, 0))
    md.add_mass("ROD", m, (0, sg * L / 2, 0), np.diag([m * L**2 / 12, 0, m * L**2 / 12]))
    md.set_gravity((0, -G, 0))
    md.add_point("T", "ROD", (0, sg * L, 0))
    md.add_torque("TQ", "ROD", 0.0, direction=(0, 0, 1))  # per unit magnitude
    if damper:
        md.set_joint_damper("A", damper)
    if massless_link:
        md.add_joint("revolute", "B", "ROD", "LINK2", origin=(0, sg * L, 0))
        md.add_point("E", "LINK2", (0.5, sg * L, 0))
    return openimp.compile(md), L, m


def smd(m: float, k: float, c: float):
    """Block B (mass m) on prismatic X along x, point spring k and damper c to the
    ground along x (free length 1 at X = 0), a unit force F on the block along x."""
    md = openimp.Model("smd")
    md.add_joint("prismatic", "X", "BASE", "B", origin=(0, 0, 0), axis=(1, 0, 0))
    md.add_mass("B", m, (0, 0, 0), np.diag([1.0, 1.0, 1.0]))
    md.add_point("P", "B", (0, 0, 0))
    md.add_point("O", "BASE", (-1, 0, 0))
    md.add_spring("S", "P", "O", k, 1.0)
    md.add_damper("C", "P", "O", c)
    md.add_force("F", "P", 1.0, direction=(1, 0, 0))
    return openimp.compile(md)


def chain(m1, m2, k1, k2, c1=0.0, c2=0.0):
    """Two sliders in series along x: X1 (BASE -> B1, absolute x1), X2 (B1 -> B2, x2 - x1);
    springs k1 ground-B1 and k2 B1-B2 (dampers c1, c2 beside them), a unit force F on B2."""
    md = openimp.Model("chain")
    md.add_joint("prismatic", "X1", "BASE", "B1", origin=(0, 0, 0), axis=(1, 0, 0))
    md.add_joint("prismatic", "X2", "B1", "B2", origin=(1, 0, 0), axis=(1, 0, 0))
    md.add_mass("B1", m1, (0, 0, 0), np.diag([1.0, 1.0, 1.0]))
    md.add_mass("B2", m2, (1, 0, 0), np.diag([1.0, 1.0, 1.0]))
    md.add_point("O", "BASE", (-1, 0, 0))
    md.add_point("P1", "B1", (0, 0, 0))
    md.add_point("P2", "B2", (1, 0, 0))
    md.add_spring("S1", "P1", "O", k1, 1.0)
    md.add_spring("S2", "P2", "P1", k2, 1.0)
    if c1:
        md.add_damper("C1", "P1", "O", c1)
    if c2:
        md.add_damper("C2", "P2", "P1", c2)
    md.add_force("F", "P2", 1.0, direction=(1, 0, 0))
    return openimp.compile(md)


def chain_hand(m1, m2, k1, k2, c1=0.0, c2=0.0):
    """Hand M, D, K of :func:`chain` in (X1, X2): x_B1 = q1, x_B2 = q1 + q2, so
    T = m1 q1'^2/2 + m2 (q1' + q2')^2/2, V = k1 q1^2/2 + k2 q2^2/2; the force on B2 has
    generalized direction (1, 1)."""
    M = np.array([[m1 + m2, m2], [m2, m2]])
    return M, np.diag([c1, c2]), np.diag([k1, k2]), np.array([1.0, 1.0])


def fourbar(law: str | None = None, with_damper: bool = True):
    """The four-bar of tests/test_eom.py with gravity, a point spring S (or a cubic spring
    law), a joint spring on D, a joint damper on B, a point damper DA (or a cubic damper
    law, or none), a follower force FF at P from K toward R and a torque T."""
    m = openimp.Model("four-bar")
    m.add_joint("revolute", "A", "BASE", "CRANK", origin=(0, 0, 0))
    m.add_joint("revolute", "B", "CRANK", "COUPLER", origin=(1, 0, 0))
    m.add_joint("revolute", "C", "COUPLER", "ROCKER", origin=(3, 2, 0))
    m.add_joint("revolute", "D", "ROCKER", "BASE", origin=(4, 0, 0))
    m.add_mass("CRANK", 2.0, (0.5, 0, 0), np.diag([0.1, 0.2, 0.3]))
    m.add_mass("COUPLER", 3.0, (2, 1, 0), np.diag([0.1, 0.2, 0.5]))
    m.add_mass("ROCKER", 1.0, (3.5, 1, 0), np.diag([0.1, 0.2, 0.2]))
    m.set_gravity((0, -G, 0))
    for name, body, xyz in (("P", "COUPLER", (2, 1, 0)), ("G", "BASE", (2, 3, 0)),
                            ("R", "ROCKER", (3.6, 1.2, 0)), ("H", "BASE", (5, -1, 0)),
                            ("K", "CRANK", (0.8, 0.1, 0))):
        m.add_point(name, body, xyz)
    if law is None:
        m.add_spring("S", "P", "G", 100.0, 1.0)
        if with_damper:
            m.add_damper("DA", "R", "H", 2.5)
    else:
        m.add_spring("S", "P", "G", law=lambda s: 100.0 * (s.x - 1.0) + 40.0 * (s.x - 1.0) ** 3)
        if with_damper:
            m.add_damper("DA", "R", "H", law=damper_law)
    m.set_joint_spring("D", 5.0, free=0.2)
    m.set_joint_damper("B", 0.3)
    m.add_force("FF", "P", 7.0, along=("K", "R"))
    m.add_torque("T", "ROCKER", 3.0, direction=(0, 0, 1))
    return openimp.compile(m)


def damper_law(s):
    """Tension of the nonlinear damper DA of the law four-bar: 2 l' + 0.7 l'^3."""
    return 2.0 * s.xd + 0.7 * s.xd**3


def rssr(universal: bool = True):
    """The spatial RSSR of tests/test_kinematics.py (crank A, ball B, ball C, rocker D on
    a skew axis) with masses, gravity, a point spring, a joint spring and damper on D.
    ``universal``: C is a universal joint (pins normal to the coupler and along the
    rocker axis), an RSUR of mobility 1 whose coordinates are angles; with the ball the
    coupler's passive spin is a free coordinate, an Euler-Rodrigues parameter, which a
    sweep cannot drive (so postures cannot be closed along it for the K reference)."""
    g = rssr_geometry()
    th0 = 0.6
    _, B0, C0 = rssr_output(g, th0, +1)
    rig = Rig("rssr")
    rig.pin("A", "BASE", "CRANK", np.zeros(3), (0, 0, 1), (1, 0, 0))
    rig.ball("B", "CRANK", "COUPLER", B0)
    if universal:
        a1 = np.cross(g["w2"], C0 - B0)
        a1 /= np.linalg.norm(a1)
        rig.m.add_joint("universal", "C", "COUPLER", "ROCKER", origin=C0, axis=a1,
                        axis2=g["w2"], ref=g["w2"], ref2=a1)
    else:
        rig.ball("C", "COUPLER", "ROCKER", C0)
    rig.pin("D", "BASE", "ROCKER", g["D0"], g["w2"], g["u2"], ref2=C0 - g["D0"])
    m = rig.m
    m.add_mass("CRANK", 1.0, 0.5 * B0, np.diag([0.05, 0.06, 0.08]))
    m.add_mass("COUPLER", 2.0, 0.5 * (B0 + C0), np.diag([0.3, 0.25, 0.2]))
    m.add_mass("ROCKER", 1.5, 0.5 * (C0 + g["D0"]), np.diag([0.1, 0.12, 0.09]))
    m.set_gravity((0.3, -1.0, -G))
    m.add_point("PC", "COUPLER", 0.3 * B0 + 0.7 * C0)
    m.add_point("PK", "CRANK", 0.8 * B0)
    m.add_point("GS", "BASE", (1.0, 2.0, 3.0))
    m.add_spring("S", "PC", "GS", 40.0, 1.5)
    m.add_damper("DS", "PK", "GS", 0.6)
    m.set_joint_spring("D", 8.0, free=0.3)
    m.set_joint_damper("D", 0.4)
    m.add_force("FF", "PC", 5.0, along=("PK", "GS"))
    return openimp.compile(m)


def fivebar():
    """The planar five-bar of tests/test_kinematics.py (2 DOF) with masses, gravity, a
    point spring and damper from the coupler joint to the ground, a joint spring."""
    rig, _ = build_fivebar()
    m = rig.m
    for body, c in (("K1", (0.3, 0.6)), ("C1", (1.2, 2.4)), ("C2", (2.8, 2.4)),
                    ("K2", (3.8, 0.6))):
        m.add_mass(body, 1.5, (*c, 0), np.diag([0.1, 0.1, 0.2]))
    m.set_gravity((0, -G, 0))
    m.add_point("GS", "BASE", (2.0, 5.0, 0))
    m.add_spring("S", "PC", "GS", 60.0, 1.0)
    m.add_damper("DS", "PC", "GS", 1.5)
    m.set_joint_spring("A", 4.0, free=0.1)
    return openimp.compile(m)


def gimbal(spin: float):
    """A symmetric rotor (spin axis x, I_x = 0.8, I_y = I_z = 0.3) spinning on R about x
    inside an inner gimbal (Y about y, inertia diag(0.05, 0.2, 0.1)) inside an outer gimbal
    (Z about z, inertia diag(0.1, 0.1, 0.4)), every centre at the origin; torsion springs
    kz = 6, ky = 4 on Z and Y.  Returns the system and the hand M, G, K of the gimbal
    angles (z, y) about zero with the spin R specified at rate ``spin``:
    M = diag(I_Zz + I_Yz + I_z, I_Yy + I_y), G = [[0, -H], [H, 0]] sign-free (checked as
    skew with |G_12| = I_x spin), K = diag(kz, ky)."""
    md = openimp.Model("gimbal")
    md.add_joint("revolute", "Z", "BASE", "OUTER", origin=(0, 0, 0), axis=(0, 0, 1))
    md.add_joint("revolute", "Y", "OUTER", "INNER", origin=(0, 0, 0), axis=(0, 1, 0))
    md.add_joint("revolute", "R", "INNER", "ROTOR", origin=(0, 0, 0), axis=(1, 0, 0))
    md.add_mass("OUTER", 1.0, (0, 0, 0), np.diag([0.1, 0.1, 0.4]))
    md.add_mass("INNER", 1.0, (0, 0, 0), np.diag([0.05, 0.2, 0.1]))
    md.add_mass("ROTOR", 2.0, (0, 0, 0), np.diag([0.8, 0.3, 0.3]))
    md.set_joint_spring("Z", 6.0, free=0.0)
    md.set_joint_spring("Y", 4.0, free=0.0)
    M = np.diag([0.4 + 0.1 + 0.3, 0.2 + 0.3])
    return openimp.compile(md), M, 0.8 * spin, np.diag([6.0, 4.0])


def posture(system, drive: dict[str, float], start=None, hold_free=False) -> np.ndarray:
    """The posture closed (to 1e-13) with the joint variables of ``drive`` set."""
    tr = openimp.sweep(system, {k: [v] for k, v in drive.items()}, q=start, tol=1e-13,
                       hold_free=hold_free)
    assert tr.complete, tr.message
    return np.array(tr.q[0])


# ---------------------------------------------------------------- 1. closed forms
def test_compound_pendulum_frequency():
    """omega = sqrt(m g (L/2) / I_pivot), I_pivot = m L^2 / 3; M = I_pivot, K = m g L/2.
    Tolerance 1e-12 relative: exact formulas, round-off only."""
    system, L, m = pendulum()
    lin = openimp.linearize(system)
    Ip, kg = m * L**2 / 3, m * G * L / 2
    assert lin.coords == ["A.theta"] and not lin.specified.any()
    np.testing.assert_allclose(lin.M, [[Ip]], rtol=1e-12)
    np.testing.assert_allclose(lin.K, [[kg]], rtol=1e-12)
    np.testing.assert_allclose(lin.D, 0.0, atol=1e-12)
    np.testing.assert_allclose(lin.F, 0.0, atol=1e-12)
    md = openimp.modes(lin)
    w = np.sqrt(kg / Ip)
    np.testing.assert_allclose(md.frequency, [w], rtol=1e-12)
    np.testing.assert_allclose(md.damping, [0.0], atol=1e-12)
    np.testing.assert_allclose(np.sort(md.eigenvalues.imag), [-w, w], rtol=1e-12)
    assert md.kind == ["oscillatory"] and not md.unstable.any()
    # the same through a System and keyword arguments
    np.testing.assert_allclose(openimp.modes(system).frequency, [w], rtol=1e-12)


def test_inverted_pendulum_unstable():
    """Standing rod: K = -m g L/2, eigenvalues +-sqrt(m g L/2 / I_pivot), real; the growing
    one is flagged unstable with a negative time constant -1/lambda.  1e-12: exact."""
    system, L, m = pendulum(inverted=True)
    md = openimp.modes(system)
    lam = np.sqrt(m * G * L / 2 / (m * L**2 / 3))
    np.testing.assert_allclose(np.sort(md.eigenvalues.real), [-lam, lam], rtol=1e-12)
    np.testing.assert_allclose(md.eigenvalues.imag, 0.0, atol=1e-12)
    assert md.kind == ["overdamped", "overdamped"]
    k = int(np.argmax(md.mode_eigenvalue.real))
    assert md.unstable[k] and not md.unstable[1 - k]
    np.testing.assert_allclose(md.time_constant[k], -1.0 / lam, rtol=1e-12)
    np.testing.assert_allclose(md.time_constant[1 - k], 1.0 / lam, rtol=1e-12)
    assert md.time_constant[k] < 0


@pytest.mark.parametrize("m,k,c", [(2.0, 50.0, 3.0), (0.5, 8.0, 0.05)])
def test_spring_mass_damper_frequency_and_damping(m, k, c):
    """omega_n = sqrt(k/m), zeta = c / (2 sqrt(k m)), damped omega_n sqrt(1 - zeta^2).
    1e-12: exact formulas."""
    lin = openimp.linearize(smd(m, k, c))
    np.testing.assert_allclose(lin.M, [[m]], rtol=1e-12)
    np.testing.assert_allclose(lin.D, [[c]], rtol=1e-12)
    np.testing.assert_allclose(lin.K, [[k]], rtol=1e-12)
    md = openimp.modes(lin)
    wn, z = np.sqrt(k / m), c / (2 * np.sqrt(k * m))
    np.testing.assert_allclose(md.frequency, [wn], rtol=1e-12)
    np.testing.assert_allclose(md.damping, [z], rtol=1e-12)
    np.testing.assert_allclose(md.damped, [wn * np.sqrt(1 - z * z)], rtol=1e-12)
    assert md.kind == ["oscillatory"] and not md.unstable.any()


def test_overdamped_time_constants():
    """c > 2 sqrt(k m): two real eigenvalues, the roots of m s^2 + c s + k; time
    constants -1/root.  1e-12: exact."""
    m, k, c = 2.0, 50.0, 40.0
    md = openimp.modes(smd(m, k, c))
    roots = np.sort(np.roots([m, c, k]).real)
    np.testing.assert_allclose(np.sort(md.eigenvalues.real), roots, rtol=1e-12)
    np.testing.assert_allclose(md.eigenvalues.imag, 0.0, atol=1e-12)
    assert md.kind == ["overdamped", "overdamped"] and not md.unstable.any()
    np.testing.assert_allclose(np.sort(md.time_constant), np.sort(-1.0 / roots), rtol=1e-12)
    assert np.all(np.isnan(md.frequency))


def test_two_slider_chain_modes():
    """Eigenvalues +-i w_k with w_k^2 the eigenvalues of eigh(K, M) of the hand matrices;
    mode shapes the hand eigenvectors up to scale (and the joint shapes = the same in
    joint variables).  1e-10: eigen-solvers of a well-conditioned 2 x 2 problem."""
    m1, m2, k1, k2 = 2.0, 1.0, 30.0, 20.0
    system = chain(m1, m2, k1, k2)
    lin = openimp.linearize(system)
    M, _, K, _ = chain_hand(m1, m2, k1, k2)
    assert lin.coords == ["X1.s", "X2.s"]
    np.testing.assert_allclose(lin.M, M, rtol=1e-12)
    np.testing.assert_allclose(lin.K, K, rtol=1e-12, atol=1e-12 * k1)
    w2, V = scipy.linalg.eigh(K, M)
    md = openimp.modes(lin)
    order = np.argsort(md.frequency)
    np.testing.assert_allclose(md.frequency[order], np.sqrt(w2), rtol=1e-10)
    for j, mode in enumerate(order):
        x = md.shapes[:, mode]
        v = V[:, j] / V[np.argmax(np.abs(V[:, j])), j]
        np.testing.assert_allclose(x, v, rtol=1e-10, atol=1e-10)
        np.testing.assert_allclose(md.joint_shapes[:, mode], v, rtol=1e-10, atol=1e-10)


# ------------------------------------------------------------ 2. against the EOM by FD
#: Richardson-extrapolated central differences over closed postures: step 1e-3 (rad or
#: length), truncation O(h^4) ~ 1e-12 x the fifth derivative, round-off ~ 1e-16 / h and
#: the closure tolerance 1e-13 / h ~ 1e-10: together below 1e-9 relative, so 1e-6 leaves
#: three decades.
H_FD = 1e-3
W5 = np.array([1.0, -8.0, 8.0, -1.0]) / 12.0
OFFS = (-2.0, -1.0, 1.0, 2.0)


def fd_reference(system, q0, coords, x0, u, a, spec, extra=None):
    """M, D, K, F of the residual r = M a + c - Q of equations(), over the coordinates
    ``coords`` (values x0 at q0), rates u and accelerations a; every other joint
    variable follows the loops (sweep with all of ``coords`` as drivers from q0).
    ``extra(q, coords, rates) -> (f,)`` adds a residual term written by hand."""
    f = len(coords)

    def r(x, v):
        q = posture(system, dict(zip(coords, x, strict=True)), start=q0)
        e = equations(system, q, dict(zip(coords, v, strict=True)), specified=spec)
        assert e.coords == coords
        out = e.M @ a + e.c - e.Q
        if extra is not None:
            out = out + extra(q, coords, v)
        return out, e

    r0, e0 = r(x0, u)
    K = np.zeros((f, f))
    D = np.zeros((f, f))
    for k in range(f):
        e = np.eye(f)[k] * H_FD
        K[:, k] = sum(w * r(x0 + o * e, u)[0] for w, o in zip(W5, OFFS, strict=True)) / H_FD
        D[:, k] = sum(w * r(x0, u + o * e)[0] for w, o in zip(W5, OFFS, strict=True)) / H_FD
    return e0.M, D, K, -(r0 - e0.M @ a)


def check_against_fd(system, q0, spec, rng, tol, extra=None, scale=1.0):
    """linearize at q0 with random rates and accelerations of every generalized
    coordinate against :func:`fd_reference`; returns the relative errors."""
    coords = openimp.linearize(system, q0, specified=spec).coords
    f = len(coords)
    u = rng.uniform(-1.0, 1.0, f) * scale
    a = rng.uniform(-1.0, 1.0, f) * scale
    lin = openimp.linearize(system, q0, dict(zip(coords, u, strict=True)),
                            dict(zip(coords, a, strict=True)), specified=spec)
    assert lin.coords == coords
    assert list(lin.specified) == [c.split(".")[0] in spec or c in spec for c in coords]
    x0 = np.array([q0[system.var_index(c)] for c in coords])
    M, D, K, F = fd_reference(system, q0, coords, x0, u, a, spec, extra)
    errs = {"M": rel(lin.M, M), "D": rel(lin.D, D), "K": rel(lin.K, K), "F": rel(lin.F, F)}
    assert max(errs.values()) < tol, errs
    return errs


@pytest.mark.parametrize("spec", [(), ("A",)], ids=["free", "crank-specified"])
def test_fourbar_against_fd(spec):
    """Gravity, a point spring, a joint spring, a point and a joint damper, a follower
    force and a torque, at two random postures with random rates and accelerations."""
    system = fourbar()
    rng = np.random.default_rng(11)
    for th in rng.uniform(0.2, 1.4, 2):
        check_against_fd(system, posture(system, {"A": th}), spec, rng, 1e-6)


@pytest.mark.parametrize("spec", [(), ("D",)], ids=["free", "rocker-specified"])
def test_rsur_against_fd(spec):
    """Spatial RSUR (the RSSR with a universal joint at C): Euler-Rodrigues variables in
    the ball, every load kind."""
    system = rssr()
    rng = np.random.default_rng(12)
    q0 = posture(system, {"A": rng.uniform(-0.5, 0.5)})
    check_against_fd(system, q0, spec, rng, 1e-6)


def test_rssr_mass_against_kinetic_energy():
    """The RSSR with two balls, coordinates the crank and the coupler's passive spin (an
    Euler-Rodrigues parameter, dimensionless): 1/2 u^T M u equals the kinetic energy of
    equations() at rates u, and M is the polarisation of it.  1e-12: exact quadratic."""
    system = rssr(universal=False)
    q0 = posture(system, {"A": 0.3}, hold_free=True)
    lin = openimp.linearize(system, q0, specified=("A",))
    coords = lin.coords

    def T(v):
        return equations(system, q0, dict(zip(coords, v, strict=True)),
                         specified=("A",)).kinetic

    M = np.array([[(T(ei + ej) - T(ei - ej)) / 2.0 for ej in np.eye(2)] for ei in np.eye(2)])
    assert rel(lin.M, M) < 1e-12


def test_rssr_mass_damping_force():
    """The RSSR with two balls: coordinates the crank and the coupler's passive spin (an
    Euler-Rodrigues parameter).  M, D and F need no closed postures (D by central
    differences over the rates at the set posture): against equations() to 1e-10
    (D: c - Q quadratic in the rates, the difference is exact up to round-off); K is
    checked on the RSUR above."""
    system = rssr(universal=False)
    rng = np.random.default_rng(17)
    q0 = posture(system, {"A": 0.3}, hold_free=True)
    spec = ("A",)
    coords = openimp.linearize(system, q0, specified=spec).coords
    assert coords[0] == "A.theta" and coords[1].startswith(("B.e", "C.e"))
    u, a = rng.uniform(-1.0, 1.0, 2), rng.uniform(-1.0, 1.0, 2)
    lin = openimp.linearize(system, q0, dict(zip(coords, u, strict=True)),
                            dict(zip(coords, a, strict=True)), specified=spec)

    def r(v):
        e = equations(system, q0, dict(zip(coords, v, strict=True)), specified=spec)
        assert e.coords == coords
        return e.M @ a + e.c - e.Q, e

    e0 = r(u)[1]
    D = np.column_stack([(r(u + 0.5 * e)[0] - r(u - 0.5 * e)[0]) for e in np.eye(2)])
    assert rel(lin.M, e0.M) < 1e-10
    assert rel(lin.D, D) < 1e-10
    assert rel(lin.F, e0.Q - e0.c) < 1e-10


@pytest.mark.parametrize("spec", [(), ("A",), ("A", "E")], ids=["free", "one", "both"])
def test_fivebar_against_fd(spec):
    """Planar five-bar, 2 DOF: both free, one specified, both specified."""
    system = fivebar()
    rng = np.random.default_rng(13)
    q0 = posture(system, {"A": rng.uniform(-0.3, 0.3), "E": rng.uniform(-0.3, 0.3)})
    check_against_fd(system, q0, spec, rng, 1e-6)


def test_spring_law_against_fd():
    """A cubic spring law k (l - l0) + k3 (l - l0)^3 (position-dependent: equations()
    evaluates it at the posture), random rates and accelerations.  1e-5: the law's
    derivatives are differenced inside linearize (Richardson, step 1e-3)."""
    system = fourbar(law="cubic", with_damper=False)
    rng = np.random.default_rng(14)
    q0 = posture(system, {"A": 0.8})
    for spec in ((), ("A",)):
        check_against_fd(system, q0, spec, rng, 1e-5)


def damper_term(system):
    """The generalized force of the damper law DA of :func:`fourbar`, written by hand:
    with l the length R-H, r_DA = T(l') dl/dpsi (the tension pulls R toward H, so it
    opposes dl/dpsi), l' = dl/dpsi . psi'; dl/dpsi_j = u . dR/dpsi_j from a sweep at unit
    rate of psi_j (joint rates phi' e_j, point velocities)."""

    def extra(q, coords, v):
        def ldot(rates):
            tr = openimp.sweep(system, {c: [q[system.var_index(c)]] for c in coords},
                               rates={c: [r] for c, r in zip(coords, rates, strict=True)},
                               q=q, tol=1e-13)
            d = tr.point("R")[0] - tr.point("H")[0]
            return d @ (tr.point_velocity("R")[0] - tr.point_velocity("H")[0]) / np.linalg.norm(d)

        f = len(coords)
        grad = np.array([ldot(np.eye(f)[j]) for j in range(f)])
        ld = grad @ v
        return (2.0 * ld + 0.7 * ld**3) * grad

    return extra


def test_damper_law_against_fd():
    """A cubic damper law 2 l' + 0.7 l'^3 (rate-dependent) and the cubic spring law, at
    random rates: the reference is equations() of the same four-bar without the damper
    plus the damper's term written by hand (:func:`damper_term`), so it does not depend
    on how equations() feeds rates to laws.  1e-5 as for the spring law."""
    system = fourbar(law="cubic")
    ref_system = fourbar(law="cubic", with_damper=False)
    rng = np.random.default_rng(15)
    q0 = posture(system, {"A": 0.8})
    extra = damper_term(system)
    errs = {}
    for spec in ((), ("A",)):
        coords = openimp.linearize(system, q0, specified=spec).coords
        f = len(coords)
        u, a = rng.uniform(-1.0, 1.0, f), rng.uniform(-1.0, 1.0, f)
        lin = openimp.linearize(system, q0, dict(zip(coords, u, strict=True)),
                                dict(zip(coords, a, strict=True)), specified=spec)
        x0 = np.array([q0[system.var_index(c)] for c in coords])
        M, D, K, F = fd_reference(ref_system, q0, coords, x0, u, a, spec, extra)
        errs[spec] = {"M": rel(lin.M, M), "D": rel(lin.D, D), "K": rel(lin.K, K),
                      "F": rel(lin.F, F)}
    assert all(max(e.values()) < 1e-5 for e in errs.values()), errs


def test_equations_feed_rates_to_laws():
    """equations() of a slider with a damper law c l' (c = 3) at rate 2: Q = -6, as with
    the linear damper and as linearize's F."""
    md = openimp.Model("law-slider")
    md.add_joint("prismatic", "X", "BASE", "B", origin=(0, 0, 0), axis=(1, 0, 0))
    md.add_mass("B", 2.0, (0, 0, 0), np.diag([1.0, 1.0, 1.0]))
    md.add_point("P", "B", (0, 0, 0))
    md.add_point("O", "BASE", (-1, 0, 0))
    md.add_damper("C", "P", "O", law=lambda s: 3.0 * s.xd)
    system = openimp.compile(md)
    np.testing.assert_allclose(openimp.linearize(system, None, {"X": 2.0}).F, [-6.0],
                               rtol=1e-12)
    np.testing.assert_allclose(equations(system, None, {"X": 2.0}).Q, [-6.0], rtol=1e-12)


# ------------------------------------------------------------------- 6. gyroscopic
def test_gyroscopic_rotor():
    """A spinning symmetric rotor on a gimbal (spin R specified at rate 30): D is not
    symmetric; its FGC block is the skew gyroscopic matrix +-I_x spin; M, D, K against
    finite differences (1e-6); eigenvalues come in conjugate pairs and equal those of
    det(M s^2 + G s + K) of the hand matrices (1e-9: 4 x 4 eigenvalues)."""
    spin = 30.0
    system, M, h, K = gimbal(spin)
    q0 = system.modeling_q
    lin = openimp.linearize(system, q0, {"R": spin}, specified=("R",))
    assert lin.coords == ["Z.theta", "Y.theta", "R.theta"]
    DFF = lin.block("D", "FF")
    assert abs(DFF[0, 1] - DFF[1, 0]) > 1.0  # not symmetric
    np.testing.assert_allclose(DFF + DFF.T, 0.0, atol=1e-10 * h)
    np.testing.assert_allclose(abs(DFF[0, 1]), h, rtol=1e-12)
    np.testing.assert_allclose(lin.block("M", "FF"), M, rtol=1e-12)
    np.testing.assert_allclose(lin.block("K", "FF"), K, rtol=1e-12, atol=1e-12)
    md = openimp.modes(lin)
    lam = byfreq(md.eigenvalues)
    Gm = DFF / abs(DFF[0, 1]) * h  # the hand gyroscopic matrix with linearize's sign
    Minv = np.linalg.inv(M)
    A = np.block([[-Minv @ Gm, -Minv @ K], [np.eye(2), np.zeros((2, 2))]])
    np.testing.assert_allclose(lam, byfreq(np.linalg.eigvals(A)), rtol=1e-9)
    np.testing.assert_allclose(byfreq(lam.conj()), lam, rtol=1e-9)
    np.testing.assert_allclose(lam.real, 0.0, atol=1e-9 * np.abs(lam).max())
    assert md.kind == ["oscillatory", "oscillatory"]
    # and against finite differences of the equations of motion, off the centred posture
    rng = np.random.default_rng(16)
    q1 = posture(system, {"Z": 0.3, "Y": -0.4, "R": 0.2})
    check_against_fd(system, q1, ("R",), rng, 1e-6, scale=10.0)


# ------------------------------------------------------------ 3. frequency response
def test_spring_mass_damper_frequency_response():
    """H = 1/(k - m w^2 + i c w) from the force F to X, to the point component P.x, and
    i w H, -w^2 H to the velocity and acceleration; frequency_response and
    transfer_function(...)(1j w) both.  1e-10: polynomial evaluation near resonance."""
    m, k, c = 2.0, 50.0, 3.0
    lin = openimp.linearize(smd(m, k, c))
    w = np.linspace(0.0, 20.0, 81)
    H = 1.0 / (k - m * w**2 + 1j * c * w)
    outs = [("position", "X"), ("position", "P.x"), ("velocity", "X.s"), ("accel", "X"),
            ("position", "P.y")]
    fr = openimp.frequency_response(lin, ("force", "F"), outs, w)
    refs = [H, H, 1j * w * H, -(w**2) * H, 0 * H]
    assert fr.H.shape == (w.size, len(outs))
    for j, ref in enumerate(refs):
        np.testing.assert_allclose(fr.H[:, j], ref, rtol=1e-10, atol=1e-12 * np.abs(H).max())
        if j < 4:
            tf = openimp.transfer_function(lin, ("force", "F"), outs[j])
            np.testing.assert_allclose(tf(1j * w), ref, rtol=1e-10,
                                       atol=1e-12 * np.abs(H).max())
    tf = openimp.transfer_function(lin, ("force", "F"), ("position", "X"))
    np.testing.assert_allclose(tf.den, [1.0, c / m, k / m], rtol=1e-12)
    np.testing.assert_allclose(tf.num, [1.0 / m], rtol=1e-12)
    # a load on the joint variable is the same as the force along it
    fl = openimp.frequency_response(lin, ("load", "X"), ("position", "X"), w)
    np.testing.assert_allclose(fl.H[:, 0], H, rtol=1e-10, atol=1e-12 * np.abs(H).max())
    np.testing.assert_allclose(fr.magnitude[:, 0], np.abs(H), rtol=1e-10)


def test_pendulum_tip_response():
    """Torque TQ to the tip point T of the hanging rod with a joint damper c:
    theta/T = 1/(I s^2 + c s + m g L/2); tip x = L theta (it moves along +x for a
    positive theta about z from -y), tip y: no first-order motion.  1e-10."""
    c = 0.7
    system, L, m = pendulum(damper=c)
    lin = openimp.linearize(system)
    Ip, kg = m * L**2 / 3, m * G * L / 2
    w = np.linspace(0.0, 8.0, 41)
    s = 1j * w
    H = 1.0 / (Ip * s**2 + c * s + kg)
    fr = openimp.frequency_response(lin, ("force", "TQ"), [("position", "A"),
                                                           ("position", "T.x"),
                                                           ("position", "T.y")], w)
    np.testing.assert_allclose(fr.H[:, 0], H, rtol=1e-10)
    np.testing.assert_allclose(fr.H[:, 1], L * H, rtol=1e-10)
    np.testing.assert_allclose(fr.H[:, 2], 0.0, atol=1e-12 * np.abs(H).max())
    tf = openimp.transfer_function(lin, ("force", "TQ"), ("position", "T.x"))
    np.testing.assert_allclose(tf(s), L * H, rtol=1e-10)


def base_excitation(relative: bool):
    """A block B (m = 2) tied by a spring k = 50 and a damper c = 3 to a base body BB on a
    driven slider XB (the SGC).  The block's slider X goes from BASE (absolute x) or, if
    ``relative``, from BB (x - x_B)."""
    md = openimp.Model("base")
    md.add_joint("prismatic", "XB", "BASE", "BB", origin=(0, 0, 0), axis=(1, 0, 0))
    md.add_joint("prismatic", "X", "BB" if relative else "BASE", "B", origin=(1, 0, 0),
                 axis=(1, 0, 0))
    md.add_mass("BB", 5.0, (0, 0, 0), np.diag([1.0, 1.0, 1.0]))
    md.add_mass("B", 2.0, (1, 0, 0), np.diag([1.0, 1.0, 1.0]))
    md.add_point("PB", "BB", (0, 0, 0))
    md.add_point("P", "B", (1, 0, 0))
    md.add_spring("S", "P", "PB", 50.0, 1.0)
    md.add_damper("C", "P", "PB", 3.0)
    return openimp.compile(md)


@pytest.mark.parametrize("relative", [False, True], ids=["absolute", "relative"])
def test_base_excitation(relative):
    """x/x_S = (c s + k)/(m s^2 + c s + k) for the block's absolute position (P.x, or X
    when it is absolute); the relative coordinate gives -m s^2/(m s^2 + c s + k) (the
    M_FS path).  frequency_response, transfer_function, and the state space's frequency
    response C (sI - A)^-1 B + D.  1e-10."""
    m, k, c = 2.0, 50.0, 3.0
    lin = openimp.linearize(base_excitation(relative), specified=("XB",))
    w = np.linspace(0.0, 15.0, 31)
    s = 1j * w
    den = m * s**2 + c * s + k
    absolute = (c * s + k) / den
    own = -m * s**2 / den if relative else absolute
    inp = ("motion", "XB")
    fr = openimp.frequency_response(lin, inp, [("position", "P.x"), ("position", "X"),
                                               ("velocity", "P.x"), ("accel", "P.x")], w)
    for j, ref in enumerate([absolute, own, s * absolute, s**2 * absolute]):
        np.testing.assert_allclose(fr.H[:, j], ref, rtol=1e-10, atol=1e-12)
        tf = openimp.transfer_function(lin, inp, fr.outputs[j])
        np.testing.assert_allclose(tf(s), ref, rtol=1e-10, atol=1e-12)
    ss = openimp.state_space(lin, inp, [("position", "P.x"), ("position", "X")])
    for j, ref in enumerate([absolute, own]):
        got = np.array([(ss.C[j] @ np.linalg.solve(si * np.eye(2) - ss.A, ss.B[:, 0]))
                        + ss.D[j, 0] for si in s])
        np.testing.assert_allclose(got, ref, rtol=1e-10, atol=1e-12)
    with pytest.raises(openimp.InputError, match="velocity"):
        openimp.state_space(lin, inp, ("velocity", "P.x"))


# ------------------------------------------------------------------- 4. state space
def test_state_space_step_against_time_integration():
    """Damped two-slider chain, unit step of the force F on B2: scipy.signal.lsim of
    (A, B, C, D) against solve_ivp (rtol 1e-11) of the hand M x'' + D x' + K x = b u,
    outputs X1 position, X2 velocity, P2.x acceleration.  1e-7 of the output's range:
    both integrations are accurate to ~1e-9 (lsim is exact for the zero-order hold of
    a step; solve_ivp's tolerance), the matrices to 1e-12.  The eigenvalues of A are
    those of modes (1e-10)."""
    m1, m2, k1, k2, c1, c2 = 2.0, 1.0, 30.0, 20.0, 0.8, 0.5
    lin = openimp.linearize(chain(m1, m2, k1, k2, c1, c2))
    M, D, K, b = chain_hand(m1, m2, k1, k2, c1, c2)
    outs = [("position", "X1"), ("velocity", "X2"), ("accel", "P2.x")]
    ss = openimp.state_space(lin, ("force", "F"), outs)
    assert ss.A.shape == (4, 4) and ss.B.shape == (4, 1) and ss.C.shape == (3, 4)
    assert ss.states == ["X1.s'", "X2.s'", "X1.s", "X2.s"]
    t = np.linspace(0.0, 4.0, 401)
    _, y, _ = scipy.signal.lsim((ss.A, ss.B, ss.C, ss.D), np.ones_like(t), t)
    Minv = np.linalg.inv(M)

    def rhs(_, z):
        x, v = z[:2], z[2:]
        return np.concatenate([v, Minv @ (b - D @ v - K @ x)])

    sol = solve_ivp(rhs, (0.0, 4.0), np.zeros(4), t_eval=t, rtol=1e-11, atol=1e-13,
                    method="DOP853")
    x, v = sol.y[:2], sol.y[2:]
    acc = Minv @ (b[:, None] - D @ v - K @ x)
    ref = np.stack([x[0], v[1], acc[0] + acc[1]], axis=1)  # P2.x = q1 + q2
    for j in range(3):
        np.testing.assert_allclose(y[:, j], ref[:, j], rtol=0,
                                   atol=1e-7 * np.abs(ref[:, j]).max())
    md = openimp.modes(lin)
    np.testing.assert_allclose(np.sort_complex(np.linalg.eigvals(ss.A)),
                               np.sort_complex(md.eigenvalues), rtol=1e-10)


# ------------------------------------------------------------------------ 5. errors
def test_massless_moving_link_named():
    """A second link without mass on the pendulum: M_FF is singular; modes and the
    responses raise InputError naming LINK2."""
    system, _, _ = pendulum(massless_link=True)
    lin = openimp.linearize(system)
    with pytest.raises(openimp.InputError, match="LINK2"):
        openimp.modes(lin)
    with pytest.raises(openimp.InputError, match="LINK2"):
        openimp.frequency_response(lin, ("force", "TQ"), ("position", "A"), [1.0])
    with pytest.raises(openimp.InputError, match="LINK2"):
        openimp.state_space(lin, ("force", "TQ"), ("position", "A"))
    with pytest.raises(openimp.InputError, match="LINK2"):
        openimp.transfer_function(lin, ("force", "TQ"), ("position", "A"))


def test_no_free_coordinate():
    system, _, _ = pendulum()
    lin = openimp.linearize(system, specified=("A",))
    assert lin.free.size == 0
    for call in (lambda: openimp.modes(lin),
                 lambda: openimp.transfer_function(lin, ("force", "TQ"), ("position", "A")),
                 lambda: openimp.frequency_response(lin, ("force", "TQ"), ("position", "A"),
                                                    [1.0]),
                 lambda: openimp.state_space(lin, ("force", "TQ"), ("position", "A"))):
        with pytest.raises(openimp.AnalysisError, match="free"):
            call()


@pytest.mark.parametrize("inp,out,match", [
    (("force", "NOPE"), ("position", "X"), "NOPE"),
    (("force", "S"), ("position", "X"), "'S'"),  # a spring is not a force element
    (("load", "NOJOINT"), ("position", "X"), "NOJOINT"),
    (("motion", "X"), ("position", "X"), "X.s"),  # not specified
    (("force",), ("position", "X"), "pair"),
    ("F", ("position", "X"), "pair"),
    (("push", "F"), ("position", "X"), "push"),
    (("force", "F"), ("position", "NOPOINT.x"), "NOPOINT"),
    (("force", "F"), ("position", "P"), "P.x"),  # a point without a component
    (("force", "F"), ("displacement", "X"), "displacement"),
    (("force", "F"), ("position", 3), "pair"),
])
def test_bad_inputs_and_outputs(inp, out, match):
    lin = openimp.linearize(smd(2.0, 50.0, 3.0))
    for call in (lambda: openimp.transfer_function(lin, inp, out),
                 lambda: openimp.frequency_response(lin, inp, [out], [1.0]),
                 lambda: openimp.state_space(lin, [inp], [out])):
        with pytest.raises(openimp.InputError, match=match):
            call()


def test_bad_frequencies():
    lin = openimp.linearize(smd(2.0, 50.0, 3.0))
    for w in ([-1.0, 2.0], [np.nan], [[1.0, 2.0]]):
        with pytest.raises(openimp.InputError, match="w must"):
            openimp.frequency_response(lin, ("force", "F"), ("position", "X"), w)


def test_state_and_modes_along_agree_with_linearize():
    """linearize of a State (internal units, its sgc, rates, accelerations and time) is
    linearize with keywords; modes_along over postures and rates is modes of linearize at
    each (the same numbers: 1e-12 relative, one code path compiled in a loop)."""
    system = fivebar()
    q = posture(system, {"A": 0.4, "E": -0.2})
    lin = openimp.linearize(system, q, {"A": 1.5}, {"A": -0.7}, specified=["A"], t=0.25)
    S = openimp.system.make_state(system, system.to_internal(q), 0.25)
    a = system.var_index("A")
    S.sgc[a] = True
    S.qd[a], S.qdd[a] = 1.5, -0.7  # an angle: internal units are model units
    lin2 = openimp.linearize(system, S)
    assert lin2.coords == lin.coords
    for name in ("M", "D", "K", "F"):
        np.testing.assert_allclose(getattr(lin2, name), getattr(lin, name), rtol=1e-12,
                                   atol=1e-12 * np.abs(getattr(lin, name)).max())
    qs = np.array([posture(system, {"A": a0, "E": -0.2}) for a0 in (0.2, 0.4, 0.6)])
    mm = openimp.modes_along(system, qs, {"A": 1.5}, specified=["A"])
    for k in range(3):
        md = openimp.modes(openimp.linearize(system, qs[k], {"A": 1.5}, specified=["A"]))
        osc = np.sort(md.frequency[np.isfinite(md.frequency)])
        np.testing.assert_allclose(mm.frequency[k, :osc.size], osc, rtol=1e-12)
        np.testing.assert_allclose(np.sort_complex(mm.eigenvalues[k]),
                                   np.sort_complex(md.eigenvalues), rtol=1e-12, atol=1e-12)


def test_unassembled_posture_is_refused():
    """A posture whose loops do not close is bad input for linearize (a located
    message, not numbers about a mechanism that is not there); modes_along reports the
    step and goes on with the others."""
    system = fivebar()
    q = posture(system, {"A": 0.4, "E": -0.2})
    bad = q.copy()
    bad[system.var_index("B")] += 0.05
    with pytest.raises(openimp.InputError, match="not an assembled posture"):
        openimp.linearize(system, bad)
    mm = openimp.modes_along(system, np.array([q, bad, q]))
    assert np.isfinite(mm.frequency[[0, 2], 0]).all() and np.isnan(mm.frequency[1]).all()
    assert any("step 1: not an assembled posture" in m for m in mm.messages)


# ---------------------------------------------------------------- review findings


def test_rate_of_a_dependent_variable_and_overspecification_refused():
    """A rate given for a variable the elimination makes dependent would be dropped: an
    input error naming it and the generalized coordinates; so are specified coordinates
    that are not independent."""
    system = fourbar()
    coords = openimp.linearize(system).coords
    dep = next(n for n in ("A", "B", "C", "D") if f"{n}.theta" not in coords)
    with pytest.raises(openimp.InputError, match="not a generalized coordinate"):
        openimp.linearize(system, rates={dep: 10.0})
    with pytest.raises(openimp.InputError, match="not independent"):
        openimp.linearize(fivebar(), specified=["A", "E", "C"])


def test_stiff_chain_transfer_function_coefficients():
    """A two-mass chain with a 1e8 spring beside a unit one (modes at 1 and 1e4 rad/s):
    the rational H(s) equals the direct solution at every frequency, below and above the
    upper mode (1e-8: the coefficients come from roots, not from a difference of
    polynomials, which lost every digit here), and its numerator is exactly c2 s + k2
    times 1/(m1 m2) with round-off terms removed."""
    m1, m2, k1, k2, c1, c2 = 1.0, 1.0, 1e8, 1.0, 1e-3, 1e-3
    lin = openimp.linearize(chain(m1, m2, k1, k2, c1, c2))
    tf = openimp.transfer_function(lin, ("force", "F"), ("position", "X1"))
    w = np.array([0.5, 1.0, 50.0, 1.01e4, 2e4])
    fr = openimp.frequency_response(lin, ("force", "F"), ("position", "X1"), w)
    np.testing.assert_allclose(tf(1j * w), fr.H[:, 0], rtol=1e-8)
    # x1 / F: from the hand M, K, D of the chain: (c2 s + k2) / det(...) / (m1 m2)
    np.testing.assert_allclose(tf.num, [c2, k2], rtol=1e-8)
    M, D, K, b = chain_hand(m1, m2, k1, k2, c1, c2)
    s = 1j * w
    ref = [np.linalg.solve(si**2 * M + si * D + K, b)[0] for si in s]
    np.testing.assert_allclose(fr.H[:, 0], ref, rtol=1e-9)


def test_neutral_mode_is_neutral_not_unstable():
    """The coupler's passive spin between the two balls of the RSSR has no stiffness; its
    K_FF is round-off (1e-14), which must give a neutral mode, not an unstable pair or a
    1e-7 rad/s oscillation."""
    system = rssr(universal=False)
    for a in (0.1, 0.3, 0.5):
        q = posture(system, {"A": a}, hold_free=True)
        md = openimp.modes(openimp.linearize(system, q, specified=("A",)))
        assert md.kind == ["neutral", "neutral"] and not md.unstable.any(), md.to_table()


def test_light_part_on_a_heavy_carriage_is_not_massless():
    """A 1 g rotor (I = 1e-8) on a 10 t carriage (an SGC): M_FF is small but not singular
    (measured against the model's mass, not the carriage's block of M)."""
    md = openimp.Model("heavy")
    md.add_joint("prismatic", "X", "BASE", "B", origin=(0, 0, 0), axis=(1, 0, 0))
    md.add_joint("revolute", "R", "B", "ROT", origin=(0.1, 0, 0), axis=(0, 0, 1))
    md.add_mass("B", 1e4, (0, 0, 0), np.diag([100.0] * 3))
    md.add_mass("ROT", 1e-3, (0.1, 0, 0), np.diag([1e-8] * 3))
    md.set_joint_spring("R", 1e-3, free=0.0)
    got = openimp.modes(openimp.compile(md), specified=["X"]).frequency
    np.testing.assert_allclose(got, [np.sqrt(1e-3 / 1e-8)], rtol=1e-9)


def test_pole_frequency_and_modes_along_edges():
    """w at a pole (a free block with only a damper, w = 0) is an analysis error naming
    it; modes_along takes no postures, a structure and wrong times as it should, and pads
    missing modes with NaN, not inf."""
    lin = openimp.linearize(smd(2.0, 0.0, 1.0))
    with pytest.raises(openimp.AnalysisError, match="w = 0 rad/s is a pole"):
        openimp.frequency_response(lin, ("force", "F"), ("position", "X"), [0.0, 1.0])
    system = fivebar()
    empty = openimp.modes_along(system, np.zeros((0, system.nq)))
    assert empty.nsteps == 0 and empty.frequency.shape[0] == 0
    q = posture(system, {"A": 0.4, "E": -0.2})
    with pytest.raises(openimp.InputError, match="one time or 2 of them"):
        openimp.modes_along(system, np.array([q, q]), t=[0.0, 1.0, 2.0])
    one = openimp.modes_along(system, q[None], specified=["A", "E"])  # nothing free
    assert one.messages == ["step 0: no free generalized coordinates"]
    assert np.isnan(one.time_constant).all() and not one.unstable.any()
    tri = openimp.Model("triangle")
    tri.add_joint("revolute", "A", "BASE", "L1", origin=(0, 0, 0))
    tri.add_joint("revolute", "B", "L1", "L2", origin=(1, 0, 0))
    tri.add_joint("revolute", "C", "L2", "BASE", origin=(0, 1, 0))
    structure = openimp.compile(tri)
    mm = openimp.modes_along(structure, structure.modeling_q[None])
    assert mm.messages == ["step 0: no free generalized coordinates"]
    with pytest.raises(openimp.AnalysisError, match="structure"):
        openimp.modes(openimp.linearize(structure))


@pytest.mark.parametrize("call, match", [
    (lambda s, lin, md: openimp.frequency_response(lin, ("force", "F"), ("position", "X"),
                                                   "abc"), "w must be numbers"),
    (lambda s, lin, md: openimp.frequency_response(lin, ("force", "F"), [], [1.0]),
     "at least one"),
    (lambda s, lin, md: openimp.mode_motion(md, 0, "x"), "amplitude"),
    (lambda s, lin, md: openimp.mode_motion(md, True), "mode must be an index"),
    (lambda s, lin, md: openimp.modes("x"), "takes a Linearization"),
    (lambda s, lin, md: lin.block("K", "XY"), "part must be one of"),
    (lambda s, lin, md: lin.block("Q", "FF"), "name must be M, D, K or F"),
    (lambda s, lin, md: openimp.linearize(s, pivot_tol=-1.0), "pivot_tol"),
    (lambda s, lin, md: openimp.linearize(s, "abc"), "q must be numbers"),
])
def test_more_bad_inputs(call, match):
    """Each ends in an InputError naming the argument (never a raw ValueError,
    KeyError, ZeroDivisionError or AttributeError)."""
    s = smd(2.0, 50.0, 1.0)
    lin = openimp.linearize(s)
    with pytest.raises(openimp.InputError, match=match):
        call(s, lin, openimp.modes(lin))
