"""Sliding surfaces, switching and reaching laws, and the model-based controllers."""

from slidingarm.control.controllers import (
    FTSMC,
    NTSMC,
    PDSMC,
    SWITCHING_LAWS,
    TSMC,
    SlidingModeController,
)
from slidingarm.control.surfaces import ftsm_convergence_time, tsm_convergence_time

__all__ = [
    "FTSMC",
    "NTSMC",
    "PDSMC",
    "SWITCHING_LAWS",
    "TSMC",
    "SlidingModeController",
    "ftsm_convergence_time",
    "tsm_convergence_time",
]
