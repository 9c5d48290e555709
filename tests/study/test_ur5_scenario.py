"""The shipped UR5 scenarios (issue 9, point 5): they validate, run from the command line into a
results folder with a tool-path figure, track within the bounds measured when they were tuned,
and a serial arm read from the planar arm's URDF reproduces the planar scenario."""

from __future__ import annotations

import json
import sys
import tomllib
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from slidingarm import PlanarArm, SerialArm, robots
from slidingarm.config import load_scenario
from slidingarm.plotting import FIGURES, TOOL_FIGURES
from slidingarm.study import SHIPPED, load_shipped, run_scenario
from slidingarm.study.analysis import metrics_table, tool_paths

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # tests/: the CLI test helpers
from test_cli import invoke, one_line_error

CONTROLLERS = ("pdsmc", "tsmc", "ftsmc")
#: The UR5's effort limits (N·m), the scenarios' torque limit.
EFFORT = np.array([150.0, 150.0, 150.0, 28.0, 28.0, 28.0])

#: MSE (rad², mean over joints) each controller must stay below: about 1.3 times what the
#: scenarios gave when they were tuned (tanh: PDSMC 5.29e-4, TSMC 2.12e-4, FTSMC 1.86e-4; sign
#: within 1 % of them).
MSE_BOUND = {"pdsmc": 7e-4, "tsmc": 2.8e-4, "ftsmc": 2.5e-4}
#: Worst joint's error over the last 0.5 s (rad), FTSMC: 7.5e-5 (tanh) and 2.5e-5 (sign) when
#: tuned; the payload leaves PDSMC 3.5e-3 rad.
FTSMC_SS_BOUND = 2e-4


@pytest.fixture(scope="module")
def ur5_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """``slidingarm run ur5 --out DIR``, once for the module."""
    out = tmp_path_factory.mktemp("ur5") / "results"
    code, stdout, stderr = invoke("run", "ur5", "--out", str(out))
    assert code == 0, stderr
    assert f"wrote {out}" in stdout and "ur5" in stdout
    return out


@pytest.fixture(scope="module")
def sign_runs() -> dict[str, object]:
    return run_scenario(load_shipped("ur5_sign"))  # type: ignore[return-value]


def test_shipped_and_listed() -> None:
    assert {"ur5", "ur5_sign"} <= set(SHIPPED)
    code, out, _ = invoke("list")
    assert code == 0 and "\n  ur5 " in out and "\n  ur5_sign " in out
    for name, switching in (("ur5", "tanh"), ("ur5_sign", "sign")):
        code, out, err = invoke("validate", name)
        assert code == 0, err
        assert out.startswith("ok: ") and f"scenario {name!r}, 6-joint arm" in out
        assert f"switching {switching}" in out and "10001 samples" in out


def test_the_scenario_is_the_ur5_with_an_unknown_payload() -> None:
    tanh, sign = load_shipped("ur5"), load_shipped("ur5_sign")
    setup = tanh.build()
    ur5 = robots.load("ur5")
    assert setup.nominal == ur5 and setup.plant == ur5.with_payload(1.0)
    assert all(c.model == ur5 for c in setup.controllers.values())  # the payload is unknown
    assert list(setup.controllers) == list(CONTROLLERS)
    np.testing.assert_array_equal(setup.torque_limit, EFFORT)
    np.testing.assert_array_equal(ur5.limits["effort"], EFFORT)
    # sign differs from tanh in the switching only
    a, b = tanh.to_dict(), sign.to_dict()
    assert (a.pop("switching"), b.pop("switching")) == ("tanh", "sign")
    assert {k: v for k, v in a.items() if k not in ("name", "description")} == {
        k: v for k, v in b.items() if k not in ("name", "description")
    }
    # the trajectory moves every joint, starts and ends at rest, within the URDF's limits
    t = np.linspace(0.0, setup.t_final, 2001)
    q, qd, _ = setup.reference.evaluate(t)
    assert np.all(q.max(axis=0) - q.min(axis=0) > 0.4)
    np.testing.assert_allclose(qd[[0, -1]], 0.0, atol=1e-12)
    assert np.all(np.abs(qd) < ur5.limits["velocity"])
    assert np.all((q > ur5.limits["lower"]) & (q < ur5.limits["upper"]))


