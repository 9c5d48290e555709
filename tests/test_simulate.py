"""The fixed-step digital closed loop: shapes, determinism, batches, divergence, validation,
actuator limits, recorded parameters and model mismatch (issue 3, point 3; SPEC §5).

The paper's run is 4.5 s at 5e-4 s: 9000 control intervals, 9001 samples. Other runs are kept
short. Recorded signals are checked against what they claim to be: ``tau[k]`` is the
controller's output on the measurement at ``t_k`` (clipped), and ``q[k+1]`` is one RK4 step (or
``substeps`` of them) of the plant from ``q[k]`` under ``tau[k] + d[k]`` held.
"""

from __future__ import annotations

import math
import re
from typing import Any

import numpy as np
import pytest

from _numerics import rk4
from slidingarm import (
    FTSMC,
    PAPER_Q0,
    PDSMC,
    TSMC,
    ConstantTorque,
    GaussianNoise,
    ModelMismatch,
    PaperReference,
    PlanarArm,
    QuinticReference,
    Sensor,
    SimulationError,
    simulate,
    simulate_batch,
)
from slidingarm.simulate import DEFAULT_QD_LIMIT, time_grid

ARM = PlanarArm.paper()
REF = PaperReference()
N = ARM.n
DT = 5e-4
SIGNALS = ("q", "qd", "q_ref", "qd_ref", "q_meas", "qd_meas", "tau", "s")


def ftsmc(**kw: Any) -> FTSMC:
    """The study's FTSMC (alpha = 2, beta = 2, gamma = 3/5, k = 20), with overrides."""
    args: dict[str, Any] = {"alpha": 2.0, "beta": 2.0, "p": 5, "q": 3, "k": 20.0, **kw}
    return FTSMC(ARM, **args)


# ---------------------------------------------------------------------------- grid and shapes
def test_time_grid() -> None:
    t = time_grid(4.5, 5e-4)
    assert t.shape == (9001,)
    np.testing.assert_array_equal(t, np.arange(9001) * 5e-4)
    assert t[0] == 0.0 and t[-1] == pytest.approx(4.5, abs=1e-12)
    np.testing.assert_array_equal(time_grid(1.0, 0.25), [0.0, 0.25, 0.5, 0.75, 1.0])


def test_paper_run_shapes_and_initial_state() -> None:
    c = ftsmc()
    r = simulate(ARM, c, REF, q0=PAPER_Q0, t_final=4.5, dt=DT)
    assert r.t.shape == (9001,)
    np.testing.assert_array_equal(r.t, time_grid(4.5, DT))
    for name in SIGNALS:
        arr = getattr(r, name)
        assert arr.shape == (9001, N), name
        assert arr.dtype == np.float64
        assert np.all(np.isfinite(arr)), name
    np.testing.assert_array_equal(r.q[0], PAPER_Q0)
    np.testing.assert_array_equal(r.qd[0], np.zeros(N))
    q_ref, qd_ref, _qdd_ref = REF.evaluate(r.t)
    np.testing.assert_array_equal(r.q_ref, q_ref)
    np.testing.assert_array_equal(r.qd_ref, qd_ref)
    # no sensor: the controller measures the true state
    np.testing.assert_array_equal(r.q_meas, r.q)
    np.testing.assert_array_equal(r.qd_meas, r.qd)
    assert r.n == N and r.dt == pytest.approx(DT)
    # the paper's final errors are of order 1e-7 to 1e-6 rad; ours, with sign chattering at
    # k dt, are below 1e-4
    assert np.max(np.abs(r.e[-1])) < 1e-4


def test_recorded_torque_is_the_law_on_the_measurement() -> None:
    """tau[k] and s[k] are the controller's outputs on (q_meas[k], qd_meas[k], refs at t_k)."""
    c = ftsmc(switching="tanh")
    sensor = Sensor(noise=GaussianNoise(1e-3))
    r = simulate(ARM, c, REF, q0=PAPER_Q0, t_final=0.5, dt=DT, sensor=sensor, seed=5)
    _, _, qdd_ref = REF.evaluate(r.t)
    for k in range(0, r.t.shape[0], 50):
        tau, s = c.evaluate(r.q_meas[k], r.qd_meas[k], r.q_ref[k], r.qd_ref[k], qdd_ref[k])
        np.testing.assert_allclose(tau, r.tau[k], rtol=1e-13, atol=1e-12)
        np.testing.assert_allclose(s, r.s[k], rtol=1e-13, atol=1e-13)
    np.testing.assert_allclose(
        r.s, c.surface.value(r.q_meas - r.q_ref, r.qd_meas - r.qd_ref), rtol=1e-12, atol=1e-13
    )


