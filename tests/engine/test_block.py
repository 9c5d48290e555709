"""The block path (slidingarm._block, issue 12 points 1-2): each run of a block equals the
scalar path's run bit for bit, failures are named per run, metrics stream to the numpy ones,
and a batch does not depend on the thread count, the block size or the lane a run lands in.

One compiled block kernel (the paper's 3-joint arm, model law) serves every test of the default
run (short runs, small batches); the paper's law and other joint counts compile kernels of
their own and are marked slow. Each path is chosen by ``simulate_batch``'s ``block`` policy.
"""

from __future__ import annotations

import importlib
from collections.abc import Iterator
from typing import Any

import numba
import numpy as np
import pytest

import slidingarm as sa
from slidingarm import _block as BK
from slidingarm.metrics import METRIC_COLUMNS

S = importlib.import_module("slidingarm.simulate")

ARM = sa.PlanarArm.paper()
REF = sa.PaperReference()
DT = 5e-4
T_FINAL = 0.25
NOISE = sa.Sensor(
    noise=sa.GaussianNoise(sigma=1e-4),
    velocity=sa.sensors.DirtyDerivative(time_constant=0.005),
)
SIGNALS = ("q", "qd", "q_meas", "qd_meas", "tau", "s")


def ftsmc(switching: str, **kw: Any) -> sa.FTSMC:
    width = {} if switching == "sign" else {"width": 0.05}
    gains = {"alpha": 2, "beta": 2, "p": 5, "q": 3, "k": 20, "eps_e": 5e-8, **width, **kw}
    return sa.FTSMC(ARM, switching=switching, **gains)


def q0s(nb: int) -> np.ndarray:
    return np.asarray(sa.PAPER_Q0) + np.random.default_rng(3).normal(0.0, 0.02, (nb, 3))


def run(path: str, *args: Any, **kw: Any) -> sa.BatchResult:
    """simulate_batch on the ``path`` ("block" or "scalar"), by its ``block`` policy."""
    return sa.simulate_batch(*args, block=path == "block", **kw)


def test_the_block_policy_names_why_a_batch_cannot_take_the_block_path() -> None:
    kw: dict[str, Any] = dict(q0=sa.PAPER_Q0, t_final=0.01, dt=DT)
    serial = sa.SerialArm.from_urdf(ARM.to_urdf())
    # the plant and the law's nominal model must be of one kind, and so must all the plants
    with pytest.raises(ValueError, match="FTSMC's nominal model is not a serial arm like the plants"):
        sa.simulate_batch(serial, ftsmc("sign"), REF, block=True, **kw)
    with pytest.raises(ValueError, match="FTSMC's nominal model is not a planar arm like the plants"):
        sa.simulate_batch(ARM, sa.FTSMC(serial, alpha=2, beta=2, p=5, q=3, k=20), REF, block=True, **kw)
    with pytest.raises(ValueError, match="the plants are not all of one kind"):
        sa.simulate_batch([ARM, serial], ftsmc("sign"), REF, block=True, **kw)
    paper_law = sa.FTSMC(serial, alpha=2, beta=2, p=5, q=3, k=20, law="paper")
    with pytest.raises(ValueError, match="uses the paper's law, which is planar"):
        sa.simulate_batch(serial, paper_law, REF, block=True, **kw)
    with pytest.raises(TypeError, match="block must be True, False or None"):
        sa.simulate_batch(ARM, ftsmc("sign"), REF, block="yes", **kw)  # type: ignore[arg-type]
    # block=False keeps a large batch on the per-run loop, None takes the block path: the
    # same bits either way
    many = dict(kw, q0=q0s(S.BLOCK_MIN_RUNS))
    auto = sa.simulate_batch(ARM, ftsmc("sign"), REF, **many)
    scalar = sa.simulate_batch(ARM, ftsmc("sign"), REF, block=False, **many)
    np.testing.assert_array_equal(auto.tau, scalar.tau)


@pytest.fixture(scope="module", params=["sign", "tanh"])
def paper_pair(request: pytest.FixtureRequest) -> Iterator[tuple[sa.BatchResult, sa.BatchResult]]:
    """The paper's arm and FTSMC with noise and a dirty derivative, ``W + 4`` runs (a full
    block and a padded one), on both paths."""
    nb = BK.W + 4
    kw = dict(
        q0=q0s(nb), t_final=T_FINAL, dt=DT, sensor=NOISE, seeds=list(range(40, 40 + nb)),
    )  # fmt: skip
    ctrl = ftsmc(request.param)
    yield run("block", ARM, ctrl, REF, **kw), run("scalar", ARM, ctrl, REF, **kw)


