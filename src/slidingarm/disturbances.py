"""What the plant suffers: torque disturbances and model mismatch (docs/theory.md §4).

Torque disturbances are evaluated at the sample times and held over each interval, like the
control torque: the plant receives :math:`\\tau_k + d_k` over :math:`[t_k, t_{k+1})`. Actuator
limits are a simulator option (``torque_limit``); they clip the controller's torque.

Model mismatch makes the plant differ from the controller's nominal arm (:class:`ModelMismatch`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from slidingarm._validate import ParameterTypeError, per_joint, plain, real
from slidingarm.models.planar import PlanarArm
from slidingarm.models.serial import SerialArm

__all__ = [
    "ConstantTorque",
    "Disturbance",
    "ModelMismatch",
    "RandomTorque",
    "SinusoidalTorque",
    "disturbance_torque",
]

FloatArray = NDArray[np.float64]


def _per_joint(
    name: str,
    value: float | tuple[float, ...],
    *,
    low: float | None = None,
    inclusive: bool = False,
    why: str = "",
) -> float | tuple[float, ...]:
    """A finite number or one per joint, bounded below by ``low`` if given
    (:func:`slidingarm._validate.per_joint`, in this module's wording)."""
    return per_joint(
        name,
        value,
        low=low,
        inclusive=inclusive,
        why=why,
        invalid=f"{name} must be a finite number or one per joint, got {value!r}",
    )


def _broadcast(name: str, value: float | tuple[float, ...], n: int) -> FloatArray:
    arr = np.asarray(value, dtype=float)
    if arr.ndim == 1 and arr.shape[0] != n:
        raise ValueError(f"{name} has {arr.shape[0]} values but the arm has {n} joints")
    return np.broadcast_to(arr, (n,)).astype(float)


@dataclass(frozen=True)
class ConstantTorque:
    """:math:`d(t) = d_0` for :math:`t \\ge t_{start}` (N m), per joint or scalar."""

    value: float | tuple[float, ...] = 0.0
    t_start: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "value", _per_joint("constant disturbance value", self.value))
        t_start = real(
            "constant disturbance t_start",
            self.t_start,
            message=f"constant disturbance t_start must be a finite time (s), got {self.t_start!r}",
        )
        object.__setattr__(self, "t_start", t_start)

    def torque(self, t: FloatArray, n: int, rng: np.random.Generator) -> FloatArray:
        """Disturbance samples, shape (T, n)."""
        v = _broadcast("constant disturbance value", self.value, n)
        return np.where((t >= self.t_start)[:, None], v[None, :], 0.0)

    def to_dict(self) -> dict[str, Any]:
        return {"kind": "constant", "value": plain(self.value), "t_start": self.t_start}


@dataclass(frozen=True)
class SinusoidalTorque:
    """:math:`d(t) = A \\sin(2\\pi f t + \\varphi)` (N m); ``frequency`` in Hz."""

    amplitude: float | tuple[float, ...] = 0.0
    frequency: float = 1.0
    phase: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(
            self, "amplitude", _per_joint("sinusoidal disturbance amplitude", self.amplitude)
        )
        frequency = real(
            "sinusoidal disturbance frequency",
            self.frequency,
            low=0.0,
            message="sinusoidal disturbance frequency must be finite and >= 0 Hz, "
            f"got {self.frequency!r}",
        )
        phase = real(
            "sinusoidal disturbance phase",
            self.phase,
            message=f"sinusoidal disturbance phase must be finite (rad), got {self.phase!r}",
        )
        object.__setattr__(self, "frequency", frequency)
        object.__setattr__(self, "phase", phase)

    def torque(self, t: FloatArray, n: int, rng: np.random.Generator) -> FloatArray:
        """Disturbance samples, shape (T, n)."""
        a = _broadcast("sinusoidal disturbance amplitude", self.amplitude, n)
        return np.sin(2 * np.pi * self.frequency * t + self.phase)[:, None] * a[None, :]

    def to_dict(self) -> dict[str, Any]:
        return {
            "kind": "sinusoidal",
            "amplitude": plain(self.amplitude),
            "frequency": self.frequency,
            "phase": self.phase,
        }


@dataclass(frozen=True)
class RandomTorque:
    """Gaussian torque :math:`d_k \\sim \\mathcal N(0, \\sigma^2)` drawn once per sample (N m),
    held over the interval (band-limited white noise)."""

    sigma: float | tuple[float, ...] = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(
            self,
            "sigma",
            _per_joint("random disturbance sigma", self.sigma, low=0.0, inclusive=True),
        )

    def torque(self, t: FloatArray, n: int, rng: np.random.Generator) -> FloatArray:
        """Disturbance samples, shape (T, n)."""
        s = _broadcast("random disturbance sigma", self.sigma, n)
        return rng.standard_normal((t.shape[0], n)) * s[None, :]

    def to_dict(self) -> dict[str, Any]:
        return {"kind": "random", "sigma": plain(self.sigma)}


Disturbance = ConstantTorque | SinusoidalTorque | RandomTorque


def disturbance_torque(
    disturbances: tuple[Disturbance, ...], t: FloatArray, n: int, rng: np.random.Generator
) -> FloatArray:
    """Sum of the disturbances at the sample times, shape (T, n); zeros if there are none."""
    total = np.zeros((t.shape[0], n))
    for d in disturbances:
        total += d.torque(t, n, rng)
    return total


@dataclass(frozen=True)
class ModelMismatch:
    """How the real plant differs from the nominal arm the controller uses.

    The plant is the nominal arm with masses (and inertias with them) scaled by
    ``1 + mass_error``, lengths by ``1 + length_error`` (scalars or per joint; centres of mass
    keep their fraction of the link, inertias scale as :math:`m l^2`), then a point ``payload``
    (kg) at the tool, or, for a :class:`~slidingarm.SerialArm`, at the origin of the link
    ``payload_link``.
    """

    payload: float = 0.0
    mass_error: float | tuple[float, ...] = 0.0
    length_error: float | tuple[float, ...] = 0.0
    payload_link: str | None = None

    def __post_init__(self) -> None:
        payload = real(
            "payload",
            self.payload,
            low=0.0,
            message=f"payload must be a finite mass >= 0 kg, got {self.payload!r}",
        )
        object.__setattr__(self, "payload", payload)
        why = " (a relative error; -1 would remove the link)"
        for name in ("mass_error", "length_error"):
            object.__setattr__(self, name, _per_joint(name, getattr(self, name), low=-1.0, why=why))
        if self.payload_link is not None and not isinstance(self.payload_link, str):
            raise ParameterTypeError(f"payload_link must be a link name, got {self.payload_link!r}")

    def apply(self, nominal: PlanarArm | SerialArm) -> PlanarArm | SerialArm:
        """The plant: the nominal arm with this mismatch."""
        fm = 1.0 + _broadcast("mass_error", self.mass_error, nominal.n)
        fl = 1.0 + _broadcast("length_error", self.length_error, nominal.n)
        arm = nominal.scaled(mass=fm, length=fl)
        if isinstance(arm, SerialArm):
            return arm.with_payload(self.payload, link=self.payload_link) if self.payload > 0 else arm
        if self.payload_link is not None:
            raise ValueError(
                f"payload_link={self.payload_link!r} names a link; a planar arm's payload sits at its tip"
            )
        return arm.with_payload(self.payload) if self.payload > 0 else arm

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            "payload": self.payload,
            "mass_error": plain(self.mass_error),
            "length_error": plain(self.length_error),
        }
        if self.payload_link is not None:
            out["payload_link"] = self.payload_link
        return out
