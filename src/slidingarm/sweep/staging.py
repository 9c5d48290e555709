"""Staging a sweep's runs: each draw's values and seed, and the library objects of its run.

Draw ``i`` of a sweep with seed ``S`` depends only on ``(S, i)``: key ``k`` draws from
``numpy.random.SeedSequence(S, spawn_key=(i, 1, crc32(k)))`` and the run's own seed (its noise
and random disturbances) is the first 32-bit word of ``SeedSequence(S, spawn_key=(i, 0))``.
So a draw does not depend on the chunk it falls in, on the number of workers, nor on the other
keys of the sweep (adding a key leaves the other keys' draws as they were).

Building a scenario per draw (validate everything, build every component) costs about 2 ms;
:class:`Stager` validates only what a draw changes and rebuilds only the components that
depend on it (``mismatch`` the plant, ``sensor`` the sensor, ``disturbances`` the
disturbances, ``gains`` and ``controllers`` the controllers, ``simulation`` the initial state
and torque limit), which gives the same objects as :func:`~slidingarm.sweep.space.applied`
(a test checks it); anything else (``plant``, or an initial state of a serial arm, whose limits
are checked against the reference) takes the full path. A key that names a field of a table
(``gains.k``, ``mismatch.payload``, ``controllers[2].k``, ``simulation.q0[1]``) is validated
alone, by that field's own type and rules, on a copy of the validated table (the table's
after-validators run on the copy): the rules a full validation applies to it, unless a field
validator of the table could read it (a validator of that field or of a later one sees the
earlier fields), in which case the whole table is validated again. A draw the fast path
refuses takes the full path, whose error names the key and says why.
"""

from __future__ import annotations

import copy
import dataclasses
import inspect
import zlib
from collections.abc import Mapping, Sequence
from functools import lru_cache, partial
from typing import TYPE_CHECKING, Annotated, Any

import numpy as np
from pydantic import BaseModel, TypeAdapter, ValidationError

from slidingarm.config.errors import ConfigError
from slidingarm.config.specs import (
    _CONTROLLER_CLASSES,
    ControllerSpec,
    DisturbanceSpec,
    GainsSpec,
    MismatchSpec,
    SensorSpec,
    SimulationSpec,
    _build_disturbance,
    _tuple,
)
from slidingarm.models.serial import SerialArm
from slidingarm.sweep._seeding import pcg64_states, spawned_words
from slidingarm.sweep.space import (
    Distribution,
    _is_numeric,
    _plain,
    _set,
    applied,
    get_value,
    is_fixed,
    parse_key,
)

if TYPE_CHECKING:
    from slidingarm.config.scenario import Scenario, Setup

__all__ = [
    "Stager", "check_keys", "draw_run", "draw_runs", "key_shapes", "run_seed", "run_seeds",
]  # fmt: skip

_DISTURBANCE: TypeAdapter[Any] = TypeAdapter(DisturbanceSpec)

#: The tables :class:`Stager` rebuilds alone.
FAST_SECTIONS = frozenset(
    {"mismatch", "sensor", "disturbances", "gains", "controllers", "simulation"}
)


def check_keys(scenario: Scenario, distributions: Mapping[str, Distribution]) -> None:
    """Each key exists, is real-valued and may vary in a sweep; an offset has a value to add
    to.

    Raises
    ------
    ConfigError
        Naming the key.
    """
    data = scenario.to_dict()
    for key, dist in distributions.items():
        parse_key(key)
        if is_fixed(key):
            raise ConfigError(
                "cannot vary in a sweep: every run of a batch shares the time grid, the "
                "reference and the sweep's own seeds",
                path=key,
            )
        try:
            base = get_value(data, key)
        except ConfigError:
            base = None
        if dist.offset and base is None:
            raise ConfigError(
                "offset = true adds the draw to the scenario's value, but the key is not set "
                "in the scenario",
                path=key,
            )
        probe = copy.deepcopy(data)
        _set(probe, key, base if base is not None else 1.0)


def key_shapes(scenario: Scenario, distributions: Mapping[str, Distribution]) -> dict[str, int]:
    """Per key, the number of values a draw has: the length of a per-joint (list) value in
    the scenario, else 0 (a scalar)."""
    data = scenario.to_dict()
    out: dict[str, int] = {}
    for key in distributions:
        try:
            base = get_value(data, key)
        except ConfigError:
            base = None
        out[key] = len(base) if isinstance(base, list) else 0
    return out


def run_seeds(seed: int, runs: Sequence[int]) -> list[int]:
    """The seed of each run ``i`` of ``runs`` (its sensor noise and random disturbances):
    ``SeedSequence(seed, spawn_key=(i, 0)).generate_state(1)[0]``."""
    keys = np.array([[i, 0] for i in runs], dtype=np.int64).reshape(-1, 2)
    return [int(v) for v in spawned_words(seed, keys, 1)[:, 0]]


def run_seed(seed: int, i: int) -> int:
    """The seed of run ``i`` (:func:`run_seeds`)."""
    return run_seeds(seed, [i])[0]


