"""slidingarm._validate: one definition of a number, a boolean and a per-joint value."""

from __future__ import annotations

import math
from fractions import Fraction
from typing import Any

import numpy as np
import pytest

from slidingarm._validate import (
    as_real,
    has_bool,
    is_integer,
    is_real,
    per_joint,
    plain,
    positive,
)


@pytest.mark.parametrize(
    "value", [0, -3, 2.5, math.nan, math.inf, np.int64(2), np.float32(0.5), Fraction(1, 3)]
)
def test_real_numbers(value: Any) -> None:
    assert is_real(value)


@pytest.mark.parametrize(
    "value", [True, False, np.True_, np.False_, "1.5", None, np.array(1.0), [1.0], 1j]
)
def test_not_real_numbers(value: Any) -> None:
    assert not is_real(value)


def test_finite_real_numbers() -> None:
    assert is_real(1.0, finite=True) and is_real(np.int8(-1), finite=True)
    assert not any(is_real(v, finite=True) for v in (math.nan, math.inf, -np.inf, True))


def test_integers() -> None:
    assert is_integer(3) and is_integer(np.int64(-2)) and is_integer(np.uint8(1))
    assert not any(is_integer(v) for v in (True, np.True_, 2.0, np.float64(2.0), "2", None))


@pytest.mark.parametrize(
    "value",
    [
        True,
        np.False_,
        np.array([True, False]),
        np.array([1.0, True], dtype=object),
        [1.0, True],
        (1.0, (2.0, np.True_)),
    ],
)
def test_has_bool(value: Any) -> None:
    assert has_bool(value)


@pytest.mark.parametrize("value", [1, 1.0, np.array([1.0, 0.0]), [1, 0], (0.0,), "True", None])
def test_has_no_bool(value: Any) -> None:
    assert not has_bool(value)


def test_as_real_and_positive() -> None:
    assert as_real("x", np.float32(0.5)) == 0.5 and isinstance(as_real("x", 2), float)
    with pytest.raises(TypeError, match=r"^x must be a number, not a boolean, got np\.True_$"):
        as_real("x", np.True_)
    with pytest.raises(TypeError, match=r"^x must be a number, got '2'$"):
        as_real("x", "2")
    assert positive("x", 3) == 3.0
    with pytest.raises(ValueError, match=r"^x must be a finite value > 0 \(why\), got 0$"):
        positive("x", 0, why=" (why)")
    with pytest.raises(ValueError, match=r"^x must be a finite value > 0, got inf$"):
        positive("x", math.inf)


def test_per_joint_values() -> None:
    assert per_joint("g", 2) == 2.0 and isinstance(per_joint("g", 2), float)
    assert per_joint("g", [1, 2.5]) == (1.0, 2.5)
    assert per_joint("g", np.array([1, 2, 3])) == (1.0, 2.0, 3.0)
    assert per_joint("g", np.float64(0.0), low=0.0, inclusive=True) == 0.0
    assert per_joint("g", (-0.5,), low=-1.0) == (-0.5,)
    assert plain(per_joint("g", (1.0, 2.0))) == [1.0, 2.0] and plain(1.5) == 1.5


@pytest.mark.parametrize(
    ("value", "kw", "message"),
    [
        (True, {}, "g must be a number or one number per joint, not a boolean, got True"),
        (
            np.array([True, False]),
            {},
            "g must be a number or one number per joint, not a boolean, "
            "got array([ True, False])",
        ),
        ("2", {}, "g must be a number or one number per joint, got '2'"),
        ([1.0, None], {}, "g must be a number or one number per joint, got [1.0, None]"),
        ([[1.0, 2.0]], {}, "g must be a scalar or a 1-D vector (one per joint), got shape (1, 2)"),
        ([], {}, "g must not be empty"),
        ([1.0, math.nan], {}, "g must be finite, got [1.0, nan]"),
        (0, {"low": 0.0}, "g must be > 0, got 0.0"),
        ((1.0, -1.0), {"low": 0.0, "inclusive": True}, "g must be >= 0, got (1.0, -1.0)"),
        (np.array([0.5, -1.0]), {"low": -1.0, "why": " (why)"}, "g must be > -1 (why), got [0.5, -1.0]"),
        # the caller's own wording
        (np.True_, {"invalid": "bad"}, "bad"),
        ([], {"invalid": "bad"}, "bad"),
        (True, {"invalid": "bad", "boolean": "no booleans"}, "no booleans"),
        (-1.0, {"low": 0.0, "invalid": "bad"}, "g must be > 0, got -1.0"),
        (-1.0, {"low": 0.0, "out_of_range": "too low"}, "too low"),
    ],
)  # fmt: skip
def test_per_joint_errors(value: Any, kw: dict[str, Any], message: str) -> None:
    # a wrong type (booleans, strings, None) is a TypeError; a wrong value a ValueError
    wrong_type = (
        has_bool(value) or isinstance(value, str) or (isinstance(value, list) and None in value)
    )
    with pytest.raises(TypeError if wrong_type else ValueError) as info:
        per_joint("g", value, **kw)
    assert str(info.value) == message
    if not wrong_type:
        assert not isinstance(info.value, TypeError)


@pytest.mark.parametrize(
    "value", [0, 2, -0.0, 1.5, [1, 2, 3], (0.25, 4), [2**60, 1e-300, -7.0], [10**400]]
)
def test_per_joint_gives_the_same_for_python_numbers_as_for_arrays(value: object) -> None:
    """Python numbers and lists of them skip numpy (the sweep's staging); the result is the
    general path's, which a numpy array of the same values takes."""
    from slidingarm._validate import per_joint

    array = np.array(value, dtype=object if value == [10**400] else None)
    if value == [10**400]:
        with pytest.raises(ValueError, match="x must be finite"):
            per_joint("x", value)
        return
    got, want = per_joint("x", value), per_joint("x", array)
    assert got == want and type(got) is type(want)
    for low, inclusive in ((-1e300, False), (-0.0, True)):
        if all(v >= low for v in np.atleast_1d(np.asarray(value, dtype=float))):
            assert per_joint("x", value, low=low, inclusive=inclusive) == want
    # a value a check refuses is worded by the general path, whichever way it came
    with pytest.raises(ValueError, match=r"x must be > 1e\+300"):
        per_joint("x", value, low=1e300)
