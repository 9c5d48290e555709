"""Running a sweep: the definition, the chunks, the executors and the output folder.

A sweep of ``runs`` draws is cut into chunks of ``chunk`` draws; each chunk is one
:func:`slidingarm.simulate_batch` of ``chunk`` × (number of controllers) runs with
``record="metrics", throw=False`` and one Parquet shard. Every controller of the scenario runs
on the same draws: the same plant, initial state, sensor, disturbances and seed.

The output folder::

    sweep.json          the definition: scenario, distributions, seed, runs, chunk, its hash
    shards/chunk-000000.parquet ...   one per finished chunk (written atomically)
    results.parquet     the final table (one row per run × controller × joint)
    summary.csv         median and bootstrap CI per controller, joint and metric; success rates
    figures/            ecdf.png/.svg, scatter.png/.svg

Rerunning the same sweep into the same folder skips every finished shard (resume after any
interruption, ``kill -9`` included); a different definition is refused, as is a folder that
holds something other than a sweep.
"""

from __future__ import annotations

import hashlib
import io
import json
import math
import os
import time
from collections.abc import Callable, Iterable, Mapping
from concurrent.futures import FIRST_COMPLETED, Executor, Future, ThreadPoolExecutor, wait
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from slidingarm._io import atomic_write_bytes, atomic_write_text
from slidingarm.config.errors import ConfigError
from slidingarm.metrics import METRIC_COLUMNS
from slidingarm.sweep.space import Distribution
from slidingarm.sweep.staging import (
    Stager,
    check_keys,
    columns_of,
    draw_runs,
    key_shapes,
    run_seeds,
)

if TYPE_CHECKING:
    import pandas as pd

    from slidingarm.config.scenario import Scenario
    from slidingarm.results import BatchResult

__all__ = [
    "DEFAULT_CHUNK",
    "SweepDefinition",
    "SweepError",
    "SweepResult",
    "run_chunk",
    "sweep",
]

#: Draws per chunk (and per shard) unless told: 64 draws × 3 controllers = 192 runs, twelve
#: of the batch engine's 16-run thread chunks, about a second of work on the paper arm.
DEFAULT_CHUNK = 64

#: Identifies a folder as a sweep of ours.
FORMAT = "slidingarm-sweep"
FORMAT_VERSION = 1
DEFINITION = "sweep.json"
SHARDS = "shards"
RESULTS = "results.parquet"
SUMMARY = "summary.csv"


class SweepError(ConfigError):
    """A sweep that cannot start: its folder holds something else or another sweep."""


# --------------------------------------------------------------------------------------------
# the definition


@dataclass(frozen=True)
class SweepDefinition:
    """A resolved sweep: what its results depend on, and nothing else.

    Parameters
    ----------
    scenario : dict
        The scenario as :meth:`~slidingarm.config.Scenario.to_dict` gives it, without
        ``sweep``.
    distributions : dict of str to Distribution
        By dotted key, in order.
    seed, runs, chunk : int
    base_dir : str or None
        Where the scenario's relative paths are read from (not part of the hash: the
        scenario's table and URDF paths are absolute in ``scenario``).
    """

    scenario: dict[str, Any]
    distributions: dict[str, Distribution]
    seed: int
    runs: int
    chunk: int
    base_dir: str | None = field(default=None, compare=False)

    def __post_init__(self) -> None:
        for name in ("seed", "runs", "chunk"):
            v = getattr(self, name)
            low = 0 if name == "seed" else 1
            if isinstance(v, bool) or not isinstance(v, int | np.integer) or v < low:
                raise ConfigError(f"must be an integer >= {low}, got {v!r}", path=name)

    @property
    def n_chunks(self) -> int:
        """The number of chunks (and shards)."""
        return math.ceil(self.runs / self.chunk)

    def chunk_runs(self, c: int) -> range:
        """The draws of chunk ``c``."""
        return range(c * self.chunk, min((c + 1) * self.chunk, self.runs))

    def to_dict(self) -> dict[str, Any]:
        """As ``sweep.json`` holds it (with :attr:`hash`)."""
        d: dict[str, Any] = {
            "format": FORMAT,
            "version": FORMAT_VERSION,
            "scenario": self.scenario,
            "distributions": {k: v.to_dict() for k, v in self.distributions.items()},
            "seed": int(self.seed),
            "runs": int(self.runs),
            "chunk": int(self.chunk),
        }
        d["hash"] = _hash(d)
        return d

    @property
    def hash(self) -> str:
        """SHA-256 of the canonical JSON of the definition (scenario, distributions, seed,
        runs, chunk)."""
        return str(self.to_dict()["hash"])

    def build_scenario(self) -> Scenario:
        """The base scenario (validated)."""
        return _scenario(json.dumps(self.scenario, sort_keys=True), self.base_dir)


