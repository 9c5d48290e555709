"""Throughput of ``simulate_batch``: the block path against the scalar path (issue 12, point 3).

Run as ``python benchmarks/bench_batch.py [--quick] [--repeats R] [--sizes 64 1000 10000]``.
In one run, for 1 and 2 threads and each batch size ``B``, the paper's arm (3 joints, 4.5 s at
5e-4 s: 9000 steps a run) under FTSMC with sign switching (the gains of
``_numba_reference.py``) in ``record="metrics"`` mode, it prints arm-steps per second
(``B * 9000 / wall time``) of

* the block path (:mod:`slidingarm._block`, taken by ``simulate_batch`` for ``B >= 16``),
* the scalar path (the same call with ``simulate.BLOCK_MIN_RUNS`` raised above ``B``),
* a plain numba ``prange`` loop over scalar runs written here (``_numba_reference.closed_loop_mse``
  per run: the same loop, each run's MSE per joint accumulated as its metric, no trace kept),
  the reference of issue 12,

and the ratios block / scalar and block / reference; then a UR5 figure (arm-steps per second
of ``simulate_batch`` on 64 UR5 runs, metrics mode, on the block path and on the per-run loop). Before timing, the reference is checked to
run the same loop as ours: its trajectory of the paper's run within 1e-9 rad of both our
paths', and its MSE of 16 perturbed runs within 1e-6 (relative) of our ``mse`` metric. Each
figure is the median of ``--repeats`` timings that take turns (block, scalar, reference), so
that a change of the machine's load shows in all three; the load average is printed with the
table. Targets (issue 12): at ``B = 10 000`` on 2 threads at least 1.5e7 arm-steps/s and at
least 5x the reference.
The threads of ``simulate_batch`` follow ``numba.config.NUMBA_NUM_THREADS``, those of the
reference ``numba.set_num_threads``; both are set per row.
"""

from __future__ import annotations

import argparse
import importlib
import os
import time

import numba
import numpy as np
from numba import njit, prange

import _host
import _numba_reference as NR
import slidingarm as sa
from slidingarm.references import PAPER_Q0

S = importlib.import_module("slidingarm.simulate")

DT = 5e-4
T_FINAL = 4.5
STEPS = 9000
TARGET_RATE = 1.5e7
TARGET_RATIO = 5.0
REFERENCE_DEV = 1e-9
REFERENCE_MSE_REL = 1e-6


@njit(parallel=True, cache=True)
def prange_batch(
    m: np.ndarray,
    ln: np.ndarray,
    g: float,
    q0s: np.ndarray,
    qd0: np.ndarray,
    q_ref: np.ndarray,
    qd_ref: np.ndarray,
    qdd_ref: np.ndarray,
    dt: float,
    mse: np.ndarray,
) -> None:
    """The reference: each run the plain scalar loop, runs spread over numba's threads, the MSE
    per joint of each run into ``mse`` (B, n)."""
    for b in prange(q0s.shape[0]):
        NR.closed_loop_mse(m, ln, g, q0s[b], qd0, q_ref, qd_ref, qdd_ref, dt, mse[b])


def problem() -> tuple[sa.PlanarArm, sa.FTSMC, sa.PaperReference]:
    arm = sa.PlanarArm.paper()
    ctrl = sa.FTSMC(arm, alpha=NR.ALPHA, beta=NR.BETA, p=5, q=3, k=NR.K, eps_e=NR.EPS_E)
    return arm, ctrl, sa.PaperReference()


def initial_states(b: int) -> np.ndarray:
    return np.asarray(PAPER_Q0) + np.random.default_rng(0).normal(0.0, 0.01, (b, 3))


def batch(path: str, q0: np.ndarray, record: str = "metrics") -> sa.BatchResult:
    """One ``simulate_batch`` of the runs from ``q0`` (B, 3) on ``path``."""
    arm, ctrl, ref = problem()
    saved = S.BLOCK_MIN_RUNS
    S.BLOCK_MIN_RUNS = saved if path == "block" else 10**12
    try:
        return sa.simulate_batch(arm, ctrl, ref, q0=q0, t_final=T_FINAL, dt=DT, record=record)
    finally:
        S.BLOCK_MIN_RUNS = saved


