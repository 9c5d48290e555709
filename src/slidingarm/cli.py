"""The ``slidingarm`` command line: thin verbs that parse, validate, call the library, report.

Verbs: ``reproduce`` (the whole study), ``run`` (one scenario), ``sweep`` (Monte Carlo over a
scenario), ``validate``, ``list``, ``schema``; ``--version``. A user mistake (missing or invalid scenario file, unusable output
folder, a file or folder the system refuses, e.g. a full disk) prints one line on stderr and
exits with status 2; a diverging simulation or a failed
check of the study exits with 1; an interrupt with 130. Progress bars go to stderr and only
when stdout is a terminal.
"""

from __future__ import annotations

import atexit
import json
import math
import os
import shlex
import sys
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Annotated, Any, NoReturn

import typer

from slidingarm._version import __version__

app = typer.Typer(
    name="slidingarm",
    help="Sliding-mode control of robot arms: simulate, compare and reproduce the FTSMC study.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)

#: Exit status of a user mistake (bad file, bad value, unusable output folder).
EXIT_USAGE = 2
#: Exit status of a run that diverged or a study whose checks failed.
EXIT_FAILED = 1
#: Exit status after Ctrl-C.
EXIT_INTERRUPTED = 130
#: Default results folder of ``reproduce`` (its one definition: the library's
#: :func:`slidingarm.study.reproduce` takes the folder as an argument).
DEFAULT_OUT = Path("slidingarm-results")


def _version_callback(value: bool) -> None:
    if value:
        typer.echo(f"slidingarm {__version__}")
        raise typer.Exit()


@app.callback()
def _root(
    version: bool = typer.Option(
        False,
        "--version",
        callback=_version_callback,
        is_eager=True,
        help="Print the version and exit.",
    ),
) -> None:
    """Sliding-mode control of robot arms."""


# --------------------------------------------------------------------------------------------
# plumbing


def _fail(message: str, code: int = EXIT_USAGE) -> NoReturn:
    typer.echo(f"error: {' '.join(str(message).split())}", err=True)
    raise typer.Exit(code)


def _command(*words: object) -> str:
    """The command line as it would be typed (for the manifest and report)."""
    return " ".join(["slidingarm", *(shlex.quote(str(w)) for w in words)])


@contextmanager
def _errors() -> Iterator[None]:
    """Turn the library's errors into one line on stderr and an exit status."""
    from slidingarm.config import ConfigError
    from slidingarm.simulate import RunTooLargeError, SimulationError
    from slidingarm.study.output import OutputError

    try:
        yield
    except (ConfigError, OutputError, RunTooLargeError) as exc:
        _fail(str(exc), EXIT_USAGE)
    except SimulationError as exc:
        _fail(str(exc), EXIT_FAILED)
    except OSError as exc:
        # the system refused a file or folder the user chose (disk full, permissions, ...);
        # the staged output has been discarded by then
        where = f"{exc.filename}: " if exc.filename else ""
        _fail(f"{where}{exc.strerror or exc}; nothing was written", EXIT_USAGE)
    except KeyboardInterrupt:
        _fail("interrupted; the output folder was left as it was", EXIT_INTERRUPTED)


@contextmanager
def _progress(*, thread: bool = True) -> Iterator[Callable[[str, int, int], None] | None]:
    """A rich progress bar on stderr when stdout is a terminal; otherwise no callback.

    Without ``thread`` the bar is redrawn at each step rather than by a thread of its own
    (``auto_refresh`` off; its clock then moves by steps): a process running no other thread
    can fork its workers (:func:`slidingarm.study.reproduce`), which starts them about a second
    sooner."""
    if not sys.stdout.isatty():
        yield None
        return
    from rich.console import Console
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    bar = Progress(
        TextColumn("{task.description:<34}"),
        BarColumn(),
        TextColumn("{task.completed}/{task.total}"),
        TimeElapsedColumn(),
        console=Console(stderr=True),
        transient=True,
        auto_refresh=thread,
    )
    task = bar.add_task("starting", total=None)

    def update(what: str, done: int, total: int) -> None:
        bar.update(task, description=what, completed=done, total=total, refresh=True)

    with bar:
        yield update


def _mse_table(metrics: Any) -> str:
    mean = metrics[metrics["joint"] == "mean"]
    wide = mean.pivot(index="scenario", columns="controller", values="mse")
    wide = wide.loc[list(dict.fromkeys(mean["scenario"])), list(dict.fromkeys(mean["controller"]))]
    head = f"{'MSE (rad², mean over joints)':<30}" + "".join(f"{c:>12}" for c in wide.columns)
    lines = [head]
    for scenario, row in wide.iterrows():
        lines.append(f"{scenario!s:<30}" + "".join(f"{v:>12.4g}" for v in row.to_numpy()))
    return "\n".join(lines)


#: Help of ``--overwrite`` (``run`` and ``reproduce``).
_OVERWRITE_HELP = (
    "Replace another scenario's results in the folder (and files no manifest lists); never a "
    "file edited since its manifest recorded it, nor the run's input."
)


def _report_kept(kept: list[Path], out: Path) -> None:
    """Say which of the previous run's files were kept because they were edited."""
    if kept:
        names = ", ".join(str(p) for p in kept[:5]) + (
            f" and {len(kept) - 5} more" if len(kept) > 5 else ""
        )
        typer.echo(
            f"kept in {out} (changed since the previous run wrote them, or this run's input; "
            f"not part of these results): {names}",
            err=True,
        )


def _load(config: str) -> Any:
    from slidingarm.study import resolve_scenario

    return resolve_scenario(config)


# --------------------------------------------------------------------------------------------
# verbs


@app.command()
def reproduce(
    out: Annotated[
        Path, typer.Option("--out", "-o", help="Results folder (created if needed).")
    ] = DEFAULT_OUT,
    jobs: Annotated[
        int,
        typer.Option(
            "--jobs", "-j", min=0, help="Processes drawing figures (0: automatic, 1: none)."
        ),
    ] = 0,
    overwrite: Annotated[bool, typer.Option("--overwrite", help=_OVERWRITE_HELP)] = False,
    svg: Annotated[
        bool,
        typer.Option(
            "--svg", help="Also save every figure as SVG (the report shows the PNGs; slower)."
        ),
    ] = False,
) -> None:
    """Regenerate the study: 3 scenarios × 3 controllers, CSVs, metrics, figures, report."""
    from slidingarm.study import reproduce as run_study

    words: list[object] = ["--out", out, *(["--jobs", jobs] if jobs else [])]
    flags = [*(["--overwrite"] if overwrite else []), *(["--svg"] if svg else [])]
    with _errors(), _progress(thread=False) as progress:
        result = run_study(
            out,
            progress=progress,
            command=_command("reproduce", *words, *flags),
            jobs=jobs or None,
            overwrite=overwrite,
            svg=svg,
        )
    _report_kept(result.kept, out)
    typer.echo(f"wrote {out} ({len(result.files)} files) in {result.runtime_s:.1f} s")
    typer.echo(f"report: {out / 'report.html'}")
    typer.echo(_mse_table(result.metrics))
    checks = result.checks
    failed = checks[~checks["passed"].astype(bool)]
    typer.echo(f"checks: {len(checks) - len(failed)}/{len(checks)} passed")
    if len(failed):
        for _, row in failed.iterrows():
            typer.echo(
                f"failed check: {row['name']}: {row['value']} (threshold {row['threshold']})",
                err=True,
            )
        _fail(f"{len(failed)} of {len(checks)} checks failed; see {out / 'report.md'}", EXIT_FAILED)


@app.command()
def run(
    config: Annotated[
        str, typer.Argument(help="Scenario file, or the name of a shipped scenario.")
    ],
    out: Annotated[Path, typer.Option("--out", "-o", help="Results folder (created if needed).")],
    figures: Annotated[
        bool, typer.Option("--figures/--no-figures", help="Draw the figures.")
    ] = True,
    overwrite: Annotated[bool, typer.Option("--overwrite", help=_OVERWRITE_HELP)] = False,
) -> None:
    """Run one scenario: CSVs, metrics.csv, figures and the config used."""
    from slidingarm.study import run as run_one

    with _errors():
        scenario = _load(config)
        with _progress() as progress:
            options = [
                *([] if figures else ["--no-figures"]),
                *(["--overwrite"] if overwrite else []),
            ]
            command = _command("run", config, "--out", out, *options)
            result = run_one(
                scenario,
                out,
                progress=progress,
                command=command,
                figures=figures,
                overwrite=overwrite,
            )
    _report_kept(result.kept, out)
    typer.echo(f"wrote {out} ({len(result.files)} files) in {result.runtime_s:.1f} s")
    typer.echo(_mse_table(result.metrics))


@app.command()
def validate(
    config: Annotated[
        str, typer.Argument(help="Scenario file, or the name of a shipped scenario.")
    ],
) -> None:
    """Check a scenario file: keys, types, ranges, and that it builds."""
    with _errors():
        scenario = _load(config)
        setup = scenario.build()
    n_samples = round(setup.t_final / setup.dt) + 1
    names = ", ".join(setup.controllers)
    typer.echo(
        f"ok: {scenario.source or config}: scenario {setup.name!r}, {setup.nominal.n}-joint arm, "
        f"{len(setup.controllers)} controllers ({names}), switching {scenario.switching}, "
        f"{n_samples} samples of {setup.dt:g} s"
    )


@app.command(name="list")
def list_() -> None:
    """List controllers, laws, references, sensors, disturbances, shipped scenarios and robots."""
    from slidingarm import robots
    from slidingarm.config import CONTROLLERS, choices
    from slidingarm.study import SHIPPED, load_shipped

    typer.echo("controllers:")
    for name, text in CONTROLLERS.items():
        typer.echo(f"  {name:<8} {text}")
    for section, values in choices().items():
        typer.echo(f"{section}: {', '.join(values)}")
    typer.echo("scenarios (shipped; run with `slidingarm run NAME --out DIR`):")
    for name in SHIPPED:
        typer.echo(f"  {name:<8} {load_shipped(name).description}")
    typer.echo("robots (shipped URDFs; load with `slidingarm.robots.load(NAME)`):")
    for name in robots.names():
        typer.echo(f"  {name:<8} {robots.describe(name)}")


@app.command()
def schema() -> None:
    """Print the JSON schema of a scenario file."""
    from slidingarm.config import Scenario

    typer.echo(json.dumps(Scenario.model_json_schema(), indent=2, ensure_ascii=False))


@app.command(name="sweep")
def sweep_(
    config: Annotated[
        str, typer.Argument(help="Scenario file, or the name of a shipped scenario.")
    ],
    out: Annotated[
        Path, typer.Option("--out", "-o", help="Sweep folder (created, or resumed if it holds this sweep).")
    ],
    runs: Annotated[
        int | None, typer.Option("--runs", "-n", help="Number of draws (default: [sweep] runs).")
    ] = None,
    vary: Annotated[
        list[str] | None,
        typer.Option(
            "--vary",
            help="KEY=DIST, e.g. 'gains.k=uniform(10,40)', 'simulation.q0=+normal(0,0.05)' (+: "
            "an offset); adds to or replaces the [sweep] table's entry. Repeatable.",
        ),
    ] = None,
    dask: Annotated[
        str | None,
        typer.Option(
            "--dask",
            help="Run the chunks on Dask: 'local' or 'local:W' (a LocalCluster of W processes) "
            "or a scheduler ADDRESS.",
        ),
    ] = None,
    chunk: Annotated[
        int | None, typer.Option("--chunk", help="Draws per chunk and shard.")
    ] = None,
    seed: Annotated[
        int | None, typer.Option("--seed", help="Seed of the draws (default: [sweep] seed).")
    ] = None,
    figures: Annotated[
        bool, typer.Option("--figures/--no-figures", help="Draw the figures.")
    ] = True,
) -> None:
    """Monte Carlo over a scenario: every controller on the same draws, resumable."""
    from slidingarm.config import ConfigError
    from slidingarm.sweep import sweep as run_sweep
    from slidingarm.sweep.summary import summary_text

    with _errors():
        scenario = _load(config)
        entries: dict[str, str] = {}
        for item in vary or []:
            key, eq, dist = item.partition("=")
            if not eq or not key.strip():
                raise ConfigError(
                    f"must be KEY=DIST, e.g. 'gains.k=uniform(10,40)', got {item!r}", path="--vary"
                )
            entries[key.strip()] = dist
        with _sweep_progress() as progress:
            result = run_sweep(
                scenario,
                runs=runs,
                out=out,
                vary=entries,
                seed=seed,
                chunk=chunk,
                executor=dask,
                progress=progress,
                figures=figures,
            )
    d = result.definition
    typer.echo(
        f"wrote {out}: {d.runs} draws × {len(result.table['controller'].unique())} controllers "
        f"in {d.n_chunks} chunks ({result.computed} run now, {result.resumed} resumed) in "
        f"{result.runtime_s:.1f} s; {result.status}"
    )
    typer.echo("varied: " + ", ".join(f"{k} ~ {v}" for k, v in d.distributions.items()))
    typer.echo(summary_text(result.summary))


@contextmanager
def _sweep_progress() -> Iterator[Callable[[int, int], None] | None]:
    """A rich progress bar with rate and ETA on stderr when it is a terminal; else none."""
    if not sys.stderr.isatty():
        yield None
        return
    from rich.console import Console
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TaskProgressColumn,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

    bar = Progress(
        TextColumn("sweep"),
        BarColumn(),
        MofNCompleteColumn(),
        TaskProgressColumn(),
        TextColumn("{task.fields[rate]}"),
        TimeElapsedColumn(),
        TextColumn("ETA"),
        TimeRemainingColumn(),
        console=Console(stderr=True),
        transient=True,
    )
    task = bar.add_task("sweep", total=None, rate="")
    first: list[tuple[float, int]] = []

    def update(done: int, total: int) -> None:
        import time

        now = time.perf_counter()
        if not first:
            # resumed draws are not progress made now: they count in neither rate nor ETA
            first.append((now, done))
            bar.reset(task, total=total, completed=done, rate="")
            return
        t0, d0 = first[0]
        rate = f"{(done - d0) / (now - t0):.1f} draws/s" if now > t0 and done > d0 else ""
        bar.update(task, completed=done, total=total, rate=rate)

    with bar:
        yield update


def _pareto_lines(result: Any, limit: int = 20) -> list[str]:
    """The Pareto front as text: trial, gains, objectives; the knee marked ``*``."""
    front = result.pareto
    if front.empty:
        return []
    best = result.best
    names = [*result.space.names, *result.objectives]
    lines = ["  trial " + "".join(f"{n:>13}" for n in names)]
    for _, row in front.head(limit).iterrows():
        mark = "*" if int(row["trial"]) == best else " "
        lines.append(
            f"{mark}{int(row['trial']):>6} " + "".join(f"{float(row[n]):>13.5g}" for n in names)
        )
    if len(front) > limit:
        lines.append(f"  ... {len(front) - limit} more in {result.out_dir / 'pareto.csv'}")
    lines.append(f"  * the knee (--export best): trial {best}")
    return lines


def _pairs(values: list[str] | None, option: str) -> dict[str, float]:
    from slidingarm.config import ConfigError

    out: dict[str, float] = {}
    for text in values or []:
        name, sep, value = text.partition("=")
        try:
            number = float(value)
        except ValueError:
            number = float("nan")
        if not sep or not name.strip() or number != number:
            raise ConfigError(f"expected METRIC=VALUE, got {text!r}", path=option)
        out[name.strip()] = number
    return out


@app.command()
def tune(
    config: Annotated[
        str, typer.Argument(help="Scenario file, or the name of a shipped scenario.")
    ],
    controller: Annotated[
        str,
        typer.Option(
            "--controller",
            "-c",
            help="The controller to tune: a label of the scenario, or a class (pdsmc, tsmc, "
            "ftsmc, ntsmc) added with its shared gains.",
        ),
    ],
    trials: Annotated[int, typer.Option("--trials", "-n", min=1, help="Total trial budget.")],
    out: Annotated[Path, typer.Option("--out", "-o", help="Tuning folder (resumed if it exists).")],
    objectives: Annotated[
        str, typer.Option("--objectives", help="Metrics to minimise, comma-separated.")
    ] = "mse,chattering,peak_torque",
    robust: Annotated[
        int,
        typer.Option(
            "--robust", min=0, help="Score each trial on the scenario's [sweep] draws 0..K-1."
        ),
    ] = 0,
    statistic: Annotated[
        str, typer.Option("--statistic", help="Reduction over the draws: mean or p90.")
    ] = "mean",
    bound: Annotated[
        list[str] | None,
        typer.Option(
            "--bound", help="Gain interval NAME=LOW:HIGH[:log|linear] or NAME=fixed (repeat)."
        ),
    ] = None,
    limit: Annotated[
        list[str] | None,
        typer.Option("--limit", help="Constraint METRIC=VALUE: metric <= value (repeat)."),
    ] = None,
    export: Annotated[
        list[str] | None,
        typer.Option(
            "--export", help="Write trial TRIAL (or 'best', the knee) as a scenario file (repeat)."
        ),
    ] = None,
    sampler: Annotated[str, typer.Option("--sampler", help="nsga2 or tpe.")] = "nsga2",
    seed: Annotated[int, typer.Option("--seed", min=0, help="Seed of the sampler.")] = 0,
    population: Annotated[
        int, typer.Option("--population", min=2, help="NSGA-II's population size.")
    ] = 20,
) -> None:
    """Tune one controller's gains with optuna: Pareto front, figure, exports; resumable."""
    from slidingarm.config import ConfigError
    from slidingarm.tune import parse_bound
    from slidingarm.tune import tune as run_tuning

    with _errors():
        scenario = _load(config)
        bounds = dict(parse_bound(b) for b in bound or [])
        limits = _pairs(limit, "--limit")
        wanted: list[int | str] = []
        for e in export or []:
            if e != "best" and not e.isdigit():
                raise ConfigError(f"expected a trial number or 'best', got {e!r}", path="--export")
            wanted.append("best" if e == "best" else int(e))
        names = [o.strip() for o in objectives.split(",") if o.strip()]
        try:
            with _progress() as progress:
                result = run_tuning(
                    scenario,
                    controller=controller,
                    trials=trials,
                    out=out,
                    objectives=names,
                    bounds=bounds,
                    limits=limits,
                    robust=robust,
                    statistic=statistic,  # type: ignore[arg-type]
                    sampler=sampler,  # type: ignore[arg-type]
                    seed=seed,
                    population=population,
                    progress=progress,
                )
        except KeyboardInterrupt:
            _fail(
                f"interrupted; the finished trials are kept in {out}: rerun the same command to "
                "resume",
                EXIT_INTERRUPTED,
            )
    typer.echo(
        f"tuned {result.controller} of {scenario.key} in {out}: {result.message} "
        f"({result.ran} run now, {result.kept} kept) in {result.runtime_s:.1f} s"
    )
    for line in _pareto_lines(result):
        typer.echo(line)
    if not result.ok:
        _fail(result.message, EXIT_FAILED)
    for k in wanted:
        try:
            path = result.export(k)  # type: ignore[arg-type]
        except ValueError as exc:
            _fail(f"--export {k}: {exc}", EXIT_USAGE)
        typer.echo(f"exported {path} (slidingarm run {path} --out DIR)")


@app.command()
def compare(
    config: Annotated[
        str,
        typer.Argument(help="Scenario file with a [sweep] table (e.g. the shipped robust.toml)."),
    ],
    out: Annotated[Path, typer.Option("--out", "-o", help="Comparison folder (resumed).")],
    quick: Annotated[
        bool, typer.Option("--quick", help="A smoke run of the pipeline (under a minute).")
    ] = False,
    limit: Annotated[
        list[str] | None,
        typer.Option(
            "--limit", help="Constraint METRIC=VALUE of every tuning (default: the scenario's)."
        ),
    ] = None,
    vary: Annotated[
        list[str] | None,
        typer.Option("--vary", help="Add a draw to the [sweep]: KEY=DIST, e.g. mismatch.payload=uniform(0,0.5)."),
    ] = None,
    seed: Annotated[int, typer.Option("--seed", min=0, help="Seed of the tunings.")] = 0,
) -> None:
    """Fair comparison: five controllers tuned alike, tested on the same draws, ranked."""
    from slidingarm.config import ConfigError
    from slidingarm.tune.compare import FULL, QUICK
    from slidingarm.tune.compare import compare as run_compare

    with _errors():
        scenario = _load(config)
        limits = _pairs(limit, "--limit") if limit else None
        draws: dict[str, str] = {}
        for text in vary or []:
            key, sep, dist = text.partition("=")
            if not sep or not key.strip():
                raise ConfigError(f"expected KEY=DIST, got {text!r}", path="--vary")
            draws[key.strip()] = dist.strip()
        try:
            with _progress() as progress:
                result = run_compare(
                    scenario,
                    out=out,
                    budget=QUICK if quick else FULL,
                    limits=limits,
                    vary=draws or None,
                    seed=seed,
                    progress=progress,
                )
        except KeyboardInterrupt:
            _fail(
                f"interrupted; finished trials and chunks are kept in {out}: rerun the same "
                "command to resume",
                EXIT_INTERRUPTED,
            )
    typer.echo(result.headline)
    typer.echo(f"{'controller':<10}{'median MSE':>12}{'95 % CI':>24}{'success':>9}  gains")
    for _, r in result.controllers.iterrows():
        median = float(r.get("median_mse", float("nan")))
        if not r["gains"] or math.isnan(median):
            typer.echo(f"{r['controller']:<10}  no feasible gains within the limits (not tested)")
            continue
        ci = f"[{r['median_low']:.4g}, {r['median_high']:.4g}]"
        typer.echo(
            f"{r['controller']:<10}{median:>12.4g}{ci:>24}{r['success']:>9.1%}  {r['gains']}"
        )
    typer.echo(f"report: {out / 'report.md'} ({result.runtime_s:.0f} s)")


def _click_error(name: str) -> type[Exception]:
    """The class ``name`` of the click typer runs on (typer >= 0.22 ships its own copy of
    click, so ``import click`` may be another module): found from typer's public
    ``BadParameter``, a ``UsageError`` and a ``ClickException``."""
    return next(c for c in typer.BadParameter.__mro__ if c.__name__ == name)


def main(argv: list[str] | None = None) -> None:
    """Entry point of the ``slidingarm`` console script (``argv`` default: ``sys.argv[1:]``).

    A usage error (a missing argument or ``--out``, an unknown option or command, a value
    click cannot convert) prints one line, ``error: ...`` with where to find help, on stderr
    and exits with :data:`EXIT_USAGE`, as every other user mistake does; no arguments at all
    print the help (and exit with 2, as before).
    """
    usage_error = _click_error("UsageError")
    click_error = _click_error("ClickException")
    try:
        code = app(args=argv, prog_name="slidingarm", standalone_mode=False)
    except usage_error as exc:
        ctx = getattr(exc, "ctx", None)
        if type(exc).__name__ == "NoArgsIsHelpError" and ctx is not None:
            typer.echo(ctx.get_help(), nl=False)
            sys.exit(EXIT_USAGE)
        where = f"{ctx.command_path}: " if ctx is not None else ""
        hint = f"; see '{ctx.command_path} --help'" if ctx is not None else ""
        text = " ".join(exc.format_message().split()).rstrip(".")  # type: ignore[attr-defined]
        typer.echo(f"error: {where}{text[:1].lower()}{text[1:]}{hint}", err=True)
        sys.exit(EXIT_USAGE)
    except click_error as exc:
        text = " ".join(exc.format_message().split())  # type: ignore[attr-defined]
        typer.echo(f"error: {text}", err=True)
        sys.exit(getattr(exc, "exit_code", 1))
    except typer.Abort:
        typer.echo("error: aborted", err=True)
        sys.exit(EXIT_FAILED)
    sys.exit(code if isinstance(code, int) else 0)


def script() -> NoReturn:
    """The ``slidingarm`` console script and ``python -m slidingarm``: :func:`main`, then the
    process ends at once with its exit status.

    A finished command has written and closed its files (atomically) and joined its worker
    processes; what the interpreter would still do is tear down the modules and objects it
    holds (numba's compiled code, pandas), about half a second after ``reproduce``. So, in the
    order the interpreter's own shutdown takes, the threads that are not daemons are waited
    for, the exit handlers run (:mod:`atexit`: multiprocessing's and Dask's clean-ups among
    them), the standard streams are flushed, and :func:`os._exit` ends the process with the
    status :func:`main` exited with (a status that is not a number is printed on stderr and
    exits with 1, as Python does).
    """
    try:
        main()
        code: object = 0
    except SystemExit as exc:
        code = exc.code
    if code is None:
        code = 0
    elif not isinstance(code, int):
        print(code, file=sys.stderr)
        code = 1
    for thread in threading.enumerate():
        if thread is not threading.current_thread() and not thread.daemon:
            thread.join()
    atexit._run_exitfuncs()
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):  # a closed pipe or stream: nothing more can reach it
            code = code or EXIT_FAILED
    os._exit(code)
