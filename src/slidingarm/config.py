"""Scenario files: a TOML description of one comparison, validated, then built into library objects.

A scenario states the arm, the model mismatch, the reference, the simulation, the sensor, the
disturbances, the controllers to compare and the gains they share. It is validated by pydantic
models that forbid unknown keys everywhere; every error is one line naming the file, the key
path (``controllers[1].gamma``, ``sensor.noise.sigma``) and what is allowed::

    sign.toml: controllers[1].gamma: must lie in (0, 1) (terminal: gamma = q/p with odd q < p), got 1.6667

Layout of a file (every table is optional except ``plant``, ``reference``, ``simulation`` and
``controllers``; ``slidingarm schema`` prints the full JSON schema)::

    extends = "paper.toml"      # optional base file (relative path), merged under this one:
                                # tables merge key by key, except a table that names its kind
                                # (kind; for [plant] preset or masses), which replaces the base's;
                                # values and arrays replace
    name = "sign"               # default: the file's stem
    description = "..."
    switching = "sign"          # shared switching function: sign | tanh | sat

    [plant]                     # the controller's nominal arm
    preset = "paper"            # or masses, lengths (and com, inertia)
    mass_model = "point"        # point | rod

    [mismatch]                  # the simulated plant = nominal arm with these errors
    payload = 0.0               # kg at the tool
    mass_error = 0.0            # relative, scalar or per joint
    length_error = 0.0

    [reference]                 # slidingarm.references.reference_from_dict
    kind = "paper"              # paper | quintic | sine | table (path relative to the file)

    [simulation]
    t_final = 4.5               # s
    dt = 5e-4                   # s, sample time
    substeps = 1                # RK4 steps per sample
    q0 = [0.7, 1.5, 0.5]        # rad
    qd0 = [0.0, 0.0, 0.0]       # rad/s
    seed = 1
    torque_limit = 100.0        # optional, N m, scalar or per joint

    [sensor]
    noise = { sigma = 1e-4 }                           # rad
    velocity = { kind = "filtered", time_constant = 0.005 }
    faults = [{ kind = "bias", joint = 1, t_start = 2.0, value = 0.01 }]
    reasons = "markdown"

    [[disturbances]]
    kind = "constant"           # constant | sinusoidal | random
    value = 0.5

    [gains]                     # stated once, shared wherever a gain means the same thing
    alpha = 2.0                 # = lam: PDSMC's lambda and FTSMC's alpha (the linear term)
    beta = 2.0                  # the terminal term of TSMC and FTSMC
    p = 5                       # gamma = q/p (or give gamma)
    q = 3
    k = 20.0                    # reaching gain
    width = 0.05                # boundary layer of tanh/sat (ignored with sign)
    reasons = "markdown"

    [[controllers]]
    name = "ftsmc"              # pdsmc | tsmc | ftsmc | ntsmc
    label = "ftsmc"             # unique; names the results (default: name)
    law = "model"               # model | paper
    reaching = "classic"        # classic | super-twisting
    # any gain above (and switching, allow_nonterminal) overrides the shared value here

Load with :func:`load_scenario` (or :func:`scenario_from_dict`) and build with
:meth:`Scenario.build`, which returns a :class:`Setup` of library objects.
"""

from __future__ import annotations

import difflib
import math
import re
import tomllib
import types
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import Annotated, Any, Literal, Union, get_args, get_origin

from pydantic import (
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
    PrivateAttr,
    StrictBool,
    ValidationError,
    ValidationInfo,
    field_validator,
    model_validator,
)
from pydantic.functional_validators import PlainValidator
from pydantic.json_schema import WithJsonSchema

from slidingarm._validate import is_integer, is_real
from slidingarm.control.controllers import (
    FTSMC,
    NTSMC,
    PDSMC,
    TSMC,
    SlidingModeController,
)
from slidingarm.disturbances import (
    ConstantTorque,
    Disturbance,
    ModelMismatch,
    RandomTorque,
    SinusoidalTorque,
)
from slidingarm.models.planar import PlanarArm
from slidingarm.references import Reference, reference_from_dict
from slidingarm.sensors import (
    BackwardDifference,
    DirtyDerivative,
    GaussianNoise,
    LevantDifferentiator,
    Sensor,
    SensorFault,
    TrueVelocity,
    VelocityEstimator,
)
from slidingarm.simulate import time_grid

__all__ = [
    "CONTROLLERS",
    "ConfigError",
    "ControllerSpec",
    "GainsSpec",
    "Scenario",
    "Setup",
    "choices",
    "load_scenario",
    "scenario_from_dict",
]

#: Controller names a scenario may use, with what they are.
CONTROLLERS: dict[str, str] = {
    "pdsmc": "PD sliding mode: s = ė + λe",
    "tsmc": "terminal SMC: s = ė + β sig(e)^γ, 0 < γ < 1",
    "ftsmc": "fast terminal SMC: s = ė + αe + β sig(e)^γ",
    "ntsmc": "nonsingular terminal SMC (Feng et al. 2002): s = e + (1/β) sig(ė)^(p/q), 1 < p/q < 2",
}

_CONTROLLER_CLASSES: dict[str, type[SlidingModeController]] = {
    "pdsmc": PDSMC,
    "tsmc": TSMC,
    "ftsmc": FTSMC,
    "ntsmc": NTSMC,
}

#: Which surface gains each controller takes ("linear" is alpha = lam, "exponent" gamma or p/q).
_SURFACE_GAINS: dict[str, tuple[str, ...]] = {
    "pdsmc": ("linear",),
    "tsmc": ("beta", "exponent"),
    "ftsmc": ("linear", "beta", "exponent"),
    "ntsmc": ("beta", "exponent"),
}

_NAME_PATTERN = r"^[A-Za-z0-9][A-Za-z0-9_.-]*$"


# --------------------------------------------------------------------------------------------
# errors


class ConfigError(ValueError):
    """An invalid scenario: one line naming the file, the key path and what is allowed.

    Attributes
    ----------
    file : str or None
        The file (or ``None`` for a scenario given as a mapping).
    path : str
        The key path, e.g. ``controllers[1].gamma`` (empty for the whole file).
    reason : str
        What is wrong and what is allowed.
    """

    def __init__(self, reason: str, *, file: str | Path | None = None, path: str = "") -> None:
        self.file = None if file is None else str(file)
        self.path = path
        self.reason = " ".join(str(reason).split())
        super().__init__(": ".join(p for p in (self.file, self.path, self.reason) if p))


