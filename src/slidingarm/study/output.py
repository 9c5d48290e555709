"""Writing a results folder so that an interrupted run never leaves a complete-looking one, and
no run loses a file it did not write.

A run takes the folder first: it creates it if needed and holds an exclusive lock on
``<target>/.slidingarm.lock`` (:func:`fcntl.flock`; the file names the holder's pid) until it
has published or given up, so a second run into the same folder is refused at once. Everything
is then written into a hidden staging folder *inside* the target
(``<target>/.partial-<pid>-<start>-XXXX``), so staging and publishing stay on the target's own
file system (a mount point, a Docker volume) and need no write access to the target's parent.
Publishing writes a record of both runs' files and hashes (``.manifest.pending.json``), removes
the old ``manifest.json``, moves each file in with :func:`os.replace` (atomic per file), moves
the new ``manifest.json`` in last and drops the record; a run killed half-way thus leaves a
folder without a manifest, and the record tells the next run which of its files were results.
A folder whose ``manifest.json`` lists its files is complete; a failure before publishing
removes the staging folder (and the target, if this run created it and nothing else is in it)
and leaves the target as it was.

What a run may replace or remove in an existing folder:

* a file that the previous ``manifest.json`` lists *and* whose content still has the SHA-256
  recorded there (the previous run's untouched output);
* a file the run writes with the very same bytes (nothing changes);
* with ``overwrite``, also a file that no manifest lists but that has the name of one this run
  writes, and the results of scenarios other than this run's.

Never: a file changed since the manifest recorded it, nor the run's own input (its scenario
file and the files it extends). Such a file in the way of a result refuses the run (before
anything is moved); one that the run merely would have removed is kept. A staging folder left
by a killed run is removed by the next run into the folder, once its owner process is dead.
"""

from __future__ import annotations

import errno
import hashlib
import io
import json
import os
import shutil
import tempfile
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from slidingarm._io import atomic_write_text, umask
from slidingarm.results import SimResult

try:  # POSIX; elsewhere runs are not locked against each other
    import fcntl
except ImportError:  # pragma: no cover - Windows
    fcntl = None  # type: ignore[assignment]

__all__ = ["LOCK", "MANIFEST", "OutputError", "Staging", "csv_bytes"]

#: Name of the manifest, the file written last.
MANIFEST = "manifest.json"
#: Name of the lock file a run holds inside its output folder (removed when it is done).
LOCK = ".slidingarm.lock"
#: Prefix of a staging folder inside the output folder.
PARTIAL = ".partial-"
#: While a run moves its files in: every file of the previous and the new manifest with their
#: hashes, so that a run killed half-way leaves a record of what in the folder were results.
PENDING = ".manifest.pending.json"
#: How many file names a refusal lists before "and N more".
_SHOWN = 5
#: ``flock`` errors of a file system that has no locks (some network file systems).
_NO_LOCKS = frozenset(
    getattr(errno, name)
    for name in ("ENOLCK", "EOPNOTSUPP", "ENOTSUP", "ENOSYS")
    if hasattr(errno, name)
)


class OutputError(OSError):
    """The output folder cannot be used (it is a file, cannot be created or written, another
    run holds it, or the run would replace what it must not)."""


