"""Every validation error of :class:`PlanarArm` names the parameter and what is allowed."""

from __future__ import annotations

import re

import numpy as np
import pytest

from slidingarm import PlanarArm

M3 = (1.0, 1.0, 1.0)
L3 = (0.5, 1.0, 1.0)


def _m(text: str) -> str:
    """A ``match`` pattern for a literal message fragment."""
    return re.escape(text)


# ---------------------------------------------------------------------- parameters
@pytest.mark.parametrize("masses", [(1.0, 0.0, 1.0), (1.0, -2.0, 1.0), (-1e-300,)])
def test_non_positive_mass(masses: tuple[float, ...]) -> None:
    lengths = (1.0,) * len(masses)
    with pytest.raises(ValueError, match=_m("masses must be > 0 and <= 1e+06 kg, got [")):
        PlanarArm(masses, lengths)


@pytest.mark.parametrize("lengths", [(0.5, 0.0, 1.0), (0.5, 1.0, -1.0)])
def test_non_positive_length(lengths: tuple[float, ...]) -> None:
    with pytest.raises(ValueError, match=_m("lengths must be > 0 and <= 1000 m, got [")):
        PlanarArm(M3, lengths)


def test_negative_inertia() -> None:
    with pytest.raises(ValueError, match=_m("inertia must be >= 0 and <= 1e+09 kg m², got [0.1, -0.01, 0.1]")):
        PlanarArm(M3, L3, inertia=(0.1, -0.01, 0.1))


@pytest.mark.parametrize("com", [(0.5, 1.0, 1.0 + 1e-12), (0.25, -0.1, 0.5), (0.6, 0.5, 0.5)])
def test_com_outside_the_link(com: tuple[float, ...]) -> None:
    with pytest.raises(ValueError, match=_m("com must lie on the link, 0 <= com[i] <= lengths[i]")):
        PlanarArm(M3, L3, com=com)


def test_com_on_the_ends_of_the_link_is_allowed() -> None:
    arm = PlanarArm(M3, L3, com=(0.0, 1.0, 0.5), inertia=(0.1, 0.0, 0.0))
    np.testing.assert_array_equal(arm.com, (0.0, 1.0, 0.5))


@pytest.mark.parametrize(
    ("com", "inertia", "link"),
    [((0.0, 1.0, 1.0), (0.0, 0.0, 0.0), 1), ((0.5, 1.0, 0.0), None, 3)],
)
def test_link_without_inertia_about_its_joint(
    com: tuple[float, ...], inertia: tuple[float, ...] | None, link: int
) -> None:
    """``c_i = 0`` and ``I_i = 0`` leaves a link's joint without inertia: M(q) can be singular."""
    with pytest.raises(ValueError, match=_m(f"link {link} has com = 0 and inertia = 0")):
        PlanarArm(M3, L3, com=com, inertia=inertia)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"lengths": (0.5, 1.0)}, "lengths must have 3 values (one per link), got 2"),
        ({"lengths": (0.5, 1.0, 1.0, 1.0)}, "lengths must have 3 values (one per link), got 4"),
        ({"com": (0.5, 1.0)}, "com must have 3 values (one per link), got 2"),
        ({"inertia": (0.1,) * 4}, "inertia must have 3 values (one per link), got 4"),
    ],
)
def test_wrong_vector_length(kwargs: dict[str, object], message: str) -> None:
    args: dict[str, object] = {"masses": M3, "lengths": L3} | kwargs
    with pytest.raises(ValueError, match=_m(message)):
        PlanarArm(**args)  # type: ignore[arg-type]


def test_no_links() -> None:
    with pytest.raises(ValueError, match=_m("masses must have at least one value")):
        PlanarArm([], [])


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        (
            {"masses": [[1.0, 1.0, 1.0]]},
            "masses must be one-dimensional (one value per link), got shape (1, 3)",
        ),
        (
            {"lengths": np.ones((3, 1))},
            "lengths must be one-dimensional (one value per link), got shape (3, 1)",
        ),
        ({"masses": ("a", "b", "c")}, "masses must be a sequence of numbers, got"),
        ({"com": [0.1, [0.2], 0.3]}, "com must be a sequence of numbers, got"),
    ],
)
def test_malformed_vectors(kwargs: dict[str, object], message: str) -> None:
    args: dict[str, object] = {"masses": M3, "lengths": L3} | kwargs
    with pytest.raises(ValueError, match=_m(message)):
        PlanarArm(**args)  # type: ignore[arg-type]


