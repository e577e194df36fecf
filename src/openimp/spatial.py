"""Spatial kinematics: rotations, 4x4 transforms, screws and lines (book chapter 3).

Pure numpy.  Every function accepts a leading batch shape: points and vectors are
``(..., 3)``, homogeneous transforms ``(..., 4, 4)``, rotation matrices Θ
``(..., 3, 3)`` (functions that *read* a rotation also accept a 4x4 transform and
use its upper-left block), Euler-Rodrigues parameters / quaternions ``(..., 4)``
and Plücker lines ``(..., 6)``.  Angles are in radians and may be arrays; batch
shapes broadcast against each other.

Conventions (Uicker, Ravani & Sheth 2013, chapter 3; where an equation is
printed wrongly in the book, the function that implements it says so and
follows the corrected form, e.g. (3.9) in :func:`plucker_from_points`):

* ``T = [[Θ, d], [0, 1]]`` maps body coordinates to the fixed frame (3.25).
* ``skew(a) @ b == cross(a, b)`` (3.12).
* Rotations are active and right-handed (counterclockwise positive).
* Euler-Rodrigues parameters ``e = [e1, e2, e3, e4] = [w sin(θ/2), cos(θ/2)]``
  (3.48): the scalar part is **last**.  Quaternions use the same layout
  ``[x, y, z, w]`` (3.62), with Hamilton's product (ij = k).
* A Plücker line is the 6-vector ``[a, b, c, d, e, f] = [Ω; Ω̂]``: moment
  ``Ω = r × Ω̂`` first, direction ``Ω̂`` last (3.7), the same order as the screw
  coordinates of chapter 6.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from openimp.errors import InputError

__all__ = [
    "axis_angle_to_er",
    "er_angular_velocity",
    "er_rates",
    "er_to_axis_angle",
    "er_to_rotation",
    "euler_to_rotation",
    "frame_from_points",
    "inverse",
    "plucker_displace",
    "plucker_distance",
    "plucker_from_point_direction",
    "plucker_from_points",
    "plucker_point",
    "quat_conjugate",
    "quat_inverse",
    "quat_multiply",
    "quat_rotate",
    "quat_to_rotation",
    "rot_x",
    "rot_y",
    "rot_z",
    "rotation_about",
    "rotation_to_er",
    "rotation_to_euler",
    "rotation_to_quat",
    "rotation_to_rpy",
    "rpy_to_rotation",
    "screw_to_transform",
    "screw_transform",
    "skew",
    "three_point_displacement",
    "transform",
    "transform_to_screw",
    "translation",
    "unskew",
]

FloatArray = npt.NDArray[np.float64]

#: Default relative tolerance used to detect degenerate geometric input.
GEOMETRY_TOL = 1e-10


# --------------------------------------------------------------------------- helpers


def _f(x: npt.ArrayLike) -> FloatArray:
    """Return ``x`` as a float64 array (no copy when already float64)."""
    return np.asarray(x, dtype=np.float64)


def _vec3(x: npt.ArrayLike, name: str) -> FloatArray:
    a = _f(x)
    if a.ndim < 1 or a.shape[-1] != 3:
        raise InputError(f"{name} must have shape (..., 3); got shape {a.shape}")
    return a


def _rot3(R: npt.ArrayLike, name: str = "R") -> FloatArray:
    """Rotation block of a (..., 3, 3) rotation or a (..., 4, 4) transform."""
    a = _f(R)
    if a.ndim < 2 or a.shape[-2:] not in ((3, 3), (4, 4)):
        raise InputError(f"{name} must have shape (..., 3, 3) or (..., 4, 4); got {a.shape}")
    return a[..., :3, :3]


def _tf(T: npt.ArrayLike, name: str = "T") -> FloatArray:
    a = _f(T)
    if a.ndim < 2 or a.shape[-2:] != (4, 4):
        raise InputError(f"{name} must have shape (..., 4, 4); got shape {a.shape}")
    return a


def _vec4(x: npt.ArrayLike, name: str) -> FloatArray:
    a = _f(x)
    if a.ndim < 1 or a.shape[-1] != 4:
        raise InputError(f"{name} must have shape (..., 4); got shape {a.shape}")
    return a


def _line(x: npt.ArrayLike, name: str = "line") -> FloatArray:
    a = _f(x)
    if a.ndim < 1 or a.shape[-1] != 6:
        raise InputError(f"{name} must have shape (..., 6) = [moment; direction]; got {a.shape}")
    return a


def _norm(a: FloatArray) -> FloatArray:
    return np.sqrt(np.sum(a * a, axis=-1))


def _dot(a: FloatArray, b: FloatArray) -> FloatArray:
    return np.sum(a * b, axis=-1)


def _scalar(x: FloatArray) -> FloatArray:
    """Turn a 0-d array into a numpy scalar, leave batched arrays alone."""
    return x[()] if isinstance(x, np.ndarray) and x.ndim == 0 else x


def _where_bad(mask: FloatArray) -> str:
    """Describe where a boolean mask is true (for batched error messages)."""
    mask = np.asarray(mask)
    if mask.ndim == 0:
        return ""
    idx = tuple(int(i) for i in np.argwhere(mask)[0])
    return f" (first at batch index {idx})"


def _wrap(a: FloatArray) -> FloatArray:
    """Wrap angles into (-pi, pi]."""
    return np.arctan2(np.sin(a), np.cos(a))


def _mat3(rows: list[list[FloatArray]]) -> FloatArray:
    """Stack 3x3 nested lists of broadcastable arrays into (..., 3, 3)."""
    shape = np.broadcast_shapes(*(np.shape(x) for row in rows for x in row))
    out = np.empty((*shape, 3, 3))
    for i, row in enumerate(rows):
        for j, x in enumerate(row):
            out[..., i, j] = x
    return out


# --------------------------------------------------------------------------- basics


def skew(a: npt.ArrayLike) -> FloatArray:
    """Skew-symmetric matrix ã of a 3-vector (3.12): ``skew(a) @ b = a × b``.

    ``a`` has shape (..., 3); the result has shape (..., 3, 3) and equals
    ``[[0, -a_z, a_y], [a_z, 0, -a_x], [-a_y, a_x, 0]]``.
    """
    a = _vec3(a, "a")
    x, y, z = a[..., 0], a[..., 1], a[..., 2]
    zero = np.zeros_like(x)
    return _mat3([[zero, -z, y], [z, zero, -x], [-y, x, zero]])


def unskew(M: npt.ArrayLike) -> FloatArray:
    """Inverse of :func:`skew`: the vector ``[M(3,2), M(1,3), M(2,1)]``.

    As in the screw-coordinate operator (6.41) only these three entries are
    read, so ``unskew(skew(a)) == a`` exactly.  ``M`` may be (..., 3, 3) or
    (..., 4, 4) (the upper-left block is used).
    """
    M = _f(M)
    if M.ndim < 2 or M.shape[-2:] not in ((3, 3), (4, 4)):
        raise InputError(f"M must have shape (..., 3, 3) or (..., 4, 4); got {M.shape}")
    return np.stack([M[..., 2, 1], M[..., 0, 2], M[..., 1, 0]], axis=-1)


def transform(R: npt.ArrayLike, p: npt.ArrayLike) -> FloatArray:
    """Homogeneous transform ``T = [[Θ, p], [0 0 0, 1]]`` (3.25).

    ``R`` is a (..., 3, 3) rotation (its columns are the unit vectors u, v, w of
    the moving frame, 3.26) and ``p`` a (..., 3) origin; batch shapes broadcast.
    """
    R = _f(R)
    if R.ndim < 2 or R.shape[-2:] != (3, 3):
        raise InputError(f"R must have shape (..., 3, 3); got shape {R.shape}")
    p = _vec3(p, "p")
    shape = np.broadcast_shapes(R.shape[:-2], p.shape[:-1])
    T = np.zeros((*shape, 4, 4))
    T[..., :3, :3] = R
    T[..., :3, 3] = p
    T[..., 3, 3] = 1.0
    return T


def inverse(T: npt.ArrayLike) -> FloatArray:
    """Rigid inverse of a (..., 4, 4) transform: ``[[Θᵗ, -Θᵗ p], [0, 1]]``.

    Valid only for rigid transforms (orthogonal Θ); no general matrix inverse
    is computed.
    """
    T = _tf(T)
    Rt = np.swapaxes(T[..., :3, :3], -1, -2)
    out = np.zeros_like(T)
    out[..., :3, :3] = Rt
    out[..., :3, 3] = -np.einsum("...ij,...j->...i", Rt, T[..., :3, 3])
    out[..., 3, 3] = 1.0
    return out


def translation(p: npt.ArrayLike) -> FloatArray:
    """Pure translation transform ``[[I, p], [0, 1]]``; ``p`` is (..., 3)."""
    p = _vec3(p, "p")
    return transform(np.broadcast_to(np.eye(3), (*p.shape[:-1], 3, 3)), p)


def _rot4(c: FloatArray, s: FloatArray, axis: int) -> FloatArray:
    T = np.zeros((*c.shape, 4, 4))
    T[..., 3, 3] = 1.0
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    T[..., axis, axis] = 1.0
    T[..., i, i] = c
    T[..., j, j] = c
    T[..., i, j] = -s
    T[..., j, i] = s
    return T


def rot_x(a: npt.ArrayLike) -> FloatArray:
    """4x4 rotation by angle ``a`` (counterclockwise) about the x axis; shape (..., 4, 4)."""
    a = _f(a)
    return _rot4(np.cos(a), np.sin(a), 0)


def rot_y(a: npt.ArrayLike) -> FloatArray:
    """4x4 rotation by angle ``a`` (counterclockwise) about the y axis; shape (..., 4, 4)."""
    a = _f(a)
    return _rot4(np.cos(a), np.sin(a), 1)


def rot_z(a: npt.ArrayLike) -> FloatArray:
    """4x4 rotation by angle ``a`` (counterclockwise) about the z axis; shape (..., 4, 4)."""
    a = _f(a)
    return _rot4(np.cos(a), np.sin(a), 2)


# --------------------------------------------------------------------------- screw displacement


def _unit_axis(axis: npt.ArrayLike, name: str = "axis") -> FloatArray:
    w = _vec3(axis, name)
    n = _norm(w)
    bad = ~(n > 0.0)
    if np.any(bad):
        raise InputError(f"{name} must be a nonzero vector{_where_bad(bad)}")
    return w / n[..., None]


def rotation_about(axis: npt.ArrayLike, angle: npt.ArrayLike) -> FloatArray:
    """Rotation Θ by ``angle`` about ``axis`` through the origin, Rodrigues form (3.37).

    ``Θ = I + w̃ sin θ + w̃² (1 - cos θ)`` with ``w = axis / |axis|`` (the axis
    need not be a unit vector but must be nonzero).  Elementwise this is (3.40).
    Returns (..., 3, 3).
    """
    w = _unit_axis(axis)
    th = _f(angle)
    W = skew(w)
    s = np.sin(th)[..., None, None]
    vc = (1.0 - np.cos(th))[..., None, None]
    return np.eye(3) + s * W + vc * (W @ W)


def screw_transform(
    axis: npt.ArrayLike, point: npt.ArrayLike, angle: npt.ArrayLike, slide: npt.ArrayLike
) -> FloatArray:
    """4x4 screw displacement (3.39)-(3.41).

    Rotation by ``angle`` θ about the line through ``point`` P with direction
    ``axis`` (normalised to w), plus translation ``slide`` φ along w:
    ``T = [[Θ, d], [0, 1]]`` with Θ from (3.37) and ``d = (I - Θ) P + φ w`` (3.38).
    """
    w = _unit_axis(axis)
    P = _vec3(point, "point")
    R = rotation_about(w, angle)
    phi = _f(slide)
    d = P - np.einsum("...ij,...j->...i", R, P) + phi[..., None] * w
    return transform(R, d)


# --------------------------------------------------------------------------- Euler / Cardan angles


def euler_to_rotation(xi: npt.ArrayLike, theta: npt.ArrayLike, phi: npt.ArrayLike) -> FloatArray:
    """Rotation of z-x-z Euler angles, ``Θ = Rz(ξ) Rx(ϑ) Rz(φ)`` (3.44), shape (..., 3, 3).

    ξ is the precession (about z, to the line of nodes), ϑ the nutation (about
    the line of nodes) and φ the spin (about the new z).
    """
    xi, theta, phi = _f(xi), _f(theta), _f(phi)
    sx, cx = np.sin(xi), np.cos(xi)
    st, ct = np.sin(theta), np.cos(theta)
    sp, cp = np.sin(phi), np.cos(phi)
    return _mat3(
        [
            [-sx * ct * sp + cx * cp, -sx * ct * cp - cx * sp, sx * st],
            [cx * ct * sp + sx * cp, cx * ct * cp - sx * sp, -cx * st],
            [st * sp, st * cp, ct],
        ]
    )


def rotation_to_euler(
    R: npt.ArrayLike, tol: float = 1e-12
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """z-x-z Euler angles ``(ξ, ϑ, φ)`` of a rotation, inverse of :func:`euler_to_rotation`.

    ϑ = atan2(√(Θ13² + Θ23²), Θ33) lies in [0, π]; ξ and φ are in (-π, π].
    ξ = atan2(Θ13, -Θ23) and φ is obtained from the well-conditioned sum
    ξ + φ = atan2(Θ21 - Θ12, Θ11 + Θ22) (when cos ϑ ≥ 0) or difference
    ξ - φ = atan2(Θ21 + Θ12, Θ11 - Θ22) (when cos ϑ < 0), so the angles
    reproduce Θ to machine precision even close to gimbal lock.

    Gimbal lock (sin ϑ ≤ ``tol``, i.e. ϑ ≈ 0 or ϑ ≈ π): only ξ + φ (resp.
    ξ - φ) is defined; by convention **φ = 0** and all of the rotation about z
    is put in ξ.  ``R`` may be (..., 3, 3) or (..., 4, 4).
    """
    Th = _rot3(R)
    st = np.hypot(Th[..., 0, 2], Th[..., 1, 2])
    ct = Th[..., 2, 2]
    theta = np.arctan2(st, ct)
    xi = np.arctan2(Th[..., 0, 2], -Th[..., 1, 2])
    # ξ + φ and ξ - φ from the upper-left 2x2 block.
    ssum = np.arctan2(Th[..., 1, 0] - Th[..., 0, 1], Th[..., 0, 0] + Th[..., 1, 1])
    sdif = np.arctan2(Th[..., 1, 0] + Th[..., 0, 1], Th[..., 0, 0] - Th[..., 1, 1])
    upper = ct >= 0.0
    lock = st <= tol
    xi = np.where(lock, np.where(upper, ssum, sdif), xi)
    phi = np.where(upper, ssum - xi, xi - sdif)
    phi = np.where(lock, 0.0, _wrap(phi))
    return _scalar(xi), _scalar(theta), _scalar(phi)


def rpy_to_rotation(alpha: npt.ArrayLike, beta: npt.ArrayLike, gamma: npt.ArrayLike) -> FloatArray:
    """Cardan (Tait-Bryan, roll-pitch-yaw) rotation ``Rx(α) Ry(β) Rz(γ)`` (3.46), (..., 3, 3)."""
    a, b, g = _f(alpha), _f(beta), _f(gamma)
    sa, ca = np.sin(a), np.cos(a)
    sb, cb = np.sin(b), np.cos(b)
    sg, cg = np.sin(g), np.cos(g)
    return _mat3(
        [
            [cb * cg, -cb * sg, sb],
            [sa * sb * cg + ca * sg, -sa * sb * sg + ca * cg, -sa * cb],
            [-ca * sb * cg + sa * sg, ca * sb * sg + sa * cg, ca * cb],
        ]
    )


def rotation_to_rpy(
    R: npt.ArrayLike, tol: float = 1e-12
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Cardan angles ``(α, β, γ)``, ``Θ = Rx(α) Ry(β) Rz(γ)``; inverse of :func:`rpy_to_rotation`.

    β = atan2(Θ13, √(Θ11² + Θ12²)) lies in [-π/2, π/2]; α = atan2(-Θ23, Θ33)
    and γ follows from the well-conditioned α + γ = atan2(Θ21 + Θ32, Θ22 - Θ31)
    (β ≥ 0) or α - γ = atan2(Θ32 - Θ21, Θ22 + Θ31) (β < 0); α, γ in (-π, π].

    Gimbal lock (cos β ≤ ``tol``, β = ±90°): only α ± γ is defined; by
    convention **γ = 0** and the whole rotation about x is put in α.
    ``R`` may be (..., 3, 3) or (..., 4, 4).
    """
    Th = _rot3(R)
    cb = np.hypot(Th[..., 0, 0], Th[..., 0, 1])
    sb = Th[..., 0, 2]
    beta = np.arctan2(sb, cb)
    alpha = np.arctan2(-Th[..., 1, 2], Th[..., 2, 2])
    ssum = np.arctan2(Th[..., 1, 0] + Th[..., 2, 1], Th[..., 1, 1] - Th[..., 2, 0])
    sdif = np.arctan2(Th[..., 2, 1] - Th[..., 1, 0], Th[..., 1, 1] + Th[..., 2, 0])
    upper = sb >= 0.0
    lock = cb <= tol
    alpha = np.where(lock, np.where(upper, ssum, sdif), alpha)
    gamma = np.where(upper, ssum - alpha, alpha - sdif)
    gamma = np.where(lock, 0.0, _wrap(gamma))
    return _scalar(alpha), _scalar(beta), _scalar(gamma)