def _key_id(key: str) -> int:
    return zlib.crc32(key.encode("utf-8"))


def draw_runs(
    seed: int,
    runs: Sequence[int],
    distributions: Mapping[str, Distribution],
    shapes: Mapping[str, int],
    bases: Mapping[str, Any],
) -> list[dict[str, float | list[float]]]:
    """The values of each draw ``i`` of ``runs``: per key a number, or one per joint
    (``shapes[key] > 0``), drawn by ``Generator(PCG64(SeedSequence(seed, spawn_key=(i, 1,
    crc32(key)))))``; an offset distribution's draw is added to ``bases[key]``.

    The generators' states come from :mod:`slidingarm.sweep._seeding` for all draws and keys
    at once (numpy's seeding, bit for bit, about 5x cheaper than a ``SeedSequence`` each); one
    generator is set to each state in turn."""
    keys = list(distributions)
    index = np.array([[i, 1, _key_id(k)] for i in runs for k in keys], dtype=np.int64)
    states: list[Any] = pcg64_states(spawned_words(seed, index.reshape(-1, 3), 8))
    bitgen = np.random.PCG64(0)
    rng = np.random.Generator(bitgen)
    out: list[dict[str, float | list[float]]] = []
    at = 0
    for _ in runs:
        values: dict[str, float | list[float]] = {}
        for key in keys:
            dist = distributions[key]
            bitgen.state = states[at]
            at += 1
            n = shapes[key]
            x = dist.draw(rng, n if n else 1)
            if dist.offset:
                x = x + np.asarray(bases[key], dtype=float)
            values[key] = [float(v) for v in x] if n else float(x[0])
        out.append(values)
    return out


def draw_run(
    seed: int,
    i: int,
    distributions: Mapping[str, Distribution],
    shapes: Mapping[str, int],
    bases: Mapping[str, Any],
) -> dict[str, float | list[float]]:
    """The values of draw ``i`` (:func:`draw_runs`)."""
    return draw_runs(seed, [i], distributions, shapes, bases)[0]


@lru_cache(maxsize=256)
def _field_adapter(model: type[BaseModel], name: str) -> TypeAdapter[Any] | None:
    """The validator of field ``name`` of ``model`` alone, or ``None`` where validating it
    alone could differ from validating the whole model: a field validator on it or on a later
    field (pydantic hands a field validator the fields before it), a model validator other
    than a plain ``after`` one, a discriminated field, or a model config beyond ``extra`` and
    ``frozen``."""
    fields = list(model.model_fields)
    if name not in fields or set(model.model_config) - {"extra", "frozen"}:
        return None
    decorators = model.__pydantic_decorators__
    later = set(fields[fields.index(name) :]) | {"*"}
    for fdec in decorators.field_validators.values():
        if later & set(fdec.info.fields):
            return None
    for mdec in decorators.model_validators.values():
        if mdec.info.mode != "after" or len(inspect.signature(mdec.func).parameters) != 1:
            return None
    info = model.model_fields[name]
    if info.discriminator is not None:
        return None
    if not info.metadata:
        return TypeAdapter(info.annotation)
    return TypeAdapter(Annotated[info.annotation, *info.metadata])


def _after_validators(model: BaseModel) -> BaseModel:
    """``model`` through its class's ``after`` model validators (which raise ValueError)."""
    for dec in type(model).__pydantic_decorators__.model_validators.values():
        out = dec.func(model)
        if isinstance(out, type(model)):
            model = out
    return model


#: A key a table's field validator takes alone: (section, index in a list section or None,
#: field, index in the field's list or None).
Route = tuple[str, int | None, str, int | None]


