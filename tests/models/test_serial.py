"""``SerialArm`` (URDF serial chains) against Pinocchio, MuJoCo, theory and the planar arm.

The chains are the fixed random set of ``urdf_chains.chain_set`` (60 chains of 1-9 moving
joints: revolute, continuous and prismatic about arbitrary axes, random joint and inertial
frames, full inertia tensors, massive links behind fixed joints, a massless ``tool`` link),
validated on their own in ``test_urdf_chains.py`` (Pinocchio and MuJoCo agree on them to
~1e-13). Each chain is checked on ``STATES`` random states, the last ``FAST`` of them at ten
times the speed (up to 30 rad/s or m/s per joint).

Also: the vendored Panda and UR5, URDF defaults (omitted origins and axes), the planar arm
through its URDF, energy conservation under RK4, the refusals, pickling.

Tolerances are relative to the reference value's scale, per state:
``max|ours - ref| <= tol * max(1, max|ref|)``, with ``tol = 1e-9`` against Pinocchio and
``1e-8`` against MuJoCo (both engines agree with each other to ~1e-13 on these chains, and
``M`` is well conditioned: cond(M) < 1e5, checked there; measured < 1e4).
"""

from __future__ import annotations

import functools
import pickle
import re
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from urdf_chains import (
    Chain,
    NumpyChain,
    chain_info,
    chain_set,
    mujoco_forward,
    mujoco_model,
    pin_aba,
    pin_bias,
    pin_coriolis,
    pin_gravity,
    pin_kinetic,
    pin_mass,
    pin_model,
    pin_potential,
    pin_q,
    pin_rnea,
    random_chain,
    random_states,
)

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from _arms import massless_tip_ur5

serial = pytest.importorskip("slidingarm.models.serial")
SerialArm = serial.SerialArm

from slidingarm import PlanarArm, SteppedArm  # noqa: E402

#: Agreement with Pinocchio, relative to the value's scale.
TOL_PIN = 1e-9
#: Agreement with MuJoCo, relative to the value's scale.
TOL_MUJOCO = 1e-8
#: Agreement with the closed-form planar arm, relative to the value's scale.
TOL_PLANAR = 1e-12

STATES = 40
FAST = 10

CHAINS = chain_set()
IDS = [c.name for c in CHAINS]


def _rel_err(ours: np.ndarray, ref: np.ndarray) -> float:
    """Worst over the batch of ``max|a - b| / max(1, max|b|)`` per state (axis 0)."""
    ours = np.asarray(ours, dtype=float)
    ref = np.asarray(ref, dtype=float)
    assert ours.shape == ref.shape, (ours.shape, ref.shape)
    if ref.ndim == 1:
        return float(np.max(np.abs(ours - ref) / np.maximum(1.0, np.abs(ref))))
    axes = tuple(range(1, ref.ndim))
    err = np.abs(ours - ref).max(axis=axes)
    return float(np.max(err / np.maximum(1.0, np.abs(ref).max(axis=axes))))


# ---------------------------------------------------------------------- cases
@dataclass(frozen=True)
class Case:
    chain: Chain
    arm: object
    model: pin.Model
    q: np.ndarray
    qd: np.ndarray
    tau: np.ndarray
    qdd: np.ndarray


@functools.cache
def _case(index: int) -> Case:
    chain = CHAINS[index]
    rng = chain.rng(2)
    q, qd = random_states(rng, chain.info.types, STATES, fast=FAST)
    tau = rng.uniform(-50.0, 50.0, q.shape)
    qdd = rng.uniform(-20.0, 20.0, q.shape)
    arm = SerialArm.from_urdf(chain.urdf, gravity=chain.gravity)
    return Case(chain, arm, pin_model(chain.urdf, chain.gravity), q, qd, tau, qdd)


@functools.cache
def _pin_ref(index: int) -> dict[str, np.ndarray]:
    c = _case(index)
    return {
        "M": pin_mass(c.model, c.q),
        "h": pin_bias(c.model, c.q, c.qd),
        "qdd": pin_aba(c.model, c.q, c.qd, c.tau),
        "tau": pin_rnea(c.model, c.q, c.qd, c.qdd),
        "C": pin_coriolis(c.model, c.q, c.qd),
        "G": pin_gravity(c.model, c.q),
    }


CASES = list(range(len(CHAINS)))


# ---------------------------------------------------------------------- structure
def test_public_name() -> None:
    import slidingarm

    assert slidingarm.SerialArm is SerialArm
    assert issubclass(SerialArm, slidingarm.ArmModel)


@pytest.mark.parametrize("index", CASES, ids=IDS)
def test_joints_in_chain_order(index: int) -> None:
    c = _case(index)
    arm = c.arm
    assert arm.n == c.chain.info.n == c.model.nv
    assert tuple(arm.joint_names) == c.chain.info.names
    assert isinstance(arm.joint_types, tuple)
    assert arm.joint_types == c.chain.info.types
    assert arm.gravity == c.chain.gravity


def test_default_gravity() -> None:
    arm = SerialArm.from_urdf(CHAINS[3].urdf)
    assert arm.gravity == 9.81
    np.testing.assert_allclose(
        arm.gravity_torque(np.zeros(arm.n)),
        pin_gravity(pin_model(CHAINS[3].urdf), np.zeros(arm.n)),
        rtol=0,
        atol=1e-10,
    )


# ---------------------------------------------------------------------- Pinocchio
@pytest.mark.parametrize("index", CASES, ids=IDS)
def test_mass_bias_gravity_match_pinocchio(index: int) -> None:
    c, ref = _case(index), _pin_ref(index)
    for key, ours in (
        ("M", c.arm.mass_matrix(c.q)),
        ("h", c.arm.bias(c.q, c.qd)),
        ("G", c.arm.gravity_torque(c.q)),
    ):
        err = _rel_err(ours, ref[key])
        assert err <= TOL_PIN, f"{key}: relative error {err:.3e}"


@pytest.mark.parametrize("index", CASES, ids=IDS)
def test_forward_and_inverse_dynamics_match_pinocchio(index: int) -> None:
    c, ref = _case(index), _pin_ref(index)
    err = _rel_err(c.arm.forward_dynamics(c.q, c.qd, c.tau), ref["qdd"])
    assert err <= TOL_PIN, f"q̈ (vs aba): relative error {err:.3e}"
    err = _rel_err(c.arm.inverse_dynamics(c.q, c.qd, c.qdd), ref["tau"])
    assert err <= TOL_PIN, f"τ (vs rnea): relative error {err:.3e}"


