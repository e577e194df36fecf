"""Mass properties: the book's 4x4 pseudo-inertia (chapter 9, §9.3) and unit systems (§9.4).

The pseudo-inertia of a rigid body is

    J = ∫ r r^t dm,   r = [x y z 1]^t                                       (9.2)

a symmetric 4x4 matrix whose upper-left 3x3 block holds the second moments
``Σ = ∫ x x^t dm`` (products of inertia *without* a minus sign), whose last
row and column hold the first moments ``m c`` and whose corner is the mass
``m`` (9.6).  Every function here returns ``J`` about the **global origin on
global axes**; :func:`transform` re-expresses it in another frame
(``J_body = T^-1 J (T^-1)^t``).

Inertia tensors given by the user follow the usual engineering convention
``I = ∫ (|s|^2 E - s s^t) dm`` (moments on the diagonal, *negative* products
off it).  The two are related by ``Σ = ½ trace(I) E - I`` and
``I = trace(Σ) E - Σ``.

Nothing here warns through :mod:`warnings`: :func:`check_inertia` returns its
findings as strings and the caller decides how to report them.  Errors are
:class:`~openimp.errors.InputError` whose message says what is wrong; callers
prepend the element name.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from openimp.errors import InputError

__all__ = [
    "UNITS",
    "Units",
    "box",
    "centroidal",
    "check_inertia",
    "cylinder",
    "disc",
    "mass_value",
    "pseudo_inertia",
    "rod",
    "sphere",
    "transform",
    "tube",
    "units",
]

#: relative tolerance of the symmetry, rotation and plausibility checks
_TOL = 1e-9


# --------------------------------------------------------------------------------------------
# validation helpers
# --------------------------------------------------------------------------------------------


def _array(value: Any, shape: tuple[int, ...], what: str) -> np.ndarray:
    """``value`` as a finite float array of ``shape``, or InputError naming ``what``."""
    try:
        a = np.array(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise InputError(f"{what} must be numbers of shape {shape}, got {value!r}") from exc
    if a.shape != shape:
        raise InputError(f"{what} must have shape {shape}, got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise InputError(f"{what} must be finite numbers, got {a.tolist()}")
    return a


def mass_value(value: Any, what: str = "the mass") -> float:
    """``value`` as a mass: a finite float >= 0, or InputError naming ``what``.  The one
    refusal of a negative mass (:func:`pseudo_inertia`, the IMP statement DATA MASS)."""
    m = _scalar(value, what)
    if m < 0.0:
        raise InputError(f"{what} must not be negative (>= 0), got {m:g}")
    return m


def _scalar(value: Any, what: str) -> float:
    """``value`` as a finite float, or InputError naming ``what``."""
    if isinstance(value, bool | np.bool_):
        raise InputError(f"{what} must be a number, got {value!r}")
    try:
        x = float(value)
    except (TypeError, ValueError) as exc:
        raise InputError(f"{what} must be a number, got {value!r}") from exc
    if not math.isfinite(x):
        raise InputError(f"{what} must be a finite number, got {x!r}")
    return x


def _positive(value: Any, what: str) -> float:
    """A finite number > 0, or InputError naming ``what`` and the value."""
    x = _scalar(value, what)
    if x <= 0.0:
        raise InputError(f"{what} must be > 0, got {x!r}")
    return x


def _rotation(value: Any, what: str) -> np.ndarray:
    """A 3x3 proper rotation (orthonormal columns, determinant +1), or InputError."""
    R = _array(value, (3, 3), what)
    err = float(np.max(np.abs(R.T @ R - np.eye(3))))
    if err > _TOL:
        raise InputError(
            f"{what} must be a rotation (orthonormal columns); R^t R differs from the "
            f"identity by {err:.3g}"
        )
    det = float(np.linalg.det(R))
    if det <= 0.0:
        raise InputError(f"{what} must be a rotation; its determinant is {det:.6g}, not +1")
    return R


def _rigid(value: Any, what: str) -> np.ndarray:
    """A 4x4 rigid transform [[R, p], [0 0 0 1]], or InputError."""
    T = _array(value, (4, 4), what)
    if not np.array_equal(T[3], [0.0, 0.0, 0.0, 1.0]):
        raise InputError(f"{what} must be a rigid transform; its last row is {T[3].tolist()}")
    _rotation(T[:3, :3], f"the rotation part of {what}")
    return T


def _symmetric(I: np.ndarray, what: str) -> np.ndarray:
    """The symmetric part of ``I`` after checking it is symmetric to ``_TOL`` relative."""
    scale = float(np.max(np.abs(I)))
    asym = float(np.max(np.abs(I - I.T)))
    if asym > _TOL * scale:
        raise InputError(
            f"{what} must be symmetric; it differs from its transpose by {asym:.6g} "
            f"(largest entry {scale:.6g})"
        )
    return 0.5 * (I + I.T)


def _pseudo(J: Any) -> np.ndarray:
    return _array(J, (4, 4), "the pseudo-inertia J")


def _fmt(x: float) -> str:
    return f"{x:.6g}"


# --------------------------------------------------------------------------------------------
# pseudo-inertia
# --------------------------------------------------------------------------------------------


def pseudo_inertia(
    mass: float,
    center: Any,
    inertia: Any = None,
    *,
    axes: Any = None,
    about: str = "center",
    origin: Any = None,
) -> np.ndarray:
    """The 4x4 pseudo-inertia ``J = ∫ r r^t dm`` about the global origin on global axes.

    Args:
        mass: the mass ``m >= 0``.
        center: shape (3,), the centre of mass in global coordinates.
        inertia: ``None`` (a point mass), shape (3,) principal (diagonal) moments on
            ``axes``, or shape (3, 3) the symmetric inertia tensor on ``axes`` in the
            engineering convention ``I = ∫ (|s|^2 E - s s^t) dm`` (off-diagonals are
            minus the products of inertia).
        axes: shape (3, 3) rotation whose columns are the (global) directions of the
            axes on which ``inertia`` is given; default the global axes.
        about: ``"center"`` when ``inertia`` is about the centre of mass, ``"origin"``
            when it is about the point ``origin`` (for example a joint frame origin).
        origin: shape (3,), global coordinates of the reference point of ``inertia``;
            required with ``about="origin"`` and refused otherwise.

    Returns:
        shape (4, 4): ``[[Σ, m c], [m c^t, m]]`` with ``Σ = ∫ x x^t dm`` (9.6).

    The parallel-axis theorem used: with ``s = x - o`` and ``Σ_o = ∫ s s^t dm``,
    ``∫ x x^t dm = Σ_o + m (o c^t + c o^t) - m o o^t``.

    Raises:
        InputError: non-finite numbers, negative mass, wrong shapes, a non-symmetric
            tensor, ``axes`` not a rotation, a bad ``about`` / ``origin``.
    """
    m = mass_value(mass)
    c = _array(center, (3,), "the centre of mass")
    if about == "center":
        if origin is not None:
            raise InputError(
                "an origin is only used with about='origin'; the inertia is about the "
                "centre of mass with about='center'"
            )
        o = c
    elif about == "origin":
        if origin is None:
            raise InputError("about='origin' needs the origin (3 global coordinates)")
        o = _array(origin, (3,), "the origin of the inertia")
    else:
        raise InputError(f"about must be 'center' or 'origin', got {about!r}")

    if inertia is None:
        I = np.zeros((3, 3))
        if about == "origin":
            raise InputError(
                "about='origin' needs an inertia; a point mass is given by its centre alone"
            )
    else:
        a = np.asarray(inertia, dtype=object)
        if a.shape == (3,):
            I = np.diag(_array(inertia, (3,), "the principal moments of inertia"))
        elif a.shape == (3, 3):
            I = _symmetric(_array(inertia, (3, 3), "the inertia tensor"), "the inertia tensor")
        else:
            raise InputError(
                f"the inertia must be 3 principal moments or a 3x3 tensor, got shape {a.shape}"
            )
    if axes is not None:
        R = _rotation(axes, "the inertia axes")
        I = R @ I @ R.T
        I = 0.5 * (I + I.T)

    sigma_o = 0.5 * np.trace(I) * np.eye(3) - I
    sigma = sigma_o + m * (np.outer(o, c) + np.outer(c, o)) - m * np.outer(o, o)
    J = np.empty((4, 4))
    J[:3, :3] = 0.5 * (sigma + sigma.T)
    J[:3, 3] = m * c
    J[3, :3] = m * c
    J[3, 3] = m
    return J


def centroidal(J: Any) -> tuple[float, np.ndarray, np.ndarray]:
    """Mass, centre and centroidal inertia tensor of a pseudo-inertia.

    Args:
        J: shape (4, 4), a pseudo-inertia (any frame; the results are in that frame).

    Returns:
        ``(m, c, I_c)``: the mass, shape (3,) the centre of mass (zeros when ``m`` is
        zero) and shape (3, 3) the inertia tensor about the centre on the axes of
        ``J``, engineering convention (``I = trace(Σ) E - Σ``).
    """
    J = _pseudo(J)
    m = float(J[3, 3])
    first = 0.5 * (J[:3, 3] + J[3, :3])
    sigma = 0.5 * (J[:3, :3] + J[:3, :3].T)
    if m == 0.0:
        c = np.zeros(3)
    else:
        c = first / m
        sigma = sigma - m * np.outer(c, c)
    I = np.trace(sigma) * np.eye(3) - sigma
    return m, c, 0.5 * (I + I.T)


def check_inertia(J: Any) -> list[str]:
    """Plausibility of a pseudo-inertia: human-readable findings, empty when fine.

    Args:
        J: shape (4, 4), a pseudo-inertia.

    Returns:
        A list of messages.  Checked: symmetry; a negative mass; a zero mass with
        non-zero first or second moments; centroidal principal moments that are
        negative or break the triangle inequality ``I1 + I2 >= I3`` (relative
        tolerance 1e-9 of the largest of them and of the second moments of J).

    Raises:
        InputError: ``J`` is not a finite 4x4 array.
    """
    J = _pseudo(J)
    found: list[str] = []
    scale = float(np.max(np.abs(J)))
    asym = float(np.max(np.abs(J - J.T)))
    if asym > _TOL * scale:
        found.append(
            f"the pseudo-inertia is not symmetric (it differs from its transpose by "
            f"{_fmt(asym)}); check how it was built"
        )
    m = float(J[3, 3])
    if m < 0.0:
        found.append(f"the mass is negative ({_fmt(m)}); check the mass data")
        return found
    if m == 0.0:
        first = float(np.max(np.abs(J[:3, 3])))
        second = float(np.max(np.abs(J[:3, :3])))
        if first != 0.0:
            found.append(
                f"the mass is zero but the first moments m*c are not (largest {_fmt(first)}); "
                "a centre of mass or moments were given without a mass: check the mass data"
            )
        if second != 0.0:
            found.append(
                f"the mass is zero but the moments of inertia are not (largest {_fmt(second)}); "
                "check the mass data"
            )
        return found
    _, _, I_c = centroidal(J)
    p = np.sort(np.linalg.eigvalsh(I_c))
    # the centroidal moments are J's second moments less m c c^T: their round-off is
    # relative to those (a point mass off the origin has moments 0 within it)
    tol = _TOL * max(float(np.max(np.abs(p))), float(np.max(np.abs(J[:3, :3]))))
    shown = ", ".join(_fmt(float(x)) for x in p)
    if p[0] < -tol:
        found.append(
            f"the principal moments about the centre of mass, {shown}, include a negative "
            "one: no rigid body has them; check the inertia data (sign convention, units, "
            "reference point)"
        )
    if p[0] + p[1] < p[2] - tol:
        found.append(
            f"the principal moments about the centre of mass, {shown}, break the triangle "
            "inequality I1 + I2 >= I3: no rigid body has them; check the inertia data "
            "(a moment about a point other than the centre of mass, or products of inertia "
            "with the wrong sign?)"
        )
    return found


def transform(J: Any, T: Any) -> np.ndarray:
    """``T J T^t``: the pseudo-inertia re-expressed by the rigid transform ``T``.

    Args:
        J: shape (4, 4), pseudo-inertia in frame b.
        T: shape (4, 4), rigid transform from frame b to frame a (``r_a = T r_b``).

    Returns:
        shape (4, 4), the same pseudo-inertia in frame a.  Use ``T^-1`` to go the other
        way: ``J_body = T^-1 J_global (T^-1)^t``.
    """
    J = _pseudo(J)
    T = _rigid(T, "the transform")
    out = T @ J @ T.T
    return 0.5 * (out + out.T)


# --------------------------------------------------------------------------------------------
# primitive solids
# --------------------------------------------------------------------------------------------


def _solid(m: float, second: tuple[float, float, float], frame: Any) -> np.ndarray:
    """Place a solid with centroidal second moments ``diag(second)`` at ``frame``."""
    F = np.eye(4) if frame is None else _rigid(frame, "the frame")
    local = np.zeros((4, 4))
    local[0, 0], local[1, 1], local[2, 2] = second
    local[3, 3] = m
    J = F @ local @ F.T
    return 0.5 * (J + J.T)


def box(a: float, b: float, c: float, density: float, frame: Any = None) -> np.ndarray:
    """A rectangular box centred at the frame origin with edges a, b, c along its x, y, z.

    Args:
        a, b, c: edge lengths (> 0).
        density: mass per volume (> 0).
        frame: shape (4, 4) rigid transform placing the box; default the identity.

    Returns:
        shape (4, 4), pseudo-inertia about the global origin (``I_x = m (b² + c²)/12``...).
    """
    a = _positive(a, "the box edge a")
    b = _positive(b, "the box edge b")
    c = _positive(c, "the box edge c")
    rho = _positive(density, "the density")
    m = rho * a * b * c
    return _solid(m, (m * a * a / 12.0, m * b * b / 12.0, m * c * c / 12.0), frame)


def cylinder(radius: float, length: float, density: float, frame: Any = None) -> np.ndarray:
    """A solid cylinder along the frame z axis, centred at the frame origin.

    Args:
        radius, length: > 0; the cylinder spans z = -length/2 .. length/2.
        density: mass per volume (> 0).
        frame: shape (4, 4) rigid transform; default the identity.

    Returns:
        shape (4, 4); ``I_z = m r²/2``, ``I_x = I_y = m (3 r² + L²)/12``.
    """
    r = _positive(radius, "the cylinder radius")
    L = _positive(length, "the cylinder length")
    rho = _positive(density, "the density")
    m = rho * math.pi * r * r * L
    return _solid(m, (m * r * r / 4.0, m * r * r / 4.0, m * L * L / 12.0), frame)


def tube(
    r_outer: float, r_inner: float, length: float, density: float, frame: Any = None
) -> np.ndarray:
    """A hollow cylinder (0 <= r_inner < r_outer) along frame z, centred at the origin.

    Args:
        r_outer: outer radius (> 0).
        r_inner: inner radius (>= 0 and < r_outer).
        length: > 0.
        density: mass per volume (> 0).
        frame: shape (4, 4) rigid transform; default the identity.

    Returns:
        shape (4, 4); ``I_z = m (ro² + ri²)/2``, ``I_x = I_y = m (3 (ro² + ri²) + L²)/12``.
    """
    ro = _positive(r_outer, "the tube outer radius")
    ri = _scalar(r_inner, "the tube inner radius")
    if ri < 0.0 or ri >= ro:
        raise InputError(
            f"the tube inner radius must be >= 0 and < the outer radius {ro!r}, got {ri!r}"
        )
    L = _positive(length, "the tube length")
    rho = _positive(density, "the density")
    m = rho * math.pi * (ro * ro - ri * ri) * L
    s = m * (ro * ro + ri * ri) / 4.0
    return _solid(m, (s, s, m * L * L / 12.0), frame)


def rod(length: float, density: float, frame: Any = None) -> np.ndarray:
    """A slender rod (zero radius) along frame z, centred at the frame origin.

    Args:
        length: > 0.
        density: mass per **length** (> 0).
        frame: shape (4, 4) rigid transform; default the identity.

    Returns:
        shape (4, 4); ``I_x = I_y = m L²/12``, ``I_z = 0``.
    """
    L = _positive(length, "the rod length")
    rho = _positive(density, "the density")
    m = rho * L
    return _solid(m, (0.0, 0.0, m * L * L / 12.0), frame)


def disc(radius: float, thickness: float, density: float, frame: Any = None) -> np.ndarray:
    """A disc: a cylinder of the given thickness along frame z (thin or not).

    Args:
        radius, thickness: > 0.
        density: mass per volume (> 0).
        frame: shape (4, 4) rigid transform; default the identity.

    Returns:
        shape (4, 4), the same as ``cylinder(radius, thickness, density, frame)``.
    """
    r = _positive(radius, "the disc radius")
    t = _positive(thickness, "the disc thickness")
    return cylinder(r, t, density, frame)


def sphere(radius: float, density: float, frame: Any = None) -> np.ndarray:
    """A solid sphere centred at the frame origin.

    Args:
        radius: > 0.
        density: mass per volume (> 0).
        frame: shape (4, 4) rigid transform; default the identity.

    Returns:
        shape (4, 4); ``I = 2 m r²/5`` about every axis through the centre.
    """
    r = _positive(radius, "the sphere radius")
    rho = _positive(density, "the density")
    m = rho * 4.0 / 3.0 * math.pi * r**3
    s = m * r * r / 5.0
    return _solid(m, (s, s, s), frame)


# --------------------------------------------------------------------------------------------
# units (§9.4)
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True, kw_only=True)
class Units:
    """A consistent "gravitational" unit system: mass is force·s²/length.

    Attributes:
        name: the preset name.
        length, force, time, mass: unit labels.
        mass_factor: one user mass unit in force·s²/length; masses entered by the user
            are multiplied by it once, at input.
        g: standard gravity in length/s².
    """

    name: str
    length: str
    force: str
    time: str = "s"
    mass: str
    mass_factor: float = 1.0
    g: float

    def labels(self) -> dict[str, str]:
        """Unit labels of the quantities: length, force, mass, time, moment, energy, angle."""
        moment = f"{self.force} {self.length}"
        return {
            "length": self.length,
            "force": self.force,
            "mass": self.mass,
            "time": self.time,
            "moment": moment,
            "energy": moment,
            "angle": "rad",
        }


_G_SI = 9.80665  # m/s², exact by definition
_G_IN = _G_SI / 0.0254  # 386.0885826771654 in/s²
_G_FT = _G_SI / 0.3048  # 32.17404855643044 ft/s²

#: the unit presets, by name
UNITS: dict[str, Units] = {
    u.name: u
    for u in (
        Units(name="SI", length="m", force="N", mass="kg", g=_G_SI),
        Units(name="mm-N-s", length="mm", force="N", mass="t", g=_G_SI * 1000.0),
        Units(name="in-lbf-s", length="in", force="lbf", mass="lbf s^2/in", g=_G_IN),
        # 1 lbm = (1/g_n) lbf s²/in exactly (lbf = lbm·g_n): IMP's default mass unit
        Units(
            name="in-lbm", length="in", force="lbf", mass="lbm", mass_factor=1.0 / _G_IN, g=_G_IN
        ),
        Units(name="ft-lbf-s", length="ft", force="lbf", mass="slug", g=_G_FT),
    )
}

_ALIASES = {
    "si": "SI",
    "mks": "SI",
    "m-n-s": "SI",
    "m-n-kg": "SI",
    "mm": "mm-N-s",
    "mm-n-t": "mm-N-s",
    "ips": "in-lbf-s",
    "imp": "in-lbm",
    "fps": "ft-lbf-s",
    "ft-lbf-slug": "ft-lbf-s",
}


def units(spec: str | Units) -> Units:
    """The unit system named ``spec`` (case-insensitive, a few aliases), or ``spec`` itself.

    Args:
        spec: a preset name of :data:`UNITS` (``"SI"``, ``"mm-N-s"``, ``"in-lbf-s"``,
            ``"in-lbm"``, ``"ft-lbf-s"``), an alias (``"si"``, ``"imp"`` = ``"in-lbm"``,
            ``"ips"``, ``"fps"``, ``"mks"``, ``"mm"``) or a :class:`Units`.

    Raises:
        InputError: unknown name; the message lists the known names.
    """
    if isinstance(spec, Units):
        return spec
    if isinstance(spec, str):
        key = spec.strip().lower()
        for name, u in UNITS.items():
            if name.lower() == key:
                return u
        if key in _ALIASES:
            return UNITS[_ALIASES[key]]
    known = ", ".join(UNITS)
    aliases = ", ".join(f"{k} = {v}" for k, v in _ALIASES.items())
    raise InputError(f"unknown unit system {spec!r}; known: {known} (aliases: {aliases})")
