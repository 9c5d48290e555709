"""slidingarm: sliding-mode control of robot arms, simulated fast and checked against theory.

The public API is exactly what this module re-exports.
"""

from slidingarm import (
    robots,  # the shipped robots: sa.robots.load(...)
    sweep,  # Monte Carlo; the package is callable: sa.sweep(scenario, runs=..., out=...)
)
from slidingarm._version import __version__
from slidingarm.control import (
    FTSMC,
    NTSMC,
    PDSMC,
    TSMC,
    Controller,
    ControllerCheckError,
    CustomController,
    SlidingModeController,
    check_controller,
    ftsm_convergence_time,
    tsm_convergence_time,
)
from slidingarm.disturbances import ConstantTorque, ModelMismatch, RandomTorque, SinusoidalTorque
from slidingarm.models import (
    ArmModel,
    MujocoPlant,
    PlanarArm,
    SerialArm,
    SteppedArm,
    SteppedPlant,
)
from slidingarm.references import (
    PAPER_DT,
    PAPER_Q0,
    PAPER_QD0,
    PAPER_T_FINAL,
    CallableReference,
    PaperReference,
    QuinticReference,
    Reference,
    TableReference,
)
from slidingarm.results import BatchResult, SimResult
from slidingarm.sensors import (
    BackwardDifference,
    DirtyDerivative,
    GaussianNoise,
    LevantDifferentiator,
    Sensor,
    SensorFault,
    TrueVelocity,
)
from slidingarm.simulate import Every, SimulationError, simulate, simulate_batch

__all__ = [
    "FTSMC",
    "NTSMC",
    "PAPER_DT",
    "PAPER_Q0",
    "PAPER_QD0",
    "PAPER_T_FINAL",
    "PDSMC",
    "TSMC",
    "ArmModel",
    "BackwardDifference",
    "BatchResult",
    "CallableReference",
    "ConstantTorque",
    "Controller",
    "ControllerCheckError",
    "CustomController",
    "DirtyDerivative",
    "Every",
    "GaussianNoise",
    "LevantDifferentiator",
    "ModelMismatch",
    "MujocoPlant",
    "PaperReference",
    "PlanarArm",
    "QuinticReference",
    "RandomTorque",
    "Reference",
    "Sensor",
    "SensorFault",
    "SerialArm",
    "SimResult",
    "SimulationError",
    "SinusoidalTorque",
    "SlidingModeController",
    "SteppedArm",
    "SteppedPlant",
    "TableReference",
    "TrueVelocity",
    "__version__",
    "check_controller",
    "ftsm_convergence_time",
    "robots",
    "simulate",
    "simulate_batch",
    "sweep",
    "tsm_convergence_time",
]
