"""Desired joint trajectories :math:`q_d(t)` with analytic derivatives (docs/theory.md §2).

A :class:`Reference` gives the desired position, velocity and acceleration of every joint. The
simulator calls :meth:`Reference.evaluate` once, with the whole sample-time grid ``t`` (T,),
before its compiled loop; each output has shape (T, n), time-major like every array in
slidingarm. :meth:`Reference.__call__` evaluates one time and returns three (n,) vectors.

Derivatives are always analytic (closed form, or the exact derivative of a piecewise
polynomial): nothing here differentiates numerically (docs/theory.md §2).

References:

- :class:`PaperReference` -- the paper's sinusoidal reference (docs/theory.md §2, Table 1);
- :class:`QuinticReference` -- point-to-point move with zero velocity and acceleration at both ends;
- :class:`SineReference` -- per-joint sinusoid;
- :class:`TableReference` -- a sampled table interpolated by a quintic or cubic spline
  (:meth:`TableReference.from_csv` reads one from a CSV file);
- :class:`CallableReference` -- user functions for :math:`q_d`, :math:`\\dot q_d` and
  :math:`\\ddot q_d`.

Every reference except :class:`CallableReference` round-trips through :meth:`Reference.to_dict`
and :func:`reference_from_dict` (the configuration files' format).

The paper's initial state and time grid live here too, in one named place: :data:`PAPER_Q0`,
:data:`PAPER_QD0`, :data:`PAPER_T_FINAL`, :data:`PAPER_DT`.
"""

from __future__ import annotations

import abc
import csv
import json
import math
import pickle
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any, Literal

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray

from slidingarm._io import MAX_TABLE_BYTES, file_problem
from slidingarm._validate import ParameterTypeError, integer, number_array, real

__all__ = [
    "PAPER_DT",
    "PAPER_Q0",
    "PAPER_QD0",
    "PAPER_T_FINAL",
    "REFERENCE_KINDS",
    "CallableReference",
    "PaperReference",
    "QuinticReference",
    "Reference",
    "SineReference",
    "SplineEnds",
    "SplineKind",
    "TableReference",
    "reference_from_dict",
]

FloatArray = NDArray[np.float64]
Trajectory = tuple[FloatArray, FloatArray, FloatArray]
SplineKind = Literal["quintic", "cubic"]
#: End conditions of a table's spline: scipy's ``"not-a-knot"``, or ``"rest"`` (zero velocity
#: and, for the quintic, zero acceleration at both ends).
SplineEnds = Literal["not-a-knot", "rest"]

#: The paper's initial joint positions :math:`q(0)` (rad), docs/theory.md §2.
PAPER_Q0: tuple[float, float, float] = (0.7, 1.5, 0.5)
#: The paper's initial joint velocities :math:`\dot q(0)` (rad/s), docs/theory.md §2.
PAPER_QD0: tuple[float, float, float] = (0.0, 0.0, 0.0)
#: The paper's final time :math:`T` (s), docs/theory.md §2.
PAPER_T_FINAL: float = 4.5
#: The paper's sample time :math:`T_s` (s), docs/theory.md §2.
PAPER_DT: float = 5e-4

#: The ``"kind"`` values :func:`reference_from_dict` understands (``"callable"`` is recorded by
#: :meth:`CallableReference.to_dict` but cannot be rebuilt).
REFERENCE_KINDS: tuple[str, ...] = ("paper", "quintic", "sine", "table", "callable")

_SPLINE_ORDER: dict[str, int] = {"quintic": 5, "cubic": 3}
_SPLINE_ENDS: tuple[str, ...] = ("not-a-knot", "rest")

#: Times at most this far (relative to the table's time scale) outside a table's range are
#: treated as its end points, so a grid built as ``k * dt`` that overshoots the last sample by
#: rounding still evaluates.
_TABLE_RANGE_RTOL = 1e-12


# --------------------------------------------------------------------------------------------
# validation helpers


def _finite_scalar(name: str, value: Any) -> float:
    x = real(name, value, finite=False, message=f"{name} must be a real number, got {value!r}")
    if not math.isfinite(x):
        raise ValueError(f"{name} must be finite, got {x!r}")
    return x


def _joint_vector(name: str, value: ArrayLike, n: int | None = None) -> FloatArray:
    """A finite (n,) float64 vector, read-only; a scalar is one joint."""
    arr = number_array(name, value, message=f"{name} must be a sequence of numbers, got {value!r}")
    arr = np.atleast_1d(arr)
    if arr.ndim != 1:
        raise ValueError(
            f"{name} must be one-dimensional (one value per joint), got shape {arr.shape}"
        )
    if arr.shape[0] == 0:
        raise ValueError(f"{name} must have at least one value (one per joint), got none")
    if n is not None and arr.shape[0] != n:
        raise ValueError(f"{name} must have {n} values (one per joint), got {arr.shape[0]}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite, got {arr.tolist()}")
    arr.flags.writeable = False
    return arr


def _per_joint(name: str, value: ArrayLike, n: int) -> FloatArray:
    """A scalar (the same for every joint) or an (n,) vector, as a read-only (n,) vector."""
    if np.ndim(value) == 0:
        scalar = _joint_vector(name, value)
        out = np.full(n, scalar[0])
        out.flags.writeable = False
        return out
    return _joint_vector(name, value, n)


