"""Tests for slidingarm.study: one real `reproduce` run, asserted on the files it wrote, and the
atomicity of the output folder under failures."""

from __future__ import annotations

import gc
import hashlib
import json
import math
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import slidingarm
from slidingarm.config import load_scenario
from slidingarm.metrics import DEFAULT_DELTA_E, DEFAULT_DELTA_S, METRIC_COLUMNS
from slidingarm.plotting import FIGURES
from slidingarm.report import format_value
from slidingarm.study import SCENARIOS, StudyOutput, load_shipped, reproduce, run_scenario
from slidingarm.study import analysis as A
from slidingarm.study import output as O
from slidingarm.study.output import MANIFEST, OutputError, Staging
from slidingarm.study.paper_report import figure_stem
from slidingarm.study.reproduce import ERRATA_SCENARIO, scenario_kind

CONTROLLERS = ("pdsmc", "tsmc", "ftsmc")
N_SAMPLES = 9001  # 4.5 s at 5e-4 s, both ends included
CSV_COLUMNS = ["t"] + [
    f"{prefix}{j}"
    for prefix in ("q", "qd", "qref", "qdref", "qm", "qdm", "tau", "s")
    for j in (1, 2, 3)
]


@pytest.fixture(scope="module")
def study(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, StudyOutput]:
    """The study, reproduced once for the whole module."""
    out = tmp_path_factory.mktemp("study") / "results"
    seen: list[tuple[str, int, int]] = []
    collecting: list[bool] = []

    def progress(what: str, done: int, total: int) -> None:
        seen.append((what, done, total))
        collecting.append(gc.isenabled())

    assert gc.isenabled()
    result = reproduce(out, progress=progress)
    assert seen and seen[-1][1] == seen[-1][2], "progress reaches its total"
    # no automatic garbage collection during the study (slidingarm._gc), and back after it
    assert collecting and not any(collecting)
    assert gc.isenabled()
    return out, result


@pytest.fixture(scope="module")
def metrics(study: tuple[Path, StudyOutput]) -> pd.DataFrame:
    return pd.read_csv(study[0] / "metrics.csv", dtype={"joint": str})


def mse(metrics: pd.DataFrame, scenario: str, controller: str, joint: str = "mean") -> float:
    row = metrics[
        (metrics.scenario == scenario)
        & (metrics.controller == controller)
        & (metrics.joint == joint)
    ]
    assert len(row) == 1
    return float(row["mse"].iloc[0])


# ---------------------------------------------------------------------------- files


@pytest.mark.parametrize("scenario", SCENARIOS)
@pytest.mark.parametrize("controller", CONTROLLERS)
def test_run_csv(study: tuple[Path, StudyOutput], scenario: str, controller: str) -> None:
    df = pd.read_csv(study[0] / scenario / f"{controller}.csv")
    assert list(df.columns) == CSV_COLUMNS
    assert len(df) == N_SAMPLES
    assert np.isfinite(df.to_numpy()).all()
    np.testing.assert_allclose(df["t"].to_numpy(), np.arange(N_SAMPLES) * 5e-4, rtol=0, atol=1e-12)
    np.testing.assert_allclose(df[["q1", "q2", "q3"]].iloc[0], slidingarm.PAPER_Q0)


def test_csv_is_exact(study: tuple[Path, StudyOutput]) -> None:
    """The CSV holds the run's floats exactly (shortest round-trip text)."""
    path = study[0] / "sign" / "ftsmc.csv"
    with path.open() as fh:
        header = fh.readline().strip().split(",")
        values = np.array([[float(x) for x in line.split(",")] for line in fh])
    again = run_scenario(load_shipped("sign"))["ftsmc"]
    assert header == again.columns()
    np.testing.assert_array_equal(values, again.to_dataframe().to_numpy())


def test_metrics_csv(metrics: pd.DataFrame) -> None:
    assert len(metrics) == len(SCENARIOS) * len(CONTROLLERS) * 4
    assert list(metrics.columns[:3]) == ["scenario", "controller", "joint"]
    assert set(METRIC_COLUMNS) <= set(metrics.columns)
    assert set(metrics.joint) == {"1", "2", "3", "mean"}
    assert not metrics[list(METRIC_COLUMNS)].isna().any().any()
    # the post-transient columns: finite, except the terminal gain of a controller without one
    assert set(A.LATE_COLUMNS) <= set(metrics.columns)
    others = [c for c in A.LATE_COLUMNS if c != "terminal_gain_late"]
    assert np.isfinite(metrics[others].to_numpy()).all()
    gain = metrics.set_index("controller")["terminal_gain_late"]
    assert gain.loc["pdsmc"].isna().all()
    assert np.isfinite(gain.loc[["tsmc", "ftsmc"]].to_numpy()).all()


