"""Tests for slidingarm.references: values, analytic derivatives, validation, round trips.

Finite differences appear only here, to check the analytic derivatives. The stencils are the
fourth-order central ones,

    f'(t)  ≈ (-f(t+2h) + 8 f(t+h) - 8 f(t-h) + f(t-2h)) / (12 h),        error h^4 |f^(5)| / 30
    f''(t) ≈ (-f(t+2h) + 16 f(t+h) - 30 f(t) + 16 f(t-h) - f(t-2h)) / (12 h^2),  error h^4 |f^(6)| / 90

plus a rounding error of about eps |f| * 18 / (12 h) and eps |f| * 64 / (12 h^2). Each test
states the resulting bound next to its tolerance.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from slidingarm.references import (
    PAPER_DT,
    PAPER_Q0,
    PAPER_QD0,
    PAPER_T_FINAL,
    REFERENCE_KINDS,
    CallableReference,
    PaperReference,
    QuinticReference,
    Reference,
    SineReference,
    TableReference,
    reference_from_dict,
)

EPS = np.finfo(np.float64).eps
Arr = np.ndarray


def fd1(f: Callable[[Arr], Arr], t: Arr, h: float) -> Arr:
    return (-f(t + 2 * h) + 8 * f(t + h) - 8 * f(t - h) + f(t - 2 * h)) / (12 * h)


def fd2(f: Callable[[Arr], Arr], t: Arr, h: float) -> Arr:
    return (-f(t + 2 * h) + 16 * f(t + h) - 30 * f(t) + 16 * f(t - h) - f(t - 2 * h)) / (12 * h * h)


def pos(ref: Reference) -> Callable[[Arr], Arr]:
    return lambda t: ref.evaluate(t)[0]


def vel(ref: Reference) -> Callable[[Arr], Arr]:
    return lambda t: ref.evaluate(t)[1]


def sample_table(n_samples: int = 40, spline: str = "quintic") -> TableReference:
    t = np.linspace(0.0, 4.0, n_samples)
    q = np.stack([np.sin(t), 0.3 * np.cos(2 * t), 0.1 * t**2], axis=1)
    return TableReference(t, q, spline=spline)  # type: ignore[arg-type]


def sample_callable() -> CallableReference:
    return CallableReference(
        lambda t: np.stack([np.sin(t), t**2], axis=1),
        lambda t: np.stack([np.cos(t), 2 * t], axis=1),
        lambda t: np.stack([-np.sin(t), 2 + 0 * t], axis=1),
        n=2,
    )


def all_references() -> list[Reference]:
    return [
        PaperReference(),
        QuinticReference([0.0, 1.0, -2.0], [1.0, 1.0, 3.0], duration=2.0, t_start=0.5),
        SineReference([0.1, -0.2], [0.5, 0.25], [0.5, 2.0], [0.0, 1.0]),
        sample_table(),
        sample_table(spline="cubic"),
        sample_callable(),
    ]


REFS = all_references()
IDS = [type(r).__name__ + (f"-{r.spline}" if isinstance(r, TableReference) else "") for r in REFS]


# --------------------------------------------------------------------------------------------
# the common interface


@pytest.mark.parametrize("ref", REFS, ids=IDS)
def test_evaluate_shapes_dtype_contiguity(ref: Reference) -> None:
    t = np.linspace(0.0, 4.0, 101)
    out = ref.evaluate(t)
    assert len(out) == 3
    for a in out:
        assert a.shape == (101, ref.n)
        assert a.dtype == np.float64
        assert a.flags.c_contiguous
        assert np.all(np.isfinite(a))


@pytest.mark.parametrize("ref", REFS, ids=IDS)
def test_evaluate_accepts_lists_and_unsorted_times(ref: Reference) -> None:
    t = [3.0, 0.5, 2.0]
    q, qd, qdd = ref.evaluate(t)
    q_sorted, qd_sorted, qdd_sorted = ref.evaluate(np.array([0.5, 2.0, 3.0]))
    np.testing.assert_array_equal(q[[1, 2, 0]], q_sorted)
    np.testing.assert_array_equal(qd[[1, 2, 0]], qd_sorted)
    np.testing.assert_array_equal(qdd[[1, 2, 0]], qdd_sorted)


@pytest.mark.parametrize("ref", REFS, ids=IDS)
def test_call_equals_a_row_of_evaluate(ref: Reference) -> None:
    t = np.linspace(0.0, 4.0, 17)
    q, qd, qdd = ref.evaluate(t)
    for k in (0, 5, 16):
        q1, qd1, qdd1 = ref(float(t[k]))
        assert q1.shape == qd1.shape == qdd1.shape == (ref.n,)
        np.testing.assert_array_equal(q1, q[k])
        np.testing.assert_array_equal(qd1, qd[k])
        np.testing.assert_array_equal(qdd1, qdd[k])
    # numpy scalars and ints are times too
    np.testing.assert_array_equal(ref(np.float64(t[5]))[0], q[5])
    np.testing.assert_array_equal(ref(1)[0], ref.evaluate([1.0])[0][0])


@pytest.mark.parametrize("ref", REFS[:5], ids=IDS[:5])
def test_evaluate_empty_grid(ref: Reference) -> None:
    for a in ref.evaluate(np.empty(0)):
        assert a.shape == (0, ref.n)


@pytest.mark.parametrize("ref", REFS, ids=IDS)
def test_evaluate_returns_fresh_arrays(ref: Reference) -> None:
    t = np.array([1.0, 2.0])
    q, _, _ = ref.evaluate(t)
    q[:] = 123.0
    assert not np.any(ref.evaluate(t)[0] == 123.0)


@pytest.mark.parametrize(
    ("t", "match"),
    [
        (np.zeros((3, 2)), r"t must be one-dimensional, shape \(T,\), got shape \(3, 2\)"),
        (1.0, r"got shape \(\); to evaluate one time call the reference, ref\(t\)"),
        (np.array([0.0, np.nan]), r"t must be finite, got t\[1\] = nan"),
        ([0.0, 1.0, np.inf], r"t must be finite, got t\[2\] = inf"),
        (np.array([1j, 2]), "t must be real sample times"),
        (["a", "b"], "t must be an array of sample times"),
    ],
)
def test_evaluate_rejects_bad_times(t: object, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        PaperReference().evaluate(t)  # type: ignore[arg-type]


def test_call_rejects_arrays_and_non_numbers() -> None:
    ref = PaperReference()
    with pytest.raises(ValueError, match=r"ref\(t\) takes one time, got shape \(2,\)"):
        ref(np.array([0.0, 1.0]))  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="t must be a real number"):
        ref("soon")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="t must be finite"):
        ref(math.nan)


def test_reference_is_abstract() -> None:
    with pytest.raises(TypeError):
        Reference()  # type: ignore[abstract]


# --------------------------------------------------------------------------------------------
# the paper's reference and constants


def test_paper_constants() -> None:
    assert PAPER_Q0 == (0.7, 1.5, 0.5)
    assert PAPER_QD0 == (0.0, 0.0, 0.0)
    assert PAPER_T_FINAL == 4.5
    assert PAPER_DT == 5e-4
    assert round(PAPER_T_FINAL / PAPER_DT) == 9000


def test_paper_reference_at_zero() -> None:
    q, qd, qdd = PaperReference()(0.0)
    # 0.35 - 0.5 sin 0 and 0.25 + 0.5 cos 0 are exact; 0.45 - 0.5 is computed exactly
    # (Sterbenz), which is the double nearest to 0.45 minus 0.5, one ulp from the literal -0.05.
    assert q.tolist() == [0.35, 0.75, 0.45 - 0.5]
    assert abs(q[2] - (-0.05)) <= 2 * EPS * 0.05
    assert qd.tolist() == [-0.5, 0.0, 0.0]
    assert qdd.tolist() == [0.0, -0.5, 0.5]
    assert PaperReference().n == 3


def test_paper_reference_formula() -> None:
    t = np.linspace(0.0, PAPER_T_FINAL, 9001)
    q, qd, qdd = PaperReference().evaluate(t)
    s, c = np.sin(t), np.cos(t)
    np.testing.assert_array_equal(q, np.c_[0.35 - 0.5 * s, 0.25 + 0.5 * c, 0.45 - 0.5 * c])
    np.testing.assert_array_equal(qd, np.c_[-0.5 * c, -0.5 * s, 0.5 * s])
    np.testing.assert_array_equal(qdd, np.c_[0.5 * s, -0.5 * c, 0.5 * c])
    # the paper's arm starts off the reference
    assert not np.allclose(q[0], PAPER_Q0)


def test_paper_reference_matches_sine_reference() -> None:
    # 0.35 - 0.5 sin t = 0.35 + 0.5 sin(t + π), 0.25 + 0.5 cos t = 0.25 + 0.5 sin(t + π/2), ...
    sine = SineReference([0.35, 0.25, 0.45], 0.5, 1 / (2 * np.pi), [np.pi, np.pi / 2, -np.pi / 2])
    t = np.linspace(0.0, PAPER_T_FINAL, 501)
    for a, b in zip(PaperReference().evaluate(t), sine.evaluate(t), strict=True):
        # different but equivalent formulas: agreement to a few ulps of the O(1) values
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-14)


def test_paper_derivatives_against_finite_differences() -> None:
    ref = PaperReference()
    t = np.linspace(0.0, PAPER_T_FINAL, 200)
    _, qd, qdd = ref.evaluate(t)
    # h = 1e-3: truncation h^4 * 0.5 / 30 ≈ 2e-14, rounding ≈ eps * 1 * 1.5 / h ≈ 3e-13
    np.testing.assert_allclose(qd, fd1(pos(ref), t, 1e-3), rtol=0, atol=2e-12)
    np.testing.assert_allclose(qdd, fd1(vel(ref), t, 1e-3), rtol=0, atol=2e-12)
    # h = 1e-2: truncation h^4 * 0.5 / 90 ≈ 6e-11, rounding ≈ eps * 1 * 5.3 / h^2 ≈ 1.2e-11
    np.testing.assert_allclose(qdd, fd2(pos(ref), t, 1e-2), rtol=0, atol=2e-10)


# --------------------------------------------------------------------------------------------
# quintic point-to-point


def test_quintic_boundary_conditions_exact() -> None:
    q0 = np.array([0.1, -0.7, 2.3])
    q1 = np.array([1.3, 0.2, -2.9])
    ref = QuinticReference(q0, q1, duration=1.7, t_start=0.3)
    assert ref.t_end == 0.3 + 1.7
    t = np.array([-1.0, 0.0, 0.3, ref.t_end, 5.0])
    q, qd, qdd = ref.evaluate(t)
    for k in (0, 1, 2):  # before and at the start: hold q_start
        np.testing.assert_array_equal(q[k], q0)
    for k in (3, 4):  # at and after the end: hold q_end
        np.testing.assert_array_equal(q[k], q1)
    np.testing.assert_array_equal(qd, 0.0)
    np.testing.assert_array_equal(qdd, 0.0)


def test_quintic_midpoint_and_peak_velocity() -> None:
    ref = QuinticReference([0.0], [2.0], duration=4.0)
    q, qd, qdd = ref(2.0)
    # p(1/2) = 1/2, p'(1/2) = 30/16, p''(1/2) = 0
    assert q[0] == 1.0
    assert qd[0] == pytest.approx(2.0 * 30 / 16 / 4.0, rel=1e-15)
    assert qdd[0] == 0.0


@settings(max_examples=60, deadline=None)
@given(
    q0=st.lists(st.floats(-3, 3), min_size=1, max_size=4),
    dq=st.lists(st.floats(-3, 3), min_size=4, max_size=4),
    duration=st.floats(0.1, 10.0),
    t_start=st.floats(-5.0, 5.0),
)
def test_quintic_properties(
    q0: list[float], dq: list[float], duration: float, t_start: float
) -> None:
    n = len(q0)
    q_start = np.array(q0)
    q_end = q_start + np.array(dq[:n])
    ref = QuinticReference(q_start, q_end, duration=duration, t_start=t_start)
    end = t_start + duration

    # exact boundary conditions (the profile's factored forms vanish exactly), at the ends as
    # computed in floating point ((end - t_start) / D may round below 1)
    assert ref.t_end == end
    q, qd, qdd = ref.evaluate(np.array([t_start, end]))
    np.testing.assert_array_equal(q[0], q_start)
    np.testing.assert_array_equal(q[1], q_end)
    np.testing.assert_array_equal(qd, 0.0)
    np.testing.assert_array_equal(qdd, 0.0)

    # monotone in each joint, never overshooting; velocity has the sign of the move
    t = np.linspace(t_start - 0.5, end + 0.5, 400)
    q, qd, _ = ref.evaluate(t)
    delta = q_end - q_start
    step = np.diff(q, axis=0) * np.sign(delta)
    # q = (1-p) q0 + p q1 rounds to a few ulps of max(|q0|, |q1|) <= 6
    assert np.all(step >= -4 * EPS * 6)
    lo, hi = np.minimum(q_start, q_end), np.maximum(q_start, q_end)
    assert np.all(q >= lo - 4 * EPS * 6) and np.all(q <= hi + 4 * EPS * 6)
    assert np.all(qd * np.sign(delta) >= 0.0)

    # analytic derivatives against finite differences, inside the move (q is a quintic there)
    # and outside (constant). Scale h with D. Inside: fd1's truncation is
    # h^4/30 * 720 |Δ| / D^5 = 2.4e-11 |Δ|/D for h = 1e-3 D; fd2 is exact on quintics.
    # Rounding: eps * 6 * 1.5 / h ≈ 2e-12 / D and eps * 6 * 5.3 / h^2 ≈ 7e-11 / D^2.
    scale = float(np.max(np.abs(delta))) + 6.0
    t_in = t_start + duration * np.linspace(0.05, 0.95, 19)
    t_out = np.array([t_start - 0.1 * duration, end + 0.1 * duration])
    tt = np.r_[t_in, t_out]
    q, qd, qdd = ref.evaluate(tt)
    h1, h2 = 1e-3 * duration, 1e-2 * duration
    np.testing.assert_allclose(qd, fd1(pos(ref), tt, h1), rtol=0, atol=1e-9 * scale / duration)
    np.testing.assert_allclose(qdd, fd1(vel(ref), tt, h1), rtol=0, atol=1e-9 * scale / duration**2)
    np.testing.assert_allclose(qdd, fd2(pos(ref), tt, h2), rtol=0, atol=1e-8 * scale / duration**2)
    np.testing.assert_array_equal(qd[-2:], 0.0)
    np.testing.assert_array_equal(qdd[-2:], 0.0)


def _quintic_scalar(ref: QuinticReference, tk: float) -> tuple[list[float], ...]:
    """The class docstring's formula at one time, in plain Python floats, joint by joint."""
    d = ref.duration
    s = 1.0 if tk >= ref.t_end else min(max((tk - ref.t_start) / d, 0.0), 1.0)
    p = min(max(s**3 * (10.0 + s * (-15.0 + 6.0 * s)), 0.0), 1.0)
    rows: tuple[list[float], ...] = ([], [], [])
    for a, b in zip(ref.q_start.tolist(), ref.q_end.tolist(), strict=True):
        rows[0].append((1.0 - p) * a + p * b)
        rows[1].append((b - a) * (30.0 * s * s * (1.0 - s) * (1.0 - s) / d))
        rows[2].append((b - a) * (60.0 * s * (1.0 - s) * (1.0 - 2.0 * s) / (d * d)))
    return rows


