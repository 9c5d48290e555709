"""Multi-objective gain tuning with optuna, resumable from its output folder.

:func:`tune` searches one controller's gains (:mod:`slidingarm.tune.space`) for the Pareto
front of the chosen metrics (:mod:`slidingarm.tune.evaluate`), with NSGA-II or multi-objective
TPE, and writes into ``out``::

    tune.json        the tuning's definition (scenario, controller, gain space, objectives,
                     limits, robust draws, statistic, sampler, seed) and its SHA-256
    journal.log      optuna's journal storage: every trial as it happens
    trials.csv       one row per finished trial: trial, state, feasible, pareto, the gains,
                     every metric (mean over joints; over the draws, the statistic), message
    pareto.csv       the Pareto front (complete, feasible, non-dominated trials), sorted by the
                     first objective
    pareto.png .svg  the front against every trial, each pair of objectives
    exports/trial-<k>.toml   a trial's scenario, written by :meth:`TuneResult.export`

**Resume.** Calling :func:`tune` again with the same definition into the same folder keeps every
finished trial and runs only the remaining ones (``trials`` is the total budget, not part of
the definition: a larger one extends a finished tuning). A trial cut short by a kill is marked
failed in the journal with the user attribute ``interrupted`` and run again. A different
definition is refused with a :class:`~slidingarm.study.OutputError` naming the first key that
differs, and a folder holding anything else is refused, never cleared.

**Determinism.** Trial ``k``'s sampler is seeded with
``SeedSequence(seed, spawn_key=(k,))``, and trials run one after another, so trial ``k``'s gains
depend only on the seed and trials ``0..k-1``: a killed and resumed tuning gives the same trials
as an uninterrupted one.

**Baseline.** Unless ``baseline=False``, trial 0 is the scenario's own gains (enqueued with
``Study.enqueue_trial``), so the table shows where the hand-tuned controller stands.

**Failures.** A trial whose run (or any robust draw) diverges is told to optuna as
``TrialState.FAIL`` with the user attribute ``failure`` (the run's message); it counts toward the
budget, is listed in ``trials.csv`` with state ``failed``, and the samplers ignore it.

**Limits.** ``limits={"peak_torque": 60}`` makes :math:`m \\le 60` a constraint on the same
reduced metric the objectives use, set on each complete trial with optuna's
``Trial.set_constraint`` as :math:`c = m - \\text{limit} \\le 0` (the samplers' own
``constraints_func`` is deprecated in optuna 5); NSGA-II and TPE rank infeasible trials behind
feasible ones, and the Pareto front holds feasible trials only.
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import hashlib
import json
import math
import os
import time
import warnings
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
import pandas as pd

from slidingarm._io import atomic_write_text
from slidingarm._version import __version__
from slidingarm.config import ConfigError, Scenario, scenario_from_dict
from slidingarm.metrics import METRIC_COLUMNS
from slidingarm.study.output import OutputError
from slidingarm.tune.evaluate import (
    STATISTICS,
    Score,
    _gains_applied,
    check_draws,
    robust_score,
    score,
    tuning_scenario,
    with_gains,
)
from slidingarm.tune.space import BoundSpec, GainSpace, gain_space

if TYPE_CHECKING:
    import optuna

__all__ = [
    "DEFAULT_OBJECTIVES",
    "DEFAULT_POPULATION",
    "SAMPLERS",
    "TuneResult",
    "knee",
    "tune",
]

#: Progress callback: ``progress(what, done, total)``.
Progress = Callable[[str, int, int], None]
Sampler = Literal["nsga2", "tpe"]

#: The objectives of ``slidingarm tune`` when none are given.
DEFAULT_OBJECTIVES: tuple[str, ...] = ("mse", "chattering", "peak_torque")
#: The samplers by name: NSGA-II (optuna's ``NSGAIISampler``) or multivariate TPE.
SAMPLERS: tuple[str, ...] = ("nsga2", "tpe")
#: NSGA-II's population (trials per generation) unless given: small enough that a budget of a
#: few hundred trials runs ten generations or more.
DEFAULT_POPULATION = 20

DEFINITION = "tune.json"
JOURNAL = "journal.log"
TRIALS = "trials.csv"
PARETO = "pareto.csv"
FIGURE = "pareto"
EXPORTS = "exports"
_LOCK = ".lock"
_FORMAT = "slidingarm-tune/1"
_STUDY = "tune"


# --------------------------------------------------------------------------------------------
# the result


@dataclass(frozen=True, eq=False)
class TuneResult:
    """What :func:`tune` found and wrote.

    Attributes
    ----------
    out_dir : Path
        The tuning folder.
    controller : str
        The tuned controller's label.
    objectives : tuple of str
        The metrics minimised.
    trials : DataFrame
        As ``trials.csv``: one row per finished trial.
    pareto : DataFrame
        As ``pareto.csv``.
    ran, kept : int
        Trials evaluated by this call, and finished trials found in the folder.
    status : {"ok", "infeasible", "all_failed"}
        ``ok`` when the front is not empty; ``infeasible`` when trials completed but none meets
        the limits; ``all_failed`` when no trial completed.
    message : str
        One line on the outcome.
    runtime_s : float
        Wall-clock time of the call (s).
    base : Scenario
        The tuned scenario reduced to the controller (trial gains go on it).
    files : list of Path
        The files written, relative to ``out_dir``.
    """

    out_dir: Path
    controller: str
    objectives: tuple[str, ...]
    trials: pd.DataFrame
    pareto: pd.DataFrame
    ran: int
    kept: int
    status: str
    message: str
    runtime_s: float
    base: Scenario
    space: GainSpace
    robust: int = 0
    statistic: str = "mean"
    files: list[Path] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        """Whether the Pareto front holds a trial."""
        return self.status == "ok"

    def __repr__(self) -> str:
        return (
            f"TuneResult({self.controller!r}, {len(self.trials)} trials, "
            f"{len(self.pareto)} on the front, status={self.status!r})"
        )

    @property
    def best(self) -> int:
        """The knee of the front (:func:`knee`).

        Raises
        ------
        ValueError
            If the front is empty.
        """
        if self.pareto.empty:
            raise ValueError(f"the tuning in {self.out_dir} has no Pareto front: {self.message}")
        return knee(self.pareto, self.objectives)

    def gains(self, trial: int) -> dict[str, float]:
        """The gains of finished trial ``trial``."""
        row = self._row(trial)
        return {name: float(row[name]) for name in self.space.names}

    def _row(self, trial: int) -> pd.Series:
        rows = self.trials[self.trials["trial"] == trial]
        if rows.empty:
            raise ValueError(
                f"trial {trial} is not a finished trial of this tuning (trials 0 to "
                f"{len(self.trials) - 1})"
            )
        return rows.iloc[0]

    def scenario(self, trial: int) -> Scenario:
        """The scenario of trial ``trial``: the tuned scenario with that trial's gains on its
        one controller, named ``<scenario>-<controller>-trial<k>``."""
        s = with_gains(self.base, self.gains(trial))
        d = s.to_dict()
        d["name"] = f"{self.base.key}-{self.controller}-trial{trial}"
        values = ", ".join(f"{k} = {v:.6g}" for k, v in self.gains(trial).items())
        d["description"] = (
            f"{self.base.key} with {self.controller}'s gains of trial {trial} of a tuning "
            f"({values})."
        )
        return scenario_from_dict(d, source=self.base.source, base_dir=self.base._base_dir)

    def export(
        self, trial: int | Literal["best"], path: str | os.PathLike[str] | None = None
    ) -> Path:
        """Write trial ``trial``'s scenario (``"best"``: :attr:`best`) as a TOML file that
        ``slidingarm run`` takes, headed by comments stating the objective values the tuning
        measured (``run`` on it gives them again, for a nominal tuning).

        Parameters
        ----------
        trial : int or "best"
            A complete trial.
        path : path, optional
            Default ``<out_dir>/exports/trial-<k>.toml``.

        Raises
        ------
        ValueError
            If the trial is not finished, or failed.
        """
        k = self.best if trial == "best" else int(trial)
        row = self._row(k)
        if row["state"] != "complete":
            raise ValueError(f"trial {k} failed ({row['message']}); export a complete trial")
        target = Path(path) if path is not None else self.out_dir / EXPORTS / f"trial-{k}.toml"
        where = "on" if bool(row["pareto"]) else "off"
        scored = (
            "its nominal run"
            if self.robust == 0
            else f"the {self.statistic} over {self.robust} [sweep] draws"
        )
        head = [
            f"# trial {k} of `slidingarm tune` (slidingarm {__version__}) of {self.controller}, "
            f"{where} the Pareto front",
            f"# objectives ({scored}, mean over joints): "
            + ", ".join(f"{name} = {float(row[name])!r}" for name in self.objectives),
            "# run it with `slidingarm run <this file> --out DIR`",
        ]
        atomic_write_text(target, "\n".join(head) + "\n" + self.scenario(k).to_toml())
        return target

    def plot(self) -> Any:
        """The Pareto figure (:func:`slidingarm.plotting.tune.plot_pareto`)."""
        from slidingarm.plotting.tune import plot_pareto

        return plot_pareto(
            self.trials, self.objectives, best=None if self.pareto.empty else self.best
        )


def knee(front: pd.DataFrame, objectives: Sequence[str]) -> int:
    """The knee of a Pareto front: the trial nearest the ideal point once each objective is
    scaled to [0, 1] over the front,

    .. math:: k^* = \\arg\\min_k \\Big\\|\\Big(\\frac{f_i(k) - \\min_j f_i(j)}
              {\\max_j f_i(j) - \\min_j f_i(j)}\\Big)_i\\Big\\|_2

    (an objective constant over the front scales to 0, an infinite value to 2); ties go to the
    lowest trial number. With one objective: its minimiser.

    Parameters
    ----------
    front : DataFrame
        Columns ``trial`` and each objective; not empty.
    """
    rows = front.sort_values("trial")
    scaled = np.zeros((len(rows), len(objectives)))
    for i, name in enumerate(objectives):
        v = rows[name].to_numpy(dtype=np.float64)
        finite = np.isfinite(v)
        if not finite.any():
            continue
        lo, hi = float(v[finite].min()), float(v[finite].max())
        span = hi - lo
        scaled[:, i] = np.where(finite, (v - lo) / span if span > 0 else 0.0, 2.0)
    k = int(np.argmin(np.sqrt(np.sum(scaled**2, axis=1))))
    return int(rows["trial"].iloc[k])


# --------------------------------------------------------------------------------------------
# the folder


def _canonical(obj: Any) -> Any:
    return json.loads(json.dumps(obj, sort_keys=True))


def _first_difference(a: Any, b: Any, path: str = "") -> str | None:
    """The first key path where ``a`` and ``b`` differ (JSON data)."""
    if isinstance(a, dict) and isinstance(b, dict):
        for key in sorted(set(a) | set(b)):
            here = f"{path}.{key}" if path else str(key)
            if key not in a or key not in b:
                return here
            d = _first_difference(a[key], b[key], here)
            if d is not None:
                return d
        return None
    if isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            d = _first_difference(x, y, f"{path}[{i}]")
            if d is not None:
                return d
        return None
    return None if a == b else (path or "(whole definition)")


def _show(value: Any) -> str:
    text = json.dumps(value, sort_keys=True)
    return text if len(text) <= 60 else text[:57] + "..."


def _lookup(data: Any, path: str) -> Any:
    import re

    cur = data
    for name, index in re.findall(r"([^.\[\]]+)|\[(\d+)\]", path):
        try:
            cur = cur[int(index)] if index else cur[name]
        except (KeyError, IndexError, TypeError):
            return "(absent)"
    return cur


@contextlib.contextmanager
def _folder(out: Path, definition: dict[str, Any]) -> Iterator[Path]:
    """Open (or create) the tuning folder under an exclusive lock, checking its definition.

    Yields the path of the journal. The lock is :func:`fcntl.flock` on ``out/.lock``, released
    by the operating system however the process ends, so a killed tuning never blocks its
    resumption.
    """
    try:
        if out.exists() and not out.is_dir():
            raise OutputError(f"{out}: exists and is not a folder; choose another --out")
        fresh = not out.exists() or not any(out.iterdir())
        if not fresh and not (out / DEFINITION).is_file():
            raise OutputError(
                f"{out}: holds files that are not a tuning (no {DEFINITION}); choose another "
                "--out (nothing was changed)"
            )
        out.mkdir(parents=True, exist_ok=True)
        fd = os.open(out / _LOCK, os.O_RDWR | os.O_CREAT, 0o666)
    except OutputError:
        raise
    except OSError as exc:
        raise OutputError(f"{out}: cannot write there ({exc.strerror or exc})") from None
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as exc:
            if exc.errno in (errno.EAGAIN, errno.EACCES):
                raise OutputError(
                    f"{out}: another slidingarm tune is writing this folder; wait for it or "
                    "choose another --out"
                ) from None
            raise
        path = out / DEFINITION
        text = {"format": _FORMAT, "definition": definition, "sha256": _digest(definition)}
        if path.is_file():
            try:
                old = json.loads(path.read_text(encoding="utf-8"))
                old_def = old["definition"]
            except (OSError, ValueError, KeyError, TypeError):
                raise OutputError(
                    f"{out}: its {DEFINITION} is not a tuning definition; choose another --out"
                ) from None
            if old.get("format") != _FORMAT:
                raise OutputError(
                    f"{out}: {DEFINITION} is of another format ({old.get('format')!r})"
                )
            where = _first_difference(old_def, definition)
            if where is not None:
                raise OutputError(
                    f"{out}: holds a tuning with another definition ({where}: "
                    f"{_show(_lookup(old_def, where))} there, {_show(_lookup(definition, where))} "
                    "here); rerun with the same settings to resume, or choose another --out"
                )
        else:
            atomic_write_text(path, json.dumps({**text, "version": __version__}, indent=1) + "\n")
        journal = out / JOURNAL
        _repair_journal(journal)
        stale = out / (JOURNAL + ".lock")
        # under our flock no other process writes the journal: its lock file is a dead one's
        stale.unlink(missing_ok=True)
        yield journal
    finally:
        os.close(fd)


def _repair_journal(path: Path) -> None:
    """Drop a last line cut short by a kill (optuna would append after it and lose both)."""
    if not path.is_file():
        return
    with open(path, "rb+") as fh:
        data = fh.read()
        if data and not data.endswith(b"\n"):
            fh.truncate(data.rfind(b"\n") + 1)


def _digest(definition: Mapping[str, Any]) -> str:
    text = json.dumps(definition, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


# --------------------------------------------------------------------------------------------
# the study


def _trial_seed(seed: int, k: int) -> int:
    return int(np.random.SeedSequence(seed, spawn_key=(k,)).generate_state(1, dtype=np.uint32)[0])


def _make_sampler(name: str, seed: int, population: int) -> optuna.samplers.BaseSampler:
    import optuna

    if name == "nsga2":
        return optuna.samplers.NSGAIISampler(population_size=population, seed=seed)
    return optuna.samplers.TPESampler(seed=seed, multivariate=True)


def _validate(
    trials: int,
    objectives: Sequence[str],
    limits: Mapping[str, float],
    robust: int,
    statistic: str,
    sampler: str,
    seed: int,
    population: int,
) -> None:
    def integer(name: str, value: Any, low: int) -> None:
        if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < low:
            raise ConfigError(f"must be an integer >= {low}, got {value!r}", path=name)

    integer("trials", trials, 1)
    integer("robust", robust, 0)
    integer("seed", seed, 0)
    integer("population", population, 2)
    if isinstance(objectives, str) or not objectives:
        raise ConfigError(
            f"give one or more of {', '.join(METRIC_COLUMNS)}, got {objectives!r}",
            path="objectives",
        )
    for name in objectives:
        if name not in METRIC_COLUMNS:
            raise ConfigError(
                f"unknown metric {name!r}; choose from {', '.join(METRIC_COLUMNS)}",
                path="objectives",
            )
    if len(set(objectives)) != len(objectives):
        raise ConfigError(f"names a metric twice: {', '.join(objectives)}", path="objectives")
    for name, value in limits.items():
        if name not in METRIC_COLUMNS:
            raise ConfigError(
                f"unknown metric {name!r}; choose from {', '.join(METRIC_COLUMNS)}",
                path="limits",
            )
        if (
            isinstance(value, bool)
            or not isinstance(value, int | float)
            or not math.isfinite(value)
        ):
            raise ConfigError(
                f"{name}: the limit must be a finite number, got {value!r}", path="limits"
            )
    if statistic not in STATISTICS:
        raise ConfigError(
            f"must be one of {', '.join(STATISTICS)}, got {statistic!r}", path="statistic"
        )
    if sampler not in SAMPLERS:
        raise ConfigError(f"must be one of {', '.join(SAMPLERS)}, got {sampler!r}", path="sampler")


def _is_interrupted(t: optuna.trial.FrozenTrial) -> bool:
    return bool(t.user_attrs.get("interrupted", False))


def _finished(study: optuna.Study) -> list[optuna.trial.FrozenTrial]:
    """The study's finished trials (complete, or failed by a divergence), by index."""
    from optuna.trial import TrialState

    done = [
        t
        for t in study.get_trials(deepcopy=False, states=(TrialState.COMPLETE, TrialState.FAIL))
        if "index" in t.user_attrs and not _is_interrupted(t)
    ]
    return sorted(done, key=lambda t: int(t.user_attrs["index"]))


