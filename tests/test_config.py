"""Tests for slidingarm.config: scenario files, their one-line errors, and what they build."""

from __future__ import annotations

import json
import textwrap
from pathlib import Path

import numpy as np
import pytest

from _scenarios import minimal_scenario
from slidingarm import FTSMC, NTSMC, PDSMC, TSMC, DirtyDerivative, PaperReference, PlanarArm
from slidingarm.config import (
    ConfigError,
    Scenario,
    choices,
    load_scenario,
    scenario_from_dict,
)
from slidingarm.study import SCENARIOS, load_shipped, scenario_path, scenarios_dir

MINIMAL = minimal_scenario()


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
    # the numbers are stated once: only the base file of each family holds a [gains] table
    # (paper.toml for the study, ur5.toml for the UR5's pair)
    for path in scenarios_dir().glob("*.toml"):
        has_gains = "gains" in tomllib.loads(path.read_text(encoding="utf-8"))
        assert has_gains == (path.name in ("paper.toml", "ur5.toml")), path.name
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
    with pytest.raises(ConfigError, match="sign, tanh, noise, ur5, ur5_sign"):
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
         "must be an integer from 1 to 1000000, not a boolean, got True"),
        ("[simulation]\nsubsteps = 2.0\n", "simulation.substeps",
         "must be an integer from 1 to 1000000, got 2.0"),
        ("[simulation]\nsubsteps = 1.5\n", "simulation.substeps",
         "must be an integer from 1 to 1000000, got 1.5"),
        ('[simulation]\nsubsteps = "2"\n', "simulation.substeps",
         "must be an integer from 1 to 1000000, got '2'"),
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
        ("[gains]\neps_e = true\n", "gains.eps_e", "must be a number >= 1e-300 (rad), not a boolean, got True"),
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


# ---------------------------------------------------------------------------- serial arms

SERIAL = """
switching = "tanh"

[plant]
robot = "ur5"

[reference]
kind = "quintic"
q_start = [0.0, -1.3, 1.3, -1.6, -1.57, 0.0]
q_end = [0.5, -1.0, 1.0, -1.2, -1.2, 0.5]
duration = 1.0

[simulation]
t_final = 0.1
dt = 5e-4
q0 = [0.0, -1.3, 1.3, -1.6, -1.57, 0.0]

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
name = "ftsmc"
"""


def serial(tmp_path: Path, extra: str = "", name: str = "s.toml") -> Path:
    """A UR5 scenario extended with ``extra``."""
    write(tmp_path, SERIAL, "ur5base.toml")
    return write(tmp_path, 'extends = "ur5base.toml"\n' + textwrap.dedent(extra), name)


def test_robot_builds_the_serial_arm_for_plant_and_controllers(tmp_path: Path) -> None:
    from slidingarm import SerialArm, robots

    setup = load_scenario(serial(tmp_path, "[mismatch]\npayload = 1.0\n")).build()
    ur5 = robots.load("ur5")
    assert isinstance(setup.nominal, SerialArm) and setup.nominal == ur5
    assert setup.nominal.tool == "tool0"
    # the payload is the plant's, not the controllers'
    assert setup.plant == ur5.with_payload(1.0)
    assert setup.plant.total_mass == pytest.approx(ur5.total_mass + 1.0)
    for c in setup.controllers.values():
        assert c.model == ur5
    # tool and gravity reach the arm
    other = load_scenario(
        serial(tmp_path, '[plant]\ntool = "wrist_3_link"\ngravity = 1.62\n', "moon.toml")
    ).build()
    assert other.nominal == ur5.replace(tool="wrist_3_link", gravity=1.62)


def test_payload_link_of_a_serial_arm(tmp_path: Path) -> None:
    from slidingarm import robots

    path = serial(tmp_path, '[mismatch]\npayload = 2.0\npayload_link = "forearm_link"\n')
    setup = load_scenario(path).build()
    ur5 = robots.load("ur5")
    assert setup.plant == ur5.with_payload(2.0, link="forearm_link")
    assert setup.plant != ur5.with_payload(2.0)


def test_mismatch_errors_scale_a_serial_arm(tmp_path: Path) -> None:
    from slidingarm import robots

    text = "[mismatch]\nmass_error = [0.1, 0.0, 0.0, 0.0, 0.0, -0.1]\nlength_error = 0.05\n"
    setup = load_scenario(serial(tmp_path, text)).build()
    factors = np.array([1.1, 1.0, 1.0, 1.0, 1.0, 0.9])
    assert setup.plant == robots.load("ur5").scaled(mass=factors, length=1.05)


def test_a_robot_replaces_the_planar_plant_of_the_base(tmp_path: Path) -> None:
    # the base's preset and mass_model do not leak into a robot plant
    text = """
    [plant]
    robot = "ur5"

    [reference]
    kind = "sine"
    offset = [0.0, -1.3, 1.3, -1.6, -1.57, 0.0]
    amplitude = 0.2
    frequency = [0.2, 0.3, 0.2, 0.4, 0.3, 0.5]

    [simulation]
    q0 = [0.0, -1.3, 1.3, -1.6, -1.57, 0.0]
    """
    setup = load_scenario(with_base(tmp_path, text)).build()
    assert setup.nominal.n == 6 and setup.reference.n == 6


