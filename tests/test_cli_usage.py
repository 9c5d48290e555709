"""The ``slidingarm`` entry point (:func:`slidingarm.cli.main`): click's usage errors are one
line ``error: ...`` on stderr with exit status 2, like every other user mistake (issue 11,
point 9), and the size, number and file checks of ``validate`` reach the user as one line."""

from __future__ import annotations

import importlib
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from _scenarios import minimal_scenario
from slidingarm import __version__
from slidingarm.cli import EXIT_USAGE, main


def call(capsys: pytest.CaptureFixture[str], *args: str) -> tuple[int, str, str]:
    with pytest.raises(SystemExit) as info:
        main(list(args))
    out, err = capsys.readouterr()
    code = info.value.code
    return (code if isinstance(code, int) else 0 if code is None else 1), out, err


def one_line(err: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1, f"expected one line on stderr, got {err!r}"
    assert lines[0].startswith("error: ") and "Traceback" not in err and "╭" not in err
    return lines[0]


@pytest.mark.parametrize(
    ("args", "expected"),
    [
        (["run", "sign"], "error: slidingarm run: missing option '--out' / '-o'; "
         "see 'slidingarm run --help'"),
        (["run", "sign", "--out", "x", "--bogus"], "error: slidingarm run: no such option: --bogus"),
        (["run", "sign", "--out"], "error: option '--out' requires an argument"),
        (["validate"], "error: slidingarm validate: missing argument 'config'; "
         "see 'slidingarm validate --help'"),
        (["validate", "--strict", "sign"], "error: slidingarm validate: no such option: --strict"),
        (["frobnicate"], "error: slidingarm: no such command 'frobnicate'"),
        (["reproduce", "--jobs", "many"], "error: slidingarm reproduce: invalid value for "
         "'--jobs' / '-j'"),
    ],
)  # fmt: skip
def test_usage_errors_are_one_line_with_exit_2(
    capsys: pytest.CaptureFixture[str], args: list[str], expected: str
) -> None:
    code, out, err = call(capsys, *args)
    assert code == EXIT_USAGE
    assert out == ""
    assert one_line(err).startswith(expected)


def test_no_arguments_print_the_help(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = call(capsys)
    assert code == EXIT_USAGE and err == ""
    assert "Usage: slidingarm" in out and "validate" in out


def test_help_and_version_still_exit_0(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = call(capsys, "--version")
    assert (code, out.strip()) == (0, f"slidingarm {__version__}")
    code, out, _ = call(capsys, "run", "--help")
    assert code == 0 and "--out" in out


def test_a_command_that_works_exits_0(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = call(capsys, "validate", "sign")
    assert code == 0 and out.startswith("ok: ") and err == ""


BASE = minimal_scenario(switching="tanh", t_final=0.01, controllers=("pdsmc",))


@pytest.mark.parametrize(
    ("old", "new", "expected"),
    [
        ("t_final = 0.01", "t_final = 5e11", ": simulation.t_final: simulation.t_final / "
         "simulation.dt = 1e+15 steps x 3 joints x 1 run (one per controller) would need"),
        ("dt = 5e-4", "dt = 5e-324", ": simulation.dt: must be a number >= 1e-09 (s)"),
        ("q0 = [0.7, 1.5, 0.5]", "q0 = [1e300, 1.5, 0.5]", ": simulation.q0: must be a list of "
         "finite numbers within ±1000"),
        ("k = 20.0", "k = " + "[" * 3000 + "1" + "]" * 3000, ": invalid TOML: arrays or tables "
         "nested too deep to read"),
    ],
)  # fmt: skip
def test_validate_refuses_oversize_and_absurd_inputs_in_one_line(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, old: str, new: str, expected: str
) -> None:
    path = tmp_path / "s.toml"
    path.write_text(textwrap.dedent(BASE).replace(old, new, 1), encoding="utf-8")
    code, out, err = call(capsys, "validate", str(path))
    assert code == EXIT_USAGE and out == ""
    assert one_line(err).startswith(f"error: {path}{expected}")


def test_validate_refuses_a_device_without_reading_it(capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = call(capsys, "validate", "/dev/zero")
    assert code == EXIT_USAGE
    assert one_line(err) == (
        "error: /dev/zero: is not a regular file (a FIFO, device or socket), so not a scenario file"
    )


def test_the_console_entry_point_prints_one_line() -> None:
    done = subprocess.run(
        [sys.executable, "-m", "slidingarm", "run", "sign"],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert done.returncode == EXIT_USAGE and done.stdout == ""
    assert one_line(done.stderr).startswith("error: slidingarm run: missing option '--out'")


def test_a_run_refused_by_the_memory_check_is_one_line(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Memory that shrank between the scenario's check and the simulation's: the library's
    RunTooLargeError reaches the user as one line with exit 2, and nothing is written."""
    scenario_module = importlib.import_module("slidingarm.config.scenario")
    simulate_module = importlib.import_module("slidingarm.simulate")
    monkeypatch.setattr(scenario_module, "available_memory", lambda: 2**40, raising=False)
    monkeypatch.setattr(simulate_module, "available_memory", lambda: 2**10, raising=False)
    path = tmp_path / "s.toml"
    path.write_text(textwrap.dedent(BASE), encoding="utf-8")
    out_dir = tmp_path / "out"
    code, _, err = call(capsys, "run", str(path), "--out", str(out_dir), "--no-figures")
    assert code == EXIT_USAGE
    assert "of the 1 KiB of memory available: use record='metrics'" in one_line(err)
    assert not out_dir.exists()


def test_the_console_script_runs_exit_handlers_flushes_and_keeps_the_status(
    tmp_path: Path,
) -> None:
    # slidingarm.cli.script ends the process without the interpreter's teardown: what an
    # exit handler prints still arrives after the command's output, through a pipe (flushed),
    # and the status is main's, for a success and for a user mistake
    code = (
        "import atexit, sys, threading, time\n"
        "atexit.register(lambda: print('handler ran'))\n"
        "sys.argv = ['slidingarm', *sys.argv[1:]]\n"
        "from slidingarm.cli import script\n"
        # a thread that is not a daemon, still running when the command returns, is waited
        # for, as the interpreter's shutdown does
        "threading.Thread(target=lambda: (time.sleep(1.0), print('thread done'))).start()\n"
        "script()\n"
        "raise AssertionError('script returned')\n"
    )
    ok = subprocess.run(
        [sys.executable, "-c", code, "--help"],
        capture_output=True, text=True, timeout=120, check=False,
    )  # fmt: skip
    assert ok.returncode == 0, ok.stderr
    assert ok.stdout.rstrip("\n").endswith("thread done\nhandler ran")
    assert len(ok.stdout.splitlines()) > 2
    bad = subprocess.run(
        [sys.executable, "-c", code, "run", "sign"],
        capture_output=True, text=True, timeout=120, check=False,
    )  # fmt: skip
    assert bad.returncode == EXIT_USAGE and bad.stdout == "thread done\nhandler ran\n"
    assert one_line(bad.stderr).startswith("error: slidingarm run: missing option '--out'")

