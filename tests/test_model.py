"""The Model (building, validation) and its compilation to a System.

Misuse must raise :class:`openimp.InputError` whose message names the element
(joint, point, body, driver) -- never another exception type.  Each misuse
test calls :func:`input_error`, which lets any other exception propagate (a
test error) and checks the names in the message.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import openimp
from helpers.models import fourbar
from openimp import InputError, Model


def input_error(fn, *names: str) -> str:
    """Run ``fn``; it must raise InputError (nothing else) naming every one of ``names``."""
    with pytest.raises(InputError) as ei:
        fn()
    msg = str(ei.value)
    for n in names:
        assert n in msg, f"{n!r} not named in: {msg}"
    return msg


@pytest.fixture(scope="module")
def fb_system():
    return openimp.compile(fourbar())


# =============================================================================
# Building a model (positive behaviour the misuse tests rely on)
# =============================================================================


def test_joint_frames_from_origin_axis_ref():
    """frame1 has w along the axis, u along ref squared off against w (ref - (ref.w) w,
    normalised), v = w x u, origin as given; frame2 defaults to the same frame."""
    m = Model("m")
    axis = np.array([1.0, 2.0, 2.0])
    ref = np.array([1.0, 0.0, 0.0])
    j = m.add_joint("revolute", "J", "BASE", "L1", origin=(1, 2, 3), axis=axis, ref=ref)
    w = axis / 3.0
    u = ref - (ref @ w) * w
    u /= np.linalg.norm(u)
    want = np.eye(4)
    want[:3, 0], want[:3, 1], want[:3, 2], want[:3, 3] = u, np.cross(w, u), w, (1, 2, 3)
    np.testing.assert_allclose(j.frame1, want, atol=1e-15)
    np.testing.assert_allclose(j.frame2, want, atol=1e-15)
    assert m.bodies == ["BASE", "L1"]


def test_modeling_variables_from_frames():
    """At the modeling posture a revolute's variable is the angle from u to u'
    about w (ref2 at 30 deg: 30 deg), a prismatic's the offset of the primed
    origin along w (origin2 - origin = 0.7 w: 0.7)."""
    m = Model("m")
    c, s = math.cos(math.radians(30)), math.sin(math.radians(30))
    m.add_joint("revolute", "R", "BASE", "L1", origin=(0, 0, 0), axis=(0, 0, 1),
                ref=(1, 0, 0), ref2=(c, s, 0))
    m.add_joint("prismatic", "P", "L1", "L2", origin=(0, 1, 0), axis=(0, 1, 0),
                ref=(1, 0, 0), origin2=(0, 1.7, 0))
    m.add_joint("open", "O", "L2", "BASE", origin=(0, 1.7, 0))
    sysm = openimp.compile(m)
    assert sysm.modeling_q[sysm.var_index("R")] == pytest.approx(math.radians(30), abs=1e-14)
    assert sysm.modeling_q[sysm.var_index("P")] == pytest.approx(0.7, abs=1e-14)


def test_system_names_and_sizes(fb_system):
    """Four-bar: 4 bodies, 4 joints, 4 variables, one loop, no ER rows;
    var_index accepts 'A', 'A.theta', ('A', 'theta') and ('A', 0)."""
    s = fb_system
    assert s.bodies == ("BASE", "CRANK", "COUPLER", "ROCKER")
    assert s.joints == ("A", "B", "C", "D")
    assert s.var_names == ("A.theta", "B.theta", "C.theta", "D.theta")
    assert (s.nq, s.nloops, s.nconstraints, s.nrows) == (4, 1, 0, 6)
    assert s.var_index("C") == s.var_index("C.theta") == s.var_index(("C", "theta")) == 2
    assert s.var_index(("C", 0)) == 2


def test_length_scale_is_bounding_box_diagonal():
    """Book 6.7: one internal unit = the diagonal of the bounding box of every
    frame origin, point and body-frame origin (here (0,0,0) .. (3, 4, 12): 13)."""
    m = Model("m")
    m.add_joint("revolute", "A", "BASE", "L1", origin=(0, 0, 0))
    m.add_joint("open", "O", "L1", "BASE", origin=(3, 4, 0))
    m.add_point("P", "L1", (0, 0, 12))
    assert openimp.compile(m).length_scale == pytest.approx(13.0, rel=1e-15)


# =============================================================================
# 5. Misuse: every one an InputError naming the element
# =============================================================================


def test_unknown_kind():
    input_error(lambda: Model().add_joint("hinge", "J1", "BASE", "L1", origin=(0, 0, 0)),
                "hinge")


def test_duplicate_joint_name_keeps_the_first():
    m = fourbar()
    first = m.joints["A"]
    input_error(lambda: m.add_joint("revolute", "A", "BASE", "X", origin=(0, 0, 0)), "'A'")
    assert m.joints["A"] is first
    assert "X" not in m.bodies


def test_duplicate_point_name():
    m = fourbar()
    m.add_point("P", "CRANK", (1, 0, 0))
    input_error(lambda: m.add_point("P", "COUPLER", (2, 0, 0)), "'P'")
    assert m.points["P"].body == "CRANK"


@pytest.mark.parametrize("kw", [
    {"axis": (0, 0, 0)},
    {"axis2": (0.0, 0.0, 0.0)},
    {"axis": (1e-14, 0, 0)},
], ids=["axis", "axis2", "tiny"])
def test_zero_length_axis(kw):
    m = Model()
    msg = input_error(lambda: m.add_joint("revolute", "J9", "BASE", "L1", origin=(0, 0, 0), **kw),
                      "J9")
    assert "axis" in msg
    assert m.joints == {} and m.bodies == []


def test_zero_or_parallel_reference_direction():
    input_error(lambda: Model().add_joint("revolute", "J9", "BASE", "L1", origin=(0, 0, 0),
                                          ref=(0, 0, 0)), "J9")
    input_error(lambda: Model().add_joint("revolute", "J9", "BASE", "L1", origin=(0, 0, 0),
                                          axis=(0, 0, 1), ref=(0, 0, 2)), "J9")


def test_joint_of_body_with_itself():
    input_error(lambda: Model().add_joint("revolute", "J3", "L1", "L1", origin=(0, 0, 0)),
                "J3", "L1")


def test_missing_ground():
    """The ground body is in no joint (Model(ground='FRAME'), joints on BASE)."""
    m = fourbar(ground="FRAME")
    input_error(lambda: openimp.compile(m), "FRAME")


def test_point_on_unknown_body():
    m = fourbar()
    input_error(lambda: m.add_point("P7", "NOPE", (0, 0, 0)), "P7", "NOPE")
    assert "P7" not in m.points


@pytest.mark.parametrize("kw", [
    {"axis2": (1, 0, 0), "ref2": (0, 1, 0)},  # axes at 90 deg
    {"axis2": (0, math.sin(0.01), math.cos(0.01))},  # axes 0.57 deg apart
    {"origin2": (0.5, 0, 0)},  # parallel axes, offset
    {"origin2": (0, 0, 0.5)},  # same axis, shifted along it
    {"axis2": (0, 0, -1)},  # opposite sense
], ids=["perpendicular", "tilted", "offset", "axial-shift", "reversed"])
def test_revolute_nonconforming_frames(kw):
    """A revolute whose two frames' axes (w, w' with a common origin) do not coincide."""
    m = fourbar()
    m.add_joint("revolute", "E7", "ROCKER", "X", origin=(0, 0, 0), **kw)
    m.add_joint("revolute", "E8", "X", "BASE", origin=(0, 0, 0))
    msg = input_error(lambda: openimp.compile(m), "E7")
    assert "E8" not in msg


def test_revolute_nonconforming_full_frames():
    """The same with full 4x4 frames: w' tilted by 1 deg about u."""
    F1 = np.eye(4)
    F2 = np.eye(4)
    t = math.radians(1.0)
    F2[1:3, 1:3] = [[math.cos(t), -math.sin(t)], [math.sin(t), math.cos(t)]]
    m = Model()
    m.add_joint("revolute", "Q1", "BASE", "L1", frame1=F1, frame2=F2)
    input_error(lambda: openimp.compile(m), "Q1")


