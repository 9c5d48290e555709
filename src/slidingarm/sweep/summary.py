"""The summary of a sweep: per controller, the median of each metric with a bootstrap
confidence interval, and the success rate with a Wilson interval.

- **Median and CI.** Over the runs that finished (``ok``), per controller, joint (``"1"`` …
  ``"n"`` and ``"mean"``, the mean over joints) and metric: the sample median and a
  ``confidence`` (default 95 %) **percentile** bootstrap interval, the interval
  :func:`scipy.stats.bootstrap` gives with ``method="percentile"``: the
  :math:`\\alpha/2` and :math:`1-\\alpha/2` quantiles (linear interpolation,
  :func:`numpy.quantile`) of the medians of ``n_resamples`` resamples with replacement, drawn
  from a generator seeded with the sweep's seed. Percentile rather than BCa: BCa's
  acceleration comes from the jackknife, which is inconsistent for the median (a non-smooth
  statistic), and it fails on the many metrics that are constant over the runs.
- **The resampled medians, drawn directly.** A resample of the sorted sample
  :math:`x_{(0)} \\le \\dots \\le x_{(m-1)}` is :math:`x_{(J_1)}, \\dots, x_{(J_m)}` with
  :math:`J_i = \\lfloor m U_i \\rfloor`, :math:`U_i` uniform on [0, 1); as
  :math:`u \\mapsto x_{(\\lfloor m u \\rfloor)}` is non-decreasing, the resample's
  :math:`k`-th smallest value is :math:`x_{(\\lfloor m U_{(k)} \\rfloor)}`. The order statistics
  of :math:`m` uniforms are :math:`U_{(k)} \\sim \\mathrm{Beta}(k, m-k+1)` and, given
  :math:`U_{(k)} = u`, :math:`U_{(k+1)} = u + (1-u)\\,V` with :math:`V \\sim \\mathrm{Beta}(1, m-k)`.
  So the median of a resample, :math:`x_{(\\lfloor m U_{(k)} \\rfloor)}` with
  :math:`k = (m+1)/2` for odd :math:`m`, the mean of the :math:`k`-th and :math:`(k+1)`-th
  values with :math:`k = m/2` for even :math:`m` (:func:`numpy.median`), is drawn exactly, from
  one or two Beta variates: O(``n_resamples``) per metric after one sort, instead of
  O(``n_resamples`` × m) for resampling the indices (the same bootstrap distribution, another
  stream of random numbers than scipy's).
- **Success rate.** :math:`\\hat p = k/m` of the ``m`` runs of a controller, ``k`` of which
  finished, with the Wilson score interval
  :math:`\\frac{\\hat p + z^2/2m \\pm z\\sqrt{\\hat p(1-\\hat p)/m + z^2/4m^2}}{1 + z^2/m}`
  (:meth:`scipy.stats.binomtest(...).proportion_ci(method="wilson")`).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from slidingarm.metrics import METRIC_COLUMNS

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["SUMMARY_COLUMNS", "bootstrap_medians", "success_rates", "summarize", "summary_text"]

#: The columns of :func:`summarize`.
SUMMARY_COLUMNS: tuple[str, ...] = (
    "controller",
    "joint",
    "metric",
    "statistic",
    "n",
    "estimate",
    "ci_low",
    "ci_high",
    "method",
)


def bootstrap_medians(x: np.ndarray, n_resamples: int, rng: np.random.Generator) -> np.ndarray:
    """The medians of ``n_resamples`` bootstrap resamples of ``x`` (1-d, no NaN), drawn from
    the order statistics of uniforms (see the module's notes): the bootstrap distribution of
    :func:`numpy.median` without forming the resamples.

    Returns
    -------
    ndarray, shape (n_resamples,)
    """
    xs = np.sort(np.asarray(x, dtype=float))
    m = xs.size
    if m == 0:
        raise ValueError("x: the bootstrap needs at least one value")
    k = (m + 1) // 2  # the (lower) middle rank, from 1
    u = rng.beta(k, m - k + 1, size=n_resamples)  # U_(k)
    low = xs[np.minimum((m * u).astype(np.int64), m - 1)]
    if m % 2:
        return low
    v = u + (1.0 - u) * rng.beta(1.0, m - k, size=n_resamples)  # U_(k+1)
    high = xs[np.minimum((m * v).astype(np.int64), m - 1)]
    return 0.5 * (low + high)


def _median_ci(
    x: np.ndarray, *, confidence: float, n_resamples: int, rng: np.random.Generator
) -> tuple[float, float]:
    if x.size < 2 or np.all(x == x[0]):
        v = float(x[0]) if x.size else float("nan")
        return v, v
    alpha = (1.0 - confidence) / 2.0
    with np.errstate(invalid="ignore"):  # an infinite metric (never settled) is allowed
        medians = bootstrap_medians(x, n_resamples, rng)
        low, high = np.quantile(medians, [alpha, 1.0 - alpha])
    return float(low), float(high)


def success_rates(table: pd.DataFrame, *, confidence: float = 0.95) -> pd.DataFrame:
    """Per controller: ``runs``, ``ok`` (finished), ``rate`` and its Wilson interval
    ``ci_low``, ``ci_high``."""
    import pandas as pd
    from scipy.stats import binomtest

    rows = table[table["joint"] == "mean"]
    out = []
    for controller in dict.fromkeys(rows["controller"]):
        ok = rows.loc[rows["controller"] == controller, "ok"].astype(bool).to_numpy()
        m, k = int(ok.size), int(ok.sum())
        ci = binomtest(k, m).proportion_ci(confidence_level=confidence, method="wilson")
        out.append(
            {
                "controller": controller,
                "runs": m,
                "ok": k,
                "rate": k / m,
                "ci_low": float(ci.low),
                "ci_high": float(ci.high),
            }
        )
    return pd.DataFrame(out)


def summarize(
    table: pd.DataFrame,
    *,
    metrics: Sequence[str] | None = None,
    confidence: float = 0.95,
    n_resamples: int = 1000,
    seed: int = 0,
) -> pd.DataFrame:
    """The summary of a sweep's table (one row per run × controller × joint).

    Returns
    -------
    pandas.DataFrame
        :data:`SUMMARY_COLUMNS`: per controller, joint and metric the ``median`` of the
        finished runs (``n`` of them) and its bootstrap CI (``method`` "bootstrap
        percentile"); then per controller a row with ``metric`` "success_rate", ``joint``
        "all", ``statistic`` "proportion" and the Wilson interval. A controller none of whose
        runs finished has no median rows.
    """
    import pandas as pd

    names = list(metrics) if metrics is not None else list(METRIC_COLUMNS)
    for name in names:
        if name not in table.columns:
            raise ValueError(f"metrics: {name!r} is not a column of the table")
    rng = np.random.default_rng(seed)
    rows: list[dict[str, object]] = []
    ok = table["ok"].astype(bool)
    for controller in dict.fromkeys(table["controller"]):
        mine = table[(table["controller"] == controller) & ok]
        for joint in dict.fromkeys(table["joint"]):
            sub = mine[mine["joint"] == joint]
            if sub.empty:
                continue
            for name in names:
                x = sub[name].to_numpy(dtype=float)
                x = x[~np.isnan(x)]
                if x.size == 0:
                    continue
                low, high = _median_ci(x, confidence=confidence, n_resamples=n_resamples, rng=rng)
                rows.append(
                    {
                        "controller": controller,
                        "joint": joint,
                        "metric": name,
                        "statistic": "median",
                        "n": int(x.size),
                        "estimate": float(np.median(x)),
                        "ci_low": low,
                        "ci_high": high,
                        "method": "bootstrap percentile",
                    }
                )
    for r in success_rates(table, confidence=confidence).to_dict("records"):
        rows.append(
            {
                "controller": r["controller"],
                "joint": "all",
                "metric": "success_rate",
                "statistic": "proportion",
                "n": r["runs"],
                "estimate": r["rate"],
                "ci_low": r["ci_low"],
                "ci_high": r["ci_high"],
                "method": "wilson",
            }
        )
    return pd.DataFrame(rows, columns=list(SUMMARY_COLUMNS))


def summary_text(
    summary: pd.DataFrame, *, metrics: Sequence[str] = ("mse", "chattering", "peak_torque")
) -> str:
    """A markdown table of the ``mean`` joint: per controller the median [95 % CI] of
    ``metrics`` and the success rate [Wilson CI]."""
    controllers = list(dict.fromkeys(summary["controller"]))
    head = ["controller", *[f"{m} median [CI]" for m in metrics], "success [CI]"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for c in controllers:
        cells = [c]
        for m in metrics:
            row = summary[
                (summary["controller"] == c)
                & (summary["joint"] == "mean")
                & (summary["metric"] == m)
            ]
            if row.empty:
                cells.append("—")
            else:
                r = row.iloc[0]
                cells.append(f"{r.estimate:.4g} [{r.ci_low:.4g}, {r.ci_high:.4g}]")
        row = summary[(summary["controller"] == c) & (summary["metric"] == "success_rate")]
        r = row.iloc[0]
        cells.append(f"{r.estimate:.1%} [{r.ci_low:.1%}, {r.ci_high:.1%}] of {int(r.n)}")
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)