# --------------------------------------------------------------------------- Euler-Rodrigues


def er_to_rotation(e: npt.ArrayLike) -> FloatArray:
    """Rotation Θ of Euler-Rodrigues parameters ``e = [e1, e2, e3, e4]`` (3.50), (..., 3, 3).

    ``e`` is normalised first (so any nonzero multiple gives the same Θ);
    e4 is the scalar part cos(θ/2).
    """
    e = _vec4(e, "e")
    n = _norm(e)
    bad = ~(n > 0.0)
    if np.any(bad):
        raise InputError(f"Euler-Rodrigues parameters must not be all zero{_where_bad(bad)}")
    e = e / n[..., None]
    e1, e2, e3, e4 = e[..., 0], e[..., 1], e[..., 2], e[..., 3]
    return _mat3(
        [
            [
                e1 * e1 - e2 * e2 - e3 * e3 + e4 * e4,
                2 * (e1 * e2 - e3 * e4),
                2 * (e1 * e3 + e2 * e4),
            ],
            [
                2 * (e1 * e2 + e3 * e4),
                -e1 * e1 + e2 * e2 - e3 * e3 + e4 * e4,
                2 * (e2 * e3 - e1 * e4),
            ],
            [
                2 * (e1 * e3 - e2 * e4),
                2 * (e2 * e3 + e1 * e4),
                -e1 * e1 - e2 * e2 + e3 * e3 + e4 * e4,
            ],
        ]
    )


