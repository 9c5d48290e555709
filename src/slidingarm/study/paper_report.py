"""The paper's report: the study's numbers as a sequence of blocks (markdown text and
figures), written by the generic renderer of :mod:`slidingarm.report`.

:func:`write_report` writes ``report.md`` and a self-contained ``report.html`` from a
:class:`~slidingarm.study.report_context.ReportContext`. The report only formats what the study
computed: the MSE beside the paper's (beside the sign scenario only, the case of the paper's
MSE table), the gains and noise with their reasons, the checks, finite-time convergence, the
sign/tanh chattering contrast over the whole run and after the transient, the paper's errata and
their measured cost, the gain grid, every metric (with the thresholds of
:mod:`slidingarm.metrics`) and every figure. Every number in its prose comes from those tables
or from the library's constants.
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import pandas as pd

from slidingarm.metrics import (
    DEFAULT_CUTOFF_HZ,
    DEFAULT_DELTA_E,
    DEFAULT_DELTA_S,
    DEFAULT_WINDOW,
    METRIC_COLUMNS,
)
from slidingarm.plotting._catalog import FIGURES, SMOOTH_SECONDS
from slidingarm.report import Block, FigureBlock, write_blocks
from slidingarm.report._format import (
    COLUMN_LABELS,
    controller_label,
    format_value,
    frame_table,
    is_missing,
    markdown_table,
)
from slidingarm.study.analysis import (
    ALTERNATING,
    CONVERGENCE_COLUMNS,
    LATE_FRACTION,
    follows_ranking,
    ranking_mse,
)
from slidingarm.study.paper import (
    PAPER_FIGURES,
    PAPER_MSE_SWITCHING,
    RANKING,
    ScenarioKind,
    figure_stem,
    paper_figure_number,
)
from slidingarm.study.report_context import ReportContext

__all__ = [
    "PAPER_FIGURES",
    "ReportContext",
    "ScenarioKind",
    "build_blocks",
    "figure_stem",
    "paper_figure_number",
    "write_report",
]

_KIND_TEXT: dict[ScenarioKind, str] = {
    "sign": "sign switching (paper Figs. 3–9 and the MSE table)",
    "tanh": "tanh switching (paper Figs. 10–15)",
    "noise": "tanh switching with Gaussian noise on the measured angles (paper Figs. 16–22)",
}

_FIGURE_TEXT = {
    "tracking_all": "Joint angles q of every joint against the reference q_d (dashed black).",
    "tracking_joint1": "Joint 1 angle against the reference (dashed black).",
    "torque": (
        "Control torque of every joint (rows), one controller per column on a shared axis, so "
        "that no controller's chattering hides another's. Where a torque chatters, the "
        "translucent band is the range its samples fill and the line its "
        f"{format_value(SMOOTH_SECONDS * 1e3)} ms moving mean."
    ),
    "sliding": (
        "Sliding variable s of every joint (rows), one controller per column, on a symmetric "
        "log axis (linear in a narrow band around 0, whose half-width each row states), so "
        "that both the reaching phase and the band s stays in afterwards read."
    ),
    "velocity": "Joint velocities against the reference velocity (dashed black).",
    "error": "Tracking error e = q − q_d of every joint.",
    "steady_state": (
        f"Magnitude of the tracking error over the last {format_value(DEFAULT_WINDOW)} s, log "
        "axis (the paper reports final errors of 1e-7 to 1e-6 rad)."
    ),
}

_ERRATA_STATIC = """\
The paper's mathematics has errors that slidingarm corrects (docs/theory.md §8); each is listed with
what we do instead. The table after the list measures what they cost, by running the paper's
version of each as a variant of the study.

1. **A non-terminal exponent.** The paper writes the surface exponent as p/q with q < p, which
   is greater than 1: such a surface is not terminal and gives no finite-time convergence. We
   use γ = q/p < 1 with odd q < p (Yu & Man 2002) and reject non-terminal exponents.
2. **A row of M⁻¹ used as a scalar.** The paper's law (its eqs. 19–22) divides by
   g_i = [M⁻¹]_ii as if the joints were decoupled. We use the full nominal inertia matrix:
   τ = M̂(q) [q̈_d − ν(e, ė) − K φ(s)] + ĥ(q, q̇).
