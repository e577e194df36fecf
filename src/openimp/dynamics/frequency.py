"""Transfer functions, frequency responses and state space of the linearized equations
(book 13.18-13.21).

* :func:`transfer_function`, :func:`frequency_response`,
  :func:`state_space`: from a force element, a load on a joint variable or
  an SGC motion to positions, velocities or accelerations of joint variables
  and point components.

Inputs are ``("force", element)`` (a force or torque element of the model,
per unit of its magnitude), ``("load", "joint[.var]")`` (a force or moment
on a joint variable, positive tending to increase it) or
``("motion", "joint[.var]")`` (an SGC moved by x_S).  Outputs are
``("position" | "velocity" | "accel", name)`` with name a joint variable
(``"J"``, ``"J.var"``) or a point component (``"P.x"``, ``"P.y"``,
``"P.z"``).  Everything is in model units (radians for angles).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import scipy.linalg

from openimp.dynamics.modes import first_order, free_blocks, no_fgc
from openimp.errors import AnalysisError, InputError
from openimp.kinematics.inputs import floats
from openimp.limits import MAX_STEPS
from openimp.results import FrequencyResponse, Linearization, StateSpace, TransferFunction

OUTPUT_KINDS = ("position", "velocity", "accel")
INPUT_KINDS = ("force", "load", "motion")


def _input_vector(lin: Linearization, inp: Any) -> tuple[tuple[str, str], np.ndarray, int]:
    """(label, generalized direction over coords (f,), SGC index or -1)."""
    kind, name = _pair(inp, INPUT_KINDS, "input")
    system = lin.system
    if kind == "force":
        if name not in lin.inputs:
            known = ", ".join(lin.inputs) or "none"
            raise InputError(f"input ('force', {name!r}): not a force or torque element of "
                             f"the model (known: {known})")
        g = lin.inputs[name]
        if not np.any(g):
            raise InputError(f"input ('force', {name!r}): the element has no direction at "
                             "this posture (its two direction points coincide) or does no "
                             "work on any free coordinate")
        return (kind, name), g, -1
    c = system.var_index(name)
    vname = system.var_names[c]
    if kind == "load":
        g = lin.phi[c].copy()
        if not np.any(g[lin.free]):
            raise InputError(f"input ('load', {name!r}): {vname} is locked (a specified "
                             "coordinate, or moved by none of the free ones), so a load on it "
                             "moves nothing; use ('motion', ...) for a specified coordinate")
        return (kind, vname), g, -1
    if vname not in lin.coords or not lin.specified[lin.coords.index(vname)]:
        raise InputError(f"input ('motion', {name!r}): {vname} is not a specified "
                         "generalized coordinate (SGC) of this linearization; pass it in "
                         "specified=")
    return (kind, vname), np.zeros(len(lin.coords)), lin.coords.index(vname)


def _output_vector(lin: Linearization, out: Any) -> tuple[tuple[str, str], np.ndarray]:
    """(label, d output / d psi over coords (f,)) of a position-level output."""
    kind, name = _pair(out, OUTPUT_KINDS, "output")
    system = lin.system
    if "." in name:
        head, _, axis = name.rpartition(".")
        if head in lin.points and axis.lower() in ("x", "y", "z"):
            return (kind, f"{head}.{axis.lower()}"), lin.points[head]["xyz".index(
                axis.lower())].copy()
    if name in lin.points:
        raise InputError(f"output ({kind!r}, {name!r}): name a component of the point, "
                         f"e.g. {name}.x")
    c = system.var_index(name)
    return (kind, system.var_names[c]), lin.phi[c].copy()


def _listed(x: Any, what: str) -> list:
    """One (kind, name) pair or a non-empty list of them."""
    if isinstance(x, tuple) and len(x) == 2 and isinstance(x[0], str):
        return [x]
    try:
        out = list(x)
    except TypeError:
        raise InputError(f"{what} must be a (kind, name) pair or a list of them, got "
                         f"{x!r}") from None
    if not out:
        raise InputError(f"{what}: give at least one (kind, name) pair")
    return out


def _pair(x: Any, kinds: tuple[str, ...], what: str) -> tuple[str, str]:
    if (not isinstance(x, (tuple, list)) or len(x) != 2 or not isinstance(x[0], str)
            or not isinstance(x[1], str)):
        raise InputError(f"{what} must be a pair (kind, name) with kind one of "
                         f"{', '.join(kinds)}; got {x!r}")
    k = x[0].lower()
    if k == "acceleration":
        k = "accel"
    if k not in kinds:
        raise InputError(f"{what} kind {x[0]!r}: expected one of {', '.join(kinds)}")
    return k, x[1]


def _realization(lin: Linearization, b: np.ndarray, p: int, c: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A, B, C, D of the position output c . psi for one input, state (v, x) (13.6).

    Force or load b: M x'' + D x' + K x = b_F u.  SGC motion p (x_p = u):
    M x'' + D x' + K x = -(M_Fp u'' + D_Fp u' + K_Fp u), realized with the state
    x' = x + P u, v'' = x'' ... shifted so that no derivative of u remains:
    P = M^-1 M_Fp, R = M^-1 (D P - D_Fp); x'^. = v'' + R u,
    v''^. = M^-1 (-K x' - D v'' + (K P - K_Fp - D R) u), y = c_F x' + (c_p - c_F P) u.
    """
    MFF, DFF, KFF = free_blocks(lin)
    F = lin.free
    nf = F.size
    Minv = np.linalg.inv(MFF)
    A = first_order(MFF, DFF, KFF)
    cF = c[F]
    C = np.concatenate([np.zeros(nf), cF])[None, :]
    if p < 0:
        B = np.concatenate([Minv @ b[F], np.zeros(nf)])[:, None]
        return A, B, C, np.zeros((1, 1))
    Mp, Dp, Kp = lin.M[F, p], lin.D[F, p], lin.K[F, p]
    P = Minv @ Mp
    R = Minv @ (DFF @ P - Dp)
    B = np.concatenate([Minv @ (KFF @ P - Kp - DFF @ R), R])[:, None]
    return A, B, C, np.array([[c[p] - cF @ P]])