@pytest.mark.parametrize("substeps", [1, 3])
def test_plant_is_rk4_under_the_held_torque(substeps: int) -> None:
    """q[k+1] is ``substeps`` RK4 steps of length dt/substeps under tau[k] (ZOH)."""
    r = simulate(ARM, ftsmc(), REF, q0=PAPER_Q0, t_final=0.2, dt=DT, substeps=substeps)
    h = DT / substeps
    for k in range(0, r.t.shape[0] - 1, 20):
        q, qd = r.q[k], r.qd[k]
        for _ in range(substeps):
            q, qd = rk4(ARM, q, qd, r.tau[k], h)
        np.testing.assert_allclose(q, r.q[k + 1], rtol=0, atol=1e-13)
        np.testing.assert_allclose(qd, r.qd[k + 1], rtol=0, atol=1e-11)


# ---------------------------------------------------------------------------- determinism
def _noisy(seed: int, **kw: Any) -> Any:
    sensor = Sensor(noise=GaussianNoise(1e-3))
    return simulate(ARM, ftsmc(switching="tanh"), REF, q0=PAPER_Q0, t_final=0.5, dt=DT,
                    sensor=sensor, seed=seed, **kw)  # fmt: skip


def test_a_seed_determines_the_run() -> None:
    a, b = _noisy(42), _noisy(42)
    for name in ("t", *SIGNALS):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
    assert a.seed == b.seed == 42 and a.params == b.params


def test_different_seeds_draw_different_noise() -> None:
    a, b = _noisy(1), _noisy(2)
    na, nb = a.q_meas - a.q, b.q_meas - b.q
    assert not np.allclose(na, nb)
    # independent draws: their correlation is that of independent samples (|rho| < 4/sqrt(T n))
    rho = np.corrcoef(na.ravel(), nb.ravel())[0, 1]
    assert abs(rho) < 4 / math.sqrt(na.size)
    assert not np.array_equal(a.q, b.q)  # and the noise reaches the plant through the control
    assert a.params["seed"] == 1 and b.params["seed"] == 2


def test_a_run_without_randomness_ignores_the_seed() -> None:
    a = simulate(ARM, ftsmc(), REF, q0=PAPER_Q0, t_final=0.1, dt=DT, seed=1)
    b = simulate(ARM, ftsmc(), REF, q0=PAPER_Q0, t_final=0.1, dt=DT, seed=2)
    np.testing.assert_array_equal(a.q, b.q)


# ---------------------------------------------------------------------------- batch
def test_batch_equals_single_runs() -> None:
    ctrls = [
        PDSMC(ARM, lam=2.0, k=20.0, switching="tanh", width=0.05),
        TSMC(ARM, beta=2.0, p=5, q=3, k=20.0, switching="tanh", width=0.05),
        ftsmc(switching="tanh", width=0.05),
    ]
    q0 = np.array([PAPER_Q0, [0.6, 1.4, 0.6], [0.2, 0.9, -0.1]])
    qd0 = np.array([0.1, -0.2, 0.3])
    seeds = [7, 8, 9]
    sensor = Sensor(noise=GaussianNoise((1e-3, 2e-3, 5e-4)))
    kw: dict[str, Any] = {"t_final": 0.3, "dt": DT, "sensor": sensor, "substeps": 2}
    batch = simulate_batch(ARM, ctrls, REF, q0=q0, qd0=qd0, seeds=seeds, **kw)
    assert len(batch) == 3
    assert batch.q.shape == (3, 601, N)
    assert batch.seeds == seeds
    for b in range(3):
        single = simulate(ARM, ctrls[b], REF, q0=q0[b], qd0=qd0, seed=seeds[b], **kw)
        one = batch[b]
        for name in ("t", *SIGNALS):
            np.testing.assert_array_equal(getattr(one, name), getattr(single, name), err_msg=name)
        assert one.params == single.params
        assert one.seed == single.seed == seeds[b]


