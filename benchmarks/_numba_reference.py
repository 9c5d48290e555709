"""A plain numba reference for the paper's closed loop, to time slidingarm against.

Written from scratch for the benchmark, without slidingarm's kernels: the loop as someone who
knows numba would write it without tuning it, so that a time of ours divided by this one's,
measured in the same run, says how our compiled loop compares to a straightforward one on
whatever load the machine carries.

The problem is the paper's: the 3-link planar arm of ``slidingarm.PlanarArm.paper()`` (point
masses ``m = (1, 1, 1)`` kg at the tips of links ``l = (0.5, 1, 1)`` m, no link inertia,
gravity ``g = 9.81`` m/s² along ``-y``; ``q[0]`` is link 1's angle from ``+x``, ``q[i]``
link ``i+1``'s angle relative to link ``i``), controlled by the FTSMC law

.. math::

    s = \\dot e + \\alpha e + \\beta\\,\\mathrm{sig}(e)^\\gamma, \\qquad
    \\nu = (\\alpha + \\beta\\gamma\\max(|e|, \\varepsilon_e)^{\\gamma-1})\\,\\dot e, \\\\
    \\tau = M(q)\\,(\\ddot q_d - \\nu - k\\,\\mathrm{sign}(s)) + h(q, \\dot q)

with ``alpha = beta = 2``, ``gamma = 3/5``, ``k = 20``, ``eps_e = 1e-9``, the exact state
measured, the torque held over each sample (zero-order hold) and the plant integrated by one
RK4 step per sample, :math:`\\ddot q = M^{-1}(\\tau - h)` by a hand-written Cholesky
solve (``np.linalg.solve`` made the whole loop about 1.4x slower, its LAPACK call's checks and
copies then taking a third of the time, and ties the reference to the LAPACK build). ``M`` and
``h`` are formed explicitly from the tips' Jacobians, in small arrays allocated per call:

.. math:: M = \\sum_i m_i J_i^T J_i, \\qquad h = \\sum_i m_i J_i^T (\\dot J_i \\dot q + g\\hat y).

The reference trajectory is passed in as arrays (the caller evaluates
``slidingarm.PaperReference()`` on the time grid).
"""

from __future__ import annotations

import numpy as np
from numba import njit

# the paper's arm (Table 1): point masses at the link tips
MASSES = np.array([1.0, 1.0, 1.0])
LENGTHS = np.array([0.5, 1.0, 1.0])
GRAVITY = 9.81

# the paper's FTSMC gains, gamma = q/p with p = 5, q = 3, and slidingarm's default guard
ALPHA = 2.0
BETA = 2.0
GAMMA = 3.0 / 5.0
K = 20.0
EPS_E = 1e-9


