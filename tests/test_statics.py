"""Static equilibrium (book ch 12): openimp.equilibrium and openimp.equilibria against
references written here (and in tests/helpers/statics_models.py) in plain numpy / scipy.

* an upright pendulum with a torsional spring (k < m g l): every root of
  k theta = m g l sin theta by brentq; seek_stable leads to a stable root from any
  start, plain Newton (seek_stable=False) to the unstable root it starts near;
  eigenvalue k - m g l cos theta, potential 1/2 k theta^2 + m g l cos theta;
  a spring law k theta + c theta^3; the increment limit;
* a double pendulum with joint springs against scipy.optimize.minimize of its
  potential; the residual and the stiffness at any posture against the gradient and
  the Hessian of that potential; with weak springs every saddle and maximum (scipy
  root): plain Newton stays on it, the default search reaches a minimum;
* a rod on a ball joint (Euler-Rodrigues coordinates) against scipy's minimizer;
* the book's slider-crank of figure 12.1 (energy test: the search reaches the stable
  inner dead centre, plain Newton the unstable outer one); holding forces on the
  crank and on the piston by virtual work;
* at every equilibrium: the generalized forces on the FGCs within force_tol,
  Newton-Euler balance of every body with the reported joint reactions, holding
  forces = the drives of the force analysis = virtual work by hand;
* a neutral freedom (the book's vehicle on a flat road): neutral, and with a
  horizontal push the step cap, quickly;
* bad input;
* paths: a double pendulum stepped through its first joint and a slider-crank with
  a sprung block stepped through its crank (holding torque by virtual work, its
  extrema reported), a von Mises truss under displacement control (holding force
  extrema) and under a load law of t through its limit point (the snap-through
  reported), a path that stops where no equilibrium exists.

Tolerances are stated at each check: postures 1e-9 (1e-7 against scipy's
minimizers), eigenvalues and holding forces 1e-8 relative (1e-6 where the stiffness
of a load law is differenced), Newton-Euler balance 1e-9 of the body's largest term.

"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq, minimize, root

import openimp
from helpers.models import spec_cache
from helpers.statics_models import (
    DEG,
    DP,
    SC,
    SPH,
    VEH,
    VM,
    G,
    body_balance,
    d_central,
    double_pendulum,
    double_pendulum_gradient,
    double_pendulum_hessian,
    double_pendulum_potential,
    slider_crank,
    slider_crank_coordinate,
    slider_crank_kinematics,
    spherical_pendulum,
    spherical_potential,
    truss,
    truss_resistance,
    upright_pendulum,
    vehicle,
)
from openimp.errors import InputError

#: Newton-Euler balance: residual relative to the largest force / moment term of a body
NE_TOL = 1e-9
#: eigenvalues, stiffness and holding forces against the references (relative)
REL = 1e-8


def rel(x, ref) -> float:
    x, ref = np.asarray(x, float), np.asarray(ref, float)
    return float(np.abs(x - ref).max() / max(np.abs(ref).max(), 1e-300))


#: each spec compiled once per test session: compiled(key, build) -> (spec, system)
compiled = spec_cache()


def check_balanced(eq, spec, bodies, plane=False, law_forces=()):
    """Item 4 at one converged equilibrium: the generalized forces left on the FGCs are
    within force_tol; every moving body balances (Newton-Euler at rest with the
    reactions of eq.forces, gravity and the elements) to NE_TOL; the drive of the force
    analysis is the holding force on every SGC (REL) and zero (within force_tol) on
    every FGC."""
    assert eq.converged, eq.messages
    free = ~eq.specified
    assert np.all(np.abs(eq.residual[free]) <= eq.force_tol[free]), \
        (eq.residual, eq.force_tol)
    assert eq.unbalance <= eq.force_tol[free].max(initial=0.0)
    assert eq.forces is not None
    worst = body_balance(spec, eq.trajectory, eq.forces, bodies, plane, law_forces)
    assert worst <= NE_TOL, worst
    for name, spec_ in zip(eq.coords, eq.specified, strict=True):
        d = float(eq.forces.drive[name][0])
        if spec_:
            assert abs(d - eq.holding[name]) <= REL * max(abs(eq.holding[name]), 1.0), \
                (name, d, eq.holding[name])
            assert eq.residual[eq.coords.index(name)] == pytest.approx(-eq.holding[name],
                                                                        rel=1e-12, abs=1e-12)
        else:
            assert abs(d) <= eq.force_tol[eq.coords.index(name)], (name, d)


# =============================================================================
# 1. Upright pendulum with a torsional spring: k theta = m g l sin theta
# =============================================================================

K_RATIO = 0.1  # k = 0.1 m g l: roots 0, +-2.85, +-7.07, +-8.42 (sin theta / theta = 0.1)


@pytest.fixture(scope="module")
def pend():
    spec, sy = compiled("pendulum", lambda: upright_pendulum(K_RATIO)[0])
    _, k, mgl = upright_pendulum(K_RATIO)
    f = lambda th: k * th - mgl * math.sin(th)  # noqa: E731  dV/dtheta
    grid = np.linspace(-12.0, 12.0, 4801)  # no root beyond |theta| = 10 (k theta > mgl)
    vals = np.array([f(x) for x in grid])
    roots = [0.0]
    for i in range(grid.size - 1):
        if vals[i] == 0.0 or vals[i] * vals[i + 1] > 0 or abs(grid[i]) < 1e-9 \
                or abs(grid[i + 1]) < 1e-9:
            continue
        roots.append(brentq(f, grid[i], grid[i + 1], xtol=1e-15, rtol=1e-15))
    roots = np.array(sorted(roots))
    stiff = k - mgl * np.cos(roots)
    return dict(spec=spec, sy=sy, k=k, mgl=mgl, roots=roots, stable=roots[stiff > 0],
                unstable=roots[stiff < 0],
                V=lambda th: 0.5 * k * th * th + mgl * math.cos(th))


def test_pendulum_roots_reference(pend):
    """The reference itself: seven roots, the stable ones 2.85 and 8.42 in magnitude."""
    r = pend["roots"]
    assert r.size == 7
    assert np.allclose(np.sort(np.abs(pend["stable"]))[::2], [2.8523418944, 8.4232369],
                       atol=1e-6)
    assert 0.0 in pend["unstable"] and pend["unstable"].size == 3


@pytest.mark.parametrize("start", [0.0, 0.2, -0.7, 1.6, 4.0, 5.5, 7.0, 7.15, -7.1, 9.6])
def test_pendulum_seek_stable_reaches_a_stable_root(pend, start):
    """From any start (on the unstable roots 0 and +-7.07 too), the default search ends
    on a stable root (to 1e-9 rad), reports "stable" with eigenvalue k - m g l cos theta
    (1e-8 relative) and the potential 1/2 k theta^2 + m g l cos theta (1e-9 of m g l),
    and the potential energy did not rise from the start."""
    sy, k, mgl = pend["sy"], pend["k"], pend["mgl"]
    eq = openimp.equilibrium(sy, [start])
    th = eq.value("A")
    assert eq.status == "balanced" and eq.converged, eq.messages
    assert eq.stability == "stable", (start, th, eq.messages)
    assert np.abs(pend["stable"] - th).min() <= 1e-9, (start, th, pend["stable"])
    assert eq.eigenvalues.shape == (1,)
    assert rel(eq.eigenvalues[0], k - mgl * math.cos(th)) <= REL
    assert rel(eq.stiffness[0, 0], k - mgl * math.cos(th)) <= REL
    assert abs(eq.potential - pend["V"](th)) <= 1e-9 * mgl
    assert pend["V"](th) <= pend["V"](start) + 1e-12 * mgl
    assert eq.history and all(h[0] in ("newton", "descent", "modified", "escape")
                              for h in eq.history)
    check_balanced(eq, pend["spec"], ["ROD"])


@pytest.mark.parametrize("which", [0, 1, 2])
@pytest.mark.parametrize("offset", [0.05, -0.04])
def test_pendulum_plain_newton_finds_the_unstable_root(pend, which, offset):
    """seek_stable=False, started 0.05 rad from an unstable root: plain Newton converges
    on that root (1e-9 rad), "unstable" with eigenvalue k - m g l cos theta < 0 (1e-8
    relative) and a message saying so; every step a Newton step.  With seek_stable the
    same start leads to a stable root."""
    sy, k, mgl = pend["sy"], pend["k"], pend["mgl"]
    root = pend["unstable"][which]
    eq = openimp.equilibrium(sy, [root + offset], seek_stable=False)
    th = eq.value("A")
    assert eq.converged, eq.messages
    assert abs(th - root) <= 1e-9, (root, th)
    assert eq.stability == "unstable"
    lam = k - mgl * math.cos(th)
    assert lam < 0 and rel(eq.eigenvalues[0], lam) <= REL
    assert any("unstable equilibrium" in m and "A.theta" in m for m in eq.messages), \
        eq.messages
    assert {h[0] for h in eq.history} == {"newton"}
    check_balanced(eq, pend["spec"], ["ROD"])
    eq2 = openimp.equilibrium(sy, [root + offset])
    assert eq2.stability == "stable"
    assert np.abs(pend["stable"] - eq2.value("A")).min() <= 1e-9


@pytest.mark.parametrize("which", [0, 1, 2])
def test_pendulum_started_on_an_unstable_root(pend, which):
    """Started exactly on an unstable root (no load to follow): plain Newton stays there
    (no step, "unstable"); the default search leaves it along its mode ("escape" first,
    reported in the messages) and ends on a stable root of lower potential (1e-9)."""
    sy, mgl = pend["sy"], pend["mgl"]
    root = pend["unstable"][which]
    eq0 = openimp.equilibrium(sy, [root], seek_stable=False)
    assert eq0.converged and eq0.steps == 0 and eq0.stability == "unstable"
    assert abs(eq0.value("A") - root) <= 1e-12
    eq = openimp.equilibrium(sy, [root])
    th = eq.value("A")
    assert eq.converged and eq.stability == "stable", eq.messages
    assert eq.history[0][0] == "escape"
    assert any("unstable equilibrium(s) left" in m for m in eq.messages), eq.messages
    assert np.abs(pend["stable"] - th).min() <= 1e-9
    assert pend["V"](th) < pend["V"](root) - 1e-3 * mgl
    check_balanced(eq, pend["spec"], ["ROD"])


def test_pendulum_spring_law():
    """A joint spring given by a law, k theta + c theta^3: the equilibrium solves
    k theta + c theta^3 = m g l sin theta (brentq, 1e-9) and its eigenvalue is
    k + 3 c theta^2 - m g l cos theta (1e-6 relative: the stiffness of a law is
    differenced)."""
    m, l, c = 3.0, 0.8, 2.0
    mgl = m * G * l
    k = 0.1 * mgl

    def build():
        s, _, _ = upright_pendulum(0.1, m=m, l=l)
        s.model.set_joint_spring("A", law=lambda st: k * st.x + c * st.x**3)
        s.jsprings.clear()  # not a linear spring: the reaction of A carries it
        return s

    spec, sy = compiled("pendulum law", build)
    r = brentq(lambda t: k * t + c * t**3 - mgl * math.sin(t), 0.3, 3.0, xtol=1e-15)
    for start in (0.5, -1.0, 2.5):
        eq = openimp.equilibrium(sy, [start])
        th = eq.value("A")
        assert eq.converged and eq.stability == "stable", eq.messages
        assert abs(abs(th) - r) <= 1e-9 and np.sign(th) == np.sign(start)
        assert rel(eq.eigenvalues[0], k + 3 * c * r * r - mgl * math.cos(r)) <= 1e-6
        check_balanced(eq, spec, ["ROD"])


def test_pendulum_force_tol_in_model_units(pend):
    """A stated force_tol (model units, a moment on the angle) is reported as is and
    honoured."""
    eq = openimp.equilibrium(pend["sy"], [1.0], force_tol=1e-3)
    assert eq.converged
    assert np.allclose(eq.force_tol, 1e-3, rtol=1e-12)
    assert abs(eq.residual[0]) <= 1e-3
    assert np.abs(pend["stable"] - eq.value("A")).min() <= 1e-3 / (pend["k"] + pend["mgl"]) * 10


# =============================================================================
# 2. Double pendulum with joint springs against scipy.optimize.minimize
# =============================================================================

@pytest.fixture(scope="module")
def dpend():
    spec, sy = compiled("double pendulum", lambda: double_pendulum()[0])
    return spec, sy


@pytest.mark.parametrize("start", [(0.0, 0.0), (2.0, 1.0), (-2.0, -1.0), (3.0, 3.0),
                                   (1.0, -2.5)])
def test_double_pendulum_against_minimize(dpend, start):
    """The equilibrium equals the minimizer of V (scipy BFGS with the hand gradient,
    polished by Newton on the hand Hessian) to 1e-7 rad; K = the Hessian there and the
    eigenvalues its eigenvalues (1e-8 relative); the potential V (1e-10 relative)."""
    spec, sy = dpend
    ref = minimize(double_pendulum_potential, np.array(start, float),
                   jac=double_pendulum_gradient, method="BFGS", options=dict(gtol=1e-10))
    x = ref.x
    for _ in range(3):  # polish: Newton on the hand gradient and Hessian
        x = x - np.linalg.solve(double_pendulum_hessian(x), double_pendulum_gradient(x))
    assert np.abs(x - ref.x).max() < 1e-6
    assert np.abs(double_pendulum_gradient(x)).max() < 1e-11
    assert np.all(np.linalg.eigvalsh(double_pendulum_hessian(x)) > 0)
    eq = openimp.equilibrium(sy, list(start))
    assert eq.converged and eq.stability == "stable", eq.messages
    th = np.array([eq.value("A"), eq.value("B")])
    assert np.abs(th - x).max() <= 1e-7, (th, x)
    H = double_pendulum_hessian(th)
    idx = [eq.coords.index("A.theta"), eq.coords.index("B.theta")]
    assert rel(eq.stiffness[np.ix_(idx, idx)], H) <= REL
    assert rel(eq.eigenvalues, np.linalg.eigvalsh(H)) <= REL
    assert rel(eq.potential, double_pendulum_potential(th)) <= 1e-10
    check_balanced(eq, spec, ["L1", "L2"])


WEAK = dict(kA=5.0, kB=3.0)  # weak springs: three minima, three saddles, a maximum


@pytest.fixture(scope="module")
def weak_equilibria():
    """Every equilibrium of the weakly sprung double pendulum in [-6, 6]^2 (scipy root
    on the hand gradient from a 13 x 13 grid of starts), with the eigenvalues of the
    hand Hessian."""
    sols = []
    for a in np.linspace(-6.0, 6.0, 13):
        for b in np.linspace(-6.0, 6.0, 13):
            r = root(lambda x: double_pendulum_gradient(x, **WEAK), [a, b],
                     jac=lambda x: double_pendulum_hessian(x, **WEAK), tol=1e-14)
            if r.success and np.abs(double_pendulum_gradient(r.x, **WEAK)).max() < 1e-10 \
                    and not any(np.abs(r.x - x).max() < 1e-6 for x in sols):
                sols.append(r.x)
    lam = [np.linalg.eigvalsh(double_pendulum_hessian(x, **WEAK)) for x in sols]
    return sols, lam


def test_double_pendulum_saddles_plain_newton_and_seek_stable(weak_equilibria):
    """Several freedoms: started on (and 0.03 rad off) every saddle and maximum, plain
    Newton converges on it (1e-9) and reports it unstable with the Hessian's eigenvalues
    (1e-8 relative); the default search ends on one of the minima (1e-8), of lower
    potential, reported stable."""
    sols, lams = weak_equilibria
    minima = [x for x, lam in zip(sols, lams, strict=True) if lam[0] > 0]
    others = [(x, lam) for x, lam in zip(sols, lams, strict=True) if lam[0] < 0]
    assert len(minima) >= 2 and len(others) >= 3
    spec, sy = compiled("double pendulum weak", lambda: double_pendulum(**WEAK)[0])
    for x, lam in others:
        for off in (np.zeros(2), np.array([0.03, -0.02])):
            eq0 = openimp.equilibrium(sy, x + off, seek_stable=False)
            assert eq0.converged and eq0.stability == "unstable", eq0.messages
            assert np.abs(eq0.q - x).max() <= 1e-9
            assert rel(eq0.eigenvalues, lam) <= REL
            eq = openimp.equilibrium(sy, x + off)
            th = eq.q.copy()
            assert eq.converged and eq.stability == "stable", eq.messages
            assert min(np.abs(th - m).max() for m in minima) <= 1e-8, (x, th)
            assert double_pendulum_potential(th, **WEAK) < double_pendulum_potential(
                x + off, **WEAK)
            assert {"modified", "escape"} & {h[0] for h in eq.history}
    check_balanced(eq, spec, ["L1", "L2"])


@pytest.mark.parametrize("q", [(0.7, -1.1), (-2.0, 2.5), (3.0, 0.2)])
def test_double_pendulum_residual_and_stiffness_at_any_posture(dpend, q):
    """Both joints specified (no FGC): the residual is -grad V and the holding forces
    +grad V (the drives of the force analysis, virtual work), the stiffness the Hessian
    of V, at postures that are not equilibria (1e-9 relative)."""
    spec, sy = dpend
    eq = openimp.equilibrium(sy, list(q), specified=["A", "B"])
    assert eq.status == "no free coordinate" and eq.converged
    assert eq.stability == "none" and eq.eigenvalues.size == 0
    assert np.allclose(eq.q, q, atol=1e-14)
    idx = [eq.coords.index("A.theta"), eq.coords.index("B.theta")]
    g = double_pendulum_gradient(q)
    assert rel(eq.residual[idx], -g) <= 1e-9
    assert rel([eq.holding["A.theta"], eq.holding["B.theta"]], g) <= 1e-9
    assert rel(eq.stiffness[np.ix_(idx, idx)], double_pendulum_hessian(q)) <= 1e-9
    check_balanced(eq, spec, ["L1", "L2"])


def test_ball_joint_against_minimize():
    """A rod on a ball joint (Euler-Rodrigues coordinates) under gravity and a point
    spring: its tip where V over the rod's direction is least (scipy BFGS, 3-point
    gradient, gtol 1e-11) to 1e-7; the potential to 1e-9 relative; the spin about the
    rod is the one neutral freedom (the other two eigenvalues positive)."""
    spec, sy = compiled("spherical", spherical_pendulum)
    eq = openimp.equilibrium(sy)
    assert eq.converged, eq.messages
    ref = minimize(spherical_potential, [0.2, 0.1], jac="3-point", method="BFGS",
                   options=dict(gtol=1e-11))
    x, y = ref.x
    tip = SPH["l"] * np.array([x, y, -math.sqrt(1 - x * x - y * y)])
    assert np.abs(eq.trajectory.point("T")[0] - tip).max() <= 1e-7
    assert rel(eq.potential, ref.fun) <= 1e-9
    assert eq.stability == "neutral" and eq.eigenvalues.size == 3
    assert abs(eq.eigenvalues[0]) <= 1e-8 * eq.eigenvalues[-1] and eq.eigenvalues[1] > 0
    check_balanced(eq, spec, ["ROD"])


def test_increment_limit():
    """step_limit bounds every step (12.4): each history entry's largest |dpsi| (an
    angle, radians) is at most the limit, and the search still ends on the same stable
    root (1e-9)."""
    _, sy = compiled("pendulum", lambda: upright_pendulum(K_RATIO)[0])
    eq1 = openimp.equilibrium(sy, [1.0])
    eq2 = openimp.equilibrium(sy, [1.0], step_limit=0.05, max_iter=200)
    assert eq2.converged, eq2.messages
    assert max(h[2] for h in eq2.history) <= 0.05 * (1 + 1e-12)
    assert len(eq2.history) > len(eq1.history)
    assert abs(eq1.value("A") - eq2.value("A")) <= 1e-9


# =============================================================================
# 3. The slider-crank of figure 12.1
# =============================================================================

def _crank(eq) -> float:
    """The absolute crank angle, wrapped to [-pi, pi)."""
    phi = eq.value("A") + SC["th0"]
    return (phi + math.pi) % (2 * math.pi) - math.pi


def _sc_stiffness(name: str, phi: float, e: float, P: float) -> float:
    """K on coordinate ``name`` at a stationary crank angle phi: V = P x(phi), so
    d2V/dpsi^2 = V''(phi) / (dpsi/dphi)^2 there (V' = 0)."""
    _, V2 = d_central(lambda p: P * float(slider_crank_kinematics(p, e)[0]), phi, 1e-3)
    dpsi, _ = d_central(lambda p: float(slider_crank_coordinate(name, p, e)), phi, 1e-3)
    return V2 / dpsi**2


@pytest.mark.parametrize("e", [0.0, 0.3], ids=["in-line", "offset"])
def test_slider_crank_12_1_energy_test(e):
    """A large piston force P toward the crank, gravity normal to the plane, start at
    crank 30 deg.  The default search reaches the stable inner dead centre
    phi = pi + asin(e / (b - a)) (near 180 deg, 1e-9 rad), not the outer one near 0;
    its history has steps of the energy test ("descent" or "modified").  Plain Newton
    (seek_stable=False) goes to phi = asin(e / (a + b)) (near 0) and reports it
    unstable.  Eigenvalues V''(phi) / (dpsi/dphi)^2 on the reported coordinate (FD of
    the hand kinematics, 1e-7 relative)."""
    P = 1000.0
    spec, sy = compiled(("sc", e), lambda: slider_crank(P=P, e=e))
    a, b = SC["a"], SC["b"]
    eq = openimp.equilibrium(sy)
    kinds = [h[0] for h in eq.history]
    print(f"\nslider-crank e={e}: default search history {kinds}")
    assert eq.converged and eq.stability == "stable", eq.messages
    phi_in = math.pi + math.asin(e / (b - a))
    assert abs((_crank(eq) - phi_in + math.pi) % (2 * math.pi) - math.pi) <= 1e-9
    assert {"descent", "modified"} & set(kinds), kinds
    (name,) = eq.free
    assert rel(eq.eigenvalues[0], _sc_stiffness(name, phi_in, e, P)) <= 1e-7
    check_balanced(eq, spec, ["CRANK", "ROD", "SLIDER"], plane=True)

    eq0 = openimp.equilibrium(sy, seek_stable=False)
    kinds0 = [h[0] for h in eq0.history]
    print(f"slider-crank e={e}: plain Newton history {kinds0}")
    assert eq0.converged and eq0.stability == "unstable", eq0.messages
    phi_out = math.asin(e / (a + b))
    assert abs(_crank(eq0) - phi_out) <= 1e-9, _crank(eq0) / DEG
    assert set(kinds0) == {"newton"}
    (name0,) = eq0.free
    lam = _sc_stiffness(name0, phi_out, e, P)
    assert lam < 0 and rel(eq0.eigenvalues[0], lam) <= 1e-7
    check_balanced(eq0, spec, ["CRANK", "ROD", "SLIDER"], plane=True)


@pytest.mark.parametrize("phi_deg", [50.0, 123.0, -70.0])
def test_slider_crank_holding_torque_by_virtual_work(phi_deg):
    """The crank held (no FGC left): the holding torque is dV/dphi = P x'(phi) (the
    virtual work of the piston force, x' by the chain rule of the hand kinematics) and
    the drive of the force analysis (1e-9 relative); every body balances."""
    P, e = 1000.0, 0.3
    spec, sy = compiled(("sc", e), lambda: slider_crank(P=P, e=e))
    a, b = SC["a"], SC["b"]
    phi = phi_deg * DEG
    sw = openimp.sweep(sy, {"A": [phi - SC["th0"]]})
    assert sw.complete
    eq = openimp.equilibrium(sy, sw.q[0], specified=["A"])
    assert eq.status == "no free coordinate"
    assert any("no free generalized coordinate" in m for m in eq.messages)
    # x = a cos phi + sqrt(b^2 - (e - a sin phi)^2)
    s = math.sqrt(b * b - (e - a * math.sin(phi)) ** 2)
    dx = -a * math.sin(phi) + (e - a * math.sin(phi)) * a * math.cos(phi) / s
    assert abs(eq.value("D") - slider_crank_kinematics(phi, e)[0]) <= 1e-12
    assert rel(eq.holding["A.theta"], P * dx) <= 1e-9
    check_balanced(eq, spec, ["CRANK", "ROD", "SLIDER"], plane=True)


def test_slider_crank_piston_held_against_crank_spring():
    """The piston (D.s, not the coordinate the crank would be) held, a spring kA in the
    crank: the holding force on the piston is dV/dx = kA (phi - phi0) / x'(phi)
    (virtual work through the hand kinematics, 1e-9 relative) and every body balances."""
    kA = 50.0
    spec, sy = compiled("sc crank spring", lambda: slider_crank(P=0.0, crank_spring=(kA, 0.0)))
    sw = openimp.sweep(sy, {"A": [0.4]})
    eq = openimp.equilibrium(sy, sw.q[0], specified=["D"])
    assert eq.status == "no free coordinate" and eq.coords == ["D.s"]
    phi = 0.4 + SC["th0"]
    dx, _ = d_central(lambda p: float(slider_crank_kinematics(p)[0]), phi, 1e-3)
    assert abs(eq.value("A") - 0.4) <= 1e-12
    assert rel(eq.holding["D.s"], kA * 0.4 / dx) <= 1e-9
    check_balanced(eq, spec, ["CRANK", "ROD", "SLIDER"], plane=True)


# =============================================================================
# 5. A neutral freedom: the vehicle on a flat road
# =============================================================================

def test_vehicle_neutral_freedom():
    """No fore-aft stiffness: the search balances the suspension (drop m g / k, 1e-12)
    and reports the equilibrium neutral, naming X; eigenvalues 0 and k (1e-9 of k); the
    cart stays where it started."""
    spec, sy = compiled("vehicle", vehicle)
    eq = openimp.equilibrium(sy, [0.3, 0.0])
    assert eq.converged and eq.status == "balanced", eq.messages
    assert eq.stability == "neutral"
    msg = [m for m in eq.messages if "neutral" in m]
    assert msg and "X.s" in msg[0], eq.messages
    assert abs(eq.value("X") - 0.3) <= 1e-12
    assert abs(eq.value("Y") + VEH["m_body"] * G / VEH["k"]) <= 1e-12
    assert np.abs(eq.eigenvalues - [0.0, VEH["k"]]).max() <= 1e-9 * VEH["k"]
    check_balanced(eq, spec, ["CART", "BODY"])


def test_vehicle_neutral_message_names_the_neutral_coordinate():
    """The same vehicle with the suspension's joint first (coordinates Y.s, X.s): the
    neutral mode is X.s alone (eigenvector (0, 1), 1e-12) and the message must not say
    that any value of the sprung Y.s balances."""
    spec, sy = compiled("vehicle Y first", lambda: vehicle(vertical_first=True))
    eq = openimp.equilibrium(sy)
    assert eq.converged and eq.stability == "neutral"
    assert eq.coords == ["Y.s", "X.s"]
    assert np.abs(np.abs(eq.eigenvectors[:, 0]) - [0.0, 1.0]).max() <= 1e-12
    assert abs(eq.value("Y") + (VEH["m_body"] + VEH["m_cart"]) * G / VEH["k"]) <= 1e-12
    check_balanced(eq, spec, ["CART", "BODY"])
    msg = [m for m in eq.messages if "neutral" in m]
    assert msg and "X.s" in msg[0], eq.messages
    assert "Y.s" not in msg[0], msg[0]


@pytest.mark.parametrize("max_iter", [25, 7])
def test_vehicle_pushed_has_no_equilibrium(max_iter):
    """A small constant horizontal force: no equilibrium exists; the search stops at the
    step cap (steps == max_iter) with a message naming the step cap and X, having moved
    the cart along the push."""
    _, sy = compiled("vehicle pushed", lambda: vehicle(push=1.0))
    eq = openimp.equilibrium(sy, [0.0, 0.0], max_iter=max_iter)
    assert eq.status == "step cap" and not eq.converged
    assert eq.steps == max_iter
    assert any("step cap" in m and "X.s" in m for m in eq.messages), eq.messages
    assert any("neutral" in m and "X.s" in m for m in eq.messages), eq.messages
    assert eq.value("X") > 0.0
    assert abs(eq.residual[eq.coords.index("X.s")] - 1.0) <= 1e-9


# =============================================================================
# 6. Bad input
# =============================================================================

def _free_rod():
    m = openimp.Model("no loads")
    m.add_joint("revolute", "A", "BASE", "ROD", origin=(0, 0, 0))
    m.add_mass("ROD", 1.0, (1.0, 0, 0), np.diag([0.1, 0.1, 0.1]))
    return openimp.compile(m)


def test_no_load_every_posture_is_an_equilibrium():
    sy = _free_rod()
    eq = openimp.equilibrium(sy, [0.3])
    assert eq.converged
    assert abs(eq.value("A") - 0.3) <= 1e-15
    assert any("every posture is an equilibrium" in m for m in eq.messages), eq.messages


def test_stress_free_equilibrium_is_not_reported_as_no_load():
    """The truss started with its apex 0.2 above rest (springs loaded) relaxes to the
    rest posture (Y = 0, stiffness 4 k h^2 / L0^2 = 400): springs act, the start
    posture is not returned, so 'every posture is an equilibrium' is false."""
    _, sy = compiled("truss", truss)
    eq = openimp.equilibrium(sy, [0.2])
    assert eq.converged and eq.steps > 0 and abs(eq.value("Y")) <= 1e-12
    L0 = math.hypot(VM["a"], VM["h"])
    assert rel(eq.eigenvalues[0], 2 * VM["k"] * (VM["h"] / L0) ** 2) <= REL
    assert not any("every posture is an equilibrium" in m for m in eq.messages), eq.messages


def test_no_free_coordinate_holding_by_virtual_work():
    """A pendulum held at 0.3 rad: "no free coordinate", the holding torque
    k theta + m g r cos theta (virtual work) = the drive of the force analysis."""
    m = openimp.Model("held")
    m.add_joint("revolute", "A", "BASE", "ROD", origin=(0, 0, 0))
    m.add_mass("ROD", 2.0, (1.0, 0, 0), np.diag([0.01, 0.01, 0.01]))
    m.set_gravity((0, -G, 0))
    m.set_joint_spring("A", 5.0, 0.0)
    sy = openimp.compile(m)
    eq = openimp.equilibrium(sy, [0.3], specified=["A"])
    assert eq.status == "no free coordinate" and eq.converged and eq.stability == "none"
    ref = 5.0 * 0.3 + 2.0 * G * 1.0 * math.cos(0.3)
    assert rel(eq.holding["A.theta"], ref) <= 1e-12
    assert rel(eq.forces.drive["A.theta"][0], ref) <= 1e-9
    eq2 = openimp.equilibrium(sy, [0.3], specified=["A"], forces=False)
    assert eq2.forces is None and rel(eq2.holding["A.theta"], ref) <= 1e-12


def _fourbar_triple_rocker():
    """A non-Grashof four-bar (a 1, b 2, c 1.5, d 3): the crank cannot reach 180 deg."""
    a, b, c, d, th0 = 1.0, 2.0, 1.5, 3.0, 0.7
    B = a * np.array([math.cos(th0), math.sin(th0), 0.0])
    D = np.array([d, 0.0, 0.0])
    PQ = D - B
    L = float(np.linalg.norm(PQ))
    x = (b * b - c * c + L * L) / (2 * L)
    C = B + x * PQ / L + math.sqrt(b * b - x * x) * np.array([-PQ[1], PQ[0], 0.0]) / L
    m = openimp.Model("triple rocker")
    m.add_joint("revolute", "A", "BASE", "CRANK", origin=(0, 0, 0))
    m.add_joint("revolute", "B", "CRANK", "COUPLER", origin=B)
    m.add_joint("revolute", "C", "COUPLER", "ROCKER", origin=C)
    m.add_joint("revolute", "D", "ROCKER", "BASE", origin=D)
    for body, cc in (("CRANK", B / 2), ("COUPLER", (B + C) / 2), ("ROCKER", (C + D) / 2)):
        m.add_mass(body, 1.0, cc, np.diag([0.1, 0.1, 0.1]))
    m.set_gravity((0, -G, 0))
    m.set_joint_spring("A", 10.0, 0.0)
    return openimp.compile(m), th0


def test_unassembled_start_is_input_error():
    sy, th0 = _fourbar_triple_rocker()
    q = sy.modeling_q.copy()
    q[sy.var_index("A")] = math.pi - th0  # crank at 180 deg: |BD| = 4 > b + c
    with pytest.raises(InputError, match="cannot be assembled"):
        openimp.equilibrium(sy, q, specified=["A"])
    # a start that only misses closing is closed first
    q = sy.modeling_q.copy()
    q[sy.var_index("B")] += 0.05
    eq = openimp.equilibrium(sy, q)
    assert eq.converged


BAD_OPTIONS = [dict(force_tol=-1.0), dict(force_tol="x"), dict(force_rtol=0.0),
               dict(force_rtol=None), dict(step_tol=0.0), dict(max_iter=0), dict(max_iter=2.5),
               dict(max_iter=True), dict(step_limit=float("nan")), dict(step_limit=-1.0),
               dict(neutral_tol="x"), dict(pivot_tol=float("inf")), dict(t="x"),
               dict(specified=["Z"])]


@pytest.mark.parametrize("kw", BAD_OPTIONS, ids=[str(k) for k in BAD_OPTIONS])
def test_bad_options_are_input_errors(pend, kw):
    with pytest.raises(InputError):
        openimp.equilibrium(pend["sy"], [0.5], **kw)


@pytest.mark.parametrize("call", [
    lambda sy: openimp.equilibrium(sy, [0.1, 0.2]),
    lambda sy: openimp.equilibrium(sy, [float("nan")]),
    lambda sy: openimp.equilibrium(sy, "abc"),
    lambda sy: openimp.equilibrium(openimp.Model("m")),
    lambda sy: openimp.equilibria(sy),
    lambda sy: openimp.equilibria(sy, [0.1]),
    lambda sy: openimp.equilibria(sy, {"A": []}),
    lambda sy: openimp.equilibria(sy, {"A": [[0.1], [0.2]]}),
    lambda sy: openimp.equilibria(sy, {"A": [0.1, math.inf]}),
    lambda sy: openimp.equilibria(sy, {"Z": [0.1]}),
    lambda sy: openimp.equilibria(sy, {"A": [0.1, 0.2]}, times=[0.0, 1.0, 2.0]),
    lambda sy: openimp.equilibria(sy, times=[0.0, math.nan]),
    lambda sy: openimp.equilibria(sy, {"A": [0.1]}, bogus=1),
    lambda sy: openimp.equilibria(sy, {"A": [0.1]}, max_iter=-3),
], ids=["q shape", "q nan", "q text", "model", "no path", "path list", "empty", "2-d",
        "inf", "unknown", "times length", "times nan", "unknown option", "max_iter"])
def test_bad_calls_are_input_errors(pend, call):
    with pytest.raises(InputError):
        call(pend["sy"])


def test_path_of_text_is_input_error(pend):
    with pytest.raises(InputError):
        openimp.equilibria(pend["sy"], {"A": "abc"})


def test_nonfinite_time_is_input_error(pend):
    with pytest.raises(InputError):
        openimp.equilibrium(pend["sy"], [0.5], t=math.nan)


# =============================================================================
# 7. Paths
# =============================================================================

def test_path_double_pendulum_holding_torque_and_extremum():
    """Joint A stepped (no spring on it), B free: at every step B is the root of
    dV/dtheta2 = 0 (brentq, 1e-9 rad), the holding torque of A is dV/dtheta1 there
    (virtual work, 1e-8 relative) and the drive of the path's force analysis; every
    body balances; the turning points name exactly the steps where the reference
    holding torque has an extremum, with its kind."""
    spec, sy = compiled("double pendulum kA=0", lambda: double_pendulum(kA=0.0)[0])
    th1 = np.linspace(-1.2, 1.3, 21)
    pa = openimp.equilibria(sy, {"A": th1})
    assert pa.message == "" and len(pa) == th1.size
    assert pa.parameter == "A" and np.allclose(pa.values, th1)
    th2 = np.array([brentq(lambda x, t=t: double_pendulum_gradient((t, x), kA=0.0)[1],
                           DP["qB0"] - 1.0, DP["qB0"] + 1.0, xtol=1e-15) for t in th1])
    assert np.abs(pa.q[:, sy.var_index("B")] - th2).max() <= 1e-9
    assert np.abs(pa.q[:, sy.var_index("A")] - th1).max() <= 1e-14
    hold = np.array([double_pendulum_gradient((a, b), kA=0.0)[0] for a, b in zip(th1, th2)])
    assert rel(pa.holding("A.theta"), hold) <= REL
    assert rel(pa.forces.drive["A.theta"], hold) <= 1e-9
    for e in pa.steps:
        assert e.converged and e.stability == "stable"
        assert abs(e.residual[~e.specified][0]) <= e.force_tol[~e.specified][0]
    assert body_balance(spec, pa.trajectory, pa.forces, ["L1", "L2"], False) <= NE_TOL
    dh = np.diff(hold)
    ext = {k: ("maximum" if dh[k - 1] > 0 else "minimum")
           for k in range(1, dh.size) if dh[k - 1] * dh[k] < 0}
    assert ext, "the reference has no extremum on this path"
    got = [m for m in pa.turning_points if "holding force of A.theta" in m]
    assert len(got) == len(ext), pa.turning_points
    for k, kind in ext.items():
        assert any(f"passes a {kind}" in m and f"at step {k} " in m for m in got), \
            (k, kind, got)
    tab = pa.to_table()
    assert np.allclose(tab["holding A.theta"], pa.holding("A.theta"))


def test_path_slider_crank_block_holding_torque():
    """A slider-crank (one loop) with a sprung block on the piston: the crank stepped
    through 300 deg (the SGC), the block's shift u free (the FGC).  At every step u is
    k2 (xg - x - l0) / (k1 + k2) (1e-9), the holding torque dV/dphi =
    -k2 (xg - x - u - l0) x'(phi) (virtual work, x' by differences of the hand
    kinematics, 1e-8 relative) and the drive of the force analysis; every body balances;
    the reference's extrema are the turning points reported."""
    k1, k2, xg, l0 = 300.0, 500.0, 6.0, 1.0
    spec, sy = compiled("sc block", lambda: slider_crank(block=(k1, k2, xg, l0)))
    phis = np.linspace(30.0, 330.0, 21) * DEG
    pa = openimp.equilibria(sy, {"A": phis - SC["th0"]})
    assert pa.message == "" and len(pa) == phis.size
    x, _ = slider_crank_kinematics(phis)
    u = k2 * (xg - x - l0) / (k1 + k2)
    assert np.abs(pa.q[:, sy.var_index("E")] - u).max() <= 1e-9
    assert np.abs(pa.q[:, sy.var_index("D")] - x).max() <= 1e-9
    dx = np.array([d_central(lambda p: float(slider_crank_kinematics(p)[0]), ph, 1e-3)[0]
                   for ph in phis])
    hold = -k2 * (xg - x - u - l0) * dx
    assert rel(pa.holding("A.theta"), hold) <= REL
    assert rel(pa.forces.drive["A.theta"], hold) <= 1e-9
    for e in pa.steps:
        assert e.converged and e.free == ["E.s"] and e.stability == "stable"
        assert rel(e.eigenvalues[0], k1 + k2) <= REL
        assert abs(e.residual[~e.specified][0]) <= e.force_tol[~e.specified][0]
    assert body_balance(spec, pa.trajectory, pa.forces, ["CRANK", "ROD", "SLIDER", "BLOCK"],
                        True) <= NE_TOL
    dh = np.diff(hold)
    ext = {k: ("maximum" if dh[k - 1] > 0 else "minimum")
           for k in range(1, dh.size) if dh[k - 1] * dh[k] < 0}
    got = [m for m in pa.turning_points if "holding force of A.theta" in m]
    assert len(ext) == 2 and len(got) == 2, pa.turning_points
    for k, kind in ext.items():
        assert any(f"passes a {kind}" in m and f"at step {k} " in m for m in got), got


def test_path_stops_where_no_equilibrium_exists():
    """The vehicle pushed by a load law H = t: at t = 0 a (neutral) equilibrium, at
    t = 1 none (the step cap): the path ends there with a message naming the step and
    the step cap; the steps before it are kept and balanced."""
    _, sy = compiled("vehicle law", lambda: vehicle(push_law=lambda s: s.t))
    pa = openimp.equilibria(sy, times=[0.0, 1.0, 2.0, 3.0], max_iter=10)
    assert pa.message.startswith("step 1:") and "step cap" in pa.message, pa.message
    assert 1 <= len(pa) <= 2
    assert pa.steps[0].converged and pa.steps[0].stability == "neutral"
    assert abs(pa.q[0, sy.var_index("Y")] + VEH["m_body"] * G / VEH["k"]) <= 1e-12
    if len(pa) == 2:
        assert not pa.steps[1].converged and pa.steps[1].steps == 10


def test_path_truss_displacement_control():
    """The apex of a von Mises truss pushed down through both limit points (no FGC):
    every holding force is minus the springs' resistance 2 k (L0 - L) y / L (1e-9
    relative), with the extrema of the reference reported at their steps."""
    spec, sy = compiled("truss", truss)
    ys = np.linspace(0.0, -0.93, 20)
    pa = openimp.equilibria(sy, {"Y": ys})
    assert pa.message == "" and len(pa) == ys.size
    assert all(e.status == "no free coordinate" for e in pa.steps)
    R = truss_resistance(VM["h"] + ys)
    assert np.abs(pa.holding("Y.s") + R).max() <= 1e-9 * np.abs(R).max()
    assert body_balance(spec, pa.trajectory, pa.forces, ["APEX"], False) <= NE_TOL
    h = -R
    dh = np.diff(h)
    ext = {k: ("maximum" if dh[k - 1] > 0 else "minimum")
           for k in range(1, dh.size) if dh[k - 1] * dh[k] < 0}
    assert len(ext) == 2
    got = [m for m in pa.turning_points if "holding force of Y.s" in m]
    assert len(got) == 2, pa.turning_points
    for k, kind in ext.items():
        assert any(f"passes a {kind}" in m and f"at step {k} " in m for m in got), got


def test_path_truss_load_law_snap_through():
    """A downward load W = t on the apex (a load law of t) stepped past the limit load
    P_max of the truss: before it the apex sits on the upper branch (root of
    R(y) = t above the limit height, brentq), after it on the inverted branch below
    -h (1e-9); the eigenvalue is -R'(y) (1e-6 relative: the stiffness of a load law is
    differenced); the jump between the steps straddling P_max is reported; every
    step balances (the law force included)."""
    spec, sy = compiled("truss law", lambda: truss(load_law=lambda s: s.t))
    h = VM["h"]
    y_lim = brentq(lambda y: d_central(truss_resistance, y, 1e-4)[0], 0.05, h - 0.01,
                   xtol=1e-14)
    p_max = float(truss_resistance(y_lim))
    tt = np.linspace(0.0, 1.25 * p_max, 12)
    pa = openimp.equilibria(sy, times=tt)
    assert pa.message == "" and len(pa) == tt.size, pa.message
    assert pa.parameter == "t" and np.allclose(pa.values, tt)
    k_jump = int(np.argmax(tt > p_max))
    y = pa.q[:, 0] + h
    for k, t in enumerate(tt):
        if k < k_jump:
            ref = brentq(lambda x, t=t: truss_resistance(x) - t, y_lim, h, xtol=1e-15)
        else:
            ref = brentq(lambda x, t=t: truss_resistance(x) - t, -h - 5.0, -h, xtol=1e-15)
        assert abs(y[k] - ref) <= 1e-9, (k, t, y[k], ref)
        e = pa.steps[k]
        assert e.converged and e.stability == "stable", (k, e.messages)
        assert rel(e.eigenvalues[0], -d_central(truss_resistance, ref, 1e-4)[0]) <= 1e-6
        assert abs(e.residual[0]) <= e.force_tol[0]
    jumps = [m for m in pa.turning_points if "jumps" in m]
    assert len(jumps) == 1 and f"between steps {k_jump - 1} and {k_jump}" in jumps[0], \
        pa.turning_points
    worst = body_balance(spec, pa.trajectory, pa.forces, ["APEX"], False,
                         law_forces=[("P", lambda t: t, (0.0, -1.0, 0.0))])
    assert worst <= NE_TOL


def test_equilibrium_with_load_law_at_time():
    """equilibrium(t=...) reads the load law at t: the apex of the truss under W = t
    sits where R(y) = t (1e-9)."""
    spec, sy = compiled("truss law", lambda: truss(load_law=lambda s: s.t))
    t = 20.0
    eq = openimp.equilibrium(sy, t=t)
    ref = brentq(lambda x: truss_resistance(x) - t, 0.3, VM["h"], xtol=1e-15)
    assert eq.converged and abs(eq.value("Y") + VM["h"] - ref) <= 1e-9
    check_balanced(eq, spec, ["APEX"], law_forces=[("P", lambda tk: tk, (0.0, -1.0, 0.0))])


# =============================================================================
# review findings (each a reproducer of a problem a reviewer found, now fixed)
# =============================================================================
def _cart_pole(units: str, point_at_bob: bool = False):
    """A cart on a slider (spring 1 N/m to x = 0) carrying a pendulum 1 m long, bob below:
    every joint origin at one place, so the model's size comes from the bob's mass."""
    s = 1000.0 if units == "mm" else 1.0
    m = openimp.Model("cp")
    m.set_units(units)
    m.add_joint("prism", "X", "BASE", "CART", origin=(0, 0, 0), axis=(1, 0, 0))
    m.add_joint("revolute", "A", "CART", "POLE", origin=(0, 0, 0))
    m.add_mass("CART", 10.0, (0, 0, 0))
    m.add_mass("POLE", 10.0, (0, -1.0 * s, 0))
    if point_at_bob:
        m.add_point("BOB", "POLE", (0, -1.0 * s, 0))
    m.set_gravity((0, -9.81 * s, 0))
    m.set_joint_spring("X", 1.0 / s, free=0.0)  # 1 N/m in N/mm for mm
    return openimp.compile(m), s


@pytest.mark.parametrize("units", ["SI", "mm"])
def test_review_model_size_includes_mass_centres(units) -> None:
    """In mm with every joint at one place the increment limit was 1 mm (the search
    stalled at the step cap); the size of the model now includes its mass centres."""
    sy, s = _cart_pole(units)
    eq = openimp.equilibrium(sy, q=[0.3 * s, 0.2], forces=False)
    assert eq.converged and eq.steps <= 10, eq.messages
    np.testing.assert_allclose(eq.q, [0.0, 0.0], atol=1e-9 * s)


def test_review_stability_does_not_depend_on_units() -> None:
    """The same cart-pole in SI and mm: stable in both, eigenvalues k and m g l."""
    out = {}
    for units in ("SI", "mm"):
        sy, s = _cart_pole(units, point_at_bob=True)
        eq = openimp.equilibrium(sy, q=[0.3 * s, 0.2], forces=False)
        assert eq.converged and eq.stability == "stable", (units, eq.messages)
        out[units] = eq
    # K = [[k, 0], [0, m g l]] in the model's units (mm: g = 9810, l = 1000)
    np.testing.assert_allclose(np.sort(np.diag(out["SI"].stiffness)), [1.0, 98.1], rtol=1e-9)
    np.testing.assert_allclose(np.sort(np.diag(out["mm"].stiffness)),
                               [1e-3, 10 * 9810.0 * 1000.0], rtol=1e-9)


def _ziegler():
    m = openimp.Model("ziegler")
    m.set_units("SI")
    m.add_joint("revolute", "A", "BASE", "R1", origin=(0, 0, 0))
    m.add_joint("revolute", "B", "R1", "R2", origin=(0, 1, 0))
    m.add_mass("R1", 1.0, (0, 1, 0))
    m.add_mass("R2", 0.2, (0, 2, 0))
    m.add_point("T", "R2", (0, 2, 0))
    m.add_point("T0", "R2", (0, 1, 0))
    m.set_joint_spring("A", 10.0, free=0.0)
    m.set_joint_spring("B", 10.0, free=0.0)
    m.add_force("P", "T", 25.0, along=("T", "T0"))  # a follower: along the second rod
    m.add_torque("M", "R2", 3.0, direction=(0, 0, 1))
    return openimp.compile(m)


def test_review_follower_load_converges_and_is_judged_on_k_itself() -> None:
    """A Ziegler column (follower tip load): K is unsymmetric with eigenvalues 10, 10; the
    default search converged nowhere (its stable-seeking used K's symmetric part, which
    is indefinite) and called the rest unstable."""
    sy = _ziegler()
    eq = openimp.equilibrium(sy, forces=False)
    plain = openimp.equilibrium(sy, seek_stable=False, forces=False)
    assert eq.converged and plain.converged, eq.messages
    np.testing.assert_allclose(eq.q, plain.q, atol=1e-10)
    assert eq.stability == "stable", eq.messages
    assert any("not symmetric" in m for m in eq.messages)
    # the residual is balanced: moment balance of both rods by hand at the posture
    assert eq.unbalance <= eq.force_tol.max()
    lam = np.linalg.eigvals(eq.block("K", "FF") if hasattr(eq, "block") else eq.stiffness)
    assert np.all(lam.real > 0)


def test_review_constant_holding_force_has_no_turning_points() -> None:
    """A lift on an inclined slider carrying a sprung four-bar: the holding force is the
    weight along the axis at every step (equal to round-off); no extremum reported."""
    m = openimp.Model("lift4")
    m.set_units("SI")
    m.add_joint("prism", "Y", "BASE", "CAR", origin=(0, 0, 0), axis=(0.1, 1, 0))
    A, B, C, D = (np.array(v, float) for v in ([0, 0, 0], [0.3, 0.8, 0], [1.2, 1.0, 0],
                                               [1.0, 0, 0]))
    for n, b1, b2, o in (("A", "CAR", "CRANK", A), ("B", "CRANK", "COUP", B),
                         ("C", "COUP", "ROCK", C), ("D", "ROCK", "CAR", D)):
        m.add_joint("revolute", n, b1, b2, origin=tuple(o))
    m.add_mass("CAR", 3, (0.5, 0, 0))
    m.add_mass("CRANK", 1, tuple((A + B) / 2))
    m.add_mass("COUP", 1, tuple((B + C) / 2))
    m.add_mass("ROCK", 1, tuple((C + D) / 2))
    m.add_point("PB", "CRANK", tuple(B))
    m.add_point("G1", "CAR", (0.5, 1.5, 0))
    m.add_spring("S", "PB", "G1", 50.0, free_length=0.2)
    m.set_gravity((0, -9.81, 0))
    p = openimp.equilibria(openimp.compile(m), {"Y": np.linspace(0, 1, 41)}, forces=False)
    assert len(p) == 41 and not p.message
    w = p.holding("Y.s")
    # the weight (6 kg) along the unit axis (0.1, 1)/|.|, by hand
    np.testing.assert_allclose(w, 6 * 9.81 / np.hypot(0.1, 1.0), rtol=1e-12)
    assert p.turning_points == []


def test_review_neutral_spin_is_not_a_change_of_stability() -> None:
    """A rod on a ball joint whose spin is neutral at every step: the round-off sign of
    its zero eigenvalue is no turning point."""
    c = openimp.Model("lift")
    c.set_units("SI")
    c.add_joint("prism", "Y", "BASE", "CAR", origin=(0, 0, 0), axis=(0, 1, 0))
    c.add_joint("sphere", "S", "CAR", "ROD", origin=(0.1, 0.2, 0.3))
    c.add_mass("CAR", 50.0, (0.1, 0.2, 0.3))
    c.add_mass("ROD", 5.0, (0.1, -0.6, 0.3))
    c.add_point("T", "ROD", (0.1, -0.8, 0.3))
    c.add_point("G", "BASE", (0.7, -0.5, 0.1))
    c.add_spring("K", "T", "G", 200.0, free_length=0.3)
    c.set_gravity((0, -9.81, 0))
    p = openimp.equilibria(openimp.compile(c), {"Y": np.linspace(0, 0.05, 11)}, forces=False)
    assert len(p) == 11 and set(p.stability) == {"neutral"}
    assert not any("changes sign" in t for t in p.turning_points), p.turning_points


def _wound(k: float):
    """A rod (2 kg, centre 1 m out) on a torsion spring k between it and a key wound by
    the SGC A, under gravity."""
    m = openimp.Model("wound")
    m.set_units("SI")
    m.add_joint("revolute", "A", "BASE", "KEY", origin=(0, 0, 0))
    m.add_joint("revolute", "B", "KEY", "ROD", origin=(0, 0, 0))
    m.add_mass("ROD", 2.0, (1.0, 0, 0))
    m.set_gravity((0, -9.81, 0))
    m.set_joint_spring("B", k, free=0.0)
    return openimp.compile(m)


def test_review_uneven_steps_are_no_jump() -> None:
    """A stiff wound pendulum (no fold) stepped unevenly: no jump is reported."""
    p = openimp.equilibria(_wound(30.0), {"A": [0, 0.01, 0.3, 0.31]}, forces=False)
    assert len(p) == 4 and set(p.stability) == {"stable"}
    assert not any("jumps" in t for t in p.turning_points), p.turning_points


def test_review_state_time_and_history_units() -> None:
    """equilibrium(state=State, t=...) uses t; the history is in model units."""
    from openimp.system import make_state

    m = openimp.Model("slider")
    m.set_units("SI")
    m.add_joint("prism", "Y", "BASE", "B", origin=(0, 0, 0), axis=(0, 1, 0))
    m.add_point("P", "B", (0, 0, 0))
    m.add_point("Q", "BASE", (0, 2.0, 0))  # the model is 2 m long: internal unit 2 m
    m.set_joint_spring("Y", 100.0, free=0.0)
    m.add_force("F", "P", 0.0, direction=(0, 1, 0), law=lambda s: 10.0 * s.t)
    sy = openimp.compile(m)
    a = openimp.equilibrium(sy, t=2.0, forces=False)
    b = openimp.equilibrium(sy, state=make_state(sy), t=2.0, forces=False)
    assert a.value("Y") == pytest.approx(0.2, abs=1e-12)
    assert b.value("Y") == pytest.approx(0.2, abs=1e-12) and b.t == 2.0
    # the first step: unbalanced force 20 N at y = 0 (model units), a step of 0.2 m
    _kind, f0, s0 = a.history[0]
    assert f0 == pytest.approx(20.0, rel=1e-9) and s0 == pytest.approx(0.2, rel=1e-6)


def test_review_nested_search_in_a_progress_callback() -> None:
    """A search started inside a path's progress callback (same System) does not change
    the path's options or scratch."""
    sy = _wound(8.0)
    alpha = np.radians(np.arange(0, 200, 15))
    ref = openimp.equilibria(sy, {"A": alpha}, forces=False)

    def prog(i, n):
        openimp.equilibrium(sy, force_tol=5.0, seek_stable=False, forces=False)

    got = openimp.equilibria(sy, {"A": alpha}, progress=prog, forces=False)
    np.testing.assert_allclose(got.q, ref.q, atol=1e-12)
    assert all(e.unbalance <= e.force_tol.max() for e in got.steps)
    with pytest.raises(InputError, match="progress"):
        openimp.equilibria(sy, {"A": alpha}, progress=5)


def test_review_over_specified_sgcs_are_said() -> None:
    """Two SGCs on a one-freedom four-bar: their holding forces share the load in a way
    the rigid model cannot determine; the result says so."""
    m = openimp.Model("fb")
    m.set_units("SI")
    m.add_joint("revolute", "A", "BASE", "CR", origin=(0, 0, 0))
    m.add_joint("revolute", "B", "CR", "CO", origin=(0.3, 0.8, 0))
    m.add_joint("revolute", "C", "CO", "RO", origin=(1.2, 1.0, 0))
    m.add_joint("revolute", "D", "RO", "BASE", origin=(1.0, 0, 0))
    m.add_mass("CO", 1.0, (0.75, 0.9, 0))
    m.set_gravity((0, -9.81, 0))
    eq = openimp.equilibrium(openimp.compile(m), specified=["A", "B"], forces=False)
    assert eq.status == "no free coordinate"
    assert any("over-specify" in msg for msg in eq.messages), eq.messages


def test_review_path_holding_takes_joint_names_and_refuses_others() -> None:
    """EquilibriumPath.holding accepts the name used in the path ('A') as well as
    'A.theta'; an unknown name or a coordinate that is not an SGC is an InputError; bad
    flags are input errors."""
    sy = _wound(8.0)
    p = openimp.equilibria(sy, {"A": [0.1, 0.2]}, forces=False)
    np.testing.assert_array_equal(p.holding("A"), p.holding("A.theta"))
    assert np.all(np.isfinite(p.holding("A")))
    for bad in ("bogus", "B"):
        with pytest.raises(InputError):
            p.holding(bad)
    with pytest.raises(InputError, match="seek_stable"):
        openimp.equilibrium(sy, seek_stable="no")
    with pytest.raises(InputError, match="forces"):
        openimp.equilibrium(sy, forces="no")