@pytest.mark.parametrize("index", CASES, ids=IDS)
def test_coriolis_matches_pinocchio_and_theory(index: int) -> None:
    """``C`` equals Pinocchio's (the Christoffel matrix, see test_urdf_chains), ``C q̇ + G`` is
    the bias, and ``Ṁ = C + Cᵀ`` (i.e. ``Ṁ - 2C`` skew) with ``Ṁ`` a 4th-order central
    difference of our own ``M`` along ``q̇``.

    The difference uses the step ``h = 1e-3 / w`` (``w = Σ|q̇_i|``), so every coordinate moves
    at most 2e-3: truncation ~(1e-3)⁴ and rounding ~1.5 eps / h of ``|M| w``; the bound
    1e-9 ``max(1, |M| w)`` is far above both and far below a wrong ``C`` (errors of order
    ``|M| w``).
    """
    c, ref = _case(index), _pin_ref(index)
    cor = c.arm.coriolis(c.q, c.qd)
    err = _rel_err(cor, ref["C"])
    assert err <= TOL_PIN, f"C: relative error {err:.3e}"
    back = np.einsum("bij,bj->bi", cor, c.qd) + c.arm.gravity_torque(c.q)
    err = _rel_err(back, c.arm.bias(c.q, c.qd))
    assert err <= 1e-10, f"C q̇ + G vs bias: relative error {err:.3e}"
    w = np.abs(c.qd).sum(axis=1, keepdims=True)
    h = 1e-3 / w
    m2, m1, p1, p2 = (c.arm.mass_matrix(c.q + s * h * c.qd) for s in (-2.0, -1.0, 1.0, 2.0))
    mdot = (m2 - 8.0 * m1 + 8.0 * p1 - p2) / (12.0 * h[:, :, None])
    scale = np.maximum(1.0, np.abs(c.arm.mass_matrix(c.q)).max(axis=(1, 2)) * w[:, 0])
    err_sym = np.abs(mdot - cor - np.swapaxes(cor, 1, 2)).max(axis=(1, 2))
    assert np.all(err_sym <= 1e-9 * scale), f"Ṁ - C - Cᵀ: worst {np.max(err_sym / scale):.3e}"


#: URDF's defaults: no <origin> (identity), <origin> without rpy or without xyz, no <axis>
#: (x), an inertial without <origin>, a massive link behind a fixed joint without <origin>.
DEFAULTS_URDF = """<?xml version="1.0"?>
<robot name="defaults">
  <link name="base"/>
  <link name="a"><inertial><mass value="1.3"/>
    <inertia ixx="0.02" ixy="0.001" ixz="0" iyy="0.03" iyz="0" izz="0.04"/></inertial></link>
  <link name="b"><inertial><origin xyz="0.2 0 0.05"/><mass value="0.7"/>
    <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.012" iyz="0" izz="0.011"/></inertial></link>
  <link name="b_plate"><inertial><origin rpy="0.4 0 0"/><mass value="0.3"/>
    <inertia ixx="0.002" ixy="0" ixz="0" iyy="0.003" iyz="0" izz="0.004"/></inertial></link>
  <link name="c"><inertial><origin xyz="0 0.1 0" rpy="0 0 0.3"/><mass value="0.5"/>
    <inertia ixx="0.005" ixy="0" ixz="0" iyy="0.006" iyz="0" izz="0.007"/></inertial></link>
  <link name="tool"/>
  <joint name="j1" type="continuous"><parent link="base"/><child link="a"/></joint>
  <joint name="j2" type="revolute"><parent link="a"/><child link="b"/>
    <origin xyz="0.3 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <joint name="plate" type="fixed"><parent link="b"/><child link="b_plate"/></joint>
  <joint name="j3" type="prismatic"><parent link="b_plate"/><child link="c"/>
    <origin rpy="0.3 0.2 0.1"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <joint name="tip" type="fixed"><parent link="c"/><child link="tool"/>
    <origin xyz="0 0 0.25"/></joint>
</robot>
"""


def test_urdf_defaults() -> None:
    """Omitted origins, rpy, xyz and axes take URDF's defaults, as Pinocchio, MuJoCo and the
    numpy reading take them."""
    arm = SerialArm.from_urdf(DEFAULTS_URDF)
    assert arm.joint_types == ("continuous", "revolute", "prismatic")
    model = pin_model(DEFAULTS_URDF)
    rng = np.random.default_rng(77)
    q, qd = random_states(rng, arm.joint_types, 50, fast=10)
    tau = rng.uniform(-20.0, 20.0, q.shape)
    assert _rel_err(arm.mass_matrix(q), pin_mass(model, q)) <= TOL_PIN
    assert _rel_err(arm.bias(q, qd), pin_bias(model, q, qd)) <= TOL_PIN
    qdd = arm.forward_dynamics(q, qd, tau)
    assert _rel_err(qdd, pin_aba(model, q, qd, tau)) <= TOL_PIN
    mj = mujoco_forward(mujoco_model(DEFAULTS_URDF), q, qd, tau)
    assert _rel_err(qdd, mj["qdd"]) <= TOL_MUJOCO
    ref = NumpyChain(DEFAULTS_URDF)
    for x in q[:5]:
        mass, potential = ref.mass_and_potential(x)
        assert _rel_err(arm.mass_matrix(x)[None], mass[None]) <= 1e-12
        assert abs(arm.potential_energy(x) - potential) <= 1e-12 * max(1.0, abs(potential))
        pos, rot, _ = ref.frames(x)["tool"]
        ours_pos, ours_rot = arm.frame_pose(x)
        np.testing.assert_allclose(ours_pos, pos, rtol=0, atol=1e-13)
        np.testing.assert_allclose(ours_rot, rot, rtol=0, atol=1e-13)


def test_axis_length_does_not_matter() -> None:
    """URDF axes are directions: writing every axis 2.5 times longer changes nothing (as
    Pinocchio and MuJoCo normalise them)."""
    chain = CHAINS[25]
    longer = re.sub(
        r'<axis xyz="([^"]*)"',
        lambda m: '<axis xyz="' + " ".join(repr(2.5 * float(x)) for x in m.group(1).split()) + '"',
        chain.urdf,
    )
    assert longer != chain.urdf
    c = _case(25)
    arm = SerialArm.from_urdf(longer, gravity=chain.gravity)
    assert _rel_err(arm.mass_matrix(c.q), _pin_ref(25)["M"]) <= TOL_PIN
    assert _rel_err(arm.forward_dynamics(c.q, c.qd, c.tau), _pin_ref(25)["qdd"]) <= TOL_PIN


#: Elements a URDF may carry besides links and joints: ROS ``<transmission>`` blocks (each
#: names a joint in a ``<joint>`` element of its own, with no type), ``<gazebo>`` and
#: ``<material>``. They are not part of the kinematic tree.
EXTRAS = """  <material name="grey"><color rgba="0.5 0.5 0.5 1"/></material>
  <transmission name="joint1_trans">
    <type>transmission_interface/SimpleTransmission</type>
    <joint name="joint1"><hardwareInterface>hardware_interface/EffortJointInterface</hardwareInterface></joint>
    <actuator name="joint1_motor"><mechanicalReduction>1</mechanicalReduction></actuator>
  </transmission>
  <gazebo reference="link1"><selfCollide>false</selfCollide></gazebo>
</robot>
"""


