"""What the controller measures and what the plant suffers (issue 3, point 4; SPEC §4).

Sensors: Gaussian position noise has the stated statistics, faults act from ``t_start`` exactly,
and every velocity estimator equals its recursion on the recorded measurement; Levant's
differentiator converges to the true velocity with the O(L dt) accuracy of its sampled form
(Levant 1998). Disturbances: sample values, the plant receives ``tau_k + d_k`` held over the
interval, and a constant torque moves the sliding variable to the equilibrium the reaching law
predicts. Every dataclass rejects bad parameters with a message naming them.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest
from scipy import stats

from _numerics import rk4
from slidingarm import (
    FTSMC,
    PAPER_Q0,
    PDSMC,
    BackwardDifference,
    ConstantTorque,
    DirtyDerivative,
    GaussianNoise,
    LevantDifferentiator,
    ModelMismatch,
    PaperReference,
    PlanarArm,
    QuinticReference,
    RandomTorque,
    Sensor,
    SensorFault,
    SimResult,
    SinusoidalTorque,
    TrueVelocity,
    simulate,
)
from slidingarm.disturbances import disturbance_torque

ARM = PlanarArm.paper()
REF = PaperReference()
N = ARM.n
DT = 5e-4


def ftsmc(switching: str = "tanh") -> FTSMC:
    extra: dict[str, Any] = {} if switching == "sign" else {"width": 0.05}
    return FTSMC(ARM, alpha=2.0, beta=2.0, p=5, q=3, k=20.0, switching=switching, **extra)


def run(sensor: Sensor | None = None, t_final: float = 1.0, **kw: Any) -> SimResult:
    return simulate(ARM, ftsmc(), REF, q0=PAPER_Q0, t_final=t_final, dt=DT, sensor=sensor, **kw)


# ---------------------------------------------------------------------------- position noise
def test_gaussian_noise_statistics() -> None:
    """q_meas - q over the paper's run (T = 9001) is N(0, σ²), independent in time and joints.

    Bounds are 4 standard errors: sample std within 4/sqrt(2T) = 3 %, mean within 4σ/sqrt(T),
    correlations within 4/sqrt(T); a KS test against N(0, σ²) at p > 1e-3.
    """
    sigma = np.array([1e-3, 2e-3, 5e-4])
    r = simulate(ARM, ftsmc(), REF, q0=PAPER_Q0, t_final=4.5, dt=DT,
                 sensor=Sensor(noise=GaussianNoise(tuple(sigma))), seed=2024)  # fmt: skip
    noise = r.q_meas - r.q
    T = noise.shape[0]
    assert T == 9001
    se = 4 / math.sqrt(T)
    for j in range(N):
        x = noise[:, j]
        assert abs(x.std(ddof=1) / sigma[j] - 1) < 4 / math.sqrt(2 * T)
        assert abs(x.mean()) < se * sigma[j]
        assert abs(np.corrcoef(x[1:], x[:-1])[0, 1]) < se
        assert stats.kstest(x / sigma[j], "norm").pvalue > 1e-3
    for i in range(N):
        for j in range(i + 1, N):
            assert abs(np.corrcoef(noise[:, i], noise[:, j])[0, 1]) < se
    # the plant state is not noisy: the noise enters only through the measurement
    assert r.params["sensor"]["noise"] == {"kind": "gaussian", "sigma": sigma.tolist()}


def test_gaussian_noise_draws_from_the_generator() -> None:
    g = GaussianNoise(0.01)
    a = g.sample(np.random.default_rng(5), (100, N))
    np.testing.assert_array_equal(a, np.random.default_rng(5).standard_normal((100, N)) * 0.01)
    per_joint = GaussianNoise((0.0, 0.01, 0.02)).sample(np.random.default_rng(5), (100, N))
    np.testing.assert_array_equal(per_joint[:, 0], 0.0)
    z = np.random.default_rng(5).standard_normal((100, N))
    np.testing.assert_array_equal(per_joint, z * np.array([0.0, 0.01, 0.02]))


def test_zero_noise_is_an_exact_measurement() -> None:
    r = run(Sensor(noise=GaussianNoise(0.0)), t_final=0.1)
    np.testing.assert_array_equal(r.q_meas, r.q)
    assert not Sensor(noise=GaussianNoise(0.0)).random


# ---------------------------------------------------------------------------- faults
def test_bias_fault_offsets_from_t_start() -> None:
    fault = SensorFault("bias", joint=2, t_start=0.3, value=0.01)
    r = run(Sensor(faults=(fault,)), t_final=2.0)
    on = r.t >= 0.3
    assert 0 < on.sum() < on.size
    np.testing.assert_array_equal(r.q_meas[on, 1], r.q[on, 1] + 0.01)
    np.testing.assert_array_equal(r.q_meas[~on, 1], r.q[~on, 1])
    np.testing.assert_array_equal(r.q_meas[:, [0, 2]], r.q[:, [0, 2]])
    # the controller believes the bias: it drives the measured joint toward the reference, so
    # the true joint settles off it by the bias (measured e = -0.0099997 at 2 s)
    assert r.e[-1, 1] == pytest.approx(-0.01, abs=1e-5)


def test_stuck_fault_freezes_the_measurement() -> None:
    fault = SensorFault("stuck", joint=3, t_start=0.25)
    r = run(Sensor(faults=(fault,)), t_final=0.5)
    k0 = int(np.flatnonzero(r.t >= 0.25)[0])
    np.testing.assert_array_equal(r.q_meas[:k0], r.q[:k0])
    np.testing.assert_array_equal(r.q_meas[k0:, 2], r.q[k0 - 1, 2])
    np.testing.assert_array_equal(r.q_meas[:, :2], r.q[:, :2])
    assert np.ptp(r.q[k0:, 2]) > 1e-3  # the joint itself kept moving


def test_fault_parameters_are_stored_as_plain_numbers() -> None:
    fault = SensorFault("dropout", joint=np.int64(2), t_start=1, probability=np.float32(0.5))
    assert (type(fault.joint), type(fault.t_start), type(fault.probability)) == (int, float, float)
    assert fault.to_dict() == {"kind": "dropout", "joint": 2, "t_start": 1.0, "probability": 0.5}
    # the defaults of the parameters a kind does not use are accepted (the config files pass them)
    assert SensorFault("stuck", joint=1, value=0.0, probability=1.0).to_dict() == {
        "kind": "stuck",
        "joint": 1,
        "t_start": 0.0,
    }


def test_dropout_with_probability_one_is_stuck() -> None:
    stuck = run(Sensor(faults=(SensorFault("stuck", joint=1, t_start=0.2),)), t_final=0.4)
    drop = run(Sensor(faults=(SensorFault("dropout", joint=1, t_start=0.2),)), t_final=0.4, seed=9)
    for name in ("q", "qd", "q_meas", "qd_meas", "tau", "s"):
        np.testing.assert_array_equal(getattr(drop, name), getattr(stuck, name), err_msg=name)


def test_dropout_loses_the_stated_share_of_samples() -> None:
    p = 0.3
    fault = SensorFault("dropout", joint=2, t_start=0.5, probability=p)
    r = run(Sensor(faults=(fault,)), t_final=2.0, seed=4)
    held = r.q_meas[1:, 1] == r.q_meas[:-1, 1]
    fresh = r.q_meas[1:, 1] == r.q[1:, 1]
    assert np.all(held | fresh)
    t = r.t[1:]
    assert not held[t < 0.5].any()
    share = held[t >= 0.5].mean()
    m = int((t >= 0.5).sum())
    assert abs(share - p) < 4 * math.sqrt(p * (1 - p) / m)
    # reproducible from the seed, different for another
    again = run(Sensor(faults=(fault,)), t_final=2.0, seed=4)
    np.testing.assert_array_equal(again.q_meas, r.q_meas)
    other = run(Sensor(faults=(fault,)), t_final=2.0, seed=5)
    assert not np.array_equal(other.q_meas, r.q_meas)


def test_fault_on_a_missing_joint() -> None:
    with pytest.raises(ValueError, match=r"^fault joint 4 does not exist on a 3-joint arm$"):
        run(Sensor(faults=(SensorFault("bias", joint=4, value=0.1),)), t_final=0.01)


# ---------------------------------------------------------------------------- velocity
NOISY = GaussianNoise(1e-4)


def test_true_velocity() -> None:
    r = run(Sensor(noise=NOISY, velocity=TrueVelocity()), t_final=0.2, seed=1)
    np.testing.assert_array_equal(r.qd_meas, r.qd)


def test_backward_difference_is_exact() -> None:
    qd0 = np.array([0.1, -0.2, 0.3])
    r = run(Sensor(noise=NOISY, velocity=BackwardDifference()), t_final=0.2, seed=1, qd0=qd0)
    np.testing.assert_array_equal(r.qd_meas[0], qd0)  # initialised at the known q̇(0)
    np.testing.assert_array_equal(r.qd_meas[1:], (r.q_meas[1:] - r.q_meas[:-1]) / DT)
    # the paper's remark: differentiating noise of std σ gives std sqrt(2) σ / dt
    diff_noise = np.diff(r.q_meas - r.q, axis=0) / DT
    assert diff_noise.std() == pytest.approx(math.sqrt(2) * 1e-4 / DT, rel=0.05)


def test_dirty_derivative_equals_its_recursion() -> None:
    tf = 0.004
    qd0 = np.array([0.1, -0.2, 0.3])
    r = run(Sensor(noise=NOISY, velocity=DirtyDerivative(tf)), t_final=0.3, seed=2, qd0=qd0)
    v = np.empty_like(r.qd_meas)
    v[0] = qd0
    for k in range(1, v.shape[0]):
        v[k] = (tf * v[k - 1] + (r.q_meas[k] - r.q_meas[k - 1])) / (tf + DT)
    np.testing.assert_allclose(r.qd_meas, v, rtol=1e-13, atol=1e-13)


def test_levant_differentiator_equals_its_recursion() -> None:
    """z0' = -λ1 sqrt(L|σ|) sign σ + z1, z1' = -λ0 L sign σ, σ = z0 - q̃, explicit Euler."""
    lev = LevantDifferentiator(lipschitz=40.0, lambda1=1.6, lambda0=1.2)
    qd0 = np.array([0.1, -0.2, 0.3])
    r = run(Sensor(noise=NOISY, velocity=lev), t_final=0.3, seed=3, qd0=qd0)
    z0 = r.q_meas[0].copy()
    z1 = qd0.copy()
    expected = np.empty_like(r.qd_meas)
    expected[0] = z1
    for k in range(1, expected.shape[0]):
        sig = z0 - r.q_meas[k]
        sg = np.sign(sig)
        z0 = z0 + DT * (-1.6 * np.sqrt(40.0 * np.abs(sig)) * sg + z1)
        z1 = z1 + DT * (-1.2 * 40.0 * sg)
        expected[k] = z1
    np.testing.assert_allclose(r.qd_meas, expected, rtol=1e-12, atol=1e-12)


def test_levant_differentiator_converges_on_a_noise_free_run() -> None:
    """Noise-free, |q̈| <= L: after a 0.5 s transient |ẑ1 - q̇| <= 2 λ0 L dt (sampled exact
    differentiation is O(L dt), Levant 1998), and halving dt halves the error.

    Measured (PDSMC, tanh, L = 50): max |q̇_meas - q̇| = 0.0460 (dt = 5e-4) and 0.0223
    (dt = 2.5e-4), i.e. 1.67 and 1.62 λ0 L dt; |q̈| <= 21 rad/s².
    """
    lev = LevantDifferentiator(lipschitz=50.0)
    errs = []
    for dt in (DT, DT / 2):
        c = PDSMC(ARM, lam=2.0, k=20.0, switching="tanh", width=0.05)
        r = simulate(ARM, c, REF, q0=PAPER_Q0, t_final=2.0, dt=dt, sensor=Sensor(velocity=lev))
        qdd = np.diff(r.qd, axis=0) / dt
        assert np.max(np.abs(qdd)) <= lev.lipschitz  # the differentiator's premise holds
        err = np.max(np.abs(r.qd_meas - r.qd)[r.t >= 0.5])
        assert err <= 2 * lev.lambda0 * lev.lipschitz * dt, (dt, err)
        errs.append(err)
    assert 0.4 < errs[1] / errs[0] < 0.6


# ---------------------------------------------------------------------------- sensor validation
@pytest.mark.parametrize(
    ("build", "match"),
    [
        (
            lambda: GaussianNoise(-1e-3),
            r"^noise sigma must be finite and >= 0 \(rad\), got -0\.001$",
        ),
        (
            lambda: GaussianNoise(math.nan),
            r"^noise sigma must be finite and >= 0 \(rad\), got nan$",
        ),
        (lambda: GaussianNoise((1e-3, -1e-3, 0.0)), r"^noise sigma must be finite and >= 0"),
        (lambda: GaussianNoise(((1e-3,),)), r"^noise sigma must be finite and >= 0"),
        (lambda: DirtyDerivative(0.0), r"^time_constant must be a finite value > 0, got 0\.0$"),
        (lambda: DirtyDerivative(-1.0), r"^time_constant must be a finite value > 0, got -1\.0$"),
        (lambda: DirtyDerivative("slow"), r"^time_constant must be a number, got 'slow'$"),  # type: ignore[arg-type]
        (
            lambda: LevantDifferentiator(lipschitz=0.0),
            r"^lipschitz must be a finite value > 0, got 0\.0$",
        ),
        (
            lambda: LevantDifferentiator(lambda1=math.inf),
            r"^lambda1 must be a finite value > 0, got inf$",
        ),
        (
            lambda: LevantDifferentiator(lambda0=-1.1),
            r"^lambda0 must be a finite value > 0, got -1\.1$",
        ),
        (
            lambda: SensorFault("broken", joint=1),
            r"^fault kind must be 'bias', 'stuck' or 'dropout', got 'broken'$",
        ),
        (lambda: SensorFault("bias", joint=0), r"^fault joint must be a joint number >= 1, got 0$"),
        (
            lambda: SensorFault("bias", joint=1.0),
            r"^fault joint must be a joint number >= 1, got 1\.0$",
        ),
        (
            lambda: SensorFault("bias", joint=1, t_start=-0.1),
            r"^fault t_start must be a finite time >= 0 s, got -0\.1$",
        ),
        (
            lambda: SensorFault("stuck", joint=1, t_start=math.nan),
            r"^fault t_start must be a finite time >= 0 s, got nan$",
        ),
        (
            lambda: SensorFault("bias", joint=1, value=math.inf),
            r"^fault value must be finite, got inf$",
        ),
        (
            lambda: SensorFault("dropout", joint=1, probability=1.5),
            r"^fault probability must lie in \[0, 1\], got 1\.5$",
        ),
        (
            lambda: SensorFault("dropout", joint=1, probability=math.nan),
            r"^fault probability must lie in \[0, 1\], got nan$",
        ),
        (
            lambda: Sensor(velocity="levant"),
            r"^velocity must be a velocity estimator, got 'levant'$",
        ),
        # a stuck sensor freezes at its last reading: a value would be ignored, so it is refused
        (
            lambda: SensorFault("stuck", joint=1, value=0.3),
            r"^fault value applies to kind='bias' only, got value=0\.3 with kind='stuck' "
            r"\(a stuck sensor freezes at its last reading before t_start\)$",
        ),
        (
            lambda: SensorFault("dropout", joint=1, value=0.3),
            r"^fault value applies to kind='bias' only, got value=0\.3 with kind='dropout' "
            r"\(a lost sample repeats the last reading\)$",
        ),
        (
            lambda: SensorFault("bias", joint=1, value=0.1, probability=0.5),
            r"^fault probability applies to kind='dropout' only, got probability=0\.5 with "
            r"kind='bias'$",
        ),
        (
            lambda: SensorFault("stuck", joint=1, probability=0.0),
            r"^fault probability applies to kind='dropout' only, got probability=0\.0 with "
            r"kind='stuck'$",
        ),
        # numbers that are not numbers: ValueError naming the parameter, never TypeError
        (
            lambda: SensorFault("stuck", joint=1, t_start="a"),
            r"^fault t_start must be a finite time >= 0 s, got 'a'$",
        ),
        (
            lambda: SensorFault("stuck", joint=1, t_start=None),
            r"^fault t_start must be a finite time >= 0 s, got None$",
        ),
        (
            lambda: SensorFault("stuck", joint=1, t_start=True),
            r"^fault t_start must be a finite time >= 0 s, got True$",
        ),
        (lambda: SensorFault("bias", joint=1, value="a"), r"^fault value must be a number \(rad\), got 'a'$"),
        (lambda: SensorFault("bias", joint=1, value=True), r"^fault value must be a number \(rad\), got True$"),
        (
            lambda: SensorFault("dropout", joint=1, probability="a"),
            r"^fault probability must lie in \[0, 1\], got 'a'$",
        ),
        (
            lambda: SensorFault("dropout", joint=1, probability=True),
            r"^fault probability must lie in \[0, 1\], got True$",
        ),
        (lambda: SensorFault("bias", joint=True), r"^fault joint must be a joint number >= 1, got True$"),
        (lambda: GaussianNoise("a"), r"^noise sigma must be finite and >= 0 \(rad\), got 'a'$"),
        (lambda: GaussianNoise(None), r"^noise sigma must be finite and >= 0 \(rad\), got None$"),
        (
            lambda: GaussianNoise(True),
            r"^noise sigma must be a number \(rad\) or one per joint, not a boolean, got True$",
        ),
        (
            lambda: GaussianNoise((1e-3, True, 0.0)),
            r"^noise sigma must be a number \(rad\) or one per joint, not a boolean, "
            r"got \(0\.001, True, 0\.0\)$",
        ),
        (
            lambda: DirtyDerivative(True),
            r"^time_constant must be a number, not a boolean, got True$",
        ),
        (
            lambda: LevantDifferentiator(lambda1=False),
            r"^lambda1 must be a number, not a boolean, got False$",
        ),
        # numpy booleans and boolean arrays are booleans too; strings are not numbers
        (
            lambda: GaussianNoise(np.array([True, False, True])),
            r"^noise sigma must be a number \(rad\) or one per joint, not a boolean, "
            r"got array\(\[ True, False,  True\]\)$",
        ),
        (
            lambda: GaussianNoise(np.True_),
            r"^noise sigma must be a number \(rad\) or one per joint, not a boolean, got np\.True_$",
        ),
        (lambda: GaussianNoise(()), r"^noise sigma must be finite and >= 0 \(rad\), got \(\)$"),
        (
            lambda: DirtyDerivative(np.True_),
            r"^time_constant must be a number, not a boolean, got np\.True_$",
        ),
        (lambda: DirtyDerivative("0.005"), r"^time_constant must be a number, got '0\.005'$"),
        (
            lambda: SensorFault("bias", joint=np.True_),
            r"^fault joint must be a joint number >= 1, got np\.True_$",
        ),
        (
            lambda: SensorFault("stuck", joint=1, t_start=np.True_),
            r"^fault t_start must be a finite time >= 0 s, got np\.True_$",
        ),
        (
            lambda: SensorFault("bias", joint=1, value=np.False_),
            r"^fault value must be a number \(rad\), got np\.False_$",
        ),
        (
            lambda: SensorFault("dropout", joint=1, probability=np.True_),
            r"^fault probability must lie in \[0, 1\], got np\.True_$",
        ),
    ],
)  # fmt: skip
def test_sensor_validation(build: Any, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        build()


def test_per_joint_noise_must_match_the_arm() -> None:
    with pytest.raises(ValueError, match=r"^noise sigma has 2 values but the arm has 3 joints$"):
        run(Sensor(noise=GaussianNoise((1e-3, 1e-3))), t_final=0.01)


# ---------------------------------------------------------------------------- disturbances
def test_disturbance_sample_values() -> None:
    t = np.arange(11) * 0.1
    rng = np.random.default_rng(0)
    c = ConstantTorque((1.0, -2.0, 3.0), t_start=0.5).torque(t, N, rng)
    assert c.shape == (11, N)
    np.testing.assert_array_equal(c[t < 0.5], 0.0)
    np.testing.assert_array_equal(
        c[t >= 0.5], np.tile([1.0, -2.0, 3.0], (int((t >= 0.5).sum()), 1))
    )
    np.testing.assert_array_equal(ConstantTorque(2.0).torque(t, N, rng), np.full((11, N), 2.0))

    s = SinusoidalTorque(amplitude=(1.0, 0.0, -2.0), frequency=2.0, phase=0.3).torque(t, N, rng)
    expected = np.sin(2 * np.pi * 2.0 * t + 0.3)[:, None] * np.array([1.0, 0.0, -2.0])
    np.testing.assert_allclose(s, expected, rtol=0, atol=1e-15)

    big = np.arange(20_000) * DT
    draw = RandomTorque(sigma=(0.5, 0.0, 2.0)).torque(big, N, np.random.default_rng(8))
    np.testing.assert_array_equal(
        draw, np.random.default_rng(8).standard_normal((big.size, N)) * [0.5, 0.0, 2.0]
    )
    np.testing.assert_array_equal(draw[:, 1], 0.0)
    assert draw[:, 0].std() == pytest.approx(0.5, rel=4 / math.sqrt(2 * big.size))
    assert draw[:, 2].std() == pytest.approx(2.0, rel=4 / math.sqrt(2 * big.size))

    total = disturbance_torque(
        (ConstantTorque(1.0), SinusoidalTorque(2.0, frequency=1.0)), t, N, rng
    )
    expected = np.broadcast_to(1.0 + 2.0 * np.sin(2 * np.pi * t)[:, None], (11, N))
    np.testing.assert_allclose(total, expected, rtol=0, atol=1e-15)
    np.testing.assert_array_equal(disturbance_torque((), t, N, rng), np.zeros((11, N)))


def test_per_joint_disturbance_must_match_the_arm() -> None:
    with pytest.raises(
        ValueError, match=r"^constant disturbance value has 2 values but the arm has 3 joints$"
    ):
        run(disturbances=[ConstantTorque((1.0, 2.0))], t_final=0.01)
    with pytest.raises(ValueError, match=r"^random disturbance sigma has 4 values"):
        run(disturbances=[RandomTorque((1.0, 2.0, 3.0, 4.0))], t_final=0.01)


def test_the_plant_receives_tau_plus_the_disturbance_held() -> None:
    """q[k+1] = RK4(q[k], q̇[k]; tau[k] + d(t_k)) with d sampled at t_k and held."""
    dist = SinusoidalTorque(amplitude=(3.0, -2.0, 1.0), frequency=5.0, phase=0.1)
    r = run(t_final=0.2, disturbances=[dist])
    d = dist.torque(r.t, N, np.random.default_rng(0))
    for k in range(0, r.t.shape[0] - 1, 10):
        q, qd = rk4(ARM, r.q[k], r.qd[k], r.tau[k] + d[k], DT)
        np.testing.assert_allclose(q, r.q[k + 1], rtol=0, atol=1e-13)
        np.testing.assert_allclose(qd, r.qd[k + 1], rtol=0, atol=1e-11)
    # and the recorded tau is the controller's alone
    free = run(t_final=0.2)
    np.testing.assert_array_equal(r.tau[0], free.tau[0])


def test_random_torque_is_seeded() -> None:
    a = run(t_final=0.2, disturbances=[RandomTorque(1.0)], seed=1)
    b = run(t_final=0.2, disturbances=[RandomTorque(1.0)], seed=1)
    c = run(t_final=0.2, disturbances=[RandomTorque(1.0)], seed=2)
    np.testing.assert_array_equal(a.q, b.q)
    assert not np.array_equal(a.q, c.q)


def test_a_disturbance_moves_the_arm_in_its_direction() -> None:
    """First sample: the disturbance adds dt M(q0)⁻¹ d to q̇ (to O(dt²))."""
    d = np.array([5.0, 0.0, 0.0])
    free = run(t_final=0.01)
    pushed = run(t_final=0.01, disturbances=[ConstantTorque(tuple(d))])
    dv = pushed.qd[1] - free.qd[1]
    expected = DT * np.linalg.solve(ARM.mass_matrix(PAPER_Q0), d)
    np.testing.assert_allclose(dv, expected, rtol=1e-3)
    assert dv[0] > 0


@pytest.mark.parametrize("d", [2.0, -2.0])
def test_constant_torque_sets_the_boundary_layer_equilibrium(d: float) -> None:
    """One joint (M = m l² = 1), static reference: ṡ = -k tanh(s/ε) + d/M settles at
    s* = ε atanh(d/(M k)), and ė + λe = s* moves e by s*/λ. Measured: s within 6e-9
    relative of s*, the e shift within 3e-4."""
    arm = PlanarArm((1.0,), (1.0,))
    ref = QuinticReference((0.0,), (0.5,), duration=1.0)
    c = PDSMC(arm, lam=2.0, k=20.0, switching="tanh", width=0.05)

    def go(dist: list[ConstantTorque]) -> SimResult:
        return simulate(arm, c, ref, q0=(0.1,), t_final=4.0, dt=DT, disturbances=dist)

    free, pushed = go([]), go([ConstantTorque(d)])
    s_star = 0.05 * math.atanh(d / 20.0)
    assert pushed.s[-1, 0] == pytest.approx(s_star, rel=1e-6)
    assert pushed.e[-1, 0] - free.e[-1, 0] == pytest.approx(s_star / 2.0, rel=1e-3)
    assert math.copysign(1.0, pushed.e[-1, 0] - free.e[-1, 0]) == math.copysign(1.0, d)


@pytest.mark.parametrize(
    ("build", "match"),
    [
        (
            lambda: ConstantTorque(math.nan),
            r"^constant disturbance value must be a finite number or one per joint, got nan$",
        ),
        (
            lambda: ConstantTorque(((1.0, 2.0),)),
            r"^constant disturbance value must be a finite number or one per joint",
        ),
        (
            lambda: ConstantTorque(1.0, t_start=math.nan),
            r"^constant disturbance t_start must be a finite time \(s\), got nan$",
        ),
        (
            lambda: SinusoidalTorque(math.inf),
            r"^sinusoidal disturbance amplitude must be a finite number or one per joint",
        ),
        (
            lambda: SinusoidalTorque(1.0, frequency=-1.0),
            r"^sinusoidal disturbance frequency must be finite and >= 0 Hz, got -1\.0$",
        ),
        (
            lambda: SinusoidalTorque(1.0, frequency=math.nan),
            r"^sinusoidal disturbance frequency must be finite and >= 0 Hz, got nan$",
        ),
        (
            lambda: SinusoidalTorque(1.0, phase=math.inf),
            r"^sinusoidal disturbance phase must be finite \(rad\), got inf$",
        ),
        (lambda: RandomTorque(-1.0), r"^random disturbance sigma must be >= 0, got -1\.0$"),
        (
            lambda: RandomTorque((1.0, math.nan)),
            r"^random disturbance sigma must be a finite number",
        ),
        (
            lambda: ModelMismatch(payload=-0.1),
            r"^payload must be a finite mass >= 0 kg, got -0\.1$",
        ),
        (
            lambda: ModelMismatch(payload=math.inf),
            r"^payload must be a finite mass >= 0 kg, got inf$",
        ),
        (
            lambda: ModelMismatch(mass_error=-1.0),
            r"^mass_error must be > -1 \(a relative error; -1 would remove the link\), got -1\.0$",
        ),
        (
            lambda: ModelMismatch(length_error=(0.1, -1.5, 0.0)),
            r"^length_error must be > -1 .*got \(0\.1, -1\.5, 0\.0\)$",
        ),
        (
            lambda: ModelMismatch(mass_error=math.nan),
            r"^mass_error must be a finite number or one per joint, got nan$",
        ),
        # not numbers: named, never a bare conversion error; booleans are not numbers either
        (
            lambda: ConstantTorque("a"),
            r"^constant disturbance value must be a finite number or one per joint, got 'a'$",
        ),
        (
            lambda: ConstantTorque(True),
            r"^constant disturbance value must be a finite number or one per joint, got True$",
        ),
        (
            lambda: SinusoidalTorque("a"),
            r"^sinusoidal disturbance amplitude must be a finite number or one per joint, got 'a'$",
        ),
        (
            lambda: RandomTorque((1.0, "x", 2.0)),
            r"^random disturbance sigma must be a finite number or one per joint, got \(1\.0, 'x', 2\.0\)$",
        ),
        (lambda: ModelMismatch(payload="a"), r"^payload must be a finite mass >= 0 kg, got 'a'$"),
        (lambda: ModelMismatch(payload=True), r"^payload must be a finite mass >= 0 kg, got True$"),
        (
            lambda: ModelMismatch(length_error=[0.1, True, 0.0]),
            r"^length_error must be a finite number or one per joint, got \[0\.1, True, 0\.0\]$",
        ),
        # numpy booleans and boolean arrays are booleans too (they were read as 1.0 and 0.0)
        (
            lambda: ConstantTorque(np.array([True, False, True])),
            r"^constant disturbance value must be a finite number or one per joint, "
            r"got array\(\[ True, False,  True\]\)$",
        ),
        (
            lambda: ConstantTorque(np.True_),
            r"^constant disturbance value must be a finite number or one per joint, got np\.True_$",
        ),
        (
            lambda: ConstantTorque(1.0, t_start=np.True_),
            r"^constant disturbance t_start must be a finite time \(s\), got np\.True_$",
        ),
        (
            lambda: SinusoidalTorque((1.0, np.True_, 0.0)),
            r"^sinusoidal disturbance amplitude must be a finite number or one per joint, "
            r"got \(1\.0, np\.True_, 0\.0\)$",
        ),
        (
            lambda: SinusoidalTorque(1.0, frequency=np.True_),
            r"^sinusoidal disturbance frequency must be finite and >= 0 Hz, got np\.True_$",
        ),
        (
            lambda: RandomTorque(np.array([True])),
            r"^random disturbance sigma must be a finite number or one per joint, "
            r"got array\(\[ True\]\)$",
        ),
        (
            lambda: ModelMismatch(mass_error=np.array([True, False, False])),
            r"^mass_error must be a finite number or one per joint, "
            r"got array\(\[ True, False, False\]\)$",
        ),
        (
            lambda: ModelMismatch(payload=np.True_),
            r"^payload must be a finite mass >= 0 kg, got np\.True_$",
        ),
        # strings are not numbers, even when they read as one; an empty vector has no joints
        (
            lambda: ConstantTorque("1.5"),
            r"^constant disturbance value must be a finite number or one per joint, got '1\.5'$",
        ),
        (
            lambda: RandomTorque(()),
            r"^random disturbance sigma must be a finite number or one per joint, got \(\)$",
        ),
    ],
)
def test_disturbance_validation(build: Any, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        build()


def test_model_mismatch_builds_the_plant() -> None:
    plant = ModelMismatch(payload=0.5).apply(ARM)
    # the payload sits at the tool: the last link's mass and centre of mass move out
    assert plant.masses.tolist() == [1.0, 1.0, 1.5]
    np.testing.assert_allclose(plant.com, [0.5, 1.0, 1.0])
    np.testing.assert_allclose(plant.lengths, ARM.lengths)
    scaled = ModelMismatch(mass_error=(0.1, 0.0, -0.2), length_error=0.05).apply(ARM)
    np.testing.assert_allclose(scaled.masses, [1.1, 1.0, 0.8])
    np.testing.assert_allclose(scaled.lengths, 1.05 * ARM.lengths)
    np.testing.assert_allclose(scaled.com, 1.05 * ARM.com)
    assert ModelMismatch().apply(ARM) == ARM
    assert ModelMismatch(mass_error=(0.1, 0.0, -0.2)).to_dict() == {
        "payload": 0.0,
        "mass_error": [0.1, 0.0, -0.2],
        "length_error": 0.0,
    }
    with pytest.raises(ValueError, match=r"mass_error has 2 values but the arm has 3 joints"):
        ModelMismatch(mass_error=(0.1, 0.2)).apply(ARM)
