"""What the controller sees: position noise, sensor faults and the velocity estimate (docs/theory.md §4).

A :class:`Sensor` composes a position-noise model, any number of :class:`SensorFault` and one
velocity estimator. It turns into plain arrays before the compiled loop runs:

- ``add`` (T, n): added to the true position at each sample (noise, bias faults);
- ``hold`` (T, n): where set, the previous measurement is repeated (stuck sensor, dropout);
- the velocity estimator's code and parameters.

All randomness comes from the ``numpy.random.Generator`` the simulator passes in, drawn in a
fixed order (noise, then dropouts), so a run is reproducible from its seed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from slidingarm import _engine as E
from slidingarm._validate import (
    MAX_POSITION,
    ParameterTypeError,
    integer,
    per_joint,
    plain,
    positive,
    real,
)

__all__ = [
    "VELOCITY_ESTIMATORS",
    "BackwardDifference",
    "DirtyDerivative",
    "GaussianNoise",
    "LevantDifferentiator",
    "Sensor",
    "SensorFault",
    "TrueVelocity",
    "VelocityEstimator",
]

FloatArray = NDArray[np.float64]


# ---------------------------------------------------------------------------- velocity
@dataclass(frozen=True)
class TrueVelocity:
    """The controller uses the plant's true joint velocity (an ideal tachometer)."""

    kind: Literal["true"] = field(default="true", init=False)

    def params(self, n: int) -> tuple[int, FloatArray]:
        """Compiled code and ``(NVF, n)`` parameter table."""
        return E.VEL_TRUE, np.zeros((E.NVF, n))

    def to_dict(self) -> dict[str, Any]:
        return {"kind": self.kind}


@dataclass(frozen=True)
class BackwardDifference:
    """:math:`\\hat{\\dot q}_k = (\\tilde q_k - \\tilde q_{k-1})/T_s`: the paper's remark that
    differentiation amplifies noise (white noise of std σ becomes :math:`\\sqrt2\\sigma/T_s`)."""

    kind: Literal["difference"] = field(default="difference", init=False)

    def params(self, n: int) -> tuple[int, FloatArray]:
        """Compiled code and ``(NVF, n)`` parameter table."""
        return E.VEL_DIFFERENCE, np.zeros((E.NVF, n))

    def to_dict(self) -> dict[str, Any]:
        return {"kind": self.kind}


@dataclass(frozen=True)
class DirtyDerivative:
    """Filtered derivative :math:`s/(T_f s + 1)`, discretised by backward Euler:
    :math:`v_k = (T_f v_{k-1} + \\tilde q_k - \\tilde q_{k-1})/(T_f + T_s)`.

    ``time_constant`` :math:`T_f` (s); the default 5 ms is a 32 Hz corner.
    """

    time_constant: float = 0.005
    kind: Literal["filtered"] = field(default="filtered", init=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "time_constant", positive("time_constant", self.time_constant))

    def params(self, n: int) -> tuple[int, FloatArray]:
        """Compiled code and ``(NVF, n)`` parameter table."""
        vf = np.zeros((E.NVF, n))
        vf[E.VF_TIME_CONSTANT] = self.time_constant
        return E.VEL_FILTERED, vf

    def to_dict(self) -> dict[str, Any]:
        return {"kind": self.kind, "time_constant": self.time_constant}


@dataclass(frozen=True)
class LevantDifferentiator:
    """Levant's first-order robust exact differentiator (Levant 1998), explicit Euler:

    .. math::

        \\dot z_0 = -\\lambda_1 L^{1/2}|z_0 - \\tilde q|^{1/2}\\mathrm{sign}(z_0 - \\tilde q) + z_1,
        \\qquad \\dot z_1 = -\\lambda_0 L\\,\\mathrm{sign}(z_0 - \\tilde q)

    with :math:`z_1` the velocity estimate. ``lipschitz`` :math:`L` bounds :math:`|\\ddot q|`
    (rad/s²); :math:`\\lambda_1 = 1.5, \\lambda_0 = 1.1` are Levant's standard values.
    """

    lipschitz: float = 50.0
    lambda1: float = 1.5
    lambda0: float = 1.1
    kind: Literal["levant"] = field(default="levant", init=False)

    def __post_init__(self) -> None:
        for name in ("lipschitz", "lambda1", "lambda0"):
            object.__setattr__(self, name, positive(name, getattr(self, name)))

    def params(self, n: int) -> tuple[int, FloatArray]:
        """Compiled code and ``(NVF, n)`` parameter table."""
        vf = np.zeros((E.NVF, n))
        vf[E.VF_LIPSCHITZ] = self.lipschitz
        vf[E.VF_LAMBDA1] = self.lambda1
        vf[E.VF_LAMBDA0] = self.lambda0
        return E.VEL_LEVANT, vf

    def to_dict(self) -> dict[str, Any]:
        return {
            "kind": self.kind,
            "lipschitz": self.lipschitz,
            "lambda1": self.lambda1,
            "lambda0": self.lambda0,
        }