def test_transmissions_and_other_elements_are_not_joints() -> None:
    """A URDF with a ``<transmission>`` (as the UR5 of ``slidingarm.robots`` has) is the same
    arm as without it."""
    chain = CHAINS[21]
    text = chain.urdf.replace("</robot>\n", EXTRAS)
    assert text != chain.urdf
    c = _case(21)
    arm = SerialArm.from_urdf(text, gravity=chain.gravity)
    assert arm.joint_names == c.arm.joint_names
    assert arm.joint_types == c.arm.joint_types
    np.testing.assert_array_equal(arm.mass_matrix(c.q), c.arm.mass_matrix(c.q))
    np.testing.assert_array_equal(arm.bias(c.q, c.qd), c.arm.bias(c.q, c.qd))


def _robot_urdf(name: str) -> Path:
    from slidingarm import robots

    return Path(robots.path(name))


@pytest.mark.parametrize("name", ["panda", "ur5"])
def test_shipped_robots_match_pinocchio_and_mujoco(name: str) -> None:
    """The vendored Panda and UR5 (real inertial data, ``<dynamics>`` damping that rigid-body
    dynamics leave out, transmissions) on 1000 random states, 250 of them fast."""
    path = _robot_urdf(name)
    text = path.read_text()
    arm = SerialArm.from_urdf(path)
    info = chain_info(text)
    assert arm.joint_names == info.names and arm.joint_types == info.types
    model = pin_model(text)
    rng = np.random.default_rng(5_150)
    q, qd = random_states(rng, info.types, 1000, fast=250)
    tau = rng.uniform(-50.0, 50.0, q.shape)
    qdd = rng.uniform(-20.0, 20.0, q.shape)
    assert _rel_err(arm.mass_matrix(q), pin_mass(model, q)) <= TOL_PIN
    assert _rel_err(arm.bias(q, qd), pin_bias(model, q, qd)) <= TOL_PIN
    ours = arm.forward_dynamics(q, qd, tau)
    assert _rel_err(ours, pin_aba(model, q, qd, tau)) <= TOL_PIN
    assert _rel_err(arm.inverse_dynamics(q, qd, qdd), pin_rnea(model, q, qd, qdd)) <= TOL_PIN
    mj = mujoco_forward(mujoco_model(text), q, qd, tau)
    assert _rel_err(ours, mj["qdd"]) <= TOL_MUJOCO


# ---------------------------------------------------------------------- aligned frames
def _aligned_arms() -> list[object]:
    from slidingarm import robots

    return [_case(i).arm for i in CASES] + [robots.load("ur5"), robots.load("panda")]


def test_aligned_frames_turn_each_axis_to_z() -> None:
    """The kernels' table (``SK.aligned``): each frame ``Q_i`` is a rotation whose third
    column is the joint's axis; in the aligned table every axis is ``e_z``, mass, ``|h|``
    and the trace of ``I_o`` are unchanged, and aligning it again changes nothing."""
    from slidingarm.models import _spatial as SK

    for arm in _aligned_arms():
        t = arm.table
        al, frames = SK.aligned(t)
        for i in range(arm.n):
            qf = frames[i]
            assert np.max(np.abs(qf.T @ qf - np.eye(3))) <= 1e-15
            assert np.linalg.det(qf) == pytest.approx(1.0, abs=1e-15)
            assert np.max(np.abs(qf[:, 2] - t[SK.P_AXIS : SK.P_AXIS + 3, i])) <= 1e-16
        assert np.all(al[SK.P_AXIS : SK.P_AXIS + 3] == np.array([[0.0], [0.0], [1.0]]))
        assert np.array_equal(al[SK.P_TYPE : SK.P_MASS + 1], t[SK.P_TYPE : SK.P_MASS + 1])
        for rows in (slice(SK.P_H, SK.P_H + 3), slice(9, 12)):
            norms = np.linalg.norm(al[rows], axis=0), np.linalg.norm(t[rows], axis=0)
            assert np.allclose(*norms, rtol=1e-15, atol=0)
        trace = slice(SK.P_IO, SK.P_IO + 3)
        assert np.allclose(al[trace].sum(axis=0), t[trace].sum(axis=0), rtol=1e-14, atol=0)
        again, ident = SK.aligned(al)
        assert np.array_equal(again, al)
        assert np.array_equal(ident, np.broadcast_to(np.eye(3), ident.shape))
        assert np.array_equal(arm.params[: SK.ROWS], al)


@pytest.mark.parametrize("name", ["panda", "ur5"])
def test_shipped_robots_align_by_exact_signed_permutations(name: str) -> None:
    """Their URDF axes lie along coordinate axes, so the frame turns are exact: every entry
    of every ``Q_i`` is 0 or ±1 (nothing is rounded by aligning their frames)."""
    from slidingarm import robots
    from slidingarm.models import _spatial as SK

    _, frames = SK.aligned(robots.load(name).table)
    assert np.all(np.isin(frames, (-1.0, 0.0, 1.0)))
    assert np.all(np.abs(frames).sum(axis=1) == 1.0)


# ---------------------------------------------------------------------- MuJoCo
@pytest.mark.parametrize("index", CASES, ids=IDS)
def test_forward_dynamics_matches_mujoco(index: int) -> None:
    c = _case(index)
    ref = mujoco_forward(mujoco_model(c.chain.urdf, c.chain.gravity), c.q, c.qd, c.tau)
    err = _rel_err(c.arm.forward_dynamics(c.q, c.qd, c.tau), ref["qdd"])
    assert err <= TOL_MUJOCO, f"q̈ (vs MuJoCo qacc): relative error {err:.3e}"
    err = _rel_err(c.arm.mass_matrix(c.q), ref["M"])
    assert err <= TOL_MUJOCO, f"M (vs MuJoCo): relative error {err:.3e}"
    err = _rel_err(c.arm.bias(c.q, c.qd), ref["h"])
    assert err <= TOL_MUJOCO, f"h (vs MuJoCo qfrc_bias): relative error {err:.3e}"


# ---------------------------------------------------------------------- energies
def _lever(ref: NumpyChain, travel: np.ndarray) -> float:
    """``Σ_i m_i R_i`` over the links that move, with ``R_i`` a bound on how far link i's
    centre of mass is from the root: the joint-origin lengths on its path, the travel of the
    prismatic joints on it and its centre-of-mass offset."""
    reach = ref.reach(travel)
    total = 0.0
    for link, (mass, com, _) in ref.inertial.items():
        dist, moves = reach[link]
        if moves:
            total += mass * (dist + float(np.linalg.norm(com)))
    return total


def _potential_scale(chain: Chain) -> float:
    """``g Σ m_i R_i`` for prismatic joints within ±0.5 m (the drawn states): the size of
    ``V``'s changes."""
    ref = NumpyChain(chain.urdf, chain.gravity)
    return chain.gravity * _lever(ref, np.full(chain.info.n, 0.5))


