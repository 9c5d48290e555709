"""The closed loop of :mod:`slidingarm._engine`, advancing a block of ``W`` runs together.

:func:`run_block` is :func:`slidingarm._engine.run_one` for :data:`W` runs at once, for the
planar kind (plant and nominal model) and the built-in sliding-mode law with ``law =
"model"``: every surface, switching function and reaching law of
:func:`slidingarm.control._kernels.control_into`, every velocity estimator, the held and added
measurement arrays, torque disturbances, torque limits and ``substeps``. Every state and
parameter is a structure-of-arrays block ``(rows, n, W)`` with the lane (run) index innermost
and contiguous; every lane loop is ``for ln in range(W)`` with ``W`` a compile-time constant and
a branch-free body (a per-lane condition is a select), so that LLVM turns it into ``<8 x
double>`` operations. The law's codes, the velocity estimator and ``substeps`` are the same for
every lane of a block (the caller groups runs by them), so their branches are uniform.

**Results.** Each lane computes exactly what :func:`~slidingarm._engine.run_one` computes for
its run: the same floating-point operations in the same order, with the same elementary
functions (:data:`sin`, :data:`cos`, :data:`tanh`, :data:`pow_abs`), no ``fastmath`` flag on
any operation (lanes are independent, so vectorising needs no reassociation, and without
``contract`` no multiply-add is fused differently from the scalar loop). A run's trajectory is
therefore bit-identical to the scalar path's, whatever lane or block it lands in, whatever the
thread count: no value ever crosses lanes. The only block-wide decisions are whether *any* lane
needs something (the sines and cosines of a large RK4 stage step, a measurement that differed
from the state), and the lanes that do not need it discard it by a select, so they compute what
they would alone.

**Status.** A lane whose torque, sliding variable or state stops being finite, or whose speed
exceeds ``qd_limit``, records ``[code, sample, joint]`` as ``run_one`` would, stops writing
outputs, and is reset to its initial state so that its garbage cannot slow the block (denormals,
overflow); when every lane has failed or finished the block returns. A lane of the planar kind
with positive masses has positive ABA pivots for any finite state, so the singular-matrix code
is reached only with a non-finite state, which is reported as such first.

**Metrics** (``record`` other than ``"full"``): the kernel streams per lane what
:func:`slidingarm.results.metric_values` computes from the traces (sums by Neumaier's
compensated summation, maxima, the last sample outside a band and its neighbour for the
reaching and settling times); :func:`finish_metrics` turns them into the metrics by the very
formulas of :mod:`slidingarm.metrics`. The one metric that cannot stream is the FFT measure
``hf_power_share``: for it the kernel keeps each run's torque trace ``(T, n)`` only.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from slidingarm import _engine as E
from slidingarm.control import _kernels as CK

#: Lanes of a block: eight float64, one AVX-512 register.
W = 8

#: The elementary functions of the block loop. They must be those of the scalar loop
#: (:mod:`slidingarm.models._kernels`, :mod:`slidingarm.control._kernels`) for bit-identical
#: runs.
sin = math.sin
cos = math.cos
tanh = math.tanh


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def pow_abs(x: float, g: float) -> float:
    """:math:`|x|^g` as the scalar law computes it (``abs(x) ** g``)."""
    return abs(x) ** g


# ---------------------------------------------------------------------- workspace rows (n, W)
_Q = 0
_QD = 1
_QM = 2
_QDM = 3
_QMP = 4
_Z0 = 5
_ST = 6  # super-twisting integral w
_TAPP = 7  # held input tau + d
_S = 8
_NU = 9
_ACC = 10
_TAU = 11
_LC = 12  # law's cos / sin of the measured absolute angles
_LS = 13
_R2 = 14  # RNEA rows 2-4
_R3 = 15
_R4 = 16
_K0 = 17  # 4 RK4 stages
_DQ = 21
_QT = 22
_VT = 23
_BC = 24  # base cos / sin of the step's start
_BS = 25
_AC = 26  # stage cos / sin
_AS = 27
_A2 = 28  # ABA rows 2-6
_DC = 33  # direct cos / sin of a stage (when a lane's step is large)
_DS = 34
_EPSG = 35  # eps_e ** (gamma - 1) per joint
_TMP = 36  # |e| / pow results
_TMP2 = 37
_TMP3 = 38
WS_ROWS = 39

# lane scalars (rows of (NLV, W))
_L_PHI = 0
_L_W = 1
_L_WD = 2
_L_AX = 3
_L_AY = 4
_L_FX = 5
_L_FY = 6
_L_MOM = 7
_L_OK = 8  # RK4 pivots all positive (1.0 / 0.0)
_L_ALIVE = 9
_L_DELTA = 10
_L_FAR = 11
_L_BAD = 12
_L_CODE = 13
_L_JOINT = 14
_L_EXACT = 15
_L_T = 16  # ABA pass temporaries
_NLV = 40

# metric accumulators (rows of (NACC, n, W))
M_SE2 = 0  # sum of e^2 (Neumaier: sum, compensation)
M_SE2C = 1
M_IAE = 2  # sum of (|e_k| + |e_k-1|)(t_k - t_k-1)
M_IAEC = 3
M_ITAE = 4
M_ITAEC = 5
M_EFF = 6  # sum of tau_k^2 (t_k+1 - t_k), k <= T-2
M_EFFC = 7
M_CHAT = 8  # sum of |tau_k - tau_k-1|, 1 <= k <= T-2
M_CHATC = 9
M_PEAK = 10  # max |tau_k|, k <= T-2
M_SSE = 11  # max |e_k|, k >= start
M_FINAL = 12  # e_T-1
M_S_LAST = 13  # last sample with |s| > delta_s (-1: none), s there and at the next sample
M_S_XK = 14
M_S_XK1 = 15
M_E_LAST = 16
M_E_XK = 17
M_E_XK1 = 18
M_PAE = 19  # previous |e|, (t - t0)|e|, tau
M_PWE = 20
M_PTAU = 21
NACC = 22


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _sgn(x: float) -> float:
    return 1.0 if x > 0.0 else (-1.0 if x < 0.0 else 0.0)


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _neumaier(acc: np.ndarray, row: int, j: int, ln: int, x: float) -> None:
    """Add ``x`` to the compensated sum in rows ``row`` (sum), ``row + 1`` (compensation)."""
    s = acc[row, j, ln]
    t = s + x
    big = abs(s) >= abs(x)
    acc[row + 1, j, ln] += ((s - t) + x) if big else ((x - t) + s)
    acc[row, j, ln] = t


@njit(cache=True, nogil=True, error_model="numpy")
def _angles(ws: np.ndarray, lv: np.ndarray, src: int, rc: int, rs: int, n: int) -> None:
    """Cosines and sines of the absolute angles of ``ws[src]`` into rows ``rc``, ``rs``
    (:func:`slidingarm.models._kernels.angles_into` per lane)."""
    for ln in range(W):
        lv[_L_PHI, ln] = 0.0
    for i in range(n):
        for ln in range(W):
            lv[_L_PHI, ln] += ws[src, i, ln]
        for ln in range(W):
            ws[rc, i, ln] = cos(lv[_L_PHI, ln])
        for ln in range(W):
            ws[rs, i, ln] = sin(lv[_L_PHI, ln])


@njit(cache=True, nogil=True, error_model="numpy")
def _rnea(arm: np.ndarray, g: np.ndarray, ws: np.ndarray, lv: np.ndarray, n: int) -> None:
    """Planar RNEA per lane (:func:`slidingarm.models._kernels._rnea_from_angles` with
    ``qdd_scale = 1``): ``tau = M(qm) acc + h(qm, qdm)`` into row ``_TAU``, from the angles in
    rows ``_LC``, ``_LS``."""
    for ln in range(W):
        lv[_L_W, ln] = 0.0
        lv[_L_WD, ln] = 0.0
        lv[_L_AX, ln] = 0.0
        lv[_L_AY, ln] = g[ln]
    for i in range(n):
        for ln in range(W):
            w = lv[_L_W, ln] + ws[_QDM, i, ln]
            wd = lv[_L_WD, ln] + ws[_ACC, i, ln]
            c = arm[2, i, ln]
            l_i = arm[1, i, ln]
            cphi = ws[_LC, i, ln]
            sphi = ws[_LS, i, ln]
            ax = lv[_L_AX, ln]
            ay = lv[_L_AY, ln]
            ws[_R2, i, ln] = ax + wd * (-c * sphi) - w * w * c * cphi
            ws[_R3, i, ln] = ay + wd * (c * cphi) - w * w * c * sphi
            ws[_R4, i, ln] = wd
            lv[_L_AX, ln] = ax + wd * (-l_i * sphi) - w * w * l_i * cphi
            lv[_L_AY, ln] = ay + wd * (l_i * cphi) - w * w * l_i * sphi
            lv[_L_W, ln] = w
            lv[_L_WD, ln] = wd
    for ln in range(W):
        lv[_L_FX, ln] = 0.0
        lv[_L_FY, ln] = 0.0
        lv[_L_MOM, ln] = 0.0
    for i in range(n - 1, -1, -1):
        for ln in range(W):
            m = arm[0, i, ln]
            c = arm[2, i, ln]
            l_i = arm[1, i, ln]
            cphi = ws[_LC, i, ln]
            sphi = ws[_LS, i, ln]
            gx = m * ws[_R2, i, ln]
            gy = m * ws[_R3, i, ln]
            fx = lv[_L_FX, ln]
            fy = lv[_L_FY, ln]
            mom = (
                arm[3, i, ln] * ws[_R4, i, ln]
                + c * (cphi * gy - sphi * gx)
                + l_i * (cphi * fy - sphi * fx)
                + lv[_L_MOM, ln]
            )
            lv[_L_FX, ln] = fx + gx
            lv[_L_FY, ln] = fy + gy
            lv[_L_MOM, ln] = mom
            ws[_TAU, i, ln] = mom


@njit(cache=True, nogil=True, error_model="numpy")
def _aba(
    arm: np.ndarray, g: np.ndarray, ws: np.ndarray, lv: np.ndarray, n: int, kout: int
) -> None:
    """Planar ABA per lane (:func:`slidingarm.models._kernels.aba_from_angles_into`): the
    acceleration at velocity row ``_VT`` and input row ``_TAPP`` into row ``kout``, from the
    angles in rows ``_AC``, ``_AS``; a pivot that is not positive clears ``lv[_L_OK]``."""
    A2 = _A2
    A3 = _A2 + 1
    A4 = _A2 + 2
    A5 = _A2 + 3
    A6 = _A2 + 4
    for ln in range(W):
        lv[_L_W, ln] = 0.0
        lv[_L_T, ln] = 0.0  # vx
        lv[_L_T + 1, ln] = 0.0  # vy
    for i in range(n):
        for ln in range(W):
            w = lv[_L_W, ln] + ws[_VT, i, ln]
            vx = lv[_L_T, ln]
            vy = lv[_L_T + 1, ln]
            ws[A2, i, ln] = w
            ws[A3, i, ln] = vx
            ws[A4, i, ln] = vy
            lv[_L_T, ln] = vx - w * arm[1, i, ln] * ws[_AS, i, ln]
            lv[_L_T + 1, ln] = vy + w * arm[1, i, ln] * ws[_AC, i, ln]
            lv[_L_W, ln] = w
    # child's articulated inertia ca..cf (rows _L_T .. _L_T+5), bias p0..p2 (_L_T+6 ..)
    for ln in range(W):
        for r in range(9):
            lv[_L_T + r, ln] = 0.0
    for i in range(n - 1, -1, -1):
        for ln in range(W):
            ca = lv[_L_T, ln]
            cb = lv[_L_T + 1, ln]
            cc = lv[_L_T + 2, ln]
            cd = lv[_L_T + 3, ln]
            ce = lv[_L_T + 4, ln]
            cf = lv[_L_T + 5, ln]
            p0 = lv[_L_T + 6, ln]
            p1 = lv[_L_T + 7, ln]
            p2 = lv[_L_T + 8, ln]
            m = arm[0, i, ln]
            c = arm[2, i, ln]
            wi = ws[A2, i, ln]
            vxi = ws[A3, i, ln]
            vyi = ws[A4, i, ln]
            ia = arm[3, i, ln] + m * c * c
            ib = -m * c * ws[_AS, i, ln]
            ic = m * c * ws[_AC, i, ln]
            fx = ib * wi + m * vxi
            fy = ic * wi + m * vyi
            d = ia + ca
            ib += cb
            ic += cc
            dd = m + cd
            de = ce
            df = m + cf
            pa0 = vxi * fy - vyi * fx + p0
            pa1 = -wi * fy + p1
            pa2 = wi * fx + p2
            lv[_L_OK, ln] = lv[_L_OK, ln] if d > 0.0 else 0.0
            dinv = 1.0 / d
            u = ws[_TAPP, i, ln] - pa0
            ws[kout, i, ln] = u
            qdi = ws[_VT, i, ln]
            cvx = vyi * qdi
            cvy = -vxi * qdi
            ws[A2, i, ln] = dinv
            ws[A3, i, ln] = cvx
            ws[A4, i, ln] = cvy
            ws[A5, i, ln] = ib
            ws[A6, i, ln] = ic
            if i > 0:
                bd = ib * dinv
                cdv = ic * dinv
                dd -= ib * bd
                de -= ib * cdv
                df -= ic * cdv
                ud = u * dinv
                pa1 += dd * cvx + de * cvy + ib * ud
                pa2 += de * cvx + df * cvy + ic * ud
                rx = arm[1, i - 1, ln] * ws[_AC, i - 1, ln]
                ry = arm[1, i - 1, ln] * ws[_AS, i - 1, ln]
                cb = rx * de - ry * dd
                cc = rx * df - ry * de
                lv[_L_T, ln] = rx * cc - ry * cb
                lv[_L_T + 1, ln] = cb
                lv[_L_T + 2, ln] = cc
                lv[_L_T + 3, ln] = dd
                lv[_L_T + 4, ln] = de
                lv[_L_T + 5, ln] = df
                lv[_L_T + 6, ln] = ws[_TAPP, i, ln] + rx * pa2 - ry * pa1
                lv[_L_T + 7, ln] = pa1
                lv[_L_T + 8, ln] = pa2
    # pass 3: alpha (_L_T), ax (_L_T+1), ay (_L_T+2)
    for ln in range(W):
        lv[_L_T, ln] = 0.0
        lv[_L_T + 1, ln] = 0.0
        lv[_L_T + 2, ln] = g[ln]
    for i in range(n):
        for ln in range(W):
            alpha = lv[_L_T, ln]
            ax = lv[_L_T + 1, ln]
            ay = lv[_L_T + 2, ln]
            if i > 0:
                ax += ws[A3, i, ln] - alpha * arm[1, i - 1, ln] * ws[_AS, i - 1, ln]
                ay += ws[A4, i, ln] + alpha * arm[1, i - 1, ln] * ws[_AC, i - 1, ln]
            alpha_i = (ws[kout, i, ln] - ws[A5, i, ln] * ax - ws[A6, i, ln] * ay) * ws[A2, i, ln]
            ws[kout, i, ln] = alpha_i - alpha
            lv[_L_T, ln] = alpha_i
            lv[_L_T + 1, ln] = ax
            lv[_L_T + 2, ln] = ay


_R6 = 1.0 / 6.0
_R12 = 1.0 / 12.0
_R20 = 1.0 / 20.0
_R30 = 1.0 / 30.0
_R42 = 1.0 / 42.0
_R56 = 1.0 / 56.0


@njit(cache=True, nogil=True, error_model="numpy")
def _stage_angles(ws: np.ndarray, lv: np.ndarray, n: int) -> None:
    """Angles of row ``_QT`` into ``_AC``, ``_AS``: the base angles rotated by the summed
    steps ``_DQ`` (:func:`slidingarm.models._kernels.shifted_angles_into` per lane); where a
    lane's summed step exceeds ``2**-5`` its sines and cosines are computed directly."""
    anyfar = False
    for ln in range(W):
        lv[_L_DELTA, ln] = 0.0
        lv[_L_FAR, ln] = 0.0
    for i in range(n):
        for ln in range(W):
            delta = lv[_L_DELTA, ln] + ws[_DQ, i, ln]
            lv[_L_DELTA, ln] = delta
            lv[_L_FAR, ln] = lv[_L_FAR, ln] if abs(delta) <= 0.03125 else 1.0
    for ln in range(W):
        anyfar |= lv[_L_FAR, ln] != 0.0
    if anyfar:
        _angles(ws, lv, _QT, _DC, _DS, n)
    for ln in range(W):
        lv[_L_DELTA, ln] = 0.0
    for i in range(n):
        for ln in range(W):
            delta = lv[_L_DELTA, ln] + ws[_DQ, i, ln]
            lv[_L_DELTA, ln] = delta
            c = ws[_BC, i, ln]
            s = ws[_BS, i, ln]
            d2 = delta * delta
            sin_d = delta * (1.0 - d2 * _R6 * (1.0 - d2 * _R20 * (1.0 - d2 * _R42)))
            cos_m1 = -0.5 * d2 * (1.0 - d2 * _R12 * (1.0 - d2 * _R30 * (1.0 - d2 * _R56)))
            ws[_AC, i, ln] = c + (c * cos_m1 - s * sin_d)
            ws[_AS, i, ln] = s + (s * cos_m1 + c * sin_d)
        if anyfar:
            for ln in range(W):
                far = lv[_L_FAR, ln] != 0.0
                ws[_AC, i, ln] = ws[_DC, i, ln] if far else ws[_AC, i, ln]
                ws[_AS, i, ln] = ws[_DS, i, ln] if far else ws[_AS, i, ln]