def test_each_run_of_a_batch_owns_its_parameter_lists() -> None:
    """Inputs given once for the batch (one q0, qd0 and torque limit) are listed per run in
    its params: editing one run's lists leaves the other runs' as they were."""
    batch = simulate_batch(
        ARM, ftsmc(), REF, q0=PAPER_Q0, seeds=[1, 2], torque_limit=10.0, t_final=0.01, dt=DT
    )
    first, second = batch.params
    for key in ("q0", "qd0", "torque_limit"):
        assert first[key] == second[key]
        first[key][0] = 99.0
        assert second[key][0] != 99.0, key
    assert second["q0"] == np.asarray(PAPER_Q0, dtype=float).tolist()
    assert second["torque_limit"] == [10.0, 10.0, 10.0]


def test_batch_broadcasting() -> None:
    kw: dict[str, Any] = {"t_final": 0.05, "dt": DT}
    # B from the plants
    plants = [ARM, ModelMismatch(payload=0.3).apply(ARM)]
    batch = simulate_batch(plants, ftsmc(), REF, q0=PAPER_Q0, **kw)
    assert len(batch) == 2
    assert batch.params[0]["plant"] == ARM.to_dict()
    assert batch.params[1]["plant"] == plants[1].to_dict()
    assert not np.array_equal(batch.q[0], batch.q[1])
    # B from q0 (B, n); everything else shared
    q0 = np.array([PAPER_Q0, PAPER_Q0])
    batch = simulate_batch(ARM, ftsmc(), REF, q0=q0, **kw)
    assert len(batch) == 2
    np.testing.assert_array_equal(batch.q[0], batch.q[1])
    # B from the seeds: one shared sensor, different noise per run
    sensor = Sensor(noise=GaussianNoise(1e-3))
    batch = simulate_batch(ARM, ftsmc(), REF, q0=PAPER_Q0, seeds=[1, 2, 3], sensor=sensor, **kw)
    assert len(batch) == 3 and batch.seeds == [1, 2, 3]
    noise = batch.q_meas - batch.q
    assert not np.allclose(noise[0], noise[1]) and not np.allclose(noise[1], noise[2])
    # one seed shared by B runs: the same noise in each
    batch = simulate_batch(ARM, ftsmc(), REF, q0=q0, seeds=4, sensor=sensor, **kw)
    assert batch.seeds == [4, 4]
    np.testing.assert_array_equal(batch.q_meas[0], batch.q_meas[1])
    # a single run is a batch of one
    batch = simulate_batch(ARM, ftsmc(), REF, q0=PAPER_Q0, **kw)
    assert len(batch) == 1 and batch.q.shape == (1, 101, N)


@pytest.mark.parametrize(
    ("kwargs", "sizes"),
    [
        (
            {"plant": [ARM, ARM], "seeds": [1, 2, 3]},
            "plants 2, controllers 1, q0 1, qd0 1, seeds 3",
        ),
        (
            {"controller": "two", "q0": np.zeros((3, N))},
            "plants 1, controllers 2, q0 3, qd0 1, seeds 1",
        ),
        (
            {"qd0": np.zeros((2, N)), "seeds": [1, 2, 3, 4]},
            "plants 1, controllers 1, q0 1, qd0 2, seeds 4",
        ),
    ],
)
def test_batch_size_mismatch(kwargs: dict[str, Any], sizes: str) -> None:
    args: dict[str, Any] = {"plant": ARM, "controller": ftsmc(), "q0": PAPER_Q0}
    args.update(kwargs)
    if args["controller"] == "two":
        args["controller"] = [ftsmc(), ftsmc()]
    with pytest.raises(ValueError, match=rf"^batch sizes differ: {sizes} \(each must be 1 or B\)$"):
        simulate_batch(args.pop("plant"), args.pop("controller"), REF, t_final=0.01, dt=DT, **args)


def test_batch_validation() -> None:
    two = PlanarArm((1.0, 1.0), (1.0, 1.0))
    with pytest.raises(ValueError, match=r"all plants must have the same number of joints"):
        simulate_batch([ARM, two], ftsmc(), REF, q0=PAPER_Q0, t_final=0.01, dt=DT)
    with pytest.raises(TypeError, match=r"^plant must be an arm model or a SteppedPlant \(or a sequence of them\)"):
        simulate_batch([ARM, "arm"], ftsmc(), REF, q0=PAPER_Q0, t_final=0.01, dt=DT)  # type: ignore[list-item]
    with pytest.raises(ValueError, match=r"^plant must not be empty$"):
        simulate_batch([], ftsmc(), REF, q0=PAPER_Q0, t_final=0.01, dt=DT)
    with pytest.raises(ValueError, match=r"^seeds must not be empty$"):
        simulate_batch(ARM, ftsmc(), REF, q0=PAPER_Q0, t_final=0.01, dt=DT, seeds=[])


