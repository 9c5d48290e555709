"""A plain numba reference for the paper's closed loop, to time slidingarm against.

Written from scratch for the benchmarks, without slidingarm's kernels: the loop as someone who
knows numba would write it, plain scalar code without tuning it (no SIMD, no fastmath, no
algebra shared between the law and the plant), so that a time of ours divided by this one's,
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
``h`` are formed explicitly from the tips' Jacobians, at the law's state and at each of the four
RK4 stages:

.. math:: M = \\sum_i m_i J_i^T J_i, \\qquad h = \\sum_i m_i J_i^T (\\dot J_i \\dot q + g\\hat y).

Every function writes into arrays its caller gives; a run allocates its few small work arrays
once (:func:`workspace`) and none per step. (An earlier version returned fresh arrays from
every function, about 90 small allocations a step: it ran at 2.7e5 arm-steps/s on one thread,
6.4x slower than slidingarm's own scalar loop on the same run, and 2-5e5 on two threads, where
the threads' allocations contend; that measured numba's allocator, not the loop.)

The reference trajectory is passed in as arrays (the caller evaluates
``slidingarm.PaperReference()`` on the time grid). :func:`closed_loop` returns the trajectory;
:func:`closed_loop_mse` keeps only each joint's mean squared tracking error over the run's
samples, :math:`\\frac{1}{T}\\sum_k (q_{k,j} - q_{d,k,j})^2` (the MSE of
``slidingarm.metrics.mse``), accumulated as the run goes, for batches.
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

# rows of a run's (ROWS, n) work array (see workspace): the arm's masses and lengths, the
# reference's current sample, the state, the law's and the plant's vectors, the RK4 stages
MASS, LEN, QR, QDR, QDDR = range(5)
Q, QD, COS, SIN, RATE, JX, JY, BIAS, RHS, ACC, TAU, POS = range(5, 17)
A1, A2, A3, A4, V2, V3, V4 = range(17, 24)
ROWS = 24


@njit(cache=True)
def workspace(m: np.ndarray, ln: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The work arrays of one run of ``n = len(m)`` joints: vectors ``ws`` (``ROWS``, n),
    addressed ``ws[ROW, j]``, with the masses ``m`` and lengths ``ln`` copied in, and
    matrices ``sq`` (2, n, n), ``M`` and its Cholesky factor.

    Each run reads and writes only its own arrays once it has started: an array shared by the
    runs of a batch (the arm's, the reference's) passed to the functions of every step would
    have its reference count changed by every thread at every call, an atomic on a cache line
    the threads share (the previous version ran slower on two threads than on one).
    """
    n = m.shape[0]
    ws = np.empty((ROWS, n))
    for j in range(n):
        ws[MASS, j] = m[j]
        ws[LEN, j] = ln[j]
    return ws, np.empty((2, n, n))


@njit(cache=True)
def mass_and_bias(g: float, ws: np.ndarray, sq: np.ndarray, iq: int, iqd: int) -> None:
    """``M(q)`` into ``sq[0]`` (n, n) and ``h(q, qd)`` into ``ws[BIAS]`` of a planar arm with
    point masses ``ws[MASS]`` at the tips of links ``ws[LEN]``, for ``q = ws[iq]`` and
    ``qd = ws[iqd]``."""
    n = ws.shape[1]
    phi = 0.0  # absolute angle and rate of link a
    rate = 0.0
    for a in range(n):
        phi += ws[iq, a]
        rate += ws[iqd, a]
        ws[COS, a] = np.cos(phi)
        ws[SIN, a] = np.sin(phi)
        ws[RATE, a] = rate
    for a in range(n):
        ws[BIAS, a] = 0.0
        for b in range(n):
            sq[0, a, b] = 0.0
    for i in range(n):
        # tip i: p_i = sum_{a <= i} l_a (cos phi_a, sin phi_a); column j <= i of its Jacobian
        # is sum_{a = j..i} l_a (-sin phi_a, cos phi_a)
        for j in range(i + 1):
            x = 0.0
            y = 0.0
            for a in range(j, i + 1):
                x -= ws[LEN, a] * ws[SIN, a]
                y += ws[LEN, a] * ws[COS, a]
            ws[JX, j] = x
            ws[JY, j] = y
        # Jdot_i qd = -sum_{a <= i} l_a w_a^2 (cos phi_a, sin phi_a), plus gravity's g y
        ax = 0.0
        ay = g
        for a in range(i + 1):
            w = ws[RATE, a]
            ax -= ws[LEN, a] * w * w * ws[COS, a]
            ay -= ws[LEN, a] * w * w * ws[SIN, a]
        mi = ws[MASS, i]
        for a in range(i + 1):
            jxa = ws[JX, a]
            jya = ws[JY, a]
            for b in range(i + 1):
                sq[0, a, b] += mi * (jxa * ws[JX, b] + jya * ws[JY, b])
            ws[BIAS, a] += mi * (jxa * ax + jya * ay)


@njit(cache=True)
def ftsmc(g: float, ws: np.ndarray, sq: np.ndarray) -> None:
    """The FTSMC torque at the state ``ws[Q], ws[QD]`` and the reference's sample
    ``ws[QR], ws[QDR], ws[QDDR]`` into ``ws[TAU]``, computed-torque form with the arm's own
    model."""
    n = ws.shape[1]
    for j in range(n):
        e = ws[Q, j] - ws[QR, j]
        ed = ws[QD, j] - ws[QDR, j]
        ae = abs(e)
        s = ed + ALPHA * e + BETA * ae**GAMMA * np.sign(e)
        nu = (ALPHA + BETA * GAMMA * max(ae, EPS_E) ** (GAMMA - 1.0)) * ed
        ws[ACC, j] = ws[QDDR, j] - nu - K * np.sign(s)
    mass_and_bias(g, ws, sq, Q, QD)
    for a in range(n):
        t = ws[BIAS, a]
        for b in range(n):
            t += sq[0, a, b] * ws[ACC, b]
        ws[TAU, a] = t


