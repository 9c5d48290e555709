"""Regenerate the study (docs/theory.md §7): three scenarios × three controllers, analyses, figures, report.

:func:`reproduce` writes, into one folder (see :mod:`slidingarm.study.output` for how it is
kept consistent)::

    metrics.csv                      one row per scenario × controller × joint (1..n, mean)
    convergence.csv chattering.csv errata.csv gain_grid.csv checks.csv   the report's tables
    <scenario>/<controller>.csv      every sample: t, q1.., qd1.., qref1.., qdref1.., qm1..,
                                     qdm1.., tau1.., s1..
    figures/<scenario>_fig<NN>_<figure>.png  (NN: the paper's figure; a serial arm adds
                                     tool_path), and .svg with ``svg=True`` (``--svg``)
    config/<scenario>.toml           the exact scenario run, resolved and self-contained
    report.md report.html            the report (the HTML embeds its figures)
    manifest.json                    version, seeds, command, runtime, every file's SHA-256;
                                     written last

:func:`run` does the same for one scenario, without the study's analyses and report.
"""

from __future__ import annotations

import concurrent.futures as cf
import datetime as _dt
import multiprocessing
import os
import platform
import signal
import sys
import threading
import time
import warnings
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager, nullcontext, suppress
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from slidingarm import _engine as E
from slidingarm._gc import paused
from slidingarm._pointers import INLINED, LINKED
from slidingarm._version import __version__
from slidingarm.config import Scenario, Setup
from slidingarm.models.serial import SerialArm
from slidingarm.results import SimResult
from slidingarm.study.output import Staging, csv_bytes
from slidingarm.study.paper import figure_stem
from slidingarm.study.runs import simulate_setup
from slidingarm.study.shipped import SCENARIOS, load_shipped

if TYPE_CHECKING:
    from multiprocessing.context import BaseContext
    from types import FrameType

    import pandas as pd

    from slidingarm.study.paper import ScenarioKind

__all__ = ["Progress", "StudyOutput", "reproduce", "run", "run_scenario", "scenario_kind"]

#: Progress callback: ``progress(what, done, total)`` with ``done`` out of ``total`` steps.
Progress = Callable[[str, int, int], None]

#: Scenarios whose TSMC/FTSMC runs are held to docs/theory.md §3's convergence times.
CONVERGENCE_SCENARIOS: tuple[str, ...] = ("sign", "tanh")
#: Scenarios the gain grid is run on.
GRID_SCENARIOS: tuple[str, ...] = ("sign", "tanh")
#: The scenario the errata are measured in.
ERRATA_SCENARIO: str = "sign"
#: The scenario with the noisy sensor.
NOISE_SCENARIO: str = "noise"


def _empty_table() -> pd.DataFrame:
    """An empty table (pandas imported when one is made, not with this module)."""
    import pandas as pd

    return pd.DataFrame()


@dataclass(frozen=True, eq=False)
class StudyOutput:
    """What :func:`reproduce` or :func:`run` wrote.

    Attributes
    ----------
    out_dir : Path
        The results folder.
    metrics : DataFrame
        The metrics table (as ``metrics.csv``).
    checks : DataFrame
        The must-hold checks (``name, value, threshold, passed``); empty for :func:`run`.
    runtime_s : float
        Wall-clock time of the whole call (s).
    files : list of Path
        Every file written, relative to ``out_dir``.
    kept : list of Path
        Files of the folder's previous run that this run did not write but kept, because they
        changed since that run's manifest recorded them (or are this run's input), relative to
        ``out_dir``.
    """

    out_dir: Path
    metrics: pd.DataFrame
    checks: pd.DataFrame = field(default_factory=_empty_table)
    runtime_s: float = 0.0
    files: list[Path] = field(default_factory=list)
    kept: list[Path] = field(default_factory=list)

    @property
    def passed(self) -> bool:
        """Whether every check passed."""
        return bool(self.checks.empty or self.checks["passed"].all())


# pandas and the analyses (slidingarm.study.analysis, slidingarm.study.paper_report) are
# imported where a study needs them, not with this module: reproduce imports them once it has
# simulated (slidingarm.study.runs has no pandas), so that its figure workers are forked
# sooner and the import runs while they draw, not before the workers start, when one core
# works and the other waits (benchmarks/bench_reproduce.py)