def test_block_runs_equal_the_scalar_runs(paper_pair: tuple[sa.BatchResult, sa.BatchResult]) -> None:
    block, scalar = paper_pair
    assert np.all(block.ok) and np.all(scalar.ok)
    # the bound, and the design's: the same operations, hence the same bits
    assert np.max(np.abs(block.q - scalar.q)) <= 1e-9
    for name in SIGNALS:
        np.testing.assert_array_equal(getattr(block, name), getattr(scalar, name), err_msg=name)
    # the runs differ from one another (noise seeds, q0), so lanes were not confused
    assert np.min(np.abs(np.diff(block.q[:, -1, 0]))) > 0.0


def test_block_metrics_and_every_k_equal_the_scalar_ones() -> None:
    nb = BK.W + 4  # a full block and a padded one
    ctrls = [ftsmc("tanh", k=float(k)) for k in np.linspace(15.0, 25.0, nb)]
    kw = dict(
        q0=q0s(nb), t_final=T_FINAL, dt=DT, sensor=NOISE, seeds=list(range(nb)),
        disturbances=[[sa.SinusoidalTorque(0.5 + 0.1 * i, 3.0)] for i in range(nb)],
        torque_limit=[None if i % 3 else 40.0 for i in range(nb)],
    )  # fmt: skip
    for record in ("metrics", sa.Every(7)):
        block = run("block", ARM, ctrls, REF, record=record, **kw)
        scalar = run("scalar", ARM, ctrls, REF, record=record, **kw)
        assert block.metric_values is not None and scalar.metric_values is not None
        for name in METRIC_COLUMNS:
            a, b = block.metric_values[name], scalar.metric_values[name]
            np.testing.assert_array_equal(np.isfinite(a), np.isfinite(b), err_msg=name)
            fin = np.isfinite(b)
            np.testing.assert_allclose(a[fin], b[fin], rtol=1e-12, atol=0, err_msg=name)
        if record != "metrics":
            for name in SIGNALS:
                np.testing.assert_array_equal(getattr(block, name), getattr(scalar, name))


def test_a_failing_lane_is_named_and_the_others_finish() -> None:
    nb = 10
    qd0 = np.zeros((nb, 3))
    qd0[2] = (30.0, 0.0, 0.0)  # beyond qd_limit at the first check: runaway at sample 1
    ctrls = [ftsmc("sign") for _ in range(nb)]
    ctrls[6] = ftsmc("sign", k=1e9)  # a torque that overflows the state within a few samples
    kw = dict(q0=q0s(nb), qd0=qd0, t_final=T_FINAL, dt=DT, qd_limit=25.0, throw=False)
    block = run("block", ARM, ctrls, REF, **kw)
    scalar = run("scalar", ARM, ctrls, REF, **kw)
    assert np.flatnonzero(~block.ok).tolist() == [2, 6]
    np.testing.assert_array_equal(block.status_code, scalar.status_code)
    np.testing.assert_array_equal(block.fail_time, scalar.fail_time)
    np.testing.assert_array_equal(block.fail_joint, scalar.fail_joint)
    assert block.messages == scalar.messages
    assert block.fail_time[2] == DT  # sample 1
    for name in SIGNALS:
        np.testing.assert_array_equal(getattr(block, name), getattr(scalar, name), err_msg=name)
    with pytest.raises(sa.SimulationError, match=r"run 2 of 10"):
        run("block", ARM, ctrls, REF, **{**kw, "throw": True})
    # metrics mode: a failed lane runs on from its initial state and writes its torque trace
    # (which the spectral metric then clears); its runs' metrics are NaN, the others' those of
    # the scalar path
    block = run("block", ARM, ctrls, REF, record="metrics", **kw)
    scalar = run("scalar", ARM, ctrls, REF, record="metrics", **kw)
    assert block.metric_values is not None and scalar.metric_values is not None
    np.testing.assert_array_equal(block.status_code, scalar.status_code)
    for name in METRIC_COLUMNS:
        a, b = block.metric_values[name], scalar.metric_values[name]
        assert np.all(np.isnan(a[[2, 6]])), name
        np.testing.assert_array_equal(np.isfinite(a), np.isfinite(b), err_msg=name)
        fin = np.isfinite(b)
        np.testing.assert_allclose(a[fin], b[fin], rtol=1e-12, atol=0, err_msg=name)