def test_bodies_not_connected_to_ground():
    m = fourbar()
    m.add_joint("revolute", "X", "L5", "L6", origin=(0, 0, 0))
    input_error(lambda: openimp.compile(m), "L5", "L6")


def test_driver_with_wrong_length(fb_system):
    input_error(lambda: openimp.sweep(fb_system, {"A": [0.0, 0.1, 0.2], "B": [0.0, 0.1]}), "B")


@pytest.mark.parametrize("vals", [[], [0.0, float("nan")], [[0.0, 0.1]], [0.0, float("inf")]],
                         ids=["empty", "nan", "2d", "inf"])
def test_driver_with_bad_values(fb_system, vals):
    input_error(lambda: openimp.sweep(fb_system, {"A": vals}), "A")


def test_driver_with_non_numeric_values(fb_system):
    input_error(lambda: openimp.sweep(fb_system, {"A": ["a", "b"]}), "A")


@pytest.mark.parametrize("key,name", [("Z", "Z"), ("A.phi", "phi"), (("A", 3), "3"), (7, "7")],
                         ids=["joint", "variable", "number", "int"])
def test_unknown_driver_joint(fb_system, key, name):
    input_error(lambda: openimp.sweep(fb_system, {key: [0.0, 0.1]}), name)


def test_driver_given_twice(fb_system):
    input_error(lambda: openimp.sweep(fb_system, {"A": [0.0, 0.1], "A.theta": [0.0, 0.1]}), "A")