@njit(cache=True)
def mass_and_bias(
    m: np.ndarray, ln: np.ndarray, g: float, q: np.ndarray, qd: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """``M(q)`` (n, n) and ``h(q, qd)`` (n,) of a planar arm with point masses at the tips."""
    n = q.shape[0]
    phi = np.cumsum(q)  # absolute angles
    w = np.cumsum(qd)  # absolute rates
    c = np.cos(phi)
    s = np.sin(phi)
    mass = np.zeros((n, n))
    bias = np.zeros(n)
    jx = np.zeros(n)
    jy = np.zeros(n)
    for i in range(n):
        # tip i: p_i = sum_{a <= i} l_a (cos phi_a, sin phi_a); column j <= i of its Jacobian
        # is sum_{a = j..i} l_a (-sin phi_a, cos phi_a)
        for j in range(i + 1):
            x = 0.0
            y = 0.0
            for a in range(j, i + 1):
                x -= ln[a] * s[a]
                y += ln[a] * c[a]
            jx[j] = x
            jy[j] = y
        # Jdot_i qd = -sum_{a <= i} l_a w_a^2 (cos phi_a, sin phi_a), plus gravity's g y
        ax = 0.0
        ay = g
        for a in range(i + 1):
            ax -= ln[a] * w[a] * w[a] * c[a]
            ay -= ln[a] * w[a] * w[a] * s[a]
        for a in range(i + 1):
            for b in range(i + 1):
                mass[a, b] += m[i] * (jx[a] * jx[b] + jy[a] * jy[b])
            bias[a] += m[i] * (jx[a] * ax + jy[a] * ay)
    return mass, bias


@njit(cache=True)
def ftsmc(
    m: np.ndarray,
    ln: np.ndarray,
    g: float,
    q: np.ndarray,
    qd: np.ndarray,
    q_ref: np.ndarray,
    qd_ref: np.ndarray,
    qdd_ref: np.ndarray,
) -> np.ndarray:
    """The FTSMC torque, computed-torque form with the arm's own model."""
    n = q.shape[0]
    acc = np.empty(n)
    for j in range(n):
        e = q[j] - q_ref[j]
        ed = qd[j] - qd_ref[j]
        ae = abs(e)
        s = ed + ALPHA * e + BETA * ae**GAMMA * np.sign(e)
        nu = (ALPHA + BETA * GAMMA * max(ae, EPS_E) ** (GAMMA - 1.0)) * ed
        acc[j] = qdd_ref[j] - nu - K * np.sign(s)
    mass, bias = mass_and_bias(m, ln, g, q, qd)
    tau = bias.copy()
    for a in range(n):
        for b in range(n):
            tau[a] += mass[a, b] * acc[b]
    return tau


@njit(cache=True)
def solve_spd(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``x`` with ``a x = b`` for a symmetric positive definite ``a``, by Cholesky."""
    n = b.shape[0]
    low = np.zeros((n, n))
    for i in range(n):
        for j in range(i + 1):
            acc = a[i, j]
            for p in range(j):
                acc -= low[i, p] * low[j, p]
            if i == j:
                low[i, i] = np.sqrt(acc)
            else:
                low[i, j] = acc / low[j, j]
    x = np.empty(n)
    for i in range(n):  # L y = b
        acc = b[i]
        for p in range(i):
            acc -= low[i, p] * x[p]
        x[i] = acc / low[i, i]
    for i in range(n - 1, -1, -1):  # L^T x = y
        acc = x[i]
        for p in range(i + 1, n):
            acc -= low[p, i] * x[p]
        x[i] = acc / low[i, i]
    return x


@njit(cache=True)
def accel(
    m: np.ndarray, ln: np.ndarray, g: float, q: np.ndarray, qd: np.ndarray, tau: np.ndarray
) -> np.ndarray:
    """Forward dynamics ``qdd = M^{-1} (tau - h)``."""
    mass, bias = mass_and_bias(m, ln, g, q, qd)
    return solve_spd(mass, tau - bias)


@njit(cache=True)
def rk4(
    m: np.ndarray,
    ln: np.ndarray,
    g: float,
    q: np.ndarray,
    qd: np.ndarray,
    tau: np.ndarray,
    h: float,
) -> tuple[np.ndarray, np.ndarray]:
    """One classic RK4 step of ``(q, qd)`` with ``tau`` held."""
    a1 = accel(m, ln, g, q, qd, tau)
    v2 = qd + h / 2 * a1
    a2 = accel(m, ln, g, q + h / 2 * qd, v2, tau)
    v3 = qd + h / 2 * a2
    a3 = accel(m, ln, g, q + h / 2 * v2, v3, tau)
    v4 = qd + h * a3
    a4 = accel(m, ln, g, q + h * v3, v4, tau)
    return (
        q + h / 6 * (qd + 2 * v2 + 2 * v3 + v4),
        qd + h / 6 * (a1 + 2 * a2 + 2 * a3 + a4),
    )


@njit(cache=True)
def closed_loop(
    m: np.ndarray,
    ln: np.ndarray,
    g: float,
    q0: np.ndarray,
    qd0: np.ndarray,
    q_ref: np.ndarray,
    qd_ref: np.ndarray,
    qdd_ref: np.ndarray,
    dt: float,
) -> np.ndarray:
    """The sampled closed loop; returns ``q`` at the samples, shape ``q_ref.shape``."""
    nt, n = q_ref.shape
    qs = np.empty((nt, n))
    q = q0.copy()
    qd = qd0.copy()
    for k in range(nt):
        qs[k] = q
        if k == nt - 1:
            break
        tau = ftsmc(m, ln, g, q, qd, q_ref[k], qd_ref[k], qdd_ref[k])
        q, qd = rk4(m, ln, g, q, qd, tau, dt)
    return qs


def paper_inputs(
    q0: tuple[float, ...], q_ref: np.ndarray, qd_ref: np.ndarray, qdd_ref: np.ndarray, dt: float
) -> tuple[object, ...]:
    """The arguments of :func:`closed_loop` for the paper's run from rest at ``q0``, the
    reference sampled every ``dt``."""
    return (
        MASSES,
        LENGTHS,
        GRAVITY,
        np.array(q0, dtype=np.float64),
        np.zeros(len(q0)),
        np.ascontiguousarray(q_ref, dtype=np.float64),
        np.ascontiguousarray(qd_ref, dtype=np.float64),
        np.ascontiguousarray(qdd_ref, dtype=np.float64),
        float(dt),
    )