def test_run_writes_every_file_and_figure(ur5_run: Path) -> None:
    manifest = json.loads((ur5_run / "manifest.json").read_text(encoding="utf-8"))
    listed = {f["path"] for f in manifest["files"]}
    expected = {"metrics.csv", "config/ur5.toml"} | {f"ur5/{c}.csv" for c in CONTROLLERS}
    expected |= {f"figures/ur5_{f}.{ext}" for f in FIGURES + TOOL_FIGURES for ext in ("png", "svg")}
    assert expected == listed
    assert all((ur5_run / p).stat().st_size > 0 for p in listed)
    assert manifest["scenarios"] == ["ur5"]
    # the config written is the scenario run, and runs again as it is
    config = tomllib.loads((ur5_run / "config" / "ur5.toml").read_text(encoding="utf-8"))
    assert config["plant"] == {"robot": "ur5", "gravity": 9.81}
    assert load_scenario(ur5_run / "config" / "ur5.toml").to_dict() == load_shipped("ur5").to_dict()


def test_every_controller_tracks_within_its_bound(ur5_run: Path, sign_runs: dict) -> None:
    tables = {
        "ur5": pd.read_csv(ur5_run / "metrics.csv"),
        "ur5_sign": metrics_table({"ur5_sign": sign_runs}),
    }
    for name, metrics in tables.items():
        assert list(dict.fromkeys(metrics["controller"])) == list(CONTROLLERS)
        finite = ["mse", "iae", "steady_state_error", "final_error", "control_effort",
                  "peak_torque", "chattering"]  # fmt: skip
        assert np.all(np.isfinite(metrics[finite].to_numpy(dtype=float))), name
        mean = metrics[metrics["joint"] == "mean"].set_index("controller")
        joints = metrics[metrics["joint"] != "mean"]
        for c in CONTROLLERS:
            assert mean.loc[c, "mse"] < MSE_BOUND[c], (name, c, mean.loc[c, "mse"])
            # within the effort limits, with room to spare: tanh's peak, which is smooth and the
            # same whatever rounding the loop does; see test_sign_torque_has_room for sign's
            if name == "ur5":
                peak = joints[joints["controller"] == c]["peak_torque"].to_numpy(dtype=float)
                assert np.all(peak <= 0.95 * EFFORT), (name, c, peak)
        # the paper's ranking holds on the UR5 too, and the terminal controllers converge
        assert mean.loc["ftsmc", "mse"] < mean.loc["tsmc", "mse"] < mean.loc["pdsmc", "mse"]
        ftsmc = joints[joints["controller"] == "ftsmc"]
        assert float(ftsmc["steady_state_error"].max()) < FTSMC_SS_BOUND, name
        assert np.all(np.isfinite(ftsmc["settling_time"].to_numpy(dtype=float)))
    # sign switching chatters, tanh does not
    sign = tables["ur5_sign"].query("joint == 'mean'").set_index("controller")["chattering"]
    tanh = tables["ur5"].query("joint == 'mean'").set_index("controller")["chattering"]
    assert np.all(sign / tanh > 100)


def test_sign_torque_has_room(sign_runs: dict) -> None:
    """Sign switching's torque stays clear of the effort limits in 999 samples of 1000.

    Its single largest sample is not a property of the scenario: moving q0 by N(0, 1e-12) rad
    moved the FTSMC's and TSMC's peak (joint 2) over 0.91-0.96 of the effort limit in 8 draws
    (PDSMC's stayed at 0.852), so any change of rounding in the loop decides whether one spike
    passes 0.95. The 99.9th percentile of |tau| / effort moved only over 0.874-0.897 in the same
    draws (FTSMC 0.884, TSMC 0.887 unperturbed), so it is bounded instead, with room over that spread."""
    for c, r in sign_runs.items():
        share = np.quantile(np.abs(r.tau) / EFFORT, 0.999, axis=0)
        assert np.all(share <= 0.92), (c, share)