def test_figures(study: tuple[Path, StudyOutput]) -> None:
    figures = study[0] / "figures"
    for scenario in SCENARIOS:
        for name in FIGURES:
            p = figures / f"{figure_stem(scenario, name)}.png"
            assert p.is_file() and p.stat().st_size > 1000, p
    # SVG on request only (reproduce(svg=True), --svg)
    assert sorted(p.suffix for p in figures.iterdir()) == [".png"] * len(SCENARIOS) * len(FIGURES)


def test_report(study: tuple[Path, StudyOutput]) -> None:
    out = study[0]
    md = (out / "report.md").read_text(encoding="utf-8")
    html = (out / "report.html").read_text(encoding="utf-8")
    assert "0.1331" in md  # the paper's numbers beside ours
    sources = re.findall(r"""<img[^>]*\ssrc=["']([^"']*)["']""", html)
    assert len(sources) >= len(SCENARIOS) * len(FIGURES)
    assert all(s.startswith("data:image/") for s in sources), "the HTML embeds its images"
    assert not re.search(r"""(src|href)=["'](https?:|//|file:)""", html), "no external resource"


def _md_section(out: Path, heading: str) -> str:
    md = (out / "report.md").read_text(encoding="utf-8")
    return md.split(heading)[1].split("\n## ")[0]


def _rows(section: str) -> list[list[str]]:
    return [
        [c.strip() for c in line.strip().strip("|").split("|")]
        for line in section.splitlines()
        if line.startswith("| ") and not line.startswith("|---")
    ]


def test_report_paper_mse_beside_the_sign_rows_only(study: tuple[Path, StudyOutput]) -> None:
    section = _md_section(study[0], "## Mean-square error")
    paper = {format_value(v) for v in A.PAPER_MSE.values()}
    rows = [r for r in _rows(section) if r[0] in SCENARIOS]
    assert len(rows) == len(SCENARIOS) * len(CONTROLLERS)
    kinds = {name: scenario_kind(load_shipped(name)) for name in SCENARIOS}
    for row in rows:
        beside = [c for c in row[5:] if c]
        if kinds[row[0]] == A.PAPER_MSE_SWITCHING:
            assert beside and beside[0] in paper, row
        else:
            assert not beside, row
    assert any(kinds[r[0]] == A.PAPER_MSE_SWITCHING for r in rows)


def test_report_chattering_after_the_transient(study: tuple[Path, StudyOutput]) -> None:
    """chattering.csv has the post-transient columns, and the report's words follow them: the
    controllers it calls smooth or alternating under tanh are those the numbers say, and it
    blames the terminal gain only where that gain per sample exceeds 1."""
    table = pd.read_csv(study[0] / "chattering.csv").set_index("controller")
    late = [
        f"{sw}_{k}" for k in ("late", "step_late", "alternation_late") for sw in ("sign", "tanh")
    ]
    assert np.isfinite(table[late].to_numpy()).all()
    assert (table[late].to_numpy() >= 0).all()
    assert table["sign_gain_late"].isna().loc["pdsmc"]
    assert (table["sign_alternation_late"] >= A.ALTERNATING).all()  # sign flips every sample
    section = _md_section(study[0], "## Chattering")
    smooth = [c for c in table.index if table.loc[c, "tanh_alternation_late"] < A.ALTERNATING]
    flipping = [c for c in table.index if c not in smooth]
    assert ("removes that for " in section) == bool(smooth), section
    said = section.split("removes that for ")[1].split(" (")[0] if smooth else ""
    assert set(re.findall(r"[A-Z]+SMC", said)) == {c.upper() for c in smooth}
    for c in flipping:
        # alternating under tanh goes with a terminal gain per sample above 1, and back
        assert table.loc[c, "tanh_gain_late"] > 1
        assert table.loc[c, "tanh_late"] > table.loc["pdsmc", "tanh_late"]
    for c in smooth:
        gain = table.loc[c, "tanh_gain_late"]
        assert math.isnan(gain) or gain <= 1
    assert ("It does not for " in section) == bool(flipping), section
    if flipping:
        said = section.split("It does not for ")[1].split(":")[0]
        assert set(re.findall(r"[A-Z]+SMC", said)) == {c.upper() for c in flipping}
        assert "βγ|e|^(γ−1)·Ts" in section


