"""A planar serial arm with revolute joints, in closed form (docs/theory.md §1).

Conventions: ``q[0]`` is link 1's angle from the ``+x`` axis, counter-clockwise positive;
``q[i]`` (``i >= 1``) is link ``i+1``'s angle relative to link ``i``. The arm moves in the
vertical x-y plane with gravity ``-g ŷ``. The equation of motion is

.. math:: M(q)\\ddot q + C(q, \\dot q)\\dot q + G(q) = \\tau .

The numeric work is done by the compiled kernels of :mod:`slidingarm.models._kernels`; this
module holds the immutable, validated parameters and thin wrappers that accept one state
``(n,)`` or a batch ``(B, n)``.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from slidingarm._validate import ParameterTypeError, _float, is_real, number_array
from slidingarm.models import _dispatch as D
from slidingarm.models.base import (
    MAX_GRAVITY,
    MAX_INERTIA,
    MAX_LENGTH,
    MAX_MASS,
    MAX_SCALE,
    ArmModel,
)

__all__ = ["MassModel", "PlanarArm"]

MassModel = Literal["point", "rod"]
FloatArray = NDArray[np.float64]

#: Inertia given to MuJoCo for axes (and point masses) that have none: MuJoCo rejects a body
#: with a zero principal inertia. Its effect on ``M`` is below 1e-11.
MUJOCO_MIN_INERTIA = 1e-12


def _num(x: float) -> str:
    """Shortest text that round-trips a float exactly (``repr`` of a Python float)."""
    return repr(float(x))


def _vector(name: str, value: ArrayLike, n: int | None) -> FloatArray:
    try:
        if value is None or isinstance(value, set | frozenset | dict):
            raise ParameterTypeError(name)
        arr = np.atleast_1d(number_array(name, value))
    except ParameterTypeError:
        raise ParameterTypeError(f"{name} must be a sequence of numbers, got {value!r}") from None
    if arr.ndim != 1:
        raise ValueError(
            f"{name} must be one-dimensional (one value per link), got shape {arr.shape}"
        )
    if n is not None and arr.shape[0] != n:
        raise ValueError(f"{name} must have {n} values (one per link), got {arr.shape[0]}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite, got {arr.tolist()}")
    return arr


def _plain_floats(value: object) -> list[float] | None:
    """``value`` as a list of Python floats if it is a 1-D float64 array or a list or tuple of
    Python floats and ints, else ``None`` (the general path converts and words any error)."""
    kind = type(value)
    if kind is np.ndarray:
        assert isinstance(value, np.ndarray)
        return value.tolist() if value.dtype == np.float64 and value.ndim == 1 else None
    if kind is list or kind is tuple:
        assert isinstance(value, list | tuple)
        if all(type(v) is float or type(v) is int for v in value):
            try:
                return [float(v) for v in value]
            except OverflowError:  # an integer beyond the float range
                return None
    return None


def _valid_fast(
    masses: object, lengths: object, com: object, inertia: object, mass_model: object,
    gravity: object,
) -> tuple[list[float], list[float], list[float] | None, list[float] | None, float] | None:
    """The arm's parameters as Python floats if they pass every check of
    :class:`PlanarArm` (bounds are written so that NaN fails them), else ``None``: the general
    path, with numpy, then words the first failing check. A sweep builds two or three arms a
    draw, and numpy's reductions on three-element arrays were most of their cost. The check
    that no link has both com = 0 and inertia = 0 is the caller's, on the final arrays."""
    if mass_model not in ("point", "rod") or not (type(gravity) is float or type(gravity) is int):
        return None
    m, ln = _plain_floats(masses), _plain_floats(lengths)
    if m is None or ln is None or not m or len(ln) != len(m):
        return None
    if not all(0.0 < x <= MAX_MASS for x in m) or not all(0.0 < x <= MAX_LENGTH for x in ln):
        return None
    c = inert = None
    if com is not None:
        c = _plain_floats(com)
        if c is None or len(c) != len(m) or not all(
            0.0 <= x <= y for x, y in zip(c, ln, strict=True)
        ):
            return None
    if inertia is not None:
        inert = _plain_floats(inertia)
        if inert is None or len(inert) != len(m) or not all(0.0 <= x <= MAX_INERTIA for x in inert):
            return None
    if not 0 <= gravity <= MAX_GRAVITY:
        return None
    return m, ln, c, inert, float(gravity)