@pytest.mark.parametrize("index", CASES, ids=IDS)
def test_potential_energy(index: int) -> None:
    """``G = ∂V/∂q`` by a 4th-order central difference (step 1e-3: truncation ~1e-12 and
    rounding ~1e-13 of the scale ``V_s`` of V); ``V`` differs between states as Pinocchio's
    ``Σ m g z_com`` does, and equals it where no massive link is welded to the root (where
    the constant of links that never move is a matter of convention)."""
    c = _case(index)
    q = c.q[:8]
    arm = c.arm
    vs = max(1.0, _potential_scale(c.chain))
    h = 1e-3
    grad = np.empty_like(q)
    for i, e in enumerate(np.eye(arm.n)):
        v2, v1, u1, u2 = (arm.potential_energy(q + s * h * e) for s in (-2.0, -1.0, 1.0, 2.0))
        grad[:, i] = (v2 - 8.0 * v1 + 8.0 * u1 - u2) / (12.0 * h)
    g = arm.gravity_torque(q)
    assert np.max(np.abs(grad - g)) <= 1e-9 * vs
    ours = arm.potential_energy(q)
    theirs = pin_potential(c.model, q)
    assert np.shape(ours) == (q.shape[0],)
    assert np.max(np.abs((ours - ours[0]) - (theirs - theirs[0]))) <= 1e-12 * vs
    if '<link name="mount">' not in c.chain.urdf:
        assert np.max(np.abs(ours - theirs)) <= 1e-12 * vs


@pytest.mark.parametrize("index", CASES, ids=IDS)
def test_kinetic_energy(index: int) -> None:
    c = _case(index)
    ours = c.arm.kinetic_energy(c.q, c.qd)
    theirs = pin_kinetic(c.model, c.q, c.qd)
    assert _rel_err(ours, theirs) <= TOL_PIN
    total = c.arm.total_energy(c.q, c.qd)
    np.testing.assert_allclose(total, ours + c.arm.potential_energy(c.q), rtol=1e-14, atol=1e-12)


# ---------------------------------------------------------------------- kinematics
@pytest.mark.parametrize("index", CASES[::3], ids=IDS[::3])
def test_frame_poses_match_pinocchio(index: int) -> None:
    """Every link's frame, and by default the tool frame (the chain's last link, ``tool``)."""
    c = _case(index)
    data = c.model.createData()
    links = list(NumpyChain(c.chain.urdf).frames(np.zeros(c.arm.n)))
    for x in c.q[:4]:
        pin.framesForwardKinematics(c.model, data, pin_q(c.model, x))
        for link in [*links, None]:
            pos, rot = c.arm.frame_pose(x) if link is None else c.arm.frame_pose(x, link)
            frame = data.oMf[c.model.getFrameId("tool" if link is None else link, pin.BODY)]
            assert np.shape(pos) == (3,) and np.shape(rot) == (3, 3)
            np.testing.assert_allclose(pos, frame.translation, rtol=0, atol=1e-11)
            np.testing.assert_allclose(rot, frame.rotation, rtol=0, atol=1e-13)


@pytest.mark.parametrize("index", CASES, ids=IDS)
def test_matches_independent_numpy_reading(index: int) -> None:
    """SerialArm reads URDF with Pinocchio's parser, so a misreading they shared would pass
    the comparisons with Pinocchio: here an independent numpy reading of the same text
    (``NumpyChain``, no engine) gives ``M``, the differences of ``V`` and every link pose."""
    c = _case(index)
    ref = NumpyChain(c.chain.urdf, c.chain.gravity)
    q = c.q[:4]
    v0 = c.arm.potential_energy(q[0])
    ref_v0 = ref.mass_and_potential(q[0])[1]
    vs = max(1.0, _potential_scale(c.chain))
    for x in q:
        mass, potential = ref.mass_and_potential(x)
        assert _rel_err(c.arm.mass_matrix(x)[None], mass[None]) <= 1e-12
        assert abs((c.arm.potential_energy(x) - v0) - (potential - ref_v0)) <= 1e-12 * vs
        for link, (pos, rot, _) in ref.frames(x).items():
            ours_pos, ours_rot = c.arm.frame_pose(x, link)
            np.testing.assert_allclose(ours_pos, pos, rtol=0, atol=1e-11)
            np.testing.assert_allclose(ours_rot, rot, rtol=0, atol=1e-13)


def test_tool_argument_sets_the_default_frame() -> None:
    chain = next(c for c in CHAINS if c.info.n >= 3)
    arm = SerialArm.from_urdf(chain.urdf, tool="link2")
    x = np.linspace(-1.0, 1.0, arm.n)
    pos, rot = arm.frame_pose(x)
    ref_pos, ref_rot = SerialArm.from_urdf(chain.urdf).frame_pose(x, "link2")
    np.testing.assert_array_equal(pos, ref_pos)
    np.testing.assert_array_equal(rot, ref_rot)
    with pytest.raises(ValueError, match="no_such_link"):
        SerialArm.from_urdf(chain.urdf, tool="no_such_link")
    with pytest.raises(ValueError, match="no_such_link"):
        arm.frame_pose(x, "no_such_link")


# ---------------------------------------------------------------------- shapes
def test_single_states_match_batch_rows() -> None:
    c = _case(7)
    arm = c.arm
    for b in (0, STATES - 1):
        q, qd, tau = c.q[b], c.qd[b], c.tau[b]
        pairs = [
            (arm.mass_matrix(q), arm.mass_matrix(c.q)[b]),
            (arm.coriolis(q, qd), arm.coriolis(c.q, c.qd)[b]),
            (arm.bias(q, qd), arm.bias(c.q, c.qd)[b]),
            (arm.gravity_torque(q), arm.gravity_torque(c.q)[b]),
            (arm.forward_dynamics(q, qd, tau), arm.forward_dynamics(c.q, c.qd, c.tau)[b]),
            (arm.inverse_dynamics(q, qd, tau), arm.inverse_dynamics(c.q, c.qd, c.tau)[b]),
        ]
        for single, row in pairs:
            assert np.shape(single) == np.shape(row)
            np.testing.assert_allclose(single, row, rtol=1e-14, atol=1e-14)
        for single, row in (
            (arm.kinetic_energy(q, qd), arm.kinetic_energy(c.q, c.qd)[b]),
            (arm.potential_energy(q), arm.potential_energy(c.q)[b]),
            (arm.total_energy(q, qd), arm.total_energy(c.q, c.qd)[b]),
        ):
            assert np.ndim(single) == 0
            np.testing.assert_allclose(single, row, rtol=1e-14, atol=1e-14)


