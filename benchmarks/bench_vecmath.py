"""Cost per element of the vectorisable elementary functions (slidingarm._vecmath) against
the libm calls they replace, each in the same compiled loop.

Run as ``python benchmarks/bench_vecmath.py [--n N] [--repeats R] [--clock wall|cpu]``.
For each function a loop ``for i in range(n): out[i] = f(x[i])`` over ``n = 10**6`` values
(the range the closed loop meets) is compiled twice, with ours and with ``math.sin`` etc.
(``abs(x) ** g`` for ``pow_abs``), both ``error_model="numpy"`` and
``fastmath={"contract"}`` as the block path uses them. Ours inlines and vectorises (LLVM
picks ``<4 x double>`` on this CPU), the libm loop calls a scalar function per element.
Prints the median ns per element over the repeats (10th-90th percentile spread) and the
ratio libm / ours of the medians; the two loops of a function are timed in turns so that a
change of the machine's load shows in both. ``--clock cpu`` reads the thread's CPU time
(``time.thread_time``) instead of the wall clock.
"""

from __future__ import annotations

import argparse
import math
import os
import time
from collections.abc import Callable
from typing import Any

import numba
import numpy as np
from numba import njit

import _host
from slidingarm import _vecmath as vm

_FLAGS: dict[str, Any] = {"error_model": "numpy", "fastmath": {"contract"}}
G = 5.0 / 7.0  # a terminal-surface exponent


def _unary(f: Callable[..., Any]) -> Any:
    @njit(**_FLAGS)
    def loop(x: np.ndarray, out: np.ndarray) -> None:
        for i in range(x.shape[0]):
            out[i] = f(x[i])

    return loop


@njit(**_FLAGS)
def _ours_sincos(x: np.ndarray, out: np.ndarray) -> None:
    for i in range(x.shape[0]):
        s, c = vm.sincos(x[i])
        out[i] = s + c


@njit(**_FLAGS)
def _libm_sincos(x: np.ndarray, out: np.ndarray) -> None:
    for i in range(x.shape[0]):
        out[i] = math.sin(x[i]) + math.cos(x[i])


@njit(**_FLAGS)
def _ours_pow(x: np.ndarray, out: np.ndarray) -> None:
    for i in range(x.shape[0]):
        out[i] = vm.pow_abs(x[i], G)


@njit(**_FLAGS)
def _libm_pow(x: np.ndarray, out: np.ndarray) -> None:
    for i in range(x.shape[0]):
        out[i] = abs(x[i]) ** G


def _cases(rng: np.random.Generator, n: int) -> list[tuple[str, np.ndarray, Any, Any]]:
    angles = rng.uniform(-1e3, 1e3, n)
    return [
        ("sin", angles, _unary(vm.sin), _unary(math.sin)),
        ("cos", angles, _unary(vm.cos), _unary(math.cos)),
        ("sincos (s + c)", angles, _ours_sincos, _libm_sincos),
        ("exp", rng.uniform(-700.0, 700.0, n), _unary(vm.exp), _unary(math.exp)),
        ("log", np.exp(rng.uniform(-690.0, 690.0, n)), _unary(vm.log), _unary(math.log)),
        ("tanh", rng.uniform(-20.0, 20.0, n), _unary(vm.tanh), _unary(math.tanh)),
        (f"pow_abs (g = {G:.4f})", np.exp(rng.uniform(-690.0, 6.9, n)), _ours_pow, _libm_pow),
    ]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=10**6, help="values per loop (default 10**6)")
    ap.add_argument("--repeats", type=int, default=21, help="timed repeats (default 21)")
    ap.add_argument("--clock", choices=["wall", "cpu"], default="wall")
    args = ap.parse_args()
    if args.n < 1 or args.repeats < 1:
        ap.error("--n and --repeats must be at least 1")
    clock = time.thread_time if args.clock == "cpu" else time.perf_counter

    print(f"# {_host.describe()}")
    print(
        f"# numba {numba.__version__}, "
        f"n = {args.n}, {args.repeats} repeats, {args.clock} clock, "
        f"load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} CPUs"
    )
    print(f"{'function':<22}{'ours ns/elem':>24}{'libm ns/elem':>24}{'libm/ours':>11}")
    rng = np.random.default_rng(12)
    for name, x, ours, libm in _cases(rng, args.n):
        out = np.empty_like(x)
        ours(x[:8], out[:8])  # compile
        libm(x[:8], out[:8])
        times: dict[str, list[float]] = {"ours": [], "libm": []}
        for _ in range(args.repeats):
            for key, fn in (("ours", ours), ("libm", libm)):
                t0 = clock()
                fn(x, out)
                times[key].append((clock() - t0) / x.size * 1e9)
        cols = []
        for key in ("ours", "libm"):
            a = np.array(times[key])
            cols.append(
                f"{np.median(a):7.2f} [{np.percentile(a, 10):5.2f}, {np.percentile(a, 90):5.2f}]"
            )
        ratio = np.median(times["libm"]) / np.median(times["ours"])
        print(f"{name:<22}{cols[0]:>24}{cols[1]:>24}{ratio:>10.1f}x")


if __name__ == "__main__":
    main()
