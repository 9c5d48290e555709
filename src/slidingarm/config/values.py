"""Value types of scenario files: numbers with their bounds, per-joint values, vectors, and
their JSON schema; one error per bad value, with the allowed range in words.

The checks themselves are :mod:`slidingarm._validate`'s, the same the library's classes use.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Annotated, Any, Literal

from pydantic import BaseModel, BeforeValidator, ConfigDict, Field
from pydantic.functional_validators import PlainValidator
from pydantic.json_schema import WithJsonSchema

from slidingarm._validate import is_integer, is_real

_NAME_PATTERN = r"^[A-Za-z0-9][A-Za-z0-9_.-]*$"


def _bound(low: float | None, inclusive: bool) -> str:
    return "" if low is None else (f" >= {low:g}" if inclusive else f" > {low:g}")


def _below(x: float, low: float | None, inclusive: bool) -> bool:
    return low is not None and (x < low or (x == low and not inclusive))


def _per_joint_check(
    low: float | None, *, inclusive: bool = False, what: str = ""
) -> Callable[[Any], float | list[float]]:
    """Validator of a finite number or a non-empty list of them (one per joint)."""
    bound = _bound(low, inclusive)

    def check(v: Any) -> float | list[float]:
        if is_real(v):
            values, scalar = [float(v)], True
        elif isinstance(v, list | tuple) and v and all(is_real(x) for x in v):
            values, scalar = [float(x) for x in v], False
        else:
            raise ValueError(
                f"must be a number{bound} or a list of them (one per joint){what}, got {v!r}"
            )
        for x in values:
            if not math.isfinite(x):
                raise ValueError(f"must be finite, got {v!r}")
            if _below(x, low, inclusive):
                raise ValueError(f"must be{bound}{what} (a scalar or one per joint), got {v!r}")
        return values[0] if scalar else values

    return check


def _vector_check(
    low: float | None = None, *, inclusive: bool = False
) -> Callable[[Any], list[float]]:
    """Validator of a non-empty list of finite numbers (one per joint)."""
    bound = _bound(low, inclusive)

    def check(v: Any) -> list[float]:
        if not (isinstance(v, list | tuple) and v and all(is_real(x) for x in v)):
            raise ValueError(f"must be a list of numbers{bound} (one per joint), got {v!r}")
        values = [float(x) for x in v]
        if any(not math.isfinite(x) or _below(x, low, inclusive) for x in values):
            raise ValueError(f"must be a list of finite numbers{bound}, got {v!r}")
        return values

    return check


def _type_check(allowed: str, accept: Callable[[Any], bool]) -> Callable[[Any], Any]:
    """Before-validator of a plain number: ``accept`` (:func:`is_real` or :func:`is_integer`)
    lets a value through to pydantic, which converts and bounds it; ``allowed`` says what is
    allowed (``"a number > 0"``, ``"an integer >= 1"``).

    Without it, pydantic's lax mode would read ``true`` as 1, the float ``2.0`` as the integer
    2 and the string ``"4.5"`` as 4.5.
    """

    def check(v: Any) -> Any:
        if isinstance(v, bool):
            raise ValueError(f"must be {allowed}, not a boolean, got {v!r}")
        if not accept(v):
            raise ValueError(f"must be {allowed}, got {v!r}")
        return v

    return check


def _number(allowed: str) -> BeforeValidator:
    return BeforeValidator(_type_check(allowed, is_real))


def _integer(allowed: str) -> BeforeValidator:
    return BeforeValidator(_type_check(allowed, is_integer))


def _schema(low: float | None, *, inclusive: bool = False, scalar: bool = True) -> dict[str, Any]:
    """JSON schema of a per-joint value (``scalar``: a number or a list) or a vector."""
    item: dict[str, Any] = {"type": "number"}
    if low is not None:
        item["minimum" if inclusive else "exclusiveMinimum"] = low
    array = {"type": "array", "items": item, "minItems": 1}
    return {"anyOf": [item, array]} if scalar else array


PositivePerJoint = Annotated[
    float | list[float], PlainValidator(_per_joint_check(0.0)), WithJsonSchema(_schema(0.0))
]
NonNegativePerJoint = Annotated[
    float | list[float],
    PlainValidator(_per_joint_check(0.0, inclusive=True)),
    WithJsonSchema(_schema(0.0, inclusive=True)),
]
RealPerJoint = Annotated[
    float | list[float], PlainValidator(_per_joint_check(None)), WithJsonSchema(_schema(None))
]
RelativeError = Annotated[
    float | list[float],
    PlainValidator(_per_joint_check(-1.0, what=" (a relative error; -1 would remove the link)")),
    WithJsonSchema(_schema(-1.0)),
]
Vector = Annotated[
    list[float], PlainValidator(_vector_check()), WithJsonSchema(_schema(None, scalar=False))
]
PositiveVector = Annotated[
    list[float], PlainValidator(_vector_check(0.0)), WithJsonSchema(_schema(0.0, scalar=False))
]
NonNegativeVector = Annotated[
    list[float],
    PlainValidator(_vector_check(0.0, inclusive=True)),
    WithJsonSchema(_schema(0.0, inclusive=True, scalar=False)),
]
# The type check comes last: it wraps the constraints, so it runs first, and the JSON schema
# keeps them (``minimum``, ``exclusiveMinimum``).
PositiveFloat = Annotated[float, Field(gt=0, allow_inf_nan=False), _number("a number > 0")]
NonNegativeFloat = Annotated[float, Field(ge=0, allow_inf_nan=False), _number("a number >= 0")]
FiniteFloat = Annotated[float, Field(allow_inf_nan=False), _number("a finite number")]
Probability = Annotated[float, Field(ge=0, le=1), _number("a number in [0, 1]")]
Real = Annotated[float, _number("a number")]
PositiveInt = Annotated[int, Field(ge=1), _integer("an integer >= 1")]
NonNegativeInt = Annotated[int, Field(ge=0), _integer("an integer >= 0")]
OddInt = Annotated[int, _integer("a positive odd integer")]
Switching = Literal["sign", "tanh", "sat"]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)
