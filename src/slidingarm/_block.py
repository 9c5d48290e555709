"""The closed loop of :mod:`slidingarm._engine`, advancing a block of ``W`` runs together.

:func:`run_block` is :func:`slidingarm._engine.run_one` for :data:`W` runs at once, for the
planar kind (plant and nominal model) and the built-in sliding-mode law, ``law = "model"``
and the paper's ``law = "paper"`` (:func:`_paper_law`), and for the serial kind with
``law = "model"`` (:func:`_rk4_serial`, :func:`_serial_torque`; the kind and the law are the
type of a tag argument, :data:`MODEL_TAG`): every surface, switching function and
reaching law of
:func:`slidingarm.control._kernels.control_into`, every velocity estimator, the held and added
measurement arrays, torque disturbances, torque limits and ``substeps``. The law's codes, the
velocity estimator and ``substeps`` are the same for every lane of a block (the caller groups
runs by them), so their branches are uniform.

**Layout.** Everything a lane's loop touches (state, parameters, scratch, metric
accumulators) lives in one flat float64 workspace, structure of arrays: lane scalars at
``ws[_L_X + ln]``, joint ``i``'s rows at ``ws[J0 + i JS + _X + ln]`` with every ``_X`` a
multiple of ``W``, the lane index ``ln`` innermost and contiguous. Every lane loop is ``for ln
in range(W)`` with ``W`` a compile-time constant and a branch-free body (a per-lane choice is a
select between two computed values: one-level conditionals and ``&`` of conditions, since a
nested conditional or a short-circuit ``and`` stays a branch, :func:`_sgn`). One array and
offsets that differ by compile-time constants let LLVM prove that a loop's stores do not alias
its loads, so its SLP vectoriser turns each unrolled lane loop into ``<16 x double>``
operations (several arrays, or rows strided by a run-time stride, defeat that proof and
nothing vectorises). numba leaves the SLP vectoriser off by default; :func:`compiled` turns it
on for this module's compilation only. The joint count ``n`` is a compile-time constant too
(a kernel per joint count, :func:`compiled`): the loops over joints unroll, and what one
joint's iteration leaves for the next stays in registers instead of the workspace. A lane
loop that calls libm (``math.sin``, ``cos``, ``tanh``, ``pow``) stays scalar, so those calls
have loops of their own and the arithmetic around them still vectorises. The two passes that
hand many values from joint to joint, the articulated-body algorithm (the plant's, and the
nominal model's in the paper's law) and the nominal model's RNEA, have the other form: one lane loop whose body is the whole pass over the joints
with its values in local variables (source generated per joint count, :func:`_aba_source`,
:func:`_rnea_source`); LLVM's loop vectoriser turns it into ``<8 x double>`` code that keeps
those values in registers instead of storing each to the workspace and loading it back.

**Results.** For the planar kind, each lane computes exactly what
:func:`~slidingarm._engine.run_one` computes for its run: the same floating-point operations in the same order, with the same elementary
functions, and no ``fastmath`` flag on any operation: lanes are independent, so vectorising
needs no reassociation, and without ``contract`` no multiply-add is fused where the scalar loop
does not fuse one. A run's trajectory is therefore bit-identical to the scalar path's,
whatever lane or block it lands in and whatever the thread count: no value crosses lanes. The
only block-wide decisions are whether *any* lane needs something (the direct sines and cosines
of a large RK4 stage step, a measurement that differed from the state), and a lane that does
not need it discards it by a select, so it computes what it would alone. For the serial kind
a lane agrees with the per-run loop to rounding, not bit for bit (the comment heading the
serial kind's kernels says why); it is still independent of the other lanes, the block size
and the thread count.

**Status.** A lane whose torque, sliding variable or state stops being finite, or whose speed
exceeds ``qd_limit``, records ``[code, sample, joint]`` as ``run_one`` would, stops writing
outputs (but the torque trace of the spectral metric, whose failed runs :func:`finish_metrics`
clears) and restarts from its initial state (finite values cost what live ones cost); when
every lane has failed the block returns. ``run_one``'s ABA returns early at a pivot that is not
positive; the block computes on and only records the failure, which for a planar arm with
positive masses happens only with a non-finite state, reported as such first. A serial arm's
mass matrix can be singular at a finite state (a massless body at the tip): the block's
Cholesky takes 1 for such a pivot, so the state stays finite and the run is reported
singular, as the per-run loop reports it (:func:`_serial_solve_source`).

**Metrics** (``record`` other than ``"full"``): the kernel streams per lane what
:func:`slidingarm.results.metric_values` computes from the traces: the sums in plain partial
sums of :data:`FOLD` samples, each added to its total by Neumaier's compensated summation (a
rounding error of about ``FOLD eps`` of the terms' magnitudes, numpy's pairwise sums about
``log2(T) eps``: the two agree to rounding; a compensated addition at every sample made the
metrics phase of a block step about 70 ticks longer, some 2 % of the step, measured against
the RK4 phase in alternating runs), the maxima, and for the reaching and settling times the last sample outside the band with the
values there and at the next sample; :func:`finish_metrics` applies the formulas of
:mod:`slidingarm.metrics` to them. The FFT measure ``hf_power_share`` cannot stream: for it
the kernel writes each run's applied torques ``(n, T - 1)``, each joint's series contiguous
in time, and :func:`hf_power_share` computes it per block (the same formulas; the
detrending and the power sums compiled, ducc0's FFT between them, :func:`_spectra`).
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Iterator
from contextlib import contextmanager

import llvmlite.binding as _llvm
import numpy as np
from numba import njit
from numba import types as numba_types
from numba.core import config as _numba_config
from numba.core.compiler_lock import global_compiler_lock
from numba.extending import overload

from slidingarm import _engine as E
from slidingarm import _vecmath as VM
from slidingarm._gc import paused
from slidingarm.control import _kernels as CK
from slidingarm.models import _kernels as PK
from slidingarm.models import _spatial as SK

#: Lanes of a block: sixteen float64, two AVX-512 registers (or four AVX2 ones) per lane
#: loop. Two independent registers per operation hide the latency of the long dependent
#: chains (the ABA's passes down and up the arm, the divisions, the power's and tanh's
#: polynomials) that one register left exposed: the paper arm's block path ran 10-23 % more
#: arm-steps per second than with eight lanes (one thread, two processes side by side on the
#: two cores, swapped; 32 lanes gained nothing more), the UR5's about 6 % (3 of 4 pairs), and
#: the kernels compile no slower. Results do not depend on it: no value crosses lanes.
W = 16

#: The elementary functions of the block loop, inlined into its lane loops
#: (:mod:`slidingarm._vecmath`, at most 1 ulp each, no libm call): those the scalar loop calls
#: (:func:`slidingarm.models._kernels.sincos`, :func:`slidingarm.control._kernels.pow_abs`
#: and ``tanh`` for a planar nominal model), so that planar runs are bit-identical.
sincos = VM.sincos
pow_abs = VM.pow_abs
tanh = VM.tanh

_OPT = {"cache": True, "nogil": True, "error_model": "numpy"}


# A per-lane choice among three values is written as two one-level conditionals, and a
# conjunction of per-lane conditions as ``&``, not ``and``: LLVM turns a two-way conditional
# into a select, but a nested one (a three-way phi) and a short-circuit ``and`` stay branches,
# and a lane loop with a branch is not vectorised (measured: the law's surface and switching
# loops were scalar per lane, eight divisions each; the status checks were scalar too).


@njit(inline="always", **_OPT)
def _sgn(x: float) -> float:
    """``sign(x)`` in ``{-1, 0, 1}`` (``0`` for ``±0`` and NaN), as two selects: the bits of
    ``1.0 if x > 0 else (-1.0 if x < 0 else 0.0)``."""
    pos = 1.0 if x > 0.0 else 0.0
    neg = 1.0 if x < 0.0 else 0.0
    return pos - neg


@njit(inline="always", **_OPT)
def _clamp(x: float, lo: float, hi: float) -> float:
    """``x`` clamped to ``[lo, hi]`` (``lo <= hi``; NaN kept), as two selects: the bits of
    ``hi if x > hi else (lo if x < lo else x)``."""
    y = lo if x < lo else x
    return hi if x > hi else y


# lane scalars: ws[_L_X + ln]
_L_PHI = 0 * W
_L_OK = 1 * W
_L_ALIVE = 2 * W
_L_DELTA = 3 * W
_L_FAR = 4 * W
_L_BAD = 5 * W
_L_CODE = 6 * W
_L_JOINT = 7 * W
_L_G = 8 * W
_L_MG = 9 * W
_L_T0 = 10 * W
_L_T1 = 11 * W
# 1 / the tip's pivot (its rigid inertia about its joint, as the ABA forms it) of the plant
# and of the nominal model: constant in a run, so that the ABA does not divide by it
_L_PTIP = 12 * W
_L_MTIP = 13 * W
# whether a lane is outside a metric's band at this sample (:func:`_stream_metrics`)
_L_OUT = 14 * W
_NLV = 15
#: Start of the per-joint rows: ws[J0 + i JS + _X + ln] for joint i.
J0 = _NLV * W
_Q = 0 * W
_QD = 1 * W
_QM = 2 * W
_QDM = 3 * W
_QMP = 4 * W
_Z0 = 5 * W
_ST = 6 * W
_TAPP = 7 * W
_S = 8 * W
_NU = 9 * W
_ACC = 10 * W
_TAU = 11 * W
_LC = 12 * W
_LS = 13 * W
_K0 = 14 * W
_K1 = 15 * W
_K2 = 16 * W
_KX = 17 * W
_DQ = 18 * W
_QT = 19 * W
_VT = 20 * W
_BC = 21 * W
_BS = 22 * W
_AC = 23 * W
_AS = 24 * W
_DC = 25 * W
_DS = 26 * W
_EPSG = 27 * W
_TMP = 28 * W
_TMP2 = 29 * W
_TMP3 = 30 * W
_MADD = 31 * W
_MHOLD = 32 * W
_DIST = 33 * W
_PM = 34 * W
_PL = 35 * W
_PC = 36 * W
_PI = 37 * W
_MM = 38 * W
_ML = 39 * W
_MC = 40 * W
_MI = 41 * W
_CFA = 42 * W
_CFB = 43 * W
_CFG = 44 * W
_CFK = 45 * W
_CFW = 46 * W
_CFK2 = 47 * W
_CFE = 48 * W
_VF0 = 49 * W
_VF1 = 50 * W
_VF2 = 51 * W
_VF3 = 52 * W
_TMAX = 53 * W
_Q0 = 54 * W
_QD0 = 55 * W
# the paper's law (``law = "paper"``): its reaching term, a row of zeros (the input and the
# velocity of its forward dynamics), the solves' unit input and solution (also the serial
# plant's solve's right-hand side), and f = -M^{-1} h
_PR = 56 * W
_PZ = 57 * W
_PRHS = 58 * W
_PCOL = 59 * W
_PF = 60 * W
#: First metric accumulator row (rows M_* follow, per joint).
_MACC = 61
M_SE2 = 0
M_SE2C = 1
M_IAE = 2
M_IAEC = 3
M_ITAE = 4
M_ITAEC = 5
M_EFF = 6
M_EFFC = 7
M_CHAT = 8
M_CHATC = 9
M_PEAK = 10
M_SSE = 11
M_FINAL = 12
M_S_LAST = 13
M_S_XK = 14
M_S_XK1 = 15
M_E_LAST = 16
M_E_XK = 17
M_E_XK1 = 18
M_PAE = 19
M_PWE = 20
M_PTAU = 21
NACC = 22
#: The streamed sums' running partial sums (workspace rows after the accumulators, in the
#: order of :data:`_SUMS`), folded into the compensated sums every :data:`FOLD` samples.
_PART = _MACC + NACC
_NJR = _PART + 5
#: Stride of one joint's rows.
JS = _NJR * W
#: ``o & _NONNEG`` is ``o`` for any offset here, and tells LLVM that an index built on it is not
#: negative, so that numba's wraparound of negative indices (a compare and a select per
#: access, which also stops the vectoriser) compiles away.
_NONNEG = 2**40 - 1
_A_SE2 = (_MACC + M_SE2) * W
_A_SE2C = (_MACC + M_SE2C) * W
_A_IAE = (_MACC + M_IAE) * W
_A_IAEC = (_MACC + M_IAEC) * W
_A_ITAE = (_MACC + M_ITAE) * W
_A_ITAEC = (_MACC + M_ITAEC) * W
_A_EFF = (_MACC + M_EFF) * W
_A_EFFC = (_MACC + M_EFFC) * W
_A_CHAT = (_MACC + M_CHAT) * W
_P_SE2 = (_PART + 0) * W
_P_IAE = (_PART + 1) * W
_P_ITAE = (_PART + 2) * W
_P_EFF = (_PART + 3) * W
_P_CHAT = (_PART + 4) * W
#: The compensated sums of the metrics, in the order of their partial-sum rows.
_SUMS = (M_SE2, M_IAE, M_ITAE, M_EFF, M_CHAT)
#: Samples between two folds of the partial sums: each partial sum adds at most this many
#: terms in plain floating point, a rounding error of at most ``FOLD eps`` of their
#: magnitudes' sum, before Neumaier's summation adds it to its metric's total.
FOLD = 32
_A_CHATC = (_MACC + M_CHATC) * W
_A_PEAK = (_MACC + M_PEAK) * W
_A_SSE = (_MACC + M_SSE) * W
_A_FINAL = (_MACC + M_FINAL) * W
_A_S_LAST = (_MACC + M_S_LAST) * W
_A_S_XK = (_MACC + M_S_XK) * W
_A_S_XK1 = (_MACC + M_S_XK1) * W
_A_E_LAST = (_MACC + M_E_LAST) * W
_A_E_XK = (_MACC + M_E_XK) * W
_A_E_XK1 = (_MACC + M_E_XK1) * W
_A_PAE = (_MACC + M_PAE) * W
_A_PWE = (_MACC + M_PWE) * W
_A_PTAU = (_MACC + M_PTAU) * W


# the serial kind's rows (:func:`_serial_torque`, :func:`_rk4_serial`), after the mass matrix
# and its factor: lane scalars ws[_serial_base(n) + _SL_X + ln], then joint i's rows at
# ws[_serial_base(n) + _SL_END + i SJS + _SX + ln]
_SL_W = 0 * W  # 3: the body's angular velocity (RNEA), then 3: its linear velocity
_SL_B = 6 * W  # 3 + 3: its acceleration (RNEA)
_SL_F = 12 * W  # 6: a force carried down the chain (the mass matrix's entries)
_SL_END = 18 * W
_SP = 0 * W  # 26: the plant's table (slidingarm.models._spatial, joint-aligned)
_SM = 26 * W  # 26: the nominal model's table
_SR = 52 * W  # 9: R_pc
_SO = 61 * W  # 3: r, the body's origin in its parent
_SF = 64 * W  # 6: the body's force (RNEA)
_SC = 70 * W  # 10: its composite inertia (CRBA)
#: Stride of one joint's serial rows.
SJS = 80 * W
#: Rows of a serial kind's table that the block copies (the physical ones).
SERIAL_TABLE_ROWS = 26


@njit(inline="always", **_OPT)
def _serial_base(n: int) -> int:
    return J0 + n * JS + 2 * n * n * W


@njit(inline="always", **_OPT)
def workspace_size(n: int) -> int:
    """Length of the flat workspace of a block of ``n``-joint runs: the lane scalars, the
    joints' rows, a serial plant's mass matrix and its Cholesky factor (``n x n`` rows of
    ``W`` lanes each, :func:`_serial_forward`), then the serial kind's lane scalars and joint
    rows."""
    return _serial_base(n) + _SL_END + n * SJS


@njit(inline="always", **_OPT)
def _neumaier(ws: np.ndarray, at: int, x: float) -> None:
    """Add ``x`` to the compensated sum ``ws[at]`` (its compensation at ``ws[at + W]``)."""
    s = ws[at]
    t = s + x
    c1 = (s - t) + x
    c2 = (x - t) + s
    ws[at + W] += c1 if abs(s) >= abs(x) else c2
    ws[at] = t


@njit(forceinline=True, **_OPT)
def _angles_law(ws: np.ndarray, n: int) -> None:
    """Cosines and sines of the absolute angles of the measurement ``_QM`` into ``_LC``,
    ``_LS`` (:func:`slidingarm.models._kernels.angles_into` per lane)."""
    for ln in range(W):
        ws[_L_PHI + ln] = 0.0
    for i in range(n):
        o = (J0 + i * JS) & _NONNEG
        for ln in range(W):
            ws[_L_PHI + ln] += ws[o + _QM + ln]
        for ln in range(W):
            sv, cv = sincos(ws[_L_PHI + ln])
            ws[o + _LC + ln] = cv
            ws[o + _LS + ln] = sv


@njit(**_OPT)
def _angles_state(ws: np.ndarray, n: int) -> None:
    """Angles of the state ``_Q`` into the RK4 base rows ``_BC``, ``_BS``."""
    for ln in range(W):
        ws[_L_PHI + ln] = 0.0
    for i in range(n):
        o = (J0 + i * JS) & _NONNEG
        for ln in range(W):
            ws[_L_PHI + ln] += ws[o + _Q + ln]
        for ln in range(W):
            sv, cv = sincos(ws[_L_PHI + ln])
            ws[o + _BC + ln] = cv
            ws[o + _BS + ln] = sv


@njit(**_OPT)
def _angles_stage(ws: np.ndarray, n: int) -> None:
    """Angles of a stage's position ``_QT`` into ``_DC``, ``_DS``."""
    for ln in range(W):
        ws[_L_PHI + ln] = 0.0
    for i in range(n):
        o = (J0 + i * JS) & _NONNEG
        for ln in range(W):
            ws[_L_PHI + ln] += ws[o + _QT + ln]
        for ln in range(W):
            sv, cv = sincos(ws[_L_PHI + ln])
            ws[o + _DC + ln] = cv
            ws[o + _DS + ln] = sv


