"""Python's cyclic garbage collector held back during work that allocates objects in bursts.

Numba's compilation and matplotlib's drawing each create hundreds of thousands of small
container objects. Every 700 of them CPython collects its young generation, every tenth time
the middle one too, each collection walking everything those generations hold. Measured
cold, in one process: collections were 1.0 CPU-s of the 5.9-6.3 that compiling the loop's
parts and the loop and running one scenario took (5.2-5.4 without them); and 0.2-0.5 CPU-s of
the 1.35-2.1 that drawing one scenario's seven figures took. Almost all of those objects are
freed by reference counting as soon as they are dropped; the few cycles (a figure and its
artists, numba's IR) wait for a collection asked for when the work is done.
"""

from __future__ import annotations

import gc
from collections.abc import Iterator
from contextlib import contextmanager

__all__ = ["collect_young", "freeze_and_hold", "paused"]


@contextmanager
def paused() -> Iterator[None]:
    """No automatic collection while the block runs; the collector's state restored after
    (a collection is not forced: the next automatic one frees what cycles the block left)."""
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if enabled:
            gc.enable()


def freeze_and_hold() -> None:
    """For a worker process: move every object it has now (its imports, or what a fork
    inherited) to the permanent generation, which no collection walks again, and turn
    automatic collection off; the worker then calls :func:`collect_young` between tasks."""
    gc.freeze()
    gc.disable()


def collect_young() -> None:
    """Collect the youngest generation (what was made since the last call, with automatic
    collection off): the cycles a finished task left, such as its dropped figures. What is
    still alive moves on to an older generation and is not walked again by the next call."""
    gc.collect(0)