def test_quintic_grid_pass_matches_the_scalar_formula() -> None:
    """The compiled one-pass evaluation on a whole grid against the formula sample by sample:
    velocity and acceleration exactly; the position to the rounding of ``p``, whose ``s**3``
    numpy may round one ulp away from Python's ``pow`` (so at most ``2 eps (|q_0| + |q_1|)``),
    and exactly outside the move and at its ends."""
    rng = np.random.default_rng(9)
    for _ in range(20):
        n = int(rng.integers(1, 8))
        q0 = rng.normal(size=n) * 10.0 ** rng.uniform(-3, 2)
        q1 = rng.normal(size=n) * 10.0 ** rng.uniform(-3, 2)
        ref = QuinticReference(q0, q1, duration=10.0 ** rng.uniform(-3, 2), t_start=rng.normal())
        d, t0 = ref.duration, ref.t_start
        t = np.r_[rng.uniform(t0 - d, t0 + 2 * d, 300), np.linspace(t0, ref.t_end, 101)]
        q, qd, qdd = ref.evaluate(t)
        rows = [_quintic_scalar(ref, float(tk)) for tk in t]
        want_q, want_qd, want_qdd = (np.array([r[i] for r in rows]) for i in range(3))
        np.testing.assert_array_equal(qd, want_qd)
        np.testing.assert_array_equal(qdd, want_qdd)
        assert np.all(np.abs(q - want_q) <= 2 * EPS * (np.abs(q0) + np.abs(q1)))
        ends = (t <= t0) | (t >= ref.t_end)
        np.testing.assert_array_equal(q[ends], want_q[ends])
        # and bit for bit the numpy broadcast of the formula (earlier versions' trajectory)
        s = np.where(t >= ref.t_end, 1.0, np.clip((t - t0) / d, 0.0, 1.0))[:, None]
        p = np.clip(s**3 * (10.0 + s * (-15.0 + 6.0 * s)), 0.0, 1.0)
        np.testing.assert_array_equal(q, (1.0 - p) * q0 + p * q1)