def _joint_row(i: int, x: int | str) -> str:
    """Source of joint ``i``'s entry of row ``x`` (an offset, or the name of an argument that
    holds one) at lane ``ln``, for the generated lane loops."""
    if isinstance(x, int):
        return f"ws[{J0 + i * JS + x} + ln]"
    return f"ws[{J0 + i * JS} + {x} + ln]"


def _rnea_source(n: int) -> str:
    """Source of the planar RNEA of the nominal model for ``n`` joints, per lane
    (:func:`slidingarm.models._kernels._rnea_from_angles`, ``qdd_scale = 1``, its operations
    in its order): :math:`\\tau = \\hat M(q_m)\\,a + \\hat h(q_m, \\dot q_m)` into
    ``_TAU``, from the angles in ``_LC``, ``_LS``, the velocities ``_QDM`` and the
    accelerations ``_ACC``. Pass 1 (base to tip) carries :math:`\\omega_i`,
    :math:`\\dot\\omega_i` and the joint's linear acceleration (gravity as the base's
    upward acceleration) and gives each body's centre-of-mass acceleration; pass 2 (tip to
    base) carries the force and sums the moments about each joint. One lane loop with scalar
    locals, as :func:`_aba_source` and for its reason: the passes hand on their values in
    registers."""
    row = _joint_row
    lines = ["def rnea(ws, joints):", f"    for ln in range({W}):"]
    add = lines.append
    ind = "        "
    add(ind + "w = 0.0")
    add(ind + "wd = 0.0")
    add(ind + "ax = 0.0")
    add(ind + f"ay = ws[{_L_MG} + ln]")
    for i in range(n):
        add(ind + f"w = w + {row(i, _QDM)}")
        add(ind + f"wd = wd + {row(i, _ACC)}")
        add(ind + f"c = {row(i, _MC)}")
        add(ind + f"l{i} = {row(i, _ML)}")
        add(ind + f"cphi{i} = {row(i, _LC)}")
        add(ind + f"sphi{i} = {row(i, _LS)}")
        add(ind + "ww = w * w")
        add(ind + f"r2_{i} = fma(-wd, c * sphi{i}, fma(-ww, c * cphi{i}, ax))")
        add(ind + f"r3_{i} = fma(wd, c * cphi{i}, fma(-ww, c * sphi{i}, ay))")
        add(ind + f"r4_{i} = wd")
        add(ind + f"ax = fma(-wd, l{i} * sphi{i}, fma(-ww, l{i} * cphi{i}, ax))")
        add(ind + f"ay = fma(wd, l{i} * cphi{i}, fma(-ww, l{i} * sphi{i}, ay))")
    add(ind + "fx = 0.0")
    add(ind + "fy = 0.0")
    add(ind + "mom = 0.0")
    for i in range(n - 1, -1, -1):
        add(ind + f"m = {row(i, _MM)}")
        add(ind + f"c = {row(i, _MC)}")
        add(ind + f"gx = m * r2_{i}")
        add(ind + f"gy = m * r3_{i}")
        add(ind + f"rc = fma(cphi{i}, gy, -(sphi{i} * gx))")
        add(ind + f"rl = fma(cphi{i}, fy, -(sphi{i} * fx))")
        add(ind + f"mom = fma({row(i, _MI)}, r4_{i}, fma(c, rc, fma(l{i}, rl, mom)))")
        add(ind + "fx = fx + gx")
        add(ind + "fy = fy + gy")
        add(ind + f"{row(i, _TAU)} = mom")
    return "\n".join(lines) + "\n"


def _rnea(ws: np.ndarray, joints: tuple[int, ...]) -> None:  # pragma: no cover - typed
    """:func:`_rnea_source` for ``len(joints)`` joints, generated when numba types it."""
    raise NotImplementedError("compiled only")


@overload(_rnea, jit_options={"nogil": True, "error_model": "numpy", "forceinline": True})
def _rnea_typed(ws, joints):  # type: ignore[no-untyped-def]
    scope: dict[str, object] = {"fma": VM._fma}
    exec(_rnea_source(len(joints)), scope)  # our own generated source
    return scope["rnea"]


# The step's phases are inlined by LLVM (``forceinline``; numba still compiles each body
# once): the plant's passes into the RK4 step, the law's pieces into the law, and RK4, the
# law and the metrics into run_block's loop. Called, each call saved and reloaded registers
# around a vzeroupper and kept values in the workspace. RK4 of a paper-arm block
# 1490-1590 -> 1300-1500 ticks with the first two, the whole block step -10 % more with the
# rest (bench_block_parts, two processes side by side); the same bits, and a cold compile of
# 12.4 instead of 15.9 CPU-s.
def _aba_source(n: int) -> str:
    """Source of the planar ABA for ``n`` joints, per lane
    (:func:`slidingarm.models._kernels.aba_from_angles_into`, its operations in its order):
    of the arm whose mass, length, centre-of-mass and inertia rows start at joint row
    ``prow`` (the plant's ``_PM`` or the nominal model's ``_MM``), the acceleration at the
    velocity in joint row ``vrow``, the input in ``trow``, the gravity in lane row ``grow``
    and the angles' cosines and sines in rows ``crow``, ``srow``, into row ``out``; a pivot
    that is not positive clears lane row ``okrow``.

    With :math:`\\omega_i = \\sum_{k \\le i} \\dot q_k` and the link vectors :math:`r_i = l_i
    (\\cos\\phi_i, \\sin\\phi_i)`, pass 1 carries the joint's linear velocity down the
    chain, pass 2 (tip to base) the articulated inertia :math:`(d, b, c; D)` and bias force
    of each body, moved to its parent through :math:`r_i`, and the joint's pivot
    :math:`d_i = I_i + m_i c_i^2 + a_i`, pass 3 (base to tip) the accelerations
    :math:`\\ddot\\phi_i = (u_i - b_i a_x - c_i a_y)/d_i`,
    :math:`\\ddot q_i = \\ddot\\phi_i - \\ddot\\phi_{i-1}`.

    **One lane loop, scalar locals.** The whole ABA is the body of one ``for ln in
    range(W)`` loop whose values are local variables, not workspace rows: LLVM's loop
    vectoriser turns it into ``<8 x double>`` code and keeps what the passes hand on (each
    joint's velocities, pivots, biases, and the articulated quantities carried along the
    chain) in registers. Written as a lane loop per statement with those values in
    workspace rows (the rest of this module's form, for the SLP vectoriser), every one was
    stored and loaded back: 85 vector stores per ABA against 13, and the RK4 step of a
    paper-arm block (four ABAs) took 1.25-1.68x as long (median of seven timings per
    form, alternating, in each of six runs; the same bits). Joined with the RK4 stage's
    input and angles into one body, the loop spilled to the stack and ran slower than
    both (0.64-0.81x), so only the ABA has this form."""
    arg = _joint_row

    def par(i: int, k: int) -> str:  # row k of the arm's table at joint i, lane ln
        return f"ws[{J0 + i * JS + k * W} + prow + ln]"

    lines = [
        "def aba(ws, joints, prow, vrow, trow, grow, okrow, crow, srow, out, tiprow):",
        f"    for ln in range({W}):",
    ]
    add = lines.append
    ind = "        "
    add(ind + "wp = 0.0")
    add(ind + "vxc = 0.0")
    add(ind + "vyc = 0.0")
    for i in range(n):
        add(ind + f"ac{i} = {arg(i, 'crow')}")
        add(ind + f"as{i} = {arg(i, 'srow')}")
        add(ind + f"pl{i} = {par(i, 1)}")
        add(ind + f"vt{i} = {arg(i, 'vrow')}")
        add(ind + f"w{i} = wp + vt{i}")
        add(ind + f"vx{i} = vxc")
        add(ind + f"vy{i} = vyc")
        add(ind + f"vxc = vx{i} - w{i} * pl{i} * as{i}")
        add(ind + f"vyc = vy{i} + w{i} * pl{i} * ac{i}")
        add(ind + f"wp = w{i}")
    add(ind + "ok = ws[okrow + ln]")
    # pass 2, tip to base: t0..t8 are the child's articulated quantities (ca, cb, cc moved
    # to this joint; dd, de, df, its tau, pa1, pa2 unmoved), zero below the tip
    for ii in range(n):
        i = n - 1 - ii
        if ii == 0:
            add(ind + "t0 = t1 = t2 = t3 = t4 = t5 = t6 = t7 = t8 = 0.0")
        else:
            add(ind + f"rx = pl{i} * ac{i}")
            add(ind + f"ry = pl{i} * as{i}")
            add(ind + "cb = rx * t4 - ry * t3")
            add(ind + "cc = rx * t5 - ry * t4")
            add(ind + "t0 = rx * cc - ry * cb")
            add(ind + "t1 = cb")
            add(ind + "t2 = cc")
            add(ind + "t6 = t6 + rx * t8 - ry * t7")
        add(ind + f"m = {par(i, 0)}")
        add(ind + f"c = {par(i, 2)}")
        add(ind + f"ia = {par(i, 3)} + m * c * c")
        add(ind + f"ib = -m * c * as{i}")
        add(ind + f"ic = m * c * ac{i}")
        add(ind + f"fx = ib * w{i} + m * vx{i}")
        add(ind + f"fy = ic * w{i} + m * vy{i}")
        add(ind + "d = ia + t0")
        add(ind + "ib += t1")
        add(ind + "ic += t2")
        add(ind + "dd = m + t3")
        add(ind + "de = t4")
        add(ind + "df = m + t5")
        add(ind + f"pa0 = vx{i} * fy - vy{i} * fx + t6")
        add(ind + f"pa1 = -w{i} * fy + t7")
        add(ind + f"pa2 = w{i} * fx + t8")
        add(ind + "ok = ok if d > 0.0 else 0.0")
        # the tip's 1/d, constant in a run, computed once as it is here (:func:`_tip_pivots`)
        add(ind + (f"dinv{i} = ws[tiprow + ln]" if ii == 0 else f"dinv{i} = 1.0 / d"))
        add(ind + f"tau{i} = {arg(i, 'trow')}")
        add(ind + f"u{i} = tau{i} - pa0")
        add(ind + f"cvx{i} = vy{i} * vt{i}")
        add(ind + f"cvy{i} = -vx{i} * vt{i}")
        add(ind + f"ib{i} = ib")
        add(ind + f"ic{i} = ic")
        add(ind + f"bd = ib * dinv{i}")
        add(ind + f"cdv = ic * dinv{i}")
        add(ind + "dd -= ib * bd")
        add(ind + "de -= ib * cdv")
        add(ind + "df -= ic * cdv")
        add(ind + f"ud = u{i} * dinv{i}")
        add(ind + f"pa1 += dd * cvx{i} + de * cvy{i} + ib * ud")
        add(ind + f"pa2 += de * cvx{i} + df * cvy{i} + ic * ud")
        add(ind + "t3 = dd")
        add(ind + "t4 = de")
        add(ind + "t5 = df")
        add(ind + f"t6 = tau{i}")
        add(ind + "t7 = pa1")
        add(ind + "t8 = pa2")
    add(ind + "ws[okrow + ln] = ok")
    # pass 3, base to tip
    add(ind + "alpha = 0.0")
    add(ind + "ax = 0.0")
    add(ind + "ay = ws[grow + ln]")
    for i in range(n):
        if i > 0:
            add(ind + f"ax += cvx{i} - alpha * pl{i - 1} * as{i - 1}")
            add(ind + f"ay += cvy{i} + alpha * pl{i - 1} * ac{i - 1}")
        add(ind + f"ai = (u{i} - ib{i} * ax - ic{i} * ay) * dinv{i}")
        add(ind + f"{arg(i, 'out')} = ai - alpha")
        add(ind + "alpha = ai")
    return "\n".join(lines) + "\n"


def _aba(  # pragma: no cover - typed
    ws: np.ndarray,
    joints: tuple[int, ...],
    prow: int,
    vrow: int,
    trow: int,
    grow: int,
    okrow: int,
    crow: int,
    srow: int,
    out: int,
    tiprow: int,
) -> None:
    """:func:`_aba_source` for ``len(joints)`` joints, generated when numba types it: the
    arm's table at joint row ``prow``, the velocity in joint row ``vrow``, the input in
    ``trow``, the gravity in lane row ``grow``, the angles' cosines and sines in ``crow``,
    ``srow``, the acceleration into ``out``, a pivot that is not positive clearing lane row
    ``okrow``, the reciprocal of the tip's pivot read from lane row ``tiprow``
    (:func:`_tip_pivots`; constants where it is inlined)."""
    raise NotImplementedError("compiled only")


@overload(_aba, jit_options={"nogil": True, "error_model": "numpy", "forceinline": True})
def _aba_typed(ws, joints, prow, vrow, trow, grow, okrow, crow, srow, out, tiprow):  # type: ignore[no-untyped-def]
    scope: dict[str, object] = {}
    exec(_aba_source(len(joints)), scope)  # our own generated source
    return scope["aba"]