# --------------------------------------------------------------------------------------------
# value types: one error per bad value, with the allowed range in words


def _bound(low: float | None, inclusive: bool) -> str:
    return "" if low is None else (f" >= {low:g}" if inclusive else f" > {low:g}")


def _below(x: float, low: float | None, inclusive: bool) -> bool:
    return low is not None and (x < low or (x == low and not inclusive))


def _per_joint_check(
    low: float | None, *, inclusive: bool = False, what: str = ""
) -> Callable[[Any], float | list[float]]:
    """Validator of a finite number or a non-empty list of them (one per joint)."""
    bound = _bound(low, inclusive)

    def check(v: Any) -> float | list[float]:
        if is_real(v):
            values, scalar = [float(v)], True
        elif isinstance(v, list | tuple) and v and all(is_real(x) for x in v):
            values, scalar = [float(x) for x in v], False
        else:
            raise ValueError(
                f"must be a number{bound} or a list of them (one per joint){what}, got {v!r}"
            )
        for x in values:
            if not math.isfinite(x):
                raise ValueError(f"must be finite, got {v!r}")
            if _below(x, low, inclusive):
                raise ValueError(f"must be{bound}{what} (a scalar or one per joint), got {v!r}")
        return values[0] if scalar else values

    return check


def _vector_check(
    low: float | None = None, *, inclusive: bool = False
) -> Callable[[Any], list[float]]:
    """Validator of a non-empty list of finite numbers (one per joint)."""
    bound = _bound(low, inclusive)

    def check(v: Any) -> list[float]:
        if not (isinstance(v, list | tuple) and v and all(is_real(x) for x in v)):
            raise ValueError(f"must be a list of numbers{bound} (one per joint), got {v!r}")
        values = [float(x) for x in v]
        if any(not math.isfinite(x) or _below(x, low, inclusive) for x in values):
            raise ValueError(f"must be a list of finite numbers{bound}, got {v!r}")
        return values

    return check


def _type_check(allowed: str, accept: Callable[[Any], bool]) -> Callable[[Any], Any]:
    """Before-validator of a plain number: ``accept`` (:func:`is_real` or :func:`is_integer`)
    lets a value through to pydantic, which converts and bounds it; ``allowed`` says what is
    allowed (``"a number > 0"``, ``"an integer >= 1"``).

    Without it, pydantic's lax mode would read ``true`` as 1, the float ``2.0`` as the integer
    2 and the string ``"4.5"`` as 4.5.
    """

    def check(v: Any) -> Any:
        if isinstance(v, bool):
            raise ValueError(f"must be {allowed}, not a boolean, got {v!r}")
        if not accept(v):
            raise ValueError(f"must be {allowed}, got {v!r}")
        return v

    return check


def _number(allowed: str) -> BeforeValidator:
    return BeforeValidator(_type_check(allowed, is_real))


def _integer(allowed: str) -> BeforeValidator:
    return BeforeValidator(_type_check(allowed, is_integer))


def _schema(low: float | None, *, inclusive: bool = False, scalar: bool = True) -> dict[str, Any]:
    """JSON schema of a per-joint value (``scalar``: a number or a list) or a vector."""
    item: dict[str, Any] = {"type": "number"}
    if low is not None:
        item["minimum" if inclusive else "exclusiveMinimum"] = low
    array = {"type": "array", "items": item, "minItems": 1}
    return {"anyOf": [item, array]} if scalar else array


PositivePerJoint = Annotated[
    float | list[float], PlainValidator(_per_joint_check(0.0)), WithJsonSchema(_schema(0.0))
]
NonNegativePerJoint = Annotated[
    float | list[float],
    PlainValidator(_per_joint_check(0.0, inclusive=True)),
    WithJsonSchema(_schema(0.0, inclusive=True)),
]
RealPerJoint = Annotated[
    float | list[float], PlainValidator(_per_joint_check(None)), WithJsonSchema(_schema(None))
]
RelativeError = Annotated[
    float | list[float],
    PlainValidator(_per_joint_check(-1.0, what=" (a relative error; -1 would remove the link)")),
    WithJsonSchema(_schema(-1.0)),
]
Vector = Annotated[
    list[float], PlainValidator(_vector_check()), WithJsonSchema(_schema(None, scalar=False))
]
PositiveVector = Annotated[
    list[float], PlainValidator(_vector_check(0.0)), WithJsonSchema(_schema(0.0, scalar=False))
]
NonNegativeVector = Annotated[
    list[float],
    PlainValidator(_vector_check(0.0, inclusive=True)),
    WithJsonSchema(_schema(0.0, inclusive=True, scalar=False)),
]
# The type check comes last: it wraps the constraints, so it runs first, and the JSON schema
# keeps them (``minimum``, ``exclusiveMinimum``).
PositiveFloat = Annotated[float, Field(gt=0, allow_inf_nan=False), _number("a number > 0")]
NonNegativeFloat = Annotated[float, Field(ge=0, allow_inf_nan=False), _number("a number >= 0")]
FiniteFloat = Annotated[float, Field(allow_inf_nan=False), _number("a finite number")]
Probability = Annotated[float, Field(ge=0, le=1), _number("a number in [0, 1]")]
Real = Annotated[float, _number("a number")]
PositiveInt = Annotated[int, Field(ge=1), _integer("an integer >= 1")]
NonNegativeInt = Annotated[int, Field(ge=0), _integer("an integer >= 0")]
OddInt = Annotated[int, _integer("a positive odd integer")]
Switching = Literal["sign", "tanh", "sat"]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


# --------------------------------------------------------------------------------------------
# plant, mismatch, reference, simulation


