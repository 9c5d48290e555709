"""Reading scenario files: TOML, ``extends`` (merge onto a base file), validation.

``extends`` names a file relative to the extending one, or a shipped scenario by name
(``extends = "tanh"``). The merged scenario keeps every key of its base except ``name`` and
``description``, which belong to the extending file (its name defaults to its file's stem).
"""

from __future__ import annotations

import re
import tomllib
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from pydantic import ValidationError

from slidingarm._io import MAX_SCENARIO_BYTES, read_capped_text
from slidingarm.config.errors import ConfigError, from_pydantic
from slidingarm.config.scenario import Scenario

__all__ = ["load_scenario", "scenario_from_dict"]


_TOML_LINE = re.compile(r"\(at line (\d+), column (\d+)\)")

#: The deepest nesting of arrays and tables a scenario file may have. The deepest real one is
#: 4 (``reference.q``, a list of lists, in a table); the limit leaves room and stops a hostile
#: file long before the parser or the validation recurses out of the stack.
MAX_DEPTH = 32


def _read_toml(path: Path) -> dict[str, Any]:
    try:
        text = read_capped_text(path, "scenario file", MAX_SCENARIO_BYTES)
    except ValueError as exc:
        raise ConfigError(str(exc), file=path) from None
    try:
        data = tomllib.loads(text)
    except RecursionError:
        raise ConfigError(
            f"invalid TOML: arrays or tables nested too deep to read (a scenario nests at most "
            f"{MAX_DEPTH} deep)",
            file=path,
        ) from None
    except tomllib.TOMLDecodeError as exc:
        msg = str(exc)
        m = _TOML_LINE.search(msg)
        if m is None:
            raise ConfigError(f"invalid TOML: {msg}", file=path) from None
        reason = msg[: m.start()].strip().rstrip(".")
        raise ConfigError(
            f"invalid TOML: {reason} (column {m.group(2)})", file=f"{path}:{m.group(1)}"
        ) from None
    _check_depth(data, path)
    return data


def _check_depth(data: dict[str, Any], path: Path) -> None:
    """Refuse arrays or tables nested more than :data:`MAX_DEPTH` deep (without recursing)."""
    stack: list[tuple[Any, str, int]] = [(data, "", 0)]
    while stack:
        value, where, depth = stack.pop()
        if depth > MAX_DEPTH:
            raise ConfigError(
                f"arrays or tables nested more than {MAX_DEPTH} deep; a scenario file nests at "
                "most a few (a list of lists of numbers in a table)",
                file=path,
                path=where,
            )
        if isinstance(value, dict):
            for key, item in value.items():
                stack.append((item, f"{where}.{key}" if where else str(key), depth + 1))
        elif isinstance(value, list):
            # the key path of the outermost array suffices to find it
            stack.extend((item, where, depth + 1) for item in value)


def _merge(
    base: dict[str, Any],
    over: Mapping[str, Any],
    origin: dict[tuple[Any, ...], str],
    over_file: str,
    prefix: tuple[Any, ...] = (),
) -> dict[str, Any]:
    """Deep-merge ``over`` onto ``base``: tables merge key by key, except a table that names its
    kind (:func:`_names_kind`), which replaces; values and arrays replace. ``origin`` records
    which file each key path came from."""
    out = dict(base)
    for key, value in over.items():
        path = (*prefix, key)
        if isinstance(value, dict) and isinstance(out.get(key), dict) and not _names_kind(value):
            out[key] = _merge(out[key], value, origin, over_file, path)
        else:
            out[key] = value
            for p in [p for p in origin if p[: len(path)] == path]:
                del origin[p]
            origin[path] = over_file
    return out


def _names_kind(table: Mapping[str, Any]) -> bool:
    """Whether a table says what it is (``kind``; a plant's ``preset``, ``masses``, ``robot``
    or ``urdf``): such a table replaces the base's instead of merging into it."""
    return any(k in table for k in ("kind", "preset", "masses", "robot", "urdf"))


