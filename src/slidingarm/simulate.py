"""Fixed-step digital closed-loop simulation, single and batch (docs/theory.md §5).

The controller runs at :math:`t_k = k\\,\\Delta t` on the measurement; its torque is held over
:math:`[t_k, t_{k+1})` (zero-order hold) while the plant is integrated by RK4 (``substeps``
equal steps per interval). A run is deterministic for a given seed. The loop is
:mod:`slidingarm._engine`, written once over the plant's and the law's handles; this module
validates, prepares the per-run inputs, runs the batch in chunks of runs over threads, and
wraps the output in typed results.

Randomness: run ``b`` has the seed ``seeds[b]`` and the root
``numpy.random.SeedSequence(seeds[b])``. The sensor draws from the root's own stream (so a
recorded seed reproduces the runs of earlier versions); torque disturbance ``i`` draws from
the child ``SeedSequence(seeds[b], spawn_key=(i,))``. Adding a random disturbance therefore
changes no other component's numbers.
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor
from contextlib import nullcontext
from dataclasses import dataclass
from queue import SimpleQueue
from typing import Any, Literal

import numpy as np
from numba import config
from numpy.typing import ArrayLike, NDArray

from slidingarm import _engine as E
from slidingarm._gc import paused
from slidingarm._validate import MAX_POSITION, ParameterTypeError, _float, number_array
from slidingarm._version import __version__
from slidingarm.control.base import Controller
from slidingarm.disturbances import (
    ConstantTorque,
    Disturbance,
    RandomTorque,
    SinusoidalTorque,
    disturbance_torque,
)
from slidingarm.metrics import DEFAULT_CUTOFF_HZ
from slidingarm.models.base import ArmModel
from slidingarm.models.stepped import SteppedPlant
from slidingarm.references import Reference
from slidingarm.results import BatchResult, SimResult, metric_values, run_message
from slidingarm.sensors import Sensor

__all__ = [
    "DEFAULT_QD_LIMIT",
    "MIN_DT",
    "Every",
    "RunTooLargeError",
    "SimulationError",
    "available_memory",
    "byte_size",
    "memory_estimate",
    "simulate",
    "simulate_batch",
    "time_grid",
]

FloatArray = NDArray[np.float64]

#: A run whose joint speed exceeds this (rad/s) is declared diverged.
DEFAULT_QD_LIMIT = 1e4

#: More RK4 steps per sample than this is refused (a run would take days).
MAX_SUBSTEPS = 1_000_000

#: Runs per chunk: the unit of work of a thread, and of the bounded working set of
#: ``record="metrics"`` (a chunk's full traces live only while its metrics are computed).
CHUNK_RUNS = 16

#: A batch whose estimated memory (:func:`memory_estimate`) exceeds this share of the memory
#: available (:func:`available_memory`) is refused before anything is allocated.
MEMORY_SHARE = 0.8

#: The shortest sample time (s) accepted: a 1 GHz control loop. Real digital controllers sample
#: at 100 kHz at most, and a finite difference over a shorter step of an angle known to 1e-16
#: carries less than nine digits; below it the grid's arithmetic stops meaning time
#: (``dt = 5e-324`` is the smallest float).
MIN_DT = 1e-9

#: The most samples a time grid may have: ``2**53``, beyond which ``k dt`` and ``k`` no longer
#: map one to one in float64 (long before that the memory check refuses the run).
MAX_SAMPLES = 2**53


class RunTooLargeError(MemoryError, ValueError):
    """A run or batch whose estimated memory exceeds what this machine has available,
    refused before anything is allocated. A :class:`MemoryError`, and a :class:`ValueError`
    since the request (its duration, sample time or number of runs) is what is wrong.

    Attributes
    ----------
    estimate : int
        Bytes the run would need (:func:`memory_estimate`).
    available : int
        Bytes available when it was refused (:func:`available_memory`).
    """

    def __init__(self, message: str, *, estimate: int, available: int) -> None:
        super().__init__(message)
        self.estimate = estimate
        self.available = available


class SimulationError(RuntimeError):
    """A run diverged. ``time`` (s), ``joint`` (1-based) and ``run`` say where."""

    def __init__(self, message: str, *, time: float, joint: int, run: int) -> None:
        super().__init__(message)
        self.time = time
        self.joint = joint
        self.run = run


@dataclass(frozen=True)
class Every:
    """Record policy: keep every ``k``-th sample (``t_0, t_k, t_2k, …``) of every signal.

    The metrics of such a batch are still those of the full traces.
    """

    k: int

    def __post_init__(self) -> None:
        if isinstance(self.k, bool) or not isinstance(self.k, int | np.integer):
            raise ParameterTypeError(f"Every(k): k must be an integer >= 1, got {self.k!r}")
        if self.k < 1:
            raise ValueError(f"Every(k): k must be an integer >= 1, got {self.k!r}")


Record = Literal["full", "metrics"] | Every


def _grid_steps(t_final: float, dt: float) -> tuple[int, float]:
    """``(N, dt)`` of the grid :func:`time_grid` would build, validated, without building it."""
    for name, v in (("t_final", t_final), ("dt", dt)):
        if isinstance(v, str | bytes | bool | np.bool_) or not isinstance(
            v, int | float | np.integer | np.floating
        ):
            raise ParameterTypeError(f"{name} must be a number (s), got {type(v).__name__} {v!r}")
    tf = _float(t_final)
    h = _float(dt)
    if not (math.isfinite(h) and h > 0):
        raise ValueError(f"dt must be a finite sample time > 0 s, got {dt!r}")
    if h < MIN_DT:
        raise ValueError(
            f"dt must be at least {MIN_DT:g} s (a 1 GHz control loop), got {dt!r}"
        )
    if not (math.isfinite(tf) and tf > 0):
        raise ValueError(f"t_final must be a finite duration > 0 s, got {t_final!r}")
    ratio = tf / h
    if not ratio <= MAX_SAMPLES:
        many = f"{ratio:.3g} samples" if math.isfinite(ratio) else "beyond the float range"
        raise ValueError(
            f"t_final / dt = {tf:g} s / {h:g} s is {many}, more than a time grid can hold "
            f"({MAX_SAMPLES:.3g} samples); shorten t_final or lengthen dt"
        )
    steps = round(ratio)
    if steps < 1 or abs(steps * h - tf) > 1e-9 * max(1.0, tf):
        raise ValueError(f"t_final ({tf:g} s) must be a whole number of steps dt ({h:g} s)")
    return steps, h


def time_grid(t_final: float, dt: float) -> FloatArray:
    """Sample times :math:`t_k = k\\,\\Delta t`, ``k = 0..N`` with :math:`N = t_f/\\Delta t`.

    The paper's run (4.5 s at 5e-4 s) has 9000 control intervals, hence 9001 samples including
    both ends. ``t_final`` must be a whole number of steps, ``dt >= MIN_DT`` (1e-9 s) and
    :math:`N \\le 2^{53}`.
    """
    steps, h = _grid_steps(t_final, dt)
    return np.arange(steps + 1, dtype=np.float64) * h


def _numbers(name: str, value: Any) -> FloatArray:
    """``value`` as a float64 array; ``ParameterTypeError`` for anything but numbers (an
    integer beyond the float range becomes ±inf, which the callers refuse as not finite)."""
    try:
        if value is None or isinstance(value, set | frozenset | dict):
            raise ParameterTypeError(name)
        return number_array(name, value)
    except ParameterTypeError:
        # the message only now: a repr of every array on every call cost 0.1 ms
        kind = type(value).__name__
        raise ParameterTypeError(f"{name} must be numbers, got {kind} {value!r}") from None


def _vectors(name: str, value: ArrayLike, n: int, bound: float = math.inf) -> FloatArray:
    arr = _numbers(name, value)
    if arr.ndim == 1:
        arr = arr[None, :]
    if arr.ndim != 2 or arr.shape[1] != n:
        raise ValueError(f"{name} must have shape ({n},) or (B, {n}), got {np.shape(value)}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite")
    if np.any(np.abs(arr) > bound):
        worst = float(arr.flat[int(np.argmax(np.abs(arr)))])
        raise ValueError(
            f"{name} must lie within ±{bound:g} (rad, or m for a prismatic joint), got {worst:g}"
        )
    return np.ascontiguousarray(arr)


def _listify(name: str, value: Any, cls: type | tuple[type, ...], what: str) -> list[Any]:
    items = list(value) if isinstance(value, Sequence) and not isinstance(value, str) else [value]
    for item in items:
        if not isinstance(item, cls):
            raise ParameterTypeError(f"{name} must be {what} (or a sequence of them), got {type(item).__name__}")
    if not items:
        raise ValueError(f"{name} must not be empty")
    return items


_DISTURBANCES = (ConstantTorque, SinusoidalTorque, RandomTorque)


def _disturbance_lists(disturbances: Any) -> list[tuple[Disturbance, ...]]:
    """One tuple of disturbances shared by all runs, or one tuple per run."""

    def check(d: Any) -> Disturbance:
        if not isinstance(d, _DISTURBANCES):
            raise ParameterTypeError(
                "disturbances must be torque disturbances (ConstantTorque, SinusoidalTorque, "
                f"RandomTorque), got {type(d).__name__}; a model mismatch belongs in the plant: "
                "ModelMismatch(...).apply(arm)"
            )
        return d

    if isinstance(disturbances, _DISTURBANCES):
        return [(disturbances,)]
    if isinstance(disturbances, str) or not isinstance(disturbances, Sequence):
        check(disturbances)
    items = list(disturbances)
    if items and all(isinstance(d, Sequence) and not isinstance(d, str) for d in items):
        return [tuple(check(d) for d in run) for run in items]
    return [tuple(check(d) for d in items)]


def _torque_limits(torque_limit: Any, n: int) -> list[FloatArray | None]:
    """Per-run limits (n,) or None: one value for all, or one per run ((B, n) or a list)."""

    def one(v: Any) -> FloatArray | None:
        if v is None:
            return None
        tl = _numbers("torque_limit", v)
        if tl.ndim > 1 or (tl.ndim == 1 and tl.shape[0] != n) or np.any(~(tl > 0)):
            raise ValueError(
                f"torque_limit must be > 0 N m, a scalar or one per joint ({n}), got {v!r}"
            )
        return np.ascontiguousarray(np.broadcast_to(tl, (n,)), dtype=np.float64).copy()

    if torque_limit is None:
        return [None]
    if isinstance(torque_limit, list | tuple) and any(
        v is None or isinstance(v, list | tuple | np.ndarray) for v in torque_limit
    ):
        return [one(v) for v in torque_limit]
    arr = torque_limit if isinstance(torque_limit, np.ndarray) else None
    if arr is not None and arr.ndim == 2:
        return [one(row) for row in arr]
    return [one(torque_limit)]


def _seed_list(seeds: Any) -> list[int]:
    if isinstance(seeds, bool | np.bool_) or isinstance(seeds, str | bytes | set | frozenset):
        raise ParameterTypeError(f"seeds must be an integer or a sequence of integers, got {seeds!r}")
    raw = [seeds] if isinstance(seeds, int | np.integer) else list(seeds)
    out = []
    for s in raw:
        if isinstance(s, bool | np.bool_) or not isinstance(s, int | np.integer):
            raise ParameterTypeError(f"seeds must be integers, got {s!r}")
        if s < 0:
            raise ValueError(f"seeds must be integers >= 0 (numpy SeedSequence entropy), got {s}")
        out.append(int(s))
    if not out:
        raise ValueError("seeds must not be empty")
    return out


def _pick(items: list[Any], b: int) -> Any:
    return items[b if len(items) > 1 else 0]


@dataclass(frozen=True)
class _Plan:
    """Everything a chunk of runs needs, validated."""

    plants: list[ArmModel | SteppedPlant]
    ctrls: list[Controller]
    sensors: list[Sensor]
    dists: list[tuple[Disturbance, ...]]
    limits: list[FloatArray | None]
    seeds: list[int]
    q0: FloatArray
    qd0: FloatArray
    t: FloatArray
    refs: tuple[FloatArray, FloatArray, FloatArray]
    dt: float
    substeps: int
    qd_limit: float
    n: int
    nb: int


def _run_chunk(plan: _Plan, runs: range, out: list[FloatArray], status: NDArray[np.int64]) -> None:
    """Simulate ``runs`` of ``plan`` into ``out`` (six (len(runs), T, n) arrays) and
    ``status`` (len(runs), 3)."""
    n, t = plan.n, plan.t
    nt = t.shape[0]
    qr, qdr, qddr = plan.refs
    workspace = np.empty((E.workspace_rows(n), n))
    for i, b in enumerate(runs):
        plant = _pick(plan.plants, b)
        ctrl = _pick(plan.ctrls, b)
        sens = _pick(plan.sensors, b)
        dists = _pick(plan.dists, b)
        limit = _pick(plan.limits, b)
        seed = plan.seeds[b]
        root = np.random.SeedSequence(seed)
        madd, mhold = sens.arrays(t, n, np.random.Generator(np.random.PCG64(root)))
        dist = np.zeros((nt, n))
        for j, d in enumerate(dists):
            child = np.random.SeedSequence(seed, spawn_key=(j,))
            dist += disturbance_torque((d,), t, n, np.random.Generator(np.random.PCG64(child)))
        vcode, vf = sens.velocity.params(n)
        vf = np.ascontiguousarray(vf)
        tmax = np.full(n, np.inf) if limit is None else limit
        law = ctrl.handle
        model = ctrl.model.handle
        # writable copies: the kernels' argument types (a custom kernel may not write them)
        lp = np.array(law.params)
        mp = np.array(model.params)
        lstate = np.zeros(law.state_size)
        q0 = plan.q0[b if plan.q0.shape[0] > 1 else 0]
        qd0 = plan.qd0[b if plan.qd0.shape[0] > 1 else 0]
        outs = [o[i] for o in out]
        if isinstance(plant, SteppedPlant):
            _run_stepped(
                plant, law, lp, model, mp, lstate, q0, qd0, t, qr, qdr, qddr, madd, mhold, int(vcode),
                vf, dist, tmax, plan.dt, plan.substeps, plan.qd_limit, outs, status[i], workspace,
            )  # fmt: skip
            continue
        ph = plant.handle
        link, step, law_address = E.loop_link(ph.kind, ph.params, law.code)
        # the first run of a specialisation in this process compiles the loop (or loads it
        # from numba's cache): without automatic garbage collection meanwhile
        # (slidingarm._gc); the loop has fewer compiled signatures than specialisations then
        # (what stands in for it in a test may have none to show)
        first = len(getattr(E.run_one, "signatures", (0, 0))) < 2
        with paused() if first else nullcontext():
            E.run_one(
                ph.kind, np.array(ph.params), ph.g, step, law.code, law.entry.address, law.kernel.address, law_address, lp, lstate, model.kind,
                mp, model.g, q0, qd0, t, qr, qdr, qddr, madd, mhold, int(vcode), vf, dist,
                tmax, plan.dt, plan.substeps, plan.qd_limit, *outs, status[i], workspace, link,
            )  # fmt: skip


#: The smallest batch the block path (:mod:`slidingarm._block`) takes by default: one block
#: (:data:`slidingarm._block.W` = 16 lanes). Compiled, the block path is faster from a single
#: block on (paper arm, metrics, 4.5 s, 2 threads: 3.5x the per-run loop at 8 runs, 6.7-7.9x
#: at 16-32); the bound keeps a few runs on the per-run loop, which single runs have compiled
#: already, rather than have them wait for the block kernel's first compilation (15-35 s).
BLOCK_MIN_RUNS = 16

#: Blocks per unit of work of a thread on the block path.
BLOCK_CHUNK = 4


def _block_eligible_runs(
    plants: list[ArmModel | SteppedPlant],
    ctrls: list[Controller],
    nb: int,
    *,
    need: bool | None = None,
) -> bool:
    """Whether every run is a compiled plant under a built-in sliding-mode law with a nominal
    model of the plant's kind, all planar (``law = "model"`` or ``"paper"``) or all serial
    (``law = "model"``): what :func:`slidingarm._block.run_block` computes; and the batch has
    :data:`BLOCK_MIN_RUNS` runs. With ``need=True`` (``simulate_batch(block=True)``) any batch
    size, and a ``ValueError`` naming the reason instead of ``False``."""
    from slidingarm.control import _dispatch as LD
    from slidingarm.models import _dispatch as MD

    def no(reason: str) -> bool:
        if need:
            raise ValueError(f"block=True: this batch cannot take the block path: {reason}")
        return False

    if nb < BLOCK_MIN_RUNS and not need:
        return False
    from slidingarm.control import _kernels as CK

    kinds = {MD.KIND_PLANAR: "planar", MD.KIND_SERIAL: "serial"}
    first = plants[0]
    kind = None if isinstance(first, SteppedPlant) else first.handle.kind
    for p in plants:
        if isinstance(p, SteppedPlant) or p.handle.kind not in kinds:
            return no(f"the plant {type(p).__name__} is not a compiled planar or serial arm")
        if p.handle.kind != kind:
            return no("the plants are not all of one kind (planar or serial)")
    assert kind is not None
    for c in ctrls:
        law = c.handle
        if law.code != LD.LAW_SLIDING_MODE:
            return no(f"controller {c.label} is not a built-in sliding-mode law")
        if c.model.handle.kind != kind:
            return no(f"controller {c.label}'s nominal model is not a {kinds[kind]} arm like the plants")
        if kind == MD.KIND_SERIAL and int(law.params[CK.CI_LAW]) == CK.LAW_PAPER:
            return no(f"controller {c.label} uses the paper's law, which is planar")
    return True


def _distinct(items: list[Any], nb: int) -> tuple[list[Any], NDArray[np.int64]]:
    """The distinct objects of ``items`` (by identity) and each run's index into them."""
    index: dict[int, int] = {}
    uniq: list[Any] = []
    per = []
    for x in items:
        i = index.get(id(x))
        if i is None:
            i = index[id(x)] = len(uniq)
            uniq.append(x)
        per.append(i)
    idx = np.array(per, dtype=np.int64)
    return uniq, (np.zeros(nb, dtype=np.int64) if idx.shape[0] == 1 else idx)


