"""The Python API rejects strings, bytes, booleans, sets and None where numbers or sequences
go, with a TypeError naming the parameter; a number of the wrong value (an integer too large
for a float, NaN) is a ValueError. Never an OverflowError or an AttributeError."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

from slidingarm import PlanarArm
from slidingarm._validate import ParameterTypeError, integer, per_joint, real
from slidingarm.control.surfaces import (
    FastTerminal,
    LinearSurface,
    NonsingularTerminal,
    TerminalSurface,
    exponent,
    gain,
)
from slidingarm.disturbances import ConstantTorque, ModelMismatch, RandomTorque, SinusoidalTorque
from slidingarm.references import (
    CallableReference,
    PaperReference,
    QuinticReference,
    SineReference,
    TableReference,
    reference_from_dict,
)
from slidingarm.sensors import (
    DirtyDerivative,
    GaussianNoise,
    LevantDifferentiator,
    Sensor,
    SensorFault,
)

HUGE = 10**400
NOT_NUMBERS: list[Any] = ["1.5", b"1", True, np.True_, {1.0}, None]
NOT_SEQUENCES: list[Any] = ["abc", b"abc", {1.0, 2.0}, [1.0, True, 2.0], None, (1.0, "2")]


def _zero(t: np.ndarray) -> np.ndarray:
    return np.zeros_like(t)


#: (constructor of one parameter, name the message carries)
SCALARS: list[tuple[str, Callable[[Any], Any]]] = [
    ("time_constant", lambda v: DirtyDerivative(v)),
    ("lipschitz", lambda v: LevantDifferentiator(lipschitz=v)),
    ("lambda1", lambda v: LevantDifferentiator(lambda1=v)),
    ("lambda0", lambda v: LevantDifferentiator(lambda0=v)),
    ("fault t_start", lambda v: SensorFault("bias", 1, t_start=v)),
    ("fault value", lambda v: SensorFault("bias", 1, value=v)),
    ("fault probability", lambda v: SensorFault("dropout", 1, probability=v)),
    ("constant disturbance t_start", lambda v: ConstantTorque(1.0, t_start=v)),
    ("sinusoidal disturbance frequency", lambda v: SinusoidalTorque(1.0, frequency=v)),
    ("sinusoidal disturbance phase", lambda v: SinusoidalTorque(1.0, phase=v)),
    ("payload", lambda v: ModelMismatch(payload=v)),
    ("duration", lambda v: QuinticReference([0.0], [1.0], duration=v)),
    ("t_start", lambda v: QuinticReference([0.0], [1.0], duration=1.0, t_start=v)),
    ("gamma", lambda v: TerminalSurface(1.0, v)),
    ("eps_e", lambda v: TerminalSurface(1.0, 0.5, eps_e=v)),
]

#: constructors of a per-joint value or a vector
VECTORS: list[tuple[str, Callable[[Any], Any]]] = [
    ("noise sigma", lambda v: GaussianNoise(v)),
    ("constant disturbance value", lambda v: ConstantTorque(v)),
    ("sinusoidal disturbance amplitude", lambda v: SinusoidalTorque(v)),
    ("random disturbance sigma", lambda v: RandomTorque(v)),
    ("mass_error", lambda v: ModelMismatch(mass_error=v)),
    ("length_error", lambda v: ModelMismatch(length_error=v)),
    ("q_start", lambda v: QuinticReference(v, [1.0], duration=1.0)),
    ("q_end", lambda v: QuinticReference([0.0], v, duration=1.0)),
    ("offset", lambda v: SineReference(v, 1.0, 1.0)),
    ("amplitude", lambda v: SineReference([0.0], v, 1.0)),
    ("frequency", lambda v: SineReference([0.0], 1.0, v)),
    ("phase", lambda v: SineReference([0.0], 1.0, 1.0, v)),
    ("t", lambda v: TableReference(v, np.zeros(6))),
    ("q", lambda v: TableReference(np.arange(6.0), v)),
    ("lam", lambda v: LinearSurface(v)),
    ("alpha", lambda v: FastTerminal(v, 1.0, 0.5)),
    ("beta", lambda v: FastTerminal(1.0, v, 0.5)),
    ("beta", lambda v: NonsingularTerminal(v, 1.5)),
    ("k", lambda v: gain("k", v)),
]


@pytest.mark.parametrize("value", NOT_NUMBERS, ids=repr)
@pytest.mark.parametrize(("name", "build"), SCALARS, ids=[n for n, _ in SCALARS])
def test_scalar_parameters_reject_non_numbers_with_a_type_error(
    name: str, build: Callable[[Any], Any], value: Any
) -> None:
    if value is None and name == "gamma":
        pytest.skip("gamma=None means 'give p and q'")
    with pytest.raises(TypeError, match=name.split()[-1]):
        build(value)


@pytest.mark.parametrize(("name", "build"), SCALARS, ids=[n for n, _ in SCALARS])
def test_scalar_parameters_reject_huge_integers_with_a_value_error(
    name: str, build: Callable[[Any], Any]
) -> None:
    with pytest.raises(ValueError, match=name.split()[-1]) as info:
        build(HUGE)
    assert not isinstance(info.value, TypeError)


@pytest.mark.parametrize("value", NOT_SEQUENCES, ids=repr)
@pytest.mark.parametrize(
    ("name", "build"), VECTORS, ids=[f"{n}-{i}" for i, (n, _) in enumerate(VECTORS)]
)
def test_vector_parameters_reject_non_numbers_with_a_type_error(
    name: str, build: Callable[[Any], Any], value: Any
) -> None:
    with pytest.raises(TypeError, match=name):
        build(value)


@pytest.mark.parametrize(
    ("name", "build"), VECTORS, ids=[f"{n}-{i}" for i, (n, _) in enumerate(VECTORS)]
)
def test_vector_parameters_reject_huge_integers_with_a_value_error(
    name: str, build: Callable[[Any], Any]
) -> None:
    value: Any = [0, 1, 2, 3, 4, HUGE] if name == "t" else [HUGE]
    if name == "q":
        value = [[HUGE]] * 6
    with pytest.raises(ValueError, match=name) as info:
        build(value)
    assert not isinstance(info.value, TypeError | OverflowError)


@pytest.mark.parametrize("value", [*NOT_NUMBERS[:-1], 2.0, HUGE], ids=repr)
def test_integer_parameters(value: Any) -> None:
    """Joint numbers, joint counts and exponents: integers, not booleans or floats (None, for
    the exponents, means "not given")."""
    error = ValueError if value is HUGE else TypeError
    builds: list[Callable[[], Any]] = [
        lambda: SensorFault("stuck", value),
        lambda: exponent(None, value, 3),
        lambda: exponent(None, 5, value),
        lambda: CallableReference(_zero, _zero, _zero, n=value),
    ]
    for build in builds:
        if value is HUGE and build is builds[0]:
            build()  # a joint that does not exist is found when the sensor meets the arm
            continue
        if value is HUGE and build is builds[3]:
            continue  # n is an integer >= 1: allowed, if absurd
        with pytest.raises(error):
            build()


def test_wrong_objects_are_type_errors() -> None:
    with pytest.raises(TypeError, match="velocity must be a velocity estimator"):
        Sensor(velocity="true")  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="noise must be a GaussianNoise"):
        Sensor(noise=0.1)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="faults must be a list or tuple of SensorFault"):
        Sensor(faults="bias")  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="faults must be a list or tuple of SensorFault"):
        Sensor(faults={SensorFault("stuck", 1)})  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="fault kind"):
        SensorFault(["bias"], 1)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="spline must be"):
        TableReference(np.arange(6.0), np.zeros(6), spline=["cubic"])  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="must be callable"):
        CallableReference(_zero, "qd", _zero, n=1)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="reference kind must be a string"):
        reference_from_dict({"kind": ["paper"]})
    with pytest.raises(TypeError, match="t must be"):
        PaperReference().evaluate("0.5")  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="t must be a real number"):
        PaperReference()("0.5")  # type: ignore[arg-type]


def test_the_validators_themselves() -> None:
    with pytest.raises(ParameterTypeError, match=r"^x must be a number > 0, got b'1'$"):
        real("x", b"1", low=0.0, low_inclusive=False)
    with pytest.raises(ValueError, match=r"^x must be a number in \[0, 1\], got 2$"):
        real("x", 2, low=0.0, high=1.0)
    with pytest.raises(ValueError, match=r"^x must be a finite number, got 1000"):
        real("x", HUGE)
    assert real("x", float("nan"), finite=False) != real("x", 0.0)  # NaN, unbounded
    with pytest.raises(ParameterTypeError, match=r"^must be an integer >= 1, got 2\.0$"):
        integer("", 2.0, low=1)
    with pytest.raises(ValueError, match=r"^p must be an odd integer, got 4$"):
        integer("p", 4, odd=True)
    with pytest.raises(ValueError, match=r"^g must be finite, got \[inf\]$"):
        per_joint("g", [HUGE])
    with pytest.raises(ParameterTypeError, match="g must be a number or one number per joint"):
        per_joint("g", {1.0})
    # a TypeError that code catching ValueError still catches
    assert issubclass(ParameterTypeError, TypeError) and issubclass(ParameterTypeError, ValueError)
    assert PlanarArm.paper().n == 3
