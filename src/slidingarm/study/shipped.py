"""The scenario files shipped with the package (SPEC §7): ``sign``, ``tanh``, ``noise``.

They live in ``slidingarm/study/scenarios/``. ``paper.toml`` is their common base — the arm,
reference, time grid, controllers and the shared gains with their reasons — and is not a
scenario by itself; ``sign.toml`` and ``tanh.toml`` extend it with a switching function, and
``noise.toml`` extends ``tanh.toml`` with a noisy sensor.
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path

from slidingarm.config import ConfigError, Scenario, load_scenario

__all__ = [
    "BASE",
    "SCENARIOS",
    "load_shipped",
    "resolve_scenario",
    "scenario_path",
    "scenarios_dir",
]

#: The study's scenarios, in the order of SPEC §7 (A, B, C).
SCENARIOS: tuple[str, ...] = ("sign", "tanh", "noise")

#: The base file the scenarios extend (not a scenario by itself).
BASE: str = "paper"


def scenarios_dir() -> Path:
    """The folder holding the shipped scenario files."""
    return Path(str(resources.files("slidingarm.study").joinpath("scenarios")))


def scenario_path(name: str) -> Path:
    """The file of shipped scenario ``name`` (one of :data:`SCENARIOS`)."""
    if name not in SCENARIOS:
        raise ConfigError(
            f"unknown shipped scenario {name!r}; the shipped scenarios are {', '.join(SCENARIOS)}"
        )
    return scenarios_dir() / f"{name}.toml"


def load_shipped(name: str) -> Scenario:
    """Load and validate shipped scenario ``name``."""
    return load_scenario(scenario_path(name))


def resolve_scenario(spec: str | Path) -> Scenario:
    """Load a scenario given as a file path or as the name of a shipped scenario.

    An existing file wins; otherwise a name in :data:`SCENARIOS` loads the shipped file (a
    folder of that name, such as a results folder, does not hide it).
    """
    path = Path(spec)
    try:
        is_file, exists = path.is_file(), path.exists()
    except OSError as exc:  # e.g. a name longer than the file system allows
        raise ConfigError(f"cannot be read ({exc.strerror or exc})", file=path) from None
    # only a file shadows a shipped name: `run sign --out .` makes a folder ./sign/
    if not is_file and str(spec) in SCENARIOS:
        return load_shipped(str(spec))
    if not exists:
        raise ConfigError(
            f"no such file (nor the name of a shipped scenario: {', '.join(SCENARIOS)})", file=path
        )
    return load_scenario(path)