def _as_times(t: ArrayLike) -> FloatArray:
    """Validate a sample-time array: real, one-dimensional (T,), finite."""
    if np.iscomplexobj(t):
        raise ParameterTypeError("t must be real sample times, got complex values")
    arr = number_array(
        "t", t, message=f"t must be an array of sample times (T,), got {type(t).__name__}"
    )
    if arr.ndim != 1:
        hint = "; to evaluate one time call the reference, ref(t)" if arr.ndim == 0 else ""
        raise ValueError(f"t must be one-dimensional, shape (T,), got shape {arr.shape}{hint}")
    bad = ~np.isfinite(arr)
    if np.any(bad):
        i = int(np.argmax(bad))
        raise ValueError(f"t must be finite, got t[{i}] = {float(arr[i])!r}")
    return np.ascontiguousarray(arr)


def _vec_list(x: FloatArray) -> list[float]:
    return [float(v) for v in x]


# --------------------------------------------------------------------------------------------
# base class


class Reference(abc.ABC):
    """A desired joint trajectory :math:`q_d(t)` with analytic :math:`\\dot q_d, \\ddot q_d`.

    Subclasses implement :attr:`n`, :meth:`_evaluate` and :meth:`to_dict`; the public
    :meth:`evaluate` and :meth:`__call__` validate the times and the outputs.

    References are immutable; two references are equal when their :meth:`to_dict` are.
    """

    __slots__ = ()

    @property
    @abc.abstractmethod
    def n(self) -> int:
        """Number of joints."""

    @abc.abstractmethod
    def _evaluate(self, t: FloatArray) -> Trajectory:
        """Unchecked evaluation at validated times ``t`` (T,); returns three (T, n) arrays."""

    @abc.abstractmethod
    def to_dict(self) -> dict[str, Any]:
        """JSON-able parameters, with a ``"kind"`` key; :func:`reference_from_dict` inverts it."""

    def evaluate(self, t: ArrayLike) -> Trajectory:
        """Desired position, velocity and acceleration at the sample times.

        Parameters
        ----------
        t : array_like, shape (T,)
            Finite sample times (s), in any order.

        Returns
        -------
        q, qd, qdd : ndarray, shape (T, n)
            :math:`q_d(t_k)`, :math:`\\dot q_d(t_k)`, :math:`\\ddot q_d(t_k)`: float64,
            C-contiguous, new arrays.

        Raises
        ------
        ValueError
            If ``t`` is not one-dimensional or not finite, or if the reference is not defined
            (or not finite) at some time.
        """
        times = _as_times(t)
        q, qd, qdd = self._evaluate(times)
        return (
            self._checked("q", q, times),
            self._checked("qd", qd, times),
            self._checked("qdd", qdd, times),
        )

    def __call__(self, t: float) -> Trajectory:
        """Desired position, velocity and acceleration at one time ``t`` (s).

        Returns
        -------
        q, qd, qdd : ndarray, shape (n,)
            The row of :meth:`evaluate` for ``[t]``.
        """
        if np.ndim(t) != 0:
            raise ValueError(
                f"ref(t) takes one time, got shape {np.shape(t)}; use ref.evaluate(t) for an array"
            )
        x = real("t", t, finite=False, message=f"t must be a real number (s), got {t!r}")
        t_arr = np.array([x], dtype=np.float64)
        q, qd, qdd = self.evaluate(t_arr)
        return q[0].copy(), qd[0].copy(), qdd[0].copy()

    def _checked(self, name: str, value: FloatArray, t: FloatArray) -> FloatArray:
        arr = np.ascontiguousarray(value, dtype=np.float64)
        if arr.shape != (t.shape[0], self.n):  # pragma: no cover - a bug in a subclass
            raise RuntimeError(
                f"{type(self).__name__} produced {name} of shape {arr.shape}, "
                f"expected {(t.shape[0], self.n)}"
            )
        if not np.isfinite(arr).all():
            k, j = np.argwhere(~np.isfinite(arr))[0]
            raise ValueError(
                f"{type(self).__name__}: {name} is not finite at t = {float(t[k])!r} (joint {j})"
            )
        return arr

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Reference):
            return NotImplemented
        return type(self) is type(other) and self.to_dict() == other.to_dict()

    def __hash__(self) -> int:
        return hash((type(self).__name__, json.dumps(self.to_dict(), sort_keys=True)))


# --------------------------------------------------------------------------------------------
# the paper's reference


