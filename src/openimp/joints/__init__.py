"""The joint catalogue (book ch 4, 6, 8; IMP's higher pairs), by concern:

* :mod:`~openimp.joints.codes`: the integer codes the kernels dispatch on, sizes;
* :mod:`~openimp.joints.lower`: lower pairs (rigid, revolute, prismatic, screw,
  cylinder, sphere, flat, open), compiled, and their extraction;
* :mod:`~openimp.joints.curves`: curve and function data of the higher pairs;
* :mod:`~openimp.joints.higher`: higher pairs (gears, rack, bevel, curves, cam,
  slot, universal joint, sphere-plane, sphere-groove), compiled, with their
  constants and extraction;
* :mod:`~openimp.joints.calc`: :func:`joint_calc`, one evaluation of any kind
  giving ``Phi``, ``Q`` and ``dQ`` together;
* :mod:`~openimp.joints.catalogue`: :class:`JointType` per kind, the
  conventions, conformity of a modeled joint.
"""

from openimp.joints.calc import joint_calc
from openimp.joints.catalogue import (
    ALIAS_AXES,
    CATALOGUE,
    JointType,
    Q_of,
    calc_of,
    conformity,
    dQ_of,
    joint_type,
    phi_of,
    register,
)
from openimp.joints.codes import (
    BEVEL,
    CAM,
    CYLINDER,
    FLAT,
    FLAT_POLAR,
    GEAR,
    GEAR_LOAD_SIGN_SLOT,
    GIMBAL,
    LINE_CURVE,
    MAXV,
    OPEN,
    OPEN_CARDAN,
    POINT_CURVE,
    PRISMATIC,
    RACK,
    RACK_LOAD_SIGN_SLOT,
    REVOLUTE,
    RIGID,
    SCREW,
    SLOT,
    SPHERE,
    SPHERE_GROOVE,
    SPHERE_PLANE,
    UJOINT,
    nvar,
)
from openimp.joints.curves import curve_parameter, register_curve
from openimp.joints.lower import angle_of, rotation_to_er

__all__ = [
    "ALIAS_AXES",
    "BEVEL",
    "CAM",
    "CATALOGUE",
    "CYLINDER",
    "FLAT",
    "FLAT_POLAR",
    "GEAR",
    "GEAR_LOAD_SIGN_SLOT",
    "GIMBAL",
    "LINE_CURVE",
    "MAXV",
    "OPEN",
    "OPEN_CARDAN",
    "POINT_CURVE",
    "PRISMATIC",
    "RACK",
    "RACK_LOAD_SIGN_SLOT",
    "REVOLUTE",
    "RIGID",
    "SCREW",
    "SLOT",
    "SPHERE",
    "SPHERE_GROOVE",
    "SPHERE_PLANE",
    "UJOINT",
    "JointType",
    "Q_of",
    "angle_of",
    "calc_of",
    "conformity",
    "curve_parameter",
    "dQ_of",
    "joint_calc",
    "joint_type",
    "nvar",
    "phi_of",
    "register",
    "register_curve",
    "rotation_to_er",
]
