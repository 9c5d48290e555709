"""Issue 11, points 6-8: sizes checked before allocating, numbers bounded where no value can be
meant, and only regular files of a sane size read (scenario files and reference tables)."""

from __future__ import annotations

import importlib
import math
import os
import textwrap
import threading
import tracemalloc
from collections.abc import Iterator
from pathlib import Path

import numba
import numpy as np
import pytest

import slidingarm as sa
import slidingarm.config.scenario as scenario_module
from slidingarm._io import MAX_SCENARIO_BYTES
from slidingarm._validate import MAX_POSITION, MIN_EPS_E
from slidingarm.config import ConfigError, load_scenario
from slidingarm.references import QuinticReference, SineReference, TableReference
from slidingarm.simulate import (
    MIN_DT,
    RunTooLargeError,
    available_memory,
    byte_size,
    memory_estimate,
    time_grid,
)

# the module, not the function slidingarm.simulate that shadows it as an attribute
simulate_module = importlib.import_module("slidingarm.simulate")

GiB = 2**30

BASE = """
switching = "tanh"

[plant]
preset = "paper"

[reference]
kind = "paper"

[simulation]
t_final = 0.01
dt = 5e-4
q0 = [0.7, 1.5, 0.5]

[gains]
alpha = 2.0
beta = 2.0
p = 5
q = 3
k = 20.0
width = 0.05

[[controllers]]
name = "pdsmc"

[[controllers]]
name = "tsmc"

[[controllers]]
name = "ftsmc"
"""


def scenario(tmp_path: Path, old: str = "", new: str = "", name: str = "s.toml") -> Path:
    text = textwrap.dedent(BASE)
    if old:
        assert old in text, old
        text = text.replace(old, new, 1)
    p = tmp_path / name
    p.write_text(text, encoding="utf-8")
    return p


def error_of(path: Path) -> ConfigError:
    with pytest.raises(ConfigError) as info:
        load_scenario(path)
    assert "\n" not in str(info.value), "a config error is one line"
    return info.value


@pytest.fixture
def memory(monkeypatch: pytest.MonkeyPatch) -> Iterator[None]:
    """This machine has 16 GiB available, whatever it really has."""
    monkeypatch.setattr(simulate_module, "available_memory", lambda: 16 * GiB, raising=False)
    monkeypatch.setattr(scenario_module, "available_memory", lambda: 16 * GiB, raising=False)
    yield


# ------------------------------------------------------------------------- 6. sizes


def test_validate_refuses_a_run_larger_than_memory_naming_keys_and_estimate(
    tmp_path: Path, memory: None
) -> None:
    # 1e15 samples: the grid alone would be 8 PB
    err = error_of(scenario(tmp_path, "t_final = 0.01", "t_final = 5e11"))
    assert err.path == "simulation.t_final"
    assert "simulation.t_final / simulation.dt = 1e+15 steps x 3 joints x 3 runs" in err.reason
    assert "more than 80% of the 16 GiB of memory available" in err.reason
    assert 'record = "metrics"' in err.reason


