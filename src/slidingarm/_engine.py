"""The closed loop, written once over a plant handle and a law handle (docs/theory.md §5).

Per sample ``k`` (time ``t_k = k dt``) of a run:

1. measurement: ``q̃_k = q_k + add_k``, except where ``hold_k`` is set, where the previous
   measurement is repeated (stuck sensor, dropout);
2. velocity estimate from the true velocity, a backward difference, a dirty derivative or
   Levant's robust exact differentiator;
3. the law computes ``τ_k`` and ``s_k`` (:func:`slidingarm.control._dispatch.law_into`);
   actuator limits clip ``τ_k``; the plant's input ``τ_k + d_k`` is held over the interval;
4. the plant is advanced over ``[t_k, t_k+1)``: ``substeps`` RK4 steps of a compiled model
   (:func:`slidingarm.models._dispatch.rk4_step`), or a Python-stepped plant's ``step``;
5. status: a non-finite torque, state or sliding variable, a mass matrix that is no longer
   positive definite, or a joint speed beyond ``qd_limit`` ends the run, recording
   ``[code, sample, joint]``.

Steps 1-3 and 5 are the *step pieces* :func:`control_sample` and :func:`check_state`: the
compiled per-run loop :func:`run_one` inlines them, and :func:`control_step` /
:func:`state_status` expose the very same code to the Python-stepped loop
(:func:`slidingarm.simulate` with a :class:`~slidingarm.plants.SteppedPlant`), so both loops
have one semantics. The time loop allocates nothing and does no reference counting: every
array it touches is a :func:`_borrow` alias. Workspace rows: :data:`WORKSPACE_ROWS`.

What numba inlines in its IR and what LLVM inlines: the step pieces and the dispatch on the
law's and the plant's kind are inlined in numba's IR (small bodies); the sliding-mode law
(:func:`slidingarm.control._kernels.sliding_mode_into`) and the planar RK4 step
(:func:`slidingarm.models._kernels.rk4_step`) are compiled once each and inlined by LLVM
(``forceinline``). Numba copies an IR-inlined body once per level of inlining, and those two
bodies inlined two and three levels deep made that copying about half of the loop's first
compilation (13-14 CPU-s then, 8-9 since); the loop's code is the same as before, one function
(their arrays are borrowed too, so their bodies count no references either).

Two specialisations of :func:`run_one`, by the type of its last argument
(:data:`slidingarm._pointers.INLINED` or ``LINKED``): the inlined loop above, and the linked
loop, which calls the built-in law and the plant's RK4 step through their addresses
(:func:`slidingarm.control._dispatch.law_pointer`,
:func:`slidingarm.models._dispatch.step_address`). The linked loop needs neither compiled to
compile (about 2.4 CPU-s cold, against 2.7 for the inlined one after its parts), so
``slidingarm reproduce`` compiles it while its workers compile the parts (:func:`linked_loop`,
:func:`compile_loop`); its runs are bit for bit the inlined loop's, about 100 ns a sample
slower (the paper's run: 5.6 against 4.7 ms), which ``simulate`` keeps by default.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import numpy as np
from numba import njit, typeof, types

from slidingarm._gc import paused
from slidingarm._pointers import INLINED, LINKED
from slidingarm.control import _dispatch as LD
from slidingarm.control import _kernels as CK
from slidingarm.models import _dispatch as MD
from slidingarm.models import _kernels as PK

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


#: An alias of an array that takes no part in reference counting
#: (:func:`slidingarm.models._kernels.borrow`). Numba reference-counts array variables, and in
#: the inlined kernels of the time loop every function argument and row view is one; its LLVM
#: pass removes only some of those atomic increments and decrements, which then took a fifth
#: of the loop's time. Every borrowed array here is (a view of) an argument of
#: :func:`run_one`, which its caller holds.
_borrow = PK.borrow


# rows of the per-run workspace (n columns): state and measurement vectors, the held input,
# the RK4 scratch, the control work rows, and the law's (2 n, n) scratch ``mats`` (a custom
# law is handed the mass matrix in its first n rows)
_Q = 0
_QD = 1
_QM = 2
_QDM = 3
_QM_PREV = 4
_Z0 = 5
_TAU_APPLIED = 6
_RK4 = 7
_WORK = _RK4 + MD.RK4_ROWS
_MATRICES = _WORK + CK.CONTROL_WORK_ROWS


#: Whether the plant's first RK4 stage reuses the kinematics the law left in the workspace when
#: the measurement was the exact position and plant and nominal model are of one kind with the
#: same geometry (the planar kind: its sines and cosines; the serial kind: each body's
#: placement). ``benchmarks/bench_engine.py`` measures its worth by
#: compiling the loop with it off.
REUSE_KINEMATICS = True


def workspace_rows(n: int) -> int:
    """Rows of the ``(rows, n)`` workspace of one run."""
    return _MATRICES + 2 * n


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def control_sample(
    k: int,
    t_k: float,
    dt: float,
    law_code: int,
    entry: Any,
    kernel: Any,
    link: np.ndarray,
    law_address: int,
    lp: np.ndarray,
    lstate: np.ndarray,
    mkind: int,
    mp: np.ndarray,
    mg: float,
    madd: np.ndarray,
    mhold: np.ndarray,
    vcode: int,
    vfb: np.ndarray,
    q_ref: np.ndarray,
    qd_ref: np.ndarray,
    qdd_ref: np.ndarray,
    tmax: np.ndarray,
    db: np.ndarray,
    ws: np.ndarray,
    q_b: np.ndarray,
    qd_b: np.ndarray,
    qm_b: np.ndarray,
    qdm_b: np.ndarray,
    tau_b: np.ndarray,
    s_b: np.ndarray,
) -> tuple[int, bool]:
    """Steps 1-3 of sample ``k``: measure, estimate the velocity, run the law, clip, hold.

    Reads the plant state from ``ws`` rows ``_Q``, ``_QD``; leaves the held input
    ``τ_k + d_k`` in row ``_TAU_APPLIED``; records sample ``k`` of every output. Returns the
    first joint whose torque or ``s`` is not finite (-1 if none) and whether the measurement
    was the exact position (then ``ws``'s work rows hold the kinematics of the plant's ``q``).
    """
    n = ws.shape[1]
    q = ws[_Q]
    qd = ws[_QD]
    qm = ws[_QM]
    qdm = ws[_QDM]
    qm_prev = ws[_QM_PREV]
    z0 = ws[_Z0]
    tau_applied = ws[_TAU_APPLIED]
    work = ws[_WORK:_MATRICES]
    mats = ws[_MATRICES : _MATRICES + 2 * n]
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
    exact = True
    for j in range(n):
        qm_prev[j] = qm[j]
        exact &= qm[j] == q[j]
    # --- control
    LD.law_into(
        law_code, entry, kernel, link, law_address, t_k, lp, lstate, mkind, mp, mg, qm, qdm, q_ref[k], qd_ref[k],
        qdd_ref[k], dt, tau_b[k], s_b[k], mats, work,
    )  # fmt: skip
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
    return bad, exact


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def check_state(q: np.ndarray, qd: np.ndarray, ok: bool, qd_limit: float) -> tuple[int, int]:
    """Step 5 after the plant moved: ``(code, joint)`` of the first failure, ``(0, -1)`` if none.

    An overflow inside a step also fails the pivot test, so finiteness is checked first: a
    non-finite state is reported as such, with its joint, never as a singular ``M``.
    """
    n = q.shape[0]
    for j in range(n):
        if not (math.isfinite(q[j]) and math.isfinite(qd[j])):
            return STATUS_NONFINITE, j
    if not ok:
        return STATUS_SINGULAR, 0
    for j in range(n):
        if abs(qd[j]) > qd_limit:
            return STATUS_RUNAWAY, j
    return STATUS_OK, -1


@njit(cache=True, nogil=True, error_model="numpy")
def run_one(
    pkind: int,
    pp: np.ndarray,
    pg: float,
    step_address: int,
    law_code: int,
    entry_address: int,
    kernel_address: int,
    law_address: int,
    lp: np.ndarray,
    lstate: np.ndarray,
    mkind: int,
    mp: np.ndarray,
    mg: float,
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
    q_b: np.ndarray,
    qd_b: np.ndarray,
    qm_b: np.ndarray,
    qdm_b: np.ndarray,
    tau_b: np.ndarray,
    s_b: np.ndarray,
    status: np.ndarray,
    workspace: np.ndarray,
    link: np.ndarray,
) -> None:
    """One closed-loop run of a compiled plant ``(pkind, pp, pg)``, whose RK4 step is at
    ``step_address`` (:func:`slidingarm.models._dispatch.step_address`), under the law
    ``(law_code, entry, kernel, lp, lstate)`` (the two functions given by their addresses)
    with nominal model ``(mkind, mp, mg)``, the built-in laws' surface and reaching law at
    ``law_address`` (:func:`slidingarm.control._dispatch.law_pointer`); see the module
    docstring.

    Shapes: ``q0, qd0, tmax`` (n,); ``tgrid`` (T,); ``q_ref, qd_ref, qdd_ref, madd, mhold,
    dist`` and the outputs (T, n); ``vfb`` (NVF, n); ``status`` (3,) receives ``[code,
    sample, joint]`` of the first failure (code 0: none; the outputs after it are not
    written); ``workspace`` is ``(workspace_rows(n), n)``.
    """
    entry = LD.entry_at(entry_address)
    kernel = LD.kernel_at(kernel_address)
    nt = q_b.shape[0]
    n = q_b.shape[1]
    h = dt / substeps
    ws = _borrow(workspace)
    q = ws[_Q]
    qd = ws[_QD]
    rk = ws[_RK4:_WORK]
    work = ws[_WORK:_MATRICES]
    tau_applied = ws[_TAU_APPLIED]
    pp = _borrow(pp)
    lp = _borrow(lp)
    lstate = _borrow(lstate)
    mp = _borrow(mp)
    madd = _borrow(madd)
    mhold = _borrow(mhold)
    vfb = _borrow(vfb)
    dist = _borrow(dist)
    tmax = _borrow(tmax)
    q_ref = _borrow(q_ref)
    qd_ref = _borrow(qd_ref)
    qdd_ref = _borrow(qdd_ref)
    q_b = _borrow(q_b)
    qd_b = _borrow(qd_b)
    qm_b = _borrow(qm_b)
    qdm_b = _borrow(qdm_b)
    tau_b = _borrow(tau_b)
    s_b = _borrow(s_b)
    for j in range(n):
        q[j] = q0[j]
        qd[j] = qd0[j]
    for j in range(lstate.shape[0]):
        lstate[j] = 0.0
    status[0] = STATUS_OK
    status[1] = -1
    status[2] = -1
    reuse = REUSE_KINEMATICS and pkind == mkind and MD.same_kinematics(pkind, pp, mp)
    for k in range(nt):
        bad, exact = control_sample(
            k, tgrid[k], dt, law_code, entry, kernel, link, law_address, lp, lstate, mkind, mp, mg, madd, mhold, vcode,
            vfb, q_ref, qd_ref, qdd_ref, tmax, dist, ws, q_b, qd_b, qm_b, qdm_b, tau_b, s_b,
        )  # fmt: skip
        if bad >= 0:
            status[0] = STATUS_NONFINITE
            status[1] = k
            status[2] = bad
            return
        if k == nt - 1:
            return
        # --- plant over [t_k, t_k+1); the law left the kinematics of the measured q in work
        ok = True
        for sub in range(substeps):
            known = exact and reuse and sub == 0
            ok &= MD.plant_step(
                link, pkind, step_address, pp, pg, q, qd, tau_applied, h, known, rk, work
            )
        code, j = check_state(q, qd, ok, qd_limit)
        if code != STATUS_OK:
            status[0] = code
            status[1] = k + 1
            status[2] = j
            return


@njit(cache=True, nogil=True, error_model="numpy")
def control_step(
    k: int,
    t_k: float,
    dt: float,
    law_code: int,
    entry_address: int,
    kernel_address: int,
    lp: np.ndarray,
    lstate: np.ndarray,
    mkind: int,
    mp: np.ndarray,
    mg: float,
    madd: np.ndarray,
    mhold: np.ndarray,
    vcode: int,
    vfb: np.ndarray,
    q_ref: np.ndarray,
    qd_ref: np.ndarray,
    qdd_ref: np.ndarray,
    tmax: np.ndarray,
    db: np.ndarray,
    ws: np.ndarray,
    q_b: np.ndarray,
    qd_b: np.ndarray,
    qm_b: np.ndarray,
    qdm_b: np.ndarray,
    tau_b: np.ndarray,
    s_b: np.ndarray,
) -> int:
    """:func:`control_sample` for the Python-stepped loop; returns its bad joint (-1: none)."""
    bad, _exact = control_sample(
        k, t_k, dt, law_code, LD.entry_at(entry_address), LD.kernel_at(kernel_address), INLINED, 0, lp, lstate, mkind, mp, mg, madd, mhold, vcode, vfb,
        q_ref, qd_ref, qdd_ref, tmax, db, ws, q_b, qd_b, qm_b, qdm_b, tau_b, s_b,
    )  # fmt: skip
    return bad


@njit(cache=True, nogil=True, error_model="numpy")
def state_status(q: np.ndarray, qd: np.ndarray, ok: bool, qd_limit: float) -> tuple[int, int]:
    """:func:`check_state` for the Python-stepped loop."""
    return check_state(q, qd, ok, qd_limit)


@njit(cache=True, nogil=True, error_model="numpy")
def model_rk4_step(
    kind: int,
    params: np.ndarray,
    g: float,
    q: np.ndarray,
    qd: np.ndarray,
    tau: np.ndarray,
    h: float,
    scratch: np.ndarray,
    work: np.ndarray,
) -> bool:
    """One RK4 step of a compiled model from Python (the loop's own plant step)."""
    return MD.rk4_step(kind, params, g, q, qd, tau, h, False, scratch, work)


Q_ROW = _Q
QD_ROW = _QD
TAU_APPLIED_ROW = _TAU_APPLIED


# the loop's separately compiled parts
_V = types.float64[::1]
_M = types.float64[:, ::1]

#: The functions :func:`run_one` calls that numba compiles as functions of their own, with the
#: signature they are called with, in the order to compile them: the model's ``sincos`` (a
#: call, from the law's model, the RK4 step and the paper's law), the law's ``|x|^g`` and
#: ``tanh`` (calls), the planar RK4 step and the law (both inlined by LLVM, ``forceinline``).
#: They are most of the loop's first compilation, and they compile into numba's cache in any
#: process: :func:`compile_part` in other processes, and then a process compiling the inlined
#: loop loads them from the cache, so that its own first compilation is about 3 CPU-s; the
#: linked loop does not need them to compile (its runs load the law and the step by address).
#: :func:`slidingarm.study.reproduce` has its two figure workers take them in this order as
#: each comes free: one starts on ``sincos``, the other on ``|x|^g``; the first free takes
#: ``tanh``, the other the RK4 step (``sincos`` is cached by then), and the one with ``tanh``
#: the law, whose compilation then finds its three callees in the cache (or compiles one itself
#: if another worker is late). Split so, each worker compiles about 2 CPU-s instead of the
#: law's 2.8 with its callees (measured cold, one at a time). Tests check that the law's
#: compilation finds the callees cached, and the inlined loop's the law and the step.
LOOP_PARTS: tuple[tuple[Any, Any], ...] = (
    (PK.sincos, types.UniTuple(types.float64, 2)(types.float64)),
    (CK.pow_abs, types.float64(types.float64, types.float64)),
    (CK.tanh, types.float64(types.float64)),
    # the signatures the linked loop's pointers take (slidingarm.control._dispatch.law_pointer,
    # slidingarm.models._dispatch.step_address): the same cache entries
    (PK.rk4_step, MD.SERIAL_SIGNATURES[MD.FN_RK4][1]),
    (CK.sliding_mode_into, CK.LAW_SIGNATURE),
)  # fmt: skip


def compile_part(index: int) -> None:
    """Compile part ``index`` of :data:`LOOP_PARTS` for its signature (into numba's cache;
    nothing to do if it is cached already)."""
    dispatcher, sig = LOOP_PARTS[index]
    # by its argument types alone: numba's cache keys an entry by what ``compile`` was given,
    # and the loop's typing asks for the argument types
    with paused():  # no automatic garbage collection while compiling (slidingarm._gc)
        dispatcher.compile(sig.args)


_I = types.int64
_F = types.float64
#: The argument types of the linked :func:`run_one` as ``simulate`` calls it (every array
#: C-contiguous and writable): :func:`compile_loop` compiles exactly what the first run would.
LOOP_ARGS = (
    _I, _M, _F, _I, _I, _I, _I, _I, _V, _V, _I, _M, _F, _V, _V, _V, _M, _M, _M, _M,
    types.boolean[:, ::1], _I, _M, _M, _V, _F, _I, _F, _M, _M, _M, _M, _M, _M,
    types.int64[::1], _M, types.int8[::1],
)  # fmt: skip


#: How many :func:`linked_loop` blocks are open in this process (any thread), under its lock.
_LINKED_DEPTH = [0]
_LINKED_LOCK = threading.Lock()


@contextmanager
def linked_loop() -> Iterator[None]:
    """Within the block, the runs of :func:`slidingarm.simulate` and
    :func:`slidingarm.simulate_batch` on the per-run loop take :func:`run_one` with
    :data:`~slidingarm._pointers.LINKED`, the specialisation that reaches the built-in law and
    the planar step through their addresses: the same results bit for bit, about 100 ns more
    per sample, compiled without them (:func:`compile_loop`). :func:`slidingarm.study.reproduce`
    uses it so that its loop compiles while its workers compile the parts. The switch is the
    process's: runs of other threads meanwhile take it too, until every open block has ended
    (a count, so that blocks of several threads may overlap)."""
    with _LINKED_LOCK:
        _LINKED_DEPTH[0] += 1
    try:
        yield
    finally:
        with _LINKED_LOCK:
            _LINKED_DEPTH[0] -= 1


def linked_runs() -> bool:
    """Whether this process's per-run runs take the linked loop now (:func:`linked_loop`)."""
    return _LINKED_DEPTH[0] > 0


def loop_link(pkind: int, pparams: np.ndarray, law_code: int) -> tuple[np.ndarray, int, int]:
    """``(link, step_address, law_address)`` of the next per-run run of a plant of kind
    ``pkind`` under a law of code ``law_code`` (:func:`linked_loop`): for the inlined loop,
    :data:`~slidingarm._pointers.INLINED` and two unused zeros; the law's address is that of
    the built-in laws' :func:`~slidingarm.control._kernels.sliding_mode_into`, 0 for a custom
    law, which never calls it (and so never compiles it)."""
    if not linked_runs():
        return INLINED, 0, 0
    law = LD.law_pointer().address if law_code == LD.LAW_SLIDING_MODE else 0
    return LINKED, MD.step_address(pkind, pparams), law


def compile_loop() -> None:
    """Compile the linked :func:`run_one` (or load it from numba's cache) for
    :data:`LOOP_ARGS`, what the first run in :func:`linked_loop` would: it reaches the law and
    the plant's step through their addresses, so this needs none of :data:`LOOP_PARTS`, and a
    process can compile it while others compile the parts."""
    with paused():
        run_one.compile(LOOP_ARGS)


@njit(nogil=True)
def _first(x: float) -> float:  # pragma: no cover - compiled
    """A function to compile (not cached): :func:`prime`'s."""
    return x + 1.0


def prime() -> None:
    """Do in this process what each process compiling :data:`LOOP_PARTS`, the paper's law or
    the loop would do first: numba's own set-up of its first compilation in a process (about
    0.5 CPU-s, the compilation of a one-line function). Worker processes forked after this
    inherit it instead of each repeating it (:func:`slidingarm.study.reproduce`). The model's
    ``sincos``, which the law, the RK4 step and the paper's law call, is the first of the parts:
    compiled here too it cost the study's start, on one core, 0.35 CPU-s more."""
    with paused():
        _first.compile((types.float64,))


def _cached(dispatcher: Any, last: Any = None) -> bool:
    """Whether numba's cache holds ``dispatcher`` compiled from its current source for this
    CPU (the index's key: signature, the codegen's CPU name and features, ...), for a signature
    whose last argument type is ``last`` (any with ``None``). Reads numba's cache index (not a
    public API: if it cannot be read, ``False``)."""
    try:
        index = dispatcher._cache._cache_file._load_index()
        cpu = dispatcher.targetctx.codegen().magic_tuple()
        return any(
            key[1] == cpu and (last is None or key[0][-1] == last) for key in index
        )
    except Exception:  # numba's internals moved: assume a cold cache
        return False


def loop_cached(link: np.ndarray | None = None) -> bool:
    """Whether numba's cache holds :func:`run_one` compiled from this source for this CPU: the
    specialisation of ``link`` (:data:`~slidingarm._pointers.INLINED` or ``LINKED``), or any
    with ``None``. The inlined loop then loads from the cache with what it inlined, and a
    process need not wait for :func:`compile_part` elsewhere; the linked loop's runs still
    load the law and the step by address (:func:`parts_cached`)."""
    return _cached(run_one, None if link is None else typeof(link))


def parts_cached() -> bool:
    """Whether numba's cache holds every one of :data:`LOOP_PARTS` compiled from its source
    for this CPU."""
    return all(_cached(dispatcher) for dispatcher, _ in LOOP_PARTS)