@njit(forceinline=True, **_OPT)
def _stage_angles(ws: np.ndarray, n: int) -> None:
    """Angles of the stage position ``_QT`` into ``_AC``, ``_AS``: the base angles rotated by
    the summed steps ``_DQ`` (:func:`slidingarm.models._kernels.shifted_angles_into` per
    lane); a lane whose summed step exceeds ``2**-5`` takes the direct sines and cosines."""
    for ln in range(W):
        ws[_L_DELTA + ln] = 0.0
        ws[_L_FAR + ln] = 0.0
    for i in range(n):
        o = (J0 + i * JS) & _NONNEG
        for ln in range(W):
            delta = ws[_L_DELTA + ln] + ws[o + _DQ + ln]
            ws[_L_DELTA + ln] = delta
            far = ws[_L_FAR + ln]
            ws[_L_FAR + ln] = far if abs(delta) <= 0.03125 else 1.0
    anyfar = False
    for ln in range(W):
        anyfar |= ws[_L_FAR + ln] != 0.0
    if anyfar:
        _angles_stage(ws, n)
    for ln in range(W):
        ws[_L_DELTA + ln] = 0.0
    for i in range(n):
        o = (J0 + i * JS) & _NONNEG
        for ln in range(W):
            delta = ws[_L_DELTA + ln] + ws[o + _DQ + ln]
            ws[_L_DELTA + ln] = delta
            c, s = PK.rotated(ws[o + _BC + ln], ws[o + _BS + ln], delta)
            ws[o + _AC + ln] = c
            ws[o + _AS + ln] = s
        if anyfar:
            for ln in range(W):
                far = ws[_L_FAR + ln] != 0.0
                rc = ws[o + _AC + ln]
                rs = ws[o + _AS + ln]
                dc = ws[o + _DC + ln]
                ds = ws[o + _DS + ln]
                ws[o + _AC + ln] = dc if far else rc
                ws[o + _AS + ln] = ds if far else rs


@njit(inline="always", **_OPT)
def _stage(ws: np.ndarray, n: int, c: float, h: float, first: bool, kprev: int, kprev2: int) -> None:
    """Stage input of RK4 (:func:`slidingarm.models._kernels.rk4_step`): position ``q + c h
    v`` into ``_QT`` (its step into ``_DQ``), velocity ``qd + c h k_prev`` into ``_VT``."""
    for i in range(n):
        o = (J0 + i * JS) & _NONNEG
        for ln in range(W):
            qd = ws[o + _QD + ln]
            v_alt = qd + 0.5 * h * ws[o + kprev2 + ln]
            v_prev = qd if first else v_alt
            dq = c * h * v_prev
            ws[o + _DQ + ln] = dq
            ws[o + _QT + ln] = ws[o + _Q + ln] + dq
            ws[o + _VT + ln] = qd + c * h * ws[o + kprev + ln]


@njit(inline="always", **_OPT)
def _keep_stage(ws: np.ndarray, n: int, krow: int) -> None:
    for i in range(n):
        o = (J0 + i * JS) & _NONNEG
        for ln in range(W):
            ws[o + krow + ln] = ws[o + _KX + ln]


@njit(forceinline=True, **_OPT)
def _rk4(ws: np.ndarray, joints: tuple[int, ...], h: float, known: bool) -> None:
    """One RK4 step of every lane (:func:`slidingarm.models._kernels.rk4_step`); ``known``:
    ``_LC``, ``_LS`` hold the angles of ``_Q`` already."""
    n = len(joints)
    if known:
        for i in range(n):
            o = (J0 + i * JS) & _NONNEG
            for ln in range(W):
                ws[o + _BC + ln] = ws[o + _LC + ln]
                ws[o + _BS + ln] = ws[o + _LS + ln]
    else:
        _angles_state(ws, n)
    # each stage's acceleration straight into its row (the ABA reads its inputs from the
    # rows given): no copies between the stages
    _aba(ws, joints, _PM, _QD, _TAPP, _L_G, _L_OK, _BC, _BS, _K0, _L_PTIP)
    _stage(ws, n, 0.5, h, True, _K0, _K0)
    _stage_angles(ws, n)
    _aba(ws, joints, _PM, _VT, _TAPP, _L_G, _L_OK, _AC, _AS, _K1, _L_PTIP)
    _stage(ws, n, 0.5, h, False, _K1, _K0)
    _stage_angles(ws, n)
    _aba(ws, joints, _PM, _VT, _TAPP, _L_G, _L_OK, _AC, _AS, _K2, _L_PTIP)
    _stage(ws, n, 1.0, h, False, _K2, _K1)
    _stage_angles(ws, n)
    _aba(ws, joints, _PM, _VT, _TAPP, _L_G, _L_OK, _AC, _AS, _KX, _L_PTIP)
    _rk4_finish(ws, n, h)


@njit(inline="always", **_OPT)
def _rk4_finish(ws: np.ndarray, n: int, h: float) -> None:
    """RK4's update from the stages' accelerations ``_K0``, ``_K1``, ``_K2``, ``_KX``."""
    for i in range(n):
        o = (J0 + i * JS) & _NONNEG
        for ln in range(W):
            qd = ws[o + _QD + ln]
            k0 = ws[o + _K0 + ln]
            k1 = ws[o + _K1 + ln]
            k2 = ws[o + _K2 + ln]
            k3 = ws[o + _KX + ln]
            v1 = qd
            v2 = qd + 0.5 * h * k0
            v3 = qd + 0.5 * h * k1
            v4 = qd + h * k2
            ws[o + _Q + ln] += h / 6.0 * (v1 + 2.0 * v2 + 2.0 * v3 + v4)
            ws[o + _QD + ln] = qd + h / 6.0 * (k0 + 2.0 * k1 + 2.0 * k2 + k3)


@njit(forceinline=True, **_OPT)
def _law(ws: np.ndarray, joints: tuple[int, ...], k: int, fast_terminal: bool, swcode: float, classic: bool,
         law_tag: np.ndarray, dt: float, q_ref: np.ndarray, qd_ref: np.ndarray,
         qdd_ref: np.ndarray) -> None:  # fmt: skip
    """The sliding-mode law per lane (:func:`slidingarm.control._kernels.control_into`):
    ``s`` into ``_S``, the torque into ``_TAU`` (``law = model``: the nominal RNEA at
    :math:`\\ddot q_d - \\nu - r`; ``paper``: :func:`_paper_law`, chosen by the type of
    ``law_tag``, :func:`_torque`), the angles of the measurement into ``_LC``, ``_LS``."""
    n = len(joints)
    for j in range(n):
        o = (J0 + j * JS) & _NONNEG
        qr = q_ref[k, j]
        qdr = qd_ref[k, j]
        if fast_terminal:
            for ln in range(W):
                ws[o + _TMP + ln] = ws[o + _QM + ln] - qr
            for ln in range(W):
                ws[o + _TMP2 + ln] = pow_abs(ws[o + _TMP + ln], ws[o + _CFG + ln])
            for ln in range(W):
                ej = ws[o + _TMP + ln]
                edj = ws[o + _QDM + ln] - qdr
                alpha = ws[o + _CFA + ln]
                beta = ws[o + _CFB + ln]
                gamma = ws[o + _CFG + ln]
                eps_e = ws[o + _CFE + ln]
                pw = ws[o + _TMP2 + ln]
                ae = abs(ej)
                sg = _sgn(ej)
                s0 = edj + alpha * ej
                s1 = s0 + beta * pw * sg
                g_far = alpha + beta * gamma * pw / ae
                g_near = alpha + beta * gamma * ws[o + _EPSG + ln]
                g1 = g_far if ae >= eps_e else g_near
                terminal = beta != 0.0
                s = s1 if terminal else s0
                gain = g1 if terminal else alpha
                ws[o + _S + ln] = s
                ws[o + _NU + ln] = gain * edj
        else:
            for ln in range(W):
                ws[o + _TMP + ln] = ws[o + _QDM + ln] - qdr
            for ln in range(W):
                ws[o + _TMP2 + ln] = pow_abs(ws[o + _TMP + ln], ws[o + _CFG + ln])
            for ln in range(W):
                ws[o + _TMP3 + ln] = pow_abs(ws[o + _TMP + ln], 2.0 - ws[o + _CFG + ln])
            for ln in range(W):
                ej = ws[o + _QM + ln] - qr
                edj = ws[o + _TMP + ln]
                sg = _sgn(edj)
                beta = ws[o + _CFB + ln]
                gamma = ws[o + _CFG + ln]
                ws[o + _S + ln] = ej + ws[o + _TMP2 + ln] * sg / beta
                ws[o + _NU + ln] = beta / gamma * ws[o + _TMP3 + ln] * sg
    for j in range(n):
        o = (J0 + j * JS) & _NONNEG
        if swcode == CK.SWITCH_TANH:
            for ln in range(W):
                ws[o + _TMP + ln] = tanh(ws[o + _S + ln] / ws[o + _CFW + ln])
        elif swcode == CK.SWITCH_SIGN:
            # the switching code is the block's (uniform): sign switching skips sat's division
            for ln in range(W):
                ws[o + _TMP + ln] = _sgn(ws[o + _S + ln])
        else:
            for ln in range(W):
                ws[o + _TMP + ln] = _clamp(ws[o + _S + ln] / ws[o + _CFW + ln], -1.0, 1.0)
        qddr = qdd_ref[k, j]
        if classic:
            for ln in range(W):
                r = ws[o + _CFK + ln] * ws[o + _TMP + ln]
                ws[o + _PR + ln] = r
                ws[o + _ACC + ln] = qddr - ws[o + _NU + ln] - r
        else:
            for ln in range(W):
                s = ws[o + _S + ln]
                sg = _sgn(s)
                r = ws[o + _CFK + ln] * math.sqrt(abs(s)) * sg + ws[o + _ST + ln]
                ws[o + _PR + ln] = r
                ws[o + _ST + ln] += dt * ws[o + _CFK2 + ln] * ws[o + _TMP + ln]
                ws[o + _ACC + ln] = qddr - ws[o + _NU + ln] - r
    _torque(ws, joints, law_tag)


#: The law and the arm kind of a block, as the *type* of an empty array passed to
#: :func:`run_block`: a kernel then never types (nor compiles) what its blocks do not run (the
#: paper's law, which only the errata use; the other kind's dynamics).
MODEL_TAG = np.empty(0, dtype=np.float64)
PAPER_TAG = np.empty(0, dtype=np.int8)
SERIAL_TAG = np.empty(0, dtype=np.float32)


def _tag_kind(law_tag: object) -> str:
    """``"paper"``, ``"serial"`` or ``"model"`` (planar), by the numba type of a tag."""
    if isinstance(law_tag, numba_types.Array) and law_tag.dtype == numba_types.int8:
        return "paper"
    if isinstance(law_tag, numba_types.Array) and law_tag.dtype == numba_types.float32:
        return "serial"
    return "model"


@njit(forceinline=True, **_OPT)
def _planar_torque(ws: np.ndarray, joints: tuple[int, ...]) -> None:
    _angles_law(ws, len(joints))
    _rnea(ws, joints)


@njit(forceinline=True, **_OPT)
def _paper_torque(ws: np.ndarray, joints: tuple[int, ...]) -> None:
    _angles_law(ws, len(joints))
    _paper_law(ws, joints)


def _torque(ws: np.ndarray, joints: tuple[int, ...], law_tag: np.ndarray) -> None:  # pragma: no cover - typed
    """The torque of the law that ``law_tag``'s type names (:data:`MODEL_TAG`: the planar
    nominal RNEA, :func:`_rnea`; :data:`PAPER_TAG`: :func:`_paper_law`; :data:`SERIAL_TAG`:
    the serial nominal RNEA, :func:`_serial_torque`), chosen when numba types it; the planar
    ones leave the angles of the measurement in ``_LC``, ``_LS``."""
    raise NotImplementedError("compiled only")


@overload(_torque, jit_options={"nogil": True, "error_model": "numpy"})
def _torque_typed(ws, joints, law_tag):  # type: ignore[no-untyped-def]  # numba compares the names
    # and annotations of this signature with the implementation's
    kind = _tag_kind(law_tag)
    if kind == "paper":
        return lambda ws, joints, law_tag: _paper_torque(ws, joints)
    if kind == "serial":
        return lambda ws, joints, law_tag: _serial_torque(ws, len(joints))
    return lambda ws, joints, law_tag: _planar_torque(ws, joints)


def _plant_step(ws: np.ndarray, joints: tuple[int, ...], h: float, known: bool, law_tag: np.ndarray) -> None:  # pragma: no cover - typed
    """One RK4 step of the plants of the kind ``law_tag``'s type names: :func:`_rk4`
    (planar; ``known``: the law left the angles of the state) or :func:`_rk4_serial`."""
    raise NotImplementedError("compiled only")


@overload(_plant_step, jit_options={"nogil": True, "error_model": "numpy"})
def _plant_step_typed(ws, joints, h, known, law_tag):  # type: ignore[no-untyped-def]
    if _tag_kind(law_tag) == "serial":
        return lambda ws, joints, h, known, law_tag: _rk4_serial(ws, joints, h)
    return lambda ws, joints, h, known, law_tag: _rk4(ws, joints, h, known)


def _load_tables(ws: np.ndarray, n: int, pp: np.ndarray, mp: np.ndarray, law_tag: np.ndarray) -> None:  # pragma: no cover - typed
    """A serial block's plant and nominal tables (``(rows, n, W)``) into its serial rows; a
    planar block's tip pivots (:func:`_tip_pivots`) from its rows loaded before."""
    raise NotImplementedError("compiled only")


@overload(_load_tables, jit_options={"nogil": True, "error_model": "numpy"})
def _load_tables_typed(ws, n, pp, mp, law_tag):  # type: ignore[no-untyped-def]
    if _tag_kind(law_tag) == "serial":
        return lambda ws, n, pp, mp, law_tag: _load_serial(ws, n, pp, mp)
    return lambda ws, n, pp, mp, law_tag: _tip_pivots(ws, n)


@njit(**_OPT)
def _tip_pivots(ws: np.ndarray, n: int) -> None:
    """The reciprocals of the tip's pivot of the plant (``_PM`` rows) and of the nominal model
    (``_MM`` rows) into ``_L_PTIP``, ``_L_MTIP``: :math:`1 / (I + m c^2 + 0)`, the tip's
    :math:`1/d` of :func:`_aba_source` (its rigid inertia about its joint plus the zero a
    child would add), formed by the same operations, so the same bits. It depends on
    nothing that changes in a run, and its division was one of three in every ABA: the RK4
    step of a paper-arm block 2088-2094 -> 1991-2046 ticks (bench_block_parts, three runs
    each)."""
    o = (J0 + (n - 1) * JS) & _NONNEG
    for row, tip in ((_PM, _L_PTIP), (_MM, _L_MTIP)):
        for ln in range(W):
            m = ws[o + row + ln]
            c = ws[o + row + 2 * W + ln]
            ia = ws[o + row + 3 * W + ln] + m * c * c
            ws[tip + ln] = 1.0 / (ia + 0.0)


@njit(**_OPT)
def _load_serial(ws: np.ndarray, n: int, pp: np.ndarray, mp: np.ndarray) -> None:
    sb = (_serial_base(n) + _SL_END) & _NONNEG
    for j in range(n):
        so = (sb + j * SJS) & _NONNEG
        for r in range(SERIAL_TABLE_ROWS):
            for ln in range(W):
                ws[so + _SP + r * W + ln] = pp[r, j, ln]
                ws[so + _SM + r * W + ln] = mp[r, j, ln]


# ------------------------------------------------------------------ the serial kind, per lane
# The serial kind's dynamics (slidingarm.models._spatial) per lane, on its joint-aligned table
# (each joint's axis is its body's e_z): each lane computes the same formulas as the scalar
# kernels, but the plant's forward dynamics is M(q)^{-1} (tau - h(q, qd)) by the
# composite-rigid-body algorithm, the recursive Newton-Euler algorithm and a Cholesky solve
# (O(n^2), all of it vector code across lanes), where the scalar path uses the
# articulated-body algorithm (O(n)); the scalar kernels also fuse products and sums
# (``fastmath={"contract"}``), which this module never does; the per-run law of a serial
# nominal model calls libm's pow and tanh (this module: slidingarm._vecmath's, within 1 ulp).
# Like the per-run loop, each RK4 stage rotates the step's sines and cosines by the stage's
# step (:func:`_serial_stage_angles`). So a serial run on the block path agrees with the per-run loop to rounding, not bit
# for bit (tests/engine/test_block_serial.py states the tolerances). Per joint the choice between a revolute and a prismatic joint is a select
# on the table's type row, the same for every lane of a block in practice.


