"""File writing shared by results, figures, the report and the study: atomic, ordinary modes."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

__all__ = ["atomic_write_bytes", "atomic_write_text", "umask"]


def _read_umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


#: The file-creation mask, read once at import. Reading it means setting it for an instant,
#: which a thread creating a file at that instant would feel, so it is not read per write.
_UMASK = _read_umask()


def umask() -> int:
    """The process's file-creation mask (as it was when slidingarm was imported)."""
    return _UMASK


def atomic_write_bytes(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` through a temporary file in the same folder and a rename.

    A reader never sees a partial file, and an interrupted write leaves the previous file (or
    none). The file gets the ordinary mode ``0o666 & ~umask`` (``mkstemp`` alone gives 0600).
    """
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
        os.chmod(tmp, 0o666 & ~umask())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def atomic_write_text(path: Path, text: str) -> None:
    """:func:`atomic_write_bytes` for UTF-8 text."""
    atomic_write_bytes(path, text.encode("utf-8"))
