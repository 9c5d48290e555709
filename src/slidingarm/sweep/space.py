"""What a sweep (or a tuning) varies: distributions over a scenario's numeric keys.

A scenario's numeric keys are named by their dotted paths, as in its file and in its errors:
``"gains.k"``, ``"mismatch.payload"``, ``"sensor.noise.sigma"``, ``"disturbances[0].amplitude"``,
``"controllers[2].k"``, ``"simulation.q0"`` (and one entry of a vector, ``"simulation.q0[1]"``).

- :class:`Distribution` -- ``uniform = [lo, hi]``, ``normal = [mu, sigma]``,
  ``loguniform = [lo, hi]`` (``lo > 0``), ``choice = [v1, v2, ...]``; with ``offset = true`` a
  draw is added to the scenario's own value instead of replacing it (an initial-state
  perturbation: ``"simulation.q0" = { normal = [0, 0.05], offset = true }``).
- :func:`apply` -- a new validated scenario with some keys set.
- :func:`numeric_keys` -- the keys a sweep or a tuning may vary.

**Per-joint keys.** A key whose value in the scenario is a list (one value per joint, such as
``simulation.q0`` or ``gains.k = [20, 20, 20]``) draws, from a scalar distribution, one value per
joint, independently. A key whose value is a scalar draws one value (shared by every joint it
applies to). To vary the joints of a scalar-valued key independently, write the key as a list in
the scenario (``k = [20.0, 20.0, 20.0]``); to vary one joint only, name the entry
(``"simulation.q0[0]"``).
"""

from __future__ import annotations

import math
import re
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
from numpy.typing import NDArray

from slidingarm._validate import is_real
from slidingarm.config.errors import ConfigError

if TYPE_CHECKING:
    from slidingarm.config.scenario import Scenario, Setup

__all__ = [
    "KINDS",
    "Distribution",
    "applied",
    "apply",
    "get_value",
    "is_fixed",
    "numeric_keys",
    "parse_key",
]

#: The distribution kinds and what their list holds.
KINDS: dict[str, str] = {
    "uniform": "[lo, hi], lo < hi: uniform on [lo, hi)",
    "normal": "[mu, sigma], sigma >= 0: normal with mean mu and standard deviation sigma",
    "loguniform": "[lo, hi], 0 < lo < hi: log(x) uniform on [log lo, log hi)",
    "choice": "[v1, v2, ...]: one of the values, each with the same probability",
}

Kind = Literal["uniform", "normal", "loguniform", "choice"]

#: Keys a sweep may not vary: every run of a batch shares the time grid and the reference
#: (:func:`slidingarm.simulate_batch`), and the sweep sets each run's seed itself.
FIXED_PREFIXES: tuple[str, ...] = (
    "reference",
    "simulation.t_final",
    "simulation.dt",
    "simulation.substeps",
    "simulation.seed",
    "sweep",
)


