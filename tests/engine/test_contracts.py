"""The engine contract: custom compiled laws, replace(), the checker, Python-stepped plants,
pickling in worker processes."""

from __future__ import annotations

import pickle
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))

import custom_kernels as K

import slidingarm as sa

ARM = sa.PlanarArm.paper()
REF = sa.PaperReference()
DT = 5e-4


def builtin() -> sa.PDSMC:
    return sa.PDSMC(ARM, lam=2.0, k=20.0, switching="tanh", width=0.05)


def custom(model: sa.PlanarArm = ARM) -> sa.CustomController:
    return sa.CustomController(
        K.pdsmc_tanh, model, params=K.pdsmc_kernel_args(), gains=("lam", "k", "width")
    )


# ---------------------------------------------------------------------------- custom kernels
def test_custom_pdsmc_equals_the_builtin_over_the_paper_run() -> None:
    a = sa.simulate(ARM, builtin(), REF, q0=sa.PAPER_Q0, t_final=4.5, dt=DT)
    b = sa.simulate(ARM, custom(), REF, q0=sa.PAPER_Q0, t_final=4.5, dt=DT)
    assert np.max(np.abs(a.q - b.q)) <= 1e-12
    scale = np.max(np.abs(a.tau))
    assert np.max(np.abs(a.tau - b.tau)) <= 1e-12 * scale
    assert np.max(np.abs(a.s - b.s)) <= 1e-12
    assert b.params["controller"]["controller"] == "custom"
    assert b.params["controller"]["gains"] == {"lam": 2.0, "k": 20.0, "width": 0.05}


def test_custom_kernel_with_every_option_and_a_mismatched_plant() -> None:
    """Noise, Levant's differentiator, a bias fault, disturbances, torque limits, a different
    plant: the custom law is the built-in one in every case."""
    plant = sa.ModelMismatch(payload=0.4, mass_error=0.1).apply(ARM)
    sensor = sa.Sensor(
        noise=sa.GaussianNoise(1e-4),
        velocity=sa.LevantDifferentiator(50.0),
        faults=(sa.SensorFault("bias", joint=2, t_start=0.3, value=1e-3),),
    )
    kw = dict(
        q0=sa.PAPER_Q0, t_final=1.0, dt=DT, sensor=sensor, torque_limit=60.0, seed=3,
        disturbances=[sa.SinusoidalTorque(0.5, 2.0), sa.RandomTorque(0.2)],
    )  # fmt: skip
    a = sa.simulate(plant, builtin(), REF, **kw)
    b = sa.simulate(plant, custom(), REF, **kw)
    assert np.max(np.abs(a.q - b.q)) <= 1e-12
    assert np.max(np.abs(a.tau - b.tau)) <= 1e-12 * np.max(np.abs(a.tau))


def test_custom_state_is_reset_at_each_run_and_counts_the_samples() -> None:
    c = sa.CustomController(K.counting, ARM, params=(50.0, 10.0, DT), state_size=2)
    batch = sa.simulate_batch(ARM, c, REF, q0=sa.PAPER_Q0, t_final=0.05, dt=DT, seeds=[1, 2])
    np.testing.assert_array_equal(batch.tau[0], batch.tau[1])  # same start: the state was reset
    # the Python path keeps its own state, advanced by every evaluate
    c.reset()
    for k in range(3):
        c.evaluate(batch.q_meas[0, k], batch.qd_meas[0, k], batch.q_ref[0, k],
                   batch.qd_ref[0, k], np.zeros(3))  # fmt: skip
    assert c._state[0] == 3.0


def test_custom_controller_validates_its_inputs() -> None:
    with pytest.raises(TypeError, match=r"^kernel must be a numba @njit function"):
        sa.CustomController(lambda *a: None, ARM, params=())
    with pytest.raises(TypeError, match=r"^nominal must be an ArmModel, got str"):
        sa.CustomController(K.pdsmc_tanh, "arm", params=())  # type: ignore[arg-type]
    with pytest.raises(TypeError, match=r"^params must be a sequence of numbers, got str"):
        sa.CustomController(K.pdsmc_tanh, ARM, params="1 2 3")
    with pytest.raises(TypeError, match=r"^params must be numbers, not booleans"):
        sa.CustomController(K.pdsmc_tanh, ARM, params=(1.0, True))
    with pytest.raises(ValueError, match=r"^params must be finite"):
        sa.CustomController(K.pdsmc_tanh, ARM, params=(1.0, np.nan))
    with pytest.raises(ValueError, match=r"^state_size must be an integer >= 0, got -1$"):
        sa.CustomController(K.pdsmc_tanh, ARM, params=(1.0,), state_size=-1)
    with pytest.raises(TypeError, match=r"^state_size must be an integer >= 0, got True$"):
        sa.CustomController(K.pdsmc_tanh, ARM, params=(1.0,), state_size=True)


