"""Tests for slidingarm.sweep.space: distributions, dotted keys, apply, numeric_keys."""

from __future__ import annotations

import math
import pickle

import numpy as np
import pytest

from slidingarm.config import ConfigError, scenario_from_dict
from slidingarm.study import load_shipped
from slidingarm.sweep import Distribution, apply, numeric_keys
from slidingarm.sweep.space import get_value, parse_key

N = 200_000


@pytest.fixture(scope="module")
def tanh():
    return load_shipped("tanh")


@pytest.mark.parametrize(
    "spec",
    [
        {"uniform": [10.0, 40.0]},
        {"normal": [0.0, 0.05]},
        {"loguniform": [1e-5, 1e-3]},
        {"choice": [1.0, 2.0, 7.0]},
    ],
)
def test_moments(spec):
    """Sample mean and standard deviation within 5 standard errors of the exact ones."""
    d = Distribution.from_spec("x", spec)
    x = d.draw(np.random.default_rng(7), N)
    assert x.shape == (N,) and x.dtype == np.float64
    se_mean = d.std() / math.sqrt(N)
    assert abs(x.mean() - d.mean()) < 5 * se_mean
    # the standard error of the sample std is about std / sqrt(2N) for light tails; the
    # loguniform's is wider, hence 10
    assert abs(x.std() - d.std()) < 10 * d.std() / math.sqrt(2 * N)


def test_support_and_exact_values():
    rng = np.random.default_rng(1)
    u = Distribution("uniform", (10.0, 40.0)).draw(rng, 10_000)
    assert u.min() >= 10.0 and u.max() < 40.0
    lu = Distribution("loguniform", (1e-5, 1e-3)).draw(rng, 10_000)
    assert lu.min() >= 1e-5 and lu.max() < 1e-3
    # log-uniform: a quarter of the draws in each quarter of the log range
    frac = np.mean(np.log10(lu) < -4.5)
    assert abs(frac - 0.25) < 0.02
    c = Distribution("choice", (1.0, 2.0, 7.0)).draw(rng, 9000)
    assert set(np.unique(c)) == {1.0, 2.0, 7.0}
    assert np.all(np.abs(np.bincount(c.astype(int))[[1, 2, 7]] / 9000 - 1 / 3) < 0.02)
    assert Distribution("normal", (3.0, 0.0)).draw(rng, 5).tolist() == [3.0] * 5


def test_draw_shape_and_determinism():
    d = Distribution("normal", (0.0, 1.0))
    a = d.draw(np.random.default_rng(3), (4, 3))
    b = d.draw(np.random.default_rng(3), (4, 3))
    assert a.shape == (4, 3)
    np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize(
    ("spec", "words"),
    [
        ({"uniform": [1, 0]}, "lo < hi"),
        ({"uniform": [0, 1], "normal": [0, 1]}, "exactly one"),
        ({}, "exactly one"),
        ({"gauss": [0, 1]}, "unknown key 'gauss'"),
        ({"loguniform": [0, 1]}, "0 < lo < hi"),
        ({"normal": [0, -1]}, "sigma >= 0"),
        ({"normal": [0, 1, 2]}, "two numbers"),
        ({"choice": []}, "non-empty"),
        ({"uniform": "a"}, "list of numbers"),
        ({"uniform": [0, float("nan")]}, "finite"),
        ({"uniform": [0, True]}, "finite numbers"),
        ({"uniform": [0, 1], "offset": "yes"}, "true or false"),
        (3, "must be a table"),
    ],
)
def test_bad_tables_name_the_key(spec, words):
    with pytest.raises(ConfigError) as exc:
        Distribution.from_spec("gains.k", spec)
    assert 'sweep."gains.k"' in str(exc.value)
    assert words in str(exc.value)


def test_parse_command_line():
    assert Distribution.parse("k", "uniform(10, 40)") == Distribution("uniform", (10.0, 40.0))
    assert Distribution.parse("q", "+normal(0,0.05)") == Distribution(
        "normal", (0.0, 0.05), offset=True
    )
    assert Distribution.parse("q", "{ normal = [0, 0.05], offset = true }").offset
    for bad in ("uniform(1)", "gauss(0, 1)", "uniform(a, b)", "{ uniform = [2, 1] }", "5"):
        with pytest.raises(ConfigError, match="--vary k"):
            Distribution.parse("k", bad)


def test_round_trip_and_pickle():
    for d in (
        Distribution("uniform", (0.0, 1.0)),
        Distribution("normal", (0.0, 0.05), offset=True),
        Distribution("choice", (1.0, 3.0)),
    ):
        assert Distribution.from_spec("x", d.to_dict()) == d
        assert pickle.loads(pickle.dumps(d)) == d
    with pytest.raises(AttributeError):
        d.kind = "normal"  # type: ignore[misc]


def test_parse_key():
    assert parse_key("disturbances[0].amplitude") == ["disturbances", 0, "amplitude"]
    assert parse_key("simulation.q0[1]") == ["simulation", "q0", 1]
    for bad in ("", "gains..k", "gains.k[x]", "1abc"):
        with pytest.raises(ConfigError):
            parse_key(bad)


