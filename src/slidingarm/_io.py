"""File I/O shared across the package: atomic writes with ordinary modes (results, figures, the
report, the study) and reading a model description given as a path or as its text."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

__all__ = [
    "MAX_MODEL_BYTES",
    "MAX_SCENARIO_BYTES",
    "MAX_TABLE_BYTES",
    "atomic_write_bytes",
    "atomic_write_text",
    "file_problem",
    "read_capped_text",
    "read_model_text",
    "umask",
]


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


#: A scenario file larger than this is refused before it is read: the shipped ones are a few
#: kB, and an inline reference table of 100 000 rows still fits.
MAX_SCENARIO_BYTES = 16 * 2**20

#: A reference table (CSV) larger than this is refused before it is read: a million samples
#: of a seven-joint arm take about 150 MB.
MAX_TABLE_BYTES = 256 * 2**20


def file_problem(path: Path, what: str, max_bytes: int) -> str | None:
    """Why ``path`` cannot be read as a ``what`` (e.g. "scenario file"), found without opening
    it, or ``None``: it does not exist, is a folder, is not a regular file (a FIFO, which would
    block, or a device such as ``/dev/zero``, which never ends), or is larger than
    ``max_bytes``. The reasons are phrases for a message that names the file itself."""
    import stat

    try:
        st = path.stat()
    except FileNotFoundError:
        return "no such file"
    except OSError as err:
        return f"cannot read: {err.strerror or err}"
    if stat.S_ISDIR(st.st_mode):
        return f"is a directory, not a {what}"
    if not stat.S_ISREG(st.st_mode):
        return f"is not a regular file (a FIFO, device or socket), so not a {what}"
    if st.st_size > max_bytes:
        return (
            f"is {st.st_size:,} bytes, more than the {max_bytes:,} bytes a {what} may have"
        )
    return None


def read_capped_text(path: Path, what: str, max_bytes: int) -> str:
    """The UTF-8 text of ``path``, a regular file of at most ``max_bytes``: checked by
    :func:`file_problem`, then again on the open file, and never more than ``max_bytes + 1``
    bytes read (a file that grows past the cap is refused). Line ends are read as
    :meth:`pathlib.Path.read_text` reads them (``\\r\\n`` and ``\\r`` become ``\\n``).

    Raises
    ------
    ValueError
        With the :func:`file_problem` phrase, "is not UTF-8 text (...)" or "cannot read: ...".
    """
    import stat

    problem = file_problem(path, what, max_bytes)
    if problem is not None:
        raise ValueError(problem)
    try:
        # non-blocking: a FIFO swapped in after the check must not hang the open
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0))
    except OSError as err:
        raise ValueError(f"cannot read: {err.strerror or err}") from None
    with os.fdopen(fd, "rb") as fh:
        if not stat.S_ISREG(os.fstat(fd).st_mode):
            raise ValueError(f"is not a regular file (a FIFO, device or socket), so not a {what}")
        data = fh.read(max_bytes + 1)
    if len(data) > max_bytes:
        raise ValueError(f"is more than the {max_bytes:,} bytes a {what} may have")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as err:
        raise ValueError(f"is not UTF-8 text ({err})") from None
    # universal newlines, as Path.read_text
    return text.replace("\r\n", "\n").replace("\r", "\n")