def rotation_to_er(R: npt.ArrayLike, eps: float = 1e-6) -> FloatArray:
    """Euler-Rodrigues parameters of a rotation, Friberg's procedure (3.51)-(3.55).

    Returns ``e`` (..., 4) with ``e4 ≥ 0`` (the book's choice of the + sign in
    (3.51)) and ``er_to_rotation(e) == R`` to machine precision.

    The four magnitudes come from the diagonal: ``4 (e4)² = trace Θ + 1``
    (3.51) and ``4 (ek)² = 1 + 2 Θ(k,k) - trace Θ`` (3.53).

    * **Case 1** (``|e4| > eps`` and e4 is the largest of the four):
      ``e4 = +½ √(trace Θ + 1)`` and e1, e2, e3 from the differences of the
      off-diagonal elements (3.52).  Here ``|e4| ≥ ½``, so the divisions by
      4e4 are well conditioned.  (The book's "magnitudes from (3.53), signs from
      (3.52)" variant is not used: its square roots amplify rounding errors of
      small parameters to ~1e-8.)
    * **Case 2** (``|e4| ≤ eps``, the rotation is near 180°, Θ nearly
      symmetric -- and, for accuracy, also whenever one of e1, e2, e3 is larger
      than e4): the largest ek is taken from the diagonal ((3.53), which is
      (3.55) when e4 = 0) with a + sign, the other two from the off-diagonal
      sums (3.54), ``ej = [Θ(j,k) + Θ(k,j)] / (4 ek)``, and e4 from the matching
      (3.52) numerator divided by 4 ek.  Finally the sign of the whole vector is
      chosen so that e4 ≥ 0 (when e4 is exactly 0, the largest ek stays
      positive, as in Example 3.3).

    ``R`` may be (..., 3, 3) or (..., 4, 4).  The result is normalised to unit
    length.
    """
    Th = _rot3(R)
    t = Th[..., 0, 0] + Th[..., 1, 1] + Th[..., 2, 2]
    m4 = t + 1.0  # 4 e4²
    mk = 1.0 + 2.0 * np.stack([Th[..., 0, 0], Th[..., 1, 1], Th[..., 2, 2]], axis=-1) - t[..., None]
    # antisymmetric (3.52) and symmetric (3.54) numerators
    a1 = Th[..., 2, 1] - Th[..., 1, 2]
    a2 = Th[..., 0, 2] - Th[..., 2, 0]
    a3 = Th[..., 1, 0] - Th[..., 0, 1]
    s23 = Th[..., 1, 2] + Th[..., 2, 1]
    s31 = Th[..., 2, 0] + Th[..., 0, 2]
    s12 = Th[..., 0, 1] + Th[..., 1, 0]

    e4_book = 0.5 * np.sqrt(np.maximum(m4, 0.0))
    case1 = (e4_book > eps) & (m4 >= np.max(mk, axis=-1))
    with np.errstate(divide="ignore", invalid="ignore"):
        # Case 1: pivot on e4.
        d = 4.0 * np.where(case1, e4_book, 1.0)
        c1 = np.stack([a1 / d, a2 / d, a3 / d, e4_book], axis=-1)
        # Case 2: pivot on the largest of e1, e2, e3.
        k = np.argmax(mk, axis=-1)
        ek = 0.5 * np.sqrt(np.maximum(np.take_along_axis(mk, k[..., None], axis=-1)[..., 0], 0.0))
        dk = 4.0 * np.where(ek > 0.0, ek, 1.0)
        cand = [
            np.stack([ek, s12 / dk, s31 / dk, a1 / dk], axis=-1),
            np.stack([s12 / dk, ek, s23 / dk, a2 / dk], axis=-1),
            np.stack([s31 / dk, s23 / dk, ek, a3 / dk], axis=-1),
        ]
        c2 = np.where((k == 0)[..., None], cand[0], np.where((k == 1)[..., None], cand[1], cand[2]))
        c2 = np.where((c2[..., 3] < 0.0)[..., None], -c2, c2)
    e = np.where(case1[..., None], c1, c2)
    return e / _norm(e)[..., None]