def test_quintic_parameters_are_read_only() -> None:
    ref = QuinticReference([0.0, 1.0], [1.0, 2.0], duration=1.0)
    assert ref.n == 2
    assert ref.duration == 1.0 and ref.t_start == 0.0
    with pytest.raises(ValueError, match="read-only"):
        ref.q_start[0] = 5.0
    with pytest.raises(AttributeError):
        ref.duration = 2.0  # type: ignore[misc]


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"duration": 0.0}, r"duration must be > 0 s, got 0.0"),
        ({"duration": -1.0}, r"duration must be > 0 s, got -1.0"),
        ({"duration": math.inf}, "duration must be finite"),
        ({"duration": math.nan}, "duration must be finite"),
        ({"duration": True}, "duration must be a real number"),
        ({"duration": "1"}, "duration must be a real number"),
        ({"duration": 1.0, "t_start": math.nan}, "t_start must be finite"),
        ({"duration": 1.0, "q_end": [1.0]}, r"q_end must have 2 values \(one per joint\), got 1"),
        ({"duration": 1.0, "q_start": [0.0, np.nan]}, "q_start must be finite"),
        ({"duration": 1.0, "q_end": [1.0, np.inf]}, "q_end must be finite"),
        ({"duration": 1.0, "q_start": []}, "q_start must have at least one value"),
        ({"duration": 1.0, "q_start": [[0.0, 1.0]]}, "q_start must be one-dimensional"),
        ({"duration": 1.0, "q_start": ["a", "b"]}, "q_start must be a sequence of numbers"),
    ],
)
def test_quintic_validation(kwargs: dict[str, object], match: str) -> None:
    args: dict[str, object] = {"q_start": [0.0, 1.0], "q_end": [1.0, 2.0]} | kwargs
    with pytest.raises(ValueError, match=match):
        QuinticReference(**args)  # type: ignore[arg-type]


