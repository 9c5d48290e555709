"""What the figures are and how each controller is drawn, without matplotlib: the figure names
of a scenario, the line style of each controller, the width of the moving mean over chattering
signals.

The report and the study read these without drawing anything; importing this module does not
import matplotlib (about half a second), so a process that only writes tables and the report
never loads it (:func:`slidingarm.study.reproduce` forks its figure workers before they do).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

__all__ = [
    "FIGURES",
    "REFERENCE_STYLE",
    "SMOOTH_SECONDS",
    "TOOL_FIGURES",
    "LineStyle",
    "controller_style",
]

#: The figures of one scenario, in report order (keys of :func:`scenario_figures`).
FIGURES: tuple[str, ...] = (
    "tracking_all",
    "tracking_joint1",
    "torque",
    "sliding",
    "velocity",
    "error",
    "steady_state",
)

#: The figures a serial arm's scenario adds to :data:`FIGURES` (given its tool paths).
TOOL_FIGURES: tuple[str, ...] = ("tool_path",)

#: Width (s) of the moving mean drawn over a chattering signal (see ``_draw``): 10 samples at
#: the paper's 0.5 ms, which averages out switching at the sample rate but is short against
#: the arm's motion (reaching times of order 0.1 s).
SMOOTH_SECONDS = 5e-3


@dataclass(frozen=True)
class LineStyle:
    """How one controller (or the reference) is drawn."""

    label: str
    color: str
    linestyle: Any
    linewidth: float

    def kwargs(self) -> dict[str, Any]:
        """Keyword arguments for :meth:`matplotlib.axes.Axes.plot`."""
        return {
            "label": self.label,
            "color": self.color,
            "linestyle": self.linestyle,
            "linewidth": self.linewidth,
        }


#: The paper's controllers and the extra ones of the package, by controller name. Lightness
#: differs (blue dark, vermillion middle, orange light) so the lines also read in grey scale.
_KNOWN: dict[str, LineStyle] = {
    "pdsmc": LineStyle("PDSMC", "#E69F00", (0, (1.2, 1.2)), 1.9),
    "tsmc": LineStyle("TSMC", "#D55E00", (0, (6.0, 1.6, 1.6, 1.6)), 1.5),
    "ftsmc": LineStyle("FTSMC", "#0072B2", "solid", 1.5),
    "ntsmc": LineStyle("NTSMC", "#CC79A7", (0, (3.5, 1.5)), 1.5),
}

#: Styles handed out, in order, to controllers not in the table above.
_EXTRA: tuple[tuple[str, Any], ...] = (
    ("#009E73", (0, (4.0, 1.5, 1.0, 1.5, 1.0, 1.5))),
    ("#56B4E9", (0, (2.5, 1.0))),
    ("#7F7F7F", (0, (8.0, 2.0))),
    ("#882255", (0, (1.0, 2.0))),
)

#: The reference trajectory: dashed black, thin, drawn over the controllers.
REFERENCE_STYLE = LineStyle("reference", "black", (0, (4.0, 2.5)), 1.0)


def controller_style(name: str, index: int = 0) -> LineStyle:
    """The style of controller ``name``; unknown names get an extra style chosen by ``index``.

    Known names (``pdsmc``, ``tsmc``, ``ftsmc``, ``ntsmc``, any case) always get the same
    style, whatever their position; others are labelled with their name in upper case.
    """
    key = name.lower()
    if key in _KNOWN:
        return _KNOWN[key]
    color, dash = _EXTRA[index % len(_EXTRA)]
    return LineStyle(name.upper(), color, dash, 1.5)