def test_custom_replace_by_gain_name() -> None:
    c = custom().replace(k=30.0)
    assert c.params.tolist() == [2.0, 30.0, 0.05]
    assert custom().replace(params=(1.0, 2.0, 3.0)).params.tolist() == [1.0, 2.0, 3.0]
    with pytest.raises(TypeError, match=r"unknown parameter\(s\) \['alpha'\]"):
        custom().replace(alpha=1.0)


# ---------------------------------------------------------------------------- replace
def test_replace_returns_a_new_validated_controller() -> None:
    ftsmc = sa.FTSMC(ARM, alpha=2, beta=2, p=5, q=3, k=20)
    new = ftsmc.replace(k=30, switching="tanh", width=0.05)
    expected = sa.FTSMC(ARM, alpha=2, beta=2, p=5, q=3, k=30, switching="tanh", width=0.05)
    assert new.to_dict() == expected.to_dict()
    assert ftsmc.to_dict()["k"] == 20.0 and new is not ftsmc
    back = new.replace(switching="sign")  # drops the width that sign does not take
    assert back.to_dict() == sa.FTSMC(ARM, alpha=2, beta=2, p=5, q=3, k=30).to_dict()
    assert ftsmc.replace(gamma=0.5).to_dict()["gamma"] == 0.5
    st = ftsmc.replace(reaching="super-twisting", k2=5.0)
    assert st.state_size == 3 and st.replace(reaching="classic").state_size == 0
    with pytest.raises(ValueError, match=r"^k must be"):
        ftsmc.replace(k=-1.0)
    with pytest.raises(TypeError, match=r"unknown parameter\(s\) \['lam'\]"):
        ftsmc.replace(lam=1.0)
    other = ARM.with_payload(1.0)
    assert ftsmc.replace(model=other).model == other


def test_controllers_describe_themselves() -> None:
    assert builtin().label == "PDSMC" and builtin().s_unit == "rad/s"
    nt = sa.NTSMC(ARM, beta=1.0, p=5, q=3, k=5.0)
    assert nt.s_unit == "rad" and nt.label == "NTSMC"
    assert sa.FTSMC(ARM, alpha=2, beta=2, p=5, q=3, k=20).gain_names == (
        "alpha", "beta", "gamma", "eps_e", "k"
    )  # fmt: skip
    r = sa.simulate(ARM, nt, REF, q0=sa.PAPER_Q0, t_final=0.01, dt=DT)
    assert r.params["s_unit"] == "rad" and r.params["label"] == "NTSMC"


# ---------------------------------------------------------------------------- the checker
@pytest.mark.parametrize(
    "make",
    [
        builtin,
        custom,
        lambda: sa.FTSMC(ARM, alpha=2, beta=2, p=5, q=3, k=20, law="paper"),
        lambda: sa.FTSMC(ARM, alpha=2, beta=2, p=5, q=3, k=5, reaching="super-twisting", k2=4.0),
        lambda: sa.NTSMC(ARM, beta=1.0, p=5, q=3, k=5.0, switching="sat", width=0.1),
        lambda: sa.CustomController(K.counting, ARM, params=(50.0, 10.0, DT), state_size=2),
    ],
)
def test_the_checker_passes_every_conforming_controller(make: object) -> None:
    sa.check_controller(make(), ARM)  # type: ignore[operator]


def test_the_checker_rejects_a_nan_torque() -> None:
    bad = sa.CustomController(K.blows_up, ARM, params=())
    with pytest.raises(sa.ControllerCheckError, match=r"non-finite"):
        sa.check_controller(bad, ARM)


