"""The compilation helpers of openimp._jit: one specialisation per argument type, bare views."""

from __future__ import annotations

import numpy as np
import pytest

from openimp._jit import JIT_ENABLED, njit, rows

pytestmark = pytest.mark.skipif(not JIT_ENABLED, reason="kernels not compiled (OPENIMP_NOJIT)")


# not cached: the callee's signatures are seen only when it compiles in this process
@njit(cache=False)
def _scaled(x: float, k: int) -> float:
    return x * k


@njit(cache=False)
def _caller(x: float) -> float:
    # constant arguments: numba would type them Literal[int](2), Literal[int](3)
    return _scaled(x, 2) + _scaled(x, 3)


def test_constant_arguments_do_not_specialise_the_callee():
    """Calls with different constants share one compiled callee (int64, not literals)."""
    assert _caller(1.5) == pytest.approx(7.5)
    assert len(_scaled.signatures) == 1
    assert "Literal" not in str(_scaled.signatures[0])


@njit
def _views(a1: np.ndarray, a2: np.ndarray, a3: np.ndarray, o: int, n: int) -> tuple:
    return rows(a1, o, n), rows(a2, o, n), rows(a3, o, n)


def test_rows_is_a_view_of_rows_o_to_o_plus_n():
    """rows(buf, o, n) equals buf[o:o + n] for 1-, 2- and 3-d buffers, shares their
    memory (a write through the view reaches the buffer) and may be empty."""
    a1 = np.arange(10.0)
    a2 = np.arange(40).reshape(10, 4)
    a3 = np.arange(160.0).reshape(10, 4, 4)
    for o, n in ((0, 10), (3, 4), (9, 1), (10, 0), (5, 0)):
        v1, v2, v3 = _views(a1, a2, a3, o, n)
        for v, a in ((v1, a1), (v2, a2), (v3, a3)):
            assert v.shape == a[o:o + n].shape and v.dtype == a.dtype
            assert np.array_equal(v, a[o:o + n])
    v1, v2, v3 = _views(a1, a2, a3, 2, 3)
    v3[1, 2, 3] = -7.0
    assert a3[3, 2, 3] == -7.0


def test_prune_caches_keeps_the_current_and_the_newest(tmp_path):
    """Of five older numba-* directories and the current one, the current and the
    two most recently modified stay; other entries of the base are untouched."""
    import os

    from openimp._jit import prune_caches

    old = []
    for i in range(5):
        d = tmp_path / f"numba-{i:016x}"
        d.mkdir()
        (d / "x.nbi").write_bytes(b"")
        os.utime(d, (1000.0 + i, 1000.0 + i))
        old.append(d)
    (tmp_path / "other").mkdir()
    current = tmp_path / "numba-current"
    removed = prune_caches(str(current), keep=3)
    assert sorted(removed) == sorted(str(d) for d in old[:3])
    left = sorted(p.name for p in tmp_path.iterdir())
    assert left == sorted(["other", old[3].name, old[4].name])
    assert prune_caches(str(current), keep=3) == []
