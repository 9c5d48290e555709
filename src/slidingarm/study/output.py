"""Writing a results folder so that an interrupted run never leaves a complete-looking one.

Everything is first written into a hidden staging folder next to the target
(``.<name>.partial-XXXX``). Publishing then either renames the staging folder onto the target
(when the target does not exist: one atomic rename) or, into an existing folder, removes the old
``manifest.json`` first, moves each file in with :func:`os.replace` (atomic per file) and moves
the new ``manifest.json`` in last. A folder whose ``manifest.json`` lists its files is complete;
a failure before publishing removes the staging folder and leaves the target untouched.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from slidingarm._io import umask
from slidingarm.results import SimResult

__all__ = ["MANIFEST", "OutputError", "Staging", "csv_bytes"]

#: Name of the manifest, the file written last.
MANIFEST = "manifest.json"


class OutputError(OSError):
    """The output folder cannot be used (it is a file, or cannot be created or written)."""


class Staging:
    """A private folder next to ``target`` that becomes ``target`` on :meth:`publish`.

    Raises
    ------
    OutputError
        At construction, if ``target`` exists and is not a folder, or if its parent cannot be
        created or written.
    """

    def __init__(self, target: str | os.PathLike[str]) -> None:
        self.target = Path(target).absolute()
        try:
            if self.target.exists() and not self.target.is_dir():
                raise OutputError(f"{target}: exists and is not a folder; choose another --out")
            for ancestor in self.target.parents:
                if ancestor.exists():
                    if not ancestor.is_dir():
                        raise OutputError(f"{target}: {ancestor} is a file, not a folder")
                    break
            parent = self.target.parent
            parent.mkdir(parents=True, exist_ok=True)
            self.path = Path(tempfile.mkdtemp(prefix=f".{self.target.name}.partial-", dir=parent))
        except OutputError:
            raise
        except OSError as exc:
            raise OutputError(f"{target}: cannot write there ({exc.strerror or exc})") from None
        if self.target.is_dir() and not os.access(self.target, os.W_OK | os.X_OK):
            self.discard()
            raise OutputError(f"{target}: the folder is not writable")
        self._mode_dir = 0o777 & ~umask()
        self._mode_file = 0o666 & ~umask()
        self.path.chmod(self._mode_dir)

    def file(self, relative: str | os.PathLike[str]) -> Path:
        """Path of ``relative`` inside the staging folder (its parent folders created)."""
        p = self.path / relative
        p.parent.mkdir(parents=True, exist_ok=True)
        return p

    def write_bytes(self, relative: str | os.PathLike[str], data: bytes) -> Path:
        """Write ``data`` to ``relative`` inside the staging folder."""
        p = self.file(relative)
        p.write_bytes(data)
        return p

    def write_text(self, relative: str | os.PathLike[str], text: str) -> Path:
        """Write UTF-8 ``text`` to ``relative`` inside the staging folder."""
        return self.write_bytes(relative, text.encode("utf-8"))

    def files(self) -> list[Path]:
        """Every file staged so far, relative to the staging folder, sorted."""
        return sorted(p.relative_to(self.path) for p in self.path.rglob("*") if p.is_file())

    def write_manifest(self, manifest: dict[str, Any]) -> Path:
        """Add the list of staged files (size and SHA-256) to ``manifest`` and stage it."""
        entries = []
        for rel in self.files():
            if rel.as_posix() == MANIFEST:
                continue
            data = (self.path / rel).read_bytes()
            entries.append(
                {
                    "path": rel.as_posix(),
                    "bytes": len(data),
                    "sha256": hashlib.sha256(data).hexdigest(),
                }
            )
        body = {**manifest, "files": entries}
        return self.write_text(MANIFEST, json.dumps(body, indent=2, default=_json_default) + "\n")

    def publish(self) -> Path:
        """Move the staged files into the target; the manifest last. Returns the target.

        Into an existing folder, files of the same names are replaced, and the files that the
        folder's previous ``manifest.json`` listed but this run did not write are removed, so
        that no result of an earlier run passes for one of this run. Files that no manifest
        lists (the user's own) are left alone.
        """
        for p in self.path.rglob("*"):
            p.chmod(self._mode_dir if p.is_dir() else self._mode_file)
        try:
            if not self.target.exists():
                os.replace(self.path, self.target)
                return self.target
            previous = _listed_files(self.target / MANIFEST)
            (self.target / MANIFEST).unlink(missing_ok=True)
            staged = [rel for rel in self.files() if rel.as_posix() != MANIFEST]
            for rel in staged:
                dest = self.target / rel
                dest.parent.mkdir(parents=True, exist_ok=True)
                os.replace(self.path / rel, dest)
            _remove_stale(self.target, previous - {rel.as_posix() for rel in staged})
            if (self.path / MANIFEST).exists():
                os.replace(self.path / MANIFEST, self.target / MANIFEST)
        except OSError as exc:
            raise OutputError(f"{self.target}: cannot move the results in ({exc})") from exc
        finally:
            self.discard()
        return self.target

    def discard(self) -> None:
        """Remove the staging folder and everything in it."""
        shutil.rmtree(self.path, ignore_errors=True)


def _listed_files(manifest: Path) -> set[str]:
    """The relative paths a previous run's manifest lists (none if it is missing or unreadable)."""
    try:
        entries = json.loads(manifest.read_text(encoding="utf-8")).get("files", [])
        return {str(e["path"]) for e in entries if isinstance(e, dict) and "path" in e}
    except (OSError, ValueError, AttributeError, TypeError):
        return set()


def _remove_stale(target: Path, stale: set[str]) -> None:
    """Remove the files ``stale`` (relative paths) inside ``target``, then the folders they
    leave empty; never anything outside ``target``."""
    root = target.resolve()
    for rel in sorted(stale):
        path = (target / rel).resolve()
        if root not in path.parents or not path.is_file():
            continue
        path.unlink()
        for folder in path.parents:
            if folder == root or any(folder.iterdir()):
                break
            folder.rmdir()


def _json_default(x: Any) -> Any:
    if isinstance(x, np.generic):
        return x.item()
    if isinstance(x, Path):
        return x.as_posix()
    raise TypeError(f"not JSON serialisable: {type(x).__name__}")


def csv_bytes(result: SimResult) -> bytes:
    """One row per sample with the columns of :meth:`SimResult.columns` (``t``, then ``q``,
    ``qd``, ``qref``, ``qdref``, ``qm``, ``qdm``, ``tau``, ``s`` per joint), each value the
    shortest text that reads back as the same float."""
    from slidingarm.results import SIGNALS

    data = np.column_stack([result.t] + [getattr(result, name) for name in SIGNALS])
    lines = [",".join(result.columns())]
    lines += [",".join(map(repr, row)) for row in data.tolist()]
    return ("\n".join(lines) + "\n").encode("ascii")
