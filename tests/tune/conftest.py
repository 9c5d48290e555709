"""Shared fixtures of the tuning tests: short scenarios, so that a trial costs milliseconds."""

from __future__ import annotations

from pathlib import Path

import pytest

from slidingarm.config import Scenario, load_scenario
from slidingarm.study import scenario_path

SHORT = """
extends = "{base}"
name = "short"

[simulation]
t_final = {t_final}
"""


def short_scenario(tmp_path: Path, base: str = "sign", t_final: float = 0.3) -> Path:
    """A shipped scenario cut to ``t_final`` seconds, as a file in ``tmp_path``."""
    p = tmp_path / f"short_{base}.toml"
    p.write_text(
        SHORT.format(base=scenario_path(base).as_posix(), t_final=t_final), encoding="utf-8"
    )
    return p


@pytest.fixture
def make_short(tmp_path: Path):  # type: ignore[no-untyped-def]
    """``make_short(base="sign", t_final=0.3)``: a shipped scenario cut short, as a file."""

    def make(base: str = "sign", t_final: float = 0.3) -> Path:
        return short_scenario(tmp_path, base, t_final)

    return make


@pytest.fixture
def short_file(tmp_path: Path) -> Path:
    """The sign scenario cut to 0.3 s."""
    return short_scenario(tmp_path)


@pytest.fixture
def short(short_file: Path) -> Scenario:
    return load_scenario(short_file)
