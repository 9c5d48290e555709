"""Tests for slidingarm.sweep: staging, determinism, resume after kill -9, refused folders,
diverging and refused runs, the summary, Dask, and the CLI's errors."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pandas.testing as pdt
import pytest

import slidingarm
from slidingarm.config import ConfigError, scenario_from_dict
from slidingarm.study import load_shipped
from slidingarm.sweep import Distribution, SweepError, run_chunk, summarize
from slidingarm.sweep.run import definition_of
from slidingarm.sweep.space import applied
from slidingarm.sweep.staging import Stager, draw_run, key_shapes, run_seed

SRC = Path(slidingarm.__file__).resolve().parents[1]

VARY = {
    "gains.k": "uniform(10, 40)",
    "mismatch.mass_error": {"normal": [0.0, 0.1]},
    "mismatch.payload": {"uniform": [0.0, 1.0]},
    "simulation.q0": {"normal": [0.0, 0.05], "offset": True},
}


def tiny(t_final: float = 0.1, **extra) -> slidingarm.config.Scenario:
    """The tanh scenario, cut short, with a noisy sensor and a sinusoidal disturbance."""
    d = load_shipped("tanh").to_dict()
    d["simulation"]["t_final"] = t_final
    d["sensor"]["noise"] = {"sigma": 1e-4}
    d["disturbances"] = [{"kind": "sinusoidal", "amplitude": 0.5, "frequency": 2.0}]
    d.update(extra)
    return scenario_from_dict(d)


@pytest.fixture(scope="module")
def scenario():
    return tiny()


def test_stager_equals_the_full_build(scenario, monkeypatch):
    """The fast path builds the very objects a full validation and build gives."""
    dists = {
        **{k: (Distribution.parse(k, v) if isinstance(v, str) else Distribution.from_spec(k, v))
           for k, v in VARY.items()},
        "sensor.noise.sigma": Distribution("loguniform", (1e-5, 1e-3)),
        "disturbances[0].amplitude": Distribution("uniform", (0.0, 2.0)),
        "controllers[2].k": Distribution("uniform", (5.0, 50.0)),
        "gains.width": Distribution("choice", (0.02, 0.05)),
        "simulation.qd0[1]": Distribution("uniform", (-0.1, 0.1)),
    }  # fmt: skip
    stager = Stager(scenario)
    shapes = key_shapes(scenario, dists)
    assert shapes["simulation.q0"] == 3 and shapes["gains.k"] == 0
    bases = stager.bases(dists)
    for i in range(6):
        values = draw_run(11, i, dists, shapes, bases)
        with monkeypatch.context() as m:  # the fast path, not the full one
            m.setattr("slidingarm.sweep.staging.applied", lambda *a: pytest.fail("full path"))
            fast = stager.build(values)
        _, full = applied(scenario, values)
        assert fast.plant.to_dict() == full.plant.to_dict()
        assert fast.sensor.to_dict() == full.sensor.to_dict()
        assert [d.to_dict() for d in fast.disturbances] == [d.to_dict() for d in full.disturbances]
        assert fast.q0 == full.q0 and fast.qd0 == full.qd0
        assert list(fast.controllers) == list(full.controllers)
        for label, c in fast.controllers.items():
            assert c.to_dict() == full.controllers[label].to_dict()
    # the offset is added to the scenario's q0
    values = draw_run(11, 0, dists, shapes, bases)
    assert np.all(np.abs(np.subtract(values["simulation.q0"], scenario.simulation.q0)) < 0.3)
    # a value refused by a field validated alone gives the full path's error
    for key, bad in (("gains.k", -1.0), ("simulation.qd0[1]", float("inf")),
                     ("controllers[2].k", 0.0), ("mismatch.payload", -0.5)):  # fmt: skip
        with pytest.raises(ConfigError) as fast_error:
            stager.build({**values, key: bad})
        with pytest.raises(ConfigError) as full_error:
            applied(scenario, {**values, key: bad})
        assert str(fast_error.value) == str(full_error.value) and key in str(fast_error.value)


def test_draws_depend_on_seed_and_index_only(scenario):
    d1 = {"gains.k": Distribution("uniform", (10.0, 40.0))}
    d2 = {**d1, "mismatch.payload": Distribution("uniform", (0.0, 1.0))}
    s1, s2 = key_shapes(scenario, d1), key_shapes(scenario, d2)
    b1, b2 = Stager(scenario).bases(d1), Stager(scenario).bases(d2)
    a = [draw_run(5, i, d1, s1, b1)["gains.k"] for i in range(50)]
    b = [draw_run(5, i, d2, s2, b2)["gains.k"] for i in range(50)]
    assert a == b  # adding a key leaves the others' draws as they were
    assert len(set(a)) == 50
    assert draw_run(6, 0, d1, s1, b1) != draw_run(5, 0, d1, s1, b1)
    seeds = [run_seed(5, i) for i in range(100)]
    assert len(set(seeds)) == 100 and all(0 <= s < 2**32 for s in seeds)


def test_table_and_every_controller_on_the_same_draw(scenario, tmp_path):
    r = slidingarm.sweep(scenario, runs=5, out=tmp_path / "s", vary=VARY, chunk=2, figures=False)
    t = r.table
    assert len(t) == 5 * 3 * 4  # runs × controllers × (3 joints + mean)
    assert list(t["controller"].unique()) == ["pdsmc", "tsmc", "ftsmc"]
    assert list(t.columns[:3]) == ["run", "controller", "joint"]
    for col in ("gains.k", "mismatch.mass_error", "simulation.q0[0]", "simulation.q0[2]", "seed"):
        assert col in t.columns
    per_run = t.groupby("run")
    for col in ("gains.k", "mismatch.payload", "simulation.q0[1]", "seed"):
        assert (per_run[col].nunique() == 1).all()  # one draw shared by every controller
    assert t["gains.k"].between(10, 40).all()
    assert t["ok"].all() and (t["status"] == "ok").all() and r.status == "ok"
    # the metrics are those of the batch engine on the same run
    row = t[(t["run"] == 3) & (t["controller"] == "ftsmc") & (t["joint"] == "mean")].iloc[0]
    values = {
        "gains.k": row["gains.k"],
        "mismatch.mass_error": row["mismatch.mass_error"],
        "mismatch.payload": row["mismatch.payload"],
        "simulation.q0": [row[f"simulation.q0[{j}]"] for j in range(3)],
    }
    _, setup = applied(scenario, values)
    opts = {**setup.options(), "seed": int(row["seed"])}
    one = slidingarm.simulate(setup.plant, setup.controllers["ftsmc"], setup.reference, **opts)
    from slidingarm.metrics import summary

    ref = summary(one)
    ref_mean = ref[ref["joint"] == "mean"].iloc[0]
    for m in ("mse", "peak_torque", "chattering"):
        assert row[m] == pytest.approx(ref_mean[m], rel=1e-12)
    # the folder
    out = tmp_path / "s"
    assert json.loads((out / "sweep.json").read_text())["hash"] == r.definition.hash
    assert sorted(p.name for p in (out / "shards").iterdir()) == [
        "chunk-000000.parquet",
        "chunk-000001.parquet",
        "chunk-000002.parquet",
    ]
    pdt.assert_frame_equal(pd.read_parquet(out / "results.parquet"), t)
    assert (out / "summary.csv").is_file()


def test_same_results_whatever_the_chunking_and_threads(scenario, tmp_path):
    a = slidingarm.sweep(scenario, runs=7, out=tmp_path / "a", vary=VARY, chunk=2, threads=2,
                         figures=False)  # fmt: skip
    b = slidingarm.sweep(scenario, runs=7, out=tmp_path / "b", vary=VARY, chunk=7, threads=1,
                         figures=False)  # fmt: skip
    pdt.assert_frame_equal(a.table, b.table)
    assert a.definition.hash != b.definition.hash  # the chunk is part of the definition


def test_resume_after_kill_9(scenario, tmp_path):
    """Kill the sweep with SIGKILL once some shards exist; the rerun computes only the rest
    and its table equals a fresh run's."""
    out = tmp_path / "killed"
    spec = tmp_path / "scenario.json"
    spec.write_text(json.dumps(scenario.to_dict()))
    script = tmp_path / "drive.py"
    # each chunk takes at least 0.2 s, so the kill falls in the middle of the sweep
    script.write_text(
        textwrap.dedent(
            f"""
            import json, time
            import slidingarm.sweep.run as run
            from slidingarm.config import scenario_from_dict

            inner = run.run_chunk

            def slow(definition, c):
                time.sleep(0.2)
                return inner(definition, c)

            run.run_chunk = slow
            s = scenario_from_dict(json.loads(open({str(spec)!r}).read()))
            run.sweep(s, runs=20, out={str(out)!r}, vary={VARY!r}, chunk=2, threads=1,
                      figures=False)
            """
        )
    )
    env = {**os.environ, "PYTHONPATH": str(SRC), "MPLBACKEND": "Agg"}
    proc = subprocess.Popen([sys.executable, str(script)], env=env)
    shards = out / "shards"
    deadline = time.monotonic() + 120
    try:
        while time.monotonic() < deadline:
            if shards.is_dir() and len(list(shards.glob("chunk-*.parquet"))) >= 3:
                break
            if proc.poll() is not None:
                pytest.fail(f"the sweep ended (status {proc.returncode}) before it was killed")
            time.sleep(0.02)
        else:
            pytest.fail("no shard was written in 120 s")
        os.kill(proc.pid, signal.SIGKILL)
    finally:
        proc.wait()
    done = {p.name: p.stat().st_mtime_ns for p in shards.glob("chunk-*.parquet")}
    assert 3 <= len(done) < 10
    assert not (out / "results.parquet").exists()
    resumed = slidingarm.sweep(scenario, runs=20, out=out, vary=VARY, chunk=2, threads=1,
                               figures=False)  # fmt: skip
    assert resumed.resumed == len(done) and resumed.computed == 10 - len(done)
    for name, mtime in done.items():  # finished shards were not rewritten
        assert (shards / name).stat().st_mtime_ns == mtime
    assert not list(shards.glob(".*"))  # no temporary file left
    fresh = slidingarm.sweep(scenario, runs=20, out=tmp_path / "fresh", vary=VARY, chunk=2,
                             figures=False)  # fmt: skip
    pdt.assert_frame_equal(
        pd.read_parquet(out / "results.parquet"),
        pd.read_parquet(tmp_path / "fresh" / "results.parquet"),
    )
    pdt.assert_frame_equal(resumed.table, fresh.table)


