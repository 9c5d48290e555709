"""Gain tuning (:func:`tune`): optuna over a controller's gains, objectives from the metrics.

- :mod:`~slidingarm.tune.space` — the gain space of a controller (intervals from the class's
  validated ranges and the scenario's values; ``bounds`` overrides);
- :mod:`~slidingarm.tune.evaluate` — a trial's scenario, its run(s) and its score;
- :mod:`~slidingarm.tune.tuning` — :func:`tune`, resumable from its folder, and
  :class:`TuneResult` (trials, Pareto front, export of a trial as a scenario file);
- :mod:`~slidingarm.tune.compare` — :func:`compare`, the fair comparison of the controllers.

The package itself is callable, as :mod:`slidingarm.sweep` is: ``slidingarm.tune(scenario,
controller="ftsmc", trials=100, out="dir")`` is :func:`slidingarm.tune.tuning.tune`, and
``import slidingarm.tune.space`` still works. Type checkers see the package as a
:class:`TunePackage`: called, it is :func:`~slidingarm.tune.tuning.tune` with its signature.
"""

from __future__ import annotations

import sys
import types
from typing import TYPE_CHECKING, Any

from slidingarm.tune.compare import FULL, QUICK, Budget, CompareResult, compare
from slidingarm.tune.evaluate import STATISTICS, Score, reduce, score, tuning_scenario, with_gains
from slidingarm.tune.space import GainBound, GainSpace, gain_space, parse_bound
from slidingarm.tune.tuning import (
    DEFAULT_OBJECTIVES,
    DEFAULT_POPULATION,
    SAMPLERS,
    TuneResult,
    tune,
)

__all__ = [
    "DEFAULT_OBJECTIVES",
    "DEFAULT_POPULATION",
    "FULL",
    "QUICK",
    "SAMPLERS",
    "STATISTICS",
    "Budget",
    "CompareResult",
    "GainBound",
    "GainSpace",
    "Score",
    "TuneResult",
    "compare",
    "gain_space",
    "parse_bound",
    "reduce",
    "score",
    "tune",
    "tuning_scenario",
    "with_gains",
]


class TunePackage(types.ModuleType):
    """This package, callable: ``slidingarm.tune(scenario, controller=..., trials=..., out=...)``
    is :func:`slidingarm.tune.tuning.tune` (the class of the package's module object, as type
    checkers read ``slidingarm.tune``; see :class:`slidingarm.sweep.SweepPackage`)."""

    if TYPE_CHECKING:
        __call__ = staticmethod(tune)
        Budget = Budget
        CompareResult = CompareResult
        GainBound = GainBound
        GainSpace = GainSpace
        Score = Score
        TuneResult = TuneResult
        compare = staticmethod(compare)
        gain_space = staticmethod(gain_space)
        parse_bound = staticmethod(parse_bound)
        reduce = staticmethod(reduce)
        score = staticmethod(score)
        tune = staticmethod(tune)
        tuning_scenario = staticmethod(tuning_scenario)
        with_gains = staticmethod(with_gains)
    else:

        def __call__(self, *args: Any, **kwargs: Any) -> TuneResult:
            return tune(*args, **kwargs)


sys.modules[__name__].__class__ = TunePackage