def test_report_states_thresholds_and_noise_caveat(study: tuple[Path, StudyOutput]) -> None:
    section = _md_section(study[0], "## All metrics")
    assert f"δ_s = {format_value(DEFAULT_DELTA_S)} rad/s" in section
    assert f"δ_e = {format_value(DEFAULT_DELTA_E)} rad" in section
    noisy = section.split("### noise")[1].split("### ")[0]
    assert "not applicable" in noisy
    header = next(r for r in _rows(noisy) if r[0] == "controller")
    col = header.index("reaching time (s)")
    assert {r[col] for r in _rows(noisy) if r[0] != "controller"} == {"n/a"}
    # the noise it cites is the study's: the RMS of s after the transient, beside delta_s
    metrics = pd.read_csv(study[0] / "metrics.csv", dtype={"joint": str})
    rms = metrics[(metrics.scenario == "noise") & (metrics.joint != "mean")]["s_rms_late"]
    assert format_value(rms.min()) in noisy and format_value(rms.max()) in noisy
    assert rms.max() > DEFAULT_DELTA_S / 2  # the noise on s is of the band's size
    errata = _md_section(study[0], "## The paper's errata")
    assert f"in the **{ERRATA_SCENARIO}** scenario" in errata


def test_configs_are_the_scenarios_run(study: tuple[Path, StudyOutput]) -> None:
    for scenario in SCENARIOS:
        copy = load_scenario(study[0] / "config" / f"{scenario}.toml")
        assert copy.to_dict() == load_shipped(scenario).to_dict()


def test_manifest(study: tuple[Path, StudyOutput]) -> None:
    out, result = study
    manifest = json.loads((out / MANIFEST).read_text())
    assert manifest["version"] == slidingarm.__version__
    assert manifest["scenarios"] == list(SCENARIOS)
    assert set(manifest["seeds"]) == set(SCENARIOS)
    assert manifest["runtime_s"] > 0 and manifest["command"]
    assert manifest["checks_passed"] is True
    listed = {f["path"]: f for f in manifest["files"]}
    on_disk = {p.relative_to(out).as_posix() for p in out.rglob("*") if p.is_file()} - {MANIFEST}
    assert set(listed) == on_disk
    for rel, entry in listed.items():
        data = (out / rel).read_bytes()
        assert entry["bytes"] == len(data)
        assert entry["sha256"] == hashlib.sha256(data).hexdigest()
    assert {Path(p).as_posix() for p in map(str, result.files)} == on_disk | {MANIFEST}
    # nothing left next to the output folder
    assert [p.name for p in out.parent.iterdir()] == [out.name]


# ---------------------------------------------------------------------------- the claims


@pytest.mark.parametrize("scenario", SCENARIOS)
@pytest.mark.parametrize("joint", ["mean", "1"])
def test_ranking(metrics: pd.DataFrame, scenario: str, joint: str) -> None:
    f, t, p = (mse(metrics, scenario, c, joint) for c in ("ftsmc", "tsmc", "pdsmc"))
    assert f < t < p


def test_ftsmc_steady_state(metrics: pd.DataFrame) -> None:
    def worst(scenario: str) -> float:
        rows = metrics[
            (metrics.scenario == scenario)
            & (metrics.controller == "ftsmc")
            & (metrics.joint != "mean")
        ]
        return float(rows["steady_state_error"].max())

    assert worst("sign") <= 1e-4
    assert worst("tanh") <= 1e-5
    # paper.toml's reasons: "from a few 1e-5 rad under sign ... to a few 1e-9 rad"
    assert 1e-5 <= worst("sign") < 1e-4
    assert 1e-9 <= worst("tanh") < 1e-8
    assert worst("sign") / worst("tanh") >= 100


def test_tanh_costs_little_tracking(metrics: pd.DataFrame) -> None:
    """paper.toml's reasons: with tanh "the MSE stays within a percent of sign switching"."""
    for c in CONTROLLERS:
        for joint in ("mean", "1"):
            assert mse(metrics, "tanh", c, joint) == pytest.approx(
                mse(metrics, "sign", c, joint), rel=0.01
            )


