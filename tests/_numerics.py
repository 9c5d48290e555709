"""Independent numerics shared by tests: plain numpy, no compiled code of ours."""

from __future__ import annotations

import numpy as np

from slidingarm import PlanarArm


def rk4(
    arm: PlanarArm, q: np.ndarray, qd: np.ndarray, tau: np.ndarray, h: float
) -> tuple[np.ndarray, np.ndarray]:
    """One classical RK4 step of (q, q̇) under constant torque (numpy, independent)."""

    def f(x: np.ndarray, v: np.ndarray) -> np.ndarray:
        return arm.forward_dynamics(x, v, tau)

    k1v, k1a = qd, f(q, qd)
    k2v, k2a = qd + h / 2 * k1a, f(q + h / 2 * k1v, qd + h / 2 * k1a)
    k3v, k3a = qd + h / 2 * k2a, f(q + h / 2 * k2v, qd + h / 2 * k2a)
    k4v, k4a = qd + h * k3a, f(q + h * k3v, qd + h * k3a)
    return (
        q + h / 6 * (k1v + 2 * k2v + 2 * k3v + k4v),
        qd + h / 6 * (k1a + 2 * k2a + 2 * k3a + k4a),
    )
