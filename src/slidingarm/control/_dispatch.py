"""The one place that dispatches on a control law's kind (compiled), and the custom-kernel ABI.

A control law reaches compiled code as a *law handle*: an integer ``code``, a float64
parameter vector private to the law, a state size, and two first-class functions, passed to
the loop as the addresses of :class:`FunctionPointer` objects. Built-in sliding-mode laws are
``LAW_SLIDING_MODE`` and call neither, unless the paper's law is reached through ``entry``
(they carry :data:`NULL`, address 0, so that one compiled loop serves every law). A
:class:`~slidingarm.control.custom.CustomController` is ``LAW_CUSTOM``: the loop calls
``entry(kernel, ...)``, where :func:`custom_entry` computes the nominal model's ``M`` and ``h``
and calls the user's kernel:

.. code-block:: text

    kernel(t, q, qd, q_ref, qd_ref, qdd_ref, M, h, params, state, tau, s) -> None

The pointers are typed by their signatures only (:data:`KERNEL_TYPE`, :data:`ENTRY_TYPE`), so
the loop that takes them is compiled and cached once, whatever kernel a user passes; and
since the model evaluation of custom laws sits behind ``entry``, it is compiled only when a
custom law is first made, not with the loop every built-in law uses.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numba import njit, types

from slidingarm._pointers import INLINED, FunctionPointer, function_at
from slidingarm.control import _kernels as CK
from slidingarm.models import _dispatch as MD

#: Law kind codes.
LAW_SLIDING_MODE = 0
LAW_CUSTOM = 1

_V = types.float64[::1]
_M = types.float64[:, ::1]
#: Signature every custom kernel is compiled to.
KERNEL_SIGNATURE = types.void(types.float64, _V, _V, _V, _V, _V, _M, _V, _V, _V, _V, _V)
#: The first-class function type of a compiled kernel.
KERNEL_TYPE = types.FunctionType(KERNEL_SIGNATURE)
#: Signature of an entry the loop calls through a pointer (a custom law, the paper's law):
#: ``(kernel, t, params, state, mkind, mparams, mg, q, qd, q_ref, qd_ref, qdd_ref, tau, s,
#: mats, work)``, ``mats`` (2 n, n) scratch.
ENTRY_SIGNATURE = types.void(
    KERNEL_TYPE, types.float64, _V, _V, types.int64, _M, types.float64, _V, _V, _V, _V, _V,
    _V, _V, _M, _M,
)  # fmt: skip
#: The first-class function type of an entry.
ENTRY_TYPE = types.FunctionType(ENTRY_SIGNATURE)


#: ``kernel_at(address)``: the kernel at an address (:attr:`FunctionPointer.address`).
kernel_at = function_at(KERNEL_TYPE)
#: ``entry_at(address)``: the entry at an address (:attr:`FunctionPointer.address`).
entry_at = function_at(ENTRY_TYPE)


class NullPointer:
    """The pointer built-in laws carry where a function goes: address 0, never called (the
    sliding-mode branch does not call it). Nothing to compile."""

    address = 0

    def __reduce__(self) -> tuple[Any, ...]:
        return (NullPointer, ())


#: The one :class:`NullPointer`.
NULL = NullPointer()


@njit(cache=True, nogil=True)
def null_kernel(t, q, qd, q_ref, qd_ref, qdd_ref, M, h, params, state, tau, s):  # type: ignore[no-untyped-def]  # pragma: no cover
    """The kernel :func:`control_once` passes: never called."""


@njit(cache=True, nogil=True)
def null_entry(kernel, t, lp, state, mkind, mparams, mg, q, qd, q_ref, qd_ref, qdd_ref, tau, s, mats, work):  # type: ignore[no-untyped-def]  # pragma: no cover
    """The entry :func:`control_once` passes (statically, so that inputs of any array type
    are accepted): never called, the model law does not reach it."""


@njit(cache=True, nogil=True, error_model="numpy")
def custom_entry(
    kernel: Any,
    t: float,
    lp: np.ndarray,
    state: np.ndarray,
    mkind: int,
    mparams: np.ndarray,
    mg: float,
    q: np.ndarray,
    qd: np.ndarray,
    q_ref: np.ndarray,
    qd_ref: np.ndarray,
    qdd_ref: np.ndarray,
    tau_out: np.ndarray,
    s_out: np.ndarray,
    mats: np.ndarray,
    work: np.ndarray,
) -> None:
    """A custom law's step: ``M`` (``mats[:n]``), ``h`` (``work`` row ``CK.ROW_H``) of the
    nominal model at ``(q, qd)``, ``tau`` and ``s`` zeroed, then the kernel."""
    mmat = mats[: q.shape[0]]
    h = work[CK.ROW_H]
    MD.mass_and_bias(mkind, mparams, mg, q, qd, mmat, h, work)
    for j in range(q.shape[0]):
        tau_out[j] = 0.0
        s_out[j] = 0.0
    kernel(t, q, qd, q_ref, qd_ref, qdd_ref, mmat, h, lp, state, tau_out, s_out)


_ENTRY: FunctionPointer | None = None
_PAPER: FunctionPointer | None = None
_LAW: FunctionPointer | None = None


def entry_pointer() -> FunctionPointer:
    """The (shared) pointer to :func:`custom_entry` (compiled on first use)."""
    global _ENTRY
    if _ENTRY is None:
        _ENTRY = FunctionPointer(custom_entry, ENTRY_SIGNATURE)
    return _ENTRY


def law_pointer() -> FunctionPointer:
    """The (shared) pointer to :func:`slidingarm.control._kernels.sliding_mode_into`, which the
    linked per-run loop calls through its address (compiled, or loaded from numba's cache, on
    first use)."""
    global _LAW
    if _LAW is None:
        _LAW = FunctionPointer(CK.sliding_mode_into, CK.LAW_SIGNATURE)
    return _LAW


def paper_pointer() -> FunctionPointer:
    """The (shared) pointer to the paper's law :func:`slidingarm.control._kernels.paper_entry`
    (compiled on first use)."""
    global _PAPER
    if _PAPER is None:
        _PAPER = FunctionPointer(CK.paper_entry, ENTRY_SIGNATURE)
    return _PAPER


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def law_into(
    code: int,
    entry: Any,
    kernel: Any,
    link: np.ndarray,
    law_address: int,
    t: float,
    lp: np.ndarray,
    state: np.ndarray,
    mkind: int,
    mparams: np.ndarray,
    mg: float,
    q: np.ndarray,
    qd: np.ndarray,
    q_ref: np.ndarray,
    qd_ref: np.ndarray,
    qdd_ref: np.ndarray,
    dt: float,
    tau_out: np.ndarray,
    s_out: np.ndarray,
    mats: np.ndarray,
    work: np.ndarray,
) -> None:
    """Torque ``tau_out`` and sliding variable ``s_out`` (n,) of the law ``(code, entry,
    kernel, lp, state)`` at the measured ``(q, qd)``, with the nominal model ``(mkind,
    mparams, mg)``; ``link`` and ``law_address``: how the built-in laws reach
    :func:`slidingarm.control._kernels.sliding_mode_into` (:func:`slidingarm.control._kernels.call_law`).

    ``mats`` is (2 n, n) scratch, ``work`` is ``(CK.CONTROL_WORK_ROWS, n)``; on return
    ``work`` holds the nominal model kind's kinematics of ``q``.
    """
    if code == LAW_SLIDING_MODE:
        CK.control_into(
            entry, kernel, link, law_address, lp, mkind, mparams, mg, q, qd, q_ref, qd_ref,
            qdd_ref, state, dt, tau_out, s_out, mats, work,
        )  # fmt: skip
    else:
        entry(kernel, t, lp, state, mkind, mparams, mg, q, qd, q_ref, qd_ref, qdd_ref, tau_out,
              s_out, mats, work)  # fmt: skip


@njit(cache=True, nogil=True, error_model="numpy")
def control_once(
    p: np.ndarray,
    mkind: int,
    mparams: np.ndarray,
    g: float,
    q: np.ndarray,
    qd: np.ndarray,
    q_ref: np.ndarray,
    qd_ref: np.ndarray,
    qdd_ref: np.ndarray,
    st_state: np.ndarray,
    dt: float,
    tau_out: np.ndarray,
    s_out: np.ndarray,
    scratch: np.ndarray,
) -> None:
    """One sliding-mode call from Python with the model law: torque into ``tau_out``, ``s``
    into ``s_out`` (n,); ``scratch`` is ``(CK.CONTROL_WORK_ROWS + 2 n, n)``. No pointer is
    passed (a pointer argument costs microseconds per call): the paper branch is unreachable
    here, see :func:`control_once_entry`."""
    n = q.shape[0]
    CK.control_into(
        null_entry, null_kernel, INLINED, 0, p, mkind, mparams, g, q, qd, q_ref, qd_ref, qdd_ref, st_state,
        dt, tau_out, s_out, scratch[CK.CONTROL_WORK_ROWS : CK.CONTROL_WORK_ROWS + 2 * n],
        scratch[: CK.CONTROL_WORK_ROWS],
    )  # fmt: skip


@njit(cache=True, nogil=True, error_model="numpy")
def control_once_entry(
    entry_address: int,
    kernel_address: int,
    p: np.ndarray,
    mkind: int,
    mparams: np.ndarray,
    g: float,
    q: np.ndarray,
    qd: np.ndarray,
    q_ref: np.ndarray,
    qd_ref: np.ndarray,
    qdd_ref: np.ndarray,
    st_state: np.ndarray,
    dt: float,
    tau_out: np.ndarray,
    s_out: np.ndarray,
    scratch: np.ndarray,
) -> None:
    """:func:`control_once` for a law reached through an entry (the paper's), given the
    entry's and kernel's addresses."""
    n = q.shape[0]
    CK.control_into(
        entry_at(entry_address), kernel_at(kernel_address), INLINED, 0, p, mkind, mparams, g, q, qd, q_ref, qd_ref, qdd_ref, st_state, dt,
        tau_out, s_out, scratch[CK.CONTROL_WORK_ROWS : CK.CONTROL_WORK_ROWS + 2 * n],
        scratch[: CK.CONTROL_WORK_ROWS],
    )  # fmt: skip


@njit(cache=True, nogil=True, error_model="numpy")
def mass_and_bias_once(
    mkind: int,
    mparams: np.ndarray,
    mg: float,
    q: np.ndarray,
    qd: np.ndarray,
    mmat: np.ndarray,
    h: np.ndarray,
    work: np.ndarray,
) -> None:
    """``M`` and ``h`` of the nominal model, as :func:`custom_entry` hands them to a kernel
    (the Python call path of a custom law)."""
    MD.mass_and_bias(mkind, mparams, mg, q, qd, mmat, h, work)
