"""Any serial arm from its URDF: revolute, continuous, prismatic and fixed joints.

:meth:`SerialArm.from_urdf` reads the file with Pinocchio (``pin``): it merges the links
fixed to a body into that body (their inertias combined), keeps every link's frame, and
reports each joint's kind exactly, so that what slidingarm does not model (floating, planar,
spherical or mimic joints, branching trees) is refused by name. MuJoCo's URDF import is
lighter but fuses fixed links without keeping their frames (a tool frame such as ``tool0``
is lost), refuses a moving link without mass, and turns a planar joint silently into three
joints; MuJoCo is the independent plant instead (:class:`slidingarm.MujocoPlant`).

The dynamics run in the compiled kernels of :mod:`slidingarm.models._spatial` (Newton-Euler,
composite rigid body, articulated body) through the model contract, so a ``SerialArm`` goes
wherever a :class:`~slidingarm.PlanarArm` goes.

Conventions: one coordinate per moving joint in chain order from the root (a ``continuous``
joint is one unbounded angle), SI units, gravity ``(0, 0, -g)`` in the URDF's root frame.
"""

from __future__ import annotations

import math
import os
import xml.etree.ElementTree as ET
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray

from slidingarm._io import read_model_text
from slidingarm._validate import ParameterTypeError, _float, is_real, number_array, real
from slidingarm.models import _dispatch as D
from slidingarm.models import _spatial as SK
from slidingarm.models.base import MAX_GRAVITY, MAX_MASS, MAX_SCALE, ArmModel

__all__ = ["SerialArm"]

FloatArray = NDArray[np.float64]

#: Joint kinds a chain may have (``fixed`` joints merge their child into the parent body).
JOINT_TYPES = ("revolute", "continuous", "prismatic")

def _num(x: float) -> str:
    return repr(float(x))


def _vec(values: ArrayLike) -> str:
    return " ".join(_num(v) for v in np.asarray(values, dtype=float).reshape(-1))


def _rpy(rot: FloatArray) -> tuple[float, float, float]:
    """URDF roll-pitch-yaw of a rotation, :math:`R = R_z(y) R_y(p) R_x(r)`."""
    pitch = math.atan2(-rot[2, 0], math.hypot(rot[0, 0], rot[1, 0]))
    if math.hypot(rot[0, 0], rot[1, 0]) < 1e-12:  # gimbal lock: put all of the yaw in roll
        return (math.atan2(-rot[1, 2], rot[1, 1]), pitch, 0.0)
    return (math.atan2(rot[2, 1], rot[2, 2]), pitch, math.atan2(rot[1, 0], rot[0, 0]))


def _quat(rot: FloatArray) -> tuple[float, float, float, float]:
    """Unit quaternion ``(w, x, y, z)`` of a rotation matrix (Shepperd's method)."""
    tr = rot[0, 0] + rot[1, 1] + rot[2, 2]
    if tr > 0:
        s = 2.0 * math.sqrt(1.0 + tr)
        return (
            0.25 * s,
            (rot[2, 1] - rot[1, 2]) / s,
            (rot[0, 2] - rot[2, 0]) / s,
            (rot[1, 0] - rot[0, 1]) / s,
        )
    i = int(np.argmax([rot[0, 0], rot[1, 1], rot[2, 2]]))
    j, k = (i + 1) % 3, (i + 2) % 3
    s = 2.0 * math.sqrt(max(1.0 + rot[i, i] - rot[j, j] - rot[k, k], 0.0))
    out = [0.0, 0.0, 0.0, 0.0]
    out[0] = (rot[k, j] - rot[j, k]) / s
    out[1 + i] = 0.25 * s
    out[1 + j] = (rot[j, i] + rot[i, j]) / s
    out[1 + k] = (rot[k, i] + rot[i, k]) / s
    return (out[0], out[1], out[2], out[3])


