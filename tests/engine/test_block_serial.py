"""The block path for serial arms (issue 12, point 1: both arm kinds).

Its dynamics per lane (``slidingarm._block``: kinematics, Newton-Euler, composite rigid body,
a Cholesky solve) against the scalar serial kernels (articulated-body forward dynamics and
Newton-Euler) on the UR5 and on a random chain with prismatic joints, state by state; and whole
UR5 batches on the block path against the per-run loop. The block's serial kernels compute
``M^{-1}(tau - h)`` where the scalar path runs the articulated-body algorithm, and the scalar
kernels fuse multiply-adds: a serial run agrees to rounding, not bit for bit (the planar kind's
block runs are bit-identical, tests/engine/test_block.py).
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from numba import njit

import slidingarm as sa
from slidingarm import _block as BK
from slidingarm import _engine as E
from slidingarm.models import _spatial as SK

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "models"))
from urdf_chains import random_chain

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from _arms import massless_tip_ur5

UR5 = sa.robots.load("ur5")


@njit(cache=False)
def _lane_dynamics(ws, joints, table, g, q, qd, tau, acc):  # type: ignore[no-untyped-def]  # pragma: no cover
    """The block's serial forward dynamics at ``(q, qd, tau)`` and the model law's torque (the
    RNEA at ``(q, qd, acc)``) for the ``W`` lanes (arrays ``(n, W)``), one table for all."""
    n = len(joints)
    tables = np.empty((table.shape[0], n, BK.W))
    for r in range(table.shape[0]):
        for j in range(n):
            for ln in range(BK.W):
                tables[r, j, ln] = table[r, j]
    BK._load_serial(ws, n, tables, tables)
    for ln in range(BK.W):
        ws[BK._L_G + ln] = g
        ws[BK._L_MG + ln] = g
        ws[BK._L_OK + ln] = 1.0
    for j in range(n):
        o = BK.J0 + j * BK.JS
        for ln in range(BK.W):
            ws[o + BK._QT + ln] = q[j, ln]
            ws[o + BK._VT + ln] = qd[j, ln]
            ws[o + BK._TAPP + ln] = tau[j, ln]
            ws[o + BK._QM + ln] = q[j, ln]
            ws[o + BK._QDM + ln] = qd[j, ln]
            ws[o + BK._ACC + ln] = acc[j, ln]
    BK._serial_kinematics(ws, n, BK._QT, BK._SP)  # the stage's angles, as RK4 leaves them
    BK._serial_forward(ws, joints)
    BK._serial_torque(ws, n)
    qdd = np.empty((n, BK.W))
    out = np.empty((n, BK.W))
    for j in range(n):
        o = BK.J0 + j * BK.JS
        for ln in range(BK.W):
            qdd[j, ln] = ws[o + BK._KX + ln]
            out[j, ln] = ws[o + BK._TAU + ln]
    ok = np.empty(BK.W)
    for ln in range(BK.W):
        ok[ln] = ws[BK._L_OK + ln]
    return qdd, out, ok


def _prismatic_chain() -> sa.SerialArm:
    # revolute, prismatic, prismatic: a prismatic joint on a moving parent, and a chain of them
    urdf = random_chain(np.random.default_rng(70_003), 3, prismatic=True, name="rpp")
    arm = sa.SerialArm.from_urdf(urdf)
    assert 1.0 in arm.handle.params[SK.P_TYPE], "the chain has a prismatic joint"
    assert 0.0 in arm.handle.params[SK.P_TYPE], "and a revolute one"
    return arm


@pytest.mark.parametrize(
    "arm",
    [
        # each joint count compiles the lanes' kernel (the UR5's for about 35 s): the default
        # run checks the 3-joint chain, which has both joint types
        pytest.param(UR5, id="ur5", marks=pytest.mark.slow),
        pytest.param(_prismatic_chain(), id="chain-RPP"),
    ],
)
def test_the_lanes_dynamics_equal_the_scalar_kernels(arm: sa.SerialArm) -> None:
    """Per lane, q̈ equals the articulated-body algorithm's and the law's torque the
    Newton-Euler algorithm's to 1e-12 (relative to max(1, |x|)), over 5 x W random states."""
    n, p, g = arm.n, np.ascontiguousarray(arm.handle.params), arm.handle.g
    rng = np.random.default_rng(12)
    ws = np.zeros(BK.workspace_size(n))
    work = np.zeros((SK.WORK_ROWS, n))
    worst_qdd = worst_tau = 0.0
    for _ in range(5):
        q = rng.uniform(-np.pi, np.pi, (n, BK.W))
        qd = rng.normal(0.0, 2.0, (n, BK.W))
        tau = rng.normal(0.0, 20.0, (n, BK.W))
        acc = rng.normal(0.0, 5.0, (n, BK.W))
        qdd, out, ok = _lane_dynamics(ws, (0,) * n, p, g, q, qd, tau, acc)
        assert np.all(ok == 1.0)
        for ln in range(BK.W):
            want_qdd = np.empty(n)
            want_tau = np.empty(n)
            assert SK.forward_dynamics_into(p, g, q[:, ln].copy(), qd[:, ln].copy(),
                                            tau[:, ln].copy(), want_qdd, work)  # fmt: skip
            SK.inverse_dynamics_into(p, g, q[:, ln].copy(), qd[:, ln].copy(),
                                     acc[:, ln].copy(), want_tau, work)  # fmt: skip
            worst_qdd = max(worst_qdd, float(np.max(np.abs(qdd[:, ln] - want_qdd)
                                                    / np.maximum(1.0, np.abs(want_qdd)))))  # fmt: skip
            worst_tau = max(worst_tau, float(np.max(np.abs(out[:, ln] - want_tau)
                                                    / np.maximum(1.0, np.abs(want_tau)))))  # fmt: skip
    assert worst_qdd <= 1e-12
    assert worst_tau <= 1e-12