def test_quintic_scalar_is_one_joint() -> None:
    ref = QuinticReference(0.0, 1.0, duration=1.0)
    assert ref.n == 1
    assert ref.evaluate([0.5])[0].shape == (1, 1)


# --------------------------------------------------------------------------------------------
# sine


def test_sine_formula_and_derivatives() -> None:
    ref = SineReference([0.1, -0.2], [0.5, -0.25], [0.5, 2.0], 0.3)
    t = np.linspace(0.0, 3.0, 31)
    q, qd, qdd = ref.evaluate(t)
    w = 2 * np.pi * np.array([0.5, 2.0])
    a = np.array([0.5, -0.25])
    arg = t[:, None] * w + 0.3
    np.testing.assert_allclose(q, [0.1, -0.2] + a * np.sin(arg), rtol=0, atol=1e-15)
    # |q^(5)| <= 0.25 * (4π)^5 ≈ 8e4 → h = 1e-4: truncation 8e4 h^4 / 30 ≈ 3e-13,
    # rounding eps * 0.5 * 1.5 / h ≈ 2e-12 (qd up to 3.1)
    np.testing.assert_allclose(qd, fd1(pos(ref), t, 1e-4), rtol=0, atol=2e-11)
    # qd's fifth derivative is ≤ 0.25 (4π)^6 ≈ 1e6 → 4e-11 truncation; rounding 3 * 2e-12
    np.testing.assert_allclose(qdd, fd1(vel(ref), t, 1e-4), rtol=0, atol=2e-10)
    assert ref.frequency.tolist() == [0.5, 2.0]
    assert ref.phase.tolist() == [0.3, 0.3]


def test_sine_grid_pass_matches_the_formula() -> None:
    """The compiled passes on a whole grid equal, bit for bit, the numpy broadcast of the
    formula (the same sines and cosines, the same products in the same order), and the
    scalar formula with the C library's sine and cosine to the rounding of those (a few ulps
    of ``A``, ``A ω``, ``A ω²``)."""
    rng = np.random.default_rng(10)
    for _ in range(20):
        n = int(rng.integers(1, 8))
        o, a, ph = rng.normal(size=n), 3 * rng.normal(size=n), rng.normal(size=n)
        ref = SineReference(o, a, rng.uniform(0, 5, n), ph)
        t = np.r_[rng.uniform(-20, 20, 200), np.arange(301) * 1e-3]
        q, qd, qdd = ref.evaluate(t)
        w = ref._omega
        arg = t[:, None] * w + ph
        sn, cs = np.sin(arg), np.cos(arg)
        np.testing.assert_array_equal(q, o + a * sn)
        np.testing.assert_array_equal(qd, a * w * cs)
        np.testing.assert_array_equal(qdd, -a * w * w * sn)
        ms = np.vectorize(math.sin)(arg)
        mc = np.vectorize(math.cos)(arg)
        scale = np.abs(a) * (1 + np.abs(arg)) * 4 * EPS
        assert np.all(np.abs(q - (o + a * ms)) <= scale + 2 * EPS * np.abs(o))
        assert np.all(np.abs(qd - a * w * mc) <= scale * w)
        assert np.all(np.abs(qdd + a * w * w * ms) <= scale * w * w)