def transfer_function(lin: Linearization, input: Any, output: Any) -> TransferFunction:
    """H(s) from ``input`` to ``output`` as a rational function of s (13.18-13.21), every
    SGC but a motion input locked.  Velocity and acceleration outputs are s and s^2
    times the position's."""
    (ilab, b, p), (olab, c) = _input_vector(lin, input), _output_vector(lin, output)
    if lin.free.size == 0:
        raise AnalysisError(no_fgc("transfer_function", lin))
    A, B, C, D = _realization(lin, b, p, c)
    num, den = _ss2tf(A, B, C, D)
    extra = OUTPUT_KINDS.index(olab[0])
    num = np.concatenate([num, np.zeros(extra)])
    return TransferFunction(ilab, olab, _trim(num), den)


def _ss2tf(A: np.ndarray, B: np.ndarray, C: np.ndarray, D: np.ndarray
           ) -> tuple[np.ndarray, np.ndarray]:
    """num, den of H(s) = C (sI - A)^-1 B + D (one input, one output), from roots.

    den = det(sI - A) from the eigenvalues of A (monic); num = g prod (s - z_i)
    with the zeros z_i the finite generalized eigenvalues of the Rosenbrock
    pencil ([[A, B], [C, D]], [[I, 0], [0, 0]]) (QZ: backward stable) and the
    gain g from H at the sample of largest |H| among points on the circle of
    the eigenvalues' geometric-mean size (turned off the axes, where poles of
    real and undamped modes sit).  Subtracting polynomials instead loses every
    digit on a stiff system.  Terms below 1e-12 of the largest at that size are
    round-off and set to zero.
    """
    lam = np.linalg.eigvals(A)
    n = lam.size
    mags = np.abs(lam[np.abs(lam) > 0])
    w0 = float(np.exp(np.mean(np.log(mags)))) if mags.size else 1.0
    den = _clean(np.real(np.poly(lam)), w0)
    P = np.block([[A, B], [C, D]])
    Q = np.zeros_like(P)
    Q[:n, :n] = np.eye(n)
    with np.errstate(all="ignore"):
        z = scipy.linalg.eigvals(P, Q)
    z = z[np.isfinite(z) & (np.abs(z) < 1e10 * max(w0, 1.0))]
    sk = w0 * np.exp(2j * np.pi * (np.arange(n + 1) + 0.3) / (n + 1))
    H = np.array([(C @ np.linalg.solve(sv * np.eye(n) - A, B))[0, 0] + D[0, 0] for sv in sk])
    k = int(np.argmax(np.abs(H)))
    if abs(H[k]) == 0.0:
        return np.zeros(1), den
    g = H[k] * np.polyval(den, sk[k]) / np.prod(sk[k] - z)
    num = np.real(g * np.poly(z)) if z.size else np.array([g.real])
    return _trim(_clean(num, w0)), den


def _clean(c: np.ndarray, w0: float) -> np.ndarray:
    """Zero the coefficients (highest power first) whose terms at |s| = w0 are below
    1e-12 of the largest: round-off of a cancelled or absent power."""
    terms = np.abs(c) * w0 ** np.arange(c.size - 1, -1, -1)
    big = float(terms.max()) if terms.size else 0.0
    out = c.copy()
    out[terms <= 1e-12 * big] = 0.0
    return out


def _trim(num: np.ndarray) -> np.ndarray:
    """Drop leading zero coefficients (a numerator of lower degree)."""
    k = 0
    while k < num.size - 1 and num[k] == 0.0:
        k += 1
    return num[k:]


