"""The tuning figures: panels per pair of objectives, the front drawn, the caller's axes."""

from __future__ import annotations

import matplotlib
import numpy as np
import pandas as pd
import pytest
from matplotlib.figure import Figure

from slidingarm.plotting.tune import FRONT_COLOR, plot_comparison, plot_pareto


def _trials() -> pd.DataFrame:
    rng = np.random.default_rng(3)
    n = 12
    t = pd.DataFrame(
        {
            "trial": np.arange(n),
            "state": ["complete"] * (n - 1) + ["failed"],
            "feasible": [True] * (n - 2) + [False, False],
            "pareto": [True, True, True] + [False] * (n - 3),
            "mse": rng.lognormal(size=n),
            "chattering": rng.lognormal(3, 2, size=n),
            "peak_torque": rng.uniform(10, 20, size=n),
        }
    )
    t.loc[n - 1, ["mse", "chattering", "peak_torque"]] = np.nan
    return t


def test_pareto_panels_and_front() -> None:
    fig = plot_pareto(_trials(), ["mse", "chattering", "peak_torque"], best=1)
    axes = [a for a in fig.axes if a.get_visible()]
    assert len(axes) == 3  # one per pair of objectives
    assert [a.get_xlabel() for a in axes] == ["mse", "mse", "chattering"]
    assert axes[0].get_yscale() == "log"  # chattering spans decades
    # the three front points drawn in the front colour in every panel
    for a in axes:
        front = [c for c in a.collections if c.get_label() == "Pareto front"]
        assert len(front) == 1 and len(front[0].get_offsets()) == 3
        assert matplotlib.colors.to_hex(front[0].get_facecolor()[0]) == FRONT_COLOR.lower()


def test_one_objective_and_the_callers_axes() -> None:
    fig = plot_pareto(_trials(), ["mse"])
    assert len(fig.axes) == 1 and fig.axes[0].get_xlabel() == "trial"
    own = Figure()
    axes = own.subplots(1, 3)
    assert plot_pareto(_trials(), ["mse", "chattering", "peak_torque"], ax=list(axes)) is own
    with pytest.raises(ValueError, match="3 panel"):
        plot_pareto(_trials(), ["mse", "chattering", "peak_torque"], ax=axes[0])


def test_comparison_figure() -> None:
    rng = np.random.default_rng(0)
    mse = pd.DataFrame({"pdsmc": rng.lognormal(size=20), "ftsmc": rng.lognormal(size=20)})
    ok = mse > 0
    pairs = pd.DataFrame(
        {"a": ["ftsmc"], "b": ["pdsmc"], "ratio": [0.8], "ci_low": [0.7], "ci_high": [0.9],
         "verdict": ["holds"]}
    )  # fmt: skip
    fig = plot_comparison(mse, ok, pairs)
    ecdf, forest = fig.axes
    assert len(ecdf.get_lines()) == 2
    assert [t.get_text() for t in forest.get_yticklabels()] == ["FTSMC < PDSMC"]
