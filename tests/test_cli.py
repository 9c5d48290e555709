"""Tests for the ``slidingarm`` command line: verbs, exit codes and one-line errors."""

from __future__ import annotations

import errno
import json
import os
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest
from typer.testing import CliRunner

from slidingarm import __version__
from slidingarm.cli import EXIT_FAILED, EXIT_USAGE, app
from slidingarm.study import SCENARIOS, SHIPPED, load_shipped

runner = CliRunner()

SHORT = """
extends = "{base}"
name = "short"

[simulation]
t_final = 0.25
"""


def invoke(*args: str) -> tuple[int, str, str]:
    result = runner.invoke(app, list(args))
    return result.exit_code, result.stdout, result.stderr


def one_line_error(stderr: str) -> str:
    lines = stderr.strip().splitlines()
    assert len(lines) == 1, f"expected one line on stderr, got {stderr!r}"
    assert lines[0].startswith("error: ")
    assert "Traceback" not in stderr
    return lines[0]


@pytest.fixture
def short_config(tmp_path: Path) -> Path:
    """The sign scenario cut to 0.25 s: a quick `run`."""
    base = load_shipped("sign").source
    assert base is not None
    p = tmp_path / "short.toml"
    p.write_text(SHORT.format(base=base.as_posix()), encoding="utf-8")
    return p


def test_version() -> None:
    code, out, _ = invoke("--version")
    assert code == 0 and out.strip() == f"slidingarm {__version__}"


def test_list_names_every_choice() -> None:
    code, out, _ = invoke("list")
    assert code == 0
    for word in (
        "pdsmc",
        "tsmc",
        "ftsmc",
        "ntsmc",
        "sign",
        "tanh",
        "sat",
        "super-twisting",
        "paper",
        "quintic",
        "table",
        "filtered",
        "levant",
        "difference",
        "dropout",
        "sinusoidal",
        "payload",
    ):
        assert word in out, word
    for name in SHIPPED:  # the study's scenarios and the UR5's
        assert f"\n  {name} " in out


def test_schema_is_json() -> None:
    code, out, _ = invoke("schema")
    assert code == 0
    schema = json.loads(out)
    assert schema["title"] == "Scenario"
    assert "controllers" in schema["required"]


@pytest.mark.parametrize("name", SCENARIOS)
def test_validate_shipped_by_name(name: str) -> None:
    code, out, err = invoke("validate", name)
    assert code == 0, err
    assert out.startswith("ok: ") and f"scenario {name!r}" in out and "9001 samples" in out


def test_validate_file(short_config: Path) -> None:
    code, out, _ = invoke("validate", str(short_config))
    assert code == 0 and "scenario 'short'" in out and "501 samples" in out


def test_validate_missing_file(tmp_path: Path) -> None:
    code, _, err = invoke("validate", str(tmp_path / "nope.toml"))
    assert code == EXIT_USAGE
    assert "nope.toml: no such file" in one_line_error(err)


def test_validate_bad_toml(tmp_path: Path) -> None:
    p = tmp_path / "bad.toml"
    p.write_text('switching = "sign"\n[plant\n', encoding="utf-8")
    code, _, err = invoke("validate", str(p))
    assert code == EXIT_USAGE
    assert f"{p}:2: invalid TOML" in one_line_error(err)


def test_validate_invalid_value(tmp_path: Path, short_config: Path) -> None:
    p = tmp_path / "bad.toml"
    p.write_text(f'extends = "{short_config.as_posix()}"\n[gains]\nk = -3\n', encoding="utf-8")
    code, _, err = invoke("validate", str(p))
    assert code == EXIT_USAGE
    assert "gains.k: must be > 0" in one_line_error(err)


def test_run_writes_a_results_folder(tmp_path: Path, short_config: Path) -> None:
    out = tmp_path / "out"
    code, stdout, err = invoke("run", str(short_config), "--out", str(out), "--no-figures")
    assert code == 0, err
    assert "short" in stdout
    for label in ("pdsmc", "tsmc", "ftsmc"):
        df = pd.read_csv(out / "short" / f"{label}.csv")
        assert len(df) == 501 and list(df.columns[:4]) == ["t", "q1", "q2", "q3"]
    metrics = pd.read_csv(out / "metrics.csv")
    assert len(metrics) == 3 * 4
    config = (out / "config" / "short.toml").read_text(encoding="utf-8")
    assert config.startswith(f"# ran with slidingarm {__version__}, seed 2024 (simulation.seed)")
    code, _, err = invoke("validate", str(out / "config" / "short.toml"))
    assert code == 0, err
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["scenarios"] == ["short"] and manifest["command"].startswith("slidingarm run")
    # nothing left behind: no staging folder next to the output
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".out.partial")]


def test_run_into_an_existing_file(tmp_path: Path, short_config: Path) -> None:
    target = tmp_path / "taken"
    target.write_text("mine")
    code, _, err = invoke("run", str(short_config), "--out", str(target))
    assert code == EXIT_USAGE
    assert "exists and is not a folder" in one_line_error(err)
    assert target.read_text() == "mine"


