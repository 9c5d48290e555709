"""Speed of a sweep against the batch engine alone (issue 10, point 4).

Run as ``python benchmarks/bench_sweep.py [--runs N] [--turns K] [--chunk C] [--threads T]
[--clock wall|cpu] [--no-split]``.

``N`` draws (default 10 000) of the paper's tanh scenario (3 joints, 4.5 s at 5e-4 s, 9001
samples, PDSMC, TSMC and FTSMC on each draw: ``3 N`` closed-loop runs) with a per-link mass
error, a payload, the reaching gain and an initial-state offset drawn per run:

1. **sweep** -- :func:`slidingarm.sweep` into a fresh folder: drawing, staging each draw's
   objects, the batches, the Parquet shards and the final table (the summary's bootstrap and
   the figures are post-processing and are timed apart, as ``summary``);
2. **batch** -- the same ``3 N`` runs (the very objects the sweep staged, built beforehand and
   not timed) through :func:`slidingarm.simulate_batch` directly, in one call,
   ``record="metrics"``;
3. **split** (unless ``--no-split``) -- the sweep's pieces one after the other, chunk by
   chunk, each timed on its own: ``drawing`` (:func:`~slidingarm.sweep.run.draw_chunk`),
   ``staging`` (:func:`~slidingarm.sweep.run.stage_chunk`), ``batch``
   (:func:`~slidingarm.sweep.run.simulate_chunk`, one ``simulate_batch`` per chunk),
   ``table`` (:func:`~slidingarm.sweep.run.chunk_table`), ``writing`` (the shard),
   ``final table`` (the shards read back, concatenated and written) and ``summary`` (the
   bootstrap and ``summary.csv``), in ms per draw and as a share of the one-call batch.

It prints both times, arm-steps per second (runs × 9000 RK4 intervals / time) and the
overhead ``sweep / batch - 1`` (target <= 10 %), checks that both give the same metrics, and
the sweep's own work (every piece but the batch) in ms per draw. On a shared machine whose
load drifts, ``--turns K`` repeats the pair K times (new draws each turn, the order of the two
alternating) and prints the median overhead; ``--clock cpu`` times everything with this
process's CPU time over all its threads (and prints the wall-clock overhead of the same turns
beside it), which measures the sweep's own work beside the engine's even when a neighbour's
load swings the wall time by 2x. A warm-up sweep of one full chunk loads the compiled kernels
first (the block path's among them: a smaller warm-up left its loading, or its compilation on
a cold cache, inside the first turn's sweep).
"""

from __future__ import annotations

import argparse
import shutil
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

import slidingarm
from slidingarm.study import load_shipped
from slidingarm.sweep.run import (
    DEFAULT_CHUNK,
    SUMMARY,
    _prepare,
    _shard_path,
    chunk_table,
    definition_of,
    draw_chunk,
    final_table,
    simulate_chunk,
    stage_chunk,
    write_shard,
)
from slidingarm.sweep.summary import summarize

VARY = {
    "mismatch.mass_error": {"normal": [0.0, 0.1]},
    "mismatch.payload": {"uniform": [0.0, 0.5]},
    "gains.k": {"uniform": [15.0, 30.0]},
    "simulation.q0": {"normal": [0.0, 0.05], "offset": True},
}


def staged(definition):  # type: ignore[no-untyped-def]
    """The per-run inputs of every run of the sweep, in the sweep's order (the objects the
    sweep's own staging builds)."""
    cols: dict[str, list] = {k: [] for k in ("plant", "ctrl", "sensor", "dist", "q0", "seed")}
    for c in range(definition.n_chunks):
        chunk = stage_chunk(definition, draw_chunk(definition, c))
        cols["plant"] += chunk.plants
        cols["ctrl"] += chunk.controllers
        cols["sensor"] += chunk.sensors
        cols["dist"] += chunk.disturbances
        cols["q0"] += chunk.q0
        cols["seed"] += chunk.seeds
    return definition.build_scenario().build(), cols


PIECES = ("drawing", "staging", "batch", "table", "writing", "final table", "summary")