def _parse_joints(text: str, where: str) -> tuple[str, dict[str, dict[str, Any]]]:
    """The robot's name and each URDF joint's type, limits and links; refuses the joint
    kinds slidingarm does not model, by name."""
    try:
        root = ET.fromstring(text)
    except ET.ParseError as exc:
        raise ValueError(f"{where} is not valid XML: {exc}") from None
    if root.tag != "robot":
        raise ValueError(f"{where} is not a URDF: its root element is <{root.tag}>, not <robot>")
    joints: dict[str, dict[str, Any]] = {}
    for el in root.findall("joint"):
        name = el.get("name", "")
        kind = el.get("type", "")
        if kind in ("floating", "planar"):
            raise ValueError(
                f"joint {name!r} of {where} is a {kind} joint; slidingarm models fixed-base "
                "serial chains of revolute, continuous, prismatic and fixed joints"
            )
        if kind not in (*JOINT_TYPES, "fixed"):
            raise ValueError(
                f"joint {name!r} of {where} has type {kind!r}; slidingarm models revolute, "
                "continuous, prismatic and fixed joints"
            )
        if el.find("mimic") is not None:
            raise ValueError(
                f"joint {name!r} of {where} mimics another joint; slidingarm gives every "
                "moving joint its own coordinate (make it fixed or remove the <mimic>)"
            )
        limit = el.find("limit")

        def attr(
            key: str, default: float, limit: ET.Element | None = limit, name: str = name
        ) -> float:
            if limit is None or limit.get(key) is None:
                return default
            try:
                return float(limit.get(key, ""))
            except ValueError:
                raise ValueError(
                    f"joint {name!r} of {where}: limit {key}={limit.get(key)!r} is not a number"
                ) from None

        inf = math.inf
        bounded = kind in ("revolute", "prismatic")
        parent = el.find("parent")
        child = el.find("child")
        joints[name] = {
            "type": kind,
            "parent": None if parent is None else parent.get("link"),
            "child": None if child is None else child.get("link"),
            "lower": attr("lower", -inf) if bounded else -inf,
            "upper": attr("upper", inf) if bounded else inf,
            "effort": attr("effort", inf),
            "velocity": attr("velocity", inf),
        }
    return root.get("name", "robot"), joints


def _pin_axis(joint: Any, q0: FloatArray, name: str, where: str) -> tuple[str, FloatArray]:
    """``("revolute" | "prismatic", unit axis)`` of a one-dof Pinocchio joint, read from its
    motion subspace ``S = (linear, angular)``."""
    short = joint.shortname()
    if joint.nv != 1 or "Mimic" in short or "Helical" in short:
        raise ValueError(
            f"joint {name!r} of {where} is a {short} in Pinocchio; slidingarm cannot model it"
        )
    data = joint.createData()
    joint.calc(data, q0)
    motion = np.asarray(data.S, dtype=float).reshape(6)
    lin, ang = motion[:3], motion[3:]
    if np.linalg.norm(lin) == 0.0 and abs(np.linalg.norm(ang) - 1.0) < 1e-12:
        return "revolute", ang / np.linalg.norm(ang)
    if np.linalg.norm(ang) == 0.0 and abs(np.linalg.norm(lin) - 1.0) < 1e-12:
        return "prismatic", lin / np.linalg.norm(lin)
    raise ValueError(f"joint {name!r} of {where} is neither a pure rotation nor a pure translation")


class _CapturedStderr:
    """Collect what C++ code writes to file descriptor 2 (Pinocchio's URDF parser reports
    the cause of a failure there only)."""

    def __enter__(self) -> _CapturedStderr:
        import tempfile

        self.text = ""
        try:
            self._file = tempfile.TemporaryFile(mode="w+b")
            self._saved = os.dup(2)
            os.dup2(self._file.fileno(), 2)
        except OSError:  # pragma: no cover - no fd 2
            self._saved = -1
        return self

    def __exit__(self, *exc: object) -> None:
        if self._saved < 0:  # pragma: no cover
            return
        os.dup2(self._saved, 2)
        os.close(self._saved)
        self._file.seek(0)
        raw = self._file.read(65536).decode("utf-8", "replace")
        self._file.close()
        lines = [
            ln.strip()
            for ln in raw.splitlines()
            if ln.strip() and not ln.strip().startswith("at line")
        ]
        self.text = "; ".join(lines[:3])


@njit(cache=True)
def _batch_world(p, q, rot, pos):  # type: ignore[no-untyped-def]  # pragma: no cover
    work = np.empty((D.WORK_ROWS, q.shape[1]))
    for b in range(q.shape[0]):
        SK.kinematics_into(p, q[b], work)
        SK.world_into(p, q.shape[1], work, rot[b], pos[b])