@pytest.mark.parametrize("controller", CONTROLLERS)
def test_chattering_contrast(
    study: tuple[Path, StudyOutput], metrics: pd.DataFrame, controller: str
) -> None:
    def tv(scenario: str) -> float:
        row = metrics[
            (metrics.scenario == scenario)
            & (metrics.controller == controller)
            & (metrics.joint == "mean")
        ]
        return float(row["chattering"].iloc[0])

    assert tv("sign") >= 10 * tv("tanh")
    table = pd.read_csv(study[0] / "chattering.csv").set_index("controller")
    assert table.loc[controller, "ratio"] == pytest.approx(tv("sign") / tv("tanh"))


def test_noise_scenario_bounded(metrics: pd.DataFrame) -> None:
    noisy = metrics[metrics.scenario == "noise"]
    assert np.isfinite(noisy[["mse", "steady_state_error", "peak_torque"]].to_numpy()).all()
    assert noisy["steady_state_error"].max() < 1e-2


def test_checks_all_pass(study: tuple[Path, StudyOutput]) -> None:
    checks = pd.read_csv(study[0] / "checks.csv")
    assert checks["passed"].all(), checks[~checks["passed"]].to_string()
    assert len(checks) >= 6 + 2 + 3 + 1 + 1
    assert study[1].passed


def test_convergence_matches_theory(study: tuple[Path, StudyOutput]) -> None:
    conv = pd.read_csv(study[0] / "convergence.csv")
    assert set(conv.scenario) == {"sign", "tanh"}
    assert set(conv.controller) == {"tsmc", "ftsmc"}
    assert len(conv) == 2 * 2 * 3
    assert "threshold" not in conv.columns  # the band delta, not a check's tolerance
    for scenario, group in conv.groupby("scenario"):
        assert (group.band == A.CONVERGENCE_BAND[str(scenario)]).all()
    assert (conv.t_reach > 0).all() and (conv.t_reach < 0.5).all()
    tanh = conv[conv.scenario == "tanh"]
    assert tanh.rel_error.abs().max() < 0.01
    assert conv.rel_error.abs().max() < 0.05


def test_errata(study: tuple[Path, StudyOutput]) -> None:
    errata = pd.read_csv(study[0] / "errata.csv").set_index("variant")
    assert list(errata.index) == [v for v, _, _ in A.ERRATA]
    assert set(errata.scenario) == {ERRATA_SCENARIO} and set(errata.controller) == {"ftsmc"}
    correct = errata.loc["correct"]
    for variant in errata.index[1:]:
        row = errata.loc[variant]
        # each erratum costs accuracy (or diverges, and says so)
        diverged = math.isnan(row.mse_mean) and "Diverged" in row.description
        assert diverged or row.mse_mean > correct.mse_mean


def test_gain_grid(study: tuple[Path, StudyOutput]) -> None:
    grid = pd.read_csv(study[0] / "gain_grid.csv")
    assert len(grid) == 2 * len(A.GRID_K) * len(A.GRID_LINEAR) * len(A.GRID_BETA)
    assert set(grid.switching) == {"sign", "tanh"}
    at = grid.set_index(["switching", "k", "lam_alpha", "beta"])
    for sw in ("sign", "tanh"):
        assert at.loc[(sw, 20.0, 2.0, 2.0), "ranking_holds"]  # the study's gains
        assert not at.loc[(sw, 20.0, 2.0, 5.0), "ranking_holds"]  # beta large: TSMC < FTSMC
        assert not at.loc[(sw, 20.0, 5.0, 1.0), "ranking_holds"]  # lambda large: PDSMC < TSMC
        assert not at.loc[(sw, 5.0, 2.0, 2.0), "ranking_holds"]  # k small: FTSMC reaches late
    # the grid's point at the study's gains is the study's own sign run, to the last bit (the
    # same runs, and the MSE of both is slidingarm.metrics.mse averaged over the joints)
    ours = at.loc[("sign", 20.0, 2.0, 2.0)]
    metrics = pd.read_csv(study[0] / "metrics.csv", dtype={"joint": str})
    mean = metrics[(metrics.scenario == "sign") & (metrics.joint == "mean")].set_index("controller")
    for label in ("pdsmc", "tsmc", "ftsmc"):
        assert ours[f"mse_{label}"] == mean.loc[label, "mse"]
    # the structural claims of paper.toml's reasons about the grid
    assert not (grid.ranking_holds & (grid.lam_alpha > grid.beta)).any()  # never with alpha > beta
    assert not grid[grid.lam_alpha == 5.0].ranking_holds.any()  # never at alpha = 5
    a5b1 = grid[(grid.lam_alpha == 5.0) & (grid.beta == 1.0)]
    assert (a5b1.mse_pdsmc < a5b1.mse_tsmc).all()  # PDSMC beats TSMC at every k
    a2b5 = grid[(grid.lam_alpha == 2.0) & (grid.beta == 5.0)]
    k_max = max(A.GRID_K)
    assert (a2b5[a2b5.k < k_max].mse_tsmc < a2b5[a2b5.k < k_max].mse_ftsmc).all()
    assert (a2b5[a2b5.k == k_max].mse_tsmc > a2b5[a2b5.k == k_max].mse_ftsmc).all()


