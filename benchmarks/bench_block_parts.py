"""Where a block step's time goes: cycles of each phase of :func:`slidingarm._block.run_block`.

Run as ``python benchmarks/bench_block_parts.py [--runs B] [--repeats R] [--law model|paper]``.

The benchmark takes the source of ``run_block`` and inserts, at the start of each phase of its
time loop, a read of the processor's time-stamp counter (LLVM's ``readcyclecounter``, an
``rdtsc`` on x86), then compiles that copy with the SLP vectoriser on and, where the kernel
is so compiled, its lane loops interleaved (``_block._interleaved``, the RK4 step compiled
before at LLVM's own choice), as :func:`slidingarm._block.compiled` compiles the kernel
itself. It runs ``simulate_batch`` on
the paper's arm (FTSMC with sign switching, ``record="metrics"``, 4.5 s at 5e-4 s, one thread)
through the copy and prints, per phase, the counter ticks per block step (``W`` runs advanced
one sample), their share, and the wall time per arm-step of the whole batch (the Python part
included: the staging of each block, ``finish_metrics`` and its FFT). The phases:

* ``measure``: the measurement and the velocity estimate (``_measure``);
* ``law``: the sliding-mode law and its torque (``_law``);
* ``clip``: torque limits, the held input and the non-finite check (``_clip``);
* ``record``: the traces of a recorded sample (none in metrics mode);
* ``metrics``: the streamed metrics and the torque trace of the spectral metric;
* ``status``: failed lanes, before and after the plant;
* ``rk4``: the plant's RK4 step(s) (``_rk4``);
* ``check``: the state check (``_check``).

The counter ticks at a constant rate (``constant_tsc``), not at the core's clock: the
ticks are a time, comparable between phases of one run. The reads themselves cost a few
ticks each and keep LLVM from moving work across phases; the per-phase figures add up to a
little more than the kernel alone. If the kernel's source changes so that a phase's marker
line is not found, the benchmark stops and names it.
"""

from __future__ import annotations

import argparse
import contextlib
import inspect
import textwrap
import time
from typing import Any

import numpy as np
from numba import njit, types
from numba.extending import intrinsic

import slidingarm as sa
from slidingarm import _block as BK
from slidingarm.references import PAPER_Q0

#: The phases, each opened by the first line of the time loop that starts with its marker.
PHASES = (
    ("measure", "        exact = _measure("),
    ("law", "        _law(ws, joints, k,"),
    ("clip", "        _clip(ws, n)"),
    ("record", "        if stride > 0 and k % stride == 0:"),
    ("metrics", "        if metrics:"),
    ("status", "        nalive = W"),
    ("rk4", "        for sub in range(substeps):"),
    ("check", "        _check(ws, n, qd_limit)"),
)


@intrinsic
def _ticks(typingctx: Any) -> Any:
    """The time-stamp counter (``llvm.readcyclecounter``)."""

    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        import llvmlite.ir as ir

        fnty = ir.FunctionType(ir.IntType(64), [])
        fn = builder.module.declare_intrinsic("llvm.readcyclecounter", fnty=fnty)
        return builder.call(fn, [])

    return types.int64(), codegen


def instrumented_kernel() -> Any:
    """``run_block`` with a tick read at each phase's start, accumulating into a last
    argument ``ticks`` (int64, one slot per phase); compiled lazily by numba."""
    src = inspect.getsource(BK.run_block.py_func)
    src = src.replace("@njit(**_OPT)\n", "", 1)
    head = "    joints: tuple[int, ...],\n) -> None:"
    if head not in src:
        raise SystemExit("bench_block_parts: run_block's signature changed (no 'joints' last)")
    src = src.replace(head, "    joints: tuple[int, ...],\n    ticks: np.ndarray,\n) -> None:")
    loop = "    for k in range(nt):\n"
    if loop not in src:
        raise SystemExit("bench_block_parts: run_block has no 'for k in range(nt)' loop")
    src = src.replace(loop, "    _t0 = _ticks()\n    _ph = 0\n" + loop, 1)
    lines = src.splitlines()
    body = lines.index(loop.rstrip("\n"))
    out = lines[: body + 1]
    found = {name: False for name, _ in PHASES}
    for line in lines[body + 1 :]:
        for i, (name, marker) in enumerate(PHASES):
            if line.startswith(marker):
                out.append(
                    f"        _t1 = _ticks(); ticks[_ph] += _t1 - _t0; _t0 = _t1; _ph = {i}"
                )
                found[name] = True
                break
        out.append(line)
    missing = [name for name, ok in found.items() if not ok]
    if missing:
        raise SystemExit(f"bench_block_parts: no marker line found for phases {missing}")
    namespace = dict(vars(BK))
    namespace["_ticks"] = _ticks
    exec(textwrap.dedent("\n".join(out)), namespace)
    return njit(nogil=True, error_model="numpy")(namespace["run_block"])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=256, help="runs of the batch (default 256)")
    parser.add_argument("--repeats", type=int, default=3, help="batches timed (median)")
    parser.add_argument("--law", choices=("model", "paper"), default="model")
    args = parser.parse_args()

    arm = sa.PlanarArm.paper()
    ctrl = sa.FTSMC(arm, alpha=2, beta=2, p=5, q=3, k=20, law=args.law)
    ref = sa.PaperReference()
    q0 = np.asarray(PAPER_Q0) + np.random.default_rng(0).normal(0.0, 0.01, (args.runs, 3))
    kernel = instrumented_kernel()
    ticks = np.zeros(len(PHASES), dtype=np.int64)

    def patched(*a: Any) -> None:
        # compiled as BK.compiled compiles the kernel: the SLP vectoriser on, the lane loops
        # interleaved where the kernel is (the RK4 step compiled before, by BK.compiled, at
        # LLVM's own choice)
        lanes = BK._interleaved() if BK._interleave_lanes() else contextlib.nullcontext()
        with BK._slp_vectorised(), lanes:
            kernel(*a, ticks)

    BK.compiled(paper=args.law == "paper", n=3)  # the real kernel's callees, from the cache
    saved = BK.run_block
    BK.run_block = patched
    try:
        kw = dict(t_final=4.5, dt=5e-4, record="metrics", threads=1)
        sa.simulate_batch(arm, ctrl, ref, q0=q0[:16], block=True, **kw)  # compile the copy
        walls, parts = [], []
        for _ in range(args.repeats):
            ticks[:] = 0
            t0 = time.perf_counter()
            sa.simulate_batch(arm, ctrl, ref, q0=q0, block=True, **kw)
            walls.append(time.perf_counter() - t0)
            parts.append(ticks.copy())
    finally:
        BK.run_block = saved
    steps = -(-args.runs // BK.W) * 9000
    per = np.median(np.stack(parts), axis=0) / steps
    print(
        f"paper arm, FTSMC sign, law={args.law}, {args.runs} runs, metrics, 1 thread; "
        f"median of {args.repeats}"
    )
    print(f"wall: {np.median(walls) / (args.runs * 9000) * 1e9:.0f} ns per arm-step (all of it)")
    print(f"ticks per block step ({BK.W} runs, one sample) by phase:")
    for (name, _), v in zip(PHASES, per, strict=True):
        print(f"  {name:8s} {v:8.0f}  {100 * v / per.sum():5.1f} %")
    print(f"  {'total':8s} {per.sum():8.0f}")


if __name__ == "__main__":
    main()
