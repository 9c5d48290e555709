"""The loop's kinematics reuse (``slidingarm._engine.REUSE_KINEMATICS``): the plant's first
RK4 stage takes the sines and cosines the law left in the workspace. These tests check that
the reuse is taken on the shipped UR5 with an exact nominal model, refused when the nominal
model's geometry differs, and that it changes no result."""

from __future__ import annotations

import numpy as np
import pytest
from numba import njit

import slidingarm as sa
from slidingarm import robots
from slidingarm.models import _dispatch as MD

UR5 = robots.load("ur5")
PAPER = sa.PlanarArm.paper()


@njit(cache=False)
def _law_then_rk4(kind, p, g, q, qd, qdd, tau, h, known):  # type: ignore[no-untyped-def]  # pragma: no cover
    """The law's inverse dynamics at ``q`` into a fresh workspace, then one RK4 step of
    ``(q, qd)`` in place, told (``known``) or not that the workspace holds ``q``'s kinematics."""
    n = q.shape[0]
    work = np.full((MD.WORK_ROWS, n), np.nan)
    scratch = np.full((MD.RK4_ROWS, n), np.nan)
    out = np.empty(n)
    MD.inverse_dynamics(kind, p, g, q, qd, qdd, out, work)
    return MD.rk4_step(kind, p, g, q, qd, tau, h, known, scratch, work)


def test_the_ur5_with_its_exact_nominal_model_takes_the_reuse() -> None:
    """``run_one`` reuses when plant and nominal model have the same kinematics rows: the
    UR5 and the copy of it a controller holds do; a payload (mass rows only) keeps them equal;
    a moved joint origin does not."""
    ctrl = sa.FTSMC(UR5, alpha=2.0, beta=2.0, p=5, q=3, k=20.0, switching="tanh", width=0.05)
    plant = np.array(UR5.handle.params)
    nominal = np.array(ctrl.model.handle.params)
    assert UR5.handle.kind == ctrl.model.handle.kind == MD.KIND_SERIAL
    assert MD.same_kinematics(MD.KIND_SERIAL, plant, nominal)
    heavier = np.array(UR5.with_payload(1.0).handle.params)
    assert not np.array_equal(heavier, plant)
    assert MD.same_kinematics(MD.KIND_SERIAL, plant, heavier)
    moved = plant.copy()
    moved[9, 2] += 1e-3  # joint 2's origin in its parent
    assert not MD.same_kinematics(MD.KIND_SERIAL, plant, moved)


@pytest.mark.parametrize("arm", [PAPER, UR5], ids=["paper", "ur5"])
def test_rk4_on_the_laws_kinematics_equals_rk4_recomputing_them(arm: sa.ArmModel) -> None:
    """The workspace contract the reuse rests on, bit for bit: after the law's inverse
    dynamics at ``q``, the step told that the workspace holds ``q``'s kinematics gives the
    very same ``(q, qd)`` as the step that computes them itself."""
    hd = arm.handle
    p = np.array(hd.params)
    rng = np.random.default_rng(9)
    for _ in range(20):
        q0 = rng.uniform(-np.pi, np.pi, arm.n)
        qd0 = rng.normal(size=arm.n)
        qdd = rng.normal(size=arm.n)
        tau = rng.normal(size=arm.n) * 5.0
        q_a, qd_a = q0.copy(), qd0.copy()
        q_b, qd_b = q0.copy(), qd0.copy()
        assert _law_then_rk4(hd.kind, p, hd.g, q_a, qd_a, qdd, tau, 1e-3, True)
        assert _law_then_rk4(hd.kind, p, hd.g, q_b, qd_b, qdd, tau, 1e-3, False)
        assert np.all(np.isfinite(q_a)) and not np.array_equal(q_a, q0)
        np.testing.assert_array_equal(q_a, q_b)
        np.testing.assert_array_equal(qd_a, qd_b)


def test_the_ur5_closed_loop_with_reuse_equals_the_python_stepped_loop() -> None:
    """End to end on the UR5 (exact measurement, so the compiled loop reuses): the same run
    as the Python-stepped plant, whose every RK4 step computes its own kinematics."""
    ctrl = sa.FTSMC(UR5, alpha=2.0, beta=2.0, p=5, q=3, k=20.0, switching="tanh", width=0.05)
    q0 = np.zeros(UR5.n)
    ref = sa.QuinticReference(q0, np.full(UR5.n, 0.5), duration=0.5)
    compiled = sa.simulate(UR5, ctrl, ref, q0=q0, t_final=0.5, dt=1e-3)
    stepped = sa.simulate(sa.SteppedArm(UR5), ctrl, ref, q0=q0, t_final=0.5, dt=1e-3)
    assert compiled.success and stepped.success
    assert np.max(np.abs(compiled.q[-1] - q0)) > 0.1  # the arm moved
    np.testing.assert_array_equal(compiled.q, stepped.q)
    np.testing.assert_array_equal(compiled.tau, stepped.tau)
