"""Tests for slidingarm.study: one real `reproduce` run, asserted on the files it wrote, and the
atomicity of the output folder under failures."""

from __future__ import annotations

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
from slidingarm.metrics import METRIC_COLUMNS
from slidingarm.plotting import FIGURES
from slidingarm.study import SCENARIOS, StudyOutput, load_shipped, reproduce, run_scenario
from slidingarm.study import analysis as A
from slidingarm.study import output as O
from slidingarm.study.output import MANIFEST, OutputError, Staging

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
    result = reproduce(out, progress=lambda what, done, total: seen.append((what, done, total)))
    assert seen and seen[-1][1] == seen[-1][2], "progress reaches its total"
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


def test_figures(study: tuple[Path, StudyOutput]) -> None:
    figures = study[0] / "figures"
    for scenario in SCENARIOS:
        for name in FIGURES:
            for ext in ("png", "svg"):
                p = figures / f"{scenario}_{name}.{ext}"
                assert p.is_file() and p.stat().st_size > 1000, p


def test_report(study: tuple[Path, StudyOutput]) -> None:
    out = study[0]
    md = (out / "report.md").read_text(encoding="utf-8")
    html = (out / "report.html").read_text(encoding="utf-8")
    assert "0.1331" in md  # the paper's numbers beside ours
    sources = re.findall(r"""<img[^>]*\ssrc=["']([^"']*)["']""", html)
    assert len(sources) >= len(SCENARIOS) * len(FIGURES)
    assert all(s.startswith("data:image/") for s in sources), "the HTML embeds its images"
    assert not re.search(r"""(src|href)=["'](https?:|//|file:)""", html), "no external resource"


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
    assert (conv.t_reach > 0).all() and (conv.t_reach < 0.5).all()
    tanh = conv[conv.scenario == "tanh"]
    assert tanh.rel_error.abs().max() < 0.01
    assert conv.rel_error.abs().max() < 0.05


def test_errata(study: tuple[Path, StudyOutput]) -> None:
    errata = pd.read_csv(study[0] / "errata.csv").set_index("variant")
    assert list(errata.index) == [v for v, _, _ in A.ERRATA]
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
    ours = at.loc[("sign", 20.0, 2.0, 2.0)]
    assert ours.mse_ftsmc == pytest.approx(0.0125, abs=5e-5)


# ---------------------------------------------------------------------------- atomicity


def staging_dirs(parent: Path) -> list[Path]:
    return [p for p in parent.iterdir() if ".partial-" in p.name]


def test_failure_mid_run_leaves_nothing(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    def boom(*args: object, **kwargs: object) -> None:
        raise RuntimeError("simulated failure")

    monkeypatch.setattr(A, "errata_table", boom)  # after the CSVs are staged
    out = tmp_path / "results"
    with pytest.raises(RuntimeError, match="simulated failure"):
        reproduce(out, jobs=1)
    assert not out.exists()
    assert staging_dirs(tmp_path) == []


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
    assert not out.exists()
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
