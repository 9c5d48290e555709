"""Error translation: :class:`ConfigError`, and a pydantic error turned into its one line.

Every error of a scenario file is one line naming the file, the key path
(``controllers[1].gamma``) and what is allowed (:mod:`slidingarm.config`).
"""

from __future__ import annotations

import difflib
import types
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Annotated, Any, Literal, Union, get_args, get_origin

from pydantic import BaseModel, ValidationError

from slidingarm._validate import is_real

__all__ = ["ConfigError", "from_pydantic", "literal_values", "tags"]


class ConfigError(ValueError):
    """An invalid scenario: one line naming the file, the key path and what is allowed.

    When a file has several errors, the message lists them all in one line,
    ``"3 errors: (1) <file>: <key>: <reason>; (2) ...; (3) ..."``, and :attr:`errors` holds each
    as its own :class:`ConfigError`; ``file``, ``path`` and ``reason`` are the first one's.

    Attributes
    ----------
    errors : tuple of ConfigError
        Every error found, this one first (just ``(self,)`` for a single error).
    file : str or None
        The file (or ``None`` for a scenario given as a mapping).
    path : str
        The key path, e.g. ``controllers[1].gamma`` (empty for the whole file).
    reason : str
        What is wrong and what is allowed.
    """

    def __init__(
        self,
        reason: str,
        *,
        file: str | Path | None = None,
        path: str = "",
        also: Sequence[ConfigError] = (),
    ) -> None:
        self.file = None if file is None else str(file)
        self.path = path
        self.reason = " ".join(str(reason).split())
        first = ": ".join(p for p in (self.file, self.path, self.reason) if p)
        self.errors: tuple[ConfigError, ...] = (self, *also)
        if also:
            lines = [first, *(str(e) for e in also)]
            listed = "; ".join(f"({i}) {line}" for i, line in enumerate(lines, start=1))
            super().__init__(f"{len(self.errors)} errors: {listed}")
        else:
            super().__init__(first)

    def __reduce__(self) -> tuple[Any, ...]:
        # rebuilt from its parts (the default would pass the message as the reason)
        return (_rebuild, (self.reason, self.file, self.path, self.errors[1:]))


def _rebuild(
    reason: str, file: str | None, path: str, also: Sequence[ConfigError]
) -> ConfigError:
    return ConfigError(reason, file=file, path=path, also=also)


def _unwrap(tp: Any) -> Any:
    while get_origin(tp) is Annotated:
        tp = get_args(tp)[0]
    return tp


def _union_members(tp: Any) -> list[Any]:
    tp = _unwrap(tp)
    if get_origin(tp) in (Union, types.UnionType):
        return [_unwrap(a) for a in get_args(tp)]
    return [tp]


def _is_model(tp: Any) -> bool:
    return isinstance(tp, type) and issubclass(tp, BaseModel)


def _tag(model: type[BaseModel]) -> str | None:
    field = model.model_fields.get("kind")
    if field is None:
        return None
    args = get_args(field.annotation)
    return str(args[0]) if args else None


def _locate(
    loc: Sequence[Any], root: type[BaseModel]
) -> tuple[str, type[BaseModel] | None, type[BaseModel] | None]:
    """Pretty key path of a pydantic ``loc`` under the model ``root`` (tags of tagged unions
    dropped), the model that holds its last key, and the model the path itself points at (if
    any)."""
    tp: Any = root
    parts: list[str] = []
    holder: type[BaseModel] | None = None
    for item in loc:
        members = [m for m in _union_members(tp) if m is not type(None)]
        models = [m for m in members if _is_model(m)]
        if isinstance(item, int):
            seq = [m for m in members if get_origin(m) in (list, tuple)]
            parts.append(f"[{item}]")
            tp = get_args(seq[0])[0] if seq else None
            continue
        if len(models) > 1:
            match = [m for m in models if _tag(m) == item]
            if match:
                tp = match[0]
                continue
        if len(models) == 1:
            holder = models[0]
            field = holder.model_fields.get(str(item))
            parts.append(("." if parts else "") + str(item))
            tp = field.annotation if field is not None else None
            continue
        # union member names ("float", "list[...]") and the like add nothing
        if tp is None:
            parts.append(("." if parts else "") + str(item))
    models = [m for m in _union_members(tp) if _is_model(m)]
    return "".join(parts), holder, models[0] if len(models) == 1 else None