def test_apply_sets_keys_and_keeps_the_rest(tanh):
    s = apply(
        tanh,
        {
            "gains.k": 30.0,
            "mismatch.mass_error": np.array([0.1, -0.2, 0.0]),
            "simulation.q0[1]": 1.4,
            "controllers[2].k": 5.0,
            "mismatch.payload": np.float64(0.5),
        },
    )
    assert s.gains.k == 30.0
    assert s.mismatch.mass_error == [0.1, -0.2, 0.0]
    assert s.simulation.q0 == [0.7, 1.4, 0.5]
    assert s.controllers[2].k == 5.0 and s.controllers[0].k is None
    assert s.mismatch.payload == 0.5
    assert s.switching == tanh.switching and s.key == tanh.key
    assert tanh.gains.k == 20.0  # the original is untouched
    # builds what it says: FTSMC's own k, the others the shared one
    setup = s.build()
    assert np.allclose(setup.controllers["ftsmc"].to_dict()["k"], 5.0)
    assert np.allclose(setup.controllers["pdsmc"].to_dict()["k"], 30.0)
    # equal to the round trip through a mapping
    d = tanh.to_dict()
    d["gains"]["k"] = 30.0
    assert apply(tanh, {"gains.k": 30.0}).to_dict() == scenario_from_dict(d).to_dict()


def test_apply_table_path_stays_anchored(tmp_path):
    (tmp_path / "ref.csv").write_text(
        "t,q1,q2,q3\n0,0,0,0\n0.5,0.1,0.2,0.3\n1,0.2,0.3,0.4\n1.5,0.3,0.3,0.3\n2,0.2,0.3,0.4\n"
    )
    d = load_shipped("tanh").to_dict()
    d["reference"] = {"kind": "table", "path": "ref.csv", "spline": "cubic"}
    d["simulation"]["t_final"] = 1.0
    s = scenario_from_dict(d, base_dir=tmp_path)
    out = apply(s, {"gains.k": 25.0})
    assert out.build().reference.n == 3


@pytest.mark.parametrize(
    ("values", "key", "words"),
    [
        ({"gains.kk": 1.0}, "gains.kk", "no such key"),
        ({"gains": 1.0}, "gains", "is a table"),
        ({"switching": 1.0}, "switching", "not a numeric key"),
        ({"simulation.seed": 3.0}, "simulation.seed", "integer key"),
        ({"gains.p": 3}, "gains.p", "integer key"),
        ({"mismatch.mass_error": -2.0}, "mismatch.mass_error", "> -1"),
        ({"simulation.q0": [1.0]}, "simulation.q0", "3 joints"),
        ({"simulation.q0[5]": 1.0}, "simulation.q0[5]", "index 5"),
        ({"sensor.noise.sigma": 1e-3}, "sensor.noise.sigma", "sensor.noise is not set"),
        ({"disturbances[0].amplitude": 1.0}, "disturbances[0].amplitude", "0 entries"),
        ({"controllers[5].k": 1.0}, "controllers[5].k", "3 entries"),
        ({"gains.k": float("nan")}, "gains.k", "finite"),
        ({"gains.k": -1.0}, "gains.k", "refused"),
        ({"sweep.runs": 3.0}, "sweep.runs", "not a scenario value"),
    ],
)
def test_apply_errors_name_the_key(tanh, values, key, words):
    with pytest.raises(ConfigError) as exc:
        apply(tanh, values)
    assert exc.value.path == key
    assert words in str(exc.value)


def test_numeric_keys(tanh):
    keys = numeric_keys(tanh)
    for k in ("gains.k", "gains.alpha", "mismatch.payload", "mismatch.mass_error", "simulation.q0"):
        assert k in keys
    for k in ("simulation.seed", "simulation.dt", "simulation.t_final", "gains.p", "switching"):
        assert k not in keys
    every = numeric_keys(tanh, overrides=True)
    assert set(keys) < set(every)
    assert "controllers[2].beta" in every and "controllers[0].beta" not in every  # PDSMC
    # each key can be applied
    for k in every:
        v = get_value(tanh, k) if k in keys else 1.0
        bumped = [x * 1.01 for x in v] if isinstance(v, list) else (v or 1.0) * 1.01
        apply(tanh, {k: bumped})


def test_sweep_table_validated():
    d = load_shipped("tanh").to_dict()
    d["sweep"] = {"runs": 10, "gains.k": {"uniform": [10, 40]}}
    s = scenario_from_dict(d)
    assert s.sweep is not None and s.sweep.runs == 10
    assert s.sweep.distributions() == {"gains.k": Distribution("uniform", (10.0, 40.0))}
    assert scenario_from_dict(s.to_dict()).to_dict() == s.to_dict()
    for bad, words in (
        ({"gains.k": {"uniform": [40, 10]}}, '"gains.k".uniform'),
        ({"runs": 0}, "sweep.runs"),
        ({"bad key": {"uniform": [0, 1]}}, '"bad key"'),
    ):
        d["sweep"] = bad
        with pytest.raises(ConfigError, match="sweep") as exc:
            scenario_from_dict(d)
        assert words in str(exc.value)