def er_to_axis_angle(e: npt.ArrayLike) -> tuple[FloatArray, FloatArray]:
    """Unit axis w and angle θ of Euler-Rodrigues parameters (3.48).

    θ = 2 atan2(|[e1, e2, e3]|, e4), so θ ∈ [0, π] when e4 ≥ 0 (as returned by
    :func:`rotation_to_er`) and θ ∈ [0, 2π] in general; w = [e1, e2, e3] / sin(θ/2).
    ``e`` need not be normalised.  For the identity (θ = 0) the axis is
    undefined and w = [0, 0, 1] is returned by convention.
    """
    e = _vec4(e, "e")
    v = e[..., :3]
    nv = _norm(v)
    theta = 2.0 * np.arctan2(nv, e[..., 3])
    safe = np.where(nv > 0.0, nv, 1.0)
    w = np.where((nv > 0.0)[..., None], v / safe[..., None], np.array([0.0, 0.0, 1.0]))
    return w, _scalar(theta)


def axis_angle_to_er(axis: npt.ArrayLike, angle: npt.ArrayLike) -> FloatArray:
    """Euler-Rodrigues parameters ``[w sin(θ/2), cos(θ/2)]`` (3.48) of a rotation θ about ``axis``.

    ``axis`` (..., 3) is normalised (it must be nonzero); ``angle`` broadcasts.
    """
    w = _unit_axis(axis)
    h = 0.5 * _f(angle)
    s = np.sin(h)[..., None]
    c = np.cos(h)[..., None]
    w, s = np.broadcast_arrays(w, s)
    return np.concatenate([w * s, np.broadcast_to(c, (*w.shape[:-1], 1))], axis=-1)