@dataclass(frozen=True)
class Distribution:
    """One key's distribution.

    Parameters
    ----------
    kind : {"uniform", "normal", "loguniform", "choice"}
        ``uniform``: :math:`x \\sim U[lo, hi)`; ``normal``: :math:`x \\sim N(\\mu, \\sigma^2)`;
        ``loguniform``: :math:`\\log x \\sim U[\\log lo, \\log hi)`; ``choice``: each of
        ``values`` with probability :math:`1/m`.
    values : sequence of float
        ``(lo, hi)``, ``(mu, sigma)``, ``(lo, hi)`` or the ``m`` choices.
    offset : bool
        Add the draw to the scenario's value (per joint for a vector) instead of replacing it.

    Raises
    ------
    ValueError
        For a kind that is not one of :data:`KINDS` or values that do not fit it.
    """

    kind: Kind
    values: tuple[float, ...]
    offset: bool = False

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ValueError(f"kind must be one of {', '.join(KINDS)}, got {self.kind!r}")
        if not isinstance(self.offset, bool):
            raise ValueError(f"offset must be true or false, got {self.offset!r}")
        vals = self.values
        if isinstance(vals, list | np.ndarray):
            vals = tuple(np.asarray(vals).tolist()) if isinstance(vals, np.ndarray) else tuple(vals)
        if not isinstance(vals, tuple) or not all(is_real(v, finite=True) for v in vals):
            raise ValueError(
                f"{self.kind} takes a list of finite numbers, {KINDS[self.kind]}; got {vals!r}"
            )
        object.__setattr__(self, "values", tuple(float(v) for v in vals))
        vals = self.values
        if self.kind == "choice":
            if len(vals) < 1:
                raise ValueError("choice takes a non-empty list of numbers [v1, v2, ...]")
            return
        if len(vals) != 2:
            raise ValueError(f"{self.kind} takes two numbers, {KINDS[self.kind]}; got {list(vals)}")
        a, b = vals
        if self.kind == "normal":
            if b < 0:
                raise ValueError(f"normal takes [mu, sigma] with sigma >= 0, got sigma = {b:g}")
        elif self.kind == "uniform":
            if not a < b:
                raise ValueError(f"uniform takes [lo, hi] with lo < hi, got [{a:g}, {b:g}]")
        elif not 0 < a < b:
            raise ValueError(f"loguniform takes [lo, hi] with 0 < lo < hi, got [{a:g}, {b:g}]")

    # ------------------------------------------------------------------ drawing
    def draw(self, rng: np.random.Generator, size: int | tuple[int, ...]) -> NDArray[np.float64]:
        """``size`` independent draws from ``rng`` (a float array of that shape)."""
        a = self.values
        if self.kind == "uniform":
            out = rng.uniform(a[0], a[1], size)
        elif self.kind == "normal":
            out = rng.normal(a[0], a[1], size)
        elif self.kind == "loguniform":
            out = np.exp(rng.uniform(math.log(a[0]), math.log(a[1]), size))
        else:
            out = np.asarray(a)[rng.integers(0, len(a), size)]
        return np.asarray(out, dtype=np.float64)

    def mean(self) -> float:
        """The distribution's mean (that of the draw; the offset is not added)."""
        a = self.values
        if self.kind == "uniform":
            return 0.5 * (a[0] + a[1])
        if self.kind == "normal":
            return a[0]
        if self.kind == "loguniform":
            return (a[1] - a[0]) / math.log(a[1] / a[0])
        return float(np.mean(a))

    def std(self) -> float:
        """The distribution's standard deviation."""
        a = self.values
        if self.kind == "uniform":
            return (a[1] - a[0]) / math.sqrt(12.0)
        if self.kind == "normal":
            return a[1]
        if self.kind == "loguniform":
            r = math.log(a[1] / a[0])
            second = (a[1] ** 2 - a[0] ** 2) / (2.0 * r)
            return math.sqrt(max(second - self.mean() ** 2, 0.0))
        return float(np.std(a))

    # ------------------------------------------------------------------ (de)serialising
    def to_dict(self) -> dict[str, Any]:
        """As a scenario's ``[sweep]`` writes it: ``{"uniform": [lo, hi]}`` (+ ``offset``)."""
        d: dict[str, Any] = {self.kind: list(self.values)}
        if self.offset:
            d["offset"] = True
        return d

    def __str__(self) -> str:
        text = f"{self.kind}({', '.join(f'{v:g}' for v in self.values)})"
        return f"+{text}" if self.offset else text

    @classmethod
    def from_spec(cls, key: str, spec: Any) -> Distribution:
        """From a ``[sweep]`` entry: ``{ uniform = [lo, hi] }`` (one kind), optionally with
        ``offset = true``.

        Raises
        ------
        ConfigError
            Naming ``sweep."<key>"`` and what is allowed.
        """
        where = f'sweep."{key}"'
        if isinstance(spec, Distribution):
            return spec
        if not isinstance(spec, Mapping):
            raise ConfigError(
                f"must be a table with one of {', '.join(KINDS)} (e.g. {{ uniform = [0, 1] }}), "
                f"got {spec!r}",
                path=where,
            )
        extra = [k for k in spec if k not in KINDS and k != "offset"]
        if extra:
            raise ConfigError(
                f"unknown key {extra[0]!r}; allowed keys: {', '.join(KINDS)}, offset", path=where
            )
        kinds = [k for k in spec if k in KINDS]
        if len(kinds) != 1:
            got = f"got {', '.join(kinds)}" if kinds else "got none"
            raise ConfigError(f"needs exactly one of {', '.join(KINDS)} ({got})", path=where)
        kind = kinds[0]
        values = spec[kind]
        offset = spec.get("offset", False)
        if not isinstance(offset, bool):
            raise ConfigError(f"must be true or false, got {offset!r}", path=f"{where}.offset")
        if not isinstance(values, list | tuple):
            raise ConfigError(
                f"must be a list of numbers, {KINDS[kind]}; got {values!r}", path=f"{where}.{kind}"
            )
        try:
            return cls(kind, tuple(values), offset=offset)
        except ValueError as exc:
            raise ConfigError(str(exc), path=f"{where}.{kind}") from None

    @classmethod
    def parse(cls, key: str, text: str) -> Distribution:
        """From the command line's ``uniform(10, 40)``, ``+normal(0, 0.05)`` (an offset) or a
        TOML inline table ``{ normal = [0, 0.05], offset = true }``.

        Raises
        ------
        ConfigError
            Naming ``--vary <key>`` and what is allowed.
        """
        where = f"--vary {key}"
        s = text.strip()
        if s.startswith("{"):
            try:
                spec = tomllib.loads(f"x = {s}")["x"]
            except tomllib.TOMLDecodeError as exc:
                raise ConfigError(f"invalid TOML inline table {s!r}: {exc}", path=where) from None
            try:
                return cls.from_spec(key, spec)
            except ConfigError as exc:
                raise ConfigError(exc.reason, path=where) from None
        offset = s.startswith("+")
        m = re.fullmatch(r"\+?\s*([a-z]+)\s*\((.*)\)", s)
        if m is None or m.group(1) not in KINDS:
            raise ConfigError(
                f"must be KIND(a, b, ...) with KIND one of {', '.join(KINDS)} (a leading + adds "
                f"it to the scenario's value), e.g. uniform(10, 40); got {text!r}",
                path=where,
            )
        try:
            values = tuple(float(v) for v in m.group(2).split(",") if v.strip())
        except ValueError:
            raise ConfigError(
                f"{m.group(1)} takes numbers, {KINDS[m.group(1)]}; got {text!r}", path=where
            ) from None
        try:
            return cls(m.group(1), values, offset=offset)  # type: ignore[arg-type]
        except ValueError as exc:
            raise ConfigError(str(exc), path=where) from None


