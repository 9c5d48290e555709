"""The compiled closed loop: digital sliding-mode control of a planar arm (SPEC §5).

Per sample ``k`` (time ``t_k = k dt``) and run ``b``:

1. measurement: ``q̃_k = q_k + add_k``, except where ``hold_k`` is set, where the previous
   measurement is repeated (stuck sensor, dropout);
2. velocity estimate from the true velocity, a backward difference, a dirty derivative or
   Levant's robust exact differentiator;
3. the controller computes ``τ_k`` and ``s_k``; actuator limits clip ``τ_k``;
4. the plant is integrated over ``[t_k, t_k+1)`` with ``τ_k + d_k`` held (zero-order hold) by
   RK4 with ``substeps`` equal substeps.

Every per-run input array has a leading batch axis that is either ``B`` or 1 (shared by all runs).
The runs of a batch are shared among threads (:func:`run_batch`). The time loop allocates
nothing and does no reference counting: every array it touches is a :func:`_borrow` alias.
The plant's forward dynamics is the articulated-body algorithm; the controller leaves the
sines and cosines of the measured angles behind, and when the measurement is exact the first
RK4 stage reuses them, the other stages rotate them by the stage's step
(:func:`slidingarm.models._kernels.shifted_angles_into`).
"""

from __future__ import annotations

import inspect
import itertools
import math
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import numpy as np
from numba import config, njit, types
from numba.core import cgutils
from numba.extending import intrinsic

from slidingarm.control import _kernels as CK
from slidingarm.models import _kernels as MK

VEL_TRUE = 0
VEL_DIFFERENCE = 1
VEL_FILTERED = 2
VEL_LEVANT = 3

# rows of the velocity-estimator parameters vf
VF_TIME_CONSTANT = 0
VF_LIPSCHITZ = 1
VF_LAMBDA1 = 2
VF_LAMBDA0 = 3
NVF = 4

STATUS_OK = 0
STATUS_NONFINITE = 1
STATUS_RUNAWAY = 2
STATUS_SINGULAR = 3


@intrinsic
def _borrow(typingctx, arr):  # type: ignore[no-untyped-def]
    """An alias of the array ``arr`` that takes no part in reference counting.

    Numba reference-counts array variables, and in the inlined kernels of the time loop every
    function argument and row view is one; its LLVM pass removes only some of those atomic
    increments and decrements, which then took a fifth of the loop's time. The alias has a
    null memory-info pointer, so all of them compile away. The caller must keep ``arr``
    alive while the alias is in use: here every borrowed array is (a view of) an argument of
    :func:`_run_one`, which :func:`_run_block` holds.
    """
    if not isinstance(arr, types.Array):
        return None

    def codegen(context, builder, signature, args):  # type: ignore[no-untyped-def]
        ary = args[0]
        return builder.insert_value(ary, cgutils.get_null_value(ary.type.elements[0]), 0)

    return arr(arr), codegen


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _rk4_step(
    arm: np.ndarray,
    g: float,
    q: np.ndarray,
    qd: np.ndarray,
    tau: np.ndarray,
    h: float,
    known: bool,
    k: np.ndarray,
    dq: np.ndarray,
    qtmp: np.ndarray,
    vtmp: np.ndarray,
    base: np.ndarray,
    work: np.ndarray,
) -> bool:
    """Advance ``(q, qd)`` in place by one RK4 step of length ``h`` with constant ``tau``.

    ``k`` is a (4, n) scratch array for the four acceleration stages (the velocity stages are
    recomputed from them); ``dq``, ``qtmp``, ``vtmp`` (n,) and ``base`` (2, n) are scratch.
    The stages' sines and cosines are those of ``q`` (in ``work`` rows 0-1 already if
    ``known``, as the controller leaves them when it measured ``q`` exactly) shifted by the
    stage's step. Returns ``False`` if a mass matrix was not positive definite.
    """
    n = q.shape[0]
    if not known:
        MK.angles_into(q, work)
    for i in range(n):
        base[0, i] = work[0, i]
        base[1, i] = work[1, i]
        vtmp[i] = qd[i]
    # Stage s is at (q + c_s h v_{s-1}, qd + c_s h a_{s-1}), c = (1/2, 1/2, 1), with
    # v_1 = qd and v_s = qd + h/2 a_{s-1} for s = 2, 3. One loop, so that the inlined
    # forward dynamics is compiled once rather than once per stage.
    ok = True
    for s in range(4):
        if s > 0:
            c = 1.0 if s == 3 else 0.5
            for i in range(n):
                v_prev = qd[i] if s == 1 else qd[i] + 0.5 * h * k[s - 2, i]
                dq[i] = c * h * v_prev
                qtmp[i] = q[i] + dq[i]
                vtmp[i] = qd[i] + c * h * k[s - 1, i]
            MK.shifted_angles_into(base, dq, qtmp, work)
        ok &= MK.aba_from_angles_into(arm, g, vtmp, tau, k[s], work)
    for i in range(n):
        v1 = qd[i]
        v2 = qd[i] + 0.5 * h * k[0, i]
        v3 = qd[i] + 0.5 * h * k[1, i]
        v4 = qd[i] + h * k[2, i]
        q[i] += h / 6.0 * (v1 + 2.0 * v2 + 2.0 * v3 + v4)
        qd[i] += h / 6.0 * (k[0, i] + 2.0 * k[1, i] + 2.0 * k[2, i] + k[3, i])
    return ok