def test_changed_definition_and_foreign_folder_refused(scenario, tmp_path):
    out = tmp_path / "s"
    slidingarm.sweep(scenario, runs=2, out=out, vary=VARY, figures=False)
    before = sorted((p.name, p.stat().st_mtime_ns) for p in out.rglob("*"))
    for change in ({"runs": 3}, {"seed": 9}, {"vary": {"gains.k": "uniform(10, 41)"}}):
        kwargs = {"runs": 2, "vary": VARY, **change}
        with pytest.raises(SweepError, match="holds a different sweep"):
            slidingarm.sweep(scenario, out=out, figures=False, **kwargs)
    assert sorted((p.name, p.stat().st_mtime_ns) for p in out.rglob("*")) == before
    other = tmp_path / "other"
    other.mkdir()
    (other / "notes.txt").write_text("mine")
    with pytest.raises(SweepError, match="something other than a slidingarm sweep"):
        slidingarm.sweep(scenario, runs=2, out=other, vary=VARY, figures=False)
    assert [p.name for p in other.iterdir()] == ["notes.txt"]
    afile = tmp_path / "file"
    afile.write_text("x")
    with pytest.raises(SweepError, match="not a folder"):
        slidingarm.sweep(scenario, runs=2, out=afile, vary=VARY, figures=False)