class Staging:
    """A private folder inside ``target`` whose files move into ``target`` on :meth:`publish`.

    Parameters
    ----------
    target : path
        The results folder; created if needed.
    scenarios : sequence of str, optional
        The scenarios this run writes (recorded by the caller in the manifest under
        ``"scenarios"``). When given, a folder whose previous manifest lists the results of
        other scenarios is refused unless ``overwrite``.
    inputs : iterable of path
        The run's own input files (its scenario file and the files it extends); never replaced
        nor removed.
    overwrite : bool
        Allow replacing another scenario's results and files that no manifest lists.

    Raises
    ------
    OutputError
        At construction (before any work): if ``target`` exists and is not a folder, cannot be
        created or written, is held by another run, or holds other scenarios' results (without
        ``overwrite``).
    """

    def __init__(
        self,
        target: str | os.PathLike[str],
        *,
        scenarios: Sequence[str] | None = None,
        inputs: Iterable[str | os.PathLike[str]] = (),
        overwrite: bool = False,
    ) -> None:
        self.target = Path(target).absolute()
        self.overwrite = bool(overwrite)
        self.scenarios = None if scenarios is None else tuple(scenarios)
        self.inputs = frozenset(_real(p) for p in inputs)
        #: Files of the previous run that this run did not write and kept, because they changed
        #: since the previous manifest recorded them or are this run's input (set by publish).
        self.kept: list[Path] = []
        self._label = str(target)
        self._lock_fd: int | None = None
        self._created = False
        self._path: Path | None = None
        try:
            self._take_folder()
            self._lock()
            _remove_stale_partials(self.target)
            self._check_previous()
            self._path = Path(tempfile.mkdtemp(prefix=f"{PARTIAL}{_owner_tag()}-", dir=self.target))
        except BaseException as exc:
            self.discard()
            if isinstance(exc, OSError) and not isinstance(exc, OutputError):
                raise OutputError(
                    f"{self._label}: cannot write there ({exc.strerror or exc})"
                ) from None
            raise
        self._mode_dir = 0o777 & ~umask()
        self._mode_file = 0o666 & ~umask()
        self._path.chmod(self._mode_dir)

    # ------------------------------------------------------------------ taking the folder
    def _take_folder(self) -> None:
        target = self.target
        if target.exists() and not target.is_dir():
            raise OutputError(f"{self._label}: exists and is not a folder; choose another --out")
        for ancestor in target.parents:
            if ancestor.exists():
                if not ancestor.is_dir():
                    raise OutputError(f"{self._label}: {ancestor} is a file, not a folder")
                break
        if not target.is_dir():
            target.parent.mkdir(parents=True, exist_ok=True)
            try:
                target.mkdir()
                self._created = True
            except FileExistsError:  # another process made it meanwhile
                if not target.is_dir():
                    raise
        if not os.access(target, os.W_OK | os.X_OK):
            raise OutputError(f"{self._label}: the folder is not writable")

    def _lock(self) -> None:
        """Hold ``<target>/.slidingarm.lock`` exclusively, or refuse naming the holder."""
        if fcntl is None:  # pragma: no cover - Windows
            return
        path = self.target / LOCK
        for _ in range(10):
            fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o666 & ~umask())
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError as exc:
                if exc.errno in _NO_LOCKS:  # a file system without locks: run unlocked
                    self._lock_fd = fd
                    return
                if exc.errno not in (errno.EAGAIN, errno.EWOULDBLOCK, errno.EACCES):
                    os.close(fd)
                    raise
                holder = _read_pid(fd)
                os.close(fd)
                who = f"another slidingarm run (pid {holder})" if holder else "another run"
                raise OutputError(
                    f"{self._label}: {who} is writing into this folder; wait for it to finish "
                    "or choose another --out"
                ) from None
            except BaseException:
                os.close(fd)
                raise
            try:
                same = os.fstat(fd).st_ino == os.stat(path).st_ino
            except FileNotFoundError:
                same = False
            if same:  # not a file its previous holder unlinked as we opened it
                os.ftruncate(fd, 0)
                os.write(fd, f"{os.getpid()}\n".encode("ascii"))
                self._lock_fd = fd
                return
            os.close(fd)
        raise OutputError(f"{self._label}: could not take the folder's lock ({path})")

    def _release(self) -> None:
        if self._lock_fd is None:
            return
        try:
            (self.target / LOCK).unlink(missing_ok=True)  # while still held: see _lock
        except OSError:
            pass
        os.close(self._lock_fd)
        self._lock_fd = None

    def _check_previous(self) -> None:
        """Refuse, unless ``overwrite``, a folder holding the results of other scenarios."""
        if self.overwrite or self.scenarios is None:
            return
        previous = _Manifest.of(self.target)
        # what this run would replace or remove: the previous results still as recorded (an
        # edited one is kept, or refuses the run when in the way: see check)
        present = [
            rel
            for rel, recorded in sorted(previous.files.items())
            if recorded and (self.target / rel).is_file() and _sha256(self.target / rel) in recorded
        ]
        if not present:
            return
        others = (
            None
            if previous.scenarios is None
            else [s for s in previous.scenarios if s not in self.scenarios]
        )
        if others == []:
            return
        whose = (
            "another run's results"
            if others is None
            else f"the results of scenario{'s' if len(others) > 1 else ''} {', '.join(others)}"
        )
        this = ", ".join(self.scenarios) or "this run"
        raise OutputError(
            f"{self._label}: holds {whose}, which this run ({this}) would replace or remove: "
            f"{_some(present)}; pass --overwrite to replace them, or choose another --out"
        )

    # ------------------------------------------------------------------ staging
    @property
    def path(self) -> Path:
        """The staging folder (inside the target)."""
        if self._path is None:
            raise OutputError(f"{self._label}: the staging folder has been discarded")
        return self._path

    def _staging(self) -> Path:
        return self.path

    def file(self, relative: str | os.PathLike[str]) -> Path:
        """Path of ``relative`` inside the staging folder (its parent folders created)."""
        p = self._staging() / relative
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
        root = self._staging()
        return sorted(p.relative_to(root) for p in root.rglob("*") if p.is_file())

    def write_manifest(self, manifest: dict[str, Any]) -> Path:
        """Add the list of staged files (size and SHA-256) to ``manifest`` and stage it."""
        entries = []
        root = self._staging()
        for rel in self.files():
            if rel.as_posix() == MANIFEST:
                continue
            data = (root / rel).read_bytes()
            entries.append(
                {
                    "path": rel.as_posix(),
                    "bytes": len(data),
                    "sha256": hashlib.sha256(data).hexdigest(),
                }
            )
        body = {**manifest, "files": entries}
        return self.write_text(MANIFEST, json.dumps(body, indent=2, default=_json_default) + "\n")

    def check(self) -> None:
        """Refuse now, rather than at :meth:`publish`, if a file staged so far may not replace
        the target's file of that name (see the module docstring).

        Raises
        ------
        OutputError
            Naming the files in the way; nothing in the target has been touched.
        """
        previous = _Manifest.of(self.target)
        root = self._staging()
        protected: list[str] = []
        unlisted: list[str] = []
        for rel in self.files():
            name = rel.as_posix()
            if name == MANIFEST:
                continue
            dest = self.target / rel
            blocked = [f for f in rel.parents if (self.target / f).is_file()]
            if blocked:
                protected.append(f"{blocked[-1].as_posix()} (a file where {name} needs a folder)")
                continue
            if dest.is_dir() and not dest.is_symlink():
                protected.append(f"{name} (a folder)")
                continue
            if not dest.is_file():
                continue
            current = _sha256(dest)
            if current == _sha256(root / rel):
                continue
            if _real(dest) in self.inputs:
                protected.append(f"{name} (this run's input)")
            elif previous.files.get(name):
                if current not in previous.files[name]:
                    protected.append(f"{name} (changed since {MANIFEST} recorded it)")
            elif not self.overwrite:
                unlisted.append(name)
        if protected:
            raise OutputError(
                f"{self._label}: this run would replace {_some(protected)}; nothing was "
                "replaced: move them out of the folder or choose another --out"
            )
        if unlisted:
            raise OutputError(
                f"{self._label}: this run would replace files that no {MANIFEST} lists: "
                f"{_some(unlisted)}; nothing was replaced: pass --overwrite to replace them, "
                "or choose another --out"
            )

    def publish(self) -> Path:
        """Move the staged files into the target; the manifest last. Returns the target.

        Files of the same names are replaced (after :meth:`check`), and the files that the
        folder's previous ``manifest.json`` listed but this run did not write are removed when
        their content is still what that manifest recorded (others are kept, and listed in
        :attr:`kept`), so that no result of an earlier run passes for one of this run. Files
        that no manifest lists (the user's own) are left alone.

        Raises
        ------
        OutputError
            If :meth:`check` refuses, or a file cannot be moved in (the folder is then left
            without a manifest: visibly incomplete).
        """
        root = self._staging()
        try:
            self.check()
            for p in root.rglob("*"):
                p.chmod(self._mode_dir if p.is_dir() else self._mode_file)
            previous = _Manifest.of(self.target)
            # until the new manifest is in, a record of both runs' files tells the next run
            # which files in the folder were results (if this one is killed half-way)
            pending = previous.merged(_Manifest.read(root / MANIFEST))
            atomic_write_text(self.target / PENDING, pending.to_json())
            (self.target / MANIFEST).unlink(missing_ok=True)
            staged = [rel for rel in self.files() if rel.as_posix() != MANIFEST]
            for rel in staged:
                dest = self.target / rel
                dest.parent.mkdir(parents=True, exist_ok=True)
                _move(root / rel, dest)
            stale = dict(previous.files)
            for rel in staged:
                stale.pop(rel.as_posix(), None)
            self.kept = _remove_stale(self.target, stale, self.inputs)
            if (root / MANIFEST).exists():
                _move(root / MANIFEST, self.target / MANIFEST)
            (self.target / PENDING).unlink(missing_ok=True)
            self._created = False  # published: the folder is the results now
        except OutputError:
            raise
        except OSError as exc:
            raise OutputError(f"{self.target}: cannot move the results in ({exc})") from exc
        finally:
            self.discard()
        return self.target

    def discard(self) -> None:
        """Remove the staging folder and release the target (removing it if this run created it
        and nothing is in it); safe to call more than once."""
        if self._path is not None:
            shutil.rmtree(self._path, ignore_errors=True)
            self._path = None
        self._release()
        if self._created:
            self._created = False
            try:
                self.target.rmdir()
            except OSError:
                pass


