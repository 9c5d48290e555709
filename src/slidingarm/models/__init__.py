"""Arm models: the contract (:class:`ArmModel`), the closed-form planar arm, URDF serial arms,
Python-stepped plants."""

from slidingarm.models.base import ArmModel, ModelHandle
from slidingarm.models.mujoco_plant import MujocoPlant
from slidingarm.models.planar import MassModel, PlanarArm
from slidingarm.models.serial import SerialArm
from slidingarm.models.stepped import SteppedArm, SteppedPlant

__all__ = [
    "ArmModel",
    "MassModel",
    "ModelHandle",
    "MujocoPlant",
    "PlanarArm",
    "SerialArm",
    "SteppedArm",
    "SteppedPlant",
]
