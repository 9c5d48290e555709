"""Time of ``slidingarm reproduce`` from a cold and a warm numba cache, and where it goes
(issue 12, point 4: under 10 s from a cold cache).

Run as ``python benchmarks/bench_reproduce.py [--runs 3] [--warm-only | --cold-only]
[--checkout]``. It first installs the checkout as the README's main command does (``pip
install .``, into a temporary folder, without its dependencies, which are those installed:
:func:`install`), so that it times what a user's ``slidingarm reproduce`` runs; with
``--checkout``, the package this Python imports (an editable install runs the checkout's
sources). Each run is a fresh process, ``python -m slidingarm reproduce --out <tmp>``, with its own
``NUMBA_CACHE_DIR``: empty for a cold run, filled by the previous cold run for a warm one (so
the package's own cache folders are neither used nor touched). For each run it prints the
wall time, the CPU time of the main process and of its children (the figure workers), the
machine's load average and the time of a fixed CPU probe just before it (:func:`host_speed`:
the machine's speed at that moment); then the median of the wall times of each kind.

With ``--phases`` two more runs (cold, then warm from the cache the cold one filled) go
through :func:`slidingarm.study.reproduce` in this benchmark's own child process and print the wall and CPU time of each step (the progress
callback's) and the compile time of each numba dispatcher of the main process (numba's
``numba:compile`` events, CPU seconds): its total, which includes the callees compiled
during its compilation, and its own share.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import _host

_PHASES = r"""
import collections, json, os, sys, time
from numba.core import event

compile_cpu = collections.defaultdict(float)
compile_self = collections.defaultdict(float)
stack = []


def _name(d):
    return d.py_func.__module__.rsplit(".", 1)[-1] + "." + d.py_func.__qualname__


class Listener(event.Listener):
    # a dispatcher's compilation includes those of the functions it calls that were not
    # compiled yet: its total (inclusive) and its own share (exclusive) are both kept
    def on_start(self, e):
        now = time.process_time()
        if stack:
            compile_self[stack[-1][0]] += now - stack[-1][2]
        stack.append([_name(e.data["dispatcher"]), now, now])

    def on_end(self, e):
        now = time.process_time()
        name, start, mark = stack.pop()
        compile_self[name] += now - mark
        compile_cpu[name] += now - start
        if stack:
            stack[-1][2] = now


def main():
    event.register("numba:compile", Listener())
    t0, c0 = time.perf_counter(), time.process_time()
    from slidingarm.study import reproduce

    marks = [("import slidingarm.study", time.perf_counter() - t0, time.process_time() - c0)]

    def progress(what, done, total):
        marks.append((what, time.perf_counter() - t0, time.process_time() - c0))

    reproduce(sys.argv[1], progress=progress)
    times = os.times()
    print(json.dumps({"marks": marks, "compile": compile_cpu, "self": compile_self,
                      "children": times.children_user + times.children_system}))


if __name__ == "__main__":
    main()
