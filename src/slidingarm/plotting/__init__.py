"""Figures of slidingarm runs (docs/theory.md §7): pure drawing, no computation, no pyplot, no
``show()``.

Every ``plot_*`` function takes one ``SimResult`` or ``{controller name: SimResult}``, accepts an
optional ``ax=`` and returns the :class:`~matplotlib.figure.Figure`; :func:`plot_tool_path` draws
one tool path or several given as (T, 3) arrays; :func:`scenario_figures` makes the seven
figures of one scenario of the study (and the tool path of a serial arm's) and
:func:`save_figure` writes one as PNG and SVG.
"""

from slidingarm.plotting._save import PNG_DPI, save_figure
from slidingarm.plotting._style import REFERENCE_STYLE, LineStyle, controller_style
from slidingarm.plotting.figures import (
    FIGURES,
    MAX_POINTS,
    TOOL_FIGURES,
    as_mapping,
    plot_error,
    plot_sliding,
    plot_steady_state,
    plot_tool_path,
    plot_torque,
    plot_tracking,
    plot_velocity,
    scenario_figures,
)

__all__ = [
    "FIGURES",
    "MAX_POINTS",
    "PNG_DPI",
    "REFERENCE_STYLE",
    "TOOL_FIGURES",
    "LineStyle",
    "as_mapping",
    "controller_style",
    "plot_error",
    "plot_sliding",
    "plot_steady_state",
    "plot_tool_path",
    "plot_torque",
    "plot_tracking",
    "plot_velocity",
    "save_figure",
    "scenario_figures",
]
