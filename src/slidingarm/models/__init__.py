"""Arm models: the closed-form planar arm (and its URDF/MJCF exports)."""

from slidingarm.models.planar import MassModel, PlanarArm

__all__ = ["MassModel", "PlanarArm"]
