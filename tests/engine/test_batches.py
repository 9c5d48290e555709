"""Monte Carlo batches: record policies, per-run status, per-run inputs, seed streams."""

from __future__ import annotations

import sys
import tracemalloc
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import slidingarm as sa
from slidingarm.metrics import METRIC_COLUMNS, summary

sys.path.insert(0, str(Path(__file__).parents[1]))
from _numerics import rk4

ARM = sa.PlanarArm.paper()
REF = sa.PaperReference()
DT = 5e-4


def ftsmc(**kw: object) -> sa.FTSMC:
    return sa.FTSMC(ARM, **{"alpha": 2, "beta": 2, "p": 5, "q": 3, "k": 20, **kw})  # type: ignore[arg-type]


def _mixed_batch(record: object, nb: int = 6, t_final: float = 1.0) -> sa.BatchResult:
    rng = np.random.default_rng(7)
    plants = [sa.ModelMismatch(payload=float(p)).apply(ARM) for p in rng.uniform(0, 1, nb)]
    ctrls = [ftsmc(k=float(k), switching="tanh") for k in rng.uniform(10, 30, nb)]
    sensors = [sa.Sensor(noise=sa.GaussianNoise(float(s))) for s in rng.uniform(1e-5, 1e-3, nb)]
    q0 = np.asarray(sa.PAPER_Q0) + rng.normal(0, 0.02, (nb, 3))
    return sa.simulate_batch(
        plants, ctrls, REF, q0=q0, t_final=t_final, dt=DT, sensor=sensors,
        disturbances=[[sa.SinusoidalTorque(float(a), 2.0)] for a in rng.uniform(0, 1, nb)],
        torque_limit=[None if i % 2 else 100.0 + i for i in range(nb)],
        seeds=list(range(10, 10 + nb)), record=record,  # type: ignore[arg-type]
    )  # fmt: skip


def test_metrics_mode_equals_summary_of_the_full_traces() -> None:
    full = _mixed_batch("full")
    only = _mixed_batch("metrics")
    assert only.q is None and only.record == "metrics"
    expected = summary(full)
    got = only.metrics()
    assert list(got.columns) == list(expected.columns) == ["run", "joint", *METRIC_COLUMNS]
    assert got["joint"].tolist() == expected["joint"].tolist()
    for col in METRIC_COLUMNS:
        a, b = got[col].to_numpy(), expected[col].to_numpy()
        finite = np.isfinite(b)
        np.testing.assert_array_equal(np.isfinite(a), finite)
        np.testing.assert_allclose(a[finite], b[finite], rtol=1e-12, atol=0)
    # full mode gives the same table from its traces
    pd.testing.assert_frame_equal(full.metrics(), expected)


def test_every_k_keeps_every_kth_sample_and_the_full_metrics() -> None:
    full = _mixed_batch("full")
    sub = _mixed_batch(sa.Every(7))
    np.testing.assert_array_equal(sub.t, full.t[::7])
    for name in ("q", "qd", "q_ref", "q_meas", "qd_meas", "tau", "s"):
        np.testing.assert_array_equal(getattr(sub, name), getattr(full, name)[:, ::7])
    np.testing.assert_allclose(
        sub.metrics()[list(METRIC_COLUMNS)].to_numpy(),
        full.metrics()[list(METRIC_COLUMNS)].to_numpy(),
        rtol=1e-12,
    )


def test_per_run_inputs_equal_single_runs() -> None:
    """Noise, disturbance, torque limit, plant, controller and q0 vary per run in one batch;
    each run equals the same run simulated alone, bit for bit."""
    nb = 4
    batch = _mixed_batch("full", nb=nb, t_final=0.3)
    rng = np.random.default_rng(7)
    payload = rng.uniform(0, 1, nb)
    ks = rng.uniform(10, 30, nb)
    sigmas = rng.uniform(1e-5, 1e-3, nb)
    q0 = np.asarray(sa.PAPER_Q0) + rng.normal(0, 0.02, (nb, 3))
    amps = rng.uniform(0, 1, nb)
    for b in range(nb):
        one = sa.simulate(
            sa.ModelMismatch(payload=float(payload[b])).apply(ARM),
            ftsmc(k=float(ks[b]), switching="tanh"), REF, q0=q0[b], t_final=0.3, dt=DT,
            sensor=sa.Sensor(noise=sa.GaussianNoise(float(sigmas[b]))),
            disturbances=[sa.SinusoidalTorque(float(amps[b]), 2.0)],
            torque_limit=None if b % 2 else 100.0 + b, seed=10 + b,
        )  # fmt: skip
        np.testing.assert_array_equal(one.q, batch.q[b])
        np.testing.assert_array_equal(one.tau, batch.tau[b])
        assert one.params == batch.params[b]


