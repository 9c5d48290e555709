"""Cost of one validated controller call from Python (issue 12, point 5: at most 5 µs at the
99th percentile).

Run as ``python benchmarks/bench_evaluate.py [--calls N]``. For the paper's FTSMC (3 joints),
each of ``N`` calls (default 100 000, after a warm-up) is timed alone with
:func:`time.perf_counter_ns`, and the median and 99th percentile are printed for:

1. ``controller.evaluate(q, qd, q_ref, qd_ref, qdd_ref)``: the validated call, on float64
   C-contiguous arrays (its fast path: O(1) checks in Python, shapes and finiteness inside
   the compiled call);
2. ``controller(q, qd, q_ref, qd_ref, qdd_ref)``: the unchecked call;
3. the compiled call alone (``_dispatch.control_once`` on preallocated outputs);
4. ``evaluate`` on lists (the general path: conversion and checks in numpy), for scale.

The four take turns in blocks of 1 000 calls, so that a change of the machine's load shows in
all of them; the load (``os.getloadavg``) is printed with the table.
"""

from __future__ import annotations

import argparse
import os
import time
from collections.abc import Callable

import numpy as np

import slidingarm as sa
from slidingarm.control import _dispatch as LD
from slidingarm.references import PAPER_Q0

BLOCK = 1_000


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--calls", type=int, default=100_000, help="timed calls of each kind")
    args = parser.parse_args()
    calls = max(BLOCK, args.calls - args.calls % BLOCK)

    arm = sa.PlanarArm.paper()
    ctrl = sa.FTSMC(arm, alpha=2.0, beta=2.0, p=5, q=3, k=20.0)
    ref = sa.PaperReference()
    q_ref, qd_ref, qdd_ref = (np.ascontiguousarray(a[0]) for a in ref.evaluate(np.array([0.1])))
    q = np.array(PAPER_Q0, dtype=float)
    qd = np.zeros(arm.n)
    tau, s = np.empty(arm.n), np.empty(arm.n)
    state = np.zeros(arm.n)
    lists = [a.tolist() for a in (q, qd, q_ref, qd_ref, qdd_ref)]
    p, mkind, mparams, g, scratch = ctrl._p, ctrl._mkind, ctrl._mparams, ctrl._g, ctrl._scratch

    kinds: dict[str, Callable[[], object]] = {
        "evaluate (float64 arrays)": lambda: ctrl.evaluate(q, qd, q_ref, qd_ref, qdd_ref),
        "controller(...) unchecked": lambda: ctrl(q, qd, q_ref, qd_ref, qdd_ref),
        "compiled call alone": lambda: LD.control_once(
            p, mkind, mparams, g, q, qd, q_ref, qd_ref, qdd_ref, state, 0.0, tau, s, scratch
        ),
        "evaluate (lists)": lambda: ctrl.evaluate(*lists),
    }
    np.testing.assert_array_equal(
        ctrl.evaluate(q, qd, q_ref, qd_ref, qdd_ref)[0], ctrl(q, qd, q_ref, qd_ref, qdd_ref)
    )
    np.testing.assert_array_equal(ctrl.evaluate(*lists)[0], ctrl(q, qd, q_ref, qd_ref, qdd_ref))
    for fn in kinds.values():  # warm-up (compilation, caches)
        for _ in range(2_000):
            fn()
    clock = time.perf_counter_ns
    ns = {name: np.empty(calls) for name in kinds}
    load0 = os.getloadavg()[0]
    for start in range(0, calls, BLOCK):
        for name, fn in kinds.items():
            out = ns[name]
            for i in range(start, start + BLOCK):
                t0 = clock()
                fn()
                out[i] = clock() - t0
    load1 = os.getloadavg()[0]
    print(f"{calls} calls of each, in turns of {BLOCK}; load average {load0:.2f} -> {load1:.2f}")
    print(f"{'':28s} {'median':>9s} {'p99':>9s}")
    for name, t in ns.items():
        print(f"{name:28s} {np.percentile(t, 50) / 1e3:7.2f}µs {np.percentile(t, 99) / 1e3:7.2f}µs")
    p99 = float(np.percentile(ns["evaluate (float64 arrays)"], 99)) / 1e3
    print(f"evaluate p99 {p99:.2f} µs: {'meets' if p99 <= 5.0 else 'misses'} the 5 µs target")


if __name__ == "__main__":
    main()