@njit(forceinline=True, **_OPT)
def _serial_kinematics(ws: np.ndarray, n: int, qoff: int, tab: int) -> None:
    """Each body's ``R_pc`` (``_SR``) and origin ``r`` (``_SO``) in its parent at the
    positions in joint rows ``qoff``, from the table at serial rows ``tab``
    (:func:`slidingarm.models._spatial._place`): a revolute joint's ``R_pc = R_0 Rot(e_z,
    q)``, ``r = p_0``; a prismatic one's ``R_pc = R_0``, ``r = p_0 + q R_0 e_z``. The
    cosines and sines of the coordinates are taken here, into ``_AC``, ``_AS``."""
    for i in range(n):
        o = (J0 + i * JS) & _NONNEG
        for ln in range(W):
            sv, cv = sincos(ws[o + qoff + ln])
            ws[o + _AC + ln] = cv
            ws[o + _AS + ln] = sv
    _serial_place(ws, n, qoff, tab)


@njit(forceinline=True, **_OPT)
def _serial_place(ws: np.ndarray, n: int, qoff: int, tab: int) -> None:
    """:func:`_serial_kinematics` with the cosines and sines of the coordinates in joint
    rows ``_AC``, ``_AS`` already."""
    sb = (_serial_base(n) + _SL_END) & _NONNEG
    for i in range(n):
        o = (J0 + i * JS) & _NONNEG
        so = (sb + i * SJS) & _NONNEG
        for ln in range(W):
            qv = ws[o + qoff + ln]
            cv = ws[o + _AC + ln]
            sv = ws[o + _AS + ln]
            rev = ws[so + tab + 15 * W + ln] == 0.0
            c = cv if rev else 1.0
            sn = sv if rev else 0.0
            slide = 0.0 if rev else qv
            for row in range(3):
                b0 = ws[so + tab + (3 * row) * W + ln]
                b1 = ws[so + tab + (3 * row + 1) * W + ln]
                b2 = ws[so + tab + (3 * row + 2) * W + ln]
                ws[so + _SR + (3 * row) * W + ln] = b0 * c + b1 * sn
                ws[so + _SR + (3 * row + 1) * W + ln] = b1 * c - b0 * sn
                ws[so + _SR + (3 * row + 2) * W + ln] = b2
                ws[so + _SO + row * W + ln] = ws[so + tab + (9 + row) * W + ln] + slide * b2


@njit(inline="always", **_OPT)
def _motion_in(ws: np.ndarray, so: int, ln: int, wx: float, wy: float, wz: float, vx: float,
               vy: float, vz: float) -> tuple[float, float, float, float, float, float]:  # fmt: skip
    """A motion of the parent carried into the body at serial rows ``so``:
    ``(E ω, E (v + ω × r))`` with ``E = R_pc^T`` (:func:`slidingarm.models._spatial._motion_in`)."""
    rx = ws[so + _SO + ln]
    ry = ws[so + _SO + W + ln]
    rz = ws[so + _SO + 2 * W + ln]
    ux = vx + wy * rz - wz * ry
    uy = vy + wz * rx - wx * rz
    uz = vz + wx * ry - wy * rx
    r00 = ws[so + _SR + ln]
    r01 = ws[so + _SR + W + ln]
    r02 = ws[so + _SR + 2 * W + ln]
    r10 = ws[so + _SR + 3 * W + ln]
    r11 = ws[so + _SR + 4 * W + ln]
    r12 = ws[so + _SR + 5 * W + ln]
    r20 = ws[so + _SR + 6 * W + ln]
    r21 = ws[so + _SR + 7 * W + ln]
    r22 = ws[so + _SR + 8 * W + ln]
    return (
        r00 * wx + r10 * wy + r20 * wz,
        r01 * wx + r11 * wy + r21 * wz,
        r02 * wx + r12 * wy + r22 * wz,
        r00 * ux + r10 * uy + r20 * uz,
        r01 * ux + r11 * uy + r21 * uz,
        r02 * ux + r12 * uy + r22 * uz,
    )


@njit(inline="always", **_OPT)
def _force_out(ws: np.ndarray, so: int, ln: int, nx: float, ny: float, nz: float, fx: float,
               fy: float, fz: float) -> tuple[float, float, float, float, float, float]:  # fmt: skip
    """A force on the body at serial rows ``so`` carried to its parent: ``(R n + r × R f, R
    f)`` (:func:`slidingarm.models._spatial._force_out`)."""
    r00 = ws[so + _SR + ln]
    r01 = ws[so + _SR + W + ln]
    r02 = ws[so + _SR + 2 * W + ln]
    r10 = ws[so + _SR + 3 * W + ln]
    r11 = ws[so + _SR + 4 * W + ln]
    r12 = ws[so + _SR + 5 * W + ln]
    r20 = ws[so + _SR + 6 * W + ln]
    r21 = ws[so + _SR + 7 * W + ln]
    r22 = ws[so + _SR + 8 * W + ln]
    gx = r00 * fx + r01 * fy + r02 * fz
    gy = r10 * fx + r11 * fy + r12 * fz
    gz = r20 * fx + r21 * fy + r22 * fz
    rx = ws[so + _SO + ln]
    ry = ws[so + _SO + W + ln]
    rz = ws[so + _SO + 2 * W + ln]
    return (
        r00 * nx + r01 * ny + r02 * nz + ry * gz - rz * gy,
        r10 * nx + r11 * ny + r12 * nz + rz * gx - rx * gz,
        r20 * nx + r21 * ny + r22 * nz + rx * gy - ry * gx,
        gx,
        gy,
        gz,
    )


@njit(forceinline=True, **_OPT)
def _serial_rnea(ws: np.ndarray, n: int, tab: int, qdoff: int, accoff: int, with_acc: bool,
                 gl: int, out: int) -> None:  # fmt: skip
    """Recursive Newton-Euler per lane with the kinematics in ``_SR``, ``_SO``
    (:func:`slidingarm.models._spatial.rnea_known`): :math:`\\tau = M(q) \\ddot q + h(q,
    \\dot q)` with :math:`\\dot q` in joint rows ``qdoff`` and :math:`\\ddot q` in ``accoff``
    (``with_acc``; else :math:`\\ddot q = 0`: the bias ``h``), gravity ``ws[gl + ln]``, the
    table at serial rows ``tab``; into joint rows ``out``."""
    base = _serial_base(n) & _NONNEG
    sb = (base + _SL_END) & _NONNEG
    for ln in range(W):
        for r in range(6):
            ws[base + _SL_W + r * W + ln] = 0.0
            ws[base + _SL_B + r * W + ln] = 0.0
        ws[base + _SL_B + 5 * W + ln] = ws[gl + ln]
    for i in range(n):
        o = (J0 + i * JS) & _NONNEG
        so = (sb + i * SJS) & _NONNEG
        for ln in range(W):
            wx, wy, wz, vx, vy, vz = _motion_in(
                ws, so, ln, ws[base + _SL_W + ln], ws[base + _SL_W + W + ln],
                ws[base + _SL_W + 2 * W + ln], ws[base + _SL_W + 3 * W + ln],
                ws[base + _SL_W + 4 * W + ln], ws[base + _SL_W + 5 * W + ln],
            )  # fmt: skip
            bx, by, bz, cx, cy, cz = _motion_in(
                ws, so, ln, ws[base + _SL_B + ln], ws[base + _SL_B + W + ln],
                ws[base + _SL_B + 2 * W + ln], ws[base + _SL_B + 3 * W + ln],
                ws[base + _SL_B + 4 * W + ln], ws[base + _SL_B + 5 * W + ln],
            )  # fmt: skip
            dq = ws[o + qdoff + ln]
            ddq = ws[o + accoff + ln] if with_acc else 0.0
            rev = ws[so + tab + 15 * W + ln] == 0.0
            # S = (e_z, 0) or (0, e_z); (w, v) x S dq = (w x e_z dq, v x e_z dq) or (0, w x e_z dq)
            wz = wz + dq if rev else wz
            vz = vz if rev else vz + dq
            bx = bx + wy * dq if rev else bx
            by = by - wx * dq if rev else by
            bz = bz + ddq if rev else bz
            cx = cx + vy * dq if rev else cx + wy * dq
            cy = cy - vx * dq if rev else cy - wx * dq
            cz = cz if rev else cz + ddq
            m = ws[so + tab + 16 * W + ln]
            hx = ws[so + tab + 17 * W + ln]
            hy = ws[so + tab + 18 * W + ln]
            hz = ws[so + tab + 19 * W + ln]
            ixx = ws[so + tab + 20 * W + ln]
            iyy = ws[so + tab + 21 * W + ln]
            izz = ws[so + tab + 22 * W + ln]
            ixy = ws[so + tab + 23 * W + ln]
            ixz = ws[so + tab + 24 * W + ln]
            iyz = ws[so + tab + 25 * W + ln]
            # the rigid inertia times (w, v) and times (b, c): (I_o w + h x v, m v - h x w)
            n1x, n1y, n1z, f1x, f1y, f1z = SK._rigid_times(
                m, hx, hy, hz, ixx, iyy, izz, ixy, ixz, iyz, wx, wy, wz, vx, vy, vz
            )
            n2x, n2y, n2z, f2x, f2y, f2z = SK._rigid_times(
                m, hx, hy, hz, ixx, iyy, izz, ixy, ixz, iyz, bx, by, bz, cx, cy, cz
            )
            ws[so + _SF + ln] = n2x + wy * n1z - wz * n1y + vy * f1z - vz * f1y
            ws[so + _SF + W + ln] = n2y + wz * n1x - wx * n1z + vz * f1x - vx * f1z
            ws[so + _SF + 2 * W + ln] = n2z + wx * n1y - wy * n1x + vx * f1y - vy * f1x
            ws[so + _SF + 3 * W + ln] = f2x + wy * f1z - wz * f1y
            ws[so + _SF + 4 * W + ln] = f2y + wz * f1x - wx * f1z
            ws[so + _SF + 5 * W + ln] = f2z + wx * f1y - wy * f1x
            ws[base + _SL_W + ln] = wx
            ws[base + _SL_W + W + ln] = wy
            ws[base + _SL_W + 2 * W + ln] = wz
            ws[base + _SL_W + 3 * W + ln] = vx
            ws[base + _SL_W + 4 * W + ln] = vy
            ws[base + _SL_W + 5 * W + ln] = vz
            ws[base + _SL_B + ln] = bx
            ws[base + _SL_B + W + ln] = by
            ws[base + _SL_B + 2 * W + ln] = bz
            ws[base + _SL_B + 3 * W + ln] = cx
            ws[base + _SL_B + 4 * W + ln] = cy
            ws[base + _SL_B + 5 * W + ln] = cz
    for ii in range(n):
        i = n - 1 - ii
        o = (J0 + i * JS) & _NONNEG
        so = (sb + i * SJS) & _NONNEG
        at = (o + out) & _NONNEG
        for ln in range(W):
            rev = ws[so + tab + 15 * W + ln] == 0.0
            ws[at + ln] = ws[so + _SF + 2 * W + ln] if rev else ws[so + _SF + 5 * W + ln]
        if i > 0:
            sp = (so - SJS) & _NONNEG
            for ln in range(W):
                nx, ny, nz, fx, fy, fz = _force_out(
                    ws, so, ln, ws[so + _SF + ln], ws[so + _SF + W + ln],
                    ws[so + _SF + 2 * W + ln], ws[so + _SF + 3 * W + ln],
                    ws[so + _SF + 4 * W + ln], ws[so + _SF + 5 * W + ln],
                )  # fmt: skip
                ws[sp + _SF + ln] += nx
                ws[sp + _SF + W + ln] += ny
                ws[sp + _SF + 2 * W + ln] += nz
                ws[sp + _SF + 3 * W + ln] += fx
                ws[sp + _SF + 4 * W + ln] += fy
                ws[sp + _SF + 5 * W + ln] += fz


@njit(forceinline=True, **_OPT)
def _serial_crba(ws: np.ndarray, joints: tuple[int, ...], tab: int, mb: int) -> None:
    """Composite-rigid-body algorithm per lane with the kinematics in ``_SR``, ``_SO``
    (:func:`slidingarm.models._spatial.crba_known`): ``M`` into the ``n x n`` rows at ``mb``
    (row ``a``, column ``b`` at ``mb + (a n + b) W``); the composite inertias
    :math:`I^c_i = I_i + X_{i+1}^T I^c_{i+1} X_{i+1}` here, the entries by
    :func:`_serial_mass`."""
    n = len(joints)
    base = _serial_base(n) & _NONNEG
    sb = (base + _SL_END) & _NONNEG
    for i in range(n):
        so = (sb + i * SJS) & _NONNEG
        for k in range(10):
            for ln in range(W):
                ws[so + _SC + k * W + ln] = ws[so + tab + (16 + k) * W + ln]
    for ii in range(n - 1):
        i = n - 1 - ii
        so = (sb + i * SJS) & _NONNEG
        sp = (so - SJS) & _NONNEG
        for ln in range(W):
            m = ws[so + _SC + ln]
            hx = ws[so + _SC + W + ln]
            hy = ws[so + _SC + 2 * W + ln]
            hz = ws[so + _SC + 3 * W + ln]
            jxx = ws[so + _SC + 4 * W + ln]
            jyy = ws[so + _SC + 5 * W + ln]
            jzz = ws[so + _SC + 6 * W + ln]
            jxy = ws[so + _SC + 7 * W + ln]
            jxz = ws[so + _SC + 8 * W + ln]
            jyz = ws[so + _SC + 9 * W + ln]
            e00 = ws[so + _SR + ln]
            e01 = ws[so + _SR + W + ln]
            e02 = ws[so + _SR + 2 * W + ln]
            e10 = ws[so + _SR + 3 * W + ln]
            e11 = ws[so + _SR + 4 * W + ln]
            e12 = ws[so + _SR + 5 * W + ln]
            e20 = ws[so + _SR + 6 * W + ln]
            e21 = ws[so + _SR + 7 * W + ln]
            e22 = ws[so + _SR + 8 * W + ln]
            ox = ws[so + _SO + ln]
            oy = ws[so + _SO + W + ln]
            oz = ws[so + _SO + 2 * W + ln]
            # (m, h, I_o) carried to the parent (numba inlines the scalar helper's body here: the
            # same formulas, without the scalar kernels' fastmath flags)
            gx, gy, gz, ixx, iyy, izz, ixy, ixz, iyz = SK._carry_inertia(
                m, hx, hy, hz, jxx, jyy, jzz, jxy, jxz, jyz,
                e00, e01, e02, e10, e11, e12, e20, e21, e22, ox, oy, oz,
            )  # fmt: skip
            ws[sp + _SC + ln] += m
            ws[sp + _SC + W + ln] += gx
            ws[sp + _SC + 2 * W + ln] += gy
            ws[sp + _SC + 3 * W + ln] += gz
            ws[sp + _SC + 4 * W + ln] += ixx
            ws[sp + _SC + 5 * W + ln] += iyy
            ws[sp + _SC + 6 * W + ln] += izz
            ws[sp + _SC + 7 * W + ln] += ixy
            ws[sp + _SC + 8 * W + ln] += ixz
            ws[sp + _SC + 9 * W + ln] += iyz
    _serial_mass(ws, joints, tab, mb)