@dataclass(frozen=True)
class _BlockStage:
    """A batch's per-run block inputs, built once per distinct object: stacked tables
    (distinct, ...) and each run's index into them."""

    plant: tuple[FloatArray, FloatArray, NDArray[np.int64]]  # params (D, rows, n), g (D,), idx
    law: tuple[FloatArray, FloatArray, FloatArray, FloatArray, NDArray[np.int64]]
    sensor: tuple[NDArray[np.int64], FloatArray, list[Sensor], NDArray[np.int64]]
    limit: tuple[FloatArray, NDArray[np.int64]]
    blocks: list[NDArray[np.int64]]
    serial: bool  # the serial kind's arms (else planar)


def _block_stage(plan: _Plan) -> _BlockStage:
    """Tables per distinct plant, controller, sensor and limit, and the runs grouped into
    blocks of ``W`` lanes that share the law's codes and the velocity estimator (a tail block
    is padded by repeating its last run)."""
    from slidingarm import _block as BK
    from slidingarm.control import _kernels as CK
    from slidingarm.models import _dispatch as MD

    n, nb = plan.n, plan.nb
    plants, pidx = _distinct(plan.plants, nb)
    pp = np.stack([np.asarray(p.handle.params, dtype=np.float64) for p in plants])
    pg = np.array([p.handle.g for p in plants], dtype=np.float64)
    ctrls, cidx = _distinct(plan.ctrls, nb)
    lps = [np.asarray(c.handle.params, dtype=np.float64) for c in ctrls]
    codes = np.stack([lp[: CK.NCI] for lp in lps])
    cf = np.stack([lp[CK.NCI :].reshape(CK.NCF, n) for lp in lps])
    mp = np.stack([np.asarray(c.model.handle.params, dtype=np.float64) for c in ctrls])
    mg = np.array([c.model.handle.g for c in ctrls], dtype=np.float64)
    sensors, sidx = _distinct(plan.sensors, nb)
    vel = [s.velocity.params(n) for s in sensors]
    vcodes = np.array([int(v[0]) for v in vel], dtype=np.int64)
    vf = np.stack([np.asarray(v[1], dtype=np.float64) for v in vel])
    limits, lidx = _distinct(plan.limits, nb)
    tl = np.stack([np.full(n, np.inf) if x is None else np.asarray(x) for x in limits])
    # group runs by (codes, velocity estimator), in run order within a group
    key = [
        (*codes[cidx[b]].tolist(), int(vcodes[sidx[b]])) for b in range(nb)
    ] if (len(ctrls) > 1 or len(sensors) > 1) else [()] * nb
    groups: dict[tuple[Any, ...], list[int]] = {}
    for b in range(nb):
        groups.setdefault(key[b], []).append(b)
    blocks = []
    for runs in groups.values():
        for lo in range(0, len(runs), BK.W):
            part = runs[lo : lo + BK.W]
            part = part + [part[-1]] * (BK.W - len(part))
            blocks.append(np.array(part, dtype=np.int64))
    serial = plants[0].handle.kind == MD.KIND_SERIAL
    return _BlockStage(
        (pp, pg, pidx), (codes, cf, mp, mg, cidx), (vcodes, vf, sensors, sidx), (tl, lidx),
        blocks, serial,
    )  # fmt: skip