def _close_interrupted(study: optuna.Study, storage: Any) -> int:
    """Mark the trials a killed run left running as failed, ``interrupted``; their count."""
    from optuna.trial import TrialState

    running = study.get_trials(deepcopy=False, states=(TrialState.RUNNING,))
    if not running:
        return 0
    study_id = storage.get_study_id_from_name(_STUDY)
    for t in running:
        trial_id = storage.get_trial_id_from_study_id_trial_number(study_id, t.number)
        storage.set_trial_user_attr(trial_id, "interrupted", True)
        study.tell(t.number, state=TrialState.FAIL)
    return len(running)


def _table(
    study: optuna.Study, space: GainSpace, limits: Mapping[str, float]
) -> tuple[pd.DataFrame, set[int]]:
    """trials.csv and the indices on the Pareto front."""
    from optuna.trial import TrialState

    finished = _finished(study)
    front = {int(t.user_attrs["index"]) for t in study.best_trials if not _is_interrupted(t)}
    rows = []
    for t in finished:
        k = int(t.user_attrs["index"])
        complete = t.state == TrialState.COMPLETE
        metrics = dict(t.user_attrs.get("metrics", {}))
        row: dict[str, Any] = {
            "trial": k,
            "state": "complete" if complete else "failed",
            "feasible": complete and all(metrics[n] <= v for n, v in limits.items()),
            "pareto": k in front,
        }
        for name in space.names:
            row[name] = float(t.params[name]) if name in t.params else math.nan
        for name in METRIC_COLUMNS:
            row[name] = float(metrics[name]) if complete else math.nan
        row["message"] = "" if complete else str(t.user_attrs.get("failure", ""))
        rows.append(row)
    columns = ["trial", "state", "feasible", "pareto", *space.names, *METRIC_COLUMNS, "message"]
    return pd.DataFrame(rows, columns=columns), front