def er_rates(e: npt.ArrayLike, w: npt.ArrayLike) -> FloatArray:
    """Rates ``e'`` (..., 4) of the Euler-Rodrigues parameters ``e`` of a rotation Θ(e)
    (3.50) turning at the angular velocity ``w`` (..., 3), given in the axes that Θ maps
    into (for a SPHERE joint: the second body relative to the first, in the first
    body's joint frame u v w): Θ' Θ^T = [w]x, so e' = (w, 0) e / 2 (3.57),

        e_v' = (e4 w + w x e_v) / 2,    e4' = -(w . e_v) / 2.

    ``e`` must be normalised (|e| = 1); then e . e' = 0.  At e = (0, 0, 0, 1):
    e' = (w / 2, 0).
    """
    e = _vec4(e, "e")
    w = _vec3(w, "w")
    ev, e4 = e[..., :3], e[..., 3:]
    v = 0.5 * (e4 * w + np.cross(w, ev))
    s = -0.5 * _dot(w, ev)[..., None]
    return np.concatenate([v, s], axis=-1)


def er_angular_velocity(e: npt.ArrayLike, ed: npt.ArrayLike) -> FloatArray:
    """The angular velocity ``w`` (..., 3) of Euler-Rodrigues parameters ``e`` moving at
    ``ed`` (the inverse of :func:`er_rates`): w = 2 (e4 e_v' - e4' e_v + e_v x e_v')."""
    e = _vec4(e, "e")
    ed = _vec4(ed, "ed")
    ev, e4 = e[..., :3], e[..., 3:]
    dv, d4 = ed[..., :3], ed[..., 3:]
    return 2.0 * (e4 * dv - d4 * ev + np.cross(ev, dv))