def _lanes(table: FloatArray, idx: NDArray[np.int64]) -> FloatArray:
    """``table[idx]`` (W, ...) with the lane axis moved last, contiguous."""
    return np.ascontiguousarray(np.moveaxis(table[idx], 0, -1))


def _run_blocks(
    plan: _Plan,
    stage: _BlockStage,
    blocks: list[NDArray[np.int64]],
    keep: list[FloatArray] | None,
    stride: int,
    status: NDArray[np.int64],
    metrics: bool,
    spectra: Any = None,
) -> tuple[NDArray[np.int64], dict[str, FloatArray]] | None:
    """Run ``blocks`` (lane arrays of run indices) with :func:`slidingarm._block.run_block`:
    traces into ``keep`` (six (B, K, n) arrays, every ``stride``-th sample), status into
    ``status`` (B, 3); with ``metrics``, the chunk's runs and their metrics, the torque traces
    and the spectral metric's buffers in ``spectra`` (a :class:`slidingarm._block.SpectrumWork`
    of this thread's; a new one if ``None``)."""
    from slidingarm import _block as BK
    from slidingarm.control import _kernels as CK
    from slidingarm.metrics import (
        DEFAULT_DELTA_E,
        DEFAULT_DELTA_S,
        DEFAULT_WINDOW,
    )

    n, t = plan.n, plan.t
    nt = t.shape[0]
    qr, qdr, qddr = plan.refs
    pp, pg, pidx = stage.plant
    codes, cf, mp, mg, cidx = stage.law
    vcodes, vf, sensors, sidx = stage.sensor
    tl, lidx = stage.limit
    dummy = np.empty((1, 1, n))
    outs = keep if keep is not None else [dummy] * 6
    bands = np.array([DEFAULT_DELTA_S, DEFAULT_DELTA_E, BK.steady_start(t, DEFAULT_WINDOW)])
    q0s = plan.q0 if plan.q0.shape[0] > 1 else np.broadcast_to(plan.q0, (plan.nb, n))
    qd0s = plan.qd0 if plan.qd0.shape[0] > 1 else np.broadcast_to(plan.qd0, (plan.nb, n))
    done: list[NDArray[np.int64]] = []
    values: list[dict[str, FloatArray]] = []
    # the torque traces and the spectral metric's buffers, one block's worth, reused by every
    # block (a block's runs write all of their rows before the metrics read them)
    if metrics and spectra is None:
        spectra = BK.SpectrumWork(BK.W, nt, n)
    for lanes in blocks:
        # the block's distinct runs (a padded block repeats one) and each lane's index there
        runs = np.array(list(dict.fromkeys(lanes.tolist())), dtype=np.int64)
        where = {int(b): i for i, b in enumerate(runs)}
        local = np.array([where[int(b)] for b in lanes], dtype=np.int64)
        # the metrics' working set is one block's: memory does not grow with the chunk
        if metrics:
            assert spectra is not None
            acc = np.zeros((runs.shape[0], BK.NACC, n))
            tau_trace = spectra.trace[: runs.shape[0]]
        else:
            acc = np.zeros((1, BK.NACC, n))
            tau_trace = dummy
        madd = mhold = dist = None
        for ln, b in enumerate(lanes.tolist()):
            sens = sensors[sidx[b]]
            seed = plan.seeds[b]
            if sens.noise is not None or sens.faults:
                root = np.random.SeedSequence(seed)
                add, hold = sens.arrays(t, n, np.random.Generator(np.random.PCG64(root)))
                if madd is None:
                    madd = np.zeros((nt, n, BK.W))
                    mhold = np.zeros((nt, n, BK.W), dtype=np.bool_)
                assert mhold is not None
                madd[:, :, ln] = add
                mhold[:, :, ln] = hold
            ds = _pick(plan.dists, b)
            if ds:
                if dist is None:
                    dist = np.zeros((nt, n, BK.W))
                one = np.zeros((nt, n))
                for j, d in enumerate(ds):
                    child = np.random.SeedSequence(seed, spawn_key=(j,))
                    one += disturbance_torque((d,), t, n, np.random.Generator(np.random.PCG64(child)))
                dist[:, :, ln] = one
        if mhold is not None and not mhold.any():
            mhold = None
        first = int(lanes[0])
        paper = codes[cidx[first], CK.CI_LAW] == CK.LAW_PAPER
        tag = BK.PAPER_TAG if paper else (BK.SERIAL_TAG if stage.serial else BK.MODEL_TAG)
        BK.run_block(
            lanes, local, _lanes(pp, pidx[lanes]), pg[pidx[lanes]], codes[cidx[first]],
            _lanes(cf, cidx[lanes]), _lanes(mp, cidx[lanes]), mg[cidx[lanes]],
            np.ascontiguousarray(q0s[lanes].T), np.ascontiguousarray(qd0s[lanes].T), t, qr, qdr,
            qddr, np.empty((0, n, BK.W)) if madd is None else madd,
            np.empty((0, n, BK.W), dtype=np.bool_) if mhold is None else mhold,
            int(vcodes[sidx[first]]), _lanes(vf, sidx[lanes]),
            np.empty((0, n, BK.W)) if dist is None else dist, _lanes(tl, lidx[lanes]),
            plan.dt, plan.substeps, plan.qd_limit, stride if keep is not None else 0, *outs,
            metrics, bands, acc, tau_trace, status, tag, BK.joints_tag(n),
        )  # fmt: skip
        if metrics:
            failed = status[runs, 0] != E.STATUS_OK
            done.append(runs)
            part = BK.finish_metrics(
                t, acc, tau_trace, failed, delta_s=DEFAULT_DELTA_S, delta_e=DEFAULT_DELTA_E,
                cutoff_hz=DEFAULT_CUTOFF_HZ, work=spectra,
            )  # fmt: skip
            values.append(part)
    if not metrics:
        return None
    return np.concatenate(done), {
        name: np.concatenate([v[name] for v in values]) for name in values[0]
    }