@pytest.mark.parametrize("name", ["masses", "lengths", "com", "inertia"])
@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_parameters(name: str, bad: float) -> None:
    args: dict[str, object] = {
        "masses": M3,
        "lengths": L3,
        "com": (0.25, 0.5, 0.5),
        "inertia": (0.1, 0.1, 0.1),
    }
    args[name] = (1.0 if name == "masses" else 0.25, bad, 0.5)
    with pytest.raises(ValueError, match=_m(f"{name} must be finite, got [")):
        PlanarArm(**args)  # type: ignore[arg-type]


@pytest.mark.parametrize("model", ["Point", "rods", "", None, "explicit"])
def test_bad_mass_model(model: object) -> None:
    with pytest.raises(ValueError, match=_m(f"mass_model must be 'point' or 'rod', got {model!r}")):
        PlanarArm(M3, L3, mass_model=model)  # type: ignore[arg-type]


@pytest.mark.parametrize("gravity", [-9.81, -1e-300, np.nan, np.inf, -np.inf])
def test_bad_gravity_value(gravity: float) -> None:
    with pytest.raises(ValueError, match=_m("gravity must be >= 0 and <= 1000 m/s², got")):
        PlanarArm(M3, L3, gravity=gravity)


@pytest.mark.parametrize("gravity", ["down", None, (9.81, 0.0), object()])
def test_gravity_not_a_number(gravity: object) -> None:
    with pytest.raises(ValueError, match=_m("gravity must be a number, got")):
        PlanarArm(M3, L3, gravity=gravity)  # type: ignore[arg-type]


def test_zero_gravity_is_allowed() -> None:
    arm = PlanarArm(M3, L3, gravity=0.0)
    np.testing.assert_array_equal(arm.gravity_torque([0.1, 0.2, 0.3]), 0.0)


# ---------------------------------------------------------------------- states
ARM = PlanarArm.paper()


@pytest.mark.parametrize(
    "state", [np.zeros(2), np.zeros(4), np.zeros((5, 2)), np.zeros((2, 3, 3)), np.float64(0.0), []]
)
def test_wrong_state_shape(state: np.ndarray) -> None:
    shape = np.shape(state)
    expected = f"q must have shape (3,) or (B, 3) for this 3-joint arm, got {shape}"
    with pytest.raises(ValueError, match=_m(expected)):
        ARM.mass_matrix(state)


@pytest.mark.parametrize(
    ("method", "names"),
    [
        ("mass_matrix", ["q"]),
        ("gravity_torque", ["q"]),
        ("potential_energy", ["q"]),
        ("joint_positions", ["q"]),
        ("com_positions", ["q"]),
        ("tip_position", ["q"]),
        ("coriolis", ["q", "qd"]),
        ("bias", ["q", "qd"]),
        ("kinetic_energy", ["q", "qd"]),
        ("total_energy", ["q", "qd"]),
        ("forward_dynamics", ["q", "qd", "tau"]),
        ("inverse_dynamics", ["q", "qd", "qdd"]),
    ],
)
def test_every_state_argument_is_checked(method: str, names: list[str]) -> None:
    fn = getattr(ARM, method)
    good = [np.full(3, 0.1) for _ in names]
    for k, name in enumerate(names):
        for bad, error, message in [
            (np.zeros(2), ValueError,
             f"{name} must have shape (3,) or (B, 3) for this 3-joint arm, got (2,)"),
            (np.array([0.0, np.nan, 0.0]), ValueError, f"{name} must be finite (no NaN or inf)"),
            (np.array([[0.0, 0.0, np.inf]]), ValueError, f"{name} must be finite (no NaN or inf)"),
            (["a", "b", "c"], TypeError, f"{name} must be an array of numbers, got"),
            ("0.1", TypeError, f"{name} must be an array of numbers, got str"),
            (b"abc", TypeError, f"{name} must be an array of numbers, got bytes"),
            ({0.1, 0.2, 0.3}, TypeError, f"{name} must be an array of numbers, got set"),
            ([0.1, True, 0.2], TypeError, f"{name} must be an array of numbers, got list"),
        ]:  # fmt: skip
            args = list(good)
            args[k] = bad
            with pytest.raises(error, match=_m(message)):
                fn(*args)