def _resolve(
    path: Path, seen: tuple[Path, ...] = ()
) -> tuple[dict[str, Any], dict[tuple[Any, ...], str]]:
    """Read ``path`` and the chain of files it extends; return the merged data and, for each key
    path, the file that set it."""
    real = path.resolve()
    if real in seen:
        chain = " -> ".join(p.name for p in (*seen, real))
        raise ConfigError(f"extends forms a cycle: {chain}", file=path, path="extends")
    data = _read_toml(path)
    origin: dict[tuple[Any, ...], str] = {}
    base_name = data.pop("extends", None)
    if base_name is None:
        for key in data:
            origin[(key,)] = str(path)
        return data, origin
    if not isinstance(base_name, str):
        raise ConfigError(
            f"must be a file name (a string), got {base_name!r}", file=path, path="extends"
        )
    base_path = _base_path(base_name, path)
    base, origin = _resolve(base_path, (*seen, real))
    for key in _OWN_KEYS:
        # the scenario is the extending file's: its name and description are its own
        base.pop(key, None)
        origin.pop((key,), None)
    return _merge(base, data, origin, str(path)), origin


#: Keys a file never inherits from the file it extends: they say which scenario it is.
_OWN_KEYS: tuple[str, ...] = ("name", "description")


def _base_path(base_name: str, path: Path) -> Path:
    """The file ``extends = base_name`` of ``path`` names: a file relative to ``path`` (or
    absolute), else the name of a shipped scenario (``"tanh"``, as ``slidingarm run tanh``)."""
    base_path = Path(base_name)
    if not base_path.is_absolute():
        base_path = path.parent / base_path
    if base_path.exists():
        # not only a regular file: the reader names what else it is (a FIFO, a device)
        return base_path
    shipped = _shipped_file(base_name)
    if shipped is not None:
        return shipped
    from slidingarm.study.shipped import SHIPPED

    raise ConfigError(
        f"base file {base_name!r} not found (looked for {base_path}; nor is it the name of a "
        f"shipped scenario: {', '.join(SHIPPED)})",
        file=path,
        path="extends",
    )


def _shipped_file(name: str) -> Path | None:
    """The file of shipped scenario ``name`` (or of the study's base, ``paper``), if it is one."""
    from slidingarm.study.shipped import BASE, SHIPPED, scenarios_dir

    stem = name[: -len(".toml")] if name.endswith(".toml") else name
    if stem in (*SHIPPED, BASE) and "/" not in stem and "\\" not in stem:
        return scenarios_dir() / f"{stem}.toml"
    return None


def load_scenario(path: str | Path) -> Scenario:
    """Read, merge (``extends``), validate and check a scenario file.

    Raises
    ------
    ConfigError
        One line: the file (and line for TOML syntax), the key path and what is allowed.
    """
    p = Path(path)
    data, origin = _resolve(p)
    return _validate(data, source=p, origin=origin)


def scenario_from_dict(
    data: Mapping[str, Any], *, source: str | Path | None = None, base_dir: str | Path | None = None
) -> Scenario:
    """Validate and check a scenario given as a mapping (as a TOML file would parse).

    ``extends`` is not resolved here; ``base_dir`` anchors a relative table ``path``
    (default: the directory of ``source``, else the current directory).
    """
    d = dict(data)
    if d.get("extends") is not None:
        raise ConfigError(
            "extends is resolved when reading files; load with load_scenario",
            file=source,
            path="extends",
        )
    src = None if source is None else Path(source)
    return _validate(d, source=src, origin={}, base_dir=base_dir)


def _validate(
    data: Mapping[str, Any],
    *,
    source: Path | None,
    origin: Mapping[tuple[Any, ...], str],
    base_dir: str | Path | None = None,
) -> Scenario:
    try:
        scenario = Scenario.model_validate(data)
    except ValidationError as exc:
        raise from_pydantic(exc, Scenario, source, origin) from None
    scenario._source = source
    scenario._origin = dict(origin)
    if base_dir is not None:
        scenario._base_dir = Path(base_dir)
    elif source is not None:
        scenario._base_dir = source.parent
    scenario.check()
    return scenario
