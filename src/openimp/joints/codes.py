"""Integer codes of the joint kinds and their sizes, as the compiled kernels see them.

A joint kind is dispatched inside the kernels by its code; the catalogue
(:mod:`openimp.joints.catalogue`) maps names to codes.
"""

from __future__ import annotations

from openimp._jit import njit

RIGID = 0
REVOLUTE = 1
PRISMATIC = 2
SCREW = 3
CYLINDER = 4
SPHERE = 5
FLAT = 6
OPEN = 7
GEAR = 8
RACK = 9
BEVEL = 10
POINT_CURVE = 11
LINE_CURVE = 12
CAM = 13
SLOT = 14
UJOINT = 15
SPHERE_PLANE = 16
SPHERE_GROOVE = 17
GIMBAL = 18
OPEN_CARDAN = 19
FLAT_POLAR = 20

#: the kinds the kernels evaluate in closed form (see :func:`closed_form`)
CLOSED_FORM = (RIGID, REVOLUTE, PRISMATIC, CYLINDER)

#: Largest number of variables of any joint (the open joint: 3 + 4).
MAXV = 7

#: index, in a gear's constants, of the initial load sign sgn(F) of book (4.28): the
#: value a :class:`~openimp.system.State` starts with (0 for kinematics, +-1 set by force
#: analysis in the state, never in the model's constants)
GEAR_LOAD_SIGN_SLOT = 6
#: index, in a rack's constants, of its initial load sign sgn(F) (book 4.31)
RACK_LOAD_SIGN_SLOT = 3


@njit(nrt=False, forceinline=True)
def nvar(code: int) -> int:
    """Number of variables of a joint kind (must agree with the catalogue)."""
    if code == RIGID:
        return 0
    if code == REVOLUTE or code == PRISMATIC or code == SCREW:
        return 1
    if code == CYLINDER or code == BEVEL or code == CAM or code == SLOT or code == UJOINT:
        return 2
    if (code == FLAT or code == GEAR or code == RACK or code == POINT_CURVE
            or code == LINE_CURVE or code == GIMBAL or code == FLAT_POLAR):
        return 3
    if code == SPHERE:
        return 4
    if code == SPHERE_GROOVE:
        return 5
    if code == SPHERE_PLANE or code == OPEN_CARDAN:
        return 6
    if code == OPEN:
        return 7
    return 0


@njit(nrt=False, forceinline=True)
def constant_Q(code: int) -> bool:
    """True for kinds whose Q does not depend on q (every Q_{g,i} is zero)."""
    return (code == RIGID or code == REVOLUTE or code == PRISMATIC or code == SCREW
            or code == CYLINDER)


@njit(nrt=False, forceinline=True)
def closed_form(code: int) -> bool:
    """True for the kinds the kernels evaluate in closed form, without :func:`joint_calc`.

    Rigid, revolute, prismatic and cylindric joints: Phi is a rotation about
    and a slide along z, and their screws follow from the joint axis alone.
    """
    return code == RIGID or code == REVOLUTE or code == PRISMATIC or code == CYLINDER


@njit(nrt=False, forceinline=True)
def is_planar(code: int) -> bool:
    """True for the planar higher pairs, Phi = [[Rz(theta(q)), p(q)], [0, 1]]."""
    return (
        code == GEAR or code == RACK or code == POINT_CURVE or code == LINE_CURVE
        or code == CAM or code == SLOT or code == FLAT_POLAR
    )