def test_diverging_and_refused_runs_are_recorded(tmp_path):
    s = tiny(disturbances=[{"kind": "constant", "value": 0.0}])
    vary = {
        "disturbances[0].value": {"choice": [0.0, 1e9]},  # a runaway torque diverges
        "mismatch.mass_error": {"normal": [0.0, 1.0]},  # below -1 is refused by the scenario
    }
    r = slidingarm.sweep(s, runs=16, out=tmp_path / "d", vary=vary, chunk=5, figures=False)
    t = r.table
    mean = t[t["joint"] == "mean"]
    diverged = mean[mean["disturbances[0].value"] == 1e9]
    refused = mean[mean["mismatch.mass_error"] <= -1]
    fine = mean[(mean["disturbances[0].value"] == 0) & (mean["mismatch.mass_error"] > -1)]
    assert len(diverged) and len(refused) and len(fine)
    bad = diverged[diverged["mismatch.mass_error"] > -1]
    assert not bad["ok"].any() and (bad["status"] != "ok").all() and bad["mse"].isna().all()
    assert (bad["message"].str.len() > 0).all()
    assert (refused["status"] == "refused").all()
    assert refused["message"].str.contains("mismatch.mass_error").all()
    assert fine["ok"].all() and np.isfinite(fine["mse"]).all()
    assert r.failed == len(mean) - len(fine) and r.status != "ok"
    rate = r.summary[(r.summary["metric"] == "success_rate")].set_index("controller")
    assert rate.loc["ftsmc", "estimate"] == pytest.approx(len(fine) / 3 / 16)


