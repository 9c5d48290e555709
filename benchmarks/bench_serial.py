"""Cost of one closed-loop step on the UR5: the compiled loop against the same loop stepping
Pinocchio from Python, and the dynamics kernels against Pinocchio's.

Run as ``python benchmarks/bench_serial.py [--repeats R] [--clock wall|cpu]``. Prints medians
(and the 10th-90th percentile spread) of microseconds, and the ratios measured in this one
run. ``--clock cpu`` times with the calling thread's CPU time (``time.thread_time``; every
timed piece runs in that thread) instead of the wall clock, so that time the thread spends
descheduled on a shared machine is not counted; the default is the wall clock:

1. **compiled step**: ``simulate`` on the UR5 (FTSMC, tanh, exact nominal model, quintic
   reference, full record) for 1 s and for 5 s at ``dt = 1 ms``; the difference over the
   4000 extra steps is the cost of one step — the law (``τ`` by Newton-Euler at the
   commanded acceleration) plus one RK4 step (four articulated-body passes) plus recording —
   without the per-run set-up. Split into the part inside the compiled loop
   (:func:`slidingarm._engine.run_one`, timed by a wrapper put in its place) and the rest,
   what :func:`simulate` spends per sample in Python (the reference evaluated at every
   sample, the input and output arrays, the memory they fault in).
2. **Pinocchio from Python**: the same law with ``pin.rnea`` (``τ = M u + h`` in one call)
   and RK4 with four ``pin.aba`` calls, in a Python loop with numpy for the rest.
3. The kernels one state at a time from a jitted loop: ``M`` + ``h``, and ``q̈``, against
   ``pin.crba`` + ``pin.rnea`` and ``pin.aba`` called from Python (the call overhead is part
   of what a Python loop pays); and the step's own pieces, each through the kind's dispatch
   as the loop calls them: the law's Newton-Euler (with the kinematics of ``q``), the whole
   law (the surface's ``|e|^γ``, the reaching law's ``tanh`` and that Newton-Euler) and one RK4
   step (four articulated-body passes, the stages' sines and cosines rotated); what
   ``run_one`` costs per step beyond the whole law and the RK4 step is the loop's own
   (measurement, recording, checks, dispatch; a difference of medians of separately timed
   loops, so noisy, and the law's loop times random states rather than a tracked trajectory).

The two loops of 1 and 2 are timed in turns, one repeat of each after the other, so that a
change of the machine's load between them shows in both; the ratio is printed as the ratio of
the two medians and as the median of the per-repeat ratios.

Targets (issue 9): compiled step <= 5 µs and >= 20x faster than the Pinocchio loop.
"""

from __future__ import annotations

import argparse
import math
import platform
import time
from collections.abc import Callable

import numba
import numpy as np
import pinocchio as pin
from numba import njit

from slidingarm import FTSMC, QuinticReference, robots, simulate
from slidingarm import _engine as E
from slidingarm._pointers import INLINED
from slidingarm.control import _dispatch as LD
from slidingarm.control import _kernels as CK
from slidingarm.models import _dispatch as D

DT = 1e-3
GAINS = {"alpha": 2.0, "beta": 2.0, "p": 5, "q": 3, "k": 20.0, "switching": "tanh", "width": 0.05}


def _stats(x: np.ndarray) -> str:
    return f"{np.median(x):8.2f} µs  [{np.percentile(x, 10):.2f}, {np.percentile(x, 90):.2f}]"


#: The clock every timing reads (``--clock``).
_clock: Callable[[], float] = time.perf_counter


def _time(fn: Callable[[], object], repeats: int, per: int) -> np.ndarray:
    fn()
    out = np.empty(repeats)
    for r in range(repeats):
        t0 = _clock()
        fn()
        out[r] = (_clock() - t0) / per * 1e6
    return out


def compiled_step() -> Callable[[], tuple[float, float]]:
    """One repeat of the compiled step's timing (µs), :func:`simulate` compiled and warm, and
    of the part of it spent inside the compiled loop :func:`slidingarm._engine.run_one` (timed
    by a wrapper around it; the rest is what :func:`simulate` spends per sample in Python)."""
    arm = robots.load("ur5")
    ctrl = FTSMC(arm, **GAINS)  # type: ignore[arg-type]
    q0 = np.zeros(arm.n)
    ref = QuinticReference(q0, np.full(arm.n, 0.5), duration=5.0)
    inner = [0.0]
    compiled = E.run_one

    def timed(*args: object) -> None:
        t0 = _clock()
        compiled(*args)
        inner[0] += _clock() - t0

    def run(t_final: float) -> tuple[float, float]:
        inner[0] = 0.0
        E.run_one = timed
        try:
            t0 = _clock()
            res = simulate(arm, ctrl, ref, q0=q0, t_final=t_final, dt=DT)
            total = _clock() - t0
        finally:
            E.run_one = compiled
        assert res.success, res.message
        return total, inner[0] if inner[0] > 0 else math.nan

    def one() -> tuple[float, float]:
        short = min(run(1.0) for _ in range(3))
        long_ = min(run(5.0) for _ in range(3))
        return (long_[0] - short[0]) / 4000 * 1e6, (long_[1] - short[1]) / 4000 * 1e6

    run(1.0)
    return one


