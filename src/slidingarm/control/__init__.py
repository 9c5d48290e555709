"""The control-law contract, the sliding-mode family, custom compiled laws and their checker."""

from slidingarm.control.base import Controller, LawHandle
from slidingarm.control.check import ControllerCheckError, check_controller
from slidingarm.control.controllers import (
    FTSMC,
    NTSMC,
    PDSMC,
    SWITCHING_LAWS,
    TSMC,
    SlidingModeController,
    guard_for_period,
)
from slidingarm.control.custom import CustomController
from slidingarm.control.surfaces import ftsm_convergence_time, tsm_convergence_time

__all__ = [
    "FTSMC",
    "NTSMC",
    "PDSMC",
    "SWITCHING_LAWS",
    "TSMC",
    "Controller",
    "ControllerCheckError",
    "CustomController",
    "LawHandle",
    "SlidingModeController",
    "check_controller",
    "ftsm_convergence_time",
    "guard_for_period",
    "tsm_convergence_time",
]
