"""Plants stepped from Python: the contract for a plant that cannot be compiled (MuJoCo).

The closed loop runs such a plant with the same step pieces as the compiled loop
(:func:`slidingarm._engine.control_step`, :func:`slidingarm._engine.state_status`); only the
plant's advance over each control interval is a Python call.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import Any

import numpy as np
from numpy.typing import NDArray

from slidingarm._validate import ParameterTypeError
from slidingarm.models.base import ArmModel

__all__ = ["SteppedArm", "SteppedPlant"]

FloatArray = NDArray[np.float64]


class SteppedPlant(ABC):
    """A plant advanced from Python: ``step(q, qd, tau, h)`` moves the state ``(q, qd)``
    (float64 arrays (n,), updated in place) over ``h`` seconds with the input ``tau`` held.

    ``step`` returns ``False`` if the plant cannot continue (a singular mass matrix), else
    ``True`` or ``None``. A non-finite state or a runaway speed is detected by the loop.
    """

    @property
    @abstractmethod
    def n(self) -> int:
        """Number of joints."""

    @abstractmethod
    def step(self, q: FloatArray, qd: FloatArray, tau: FloatArray, h: float) -> bool | None:
        """Advance ``(q, qd)`` in place by ``h`` (s) with ``tau`` (n,) held."""

    @abstractmethod
    def to_dict(self) -> dict[str, Any]:
        """Plain parameters, recorded in results."""


class SteppedArm(SteppedPlant):
    """A compiled :class:`~slidingarm.models.ArmModel` advanced by RK4 from Python.

    The same arithmetic as the compiled loop's plant, one Python call per step: it exists to
    check the Python-stepped loop against the compiled one, and as the template of a plant
    written in Python.
    """

    def __init__(self, model: ArmModel) -> None:
        if not isinstance(model, ArmModel):
            raise ParameterTypeError(f"model must be an ArmModel, got {type(model).__name__}")
        from slidingarm.models import _dispatch as MD

        self.model = model
        self._h = model.handle
        self._scratch = np.empty((MD.RK4_ROWS, model.n))
        self._work = np.empty((MD.WORK_ROWS, model.n))

    @property
    def n(self) -> int:
        return self.model.n

    def step(self, q: FloatArray, qd: FloatArray, tau: FloatArray, h: float) -> bool:
        from slidingarm._engine import model_rk4_step

        hd = self._h
        return bool(
            model_rk4_step(hd.kind, hd.params, hd.g, q, qd, tau, h, self._scratch, self._work)
        )

    def to_dict(self) -> dict[str, Any]:
        return {"stepped": self.model.to_dict()}

    def __reduce__(self) -> tuple[Any, ...]:
        return (SteppedArm, (self.model,))
