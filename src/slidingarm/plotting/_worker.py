"""What a figure worker process of :func:`slidingarm.study.reproduce` runs.

The functions a worker is handed (its initializer and its tasks) are pickled by reference, so
a spawned worker (not Linux, or a parent running other threads) imports the module they live
in. They live here, beside the plotting code and away from :mod:`slidingarm.study`, so that
such a worker imports only the package, matplotlib and the plotting code: not pandas, the
scenario files' machinery nor the study's analyses (about 0.9 s of CPU per worker). A forked
worker has its parent's modules already, and imports matplotlib at its first warm-up.
"""

from __future__ import annotations

import ctypes
import importlib
import os
import signal
import sys
import threading
import time
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from slidingarm._gc import after_task, hold_in_worker

if TYPE_CHECKING:
    import numpy as np

    from slidingarm.results import SimResult

__all__ = [
    "WORKER_NICENESS",
    "compile_loop_part",
    "compile_paper_law",
    "draw",
    "init_worker",
    "warm_up",
]

#: ``prctl`` option asking Linux to send a signal to this process when its parent dies.
_PR_SET_PDEATHSIG = 1
#: How often a figure worker checks that its parent still runs (s).
_WATCH_PERIOD_S = 0.5
#: How much a figure worker lowers its scheduling priority (:func:`os.nice`). While the main
#: process compiles and simulates, the workers' start-up (imports, warm-up, the paper's law)
#: would otherwise take a third of its core from it (three busy processes on two cores); so
#: lowered, the workers take what the main process leaves. Later, while they draw, the main
#: process has little to do, so their figures are not delayed.
WORKER_NICENESS = 5


def init_worker(parent: int) -> None:
    """Initializer of a figure worker: restore SIGTERM's default action and the standard
    streams (a forked worker inherits its parent's), lower its priority by
    :data:`WORKER_NICENESS` and end it as soon as ``parent`` (the process that started it)
    dies, even by ``kill -9``, so that no worker outlives an interrupted study.

    On Linux the kernel kills the worker when its parent dies (``prctl(PR_SET_PDEATHSIG,
    SIGKILL)``); everywhere a daemon thread also polls :func:`os.getppid`, which changes from
    ``parent`` when the parent is gone.
    """
    if sys.platform.startswith("linux"):
        try:
            libc = ctypes.CDLL(None, use_errno=True)
            libc.prctl(_PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0)
        except (OSError, AttributeError):  # no prctl: the thread below still watches
            pass
    if os.getppid() != parent:  # the parent died before the worker got here
        os._exit(1)
    # a forked worker starts with its parent's state: SIGTERM's default action again (the
    # parent may handle it, the study as Ctrl-C, an application its own way), and the real
    # standard streams (a terminal's progress bar redirects them in the parent)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    sys.stdout, sys.stderr = sys.__stdout__, sys.__stderr__
    if hasattr(os, "nice"):  # before the thread below, which would keep the old priority
        try:
            os.nice(WORKER_NICENESS)
        except OSError:  # not allowed here: the worker keeps its priority
            pass

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(_WATCH_PERIOD_S)
        os._exit(1)

    threading.Thread(target=watch, name="slidingarm-watch-parent", daemon=True).start()
    # automatic garbage collection off (it was 15-20 % of a figure's drawing): what the worker
    # has now is frozen, and each figure task collects what it left (slidingarm._gc)
    hold_in_worker()


def warm_up(paper_law: bool = False, layouts: tuple[int, Sequence[str]] | None = None) -> None:
    """Make a worker process ready for its first figure while the main process compiles and
    simulates: import the plotting stack (matplotlib, its Agg backend and the plotting code);
    with ``paper_law``, first :func:`compile_paper_law` (one task, so that the worker that
    compiles it is made ready too: a second warm-up task would go to whichever worker is
    free, the other one). The law's small callees (the model's ``sincos``) are cached by the
    loop's parts (:data:`slidingarm._engine.LOOP_PARTS`) when the study is cold; a forked worker
    inherits numba's set-up from the main process (:func:`slidingarm._engine.prime`).

    With ``layouts = (joints, labels)`` it then makes the figures of every layout a scenario of
    that many joints and those run labels draws, and hands them back
    (:func:`prepare_figures`), so that the worker's first figures are drawn into them. A cold
    study gives it while its main process compiles the loop: the other core, once it has
    compiled the paper's law, waits for the simulations then (about half a second, more for the
    worker without the law). Otherwise it draws nothing: a small figure drawn only to load the
    fonts and fill matplotlib's caches cost 0.15-0.2 CPU-s more than it saved."""
    if paper_law:
        compile_paper_law()
    for module in (
        "matplotlib.figure",
        "matplotlib.backends.backend_agg",
        "slidingarm.plotting.figures",
        "slidingarm.plotting._save",
    ):
        importlib.import_module(module)
    if layouts is not None:
        prepare_figures(*layouts)
    after_task()  # the paper's law's compilation


