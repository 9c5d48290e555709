"""The arm-model contract: what the controllers, the engine and the numpy API rely on.

An :class:`ArmModel` is immutable and picklable. It reaches compiled code as a
:class:`ModelHandle` (kind code, per-joint float64 parameter table, gravity); the numpy dynamics
API below is written once over that handle and :mod:`slidingarm.models._dispatch`, the one
place that dispatches on the kind. A subclass supplies the parameter block and its kind, its
own constructor, ``to_dict`` and the exports.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray

from slidingarm._validate import ParameterTypeError, number_array
from slidingarm.models import _dispatch as D

__all__ = [
    "MAX_GRAVITY", "MAX_INERTIA", "MAX_LENGTH", "MAX_MASS", "MAX_SCALE", "ArmModel", "ModelHandle",
]  # fmt: skip

#: Physical bounds of an arm's parameters: beyond them a value cannot be meant (a link of
#: a thousand tonnes or a kilometre, gravity beyond the Sun's 274 m/s²) and the dynamics would
#: overflow a float long before a run ends.
MAX_MASS = 1e6  # kg, also the payload
MAX_LENGTH = 1e3  # m
MAX_INERTIA = 1e9  # kg m²
MAX_GRAVITY = 1e3  # m/s²
#: Largest factor of :meth:`PlanarArm.scaled` (a relative model error of at most 1e3 - 1).
MAX_SCALE = 1e3


FloatArray = NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class ModelHandle:
    """What compiled code needs of an arm: ``kind`` (a code of :mod:`._dispatch`), the
    read-only float64 ``params`` table ``(rows, n)`` (one column per joint) whose rows belong
    to that kind, the gravity ``g``
    (m/s²) and the number of joints ``n``."""

    kind: int
    params: FloatArray
    g: float
    n: int


@njit(cache=True)
def _batch_mass(kind, p, g, q, out):  # type: ignore[no-untyped-def]  # pragma: no cover
    work = np.empty((D.WORK_ROWS, q.shape[1]))
    for b in range(q.shape[0]):
        D.mass_matrix(kind, p, g, q[b], out[b], work)


@njit(cache=True)
def _batch_coriolis(kind, p, g, q, qd, out):  # type: ignore[no-untyped-def]  # pragma: no cover
    work = np.empty((D.WORK_ROWS, q.shape[1]))
    for b in range(q.shape[0]):
        D.coriolis(kind, p, g, q[b], qd[b], out[b], work)


@njit(cache=True)
def _batch_gravity(kind, p, g, q, out):  # type: ignore[no-untyped-def]  # pragma: no cover
    work = np.empty((D.WORK_ROWS, q.shape[1]))
    for b in range(q.shape[0]):
        D.gravity_torque(kind, p, g, q[b], out[b], work)


@njit(cache=True)
def _batch_bias(kind, p, g, q, qd, out):  # type: ignore[no-untyped-def]  # pragma: no cover
    work = np.empty((D.WORK_ROWS, q.shape[1]))
    for b in range(q.shape[0]):
        D.bias(kind, p, g, q[b], qd[b], out[b], work)


@njit(cache=True)
def _batch_inverse(kind, p, g, q, qd, qdd, out):  # type: ignore[no-untyped-def]  # pragma: no cover
    work = np.empty((D.WORK_ROWS, q.shape[1]))
    for b in range(q.shape[0]):
        D.inverse_dynamics(kind, p, g, q[b], qd[b], qdd[b], out[b], work)


@njit(cache=True)
def _batch_forward(kind, p, g, q, qd, tau, out):  # type: ignore[no-untyped-def]  # pragma: no cover
    """Fill ``out``; return the first state index whose M(q) is not positive definite, or -1."""
    work = np.empty((D.WORK_ROWS, q.shape[1]))
    for b in range(q.shape[0]):
        if not D.forward_dynamics(kind, p, g, q[b], qd[b], tau[b], out[b], work):
            return b
    return -1


@njit(cache=True)
def _batch_potential(kind, p, g, q, out):  # type: ignore[no-untyped-def]  # pragma: no cover
    work = np.empty((D.WORK_ROWS, q.shape[1]))
    for b in range(q.shape[0]):
        out[b] = D.potential_energy(kind, p, g, q[b], work)


def _read_only(a: FloatArray) -> FloatArray:
    """A C-contiguous, read-only view (or copy) of ``a``: the compiled batch kernels then see one
    array type whether the caller's array was writable or not (a result's frozen signals), so
    each compiles once, not once per mutability (about 5 s of compile each)."""
    out = np.ascontiguousarray(a).view()
    out.flags.writeable = False
    return out


class ArmModel(ABC):
    """An immutable rigid-body arm with ``n`` joints: :math:`M(q)\\ddot q + h(q, \\dot q) = \\tau`.

    Every dynamics method accepts one state ``(n,)`` or a batch ``(B, n)`` and returns the
    matching shape: vectors ``(n,)``/``(B, n)``, matrices ``(n, n)``/``(B, n, n)``, energies a
    float or ``(B,)``.
    """

    __slots__ = ()

    #: The kind code of :mod:`slidingarm.models._dispatch` this class's handles carry.
    KIND: ClassVar[int]

    # ------------------------------------------------------------------ the contract
    @property
    @abstractmethod
    def n(self) -> int:
        """Number of joints."""

    @property
    @abstractmethod
    def gravity(self) -> float:
        """Gravity magnitude ``g`` (m/s²)."""

    @property
    @abstractmethod
    def params(self) -> FloatArray:
        """The read-only ``(rows, n)`` float64 parameter table of this model's kind."""

    @abstractmethod
    def to_dict(self) -> dict[str, Any]:
        """Plain parameters (lists, floats, strings), enough to rebuild the model."""

    @property
    def handle(self) -> ModelHandle:
        """The model as compiled code takes it."""
        return ModelHandle(type(self).KIND, self.params, float(self.gravity), self.n)

    # ------------------------------------------------------------------ input handling
    def _state(self, name: str, value: ArrayLike) -> tuple[FloatArray, bool]:
        """``value`` as a C-contiguous ``(B, n)`` array and whether it was one state."""
        try:
            if value is None or isinstance(value, set | frozenset | dict):
                raise ParameterTypeError(name)
            arr = number_array(name, value)
        except ParameterTypeError:
            # the message only now: a repr of the array on every call would cost 0.1 ms
            raise ParameterTypeError(
                f"{name} must be an array of numbers, got {type(value).__name__} {value!r}"
            ) from None
        n = self.n
        if arr.ndim == 1 and arr.shape[0] == n:
            single = True
            arr = arr.reshape(1, n)
        elif arr.ndim == 2 and arr.shape[1] == n:
            single = False
        else:
            raise ValueError(
                f"{name} must have shape ({n},) or (B, {n}) for this {n}-joint arm, got {arr.shape}"
            )
        if not np.all(np.isfinite(arr)):
            raise ValueError(f"{name} must be finite (no NaN or inf)")
        return np.ascontiguousarray(arr), single

    def _states(self, **named: ArrayLike) -> tuple[list[FloatArray], bool]:
        arrays: list[FloatArray] = []
        singles: list[bool] = []
        for name, value in named.items():
            arr, single = self._state(name, value)
            arrays.append(arr)
            singles.append(single)
        batch = {a.shape[0] for a, s in zip(arrays, singles, strict=True) if not s}
        if len(batch) > 1:
            raise ValueError(
                f"batch sizes differ: {', '.join(f'{k} {a.shape}' for k, a in zip(named, arrays, strict=True))}"
            )
        size = batch.pop() if batch else 1
        arrays = [_read_only(np.broadcast_to(a, (size, self.n))) for a in arrays]
        return arrays, all(singles)

    @staticmethod
    def _out(x: FloatArray, single: bool) -> FloatArray:
        return x[0] if single else x

    def _h(self) -> tuple[int, FloatArray, float]:
        h = self.handle
        return h.kind, h.params, h.g

    # ------------------------------------------------------------------ dynamics
    def mass_matrix(self, q: ArrayLike) -> FloatArray:
        """Joint-space inertia matrix :math:`M(q)`, shape (n, n) or (B, n, n)."""
        (qa,), single = self._states(q=q)
        out = np.empty((qa.shape[0], self.n, self.n))
        _batch_mass(*self._h(), qa, out)
        return self._out(out, single)

    def coriolis(self, q: ArrayLike, qd: ArrayLike) -> FloatArray:
        """Coriolis matrix :math:`C(q, \\dot q)` with :math:`\\dot M - 2C` skew-symmetric,
        shape (n, n) or (B, n, n)."""
        (qa, qda), single = self._states(q=q, qd=qd)
        out = np.empty((qa.shape[0], self.n, self.n))
        _batch_coriolis(*self._h(), qa, qda, out)
        return self._out(out, single)

    def gravity_torque(self, q: ArrayLike) -> FloatArray:
        """Gravity torque :math:`G(q) = \\partial V/\\partial q`, shape (n,) or (B, n)."""
        (qa,), single = self._states(q=q)
        out = np.empty_like(qa)
        _batch_gravity(*self._h(), qa, out)
        return self._out(out, single)

    def bias(self, q: ArrayLike, qd: ArrayLike) -> FloatArray:
        """Bias torque :math:`h(q, \\dot q) = C(q, \\dot q)\\dot q + G(q)`, shape (n,) or (B, n)."""
        (qa, qda), single = self._states(q=q, qd=qd)
        out = np.empty_like(qa)
        _batch_bias(*self._h(), qa, qda, out)
        return self._out(out, single)

    def forward_dynamics(self, q: ArrayLike, qd: ArrayLike, tau: ArrayLike) -> FloatArray:
        """Joint acceleration :math:`\\ddot q = M(q)^{-1}(\\tau - h(q, \\dot q))`."""
        (qa, qda, ta), single = self._states(q=q, qd=qd, tau=tau)
        out = np.empty_like(qa)
        bad = _batch_forward(*self._h(), qa, qda, ta, out)
        if bad >= 0:
            raise ValueError(
                f"M(q) is not positive definite at q = {qa[bad].tolist()}; the arm is degenerate"
            )
        return self._out(out, single)

    def inverse_dynamics(self, q: ArrayLike, qd: ArrayLike, qdd: ArrayLike) -> FloatArray:
        """Joint torque :math:`\\tau = M(q)\\ddot q + h(q, \\dot q)` (recursive Newton-Euler)."""
        (qa, qda, qdda), single = self._states(q=q, qd=qd, qdd=qdd)
        out = np.empty_like(qa)
        _batch_inverse(*self._h(), qa, qda, qdda, out)
        return self._out(out, single)

    def kinetic_energy(self, q: ArrayLike, qd: ArrayLike) -> FloatArray:
        """Kinetic energy :math:`T = \\tfrac12 \\dot q^T M(q) \\dot q` (J), scalar or (B,)."""
        (qa, qda), single = self._states(q=q, qd=qd)
        mm = np.empty((qa.shape[0], self.n, self.n))
        _batch_mass(*self._h(), qa, mm)
        e = 0.5 * np.einsum("bi,bij,bj->b", qda, mm, qda)
        return e[0] if single else e

    def potential_energy(self, q: ArrayLike) -> FloatArray:
        """Potential energy :math:`V(q)` (J; zero where the kind puts it), scalar or (B,)."""
        (qa,), single = self._states(q=q)
        out = np.empty(qa.shape[0])
        _batch_potential(*self._h(), qa, out)
        return out[0] if single else out

    def total_energy(self, q: ArrayLike, qd: ArrayLike) -> FloatArray:
        """Total mechanical energy :math:`T + V` (J), scalar or (B,)."""
        return self.kinetic_energy(q, qd) + self.potential_energy(q)
