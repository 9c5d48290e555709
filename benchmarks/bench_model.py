"""Cost of one ``M(q)`` + ``h(q, q̇)`` evaluation of the paper's arm, three ways.

Run as ``python benchmarks/bench_model.py [--repeats R] [--n N]``. Prints the median (and the
spread between the 10th and 90th percentiles) of microseconds per state:

1. one state through the Python wrapper: ``arm.mass_matrix(q)`` then ``arm.bias(q, qd)``;
2. a batch of 1000 states through the wrapper, divided by 1000;
3. the raw compiled kernels called in a jitted loop over 1000 states, both as
   ``mass_matrix_into`` + ``bias_into`` and as the fused ``mass_and_bias_into``.

Every timing is repeated ``R`` times after a warm-up (compilation excluded) and the median is
reported, because the machine is shared and noisy.
"""

from __future__ import annotations

import argparse
import platform
import time
from collections.abc import Callable

import numba
import numpy as np
from numba import njit

from slidingarm import PlanarArm
from slidingarm.models import _kernels as K

BATCH = 1000


@njit(cache=False)  # a cached caller would not see edits to the kernels it inlines
def _kernels_separate(
    arm: np.ndarray, g: float, q: np.ndarray, qd: np.ndarray, mm: np.ndarray, h: np.ndarray
) -> None:  # pragma: no cover
    work = np.empty((K.WORK_ROWS, q.shape[1]))
    for b in range(q.shape[0]):
        K.mass_matrix_into(arm, q[b], mm[b], work)
        K.bias_into(arm, g, q[b], qd[b], h[b], work)


@njit(cache=False)  # a cached caller would not see edits to the kernels it inlines
def _kernels_fused(
    arm: np.ndarray, g: float, q: np.ndarray, qd: np.ndarray, mm: np.ndarray, h: np.ndarray
) -> None:  # pragma: no cover
    work = np.empty((K.WORK_ROWS, q.shape[1]))
    for b in range(q.shape[0]):
        K.mass_and_bias_into(arm, g, q[b], qd[b], mm[b], h[b], work)


def _time(fn: Callable[[], object], per_call: int, repeats: int, inner: int) -> np.ndarray:
    """Microseconds per state of ``fn`` (which handles ``per_call`` states), ``repeats`` times."""
    fn()  # warm up: compile, fill caches
    out = np.empty(repeats)
    for r in range(repeats):
        t0 = time.perf_counter()
        for _ in range(inner):
            fn()
        out[r] = (time.perf_counter() - t0) / (inner * per_call) * 1e6
    return out


def _report(label: str, samples: np.ndarray) -> None:
    p10, p50, p90 = np.percentile(samples, [10, 50, 90])
    print(f"  {label:<44s} {p50:9.3f} µs/state   (p10 {p10:.3f}, p90 {p90:.3f})")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=31, help="timed repetitions (median)")
    parser.add_argument("--n", type=int, default=3, help="joints (3: the paper's arm)")
    args = parser.parse_args()

    arm = PlanarArm.paper() if args.n == 3 else PlanarArm(np.ones(args.n), np.ones(args.n))
    rng = np.random.default_rng(0)
    q = rng.uniform(-np.pi, np.pi, (BATCH, arm.n))
    qd = rng.uniform(-3.0, 3.0, (BATCH, arm.n))
    packed, g = arm.packed, arm.gravity
    mm = np.empty((BATCH, arm.n, arm.n))
    h = np.empty((BATCH, arm.n))
    q1, qd1 = q[0], qd[0]

    def single() -> None:
        arm.mass_matrix(q1)
        arm.bias(q1, qd1)

    def batch() -> None:
        arm.mass_matrix(q)
        arm.bias(q, qd)

    def separate() -> None:
        _kernels_separate(packed, g, q, qd, mm, h)

    def fused() -> None:
        _kernels_fused(packed, g, q, qd, mm, h)

    # the three ways agree
    _kernels_fused(packed, g, q, qd, mm, h)
    np.testing.assert_allclose(mm, arm.mass_matrix(q), rtol=1e-14, atol=1e-14)
    np.testing.assert_allclose(h, arm.bias(q, qd), rtol=1e-14, atol=1e-13)

    print(
        f"M(q) + h(q, qd), n = {arm.n}; median of {args.repeats} repeats "
        f"(python {platform.python_version()}, numpy {np.__version__}, numba {numba.__version__})"
    )
    _report("wrapper, one state", _time(single, 1, args.repeats, inner=2000))
    _report(f"wrapper, batch of {BATCH} (per state)", _time(batch, BATCH, args.repeats, inner=20))
    _report("compiled kernels in a jitted loop", _time(separate, BATCH, args.repeats, inner=20))
    _report("compiled fused kernel in a jitted loop", _time(fused, BATCH, args.repeats, inner=20))


if __name__ == "__main__":
    main()
