"""Arm models: the contract (:class:`ArmModel`), the closed-form planar arm, Python-stepped
plants."""

from slidingarm.models.base import ArmModel, ModelHandle
from slidingarm.models.mujoco_plant import MujocoPlant
from slidingarm.models.planar import MassModel, PlanarArm
from slidingarm.models.stepped import SteppedArm, SteppedPlant

__all__ = [
    "ArmModel",
    "MassModel",
    "ModelHandle",
    "MujocoPlant",
    "PlanarArm",
    "SteppedArm",
    "SteppedPlant",
]
