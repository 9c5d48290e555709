"""File I/O shared across the package: atomic writes with ordinary modes (results, figures, the
report, the study) and reading a model description given as a path or as its text."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

__all__ = ["MAX_MODEL_BYTES", "atomic_write_bytes", "atomic_write_text", "read_model_text", "umask"]


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


#: A model file (URDF, MJCF) larger than this is refused before it is read: the largest robot
#: descriptions are a few MB with meshes inline.
MAX_MODEL_BYTES = 64 * 2**20


def read_model_text(source: object, what: str) -> tuple[str, Path | None, str]:
    """``(text, resolved path or None, label for messages)`` of a model ``source``: a path
    (``str`` or ``os.PathLike``, relative to the working directory) or the model's text itself
    (a string whose first non-blank character is ``<``). ``what`` names the format ("URDF").

    Raises
    ------
    TypeError, ValueError
        ``ParameterTypeError`` for a source of another type; ``ValueError`` naming the file if
        it does not exist, is not a regular file (a FIFO, ``/dev/zero``), is larger than
        :data:`MAX_MODEL_BYTES`, is not UTF-8 or cannot be read.
    """
    import stat

    from slidingarm._validate import ParameterTypeError

    if isinstance(source, str) and source.lstrip().startswith("<"):
        return source, None, f"the {what} text"
    if not isinstance(source, str | os.PathLike):
        raise ParameterTypeError(
            f"source must be a path or {what} text (a str), got {type(source).__name__}"
        )
    path = Path(source)
    label = f"{what} file {str(path)!r}"
    try:
        st = path.stat()
    except FileNotFoundError:
        raise ValueError(
            f"cannot read {label}: it does not exist (a relative path is read from the working "
            f"directory {os.getcwd()!r}; text, not a path, must start with '<')"
        ) from None
    except OSError as err:
        raise ValueError(f"cannot read {label}: {err.strerror or err}") from None
    if not stat.S_ISREG(st.st_mode):
        raise ValueError(f"cannot read {label}: it is not a regular file")
    if st.st_size > MAX_MODEL_BYTES:
        raise ValueError(
            f"cannot read {label}: it is {st.st_size} bytes, more than a model file can sensibly be"
        )
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError as err:
        raise ValueError(f"cannot read {label}: it is not UTF-8 text ({err})") from None
    except OSError as err:
        raise ValueError(f"cannot read {label}: {err.strerror or err}") from None
    return text, path.resolve(), label
