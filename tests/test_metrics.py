"""Tests for slidingarm.metrics: closed forms, batch shapes, validation and the summary table.

Each tolerance is derived next to its test. The recurring ones:

- trapezoid rule on a smooth f with step h: error = h²/12 (f'(b) - f'(a)) + O(h⁴), so the tests
  allow 1.01 times that leading term plus round-off;
- linear interpolation of a convex decreasing f between samples crosses a level later than f
  by at most h² max|f''| / (8 min|f'|), which for A e^{-λt} is h² λ / 8;
- sums of sin²/cos² and of |Δ sin| over whole sampled periods are exact identities, so those
  results match to round-off (1e-12 relative).
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import slidingarm.metrics as M
from slidingarm.metrics import (
    DEFAULT_CUTOFF_HZ,
    DEFAULT_DELTA_E,
    DEFAULT_DELTA_S,
    DEFAULT_WINDOW,
    METRIC_COLUMNS,
    chattering,
    control_effort,
    final_error,
    hf_power_share,
    iae,
    itae,
    mse,
    peak_torque,
    reaching_time,
    rmse,
    settling_time,
    steady_state_error,
    summary,
)
from slidingarm.results import SIGNALS, BatchResult, FloatArray, SimResult

#: The paper's sample time and horizon (SPEC §2): 9001 samples, 9000 applied torques.
DT = 5e-4
T_FINAL = 4.5
T_PAPER = np.arange(9001) * DT

# Exponential decays, one per joint: e_i = A_i exp(-λ_i t) on a fine grid.
H = 1e-4
T_EXP = np.arange(20001) * H  # 0 .. 2 s
A_EXP = np.array([1.0, -0.4, 0.75])
LAM_EXP = np.array([4.0, 5.0, 8.0])  # all below 1e-3 by t = 2 s
E_EXP = A_EXP * np.exp(-np.outer(T_EXP, LAM_EXP))


def test_defaults_are_the_documented_values() -> None:
    assert DEFAULT_DELTA_S == 2e-2
    assert DEFAULT_DELTA_E == 1e-3
    assert DEFAULT_WINDOW == 0.5
    assert DEFAULT_CUTOFF_HZ == 50.0


# ---------------------------------------------------------------------------- tracking
def test_mse_and_rmse_of_exponential_match_geometric_sum() -> None:
    # mean_k A² r^k with r = exp(-2 λ h) over N samples is A² (1 - r^N) / (N (1 - r)) exactly.
    n_samples = T_EXP.shape[0]
    r = np.exp(-2.0 * LAM_EXP * H)
    exact = A_EXP**2 * (1.0 - r**n_samples) / (n_samples * (1.0 - r))
    np.testing.assert_allclose(mse(E_EXP), exact, rtol=1e-10)
    np.testing.assert_allclose(rmse(E_EXP), np.sqrt(exact), rtol=1e-10)
    # And the continuous mean A²(1 - e^{-2λT}) / (2 λ T) within the O(h) of a left sum.
    T = T_EXP[-1]
    cont = A_EXP**2 * (1.0 - np.exp(-2 * LAM_EXP * T)) / (2 * LAM_EXP * T)
    np.testing.assert_allclose(mse(E_EXP), cont, rtol=1.1 * float(np.max(LAM_EXP)) * H)


def test_iae_of_exponential_matches_closed_form_to_trapezoid_error() -> None:
    T = T_EXP[-1]
    a, lam = np.abs(A_EXP), LAM_EXP
    exact = a / lam * (1.0 - np.exp(-lam * T))
    # f = a e^{-λt}: f'(T) - f'(0) = a λ (1 - e^{-λT}); trapezoid overestimates a convex f.
    lead = H**2 / 12.0 * a * lam * (1.0 - np.exp(-lam * T))
    err = iae(T_EXP, E_EXP) - exact
    assert np.all(err > 0.0)
    np.testing.assert_allclose(err, lead, rtol=0.01, atol=1e-14)


def test_itae_of_exponential_matches_closed_form_to_trapezoid_error() -> None:
    T = T_EXP[-1]
    a, lam = np.abs(A_EXP), LAM_EXP
    exact = a / lam**2 * (1.0 - np.exp(-lam * T) * (1.0 + lam * T))
    # g = a t e^{-λt}, g' = a e^{-λt} (1 - λt): error h²/12 (g'(T) - g'(0)).
    lead = H**2 / 12.0 * (a * np.exp(-lam * T) * (1.0 - lam * T) - a)
    err = itae(T_EXP, E_EXP) - exact
    np.testing.assert_allclose(err, lead, rtol=0.01, atol=1e-14)


def test_itae_measures_time_from_the_start_of_the_run() -> None:
    shifted = itae(T_EXP + 10.0, E_EXP)
    np.testing.assert_allclose(shifted, itae(T_EXP, E_EXP), rtol=1e-9)


def test_iae_uses_the_actual_nonuniform_grid() -> None:
    # |e| = 1 on any grid integrates to the duration exactly.
    t = np.array([0.0, 0.1, 0.15, 0.7, 2.0])
    np.testing.assert_allclose(iae(t, -np.ones((5, 2))), [2.0, 2.0], rtol=1e-15)


# ---------------------------------------------------------------------------- convergence
def test_settling_time_of_exponential_is_log_ratio_within_interpolation_error() -> None:
    delta = 1e-3
    exact = np.log(np.abs(A_EXP) / delta) / LAM_EXP
    got = settling_time(T_EXP, E_EXP, delta_e=delta)
    # Within one sample (the brief), and within h² λ / 8 (linear interpolation of a convex f).
    assert np.all(np.abs(got - exact) <= H)
    assert np.all(got - exact >= -1e-12)
    assert np.all(got - exact <= H**2 * LAM_EXP / 8.0 + 1e-12)


def test_reaching_time_of_exponential_sliding_variable() -> None:
    delta = 1e-2
    exact = np.log(np.abs(A_EXP) / delta) / LAM_EXP
    got = reaching_time(T_EXP, E_EXP, delta_s=delta)
    assert np.all(np.abs(got - exact) <= H**2 * LAM_EXP / 8.0 + 1e-12)


def test_reaching_time_of_discrete_sign_law_is_s0_minus_delta_over_k() -> None:
    # ZOH sign switching with an exact model: s_{j+1} = s_j - k Δt sign(s_j) (SPEC §3).
    # s falls linearly from s0 and then chatters in |s| <= k Δt; with δ_s = 2 k Δt the band is
    # entered on a straight line, where linear interpolation is exact: t_r = (|s0| - δ_s) / k.
    k = np.array([20.0, 20.0, 35.0])
    s0 = np.array([2.0, -1.3, 0.9])
    s = np.empty((T_PAPER.shape[0], 3))
    s[0] = s0
    for j in range(T_PAPER.shape[0] - 1):
        s[j + 1] = s[j] - k * DT * np.sign(s[j])
    assert np.all(np.abs(s[-100:]) <= k * DT + 1e-12)  # chattering band
    delta = 2 * 20.0 * DT
    got = reaching_time(T_PAPER, s, delta_s=delta)
    np.testing.assert_allclose(got, (np.abs(s0) - delta) / k, rtol=0, atol=1e-12)
    # The default band also counts the chattering run as reached.
    assert np.all(np.isfinite(reaching_time(T_PAPER, s)))


def test_never_reached_is_inf_not_nan() -> None:
    t = np.linspace(0.0, 1.0, 11)
    s = np.ones((11, 2))
    s[:, 1] = np.linspace(1.0, 0.0, 11)  # reaches the band ...
    s[-1, 1] = 0.5  # ... but leaves it at the last sample
    got = reaching_time(t, s, delta_s=0.1)
    assert np.all(np.isposinf(got))
    assert np.all(np.isposinf(settling_time(t, s, delta_e=0.1)))


def test_band_holding_from_start_returns_first_time() -> None:
    t = 0.3 + np.linspace(0.0, 1.0, 11)
    x = np.full((11, 2), 0.05)
    x[:, 1] = -0.1  # exactly on the band's edge counts as inside
    np.testing.assert_array_equal(reaching_time(t, x, delta_s=0.1), [0.3, 0.3])
    np.testing.assert_array_equal(settling_time(t, x, delta_e=0.1), [0.3, 0.3])


def test_reentry_counts_only_the_last_entry() -> None:
    t = np.arange(6, dtype=float)
    x = np.array([[1.0], [0.0], [0.0], [-3.0], [0.0], [0.0]])
    # Last sample outside is k = 3 (x = -3); the line to 0 crosses -0.5 at 3 + 2.5/3.
    np.testing.assert_allclose(settling_time(t, x, delta_e=0.5), [3.0 + 2.5 / 3.0], rtol=1e-15)


@settings(max_examples=60, deadline=None)
@given(
    values=st.lists(st.floats(-2.0, 2.0, allow_nan=False), min_size=2, max_size=40),
    delta=st.floats(0.01, 1.5),
)
def test_entry_time_is_bracketed_by_the_last_violation(values: list[float], delta: float) -> None:
    x = np.array(values)[:, None]
    t = np.cumsum(np.r_[0.0, np.full(len(values) - 1, 0.1)])
    tr = float(settling_time(t, x, delta_e=delta)[0])
    outside = np.flatnonzero(np.abs(x[:, 0]) > delta)
    if outside.size == 0:
        assert tr == t[0]
    elif outside[-1] == len(values) - 1:
        assert tr == math.inf
    else:
        k = outside[-1]
        assert t[k] < tr <= t[k + 1] + 1e-15
        assert np.all(np.abs(x[t >= tr + 1e-12, 0]) <= delta)


def test_steady_state_error_takes_the_last_window_inclusive() -> None:
    t = np.arange(21) * 0.1  # 0 .. 2 s; the last 0.5 s holds samples 15..20
    e = np.zeros((21, 2))
    e[14] = [100.0, -100.0]  # just outside the window
    e[15] = [7.0, -9.0]  # on its edge (1.5 computed with round-off)
    e[18] = [-8.0, 3.0]
    np.testing.assert_array_equal(steady_state_error(t, e, window=0.5), [8.0, 9.0])
    # Default window is 0.5 s too; a window longer than the run takes the whole run.
    np.testing.assert_array_equal(steady_state_error(t, e), [8.0, 9.0])
    np.testing.assert_array_equal(steady_state_error(t, e, window=50.0), [100.0, 100.0])


def test_steady_state_error_of_decaying_ramp() -> None:
    # e = -(T - t): over the last 0.5 s the largest |e| is 0.5, at the window's start.
    e = -(T_FINAL - T_PAPER)[:, None]
    np.testing.assert_allclose(steady_state_error(T_PAPER, e), [0.5], rtol=1e-12)


def test_final_error_is_signed_last_sample() -> None:
    e = E_EXP.copy()
    np.testing.assert_array_equal(final_error(e), E_EXP[-1])
    assert final_error(e)[1] < 0.0


# ---------------------------------------------------------------------------- effort / chattering
def _sine(amp: float, freq: float, t: np.ndarray = T_PAPER) -> np.ndarray:
    return amp * np.sin(2 * np.pi * freq * t)


def test_control_effort_of_sine_is_a2_t_over_2_exactly() -> None:
    # 2 Hz at Δt = 5e-4: 1000 samples a period, 9 whole periods in the 9000 applied samples,
    # and Σ sin² over whole sampled periods is exactly half the count.
    tau = np.stack([_sine(3.0, 2.0), _sine(0.5, 10.0)], axis=-1)
    np.testing.assert_allclose(
        control_effort(T_PAPER, tau), [9.0 * T_FINAL / 2, 0.25 * T_FINAL / 2], rtol=1e-12
    )


def test_last_torque_row_is_never_applied() -> None:
    tau = np.stack([_sine(3.0, 2.0), np.ones_like(T_PAPER)], axis=-1)
    spoiled = tau.copy()
    spoiled[-1] = [1e6, -1e6]
    for fn in (control_effort, chattering, hf_power_share):
        np.testing.assert_array_equal(fn(T_PAPER, spoiled), fn(T_PAPER, tau))
    np.testing.assert_array_equal(peak_torque(spoiled), peak_torque(tau))
    np.testing.assert_allclose(peak_torque(tau), [3.0, 1.0], rtol=1e-12)


def test_control_effort_is_exact_for_zoh_on_nonuniform_grid() -> None:
    t = np.array([0.0, 0.5, 0.75, 2.0])
    tau = np.array([[2.0], [-1.0], [4.0], [99.0]])
    np.testing.assert_allclose(control_effort(t, tau), [4 * 0.5 + 1 * 0.25 + 16 * 1.25])


def test_chattering_of_sine_is_4af() -> None:
    # Sampled peaks (1000 and 200 samples a period, multiples of 4) make Σ|Δτ| over whole periods
    # exactly 4A per period; the applied samples stop one step short of the 9th period's end,
    # missing |A sin(2π f Δt)|.
    amps, freqs = np.array([3.0, 0.5]), np.array([2.0, 10.0])
    tau = np.stack([_sine(a, f) for a, f in zip(amps, freqs, strict=True)], axis=-1)
    tv = 4 * amps * freqs * T_FINAL - amps * np.sin(2 * np.pi * freqs * DT)
    np.testing.assert_allclose(chattering(T_PAPER, tau), tv / T_FINAL, rtol=1e-12)
    np.testing.assert_allclose(chattering(T_PAPER, tau), 4 * amps * freqs, rtol=2e-3)


def test_chattering_of_sample_rate_sign_switching() -> None:
    # ±u flipping every sample: 8999 jumps of 2u over 4.5 s.
    u = 2.5
    tau = (u * (-1.0) ** np.arange(T_PAPER.shape[0]))[:, None]
    np.testing.assert_allclose(chattering(T_PAPER, tau), [8999 * 2 * u / T_FINAL], rtol=1e-12)
    assert hf_power_share(T_PAPER, tau)[0] > 1.0 - 1e-6


def test_hf_power_share_of_low_and_high_sines() -> None:
    # Leakage of the detrending line for a whole-period sine is about 6 / (π f T)² of its power,
    # spread mostly below f_c; 1e-4 bounds what reaches above 50 Hz (or is lost below it).
    tau = np.stack([_sine(3.0, 2.0), _sine(0.1, 0.16), _sine(1.0, 200.0), _sine(1.0, 60.0)], -1)
    share = hf_power_share(T_PAPER, tau)
    assert share[0] < 1e-4
    assert share[1] < 1e-3  # 0.72 of a period: a detrended arc, still far below 50 Hz
    assert share[2] > 1.0 - 1e-4
    assert share[3] > 1.0 - 1e-4


def test_hf_power_share_of_two_cosines_is_their_power_ratio() -> None:
    # Cosines over whole periods are orthogonal to the detrending line (up to O(1/N²)), so the
    # share is A2² / (A1² + A2²) to round-off of order 1e-6.
    a1, a2 = 2.0, 1.0
    t = T_PAPER
    tau = np.stack(
        [
            a1 * np.cos(2 * np.pi * 2.0 * t) + a2 * np.cos(2 * np.pi * 200.0 * t),
            0.3 * np.cos(2 * np.pi * 4.0 * t) + 0.4 * np.cos(2 * np.pi * 100.0 * t) + 7.0,
        ],
        axis=-1,
    )
    expected = [a2**2 / (a1**2 + a2**2), 0.16 / (0.09 + 0.16)]
    np.testing.assert_allclose(hf_power_share(T_PAPER, tau), expected, atol=1e-6)


def test_hf_power_share_removes_a_linear_trend_and_depends_on_cutoff() -> None:
    tau = (5.0 + 30.0 * T_PAPER + 0.2 * np.cos(2 * np.pi * 200.0 * T_PAPER))[:, None]
    assert hf_power_share(T_PAPER, tau)[0] > 1.0 - 1e-6
    assert hf_power_share(T_PAPER, tau, cutoff_hz=300.0)[0] < 1e-6


def test_hf_power_share_of_flat_signals_is_zero_not_nan() -> None:
    tau = np.stack(
        [np.zeros_like(T_PAPER), np.full_like(T_PAPER, 3.7), 1.0 - 2.0 * T_PAPER], axis=-1
    )
    np.testing.assert_array_equal(hf_power_share(T_PAPER, tau), [0.0, 0.0, 0.0])
    assert np.all(np.isfinite(chattering(T_PAPER, tau)))


# ---------------------------------------------------------------------------- batch shapes
SignalMetric = Callable[[np.ndarray, np.ndarray], np.ndarray]

TIMED: dict[str, SignalMetric] = {
    "iae": iae,
    "itae": itae,
    "reaching_time": lambda t, x: reaching_time(t, x, delta_s=0.3),
    "settling_time": lambda t, x: settling_time(t, x, delta_e=0.3),
    "steady_state_error": lambda t, x: steady_state_error(t, x, window=0.2),
    "control_effort": control_effort,
    "chattering": chattering,
    "hf_power_share": lambda t, x: hf_power_share(t, x, cutoff_hz=20.0),
}
UNTIMED: dict[str, Callable[[np.ndarray], np.ndarray]] = {
    "mse": mse,
    "rmse": rmse,
    "final_error": final_error,
    "peak_torque": peak_torque,
}


@pytest.mark.parametrize("batch_shape", [(4,), (2, 3)])
def test_batch_agrees_with_per_run_calls(batch_shape: tuple[int, ...]) -> None:
    rng = np.random.default_rng(7)
    t = np.arange(200) * 0.01
    decay = np.exp(-3.0 * t)[:, None]
    x = rng.normal(size=(*batch_shape, 200, 3)) * decay
    runs = x.reshape(-1, 200, 3)
    for name, fn in TIMED.items():
        got = fn(t, x)
        assert got.shape == (*batch_shape, 3), name
        per_run = np.stack([fn(t, r) for r in runs]).reshape(*batch_shape, 3)
        np.testing.assert_array_equal(got, per_run, err_msg=name)
    for name, fn0 in UNTIMED.items():
        got = fn0(x)
        assert got.shape == (*batch_shape, 3), name
        per_run = np.stack([fn0(r) for r in runs]).reshape(*batch_shape, 3)
        np.testing.assert_array_equal(got, per_run, err_msg=name)


# ---------------------------------------------------------------------------- validation
T5 = np.linspace(0.0, 1.0, 5)
X5 = np.zeros((5, 2))


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda: iae(T5, np.zeros((4, 2))), "e has 4 samples on its time axis (-2) but t has 5"),
        (lambda: control_effort(T5, np.zeros((3, 6, 2))), "tau has 6 samples on its time axis"),
        (lambda: reaching_time(T5, np.zeros(5)), "s must have shape (..., T, n), got shape (5,)"),
        (lambda: mse(np.zeros((0, 2))), "e has no samples"),
        (lambda: iae(np.zeros((5, 1)), X5), "t must have shape (T,), got shape (5, 1)"),
        (lambda: iae(np.zeros(1), X5[:1]), "t must have at least 2 samples, got 1"),
        (
            lambda: iae(np.array([0.0, 0.1, 0.1, 0.3, 0.4]), X5),
            "t must be strictly increasing, but t[2] = 0.1 <= t[1] = 0.1",
        ),
        (lambda: iae(T5[::-1], X5), "t must be strictly increasing"),
        (lambda: iae(np.r_[T5[:4], np.nan], X5), "t contains non-finite values"),
        (lambda: mse(np.full((5, 2), np.inf)), "e contains non-finite values"),
        (
            lambda: reaching_time(T5, X5, delta_s=0.0),
            "delta_s must be positive and finite, got 0.0",
        ),
        (lambda: settling_time(T5, X5, delta_e=-1e-3), "delta_e must be positive and finite"),
        (
            lambda: settling_time(T5, X5, delta_e=True),
            "delta_e must be positive and finite, got True",
        ),
        (
            lambda: steady_state_error(T5, X5, window="0.5"),
            "window must be positive and finite, got '0.5'",
        ),
        (lambda: steady_state_error(T5, X5, window=math.inf), "window must be positive and finite"),
        (
            lambda: hf_power_share(T5, X5, cutoff_hz=0),
            "cutoff_hz must be positive and finite, got 0.0",
        ),
        (
            lambda: hf_power_share(T5, X5, cutoff_hz=2.0),
            "cutoff_hz must be below the Nyquist frequency 1/(2 dt) = 2 Hz, got 2",
        ),
        (
            lambda: hf_power_share(np.array([0.0, 0.1, 0.3, 0.4, 0.5]), X5),
            "t must be uniformly spaced for hf_power_share",
        ),
        (lambda: peak_torque(np.zeros((1, 2))), "tau must have at least 2 samples, got 1"),
    ],
)
def test_validation_messages(call: Callable[[], object], message: str) -> None:
    with pytest.raises(ValueError, match=re.escape(message)):
        call()


# ---------------------------------------------------------------------------- summary
def _sim_result(n_joints: int = 3, *, stuck_joint: bool = False, seed: int = 0) -> SimResult:
    """A run built by hand: exponential errors and sliding variables, sine torques."""
    rng = np.random.default_rng(seed)
    t: FloatArray = np.arange(2001, dtype=np.float64) * DT  # 1 s
    amps = rng.uniform(0.2, 1.0, n_joints) * rng.choice([-1.0, 1.0], n_joints)
    lam = rng.uniform(5.0, 20.0, n_joints)
    e = amps * np.exp(-np.outer(t, lam))
    if stuck_joint:
        e[:, -1] = 0.3
    q_ref = np.outer(np.cos(t), np.ones(n_joints))
    tau = np.sin(2 * np.pi * np.outer(t, np.arange(1, n_joints + 1)))
    signals = {
        "q": q_ref + e,
        "qd": np.zeros_like(e),
        "q_ref": q_ref,
        "qd_ref": np.zeros_like(e),
        "q_meas": q_ref + e,
        "qd_meas": np.zeros_like(e),
        "tau": tau,
        "s": 5.0 * e,
    }
    return SimResult(t=t, **signals, params={"case": "hand-made"}, seed=seed)


def _batch(runs: list[SimResult]) -> BatchResult:
    return BatchResult(
        t=runs[0].t,
        **{name: np.stack([getattr(r, name) for r in runs]) for name in SIGNALS},
        params=[r.params for r in runs],
        seeds=[r.seed for r in runs],
    )


def test_summary_of_a_sim_result() -> None:
    res = _sim_result()
    df = summary(res)
    assert isinstance(df, pd.DataFrame)
    assert list(df.columns) == ["joint", *METRIC_COLUMNS]
    assert list(df["joint"]) == ["1", "2", "3", "mean"]
    e, t = res.e, res.t
    direct = {
        "mse": mse(e),
        "rmse": rmse(e),
        "iae": iae(t, e),
        "itae": itae(t, e),
        "reaching_time": reaching_time(t, res.s),
        "settling_time": settling_time(t, e),
        "steady_state_error": steady_state_error(t, e),
        "final_error": final_error(e),
        "control_effort": control_effort(t, res.tau),
        "peak_torque": peak_torque(res.tau),
        "chattering": chattering(t, res.tau),
        "hf_power_share": hf_power_share(t, res.tau),
    }
    for name, values in direct.items():
        np.testing.assert_array_equal(df[name].to_numpy()[:3], values, err_msg=name)
        np.testing.assert_allclose(df[name].iloc[3], np.mean(values), rtol=1e-15, err_msg=name)
    # Sanity of the hand-made run: e_i = A_i e^{-λ_i t} settles at ln(|A_i|/δ_e)/λ_i.
    assert np.all(np.isfinite(df["settling_time"]))
    # Torques sin(2π j t) over whole periods: effort 1/2, TV/s 4j (up to the one missing step).
    np.testing.assert_allclose(df["control_effort"].to_numpy()[:3], 0.5, rtol=1e-12)
    np.testing.assert_allclose(df["chattering"].to_numpy()[:3], [4.0, 8.0, 12.0], rtol=1e-2)


def test_summary_mean_row_is_inf_when_a_joint_never_settles() -> None:
    df = summary(_sim_result(stuck_joint=True))
    settle = df.set_index("joint")["settling_time"]
    assert np.isposinf(settle["3"]) and np.isfinite(settle["1"])
    assert np.isposinf(settle["mean"])
    assert not df.drop(columns="joint").isna().to_numpy().any()


def test_summary_passes_thresholds_through() -> None:
    res = _sim_result()
    loose = summary(res, delta_e=0.5, delta_s=10.0, window=1.0, cutoff_hz=0.5)
    assert np.all(loose["settling_time"] <= summary(res)["settling_time"])
    np.testing.assert_array_equal(loose["reaching_time"], 0.0)
    np.testing.assert_array_equal(
        loose["steady_state_error"].to_numpy()[:3], np.max(np.abs(res.e), axis=0)
    )
    assert np.all(loose["hf_power_share"].to_numpy()[:3] > 0.99)


def test_summary_of_a_batch_stacks_runs() -> None:
    runs = [_sim_result(seed=s) for s in (1, 2)]
    df = summary(_batch(runs))
    assert list(df.columns) == ["run", "joint", *METRIC_COLUMNS]
    assert list(df["run"]) == [0, 0, 0, 0, 1, 1, 1, 1]
    assert list(df["joint"]) == ["1", "2", "3", "mean"] * 2
    for b, run in enumerate(runs):
        single = summary(run)
        part = df[df["run"] == b].drop(columns="run").reset_index(drop=True)
        pd.testing.assert_frame_equal(part, single, check_exact=False, rtol=1e-12)


# ---------------------------------------------------------------------------- windows
def test_late_start_is_the_first_sample_of_the_window() -> None:
    t = np.arange(11) * 0.1  # 0 .. 1 s
    assert M.late_start(t, fraction=0.5) == 5
    assert M.late_start(t, fraction=1.0) == 0
    # at least two applied steps stay in the window
    assert M.late_start(t, fraction=1e-6) == 8
    for bad in (0.0, 1.5, True, "0.5"):
        with pytest.raises(ValueError, match="fraction"):
            M.late_start(t, fraction=bad)  # type: ignore[arg-type]


def test_max_step_alternation_and_rms_follow_their_formulas() -> None:
    k = np.arange(9)
    flip = np.where(k % 2 == 0, 1.0, -1.0)
    ramp = 0.5 * k
    tau = np.stack([flip, ramp], axis=1)
    # the last row is never applied: steps of rows 0..7
    np.testing.assert_array_equal(M.max_step(tau), [2.0, 0.5])
    np.testing.assert_array_equal(M.alternation(tau), [1.0, 0.0])
    assert M.alternation(tau[:3]).tolist() == [0.0, 0.0]  # one step: nothing reverses
    np.testing.assert_allclose(M.rms(tau), np.sqrt(np.mean(tau**2, axis=0)), rtol=1e-15)
    # batches: one value per run and joint
    assert M.max_step(np.stack([tau, 2 * tau])).shape == (2, 2)


def test_terminal_gain_is_the_guarded_formula() -> None:
    e = np.full((5, 2), 1e-8)
    got = M.terminal_gain(e, beta=[2.0, 1.0], gamma=0.6, eps_e=1e-9, dt=5e-4)
    np.testing.assert_allclose(got, np.array([2.0, 1.0]) * 0.6 * 1e-8 ** (-0.4) * 5e-4)
    guarded = M.terminal_gain(e * 1e-4, beta=2.0, gamma=0.6, eps_e=1e-9, dt=5e-4)
    np.testing.assert_allclose(guarded, 1.2 * 1e-9 ** (-0.4) * 5e-4)


def test_late_metrics_names_and_window() -> None:
    t = np.arange(101) * 0.01
    tau = np.stack([np.sin(t), np.where(np.arange(101) % 2 == 0, 1.0, -1.0)], axis=1)
    s = np.full_like(tau, 0.2)
    late = M.late_metrics(t, tau, s, np.zeros_like(tau), dt=0.01)
    assert tuple(late) == M.LATE_COLUMNS
    np.testing.assert_array_equal(late["chattering_late"], M.chattering(t[50:], tau[50:]))
    np.testing.assert_array_equal(late["max_step_late"], M.max_step(tau[50:]))
    assert np.isnan(late["terminal_gain_late"]).all()
    np.testing.assert_allclose(late["s_rms_late"], 0.2)
    short = M.late_metrics(t[:2], tau[:2], s[:2], s[:2], dt=0.01)
    assert all(np.isnan(v).all() for v in short.values())
