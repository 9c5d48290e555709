"""The control-law contract: what the engine, the results and the studies rely on.

A :class:`Controller` holds its nominal arm model (an :class:`~slidingarm.models.ArmModel`),
describes itself (``name``, ``label``, the unit of its sliding variable, its gain names),
reaches compiled code as a :class:`LawHandle`, and changes only through
:meth:`Controller.replace`, which returns a new, validated controller. The sliding-mode family
(:mod:`slidingarm.control.controllers`) and :class:`~slidingarm.control.custom.CustomController`
implement it; :func:`slidingarm.control.check.check_controller` tests any implementation.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

if TYPE_CHECKING:
    from slidingarm.control._dispatch import FunctionPointer, NullPointer
    from slidingarm.models.base import ArmModel

__all__ = ["Controller", "LawHandle", "checked_inputs"]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class LawHandle:
    """What compiled code needs of a law: its kind ``code`` (of
    :mod:`slidingarm.control._dispatch`), its read-only float64 ``params``, the length
    ``state_size`` of the state vector it keeps between samples (zeroed at the start of a run),
    and the first-class functions ``kernel`` and ``entry`` (called for custom laws only)."""

    code: int
    params: FloatArray
    state_size: int
    kernel: FunctionPointer | NullPointer
    entry: FunctionPointer | NullPointer


def checked_inputs(n: int, **inputs: ArrayLike) -> list[FloatArray]:
    """The inputs of :meth:`Controller.evaluate` as C-contiguous float64 arrays (n,), in the
    order given; ``ValueError`` naming the first of the wrong shape or not finite."""
    arrays = []
    for name, v in inputs.items():
        a = np.ascontiguousarray(np.asarray(v, dtype=np.float64))
        if a.shape != (n,):
            raise ValueError(f"{name} must have shape ({n},), got {a.shape}")
        if not np.all(np.isfinite(a)):
            raise ValueError(f"{name} must be finite (no NaN or inf)")
        arrays.append(a)
    return arrays


class Controller(ABC):
    """A control law :math:`\\tau_k = \\kappa(t_k, \\tilde q_k, \\hat{\\dot q}_k, q_d, \\dot q_d,
    \\ddot q_d)` for an ``n``-joint arm, evaluated at the samples :math:`t_k`."""

    #: Short machine name (``"ftsmc"``, ``"custom"``, …), recorded in results.
    name: str = "controller"

    # ------------------------------------------------------------------ the contract
    @property
    @abstractmethod
    def model(self) -> ArmModel:
        """The nominal arm model the law uses."""

    @property
    def n(self) -> int:
        """Number of joints."""
        return self.model.n

    @property
    def label(self) -> str:
        """Display name for tables and figures (default: ``name`` upper-cased)."""
        return self.name.upper()

    @property
    def s_unit(self) -> str:
        """Unit of the sliding variable ``s`` the law outputs."""
        return "rad/s"

    @property
    @abstractmethod
    def gain_names(self) -> tuple[str, ...]:
        """Names of the law's tunable numeric parameters (each accepted by :meth:`replace`)."""

    @property
    @abstractmethod
    def handle(self) -> LawHandle:
        """The law as compiled code takes it."""

    @property
    def state_size(self) -> int:
        """Length of the state the law keeps between samples."""
        return self.handle.state_size

    def for_period(self, dt: float) -> Controller:
        """This law as it runs at control period ``dt`` (s). The simulator calls it when a run
        starts, so that a parameter left to be chosen from the period (the sliding-mode
        controllers' automatic ``eps_e``) is fixed then; the default returns ``self``."""
        return self

    @abstractmethod
    def replace(self, **changes: Any) -> Controller:
        """A new controller with ``changes`` applied, validated as a new one is."""

    @abstractmethod
    def to_dict(self) -> dict[str, Any]:
        """JSON-able parameters, with ``"controller"`` (:attr:`name`) and ``"model"``."""

    @abstractmethod
    def reset(self) -> None:
        """Clear the state of the Python call path."""

    @abstractmethod
    def evaluate(
        self,
        q: ArrayLike,
        qd: ArrayLike,
        q_ref: ArrayLike,
        qd_ref: ArrayLike,
        qdd_ref: ArrayLike,
        *,
        dt: float | None = None,
        t: float = 0.0,
    ) -> tuple[FloatArray, FloatArray]:
        """Validated evaluation from Python: ``(tau, s)``, each (n,); advances the state."""