def _run_stepped(
    plant: SteppedPlant,
    law: Any,
    lp: FloatArray,
    model: Any,
    mp: FloatArray,
    lstate: FloatArray,
    q0: FloatArray,
    qd0: FloatArray,
    t: FloatArray,
    qr: FloatArray,
    qdr: FloatArray,
    qddr: FloatArray,
    madd: FloatArray,
    mhold: NDArray[np.bool_],
    vcode: int,
    vf: FloatArray,
    dist: FloatArray,
    tmax: FloatArray,
    dt: float,
    substeps: int,
    qd_limit: float,
    outs: list[FloatArray],
    status: NDArray[np.int64],
    ws: FloatArray,
) -> None:
    """:func:`slidingarm._engine.run_one`'s loop with the plant stepped from Python: the same
    compiled step pieces before and after the plant's ``step``."""
    nt = t.shape[0]
    h = dt / substeps
    q = ws[E.Q_ROW]
    qd = ws[E.QD_ROW]
    tau_applied = ws[E.TAU_APPLIED_ROW]
    q[:] = q0
    qd[:] = qd0
    lstate[:] = 0.0
    status[:] = (E.STATUS_OK, -1, -1)
    for k in range(nt):
        bad = E.control_step(
            k, t[k], dt, law.code, law.entry.address, law.kernel.address, lp, lstate, model.kind, mp, model.g, madd, mhold, vcode, vf, qr, qdr, qddr, tmax, dist, ws, *outs,
        )  # fmt: skip
        if bad >= 0:
            status[:] = (E.STATUS_NONFINITE, k, bad)
            return
        if k == nt - 1:
            return
        ok = True
        for _ in range(substeps):
            ok &= plant.step(q, qd, tau_applied, h) is not False
        code, j = E.state_status(q, qd, ok, qd_limit)
        if code != E.STATUS_OK:
            status[:] = (code, k + 1, j)
            return