class PaperReference(Reference):
    """The paper's reference trajectory for its 3-DOF arm (docs/theory.md §2, Table 1).

    .. math::

        q_d(t) &= (0.35 - 0.5\\sin t,\\; 0.25 + 0.5\\cos t,\\; 0.45 - 0.5\\cos t), \\\\
        \\dot q_d(t) &= (-0.5\\cos t,\\; -0.5\\sin t,\\; 0.5\\sin t), \\\\
        \\ddot q_d(t) &= (0.5\\sin t,\\; -0.5\\cos t,\\; 0.5\\cos t).

    At :math:`t = 0`: :math:`q_d = (0.35, 0.75, -0.05)`, :math:`\\dot q_d = (-0.5, 0, 0)`,
    :math:`\\ddot q_d = (0, -0.5, 0.5)`. The paper starts the arm at :data:`PAPER_Q0`,
    :data:`PAPER_QD0`, off the reference.
    """

    __slots__ = ()

    @property
    def n(self) -> int:
        return 3

    def _evaluate(self, t: FloatArray) -> Trajectory:
        s = np.sin(t)
        c = np.cos(t)
        q = np.stack([0.35 - 0.5 * s, 0.25 + 0.5 * c, 0.45 - 0.5 * c], axis=1)
        qd = np.stack([-0.5 * c, -0.5 * s, 0.5 * s], axis=1)
        qdd = np.stack([0.5 * s, -0.5 * c, 0.5 * c], axis=1)
        return q, qd, qdd

    def to_dict(self) -> dict[str, Any]:
        return {"kind": "paper"}

    def __repr__(self) -> str:
        return "PaperReference()"


# --------------------------------------------------------------------------------------------
# quintic point-to-point


@njit(cache=True, nogil=True, error_model="numpy")
def _quintic_into(
    s: FloatArray,
    s3: FloatArray,
    q_start: FloatArray,
    q_end: FloatArray,
    delta: FloatArray,
    d: float,
    q: FloatArray,
    qd: FloatArray,
    qdd: FloatArray,
) -> None:
    """:class:`QuinticReference` on the whole grid in one pass, from the normalised times
    ``s`` (T,) and their cubes ``s3``: :math:`p = \\mathrm{clip}(s^3 (10 + s(-15 + 6 s)), 0, 1)`,
    ``q[k] = (1 - p) q_start + p q_end``, ``qd[k] = delta 30 s^2 (1 - s)^2 / D``,
    ``qdd[k] = delta 60 s (1 - s)(1 - 2 s) / D^2`` (T, n), each product and sum in the order
    (and so with the rounding) of the formula written out elementwise; no fused multiply-add.

    ``p(0) = 0`` and ``p(1) = 1`` exactly in this Horner form, so the ends are exactly
    ``q_start`` and ``q_end``; the clip keeps rounding from stepping outside ``[0, 1]``
    (monotone, no overshoot).
    """
    d2 = d * d
    n = q.shape[1]
    for k in range(s.shape[0]):
        sk = s[k]
        p = s3[k] * (10.0 + sk * (-15.0 + 6.0 * sk))
        p = min(max(p, 0.0), 1.0)
        om = 1.0 - sk
        wv = 30.0 * sk * sk * om * om / d
        wa = 60.0 * sk * om * (1.0 - 2.0 * sk) / d2
        pm = 1.0 - p
        for j in range(n):
            q[k, j] = pm * q_start[j] + p * q_end[j]
            qd[k, j] = delta[j] * wv
            qdd[k, j] = delta[j] * wa


class QuinticReference(Reference):
    """Point-to-point move with zero velocity and acceleration at both ends.

    With :math:`s = \\mathrm{clip}((t - t_0)/D, 0, 1)`, :math:`t_0` = ``t_start`` and
    :math:`D` = ``duration``:

    .. math::

        p(s) &= 10 s^3 - 15 s^4 + 6 s^5, \\\\
        q_d(t) &= (1 - p)\\, q_{start} + p\\, q_{end}, \\\\
        \\dot q_d(t) &= (q_{end} - q_{start})\\, 30 s^2 (1 - s)^2 / D, \\\\
        \\ddot q_d(t) &= (q_{end} - q_{start})\\, 60 s (1 - s)(1 - 2 s) / D^2 .

    Up to ``t_start`` it holds ``q_start``, from ``t_end = t_start + duration`` (computed in
    floating point) on it holds ``q_end``, with zero velocity and acceleration. The end values
    and the zero derivatives are exact in floating point; each joint moves monotonically (:math:`p' = 30 s^2 (1-s)^2 \\ge 0`).
    The trajectory is :math:`C^2`; the jerk jumps at both ends.

    Parameters
    ----------
    q_start, q_end : array_like, shape (n,)
        Start and end joint positions (rad), finite, same length.
    duration : float
        Move time :math:`D > 0` (s).
    t_start : float, default 0.0
        Time the move starts (s).
    """

    __slots__ = ("_delta", "_duration", "_q_end", "_q_start", "_t_start")

    def __init__(
        self, q_start: ArrayLike, q_end: ArrayLike, *, duration: float, t_start: float = 0.0
    ) -> None:
        self._q_start = _joint_vector("q_start", q_start)
        self._q_end = _joint_vector("q_end", q_end, self._q_start.shape[0])
        self._duration = _finite_scalar("duration", duration)
        if self._duration <= 0.0:
            raise ValueError(f"duration must be > 0 s, got {self._duration!r}")
        self._t_start = _finite_scalar("t_start", t_start)
        self._delta = self._q_end - self._q_start

    @property
    def n(self) -> int:
        return int(self._q_start.shape[0])

    @property
    def q_start(self) -> FloatArray:
        """Start position (n,), read-only."""
        return self._q_start

    @property
    def q_end(self) -> FloatArray:
        """End position (n,), read-only."""
        return self._q_end

    @property
    def duration(self) -> float:
        """Move time (s)."""
        return self._duration

    @property
    def t_start(self) -> float:
        """Start time of the move (s)."""
        return self._t_start

    @property
    def t_end(self) -> float:
        """End time of the move, ``t_start + duration`` (s)."""
        return self._t_start + self._duration

    def _evaluate(self, t: FloatArray) -> Trajectory:
        d = self._duration
        # s = 1 exactly from t_end = t_start + D on, even where (t_end - t_start) / D rounds below 1
        s = np.where(t >= self.t_end, 1.0, np.clip((t - self._t_start) / d, 0.0, 1.0))
        # s**3 by numpy's power (whose last bit may differ from the C library's pow, which the
        # compiled pass would call): the trajectory stays the one earlier versions recorded
        s3 = s**3
        nt = t.shape[0]
        q = np.empty((nt, self.n))
        qd = np.empty((nt, self.n))
        qdd = np.empty((nt, self.n))
        _quintic_into(s, s3, self._q_start, self._q_end, self._delta, d, q, qd, qdd)
        return q, qd, qdd

    def to_dict(self) -> dict[str, Any]:
        return {
            "kind": "quintic",
            "q_start": _vec_list(self._q_start),
            "q_end": _vec_list(self._q_end),
            "duration": self._duration,
            "t_start": self._t_start,
        }

    def __repr__(self) -> str:
        return (
            f"QuinticReference(q_start={_vec_list(self._q_start)}, q_end={_vec_list(self._q_end)}, "
            f"duration={self._duration!r}, t_start={self._t_start!r})"
        )


