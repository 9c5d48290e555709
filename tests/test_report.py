"""Tests for slidingarm.report and the paper's report (slidingarm.study.paper_report): a report written from small synthetic tables and one tiny
figure is complete, self-contained, escaped and never prints inf or nan."""

from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Any, get_args

import numpy as np
import pandas as pd
import pytest
from matplotlib.figure import Figure

from slidingarm.metrics import DEFAULT_CUTOFF_HZ, DEFAULT_DELTA_E, DEFAULT_DELTA_S, DEFAULT_WINDOW
from slidingarm.plotting import FIGURES, controller_style, save_figure
from slidingarm.plotting.figures import SMOOTH_SECONDS
from slidingarm.report import format_value
from slidingarm.report._format import controller_label
from slidingarm.study.analysis import ALTERNATING
from slidingarm.study.paper import PAPER_MSE_SWITCHING
from slidingarm.study.paper_report import PAPER_FIGURES, ReportContext, ScenarioKind, write_report

PAPER_MSE = {"ftsmc": 0.1331, "tsmc": 0.1976, "pdsmc": 0.4698}
SCENARIOS = ("A_sign", "B_tanh", "C_noise")
#: The kind of each scenario, given to the report (names are not read for it).
KINDS: dict[str, ScenarioKind] = {"A_sign": "sign", "B_tanh": "tanh", "C_noise": "noise"}
CONTROLLERS = ("pdsmc", "tsmc", "ftsmc")
METRICS = (
    "mse", "rmse", "iae", "itae", "reaching_time", "settling_time", "steady_state_error",
    "final_error", "control_effort", "peak_torque", "chattering", "hf_power_share",
)  # fmt: skip


def _metrics() -> pd.DataFrame:
    rows = []
    for si, scen in enumerate(SCENARIOS):
        for ci, ctrl in enumerate(CONTROLLERS):
            for joint in ("1", "2", "3", "mean"):
                row: dict[str, Any] = {"scenario": scen, "controller": ctrl, "joint": joint}
                for mi, m in enumerate(METRICS):
                    row[m] = (3 - ci) * 1e-3 * (1 + si) * (mi + 1)
                # PDSMC in the noise scenario never reaches its band
                row["reaching_time"] = math.inf if (ctrl == "pdsmc" and si == 2) else 0.1
                row["final_error"] = -3.8e-7
                row["s_rms_late"] = 0.03 if si == 2 else 1e-3 * (1 + ci)
                rows.append(row)
    return pd.DataFrame(rows)


def _grid(points: int) -> pd.DataFrame:
    rows = []
    for i in range(points):
        holds = i % 5 != 0
        rows.append(
            {
                "switching": "sign" if i % 2 else "tanh",
                "k": 10 * (1 + i % 3),
                "lam_alpha": 1 + i % 4,
                "beta": 2.0,
                "gamma": 0.6,
                "mse_pdsmc": 0.02,
                "mse_tsmc": 0.015,
                "mse_ftsmc": 0.01 if holds else 0.03,
                "ranking_holds": holds,
            }
        )
    return pd.DataFrame(rows)


def _chattering(tanh_alternation: tuple[float, float, float] = (0.0, 0.9, 0.92)) -> pd.DataFrame:
    """A chattering table as :func:`slidingarm.study.analysis.chattering_table` writes it, with
    the given share of reversing torque steps under tanh (PDSMC, TSMC, FTSMC)."""
    alternating = [a >= ALTERNATING for a in tanh_alternation]
    return pd.DataFrame(
        {
            "controller": list(CONTROLLERS),
            "sign": [1.2e5, 1.3e5, 1.5e5],
            "tanh": [300.0, 310.0, 0.0],
            "ratio": [400.0, 419.4, math.inf],
            "sign_late": [2.2e5, 2.5e5, 2.9e5],
            "tanh_late": [1800.0 if a else 9.0 for a in alternating],
            "sign_step_late": [170.0, 190.0, 230.0],
            "tanh_step_late": [5.0 if a else 0.01 for a in alternating],
            "sign_alternation_late": [1.0, 1.0, 1.0],
            "tanh_alternation_late": list(tanh_alternation),
            "sign_gain_late": [math.nan, 0.13, 0.14],
            "tanh_gain_late": [math.nan] + [2.1 if a else 0.5 for a in alternating[1:]],
        }
    )


def _section(md: str, heading: str) -> str:
    return md.split(heading)[1].split("\n## ")[0]


def _table_rows(section: str, first_cell: str) -> list[list[str]]:
    """Cells of the markdown table rows of ``section`` whose first cell is ``first_cell``."""
    rows = []
    for line in section.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if line.startswith("|") and cells[0] == first_cell:
            rows.append(cells)
    return rows


