"""Tests for the output folder: what publishing into an existing folder keeps and removes, the
lock, the staging folder on the target's file system, and the staging folders of killed runs."""

from __future__ import annotations

import errno
import json
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from slidingarm.study import output as O
from slidingarm.study.output import LOCK, MANIFEST, PARTIAL, OutputError, Staging


def _publish(target: Path, files: dict[str, str]) -> None:
    staging = Staging(target)
    for rel, text in files.items():
        staging.write_text(rel, text)
    staging.write_manifest({"run": sorted(files)})
    staging.publish()


def test_a_rerun_removes_what_only_the_previous_run_wrote(tmp_path: Path) -> None:
    out = tmp_path / "out"
    _publish(out, {"a.csv": "1", "sign/ntsmc.csv": "2", "figures/x.png": "3"})
    (out / "mine.txt").write_text("the user's own file")
    _publish(out, {"a.csv": "4"})
    assert (out / "a.csv").read_text() == "4"
    assert not (out / "sign").exists(), "the previous run's sign/ntsmc.csv and its folder go"
    assert not (out / "figures").exists()
    assert (out / "mine.txt").read_text() == "the user's own file", "no manifest lists it"
    listed = [e["path"] for e in json.loads((out / MANIFEST).read_text())["files"]]
    assert listed == ["a.csv"]


def test_a_manifest_cannot_remove_anything_outside_the_folder(tmp_path: Path) -> None:
    out = tmp_path / "out"
    _publish(out, {"a.csv": "1"})
    outside = tmp_path / "precious.txt"
    outside.write_text("keep")
    manifest = json.loads((out / MANIFEST).read_text())
    manifest["files"].append({"path": "../precious.txt"})
    manifest["files"].append({"path": str(outside)})
    (out / MANIFEST).write_text(json.dumps(manifest))
    _publish(out, {"b.csv": "2"})
    assert outside.read_text() == "keep"
    assert not (out / "a.csv").exists() and (out / "b.csv").read_text() == "2"


def test_an_unreadable_previous_manifest_removes_nothing(tmp_path: Path) -> None:
    out = tmp_path / "out"
    _publish(out, {"a.csv": "1"})
    (out / MANIFEST).write_text("{not json")
    _publish(out, {"b.csv": "2"})
    assert (out / "a.csv").read_text() == "1" and (out / "b.csv").read_text() == "2"


# ---------------------------------------------------------------- files a run must not lose


def test_a_file_edited_since_its_manifest_is_kept_not_removed(tmp_path: Path) -> None:
    """The previous run's file that this run does not write goes only if it is untouched."""
    out = tmp_path / "out"
    _publish(out, {"a.csv": "1", "notes/b.csv": "2", "c.csv": "3"})
    (out / "notes" / "b.csv").write_text("2, and the user's remark")
    staging = Staging(out)
    staging.write_text("a.csv", "4")
    staging.write_manifest({})
    staging.publish()
    assert (out / "notes" / "b.csv").read_text() == "2, and the user's remark"
    assert not (out / "c.csv").exists(), "untouched output of the previous run goes"
    assert staging.kept == [Path("notes/b.csv")]
    listed = [e["path"] for e in json.loads((out / MANIFEST).read_text())["files"]]
    assert listed == ["a.csv"], "the kept file is not passed off as this run's"


def test_an_edited_file_in_the_way_refuses_the_run_and_moves_nothing(tmp_path: Path) -> None:
    out = tmp_path / "out"
    _publish(out, {"a.csv": "1", "b.csv": "2"})
    (out / "b.csv").write_text("edited")
    manifest_before = (out / MANIFEST).read_bytes()
    staging = Staging(out)
    staging.write_text("a.csv", "new a")
    staging.write_text("b.csv", "new b")
    staging.write_manifest({})
    with pytest.raises(OutputError, match=r"b\.csv \(changed since manifest\.json recorded it\)"):
        staging.publish()
    assert (out / "a.csv").read_text() == "1", "refused before anything moved"
    assert (out / "b.csv").read_text() == "edited"
    assert (out / MANIFEST).read_bytes() == manifest_before
    assert sorted(p.name for p in out.iterdir()) == ["a.csv", "b.csv", MANIFEST]


