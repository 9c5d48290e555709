"""``extends`` with a shipped scenario's name, what an extending file does not inherit, and
``validate`` listing every error of a file (issue 11, point 12)."""

from __future__ import annotations

import pickle
from pathlib import Path

import pytest
from typer.testing import CliRunner

from slidingarm.cli import EXIT_USAGE, app
from slidingarm.config import ConfigError, load_scenario
from slidingarm.study import SHIPPED, load_shipped

runner = CliRunner()


def _write(folder: Path, text: str, name: str = "mine.toml") -> Path:
    path = folder / name
    path.write_text(text, encoding="utf-8")
    return path


@pytest.mark.parametrize("base", ["tanh", "noise", "ur5_sign", "tanh.toml"])
def test_extends_takes_a_shipped_scenario_by_name(tmp_path: Path, base: str) -> None:
    path = _write(tmp_path, f'extends = "{base}"\n\n[gains]\nk = 30.0\n')
    mine = load_scenario(path)
    shipped = load_shipped(base.removesuffix(".toml"))
    assert mine.switching == shipped.switching
    assert mine.sensor == shipped.sensor and mine.plant == shipped.plant
    assert mine.gains.k == 30.0 and shipped.gains.k != 30.0
    mine.build()  # and it builds


def test_a_local_file_wins_over_a_shipped_name(tmp_path: Path) -> None:
    _write(tmp_path, load_shipped("sign").source.read_text(encoding="utf-8")  # type: ignore[union-attr]
           .replace('extends = "paper.toml"', 'extends = "paper"'), "tanh.toml")  # fmt: skip
    mine = load_scenario(_write(tmp_path, 'extends = "tanh.toml"\n'))
    assert mine.switching == "sign"  # ./tanh.toml (a copy of sign) rather than the shipped tanh


def test_an_unknown_base_names_the_shipped_scenarios(tmp_path: Path) -> None:
    with pytest.raises(ConfigError) as info:
        load_scenario(_write(tmp_path, 'extends = "tahn"\n'))
    msg = str(info.value)
    assert info.value.path == "extends" and "'tahn' not found" in msg
    assert all(name in msg for name in SHIPPED)


def test_an_extending_file_has_its_own_name_and_description(tmp_path: Path) -> None:
    """The base's description ("Scenario B: ...") and name ("tanh") are not inherited, so the
    figures and report call the user's scenario by its own name."""
    mine = load_scenario(_write(tmp_path, 'extends = "tanh"\n'))
    assert mine.description == "" and mine.key == "mine"
    setup = mine.build()
    assert setup.name == "mine" and "Scenario B" not in setup.description
    own = load_scenario(
        _write(tmp_path, 'extends = "tanh"\ndescription = "My arm, tanh."\n', "own.toml")
    )
    assert own.description == "My arm, tanh." and own.key == "own"
    # the shipped chain keeps working: noise extends tanh extends paper, each with its own
    noise = load_shipped("noise")
    assert noise.key == "noise" and noise.description.startswith("Scenario C")


FIVE_ERRORS = """
extends = "tanh"

[simulation]
t_final = -1.0
dt = "fast"

[gains]
k = -20.0
kk = 3.0

[plant]
preset = "nope"
"""


def test_every_error_of_a_file_is_listed(tmp_path: Path) -> None:
    path = _write(tmp_path, FIVE_ERRORS)
    with pytest.raises(ConfigError) as info:
        load_scenario(path)
    err = info.value
    keys = ["gains.kk", "simulation.t_final", "simulation.dt", "gains.k", "plant.preset"]
    assert len(err.errors) == len(keys)
    assert sorted(e.path for e in err.errors) == sorted(keys)
    assert err.errors[0].path == "gains.kk"  # an unknown key first
    msg = str(err)
    assert "\n" not in msg and "more error" not in msg
    assert msg.startswith(f"{len(keys)} errors: (1) {path}: gains.kk: unknown key 'kk'")
    for i, key in enumerate(keys, start=1):
        assert f"({i}) " in msg and f": {key}: " in msg
    # the error survives pickling (sent back from a worker) with its list
    again = pickle.loads(pickle.dumps(err))
    assert str(again) == msg and [e.path for e in again.errors] == [e.path for e in err.errors]


def test_a_single_error_reads_as_before(tmp_path: Path) -> None:
    with pytest.raises(ConfigError) as info:
        load_scenario(_write(tmp_path, 'extends = "tanh"\n[gains]\nk = -1.0\n'))
    assert len(info.value.errors) == 1
    assert str(info.value).startswith(f"{tmp_path / 'mine.toml'}: gains.k: ")


def test_validate_prints_every_error_on_its_one_line(tmp_path: Path) -> None:
    path = _write(tmp_path, FIVE_ERRORS)
    result = runner.invoke(app, ["validate", str(path)])
    assert result.exit_code == EXIT_USAGE
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: 5 errors: (1) ")
    for key in ("gains.kk", "simulation.t_final", "simulation.dt", "gains.k", "plant.preset"):
        assert f": {key}: " in lines[0]
