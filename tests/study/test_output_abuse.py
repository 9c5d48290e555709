"""The output folder attacked as a new user would: an edited file listed in the old manifest, the
run's own input inside the output folder, ``--out`` on another file system or under a read-only
parent, ``kill -9`` and SIGTERM of ``reproduce``, two runs into one folder, and another
scenario's results. Every case goes through the command line (``run`` on a 0.25 s scenario
without figures, except where the figure workers are the point)."""

from __future__ import annotations

import errno
import hashlib
import json
import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from typer.testing import CliRunner

from slidingarm.cli import EXIT_INTERRUPTED, EXIT_USAGE, app
from slidingarm.study import analysis as A
from slidingarm.study import load_shipped

runner = CliRunner()
MANIFEST = "manifest.json"
SHORT = 'extends = "{base}"\nname = "{name}"\n\n[simulation]\nt_final = 0.25\n'
LINUX = sys.platform.startswith("linux") and Path("/proc/self/stat").is_file()


def invoke(*args: str) -> tuple[int, str, str]:
    result = runner.invoke(app, list(args))
    return result.exit_code, result.stdout, result.stderr


def one_line_error(stderr: str) -> str:
    lines = stderr.strip().splitlines()
    assert len(lines) == 1, f"expected one line on stderr, got {stderr!r}"
    assert lines[0].startswith("error: ") and "Traceback" not in stderr
    return lines[0]


def short(tmp_path: Path, name: str = "short") -> Path:
    """The sign scenario cut to 0.25 s, named ``name``."""
    base = load_shipped("sign").source
    assert base is not None
    p = tmp_path / f"{name}.toml"
    p.write_text(SHORT.format(base=base.as_posix(), name=name), encoding="utf-8")
    return p


def run(config: Path | str, out: Path, *options: str) -> tuple[int, str, str]:
    return invoke("run", str(config), "--out", str(out), "--no-figures", *options)


def listed(out: Path) -> list[str]:
    return [e["path"] for e in json.loads((out / MANIFEST).read_text())["files"]]


def hidden(folder: Path) -> list[str]:
    """Staging folders and lock files in ``folder`` and beside it."""
    places = [folder, folder.parent]
    return sorted(
        p.name
        for place in places
        if place.is_dir()
        for p in place.iterdir()
        if ".partial-" in p.name or p.name.endswith(".lock")
    )


@pytest.fixture
def no_simulation(monkeypatch: pytest.MonkeyPatch) -> Iterator[None]:
    """Any simulation fails the test: a refusal must come before the work."""

    def fail(*args: object, **kwargs: object) -> None:
        raise AssertionError("simulated although the run was to be refused first")

    monkeypatch.setattr(A, "simulate_setup", fail)
    yield


# ---------------------------------------------------------------- 1: never lose an edited file


