"""`slidingarm tune` from the command line: output, exports that `run` reproduces, errors."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest
from typer.testing import CliRunner

from slidingarm.cli import EXIT_FAILED, EXIT_USAGE, app

runner = CliRunner()


def invoke(*args: str) -> tuple[int, str, str]:
    result = runner.invoke(app, [str(a) for a in args])
    return result.exit_code, result.stdout, result.stderr


def one_line_error(stderr: str) -> str:
    lines = stderr.strip().splitlines()
    assert len(lines) == 1, f"expected one line on stderr, got {stderr!r}"
    assert lines[0].startswith("error: ") and "Traceback" not in stderr
    return lines[0]


def test_tune_prints_the_front_and_exports_what_run_reproduces(
    short_file: Path, tmp_path: Path
) -> None:
    out = tmp_path / "t"
    code, stdout, stderr = invoke(
        "tune", short_file, "--controller", "ftsmc", "--trials", "8", "--out", out,
        "--objectives", "mse,peak_torque", "--export", "best", "--export", "0",
    )  # fmt: skip
    assert code == 0, stderr
    assert "tuned ftsmc of short" in stdout and "8 trials (8 complete, 0 failed)" in stdout
    assert "the knee (--export best): trial" in stdout
    pareto = pd.read_csv(out / "pareto.csv")
    best = int(stdout.split("the knee (--export best): trial")[1].split()[0])
    assert best in set(pareto["trial"])
    exported = out / "exports" / f"trial-{best}.toml"
    assert exported.is_file() and (out / "exports" / "trial-0.toml").is_file()
    code, _, stderr = invoke("run", exported, "--out", tmp_path / "run", "--no-figures")
    assert code == 0, stderr
    metrics = pd.read_csv(tmp_path / "run" / "metrics.csv")
    mean = metrics[metrics["joint"] == "mean"].iloc[0]
    row = pareto[pareto["trial"] == best].iloc[0]
    for name in ("mse", "peak_torque"):
        assert mean[name] == pytest.approx(row[name], rel=1e-12, abs=0.0)
    # the same command again runs nothing and keeps every trial
    code, stdout, _ = invoke(
        "tune", short_file, "--controller", "ftsmc", "--trials", "8", "--out", out,
        "--objectives", "mse,peak_torque",
    )  # fmt: skip
    assert code == 0 and "(0 run now, 8 kept)" in stdout


@pytest.mark.parametrize(
    ("extra", "words"),
    [
        (["--controller", "lqr"], "controller: is neither a controller"),
        (["--bound", "k=5"], "--bound: expected NAME=LOW:HIGH"),
        (["--bound", "zeta=1:2"], "bounds.zeta"),
        (["--bound", "k=60:5"], "bounds.k: needs low < high"),
        (["--limit", "peak_torque"], "--limit: expected METRIC=VALUE"),
        (["--limit", "speed=3"], "limits: unknown metric 'speed'"),
        (["--objectives", "mse,speed"], "objectives: unknown metric 'speed'"),
        (["--export", "first"], "--export: expected a trial number or 'best'"),
        (["--statistic", "median"], "statistic: must be one of mean, p90"),
        (["--sampler", "cmaes"], "sampler: must be one of nsga2, tpe"),
        (["--robust", "3"], "sweep: a robust tuning"),
    ],
)
def test_user_mistakes_are_one_line_and_exit_2(
    short_file: Path, tmp_path: Path, extra: list[str], words: str
) -> None:
    args = ["tune", short_file, "--controller", "ftsmc", "--trials", "2", "--out", tmp_path / "t"]
    if "--controller" in extra:
        args[2:4] = []
    code, _, stderr = invoke(*args, *extra)
    assert code == EXIT_USAGE
    assert words in one_line_error(stderr)
    assert not (tmp_path / "t").exists()


def test_folder_mistakes_and_failed_tunings(short_file: Path, tmp_path: Path) -> None:
    out = tmp_path / "t"
    base = ["tune", short_file, "--controller", "pdsmc", "--out", out]
    code, _, _ = invoke(*base, "--trials", "12", "--bound", "k=1:1e7")
    assert code == 0
    code, _, stderr = invoke(*base, "--trials", "12", "--seed", "1", "--bound", "k=1:1e7")
    assert code == EXIT_USAGE and "another definition (seed: 0 there, 1 here)" in one_line_error(
        stderr
    )
    (tmp_path / "other").mkdir()
    (tmp_path / "other" / "x.txt").write_text("mine")
    code, _, stderr = invoke("tune", short_file, "-c", "pdsmc", "-n", "2", "-o", tmp_path / "other")
    assert code == EXIT_USAGE and "not a tuning" in one_line_error(stderr)
    # every trial diverges: the tables are written, the verb says why and exits 1
    bad = tmp_path / "bad"
    code, _, stderr = invoke(
        "tune", short_file, "-c", "pdsmc", "-n", "2", "-o", bad, "--bound", "k=1e7:1e8"
    )
    assert code == EXIT_FAILED and "all 2 trials failed" in one_line_error(stderr)
    assert (bad / "trials.csv").is_file()
    # exporting a failed trial, or one that does not exist, is a user mistake
    trials = pd.read_csv(out / "trials.csv")
    failed = trials.loc[trials["state"] == "failed", "trial"]
    assert 0 < len(failed) < 12  # k up to 1e7 diverges, k near 1 does not
    again = [*base, "--trials", "12", "--bound", "k=1:1e7", "--export"]
    code, _, stderr = invoke(*again, str(int(failed.iloc[0])))
    assert code == EXIT_USAGE and "export a complete trial" in one_line_error(stderr)
    code, _, stderr = invoke(*again, "12")
    assert code == EXIT_USAGE and "trial 12 is not a finished trial" in one_line_error(stderr)