def test_the_memory_check_uses_what_is_available(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """2e6 samples of 3 controllers need about 1 GiB: fine with 16 GiB, refused with 1 GiB."""
    path = scenario(tmp_path, "t_final = 0.01", "t_final = 1000.0")
    monkeypatch.setattr(scenario_module, "available_memory", lambda: 16 * GiB, raising=False)
    assert load_scenario(path).build().t_final == 1000.0
    monkeypatch.setattr(scenario_module, "available_memory", lambda: 1 * GiB, raising=False)
    err = error_of(path)
    need = memory_estimate(2_000_001, 3, 3)
    assert 0.8 * GiB < need < 16 * 0.8 * GiB
    assert f"would need {byte_size(need)} of traces" in err.reason
    assert "more than 80% of the 1 GiB of memory available" in err.reason


def test_validate_never_allocates_the_traces(tmp_path: Path, memory: None) -> None:
    """5e6 samples: the time grid alone would be 40 MB, the traces 2 GB; validation checks the
    reference a chunk at a time, so it allocates what it allocates for 21 samples, give or take
    a few MB."""

    def peak(t_final: str) -> int:
        path = scenario(tmp_path, "t_final = 0.01", f"t_final = {t_final}")
        tracemalloc.start()
        try:
            load_scenario(path)
            return tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()

    peak("0.01")  # the first load's one-off caches
    short, long = peak("0.01"), peak("2500.0")
    assert long - short < 8e6, f"5e6 samples took {(long - short) / 1e6:.1f} MB more than 21"


def test_a_batch_too_large_is_a_memory_error_and_a_value_error_naming_its_size(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setattr(simulate_module, "available_memory", lambda: 1 * GiB, raising=False)
    arm = sa.PlanarArm.paper()
    ctrl = sa.FTSMC(arm, alpha=2.0, beta=2.0, gamma=0.6, k=20.0)
    with pytest.raises(ValueError) as info:
        sa.simulate_batch(arm, ctrl, sa.PaperReference(), q0=np.zeros((2000, 3)), t_final=4.5,
                          dt=5e-4)  # fmt: skip
    err = info.value
    assert isinstance(err, MemoryError) and isinstance(err, RunTooLargeError)
    msg = str(err)
    assert "t_final/dt = 9000 steps x 3 joints x 2000 runs (every sample)" in msg
    assert err.estimate == memory_estimate(9001, 3, 2000, threads=_threads(2000))
    assert f"would need {byte_size(err.estimate)} of traces" in msg and "of the 1 GiB" in msg
    assert "use record='metrics'" in msg
    # the same batch keeping only metrics needs a bounded working set: accepted by the check
    need = memory_estimate(9001, 3, 2000, record="metrics", threads=_threads(2000))
    assert need < 0.8 * GiB


def _threads(nb: int) -> int:
    return simulate_module._threads(nb, False)


@pytest.mark.parametrize("threads", [1, 2])
@pytest.mark.parametrize(
    ("runs", "record"), [(1, "full"), (8, "full"), (40, "full"), (40, "metrics"), (40, "every")]
)
def test_the_memory_estimate_bounds_what_a_batch_allocates(
    runs: int, record: str, threads: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The estimate is an upper bound of the traced peak, and, on one thread, not a loose one
    (on two, the peak depends on whether the threads' working sets happen to overlap)."""
    monkeypatch.setattr(numba.config, "NUMBA_NUM_THREADS", threads)
    arm = sa.PlanarArm.paper()
    ctrl = sa.FTSMC(arm, alpha=2.0, beta=2.0, gamma=0.6, k=20.0)
    rec: simulate_module.Record = sa.Every(10) if record == "every" else record  # type: ignore[assignment]
    opts = dict(dt=5e-4, record=rec, sensor=sa.Sensor(noise=sa.GaussianNoise(1e-4)))
    batch = dict(q0=np.tile(sa.PAPER_Q0, (runs, 1)), seeds=list(range(runs)))
    # a short batch of the same size first: it takes the same path, whose kernels compile
    # outside the traced call
    sa.simulate_batch(arm, ctrl, sa.PaperReference(), t_final=0.01, **batch, **opts)  # type: ignore[arg-type]
    tracemalloc.start()
    try:
        sa.simulate_batch(arm, ctrl, sa.PaperReference(), t_final=1.0, **batch, **opts)  # type: ignore[arg-type]
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    estimate = memory_estimate(2001, 3, runs, record=rec, threads=_threads(runs))
    assert peak <= estimate
    if threads == 1:
        assert estimate <= 1.5 * peak + 2**20


def test_available_memory_is_at_most_the_physical_memory() -> None:
    avail = available_memory()
    total = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    assert avail is not None and 0 < avail <= total


# ------------------------------------------------------------------------- 7. numbers

BIG = "1" + "0" * 400


@pytest.mark.parametrize(
    ("old", "new", "path", "reason"),
    [
        # beyond the float range
        ("k = 20.0", f"k = {BIG}", "gains.k", "must be finite"),
        ('preset = "paper"', f"masses = [{BIG}, 1, 1]\nlengths = [0.5, 1, 1]", "plant.masses",
         "must be a list of finite numbers > 0"),
        ("[reference]", f"[mismatch]\nmass_error = {BIG}\n[reference]", "mismatch.mass_error",
         "must be finite"),
        ("dt = 5e-4", "dt = 5e-324", "simulation.dt", "must be a number >= 1e-09 (s)"),
        ("t_final = 0.01", "t_final = 1.7e308", "simulation.t_final",
         "t_final / dt = 1.7e+308 s / 0.0005 s is beyond the float range"),
        ("q0 = [", f"substeps = {BIG}\nq0 = [", "simulation.substeps",
         "must be an integer from 1 to 1000000"),
        ("q0 = [", "substeps = 1000000000000\nq0 = [", "simulation.substeps",
         "must be an integer from 1 to 1000000, got 1000000000000"),
        # finite, but no value can be meant
        ('kind = "paper"',
         'kind = "sine"\noffset = [0.7, 1.5, 0.5]\namplitude = 0.1\nfrequency = 1e200',
         "reference.frequency",
         "must be below the Nyquist rate 1/(2 dt) = 1000 Hz of the grid (simulation.dt = "
         "0.0005 s), got 1e+200 Hz"),
        ('kind = "paper"',
         'kind = "quintic"\nq_start = [0.7, 1.5, 0.5]\nq_end = [0.8, 1.4, 0.6]\n'
         "duration = 1e-200",
         "reference.duration", "must be at least one sample, simulation.dt = 0.0005 s"),
        ("q0 = [0.7, 1.5, 0.5]", "q0 = [1e300, 1.5, 0.5]", "simulation.q0",
         "must be a list of finite numbers within ±1000, got [1e+300, 1.5, 0.5]"),
        ("[gains]", "[sensor]\nnoise = { sigma = 1e300 }\n[gains]", "sensor.noise.sigma",
         "must be >= 0 and <= 1000"),
        ("p = 5\nq = 3\n", "gamma = 0.01\neps_e = 1e-320\n", "gains.eps_e",
         "must be a number >= 1e-300 (rad), got 1e-320"),
        ("[gains]", '[[sensor.faults]]\nkind = "bias"\njoint = 1\nvalue = 1e300\n[gains]',
         "sensor.faults[0].value", "must be a number within ±1000, got 1e+300"),
        ("[[controllers]]", '[[disturbances]]\nkind = "sinusoidal"\namplitude = 1.0\n'
         "frequency = 1000.0\n\n[[controllers]]", "disturbances[0].frequency",
         "must be below the Nyquist rate"),
        ('kind = "paper"',
         'kind = "sine"\noffset = [0.7, 1.5, 0.5]\namplitude = 1e308\nfrequency = 1.0',
         "reference.amplitude", "SineReference: qd is not finite at t = 0.0"),
        ('kind = "paper"',
         'kind = "sine"\noffset = [0.7, 1.5, 0.5]\namplitude = 2e5\nfrequency = 1.0',
         "reference.amplitude", "joint 1 reaches 1257.33 at t = 0.001 s, beyond ±1000"),
        # an arm no value of which can be meant (it overflowed the control effort to inf)
        ('preset = "paper"', "masses = [1e300, 1, 1]\nlengths = [0.5, 1, 1]", "plant",
         "masses must be > 0 and <= 1e+06 kg"),
        ('preset = "paper"', "masses = [1, 1, 1]\nlengths = [1e300, 1, 1]", "plant",
         "lengths must be > 0 and <= 1000 m"),
        ("[reference]", "[mismatch]\nlength_error = 1e300\n[reference]", "mismatch",
         "scale factors must be > 0 and <= 1000"),
        ("[reference]", "[mismatch]\nmass_error = 1e300\n[reference]", "mismatch",
         "scale factors must be > 0 and <= 1000"),
        ("[reference]", "[mismatch]\npayload = 1e300\n[reference]", "mismatch",
         "payload mass must be >= 0 and <= 1e+06 kg"),
    ],
)  # fmt: skip
def test_overflowing_and_absurd_numbers_are_refused_at_validate_time(
    tmp_path: Path, old: str, new: str, path: str, reason: str
) -> None:
    err = error_of(scenario(tmp_path, old, new))
    assert err.path == path
    assert reason in err.reason


def test_the_bounds_themselves_are_accepted(tmp_path: Path) -> None:
    """At the bounds the scenario builds: the bounds refuse only what cannot be meant."""
    for old, new in [
        ("q0 = [0.7, 1.5, 0.5]", f"q0 = [{MAX_POSITION}, 1.5, 0.5]"),
        ("[gains]", f"[sensor]\nnoise = {{ sigma = {MAX_POSITION} }}\n[gains]"),
        ("t_final = 0.01\ndt = 5e-4", f"t_final = {1000 * MIN_DT}\ndt = {MIN_DT}"),
        ("p = 5\nq = 3\n", f"gamma = 0.01\neps_e = {MIN_EPS_E}\n"),
        ("q0 = [", "substeps = 1000000\nq0 = ["),
        ('kind = "paper"',
         'kind = "sine"\noffset = [0.7, 1.5, 0.5]\namplitude = 0.1\nfrequency = 999.9'),
        ('kind = "paper"', 'kind = "quintic"\nq_start = [0.7, 1.5, 0.5]\n'
         "q_end = [0.8, 1.4, 0.6]\nduration = 5e-4"),
    ]:  # fmt: skip
        load_scenario(scenario(tmp_path, old, new)).build()


def test_python_refuses_the_same_numbers_with_value_errors() -> None:
    arm = sa.PlanarArm.paper()
    ctrl = sa.PDSMC(arm, lam=2.0, k=20.0)
    ref = sa.PaperReference()
    opts = dict(q0=sa.PAPER_Q0, t_final=0.01, dt=5e-4)
    with pytest.raises(ValueError, match=r"dt must be at least 1e-09 s"):
        time_grid(1.0, 5e-324)
    with pytest.raises(ValueError, match=r"t_final / dt = 1\.7e\+308 s / 0\.0005 s is beyond"):
        time_grid(1.7e308, 5e-4)
    with pytest.raises(ValueError, match=r"more than a time grid can hold"):
        time_grid(1e16, 1.0)
    with pytest.raises(ValueError, match=r"q0 must lie within ±1000 .*got 1e\+300"):
        sa.simulate(arm, ctrl, ref, **{**opts, "q0": [1e300, 1.5, 0.5]})
    with pytest.raises(ValueError, match=r"noise sigma must be at most 1000"):
        sa.GaussianNoise(1e300)
    with pytest.raises(ValueError, match=r"eps_e must be >= 1e-300"):
        sa.TSMC(arm, beta=2.0, gamma=0.01, eps_e=1e-320, k=20.0)
    with pytest.raises(ValueError, match=r"makes the guarded gain .* overflow"):
        sa.FTSMC(arm, alpha=2.0, beta=2.0, gamma=200.0, eps_e=1e3, k=20.0,
                 allow_nonterminal=True)  # fmt: skip
    for substeps in (10**12, 10**400):
        with pytest.raises(ValueError, match=r"substeps must be at most 1,000,000"):
            sa.simulate(arm, ctrl, ref, substeps=substeps, **opts)
    # the guard at its bound keeps the largest gain finite
    tsmc = sa.TSMC(arm, beta=2.0, gamma=0.01, eps_e=MIN_EPS_E, k=20.0)
    nu = tsmc.surface.nu(np.zeros(3), np.ones(3))
    assert np.all(np.isfinite(nu)) and math.isclose(nu[0], 2.0 * 0.01 * MIN_EPS_E**-0.99)


@pytest.mark.filterwarnings("ignore:overflow:RuntimeWarning", "ignore:invalid:RuntimeWarning")
def test_arms_refuse_parameters_no_arm_can_have() -> None:
    """Physical bounds of both arm kinds (slidingarm.models.base.MAX_*), and the bounds
    themselves accepted."""
    from slidingarm.models.base import MAX_GRAVITY, MAX_MASS, MAX_SCALE

    planar = sa.PlanarArm.paper()
    ur5 = sa.robots.load("ur5")
    with pytest.raises(ValueError, match=r"masses must be > 0 and <= 1e\+06 kg"):
        sa.PlanarArm([1e300, 1.0, 1.0], [0.5, 1.0, 1.0])
    with pytest.raises(ValueError, match=r"inertia must be >= 0 and <= 1e\+09"):
        sa.PlanarArm([1.0, 1.0, 1.0], [0.5, 1.0, 1.0], inertia=[1e300, 0.0, 0.0])
    with pytest.raises(ValueError, match=r"gravity must be >= 0 and <= 1000"):
        sa.PlanarArm([1.0, 1.0, 1.0], [0.5, 1.0, 1.0], gravity=1e300)
    with pytest.raises(ValueError, match=r"gravity must be a number in \[0, 1000\]"):
        ur5.replace(gravity=1e300)
    for arm in (planar, ur5):
        with pytest.raises(ValueError, match=r"payload mass must be >= 0 and <= 1e\+06 kg"):
            arm.with_payload(1e300)
        for kw in ({"mass": 1e300}, {"length": 1e300}):
            with pytest.raises(ValueError, match=r"factors must be > 0 and <= 1000"):
                arm.scaled(**kw)
        arm.scaled(mass=MAX_SCALE)
        arm.with_payload(MAX_MASS - 10.0)  # the link keeps its own few kg
    ur5.replace(gravity=MAX_GRAVITY)


def test_references_too_fast_for_the_grid_fail_in_python_as_value_errors() -> None:
    arm = sa.PlanarArm.paper()
    ctrl = sa.PDSMC(arm, lam=2.0, k=20.0)
    opts = dict(q0=sa.PAPER_Q0, t_final=0.01, dt=5e-4)
    for ref in (
        SineReference(sa.PAPER_Q0, 0.1, 1e200),
        QuinticReference(sa.PAPER_Q0, (0.8, 1.4, 0.6), duration=1e-200),
    ):
        with pytest.raises(ValueError, match=r"not finite"):
            sa.simulate(arm, ctrl, ref, **opts)


# ------------------------------------------------------------------------- 8. files


def test_a_deeply_nested_array_is_one_line(tmp_path: Path) -> None:
    deep = "[" * 3000 + "1" + "]" * 3000
    err = error_of(scenario(tmp_path, "k = 20.0", f"k = {deep}"))
    assert "nested too deep" in err.reason
    err = error_of(scenario(tmp_path, "k = 20.0", "k = " + "[" * 40 + "1" + "]" * 40))
    assert err.path == "gains.k" and "nested more than 32 deep" in err.reason


def test_a_device_is_refused_without_reading(tmp_path: Path) -> None:
    # /dev/zero would be read until memory runs out; /dev/null takes the same path
    for dev in ("/dev/null", "/dev/zero"):
        err = error_of(Path(dev))
        assert err.file == dev and "is not a regular file" in err.reason


@pytest.fixture
def fifo(tmp_path: Path) -> Iterator[Path]:
    """A FIFO; a writer opens and closes it if a reader ever opens it (so that a reader that
    blocks is released, with an empty file, instead of hanging the tests)."""
    path = tmp_path / "fifo.toml"
    os.mkfifo(path)
    stop = threading.Event()

    def release() -> None:
        while not stop.wait(0.05):
            try:
                os.close(os.open(path, os.O_WRONLY | os.O_NONBLOCK))
            except OSError:  # no reader yet
                continue

    thread = threading.Thread(target=release, daemon=True)
    thread.start()
    yield path
    stop.set()
    thread.join()


def test_a_fifo_is_refused_without_opening(fifo: Path) -> None:
    err = error_of(fifo)
    assert "is not a regular file" in err.reason


def test_an_oversized_scenario_file_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "big.toml"
    with path.open("wb") as fh:  # sparse: no disk used
        fh.truncate(MAX_SCENARIO_BYTES + 1)
    err = error_of(path)
    assert f"is {MAX_SCENARIO_BYTES + 1:,} bytes, more than the" in err.reason


def test_a_base_file_that_is_a_fifo_is_refused(tmp_path: Path, fifo: Path) -> None:
    path = tmp_path / "child.toml"
    path.write_text(f'extends = "{fifo.name}"\n', encoding="utf-8")
    err = error_of(path)
    assert err.file == str(fifo) and "is not a regular file" in err.reason


def test_a_reference_table_that_is_not_a_regular_file_is_refused(
    tmp_path: Path, fifo: Path
) -> None:
    text = 'kind = "table"\npath = "fifo.toml"'
    err = error_of(scenario(tmp_path, 'kind = "paper"', text))
    assert err.path == "reference.path" and "is not a regular file" in err.reason
    with pytest.raises(ValueError, match=r"/dev/null: is not a regular file"):
        TableReference.from_csv("/dev/null")


def test_scenario_files_still_read_with_any_line_ends(tmp_path: Path) -> None:
    text = textwrap.dedent(BASE).replace("\n", "\r\n")
    path = tmp_path / "crlf.toml"
    path.write_bytes(text.encode("utf-8"))
    assert load_scenario(path).build().dt == 5e-4