def test_run_into_an_unwritable_place(tmp_path: Path, short_config: Path) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("x")
    code, _, err = invoke("run", str(short_config), "--out", str(blocker / "sub" / "deeper"))
    assert code == EXIT_USAGE
    assert (
        one_line_error(err)
        == f"error: {blocker / 'sub' / 'deeper'}: {blocker} is a file, not a folder"
    )


@pytest.mark.skipif(not Path("/proc/self").is_dir(), reason="needs Linux /proc")
def test_run_where_no_folder_can_be_made(tmp_path: Path, short_config: Path) -> None:
    """/proc takes no new folders, whoever runs the test (root ignores permission bits)."""
    code, _, err = invoke("run", str(short_config), "--out", "/proc/slidingarm-test/out")
    assert code == EXIT_USAGE
    assert one_line_error(err).startswith("error: /proc/slidingarm-test/out: cannot write there (")


def test_run_missing_config(tmp_path: Path) -> None:
    code, _, err = invoke("run", "nonesuch", "--out", str(tmp_path / "o"))
    assert code == EXIT_USAGE
    line = one_line_error(err)
    assert "nonesuch: no such file (nor the name of a shipped scenario: sign, tanh, noise, ur5, ur5_sign, robust)" in line
    assert not (tmp_path / "o").exists()


def test_run_diverging_scenario_exits_1(tmp_path: Path, short_config: Path) -> None:
    p = tmp_path / "wild.toml"
    p.write_text(
        f'extends = "{short_config.as_posix()}"\n[[controllers]]\nname = "ftsmc"\nlaw = "paper"\n'
        "k = 1e6\n",
        encoding="utf-8",
    )
    code, _, err = invoke("run", str(p), "--out", str(tmp_path / "o"), "--no-figures")
    assert code == EXIT_FAILED
    assert "diverged" in one_line_error(err)
    assert not (tmp_path / "o").exists()


def test_python_dash_m() -> None:
    done = subprocess.run(
        [sys.executable, "-m", "slidingarm", "validate", "nonesuch.toml"],
        capture_output=True,
        text=True,
        check=False,
    )
    assert done.returncode == EXIT_USAGE
    assert done.stdout == ""
    assert done.stderr.strip().splitlines() == [
        "error: nonesuch.toml: no such file (nor the name of a shipped scenario: sign, tanh, noise, ur5, ur5_sign, robust)"
    ]


def test_a_name_too_long_for_the_file_system(tmp_path: Path, short_config: Path) -> None:
    long = "b" * 300
    code, _, err = invoke("validate", f"{long}.toml")
    assert code == EXIT_USAGE
    assert one_line_error(err).startswith(f"error: {long}.toml: cannot be read (")
    code, _, err = invoke("run", str(short_config), "--out", str(tmp_path / long))
    assert code == EXIT_USAGE
    assert one_line_error(err).startswith(f"error: {tmp_path / long}: cannot write there (")


def test_a_full_disk_is_one_line_and_writes_nothing(
    tmp_path: Path, short_config: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from slidingarm.study.output import Staging

    def full(self: Staging, relative: str, data: bytes) -> Path:
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(self.path / relative))

    monkeypatch.setattr(Staging, "write_bytes", full)
    out = tmp_path / "out"
    code, _, err = invoke("run", str(short_config), "--out", str(out), "--no-figures")
    assert code == EXIT_USAGE
    line = one_line_error(err)
    assert line.endswith(f"{os.strerror(errno.ENOSPC)}; nothing was written")
    assert "config/short.toml" in line, "the first file staged: the config, before any simulation"
    assert list(tmp_path.iterdir()) == [short_config], "neither the output nor a staging folder"


def test_a_results_folder_does_not_hide_a_shipped_scenario(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """`run sign --out .` makes ./sign/; `validate sign` there still means the shipped one."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "sign").mkdir()
    code, out, err = invoke("validate", "sign")
    assert code == 0, err
    assert "scenario 'sign'" in out
    (tmp_path / "mine").mkdir()
    code, _, err = invoke("validate", "mine")
    assert code == EXIT_USAGE
    assert "mine" in one_line_error(err)


@pytest.mark.parametrize("flag", [[], ["--svg"]])
def test_reproduce_saves_svg_on_request(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, flag: list[str]
) -> None:
    # --svg reaches the study (which also records it in the command of the manifest)
    import slidingarm.study as study
    from slidingarm.study.output import OutputError

    seen: dict[str, object] = {}

    def fake(out: Path, **kwargs: object) -> None:
        seen.update(kwargs)
        raise OutputError("stopped here")

    monkeypatch.setattr(study, "reproduce", fake)
    code, _, err = invoke("reproduce", "--out", str(tmp_path / "r"), *flag)
    assert code != 0 and "stopped here" in err
    assert seen["svg"] is bool(flag)
    assert str(seen["command"]).endswith("--svg") is bool(flag)
