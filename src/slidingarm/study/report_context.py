"""What the paper's report is written from: the study's numbers, choices and figures, in one object."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, get_args

import pandas as pd

from slidingarm.study.paper import ScenarioKind

__all__ = ["ReportContext", "ScenarioKind"]

#: Columns the report cannot do without, per table (the others are shown when present).
_REQUIRED: dict[str, tuple[str, ...]] = {
    "metrics": ("scenario", "controller", "joint", "mse"),
    "convergence": (),
    "chattering": (),
    "errata": (),
    "grid": (),
    "checks": (),
}


@dataclass(frozen=True, eq=False)
class ReportContext:
    """Everything :func:`~slidingarm.study.paper_report.write_report` needs.

    Attributes
    ----------
    metrics : DataFrame
        Long table, one row per (scenario, controller, joint): columns ``scenario``,
        ``controller``, ``joint`` (``"1"`` … ``"n"`` or ``"mean"``) and the metrics of
        :data:`slidingarm.metrics.METRIC_COLUMNS` (``mse``, ``rmse``, …), optionally followed
        by the post-transient :data:`slidingarm.study.analysis.LATE_COLUMNS`.
    paper_mse : Mapping[str, float]
        The paper's published MSE by controller name, e.g. ``{"ftsmc": 0.1331, ...}``: its
        sign-switching case, so the report shows it beside the sign scenario only.
    gains : Mapping[str, Any]
        The gains shared by the study (values may be nested mappings).
    gain_reasons : str
        Markdown: why these gains.
    noise : Mapping[str, Any]
        ``sigma``, the velocity estimator, the seed, … and ``"reasons"`` (markdown).
    convergence : DataFrame
        ``scenario, controller, joint, t_reach, e_at_reach, t_s_formula, t_s_measured,
        rel_error, band`` (``band``: the error band δ the times are measured to, rad).
    chattering : DataFrame
        ``controller, sign, tanh, ratio`` (whole run) and, when the study measured them, the
        post-transient ``<sw>_late, <sw>_step_late, <sw>_alternation_late, <sw>_gain_late`` for
        ``<sw>`` in ``sign``, ``tanh`` (see :func:`slidingarm.study.analysis.chattering_table`).
    errata : DataFrame
        ``variant, description, mse_mean, mse_joint1, steady_state_error, chattering`` and,
        optionally, the ``scenario`` and ``controller`` the variants run; the numbers of a
        variant that diverged are missing (None/NaN) and its description says so.
    grid : DataFrame
        ``switching, k, lam_alpha, beta, gamma, mse_pdsmc, mse_tsmc, mse_ftsmc,
        ranking_holds``.
    checks : DataFrame
        ``name, value, threshold, passed``.
    figures : Mapping[str, Mapping[str, Path]]
        Scenario → figure name → PNG path relative to the report's folder.
    kinds : Mapping[str, ScenarioKind]
        Scenario → the paper's case it runs (:data:`ScenarioKind`), as the study defines it
        (:func:`slidingarm.study.reproduce.scenario_kind`); a scenario not listed is none of
        them. The report sets the paper's MSE beside the ``"sign"`` scenarios (the case of
        :data:`slidingarm.study.paper.PAPER_MSE_SWITCHING`), names the paper's figures
        beside each scenario's, and does not apply the reaching time under ``"noise"``.
    meta : Mapping[str, Any]
        ``version``, ``seeds``, ``runtime_s``, ``command``, ``date``, Python and NumPy
        versions, ….
    """

    metrics: pd.DataFrame
    paper_mse: Mapping[str, float]
    gains: Mapping[str, Any]
    gain_reasons: str
    noise: Mapping[str, Any]
    convergence: pd.DataFrame
    chattering: pd.DataFrame
    errata: pd.DataFrame
    grid: pd.DataFrame
    checks: pd.DataFrame
    figures: Mapping[str, Mapping[str, Path]]
    kinds: Mapping[str, ScenarioKind]
    meta: Mapping[str, Any]

    def __post_init__(self) -> None:
        for name, required in _REQUIRED.items():
            value = getattr(self, name)
            if not isinstance(value, pd.DataFrame):
                raise TypeError(
                    f"ReportContext.{name} must be a pandas DataFrame, got {type(value).__name__}"
                )
            missing = [c for c in required if c not in value.columns]
            if missing:
                raise ValueError(
                    f"ReportContext.{name} lacks column(s) {missing}; it has {list(value.columns)}"
                )
        for name in ("paper_mse", "gains", "noise", "figures", "kinds", "meta"):
            if not isinstance(getattr(self, name), Mapping):
                raise TypeError(
                    f"ReportContext.{name} must be a mapping, got {type(getattr(self, name)).__name__}"
                )
        allowed = get_args(ScenarioKind)
        bad = {str(k): v for k, v in self.kinds.items() if v not in allowed}
        if bad:
            raise ValueError(
                f"ReportContext.kinds: a scenario's kind is one of {list(allowed)}, got {bad}"
            )
        if not isinstance(self.gain_reasons, str):
            raise TypeError("ReportContext.gain_reasons must be a markdown string")
