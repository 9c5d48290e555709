"""Number formatting and GitHub-flavoured markdown tables for the report.

Numbers get 4 significant digits, scientific notation below 1e-3 or from 1e4 up; missing values
show as an em dash, infinite times as "never" and other infinities as "∞" — the words ``inf``
and ``nan`` never reach the report.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import pandas as pd

from slidingarm.plotting import controller_style

__all__ = [
    "COLUMN_LABELS",
    "MISSING",
    "TIME_COLUMNS",
    "cell",
    "controller_label",
    "format_value",
    "frame_table",
    "is_missing",
    "markdown_table",
    "md_cell",
]

MISSING = "—"

#: Columns holding times, whose +∞ (the event never happened) reads "never".
TIME_COLUMNS: frozenset[str] = frozenset(
    {"reaching_time", "settling_time", "t_reach", "t_s_formula", "t_s_measured"}
)

#: Headers of known columns, with their units.
COLUMN_LABELS: dict[str, str] = {
    "scenario": "scenario",
    "controller": "controller",
    "joint": "joint",
    "mse": "MSE (rad²)",
    "rmse": "RMSE (rad)",
    "iae": "IAE (rad·s)",
    "itae": "ITAE (rad·s²)",
    "reaching_time": "reaching time (s)",
    "settling_time": "settling time (s)",
    "steady_state_error": "steady-state error (rad)",
    "final_error": "final error (rad)",
    "control_effort": "effort ∫τ²dt (N²·m²·s)",
    "peak_torque": "peak |τ| (N·m)",
    "chattering": "chattering (N·m/s)",
    "hf_power_share": "HF power share",
    "t_reach": "t reach (s)",
    "e_at_reach": "e at reach (rad)",
    "t_s_formula": "t_s formula (s)",
    "t_s_measured": "t_s measured (s)",
    "rel_error": "relative error",
    "band": "band δ (rad)",
    "chattering_late": "chattering after the transient (N·m/s)",
    "max_step_late": "largest step after the transient (N·m)",
    "alternation_late": "reversing steps after the transient",
    "terminal_gain_late": "βγ|e|^(γ−1)·Ts after the transient",
    "s_rms_late": "RMS of s after the transient (rad/s)",
    "mse_mean": "MSE mean (rad²)",
    "mse_joint1": "MSE joint 1 (rad²)",
    "mse_pdsmc": "MSE PDSMC",
    "mse_tsmc": "MSE TSMC",
    "mse_ftsmc": "MSE FTSMC",
    "ranking_holds": "ranking holds",
    "lam_alpha": "λ = α",
    "beta": "β",
    "gamma": "γ",
    "k": "k",
    "switching": "switching",
    "variant": "variant",
    "description": "description",
    "name": "check",
    "value": "value",
    "threshold": "threshold",
    "passed": "result",
    "sign": "sign",
    "tanh": "tanh",
    "ratio": "ratio",
}


def controller_label(name: Any) -> str:
    """A controller's name as the figures label it (:func:`slidingarm.plotting.controller_style`):
    ``"ftsmc"`` → ``"FTSMC"``; other names upper-cased."""
    return controller_style(str(name)).label


def is_missing(value: Any) -> bool:
    """``None``, NaN, ``pd.NA`` / ``NaT`` or an empty string."""
    if value is None:
        return True
    if isinstance(value, str):
        return value.strip() == ""
    try:
        return bool(pd.isna(value))
    except (TypeError, ValueError):
        return False


def _number(x: float) -> str:
    if x == 0.0:
        return "0"
    ax = abs(x)
    if ax < 1e-3 or ax >= 1e4:
        mant, exp = f"{x:.3e}".split("e")
        mant = mant.rstrip("0").rstrip(".")
        return f"{mant}e{int(exp)}"
    text = f"{x:.4g}"
    if "e" in text:  # .4g switched to exponent (9999.95 → 1e+04)
        return _number(float(text))
    return text


def format_value(value: Any, *, time: bool = False) -> str:
    """A table cell's text.

    Floats: 4 significant digits (``0.1331``, ``251.5``), scientific outside [1e-3, 1e4)
    (``3.032e-6``); ``None``/NaN → "—"; +∞ → "never" when ``time`` (an event that did not
    happen) else "∞"; −∞ → "-∞". Booleans → "yes"/"no"; integers as they are; sequences joined
    with ", "; mappings as ``key = value`` pairs; anything else through ``str``.
    """
    if isinstance(value, bool | np.bool_):
        return "yes" if bool(value) else "no"
    if is_missing(value):
        return MISSING
    if isinstance(value, numbers.Integral):
        return str(int(value))
    if isinstance(value, numbers.Real):
        x = float(value)
        if math.isnan(x):
            return MISSING
        if math.isinf(x):
            if x > 0:
                return "never" if time else "∞"
            return "-∞"
        return _number(x)
    if isinstance(value, str):
        return value
    if isinstance(value, Mapping):
        return ", ".join(f"{k} = {format_value(v, time=time)}" for k, v in value.items())
    if isinstance(value, Sequence | np.ndarray):
        return ", ".join(format_value(v, time=time) for v in value)
    return str(value)


def md_cell(text: str) -> str:
    """Text made safe for one markdown table cell (pipes escaped, line breaks removed)."""
    return " ".join(str(text).split()).replace("|", "\\|")


def markdown_table(
    header: Sequence[str],
    rows: Sequence[Sequence[str]],
    *,
    align: Sequence[str] | None = None,
) -> str:
    """A GitHub-flavoured markdown table; ``align`` holds ``"l"`` or ``"r"`` per column.

    Cells are taken as markdown (already formatted); pipes and line breaks are escaped.
    """
    width = len(header)
    if align is None:
        align = ["l"] * width
    rule = {"l": "---", "r": "---:", "c": ":---:"}
    lines = [
        "| " + " | ".join(md_cell(h) for h in header) + " |",
        "|" + "|".join(rule[a] for a in align) + "|",
    ]
    for row in rows:
        cells = [md_cell(c) for c in row] + [""] * (width - len(row))
        lines.append("| " + " | ".join(cells[:width]) + " |")
    return "\n".join(lines)


def frame_table(df: pd.DataFrame, columns: Sequence[str] | None = None) -> str:
    """``df`` (the given columns, in order, then any others) as a markdown table.

    Known columns get labels with units (:data:`COLUMN_LABELS`), controller names are written
    as acronyms, times use "never" for +∞, ``passed`` reads "pass" / "FAIL", numeric
    columns are right-aligned. An empty frame gives the sentence "No rows."
    """
    if df is None or df.shape[0] == 0:
        return "_No rows._"
    order = [c for c in (columns or []) if c in df.columns]
    order += [c for c in df.columns if c not in order]
    header = [COLUMN_LABELS.get(str(c), str(c)) for c in order]
    align = [
        "r"
        if pd.api.types.is_numeric_dtype(df[c]) and not pd.api.types.is_bool_dtype(df[c])
        else "l"
        for c in order
    ]
    rows = []
    for rec in df[order].itertuples(index=False, name=None):
        cells = []
        for col, value in zip(order, rec, strict=True):
            cells.append(cell(str(col), value))
        rows.append(cells)
    return markdown_table(header, rows, align=align)


def cell(column: str, value: Any) -> str:
    """One formatted cell of column ``column``."""
    if column == "passed" and not is_missing(value):
        return "pass" if bool(value) else "FAIL"
    if column == "controller" and not is_missing(value):
        return controller_label(value)
    return format_value(value, time=column in TIME_COLUMNS)
