"""Robust tuning: each trial scored on the scenario's [sweep] draws, the same for every trial."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from slidingarm import sweep, tune
from slidingarm.config import ConfigError, Scenario, load_scenario
from slidingarm.study import scenario_path
from slidingarm.tune import reduce, tuning_scenario

ROBUST = """
extends = "{base}"
name = "rob"

[simulation]
t_final = 0.3

[sweep]
seed = 5
"mismatch.mass_error" = {{ normal = [0, 0.1] }}
"mismatch.payload" = {{ uniform = [0, 0.5] }}
"controllers[1].eps_e" = {{ loguniform = [1e-8, 1e-7] }}
"controllers[2].eps_e" = {{ loguniform = [1e-8, 1e-6] }}
{extra}
"""


def _robust(tmp_path: Path, extra: str = "") -> Scenario:
    p = tmp_path / "rob.toml"
    p.write_text(ROBUST.format(base=scenario_path("tanh").as_posix(), extra=extra))
    return load_scenario(p)


def test_draws_follow_the_kept_controller(tmp_path: Path) -> None:
    base, _ = tuning_scenario(_robust(tmp_path), "ftsmc")
    assert base.sweep is not None
    keys = list(base.sweep.distributions())
    # ftsmc was controllers[2]: its key is renumbered, tsmc's (controllers[1]) is dropped
    assert keys == ["mismatch.mass_error", "mismatch.payload", "controllers[0].eps_e"]
    assert base.sweep.distributions()["controllers[0].eps_e"].to_dict() == {
        "loguniform": [1e-8, 1e-6]
    }


@pytest.mark.parametrize("statistic", ["mean", "p90"])
def test_robust_objectives_are_the_statistic_over_the_sweep_draws(
    tmp_path: Path, statistic: str
) -> None:
    k = 6
    r = tune(
        _robust(tmp_path), figure=False, controller="ftsmc", trials=4, out=tmp_path / "t",
        robust=k, statistic=statistic,  # type: ignore[arg-type]
    )  # fmt: skip
    assert r.ok
    trial = r.best
    exported = load_scenario(r.export(trial))
    # the same draws again, by `slidingarm sweep` of the exported file (other chunks)
    swept = sweep(exported, runs=k, chunk=4, out=tmp_path / "sweep", figures=False)
    mean = swept.table[swept.table["joint"] == "mean"].sort_values("run")
    assert list(mean["run"]) == list(range(k)) and mean["ok"].all()
    row = r.trials[r.trials["trial"] == trial].iloc[0]
    for name in ("mse", "chattering", "peak_torque", "iae"):
        expected = reduce(mean[name].to_numpy(dtype=np.float64), statistic)  # type: ignore[arg-type]
        assert float(row[name]) == pytest.approx(expected, rel=1e-12, abs=0.0), name
    # the draws differ (a robust score is not the nominal run repeated)
    assert mean["mse"].nunique() == k


def test_a_diverging_draw_fails_the_trial(tmp_path: Path) -> None:
    # k of 1e7 rad/s² and more: k·Ts/width > 1e5, the sampled reaching law blows up on a draw
    r = tune(
        _robust(tmp_path), figure=False, controller="pdsmc", trials=3, out=tmp_path / "t",
        robust=4, bounds={"k": (1e7, 1e8)},
    )  # fmt: skip
    failed = r.trials[r.trials["state"] == "failed"]
    assert len(failed) == 3 and r.status == "all_failed"
    assert failed["message"].str.match(r"draw \d: ").all()


def test_robust_needs_draws_that_leave_the_tuned_gains_alone(tmp_path: Path) -> None:
    nominal = load_scenario(scenario_path("sign"))
    with pytest.raises(ConfigError) as info:
        tune(nominal, controller="ftsmc", trials=2, out=tmp_path / "a", robust=3)
    assert info.value.path == "sweep"
    clash = _robust(tmp_path, '"gains.k" = { uniform = [10, 40] }')
    with pytest.raises(ConfigError) as info:
        tune(clash, controller="ftsmc", trials=2, out=tmp_path / "b", robust=3)
    assert info.value.path == 'sweep."gains.k"' and "--bound k=fixed" in str(info.value)
    # with k out of the tuning, its draws are allowed
    r = tune(
        clash, figure=False, controller="ftsmc", trials=2, out=tmp_path / "c", robust=3,
        bounds={"k": "fixed"},
    )  # fmt: skip
    assert r.ok and "k" not in r.trials.columns
    assert not (tmp_path / "a").exists() and not (tmp_path / "b").exists()