# rows of the per-run workspace: vectors (n,), the stage's base sines and cosines (2 rows), the
# RK4 stages (4 rows), the control work rows, and the controller's M and its Cholesky factor
# (n rows each)
_Q = 0
_QD = 1
_QM = 2
_QDM = 3
_QM_PREV = 4
_Z0 = 5
_TAU_APPLIED = 6
_ST_STATE = 7
_QTMP = 8
_VTMP = 9
_DQ = 10
_BASE = 11  # 2 rows
_K = 13  # 4 rows
_WORK = _K + 4
_MATRICES = _WORK + CK.CONTROL_WORK_ROWS


def _run_batch(
    plant_arm: np.ndarray,
    plant_g: np.ndarray,
    ci: np.ndarray,
    cf: np.ndarray,
    ctrl_arm: np.ndarray,
    ctrl_g: np.ndarray,
    q0: np.ndarray,
    qd0: np.ndarray,
    q_ref: np.ndarray,
    qd_ref: np.ndarray,
    qdd_ref: np.ndarray,
    meas_add: np.ndarray,
    meas_hold: np.ndarray,
    vel_code: np.ndarray,
    vf: np.ndarray,
    dist: np.ndarray,
    tau_max: np.ndarray,
    dt: float,
    substeps: int,
    qd_limit: float,
    q_out: np.ndarray,
    qd_out: np.ndarray,
    qm_out: np.ndarray,
    qdm_out: np.ndarray,
    tau_out: np.ndarray,
    s_out: np.ndarray,
    status: np.ndarray,
) -> None:
    """Simulate ``B`` closed-loop runs; see the module docstring.

    Shapes (``B'`` is ``B`` or 1): ``plant_arm, ctrl_arm`` (B', 4, n); ``plant_g, ctrl_g`` (B',);
    ``ci`` (B', NCI) int; ``cf`` (B', NCF, n); ``q0, qd0`` (B', n); ``q_ref, qd_ref, qdd_ref``
    (T, n); ``meas_add`` (B', T, n); ``meas_hold`` (B', T, n) bool; ``vel_code`` (B',) int;
    ``vf`` (B', NVF, n); ``dist`` (B', T, n); ``tau_max`` (B', n). Outputs (B, T, n);
    ``status`` (B, 3) receives ``[code, sample, joint]`` of the first failure (code 0: none).

    The runs are shared out, in contiguous blocks, among up to ``numba.config.NUMBA_NUM_THREADS``
    threads (the compiled loop releases the GIL); each run is computed alone, so the results
    do not depend on the split.
    """
    args = (
        plant_arm, plant_g, ci, cf, ctrl_arm, ctrl_g, q0, qd0, q_ref, qd_ref, qdd_ref,
        meas_add, meas_hold, vel_code, vf, dist, tau_max, dt, substeps, qd_limit,
        q_out, qd_out, qm_out, qdm_out, tau_out, s_out, status,
    )  # fmt: skip
    nb = q_out.shape[0]
    nthreads = min(nb, int(config.NUMBA_NUM_THREADS))
    if nthreads <= 1:
        _run_block(*args)
        return
    bounds = [nb * i // nthreads for i in range(nthreads + 1)]
    with ThreadPoolExecutor(nthreads) as pool:
        blocks = [
            pool.submit(_run_block, *_block(args, nb, lo, hi))
            for lo, hi in itertools.pairwise(bounds)
        ]
        for block in blocks:
            block.result()


#: :func:`_run_batch`, typed as loosely as the compiled dispatcher it replaced, so that callers
#: may pass the outputs as ``*outputs``.
run_batch: Callable[..., None] = _run_batch


# positions among _run_batch's arguments of q_ref, qd_ref, qdd_ref (their leading axis is
# time, not runs) and of q_out, read from its signature so that they follow any change to it
_ARGS = list(inspect.signature(_run_batch).parameters)
_TIME_ARGS = tuple(_ARGS.index(name) for name in ("q_ref", "qd_ref", "qdd_ref"))
_Q_OUT_ARG = _ARGS.index("q_out")


def _block(args: tuple[object, ...], nb: int, lo: int, hi: int) -> tuple[object, ...]:
    """``args`` of :func:`_run_batch` for runs ``lo:hi``: every array with a leading batch axis
    of ``nb`` is sliced (one of 1 is shared)."""
    return tuple(
        a[lo:hi]
        if isinstance(a, np.ndarray) and a.ndim > 0 and a.shape[0] == nb and i not in _TIME_ARGS
        else a
        for i, a in enumerate(args)
    )


def _run_block(*args: Any) -> None:
    """:func:`_run_batch` (the same arguments) in the calling thread: one compiled
    :func:`_run_one` per run.

    The loop over runs stays in Python (a few microseconds per run against milliseconds of
    compiled work) so that only :func:`_run_one` is compiled: a compiled wrapper around it
    cost another 2.5 s of compilation on a cold cache.
    """
    q_out = args[_Q_OUT_ARG]
    n = q_out.shape[2]
    workspace = np.empty((_MATRICES + 2 * n, n))
    for b in range(q_out.shape[0]):
        _run_one(b, *args, workspace)


@njit(cache=True, nogil=True, error_model="numpy")
def _run_one(
    b: int,
    plant_arm: np.ndarray,
    plant_g: np.ndarray,
    ci: np.ndarray,
    cf: np.ndarray,
    ctrl_arm: np.ndarray,
    ctrl_g: np.ndarray,
    q0: np.ndarray,
    qd0: np.ndarray,
    q_ref: np.ndarray,
    qd_ref: np.ndarray,
    qdd_ref: np.ndarray,
    meas_add: np.ndarray,
    meas_hold: np.ndarray,
    vel_code: np.ndarray,
    vf: np.ndarray,
    dist: np.ndarray,
    tau_max: np.ndarray,
    dt: float,
    substeps: int,
    qd_limit: float,
    q_out: np.ndarray,
    qd_out: np.ndarray,
    qm_out: np.ndarray,
    qdm_out: np.ndarray,
    tau_out: np.ndarray,
    s_out: np.ndarray,
    status: np.ndarray,
    workspace: np.ndarray,
) -> None:
    """Run ``b`` of :func:`_run_batch`, given a ``workspace`` of ``_MATRICES + 2 n`` rows of
    ``n``. Every array the time loop touches is a :func:`_borrow` alias of an argument."""
    nt = q_out.shape[1]
    n = q_out.shape[2]
    h = dt / substeps
    ws = _borrow(workspace)
    q = ws[_Q]
    qd = ws[_QD]
    qm = ws[_QM]
    qdm = ws[_QDM]
    qm_prev = ws[_QM_PREV]
    z0 = ws[_Z0]
    tau_applied = ws[_TAU_APPLIED]
    st_state = ws[_ST_STATE]
    qtmp = ws[_QTMP]
    vtmp = ws[_VTMP]
    dq = ws[_DQ]
    base = ws[_BASE : _BASE + 2]
    kst = ws[_K : _K + 4]
    work = ws[_WORK:_MATRICES]
    mmat = ws[_MATRICES : _MATRICES + n]
    lw = ws[_MATRICES + n : _MATRICES + 2 * n]
    # this run's inputs and outputs
    pa = _borrow(plant_arm[b if plant_arm.shape[0] > 1 else 0])
    pg = plant_g[b if plant_g.shape[0] > 1 else 0]
    cib = _borrow(ci[b if ci.shape[0] > 1 else 0])
    cfb = _borrow(cf[b if cf.shape[0] > 1 else 0])
    ca = _borrow(ctrl_arm[b if ctrl_arm.shape[0] > 1 else 0])
    cg = ctrl_g[b if ctrl_g.shape[0] > 1 else 0]
    madd = _borrow(meas_add[b if meas_add.shape[0] > 1 else 0])
    mhold = _borrow(meas_hold[b if meas_hold.shape[0] > 1 else 0])
    vcode = vel_code[b if vel_code.shape[0] > 1 else 0]
    vfb = _borrow(vf[b if vf.shape[0] > 1 else 0])
    db = _borrow(dist[b if dist.shape[0] > 1 else 0])
    tmax = _borrow(tau_max[b if tau_max.shape[0] > 1 else 0])
    q_ref = _borrow(q_ref)
    qd_ref = _borrow(qd_ref)
    qdd_ref = _borrow(qdd_ref)
    q_b = _borrow(q_out[b])
    qd_b = _borrow(qd_out[b])
    qm_b = _borrow(qm_out[b])
    qdm_b = _borrow(qdm_out[b])
    tau_b = _borrow(tau_out[b])
    s_b = _borrow(s_out[b])
    for j in range(n):
        q[j] = q0[b if q0.shape[0] > 1 else 0, j]
        qd[j] = qd0[b if qd0.shape[0] > 1 else 0, j]
        st_state[j] = 0.0
    status[b, 0] = STATUS_OK
    status[b, 1] = -1
    status[b, 2] = -1
    for k in range(nt):
        # --- measurement
        for j in range(n):
            if k > 0 and mhold[k, j]:
                qm[j] = qm_prev[j]
            else:
                qm[j] = q[j] + madd[k, j]
        # --- velocity estimate (state in qdm / z0, initialised at the known qd0)
        if vcode == VEL_TRUE:
            for j in range(n):
                qdm[j] = qd[j]
        elif k == 0:
            for j in range(n):
                qdm[j] = qd[j]
                z0[j] = qm[j]
        elif vcode == VEL_DIFFERENCE:
            for j in range(n):
                qdm[j] = (qm[j] - qm_prev[j]) / dt
        elif vcode == VEL_FILTERED:
            for j in range(n):
                tf = vfb[VF_TIME_CONSTANT, j]
                qdm[j] = (tf * qdm[j] + (qm[j] - qm_prev[j])) / (tf + dt)
        else:
            # first-order robust exact differentiator (Levant 1998), explicit Euler
            for j in range(n):
                lip = vfb[VF_LIPSCHITZ, j]
                sigma = z0[j] - qm[j]
                sg = 1.0 if sigma > 0.0 else (-1.0 if sigma < 0.0 else 0.0)
                z0[j] += dt * (-vfb[VF_LAMBDA1, j] * math.sqrt(lip * abs(sigma)) * sg + qdm[j])
                qdm[j] += dt * (-vfb[VF_LAMBDA0, j] * lip * sg)
        # the controller leaves the cosines and sines of its q in work rows 0-1: when it
        # measured the exact position, they are the first RK4 stage's
        exact = True
        for j in range(n):
            qm_prev[j] = qm[j]
            exact &= qm[j] == q[j]
        # --- control
        CK.control_into(
            cib,
            cfb,
            ca,
            cg,
            qm,
            qdm,
            q_ref[k],
            qd_ref[k],
            qdd_ref[k],
            st_state,
            dt,
            tau_b[k],
            s_b[k],
            mmat,
            lw,
            work,
        )
        bad = -1
        for j in range(n):
            t_j = tau_b[k, j]
            if t_j > tmax[j]:
                t_j = tmax[j]
            elif t_j < -tmax[j]:
                t_j = -tmax[j]
            tau_b[k, j] = t_j
            tau_applied[j] = t_j + db[k, j]
            q_b[k, j] = q[j]
            qd_b[k, j] = qd[j]
            qm_b[k, j] = qm[j]
            qdm_b[k, j] = qdm[j]
            if bad < 0 and not (math.isfinite(t_j) and math.isfinite(s_b[k, j])):
                bad = j
        if bad >= 0:
            status[b, 0] = STATUS_NONFINITE
            status[b, 1] = k
            status[b, 2] = bad
            return
        if k == nt - 1:
            return
        # --- plant over [t_k, t_k+1)
        ok = True
        for sub in range(substeps):
            ok &= _rk4_step(
                pa, pg, q, qd, tau_applied, h, exact and sub == 0, kst, dq, qtmp, vtmp, base, work
            )
        # An overflow inside the step also fails the pivot test, so finiteness is checked first:
        # a non-finite state is reported as such, with its joint, never as a singular M.
        for j in range(n):
            if not (math.isfinite(q[j]) and math.isfinite(qd[j])):
                status[b, 0] = STATUS_NONFINITE
                status[b, 1] = k + 1
                status[b, 2] = j
                return
        if not ok:
            status[b, 0] = STATUS_SINGULAR
            status[b, 1] = k + 1
            status[b, 2] = 0
            return
        for j in range(n):
            if abs(qd[j]) > qd_limit:
                status[b, 0] = STATUS_RUNAWAY
                status[b, 1] = k + 1
                status[b, 2] = j
                return