class PlantSpec(_Strict):
    """The controller's nominal arm: the paper's preset or explicit link parameters (SI units)."""

    preset: Literal["paper"] | None = Field(
        default=None, description="'paper': m = (1, 1, 1) kg, l = (0.5, 1, 1) m (SPEC §2)."
    )
    mass_model: Literal["point", "rod"] = Field(
        default="point", description="point: mass at the link's tip; rod: uniform slender rod."
    )
    masses: PositiveVector | None = Field(default=None, description="Link masses (kg).")
    lengths: PositiveVector | None = Field(default=None, description="Link lengths (m).")
    com: NonNegativeVector | None = Field(
        default=None,
        description="Centre-of-mass distance from each joint (m); default from mass_model.",
    )
    inertia: NonNegativeVector | None = Field(
        default=None, description="Centroidal inertias (kg m²); default from mass_model."
    )
    gravity: NonNegativeFloat = Field(default=9.81, description="g (m/s²), acting along -y.")

    @model_validator(mode="after")
    def _one_source(self) -> PlantSpec:
        explicit = [
            k for k in ("masses", "lengths", "com", "inertia") if getattr(self, k) is not None
        ]
        if self.preset is not None and explicit:
            raise ValueError(
                f"give either preset = 'paper' or explicit masses and lengths, not both "
                f"(got preset and {', '.join(explicit)})"
            )
        if self.preset is None and (self.masses is None or self.lengths is None):
            raise ValueError("needs preset = 'paper' or both masses and lengths")
        return self

    def build(self) -> PlanarArm:
        """The nominal arm."""
        if self.preset == "paper":
            return PlanarArm.paper(self.mass_model, gravity=self.gravity)
        return PlanarArm(
            self.masses if self.masses is not None else (),
            self.lengths if self.lengths is not None else (),
            com=self.com,
            inertia=self.inertia,
            mass_model=self.mass_model,
            gravity=self.gravity,
        )


class MismatchSpec(_Strict):
    """How the simulated plant differs from the nominal arm the controllers use."""

    payload: NonNegativeFloat = Field(default=0.0, description="Point mass at the tool (kg).")
    mass_error: RelativeError = Field(default=0.0, description="Relative mass error, > -1.")
    length_error: RelativeError = Field(default=0.0, description="Relative length error, > -1.")

    def build(self) -> ModelMismatch:
        return ModelMismatch(
            payload=self.payload,
            mass_error=_tuple(self.mass_error),
            length_error=_tuple(self.length_error),
        )


class PaperReferenceSpec(_Strict):
    """The paper's reference q_d(t) (SPEC §2)."""

    kind: Literal["paper"]


class QuinticReferenceSpec(_Strict):
    """A quintic point-to-point move."""

    kind: Literal["quintic"]
    q_start: Vector
    q_end: Vector
    duration: PositiveFloat
    t_start: NonNegativeFloat = 0.0


class SineReferenceSpec(_Strict):
    """q_d = offset + amplitude sin(2π frequency t + phase), per joint."""

    kind: Literal["sine"]
    offset: Vector
    amplitude: RealPerJoint
    frequency: NonNegativePerJoint
    phase: RealPerJoint = 0.0


class TableReferenceSpec(_Strict):
    """A spline through a table: inline t and q, or a CSV file (path relative to the scenario)."""

    kind: Literal["table"]
    t: Vector | None = None
    q: list[Vector] | None = None
    path: str | None = None
    spline: Literal["quintic", "cubic"] = "quintic"

    @model_validator(mode="after")
    def _one_source(self) -> TableReferenceSpec:
        if self.path is not None and (self.t is not None or self.q is not None):
            raise ValueError("give either path (a CSV file) or t and q, not both")
        if self.path is None and (self.t is None or self.q is None):
            raise ValueError("needs path (a CSV file with columns t, q1..qn) or both t and q")
        return self


ReferenceSpec = Annotated[
    PaperReferenceSpec | QuinticReferenceSpec | SineReferenceSpec | TableReferenceSpec,
    Field(discriminator="kind"),
]


class SimulationSpec(_Strict):
    """Time grid, initial state, seed and actuator limits."""

    t_final: PositiveFloat = Field(description="Duration (s), a whole number of dt.")
    dt: PositiveFloat = Field(description="Sample time of the digital controller (s).")
    substeps: PositiveInt = Field(default=1, description="RK4 steps per sample interval.")
    q0: Vector = Field(description="Initial joint angles (rad).")
    qd0: Vector | None = Field(
        default=None, description="Initial joint velocities (rad/s); default rest."
    )
    seed: NonNegativeInt = Field(default=0, description="Seed of the run's random generator.")
    torque_limit: PositivePerJoint | None = Field(
        default=None, description="Actuator limit |tau_i| <= tau_max (N m), scalar or per joint."
    )


# --------------------------------------------------------------------------------------------
# sensor


class NoiseSpec(_Strict):
    """Gaussian noise on the measured joint positions."""

    sigma: NonNegativePerJoint = Field(description="Standard deviation (rad), scalar or per joint.")


class TrueVelocitySpec(_Strict):
    """The controller uses the true joint velocity."""

    kind: Literal["true"]


class DifferenceVelocitySpec(_Strict):
    """Backward difference of the measured position."""

    kind: Literal["difference"]


class FilteredVelocitySpec(_Strict):
    """Dirty derivative s/(T_f s + 1)."""

    kind: Literal["filtered"]
    time_constant: PositiveFloat = Field(default=0.005, description="T_f (s).")


class LevantVelocitySpec(_Strict):
    """Levant's robust exact differentiator."""

    kind: Literal["levant"]
    lipschitz: PositiveFloat = Field(default=50.0, description="Bound L on |q̈| (rad/s²).")
    lambda1: PositiveFloat = 1.5
    lambda0: PositiveFloat = 1.1


VelocitySpec = Annotated[
    TrueVelocitySpec | DifferenceVelocitySpec | FilteredVelocitySpec | LevantVelocitySpec,
    Field(discriminator="kind"),
]


class BiasFaultSpec(_Strict):
    """The measurement of one joint is offset by value (rad) from t_start on."""

    kind: Literal["bias"]
    joint: PositiveInt = Field(description="Joint number, from 1.")
    t_start: NonNegativeFloat = 0.0
    value: FiniteFloat


class StuckFaultSpec(_Strict):
    """The measurement of one joint freezes from t_start on."""

    kind: Literal["stuck"]
    joint: PositiveInt
    t_start: NonNegativeFloat = 0.0


