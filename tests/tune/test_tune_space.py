"""The gain space of a tuning, its overrides, the one-controller scenario and the statistics."""

from __future__ import annotations

import math

import numpy as np
import pytest

from slidingarm.config import ConfigError, Scenario, scenario_from_dict
from slidingarm.study import load_shipped
from slidingarm.tune import GainBound, gain_space, parse_bound, reduce, tuning_scenario, with_gains


def _controller(scenario: Scenario, name: str):  # type: ignore[no-untyped-def]
    base, label = tuning_scenario(scenario, name)
    return base.build().controllers[label]


def test_default_space_of_ftsmc_under_sign() -> None:
    space = gain_space(_controller(load_shipped("sign"), "ftsmc"))
    assert space.names == ("alpha", "beta", "gamma", "k")  # no width under sign switching
    # two decades around the paper's gains, on a log scale; gamma inside (0, 1)
    assert space["alpha"] == GainBound("alpha", 0.2, 20.0, log=True)
    assert space["beta"] == GainBound("beta", 0.2, 20.0, log=True)
    assert space["k"] == GainBound("k", 2.0, 200.0, log=True)
    assert space["gamma"] == GainBound("gamma", 0.05, 0.95, log=False)


def test_spaces_follow_each_class() -> None:
    tanh = load_shipped("tanh")
    assert gain_space(_controller(tanh, "pdsmc")).names == ("lam", "k", "width")
    assert gain_space(_controller(tanh, "tsmc")).names == ("beta", "gamma", "k", "width")
    width = gain_space(_controller(tanh, "ftsmc"))["width"]
    assert (width.low, width.high) == pytest.approx((0.005, 0.5))
    # NTSMC's exponent p/q lies in (1, 2)
    nts = gain_space(_controller(tanh, "ntsmc"))
    assert nts.names == ("beta", "gamma", "k", "width")
    assert (nts["gamma"].low, nts["gamma"].high) == pytest.approx((1.05, 1.95))


def test_super_twisting_tunes_k2_and_per_joint_values_span_their_range() -> None:
    d = load_shipped("tanh").to_dict()
    d["controllers"] = [{"name": "ftsmc", "reaching": "super-twisting", "k2": [50.0, 100.0, 200.0]}]
    space = gain_space(_controller(scenario_from_dict(d), "ftsmc"))
    assert space.names[-1] == "k2"
    assert (space["k2"].low, space["k2"].high) == pytest.approx((5.0, 2000.0))


def test_bounds_override_fix_and_scale() -> None:
    ctrl = _controller(load_shipped("sign"), "ftsmc")
    space = gain_space(ctrl, {"k": (5, 60), "alpha": (1, 3, "linear"), "gamma": "fixed"})
    assert space["k"] == GainBound("k", 5.0, 60.0, log=True)
    assert space["alpha"] == GainBound("alpha", 1.0, 3.0, log=False)
    assert "gamma" not in space.names and space.fixed == ("gamma",)


@pytest.mark.parametrize(
    ("bounds", "key", "words"),
    [
        ({"lam": (1, 2)}, "bounds.lam", "no gain 'lam'"),
        ({"k": (60, 5)}, "bounds.k", "low < high"),
        ({"k": (0, 5)}, "bounds.k", "log scale needs low > 0"),
        ({"k": (-1, 5, "linear")}, "bounds.k", "must be > 0"),
        ({"gamma": (0.0, 0.5)}, "bounds.gamma", "open interval (0, 1)"),
        ({"gamma": (0.5, 1.0)}, "bounds.gamma", "open interval (0, 1)"),
        ({"k": (1, math.inf)}, "bounds.k", "finite"),
        ({"k": (1, 5, "cubic")}, "bounds.k", "'log' or 'linear'"),
        ({"k": "free"}, "bounds.k", "'fixed'"),
        ({n: "fixed" for n in ("alpha", "beta", "gamma", "k")}, "bounds", "nothing to tune"),
    ],
)
def test_bad_bounds_name_the_gain(bounds: dict, key: str, words: str) -> None:  # type: ignore[type-arg]
    ctrl = _controller(load_shipped("sign"), "ftsmc")
    with pytest.raises(ConfigError) as info:
        gain_space(ctrl, bounds)
    assert info.value.path == key and words in str(info.value)


def test_parse_bound() -> None:
    assert parse_bound("k=5:60") == ("k", (5.0, 60.0))
    assert parse_bound(" alpha = 0.5:4:linear ") == ("alpha", (0.5, 4.0, "linear"))
    assert parse_bound("gamma=fixed") == ("gamma", "fixed")
    for bad in ("k", "k=5", "k=a:b", "=1:2", "k=1:2:3:4"):
        with pytest.raises(ConfigError, match="--bound"):
            parse_bound(bad)


def test_tuning_scenario_keeps_one_controller_with_the_same_law() -> None:
    sign = load_shipped("sign")
    base, label = tuning_scenario(sign, "ftsmc")
    assert label == "ftsmc" and [c.key for c in base.controllers] == ["ftsmc"]
    ours = base.build().controllers["ftsmc"]
    theirs = sign.build().controllers["ftsmc"]
    # p = 5, q = 3 became gamma = 0.6: the same packed law, bit for bit
    assert np.array_equal(ours.handle.params, theirs.handle.params)
    # a class the scenario does not have is added with the shared gains (NTSMC: p/q = 5/3)
    nts, label = tuning_scenario(sign, "ntsmc")
    assert label == "ntsmc"
    assert nts.build().controllers["ntsmc"].to_dict()["gamma"] == pytest.approx(5 / 3)
    with pytest.raises(ConfigError, match="neither a controller"):
        tuning_scenario(sign, "lqr")


def test_with_gains_sets_and_validates() -> None:
    base, _ = tuning_scenario(load_shipped("sign"), "ftsmc")
    s = with_gains(base, {"k": 33.0, "gamma": 0.7})
    d = s.build().controllers["ftsmc"].to_dict()
    assert d["k"] == 33.0 and d["gamma"] == 0.7
    with pytest.raises(ConfigError, match=r"controllers\[0\]\.gamma"):
        with_gains(base, {"gamma": 1.5})


def test_reduce_mean_and_p90() -> None:
    rng = np.random.default_rng(7)
    x = rng.lognormal(size=11)
    assert reduce(x, "mean") == pytest.approx(float(np.mean(x)), rel=1e-15)
    assert reduce(x, "p90") == pytest.approx(float(np.percentile(x, 90)), rel=1e-14)
    # an infinite draw (a reaching time never reached) makes the mean infinite, and the p90
    # infinite only when the 90th percentile reaches it
    y = np.append(np.arange(10.0), math.inf)  # 11 values: p90 sits at index 9
    assert reduce(y, "mean") == math.inf
    assert reduce(y, "p90") == 9.0
    z = np.append(np.arange(9.0), [math.inf, math.inf])
    assert reduce(z, "p90") == math.inf
    with pytest.raises(ValueError, match="statistic"):
        reduce(x, "median")  # type: ignore[arg-type]