def run_scenario(scenario: Scenario | Setup) -> dict[str, SimResult]:
    """Simulate every controller of a scenario; results keyed by controller label, in order.

    Raises
    ------
    ConfigError
        If the scenario does not build.
    SimulationError
        If a run diverges.
    """
    setup = scenario.build() if isinstance(scenario, Scenario) else scenario
    return simulate_setup(setup)


def scenario_kind(scenario: Scenario) -> ScenarioKind | None:
    """Which of the paper's cases (docs/theory.md §7) a scenario runs, from its switching function and
    its sensor: ``"sign"`` or ``"tanh"`` switching with exact measurements, or ``"noise"``,
    tanh switching with Gaussian noise on the measured positions; None for anything else
    (``sat`` switching, or noise under sign switching).

    The report (:class:`slidingarm.study.paper_report.ReportContext` ``kinds``) matches each scenario's
    figures to the paper's by it.
    """
    noise = scenario.sensor.noise
    noisy = noise is not None and bool(np.any(np.asarray(noise.sigma, dtype=float) > 0))
    if scenario.switching == "tanh":
        return "noise" if noisy else "tanh"
    if scenario.switching == "sign" and not noisy:
        return "sign"
    return None


# --------------------------------------------------------------------------------------------
# helpers


class _Steps:
    """Counts steps for a progress callback."""

    def __init__(self, progress: Progress | None, total: int) -> None:
        self.progress = progress
        self.total = total
        self.done = 0

    def __call__(self, what: str, n: int = 1) -> None:
        _check_terminated()
        self.done = min(self.done + n, self.total)
        if self.progress is not None:
            self.progress(what, self.done, self.total)

    def start(self, what: str) -> None:
        _check_terminated()
        if self.progress is not None:
            self.progress(what, self.done, self.total)


def _title(setup: Setup) -> str:
    head = setup.description.split(":", 1)[0].strip() if ":" in setup.description else ""
    return f"{head} ({setup.name})" if head and len(head) < 40 else setup.name


def render_figures(
    name: str,
    results: Mapping[str, SimResult],
    title: str,
    fig_dir: Path,
    only: Sequence[str] | None = None,
    tool_paths: tuple[np.ndarray, Mapping[str, np.ndarray]] | None = None,
    *,
    svg: bool = True,
) -> dict[str, Path]:
    """Draw and save the figures of one scenario (or ``only`` these) as
    ``fig_dir/<name>_fig<NN>_<figure>.png`` and, with ``svg``, ``.svg`` (the paper's figure number, for the study's
    scenarios; ``<name>_<figure>`` for a figure the paper does not have,
    :func:`slidingarm.study.paper.figure_stem`); return figure name → PNG path. ``tool_paths`` (a
    serial arm's ``(desired, {label: actual})``, :func:`slidingarm.study.analysis.tool_paths`)
    adds the tool-path figure. (A figure worker runs :func:`slidingarm.plotting._worker.draw`
    itself, given the stems, so that it need not import this module.)"""
    from slidingarm.plotting import FIGURES, TOOL_FIGURES
    from slidingarm.plotting._worker import draw

    names = FIGURES + (TOOL_FIGURES if tool_paths is not None else ())
    wanted = names if only is None else tuple(only)
    # in the figures' own order; an unknown name is refused by scenario_figures
    order = [f for f in names if f in wanted] + [f for f in wanted if f not in names]
    stems = {f: fig_dir / figure_stem(name, f) for f in order}
    return draw(results, title, stems, tool_paths, svg=svg)


def _stage_runs(
    staging: Staging, name: str, results: Mapping[str, SimResult], steps: _Steps
) -> None:
    for label, result in results.items():
        steps.start(f"{name}: writing {label}.csv")
        staging.write_bytes(f"{name}/{label}.csv", csv_bytes(result))
        steps(f"{name}: wrote {label}.csv")


def _stage_table(staging: Staging, relative: str, table: pd.DataFrame) -> None:
    """Stage a table as CSV, floats as their shortest round-trip text."""
    staging.write_text(relative, table.to_csv(index=False, float_format=_repr_float))


