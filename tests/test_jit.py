"""The compilation helpers of openimp._jit: one specialisation per argument type, bare views."""

from __future__ import annotations

import numpy as np
import pytest

from openimp._jit import JIT_ENABLED, njit, view1, view2, view3, view4

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
def _views(buf: np.ndarray, o: int, a: int, b: int, c: int, d: int) -> tuple:
    return (view1(buf, o, a), view2(buf, o, a, b), view3(buf, o, a, b, c),
            view4(buf, o, a, b, c, d))


def test_views_are_c_ordered_views_of_a_flat_buffer():
    """view1..view4(buf, o, dims) equal buf[o:o + prod(dims)].reshape(dims) for int, float
    and bool buffers, share their memory (a write through a view reaches the buffer),
    may be empty, and a read-only buffer gives read-only views."""
    for buf in (np.arange(100.0), np.arange(100), np.arange(100) % 3 == 0):
        for o, dims in ((0, (2, 3, 4, 2)), (7, (1, 2, 2, 4)), (50, (0, 4, 4, 1)),
                        (99, (1, 1, 1, 1))):
            vs = _views(buf, o, *dims)
            for k, v in enumerate(vs):
                shape = dims[:k + 1]
                n = int(np.prod(shape))
                assert v.shape == shape and v.dtype == buf.dtype and v.flags.c_contiguous
                assert np.array_equal(v, buf[o:o + n].reshape(shape))
    buf = np.zeros(40)
    v3 = _views(buf, 4, 2, 2, 2, 1)[2]
    v3[1, 0, 1] = -7.0
    assert buf[4 + 4 + 1] == -7.0
    ro = np.arange(40.0)
    ro.setflags(write=False)
    assert not _views(ro, 0, 2, 2, 2, 2)[3].flags.writeable


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