# ---------------------------------------------------------------------- the planar arm
PLANAR = {
    "paper-point": PlanarArm.paper("point"),
    "paper-rod": PlanarArm.paper("rod"),
    "rod-n5": PlanarArm((1.0, 0.8, 1.2, 0.6, 1.0), (0.6, 0.9, 0.7, 0.8, 0.5), mass_model="rod"),
    "point-n1-moon": PlanarArm((2.5,), (0.7,), mass_model="point", gravity=1.62),
    "explicit-n4": PlanarArm(
        (1.5, 0.7, 1.1, 0.4),
        (0.8, 0.6, 0.9, 0.3),
        com=(0.3, 0.6, 0.2, 0.15),
        inertia=(0.05, 0.0, 0.12, 0.003),
        gravity=12.0,
    ),
    "paper-payload": PlanarArm.paper("point").with_payload(0.75),
    "paper-no-gravity": PlanarArm.paper("rod", gravity=0.0),
}


@pytest.mark.parametrize("arm", PLANAR.values(), ids=PLANAR.keys())
def test_planar_arm_urdf_is_the_planar_arm(arm: PlanarArm) -> None:
    """From its URDF, the planar arm has the closed form's dynamics on 1000 random states."""
    serial_arm = SerialArm.from_urdf(arm.to_urdf(), gravity=arm.gravity)
    assert serial_arm.n == arm.n
    assert tuple(serial_arm.joint_types) == ("revolute",) * arm.n
    assert tuple(serial_arm.joint_names) == tuple(f"joint{i + 1}" for i in range(arm.n))
    rng = np.random.default_rng(4_200 + arm.n)
    size = 1000
    q = rng.uniform(-2 * np.pi, 2 * np.pi, (size, arm.n))
    qd = rng.uniform(-3.0, 3.0, (size, arm.n))
    qd[-100:] *= 10.0  # and some fast states
    tau = rng.uniform(-50.0, 50.0, (size, arm.n))
    qdd = rng.uniform(-20.0, 20.0, (size, arm.n))
    for key, ours, theirs in (
        ("M", serial_arm.mass_matrix(q), arm.mass_matrix(q)),
        ("h", serial_arm.bias(q, qd), arm.bias(q, qd)),
        ("qdd", serial_arm.forward_dynamics(q, qd, tau), arm.forward_dynamics(q, qd, tau)),
        ("tau", serial_arm.inverse_dynamics(q, qd, qdd), arm.inverse_dynamics(q, qd, qdd)),
        ("C", serial_arm.coriolis(q, qd), arm.coriolis(q, qd)),
        ("G", serial_arm.gravity_torque(q), arm.gravity_torque(q)),
        ("T", serial_arm.kinetic_energy(q, qd), arm.kinetic_energy(q, qd)),
        ("V", serial_arm.potential_energy(q), arm.potential_energy(q)),
    ):
        err = _rel_err(ours, theirs)
        assert err <= TOL_PLANAR, f"{key}: relative error {err:.3e}"
    # the arm's plane is the root's x-z plane: the tip (x, y) is at (x, 0, y)
    for x in q[:20]:
        pos, rot = serial_arm.frame_pose(x)
        tip = arm.tip_position(x)
        np.testing.assert_allclose(pos, [tip[0], 0.0, tip[1]], rtol=0, atol=1e-13)
        phi = float(np.sum(x))
        # link axis +x turned by phi in the plane; the arm's z is the root's -y
        np.testing.assert_allclose(rot[:, 0], [np.cos(phi), 0.0, np.sin(phi)], atol=1e-13)
        np.testing.assert_allclose(rot[:, 2], [0.0, -1.0, 0.0], atol=1e-13)


def test_planar_urdf_gravity_defaults_to_981() -> None:
    arm = PlanarArm.paper()
    assert SerialArm.from_urdf(arm.to_urdf()).gravity == 9.81
    heavy = PlanarArm.paper(gravity=20.0)
    q = np.array([0.3, -0.7, 1.1])
    np.testing.assert_allclose(
        SerialArm.from_urdf(heavy.to_urdf(), gravity=20.0).gravity_torque(q),
        heavy.gravity_torque(q),
        rtol=1e-13,
    )


# ---------------------------------------------------------------------- energy
def _free_run(arm: object, q0: np.ndarray, qd0: np.ndarray, t_end: float, dt: float):
    """Free motion (τ = 0) by SteppedArm's RK4, sampled every 0.1 s."""
    stepper = SteppedArm(arm)
    q, qd = q0.astype(float).copy(), qd0.astype(float).copy()
    tau = np.zeros(arm.n)
    steps, every = round(t_end / dt), round(0.1 / dt)
    qs, qds = [q.copy()], [qd.copy()]
    for s in range(1, steps + 1):
        assert stepper.step(q, qd, tau, dt)
        if s % every == 0:
            qs.append(q.copy())
            qds.append(qd.copy())
    return np.array(qs), np.array(qds)


def _energy_drift(
    arm: object,
    urdf: str,
    q0: np.ndarray,
    qd0: np.ndarray,
    *,
    t_end: float = 10.0,
    dt: float = 1e-4,
) -> float:
    """Max over the run of ``|E(t) - E(0)| / E_s``, as test_properties does for the planar
    arm: ``E_s = T(0) + g Σ_i m_i R_i`` with ``R_i`` the reach of link i's centre of mass
    from the root (the sum of the joint-origin lengths up to it, its offset, and the largest
    travel of the prismatic joints before it seen in the run). For the planar arm it is
    test_properties' ``T(0) + g Σ m_i (Σ_{j<i} l_j + c_i)``."""
    qs, qds = _free_run(arm, q0, qd0, t_end, dt)
    energy = arm.total_energy(qs, qds)
    lever = _lever(NumpyChain(urdf, arm.gravity), np.abs(qs).max(axis=0))
    e_scale = float(arm.kinetic_energy(q0, qd0)) + arm.gravity * lever
    return float(np.max(np.abs(energy - energy[0])) / e_scale)