3. **No q̈_d feedforward.** The paper's law omits the reference acceleration; we add it, so that
   with an exact model the sliding variable obeys ṡ = −K φ(s) exactly.
4. **e^(p/q) is undefined for e < 0.** A fractional power of a negative error is not real; we
   use sig(e)^γ = |e|^γ sign(e).
5. **An unguarded singularity.** The surface's derivative holds |e|^(γ−1) ė, unbounded as
   e → 0 while ė ≠ 0; we evaluate it at max(|e|, ε_e) so the torque stays finite, and offer
   the nonsingular surface (NTSMC, Feng et al. 2002) as an extra controller.
"""


# ---------------------------------------------------------------------------- helpers
def _unique(values: Iterable[Any]) -> list[Any]:
    seen: list[Any] = []
    for v in values:
        if v not in seen:
            seen.append(v)
    return seen


def _scenarios(ctx: ReportContext) -> list[str]:
    names = [str(s) for s in _unique(ctx.metrics["scenario"].tolist())]
    for s in ctx.figures:
        if str(s) not in names:
            names.append(str(s))
    return names


def _scenario_title(ctx: ReportContext, name: str) -> str:
    kind = ctx.kinds.get(name)
    return f"{name}: {_KIND_TEXT[kind]}" if kind else name


def _order_text(order: Sequence[str]) -> str:
    return " < ".join(controller_label(c) for c in order)


def _mse(metrics: pd.DataFrame, scenario: str, controller: str, joint: str) -> float | None:
    """The ``mse`` of one row of the metrics table, None when it has no such row or value."""
    rows = metrics[
        (metrics["scenario"].astype(str) == scenario)
        & (metrics["controller"].astype(str) == controller)
        & (metrics["joint"].astype(str) == joint)
    ]
    if rows.empty:
        return None
    value = rows["mse"].iloc[0]
    return None if is_missing(value) else float(value)


def _ranking(ctx: ReportContext, scenario: str, joint: str) -> tuple[list[str], bool | None]:
    """The controllers of :data:`~slidingarm.study.paper.RANKING` this scenario ran (best
    first) and whether their MSE follows that order (None when fewer than two ran), as the
    study's checks judge it."""
    values = ranking_mse(ctx.metrics, scenario, joint)
    if len(values) < 2:
        return list(values), None
    return list(values), follows_ranking(values)


def _bool_count(df: pd.DataFrame, column: str) -> tuple[int, int] | None:
    if column not in df.columns or df.empty:
        return None
    values = df[column].dropna()
    return int(sum(bool(v) for v in values)), int(values.shape[0])


def _flatten(mapping: Mapping[str, Any], prefix: str = "") -> list[tuple[str, Any]]:
    items: list[tuple[str, Any]] = []
    for key, value in mapping.items():
        name = f"{prefix}{key}"
        if isinstance(value, Mapping):
            items += _flatten(value, prefix=f"{name}.")
        else:
            items.append((name, value))
    return items


def _kv_table(items: Sequence[tuple[str, Any]], header: tuple[str, str]) -> str:
    if not items:
        return "_None given._"
    return markdown_table(
        list(header), [[f"`{k}`", format_value(v)] for k, v in items], align=["l", "l"]
    )


def _fmt_runtime(value: Any) -> str:
    if isinstance(value, int | float) and not isinstance(value, bool):
        return f"{format_value(float(value))} s"
    return format_value(value)