# --------------------------------------------------------------------------- quaternions


def quat_multiply(p: npt.ArrayLike, q: npt.ArrayLike) -> FloatArray:
    """Hamilton product ``p q`` of quaternions ``[x, y, z, w]`` (3.57).

    vector part ``p4 q_v + q4 p_v + p_v × q_v``, scalar part ``p4 q4 - p_v · q_v``;
    so that ``quat_to_rotation(p q) = quat_to_rotation(p) @ quat_to_rotation(q)``.
    """
    p = _vec4(p, "p")
    q = _vec4(q, "q")
    pv, pw = p[..., :3], p[..., 3:]
    qv, qw = q[..., :3], q[..., 3:]
    v = pw * qv + qw * pv + np.cross(pv, qv)
    w = pw * qw - _dot(pv, qv)[..., None]
    return np.concatenate([v, w], axis=-1)


def quat_conjugate(q: npt.ArrayLike) -> FloatArray:
    """Conjugate ``q̄ = [-x, -y, -z, w]`` (3.59)."""
    q = _vec4(q, "q")
    return q * np.array([-1.0, -1.0, -1.0, 1.0])


def quat_inverse(q: npt.ArrayLike) -> FloatArray:
    """Inverse ``q⁻¹ = q̄ / |q|²`` (3.61); ``q`` must be nonzero."""
    q = _vec4(q, "q")
    n2 = _dot(q, q)
    bad = ~(n2 > 0.0)
    if np.any(bad):
        raise InputError(f"cannot invert a zero quaternion{_where_bad(bad)}")
    return quat_conjugate(q) / n2[..., None]


def quat_to_rotation(q: npt.ArrayLike) -> FloatArray:
    """Rotation matrix of a quaternion ``[x, y, z, w]`` (normalised first), identical to (3.50)."""
    return er_to_rotation(q)


def rotation_to_quat(R: npt.ArrayLike, eps: float = 1e-6) -> FloatArray:
    """Unit quaternion ``[x, y, z, w]`` (w ≥ 0) of a rotation; same as :func:`rotation_to_er`."""
    return rotation_to_er(R, eps)


def quat_rotate(q: npt.ArrayLike, v: npt.ArrayLike) -> FloatArray:
    """Rotate vector(s) ``v`` (..., 3) by quaternion ``q``: ``q v q⁻¹``, i.e. ``Θ(q) v``.

    Uses ``v' = v + 2 q4 (q_v × v) + 2 q_v × (q_v × v)`` after normalising q.
    """
    q = _vec4(q, "q")
    v = _vec3(v, "v")
    n = _norm(q)
    bad = ~(n > 0.0)
    if np.any(bad):
        raise InputError(f"cannot rotate by a zero quaternion{_where_bad(bad)}")
    q = q / n[..., None]
    qv, qw = q[..., :3], q[..., 3:]
    t = 2.0 * np.cross(qv, v)
    return v + qw * t + np.cross(qv, t)


# --------------------------------------------------------------------------- Chasles screw