def pinocchio_step(steps: int = 500) -> Callable[[], float]:
    """One repeat of the timing (µs per step) of the closed loop of :func:`compiled_step` with
    Pinocchio from Python."""
    model = pin.buildModelFromUrdf(str(robots.path("ur5")))
    data = model.createData()
    n = model.nv
    a, b, pq, k, w = 2.0, 2.0, 5.0 / 3.0, 20.0, 0.05
    q_end = np.full(n, 0.5)

    def loop() -> None:
        q = np.zeros(n)
        qd = np.zeros(n)
        for i in range(steps):
            t = i * DT
            s_ = min(t / 5.0, 1.0)
            p = 10 * s_**3 - 15 * s_**4 + 6 * s_**5
            qr = p * q_end
            qdr = q_end * 30 * s_**2 * (1 - s_) ** 2 / 5.0
            qddr = q_end * 60 * s_ * (1 - s_) * (1 - 2 * s_) / 25.0
            e = q - qr
            ed = qd - qdr
            ae = np.abs(e)
            s = ed + a * e + b * np.sign(e) * ae**pq
            u = qddr - a * ed - b * pq * ae ** (pq - 1) * ed - k * np.tanh(s / w)
            tau = pin.rnea(model, data, q, qd, u)
            k1 = pin.aba(model, data, q, qd, tau).copy()
            k2 = pin.aba(model, data, q + 0.5 * DT * qd, qd + 0.5 * DT * k1, tau).copy()
            v2 = qd + 0.5 * DT * k1
            k3 = pin.aba(model, data, q + 0.5 * DT * v2, qd + 0.5 * DT * k2, tau).copy()
            v3 = qd + 0.5 * DT * k2
            k4 = pin.aba(model, data, q + DT * v3, qd + DT * k3, tau).copy()
            v4 = qd + DT * k3
            q = q + DT / 6 * (qd + 2 * v2 + 2 * v3 + v4)
            qd = qd + DT / 6 * (k1 + 2 * k2 + 2 * k3 + k4)

    def one() -> float:
        t0 = _clock()
        loop()
        return (_clock() - t0) / steps * 1e6

    loop()
    return one


@njit(cache=False)
def _mh_loop(kind, p, g, q, qd, mm, h):  # type: ignore[no-untyped-def]  # pragma: no cover
    work = np.empty((D.WORK_ROWS, q.shape[1]))
    for i in range(q.shape[0]):
        D.mass_and_bias(kind, p, g, q[i], qd[i], mm[i], h[i], work)


@njit(cache=False)
def _fd_loop(kind, p, g, q, qd, tau, out):  # type: ignore[no-untyped-def]  # pragma: no cover
    work = np.empty((D.WORK_ROWS, q.shape[1]))
    for i in range(q.shape[0]):
        D.forward_dynamics(kind, p, g, q[i], qd[i], tau[i], out[i], work)


@njit(cache=False)
def _id_loop(kind, p, g, q, qd, qdd, out):  # type: ignore[no-untyped-def]  # pragma: no cover
    work = np.empty((D.WORK_ROWS, q.shape[1]))
    for i in range(q.shape[0]):
        D.inverse_dynamics(kind, p, g, q[i], qd[i], qdd[i], out[i], work)


@njit(cache=False)
def _law_loop(kind, p, g, lp, q, qd, qr, qdr, qddr, tau, s):  # type: ignore[no-untyped-def]  # pragma: no cover
    work = np.empty((CK.CONTROL_WORK_ROWS, q.shape[1]))
    mats = np.empty((2 * q.shape[1], q.shape[1]))
    state = np.zeros(q.shape[1])
    for i in range(q.shape[0]):
        CK.control_into(
            LD.null_entry, LD.null_kernel, INLINED, 0, lp, kind, p, g, q[i], qd[i], qr[i], qdr[i],
            qddr[i], state, DT, tau[i], s[i], mats, work,
        )  # fmt: skip


@njit(cache=False)
def _rk4_loop(kind, p, g, q, qd, tau):  # type: ignore[no-untyped-def]  # pragma: no cover
    work = np.empty((D.WORK_ROWS, q.shape[1]))
    scratch = np.empty((D.RK4_ROWS, q.shape[1]))
    for i in range(q.shape[0]):
        D.rk4_step(kind, p, g, q[i], qd[i], tau[i], DT, False, scratch, work)


