"""A fair comparison of the sliding-mode controllers: each tuned under the same budget,
objective and constraints, then all tested on the same Monte Carlo draws.

:func:`compare` runs, on a scenario with a ``[sweep]`` table (the uncertainty: for the shipped
``robust.toml`` a mass error per link, the noise level, a torque disturbance's amplitude and an
initial-state offset; ``vary`` adds more, e.g. a payload):

1. **Tuning.** :data:`COMPARED` — PDSMC, TSMC, FTSMC, NTSMC and FTSMC with the super-twisting
   reaching law — each tuned by :func:`slidingarm.tune` with the same number of trials, the same
   single objective (the mean MSE over the ``robust`` tuning draws ``0..K-1`` of the
   ``[sweep]``, the same for everyone), the same limits on peak torque and chattering (the same
   statistic of the same draws), the same sampler (multivariate TPE) and seed. The gain spaces
   are each class's defaults (:mod:`slidingarm.tune.space`). Unless given, the limits are the
   largest peak torque and chattering that the scenario's own, hand-tuned controllers use on
   those draws: no tuned controller may spend more effort or chatter more than the most
   demanding of them. Each controller keeps the feasible trial of least MSE.
2. **Test.** The tuned controllers run together on ``runs`` fresh draws of the same ``[sweep]``
   (seed: the sweep's seed + 1, so the test draws are not the tuning draws), through
   :func:`slidingarm.sweep`: the same plant, noise and disturbance for every controller on each
   draw.
3. **Statistics** (paired, on the same draws). For controllers A and B and the draws where both
   finished, the geometric-mean MSE ratio
   :math:`R = \\exp\\big(\\frac1m\\sum_i \\ln(\\mathrm{MSE}_{A,i}/\\mathrm{MSE}_{B,i})\\big)`
   with a 95 % percentile bootstrap interval over the draws (``n_resamples`` resamples, seeded);
   and the share of draws on which A's MSE is lower (a draw on which A fails counts as a loss,
   B failing as a win), with its Wilson interval. "A < B" *holds* when the interval of
   :math:`R` lies below 1, is *reversed* when it lies above 1, and is *inconclusive* otherwise.
   The paper's ranking FTSMC < TSMC < PDSMC holds when both of its pairs hold.
4. **Where it fails.** For each drawn parameter (a column of the sweep), the test draws are cut
   into terciles of that parameter and the paper's two pairs are tested again in each third.

Output folder ``out``::

    compare.json            the definition (refused if another one is found)
    tune/<label>/           each controller's tuning (a resumable slidingarm tune folder)
    sweep/                  the test sweep (a resumable slidingarm sweep folder)
    controllers.csv         per controller: tuned gains, tuning MSE, success rate, median MSE
    pairs.csv               the paired comparisons
    where.csv               the paper's pairs per tercile of each drawn parameter
    report.md               the headline table and the verdict
    comparison.png .svg     MSE distributions and the paired ratios

Everything is resumable: rerunning the same comparison skips finished trials and chunks.
"""

from __future__ import annotations

import json
import math
import os
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from slidingarm._io import atomic_write_text
from slidingarm.config import ConfigError, Scenario, scenario_from_dict
from slidingarm.study.output import OutputError
from slidingarm.tune.evaluate import robust_score, tuning_scenario
from slidingarm.tune.tuning import tune

__all__ = [
    "COMPARED",
    "FULL",
    "PAPER_PAIRS",
    "QUICK",
    "Budget",
    "CompareResult",
    "compare",
]

#: Progress callback: ``progress(what, done, total)``.
Progress = Callable[[str, int, int], None]

#: The compared controllers by label, as scenario controller tables. The super-twisting
#: FTSMC starts from Levant's rule :math:`k_2 \\approx 1.1 L` with :math:`k_1 = 1.5\\sqrt{L}`,
#: which gives :math:`k_2 \\approx 200` for the scenario's :math:`k_1 = k = 20`; its tuning
#: searches :math:`[20, 2000]` around it.
COMPARED: dict[str, dict[str, Any]] = {
    "pdsmc": {"name": "pdsmc"},
    "tsmc": {"name": "tsmc"},
    "ftsmc": {"name": "ftsmc"},
    "ntsmc": {"name": "ntsmc"},
    "ftsmc_st": {"name": "ftsmc", "label": "ftsmc_st", "reaching": "super-twisting", "k2": 200.0},
}