def split(definition, out: Path) -> dict[str, float]:  # type: ignore[no-untyped-def]
    """The sweep's pieces one after the other (one chunk at a time), each timed on its own."""
    clock = CLOCK[0]
    t = dict.fromkeys(PIECES, 0.0)
    _prepare(out, definition)
    tables = {}
    for c in range(definition.n_chunks):
        t0 = clock()
        draws = draw_chunk(definition, c)
        t1 = clock()
        chunk = stage_chunk(definition, draws)
        t2 = clock()
        result = simulate_chunk(definition, chunk)
        t3 = clock()
        table = chunk_table(definition, chunk, result)
        t4 = clock()
        write_shard(_shard_path(out, c), table)
        tables[c] = table
        t5 = clock()
        for name, dt in zip(PIECES, (t1 - t0, t2 - t1, t3 - t2, t4 - t3, t5 - t4), strict=False):
            t[name] += dt
    t0 = clock()
    table = final_table(out, definition, tables)
    t1 = clock()
    summary = summarize(table, seed=definition.seed)
    (out / SUMMARY).write_text(summary.to_csv(index=False), encoding="utf-8")
    t2 = clock()
    t["final table"] += t1 - t0
    t["summary"] += t2 - t1
    return t


#: The clock of every timing: wall time (default) or ``--clock cpu``, this process's CPU time
#: over all its threads (numba's and the sweep's), which a neighbour's load barely moves.
CLOCK: list[Callable[[], float]] = [time.perf_counter]


def one_turn(scenario, args, tmp: Path, turn: int) -> dict[str, float]:  # type: ignore[no-untyped-def]
    """One sweep and the same runs through simulate_batch, in an order that alternates with
    the turn (so that a drifting machine load favours neither)."""
    out = tmp / f"sweep-{turn}"
    definition = definition_of(scenario, runs=args.runs, vary=VARY, seed=turn, chunk=args.chunk)
    base, cols = staged(definition)
    times: dict[str, float] = {}

    def run_sweep() -> None:
        t0, w0 = CLOCK[0](), time.perf_counter()
        marks: list[tuple[float, float]] = []
        result = slidingarm.sweep(
            scenario,
            runs=args.runs,
            out=out,
            vary=VARY,
            seed=turn,
            chunk=args.chunk,
            threads=args.threads,
            figures=False,
            progress=lambda done, total: (
                marks.append((CLOCK[0](), time.perf_counter())) if done == total else None
            ),
        )
        times["total"] = CLOCK[0]() - t0
        times["sweep"] = marks[-1][0] - t0  # up to the last shard
        times["sweep wall"] = marks[-1][1] - w0
        mean = result.table[result.table["joint"] == "mean"]
        times["_mse_sweep"] = mean["mse"].to_numpy()  # type: ignore[assignment]
        times["failed"] = result.failed

    def run_batch() -> None:
        t0, w0 = CLOCK[0](), time.perf_counter()
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
        times["batch"] = CLOCK[0]() - t0
        times["batch wall"] = time.perf_counter() - w0
        m = batch.metrics()
        times["_mse_batch"] = m[m["joint"] == "mean"]["mse"].to_numpy()  # type: ignore[assignment]

    for step in (run_sweep, run_batch) if turn % 2 == 0 else (run_batch, run_sweep):
        step()
    shutil.rmtree(out, ignore_errors=True)
    if args.split:
        for name, v in split(definition, out).items():
            times[f"split {name}"] = v
        shutil.rmtree(out, ignore_errors=True)
    times["same"] = float(
        np.array_equal(times.pop("_mse_sweep"), times.pop("_mse_batch"), equal_nan=True)  # type: ignore[call-overload]
    )
    times["steps"] = 3 * args.runs * round(base.t_final / base.dt)
    return times