class SerialArm(ArmModel):
    """An immutable fixed-base serial arm of revolute and prismatic joints (spatial dynamics).

    Build one with :meth:`from_urdf` (or :func:`slidingarm.robots.load`). The parameter table
    is that of :mod:`slidingarm.models._spatial`: per joint, its placement in the parent body,
    its axis and kind, and the spatial inertia of the body it moves.

    Parameters
    ----------
    table : array_like, shape (26, n)
        The kernel's parameter table (see :mod:`slidingarm.models._spatial`).
    gravity : float
        Gravity magnitude (m/s²) along ``-z`` of the root frame.
    name : str
        The robot's name.
    joints : sequence of str
        Joint names, root to tip.
    types : sequence of str
        ``"revolute"``, ``"continuous"`` or ``"prismatic"`` per joint.
    links : sequence of str
        The link each joint moves (the body's name).
    frames : mapping of str to (int, rotation (3, 3), origin (3,))
        Every link's frame: the body it is fixed to (``-1`` for the root) and its placement in
        that body's frame.
    tool : str
        The frame of the tool: forward kinematics' default and where a payload goes.
    limits : mapping of str to array_like (n,), optional
        ``lower``, ``upper`` (rad or m), ``effort`` (N·m or N), ``velocity``; ``±inf`` where
        the file sets none.
    root : str
        The root link's name.
    """

    KIND = D.KIND_SERIAL

    _table: FloatArray
    _gravity: float
    _name: str
    _joints: tuple[str, ...]
    _types: tuple[str, ...]
    _links: tuple[str, ...]
    _frames: dict[str, tuple[int, FloatArray, FloatArray]]
    _tool: str
    _limits: dict[str, FloatArray]
    _root: str

    def __init__(
        self,
        table: ArrayLike,
        *,
        gravity: float = 9.81,
        name: str = "robot",
        joints: Sequence[str],
        types: Sequence[str],
        links: Sequence[str],
        frames: Mapping[str, tuple[int, ArrayLike, ArrayLike]],
        tool: str,
        limits: Mapping[str, ArrayLike] | None = None,
        root: str = "base",
    ) -> None:
        arr = np.array(number_array("table", table), dtype=float)
        if arr.ndim != 2 or arr.shape[0] != SK.ROWS or arr.shape[1] < 1:
            raise ValueError(f"table must have shape ({SK.ROWS}, n) with n >= 1, got {arr.shape}")
        if not np.all(np.isfinite(arr)):
            raise ValueError("table must be finite")
        n = arr.shape[1]
        for label, seq in (("joints", joints), ("types", types), ("links", links)):
            if len(seq) != n or not all(isinstance(s, str) for s in seq):
                raise ValueError(f"{label} must be {n} names, got {list(seq)!r}")
        bad = [t for t in types if t not in JOINT_TYPES]
        if bad:
            raise ValueError(f"joint types must be among {JOINT_TYPES}, got {bad}")
        for i in range(n):
            ax = arr[SK.P_AXIS : SK.P_AXIS + 3, i]
            if abs(np.linalg.norm(ax) - 1.0) > 1e-9:
                raise ValueError(f"joint {joints[i]!r}: axis {ax.tolist()} is not a unit vector")
            if (arr[SK.P_TYPE, i] == 1.0) != (types[i] == "prismatic"):
                raise ValueError(f"joint {joints[i]!r}: its table kind disagrees with {types[i]!r}")
            if arr[SK.P_MASS, i] < 0:
                raise ValueError(f"link {links[i]!r} has a negative mass {arr[SK.P_MASS, i]}")
        g = real("gravity", gravity, low=0.0, high=MAX_GRAVITY)
        fr: dict[str, tuple[int, FloatArray, FloatArray]] = {}
        for key, (body, rot, org) in frames.items():
            r = np.array(rot, dtype=float).reshape(3, 3)
            o = np.array(org, dtype=float).reshape(3)
            if not -1 <= int(body) < n:
                raise ValueError(f"frame {key!r} is fixed to body {body}, not one of -1..{n - 1}")
            r.setflags(write=False)
            o.setflags(write=False)
            fr[str(key)] = (int(body), r, o)
        if tool not in fr:
            raise ValueError(f"tool frame {tool!r} is not a link of {name!r}; links: {sorted(fr)}")
        lim: dict[str, FloatArray] = {}
        for key in ("lower", "upper", "effort", "velocity"):
            default = -math.inf if key == "lower" else math.inf
            value = (
                np.full(n, default)
                if limits is None or key not in limits
                else np.array(limits[key], dtype=float)
            )
            if value.shape != (n,):
                raise ValueError(f"limits[{key!r}] must have {n} values, got shape {value.shape}")
            value.setflags(write=False)
            lim[key] = value
        arr.setflags(write=False)
        set_ = object.__setattr__
        set_(self, "_table", arr)
        set_(self, "_gravity", g)
        set_(self, "_name", str(name))
        set_(self, "_joints", tuple(joints))
        set_(self, "_types", tuple(types))
        set_(self, "_links", tuple(links))
        set_(self, "_frames", fr)
        set_(self, "_tool", tool)
        set_(self, "_limits", lim)
        set_(self, "_root", str(root))

    def __setattr__(self, name: str, value: object) -> None:
        raise AttributeError(f"SerialArm is immutable; cannot set {name!r}")

    def __reduce__(self) -> tuple[object, ...]:
        return (_rebuild, (self.to_dict(),))

    # ------------------------------------------------------------------ constructors
    @classmethod
    def from_urdf(
        cls, source: str | os.PathLike[str], *, gravity: float = 9.81, tool: str | None = None
    ) -> SerialArm:
        """Load a serial arm from a URDF file or URDF text.

        Parameters
        ----------
        source : str or path-like
            A path to a ``.urdf`` file, or the URDF text itself (a string starting with ``<``).
        gravity : float
            Gravity magnitude (m/s²), along ``-z`` of the URDF's root link (URDF's convention).
        tool : str, optional
            The tool frame's link; by default the link deepest below the last moving body
            (the first in the file of equally deep ones).

        Raises
        ------
        ValueError
            If the file cannot be read, is not a URDF, has no moving joint, or has a floating,
            planar, spherical, mimic or unknown joint or a branching tree (naming the joint).

        Notes
        -----
        Joint ``<dynamics>`` (damping, friction) and position limits are not part of the
        dynamics; the limits are kept in :attr:`limits`.
        """
        text, _, where = read_model_text(source, "URDF")
        robot, urdf_joints = _parse_joints(text, where)
        import pinocchio as pin

        cause = ""
        with _CapturedStderr() as err:
            try:
                model = pin.buildModelFromXML(text)
            except Exception as exc:  # Pinocchio raises plain RuntimeErrors
                model = None
                cause = str(exc)
        if model is None:
            raise ValueError(f"{where} could not be read as a URDF: {err.text or cause}")
        n = model.njoints - 1
        if n < 1:
            raise ValueError(f"{where} has no moving joint (revolute, continuous or prismatic)")
        table = np.zeros((SK.ROWS, n))
        q_neutral = pin.neutral(model)
        names: list[str] = []
        types: list[str] = []
        for i in range(1, n + 1):
            jname = str(model.names[i])
            if model.parents[i] != i - 1:
                raise ValueError(
                    f"joint {jname!r} of {where} branches off joint "
                    f"{model.names[model.parents[i]]!r}, which already has a moving child; "
                    "slidingarm models serial chains only"
                )
            kind, axis = _pin_axis(model.joints[i], q_neutral, jname, where)
            placement = model.jointPlacements[i]
            table[0:9, i - 1] = np.asarray(placement.rotation).reshape(9)
            table[9:12, i - 1] = np.asarray(placement.translation)
            table[SK.P_AXIS : SK.P_AXIS + 3, i - 1] = axis
            table[SK.P_TYPE, i - 1] = 1.0 if kind == "prismatic" else 0.0
            inertia = model.inertias[i]
            _set_inertia(
                table,
                i - 1,
                float(inertia.mass),
                np.asarray(inertia.lever),
                np.asarray(inertia.inertia),
            )
            names.append(jname)
            types.append(urdf_joints[jname]["type"] if jname in urdf_joints else kind)
        frames: dict[str, tuple[int, FloatArray, FloatArray]] = {}
        depth: dict[int, int] = {}
        links: list[str] = [""] * n
        for fid, frame in enumerate(model.frames):
            depth[fid] = 0 if fid == 0 else depth.get(int(frame.parentFrame), 0) + 1
            if frame.type != pin.FrameType.BODY:
                continue
            body = int(frame.parentJoint) - 1
            # a link moved by a joint sits at that joint's frame; note the first one as its body
            if body >= 0 and not links[body]:
                links[body] = str(frame.name)
            frames[str(frame.name)] = (
                body,
                np.asarray(frame.placement.rotation).copy(),
                np.asarray(frame.placement.translation).copy(),
            )
        root = next((str(f.name) for f in model.frames if f.type == pin.FrameType.BODY), "base")
        if tool is None:
            best = -1
            tool_name = links[-1]
            for fid, frame in enumerate(model.frames):
                if (
                    frame.type == pin.FrameType.BODY
                    and int(frame.parentJoint) == n
                    and depth[fid] > best
                ):
                    best = depth[fid]
                    tool_name = str(frame.name)
        else:
            if not isinstance(tool, str):
                raise ParameterTypeError(f"tool must be a link name, got {tool!r}")
            if tool not in frames:
                raise ValueError(
                    f"tool {tool!r} is not a link of {where}; its links are {sorted(frames)}"
                )
            tool_name = tool
        limits = {
            key: np.array(
                [
                    urdf_joints[j][key]
                    if j in urdf_joints
                    else (-math.inf if key == "lower" else math.inf)
                    for j in names
                ]
            )
            for key in ("lower", "upper", "effort", "velocity")
        }
        return cls(
            table,
            gravity=gravity,
            name=robot,
            joints=names,
            types=types,
            links=links,
            frames=frames,
            tool=tool_name,
            limits=limits,
            root=root,
        )

    def replace(self, **changes: object) -> SerialArm:
        """A new arm with ``gravity``, ``tool`` or ``name`` changed (validated again)."""
        allowed = {"gravity", "tool", "name"}
        unknown = sorted(set(changes) - allowed)
        if unknown:
            raise TypeError(
                f"SerialArm.replace() got unknown parameter(s) {unknown}; allowed: {sorted(allowed)}"
            )
        return self._with(
            self._table,
            gravity=changes.get("gravity", self._gravity),
            tool=changes.get("tool", self._tool),
            name=changes.get("name", self._name),
        )

    def _with(
        self,
        table: FloatArray,
        *,
        frames: Mapping[str, tuple[int, ArrayLike, ArrayLike]] | None = None,
        **kw: Any,
    ) -> SerialArm:
        args: dict[str, Any] = {
            "gravity": self._gravity, "name": self._name, "joints": self._joints, "types": self._types,
            "links": self._links, "frames": self._frames if frames is None else frames, "tool": self._tool,
            "limits": self._limits, "root": self._root,
        }  # fmt: skip
        args.update(kw)
        return SerialArm(table, **args)

    # ------------------------------------------------------------------ model changes
    def with_payload(self, mass: float, *, link: str | None = None) -> SerialArm:
        """The arm with a point ``mass`` (kg) at the origin of ``link``'s frame (default: the
        tool frame), added to the body that link is fixed to:
        :math:`m' = m + p`, :math:`h' = h + p\\,o`, :math:`I_o' = I_o + p(|o|^2 1 - o o^T)`,
        with :math:`o` the point in the body's frame."""
        if not is_real(mass):
            raise ParameterTypeError(f"payload mass must be a number (kg), got {mass!r}")
        p = _float(mass)
        if not np.isfinite(p) or p < 0 or p > MAX_MASS:
            raise ValueError(f"payload mass must be >= 0 and <= {MAX_MASS:g} kg, got {mass!r}")
        name = self._tool if link is None else link
        if not isinstance(name, str) or name not in self._frames:
            raise ValueError(
                f"payload link {name!r} is not a link of {self._name!r}; links: {sorted(self._frames)}"
            )
        body, _, org = self._frames[name]
        if body < 0:
            raise ValueError(
                f"payload link {name!r} is fixed to the root; a payload there changes nothing"
            )
        table = self._table.copy()
        m, c, ic = _get_inertia(table, body)
        h = m * c + p * org
        mn = m + p
        io = _io(m, c, ic) + p * (float(org @ org) * np.eye(3) - np.outer(org, org))
        _set_io(table, body, mn, h, io)
        return self._with(table)

    def scaled(self, *, mass: ArrayLike = 1.0, length: ArrayLike = 1.0) -> SerialArm:
        """The arm with each body's mass and inertia multiplied by ``mass`` and its size by
        ``length`` (scalars or per body).

        A length factor ``f`` of body ``i`` scales the offsets inside it — the next joint's
        origin, its centre of mass, the frames fixed to it — and its centroidal inertia by
        ``f²`` (with the mass factor: ``m f²``), as :meth:`PlanarArm.scaled` does.
        """
        fm = _factors("mass scale", mass, self.n)
        fl = _factors("length scale", length, self.n)
        table = self._table.copy()
        for i in range(self.n):
            m, c, ic = _get_inertia(table, i)
            _set_inertia(table, i, m * fm[i], c * fl[i], ic * fm[i] * fl[i] ** 2)
            if i + 1 < self.n:
                table[9:12, i + 1] *= fl[i]
        frames = {
            k: (b, r, o * (fl[b] if b >= 0 else 1.0)) for k, (b, r, o) in self._frames.items()
        }
        return self._with(table, frames=frames)

    # ------------------------------------------------------------------ parameters
    @property
    def n(self) -> int:
        return int(self._table.shape[1])

    @property
    def gravity(self) -> float:
        return float(self._gravity)

    @property
    def params(self) -> FloatArray:
        """The kind's table: the ``(26, n)`` physical rows in joint-aligned body frames
        (:func:`slidingarm.models._spatial.aligned` of :attr:`table`: every joint axis is its
        body's ``+z``, what the kernels take) and, in column 0 of the rows below, the
        addresses of the serial kind's compiled kernels (looked up, and on the first arm
        compiled, when first asked for; never pickled)."""
        cached: FloatArray | None = getattr(self, "_kernel_table", None)
        if cached is None:
            cached = np.zeros((SK.ROWS + len(D.SERIAL_SIGNATURES), self.n))
            cached[: SK.ROWS] = self._aligned()[0]
            cached[SK.P_FN :, 0] = D.serial_addresses()
            cached.setflags(write=False)
            object.__setattr__(self, "_kernel_table", cached)
        return cached

    def _aligned(self) -> tuple[FloatArray, FloatArray]:
        """The table in joint-aligned body frames and those frames (:func:`SK.aligned`),
        computed once."""
        cached: tuple[FloatArray, FloatArray] | None = getattr(self, "_aligned_table", None)
        if cached is None:
            table, frames = SK.aligned(self._table)
            table.setflags(write=False)
            frames.setflags(write=False)
            cached = (table, frames)
            object.__setattr__(self, "_aligned_table", cached)
        return cached

    @property
    def table(self) -> FloatArray:
        """The ``(26, n)`` physical parameter table (:mod:`slidingarm.models._spatial`)."""
        return self._table

    @property
    def name(self) -> str:
        """The robot's name."""
        return str(self._name)

    @property
    def joint_names(self) -> tuple[str, ...]:
        """The moving joints' names, root to tip."""
        return self._joints

    @property
    def joint_types(self) -> tuple[str, ...]:
        """``"revolute"``, ``"continuous"`` or ``"prismatic"`` per joint."""
        return self._types

    @property
    def link_names(self) -> tuple[str, ...]:
        """The link each joint moves."""
        return self._links

    @property
    def frame_names(self) -> tuple[str, ...]:
        """Every link frame (fixed links included)."""
        return tuple(self._frames)

    @property
    def tool(self) -> str:
        """The tool frame's link."""
        return str(self._tool)

    @property
    def limits(self) -> dict[str, FloatArray]:
        """``lower``, ``upper``, ``effort``, ``velocity`` per joint (``±inf`` where unset)."""
        return dict(self._limits)

    @property
    def masses(self) -> FloatArray:
        """Each body's mass (kg), fixed links merged in."""
        return self._table[SK.P_MASS].copy()

    @property
    def total_mass(self) -> float:
        """Mass of everything that moves (kg)."""
        return float(self._table[SK.P_MASS].sum())

    def to_dict(self) -> dict[str, Any]:
        return {
            "kind": "serial",
            "name": self._name,
            "gravity": self.gravity,
            "joints": list(self._joints),
            "types": list(self._types),
            "links": list(self._links),
            "root": self._root,
            "tool": self._tool,
            "table": self._table.tolist(),
            "frames": {k: [b, r.tolist(), o.tolist()] for k, (b, r, o) in self._frames.items()},
            "limits": {k: v.tolist() for k, v in self._limits.items()},
        }

    def __repr__(self) -> str:
        return f"SerialArm({self._name!r}, n={self.n}, mass={self.total_mass:.4g} kg, tool={self._tool!r})"

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, SerialArm):
            return NotImplemented
        a, b = self.to_dict(), other.to_dict()
        return a == b

    def __hash__(self) -> int:
        return hash((self._name, self._joints, self._table.tobytes()))

    # ------------------------------------------------------------------ kinematics
    def body_poses(self, q: ArrayLike) -> tuple[FloatArray, FloatArray]:
        """Each body frame's origin ``(.., n, 3)`` and rotation ``(.., n, 3, 3)`` in the root
        frame: :math:`R_{0i} = R_{0,i-1} R_{0,i}^{(0)} \\mathrm{Rot}(a_i, q_i)`."""
        (qa,), single = self._states(q=q)
        rot = np.empty((qa.shape[0], self.n, 3, 3))
        pos = np.empty((qa.shape[0], self.n, 3))
        table, frames = self._aligned()
        _batch_world(table, qa, rot, pos)
        rot = rot @ np.swapaxes(frames, -1, -2)  # the aligned frames turned back, R_0i' Q_i^T
        return (pos[0], rot[0]) if single else (pos, rot)

    def frame_pose(self, q: ArrayLike, frame: str | None = None) -> tuple[FloatArray, FloatArray]:
        """Position ``(3,)``/``(B, 3)`` and rotation ``(3, 3)``/``(B, 3, 3)`` of a link frame
        (default: the tool) in the root frame."""
        name = self._tool if frame is None else frame
        if not isinstance(name, str) or name not in self._frames:
            raise ValueError(
                f"frame {name!r} is not a link of {self._name!r}; links: {sorted(self._frames)}"
            )
        body, r, o = self._frames[name]
        pos, rot = self.body_poses(q)
        if body < 0:
            shape = pos.shape[:-2]
            return np.broadcast_to(o, (*shape, 3)).copy(), np.broadcast_to(r, (*shape, 3, 3)).copy()
        pb = pos[..., body, :]
        rb = rot[..., body, :, :]
        return pb + rb @ o, rb @ r

    def tool_position(self, q: ArrayLike) -> FloatArray:
        """The tool frame's origin in the root frame, ``(3,)`` or ``(B, 3)``."""
        return self.frame_pose(q)[0]

    def joint_positions(self, q: ArrayLike) -> FloatArray:
        """The root, each body frame's origin and the tool, ``(n + 2, 3)`` or ``(B, n + 2, 3)``:
        the arm's polyline for plots."""
        pos, _ = self.body_poses(q)
        tool = self.tool_position(q)
        root = np.zeros_like(tool)
        return np.concatenate([root[..., None, :], pos, tool[..., None, :]], axis=-2)

    # ------------------------------------------------------------------ exports
    def _frame_children(self) -> dict[int, list[str]]:
        out: dict[int, list[str]] = {}
        for k, (b, _, _) in self._frames.items():
            if k == self._root or (0 <= b and k == self._links[b]):
                continue
            out.setdefault(b, []).append(k)
        return out

    def to_urdf(self, name: str | None = None) -> str:
        """URDF text of this arm (after any payload or scaling): one link per body with its
        merged inertial, its moving joint, and the fixed links as massless fixed children."""
        parts = [
            f'<?xml version="1.0"?>\n<robot name="{name or self._name}">',
            f'  <link name="{self._root}"/>',
        ]
        extra = self._frame_children()
        lim = self._limits
        for i in range(self.n):
            parent = self._root if i == 0 else self._links[i - 1]
            rot = self._table[0:9, i].reshape(3, 3)
            kind = self._types[i]
            limit = ""
            if kind != "continuous":
                lo, hi = lim["lower"][i], lim["upper"][i]
                lo = -1e6 if not np.isfinite(lo) else lo
                hi = 1e6 if not np.isfinite(hi) else hi
                eff = lim["effort"][i] if np.isfinite(lim["effort"][i]) else 1e6
                vel = lim["velocity"][i] if np.isfinite(lim["velocity"][i]) else 1e6
                limit = f'\n    <limit lower="{_num(lo)}" upper="{_num(hi)}" effort="{_num(eff)}" velocity="{_num(vel)}"/>'
            parts.append(
                f'  <joint name="{self._joints[i]}" type="{kind}">\n'
                f'    <parent link="{parent}"/>\n    <child link="{self._links[i]}"/>\n'
                f'    <origin xyz="{_vec(self._table[9:12, i])}" rpy="{_vec(_rpy(rot))}"/>\n'
                f'    <axis xyz="{_vec(self._table[SK.P_AXIS : SK.P_AXIS + 3, i])}"/>{limit}\n  </joint>'
            )
            m, c, ic = _get_inertia(self._table, i)
            parts.append(
                f'  <link name="{self._links[i]}">\n    <inertial>\n'
                f'      <origin xyz="{_vec(c)}" rpy="0 0 0"/>\n      <mass value="{_num(m)}"/>\n'
                f'      <inertia ixx="{_num(ic[0, 0])}" ixy="{_num(ic[0, 1])}" ixz="{_num(ic[0, 2])}" '
                f'iyy="{_num(ic[1, 1])}" iyz="{_num(ic[1, 2])}" izz="{_num(ic[2, 2])}"/>\n'
                "    </inertial>\n  </link>"
            )
        for body, names in sorted(extra.items()):
            parent = self._root if body < 0 else self._links[body]
            for k in names:
                _, r, o = self._frames[k]
                parts.append(
                    f'  <joint name="{k}_fixed" type="fixed">\n    <parent link="{parent}"/>\n'
                    f'    <child link="{k}"/>\n    <origin xyz="{_vec(o)}" rpy="{_vec(_rpy(r))}"/>\n'
                    f'  </joint>\n  <link name="{k}"/>'
                )
        parts.append("</robot>\n")
        return "\n".join(parts)

    def to_mjcf(self, name: str | None = None, timestep: float = 5e-4) -> str:
        """MJCF text of this arm for MuJoCo: gravity ``(0, 0, -g)``, RK4, contacts disabled,
        hinge/slide joints without damping, armature or limits, each body's merged inertia
        (``fullinertia`` about its centre of mass), the tool as a site. Principal inertias
        below :data:`~slidingarm.models.planar.MUJOCO_MIN_INERTIA` are raised to it (MuJoCo
        rejects zero ones; ``M`` changes by less than ``n`` times that)."""
        from slidingarm.models.planar import MUJOCO_MIN_INERTIA

        lines = [
            f'<mujoco model="{name or self._name}">',
            '  <compiler angle="radian" inertiafromgeom="false"/>',
            f'  <option gravity="0 0 {_num(-self._gravity)}" timestep="{_num(timestep)}" integrator="RK4">',
            '    <flag contact="disable"/>',
            "  </option>",
            "  <worldbody>",
        ]
        indent = "    "
        for i in range(self.n):
            rot = self._table[0:9, i].reshape(3, 3)
            lines.append(
                f'{indent}<body name="{self._links[i]}" pos="{_vec(self._table[9:12, i])}" quat="{_vec(_quat(rot))}">'
            )
            kind = "slide" if self._types[i] == "prismatic" else "hinge"
            lines.append(
                f'{indent}  <joint name="{self._joints[i]}" type="{kind}" axis="{_vec(self._table[SK.P_AXIS : SK.P_AXIS + 3, i])}" '
                'damping="0" armature="0" frictionloss="0" limited="false"/>'
            )
            m, c, ic = _get_inertia(self._table, i)
            w, v = np.linalg.eigh(ic)
            ic = (v * np.maximum(w, MUJOCO_MIN_INERTIA)) @ v.T
            lines.append(
                f'{indent}  <inertial pos="{_vec(c)}" mass="{_num(max(m, MUJOCO_MIN_INERTIA))}" '
                f'fullinertia="{_vec((ic[0, 0], ic[1, 1], ic[2, 2], ic[0, 1], ic[0, 2], ic[1, 2]))}"/>'
            )
            if i == self.n - 1 or self._frames[self._tool][0] == i:
                body, r, o = self._frames[self._tool]
                if body == i:
                    lines.append(
                        f'{indent}  <site name="tool" pos="{_vec(o)}" quat="{_vec(_quat(r))}"/>'
                    )
            indent += "  "
        for _ in range(self.n):
            indent = indent[:-2]
            lines.append(f"{indent}</body>")
        lines += ["  </worldbody>", "</mujoco>", ""]
        return "\n".join(lines)