def test_a_diverging_run_is_recorded_and_the_others_finish() -> None:
    kick = [sa.ConstantTorque((0.0, 0.0, 1e7), t_start=0.25)]
    dists = [[], kick, []]
    for record in ("full", "metrics"):
        batch = sa.simulate_batch(
            ARM, ftsmc(), REF, q0=sa.PAPER_Q0, t_final=0.5, dt=DT, disturbances=dists,
            throw=False, record=record,  # type: ignore[arg-type]
        )  # fmt: skip
        assert batch.ok.tolist() == [True, False, True]
        assert batch.status == ["ok", "runaway", "ok"]
        assert batch.message[0] == batch.message[2] == ""
        assert "joint velocity ran away" in batch.message[1] and "t = 0.2505 s" in batch.message[1]
        assert batch.fail_time[1] == pytest.approx(0.2505) and np.isinf(batch.fail_time[0])
        m = batch.metrics()
        failed = m[m.run == 1][list(METRIC_COLUMNS)].to_numpy()
        assert np.all(np.isnan(failed)), "a failed run has no metric that looks valid"
        good = m[m.run != 1][list(METRIC_COLUMNS)].to_numpy()
        assert not np.any(np.isnan(good)), "an ok run has no NaN"
        runs = batch.runs()
        assert runs["status"].tolist() == ["ok", "runaway", "ok"]
        if record == "full":
            assert not np.any(np.isnan(batch.q[[0, 2]]))
            k = int(np.searchsorted(batch.t, 0.2505))
            assert np.all(np.isnan(batch.q[1, k:])) and not np.any(np.isnan(batch.q[1, :k]))
            single = sa.simulate(ARM, ftsmc(), REF, q0=sa.PAPER_Q0, t_final=0.5, dt=DT)
            np.testing.assert_array_equal(batch.q[0], single.q)
    with pytest.raises(sa.SimulationError, match=r"\(run 1 of 3\)"):
        sa.simulate_batch(ARM, ftsmc(), REF, q0=sa.PAPER_Q0, t_final=0.5, dt=DT, disturbances=dists)


def test_a_single_run_can_report_instead_of_raising() -> None:
    kick = [sa.ConstantTorque((0.0, 0.0, 1e7), t_start=0.25)]
    r = sa.simulate(ARM, ftsmc(), REF, q0=sa.PAPER_Q0, t_final=0.5, dt=DT, disturbances=kick,
                    throw=False)  # fmt: skip
    assert not r.success and r.status == "runaway" and "at t = 0.2505 s, joint 1" in r.message
    ok = sa.simulate(ARM, ftsmc(), REF, q0=sa.PAPER_Q0, t_final=0.05, dt=DT)
    assert ok.success and ok.message == ""