def test_the_edited_input_inside_the_folder_is_not_replaced(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """`run R/config/short.toml --out R` after editing that file: refused before simulating,
    the file as the user left it (an edit that the recorded config reproduces byte for byte
    is simply rewritten: see the next test)."""
    out = tmp_path / "R"
    assert run(short(tmp_path), out)[0] == 0
    config = out / "config" / "short.toml"
    # an edit that the recorded config does not keep (a comment): the user's text is at stake
    edited = config.read_text().replace("t_final = 0.25", "t_final = 0.3  # a longer run")
    assert edited != config.read_text()
    config.write_text(edited)
    before = {p: p.read_bytes() for p in out.rglob("*") if p.is_file()}

    def fail(*args: object, **kwargs: object) -> None:
        raise AssertionError("simulated although the run was to be refused first")

    monkeypatch.setattr(A, "simulate_setup", fail)
    for options in ((), ("--overwrite",)):  # --overwrite does not give it away either
        code, _, err = run(config, out, *options)
        assert code == EXIT_USAGE
        line = one_line_error(err)
        assert line.startswith(
            f"error: {out}: this run would replace config/short.toml (this run's input)"
        )
        assert "nothing was replaced" in line
        assert {p: p.read_bytes() for p in out.rglob("*") if p.is_file()} == before
        assert hidden(out) == []


def test_the_unedited_config_reruns_into_its_own_folder(tmp_path: Path) -> None:
    """Rerunning the recorded config into its folder writes the same bytes: allowed."""
    out = tmp_path / "R"
    assert run(short(tmp_path), out)[0] == 0
    config = out / "config" / "short.toml"
    text = config.read_text()
    code, _, err = run(config, out)
    assert code == 0, err
    assert config.read_text() == text
    assert "config/short.toml" in listed(out)


def test_an_input_renamed_scenario_keeps_the_input_and_edited_files(tmp_path: Path) -> None:
    """The issue's case: the edited R/config/short.toml now names another scenario; with
    --overwrite the old results go, but neither the input nor a CSV the user edited."""
    out = tmp_path / "R"
    assert run(short(tmp_path), out)[0] == 0
    config = out / "config" / "short.toml"
    config.write_text(config.read_text().replace('name = "short"', 'name = "mine"'))
    user_csv = out / "short" / "tsmc.csv"
    user_csv.write_text(user_csv.read_text() + "# my note\n")
    code, _, err = run(config, out, "--overwrite")
    assert code == 0, err
    assert 'name = "mine"' in config.read_text(), "the run's input is still there"
    assert user_csv.read_text().endswith("# my note\n"), "the edited CSV is still there"
    assert not (out / "short" / "pdsmc.csv").exists(), "untouched old results went"
    assert "short/tsmc.csv" in err and "config/short.toml" in err, "said what was kept"
    names = listed(out)
    assert "mine/ftsmc.csv" in names and "config/mine.toml" in names
    assert not any(n.startswith("short/") or n == "config/short.toml" for n in names)


# ---------------------------------------------------------------- 2: the target's own file system


def _fake_mount(monkeypatch: pytest.MonkeyPatch, mount: Path) -> None:
    """os.replace and os.rename fail with EXDEV between ``mount`` and the rest of the disk."""

    def inside(p: object) -> bool:
        path = Path(os.fspath(p)).absolute()  # type: ignore[arg-type]
        return path == mount or mount in path.parents

    for name in ("replace", "rename"):
        real = getattr(os, name)

        def moved(
            src: object, dst: object, *args: object, _real: object = real, **kw: object
        ) -> None:
            if inside(src) != inside(dst):
                raise OSError(errno.EXDEV, os.strerror(errno.EXDEV), src, None, dst)
            _real(src, dst, *args, **kw)  # type: ignore[operator]

        monkeypatch.setattr(os, name, moved)


@pytest.mark.parametrize("existing", [True, False], ids=["volume", "volume-with-results"])
def test_out_on_another_file_system(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, existing: bool
) -> None:
    """--out is a mount point (a Docker volume): staging and publishing stay on it."""
    volume = tmp_path / "volume"
    volume.mkdir()
    config = short(tmp_path)
    if not existing:
        assert run(config, volume)[0] == 0
    _fake_mount(monkeypatch, volume)
    code, _, err = run(config, volume)
    assert code == 0, err
    assert "short/ftsmc.csv" in listed(volume)
    assert hidden(volume) == []


def test_a_writable_out_under_a_read_only_parent(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    parent = tmp_path / "readonly"
    out = parent / "out"
    out.mkdir(parents=True)
    config = short(tmp_path)
    real_mkdir = os.mkdir

    def mkdir(path: object, *args: object, **kwargs: object) -> None:
        # permission bits do not stop root: refuse new entries in `parent` as the kernel would
        p = Path(os.fspath(path)).absolute()  # type: ignore[arg-type]
        if p.parent == parent:
            if p.exists():
                raise FileExistsError(errno.EEXIST, os.strerror(errno.EEXIST), str(p))
            raise PermissionError(errno.EACCES, os.strerror(errno.EACCES), str(p))
        real_mkdir(path, *args, **kwargs)  # type: ignore[arg-type]

    monkeypatch.setattr(os, "mkdir", mkdir)
    parent.chmod(0o555)
    try:
        code, _, err = run(config, out)
        assert code == 0, err
        assert "short/pdsmc.csv" in listed(out)
        assert sorted(p.name for p in parent.iterdir()) == ["out"]
    finally:
        parent.chmod(0o755)


# ---------------------------------------------------------------- 3: kill -9 and SIGTERM


def _children(pid: int) -> list[int]:
    """Processes whose parent is ``pid`` (Linux /proc)."""
    found = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            text = stat.read_text()
        except OSError:
            continue
        rest = text[text.rfind(")") + 2 :].split()
        if len(rest) > 1 and int(rest[1]) == pid:
            found.append(int(stat.parent.name))
    return found


def _running(pid: int) -> bool:
    """Whether ``pid`` is a live process (a zombie is dead)."""
    try:
        text = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    return text[text.rfind(")") + 2 :].split()[0] not in ("Z", "X")


def _cmdline(pid: int) -> str:
    try:
        return Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode()
    except OSError:
        return ""


def _start_reproduce(out: Path) -> tuple[subprocess.Popen[bytes], list[int]]:
    """``slidingarm reproduce --jobs 2`` in a subprocess, once its two figure workers run."""
    env = {**os.environ, "MPLBACKEND": "Agg"}
    proc = subprocess.Popen(
        [sys.executable, "-m", "slidingarm", "reproduce", "--out", str(out), "--jobs", "2"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        env=env,
    )
    deadline = time.monotonic() + 120
    workers: list[int] = []
    while time.monotonic() < deadline and proc.poll() is None:
        # forked workers (Linux, slidingarm.study.reproduce._worker_context) or spawned ones
        workers = [c for c in _children(proc.pid) if "resource_tracker" not in _cmdline(c)]
        if len(workers) == 2:
            break
        time.sleep(0.05)
    if len(workers) != 2:
        proc.kill()
        proc.wait()
        pytest.fail(
            f"the figure workers did not start: {proc.stderr.read() if proc.stderr else ''!r}"
        )
    return proc, workers


def _wait_gone(pids: list[int], timeout: float = 60.0) -> list[int]:
    """Wait for ``pids`` to end; return those still running. A worker killed while it starts
    ends once it reaches its initializer (after its imports: seconds on a loaded machine)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        alive = [p for p in pids if _running(p)]
        if not alive:
            return []
        time.sleep(0.05)
    return [p for p in pids if _running(p)]


def _kill_all(pids: list[int]) -> None:
    for p in pids:
        try:
            os.kill(p, signal.SIGKILL)
        except OSError:
            pass


@pytest.mark.skipif(not LINUX, reason="reads processes from Linux /proc")
def test_kill_9_of_reproduce_leaves_no_worker_and_the_next_run_cleans_up(tmp_path: Path) -> None:
    out = tmp_path / "results"
    proc, workers = _start_reproduce(out)
    children = _children(proc.pid)
    assert set(workers) <= set(children)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    alive = _wait_gone(children)
    _kill_all(alive)
    assert alive == [], f"orphans left by kill -9: {[_cmdline(p) for p in alive]}"
    partial = [p for p in out.iterdir() if p.name.startswith(".partial-")]
    assert len(partial) == 1, "kill -9 leaves its staging folder (nothing can stop that)"
    code, _, err = run(short(tmp_path), out)
    assert code == 0, err
    assert hidden(out) == [], "the next run removed the dead run's staging folder and lock"


@pytest.mark.skipif(not LINUX, reason="reads processes from Linux /proc")
def test_sigterm_of_reproduce_cleans_up_like_ctrl_c(tmp_path: Path) -> None:
    out = tmp_path / "results"
    proc, workers = _start_reproduce(out)
    children = _children(proc.pid)
    assert set(workers) <= set(children)
    os.kill(proc.pid, signal.SIGTERM)
    try:
        code = proc.wait(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    alive = _wait_gone(children)
    _kill_all(alive)
    err = proc.stderr.read().decode() if proc.stderr else ""
    assert code == EXIT_INTERRUPTED, err
    assert one_line_error(err) == "error: interrupted; the output folder was left as it was"
    assert alive == [], f"orphans left by SIGTERM: {[_cmdline(p) for p in alive]}"
    assert not out.exists(), "the folder this run created is gone with its staging folder"
    assert hidden(out) == []


_CONTEXT = """
import threading
from slidingarm.study.reproduce import _worker_context
alone = _worker_context().get_start_method()
release = threading.Event()
other = threading.Thread(target=release.wait)
other.start()
beside = _worker_context().get_start_method()
release.set()
other.join()
import numba, numpy as np
@numba.njit(parallel=True)
def total(x):
    s = 0.0
    for i in numba.prange(x.shape[0]):
        s += x[i]
    return s
assert total(np.ones(64)) == 64.0 and threading.active_count() == 1
after_parallel = _worker_context().get_start_method()  # numba's threads are not Python's
print(alone, beside, after_parallel)
"""


@pytest.mark.skipif(not LINUX, reason="workers are forked on Linux only")
def test_workers_are_forked_only_from_a_process_running_no_other_thread() -> None:
    # a fork copies the locks another thread may hold: with one running (a Python thread, or
    # numba's threading layer after a parallel batch), workers are spawned
    done = subprocess.run(
        [sys.executable, "-c", _CONTEXT], capture_output=True, text=True, check=True
    )
    assert done.stdout.split() == ["fork", "spawn", "spawn"], done.stderr


@pytest.mark.skipif(not hasattr(os, "fork"), reason="needs os.fork")
def test_a_process_forked_during_a_study_ends_on_sigterm() -> None:
    # the study handles SIGTERM as Ctrl-C; its forked figure workers must not inherit that
    code = (
        "import importlib, os, signal\n"
        "R = importlib.import_module('slidingarm.study.reproduce')\n"
        "with R._terminate_as_interrupt():\n"
        "    study = signal.getsignal(signal.SIGTERM)\n"
        "    pid = os.fork()\n"
        "    if pid == 0:\n"
        "        os._exit(0 if signal.getsignal(signal.SIGTERM) == signal.SIG_DFL else 3)\n"
        "    _, status = os.waitpid(pid, 0)\n"
        "    assert os.waitstatus_to_exitcode(status) == 0, status\n"
        "    assert signal.getsignal(signal.SIGTERM) is study != signal.SIG_DFL\n"
        "pid = os.fork()\n"  # outside a study a fork keeps the handler it has
        "if pid == 0:\n"
        "    os._exit(0 if signal.getsignal(signal.SIGTERM) == signal.SIG_DFL else 4)\n"
        "assert os.waitstatus_to_exitcode(os.waitpid(pid, 0)[1]) == 0\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True)


def test_a_sigterm_inside_llvmlite_waits_for_the_next_step() -> None:
    # an exception raised in llvmlite's code while numba compiles is not safe: in a ctypes
    # callback it is printed and dropped (the study would go on to the end), in an object's
    # constructor it leaves a half-made object whose finalizer prints a traceback; it is held
    # back to the next step instead
    import importlib

    R = importlib.import_module("slidingarm.study.reproduce")
    frames = []
    for module, name in (
        ("llvmlite.binding.executionengine", "_raw_object_cache_notify"),  # a ctypes callback
        ("llvmlite.binding.newpassmanagers", "__init__"),  # a pass builder being made
    ):
        scope: dict[str, object] = {"__name__": module, "sys": sys}
        exec(f"def {name}():\n    return sys._getframe()", scope)
        frames.append(scope[name]())  # type: ignore[operator]
    assert not R._in_llvmlite(sys._getframe())
    previous = signal.getsignal(signal.SIGTERM)
    try:
        for inside in frames:
            termination = R._Termination()
            termination.handler(signal.SIGTERM, inside)
            assert termination.pending
            with pytest.raises(KeyboardInterrupt):
                termination.check()
            assert not termination.pending
            with pytest.raises(KeyboardInterrupt):  # elsewhere it interrupts at once
                termination.handler(signal.SIGTERM, sys._getframe())
    finally:
        signal.signal(signal.SIGTERM, previous)


def test_the_progress_bar_runs_no_thread(monkeypatch: pytest.MonkeyPatch) -> None:
    # a refresh thread would make reproduce spawn its workers instead of forking them
    import io
    import threading

    from slidingarm import cli

    class Terminal(io.StringIO):
        def isatty(self) -> bool:
            return True

    monkeypatch.setattr(sys, "stdout", Terminal())
    before = threading.active_count()
    with cli._progress(thread=False) as update:  # reproduce's
        assert update is not None
        update("simulating", 1, 4)
        assert threading.active_count() == before


# ---------------------------------------------------------------- 4: one run at a time


HOLD = """
import sys, time
from slidingarm.study.output import Staging
staging = Staging(sys.argv[1])
staging.write_text("sign/pdsmc.csv", "half")
print("holding", flush=True)
time.sleep(120)
"""


def test_a_second_run_into_a_held_folder_is_refused(tmp_path: Path, no_simulation: None) -> None:
    out = tmp_path / "out"
    holder = subprocess.Popen(
        [sys.executable, "-c", HOLD, str(out)], stdout=subprocess.PIPE, text=True
    )
    try:
        assert holder.stdout is not None and holder.stdout.readline().strip() == "holding"
        code, _, err = run(short(tmp_path), out)
        assert code == EXIT_USAGE
        assert one_line_error(err) == (
            f"error: {out}: another slidingarm run (pid {holder.pid}) is writing into this "
            "folder; wait for it to finish or choose another --out"
        )
        staged = [p for p in out.iterdir() if p.name.startswith(".partial-")]
        assert len(staged) == 1 and (staged[0] / "sign" / "pdsmc.csv").read_text() == "half"
    finally:
        holder.kill()
        holder.wait()


def test_the_folder_is_free_again_after_a_run(tmp_path: Path) -> None:
    out = tmp_path / "out"
    config = short(tmp_path)
    assert run(config, out)[0] == 0
    code, _, err = run(config, out)
    assert code == 0, err
    assert hidden(out) == []


# ---------------------------------------------------------------- 5: another scenario's results


def test_another_scenarios_results_need_overwrite(tmp_path: Path) -> None:
    out = tmp_path / "R"
    assert run(short(tmp_path, "short"), out)[0] == 0
    before = {p: p.read_bytes() for p in out.rglob("*") if p.is_file()}
    other = short(tmp_path, "other")
    code, _, err = run(other, out)
    assert code == EXIT_USAGE
    line = one_line_error(err)
    assert line.startswith(
        f"error: {out}: holds the results of scenario short, which this run (other) would "
        "replace or remove: config/short.toml, metrics.csv, short/ftsmc.csv, short/pdsmc.csv, "
        "short/tsmc.csv; pass --overwrite"
    ), line
    assert {p: p.read_bytes() for p in out.rglob("*") if p.is_file()} == before
    assert hidden(out) == []
    code, _, err = run(other, out, "--overwrite")
    assert code == 0, err
    assert not (out / "short").exists()
    assert listed(out) == [
        "config/other.toml",
        "metrics.csv",
        "other/ftsmc.csv",
        "other/pdsmc.csv",
        "other/tsmc.csv",
    ]
    assert "--overwrite" in json.loads((out / MANIFEST).read_text())["command"]


def test_files_no_manifest_lists_need_overwrite(tmp_path: Path) -> None:
    """A folder of the user's own with a metrics.csv: not replaced without --overwrite."""
    out = tmp_path / "mine"
    out.mkdir()
    (out / "metrics.csv").write_text("my own metrics\n")
    (out / "notes.txt").write_text("keep\n")
    config = short(tmp_path)
    code, _, err = run(config, out)
    assert code == EXIT_USAGE
    assert "no manifest.json lists: metrics.csv;" in one_line_error(err)
    assert (out / "metrics.csv").read_text() == "my own metrics\n"
    assert sorted(p.name for p in out.iterdir()) == ["metrics.csv", "notes.txt"]
    code, _, err = run(config, out, "--overwrite")
    assert code == 0, err
    assert (out / "notes.txt").read_text() == "keep\n"
    assert "metrics.csv" in listed(out)


# ---------------------------------------------------------------- kill -9 in the middle of publishing


KILL_WHILE_PUBLISHING = """
import os, signal, sys
from slidingarm.cli import app
real, calls = os.replace, [0]
def replace(src, dst):
    calls[0] += 1
    if calls[0] == 3:  # two result files moved in, the old manifest gone
        os.kill(os.getpid(), signal.SIGKILL)
    real(src, dst)
os.replace = replace
app(sys.argv[1:])
"""


def test_kill_9_while_publishing_then_the_next_run_recovers(tmp_path: Path) -> None:
    """The killed run leaves a folder without a manifest (visibly incomplete); the next run
    knows its files from the pending record, so it needs no --overwrite and keeps nothing
    stale."""
    out = tmp_path / "R"
    config = short(tmp_path)
    assert run(config, out)[0] == 0
    longer = tmp_path / "longer.toml"  # the same scenario, other numbers: other bytes
    longer.write_text(config.read_text().replace("t_final = 0.25", "t_final = 0.3"))
    args = ["run", str(longer), "--out", str(out), "--no-figures"]
    done = subprocess.run(
        [sys.executable, "-c", KILL_WHILE_PUBLISHING, *args], capture_output=True, check=False
    )
    assert done.returncode == -signal.SIGKILL, done.stderr
    assert not (out / MANIFEST).exists(), "a half-published folder has no manifest"
    code, _, err = run(config, out)
    assert code == 0, err
    manifest = json.loads((out / MANIFEST).read_text())
    on_disk = sorted(
        p.relative_to(out).as_posix()
        for p in out.rglob("*")
        if p.is_file() and not p.name.startswith(".")
    )
    assert on_disk == sorted([*listed(out), MANIFEST]), "nothing unlisted is left"
    for entry in manifest["files"]:
        assert hashlib.sha256((out / entry["path"]).read_bytes()).hexdigest() == entry["sha256"]
    assert hidden(out) == [] and not (out / ".manifest.pending.json").exists()