def _io(m: float, c: FloatArray, ic: FloatArray) -> FloatArray:
    """Inertia about the frame's origin: :math:`I_o = I_c + m(|c|^2 1 - c c^T)`."""
    return ic + m * (float(c @ c) * np.eye(3) - np.outer(c, c))


def _set_io(table: FloatArray, i: int, m: float, h: FloatArray, io: FloatArray) -> None:
    table[SK.P_MASS, i] = m
    table[SK.P_H : SK.P_H + 3, i] = h
    table[SK.P_IO : SK.P_IO + 6, i] = (io[0, 0], io[1, 1], io[2, 2], io[0, 1], io[0, 2], io[1, 2])


def _set_inertia(table: FloatArray, i: int, m: float, c: FloatArray, ic: FloatArray) -> None:
    """Store a body of mass ``m``, centre of mass ``c`` and centroidal inertia ``ic``."""
    _set_io(
        table,
        i,
        m,
        m * np.asarray(c, dtype=float),
        _io(m, np.asarray(c, dtype=float), np.asarray(ic, dtype=float)),
    )


def _get_inertia(table: FloatArray, i: int) -> tuple[float, FloatArray, FloatArray]:
    """``(m, c, I_c)`` of body ``i`` (``c = 0`` for a massless body)."""
    m = float(table[SK.P_MASS, i])
    h = table[SK.P_H : SK.P_H + 3, i].copy()
    xx, yy, zz, xy, xz, yz = table[SK.P_IO : SK.P_IO + 6, i]
    io = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
    c = h / m if m > 0 else np.zeros(3)
    return m, c, io - m * (float(c @ c) * np.eye(3) - np.outer(c, c))