def _repr_float(x: object) -> str:
    return repr(float(x))  # type: ignore[arg-type]


def _meta(
    command: str | None, seeds: Mapping[str, int], runtime: float, jobs: int
) -> dict[str, Any]:
    import pandas as pd

    return {
        "version": __version__,
        "command": command if command is not None else "slidingarm.study.reproduce()",
        "date": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
        "seeds": dict(seeds),
        "runtime_s": round(runtime, 3),
        "jobs": jobs,
        "python": platform.python_version(),
        "numpy": np.__version__,
        "pandas": pd.__version__,
        "platform": platform.platform(),
    }


def _gains(scenarios: Mapping[str, Scenario]) -> dict[str, Any]:
    """The shared gains as the files state them (plus gamma = q/p), the switching function of
    each scenario, and under ``per_scenario`` any gain that differs between scenarios."""

    def one(s: Scenario) -> dict[str, Any]:
        g = s.gains.model_dump(exclude_none=True, exclude={"reasons"})
        if "p" in g and "q" in g:
            g["gamma"] = g["q"] / g["p"]
        return g

    per = {name: one(s) for name, s in scenarios.items()}
    first = next(iter(per.values()))
    common = {k: v for k, v in first.items() if all(g.get(k) == v for g in per.values())}
    out: dict[str, Any] = {
        **common,
        "switching": {name: s.switching for name, s in scenarios.items()},
    }
    differing = {name: {k: v for k, v in g.items() if k not in common} for name, g in per.items()}
    if any(differing.values()):
        out["per_scenario"] = differing
    return out


def _noise(scenario: Scenario) -> dict[str, Any]:
    sensor = scenario.sensor
    return {
        "scenario": scenario.key,
        "sigma": None if sensor.noise is None else sensor.noise.sigma,
        "velocity": sensor.velocity.model_dump(),
        "seed": scenario.simulation.seed,
        "reasons": sensor.reasons or "",
    }


def _config_text(scenario: Scenario) -> str:
    """The scenario as it ran, headed by the package version and its seed (a TOML comment, so
    the file still runs as it is)."""
    return (
        f"# ran with slidingarm {__version__}, seed {scenario.simulation.seed} "
        "(simulation.seed); run it again with `slidingarm run <this file> --out DIR`\n"
        + scenario.to_toml()
    )


