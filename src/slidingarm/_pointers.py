"""Compiled functions passed to compiled code as addresses (the ABI of first-class functions).

A :class:`FunctionPointer` holds a numba function compiled to one signature and the address of
its C wrapper; :func:`function_at` makes an intrinsic that turns such an address (an int64)
back into a callable first-class function inside compiled code. The control laws' custom
kernels and entries (:mod:`slidingarm.control._dispatch`) and the serial arm's kernels
(:mod:`slidingarm.models._dispatch`) go through it: code reached by an address is compiled
when it is first needed, not with every loop that could call it.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numba import types
from numba.core import cgutils
from numba.core.types.function_type import WrapperAddressProtocol
from numba.extending import intrinsic

from slidingarm._gc import paused

__all__ = ["INLINED", "LINKED", "FunctionPointer", "function_at", "inline_unless_linked", "linked"]

#: How the per-run loop reaches the built-in law and the planar plant's RK4 step, as the *type*
#: of an empty array it is given (one source, two compiled specialisations, each cached):
#: ``INLINED`` calls them directly, compiled into the loop and inlined by LLVM (the fastest
#: loop, which needs them compiled before it); ``LINKED`` calls them through their addresses,
#: so that the loop compiles without them, while other processes compile them
#: (:func:`slidingarm.study.reproduce`), at about 100 ns more per sample.
INLINED = np.empty(0, dtype=np.float64)
LINKED = np.empty(0, dtype=np.int8)


def linked(tag: Any) -> bool:
    """Whether the numba type ``tag`` is :data:`LINKED`'s."""
    return isinstance(tag, types.Array) and tag.dtype == types.int8


def inline_unless_linked(expr: Any, caller_info: Any, callee_info: Any) -> bool:
    """numba's ``inline=`` cost model of an overload whose first argument is the tag: inlined
    in numba's IR where the tag is :data:`INLINED` (the direct call then compiles as it did
    before the tag, and runs as fast), compiled as a small function of its own where it is
    :data:`LINKED` (less of the linked loop's compilation)."""
    return not linked(caller_info.typemap[expr.args[0].name])


class FunctionPointer(WrapperAddressProtocol):
    """A compiled function as a first-class function of ``signature``.

    Numba types it by its signature alone, so passing different functions to one compiled
    function does not compile (or cache) that function again. Pickles as its function (a
    module-level ``@njit`` function pickles by reference) and signature; the address is
    looked up again in the receiving process.
    """

    def __init__(self, function: Any, signature: Any) -> None:
        from numba.experimental.function_type import _get_wrapper_address

        with paused():  # a compilation: no automatic garbage collection (slidingarm._gc)
            function.compile(signature.args)
        self.function = function
        self._signature = signature
        self._address = int(_get_wrapper_address(function, signature))

    def __wrapper_address__(self) -> int:
        return self._address

    @property
    def address(self) -> int:
        """The address of the function's C wrapper: what the loop takes (an int64 unboxes in
        nanoseconds, this object in about 17 µs), made a function again by :func:`kernel_at`
        or :func:`entry_at`. Valid while the function lives (this object holds it)."""
        return self._address

    def signature(self) -> Any:
        return self._signature

    def __reduce__(self) -> tuple[Any, ...]:
        return (FunctionPointer, (self.function, self._signature))


def function_at(fnty: Any) -> Any:
    """An intrinsic turning an int64 address of a C wrapper of signature ``fnty`` into a
    first-class function of that type (what numba builds when it unboxes a pointer object,
    without the Python calls)."""

    @intrinsic
    def at(typingctx, addr):  # type: ignore[no-untyped-def]
        if not isinstance(addr, types.Integer):
            return None

        def codegen(context, builder, signature, args):  # type: ignore[no-untyped-def]
            sfunc = cgutils.create_struct_proxy(fnty)(context, builder)
            voidptr = context.get_value_type(types.voidptr)
            sfunc.c_addr = builder.inttoptr(args[0], voidptr)
            sfunc.py_addr = cgutils.get_null_value(voidptr)
            sfunc.jit_addr = cgutils.get_null_value(voidptr)
            return sfunc._getvalue()

        return fnty(addr), codegen

    return at


@intrinsic
def as_writable(typingctx, arr):  # type: ignore[no-untyped-def]
    """``arr`` typed as a writable array of the same layout (a read-only and a writable array
    share their data model): a first-class function's signature names one of the two, and
    the callee does not write what it is given read-only."""
    if not isinstance(arr, types.Array):
        return None
    out = arr.copy(readonly=False)

    def codegen(context, builder, signature, args):  # type: ignore[no-untyped-def]
        from numba.core.imputils import impl_ret_borrowed

        return impl_ret_borrowed(context, builder, signature.return_type, args[0])

    return out(arr), codegen