# --------------------------------------------------------------------------------------------
# dotted keys

_PART = re.compile(r"([A-Za-z_][A-Za-z0-9_]*)((?:\[\d+\])*)")


def parse_key(key: str) -> list[str | int]:
    """``"disturbances[0].amplitude"`` as ``["disturbances", 0, "amplitude"]``.

    Raises
    ------
    ConfigError
        For a key that is not of the form ``name[.name][index]...``.
    """
    if not isinstance(key, str) or not key:
        raise ConfigError(f"a key must be a dotted path such as 'gains.k', got {key!r}", path="")
    parts: list[str | int] = []
    for piece in key.split("."):
        m = _PART.fullmatch(piece)
        if m is None:
            raise ConfigError(
                "is not a dotted key path (e.g. gains.k, disturbances[0].amplitude, "
                "simulation.q0[1])",
                path=key,
            )
        parts.append(m.group(1))
        parts += [int(i) for i in re.findall(r"\[(\d+)\]", m.group(2))]
    return parts


def _is_number(v: Any) -> bool:
    return is_real(v, finite=True)


def _is_numeric(v: Any) -> bool:
    return _is_number(v) or (isinstance(v, list) and len(v) > 0 and all(_is_number(x) for x in v))


def _walk(data: Any, key: str, parts: list[str | int]) -> tuple[Any, str | int]:
    """The container holding ``parts[-1]`` in ``data``, and that last part; an error names
    the first part that does not exist."""
    node = data
    done = ""
    for i, part in enumerate(parts[:-1]):
        here = done + (f"[{part}]" if isinstance(part, int) else ("." if done else "") + part)
        if isinstance(part, int):
            if not isinstance(node, list) or part >= len(node):
                size = len(node) if isinstance(node, list) else 0
                raise ConfigError(f"no such key: {done} has {size} entries", path=key)
            node = node[part]
        else:
            if not isinstance(node, dict) or part not in node:
                raise ConfigError(
                    f"no such key: {here} is not set in this scenario (numeric keys: "
                    f"{_hint(data, parts[: i + 1])})",
                    path=key,
                )
            node = node[part]
        done = here
    return node, parts[-1]


