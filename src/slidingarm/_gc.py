"""Python's cyclic garbage collector held back during work that allocates objects in bursts.

Numba's compilation and matplotlib's drawing each create hundreds of thousands of small
container objects. Each time allocations outnumber deallocations by 700, CPython 3.11 collects
its youngest generation (and every tenth time the next one too), walking everything those
generations hold. Measured cold, in one process: those collections were 1.0 CPU-s of the
5.9-6.3 that compiling the loop's parts and the loop and running one scenario took (5.2-5.4
without them); and 0.2-0.5 CPU-s of the 1.35-2.1 that drawing one scenario's seven figures
took. Most of those objects are freed by reference counting as soon as they are dropped; the
rest are cycles (numba's IR, a figure and its artists: about 290 000 unreachable objects after
compiling the loop's parts), freed by the next collection: in a figure worker the one after
each figure task (:func:`after_task`), elsewhere the first automatic one after :func:`paused`.
"""

from __future__ import annotations

import gc
from collections.abc import Iterator
from contextlib import contextmanager

__all__ = ["after_task", "hold_in_worker", "paused"]

#: Whether this process is a worker that collects only between its tasks (:func:`hold_in_worker`).
_holding = False


@contextmanager
def paused() -> Iterator[None]:
    """No automatic collection while the block runs; the collector's state restored after (a
    collection is not forced: the next automatic one frees the cycles the block left). The
    state is the process's: other threads run without automatic collection meanwhile too."""
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if enabled:
            gc.enable()


def hold_in_worker() -> None:
    """For a worker process, at its start: move every object it has now (its imports, or what
    a fork inherited) to the permanent generation, which no collection walks, and turn
    automatic collection off for good; :func:`after_task` then collects between tasks."""
    global _holding
    gc.freeze()
    gc.disable()
    _holding = True


def after_task() -> None:
    """After a task that drew figures. In a worker (:func:`hold_in_worker`): collect
    everything made since the previous call (the task's cycles, and a compilation's before it),
    then freeze what survives (live caches), so that the next call walks only the next task's
    objects; nothing can be left in an older generation that no collection walks. Elsewhere,
    while automatic collection is off (:func:`paused`): collect the youngest generation (the
    task's figures), the older ones waiting for automatic collection to resume; with it on,
    nothing."""
    if _holding:
        gc.collect()
        gc.freeze()
    elif not gc.isenabled():
        gc.collect(0)
