"""The loop's separately compiled parts (``slidingarm._engine.LOOP_PARTS``): compiled into
numba's cache by one process, they are what another process's compilation of the loop asks
for, so it loads them instead of compiling them (``slidingarm reproduce`` compiles them in its
figure workers while it starts up). Each process here has its own empty numba cache."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

_COMPILE_PARTS = """
from slidingarm import _engine as E
assert not E.loop_cached()
for i in range(len(E.LOOP_PARTS)):
    E.compile_part(i)
"""

_RUN_LOOP = """
import json
from slidingarm import _engine as E, PAPER_Q0, FTSMC, PaperReference, PlanarArm, simulate
before = E.loop_cached()
arm = PlanarArm.paper()
law = FTSMC(arm, alpha=5.0, beta=5.0, p=5, q=3, k=20.0, switching="tanh", width=0.05)
simulate(arm, law, PaperReference(), q0=PAPER_Q0, t_final=0.01, dt=1e-3)
stats = {d.py_func.__name__: [sum(d.stats.cache_hits.values()), sum(d.stats.cache_misses.values())]
         for d, _ in E.LOOP_PARTS}
stats["run_one"] = [sum(E.run_one.stats.cache_hits.values()),
                    sum(E.run_one.stats.cache_misses.values())]
print(json.dumps({"before": before, "after": E.loop_cached(), "stats": stats}))
"""


def _python(code: str, cache: Path) -> str:
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache))
    proc = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=600
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    return proc.stdout


@pytest.mark.slow  # two fresh processes compile the loop's parts, then the loop (about 10 s)
def test_the_loop_loads_the_parts_another_process_compiled(tmp_path: Path) -> None:
    _python(_COMPILE_PARTS, tmp_path)
    out = json.loads(_python(_RUN_LOOP, tmp_path).strip().splitlines()[-1])
    assert out["before"] is False  # the parts alone are not the loop
    assert out["after"] is True
    # the loop was compiled here, and each part it called was loaded, none compiled again
    assert out["stats"].pop("run_one") == [0, 1]
    # the law's callees came with the law: neither asked for by the loop's compilation
    assert out["stats"] == {
        "sincos": [0, 0], "pow_abs": [0, 0], "tanh": [0, 0], "sliding_mode_into": [1, 0],
        "rk4_step": [1, 0],
    }


_COMPILE_CALLEES = """
from slidingarm import _engine as E
from slidingarm.control import _kernels as CK
from slidingarm.models import _kernels as PK
for i in (0, 1, 2):
    E.compile_part(i)
assert [d for d, _ in E.LOOP_PARTS[:3]] == [PK.sincos, CK.pow_abs, CK.tanh]
"""

_COMPILE_LAW = """
import json
from slidingarm import _engine as E
from slidingarm.control import _kernels as CK
from slidingarm.models import _kernels as PK
assert E.LOOP_PARTS[4][0] is CK.sliding_mode_into
E.compile_part(4)
print(json.dumps({d.py_func.__name__: [sum(d.stats.cache_hits.values()),
                                       sum(d.stats.cache_misses.values())]
                  for d in (PK.sincos, CK.pow_abs, CK.tanh, CK.sliding_mode_into)}))
"""


@pytest.mark.slow  # two fresh processes compile the law's callees, then the law (about 4 s)
def test_the_law_loads_the_callees_another_process_compiled(tmp_path: Path) -> None:
    # what lets reproduce's two figure workers compile the law's pieces side by side
    _python(_COMPILE_CALLEES, tmp_path)
    stats = json.loads(_python(_COMPILE_LAW, tmp_path).strip().splitlines()[-1])
    assert stats == {
        "sincos": [1, 0], "pow_abs": [1, 0], "tanh": [1, 0], "sliding_mode_into": [0, 1]
    }


_LINKED = """
import json
from numba.core import event
import numpy as np
from slidingarm import _engine as E, PAPER_Q0, FTSMC, PaperReference, PlanarArm, simulate
compiled = []
class Listener(event.Listener):
    def on_start(self, ev):
        if ev.kind == "numba:compile":
            compiled.append(ev.data["dispatcher"].py_func.__name__)
    def on_end(self, ev):
        pass
from slidingarm._pointers import INLINED, LINKED
before = [E.loop_cached(), E.loop_cached(LINKED)]
with event.install_listener("numba:compile", Listener()):
    E.compile_loop()
loop_alone = sorted(set(compiled))
cached = [E.loop_cached(LINKED), E.loop_cached(INLINED), E.loop_cached()]
arm = PlanarArm.paper()
law = FTSMC(arm, alpha=5.0, beta=5.0, p=5, q=3, k=20.0, switching="tanh", width=0.05)
with E.linked_loop():
    r = simulate(arm, law, PaperReference(), q0=PAPER_Q0, t_final=0.01, dt=1e-3)
print(json.dumps({"loop_alone": loop_alone, "signatures": len(E.run_one.signatures),
                  "before": before, "cached": cached,
                  "finite": bool(np.isfinite(r.q).all())}))
"""


@pytest.mark.slow  # a fresh process compiles the linked loop, then runs it (about 6 s)
def test_the_linked_loop_compiles_without_the_parts(tmp_path: Path) -> None:
    # what lets reproduce compile its loop while its figure workers compile the parts
    out = json.loads(_python(_LINKED, tmp_path).strip().splitlines()[-1])
    parts = {"sincos", "pow_abs", "tanh", "sliding_mode_into", "rk4_step"}
    assert "run_one" in out["loop_alone"]
    assert not parts & set(out["loop_alone"]), out["loop_alone"]
    # compile_loop compiled what the first linked run takes: no second signature
    assert out["signatures"] == 1
    assert out["finite"]
    # the cache tells the two specialisations apart (reproduce takes the inlined loop if cached)
    assert out["before"] == [False, False]
    assert out["cached"] == [True, False, True]
