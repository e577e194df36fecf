"""The cold-start helper (openimp._warm): when it runs and that it compiles what a run uses."""

from __future__ import annotations

import numba
import numpy as np
import pytest

import openimp
from helpers.models import fourbar
from openimp import _announce, _warm
from openimp._jit import JIT_ENABLED

pytestmark = pytest.mark.skipif(not JIT_ENABLED, reason="kernels not compiled (OPENIMP_NOJIT)")


def test_helper_compiles_the_signatures_a_run_uses():
    """After a sweep with rates and the postures and rates of its bodies, the
    disk cache holds every (kernel, types) the helper compiles: the helper's
    entries are the ones a run looks up."""
    s = openimp.compile(fourbar())
    a = np.radians(np.arange(0.0, 30.0, 10.0))
    res = openimp.sweep(s, {"A": a}, rates={"A": 1.0}, accels={"A": 0.5})
    res.angular_velocity("COUPLER")
    res.posture("COUPLER")
    for kernel, types in _warm.rate_kernel_signatures():
        # compiled in this process or loaded: either way the disk cache has the entry
        cached = kernel._cache.load_overload(types, kernel.targetctx)
        assert cached is not None, kernel.__name__
        assert tuple(cached.signature.args) == types


def test_cache_is_cold_until_the_last_kernel_is_cached(tmp_path, monkeypatch):
    """cold on an empty cache directory; warm once the helper's last kernel has an index."""
    monkeypatch.setattr(numba.config, "CACHE_DIR", str(tmp_path))
    assert _warm.cache_is_cold()
    sub = tmp_path / "openimp_0123"
    sub.mkdir()
    (sub / "track.track-1052.py311.nbi").write_bytes(b"")
    assert not _warm.cache_is_cold()


def test_no_helper_on_a_warm_cache_or_when_disabled(tmp_path, monkeypatch):
    """start() spawns nothing when the cache is warm or OPENIMP_NO_WARMUP=1."""
    monkeypatch.setattr(numba.config, "CACHE_DIR", str(tmp_path))
    (tmp_path / "track.track-1.py311.nbi").write_bytes(b"")
    assert _warm.start() is None
    (tmp_path / "track.track-1.py311.nbi").unlink()
    monkeypatch.setenv("OPENIMP_NO_WARMUP", "1")
    assert _warm.start() is None


def test_no_helper_on_a_busy_machine(tmp_path, monkeypatch):
    """On a cold cache the helper still stays off when the load average leaves no core
    beside the run's own (it would slow a loaded 2-core machine down)."""
    monkeypatch.setattr(numba.config, "CACHE_DIR", str(tmp_path))
    monkeypatch.delenv("OPENIMP_NO_WARMUP", raising=False)
    monkeypatch.setattr(_warm.os, "cpu_count", lambda: 2)
    monkeypatch.setattr(_warm.os, "getloadavg", lambda: (1.0, 1.0, 1.0))
    assert _warm.machine_busy()
    assert _warm.start() is None
    monkeypatch.setattr(_warm.os, "getloadavg", lambda: (0.2, 0.2, 0.2))
    assert not _warm.machine_busy()


def test_deck_flavours_follow_the_joint_keywords(tmp_path):
    """A deck with a joint of a general kind (GEAR, SPHERE, CAM ...) wants the general
    kernels first; one of pins and slides only the closed-form ones."""
    pins = tmp_path / "pins.imp"
    pins.write_text("ZPIN (BASE, CRANK) = A\nXSLIDE (CRANK, S) = B\nEXECUTE\n")
    balls = tmp_path / "balls.imp"
    balls.write_text("ZPIN (BASE, CRANK) = A\nSPHERE (CRANK, C) = B\nEXECUTE\n")
    assert _warm.deck_flavours(pins)[0] == _warm.LOWER
    assert _warm.deck_flavours(balls)[0] == _warm.GENERAL
    assert _warm.deck_flavours(tmp_path / "missing.imp") == [_warm.LOWER, _warm.GENERAL]


def test_announcer_says_once_that_it_compiles_and_how_long():
    """The first compile of an openimp kernel gives one located note with the expected
    time, nested compiles and other kernels add progress only, a library's compile is
    not counted, and close() reports the count; nothing is said when nothing compiled."""
    import io as _io
    import types

    buf = _io.StringIO()
    talk = _announce.Announcer(buf, live=False, prefix="deck.imp: ")

    def kernel(name, module="openimp.kinematics.posture"):
        fn = types.FunctionType((lambda: None).__code__, {}, name)
        fn.__module__ = module
        return types.SimpleNamespace(py_func=fn)

    talk._on_start(kernel("newton"))       # top level
    talk._on_start(kernel("position"))     # nested in newton
    talk.depth -= 2
    talk._on_start(kernel("helper", module="numpy.linalg"))
    talk.depth -= 1
    talk._on_start(kernel("sweep_steps"))
    talk.depth -= 1
    talk.close()
    lines = buf.getvalue().splitlines()
    assert len(lines) == 2
    assert lines[0].startswith("openimp: note: deck.imp: compiling the kinematic kernels")
    assert f"about {_announce.COMPILE_SECONDS} s" in lines[0]
    assert lines[1].startswith("openimp: note: deck.imp: 2 kernels compiled and cached in")
    quiet = _io.StringIO()
    _announce.Announcer(quiet, live=False).close()
    assert quiet.getvalue() == ""


