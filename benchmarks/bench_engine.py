"""Speed of the compiled closed loop against its targets (issue 3, point 6).

Run as ``python benchmarks/bench_engine.py [--quick | --cold]``. Everything is measured in this one
run, for a shared, noisy machine: every time is the median of several repeats after a
warm-up, and each ratio is the median of the ratios of runs that took turns (ours timed
warm within each turn).

1. The paper's run (3 joints, 4.5 s at 5e-4 s, 9001 samples, RK4): end to end through
   :func:`slidingarm.simulate`, and the compiled loop alone (``_engine.run_one`` on the
   arrays ``simulate`` prepares), both taking turns with a plain numba reference: the same loop
   written from scratch in ``_numba_reference.py`` (explicit ``M``, ``h``, RK4, the FTSMC law),
   checked to give our trajectory to 1e-9. The ratios ours / reference, measured in the same
   run, compare code across commits on a machine whose load changes.
2. The same closed loop stepped through MuJoCo from Python (``arm.to_mjcf()``, RK4, timestep
   ``dt``; the controller's Python ``__call__`` each sample, its torque applied through
   ``qfrc_applied``, one ``mj_step`` per sample), checked to track like ours.
3. The same loop written in idiomatic numpy (``M(q)``, ``h``, ``np.linalg.solve``, RK4, the
   FTSMC law), checked to give our trajectory to 1e-9.
4. One controller call from Python, ``controller(q, qd, q_ref, qd_ref, qdd_ref)``.
5. Compilation (numba cache): a fresh process's import, first call and warm call; without
   ``--quick`` also a first call that compiles from an empty cache.
6. ``import slidingarm`` in fresh processes, and the heavy packages it imports eagerly.
7. ``simulate_batch`` throughput, on all threads and on one.
8. A custom compiled law against the built-in law it re-implements (PDSMC with tanh, kernel
   in ``_custom_pdsmc.py``): the cost ratio (target <= 1.5x) and their difference.
9. What the sin/cos hand-off from the law to the plant's first RK4 stage is worth: the loop
   compiled again with ``_engine.REUSE_KINEMATICS`` off, against the loop.

``--cold`` measures only the compilation from an empty cache: three fresh processes, each with
its own empty ``NUMBA_CACHE_DIR``, and the median of their first ``simulate`` (which follows a
first controller call, timed separately). The processes use only slidingarm's public API, so
the measurement is the same for any version of the code on ``PYTHONPATH``.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from typing import Any

import numba
import numpy as np

import _numba_reference as NR
import slidingarm as sa
from slidingarm import _engine as E
from slidingarm.control.surfaces import FastTerminalSurface
from slidingarm.references import PAPER_Q0

DT = 5e-4
T_FINAL = 4.5

# targets
E2E_MS = 10.0
MUJOCO_RATIO = 20.0
NUMPY_RATIO = 100.0
REFERENCE_DEV = 1e-9
COLD_RUNS = 3
CALL_P99_US = 5.0
IMPORT_S = 1.0
CUSTOM_RATIO = 1.5


def paper_problem() -> tuple[sa.PlanarArm, sa.FTSMC, sa.PaperReference]:
    arm = sa.PlanarArm.paper()
    return arm, sa.FTSMC(arm, alpha=2, beta=2, p=5, q=3, k=20, eps_e=NR.EPS_E), sa.PaperReference()


def run_ours() -> sa.SimResult:
    arm, ctrl, ref = paper_problem()
    return sa.simulate(arm, ctrl, ref, q0=PAPER_Q0, t_final=T_FINAL, dt=DT)


def timed(
    *fns: Callable[[], object], repeats: int, inner: tuple[int, ...] | None = None
) -> list[np.ndarray]:
    """Seconds per call of each of ``fns``, ``repeats`` times after one warm-up call each.

    The functions take turns, so that a ratio of their times compares them under the same
    load of the machine; in each turn function ``i`` runs ``inner[i]`` times in a row (default
    once) and keeps the median, so that a fast function is timed warm, not just after a slow
    one evicted it from the caches.
    """
    for fn in fns:
        fn()
    counts = inner or (1,) * len(fns)
    out = [np.empty(repeats) for _ in fns]
    for r in range(repeats):
        for fn, times, count in zip(fns, out, counts, strict=True):
            turn = np.empty(count)
            for i in range(count):
                t0 = time.perf_counter()
                fn()
                turn[i] = time.perf_counter() - t0
            times[r] = np.median(turn)
    return out


# ---------------------------------------------------------------------------- the kernel alone
@contextlib.contextmanager
def _captured_kernel_args() -> Iterator[list[tuple[Any, ...]]]:
    """Record the arguments ``simulate`` passes to the compiled loop (copies)."""
    calls: list[tuple[Any, ...]] = []
    real = E.run_one

    def spy(*args: Any) -> None:
        calls.append(tuple(a.copy() if isinstance(a, np.ndarray) else a for a in args))
        real(*args)

    E.run_one = spy
    try:
        yield calls
    finally:
        E.run_one = real


def kernel_args() -> tuple[Any, ...]:
    with _captured_kernel_args() as calls:
        run_ours()
    return calls[0]


# ---------------------------------------------------------------------------- numba reference
def reference_args() -> tuple[Any, ...]:
    """The arguments of the plain numba reference loop for the paper's run.

    The reference has the paper's arm and gains written in; they are checked against the
    problem ``simulate`` is given, so that both solve the same one.
    """
    arm, ctrl, ref = paper_problem()
    surf = ctrl.surface
    assert isinstance(surf, FastTerminalSurface)
    same = (
        np.array_equal(arm.masses, NR.MASSES)
        and np.array_equal(arm.lengths, NR.LENGTHS)
        and np.array_equal(arm.com, NR.LENGTHS)
        and not np.any(arm.inertia)
        and arm.gravity == NR.GRAVITY
        and np.all(surf.alpha == NR.ALPHA)
        and np.all(surf.beta == NR.BETA)
        and surf.gamma == NR.GAMMA
        and surf.eps_e == NR.EPS_E
        and np.all(ctrl.k == NR.K)
    )
    if not same:
        raise AssertionError("the numba reference's arm or gains are not the paper run's")
    t = np.arange(round(T_FINAL / DT) + 1) * DT
    return NR.paper_inputs(PAPER_Q0, *ref.evaluate(t), DT)


# ---------------------------------------------------------------------------- MuJoCo baseline
def mujoco_loop(arm: sa.PlanarArm, ctrl: sa.FTSMC, ref: sa.PaperReference) -> np.ndarray:
    """The closed loop stepped through MuJoCo from Python; returns q, shape (T, n)."""
    import mujoco

    model = mujoco.MjModel.from_xml_string(arm.to_mjcf(timestep=DT))  # RK4 integrator
    data = mujoco.MjData(model)
    t = np.arange(round(T_FINAL / DT) + 1) * DT
    q_ref, qd_ref, qdd_ref = (np.ascontiguousarray(a) for a in ref.evaluate(t))
    n = arm.n
    qs = np.empty((t.shape[0], n))
    qds = np.empty((t.shape[0], n))
    taus = np.zeros((t.shape[0], n))
    data.qpos[:] = PAPER_Q0
    data.qvel[:] = 0.0
    ctrl.reset()
    last = t.shape[0] - 1
    for k in range(t.shape[0]):
        qs[k] = data.qpos
        qds[k] = data.qvel
        tau = ctrl(qs[k], qds[k], q_ref[k], qd_ref[k], qdd_ref[k])
        taus[k] = tau
        if k == last:
            break
        data.qfrc_applied[:] = tau
        mujoco.mj_step(model, data)
    return qs


# ---------------------------------------------------------------------------- numpy baseline
def numpy_loop(arm: sa.PlanarArm, ctrl: sa.FTSMC, ref: sa.PaperReference) -> np.ndarray:
    """The closed loop as a user would write it in numpy; returns q, shape (T, n)."""
    m, ln, c, inertia, g = arm.masses, arm.lengths, arm.com, arm.inertia, arm.gravity
    surf = ctrl.surface
    assert isinstance(surf, FastTerminalSurface)
    alpha, beta, gamma, eps_e = surf.alpha, surf.beta, surf.gamma, surf.eps_e
    k_gain = ctrl.k
    n = arm.n

    def mass_and_bias(q: np.ndarray, qd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        # M = sum_i m_i J_i^T J_i + I_i 1 1^T and h = sum_i m_i J_i^T (Jdot_i qd + g y)
        phi = np.cumsum(q)
        w = np.cumsum(qd)
        cs, sn = np.cos(phi), np.sin(phi)
        mass = np.zeros((n, n))
        bias = np.zeros(n)
        for i in range(n):
            jac = np.zeros((2, n))
            for j in range(i + 1):
                jac[0, j] = -ln[j:i] @ sn[j:i] - c[i] * sn[i]
                jac[1, j] = ln[j:i] @ cs[j:i] + c[i] * cs[i]
            acc = -np.array(
                [
                    ln[:i] @ (w[:i] ** 2 * cs[:i]) + c[i] * w[i] ** 2 * cs[i],
                    ln[:i] @ (w[:i] ** 2 * sn[:i]) + c[i] * w[i] ** 2 * sn[i],
                ]
            )
            ones = (np.arange(n) <= i).astype(float)
            mass += m[i] * jac.T @ jac + inertia[i] * np.outer(ones, ones)
            bias += m[i] * jac.T @ (acc + np.array([0.0, g]))
        return mass, bias

    def control(
        q: np.ndarray, qd: np.ndarray, qr: np.ndarray, qdr: np.ndarray, qddr: np.ndarray
    ) -> np.ndarray:
        e = q - qr
        ed = qd - qdr
        s = ed + alpha * e + beta * np.abs(e) ** gamma * np.sign(e)
        nu = (alpha + beta * gamma * np.maximum(np.abs(e), eps_e) ** (gamma - 1.0)) * ed
        mass, bias = mass_and_bias(q, qd)
        return mass @ (qddr - nu - k_gain * np.sign(s)) + bias

    def accel(q: np.ndarray, qd: np.ndarray, tau: np.ndarray) -> np.ndarray:
        mass, bias = mass_and_bias(q, qd)
        return np.linalg.solve(mass, tau - bias)

    def rk4(
        q: np.ndarray, qd: np.ndarray, tau: np.ndarray, h: float
    ) -> tuple[np.ndarray, np.ndarray]:
        a1 = accel(q, qd, tau)
        a2 = accel(q + h / 2 * qd, qd + h / 2 * a1, tau)
        a3 = accel(q + h / 2 * (qd + h / 2 * a1), qd + h / 2 * a2, tau)
        a4 = accel(q + h * (qd + h / 2 * a2), qd + h * a3, tau)
        v2, v3, v4 = qd + h / 2 * a1, qd + h / 2 * a2, qd + h * a3
        return (
            q + h / 6 * (qd + 2 * v2 + 2 * v3 + v4),
            qd + h / 6 * (a1 + 2 * a2 + 2 * a3 + a4),
        )

    t = np.arange(round(T_FINAL / DT) + 1) * DT
    q_ref, qd_ref, qdd_ref = ref.evaluate(t)
    q = np.array(PAPER_Q0, dtype=float)
    qd = np.zeros(n)
    qs = np.empty((t.shape[0], n))
    for k in range(t.shape[0]):
        qs[k] = q
        if k == t.shape[0] - 1:
            break
        tau = control(q, qd, q_ref[k], qd_ref[k], qdd_ref[k])
        q, qd = rk4(q, qd, tau, DT)
    return qs


# ---------------------------------------------------------------------------- one call
def call_percentiles(calls: int) -> tuple[float, float]:
    arm, ctrl, ref = paper_problem()
    q_ref, qd_ref, qdd_ref = (np.ascontiguousarray(a[0]) for a in ref.evaluate(np.array([0.1])))
    q = np.array(PAPER_Q0, dtype=float)
    qd = np.zeros(arm.n)
    for _ in range(2000):
        ctrl(q, qd, q_ref, qd_ref, qdd_ref)
    clock = time.perf_counter_ns
    ns = np.empty(calls)
    for i in range(calls):
        t0 = clock()
        ctrl(q, qd, q_ref, qd_ref, qdd_ref)
        ns[i] = clock() - t0
    return float(np.percentile(ns, 50)) / 1e3, float(np.percentile(ns, 99)) / 1e3


# ---------------------------------------------------------------------------- fresh processes
_FIRST_CALL = """
import json, time
t0 = time.perf_counter()
import numpy as np
import slidingarm as sa
t1 = time.perf_counter()
arm = sa.PlanarArm.paper()
c = sa.FTSMC(arm, alpha=2, beta=2, p=5, q=3, k=20)
ref = sa.PaperReference()
q, z = np.array(sa.PAPER_Q0), np.zeros(3)
t2 = time.perf_counter(); c(q, z, q, z, z); t3 = time.perf_counter()
run = lambda: sa.simulate(arm, c, ref, q0=sa.PAPER_Q0, t_final=4.5, dt=5e-4)
run(); t4 = time.perf_counter(); run(); t5 = time.perf_counter()
print(json.dumps({"import": t1 - t0, "call": t3 - t2, "first": t4 - t3, "warm": t5 - t4}))
"""


def fresh_process(env: dict[str, str] | None = None) -> dict[str, float]:
    out = subprocess.run(
        [sys.executable, "-c", _FIRST_CALL],
        capture_output=True,
        text=True,
        check=True,
        env={**os.environ, **(env or {})},
    )
    result: dict[str, float] = json.loads(out.stdout.strip().splitlines()[-1])
    return result


def cold_compile(runs: int = COLD_RUNS) -> list[dict[str, float]]:
    """:func:`fresh_process` ``runs`` times, each with its own empty numba cache."""
    out = []
    for _ in range(runs):
        with tempfile.TemporaryDirectory() as cache:
            out.append(fresh_process({"NUMBA_CACHE_DIR": cache}))
    return out


def report_cold() -> None:
    runs = cold_compile()
    print(f"compilation from an empty numba cache, {len(runs)} fresh processes (median)")
    for key, what in (
        ("import", "import slidingarm"),
        ("call", "first controller call"),
        ("first", "first simulate"),
        ("warm", "second simulate"),
    ):
        values = [r[key] for r in runs]
        each = ", ".join(f"{v:.3f}" for v in values)
        print(f"  {what:<24} {np.median(values):7.3f} s   ({each})")
    both = [r["call"] + r["first"] for r in runs]
    print(f"  {'controller + simulate':<24} {np.median(both):7.3f} s")


def import_profile() -> tuple[float, float, float, list[tuple[str, str, float]]]:
    """``import slidingarm`` in fresh processes (medians of 3): the statement's own time, the
    process's wall time minus that of a bare interpreter (which adds the interpreter's exit),
    the total that ``-X importtime`` gives, and the direct imports of third-party modules by
    slidingarm modules that take over 20 ms, with their importer, slowest first."""

    def run(code: str) -> tuple[float, str]:
        t0 = time.perf_counter()
        out = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True)
        return time.perf_counter() - t0, out.stdout.decode()

    timed_import = (
        "import time; t = time.perf_counter(); import slidingarm; print(time.perf_counter() - t)"
    )
    own, walls, bare = [], [], []
    for _ in range(3):
        wall, printed = run(timed_import)
        own.append(float(printed))
        walls.append(wall)
        bare.append(run("pass")[0])
    total_wall = float(np.median(walls) - np.median(bare))
    out = subprocess.run(
        [sys.executable, "-X", "importtime", "-c", "import slidingarm"],
        capture_output=True,
        text=True,
        check=True,
    )
    # "import time: self | cumulative | <indent>name"; a module is printed after the modules
    # it imports, one indentation level deeper
    entries: list[tuple[int, str, float]] = []
    for line in out.stderr.splitlines():
        parts = line.split("|")
        if len(parts) != 3 or not parts[1].strip().isdigit():
            continue
        name = parts[2].rstrip()
        entries.append((len(name) - len(name.lstrip()), name.strip(), int(parts[1]) / 1e6))
    total = next((cum for _, name, cum in entries if name == "slidingarm"), float("nan"))
    heavy = []
    for i, (depth, name, cum) in enumerate(entries):
        if name.startswith("slidingarm") or cum < 0.02:
            continue
        parent = next((n for d, n, _ in entries[i + 1 :] if d < depth), "")
        if parent.startswith("slidingarm"):
            heavy.append((name, parent, cum))
    heavy.sort(key=lambda x: -x[2])
    return float(np.median(own)), total_wall, total, heavy


# ---------------------------------------------------------------------------- batch
def batch_rate(b: int, threads: int | None) -> float:
    arm, ctrl, ref = paper_problem()
    rng = np.random.default_rng(0)
    q0 = PAPER_Q0 + rng.normal(0.0, 0.01, (b, arm.n))
    saved = numba.config.NUMBA_NUM_THREADS
    if threads is not None:
        numba.config.NUMBA_NUM_THREADS = threads
    try:
        sa.simulate_batch(arm, ctrl, ref, q0=q0[:2], t_final=T_FINAL, dt=DT)  # warm up
        rates = []
        for _ in range(3):  # the median of three: one batch is at the mercy of the neighbours
            t0 = time.perf_counter()
            sa.simulate_batch(arm, ctrl, ref, q0=q0, t_final=T_FINAL, dt=DT)
            rates.append(b / (time.perf_counter() - t0))
        return float(np.median(rates))
    finally:
        numba.config.NUMBA_NUM_THREADS = saved


# ---------------------------------------------------------------------------- contracts
def custom_cost(reps: int) -> tuple[float, float, float, float]:
    """The paper run under PDSMC with tanh: built-in law against the same law as a custom
    kernel (the engine computes M and h, the kernel forms M a + h)."""
    from _custom_pdsmc import pdsmc_tanh

    arm, ref = sa.PlanarArm.paper(), sa.PaperReference()
    builtin = sa.PDSMC(arm, lam=2.0, k=20.0, switching="tanh", width=0.05)
    custom = sa.CustomController(pdsmc_tanh, arm, params=(2.0, 20.0, 0.05))

    def run(c: Any) -> sa.SimResult:
        return sa.simulate(arm, c, ref, q0=PAPER_Q0, t_final=T_FINAL, dt=DT)

    dev = float(np.max(np.abs(run(builtin).q - run(custom).q)))
    b, c = timed(lambda: run(builtin), lambda: run(custom), repeats=reps)
    return (
        float(np.median(b)) * 1e3,
        float(np.median(c)) * 1e3,
        float(np.median(c / b)),
        dev,
    )


def handoff_worth(kargs: tuple[Any, ...], reps: int) -> tuple[float, float]:
    """The compiled loop compiled again with ``REUSE_KINEMATICS`` off, against the loop."""
    import types as pytypes

    from numba import njit

    fn = E.run_one.py_func
    glb = dict(fn.__globals__, REUSE_KINEMATICS=False)
    off = njit(nogil=True, error_model="numpy")(
        pytypes.FunctionType(fn.__code__, glb, fn.__name__, fn.__defaults__, fn.__closure__)
    )
    off(*kargs)
    with_, without = timed(lambda: E.run_one(*kargs), lambda: off(*kargs), repeats=reps)
    return float(np.median(without)) * 1e3, float(np.median(without / with_))


# ---------------------------------------------------------------------------- report
def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    mode = parser.add_mutually_exclusive_group()
    mode.add_argument("--quick", action="store_true", help="fewer repeats, smaller batch")
    mode.add_argument(
        "--cold",
        action="store_true",
        help=f"only the first simulate from an empty numba cache ({COLD_RUNS} fresh processes)",
    )
    args = parser.parse_args()
    quick = args.quick
    reps = 15 if quick else 60

    print(f"python {platform.python_version()}, numpy {np.__version__}, numba {numba.__version__}")
    print(f"{platform.machine()}, {os.cpu_count()} CPUs, {numba.config.NUMBA_NUM_THREADS} threads")
    if args.cold:
        report_cold()
        return
    print(
        f"paper run: 3 joints, {T_FINAL} s at dt = {DT} s, RK4 ({round(T_FINAL / DT) + 1} samples)\n"
    )

    ours = run_ours()
    kargs = kernel_args()
    rargs = reference_args()
    nr_dev = float(np.abs(NR.closed_loop(*rargs) - ours.q).max())
    if not nr_dev <= REFERENCE_DEV:
        raise AssertionError(
            f"the numba reference's q differs from simulate's by {nr_dev:.1e} rad "
            f"(> {REFERENCE_DEV:g}): they do not run the same loop"
        )
    e2e, kernel, nref = timed(
        run_ours, lambda: E.run_one(*kargs), lambda: NR.closed_loop(*rargs), repeats=reps
    )
    e2e_ms = float(np.median(e2e)) * 1e3
    kernel_ms = float(np.median(kernel)) * 1e3
    nr_ms = float(np.median(nref)) * 1e3
    nr_e2e_ratio = float(np.median(e2e / nref))
    nr_kernel_ratio = float(np.median(kernel / nref))

    arm, ctrl, ref = paper_problem()
    q_mj = mujoco_loop(arm, ctrl, ref)
    mj_dev = float(np.abs(q_mj - ours.q).max())
    mj_err = float(np.abs(q_mj[-1] - ours.q_ref[-1]).max())
    our_err = float(np.abs(ours.e[-1]).max())
    mj, ours_mj = timed(
        lambda: mujoco_loop(arm, ctrl, ref), run_ours, repeats=5 if quick else 15, inner=(1, 5)
    )
    mj_ms = float(np.median(mj)) * 1e3
    mj_ratio = float(np.median(mj / ours_mj))

    q_np = numpy_loop(arm, ctrl, ref)
    np_dev = float(np.abs(q_np - ours.q).max())
    npy, ours_np = timed(
        lambda: numpy_loop(arm, ctrl, ref), run_ours, repeats=1 if quick else 3, inner=(1, 5)
    )
    np_ms = float(np.median(npy)) * 1e3
    np_ratio = float(np.median(npy / ours_np))

    p50, p99 = call_percentiles(20_000 if quick else 100_000)

    fresh = fresh_process()
    cold: dict[str, float] | None = None
    if not quick:
        with tempfile.TemporaryDirectory() as cache:
            cold = fresh_process({"NUMBA_CACHE_DIR": cache})
    import_own, import_wall, import_total, heavy = import_profile()

    nb = 200 if quick else 1000
    rate_all = batch_rate(nb, None)
    rate_one = batch_rate(nb // 5, 1)

    builtin_ms, custom_ms, custom_ratio, custom_dev = custom_cost(reps)
    nohand_ms, hand_ratio = handoff_worth(kargs, reps)

    rows: list[tuple[str, str, str, str]] = []

    def row(what: str, value: str, target: str = "", met: bool | None = None) -> None:
        rows.append((what, value, target, "" if met is None else ("yes" if met else "NO")))

    row(
        "paper run, end to end (simulate)",
        f"{e2e_ms:.2f} ms",
        f"<= {E2E_MS:g} ms",
        e2e_ms <= E2E_MS,
    )
    row(
        "paper run, compiled loop only",
        f"{kernel_ms:.2f} ms ({kernel_ms / 9000 * 1e6:.0f} ns/step)",
    )
    row("plain numba reference, same loop", f"{nr_ms:.2f} ms")
    row("  ratio ours / reference (end to end)", f"{nr_e2e_ratio:.3f}")
    row("  ratio compiled loop / reference", f"{nr_kernel_ratio:.3f}")
    row(
        "  max |q_ref_loop - q_ours|",
        f"{nr_dev:.1e} rad",
        "<= 1e-9",
        nr_dev <= REFERENCE_DEV,
    )
    row("MuJoCo from Python, same loop", f"{mj_ms:.1f} ms")
    row(
        "  ratio MuJoCo / ours (end to end)",
        f"{mj_ratio:.1f}x",
        f">= {MUJOCO_RATIO:g}x",
        mj_ratio >= MUJOCO_RATIO,
    )
    row("  max |q_mujoco - q_ours|", f"{mj_dev:.1e} rad")
    row("  final |e|: MuJoCo / ours", f"{mj_err:.1e} / {our_err:.1e} rad")
    row("idiomatic numpy loop", f"{np_ms:.0f} ms")
    row(
        "  ratio numpy / ours (end to end)",
        f"{np_ratio:.0f}x",
        f">= {NUMPY_RATIO:g}x",
        np_ratio >= NUMPY_RATIO,
    )
    row("  max |q_numpy - q_ours|", f"{np_dev:.1e} rad", "<= 1e-9", np_dev <= 1e-9)
    row("controller call from Python, p50", f"{p50:.2f} us")
    row(
        "controller call from Python, p99",
        f"{p99:.2f} us",
        f"<= {CALL_P99_US:g} us",
        p99 <= CALL_P99_US,
    )
    row("fresh process: first controller call", f"{fresh['call'] * 1e3:.0f} ms")
    row("fresh process: first simulate", f"{fresh['first'] * 1e3:.0f} ms")
    row("fresh process: second simulate", f"{fresh['warm'] * 1e3:.1f} ms")
    if cold is not None:
        row("empty numba cache: first controller call", f"{cold['call']:.1f} s")
        row("empty numba cache: first simulate", f"{cold['first']:.1f} s")
    row(
        "import slidingarm (fresh process)",
        f"{import_own:.2f} s",
        f"< {IMPORT_S:g} s",
        import_own < IMPORT_S,
    )
    row("  process wall time, minus a bare python", f"{import_wall:.2f} s")
    row("  -X importtime total", f"{import_total:.2f} s")
    for name, owner, cum in heavy[:6]:
        row(f"    {name} (imported by {owner})", f"{cum:.2f} s")
    row(f"simulate_batch B={nb}, all threads", f"{rate_all:.0f} runs/s")
    row(f"simulate_batch B={nb // 5}, one thread", f"{rate_one:.0f} runs/s")
    row("PDSMC tanh, built-in law (end to end)", f"{builtin_ms:.2f} ms")
    row("PDSMC tanh, custom kernel (end to end)", f"{custom_ms:.2f} ms")
    row(
        "  ratio custom / built-in",
        f"{custom_ratio:.2f}x",
        f"<= {CUSTOM_RATIO:g}x",
        custom_ratio <= CUSTOM_RATIO,
    )
    row("  max |q_custom - q_builtin|", f"{custom_dev:.1e} rad", "<= 1e-12", custom_dev <= 1e-12)
    row("loop without the sin/cos hand-off", f"{nohand_ms:.2f} ms")
    row("  ratio without / with the hand-off", f"{hand_ratio:.3f}x")

    widths = [max(len(r[i]) for r in rows) for i in range(4)]
    head = ("measure", "median", "target", "met")
    widths = [max(w, len(h)) for w, h in zip(widths, head, strict=True)]
    line = "  ".join(h.ljust(w) for h, w in zip(head, widths, strict=True))
    print(line)
    print("-" * len(line))
    for r in rows:
        print("  ".join(c.ljust(w) for c, w in zip(r, widths, strict=True)))


if __name__ == "__main__":
    main()
