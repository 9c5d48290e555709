"""Tests for the output folder: what publishing into an existing folder keeps and removes."""

from __future__ import annotations

import json
from pathlib import Path

from slidingarm.study.output import MANIFEST, Staging


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