@njit(cache=True, nogil=True, error_model="numpy")
def _rk4(
    arm: np.ndarray, g: np.ndarray, ws: np.ndarray, lv: np.ndarray, n: int, h: float,
    known: bool,
) -> None:  # fmt: skip
    """One RK4 step of every lane (:func:`slidingarm.models._kernels.rk4_step`); ``known``:
    rows ``_LC``, ``_LS`` hold the angles of ``_Q`` already."""
    if known:
        for i in range(n):
            for ln in range(W):
                ws[_BC, i, ln] = ws[_LC, i, ln]
                ws[_BS, i, ln] = ws[_LS, i, ln]
    else:
        _angles(ws, lv, _Q, _BC, _BS, n)
    for i in range(n):
        for ln in range(W):
            ws[_AC, i, ln] = ws[_BC, i, ln]
            ws[_AS, i, ln] = ws[_BS, i, ln]
            ws[_VT, i, ln] = ws[_QD, i, ln]
    for s in range(4):
        if s > 0:
            c = 1.0 if s == 3 else 0.5
            for i in range(n):
                for ln in range(W):
                    qd = ws[_QD, i, ln]
                    v_prev = qd if s == 1 else qd + 0.5 * h * ws[_K0 + s - 2, i, ln]
                    dq = c * h * v_prev
                    ws[_DQ, i, ln] = dq
                    ws[_QT, i, ln] = ws[_Q, i, ln] + dq
                    ws[_VT, i, ln] = qd + c * h * ws[_K0 + s - 1, i, ln]
            _stage_angles(ws, lv, n)
        _aba(arm, g, ws, lv, n, _K0 + s)
    for i in range(n):
        for ln in range(W):
            qd = ws[_QD, i, ln]
            k0 = ws[_K0, i, ln]
            k1 = ws[_K0 + 1, i, ln]
            k2 = ws[_K0 + 2, i, ln]
            k3 = ws[_K0 + 3, i, ln]
            v1 = qd
            v2 = qd + 0.5 * h * k0
            v3 = qd + 0.5 * h * k1
            v4 = qd + h * k2
            ws[_Q, i, ln] += h / 6.0 * (v1 + 2.0 * v2 + 2.0 * v3 + v4)
            ws[_QD, i, ln] = qd + h / 6.0 * (k0 + 2.0 * k1 + 2.0 * k2 + k3)


