"""Figures of a tuning (:func:`slidingarm.tune`): the Pareto front against every trial.

Pure drawing from the trials table (``trials.csv``, :attr:`slidingarm.tune.TuneResult.trials`);
no computation beyond choosing axis scales, no pyplot, no ``show()``.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from typing import Any

import matplotlib
import numpy as np
import pandas as pd
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.ticker import FormatStrFormatter, NullLocator

from slidingarm.plotting._style import RC, PowerOfTenFormatter

__all__ = ["FRONT_COLOR", "plot_comparison", "plot_pareto"]

#: Colour of the Pareto front (Okabe–Ito blue); other trials are grey.
FRONT_COLOR = "#0072B2"
_OTHER = "#9A9A9A"
_INFEASIBLE = "#D55E00"
_COLUMNS = 3


def _log_scale(values: np.ndarray) -> bool:
    """A log axis when every value is positive and they span more than two decades."""
    v = values[np.isfinite(values)]
    return bool(v.size and np.all(v > 0) and v.max() / v.min() > 100.0)


def _set_log(axis: Any) -> None:
    """A log axis labelled ``10ⁿ`` in plain Unicode (mathtext costs most of a figure's time)."""
    axis.set_major_formatter(PowerOfTenFormatter())
    axis.set_minor_formatter(PowerOfTenFormatter(labelOnlyBase=False))
    axis.set_minor_locator(NullLocator())


def _axes(count: int, ax: Axes | Sequence[Axes] | None) -> tuple[Figure, list[Axes]]:
    if ax is not None:
        axes = [ax] if isinstance(ax, Axes) else list(ax)
        if len(axes) != count:
            raise ValueError(f"ax: this figure draws {count} panel(s), got {len(axes)} axes")
        fig = axes[0].get_figure()
        assert isinstance(fig, Figure)
        return fig, axes
    cols = min(count, _COLUMNS)
    rows = math.ceil(count / cols)
    width, height = 3.7 * cols + 0.3, 3.2 * rows + 0.5
    fig = Figure(figsize=(width, height))
    # fixed margins (in inches): the constrained layout would triple the drawing time
    grid = fig.subplots(rows, cols, squeeze=False)
    fig.subplots_adjust(
        left=0.85 / width, right=1 - 0.2 / width, bottom=0.6 / height, top=1 - 0.45 / height,
        wspace=0.95 * cols / (width - 1.05), hspace=0.75 * rows / (height - 1.05),
    )  # fmt: skip
    axes = list(grid.ravel())
    for extra in axes[count:]:
        extra.set_visible(False)
    return fig, axes[:count]


def plot_pareto(
    trials: pd.DataFrame,
    objectives: Sequence[str],
    *,
    best: int | None = None,
    title: str | None = None,
    ax: Axes | Sequence[Axes] | None = None,
) -> Figure:
    """The trials of a tuning in each pair of objectives, the Pareto front highlighted.

    With one objective, the objective of each trial against its number and the best value so
    far. Failed trials (no values) are not drawn; infeasible ones (outside the limits) are
    crosses.

    Parameters
    ----------
    trials : DataFrame
        Columns ``trial``, ``state``, ``feasible``, ``pareto`` and each objective.
    objectives : sequence of str
        The objectives, in order.
    best : int, optional
        A trial to mark with a star (e.g. :attr:`~slidingarm.tune.TuneResult.best`).
    title : str, optional
        The figure's title.
    ax : Axes or sequence of Axes, optional
        One Axes per panel (``m (m - 1) / 2`` for ``m >= 2`` objectives, else one).

    Returns
    -------
    matplotlib.figure.Figure
    """
    names = list(objectives)
    pairs = list(itertools.combinations(range(len(names)), 2)) if len(names) > 1 else []
    with matplotlib.rc_context(RC):
        fig, axes = _axes(max(len(pairs), 1), ax)
        done = trials[trials["state"] == "complete"]
        feasible = done["feasible"].astype(bool).to_numpy()
        front = done["pareto"].astype(bool).to_numpy()
        if not pairs:
            a = axes[0]
            y = done[names[0]].to_numpy(dtype=np.float64)
            x = done["trial"].to_numpy()
            a.scatter(x[feasible & ~front], y[feasible & ~front], s=12, color=_OTHER, label="trial")
            a.scatter(
                x[~feasible], y[~feasible], s=14, marker="x", color=_INFEASIBLE, label="infeasible"
            )
            if feasible.any():
                order = np.argsort(x[feasible], kind="stable")
                running = np.minimum.accumulate(y[feasible][order])
                a.step(
                    x[feasible][order],
                    running,
                    where="post",
                    color=FRONT_COLOR,
                    label="best so far",
                )
            a.set_xlabel("trial")
            a.set_ylabel(names[0])
            if _log_scale(y):
                a.set_yscale("log")
                _set_log(a.yaxis)
        for a, (i, j) in zip(axes, pairs, strict=False):
            x = done[names[i]].to_numpy(dtype=np.float64)
            y = done[names[j]].to_numpy(dtype=np.float64)
            other = feasible & ~front
            a.scatter(
                x[other], y[other], s=10, color=_OTHER, alpha=0.7, label="trial", linewidths=0
            )
            if (~feasible).any():
                a.scatter(x[~feasible], y[~feasible], s=14, marker="x", color=_INFEASIBLE,
                          alpha=0.7, label="infeasible")  # fmt: skip
            a.scatter(x[front], y[front], s=22, color=FRONT_COLOR, label="Pareto front", zorder=3)
            if best is not None:
                hit = (done["trial"] == best).to_numpy()
                a.scatter(x[hit], y[hit], s=120, marker="*", color="black", label=f"trial {best}",
                          zorder=4)  # fmt: skip
            a.set_xlabel(names[i])
            a.set_ylabel(names[j])
            if _log_scale(x):
                a.set_xscale("log")
                _set_log(a.xaxis)
            if _log_scale(y):
                a.set_yscale("log")
                _set_log(a.yaxis)
            a.margins(0.06)
        handles: dict[str, Any] = {}
        for a in axes:
            for h, lab in zip(*a.get_legend_handles_labels(), strict=True):
                handles.setdefault(lab, h)
        if handles:
            axes[0].legend(list(handles.values()), list(handles), loc="best", fontsize="small")
        if title:
            fig.suptitle(title)
    return fig


_LABELS = {"ftsmc_st": "FTSMC-ST"}


def plot_comparison(
    mse: pd.DataFrame,
    ok: pd.DataFrame,
    pairs: pd.DataFrame,
    *,
    title: str | None = None,
    ax: Sequence[Axes] | None = None,
) -> Figure:
    """A fair comparison (:func:`slidingarm.tune.compare.compare`): the ECDF of each
    controller's MSE over the test draws (its finished runs), and each paired comparison's
    geometric-mean MSE ratio with its 95 % interval (left of 1: A's MSE is lower).

    Parameters
    ----------
    mse, ok : DataFrame
        One row per draw, one column per controller: the MSE (mean over joints) and whether
        the run finished.
    pairs : DataFrame
        Columns ``a``, ``b``, ``ratio``, ``ci_low``, ``ci_high``, ``verdict``.
    ax : two Axes, optional
    """
    from slidingarm.plotting._style import controller_style

    with matplotlib.rc_context(RC):
        if ax is None:
            fig = Figure(figsize=(11.0, 4.2))
            axes = list(fig.subplots(1, 2))
            fig.subplots_adjust(left=0.07, right=0.98, bottom=0.14, top=0.88, wspace=0.45)
        else:
            fig, axes = _axes(2, ax)
        a0, a1 = axes
        for i, c in enumerate(mse.columns):
            x = np.sort(mse[c].to_numpy(dtype=np.float64)[ok[c].to_numpy(dtype=bool)])
            if not x.size:
                continue
            style = controller_style(str(c).split("_")[0] if c != "ftsmc_st" else c, i)
            y = np.arange(1, x.size + 1) / len(mse)
            kw = style.kwargs()
            kw["label"] = _LABELS.get(str(c), style.label)
            a0.step(x, y, where="post", **kw)
        a0.set_xlabel("MSE (rad², mean over joints)")
        a0.set_ylabel("share of draws (failed runs never count)")
        a0.set_ylim(0, 1.02)
        if _log_scale(mse.to_numpy(dtype=np.float64).ravel()):
            a0.set_xscale("log")
            _set_log(a0.xaxis)
        a0.legend(loc="lower right", fontsize="small")
        names = [
            f"{_LABELS.get(a, a.upper())} < {_LABELS.get(b, b.upper())}"
            for a, b in zip(pairs["a"], pairs["b"], strict=True)
        ]
        yy = np.arange(len(pairs))[::-1]
        colors = {"holds": FRONT_COLOR, "reversed": _INFEASIBLE, "inconclusive": _OTHER}
        for y, (_, r) in zip(yy, pairs.iterrows(), strict=True):
            c = colors.get(str(r["verdict"]), _OTHER)
            a1.plot([r["ci_low"], r["ci_high"]], [y, y], color=c, linewidth=2.5)
            a1.plot([r["ratio"]], [y], "o", color=c)
        a1.axvline(1.0, color="black", linewidth=0.8, linestyle=(0, (4.0, 2.5)))
        a1.set_yticks(yy, names)
        a1.set_xscale("log")
        a1.margins(x=0.08)
        a1.xaxis.set_major_formatter(FormatStrFormatter("%g"))
        a1.xaxis.set_minor_formatter(FormatStrFormatter("%g"))
        a1.set_xlabel("geometric-mean MSE ratio A/B (95 % CI)")
        a1.set_ylim(-0.7, len(pairs) - 0.3)
        if title:
            fig.suptitle(title)
    return fig
