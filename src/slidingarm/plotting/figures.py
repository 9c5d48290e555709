"""The study's figures (docs/theory.md §7, paper Figs. 3–22): one function per signal, any number of joints.

Every joint ``plot_*`` function takes one :class:`~slidingarm.results.SimResult` or the runs to
compare as a mapping ``{controller name: SimResult}`` (drawn in the mapping's order, each
controller in its own fixed style; a single run is named by its controller), draws one
panel per joint over a shared time axis (stacked, or in a grid of two columns beyond three
joints), and returns the :class:`~matplotlib.figure.Figure`. :func:`plot_tool_path` draws tool
paths given as arrays (the caller computes them from its arm's kinematics). With
``ax=None`` it makes a new figure without pyplot (so it needs no GUI backend and leaves no
global state); otherwise it draws into ``ax`` — one Axes per joint drawn, or a single Axes with
``joints=[j]``. Nothing is shown or saved here: see :func:`slidingarm.plotting.save_figure`.

Joints are numbered from 1, as in the paper (``joints=[1]`` is the first joint).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from typing import Literal

import matplotlib
import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.ticker import NullLocator
from numpy.typing import ArrayLike, NDArray

from slidingarm.metrics import DEFAULT_WINDOW
from slidingarm.plotting import _recycle
from slidingarm.plotting._catalog import (
    FIGURES,
    REFERENCE_STYLE,
    SMOOTH_SECONDS,
    TOOL_FIGURES,
    LineStyle,
    controller_style,
)
from slidingarm.plotting._style import (
    RC,
    PowerOfTenFormatter,
    band_limits,
    bottom_panels,
    envelope,
    frame,
    panels,
    pow10_text,
    smooth,
    subscript,
)
from slidingarm.results import SimResult, run_name, sliding_unit

__all__ = [
    "FIGURES",
    "LAYOUTS",
    "TOOL_FIGURES",
    "as_mapping",
    "plot_error",
    "plot_sliding",
    "plot_steady_state",
    "plot_tool_path",
    "plot_torque",
    "plot_tracking",
    "plot_velocity",
    "scenario_figures",
]

FloatArray = NDArray[np.float64]

#: How several runs share a figure: ``"overlay"`` draws them on one panel per joint,
#: ``"columns"`` gives each run its own column of panels (small multiples), so that chattering
#: bands cannot hide one another.
Layout = Literal["overlay", "columns"]
LAYOUTS: tuple[str, ...] = ("overlay", "columns")
#: What every ``plot_*`` function takes: one run, or runs keyed by controller name.
Results = SimResult | Mapping[str, SimResult]
AxesArg = Axes | Sequence[Axes] | None


#: The projections of :func:`plot_tool_path`: (horizontal, vertical) coordinate of the root frame.
_PROJECTIONS: tuple[tuple[int, int], ...] = ((0, 1), (0, 2), (1, 2))
_AXIS_NAMES = "xyz"

#: Samples kept per line by default (min–max decimation, see ``envelope``): two per pixel
#: column of a 7-inch figure at 150 dpi, so the drawing equals the full-resolution one.
MAX_POINTS = 2400

_TIME_LABEL = "time t (s)"
_SINGLE_JOINT_HEIGHT = 3.6


# ---------------------------------------------------------------------------- helpers
def as_mapping(results: Results) -> Mapping[str, SimResult]:
    """``results`` as ``{name: SimResult}``: a single run is keyed by its controller's name
    (:func:`slidingarm.results.run_name`), so it keeps that controller's style."""
    if isinstance(results, SimResult):
        return {run_name(results.params): results}
    if not isinstance(results, Mapping):
        raise TypeError(
            "results must be a SimResult or a mapping {name: SimResult}, got "
            f"{type(results).__name__}"
        )
    for name, res in results.items():
        if not isinstance(res, SimResult):
            raise TypeError(f"results[{name!r}] must be a SimResult, got {type(res).__name__}")
    return results


def _items(results: Results) -> tuple[list[tuple[str, SimResult]], int]:
    """The runs in order and their common number of joints."""
    items = list(as_mapping(results).items())
    if not items:
        raise ValueError("results is empty: pass at least one {controller name: SimResult}")
    n = items[0][1].n
    for name, res in items:
        if res.n != n:
            raise ValueError(
                f"results must all have the same number of joints: {items[0][0]!r} has {n}, "
                f"{name!r} has {res.n}"
            )
    return items, n