def _figures(out: Path) -> dict[str, dict[str, Path]]:
    figs: dict[str, dict[str, Path]] = {}
    for scen in SCENARIOS:
        figs[scen] = {}
        for name in ("tracking_all", "steady_state"):
            fig = Figure(figsize=(1.0, 1.0))
            fig.add_subplot().plot([0, 1], [0, 1])
            save_figure(fig, out / scen / name)
            figs[scen][name] = Path(scen) / f"{name}.png"
    return figs


def _context(out: Path, *, grid_points: int = 6, **changes: Any) -> ReportContext:
    fields: dict[str, Any] = {
        "metrics": _metrics(),
        "paper_mse": PAPER_MSE,
        "gains": {"k": 20, "ftsmc": {"alpha": 2.0, "beta": 2.0, "p": 5, "q": 3}, "tau_max": math.inf},
        "gain_reasons": "- **k = 20** makes the reaching time about 0.15 s.\n- <b>raw</b> html",
        "noise": {"sigma": 1e-4, "velocity": "dirty derivative", "seed": 1, "reasons": "σ: a 14-bit encoder."},
        "convergence": pd.DataFrame(
            {
                "scenario": ["A_sign", "A_sign"],
                "controller": ["pdsmc", "ftsmc"],
                "joint": ["1", "1"],
                "t_reach": [0.07, 0.11],
                "e_at_reach": [0.3, 0.25],
                "t_s_formula": [np.nan, 0.52],
                "t_s_measured": [math.inf, 0.53],
                "rel_error": [None, 0.019],
                "band": [1e-4, 1e-4],
            }
        ),
        "chattering": _chattering(),
        "errata": pd.DataFrame(
            [
                {"variant": "corrected", "description": "the default law", "mse_mean": 0.0125, "mse_joint1": 0.0044, "steady_state_error": 3e-6, "chattering": 1.5e5, "scenario": "A_sign", "controller": "ftsmc"},
                {"variant": "paper_exponent", "description": "p/q = 5/3: diverged at t = 0.12 s (joint 2)", "mse_mean": None, "mse_joint1": np.nan, "steady_state_error": None, "chattering": None, "scenario": "A_sign", "controller": "ftsmc"},
            ]
        ),
        "grid": _grid(grid_points),
        "checks": pd.DataFrame(
            {
                "name": ["ranking A", "t_r = |s(0)|/k", "sign/tanh chattering"],
                "value": [True, 0.004, math.inf],
                "threshold": ["FTSMC < TSMC < PDSMC", 0.01, 10.0],
                "passed": [True, True, False],
            }
        ),
        "kinds": KINDS,
        "meta": {"version": "0.1.0", "seeds": [1, 2], "runtime_s": 12.3456, "command": "slidingarm reproduce --out results", "date": "2026-01-01", "python": "3.11.7", "numpy": "2.4.6"},
    }  # fmt: skip
    fields.update(changes)
    if "figures" not in fields:
        fields["figures"] = _figures(out)
    return ReportContext(**fields)


def _without_data_uris(text: str) -> str:
    return re.sub(r"data:image/png;base64,[A-Za-z0-9+/=]+", "data:", text)


@pytest.fixture(scope="module")
def written(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, str, str]:
    out = tmp_path_factory.mktemp("report")
    md_path, html_path = write_report(out, _context(out))
    assert (md_path, html_path) == (out / "report.md", out / "report.html")
    return out, md_path.read_text(encoding="utf-8"), html_path.read_text(encoding="utf-8")


def test_both_files_written_and_no_temporary_files_left(written: tuple[Path, str, str]) -> None:
    out, md, html = written
    assert md.startswith("# ") and html.startswith("<!DOCTYPE html>")
    assert not [p for p in out.rglob("*") if p.name.endswith(".tmp")]


def test_html_is_self_contained(written: tuple[Path, str, str]) -> None:
    _, _, html = written
    assert html.count("data:image/png;base64,") == 6
    assert 'src="http' not in html
    assert not re.findall(r'src="(?!data:)', html)
    assert "<link" not in html and "<script" not in html
    assert "<style>" in html


def test_markdown_links_figures_relatively(written: tuple[Path, str, str]) -> None:
    _, md, _ = written
    assert "(A_sign/tracking_all.png)" in md
    assert "[SVG](C_noise/steady_state.svg)" in md
    assert "Paper Figs. 3 and 9." in md and "Paper Fig. 22." in md
    assert "No counterpart in the paper." in md