def literal_values(tp: Any) -> list[Any]:
    values: list[Any] = []
    for member in _union_members(tp):
        if get_origin(member) is Literal:
            values += list(get_args(member))
    return values


def _allowed_keys(model: type[BaseModel] | None) -> list[str]:
    return [] if model is None else list(model.model_fields)


def from_pydantic(
    exc: ValidationError,
    root: type[BaseModel],
    source: Path | None,
    origin: Mapping[tuple[Any, ...], str],
) -> ConfigError:
    """Every error of ``exc`` (validating ``root``) as one :class:`ConfigError` that lists them
    all (:attr:`ConfigError.errors`); unknown keys first, since a misspelt key also makes the
    key it meant "missing".

    ``origin`` maps key paths to the file that set them (``extends``), so that an error is
    reported against the file that holds the bad value.
    """
    # an unknown key first: a misspelt key also makes the key it meant "missing"
    errors = sorted(exc.errors(include_url=False), key=lambda e: e["type"] != "extra_forbidden")
    found = [_one(err, root, source, origin) for err in errors]
    return ConfigError(found[0].reason, file=found[0].file, path=found[0].path, also=found[1:])


def _one(
    err: Any,
    root: type[BaseModel],
    source: Path | None,
    origin: Mapping[tuple[Any, ...], str],
) -> ConfigError:
    """One pydantic error as a :class:`ConfigError`."""
    loc = tuple(err["loc"])
    etype = err["type"]
    path, holder, _ = _locate(loc, root)
    value = err.get("input")
    msg = str(err["msg"])
    if etype == "extra_forbidden":
        _, _, parent = _locate(loc[:-1], root)
        allowed = _allowed_keys(parent)
        key = str(loc[-1])
        near = difflib.get_close_matches(key, allowed, n=1)
        hint = f" (did you mean {near[0]!r}?)" if near else ""
        reason = f"unknown key {key!r}{hint}; allowed keys: {', '.join(allowed)}"
    elif etype == "missing":
        reason = "missing required key"
        field = holder.model_fields.get(str(loc[-1])) if holder is not None else None
        if field is not None:
            choices = literal_values(field.annotation)
            if choices:
                reason += f"; one of {', '.join(repr(c) for c in choices)}"
            elif field.description:
                reason += f" ({field.description.rstrip('.')})"
    elif etype in ("union_tag_invalid", "union_tag_not_found"):
        ctx = err.get("ctx", {})
        tags = ctx.get("expected_tags", "")
        reason = f"kind must be one of {tags}" + (
            f", got {ctx.get('tag')!r}" if "tag" in ctx else ""
        )
        if etype == "union_tag_not_found":
            reason = f"needs a 'kind' key, one of {tags}"
    else:
        if msg.startswith("Value error, "):
            msg = msg[len("Value error, ") :]
        elif msg.startswith("Assertion failed, "):
            msg = msg[len("Assertion failed, ") :]
        else:
            msg = msg[0].lower() + msg[1:] if msg else msg
        shown = is_real(value) or isinstance(value, str | bool)
        reason = msg if ("got" in msg or not shown) else f"{msg}, got {value!r}"
    file: str | Path | None = source
    for n in range(len(loc), 0, -1):
        if loc[:n] in origin:
            file = origin[loc[:n]]
            break
    # a table both files contributed to is the extending file's responsibility
    if any(p[: len(loc)] == loc and f == str(source) for p, f in origin.items()):
        file = source
    if file is not None and source is not None and str(file) != str(source):
        reason += f" (set in {Path(file).name}, extended by {source.name})"
    return ConfigError(reason, file=file, path=path)


def tags(union: Any) -> list[str]:
    """The ``kind`` tags of a tagged union of models."""
    return [t for t in (_tag(m) for m in _union_members(union) if _is_model(m)) if t is not None]