def print_split(t: dict[str, float], runs: int) -> None:
    """The pieces in ms per draw and as a share of the one-call batch."""
    unit = "CPU-ms" if CLOCK[0] is time.process_time else "ms"
    batch = t["batch"]
    cells = [
        f"{name} {1e3 * t[f'split {name}'] / runs:.3f} ({t[f'split {name}'] / batch:.2%})"
        for name in PIECES
    ]
    own = sum(t[f"split {name}"] for name in PIECES if name != "batch")
    print(f"  split, {unit} per draw (share of the batch): " + ", ".join(cells), flush=True)
    print(
        f"  the sweep's own work (all but the batch): {1e3 * own / runs:.3f} {unit} per draw, "
        f"{own / batch:.2%} of the one-call batch ({1e3 * batch / runs:.2f} {unit} per draw); "
        f"the chunked batch {t['split batch'] / batch - 1:+.1%} against the one-call batch",
        flush=True,
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=10_000, help="draws per turn (default 10000)")
    ap.add_argument("--turns", type=int, default=1, help="turns of sweep and batch (default 1)")
    ap.add_argument(
        "--first-turn", type=int, default=0, help="number of the first turn (odd: batch first)"
    )
    ap.add_argument("--chunk", type=int, default=None, help="draws per chunk (default 64)")
    ap.add_argument("--threads", type=int, default=2, help="sweep threads: 1 in turn, T runs T chunks side by side, each batch on one thread (default 2)")
    ap.add_argument(
        "--split", action=argparse.BooleanOptionalAction, default=True,
        help="time the sweep's pieces one by one too (default: yes)",
    )  # fmt: skip
    ap.add_argument(
        "--clock", choices=("wall", "cpu"), default="wall",
        help="wall time, or this process's CPU time (steadier on a shared machine)",
    )  # fmt: skip
    args = ap.parse_args()
    CLOCK[0] = time.process_time if args.clock == "cpu" else time.perf_counter
    d = load_shipped("tanh").to_dict()
    d["mismatch"]["mass_error"] = [0.0, 0.0, 0.0]
    scenario = slidingarm.config.scenario_from_dict(d)
    tmp = Path(tempfile.mkdtemp(prefix="bench-sweep-"))
    try:
        # one full chunk, so that its batch takes the block path and loads that kernel too
        slidingarm.sweep(
            scenario, runs=args.chunk or DEFAULT_CHUNK, out=tmp / "warm", vary=VARY, chunk=args.chunk,
            threads=args.threads, figures=False,
        )  # fmt: skip
        turns = []
        for turn in range(args.first_turn, args.first_turn + args.turns):
            t = one_turn(scenario, args, tmp, turn)
            turns.append(t)
            print(
                f"turn {turn}: {args.runs} draws × 3 controllers; sweep {t['sweep']:.2f} s "
                f"({t['steps'] / t['sweep']:.4g} arm-steps/s; + final table and summary "
                f"{t['total'] - t['sweep']:.2f} s), batch {t['batch']:.2f} s "
                f"({t['steps'] / t['batch']:.4g} arm-steps/s), overhead "
                f"{t['sweep'] / t['batch'] - 1:+.1%} "
                f"({1e3 * (t['sweep'] - t['batch']) / args.runs:+.3f} ms per draw)"
                + (
                    f"; wall clock: sweep {t['sweep wall']:.2f} s, batch {t['batch wall']:.2f} s, "
                    f"overhead {t['sweep wall'] / t['batch wall'] - 1:+.1%}"
                    if CLOCK[0] is not time.perf_counter
                    else ""
                )
                + ", same "
                f"metrics {bool(t['same'])}, failed runs {int(t['failed'])}",
                flush=True,
            )
            if args.split:
                print_split(t, args.runs)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    ratios = sorted(t["sweep"] / t["batch"] for t in turns)
    median = (
        ratios[len(ratios) // 2]
        if len(ratios) % 2
        else 0.5 * (ratios[len(ratios) // 2 - 1] + ratios[len(ratios) // 2])
    )
    print(
        f"overhead sweep / batch - 1, median of {len(turns)} turn(s): {median - 1:+.1%} "
        "(target <= 10 %)"
    )
    if CLOCK[0] is not time.perf_counter:
        walls = [t["sweep wall"] / t["batch wall"] for t in turns]
        print(f"  on the wall clock, median of the same turns: {float(np.median(walls)) - 1:+.1%}")


if __name__ == "__main__":
    main()
