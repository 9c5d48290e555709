"""Tests for slidingarm.study.analysis on synthetic runs: the post-transient metrics and the
chattering table built from them."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from slidingarm.metrics import chattering
from slidingarm.results import SimResult
from slidingarm.study import analysis as A

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
