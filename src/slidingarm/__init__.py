"""slidingarm: sliding-mode control of robot arms, simulated fast and checked against theory.

The public API is exactly what this module re-exports. ``sweep`` and ``tune`` (callable
packages) and their results are imported on first use, so that ``import slidingarm`` does not
load the scenario files' machinery, optuna or pyarrow.
"""

from typing import TYPE_CHECKING, Any

from slidingarm import robots  # the shipped robots: sa.robots.load(...)
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

if TYPE_CHECKING:
    from slidingarm.sweep import SweepPackage, SweepResult
    from slidingarm.tune import TunePackage, TuneResult

    #: Monte Carlo: the package, callable as ``sa.sweep(scenario, runs=..., out=...)``.
    sweep: SweepPackage
    #: Gain tuning: the package, callable as ``sa.tune(scenario, controller=..., ...)``.
    tune: TunePackage

#: The names imported on first use: (module, attribute or None for the module itself).
_LAZY: dict[str, tuple[str, str | None]] = {
    "sweep": ("slidingarm.sweep", None),
    "SweepResult": ("slidingarm.sweep", "SweepResult"),
    "tune": ("slidingarm.tune", None),
    "TuneResult": ("slidingarm.tune", "TuneResult"),
}


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        import importlib

        module, attr = _LAZY[name]
        value = importlib.import_module(module)
        if attr is not None:
            value = getattr(value, attr)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'slidingarm' has no attribute {name!r}")

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
    "SweepResult",
    "TableReference",
    "TrueVelocity",
    "TuneResult",
    "__version__",
    "check_controller",
    "ftsm_convergence_time",
    "robots",
    "simulate",
    "simulate_batch",
    "sweep",
    "tsm_convergence_time",
    "tune",
]