def _serial_mass_source(n: int) -> str:
    """Source of the second half of :func:`_serial_crba` for ``n`` joints, from the composite
    inertias: :math:`M_{ii} = S_i^T I^c_i S_i` (revolute: :math:`I^c (a, 0) = (I_o a, -h
    \\times a)`; prismatic: :math:`I^c (0, a) = (h \\times a, m a)`) and
    :math:`M_{ki} = S_k^T X_{k+1}^T \\cdots X_i^T I^c_i S_i` for :math:`k < i`, the force
    carried down the chain in registers: one lane loop per column, at constant offsets.
    Written as loops over the columns and the chain, the chain's lane loop (offsets that
    depend on both loops) stayed scalar per lane (measured)."""
    sb = J0 + n * JS + 2 * n * n * W + _SL_END

    def so(i: int) -> int:
        return sb + i * SJS

    lines = ["def mass(ws, joints, tab, mb):"]
    for i in range(n):
        o = so(i)
        lines += [
            f"    for ln in range({W}):",
            f"        ax = ws[{o} + tab + {12 * W} + ln]",
            f"        ay = ws[{o} + tab + {13 * W} + ln]",
            f"        az = ws[{o} + tab + {14 * W} + ln]",
            f"        m = ws[{o + _SC} + ln]",
            f"        hx = ws[{o + _SC + W} + ln]",
            f"        hy = ws[{o + _SC + 2 * W} + ln]",
            f"        hz = ws[{o + _SC + 3 * W} + ln]",
            f"        rev = ws[{o} + tab + {15 * W} + ln] == 0.0",
            "        hxa_x = hy * az - hz * ay",
            "        hxa_y = hz * ax - hx * az",
            "        hxa_z = hx * ay - hy * ax",
            f"        ioa_x = ws[{o + _SC + 4 * W} + ln] * ax + ws[{o + _SC + 7 * W} + ln] * ay"
            f" + ws[{o + _SC + 8 * W} + ln] * az",
            f"        ioa_y = ws[{o + _SC + 7 * W} + ln] * ax + ws[{o + _SC + 5 * W} + ln] * ay"
            f" + ws[{o + _SC + 9 * W} + ln] * az",
            f"        ioa_z = ws[{o + _SC + 8 * W} + ln] * ax + ws[{o + _SC + 9 * W} + ln] * ay"
            f" + ws[{o + _SC + 6 * W} + ln] * az",
            "        nx = ioa_x if rev else hxa_x",
            "        ny = ioa_y if rev else hxa_y",
            "        nz = ioa_z if rev else hxa_z",
            "        fx = -hxa_x if rev else m * ax",
            "        fy = -hxa_y if rev else m * ay",
            "        fz = -hxa_z if rev else m * az",
            "        d_rev = ax * nx + ay * ny + az * nz",
            "        d_pri = ax * fx + ay * fy + az * fz",
            f"        ws[mb + {(i * n + i) * W} + ln] = d_rev if rev else d_pri",
        ]
        fl = J0 + n * JS + 2 * n * n * W + _SL_F
        if i > 0:
            lines += [f"        ws[{fl + r * W} + ln] = {v}" for r, v in enumerate(("nx", "ny", "nz", "fx", "fy", "fz"))]
        for j in range(i, 0, -1):
            k = j - 1
            lines += [f"    for ln in range({W}):"]
            lines += [f"        {v} = ws[{fl + r * W} + ln]" for r, v in enumerate(("nx", "ny", "nz", "fx", "fy", "fz"))]
            lines += [
                f"        nx, ny, nz, fx, fy, fz = _force_out(ws, {so(j)}, ln, nx, ny, nz, fx, fy, fz)",
                f"        bx = ws[{so(k)} + tab + {12 * W} + ln]",
                f"        by = ws[{so(k)} + tab + {13 * W} + ln]",
                f"        bz = ws[{so(k)} + tab + {14 * W} + ln]",
                f"        rk = ws[{so(k)} + tab + {15 * W} + ln] == 0.0",
                "        v_rev = bx * nx + by * ny + bz * nz",
                "        v_pri = bx * fx + by * fy + bz * fz",
                "        v = v_rev if rk else v_pri",
                f"        ws[mb + {(k * n + i) * W} + ln] = v",
                f"        ws[mb + {(i * n + k) * W} + ln] = v",
            ]
            if j > 1:
                lines += [f"        ws[{fl + r * W} + ln] = {v}" for r, v in enumerate(("nx", "ny", "nz", "fx", "fy", "fz"))]
    return "\n".join(lines) + "\n"


def _serial_mass(ws: np.ndarray, joints: tuple[int, ...], tab: int, mb: int) -> None:  # pragma: no cover - typed
    """:func:`_serial_mass_source` for ``len(joints)`` joints, generated when numba types it."""
    raise NotImplementedError("compiled only")


@overload(_serial_mass, jit_options={"nogil": True, "error_model": "numpy", "forceinline": True})
def _serial_mass_typed(ws, joints, tab, mb):  # type: ignore[no-untyped-def]
    scope: dict[str, object] = {"_force_out": _force_out}
    exec(_serial_mass_source(len(joints)), scope)  # our own generated source
    return scope["mass"]


def _serial_solve_source(n: int) -> str:
    """Source of the serial plant's solve for ``n`` joints, :math:`M x = b` per lane with
    ``M`` at :func:`_serial_forward`'s rows, ``b`` in joint rows ``_PRHS`` and ``x`` into
    ``_KX``: the Cholesky factorisation :math:`M = L L^T` row by row
    (:math:`L_{ij} = (M_{ij} - \\sum_{k<j} L_{ik} L_{jk}) / L_{jj}`, the diagonal by a square
    root), then the forward and back substitutions, written out for each entry (a lane loop
    each, at constant offsets). Written as loops over the entries, LLVM did not unroll them
    (too large once nested) and the whole solve stayed scalar per lane (measured: no vector
    instruction in it); written out, each lane loop is vector code.
    A lane with a pivot that is not positive clears ``_L_OK`` and takes 1 for it, so that its
    state stays finite and the run is reported singular (code, sample and joint 0), as the
    per-run loop's articulated-body pass reports it (a NaN pivot passes through: a non-finite
    state is reported as such first, on both paths)."""
    mb = J0 + n * JS
    lb = mb + n * n * W
    t0 = _L_T0

    def m_at(i: int, j: int) -> int:
        return mb + (i * n + j) * W

    def l_at(i: int, j: int) -> int:
        return lb + (i * n + j) * W

    def row(i: int, r: int) -> int:
        return J0 + i * JS + r

    lines = ["def solve(ws, joints):"]
    loop = f"    for ln in range({W}):"
    for i in range(n):
        for j in range(i + 1):
            lines += [loop, f"        ws[{t0} + ln] = ws[{m_at(i, j)} + ln]"]
            for k in range(j):
                lines += [loop, f"        ws[{t0} + ln] -= ws[{l_at(i, k)} + ln] * ws[{l_at(j, k)} + ln]"]
            if i == j:
                lines += [
                    loop,
                    f"        piv = ws[{t0} + ln]",
                    f"        ok = ws[{_L_OK} + ln]",
                    f"        ws[{_L_OK} + ln] = ok if piv > 0.0 else 0.0",
                    f"        ws[{l_at(i, i)} + ln] = math.sqrt(1.0 if piv <= 0.0 else piv)",
                ]
            else:
                lines += [loop, f"        ws[{l_at(i, j)} + ln] = ws[{t0} + ln] / ws[{l_at(j, j)} + ln]"]
    for i in range(n):
        lines += [loop, f"        ws[{t0} + ln] = ws[{row(i, _PRHS)} + ln]"]
        for k in range(i):
            lines += [loop, f"        ws[{t0} + ln] -= ws[{l_at(i, k)} + ln] * ws[{row(k, _KX)} + ln]"]
        lines += [loop, f"        ws[{row(i, _KX)} + ln] = ws[{t0} + ln] / ws[{l_at(i, i)} + ln]"]
    for i in range(n - 1, -1, -1):
        lines += [loop, f"        ws[{t0} + ln] = ws[{row(i, _KX)} + ln]"]
        for k in range(i + 1, n):
            lines += [loop, f"        ws[{t0} + ln] -= ws[{l_at(k, i)} + ln] * ws[{row(k, _KX)} + ln]"]
        lines += [loop, f"        ws[{row(i, _KX)} + ln] = ws[{t0} + ln] / ws[{l_at(i, i)} + ln]"]
    return "\n".join(lines) + "\n"


def _serial_solve(ws: np.ndarray, joints: tuple[int, ...]) -> None:  # pragma: no cover - typed
    """:func:`_serial_solve_source` for ``len(joints)`` joints, generated when numba types it."""
    raise NotImplementedError("compiled only")


@overload(_serial_solve, jit_options={"nogil": True, "error_model": "numpy", "forceinline": True})
def _serial_solve_typed(ws, joints):  # type: ignore[no-untyped-def]
    n = len(joints)
    scope: dict[str, object] = {"math": math}
    exec(_serial_solve_source(n), scope)  # our own generated source
    return scope["solve"]


@njit(forceinline=True, **_OPT)
def _serial_forward(ws: np.ndarray, joints: tuple[int, ...]) -> None:
    """The serial plant's acceleration per lane at the stage position ``_QT`` (the cosines
    and sines of its coordinates in ``_AC``, ``_AS``), velocity ``_VT`` and input ``_TAPP``: :math:`\\ddot q = M(q)^{-1} (\\tau - h(q, \\dot q))` into
    ``_KX`` (a pivot that is not positive clears ``_L_OK``)."""
    n = len(joints)
    mb = (J0 + n * JS) & _NONNEG
    _serial_place(ws, n, _QT, _SP)
    _serial_rnea(ws, n, _SP, _VT, _VT, False, _L_G, _PRHS)
    for i in range(n):
        o = (J0 + i * JS) & _NONNEG
        for ln in range(W):
            ws[o + _PRHS + ln] = ws[o + _TAPP + ln] - ws[o + _PRHS + ln]
    _serial_crba(ws, joints, _SP, mb)
    _serial_solve(ws, joints)


@njit(forceinline=True, **_OPT)
def _rk4_serial(ws: np.ndarray, joints: tuple[int, ...], h: float) -> None:
    """One RK4 step of every lane of serial plants (the stages of :func:`_rk4`, each at
    :func:`_serial_forward`)."""
    n = len(joints)
    for i in range(n):
        o = (J0 + i * JS) & _NONNEG
        for ln in range(W):
            qv = ws[o + _Q + ln]
            sv, cv = sincos(qv)
            ws[o + _BC + ln] = cv
            ws[o + _BS + ln] = sv
            ws[o + _AC + ln] = cv
            ws[o + _AS + ln] = sv
            ws[o + _QT + ln] = qv
            ws[o + _VT + ln] = ws[o + _QD + ln]
    _serial_forward(ws, joints)
    _keep_stage(ws, n, _K0)
    _stage(ws, n, 0.5, h, True, _K0, _K0)
    _serial_stage_angles(ws, n)
    _serial_forward(ws, joints)
    _keep_stage(ws, n, _K1)
    _stage(ws, n, 0.5, h, False, _K1, _K0)
    _serial_stage_angles(ws, n)
    _serial_forward(ws, joints)
    _keep_stage(ws, n, _K2)
    _stage(ws, n, 1.0, h, False, _K2, _K1)
    _serial_stage_angles(ws, n)
    _serial_forward(ws, joints)
    _rk4_finish(ws, n, h)


@njit(forceinline=True, **_OPT)
def _serial_stage_angles(ws: np.ndarray, n: int) -> None:
    """The cosines and sines of a stage's coordinates ``_QT`` into ``_AC``, ``_AS``: those of
    the step's start (``_BC``, ``_BS``) rotated by the stage's step ``_DQ`` where it is at
    most ``2**-5`` (the per-run loop's
    :func:`slidingarm.models._spatial._angles_shifted_into`), else taken directly (only if
    some lane needs it)."""
    for ln in range(W):
        ws[_L_FAR + ln] = 0.0
    for i in range(n):
        o = (J0 + i * JS) & _NONNEG
        for ln in range(W):
            far = ws[_L_FAR + ln]
            ws[_L_FAR + ln] = far if abs(ws[o + _DQ + ln]) <= 0.03125 else 1.0
    anyfar = False
    for ln in range(W):
        anyfar |= ws[_L_FAR + ln] != 0.0
    for i in range(n):
        o = (J0 + i * JS) & _NONNEG
        for ln in range(W):
            c, s = PK.rotated(ws[o + _BC + ln], ws[o + _BS + ln], ws[o + _DQ + ln])
            ws[o + _AC + ln] = c
            ws[o + _AS + ln] = s
        if anyfar:
            for ln in range(W):
                sv, cv = sincos(ws[o + _QT + ln])
                near = abs(ws[o + _DQ + ln]) <= 0.03125
                ws[o + _AC + ln] = ws[o + _AC + ln] if near else cv
                ws[o + _AS + ln] = ws[o + _AS + ln] if near else sv


@njit(forceinline=True, **_OPT)
def _serial_torque(ws: np.ndarray, n: int) -> None:
    """The model law's torque for a serial nominal model per lane: the RNEA at the
    measurement, :math:`\\tau = \\hat M(q_m)\\,a + \\hat h(q_m, \\dot q_m)` with :math:`a`
    in ``_ACC``, into ``_TAU``."""
    _serial_kinematics(ws, n, _QM, _SM)
    _serial_rnea(ws, n, _SM, _QDM, _ACC, True, _L_MG, _TAU)


@njit(**_OPT)
def _paper_law(ws: np.ndarray, joints: tuple[int, ...]) -> None:
    r"""The paper's law per lane (:func:`slidingarm.control._kernels.paper_entry`, its
    operations in its order), from the angles of the measurement in ``_LC``, ``_LS``,
    ``nu`` in ``_NU`` and ``r`` in ``_PR``: :math:`f = -\hat M^{-1} \hat h` by the nominal
    model's ABA (:func:`_aba`) at the measured velocity ``_QDM`` under no torque into
    ``_PF``, each :math:`\hat M^{-1} e_i` by the ABA at rest, without gravity, under the unit
    torque :math:`e_i` (in ``_PRHS``; the zero velocity and input in ``_PZ``, the zero gravity
    in lane row ``_L_T1``) into ``_PCOL``, and :math:`\tau_i = (-f_i - \nu_i) / g_i - r_i`,
    :math:`g_i = [\hat M^{-1}]_{ii}`, into ``_TAU``. A lane where a pivot of those ABAs is
    not positive (lane row ``_L_T0`` cleared) gets NaN torques, as the scalar law."""
    n = len(joints)
    for ln in range(W):
        ws[_L_T0 + ln] = 1.0
        ws[_L_T1 + ln] = 0.0
    for j in range(n):
        o = (J0 + j * JS) & _NONNEG
        for ln in range(W):
            ws[o + _PZ + ln] = 0.0
    _aba(ws, joints, _MM, _QDM, _PZ, _L_MG, _L_T0, _LC, _LS, _PF, _L_MTIP)
    for i in range(n):
        for j in range(n):
            o = (J0 + j * JS) & _NONNEG
            unit = 1.0 if j == i else 0.0
            for ln in range(W):
                ws[o + _PRHS + ln] = unit
        _aba(ws, joints, _MM, _PZ, _PRHS, _L_T1, _L_T0, _LC, _LS, _PCOL, _L_MTIP)
        oi = (J0 + i * JS) & _NONNEG
        for ln in range(W):
            ws[oi + _TAU + ln] = (
                (-ws[oi + _PF + ln] - ws[oi + _NU + ln]) / ws[oi + _PCOL + ln] - ws[oi + _PR + ln]
            )
    for i in range(n):
        oi = (J0 + i * JS) & _NONNEG
        for ln in range(W):
            ws[oi + _TAU + ln] = ws[oi + _TAU + ln] if ws[_L_T0 + ln] != 0.0 else np.nan


