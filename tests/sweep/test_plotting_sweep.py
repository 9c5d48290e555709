"""Tests for slidingarm.plotting.sweep: the ECDF and scatter figures draw the table's values."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import numpy as np
import pandas as pd
import pytest

from slidingarm.plotting.sweep import plot_ecdf, plot_scatter


@pytest.fixture
def table():
    rng = np.random.default_rng(2)
    rows = []
    for run in range(30):
        k = rng.uniform(10, 40)
        for c in ("pdsmc", "ftsmc"):
            for joint in ("1", "mean"):
                rows.append({"run": run, "controller": c, "joint": joint, "gains.k": k,
                             "mse": rng.exponential(), "chattering": k * 3.0,
                             "ok": run != 0})  # fmt: skip
    return pd.DataFrame(rows)


def test_ecdf_steps_are_the_sorted_values(table):
    fig = plot_ecdf(table, metrics=["mse", "chattering"])
    axes = fig.get_axes()
    assert len(axes) == 2
    lines = axes[0].get_lines()
    assert [ln.get_label() for ln in lines] == ["PDSMC", "FTSMC"]
    mine = table[(table.controller == "pdsmc") & (table.joint == "mean") & table.ok]
    x, y = lines[0].get_data()
    np.testing.assert_array_equal(x, np.sort(mine["mse"]))  # the failed run is left out
    np.testing.assert_allclose(y, np.arange(1, 30) / 29)


def test_scatter_grid_and_points(table):
    fig = plot_scatter(table, params=["gains.k"], metrics=["mse", "chattering"])
    axes = fig.get_axes()
    assert len(axes) == 2
    offsets = axes[1].collections[0].get_offsets()
    np.testing.assert_allclose(offsets[:, 1], 3.0 * offsets[:, 0])
    assert len(offsets) == 29


def test_bad_columns_are_named(table):
    with pytest.raises(ValueError, match="'nope'"):
        plot_ecdf(table, metrics=["nope"])
    with pytest.raises(ValueError, match="params"):
        plot_scatter(table, params=["nope"])
    with pytest.raises(ValueError, match="no finished run"):
        plot_ecdf(table.assign(ok=False))