def test_adding_a_random_component_leaves_the_other_streams_alone() -> None:
    sensor = sa.Sensor(noise=sa.GaussianNoise(1e-3))
    kw = dict(q0=sa.PAPER_Q0, t_final=0.2, dt=DT, sensor=sensor, seed=42)
    alone = sa.simulate(ARM, ftsmc(), REF, **kw)
    with_torque = sa.simulate(ARM, ftsmc(), REF, disturbances=[sa.RandomTorque(0.5)], **kw)
    # the first measurement is q0 + the first noise draw in both runs; the noise stream is the
    # root's, exactly numpy's default_rng(seed)
    noise = np.random.default_rng(42).standard_normal((alone.t.shape[0], 3)) * 1e-3
    first = np.asarray(sa.PAPER_Q0) + noise[0]
    np.testing.assert_array_equal(alone.q_meas[0], first)
    np.testing.assert_array_equal(with_torque.q_meas[0], first)
    # a second random disturbance does not change the first one's draws
    a = sa.RandomTorque(0.5)
    d1 = a.torque(alone.t, 3, np.random.default_rng(np.random.SeedSequence(42, spawn_key=(0,))))
    two = sa.simulate(ARM, ftsmc(), REF, disturbances=[a, sa.RandomTorque(0.2)],
                      q0=sa.PAPER_Q0, t_final=0.2, dt=DT, seed=42)  # fmt: skip
    one = sa.simulate(ARM, ftsmc(), REF, disturbances=[a], q0=sa.PAPER_Q0, t_final=0.2, dt=DT,
                      seed=42)  # fmt: skip
    assert not np.array_equal(two.q, one.q)
    # the plant got tau + d1 under the single disturbance: check the first step's input
    q1, _ = rk4(ARM, one.q[0], one.qd[0], one.tau[0] + d1[0], DT)
    np.testing.assert_allclose(q1, one.q[1], rtol=0, atol=1e-13)


def test_to_dataframe_is_long_and_carries_the_status() -> None:
    batch = sa.simulate_batch(ARM, [ftsmc(), ftsmc(k=10)], REF, q0=sa.PAPER_Q0, t_final=0.01,
                              dt=DT)  # fmt: skip
    df = batch.to_dataframe()
    assert len(df) == 2 * 21 * 3
    assert {"run", "t", "joint", "q", "tau", "s", "seed", "ok", "status"} <= set(df.columns)
    np.testing.assert_array_equal(df[(df.run == 1) & (df.joint == 2)]["q"], batch.q[1, :, 1])
    metrics = sa.simulate_batch(ARM, ftsmc(), REF, q0=sa.PAPER_Q0, t_final=0.01, dt=DT,
                                record="metrics").to_dataframe()  # fmt: skip
    assert len(metrics) == 4 and metrics["ok"].all()
    with pytest.raises(ValueError, match=r"record='metrics' and holds no signals"):
        sa.simulate_batch(ARM, ftsmc(), REF, q0=sa.PAPER_Q0, t_final=0.01, dt=DT,
                          record="metrics")[0]  # fmt: skip


def test_bad_record_and_throw_are_refused() -> None:
    with pytest.raises(ValueError, match=r"record must be 'full', 'metrics' or Every\(k\)"):
        sa.simulate_batch(ARM, ftsmc(), REF, q0=sa.PAPER_Q0, t_final=0.01, dt=DT, record="all")  # type: ignore[arg-type]
    with pytest.raises(TypeError, match=r"throw must be True or False"):
        sa.simulate_batch(ARM, ftsmc(), REF, q0=sa.PAPER_Q0, t_final=0.01, dt=DT, throw=1)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"Every\(k\): k must be an integer >= 1"):
        sa.Every(0)
    with pytest.raises(TypeError, match=r"Every\(k\): k must be an integer >= 1"):
        sa.Every(2.0)  # type: ignore[arg-type]