def test_mse_table_has_the_paper_values_and_rankings(written: tuple[Path, str, str]) -> None:
    _, md, html = written
    section = md.split("## Mean-square error")[1].split("\n## ")[0]
    for value in ("0.1331", "0.1976", "0.4698", "3.53", "1.485"):
        assert value in section and value in html
    # ours: FTSMC 1e-3 < TSMC 2e-3 < PDSMC 3e-3 in scenario A
    assert "| A_sign | FTSMC | 0.001 | 0.001 | 1 | 0.1331 | 1 |" in section
    assert section.count("holds on the mean over joints: **yes**") == 3


def test_paper_mse_stands_beside_its_own_case_only(written: tuple[Path, str, str]) -> None:
    """The paper's MSE table is its sign-switching case: its values appear on the rows of the
    sign scenario and nowhere else, and the text says which case they are from."""
    _, md, _ = written
    section = _section(md, "## Mean-square error")
    assert f"its {PAPER_MSE_SWITCHING}-switching case" in section
    paper_values = {format_value(v) for v in PAPER_MSE.values()}
    for scen in SCENARIOS:
        rows = _table_rows(section, scen)
        assert len(rows) == len(CONTROLLERS)
        for row in rows:
            paper_cells = row[5:]
            if KINDS[scen] == PAPER_MSE_SWITCHING:
                assert paper_cells[0] in paper_values
            else:
                assert paper_cells == ["", ""], row
    outside = md.replace(section, "")
    assert not any(v in outside for v in ("0.4698", "0.1976", "0.1331"))


def test_no_paper_columns_without_a_sign_scenario(tmp_path: Path) -> None:
    metrics = _metrics()
    metrics = metrics[metrics["scenario"] != "A_sign"]
    md_path, _ = write_report(tmp_path, _context(tmp_path, metrics=metrics, figures={}))
    section = _section(md_path.read_text(encoding="utf-8"), "## Mean-square error")
    assert "paper MSE" not in section and "0.1331" not in section
    assert "which no scenario of this study runs" in section


def test_metric_thresholds_are_stated_from_metrics_module(written: tuple[Path, str, str]) -> None:
    _, md, _ = written
    section = _section(md, "## All metrics")
    assert f"δ_s = {format_value(DEFAULT_DELTA_S)} rad/s" in section
    assert f"δ_e = {format_value(DEFAULT_DELTA_E)} rad" in section
    assert f"last {format_value(DEFAULT_WINDOW)} s" in section
    assert f"above {format_value(DEFAULT_CUTOFF_HZ)} Hz" in section


def test_reaching_time_not_applicable_under_noise(written: tuple[Path, str, str]) -> None:
    _, md, _ = written
    section = _section(md, "## All metrics")
    header = next(ln for ln in section.splitlines() if ln.startswith("| controller"))
    col = [c.strip() for c in header.strip("|").split("|")].index("reaching time (s)")
    for scen in SCENARIOS:
        sub = section.split(f"### {scen}")[1].split("### ")[0]
        cells = [
            [c.strip() for c in ln.strip().strip("|").split("|")][col]
            for ln in sub.splitlines()
            if ln.startswith("| ") and not ln.startswith("| controller")
        ]
        assert len(cells) == len(CONTROLLERS) * 4
        if KINDS[scen] == "noise":
            assert set(cells) == {"n/a"}
            # the note gives the measured RMS of s beside delta_s
            assert "Reaching times are not applicable" in sub and "RMS is 0.03 rad/s" in sub
        else:
            assert "n/a" not in cells and "not applicable" not in sub


def test_convergence_band_column_is_not_called_threshold(written: tuple[Path, str, str]) -> None:
    _, md, _ = written
    section = _section(md, "## Finite-time convergence")
    assert "band δ (rad)" in section and "threshold" not in section
    assert "δ = 1e-4 rad in A_sign" in section  # from the table, not typed
    checks = _section(md, "## Checks")
    assert "| check | value | threshold | result |" in checks


def test_errata_say_which_scenario_they_run(written: tuple[Path, str, str]) -> None:
    _, md, _ = written
    section = _section(md, "## The paper's errata, measured")
    assert "Every variant runs FTSMC in the **A_sign** scenario" in section
    header = next(ln for ln in section.splitlines() if ln.startswith("| variant"))
    assert "scenario" not in header  # said once in the text instead