# ---------------------------------------------------------------------------- atomicity


def staging_dirs(parent: Path) -> list[Path]:
    """Staging folders (and lock files) anywhere under ``parent``: beside or inside a target."""
    return [p for p in parent.rglob("*") if ".partial-" in p.name or p.name == O.LOCK]


def test_failure_mid_run_leaves_nothing(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    def boom(*args: object, **kwargs: object) -> None:
        raise RuntimeError("simulated failure")

    monkeypatch.setattr(A, "errata_table", boom)  # after the CSVs are staged
    out = tmp_path / "results"
    with pytest.raises(RuntimeError, match="simulated failure"):
        reproduce(out, jobs=1)
    assert not out.exists()
    assert staging_dirs(tmp_path) == []
    assert gc.isenabled()  # the collector's state restored on the way out too


def test_interrupt_keeps_the_previous_results(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    out = tmp_path / "results"
    (out / "sign").mkdir(parents=True)
    (out / "sign" / "ftsmc.csv").write_text("old")
    (out / MANIFEST).write_text("{}")

    def interrupt(*args: object, **kwargs: object) -> None:
        raise KeyboardInterrupt

    monkeypatch.setattr(A, "gain_grid", interrupt)
    with pytest.raises(KeyboardInterrupt):
        reproduce(out, jobs=1)
    assert (out / "sign" / "ftsmc.csv").read_text() == "old"
    assert (out / MANIFEST).read_text() == "{}"
    assert sorted(p.name for p in out.rglob("*")) == ["ftsmc.csv", MANIFEST, "sign"]
    assert staging_dirs(tmp_path) == []


def test_publish_failure_leaves_no_manifest(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Moving files into an existing folder: the old manifest goes first and the new one comes
    last, so a failure half-way leaves a folder without a manifest (visibly incomplete)."""
    out = tmp_path / "results"
    out.mkdir()
    (out / MANIFEST).write_text("{}")
    staging = Staging(out)
    for name in ("a.csv", "b.csv", "c.csv"):
        staging.write_text(name, "data\n")
    staging.write_manifest({"version": "test"})
    real_replace = O.os.replace
    calls = {"n": 0}

    def flaky(src: object, dst: object) -> None:
        calls["n"] += 1
        if calls["n"] == 2:
            raise OSError("disk full")
        real_replace(src, dst)  # type: ignore[arg-type]

    monkeypatch.setattr(O.os, "replace", flaky)
    with pytest.raises(OutputError, match="disk full"):
        staging.publish()
    assert not (out / MANIFEST).exists()
    assert staging_dirs(tmp_path) == []


def test_staged_files_are_invisible_until_published(tmp_path: Path) -> None:
    out = tmp_path / "results"
    staging = Staging(out)
    staging.write_text("x/y.csv", "1\n")
    # the folder is taken (locked, staging inside it) but holds no result yet
    assert sorted(p.name for p in out.iterdir()) == sorted([O.LOCK, staging.path.name])
    assert staging.path.name.startswith(".partial-")
    staging.write_manifest({})
    staging.publish()
    assert (out / "x" / "y.csv").read_text() == "1\n"
    manifest = json.loads((out / MANIFEST).read_text())
    assert [f["path"] for f in manifest["files"]] == ["x/y.csv"]
    assert staging_dirs(tmp_path) == []


def test_output_that_is_a_file(tmp_path: Path) -> None:
    target = tmp_path / "taken"
    target.write_text("mine")
    with pytest.raises(OutputError, match="exists and is not a folder"):
        reproduce(target)
    assert target.read_text() == "mine"