class DropoutFaultSpec(_Strict):
    """Each sample of one joint is lost with probability from t_start on."""

    kind: Literal["dropout"]
    joint: PositiveInt
    t_start: NonNegativeFloat = 0.0
    probability: Probability


FaultSpec = Annotated[
    BiasFaultSpec | StuckFaultSpec | DropoutFaultSpec, Field(discriminator="kind")
]


class SensorSpec(_Strict):
    """What the controller measures: position noise, velocity estimate, faults."""

    noise: NoiseSpec | None = None
    velocity: VelocitySpec = TrueVelocitySpec(kind="true")
    faults: list[FaultSpec] = Field(default_factory=list)
    reasons: str | None = Field(
        default=None, description="Why this sensor (markdown, for the report)."
    )

    def build(self) -> Sensor:
        v = self.velocity
        velocity: VelocityEstimator
        if isinstance(v, FilteredVelocitySpec):
            velocity = DirtyDerivative(v.time_constant)
        elif isinstance(v, LevantVelocitySpec):
            velocity = LevantDifferentiator(v.lipschitz, v.lambda1, v.lambda0)
        elif isinstance(v, DifferenceVelocitySpec):
            velocity = BackwardDifference()
        else:
            velocity = TrueVelocity()
        faults = tuple(
            SensorFault(
                f.kind,
                f.joint,
                t_start=f.t_start,
                value=getattr(f, "value", 0.0),
                probability=getattr(f, "probability", 1.0),
            )
            for f in self.faults
        )
        noise = None if self.noise is None else GaussianNoise(_tuple(self.noise.sigma))
        return Sensor(noise=noise, velocity=velocity, faults=faults)


# --------------------------------------------------------------------------------------------
# disturbances


class ConstantDisturbanceSpec(_Strict):
    """A constant torque (N m) from t_start on."""

    kind: Literal["constant"]
    value: RealPerJoint
    t_start: NonNegativeFloat = 0.0


class SinusoidalDisturbanceSpec(_Strict):
    """amplitude sin(2π frequency t + phase) (N m)."""

    kind: Literal["sinusoidal"]
    amplitude: RealPerJoint
    frequency: NonNegativeFloat = Field(default=1.0, description="Hz.")
    phase: FiniteFloat = 0.0


class RandomDisturbanceSpec(_Strict):
    """Gaussian torque drawn once per sample (N m)."""

    kind: Literal["random"]
    sigma: NonNegativePerJoint


DisturbanceSpec = Annotated[
    ConstantDisturbanceSpec | SinusoidalDisturbanceSpec | RandomDisturbanceSpec,
    Field(discriminator="kind"),
]


def _build_disturbance(d: Any) -> Disturbance:
    if isinstance(d, ConstantDisturbanceSpec):
        return ConstantTorque(_tuple(d.value), t_start=d.t_start)
    if isinstance(d, SinusoidalDisturbanceSpec):
        return SinusoidalTorque(_tuple(d.amplitude), frequency=d.frequency, phase=d.phase)
    return RandomTorque(_tuple(d.sigma))


# --------------------------------------------------------------------------------------------
# gains and controllers


class _GainFields(_Strict):
    """Gains a controller may take; the shared ones and each controller's overrides."""

    alpha: PositivePerJoint | None = Field(
        default=None,
        description="Linear surface gain: FTSMC's alpha = PDSMC's lambda (give alpha or lam).",
    )
    lam: PositivePerJoint | None = Field(default=None, description="Synonym of alpha.")
    beta: PositivePerJoint | None = Field(
        default=None, description="Terminal surface gain of TSMC and FTSMC (and NTSMC's beta)."
    )
    gamma: Real | None = Field(
        default=None,
        description="Terminal exponent in (0, 1) (give gamma or p and q); for NTSMC p/q in (1, 2).",
    )
    p: OddInt | None = Field(default=None, description="Odd integer; gamma = q/p (NTSMC: p/q).")
    q: OddInt | None = Field(default=None, description="Odd integer q < p.")
    k: PositivePerJoint | None = Field(
        default=None, description="Reaching gain K = diag(k) (rad/s²)."
    )
    width: PositivePerJoint | None = Field(
        default=None, description="Boundary layer of tanh/sat (rad/s); ignored with sign."
    )
    k2: PositivePerJoint | None = Field(
        default=None, description="Integral gain of the super-twisting reaching law."
    )
    eps_e: PositiveFloat | None = Field(
        default=None, description="Singularity guard: |e|^(gamma-1) evaluated at max(|e|, eps_e)."
    )

    @field_validator("gamma")
    @classmethod
    def _gamma_range(cls, v: float | None, info: ValidationInfo) -> float | None:
        if v is None:
            return v
        if not math.isfinite(v):
            raise ValueError(f"must be finite, got {v!r}")
        name = info.data.get("name")
        if name == "ntsmc":
            if not 1.0 < v < 2.0:
                raise ValueError(
                    f"must lie in (1, 2) for ntsmc (nonsingular: 1 < p/q < 2), got {v:.5g}"
                )
        elif info.data.get("allow_nonterminal", False):
            if v <= 0:
                raise ValueError(f"must be > 0, got {v:.5g}")
        elif not 0.0 < v < 1.0:
            hint = (
                "; the paper's p/q > 1 is not terminal (set allow_nonterminal = true on a tsmc "
                "or ftsmc controller to measure it)"
                if v >= 1.0
                else ""
            )
            raise ValueError(
                f"must lie in (0, 1) (terminal: gamma = q/p with odd q < p), got {v:.5g}{hint}"
            )
        return v

    @field_validator("p", "q")
    @classmethod
    def _odd(cls, v: int | None, info: ValidationInfo) -> int | None:
        if v is None:
            return v
        if v <= 0 or v % 2 == 0:
            raise ValueError(f"must be a positive odd integer, got {v!r}")
        if info.field_name == "q":
            p = info.data.get("p")
            if p is not None and not v < p and not info.data.get("allow_nonterminal", False):
                raise ValueError(
                    f"must be < p (gamma = q/p < 1 is terminal; p/q for ntsmc), got q = {v} with p = {p}"
                )
        return v

    @model_validator(mode="after")
    def _exclusive(self) -> _GainFields:
        if self.alpha is not None and self.lam is not None:
            raise ValueError(
                "alpha and lam are the same gain (the linear term of PDSMC and FTSMC); give one"
            )
        if self.gamma is not None and (self.p is not None or self.q is not None):
            raise ValueError("give the exponent once: gamma or p and q, not both")
        if (self.p is None) != (self.q is None):
            raise ValueError("give both p and q (gamma = q/p), or gamma")
        return self

    @property
    def linear(self) -> float | list[float] | None:
        """alpha (= lam), whichever was given."""
        return self.alpha if self.alpha is not None else self.lam

    def exponent(self) -> dict[str, Any]:
        """``{"gamma": g}`` or ``{"p": p, "q": q}`` or ``{}``."""
        if self.gamma is not None:
            return {"gamma": self.gamma}
        if self.p is not None:
            return {"p": self.p, "q": self.q}
        return {}