@njit(cache=True, nogil=True, error_model="numpy")
def run_block(
    lanes: np.ndarray,
    local: np.ndarray,
    pp: np.ndarray,
    pg: np.ndarray,
    codes: np.ndarray,
    cf: np.ndarray,
    mp: np.ndarray,
    mg: np.ndarray,
    q0: np.ndarray,
    qd0: np.ndarray,
    tgrid: np.ndarray,
    q_ref: np.ndarray,
    qd_ref: np.ndarray,
    qdd_ref: np.ndarray,
    madd: np.ndarray,
    mhold: np.ndarray,
    vcode: int,
    vfb: np.ndarray,
    dist: np.ndarray,
    tmax: np.ndarray,
    dt: float,
    substeps: int,
    qd_limit: float,
    stride: int,
    q_b: np.ndarray,
    qd_b: np.ndarray,
    qm_b: np.ndarray,
    qdm_b: np.ndarray,
    tau_b: np.ndarray,
    s_b: np.ndarray,
    metrics: bool,
    bands: np.ndarray,
    acc: np.ndarray,
    tau_trace: np.ndarray,
    status: np.ndarray,
) -> None:
    """``W`` closed-loop runs of planar plants ``pp`` (4, n, W) (gravity ``pg`` (W,)) under
    the sliding-mode law with codes ``codes`` (``CK.NCI``,) and table ``cf`` (``CK.NCF``, n,
    W), nominal models ``mp``, ``mg``; see the module docstring.

    Lane ``ln`` is run ``lanes[ln]`` of the batch: it writes its recorded samples (every
    ``stride``-th; none if ``stride == 0``) to ``q_b[lanes[ln], k // stride]`` etc. (arrays
    ``(B, K, n)``), its status to ``status[lanes[ln]]`` and, if ``metrics``, its metric
    accumulators to ``acc[local[ln]]`` ((C, NACC, n)) and its torque to
    ``tau_trace[local[ln]]`` ((C, T, n)), ``local`` indexing the caller's chunk of runs. Two lanes may be the same run (a padded block): they
    compute and write the same values. ``madd``, ``mhold``, ``dist`` are ``(T, n, W)``, or
    ``(0, n, W)`` when no lane has any (then the measurement is ``q + 0.0``, the input ``tau +
    0.0``, as the scalar loop computes with its zero arrays). ``bands`` is ``(delta_s, delta_e,
    start)``: the metrics' bands and the first sample of the steady-state window.
    """
    q_ref = E._borrow(q_ref)
    qd_ref = E._borrow(qd_ref)
    qdd_ref = E._borrow(qdd_ref)
    madd = E._borrow(madd)
    mhold = E._borrow(mhold)
    dist = E._borrow(dist)
    pp = E._borrow(pp)
    mp = E._borrow(mp)
    cf = E._borrow(cf)
    vfb = E._borrow(vfb)
    tmax = E._borrow(tmax)
    acc = E._borrow(acc)
    tau_trace = E._borrow(tau_trace)
    q_b = E._borrow(q_b)
    qd_b = E._borrow(qd_b)
    qm_b = E._borrow(qm_b)
    qdm_b = E._borrow(qdm_b)
    tau_b = E._borrow(tau_b)
    s_b = E._borrow(s_b)
    nt = tgrid.shape[0]
    n = q0.shape[0]
    h = dt / substeps
    has_add = madd.shape[0] > 0
    has_hold = mhold.shape[0] > 0
    has_dist = dist.shape[0] > 0
    wsa = np.zeros((WS_ROWS, n, W))
    lva = np.zeros((_NLV, W))
    acca = np.zeros((NACC, n, W))
    ws = E._borrow(wsa)
    lv = E._borrow(lva)
    ac = E._borrow(acca)
    fast_terminal = codes[CK.CI_SURFACE] == CK.SURFACE_FAST_TERMINAL
    swcode = codes[CK.CI_SWITCHING]
    classic = codes[CK.CI_REACHING] == CK.REACH_CLASSIC
    delta_s = bands[0]
    delta_e = bands[1]
    start = int(bands[2])
    for j in range(n):
        for ln in range(W):
            ws[_Q, j, ln] = q0[j, ln]
            ws[_QD, j, ln] = qd0[j, ln]
            ws[_ST, j, ln] = 0.0
            ws[_EPSG, j, ln] = cf[CK.CF_EPS_E, j, ln] ** (cf[CK.CF_GAMMA, j, ln] - 1.0)
            ac[M_S_LAST, j, ln] = -1.0
            ac[M_E_LAST, j, ln] = -1.0
    for ln in range(W):
        lv[_L_ALIVE, ln] = 1.0
        status[lanes[ln], 0] = E.STATUS_OK
        status[lanes[ln], 1] = -1
        status[lanes[ln], 2] = -1
    t0 = tgrid[0]
    for k in range(nt):
        # --- measurement
        for j in range(n):
            for ln in range(W):
                add = madd[k, j, ln] if has_add else 0.0
                v = ws[_Q, j, ln] + add
                if has_hold:
                    v = ws[_QMP, j, ln] if (k > 0 and mhold[k, j, ln]) else v
                ws[_QM, j, ln] = v
        # --- velocity estimate
        if vcode == E.VEL_TRUE or k == 0:
            for j in range(n):
                for ln in range(W):
                    ws[_QDM, j, ln] = ws[_QD, j, ln]
                    if vcode != E.VEL_TRUE:
                        ws[_Z0, j, ln] = ws[_QM, j, ln]
        elif vcode == E.VEL_DIFFERENCE:
            for j in range(n):
                for ln in range(W):
                    ws[_QDM, j, ln] = (ws[_QM, j, ln] - ws[_QMP, j, ln]) / dt
        elif vcode == E.VEL_FILTERED:
            for j in range(n):
                for ln in range(W):
                    tf = vfb[E.VF_TIME_CONSTANT, j, ln]
                    ws[_QDM, j, ln] = (tf * ws[_QDM, j, ln] + (ws[_QM, j, ln] - ws[_QMP, j, ln])) / (
                        tf + dt
                    )
        else:
            for j in range(n):
                for ln in range(W):
                    lip = vfb[E.VF_LIPSCHITZ, j, ln]
                    sigma = ws[_Z0, j, ln] - ws[_QM, j, ln]
                    sg = _sgn(sigma)
                    qdm = ws[_QDM, j, ln]
                    ws[_Z0, j, ln] += dt * (
                        -vfb[E.VF_LAMBDA1, j, ln] * math.sqrt(lip * abs(sigma)) * sg + qdm
                    )
                    ws[_QDM, j, ln] = qdm + dt * (-vfb[E.VF_LAMBDA0, j, ln] * lip * sg)
        exact = True
        for j in range(n):
            for ln in range(W):
                ws[_QMP, j, ln] = ws[_QM, j, ln]
                exact &= ws[_QM, j, ln] == ws[_Q, j, ln]
        # --- surface (s, nu) of every joint
        for j in range(n):
            qr = q_ref[k, j]
            qdr = qd_ref[k, j]
            if fast_terminal:
                for ln in range(W):
                    ws[_TMP, j, ln] = ws[_QM, j, ln] - qr
                for ln in range(W):
                    ws[_TMP2, j, ln] = pow_abs(ws[_TMP, j, ln], cf[CK.CF_GAMMA, j, ln])
                for ln in range(W):
                    ej = ws[_TMP, j, ln]
                    edj = ws[_QDM, j, ln] - qdr
                    alpha = cf[CK.CF_ALPHA, j, ln]
                    beta = cf[CK.CF_BETA, j, ln]
                    gamma = cf[CK.CF_GAMMA, j, ln]
                    eps_e = cf[CK.CF_EPS_E, j, ln]
                    pw = ws[_TMP2, j, ln]
                    ae = abs(ej)
                    s0 = edj + alpha * ej
                    s1 = s0 + beta * pw * _sgn(ej)
                    g_far = alpha + beta * gamma * pw / ae
                    g_near = alpha + beta * gamma * ws[_EPSG, j, ln]
                    g1 = g_far if ae >= eps_e else g_near
                    s = s1 if beta != 0.0 else s0
                    gain = g1 if beta != 0.0 else alpha
                    ws[_S, j, ln] = s
                    ws[_NU, j, ln] = gain * edj
            else:
                for ln in range(W):
                    ws[_TMP, j, ln] = ws[_QDM, j, ln] - qdr
                for ln in range(W):
                    ws[_TMP2, j, ln] = pow_abs(ws[_TMP, j, ln], cf[CK.CF_GAMMA, j, ln])
                for ln in range(W):
                    ws[_TMP3, j, ln] = pow_abs(ws[_TMP, j, ln], 2.0 - cf[CK.CF_GAMMA, j, ln])
                for ln in range(W):
                    ej = ws[_QM, j, ln] - qr
                    sg = _sgn(ws[_TMP, j, ln])
                    beta = cf[CK.CF_BETA, j, ln]
                    gamma = cf[CK.CF_GAMMA, j, ln]
                    ws[_S, j, ln] = ej + ws[_TMP2, j, ln] * sg / beta
                    ws[_NU, j, ln] = beta / gamma * ws[_TMP3, j, ln] * sg
        # --- reaching term and commanded acceleration
        for j in range(n):
            if swcode == CK.SWITCH_TANH:
                for ln in range(W):
                    ws[_TMP, j, ln] = tanh(ws[_S, j, ln] / cf[CK.CF_WIDTH, j, ln])
            else:
                for ln in range(W):
                    s = ws[_S, j, ln]
                    x = s / cf[CK.CF_WIDTH, j, ln]
                    sat = 1.0 if x > 1.0 else (-1.0 if x < -1.0 else x)
                    ws[_TMP, j, ln] = _sgn(s) if swcode == CK.SWITCH_SIGN else sat
            qddr = qdd_ref[k, j]
            for ln in range(W):
                s = ws[_S, j, ln]
                phi = ws[_TMP, j, ln]
                kk = cf[CK.CF_K, j, ln]
                if classic:
                    r = kk * phi
                else:
                    r = kk * math.sqrt(abs(s)) * _sgn(s) + ws[_ST, j, ln]
                    ws[_ST, j, ln] += dt * cf[CK.CF_K2, j, ln] * phi
                ws[_ACC, j, ln] = qddr - ws[_NU, j, ln] - r
        # --- law = model: the nominal arm's inverse dynamics at the measured state
        _angles(ws, lv, _QM, _LC, _LS, n)
        _rnea(mp, mg, ws, lv, n)
        # --- clip, hold, record, check
        for ln in range(W):
            lv[_L_BAD, ln] = -1.0
        for j in range(n):
            for ln in range(W):
                t_j = ws[_TAU, j, ln]
                lim = tmax[j, ln]
                t_j = lim if t_j > lim else (-lim if t_j < -lim else t_j)
                ws[_TAU, j, ln] = t_j
                add = dist[k, j, ln] if has_dist else 0.0
                ws[_TAPP, j, ln] = t_j + add
                fin = math.isfinite(t_j) and math.isfinite(ws[_S, j, ln])
                lv[_L_BAD, ln] = j if (lv[_L_BAD, ln] < 0.0 and not fin) else lv[_L_BAD, ln]
        if stride > 0 and k % stride == 0:
            kk_ = k // stride
            for ln in range(W):
                if lv[_L_ALIVE, ln] != 0.0:
                    b = lanes[ln]
                    for j in range(n):
                        q_b[b, kk_, j] = ws[_Q, j, ln]
                        qd_b[b, kk_, j] = ws[_QD, j, ln]
                        qm_b[b, kk_, j] = ws[_QM, j, ln]
                        qdm_b[b, kk_, j] = ws[_QDM, j, ln]
                        tau_b[b, kk_, j] = ws[_TAU, j, ln]
                        s_b[b, kk_, j] = ws[_S, j, ln]
        if metrics:
            _stream_metrics(ac, ws, tgrid, q_ref, k, nt, n, t0, delta_s, delta_e, start)
            for ln in range(W):
                if lv[_L_ALIVE, ln] != 0.0:
                    b = local[ln]
                    for j in range(n):
                        tau_trace[b, k, j] = ws[_TAU, j, ln]
        nalive = 0
        for ln in range(W):
            if lv[_L_ALIVE, ln] != 0.0 and lv[_L_BAD, ln] >= 0.0:
                b = lanes[ln]
                status[b, 0] = E.STATUS_NONFINITE
                status[b, 1] = k
                status[b, 2] = int(lv[_L_BAD, ln])
                lv[_L_ALIVE, ln] = 0.0
            nalive += lv[_L_ALIVE, ln] != 0.0
        if nalive == 0 or k == nt - 1:
            break
        for ln in range(W):
            if lv[_L_ALIVE, ln] == 0.0:
                _reset_lane(ws, q0, qd0, n, ln)
        # --- plant over [t_k, t_k+1)
        for ln in range(W):
            lv[_L_OK, ln] = 1.0
        for sub in range(substeps):
            _rk4(pp, pg, ws, lv, n, h, exact and sub == 0, )
        # --- status (check_state per lane)
        for ln in range(W):
            lv[_L_CODE, ln] = E.STATUS_OK
            lv[_L_JOINT, ln] = -1.0
        for j in range(n):
            for ln in range(W):
                fin = math.isfinite(ws[_Q, j, ln]) and math.isfinite(ws[_QD, j, ln])
                first = lv[_L_CODE, ln] == E.STATUS_OK and not fin
                lv[_L_CODE, ln] = E.STATUS_NONFINITE if first else lv[_L_CODE, ln]
                lv[_L_JOINT, ln] = j if first else lv[_L_JOINT, ln]
        for ln in range(W):
            sing = lv[_L_CODE, ln] == E.STATUS_OK and lv[_L_OK, ln] == 0.0
            lv[_L_CODE, ln] = E.STATUS_SINGULAR if sing else lv[_L_CODE, ln]
            lv[_L_JOINT, ln] = 0.0 if sing else lv[_L_JOINT, ln]
        for j in range(n):
            for ln in range(W):
                run = lv[_L_CODE, ln] == E.STATUS_OK and abs(ws[_QD, j, ln]) > qd_limit
                lv[_L_CODE, ln] = E.STATUS_RUNAWAY if run else lv[_L_CODE, ln]
                lv[_L_JOINT, ln] = j if run else lv[_L_JOINT, ln]
        nalive = 0
        for ln in range(W):
            if lv[_L_ALIVE, ln] != 0.0 and lv[_L_CODE, ln] != E.STATUS_OK:
                b = lanes[ln]
                status[b, 0] = int(lv[_L_CODE, ln])
                status[b, 1] = k + 1
                status[b, 2] = int(lv[_L_JOINT, ln])
                lv[_L_ALIVE, ln] = 0.0
            if lv[_L_ALIVE, ln] == 0.0:
                _reset_lane(ws, q0, qd0, n, ln)
            nalive += lv[_L_ALIVE, ln] != 0.0
        if nalive == 0:
            break
    if metrics:
        for ln in range(W):
            if lv[_L_ALIVE, ln] != 0.0:
                b = local[ln]
                for r in range(NACC):
                    for j in range(n):
                        acc[b, r, j] = ac[r, j, ln]


