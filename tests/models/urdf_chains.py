"""Random URDF serial chains and the Pinocchio and MuJoCo references they are checked against.

:func:`random_chain` writes a serial chain of 1-9 moving joints (revolute, continuous,
prismatic) about arbitrary unit axes, with random joint origins (``xyz`` and ``rpy``), full
inertia tensors in rotated, offset inertial frames, massive links behind fixed joints and a
massless ``tool`` link at the end. Its numbers are written with ``repr`` (shortest text that
round-trips a float64), so every reader parses exactly the same chain.

The references take one state ``(n,)`` or a batch ``(B, n)`` of *our* coordinates: one per
moving joint, in chain order, the continuous joints as an angle. Pinocchio models a continuous
joint with two configuration numbers ``(cos θ, sin θ)`` (:func:`pin_q` converts); MuJoCo's
hinge coordinate is the angle itself.

Nothing here imports slidingarm: the generator is validated against two independent engines
(``test_urdf_chains.py``) before any ``SerialArm`` is compared with them.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import mujoco
import numpy as np
import pinocchio as pin

__all__ = [
    "Chain",
    "ChainInfo",
    "NumpyChain",
    "chain_info",
    "chain_set",
    "mujoco_forward",
    "mujoco_model",
    "pin_aba",
    "pin_bias",
    "pin_coriolis",
    "pin_gravity",
    "pin_kinetic",
    "pin_mass",
    "pin_model",
    "pin_potential",
    "pin_q",
    "pin_rnea",
    "random_chain",
    "random_inertia",
    "random_states",
    "rpy_matrix",
]

MOVING = ("revolute", "continuous", "prismatic")


# ---------------------------------------------------------------------- generator
def _num(x: float) -> str:
    return repr(float(x))


def _vec(v: np.ndarray) -> str:
    return " ".join(_num(x) for x in v)


def _rotation(rng: np.random.Generator) -> np.ndarray:
    """A uniformly random rotation matrix (from a normalised Gaussian quaternion)."""
    quat = rng.normal(size=4)
    w, x, y, z = quat / np.linalg.norm(quat)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def _unit(rng: np.random.Generator) -> np.ndarray:
    v = rng.normal(size=3)
    return v / np.linalg.norm(v)


def _rpy(rng: np.random.Generator) -> np.ndarray:
    """Random roll-pitch-yaw: zero a fifth of the time (the common case in real URDFs)."""
    if rng.random() < 0.2:
        return np.zeros(3)
    return np.array(
        [rng.uniform(-np.pi, np.pi), rng.uniform(-np.pi / 2, np.pi / 2), rng.uniform(-np.pi, np.pi)]
    )


def _origin(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """A joint origin: a translation of 0.05-1 m in a random direction and a random rpy."""
    return _unit(rng) * rng.uniform(0.05, 1.0), _rpy(rng)


def _axis(rng: np.random.Generator) -> np.ndarray:
    """A unit joint axis: a signed coordinate axis a quarter of the time (Pinocchio then uses
    its aligned joint models, JointModelRX/PY/RUBZ...), else an arbitrary direction."""
    if rng.random() < 0.25:
        axis = np.zeros(3)
        axis[rng.integers(3)] = rng.choice([-1.0, 1.0])
        return axis
    return _unit(rng)


def random_inertia(rng: np.random.Generator, mass: float) -> np.ndarray:
    """A physically valid 3x3 inertia tensor about the centre of mass, in a random frame.

    The body's second moment of mass about its principal axes is ``diag(s)`` with
    ``s_i = m r_i²`` (``r_i`` 0.02-0.4 m, like the half-size of a robot link); the principal
    moments ``I_i = s_j + s_k`` then satisfy the triangle inequalities strictly
    (``I_i + I_j - I_k = 2 s_k > 0``). The tensor is ``R diag(I) Rᵀ`` for a random ``R``, so
    all products of inertia are non-zero.
    """
    s = mass * rng.uniform(0.02, 0.4, 3) ** 2
    principal = s.sum() - s
    rot = _rotation(rng)
    inertia = rot @ np.diag(principal) @ rot.T
    return 0.5 * (inertia + inertia.T)


@dataclass
class _Link:
    name: str
    mass: float = 0.0
    com_xyz: np.ndarray = field(default_factory=lambda: np.zeros(3))
    com_rpy: np.ndarray = field(default_factory=lambda: np.zeros(3))
    inertia: np.ndarray | None = None

    def urdf(self) -> str:
        if self.inertia is None:
            return f'  <link name="{self.name}"/>'
        i = self.inertia
        return (
            f'  <link name="{self.name}">\n    <inertial>\n'
            f'      <origin xyz="{_vec(self.com_xyz)}" rpy="{_vec(self.com_rpy)}"/>\n'
            f'      <mass value="{_num(self.mass)}"/>\n'
            f'      <inertia ixx="{_num(i[0, 0])}" ixy="{_num(i[0, 1])}" ixz="{_num(i[0, 2])}" '
            f'iyy="{_num(i[1, 1])}" iyz="{_num(i[1, 2])}" izz="{_num(i[2, 2])}"/>\n'
            "    </inertial>\n  </link>"
        )


@dataclass
class _Joint:
    name: str
    kind: str
    parent: str
    child: str
    xyz: np.ndarray
    rpy: np.ndarray
    axis: np.ndarray | None = None

    def urdf(self) -> str:
        lines = [
            f'  <joint name="{self.name}" type="{self.kind}">',
            f'    <parent link="{self.parent}"/>',
            f'    <child link="{self.child}"/>',
            f'    <origin xyz="{_vec(self.xyz)}" rpy="{_vec(self.rpy)}"/>',
        ]
        if self.axis is not None:
            lines.append(f'    <axis xyz="{_vec(self.axis)}"/>')
        if self.kind in ("revolute", "prismatic"):
            # wide limits, never reached: the references must see the free chain
            lines.append('    <limit lower="-1e6" upper="1e6" effort="1e6" velocity="1e6"/>')
        lines.append("  </joint>")
        return "\n".join(lines)


def _massive_link(rng: np.random.Generator, name: str) -> _Link:
    mass = float(np.exp(rng.uniform(np.log(0.1), np.log(10.0))))  # 0.1-10 kg, log-uniform
    return _Link(
        name,
        mass,
        _unit(rng) * rng.uniform(0.0, 0.5),
        _rpy(rng),
        random_inertia(rng, mass),
    )


def random_chain(
    rng: np.random.Generator,
    n_joints: int,
    *,
    prismatic: bool = True,
    fixed: bool = True,
    continuous: bool = True,
    name: str = "random_chain",
) -> str:
    """URDF text of a random serial chain with ``n_joints`` (1-9) moving joints.

    Layout: a massless root ``world``; with ``fixed``, a fixed joint to a massive ``mount``
    link at a random pose, before each later moving joint, with probability 0.3, a fixed
    joint to a massive link ``fixed<i>``, and on each link but the last, with probability
    0.25, a massive side link ``side<i>`` on a fixed joint (a tree, but not a branching
    chain: no moving joint below it, like a robot hand's welded fingers); the moving joints ``joint1..`` to the links
    ``link1..`` (each has a mass: MuJoCo refuses a moving body without one); at the end a
    fixed joint to a massless ``tool`` link (always: the default tool frame). Joint types are
    drawn among revolute and, if allowed, continuous and prismatic; all masses are 0.1-10 kg,
    translations 0.05-1 m (centres of mass up to 0.5 m off their link frame).
    """
    if not 1 <= n_joints <= 9:
        raise ValueError(f"n_joints must be 1-9, got {n_joints}")
    kinds = ["revolute"] + ["continuous"] * continuous + ["prismatic"] * prismatic
    links = [_Link("world")]
    joints: list[_Joint] = []
    parent = "world"
    if fixed:
        links.append(_massive_link(rng, "mount"))
        joints.append(_Joint("mount_joint", "fixed", parent, "mount", *_origin(rng)))
        parent = "mount"
    for i in range(1, n_joints + 1):
        if fixed and i > 1 and rng.random() < 0.3:
            child = f"fixed{i}"
            links.append(_massive_link(rng, child))
            joints.append(_Joint(f"fixed{i}_joint", "fixed", parent, child, *_origin(rng)))
            parent = child
        kind = str(rng.choice(kinds))
        child = f"link{i}"
        links.append(_massive_link(rng, child))
        joints.append(_Joint(f"joint{i}", kind, parent, child, *_origin(rng), axis=_axis(rng)))
        parent = child
        if fixed and i < n_joints and rng.random() < 0.25:
            side = f"side{i}"
            links.append(_massive_link(rng, side))
            joints.append(_Joint(f"side{i}_joint", "fixed", parent, side, *_origin(rng)))
    links.append(_Link("tool"))
    joints.append(_Joint("tool_joint", "fixed", parent, "tool", *_origin(rng)))
    body = [link.urdf() for link in links] + [joint.urdf() for joint in joints]
    return f'<?xml version="1.0"?>\n<robot name="{name}">\n' + "\n".join(body) + "\n</robot>\n"


def random_states(
    rng: np.random.Generator,
    types: tuple[str, ...],
    size: int,
    *,
    qd_max: float = 3.0,
    fast: int = 0,
) -> tuple[np.ndarray, np.ndarray]:
    """``size`` random states ``(q, q̇)`` of a chain with these joint ``types``.

    Angles are drawn in ±2π (continuous joints in ±4π: any angle is valid), prismatic
    displacements in ±0.5 m, speeds in ±``qd_max``; the last ``fast`` states have speeds
    ten times larger (up to 10 ``qd_max``).
    """
    n = len(types)
    prism = np.array([t == "prismatic" for t in types])
    cont = np.array([t == "continuous" for t in types])
    q = rng.uniform(-2 * np.pi, 2 * np.pi, (size, n))
    q[:, cont] *= 2.0
    q[:, prism] = rng.uniform(-0.5, 0.5, (size, int(prism.sum())))
    qd = rng.uniform(-qd_max, qd_max, (size, n))
    if fast:
        qd[size - fast :] *= 10.0
    return q, qd


# ---------------------------------------------------------------------- chain facts
@dataclass(frozen=True)
class ChainInfo:
    """What a reference model says of a chain: moving-joint names and types in chain order."""

    names: tuple[str, ...]
    types: tuple[str, ...]

    @property
    def n(self) -> int:
        return len(self.names)


def _tree(urdf: str) -> tuple[str, list]:
    """The root link and the URDF's joints (``<robot>``'s own ``<joint>`` children, not those
    of a ``<transmission>``) in depth-first order from the root. In a serial chain with fixed
    side branches that order lists the moving joints in chain order."""
    import xml.etree.ElementTree as ET

    root = ET.fromstring(urdf)
    joints = root.findall("joint")
    below: dict[str, list] = {}
    for j in joints:
        below.setdefault(str(j.find("parent").get("link")), []).append(j)  # type: ignore[union-attr]
    children = {str(j.find("child").get("link")) for j in joints}  # type: ignore[union-attr]
    (base,) = {str(link.get("name")) for link in root.findall("link")} - children
    order: list = []
    stack = list(reversed(below.get(base, [])))
    while stack:
        j = stack.pop()
        order.append(j)
        stack.extend(reversed(below.get(str(j.find("child").get("link")), [])))  # type: ignore[union-attr]
    return base, order


def chain_info(urdf: str) -> ChainInfo:
    """Moving joints of the chain, in chain order, from the URDF text itself (xml, not an engine)."""
    moving = [j for j in _tree(urdf)[1] if j.get("type") in MOVING]
    return ChainInfo(
        tuple(str(j.get("name")) for j in moving), tuple(str(j.get("type")) for j in moving)
    )


# ---------------------------------------------------------------------- the shared chain set
@dataclass(frozen=True)
class Chain:
    """One chain of the fixed test set: its id, URDF text, moving joints and gravity (m/s²)."""

    name: str
    urdf: str
    info: ChainInfo
    gravity: float
    seed: int

    def rng(self, purpose: int = 0) -> np.random.Generator:
        """A Generator for this chain's states, one stream per ``purpose``."""
        return np.random.default_rng([self.seed, purpose])