def _repr_float(x: object) -> str:
    return repr(float(x))  # type: ignore[arg-type]


def _csv(table: pd.DataFrame) -> str:
    return table.to_csv(index=False, float_format=_repr_float)


@contextlib.contextmanager
def _quiet_optuna() -> Iterator[None]:
    """optuna's per-trial INFO lines and experimental-feature warnings off, for this call."""
    import optuna

    level = optuna.logging.get_verbosity()
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", optuna.exceptions.ExperimentalWarning)
            yield
    finally:
        optuna.logging.set_verbosity(level)


def tune(
    scenario: Scenario,
    *,
    controller: str,
    trials: int,
    out: str | os.PathLike[str],
    objectives: Sequence[str] = DEFAULT_OBJECTIVES,
    bounds: Mapping[str, BoundSpec] | None = None,
    limits: Mapping[str, float] | None = None,
    robust: int = 0,
    statistic: Literal["mean", "p90"] = "mean",
    sampler: Sampler = "nsga2",
    seed: int = 0,
    population: int = DEFAULT_POPULATION,
    figure: bool = True,
    baseline: bool = True,
    progress: Progress | None = None,
) -> TuneResult:
    """Tune one controller's gains of a scenario for the Pareto front of ``objectives``.

    Parameters
    ----------
    scenario : Scenario
        The scenario; its other controllers are dropped.
    controller : str
        A label of the scenario's controllers, or a controller class name it does not have
        (added with the shared ``[gains]``; see :func:`~slidingarm.tune.evaluate.tuning_scenario`).
    trials : int
        The total budget of trials (those already in ``out`` included).
    out : path
        The tuning folder (created; an existing one of the same definition is resumed).
    objectives : sequence of str
        Metrics of :data:`~slidingarm.metrics.METRIC_COLUMNS` to minimise (mean over joints).
    bounds : mapping, optional
        Gain intervals overriding the defaults (:func:`~slidingarm.tune.space.gain_space`).
    limits : mapping of str to float, optional
        Constraints ``metric <= value``.
    robust : int
        0: score the nominal run. ``K > 0``: score the runs on the scenario's ``[sweep]`` draws
        ``0..K-1`` by ``statistic``.
    statistic : {"mean", "p90"}
        How the draws' metrics are reduced (:func:`~slidingarm.tune.evaluate.reduce`).
    sampler : {"nsga2", "tpe"}
        optuna's NSGA-II (population ``population``) or multivariate TPE.
    seed : int
        Seed of the samplers (trial ``k``: ``SeedSequence(seed, spawn_key=(k,))``).
    population : int
        NSGA-II's population size (default :data:`DEFAULT_POPULATION`).
    figure : bool
        Draw ``pareto.png``/``.svg`` (about a second; the tables are always written).
    baseline : bool
        Trial 0 evaluates the scenario's own gains (:meth:`GainSpace.start`, clipped into the
        bounds), so that the tuning reports the hand-tuned point and starts from it.
    progress : callable, optional
        ``progress(what, done, total)`` after each trial.

    Returns
    -------
    TuneResult

    Raises
    ------
    ConfigError
        For a bad argument (naming it), a controller the scenario cannot build, or bounds the
        controller refuses.
    OutputError
        If ``out`` is a file, holds something other than a tuning, holds a tuning of another
        definition, or is being written by another tuning.
    """
    t0 = time.perf_counter()
    limits = dict(limits or {})
    if isinstance(objectives, str):
        raise ConfigError(
            f"give a sequence of metric names, not one string ({objectives!r})", path="objectives"
        )
    objectives = tuple(objectives)
    _validate(trials, objectives, limits, robust, statistic, sampler, seed, population)
    base, label = tuning_scenario(scenario, controller)
    ctrl = base.build().controllers[label]
    space = gain_space(ctrl, bounds)
    if robust:
        from slidingarm.sweep.run import definition_of

        check_draws(base, space.names)
        definition_of(base, runs=robust, chunk=robust)  # the draws' keys, checked once here
    definition = _canonical(
        {
            "scenario": base.to_dict(),
            "controller": label,
            "space": space.to_dict(),
            "objectives": list(objectives),
            "limits": limits,
            "robust": robust,
            "statistic": statistic,
            "sampler": sampler,
            "seed": seed,
            "population": population if sampler == "nsga2" else None,
            "baseline": space.start(ctrl) if baseline else None,
        }
    )
    out_dir = Path(out)

    import optuna
    from optuna.storages import JournalStorage
    from optuna.storages.journal import JournalFileBackend
    from optuna.trial import TrialState

    with _folder(out_dir, definition) as journal, _quiet_optuna():
        storage = JournalStorage(JournalFileBackend(str(journal)))
        study = optuna.create_study(
            storage=storage,
            study_name=_STUDY,
            directions=["minimize"] * len(objectives),
            load_if_exists=True,
        )
        _close_interrupted(study, storage)
        kept = len(_finished(study))
        distributions = space.distributions()
        ran = 0
        waiting = study.get_trials(deepcopy=False, states=(TrialState.WAITING,))
        if baseline and kept == 0 and trials > 0 and not waiting:
            study.enqueue_trial(space.start(ctrl))
        for k in range(kept, trials):
            study.sampler = _make_sampler(sampler, _trial_seed(seed, k), population)
            trial = study.ask(distributions)
            trial.set_user_attr("index", k)
            result = _evaluate(base, dict(trial.params), robust, statistic)
            if result.ok:
                trial.set_user_attr("metrics", result.values)
                for name, value in limits.items():
                    trial.set_constraint(name, result.values[name] - value)
                study.tell(trial, [result.values[name] for name in objectives])
            else:
                trial.set_user_attr("failure", result.message)
                study.tell(trial, state=TrialState.FAIL)
            ran += 1
            if progress is not None:
                progress(f"{label}: trial {k}", k + 1, trials)
        table, _front = _table(study, space, limits)
    files = _write_outputs(out_dir, table, objectives, figure=figure)
    pareto = _pareto(table, objectives)
    complete = int((table["state"] == "complete").sum())
    if complete == 0:
        status = "all_failed"
        message = f"all {len(table)} trials failed (diverged); widen or move the gain bounds"
    elif pareto.empty:
        status = "infeasible"
        message = f"{complete} trials completed but none meets the limits " + ", ".join(
            f"{n} <= {v:g}" for n, v in limits.items()
        )
    else:
        status = "ok"
        message = (
            f"{len(table)} trials ({complete} complete, {len(table) - complete} failed), "
            f"{len(pareto)} on the Pareto front"
        )
    return TuneResult(
        out_dir=out_dir,
        controller=label,
        objectives=objectives,
        trials=table,
        pareto=pareto,
        ran=ran,
        kept=kept,
        status=status,
        message=message,
        runtime_s=time.perf_counter() - t0,
        base=base,
        space=space,
        robust=robust,
        statistic=statistic,
        files=files,
    )