def test_batch_size_mismatch() -> None:
    with pytest.raises(ValueError, match=_m("batch sizes differ: q (4, 3), qd (5, 3)")):
        ARM.bias(np.zeros((4, 3)), np.zeros((5, 3)))
    with pytest.raises(ValueError, match=_m("batch sizes differ: q (2, 3), qd (2, 3), tau (3, 3)")):
        ARM.forward_dynamics(np.zeros((2, 3)), np.zeros((2, 3)), np.zeros((3, 3)))


def test_single_state_broadcasts_against_any_batch() -> None:
    assert ARM.bias(np.zeros((4, 3)), np.zeros(3)).shape == (4, 3)
    assert ARM.inverse_dynamics(np.zeros(3), np.zeros((2, 3)), np.zeros(3)).shape == (2, 3)


# ---------------------------------------------------------------------- derived arms
@pytest.mark.parametrize("mass", [-0.1, np.nan, np.inf])
def test_bad_payload(mass: float) -> None:
    with pytest.raises(ValueError, match=_m("payload mass must be >= 0 and <= 1e+06 kg, got")):
        ARM.with_payload(mass)


@pytest.mark.parametrize(
    "kwargs",
    [{"mass": 0.0}, {"length": -1.0}, {"mass": (1.0, 0.0, 1.0)}, {"length": (1.0, 1.0, -2.0)}],
)
def test_non_positive_scale_factor(kwargs: dict[str, object]) -> None:
    with pytest.raises(ValueError, match=_m("mass and length scale factors must be > 0")):
        ARM.scaled(**kwargs)  # type: ignore[arg-type]


@pytest.mark.parametrize(("key", "label"), [("mass", "mass scale"), ("length", "length scale")])
@pytest.mark.parametrize("size", [2, 4])
def test_scale_factor_of_wrong_length(key: str, label: str, size: int) -> None:
    with pytest.raises(
        ValueError, match=_m(f"{label} must be one value or 3 (one per link), got {size}")
    ):
        ARM.scaled(**{key: np.ones(size)})  # type: ignore[arg-type]


@pytest.mark.parametrize(("key", "label"), [("mass", "mass scale"), ("length", "length scale")])
def test_non_finite_scale_factor(key: str, label: str) -> None:
    with pytest.raises(ValueError, match=_m(f"{label} must be finite")):
        ARM.scaled(**{key: np.nan})  # type: ignore[arg-type]


# ---------------------------------------------------------------------- immutability
def test_attributes_cannot_be_set() -> None:
    for name in ("masses", "n", "gravity", "_masses", "_packed", "new_attribute"):
        with pytest.raises(
            AttributeError, match=_m(f"PlanarArm is immutable; cannot set {name!r}")
        ):
            setattr(ARM, name, 1.0)


@pytest.mark.parametrize("name", ["masses", "lengths", "com", "inertia"])
def test_parameter_arrays_are_read_only(name: str) -> None:
    arr = getattr(ARM, name)
    with pytest.raises(ValueError, match="read-only"):
        arr[0] = 5.0
    assert not arr.flags.writeable


def test_inputs_are_copied_and_packed_is_a_copy() -> None:
    masses = np.array([1.0, 2.0])
    arm = PlanarArm(masses, [1.0, 1.0])
    masses[0] = 99.0
    assert arm.masses[0] == 1.0
    packed = arm.packed
    packed[:] = 0.0
    assert arm.packed[0, 0] == 1.0
    before = arm.mass_matrix([0.1, 0.2])
    np.testing.assert_array_equal(arm.mass_matrix([0.1, 0.2]), before)


def test_equal_arms_hash_equal() -> None:
    assert PlanarArm.paper() == PlanarArm(M3, L3)
    assert hash(PlanarArm.paper()) == hash(PlanarArm(M3, L3))
    assert PlanarArm.paper() != PlanarArm.paper("rod")
    assert PlanarArm.paper() != PlanarArm(M3, L3, gravity=9.8)
    assert PlanarArm.paper() != "not an arm"


