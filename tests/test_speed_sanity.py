"""The fast paths of the compiled loop (issue 3, point 6): exact where they replace a slower
computation, and fast enough that a regression of an order of magnitude fails.

The timing bounds are several times the measured values (``benchmarks/bench_engine.py``) so
that a loaded machine does not fail them; the benchmark is where speed is measured.
"""

from __future__ import annotations

import re
import time

import numba
import numpy as np
import pytest
from numba import njit

from slidingarm import FTSMC, PAPER_Q0, PaperReference, PlanarArm, simulate, simulate_batch
from slidingarm import _engine as E
from slidingarm.models import _kernels as K

EPS = float(np.finfo(np.float64).eps)


def _arms() -> list[PlanarArm]:
    rng = np.random.default_rng(3)
    out = [PlanarArm.paper(), PlanarArm.paper("rod")]
    for n in (1, 2, 5, 7):
        m, ln = rng.uniform(0.2, 5.0, n), rng.uniform(0.2, 2.0, n)
        com = rng.uniform(0.1, 1.0, n) * ln
        out.append(PlanarArm(m, ln, com=com, inertia=rng.uniform(0, 1 / 6, n) * m * ln**2))
    return out


@pytest.mark.parametrize("arm", _arms(), ids=lambda a: f"n{a.n}")
def test_articulated_body_algorithm_solves_the_mass_matrix(arm: PlanarArm) -> None:
    """forward_dynamics (ABA, O(n)) is M(q)^-1 (tau - h) to the conditioning of M."""
    rng = np.random.default_rng(arm.n)
    q = rng.uniform(-np.pi, np.pi, (200, arm.n))
    qd = rng.uniform(-5, 5, (200, arm.n))
    tau = rng.uniform(-50, 50, (200, arm.n))
    qdd = arm.forward_dynamics(q, qd, tau)
    mass, bias = arm.mass_matrix(q), arm.bias(q, qd)
    ref = np.linalg.solve(mass, (tau - bias)[..., None])[..., 0]
    scale = np.abs(ref).max(axis=1) * np.linalg.cond(mass)
    assert np.all(np.abs(qdd - ref).max(axis=1) <= 100 * EPS * scale)


@njit(cache=False)
def _angles_two_ways(
    q: np.ndarray, dq: np.ndarray, shifted: np.ndarray, direct: np.ndarray
) -> None:  # pragma: no cover - compiled
    n = q.shape[0]
    base = np.empty((2, n))
    K.angles_into(q, direct)
    base[:] = direct[:2]
    qs = q + dq
    K.shifted_angles_into(base, dq, qs, shifted)
    K.angles_into(qs, direct)


@pytest.mark.parametrize("step", [1e-9, 1e-5, 1e-3, 0.01, 0.2])
def test_shifted_angles_are_the_angles_of_the_stage(step: float) -> None:
    """Rotating the sines and cosines of q by a small step agrees with computing them at
    q + dq to a few ulps; a step beyond 2^-5 falls back to computing them."""
    rng = np.random.default_rng(0)
    for _ in range(200):
        q = rng.uniform(-4, 4, 3)
        dq = rng.uniform(-1, 1, 3) * step
        shifted, direct = np.zeros((K.WORK_ROWS, 3)), np.zeros((K.WORK_ROWS, 3))
        _angles_two_ways(q, dq, shifted, direct)
        if np.abs(np.cumsum(dq)).max() > 2.0**-5:
            np.testing.assert_array_equal(shifted[:2], direct[:2])
        else:
            # the direct value rounds q + dq first: a few ulps of q's size apart
            np.testing.assert_allclose(shifted[:2], direct[:2], rtol=0, atol=8 * EPS * 4)


@njit(cache=False)
def _rotated_many(c: np.ndarray, s: np.ndarray, d: np.ndarray, out: np.ndarray) -> None:  # pragma: no cover - compiled
    for i in range(c.shape[0]):
        out[0, i], out[1, i] = K.rotated(c[i], s[i], d[i])


def test_rotated_is_the_rotation_to_rounding() -> None:
    """``rotated`` (the RK4 stages' sines and cosines) is the rotation of the given pair
    ``(c, s)`` by ``delta`` to within half an ulp of 1 absolute, over ``|delta| <= 2**-5``
    (its Taylor series' range) and every quadrant: checked against the rotation in 64-bit
    precision (x87 long double). A wrong or missing Taylor coefficient fails by orders of
    magnitude (the first omitted term at 2**-5 is 2e-13)."""
    if np.finfo(np.longdouble).nmant < 63:
        pytest.skip("no extended-precision long double on this platform")
    rng = np.random.default_rng(7)
    m = 20000
    phi = rng.uniform(-np.pi, np.pi, m)
    delta = rng.uniform(-(2.0**-5), 2.0**-5, m) * rng.choice([1.0, 1e-3, 1e-8], m)
    c, s = np.cos(phi), np.sin(phi)
    out = np.empty((2, m))
    _rotated_many(c, s, delta, out)
    cl, sl, dl = c.astype(np.longdouble), s.astype(np.longdouble), delta.astype(np.longdouble)
    ref_c = cl * np.cos(dl) - sl * np.sin(dl)
    ref_s = sl * np.cos(dl) + cl * np.sin(dl)
    err = max(np.max(np.abs(out[0] - ref_c)), np.max(np.abs(out[1] - ref_s)))
    assert float(err) <= EPS / 2