def _evaluate(
    base: Scenario, gains: dict[str, float], robust: int, statistic: Literal["mean", "p90"]
) -> Score:
    """One trial: its nominal run, or its ``robust`` draws reduced by ``statistic``; gains the
    scenario refuses make a failed trial."""
    try:
        scn, setup = _gains_applied(base, gains)
    except ConfigError as exc:
        return Score(ok=False, message=f"the scenario refuses these gains: {exc}")
    if robust == 0:
        return score(setup)
    try:
        return robust_score(scn, robust, statistic)
    except ConfigError as exc:
        return Score(ok=False, message=f"a draw is refused: {exc}", runs=robust)


def _pareto(table: pd.DataFrame, objectives: Sequence[str]) -> pd.DataFrame:
    front = table[table["pareto"].astype(bool)]
    keep = [
        "trial",
        *[c for c in table.columns if c not in ("trial", "state", "feasible", "pareto", "message")],
    ]
    return front[keep].sort_values([*objectives, "trial"], kind="stable").reset_index(drop=True)


def _write_outputs(
    out: Path, table: pd.DataFrame, objectives: Sequence[str], *, figure: bool
) -> list[Path]:
    from slidingarm.plotting import save_figure
    from slidingarm.plotting.tune import plot_pareto

    atomic_write_text(out / TRIALS, _csv(table))
    front = _pareto(table, objectives)
    atomic_write_text(out / PARETO, _csv(front))
    files = [Path(TRIALS), Path(PARETO)]
    if figure:
        best = None if front.empty else knee(front, objectives)
        drawn = save_figure(plot_pareto(table, objectives, best=best), out / FIGURE)
        files += [p.relative_to(out) for p in drawn]
    return files