def test_metrics_at_a_step_too_coarse_for_their_spectrum_are_refused_before_running(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """hf_power_share's 50 Hz cut-off needs dt < 0.01 s: a metrics batch at dt = 0.02 s is
    refused up front, naming dt, without running a single step (it used to raise after the
    whole batch); record='full' at that step still runs."""
    import slidingarm._engine as E

    def never(*args: object, **kw: object) -> None:
        raise AssertionError("the batch ran")

    monkeypatch.setattr(E, "run_one", never)
    for record in ("metrics", sa.Every(2)):
        with pytest.raises(ValueError, match=r"needs dt < 0\.01 s .*got dt = 0\.02 s"):
            sa.simulate_batch(ARM, ftsmc(), REF, q0=sa.PAPER_Q0, t_final=0.2, dt=0.02, record=record)
    monkeypatch.undo()
    full = sa.simulate_batch(ARM, ftsmc(), REF, q0=sa.PAPER_Q0, t_final=0.2, dt=0.02)
    assert full.q.shape == (1, 11, 3)


def test_a_batch_too_large_for_memory_is_refused_before_allocating() -> None:
    with pytest.raises(MemoryError, match=r"use record='metrics'"):
        sa.simulate_batch(ARM, ftsmc(), REF, q0=np.zeros((100_000, 3)), t_final=4.5, dt=DT)


def test_metrics_mode_memory_does_not_grow_with_the_batch() -> None:
    """The traces live only per chunk: the peak of traced allocations for 128 runs is not
    larger than for 32 (both keep every thread busy; plus the O(B n) metrics), and far below
    what 'full' keeps."""

    def peak(nb: int) -> int:
        tracemalloc.start()
        sa.simulate_batch(ARM, ftsmc(), REF, q0=np.tile(sa.PAPER_Q0, (nb, 1)), t_final=1.0,
                          dt=DT, record="metrics", sensor=sa.Sensor(noise=sa.GaussianNoise(1e-4)),
                          seeds=list(range(nb)))  # fmt: skip
        _, top = tracemalloc.get_traced_memory()
        tracemalloc.stop()
        return top

    small, large = peak(32), peak(128)
    full = 6 * 128 * 2001 * 3 * 8
    assert large < 1.3 * small + 2e6
    assert large < full / 2


def test_per_run_inputs_name_their_mistakes() -> None:
    kw = dict(q0=sa.PAPER_Q0, t_final=0.01, dt=DT)
    with pytest.raises(TypeError, match=r"^disturbances must be torque disturbances .*got str"):
        sa.simulate_batch(ARM, ftsmc(), REF, disturbances=[[sa.ConstantTorque(1.0)], ["x"]], **kw)
    with pytest.raises(TypeError, match=r"^torque_limit must be numbers, got str 'a'$"):
        sa.simulate_batch(ARM, ftsmc(), REF, torque_limit=[None, "a"], **kw)
    with pytest.raises(ValueError, match=r"^torque_limit must be > 0 N m"):
        sa.simulate_batch(ARM, ftsmc(), REF, torque_limit=[None, -1.0], **kw)
    with pytest.raises(TypeError, match=r"^sensor must be a Sensor \(or a sequence of them\), got int$"):
        sa.simulate_batch(ARM, ftsmc(), REF, sensor=[sa.Sensor(), 3], **kw)
    with pytest.raises(ValueError, match=r"batch sizes differ: .*sensors 2, .*seeds 3"):
        sa.simulate_batch(ARM, ftsmc(), REF, sensor=[sa.Sensor()] * 2, seeds=[1, 2, 3], **kw)


class _Stuck(sa.SteppedPlant):
    """A Python plant whose mass matrix goes singular at its third step."""

    def __init__(self) -> None:
        self.inner = sa.SteppedArm(ARM)
        self.calls = 0

    @property
    def n(self) -> int:
        return 3

    def step(self, q: np.ndarray, qd: np.ndarray, tau: np.ndarray, h: float) -> bool:
        self.calls += 1
        return self.calls < 3 and self.inner.step(q, qd, tau, h)

    def to_dict(self) -> dict[str, object]:
        return {"stuck": True}


def test_a_stepped_plant_that_fails_is_reported_as_singular() -> None:
    r = sa.simulate(_Stuck(), ftsmc(), REF, q0=sa.PAPER_Q0, t_final=0.01, dt=DT, throw=False)
    assert r.status == "singular" and "positive definite" in r.message
    assert np.all(np.isnan(r.q[3:])) and not np.any(np.isnan(r.q[:3]))


def test_the_checker_refuses_what_is_not_a_controller_or_a_model() -> None:
    with pytest.raises(TypeError, match=r"^controller must be a Controller, got str$"):
        sa.check_controller("ftsmc", ARM)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match=r"^model must be an ArmModel, got NoneType$"):
        sa.check_controller(ftsmc(), None)  # type: ignore[arg-type]