def test_a_singular_mass_matrix_clears_the_lane_only() -> None:
    """A lane whose state is not finite has no positive pivot: it, and only it, is flagged
    (its acceleration not finite either)."""
    arm = _prismatic_chain()
    n, p, g = arm.n, np.ascontiguousarray(arm.handle.params), arm.handle.g
    q = np.zeros((n, BK.W))
    q[2, 3] = np.nan
    z = np.zeros((n, BK.W))
    qdd, _out, ok = _lane_dynamics(np.zeros(BK.workspace_size(n)), (0,) * n, p, g, q, z, z, z)
    assert ok.tolist() == [0.0 if ln == 3 else 1.0 for ln in range(BK.W)]
    assert np.all(np.isfinite(np.delete(qdd, 3, axis=1))) and not np.all(np.isfinite(qdd[:, 3]))


def test_a_massless_tip_is_flagged_singular_with_a_finite_acceleration() -> None:
    """A body with no mass nor inertia at the tip makes ``M`` singular at any (finite) state:
    every lane is flagged and its acceleration stays finite, so that the run is reported
    singular, not non-finite, as the per-run loop's articulated-body pass reports it."""
    arm = _prismatic_chain()
    n, g = arm.n, arm.handle.g
    p = np.array(arm.handle.params)
    p[SK.P_MASS : SK.P_IO + 6, n - 1] = 0.0
    rng = np.random.default_rng(3)
    q = rng.uniform(-1.0, 1.0, (n, BK.W))
    z = np.zeros((n, BK.W))
    qdd, _out, ok = _lane_dynamics(np.zeros(BK.workspace_size(n)), (0,) * n, p, g, q, z, z, z)
    assert np.all(ok == 0.0)
    assert np.all(np.isfinite(qdd))


# ------------------------------------------------------------------------ whole batches (slow)


def _ur5_batch(path: str, switching: str, *, noise: bool = True, ulp: bool = False,
               **kw: Any) -> sa.BatchResult:  # fmt: skip
    """The shipped UR5 scenario's FTSMC (tanh) or the same gains with sign switching, ``nb``
    perturbed starts (``ulp``: joint 3's one ulp higher), with or without sensor noise and a
    dirty derivative, on ``path``."""
    from slidingarm.study import load_shipped

    st = load_shipped("ur5").build()
    ctrl = st.controllers["ftsmc"]
    if switching == "sign":
        ctrl = sa.FTSMC(
            st.nominal, alpha=2.0, beta=2.0, p=5, q=3, k=[10.0, 10.0, 20.0, 20.0, 10.0, 10.0]
        )
    nb = kw.pop("nb", BK.W + 4)  # a full block and a padded one
    q0 = np.asarray(st.q0) + np.random.default_rng(5).normal(0.0, 0.02, (nb, UR5.n))
    if ulp:
        q0[:, 2] = np.nextafter(q0[:, 2], np.inf)
    order = kw.pop("order", np.arange(nb))
    sensor = sa.Sensor(noise=sa.GaussianNoise(sigma=1e-4),
                       velocity=sa.sensors.DirtyDerivative(time_constant=0.005))  # fmt: skip
    return sa.simulate_batch(
        st.plant, ctrl, st.reference, q0=q0[order], t_final=kw.pop("t_final", 1.0), dt=st.dt,
        torque_limit=st.torque_limit, sensor=sensor if noise else None, seeds=[int(b) for b in order],
        block=path == "block", **kw,
    )  # fmt: skip