def test_summary_median_and_intervals():
    rng = np.random.default_rng(0)
    rows = []
    for run in range(200):
        for c, scale in (("a", 1.0), ("b", 2.0)):
            x = rng.exponential(scale)
            ok = run % 10 != 0 or c == "a"
            for joint in ("1", "mean"):
                rows.append({"run": run, "controller": c, "joint": joint, "mse": x, "ok": ok})
    t = pd.DataFrame(rows)
    s = summarize(t, metrics=["mse"], seed=1)
    med = s[(s["metric"] == "mse") & (s["joint"] == "mean")].set_index("controller")
    for c in ("a", "b"):
        x = t[(t["controller"] == c) & (t["joint"] == "mean") & t["ok"]]["mse"]
        assert med.loc[c, "estimate"] == pytest.approx(np.median(x))
        assert med.loc[c, "ci_low"] < med.loc[c, "estimate"] < med.loc[c, "ci_high"]
        # the median's standard error is about 1.2533 sigma / sqrt(n) for a normal; the
        # exponential's is 1/(2 f(m) sqrt(n)) = scale / sqrt(n): the 95 % CI spans ~4 of them
        width = med.loc[c, "ci_high"] - med.loc[c, "ci_low"]
        se = (1.0 if c == "a" else 2.0) / np.sqrt(len(x))
        assert 2.0 * se < width < 7.0 * se
    assert med.loc["b", "n"] == 180
    rate = s[s["metric"] == "success_rate"].set_index("controller")
    assert rate.loc["a", "estimate"] == 1.0 and rate.loc["a", "ci_high"] == pytest.approx(1.0)
    # Wilson at k = n = 200: lower bound n / (n + z^2)
    assert rate.loc["a", "ci_low"] == pytest.approx(200 / (200 + 1.959964**2), rel=1e-6)
    assert rate.loc["b", "estimate"] == pytest.approx(0.9)
    assert rate.loc["b", "ci_low"] < 0.9 < rate.loc["b", "ci_high"]
    # seeded: the same summary twice
    pdt.assert_frame_equal(s, summarize(t, metrics=["mse"], seed=1))


def test_dask_local_cluster_gives_the_same_table(scenario, tmp_path):
    local = slidingarm.sweep(scenario, runs=6, out=tmp_path / "l", vary=VARY, chunk=2,
                             figures=False)  # fmt: skip
    env = os.environ.get("PYTHONPATH", "")
    os.environ["PYTHONPATH"] = os.pathsep.join([str(SRC), env]) if env else str(SRC)
    try:
        dask = slidingarm.sweep(scenario, runs=6, out=tmp_path / "d", vary=VARY, chunk=2,
                                executor="local:2", figures=False)  # fmt: skip
        # a scheduler someone else started, reached by its address (--dask ADDRESS)
        from distributed import LocalCluster

        with LocalCluster(n_workers=1, threads_per_worker=1, processes=True,
                          dashboard_address=None) as cluster:  # fmt: skip
            remote = slidingarm.sweep(scenario, runs=6, out=tmp_path / "r", vary=VARY, chunk=3,
                                      executor=cluster.scheduler_address, figures=False)  # fmt: skip
    finally:
        if env:
            os.environ["PYTHONPATH"] = env
        else:
            del os.environ["PYTHONPATH"]
    pdt.assert_frame_equal(local.table, dask.table)
    pdt.assert_frame_equal(local.table, remote.table)