def _threads(nb: int, stepped: bool, threads: int | None = None) -> int:
    most = int(config.NUMBA_NUM_THREADS) if threads is None else threads
    return 1 if stepped else max(1, min(most, math.ceil(nb / CHUNK_RUNS)))


def available_memory() -> int | None:
    """Bytes of memory this process can still use: the kernel's ``MemAvailable``
    (``/proc/meminfo``), or the free physical pages (``os.sysconf``), capped by the
    room left under a cgroup v2 limit (a container's ``memory.max``); ``None`` where neither
    can be read."""
    avail: int | None = None
    try:
        with open("/proc/meminfo", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    avail = int(line.split()[1]) * 1024
                    break
    except (OSError, ValueError, IndexError):
        pass
    if avail is None:
        try:
            avail = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_AVPHYS_PAGES")
        except (ValueError, OSError, AttributeError):  # pragma: no cover - non-POSIX
            return None
    try:
        with open("/sys/fs/cgroup/memory.max", encoding="ascii") as fh:
            limit = fh.read().strip()
        if limit != "max":
            with open("/sys/fs/cgroup/memory.current", encoding="ascii") as fh:
                used = int(fh.read().strip())
            avail = min(avail, max(int(limit) - used, 0))
    except (OSError, ValueError):
        pass
    return avail


def memory_estimate(
    samples: int,
    joints: int,
    runs: int = 1,
    *,
    record: Record = "full",
    threads: int = 1,
    block: bool | None = None,
) -> int:
    """Bytes a batch allocates: its kept traces plus its workspaces.

    With :math:`T` samples, :math:`n` joints, :math:`B` runs, :math:`K` kept samples
    (:math:`T` for ``"full"``, :math:`\\lceil T/k \\rceil` for ``Every(k)``, 0 for
    ``"metrics"``), :math:`P` threads and chunks of :math:`c = \\min(B, 16)` runs:

    .. math::

        8\\,T\\,(1 + 3n) + 8 \\cdot 6\\,B K n + 8\\,P\\,T n\\,(6 + 14\\,c\\,[K < T])

    -- the time grid and the reference's :math:`q, \\dot q, \\ddot q`; the six recorded
    signals (:math:`q, \\dot q`, their measurements, :math:`\\tau`, :math:`s`) of every run;
    per thread, a run's sensor and disturbance arrays and, unless every sample is kept, a
    chunk's full traces and the temporaries of its metrics.

    On the block path (``block``; by default whenever :math:`B \\ge` :data:`BLOCK_MIN_RUNS`,
    the runs of planar or serial arms under a built-in law) the per-thread term is instead
    :math:`8\\,P\\,T n\\,(56 + 1.5\\,W)` with :math:`W` = :data:`~slidingarm._block.W` lanes
    a block: a block's sensor and disturbance arrays for its lanes, their per-run temporaries,
    and its torque traces with the temporaries of their ``hf_power_share`` (measured peaks:
    12 to 59 such :math:`8 T n` units per thread with 8 lanes, 70 to 72 with 16).
    """
    if record == "full":
        kept = samples
    elif isinstance(record, Every):
        kept = -(-samples // record.k)
    else:
        kept = 0
    chunk = min(runs, CHUNK_RUNS)
    grid = 8 * samples * (1 + 3 * joints)
    traces = 8 * 6 * runs * kept * joints
    if block is None:
        block = runs >= BLOCK_MIN_RUNS
    if block:
        from slidingarm._block import W as lanes

        work = 8 * threads * samples * joints * (56 + 3 * lanes // 2)
    else:
        work = 8 * threads * samples * joints * (6 + (14 * chunk if kept < samples else 0))
    return grid + traces + work


def byte_size(nbytes: float) -> str:
    """``nbytes`` for a message, in the largest binary unit below it: ``"1.5 GiB"``."""
    for unit, scale in (("TiB", 2**40), ("GiB", 2**30), ("MiB", 2**20), ("KiB", 2**10)):
        if nbytes >= scale:
            return f"{nbytes / scale:.3g} {unit}"
    return f"{nbytes:.0f} bytes"


def _check_memory(
    samples: int, joints: int, runs: int, record: Record, threads: int, block: bool
) -> None:
    """Refuse a batch whose :func:`memory_estimate` exceeds :data:`MEMORY_SHARE` of the
    :func:`available_memory`, before anything is allocated."""
    need = memory_estimate(samples, joints, runs, record=record, threads=threads, block=block)
    avail = available_memory()
    if avail is None or need <= MEMORY_SHARE * avail:
        return
    kind = "every sample" if record == "full" else f"record={record!r}"
    raise RunTooLargeError(
        f"t_final/dt = {samples - 1:.4g} steps x {joints} joints x {runs} run"
        f"{'s' if runs != 1 else ''} ({kind}) would need {byte_size(need)} of traces and "
        f"workspaces, more than {MEMORY_SHARE:.0%} of the {byte_size(avail)} of memory available: "
        "use record='metrics' (per-run metrics only) or record=Every(k), fewer runs, or a "
        "shorter t_final or longer dt",
        estimate=need,
        available=avail,
    )


def simulate_batch(
    plant: ArmModel | SteppedPlant | Sequence[ArmModel | SteppedPlant],
    controller: Controller | Sequence[Controller],
    reference: Reference,
    *,
    q0: ArrayLike,
    qd0: ArrayLike | None = None,
    t_final: float,
    dt: float,
    substeps: int = 1,
    sensor: Sensor | Sequence[Sensor] | None = None,
    disturbances: Sequence[Disturbance] | Sequence[Sequence[Disturbance]] = (),
    torque_limit: ArrayLike | Sequence[ArrayLike | None] | None = None,
    seeds: int | Sequence[int] = 0,
    qd_limit: float = DEFAULT_QD_LIMIT,
    record: Record = "full",
    throw: bool = True,
    block: bool | None = None,
    threads: int | None = None,
) -> BatchResult:
    """Simulate ``B`` closed-loop runs on one time grid.

    Any of ``plant``, ``controller``, ``q0`` (``(B, n)``), ``qd0``, ``sensor``,
    ``disturbances`` (a sequence of per-run sequences), ``torque_limit`` (``(B, n)`` or a list
    with one entry per run, ``None`` for none) and ``seeds`` may vary per run; each is either
    one value shared by all runs or ``B`` values. Parameters are otherwise those of
    :func:`simulate`.

    Parameters
    ----------
    record : {"full", "metrics"} or Every
        ``"full"``: every sample of every signal, ``(B, T, n)``; ``Every(k)``: every ``k``-th
        sample; ``"metrics"``: no traces, only each run's metrics (those of
        :func:`slidingarm.metrics.summary` on its full traces), computed chunk by chunk so
        that memory stays O(B n) beyond a bounded working set.
    block : bool or None
        Which loop runs the batch. ``None`` (default): the block path
        (:mod:`slidingarm._block`, 16 runs advanced together) when every run is a planar
        arm, or every run a serial arm, under a built-in sliding-mode law with a nominal model
        of the same kind, and :math:`B \\ge` :data:`BLOCK_MIN_RUNS`; else the per-run loop. A
        planar run is bit-identical on both paths; a serial one agrees to rounding (the block
        solves :math:`M^{-1}(\\tau - h)` where the per-run loop runs the articulated-body
        algorithm). ``False``: always the
        per-run loop (the block kernel's first compilation, 15-35 s once per cache for each
        law, arm kind and joint count, is not worth it for a few dozen runs). ``True``: the block path,
        and a ``ValueError`` saying why if the batch cannot take it.
    threads : int or None
        At most this many threads run the batch's compiled loops (each releases the GIL).
        ``None`` (default): numba's ``NUMBA_NUM_THREADS`` (the machine's cores unless set). A
        caller that runs several batches side by side in its own threads passes ``threads=1``
        to each, so that the loops never outnumber the cores. Results do not depend on it.
    throw : bool
        ``True``: raise :class:`SimulationError` for the first diverging run. ``False``:
        record each run's status (``BatchResult.ok``, ``.status``, ``.message``) and let the
        others finish; a failed run's samples after the failure and its metrics are NaN.

    Raises
    ------
    SimulationError
        With ``throw=True``, if any run diverges; the message names the run, time and joint.
    RunTooLargeError
        A :class:`MemoryError` (and :class:`ValueError`), before anything is allocated, if
        the batch's :func:`memory_estimate` exceeds :data:`MEMORY_SHARE` of the
        :func:`available_memory`.
    """
    if record not in ("full", "metrics") and not isinstance(record, Every):
        raise ValueError(f"record must be 'full', 'metrics' or Every(k), got {record!r}")
    if not isinstance(throw, bool):
        raise ParameterTypeError(f"throw must be True or False, got {throw!r}")
    plants = _listify("plant", plant, (ArmModel, SteppedPlant), "an arm model or a SteppedPlant")
    ctrls = _listify("controller", controller, Controller, "a Controller")
    n = plants[0].n
    for p in plants:
        if p.n != n:
            raise ValueError(f"all plants must have the same number of joints, got {p.n} and {n}")
    for c in ctrls:
        if c.n != n:
            raise ValueError(f"controller has {c.n} joints but the plant has {n}")
    ref_n = getattr(reference, "n", None)
    if ref_n != n or not hasattr(reference, "evaluate"):
        raise ValueError(f"reference must be a Reference with n = {n} joints, got {reference!r}")
    if isinstance(substeps, bool) or not isinstance(substeps, int | np.integer):
        raise ParameterTypeError(f"substeps must be an integer >= 1, got {substeps!r}")
    if substeps < 1:
        raise ValueError(f"substeps must be an integer >= 1, got {substeps!r}")
    if substeps > MAX_SUBSTEPS:
        raise ValueError(
            f"substeps must be at most {MAX_SUBSTEPS:,} RK4 steps per sample, got {substeps!r}"
        )
    if isinstance(qd_limit, str | bytes | bool | np.bool_) or not isinstance(
        qd_limit, int | float | np.integer | np.floating
    ):
        raise ParameterTypeError(f"qd_limit must be a number (rad/s), got {qd_limit!r}")
    if not (math.isfinite(_float(qd_limit)) and qd_limit > 0):
        raise ValueError(f"qd_limit must be a finite speed > 0 rad/s, got {qd_limit!r}")
    sensors = [Sensor()] if sensor is None else _listify("sensor", sensor, Sensor, "a Sensor")
    dists = _disturbance_lists(disturbances)
    limits = _torque_limits(torque_limit, n)
    q0a = _vectors("q0", q0, n, MAX_POSITION)
    qd0a = _vectors("qd0", np.zeros(n) if qd0 is None else qd0, n)
    seed_list = _seed_list(seeds)
    counts = {
        "plants": len(plants), "controllers": len(ctrls), "q0": q0a.shape[0],
        "qd0": qd0a.shape[0], "sensors": len(sensors), "disturbances": len(dists),
        "torque_limit": len(limits), "seeds": len(seed_list),
    }  # fmt: skip
    sizes = set(counts.values()) - {1}
    if len(sizes) > 1:
        base = ("plants", "controllers", "q0", "qd0")
        shown = [k for k in counts if k != "seeds" and (k in base or counts[k] != 1)]
        raise ValueError(
            "batch sizes differ: "
            + ", ".join(f"{k} {counts[k]}" for k in [*shown, "seeds"])
            + " (each must be 1 or B)"
        )
    nb = sizes.pop() if sizes else 1

    steps, _h = _grid_steps(t_final, dt)
    nt = steps + 1
    if record != "full" and not DEFAULT_CUTOFF_HZ < 0.5 / float(dt):
        # the streamed metrics include hf_power_share, whose cut-off must lie below the
        # Nyquist frequency: refused here, not after the whole batch has run
        raise ValueError(
            f"record={record!r} computes hf_power_share above {DEFAULT_CUTOFF_HZ:g} Hz, which "
            f"needs dt < {0.5 / DEFAULT_CUTOFF_HZ:g} s (the Nyquist frequency 1/(2 dt) above "
            f"it); got dt = {float(dt):g} s: use a smaller dt or record='full'"
        )
    stepped = any(isinstance(p, SteppedPlant) for p in plants)
    if threads is not None and (
        isinstance(threads, bool) or not isinstance(threads, int | np.integer) or threads < 1
    ):
        raise ParameterTypeError(f"threads must be None or an integer >= 1, got {threads!r}")
    nthreads = _threads(nb, stepped, None if threads is None else int(threads))
    if block is not None and not isinstance(block, bool):
        raise ParameterTypeError(f"block must be True, False or None, got {block!r}")
    blockable = block is not False and _block_eligible_runs(plants, ctrls, nb, need=block)
    _check_memory(nt, n, nb, record, nthreads, blockable)
    t = time_grid(t_final, dt)
    # parameters chosen from the control period (an automatic eps_e) are fixed now
    ctrls = [c.for_period(float(dt)) for c in ctrls]
    qr, qdr, qddr = (np.ascontiguousarray(a, dtype=np.float64) for a in reference.evaluate(t))
    # Reference.evaluate (unless a subclass replaced it or its check) has checked every value
    kind = type(reference)
    checked = (
        isinstance(reference, Reference)
        and kind.evaluate is Reference.evaluate
        and kind._checked is Reference._checked
    )
    for name, a in (("q", qr), ("qd", qdr), ("qdd", qddr)):
        if a.shape != (nt, n) or not (checked or np.isfinite(a).all()):
            raise ValueError(
                f"reference {name} must be finite with shape ({nt}, {n}), got {a.shape}"
            )
    stride = 1 if record == "full" else (record.k if isinstance(record, Every) else 0)
    kept = 0 if stride == 0 else len(range(0, nt, stride))
    for c in ctrls:
        c.reset()
    plan = _Plan(
        plants, ctrls, sensors, dists, limits,
        seed_list if len(seed_list) == nb else seed_list * nb,
        q0a, qd0a, t, (qr, qdr, qddr), float(dt), int(substeps), float(qd_limit), n, nb,
    )  # fmt: skip

    # the six traces as views of one block: freed as one chunk, which the C allocator then
    # keeps for the next run of that size (six chunks of a fifth of a megabyte each were
    # handed back to the system and faulted in again page by page, 0.3 µs per UR5 sample)
    keep = list(np.empty((6, nb, kept, n))) if kept else None
    metrics: dict[str, FloatArray] | None = None if record == "full" else {}
    status = np.zeros((nb, 3), dtype=np.int64)
    chunks = [range(lo, min(lo + CHUNK_RUNS, nb)) for lo in range(0, nb, CHUNK_RUNS)]

    def work(runs: range) -> dict[str, FloatArray] | None:
        sl = slice(runs.start, runs.stop)
        if record == "full":
            assert keep is not None
            _run_chunk(plan, runs, [k[sl] for k in keep], status[sl])
            _blank_failures([k[sl] for k in keep], status[sl])
            return None
        full = [np.empty((len(runs), nt, n)) for _ in range(6)]
        _run_chunk(plan, runs, full, status[sl])
        _blank_failures(full, status[sl])
        if keep is not None:
            for k, f in zip(keep, full, strict=True):
                k[sl] = f[:, ::stride]
        q, _qd, _qm, _qdm, tau, s = full
        return metric_values(t, q - qr[None], s, tau, status[sl, 0] != E.STATUS_OK)

    if blockable:
        from slidingarm import _block as BK
        from slidingarm.control import _kernels as CK

        stage = _block_stage(plan)
        # the kernel of each law the batch has (the paper's is a signature of its own), for
        # the batch's joint count (a signature each)
        for paper in {bool(c == CK.LAW_PAPER) for c in stage.law[0][:, CK.CI_LAW]}:
            BK.compiled(paper=paper, n=plan.n, serial=stage.serial)
        # chunks of at most BLOCK_CHUNK blocks, enough of them for every thread
        nthr = max(1, int(config.NUMBA_NUM_THREADS) if threads is None else int(threads))
        per = max(1, min(BLOCK_CHUNK, -(-len(stage.blocks) // nthr)))
        bchunks = [stage.blocks[i : i + per] for i in range(0, len(stage.blocks), per)]

        bthreads = max(1, min(nthr, len(bchunks)))
        # one set of the metrics' block buffers per thread, for the whole batch: allocated
        # per chunk they were faulted in (and out) again every few blocks
        spare: SimpleQueue[Any] = SimpleQueue()
        for _ in range(bthreads if metrics is not None else 0):
            spare.put(BK.SpectrumWork(BK.W, plan.t.shape[0], n))

        def bwork(
            blocks: list[NDArray[np.int64]],
        ) -> tuple[NDArray[np.int64], dict[str, FloatArray]] | None:
            spectra = spare.get() if metrics is not None else None
            try:
                return _run_blocks(
                    plan, stage, blocks, keep, stride, status, metrics is not None, spectra
                )
            finally:
                if spectra is not None:
                    spare.put(spectra)

        if bthreads <= 1:
            bparts = [bwork(c) for c in bchunks]
        else:
            with ThreadPoolExecutor(bthreads) as pool:
                bparts = list(pool.map(bwork, bchunks))
        if keep is not None:
            _blank_kept(keep, status, stride)
        if metrics is not None:
            for part in bparts:
                assert part is not None
                runs, values = part
                for name, v in values.items():
                    if name not in metrics:
                        metrics[name] = np.empty((nb, n))
                    metrics[name][runs] = v
    else:
        if nthreads <= 1:
            parts = [work(r) for r in chunks]
        else:
            with ThreadPoolExecutor(nthreads) as pool:
                parts = list(pool.map(work, chunks))
        if metrics is not None:
            for name in parts[0] or {}:
                metrics[name] = np.concatenate([p[name] for p in parts if p is not None])

    run_seeds = plan.seeds
    rows = status.tolist()  # Python ints: a row of a numpy array per run is ten times slower
    fail_time = np.where(status[:, 1] >= 0, t[np.maximum(status[:, 1], 0)], math.inf)
    ok_message = run_message(E.STATUS_OK, math.inf, 0, qd_limit)
    messages = [
        ok_message if c == E.STATUS_OK else run_message(c, float(t[k]), j + 1, qd_limit)
        for c, k, j in rows
    ]
    bad = np.flatnonzero(status[:, 0] != E.STATUS_OK)
    if throw and bad.size:
        b = int(bad[0])
        _code, k, j = rows[b]
        when = float(t[k])
        run = f" (run {b} of {nb})" if nb > 1 else ""
        raise SimulationError(
            f"simulation diverged at t = {when:.6g} s, joint {j + 1}{run}: {messages[b]}"
            "; check the gains, the sample time and the torque limits",
            time=when,
            joint=j + 1,
            run=b,
        )

    # each distinct object's dict is built once and shared by the runs that use it
    # (O(distinct objects), not O(B) calls of to_dict), a key's values as a column first:
    # 10 000 runs' dicts 0.2 -> 0.05 s, which no thread shares
    memo: dict[tuple[str, int], Any] = {}

    def column(kind: str, items: list[Any], make: Any) -> list[Any]:
        values = []
        for x in items:
            key = (kind, id(x))
            if key not in memo:
                memo[key] = make(x)
            values.append(memo[key])
        return values if len(values) > 1 else values * nb

    def own_lists(x: list[Any]) -> list[Any]:
        # each run's own list (a shared one would change every run's when one is edited)
        return x if len(x) > 1 else [None if x[0] is None else list(x[0]) for _ in range(nb)]

    ref_dict = reference.to_dict()
    params = [
        {
            "version": __version__,
            "plant": plant,
            "controller": controller,
            "label": label,
            "s_unit": s_unit,
            "reference": ref_dict,
            "q0": q0_b,
            "qd0": qd0_b,
            "t_final": float(t[-1]),
            "dt": float(dt),
            "substeps": int(substeps),
            "sensor": sensor,
            "disturbances": dist,
            "torque_limit": limit,
            "seed": seed,
        }
        for plant, controller, label, s_unit, q0_b, qd0_b, sensor, dist, limit, seed in zip(
            column("plant", plants, lambda x: x.to_dict()),
            column("ctrl", ctrls, lambda x: x.to_dict()),
            column("label", ctrls, lambda x: x.label),
            column("s_unit", ctrls, lambda x: x.s_unit),
            own_lists(q0a.tolist()),
            own_lists(qd0a.tolist()),
            column("sensor", sensors, lambda x: x.to_dict()),
            column("dist", dists, lambda x: [d.to_dict() for d in x]),
            own_lists([None if x is None else x.tolist() for x in limits]),
            run_seeds,
            strict=True,
        )
    ]
    tk = t if stride in (0, 1) else t[::stride]
    signals: dict[str, Any] = {}
    if keep is not None:
        shape = (nb, kept, n)
        signals = dict(
            q=keep[0], qd=keep[1], q_meas=keep[2], qd_meas=keep[3], tau=keep[4], s=keep[5],
            q_ref=np.broadcast_to(qr[::stride], shape), qd_ref=np.broadcast_to(qdr[::stride], shape),
        )  # fmt: skip
    return BatchResult(
        t=tk,
        **signals,
        params=params,
        seeds=[int(s) for s in run_seeds],
        status_code=status[:, 0].copy(),
        fail_time=fail_time,
        fail_joint=status[:, 2] + 1,
        messages=messages,
        metric_values=metrics,
        t_full=t,
        record="full" if record == "full" else ("metrics" if stride == 0 else f"every {stride}"),
    )


def _blank_kept(keep: list[FloatArray], status: NDArray[np.int64], stride: int) -> None:
    """:func:`_blank_failures` for traces kept every ``stride``-th sample: NaN from the first
    kept sample at or after each failed run's failing sample."""
    for i in np.flatnonzero(status[:, 0] != E.STATUS_OK):
        first = -(-int(status[i, 1]) // stride)
        for o in keep:
            o[i, first:] = np.nan


def _blank_failures(outs: list[FloatArray], status: NDArray[np.int64]) -> None:
    """NaN from each failed run's failing sample on, so that no sample of a failed run looks
    valid past the failure (the outputs after it were never written)."""
    for i in np.flatnonzero(status[:, 0] != E.STATUS_OK):
        first = int(status[i, 1])
        for o in outs:
            o[i, first:] = np.nan


def simulate(
    plant: ArmModel | SteppedPlant,
    controller: Controller,
    reference: Reference,
    *,
    q0: ArrayLike,
    qd0: ArrayLike | None = None,
    t_final: float,
    dt: float,
    substeps: int = 1,
    sensor: Sensor | None = None,
    disturbances: Sequence[Disturbance] = (),
    torque_limit: ArrayLike | None = None,
    seed: int = 0,
    qd_limit: float = DEFAULT_QD_LIMIT,
    throw: bool = True,
) -> SimResult:
    """Simulate one closed-loop run of ``plant`` under ``controller`` tracking ``reference``.

    Parameters
    ----------
    plant : ArmModel or SteppedPlant
        The real arm (the controller holds its own nominal model): a compiled model such as
        :class:`~slidingarm.PlanarArm`, or a plant stepped from Python.
    controller : Controller
        The control law; its state is reset before the run.
    reference : Reference
        Desired trajectory with analytic derivatives, evaluated at the sample times.
    q0, qd0 : array_like, shape (n,)
        Initial state; ``qd0`` defaults to rest. The paper's is
        :data:`slidingarm.references.PAPER_Q0`.
    t_final, dt : float
        Duration and sample time (s); ``t_final`` is a whole number of steps.
    substeps : int
        RK4 steps per sample interval.
    sensor : Sensor, optional
        Position noise, faults and velocity estimate (default: exact measurement).
    disturbances : sequence of Disturbance
        Torque disturbances added to the plant's input.
    torque_limit : float or array_like (n,), optional
        Actuator limit :math:`|\\tau_i| \\le \\tau_{max,i}` (N m), applied to the controller output.
    seed : int
        Seed of the run's ``numpy.random.SeedSequence``, recorded in the result.
    qd_limit : float
        Speed (rad/s) beyond which the run is declared diverged.
    throw : bool
        ``True``: raise on divergence; ``False``: return the result with ``success=False``,
        its ``message``, and NaN samples after the failure.

    Returns
    -------
    SimResult
        Every sample: ``t`` (T,), ``q, qd, q_ref, qd_ref, q_meas, qd_meas, tau, s`` (T, n).

    Raises
    ------
    SimulationError
        If the run diverges (non-finite state or runaway velocity) and ``throw``; names time
        and joint.
    """
    if not isinstance(plant, ArmModel | SteppedPlant):
        raise ParameterTypeError(
            f"plant must be an arm model (PlanarArm, ...) or a SteppedPlant, got {type(plant).__name__}"
        )
    if not isinstance(controller, Controller):
        raise ParameterTypeError(f"controller must be a Controller, got {type(controller).__name__}")
    q0a = _vectors("q0", q0, plant.n)
    if q0a.shape[0] != 1:
        raise ValueError(
            f"q0 must have shape ({plant.n},) for one run; use simulate_batch for a batch"
        )
    if isinstance(seed, bool | np.bool_) or not isinstance(seed, int | np.integer):
        raise ParameterTypeError(f"seed must be an integer, got {seed!r}")
    if torque_limit is not None and np.ndim(torque_limit) > 1:
        raise ValueError(
            f"torque_limit must be > 0 N m, a scalar or one per joint ({plant.n}), got "
            f"shape {np.shape(torque_limit)} (per-run limits belong to simulate_batch)"
        )
    batch = simulate_batch(
        plant,
        controller,
        reference,
        q0=q0a[0],
        qd0=qd0,
        t_final=t_final,
        dt=dt,
        substeps=substeps,
        sensor=sensor,
        disturbances=disturbances,
        torque_limit=torque_limit,
        seeds=int(seed),
        qd_limit=qd_limit,
        throw=throw,
    )
    return batch[0]