def _energy_chain(seed: int, n: int, prismatic: bool) -> tuple[str, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    urdf = random_chain(rng, n, prismatic=prismatic)
    types = np.array(chain_info(urdf).types)
    q0 = rng.uniform(-np.pi, np.pi, n)
    q0[types == "prismatic"] = 0.0
    return urdf, q0, rng.uniform(-1.0, 1.0, n)


ENERGY = {
    "paper": (PlanarArm.paper("point").to_urdf(), np.array([0.7, 1.5, 0.5]), np.zeros(3)),
    "rotary-n3": _energy_chain(1, 3, prismatic=False),
    "prismatic-n4": _energy_chain(3, 4, prismatic=True),
}


@pytest.mark.parametrize("case", ENERGY.values(), ids=ENERGY.keys())
def test_energy_is_conserved_without_torque(case: tuple) -> None:
    """Over 10 s of free motion under RK4 at dt = 1e-4, relative energy drift <= 1e-8 (the
    planar arm's bound in test_properties)."""
    urdf, q0, qd0 = case
    arm = SerialArm.from_urdf(urdf)
    if "prismatic" in urdf:
        assert "prismatic" in arm.joint_types
    assert _energy_drift(arm, urdf, q0, qd0) <= 1e-8


#: The time steps compared per case: the planar test's (8e-4, 4e-4), and twice those for the
#: prismatic chain, whose drift at 4e-4 (6e-15) is already at rounding level.
HALVING = {"paper": 8e-4, "rotary-n3": 8e-4, "prismatic-n4": 1.6e-3}


@pytest.mark.parametrize("name", ENERGY)
def test_energy_drift_is_rk4_truncation(name: str) -> None:
    """The drift falls as dt⁴ (ratio ~16 per halving): an integrator effect, not the model's.
    Over 2 s; both drifts must stand well above rounding (the drift stops falling at ~2e-15)
    for the ratio to mean that."""
    urdf, q0, qd0 = ENERGY[name]
    arm = SerialArm.from_urdf(urdf)
    dt = HALVING[name]
    drifts = [_energy_drift(arm, urdf, q0, qd0, t_end=2.0, dt=h) for h in (dt, dt / 2)]
    assert drifts[1] > 3e-14
    assert 10.0 < drifts[0] / drifts[1] < 25.0


# ---------------------------------------------------------------------- refusals
def _urdf(*joints: str) -> str:
    """A small URDF of these joints: a massless ``root`` and a massive link (1 kg) for every
    child link the joints name."""
    inertial = (
        '<inertial><origin xyz="0.1 0 0" rpy="0 0 0"/><mass value="1.0"/>'
        '<inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial>'
    )
    names = [re.search(r'<child link="([^"]+)"', j).group(1) for j in joints]  # type: ignore[union-attr]
    body = ['<link name="root"/>'] + [f'<link name="{n}">{inertial}</link>' for n in names]
    return (
        '<?xml version="1.0"?>\n<robot name="bad">\n' + "\n".join([*body, *joints]) + "\n</robot>\n"
    )


def _joint(name: str, kind: str, parent: str, child: str, extra: str = "") -> str:
    limit = '<limit lower="-3" upper="3" effort="10" velocity="10"/>'
    return (
        f'<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>'
        f'<origin xyz="0.3 0 0" rpy="0 0 0"/><axis xyz="0 0 1"/>{limit}{extra}</joint>'
    )


def test_a_valid_small_urdf_loads() -> None:
    """The refusal URDFs below differ from this accepted one in one joint each."""
    text = _urdf(
        _joint("j1", "revolute", "root", "upper"), _joint("j2", "continuous", "upper", "fore")
    )
    arm = SerialArm.from_urdf(text)
    assert arm.n == 2 and tuple(arm.joint_types) == ("revolute", "continuous")


@pytest.mark.parametrize(
    ("kind", "name"),
    [
        ("floating", "the_floating_joint"),
        ("planar", "the_planar_joint"),
        ("spherical", "the_spherical_joint"),
        ("banana", "the_banana_joint"),
    ],
)
def test_unsupported_joint_types_are_refused(kind: str, name: str) -> None:
    text = _urdf(_joint("j1", "revolute", "root", "upper"), _joint(name, kind, "upper", "fore"))
    with pytest.raises(ValueError, match=name):
        SerialArm.from_urdf(text)


def test_mimic_joint_is_refused() -> None:
    text = _urdf(
        _joint("j1", "revolute", "root", "upper"),
        _joint(
            "the_mimic_joint", "revolute", "upper", "fore", '<mimic joint="j1" multiplier="2"/>'
        ),
    )
    with pytest.raises(ValueError, match="the_mimic_joint"):
        SerialArm.from_urdf(text)


def test_branching_trees_are_refused() -> None:
    """Two moving joints below one link, directly or each behind a fixed joint."""
    direct = _urdf(
        _joint("j1", "revolute", "root", "upper"),
        _joint("left_joint", "revolute", "upper", "fore"),
        _joint("right_joint", "prismatic", "upper", "hand"),
    )
    via_fixed = _urdf(
        _joint("j1", "revolute", "root", "upper"),
        _joint("left_mount", "fixed", "upper", "fore"),
        _joint("right_mount", "fixed", "upper", "hand"),
        _joint("left_joint", "revolute", "fore", "finger"),
        _joint("right_joint", "continuous", "hand", "thumb"),
    )
    for text in (direct, via_fixed):
        with pytest.raises(
            ValueError, match=r"left_joint|right_joint|left_mount|right_mount|upper"
        ):
            SerialArm.from_urdf(text)


def test_a_chain_without_moving_joints_is_refused() -> None:
    text = _urdf(
        _joint("only_fixed", "fixed", "root", "upper"),
        _joint("more_fixed", "fixed", "upper", "fore"),
    )
    with pytest.raises(ValueError, match=r"(?i)joint"):
        SerialArm.from_urdf(text)


@pytest.mark.parametrize(
    "text",
    [
        "this is not a robot",
        "<robot name='broken'><link name='a'></robot>",
        '<mujoco model="not_urdf"><worldbody/></mujoco>',
        "",
    ],
    ids=["prose", "bad-xml", "mjcf", "empty"],
)
def test_non_urdf_text_is_refused(text: str) -> None:
    with pytest.raises(ValueError):
        SerialArm.from_urdf(text)


def test_missing_file_is_refused(tmp_path: Path) -> None:
    missing = tmp_path / "no_such_arm.urdf"
    for source in (missing, str(missing)):
        with pytest.raises(ValueError, match=re.escape("no_such_arm.urdf")):
            SerialArm.from_urdf(source)


def test_what_is_not_a_regular_file_is_refused(tmp_path: Path) -> None:
    """A folder (and so a FIFO or a device such as /dev/zero) is refused before any read."""
    with pytest.raises(ValueError, match="is not a regular file"):
        SerialArm.from_urdf(tmp_path)
    with pytest.raises(ValueError, match="is not a regular file"):
        SerialArm.from_urdf("/dev/zero")


def test_file_and_text_give_the_same_arm(tmp_path: Path) -> None:
    chain = CHAINS[16]
    path = tmp_path / "chain.urdf"
    path.write_text(chain.urdf)
    from_text = SerialArm.from_urdf(chain.urdf)
    assert SerialArm.from_urdf(path) == from_text
    assert SerialArm.from_urdf(str(path)) == from_text


# ---------------------------------------------------------------------- equality, pickling
def test_equality() -> None:
    a = SerialArm.from_urdf(CHAINS[5].urdf)
    assert a == SerialArm.from_urdf(CHAINS[5].urdf)
    assert a != SerialArm.from_urdf(CHAINS[6].urdf)
    assert a != SerialArm.from_urdf(CHAINS[5].urdf, gravity=3.0)
    assert a != PlanarArm.paper()


@pytest.mark.parametrize("index", [0, 8, 16, 35], ids=[IDS[i] for i in (0, 8, 16, 35)])
def test_pickle_round_trip(index: int) -> None:
    c = _case(index)
    back = pickle.loads(pickle.dumps(c.arm))
    assert back == c.arm
    assert type(back) is SerialArm
    assert tuple(back.joint_names) == tuple(c.arm.joint_names)
    assert tuple(back.joint_types) == tuple(c.arm.joint_types)
    assert back.gravity == c.arm.gravity
    np.testing.assert_array_equal(back.mass_matrix(c.q), c.arm.mass_matrix(c.q))
    np.testing.assert_array_equal(back.bias(c.q, c.qd), c.arm.bias(c.q, c.qd))
    np.testing.assert_array_equal(
        back.forward_dynamics(c.q, c.qd, c.tau), c.arm.forward_dynamics(c.q, c.qd, c.tau)
    )
    np.testing.assert_array_equal(
        back.inverse_dynamics(c.q, c.qd, c.qdd), c.arm.inverse_dynamics(c.q, c.qd, c.qdd)
    )
    pos, rot = back.frame_pose(c.q[0])
    ref_pos, ref_rot = c.arm.frame_pose(c.q[0])
    np.testing.assert_array_equal(pos, ref_pos)
    np.testing.assert_array_equal(rot, ref_rot)


@pytest.mark.parametrize("index", range(0, 60, 6))
def test_rk4_step_is_classical_rk4_on_pinocchio_dynamics(index: int) -> None:
    """The compiled RK4 step (its stages' sines and cosines rotated from the step's start)
    equals classical RK4 over Pinocchio's q̈, for steps whose stage increments are below and
    above the 2^-5 rad where the rotation hands over to sin/cos."""
    c = _case(index)
    arm = c.arm
    model = c.model
    plant = SteppedArm(arm)  # type: ignore[arg-type]
    rng = np.random.default_rng(index)
    for h, speed in ((1e-3, 1.0), (1e-3, 30.0), (5e-2, 3.0)):
        q0 = rng.uniform(-np.pi, np.pi, arm.n)
        v0 = rng.normal(size=arm.n) * speed
        tau = rng.normal(size=arm.n) * 5.0

        def f(q: np.ndarray, v: np.ndarray) -> np.ndarray:
            return pin_aba(model, q[None], v[None], tau[None])[0]  # noqa: B023

        k1 = f(q0, v0)
        k2 = f(q0 + 0.5 * h * v0, v0 + 0.5 * h * k1)
        k3 = f(q0 + 0.5 * h * (v0 + 0.5 * h * k1), v0 + 0.5 * h * k2)
        k4 = f(q0 + h * (v0 + 0.5 * h * k2), v0 + h * k3)
        v2, v3, v4 = v0 + 0.5 * h * k1, v0 + 0.5 * h * k2, v0 + h * k3
        q_ref = q0 + h / 6 * (v0 + 2 * v2 + 2 * v3 + v4)
        v_ref = v0 + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        q, v = q0.copy(), v0.copy()
        assert plant.step(q, v, tau, h)
        scale = max(1.0, float(np.max(np.abs(v_ref))))
        assert np.max(np.abs(q - q_ref)) <= 1e-12 * scale
        assert np.max(np.abs(v - v_ref)) <= 1e-9 * scale


@pytest.mark.parametrize("index", range(0, 60, 10))
def test_to_urdf_round_trip_keeps_the_dynamics(index: int) -> None:
    """``to_urdf`` writes the merged bodies: read back, by us and by Pinocchio, it is the
    same arm (M, q̈) and the same tool frame."""
    c = _case(index)
    text = c.arm.to_urdf()
    back = SerialArm.from_urdf(text, gravity=c.arm.gravity, tool=c.arm.tool)
    q, qd, tau = c.q[:10], c.qd[:10], c.tau[:10]
    scale = max(1.0, float(np.max(np.abs(c.arm.mass_matrix(q)))))
    assert np.max(np.abs(back.mass_matrix(q) - c.arm.mass_matrix(q))) <= 1e-12 * scale
    ref = pin_aba(pin_model(text, c.arm.gravity), q, qd, tau)
    got = c.arm.forward_dynamics(q, qd, tau)
    assert np.max(np.abs(got - ref)) <= 1e-9 * max(1.0, float(np.max(np.abs(ref))))
    np.testing.assert_allclose(back.tool_position(q), c.arm.tool_position(q), atol=1e-12)


def test_payload_at_a_link_and_scaling_match_pinocchio() -> None:
    """``with_payload`` (a point mass at a named link's origin) and ``scaled`` against
    Pinocchio given the same changes: a point-mass body appended at that frame, and the
    URDF's masses and inertias multiplied."""
    from slidingarm import ModelMismatch, robots

    ur5 = robots.load("ur5")
    rng = np.random.default_rng(3)
    q = rng.uniform(-3, 3, (30, 6))
    plant = ModelMismatch(payload=1.5, payload_link="wrist_2_link").apply(ur5)
    model = pin.buildModelFromUrdf(str(robots.path("ur5")))
    frame = model.frames[model.getFrameId("wrist_2_link")]
    model.appendBodyToJoint(
        frame.parentJoint, pin.Inertia(1.5, np.zeros(3), np.zeros((3, 3))), frame.placement
    )
    data = model.createData()
    for qi in q:
        m_ref = pin.crba(model, data, qi)
        m_ref = np.triu(m_ref) + np.triu(m_ref, 1).T
        assert np.max(np.abs(plant.mass_matrix(qi) - m_ref)) <= 1e-12
        g_ref = pin.computeGeneralizedGravity(model, data, qi)
        assert np.max(np.abs(plant.gravity_torque(qi) - g_ref)) <= 1e-11
    heavier = ur5.scaled(mass=1.2)
    assert np.max(np.abs(heavier.mass_matrix(q) - 1.2 * ur5.mass_matrix(q))) <= 1e-12


def test_batches_of_serial_arms_equal_single_runs() -> None:
    """Per-run plants, noise and seeds on a serial arm: a batch equals its single runs."""
    from slidingarm import (
        FTSMC,
        GaussianNoise,
        ModelMismatch,
        QuinticReference,
        Sensor,
        robots,
        simulate,
        simulate_batch,
    )

    ur5 = robots.load("ur5")
    ctrl = FTSMC(ur5, alpha=2.0, beta=2.0, p=5, q=3, k=20.0, switching="tanh", width=0.05)
    ref = QuinticReference(np.zeros(6), np.full(6, 0.4), duration=1.0)
    plants = [ModelMismatch(payload=p).apply(ur5) for p in (0.0, 0.5, 2.0)]
    sensor = Sensor(noise=GaussianNoise(1e-5))
    opts = {"q0": np.zeros(6), "t_final": 1.0, "dt": 1e-3, "sensor": sensor}
    batch = simulate_batch(
        plants, ctrl, ref, seeds=[1, 2, 3], torque_limit=[150.0] * 3 + [28.0] * 3, **opts
    )
    for b, plant in enumerate(plants):
        one = simulate(plant, ctrl, ref, seed=b + 1, torque_limit=[150.0] * 3 + [28.0] * 3, **opts)
        np.testing.assert_array_equal(batch.q[b], one.q)
    assert batch.ok.all()
    assert not np.array_equal(batch.q[0], batch.q[2])  # the payload mattered


def test_bad_arguments_name_the_problem() -> None:
    """The serial arm's own inputs: the source's type, the tool, a payload's mass and link,
    scale factors, frames and replace()'s keys."""
    from slidingarm._validate import ParameterTypeError
    from slidingarm.robots import load

    ur5 = load("ur5")
    with pytest.raises(ParameterTypeError, match="source must be a path or URDF text"):
        SerialArm.from_urdf(12)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="tool 'hand' is not a link"):
        SerialArm.from_urdf(PlanarArm.paper().to_urdf(), tool="hand")
    with pytest.raises(ValueError, match="payload mass must be >= 0 and <= 1e\\+06 kg"):
        ur5.with_payload(-1.0)
    with pytest.raises(ParameterTypeError, match="payload mass must be a number"):
        ur5.with_payload("1")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="payload link 'gripper' is not a link of 'ur5'"):
        ur5.with_payload(1.0, link="gripper")
    with pytest.raises(ValueError, match="fixed to the root"):
        ur5.with_payload(1.0, link="base_link")
    with pytest.raises(ValueError, match="mass scale factors must be > 0 and <= 1000"):
        ur5.scaled(mass=0.0)
    with pytest.raises(ValueError, match=r"length scale must be one value or 6"):
        ur5.scaled(length=[1.0, 2.0])
    with pytest.raises(ValueError, match="frame 'hand' is not a link of 'ur5'"):
        ur5.frame_pose(np.zeros(6), "hand")
    with pytest.raises(TypeError, match=r"unknown parameter\(s\) \['masses'\]"):
        ur5.replace(masses=1.0)
    with pytest.raises(ValueError, match="gravity"):
        ur5.replace(gravity=-1.0)
    with pytest.raises(AttributeError, match="immutable"):
        ur5.tool = "x"  # type: ignore[misc]


