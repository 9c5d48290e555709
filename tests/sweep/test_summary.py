"""The summary's bootstrap: the medians drawn from order statistics have the bootstrap
distribution of the median, and the interval is scipy's percentile interval."""

from __future__ import annotations

import inspect

import numpy as np
import pytest
from scipy.stats import binom, bootstrap

from slidingarm.sweep.summary import _median_ci, bootstrap_medians


def _scipy_interval(x: np.ndarray, n_resamples: int, seed: int) -> tuple[float, float]:
    name = "rng" if "rng" in inspect.signature(bootstrap).parameters else "random_state"
    res = bootstrap(
        (x,), np.median, n_resamples=n_resamples, method="percentile", vectorized=True,
        **{name: np.random.default_rng(seed)},
    )  # fmt: skip
    return float(res.confidence_interval.low), float(res.confidence_interval.high)


@pytest.mark.parametrize("m", [2, 7, 40, 41, 300])
def test_interval_matches_scipy_percentile(m):
    """Same sample, same seed, same resample count: the interval scipy's percentile
    bootstrap gives, within the Monte Carlo error of the bootstrap (the two draw different
    random streams), which is a few order-statistic spacings around the median."""
    x = np.random.default_rng(m).exponential(size=m)
    ours = _median_ci(x, confidence=0.95, n_resamples=20_000, rng=np.random.default_rng(1))
    theirs = _scipy_interval(x, 20_000, 1)
    xs = np.sort(x)
    spacing = np.max(np.diff(xs[m // 4 : 3 * m // 4 + 1])) if m > 4 else np.ptp(xs)
    assert ours[0] <= np.median(x) <= ours[1]
    np.testing.assert_allclose(ours, theirs, atol=1.5 * spacing)
    # the same seed gives the same interval
    again = _median_ci(x, confidence=0.95, n_resamples=20_000, rng=np.random.default_rng(1))
    assert again == ours


def test_resampled_medians_have_the_exact_bootstrap_distribution():
    """Odd m: the bootstrap median is x_(j) or below iff at least k = (m+1)/2 of the m draws
    fall on x_(0..j), so P(M* <= x_(j)) = P(Binomial(m, (j+1)/m) >= k)."""
    m, k = 41, 21
    x = np.sort(np.random.default_rng(5).normal(size=m))
    med = bootstrap_medians(x, 100_000, np.random.default_rng(0))
    assert np.isin(med, x).all()
    empirical = np.searchsorted(np.sort(med), x, side="right") / med.size
    exact = binom.sf(k - 1, m, (np.arange(m) + 1) / m)
    assert np.max(np.abs(empirical - exact)) < 0.006  # 4 sigma of the largest binomial error


def test_even_sample_averages_the_two_middle_values():
    """Even m: each resampled median is the mean of two values of the sample, ordered as the
    resample's middle pair; its mean matches that of scipy's resampled medians."""
    x = np.random.default_rng(9).exponential(size=20)
    med = bootstrap_medians(x, 20_000, np.random.default_rng(2))
    pairs = 0.5 * (x[:, None] + x[None, :])
    assert np.all(np.min(np.abs(med[:, None] - pairs.ravel()[None, :]), axis=1) < 1e-12)
    idx = np.random.default_rng(3).integers(0, x.size, size=(20_000, x.size))
    direct = np.median(x[idx], axis=1)
    se = np.std(direct) / np.sqrt(direct.size)
    assert abs(med.mean() - direct.mean()) < 5 * np.sqrt(2) * se
    assert abs(np.std(med) / np.std(direct) - 1) < 0.03
