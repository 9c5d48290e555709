"""Resident memory of a metrics-only Monte Carlo batch (issue 8, point 5).

Run as ``python benchmarks/bench_memory.py [--runs 10000]``: B paper runs (FTSMC, sign,
4.5 s at 5e-4 s) with per-run initial states, noise and payloads, ``record="metrics"``,
on all threads. Prints the peak resident set size of this process (``ru_maxrss``) before
and after the batch, the run rate, and what ``record="full"`` would have kept.
"""

from __future__ import annotations

import argparse
import resource
import time

import numpy as np

import slidingarm as sa


def peak_mib() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=10_000)
    args = parser.parse_args()
    nb = args.runs
    arm = sa.PlanarArm.paper()
    rng = np.random.default_rng(0)
    plants = [sa.ModelMismatch(payload=float(p)).apply(arm) for p in rng.uniform(0, 0.5, nb)]
    ctrl = sa.FTSMC(arm, alpha=2, beta=2, p=5, q=3, k=20)
    q0 = np.asarray(sa.PAPER_Q0) + rng.normal(0, 0.02, (nb, 3))
    sensors = [sa.Sensor(noise=sa.GaussianNoise(float(s))) for s in rng.uniform(1e-5, 1e-4, nb)]
    kw = dict(t_final=sa.PAPER_T_FINAL, dt=sa.PAPER_DT)
    # warm up (compile) on a small batch
    sa.simulate_batch(arm, ctrl, sa.PaperReference(), q0=sa.PAPER_Q0, record="metrics", **kw)
    before = peak_mib()
    t0 = time.perf_counter()
    batch = sa.simulate_batch(
        plants, ctrl, sa.PaperReference(), q0=q0, sensor=sensors, seeds=list(range(nb)),
        record="metrics", throw=False, **kw,
    )  # fmt: skip
    wall = time.perf_counter() - t0
    after = peak_mib()
    full = 6 * nb * 9001 * 3 * 8 / 2**20
    print(f"runs: {nb}, ok: {int(batch.ok.sum())}, wall {wall:.1f} s, {nb / wall:.0f} runs/s")
    print(f"peak RSS before the batch: {before:.0f} MiB; after: {after:.0f} MiB")
    print(f"record='full' would keep {full:.0f} MiB of traces (plus inputs)")
    print(f"target: peak under 1024 MiB -> {'met' if after < 1024 else 'NOT met'}")


if __name__ == "__main__":
    main()
