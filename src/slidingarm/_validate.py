"""Checks shared by the parameter classes: what counts as a number, and per-joint values.

One definition each, so that every parameter class agrees on what it accepts. A boolean is
never a number here (``k=True`` is a mistake, not a gain of 1), whether it is Python's
``bool`` or numpy's ``np.bool_``, alone, in a sequence or as an array's dtype; nor is a
string, even one that reads as a number.

One validator per meaning, serving the library's classes and the scenario files alike:

- :func:`real` -- a real number, finite unless told otherwise, with optional bounds;
- :func:`integer` -- an integer with an optional lower bound (and oddness);
- :func:`per_joint` -- a finite number, or one per joint (a non-empty 1-D sequence);
- :func:`number_array` -- anything array-like of real numbers, as a float array (shape checks
  are the caller's).

A value of the wrong *type* (a string, bytes, a boolean, a set, ``None``, a mapping, ...)
raises :class:`ParameterTypeError`, a :class:`TypeError`; a number of the wrong *value* (NaN,
out of range, an integer too large for a float) raises :class:`ValueError`. Neither
:class:`OverflowError` nor :class:`AttributeError` ever escapes.

The messages name the parameter and what is allowed; callers with an established wording pass
their own (``message``, or ``invalid``, ``boolean``, ``not_finite``, ``out_of_range`` of
:func:`per_joint`). An empty ``name`` gives messages that start with "must" (the scenario files
put the key path in front).
"""

from __future__ import annotations

import math
import numbers

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "MAX_POSITION",
    "MIN_EPS_E",
    "ParameterTypeError",
    "as_real",
    "has_bool",
    "integer",
    "is_integer",
    "is_real",
    "number_array",
    "per_joint",
    "plain",
    "positive",
    "real",
]


#: The largest joint position (rad, or m for a prismatic joint) an initial state, a reference
#: or a position-noise standard deviation may have: 1e3 rad is 159 turns, 1e3 m a kilometre of
#: travel, beyond any arm's. It keeps squared tracking errors (about 1e6) and their integrals
#: over any run far inside the float range, where 1e300 makes the MSE overflow to inf.
MAX_POSITION = 1e3

#: The smallest singularity guard ``eps_e`` (rad) of a terminal surface. The guarded power
#: :math:`\max(|e|, \varepsilon_e)^{\gamma - 1}` is at most :math:`\varepsilon_e^{-1}` for
#: :math:`0 < \gamma < 1`, so 1e-300 keeps it below 1e300, eight decades under the float
#: maximum for the gains and rates that multiply it; a guard of 1e-320 with
#: :math:`\gamma = 0.01` gives inf.
MIN_EPS_E = 1e-300


class ParameterTypeError(TypeError, ValueError):
    """A parameter of the wrong type: a string, bytes, a boolean, a set, ``None``, … where a
    number or a sequence of numbers goes.

    A :class:`TypeError`. It is also a :class:`ValueError`, so that code written when every
    invalid parameter raised :class:`ValueError` (``except ValueError``) still catches it.
    """


def _subject(name: str) -> str:
    return f"{name} " if name else ""


def _bounds_text(
    low: float | None, high: float | None, low_inclusive: bool, high_inclusive: bool
) -> str:
    if low is not None and high is not None:
        left, right = "[" if low_inclusive else "(", "]" if high_inclusive else ")"
        return f" in {left}{low:g}, {high:g}{right}"
    if low is not None:
        return f" {'>=' if low_inclusive else '>'} {low:g}"
    if high is not None:
        return f" {'<=' if high_inclusive else '<'} {high:g}"
    return ""


def is_real(value: object, *, finite: bool = False) -> bool:
    """Whether ``value`` is a real number: not a boolean, a string, an array or ``None``.

    Parameters
    ----------
    value : object
        Anything.
    finite : bool, default False
        Also require :math:`|x| < \\infty` (no NaN or inf).

    Returns
    -------
    bool
        ``True`` for Python and numpy integers and floats (any :class:`numbers.Real`) other
        than ``bool`` and ``np.bool_``.
    """
    kind = type(value)
    if kind is float or kind is int:  # the common case, without the ABC checks below
        return not finite or math.isfinite(value)  # type: ignore[arg-type]
    if not isinstance(value, numbers.Real) or isinstance(value, bool | np.bool_):
        return False
    return not finite or math.isfinite(value)