# ---------------------------------------------------------------------------- sections
def _summary(ctx: ReportContext, scenarios: list[str]) -> str:
    version = ctx.meta.get("version")
    mean_hold = [_ranking(ctx, s, "mean")[1] for s in scenarios]
    j1_hold = [_ranking(ctx, s, "1")[1] for s in scenarios]
    judged = [h for h in mean_hold if h is not None]
    parts = [
        "slidingarm"
        + (f" {version}" if version else "")
        + " regenerates the study of the fast terminal sliding mode control (FTSMC) paper: a "
        "3-DOF planar arm tracking the paper's trajectory under PD sliding mode control "
        "(PDSMC), terminal sliding mode control (TSMC) and FTSMC, in "
        f"{len(scenarios)} scenario{'s' if len(scenarios) != 1 else ''} "
        f"({', '.join(scenarios)}), with the corrected control law (see the errata below).",
        "The paper publishes no controller gains, so its absolute MSE cannot be matched; what "
        f"must hold is its ranking {_order_text(RANKING)}.",
    ]
    if judged:
        j1 = [h for h in j1_hold if h is not None]
        parts.append(
            f"Our mean-over-joints MSE follows that ranking in {sum(judged)} of {len(judged)} "
            f"scenarios, and joint 1's in {sum(j1)} of {len(j1)}."
        )
    checks = _bool_count(ctx.checks, "passed")
    if checks:
        failed = []
        if "name" in ctx.checks.columns:
            failed = [
                str(n)
                for n, p in zip(ctx.checks["name"], ctx.checks["passed"], strict=True)
                if not is_missing(p) and not bool(p)
            ]
        parts.append(
            f"{checks[0]} of {checks[1]} checks of the study pass"
            + (f" (failing: {', '.join(failed)})." if failed else ".")
        )
    grid = _bool_count(ctx.grid, "ranking_holds")
    if grid:
        parts.append(f"Over the gain grid the ranking holds at {grid[0]} of {grid[1]} points.")
    return " ".join(parts)


def _reproduce(ctx: ReportContext) -> str:
    lines = ["## How to reproduce", ""]
    command = ctx.meta.get("command")
    if command:
        lines += ["```sh", str(command), "```", ""]
    labels = {
        "version": "slidingarm version",
        "seeds": "seeds",
        "seed": "seed",
        "runtime_s": "runtime",
        "date": "date",
        "python": "Python",
        "numpy": "NumPy",
    }
    items = []
    for key, value in ctx.meta.items():
        if key == "command":
            continue
        text = _fmt_runtime(value) if key == "runtime_s" else format_value(value)
        items.append([labels.get(key, key), text])
    if items:
        lines.append(markdown_table(["", "value"], items, align=["l", "l"]))
    return "\n".join(lines)


def _paper_scenarios(ctx: ReportContext, scenarios: Sequence[str]) -> list[str]:
    """The scenarios of the paper's MSE table's case (:data:`PAPER_MSE_SWITCHING`)."""
    return [s for s in scenarios if ctx.kinds.get(s) == PAPER_MSE_SWITCHING]


def _mse_section(ctx: ReportContext, scenarios: list[str]) -> str:
    ref = RANKING[0]
    ref_label = controller_label(ref)
    beside = _paper_scenarios(ctx, scenarios) if ctx.paper_mse else []
    lines = [
        "## Mean-square error beside the paper's",
        "",
        "MSE is the mean over all samples of the whole run of e² (rad²), for joint 1 and averaged "
        "over the joints; the paper does not say which joints or window its table uses. The "
        "paper gives no gains, so absolute values cannot match; the ratios to "
        f"{ref_label} compare the shape of the ranking, and what must hold is the order "
        f"{_order_text(RANKING)}.",
        "",
    ]
    if ctx.paper_mse:
        where = (
            f"so its values stand beside the {', '.join(f'**{s}**' for s in beside)} rows only"
            if beside
            else "which no scenario of this study runs, so they are not shown"
        )
        lines += [
            f"The paper's MSE table belongs to its {PAPER_MSE_SWITCHING}-switching case (its "
            "section with the sign function, after Figs. 3–9; the tanh and noise cases publish "
            f"no MSE), {where}.",
            "",
        ]
    header = [
        "scenario",
        "controller",
        "MSE joint 1 (rad²)",
        "MSE mean (rad²)",
        f"mean ÷ {ref_label}",
    ]
    align = ["l", "l", "r", "r", "r"]
    if beside:
        header += [f"paper MSE ({PAPER_MSE_SWITCHING})", f"paper ÷ {ref_label}"]
        align += ["r", "r"]
    rows = []
    for scen in scenarios:
        controllers = [
            str(c)
            for c in _unique(
                ctx.metrics.loc[ctx.metrics["scenario"].astype(str) == scen, "controller"]
            )
        ]
        ref_mean = _mse(ctx.metrics, scen, ref, "mean")
        for ctrl in controllers:
            j1 = _mse(ctx.metrics, scen, ctrl, "1")
            mean = _mse(ctx.metrics, scen, ctrl, "mean")
            ratio = mean / ref_mean if (mean is not None and ref_mean) else None
            row = [
                scen,
                controller_label(ctrl),
                format_value(j1),
                format_value(mean),
                format_value(ratio),
            ]
            if beside:
                if scen in beside:
                    paper = ctx.paper_mse.get(ctrl)
                    paper_ref = ctx.paper_mse.get(ref)
                    paper_ratio = paper / paper_ref if (paper is not None and paper_ref) else None
                    row += [format_value(paper), format_value(paper_ratio)]
                else:
                    row += ["", ""]
            rows.append(row)
    lines.append(markdown_table(header, rows, align=align))
    lines.append("")
    for scen in scenarios:
        order, holds_mean = _ranking(ctx, scen, "mean")
        _, holds_j1 = _ranking(ctx, scen, "1")
        if holds_mean is None and holds_j1 is None:
            continue
        lines.append(
            f"- **{scen}**: {_order_text(order)} holds on the mean over joints: "
            f"**{format_value(holds_mean)}**; on joint 1: **{format_value(holds_j1)}**."
        )
    return "\n".join(lines).rstrip()