def _long_chain(rng: np.random.Generator, n: int) -> str:
    """URDF of a random chain of ``n`` moving joints (revolute and prismatic, random axes and
    origins, full inertias off the link frames), for lengths beyond ``random_chain``'s 9."""
    from urdf_chains import _axis, _Joint, _Link, _massive_link, _origin

    links = [_Link("world")]
    joints = []
    parent = "world"
    for i in range(1, n + 1):
        kind = "prismatic" if rng.random() < 0.2 else "revolute"
        links.append(_massive_link(rng, f"link{i}"))
        joints.append(_Joint(f"joint{i}", kind, parent, f"link{i}", *_origin(rng), axis=_axis(rng)))
        parent = f"link{i}"
    body = [link.urdf() for link in links] + [joint.urdf() for joint in joints]
    return '<?xml version="1.0"?>\n<robot name="long">\n' + "\n".join(body) + "\n</robot>\n"


@pytest.mark.parametrize("n", [15, 16, 17, 24])
def test_long_chains_match_pinocchio(n: int) -> None:
    """The articulated-body algorithm keeps its per-body buffer in groups of 8 bodies, on the
    stack up to 16 bodies and in the workspace beyond: chains on both sides of those
    boundaries give Pinocchio's q̈ (to 1e-9 of its scale) and classical RK4 on it."""
    rng = np.random.default_rng(9_000 + n)
    text = _long_chain(rng, n)
    arm = SerialArm.from_urdf(text)
    assert arm.n == n
    model = pin_model(text)
    q, qd = random_states(rng, arm.joint_types, 20)
    tau = rng.uniform(-20.0, 20.0, q.shape)
    assert _rel_err(arm.forward_dynamics(q, qd, tau), pin_aba(model, q, qd, tau)) <= TOL_PIN
    h = 1e-3

    def f(x: np.ndarray, v: np.ndarray) -> np.ndarray:
        return pin_aba(model, x[None], v[None], tau[0][None])[0]

    q0, v0 = q[0], qd[0]
    k1 = f(q0, v0)
    k2 = f(q0 + 0.5 * h * v0, v0 + 0.5 * h * k1)
    k3 = f(q0 + 0.5 * h * (v0 + 0.5 * h * k1), v0 + 0.5 * h * k2)
    k4 = f(q0 + h * (v0 + 0.5 * h * k2), v0 + h * k3)
    v2, v3, v4 = v0 + 0.5 * h * k1, v0 + 0.5 * h * k2, v0 + h * k3
    q_ref = q0 + h / 6 * (v0 + 2 * v2 + 2 * v3 + v4)
    v_ref = v0 + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    x, v = q0.copy(), v0.copy()
    assert SteppedArm(arm).step(x, v, tau[0], h)  # type: ignore[arg-type]
    scale = max(1.0, float(np.max(np.abs(v_ref))))
    assert np.max(np.abs(x - q_ref)) <= 1e-12 * scale
    assert np.max(np.abs(v - v_ref)) <= 1e-9 * scale