@njit(cache=True, nogil=True, error_model="numpy")
def _reset_lane(ws: np.ndarray, q0: np.ndarray, qd0: np.ndarray, n: int, ln: int) -> None:
    """A failed lane restarts from its initial state: finite, so it costs what a live lane
    costs; nothing it computes is written any more."""
    for j in range(n):
        ws[_Q, j, ln] = q0[j, ln]
        ws[_QD, j, ln] = qd0[j, ln]
        ws[_QM, j, ln] = q0[j, ln]
        ws[_QMP, j, ln] = q0[j, ln]
        ws[_QDM, j, ln] = qd0[j, ln]
        ws[_Z0, j, ln] = q0[j, ln]
        ws[_ST, j, ln] = 0.0


@njit(cache=True, nogil=True, error_model="numpy")
def _stream_metrics(
    ac: np.ndarray,
    ws: np.ndarray,
    tgrid: np.ndarray,
    q_ref: np.ndarray,
    k: int,
    nt: int,
    n: int,
    t0: float,
    delta_s: float,
    delta_e: float,
    start: int,
) -> None:
    """Sample ``k``'s part of every streamed metric (see :func:`finish_metrics`)."""
    tk = tgrid[k]
    dtk = tgrid[k] - tgrid[k - 1] if k > 0 else 0.0
    dtn = tgrid[k + 1] - tgrid[k] if k < nt - 1 else 0.0
    wt = tk - t0
    for j in range(n):
        qr = q_ref[k, j]
        for ln in range(W):
            e = ws[_Q, j, ln] - qr
            ae = abs(e)
            we = wt * ae
            tau = ws[_TAU, j, ln]
            s = ws[_S, j, ln]
            _neumaier(ac, M_SE2, j, ln, e * e)
            if k > 0:
                _neumaier(ac, M_IAE, j, ln, (ae + ac[M_PAE, j, ln]) * dtk)
                _neumaier(ac, M_ITAE, j, ln, (we + ac[M_PWE, j, ln]) * dtk)
            ac[M_PAE, j, ln] = ae
            ac[M_PWE, j, ln] = we
            if k < nt - 1:
                _neumaier(ac, M_EFF, j, ln, tau * tau * dtn)
                ac[M_PEAK, j, ln] = max(ac[M_PEAK, j, ln], abs(tau))
                if k > 0:
                    _neumaier(ac, M_CHAT, j, ln, abs(tau - ac[M_PTAU, j, ln]))
                ac[M_PTAU, j, ln] = tau
            if k >= start:
                ac[M_SSE, j, ln] = max(ac[M_SSE, j, ln], ae)
            ac[M_FINAL, j, ln] = e
            # last sample outside the band, the value there and at the next sample
            so = abs(s) > delta_s
            ac[M_S_XK1, j, ln] = s if k == ac[M_S_LAST, j, ln] + 1.0 else ac[M_S_XK1, j, ln]
            ac[M_S_LAST, j, ln] = k if so else ac[M_S_LAST, j, ln]
            ac[M_S_XK, j, ln] = s if so else ac[M_S_XK, j, ln]
            ac[M_S_XK1, j, ln] = s if so else ac[M_S_XK1, j, ln]
            eo = ae > delta_e
            ac[M_E_XK1, j, ln] = e if k == ac[M_E_LAST, j, ln] + 1.0 else ac[M_E_XK1, j, ln]
            ac[M_E_LAST, j, ln] = k if eo else ac[M_E_LAST, j, ln]
            ac[M_E_XK, j, ln] = e if eo else ac[M_E_XK, j, ln]
            ac[M_E_XK1, j, ln] = e if eo else ac[M_E_XK1, j, ln]


