"""``slidingarm._gc.paused``: no automatic collection inside, the collector's state after."""

from __future__ import annotations

import gc
import subprocess
import sys

import pytest

from slidingarm._gc import paused


def test_paused_turns_collection_off_and_back_on() -> None:
    assert gc.isenabled()
    with paused():
        assert not gc.isenabled()
        with paused():  # nested: still off, and the outer block's state is kept
            assert not gc.isenabled()
        assert not gc.isenabled()
    assert gc.isenabled()


def test_paused_keeps_collection_off_when_it_was_off() -> None:
    gc.disable()
    try:
        with paused():
            assert not gc.isenabled()
        assert not gc.isenabled()
    finally:
        gc.enable()


def test_paused_restores_collection_when_the_block_raises() -> None:
    with pytest.raises(ValueError, match="boom"), paused():
        raise ValueError("boom")
    assert gc.isenabled()


_FIRST_SIMULATE = """
import gc
import slidingarm as sa
collections = []
gc.callbacks.append(lambda phase, info: collections.append(info) if phase == "stop" else None)
arm = sa.PlanarArm.paper()
law = sa.FTSMC(arm, alpha=5.0, beta=5.0, p=5, q=3, k=20.0, switching="tanh", width=0.05)
sa.simulate(arm, law, sa.PaperReference(), q0=sa.PAPER_Q0, t_final=0.05, dt=1e-3)
assert gc.isenabled()
print(len(collections))
"""


def test_the_first_simulation_compiles_the_loop_without_collections() -> None:
    # a fresh process: its first run compiles the loop or loads it from numba's cache, both
    # of which allocate enough for about a hundred (loaded) to a thousand (compiled) young
    # collections with collection on; paused, the one left is the first after it
    proc = subprocess.run(
        [sys.executable, "-c", _FIRST_SIMULATE], capture_output=True, text=True, timeout=600
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert int(proc.stdout.strip().splitlines()[-1]) <= 2