def _factors(name: str, value: ArrayLike, n: int) -> FloatArray:
    try:
        arr = np.atleast_1d(number_array(name, value)).astype(float)
    except ParameterTypeError:
        raise ParameterTypeError(f"{name} must be a number or {n} numbers, got {value!r}") from None
    if arr.ndim != 1 or arr.shape[0] not in (1, n):
        raise ValueError(f"{name} must be one value or {n} (one per body), got shape {arr.shape}")
    if not np.all(np.isfinite(arr)) or np.any(arr <= 0) or np.any(arr > MAX_SCALE):
        raise ValueError(
            f"{name} factors must be > 0 and <= {MAX_SCALE:g} (a model off by more than "
            f"{MAX_SCALE:g}x is not a model error), got {arr.tolist()}"
        )
    return np.broadcast_to(arr, (n,)).copy()


def _rebuild(d: dict[str, Any]) -> SerialArm:
    """Unpickle a :class:`SerialArm` (module level, so that pickle finds it)."""
    return SerialArm(
        d["table"],
        gravity=d["gravity"],
        name=d["name"],
        joints=d["joints"],
        types=d["types"],
        links=d["links"],
        frames={k: (v[0], v[1], v[2]) for k, v in d["frames"].items()},
        tool=d["tool"],
        limits=d["limits"],
        root=d["root"],
    )
