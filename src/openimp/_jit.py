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

    def _make_view(context: Any, builder: Any, rty: Any, bty: Any, buf: Any, off: Any,
                   shape: list[Any]) -> Any:
        """A C-ordered ``rty`` view of ``shape`` at element ``off`` of the flat buffer
        ``buf`` (of type ``bty``); no reference is taken."""
        src = make_array(bty)(context, builder, value=buf)
        dst = make_array(rty)(context, builder)
        item = context.get_constant(types.intp, context.get_abi_sizeof(
            context.get_data_type(rty.dtype)))
        strides = [item] * rty.ndim
        for k in range(rty.ndim - 2, -1, -1):
            strides[k] = builder.mul(strides[k + 1], shape[k + 1])
        data = cgutils.gep_inbounds(builder, src.data, off)
        populate_array(dst, data=data, shape=shape, strides=strides,
                       itemsize=src.itemsize, meminfo=src.meminfo, parent=src.parent)
        return dst._getvalue()

    def _view_codegen(rty: Any) -> Callable[..., Any]:
        """Code of a C-ordered ``rty`` view of a flat buffer (see :data:`view1`)."""

        def codegen(context: Any, builder: Any, sig: Any, args: Any) -> Any:
            off = context.cast(builder, args[1], sig.args[1], types.intp)
            shape = [context.cast(builder, a, t, types.intp)
                     for a, t in zip(args[2:], sig.args[2:], strict=True)]
            value = _make_view(context, builder, rty, sig.args[0], args[0], off, shape)
            return impl_ret_borrowed(context, builder, rty, value)

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

    def packed_views(layout: tuple[tuple[int, int], ...], cls: type) -> Callable[..., Any]:
        """An intrinsic ``unpack(P)``: the named tuple ``cls`` of every field of a packed
        ``P = (I, F, B)`` (:func:`openimp.system.pack`) as views.

        ``layout`` gives per field its buffer (0, 1, 2) and number of dimensions;
        offsets and dimensions are read from the header at the start of ``I``.
        Emitted straight into the kernel: no function of its own, no inlining
        pass (a kernel that unpacked its fields through an inlined function paid
        seconds of compile time for it).
        """

        def typer(typingctx: Any, P: Any) -> Any:
            if not isinstance(P, types.BaseTuple) or len(P) != 3:
                return None
            fields = [_view_type(P[b], nd) for b, nd in layout]
            if any(f is None for f in fields):
                return None
            rty = types.NamedTuple(fields, cls)

            def codegen(context: Any, builder: Any, sig: Any, args: Any) -> Any:
                pty = sig.args[0]
                bufs = [builder.extract_value(args[0], i) for i in range(3)]
                H = make_array(pty[0])(context, builder, value=bufs[0])

                def head(i: int) -> Any:
                    ptr = cgutils.gep_inbounds(builder, H.data,
                                               context.get_constant(types.intp, i))
                    return builder.load(ptr)

                values = []
                for k, ((b, nd), fty) in enumerate(zip(layout, fields, strict=True)):
                    off = head(HEAD * k)
                    shape = [head(HEAD * k + 1 + i) for i in range(nd)]
                    values.append(_make_view(context, builder, fty, pty[b], bufs[b], off,
                                             shape))
                tup = context.make_tuple(builder, rty, values)
                return impl_ret_borrowed(context, builder, rty, tup)

            return rty(P), codegen

        return intrinsic(typer)  # type: ignore[no-any-return]
else:
    view1 = view2 = view3 = view4 = _view_py

    def packed_views(layout: tuple[tuple[int, int], ...], cls: type) -> Callable[..., Any]:
        """``unpack(P)``: the named tuple ``cls`` of the fields of ``P`` (plain Python)."""

        made: dict[int, tuple[Any, Any]] = {}

        def unpack(P: Any) -> Any:
            # the views of the same buffers are made once (a kernel unpacks at every
            # call; uncompiled, building them cost more than the arithmetic)
            H = P[0]
            hit = made.get(id(H))
            if hit is not None and hit[0] is P:
                return hit[1]
            res = _unpack(P)
            if len(made) >= 64:
                made.clear()
            made[id(H)] = (P, res)
            return res

        def _unpack(P: Any) -> Any:
            H = P[0]
            out = []
            for k, (b, nd) in enumerate(layout):
                o = int(H[HEAD * k])
                dims = (int(d) for d in H[HEAD * k + 1:HEAD * k + 1 + nd])
                out.append(_view_py(P[b], o, *dims))
            return cls(*out)

        return unpack


if JIT_ENABLED:  # a Python session hears of every compile (openimp._announce)
    from openimp._announce import announce as _announce

    _announce()
