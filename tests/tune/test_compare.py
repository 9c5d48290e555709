"""slidingarm compare: fair tuning, one test on the same draws, paired statistics."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from slidingarm.cli import EXIT_USAGE, app
from slidingarm.config import ConfigError, Scenario, load_scenario
from slidingarm.study import OutputError, scenarios_dir
from slidingarm.tune import Budget, compare
from slidingarm.tune.compare import COMPARED, paired

SHORT = """
extends = "{base}"
name = "short_robust"

[simulation]
t_final = 0.5
"""

TINY = Budget(trials=4, robust=2, runs=24)


@pytest.fixture
def robust_file(tmp_path: Path) -> Path:
    p = tmp_path / "short_robust.toml"
    p.write_text(SHORT.format(base=(scenarios_dir() / "robust.toml").as_posix()))
    return p


@pytest.fixture
def robust(robust_file: Path) -> Scenario:
    return load_scenario(robust_file)


def test_paired_statistics_on_known_data() -> None:
    rng = np.random.default_rng(1)
    b = rng.lognormal(size=200)
    a = 0.5 * b  # A's MSE is half of B's on every draw
    a[:10] = 2.0 * b[:10]  # ... except ten
    ok = pd.DataFrame({"a": np.ones(200, bool), "b": np.ones(200, bool)})
    ok.loc[0, "a"] = False  # A fails on draw 0: a loss, and left out of the ratio
    mse = pd.DataFrame({"a": a, "b": b})
    r = paired(mse, ok, "a", "b", rng=np.random.default_rng(0), n_resamples=500)
    expected = float(np.exp(np.mean(np.log(a[1:] / b[1:]))))
    assert r["draws"] == 199 and r["ratio"] == pytest.approx(expected, rel=1e-12)
    assert r["ci_low"] < r["ratio"] < r["ci_high"] < 1.0 and r["verdict"] == "holds"
    assert r["wins"] == 190 and r["win_low"] < 190 / 200 < r["win_high"]
    swapped = paired(mse, ok, "b", "a", rng=np.random.default_rng(0), n_resamples=500)
    assert swapped["verdict"] == "reversed" and swapped["wins"] == 10
    same = paired(
        pd.DataFrame({"a": b, "b": b}), ok, "a", "b", rng=np.random.default_rng(0), n_resamples=200
    )
    assert same["ratio"] == 1.0 and same["verdict"] == "inconclusive"


def test_compare_tunes_alike_and_tests_on_the_same_draws(robust: Scenario, tmp_path: Path) -> None:
    out = tmp_path / "c"
    r = compare(robust, out=out, budget=TINY, figures=True)
    assert list(r.controllers["controller"]) == list(COMPARED)
    for name in ("compare.json", "controllers.csv", "pairs.csv", "where.csv", "report.md",
                 "comparison.png", "comparison.svg"):  # fmt: skip
        assert (out / name).is_file(), name
    # every tuning had the same budget, objective and limits
    definitions = {
        c: json.loads((out / "tune" / c / "tune.json").read_text())["definition"] for c in COMPARED
    }
    for d in definitions.values():
        assert d["objectives"] == ["mse"] and d["robust"] == TINY.robust
        assert d["limits"] == definitions["pdsmc"]["limits"] and d["sampler"] == "tpe"
        assert len(pd.read_csv(out / "tune" / d["controller"] / "trials.csv")) == TINY.trials
    # the test: every tested controller on the same fresh draws, with its tuned gains
    table = pd.read_parquet(out / "sweep" / "results.parquet")
    mean = table[table["joint"] == "mean"]
    tested = [c for c in COMPARED if c in set(mean["controller"])]
    assert tested == [
        c for c in COMPARED if c in set(r.controllers.query("trial >= 0")["controller"])
    ]
    per_draw = mean.groupby("run")["mismatch.mass_error[0]"].nunique()
    assert len(per_draw) == TINY.runs and (per_draw == 1).all()  # one draw, every controller
    sweep_def = json.loads((out / "sweep" / "sweep.json").read_text())
    specs = {c.get("label", c["name"]): c for c in sweep_def["scenario"]["controllers"]}
    for _, row in r.controllers[r.controllers["trial"] >= 0].iterrows():
        for name, value in json.loads(row["gains"]).items():
            assert specs[row["controller"]][name] == pytest.approx(value, rel=1e-5)
    # the pairs, recomputed from the draws
    mse = mean.pivot(index="run", columns="controller", values="mse")
    ok = mean.pivot(index="run", columns="controller", values="ok").astype(bool)
    for _, p in r.pairs.iterrows():
        both = ok[p["a"]] & ok[p["b"]]
        ratio = np.exp(np.mean(np.log(mse.loc[both, p["a"]] / mse.loc[both, p["b"]])))
        assert p["ratio"] == pytest.approx(ratio, rel=1e-12)
        assert p["ci_low"] <= p["ratio"] <= p["ci_high"]
        holds = p["ci_high"] < 1.0
        assert (p["verdict"] == "holds") == holds
    assert r.ranking in ("holds", "fails", "inconclusive")
    assert "FTSMC < TSMC < PDSMC" in r.headline and r.headline in (out / "report.md").read_text()
    # the same comparison again resumes everything and gives the same tables
    again = compare(robust, out=out, budget=TINY, figures=False)
    pd.testing.assert_frame_equal(again.pairs, r.pairs)
    pd.testing.assert_frame_equal(again.controllers, r.controllers)


def test_compare_refuses_what_it_cannot_use(robust: Scenario, tmp_path: Path) -> None:
    nominal = load_scenario(scenarios_dir() / "sign.toml")
    with pytest.raises(ConfigError) as info:
        compare(nominal, out=tmp_path / "a", budget=TINY)
    assert info.value.path == "sweep"
    with pytest.raises(ConfigError) as info:
        compare(robust, out=tmp_path / "b", budget=TINY, controllers=("ftsmc", "lqr"))
    assert info.value.path == "controllers"
    with pytest.raises(ConfigError) as info:
        Budget(trials=0, robust=2, runs=10)
    assert info.value.path == "trials"
    other = tmp_path / "other"
    other.mkdir()
    (other / "x.txt").write_text("mine")
    with pytest.raises(OutputError, match="not a comparison"):
        compare(robust, out=other, budget=TINY)
    assert [p.name for p in other.iterdir()] == ["x.txt"]
    assert not (tmp_path / "a").exists() and not (tmp_path / "b").exists()


def test_compare_quick_from_the_command_line(robust_file: Path, tmp_path: Path) -> None:
    runner = CliRunner()
    out = tmp_path / "q"
    result = runner.invoke(
        app, ["compare", str(robust_file), "--out", str(out), "--quick",
              "--limit", "peak_torque=400", "--limit", "chattering=2e5"],
    )  # fmt: skip
    assert result.exit_code == 0, result.stderr
    assert "the paper's ranking FTSMC < TSMC < PDSMC" in result.stdout
    assert "report:" in result.stdout
    # a controller without feasible gains is named as such, never printed as NaN
    assert "nan" not in result.stdout.lower()
    limits = json.loads((out / "compare.json").read_text())["definition"]["limits"]
    assert limits == {"peak_torque": 400.0, "chattering": 2e5}
    bad = runner.invoke(app, ["compare", str(robust_file), "--out", str(out), "--vary", "x"])
    assert bad.exit_code == EXIT_USAGE and bad.stderr.startswith("error: ")
    assert len(bad.stderr.strip().splitlines()) == 1
