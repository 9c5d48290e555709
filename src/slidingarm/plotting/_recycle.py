"""Figures drawn again: a process that saves many figures of one layout reuses them.

Making a figure of panels (its Axes, and the ticks each axis makes on its first draw) is
about half of drawing one of the study's figures: drawn into figures given back, the study's
21 figures took 4.5-4.75 CPU-s one after another in one process against 5.6-5.9 for new
figures (two alternating runs, the PNG files identical).
A process that saves a figure and has no further use for it (a figure worker of
:func:`slidingarm.study.reproduce`, after :func:`slidingarm.plotting.save_figure`) hands it
back with :func:`give_back`; the next figure of the same layout (a key of :func:`tag`: the
kind of grid and its size) is then drawn into it, after :func:`_reset` has taken away what
the previous one drew and set back what the plot functions set. The result is the same
image as a new figure's, byte for byte (``tests/test_plotting.py`` draws every figure of a
scenario both ways and compares the PNG and SVG files).

Only a figure handed back is reused: a caller of the ``plot_*`` functions, who keeps the
figures, always gets a new one. One figure per layout is kept, in this process.
"""

from __future__ import annotations

from collections.abc import Hashable, Sequence

import matplotlib as mpl
from matplotlib.axes import Axes
from matplotlib.figure import Figure

__all__ = ["clear", "give_back", "held", "tag", "take"]

# the attribute of a tagged figure: (its layout key, its panels in its maker's order)
_ATTR = "_slidingarm_layout"
# layout key → a figure handed back, with its panels
_BIN: dict[Hashable, tuple[Figure, list[Axes]]] = {}


def tag(fig: Figure, key: Hashable, axes: Sequence[Axes]) -> None:
    """Record on ``fig``, a new figure of one of the makers of panels, its layout ``key`` and
    its panels ``axes`` (in the order its maker returns them), so that it can be given back.
    The record lives on the figure: nothing is kept here for a figure never given back."""
    setattr(fig, _ATTR, (key, list(axes)))


def give_back(fig: Figure) -> None:
    """Hand back ``fig`` (saved and no longer used by the caller) for the next figure of its
    layout; a figure no maker tagged, or of a layout already held, is left alone."""
    entry = getattr(fig, _ATTR, None)
    if entry is not None and entry[0] not in _BIN:
        _BIN[entry[0]] = (fig, entry[1])


def take(key: Hashable) -> tuple[Figure, list[Axes]] | None:
    """A figure of layout ``key`` handed back, reset to the state its maker left it in (with
    its panels), or ``None``."""
    entry = _BIN.pop(key, None)
    if entry is None:
        return None
    fig, axes = entry
    _reset(fig, axes)  # it keeps its tag
    return fig, axes


def held() -> list[Figure]:
    """The figures handed back and not yet reused, in this process."""
    return [fig for fig, _ in _BIN.values()]


def clear() -> None:
    """Drop the figures handed back (the next figures are new)."""
    _BIN.clear()


def _reset(fig: Figure, axes: list[Axes]) -> None:
    """Take away what a plot function drew on ``fig`` and set back what it set: the figure's
    title and legends; on each panel its lines, bands, texts and legend, its title and axis
    labels, a linear y scale (with its default locators and formatters), data limits, and the
    view limits ``(0, 1)`` with autoscaling on, as :meth:`~matplotlib.axes.Axes.clear` leaves
    them. What stays is what the layout made: the panels, their sharing, and the ticks."""
    title_color = mpl.rcParams["axes.titlecolor"]
    if str(title_color).lower() == "auto":
        title_color = mpl.rcParams["text.color"]
    for legend in list(fig.legends):
        legend.remove()
    suptitle = getattr(fig, "_suptitle", None)  # matplotlib has no public way to drop it
    if suptitle is not None:
        suptitle.remove()
        vars(fig)["_suptitle"] = None  # as a new figure has it
    for a in axes:
        for group in (a.lines, a.collections, a.patches, a.texts, a.images, a.tables, a.artists):
            for artist in list(group):
                artist.remove()
        if a.legend_ is not None:
            a.legend_.remove()
        for loc in ("left", "center", "right"):
            a.set_title("", loc=loc, color=title_color)
        a.set_xlabel("")
        a.set_ylabel("")
        if a.get_yscale() != "linear":
            a.set_yscale("linear")
        a.relim()
        a.set_xlim(0.0, 1.0, auto=True)
        a.set_ylim(0.0, 1.0, auto=True)
