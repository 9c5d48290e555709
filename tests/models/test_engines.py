"""The closed-form planar arm agrees with Pinocchio and MuJoCo (issue 2, point 4).

Every comparison runs on at least 1000 random states drawn from a seeded ``numpy`` Generator:
the paper's arm under both mass models, and random arms with ``n = 1..5`` joints (random
masses, lengths, centres of mass on the link and inertias). ``M``, the bias ``h``, the forward
dynamics ``q̈`` under a random torque and the inverse dynamics under a random ``q̈`` must agree
to ``ATOL = 1e-9`` absolute; the state ranges keep those values of order 1-1000.

Pinocchio reads :meth:`PlanarArm.to_urdf`, MuJoCo reads :meth:`PlanarArm.to_mjcf`. MuJoCo
rejects zero principal inertias, so the MJCF writes ``max(I_i, MUJOCO_MIN_INERTIA)``: the model
MuJoCo simulates is the arm with those inertias, and that is the arm its dynamics are compared
with. A separate test bounds what the substitution changes in ``M``.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np
import pinocchio as pin
import pytest

from slidingarm import PlanarArm
from slidingarm.models.planar import MUJOCO_MIN_INERTIA

#: Absolute agreement required of M, h, q̈ and τ (their values are of order 1-1000).
ATOL = 1e-9

#: Random states per paper arm, and per joint count for the random arms.
STATES = 1000
#: Random arms per joint count; each gets ``2 * STATES // ARMS_PER_N`` states.
ARMS_PER_N = 8


@dataclass(frozen=True)
class Case:
    """An arm and a batch of random states, torques and accelerations to compare on."""

    arm: PlanarArm
    q: np.ndarray
    qd: np.ndarray
    tau: np.ndarray
    qdd: np.ndarray


def _states(rng: np.random.Generator, n: int, size: int) -> tuple[np.ndarray, ...]:
    q = rng.uniform(-np.pi, np.pi, (size, n))
    qd = rng.uniform(-3.0, 3.0, (size, n))
    tau = rng.uniform(-20.0, 20.0, (size, n))
    qdd = rng.uniform(-10.0, 10.0, (size, n))
    return q, qd, tau, qdd


def _random_arm(rng: np.random.Generator, n: int, kind: str) -> PlanarArm:
    """A random arm; ``kind`` "point"/"rod" uses the mass model, "explicit" random c and I."""
    m = rng.uniform(0.5, 2.0, n)
    ln = rng.uniform(0.3, 1.2, n)
    g = rng.uniform(0.0, 12.0)
    if kind in ("point", "rod"):
        return PlanarArm(m, ln, mass_model=kind, gravity=g)
    com = rng.uniform(0.2, 1.0, n) * ln
    inertia = rng.uniform(0.0, 1.0 / 6.0, n) * m * ln**2
    return PlanarArm(m, ln, com=com, inertia=inertia, gravity=g)


def _cases() -> list[tuple[str, list[Case]]]:
    cases: list[tuple[str, list[Case]]] = []
    for seed, model in enumerate(("point", "rod")):
        rng = np.random.default_rng(20_240 + seed)
        arm = PlanarArm.paper(model)
        cases.append((f"paper-{model}", [Case(arm, *_states(rng, 3, STATES))]))
    for n in range(1, 6):
        rng = np.random.default_rng(31_000 + n)
        kinds = ["point", "rod"] + ["explicit"] * (ARMS_PER_N - 2)
        per_arm = 2 * STATES // ARMS_PER_N
        group = [Case(_random_arm(rng, n, k), *_states(rng, n, per_arm)) for k in kinds]
        cases.append((f"random-n{n}", group))
    return cases


CASES = _cases()
IDS = [name for name, _ in CASES]
GROUPS = [group for _, group in CASES]


def test_cases_cover_enough_states() -> None:
    for name, group in CASES:
        assert sum(c.q.shape[0] for c in group) >= 1000, name
    assert {c.arm.n for _, group in CASES for c in group} == {1, 2, 3, 4, 5}


# ---------------------------------------------------------------------- engines
def _pinocchio(arm: PlanarArm) -> tuple[pin.Model, pin.Data]:
    model = pin.buildModelFromXML(arm.to_urdf())
    model.gravity.linear = np.array([0.0, 0.0, -arm.gravity])  # URDF: -z of the root
    assert model.nq == model.nv == arm.n
    return model, model.createData()


def _pin_dynamics(case: Case) -> dict[str, np.ndarray]:
    model, data = _pinocchio(case.arm)
    size, n = case.q.shape
    out = {k: np.empty((size, n)) for k in ("h", "qdd", "tau", "g")}
    out["M"] = np.empty((size, n, n))
    out["C"] = np.empty((size, n, n))
    zero = np.zeros(n)
    for b in range(size):
        q, qd = case.q[b], case.qd[b]
        upper = np.triu(pin.crba(model, data, q))  # only the upper triangle is filled
        out["M"][b] = upper + np.triu(upper, 1).T
        out["h"][b] = pin.rnea(model, data, q, qd, zero)
        out["qdd"][b] = pin.aba(model, data, q, qd, case.tau[b])
        out["tau"][b] = pin.rnea(model, data, q, qd, case.qdd[b])
        out["C"][b] = pin.computeCoriolisMatrix(model, data, q, qd)
        out["g"][b] = pin.computeGeneralizedGravity(model, data, q)
    return out


def _mujoco_arm(arm: PlanarArm) -> PlanarArm:
    """The arm MuJoCo simulates: zero inertias raised to ``MUJOCO_MIN_INERTIA``."""
    return PlanarArm(
        arm.masses,
        arm.lengths,
        com=arm.com,
        inertia=np.maximum(arm.inertia, MUJOCO_MIN_INERTIA),
        gravity=arm.gravity,
    )


def _mujoco_dynamics(case: Case) -> dict[str, np.ndarray]:
    model = mujoco.MjModel.from_xml_string(case.arm.to_mjcf())
    data = mujoco.MjData(model)
    size, n = case.q.shape
    assert model.nq == model.nv == n
    out = {k: np.empty((size, n)) for k in ("h", "qdd")}
    out["M"] = np.empty((size, n, n))
    for b in range(size):
        data.qpos[:] = case.q[b]
        data.qvel[:] = case.qd[b]
        data.qfrc_applied[:] = case.tau[b]
        mujoco.mj_forward(model, data)
        mujoco.mj_fullM(model, data, out["M"][b])
        out["h"][b] = data.qfrc_bias
        out["qdd"][b] = data.qacc
    return out


def _worst(ours: list[np.ndarray], theirs: list[np.ndarray]) -> float:
    return max(float(np.max(np.abs(a - b))) for a, b in zip(ours, theirs, strict=True))


def _scale(values: list[np.ndarray]) -> float:
    return max(float(np.max(np.abs(v))) for v in values)


# ---------------------------------------------------------------------- Pinocchio
@pytest.mark.parametrize("group", GROUPS, ids=IDS)
def test_agrees_with_pinocchio(group: list[Case]) -> None:
    ref = [_pin_dynamics(c) for c in group]
    mass = [c.arm.mass_matrix(c.q) for c in group]
    bias = [c.arm.bias(c.q, c.qd) for c in group]
    qdd = [c.arm.forward_dynamics(c.q, c.qd, c.tau) for c in group]
    tau = [c.arm.inverse_dynamics(c.q, c.qd, c.qdd) for c in group]
    cor = [c.arm.coriolis(c.q, c.qd) for c in group]
    grav = [c.arm.gravity_torque(c.q) for c in group]
    # the premise of an absolute tolerance: values of order 1-1000
    assert _scale(qdd) < 1e4 and _scale(bias) < 1e4
    for key, ours in (
        ("M", mass),
        ("h", bias),
        ("qdd", qdd),
        ("tau", tau),
        ("C", cor),
        ("g", grav),
    ):
        err = _worst(ours, [r[key] for r in ref])
        assert err <= ATOL, f"{key}: worst |ours - pinocchio| = {err:.3e}"


# ---------------------------------------------------------------------- MuJoCo
@pytest.mark.parametrize("group", GROUPS, ids=IDS)
def test_agrees_with_mujoco(group: list[Case]) -> None:
    ref = [_mujoco_dynamics(c) for c in group]
    arms = [_mujoco_arm(c.arm) for c in group]
    mass = [a.mass_matrix(c.q) for a, c in zip(arms, group, strict=True)]
    bias = [a.bias(c.q, c.qd) for a, c in zip(arms, group, strict=True)]
    qdd = [a.forward_dynamics(c.q, c.qd, c.tau) for a, c in zip(arms, group, strict=True)]
    assert _scale(qdd) < 1e4 and _scale(bias) < 1e4
    for key, ours in (("M", mass), ("h", bias), ("qdd", qdd)):
        err = _worst(ours, [r[key] for r in ref])
        assert err <= ATOL, f"{key}: worst |ours - mujoco| = {err:.3e}"


@pytest.mark.parametrize("group", GROUPS, ids=IDS)
def test_mujoco_min_inertia_changes_mass_matrix_negligibly(group: list[Case]) -> None:
    """The documented claim: writing zero inertias as 1e-12 changes M by < 1e-11."""
    for case in group:
        ref = _mujoco_dynamics(case)
        err = float(np.max(np.abs(case.arm.mass_matrix(case.q) - ref["M"])))
        assert err <= case.arm.n * MUJOCO_MIN_INERTIA + 1e-13 < 1e-11


def test_exports_are_valid_for_both_engines() -> None:
    arm = PlanarArm((1.0, 2.0), (0.5, 0.7), mass_model="rod", gravity=3.0)
    model, _ = _pinocchio(arm)
    assert model.nq == 2
    mj = mujoco.MjModel.from_xml_string(arm.to_mjcf(timestep=1e-3))
    assert mj.nq == 2
    assert mj.opt.timestep == pytest.approx(1e-3)
    np.testing.assert_allclose(mj.opt.gravity, [0.0, -3.0, 0.0])
    np.testing.assert_allclose(mj.body_mass[1:], arm.masses)