def test_sign_runs_are_healthy(sign_runs: dict) -> None:
    for r in sign_runs.values():
        assert r.success and r.status == "ok" and r.message == ""
        assert np.all(np.abs(r.tau) <= EFFORT)
        assert np.all(np.isfinite(r.q)) and np.all(np.abs(r.qd) < 3.15)


def test_tool_paths_follow_the_desired_one(sign_runs: dict) -> None:
    setup = load_shipped("ur5_sign").build()
    paths = tool_paths(setup, sign_runs)
    assert paths is not None
    desired, actual = paths
    ur5 = robots.load("ur5")
    first = next(iter(sign_runs.values()))
    np.testing.assert_allclose(desired, ur5.tool_position(first.q_ref))
    assert desired.shape == (first.t.shape[0], 3)
    # the terminal controllers keep the tool within 0.1 mm of the desired path after the first
    # second (0.019 mm when tuned); PDSMC, slower to converge, within 3 mm after 2.5 s (0.73 mm)
    for c, path in actual.items():
        since = 2.5 if c == "pdsmc" else 1.0
        late = first.t >= since
        gap = np.linalg.norm(path[late] - desired[late], axis=1).max()
        assert gap < (3e-3 if c == "pdsmc" else 1e-4), (c, gap)
    assert tool_paths(load_shipped("tanh").build(), {}) is None  # planar: no tool path


def test_a_urdf_next_to_the_scenario_reproduces_the_planar_one(tmp_path: Path) -> None:
    # the planar paper arm written as a URDF and read back as a SerialArm is the same arm, so
    # the tanh scenario on it gives the planar scenario's metrics: this ties the two arm kinds
    # (and the URDF path relative to the scenario file) together; they agreed to 4e-12 relative
    # when written, with rounding alone between the planar and the spatial kernels
    (tmp_path / "arm.urdf").write_text(PlanarArm.paper().to_urdf(), encoding="utf-8")
    tanh = load_shipped("tanh")
    assert tanh.source is not None
    scenario = tmp_path / "urdf_tanh.toml"
    scenario.write_text(
        f'extends = "{tanh.source.as_posix()}"\nname = "urdf_tanh"\n\n[plant]\nurdf = "arm.urdf"\n',
        encoding="utf-8",
    )
    serial = load_scenario(scenario)
    setup = serial.build()
    assert isinstance(setup.nominal, SerialArm) and setup.nominal.n == 3
    assert setup.nominal == SerialArm.from_urdf(tmp_path / "arm.urdf")
    a = metrics_table({"x": run_scenario(tanh)})
    b = metrics_table({"x": run_scenario(setup)})
    columns = ["mse", "rmse", "iae", "itae", "steady_state_error", "control_effort",
               "peak_torque", "chattering"]  # fmt: skip
    np.testing.assert_allclose(
        b[columns].to_numpy(dtype=float), a[columns].to_numpy(dtype=float), rtol=1e-6, atol=1e-12
    )
    # the same file runs from the command line, and another folder's copy of its config too
    out = tmp_path / "out"
    code, _, err = invoke("run", str(scenario), "--out", str(out), "--no-figures")
    assert code == 0, err
    copied = load_scenario(out / "config" / "urdf_tanh.toml")
    assert copied.plant.urdf == str((tmp_path / "arm.urdf").resolve())


def test_a_missing_urdf_is_one_line_and_exit_2(tmp_path: Path) -> None:
    tanh = load_shipped("tanh")
    assert tanh.source is not None
    scenario = tmp_path / "s.toml"
    scenario.write_text(
        f'extends = "{tanh.source.as_posix()}"\n\n[plant]\nurdf = "arm.urdf"\n', encoding="utf-8"
    )
    code, _, err = invoke("run", str(scenario), "--out", str(tmp_path / "out"))
    assert code == 2
    line = one_line_error(err)
    assert line.startswith(f"error: {scenario}: plant.urdf: cannot read URDF file ")
    assert str(tmp_path / "arm.urdf") in line
    assert not (tmp_path / "out").exists()