def _scale_factors(value: object, n: int) -> list[float] | None:
    """:meth:`PlanarArm.scaled`'s factor as ``n`` Python floats, each in ``(0, MAX_SCALE]``,
    for a Python number or a 1-D float64 array, list or tuple of one or ``n`` numbers; else
    ``None`` (the general path words the error)."""
    if type(value) is float or type(value) is int:
        if not 0 < value <= MAX_SCALE:  # a huge integer too, before it meets float()
            return None
        xs: list[float] | None = [float(value)]
    else:
        xs = _plain_floats(value)
    if xs is None or len(xs) not in (1, n) or not all(0.0 < x <= MAX_SCALE for x in xs):
        return None
    return xs * n if len(xs) == 1 else xs


class PlanarArm(ArmModel):
    """An immutable planar serial arm with ``n >= 1`` revolute joints.

    Parameters
    ----------
    masses, lengths : sequence of float, shape (n,)
        Link masses ``m_i > 0`` (kg) and lengths ``l_i > 0`` (m).
    com : sequence of float, optional
        Distance ``c_i`` of each centre of mass from its joint along the link, ``0 <= c_i <= l_i``.
        Defaults to the mass model's value.
    inertia : sequence of float, optional
        Rotational inertia ``I_i >= 0`` of each link about its centre of mass (kg m²).
        Defaults to the mass model's value.
    mass_model : {"point", "rod"}
        ``"point"``: all mass at the distal end (``c = l``, ``I = 0``), the paper's arm;
        ``"rod"``: uniform slender rod (``c = l/2``, ``I = m l²/12``).
    gravity : float
        Magnitude ``g >= 0`` of gravity, which acts along ``-y`` (m/s²).

    Notes
    -----
    Every dynamics method accepts one state ``(n,)`` or a batch ``(B, n)`` and returns the
    matching shape: vectors ``(n,)``/``(B, n)``, matrices ``(n, n)``/``(B, n, n)``.
    """

    __slots__ = ("_com", "_gravity", "_inertia", "_lengths", "_mass_model", "_masses", "_packed")
    _masses: FloatArray
    _lengths: FloatArray
    _com: FloatArray
    _inertia: FloatArray
    _mass_model: str
    _gravity: float
    _packed: FloatArray

    def __init__(
        self,
        masses: ArrayLike,
        lengths: ArrayLike,
        *,
        com: ArrayLike | None = None,
        inertia: ArrayLike | None = None,
        mass_model: MassModel = "point",
        gravity: float = 9.81,
    ) -> None:
        fast = _valid_fast(masses, lengths, com, inertia, mass_model, gravity)
        if fast is not None:
            ml, lnl, cl, il, g = fast
            m, ln = np.array(ml), np.array(lnl)
            if cl is None:
                c = ln.copy() if mass_model == "point" else ln / 2.0
            else:
                c = np.array(cl)
            if il is None:
                inert = np.zeros(m.shape[0]) if mass_model == "point" else m * ln**2 / 12.0
            else:
                inert = np.array(il)
            # a link with com = 0 and inertia = 0: the general path words it
            if not any(
                x == 0.0 and y == 0.0 for x, y in zip(c.tolist(), inert.tolist(), strict=True)
            ):
                self._set(m, ln, c, inert, mass_model, g)
                return
        m = _vector("masses", masses, None)
        n = m.shape[0]
        if n < 1:
            raise ValueError("masses must have at least one value (an arm has n >= 1 links)")
        ln = _vector("lengths", lengths, n)
        if np.any(m <= 0) or np.any(m > MAX_MASS):
            raise ValueError(f"masses must be > 0 and <= {MAX_MASS:g} kg, got {m.tolist()}")
        if np.any(ln <= 0) or np.any(ln > MAX_LENGTH):
            raise ValueError(f"lengths must be > 0 and <= {MAX_LENGTH:g} m, got {ln.tolist()}")
        if mass_model not in ("point", "rod"):
            raise ValueError(f"mass_model must be 'point' or 'rod', got {mass_model!r}")
        if com is None:
            c = ln.copy() if mass_model == "point" else ln / 2.0
        else:
            c = _vector("com", com, n)
            if np.any(c < 0) or np.any(c > ln):
                raise ValueError(
                    f"com must lie on the link, 0 <= com[i] <= lengths[i]; got com={c.tolist()} "
                    f"for lengths={ln.tolist()}"
                )
        if inertia is None:
            inert = np.zeros(n) if mass_model == "point" else m * ln**2 / 12.0
        else:
            inert = _vector("inertia", inertia, n)
            if np.any(inert < 0) or np.any(inert > MAX_INERTIA):
                raise ValueError(
                    f"inertia must be >= 0 and <= {MAX_INERTIA:g} kg m², got {inert.tolist()}"
                )
        if not is_real(gravity):
            raise ParameterTypeError(f"gravity must be a number, got {gravity!r}")
        g = _float(gravity)
        if not np.isfinite(g) or g < 0 or g > MAX_GRAVITY:
            raise ValueError(f"gravity must be >= 0 and <= {MAX_GRAVITY:g} m/s², got {gravity!r}")
        idle = np.flatnonzero((c == 0) & (inert == 0))
        if idle.size:
            raise ValueError(
                f"link {int(idle[0]) + 1} has com = 0 and inertia = 0: every link needs com > 0 or "
                "inertia > 0, or M(q) can be singular (a mass on a joint axis belongs at the "
                "previous link's tip)"
            )
        self._set(m, ln, c, inert, mass_model, g)

    def _set(
        self, m: FloatArray, ln: FloatArray, c: FloatArray, inert: FloatArray, mass_model: str,
        g: float,
    ) -> None:
        """Store the checked parameters, read-only."""
        packed = np.array([m, ln, c, inert], dtype=np.float64)  # (4, n), C order; np.stack: 5x the time
        for arr in (m, ln, c, inert):
            arr.setflags(write=False)
        object.__setattr__(self, "_masses", m)
        object.__setattr__(self, "_lengths", ln)
        object.__setattr__(self, "_com", c)
        object.__setattr__(self, "_inertia", inert)
        object.__setattr__(self, "_mass_model", mass_model)
        object.__setattr__(self, "_gravity", g)
        object.__setattr__(self, "_packed", packed)

    KIND = D.KIND_PLANAR

    def __setattr__(self, name: str, value: object) -> None:
        raise AttributeError(f"PlanarArm is immutable; cannot set {name!r}")

    def __reduce__(self) -> tuple[object, ...]:
        # rebuilt through the constructor (validated again, immutable again)
        return (_rebuild, (self.to_dict(), self._mass_model))

    def replace(self, **changes: object) -> PlanarArm:
        """A new arm with some of ``masses``, ``lengths``, ``com``, ``inertia``, ``gravity``
        changed, validated as a new arm is.

        Raises
        ------
        TypeError
            If a name is not one of those parameters.
        """
        base = self.to_dict()
        unknown = sorted(set(changes) - set(base))
        if unknown:
            raise TypeError(
                f"PlanarArm.replace() got unknown parameter(s) {unknown}; "
                f"the parameters are {sorted(base)}"
            )
        base.update(changes)
        return PlanarArm(
            base["masses"],  # type: ignore[arg-type]
            base["lengths"],  # type: ignore[arg-type]
            com=base["com"],  # type: ignore[arg-type]
            inertia=base["inertia"],  # type: ignore[arg-type]
            gravity=base["gravity"],  # type: ignore[arg-type]
            mass_model=self._mass_model,  # type: ignore[arg-type]
        )

    # ------------------------------------------------------------------ constructors
    @classmethod
    def paper(cls, mass_model: MassModel = "point", *, gravity: float = 9.81) -> PlanarArm:
        """The paper's arm (Table 1): ``m = (1, 1, 1) kg``, ``l = (0.5, 1, 1) m``, ``g = 9.81``
        m/s² unless ``gravity`` says otherwise."""
        return cls((1.0, 1.0, 1.0), (0.5, 1.0, 1.0), mass_model=mass_model, gravity=gravity)

    def with_payload(self, mass: float) -> PlanarArm:
        """Return the arm with a point ``mass`` (kg) fixed at the tip of the last link.

        The last link's mass, centre of mass and centroidal inertia are combined by the
        parallel-axis theorem: :math:`m' = m + p`, :math:`c' = (m c + p l)/m'`,
        :math:`I' = I + m(c - c')^2 + p(l - c')^2`.
        """
        if not is_real(mass):
            raise ParameterTypeError(f"payload mass must be a number (kg), got {mass!r}")
        p = _float(mass)
        if not np.isfinite(p) or p < 0 or p > MAX_MASS:
            raise ValueError(f"payload mass must be >= 0 and <= {MAX_MASS:g} kg, got {mass!r}")
        m, ln, c, inert = (
            a.copy() for a in (self._masses, self._lengths, self._com, self._inertia)
        )
        mn, cn, lnn = m[-1], c[-1], ln[-1]
        m_new = mn + p
        # = (m c + p l) / m', written so that p = 0 returns c exactly and rounding cannot
        # carry the centre of mass past the tip
        c_new = min(cn + (p / m_new) * (lnn - cn), lnn)
        inert[-1] = inert[-1] + mn * (cn - c_new) ** 2 + p * (lnn - c_new) ** 2
        m[-1] = m_new
        c[-1] = c_new
        return PlanarArm(m, ln, com=c, inertia=inert, gravity=self._gravity)

    def scaled(self, *, mass: ArrayLike = 1.0, length: ArrayLike = 1.0) -> PlanarArm:
        """Return the arm with masses and lengths multiplied by the given factors.

        Centres of mass scale with the lengths (they stay at the same fraction of the link);
        centroidal inertias scale as :math:`m l^2`. Factors are scalars or per link.
        """
        fast = [_scale_factors(f, self.n) for f in (mass, length)]
        if fast[0] is not None and fast[1] is not None:
            fm, fl = np.array(fast[0]), np.array(fast[1])
        else:
            fm, fl = self._checked_factors(mass, length)
        return PlanarArm(
            self._masses * fm,
            self._lengths * fl,
            com=self._com * fl,
            inertia=self._inertia * fm * fl**2,
            gravity=self._gravity,
        )

    def _checked_factors(self, mass: ArrayLike, length: ArrayLike) -> tuple[FloatArray, FloatArray]:
        """:meth:`scaled`'s factors through numpy, each check's error worded."""
        factors = {
            "mass scale": _vector("mass scale", mass, None),
            "length scale": _vector("length scale", length, None),
        }
        for name, f in factors.items():
            if f.shape[0] not in (1, self.n):
                raise ValueError(
                    f"{name} must be one value or {self.n} (one per link), got {f.shape[0]}"
                )
        fm, fl = (np.broadcast_to(f, (self.n,)).astype(float) for f in factors.values())
        if np.any(fm <= 0) or np.any(fl <= 0) or np.any(fm > MAX_SCALE) or np.any(fl > MAX_SCALE):
            raise ValueError(
                f"mass and length scale factors must be > 0 and <= {MAX_SCALE:g} (a model off by "
                f"more than {MAX_SCALE:g}x is not a model error), got mass {fm.tolist()}, length "
                f"{fl.tolist()}"
            )
        return fm, fl

    # ------------------------------------------------------------------ parameters
    @property
    def n(self) -> int:
        """Number of joints."""
        return int(self._masses.shape[0])

    @property
    def masses(self) -> FloatArray:
        """Link masses ``m_i`` (kg), read-only, shape (n,)."""
        return self._masses

    @property
    def lengths(self) -> FloatArray:
        """Link lengths ``l_i`` (m), read-only, shape (n,)."""
        return self._lengths

    @property
    def com(self) -> FloatArray:
        """Centre-of-mass distances ``c_i`` from each joint (m), read-only, shape (n,)."""
        return self._com

    @property
    def inertia(self) -> FloatArray:
        """Centroidal rotational inertias ``I_i`` (kg m²), read-only, shape (n,)."""
        return self._inertia

    @property
    def gravity(self) -> float:
        """Gravity magnitude ``g`` (m/s²), acting along ``-y``."""
        return self._gravity

    @property
    def mass_model(self) -> str:
        """The mass model the arm was built with (``"point"`` or ``"rod"``)."""
        return self._mass_model

    @property
    def params(self) -> FloatArray:
        """The planar kind's parameter table ``[m; l; c; I]``, shape (4, n), read-only."""
        block = self._packed.view()
        block.setflags(write=False)
        return block

    @property
    def packed(self) -> FloatArray:
        """Parameters as the ``(4, n)`` array ``[m; l; c; I]`` the compiled kernels take (a copy)."""
        return self._packed.copy()

    def to_dict(self) -> dict[str, object]:
        """Plain parameters (lists and floats), enough to rebuild the arm."""
        return {
            "masses": self._masses.tolist(),
            "lengths": self._lengths.tolist(),
            "com": self._com.tolist(),
            "inertia": self._inertia.tolist(),
            "gravity": self._gravity,
        }

    def __repr__(self) -> str:
        return (
            f"PlanarArm(masses={self._masses.tolist()}, lengths={self._lengths.tolist()}, "
            f"com={self._com.tolist()}, inertia={self._inertia.tolist()}, gravity={self._gravity})"
        )

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, PlanarArm):
            return NotImplemented
        return bool(np.array_equal(self._packed, other._packed) and self._gravity == other._gravity)

    def __hash__(self) -> int:
        return hash((self._packed.tobytes(), self._gravity))

    # ------------------------------------------------------------------ kinematics
    def _points(self, qa: FloatArray) -> tuple[FloatArray, FloatArray]:
        phi = np.cumsum(qa, axis=1)
        u = np.stack([np.cos(phi), np.sin(phi)], axis=-1)  # (B, n, 2)
        ends = np.cumsum(u * self._lengths[None, :, None], axis=1)
        joints = np.concatenate([np.zeros((qa.shape[0], 1, 2)), ends], axis=1)  # (B, n+1, 2)
        coms = joints[:, :-1, :] + u * self._com[None, :, None]
        return joints, coms

    def joint_positions(self, q: ArrayLike) -> FloatArray:
        """Positions of the base, every joint and the tip in the plane (m).

        Shape (n + 1, 2) or (B, n + 1, 2); row 0 is the base at the origin, row n the tip.
        """
        (qa,), single = self._states(q=q)
        joints, _ = self._points(qa)
        return joints[0] if single else joints

    def com_positions(self, q: ArrayLike) -> FloatArray:
        """Positions of the links' centres of mass (m), shape (n, 2) or (B, n, 2)."""
        (qa,), single = self._states(q=q)
        _, coms = self._points(qa)
        return coms[0] if single else coms

    def tip_position(self, q: ArrayLike) -> FloatArray:
        """Position of the end of the last link (m), shape (2,) or (B, 2)."""
        return self.joint_positions(q)[..., -1, :]

    # ------------------------------------------------------------------ engine models
    def to_urdf(self, name: str = "planar_arm") -> str:
        """URDF text of the same arm, for Pinocchio, MuJoCo and :meth:`SerialArm.from_urdf`.

        URDF's convention is gravity along ``-z`` of the root link (``world``), so the arm's
        plane is the root's ``x``-``z`` plane: a fixed joint ``plane`` turns the arm's frame
        ``base`` by +90° about ``x`` (the arm's ``+y``, up, is the root's ``+z``). Links lie
        along their local ``+x``; joints are revolute about the local ``+z`` (limits of ±1e6
        rad, never reached), with no damping or friction; a massless link ``tool`` sits at the
        tip. A zero inertia is written as zero.
        """
        parts = [
            f'<?xml version="1.0"?>\n<robot name="{name}">',
            '  <link name="world"/>',
            '  <joint name="plane" type="fixed">\n    <parent link="world"/>\n'
            '    <child link="base"/>\n'
            '    <origin xyz="0 0 0" rpy="1.5707963267948966 0 0"/>\n  </joint>',
            '  <link name="base"/>',
        ]
        parent = "base"
        offset = 0.0
        for i in range(self.n):
            link = f"link{i + 1}"
            parts.append(
                f'  <joint name="joint{i + 1}" type="revolute">\n'
                f'    <parent link="{parent}"/>\n    <child link="{link}"/>\n'
                f'    <origin xyz="{_num(offset)} 0 0" rpy="0 0 0"/>\n    <axis xyz="0 0 1"/>\n'
                f'    <limit lower="-1e6" upper="1e6" effort="1e6" velocity="1e6"/>\n'
                f'    <dynamics damping="0" friction="0"/>\n  </joint>'
            )
            inert = self._inertia[i]
            parts.append(
                f'  <link name="{link}">\n    <inertial>\n'
                f'      <origin xyz="{_num(self._com[i])} 0 0" rpy="0 0 0"/>\n'
                f'      <mass value="{_num(self._masses[i])}"/>\n'
                f'      <inertia ixx="0" ixy="0" ixz="0" iyy="{_num(inert)}" iyz="0" izz="{_num(inert)}"/>\n'
                f"    </inertial>\n  </link>"
            )
            parent = link
            offset = float(self._lengths[i])
        parts.append(
            f'  <joint name="tool" type="fixed">\n    <parent link="{parent}"/>\n'
            f'    <child link="tool"/>\n    <origin xyz="{_num(offset)} 0 0" rpy="0 0 0"/>\n'
            "  </joint>\n  <link name=\"tool\"/>"
        )
        parts.append("</robot>\n")
        return "\n".join(parts)

    def to_mjcf(self, name: str = "planar_arm", timestep: float = 5e-4) -> str:
        """MJCF text of the same arm, for MuJoCo.

        Gravity ``(0, -g, 0)``, hinge joints about ``+z`` with no damping, armature or limits,
        RK4 integrator, contacts disabled. MuJoCo needs strictly positive principal inertias, so
        zero inertias are written as :data:`MUJOCO_MIN_INERTIA` (changes ``M`` by < 1e-11).
        """
        eps = MUJOCO_MIN_INERTIA
        lines = [
            f'<mujoco model="{name}">',
            '  <compiler angle="radian" inertiafromgeom="false"/>',
            f'  <option gravity="0 {_num(-self._gravity)} 0" timestep="{_num(timestep)}" integrator="RK4">',
            '    <flag contact="disable"/>',
            "  </option>",
            "  <worldbody>",
        ]
        indent = "    "
        offset = 0.0
        for i in range(self.n):
            inert = max(float(self._inertia[i]), eps)
            lines.append(f'{indent}<body name="link{i + 1}" pos="{_num(offset)} 0 0">')
            lines.append(
                f'{indent}  <joint name="joint{i + 1}" type="hinge" axis="0 0 1" '
                f'damping="0" armature="0" frictionloss="0" limited="false"/>'
            )
            lines.append(
                f'{indent}  <inertial pos="{_num(self._com[i])} 0 0" mass="{_num(self._masses[i])}" '
                f'diaginertia="{_num(eps)} {_num(inert)} {_num(inert)}"/>'
            )
            lines.append(
                f'{indent}  <geom type="capsule" fromto="0 0 0 {_num(self._lengths[i])} 0 0" '
                f'size="0.02" contype="0" conaffinity="0" mass="0"/>'
            )
            indent += "  "
            offset = float(self._lengths[i])
        for _ in range(self.n):
            indent = indent[:-2]
            lines.append(f"{indent}</body>")
        lines += ["  </worldbody>", "</mujoco>", ""]
        return "\n".join(lines)


def _rebuild(params: dict[str, object], mass_model: str) -> PlanarArm:
    """Unpickle a :class:`PlanarArm` (module level, so that pickle finds it)."""
    return PlanarArm(
        params["masses"],  # type: ignore[arg-type]
        params["lengths"],  # type: ignore[arg-type]
        com=params["com"],  # type: ignore[arg-type]
        inertia=params["inertia"],  # type: ignore[arg-type]
        gravity=params["gravity"],  # type: ignore[arg-type]
        mass_model=mass_model,  # type: ignore[arg-type]
    )