def _joints(joints: Sequence[int] | None, n: int) -> list[int]:
    """Joint numbers (1-based) to draw, checked against ``n``."""
    if joints is None:
        return list(range(1, n + 1))
    chosen = [int(j) for j in joints]
    if not chosen or any(j < 1 or j > n for j in chosen):
        raise ValueError(f"joints must be joint numbers in 1..{n} (1-based), got {list(joints)}")
    return chosen


def _window_mask(t: FloatArray, window: float | None) -> slice | NDArray[np.bool_]:
    if window is None:
        return slice(None)
    return t >= t[-1] - window - 1e-9 * max(1.0, abs(float(t[-1])))


def _symlog_threshold(series: list[FloatArray]) -> float:
    """Linear half-width of a symlog axis: the level ``|s|`` keeps in the second half of the
    run (90th percentile, the largest over the controllers), rounded down to a power of ten and
    at least ``1e-4`` of the peak, so both the reaching phase and the band around 0 show."""
    peak = max(float(np.max(np.abs(y))) for y in series)
    tail = max(float(np.percentile(np.abs(y[y.shape[0] // 2 :]), 90)) for y in series)
    level = max(tail, 1e-4 * peak, 1e-300)
    return float(10.0 ** np.floor(np.log10(level)))


def _sliding_unit(res: SimResult) -> str:
    """Unit of a run's sliding variable (see :func:`slidingarm.results.sliding_unit`)."""
    return sliding_unit(res.params)


def _draw(
    a: Axes,
    t: FloatArray,
    y: FloatArray,
    style: LineStyle,
    *,
    zorder: float,
    max_points: int,
    band: bool,
) -> None:
    """One controller's line. With ``band=True`` a chattering signal — one whose total
    variation is more than twice that of its :data:`SMOOTH_SECONDS` moving mean — is drawn as
    the translucent band its samples fill (per-bucket min to max) under its moving mean in the
    controller's style, so that overlapping bands of several controllers stay readable."""
    if band and t.shape[0] > 2 and np.all(np.isfinite(y)):
        dt = float(t[1] - t[0])
        width = max(1, round(SMOOTH_SECONDS / dt)) if dt > 0 else 1
        mean = smooth(y, width)
        tv_raw = float(np.sum(np.abs(np.diff(y))))
        tv_mean = float(np.sum(np.abs(np.diff(mean))))
        if width > 1 and tv_raw > 2.0 * tv_mean + 1e-300:
            tb, lo, hi = band_limits(t, y, max_points // 2)
            a.fill_between(tb, lo, hi, color=style.color, alpha=0.3, linewidth=0, zorder=zorder - 1)
            tt, yy = envelope(t, mean, max_points)
            a.plot(tt, yy, zorder=zorder, **style.kwargs())
            return
    tt, yy = envelope(t, y, max_points)
    a.plot(tt, yy, zorder=zorder, **style.kwargs())


def _joint_plot(
    results: Results,
    *,
    ax: AxesArg,
    joints: Sequence[int] | None,
    title: str | None,
    signal: Callable[[SimResult], FloatArray],
    ylabel: Callable[[int], str],
    reference: Callable[[SimResult], FloatArray] | None = None,
    window: float | None = None,
    yscale: Literal["linear", "log", "symlog"] = "linear",
    symlog_unit: str = "",
    zero_line: bool = False,
    band: bool = True,
    max_points: int = MAX_POINTS,
    layout: Layout = "overlay",
) -> Figure:
    """Draw ``signal`` (shape (T, n)) of every run, one panel per joint (``layout="overlay"``)
    or one panel per joint and run (``"columns"``: a row per joint, a column per run, rows
    sharing their y axis); ``symlog_unit`` follows the linear half-width written on a symlog
    panel (empty: no unit)."""
    if layout not in LAYOUTS:
        raise ValueError(f"layout must be one of {', '.join(LAYOUTS)}, got {layout!r}")
    items, n = _items(results)
    chosen = _joints(joints, n)
    columns = layout == "columns" and len(items) > 1
    with matplotlib.rc_context(RC):
        data = [(idx, name, res, signal(res)) for idx, (name, res) in enumerate(items)]
        if columns:
            fig, grid, own = _column_panels(ax, len(chosen), len(items))
        else:
            height = _SINGLE_JOINT_HEIGHT if len(chosen) == 1 else None
            fig, axes, own = panels(ax, len(chosen), height=height)
            grid = [[a] for a in axes]
        for row, j in zip(grid, chosen, strict=True):
            col = j - 1
            groups = [[d] for d in data] if columns else [data]
            # one symlog threshold per joint, so that the panels of a row read alike
            every = [_column(res, y_all, col, window, yscale)[1] for _i, _n, res, y_all in data]
            for k, (a, group) in enumerate(zip(row, groups, strict=True)):
                _panel(
                    a, group, col, reference=reference, window=window, yscale=yscale,
                    symlog_unit=symlog_unit, zero_line=zero_line, band=band,
                    max_points=max_points, threshold_of=every, note=k == len(row) - 1,
                )  # fmt: skip
            row[0].set_ylabel(ylabel(j))
        flat = [a for row in grid for a in row]
        if columns:
            for a, (idx, name, _res, _y) in zip(grid[0], data, strict=True):
                style = controller_style(name, idx)
                a.set_title(style.label, color=style.color, fontsize=10.0, pad=3.0)
            for a in grid[-1]:
                a.set_xlabel(_TIME_LABEL)
            if own and title:
                fig.suptitle(title, y=1.0 - 0.1 / fig.get_figheight(), va="top")
            elif title:
                grid[0][0].set_title(f"{title}\n{grid[0][0].get_title()}")
        else:
            for a in bottom_panels(flat) if own else flat[-1:]:
                a.set_xlabel(_TIME_LABEL)
            frame(fig, flat, own, title)
    return fig


def _column(
    res: SimResult, y_all: FloatArray, col: int, window: float | None, yscale: str
) -> tuple[FloatArray, FloatArray]:
    """Times and joint ``col`` of a run's signal over ``window``; |y| with zeros left out on a
    log axis."""
    mask = _window_mask(res.t, window)
    y = np.array(y_all[mask, col], dtype=np.float64)
    if yscale == "log":
        y = np.abs(y)
        y[y == 0.0] = np.nan
    return res.t[mask], y


def _panel(
    a: Axes,
    data: Sequence[tuple[int, str, SimResult, FloatArray]],
    col: int,
    *,
    reference: Callable[[SimResult], FloatArray] | None,
    window: float | None,
    yscale: Literal["linear", "log", "symlog"],
    symlog_unit: str,
    zero_line: bool,
    band: bool,
    max_points: int,
    threshold_of: Sequence[FloatArray],
    note: bool = True,
) -> None:
    """One joint's panel: the runs of ``data`` (``(style index, name, result, signal)``), the
    reference of the first, and the axis scale (a symlog half-width from ``threshold_of``,
    written on the panel when ``note``)."""
    columns: list[FloatArray] = []
    t_lo, t_hi = np.inf, -np.inf
    for idx, name, res, y_all in data:
        t, y = _column(res, y_all, col, window, yscale)
        columns.append(y)
        _draw(
            a,
            t,
            y,
            controller_style(name, idx),
            zorder=3 + 0.1 * idx,
            max_points=max_points,
            band=band and yscale != "log",
        )
        t_lo, t_hi = min(t_lo, float(t[0])), max(t_hi, float(t[-1]))
    if reference is not None:
        res0 = data[0][2]
        mask = _window_mask(res0.t, window)
        tt, yy = envelope(res0.t[mask], reference(res0)[mask, col], max_points)
        a.plot(tt, yy, zorder=4, **REFERENCE_STYLE.kwargs())
    if zero_line:
        a.axhline(0.0, color="0.45", linewidth=0.6, zorder=1)
    if yscale == "symlog":
        finite = [c[np.isfinite(c)] for c in threshold_of if np.any(np.isfinite(c))]
        if finite and max(float(np.max(np.abs(c))) for c in finite) > 0.0:
            thr = _symlog_threshold(finite)
            a.set_yscale("symlog", linthresh=thr, linscale=0.6)
            a.yaxis.set_major_formatter(PowerOfTenFormatter(linthresh=thr))
            if note:
                a.text(
                    0.995,
                    0.97,
                    f"symlog axis, linear for |s| < {pow10_text(thr)}"
                    + (f" {symlog_unit}" if symlog_unit else ""),
                    transform=a.transAxes,
                    ha="right",
                    va="top",
                    fontsize=7.5,
                    color="0.35",
                )
    elif yscale == "log" and any(np.any(np.isfinite(c)) for c in columns):
        a.set_yscale("log")
        a.yaxis.set_major_formatter(PowerOfTenFormatter())
        a.yaxis.set_minor_formatter(PowerOfTenFormatter(labelOnlyBase=False))
        shown = np.concatenate([c[np.isfinite(c)] for c in columns])
        if np.log10(float(shown.max()) / float(shown.min())) >= 3.0:
            # decades read well alone over a wide range, and the 8 minor ticks per
            # decade would cost about a third of the figure's drawing time
            a.yaxis.set_minor_locator(NullLocator())
    if t_hi > t_lo:
        a.set_xlim(t_lo, t_hi)
    a.grid(True, which="major")


def _column_panels(
    ax: AxesArg, rows: int, cols: int
) -> tuple[Figure, list[list[Axes]], bool]:
    """A grid of ``rows`` joints by ``cols`` runs sharing x, each row sharing y: a new figure
    (``ax=None``) or the caller's ``rows * cols`` Axes in row-major order."""
    if ax is None:
        key = ("columns", rows, cols)
        reused = _recycle.take(key)
        if reused is not None:
            fig, flat = reused
            return fig, [flat[r * cols : (r + 1) * cols] for r in range(rows)], True
        width = 1.2 + 3.1 * cols
        height = 1.0 + 1.65 * rows
        fig = Figure(figsize=(width, height))
        fig.subplots_adjust(
            left=0.95 / width, right=1.0 - 0.18 / width, bottom=0.55 / height,
            top=1.0 - 0.68 / height, wspace=0.12, hspace=0.16 * rows / max(rows, 1),
        )  # fmt: skip
        grid = fig.subplots(rows, cols, sharex=True, sharey="row", squeeze=False)
        _recycle.tag(fig, key, [grid[r, c] for r in range(rows) for c in range(cols)])
        return fig, [[grid[r, c] for c in range(cols)] for r in range(rows)], True
    axes = [ax] if isinstance(ax, Axes) else list(ax)
    if len(axes) != rows * cols or not all(isinstance(a, Axes) for a in axes):
        raise ValueError(
            f"ax must be {rows * cols} Axes for layout='columns' (a row per joint, a column per "
            f"run, row-major), got {len(axes)}"
        )
    fig, _, _ = panels(axes, len(axes))
    return fig, [axes[r * cols : (r + 1) * cols] for r in range(rows)], False


# ---------------------------------------------------------------------------- plot functions
def plot_tracking(
    results: Results,
    *,
    ax: AxesArg = None,
    joints: Sequence[int] | None = None,
    measured: bool = False,
    title: str | None = "Joint position tracking",
    max_points: int = MAX_POINTS,
) -> Figure:
    """Joint angles :math:`q_i(t)` of every run against the reference :math:`q_{d,i}(t)`.

    Parameters
    ----------
    results : SimResult or Mapping[str, SimResult]
        One run, or runs keyed by controller name, drawn in this order.
    ax : Axes, sequence of Axes or None
        Where to draw: one Axes per joint drawn (a single Axes with ``joints=[j]``); ``None``
        makes a new figure.
    joints : sequence of int, optional
        Joint numbers, 1-based (default all).
    measured : bool
        Draw the measured angle :math:`\\tilde q` (with noise) instead of the true one.
    title : str or None
        Figure title (the first panel's title when drawing into ``ax``).
    max_points : int
        Samples kept per line (min–max decimation keeps every extreme).
    """
    sym = "q\u0303" if measured else "q"
    return _joint_plot(
        results,
        ax=ax,
        joints=joints,
        title=title,
        signal=(lambda r: r.q_meas) if measured else (lambda r: r.q),
        reference=lambda r: r.q_ref,
        ylabel=lambda j: f"{sym}{subscript(j)} (rad)",
        max_points=max_points,
    )


def plot_velocity(
    results: Results,
    *,
    ax: AxesArg = None,
    joints: Sequence[int] | None = None,
    measured: bool = False,
    title: str | None = "Joint velocity",
    max_points: int = MAX_POINTS,
) -> Figure:
    """Joint velocities :math:`\\dot q_i(t)` against the reference :math:`\\dot q_{d,i}(t)`.

    ``measured=True`` draws the velocity the controller used (its estimate from the noisy
    angle) instead of the true one. Other parameters as :func:`plot_tracking`.
    """
    sym = "measured q\u0307" if measured else "q\u0307"
    return _joint_plot(
        results,
        ax=ax,
        joints=joints,
        title=title,
        signal=(lambda r: r.qd_meas) if measured else (lambda r: r.qd),
        reference=lambda r: r.qd_ref,
        ylabel=lambda j: f"{sym}{subscript(j)} (rad/s)",
        max_points=max_points,
    )


def plot_torque(
    results: Results,
    *,
    ax: AxesArg = None,
    joints: Sequence[int] | None = None,
    title: str | None = "Control torque",
    max_points: int = MAX_POINTS,
    layout: Layout = "overlay",
) -> Figure:
    """Applied joint torques :math:`\\tau_i(t)` (zero-order hold samples), one panel per joint.

    Sign switching shows as a band (chattering) under its moving mean. With several runs
    ``layout="columns"`` gives each its own column of panels (rows share their y axis), so
    that one run's band cannot hide another's; ``ax`` is then ``joints × runs`` Axes in
    row-major order. Other parameters as :func:`plot_tracking`.
    """
    return _joint_plot(
        results,
        ax=ax,
        joints=joints,
        title=title,
        signal=lambda r: r.tau,
        ylabel=lambda j: f"τ{subscript(j)} (N·m)",
        max_points=max_points,
        layout=layout,
    )


def plot_sliding(
    results: Results,
    *,
    ax: AxesArg = None,
    joints: Sequence[int] | None = None,
    scale: Literal["symlog", "linear"] = "symlog",
    title: str | None = "Sliding variable",
    max_points: int = MAX_POINTS,
    layout: Layout = "overlay",
) -> Figure:
    """Sliding variables :math:`s_i(t)` as the controllers computed them.

    ``s`` starts of order 1 and then stays in a band around 0 (of width about
    :math:`k\\,\\Delta t` under sign switching), so the default ``scale="symlog"`` shows the
    reaching phase on log decades and the band on a linear stretch around 0, whose half-width
    is written in each panel. Other parameters as :func:`plot_tracking`.

    The unit of ``s`` depends on the surface: rad/s for :math:`s = \\dot e + \\dots` (PDSMC,
    TSMC, FTSMC), rad for NTSMC's :math:`s = e + \\beta^{-1}\\mathrm{sig}(\\dot e)^{p/q}` (read
    from each run's ``params["controller"]``; a run without them counts as rad/s). The axis
    carries the unit the runs share, or ``(rad/s; NTSMC: rad)`` when NTSMC is drawn with others.
    ``layout="columns"`` draws each run in its own column, as :func:`plot_torque`.
    """
    if scale not in ("symlog", "linear"):
        raise ValueError(f"scale must be 'symlog' or 'linear', got {scale!r}")
    units = {_sliding_unit(res) for res in as_mapping(results).values()}
    unit = units.pop() if len(units) == 1 else ""
    shown = unit or "rad/s; NTSMC: rad"
    return _joint_plot(
        results,
        ax=ax,
        joints=joints,
        title=title,
        signal=lambda r: r.s,
        ylabel=lambda j: f"s{subscript(j)} ({shown})",
        yscale=scale,
        symlog_unit=unit,
        zero_line=True,
        max_points=max_points,
        layout=layout,
    )


def plot_error(
    results: Results,
    *,
    ax: AxesArg = None,
    joints: Sequence[int] | None = None,
    title: str | None = "Tracking error",
    max_points: int = MAX_POINTS,
) -> Figure:
    """Tracking errors :math:`e_i = q_i - q_{d,i}` (true angle), one panel per joint.

    Parameters as :func:`plot_tracking`.
    """
    return _joint_plot(
        results,
        ax=ax,
        joints=joints,
        title=title,
        signal=lambda r: r.e,
        ylabel=lambda j: f"e{subscript(j)} (rad)",
        zero_line=True,
        max_points=max_points,
    )


def plot_steady_state(
    results: Results,
    *,
    ax: AxesArg = None,
    joints: Sequence[int] | None = None,
    window: float = DEFAULT_WINDOW,
    log: bool = True,
    title: str | None = "Steady-state tracking error",
    max_points: int = MAX_POINTS,
) -> Figure:
    """The tracking error over the last ``window`` seconds (default 0.5 s, as docs/theory.md §6).

    With ``log=True`` (default) it draws :math:`|e_i|` on a log axis, where final errors of
    1e-8 to 1e-3 rad all read (exact zeros are left out); ``log=False`` draws :math:`e_i`.
    Other parameters as :func:`plot_tracking`.
    """
    if not window > 0.0:
        raise ValueError(f"window must be > 0 s, got {window}")
    return _joint_plot(
        results,
        ax=ax,
        joints=joints,
        title=title,
        signal=lambda r: r.e,
        ylabel=(lambda j: f"|e{subscript(j)}| (rad)")
        if log
        else (lambda j: f"e{subscript(j)} (rad)"),
        window=window,
        yscale="log" if log else "linear",
        zero_line=not log,
        band=False,
        max_points=max_points,
    )


def _path(name: str, value: ArrayLike) -> FloatArray:
    arr = np.asarray(value, dtype=np.float64)
    if arr.ndim != 2 or arr.shape[1] != 3 or arr.shape[0] < 1:
        raise ValueError(f"{name} must be a path of shape (T, 3), got shape {arr.shape}")
    return arr


def _thin(path: FloatArray, max_points: int) -> FloatArray:
    """Every ``k``-th point of a path (and its last), at most about ``max_points``."""
    size = path.shape[0]
    if size <= max_points or max_points < 2:
        return path
    idx = np.unique(np.append(np.arange(0, size, math.ceil(size / max_points)), size - 1))
    return path[idx]


def plot_tool_path(
    paths: ArrayLike | Mapping[str, ArrayLike],
    reference: ArrayLike | None = None,
    *,
    ax: AxesArg = None,
    title: str | None = "Tool path",
    max_points: int = MAX_POINTS,
) -> Figure:
    """Tool-tip paths in the root frame, projected on its x-y, x-z and y-z planes.

    Parameters
    ----------
    paths : array_like (T, 3) or Mapping[str, array_like, shape (T, 3)]
        One tool path, or each controller's tool position over its run (m), keyed by
        controller name and drawn in this order, each in the controller's style; for example
        ``{name: arm.tool_position(result.q)}``.
    reference : array_like, shape (T, 3), optional
        The desired tool path (m), e.g. ``arm.tool_position(result.q_ref)``: dashed black,
        with its start marked by a circle.
    ax : sequence of 3 Axes or None
        Where to draw the x-y, x-z and y-z views; ``None`` makes a new figure.
    title : str or None
        Figure title (the first panel's title when drawing into ``ax``).
    max_points : int
        Points kept per path (every k-th sample and the last).

    Each view keeps equal scales on its two axes, so the paths keep their shape.
    """
    if not isinstance(paths, Mapping):
        paths = {"tool": paths}  # one path, drawn in the first extra style
    drawn = {name: _path(f"paths[{name!r}]", p) for name, p in paths.items()}
    if not drawn:
        raise ValueError("paths is empty: pass at least one {controller name: (T, 3) path}")
    ref = None if reference is None else _path("reference", reference)
    with matplotlib.rc_context(RC):
        if ax is None:
            width, height = 10.0, 4.3
            fig = Figure(figsize=(width, height))
            fig.subplots_adjust(
                left=0.85 / width, right=1.0 - 0.2 / width, bottom=0.6 / height,
                top=1.0 - 0.75 / height, wspace=0.45,
            )  # fmt: skip
            grid = fig.subplots(1, len(_PROJECTIONS), squeeze=False)
            axes, own = [grid[0, i] for i in range(len(_PROJECTIONS))], True
        else:
            fig, axes, own = panels(ax, len(_PROJECTIONS))
        for a, (h, v) in zip(axes, _PROJECTIONS, strict=True):
            for idx, (name, p) in enumerate(drawn.items()):
                thin = _thin(p, max_points)
                style = controller_style(name, idx)
                a.plot(thin[:, h], thin[:, v], zorder=3 + 0.1 * idx, **style.kwargs())
            if ref is not None:
                thin = _thin(ref, max_points)
                a.plot(thin[:, h], thin[:, v], zorder=4, **REFERENCE_STYLE.kwargs())
                a.plot(
                    ref[0, h], ref[0, v], marker="o", markersize=5, color="black",
                    markerfacecolor="none", linestyle="none", zorder=5, label="_start",
                )  # fmt: skip
            a.set_xlabel(f"{_AXIS_NAMES[h]} (m)")
            a.set_ylabel(f"{_AXIS_NAMES[v]} (m)")
            a.set_aspect("equal", adjustable="datalim")
            a.margins(0.08)
            a.grid(True, which="major")
        frame(fig, axes, own, title)
    return fig


# ---------------------------------------------------------------------------- one scenario
def chosen_figures(only: Sequence[str] | None, *, tool: bool = False) -> list[str]:
    """The figures ``only`` names (all of :data:`FIGURES`, and :data:`TOOL_FIGURES` with
    ``tool``, if ``None``), checked as :func:`scenario_figures` checks them.

    Raises
    ------
    ValueError
        If a name is not among those figures.
    """
    names = FIGURES + (TOOL_FIGURES if tool else ())
    wanted = list(names) if only is None else list(only)
    unknown = [name for name in wanted if name not in names]
    if unknown:
        raise ValueError(f"unknown figure {unknown[0]!r}; the figures are {', '.join(names)}")
    return wanted


def scenario_figures(
    results: Results,
    *,
    title: str,
    only: Sequence[str] | None = None,
    tool_paths: Mapping[str, ArrayLike] | None = None,
    tool_reference: ArrayLike | None = None,
) -> dict[str, Figure]:
    """Every figure of one scenario (docs/theory.md §7), keyed by :data:`FIGURES` (and
    :data:`TOOL_FIGURES` with ``tool_paths``), in that order.

    Parameters
    ----------
    results : SimResult or Mapping[str, SimResult]
        The scenario's runs keyed by controller name (``"pdsmc"``, ``"tsmc"``, ``"ftsmc"``,
        maybe others), in plot order.
    title : str
        The scenario, e.g. ``"A. sign switching"``; each figure's title is
        ``"<what it shows> — <title>"``.
    only : sequence of str, optional
        Draw just these figures (names from :data:`FIGURES`, or :data:`TOOL_FIGURES` with
        ``tool_paths``), e.g. to share the figures of a study out among processes.
    tool_paths : Mapping[str, array_like, shape (T, 3)], optional
        Each controller's tool path in the root frame (m), for the ``tool_path`` figure
        (:func:`plot_tool_path`); a serial arm's scenario gives them, a planar one does not.
    tool_reference : array_like, shape (T, 3), optional
        The desired tool path, drawn with ``tool_paths``.

    Raises
    ------
    ValueError
        If ``only`` names a figure that is not among those of this scenario.
    """
    results = as_mapping(results)
    _items(results)
    names = FIGURES + (TOOL_FIGURES if tool_paths is not None else ())
    wanted = chosen_figures(only, tool=tool_paths is not None)

    def full(what: str) -> str:
        return f"{what} — {title}" if title else what

    draw: dict[str, Callable[[], Figure]] = {
        "tracking_all": lambda: plot_tracking(results, title=full("Joint position tracking")),
        "tracking_joint1": lambda: plot_tracking(
            results, joints=[1], title=full("Joint 1 position tracking")
        ),
        # small multiples: the controllers' chattering bands would hide one another
        "torque": lambda: plot_torque(results, title=full("Control torque"), layout="columns"),
        "sliding": lambda: plot_sliding(
            results, title=full("Sliding variable"), layout="columns"
        ),
        "velocity": lambda: plot_velocity(results, title=full("Joint velocity")),
        "error": lambda: plot_error(results, title=full("Tracking error")),
        "steady_state": lambda: plot_steady_state(
            results, title=full(f"Steady-state error, last {DEFAULT_WINDOW:g} s")
        ),
    }
    if tool_paths is not None:
        paths = tool_paths
        draw["tool_path"] = lambda: plot_tool_path(
            paths, tool_reference, title=full("Tool path in the root frame")
        )
    return {name: draw[name]() for name in names if name in wanted}