def _hash(d: Mapping[str, Any]) -> str:
    body = {k: v for k, v in d.items() if k != "hash"}
    text = json.dumps(body, sort_keys=True, separators=(",", ":"), allow_nan=False)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


@lru_cache(maxsize=8)
def _scenario(text: str, base_dir: str | None) -> Scenario:
    from slidingarm.config.loader import scenario_from_dict

    return scenario_from_dict(json.loads(text), base_dir=base_dir)


@lru_cache(maxsize=8)
def _stager(text: str, base_dir: str | None) -> Stager:
    return Stager(_scenario(text, base_dir))


# --------------------------------------------------------------------------------------------
# one chunk: drawn, staged, simulated, tabulated


@dataclass(frozen=True)
class Draw:
    """One draw of a sweep: its index ``run``, its ``values`` by key, its run ``seed``."""

    run: int
    values: dict[str, Any]
    seed: int


@dataclass(frozen=True)
class StagedChunk:
    """A chunk's draws and the inputs of its batch: per draw that the scenario accepts, one
    run per controller (in the scenario's order), all on the draw's plant, initial state,
    sensor, disturbances, torque limit and seed.

    Attributes
    ----------
    draws : tuple of Draw
    refused : tuple of (str or None)
        Per draw, why the scenario refuses its values (``None``: accepted, simulated).
    labels : tuple of str
        The controllers.
    plants, controllers, sensors, disturbances, q0, qd0, torque_limits, seeds : tuple
        One entry per run (accepted draws × controllers), run-major.
    """

    draws: tuple[Draw, ...]
    refused: tuple[str | None, ...]
    labels: tuple[str, ...]
    plants: tuple[Any, ...]
    controllers: tuple[Any, ...]
    sensors: tuple[Any, ...]
    disturbances: tuple[Any, ...]
    q0: tuple[tuple[float, ...], ...]
    qd0: tuple[tuple[float, ...], ...]
    torque_limits: tuple[Any, ...]
    seeds: tuple[int, ...]


def _stager_of(definition: SweepDefinition) -> Stager:
    return _stager(json.dumps(definition.scenario, sort_keys=True), definition.base_dir)


def draw_chunk(definition: SweepDefinition, c: int) -> list[Draw]:
    """The draws of chunk ``c`` (:func:`~slidingarm.sweep.staging.draw_runs`,
    :func:`~slidingarm.sweep.staging.run_seeds`)."""
    stager = _stager_of(definition)
    dists = definition.distributions
    shapes = key_shapes(stager.scenario, dists)
    bases = stager.bases(dists)
    runs = list(definition.chunk_runs(c))
    values = draw_runs(definition.seed, runs, dists, shapes, bases)
    seeds = run_seeds(definition.seed, runs)
    return [Draw(i, v, s) for i, v, s in zip(runs, values, seeds, strict=True)]


def stage_chunk(definition: SweepDefinition, draws: Iterable[Draw]) -> StagedChunk:
    """The objects of each draw's runs (:meth:`~slidingarm.sweep.staging.Stager.build`); a
    draw the scenario refuses is recorded with the reason, not raised."""
    stager = _stager_of(definition)
    labels = tuple(stager.setup.controllers)
    n = stager.setup.nominal.n
    cols: dict[str, list[Any]] = {
        k: [] for k in ("plants", "controllers", "sensors", "disturbances", "q0", "qd0",
                        "torque_limits", "seeds")
    }  # fmt: skip
    kept: list[Draw] = []
    refused: list[str | None] = []
    for draw in draws:
        kept.append(draw)
        try:
            setup = stager.build(draw.values)
        except ConfigError as exc:
            refused.append(str(exc))
            continue
        refused.append(None)
        qd0 = setup.qd0 if setup.qd0 is not None else (0.0,) * n
        for label in labels:
            cols["plants"].append(setup.plant)
            cols["controllers"].append(setup.controllers[label])
            cols["sensors"].append(setup.sensor)
            cols["disturbances"].append(setup.disturbances)
            cols["q0"].append(setup.q0)
            cols["qd0"].append(qd0)
            cols["torque_limits"].append(setup.torque_limit)
            cols["seeds"].append(draw.seed)
    return StagedChunk(
        tuple(kept), tuple(refused), labels, **{k: tuple(v) for k, v in cols.items()}
    )