# ---------------------------------------------------------------------------- divergence
def test_divergence_names_time_and_joint() -> None:
    """A huge torque on joint 3 from t = 0.25 s: the run stops at the first sample where some
    |q̇_j| > qd_limit, and names that sample's time and the first such joint."""
    dist = [ConstantTorque((0.0, 0.0, 1e7), t_start=0.25)]
    with pytest.raises(SimulationError) as info:
        simulate(ARM, ftsmc(), REF, q0=PAPER_Q0, t_final=1.0, dt=DT, disturbances=dist)
    err = info.value
    # the same run, allowed to go on, shows where the speed limit was first crossed
    r = simulate(ARM, ftsmc(), REF, q0=PAPER_Q0, t_final=0.2505, dt=DT, disturbances=dist,
                 qd_limit=1e12)  # fmt: skip
    over = np.abs(r.qd) > DEFAULT_QD_LIMIT
    k = int(np.flatnonzero(over.any(axis=1))[0])
    j = int(np.flatnonzero(over[k])[0])
    assert err.time == pytest.approx(r.t[k]) == pytest.approx(0.2505)
    assert err.joint == j + 1 and err.run == 0
    msg = str(err)
    assert re.search(rf"diverged at t = 0\.2505 s, joint {j + 1}: the joint velocity ran away", msg)
    assert "|qd| > 10000 rad/s" in msg and "check the gains" in msg


def test_an_absurd_gain_with_the_papers_law_diverges() -> None:
    c = ftsmc(k=1e6, law="paper")
    with pytest.raises(SimulationError, match=r"diverged at t = [0-9.e-]+ s, joint [1-3]") as info:
        simulate(ARM, c, REF, q0=PAPER_Q0, t_final=1.0, dt=DT)
    assert 0.0 < info.value.time < 1.0 and info.value.joint in (1, 2, 3)


def test_a_diverging_batch_run_is_named() -> None:
    ctrls = [ftsmc(), ftsmc(k=1e9)]
    with pytest.raises(SimulationError, match=r"joint \d \(run 1 of 2\)") as info:
        simulate_batch(ARM, ctrls, REF, q0=PAPER_Q0, t_final=0.1, dt=DT)
    assert info.value.run == 1


def test_a_lower_speed_limit_stops_earlier() -> None:
    with pytest.raises(SimulationError, match=r"\(\|qd\| > 0\.5 rad/s\)") as info:
        simulate(ARM, ftsmc(), REF, q0=PAPER_Q0, t_final=1.0, dt=DT, qd_limit=0.5)
    r = simulate(ARM, ftsmc(), REF, q0=PAPER_Q0, t_final=1.0, dt=DT)
    k = int(np.flatnonzero((np.abs(r.qd) > 0.5).any(axis=1))[0])
    assert info.value.time == pytest.approx(r.t[k])


def test_an_overflowing_state_is_reported_as_non_finite() -> None:
    with pytest.raises(SimulationError, match=r"a non-finite value \(NaN or inf\) appeared"):
        simulate(ARM, ftsmc(), REF, q0=PAPER_Q0, t_final=0.1, dt=DT,
                 disturbances=[ConstantTorque(1e300)], qd_limit=1e308)  # fmt: skip


def test_a_non_finite_state_is_an_error_not_a_result() -> None:
    """Whatever the cause is called, a run that overflows raises; no result holds NaN."""
    for value in (1e150, 1e300):
        with pytest.raises(SimulationError, match=r"diverged at t = 0\.0005 s"):
            simulate(ARM, ftsmc(), REF, q0=PAPER_Q0, t_final=0.1, dt=DT,
                     disturbances=[ConstantTorque(value)], qd_limit=1e308)  # fmt: skip