# --------------------------------------------------------------------------------------------
# sinusoid


@njit(cache=True, nogil=True, error_model="numpy")
def _phase_into(t: FloatArray, omega: FloatArray, phase: FloatArray, out: FloatArray) -> None:
    """``out[k, j] = t[k] omega[j] + phase[j]`` (T, n): a product, then a sum."""
    for k in range(t.shape[0]):
        tk = t[k]
        for j in range(out.shape[1]):
            out[k, j] = tk * omega[j] + phase[j]


@njit(cache=True, nogil=True, error_model="numpy")
def _sine_into(
    offset: FloatArray,
    amplitude: FloatArray,
    omega: FloatArray,
    s: FloatArray,
    c: FloatArray,
    qdd: FloatArray,
) -> None:
    """:class:`SineReference` from the sines ``s`` and cosines ``c`` of the phase (T, n), in
    place: ``s`` becomes :math:`o + A s`, ``c`` becomes :math:`(A \\omega) c`, and ``qdd``
    receives :math:`((-A)\\omega\\omega) s`, each in the order (and rounding) of those
    products; no fused multiply-add."""
    n = s.shape[1]
    for k in range(s.shape[0]):
        for j in range(n):
            a = amplitude[j]
            w = omega[j]
            sk = s[k, j]
            qdd[k, j] = -a * w * w * sk
            s[k, j] = offset[j] + a * sk
            c[k, j] = a * w * c[k, j]


class SineReference(Reference):
    """A sinusoid per joint.

    .. math::

        q_{d,i}(t) &= o_i + A_i \\sin(\\omega_i t + \\varphi_i), \\qquad \\omega_i = 2\\pi f_i, \\\\
        \\dot q_{d,i}(t) &= A_i \\omega_i \\cos(\\omega_i t + \\varphi_i), \\\\
        \\ddot q_{d,i}(t) &= -A_i \\omega_i^2 \\sin(\\omega_i t + \\varphi_i).

    Parameters
    ----------
    offset : array_like, shape (n,)
        :math:`o` (rad); its length is the number of joints.
    amplitude : float or array_like, shape (n,)
        :math:`A` (rad), any sign.
    frequency : float or array_like, shape (n,)
        :math:`f \\ge 0` in Hz (as :class:`slidingarm.disturbances.SinusoidalTorque`).
    phase : float or array_like, shape (n,), default 0.0
        :math:`\\varphi` (rad).

    A scalar ``amplitude``, ``frequency`` or ``phase`` applies to every joint.
    """

    __slots__ = ("_amplitude", "_frequency", "_offset", "_omega", "_phase")

    def __init__(
        self, offset: ArrayLike, amplitude: ArrayLike, frequency: ArrayLike, phase: ArrayLike = 0.0
    ) -> None:
        self._offset = _joint_vector("offset", offset)
        n = self._offset.shape[0]
        self._amplitude = _per_joint("amplitude", amplitude, n)
        self._frequency = _per_joint("frequency", frequency, n)
        if np.any(self._frequency < 0.0):
            raise ValueError(f"frequency must be >= 0 Hz, got {self._frequency.tolist()}")
        self._phase = _per_joint("phase", phase, n)
        self._omega = 2.0 * np.pi * self._frequency

    @property
    def n(self) -> int:
        return int(self._offset.shape[0])

    @property
    def offset(self) -> FloatArray:
        """Offset (n,), read-only."""
        return self._offset

    @property
    def amplitude(self) -> FloatArray:
        """Amplitude (n,), read-only."""
        return self._amplitude

    @property
    def frequency(self) -> FloatArray:
        """Frequency (n,) in Hz, read-only."""
        return self._frequency

    @property
    def phase(self) -> FloatArray:
        """Phase (n,) in rad, read-only."""
        return self._phase

    def _evaluate(self, t: FloatArray) -> Trajectory:
        arg = np.empty((t.shape[0], self.n))
        _phase_into(t, self._omega, self._phase, arg)
        # the sines and cosines by numpy (whose last bit may differ from the C library's
        # sin and cos), in place; then the products in one compiled pass
        c = np.cos(arg)
        s = np.sin(arg, out=arg)
        qdd = np.empty_like(s)
        _sine_into(self._offset, self._amplitude, self._omega, s, c, qdd)
        return s, c, qdd

    def to_dict(self) -> dict[str, Any]:
        return {
            "kind": "sine",
            "offset": _vec_list(self._offset),
            "amplitude": _vec_list(self._amplitude),
            "frequency": _vec_list(self._frequency),
            "phase": _vec_list(self._phase),
        }

    def __repr__(self) -> str:
        return (
            f"SineReference(offset={_vec_list(self._offset)}, "
            f"amplitude={_vec_list(self._amplitude)}, frequency={_vec_list(self._frequency)}, "
            f"phase={_vec_list(self._phase)})"
        )