def simulate_chunk(
    definition: SweepDefinition, staged: StagedChunk, *, threads: int | None = None
) -> BatchResult | None:
    """One :func:`~slidingarm.simulate_batch` of the staged runs, metrics only, each run's
    failure recorded (``throw=False``), on at most ``threads`` threads (``None``: the batch
    engine's default); ``None`` if every draw was refused."""
    from slidingarm.simulate import simulate_batch

    if not staged.plants:
        return None
    base = _stager_of(definition).setup
    limits = staged.torque_limits
    return simulate_batch(
        list(staged.plants),
        list(staged.controllers),
        base.reference,
        q0=np.asarray(staged.q0, dtype=float),
        qd0=np.asarray(staged.qd0, dtype=float),
        t_final=base.t_final,
        dt=base.dt,
        substeps=base.substeps,
        sensor=list(staged.sensors),
        disturbances=list(staged.disturbances),
        torque_limit=list(limits) if any(x is not None for x in limits) else None,
        seeds=list(staged.seeds),
        record="metrics",
        throw=False,
        threads=threads,
    )


def chunk_table(
    definition: SweepDefinition, staged: StagedChunk, result: BatchResult | None
) -> pd.DataFrame:
    """The chunk's table (see :func:`sweep`), column by column: run-major, then controller,
    then joint; a refused draw's rows carry NaN metrics, ``status`` "refused" and the reason."""
    import pandas as pd

    n = _stager_of(definition).setup.nominal.n
    labels = staged.labels
    joints = [str(j + 1) for j in range(n)] + ["mean"]
    J, L, D = len(joints), len(labels), len(staged.draws)
    per_run = L * J
    rows = D * per_run
    valid = np.repeat(np.array([r is None for r in staged.refused], dtype=bool), per_run)
    columns: dict[str, Any] = {
        "run": np.repeat(np.array([d.run for d in staged.draws], dtype=np.int64), per_run),
        "controller": np.tile(np.repeat(np.array(labels, dtype=object), J), D),
        "joint": np.tile(np.array(joints, dtype=object), L * D),
    }
    metrics = result.metrics() if result is not None else None
    for name in METRIC_COLUMNS:
        col = np.full(rows, np.nan)
        if metrics is not None:
            col[valid] = metrics[name].to_numpy(dtype=np.float64)
        columns[name] = col
    params = [columns_of(d.values) for d in staged.draws]
    for key in params[0] if params else ():
        columns[key] = np.repeat(np.array([p[key] for p in params], dtype=np.float64), per_run)
    columns["seed"] = np.repeat(np.array([d.seed for d in staged.draws], dtype=np.int64), per_run)
    ok = np.zeros(rows, dtype=bool)
    status = np.full(rows, "refused", dtype=object)
    message = np.repeat(np.array([r or "" for r in staged.refused], dtype=object), per_run)
    if result is not None:
        ok[valid] = np.repeat(np.asarray(result.ok, dtype=bool), J)
        status[valid] = np.repeat(np.asarray(result.status, dtype=object), J)
        message[valid] = np.repeat(np.asarray(result.message, dtype=object), J)
    columns["ok"] = ok
    columns["status"] = status
    columns["message"] = message
    table = pd.DataFrame(columns)
    for name in ("controller", "joint", "status", "message"):
        table[name] = table[name].astype(str)
    return table


def run_chunk(definition: SweepDefinition, c: int) -> pd.DataFrame:
    """Simulate chunk ``c`` of ``definition``: its table (see :func:`sweep`).

    :func:`draw_chunk`, :func:`stage_chunk`, :func:`simulate_chunk` and :func:`chunk_table`
    in turn. A pure function of ``(definition, c)``, picklable, so that it runs as a Dask task
    on a worker that shares no file system with the client (beyond the scenario's own table or
    URDF files, if it has any).
    """
    staged = stage_chunk(definition, draw_chunk(definition, c))
    return chunk_table(definition, staged, simulate_chunk(definition, staged))


