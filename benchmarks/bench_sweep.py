"""Speed of a sweep against the batch engine alone (issue 10, point 4).

Run as ``python benchmarks/bench_sweep.py [--runs N] [--chunk C] [--threads T]``.

``N`` draws (default 10 000) of the paper's tanh scenario (3 joints, 4.5 s at 5e-4 s, 9001
samples, PDSMC, TSMC and FTSMC on each draw: ``3 N`` closed-loop runs) with a per-link mass
error, a payload, the reaching gain and an initial-state offset drawn per run:

1. **sweep** -- :func:`slidingarm.sweep` into a fresh folder: drawing, staging each draw's
   objects, the batches, the Parquet shards and the final table (the summary's bootstrap and
   the figures are post-processing and are timed apart, as ``summary``);
2. **batch** -- the same ``3 N`` runs (the very objects the sweep staged, built beforehand and
   not timed) through :func:`slidingarm.simulate_batch` directly, in one call,
   ``record="metrics"``.

It prints both times, arm-steps per second (runs × 9000 RK4 intervals / time) and the
overhead ``sweep / batch - 1`` (target <= 10 %), and checks that both give the same metrics.
A warm-up sweep of one chunk loads the compiled kernels first.
"""

from __future__ import annotations

import argparse
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np

import slidingarm
from slidingarm.study import load_shipped
from slidingarm.sweep.run import definition_of
from slidingarm.sweep.staging import Stager, draw_run, key_shapes, run_seed

VARY = {
    "mismatch.mass_error": {"normal": [0.0, 0.1]},
    "mismatch.payload": {"uniform": [0.0, 0.5]},
    "gains.k": {"uniform": [15.0, 30.0]},
    "simulation.q0": {"normal": [0.0, 0.05], "offset": True},
}


def staged(scenario, definition):  # type: ignore[no-untyped-def]
    """The per-run inputs of every run of the sweep, in the sweep's order."""
    stager = Stager(scenario)
    dists = definition.distributions
    shapes = key_shapes(scenario, dists)
    bases = stager.bases(dists)
    cols: dict[str, list] = {k: [] for k in ("plant", "ctrl", "sensor", "dist", "q0", "seed")}
    for i in range(definition.runs):
        setup = stager.build(draw_run(definition.seed, i, dists, shapes, bases))
        seed = run_seed(definition.seed, i)
        for c in setup.controllers.values():
            cols["plant"].append(setup.plant)
            cols["ctrl"].append(c)
            cols["sensor"].append(setup.sensor)
            cols["dist"].append(setup.disturbances)
            cols["q0"].append(setup.q0)
            cols["seed"].append(seed)
    return stager.setup, cols


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=10_000, help="draws (default 10000)")
    ap.add_argument("--chunk", type=int, default=None, help="draws per chunk (default 64)")
    ap.add_argument("--threads", type=int, default=2, help="chunks in flight (default 2)")
    args = ap.parse_args()
    d = load_shipped("tanh").to_dict()
    d["mismatch"]["mass_error"] = [0.0, 0.0, 0.0]
    scenario = slidingarm.config.scenario_from_dict(d)
    tmp = Path(tempfile.mkdtemp(prefix="bench-sweep-"))
    try:
        slidingarm.sweep(scenario, runs=4, out=tmp / "warm", vary=VARY, figures=False)
        t0 = time.perf_counter()
        marks: list[float] = []
        result = slidingarm.sweep(
            scenario,
            runs=args.runs,
            out=tmp / "sweep",
            vary=VARY,
            chunk=args.chunk,
            threads=args.threads,
            figures=False,
            progress=lambda done, total: (
                marks.append(time.perf_counter()) if done == total else None
            ),
        )
        total = time.perf_counter() - t0
        sweep_s = marks[-1] - t0  # up to the last shard
        definition = definition_of(scenario, runs=args.runs, vary=VARY, chunk=args.chunk)
        t1 = time.perf_counter()
        base, cols = staged(scenario, definition)
        stage_s = time.perf_counter() - t1
        t2 = time.perf_counter()
        batch = slidingarm.simulate_batch(
            cols["plant"],
            cols["ctrl"],
            base.reference,
            q0=np.asarray(cols["q0"]),
            t_final=base.t_final,
            dt=base.dt,
            sensor=cols["sensor"],
            disturbances=cols["dist"],
            seeds=cols["seed"],
            record="metrics",
            throw=False,
        )
        batch_s = time.perf_counter() - t2
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    mean = result.table[result.table["joint"] == "mean"]
    ours = mean["mse"].to_numpy()
    theirs = batch.metrics()
    theirs = theirs[theirs["joint"] == "mean"]["mse"].to_numpy()
    same = np.array_equal(ours, theirs, equal_nan=True)
    runs = 3 * args.runs
    steps = runs * round(base.t_final / base.dt)
    print(
        f"{args.runs} draws × 3 controllers = {runs} runs of {round(base.t_final / base.dt)} steps"
    )
    print(
        f"sweep (draw, stage, simulate, write shards)  {sweep_s:8.2f} s  {steps / sweep_s:12.4g} arm-steps/s"
    )
    print(f"  + final table, summary (bootstrap)         {total - sweep_s:8.2f} s")
    print(
        f"batch (simulate_batch alone, one call)       {batch_s:8.2f} s  {steps / batch_s:12.4g} arm-steps/s"
    )
    print(f"staging the same runs alone (untimed above)  {stage_s:8.2f} s")
    print(
        f"overhead sweep / batch - 1                   {sweep_s / batch_s - 1:8.1%}  (target <= 10 %)"
    )
    print(f"same metrics as the batch: {same}; failed runs: {result.failed}")


if __name__ == "__main__":
    main()
