"""The component specs of a scenario: plant, mismatch, reference, simulation, sensor,
disturbances, gains and controllers. Each spec that is a library object builds it
(``build()``)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any, Literal

from pydantic import (
    ConfigDict,
    Field,
    StrictBool,
    ValidationInfo,
    field_validator,
    model_validator,
)

from slidingarm import robots
from slidingarm.config.errors import ConfigError
from slidingarm.config.values import (
    _NAME_PATTERN,
    FiniteFloat,
    Guard,
    NonNegativeFloat,
    NonNegativeInt,
    NonNegativePerJoint,
    NonNegativeVector,
    OddInt,
    Position,
    PositionOffset,
    PositionSpread,
    PositiveFloat,
    PositiveInt,
    PositivePerJoint,
    PositiveVector,
    Probability,
    Real,
    RealPerJoint,
    RelativeError,
    SampleTime,
    Substeps,
    Switching,
    Vector,
    _Strict,
)
from slidingarm.control.controllers import CONTROLLERS as CONTROLLER_CLASSES
from slidingarm.control.controllers import SlidingModeController
from slidingarm.disturbances import (
    ConstantTorque,
    Disturbance,
    ModelMismatch,
    RandomTorque,
    SinusoidalTorque,
)
from slidingarm.models.planar import PlanarArm
from slidingarm.models.serial import SerialArm
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

if TYPE_CHECKING:
    ControllerName = str
else:
    #: The names a scenario's controller may have: those of the controller classes.
    ControllerName = Literal[tuple(CONTROLLER_CLASSES)]

#: One line per controller a scenario can name (from the controller classes).
CONTROLLERS: dict[str, str] = {name: cls.DESCRIPTION for name, cls in CONTROLLER_CLASSES.items()}

_CONTROLLER_CLASSES: dict[str, type[SlidingModeController]] = CONTROLLER_CLASSES

#: Which surface gains each controller takes ("linear" is alpha = lam, "exponent" gamma or p/q).
_SURFACE_GAINS: dict[str, tuple[str, ...]] = {
    name: cls.SURFACE_GAINS for name, cls in CONTROLLER_CLASSES.items()
}


# --------------------------------------------------------------------------------------------
# plant, mismatch, reference, simulation


#: The keys of ``[plant]`` that describe a planar arm, and those that name a serial arm's
#: description; the two sets exclude each other (``tool`` and ``gravity`` go with either source
#: of a serial arm, ``gravity`` with a planar arm too).
PLANAR_KEYS: tuple[str, ...] = ("preset", "mass_model", "masses", "lengths", "com", "inertia")
SERIAL_KEYS: tuple[str, ...] = ("robot", "urdf")


class PlantSpec(_Strict):
    """The controller's nominal arm (SI units): a planar arm (the paper's preset or explicit
    link parameters) or a serial arm (a shipped robot or a URDF file)."""

    preset: Literal["paper"] | None = Field(
        default=None, description="'paper': m = (1, 1, 1) kg, l = (0.5, 1, 1) m (docs/theory.md §2)."
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
    robot: str | None = Field(
        default=None,
        description="A shipped robot (slidingarm.robots.names()), a serial arm; excludes the "
        "planar keys.",
    )
    urdf: str | None = Field(
        default=None,
        description="A URDF file of a serial arm, relative to the folder of the scenario file "
        "that sets it (or absolute); excludes the planar keys.",
    )
    tool: str | None = Field(
        default=None,
        description="Tool link of a robot or URDF (default: a robot's flange or TCP, a URDF's "
        "deepest link).",
    )
    gravity: NonNegativeFloat = Field(
        default=9.81,
        description="g (m/s²): along -y for a planar arm, along -z of the root link for a robot "
        "or URDF.",
    )

    @field_validator("robot")
    @classmethod
    def _shipped(cls, v: str | None) -> str | None:
        if v is not None and v not in robots.names():
            raise ValueError(
                f"must be a shipped robot, one of {', '.join(robots.names())}; got {v!r}"
            )
        return v

    @model_validator(mode="after")
    def _one_source(self) -> PlantSpec:
        serial = [k for k in SERIAL_KEYS if getattr(self, k) is not None]
        if len(serial) > 1:
            raise ValueError("give either robot (a shipped robot) or urdf (a URDF file), not both")
        if serial:
            planar = [k for k in PLANAR_KEYS if k in self.model_fields_set]
            if planar:
                raise ValueError(
                    f"{serial[0]} describes a serial arm, so the planar keys "
                    f"{', '.join(planar)} do not apply; remove them (got {serial[0]} and "
                    f"{', '.join(planar)})"
                )
            return self
        if self.tool is not None:
            raise ValueError(
                "tool names a link of a robot or URDF; a planar arm's tool is its tip "
                "(give robot or urdf, or remove tool)"
            )
        explicit = [
            k for k in ("masses", "lengths", "com", "inertia") if getattr(self, k) is not None
        ]
        if self.preset is not None and explicit:
            raise ValueError(
                f"give either preset = 'paper' or explicit masses and lengths, not both "
                f"(got preset and {', '.join(explicit)})"
            )
        if self.preset is None and (self.masses is None or self.lengths is None):
            raise ValueError(
                "needs preset = 'paper' or both masses and lengths (a planar arm), or robot "
                f"(one of {', '.join(robots.names())}) or urdf (a serial arm)"
            )
        return self

    @property
    def serial(self) -> bool:
        """Whether this is a serial arm (``robot`` or ``urdf``)."""
        return self.robot is not None or self.urdf is not None

    def urdf_path(self, base_dir: str | Path | None = None) -> Path | None:
        """The URDF file, a relative ``urdf`` anchored at ``base_dir`` (default: the current
        directory); ``None`` without ``urdf``."""
        if self.urdf is None:
            return None
        path = Path(self.urdf).expanduser()
        if base_dir is not None and not path.is_absolute():
            path = Path(base_dir) / path
        return path

    def build(self, base_dir: str | Path | None = None) -> PlanarArm | SerialArm:
        """The nominal arm.

        Parameters
        ----------
        base_dir : path, optional
            The folder a relative ``urdf`` is read from.

        Raises
        ------
        ConfigError
            Naming ``plant.robot``, ``plant.urdf`` or ``plant.tool`` when a serial arm cannot
            be built (its file is missing, unreadable or refused by
            :meth:`~slidingarm.SerialArm.from_urdf`, or its tool is not one of its links).
        ValueError
            When the planar arm's parameters are refused.
        """
        if self.serial:
            return self._build_serial(base_dir)
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

    def _build_serial(self, base_dir: str | Path | None) -> SerialArm:
        key = "plant.robot" if self.robot is not None else "plant.urdf"
        try:
            if self.robot is not None:
                arm = robots.load(self.robot, gravity=self.gravity)
            else:
                path = self.urdf_path(base_dir)
                assert path is not None
                arm = SerialArm.from_urdf(path, gravity=self.gravity)
        except (ValueError, OSError) as exc:
            raise ConfigError(str(exc), path=key) from None
        if self.tool is None:
            return arm
        try:
            return arm.replace(tool=self.tool)
        except ValueError as exc:
            raise ConfigError(str(exc), path="plant.tool") from None


class MismatchSpec(_Strict):
    """How the simulated plant differs from the nominal arm the controllers use."""

    payload: NonNegativeFloat = Field(default=0.0, description="Point mass at the tool (kg).")
    mass_error: RelativeError = Field(default=0.0, description="Relative mass error, > -1.")
    length_error: RelativeError = Field(default=0.0, description="Relative length error, > -1.")
    payload_link: str | None = Field(
        default=None,
        description="The link whose origin carries the payload (a robot or URDF only; default: "
        "the tool).",
    )

    def build(self) -> ModelMismatch:
        return ModelMismatch(
            payload=self.payload,
            mass_error=_tuple(self.mass_error),
            length_error=_tuple(self.length_error),
            payload_link=self.payload_link,
        )


class PaperReferenceSpec(_Strict):
    """The paper's reference q_d(t) (docs/theory.md §2)."""

    kind: Literal["paper"]


