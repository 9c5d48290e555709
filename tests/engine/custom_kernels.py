"""Module-level custom kernels for the engine tests (module level, so that they pickle)."""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True)
def pdsmc_tanh(t, q, qd, q_ref, qd_ref, qdd_ref, M, h, p, state, tau, s):  # type: ignore[no-untyped-def]
    """PDSMC with tanh switching: s = ė + λe, τ = M(q̈_d − λė − k tanh(s/ε)) + h;
    ``p = (λ, k, ε)``."""
    lam, k, width = p[0], p[1], p[2]
    n = q.shape[0]
    for i in range(n):
        ed = qd[i] - qd_ref[i]
        s[i] = ed + lam * (q[i] - q_ref[i])
    for i in range(n):
        acc = 0.0
        for j in range(n):
            ed = qd[j] - qd_ref[j]
            acc += M[i, j] * (qdd_ref[j] - lam * ed - k * math.tanh(s[j] / width))
        tau[i] = acc + h[i]


@njit(cache=True)
def counting(t, q, qd, q_ref, qd_ref, qdd_ref, M, h, p, state, tau, s):  # type: ignore[no-untyped-def]
    """PD plus gravity with a state: state[0] counts the calls, state[1] integrates e_1·dt."""
    state[0] += 1.0
    state[1] += (q[0] - q_ref[0]) * p[2]
    for i in range(q.shape[0]):
        e = q[i] - q_ref[i]
        ed = qd[i] - qd_ref[i]
        s[i] = ed + e
        tau[i] = h[i] - p[0] * e - p[1] * ed
    tau[0] -= 0.0 * state[1]


@njit(cache=True)
def blows_up(t, q, qd, q_ref, qd_ref, qdd_ref, M, h, p, state, tau, s):  # type: ignore[no-untyped-def]
    """A torque that is NaN: the checker must reject it."""
    for i in range(q.shape[0]):
        tau[i] = np.nan
        s[i] = 0.0


def pdsmc_kernel_args() -> tuple[float, float, float]:
    return (2.0, 20.0, 0.05)
