"""slidingarm: sliding-mode control of robot arms, simulated fast and checked against theory."""

from slidingarm._version import __version__
from slidingarm.models import PlanarArm

__all__ = ["PlanarArm", "__version__"]