def test_a_batch_does_not_depend_on_threads_blocks_or_lanes() -> None:
    nb = 3 * BK.W + 3  # four blocks: on two threads, (2, 4) makes chunks of two blocks
    ctrls = [ftsmc("sign", k=float(k)) for k in np.linspace(15.0, 25.0, nb)]
    kw = dict(t_final=T_FINAL, dt=DT, sensor=NOISE, record="metrics")
    saved = (numba.config.NUMBA_NUM_THREADS, S.BLOCK_CHUNK)
    results = []
    try:
        for threads, chunk in ((1, 1), (2, 1), (2, 4)):
            numba.config.NUMBA_NUM_THREADS = threads
            S.BLOCK_CHUNK = chunk
            results.append(run("block", ARM, ctrls, REF, q0=q0s(nb), seeds=list(range(nb)), **kw))
    finally:
        numba.config.NUMBA_NUM_THREADS, S.BLOCK_CHUNK = saved
    # the same runs at other lanes: the batch reversed, and a part of it (other padding)
    rev = run("block", ARM, ctrls[::-1], REF, q0=q0s(nb)[::-1], seeds=list(range(nb))[::-1], **kw)
    part = run("block", ARM, ctrls[5:14], REF, q0=q0s(nb)[5:14], seeds=list(range(5, 14)), **kw)
    first = results[0].metric_values
    assert first is not None
    for other in results[1:]:
        assert other.metric_values is not None
        for name in METRIC_COLUMNS:
            np.testing.assert_array_equal(other.metric_values[name], first[name], err_msg=name)
    assert rev.metric_values is not None and part.metric_values is not None
    for name in METRIC_COLUMNS:
        np.testing.assert_array_equal(rev.metric_values[name][::-1], first[name], err_msg=name)
        np.testing.assert_array_equal(part.metric_values[name], first[name][5:14], err_msg=name)


@pytest.mark.parametrize("path", ["block", "scalar"])
def test_the_threads_policy_bounds_the_threads_and_leaves_the_results_alone(path: str) -> None:
    nb = 17
    ctrls = [ftsmc("sign", k=float(k)) for k in np.linspace(15.0, 25.0, nb)]
    kw = dict(q0=q0s(nb), t_final=T_FINAL, dt=DT, sensor=NOISE, seeds=list(range(nb)))
    one = run(path, ARM, ctrls, REF, threads=1, record="metrics", **kw)
    two = run(path, ARM, ctrls, REF, threads=2, record="metrics", **kw)
    assert one.metric_values is not None and two.metric_values is not None
    for name in METRIC_COLUMNS:
        np.testing.assert_array_equal(one.metric_values[name], two.metric_values[name])
    for bad in (0, -1, 1.5, True, "2"):
        with pytest.raises(ValueError, match=r"threads must be None or an integer >= 1"):
            run(path, ARM, ctrls, REF, threads=bad, **kw)


def test_the_kernel_is_compiled_for_a_joint_count_that_is_a_positive_integer() -> None:
    from slidingarm import _block as BK

    for bad in (0, -1, 2.5, True, "3", None):
        with pytest.raises(ValueError, match=r"n must be an integer >= 1"):
            BK.compiled(paper=False, n=bad)  # type: ignore[arg-type]
    BK.compiled(paper=False, n=np.int64(3))  # type: ignore[arg-type]  # numpy integers are integers
    assert BK.joints_tag(np.int64(3)) == (0, 0, 0)  # type: ignore[arg-type]