class _Manifest:
    """What a previous manifest says: file path → the SHA-256 values recorded for it (empty if
    it states none; two in a pending record, the old run's and the new one's), and the
    scenarios (None if it names none). A missing or unreadable manifest lists nothing."""

    def __init__(self, files: dict[str, frozenset[str]], scenarios: list[str] | None) -> None:
        self.files = files
        self.scenarios = scenarios

    @classmethod
    def read(cls, path: Path) -> _Manifest:
        try:
            body = json.loads(path.read_text(encoding="utf-8"))
            files: dict[str, frozenset[str]] = {}
            for e in body.get("files", []):
                if not isinstance(e, dict) or "path" not in e:
                    continue
                sha = e.get("sha256")
                hashes = [sha] if isinstance(sha, str) else sha if isinstance(sha, list) else []
                files[str(e["path"])] = frozenset(str(h) for h in hashes)
            raw = body.get("scenarios")
            scenarios = [str(s) for s in raw] if isinstance(raw, list) else None
            return cls(files, scenarios)
        except (OSError, ValueError, AttributeError, TypeError):
            return cls({}, None)

    @classmethod
    def of(cls, folder: Path) -> _Manifest:
        """The folder's ``manifest.json``; without one, the pending record of a publish that
        was cut short (:data:`PENDING`)."""
        if (folder / MANIFEST).is_file():
            return cls.read(folder / MANIFEST)
        return cls.read(folder / PENDING)

    def merged(self, other: _Manifest) -> _Manifest:
        """Both listings: each path with the hashes either records; the scenarios of both
        (None if one that lists files names none)."""
        files = dict(self.files)
        for rel, hashes in other.files.items():
            files[rel] = files.get(rel, frozenset()) | hashes
        unknown = any(m.scenarios is None and m.files for m in (self, other))
        scenarios = (
            None
            if unknown
            else list(dict.fromkeys([*(self.scenarios or []), *(other.scenarios or [])]))
        )
        return _Manifest(files, scenarios)

    def to_json(self) -> str:
        body: dict[str, Any] = {
            "files": [{"path": rel, "sha256": sorted(h)} for rel, h in sorted(self.files.items())]
        }
        if self.scenarios is not None:
            body["scenarios"] = self.scenarios
        return json.dumps(body, indent=2) + "\n"


