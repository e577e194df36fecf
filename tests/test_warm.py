"""The cold-start helper (openimp._warm): when it runs and that it compiles what a run uses."""

from __future__ import annotations

import numba
import numpy as np
import pytest

import openimp
from openimp import _warm
from openimp._jit import JIT_ENABLED

pytestmark = pytest.mark.skipif(not JIT_ENABLED, reason="kernels not compiled (OPENIMP_NOJIT)")


def test_helper_compiles_the_signatures_a_run_uses():
    """After a sweep with rates and the postures and rates of its bodies, the
    disk cache holds every (kernel, types) the helper compiles: the helper's
    entries are the ones a run looks up."""
    from test_model import fourbar

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