VelocityEstimator = TrueVelocity | BackwardDifference | DirtyDerivative | LevantDifferentiator

#: Velocity estimators by name.
VELOCITY_ESTIMATORS: dict[str, type[VelocityEstimator]] = {
    "true": TrueVelocity,
    "difference": BackwardDifference,
    "filtered": DirtyDerivative,
    "levant": LevantDifferentiator,
}


# ---------------------------------------------------------------------------- position
@dataclass(frozen=True)
class GaussianNoise:
    """Position noise :math:`n_k \\sim \\mathcal N(0, \\sigma^2 I)`, independent per sample.

    ``sigma`` (rad) is a scalar or one value per joint, in ``[0, MAX_POSITION]`` (1e3: no
    measurement errs by more than a joint can travel, :data:`slidingarm._validate.MAX_POSITION`).
    """

    sigma: float | tuple[float, ...] = 0.0

    def __post_init__(self) -> None:
        bad = f"noise sigma must be finite and >= 0 (rad), got {self.sigma!r}"
        value = per_joint(
            "noise sigma",
            self.sigma,
            low=0.0,
            inclusive=True,
            invalid=bad,
            out_of_range=bad,
            boolean=f"noise sigma must be a number (rad) or one per joint, not a boolean, "
            f"got {self.sigma!r}",
        )
        if np.any(np.asarray(value) > MAX_POSITION):
            raise ValueError(
                f"noise sigma must be at most {MAX_POSITION:g} (rad, or m; no encoder errs by "
                f"more than a joint can travel), got {self.sigma!r}"
            )
        object.__setattr__(self, "sigma", value)

    def sample(self, rng: np.random.Generator, shape: tuple[int, int]) -> FloatArray:
        """Draw noise of shape ``(T, n)``."""
        sig = np.asarray(self.sigma, dtype=float)
        if sig.ndim == 1 and sig.shape[0] != shape[1]:
            raise ValueError(
                f"noise sigma has {sig.shape[0]} values but the arm has {shape[1]} joints"
            )
        return rng.standard_normal(shape) * sig

    def to_dict(self) -> dict[str, Any]:
        return {"kind": "gaussian", "sigma": plain(self.sigma)}


FaultKind = Literal["bias", "stuck", "dropout"]


