"""Compiled sliding-mode control law (docs/theory.md §3), shared by the Python call path and the simulator.

A sliding-mode controller reaches compiled code as one float64 parameter vector ``p``, private
to this family: ``NCI`` integer codes (stored as floats) followed by the ``(NCF, n)`` table of
per-joint parameters, row by row (:func:`pack`): code ``i`` is ``p[i]`` (a small integer, exact as a float, compared as one), parameter ``(row, j)`` is
``p[NCI + row n + j]``. The nominal arm
the law uses is a model handle ``(mkind, mparams, mg)`` evaluated through
:mod:`slidingarm.models._dispatch`. The codes and row indices are defined here, once.

The law, per joint, with :math:`e = q - q_d`, :math:`\\dot e = \\dot q - \\dot q_d`:

.. math::

    a = \\ddot q_d - \\nu(e, \\dot e) - r(s), \\qquad \\tau = \\hat M(q)\\,a + \\hat h(q, \\dot q)

where :math:`s` and :math:`\\nu` come from the surface and :math:`r` from the reaching law.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit, types
from numba.extending import overload

from slidingarm import _vecmath as VM
from slidingarm._pointers import as_writable as _w
from slidingarm._pointers import function_at, inline_unless_linked, linked
from slidingarm.models import _dispatch as MD
from slidingarm.models import _kernels as PK

# --- integer codes: ci[CI_*] ------------------------------------------------------------------
CI_SURFACE = 0
CI_SWITCHING = 1
CI_LAW = 2
CI_REACHING = 3
NCI = 4

SURFACE_FAST_TERMINAL = 0  # s = ed + alpha e + beta sig(e)^gamma (PD: beta = 0; TSM: alpha = 0)
SURFACE_NONSINGULAR = 1  # s = e + (1/beta) sig(ed)^gamma, 1 < gamma < 2 (Feng et al. 2002)

SWITCH_SIGN = 0
SWITCH_TANH = 1
SWITCH_SAT = 2

LAW_MODEL = 0
LAW_PAPER = 1

REACH_CLASSIC = 0  # r = k phi(s)
REACH_SUPER_TWISTING = 1  # r = k sig(s)^(1/2) + w,  w' = k2 sign(s)

# --- float rows: cf[CF_*, j] ------------------------------------------------------------------
CF_ALPHA = 0
CF_BETA = 1
CF_GAMMA = 2
CF_K = 3
CF_WIDTH = 4
CF_K2 = 5
CF_EPS_E = 6
NCF = 7

# rows of the control workspace after the dynamics' MD.WORK_ROWS: nu, r, the commanded
# acceleration (also the paper's law's row of zeros), the paper's law's unit input, its
# solution and f, and the bias h that the engine hands to a custom law
_ROW_NU = MD.WORK_ROWS
_ROW_R = MD.WORK_ROWS + 1
_ROW_ACC = MD.WORK_ROWS + 2
_ROW_RHS = MD.WORK_ROWS + 3
_ROW_COL = MD.WORK_ROWS + 4
_ROW_F = MD.WORK_ROWS + 5
ROW_H = MD.WORK_ROWS + 6

#: Rows of the control workspace ``work`` (shape ``(CONTROL_WORK_ROWS, n)``).
CONTROL_WORK_ROWS = MD.WORK_ROWS + 7


def pack(ci: np.ndarray, cf: np.ndarray) -> np.ndarray:
    """The parameter vector ``p`` of codes ``ci`` (NCI,) and table ``cf`` (NCF, n)."""
    return np.concatenate([np.asarray(ci, dtype=np.float64), np.ravel(cf)])


# ``forceinline=False`` stated: numba hands a caller's ``forceinline`` on to the functions it
# compiles while compiling the caller (:func:`sliding_mode_into` has it), and these stay calls.
@njit(cache=True, nogil=True, error_model="numpy", forceinline=False)
def pow_abs(x: float, g: float) -> float:
    """:math:`|x|^g` (``g > 0``) by :func:`slidingarm._vecmath.pow_abs` (at most 1 ulp),
    the function the block loop (:mod:`slidingarm._block`) inlines into its lane loops, so that
    a run is bit-identical on both paths; one compiled body for every call here."""
    return VM.pow_abs(x, g)


@njit(cache=True, nogil=True, error_model="numpy", forceinline=False)
def tanh(x: float) -> float:
    """``tanh x`` by :func:`slidingarm._vecmath.tanh` (at most 1 ulp), as :func:`pow_abs`."""
    return VM.tanh(x)


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _sign(x: float) -> float:
    if x > 0.0:
        return 1.0
    if x < 0.0:
        return -1.0
    return 0.0


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def switch(code: int, s: float, width: float, vec: bool = False) -> float:
    """Switching function :math:`\\varphi`: ``sign(s)``, ``tanh(s/ε)`` or ``sat(s/ε)``;
    ``vec``: ``tanh`` by :func:`tanh` (the block loop's), else by libm."""
    if code == SWITCH_SIGN:
        return _sign(s)
    if code == SWITCH_TANH:
        return tanh(s / width) if vec else math.tanh(s / width)
    x = s / width
    if x > 1.0:
        return 1.0
    if x < -1.0:
        return -1.0
    return x


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _surface_joint(
    p: np.ndarray, j: int, n: int, ej: float, edj: float, vec: bool = False
) -> tuple[float, float]:
    """``(s, nu)`` of joint ``j`` for the errors ``ej, edj``; see :func:`surface_into`.
    ``vec``: the powers by :func:`pow_abs` (the block loop's), else by libm."""
    if p[CI_SURFACE] == SURFACE_FAST_TERMINAL:
        alpha = p[NCI + CF_ALPHA * n + j]
        beta = p[NCI + CF_BETA * n + j]
        s = edj + alpha * ej
        gain = alpha
        if beta != 0.0:
            gamma = p[NCI + CF_GAMMA * n + j]
            ae = abs(ej)
            eps_e = p[NCI + CF_EPS_E * n + j]
            if ae >= eps_e:
                pw = pow_abs(ej, gamma) if vec else ae**gamma  # and |e|^(gamma-1) = pw / |e|
                s += beta * pw * _sign(ej)
                gain += beta * gamma * pw / ae
            else:
                s += beta * (pow_abs(ej, gamma) if vec else ae**gamma) * _sign(ej)
                gain += beta * gamma * eps_e ** (gamma - 1.0)
        return s, gain * edj
    beta = p[NCI + CF_BETA * n + j]
    gamma = p[NCI + CF_GAMMA * n + j]
    sg = _sign(edj)
    aed = abs(edj)
    pg = pow_abs(edj, gamma) if vec else aed**gamma
    pg2 = pow_abs(edj, 2.0 - gamma) if vec else aed ** (2.0 - gamma)
    return ej + pg * sg / beta, beta / gamma * pg2 * sg


@njit(cache=True, nogil=True, error_model="numpy")
def surface_into(
    p: np.ndarray,
    e: np.ndarray,
    ed: np.ndarray,
    s_out: np.ndarray,
    nu_out: np.ndarray,
) -> None:
    """Sliding variable ``s`` and the derivative term ``nu`` of the surface, per joint.

    Fast-terminal family (PDSMC, TSMC, FTSMC):

    .. math:: s = \\dot e + \\alpha e + \\beta\\,\\mathrm{sig}(e)^\\gamma,\\qquad
              \\nu = (\\alpha + \\beta\\gamma\\max(|e|, \\varepsilon_e)^{\\gamma-1})\\,\\dot e

    (the guard :math:`\\varepsilon_e` keeps the TSM term finite at ``e = 0``). Nonsingular
    (NTSMC, with :math:`1 < \\gamma = p/q < 2`):

    .. math:: s = e + \\beta^{-1}\\mathrm{sig}(\\dot e)^\\gamma,\\qquad
              \\nu = \\frac{\\beta}{\\gamma}\\,\\mathrm{sig}(\\dot e)^{2-\\gamma}
    """
    n = e.shape[0]
    for j in range(n):
        s_out[j], nu_out[j] = _surface_joint(p, j, n, e[j], ed[j])


@njit(cache=True, nogil=True, error_model="numpy")
def paper_entry(
    kernel: Any,
    t: float,
    lp: np.ndarray,
    state: np.ndarray,
    mkind: int,
    mparams: np.ndarray,
    g: float,
    q: np.ndarray,
    qd: np.ndarray,
    q_ref: np.ndarray,
    qd_ref: np.ndarray,
    qdd_ref: np.ndarray,
    tau_out: np.ndarray,
    s_out: np.ndarray,
    mats: np.ndarray,
    work: np.ndarray,
) -> None:
    """The paper's law (eqs. 19-22) into ``tau_out``, given ``nu`` and ``r`` in their
    ``work`` rows (see :func:`control_into`); ``mats`` is unused. The signature is the
    custom-law entry's (:data:`slidingarm.control._dispatch.ENTRY_SIGNATURE`), unused
    arguments included.

    :math:`f = -\\hat M^{-1}\\hat h` and the diagonal :math:`g_i = [\\hat M^{-1}]_{ii}` come
    from the nominal model's forward dynamics
    (:func:`slidingarm.models._dispatch.forward_dynamics`; the articulated-body algorithm for
    either kind): :math:`f` is the acceleration at ``(q, qd)`` under no torque, and
    :math:`\\hat M^{-1} e_i` the acceleration at rest, without gravity, under the unit
    torque :math:`e_i`, so that no mass matrix is formed or factorised. Then
    :math:`\\tau_i = (-f_i - \\nu_i)/g_i - r_i`. Where the mass matrix is not positive
    definite (a pivot of the forward dynamics that is not positive: for a planar arm with
    positive masses, a non-finite measurement; for a serial nominal model, also a singular
    one at a finite state, a massless body at the tip), every torque is NaN, which ends the
    run as non-finite. The block loop's :func:`slidingarm._block._paper_law` does the same
    operations in the same order.

    Reached through a function pointer: it serves only the errata, so it is compiled (and
    cached) when a controller with ``law="paper"`` is first made, not with the loop. Built on
    the forward dynamics that the loop's RK4 step compiles too (the planar ABA), its first
    compilation finds that in numba's cache: about 0.75 CPU-s, where forming and factorising
    :math:`\\hat M` took 1.6.
    """
    n = q.shape[0]
    nu = work[_ROW_NU]
    r = work[_ROW_R]
    zero = work[_ROW_ACC]
    unit = work[_ROW_RHS]
    col = work[_ROW_COL]
    f = work[_ROW_F]
    for j in range(n):
        zero[j] = 0.0
    ok = MD.forward_dynamics(mkind, mparams, g, q, qd, zero, f, work)
    for i in range(n):
        for j in range(n):
            unit[j] = 0.0
        unit[i] = 1.0
        ok &= MD.forward_dynamics(mkind, mparams, 0.0, q, zero, unit, col, work)
        tau_out[i] = (-f[i] - nu[i]) / col[i] - r[i]
    if not ok:
        for i in range(n):
            tau_out[i] = np.nan


@njit(cache=True, nogil=True, error_model="numpy", forceinline=True)
def sliding_mode_into(
    p: np.ndarray,
    mkind: int,
    mparams: np.ndarray,
    g: float,
    q: np.ndarray,
    qd: np.ndarray,
    q_ref: np.ndarray,
    qd_ref: np.ndarray,
    qdd_ref: np.ndarray,
    st_state: np.ndarray,
    dt: float,
    tau_out: np.ndarray,
    s_out: np.ndarray,
    work: np.ndarray,
) -> None:
    """The sliding-mode law's compiled body: ``s`` into ``s_out``, :math:`\\nu` and
    :math:`r` into their ``work`` rows, and with ``law = model`` the torque
    :math:`\\tau = \\hat M(q)(\\ddot q_d - \\nu - r) + \\hat h(q, \\dot q)` into
    ``tau_out`` (see :func:`control_into`, which adds the paper's law).

    Compiled once as a function of its own and inlined by LLVM (``forceinline``: the
    ``alwaysinline`` attribute) into the compiled function that calls it, rather than inlined in
    numba's IR (``inline="always"``): numba copies an IR-inlined body once per level of
    inlining, and with this body three levels deep into the loop that copying was about half
    of the loop's first compilation. LLVM's inlining keeps the loop as fast as before (a call
    per sample cost 8-13 % of the paper's run). The arrays are borrowed
    (:func:`slidingarm.models._kernels.borrow`), so that the body counts no references.
    """
    p = PK.borrow(p)
    mparams = PK.borrow(mparams)
    q = PK.borrow(q)
    qd = PK.borrow(qd)
    q_ref = PK.borrow(q_ref)
    qd_ref = PK.borrow(qd_ref)
    qdd_ref = PK.borrow(qdd_ref)
    st_state = PK.borrow(st_state)
    tau_out = PK.borrow(tau_out)
    s_out = PK.borrow(s_out)
    work = PK.borrow(work)
    n = q.shape[0]
    swcode = p[CI_SWITCHING]
    classic = p[CI_REACHING] == REACH_CLASSIC
    # a planar nominal model is what the block loop (slidingarm._block) runs: its powers and
    # tanh by the block's vectorisable functions, so that both loops compute the same bits;
    # the serial kind keeps libm's (quicker here; its block loop agrees to rounding anyway:
    # its dynamics are another algorithm, slidingarm._block)
    vec = mkind == MD.KIND_PLANAR
    nu = work[_ROW_NU]
    r = work[_ROW_R]
    acc = work[_ROW_ACC]
    # the surface of every joint, then the reaching term of every joint: two loops, each with
    # one kind of libm call (pow, then tanh), ran the FTSMC-with-tanh law about 0.1 µs (of
    # about 1 µs) quicker on the UR5 than one loop alternating the two, with the same results
    # (benchmarks/bench_serial.py)
    for j in range(n):
        s, nu_j = _surface_joint(p, j, n, q[j] - q_ref[j], qd[j] - qd_ref[j], vec)
        s_out[j] = s
        nu[j] = nu_j
    for j in range(n):
        s = s_out[j]
        # reaching term r
        if classic:
            r[j] = p[NCI + CF_K * n + j] * switch(swcode, s, p[NCI + CF_WIDTH * n + j], vec)
        else:
            r[j] = p[NCI + CF_K * n + j] * math.sqrt(abs(s)) * _sign(s) + st_state[j]
            st_state[j] += dt * p[NCI + CF_K2 * n + j] * switch(
                swcode, s, p[NCI + CF_WIDTH * n + j], vec
            )
        acc[j] = qdd_ref[j] - nu[j] - r[j]
    if p[CI_LAW] == LAW_MODEL:
        MD.inverse_dynamics(mkind, mparams, g, q, qd, acc, tau_out, work)


_V = types.float64[::1]
_M = types.float64[:, ::1]
#: Signature of :func:`sliding_mode_into` as the linked per-run loop calls it: ``(p, mkind,
#: mparams, mg, q, qd, q_ref, qd_ref, qdd_ref, st_state, dt, tau, s, work)``.
LAW_SIGNATURE = types.void(
    _V, types.int64, _M, types.float64, _V, _V, _V, _V, _V, _V, types.float64, _V, _V, _M
)
#: ``law_at(address)``: :func:`sliding_mode_into` at its address.
law_at = function_at(types.FunctionType(LAW_SIGNATURE))


def call_law(
    link: np.ndarray,
    address: int,
    p: np.ndarray,
    mkind: int,
    mparams: np.ndarray,
    g: float,
    q: np.ndarray,
    qd: np.ndarray,
    q_ref: np.ndarray,
    qd_ref: np.ndarray,
    qdd_ref: np.ndarray,
    st_state: np.ndarray,
    dt: float,
    tau_out: np.ndarray,
    s_out: np.ndarray,
    work: np.ndarray,
) -> None:  # pragma: no cover - typed by its overload
    """:func:`sliding_mode_into`, called directly or, with ``link``
    :data:`~slidingarm._pointers.LINKED`, at ``address``."""
    raise NotImplementedError


@overload(
    call_law,
    jit_options={"nogil": True, "error_model": "numpy", "forceinline": True},
    inline=inline_unless_linked,
)
def _call_law_typed(link, address, p, mkind, mparams, g, q, qd, q_ref, qd_ref, qdd_ref, st_state, dt, tau_out, s_out, work):  # type: ignore[no-untyped-def]
    if linked(link):

        def at(link, address, p, mkind, mparams, g, q, qd, q_ref, qd_ref, qdd_ref, st_state, dt, tau_out, s_out, work):  # type: ignore[no-untyped-def]
            law_at(address)(
                _w(p), mkind, _w(mparams), g, _w(q), _w(qd), _w(q_ref), _w(qd_ref),
                _w(qdd_ref), _w(st_state), dt, _w(tau_out), _w(s_out), _w(work),
            )  # fmt: skip

        return at

    def direct(link, address, p, mkind, mparams, g, q, qd, q_ref, qd_ref, qdd_ref, st_state, dt, tau_out, s_out, work):  # type: ignore[no-untyped-def]
        sliding_mode_into(
            p, mkind, mparams, g, q, qd, q_ref, qd_ref, qdd_ref, st_state, dt, tau_out, s_out,
            work,
        )  # fmt: skip

    return direct


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def control_into(
    entry: Any,
    kernel: Any,
    link: np.ndarray,
    law_address: int,
    p: np.ndarray,
    mkind: int,
    mparams: np.ndarray,
    g: float,
    q: np.ndarray,
    qd: np.ndarray,
    q_ref: np.ndarray,
    qd_ref: np.ndarray,
    qdd_ref: np.ndarray,
    st_state: np.ndarray,
    dt: float,
    tau_out: np.ndarray,
    s_out: np.ndarray,
    mats: np.ndarray,
    work: np.ndarray,
) -> None:
    """Compute the control torque ``tau_out`` and sliding variable ``s_out`` (both (n,)).

    ``q, qd`` are what the controller measures; ``st_state`` (n,) is the super-twisting
    integral :math:`w`, advanced by ``dt`` after use (ignored by the classic reaching law).
    ``mats`` is (2 n, n) scratch, ``work`` is ``(CONTROL_WORK_ROWS, n)``; on
    return it holds the nominal model kind's kinematics of ``q``
    (:mod:`slidingarm.models._dispatch`).

    ``law = model`` (docs/theory.md §3): :math:`\\tau = \\hat M(q)(\\ddot q_d - \\nu - r) + \\hat h(q,\\dot q)`,
    computed as the inverse dynamics (RNEA, O(n)) of the nominal arm at the acceleration
    :math:`\\ddot q_d - \\nu - r`.

    ``law = paper`` (the paper's eqs. 19-22, kept to measure its cost): with
    :math:`f = -\\hat M^{-1}\\hat h` and :math:`g_i = [\\hat M^{-1}]_{ii}`,
    :math:`\\tau_i = (-f_i - \\nu_i)/g_i - r_i` (no :math:`\\ddot q_d`, a row of
    :math:`M^{-1}` used as a scalar).

    The surface, the reaching law and the model law are :func:`sliding_mode_into`: compiled
    once and inlined by LLVM, or with ``link`` :data:`~slidingarm._pointers.LINKED` called at
    ``law_address`` (:func:`slidingarm.control._dispatch.law_pointer`; :func:`call_law`).
    This function is inlined in numba's IR where it is called (and so are :func:`call_law`'s
    direct call and the call of the paper's ``entry``): ``entry`` may be a compiled function
    given statically (:func:`slidingarm.control._dispatch.control_once`), which a compiled
    function cannot take as an argument without losing numba's cache.
    """
    call_law(
        link, law_address, p, mkind, mparams, g, q, qd, q_ref, qd_ref, qdd_ref, st_state, dt,
        tau_out, s_out, work,
    )  # fmt: skip
    if p[CI_LAW] != LAW_MODEL:
        # the paper's law, through its pointer (:func:`paper_entry`)
        entry(kernel, 0.0, p, st_state, mkind, mparams, g, q, qd, q_ref, qd_ref, qdd_ref,
              tau_out, s_out, mats, work)  # fmt: skip