# ---------------------------------------------------------------------------- validation
def _sim(**kw: Any) -> Any:
    args: dict[str, Any] = {"q0": PAPER_Q0, "t_final": 0.01, "dt": DT}
    args.update(kw)
    plant = args.pop("plant", ARM)
    controller = args.pop("controller", ftsmc())
    reference = args.pop("reference", REF)
    return simulate(plant, controller, reference, **args)


class _NaNAfter(PaperReference):
    """The paper's reference, NaN in ``qdd`` from 0.01 s on; ``checks`` says whether through
    :meth:`Reference.evaluate`'s own check (``False``: an ``evaluate`` that replaces it)."""

    __slots__ = ("checks",)

    def __init__(self, checks: bool) -> None:
        self.checks = checks

    def _evaluate(self, t: np.ndarray) -> Any:
        q, qd, qdd = super()._evaluate(t)
        qdd[t >= 0.01] = np.nan
        return q, qd, qdd

    def evaluate(self, t: Any) -> Any:
        return super().evaluate(t) if self.checks else self._evaluate(np.asarray(t))


@pytest.mark.parametrize(
    ("checks", "match"),
    [
        (True, r"_NaNAfter: qdd is not finite at t = 0\.01 \(joint 0\)"),
        (False, r"reference qdd must be finite with shape \(41, 3\)"),
    ],
)
def test_non_finite_reference_is_refused(checks: bool, match: str) -> None:
    """A reference's non-finite value is refused before the loop runs, by the reference's own
    check or, where a subclass replaced :meth:`Reference.evaluate`, by :func:`simulate`."""
    with pytest.raises(ValueError, match=match):
        simulate(ARM, ftsmc(), _NaNAfter(checks), q0=PAPER_Q0, t_final=0.02, dt=DT)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        (
            {"t_final": 0.01025},
            r"t_final \(0\.01025 s\) must be a whole number of steps dt \(0\.0005 s\)",
        ),
        ({"t_final": 1e-4}, r"t_final \(0\.0001 s\) must be a whole number of steps"),
        ({"t_final": 0.0}, r"t_final must be a finite duration > 0 s, got 0\.0"),
        ({"t_final": math.inf}, r"t_final must be a finite duration > 0 s, got inf"),
        ({"dt": 0.0}, r"dt must be a finite sample time > 0 s, got 0\.0"),
        ({"dt": -5e-4}, r"dt must be a finite sample time > 0 s, got -0\.0005"),
        ({"dt": math.nan}, r"dt must be a finite sample time > 0 s, got nan"),
        ({"substeps": 0}, r"substeps must be an integer >= 1, got 0"),
        ({"q0": (0.1, 0.2)}, r"q0 must have shape \(3,\) or \(B, 3\), got \(2,\)"),
        ({"q0": np.zeros((2, N))}, r"q0 must have shape \(3,\) for one run; use simulate_batch"),
        ({"q0": (0.1, math.nan, 0.2)}, r"q0 must be finite"),
        ({"q0": (0.1, math.inf, 0.2)}, r"q0 must be finite"),
        ({"qd0": (0.0, 0.0)}, r"qd0 must have shape \(3,\) or \(B, 3\), got \(2,\)"),
        ({"qd0": (0.0, math.nan, 0.0)}, r"qd0 must be finite"),
        ({"qd_limit": 0.0}, r"qd_limit must be a finite speed > 0 rad/s, got 0\.0"),
        ({"qd_limit": math.inf}, r"qd_limit must be a finite speed > 0 rad/s, got inf"),
        (
            {"torque_limit": 0.0},
            r"torque_limit must be > 0 N m, a scalar or one per joint \(3\), got 0\.0",
        ),
        ({"torque_limit": -5.0}, r"torque_limit must be > 0 N m"),
        ({"torque_limit": math.nan}, r"torque_limit must be > 0 N m"),
        (
            {"torque_limit": (10.0, 10.0)},
            r"torque_limit must be > 0 N m, a scalar or one per joint \(3\)",
        ),
        ({"torque_limit": (10.0, 0.0, 10.0)}, r"torque_limit must be > 0 N m"),
        ({"torque_limit": np.ones((3, 3))}, r"torque_limit must be > 0 N m"),
    ],
)
def test_validation(kwargs: dict[str, Any], match: str) -> None:
    with pytest.raises(ValueError, match=match):
        _sim(**kwargs)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"dt": "fast"}, r"^dt must be a number \(s\), got str 'fast'$"),
        ({"t_final": "0.01"}, r"^t_final must be a number \(s\), got str '0\.01'$"),
        ({"t_final": True}, r"^t_final must be a number \(s\), got bool True$"),
        ({"substeps": 2.0}, r"substeps must be an integer >= 1, got 2\.0"),
        ({"substeps": True}, r"substeps must be an integer >= 1, got True"),
        ({"seed": 1.5}, r"seed must be an integer, got 1\.5"),
        ({"seed": b"1"}, r"seed must be an integer, got b'1'"),
        ({"torque_limit": True}, r"^torque_limit must be numbers, got bool True$"),
        ({"torque_limit": "150"}, r"^torque_limit must be numbers, got str '150'$"),
        ({"q0": "0.1 0.2 0.3"}, r"^q0 must be numbers, got str"),
        ({"q0": {0.1, 0.2, 0.3}}, r"^q0 must be numbers, got set"),
        ({"qd_limit": "1e4"}, r"^qd_limit must be a number \(rad/s\), got '1e4'$"),
        ({"qd_limit": None}, r"^qd_limit must be a number \(rad/s\), got None$"),
        ({"q0": None}, r"^q0 must be numbers, got NoneType None$"),
        ({"plant": "paper"}, r"^plant must be an arm model \(PlanarArm, \.\.\.\) or a SteppedPlant, got str$"),
        ({"controller": None}, r"^controller must be a Controller, got NoneType$"),
        ({"sensor": GaussianNoise(0.1)}, r"^sensor must be a Sensor \(or a sequence of them\), got GaussianNoise$"),
        (
            {"disturbances": [ModelMismatch(payload=1.0)]},
            r"disturbances must be torque disturbances .*got ModelMismatch; a model mismatch belongs in the plant",
        ),
    ],
)  # fmt: skip
def test_wrong_types_raise_type_error(kwargs: dict[str, Any], match: str) -> None:
    with pytest.raises(TypeError, match=match):
        _sim(**kwargs)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"t_final": 10**400}, r"^t_final must be a finite duration > 0 s"),
        ({"dt": 10**400}, r"^dt must be a finite sample time > 0 s"),
        ({"q0": [10**400, 0, 0]}, r"^q0 must be finite$"),
        ({"qd_limit": 10**400}, r"^qd_limit must be a finite speed > 0 rad/s"),
        ({"substeps": 10**20}, r"^substeps must be at most 1,000,000 RK4 steps per sample, got 100000000000000000000$"),
    ],
)
def test_integers_beyond_float_are_values_out_of_range(kwargs: dict[str, Any], match: str) -> None:
    """Never an OverflowError: an integer beyond the float range is an infinite value."""
    with pytest.raises(ValueError, match=match) as info:
        _sim(**kwargs)
    assert not isinstance(info.value, TypeError)