def test_chattering_text_follows_the_post_transient_numbers(tmp_path: Path) -> None:
    """Which controllers the text calls smooth or alternating under tanh comes from the
    table, as does the cause it gives; nothing is claimed that the numbers do not show."""
    for tanh_alt in ((0.0, 0.9, 0.92), (0.0, 0.0, 0.0), (0.0, 0.0, 0.92)):
        out = tmp_path / "x".join(map(str, tanh_alt))
        md_path, _ = write_report(out, _context(out, chattering=_chattering(tanh_alt), figures={}))
        section = _section(md_path.read_text(encoding="utf-8"), "## Chattering")
        late_rows = [r for c in ("PDSMC", "TSMC", "FTSMC") for r in _table_rows(section, c)]
        assert (
            sorted(r[1] for r in late_rows if r[1] in ("sign", "tanh"))
            == ["sign"] * 3 + ["tanh"] * 3
        )  # the post-transient table has both laws for every controller
        flipping = {
            c.upper() for c, a in zip(CONTROLLERS, tanh_alt, strict=True) if a >= ALTERNATING
        }
        smooth = {c.upper() for c, a in zip(CONTROLLERS, tanh_alt, strict=True) if a < ALTERNATING}
        said_smooth = section.split("removes that for ")[1].split(" (")[0]
        assert set(re.findall(r"[A-Z]+SMC", said_smooth)) == smooth
        if flipping:
            said_flipping = section.split("It does not for ")[1].split(":")[0]
            assert set(re.findall(r"[A-Z]+SMC", said_flipping)) == flipping
            assert "βγ|e|^(γ−1)·Ts exceeds 1" in section  # the cause, with the gain
        else:
            assert "It does not for" not in section and "exceeds 1" not in section


def test_chattering_without_post_transient_columns(tmp_path: Path) -> None:
    chattering = _chattering()[["controller", "sign", "tanh", "ratio"]]
    md_path, _ = write_report(tmp_path, _context(tmp_path, chattering=chattering, figures={}))
    section = _section(md_path.read_text(encoding="utf-8"), "## Chattering")
    assert "| PDSMC | 1.2e5 | 300 | 400 |" in section
    assert "After the transient" not in section and "removes" not in section


def test_no_inf_or_nan_text_anywhere(written: tuple[Path, str, str]) -> None:
    _, md, html = written
    for text in (md, _without_data_uris(html)):
        assert not re.search(r"\b(inf|Inf|INF|nan|NaN|None)\b", text)
    assert "never" in md  # infinite times
    assert "∞" in md  # other infinities


def test_diverged_errata_row_and_static_errata(written: tuple[Path, str, str]) -> None:
    _, md, _ = written
    section = md.split("## The paper's errata, measured")[1].split("\n## ")[0]
    row = next(line for line in section.splitlines() if line.startswith("| paper_exponent"))
    assert "diverged at t = 0.12 s" in row and row.count("—") == 4
    for fact in ("γ = q/p < 1", "M̂", "q̈_d", "sig(e)^γ", "max(|e|, ε_e)", "NTSMC"):
        assert fact in section


def test_sections_checks_gains_noise_grid_reproduce(written: tuple[Path, str, str]) -> None:
    _, md, _ = written
    for heading in (
        "## How to reproduce",
        "## Gains and noise, with their reasons",
        "## Checks",
        "## Finite-time convergence",
        "## Chattering: sign against tanh",
        "## Gain grid",
        "## All metrics",
        "## Figures",
    ):
        assert heading in md
    assert "slidingarm reproduce --out results" in md and "12.35 s" in md
    assert "| pass |" in md and "| FAIL |" in md and "2 of 3 checks pass" in md
    assert "`ftsmc.alpha`" in md and "1e-4" in md and "σ: a 14-bit encoder." in md
    assert "It holds at 4 of 6 grid points" in md
    assert "t_r = \\|s(0)\\|/k" in md  # pipes escaped inside a table cell


def test_markup_in_text_is_escaped_in_html(written: tuple[Path, str, str]) -> None:
    _, _, html = written
    assert "<b>raw</b>" not in html and "&lt;b&gt;raw&lt;/b&gt;" in html
    assert "<strong>k = 20</strong>" in html  # markdown still renders


def test_large_grid_lists_only_failing_points(tmp_path: Path) -> None:
    md_path, _ = write_report(tmp_path, _context(tmp_path, grid_points=60))
    section = md_path.read_text(encoding="utf-8").split("## Gain grid")[1].split("\n## ")[0]
    assert "It holds at 48 of 60 grid points" in section
    assert "where it does not hold" in section
    # the way to the fair comparison, by a command that names a shipped scenario
    from slidingarm.study import SHIPPED

    assert "`slidingarm compare robust --out DIR`" in section and "robust" in SHIPPED
    table_rows = [
        ln for ln in section.splitlines() if ln.startswith("| sign") or ln.startswith("| tanh")
    ]
    assert len(table_rows) == 12