def test_the_runs_own_input_is_neither_removed_nor_replaced(tmp_path: Path) -> None:
    out = tmp_path / "out"
    _publish(out, {"config/x.toml": "a = 1\n", "y.csv": "1"})
    (out / "config" / "x.toml").write_text("a = 2\n")  # the user edits it and runs it
    staging = Staging(out, inputs=[out / "config" / "x.toml"])
    staging.write_text("z.csv", "2")
    staging.write_manifest({})
    staging.publish()
    assert (out / "config" / "x.toml").read_text() == "a = 2\n"
    assert staging.kept == [Path("config/x.toml")]
    # even unedited (its hash as recorded), the input stays
    out = tmp_path / "again"
    _publish(out, {"config/x.toml": "a = 3\n"})
    staging = Staging(out, inputs=[out / "config" / "x.toml"])
    staging.write_text("z.csv", "3")
    staging.write_manifest({})
    staging.publish()
    assert (out / "config" / "x.toml").read_text() == "a = 3\n"
    staging = Staging(out, inputs=[out / "config" / "x.toml"])
    staging.write_text("config/x.toml", "a = 4\n")
    with pytest.raises(OutputError, match=r"config/x\.toml \(this run's input\)"):
        staging.check()
    staging.discard()
    assert (out / "config" / "x.toml").read_text() == "a = 3\n"


def test_a_file_or_folder_where_the_other_goes_is_refused_first(tmp_path: Path) -> None:
    out = tmp_path / "out"
    out.mkdir()
    (out / "sign").write_text("a file named like a results folder")
    (out / "metrics.csv").mkdir()
    staging = Staging(out, overwrite=True)
    staging.write_text("sign/pdsmc.csv", "1")
    staging.write_text("metrics.csv", "2")
    with pytest.raises(OutputError) as info:
        staging.publish()
    assert "metrics.csv (a folder)" in str(info.value)
    assert "sign (a file where sign/pdsmc.csv needs a folder)" in str(info.value)
    assert (out / "sign").read_text() == "a file named like a results folder"
    assert sorted(p.name for p in out.iterdir()) == ["metrics.csv", "sign"]


def test_identical_bytes_replace_anything(tmp_path: Path) -> None:
    """Writing a file with the bytes it already has loses nothing, so it is never refused."""
    out = tmp_path / "out"
    out.mkdir()
    (out / "a.csv").write_text("same")
    staging = Staging(out, inputs=[out / "a.csv"])
    staging.write_text("a.csv", "same")
    staging.write_manifest({})
    staging.publish()
    assert [e["path"] for e in json.loads((out / MANIFEST).read_text())["files"]] == ["a.csv"]


def test_a_users_file_in_the_way_needs_overwrite(tmp_path: Path) -> None:
    out = tmp_path / "out"
    out.mkdir()
    (out / "a.csv").write_text("the user's own")
    staging = Staging(out)
    staging.write_text("a.csv", "results")
    with pytest.raises(OutputError, match=r"no manifest\.json lists: a\.csv; .*--overwrite"):
        staging.publish()
    assert (out / "a.csv").read_text() == "the user's own"
    staging = Staging(out, overwrite=True)
    staging.write_text("a.csv", "results")
    staging.write_manifest({})
    staging.publish()
    assert (out / "a.csv").read_text() == "results"


# ---------------------------------------------------------------- another scenario's results


def test_another_scenarios_results_are_refused_unless_overwrite(tmp_path: Path) -> None:
    out = tmp_path / "out"
    _publish(out, {"sign/pdsmc.csv": "1", "metrics.csv": "2"})
    manifest = json.loads((out / MANIFEST).read_text())
    (out / MANIFEST).write_text(json.dumps({**manifest, "scenarios": ["sign"]}))
    with pytest.raises(OutputError) as info:
        Staging(out, scenarios=["tanh"])
    message = str(info.value)
    assert message.startswith(f"{out}: holds the results of scenario sign, ")
    assert "metrics.csv, sign/pdsmc.csv" in message and "--overwrite" in message
    assert "\n" not in message
    assert sorted(p.name for p in out.iterdir()) == [MANIFEST, "metrics.csv", "sign"]
    Staging(out, scenarios=["sign"]).discard()  # the same scenario again: fine
    Staging(out, scenarios=["tanh", "sign"]).discard()  # a superset: fine
    staging = Staging(out, scenarios=["tanh"], overwrite=True)
    staging.write_text("tanh/pdsmc.csv", "3")
    staging.write_manifest({"scenarios": ["tanh"]})
    staging.publish()
    assert sorted(p.name for p in out.iterdir()) == [MANIFEST, "tanh"]