def test_no_driver(fb_system):
    input_error(lambda: openimp.sweep(fb_system, {}))


def test_multi_variable_joint_needs_variable_name():
    m = Model()
    m.add_joint("cylinder", "CY", "BASE", "L1", origin=(0, 0, 0))
    s = openimp.compile(m)
    input_error(lambda: openimp.sweep(s, {"CY": [0.0, 0.1]}), "CY", "theta")


def test_euler_rodrigues_parameter_cannot_be_driven():
    m = Model()
    m.add_joint("sphere", "S", "BASE", "L1", origin=(0, 0, 0))
    s = openimp.compile(m)
    input_error(lambda: openimp.sweep(s, {"S.e1": [0.0, 0.1]}), "S.e1")


def test_start_posture_of_wrong_length(fb_system):
    input_error(lambda: openimp.sweep(fb_system, {"A": [0.0, 0.1]}, q=[0.0, 0.0]), "q must hold")


def test_unknown_point_and_body_in_results(fb_system):
    res = openimp.sweep(fb_system, {"A": [0.0, 0.1]})
    input_error(lambda: res.point("Q"), "Q")
    input_error(lambda: res.posture("NOBODY"), "NOBODY")
    input_error(lambda: res.joint("NOJOINT"), "NOJOINT")


@pytest.mark.parametrize("kw,name", [
    ({}, "origin"),
    ({"origin": (0, 0)}, "origin"),
    ({"origin": (0, float("nan"), 0)}, "origin"),
    ({"origin": "abc"}, "origin"),
    ({"frame1": np.ones((4, 4))}, "frame1"),
    ({"frame1": np.eye(3)}, "frame1"),
    ({"frame1": np.diag([1.0, 1.0, -1.0, 1.0])}, "frame1"),
], ids=["none", "2d", "nan", "str", "singular", "3x3", "left-handed"])
def test_bad_joint_geometry(kw, name):
    msg = input_error(lambda: Model().add_joint("revolute", "G1", "BASE", "L1", **kw), "G1")
    assert name in msg


def test_bad_constants():
    input_error(lambda: Model().add_joint("screw", "S1", "BASE", "L1", origin=(0, 0, 0)), "S1")
    input_error(lambda: Model().add_joint("screw", "S1", "BASE", "L1", origin=(0, 0, 0), lead=0),
                "S1")
    input_error(lambda: Model().add_joint("revolute", "R1", "BASE", "L1", origin=(0, 0, 0),
                                          lead=1.0), "R1", "lead")


