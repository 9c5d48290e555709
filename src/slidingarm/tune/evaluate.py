"""What one trial of a tuning computes: the scenario with the trial's gains, its run(s) and
the score.

A trial's scenario is the tuned scenario reduced to the tuned controller (the others dropped)
with the trial's gains set on that controller (:func:`with_gains`); it is exactly the scenario
``--export`` writes, so ``slidingarm run`` on the export repeats the trial's nominal run.

Score of a trial, for each metric :math:`m` of :data:`slidingarm.metrics.METRIC_COLUMNS`
(the ``mean`` row: the mean over joints):

- ``robust = 0``: the one run of the scenario, :math:`m`;
- ``robust = K``: the runs on the scenario's ``[sweep]`` draws :math:`0, \\dots, K-1` (the same
  draws for every trial), reduced by the statistic: ``"mean"``
  :math:`\\bar m = \\frac1K \\sum_i m_i`, or ``"p90"``, the 90th percentile with linear
  interpolation between order statistics, :math:`m_{(j)} + f\\,(m_{(j+1)} - m_{(j)})` with
  :math:`j + f = 0.9\\,(K - 1)` (an infinite order statistic gives :math:`+\\infty`).

A run that diverges makes the trial fail: it has no score, and the tuning records it as a failed
trial (``optuna.trial.TrialState.FAIL``) with the run's message.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

from slidingarm.config import ConfigError, Scenario, Setup, scenario_from_dict
from slidingarm.control.controllers import CONTROLLERS
from slidingarm.metrics import METRIC_COLUMNS, summary

__all__ = [
    "STATISTICS",
    "Score",
    "check_draws",
    "reduce",
    "robust_score",
    "score",
    "tuning_scenario",
    "with_gains",
]

Statistic = Literal["mean", "p90"]

#: The statistics a robust trial's draws are reduced by.
STATISTICS: tuple[str, ...] = ("mean", "p90")


@dataclass(frozen=True)
class Score:
    """The outcome of one trial.

    Attributes
    ----------
    ok : bool
        Whether every run finished.
    values : dict of str to float
        Every metric of :data:`~slidingarm.metrics.METRIC_COLUMNS` (mean over joints, reduced
        over the draws by the statistic); empty when not ``ok``.
    message : str
        Why the trial failed (the first diverging run's message, with its draw); ``""`` if ok.
    runs : int
        Runs made (1, or the number of draws).
    failed_runs : int
        How many of them diverged.
    """

    ok: bool
    values: dict[str, float] = field(default_factory=dict)
    message: str = ""
    runs: int = 1
    failed_runs: int = 0


def tuning_scenario(scenario: Scenario, controller: str) -> tuple[Scenario, str]:
    """The scenario reduced to one controller, ready for :func:`with_gains`.

    ``controller`` is a label of the scenario's controllers, or the name of a controller class
    (``pdsmc``, ``tsmc``, ``ftsmc``, ``ntsmc``) that the scenario does not have, added with the
    scenario's shared ``[gains]``. The kept controller's exponent, if it states ``p`` and ``q``,
    becomes the equal float ``gamma`` (the tuned form), and its linear gain takes its class's
    own name (``lam`` for PDSMC, ``alpha`` for FTSMC).

    Returns
    -------
    (Scenario, str)
        The validated one-controller scenario and the controller's label.

    Raises
    ------
    ConfigError
        Naming ``controller`` when it is neither a label of the scenario nor a class name, or
        when the scenario's gains do not build that controller.
    """
    labels = [c.key for c in scenario.controllers]
    d = scenario.to_dict()
    kept: int | None = None
    if controller in labels:
        kept = labels.index(controller)
        spec = dict(d["controllers"][kept])
    elif controller in CONTROLLERS:
        spec = {"name": controller}
    else:
        raise ConfigError(
            f"is neither a controller of scenario {scenario.key!r} ({', '.join(labels)}) nor a "
            f"controller class ({', '.join(CONTROLLERS)}); got {controller!r}",
            path="controller",
        )
    klass = CONTROLLERS[spec["name"]]
    if "p" in spec and "q" in spec:
        p, q = spec.pop("p"), spec.pop("q")
        spec["gamma"] = p / q if klass.EXPONENT_RANGE[0] >= 1.0 else q / p
    synonym = {"alpha": "lam", "lam": "alpha"}
    if klass.LINEAR_NAME is not None and synonym[klass.LINEAR_NAME] in spec:
        spec[klass.LINEAR_NAME] = spec.pop(synonym[klass.LINEAR_NAME])
    d["controllers"] = [spec]
    if "sweep" in d:
        d["sweep"] = _renumbered(d["sweep"], kept)
    base = scenario_from_dict(d, source=scenario.source, base_dir=scenario._base_dir)
    return base, base.controllers[0].key


_CONTROLLER_KEY = re.compile(r"^controllers\[(\d+)\](.*)$")


def _renumbered(sweep: dict[str, Any], kept: int | None) -> dict[str, Any]:
    """A ``[sweep]`` table for the one-controller scenario: keys of the kept controller
    ``controllers[kept].x`` become ``controllers[0].x``; those of dropped controllers go."""
    out: dict[str, Any] = {}
    for key, value in sweep.items():
        m = _CONTROLLER_KEY.match(key)
        if m is None:
            out[key] = value
        elif kept is not None and int(m.group(1)) == kept:
            out[f"controllers[0]{m.group(2)}"] = value
    return out


def check_draws(base: Scenario, tuned: Sequence[str]) -> None:
    """A robust tuning's ``[sweep]`` exists and varies none of the ``tuned`` gains (the trial
    sets them: a draw of one would be overwritten or, on ``[gains]``, shadowed).

    Raises
    ------
    ConfigError
        Naming ``sweep`` when the scenario has no draws, or the ``sweep."<key>"`` that varies
        a tuned gain.
    """
    spec = base.sweep
    keys = list(spec.distributions()) if spec is not None else []
    if not keys:
        raise ConfigError(
            "a robust tuning scores each trial on the scenario's [sweep] draws, but it has "
            'none; add a [sweep] table (e.g. "mismatch.mass_error" = { normal = [0, 0.1] }) or '
            "use robust = 0",
            file=base.source,
            path="sweep",
        )
    names = set(tuned)
    if names & {"alpha", "lam"}:
        names |= {"alpha", "lam"}
    for key in keys:
        head, _, gain = key.rpartition(".")
        if head in ("gains", "controllers[0]") and gain in names:
            raise ConfigError(
                f"varies {gain}, a gain the tuning sets; remove it from [sweep] or keep the "
                f"gain out of the tuning (--bound {gain}=fixed)",
                file=base.source,
                path=f'sweep."{key}"',
            )


def with_gains(base: Scenario, gains: Mapping[str, float]) -> Scenario:
    """``base`` (from :func:`tuning_scenario`) with ``gains`` set on its one controller,
    validated as a scenario file is (:func:`slidingarm.sweep.space.apply` of
    ``controllers[0].<gain>``).

    Raises
    ------
    ConfigError
        Naming ``controllers[0].<gain>`` when the scenario refuses a value.
    """
    return _gains_applied(base, gains)[0]


def _gains_applied(base: Scenario, gains: Mapping[str, float]) -> tuple[Scenario, Setup]:
    from slidingarm.sweep.space import applied

    return applied(base, {f"controllers[0].{k}": float(v) for k, v in gains.items()})


def _percentile(values: np.ndarray, q: float) -> float:
    """The ``q``-quantile with linear interpolation; ``+inf`` when it involves an infinite
    order statistic (numpy would give NaN for ``inf - inf``)."""
    v = np.sort(np.asarray(values, dtype=np.float64))
    pos = q * (v.size - 1)
    j = math.floor(pos)
    f = pos - j
    lo = float(v[j])
    if f == 0.0 or j + 1 >= v.size:
        return lo
    hi = float(v[j + 1])
    if math.isinf(hi) or math.isinf(lo):
        return math.inf
    return lo + f * (hi - lo)


def reduce(values: np.ndarray, statistic: Statistic) -> float:
    """One metric over the draws (``(K,)``) by ``statistic`` (see the module's formulas)."""
    v = np.asarray(values, dtype=np.float64)
    if statistic == "mean":
        return float(np.mean(v))
    if statistic == "p90":
        return _percentile(v, 0.9)
    raise ValueError(f"statistic must be one of {', '.join(STATISTICS)}, got {statistic!r}")


def _mean_row(table: Any) -> dict[str, float]:
    row = table[table["joint"] == "mean"].iloc[0]
    return {name: float(row[name]) for name in METRIC_COLUMNS}


def score(scenario: Scenario | Setup) -> Score:
    """The nominal score of a one-controller scenario: its one run, as ``slidingarm run``
    computes it (the same simulation, :func:`slidingarm.metrics.summary` of the full traces).

    Raises
    ------
    ConfigError
        If the scenario does not build.
    """
    from slidingarm.study.analysis import simulate_setup

    setup = scenario.build() if isinstance(scenario, Scenario) else scenario
    (result,) = simulate_setup(setup, on_diverge="record").values()
    if isinstance(result, str):
        return Score(ok=False, message=result, runs=1, failed_runs=1)
    return Score(ok=True, values=_mean_row(summary(result)), runs=1)


def robust_score(scenario: Scenario, draws: int, statistic: Statistic) -> Score:
    """The score of a one-controller scenario over its ``[sweep]`` draws ``0..draws-1``, each
    metric reduced by ``statistic`` (:func:`reduce`); the draws are those
    ``slidingarm sweep`` makes of this scenario (:func:`slidingarm.sweep.run.run_chunk` of
    one chunk), so they are the same for every trial.

    Raises
    ------
    ConfigError
        If the scenario has no draws or a draw's key is refused.
    """
    from slidingarm.sweep.run import definition_of, run_chunk

    definition = definition_of(scenario, runs=draws, chunk=draws)
    table = run_chunk(definition, 0)
    mean = table[table["joint"] == "mean"]
    ok = mean["ok"].to_numpy(dtype=bool)
    if not ok.all():
        first = mean[~ok].iloc[0]
        return Score(
            ok=False,
            message=f"draw {int(first['run'])}: {first['message']}",
            runs=draws,
            failed_runs=int((~ok).sum()),
        )
    values = {
        name: reduce(mean[name].to_numpy(dtype=np.float64), statistic) for name in METRIC_COLUMNS
    }
    return Score(ok=True, values=values, runs=draws)