@pytest.mark.slow  # the paper's law has a block kernel of its own (about 15 s to compile)
def test_the_papers_law_on_the_block_path_equals_the_scalar_path() -> None:
    """``law="paper"`` (eqs. 19-22: f and the diagonal of M^-1 by the nominal model's ABA per
    lane) beside ``law="model"`` in one batch, every surface and both reaching laws: the same
    bits on both paths."""
    gains = {"alpha": 2, "beta": 2, "p": 5, "q": 3, "k": 20}
    ctrls: list[sa.Controller] = [
        sa.FTSMC(ARM, switching="tanh", width=0.05, law="paper", **gains),
        sa.FTSMC(ARM, switching="sign", law="paper", **gains),
        sa.TSMC(ARM, beta=2, p=5, q=3, k=20, switching="sat", width=0.05, law="paper"),
        sa.PDSMC(ARM, lam=2, k=20, switching="tanh", width=0.05, law="paper"),
        sa.NTSMC(ARM, beta=2, p=5, q=3, k=20, switching="tanh", width=0.05, law="paper"),
        sa.FTSMC(ARM, switching="tanh", width=0.05, law="model", **gains),
    ]
    ctrls += [
        sa.FTSMC(ARM, switching="tanh", width=0.05, law="paper", reaching="super-twisting",
                 k2=20, **{**gains, "k": 5})
    ]  # fmt: skip
    nb = 3 * len(ctrls)
    kw = dict(
        q0=q0s(nb), t_final=T_FINAL, dt=DT, sensor=NOISE, seeds=list(range(nb)),
        disturbances=[[sa.SinusoidalTorque(0.5, 3.0)]] * nb,
    )  # fmt: skip
    block = run("block", ARM, ctrls * 3, REF, **kw)
    scalar = run("scalar", ARM, ctrls * 3, REF, **kw)
    assert np.all(block.ok) and np.all(scalar.ok)
    for name in SIGNALS:
        np.testing.assert_array_equal(getattr(block, name), getattr(scalar, name), err_msg=name)
    # the paper's law is not the model law: the two FTSMC-tanh runs' torques differ
    assert np.max(np.abs(block.tau[0] - block.tau[4])) > 1e-3


@pytest.mark.slow  # each joint count compiles a block kernel of its own (about 15 s each)
@pytest.mark.parametrize("n", [2, 4])
def test_other_joint_counts_on_the_block_path_equal_the_scalar_path(n: int) -> None:
    """The block kernel is compiled per joint count (the count is part of its signature): a
    2- and a 4-joint arm give the scalar path's bits, with noise, a dirty derivative, a
    disturbance and a torque limit that binds."""
    arm = sa.PlanarArm(np.linspace(1.2, 0.6, n), np.linspace(0.8, 0.4, n))
    q_end = np.linspace(0.6, -0.4, n)
    ref = sa.QuinticReference(np.zeros(n), q_end, duration=T_FINAL)
    ctrls = [
        sa.FTSMC(arm, alpha=2, beta=2, p=5, q=3, k=float(k), switching="tanh", width=0.05)
        for k in np.linspace(15.0, 25.0, 9)
    ]
    nb = len(ctrls)
    q0 = np.random.default_rng(n).normal(0.0, 0.05, (nb, n))
    kw = dict(
        q0=q0, t_final=T_FINAL, dt=DT, sensor=NOISE, seeds=list(range(nb)),
        disturbances=[[sa.SinusoidalTorque(0.5, 3.0)]] * nb,
        torque_limit=[None if i % 2 else 8.0 for i in range(nb)],
    )  # fmt: skip
    block = run("block", arm, ctrls, ref, **kw)
    scalar = run("scalar", arm, ctrls, ref, **kw)
    assert np.all(block.ok) and np.all(scalar.ok)
    assert block.q is not None and block.q.shape == (nb, scalar.q.shape[1], n)
    for name in SIGNALS:
        np.testing.assert_array_equal(getattr(block, name), getattr(scalar, name), err_msg=name)
    # the limit binds on the limited runs: their torques reach it and stay within it
    assert np.max(np.abs(block.tau[0])) == pytest.approx(8.0)
    assert np.max(np.abs(block.tau[1])) > 8.0
    if n == 2:
        # a joints tag that is not the data's joint count (here the 2-joint kernel handed the
        # paper's 3-joint arm) is refused by the kernel, not run past its workspace
        from slidingarm import _block as BK

        real = BK.joints_tag
        BK.joints_tag = lambda m: real(2)  # type: ignore[assignment]
        try:
            with pytest.raises(ValueError, match="one entry per joint"):
                run("block", ARM, ftsmc("sign"), REF, q0=q0s(16), t_final=T_FINAL, dt=DT)
        finally:
            BK.joints_tag = real  # type: ignore[assignment]


