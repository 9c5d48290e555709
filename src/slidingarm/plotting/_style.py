"""Shared look of every slidingarm figure: controller styles, rc settings, axes, decimation.

One controller keeps one colour and one line style in every figure, chosen so the three
controllers of the paper read apart in colour (Okabe–Ito palette, safe for colour-blind readers)
and in grey scale (different lightness and dash). The reference is always dashed black.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.ticker import LogFormatter
from numpy.typing import NDArray

from slidingarm.plotting import _recycle
from slidingarm.plotting._catalog import REFERENCE_STYLE, LineStyle, controller_style

if TYPE_CHECKING:
    from matplotlib.typing import RcKeyType

__all__ = [
    "RC",
    "REFERENCE_STYLE",
    "LineStyle",
    "PowerOfTenFormatter",
    "band_limits",
    "bottom_panels",
    "controller_style",
    "envelope",
    "frame",
    "panels",
    "pow10_text",
    "smooth",
    "subscript",
]

FloatArray = NDArray[np.float64]


#: Resolution of the PNG files: sharp on screen and in the HTML report, quick to render.
PNG_DPI = 150

#: rc settings of every figure (creation and saving). ``svg.hashsalt`` makes the SVG ids, and
#: so the files, identical from one run to the next.
RC: dict[RcKeyType, Any] = {
    "font.size": 10.0,
    "axes.labelsize": 10.0,
    "axes.titlesize": 10.5,
    "figure.titlesize": 12.0,
    "legend.fontsize": 9.5,
    "xtick.labelsize": 9.0,
    "ytick.labelsize": 9.0,
    "axes.grid": True,
    "grid.linewidth": 0.5,
    "grid.alpha": 0.35,
    "axes.spines.top": False,
    "axes.spines.right": False,
    "axes.xmargin": 0.0,
    "lines.linewidth": 1.4,
    "path.simplify": True,
    "agg.path.chunksize": 20000,
    "svg.hashsalt": "slidingarm",
    "svg.fonttype": "path",
    "savefig.dpi": PNG_DPI,
}


#: Fixed margins of the figures made here, in inches: a manual layout is as tidy as a layout
#: engine for these regular stacks of panels and saves its extra drawing pass on every save.
_LEFT, _RIGHT, _BOTTOM, _GAP = 0.95, 0.18, 0.55, 0.14
_TITLE_H, _LEGEND_H = 0.34, 0.30


#: Up to this many panels are stacked in one column; more (a 6- or 7-joint arm) go in a grid of
#: :data:`GRID_COLUMNS` columns, so each panel keeps a readable height on a page.
MAX_STACKED = 3
GRID_COLUMNS = 2
_GRID_WIDTH, _GRID_ROW_H = 10.0, 1.85


def panels(
    ax: Axes | Sequence[Axes] | None, count: int, *, height: float | None = None
) -> tuple[Figure, list[Axes], bool]:
    """Axes for ``count`` panels sharing the time axis.

    With ``ax=None`` a new :class:`~matplotlib.figure.Figure` (no pyplot, fixed margins that
    leave room at the top for a title and a one-row legend, see :func:`frame`) is made: up to
    :data:`MAX_STACKED` panels stacked in one column, more in a grid of :data:`GRID_COLUMNS`
    columns filled row by row (panel ``i`` at row ``i // 2``, column ``i % 2``; an empty last
    cell is removed and the panel above it shows the time axis). Otherwise ``ax`` must be one
    Axes (``count == 1``) or ``count`` Axes. Returns the figure, the axes and whether the
    figure is ours.
    """
    if ax is None and count > MAX_STACKED:
        return _grid(count, height)
    if ax is None:
        if height is None:
            height = 1.6 + 1.75 * count if count <= 3 else 1.6 + 1.4 * count
        key = ("stacked", count, height)
        reused = _recycle.take(key)
        if reused is not None:
            return reused[0], reused[1], True
        width = 7.0
        fig = Figure(figsize=(width, height))
        fig.subplots_adjust(
            left=_LEFT / width,
            right=1.0 - _RIGHT / width,
            bottom=_BOTTOM / height,
            top=1.0 - (_TITLE_H + _LEGEND_H) / height,
            hspace=_GAP * count / (height - _BOTTOM - _TITLE_H - _LEGEND_H - _GAP * (count - 1)),
        )
        grid = fig.subplots(count, 1, sharex=True, squeeze=False)
        stacked = [grid[i, 0] for i in range(count)]
        _recycle.tag(fig, key, stacked)
        return fig, stacked, True
    axes = [ax] if isinstance(ax, Axes) else list(ax)
    if len(axes) != count or not all(isinstance(a, Axes) for a in axes):
        raise ValueError(
            f"ax must be one Axes per panel: this plot has {count} panel(s) (one per joint), "
            f"got {len(axes)}; pass joints=[j] to draw a single joint on one Axes"
        )
    root = axes[0].figure
    while not isinstance(root, Figure):  # a SubFigure: its root Figure is what is returned
        root = root.figure
    return root, axes, False


def _grid(count: int, height: float | None) -> tuple[Figure, list[Axes], bool]:
    """A new figure of ``count`` panels in :data:`GRID_COLUMNS` columns (see :func:`panels`)."""
    cols = GRID_COLUMNS
    rows = math.ceil(count / cols)
    width = _GRID_WIDTH
    if height is None:
        height = _BOTTOM + _TITLE_H + _LEGEND_H + 0.25 + _GRID_ROW_H * rows
    key = ("grid", count, height)
    reused = _recycle.take(key)
    if reused is not None:
        return reused[0], reused[1], True
    fig = Figure(figsize=(width, height))
    inner_h = height - _BOTTOM - _TITLE_H - _LEGEND_H
    panel_w = (width - _LEFT - _RIGHT - _LEFT * (cols - 1)) / cols
    fig.subplots_adjust(
        left=_LEFT / width,
        right=1.0 - _RIGHT / width,
        bottom=_BOTTOM / height,
        top=1.0 - (_TITLE_H + _LEGEND_H) / height,
        wspace=_LEFT / panel_w,
        hspace=_GAP * rows / (inner_h - _GAP * (rows - 1)),
    )
    grid = fig.subplots(rows, cols, sharex=True, squeeze=False)
    axes = [grid[i // cols, i % cols] for i in range(count)]
    for i in range(count, rows * cols):
        fig.delaxes(grid[i // cols, i % cols])
        # the panel above the empty cell ends its column: it shows the time axis
        grid[i // cols - 1, i % cols].xaxis.set_tick_params(labelbottom=True)
    _recycle.tag(fig, key, axes)
    return fig, axes, True


def bottom_panels(axes: Sequence[Axes]) -> list[Axes]:
    """The lowest of ``axes`` in each column of their grid (where the time axis is labelled);
    the last one for axes that are not on one grid."""
    lowest: dict[int, tuple[int, Axes]] = {}
    for a in axes:
        spec = a.get_subplotspec()
        if spec is None:
            return [axes[-1]]
        row, col = spec.rowspan.stop, spec.colspan.start
        if col not in lowest or row > lowest[col][0]:
            lowest[col] = (row, a)
    return [a for _, a in lowest.values()]


def frame(fig: Figure, axes: list[Axes], own: bool, title: str | None) -> None:
    """Title and legend: on a figure of :func:`panels`, the title on top and one legend row
    under it; on the caller's axes, the title and legend of the first axes."""
    handles, labels = axes[0].get_legend_handles_labels()
    if own:
        height = fig.get_figheight()
        if title:
            fig.suptitle(title, y=1.0 - 0.1 / height, va="top")
        if handles:
            fig.legend(
                handles,
                labels,
                loc="lower center",
                bbox_to_anchor=(0.5, 1.0 - (_TITLE_H + _LEGEND_H) / height),
                ncols=min(len(handles), 5),
                frameon=False,
                handlelength=3.2,
                borderaxespad=0.1,
            )
    else:
        if title:
            axes[0].set_title(title)
        if handles:
            axes[0].legend(handles, labels, loc="upper right", handlelength=3.2, framealpha=0.85)