def _gains_section(ctx: ReportContext) -> str:
    lines = ["## Gains and noise, with their reasons", "", "### Gains", ""]
    lines.append(_kv_table(_flatten(ctx.gains), ("gain", "value")))
    if ctx.gain_reasons.strip():
        lines += ["", ctx.gain_reasons.strip()]
    lines += ["", "### Measurement noise", ""]
    items = [(k, v) for k, v in _flatten(ctx.noise) if k != "reasons"]
    lines.append(_kv_table(items, ("setting", "value")))
    reasons = ctx.noise.get("reasons")
    if isinstance(reasons, str) and reasons.strip():
        lines += ["", reasons.strip()]
    return "\n".join(lines)


def _checks_section(ctx: ReportContext) -> str:
    lines = ["## Checks", ""]
    counts = _bool_count(ctx.checks, "passed")
    if counts:
        lines += [f"{counts[0]} of {counts[1]} checks pass.", ""]
    lines.append(frame_table(ctx.checks, ["name", "value", "threshold", "passed"]))
    return "\n".join(lines)


def _bands_text(conv: pd.DataFrame) -> str:
    """``"δ = 1e-4 rad in sign; 1e-6 rad in tanh"`` from the table's ``band`` column."""
    if conv.empty or "band" not in conv.columns or "scenario" not in conv.columns:
        return ""
    parts = []
    for scen in _unique(conv["scenario"].astype(str)):
        bands = _unique(conv.loc[conv["scenario"].astype(str) == scen, "band"].dropna())
        if bands:
            parts.append(f"{', '.join(format_value(b) for b in bands)} rad in {scen}")
    return "δ = " + "; ".join(parts) if parts else ""


def _convergence_section(ctx: ReportContext) -> str:
    bands = _bands_text(ctx.convergence)
    return "\n".join(
        [
            "## Finite-time convergence",
            "",
            "Under sign switching with an exact model each sliding variable reaches 0 at "
            "t_r = |s(0)|/k. From there, on the surface, the error reaches 0 in "
            "t_s = |e|^(1−γ) / (β(1−γ)) for TSM and "
            "t_s = ln((α|e|^(1−γ) + β)/β) / (α(1−γ)) for FTSM (paper eq. 10 with the exponent "
            "corrected). A sampled loop never makes e exactly 0, so the table measures the "
            "time to reach the band |e| < δ"
            + (f" ({bands}, above the error ripple each switching leaves)" if bands else "")
            + " and compares it with the formula's time for the same band, "
            "t_s(|e_r|) − t_s(δ), e_r being the error at reaching. PDSMC's linear surface "
            "converges only asymptotically, so it has no formula.",
            "",
            frame_table(ctx.convergence, list(CONVERGENCE_COLUMNS)),
        ]
    )