def test_non_numeric_screw_lead():
    input_error(lambda: Model().add_joint("screw", "S1", "BASE", "L1", origin=(0, 0, 0),
                                          lead="abc"), "S1")


def test_non_string_kind():
    input_error(lambda: Model().add_joint(3, "K1", "BASE", "L1", origin=(0, 0, 0)), "3")


def test_bad_names():
    input_error(lambda: Model().add_joint("revolute", "", "BASE", "L1", origin=(0, 0, 0)),
                "joint")
    input_error(lambda: Model().add_joint("revolute", "J", "BASE", 3, origin=(0, 0, 0)), "J")


def test_alias_axis_mismatch():
    input_error(lambda: Model().add_joint("xpin", "XP", "BASE", "L1", origin=(0, 0, 0),
                                          axis=(0, 0, 1)), "XP")


def test_messages_print_plain_numbers():
    msg = input_error(lambda: Model().add_joint("revolute", "J9", "BASE", "L1",
                                                origin=(0, 0, 0), ref=(0, 0, 2)), "J9")
    assert "np.float64" not in msg


def test_unknown_body_frame_joint_and_empty_model():
    input_error(lambda: Model().set_body_frame("QQ", np.eye(4)), "QQ")
    input_error(lambda: Model().delete_joint("QQ"), "QQ")
    input_error(lambda: openimp.compile(Model("empty")), "empty")
    m = fourbar()
    bad = np.eye(4)
    bad[0, 0] = 2.0
    input_error(lambda: m.set_body_frame("CRANK", bad), "CRANK")


def test_packed_model_and_data_are_their_field_tables():
    """The views a kernel rebuilds from the packed buffers (model_views, data_views, run
    compiled) equal the field tables' arrays (name, order, shape, dtype, values) for an
    RSSR with ball joints (ER rows), points and a loop; the Python-side K shares the
    packed storage, and the model's buffers are read-only."""
    from openimp._jit import njit
    from openimp.system import (
        DATA_FIELDS,
        MODEL_FIELDS,
        data_views,
        make_data,
        model_views,
        views,
    )

    m = Model("rssr")
    m.add_joint("revolute", "A", "BASE", "CRANK", origin=(0, 0, 0), axis=(0, 0, 1))
    m.add_joint("sphere", "B", "CRANK", "COUPLER", origin=(1, 0, 0))
    m.add_joint("sphere", "C", "COUPLER", "ROCKER", origin=(1.5, 2, 1))
    m.add_joint("revolute", "D", "ROCKER", "BASE", origin=(0, 2, 1), axis=(1, 0, 0))
    m.add_point("P", "COUPLER", (1.2, 1, 0.5))
    m.add_point("Q", "ROCKER", (1.5, 2, 1))
    s = openimp.compile(m)
    data = make_data(s, nd=2)
    data.v.T[...] = np.arange(data.v.T.size).reshape(data.v.T.shape)
    data.v.pcol[...] = 7
    data.v.used[::2] = True
    for table, P, unpack in ((MODEL_FIELDS, s.KP, model_views),
                             (DATA_FIELDS, data.DP, data_views)):
        ref = views(table, P)
        got = njit(lambda P, f=unpack: f(P))(P)
        assert got._fields == tuple(f.name for f in table)
        for f, a, b in zip(table, got, ref, strict=True):
            assert a.shape == b.shape and a.dtype == b.dtype, f.name
            assert a.ndim == len(f.shape), f.name
            assert np.array_equal(a, b), f.name
    assert s.K.er.size == 2 and s.K.L.shape == (1, 4) and s.K.ptlocal.shape == (2, 4)
    assert data.v.G.shape == (s.nq, 2) and data.v.T.shape == (s.nrows, s.nq + 1)
    assert np.shares_memory(s.K.S1, s.KP[1]) and np.shares_memory(s.K.L, s.KP[0])
    assert all(not a.flags.writeable for a in s.KP)