def kernels(repeats: int, batch: int = 1000) -> dict[str, np.ndarray]:
    arm = robots.load("ur5")
    hd = arm.handle
    model = pin.buildModelFromUrdf(str(robots.path("ur5")))
    data = model.createData()
    rng = np.random.default_rng(0)
    q = rng.uniform(-np.pi, np.pi, (batch, arm.n))
    qd = rng.normal(size=(batch, arm.n))
    tau = rng.normal(size=(batch, arm.n)) * 10
    mm = np.empty((batch, arm.n, arm.n))
    h = np.empty((batch, arm.n))
    out = np.empty((batch, arm.n))
    # the law's tracking errors as along a tracked trajectory: small (|e| above the guard) and
    # of one sign from state to state (random signs would time branch mispredictions that a
    # closed loop, whose errors change sign rarely, does not pay)
    law = FTSMC(arm, **GAINS).for_period(DT).handle  # type: ignore[arg-type]
    lp = np.array(law.params)
    q_ref = q - np.abs(rng.normal(size=(batch, arm.n))) * 1e-3
    qd_ref = qd - np.abs(rng.normal(size=(batch, arm.n))) * 1e-3
    qdd_ref = rng.normal(size=(batch, arm.n))
    s = np.empty((batch, arm.n))
    q_rk = q.copy()  # stepped in place by the RK4 timing
    qd_rk = qd.copy()
    small = 200

    def pin_mh() -> None:
        for i in range(small):
            pin.crba(model, data, q[i])
            pin.rnea(model, data, q[i], qd[i], np.zeros(arm.n))

    def pin_fd() -> None:
        for i in range(small):
            pin.aba(model, data, q[i], qd[i], tau[i])

    return {
        "M + h, compiled": _time(
            lambda: _mh_loop(hd.kind, hd.params, hd.g, q, qd, mm, h), repeats, batch
        ),
        "M + h, pin.crba + pin.rnea from Python": _time(pin_mh, repeats, small),
        "q̈, compiled (articulated body)": _time(
            lambda: _fd_loop(hd.kind, hd.params, hd.g, q, qd, tau, out), repeats, batch
        ),
        "q̈, pin.aba from Python": _time(pin_fd, repeats, small),
        "law: τ by Newton-Euler, compiled": _time(
            lambda: _id_loop(hd.kind, hd.params, hd.g, q, qd, tau, out), repeats, batch
        ),
        "the whole law (surface, tanh, τ), compiled": _time(
            lambda: _law_loop(hd.kind, hd.params, hd.g, lp, q, qd, q_ref, qd_ref, qdd_ref, out, s),
            repeats,
            batch,
        ),
        "one RK4 step (4 x ABA), compiled": _time(
            lambda: _rk4_loop(hd.kind, hd.params, hd.g, q_rk, qd_rk, tau), repeats, batch
        ),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--clock", choices=("wall", "cpu"), default="wall")
    args = ap.parse_args()
    global _clock
    _clock = time.thread_time if args.clock == "cpu" else time.perf_counter
    print(
        f"# {platform.processor() or platform.machine()}, numba {numba.__version__}, pin {pin.__version__}, threads {numba.config.NUMBA_NUM_THREADS}, clock {args.clock}"
    )
    ours_one, theirs_one = compiled_step(), pinocchio_step()
    pairs = np.array([(*ours_one(), theirs_one()) for _ in range(args.repeats)])
    ours, loop, theirs = pairs[:, 0], pairs[:, 1], pairs[:, 2]
    print("UR5 closed-loop step (law + one RK4 step), median [p10, p90]:")
    print(f"  compiled loop (simulate)      {_stats(ours)}   target <= 5 µs")
    print(f"    of it inside run_one        {_stats(loop)}")
    print(f"    simulate's Python per step  {_stats(ours - loop)}")
    print(f"  Pinocchio from Python         {_stats(theirs)}")
    print(
        f"  ratio Pinocchio / compiled    {np.median(theirs) / np.median(ours):8.1f}x   target >= 20x"
    )
    print(f"  median of per-repeat ratios   {np.median(theirs / ours):8.1f}x")
    print("UR5 dynamics, one state:")
    res = kernels(args.repeats)
    for name, x in res.items():
        print(f"  {name:<40} {_stats(x)}")
    law = np.median(res["the whole law (surface, tanh, τ), compiled"])
    rk4 = np.median(res["one RK4 step (4 x ABA), compiled"])
    print(
        f"  {'run_one beyond law and RK4 (medians)':<40} {np.median(loop) - law - rk4:8.2f} µs"
        "  (measurement, recording, checks, dispatch)"
    )


if __name__ == "__main__":
    main()