def test_the_checker_rejects_a_controller_of_another_arm() -> None:
    two = sa.PlanarArm((1.0, 1.0), (1.0, 1.0))
    with pytest.raises(sa.ControllerCheckError, match=r"controller has n = 3, the model 2"):
        sa.check_controller(builtin(), two)


# ---------------------------------------------------------------------------- stepped plants
def test_the_python_stepped_loop_is_the_compiled_loop() -> None:
    """The same step pieces around a plant stepped from Python: equal to the compiled loop,
    with noise, a differentiator, disturbances, limits, substeps and both kinds of law."""
    sensor = sa.Sensor(noise=sa.GaussianNoise(1e-4), velocity=sa.DirtyDerivative(5e-3))
    kw = dict(q0=sa.PAPER_Q0, t_final=0.5, dt=DT, sensor=sensor, torque_limit=80.0, seed=5,
              substeps=2, disturbances=[sa.RandomTorque(0.3)])  # fmt: skip
    for ctrl in (sa.FTSMC(ARM, alpha=2, beta=2, p=5, q=3, k=20, switching="tanh"), custom()):
        compiled = sa.simulate(ARM, ctrl, REF, **kw)
        stepped = sa.simulate(sa.SteppedArm(ARM), ctrl, REF, **kw)
        assert np.max(np.abs(compiled.q - stepped.q)) <= 1e-12
        assert np.max(np.abs(compiled.tau - stepped.tau)) <= 1e-12 * np.max(np.abs(compiled.tau))


def test_a_stepped_plant_reports_divergence_like_the_compiled_one() -> None:
    dist = [sa.ConstantTorque((0.0, 0.0, 1e7), t_start=0.25)]
    kw = dict(q0=sa.PAPER_Q0, t_final=0.5, dt=DT, disturbances=dist, throw=False)
    a = sa.simulate(ARM, builtin(), REF, **kw)
    b = sa.simulate(sa.SteppedArm(ARM), builtin(), REF, **kw)
    assert a.status == b.status == "runaway" and a.message == b.message
    np.testing.assert_array_equal(np.isnan(a.q), np.isnan(b.q))


# ---------------------------------------------------------------------------- pickling
def _run_in_worker(payload: bytes) -> bytes:
    plant, ctrl, ref, sensor, dists = pickle.loads(payload)
    r = sa.simulate(plant, ctrl, ref, q0=sa.PAPER_Q0, t_final=0.2, dt=DT, sensor=sensor,
                    disturbances=dists, seed=4)  # fmt: skip
    return pickle.dumps(r)


def test_everything_pickles_and_runs_identically_in_a_worker_process() -> None:
    plant = sa.ModelMismatch(payload=0.3).apply(ARM)
    sensor = sa.Sensor(noise=sa.GaussianNoise(1e-4), velocity=sa.LevantDifferentiator(40.0))
    dists = [sa.SinusoidalTorque(0.5, 2.0), sa.RandomTorque(0.1)]
    ctrls = [builtin(), custom(), sa.NTSMC(ARM, beta=1.0, p=5, q=3, k=5.0)]
    for obj in [ARM, plant, *ctrls, REF, sensor, *dists, sa.SteppedArm(ARM)]:
        copy = pickle.loads(pickle.dumps(obj))
        assert type(copy) is type(obj)
    local = [
        sa.simulate(plant, c, REF, q0=sa.PAPER_Q0, t_final=0.2, dt=DT, sensor=sensor,
                    disturbances=dists, seed=4)
        for c in ctrls
    ]  # fmt: skip
    payloads = [pickle.dumps((plant, c, REF, sensor, dists)) for c in ctrls]
    with ProcessPoolExecutor(2) as pool:
        remote = [pickle.loads(b) for b in pool.map(_run_in_worker, payloads)]
    for a, b in zip(local, remote, strict=True):
        np.testing.assert_array_equal(a.q, b.q)
        np.testing.assert_array_equal(a.tau, b.tau)
        assert a.params == b.params
    batch = sa.simulate_batch(ARM, ctrls, REF, q0=sa.PAPER_Q0, t_final=0.05, dt=DT, record="metrics")
    again = pickle.loads(pickle.dumps(batch))
    assert again.metrics().equals(batch.metrics())
