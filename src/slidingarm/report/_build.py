"""The report as a sequence of blocks — markdown text and figures — rendered to both formats."""

from __future__ import annotations

import re
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from itertools import pairwise
from pathlib import Path
from typing import Any

import pandas as pd

from slidingarm.report._context import ReportContext
from slidingarm.report._format import (
    COLUMN_LABELS,
    controller_label,
    format_value,
    frame_table,
    is_missing,
    markdown_table,
)

__all__ = ["PAPER_FIGURES", "FigureBlock", "build_blocks", "scenario_kind"]

#: Scenario kind → figure name → the paper's figure number(s) showing the same thing (None:
#: the paper has no such figure). From the paper's captions: Figs. 3–9 sign switching,
#: 10–15 tanh, 16–22 tanh with noise; the paper shows joint 1 only for torque, sliding
#: variable, velocity and error.
PAPER_FIGURES: dict[str, dict[str, str | None]] = {
    "sign": {
        "tracking_all": "3 and 9",
        "tracking_joint1": "4",
        "torque": "5",
        "sliding": "6",
        "velocity": "7",
        "error": "8",
        "steady_state": None,
    },
    "tanh": {
        "tracking_all": "15",
        "tracking_joint1": "10",
        "torque": "11",
        "sliding": "12",
        "velocity": "13",
        "error": "14",
        "steady_state": None,
    },
    "noise": {
        "tracking_all": "21",
        "tracking_joint1": "16",
        "torque": "17",
        "sliding": "18",
        "velocity": "19",
        "error": "20",
        "steady_state": "22",
    },
}

#: The figures of a scenario in report order (that of ``slidingarm.plotting.FIGURES``).
_FIGURE_ORDER: tuple[str, ...] = tuple(PAPER_FIGURES["noise"])

_KIND_TEXT = {
    "sign": "sign switching (paper Figs. 3–9 and the MSE table)",
    "tanh": "tanh switching (paper Figs. 10–15)",
    "noise": "tanh switching with Gaussian noise on the measured angles (paper Figs. 16–22)",
}

_FIGURE_TEXT = {
    "tracking_all": "Joint angles q of every joint against the reference q_d (dashed black).",
    "tracking_joint1": "Joint 1 angle against the reference (dashed black).",
    "torque": (
        "Control torque of every joint. Where a torque chatters, the translucent band is the "
        "range its samples fill and the line its 5 ms moving mean."
    ),
    "sliding": (
        "Sliding variable s of every joint on a symmetric log axis (linear in a narrow band "
        "around 0, whose half-width each panel states), so that both the reaching phase and "
        "the band s stays in afterwards read."
    ),
    "velocity": "Joint velocities against the reference velocity (dashed black).",
    "error": "Tracking error e = q − q_d of every joint.",
    "steady_state": (
        "Magnitude of the tracking error over the last 0.5 s, log axis (the paper reports "
        "final errors of 1e-7 to 1e-6 rad)."
    ),
}