def transform_to_screw(
    T: npt.ArrayLike, tol: float = 1e-12
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Chasles (screw) decomposition of a rigid transform, inverse of :func:`screw_to_transform`.

    Returns ``(w, P, θ, d)``: unit axis direction w (..., 3), the point P of the
    screw axis closest to the origin (P · w = 0), rotation angle θ ∈ [0, π]
    about w (right-handed) and slide d along w, such that
    ``T = screw_to_transform(w, P, θ, d)``.

    The rotation part gives (w, θ) through the Euler-Rodrigues parameters
    (robust near 180°).  With p the translation of T: ``d = w · p`` and, from
    (3.38), ``P = ½ [p⊥ + cot(θ/2) w × p⊥]`` with ``p⊥ = p - d w``.
    Pure translation (θ ≤ ``tol``): θ = 0, w = p / |p|, P = 0, d = |p|
    (w = [0, 0, 1], d = 0 for the identity).  At θ = π the sign of w is
    arbitrary (both describe the same displacement).  For very small but
    nonzero θ the axis lies far away (|P| ~ |p| / θ), and P is correspondingly
    ill-conditioned.
    """
    T = _tf(T)
    w, theta = er_to_axis_angle(rotation_to_er(T))
    theta = np.asarray(theta)
    p = T[..., :3, 3]
    pure = theta <= tol
    npn = _norm(p)
    wt = np.where(
        (npn > 0.0)[..., None], p / np.where(npn > 0.0, npn, 1.0)[..., None], [0.0, 0.0, 1.0]
    )
    w = np.where(pure[..., None], wt, w)
    theta = np.where(pure, 0.0, theta)
    d = _dot(w, p)
    pperp = p - d[..., None] * w
    half = np.where(pure, 1.0, 0.5 * theta)
    cot = np.cos(half) / np.sin(half)
    P = 0.5 * (pperp + cot[..., None] * np.cross(w, pperp))
    P = np.where(pure[..., None], 0.0, P)
    return w, P, _scalar(theta), _scalar(d)


def screw_to_transform(
    w: npt.ArrayLike, P: npt.ArrayLike, theta: npt.ArrayLike, d: npt.ArrayLike
) -> FloatArray:
    """4x4 transform of a screw displacement: rotation θ about the axis (P, w) and slide d along w.

    Same as :func:`screw_transform` (3.39)-(3.41); ``w`` is normalised.
    """
    return screw_transform(w, P, theta, d)


# --------------------------------------------------------------------------- Plücker lines


def plucker_from_points(p1: npt.ArrayLike, p2: npt.ArrayLike) -> FloatArray:
    """Plücker line ``[Ω; Ω̂]`` through two points, directed from p1 to p2 (corrected (3.9)).

    Points are Cartesian (..., 3) or homogeneous (..., 4) ``[x, y, z, w]``.
    Direction ``Ω̂ = w1 p2 - w2 p1`` (= p2 - p1 for w = 1) and moment
    ``Ω = p1 × p2`` (= r × Ω̂).  The book's (3.9) prints the direction with
    the opposite sign, inconsistent with (3.7) and (3.11); this is the
    corrected form (with the printed sign, (3.10) would put the line through
    (1,0,0) and (1,1,0) at x = -1).  A point at infinity (w = 0) is a
    direction.  Raises :class:`InputError` when the points coincide.
    """
    a, b = _f(p1), _f(p2)
    if a.ndim < 1 or a.shape[-1] not in (3, 4) or b.ndim < 1 or b.shape[-1] != a.shape[-1]:
        raise InputError(
            f"p1 and p2 must both have shape (..., 3) or (..., 4); got {a.shape} and {b.shape}"
        )
    if a.shape[-1] == 4:
        x1, w1 = a[..., :3], a[..., 3:]
        x2, w2 = b[..., :3], b[..., 3:]
        direction = w1 * x2 - w2 * x1
    else:
        x1, x2 = a, b
        direction = x2 - x1
    moment = np.cross(x1, x2)
    bad = ~(_norm(direction) > 0.0)
    if np.any(bad):
        raise InputError(f"plucker_from_points: the two points coincide{_where_bad(bad)}")
    moment, direction = np.broadcast_arrays(moment, direction)
    return np.concatenate([moment, direction], axis=-1)


def plucker_from_point_direction(p: npt.ArrayLike, d: npt.ArrayLike) -> FloatArray:
    """Plücker line ``[p × d; d]`` through point p with direction d (3.7); d must be nonzero."""
    p = _vec3(p, "p")
    d = _vec3(d, "d")
    bad = ~(_norm(d) > 0.0)
    if np.any(bad):
        raise InputError(f"line direction must be nonzero{_where_bad(bad)}")
    moment = np.cross(p, d)
    moment, d = np.broadcast_arrays(moment, d)
    return np.concatenate([moment, d], axis=-1)


def plucker_displace(T: npt.ArrayLike, line: npt.ArrayLike) -> FloatArray:
    """Image of a line under the rigid displacement T (3.56).

    Equivalent to the similarity ``T [[σ̂̃, σ], [0, 0]] T⁻¹``: direction
    ``Ω̂ = Θ σ̂`` and moment ``Ω = Θ σ + d × (Θ σ̂)``.
    """
    T = _tf(T)
    L = _line(line)
    R, p = T[..., :3, :3], T[..., :3, 3]
    rd = np.einsum("...ij,...j->...i", R, L[..., 3:])
    rm = np.einsum("...ij,...j->...i", R, L[..., :3]) + np.cross(p, rd)
    return np.concatenate([rm, rd], axis=-1)


def plucker_point(line: npt.ArrayLike, lam: npt.ArrayLike = 0.0) -> FloatArray:
    """Point of a line (3.11): ``r = (Ω̂ × Ω) / |Ω̂|² + λ Ω̂``.

    λ = 0 gives the point closest to the origin; λ is measured in units of
    the (not necessarily unit) direction Ω̂.
    """
    L = _line(line)
    m, d = L[..., :3], L[..., 3:]
    n2 = _dot(d, d)
    bad = ~(n2 > 0.0)
    if np.any(bad):
        raise InputError(f"line direction must be nonzero{_where_bad(bad)}")
    return np.cross(d, m) / n2[..., None] + _f(lam)[..., None] * d


def plucker_distance(line1: npt.ArrayLike, line2: npt.ArrayLike, tol: float = 1e-12) -> FloatArray:
    """Shortest distance between two lines.

    Skew or intersecting lines: ``|Ω̂1 · Ω2 + Ω̂2 · Ω1| / |Ω̂1 × Ω̂2|``.  Parallel
    lines (``|Ω̂1 × Ω̂2| ≤ tol |Ω̂1| |Ω̂2|``): the distance of the point of
    line 2 closest to the origin from line 1.
    """
    L1, L2 = _line(line1, "line1"), _line(line2, "line2")
    m1, d1 = L1[..., :3], L1[..., 3:]
    m2, d2 = L2[..., :3], L2[..., 3:]
    c = np.cross(d1, d2)
    nc = _norm(c)
    n1, n2 = _norm(d1), _norm(d2)
    if np.any(~(n1 > 0.0)) or np.any(~(n2 > 0.0)):
        raise InputError("line direction must be nonzero")
    parallel = nc <= tol * n1 * n2
    skew_dist = np.abs(_dot(d1, m2) + _dot(d2, m1)) / np.where(parallel, 1.0, nc)
    # parallel: moment of line 1 about a point r2 of line 2 is m1 - r2 × d1.
    r2 = np.cross(d2, m2) / (n2 * n2)[..., None]
    par_dist = _norm(m1 - np.cross(r2, d1)) / n1
    return _scalar(np.where(parallel, par_dist, skew_dist))


# --------------------------------------------------------------------------- frames from points


def frame_from_points(
    p1: npt.ArrayLike, p2: npt.ArrayLike, p3: npt.ArrayLike, tol: float = GEOMETRY_TOL
) -> FloatArray:
    """Transform of the frame uvw defined by three measured points (book §4.4, eq. 4.1).

    ``p1`` is the origin, ``p2`` a point on the +w axis, ``p3`` a point in the
    half-plane bounded by the w axis that contains +u.  Steps: column 4 = p1;
    w = (p2 - p1)/|p2 - p1|; u = (p3 - p1)/|p3 - p1|; v = w × u normalised;
    u overwritten by v × w, so the frame is orthonormal even when the angle
    3-1-2 is not exactly 90°.

    Raises :class:`InputError` when p2 or p3 coincides with p1 (distance at most
    ``tol`` times the size of the data) or the three points are collinear
    (sine of the angle 3-1-2 at most ``tol``).
    """
    a, b, c = _vec3(p1, "p1"), _vec3(p2, "p2"), _vec3(p3, "p3")
    a, b, c = np.broadcast_arrays(a, b, c)
    scale = np.maximum(np.maximum(_norm(a), _norm(b)), np.maximum(_norm(c), 1.0))
    w = b - a
    w2 = _norm(w)
    bad = ~(w2 > tol * scale)
    if np.any(bad):
        raise InputError(
            "frame_from_points: point 2 (on the +w axis) coincides with point 1 (the origin)"
            + _where_bad(bad)
        )
    u = c - a
    u3 = _norm(u)
    bad = ~(u3 > tol * scale)
    if np.any(bad):
        raise InputError(
            "frame_from_points: point 3 (in the +u half-plane) coincides with point 1 (the origin)"
            + _where_bad(bad)
        )
    w = w / w2[..., None]
    u = u / u3[..., None]
    v = np.cross(w, u)
    nv = _norm(v)
    bad = ~(nv > tol)
    if np.any(bad):
        raise InputError(
            "frame_from_points: the three points are collinear; point 3 must lie off the "
            "line through points 1 and 2" + _where_bad(bad)
        )
    v = v / nv[..., None]
    u = np.cross(v, w)
    return transform(np.stack([u, v, w], axis=-1), a)


def three_point_displacement(r_before: npt.ArrayLike, r_after: npt.ArrayLike) -> FloatArray:
    """Displacement T of a rigid body from three of its points, (3.29)-(3.32).

    ``r_before`` and ``r_after`` have shape (..., 3, 3) (three points as rows,
    Cartesian) or (..., 3, 4) (homogeneous rows, divided by their last entry).
    A fourth point ``r4 = r1 + (r2 - r1) × (r3 - r1)`` (3.29) is added to both
    sets and ``T = [R1 R2 R3 R4] [r1 r2 r3 r4]⁻¹`` (3.32), so that ``R = T r``
    (3.31).  T is exactly rigid only for exact (consistent) data; no
    re-orthogonalisation is done.  Raises :class:`InputError` when the three
    initial points are (nearly) collinear.
    """

    def cart(x: npt.ArrayLike, name: str) -> FloatArray:
        a = _f(x)
        if a.ndim < 2 or a.shape[-2] != 3 or a.shape[-1] not in (3, 4):
            raise InputError(f"{name} must have shape (..., 3, 3) or (..., 3, 4); got {a.shape}")
        if a.shape[-1] == 4:
            a = a[..., :3] / a[..., 3:]
        return a

    def columns(pts: FloatArray) -> FloatArray:
        r1, r2, r3 = pts[..., 0, :], pts[..., 1, :], pts[..., 2, :]
        r4 = r1 + np.cross(r2 - r1, r3 - r1)
        M = np.ones((*pts.shape[:-2], 4, 4))
        M[..., :3, :] = np.stack([r1, r2, r3, r4], axis=-1)
        return M

    rb = cart(r_before, "r_before")
    ra = cart(r_after, "r_after")
    rb, ra = np.broadcast_arrays(rb, ra)
    e1 = rb[..., 1, :] - rb[..., 0, :]
    e2 = rb[..., 2, :] - rb[..., 0, :]
    n = _norm(np.cross(e1, e2))
    bad = ~(n > GEOMETRY_TOL * _norm(e1) * _norm(e2))
    if np.any(bad):
        raise InputError(
            "three_point_displacement: the three initial points are coincident or collinear"
            + _where_bad(bad)
        )
    A = columns(ra)
    B = columns(rb)
    # T = A B⁻¹  <=>  Bᵗ Tᵗ = Aᵗ
    Tt = np.linalg.solve(np.swapaxes(B, -1, -2), np.swapaxes(A, -1, -2))
    T = np.swapaxes(Tt, -1, -2)
    T[..., 3, :] = [0.0, 0.0, 0.0, 1.0]
    return T
