"""Figures of slidingarm runs (docs/theory.md §7): pure drawing, no computation, no pyplot, no
``show()``.

Every ``plot_*`` function takes one ``SimResult`` or ``{controller name: SimResult}``, accepts an
optional ``ax=`` and returns the :class:`~matplotlib.figure.Figure`; :func:`plot_tool_path` draws
one tool path or several given as (T, 3) arrays; :func:`scenario_figures` makes the seven
figures of one scenario of the study (and the tool path of a serial arm's) and
:func:`save_figure` writes one as PNG and SVG.

The names are loaded on first use: importing this package does not import matplotlib, and
the figure names and controller styles (:mod:`slidingarm.plotting._catalog`) never do, so the
study's tables and report are written by a process that never loads it.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from slidingarm.plotting._catalog import (
        FIGURES,
        REFERENCE_STYLE,
        TOOL_FIGURES,
        LineStyle,
        controller_style,
    )
    from slidingarm.plotting._save import PNG_DPI, save_figure
    from slidingarm.plotting.figures import (
        MAX_POINTS,
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

#: The modules holding the public names, in the order they are looked in: the catalog first,
#: which does not import matplotlib.
_HOMES = ("_catalog", "_save", "figures")

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


#: The submodules, reachable as attributes (``slidingarm.plotting.figures``) as when the
#: package imported them.
_SUBMODULES = frozenset({"figures", "sweep", "tune"})

if not TYPE_CHECKING:  # for mypy, only the names imported above exist

    def __getattr__(name: str) -> Any:
        if name in __all__:
            homes = (importlib.import_module(f"{__name__}.{home}") for home in _HOMES)
            value = next(getattr(m, name) for m in homes if hasattr(m, name))
        elif name in _SUBMODULES:
            value = importlib.import_module(f"{__name__}.{name}")
        else:
            raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
        globals()[name] = value  # later lookups find it directly
        return value


def __dir__() -> list[str]:
    return sorted(set(__all__) | _SUBMODULES)