def envelope(t: FloatArray, y: FloatArray, max_points: int) -> tuple[FloatArray, FloatArray]:
    """Decimate ``y(t)`` to about ``max_points`` samples keeping each bucket's extremes.

    The samples are cut into buckets of ``b`` consecutive samples and each bucket keeps its
    minimum and its maximum, in time order (the min–max, or envelope, decimation): at a bucket
    width below a pixel the drawn line is the same as the full one, chattering included, while
    files stay small and rendering fast. The first and last samples are always kept.
    """
    size = t.shape[0]
    if size <= max_points or max_points < 4:
        return t, y
    b = math.ceil(size / (max_points // 2))
    m = (size // b) * b
    blocks = y[:m].reshape(-1, b)
    base = np.arange(blocks.shape[0]) * b
    picks = np.stack([base + np.argmin(blocks, axis=1), base + np.argmax(blocks, axis=1)], axis=1)
    idx = np.unique(np.concatenate([[0], picks.ravel(), np.arange(m, size), [size - 1]]))
    return t[idx], y[idx]


def smooth(y: FloatArray, width: int) -> FloatArray:
    """Centred moving mean of ``y`` over ``width`` samples; near the ends the window shrinks to
    the samples there are (so the ends are neither pulled towards 0 nor towards the end value)."""
    size = y.shape[0]
    if width <= 1 or size < 2:
        return y
    lo, hi = width // 2, width - 1 - width // 2
    csum = np.concatenate([[0.0], np.cumsum(y)])
    idx = np.arange(size)
    start = np.maximum(idx - lo, 0)
    stop = np.minimum(idx + hi + 1, size)
    return np.asarray((csum[stop] - csum[start]) / (stop - start), dtype=np.float64)


def band_limits(
    t: FloatArray, y: FloatArray, buckets: int
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Per-bucket time, minimum and maximum of ``y(t)`` for drawing its band as one filled
    polygon (much cheaper to render than the zig-zag of every sample, and the same picture
    when a bucket is narrower than a pixel). Each bucket spans ``ceil(T / buckets)`` samples and
    is placed at its first and last time, so the band covers the whole run."""
    size = t.shape[0]
    b = max(1, math.ceil(size / max(buckets, 1)))
    edges = np.arange(0, size, b)
    lo = np.minimum.reduceat(y, edges)
    hi = np.maximum.reduceat(y, edges)
    last = np.minimum(edges + b, size) - 1
    tb = np.stack([t[edges], t[last]], axis=1).ravel()
    return tb, np.repeat(lo, 2), np.repeat(hi, 2)


_SUB = str.maketrans("0123456789", "₀₁₂₃₄₅₆₇₈₉")
_SUP = str.maketrans("-0123456789", "⁻⁰¹²³⁴⁵⁶⁷⁸⁹")


def subscript(j: int) -> str:
    """``12`` → ``"₁₂"``: joint numbers in axis labels without mathtext (which costs a parse
    per label and per output format, the largest share of a figure's save time)."""
    return str(j).translate(_SUB)


def pow10_text(x: float) -> str:
    """``1e-3`` → ``"10⁻³"``, ``-2e-4`` → ``"−2×10⁻⁴"``, ``0`` → ``"0"``: plain Unicode."""
    if x == 0.0 or not math.isfinite(x):
        return "0" if x == 0.0 else str(x)
    sign = "\u2212" if x < 0 else ""
    exp = math.floor(math.log10(abs(x)) + 1e-9)
    mant = abs(x) / 10.0**exp
    power = "10" + str(exp).translate(_SUP)
    if abs(mant - 1.0) < 1e-6:
        return sign + power
    return f"{sign}{mant:.3g}×{power}"


class PowerOfTenFormatter(LogFormatter):
    """Log and symlog tick labels as ``10⁻³`` in plain Unicode: the same choice of labelled
    ticks as matplotlib's :class:`~matplotlib.ticker.LogFormatter`, without mathtext."""

    def __call__(self, x: float, pos: int | None = None) -> str:
        if x == 0.0:
            return "0"
        if not super().__call__(x, pos):
            return ""
        return pow10_text(float(x))