def chain_set(count: int = 60, base_seed: int = 70_000) -> list[Chain]:
    """The fixed set of random chains both test files use.

    Chain ``k`` has ``1 + k % 9`` moving joints (every count from 1 to 9 appears), prismatic
    joints allowed unless ``k % 4 == 3``, continuous unless ``k % 3 == 2``, fixed massive
    links unless ``k % 5 == 4``, gravity 9.81 m/s² except every sixth chain (0-20 m/s²).
    """
    chains = []
    for k in range(count):
        rng = np.random.default_rng(base_seed + k)
        n = 1 + k % 9
        urdf = random_chain(
            rng,
            n,
            prismatic=k % 4 != 3,
            continuous=k % 3 != 2,
            fixed=k % 5 != 4,
            name=f"chain{k}",
        )
        gravity = float(rng.uniform(0.0, 20.0)) if k % 6 == 5 else 9.81
        info = chain_info(urdf)
        letters = "".join(
            {"revolute": "R", "continuous": "C", "prismatic": "P"}[t] for t in info.types
        )
        fixed = "-fixed" if k % 5 != 4 else ""
        chains.append(Chain(f"c{k:02d}-{letters}{fixed}", urdf, info, gravity, base_seed + k))
    return chains


# ---------------------------------------------------------------------- numpy reference
def rpy_matrix(rpy: np.ndarray) -> np.ndarray:
    """URDF's ``rpy``: fixed-axis roll about x, then pitch about y, then yaw about z,
    ``R = Rz(yaw) Ry(pitch) Rx(roll)``."""
    r, p, y = rpy
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    return rz @ ry @ rx


