"""Value types of scenario files: numbers with their bounds, per-joint values, vectors, and
their JSON schema; one error per bad value, with the allowed range in words.

The checks themselves are :mod:`slidingarm._validate`'s, the same the library's classes use.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict
from pydantic.functional_validators import PlainValidator
from pydantic.json_schema import WithJsonSchema

from slidingarm._validate import MAX_POSITION, MIN_EPS_E, integer, per_joint, plain, real
from slidingarm.simulate import MAX_SUBSTEPS, MIN_DT

_NAME_PATTERN = r"^[A-Za-z0-9][A-Za-z0-9_.-]*$"


def _bound(low: float | None, inclusive: bool) -> str:
    return "" if low is None else (f" >= {low:g}" if inclusive else f" > {low:g}")


def _as_value_error(check: Callable[[Any], Any]) -> Callable[[Any], Any]:
    """``check`` raising :class:`ValueError` only: pydantic turns a ValueError into a validation
    error (with the key path) but lets a TypeError escape."""

    def wrapped(v: Any) -> Any:
        try:
            return check(v)
        except (TypeError, ValueError) as exc:
            raise ValueError(str(exc)) from None

    return wrapped


def _per_joint_check(
    low: float | None, *, inclusive: bool = False, what: str = "", high: float | None = None
) -> Callable[[Any], float | list[float]]:
    """Validator of a finite number or a non-empty list of them (one per joint):
    :func:`slidingarm._validate.per_joint` in the scenario files' wording; ``high`` an upper
    bound (inclusive)."""
    bound = _bound(low, inclusive) + ("" if high is None else f" and <= {high:g}")

    def check(v: Any) -> float | list[float]:
        invalid = f"must be a number{bound} or a list of them (one per joint){what}, got {v!r}"
        out_of_range = f"must be{bound}{what} (a scalar or one per joint), got {v!r}"
        value = per_joint(
            "",
            v,
            low=low,
            inclusive=inclusive,
            invalid=invalid,
            not_finite=f"must be finite, got {v!r}",
            out_of_range=out_of_range,
        )
        if high is not None and max(value if isinstance(value, tuple) else (value,)) > high:
            raise ValueError(out_of_range)
        return plain(value)

    return _as_value_error(check)


def _vector_check(
    low: float | None = None, *, inclusive: bool = False, magnitude: float | None = None
) -> Callable[[Any], list[float]]:
    """Validator of a non-empty list of finite numbers (one per joint):
    :func:`slidingarm._validate.per_joint`, a list required; ``magnitude`` bounds ``|x|``."""
    bound = _bound(low, inclusive) + ("" if magnitude is None else f" within ±{magnitude:g}")

    def check(v: Any) -> list[float]:
        invalid = f"must be a list of numbers{bound} (one per joint), got {v!r}"
        if not isinstance(v, list | tuple):
            raise ValueError(invalid)
        bad_value = f"must be a list of finite numbers{bound}, got {v!r}"
        value = per_joint(
            "",
            v,
            low=low,
            inclusive=inclusive,
            invalid=invalid,
            not_finite=bad_value,
            out_of_range=bad_value,
        )
        assert isinstance(value, tuple)
        if magnitude is not None and max(abs(x) for x in value) > magnitude:
            raise ValueError(bad_value)
        return list(value)

    return _as_value_error(check)


def _number(
    allowed: str,
    *,
    low: float | None = None,
    high: float | None = None,
    low_inclusive: bool = True,
    finite: bool = True,
) -> PlainValidator:
    """A real number (:func:`slidingarm._validate.real`): not a boolean and not a string, which
    pydantic's lax mode would read as 1 and 4.5; ``allowed`` says what is allowed
    (``"a number > 0"``)."""
    return PlainValidator(
        _as_value_error(
            lambda v: real(
                "",
                v,
                low=low,
                high=high,
                low_inclusive=low_inclusive,
                finite=finite,
                allowed=allowed,
            )
        )
    )


def _integer(
    allowed: str, *, low: int | None = None, high: int | None = None, odd: bool = False
) -> PlainValidator:
    """An integer (:func:`slidingarm._validate.integer`): neither a boolean nor a float,
    however integral."""
    return PlainValidator(
        _as_value_error(lambda v: integer("", v, low=low, high=high, odd=odd, allowed=allowed))
    )


def _schema(
    low: float | None,
    *,
    inclusive: bool = False,
    scalar: bool = True,
    high: float | None = None,
) -> dict[str, Any]:
    """JSON schema of a per-joint value (``scalar``: a number or a list) or a vector."""
    item: dict[str, Any] = {"type": "number"}
    if low is not None:
        item["minimum" if inclusive else "exclusiveMinimum"] = low
    if high is not None:
        item["maximum"] = high
    array = {"type": "array", "items": item, "minItems": 1}
    return {"anyOf": [item, array]} if scalar else array


def _number_schema(**bounds: float) -> WithJsonSchema:
    return WithJsonSchema({"type": "number", **bounds})


def _integer_schema(**bounds: int) -> WithJsonSchema:
    return WithJsonSchema({"type": "integer", **bounds})


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
#: A joint position vector (rad, or m): finite, within ±MAX_POSITION (1e3; see
#: :data:`slidingarm._validate.MAX_POSITION`).
Position = Annotated[
    list[float],
    PlainValidator(_vector_check(magnitude=MAX_POSITION)),
    WithJsonSchema(_schema(-MAX_POSITION, inclusive=True, scalar=False, high=MAX_POSITION)),
]
#: A spread of joint positions (a noise standard deviation, rad or m): in [0, MAX_POSITION].
PositionSpread = Annotated[
    float | list[float],
    PlainValidator(_per_joint_check(0.0, inclusive=True, high=MAX_POSITION)),
    WithJsonSchema(_schema(0.0, inclusive=True, high=MAX_POSITION)),
]
#: A position offset (rad, or m): within ±MAX_POSITION.
PositionOffset = Annotated[
    float,
    _number(f"a number within ±{MAX_POSITION:g}", low=-MAX_POSITION, high=MAX_POSITION),
    _number_schema(minimum=-MAX_POSITION, maximum=MAX_POSITION),
]
PositiveFloat = Annotated[
    float, _number("a number > 0", low=0.0, low_inclusive=False), _number_schema(exclusiveMinimum=0)
]
NonNegativeFloat = Annotated[float, _number("a number >= 0", low=0.0), _number_schema(minimum=0)]
FiniteFloat = Annotated[float, _number("a finite number"), _number_schema()]
Probability = Annotated[
    float, _number("a number in [0, 1]", low=0.0, high=1.0), _number_schema(minimum=0, maximum=1)
]
Real = Annotated[float, _number("a number", finite=False), _number_schema()]
#: A sample time (s): at least MIN_DT = 1e-9 s (:data:`slidingarm.simulate.MIN_DT`).
SampleTime = Annotated[
    float, _number(f"a number >= {MIN_DT:g} (s)", low=MIN_DT), _number_schema(minimum=MIN_DT)
]
#: The singularity guard of a terminal surface (rad): at least MIN_EPS_E = 1e-300
#: (:data:`slidingarm._validate.MIN_EPS_E`).
Guard = Annotated[
    float,
    _number(f"a number >= {MIN_EPS_E:g} (rad)", low=MIN_EPS_E),
    _number_schema(minimum=MIN_EPS_E),
]
#: RK4 steps per sample: 1 to MAX_SUBSTEPS (:data:`slidingarm.simulate.MAX_SUBSTEPS`).
Substeps = Annotated[
    int,
    _integer(f"an integer from 1 to {MAX_SUBSTEPS}", low=1, high=MAX_SUBSTEPS),
    _integer_schema(minimum=1, maximum=MAX_SUBSTEPS),
]
PositiveInt = Annotated[int, _integer("an integer >= 1", low=1), _integer_schema(minimum=1)]
NonNegativeInt = Annotated[int, _integer("an integer >= 0", low=0), _integer_schema(minimum=0)]
OddInt = Annotated[
    int, _integer("a positive odd integer", low=1, odd=True), _integer_schema(minimum=1)
]
Switching = Literal["sign", "tanh", "sat"]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)