def _fraction_text(fraction: float) -> str:
    """``0.5`` → ``"the last half"``."""
    return "the last half" if fraction == 0.5 else f"the last {100 * fraction:.0f} %"


def _span(values: Sequence[float]) -> str:
    """``"2.1"`` or ``"2.1–2.2"``: the formatted minimum and maximum."""
    lo, hi = format_value(min(values)), format_value(max(values))
    return lo if lo == hi else f"{lo}–{hi}"


def _and(items: Sequence[str]) -> str:
    """``["a", "b", "c"]`` → ``"a, b and c"``."""
    items = list(items)
    return items[0] if len(items) == 1 else ", ".join(items[:-1]) + " and " + items[-1]


#: The post-transient columns of the chattering table, per switching ``<sw>_<key>``.
_LATE_KEYS = ("late", "step_late", "alternation_late", "gain_late")


def _chattering_section(ctx: ReportContext) -> str:
    ch = ctx.chattering
    lines = [
        "## Chattering: sign against tanh",
        "",
        "Chattering is the total variation of the torque per second (docs/theory.md §6), the mean over "
        "joints, under sign and under tanh switching, per controller. The first table takes the "
        "whole run, as the check on the sign/tanh ratio does.",
        "",
    ]
    if ch.empty or not all(c in ch.columns for c in ("controller", "sign", "tanh", "ratio")):
        lines.append(frame_table(ch, ["controller", "sign", "tanh", "ratio"]))
        return "\n".join(lines)
    lines.append(
        markdown_table(
            ["controller", "sign (N·m/s)", "tanh (N·m/s)", "ratio sign ÷ tanh"],
            [
                [
                    controller_label(r["controller"]),
                    format_value(r["sign"]),
                    format_value(r["tanh"]),
                    format_value(r["ratio"]),
                ]
                for _, r in ch.iterrows()
            ],
            align=["l", "r", "r", "r"],
        )
    )
    late_cols = [f"{sw}_{k}" for k in _LATE_KEYS for sw in ("sign", "tanh")]
    if not all(c in ch.columns for c in late_cols) or ch[late_cols].isna().all().all():
        return "\n".join(lines)
    rows = []
    for _, r in ch.iterrows():
        for sw in ("sign", "tanh"):
            rows.append(
                [controller_label(r["controller"]), sw]
                + [format_value(r[f"{sw}_{k}"]) for k in _LATE_KEYS]
            )
    lines += [
        "",
        f"After the transient, over {_fraction_text(LATE_FRACTION)} of each run: the "
        "chattering (mean over joints), the largest single torque step of any joint, the share "
        "of consecutive steps that reverse (1 when the torque flips every sample, about 0 when "
        "it is smooth, 2/3 for white noise; mean over joints) and the median over the window "
        "of the terminal term's gain per sample βγ|e|^(γ−1)·Ts (Ts the sample time; mean over "
        "joints; — without a terminal term).",
        "",
        markdown_table(
            [
                "controller",
                "switching",
                "chattering (N·m/s)",
                "largest step (N·m)",
                "reversing steps",
                "βγ|e|^(γ−1)·Ts",
            ],
            rows,
            align=["l", "l", "r", "r", "r", "r"],
        ),
        "",
        _chattering_text(ch),
    ]
    return "\n".join(lines).rstrip()