def test_a_manifest_naming_no_scenario_is_another_runs_results(tmp_path: Path) -> None:
    out = tmp_path / "out"
    _publish(out, {"points.parquet": "1"})  # e.g. written by another tool
    with pytest.raises(OutputError, match=r"holds another run's results, .*points\.parquet"):
        Staging(out, scenarios=["sign"])


# ---------------------------------------------------------------- one run at a time


def test_a_second_staging_of_the_same_folder_is_refused(tmp_path: Path) -> None:
    out = tmp_path / "out"
    first = Staging(out)
    with pytest.raises(OutputError) as info:
        Staging(out)
    assert str(info.value) == (
        f"{out}: another slidingarm run (pid {os.getpid()}) is writing into this folder; "
        "wait for it to finish or choose another --out"
    )
    first.write_text("a.csv", "1")
    first.write_manifest({})
    first.publish()
    assert not (out / LOCK).exists(), "the lock goes with the run"
    Staging(out).discard()  # free again
    assert sorted(p.name for p in out.iterdir()) == ["a.csv", MANIFEST]


def test_a_file_system_without_locks_still_takes_results(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Some network file systems refuse flock (ENOLCK): the run goes on, unlocked."""

    def no_locks(fd: int, operation: int) -> None:
        raise OSError(errno.ENOLCK, os.strerror(errno.ENOLCK))

    monkeypatch.setattr(O.fcntl, "flock", no_locks)
    out = tmp_path / "out"
    _publish(out, {"a.csv": "1"})
    assert sorted(p.name for p in out.iterdir()) == ["a.csv", MANIFEST]


def test_a_failed_run_into_a_new_folder_leaves_nothing(tmp_path: Path) -> None:
    out = tmp_path / "new" / "out"
    staging = Staging(out)
    staging.write_text("a.csv", "1")
    staging.discard()
    staging.discard()  # twice is fine
    assert not out.exists()


# ---------------------------------------------------------------- the target's file system


def test_staging_lives_inside_the_target(tmp_path: Path) -> None:
    for out in (tmp_path / "new", tmp_path / "existing"):
        if out.name == "existing":
            out.mkdir()
        staging = Staging(out)
        assert staging.path.parent == out.absolute()
        assert os.stat(staging.path).st_dev == os.stat(out).st_dev
        staging.discard()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["existing"], "no staging beside"


def _fake_mounts(monkeypatch: pytest.MonkeyPatch, *mounts: Path) -> None:
    """Make os.replace/os.rename fail with EXDEV between ``mounts`` and the rest, as between
    two file systems."""

    def device(p: object) -> Path | None:
        path = Path(os.fspath(p)).absolute()  # type: ignore[arg-type]
        inside = [m for m in mounts if m == path or m in path.parents]
        return max(inside, key=lambda m: len(m.parts)) if inside else None

    for name in ("replace", "rename"):
        real = getattr(os, name)

        def moved(src: object, dst: object, *args: object, _real: Any = real, **kw: object) -> None:
            if device(src) != device(dst):
                raise OSError(errno.EXDEV, os.strerror(errno.EXDEV), src, None, dst)
            _real(src, dst, *args, **kw)

        monkeypatch.setattr(os, name, moved)


def test_a_mount_point_as_the_target(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    volume = tmp_path / "volume"
    volume.mkdir()
    _fake_mounts(monkeypatch, volume)
    _publish(volume, {"a.csv": "1", "sub/b.csv": "2"})
    assert (volume / "sub" / "b.csv").read_text() == "2"
    assert json.loads((volume / MANIFEST).read_text())["files"][0]["path"] == "a.csv"


def test_a_mount_inside_the_target_is_copied_across(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    out = tmp_path / "out"
    (out / "figures").mkdir(parents=True)
    _fake_mounts(monkeypatch, out / "figures")
    _publish(out, {"figures/x.png": "png", "a.csv": "1"})
    assert (out / "figures" / "x.png").read_text() == "png"
    assert sorted(p.name for p in (out / "figures").iterdir()) == ["x.png"], "no temporary left"


# ---------------------------------------------------------------- staging folders of killed runs


def _partial(out: Path, pid: int, start: str) -> Path:
    p = out / f"{PARTIAL}{pid}-{start}-abcd1234"
    (p / "sign").mkdir(parents=True)
    (p / "sign" / "pdsmc.csv").write_text("half-written")
    return p


def test_a_dead_runs_staging_folder_is_removed_a_live_ones_kept(tmp_path: Path) -> None:
    out = tmp_path / "out"
    out.mkdir()
    child = subprocess.Popen([sys.executable, "-c", "pass"])
    child.wait()
    dead = _partial(out, child.pid, "0")
    mine = os.getpid()
    live = _partial(out, mine, O._start_time(mine) or "0")
    reused = _partial(out, mine, "1")  # this pid, but a process that started at another time
    Staging(out).discard()
    assert not dead.exists()
    assert live.exists()
    assert not reused.exists() or O._start_time(mine) is None
    assert not any(p.name == LOCK for p in out.iterdir())


# ---------------------------------------------------------------------------- the runs' CSVs


def _repr_csv(result: Any) -> bytes:
    """The CSV as it was written before it was formatted in bulk: ``repr`` of every float."""
    from slidingarm.results import SIGNALS

    data = np.column_stack([result.t] + [getattr(result, name) for name in SIGNALS])
    lines = [",".join(result.columns())] + [",".join(map(repr, row)) for row in data.tolist()]
    return ("\n".join(lines) + "\n").encode("ascii")


def test_run_csv_reads_back_bit_identical_to_repr() -> None:
    """csv_bytes formats in bulk; parsed, its text gives exactly the floats that ``repr`` text
    gives (sign of zero, subnormals, every exponent), and every column still reads as floats
    (whole numbers keep their ``.0``)."""
    from slidingarm.results import SIGNALS, SimResult

    rng = np.random.default_rng(20261202)
    n, count = 2, 4000
    special = np.array(
        [0.0, -0.0, 1.0, -4.0, 0.1, 1 / 3, 1e-5, 1e-7, 123456.0, 1e15 - 1.0, 1e15, 1e16, 1e22,
         5e-324, 2.2250738585072014e-308, 1.7976931348623157e308, -1.5e-300, 2.5, 1e21, 7e20]
    )  # fmt: skip
    randoms = rng.standard_normal(count) * 10.0 ** rng.integers(-30, 30, count)
    values = np.concatenate([special, randoms, np.round(randoms[:100])])
    T = values.size
    signals = {
        name: np.column_stack([np.roll(values, 7 * i + j) for j in range(n)])
        for i, name in enumerate(SIGNALS)
    }
    signals["tau"][:, 1] = np.linspace(-3.0, 3.0, T)  # a column without a whole number ...
    signals["s"][:, 0] = np.round(signals["s"][:, 0] * 0.0)  # ... and one of zeros only
    result = SimResult(t=np.arange(T) * 5e-4, **signals, params={"case": "csv"}, seed=1)
    new, old = O.csv_bytes(result), _repr_csv(result)
    assert new.splitlines()[0] == old.splitlines()[0]
    parse = lambda b: np.array(  # noqa: E731
        [[float(x) for x in line.split(b",")] for line in b.splitlines()[1:]]
    )
    got, want = parse(new), parse(old)
    np.testing.assert_array_equal(got.view(np.int64), want.view(np.int64))
    np.testing.assert_array_equal(want.view(np.int64), result.to_dataframe().to_numpy().view(np.int64))
    import io

    import pandas as pd

    frame = pd.read_csv(io.BytesIO(new))
    assert (frame.dtypes == np.float64).all(), frame.dtypes[frame.dtypes != np.float64]
    assert frame.shape == (T, 1 + len(SIGNALS) * n)