@pytest.mark.parametrize(
    ("args", "match"),
    [
        (([0.0, 0.0], 1.0, -1.0), r"frequency must be >= 0 Hz, got \[-1.0, -1.0\]"),
        (([0.0, 0.0], [1.0, 2.0, 3.0], 1.0), r"amplitude must have 2 values"),
        (([0.0, 0.0], 1.0, 1.0, np.nan), "phase must be finite"),
        (([], 1.0, 1.0), "offset must have at least one value"),
    ],
)
def test_sine_validation(args: tuple[object, ...], match: str) -> None:
    with pytest.raises(ValueError, match=match):
        SineReference(*args)  # type: ignore[arg-type]


# --------------------------------------------------------------------------------------------
# sampled table


@settings(max_examples=60, deadline=None)
@given(
    coeffs=st.lists(st.lists(st.floats(-2.0, 2.0), min_size=6, max_size=6), min_size=1, max_size=3),
    gaps=st.lists(st.floats(0.5, 2.0), min_size=5, max_size=30),
    t0=st.floats(-3.0, 3.0),
)
def test_quintic_table_reproduces_quintic_polynomials(
    coeffs: list[list[float]], gaps: list[float], t0: float
) -> None:
    # samples on an irregular grid over ~[t0, t0 + 1], polynomial in (t - t0)
    g = np.array(gaps)
    t = t0 + np.r_[0.0, np.cumsum(g)] / g.sum()
    polys = [np.polynomial.Polynomial(c) for c in coeffs]
    x = t - t0
    ref = TableReference(t, np.stack([p(x) for p in polys], axis=1))
    tt = t0 + np.linspace(0.0, 1.0, 97)
    xx = tt - t0
    q, qd, qdd = ref.evaluate(tt)
    # exact up to the spline solve's rounding: gaps vary by at most 4x, the collocation
    # system is well conditioned; |p| <= 12, |p'| <= 60, |p''| <= 240 on [0, 1]; the
    # derivative of the piecewise polynomial divides by gaps >= 1/(4 * 30)
    for j, p in enumerate(polys):
        np.testing.assert_allclose(q[:, j], p(xx), rtol=0, atol=1e-10)
        np.testing.assert_allclose(qd[:, j], p.deriv(1)(xx), rtol=0, atol=1e-8)
        np.testing.assert_allclose(qdd[:, j], p.deriv(2)(xx), rtol=0, atol=1e-6)


def test_cubic_table_reproduces_cubics_but_not_quintics() -> None:
    t = np.linspace(-1.0, 2.0, 9)
    cubic = np.polynomial.Polynomial([0.3, -1.0, 0.5, 0.7])
    ref = TableReference(t, cubic(t), spline="cubic")
    assert ref.n == 1
    tt = np.linspace(-1.0, 2.0, 61)
    q, qd, qdd = ref.evaluate(tt)
    np.testing.assert_allclose(q[:, 0], cubic(tt), rtol=0, atol=1e-12)
    np.testing.assert_allclose(qd[:, 0], cubic.deriv()(tt), rtol=0, atol=1e-11)
    np.testing.assert_allclose(qdd[:, 0], cubic.deriv(2)(tt), rtol=0, atol=1e-10)

    quintic = np.polynomial.Polynomial([0, 0, 0, 0, 0, 1.0])
    q, _, _ = TableReference(t, quintic(t), spline="cubic").evaluate(tt)
    assert np.max(np.abs(q[:, 0] - quintic(tt))) > 1e-3


@pytest.mark.parametrize("spline", ["quintic", "cubic"])
def test_table_derivatives_against_finite_differences(spline: str) -> None:
    ref = sample_table(spline=spline)
    t = ref.t
    mid = 0.5 * (t[:-1] + t[1:])
    gap = t[1] - t[0]  # ≈ 0.1; the stencils (±2h) stay inside one polynomial piece
    h1, h2 = 0.005 * gap, 0.05 * gap
    _, qd, qdd = ref.evaluate(mid)
    # Inside a piece the spline is a polynomial of degree k <= 5, so fd2 (exact to degree 5)
    # and fd1 on qd (degree <= 4, fd1 is exact to degree 4) only round:
    # eps * 5.3 / h2^2 ≈ 5e-11 and eps * 1.5 / h1 ≈ 7e-13. fd1 on q has truncation
    # h1^4 / 30 * |q^(5)|, with q^(5) ≈ the data's (≤ 0.3 * 2^5 ≈ 10): ≈ 2e-14.
    np.testing.assert_allclose(qd, fd1(pos(ref), mid, h1), rtol=0, atol=1e-11)
    np.testing.assert_allclose(qdd, fd1(vel(ref), mid, h1), rtol=0, atol=1e-11)
    np.testing.assert_allclose(qdd, fd2(pos(ref), mid, h2), rtol=0, atol=5e-10)
    # and the spline interpolates the samples
    np.testing.assert_allclose(ref.evaluate(t)[0], ref.q, rtol=0, atol=1e-14)