@njit(**_OPT)
def _measure(ws: np.ndarray, n: int, k: int, vcode: int, dt: float, has_hold: bool) -> bool:
    """Measurement (``_QM``, from the added and held rows ``_MADD``, ``_MHOLD``) and velocity
    estimate (``_QDM``) per lane, as :func:`slidingarm._engine.control_sample`; whether every
    lane's measurement equals its state."""
    may_hold = has_hold and k > 0
    for j in range(n):
        o = (J0 + j * JS) & _NONNEG
        for ln in range(W):
            v = ws[o + _Q + ln] + ws[o + _MADD + ln]
            held = ws[o + _QMP + ln]
            hold = may_hold & (ws[o + _MHOLD + ln] != 0.0)
            ws[o + _QM + ln] = held if hold else v
    if vcode == E.VEL_TRUE or k == 0:
        for j in range(n):
            o = (J0 + j * JS) & _NONNEG
            for ln in range(W):
                ws[o + _QDM + ln] = ws[o + _QD + ln]
            if vcode != E.VEL_TRUE:
                for ln in range(W):
                    ws[o + _Z0 + ln] = ws[o + _QM + ln]
    elif vcode == E.VEL_DIFFERENCE:
        for j in range(n):
            o = (J0 + j * JS) & _NONNEG
            for ln in range(W):
                ws[o + _QDM + ln] = (ws[o + _QM + ln] - ws[o + _QMP + ln]) / dt
    elif vcode == E.VEL_FILTERED:
        for j in range(n):
            o = (J0 + j * JS) & _NONNEG
            for ln in range(W):
                tf = ws[o + _VF0 + E.VF_TIME_CONSTANT * W + ln]
                ws[o + _QDM + ln] = (tf * ws[o + _QDM + ln] + (ws[o + _QM + ln] - ws[o + _QMP + ln])) / (tf + dt)
    else:
        for j in range(n):
            o = (J0 + j * JS) & _NONNEG
            for ln in range(W):
                lip = ws[o + _VF0 + E.VF_LIPSCHITZ * W + ln]
                sigma = ws[o + _Z0 + ln] - ws[o + _QM + ln]
                sg = _sgn(sigma)
                qdm = ws[o + _QDM + ln]
                ws[o + _Z0 + ln] += dt * (
                    -ws[o + _VF0 + E.VF_LAMBDA1 * W + ln] * math.sqrt(lip * abs(sigma)) * sg + qdm
                )
                ws[o + _QDM + ln] = qdm + dt * (-ws[o + _VF0 + E.VF_LAMBDA0 * W + ln] * lip * sg)
    exact = True
    for j in range(n):
        o = (J0 + j * JS) & _NONNEG
        for ln in range(W):
            ws[o + _QMP + ln] = ws[o + _QM + ln]
            exact &= ws[o + _QM + ln] == ws[o + _Q + ln]
    return exact


@njit(**_OPT)
def _clip(ws: np.ndarray, n: int) -> None:
    """Torque limits, the held input ``tau + d`` (``_DIST``), and in ``_L_BAD`` the first
    joint whose torque or ``s`` is not finite (-1: none), per lane; that joint is looked for
    only in a step where some value is not finite (one vectorised test over all)."""
    allfin = True
    for ln in range(W):
        ws[_L_BAD + ln] = -1.0
    for j in range(n):
        o = (J0 + j * JS) & _NONNEG
        for ln in range(W):
            t_j = ws[o + _TAU + ln]
            lim = ws[o + _TMAX + ln]
            nlim = -lim
            t_c = _clamp(t_j, nlim, lim)
            ws[o + _TAU + ln] = t_c
            ws[o + _TAPP + ln] = t_c + ws[o + _DIST + ln]
            allfin &= math.isfinite(t_c) & math.isfinite(ws[o + _S + ln])
    if allfin:
        return
    for j in range(n):
        o = (J0 + j * JS) & _NONNEG
        for ln in range(W):
            fin = math.isfinite(ws[o + _TAU + ln]) & math.isfinite(ws[o + _S + ln])
            bad = ws[_L_BAD + ln]
            ws[_L_BAD + ln] = float(j) if ((bad < 0.0) & (not fin)) else bad


@njit(**_OPT)
def _check(ws: np.ndarray, n: int, qd_limit: float) -> None:
    """:func:`slidingarm._engine.check_state` per lane into ``_L_CODE``, ``_L_JOINT``; the
    codes worked out only in a step where some lane fails a test (one vectorised test over
    all: every position finite, every speed within ``qd_limit``, every pivot positive)."""
    for ln in range(W):
        ws[_L_CODE + ln] = E.STATUS_OK
        ws[_L_JOINT + ln] = -1.0
    fine = True
    for ln in range(W):
        fine &= ws[_L_OK + ln] != 0.0
    for j in range(n):
        o = (J0 + j * JS) & _NONNEG
        for ln in range(W):
            fine &= math.isfinite(ws[o + _Q + ln]) & (abs(ws[o + _QD + ln]) <= qd_limit)
    if fine:
        return
    for j in range(n):
        o = (J0 + j * JS) & _NONNEG
        for ln in range(W):
            fin = math.isfinite(ws[o + _Q + ln]) & math.isfinite(ws[o + _QD + ln])
            code = ws[_L_CODE + ln]
            first = (code == E.STATUS_OK) & (not fin)
            ws[_L_CODE + ln] = E.STATUS_NONFINITE if first else code
            joint = ws[_L_JOINT + ln]
            ws[_L_JOINT + ln] = float(j) if first else joint
    for ln in range(W):
        code = ws[_L_CODE + ln]
        sing = (code == E.STATUS_OK) & (ws[_L_OK + ln] == 0.0)
        ws[_L_CODE + ln] = E.STATUS_SINGULAR if sing else code
        joint = ws[_L_JOINT + ln]
        ws[_L_JOINT + ln] = 0.0 if sing else joint
    for j in range(n):
        o = (J0 + j * JS) & _NONNEG
        for ln in range(W):
            code = ws[_L_CODE + ln]
            run = (code == E.STATUS_OK) & (abs(ws[o + _QD + ln]) > qd_limit)
            ws[_L_CODE + ln] = E.STATUS_RUNAWAY if run else code
            joint = ws[_L_JOINT + ln]
            ws[_L_JOINT + ln] = float(j) if run else joint


@njit(forceinline=True, **_OPT)
def _stream_metrics(ws: np.ndarray, n: int, tgrid: np.ndarray, q_ref: np.ndarray, k: int,
                    delta_s: float, delta_e: float, start: int, bands_until: int) -> int:  # fmt: skip
    """Sample ``k``'s part of every streamed metric (see :func:`finish_metrics`); returns the
    next value of ``bands_until``, the last sample whose band bookkeeping must run.

    The reaching and settling times keep, per lane and joint, the last sample outside the
    band and the values there and at the next sample (:func:`_track_bands`). That changes
    only at a sample where a lane is outside a band, or at the one after it; at any other
    sample it writes what it reads. So one vectorised test over the lanes (any outside?)
    guards it, and it runs at such samples and the one after (``bands_until``): the same
    values. Measured on the paper's run (FTSMC sign): some lane is outside a band in the
    first 1640 of 9001 samples only; the bookkeeping was about 285 of 575 ticks of the
    metrics phase a block step."""
    nt = tgrid.shape[0]
    wt = tgrid[k] - tgrid[0]
    dtk = tgrid[k] - tgrid[k - 1] if k > 0 else 0.0
    dtn = tgrid[k + 1] - tgrid[k] if k < nt - 1 else 0.0
    for ln in range(W):
        ws[_L_OUT + ln] = 0.0
    for j in range(n):
        o = (J0 + j * JS) & _NONNEG
        qr = q_ref[k, j]
        for ln in range(W):
            e = ws[o + _Q + ln] - qr
            ws[o + _P_SE2 + ln] += e * e
            ws[o + _A_FINAL + ln] = e
            out = (abs(ws[o + _S + ln]) > delta_s) | (abs(e) > delta_e)
            ws[_L_OUT + ln] = 1.0 if out else ws[_L_OUT + ln]
    anyout = False
    for ln in range(W):
        anyout |= ws[_L_OUT + ln] != 0.0
    if anyout:
        bands_until = k + 1
    if k <= bands_until:
        _track_bands(ws, n, q_ref, k, delta_s, delta_e)
    for j in range(n):
        o = (J0 + j * JS) & _NONNEG
        qr = q_ref[k, j]
        if k > 0:
            for ln in range(W):
                ae = abs(ws[o + _Q + ln] - qr)
                ws[o + _P_IAE + ln] += (ae + ws[o + _A_PAE + ln]) * dtk
                ws[o + _P_ITAE + ln] += (wt * ae + ws[o + _A_PWE + ln]) * dtk
        for ln in range(W):
            ae = abs(ws[o + _Q + ln] - qr)
            ws[o + _A_PAE + ln] = ae
            ws[o + _A_PWE + ln] = wt * ae
        if k < nt - 1:
            for ln in range(W):
                tau = ws[o + _TAU + ln]
                ws[o + _P_EFF + ln] += tau * tau * dtn
                ws[o + _A_PEAK + ln] = max(ws[o + _A_PEAK + ln], abs(tau))
            if k > 0:
                for ln in range(W):
                    tau = ws[o + _TAU + ln]
                    ws[o + _P_CHAT + ln] += abs(tau - ws[o + _A_PTAU + ln])
            for ln in range(W):
                ws[o + _A_PTAU + ln] = ws[o + _TAU + ln]
        if k >= start:
            for ln in range(W):
                ws[o + _A_SSE + ln] = max(ws[o + _A_SSE + ln], abs(ws[o + _Q + ln] - qr))
    return bands_until


@njit(inline="always", **_OPT)
def _track_bands(ws: np.ndarray, n: int, q_ref: np.ndarray, k: int, delta_s: float,
                 delta_e: float) -> None:  # fmt: skip
    """Per lane and joint, for ``s`` and for ``e``: the last sample outside the band, the value
    there and the value at the next sample (of :func:`_stream_metrics`)."""
    fk = float(k)
    for j in range(n):
        o = (J0 + j * JS) & _NONNEG
        qr = q_ref[k, j]
        for ln in range(W):
            s = ws[o + _S + ln]
            e = ws[o + _Q + ln] - qr
            _track_band(ws, o + ln, _A_S_LAST, _A_S_XK, _A_S_XK1, s, abs(s) > delta_s, fk)
            _track_band(ws, o + ln, _A_E_LAST, _A_E_XK, _A_E_XK1, e, abs(e) > delta_e, fk)


@njit(inline="always", **_OPT)
def _track_band(ws: np.ndarray, at: int, last_row: int, xk_row: int, xk1_row: int, x: float,
                outside: bool, fk: float) -> None:  # fmt: skip
    """One series' band bookkeeping at sample ``fk`` (value ``x``, ``outside`` its band): the
    last sample outside, the value there, and the value at the sample after it."""
    last = ws[at + last_row]
    x1 = ws[at + xk1_row]
    x1 = x if fk == last + 1.0 else x1
    ws[at + xk1_row] = x if outside else x1
    ws[at + last_row] = fk if outside else last
    xk = ws[at + xk_row]
    ws[at + xk_row] = x if outside else xk


@njit(forceinline=True, **_OPT)
def _fold_sums(ws: np.ndarray, n: int) -> None:
    """Add each metric's partial sum to its compensated sum (:func:`_neumaier`) and clear it."""
    for j in range(n):
        o = (J0 + j * JS) & _NONNEG
        for r in range(5):
            acc = (o + (_MACC + _SUMS[r]) * W) & _NONNEG
            part = (o + (_PART + r) * W) & _NONNEG
            for ln in range(W):
                _neumaier(ws, acc + ln, ws[part + ln])
                ws[part + ln] = 0.0


@njit(inline="always", **_OPT)
def _any_failing(ws: np.ndarray, row: int, none: float) -> bool:
    """Whether any lane has failed before or fails now (lane row ``row`` is not ``none``):
    one vectorised test a step, so that the per-lane bookkeeping (a branch per lane) runs only
    in a step that has something to book."""
    failing = False
    for ln in range(W):
        failing |= (ws[_L_ALIVE + ln] == 0.0) | (ws[row + ln] != none)
    return failing


@njit(**_OPT)
def _reset_lane(ws: np.ndarray, n: int, ln: int) -> None:
    """A failed lane restarts from its initial state: finite values, which cost what a live
    lane's cost; nothing it computes is written any more."""
    for j in range(n):
        o = (J0 + j * JS) & _NONNEG
        q0 = ws[o + _Q0 + ln]
        qd0 = ws[o + _QD0 + ln]
        ws[o + _Q + ln] = q0
        ws[o + _QD + ln] = qd0
        ws[o + _QM + ln] = q0
        ws[o + _QMP + ln] = q0
        ws[o + _QDM + ln] = qd0
        ws[o + _Z0 + ln] = q0
        ws[o + _ST + ln] = 0.0


@njit(**_OPT)
def _book_failures(ws: np.ndarray, n: int, lanes: np.ndarray, status: np.ndarray, sample: int) -> int:
    """Each live lane with a status code other than OK in ``_L_CODE`` (its joint in
    ``_L_JOINT``) fails: ``[code, sample, joint]`` into its run's row of ``status``, and it stops
    living; every dead lane restarts (:func:`_reset_lane`). Returns the lanes still alive."""
    nalive = 0
    for ln in range(W):
        if ws[_L_ALIVE + ln] != 0.0 and ws[_L_CODE + ln] != E.STATUS_OK:
            b = lanes[ln]
            status[b, 0] = int(ws[_L_CODE + ln])
            status[b, 1] = sample
            status[b, 2] = int(ws[_L_JOINT + ln])
            ws[_L_ALIVE + ln] = 0.0
        if ws[_L_ALIVE + ln] == 0.0:
            _reset_lane(ws, n, ln)
        else:
            nalive += 1
    return nalive


