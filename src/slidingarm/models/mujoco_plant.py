"""MuJoCo as an independent plant: a URDF or MJCF model stepped by MuJoCo's own integrator.

:class:`MujocoPlant` is a :class:`~slidingarm.models.SteppedPlant`: :func:`slidingarm.simulate`
and :func:`slidingarm.simulate_batch` call its ``step(q, qd, tau, h)`` ``substeps`` times per
control period with ``tau`` held (zero-order hold). The controller keeps its own nominal model;
MuJoCo computes the real arm's motion from the model file alone, so a closed loop run against
it checks the compiled plant with a second, independent dynamics engine.

``mujoco`` is imported when a plant is first built, never by ``import slidingarm``.
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from slidingarm._io import read_model_text
from slidingarm._validate import ParameterTypeError, real
from slidingarm.models.planar import MUJOCO_MIN_INERTIA
from slidingarm.models.stepped import SteppedPlant

__all__ = ["Integrator", "MujocoPlant"]

FloatArray = NDArray[np.float64]
Format = Literal["urdf", "mjcf"]

#: MuJoCo's integrators, by their MJCF names (``<option integrator="...">``).
Integrator = Literal["Euler", "RK4", "implicit", "implicitfast", "discrete"]

# MJCF name -> mjtIntegrator member; "discrete" only where this MuJoCo has it.
_INTEGRATORS = {
    "Euler": "mjINT_EULER",
    "RK4": "mjINT_RK4",
    "implicit": "mjINT_IMPLICIT",
    "implicitfast": "mjINT_IMPLICITFAST",
    "discrete": "mjINT_DISCRETE",
}

# MuJoCo prints each of these warnings once per MjData on stdout; a divergence is reported by
# the loop instead (with its time and joint), so they are marked as already shown.
_QUIET_WARNINGS = ("mjWARN_BADQACC", "mjWARN_BADQPOS", "mjWARN_BADQVEL")


def _mujoco() -> Any:
    """The ``mujoco`` module, imported on first use (it costs ~0.1 s)."""
    try:
        import mujoco
    except ImportError as err:  # pragma: no cover - mujoco is a default dependency
        raise ImportError(
            "MujocoPlant needs the mujoco package: pip install 'mujoco>=4,<5'"
        ) from err
    return mujoco


# ---------------------------------------------------------------------- reading the source
def _root(text: str, label: str, tag: str) -> Any:
    """The parsed root element of ``text``, checked to be ``<tag>``."""
    import xml.etree.ElementTree as ET

    try:
        root = ET.fromstring(text)
    except ET.ParseError as err:
        raise ValueError(f"{label} is not valid XML: {err}") from None
    if root.tag != tag:
        what, other = ("URDF", "from_mjcf") if tag == "robot" else ("MJCF", "from_urdf")
        raise ValueError(
            f"{label} has the root element <{root.tag}>, but {what} starts with <{tag}> "
            f"(is it for {other}?)"
        )
    return root


def _prepare_urdf(text: str, label: str) -> str:
    """The URDF MuJoCo compiles: no ``<visual>`` or ``<collision>`` (no meshes are needed), a
    ``<mujoco><compiler>`` that fuses static links and bounds inertias below by
    :data:`MUJOCO_MIN_INERTIA`; a ``<mimic>`` joint is refused."""
    import xml.etree.ElementTree as ET

    root = _root(text, label, "robot")
    for joint in root.iter("joint"):
        mimic = joint.find("mimic")
        if mimic is not None:
            raise ValueError(
                f"{label}: joint {joint.get('name')!r} mimics joint {mimic.get('joint')!r} (an "
                "equality constraint); MujocoPlant needs independent joints, one torque each"
            )
    for parent in root.iter():
        for child in list(parent):
            if child.tag in ("visual", "collision"):
                parent.remove(child)
    extension = root.find("mujoco")
    if extension is None:
        extension = ET.SubElement(root, "mujoco")
    compiler = extension.find("compiler")
    if compiler is None:
        compiler = ET.SubElement(extension, "compiler")
    try:
        bound = max(float(compiler.get("boundinertia", "0")), MUJOCO_MIN_INERTIA)
    except ValueError:
        raise ValueError(f"{label}: <mujoco><compiler boundinertia> must be a number, got {compiler.get('boundinertia')!r}") from None  # fmt: skip
    compiler.set("boundinertia", repr(bound))
    compiler.set("discardvisual", compiler.get("discardvisual", "true"))
    compiler.set("fusestatic", compiler.get("fusestatic", "true"))
    return ET.tostring(root, encoding="unicode")


def _load_error(err: Exception, label: str) -> ValueError:
    """MuJoCo's compile error as a ValueError naming the file and, for a massless moving
    link, the link."""
    import re

    lines = [ln.strip() for ln in str(err).strip().splitlines() if ln.strip()]
    lines = [ln for ln in lines if not ln.startswith("The static bodies of the spec")]
    message = " ".join(lines).removeprefix("Error: ")
    if "mass and inertia of moving bodies" in message:
        found = re.search(r"Element name '([^']*)'", message)
        link = repr(found.group(1)) if found else "a link"
        return ValueError(
            f"{label}: link {link} moves (a joint carries it) but has no mass: MuJoCo needs a "
            f"mass > {_mujoco().mjMINVAL:g} kg on every moving body (zero inertias are raised "
            f"to {MUJOCO_MIN_INERTIA:g}, masses never are) [MuJoCo: {message}]"
        )
    return ValueError(f"MuJoCo cannot load {label}: {message}")


# ---------------------------------------------------------------------- the plant
class MujocoPlant(SteppedPlant):
    """A robot model simulated by MuJoCo, torque in, joint state out.

    Build it with :meth:`from_urdf`, :meth:`from_mjcf` or :meth:`from_model`. One call of
    :meth:`step` is one ``mujoco.mj_step`` of length ``h`` with the generalized force
    ``qfrc_applied = tau``:

    .. math:: M(q)\\ddot q + C(q, \\dot q)\\dot q + G(q) = \\tau + \\tau_{passive}(q, \\dot q)
              + J^\\top f_{limit},

    where :math:`\\tau_{passive}` holds only what the model file declares (joint damping,
    springs, armature in :math:`M`, friction loss; URDF ``<dynamics damping friction>`` is
    kept as written) and :math:`f_{limit}` is present only with ``limits=True``.

    Semantics, whatever the file says:

    - no contacts (``mjDSBL_CONTACT``); geometry only matters through inertias;
    - joint limits ignored unless ``limits=True`` (``mjDSBL_LIMIT``). slidingarm's own arms have
      no joint limits (:meth:`PlanarArm.to_urdf` writes ±1e6 rad only because URDF needs a
      range), so ``limits=False`` is the same arm;
    - actuators are off (``mjDSBL_ACTUATION``): ``tau`` is the joint torque, 1:1, and is not
      clipped by a URDF ``effort`` (torque limits are ``simulate``'s ``torque_limit``);
    - no constraint warm start (``mjDSBL_WARMSTART``) and no automatic reset on divergence
      (``mjDSBL_AUTORESET``): a step depends on ``(q, qd, tau, h)`` alone, and a diverged
      state stays non-finite, so that the loop reports it instead of MuJoCo silently
      restarting from ``qpos0``.

    The model must be a serial chain of ``n`` 1-dof hinge or slide joints (``nq == nv == n``,
    no equality constraints): ``q`` is MuJoCo's ``qpos`` and its dof order is checked to be
    the chain's order from the root (each dof's parent is the previous dof), so ``q[i]`` and
    ``tau[i]`` belong to the ``i``-th joint from the base.

    Instances are immutable and picklable (rebuilt from the model text and options; MuJoCo's
    own model and data are private to each copy).
    """

    __slots__ = (
        "_data",
        "_format",
        "_gravity",
        "_integrator",
        "_joint_names",
        "_label",
        "_limits",
        "_mj_step",
        "_model",
        "_model_name",
        "_opt",
        "_path",
        "_qfrc",
        "_qpos",
        "_qvel",
        "_sha256",
        "_text",
        "_timestep",
        "_urdf_gravity",
    )

    def __init__(
        self,
        fmt: Format,
        text: str,
        *,
        path: Path | None = None,
        label: str = "",
        gravity: float | None = None,
        limits: bool = False,
        integrator: str = "RK4",
    ) -> None:
        """Use :meth:`from_urdf`, :meth:`from_mjcf` or :meth:`from_model`."""
        mujoco = _mujoco()
        if fmt not in ("urdf", "mjcf"):
            raise ValueError(f"fmt must be 'urdf' or 'mjcf', got {fmt!r}")
        if not isinstance(limits, bool | np.bool_):
            raise ParameterTypeError(f"limits must be True or False, got {limits!r}")
        code = _integrator_code(mujoco, integrator)
        label = label or f"the {fmt.upper()} text"
        if fmt == "urdf":
            g = real("gravity", gravity, allowed="a finite number (m/s²)")
            compiled_text = _prepare_urdf(text, label)
            name = _root(text, label, "robot").get("name", "")
        else:
            g = None
            compiled_text = text
            name = _root(text, label, "mujoco").get("model", "")
        try:
            if path is not None and fmt == "mjcf":  # includes and assets relative to the file
                model = mujoco.MjModel.from_xml_path(str(path))
            else:
                model = mujoco.MjModel.from_xml_string(compiled_text)
        except Exception as err:  # MuJoCo raises ValueError, its own errors for others
            raise _load_error(err, label) from None
        names = _check_chain(mujoco, model, label)

        opt = model.opt
        opt.integrator = code
        off = mujoco.mjtDisableBit
        flags = int(opt.disableflags)
        flags |= int(off.mjDSBL_CONTACT) | int(off.mjDSBL_ACTUATION)
        flags |= int(off.mjDSBL_WARMSTART) | int(off.mjDSBL_AUTORESET)
        flags = flags & ~int(off.mjDSBL_LIMIT) if limits else flags | int(off.mjDSBL_LIMIT)
        opt.disableflags = flags
        if g is not None:
            opt.gravity[:] = (0.0, 0.0, -g)
        data = mujoco.MjData(model)
        for warning in _QUIET_WARNINGS:
            data.warning[int(getattr(mujoco.mjtWarning, warning))].number = 1

        self._format: Format = fmt
        self._text = text
        self._path = path
        self._label = label
        self._model_name = name
        self._sha256 = _sha256(text)
        self._urdf_gravity = g
        self._gravity = tuple(float(x) for x in opt.gravity)
        self._limits = bool(limits)
        self._integrator = integrator
        self._joint_names = names
        self._model = model
        self._opt = opt
        self._mj_step = mujoco.mj_step
        self._timestep = float(opt.timestep)
        # views into MjData's buffers, valid while the data lives
        self._qpos = data.qpos
        self._qvel = data.qvel
        self._qfrc = data.qfrc_applied
        self._data = data  # last: from here on the instance is immutable

    # ------------------------------------------------------------------ constructors
    @classmethod
    def from_urdf(
        cls,
        source: str | os.PathLike[str],
        *,
        gravity: float = 9.81,
        limits: bool = False,
        integrator: Integrator = "RK4",
    ) -> MujocoPlant:
        """The arm of a URDF file or text, compiled by MuJoCo's URDF import.

        ``<visual>`` and ``<collision>`` elements are dropped first (no meshes are needed),
        static links are fused into their parents, and principal inertias below
        :data:`~slidingarm.models.planar.MUJOCO_MIN_INERTIA` (1e-12 kg m²) are raised to it
        (``<compiler boundinertia>``; MuJoCo refuses a moving body with a zero inertia, and
        point masses have one). That changes each diagonal entry of ``M`` by less than
        ``n · 1e-12``.

        Parameters
        ----------
        source : str or os.PathLike
            A path (relative to the working directory) or the URDF text (starting with ``<``).
        gravity : float
            :math:`g` (m/s²), along ``-z`` of the root link (URDF's convention):
            gravity vector ``(0, 0, -g)``.
        limits : bool
            Enforce the URDF joint limits (``<limit lower upper>``) as MuJoCo constraints.
        integrator : {"RK4", "Euler", "implicit", "implicitfast", "discrete"}
            MuJoCo's integrator ("discrete" where this MuJoCo has it).

        Raises
        ------
        ValueError
            A missing or unreadable file, text that is not URDF, a ``<mimic>`` or floating
            joint, a massless moving link, a branched tree, a bad integrator name; the
            message names the file and the culprit.
        """
        text, path, label = read_model_text(source, "URDF")
        return cls(
            "urdf", text, path=path, label=label, gravity=gravity, limits=limits,
            integrator=integrator,
        )  # fmt: skip

    @classmethod
    def from_mjcf(
        cls,
        source: str | os.PathLike[str],
        *,
        limits: bool = False,
        integrator: Integrator = "RK4",
    ) -> MujocoPlant:
        """The arm of an MJCF file or text, with the file's own options (gravity, damping,
        ...) except the integrator, contacts, limits and actuators (see the class).

        A file is compiled from its path, so that its ``<include>`` and assets resolve
        relative to it; its pickles rebuild from the same path while the file is unchanged,
        else from the text.

        Parameters
        ----------
        source : str or os.PathLike
            A path (relative to the working directory) or the MJCF text (starting with ``<``).
        limits : bool
            Enforce the joints' ``range`` (those ``limited``) as MuJoCo constraints.
        integrator : {"RK4", "Euler", "implicit", "implicitfast", "discrete"}
            MuJoCo's integrator, replacing the file's.

        Raises
        ------
        ValueError
            As :meth:`from_urdf`, and for equality constraints, free or ball joints.
        """
        text, path, label = read_model_text(source, "MJCF")
        return cls("mjcf", text, path=path, label=label, limits=limits, integrator=integrator)

    @classmethod
    def from_model(cls, arm: Any) -> MujocoPlant:
        """The slidingarm model ``arm`` (one with ``to_mjcf()``, e.g. :class:`PlanarArm`)
        simulated by MuJoCo, RK4, no limits: the same arm up to the inertias ``to_mjcf``
        raises to :data:`~slidingarm.models.planar.MUJOCO_MIN_INERTIA`."""
        to_mjcf = getattr(arm, "to_mjcf", None)
        if not callable(to_mjcf):
            raise ParameterTypeError(
                f"arm must be a slidingarm model with to_mjcf() (PlanarArm, ...), got "
                f"{type(arm).__name__}"
            )
        return cls("mjcf", to_mjcf(), label=f"{type(arm).__name__}.to_mjcf()")

    # ------------------------------------------------------------------ the contract
    @property
    def n(self) -> int:
        """Number of joints."""
        return len(self._joint_names)

    def step(self, q: FloatArray, qd: FloatArray, tau: FloatArray, h: float) -> bool:
        """Advance ``(q, qd)`` (float64 (n,), in place) by one MuJoCo step of ``h`` seconds
        with the joint torques ``tau`` (n,); ``False`` if the new state is not finite."""
        if h != self._timestep:
            self._opt.timestep = h
            object.__setattr__(self, "_timestep", h)
        self._qpos[:] = q
        self._qvel[:] = qd
        self._qfrc[:] = tau
        self._mj_step(self._model, self._data)
        q[:] = self._qpos
        qd[:] = self._qvel
        # NaN and ±inf survive a sum (inf - inf is NaN); finite values overflow only near 1e308.
        # Summing Python floats is the cheapest test for n of a few joints (0.8 µs).
        return math.isfinite(sum(q.tolist()) + sum(qd.tolist()))

    def to_dict(self) -> dict[str, Any]:
        """Plain parameters: ``kind`` "mujoco", the format, source, model name, SHA-256 of
        the model text, ``n``, joint names and the options."""
        return {
            "kind": "mujoco",
            "format": self._format,
            "source": self._label,
            "model": self._model_name,
            "sha256": self._sha256,
            "n": self.n,
            "joints": list(self._joint_names),
            "gravity": list(self._gravity),
            "limits": self._limits,
            "integrator": self._integrator,
        }

    # ------------------------------------------------------------------ read-only facts
    @property
    def joint_names(self) -> tuple[str, ...]:
        """The joints, in ``q`` order (from the root)."""
        return self._joint_names

    @property
    def gravity(self) -> tuple[float, float, float]:
        """MuJoCo's gravity vector (m/s²)."""
        return self._gravity  # type: ignore[return-value]

    @property
    def limits(self) -> bool:
        """Whether joint limits are enforced."""
        return self._limits

    @property
    def integrator(self) -> str:
        """MuJoCo's integrator, by its MJCF name."""
        return self._integrator

    @property
    def format(self) -> str:
        """``"urdf"`` or ``"mjcf"``: what the model was read from."""
        return self._format

    @property
    def sha256(self) -> str:
        """SHA-256 (hex) of the model text as given."""
        return self._sha256

    def __setattr__(self, name: str, value: object) -> None:
        if hasattr(self, "_data"):
            raise AttributeError(f"MujocoPlant is immutable: cannot set {name!r}")
        object.__setattr__(self, name, value)

    def __reduce__(self) -> tuple[Any, ...]:
        return (
            _rebuild,
            (self._format, self._text, None if self._path is None else str(self._path),
             self._label, self._urdf_gravity, self._limits, self._integrator, self._sha256),
        )  # fmt: skip

    def __repr__(self) -> str:
        name = f" {self._model_name!r}" if self._model_name else ""
        return (
            f"MujocoPlant({self._format}{name}, n={self.n}, integrator={self._integrator!r}, "
            f"limits={self._limits}, gravity={self._gravity}, sha256={self._sha256[:12]})"
        )


