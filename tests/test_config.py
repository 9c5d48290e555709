"""Tests for slidingarm.config: scenario files, their one-line errors, and what they build."""

from __future__ import annotations

import json
import textwrap
from pathlib import Path

import numpy as np
import pytest

from slidingarm import FTSMC, NTSMC, PDSMC, TSMC, DirtyDerivative, PaperReference, PlanarArm
from slidingarm.config import (
    ConfigError,
    Scenario,
    choices,
    load_scenario,
    scenario_from_dict,
)
from slidingarm.study import SCENARIOS, load_shipped, scenario_path, scenarios_dir

MINIMAL = """
switching = "sign"

[plant]
preset = "paper"

[reference]
kind = "paper"

[simulation]
t_final = 0.5
dt = 5e-4
q0 = [0.7, 1.5, 0.5]

[gains]
alpha = 2.0
beta = 2.0
p = 5
q = 3
k = 20.0
width = 0.05

[[controllers]]
name = "pdsmc"

[[controllers]]
name = "tsmc"

[[controllers]]
name = "ftsmc"
"""


def write(tmp_path: Path, text: str, name: str = "s.toml") -> Path:
    p = tmp_path / name
    p.write_text(textwrap.dedent(text), encoding="utf-8")
    return p


def error_of(path: Path) -> str:
    with pytest.raises(ConfigError) as info:
        load_scenario(path)
    message = str(info.value)
    assert "\n" not in message, "a config error is one line"
    return message


def with_base(tmp_path: Path, extra: str) -> Path:
    """A scenario that extends the minimal one with ``extra``."""
    write(tmp_path, MINIMAL, "base.toml")
    return write(tmp_path, 'extends = "base.toml"\n' + textwrap.dedent(extra))


# ---------------------------------------------------------------------------- valid files


def test_minimal_builds_the_library_objects(tmp_path: Path) -> None:
    scenario = load_scenario(write(tmp_path, MINIMAL))
    setup = scenario.build()
    assert scenario.key == "s"  # the file's stem
    assert setup.nominal == PlanarArm.paper()
    assert setup.plant == setup.nominal  # no mismatch
    assert isinstance(setup.reference, PaperReference)
    assert list(setup.controllers) == ["pdsmc", "tsmc", "ftsmc"]
    pd_, ts, ft = setup.controllers.values()
    assert isinstance(pd_, PDSMC) and isinstance(ts, TSMC) and isinstance(ft, FTSMC)
    # the shared gains reach every controller that has them
    assert pd_.to_dict()["lam"] == 2.0
    assert ft.to_dict()["alpha"] == 2.0 and ft.to_dict()["beta"] == 2.0
    assert ts.to_dict()["beta"] == 2.0
    assert ts.to_dict()["gamma"] == pytest.approx(0.6)
    # width is a boundary layer: ignored with sign switching
    assert all(
        c.switching == "sign" and "width" not in c.to_dict() for c in setup.controllers.values()
    )
    assert setup.t_final == 0.5 and setup.dt == 5e-4 and setup.seed == 0


def test_lam_is_alpha_and_controller_overrides(tmp_path: Path) -> None:
    text = MINIMAL.replace("alpha = 2.0", "lam = 3.0") + textwrap.dedent(
        """
        [[controllers]]
        name = "ftsmc"
        label = "ftsmc-tanh"
        switching = "tanh"
        k = 40.0
        law = "paper"
        """
    )
    setup = load_scenario(write(tmp_path, text)).build()
    assert setup.controllers["pdsmc"].to_dict()["lam"] == 3.0
    extra = setup.controllers["ftsmc-tanh"]
    assert extra.switching == "tanh" and extra.law == "paper"
    assert extra.to_dict()["width"] == 0.05 and float(extra.k[0]) == 40.0
    assert extra.to_dict()["alpha"] == 3.0


def test_per_joint_gains_mismatch_sensor_disturbances(tmp_path: Path) -> None:
    text = with_base(
        tmp_path,
        """
        [gains]
        k = [10.0, 20.0, 30.0]

        [mismatch]
        payload = 0.5
        mass_error = [0.1, 0.0, -0.1]

        [sensor]
        noise = { sigma = 1e-4 }
        velocity = { kind = "filtered", time_constant = 0.01 }
        faults = [{ kind = "bias", joint = 2, t_start = 0.1, value = 0.01 }]

        [[disturbances]]
        kind = "sinusoidal"
        amplitude = 0.5
        frequency = 2.0
        """,
    )
    setup = load_scenario(text).build()
    np.testing.assert_array_equal(setup.controllers["tsmc"].k, [10.0, 20.0, 30.0])
    assert setup.plant != setup.nominal
    assert setup.plant.masses[0] == pytest.approx(1.1)
    assert setup.plant.masses[2] == pytest.approx(0.9 + 0.5)
    assert setup.sensor.velocity == DirtyDerivative(0.01)
    assert setup.sensor.noise is not None and setup.sensor.noise.sigma == 1e-4
    assert setup.sensor.faults[0].joint == 2
    assert len(setup.disturbances) == 1