"""


#: Extra environment of every run: ``PYTHONPATH`` of the installed copy (:func:`install`).
_ENV: dict[str, str] = {}


def install(root: Path) -> None:
    """Install this checkout as the README's main command does (``pip install .``: a regular
    install, its modules byte-compiled by pip) into ``root/site``, the dependencies being
    those already installed, and run every study from there (``PYTHONPATH``). An editable
    install (the README's test command) has no bytecode of its own modules when
    ``PYTHONDONTWRITEBYTECODE`` is set, as on this machine: each process then compiles them
    from source, about 0.3 s more at start-up (``--checkout`` measures that)."""
    site = root / "site"
    repo = Path(__file__).resolve().parent.parent
    subprocess.run(
        [sys.executable, "-m", "pip", "install", "--quiet", "--no-deps", "--target", str(site),
         str(repo)],
        check=True, capture_output=True,
    )  # fmt: skip
    _ENV["PYTHONPATH"] = str(site)
    where = subprocess.run(
        [sys.executable, "-c", "import slidingarm; print(slidingarm.__file__)"],
        env=dict(os.environ, **_ENV), capture_output=True, text=True, check=True,
    ).stdout.strip()  # fmt: skip
    if not where.startswith(str(site)):
        raise SystemExit(f"the installed copy is not the one imported: {where}")


def host_speed() -> float:
    """CPU seconds of a fixed pure-Python loop (3e6 multiply-adds), timed just before a run:
    this machine's speed drifts by up to 40 % within minutes (its neighbours), and a run's
    time follows it; comparing two runs means comparing them at the same speed."""
    start = time.process_time()
    total = 0
    for i in range(3_000_000):
        total += i * i
    return time.process_time() - start


def one_run(cache: str, out: Path) -> dict[str, float]:
    """``python -m slidingarm reproduce`` in a fresh process; wall, CPU (self, children)."""
    env = dict(os.environ, NUMBA_CACHE_DIR=cache, MPLBACKEND="Agg", **_ENV)
    shutil.rmtree(out, ignore_errors=True)
    speed = host_speed()
    load = os.getloadavg()[0]
    before = os.times()
    t0 = time.perf_counter()
    proc = subprocess.run(
        [sys.executable, "-m", "slidingarm", "reproduce", "--out", str(out)],
        env=env,
        capture_output=True,
        text=True,
    )
    wall = time.perf_counter() - t0
    after = os.times()
    if proc.returncode != 0:
        raise SystemExit(f"reproduce failed ({proc.returncode}):\n{proc.stderr[-3000:]}")
    cpu = (after.children_user - before.children_user) + (
        after.children_system - before.children_system
    )
    return {"wall": wall, "cpu": cpu, "load": load, "speed": speed}


def phases(cache: str, out: Path, kind: str = "cold") -> None:
    env = dict(os.environ, NUMBA_CACHE_DIR=cache, MPLBACKEND="Agg", **_ENV)
    shutil.rmtree(out, ignore_errors=True)
    with tempfile.NamedTemporaryFile("w", suffix=".py", delete=False) as fh:
        fh.write(_PHASES)
        script = fh.name
    try:
        proc = subprocess.run(
            [sys.executable, script, str(out)], env=env, capture_output=True, text=True
        )
    finally:
        os.unlink(script)
    if proc.returncode != 0:
        raise SystemExit(f"the phase run failed:\n{proc.stderr[-3000:]}")
    body = json.loads(proc.stdout.strip().splitlines()[-1])
    print(f"\nphases of a {kind} run (wall s since start, CPU s of the main process in the step;")
    print(f"load {os.getloadavg()[0]:.2f} after it):")
    prev_wall, prev_cpu = 0.0, 0.0
    for what, wall, cpu in body["marks"]:
        if wall - prev_wall >= 0.05 or cpu - prev_cpu >= 0.05:
            print(f"  {wall:7.2f}  +{wall - prev_wall:5.2f} wall  +{cpu - prev_cpu:5.2f} cpu  {what}")
        prev_wall, prev_cpu = wall, cpu
    print(f"  main process CPU {prev_cpu:.2f} s; figure workers (children) {body['children']:.2f} s")
    print("numba compile CPU of the main process by dispatcher (s; total includes the")
    print("callees it compiled, self does not; the self column adds up to all compilation):")
    print(f"  {'total':>6s} {'self':>6s}")
    for name, sec in sorted(body["compile"].items(), key=lambda kv: -kv[1]):
        print(f"  {sec:6.2f} {body['self'][name]:6.2f}  {name}")
    print(f"  {'':6s} {sum(body['self'].values()):6.2f}  all")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=3, help="runs of each kind (default 3)")
    kind = parser.add_mutually_exclusive_group()
    kind.add_argument("--cold-only", action="store_true")
    kind.add_argument("--warm-only", action="store_true")
    parser.add_argument("--phases", action="store_true", help="also the per-step timing")
    parser.add_argument(
        "--checkout",
        action="store_true",
        help="run the package this Python imports (an editable install: the checkout's "
        "sources) instead of installing the checkout as the README does",
    )
    args = parser.parse_args()
    root = Path(tempfile.mkdtemp(prefix="bench-reproduce-"))
    rows: dict[str, list[dict[str, float]]] = {"cold": [], "warm": []}
    try:
        if not args.checkout:
            install(root)
        print(_host.describe())
        print(
            "package: "
            + ("as this Python imports it" if args.checkout else "installed as the README does")
        )
        for i in range(args.runs):
            cache = str(root / f"cache{i}")
            cold = one_run(cache, root / "out")  # fills the cache (also for --warm-only)
            if not args.warm_only:
                rows["cold"].append(cold)
            if not args.cold_only:
                rows["warm"].append(one_run(cache, root / "out"))
        print(f"{'run':6s} {'wall s':>8s} {'cpu s':>8s} {'load':>6s} {'probe s':>8s}")
        for name, runs in rows.items():
            for r in runs:
                print(
                    f"{name:6s} {r['wall']:8.2f} {r['cpu']:8.2f} {r['load']:6.2f}"
                    f" {r['speed']:8.3f}"
                )
        for name, runs in rows.items():
            if runs:
                wall = statistics.median(r["wall"] for r in runs)
                cpu = statistics.median(r["cpu"] for r in runs)
                print(f"median {name}: {wall:.2f} s wall, {cpu:.2f} s CPU over {len(runs)} runs")
        if args.phases:
            phases(str(root / "phase-cache"), root / "phase-out")
            phases(str(root / "phase-cache"), root / "phase-out", "warm")
    finally:
        shutil.rmtree(root, ignore_errors=True)


if __name__ == "__main__":
    main()