def test_batch_does_not_depend_on_the_threads(monkeypatch: pytest.MonkeyPatch) -> None:
    arm = PlanarArm.paper()
    rng = np.random.default_rng(1)
    q0 = np.asarray(PAPER_Q0) + rng.normal(0, 0.05, (5, 3))
    ctrls = [FTSMC(arm, alpha=2, beta=2, p=5, q=3, k=k) for k in (10, 15, 20, 25, 30)]
    runs = []
    for threads in (1, 2, 3):
        monkeypatch.setattr(numba.config, "NUMBA_NUM_THREADS", threads)
        runs.append(simulate_batch(arm, ctrls, PaperReference(), q0=q0, t_final=0.2, dt=5e-4))
    for other in runs[1:]:
        for name in ("q", "qd", "tau", "s"):
            np.testing.assert_array_equal(getattr(other, name), getattr(runs[0], name))


def test_time_loop_does_no_reference_counting(monkeypatch: pytest.MonkeyPatch) -> None:
    """Every array the time loop touches is borrowed: no atomic increments per sample (they
    once took a fifth of the loop's time)."""
    captured: list[tuple[object, ...]] = []
    real = E.run_one

    def spy(*args: object) -> None:
        # copies: the outputs become read-only results afterwards
        captured.append(tuple(a.copy() if isinstance(a, np.ndarray) else a for a in args))
        real(*args)

    monkeypatch.setattr(E, "run_one", spy)
    arm = PlanarArm.paper()
    ctrl = FTSMC(arm, alpha=2, beta=2, p=5, q=3, k=20)
    simulate(arm, ctrl, PaperReference(), q0=PAPER_Q0, t_final=0.01, dt=5e-4)
    args = captured[0]
    # compile the per-run loop afresh (a cached one cannot show its IR)
    fresh = njit(cache=False, nogil=True, error_model="numpy")(real.py_func)
    fresh(*args)
    ir = fresh.inspect_llvm(fresh.signatures[0])
    body = next(
        f for f in re.split(r"\n(?=define )", ir) if f.startswith("define") and "run_one" in f
    )
    # a few on entry and exit at most; the loop over the samples has none
    assert body.count("@NRT_incref") <= 4
    # the law and the RK4 step, compiled on their own, are inlined into it by LLVM (a call of
    # each per sample cost 8-13 % of the paper's run), so the count above covers them too
    assert not re.search(r"call [^\n]*@[^\n(]*(sliding_mode_into|rk4_step)", body)
    # and the kernels it still calls (the powers, tanh) count no references either
    for f in re.split(r"\n(?=define )", ir):
        name = re.match(r"define [^@]*@\"?([^\"(]+)", f)
        if name and "run_one" not in name[1] and not name[1].startswith("NRT_"):
            assert f.count("@NRT_incref") == 0, name[1]


def test_paper_run_is_fast() -> None:
    arm = PlanarArm.paper()
    ctrl = FTSMC(arm, alpha=2, beta=2, p=5, q=3, k=20)
    ref = PaperReference()

    def run() -> object:
        return simulate(arm, ctrl, ref, q0=PAPER_Q0, t_final=4.5, dt=5e-4)

    run()
    times = []
    for _ in range(5):
        t0 = time.perf_counter()
        run()
        times.append(time.perf_counter() - t0)
    assert np.median(times) < 0.05  # measured ~5 ms; the target is 10 ms


def test_controller_call_is_fast() -> None:
    arm = PlanarArm.paper()
    ctrl = FTSMC(arm, alpha=2, beta=2, p=5, q=3, k=20)
    q, z = np.asarray(PAPER_Q0, dtype=float), np.zeros(3)
    for _ in range(100):
        ctrl(q, z, q, z, z)
    times = []
    for _ in range(2000):
        t0 = time.perf_counter()
        ctrl(q, z, q, z, z)
        times.append(time.perf_counter() - t0)
    assert np.median(times) < 25e-6  # measured ~2 us; the target is 5 us at the 99th percentile