def test_the_blocks_spectral_share_equals_the_metrics_one_on_hard_series() -> None:
    """hf_power_share of a block's traces (detrended in place in two passes, sums shifted by
    the first sample) against slidingarm.metrics' numpy formulas: a large mean (5e6) under a small
    fluctuation, a steep trend, a constant (flat: 0) and a straight line (flat: 0)."""
    from slidingarm import metrics as M

    t = np.arange(4001) * DT
    rng = np.random.default_rng(11)
    runs, n = 4, 3
    tau = rng.normal(size=(runs, t.size, n)) * np.array([1e-3, 1.0, 30.0])
    tau += 5e6 + 40.0 * t[:, None] + 3.0 * np.sin(2 * np.pi * 70.0 * t)[:, None]
    tau[1, :, 0] = 7.25
    tau[2, :, 1] = -3.0 + 12.5 * t
    expected = M.hf_power_share(t, tau)
    work = BK.SpectrumWork(runs, t.size, n)
    work.trace[:] = np.swapaxes(tau[:, :-1], 1, 2)
    got = BK.hf_power_share(t, work.trace[:runs], 50.0, work=work)
    assert got[1, 0] == 0.0 and got[2, 1] == 0.0
    assert expected[1, 0] == 0.0 and expected[2, 1] == 0.0
    np.testing.assert_allclose(got, expected, rtol=1e-11, atol=0)
    # the residual left in place is the least-squares one: orthogonal to 1 and to t
    # (to the rounding of the samples themselves, eps of their magnitude each)
    resid = work.trace[0]
    ta = t[:-1] - t[:-1].mean()
    size = np.abs(tau[0, :-1]).T
    eps = np.finfo(float).eps
    assert np.all(np.abs(resid.sum(axis=-1)) <= 4 * eps * size.sum(axis=-1))
    assert np.all(np.abs(resid @ ta) <= 4 * eps * (size @ np.abs(ta)))


def test_a_series_spectrum_does_not_depend_on_its_block() -> None:
    """BK._spectra (ducc0's r2c) is numpy's rfft to rounding, and a series' spectrum is the
    same bits whatever the block around it: any number of runs (odd series counts too, which
    ducc0 would finish one at a time), at any row, through a block's buffer or without one."""
    rng = np.random.default_rng(5)
    n, nn = 3, 4001
    series = rng.normal(size=(BK.W, n, nn)) * 30.0 + 5.0
    work = BK.SpectrumWork(BK.W, nn + 1, n)
    work.trace[:] = series
    full = BK._spectra(work.trace, work).copy()
    ref = np.fft.rfft(series, axis=-1)
    assert np.max(np.abs(full - ref)) <= 1e-14 * np.max(np.abs(ref))
    for runs in (1, 2, 3, 5, 16):
        rows = rng.choice(BK.W, runs, replace=False)
        work.trace[:runs] = series[rows]
        np.testing.assert_array_equal(BK._spectra(work.trace[:runs], work), full[rows])
        np.testing.assert_array_equal(BK._spectra(series[rows], None), full[rows])


def test_the_kernels_rk4_step_is_the_one_compiled_before_it() -> None:
    """compiled() compiles the RK4 step (the articulated-body passes) at LLVM's own choice
    before the kernel, whose other lane loops it interleaves (BK._interleaved): the kernel must
    link that compiled step, not type a second one of its own (which would then be compiled
    interleaved, and spill), so the step has one signature per joint count."""
    run("block", ARM, ftsmc("sign"), REF, q0=q0s(16), t_final=0.01, dt=DT, record="metrics")
    counts = [len(sig[1]) for sig in BK._rk4.signatures]
    assert 3 in counts
    assert len(counts) == len(set(counts)), BK._rk4.signatures


def test_the_spectral_passes_run_as_compiled_with_the_slp_vectoriser() -> None:
    """BK.spectral_compiled compiles the detrending and the power sums for the arrays
    hf_power_share passes, with the SLP vectoriser on: a block's metrics must run those
    (one signature each), not a second specialisation numba would compile lazily without it
    (the same bits, at 2.6 times the time)."""
    run("block", ARM, ftsmc("sign"), REF, q0=q0s(16), t_final=0.01, dt=DT, record="metrics")
    assert len(BK._detrend.signatures) == 1, BK._detrend.signatures
    assert len(BK._power_sums.signatures) == 1, BK._power_sums.signatures


def test_interleaving_is_on_only_inside_its_context() -> None:
    """BK._interleaved sets a process-wide LLVM option for one compilation: a loop compiled
    inside it is interleaved (four divisions a vector iteration where LLVM's own choice makes
    one), and one compiled after it is as one compiled before it."""
    from numba import njit

    from slidingarm import _vecmath as VM

    def divisions() -> int:
        @njit(nogil=True, error_model="numpy")
        def logs(x: np.ndarray, out: np.ndarray) -> None:
            for i in range(x.shape[0]):
                out[i] = VM.log(x[i])

        x = np.linspace(0.5, 2.0, 64)
        logs(x, np.empty_like(x))
        return int(logs.inspect_asm(logs.signatures[0]).count("vdivpd"))

    before = divisions()
    with BK._interleaved():
        inside = divisions()
    after = divisions()
    assert inside >= 4 * before > 0
    assert after == before