@njit(**_OPT)
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
    law_tag: np.ndarray,
    joints: tuple[int, ...],
) -> None:
    """``W`` closed-loop runs of plants ``pp`` (rows, n, W) (gravity ``pg`` (W,)) under
    the sliding-mode law with codes ``codes`` (``CK.NCI``,) and table ``cf`` (``CK.NCF``, n,
    W), nominal models ``mp`` (rows, n, W), ``mg`` (W,) (the kind's tables: 4 rows planar, a
    serial kind's :data:`SERIAL_TABLE_ROWS` or more; the kind is ``law_tag``'s); see the
    module docstring. ``q0, qd0,
    tmax`` are (n, W), ``vfb`` (NVF, n, W).

    Lane ``ln`` is run ``lanes[ln]`` of the batch: it writes its recorded samples (every
    ``stride``-th; none if ``stride == 0``) to ``q_b[lanes[ln], k // stride]`` etc. (arrays
    ``(B, K, n)``), its status to ``status[lanes[ln]]`` and, if ``metrics``, its metric
    accumulators to ``acc[local[ln]]`` ((C, NACC, n)) and its torque to
    ``tau_trace[local[ln]]`` ((C, n, T - 1): the applied torques, each joint's contiguous in
    time; written by every lane at every step, a failed one's too, without a branch: 85 ticks
    less a block step than a test per lane, bench_block_parts), ``local`` indexing the
    caller's chunk of runs. Two
    lanes may be the same run (a padded block): they compute and write the same values.
    ``madd``, ``mhold``, ``dist`` are ``(T, n, W)``, or ``(0, n, W)`` when no lane has any
    (then the measurement is ``q + 0.0`` and the input ``tau + 0.0``, as the scalar loop
    computes them with its zero arrays). ``bands`` is ``(delta_s, delta_e, start)``: the
    metrics' bands and the first sample of the steady-state window. ``joints`` is a tuple
    of ``n`` zeros: its length, part of its type, makes the joint count a compile-time
    constant (see :func:`compiled`).
    """
    nt = tgrid.shape[0]
    n = len(joints)
    if q0.shape[0] != n or pp.shape[1] != n or mp.shape[1] != n or cf.shape[1] != n:
        raise ValueError("run_block: joints must have one entry per joint of q0, pp, mp and cf")
    h = dt / substeps
    has_add = madd.shape[0] > 0
    has_hold = mhold.shape[0] > 0
    has_dist = dist.shape[0] > 0
    wsa = np.zeros(workspace_size(n))
    ws = E._borrow(wsa)
    fast_terminal = codes[CK.CI_SURFACE] == CK.SURFACE_FAST_TERMINAL
    swcode = codes[CK.CI_SWITCHING]
    classic = codes[CK.CI_REACHING] == CK.REACH_CLASSIC
    delta_s = bands[0]
    delta_e = bands[1]
    start = int(bands[2])
    bands_until = 0
    for ln in range(W):
        ws[_L_G + ln] = pg[ln]
        ws[_L_MG + ln] = mg[ln]
        ws[_L_ALIVE + ln] = 1.0
        status[lanes[ln], 0] = E.STATUS_OK
        status[lanes[ln], 1] = -1
        status[lanes[ln], 2] = -1
    for j in range(n):
        o = (J0 + j * JS) & _NONNEG
        for ln in range(W):
            ws[o + _Q0 + ln] = q0[j, ln]
            ws[o + _QD0 + ln] = qd0[j, ln]
            ws[o + _Q + ln] = q0[j, ln]
            ws[o + _QD + ln] = qd0[j, ln]
            ws[o + _TMAX + ln] = tmax[j, ln]
            for r in range(4):
                ws[o + _PM + r * W + ln] = pp[r, j, ln]
                ws[o + _MM + r * W + ln] = mp[r, j, ln]
                ws[o + _VF0 + r * W + ln] = vfb[r, j, ln]
            for r in range(CK.NCF):
                ws[o + _CFA + r * W + ln] = cf[r, j, ln]
            ws[o + _EPSG + ln] = cf[CK.CF_EPS_E, j, ln] ** (cf[CK.CF_GAMMA, j, ln] - 1.0)
            ws[o + _A_S_LAST + ln] = -1.0
            ws[o + _A_E_LAST + ln] = -1.0
    _load_tables(ws, n, pp, mp, law_tag)
    for k in range(nt):
        if has_add or has_hold or has_dist:
            for j in range(n):
                o = (J0 + j * JS) & _NONNEG
                for ln in range(W):
                    if has_add:
                        ws[o + _MADD + ln] = madd[k, j, ln]
                    if has_hold:
                        ws[o + _MHOLD + ln] = 1.0 if mhold[k, j, ln] else 0.0
                    if has_dist:
                        ws[o + _DIST + ln] = dist[k, j, ln]
        exact = _measure(ws, n, k, vcode, dt, has_hold)
        _law(ws, joints, k, fast_terminal, swcode, classic, law_tag, dt, q_ref, qd_ref, qdd_ref)
        _clip(ws, n)
        if stride > 0 and k % stride == 0:
            kk = k // stride
            for ln in range(W):
                if ws[_L_ALIVE + ln] != 0.0:
                    b = lanes[ln]
                    for j in range(n):
                        o = ((J0 + j * JS) & _NONNEG) + ln
                        q_b[b, kk, j] = ws[o + _Q]
                        qd_b[b, kk, j] = ws[o + _QD]
                        qm_b[b, kk, j] = ws[o + _QM]
                        qdm_b[b, kk, j] = ws[o + _QDM]
                        tau_b[b, kk, j] = ws[o + _TAU]
                        s_b[b, kk, j] = ws[o + _S]
        if metrics:
            bands_until = _stream_metrics(ws, n, tgrid, q_ref, k, delta_s, delta_e, start, bands_until)
            if k % FOLD == FOLD - 1:
                _fold_sums(ws, n)
            if k < nt - 1:
                for j in range(n):
                    o = (J0 + j * JS) & _NONNEG
                    for ln in range(W):
                        tau_trace[local[ln], j, k] = ws[o + _TAU + ln]
        nalive = W
        if _any_failing(ws, _L_BAD, -1.0):
            # a non-finite torque or s as a status code (_check rewrites these rows anyway)
            for ln in range(W):
                bad = ws[_L_BAD + ln]
                ws[_L_CODE + ln] = E.STATUS_NONFINITE if bad >= 0.0 else E.STATUS_OK
                ws[_L_JOINT + ln] = bad
            nalive = _book_failures(ws, n, lanes, status, k)
        if nalive == 0 or k == nt - 1:
            break
        # --- plant over [t_k, t_k+1)
        for ln in range(W):
            ws[_L_OK + ln] = 1.0
        for sub in range(substeps):
            _plant_step(ws, joints, h, exact and sub == 0, law_tag)
        _check(ws, n, qd_limit)
        nalive = W
        if _any_failing(ws, _L_CODE, float(E.STATUS_OK)):
            nalive = _book_failures(ws, n, lanes, status, k + 1)
        if nalive == 0:
            break
    if metrics:
        _fold_sums(ws, n)
        for ln in range(W):
            if ws[_L_ALIVE + ln] != 0.0:
                b = local[ln]
                for r in range(NACC):
                    for j in range(n):
                        acc[b, r, j] = ws[J0 + j * JS + (_MACC + r) * W + ln]


_compiled: set[tuple[bool, bool, int]] = set()


@contextmanager
def _slp_vectorised() -> Iterator[None]:
    """numba's SLP vectoriser on, for a compilation that happens in the block."""
    saved = _numba_config.SLP_VECTORIZE
    _numba_config.SLP_VECTORIZE = 1
    try:
        yield
    finally:
        _numba_config.SLP_VECTORIZE = saved


def _interleave_lanes() -> bool:
    """Whether the planar kernels' lane loops are compiled :func:`_interleaved`: where numba
    compiles for a processor without AVX-512, where it was measured; for an AVX-512 one LLVM
    keeps its own choice, with which the figures there were measured. The serial kind's
    kernels are not (UR5, FTSMC tanh, B = 64, 1 thread, Zen 2: 8.43e5 arm-steps/s as they
    are, 6.12e5 interleaved, 8.18e5 interleaved with the RK4 step compiled first)."""
    from numba.core.registry import cpu_target

    features = cpu_target.target_context.codegen().magic_tuple()[2]
    return "+avx512f" not in features.split(",")


@contextmanager
def _interleaved() -> Iterator[None]:
    """LLVM's loop vectoriser interleaving four vector iterations of a loop while a kernel
    compiles, and its own choice again after (``-force-vector-interleave``, a process-wide LLVM
    option: set and reset under numba's compiler lock, so that no other compilation sees it).

    Why: on AVX2 (four float64 a register) LLVM vectorises a lane loop whose body is long
    (the law's power, sines and cosines, each a chain of dependent polynomial steps) four
    lanes at a time, one chain after the other, and the processor overlaps little of them;
    interleaved four times, the loop does its sixteen lanes in one iteration, each operation
    on four registers side by side: four chains in flight. Measured on the paper arm (Zen 2,
    bench_block_parts, FTSMC sign, two runs each): the law 1674-1684 -> 1462-1470 ticks a
    block step, the block step 4695-4718 -> 4455-4497; with the paper's law, the law
    3154-3179 -> 2772-2858, the block step 6142-6195 -> 5783-5900. The articulated-body passes
    (:func:`_rk4`, :func:`_paper_law`), which keep a pass's values in registers, spill so
    (the RK4 step 2090 -> 2760 ticks): :func:`compiled` compiles them first, at LLVM's own
    choice, and the kernel links them as they are. Forcing the vector width (16) instead gave
    the same and made LLVM print a remark for every loop it could not vectorise. No result
    changes (the vectoriser does not reorder a floating-point operation)."""
    with global_compiler_lock:
        _llvm.set_option("", f"-force-vector-interleave={W // 4}")  # four float64 a register
        try:
            yield
        finally:
            _llvm.set_option("", "-force-vector-interleave=0")


def joints_tag(n: int) -> tuple[int, ...]:
    """The ``joints`` argument of :func:`run_block` for ``n`` joints: ``n`` zeros."""
    return (0,) * int(n)


def compiled(paper: bool = False, n: int = 3, *, serial: bool = False) -> None:
    """Compile (or load from the cache) :func:`run_block` for the model law on planar arms,
    with ``paper`` for the paper's law, with ``serial`` for the model law on serial arms (each
    a signature of its own, compiled only when a batch needs it), for arms of ``n`` joints,
    with the SLP vectoriser on: it is what turns the unrolled lane loops into vector
    operations. Called by the batch before its first block of that law, kind and joint count;
    a no-op afterwards.

    The joint count is part of the signature (:func:`joints_tag`), so that LLVM sees a
    constant ``n``: it unrolls the loops over joints and keeps in registers what a loop over a
    run-time ``n`` stores to the workspace and loads back at the next joint. Measured on the
    paper's arm (AMD EPYC, AVX-512): the RK4 step of a block 3400 -> 1800 cycles, a whole
    block step about -20 %; each joint count compiles (and caches) a kernel of its own."""
    if isinstance(n, bool) or not isinstance(n, numbers.Integral) or n < 1:
        raise ValueError(f"n must be an integer >= 1, got {n!r}")
    n = int(n)
    if paper and serial:
        raise ValueError("the paper's law has no serial-arm block kernel")
    if (paper, serial, n) in _compiled:
        return
    from numba import types as T

    f8 = T.float64
    i8 = T.int64
    a1 = T.Array(f8, 1, "C")
    a2 = T.Array(f8, 2, "C")
    a3 = T.Array(f8, 3, "C")
    tag = T.Array(T.int8 if paper else (T.float32 if serial else f8), 1, "C")
    sig = (
        T.Array(i8, 1, "C"), T.Array(i8, 1, "C"), a3, a1, a1, a3, a3, a1, a2, a2, a1, a2, a2,
        a2, a3, T.Array(T.boolean, 3, "C"), i8, a3, a3, a2, f8, i8, f8, i8, a3, a3, a3, a3,
        a3, a3, T.boolean, a1, a3, a3, T.Array(i8, 2, "C"), tag, T.UniTuple(i8, n),
    )  # fmt: skip
    # no automatic garbage collection while numba compiles (slidingarm._gc): 12.1 -> 11.2
    # CPU-s for the planar kernel, measured cold
    with _slp_vectorised(), paused():
        if serial or not _interleave_lanes():
            run_block.compile(sig)
        else:
            # the passes that keep their values in registers at LLVM's own width first
            rk4_sig = (a1, T.UniTuple(i8, n), f8, T.boolean)
            _rk4.compile(rk4_sig)
            if paper:
                _paper_law.compile((a1, T.UniTuple(i8, n)))
            with _interleaved():
                run_block.compile(sig)
    _compiled.add((paper, serial, n))


#: The metrics :func:`_finish_streamed` works out, in the order of its output's rows.
_STREAMED = (
    "mse", "rmse", "iae", "itae", "reaching_time", "settling_time", "steady_state_error",
    "final_error", "control_effort", "peak_torque", "chattering",
)  # fmt: skip


@njit(inline="always", **_OPT)
def _entry_time(t: np.ndarray, last: float, xk: float, xk1: float, delta: float) -> float:
    """:func:`slidingarm.metrics._entry_time` of one series from the streamed last sample
    outside the band (``-1``: none) and the values there and at the next sample: the same
    formulas (the crossing of the band's edge ``sign(x_k) delta`` interpolated linearly in
    ``[t_k, t_{k+1}]``; ``t_0`` if never outside, ``inf`` if outside at the last sample)."""
    nt = t.shape[0]
    if not last >= 0.0:
        return t[0]
    li = int(last)
    if li == nt - 1:
        return math.inf
    nxt = min(li + 1, nt - 1)
    sg = 1.0 if xk > 0.0 else (-1.0 if xk < 0.0 else (0.0 if xk == 0.0 else xk))
    level = sg * delta
    denom = xk - xk1
    safe = 1.0 if denom == 0.0 else denom
    frac = (xk - level) / safe
    frac = frac if frac != frac else (0.0 if frac < 0.0 else (1.0 if frac > 1.0 else frac))
    return t[li] + frac * (t[nxt] - t[li])


@njit(**_OPT)
def _finish_streamed(t: np.ndarray, acc: np.ndarray, failed: np.ndarray, delta_s: float,
                     delta_e: float, out: np.ndarray) -> None:  # fmt: skip
    """The metrics of :data:`_STREAMED` from the accumulators ``acc`` (C, NACC, n) into
    ``out`` (len(_STREAMED), C, n), NaN for ``failed`` runs: :func:`finish_metrics`' formulas
    (a compensated sum is its total plus its compensation; ``mse`` the sum of squares over
    ``T``, ``iae`` and ``itae`` halves of their trapezoid sums, ``chattering`` over the
    span), compiled: as two dozen numpy calls on (C, n) arrays they took 0.2 ms a block."""
    nt = t.shape[0]
    span = t[nt - 1] - t[0]
    for b in range(acc.shape[0]):
        for j in range(acc.shape[2]):
            mse = (acc[b, M_SE2, j] + acc[b, M_SE2C, j]) / nt
            out[0, b, j] = mse
            out[1, b, j] = math.sqrt(mse)
            out[2, b, j] = 0.5 * (acc[b, M_IAE, j] + acc[b, M_IAEC, j])
            out[3, b, j] = 0.5 * (acc[b, M_ITAE, j] + acc[b, M_ITAEC, j])
            out[4, b, j] = _entry_time(t, acc[b, M_S_LAST, j], acc[b, M_S_XK, j], acc[b, M_S_XK1, j], delta_s)
            out[5, b, j] = _entry_time(t, acc[b, M_E_LAST, j], acc[b, M_E_XK, j], acc[b, M_E_XK1, j], delta_e)
            out[6, b, j] = acc[b, M_SSE, j]
            out[7, b, j] = acc[b, M_FINAL, j]
            out[8, b, j] = acc[b, M_EFF, j] + acc[b, M_EFFC, j]
            out[9, b, j] = acc[b, M_PEAK, j]
            out[10, b, j] = (acc[b, M_CHAT, j] + acc[b, M_CHATC, j]) / span
            if failed[b]:
                for r in range(out.shape[0]):
                    out[r, b, j] = np.nan


def finish_metrics(
    t: np.ndarray,
    acc: np.ndarray,
    tau_trace: np.ndarray,
    failed: np.ndarray,
    *,
    delta_s: float,
    delta_e: float,
    cutoff_hz: float,
    work: SpectrumWork | None = None,
) -> dict[str, np.ndarray]:
    """The metrics of :func:`slidingarm.results.metric_values` from the streamed accumulators
    ``acc`` (B, NACC, n) and the applied torques ``tau_trace`` (B, n, T - 1), NaN for
    ``failed`` runs (:func:`_finish_streamed`, :func:`hf_power_share`); ``work``: the
    spectral metric's buffers (:class:`SpectrumWork`). ``tau_trace`` is scratch:
    :func:`hf_power_share` overwrites it with its residuals."""
    failed = np.ascontiguousarray(failed, dtype=np.bool_)
    streamed = np.empty((len(_STREAMED), acc.shape[0], acc.shape[2]))
    _finish_streamed(t, np.ascontiguousarray(acc), failed, float(delta_s), float(delta_e), streamed)
    if failed.any():
        # a failed run's trace is its restarted lane's (possibly a NaN where it failed); its
        # metrics are NaN either way, and zeros keep the FFT's input finite
        tau_trace[failed] = 0.0
    out = dict(zip(_STREAMED, streamed, strict=True))
    share = hf_power_share(t, tau_trace, cutoff_hz, work=work)
    share[failed] = np.nan
    out["hf_power_share"] = share
    return out