@dataclass(frozen=True)
class SensorFault:
    """A position-sensor fault on one joint (1-based ``joint``) from ``t_start`` (s) on.

    - ``bias``: the measurement is offset by ``value`` (rad);
    - ``stuck``: the measurement freezes at its last reading before ``t_start`` (at
      ``t_start = 0``, at the first reading), as a jammed encoder does. It freezes where it
      was, not at a chosen angle (the measurement is formed in the compiled loop from the
      true angle, which is not known in advance), so ``value`` is rejected rather than
      silently ignored;
    - ``dropout``: each sample is lost with ``probability``; a lost sample repeats the last one.

    ``value`` applies to ``bias`` only and ``probability`` to ``dropout`` only: a fault of
    another kind must leave them at their defaults (0 and 1), or a :class:`ValueError` names
    the parameter. Numbers must be real numbers, not booleans or strings.

    Parameters
    ----------
    kind : {"bias", "stuck", "dropout"}
        The fault.
    joint : int
        Joint number, from 1.
    t_start : float, default 0
        Onset (s), finite and >= 0.
    value : float, default 0
        Bias (rad), finite; ``bias`` only.
    probability : float, default 1
        Share of samples lost, in [0, 1]; ``dropout`` only.
    """

    kind: FaultKind
    joint: int
    t_start: float = 0.0
    value: float = 0.0
    probability: float = 1.0

    def __post_init__(self) -> None:
        if not isinstance(self.kind, str):
            raise ParameterTypeError(
                f"fault kind must be 'bias', 'stuck' or 'dropout', got {self.kind!r}"
            )
        if self.kind not in ("bias", "stuck", "dropout"):
            raise ValueError(f"fault kind must be 'bias', 'stuck' or 'dropout', got {self.kind!r}")
        joint = integer(
            "fault joint",
            self.joint,
            low=1,
            message=f"fault joint must be a joint number >= 1, got {self.joint!r}",
        )
        t_start = real(
            "fault t_start",
            self.t_start,
            low=0.0,
            message=f"fault t_start must be a finite time >= 0 s, got {self.t_start!r}",
        )
        value = real(
            "fault value",
            self.value,
            finite=False,
            message=f"fault value must be a number (rad), got {self.value!r}",
        )
        if not math.isfinite(value):
            raise ValueError(f"fault value must be finite, got {self.value!r}")
        probability = real(
            "fault probability",
            self.probability,
            low=0.0,
            high=1.0,
            message=f"fault probability must lie in [0, 1], got {self.probability!r}",
        )
        if self.kind != "bias" and value != 0.0:
            why = (
                "a stuck sensor freezes at its last reading before t_start"
                if self.kind == "stuck"
                else "a lost sample repeats the last reading"
            )
            raise ValueError(
                f"fault value applies to kind='bias' only, got value={self.value!r} with "
                f"kind={self.kind!r} ({why})"
            )
        if self.kind != "dropout" and probability != 1.0:
            raise ValueError(
                f"fault probability applies to kind='dropout' only, got "
                f"probability={self.probability!r} with kind={self.kind!r}"
            )
        object.__setattr__(self, "joint", joint)
        object.__setattr__(self, "t_start", t_start)
        object.__setattr__(self, "value", value)
        object.__setattr__(self, "probability", probability)

    def to_dict(self) -> dict[str, Any]:
        d: dict[str, Any] = {"kind": self.kind, "joint": self.joint, "t_start": self.t_start}
        if self.kind == "bias":
            d["value"] = self.value
        if self.kind == "dropout":
            d["probability"] = self.probability
        return d


@dataclass(frozen=True)
class Sensor:
    """What the controller measures: noise, faults and a velocity estimator."""

    noise: GaussianNoise | None = None
    velocity: VelocityEstimator = field(default_factory=TrueVelocity)
    faults: tuple[SensorFault, ...] = ()

    def __post_init__(self) -> None:
        if self.noise is not None and not isinstance(self.noise, GaussianNoise):
            raise ParameterTypeError(f"noise must be a GaussianNoise or None, got {self.noise!r}")
        if not isinstance(
            self.velocity,
            TrueVelocity | BackwardDifference | DirtyDerivative | LevantDifferentiator,
        ):
            raise ParameterTypeError(
                f"velocity must be a velocity estimator, got {self.velocity!r}"
            )
        faults = self.faults
        if not isinstance(faults, list | tuple) or not all(
            isinstance(f, SensorFault) for f in faults
        ):
            raise ParameterTypeError(
                f"faults must be a list or tuple of SensorFault, got {faults!r}"
            )
        object.__setattr__(self, "faults", tuple(faults))

    @property
    def random(self) -> bool:
        """Whether the sensor draws random numbers."""
        noisy = self.noise is not None and np.any(np.asarray(self.noise.sigma) > 0)
        return bool(noisy or any(f.kind == "dropout" for f in self.faults))

    def arrays(
        self, t: FloatArray, n: int, rng: np.random.Generator
    ) -> tuple[FloatArray, NDArray[np.bool_]]:
        """``(add, hold)`` of shape (T, n) for sample times ``t``."""
        nt = t.shape[0]
        add = np.zeros((nt, n))
        hold = np.zeros((nt, n), dtype=np.bool_)
        if self.noise is not None:
            add += self.noise.sample(rng, (nt, n))
        for fault in self.faults:
            j = fault.joint - 1
            if j >= n:
                raise ValueError(f"fault joint {fault.joint} does not exist on a {n}-joint arm")
            active = t >= fault.t_start
            if fault.kind == "bias":
                add[active, j] += fault.value
            elif fault.kind == "stuck":
                hold[active, j] = True
            else:
                lost = rng.random(nt) < fault.probability
                hold[active & lost, j] = True
        return add, hold

    def to_dict(self) -> dict[str, Any]:
        return {
            "noise": None if self.noise is None else self.noise.to_dict(),
            "velocity": self.velocity.to_dict(),
            "faults": [f.to_dict() for f in self.faults],
        }