_ERRATA_STATIC = """\
The paper's mathematics has errors that slidingarm corrects (SPEC §3); each is listed with
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


@dataclass(frozen=True)
class FigureBlock:
    """One figure of the report: where its PNG is (relative to the report and on disk)."""

    rel: str
    path: Path
    caption: str
    alt: str
    svg: str | None = None


Block = str | FigureBlock


# ---------------------------------------------------------------------------- helpers
def scenario_kind(name: str) -> str | None:
    """``"sign"``, ``"tanh"`` or ``"noise"`` for a scenario name of the study, else None.

    Recognises names containing ``noise``/``disturb``, ``tanh``, ``sign``/``sgn``, or starting
    with the paper's scenario letters A, B, C (``"A"``, ``"a_sign"``, ``"B. tanh"``).
    """
    key = str(name).lower()
    if "noise" in key or "noisy" in key or "disturb" in key:
        return "noise"
    if "tanh" in key or "smooth" in key:
        return "tanh"
    if "sign" in key or "sgn" in key:
        return "sign"
    m = re.match(r"^([abc])(?![a-z0-9])", key)
    if m:
        return {"a": "sign", "b": "tanh", "c": "noise"}[m.group(1)]
    return None


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


def _scenario_title(name: str) -> str:
    kind = scenario_kind(name)
    return f"{name}: {_KIND_TEXT[kind]}" if kind else name


def _order_text(order: Sequence[str]) -> str:
    return " < ".join(controller_label(c) for c in order)


def _mse(metrics: pd.DataFrame, scenario: str, controller: str, joint: str) -> float | None:
    rows = metrics[
        (metrics["scenario"].astype(str) == scenario)
        & (metrics["controller"].astype(str) == controller)
    ]
    if rows.empty:
        return None
    joints = rows["joint"].astype(str)
    hit = rows[joints == joint]
    if not hit.empty:
        value = hit["mse"].iloc[0]
        return None if is_missing(value) else float(value)
    if joint == "mean":
        per_joint = pd.to_numeric(rows.loc[joints.str.fullmatch(r"\d+"), "mse"], errors="coerce")
        if per_joint.notna().any():
            return float(per_joint.mean())
    return None


def _ranking(ctx: ReportContext, scenario: str, joint: str) -> tuple[list[str], bool | None]:
    """The paper's order (best first) of the controllers this scenario ran, and whether our MSE
    follows it strictly (None when fewer than two controllers can be compared)."""
    present = {str(c) for c in ctx.metrics["controller"]}
    order = [c for c in sorted(ctx.paper_mse, key=lambda c: ctx.paper_mse[c]) if c in present]
    values = [_mse(ctx.metrics, scenario, c, joint) for c in order]
    pairs = [(c, v) for c, v in zip(order, values, strict=True) if v is not None]
    if len(pairs) < 2:
        return order, None
    return [c for c, _ in pairs], all(a[1] < b[1] for a, b in pairwise(pairs))


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
    order = [c for c in sorted(ctx.paper_mse, key=lambda c: ctx.paper_mse[c])]
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
        f"must hold is its ranking {_order_text(order)}.",
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


def _mse_section(ctx: ReportContext, scenarios: list[str]) -> str:
    order_all = [c for c in sorted(ctx.paper_mse, key=lambda c: ctx.paper_mse[c])]
    ref = order_all[0] if order_all else None
    ref_label = controller_label(ref) if ref else "best"
    lines = [
        "## Mean-square error beside the paper's",
        "",
        "MSE is the mean over all samples of the whole run of e² (rad²), for joint 1 and averaged "
        "over the joints; the paper does not say which joints or window its table uses. The "
        "paper gives no gains, so absolute values cannot match; the ratios to "
        f"{ref_label} compare the shape of the ranking, and what must hold is the order "
        f"{_order_text(order_all)}.",
        "",
    ]
    header = [
        "scenario",
        "controller",
        "MSE joint 1 (rad²)",
        "MSE mean (rad²)",
        f"mean ÷ {ref_label}",
        "paper MSE",
        f"paper ÷ {ref_label}",
    ]
    rows = []
    for scen in scenarios:
        controllers = [
            str(c)
            for c in _unique(
                ctx.metrics.loc[ctx.metrics["scenario"].astype(str) == scen, "controller"]
            )
        ]
        ref_mean = _mse(ctx.metrics, scen, ref, "mean") if ref else None
        for ctrl in controllers:
            j1 = _mse(ctx.metrics, scen, ctrl, "1")
            mean = _mse(ctx.metrics, scen, ctrl, "mean")
            paper = ctx.paper_mse.get(ctrl)
            ratio = mean / ref_mean if (mean is not None and ref_mean) else None
            paper_ratio = (
                paper / ctx.paper_mse[ref]
                if (paper is not None and ref and ctx.paper_mse[ref])
                else None
            )
            rows.append(
                [
                    scen,
                    controller_label(ctrl),
                    format_value(j1),
                    format_value(mean),
                    format_value(ratio),
                    format_value(paper),
                    format_value(paper_ratio),
                ]
            )
    lines.append(markdown_table(header, rows, align=["l", "l", "r", "r", "r", "r", "r"]))
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


def _convergence_section(ctx: ReportContext) -> str:
    return "\n".join(
        [
            "## Finite-time convergence",
            "",
            "Under sign switching with an exact model each sliding variable reaches 0 at "
            "t_r = |s(0)|/k. From there, on the surface, the error reaches 0 in "
            "t_s = |e|^(1−γ) / (β(1−γ)) for TSM and "
            "t_s = ln((α|e|^(1−γ) + β)/β) / (α(1−γ)) for FTSM (paper eq. 10 with the exponent "
            "corrected). A sampled loop never makes e exactly 0, so the table measures the "
            "time to reach the band |e| < δ (δ = 1e-4 rad under sign, whose ripple is a few "
            "1e-5 rad; δ = 1e-6 rad under tanh) and compares it with the formula's time for "
            "the same band, t_s(|e_r|) − t_s(δ), e_r being the error at reaching. PDSMC's "
            "linear surface converges only asymptotically, so it has no formula.",
            "",
            frame_table(
                ctx.convergence,
                [
                    "scenario",
                    "controller",
                    "joint",
                    "t_reach",
                    "e_at_reach",
                    "t_s_formula",
                    "t_s_measured",
                    "rel_error",
                ],
            ),
        ]
    )


def _chattering_section(ctx: ReportContext) -> str:
    return "\n".join(
        [
            "## Chattering: sign against tanh",
            "",
            "Chattering of the torque under sign and under tanh switching, per controller, as the "
            "study measures it (SPEC §6), and their ratio. Sign switching flips the torque at "
            "the sample rate; tanh's boundary layer removes that.",
            "",
            frame_table(ctx.chattering, ["controller", "sign", "tanh", "ratio"]),
        ]
    )


def _errata_section(ctx: ReportContext) -> str:
    return "\n".join(
        [
            "## The paper's errata, measured",
            "",
            _ERRATA_STATIC.strip(),
            "",
            "A variant that diverged has no numbers (—); its description says what happened.",
            "",
            frame_table(
                ctx.errata,
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


def _metrics_section(ctx: ReportContext, scenarios: list[str]) -> str:
    lines = [
        "## All metrics",
        "",
        "Definitions and thresholds are those of `slidingarm.metrics` (SPEC §6): times are "
        "the first instant after which the signal stays in its band (never: it does not); "
        "steady-state error is the largest |e| over the last 0.5 s; chattering is the total "
        "variation of τ per second; the HF power share is the part of τ's power above 50 Hz.",
    ]
    m = ctx.metrics
    for scen in scenarios:
        sub = m[m["scenario"].astype(str) == scen].drop(columns=["scenario"])
        if sub.empty:
            continue
        lines += ["", f"### {scen}", "", frame_table(sub, ["controller", "joint"])]
    return "\n".join(lines)


def _figure_blocks(ctx: ReportContext, scenarios: list[str], out_dir: Path) -> list[Block]:
    blocks: list[Block] = [
        "## Figures\n\n"
        "Each scenario's figures, with the paper's figure that shows the same thing. The paper "
        "shows joint 1 only for torque, sliding variable, velocity and error; we show every "
        "joint. Colours and line styles are the same in every figure; the reference is dashed "
        "black."
    ]
    for scen in scenarios:
        figs = ctx.figures.get(scen)
        if not figs:
            continue
        blocks.append(f"### {_scenario_title(scen)}")
        kind = scenario_kind(scen)
        names = [f for f in _FIGURE_ORDER if f in figs] + [
            f for f in figs if f not in _FIGURE_ORDER
        ]
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
