"""The random URDF chains of ``urdf_chains.py`` and their references, checked before use.

``test_serial.py`` compares ``SerialArm`` with Pinocchio and MuJoCo on these chains; that
comparison means something only if the chains are what they claim to be (every feature
present, physical inertias) and the two engines read them the same way. Here, with no
slidingarm code involved:

* Pinocchio's ABA and MuJoCo's ``qacc`` agree on q̈ to 1e-8 of the value's scale (measured:
  ~1e-13), and on ``M`` and the bias to 1e-9 (measured: ~1e-14);
* an independent numpy reading of the URDF (``NumpyChain``: forward kinematics, ``M`` from
  link Jacobians, ``V``) agrees with Pinocchio on every link pose, ``M`` and ``V`` to 1e-12;
* Pinocchio's Coriolis matrix is the Christoffel one (computed here from finite differences
  of ``M``), so it is *the* reference for a ``C`` with ``Ṁ - 2C`` skew;
* the comparisons can fail: a URDF with the inertial frames' rpy dropped, or one joint axis
  flipped, disagrees.

One disagreement had a cause outside the chains: MuJoCo's URDF import turns
``<dynamics damping>`` into joint damping (a passive force) and the shipped Panda has some,
while Pinocchio (and rigid-body dynamics) ignore it; ``mujoco_model`` zeroes damping,
armature, friction loss and springs.

Tolerances are relative to the scale of the reference: ``|a - b| <= tol * max(1, max|b|)``
per state.
"""

from __future__ import annotations

import re

import numpy as np
import pinocchio as pin
import pytest
from urdf_chains import (
    Chain,
    NumpyChain,
    chain_set,
    mujoco_forward,
    mujoco_model,
    pin_aba,
    pin_bias,
    pin_coriolis,
    pin_mass,
    pin_model,
    pin_potential,
    pin_q,
    random_chain,
    random_states,
)

CHAINS = chain_set()
IDS = [c.name for c in CHAINS]

#: States per chain, of which the last FAST have speeds up to ten times larger (±30 rad/s).
STATES = 24
FAST = 6


def _rel_err(ours: np.ndarray, ref: np.ndarray) -> float:
    """Worst over the batch of ``max|a - b| / max(1, max|b|)`` per state."""
    axes = tuple(range(1, ref.ndim))
    err = np.abs(ours - ref).max(axis=axes)
    return float(np.max(err / np.maximum(1.0, np.abs(ref).max(axis=axes))))


def _states(chain: Chain) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = chain.rng(1)
    q, qd = random_states(rng, chain.info.types, STATES, fast=FAST)
    tau = rng.uniform(-50.0, 50.0, q.shape)
    return q, qd, tau


# ---------------------------------------------------------------------- the set itself
def test_chain_set_covers_every_feature() -> None:
    assert len(CHAINS) >= 50
    assert {c.info.n for c in CHAINS} == set(range(1, 10))
    types = [t for c in CHAINS for t in c.info.types]
    for kind in ("revolute", "continuous", "prismatic"):
        assert types.count(kind) >= 30, kind
    assert sum("prismatic" in c.info.types for c in CHAINS) >= 20
    assert sum(c.gravity != 9.81 for c in CHAINS) >= 5
    # Pinocchio's joint models: aligned and unaligned axes of every type
    shortnames = {j.shortname() for c in CHAINS for j in pin_model(c.urdf).joints[1:]}
    for model in (
        "JointModelRevoluteUnaligned",
        "JointModelRevoluteUnboundedUnaligned",
        "JointModelPrismaticUnaligned",
    ):
        assert model in shortnames
    assert shortnames & {"JointModelRX", "JointModelRY", "JointModelRZ"}
    assert shortnames & {"JointModelRUBX", "JointModelRUBY", "JointModelRUBZ"}
    assert shortnames & {"JointModelPX", "JointModelPY", "JointModelPZ"}
    # massive links behind fixed joints, inside the chain (not only at the root)
    assert sum(re.search(r'<joint name="fixed\d+_joint"', c.urdf) is not None for c in CHAINS) >= 20
    # massive side links on fixed joints (trees without a moving branch)
    assert sum('<joint name="side' in c.urdf for c in CHAINS) >= 20
    assert all('<link name="tool"/>' in c.urdf for c in CHAINS)


def test_inertias_are_physical() -> None:
    """Every massive link: mass 0.1-10 kg, inertia symmetric positive definite whose principal
    moments satisfy the triangle inequalities with a margin (MuJoCo checks them too)."""
    count = 0
    for chain in CHAINS:
        ref = NumpyChain(chain.urdf)
        for name, (mass, com, _) in ref.inertial.items():
            inertia = ref.written[name]
            assert 0.1 <= mass <= 10.0, name
            assert np.linalg.norm(com) <= 0.5 + 1e-12
            a, b, c = np.linalg.eigvalsh(inertia)
            assert a > 0
            assert a + b - c >= 2 * mass * 0.02**2 * (1 - 1e-9)  # = 2 s_min
            assert np.count_nonzero(inertia - np.diag(np.diag(inertia))) == 6  # products
            count += 1
    assert count >= 300


def test_random_chain_rejects_bad_joint_counts() -> None:
    rng = np.random.default_rng(0)
    for n in (0, 10):
        with pytest.raises(ValueError, match="n_joints"):
            random_chain(rng, n)


