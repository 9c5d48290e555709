"""The one place that dispatches on a control law's kind (compiled), and the custom-kernel ABI.

A control law reaches compiled code as a *law handle*: an integer ``code``, a float64
parameter vector private to the law, a state size, and a first-class function pointer
(:class:`KernelPointer`). Built-in sliding-mode laws are ``LAW_SLIDING_MODE`` and ignore the
pointer (they get a pointer to :func:`null_kernel`, so that one compiled loop serves every
law); a :class:`~slidingarm.control.custom.CustomController` is ``LAW_CUSTOM`` and is called
through its pointer with the nominal model's ``M`` and ``h`` computed here:

.. code-block:: text

    kernel(t, q, qd, q_ref, qd_ref, qdd_ref, M, h, params, state, tau, s) -> None

The pointer is typed by its signature only (:data:`KERNEL_TYPE`), so the loop that takes it
is compiled and cached once, whatever kernel a user passes.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numba import njit, types
from numba.core.types.function_type import WrapperAddressProtocol

from slidingarm.control import _kernels as CK
from slidingarm.models import _dispatch as MD

#: Law kind codes.
LAW_SLIDING_MODE = 0
LAW_CUSTOM = 1

_V = types.float64[::1]
#: Signature every custom kernel is compiled to.
KERNEL_SIGNATURE = types.void(
    types.float64, _V, _V, _V, _V, _V, types.float64[:, ::1], _V, _V, _V, _V, _V
)
#: The first-class function type of a compiled kernel.
KERNEL_TYPE = types.FunctionType(KERNEL_SIGNATURE)


class KernelPointer(WrapperAddressProtocol):
    """A compiled kernel as a first-class function of :data:`KERNEL_SIGNATURE`.

    Numba types it by its signature alone, so passing different kernels to one compiled
    function does not compile (or cache) that function again. Pickles as its kernel (a
    module-level ``@njit`` function pickles by reference); the address is looked up again in
    the receiving process.
    """

    def __init__(self, kernel: Any) -> None:
        from numba.experimental.function_type import _get_wrapper_address

        kernel.compile(KERNEL_SIGNATURE.args)
        self.kernel = kernel
        self._address = int(_get_wrapper_address(kernel, KERNEL_SIGNATURE))

    def __wrapper_address__(self) -> int:
        return self._address

    def signature(self) -> Any:
        return KERNEL_SIGNATURE

    def __reduce__(self) -> tuple[Any, ...]:
        return (KernelPointer, (self.kernel,))


@njit(cache=True, nogil=True)
def null_kernel(t, q, qd, q_ref, qd_ref, qdd_ref, M, h, params, state, tau, s):  # type: ignore[no-untyped-def]  # pragma: no cover
    """The pointer built-in laws carry: never called."""


_NULL: KernelPointer | None = None


def null_pointer() -> KernelPointer:
    """The (shared) pointer to :func:`null_kernel`."""
    global _NULL
    if _NULL is None:
        _NULL = KernelPointer(null_kernel)
    return _NULL


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def law_into(
    code: int,
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
    dt: float,
    tau_out: np.ndarray,
    s_out: np.ndarray,
    mmat: np.ndarray,
    lw: np.ndarray,
    work: np.ndarray,
) -> None:
    """Torque ``tau_out`` and sliding variable ``s_out`` (n,) of the law ``(code, kernel, lp,
    state)`` at the measured ``(q, qd)``, with the nominal model ``(mkind, mparams, mg)``.

    ``mmat``, ``lw`` are (n, n) scratch, ``work`` is ``(CK.CONTROL_WORK_ROWS, n)``; on return
    ``work`` holds the nominal model kind's kinematics of ``q``.
    """
    if code == LAW_SLIDING_MODE:
        CK.control_into(
            lp, mkind, mparams, mg, q, qd, q_ref, qd_ref, qdd_ref, state, dt, tau_out, s_out,
            mmat, lw, work,
        )  # fmt: skip
    else:
        _custom_law_into(
            kernel, t, lp, state, mkind, mparams, mg, q, qd, q_ref, qd_ref, qdd_ref, tau_out,
            s_out, mmat, work,
        )  # fmt: skip


@njit(cache=True, nogil=True, error_model="numpy", inline="never")
def _custom_law_into(
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
    mmat: np.ndarray,
    work: np.ndarray,
) -> None:
    """A custom law: ``M``, ``h`` of the nominal model, then the kernel through its pointer.

    Not inlined: compiled (and cached) on its own, it keeps the loop that built-in laws use
    as quick to compile as before.
    """
    h = work[CK.ROW_H]
    MD.mass_and_bias(mkind, mparams, mg, q, qd, mmat, h, work)
    for j in range(q.shape[0]):
        tau_out[j] = 0.0
        s_out[j] = 0.0
    kernel(t, q, qd, q_ref, qd_ref, qdd_ref, mmat, h, lp, state, tau_out, s_out)


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
    """``M`` and ``h`` of the nominal model, as :func:`law_into` hands them to a custom kernel
    (the Python call path of a custom law)."""
    MD.mass_and_bias(mkind, mparams, mg, q, qd, mmat, h, work)