def test_table_range() -> None:
    ref = sample_table()
    assert ref.t_range == (0.0, 4.0)
    # a rounding overshoot of the grid is taken as the end point
    q_end = ref.evaluate([4.0])[0]
    np.testing.assert_array_equal(ref.evaluate([4.0 * (1 + 2 * EPS)])[0], q_end)
    np.testing.assert_array_equal(ref.evaluate([-1e-15])[0], ref.evaluate([0.0])[0])
    with pytest.raises(ValueError, match=r"defined on \[0.0, 4.0\] s, got t\[1\] = 4.001"):
        ref.evaluate([1.0, 4.001])
    with pytest.raises(ValueError, match=r"defined on \[0.0, 4.0\] s, got t\[0\] = -0.5"):
        ref(-0.5)


def test_table_covers_the_paper_grid() -> None:
    t = np.linspace(0.0, PAPER_T_FINAL, 91)
    q_paper = PaperReference().evaluate(t)[0]
    ref = TableReference(t, q_paper)
    grid = np.arange(9001) * PAPER_DT
    q, qd, _ = ref.evaluate(grid)
    qp, qdp, _ = PaperReference().evaluate(grid)
    # quintic spline on spacing 0.05 of 0.5-amplitude sinusoids: error ~ h^6 * 0.5 → tiny
    np.testing.assert_allclose(q, qp, rtol=0, atol=1e-8)
    np.testing.assert_allclose(qd, qdp, rtol=0, atol=1e-6)


def test_table_data_is_read_only() -> None:
    ref = sample_table()
    with pytest.raises(ValueError, match="read-only"):
        ref.q[0, 0] = 1.0
    with pytest.raises(ValueError, match="read-only"):
        ref.t[0] = 1.0


@pytest.mark.parametrize(
    ("t", "q", "spline", "match"),
    [
        (
            [0, 1, 1, 2, 3, 4],
            np.zeros(6),
            "quintic",
            r"strictly increasing, got t\[2\] = 1.0 <= t\[1\]",
        ),
        ([0, 2, 1, 3, 4, 5], np.zeros(6), "quintic", r"strictly increasing, got t\[2\] = 1.0"),
        ([0, 1, np.nan, 3, 4, 5], np.zeros(6), "quintic", r"t must be finite, got t\[2\] = nan"),
        (np.zeros((6, 1)), np.zeros(6), "quintic", r"t must be one-dimensional, shape \(T_s,\)"),
        (range(6), np.zeros((5, 2)), "quintic", r"q must have shape \(T_s, n\) = \(6, n\)"),
        (range(6), np.zeros((6, 0)), "quintic", r"got shape \(6, 0\)"),
        (range(6), np.zeros((6, 2, 1)), "quintic", r"got shape \(6, 2, 1\)"),
        (range(6), [[0, 0]] * 5 + [[0, np.inf]], "quintic", r"q must be finite, got q\[5, 1\]"),
        (
            range(5),
            np.zeros(5),
            "quintic",
            "a quintic spline \\(degree 5\\) needs at least 6 samples, got 5",
        ),
        (
            range(3),
            np.zeros(3),
            "cubic",
            "a cubic spline \\(degree 3\\) needs at least 4 samples, got 3",
        ),
        (range(6), np.zeros(6), "linear", "spline must be 'quintic' or 'cubic', got 'linear'"),
        (range(6), ["x"] * 6, "quintic", "q must be an array of numbers"),
    ],
)
def test_table_validation(t: object, q: object, spline: str, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        TableReference(t, q, spline=spline)  # type: ignore[arg-type]


def test_table_minimum_sizes_work() -> None:
    TableReference(range(6), np.arange(6.0), spline="quintic")
    TableReference(range(4), np.arange(4.0), spline="cubic")


@pytest.mark.parametrize("spline", ["quintic", "cubic"])
def test_table_at_rest_starts_and_ends_at_rest(spline: str) -> None:
    # a few waypoints of a 6-joint arm: the spline goes through each and is at rest at the ends
    t = [0.0, 1.5, 3.0, 5.0]
    q = np.array([[0.0, -1.3, 1.3, -1.6, -1.57, 0.0], [0.6, -1.6, 1.7, -1.2, -1.1, 0.6],
                  [1.0, -1.0, 1.0, -1.9, -1.9, 1.2], [0.0, -1.3, 1.3, -1.6, -1.57, 0.0]])
    ref = TableReference(t, q, spline=spline, ends="rest")  # type: ignore[arg-type]
    assert ref.n == 6 and ref.ends == "rest"
    pos, vel, acc = ref.evaluate(np.array(t))
    np.testing.assert_allclose(pos, q, atol=1e-14)
    np.testing.assert_allclose(vel[[0, -1]], 0.0, atol=1e-13)
    if spline == "quintic":
        np.testing.assert_allclose(acc[[0, -1]], 0.0, atol=1e-13)
    # two samples suffice at rest: the quintic between them is the rest-to-rest quintic
    two = TableReference([0.0, 2.0], [[0.0], [1.0]], ends="rest")
    move = QuinticReference([0.0], [1.0], duration=2.0)
    tt = np.linspace(0.0, 2.0, 41)
    for a, b in zip(two.evaluate(tt), move.evaluate(tt), strict=True):
        np.testing.assert_allclose(a, b, atol=1e-12)
    # a record of it rebuilds it, ends included
    again = reference_from_dict(ref.to_dict())
    assert again == ref and again.to_dict()["ends"] == "rest"
    assert ref != TableReference(np.linspace(0, 5, 6), np.zeros((6, 6)), spline=spline)  # type: ignore[arg-type]


def test_table_ends_are_checked() -> None:
    with pytest.raises(ValueError, match="ends must be 'not-a-knot' or 'rest', got 'clamped'"):
        TableReference(range(6), np.arange(6.0), ends="clamped")  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="ends must be 'not-a-knot' or 'rest', got 1"):
        TableReference(range(6), np.arange(6.0), ends=1)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"quintic spline \(degree 5\) at rest needs at least 2"):
        TableReference([0.0], [[1.0]], ends="rest")