def test_batch_seeds_reject_bytes_and_booleans() -> None:
    for seeds, match in [(b"1", r"seeds must be an integer or a sequence"), ([1, True], r"seeds must be integers, got True")]:
        with pytest.raises(TypeError, match=match):
            simulate_batch(ARM, ftsmc(), REF, q0=PAPER_Q0, t_final=0.01, dt=DT, seeds=seeds)


def test_joint_counts_must_agree() -> None:
    two = PlanarArm((1.0, 1.0), (0.5, 0.5))
    two_ctrl = FTSMC(two, alpha=2.0, beta=2.0, gamma=0.6, k=20.0)
    with pytest.raises(ValueError, match=r"^controller has 2 joints but the plant has 3$"):
        _sim(controller=two_ctrl)
    with pytest.raises(ValueError, match=r"^controller has 3 joints but the plant has 2$"):
        _sim(plant=two, q0=(0.1, 0.2))
    ref2 = QuinticReference((0.0, 0.0), (1.0, 1.0), duration=1.0)
    with pytest.raises(ValueError, match=r"^reference must be a Reference with n = 3 joints"):
        _sim(reference=ref2)
    with pytest.raises(ValueError, match=r"^reference must be a Reference with n = 3 joints"):
        _sim(reference=lambda t: t)
    # all 2-joint: runs
    r = _sim(plant=two, controller=two_ctrl, reference=ref2, q0=(0.1, 0.2))
    assert r.q.shape == (21, 2)