def test_explicit_plant_replaces_the_preset_of_the_base(tmp_path: Path) -> None:
    path = with_base(
        tmp_path,
        """
        [plant]
        masses = [1.0, 2.0, 3.0]
        lengths = [0.5, 0.5, 0.5]
        mass_model = "rod"
        """,
    )
    setup = load_scenario(path).build()
    np.testing.assert_allclose(setup.nominal.masses, [1.0, 2.0, 3.0])
    np.testing.assert_allclose(setup.nominal.com, [0.25, 0.25, 0.25])


def test_table_reference_path_is_relative_to_the_file(tmp_path: Path) -> None:
    sub = tmp_path / "refs"
    sub.mkdir()
    t = np.linspace(0, 1, 11)
    rows = "\n".join(f"{x},{0.7 + 0.1 * x},{1.5},{0.5}" for x in t)
    (sub / "traj.csv").write_text("t,q1,q2,q3\n" + rows + "\n")
    text = MINIMAL.replace('kind = "paper"', 'kind = "table"\npath = "refs/traj.csv"').replace(
        "t_final = 0.5", "t_final = 1.0"
    )
    scenario = load_scenario(write(tmp_path, text))
    assert scenario.build().reference.n == 3
    # the exported TOML makes the path absolute, so the copy validates anywhere
    copy = write(tmp_path / "refs", scenario.to_toml(), "copy.toml")
    assert load_scenario(copy).build().reference.n == 3


def test_ntsmc_takes_the_inverse_exponent(tmp_path: Path) -> None:
    text = MINIMAL + '\n[[controllers]]\nname = "ntsmc"\n'
    setup = load_scenario(write(tmp_path, text)).build()
    nt = setup.controllers["ntsmc"]
    assert isinstance(nt, NTSMC)
    assert nt.to_dict()["gamma"] == pytest.approx(5 / 3)


def test_to_toml_round_trips(tmp_path: Path) -> None:
    scenario = load_shipped("noise")
    copy = write(tmp_path, scenario.to_toml(), "noise.toml")
    again = load_scenario(copy)
    assert again.to_dict() == scenario.to_dict()


def test_scenario_from_dict_and_schema() -> None:
    import tomllib

    data = tomllib.loads(MINIMAL)
    scenario = scenario_from_dict(data, source="inline.toml")
    assert scenario.key == "inline"
    schema = Scenario.model_json_schema()
    json.dumps(schema)
    assert schema["additionalProperties"] is False
    assert {"plant", "reference", "simulation", "gains", "controllers"} <= set(schema["properties"])
    with pytest.raises(ConfigError, match="switching: missing required key; one of 'sign'"):
        scenario_from_dict({k: v for k, v in data.items() if k != "switching"})


def test_choices_cover_the_library() -> None:
    c = choices()
    assert c["switching laws (switching)"] == ["sign", "tanh", "sat"]
    assert c["velocity estimators (sensor.velocity.kind)"] == [
        "true",
        "difference",
        "filtered",
        "levant",
    ]
    assert c["references (reference.kind)"] == ["paper", "quintic", "sine", "table"]


# ---------------------------------------------------------------------------- shipped scenarios


@pytest.mark.parametrize("name", SCENARIOS)
def test_shipped_scenarios_validate_and_build(name: str) -> None:
    scenario = load_shipped(name)
    setup = scenario.build()
    assert scenario.key == name
    assert list(setup.controllers) == ["pdsmc", "tsmc", "ftsmc"]
    assert setup.t_final == 4.5 and setup.dt == 5e-4
    assert setup.q0 == (0.7, 1.5, 0.5)
    assert scenario.gains.reasons and "alpha" in scenario.gains.reasons