# --------------------------------------------------------------------------------------------
# CSV


def write(tmp_path: Path, text: str, name: str = "traj.csv") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def test_from_csv_with_header_and_comments(tmp_path: Path) -> None:
    t = np.linspace(0.0, 1.0, 8)
    lines = ["# a trajectory", "t, q1, q2", ""]
    lines += [f"{a!r}, {a**2!r}, {-a!r}" for a in t.tolist()]
    ref = TableReference.from_csv(write(tmp_path, "\n".join(lines) + "\n"))
    assert ref.n == 2
    assert ref.spline == "quintic"
    np.testing.assert_array_equal(ref.t, t)
    np.testing.assert_array_equal(ref.q, np.c_[t**2, -t])
    np.testing.assert_allclose(ref(0.5)[1], [1.0, -1.0], rtol=0, atol=1e-12)


def test_from_csv_without_header_cubic_and_delimiter(tmp_path: Path) -> None:
    text = "\n".join(f"{k};{k * 0.5}" for k in range(5))
    ref = TableReference.from_csv(str(write(tmp_path, text)), spline="cubic", delimiter=";")
    assert ref.n == 1 and ref.spline == "cubic"
    np.testing.assert_allclose(ref(2.5)[0], [1.25], atol=1e-14)


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("time,q1\n0,1\n1,oops\n", r"traj.csv, line 3, column 2 \('q1'\): cannot read 'oops'"),
        ("0,1\n1,x\n", r"traj.csv, line 2, column 2: cannot read 'x' as a number"),
        ("t,q1\n0,1\n1,nan\n", r"traj.csv, line 3, column 2 \('q1'\): value 'nan' is not finite"),
        ("t,q1,q2\n0,1,2\n1,2\n", r"traj.csv, line 3: 2 columns, expected 3 \(.*line 1\)"),
        ("angle,q1\n0,1\n", r"traj.csv, line 1: the first column must be the time 't'"),
        ("# only\n0\n1\n", r"traj.csv, line 2: needs a time column and at least one joint"),
        ("t,q1\n0,1\n2,1\n1,1\n", r"traj.csv, line 4: time 1.0 is not greater than 2.0 on line 3"),
        ("t,q1\n# nothing\n", r"traj.csv: no data rows"),
        ("", r"traj.csv: no data rows"),
        ("t,q1\n0,0\n1,1\n2,2\n", r"traj.csv: a quintic spline \(degree 5\) needs at least 6"),
    ],
)
def test_from_csv_errors_name_file_line_column(tmp_path: Path, text: str, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        TableReference.from_csv(write(tmp_path, text))


def test_from_csv_missing_file(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError, match=r"nope\.csv"):
        TableReference.from_csv(tmp_path / "nope.csv")


# --------------------------------------------------------------------------------------------
# callables


def test_callable_reference_values() -> None:
    ref = sample_callable()
    t = np.linspace(0.0, 2.0, 11)
    q, _, qdd = ref.evaluate(t)
    np.testing.assert_array_equal(q, np.c_[np.sin(t), t**2])
    np.testing.assert_array_equal(qdd[:, 1], 2.0)
    assert ref.n == 2


def test_callable_receives_read_only_times() -> None:
    def q(t: Arr) -> Arr:
        t[0] = 99.0
        return t

    ref = CallableReference(q, q, q, n=1)
    with pytest.raises(ValueError, match="read-only"):
        ref.evaluate(np.array([0.0, 1.0]))


def test_callable_one_joint_accepts_flat_output() -> None:
    ref = CallableReference(np.sin, np.cos, lambda t: -np.sin(t), n=1)
    q, qd, _ = ref.evaluate(np.array([0.0, 1.0]))
    assert q.shape == (2, 1)
    np.testing.assert_array_equal(qd[:, 0], np.cos([0.0, 1.0]))


def test_callable_requires_derivatives() -> None:
    with pytest.raises(ValueError, match="CallableReference needs qd: the derivatives"):
        CallableReference(np.sin, n=1)
    with pytest.raises(ValueError, match=r"CallableReference needs qdd.*never differentiates"):
        CallableReference(np.sin, np.cos, n=1)
    with pytest.raises(ValueError, match=r"qd must be callable, got 3\.0"):
        CallableReference(np.sin, 3.0, np.cos, n=1)  # type: ignore[arg-type]


@pytest.mark.parametrize("n", [0, -1, 1.5, True, "2"])
def test_callable_validates_n(n: object) -> None:
    with pytest.raises(ValueError, match="n must be an integer >= 1"):
        CallableReference(np.sin, np.cos, np.sin, n=n)  # type: ignore[arg-type]


def test_callable_output_checks_name_the_function() -> None:
    good = lambda t: np.zeros((t.shape[0], 2))  # noqa: E731
    t = np.linspace(0.0, 1.0, 4)

    transposed = CallableReference(good, lambda t: np.zeros((2, t.shape[0])), good, n=2)
    with pytest.raises(ValueError, match=r"qd\(t\) returned shape \(2, 4\) .* expected \(4, 2\)$"):
        transposed.evaluate(t)

    flat = CallableReference(good, good, lambda t: np.zeros(t.shape[0]), n=2)
    with pytest.raises(ValueError, match=r"qdd\(t\) returned shape \(4,\)"):
        flat.evaluate(t)

    scalar = CallableReference(lambda t: 1.0, np.cos, np.sin, n=1)
    with pytest.raises(
        ValueError, match=r"q\(t\) returned shape \(\) .* expected \(4, 1\) or \(4,\)"
    ):
        scalar.evaluate(t)

    nonfinite = CallableReference(good, good, lambda t: np.c_[t, 1 / (t - t[2])], n=2)
    with (
        pytest.raises(ValueError, match=r"qdd\(t\) is not finite at t = 0.666.* \(joint 1\)"),
        np.errstate(divide="ignore"),
    ):
        nonfinite.evaluate(t)

    garbage = CallableReference(good, lambda t: [["a", "b"]] * len(t), good, n=2)
    with pytest.raises(ValueError, match=r"qd\(t\) must return numbers of shape \(4, 2\)"):
        garbage.evaluate(t)


def test_callable_equality_is_by_function_identity() -> None:
    a = sample_callable()
    assert a == a
    assert a != sample_callable()  # different lambda objects
    assert CallableReference(np.sin, np.cos, np.sin, n=1) == CallableReference(
        np.sin, np.cos, np.sin, n=1
    )
    assert a != PaperReference()
    d = a.to_dict()
    assert d["kind"] == "callable" and d["n"] == 2
    json.dumps(d)


# --------------------------------------------------------------------------------------------
# to_dict / reference_from_dict


@pytest.mark.parametrize("ref", REFS[:5], ids=IDS[:5])
def test_round_trip(ref: Reference) -> None:
    d = ref.to_dict()
    assert d["kind"] in REFERENCE_KINDS
    text = json.dumps(d)  # JSON-able
    rebuilt = reference_from_dict(json.loads(text))
    assert type(rebuilt) is type(ref)
    assert rebuilt == ref
    assert hash(rebuilt) == hash(ref)
    assert rebuilt.to_dict() == d
    t = np.linspace(0.0, 4.0, 33)
    for a, b in zip(ref.evaluate(t), rebuilt.evaluate(t), strict=True):
        np.testing.assert_array_equal(a, b)


def test_inequality_and_repr() -> None:
    a = QuinticReference([0.0], [1.0], duration=1.0)
    assert a != QuinticReference([0.0], [1.0], duration=2.0)
    assert a != PaperReference()
    assert a != "quintic"
    for ref in REFS:
        assert type(ref).__name__ in repr(ref)


def test_table_from_dict_path(tmp_path: Path) -> None:
    text = "t,q1\n" + "\n".join(f"{k},{k * k}" for k in range(6))
    write(tmp_path, text)
    ref = reference_from_dict(
        {"kind": "table", "path": "traj.csv", "spline": "cubic"}, base_dir=tmp_path
    )
    assert isinstance(ref, TableReference) and ref.spline == "cubic"
    # to_dict stores the data inline, so the record does not depend on the file
    assert reference_from_dict(ref.to_dict()) == ref
    absolute = reference_from_dict({"kind": "table", "path": str(tmp_path / "traj.csv")})
    assert isinstance(absolute, TableReference) and absolute.spline == "quintic"


def test_defaults_from_dict() -> None:
    q = reference_from_dict({"kind": "quintic", "q_start": [0], "q_end": [1], "duration": 2})
    assert isinstance(q, QuinticReference) and q.t_start == 0.0
    s = reference_from_dict({"kind": "sine", "offset": [0, 0], "amplitude": 1, "frequency": 1})
    assert isinstance(s, SineReference) and s.phase.tolist() == [0.0, 0.0]


@pytest.mark.parametrize(
    ("d", "match"),
    [
        ({}, r"reference needs a 'kind' key, one of \['paper', 'quintic', 'sine', 'table'\]"),
        ({"kind": "spline"}, "unknown reference kind 'spline'; expected one of"),
        ({"kind": "callable", "n": 2}, "CallableReference cannot be rebuilt from a dict"),
        (
            {"kind": "paper", "amplitude": 1},
            r"unknown key\(s\) \['amplitude'\] for reference kind 'paper'",
        ),
        (
            {"kind": "quintic", "q_start": [0]},
            r"reference kind 'quintic' needs \['duration', 'q_end'\]",
        ),
        (
            {"kind": "quintic", "q_start": [0], "q_end": [1], "duration": 1, "durration": 2},
            r"unknown key\(s\) \['durration'\].*allowed: \['duration', 'q_end', 'q_start', 't_start'\]",
        ),
        ({"kind": "quintic", "q_start": [0], "q_end": [1], "duration": -1}, "duration must be > 0"),
        ({"kind": "table", "t": [0, 1]}, "a table reference needs 't' and 'q' \\(or 'path'"),
        ({"kind": "table", "path": "x.csv", "t": [0]}, "either 'path' or 't' and 'q', not both"),
        ({"kind": "table", "t": list(range(6)), "q": [0] * 6, "spline": "akima"}, "spline must be"),
        ([("kind", "paper")], "a reference must be given as a mapping"),
    ],
)
def test_from_dict_errors(d: object, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        reference_from_dict(d)  # type: ignore[arg-type]