def is_integer(value: object) -> bool:
    """Whether ``value`` is an integer (Python or numpy), not a boolean and not a float."""
    if type(value) is int:  # the common case, without the ABC checks below
        return True
    return isinstance(value, numbers.Integral) and not isinstance(value, bool | np.bool_)


def has_bool(value: object) -> bool:
    """Whether ``value`` is a boolean or a sequence or array holding one.

    ``bool`` and ``np.bool_`` scalars, arrays of dtype ``bool``, and object arrays, lists and
    tuples with a boolean anywhere inside.
    """
    if isinstance(value, bool | np.bool_):
        return True
    if isinstance(value, np.ndarray):
        return value.dtype == np.bool_ or (
            value.dtype == object and any(has_bool(v) for v in value.flat)
        )
    if isinstance(value, list | tuple):
        return any(has_bool(v) for v in value)
    return False


def real(
    name: str,
    value: object,
    *,
    low: float | None = None,
    high: float | None = None,
    low_inclusive: bool = True,
    high_inclusive: bool = True,
    finite: bool = True,
    allowed: str | None = None,
    message: str | None = None,
) -> float:
    """``value`` as a float, checked to be a real number (:func:`is_real`) within bounds.

    Parameters
    ----------
    name : str
        The parameter, as the messages name it ("" for messages that start with "must").
    value : object
        Anything.
    low, high : float, optional
        Bounds; ``low_inclusive`` and ``high_inclusive`` (default True) say whether they are
        allowed.
    finite : bool, default True
        Reject NaN and ±inf (and integers too large for a float).
    allowed : str, optional
        What is allowed, in words, e.g. ``"a number > 0"``; default from the bounds.
    message : str, optional
        The whole message for any fault (type or value).

    Raises
    ------
    ParameterTypeError
        ``"{name} must be {allowed}, not a boolean, got {value!r}"`` for a boolean,
        ``"{name} must be {allowed}, got {value!r}"`` for anything else that is not a number.
    ValueError
        ``"{name} must be {allowed}, got {value!r}"`` for a number out of range or not finite.
    """
    what = allowed or (
        ("a finite number" if finite and low is None and high is None else "a number")
        + _bounds_text(low, high, low_inclusive, high_inclusive)
    )
    subject = _subject(name)
    if isinstance(value, bool | np.bool_):
        raise ParameterTypeError(
            message or f"{subject}must be {what}, not a boolean, got {value!r}"
        )
    if not isinstance(value, numbers.Real):
        raise ParameterTypeError(message or f"{subject}must be {what}, got {value!r}")
    try:
        x = float(value)
    except OverflowError:
        x = math.inf if value > 0 else -math.inf  # type: ignore[operator]
    bad = (
        (finite and not math.isfinite(x))
        or ((low is not None or high is not None) and math.isnan(x))
        or (low is not None and (x < low or (x == low and not low_inclusive)))
        or (high is not None and (x > high or (x == high and not high_inclusive)))
    )
    if bad:
        raise ValueError(message or f"{subject}must be {what}, got {value!r}")
    return x


def integer(
    name: str,
    value: object,
    *,
    low: float | None = None,
    high: float | None = None,
    odd: bool = False,
    allowed: str | None = None,
    message: str | None = None,
) -> int:
    """``value`` as an int, checked to be an integer (:func:`is_integer`: not a boolean, not a
    float however integral) ``>= low`` and ``<= high``, and odd with ``odd``.

    Raises
    ------
    ParameterTypeError
        ``"{name} must be {allowed}, not a boolean, got {value!r}"`` or
        ``"{name} must be {allowed}, got {value!r}"`` for a value that is not an integer.
    ValueError
        ``"{name} must be {allowed}, got {value!r}"`` for an integer out of range or even.
    """
    what = allowed or ("an odd integer" if odd else "an integer") + _bounds_text(
        low, high, True, True
    )
    subject = _subject(name)
    if isinstance(value, bool | np.bool_):
        raise ParameterTypeError(
            message or f"{subject}must be {what}, not a boolean, got {value!r}"
        )
    if not is_integer(value):
        raise ParameterTypeError(message or f"{subject}must be {what}, got {value!r}")
    k = int(value)  # type: ignore[call-overload]
    if (low is not None and k < low) or (high is not None and k > high) or (odd and k % 2 == 0):
        raise ValueError(message or f"{subject}must be {what}, got {value!r}")
    return k


