"""Checks shared by the parameter classes: what counts as a number, and per-joint values.

One definition each, so that every parameter class agrees on what it accepts. A boolean is
never a number here (``k=True`` is a mistake, not a gain of 1), whether it is Python's
``bool`` or numpy's ``np.bool_``, alone, in a sequence or as an array's dtype; nor is a
string, even one that reads as a number.

The messages name the parameter and what is allowed; callers with an established wording pass
their own (``invalid``, ``boolean``, ``out_of_range`` of :func:`per_joint`).
"""

from __future__ import annotations

import math
import numbers

import numpy as np
from numpy.typing import NDArray

__all__ = ["as_real", "has_bool", "is_integer", "is_real", "per_joint", "plain", "positive"]


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
    if not isinstance(value, numbers.Real) or isinstance(value, bool | np.bool_):
        return False
    return not finite or math.isfinite(value)


def is_integer(value: object) -> bool:
    """Whether ``value`` is an integer (Python or numpy), not a boolean and not a float."""
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


def as_real(name: str, value: object) -> float:
    """``value`` as a float, or a :class:`ValueError` naming ``name`` if it is not a real number.

    Raises
    ------
    ValueError
        ``"{name} must be a number, not a boolean, got {value!r}"`` for a boolean,
        ``"{name} must be a number, got {value!r}"`` for anything else that is not
        :func:`is_real`.
    """
    if isinstance(value, bool | np.bool_):
        raise ValueError(f"{name} must be a number, not a boolean, got {value!r}")
    if not isinstance(value, numbers.Real):  # with the line above: not is_real(value)
        raise ValueError(f"{name} must be a number, got {value!r}")
    return float(value)


def positive(name: str, value: object, *, why: str = "") -> float:
    """``value`` as a float, checked to be a real number, finite and > 0.

    Raises
    ------
    ValueError
        As :func:`as_real`, or ``"{name} must be a finite value > 0{why}, got {value!r}"``.
    """
    v = as_real(name, value)
    if not (math.isfinite(v) and v > 0):
        raise ValueError(f"{name} must be a finite value > 0{why}, got {value!r}")
    return v


def _numeric_array(value: object) -> NDArray[np.float64] | None:
    """``value`` as a float array if it is a number or a (nested) sequence or array of numbers,
    else ``None``. Booleans are assumed already rejected."""
    try:
        arr = np.asarray(value)
    except (TypeError, ValueError):  # ragged nesting
        return None
    if arr.dtype.kind == "O":
        if not all(is_real(v) for v in arr.flat):
            return None
    elif arr.dtype.kind not in "iuf":
        return None
    try:
        return arr.astype(np.float64)
    except (TypeError, ValueError, OverflowError):
        return None


def per_joint(
    name: str,
    value: object,
    *,
    low: float | None = None,
    inclusive: bool = False,
    why: str = "",
    invalid: str | None = None,
    boolean: str | None = None,
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
    out_of_range : str, optional
        The whole message for an entry below ``low``.

    Returns
    -------
    float or tuple of float
        A float if ``value`` is a scalar, else a tuple with one float per joint.

    Raises
    ------
    ValueError
        With, unless overridden, ``"{name} must be a number or one number per joint, not a
        boolean, got {value!r}"``, ``"... per joint, got {value!r}"`` (not numbers),
        ``"{name} must be a scalar or a 1-D vector (one per joint), got shape {shape}"``,
        ``"{name} must not be empty"``, ``"{name} must be finite, got {shown}"`` or
        ``"{name} must be > {low}{why}, got {shown}"`` (``>=`` with ``inclusive``), where
        ``shown`` is ``value`` with its entries as floats.
    """
    if has_bool(value):
        raise ValueError(
            boolean
            or invalid
            or f"{name} must be a number or one number per joint, not a boolean, got {value!r}"
        )
    arr = _numeric_array(value)
    if arr is None:
        raise ValueError(
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
        raise ValueError(invalid or f"{name} must be finite, got {shown!r}")
    if low is not None and (np.any(arr < low) or (not inclusive and np.any(arr == low))):
        bound = f"{'>=' if inclusive else '>'} {low:g}"
        raise ValueError(out_of_range or f"{name} must be {bound}{why}, got {shown!r}")
    return result


def plain(value: float | tuple[float, ...]) -> float | list[float]:
    """A :func:`per_joint` value as JSON has it (a list, not a tuple), so that parameters
    survive a round trip through ``to_dict``."""
    return list(value) if isinstance(value, tuple) else value
