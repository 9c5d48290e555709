"""Tests for slidingarm.study.analysis: the post-transient metrics and the chattering table on
synthetic runs, the one way of running a setup's controllers, the scenario kinds and the
paper's ranking."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from slidingarm.config import Setup, load_scenario
from slidingarm.metrics import chattering
from slidingarm.results import SimResult
from slidingarm.simulate import SimulationError, simulate
from slidingarm.study import SCENARIOS, load_shipped
from slidingarm.study import analysis as A
from slidingarm.study.reproduce import scenario_kind

DT = 1e-3
T = 1001  # 1 s


def _run(
    tau: np.ndarray, *, e: float = 1e-9, s: float = 0.0, params: dict | None = None
) -> SimResult:
    t = np.arange(T) * DT
    zeros = np.zeros((T, tau.shape[1]))
    q_ref = np.ones_like(zeros)
    return SimResult(
        t=t,
        q=q_ref + e,
        qd=zeros,
        q_ref=q_ref,
        qd_ref=zeros,
        q_meas=q_ref + e,
        qd_meas=zeros,
        tau=tau,
        s=np.full_like(zeros, s),
        params=params or {},
    )


def _terminal(beta: float = 2.0, gamma: float = 0.6, eps_e: float = 1e-9) -> dict:
    return {
        "dt": DT,
        "controller": {
            "controller": "tsmc",
            "surface": "fast_terminal",
            "beta": beta,
            "gamma": gamma,
            "eps_e": eps_e,
        },
    }


def test_late_metrics_of_a_torque_flipping_every_sample() -> None:
    k = np.arange(T)
    smooth = np.sin(2 * np.pi * k * DT)
    # a smooth torque for the first half, then +-1 about it at every sample
    flip = np.where(k >= T // 2, np.where(k % 2 == 0, 1.0, -1.0), 0.0)
    tau = np.stack([smooth, smooth + flip], axis=1)
    late = A.late_metrics(_run(tau), fraction=0.5)
    k0 = T // 2
    assert late["alternation_late"][0] == pytest.approx(0.0, abs=0.01)
    assert late["alternation_late"][1] == pytest.approx(1.0)
    assert late["max_step_late"][1] == pytest.approx(2.0, rel=0.01)
    # the window's total variation per second, as slidingarm.metrics defines chattering
    t = np.arange(T) * DT
    np.testing.assert_allclose(late["chattering_late"], chattering(t[k0:], tau[k0:]))
    assert late["chattering_late"][1] == pytest.approx(2.0 / DT, rel=0.01)
    # the first half does not count
    assert late["chattering_late"][0] < 0.5 * float(chattering(t, tau)[1])


def test_late_terminal_gain_is_the_formula_and_absent_without_terminal_term() -> None:
    tau = np.zeros((T, 2))
    e = 1e-8
    late = A.late_metrics(_run(tau, e=e, s=0.03, params=_terminal()))
    expected = 2.0 * 0.6 * e ** (0.6 - 1.0) * DT
    np.testing.assert_allclose(late["terminal_gain_late"], expected, rtol=1e-6)
    np.testing.assert_allclose(late["s_rms_late"], 0.03)
    # the guard: below eps_e the gain is evaluated at eps_e
    guarded = A.late_metrics(_run(tau, e=1e-12, params=_terminal(eps_e=1e-9)))
    np.testing.assert_allclose(guarded["terminal_gain_late"], 1.2 * 1e-9 ** (-0.4) * DT, rtol=1e-6)
    assert np.isnan(A.late_metrics(_run(tau))["terminal_gain_late"]).all()
    pd_params = {
        "controller": {"controller": "pdsmc", "surface": "fast_terminal", "beta": 0.0, "gamma": 0.5}
    }
    assert np.isnan(A.late_metrics(_run(tau, params=pd_params))["terminal_gain_late"]).all()
    with pytest.raises(ValueError, match="fraction"):
        A.late_metrics(_run(tau), fraction=0.0)


def test_metrics_and_chattering_tables_carry_the_late_columns() -> None:
    k = np.arange(T)
    flip = np.where(k % 2 == 0, 1.0, -1.0)
    sign = _run(np.stack([flip, 2 * flip], axis=1), params=_terminal())
    smooth = _run(np.zeros((T, 2)) + 0.5 * k[:, None] * DT, params=_terminal())
    metrics = A.metrics_table({"sign": {"tsmc": sign}, "tanh": {"tsmc": smooth}})
    assert list(metrics.columns[-len(A.LATE_COLUMNS) :]) == list(A.LATE_COLUMNS)
    mean = metrics[metrics.joint == "mean"].set_index("scenario")
    per_joint = metrics[metrics.joint != "mean"]
    for column in A.LATE_COLUMNS:
        for scenario in ("sign", "tanh"):
            values = per_joint[per_joint.scenario == scenario][column]
            assert mean.loc[scenario, column] == pytest.approx(values.mean())
    table = A.chattering_table(metrics).set_index("controller")
    assert table.loc["tsmc", "sign_alternation_late"] == pytest.approx(1.0)
    assert table.loc["tsmc", "tanh_alternation_late"] == pytest.approx(0.0)
    assert table.loc["tsmc", "sign_step_late"] == pytest.approx(4.0)  # the larger joint's step
    assert table.loc["tsmc", "sign_late"] == pytest.approx(mean.loc["sign", "chattering_late"])
    assert table.loc["tsmc", "ratio"] == pytest.approx(
        table.loc["tsmc", "sign"] / table.loc["tsmc", "tanh"]
    )


def test_chattering_table_without_late_columns_is_nan() -> None:
    rows = [
        {"scenario": sc, "controller": "pdsmc", "joint": "mean", "chattering": v}
        for sc, v in (("sign", 100.0), ("tanh", 1.0))
    ]
    table = A.chattering_table(pd.DataFrame(rows))
    assert table.loc[0, "ratio"] == pytest.approx(100.0)
    assert math.isnan(table.loc[0, "tanh_late"]) and math.isnan(table.loc[0, "sign_gain_late"])


# ---------------------------------------------------------------------------- running

WILD = """
extends = "{base}"
name = "short"