def test_shipped_scenarios_share_one_set_of_gains() -> None:
    import tomllib

    gains = {name: load_shipped(name).gains for name in SCENARIOS}
    assert len({g.model_dump_json() for g in gains.values()}) == 1
    # the numbers are stated once: only the base file holds a [gains] table
    for path in scenarios_dir().glob("*.toml"):
        has_gains = "gains" in tomllib.loads(path.read_text(encoding="utf-8"))
        assert has_gains == (path.name == "paper.toml"), path.name
    assert load_shipped("sign").switching == "sign"
    assert load_shipped("tanh").switching == "tanh"
    noise = load_shipped("noise")
    assert noise.switching == "tanh"
    assert noise.sensor.noise is not None and noise.sensor.noise.sigma == 1e-4
    assert noise.sensor.reasons and "16-bit" in noise.sensor.reasons


def test_base_alone_is_not_a_scenario() -> None:
    with pytest.raises(ConfigError, match=r"paper\.toml: switching: missing required key"):
        load_scenario(scenarios_dir() / "paper.toml")


def test_unknown_shipped_name() -> None:
    with pytest.raises(ConfigError, match="sign, tanh, noise"):
        scenario_path("nope")


# ---------------------------------------------------------------------------- error messages


def test_unknown_key_names_path_and_allowed_keys(tmp_path: Path) -> None:
    msg = error_of(with_base(tmp_path, "[gains]\ngama = 0.5\n"))
    assert msg.startswith(f"{tmp_path / 's.toml'}: gains.gama: unknown key 'gama'")
    assert "did you mean 'gamma'?" in msg
    assert "allowed keys: alpha, lam, beta, gamma, p, q, k, width, k2, eps_e, reasons" in msg


def test_unknown_key_at_top_level(tmp_path: Path) -> None:
    msg = error_of(with_base(tmp_path, "seeed = 3\n"))
    assert ": seeed: unknown key 'seeed'" in msg
    assert "allowed keys: extends, name" in msg


def test_unknown_key_inside_a_tagged_table(tmp_path: Path) -> None:
    msg = error_of(with_base(tmp_path, '[[disturbances]]\nkind = "constant"\nvalu = 1.0\n'))
    assert ": disturbances[0].valu: unknown key 'valu' (did you mean 'value'?)" in msg
    assert "allowed keys: kind, value, t_start" in msg


def test_wrong_type(tmp_path: Path) -> None:
    msg = error_of(with_base(tmp_path, '[gains]\nk = "fast"\n'))
    assert ": gains.k: must be a number > 0 or a list of them (one per joint), got 'fast'" in msg
    msg = error_of(with_base(tmp_path, "[simulation]\nsubsteps = 1.5\n"))
    assert ": simulation.substeps: " in msg and "integer" in msg


def test_out_of_range_gamma_names_the_controller(tmp_path: Path) -> None:
    msg = error_of(
        with_base(
            tmp_path,
            """
            [[controllers]]
            name = "pdsmc"

            [[controllers]]
            name = "ftsmc"
            gamma = 1.6667
            """,
        )
    )
    assert ": controllers[1].gamma: must lie in (0, 1)" in msg
    assert "got 1.6667" in msg and "allow_nonterminal" in msg


def test_nonterminal_gamma_is_admitted_only_on_request(tmp_path: Path) -> None:
    path = with_base(
        tmp_path,
        '[[controllers]]\nname = "ftsmc"\ngamma = 1.6667\nallow_nonterminal = true\n',
    )
    ft = load_scenario(path).build().controllers["ftsmc"]
    assert ft.to_dict()["gamma"] == pytest.approx(1.6667)


def test_shared_gamma_out_of_range(tmp_path: Path) -> None:
    text = MINIMAL.replace("p = 5\nq = 3", "gamma = 0.0")
    msg = error_of(write(tmp_path, text))
    assert ": gains.gamma: must lie in (0, 1)" in msg


def test_bad_enum_lists_allowed_values(tmp_path: Path) -> None:
    msg = error_of(with_base(tmp_path, 'switching = "sing"\n'))
    assert ": switching: input should be 'sign', 'tanh' or 'sat', got 'sing'" in msg
    msg = error_of(with_base(tmp_path, '[sensor]\nvelocity = { kind = "kalman" }\n'))
    assert (
        ": sensor.velocity: kind must be one of 'true', 'difference', 'filtered', 'levant'" in msg
    )


def test_negative_sigma_path(tmp_path: Path) -> None:
    msg = error_of(with_base(tmp_path, "[sensor.noise]\nsigma = -1e-4\n"))
    assert ": sensor.noise.sigma: must be >= 0" in msg