def test_a_single_disturbance_need_not_be_wrapped() -> None:
    d = ConstantTorque(1.0)
    a = _sim(disturbances=d)
    b = _sim(disturbances=[d])
    np.testing.assert_array_equal(a.q, b.q)


# ---------------------------------------------------------------------------- torque limits
def test_torque_limit_clips_tau() -> None:
    limit = np.array([20.0, 15.0, 5.0])
    free = _sim(t_final=0.5)
    assert np.any(np.abs(free.tau) > limit)  # the limits bind on this run
    r = _sim(t_final=0.5, torque_limit=limit)
    assert np.all(np.abs(r.tau) <= limit)
    at_limit = np.isclose(np.abs(r.tau), limit, rtol=0, atol=0)
    assert at_limit.sum() > 10
    # the clipped torque is what the plant received (one RK4 step per sample)
    for k in np.flatnonzero(at_limit.any(axis=1))[:20]:
        if k + 1 < r.t.shape[0]:
            q, _qd = rk4(ARM, r.q[k], r.qd[k], r.tau[k], DT)
            np.testing.assert_allclose(q, r.q[k + 1], rtol=0, atol=1e-13)
    # a scalar limit applies to every joint
    r = _sim(t_final=0.5, torque_limit=10.0)
    assert np.all(np.abs(r.tau) <= 10.0) and np.any(np.abs(r.tau) == 10.0)
    assert r.params["torque_limit"] == [10.0, 10.0, 10.0]


# ---------------------------------------------------------------------------- parameters
def test_params_record_the_run() -> None:
    c = ftsmc(switching="tanh", width=0.05)
    sensor = Sensor(noise=GaussianNoise(1e-3))
    dist = [ConstantTorque((0.1, 0.0, 0.0))]
    r = simulate(ARM, c, REF, q0=PAPER_Q0, qd0=(0.1, 0.0, 0.0), t_final=0.05, dt=DT,
                 substeps=2, sensor=sensor, disturbances=dist, seed=123)  # fmt: skip
    p = r.params
    assert p["seed"] == 123 and r.seed == 123
    assert p["plant"] == ARM.to_dict()
    # the automatic guard is recorded as resolved for the run's period
    assert p["controller"] == c.for_period(DT).to_dict()
    assert c.to_dict()["eps_e"] is None and p["controller"]["eps_e"] > 0
    ctrl = p["controller"]
    assert ctrl["controller"] == "ftsmc"
    assert (ctrl["alpha"], ctrl["beta"], ctrl["k"], ctrl["width"]) == (2.0, 2.0, 20.0, 0.05)
    assert ctrl["gamma"] == pytest.approx(0.6) and ctrl["switching"] == "tanh"
    assert ctrl["model"] == ARM.to_dict()
    assert p["reference"] == {"kind": "paper"}
    assert p["q0"] == list(PAPER_Q0) and p["qd0"] == [0.1, 0.0, 0.0]
    assert p["t_final"] == pytest.approx(0.05) and p["dt"] == DT and p["substeps"] == 2
    assert p["sensor"] == sensor.to_dict()
    assert p["disturbances"] == [d.to_dict() for d in dist]
    assert p["torque_limit"] is None
    assert isinstance(p["version"], str)
    import json

    assert json.loads(json.dumps(p)) == p  # JSON-able


# ---------------------------------------------------------------------------- mismatch
@pytest.mark.parametrize("switching", ["sign", "tanh"])
def test_model_mismatch_run_still_tracks(switching: str) -> None:
    """A 0.5 kg payload the controller does not know: sliding mode still tracks.

    Measured max |e| over the last 0.5 s: 3.1e-5 (sign), 1.1e-4 (tanh: the layer lets the
    mismatch through as a steady s of order ε·atanh(Δ/k)); with the exact model 3.4e-5 and
    2.4e-8.
    """
    plant = ModelMismatch(payload=0.5).apply(ARM)
    assert plant != ARM
    c = ftsmc(switching=switching) if switching == "sign" else ftsmc(switching="tanh", width=0.05)
    r = simulate(plant, c, REF, q0=PAPER_Q0, t_final=4.5, dt=DT)
    assert r.params["plant"] == plant.to_dict() and r.params["controller"]["model"] == ARM.to_dict()
    tail = r.t >= 4.0
    assert np.max(np.abs(r.e[tail])) < 1e-3
    assert np.max(np.abs(r.e[0])) > 0.5  # it started far off