def as_real(name: str, value: object) -> float:
    """``value`` as a float, or an error naming ``name`` if it is not a real number (NaN and
    inf are real numbers here).

    Raises
    ------
    ParameterTypeError
        ``"{name} must be a number, not a boolean, got {value!r}"`` for a boolean,
        ``"{name} must be a number, got {value!r}"`` for anything else that is not
        :func:`is_real`.
    """
    return real(name, value, finite=False, allowed="a number")


def positive(name: str, value: object, *, why: str = "") -> float:
    """``value`` as a float, checked to be a real number, finite and > 0.

    Raises
    ------
    ParameterTypeError
        As :func:`as_real`.
    ValueError
        ``"{name} must be a finite value > 0{why}, got {value!r}"``.
    """
    v = as_real(name, value)
    if not (math.isfinite(v) and v > 0):
        raise ValueError(f"{name} must be a finite value > 0{why}, got {value!r}")
    return v


def _float(x: object) -> float:
    try:
        return float(x)  # type: ignore[arg-type]
    except OverflowError:  # an integer beyond the float range
        return math.inf if x > 0 else -math.inf  # type: ignore[operator]


def _numeric_array(value: object) -> NDArray[np.float64] | None:
    """``value`` as a float array if it is a number or a (nested) list, tuple or array of
    numbers, else ``None`` (strings, bytes, sets, mappings, ``None``, ragged nesting).
    Booleans are assumed already rejected; an integer too large for a float becomes ±inf."""
    if isinstance(value, str | bytes | bytearray | memoryview):
        return None
    try:
        arr = np.asarray(value)
    except (TypeError, ValueError, OverflowError):  # ragged nesting
        return None
    if arr.dtype.kind == "O":
        flat = list(arr.flat)
        if not all(is_real(v) for v in flat):
            return None
        return np.array([_float(v) for v in flat], dtype=np.float64).reshape(arr.shape)
    if arr.dtype.kind not in "iuf":
        return None
    try:
        return arr.astype(np.float64)
    except (TypeError, ValueError, OverflowError):  # pragma: no cover - iuf always converts
        return None


def number_array(name: str, value: object, *, message: str | None = None) -> NDArray[np.float64]:
    """``value`` (a number, or a nested list, tuple or array of numbers) as a new float64 array.

    Only the type is checked here: shape, finiteness and bounds are the caller's.

    Raises
    ------
    ParameterTypeError
        ``"{name} must be numbers, not booleans, got {value!r}"`` or
        ``"{name} must be numbers, got {value!r}"`` (or ``message``).
    """
    if has_bool(value):
        raise ParameterTypeError(
            message or f"{_subject(name)}must be numbers, not booleans, got {value!r}"
        )
    arr = _numeric_array(value)
    if arr is None:
        raise ParameterTypeError(message or f"{_subject(name)}must be numbers, got {value!r}")
    return arr


def _plain_per_joint(
    value: object, low: float | None, inclusive: bool
) -> float | tuple[float, ...] | None:
    """:func:`per_joint`'s result for a valid Python ``float``/``int`` or a non-empty list or
    tuple of them, without numpy (a sweep builds a few dozen such values per draw, and numpy's
    reductions on three-element arrays cost microseconds each); ``None`` for anything else
    and for any value that fails a check, which the general path then words."""
    try:
        if type(value) is float or type(value) is int:
            x = float(value)
            xs: tuple[float, ...] = (x,)
            result: float | tuple[float, ...] = x
        elif (type(value) is list or type(value) is tuple) and value:
            if not all(type(v) is float or type(v) is int for v in value):
                return None
            xs = result = tuple(float(v) for v in value)
        else:
            return None
    except OverflowError:  # an integer beyond the float range: the general path says so
        return None
    for x in xs:
        if not math.isfinite(x):
            return None
        if low is not None and (x < low or (not inclusive and x == low)):
            return None
    return result


