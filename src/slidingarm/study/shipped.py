"""The scenario files shipped with the package: the paper's study (docs/theory.md §7) ``sign``, ``tanh``,
``noise``, and the UR5's ``ur5`` and ``ur5_sign``.

They live in ``slidingarm/study/scenarios/``. ``paper.toml`` is the common base of the study —
the arm, reference, time grid, controllers and the shared gains with their reasons — and is not
a scenario by itself; ``sign.toml`` and ``tanh.toml`` extend it with a switching function, and
``noise.toml`` extends ``tanh.toml`` with a noisy sensor. ``ur5.toml`` is a complete scenario on
the shipped UR5 (tanh switching, an unknown payload) and ``ur5_sign.toml`` extends it with sign
switching. :func:`slidingarm.study.reproduce` runs the study's scenarios (:data:`SCENARIOS`);
``slidingarm run`` and ``validate`` take any of :data:`SHIPPED` by name.
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path

from slidingarm.config import ConfigError, Scenario, load_scenario

__all__ = [
    "BASE",
    "SCENARIOS",
    "SHIPPED",
    "load_shipped",
    "resolve_scenario",
    "scenario_path",
    "scenarios_dir",
]

#: The study's scenarios, in the order of docs/theory.md §7 (A, B, C): what ``reproduce`` runs.
SCENARIOS: tuple[str, ...] = ("sign", "tanh", "noise")

#: Every shipped scenario, by name: the study's and those beyond it (the UR5's, and
#: ``robust``, scenario B with the ``[sweep]`` of ``slidingarm sweep`` and ``compare``), in the
#: order ``slidingarm list`` shows them.
SHIPPED: tuple[str, ...] = (*SCENARIOS, "ur5", "ur5_sign", "robust")

#: The base file the scenarios extend (not a scenario by itself).
BASE: str = "paper"


def scenarios_dir() -> Path:
    """The folder holding the shipped scenario files."""
    return Path(str(resources.files("slidingarm.study").joinpath("scenarios")))


def scenario_path(name: str) -> Path:
    """The file of shipped scenario ``name`` (one of :data:`SHIPPED`)."""
    if name not in SHIPPED:
        raise ConfigError(
            f"unknown shipped scenario {name!r}; the shipped scenarios are {', '.join(SHIPPED)}"
        )
    return scenarios_dir() / f"{name}.toml"


def load_shipped(name: str) -> Scenario:
    """Load and validate shipped scenario ``name``."""
    return load_scenario(scenario_path(name))


def resolve_scenario(spec: str | Path) -> Scenario:
    """Load a scenario given as a file path or as the name of a shipped scenario.

    An existing file wins; otherwise a name in :data:`SHIPPED` loads the shipped file (a
    folder of that name, such as a results folder, does not hide it).
    """
    path = Path(spec)
    try:
        is_file, exists = path.is_file(), path.exists()
    except OSError as exc:  # e.g. a name longer than the file system allows
        raise ConfigError(f"cannot be read ({exc.strerror or exc})", file=path) from None
    # only a file shadows a shipped name: `run sign --out .` makes a folder ./sign/
    if not is_file and str(spec) in SHIPPED:
        return load_shipped(str(spec))
    if not exists:
        raise ConfigError(
            f"no such file (nor the name of a shipped scenario: {', '.join(SHIPPED)})", file=path
        )
    return load_scenario(path)