def _chattering_text(ch: pd.DataFrame) -> str:
    """What the post-transient columns show, in words, with the study's numbers."""

    def num(row: pd.Series, col: str) -> float:
        value = row[col]
        return math.nan if is_missing(value) else float(value)

    rows = [r for _, r in ch.iterrows()]
    sign_alt = [num(r, "sign_alternation_late") for r in rows]
    smooth = [r for r in rows if num(r, "tanh_alternation_late") < ALTERNATING]
    flipping = [r for r in rows if num(r, "tanh_alternation_late") >= ALTERNATING]
    parts = []
    if sign_alt and all(a >= ALTERNATING for a in sign_alt):
        parts.append(
            "Sign switching flips the torque at the sample rate for every controller "
            f"(reversing steps {_span(sign_alt)})."
        )
    if smooth:
        names = _and([controller_label(r["controller"]) for r in smooth])
        values = [num(r, "tanh_late") for r in smooth]
        parts.append(
            f"tanh's boundary layer removes that for {names} ({_span(values)} N·m/s after "
            "the transient)."
        )
    if flipping:
        names = _and([controller_label(r["controller"]) for r in flipping])
        late = [num(r, "tanh_late") for r in flipping]
        steps = [num(r, "tanh_step_late") for r in flipping]
        alt = [num(r, "tanh_alternation_late") for r in flipping]
        parts.append(
            f"It does not for {names}: under tanh their torque still alternates at the sample "
            f"rate (reversing steps {_span(alt)}; {_span(late)} N·m/s after the transient, "
            f"single steps of up to {format_value(max(steps))} N·m) — far less than under "
            "sign, but not smooth."
        )
        gains = [num(r, "tanh_gain_late") for r in flipping]
        sign_gains = [num(r, "sign_gain_late") for r in flipping]
        if all(g > 1 for g in gains):
            below = (
                f"; under sign switching their error stays where it is below 1 "
                f"({_span(sign_gains)}) and the switching itself dominates"
                if all(g < 1 for g in sign_gains)
                else ""
            )
            parts.append(
                "The cause is the terminal term in discrete time, not the switching law: "
                "near e = 0 the factor βγ|e|^(γ−1) of ė in ν grows without bound, and where "
                "βγ|e|^(γ−1)·Ts exceeds 1 the sampled loop overshoots at every sample. Under "
                f"tanh the error of {names} settles where βγ|e|^(γ−1)·Ts is above 1 (median "
                f"{_span(gains)} over the window)"
                + below
                + ". The singularity guard caps the factor at βγ·ε_e^(γ−1)·Ts; only a cap "
                "below 1, ε_e ≥ (βγ·Ts)^(1/(1−γ)), would stop the overshoot."
            )
    return " ".join(parts)


def _errata_runs(ctx: ReportContext) -> tuple[str, list[str]]:
    """A sentence naming the scenario (and controller) the errata runs use, and the columns
    it makes redundant in the table."""
    errata = ctx.errata
    said: dict[str, str] = {}
    for column in ("controller", "scenario"):
        if column in errata.columns and not errata.empty:
            values = [str(v) for v in _unique(errata[column].dropna())]
            if len(values) == 1:
                said[column] = values[0]
    if "scenario" not in said:
        return "", list(said)
    scen = said["scenario"]
    kind = ctx.kinds.get(scen)
    who = controller_label(said["controller"]) if "controller" in said else "the controller"
    what = f": {_KIND_TEXT[kind]}" if kind else ""
    return (
        f"Every variant runs {who} in the **{scen}** scenario, with its gains and settings"
        f"{what}. Only what the variant names differs.",
        list(said),
    )


def _errata_section(ctx: ReportContext) -> str:
    runs, drop = _errata_runs(ctx)
    return "\n".join(
        [
            "## The paper's errata, measured",
            "",
            _ERRATA_STATIC.strip(),
            "",
            (runs + " " if runs else "")
            + "A variant that diverged has no numbers (—); its description says what happened.",
            "",
            frame_table(
                ctx.errata.drop(columns=drop),
                [
                    "variant",
                    "description",
                    "mse_mean",
                    "mse_joint1",
                    "steady_state_error",
                    "chattering",
                ],
            ),
        ]
    )


_GRID_PARAMS = ("switching", "k", "lam_alpha", "beta", "gamma")
_GRID_FULL_MAX = 24
_GRID_FAIL_MAX = 30


#: Where the report sends a reader who asks whether the ranking survives fair tuning.
FAIR_COMPARISON = (
    "A grid of shared gains cannot settle the ranking: each controller may need gains of its "
    "own. `slidingarm compare robust --out DIR` tunes PDSMC, TSMC, FTSMC, NTSMC and FTSMC with "
    "super-twisting alike (the same trial budget, objective and torque and chattering limits), "
    "tests each on the same 1000 Monte Carlo draws of mass and payload error, measurement "
    "noise and a torque disturbance, and reports with 95 % confidence intervals whether "
    "FTSMC < TSMC < PDSMC holds and where it fails (`--quick` in under a minute)."
)


