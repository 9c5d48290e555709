"""slidingarm.tune: the Pareto front, failures, limits, exports, resume and determinism."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from slidingarm import tune
from slidingarm.config import Scenario
from slidingarm.metrics import METRIC_COLUMNS
from slidingarm.study import OutputError
from slidingarm.tune.tuning import JOURNAL, knee

OBJECTIVES = ("mse", "chattering", "peak_torque")


def _dominates(a: np.ndarray, b: np.ndarray) -> bool:
    return bool(np.all(a <= b) and np.any(a < b))


def test_front_is_the_non_dominated_set_and_files_are_written(
    short: Scenario, tmp_path: Path
) -> None:
    out = tmp_path / "t"
    r = tune(short, controller="ftsmc", trials=16, out=out)
    assert r.ok and r.ran == 16 and r.kept == 0
    trials = r.trials
    assert list(trials["trial"]) == list(range(16))
    assert (trials["state"] == "complete").all()
    # every trial's gains lie within the space
    for b in r.space.bounds:
        assert trials[b.name].between(b.low, b.high).all(), b.name
    values = trials[list(OBJECTIVES)].to_numpy()
    front = trials["pareto"].to_numpy(dtype=bool)
    assert front.any()
    for i in range(len(trials)):
        dominated = any(_dominates(values[j], values[i]) for j in range(len(trials)) if j != i)
        assert front[i] == (not dominated), i
    # the files, and pareto.csv as the front sorted by the first objective
    for name in ("tune.json", JOURNAL, "trials.csv", "pareto.csv", "pareto.png", "pareto.svg"):
        assert (out / name).is_file(), name
    pareto = pd.read_csv(out / "pareto.csv")
    assert set(pareto["trial"]) == set(trials.loc[front, "trial"])
    assert pareto["mse"].is_monotonic_increasing
    np.testing.assert_array_equal(
        pd.read_csv(out / "trials.csv")[list(METRIC_COLUMNS)], trials[list(METRIC_COLUMNS)]
    )
    assert r.best in set(pareto["trial"])
    definition = json.loads((out / "tune.json").read_text())
    assert definition["definition"]["objectives"] == list(OBJECTIVES)


def test_knee_is_nearest_the_ideal_point() -> None:
    front = pd.DataFrame(
        {"trial": [4, 1, 9], "mse": [0.0, 0.4, 1.0], "chattering": [10.0, 3.0, 0.0]}
    )
    # scaled: (0, 1), (0.4, 0.3), (1, 0): the middle one is nearest the origin
    assert knee(front, ("mse", "chattering")) == 1
    assert knee(front, ("mse",)) == 4


def test_same_seed_same_trials_other_seed_other_trials(short: Scenario, tmp_path: Path) -> None:
    a = tune(short, figure=False, controller="tsmc", trials=6, out=tmp_path / "a", seed=3)
    b = tune(short, figure=False, controller="tsmc", trials=6, out=tmp_path / "b", seed=3)
    c = tune(short, figure=False, controller="tsmc", trials=6, out=tmp_path / "c", seed=4)
    pd.testing.assert_frame_equal(a.trials, b.trials)
    assert not np.allclose(a.trials["k"], c.trials["k"])


def test_rerun_keeps_finished_trials_and_extends_the_budget(
    short: Scenario, tmp_path: Path
) -> None:
    out = tmp_path / "t"
    first = tune(short, figure=False, controller="pdsmc", trials=5, out=out)
    again = tune(short, figure=False, controller="pdsmc", trials=5, out=out)
    assert (again.ran, again.kept) == (0, 5)
    pd.testing.assert_frame_equal(first.trials, again.trials)
    more = tune(short, figure=False, controller="pdsmc", trials=8, out=out)
    assert (more.ran, more.kept) == (3, 5)
    # the same eight trials as a tuning of eight from the start
    whole = tune(short, figure=False, controller="pdsmc", trials=8, out=tmp_path / "whole")
    pd.testing.assert_frame_equal(more.trials, whole.trials)


def test_changed_definition_is_refused(short: Scenario, tmp_path: Path) -> None:
    out = tmp_path / "t"
    tune(short, figure=False, controller="ftsmc", trials=2, out=out)
    before = {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()}
    with pytest.raises(OutputError, match=r"another definition \(objectives"):
        tune(short, figure=False, controller="ftsmc", trials=2, out=out, objectives=("mse",))
    with pytest.raises(OutputError, match=r"another definition \(space\.bounds\.k\.high"):
        tune(short, figure=False, controller="ftsmc", trials=2, out=out, bounds={"k": (2.0, 100.0)})
    with pytest.raises(OutputError, match=r"another definition \(seed"):
        tune(short, figure=False, controller="ftsmc", trials=2, out=out, seed=1)
    after = {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()}
    assert after == before


def test_a_folder_of_something_else_is_refused_untouched(short: Scenario, tmp_path: Path) -> None:
    out = tmp_path / "mine"
    out.mkdir()
    (out / "notes.txt").write_text("keep me")
    with pytest.raises(OutputError, match="not a tuning"):
        tune(short, figure=False, controller="ftsmc", trials=2, out=out)
    assert sorted(p.name for p in out.iterdir()) == ["notes.txt"]
    with pytest.raises(OutputError, match="not a folder"):
        tune(short, figure=False, controller="ftsmc", trials=2, out=out / "notes.txt")


def test_diverging_trials_are_recorded_as_failed(short: Scenario, tmp_path: Path) -> None:
    # k up to 1e7 rad/s²: a sign ripple k·Ts of thousands of rad/s, beyond the 1e4 rad/s limit
    r = tune(
        short,
        figure=False,
        controller="pdsmc",
        trials=12,
        out=tmp_path / "t",
        bounds={"k": (1.0, 1e7)},
    )
    failed = r.trials[r.trials["state"] == "failed"]
    assert 0 < len(failed) < 12
    assert failed["message"].str.contains("diverged|exceeds|non-finite", regex=True).all()
    assert failed[list(METRIC_COLUMNS)].isna().all().all()
    assert not failed["pareto"].any() and not failed["feasible"].any()
    assert (failed["k"] > r.trials.loc[r.trials["state"] == "complete", "k"].min()).all()
    with pytest.raises(ValueError, match="failed"):
        r.export(int(failed["trial"].iloc[0]))
    # every trial diverging: no front, and the result says so
    bad = tune(
        short,
        figure=False,
        controller="pdsmc",
        trials=3,
        out=tmp_path / "bad",
        bounds={"k": (1e7, 1e8)},
    )
    assert bad.status == "all_failed" and not bad.ok and bad.pareto.empty
    with pytest.raises(ValueError, match="no Pareto front"):
        _ = bad.best


def test_limits_are_constraints(short: Scenario, tmp_path: Path) -> None:
    free = tune(short, figure=False, controller="ftsmc", trials=12, out=tmp_path / "free")
    cap = float(free.trials["peak_torque"].median())
    r = tune(
        short,
        figure=False,
        controller="ftsmc",
        trials=12,
        out=tmp_path / "cap",
        limits={"peak_torque": cap},
    )
    t = r.trials
    assert (t["feasible"] == (t["peak_torque"] <= cap)).all()
    assert 0 < t["feasible"].sum() < len(t)
    assert (r.pareto["peak_torque"] <= cap).all()
    # the front of the feasible trials: none dominated by another feasible trial
    ok = t[t["feasible"]][list(OBJECTIVES)].to_numpy()
    for row in r.pareto[list(OBJECTIVES)].to_numpy():
        assert not any(_dominates(o, row) for o in ok)
    impossible = tune(
        short,
        figure=False,
        controller="ftsmc",
        trials=4,
        out=tmp_path / "no",
        limits={"peak_torque": 1e-3},
    )
    assert impossible.status == "infeasible" and impossible.pareto.empty


def test_tpe_and_one_objective(short: Scenario, tmp_path: Path) -> None:
    r = tune(
        short,
        figure=False,
        controller="ftsmc",
        trials=12,
        out=tmp_path / "t",
        sampler="tpe",
        objectives=("iae",),
    )
    assert r.ok and len(r.pareto) == 1
    assert r.best == int(r.trials.loc[r.trials["iae"].idxmin(), "trial"])


def test_export_reproduces_the_reported_objectives(short: Scenario, tmp_path: Path) -> None:
    from slidingarm.config import load_scenario
    from slidingarm.study import run

    r = tune(short, figure=False, controller="ftsmc", trials=8, out=tmp_path / "t")
    best = r.best
    path = r.export("best")
    assert path == tmp_path / "t" / "exports" / f"trial-{best}.toml"
    exported = load_scenario(path)
    assert [c.key for c in exported.controllers] == ["ftsmc"]
    metrics = run(exported, tmp_path / "run", figures=False).metrics
    mean = metrics[metrics["joint"] == "mean"].iloc[0]
    row = r.pareto[r.pareto["trial"] == best].iloc[0]
    for name in OBJECTIVES:
        assert float(mean[name]) == pytest.approx(float(row[name]), rel=1e-12, abs=0.0), name
    # the file states them in its head, exactly
    head = path.read_text().splitlines()[1]
    for name in OBJECTIVES:
        assert f"{name} = {float(row[name])!r}" in head


def test_bad_arguments_name_the_parameter(short: Scenario, tmp_path: Path) -> None:
    from slidingarm.config import ConfigError

    cases = [
        ({"objectives": ("mse", "speed")}, "objectives"),
        ({"objectives": ()}, "objectives"),
        ({"objectives": "mse"}, "objectives"),
        ({"objectives": ("mse", "mse")}, "objectives"),
        ({"limits": {"peak": 1.0}}, "limits"),
        ({"limits": {"peak_torque": float("nan")}}, "limits"),
        ({"trials": 0}, "trials"),
        ({"robust": -1}, "robust"),
        ({"statistic": "median"}, "statistic"),
        ({"sampler": "cmaes"}, "sampler"),
        ({"seed": -2}, "seed"),
        ({"controller": "lqr"}, "controller"),
    ]
    for change, key in cases:
        kwargs = {"controller": "ftsmc", "trials": 2, "out": tmp_path / "x", **change}
        with pytest.raises(ConfigError) as info:
            tune(short, **kwargs)
        assert info.value.path == key, change
    assert not (tmp_path / "x").exists()


KILLED = """
import sys
from slidingarm.config import load_scenario
from slidingarm.tune import tune