@njit(inline="always", **_OPT)
def _sum(x: np.ndarray, lo: int, hi: int) -> float:
    r""":math:`\sum_{k=lo}^{hi-1} x_k` in blocks of 128, each by eight interleaved partial
    sums combined pairwise (as numpy's pairwise sum does at its leaves), the blocks' sums in
    turn: a rounding error of at most about ``(16 + (hi - lo) / 128) eps`` of the sum of
    :math:`|x_k|`, and eight independent additions in flight instead of one chain. The index
    is masked (:data:`_NONNEG`) as in the kernel, here and in the other passes over a trace
    below; with numba's wraparound select per access, these passes ran scalar code (the
    detrending of a block 1.2 ms, see :func:`spectral_compiled`)."""
    total = 0.0
    k = lo
    while k < hi:
        end = min(k + 128, hi)
        r0 = r1 = r2 = r3 = r4 = r5 = r6 = r7 = 0.0
        m = k + ((end - k) // 8) * 8
        for i0 in range(k, m, 8):
            i = i0 & _NONNEG
            r0 += x[i]
            r1 += x[i + 1]
            r2 += x[i + 2]
            r3 += x[i + 3]
            r4 += x[i + 4]
            r5 += x[i + 5]
            r6 += x[i + 6]
            r7 += x[i + 7]
        part = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
        for i0 in range(m, end):
            i = i0 & _NONNEG
            part += x[i]
        total += part
        k = end
    return total


@njit(inline="always", **_OPT)
def _line_sums(row: np.ndarray, tc: np.ndarray, a0: float, lo: int, hi: int) -> tuple[float, float, float]:
    """Over ``row[lo:hi]``: :math:`\\sum (a - a_0)`, :math:`\\sum t_c (a - a_0)` by eight
    interleaved partial sums each, combined pairwise, and :math:`\\max |a|`."""
    a_0 = a_1 = a_2 = a_3 = a_4 = a_5 = a_6 = a_7 = 0.0
    t_0 = t_1 = t_2 = t_3 = t_4 = t_5 = t_6 = t_7 = 0.0
    m_0 = m_1 = m_2 = m_3 = m_4 = m_5 = m_6 = m_7 = 0.0
    m = lo + ((hi - lo) // 8) * 8
    for i0 in range(lo, m, 8):
        i = i0 & _NONNEG
        d0 = row[i] - a0
        d1 = row[i + 1] - a0
        d2 = row[i + 2] - a0
        d3 = row[i + 3] - a0
        d4 = row[i + 4] - a0
        d5 = row[i + 5] - a0
        d6 = row[i + 6] - a0
        d7 = row[i + 7] - a0
        a_0 += d0
        a_1 += d1
        a_2 += d2
        a_3 += d3
        a_4 += d4
        a_5 += d5
        a_6 += d6
        a_7 += d7
        t_0 += tc[i] * d0
        t_1 += tc[i + 1] * d1
        t_2 += tc[i + 2] * d2
        t_3 += tc[i + 3] * d3
        t_4 += tc[i + 4] * d4
        t_5 += tc[i + 5] * d5
        t_6 += tc[i + 6] * d6
        t_7 += tc[i + 7] * d7
        # a select each (``max`` is a compare and a branch), eight independent chains
        v0 = abs(row[i])
        v1 = abs(row[i + 1])
        v2 = abs(row[i + 2])
        v3 = abs(row[i + 3])
        v4 = abs(row[i + 4])
        v5 = abs(row[i + 5])
        v6 = abs(row[i + 6])
        v7 = abs(row[i + 7])
        m_0 = v0 if v0 > m_0 else m_0
        m_1 = v1 if v1 > m_1 else m_1
        m_2 = v2 if v2 > m_2 else m_2
        m_3 = v3 if v3 > m_3 else m_3
        m_4 = v4 if v4 > m_4 else m_4
        m_5 = v5 if v5 > m_5 else m_5
        m_6 = v6 if v6 > m_6 else m_6
        m_7 = v7 if v7 > m_7 else m_7
    sa = ((a_0 + a_1) + (a_2 + a_3)) + ((a_4 + a_5) + (a_6 + a_7))
    st = ((t_0 + t_1) + (t_2 + t_3)) + ((t_4 + t_5) + (t_6 + t_7))
    top = max(max(max(m_0, m_1), max(m_2, m_3)), max(max(m_4, m_5), max(m_6, m_7)))
    for i0 in range(m, hi):
        i = i0 & _NONNEG
        d = row[i] - a0
        sa += d
        st += tc[i] * d
        top = max(top, abs(row[i]))
    return sa, st, top


@njit(inline="always", **_OPT)
def _residual(row: np.ndarray, tc: np.ndarray, abar: float, slope: float, lo: int, hi: int) -> float:
    """``row[lo:hi]`` minus the line :math:`\\bar a + b t_c`, in place; the sum of the
    residual's squares by eight interleaved partial sums, combined pairwise."""
    s_0 = s_1 = s_2 = s_3 = s_4 = s_5 = s_6 = s_7 = 0.0
    m = lo + ((hi - lo) // 8) * 8
    for i0 in range(lo, m, 8):
        i = i0 & _NONNEG
        r0 = row[i] - abar - slope * tc[i]
        r1 = row[i + 1] - abar - slope * tc[i + 1]
        r2 = row[i + 2] - abar - slope * tc[i + 2]
        r3 = row[i + 3] - abar - slope * tc[i + 3]
        r4 = row[i + 4] - abar - slope * tc[i + 4]
        r5 = row[i + 5] - abar - slope * tc[i + 5]
        r6 = row[i + 6] - abar - slope * tc[i + 6]
        r7 = row[i + 7] - abar - slope * tc[i + 7]
        row[i] = r0
        row[i + 1] = r1
        row[i + 2] = r2
        row[i + 3] = r3
        row[i + 4] = r4
        row[i + 5] = r5
        row[i + 6] = r6
        row[i + 7] = r7
        s_0 += r0 * r0
        s_1 += r1 * r1
        s_2 += r2 * r2
        s_3 += r3 * r3
        s_4 += r4 * r4
        s_5 += r5 * r5
        s_6 += r6 * r6
        s_7 += r7 * r7
    ss = ((s_0 + s_1) + (s_2 + s_3)) + ((s_4 + s_5) + (s_6 + s_7))
    for i0 in range(m, hi):
        i = i0 & _NONNEG
        r = row[i] - abar - slope * tc[i]
        row[i] = r
        ss += r * r
    return ss


@njit(**_OPT)
def _detrend(x: np.ndarray, ta: np.ndarray, rms: np.ndarray, scale: np.ndarray) -> None:
    r"""Per series ``a = x[c, j]`` (its applied torques at the times ``ta``, ``N`` of them),
    in place: the residual of its least-squares line in time,
    :math:`r = a - \bar a - b\,t_c` with :math:`t_c = t - \bar t` and
    :math:`b = \sum t_c (a - \bar a) / \sum t_c^2`; its RMS into ``rms[c, j]`` and
    :math:`\max |a|` into ``scale[c, j]``.

    Two passes over each series, in blocks of 128 samples (eight interleaved partial sums in
    a block, the blocks' sums in turn, as :func:`_sum`): the first sums :math:`a - a_0` and
    :math:`t_c (a - a_0)`, shifted by the first sample so that a large mean does not swamp
    them, and takes the maximum (:func:`_line_sums`); then :math:`\bar a = a_0 + \sum (a -
    a_0) / N` and :math:`b = (\sum t_c (a - a_0) - (\bar a - a_0) \sum t_c) / \sum
    t_c^2` (the :math:`\sum t_c` term, zero but for rounding, keeps it the least-squares
    line); the second writes the residual and sums its squares (:func:`_residual`)."""
    nc, n, nn = x.shape
    tc = ta - _sum(ta, 0, nn) / nn
    stc = _sum(tc, 0, nn)
    sq = tc * tc
    stt = _sum(sq, 0, nn)
    for c in range(nc):
        for j in range(n):
            row = x[c, j]
            a0 = row[0]
            sa = 0.0
            sta = 0.0
            top = 0.0
            for k in range(0, nn, 128):
                ba, bt, bm = _line_sums(row, tc, a0, k, min(k + 128, nn))
                sa += ba
                sta += bt
                top = max(top, bm)
            shift = sa / nn
            abar = a0 + shift
            slope = (sta - shift * stc) / stt
            ss = 0.0
            for k in range(0, nn, 128):
                ss += _residual(row, tc, abar, slope, k, min(k + 128, nn))
            rms[c, j] = math.sqrt(ss / nn)
            scale[c, j] = top


@njit(**_OPT)
def _power_sums(spectrum: np.ndarray, first_high: int, even: bool, out: np.ndarray) -> None:
    r"""One-sided weighted power of each series' ``rfft`` (C, n, K): :math:`\sum_k w_k
    |X_k|^2` into ``out[0]`` and the same over ``k >= first_high`` into ``out[1]``, with
    :math:`w_0 = 1`, :math:`w_{K-1} = 1` for an even series length, 2 otherwise (sums by
    :func:`_sum`)."""
    nc, n, nk = spectrum.shape
    wp = np.empty(nk)
    for c in range(nc):
        for j in range(n):
            row = spectrum[c, j]
            for k0 in range(nk):
                k = k0 & _NONNEG
                x = row[k]
                wp[k] = 2.0 * (x.real * x.real + x.imag * x.imag)
            wp[0] *= 0.5
            if even:
                wp[nk - 1] *= 0.5
            out[0, c, j] = _sum(wp, 0, nk)
            out[1, c, j] = _sum(wp, min(first_high, nk), nk)


def spectral_compiled() -> None:
    """Compile :func:`_detrend` and :func:`_power_sums` for the arrays :func:`hf_power_share`
    passes (or load them from the cache), with the SLP vectoriser on, as :func:`compiled`
    does the kernel: it packs their eight interleaved partial sums into vector operations
    (the same operations in the same order: the same bits). Measured on 48 traces of 9000
    samples (a block of the paper's run, Zen 2): the detrending 1.21 -> 0.46 ms, the power
    sums 0.32 -> 0.17 ms (0.77 and 0.16 with the masked indices alone). A no-op after the
    first call."""
    global _spectral_ready
    if _spectral_ready:
        return
    from numba import types as T

    f8 = T.float64
    a2 = T.Array(f8, 2, "C")
    a3 = T.Array(f8, 3, "C")
    with _slp_vectorised(), paused():
        _detrend.compile((a3, T.Array(f8, 1, "C"), a2, a2))
        _power_sums.compile((T.Array(T.complex128, 3, "C"), T.int64, T.boolean, a3))
    _spectral_ready = True


_spectral_ready = False


#: Series per transform of :func:`_spectra`: a multiple of any SIMD group ducc0 forms.
FFT_GROUP = 16


def _spectra(tau: np.ndarray, work: SpectrumWork | None) -> np.ndarray:
    """``rfft`` of each series of ``tau`` (C, n, N) along its last axis (numpy's transform:
    :math:`X_k = \\sum_t x_t e^{-2\\pi i k t / N}`, unscaled), by ``ducc0.fft.r2c`` on one
    thread: 1.01 against numpy's 1.51 ms for a block's 48 series of 9000 (Zen 2, median of
    40). ducc0 transforms the series in SIMD groups and a remainder one at a time, which
    round differently (measured: the last of an odd number of series differs in its last
    bits); so that a run's spectrum does not depend on the block it is in (how many runs,
    at which place), every transform covers a multiple of :data:`FFT_GROUP` series: the
    rows after ``tau``'s in ``work`` (a block's buffer: stale finite values or zeros), or
    zeros. Returns the spectra of ``tau``'s series (C, n, N // 2 + 1)."""
    import ducc0

    nc, n, nn = tau.shape
    cp = nc
    while (cp * n) % FFT_GROUP:
        cp += 1
    nk = nn // 2 + 1
    if (
        work is not None
        and work.trace.shape[0] >= cp
        and work.trace.shape[1:] == (n, nn)
        and tau.ctypes.data == work.trace.ctypes.data
    ):
        src = work.trace[:cp]
        out = work.spectrum[:cp]
    else:
        src = np.zeros((cp, n, nn))
        src[:nc] = tau
        out = np.empty((cp, n, nk), dtype=np.complex128)
    ducc0.fft.r2c(src, axes=(2,), forward=True, nthreads=1, out=out)
    return out[:nc]


class SpectrumWork:
    """Buffers of :func:`hf_power_share` for up to ``runs`` runs of ``samples`` samples
    (``n`` joints), reused by every block of a chunk: the applied torques ``(runs, n,
    samples - 1)`` (the kernel's output, detrended in place) and their spectra. Arrays of a
    block's size made afresh each block (1.7 MB each for the paper's run) cost about 900 page
    faults a block, and their first touch evicted what the kernel had left in cache
    (measured: the Python part of a metrics-mode block 30 % of its time). Not shared between
    threads: each chunk's loop makes its own."""

    def __init__(self, runs: int, samples: int, n: int) -> None:
        applied = max(samples - 1, 1)
        # zeros: rows a block does not use are transformed too (_spectra), and stay finite
        self.trace = np.zeros((runs, n, applied))
        self.spectrum = np.empty((runs, n, applied // 2 + 1), dtype=np.complex128)


def hf_power_share(
    t: np.ndarray, tau: np.ndarray, cutoff_hz: float, *, work: SpectrumWork | None = None
) -> np.ndarray:
    """:func:`slidingarm.metrics.hf_power_share` of the applied torques ``tau`` (C, n, T - 1)
    on the validated uniform grid ``t``: the same formulas (least-squares detrending,
    one-sided weighted power of ``rfft`` above ``cutoff_hz`` over all of it, 0 for a flat
    series), the detrending (in place: ``tau`` is left holding the residuals) and the power
    sums compiled (:func:`_detrend`, :func:`_power_sums`: numpy's dozen passes over a block's
    traces were a quarter of a metrics-mode block's time, with the GIL held), ducc0's FFT
    between them (:func:`_spectra`). The sums round differently from numpy's pairwise ones,
    and ducc0's transform from numpy's (both to about 1e-15 relative here)."""
    from slidingarm import metrics as M

    ta = np.ascontiguousarray(t[:-1])
    n_applied = ta.shape[0]
    dt = float(np.mean(np.diff(t)))
    nc, n, _ = tau.shape
    if n_applied < 2 or not cutoff_hz < 0.5 / dt:
        # the metric's own answer (zeros) or error (a cut-off beyond the Nyquist frequency),
        # on the (C, T, n) traces it takes
        full = np.zeros((nc, t.shape[0], n))
        full[:, :n_applied] = np.swapaxes(tau[..., :n_applied], -1, -2)
        return np.asarray(M.hf_power_share(t, full, cutoff_hz=cutoff_hz), dtype=np.float64)
    if tau.shape[-1] != n_applied or not tau.flags.c_contiguous:
        raise ValueError(f"tau must be a C-contiguous (C, n, {n_applied}) array, got {tau.shape}")
    rms = np.empty((nc, n))
    scale = np.empty((nc, n))
    spectral_compiled()
    _detrend(tau, ta, rms, scale)
    spectrum = _spectra(tau, work)
    freqs = np.fft.rfftfreq(n_applied, d=dt)
    sums = np.empty((2, nc, n))
    first_high = int(np.searchsorted(freqs, cutoff_hz, side="right"))
    _power_sums(spectrum, first_high, n_applied % 2 == 0, sums)
    total, high = sums
    flat = rms <= M._FLAT_RTOL * scale
    share = np.where(flat, 0.0, high / np.where(flat, 1.0, total))
    return np.asarray(np.clip(share, 0.0, 1.0), dtype=np.float64)


def steady_start(t: np.ndarray, window: float) -> int:
    """First sample of :func:`slidingarm.metrics.steady_state_error`'s final window."""
    tol = 1e-9 * (t[-1] - t[0])
    return int(np.searchsorted(t, t[-1] - window - tol, side="left"))