def _real(path: str | os.PathLike[str]) -> Path:
    try:
        return Path(path).resolve()
    except OSError:
        return Path(path).absolute()


def _sha256(path: Path) -> str | None:
    try:
        h = hashlib.sha256()
        with path.open("rb") as fh:
            for block in iter(lambda: fh.read(1 << 20), b""):
                h.update(block)
        return h.hexdigest()
    except OSError:
        return None


def _some(names: Sequence[str]) -> str:
    shown = ", ".join(names[:_SHOWN])
    return shown if len(names) <= _SHOWN else f"{shown} and {len(names) - _SHOWN} more"


def _move(src: Path, dest: Path) -> None:
    """:func:`os.replace`, or across file systems (a mount inside the target) a copy into a
    temporary file beside ``dest`` and a rename, so ``dest`` is never seen half-written."""
    try:
        os.replace(src, dest)
        return
    except OSError as exc:
        if exc.errno != errno.EXDEV:
            raise
    fd, tmp = tempfile.mkstemp(prefix=f".{dest.name}.", suffix=".tmp", dir=dest.parent)
    try:
        with os.fdopen(fd, "wb") as out, src.open("rb") as inp:
            shutil.copyfileobj(inp, out)
        os.chmod(tmp, src.stat().st_mode & 0o777)
        os.replace(tmp, dest)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    src.unlink()


def _remove_stale(
    target: Path, stale: dict[str, frozenset[str]], inputs: frozenset[Path]
) -> list[Path]:
    """Remove the files ``stale`` (relative path → recorded SHA-256 values) inside ``target``
    whose content is still a recorded one and that are not among ``inputs``, then the folders
    they leave empty; never anything outside ``target``. Returns the files kept (relative)."""
    root = target.resolve()
    kept: list[Path] = []
    for rel in sorted(stale):
        path = (target / rel).resolve()
        if root not in path.parents or not path.is_file():
            continue
        recorded = stale[rel]
        if path in inputs or _sha256(path) not in recorded:
            kept.append(path.relative_to(root))
            continue
        path.unlink()
        for folder in path.parents:
            if folder == root or any(folder.iterdir()):
                break
            folder.rmdir()
    return kept