[simulation]
t_final = 0.25

[[controllers]]
name = "pdsmc"

[[controllers]]
name = "ftsmc"
label = "wild"
law = "paper"
k = 1e6

[[controllers]]
name = "tsmc"

[[controllers]]
name = "ftsmc"
label = "wilder"
law = "paper"
k = 2e6
"""

SIGNALS = ("q", "qd", "q_ref", "qd_ref", "q_meas", "qd_meas", "tau", "s")


def _short(tmp_path: Path, shipped: str, text: str = "") -> Setup:
    base = load_shipped(shipped).source
    assert base is not None
    path = tmp_path / f"{shipped}_short.toml"
    head = f'extends = "{base.as_posix()}"\nname = "short"\n\n[simulation]\nt_final = 0.25\n'
    path.write_text(text.format(base=base.as_posix()) if text else head, encoding="utf-8")
    return load_scenario(path).build()


def _same(a: SimResult, b: SimResult) -> bool:
    return (
        all(np.array_equal(getattr(a, name), getattr(b, name)) for name in SIGNALS)
        and np.array_equal(a.t, b.t)
        and a.params == b.params
        and a.seed == b.seed
    )


@pytest.mark.parametrize("shipped", ["sign", "noise"])
def test_simulate_setup_is_each_run_alone_bit_for_bit(tmp_path: Path, shipped: str) -> None:
    """The batch of a setup's controllers gives, run by run, exactly what `simulate` gives for
    that controller alone with the setup's seed (the noise scenario: the same noise too)."""
    setup = _short(tmp_path, shipped)
    results = A.simulate_setup(setup)
    assert list(results) == list(setup.controllers)
    opts = setup.options()
    for label, controller in setup.controllers.items():
        alone = simulate(setup.plant, controller, setup.reference, **opts)
        assert _same(results[label], alone), label
    # a subset, by label
    some = A.simulate_setup(setup, {"x": setup.controllers["ftsmc"]})
    assert list(some) == ["x"] and _same(some["x"], results["ftsmc"])


def test_simulate_setup_diverging_runs(tmp_path: Path) -> None:
    setup = _short(tmp_path, "sign", WILD)
    recorded = A.simulate_setup(setup, on_diverge="record")
    assert list(recorded) == ["pdsmc", "wild", "tsmc", "wilder"]
    opts = setup.options()
    for label in ("wild", "wilder"):
        message = recorded[label]
        assert isinstance(message, str)
        with pytest.raises(SimulationError) as alone:
            simulate(setup.plant, setup.controllers[label], setup.reference, **opts)
        assert message == str(alone.value)  # the run's own words, not the batch's
    for label in ("pdsmc", "tsmc"):
        run = recorded[label]
        assert isinstance(run, SimResult)
        assert _same(run, simulate(setup.plant, setup.controllers[label], setup.reference, **opts))
    with pytest.raises(SimulationError, match=r"scenario 'short', controller 'wild': .*diverged"):
        A.simulate_setup(setup)
    with pytest.raises(ValueError, match="on_diverge"):
        A.simulate_setup(setup, on_diverge="ignore")  # type: ignore[call-overload]


def test_scenario_kind_from_switching_and_sensor() -> None:
    assert {name: scenario_kind(load_shipped(name)) for name in SCENARIOS} == {
        "sign": "sign",
        "tanh": "tanh",
        "noise": "noise",
    }
    noise = load_shipped("noise")
    assert scenario_kind(noise.model_copy(update={"switching": "sign"})) is None
    assert scenario_kind(noise.model_copy(update={"switching": "sat"})) is None
    quiet = noise.sensor.model_copy(update={"noise": None})
    assert scenario_kind(noise.model_copy(update={"sensor": quiet})) == "tanh"


def test_ranking_is_one_definition() -> None:
    rows = [
        {"scenario": "s", "controller": c, "joint": j, "mse": v}
        for c, v in (("pdsmc", 3.0), ("ftsmc", 1.0), ("tsmc", 2.0), ("ntsmc", 0.5))
        for j in ("1", "mean")
    ]
    metrics = pd.DataFrame(rows)
    values = A.ranking_mse(metrics, "s", "mean")
    assert list(values) == list(A.RANKING) and values["ftsmc"] == 1.0
    assert A.follows_ranking(values)
    assert not A.follows_ranking({**values, "tsmc": 0.9})
    assert A.follows_ranking({"ftsmc": 1.0, "pdsmc": 3.0})  # only those given are compared
    assert not A.follows_ranking({**values, "tsmc": math.nan})
    assert A.ranking_mse(metrics, "other") == {}
