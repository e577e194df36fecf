"""Compilation switch for the kernels.

Every hot function of openimp is written once, in the subset of Python that
numba compiles in nopython mode, and decorated with :func:`njit`.  With numba
present the decorator compiles it (cached on disk, so later runs load the
machine code); with ``OPENIMP_NOJIT=1`` in the environment the very same
functions run as plain Python, which is slow but handy for debugging.  There is
no second implementation to keep in step.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from typing import Any, TypeVar

F = TypeVar("F", bound=Callable[..., Any])

JIT_ENABLED = os.environ.get("OPENIMP_NOJIT", "") in ("", "0")

try:  # numba is a declared dependency; the fallback only serves OPENIMP_NOJIT debugging
    import numba as _numba
except ImportError:  # pragma: no cover - exercised only on broken installs
    _numba = None
    JIT_ENABLED = False


def _source_digest() -> str:
    """Hash of every source file of the package.

    numba keys a cached function on its own file only, so a kernel in
    kinematics.py would keep stale machine code of joints.py after an upgrade
    or an edit; one cache directory per source version avoids that.
    """
    import hashlib
    from pathlib import Path

    h = hashlib.sha1()
    root = Path(__file__).resolve().parent
    for p in sorted(root.rglob("*.py")):
        h.update(p.relative_to(root).as_posix().encode())
        h.update(p.read_bytes())
    return h.hexdigest()[:16]


def _cache_dir() -> str:
    base = os.environ.get("OPENIMP_CACHE_DIR") or os.path.join(
        os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache"),
        "openimp",
    )
    return os.path.join(base, "numba-" + _source_digest())


def prune_caches(current: str, keep: int = 3) -> list[str]:
    """Remove the cache directories of older source versions beside ``current``.

    Every edit or upgrade of openimp starts a new ``numba-<digest>`` directory;
    all but the ``keep`` most recently modified ones (``current`` always
    stays) are removed.  Returns the removed paths.  Removing one in use by
    another version only makes that version compile again.
    """
    import shutil

    base = os.path.dirname(current)
    try:
        names = [n for n in os.listdir(base) if n.startswith("numba-")]
    except OSError:
        return []
    paths = [os.path.join(base, n) for n in names if os.path.join(base, n) != current]
    paths.sort(key=lambda p: os.path.getmtime(p) if os.path.exists(p) else 0.0, reverse=True)
    removed = []
    for p in paths[max(keep - 1, 0):]:
        shutil.rmtree(p, ignore_errors=True)
        removed.append(p)
    return removed


if _numba is not None and JIT_ENABLED and not os.environ.get("NUMBA_CACHE_DIR"):
    _numba.config.CACHE_DIR = _cache_dir()
    if not os.path.isdir(_numba.config.CACHE_DIR):  # a new source version: tidy up once
        prune_caches(_numba.config.CACHE_DIR)


def _no_literal_specialisation(disp: Any) -> None:
    """Type calls to ``disp`` from compiled code with plain (non-literal) argument types.

    numba types a constant argument in a compiled caller (``f(x, 0)``,
    ``g(..., False)``) as a literal and compiles one specialisation of the
    callee, with its whole call tree, per constant value: five of one
    curve evaluator and two of Newton's method, 10 s of a cold start.  No
    kernel of openimp depends on the value of a constant argument at typing
    time, so every call is typed as the plain type instead.
    """
    from numba.core.types import unliteral

    template = disp.get_call_template

    def get_call_template(args: Any, kws: Any) -> Any:
        return template(tuple(unliteral(a) for a in args),
                        {k: unliteral(v) for k, v in kws.items()})

    disp.get_call_template = get_call_template


def njit(*args: Any, **kwargs: Any) -> Any:
    """Compile a function in nopython mode with an on-disk cache (or leave it as is).

    Usable bare (``@njit``) or with numba options (``@njit(parallel=True)``).
    ``nrt=False`` compiles without numba's reference counting: for kernels
    that allocate nothing, whose array arguments the caller keeps alive.  In
    the hot loops the atomic reference counts of every array view and
    argument otherwise cost more than the arithmetic.
    """
    # explicit either way: numba lets a callee without the option inherit
    # its caller's, and the joint functions that allocate must keep NRT even
    # when called from a kernel without it
    kwargs["_nrt"] = kwargs.pop("nrt", True)
    kwargs.setdefault("cache", True)
    kwargs.setdefault("nogil", True)

    def wrap(fn: F) -> F:
        if not JIT_ENABLED:
            return fn
        disp = _numba.njit(**kwargs)(fn)
        _no_literal_specialisation(disp)
        return disp  # type: ignore[no-any-return]

    if len(args) == 1 and callable(args[0]) and not kwargs.get("_called", False):
        return wrap(args[0])
    return wrap


#: ``numba.prange`` when compiling (parallel loops), plain ``range`` otherwise.
prange = _numba.prange if JIT_ENABLED else range


#: header entries per field of a packed buffer: offset, then up to four dimensions
HEAD = 5


def _field_py(buf: Any, H: Any, k: int, ndim: int) -> Any:
    """Field ``k`` of a packed buffer: the view its header entries in ``H`` describe."""
    o = int(H[HEAD * k])
    return _view_py(buf, o, *(int(d) for d in H[HEAD * k + 1:HEAD * k + 1 + ndim]))


def _view_py(buf: Any, o: int, *shape: int) -> Any:
    """``buf[o:o + prod(shape)].reshape(shape)``: a C-ordered view of a flat buffer."""
    n = 1
    for d in shape:
        n *= d
    return buf[o:o + n].reshape(shape)


if JIT_ENABLED:
    from numba.core import cgutils, types
    from numba.core.imputils import impl_ret_borrowed
    from numba.extending import intrinsic
    from numba.np.arrayobj import make_array, populate_array

    def _view_codegen(rty: Any) -> Callable[..., Any]:
        """Code of a C-ordered ``rty`` view of a flat buffer (see :data:`view1`)."""

        def codegen(context: Any, builder: Any, sig: Any, args: Any) -> Any:
            src = make_array(sig.args[0])(context, builder, value=args[0])
            dst = make_array(rty)(context, builder)
            off = context.cast(builder, args[1], sig.args[1], types.intp)
            shape = [context.cast(builder, a, t, types.intp)
                     for a, t in zip(args[2:], sig.args[2:], strict=True)]
            item = context.get_constant(types.intp, context.get_abi_sizeof(
                context.get_data_type(rty.dtype)))
            strides = [item] * rty.ndim
            for k in range(rty.ndim - 2, -1, -1):
                strides[k] = builder.mul(strides[k + 1], shape[k + 1])
            data = cgutils.gep_inbounds(builder, src.data, off)
            populate_array(dst, data=data, shape=shape, strides=strides,
                           itemsize=src.itemsize, meminfo=src.meminfo, parent=src.parent)
            return impl_ret_borrowed(context, builder, rty, dst._getvalue())

        return codegen

    def _view_type(buf: Any, ndim: int) -> Any:
        if not isinstance(buf, types.Array) or buf.ndim != 1 or buf.layout != "C":
            return None
        return types.Array(buf.dtype, ndim, "C", readonly=not buf.mutable)

    @intrinsic
    def view1(typingctx: Any, buf: Any, o: Any, d0: Any) -> Any:
        """``buf[o:o + d0]`` of a flat C buffer as a new header (no bounds arithmetic).

        numba's slicing and reshape generate index normalisation and checks;
        a kernel builds dozens of views of the packed arrays, which cost
        seconds of compile time and part of every call.  ``view2`` to
        ``view4`` give C-ordered 2-, 3- and 4-d views of ``d0 * d1 * ...``
        elements starting at ``o``.  A read-only buffer gives read-only views.
        The caller guarantees that the elements lie inside ``buf``.
        """
        rty = _view_type(buf, 1)
        return None if rty is None else (rty(buf, o, d0), _view_codegen(rty))

    @intrinsic
    def view2(typingctx: Any, buf: Any, o: Any, d0: Any, d1: Any) -> Any:
        """2-d view (d0, d1) of a flat buffer from element ``o`` (see :func:`view1`)."""
        rty = _view_type(buf, 2)
        return None if rty is None else (rty(buf, o, d0, d1), _view_codegen(rty))

    @intrinsic
    def view3(typingctx: Any, buf: Any, o: Any, d0: Any, d1: Any, d2: Any) -> Any:
        """3-d view (d0, d1, d2) of a flat buffer from element ``o`` (see :func:`view1`)."""
        rty = _view_type(buf, 3)
        return None if rty is None else (rty(buf, o, d0, d1, d2), _view_codegen(rty))

    @intrinsic
    def view4(typingctx: Any, buf: Any, o: Any, d0: Any, d1: Any, d2: Any, d3: Any) -> Any:
        """4-d view (d0, d1, d2, d3) of a flat buffer from element ``o`` (see :func:`view1`)."""
        rty = _view_type(buf, 4)
        return None if rty is None else (rty(buf, o, d0, d1, d2, d3), _view_codegen(rty))

    def _field_codegen(rty: Any) -> Callable[..., Any]:
        """Code of field ``k`` of a packed buffer: offset and dimensions read from H."""

        def codegen(context: Any, builder: Any, sig: Any, args: Any) -> Any:
            hty = sig.args[1]
            H = make_array(hty)(context, builder, value=args[1])
            k = context.cast(builder, args[2], sig.args[2], types.intp)
            base = builder.mul(k, context.get_constant(types.intp, HEAD))

            def head(i: int) -> Any:
                idx = builder.add(base, context.get_constant(types.intp, i))
                return builder.load(cgutils.gep_inbounds(builder, H.data, idx))

            vargs = [args[0], head(0), *[head(1 + i) for i in range(rty.ndim)]]
            vsig = rty(sig.args[0], types.int64, *[types.int64] * rty.ndim)
            return _view_codegen(rty)(context, builder, vsig, vargs)

        return codegen

    def _field_typer(ndim: int) -> Callable[..., Any]:
        def typer(typingctx: Any, buf: Any, H: Any, k: Any) -> Any:
            rty = _view_type(buf, ndim)
            if rty is None or not isinstance(H, types.Array) or H.dtype != types.int64:
                return None
            return rty(buf, H, k), _field_codegen(rty)

        typer.__name__ = f"field{ndim}"
        return typer

    #: ``field1(buf, H, k)`` .. ``field4``: field k of a packed buffer as a 1- to 4-d view,
    #: its offset and dimensions read from the header ``H`` (HEAD int64 entries per
    #: field).  Emitted straight into the caller (no function of its own): the view
    #: takes the caller's reference-counting mode, and a kernel that unpacks dozens of
    #: fields costs no inlining passes.
    field1: Callable[..., Any] = intrinsic(_field_typer(1))
    field2: Callable[..., Any] = intrinsic(_field_typer(2))
    field3: Callable[..., Any] = intrinsic(_field_typer(3))
    field4: Callable[..., Any] = intrinsic(_field_typer(4))
else:
    view1 = view2 = view3 = view4 = _view_py

    def field1(buf: Any, H: Any, k: int) -> Any:
        """Field k of a packed buffer as a 1-d view (plain Python)."""
        return _field_py(buf, H, k, 1)

    def field2(buf: Any, H: Any, k: int) -> Any:
        """Field k of a packed buffer as a 2-d view (plain Python)."""
        return _field_py(buf, H, k, 2)

    def field3(buf: Any, H: Any, k: int) -> Any:
        """Field k of a packed buffer as a 3-d view (plain Python)."""
        return _field_py(buf, H, k, 3)

    def field4(buf: Any, H: Any, k: int) -> Any:
        """Field k of a packed buffer as a 4-d view (plain Python)."""
        return _field_py(buf, H, k, 4)