class GainsSpec(_GainFields):
    """Gains shared by every controller wherever a gain means the same thing (stated once)."""

    reasons: str | None = Field(
        default=None, description="Why these gains (markdown, for the report)."
    )


class _ControllerHead(_Strict):
    """What a controller is (declared before its gains, whose validators read these)."""

    name: Literal["pdsmc", "tsmc", "ftsmc", "ntsmc"] = Field(description="Controller type.")
    label: str | None = Field(
        default=None,
        pattern=_NAME_PATTERN,
        description="Unique name of this controller's results (default: name).",
    )
    law: Literal["model", "paper"] = Field(
        default="model",
        description="model: the correct law; paper: the paper's eqs. 19-22 (erratum).",
    )
    reaching: Literal["classic", "super-twisting"] = "classic"
    switching: Switching | None = Field(
        default=None, description="Overrides the scenario's switching."
    )
    allow_nonterminal: StrictBool = Field(
        default=False,
        description="Admit gamma > 1 (the paper's p/q) to measure that erratum (tsmc, ftsmc).",
    )


class ControllerSpec(_GainFields, _ControllerHead):
    """One controller to compare; its gain keys override the shared ``[gains]``."""

    @property
    def key(self) -> str:
        """The label, or the name."""
        return self.label or self.name


# --------------------------------------------------------------------------------------------
# the scenario


@dataclass(frozen=True)
class Setup:
    """A built scenario: library objects ready for :func:`slidingarm.simulate`.

    ``controllers`` maps each controller's label to the controller, in the file's order.
    """

    name: str
    description: str
    nominal: PlanarArm
    plant: PlanarArm
    reference: Reference
    controllers: dict[str, SlidingModeController]
    q0: tuple[float, ...]
    qd0: tuple[float, ...] | None
    t_final: float
    dt: float
    substeps: int
    sensor: Sensor
    disturbances: tuple[Disturbance, ...]
    torque_limit: float | tuple[float, ...] | None
    seed: int

    def options(self) -> dict[str, Any]:
        """Keyword arguments of :func:`slidingarm.simulate` other than the plant, controller and
        reference."""
        return {
            "q0": self.q0,
            "qd0": self.qd0,
            "t_final": self.t_final,
            "dt": self.dt,
            "substeps": self.substeps,
            "sensor": self.sensor,
            "disturbances": self.disturbances,
            "torque_limit": self.torque_limit,
            "seed": self.seed,
        }