def _axis_rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rodrigues: rotation by ``angle`` about the unit ``axis``."""
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * (k @ k)


def _floats(text: str | None, default: str = "0 0 0") -> np.ndarray:
    return np.array([float(x) for x in (text or default).split()])


class NumpyChain:
    """An independent reading of a serial-chain URDF in plain numpy: forward kinematics of
    every link frame, ``M(q) = Σ m Jvᵀ Jv + Jωᵀ I Jω`` over every massive link (those behind
    fixed joints too) and ``V(q) = Σ m g z_com``. It shares no code with either engine, so it
    checks the conventions (rpy order, inertial frames, axis frames) they agree on."""

    def __init__(self, urdf: str, gravity: float = 9.81) -> None:
        import xml.etree.ElementTree as ET

        root = ET.fromstring(urdf)
        self.gravity = float(gravity)
        #: per massive link: mass, centre of mass and inertia tensor in the link frame
        self.inertial: dict[str, tuple[float, np.ndarray, np.ndarray]] = {}
        #: per massive link: the inertia tensor as written (in its inertial frame)
        self.written: dict[str, np.ndarray] = {}
        for link in root.findall("link"):
            node = link.find("inertial")
            if node is None:
                continue
            origin = node.find("origin")
            inertia = node.find("inertia")
            assert inertia is not None
            keys = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
            xx, xy, xz, yy, yz, zz = (float(inertia.get(k, "0")) for k in keys)
            rot = rpy_matrix(_floats(None if origin is None else origin.get("rpy")))
            tensor = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
            self.written[str(link.get("name"))] = tensor
            self.inertial[str(link.get("name"))] = (
                float(node.find("mass").get("value")),  # type: ignore[union-attr]
                _floats(None if origin is None else origin.get("xyz")),
                rot @ tensor @ rot.T,
            )
        self.root, order = _tree(urdf)
        #: per joint in depth-first order: (type, xyz, origin rotation, axis, child, parent)
        self.joints = []
        for j in order:
            origin = j.find("origin")
            axis = j.find("axis")
            self.joints.append(
                (
                    str(j.get("type")),
                    _floats(None if origin is None else origin.get("xyz")),
                    rpy_matrix(_floats(None if origin is None else origin.get("rpy"))),
                    _floats(None if axis is None else axis.get("xyz"), "1 0 0"),
                    str(j.find("child").get("link")),  # type: ignore[union-attr]
                    str(j.find("parent").get("link")),  # type: ignore[union-attr]
                )
            )

    def frames(self, q: np.ndarray) -> dict[str, tuple[np.ndarray, np.ndarray, list]]:
        """Per link: (position, rotation) in the root frame and the moving joints before it
        as (index, type, world axis, world point)."""
        out: dict[str, tuple[np.ndarray, np.ndarray, list]] = {
            self.root: (np.zeros(3), np.eye(3), [])
        }
        i = 0
        for kind, xyz, rpy_rot, axis, child, parent in self.joints:
            pos, rot, movers = out[parent]
            pos = pos + rot @ xyz
            rot = rot @ rpy_rot
            if kind != "fixed":
                a = rot @ axis
                movers = [*movers, (i, kind, a, pos.copy())]
                if kind == "prismatic":
                    pos = pos + a * q[i]
                else:
                    rot = rot @ _axis_rotation(axis, q[i])
                i += 1
            out[child] = (pos, rot, movers)
        return out

    def reach(self, travel: np.ndarray) -> dict[str, tuple[float, bool]]:
        """Per link: a bound on the distance of its frame from the root (the joint-origin
        lengths on its path plus ``|travel|`` of the prismatic joints on it) and whether a
        moving joint is on its path."""
        out: dict[str, tuple[float, bool]] = {self.root: (0.0, False)}
        i = 0
        for kind, xyz, _, _, child, parent in self.joints:
            dist, moves = out[parent]
            dist += float(np.linalg.norm(xyz))
            if kind != "fixed":
                if kind == "prismatic":
                    dist += abs(float(travel[i]))
                moves = True
                i += 1
            out[child] = (dist, moves)
        return out

    def mass_and_potential(self, q: np.ndarray) -> tuple[np.ndarray, float]:
        n = sum(kind != "fixed" for kind, *_ in self.joints)
        mass = np.zeros((n, n))
        potential = 0.0
        for name, (pos, rot, movers) in self.frames(q).items():
            if name not in self.inertial:
                continue
            m, com, inertia = self.inertial[name]
            c = pos + rot @ com
            jv = np.zeros((3, n))
            jw = np.zeros((3, n))
            for i, kind, a, p in movers:
                if kind == "prismatic":
                    jv[:, i] = a
                else:
                    jw[:, i] = a
                    jv[:, i] = np.cross(a, c - p)
            world = rot @ inertia @ rot.T
            mass += m * jv.T @ jv + jw.T @ world @ jw
            potential += m * self.gravity * c[2]
        return mass, potential


# ---------------------------------------------------------------------- Pinocchio
def pin_model(urdf: str, gravity: float = 9.81) -> pin.Model:
    """Pinocchio's model of the URDF text, gravity ``(0, 0, -gravity)`` in the root frame."""
    model = pin.buildModelFromXML(urdf)
    model.gravity.linear = np.array([0.0, 0.0, -float(gravity)])
    return model