def test_announcer_says_when_the_force_kernels_compile_too():
    """A run that reaches the force analysis on a cold cache says so once more, with the
    force kernels' expected time; a run whose first compile is a force kernel says that
    first (and not twice)."""
    import io as _io

    buf = _io.StringIO()
    talk = _announce.Announcer(buf, live=False, prefix="deck.imp: ")
    for name, module in (("sweep_steps", "openimp.kinematics.sweep"),
                         ("forces_steps", "openimp.dynamics.inverse"),
                         ("eom", "openimp.dynamics.eom")):
        talk._on_start(kernel(name, module))
        talk.depth -= 1
    talk.close()
    lines = buf.getvalue().splitlines()
    assert len(lines) == 3, lines
    assert "compiling the kinematic kernels" in lines[0]
    assert "compiling the force kernels too" in lines[1]
    assert f"about {_announce.FORCE_COMPILE_SECONDS} s" in lines[1]
    assert "3 kernels compiled" in lines[2]
    buf = _io.StringIO()
    talk = _announce.Announcer(buf, live=False)
    talk._on_start(kernel("forces_steps", "openimp.dynamics.inverse"))
    talk.depth -= 1
    talk._on_start(kernel("eom", "openimp.dynamics.eom"))
    talk.depth -= 1
    talk.close()
    lines = buf.getvalue().splitlines()
    assert len(lines) == 2 and "compiling the force kernels (the first run" in lines[0]


def kernel(name: str, module: str):
    """A stand-in for a numba dispatcher of the function ``module.name``."""
    import types

    fn = types.FunctionType((lambda: None).__code__, {}, name)
    fn.__module__ = module
    return types.SimpleNamespace(py_func=fn)


@pytest.mark.parametrize("kern, module, nested, nested_module, group, seconds", [
    ("linearize_kernel", "openimp.dynamics.linear", "mass_matrix", "openimp.dynamics.inertia",
     "linearization", "LINEAR_COMPILE_SECONDS"),
    ("search_step", "openimp.dynamics.statics", "load_stiffness", "openimp.dynamics.linear",
     "equilibrium", "STATIC_COMPILE_SECONDS"),
])
def test_announcer_names_its_own_group(kern, module, nested, nested_module, group, seconds):
    """The linearization kernel and the equilibrium search are groups of their own, said
    with their expected time; the stages they compile inside them (nested compiles) do
    not announce their own groups (the force kernels, the linearization)."""
    import io as _io

    buf = _io.StringIO()
    talk = _announce.Announcer(buf, live=False)
    talk._on_start(kernel("sweep_steps", "openimp.kinematics.sweep"))
    talk.depth -= 1
    talk._on_start(kernel(kern, module))
    talk._on_start(kernel(nested, nested_module))  # nested
    talk.depth -= 2
    talk.close()
    lines = buf.getvalue().splitlines()
    assert len(lines) == 3, lines
    assert f"compiling the {group} kernels too" in lines[1]
    assert f"about {getattr(_announce, seconds)} s" in lines[1]
    assert "2 kernels compiled" in lines[2]


@pytest.mark.skipif(not _warm.JIT_ENABLED, reason="nothing compiles without numba")
def test_a_python_session_hears_of_compiles(caplog):
    """From Python (a script, a notebook) a compile is said through the ``openimp``
    logger, once per group with its expected time, from numba's own compile event (a
    real kernel compiled here, its module that of the equilibrium search); the
    logger's level silences it; the command line's run mutes the session's."""
    import logging

    import numba

    from openimp import _announce

    assert _announce.announce() is _announce.announce()  # one per session

    def fresh(module: str):
        def kernel(x):
            return x + 1.0

        kernel.__module__ = module
        return numba.njit(cache=False)(kernel)

    session = _announce.announce()
    session.muted = True  # this test's own announcer speaks, whatever compiled before
    talk = _announce.Announcer(None, live=False)
    try:
        with caplog.at_level(logging.WARNING, logger="openimp"):
            fresh("openimp.dynamics.statics")(1.0)
            fresh("openimp.dynamics.statics")(2.0)  # the same group: said once
        said = [r.getMessage() for r in caplog.records if r.name == "openimp"
                and "compiling the equilibrium kernels" in r.getMessage()]
        assert len(said) == 1, [r.getMessage() for r in caplog.records]
        assert f"about {_announce.STATIC_COMPILE_SECONDS} s of CPU" in said[0]
        caplog.clear()
        logging.getLogger("openimp").setLevel(logging.ERROR)
        try:
            fresh("openimp.dynamics.stepping")(1.0)
        finally:
            logging.getLogger("openimp").setLevel(logging.NOTSET)
        assert not [r for r in caplog.records if "time-response" in r.getMessage()]
    finally:
        talk.close()
        session.muted = False
