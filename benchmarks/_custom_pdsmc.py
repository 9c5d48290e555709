"""PDSMC with tanh switching as a custom kernel (module level, for bench_engine.py)."""

from __future__ import annotations

import math

from numba import njit


@njit(cache=True)
def pdsmc_tanh(t, q, qd, q_ref, qd_ref, qdd_ref, M, h, p, state, tau, s):  # type: ignore[no-untyped-def]
    """s = ė + λe, τ = M(q̈_d − λė − k tanh(s/ε)) + h with p = (λ, k, ε)."""
    lam, k, width = p[0], p[1], p[2]
    n = q.shape[0]
    for i in range(n):
        s[i] = qd[i] - qd_ref[i] + lam * (q[i] - q_ref[i])
    for i in range(n):
        acc = 0.0
        for j in range(n):
            acc += M[i, j] * (qdd_ref[j] - lam * (qd[j] - qd_ref[j]) - k * math.tanh(s[j] / width))
        tau[i] = acc + h[i]