@pytest.mark.parametrize(
    ("extra", "path", "reason"),
    [
        ('[plant]\nrobot = "ur6"\n', "plant.robot",
         "must be a shipped robot, one of panda, ur5; got 'ur6'"),
        ('[plant]\ntool = "hand"\n', "plant.tool", "tool frame 'hand' is not a link of 'ur5'"),
        ('[mismatch]\npayload = 1.0\npayload_link = "nolink"\n', "mismatch.payload_link",
         "payload link 'nolink' is not a link of 'ur5'"),
        ('[mismatch]\npayload_link = "wrist_2_link"\n', "mismatch.payload_link",
         "says where the payload sits, but mismatch.payload is 0 kg"),
        ("[mismatch]\nmass_error = [0.1, 0.2]\n", "mismatch.mass_error",
         "has 2 values but the arm has 6 joints (give a scalar or 6 values)"),
        ("[simulation]\nq0 = [0.0, 0.0, 0.0]\n", "simulation.q0",
         "has 3 values but the arm has 6 joints (give 6 values)"),
        ("[simulation]\nqd0 = [0.0]\n", "simulation.qd0",
         "has 1 values but the arm has 6 joints (give 6 values)"),
        ("[gains]\nk = [1.0, 2.0, 3.0]\n", "gains.k",
         "has 3 values but the arm has 6 joints (give a scalar or 6 values)"),
        ("[reference]\nq_end = [0.5, -1.0, 1.0]\n", "reference.q_end",
         "has 3 values but the arm has 6 joints (give 6 values)"),
        ('[reference]\nkind = "paper"\n', "reference.kind",
         "the paper's reference describes 3 joints but the arm has 6"),
        ('[reference]\nkind = "sine"\noffset = [0.0, -1.3, 1.3, -1.6, -1.57, 0.0]\n'
         "amplitude = [0.1, 0.1]\nfrequency = 0.5\n", "reference.amplitude",
         "has 2 values but the arm has 6 joints (give a scalar or 6 values)"),
        ('[reference]\nkind = "table"\nt = [0.0, 1.0]\n'
         "q = [[0.0, -1.3, 1.3, -1.6, -1.57, 0.0], [0.0, -1.3, 1.3]]\nends = \"rest\"\n",
         "reference.q[1]", "has 3 values but the arm has 6 joints (give 6 values)"),
        # URDF position limits (the UR5's elbow is within ±π, the others within ±2π)
        ("[simulation]\nq0 = [0.0, -1.3, 3.3, -1.6, -1.57, 0.0]\n", "simulation.q0",
         "joint 3 (elbow_joint) starts at 3.3 rad, above its URDF upper limit 3.14159 rad"),
        ("[reference]\nq_end = [0.5, -6.5, 1.0, -1.2, -1.2, 0.5]\n", "reference.q_end",
         "joint 2 (shoulder_lift_joint) is at -6.5 rad there, below its URDF lower limit "
         "-6.28319 rad (the reference must stay within the joint limits)"),
        ('[reference]\nkind = "sine"\noffset = [0.0, -1.3, 2.9, -1.6, -1.57, 0.0]\n'
         "amplitude = 0.3\nfrequency = 2.0\n", "reference.amplitude",
         "joint 3 (elbow_joint) reaches 3.14271 rad at t = 0.075 s, above its URDF upper limit "
         "3.14159 rad"),
        # a spline through waypoints inside the limits that overshoots them between two
        ('[reference]\nkind = "table"\nends = "rest"\nt = [0.0, 0.03, 0.06, 0.1]\n'
         "q = [[0.0, -1.3, 2.0, -1.6, -1.57, 0.0], [0.0, -1.3, 3.1, -1.6, -1.57, 0.0], "
         "[0.0, -1.3, 3.1, -1.6, -1.57, 0.0], [0.0, -1.3, 2.0, -1.6, -1.57, 0.0]]\n"
         "[simulation]\nq0 = [0.0, -1.3, 2.0, -1.6, -1.57, 0.0]\n", "reference.q",
         "joint 3 (elbow_joint) reaches "),
    ],
)  # fmt: skip
def test_serial_arm_errors_name_the_key(tmp_path: Path, extra: str, path: str, reason: str) -> None:
    msg = error_of(serial(tmp_path, extra))
    assert msg.startswith(f"{tmp_path / 's.toml'}: {path}: {reason}")