def _grid_section(ctx: ReportContext) -> str:
    grid = ctx.grid
    lines = ["## Gain grid", ""]
    counts = _bool_count(grid, "ranking_holds")
    if counts is None:
        lines.append(frame_table(grid))
        return "\n".join(lines)
    held, total = counts
    if not total:
        lines.append("The grid is empty.")
        return "\n".join(lines)
    lines += [
        "The study repeats the runs over a grid of gains to see where the paper's ranking "
        f"holds. **It holds at {held} of {total} grid points** ({100.0 * held / total:.0f}%).",
        "",
        FAIR_COMPARISON,
        "",
    ]
    params = [p for p in _GRID_PARAMS if p in grid.columns]
    params += [
        c
        for c in grid.columns
        if c not in params and not str(c).startswith("mse") and c != "ranking_holds"
    ]
    if params:
        rows = []
        for p in params:
            for value in _unique(grid[p].tolist()):
                sel = grid[grid[p] == value]["ranking_holds"].dropna()
                rows.append(
                    [
                        COLUMN_LABELS.get(str(p), str(p)),
                        format_value(value),
                        str(int(sum(bool(v) for v in sel))),
                        str(int(sel.shape[0])),
                    ]
                )
        lines += [
            "Where it holds, by the value of each gain (counting the grid points with that value):",
            "",
            markdown_table(["gain", "value", "holds", "points"], rows, align=["l", "r", "r", "r"]),
            "",
        ]
    columns = [*params, "mse_pdsmc", "mse_tsmc", "mse_ftsmc", "ranking_holds"]
    if total <= _GRID_FULL_MAX:
        lines += ["Every grid point:", "", frame_table(grid, columns)]
    elif held < total:
        fails = grid[~grid["ranking_holds"].fillna(False).astype(bool)]
        shown = fails.head(_GRID_FAIL_MAX)
        more = fails.shape[0] - shown.shape[0]
        lines += [
            "The grid points where it does not hold"
            + (f" (the first {_GRID_FAIL_MAX} of {fails.shape[0]}):" if more else ":"),
            "",
            frame_table(shown, columns),
        ]
    return "\n".join(lines).rstrip()


#: Marks a metric that does not apply to a scenario.
NOT_APPLICABLE = "n/a"


def _metrics_section(ctx: ReportContext, scenarios: list[str]) -> str:
    lines = [
        "## All metrics",
        "",
        "Definitions and thresholds are those of `slidingarm.metrics` (docs/theory.md §6), at its "
        "defaults: the reaching time is the first instant after which |s_i| ≤ δ_s = "
        f"{format_value(DEFAULT_DELTA_S)} rad/s for the rest of the run, the settling time the "
        f"first instant after which |e_i| ≤ δ_e = {format_value(DEFAULT_DELTA_E)} rad for the "
        "rest of the run (never: the signal is outside its band at the end); the steady-state "
        f"error is the largest |e| over the last {format_value(DEFAULT_WINDOW)} s; chattering "
        "is the total variation of τ per second; the HF power share is the part of τ's power "
        f"above {format_value(DEFAULT_CUTOFF_HZ)} Hz. `metrics.csv` also holds, per joint, the "
        "post-transient columns of the chattering section.",
    ]
    m = ctx.metrics
    keep = ["controller", "joint", *METRIC_COLUMNS]
    for scen in scenarios:
        sub = m[m["scenario"].astype(str) == scen]
        if sub.empty:
            continue
        sub = sub[[c for c in keep if c in sub.columns]]
        lines += ["", f"### {scen}", ""]
        if ctx.kinds.get(scen) == "noise" and "reaching_time" in sub.columns:
            sub = sub.assign(reaching_time=NOT_APPLICABLE)
            lines += [_noise_reaching_note(ctx, scen), ""]
        lines.append(frame_table(sub, ["controller", "joint"]))
    return "\n".join(lines)