class Scenario(_Strict):
    """One comparison of controllers on one arm, reference, sensor and disturbance set."""

    extends: str | None = Field(
        default=None,
        description="Base scenario file (relative to this one), merged under this file: tables "
        "merge key by key, values and arrays of tables replace.",
    )
    name: str | None = Field(
        default=None, pattern=_NAME_PATTERN, description="Scenario name (default: the file's stem)."
    )
    description: str = ""
    switching: Switching = Field(description="Switching function shared by the controllers.")
    plant: PlantSpec
    mismatch: MismatchSpec = MismatchSpec()
    reference: ReferenceSpec
    simulation: SimulationSpec
    sensor: SensorSpec = SensorSpec()
    disturbances: list[DisturbanceSpec] = Field(default_factory=list)
    gains: GainsSpec = GainsSpec()
    controllers: list[ControllerSpec] = Field(min_length=1)

    _source: Path | None = PrivateAttr(default=None)
    _base_dir: Path | None = PrivateAttr(default=None)

    @property
    def source(self) -> Path | None:
        """The file this scenario was read from (``None`` when built from a mapping)."""
        return self._source

    @property
    def key(self) -> str:
        """The scenario's name (``name``, or the file's stem, or ``"scenario"``)."""
        if self.name:
            return self.name
        return self._source.stem if self._source is not None else "scenario"

    # ---------------------------------------------------------------- checks and build
    def _fail(self, path: str, reason: str) -> ConfigError:
        return ConfigError(reason, file=self._source, path=path)

    def controller_gains(self, index: int) -> dict[str, Any]:
        """Keyword arguments of controller ``index``'s class (without the model).

        Shared gains fill what the controller does not override; a gain the controller does
        not use is not passed (``width`` with sign switching, ``k2`` with classic reaching).
        """
        spec = self.controllers[index]
        here = f"controllers[{index}]"
        shared = self.gains
        switching = spec.switching or self.switching
        uses = _SURFACE_GAINS[spec.name]
        # overrides of gains this controller does not have
        meaning = {
            "alpha": "linear",
            "lam": "linear",
            "beta": "beta",
            "gamma": "exponent",
            "p": "exponent",
            "q": "exponent",
        }
        for key, what in meaning.items():
            if getattr(spec, key) is not None and what not in uses:
                raise self._fail(
                    f"{here}.{key}",
                    f"{spec.name} has no gain {key}; its gains are {_gain_names(spec.name)}",
                )
        if spec.allow_nonterminal and spec.name not in ("tsmc", "ftsmc"):
            raise self._fail(f"{here}.allow_nonterminal", "applies to tsmc and ftsmc only")
        if spec.width is not None and switching == "sign":
            raise self._fail(
                f"{here}.width",
                "the boundary layer applies to tanh and sat only, not sign switching",
            )
        if spec.k2 is not None and spec.reaching != "super-twisting":
            raise self._fail(f"{here}.k2", "applies to reaching = 'super-twisting' only")

        def pick(key: str, required: bool) -> Any:
            value = getattr(spec, key)
            if value is None:
                value = getattr(shared, key)
            if value is None and required:
                raise self._fail(
                    f"gains.{key}",
                    f"missing: {spec.name} ({here}) needs {key}; set "
                    "it in [gains] (shared) or on the controller",
                )
            return value

        kwargs: dict[str, Any] = {
            "switching": switching,
            "law": spec.law,
            "reaching": spec.reaching,
        }
        kwargs["k"] = pick("k", True)
        if switching != "sign":
            width = pick("width", False)
            if width is not None:
                kwargs["width"] = width
        if spec.reaching == "super-twisting":
            kwargs["k2"] = pick("k2", True)
        if "linear" in uses:
            linear = spec.linear if spec.linear is not None else shared.linear
            if linear is None:
                raise self._fail(
                    "gains.alpha",
                    f"missing: {spec.name} ({here}) needs alpha (= lam), "
                    "the linear surface gain; set it in [gains] or on the controller",
                )
            kwargs["lam" if spec.name == "pdsmc" else "alpha"] = linear
        if "beta" in uses:
            kwargs["beta"] = pick("beta", True)
        if "exponent" in uses:
            exp = spec.exponent() or shared.exponent()
            if not exp:
                raise self._fail(
                    "gains.gamma",
                    f"missing: {spec.name} ({here}) needs gamma (or p "
                    "and q); set it in [gains] or on the controller",
                )
            if spec.name == "ntsmc" and not spec.exponent() and "gamma" in exp:
                # shared gamma = q/p; the nonsingular surface's exponent is p/q = 1/gamma
                exp = {"gamma": 1.0 / exp["gamma"]}
            kwargs.update(exp)
            if spec.name in ("tsmc", "ftsmc"):
                kwargs["allow_nonterminal"] = spec.allow_nonterminal
                eps = pick("eps_e", False)
                if eps is not None:
                    kwargs["eps_e"] = eps
        elif spec.eps_e is not None:
            raise self._fail(f"{here}.eps_e", f"{spec.name} has no singular term to guard")
        return {k: _tuple(v) if isinstance(v, list) else v for k, v in kwargs.items()}

    def _check_lengths(self, n: int) -> None:
        """Every per-joint value has 1 or ``n`` entries; joint numbers exist."""
        items: list[tuple[str, Any]] = [
            ("simulation.q0", self.simulation.q0),
            ("simulation.qd0", self.simulation.qd0),
            ("simulation.torque_limit", self.simulation.torque_limit),
            ("mismatch.mass_error", self.mismatch.mass_error),
            ("mismatch.length_error", self.mismatch.length_error),
        ]
        if self.sensor.noise is not None:
            items.append(("sensor.noise.sigma", self.sensor.noise.sigma))
        for i, d in enumerate(self.disturbances):
            for key in ("value", "amplitude", "sigma"):
                if hasattr(d, key):
                    items.append((f"disturbances[{i}].{key}", getattr(d, key)))
        gain_keys = ("alpha", "lam", "beta", "k", "width", "k2")
        items += [(f"gains.{key}", getattr(self.gains, key)) for key in gain_keys]
        for i, c in enumerate(self.controllers):
            items += [(f"controllers[{i}].{key}", getattr(c, key)) for key in gain_keys]
        exact = {"simulation.q0", "simulation.qd0"}
        for path, value in items:
            if isinstance(value, list):
                if len(value) != n and (path in exact or len(value) != 1):
                    allowed = f"{n} values" if path in exact else f"a scalar or {n} values"
                    raise self._fail(
                        path, f"has {len(value)} values but the arm has {n} joints (give {allowed})"
                    )
        for i, f in enumerate(self.sensor.faults):
            if f.joint > n:
                raise self._fail(
                    f"sensor.faults[{i}].joint",
                    f"joint {f.joint} does not exist on a {n}-joint arm (1..{n})",
                )

    def check(self) -> None:
        """Cross-field checks pydantic cannot do alone (joint counts, time grid, gains).

        Raises
        ------
        ConfigError
        """
        self.build()

    def build(self) -> Setup:
        """Build the library objects.

        Raises
        ------
        ConfigError
            For anything the file's keys do not fit together on (joint counts, time grid,
            missing gains, table files), with the key path.
        """
        labels = [c.key for c in self.controllers]
        for i, label in enumerate(labels):
            if label in labels[:i]:
                raise self._fail(
                    f"controllers[{i}].label",
                    f"duplicate controller {label!r}; "
                    "give each controller of the same type a distinct label",
                )
        nominal = self._guard("plant", self.plant.build)
        n = nominal.n
        self._check_lengths(n)
        plant = self._guard("mismatch", lambda: self.mismatch.build().apply(nominal))
        base = self._base_dir
        ref_path = getattr(self.reference, "path", None)
        if ref_path is not None:
            full = Path(ref_path) if base is None else Path(base) / ref_path
            if not full.is_file():
                raise self._fail("reference.path", f"table file not found: {full}")
        reference = self._guard(
            "reference",
            lambda: reference_from_dict(
                self.reference.model_dump(exclude_none=True), base_dir=base
            ),
        )
        if reference.n != n:
            raise self._fail("reference", f"describes {reference.n} joints but the arm has {n}")
        sim = self.simulation
        self._guard("simulation.t_final", lambda: time_grid(sim.t_final, sim.dt))
        sensor = self._guard("sensor", self.sensor.build)
        disturbances = tuple(
            self._guard(f"disturbances[{i}]", partial(_build_disturbance, d))
            for i, d in enumerate(self.disturbances)
        )
        controllers: dict[str, SlidingModeController] = {}
        for i, spec in enumerate(self.controllers):
            kwargs = self.controller_gains(i)
            cls = _CONTROLLER_CLASSES[spec.name]
            controllers[spec.key] = self._guard(
                f"controllers[{i}]", partial(cls, nominal, **kwargs)
            )
        return Setup(
            name=self.key,
            description=self.description,
            nominal=nominal,
            plant=plant,
            reference=reference,
            controllers=controllers,
            q0=tuple(sim.q0),
            qd0=None if sim.qd0 is None else tuple(sim.qd0),
            t_final=sim.t_final,
            dt=sim.dt,
            substeps=sim.substeps,
            sensor=sensor,
            disturbances=disturbances,
            torque_limit=_tuple(sim.torque_limit) if sim.torque_limit is not None else None,
            seed=sim.seed,
        )

    def _guard(self, path: str, make: Callable[[], Any]) -> Any:
        try:
            return make()
        except ConfigError:
            raise
        except (ValueError, OSError) as exc:
            raise self._fail(path, str(exc)) from exc

    # ---------------------------------------------------------------- export
    def to_dict(self) -> dict[str, Any]:
        """The scenario as plain data (no ``extends``; a table ``path`` made absolute), such that
        ``scenario_from_dict(s.to_dict())`` is the same scenario."""
        d = self.model_dump(mode="json", exclude_none=True, exclude={"extends"})
        d["name"] = self.key
        ref = d.get("reference", {})
        if ref.get("kind") == "table" and "path" in ref and self._base_dir is not None:
            ref["path"] = str((self._base_dir / ref["path"]).resolve())
        return d

    def to_toml(self) -> str:
        """The resolved scenario as TOML text, self-contained (see :meth:`to_dict`)."""
        import tomli_w

        return tomli_w.dumps(self.to_dict(), multiline_strings=True)