def _stop_workers(pool: cf.ProcessPoolExecutor) -> None:
    """Stop a failed or interrupted study's figure workers now, without waiting for the
    figures they are drawing (which would take seconds): cancel what is queued, terminate the
    workers and wait for them to end."""
    terminate = getattr(pool, "terminate_workers", None)  # Python 3.14
    if terminate is not None:
        terminate()
        return
    # before 3.14 the executor offers no way to stop running tasks: its own process table
    processes = list(getattr(pool, "_processes", {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for process in processes:
        process.terminate()
    for process in processes:
        process.join(timeout=10)
    pool.shutdown(wait=True)


class _Ending:
    """A pool whose tasks are all done, shut down without waiting for its workers to end (it
    takes them most of a second), so that they end while the study writes its report;
    :meth:`join` then ends those still running (idle) and waits for them, :meth:`stop` does the
    same on failure, waiting at most 10 s for each."""

    def __init__(self, pool: cf.ProcessPoolExecutor) -> None:
        # the executor drops these references in shutdown(wait=False)
        self._manager: threading.Thread | None = getattr(pool, "_executor_manager_thread", None)
        self._processes = list((getattr(pool, "_processes", None) or {}).values())
        pool.shutdown(wait=False)

    def join(self) -> None:
        """End the workers and wait for them: every task is done and its files are written, so
        an idle worker is stopped rather than waited for through its interpreter's shutdown."""
        for process in self._processes:
            if process.is_alive():
                process.terminate()
        for process in self._processes:
            process.join()
        if self._manager is not None:
            self._manager.join()

    def stop(self) -> None:
        """End the workers now and wait for them."""
        for process in self._processes:
            if process.is_alive():
                process.terminate()
        for process in self._processes:
            process.join(timeout=10)
        if self._manager is not None:
            self._manager.join(timeout=10)


class _Termination:
    """SIGTERM as Ctrl-C (see :func:`_terminate_as_interrupt`), held back while a worker process
    is being started (interrupting its start leaves a child that prints a traceback) and while
    numba's compiler runs llvmlite's Python code (:func:`_in_llvmlite`); a held-back SIGTERM
    interrupts at the study's next step (:meth:`check`)."""

    def __init__(self) -> None:
        self.holding = 0
        self.pending = False

    def handler(self, signum: int, frame: FrameType | None) -> None:
        if self.holding or _in_llvmlite(frame):
            self.pending = True
            return
        self.interrupt()

    def check(self) -> None:
        """Interrupt now if a SIGTERM was held back and nothing holds it any more."""
        if self.pending and not self.holding:
            self.pending = False
            self.interrupt()

    def interrupt(self) -> None:
        signal.signal(signal.SIGTERM, signal.SIG_IGN)  # a second one during the clean-up
        raise KeyboardInterrupt

    @contextmanager
    def held(self) -> Iterator[None]:
        """Within, a SIGTERM waits; it interrupts on exit."""
        self.holding += 1
        try:
            yield
        finally:
            self.holding -= 1
        self.check()


def _in_llvmlite(frame: FrameType | None) -> bool:
    """Whether ``frame`` runs inside llvmlite's Python code (numba's compiler calls it). An
    exception raised there is not safe: in a callback from compiled code (numba's cache's
    ctypes callbacks) it is printed and dropped, and the run would go on; in the constructor
    of one of its objects (a pass builder) it leaves the object half made, and its finalizer
    prints a traceback when it is freed."""
    while frame is not None:
        if str(frame.f_globals.get("__name__", "")).startswith("llvmlite."):
            return True
        frame = frame.f_back
    return False


def _check_terminated() -> None:
    """Interrupt now if a SIGTERM was held back (see :class:`_Termination`)."""
    if _TERMINATION is not None and threading.current_thread() is threading.main_thread():
        _TERMINATION.check()


#: The handler in force, if any (only one run installs it at a time: the main thread's).
_TERMINATION: _Termination | None = None


def _default_sigterm_in_child() -> None:
    """In a process forked during a study (a figure worker), SIGTERM ends the process again
    from the fork on: the handler it inherited is the study's, for the study's own clean-up
    (the worker's initializer also restores it, whatever handler it inherited)."""
    if _TERMINATION is not None:
        signal.signal(signal.SIGTERM, signal.SIG_DFL)


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_default_sigterm_in_child)


@contextmanager
def _terminate_as_interrupt() -> Iterator[None]:
    """Within, SIGTERM raises :class:`KeyboardInterrupt` as Ctrl-C does, so that a terminated
    run removes its staging folder and stops its figure workers; a second SIGTERM during that
    clean-up is ignored. Only in the main thread and when SIGTERM has its default action (an
    application's own handler is left alone); the default is restored on exit."""
    global _TERMINATION
    if (
        threading.current_thread() is not threading.main_thread()
        or signal.getsignal(signal.SIGTERM) is not signal.SIG_DFL
    ):
        yield
        return
    _TERMINATION = _Termination()
    signal.signal(signal.SIGTERM, _TERMINATION.handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, signal.SIG_DFL)
        _TERMINATION = None


@contextmanager
def _starting_workers() -> Iterator[None]:
    """Hold back SIGTERM while the pool may start a worker process (creating it, submitting)."""
    termination = _TERMINATION
    if termination is None or threading.current_thread() is not threading.main_thread():
        yield
        return
    with termination.held():
        yield


def _inputs(scenario: Scenario) -> list[Path]:
    """The files a scenario was read from: its own and those it extends."""
    files = {Path(f) for f in scenario._origin.values()}
    if scenario.source is not None:
        files.add(scenario.source)
    return sorted(files)


def _figure_names(tool: bool = False) -> tuple[str, ...]:
    """The figures of one scenario, :data:`slidingarm.plotting.FIGURES`, and with ``tool`` (a
    serial arm's) :data:`~slidingarm.plotting.TOOL_FIGURES` (names only: matplotlib is not
    imported)."""
    from slidingarm.plotting import FIGURES, TOOL_FIGURES

    return FIGURES + (TOOL_FIGURES if tool else ())


#: Relative cost of drawing and saving each figure (measured on the paper's scenarios): the
#: figure workers take the dearest first.
_FIGURE_COST: dict[str, float] = {
    "sliding": 5.0,
    "torque": 4.0,
    "velocity": 2.5,
    "tracking_all": 2.0,
    "error": 2.0,
    "steady_state": 2.0,
    "tracking_joint1": 1.0,
}


def _worker_context() -> BaseContext:
    """How the figure workers start: forked from this process on Linux when it runs no other
    Python thread and numba's threading layer has not started, spawned (a fresh interpreter)
    otherwise.

    A forked worker starts with this process's imports (numba, the package) and, on a cold
    cache, the compilation it has done (:func:`slidingarm._engine.prime`): a spawned one
    imports all of that again, about 1 CPU-s per worker, on a study that keeps both cores busy
    from start to end (``benchmarks/bench_reproduce.py``). A fork copies the locks other threads
    may hold at that moment, so with another Python thread running (an application's, or a
    progress bar that refreshes itself) or once numba's threading layer has started its threads
    (the user's own parallel numba code ran in this process: they are not Python threads), and
    where fork is not the safe default (macOS, Windows), the workers are spawned. Native pools
    that register their own fork handlers may run (numpy's and scipy's OpenBLAS, pyarrow's
    allocator, started by imports): Python 3.12's warning about forking a multi-threaded process
    is silenced for this fork only."""
    from numba.np.ufunc import parallel

    # numba's own flag (private: if it moves, assume its threads run)
    numba_threads = getattr(parallel, "_is_initialized", True)
    if sys.platform.startswith("linux") and threading.active_count() == 1 and not numba_threads:
        return multiprocessing.get_context("fork")
    return multiprocessing.get_context("spawn")


def _default_jobs() -> int:
    return max(1, min(3, os.cpu_count() or 1))


def _workers(jobs: int, scenarios: int) -> int:
    """Figure workers of a study of ``scenarios`` scenarios with ``jobs`` processes (none
    for one: this process draws)."""
    return min(jobs, scenarios) if jobs > 1 else 0


# --------------------------------------------------------------------------------------------
# one scenario


def run(
    scenario: Scenario,
    out_dir: str | os.PathLike[str],
    *,
    progress: Progress | None = None,
    command: str | None = None,
    figures: bool = True,
    overwrite: bool = False,
) -> StudyOutput:
    """Run one scenario and write its results folder.

    Writes ``<name>/<controller>.csv``, ``metrics.csv``, ``figures/<name>_<figure>.png/.svg``,
    ``config/<name>.toml`` and ``manifest.json`` (last) into ``out_dir``, through a staging
    folder (nothing is left behind on failure). What may be replaced in an existing folder is
    stated in :mod:`slidingarm.study.output`: never a file edited since the previous manifest
    recorded it, nor the scenario's own file; another scenario's results only with
    ``overwrite``. SIGTERM (in the main thread) is handled as Ctrl-C.

    Raises
    ------
    OutputError
        If ``out_dir`` is a file, cannot be written, is being written by another run, holds
        another scenario's results (without ``overwrite``) or a file this run must not replace
        (before any simulation where it can be known then).
    ConfigError, SimulationError
        If the scenario does not build or a run diverges.
    """
    with _terminate_as_interrupt():
        return _run(
            scenario,
            out_dir,
            progress=progress,
            command=command,
            figures=figures,
            overwrite=overwrite,
        )


def _run(
    scenario: Scenario,
    out_dir: str | os.PathLike[str],
    *,
    progress: Progress | None,
    command: str | None,
    figures: bool,
    overwrite: bool,
) -> StudyOutput:
    from slidingarm.study import analysis as A

    t0 = time.perf_counter()
    staging = Staging(
        out_dir, scenarios=[scenario.key], inputs=_inputs(scenario), overwrite=overwrite
    )
    try:
        # the config is known before anything runs: a file it must not replace refuses now
        staging.write_text(f"config/{scenario.key}.toml", _config_text(scenario))
        staging.check()
        setup = scenario.build()
        name = setup.name
        n_ctrl = len(setup.controllers)
        serial = isinstance(setup.nominal, SerialArm)
        n_figures = len(_figure_names(serial)) if figures else 0
        steps = _Steps(progress, 2 * n_ctrl + n_figures + 2)
        steps.start(f"{name}: simulating")
        results = A.simulate_setup(setup)
        steps(f"{name}: simulated", n_ctrl)
        _stage_runs(staging, name, results, steps)
        metrics = A.metrics_table({name: results})
        _stage_table(staging, "metrics.csv", metrics)
        steps("metrics and config")
        if figures:
            steps.start(f"{name}: figures")
            paths = A.tool_paths(setup, results)
            render_figures(name, results, _title(setup), staging.path / "figures", tool_paths=paths)
            steps(f"{name}: figures", n_figures)
        runtime = time.perf_counter() - t0
        staging.write_manifest(
            {
                **_meta(command, {name: setup.seed}, runtime, 1),
                "scenarios": [name],
            }
        )
        files = [p for p in staging.files()]
        staging.publish()
        steps("done")
    except BaseException:
        staging.discard()
        raise
    return StudyOutput(
        Path(out_dir),
        metrics,
        runtime_s=time.perf_counter() - t0,
        files=files,
        kept=staging.kept,
    )


# --------------------------------------------------------------------------------------------
# the study


def reproduce(
    out_dir: str | os.PathLike[str],
    *,
    progress: Progress | None = None,
    command: str | None = None,
    jobs: int | None = None,
    overwrite: bool = False,
    svg: bool = False,
) -> StudyOutput:
    """Regenerate the whole study into ``out_dir`` (layout in the module docstring).

    Parameters
    ----------
    out_dir : path
        The results folder; created if needed. Existing files of the same names are replaced
        as :mod:`slidingarm.study.output` states (never a file edited since the previous
        manifest recorded it); ``manifest.json``, written last, lists the files of this run.
        (The command line's default is :data:`slidingarm.cli.DEFAULT_OUT`.)
    progress : callable, optional
        ``progress(what, done, total)``, called as the work advances.
    command : str, optional
        The command line to record in the manifest and report.
    jobs : int, optional
        Processes drawing the figures while the main process computes (default: up to 3,
        bounded by the CPU count); 1 draws them in this process. On Linux, in a process that
        runs no other thread, the workers are forked from it, else spawned
        (:func:`_worker_context`). The workers run at a lower
        priority (:data:`slidingarm.plotting._worker.WORKER_NICENESS`), so that their start-up
        does not slow this process's compilation. A worker ends when this process dies, even
        by ``kill -9``; SIGTERM (in the main thread) is handled as Ctrl-C. Python's automatic
        garbage collection is off in this process while the study runs (its state is restored
        after; other threads of the process run without it meanwhile) and in the workers,
        which collect after each figure (:mod:`slidingarm._gc`).
    overwrite : bool
        Replace the results of other scenarios (a ``run`` of one's own) in ``out_dir``.
    svg : bool
        Also save every figure as SVG (default: PNG only). The report shows the PNGs; an SVG
        draws its figure once more, about a third of the figures' CPU time and about a second
        of a cold study on two cores (``benchmarks/bench_reproduce.py``).

    Raises
    ------
    OutputError
        If ``out_dir`` is a file, cannot be written, is being written by another run or holds
        other scenarios' results (without ``overwrite``), before any work; or if it holds a
        file this run must not replace.
    """
    # no automatic garbage collection during the study (slidingarm._gc: about a sixth of the
    # CPU of compiling the loop and of drawing, in this process and the workers it forks)
    # the linked loop (slidingarm._engine.linked_loop) when there are figure workers to compile
    # the parts it reaches by address while it compiles here, unless the inlined one is cached
    jobs = _default_jobs() if jobs is None else max(1, int(jobs))
    parallel = _workers(jobs, len(SCENARIOS)) > 0
    linked = E.linked_loop() if parallel and not E.loop_cached(INLINED) else nullcontext()
    with _terminate_as_interrupt(), paused(), linked:
        return _reproduce(
            out_dir, progress=progress, command=command, jobs=jobs, overwrite=overwrite, svg=svg
        )


def _reproduce(
    out_dir: str | os.PathLike[str],
    *,
    progress: Progress | None,
    command: str | None,
    jobs: int | None,
    overwrite: bool,
    svg: bool,
) -> StudyOutput:
    t0 = time.perf_counter()
    jobs = _default_jobs() if jobs is None else max(1, int(jobs))
    scenarios = {name: load_shipped(name) for name in SCENARIOS}
    staging = Staging(
        out_dir,
        scenarios=list(scenarios),
        inputs=[f for s in scenarios.values() for f in _inputs(s)],
        overwrite=overwrite,
    )
    pool: cf.ProcessPoolExecutor | None = None
    ending: _Ending | None = None
    paper_law: cf.Future[None] | None = None
    try:
        for name, scenario in scenarios.items():
            staging.write_text(f"config/{name}.toml", _config_text(scenario))
        staging.check()
        # figures are drawn in worker processes while this one computes; the workers start
        # at once, and while this process compiles the loop and simulates, they import
        # matplotlib, compile the errata's law and (cold) make the study's figure layouts
        from slidingarm.plotting import _worker

        workers = _workers(jobs, len(scenarios))
        parts: list[cf.Future[None]] = []
        setups = {name: s.build() for name, s in scenarios.items()}
        # cold: the loop this study runs is not cached, or (linked) the parts its runs load
        if E.linked_runs():
            cold = not (E.loop_cached(LINKED) and E.parts_cached())
        else:
            cold = not E.loop_cached(INLINED)
        start = _worker_context()
        if workers and cold and start.get_start_method() == "fork":
            E.prime()  # once here, inherited by both workers
        if workers:
            with _starting_workers(), warnings.catch_warnings():
                # Python >= 3.12 warns on a fork beside native threads (see _worker_context)
                warnings.filterwarnings(
                    "ignore", message=r".*fork\(\) may lead to deadlocks", category=DeprecationWarning
                )
                pool = cf.ProcessPoolExecutor(
                    max_workers=workers,
                    mp_context=start,
                    initializer=_worker.init_worker,
                    initargs=(os.getpid(),),
                )
                # the loop's separately compiled parts first, one per worker as they come
                # free, while this process compiles the linked loop (which reaches them by
                # address) and then loads them; then the errata's law (whose worker warms up
                # after it) and the other workers' warm-ups
                if cold:
                    parts = [
                        pool.submit(_worker.compile_loop_part, i) for i in range(len(E.LOOP_PARTS))
                    ]
                paper_law = pool.submit(_worker.warm_up, True)
                # cold, the worker without the law has time while this process compiles the
                # loop: it makes the figures of the study's layouts, and its first figures are
                # drawn into them (slidingarm.plotting._recycle; the other has the law to do)
                first = next(iter(setups.values()))
                layouts = (first.nominal.n, tuple(first.controllers)) if cold else None
                for _ in range(workers - 1):
                    pool.submit(_worker.warm_up, False, layouts)
        if parts and E.linked_runs():
            # the loop here while the workers compile its parts (it reaches them through
            # their addresses); the runs then load the parts from the cache
            E.compile_loop()
        for part in parts:
            with suppress(Exception):  # a part a worker could not compile, the run compiles
                part.result()
        figures = _figure_names()

        n_runs = sum(len(s.controllers) for s in setups.values())
        total = n_runs * 2 + len(figures) * len(setups) + 2 + len(GRID_SCENARIOS) + 3
        steps = _Steps(progress, total)

        fig_dir = staging.path / "figures"
        fig_dir.mkdir(parents=True, exist_ok=True)
        # one task per figure, so that the workers stay busy to the end (per scenario, the
        # last scenario's figures were drawn by one worker while the others idled); a
        # scenario's figures are handed out as soon as it is simulated, the dearest first
        futures: dict[str, list[cf.Future[dict[str, Path]]]] = {name: [] for name in setups}
        results: dict[str, dict[str, SimResult]] = {}
        for name, setup in setups.items():
            steps.start(f"{name}: simulating")
            results[name] = simulate_setup(setup)
            steps(f"{name}: simulated", len(setup.controllers))
            if pool is None:
                continue
            with _starting_workers():
                for figure in sorted(figures, key=lambda f: _FIGURE_COST.get(f, 1.0), reverse=True):
                    futures[name].append(
                        pool.submit(
                            _worker.draw,
                            results[name],
                            _title(setup),
                            {figure: fig_dir / figure_stem(name, figure)},
                            None,
                            svg,
                        )
                    )

        for name in setups:
            _stage_runs(staging, name, results[name], steps)
        # pandas and the analyses only now, while the workers draw: imported before the
        # workers were forked, they took half a second of the one core then working
        import pandas as pd

        from slidingarm.study import analysis as A

        metrics = A.metrics_table(results)
        _stage_table(staging, "metrics.csv", metrics)
        steps("metrics")

        steps.start("convergence against docs/theory.md §3")
        convergence = A.convergence_table(results, setups, CONVERGENCE_SCENARIOS)
        chattering = A.chattering_table(metrics)
        steps("convergence and chattering")
        # the gain grids before the errata, which wait for the worker that compiles (or,
        # warm, loads) the paper's law: that worker is done by then
        grids = []
        for name in GRID_SCENARIOS:
            steps.start(f"{name}: gain grid")
            grids.append(A.gain_grid(scenarios[name]))
            steps(f"{name}: gain grid")
        grid = pd.concat(grids, ignore_index=True)
        steps.start("errata")
        if paper_law is not None:
            with suppress(Exception):  # if the worker could not compile it, this process does
                paper_law.result()
        errata = A.errata_table(scenarios[ERRATA_SCENARIO])
        steps("errata")
        checks = A.checks_table(
            metrics,
            results,
            chattering=chattering,
            convergence=convergence,
            setups=setups,
            noisy=(NOISE_SCENARIO,),
        )
        for relative, table in (
            ("convergence.csv", convergence),
            ("chattering.csv", chattering),
            ("errata.csv", errata),
            ("gain_grid.csv", grid),
            ("checks.csv", checks),
        ):
            _stage_table(staging, relative, table)

        figure_paths: dict[str, dict[str, Path]] = {}
        for name, setup in setups.items():
            steps.start(f"{name}: figures")
            if pool is not None:
                drawn = {k: p for future in futures[name] for k, p in future.result().items()}
                paths = {k: drawn[k] for k in figures}  # in report order
            else:
                paths = render_figures(name, results[name], _title(setup), fig_dir, svg=svg)
            figure_paths[name] = {k: p.relative_to(staging.path) for k, p in paths.items()}
            steps(f"{name}: figures", len(figures))
        if pool is not None:
            # every task is done: the workers end while the report is written (joined below)
            ending = _Ending(pool)
            pool = None

        from slidingarm.study.paper_report import ReportContext, write_report

        seeds = {name: setup.seed for name, setup in setups.items()}
        meta = _meta(command, seeds, time.perf_counter() - t0, jobs)
        context = ReportContext(
            metrics=metrics,
            paper_mse=dict(A.PAPER_MSE),
            gains=_gains(scenarios),
            gain_reasons=scenarios[SCENARIOS[0]].gains.reasons or "",
            noise=_noise(scenarios[NOISE_SCENARIO]),
            convergence=convergence,
            chattering=chattering,
            errata=errata,
            grid=grid,
            checks=checks,
            figures=figure_paths,
            kinds={
                name: kind
                for name, scenario in scenarios.items()
                if (kind := scenario_kind(scenario)) is not None
            },
            meta=meta,
        )
        steps.start("report")
        write_report(staging.path, context)
        steps("report")
        runtime = time.perf_counter() - t0
        staging.write_manifest(
            {
                **_meta(command, seeds, runtime, jobs),
                "scenarios": list(setups),
                "checks_passed": bool(checks["passed"].all()),
            }
        )
        files = staging.files()
        _check_terminated()
        staging.publish()
        if ending is not None:
            ending.join()
            ending = None
        steps("done")
    except BaseException:
        if pool is not None:
            _stop_workers(pool)
        if ending is not None:
            ending.stop()
        staging.discard()
        raise
    return StudyOutput(
        Path(out_dir),
        metrics,
        checks,
        runtime_s=time.perf_counter() - t0,
        files=files,
        kept=staging.kept,
    )