#: The paper's ranking as pairs (A, B) for "A < B".
PAPER_PAIRS: tuple[tuple[str, str], ...] = (("ftsmc", "tsmc"), ("tsmc", "pdsmc"))
#: Every pair reported: the paper's, its transitive closure, and the extra controllers
#: against FTSMC.
PAIRS: tuple[tuple[str, str], ...] = (
    *PAPER_PAIRS,
    ("ftsmc", "pdsmc"),
    ("ntsmc", "ftsmc"),
    ("ftsmc_st", "ftsmc"),
)


#: The columns of a paired comparison (:func:`paired`).
PAIR_COLUMNS: tuple[str, ...] = ("a", "b", "draws", "ratio", "ci_low", "ci_high", "wins",
                                 "win_share", "win_low", "win_high", "verdict")  # fmt: skip


@dataclass(frozen=True)
class Budget:
    """What a comparison spends: ``trials`` per controller, each scored on ``robust`` draws,
    then ``runs`` test draws."""

    trials: int
    robust: int
    runs: int

    def __post_init__(self) -> None:
        for name in ("trials", "robust", "runs"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or v < 1:
                raise ConfigError(f"must be an integer >= 1, got {v!r}", path=name)


#: The full comparison: 60 trials × 6 draws per controller, 1000 test draws (under 15 min on
#: two cores for the paper arm's 4.5 s runs).
FULL = Budget(trials=60, robust=6, runs=1000)
#: ``--quick``: a smoke run of the whole pipeline (under a minute), not a conclusion.
QUICK = Budget(trials=6, robust=2, runs=40)

DEFINITION = "compare.json"
_FORMAT = "slidingarm-compare/1"


@dataclass(frozen=True, eq=False)
class CompareResult:
    """What :func:`compare` found.

    Attributes
    ----------
    out_dir : Path
    controllers : DataFrame
        As ``controllers.csv``.
    pairs : DataFrame
        As ``pairs.csv``: ``a, b, draws, ratio, ci_low, ci_high, wins, win_share,
        win_low, win_high, verdict``.
    where : DataFrame
        As ``where.csv``: the paper's pairs per tercile of each drawn parameter.
    ranking : {"holds", "fails", "inconclusive"}
        The paper's FTSMC < TSMC < PDSMC: ``holds`` if both pairs hold, ``fails`` if either is
        reversed, else ``inconclusive``.
    headline : str
        The report's verdict in one paragraph.
    status : {"ok", "partial"}
        ``partial`` when a controller found no feasible gains (it is left out of the test).
    runtime_s : float
    files : list of Path
    """

    out_dir: Path
    controllers: pd.DataFrame
    pairs: pd.DataFrame
    where: pd.DataFrame
    ranking: str
    headline: str
    status: str
    runtime_s: float
    files: list[Path] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        """Whether every controller was tuned and tested."""
        return self.status == "ok"


# --------------------------------------------------------------------------------------------
# statistics


def _bootstrap_mean(
    x: np.ndarray, rng: np.random.Generator, n_resamples: int
) -> tuple[float, float]:
    """95 % percentile bootstrap interval of the mean of ``x``."""
    if x.size < 2 or np.all(x == x[0]):
        v = float(x[0]) if x.size else math.nan
        return v, v
    idx = rng.integers(0, x.size, size=(n_resamples, x.size))
    means = x[idx].mean(axis=1)
    low, high = np.quantile(means, [0.025, 0.975])
    return float(low), float(high)


def _wilson(k: int, m: int) -> tuple[float, float]:
    from scipy.stats import binomtest

    if m == 0:
        return math.nan, math.nan
    ci = binomtest(k, m).proportion_ci(confidence_level=0.95, method="wilson")
    return float(ci.low), float(ci.high)


def _verdict(low: float, high: float) -> str:
    if not (math.isfinite(low) and math.isfinite(high)):
        return "inconclusive"
    if high < 1.0:
        return "holds"
    if low > 1.0:
        return "reversed"
    return "inconclusive"


def paired(
    mse: pd.DataFrame,
    ok: pd.DataFrame,
    a: str,
    b: str,
    *,
    rng: np.random.Generator,
    n_resamples: int = 2000,
) -> dict[str, Any]:
    """The paired comparison "A < B" over the draws (rows) of ``mse`` and ``ok`` (columns:
    controllers); see the module's formulas."""
    both = ok[a].to_numpy(dtype=bool) & ok[b].to_numpy(dtype=bool)
    ma, mb = mse[a].to_numpy(dtype=np.float64), mse[b].to_numpy(dtype=np.float64)
    use = both & (ma > 0) & (mb > 0)
    logs = np.log(ma[use] / mb[use])
    if logs.size:
        ratio = float(np.exp(logs.mean()))
        lo, hi = _bootstrap_mean(logs, rng, n_resamples)
        low, high = float(np.exp(lo)), float(np.exp(hi))
    else:
        ratio = low = high = math.nan
    a_ok, b_ok = ok[a].to_numpy(dtype=bool), ok[b].to_numpy(dtype=bool)
    wins = a_ok & (~b_ok | (np.where(both, ma, np.inf) < np.where(both, mb, np.inf)))
    m = len(mse)
    k = int(wins.sum())
    w_low, w_high = _wilson(k, m)
    return {
        "a": a,
        "b": b,
        "draws": int(use.sum()),
        "ratio": ratio,
        "ci_low": low,
        "ci_high": high,
        "wins": k,
        "win_share": k / m if m else math.nan,
        "win_low": w_low,
        "win_high": w_high,
        "verdict": _verdict(low, high),
    }


# --------------------------------------------------------------------------------------------
# the comparison


def _compare_scenario(scenario: Scenario, controllers: Sequence[str]) -> Scenario:
    """The scenario with the compared controllers in place of its own (their ``[sweep]`` keys,
    which name the scenario's controllers, dropped)."""
    d = scenario.to_dict()
    d["controllers"] = [dict(COMPARED[c]) for c in controllers]
    if "sweep" in d:
        d["sweep"] = {k: v for k, v in d["sweep"].items() if not k.startswith("controllers[")}
    return scenario_from_dict(d, source=scenario.source, base_dir=scenario._base_dir)


def _default_limits(scenario: Scenario, draws: int) -> dict[str, float]:
    """The largest mean peak torque and chattering over the tuning draws of the scenario's own
    controllers."""
    peaks: list[float] = []
    chatter: list[float] = []
    for spec in scenario.controllers:
        base, _ = tuning_scenario(scenario, spec.key)
        s = robust_score(base, draws, "mean")
        if s.ok:
            peaks.append(s.values["peak_torque"])
            chatter.append(s.values["chattering"])
    if not peaks:
        raise ConfigError(
            "none of the scenario's own controllers finishes every tuning draw, so there is no "
            "reference for the limits; give limits (peak_torque, chattering)",
            file=scenario.source,
            path="limits",
        )
    return {"peak_torque": max(peaks), "chattering": max(chatter)}


def _check_folder(out: Path, definition: dict[str, Any]) -> None:
    if out.exists() and not out.is_dir():
        raise OutputError(f"{out}: exists and is not a folder; choose another --out")
    path = out / DEFINITION
    if path.is_file():
        try:
            old = json.loads(path.read_text(encoding="utf-8"))["definition"]
        except (OSError, ValueError, KeyError, TypeError):
            raise OutputError(f"{out}: its {DEFINITION} is not a comparison's") from None
        if old != definition:
            keys = sorted(k for k in set(old) | set(definition) if old.get(k) != definition.get(k))
            raise OutputError(
                f"{out}: holds a comparison with another definition ({', '.join(keys)} "
                "differ); rerun with the same settings to resume, or choose another --out"
            )
        return
    if out.is_dir() and any(out.iterdir()):
        raise OutputError(
            f"{out}: holds files that are not a comparison (no {DEFINITION}); choose another "
            "--out (nothing was changed)"
        )
    atomic_write_text(
        path, json.dumps({"format": _FORMAT, "definition": definition}, indent=1) + "\n"
    )


def compare(
    scenario: Scenario,
    *,
    out: str | os.PathLike[str],
    budget: Budget = FULL,
    controllers: Sequence[str] = tuple(COMPARED),
    limits: Mapping[str, float] | None = None,
    vary: Mapping[str, Any] | None = None,
    seed: int = 0,
    n_resamples: int = 2000,
    figures: bool = True,
    progress: Progress | None = None,
) -> CompareResult:
    """Tune each of ``controllers`` under the same budget and constraints, test them on the
    same draws, and say whether FTSMC < TSMC < PDSMC holds (see the module's description).

    Parameters
    ----------
    scenario : Scenario
        With a ``[sweep]`` table (or ``vary``): the uncertainty of the tuning and the test.
    out : path
        The comparison's folder (resumed if it holds this comparison).
    budget : Budget
        :data:`FULL` (default) or :data:`QUICK`, or your own.
    controllers : sequence of str
        Labels of :data:`COMPARED` (default: all five).
    limits : mapping, optional
        ``{"peak_torque": ..., "chattering": ...}`` (N m; N m/s): the constraints of every
        tuning; default from the scenario's own controllers.
    vary : mapping, optional
        Distributions added to the ``[sweep]`` (as :func:`slidingarm.sweep`'s ``vary``).
    seed : int
        Seed of the samplers and of the bootstrap.
    n_resamples : int
        Bootstrap resamples of the paired intervals.
    figures : bool
        Draw ``comparison.png/.svg`` (the tunings and the test sweep draw none).
    progress : callable, optional
        ``progress(what, done, total)``.

    Raises
    ------
    ConfigError
        For a bad argument or a scenario without draws.
    OutputError
        For a folder that holds something else or another comparison.
    """
    from slidingarm.sweep import sweep
    from slidingarm.sweep.run import definition_of
    from slidingarm.sweep.space import Distribution, apply

    t0 = time.perf_counter()
    unknown = [c for c in controllers if c not in COMPARED]
    if unknown or not controllers or len(set(controllers)) != len(controllers):
        raise ConfigError(
            f"choose distinct controllers among {', '.join(COMPARED)}, got {list(controllers)}",
            path="controllers",
        )
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ConfigError(f"must be an integer >= 0, got {seed!r}", path="seed")
    if vary:
        d = scenario.to_dict()
        draws = dict(d.get("sweep", {}))
        for key, dist in vary.items():
            parsed = (
                Distribution.parse(key, dist)
                if isinstance(dist, str)
                else Distribution.from_spec(key, dist)
            )
            draws[key] = parsed.to_dict()
        d["sweep"] = draws
        scenario = scenario_from_dict(d, source=scenario.source, base_dir=scenario._base_dir)
    if scenario.sweep is None or not scenario.sweep.distributions():
        raise ConfigError(
            "a comparison tests the controllers on the scenario's [sweep] draws, but it has none "
            "(try the shipped robust.toml, or give vary)",
            file=scenario.source,
            path="sweep",
        )
    cmp_scn = _compare_scenario(scenario, controllers)
    sweep_seed = definition_of(cmp_scn, runs=1).seed
    lim = dict(limits) if limits is not None else _default_limits(scenario, budget.robust)
    out_dir = Path(out)
    definition = json.loads(
        json.dumps(
            {
                "scenario": cmp_scn.to_dict(),
                "controllers": list(controllers),
                "budget": {"trials": budget.trials, "robust": budget.robust, "runs": budget.runs},
                "limits": lim,
                "seed": seed,
                "test_seed": sweep_seed + 1,
            },
            sort_keys=True,
        )
    )
    _check_folder(out_dir, definition)
    steps = len(controllers) * budget.trials + budget.runs
    done = 0

    def tick(what: str, n: int = 1) -> None:
        nonlocal done
        done += n
        if progress is not None:
            progress(what, min(done, steps), steps)

    # 1. tuning
    tuned: dict[str, dict[str, float]] = {}
    rows: list[dict[str, Any]] = []
    for label in controllers:
        before = done

        def step(
            what: str, k: int, total: int, *, _label: str = label, _before: int = before
        ) -> None:
            nonlocal done
            done = _before + k
            if progress is not None:
                progress(f"tuning {_label}", done, steps)

        r = tune(
            cmp_scn, controller=label, trials=budget.trials, out=out_dir / "tune" / label,
            objectives=("mse",), limits=lim, robust=budget.robust, statistic="mean",
            sampler="tpe", seed=seed, figure=False, progress=step,
        )  # fmt: skip
        done = before + budget.trials
        row: dict[str, Any] = {
            "controller": label,
            "feasible_trials": int(r.trials["feasible"].sum()),
        }
        if r.ok:
            best = r.best
            tuned[label] = r.gains(best)
            row |= {
                "trial": best,
                "tuning_mse": float(r.trials.loc[r.trials["trial"] == best, "mse"].iloc[0]),
            }
            row["gains"] = json.dumps({k: float(f"{v:.6g}") for k, v in tuned[label].items()})
        else:
            row |= {"trial": -1, "tuning_mse": math.nan, "gains": ""}
        rows.append(row)
    # 2. the test on fresh draws
    tested = [c for c in controllers if c in tuned]
    files: list[Path] = [Path(DEFINITION)]
    if not tested:
        raise ConfigError(
            f"no controller met the limits {lim} on the tuning draws; loosen limits",
            path="limits",
        )
    d = cmp_scn.to_dict()
    d["controllers"] = [dict(COMPARED[c]) for c in tested]
    test_scn = scenario_from_dict(d, source=cmp_scn.source, base_dir=cmp_scn._base_dir)
    values = {
        f"controllers[{i}].{name}": v for i, c in enumerate(tested) for name, v in tuned[c].items()
    }
    test_scn = apply(test_scn, values)

    def swept(k: int, total: int) -> None:
        nonlocal done
        done = len(controllers) * budget.trials + k
        if progress is not None:
            progress("testing on the draws", done, steps)

    # the sweep's own figures (a scatter of every metric against every draw) would take longer
    # than the whole quick comparison; comparison.png shows what the comparison is about
    result = sweep(
        test_scn, runs=budget.runs, out=out_dir / "sweep", seed=sweep_seed + 1,
        figures=False, progress=swept,
    )  # fmt: skip
    table = result.table
    mean = table[table["joint"] == "mean"]
    mse = mean.pivot(index="run", columns="controller", values="mse")
    ok = mean.pivot(index="run", columns="controller", values="ok").astype(bool)
    rng = np.random.default_rng(seed)
    # 3. per controller
    for row in rows:
        c = row["controller"]
        if c not in tested:
            row |= {"runs": 0, "ok": 0, "success": math.nan}
            continue
        good = ok[c].to_numpy(dtype=bool)
        x = mse[c].to_numpy(dtype=np.float64)[good]
        k, m = int(good.sum()), int(good.size)
        lo, hi = _wilson(k, m)
        med = float(np.median(x)) if x.size else math.nan
        idx = rng.integers(0, max(x.size, 1), size=(n_resamples, x.size))
        meds = np.median(x[idx], axis=1) if x.size > 1 else np.array([med, med])
        row |= {
            "runs": m, "ok": k, "success": k / m, "success_low": lo, "success_high": hi,
            "median_mse": med, "median_low": float(np.quantile(meds, 0.025)),
            "median_high": float(np.quantile(meds, 0.975)),
            "mean_mse": float(np.mean(x)) if x.size else math.nan,
            "median_peak_torque": float(mean.loc[(mean["controller"] == c) & mean["ok"], "peak_torque"].median()),
            "median_chattering": float(mean.loc[(mean["controller"] == c) & mean["ok"], "chattering"].median()),
        }  # fmt: skip
    ctrl_table = pd.DataFrame(rows)
    pairs = pd.DataFrame(
        [
            paired(mse, ok, a, b, rng=rng, n_resamples=n_resamples)
            for a, b in PAIRS
            if a in tested and b in tested
        ]
    )
    # 4. where the paper's pairs fail
    where = _where(mean, mse, ok, rng, n_resamples)
    ranking = _ranking(pairs)
    headline = _headline(ranking, pairs, ctrl_table, lim, budget, len(mse))
    status = "ok" if len(tested) == len(controllers) else "partial"
    _csv(out_dir / "controllers.csv", ctrl_table)
    _csv(out_dir / "pairs.csv", pairs)
    _csv(out_dir / "where.csv", where)
    atomic_write_text(
        out_dir / "report.md", _report(headline, ctrl_table, pairs, where, lim, budget)
    )
    files += [Path("controllers.csv"), Path("pairs.csv"), Path("where.csv"), Path("report.md")]
    if figures:
        from slidingarm.plotting import save_figure
        from slidingarm.plotting.tune import plot_comparison

        drawn = save_figure(plot_comparison(mse, ok, pairs), out_dir / "comparison")
        files += [p.relative_to(out_dir) for p in drawn]
    return CompareResult(
        out_dir=out_dir, controllers=ctrl_table, pairs=pairs, where=where, ranking=ranking,
        headline=headline, status=status, runtime_s=time.perf_counter() - t0, files=files,
    )  # fmt: skip


def _csv(path: Path, table: pd.DataFrame) -> None:
    atomic_write_text(path, table.to_csv(index=False, float_format=_repr_float))


def _repr_float(x: Any) -> str:
    return repr(float(x))


def _ranking(pairs: pd.DataFrame) -> str:
    verdicts = []
    for a, b in PAPER_PAIRS:
        hit = pairs[(pairs["a"] == a) & (pairs["b"] == b)] if not pairs.empty else pairs
        verdicts.append(hit["verdict"].iloc[0] if len(hit) else "inconclusive")
    if all(v == "holds" for v in verdicts):
        return "holds"
    if any(v == "reversed" for v in verdicts):
        return "fails"
    return "inconclusive"


def _where(
    mean: pd.DataFrame, mse: pd.DataFrame, ok: pd.DataFrame, rng: np.random.Generator, n: int
) -> pd.DataFrame:
    from slidingarm.sweep.run import _is_param

    params = [c for c in mean.columns if _is_param(c)]
    per_run = mean.drop_duplicates("run").set_index("run").loc[mse.index]
    rows = []
    for p in params:
        x = per_run[p].to_numpy(dtype=np.float64)
        if np.all(x == x[0]):
            continue
        edges = np.quantile(x, [0.0, 1 / 3, 2 / 3, 1.0])
        bins = np.clip(np.searchsorted(edges, x, side="right") - 1, 0, 2)
        for t in range(3):
            sel = bins == t
            for a, b in PAPER_PAIRS:
                if a not in mse.columns or b not in mse.columns:
                    continue
                r = paired(mse[sel], ok[sel], a, b, rng=rng, n_resamples=n)
                rows.append(
                    {"parameter": p, "tercile": t + 1, "low": float(x[sel].min()),
                     "high": float(x[sel].max()), **r}
                )  # fmt: skip
    return pd.DataFrame(rows)


_NAMES = {
    "pdsmc": "PDSMC",
    "tsmc": "TSMC",
    "ftsmc": "FTSMC",
    "ntsmc": "NTSMC",
    "ftsmc_st": "FTSMC-ST",
}


def _pair_text(row: pd.Series) -> str:
    a, b = _NAMES.get(row["a"], row["a"]), _NAMES.get(row["b"], row["b"])
    return (
        f"{a} < {b} {row['verdict']}: MSE ratio {row['ratio']:.3g} "
        f"[{row['ci_low']:.3g}, {row['ci_high']:.3g}], {a} better on "
        f"{100 * row['win_share']:.0f} % of the draws"
    )


def _headline(
    ranking: str, pairs: pd.DataFrame, ctrl: pd.DataFrame, lim: Mapping[str, float],
    budget: Budget, draws: int,
) -> str:  # fmt: skip
    said = {"holds": "holds", "fails": "fails", "inconclusive": "is not settled"}[ranking]
    parts = [
        f"Under fair tuning ({budget.trials} trials each, mean MSE over {budget.robust} "
        f"tuning draws, peak torque <= {lim.get('peak_torque', math.inf):.4g} N m and chattering "
        f"<= {lim.get('chattering', math.inf):.4g} N m/s) and {draws} fresh test draws, the "
        f"paper's ranking FTSMC < TSMC < PDSMC {said}."
    ]
    for a, b in PAPER_PAIRS:
        hit = pairs[(pairs["a"] == a) & (pairs["b"] == b)] if not pairs.empty else pairs
        if len(hit):
            parts.append(_pair_text(hit.iloc[0]) + ".")
    over = []
    for _, r in ctrl[ctrl["trial"] >= 0].iterrows():
        for metric, column in (
            ("peak_torque", "median_peak_torque"),
            ("chattering", "median_chattering"),
        ):
            if metric in lim and float(r.get(column, math.nan)) > lim[metric]:
                over.append(
                    f"{_NAMES.get(r['controller'], r['controller'])}'s {metric.replace('_', ' ')}"
                )
    if over:
        parts.append(
            "The limits bind on the tuning draws; on the test draws the median of "
            + ", ".join(over)
            + " exceeds its limit."
        )
    missing = ctrl[ctrl["trial"] < 0]["controller"].tolist()
    if missing:
        parts.append(f"No feasible gains for {', '.join(missing)} (left out of the test).")
    return " ".join(parts)


def _fmt(x: Any, spec: str = ".4g") -> str:
    try:
        v = float(x)
    except (TypeError, ValueError):
        return str(x)
    return "–" if math.isnan(v) else format(v, spec)


def _report(
    headline: str, ctrl: pd.DataFrame, pairs: pd.DataFrame, where: pd.DataFrame,
    lim: Mapping[str, float], budget: Budget,
) -> str:  # fmt: skip
    lines = ["# Fair comparison of the sliding-mode controllers", "", headline, ""]
    lines += [
        "| controller | tuned gains | tuning MSE | success | median MSE [95 % CI] | mean MSE | median peak torque | median chattering |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for _, r in ctrl.iterrows():
        lines.append(
            f"| {_NAMES.get(r['controller'], r['controller'])} | {r.get('gains', '')} | "
            f"{_fmt(r['tuning_mse'])} | {_fmt(r.get('success'), '.1%')} | "
            f"{_fmt(r.get('median_mse'))} [{_fmt(r.get('median_low'))}, {_fmt(r.get('median_high'))}] | "
            f"{_fmt(r.get('mean_mse'))} | {_fmt(r.get('median_peak_torque'))} | "
            f"{_fmt(r.get('median_chattering'))} |"
        )
    lines += ["", "## Paired comparisons (the same draws)", "",
              "| A < B | draws | geometric-mean MSE ratio A/B [95 % CI] | A better on | verdict |",
              "|---|---|---|---|---|"]  # fmt: skip
    for _, r in pairs.iterrows():
        lines.append(
            f"| {_NAMES.get(r['a'], r['a'])} < {_NAMES.get(r['b'], r['b'])} | {r['draws']} | "
            f"{_fmt(r['ratio'])} [{_fmt(r['ci_low'])}, {_fmt(r['ci_high'])}] | "
            f"{_fmt(r['win_share'], '.0%')} [{_fmt(r['win_low'], '.0%')}, {_fmt(r['win_high'], '.0%')}] | "
            f"{r['verdict']} |"
        )
    if not where.empty:
        fails = where[where["verdict"] != "holds"]
        lines += [
            "",
            "## Where the paper's pairs do not hold (terciles of each drawn parameter)",
            "",
        ]
        if fails.empty:
            lines.append("Both pairs hold in every tercile of every drawn parameter.")
        else:
            lines += [
                "| parameter | range | A < B | ratio [95 % CI] | verdict |",
                "|---|---|---|---|---|",
            ]
            for _, r in fails.iterrows():
                lines.append(
                    f"| {r['parameter']} | {_fmt(r['low'])} to {_fmt(r['high'])} | "
                    f"{_NAMES.get(r['a'], r['a'])} < {_NAMES.get(r['b'], r['b'])} | "
                    f"{_fmt(r['ratio'])} [{_fmt(r['ci_low'])}, {_fmt(r['ci_high'])}] | {r['verdict']} |"
                )
    lines += [
        "",
        "Method: each controller tuned by `slidingarm tune` (multivariate TPE, the same seed) "
        f"for the least mean MSE over the sweep's draws 0..{budget.robust - 1} under the limits "
        + ", ".join(f"{k} <= {v:.4g}" for k, v in lim.items())
        + f"; then all run on {budget.runs} draws of the same [sweep] with the next seed. "
        "Ratios are geometric means of the paired MSE ratios with percentile bootstrap "
        "intervals; win shares have Wilson intervals (a failed run loses).",
        "",
    ]
    return "\n".join(lines)
