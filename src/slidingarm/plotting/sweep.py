"""Figures of a sweep (``slidingarm sweep``): drawing only, from the sweep's table.

:func:`plot_ecdf` draws, per metric, the empirical distribution function of each controller's
metric over the finished runs; :func:`plot_scatter` draws each metric against each drawn
parameter. Both read the ``"mean"`` joint rows (the mean over joints) unless told a joint.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING

import matplotlib
import numpy as np
from matplotlib.figure import Figure

from slidingarm.plotting._style import RC, controller_style

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["DEFAULT_METRICS", "plot_ecdf", "plot_scatter"]

#: Metrics drawn unless told.
DEFAULT_METRICS: tuple[str, ...] = ("mse", "steady_state_error", "peak_torque", "chattering")

#: Points drawn per controller in one scatter panel at most (every k-th run).
MAX_SCATTER = 4000


def _rows(table: pd.DataFrame, joint: str) -> pd.DataFrame:
    rows = table[(table["joint"] == joint) & table["ok"].astype(bool)]
    if rows.empty:
        raise ValueError(f"the table has no finished run at joint {joint!r}")
    return rows


def _metrics(table: pd.DataFrame, metrics: Sequence[str] | None) -> list[str]:
    names = list(metrics) if metrics is not None else [m for m in DEFAULT_METRICS if m in table]
    for m in names:
        if m not in table.columns:
            raise ValueError(f"metrics: {m!r} is not a column of the table")
    if not names:
        raise ValueError("metrics is empty: name at least one metric column")
    return names


def _log_scale(x: np.ndarray) -> bool:
    pos = x[np.isfinite(x) & (x > 0)]
    return pos.size == x[np.isfinite(x)].size and pos.size > 1 and pos.max() / pos.min() > 100


def plot_ecdf(
    table: pd.DataFrame,
    *,
    metrics: Sequence[str] | None = None,
    joint: str = "mean",
    title: str | None = "Distribution over the sweep's runs",
) -> Figure:
    """Per metric a panel: each controller's empirical CDF
    :math:`\\hat F(x) = \\#\\{i : m_i \\le x\\} / N` over its ``N`` finished runs (log scale for
    a positive metric spanning more than two decades).

    Returns
    -------
    matplotlib.figure.Figure
    """
    rows = _rows(table, joint)
    names = _metrics(table, metrics)
    cols = min(2, len(names))
    nrows = math.ceil(len(names) / cols)
    with matplotlib.rc_context(RC):
        fig = Figure(figsize=(5.0 * cols, 0.9 + 3.0 * nrows), layout="constrained")
        grid = fig.subplots(nrows, cols, squeeze=False)
        controllers = list(dict.fromkeys(rows["controller"]))
        for k, name in enumerate(names):
            ax = grid[k // cols, k % cols]
            everything = rows[name].to_numpy(dtype=float)
            for i, c in enumerate(controllers):
                x = np.sort(rows.loc[rows["controller"] == c, name].to_numpy(dtype=float))
                x = x[np.isfinite(x)]
                if x.size == 0:
                    continue
                style = controller_style(c, i)
                f = np.arange(1, x.size + 1) / x.size
                ax.step(x, f, where="post", **style.kwargs())
            if _log_scale(everything):
                ax.set_xscale("log")
            ax.set_xlabel(name)
            ax.set_ylabel("fraction of runs ≤ x")
            ax.set_ylim(0.0, 1.02)
            ax.grid(True, alpha=0.3)
        for k in range(len(names), nrows * cols):
            fig.delaxes(grid[k // cols, k % cols])
        handles, labels = grid[0, 0].get_legend_handles_labels()
        if handles:
            fig.legend(handles, labels, loc="outside lower center", ncols=min(len(handles), 5))
        if title:
            fig.suptitle(f"{title} (joint {joint})" if joint != "mean" else title)
    return fig


def plot_scatter(
    table: pd.DataFrame,
    *,
    params: Sequence[str],
    metrics: Sequence[str] | None = None,
    joint: str = "mean",
    title: str | None = "Metrics against the drawn parameters",
    max_points: int = MAX_SCATTER,
) -> Figure:
    """A grid of panels, one row per metric and one column per drawn parameter: each
    controller's metric of each finished run against the parameter's value.

    Returns
    -------
    matplotlib.figure.Figure
    """
    rows = _rows(table, joint)
    names = _metrics(table, metrics)
    params = list(params)
    for p in params:
        if p not in table.columns:
            raise ValueError(f"params: {p!r} is not a column of the table")
    if not params:
        raise ValueError("params is empty: name at least one drawn parameter column")
    with matplotlib.rc_context(RC):
        fig = Figure(
            figsize=(1.0 + 2.8 * len(params), 1.0 + 2.4 * len(names)), layout="constrained"
        )
        grid = fig.subplots(len(names), len(params), squeeze=False, sharex="col", sharey="row")
        controllers = list(dict.fromkeys(rows["controller"]))
        for r, name in enumerate(names):
            for c, p in enumerate(params):
                ax = grid[r, c]
                for i, ctl in enumerate(controllers):
                    mine = rows[rows["controller"] == ctl]
                    step = max(1, math.ceil(len(mine) / max_points))
                    mine = mine.iloc[::step]
                    style = controller_style(ctl, i)
                    ax.scatter(
                        mine[p].to_numpy(dtype=float),
                        mine[name].to_numpy(dtype=float),
                        s=5,
                        alpha=0.5,
                        color=style.color,
                        label=style.label,
                        linewidths=0,
                    )
                if c == 0:
                    ax.set_ylabel(name)
                    if _log_scale(rows[name].to_numpy(dtype=float)):
                        ax.set_yscale("log")
                if r == len(names) - 1:
                    ax.set_xlabel(p)
                ax.grid(True, alpha=0.3)
        handles, labels = grid[0, 0].get_legend_handles_labels()
        if handles:
            fig.legend(
                handles,
                labels,
                loc="outside lower center",
                ncols=min(len(handles), 5),
                markerscale=3,
            )
        if title:
            fig.suptitle(title)
    return fig