def prepare_figures(joints: int, labels: Sequence[str]) -> None:
    """Draw (without rendering) one figure of each layout of
    :func:`slidingarm.plotting.scenario_figures` for ``joints`` joints and runs labelled
    ``labels``, on made-up runs, and hand each back (:mod:`slidingarm.plotting._recycle`): the
    panels of every joint stacked (the tracking, velocity, error and steady-state figures), one
    joint's panel (joint 1's tracking), and a row per joint and a column per run (torque,
    sliding variable). The real figures are then drawn into them, as into any figure handed
    back: the same files as new figures'."""
    import matplotlib
    import numpy as np

    from slidingarm.plotting import _recycle, scenario_figures
    from slidingarm.plotting._style import RC
    from slidingarm.results import SimResult

    t = np.linspace(0.0, 1.0, 64)
    wave = np.sin(np.outer(t, np.arange(1, joints + 1)))
    signals = dict.fromkeys(("q", "qd", "q_ref", "qd_ref", "q_meas", "qd_meas", "tau", "s"), wave)
    made_up = {label: SimResult(t=t, **signals, params={}, seed=None) for label in labels}
    for name in ("tracking_all", "tracking_joint1", "torque"):
        fig = scenario_figures(made_up, title="", only=[name])[name]
        # the ticks are made in a draw; one without rendering (at the figure's own dpi, not
        # the PNG's: the real saves make their ticks again) serves as well as a saved PNG
        # did, for the same files afterwards, at about a tenth of its CPU (0.05 against
        # 0.65 s for the three)
        with matplotlib.rc_context(RC):
            fig.draw_without_rendering()
        _recycle.give_back(fig)
    del fig, made_up


def compile_loop_part(index: int) -> None:
    """Compile part ``index`` of the loop (:data:`slidingarm._engine.LOOP_PARTS`) into numba's
    cache, on another core while the main process starts up; the main process then compiles
    only the loop's own body (nothing to do if the part is cached already)."""
    from slidingarm import _engine

    _engine.compile_part(index)


def compile_paper_law() -> None:
    """Compile the paper's law (the errata's, reached through a pointer) into numba's cache
    in a worker process, on the other core while the main process compiles the loop; the
    main process then loads it from the cache. Nothing to do if it is cached already."""
    from slidingarm.control import _dispatch as LD

    LD.paper_pointer()


def draw(
    results: Mapping[str, SimResult],
    title: str,
    stems: Mapping[str, str | os.PathLike[str]],
    tool_paths: tuple[np.ndarray, Mapping[str, np.ndarray]] | None = None,
    svg: bool = True,
) -> dict[str, Path]:
    """Draw the figures ``stems`` names (figure name → path without extension) of one
    scenario's ``results`` and save each as ``<stem>.png`` and, with ``svg``, ``<stem>.svg``
    (:func:`slidingarm.plotting.save_figure`); return figure name → PNG path, in the order
    of ``stems``. ``tool_paths`` as :func:`slidingarm.study.reproduce.render_figures`."""
    from slidingarm.plotting import _recycle, save_figure, scenario_figures
    from slidingarm.plotting.figures import chosen_figures

    desired, actual = (None, None) if tool_paths is None else tool_paths
    # every name checked before any figure is drawn
    only: Sequence[str] = chosen_figures(list(stems), tool=actual is not None)
    paths: dict[str, Path] = {}
    for fig_name in only:
        # one figure at a time, handed back once saved (not cleared: that would rebuild its
        # ticks), so that the next figure of its layout is drawn into it
        # (slidingarm.plotting._recycle)
        fig = scenario_figures(
            results, title=title, only=[fig_name], tool_paths=actual, tool_reference=desired
        )[fig_name]
        written = save_figure(fig, stems[fig_name], clear=False, svg=svg)
        _recycle.give_back(fig)
        paths[fig_name] = next(p for p in written if p.suffix == ".png")
    # the dropped figures' cycles (automatic collection is off in a worker, init_worker)
    after_task()
    return paths