# --------------------------------------------------------------------------------------------
# the folder


def _shard_path(out: Path, c: int) -> Path:
    return out / SHARDS / f"chunk-{c:06d}.parquet"


def _prepare(out: Path, definition: SweepDefinition) -> None:
    """Make ``out`` a folder for ``definition``: create it, or resume into it.

    Raises
    ------
    SweepError
        If ``out`` is a file, holds something other than a sweep, or another sweep.
    """
    text = json.dumps(definition.to_dict(), indent=2, sort_keys=True, allow_nan=False)
    if out.exists() and not out.is_dir():
        raise SweepError("exists and is not a folder; choose another --out", file=out)
    if out.is_dir() and any(out.iterdir()):
        meta = out / DEFINITION
        try:
            old = json.loads(meta.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            old = None
        if not isinstance(old, dict) or old.get("format") != FORMAT:
            raise SweepError(
                f"holds something other than a slidingarm sweep (no readable {DEFINITION}); "
                "nothing was changed; choose an empty or new folder",
                file=out,
            )
        if old.get("hash") != definition.hash:
            raise SweepError(
                f"holds a different sweep (definition {str(old.get('hash'))[:12]}, this one "
                f"{definition.hash[:12]}: {_difference(old, definition.to_dict())}); it is not "
                "resumed or changed; choose another --out",
                file=out,
            )
        return
    out.mkdir(parents=True, exist_ok=True)
    atomic_write_text(out / DEFINITION, text + "\n")


def _difference(old: Mapping[str, Any], new: Mapping[str, Any]) -> str:
    keys = [
        k
        for k in ("runs", "seed", "chunk", "distributions", "scenario", "version")
        if old.get(k) != new.get(k)
    ]
    return "differs in " + ", ".join(keys) if keys else "differs"


def final_table(
    folder: Path, definition: SweepDefinition, known: Mapping[int, pd.DataFrame] | None = None
) -> pd.DataFrame:
    """The shards of ``folder``, in chunk order, as one table, also written (atomically) as
    ``results.parquet``; ``known`` holds chunks' tables already in memory (those this
    process wrote), which are not read back.

    Raises
    ------
    SweepError
        If a shard is missing or unreadable.
    """
    import pandas as pd

    parts = []
    for c in range(definition.n_chunks):
        part = known.get(c) if known is not None else None
        if part is None:
            part = _read_shard(_shard_path(folder, c))
        if part is None:
            raise SweepError(f"shard {c} is missing or cannot be read", file=folder)
        parts.append(part)
    table = pd.concat(parts, ignore_index=True)
    buf = io.BytesIO()
    table.to_parquet(buf, index=False, engine="pyarrow")
    atomic_write_bytes(folder / RESULTS, buf.getvalue())
    return table


def write_shard(path: Path, table: pd.DataFrame) -> None:
    buf = io.BytesIO()
    table.to_parquet(buf, index=False, engine="pyarrow")
    atomic_write_bytes(path, buf.getvalue())


def _read_shard(path: Path) -> pd.DataFrame | None:
    import pandas as pd

    try:
        return pd.read_parquet(path, engine="pyarrow")
    except (OSError, ValueError):
        return None


# --------------------------------------------------------------------------------------------
# executors


def _local_cluster(spec: str) -> tuple[Any, Any]:
    """``local`` or ``local:W``: a :class:`distributed.LocalCluster` of ``W`` worker processes
    (default: the machine's cores) and its client."""
    from distributed import Client, LocalCluster

    _, _, count = spec.partition(":")
    if count:
        try:
            workers = int(count)
        except ValueError:
            workers = 0
        if workers < 1:
            raise ConfigError(f"local:W needs W >= 1 workers, got {spec!r}", path="--dask")
    else:
        workers = os.cpu_count() or 1
    cluster = LocalCluster(
        n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None
    )
    return cluster, Client(cluster)


def _check_executor(executor: Any) -> None:
    """Refuse a bad ``executor`` before anything is written."""
    if isinstance(executor, str) and (executor == "local" or executor.startswith("local:")):
        _, _, count = executor.partition(":")
        if count and not (count.isdigit() and int(count) >= 1):
            raise ConfigError(f"local:W needs W >= 1 workers, got {executor!r}", path="--dask")
    elif isinstance(executor, str):
        if not executor.strip():
            raise ConfigError("an empty scheduler address", path="--dask")
    elif (
        executor is not None
        and not isinstance(executor, Executor)
        and not hasattr(executor, "submit")
    ):
        raise ConfigError(
            "executor must be None (threads), 'local[:W]', a scheduler address, a "
            f"distributed.Client or a concurrent.futures.Executor, got {executor!r}",
            path="executor",
        )


def _client(executor: Any) -> tuple[Any, Any, Any]:
    """``(kind, executor or client, things to close)`` for ``executor``."""
    if executor is None or executor == "threads":
        return "pool", None, None
    if isinstance(executor, str):
        if executor == "local" or executor.startswith("local:"):
            cluster, client = _local_cluster(executor)
            return "dask", client, (client, cluster)
        from distributed import Client

        try:
            client = Client(executor, timeout=30)
        except (OSError, TimeoutError, ValueError) as exc:
            raise ConfigError(
                f"cannot connect to the Dask scheduler {executor!r}: {exc}", path="--dask"
            ) from None
        return "dask", client, (client,)
    try:
        from distributed import Client

        if isinstance(executor, Client):
            return "dask", executor, None
    except ImportError:  # pragma: no cover - distributed is a dependency
        pass
    if isinstance(executor, Executor):
        return "executor", executor, None
    raise ConfigError(
        "executor must be None (threads), 'local[:W]', a scheduler address, a "
        f"distributed.Client or a concurrent.futures.Executor, got {executor!r}",
        path="executor",
    )


def _results(
    kind: str, pool: Any, definition: SweepDefinition, todo: list[int], threads: int
) -> Iterable[tuple[int, pd.DataFrame]]:
    """``(chunk, table)`` of each chunk of ``todo`` as it finishes."""
    if kind == "dask":
        from distributed import as_completed

        futures = {pool.submit(run_chunk, definition, c, pure=False): c for c in todo}
        for fut in as_completed(futures):
            yield futures[fut], fut.result()
        return
    if kind == "executor":
        from concurrent.futures import as_completed as done

        cfutures: dict[Future[pd.DataFrame], int] = {
            pool.submit(run_chunk, definition, c): c for c in todo
        }
        for fut in done(cfutures):
            yield cfutures[fut], fut.result()
        return
    if threads <= 1:
        for c in todo:
            yield c, run_chunk(definition, c)
        return
    # T chunks simulated side by side in T worker threads, each batch on one compiled thread
    # (at most T loops share the cores; the loops release the GIL), and one stager thread that
    # draws and stages chunks ahead of them in order. A worker finds its chunk staged, so the
    # Python of staging overlaps the loops instead of the workers staging at the same moments
    # (workers that start together finish together) and leaving a core idle
    from collections import deque

    with ThreadPoolExecutor(1) as stager, ThreadPoolExecutor(threads) as workers:
        queue = iter(todo)
        ahead: deque[tuple[int, Future[StagedChunk]]] = deque()
        running: dict[Future[pd.DataFrame], int] = {}

        def stage_next() -> bool:
            c = next(queue, None)
            if c is None:
                return False
            ahead.append((c, stager.submit(_drawn_and_staged, definition, c)))
            return True

        def top_up() -> None:
            while len(running) < threads and (ahead or stage_next()):
                c, staged = ahead.popleft()
                running[workers.submit(_simulated, definition, staged)] = c
            while len(ahead) < threads and stage_next():
                pass

        top_up()
        while running:
            finished, _ = wait(running, return_when=FIRST_COMPLETED)
            for fut in sorted(finished, key=running.__getitem__):
                c = running.pop(fut)
                yield c, fut.result()
            top_up()


def _drawn_and_staged(definition: SweepDefinition, c: int) -> StagedChunk:
    return stage_chunk(definition, draw_chunk(definition, c))


def _simulated(definition: SweepDefinition, staged: Future[StagedChunk]) -> pd.DataFrame:
    chunk = staged.result()
    return chunk_table(definition, chunk, simulate_chunk(definition, chunk, threads=1))


# --------------------------------------------------------------------------------------------
# the sweep


@dataclass(frozen=True)
class SweepResult:
    """A finished sweep.

    Attributes
    ----------
    out : Path
        Its folder.
    table : pandas.DataFrame
        One row per run × controller × joint (``"1"`` … ``"n"``, ``"mean"``): ``run``,
        ``controller``, ``joint``, the metrics, the drawn values (``key``, or ``key[j]`` per
        joint from 0; the value applied, an offset included), ``seed``, ``ok``, ``status``,
        ``message``.
    summary : pandas.DataFrame
        :func:`slidingarm.sweep.summary.summarize` of the table.
    definition : SweepDefinition
    computed, resumed : int
        Chunks simulated by this call, and found finished in the folder.
    runtime_s : float
    files : tuple of Path
    """

    out: Path
    table: pd.DataFrame
    summary: pd.DataFrame
    definition: SweepDefinition
    computed: int
    resumed: int
    runtime_s: float
    files: tuple[Path, ...]

    @property
    def failed(self) -> int:
        """Runs × controllers that did not finish (diverged or refused)."""
        rows = self.table[self.table["joint"] == "mean"]
        return int((~rows["ok"].astype(bool)).sum())

    @property
    def status(self) -> str:
        """``"ok"`` if every run finished, else ``"N of M runs failed"``."""
        rows = int((self.table["joint"] == "mean").sum())
        return "ok" if self.failed == 0 else f"{self.failed} of {rows} runs failed"


def definition_of(
    scenario: Scenario,
    *,
    runs: int | None = None,
    vary: Mapping[str, Distribution | Mapping[str, Any] | str] | None = None,
    seed: int | None = None,
    chunk: int | None = None,
) -> SweepDefinition:
    """The sweep of ``scenario``: its ``[sweep]`` table, with ``vary`` added or replacing
    entries and ``runs``, ``seed``, ``chunk`` overriding.

    Raises
    ------
    ConfigError
        Naming the key (or ``runs``) that is missing, unknown or refused.
    """
    spec = scenario.sweep
    dists: dict[str, Distribution] = dict(spec.distributions()) if spec is not None else {}
    for key, d in (vary or {}).items():
        if isinstance(d, str):
            dists[key] = Distribution.parse(key, d)
        else:
            dists[key] = Distribution.from_spec(key, d)
    if not dists:
        raise ConfigError(
            "nothing to vary: add a [sweep] table to the scenario or --vary KEY=DIST "
            "(e.g. --vary 'gains.k=uniform(10,40)')",
            file=scenario.source,
            path="sweep",
        )
    check_keys(scenario, dists)
    n_runs = runs if runs is not None else (spec.runs if spec is not None else None)
    if n_runs is None:
        raise ConfigError("missing: give --runs N or runs in [sweep]", path="runs")
    n_seed = (
        seed
        if seed is not None
        else (spec.seed if spec is not None and spec.seed is not None else scenario.simulation.seed)
    )
    n_chunk = (
        chunk
        if chunk is not None
        else (spec.chunk if spec is not None and spec.chunk is not None else DEFAULT_CHUNK)
    )
    data = scenario.to_dict()
    data.pop("sweep", None)
    base = scenario._base_dir
    return SweepDefinition(
        data, dists, n_seed, n_runs, min(n_chunk, n_runs), None if base is None else str(base)
    )


def sweep(
    scenario: Scenario,
    *,
    runs: int | None,
    out: str | os.PathLike[str],
    vary: Mapping[str, Distribution | Mapping[str, Any] | str] | None = None,
    seed: int | None = None,
    chunk: int | None = None,
    executor: Any = None,
    progress: Callable[[int, int], None] | None = None,
    threads: int = 2,
    figures: bool = True,
    n_resamples: int = 1000,
) -> SweepResult:
    """Monte Carlo over ``scenario``: ``runs`` draws of the distributions, every controller on
    each draw, in chunks, resumable.

    Parameters
    ----------
    scenario : Scenario
    runs : int or None
        Number of draws (``None``: the ``[sweep]`` table's ``runs``).
    out : path
        The sweep's folder: created, or resumed if it holds this very sweep.
    vary : mapping, optional
        Distributions by dotted key (a :class:`Distribution`, a ``[sweep]``-style table or
        the command line's ``"uniform(10, 40)"``), added to or replacing the ``[sweep]``
        table's.
    seed : int, optional
        Seed of the draws (default: the ``[sweep]`` table's, else ``simulation.seed``).
    chunk : int, optional
        Draws per chunk and shard (default :data:`DEFAULT_CHUNK`).
    executor : None, "local[:W]", str, distributed.Client or concurrent.futures.Executor
        Where chunks run: ``None`` in this process (``threads`` chunks side by side);
        ``"local:W"`` a Dask
        ``LocalCluster`` of ``W`` processes; another string the address of a Dask scheduler;
        or a client or executor of yours. The results do not depend on it.
    progress : callable, optional
        ``progress(done, total)`` in draws, after each chunk.
    threads : int
        With ``executor=None``: 1 draws, stages, simulates and tabulates each chunk in turn in
        this thread (its batch on the batch engine's default threads); ``T >= 2`` simulates
        and tabulates ``T`` chunks at a time in ``T`` worker threads, each chunk's batch on one
        thread (``simulate_batch(threads=1)``; the compiled loops release the GIL), while a
        stager thread draws and stages up to ``T`` chunks ahead, so that the Python work
        overlaps the loops and at most ``T`` loops share the cores. The shards and the table
        do not depend on it.
    figures : bool
        Draw the figures.
    n_resamples : int
        Bootstrap resamples of the summary.

    Returns
    -------
    SweepResult

    Raises
    ------
    ConfigError
        For a bad key, distribution or count (naming it), and :class:`SweepError` for a folder
        that holds something else or another sweep (nothing in it is changed).
    """
    from slidingarm.sweep.summary import summarize

    start = time.perf_counter()
    definition = definition_of(scenario, runs=runs, vary=vary, seed=seed, chunk=chunk)
    if isinstance(threads, bool) or not isinstance(threads, int) or threads < 1:
        raise ConfigError(f"must be an integer >= 1, got {threads!r}", path="threads")
    # the draws' objects must build before anything is written: a bad key fails here
    _stager(json.dumps(definition.scenario, sort_keys=True), definition.base_dir)
    _check_executor(executor)
    folder = Path(out)
    _prepare(folder, definition)
    todo: list[int] = []
    done_runs = 0
    for c in range(definition.n_chunks):
        path = _shard_path(folder, c)
        if path.is_file() and _read_shard(path) is not None:
            done_runs += len(definition.chunk_runs(c))
        else:
            todo.append(c)
    for stale in (folder / SHARDS).glob(".chunk-*.tmp") if (folder / SHARDS).is_dir() else []:
        stale.unlink(missing_ok=True)  # a temporary shard of an interrupted write
    resumed = definition.n_chunks - len(todo)
    total = definition.runs
    if progress is not None:
        progress(done_runs, total)
    tables: dict[int, pd.DataFrame] = {}
    if todo:
        kind, pool, owned = _client(executor)
        try:
            for c, table in _results(kind, pool, definition, todo, threads):
                write_shard(_shard_path(folder, c), table)
                tables[c] = table
                done_runs += len(definition.chunk_runs(c))
                if progress is not None:
                    progress(done_runs, total)
        finally:
            for thing in owned or ():
                thing.close()
    table = final_table(folder, definition, tables)
    summary = summarize(table, n_resamples=n_resamples, seed=definition.seed)
    atomic_write_text(folder / SUMMARY, summary.to_csv(index=False))
    params = [c for c in table.columns if _is_param(c)]
    files = [folder / DEFINITION, folder / RESULTS, folder / SUMMARY]
    if figures:
        files += _figures(table, params, folder / "figures")
    return SweepResult(
        out=folder,
        table=table,
        summary=summary,
        definition=definition,
        computed=len(todo),
        resumed=resumed,
        runtime_s=time.perf_counter() - start,
        files=tuple(files),
    )


_TABLE_COLUMNS = frozenset(
    {"run", "controller", "joint", "seed", "ok", "status", "message", *METRIC_COLUMNS}
)


def _is_param(column: str) -> bool:
    return column not in _TABLE_COLUMNS


def _figures(table: pd.DataFrame, params: list[str], folder: Path) -> list[Path]:
    from slidingarm.plotting import save_figure
    from slidingarm.plotting.sweep import plot_ecdf, plot_scatter

    files = save_figure(plot_ecdf(table), folder / "ecdf")
    if params:
        files += save_figure(plot_scatter(table, params=params), folder / "scatter")
    return files
