"""Where a serial arm's block step goes: the time of each of the serial kind's lane kernels.

Run as ``python benchmarks/bench_block_serial.py [--robot ur5|panda] [--iters N] [--repeats R]``.

It loads ``W`` copies of the robot into a block workspace (one lane each, the joints at
different angles), then times, each compiled in a loop of its own with the SLP vectoriser on
(as :func:`slidingarm._block.compiled` compiles the kernel), the pieces of a block step of
:mod:`slidingarm._block`'s serial kind, in nanoseconds per block (``W`` runs, :data:`slidingarm._block.W`):

* ``rk4``: one RK4 step (:func:`~slidingarm._block._rk4_serial`): four forward dynamics;
* ``forward``: one forward dynamics (:func:`~slidingarm._block._serial_forward`), split into
  ``place`` (the bodies' placements from the stage angles), ``rnea`` (the bias by
  Newton-Euler), ``crba`` (the mass matrix) and ``solve`` (Cholesky);
* ``law``: the model law's torque (:func:`~slidingarm._block._serial_torque`: kinematics and
  Newton-Euler at the measurement);

and per arm-step (a block's time over ``W``). Each figure is the median of ``--repeats``
timings of ``--iters`` calls. The loop kernels are compiled here (``cache=False``): the first
run takes a minute or so.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable
from typing import Any

import numpy as np
from numba import njit
from numba.core import config

import slidingarm as sa
from slidingarm import _block as BK

_BODIES = {
    "rk4": "BK._rk4_serial(ws, joints, 1e-4)",
    "forward": "BK._serial_forward(ws, joints)",
    "place": "BK._serial_place(ws, n, BK._QT, BK._SP)",
    "rnea": "BK._serial_rnea(ws, n, BK._SP, BK._VT, BK._VT, False, BK._L_G, BK._PRHS)",
    "crba": "BK._serial_crba(ws, joints, BK._SP, (BK.J0 + n * BK.JS) & BK._NONNEG)",
    "solve": "BK._serial_solve(ws, joints)",
    "law": "BK._serial_torque(ws, n)",
}


def _loop(body: str) -> Callable[..., None]:
    """A compiled ``f(ws, joints, iters)`` that runs ``body`` ``iters`` times."""
    source = (
        "def f(ws, joints, iters):\n"
        "    n = len(joints)\n"
        "    for _ in range(iters):\n"
        f"        {body}\n"
    )
    scope: dict[str, Any] = {"BK": BK}
    exec(source, scope)  # our own source: one loop around a kernel call
    return njit(error_model="numpy")(scope["f"])  # type: ignore[no-any-return]


@njit(error_model="numpy")
def _load(ws, joints, table, g):  # type: ignore[no-untyped-def]  # pragma: no cover
    """The arm's table in every lane, each lane's joints at their own angles."""
    n = len(joints)
    tables = np.empty((table.shape[0], n, BK.W))
    for r in range(table.shape[0]):
        for j in range(n):
            for ln in range(BK.W):
                tables[r, j, ln] = table[r, j]
    BK._load_serial(ws, n, tables, tables)
    for ln in range(BK.W):
        ws[BK._L_G + ln] = g
        ws[BK._L_MG + ln] = g
        ws[BK._L_OK + ln] = 1.0
    for j in range(n):
        o = BK.J0 + j * BK.JS
        for ln in range(BK.W):
            q = 0.1 * (j + 1) + 0.05 * ln
            ws[o + BK._Q + ln] = q
            ws[o + BK._QT + ln] = q
            ws[o + BK._QM + ln] = q
            ws[o + BK._QD + ln] = 0.1
            ws[o + BK._VT + ln] = 0.1
            ws[o + BK._QDM + ln] = 0.1
    BK._serial_kinematics(ws, n, BK._QT, BK._SP)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robot", default="ur5", help="a shipped robot (default ur5)")
    parser.add_argument("--iters", type=int, default=20000, help="calls per timing")
    parser.add_argument("--repeats", type=int, default=7, help="timings per figure (median)")
    args = parser.parse_args()
    arm = sa.robots.load(args.robot)
    n = arm.n
    config.SLP_VECTORIZE = 1
    ws = np.zeros(BK.workspace_size(n))
    joints = (0,) * n
    _load(ws, joints, np.ascontiguousarray(arm.handle.params), arm.handle.g)
    print(f"{args.robot} ({n} joints), one block of {BK.W} lanes, median of {args.repeats} "
          f"timings of {args.iters} calls")  # fmt: skip
    print(f"{'piece':>8} {'ns/block':>9} {'ns/arm':>7}")
    for name, body in _BODIES.items():
        f = _loop(body)
        f(ws, joints, 10)  # compile
        times = []
        for _ in range(args.repeats):
            t0 = time.perf_counter()
            f(ws, joints, args.iters)
            times.append(time.perf_counter() - t0)
        per = float(np.median(times)) / args.iters * 1e9
        print(f"{name:>8} {per:9.0f} {per / BK.W:7.0f}", flush=True)


if __name__ == "__main__":
    main()