def _noise_reaching_note(ctx: ReportContext, scen: str) -> str:
    """Why the reaching time does not apply to a scenario with measurement noise."""
    m = ctx.metrics
    rms = ""
    if "s_rms_late" in m.columns:
        rows = m[(m["scenario"].astype(str) == scen) & (m["joint"].astype(str) != "mean")]
        values = pd.to_numeric(rows["s_rms_late"], errors="coerce").dropna()
        if not values.empty:
            rms = (
                f" (after the transient its RMS is {_span(list(values))} rad/s per joint, "
                f"against δ_s = {format_value(DEFAULT_DELTA_S)} rad/s)"
            )
    return (
        f"Reaching times are not applicable here ({NOT_APPLICABLE}): the controller computes s "
        f"from the noisy measurements, so s carries the noise{rms} and keeps leaving the band "
        "|s| ≤ δ_s until the end of the run; the time after which it stays inside would "
        "measure the noise, not the reaching."
    )


def _figure_blocks(ctx: ReportContext, scenarios: list[str], out_dir: Path) -> list[Block]:
    blocks: list[Block] = [
        "## Figures\n\n"
        "Each scenario's figures, with the paper's figure that shows the same thing (its "
        "number is in the file's name, e.g. `sign_fig05_torque.png`). The paper "
        "shows joint 1 only for torque, sliding variable, velocity and error; we show every "
        "joint. Colours and line styles are the same in every figure; the reference is dashed "
        "black."
    ]
    for scen in scenarios:
        figs = ctx.figures.get(scen)
        if not figs:
            continue
        blocks.append(f"### {_scenario_title(ctx, scen)}")
        kind = ctx.kinds.get(scen)
        names = [f for f in FIGURES if f in figs] + [f for f in figs if f not in FIGURES]
        for number, name in enumerate(names, start=1):
            rel_path = Path(figs[name])
            disk = rel_path if rel_path.is_absolute() else out_dir / rel_path
            try:
                rel = rel_path.relative_to(out_dir) if rel_path.is_absolute() else rel_path
            except ValueError:
                rel = rel_path
            text = _FIGURE_TEXT.get(name, name.replace("_", " ").capitalize() + ".")
            if kind is not None:
                paper = PAPER_FIGURES[kind].get(name)
                if paper is None:
                    text += " No counterpart in the paper."
                else:
                    plural = "s" if (" " in paper or "–" in paper) else ""
                    text += f" Paper Fig{plural}. {paper}."
            caption = f"Figure {scen}.{number} ({name}). {text}"
            svg = disk.with_suffix(".svg")
            svg_rel = rel.with_suffix(".svg").as_posix() if svg.is_file() else None
            blocks.append(
                FigureBlock(rel=rel.as_posix(), path=disk, caption=caption, alt=text, svg=svg_rel)
            )
    return blocks


def build_blocks(ctx: ReportContext, out_dir: Path) -> tuple[str, list[Block]]:
    """The report's title and its blocks, in order."""
    scenarios = _scenarios(ctx)
    title = "Fast terminal sliding mode control of a 3-DOF arm: the paper's study, reproduced"
    blocks: list[Block] = [
        f"# {title}",
        _summary(ctx, scenarios),
        _reproduce(ctx),
        _mse_section(ctx, scenarios),
        _gains_section(ctx),
        _checks_section(ctx),
        _convergence_section(ctx),
        _chattering_section(ctx),
        _errata_section(ctx),
        _grid_section(ctx),
        _metrics_section(ctx, scenarios),
    ]
    blocks += _figure_blocks(ctx, scenarios, out_dir)
    return title, blocks


def write_report(out_dir: str | os.PathLike[str], ctx: ReportContext) -> tuple[Path, Path]:
    """Write ``out_dir/report.md`` and ``out_dir/report.html`` from ``ctx``.

    The markdown links each figure's PNG by its path relative to ``out_dir`` (as
    ``ctx.figures`` gives it); the HTML embeds the PNGs (:func:`slidingarm.report.write_blocks`).

    Raises
    ------
    FileNotFoundError
        If a figure of ``ctx.figures`` does not exist under ``out_dir``.
    """
    out = Path(out_dir)
    title, blocks = build_blocks(ctx, out)
    return write_blocks(out, title, blocks)