def test_toml_syntax_error_names_file_and_line(tmp_path: Path) -> None:
    path = write(tmp_path, 'switching = "sign"\n\n[simulation\ndt = 1\n')
    msg = error_of(path)
    assert msg.startswith(f"{path}:3: invalid TOML:")


def test_missing_file(tmp_path: Path) -> None:
    msg = error_of(tmp_path / "nope.toml")
    assert msg == f"{tmp_path / 'nope.toml'}: no such file"


def test_joint_count_mismatch(tmp_path: Path) -> None:
    msg = error_of(with_base(tmp_path, "[simulation]\nq0 = [1.0, 2.0]\n"))
    assert ": simulation.q0: has 2 values but the arm has 3 joints (give 3 values)" in msg
    msg = error_of(with_base(tmp_path, "[gains]\nbeta = [1.0, 2.0]\n"))
    assert ": gains.beta: has 2 values but the arm has 3 joints (give a scalar or 3 values)" in msg


def test_time_grid_must_be_whole(tmp_path: Path) -> None:
    msg = error_of(with_base(tmp_path, "[simulation]\ndt = 7e-4\n"))
    assert ": simulation.t_final: " in msg and "whole number of steps" in msg


def test_gain_a_controller_does_not_have(tmp_path: Path) -> None:
    msg = error_of(with_base(tmp_path, '[[controllers]]\nname = "pdsmc"\nbeta = 2.0\n'))
    assert ": controllers[0].beta: pdsmc has no gain beta" in msg


def test_missing_gain_points_at_gains(tmp_path: Path) -> None:
    text = MINIMAL.replace("beta = 2.0\n", "")
    msg = error_of(write(tmp_path, text))
    assert ": gains.beta: missing: tsmc (controllers[1]) needs beta" in msg


def test_alpha_and_lam_are_one_gain(tmp_path: Path) -> None:
    msg = error_of(with_base(tmp_path, "[gains]\nlam = 2.0\n"))
    assert ": gains: alpha and lam are the same gain" in msg


def test_duplicate_labels(tmp_path: Path) -> None:
    msg = error_of(
        with_base(tmp_path, '[[controllers]]\nname = "tsmc"\n[[controllers]]\nname = "tsmc"\n')
    )
    assert ": controllers[1].label: duplicate controller 'tsmc'" in msg


def test_error_in_the_base_names_the_base(tmp_path: Path) -> None:
    write(tmp_path, MINIMAL.replace("k = 20.0", "k = -1.0"), "base.toml")
    path = write(tmp_path, 'extends = "base.toml"\nname = "x"\n')
    msg = error_of(path)
    assert msg.startswith(f"{tmp_path / 'base.toml'}: gains.k: must be > 0")
    assert "(set in base.toml, extended by s.toml)" in msg


def test_extends_errors(tmp_path: Path) -> None:
    msg = error_of(write(tmp_path, 'extends = "nope.toml"\n'))
    assert ": extends: base file 'nope.toml' not found" in msg
    write(tmp_path, 'extends = "b.toml"\n', "a.toml")
    write(tmp_path, 'extends = "a.toml"\n', "b.toml")
    msg = error_of(tmp_path / "a.toml")
    assert ": extends: extends forms a cycle: a.toml -> b.toml -> a.toml" in msg


def test_missing_table_file(tmp_path: Path) -> None:
    text = MINIMAL.replace('kind = "paper"', 'kind = "table"\npath = "nope.csv"')
    msg = error_of(write(tmp_path, text))
    assert ": reference.path: table file not found: " in msg


def test_fault_on_a_missing_joint(tmp_path: Path) -> None:
    msg = error_of(with_base(tmp_path, '[[sensor.faults]]\nkind = "stuck"\njoint = 4\n'))
    assert ": sensor.faults[0].joint: joint 4 does not exist on a 3-joint arm" in msg


# ---------------------------------------------------------------------------- numbers are numbers