@pytest.mark.parametrize("chain", CHAINS, ids=IDS)
def test_joint_order_and_coordinates(chain: Chain) -> None:
    """Both engines see the moving joints in chain order, one velocity each; Pinocchio has
    (cos, sin) for each continuous joint, MuJoCo one hinge angle."""
    model = pin_model(chain.urdf, chain.gravity)
    mj = mujoco_model(chain.urdf, chain.gravity)
    n = chain.info.n
    assert tuple(model.names[1:]) == chain.info.names
    assert tuple(mj.joint(i).name for i in range(mj.njnt)) == chain.info.names
    assert model.nv == mj.nv == mj.nq == n
    assert model.nq == n + chain.info.types.count("continuous")
    q = np.linspace(-3.0, 3.0, n)
    pq = pin_q(model, q)
    assert pq.shape == (model.nq,)
    for i, joint in enumerate(model.joints[1:]):
        cell = pq[joint.idx_q : joint.idx_q + joint.nq]
        expected = [np.cos(q[i]), np.sin(q[i])] if chain.info.types[i] == "continuous" else [q[i]]
        np.testing.assert_array_equal(cell, expected)


# ---------------------------------------------------------------------- Pinocchio vs MuJoCo
@pytest.mark.parametrize("chain", CHAINS, ids=IDS)
def test_pinocchio_and_mujoco_agree(chain: Chain) -> None:
    q, qd, tau = _states(chain)
    model = pin_model(chain.urdf, chain.gravity)
    ref = mujoco_forward(mujoco_model(chain.urdf, chain.gravity), q, qd, tau)
    qdd = pin_aba(model, q, qd, tau)
    assert _rel_err(qdd, ref["qdd"]) <= 1e-8
    assert _rel_err(pin_mass(model, q), ref["M"]) <= 1e-9
    assert _rel_err(pin_bias(model, q, qd), ref["h"]) <= 1e-9
    # the premise of tolerances relative to q̈'s own scale: M is well conditioned (< 1e5;
    # measured < 1e4), so solving for q̈ loses at most ~1e-11 to rounding
    assert float(np.linalg.cond(ref["M"]).max()) < 1e5


def test_disagreement_is_detected() -> None:
    """The comparison is sensitive to what it is meant to check: MuJoCo reading the chain with
    the inertial frames' rotations dropped, or one joint axis flipped, disagrees."""
    chain = next(c for c in CHAINS if c.info.n >= 4 and "prismatic" in c.info.types)
    q, qd, tau = _states(chain)
    qdd = pin_aba(pin_model(chain.urdf, chain.gravity), q, qd, tau)
    no_rpy = re.sub(r'(<inertial>\s*<origin xyz="[^"]*" rpy=")[^"]*"', '\\g<1>0 0 0"', chain.urdf)
    flipped = re.sub(
        r'<axis xyz="([^"]*)"',
        lambda m: '<axis xyz="' + " ".join(repr(-float(x)) for x in m.group(1).split()) + '"',
        chain.urdf,
        count=1,
    )
    for text in (no_rpy, flipped):
        assert text != chain.urdf
        ref = mujoco_forward(mujoco_model(text, chain.gravity), q, qd, tau)
        assert _rel_err(qdd, ref["qdd"]) > 1e-3


# ---------------------------------------------------------------------- Pinocchio vs numpy
@pytest.mark.parametrize("chain", CHAINS, ids=IDS)
def test_pinocchio_agrees_with_numpy_reading(chain: Chain) -> None:
    """Link poses, ``M`` and differences of ``V`` from an independent numpy reading."""
    model = pin_model(chain.urdf, chain.gravity)
    data = model.createData()
    ref = NumpyChain(chain.urdf, chain.gravity)
    q, _, _ = _states(chain)
    q = q[:6]
    zero = np.zeros(chain.info.n)
    v0 = ref.mass_and_potential(zero)[1]
    p0 = float(pin_potential(model, zero))
    for x in q:
        mass, potential = ref.mass_and_potential(x)
        assert _rel_err(pin_mass(model, x)[None], mass[None]) <= 1e-12
        dv = float(pin_potential(model, x)) - p0
        assert abs(dv - (potential - v0)) <= 1e-12 * max(1.0, abs(potential - v0), abs(v0))
        pin.framesForwardKinematics(model, data, pin_q(model, x))
        for link, (pos, rot, _) in ref.frames(x).items():
            frame = data.oMf[model.getFrameId(link, pin.BODY)]
            np.testing.assert_allclose(frame.translation, pos, rtol=0, atol=1e-11)
            np.testing.assert_allclose(frame.rotation, rot, rtol=0, atol=1e-13)


@pytest.mark.parametrize("chain", CHAINS[::6], ids=IDS[::6])
def test_pinocchio_coriolis_is_christoffel(chain: Chain) -> None:
    """``C_ij = Σ_k ½(∂_k M_ij + ∂_j M_ik - ∂_i M_jk) q̇_k`` with ``∂M`` by a 4th-order central
    difference (step 1e-3: truncation ~h⁴ ≈ 1e-12, rounding ~eps/h ≈ 1e-13 of M's scale)."""
    model = pin_model(chain.urdf, chain.gravity)
    q, qd, _ = _states(chain)
    n = chain.info.n
    h = 1e-3
    for x, v in zip(q[:4], qd[:4], strict=True):
        dm = np.empty((n, n, n))  # dm[k] = ∂M/∂q_k
        for k, e in enumerate(np.eye(n)):
            m2, m1, p1, p2 = (pin_mass(model, x + s * h * e) for s in (-2, -1, 1, 2))
            dm[k] = (m2 - 8 * m1 + 8 * p1 - p2) / (12 * h)
        christoffel = 0.5 * (
            np.einsum("kij,k->ij", dm, v)
            + np.einsum("jik,k->ij", dm, v)
            - np.einsum("ijk,k->ij", dm, v)
        )
        scale = max(1.0, float(np.abs(dm).max()) * float(np.abs(v).sum()))
        err = float(np.abs(pin_coriolis(model, x, v) - christoffel).max())
        assert err <= 1e-9 * scale