def _sha256(text: str) -> str:
    import hashlib

    return hashlib.sha256(text.encode()).hexdigest()


def _integrator_code(mujoco: Any, integrator: object) -> int:
    known = {k: v for k, v in _INTEGRATORS.items() if hasattr(mujoco.mjtIntegrator, v)}
    if not isinstance(integrator, str) or integrator not in known:
        raise ValueError(
            f"integrator must be one of MuJoCo's {', '.join(map(repr, known))}, got {integrator!r}"
        )
    return int(getattr(mujoco.mjtIntegrator, known[integrator]))


def _check_chain(mujoco: Any, model: Any, label: str) -> tuple[str, ...]:
    """The joint names, after checking that ``model`` is a serial chain of 1-dof hinge or
    slide joints whose dof order is the chain's order from the root."""
    obj = mujoco.mjtObj

    def joint(j: int) -> str:
        name = mujoco.mj_id2name(model, obj.mjOBJ_JOINT, j)
        if name:
            return repr(name)
        body = mujoco.mj_id2name(model, obj.mjOBJ_BODY, int(model.jnt_bodyid[j])) or "?"
        return f"#{j} (of body {body!r})"

    kinds = mujoco.mjtJoint
    one_dof = (int(kinds.mjJNT_HINGE), int(kinds.mjJNT_SLIDE))
    what = {int(kinds.mjJNT_FREE): "a free (floating, 6-dof)", int(kinds.mjJNT_BALL): "a ball (3-dof)"}  # fmt: skip
    for j in range(model.njnt):
        kind = int(model.jnt_type[j])
        if kind not in one_dof:
            raise ValueError(
                f"{label}: joint {joint(j)} is {what.get(kind, f'a type-{kind}')} joint; "
                "MujocoPlant needs 1-dof hinge (revolute) or slide (prismatic) joints"
            )
    if model.njnt == 0:
        raise ValueError(f"{label} has no moving joint")
    if model.neq:
        eq = 0
        if int(model.eq_type[eq]) == int(mujoco.mjtEq.mjEQ_JOINT):
            culprit = f"joint {joint(int(model.eq_obj1id[eq]))}"
        else:
            culprit = repr(mujoco.mj_id2name(model, obj.mjOBJ_EQUALITY, eq) or f"#{eq}")
        raise ValueError(
            f"{label}: {culprit} is bound by an equality constraint ({model.neq} in all); "
            "MujocoPlant needs independent joints, one torque each"
        )
    assert model.nq == model.nv == model.njnt  # 1-dof joints only
    for j in range(model.njnt):
        d = int(model.jnt_dofadr[j])
        parent = int(model.dof_parentid[d])
        if d != j or int(model.jnt_qposadr[j]) != j or parent != j - 1:
            after = "the root" if j == 0 else f"joint {joint(j - 1)}"
            raise ValueError(
                f"{label}: joint {joint(j)} does not follow {after} (the joints branch); "
                "MujocoPlant needs a serial chain"
            )
    return tuple(mujoco.mj_id2name(model, obj.mjOBJ_JOINT, j) or f"#{j}" for j in range(model.njnt))


def _rebuild(
    fmt: Format,
    text: str,
    path: str | None,
    label: str,
    gravity: float | None,
    limits: bool,
    integrator: str,
    sha256: str,
) -> MujocoPlant:
    """Unpickle a :class:`MujocoPlant`: from its file while the file still holds the same
    text, else from the text."""
    where: Path | None = None
    if path is not None and fmt == "mjcf":
        try:
            now = Path(path).read_text(encoding="utf-8")
            same = _sha256(now) == sha256
        except (OSError, UnicodeDecodeError):
            same = False
        where = Path(path) if same else None
    return MujocoPlant(
        fmt, text, path=where, label=label, gravity=gravity, limits=limits, integrator=integrator
    )