@pytest.mark.parametrize(
    ("extra", "path", "reason"),
    [
        # integers: neither booleans nor floats, however integral
        ("[simulation]\nsubsteps = true\n", "simulation.substeps",
         "must be an integer >= 1, not a boolean, got True"),
        ("[simulation]\nsubsteps = 2.0\n", "simulation.substeps",
         "must be an integer >= 1, got 2.0"),
        ("[simulation]\nsubsteps = 1.5\n", "simulation.substeps",
         "must be an integer >= 1, got 1.5"),
        ('[simulation]\nsubsteps = "2"\n', "simulation.substeps",
         "must be an integer >= 1, got '2'"),
        ("[simulation]\nseed = true\n", "simulation.seed",
         "must be an integer >= 0, not a boolean, got True"),
        ("[simulation]\nseed = 1.0\n", "simulation.seed", "must be an integer >= 0, got 1.0"),
        ('[[sensor.faults]]\nkind = "bias"\njoint = true\nvalue = 0.01\n',
         "sensor.faults[0].joint", "must be an integer >= 1, not a boolean, got True"),
        ('[[sensor.faults]]\nkind = "stuck"\njoint = 1.0\n', "sensor.faults[0].joint",
         "must be an integer >= 1, got 1.0"),
        ('[[sensor.faults]]\nkind = "dropout"\njoint = true\nprobability = 0.5\n',
         "sensor.faults[0].joint", "must be an integer >= 1, not a boolean, got True"),
        ("[gains]\np = true\n", "gains.p", "must be a positive odd integer, not a boolean, got True"),
        ("[gains]\nq = true\n", "gains.q", "must be a positive odd integer, not a boolean, got True"),
        ("[gains]\np = 5.0\n", "gains.p", "must be a positive odd integer, got 5.0"),
        ("[gains]\nq = 3.0\n", "gains.q", "must be a positive odd integer, got 3.0"),
        ('[[controllers]]\nname = "ntsmc"\nbeta = 2.0\np = 5\nq = true\n', "controllers[0].q",
         "must be a positive odd integer, not a boolean, got True"),
        # floats: booleans and strings are not numbers
        ("[simulation]\nt_final = true\n", "simulation.t_final",
         "must be a number > 0, not a boolean, got True"),
        ('[simulation]\nt_final = "0.5"\n', "simulation.t_final", "must be a number > 0, got '0.5'"),
        ("[gains]\neps_e = true\n", "gains.eps_e", "must be a number > 0, not a boolean, got True"),
        ("[plant]\ngravity = true\n", "plant.gravity",
         "must be a number >= 0, not a boolean, got True"),
        ("[gains]\ngamma = true\np = 5\n", "gains.gamma",
         "must be a number, not a boolean, got True"),
        ("[mismatch]\npayload = false\n", "mismatch.payload",
         "must be a number >= 0, not a boolean, got False"),
        ('[sensor]\nvelocity = { kind = "levant", lipschitz = true }\n',
         "sensor.velocity.lipschitz", "must be a number > 0, not a boolean, got True"),
        ('[[sensor.faults]]\nkind = "dropout"\njoint = 1\nprobability = true\n',
         "sensor.faults[0].probability", "must be a number in [0, 1], not a boolean, got True"),
        ('[[disturbances]]\nkind = "sinusoidal"\namplitude = 1.0\nphase = true\n',
         "disturbances[0].phase", "must be a finite number, not a boolean, got True"),
        # booleans: not numbers either
        ('[[controllers]]\nname = "tsmc"\nallow_nonterminal = 1\n',
         "controllers[0].allow_nonterminal", "input should be a valid boolean, got 1"),
    ],
)  # fmt: skip
def test_booleans_and_floats_are_not_integers(
    tmp_path: Path, extra: str, path: str, reason: str
) -> None:
    msg = error_of(with_base(tmp_path, extra))
    assert msg == f"{tmp_path / 's.toml'}: {path}: {reason}"


def test_toml_integers_are_accepted_as_floats(tmp_path: Path) -> None:
    path = with_base(tmp_path, "[simulation]\nt_final = 1\n\n[gains]\nk = 20\neps_e = 1\n")
    setup = load_scenario(path).build()
    assert setup.t_final == 1.0 and isinstance(setup.t_final, float)
    assert all(c.to_dict()["k"] == 20.0 for c in setup.controllers.values())
    assert isinstance(setup.substeps, int) and isinstance(setup.seed, int)


def test_type_checks_keep_the_schema_bounds() -> None:
    defs = Scenario.model_json_schema()["$defs"]
    sim = defs["SimulationSpec"]["properties"]
    assert sim["substeps"]["type"] == "integer" and sim["substeps"]["minimum"] == 1
    assert sim["seed"]["type"] == "integer" and sim["seed"]["minimum"] == 0
    assert sim["t_final"]["type"] == "number" and sim["t_final"]["exclusiveMinimum"] == 0
    dropout = defs["DropoutFaultSpec"]["properties"]
    assert dropout["joint"]["minimum"] == 1
    assert (dropout["probability"]["minimum"], dropout["probability"]["maximum"]) == (0, 1)