def _hint(data: Any, prefix: list[str | int]) -> str:
    keys = [k for k in _leaves(data) if not _fixed(k)]
    head = str(prefix[0])
    near = [k for k in keys if k.split(".")[0].split("[")[0] == head]
    if not near:
        return f"none under {head}; " + ", ".join(keys[:8]) + (", ..." if len(keys) > 8 else "")
    return ", ".join(near[:8]) + (", ..." if len(near) > 8 else "")


def _leaves(data: Any, prefix: str = "") -> list[str]:
    """Dotted keys of the float (or float-list) leaves of ``data``."""
    out: list[str] = []
    if isinstance(data, dict):
        for k, v in data.items():
            out += _leaves(v, f"{prefix}.{k}" if prefix else str(k))
    elif isinstance(data, list) and data and not all(_is_number(x) for x in data):
        for i, v in enumerate(data):
            out += _leaves(v, f"{prefix}[{i}]")
    elif _is_numeric(data) and _floats(data):
        out.append(prefix)
    return out


def _floats(v: Any) -> bool:
    """Float-typed (an int in the dump is an integer key: seed, substeps, p, q, joint)."""
    items = v if isinstance(v, list) else [v]
    return all(isinstance(x, float) for x in items)


def get_value(scenario: Scenario | Mapping[str, Any], key: str) -> Any:
    """The value at ``key`` of a scenario (or its :meth:`~Scenario.to_dict`).

    Raises
    ------
    ConfigError
        Naming ``key`` if it is not set.
    """
    data = scenario if isinstance(scenario, Mapping) else scenario.to_dict()
    parts = parse_key(key)
    node, last = _walk(data, key, parts)
    if isinstance(last, int):
        if not isinstance(node, list) or last >= len(node):
            raise ConfigError("no such key: index out of range", path=key)
        return node[last]
    if not isinstance(node, dict) or last not in node:
        raise ConfigError("no such key (not set in this scenario)", path=key)
    return node[last]


def _set(data: dict[str, Any], key: str, value: Any) -> None:
    parts = parse_key(key)
    node, last = _walk(data, key, parts)
    if isinstance(last, int):
        if not isinstance(node, list) or last >= len(node):
            size = len(node) if isinstance(node, list) else 0
            raise ConfigError(f"no such key: index {last} of a value with {size} entries", path=key)
        old = node[last]
    elif isinstance(node, dict):
        old = node.get(last)
        if old is None and not _may_add(parts):
            raise ConfigError(
                f"no such key: {last!r} is not set here (numeric keys: {_hint(data, parts)})",
                path=key,
            )
    else:
        raise ConfigError("no such key: its parent is not a table", path=key)
    if isinstance(old, dict):
        raise ConfigError(
            f"is a table, not a number (numeric keys: {_hint(data, parts)})", path=key
        )
    if old is not None and not _is_numeric(old):
        shown = repr(old) if len(repr(old)) <= 40 else repr(old)[:37] + "..."
        raise ConfigError(f"is not a numeric key (its value is {shown})", path=key)
    if old is not None and not _floats(old):
        raise ConfigError(
            f"is an integer key (its value is {old!r}); a sweep varies real numbers", path=key
        )
    node[last] = value


def _may_add(parts: list[str | int]) -> bool:
    """A controller's gain override may be set where the controller inherits the shared
    gain (``controllers[2].k``)."""
    from slidingarm.config.specs import _GainFields

    return (
        len(parts) == 3
        and parts[0] == "controllers"
        and isinstance(parts[2], str)
        and parts[2] in _GainFields.model_fields
        and parts[2] not in ("p", "q")
    )


def _plain(value: Any) -> Any:
    if isinstance(value, np.ndarray):
        return [float(v) for v in value.reshape(-1)] if value.ndim else float(value)
    if isinstance(value, list | tuple):
        return [float(v) if is_real(v) else v for v in value]
    if isinstance(value, np.generic):
        return value.item()
    return value