def _gain_names(name: str) -> str:
    names = {"linear": "alpha (= lam)", "beta": "beta", "exponent": "gamma (or p, q)"}
    return ", ".join([names[g] for g in _SURFACE_GAINS[name]] + ["k", "width", "k2"])


def _tuple(v: Any) -> Any:
    return tuple(v) if isinstance(v, list) else v


# --------------------------------------------------------------------------------------------
# loading


_TOML_LINE = re.compile(r"\(at line (\d+), column (\d+)\)")


def _read_toml(path: Path) -> dict[str, Any]:
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ConfigError("no such file", file=path) from None
    except IsADirectoryError:
        raise ConfigError("is a directory, not a scenario file", file=path) from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(f"cannot read: {exc}", file=path) from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        msg = str(exc)
        m = _TOML_LINE.search(msg)
        if m is None:
            raise ConfigError(f"invalid TOML: {msg}", file=path) from None
        reason = msg[: m.start()].strip().rstrip(".")
        raise ConfigError(
            f"invalid TOML: {reason} (column {m.group(2)})", file=f"{path}:{m.group(1)}"
        ) from None


def _merge(
    base: dict[str, Any],
    over: Mapping[str, Any],
    origin: dict[tuple[Any, ...], str],
    over_file: str,
    prefix: tuple[Any, ...] = (),
) -> dict[str, Any]:
    """Deep-merge ``over`` onto ``base``: tables merge key by key, except a table that names its
    kind (:func:`_names_kind`), which replaces; values and arrays replace. ``origin`` records
    which file each key path came from."""
    out = dict(base)
    for key, value in over.items():
        path = (*prefix, key)
        if isinstance(value, dict) and isinstance(out.get(key), dict) and not _names_kind(value):
            out[key] = _merge(out[key], value, origin, over_file, path)
        else:
            out[key] = value
            for p in [p for p in origin if p[: len(path)] == path]:
                del origin[p]
            origin[path] = over_file
    return out


def _names_kind(table: Mapping[str, Any]) -> bool:
    """Whether a table says what it is (``kind``; a plant's ``preset`` or ``masses``): such a
    table replaces the base's instead of merging into it."""
    return any(k in table for k in ("kind", "preset", "masses"))


def _resolve(
    path: Path, seen: tuple[Path, ...] = ()
) -> tuple[dict[str, Any], dict[tuple[Any, ...], str]]:
    """Read ``path`` and the chain of files it extends; return the merged data and, for each key
    path, the file that set it."""
    real = path.resolve()
    if real in seen:
        chain = " -> ".join(p.name for p in (*seen, real))
        raise ConfigError(f"extends forms a cycle: {chain}", file=path, path="extends")
    data = _read_toml(path)
    origin: dict[tuple[Any, ...], str] = {}
    base_name = data.pop("extends", None)
    if base_name is None:
        for key in data:
            origin[(key,)] = str(path)
        return data, origin
    if not isinstance(base_name, str):
        raise ConfigError(
            f"must be a file name (a string), got {base_name!r}", file=path, path="extends"
        )
    base_path = Path(base_name)
    if not base_path.is_absolute():
        base_path = path.parent / base_path
    if not base_path.is_file():
        raise ConfigError(
            f"base file {base_name!r} not found (looked for {base_path})", file=path, path="extends"
        )
    base, origin = _resolve(base_path, (*seen, real))
    return _merge(base, data, origin, str(path)), origin


def load_scenario(path: str | Path) -> Scenario:
    """Read, merge (``extends``), validate and check a scenario file.

    Raises
    ------
    ConfigError
        One line: the file (and line for TOML syntax), the key path and what is allowed.
    """
    p = Path(path)
    data, origin = _resolve(p)
    return _validate(data, source=p, origin=origin)


def scenario_from_dict(
    data: Mapping[str, Any], *, source: str | Path | None = None, base_dir: str | Path | None = None
) -> Scenario:
    """Validate and check a scenario given as a mapping (as a TOML file would parse).

    ``extends`` is not resolved here; ``base_dir`` anchors a relative table ``path``
    (default: the directory of ``source``, else the current directory).
    """
    d = dict(data)
    if d.get("extends") is not None:
        raise ConfigError(
            "extends is resolved when reading files; load with load_scenario",
            file=source,
            path="extends",
        )
    src = None if source is None else Path(source)
    return _validate(d, source=src, origin={}, base_dir=base_dir)


def _validate(
    data: Mapping[str, Any],
    *,
    source: Path | None,
    origin: Mapping[tuple[Any, ...], str],
    base_dir: str | Path | None = None,
) -> Scenario:
    try:
        scenario = Scenario.model_validate(data)
    except ValidationError as exc:
        raise _from_pydantic(exc, source, origin) from None
    scenario._source = source
    if base_dir is not None:
        scenario._base_dir = Path(base_dir)
    elif source is not None:
        scenario._base_dir = source.parent
    scenario.check()
    return scenario


# --------------------------------------------------------------------------------------------
# pydantic errors -> one line