def ours(path: str, b: int, q0: np.ndarray) -> float:
    """Seconds of one ``simulate_batch`` of ``b`` runs on ``path``."""
    t0 = time.perf_counter()
    out = batch(path, q0)
    dt = time.perf_counter() - t0
    assert out.metric_values is not None and np.all(out.ok)
    return dt


def check_reference(q0: np.ndarray, inputs: tuple[np.ndarray, ...]) -> str:
    """Check that the reference runs our loop; returns a line saying by how much they differ.

    On the paper's run (from ``PAPER_Q0``) the reference's trajectory must be within
    :data:`REFERENCE_DEV` of both our paths' (``record="full"``). On the runs from ``q0`` (B, 3)
    its MSE must be within :data:`REFERENCE_MSE_REL` of our ``mse`` metric: there a trajectory
    may not stay within 1e-9, because the sign law is discontinuous (a sample whose ``s`` is
    within rounding of zero can switch the other way in one implementation, and from then on
    the two runs differ by that sample's kick, about 1e-5 rad at most on the benchmark's runs);
    the largest difference of ``q`` over those runs is printed, not checked.
    """
    m, ln, g, qr, qdr, qddr = inputs
    qd0 = np.zeros(3)
    paper = np.array([PAPER_Q0])
    mine = NR.closed_loop(m, ln, g, paper[0], qd0, qr, qdr, qddr, DT)
    devs = {}
    for path in ("block", "scalar"):
        full = batch(path, paper, record="full")
        assert full.q is not None and np.all(full.ok)
        devs[path] = float(np.abs(mine - full.q[0]).max())
        if not devs[path] <= REFERENCE_DEV:
            raise AssertionError(
                f"on the paper's run the reference's q differs from the {path} path's by "
                f"{devs[path]:.1e} rad (> {REFERENCE_DEV:g}): they do not run the same loop"
            )
    mse = np.empty((q0.shape[0], 3))
    prange_batch(m, ln, g, q0, qd0, qr, qdr, qddr, DT, mse)
    metrics = batch("block", q0).metric_values
    assert metrics is not None
    mse_dev = float(np.max(np.abs(mse / metrics["mse"] - 1.0)))
    if not mse_dev <= REFERENCE_MSE_REL:
        raise AssertionError(
            f"the reference's MSE differs from ours by {mse_dev:.1e} (relative, > "
            f"{REFERENCE_MSE_REL:g}) on {q0.shape[0]} runs: they do not run the same loop"
        )
    full = batch("block", q0, record="full")
    assert full.q is not None
    runs = np.stack([NR.closed_loop(m, ln, g, q, qd0, qr, qdr, qddr, DT) for q in q0])
    q_dev = float(np.abs(runs - full.q).max())
    return (
        f"reference vs ours: paper run max |dq| {devs['block']:.1e} rad (block path), "
        f"{devs['scalar']:.1e} rad (scalar path); {q0.shape[0]} perturbed runs: MSE relative "
        f"difference {mse_dev:.1e}, max |dq| {q_dev:.1e} rad (sign law)"
    )


def reference(q0: np.ndarray, inputs: tuple[np.ndarray, ...]) -> float:
    m, ln, g, qr, qdr, qddr = inputs
    mse = np.empty((q0.shape[0], 3))
    t0 = time.perf_counter()
    prange_batch(m, ln, g, q0, np.zeros(3), qr, qdr, qddr, DT, mse)
    return time.perf_counter() - t0


#: The UR5 row: FTSMC with tanh on the exact nominal model, a quintic to 0.5 rad in 2 s, 2 s
#: at 1 ms (2000 steps a run), ``UR5_RUNS`` runs from perturbed initial states.
UR5_DT = 1e-3
UR5_T = 2.0
UR5_STEPS = 2000
UR5_RUNS = 64