def _continuous(model: pin.Model) -> list[bool]:
    """Per moving joint of ``model`` (in order): is it a continuous joint (nq = 2, nv = 1)?"""
    out = []
    for joint in model.joints[1:]:
        if joint.nv != 1 or joint.nq not in (1, 2):
            raise ValueError(f"not a one-degree-of-freedom joint: {joint.shortname()}")
        out.append(joint.nq == 2)
    return out


def pin_q(model: pin.Model, q: np.ndarray) -> np.ndarray:
    """Pinocchio's configuration ``(nq,)`` or ``(B, nq)`` of our coordinates ``q``: a
    continuous joint's angle becomes ``(cos θ, sin θ)``."""
    q = np.asarray(q, dtype=float)
    cols = []
    for i, cont in enumerate(_continuous(model)):
        if cont:
            cols += [np.cos(q[..., i]), np.sin(q[..., i])]
        else:
            cols.append(q[..., i])
    return np.stack(cols, axis=-1)


def _batch(
    model: pin.Model, fn, q: np.ndarray, *rest: np.ndarray, matrix: bool = False
) -> np.ndarray:
    q = np.asarray(q, dtype=float)
    single = q.ndim == 1
    qa = np.atleast_2d(q)
    rest_a = [np.broadcast_to(np.atleast_2d(np.asarray(r, dtype=float)), qa.shape) for r in rest]
    pq = pin_q(model, qa)
    data = model.createData()
    n = model.nv
    out = np.empty((qa.shape[0], n, n) if matrix else qa.shape)
    for b in range(qa.shape[0]):
        out[b] = fn(model, data, pq[b], *(r[b] for r in rest_a))
    return out[0] if single else out