@pytest.mark.parametrize(
    ("lines", "reason"),
    [
        ('preset = "paper"\nmass_model = "rod"',
         "robot describes a serial arm, so the planar keys preset, mass_model do not apply; "
         "remove them (got robot and preset, mass_model)"),
        ("masses = [1.0]\nlengths = [1.0]",
         "robot describes a serial arm, so the planar keys masses, lengths do not apply; "
         "remove them (got robot and masses, lengths)"),
        ('urdf = "arm.urdf"', "give either robot (a shipped robot) or urdf (a URDF file), not both"),
    ],
)  # fmt: skip
def test_serial_keys_exclude_the_planar_ones(tmp_path: Path, lines: str, reason: str) -> None:
    text = SERIAL.replace('robot = "ur5"', f'robot = "ur5"\n{lines}')
    assert error_of(write(tmp_path, text)) == f"{tmp_path / 's.toml'}: plant: {reason}"


def test_planar_arms_refuse_serial_keys(tmp_path: Path) -> None:
    msg = error_of(with_base(tmp_path, '[mismatch]\npayload = 1.0\npayload_link = "link3"\n'))
    assert msg == (
        f"{tmp_path / 's.toml'}: mismatch.payload_link: names a link of a robot or URDF arm; "
        "a planar arm's payload sits at its tip (remove payload_link)"
    )
    msg = error_of(with_base(tmp_path, '[plant]\ntool = "tip"\n'))
    assert msg.startswith(f"{tmp_path / 's.toml'}: plant: tool names a link of a robot or URDF")
    text = MINIMAL.replace('preset = "paper"', "gravity = 9.81")
    msg = error_of(write(tmp_path, text))
    assert msg == (
        f"{tmp_path / 's.toml'}: plant: needs preset = 'paper' or both masses and lengths "
        "(a planar arm), or robot (one of panda, ur5) or urdf (a serial arm)"
    )


def test_urdf_is_relative_to_the_file_that_names_it(tmp_path: Path) -> None:
    from slidingarm import SerialArm, robots

    arms = tmp_path / "arms"
    arms.mkdir()
    (arms / "ur5.urdf").write_bytes(robots.path("ur5").read_bytes())
    # the base, in arms/, names its URDF next to it; the scenario extends it from elsewhere
    write(arms, SERIAL.replace('robot = "ur5"', 'urdf = "ur5.urdf"\ntool = "tool0"'), "base.toml")
    path = write(tmp_path, 'extends = "arms/base.toml"\nname = "x"\n')
    scenario = load_scenario(path)
    nominal = scenario.build().nominal
    assert isinstance(nominal, SerialArm) and nominal == robots.load("ur5")
    # the exported TOML holds the absolute path, so the copy runs from anywhere
    exported = scenario.to_dict()["plant"]["urdf"]
    assert exported == str((arms / "ur5.urdf").resolve())
    elsewhere = tmp_path / "out" / "config"
    elsewhere.mkdir(parents=True)
    assert load_scenario(write(elsewhere, scenario.to_toml(), "x.toml")).build().nominal == nominal


def test_urdf_errors_name_plant_urdf(tmp_path: Path) -> None:
    text = SERIAL.replace('robot = "ur5"', 'urdf = "missing.urdf"')
    msg = error_of(write(tmp_path, text))
    assert msg.startswith(f"{tmp_path / 's.toml'}: plant.urdf: cannot read URDF file ")
    assert str(tmp_path / "missing.urdf") in msg
    (tmp_path / "junk.urdf").write_text("<robot name='x'><link name='a'/>", encoding="utf-8")
    msg = error_of(write(tmp_path, text.replace("missing.urdf", "junk.urdf")))
    assert ": plant.urdf: " in msg and "is not valid XML" in msg
    (tmp_path / "float.urdf").write_text(
        "<robot name='f'><link name='a'/><link name='b'/><joint name='j' type='floating'>"
        "<parent link='a'/><child link='b'/></joint></robot>",
        encoding="utf-8",
    )
    msg = error_of(write(tmp_path, text.replace("missing.urdf", "float.urdf")))
    assert ": plant.urdf: joint 'j' of URDF file " in msg and "is a floating joint" in msg


def test_serial_config_errors_exit_2_with_one_line(tmp_path: Path) -> None:
    from test_cli import invoke, one_line_error

    for extra, key in [
        ('[plant]\nrobot = "ur6"\n', "plant.robot"),
        ('[plant]\ntool = "hand"\n', "plant.tool"),
        ("[simulation]\nq0 = [0.0, 0.0, 0.0]\n", "simulation.q0"),
        ("[simulation]\nq0 = [0.0, -1.3, 3.3, -1.6, -1.57, 0.0]\n", "simulation.q0"),
    ]:
        path = serial(tmp_path, extra)
        for verb in (["validate", str(path)], ["run", str(path), "--out", str(tmp_path / "o")]):
            code, _, err = invoke(*verb)
            assert code == 2
            assert one_line_error(err).startswith(f"error: {path}: {key}: ")
    assert not (tmp_path / "o").exists()
    text = SERIAL.replace('robot = "ur5"', 'urdf = "missing.urdf"')
    code, _, err = invoke("validate", str(write(tmp_path, text)))
    assert code == 2 and ": plant.urdf: cannot read URDF file " in one_line_error(err)