def test_arm_numbers_are_numbers() -> None:
    """Booleans and strings are type errors; integers beyond the float range are values out
    of range, never an OverflowError."""
    with pytest.raises(TypeError, match=r"^gravity must be a number, got True$"):
        PlanarArm([1.0], [1.0], gravity=True)
    with pytest.raises(TypeError, match=r"^masses must be a sequence of numbers, got '1 2 3'$"):
        ARM.replace(masses="1 2 3")
    with pytest.raises(TypeError, match=r"^payload mass must be a number \(kg\), got '1'$"):
        ARM.with_payload("1")  # type: ignore[arg-type]
    for call, match in [
        (lambda: PlanarArm([1.0], [1.0], gravity=10**400), r"^gravity must be >= 0"),
        (lambda: ARM.with_payload(10**400), r"^payload mass must be >= 0"),
        (lambda: PlanarArm([10**400], [1.0]), r"^masses must be finite, got \[inf\]$"),
        (lambda: ARM.mass_matrix([10**400, 0, 0]), r"^q must be finite \(no NaN or inf\)$"),
    ]:
        with pytest.raises(ValueError, match=match) as info:
            call()
        assert not isinstance(info.value, TypeError)


# ---------------------------------------------------------------------- the fast path
def _general(values: object) -> object:
    """The same numbers as numpy float64 scalars in a list: not Python floats, so the
    constructor takes its general (numpy) path rather than the plain-Python fast one."""
    return None if values is None else [np.float64(v) for v in values]  # type: ignore[attr-defined]


@pytest.mark.parametrize("seed", range(20))
def test_fast_and_general_paths_build_the_same_arm(seed: int) -> None:
    """The plain-Python fast path (lists, tuples, float64 arrays) gives bit for bit the arm
    of the numpy path, and so do ``scaled`` and ``with_payload`` on either."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 8))
    m, ln = rng.uniform(0.1, 5.0, n), rng.uniform(0.1, 2.0, n)
    com = rng.uniform(0.0, 1.0, n) * ln if seed % 2 else None
    inertia = rng.uniform(0.0, 0.5, n) if seed % 3 else None
    model = "rod" if seed % 4 == 0 else "point"
    if model == "point" and com is not None and inertia is None:
        com = np.maximum(com, 1e-3)  # a point link needs com > 0
    kwargs = {"mass_model": model, "gravity": float(rng.uniform(0, 20))}
    fast = PlanarArm(
        m.tolist(), tuple(ln), com=com, inertia=None if inertia is None else list(inertia),
        **kwargs,  # type: ignore[arg-type]
    )  # fmt: skip
    slow = PlanarArm(_general(m), _general(ln), com=_general(com), inertia=_general(inertia), **kwargs)  # type: ignore[arg-type]
    assert np.array_equal(fast.packed, slow.packed) and fast.gravity == slow.gravity
    fm, fl = rng.uniform(0.5, 1.5, n), float(rng.uniform(0.5, 1.5))
    a, b = fast.scaled(mass=fm, length=fl), slow.scaled(mass=_general(fm), length=np.float64(fl))
    assert np.array_equal(a.packed, b.packed)
    assert np.array_equal(a.with_payload(0.7).packed, b.with_payload(np.float64(0.7)).packed)


@pytest.mark.parametrize(
    ("masses", "lengths", "kwargs", "message"),
    [
        ([1.0, float("nan")], [1.0, 1.0], {}, "masses must be finite"),
        ([1.0, 2e6], [1.0, 1.0], {}, "masses must be > 0 and <= 1e+06 kg"),
        ([1.0, 1.0], [1.0, 0.0], {}, "lengths must be > 0"),
        ([1.0, 1.0], [1.0], {}, "lengths must have 2 values"),
        ([1.0, 1.0], [1.0, 1.0], {"com": [0.0, 1.0]}, "link 1 has com = 0 and inertia = 0"),
        ([1.0, 1.0], [1.0, 1.0], {"gravity": 1e4}, "gravity must be >= 0 and <= 1000"),
        ([1.0, True], [1.0, 1.0], {}, "masses must be a sequence of numbers"),
    ],
)
def test_plain_inputs_still_get_the_general_paths_errors(
    masses: list[object], lengths: list[float], kwargs: dict[str, object], message: str
) -> None:
    with pytest.raises((ValueError, TypeError), match=_m(message)):
        PlanarArm(masses, lengths, **kwargs)  # type: ignore[arg-type]


def test_scaled_past_the_bounds_is_refused_on_the_fast_path() -> None:
    arm = PlanarArm([5e5, 1.0], [1.0, 1.0])
    with pytest.raises(ValueError, match=_m("masses must be > 0 and <= 1e+06 kg")):
        arm.scaled(mass=[3.0, 1.0])
    with pytest.raises(ValueError, match=_m("scale factors must be > 0 and <= 1000")):
        arm.scaled(mass=[2e3, 1.0])