def apply(scenario: Scenario, values: Mapping[str, Any]) -> Scenario:
    """A new, validated and checked scenario with the dotted ``values`` set.

    Parameters
    ----------
    scenario : Scenario
    values : mapping of dotted key to value
        A number for a scalar key, one number per joint (a list or array) for a vector key
        (a number is allowed where the scenario allows a scalar or per-joint value).

    Returns
    -------
    Scenario
        As ``scenario_from_dict(scenario.to_dict() with the values set)``, relative table and
        URDF paths still anchored where the scenario's were.

    Raises
    ------
    ConfigError
        Naming the key if it does not exist in the scenario, is not numeric, or the value is
        refused by the scenario's validation.
    """
    return applied(scenario, values)[0]


def applied(scenario: Scenario, values: Mapping[str, Any]) -> tuple[Scenario, Setup]:
    """:func:`apply` and the new scenario's :meth:`~Scenario.build`, built once (validating
    a scenario builds it)."""
    data = scenario.to_dict()
    for key, value in values.items():
        if key.split(".")[0].split("[")[0] == "sweep":
            raise ConfigError("the [sweep] table is not a scenario value", path=key)
        _set(data, key, _plain(value))
    return validated(scenario, data, values)


def validated(
    scenario: Scenario, data: dict[str, Any], values: Mapping[str, Any]
) -> tuple[Scenario, Setup]:
    """``data`` (``scenario.to_dict()`` with ``values`` set) validated and built as
    :func:`slidingarm.config.scenario_from_dict` does, anchored where ``scenario`` is; an
    error names the key of ``values`` it is about."""
    from pydantic import ValidationError

    from slidingarm.config.errors import from_pydantic
    from slidingarm.config.scenario import Scenario as ScenarioModel

    source = scenario.source
    try:
        try:
            out = ScenarioModel.model_validate(data)
        except ValidationError as exc:
            raise from_pydantic(exc, ScenarioModel, source, {}) from None
        out._source = source
        out._origin = dict(scenario._origin)
        out._base_dir = scenario._base_dir
        setup = out.build()
    except ConfigError as exc:
        key = _blame(exc.path, values)
        where = "" if exc.path in (key, "") else f"{exc.path}: "
        shown = _plain(values[key]) if key in values else None
        raise ConfigError(
            f"value {shown!r} refused: {where}{exc.reason}", file=source, path=key
        ) from None
    return out, setup


def _blame(path: str, values: Mapping[str, Any]) -> str:
    """The key of ``values`` an error at ``path`` is about (the longest common prefix)."""
    if path in values:
        return path
    best, score = next(iter(values), path), -1
    for key in values:
        common = 0
        for a, b in zip(key, path, strict=False):
            if a != b:
                break
            common += 1
        if common > score:
            best, score = key, common
    return best


def numeric_keys(scenario: Scenario, *, overrides: bool = False) -> list[str]:
    """The dotted keys a sweep (or a tuning) may vary: every real-valued key set in the
    scenario (scalars and per-joint vectors), except the time grid, the reference (every run of
    a batch shares them), the seed (the sweep draws it) and integer keys (``p``, ``q``,
    ``substeps``, a fault's ``joint``).

    Parameters
    ----------
    overrides : bool
        Also list each controller's real-valued gains that it inherits from ``[gains]``
        (``controllers[2].k``), which :func:`apply` may set.
    """
    data = scenario.to_dict()
    keys = [k for k in _leaves(data) if not _fixed(k)]
    if overrides:
        for i, spec in enumerate(scenario.controllers):
            used = scenario.controller_gains(i)
            for name in ("alpha", "lam", "beta", "gamma", "k", "width", "k2", "eps_e"):
                target = name
                if name in ("alpha", "lam"):
                    if not any(n in used for n in ("alpha", "lam")):
                        continue
                    if name == "lam":
                        continue
                    target = "lam" if spec.lam is not None else "alpha"
                elif name not in used or not _is_numeric(used[name]) or isinstance(used[name], int):
                    continue
                key = f"controllers[{i}].{target}"
                if key not in keys:
                    keys.append(key)
    return keys


def _fixed(key: str) -> bool:
    return any(
        key == p or key.startswith(p + ".") or key.startswith(p + "[") for p in FIXED_PREFIXES
    )


def is_fixed(key: str) -> bool:
    """Whether ``key`` is one a sweep may not vary (:data:`FIXED_PREFIXES`)."""
    return _fixed(key)