def test_missing_figure_and_bad_tables_are_reported(tmp_path: Path) -> None:
    ctx = _context(tmp_path, figures={"A_sign": {"torque": Path("A_sign/nope.png")}})
    with pytest.raises(FileNotFoundError, match=r"nope\.png"):
        write_report(tmp_path, ctx)
    with pytest.raises(ValueError, match="mse"):
        _context(tmp_path, metrics=_metrics().drop(columns=["mse"]), figures={})
    with pytest.raises(TypeError, match="grid"):
        _context(tmp_path, grid={"not": "a frame"}, figures={})


def test_empty_optional_tables_render(tmp_path: Path) -> None:
    ctx = _context(
        tmp_path,
        convergence=pd.DataFrame(),
        chattering=pd.DataFrame(),
        errata=pd.DataFrame(),
        grid=pd.DataFrame(),
        checks=pd.DataFrame(),
        figures={},
        meta={},
    )
    md_path, html_path = write_report(tmp_path, ctx)
    assert "_No rows._" in md_path.read_text(encoding="utf-8")
    assert "data:image" not in html_path.read_text(encoding="utf-8")


@pytest.mark.parametrize(
    ("value", "time", "text"),
    [
        (0.1331, False, "0.1331"),
        (251.48349, False, "251.5"),
        (3.0321e-6, False, "3.032e-6"),
        (-3.8e-7, False, "-3.8e-7"),
        (123456.0, False, "1.235e5"),
        (9999.96, False, "1e4"),
        (0.0, False, "0"),
        (math.inf, True, "never"),
        (math.inf, False, "∞"),
        (-math.inf, False, "-∞"),
        (math.nan, False, "—"),
        (None, False, "—"),
        (np.float64(0.5), False, "0.5"),
        (np.int64(3), False, "3"),
        (True, False, "yes"),
        ([1, 2], False, "1, 2"),
        ("text", False, "text"),
    ],
)
def test_format_value(value: Any, time: bool, text: str) -> None:
    assert format_value(value, time=time) == text


def test_kinds_come_from_the_context_not_the_names(tmp_path: Path) -> None:
    """A scenario's kind is what the context says, whatever its name: a "sign" scenario named
    "smooth" gets the paper's MSE and sign figures, a scenario without a kind gets neither."""
    metrics = _metrics().replace({"scenario": {"A_sign": "smooth", "C_noise": "plain"}})
    kinds: dict[str, ScenarioKind] = {"smooth": "sign", "B_tanh": "tanh"}
    md_path, _ = write_report(
        tmp_path, _context(tmp_path, metrics=metrics, kinds=kinds, figures={})
    )
    md = md_path.read_text(encoding="utf-8")
    section = _section(md, "## Mean-square error")
    assert "the **smooth** rows only" in section
    assert all(row[5] for row in _table_rows(section, "smooth"))
    assert all(row[5:] == ["", ""] for row in _table_rows(section, "plain"))
    assert "not applicable" not in _section(md, "## All metrics")  # no kind: no noise caveat
    with pytest.raises(ValueError, match="kinds"):
        _context(tmp_path, kinds={"A_sign": "sgn"}, figures={})


def test_figure_captions_state_the_plotting_constants(tmp_path: Path) -> None:
    figures = _figures(tmp_path)
    fig = Figure(figsize=(1.0, 1.0))
    fig.add_subplot().plot([0, 1], [0, 1])
    save_figure(fig, tmp_path / "A_sign" / "torque")
    figures["A_sign"]["torque"] = Path("A_sign") / "torque.png"
    md_path, _ = write_report(tmp_path, _context(tmp_path, figures=figures))
    md = md_path.read_text(encoding="utf-8")
    assert f"its {format_value(SMOOTH_SECONDS * 1e3)} ms moving mean" in md
    assert f"over the last {format_value(DEFAULT_WINDOW)} s, log axis" in md


def test_controller_labels_are_the_figures_labels() -> None:
    for name in ("pdsmc", "tsmc", "ftsmc", "ntsmc", "FTSMC", "mine"):
        assert controller_label(name) == controller_style(name).label
    assert controller_label("ftsmc") == "FTSMC" and controller_label("mine") == "MINE"


def test_paper_figure_map_covers_every_figure() -> None:
    assert set(PAPER_FIGURES) == set(get_args(ScenarioKind))
    for mapping in PAPER_FIGURES.values():
        assert tuple(mapping) == FIGURES
