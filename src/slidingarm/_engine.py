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
The time loop allocates nothing.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

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


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _rk4_step(
    arm: np.ndarray,
    g: float,
    q: np.ndarray,
    qd: np.ndarray,
    tau: np.ndarray,
    h: float,
    k: np.ndarray,
    qtmp: np.ndarray,
    vtmp: np.ndarray,
    mmat: np.ndarray,
    lw: np.ndarray,
    work: np.ndarray,
) -> bool:
    """Advance ``(q, qd)`` in place by one RK4 step of length ``h`` with constant ``tau``.

    ``k`` is a (4, n) scratch array for the four acceleration stages (the velocity stages are
    recomputed from them). Returns ``False`` if a mass matrix was not positive definite.
    """
    n = q.shape[0]
    ok = MK.forward_dynamics_into(arm, g, q, qd, tau, k[0], mmat, lw, work)
    # stage 2 at (q + h/2 qd, qd + h/2 a1)
    for i in range(n):
        qtmp[i] = q[i] + 0.5 * h * qd[i]
        vtmp[i] = qd[i] + 0.5 * h * k[0, i]
    ok &= MK.forward_dynamics_into(arm, g, qtmp, vtmp, tau, k[1], mmat, lw, work)
    # stage 3 at (q + h/2 v2, qd + h/2 a2), v2 = qd + h/2 a1
    for i in range(n):
        qtmp[i] = q[i] + 0.5 * h * (qd[i] + 0.5 * h * k[0, i])
        vtmp[i] = qd[i] + 0.5 * h * k[1, i]
    ok &= MK.forward_dynamics_into(arm, g, qtmp, vtmp, tau, k[2], mmat, lw, work)
    # stage 4 at (q + h v3, qd + h a3), v3 = qd + h/2 a2
    for i in range(n):
        qtmp[i] = q[i] + h * (qd[i] + 0.5 * h * k[1, i])
        vtmp[i] = qd[i] + h * k[2, i]
    ok &= MK.forward_dynamics_into(arm, g, qtmp, vtmp, tau, k[3], mmat, lw, work)
    for i in range(n):
        v1 = qd[i]
        v2 = qd[i] + 0.5 * h * k[0, i]
        v3 = qd[i] + 0.5 * h * k[1, i]
        v4 = qd[i] + h * k[2, i]
        q[i] += h / 6.0 * (v1 + 2.0 * v2 + 2.0 * v3 + v4)
        qd[i] += h / 6.0 * (k[0, i] + 2.0 * k[1, i] + 2.0 * k[2, i] + k[3, i])
    return ok


@njit(cache=True, nogil=True, error_model="numpy")
def run_batch(
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
    """
    nb = q_out.shape[0]
    nt = q_out.shape[1]
    n = q_out.shape[2]
    h = dt / substeps
    # scratch, allocated once per call
    q = np.empty(n)
    qd = np.empty(n)
    qm = np.empty(n)
    qdm = np.empty(n)
    qm_prev = np.empty(n)
    z0 = np.empty(n)
    tau_applied = np.empty(n)
    st_state = np.empty(n)
    kst = np.empty((4, n))
    qtmp = np.empty(n)
    vtmp = np.empty(n)
    mmat = np.empty((n, n))
    lw = np.empty((n, n))
    work = np.empty((CK.CONTROL_WORK_ROWS, n))
    for b in range(nb):
        pa = plant_arm[b if plant_arm.shape[0] > 1 else 0].copy()
        pg = plant_g[b if plant_g.shape[0] > 1 else 0]
        cib = ci[b if ci.shape[0] > 1 else 0]
        cfb = cf[b if cf.shape[0] > 1 else 0]
        ca = ctrl_arm[b if ctrl_arm.shape[0] > 1 else 0].copy()
        cg = ctrl_g[b if ctrl_g.shape[0] > 1 else 0]
        madd = meas_add[b if meas_add.shape[0] > 1 else 0]
        mhold = meas_hold[b if meas_hold.shape[0] > 1 else 0]
        vcode = vel_code[b if vel_code.shape[0] > 1 else 0]
        vfb = vf[b if vf.shape[0] > 1 else 0]
        db = dist[b if dist.shape[0] > 1 else 0]
        tmax = tau_max[b if tau_max.shape[0] > 1 else 0]
        q[:] = q0[b if q0.shape[0] > 1 else 0]
        qd[:] = qd0[b if qd0.shape[0] > 1 else 0]
        st_state[:] = 0.0
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
            for j in range(n):
                qm_prev[j] = qm[j]
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
                tau_out[b, k],
                s_out[b, k],
                mmat,
                lw,
                work,
            )
            for j in range(n):
                t_j = tau_out[b, k, j]
                if t_j > tmax[j]:
                    t_j = tmax[j]
                elif t_j < -tmax[j]:
                    t_j = -tmax[j]
                tau_out[b, k, j] = t_j
                tau_applied[j] = t_j + db[k, j]
                q_out[b, k, j] = q[j]
                qd_out[b, k, j] = qd[j]
                qm_out[b, k, j] = qm[j]
                qdm_out[b, k, j] = qdm[j]
            bad = -1
            for j in range(n):
                if not (math.isfinite(tau_out[b, k, j]) and math.isfinite(s_out[b, k, j])):
                    bad = j
                    break
            if bad >= 0:
                status[b, 0] = STATUS_NONFINITE
                status[b, 1] = k
                status[b, 2] = bad
                break
            if k == nt - 1:
                break
            # --- plant over [t_k, t_k+1)
            ok = True
            for _ in range(substeps):
                ok &= _rk4_step(pa, pg, q, qd, tau_applied, h, kst, qtmp, vtmp, mmat, lw, work)
            if not ok:
                status[b, 0] = STATUS_SINGULAR
                status[b, 1] = k + 1
                status[b, 2] = 0
                break
            for j in range(n):
                if not (math.isfinite(q[j]) and math.isfinite(qd[j])):
                    status[b, 0] = STATUS_NONFINITE
                    status[b, 1] = k + 1
                    status[b, 2] = j
                    break
                if abs(qd[j]) > qd_limit:
                    status[b, 0] = STATUS_RUNAWAY
                    status[b, 1] = k + 1
                    status[b, 2] = j
                    break
            if status[b, 0] != STATUS_OK:
                break
