"""Throughput of ``simulate_batch``: the block path against the scalar path (issue 12, point 3).

Run as ``python benchmarks/bench_batch.py [--quick] [--repeats R] [--sizes 64 1000 10000]``.
In one run, for 1 and 2 threads and each batch size ``B``, the paper's arm (3 joints, 4.5 s at
5e-4 s: 9000 steps a run) under FTSMC with sign switching (the gains of
``_numba_reference.py``) in ``record="metrics"`` mode, it prints arm-steps per second
(``B * 9000 / wall time``) of

* the block path (:mod:`slidingarm._block`, taken by ``simulate_batch`` for ``B >= 16``),
* the scalar path (the same call with ``simulate.BLOCK_MIN_RUNS`` raised above ``B``),
* a plain numba ``prange`` loop over scalar runs written here (``_numba_reference.closed_loop``
  per run, each run's MSE per joint as its metric), the reference of issue 12,

and the ratios block / scalar and block / reference. Each figure is the median of
``--repeats`` timings that take turns (block, scalar, reference), so that a change of the
machine's load shows in all three; the load average is printed with the table. Targets (issue
12): at ``B = 10 000`` on 2 threads at least 1.5e7 arm-steps/s and at least 5x the reference.
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

import _numba_reference as NR
import slidingarm as sa
from slidingarm.references import PAPER_Q0

S = importlib.import_module("slidingarm.simulate")

DT = 5e-4
T_FINAL = 4.5
STEPS = 9000
TARGET_RATE = 1.5e7
TARGET_RATIO = 5.0


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
    nt, n = q_ref.shape
    for b in prange(q0s.shape[0]):
        qs = NR.closed_loop(m, ln, g, q0s[b], qd0, q_ref, qd_ref, qdd_ref, dt)
        for j in range(n):
            acc = 0.0
            for k in range(nt):
                e = qs[k, j] - q_ref[k, j]
                acc += e * e
            mse[b, j] = acc / nt


def problem() -> tuple[sa.PlanarArm, sa.FTSMC, sa.PaperReference]:
    arm = sa.PlanarArm.paper()
    ctrl = sa.FTSMC(arm, alpha=NR.ALPHA, beta=NR.BETA, p=5, q=3, k=NR.K, eps_e=NR.EPS_E)
    return arm, ctrl, sa.PaperReference()


def initial_states(b: int) -> np.ndarray:
    return np.asarray(PAPER_Q0) + np.random.default_rng(0).normal(0.0, 0.01, (b, 3))


def ours(path: str, b: int, q0: np.ndarray) -> float:
    """Seconds of one ``simulate_batch`` of ``b`` runs on ``path``."""
    arm, ctrl, ref = problem()
    saved = S.BLOCK_MIN_RUNS
    S.BLOCK_MIN_RUNS = saved if path == "block" else 10**12
    try:
        t0 = time.perf_counter()
        out = sa.simulate_batch(arm, ctrl, ref, q0=q0, t_final=T_FINAL, dt=DT, record="metrics")
        dt = time.perf_counter() - t0
    finally:
        S.BLOCK_MIN_RUNS = saved
    assert out.metric_values is not None and np.all(out.ok)
    return dt


def reference(q0: np.ndarray, inputs: tuple[np.ndarray, ...]) -> float:
    m, ln, g, qr, qdr, qddr = inputs
    mse = np.empty((q0.shape[0], 3))
    t0 = time.perf_counter()
    prange_batch(m, ln, g, q0, np.zeros(3), qr, qdr, qddr, DT, mse)
    return time.perf_counter() - t0


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
    # warm-up: compile (or load) all three
    warm = initial_states(16)
    ours("block", 16, warm)
    ours("scalar", 16, warm)
    reference(warm, inputs)
    saved = numba.config.NUMBA_NUM_THREADS
    print(f"paper arm, FTSMC sign, record='metrics', {STEPS} steps a run; median of {repeats}")
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