# --------------------------------------------------------------------------------------------
# sampled table


class TableReference(Reference):
    """A sampled trajectory interpolated by a spline, with the spline's exact derivatives.

    The samples :math:`(t_j, q_j)`, :math:`j = 0 \\dots T_s - 1`, are interpolated per joint by
    an interpolating B-spline of degree :math:`k` (``scipy.interpolate.make_interp_spline``):
    :math:`k = 5` for ``"quintic"`` (:math:`C^4`), :math:`k = 3` for ``"cubic"``
    (:math:`C^2`). :math:`\\dot q_d` and :math:`\\ddot q_d` are the first and second derivatives
    of that piecewise polynomial.

    The ``ends`` close the system: ``"not-a-knot"`` (scipy's default; the spline reproduces
    any polynomial of degree :math:`\\le k` exactly) or ``"rest"``, which starts and ends the
    trajectory at rest: :math:`\\dot q_d = 0` at both ends, and for the quintic also
    :math:`\\ddot q_d = 0` (the :math:`(k - 1)/2` derivative conditions per end that close an odd
    degree's system). With ``"rest"`` a few waypoints suffice (two or more), and the trajectory
    through them is as smooth as the spline's degree; like any interpolating spline it may
    overshoot a waypoint between samples.

    Outside :math:`[t_0, t_{T_s-1}]` the reference is not defined and :meth:`evaluate` raises
    ``ValueError`` naming the range (extrapolating a spline is unreliable, and holding the end
    value would put a jump in the velocity). Times within a relative ``1e-12`` of an end are
    taken as that end, so a grid built as ``k * dt`` that overshoots by rounding still works.

    Parameters
    ----------
    t : array_like, shape (T_s,)
        Sample times (s), finite and strictly increasing.
    q : array_like, shape (T_s, n) or (T_s,)
        Joint positions (rad) at the sample times; one-dimensional means one joint.
    spline : {"quintic", "cubic"}, default "quintic"
        Spline degree 5 (needs :math:`T_s \\ge 6` with ``ends="not-a-knot"``) or 3 (needs
        :math:`T_s \\ge 4`).
    ends : {"not-a-knot", "rest"}, default "not-a-knot"
        End conditions (see above); ``"rest"`` needs :math:`T_s \\ge 2`.
    """

    __slots__ = ("_ends", "_q", "_spline", "_splines", "_t")

    def __init__(
        self,
        t: ArrayLike,
        q: ArrayLike,
        *,
        spline: SplineKind = "quintic",
        ends: SplineEnds = "not-a-knot",
    ) -> None:
        if not isinstance(spline, str):
            raise ParameterTypeError(f"spline must be 'quintic' or 'cubic', got {spline!r}")
        if spline not in _SPLINE_ORDER:
            raise ValueError(f"spline must be 'quintic' or 'cubic', got {spline!r}")
        if not isinstance(ends, str) or ends not in _SPLINE_ENDS:
            why = f"ends must be 'not-a-knot' or 'rest', got {ends!r}"
            raise ParameterTypeError(why) if not isinstance(ends, str) else ValueError(why)
        k = _SPLINE_ORDER[spline]
        times = _as_table_times(t)
        qa = number_array("q", q, message="q must be an array of numbers, shape (T_s, n)")
        if qa.ndim == 1:
            qa = qa[:, None]
        if qa.ndim != 2 or qa.shape[0] != times.shape[0] or qa.shape[1] == 0:
            raise ValueError(
                f"q must have shape (T_s, n) = ({times.shape[0]}, n) with n >= 1 "
                f"(one row per sample time), got shape {qa.shape}"
            )
        bad = ~np.isfinite(qa)
        if np.any(bad):
            j, i = np.argwhere(bad)[0]
            raise ValueError(
                f"q must be finite, got q[{j}, {i}] = {float(qa[j, i])!r} at t = {float(times[j])!r}"
            )
        fewest = 2 if ends == "rest" else k + 1
        if times.shape[0] < fewest:
            raise ValueError(
                f"a {spline} spline (degree {k}){'' if ends == 'not-a-knot' else ' at rest'} "
                f"needs at least {fewest} samples, got {times.shape[0]}"
            )
        qa = np.ascontiguousarray(qa)
        qa.flags.writeable = False
        self._t = times
        self._q = qa
        self._spline: SplineKind = spline
        self._ends: SplineEnds = ends
        # imported here: scipy.interpolate alone would double the time of `import slidingarm`
        from scipy.interpolate import make_interp_spline

        bc: Any = None
        if ends == "rest":
            zero = np.zeros(qa.shape[1])
            end = [(order, zero) for order in range(1, (k - 1) // 2 + 1)]
            bc = (end, end)
        pos = make_interp_spline(times, qa, k=k, axis=0, bc_type=bc)
        self._splines = (pos, pos.derivative(1), pos.derivative(2))

    @classmethod
    def from_csv(
        cls,
        path: str | Path,
        *,
        spline: SplineKind = "quintic",
        ends: SplineEnds = "not-a-knot",
        delimiter: str = ",",
    ) -> TableReference:
        """Read a table from a CSV file with columns ``t, q1, ..., qn``.

        An optional header row is recognised by a first field that is not a number; its first
        column must be named ``t`` or ``time``. Blank lines and lines starting with ``#`` are
        skipped. Errors name the file, the line and the column. A path that is not a regular
        file (a FIFO, a device) or is larger than :data:`slidingarm._io.MAX_TABLE_BYTES` is
        refused (``ValueError``) before it is opened.

        Parameters
        ----------
        path : str or Path
            The CSV file.
        spline : {"quintic", "cubic"}, default "quintic"
            As for :class:`TableReference`.
        ends : {"not-a-knot", "rest"}, default "not-a-knot"
            As for :class:`TableReference`.
        delimiter : str, default ","
            Field separator.
        """
        p = Path(path)
        # a FIFO would block and /dev/zero never end: regular files of a sane size only
        problem = file_problem(p, "reference table", MAX_TABLE_BYTES)
        if problem is not None and problem != "no such file":
            raise ValueError(f"{p}: {problem}")
        with p.open(newline="", encoding="utf-8") as fh:
            reader = csv.reader(fh, delimiter=delimiter)
            rows = [(reader.line_num, row) for row in reader]
        names: list[str] | None = None
        width: int | None = None
        first_line = 0
        data: list[list[float]] = []
        lines: list[int] = []
        for line, raw in rows:
            row = [field.strip() for field in raw]
            if not any(row) or row[0].startswith("#"):
                continue
            if width is None:
                width, first_line = len(row), line
                if width < 2:
                    raise ValueError(
                        f"{p}, line {line}: needs a time column and at least one joint column, "
                        f"got {width} column"
                    )
                if not _is_number(row[0]):
                    if row[0].lower() not in ("t", "time"):
                        raise ValueError(
                            f"{p}, line {line}: the first column must be the time 't', "
                            f"got header {row[0]!r}"
                        )
                    names = row
                    continue
            if len(row) != width:
                raise ValueError(
                    f"{p}, line {line}: {len(row)} columns, expected {width} "
                    f"(t and one column per joint, as on line {first_line})"
                )
            values: list[float] = []
            for col, field in enumerate(row):
                label = f"column {col + 1}" + (f" ({names[col]!r})" if names else "")
                try:
                    x = float(field)
                except ValueError:
                    raise ValueError(
                        f"{p}, line {line}, {label}: cannot read {field!r} as a number"
                    ) from None
                if not math.isfinite(x):
                    raise ValueError(f"{p}, line {line}, {label}: value {field!r} is not finite")
                values.append(x)
            if data and values[0] <= data[-1][0]:
                raise ValueError(
                    f"{p}, line {line}: time {values[0]!r} is not greater than {data[-1][0]!r} "
                    f"on line {lines[-1]}; times must be strictly increasing"
                )
            data.append(values)
            lines.append(line)
        if not data:
            raise ValueError(f"{p}: no data rows (expected columns t, q1, ..., qn)")
        arr = np.array(data, dtype=np.float64)
        try:
            return cls(arr[:, 0], arr[:, 1:], spline=spline, ends=ends)
        except ValueError as exc:
            raise ValueError(f"{p}: {exc}") from None

    @property
    def n(self) -> int:
        return int(self._q.shape[1])

    @property
    def t(self) -> FloatArray:
        """Sample times (T_s,), read-only."""
        return self._t

    @property
    def q(self) -> FloatArray:
        """Sampled positions (T_s, n), read-only."""
        return self._q

    @property
    def spline(self) -> SplineKind:
        """``"quintic"`` or ``"cubic"``."""
        return self._spline

    @property
    def ends(self) -> SplineEnds:
        """``"not-a-knot"`` or ``"rest"``."""
        return self._ends

    @property
    def t_range(self) -> tuple[float, float]:
        """First and last sample time (s): where the reference is defined."""
        return float(self._t[0]), float(self._t[-1])

    def _evaluate(self, t: FloatArray) -> Trajectory:
        t0, t1 = self.t_range
        tol = _TABLE_RANGE_RTOL * max(abs(t0), abs(t1), t1 - t0)
        outside = (t < t0 - tol) | (t > t1 + tol)
        if np.any(outside):
            i = int(np.argmax(outside))
            raise ValueError(
                f"TableReference is defined on [{t0!r}, {t1!r}] s, got t[{i}] = {float(t[i])!r}; "
                f"extend the table to cover the simulation time"
            )
        tc = np.clip(t, t0, t1)
        pos, vel, acc = self._splines
        return (
            np.asarray(pos(tc), dtype=np.float64),
            np.asarray(vel(tc), dtype=np.float64),
            np.asarray(acc(tc), dtype=np.float64),
        )

    def to_dict(self) -> dict[str, Any]:
        return {
            "kind": "table",
            "spline": self._spline,
            "ends": self._ends,
            "t": _vec_list(self._t),
            "q": [_vec_list(row) for row in self._q],
        }

    def __repr__(self) -> str:
        t0, t1 = self.t_range
        return (
            f"TableReference(<{self._t.shape[0]} samples, n={self.n}, t in [{t0!r}, {t1!r}]>, "
            f"spline={self._spline!r}, ends={self._ends!r})"
        )


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _as_table_times(t: ArrayLike) -> FloatArray:
    arr = number_array("t", t, message="t must be an array of sample times (T_s,)")
    if arr.ndim != 1:
        raise ValueError(f"t must be one-dimensional, shape (T_s,), got shape {arr.shape}")
    bad = ~np.isfinite(arr)
    if np.any(bad):
        i = int(np.argmax(bad))
        raise ValueError(f"t must be finite, got t[{i}] = {float(arr[i])!r}")
    step = np.diff(arr)
    if np.any(step <= 0.0):
        i = int(np.argmax(step <= 0.0))
        raise ValueError(
            f"t must be strictly increasing, got t[{i + 1}] = {float(arr[i + 1])!r} <= t[{i}] = {float(arr[i])!r}"
        )
    arr.flags.writeable = False
    return arr


# --------------------------------------------------------------------------------------------
# user functions


class CallableReference(Reference):
    """A reference given by Python functions for :math:`q_d`, :math:`\\dot q_d`, :math:`\\ddot q_d`.

    Each function maps the sample times ``t`` (T,) to an array of shape (T, n) (or (T,) when
    ``n == 1``). The derivatives must be supplied: slidingarm never differentiates a reference
    numerically (docs/theory.md §2). The outputs are checked for shape and finiteness at every call; the
    functions are not checked against each other.

    A ``CallableReference`` cannot be rebuilt from :meth:`to_dict` (which records the functions'
    names only); build it in Python.

    Parameters
    ----------
    q, qd, qdd : callable
        ``f(t: ndarray (T,)) -> ndarray (T, n)``; ``t`` is passed read-only.
    n : int
        Number of joints, ``n >= 1``.
    """

    __slots__ = ("_funcs", "_n")

    def __init__(
        self,
        q: Callable[[FloatArray], ArrayLike],
        qd: Callable[[FloatArray], ArrayLike] | None = None,
        qdd: Callable[[FloatArray], ArrayLike] | None = None,
        *,
        n: int,
    ) -> None:
        for name, f in (("q", q), ("qd", qd), ("qdd", qdd)):
            if f is None:
                raise ValueError(
                    f"CallableReference needs {name}: the derivatives qd and qdd must be "
                    "supplied as functions (slidingarm never differentiates a reference "
                    "numerically)"
                )
            if not callable(f):
                raise ParameterTypeError(f"CallableReference: {name} must be callable, got {f!r}")
        count = integer(
            "n", n, low=1, message=f"n must be an integer >= 1 (number of joints), got {n!r}"
        )
        assert qd is not None and qdd is not None
        self._funcs: tuple[Callable[[FloatArray], ArrayLike], ...] = (q, qd, qdd)
        self._n = count

    @property
    def n(self) -> int:
        return self._n

    def _evaluate(self, t: FloatArray) -> Trajectory:
        view = t.view()
        view.flags.writeable = False
        f_q, f_qd, f_qdd = self._funcs
        return (
            self._call("q", f_q, view),
            self._call("qd", f_qd, view),
            self._call("qdd", f_qdd, view),
        )

    def _call(self, name: str, f: Callable[[FloatArray], ArrayLike], t: FloatArray) -> FloatArray:
        T, n = t.shape[0], self._n
        expected = f"({T}, {n})" + (f" or ({T},)" if n == 1 else "")
        raw = f(t)
        try:
            arr = np.asarray(raw, dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise ValueError(
                f"CallableReference: {name}(t) must return numbers of shape {expected}, "
                f"got {type(raw).__name__}"
            ) from exc
        if n == 1 and arr.shape == (T,):
            arr = arr.reshape(T, 1)
        if arr.shape != (T, n):
            raise ValueError(
                f"CallableReference: {name}(t) returned shape {arr.shape} for t of shape ({T},); "
                f"expected {expected}"
            )
        if not np.isfinite(arr).all():
            k, j = np.argwhere(~np.isfinite(arr))[0]
            raise ValueError(
                f"CallableReference: {name}(t) is not finite at t = {float(t[k])!r} (joint {j}): "
                f"{float(arr[k, j])!r}"
            )
        return arr

    def to_dict(self) -> dict[str, Any]:
        names = [getattr(f, "__qualname__", repr(f)) for f in self._funcs]
        return {"kind": "callable", "n": self._n, "q": names[0], "qd": names[1], "qdd": names[2]}

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Reference):
            return NotImplemented
        return (
            isinstance(other, CallableReference)
            and self._n == other._n
            and all(a is b for a, b in zip(self._funcs, other._funcs, strict=True))
        )

    def __hash__(self) -> int:
        return hash((self._n, *map(id, self._funcs)))

    def __repr__(self) -> str:
        d = self.to_dict()
        return f"CallableReference(q={d['q']}, qd={d['qd']}, qdd={d['qdd']}, n={self._n})"

    def __reduce__(self) -> tuple[Any, ...]:
        """Pickle by the functions themselves: possible when each of them pickles (a
        module-level function, a :func:`functools.partial` of one, …), not for a lambda or a
        nested function, for which a :class:`TypeError` says so."""
        for name, f in zip(("q", "qd", "qdd"), self._funcs, strict=True):
            try:
                pickle.dumps(f)
            except Exception as exc:
                raise TypeError(
                    f"CallableReference cannot be pickled: its {name} function {f!r} does not "
                    f"pickle ({type(exc).__name__}: {exc}); give module-level functions, or use "
                    "a reference that always pickles (TableReference, SineReference, "
                    "QuinticReference, PaperReference)"
                ) from exc
        return (_callable_reference, (*self._funcs, self._n))


def _callable_reference(
    q: Callable[[FloatArray], ArrayLike],
    qd: Callable[[FloatArray], ArrayLike],
    qdd: Callable[[FloatArray], ArrayLike],
    n: int,
) -> CallableReference:
    """Rebuild a pickled :class:`CallableReference`."""
    return CallableReference(q, qd, qdd, n=n)


# --------------------------------------------------------------------------------------------
# factory


_KEYS: dict[str, tuple[frozenset[str], frozenset[str]]] = {
    # kind: (required keys, optional keys), "kind" excluded
    "paper": (frozenset(), frozenset()),
    "quintic": (frozenset({"q_start", "q_end", "duration"}), frozenset({"t_start"})),
    "sine": (frozenset({"offset", "amplitude", "frequency"}), frozenset({"phase"})),
    "table": (frozenset(), frozenset({"t", "q", "path", "spline", "ends"})),
}


def reference_from_dict(d: Mapping[str, Any], *, base_dir: str | Path | None = None) -> Reference:
    """Rebuild a reference from :meth:`Reference.to_dict` output (or a configuration table).

    Parameters
    ----------
    d : mapping
        ``{"kind": ..., <parameters>}`` with ``kind`` one of ``"paper"``, ``"quintic"``,
        ``"sine"``, ``"table"``. A table gives either ``t`` and ``q`` inline or ``path`` to a
        CSV file (:meth:`TableReference.from_csv`), and optionally ``spline`` and ``ends``.
    base_dir : str or Path, optional
        Directory a relative table ``path`` is resolved against (for example the configuration
        file's directory); default the current directory.

    Raises
    ------
    ValueError
        For a missing or unknown ``kind``, missing or unknown keys, ``kind = "callable"``
        (functions cannot be rebuilt from a dict), or invalid parameters.
    """
    if not isinstance(d, Mapping):
        raise ValueError(f"a reference must be given as a mapping with a 'kind' key, got {d!r}")
    if "kind" not in d:
        raise ValueError(
            f"reference needs a 'kind' key, one of {list(_KEYS)}; got keys {sorted(d)}"
        )
    kind = d["kind"]
    if not isinstance(kind, str):
        raise ParameterTypeError(
            f"reference kind must be a string, one of {list(_KEYS)}; got {kind!r}"
        )
    if kind == "callable":
        raise ValueError(
            "a CallableReference cannot be rebuilt from a dict (its functions are Python code); "
            "construct it in Python with CallableReference(q, qd, qdd, n=...)"
        )
    if kind not in _KEYS:
        raise ValueError(f"unknown reference kind {kind!r}; expected one of {list(_KEYS)}")
    required, optional = _KEYS[kind]
    keys = set(d) - {"kind"}
    missing = required - keys
    if missing:
        raise ValueError(
            f"reference kind {kind!r} needs {sorted(missing)}; got keys {sorted(keys)}"
        )
    unknown = keys - required - optional
    if unknown:
        raise ValueError(
            f"unknown key(s) {sorted(unknown)} for reference kind {kind!r}; "
            f"allowed: {sorted(required | optional)}"
        )
    if kind == "paper":
        return PaperReference()
    if kind == "quintic":
        return QuinticReference(
            d["q_start"], d["q_end"], duration=d["duration"], t_start=d.get("t_start", 0.0)
        )
    if kind == "sine":
        return SineReference(d["offset"], d["amplitude"], d["frequency"], d.get("phase", 0.0))
    # table
    spline = d.get("spline", "quintic")
    ends = d.get("ends", "not-a-knot")
    if "path" in d:
        if "t" in keys or "q" in keys:
            raise ValueError("a table reference takes either 'path' or 't' and 'q', not both")
        path = Path(d["path"])
        if base_dir is not None and not path.is_absolute():
            path = Path(base_dir) / path
        return TableReference.from_csv(path, spline=spline, ends=ends)
    if "t" not in keys or "q" not in keys:
        raise ValueError(
            "a table reference needs 't' and 'q' (or 'path' to a CSV file); "
            f"got keys {sorted(keys)}"
        )
    return TableReference(d["t"], d["q"], spline=spline, ends=ends)