def test_long_chain_buffer_fits_the_workspace() -> None:
    """A chain longer than ``STACK_BODIES`` keeps the articulated-body buffer in the
    workspace's rows ``W_AB`` to ``W_CS - 1``: they hold it at every length (the buffer grows
    as 48 ceil(n / 8) groups' floats, the rows as 89 n)."""
    from slidingarm.models import _spatial as SK

    for n in range(SK.STACK_BODIES + 1, 400):
        assert (SK.W_CS - SK.W_AB) * n >= SK.buffer_floats(n), n


# ---------------------------------------------------------------------- a singular M
def test_a_singular_mass_matrix_leaves_defined_values_whatever_the_buffers_held() -> None:
    """The compiled forward dynamics and RK4 step of the per-run loop at a singular ``M``:
    ``False``, zero accelerations and an unmoved-but-finite state (so the run is reported
    singular), however the caller's buffers were filled before (NaN here: the loop's
    workspace is not cleared, and once a run's status depended on what it held); a NaN state
    gives NaN accelerations (reported non-finite)."""
    from slidingarm.models import _dispatch as MD

    arm = massless_tip_ur5()
    kind, params, g = arm._h()
    rng = np.random.default_rng(4)
    q, qd, tau = rng.normal(0.0, 0.5, (3, 6))
    with pytest.raises(ValueError, match="not positive definite"):
        arm.forward_dynamics(q, qd, tau)
    out = np.full(6, np.nan)
    work = np.full((MD.WORK_ROWS, 6), np.nan)
    assert not MD.forward_dynamics(kind, params, g, q, qd, tau, out, work)
    np.testing.assert_array_equal(out, np.zeros(6))
    qs, qds = q.copy(), qd.copy()
    scratch = np.full((MD.RK4_ROWS, 6), np.nan)
    work[:] = np.nan
    assert not MD.rk4_step(kind, params, g, qs, qds, tau, 1e-3, False, scratch, work)
    assert np.all(np.isfinite(qs)) and np.all(np.isfinite(qds))
    np.testing.assert_allclose(qs, q + 1e-3 * qd, rtol=0, atol=1e-15)
    bad = q.copy()
    bad[1] = np.nan
    assert not MD.forward_dynamics(kind, params, g, bad, qd, tau, out, work)
    assert np.all(np.isnan(out))