class Stager:
    """Builds the :class:`~slidingarm.config.Setup` of a draw from a base scenario,
    rebuilding only what the draw changes.

    Parameters
    ----------
    scenario : Scenario
        The base scenario (validated and checked).
    """

    def __init__(self, scenario: Scenario) -> None:
        self.scenario = scenario
        self.data = scenario.to_dict()
        self.setup = scenario.build()
        self.serial = isinstance(self.setup.nominal, SerialArm)
        self._sections: dict[str, str] = {}
        self._routes: dict[str, Route | None] = {}

    def bases(self, keys: Mapping[str, Any]) -> dict[str, Any]:
        """The scenario's value of each key (``None`` where unset)."""
        out: dict[str, Any] = {}
        for key in keys:
            try:
                out[key] = get_value(self.data, key)
            except ConfigError:
                out[key] = None
        return out

    def build(self, values: Mapping[str, Any]) -> Setup:
        """The setup of the scenario with ``values`` set.

        Raises
        ------
        ConfigError
            Naming the key whose value the scenario refuses (as :func:`apply`).
        """
        sections = {self._section(k) for k in values}
        fast = sections <= FAST_SECTIONS and not (self.serial and "simulation" in sections)
        if fast:
            try:
                return self._fast(values, sections)
            except (ConfigError, ValidationError, ValueError, TypeError):
                pass  # the full path names the key and says why
        return applied(self.scenario, values)[1]

    def _section(self, key: str) -> str:
        sec = self._sections.get(key)
        if sec is None:
            sec = self._sections[key] = str(parse_key(key)[0])
        return sec

    def _route(self, key: str) -> Route | None:
        """How ``key`` is validated alone, or ``None`` (its whole table is validated)."""
        if key in self._routes:
            return self._routes[key]
        parts = parse_key(key)
        route: Route | None = None
        sec, rest = str(parts[0]), parts[1:]
        index: int | None = None
        if rest and isinstance(rest[0], int):
            index, rest = rest[0], rest[1:]
        field = rest[0] if rest else None
        entry = rest[1] if len(rest) == 2 else None
        if isinstance(field, str) and len(rest) <= 2 and (entry is None or isinstance(entry, int)):
            assert entry is None or isinstance(entry, int)
            node = getattr(self.scenario, sec, None)
            if index is not None:
                node = node[index] if isinstance(node, list) and index < len(node) else None
            if isinstance(node, BaseModel) and _field_adapter(type(node), field) is not None:
                route = (sec, index, field, entry)
        self._routes[key] = route
        return route

    def _table(self, sec: str, keys: list[str], values: Mapping[str, Any]) -> Any:
        """Section ``sec`` of the scenario with ``keys`` set to their ``values``, validated."""
        routes = [self._route(k) for k in keys]
        if not all(routes):
            data = copy.deepcopy(self.data[sec])
            holder = {sec: data}
            for key in keys:
                _set(holder, key, values[key])
            if sec == "disturbances":
                return [_DISTURBANCE.validate_python(d) for d in data]
            if sec == "controllers":
                return [ControllerSpec.model_validate(c) for c in data]
            return _SPECS[sec].model_validate(data)
        current = getattr(self.scenario, sec)
        changes: dict[int | None, dict[str, Any]] = {}
        for key, route in zip(keys, routes, strict=True):
            assert route is not None
            _, index, field, entry = route
            mine = changes.setdefault(index, {})
            value = _plain(values[key])
            if entry is not None:
                model = current if index is None else current[index]
                whole = list(mine.get(field, getattr(model, field)))
                whole[entry] = value  # an IndexError or TypeError: the full path says why
                value = whole
            mine[field] = value
        out = list(current) if isinstance(current, list) else current
        for index, fields in changes.items():
            model = current if index is None else current[index]
            kind: type[BaseModel] = type(model)
            update = {}
            for field, raw in fields.items():
                adapter = _field_adapter(kind, field)
                assert adapter is not None
                update[field] = adapter.validate_python(raw)
            new = _after_validators(model.model_copy(update=update))
            if index is None:
                out = new
            else:
                out[index] = new
        return out

    def _fast(self, values: Mapping[str, Any], sections: set[str]) -> Setup:
        by_section: dict[str, list[str]] = {}
        for key in values:
            by_section.setdefault(self._section(key), []).append(key)
        update = {sec: self._table(sec, keys, values) for sec, keys in by_section.items()}
        sc = self.scenario.model_copy(update=update)
        base = self.setup
        sc._check_lengths(base.nominal.n)
        changed: dict[str, Any] = {}
        if "mismatch" in sections:
            changed["plant"] = sc._build_mismatch(base.nominal)
        if "sensor" in sections:
            changed["sensor"] = sc._guard("sensor", sc.sensor.build)
        if "disturbances" in sections:
            changed["disturbances"] = tuple(
                sc._guard(f"disturbances[{i}]", partial(_build_disturbance, d))
                for i, d in enumerate(sc.disturbances)
            )
        if sections & {"gains", "controllers"}:
            ctrls = {}
            for i, spec in enumerate(sc.controllers):
                kwargs = sc.controller_gains(i)
                cls = _CONTROLLER_CLASSES[spec.name]
                ctrls[spec.key] = sc._guard(
                    f"controllers[{i}]", partial(cls, base.nominal, **kwargs)
                )
            changed["controllers"] = ctrls
        if "simulation" in sections:
            sim = sc.simulation
            changed["q0"] = tuple(sim.q0)
            changed["qd0"] = None if sim.qd0 is None else tuple(sim.qd0)
            changed["torque_limit"] = (
                _tuple(sim.torque_limit) if sim.torque_limit is not None else None
            )
        return dataclasses.replace(base, **changed)


#: The model of each table section (the list sections are validated entry by entry).
_SPECS: dict[str, type[BaseModel]] = {
    "mismatch": MismatchSpec,
    "sensor": SensorSpec,
    "gains": GainsSpec,
    "simulation": SimulationSpec,
}


def columns_of(values: Mapping[str, Any]) -> dict[str, float]:
    """The table columns of a draw: ``key`` for a scalar, ``key[j]`` (from 0) per joint."""
    out: dict[str, float] = {}
    for key, v in values.items():
        if isinstance(v, list):
            for j, x in enumerate(v):
                out[f"{key}[{j}]"] = float(x)
        elif _is_numeric(v):
            out[key] = float(v)
    return out