def test_run_chunk_is_a_pure_function(scenario):
    d = definition_of(scenario, runs=4, vary=VARY, seed=3, chunk=2)
    a, b = run_chunk(d, 1), run_chunk(d, 1)
    pdt.assert_frame_equal(a, b)
    assert sorted(a["run"].unique()) == [2, 3]
    import pickle

    assert pickle.loads(pickle.dumps(d)) == d


def test_bad_calls_name_the_problem(scenario, tmp_path):
    cases = [
        ({"vary": {}}, "nothing to vary"),
        ({"vary": {"gains.kk": "uniform(1, 2)"}}, "gains.kk"),
        ({"vary": {"simulation.dt": "uniform(1e-4, 2e-4)"}}, "cannot vary"),
        ({"vary": {"sensor.noise.sigma": "+uniform(0, 1)", "simulation.seed": "uniform(0, 1)"}},
         "simulation.seed"),
        ({"vary": VARY, "runs": None}, "--runs"),
        ({"vary": VARY, "executor": "local:0"}, "local:W"),
        ({"vary": VARY, "executor": 3}, "executor"),
    ]  # fmt: skip
    for kwargs, words in cases:
        kwargs = {"runs": 2, **kwargs}
        with pytest.raises(ConfigError, match=words):
            slidingarm.sweep(scenario, out=tmp_path / "x", figures=False, **kwargs)
    assert not (tmp_path / "x").exists()  # nothing was written


def run_cli(*args: str, cwd: Path) -> tuple[int, str, str]:
    """The CLI in this process (as tests/test_cli.py does), from ``cwd``."""
    from typer.testing import CliRunner

    from slidingarm.cli import app

    here = Path.cwd()
    os.chdir(cwd)
    try:
        result = CliRunner().invoke(app, list(args))
    finally:
        os.chdir(here)
    return result.exit_code, result.stdout, result.stderr


def test_cli(tmp_path):
    scen = tmp_path / "tiny.toml"
    scen.write_text(
        textwrap.dedent(
            """
            extends = "{base}"
            name = "tiny"
            [simulation]
            t_final = 0.1
            [sweep]
            runs = 4
            seed = 3
            "gains.k" = {{ uniform = [10, 40] }}
            """
        ).format(base=load_shipped("tanh").source)
    )
    args = ["sweep", str(scen), "--out", "o", "--vary", "simulation.q0=+normal(0,0.05)",
            "--chunk", "3", "--no-figures"]  # fmt: skip
    code, out, err = run_cli(*args, cwd=tmp_path)
    assert code == 0, err
    assert "4 draws × 3 controllers in 2 chunks" in out
    assert "gains.k ~ uniform(10, 40), simulation.q0 ~ +normal(0, 0.05)" in out
    assert "| ftsmc |" in out and err == ""  # no progress bar off a terminal
    table = pd.read_parquet(tmp_path / "o" / "results.parquet")
    assert len(table) == 4 * 3 * 4
    code, out, err = run_cli(*args, cwd=tmp_path)
    assert code == 0 and "(0 run now, 2 resumed)" in out
    for extra, words in (
        (["--out", "o", "--runs", "5"], "holds a different sweep"),
        (["--out", "p", "--vary", "gains.kk=uniform(1,2)"], "gains.kk"),
        (["--out", "p", "--vary", "gains.k=gauss(1,2)"], "--vary gains.k"),
        (["--out", "p", "--vary", "nothing"], "KEY=DIST"),
        (["--out", "p", "--dask", "local:x"], "local:W"),
        (["--out", "p", "--runs", "0"], "runs: must be an integer >= 1"),
        (["--out", "p", "--chunk", "0"], "chunk: must be an integer >= 1"),
        (["--out", "p", "--seed", "-1"], "seed: must be an integer >= 0"),
    ):
        code, out, err = run_cli("sweep", str(scen), *extra, cwd=tmp_path)
        assert code == 2, err
        lines = err.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("error: ") and words in lines[0]
        assert "Traceback" not in err
    assert not (tmp_path / "p").exists()