class QuinticReferenceSpec(_Strict):
    """A quintic point-to-point move."""

    kind: Literal["quintic"]
    q_start: Position = Field(description="Start (rad), within ±1e3.")
    q_end: Position = Field(description="End (rad), within ±1e3.")
    duration: PositiveFloat = Field(
        description="Duration of the move (s), at least simulation.dt: a shorter move falls "
        "between two samples and its acceleration ~ 1/duration² overflows."
    )
    t_start: NonNegativeFloat = 0.0


class SineReferenceSpec(_Strict):
    """q_d = offset + amplitude sin(2π frequency t + phase), per joint."""

    kind: Literal["sine"]
    offset: Position = Field(description="Offset (rad), within ±1e3.")
    amplitude: RealPerJoint
    frequency: NonNegativePerJoint = Field(
        description="Hz, below the Nyquist rate 1/(2 simulation.dt) of the grid: a faster sine "
        "aliases to another on the samples."
    )
    phase: RealPerJoint = 0.0


class TableReferenceSpec(_Strict):
    """A spline through a table: inline t and q, or a CSV file (path relative to the scenario)."""

    kind: Literal["table"]
    t: Vector | None = None
    q: list[Vector] | None = None
    path: str | None = None
    spline: Literal["quintic", "cubic"] = "quintic"
    ends: Literal["not-a-knot", "rest"] | None = Field(
        default=None,
        description="not-a-knot (default) or rest: zero velocity (and, for the quintic, "
        "acceleration) at both ends.",
    )

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

    t_final: PositiveFloat = Field(
        description="Duration (s), a whole number of dt; its traces (t_final/dt samples of "
        "every controller) must fit in the memory available."
    )
    dt: SampleTime = Field(
        description="Sample time of the digital controller (s), at least 1e-9 s (a 1 GHz loop)."
    )
    substeps: Substeps = Field(
        default=1, description="RK4 steps per sample interval, 1 to 1000000."
    )
    q0: Position = Field(
        description="Initial joint angles (rad, or m), within ±1e3 (159 turns, a kilometre)."
    )
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

    sigma: PositionSpread = Field(
        description="Standard deviation (rad), scalar or per joint, in [0, 1e3]."
    )


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
    value: PositionOffset = Field(description="Offset (rad, or m), within ±1e3.")


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
    frequency: NonNegativeFloat = Field(
        default=1.0, description="Hz, below the Nyquist rate 1/(2 simulation.dt) of the grid."
    )
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
    eps_e: Guard | None = Field(
        default=None,
        description="Singularity guard: |e|^(gamma-1) evaluated at max(|e|, eps_e) (rad), at "
        "least 1e-300 so that eps_e^(gamma-1) <= 1/eps_e stays a float.",
    )

    @field_validator("gamma")
    @classmethod
    def _gamma_range(cls, v: float | None, info: ValidationInfo) -> float | None:
        if v is None:
            return v
        if not math.isfinite(v):
            raise ValueError(f"must be finite, got {v!r}")
        name = info.data.get("name")
        klass = CONTROLLER_CLASSES.get(name) if isinstance(name, str) else None
        low, high = (0.0, 1.0) if klass is None else klass.EXPONENT_RANGE
        if low >= 1.0:
            if not low < v < high:
                raise ValueError(
                    f"must lie in ({low:g}, {high:g}) for {name} (nonsingular: {low:g} < p/q < "
                    f"{high:g}), got {v:.5g}"
                )
        elif info.data.get("allow_nonterminal", False):
            if v <= 0:
                raise ValueError(f"must be > 0, got {v:.5g}")
        elif not 0.0 < v < 1.0:
            terminal = " or ".join(n for n, c in CONTROLLER_CLASSES.items() if c.TERMINAL)
            hint = (
                "; the paper's p/q > 1 is not terminal (set allow_nonterminal = true on a "
                f"{terminal} controller to measure it)"
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
        # positive and odd: OddInt
        if v is None:
            return v
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

    name: ControllerName = Field(description="Controller type.")
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
# sweep


class SweepSpec(_Strict):
    """A Monte Carlo sweep over this scenario (``slidingarm sweep``); every other verb ignores
    it. Each key other than ``runs``, ``seed`` and ``chunk`` is a dotted path of the scenario
    with its distribution: ``"gains.k" = { uniform = [10, 40] }``,
    ``"simulation.q0" = { normal = [0, 0.05], offset = true }``
    (:class:`slidingarm.sweep.Distribution`)."""

    model_config = ConfigDict(extra="allow", frozen=True)

    runs: PositiveInt | None = Field(default=None, description="Number of draws (runs).")
    seed: NonNegativeInt | None = Field(
        default=None, description="Seed of the draws (default: simulation.seed)."
    )
    chunk: PositiveInt | None = Field(
        default=None, description="Runs per chunk (one Parquet shard each)."
    )

    @model_validator(mode="after")
    def _distributions(self) -> SweepSpec:
        from slidingarm.sweep.space import Distribution, parse_key

        for key, spec in (self.model_extra or {}).items():
            try:
                parse_key(key)
                Distribution.from_spec(key, spec)
            except ConfigError as exc:
                where = f'"{key}"' if exc.path == key else exc.path.removeprefix("sweep.")
                raise ValueError(f"{where}: {exc.reason}") from None
        return self

    def distributions(self) -> dict[str, Any]:
        """The distributions by dotted key, in the file's order."""
        from slidingarm.sweep.space import Distribution

        return {k: Distribution.from_spec(k, v) for k, v in (self.model_extra or {}).items()}


def _gain_names(name: str) -> str:
    names = {"linear": "alpha (= lam)", "beta": "beta", "exponent": "gamma (or p, q)"}
    return ", ".join([names[g] for g in _SURFACE_GAINS[name]] + ["k", "width", "k2"])


def _tuple(v: Any) -> Any:
    return tuple(v) if isinstance(v, list) else v