def ur5_rate(threads: int, repeats: int) -> dict[str, float]:
    """Arm-steps per second of ``simulate_batch`` on the UR5 (metrics mode) on the block path
    (the serial kind's lanes, :func:`slidingarm._block._rk4_serial`) and on the per-run loop,
    timings taking turns."""
    arm = sa.robots.load("ur5")
    ctrl = sa.FTSMC(arm, alpha=2.0, beta=2.0, p=5, q=3, k=20.0, switching="tanh", width=0.05)
    q0 = np.zeros(arm.n) + np.random.default_rng(1).normal(0.0, 0.01, (UR5_RUNS, arm.n))
    ref = sa.QuinticReference(np.zeros(arm.n), np.full(arm.n, 0.5), duration=UR5_T)

    def once(path: str) -> float:
        t0 = time.perf_counter()
        out = sa.simulate_batch(arm, ctrl, ref, q0=q0, t_final=UR5_T, dt=UR5_DT,
                                record="metrics", threads=threads, block=path == "block")  # fmt: skip
        dt = time.perf_counter() - t0
        assert np.all(out.ok)
        return dt

    once("block")
    once("scalar")
    times: dict[str, list[float]] = {"block": [], "scalar": []}
    for _ in range(repeats):
        for path in times:
            times[path].append(once(path))
    return {path: UR5_RUNS * UR5_STEPS / float(np.median(v)) for path, v in times.items()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="B = 64 and 1000, one repeat")
    parser.add_argument("--repeats", type=int, default=3, help="timings per figure (median)")
    parser.add_argument("--sizes", type=int, nargs="+", default=[64, 1000, 10000])
    parser.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    args = parser.parse_args()
    sizes = [64, 1000] if args.quick else args.sizes
    repeats = 1 if args.quick else args.repeats
    ref = problem()[2]
    t = S.time_grid(T_FINAL, DT)
    qr, qdr, qddr = (np.ascontiguousarray(a) for a in ref.evaluate(t))
    inputs = (NR.MASSES, NR.LENGTHS, NR.GRAVITY, qr, qdr, qddr)
    # warm-up: compile (or load) all three, and check that they run the same loop
    warm = initial_states(16)
    ours("block", 16, warm)
    ours("scalar", 16, warm)
    reference(warm, inputs)
    agreement = check_reference(warm, inputs)
    saved = numba.config.NUMBA_NUM_THREADS
    print(f"paper arm, FTSMC sign, record='metrics', {STEPS} steps a run; median of {repeats}")
    print(agreement)
    print(_host.describe())
    print(f"load average at start: {os.getloadavg()}")
    header = (
        f"{'threads':>7} {'B':>6} {'block':>10} {'scalar':>10} {'prange ref':>10} "
        f"{'blk/scal':>8} {'blk/ref':>8}"
    )
    print(header)
    rows = []
    try:
        for threads in args.threads:
            numba.config.NUMBA_NUM_THREADS = threads
            numba.set_num_threads(threads)
            for b in sizes:
                q0 = initial_states(b)
                times: dict[str, list[float]] = {"block": [], "scalar": [], "ref": []}
                for _ in range(repeats):
                    times["block"].append(ours("block", b, q0))
                    times["scalar"].append(ours("scalar", b, q0))
                    times["ref"].append(reference(q0, inputs))
                rate = {k: b * STEPS / float(np.median(v)) for k, v in times.items()}
                rows.append((threads, b, rate))
                print(
                    f"{threads:>7} {b:>6} {rate['block']:>10.3g} {rate['scalar']:>10.3g} "
                    f"{rate['ref']:>10.3g} {rate['block'] / rate['scalar']:>8.2f} "
                    f"{rate['block'] / rate['ref']:>8.2f}",
                    flush=True,
                )
    finally:
        numba.config.NUMBA_NUM_THREADS = saved
    for threads in args.threads:
        ur5 = ur5_rate(threads, repeats)
        print(f"UR5 (6 joints, FTSMC tanh), {threads} thread(s), B = {UR5_RUNS}: block "
              f"{ur5['block']:.3g}, per-run loop {ur5['scalar']:.3g} arm-steps/s "
              f"({ur5['block'] / ur5['scalar']:.2f}x)")  # fmt: skip
    print(f"load average at end: {os.getloadavg()}")
    for threads, b, rate in rows:
        if threads == 2 and b == 10000:
            met = rate["block"] >= TARGET_RATE and rate["block"] >= TARGET_RATIO * rate["ref"]
            print(
                f"target (B = 10000, 2 threads: >= {TARGET_RATE:.2g} arm-steps/s and >= "
                f"{TARGET_RATIO:g}x the reference): {'met' if met else 'NOT met'}"
            )


if __name__ == "__main__":
    main()