def _unwrap(tp: Any) -> Any:
    while get_origin(tp) is Annotated:
        tp = get_args(tp)[0]
    return tp


def _union_members(tp: Any) -> list[Any]:
    tp = _unwrap(tp)
    if get_origin(tp) in (Union, types.UnionType):
        return [_unwrap(a) for a in get_args(tp)]
    return [tp]


def _is_model(tp: Any) -> bool:
    return isinstance(tp, type) and issubclass(tp, BaseModel)


def _tag(model: type[BaseModel]) -> str | None:
    field = model.model_fields.get("kind")
    if field is None:
        return None
    args = get_args(field.annotation)
    return str(args[0]) if args else None


def _locate(loc: Sequence[Any]) -> tuple[str, type[BaseModel] | None, type[BaseModel] | None]:
    """Pretty key path of a pydantic ``loc`` (tags of tagged unions dropped), the model that
    holds its last key, and the model the path itself points at (if any)."""
    tp: Any = Scenario
    parts: list[str] = []
    holder: type[BaseModel] | None = None
    for item in loc:
        members = [m for m in _union_members(tp) if m is not type(None)]
        models = [m for m in members if _is_model(m)]
        if isinstance(item, int):
            seq = [m for m in members if get_origin(m) in (list, tuple)]
            parts.append(f"[{item}]")
            tp = get_args(seq[0])[0] if seq else None
            continue
        if len(models) > 1:
            match = [m for m in models if _tag(m) == item]
            if match:
                tp = match[0]
                continue
        if len(models) == 1:
            holder = models[0]
            field = holder.model_fields.get(str(item))
            parts.append(("." if parts else "") + str(item))
            tp = field.annotation if field is not None else None
            continue
        # union member names ("float", "list[...]") and the like add nothing
        if tp is None:
            parts.append(("." if parts else "") + str(item))
    models = [m for m in _union_members(tp) if _is_model(m)]
    return "".join(parts), holder, models[0] if len(models) == 1 else None


def _literal_values(tp: Any) -> list[Any]:
    values: list[Any] = []
    for member in _union_members(tp):
        if get_origin(member) is Literal:
            values += list(get_args(member))
    return values


def _allowed_keys(model: type[BaseModel] | None) -> list[str]:
    return [] if model is None else list(model.model_fields)


def _from_pydantic(
    exc: ValidationError, source: Path | None, origin: Mapping[tuple[Any, ...], str]
) -> ConfigError:
    # an unknown key first: a misspelt key also makes the key it meant "missing"
    errors = sorted(exc.errors(include_url=False), key=lambda e: e["type"] != "extra_forbidden")
    err = errors[0]
    loc = tuple(err["loc"])
    etype = err["type"]
    path, holder, _ = _locate(loc)
    value = err.get("input")
    msg = str(err["msg"])
    if etype == "extra_forbidden":
        _, _, parent = _locate(loc[:-1])
        allowed = _allowed_keys(parent)
        key = str(loc[-1])
        near = difflib.get_close_matches(key, allowed, n=1)
        hint = f" (did you mean {near[0]!r}?)" if near else ""
        reason = f"unknown key {key!r}{hint}; allowed keys: {', '.join(allowed)}"
    elif etype == "missing":
        reason = "missing required key"
        field = holder.model_fields.get(str(loc[-1])) if holder is not None else None
        if field is not None:
            choices = _literal_values(field.annotation)
            if choices:
                reason += f"; one of {', '.join(repr(c) for c in choices)}"
            elif field.description:
                reason += f" ({field.description.rstrip('.')})"
    elif etype in ("union_tag_invalid", "union_tag_not_found"):
        ctx = err.get("ctx", {})
        tags = ctx.get("expected_tags", "")
        reason = f"kind must be one of {tags}" + (
            f", got {ctx.get('tag')!r}" if "tag" in ctx else ""
        )
        if etype == "union_tag_not_found":
            reason = f"needs a 'kind' key, one of {tags}"
    else:
        if msg.startswith("Value error, "):
            msg = msg[len("Value error, ") :]
        elif msg.startswith("Assertion failed, "):
            msg = msg[len("Assertion failed, ") :]
        else:
            msg = msg[0].lower() + msg[1:] if msg else msg
        shown = is_real(value) or isinstance(value, str | bool)
        reason = msg if ("got" in msg or not shown) else f"{msg}, got {value!r}"
    more = len(errors) - 1
    if more:
        reason += f" (and {more} more error{'s' if more > 1 else ''})"
    file: str | Path | None = source
    for n in range(len(loc), 0, -1):
        if loc[:n] in origin:
            file = origin[loc[:n]]
            break
    # a table both files contributed to is the extending file's responsibility
    if any(p[: len(loc)] == loc and f == str(source) for p, f in origin.items()):
        file = source
    if file is not None and source is not None and str(file) != str(source):
        reason += f" (set in {Path(file).name}, extended by {source.name})"
    return ConfigError(reason, file=file, path=path)


# --------------------------------------------------------------------------------------------
# what a scenario can name


def _tags(union: Any) -> list[str]:
    return [t for t in (_tag(m) for m in _union_members(union) if _is_model(m)) if t is not None]


def choices() -> dict[str, list[str]]:
    """What each choice of a scenario file may be, by section (for ``slidingarm list``)."""
    head = _ControllerHead.model_fields
    return {
        "switching laws (switching)": list(get_args(Switching)),
        "reaching laws (controllers[].reaching)": _literal_values(head["reaching"].annotation),
        "control laws (controllers[].law)": _literal_values(head["law"].annotation),
        "references (reference.kind)": _tags(ReferenceSpec),
        "velocity estimators (sensor.velocity.kind)": _tags(VelocitySpec),
        "sensor faults (sensor.faults[].kind)": _tags(FaultSpec),
        "disturbances (disturbances[].kind)": _tags(DisturbanceSpec),
        "model mismatch ([mismatch])": list(MismatchSpec.model_fields),
        "plant presets (plant.preset)": _literal_values(
            PlantSpec.model_fields["preset"].annotation
        ),
        "mass models (plant.mass_model)": _literal_values(
            PlantSpec.model_fields["mass_model"].annotation
        ),
    }