def _mass(model: pin.Model, data: pin.Data, q: np.ndarray) -> np.ndarray:
    upper = np.triu(pin.crba(model, data, q))  # crba fills only the upper triangle
    return upper + np.triu(upper, 1).T


def pin_mass(model: pin.Model, q: np.ndarray) -> np.ndarray:
    """``M(q)`` by CRBA, symmetrised from its upper triangle."""
    return _batch(model, _mass, q, matrix=True)


def pin_bias(model: pin.Model, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
    """``h(q, q̇) = C q̇ + G`` by RNEA with zero acceleration."""
    return _batch(model, lambda m, d, x, v: pin.rnea(m, d, x, v, np.zeros(m.nv)), q, qd)


def pin_aba(model: pin.Model, q: np.ndarray, qd: np.ndarray, tau: np.ndarray) -> np.ndarray:
    """Forward dynamics ``q̈`` by ABA."""
    return _batch(model, lambda m, d, x, v, t: pin.aba(m, d, x, v, t).copy(), q, qd, tau)


def pin_rnea(model: pin.Model, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
    """Inverse dynamics ``τ`` by RNEA."""
    return _batch(model, lambda m, d, x, v, a: pin.rnea(m, d, x, v, a).copy(), q, qd, qdd)


def pin_coriolis(model: pin.Model, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
    """Pinocchio's Coriolis matrix (the one with ``Ṁ - 2C`` skew-symmetric)."""
    return _batch(
        model, lambda m, d, x, v: pin.computeCoriolisMatrix(m, d, x, v).copy(), q, qd, matrix=True
    )


def pin_gravity(model: pin.Model, q: np.ndarray) -> np.ndarray:
    """Generalized gravity ``G(q)``."""
    return _batch(model, lambda m, d, x: pin.computeGeneralizedGravity(m, d, x).copy(), q)


def pin_potential(model: pin.Model, q: np.ndarray) -> np.ndarray:
    """Potential energy ``Σ m g z_com`` (zero at root z = 0)."""
    return _batch_scalar(model, lambda m, d, x: pin.computePotentialEnergy(m, d, x), q)


def pin_kinetic(model: pin.Model, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
    """Kinetic energy."""
    return _batch_scalar(model, lambda m, d, x, v: pin.computeKineticEnergy(m, d, x, v), q, qd)


def _batch_scalar(model: pin.Model, fn, q: np.ndarray, *rest: np.ndarray) -> np.ndarray:
    q = np.asarray(q, dtype=float)
    single = q.ndim == 1
    qa = np.atleast_2d(q)
    rest_a = [np.broadcast_to(np.atleast_2d(np.asarray(r, dtype=float)), qa.shape) for r in rest]
    pq = pin_q(model, qa)
    data = model.createData()
    out = np.array([fn(model, data, pq[b], *(r[b] for r in rest_a)) for b in range(qa.shape[0])])
    return out[0] if single else out


# ---------------------------------------------------------------------- MuJoCo
def mujoco_model(urdf: str, gravity: float = 9.81) -> mujoco.MjModel:
    """MuJoCo's model of the URDF text (its URDF import fuses fixed links into their parent),
    gravity ``(0, 0, -gravity)``, contacts and all constraints (joint limits, friction loss)
    disabled, and no passive forces: MuJoCo turns a URDF ``<dynamics damping>`` into joint
    damping (the Panda's 0.003 N m s/rad changed its q̈ by ~1e-2), which rigid-body dynamics
    (Pinocchio, ``SerialArm``) do not model; the springs, dampers and armature are zeroed and
    the spring and damper forces disabled."""
    model = mujoco.MjModel.from_xml_string(urdf)
    model.opt.gravity[:] = (0.0, 0.0, -float(gravity))
    bits = mujoco.mjtDisableBit
    for bit in (
        bits.mjDSBL_CONTACT,
        bits.mjDSBL_CONSTRAINT,
        bits.mjDSBL_SPRING,
        bits.mjDSBL_DAMPER,
    ):
        model.opt.disableflags |= bit
    model.dof_damping[:] = 0.0
    model.dof_armature[:] = 0.0
    model.dof_frictionloss[:] = 0.0
    model.jnt_stiffness[:] = 0.0
    return model


def mujoco_forward(
    model: mujoco.MjModel, q: np.ndarray, qd: np.ndarray, tau: np.ndarray
) -> dict[str, np.ndarray]:
    """MuJoCo's ``q̈`` (``qacc``), bias (``qfrc_bias``) and ``M`` for a batch of states."""
    qa, qda, ta = (np.atleast_2d(np.asarray(a, dtype=float)) for a in (q, qd, tau))
    qda, ta = (np.broadcast_to(a, qa.shape) for a in (qda, ta))
    data = mujoco.MjData(model)
    size, n = qa.shape
    out = {"qdd": np.empty((size, n)), "h": np.empty((size, n)), "M": np.empty((size, n, n))}
    for b in range(size):
        data.qpos[:] = qa[b]
        data.qvel[:] = qda[b]
        data.qfrc_applied[:] = ta[b]
        mujoco.mj_forward(model, data)
        out["qdd"][b] = data.qacc
        out["h"][b] = data.qfrc_bias
        mujoco.mj_fullM(model, data, out["M"][b])
    return out