def frequency_response(lin: Linearization, input: Any, outputs: Any, w: Any
                       ) -> FrequencyResponse:
    """H(j w) (13.20, 13.21) of one input to each output at frequencies ``w`` (rad/s),
    solved at each w from (s^2 M_FF + s D_FF + K_FF) x_F = rhs, not from polynomials."""
    ilab, b, p = _input_vector(lin, input)
    outs = [_output_vector(lin, o) for o in _listed(outputs, "outputs")]
    wv = np.atleast_1d(floats(w, "frequency_response: w"))
    if wv.ndim != 1 or not np.all(np.isfinite(wv)) or np.any(wv < 0) or wv.size == 0:
        raise InputError("frequency_response: w must be finite frequencies >= 0 (rad/s)")
    if wv.size > MAX_STEPS:
        raise InputError(f"frequency_response: {wv.size} frequencies are more than {MAX_STEPS} "
                         "(limit MAX_STEPS); give fewer")
    if lin.free.size == 0:
        raise AnalysisError(no_fgc("frequency_response", lin))
    MFF, DFF, KFF = free_blocks(lin)
    F = lin.free
    H = np.zeros((wv.size, len(outs)), complex)
    for k, om in enumerate(wv):
        s = 1j * om
        Z = s * s * MFF + s * DFF + KFF
        if p < 0:
            rhs, xs = b[F].astype(complex), 0.0
        else:
            rhs = -(s * s * lin.M[F, p] + s * lin.D[F, p] + lin.K[F, p])
            xs = 1.0
        try:
            xF = np.linalg.solve(Z, rhs)
        except np.linalg.LinAlgError:
            raise AnalysisError(f"frequency_response: w = {om:g} rad/s is a pole of the "
                                "response (a rigid-body mode at 0, or an undamped mode at "
                                "that frequency); leave it out of w") from None
        with np.errstate(all="ignore"):  # an extreme w overflows to inf, said by the value
            for o, ((kind, _), c) in enumerate(outs):
                y = c[F] @ xF + (c[p] * xs if p >= 0 else 0.0)
                H[k, o] = y * s ** OUTPUT_KINDS.index(kind)
    return FrequencyResponse(wv, H, ilab, [lab for lab, _ in outs])


def state_space(lin: Linearization, inputs: Any, outputs: Any) -> StateSpace:
    """A, B, C, D of the FGC equations (14.11) for ``inputs`` and ``outputs``, state
    (v_F, x_F) (13.6).  A motion input shifts the state (see :func:`transfer_function`);
    it then allows only position outputs (a velocity or acceleration output would
    need derivatives of the input) and no other input."""
    if isinstance(inputs, tuple) and len(inputs) == 2 and isinstance(inputs[0], str):
        inputs = [inputs]
    if isinstance(outputs, tuple) and len(outputs) == 2 and isinstance(outputs[0], str):
        outputs = [outputs]
    ins = [_input_vector(lin, i) for i in inputs]
    outs = [_output_vector(lin, o) for o in outputs]
    if not ins or not outs:
        raise InputError("state_space needs at least one input and one output")
    if lin.free.size == 0:
        raise AnalysisError(no_fgc("state_space", lin))
    motion = [lab for lab, _, p in ins if p >= 0]
    if motion and len(ins) > 1:
        raise InputError("state_space: an SGC motion input shifts the state, so it must be "
                         "the only input; build one model per motion input")
    F = lin.free
    nf = F.size
    MFF, DFF, KFF = free_blocks(lin)
    Minv = np.linalg.inv(MFF)
    rows_C, rows_D = [], []
    if motion:
        _, b, p = ins[0]
        for (kind, name), c in outs:
            if kind != "position":
                raise InputError(f"state_space: output ({kind!r}, {name!r}) of a motion "
                                 "input is improper (it needs derivatives of the motion); "
                                 "use a position output or transfer_function")
            A, B, C, D = _realization(lin, b, p, c)
            rows_C.append(C[0])
            rows_D.append(D[0])
    else:
        A = first_order(MFF, DFF, KFF)
        B = np.column_stack([np.concatenate([Minv @ b[F], np.zeros(nf)])
                             for _, b, _ in ins])
        bF = np.column_stack([b[F] for _, b, _ in ins])
        for (kind, _), c in outs:
            cF = c[F]
            if kind == "position":
                rows_C.append(np.concatenate([np.zeros(nf), cF]))
                rows_D.append(np.zeros(len(ins)))
            elif kind == "velocity":
                rows_C.append(np.concatenate([cF, np.zeros(nf)]))
                rows_D.append(np.zeros(len(ins)))
            else:
                rows_C.append(cF @ A[:nf])
                rows_D.append(cF @ Minv @ bF)
    free = [lin.coords[i] for i in F]
    states = [f"{n}'" for n in free] + list(free)
    return StateSpace(A, B, np.array(rows_C), np.array(rows_D), states,
                      [lab for lab, _, _ in ins], [lab for lab, _ in outs])
