"""Staging a sweep's runs: each draw's values and seed, and the library objects of its run.

Draw ``i`` of a sweep with seed ``S`` depends only on ``(S, i)``: key ``k`` draws from
``numpy.random.SeedSequence(S, spawn_key=(i, 1, crc32(k)))`` and the run's own seed (its noise
and random disturbances) is the first 32-bit word of ``SeedSequence(S, spawn_key=(i, 0))``.
So a draw does not depend on the chunk it falls in, on the number of workers, nor on the other
keys of the sweep (adding a key leaves the other keys' draws as they were).

Building a scenario per draw (validate everything, build every component) costs about 2 ms;
:class:`Stager` validates only the tables a draw changes and rebuilds only the components that
depend on them (``mismatch`` the plant, ``sensor`` the sensor, ``disturbances`` the
disturbances, ``gains`` and ``controllers`` the controllers, ``simulation`` the initial state
and torque limit), which gives the same objects as :func:`~slidingarm.sweep.space.applied`
(a test checks it); anything else (``plant``, or an initial state of a serial arm, whose limits
are checked against the reference) takes the full path.
"""

from __future__ import annotations

import copy
import dataclasses
import zlib
from collections.abc import Mapping
from functools import partial
from typing import TYPE_CHECKING, Any

import numpy as np
from pydantic import TypeAdapter, ValidationError

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
from slidingarm.sweep.space import (
    Distribution,
    _is_numeric,
    _set,
    applied,
    get_value,
    is_fixed,
    parse_key,
)

if TYPE_CHECKING:
    from slidingarm.config.scenario import Scenario, Setup

__all__ = ["Stager", "check_keys", "draw_run", "key_shapes", "run_seed"]

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


def run_seed(seed: int, i: int) -> int:
    """The seed of run ``i`` (its sensor noise and random disturbances)."""
    return int(np.random.SeedSequence(seed, spawn_key=(i, 0)).generate_state(1)[0])


def _key_id(key: str) -> int:
    return zlib.crc32(key.encode("utf-8"))


def draw_run(
    seed: int,
    i: int,
    distributions: Mapping[str, Distribution],
    shapes: Mapping[str, int],
    bases: Mapping[str, Any],
) -> dict[str, float | list[float]]:
    """The values of draw ``i``: per key a number, or one per joint (``shapes[key] > 0``);
    an offset distribution's draw is added to ``bases[key]``."""
    out: dict[str, float | list[float]] = {}
    for key, dist in distributions.items():
        rng = np.random.Generator(
            np.random.PCG64(np.random.SeedSequence(seed, spawn_key=(i, 1, _key_id(key))))
        )
        n = shapes[key]
        x = dist.draw(rng, n if n else 1)
        if dist.offset:
            x = x + np.asarray(bases[key], dtype=float)
        out[key] = [float(v) for v in x] if n else float(x[0])
    return out


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
        sections = {str(parse_key(k)[0]) for k in values}
        fast = sections <= FAST_SECTIONS and not (self.serial and "simulation" in sections)
        if fast:
            try:
                return self._fast(values, sections)
            except (ConfigError, ValidationError, ValueError):
                pass  # the full path names the key and says why
        return applied(self.scenario, values)[1]

    def _fast(self, values: Mapping[str, Any], sections: set[str]) -> Setup:
        data = dict(self.data)
        for sec in sections:
            data[sec] = copy.deepcopy(self.data[sec])
        for key, value in values.items():
            _set(data, key, value)
        update: dict[str, Any] = {}
        if "mismatch" in sections:
            update["mismatch"] = MismatchSpec.model_validate(data["mismatch"])
        if "sensor" in sections:
            update["sensor"] = SensorSpec.model_validate(data["sensor"])
        if "disturbances" in sections:
            update["disturbances"] = [_DISTURBANCE.validate_python(d) for d in data["disturbances"]]
        if "gains" in sections:
            update["gains"] = GainsSpec.model_validate(data["gains"])
        if "controllers" in sections:
            update["controllers"] = [ControllerSpec.model_validate(c) for c in data["controllers"]]
        if "simulation" in sections:
            update["simulation"] = SimulationSpec.model_validate(data["simulation"])
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