@pytest.mark.slow  # the UR5's block kernel (6 joints, serial) compiles for about 20 s
def test_ur5_runs_on_the_block_path_agree_with_the_per_run_loop() -> None:
    """``W + 4`` UR5 runs (a full block and a padded one) under the shipped FTSMC (tanh switching, a
    Lipschitz loop) with the effort limits, 1 s: every trace of every run within 1e-9 (rad,
    rad/s, N m) of the per-run loop's (measured: 2e-16 rad, 1.2e-10 N m), in full and in
    metrics mode (1e-9 relative)."""
    block = _ur5_batch("block", "tanh", noise=False)
    scalar = _ur5_batch("scalar", "tanh", noise=False)
    assert np.all(block.ok) and np.all(scalar.ok)
    for name in ("q", "qd", "q_meas", "qd_meas", "tau", "s"):
        np.testing.assert_allclose(getattr(block, name), getattr(scalar, name), rtol=0, atol=1e-9,
                                   err_msg=name)  # fmt: skip
    a = _ur5_batch("block", "tanh", noise=False, record="metrics").metrics()
    b = _ur5_batch("scalar", "tanh", noise=False, record="metrics").metrics()
    assert list(a.columns) == list(b.columns) and len(a) == (BK.W + 4) * (UR5.n + 1)  # runs x (joints and mean)
    assert a[["run", "joint"]].equals(b[["run", "joint"]])
    values = [c for c in a.columns if c not in ("run", "joint")]
    np.testing.assert_allclose(a[values].to_numpy(float), b[values].to_numpy(float), rtol=1e-9,
                               atol=1e-12)  # fmt: skip


@pytest.mark.slow  # the same kernel as above
def test_a_chattering_ur5_loop_differs_only_as_round_off_moves_it() -> None:
    """Sign switching and sensor noise: the per-run loop's own trajectories move by more than
    1e-6 rad when one coordinate of each start moves by one ulp (the loop amplifies round-off:
    measured 3.1e-4 rad), and the block path's differ from the per-run loop's by no more than
    ten times that (measured 3.4e-4 rad, the size of the round-off difference between the
    articulated-body and the composite-rigid-body accelerations after that amplification);
    what the loop is judged by does not move: each run's MSE within 1e-4 (measured 7e-6)."""
    block = _ur5_batch("block", "sign", record="full")
    scalar = _ur5_batch("scalar", "sign")
    moved = _ur5_batch("scalar", "sign", ulp=True)
    assert np.all(block.ok) and np.all(scalar.ok)
    itself = float(np.max(np.abs(moved.q - scalar.q)))
    assert itself > 1e-6
    assert float(np.max(np.abs(block.q - scalar.q))) <= 10.0 * itself
    np.testing.assert_allclose(block.metrics()["mse"], scalar.metrics()["mse"], rtol=1e-4)


@pytest.mark.slow  # the same kernel as above
def test_ur5_block_status_and_threads() -> None:
    """A run that runs away (a huge initial speed) is named with the same code, sample and
    joint on both paths and the others finish; the block path gives the same bits on 1 and
    2 threads and whichever lane and block a run lands in (the batch reversed)."""
    nb = BK.W + 4  # two blocks: one per thread on two
    one = _ur5_batch("block", "tanh", nb=nb, threads=1)
    two = _ur5_batch("block", "tanh", nb=nb, threads=2)
    back = _ur5_batch("block", "tanh", nb=nb, order=np.arange(nb)[::-1])
    np.testing.assert_array_equal(one.q, two.q)
    np.testing.assert_array_equal(one.tau, two.tau)
    np.testing.assert_array_equal(one.q, back.q[::-1])
    np.testing.assert_array_equal(one.s, back.s[::-1])
    kw = dict(qd0=np.where(np.arange(nb)[:, None] == 4, 1e4, 0.0) * np.ones((nb, UR5.n)))
    fast_b = _ur5_batch("block", "tanh", nb=nb, throw=False, **kw)
    fast_s = _ur5_batch("scalar", "tanh", nb=nb, throw=False, **kw)
    for name in ("status_code", "fail_time", "fail_joint"):
        np.testing.assert_array_equal(getattr(fast_b, name), getattr(fast_s, name), err_msg=name)
    assert fast_b.status_code[4] == E.STATUS_RUNAWAY
    assert np.all(np.delete(fast_b.ok, 4))


def test_the_papers_law_has_no_serial_block_kernel() -> None:
    with pytest.raises(ValueError, match="the paper's law has no serial-arm block kernel"):
        BK.compiled(paper=True, n=6, serial=True)


@pytest.mark.slow  # the same kernel as the UR5 tests above
def test_a_massless_tip_is_reported_singular_on_both_paths() -> None:
    """The UR5 with its last link massless (a URDF the loader accepts): both paths stop every
    run at the first step with the same status (singular, sample 1, joint 0)."""
    arm = massless_tip_ur5()
    ctrl = sa.FTSMC(arm, alpha=2.0, beta=2.0, p=5, q=3, k=20.0, switching="tanh", width=0.05)
    ref = sa.QuinticReference(np.zeros(6), np.full(6, 0.5), duration=1.0)
    q0 = np.random.default_rng(2).normal(0.0, 0.1, (10, 6))
    kw: dict[str, Any] = dict(q0=q0, t_final=0.05, dt=1e-3, throw=False)
    runs = {
        path: sa.simulate_batch(arm, ctrl, ref, block=path == "block", **kw)
        for path in ("block", "scalar")
    }
    for name in ("status_code", "fail_time", "fail_joint"):
        np.testing.assert_array_equal(
            getattr(runs["block"], name), getattr(runs["scalar"], name), err_msg=name
        )
    assert np.all(runs["block"].status_code == E.STATUS_SINGULAR)