def per_joint(
    name: str,
    value: object,
    *,
    low: float | None = None,
    inclusive: bool = False,
    why: str = "",
    invalid: str | None = None,
    boolean: str | None = None,
    not_finite: str | None = None,
    out_of_range: str | None = None,
) -> float | tuple[float, ...]:
    """Validate a per-joint value: one finite number, or a non-empty 1-D sequence of them.

    Parameters
    ----------
    name : str
        The parameter, as the messages name it.
    value : object
        A number, or a list, tuple or 1-D array of numbers (one per joint).
    low : float, optional
        Lower bound: every entry must be ``> low`` (``>= low`` with ``inclusive``).
    inclusive : bool, default False
        Whether ``low`` itself is allowed.
    why : str, default ""
        Appended to the bound in the out-of-range message, e.g.
        ``" (a relative error; -1 would remove the link)"``.
    invalid : str, optional
        The whole message for a value that is not a finite number or a non-empty 1-D sequence
        of them (and for a boolean, unless ``boolean`` is given). Default: one message per
        fault, below.
    boolean : str, optional
        The whole message for a boolean anywhere in ``value``.
    not_finite : str, optional
        The whole message for a NaN or infinite entry (default ``invalid``, if given).
    out_of_range : str, optional
        The whole message for an entry below ``low``.

    Returns
    -------
    float or tuple of float
        A float if ``value`` is a scalar, else a tuple with one float per joint.

    Raises
    ------
    ParameterTypeError
        For a value that is not a number or a sequence of numbers (a string, bytes, a set,
        ``None``, a boolean anywhere): unless overridden, ``"{name} must be a number or one
        number per joint, not a boolean, got {value!r}"`` or ``"... per joint, got {value!r}"``.
    ValueError
        For numbers of the wrong shape or value: unless overridden,
        ``"{name} must be a scalar or a 1-D vector (one per joint), got shape {shape}"``,
        ``"{name} must not be empty"``, ``"{name} must be finite, got {shown}"`` or
        ``"{name} must be > {low}{why}, got {shown}"`` (``>=`` with ``inclusive``), where
        ``shown`` is ``value`` with its entries as floats.
    """
    fast = _plain_per_joint(value, low, inclusive)
    if fast is not None:
        return fast
    if has_bool(value):
        raise ParameterTypeError(
            boolean
            or invalid
            or f"{name} must be a number or one number per joint, not a boolean, got {value!r}"
        )
    arr = _numeric_array(value)
    if arr is None:
        raise ParameterTypeError(
            invalid or f"{name} must be a number or one number per joint, got {value!r}"
        )
    if arr.ndim > 1:
        raise ValueError(
            invalid
            or f"{name} must be a scalar or a 1-D vector (one per joint), got shape {arr.shape}"
        )
    if arr.size == 0:
        raise ValueError(invalid or f"{name} must not be empty")
    result: float | tuple[float, ...] = float(arr) if arr.ndim == 0 else tuple(arr.tolist())
    shown = list(result) if isinstance(result, tuple) and not isinstance(value, tuple) else result
    if not np.all(np.isfinite(arr)):
        raise ValueError(not_finite or invalid or f"{name} must be finite, got {shown!r}")
    if low is not None and (np.any(arr < low) or (not inclusive and np.any(arr == low))):
        bound = f"{'>=' if inclusive else '>'} {low:g}"
        raise ValueError(out_of_range or f"{name} must be {bound}{why}, got {shown!r}")
    return result


def plain(value: float | tuple[float, ...]) -> float | list[float]:
    """A :func:`per_joint` value as JSON has it (a list, not a tuple), so that parameters
    survive a round trip through ``to_dict``."""
    return list(value) if isinstance(value, tuple) else value