# -------------------------------------------------------------------- owners of staging folders


def _start_time(pid: int) -> str | None:
    """The start time of process ``pid`` in clock ticks since boot (Linux ``/proc``), to tell
    it from a later process given the same pid; None where it cannot be read."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return None
    fields = stat[stat.rfind(")") + 2 :].split()
    return fields[19] if len(fields) > 19 else None


def _owner_tag() -> str:
    pid = os.getpid()
    return f"{pid}-{_start_time(pid) or 0}"


def _alive(pid: int, start: str) -> bool:
    """Whether the process that made a staging folder (``pid``, started at ``start``) runs."""
    if pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        pass  # someone else's process: it exists
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return True  # no /proc: the pid exists
    rest = stat[stat.rfind(")") + 2 :].split()
    if rest and rest[0] in ("Z", "X"):
        return False  # a zombie: dead, not yet reaped
    return not (start != "0" and len(rest) > 19 and rest[19] != start)


def _remove_stale_partials(target: Path) -> None:
    """Remove the staging folders inside ``target`` whose owner process is dead."""
    try:
        entries = list(target.iterdir())
    except OSError:
        return
    for entry in entries:
        if not entry.name.startswith(PARTIAL) or entry.is_symlink() or not entry.is_dir():
            continue
        parts = entry.name[len(PARTIAL) :].split("-")
        if len(parts) < 3 or not parts[0].isdigit():
            continue
        if not _alive(int(parts[0]), parts[1]):
            shutil.rmtree(entry, ignore_errors=True)


def _read_pid(fd: int) -> int | None:
    try:
        text = os.pread(fd, 32, 0).decode("ascii", "replace").strip()
        return int(text) if text.isdigit() else None
    except OSError:
        return None


def _json_default(x: Any) -> Any:
    if isinstance(x, np.generic):
        return x.item()
    if isinstance(x, Path):
        return x.as_posix()
    raise TypeError(f"not JSON serialisable: {type(x).__name__}")


#: Below this magnitude Arrow writes a whole number as plain digits (``12``), to which the
#: ``.0`` of Python's ``repr`` is appended (:func:`csv_bytes`).
_PLAIN_WHOLE = 1e15


def csv_bytes(result: SimResult) -> bytes:
    """One row per sample with the columns of :meth:`SimResult.columns` (``t``, then ``q``,
    ``qd``, ``qref``, ``qdref``, ``qm``, ``qdm``, ``tau``, ``s`` per joint), each value a
    shortest text that reads back as the same float.

    The values are formatted in bulk by Arrow (shortest round-trip digits, in C++: a fraction
    of the time of a ``repr`` per value). Arrow writes a whole number as ``0`` where Python
    writes ``0.0``, and a reader such as pandas takes a column of ``0`` for integers, so a
    whole number gets ``.0`` appended (``0.0``, ``-0.0``, ``4.0``). The text may differ from
    ``repr`` in the form of a very small or large number (``0.00001`` for ``1e-05``); the
    values read back are the same, bit for bit. A column with a non-finite value (never in a
    finished run) or a whole number of 1e15 or more is written with ``repr``.
    """
    import pyarrow as pa
    import pyarrow.compute as pc
    import pyarrow.csv as pa_csv

    from slidingarm.results import SIGNALS

    data = np.column_stack([result.t] + [getattr(result, name) for name in SIGNALS])
    columns = []
    for i in range(data.shape[1]):
        col = np.ascontiguousarray(data[:, i])
        whole = col == np.trunc(col)
        if not np.isfinite(col).all() or np.any(whole & (np.abs(col) >= _PLAIN_WHOLE)):
            columns.append(pa.array([repr(x) for x in col.tolist()], type=pa.string()))
            continue
        text = pc.cast(pa.array(col), pa.string())
        if whole.any():
            text = pc.if_else(pa.array(whole), pc.binary_join_element_wise(text, ".0", ""), text)
        columns.append(text)
    sink = io.BytesIO()
    sink.write((",".join(result.columns()) + "\n").encode("ascii"))
    table = pa.table(columns, names=result.columns())
    pa_csv.write_csv(table, sink, pa_csv.WriteOptions(include_header=False, quoting_style="none"))
    return sink.getvalue()