def _entry_time(t: np.ndarray, last: np.ndarray, xk: np.ndarray, xk1: np.ndarray, delta: float) -> np.ndarray:
    """:func:`slidingarm.metrics._entry_time` from the streamed last sample outside the band
    (``-1``: none) and the values there and at the next sample: the same formulas."""
    nt = t.shape[0]
    any_out = last >= 0
    li = np.where(any_out, last, nt - 1).astype(np.int64)
    nxt = np.minimum(li + 1, nt - 1)
    level = np.sign(xk) * delta
    denom = xk - xk1
    safe = np.where(denom == 0.0, 1.0, denom)
    frac = np.clip((xk - level) / safe, 0.0, 1.0)
    t_cross = t[li] + frac * (t[nxt] - t[li])
    out = np.where(any_out, t_cross, t[0])
    out = np.where(any_out & (li == nt - 1), np.inf, out)
    return np.asarray(out, dtype=np.float64)


def finish_metrics(
    t: np.ndarray,
    acc: np.ndarray,
    tau_trace: np.ndarray,
    failed: np.ndarray,
    *,
    delta_s: float,
    delta_e: float,
    cutoff_hz: float,
) -> dict[str, np.ndarray]:
    """The metrics of :func:`slidingarm.results.metric_values` from the streamed accumulators
    ``acc`` (B, NACC, n) and the applied torques ``tau_trace`` (B, T, n) (its last row unused),
    NaN for ``failed`` runs."""
    from slidingarm.metrics import hf_power_share

    nt = t.shape[0]

    def total(row: int) -> np.ndarray:
        return np.asarray(acc[:, row] + acc[:, row + 1])

    mse = total(M_SE2) / nt
    ok = ~failed
    trace = np.where(ok[:, None, None], tau_trace, 0.0) if failed.any() else tau_trace
    table = {
        "mse": mse,
        "rmse": np.sqrt(mse),
        "iae": 0.5 * total(M_IAE),
        "itae": 0.5 * total(M_ITAE),
        "reaching_time": _entry_time(t, acc[:, M_S_LAST], acc[:, M_S_XK], acc[:, M_S_XK1], delta_s),
        "settling_time": _entry_time(t, acc[:, M_E_LAST], acc[:, M_E_XK], acc[:, M_E_XK1], delta_e),
        "steady_state_error": np.array(acc[:, M_SSE]),
        "final_error": np.array(acc[:, M_FINAL]),
        "control_effort": total(M_EFF),
        "peak_torque": np.array(acc[:, M_PEAK]),
        "chattering": total(M_CHAT) / (t[-1] - t[0]),
        "hf_power_share": hf_power_share(t, trace, cutoff_hz=cutoff_hz),
    }
    out = {}
    for name, v in table.items():
        arr = np.array(v, dtype=np.float64)
        arr[failed] = np.nan
        out[name] = arr
    return out


def steady_start(t: np.ndarray, window: float) -> int:
    """First sample of :func:`slidingarm.metrics.steady_state_error`'s final window."""
    tol = 1e-9 * (t[-1] - t[0])
    return int(np.searchsorted(t, t[-1] - window - tol, side="left"))