def progress(what, done, total):
    print(done, flush=True)

tune(load_scenario(sys.argv[1]), controller="ftsmc", trials=int(sys.argv[3]), out=sys.argv[2],
     progress=progress)
"""


def test_kill_9_then_resume_equals_an_uninterrupted_tuning(
    make_short,
    tmp_path: Path,  # type: ignore[no-untyped-def]
) -> None:
    from slidingarm.config import load_scenario

    path = make_short()
    out = tmp_path / "killed"
    n = 30
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    proc = subprocess.Popen(
        [sys.executable, "-c", textwrap.dedent(KILLED), str(path), str(out), str(n)],
        stdout=subprocess.PIPE, text=True, env=env,
    )  # fmt: skip
    assert proc.stdout is not None
    done = 0
    for line in proc.stdout:
        done = int(line)
        if done >= 5:
            break
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    assert 5 <= done < n, "the tuning finished before it could be killed"
    scenario = load_scenario(path)
    resumed = tune(scenario, figure=False, controller="ftsmc", trials=n, out=out)
    assert resumed.kept >= 5 and resumed.ran == n - resumed.kept
    fresh = tune(scenario, figure=False, controller="ftsmc", trials=n, out=tmp_path / "fresh")
    pd.testing.assert_frame_equal(resumed.trials, fresh.trials)
    pd.testing.assert_frame_equal(resumed.pareto, fresh.pareto)