@njit(cache=True)
def solve_spd(ws: np.ndarray, sq: np.ndarray, out: int) -> None:
    """``x = ws[out]`` with ``M x = b`` for ``M = sq[0]`` (symmetric positive definite) and
    ``b = ws[RHS]``, by Cholesky (the lower factor into ``sq[1]``, whose lower triangle alone
    is written and read)."""
    n = ws.shape[1]
    for i in range(n):
        for j in range(i + 1):
            acc = sq[0, i, j]
            for p in range(j):
                acc -= sq[1, i, p] * sq[1, j, p]
            if i == j:
                sq[1, i, i] = np.sqrt(acc)
            else:
                sq[1, i, j] = acc / sq[1, j, j]
    for i in range(n):  # L y = b
        acc = ws[RHS, i]
        for p in range(i):
            acc -= sq[1, i, p] * ws[out, p]
        ws[out, i] = acc / sq[1, i, i]
    for i in range(n - 1, -1, -1):  # L^T x = y
        acc = ws[out, i]
        for p in range(i + 1, n):
            acc -= sq[1, p, i] * ws[out, p]
        ws[out, i] = acc / sq[1, i, i]


@njit(cache=True)
def accel(g: float, ws: np.ndarray, sq: np.ndarray, iq: int, iqd: int, out: int) -> None:
    """Forward dynamics ``qdd = M^{-1} (tau - h)`` at ``q = ws[iq], qd = ws[iqd]``, with
    ``tau = ws[TAU]``, into ``ws[out]``."""
    mass_and_bias(g, ws, sq, iq, iqd)
    for j in range(ws.shape[1]):
        ws[RHS, j] = ws[TAU, j] - ws[BIAS, j]
    solve_spd(ws, sq, out)


@njit(cache=True)
def rk4(g: float, ws: np.ndarray, sq: np.ndarray, h: float) -> None:
    """One classic RK4 step of the state ``ws[Q], ws[QD]``, in place, with ``ws[TAU]`` held."""
    n = ws.shape[1]
    accel(g, ws, sq, Q, QD, A1)
    for j in range(n):
        ws[V2, j] = ws[QD, j] + h / 2 * ws[A1, j]
        ws[POS, j] = ws[Q, j] + h / 2 * ws[QD, j]
    accel(g, ws, sq, POS, V2, A2)
    for j in range(n):
        ws[V3, j] = ws[QD, j] + h / 2 * ws[A2, j]
        ws[POS, j] = ws[Q, j] + h / 2 * ws[V2, j]
    accel(g, ws, sq, POS, V3, A3)
    for j in range(n):
        ws[V4, j] = ws[QD, j] + h * ws[A3, j]
        ws[POS, j] = ws[Q, j] + h * ws[V3, j]
    accel(g, ws, sq, POS, V4, A4)
    for j in range(n):
        ws[Q, j] += h / 6 * (ws[QD, j] + 2 * ws[V2, j] + 2 * ws[V3, j] + ws[V4, j])
        ws[QD, j] += h / 6 * (ws[A1, j] + 2 * ws[A2, j] + 2 * ws[A3, j] + ws[A4, j])


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
    ws, sq = workspace(m, ln)
    for j in range(n):
        ws[Q, j] = q0[j]
        ws[QD, j] = qd0[j]
    for k in range(nt):
        for j in range(n):
            qs[k, j] = ws[Q, j]
        if k == nt - 1:
            break
        for j in range(n):
            ws[QR, j] = q_ref[k, j]
            ws[QDR, j] = qd_ref[k, j]
            ws[QDDR, j] = qdd_ref[k, j]
        ftsmc(g, ws, sq)
        rk4(g, ws, sq, dt)
    return qs


@njit(cache=True)
def closed_loop_mse(
    m: np.ndarray,
    ln: np.ndarray,
    g: float,
    q0: np.ndarray,
    qd0: np.ndarray,
    q_ref: np.ndarray,
    qd_ref: np.ndarray,
    qdd_ref: np.ndarray,
    dt: float,
    mse: np.ndarray,
) -> None:
    """The loop of :func:`closed_loop`, keeping only each joint's mean squared tracking
    error over the samples, :math:`\\frac{1}{T}\\sum_k (q_{k,j} - q_{d,k,j})^2`, into ``mse``
    (n,)."""
    nt, n = q_ref.shape
    ws, sq = workspace(m, ln)
    for j in range(n):
        ws[Q, j] = q0[j]
        ws[QD, j] = qd0[j]
        mse[j] = 0.0
    for k in range(nt):
        for j in range(n):
            e = ws[Q, j] - q_ref[k, j]
            mse[j] += e * e
        if k == nt - 1:
            break
        for j in range(n):
            ws[QR, j] = q_ref[k, j]
            ws[QDR, j] = qd_ref[k, j]
            ws[QDDR, j] = qdd_ref[k, j]
        ftsmc(g, ws, sq)
        rk4(g, ws, sq, dt)
    for j in range(n):
        mse[j] /= nt


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
