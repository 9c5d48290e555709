"""The vectorisable elementary functions (slidingarm._vecmath): accuracy in ulps over the
range a lane loop can meet, special values, independence from ``fastmath={"contract"}``,
and vector code without libm calls when inlined into a loop.

The reference is numpy in x87 extended precision (``np.longdouble``: 64-bit significand,
``sinl``/``expl``/... accurate to about ``2**-63``), so an error is measured to about
``2**-10`` ulp of float64; the error of a result ``y`` against the exact ``f(x)`` is
``|y - f(x)| / ulp(f(x))``, ``ulp`` the spacing of float64 at ``f(x)`` rounded to float64.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest
from numba import njit

from slidingarm import _vecmath as vm

LD = np.longdouble
pytestmark = pytest.mark.skipif(
    np.finfo(LD).nmant < 63, reason="needs an extended-precision np.longdouble as reference"
)

# the bounds the docstrings state (in ulps)
BOUND = {"sin": 1.0, "cos": 1.0, "exp": 1.0, "log": 1.0, "pow_abs": 1.0, "tanh": 1.0}


def _unary(f: Callable[..., Any], fastmath: Any) -> Any:
    @njit(error_model="numpy", fastmath=fastmath)
    def loop(x: np.ndarray, out: np.ndarray) -> None:
        for i in range(x.shape[0]):
            out[i] = f(x[i])

    return loop


def _binary(f: Callable[..., Any], fastmath: Any) -> Any:
    @njit(error_model="numpy", fastmath=fastmath)
    def loop(x: np.ndarray, g: np.ndarray, out: np.ndarray) -> None:
        for i in range(x.shape[0]):
            out[i] = f(x[i], g[i])

    return loop


def _sincos_loop(fastmath: Any) -> Any:
    @njit(error_model="numpy", fastmath=fastmath)
    def loop(x: np.ndarray, s: np.ndarray, c: np.ndarray) -> None:
        for i in range(x.shape[0]):
            s[i], c[i] = vm.sincos(x[i])

    return loop


@njit(error_model="numpy")
def _trig(x: np.ndarray, out: np.ndarray) -> None:
    """The three trigonometric entry points in one loop (one compilation):
    ``out = [sin x, cos x, sincos(x)[0], sincos(x)[1]]``."""
    for i in range(x.shape[0]):
        out[0, i] = vm.sin(x[i])
        out[1, i] = vm.cos(x[i])
        out[2, i], out[3, i] = vm.sincos(x[i])


FUNCS = {"exp": vm.exp, "log": vm.log, "tanh": vm.tanh}
FLAGS = {"plain": False, "contract": {"contract"}}
_LOOPS: dict[tuple[str, str], Any] = {}


def loop_of(name: str, flags: str = "plain") -> Any:
    """One compiled loop per function and flag set, shared by all tests of the module."""
    key = (name, flags)
    if key not in _LOOPS:
        fm = FLAGS[flags]
        if name == "pow_abs":
            _LOOPS[key] = _binary(vm.pow_abs, fm)
        elif name == "sincos":
            _LOOPS[key] = _sincos_loop(fm)
        else:
            _LOOPS[key] = _unary(FUNCS[name], fm)
    return _LOOPS[key]


def ours(name: str, x: np.ndarray, g: np.ndarray | None = None, flags: str = "plain") -> Any:
    """Our ``name`` on ``x`` (and ``g``) through a compiled loop."""
    x = np.ascontiguousarray(x, dtype=np.float64)
    out = np.empty_like(x)
    if name == "sincos" and flags != "plain":
        other = np.empty_like(x)
        loop_of("sincos", flags)(x, out, other)
        return out, other
    if name in ("sin", "cos", "sincos"):
        trig = np.empty((4, x.size))
        _trig(x, trig)
        return {"sin": trig[0], "cos": trig[1], "sincos": (trig[2], trig[3])}[name]
    if g is None:
        loop_of(name, flags)(x, out)
    else:
        loop_of(name, flags)(x, np.ascontiguousarray(np.broadcast_to(g, x.shape)), out)
    return out


def ulps(got: np.ndarray, exact: np.ndarray) -> np.ndarray:
    """``|got - exact| / ulp(exact)``, ``exact`` in long double and ``ulp(v)`` the spacing of
    float64 in the binade of ``v`` (``2**(e - 53)`` for ``|v| = m 2**e``, ``1/2 <= m < 1``;
    ``2**-1074`` in the subnormal range)."""
    _, e = np.frexp(np.abs(exact))
    ulp = np.ldexp(LD(1), np.maximum(e.astype(np.int64) - 53, -1074))
    return np.asarray(np.abs(got.astype(LD) - exact) / ulp, dtype=np.float64)


def _loguniform(rng: np.random.Generator, lo: float, hi: float, n: int) -> np.ndarray:
    return np.exp(rng.uniform(np.log(lo), np.log(hi), n))


def _with_neighbours(x: np.ndarray, k: int = 2) -> np.ndarray:
    parts = [x]
    up, dn = x.copy(), x.copy()
    for _ in range(k):
        up, dn = np.nextafter(up, np.inf), np.nextafter(dn, -np.inf)
        parts += [up, dn]
    return np.concatenate(parts)


@pytest.fixture(scope="module")
def rng() -> np.random.Generator:
    return np.random.default_rng(20261202)


# --------------------------------------------------------------------------- sin / cos


def _trig_samples(rng: np.random.Generator) -> np.ndarray:
    n = 60_000
    k = np.concatenate([np.arange(-64, 65), rng.integers(-667_000, 667_000, 4000)])
    # multiples of pi/2 (k up to 2**20 * 2/pi: the edge of the range), and neighbours
    mult = _with_neighbours(k * (np.pi / 2), 3)
    mag = _loguniform(rng, 2.0**-40, 2.0**20, n) * rng.choice([-1.0, 1.0], n)
    return np.concatenate(
        [
            rng.uniform(-1e3, 1e3, n),  # the loop's angles (MAX_POSITION = 1e3 rad)
            rng.uniform(-np.pi, np.pi, n),
            mag,
            mult,
            [0.0, 2.0**-1074, 2.0**-1022, 1e-300, 2.0**-27, 2.0**-26, 2.0**20, -(2.0**20)],
        ]
    )


def test_sin_cos_within_one_ulp_up_to_2_pow_20(rng: np.random.Generator) -> None:
    x = _trig_samples(rng)
    assert np.abs(x).max() <= 2.0**20
    xl = x.astype(LD)
    es = ulps(ours("sin", x), np.sin(xl))
    ec = ulps(ours("cos", x), np.cos(xl))
    assert es.max() <= BOUND["sin"], (es.max(), x[es.argmax()])
    assert ec.max() <= BOUND["cos"], (ec.max(), x[ec.argmax()])
    # the bound is not loose: the errors are fractions of an ulp, not exactly 0
    assert 0.5 < es.max() and 0.5 < ec.max()


def test_sin_cos_reduction_holds_to_2_pow_50(rng: np.random.Generator) -> None:
    x = _loguniform(rng, 2.0**20, vm.TRIG_MAX, 20_000) * rng.choice([-1.0, 1.0], 20_000)
    x = np.concatenate([x, _with_neighbours(np.round(x[:200] / (np.pi / 2)) * (np.pi / 2))])
    xl = x.astype(LD)
    assert ulps(ours("sin", x), np.sin(xl)).max() <= 1.0
    assert ulps(ours("cos", x), np.cos(xl)).max() <= 1.0


def test_sin_and_cos_are_sincos(rng: np.random.Generator) -> None:
    x = np.ascontiguousarray(_trig_samples(rng)[::7])
    trig = np.empty((4, x.size))
    _trig(x, trig)
    assert np.array_equal(trig[0], trig[2]) and np.array_equal(trig[1], trig[3])


def test_sin_cos_special_values() -> None:
    x = np.array([0.0, -0.0, 5e-324, -5e-324, np.inf, -np.inf, np.nan, 2.0**51, -1e300])
    s, c = ours("sin", x), ours("cos", x)
    assert np.array_equal(s[:4], x[:4]) and np.array_equal(np.signbit(s[:4]), np.signbit(x[:4]))
    assert np.array_equal(c[:4], np.ones(4))
    assert np.isnan(s[4:7]).all() and np.isnan(c[4:7]).all()
    # beyond TRIG_MAX: finite and bounded (documented as meaningless)
    assert np.isfinite(s[7:]).all() and (np.abs(s[7:]) <= 1).all() and (np.abs(c[7:]) <= 1).all()
    assert np.array_equal(ours("sin", -x[4:]), -s[4:], equal_nan=True)  # odd


# --------------------------------------------------------------------------- exp / log


def test_exp_within_one_ulp(rng: np.random.Generator) -> None:
    n = 100_000
    x = np.concatenate(
        [
            rng.uniform(-745.2, 709.78, n),
            rng.uniform(-1.0, 1.0, n),
            _loguniform(rng, 1e-300, 1.0, n) * rng.choice([-1.0, 1.0], n),
            _with_neighbours(np.arange(-1074, 1024) * np.log(2.0), 2),
            [0.0, -0.0, 5e-324, 709.782712893384, -708.39641853226408, -745.13321910194110],
        ]
    )
    e = ulps(ours("exp", x), np.exp(x.astype(LD)))
    assert e.max() <= BOUND["exp"], (e.max(), x[e.argmax()])
    # normal results are well inside the bound
    normal = np.exp(x) >= 2.2250738585072014e-308
    assert e[normal].max() < 0.9


def test_exp_special_values() -> None:
    x = np.array([709.79, 1e308, np.inf, -745.14, -1e308, -np.inf, np.nan, 0.0, -0.0])
    y = ours("exp", x)
    assert np.array_equal(y[:3], [np.inf] * 3)
    assert np.array_equal(y[3:6], [0.0] * 3)
    assert np.isnan(y[6]) and y[7] == 1.0 and y[8] == 1.0


def test_log_within_one_ulp(rng: np.random.Generator) -> None:
    n = 100_000
    x = np.concatenate(
        [
            np.exp2(rng.uniform(-1074, 1024, n)),  # every binade, subnormals included
            rng.uniform(0.5, 2.0, n),
            1.0 + _loguniform(rng, 2.0**-52, 0.25, n) * rng.choice([-1.0, 1.0], n),
            _with_neighbours(np.array([1.0, 2.0, 0.5, np.sqrt(2.0), np.sqrt(0.5), np.e]), 4),
            [5e-324, 2.0**-1022, np.nextafter(2.0**-1022, 0), 1.7976931348623157e308],
        ]
    )
    x = x[np.isfinite(x) & (x > 0)]
    e = ulps(ours("log", x), np.log(x.astype(LD)))
    assert e.max() <= BOUND["log"], (e.max(), x[e.argmax()])


def test_log_special_values() -> None:
    y = ours("log", np.array([1.0, 0.0, -0.0, -1.0, -np.inf, np.inf, np.nan, -5e-324]))
    assert y[0] == 0.0 and not np.signbit(y[0])
    assert y[1] == -np.inf and y[2] == -np.inf
    assert np.isnan(y[3]) and np.isnan(y[4]) and np.isnan(y[7])
    assert y[5] == np.inf and np.isnan(y[6])


# --------------------------------------------------------------------------- pow_abs, tanh


def test_pow_abs_within_one_ulp(rng: np.random.Generator) -> None:
    n = 120_000
    x = _loguniform(rng, 1e-300, 1e3, n) * rng.choice([-1.0, 1.0], n)
    g = rng.uniform(0.0, 2.0, n)
    g[: n // 4] = rng.choice([5 / 7, 3 / 5, 0.5, 1.0, 1.5, 1e-3, 1.999], n // 4)  # typical γ
    g = np.where(g > 0, g, 0.25)
    exact = np.power(np.abs(x).astype(LD), g.astype(LD))
    e = ulps(ours("pow_abs", x, g), exact)
    assert e.max() <= BOUND["pow_abs"], (e.max(), x[e.argmax()], g[e.argmax()])


def test_pow_abs_special_values() -> None:
    x = np.array([0.0, -0.0, 1.0, -1.0, np.inf, -np.inf, np.nan, 4.0, -9.0])
    g = np.array([0.7, 1.5, 0.3, 1.9, 0.5, 1.2, 0.5, 0.5, 0.5])
    y = ours("pow_abs", x, g)
    assert np.array_equal(y[:6], [0.0, 0.0, 1.0, 1.0, np.inf, np.inf])
    assert np.isnan(y[6]) and y[7] == 2.0 and y[8] == 3.0
    assert np.isnan(ours("pow_abs", np.array([2.0]), np.array([np.nan]))[0])


def test_tanh_within_one_ulp(rng: np.random.Generator) -> None:
    n = 100_000
    x = np.concatenate(
        [
            rng.uniform(-20.0, 20.0, n),
            rng.uniform(-1.0, 1.0, n),
            _loguniform(rng, 1e-300, 1.0, n) * rng.choice([-1.0, 1.0], n),
            _with_neighbours(np.array([0.55, 19.06, 0.5 * np.log(3.0)]), 4),
            [5e-324, 2.0**-1022, 1e-8, 0.3465, 0.3466],
        ]
    )
    e = ulps(ours("tanh", x), np.tanh(x.astype(LD)))
    assert e.max() <= BOUND["tanh"], (e.max(), x[e.argmax()])


def test_tanh_special_values(rng: np.random.Generator) -> None:
    x = np.array([0.0, -0.0, 5e-324, -5e-324, 19.1, -19.1, 1e300, np.inf, -np.inf, np.nan])
    y = ours("tanh", x)
    assert np.array_equal(y[:4], x[:4]) and np.array_equal(np.signbit(y[:4]), np.signbit(x[:4]))
    assert np.array_equal(y[4:9], [1.0, -1.0, 1.0, 1.0, -1.0]) and np.isnan(y[9])
    z = rng.uniform(-25.0, 25.0, 5000)
    assert np.array_equal(ours("tanh", -z), -ours("tanh", z))  # odd, bit for bit


# --------------------------------------------------------------------------- compiled form


def _inputs(name: str, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray | None]:
    n = 20_000
    if name == "sincos":
        return rng.uniform(-1e3, 1e3, n), None
    if name == "exp":
        return rng.uniform(-750.0, 710.0, n), None
    if name == "log":
        return np.exp2(rng.uniform(-1074, 1024, n)), None
    if name == "tanh":
        return rng.uniform(-20.0, 20.0, n), None
    return _loguniform(rng, 1e-300, 1e3, n), rng.uniform(0.01, 2.0, n)


ALL = ["sincos", "exp", "log", "tanh", "pow_abs"]


def _run(name: str, x: np.ndarray, g: np.ndarray | None, flags: str) -> np.ndarray:
    got = ours(name, x, g, flags=flags)
    return np.stack(got) if name == "sincos" else got


@pytest.mark.parametrize("name", ALL)
def test_contract_flag_changes_no_bit(name: str, rng: np.random.Generator) -> None:
    """Every product feeding a sum is an explicit fma or an uncontractable product, so a
    caller compiled with fastmath={"contract"} gets the very same results."""
    x, g = _inputs(name, rng)
    assert np.array_equal(_run(name, x, g, "plain"), _run(name, x, g, "contract"), equal_nan=True)


_VECTOR_OP = re.compile(r"(?:fmul|fadd|fsub|fdiv)[^\n]*<(?:4|8) x double>|@llvm\.fma\.v(?:4|8)f64")
_LIBM = re.compile(r"call[^\n]*@(?:llvm\.)?(?:sin|cos|exp|log|pow|tanh)(?:\.f64)?\b")


def _vector_code(dispatcher: Any) -> tuple[bool, bool]:
    """(vector arithmetic on doubles present, libm call present) in a compiled loop."""
    sig = dispatcher.signatures[0]
    llvm = dispatcher.inspect_llvm(sig)
    asm = dispatcher.inspect_asm(sig)
    vector = bool(_VECTOR_OP.search(llvm)) and bool(re.search(r"%[yz]mm", asm))
    libm = bool(_LIBM.search(llvm)) or bool(
        re.search(r"call\w*\s+\S*\b(?:sin|cos|exp|log|pow|tanh)\b", asm)
    )
    return vector, libm


@pytest.mark.parametrize("flags", list(FLAGS))
@pytest.mark.parametrize("name", ALL)
def test_vectorises_without_libm_calls(name: str, flags: str, rng: np.random.Generator) -> None:
    x, g = _inputs(name, rng)
    _run(name, x[:16], None if g is None else g[:16], flags)
    plain_trig = name == "sincos" and flags == "plain"  # the loop of sin, cos and sincos
    assert _vector_code(_trig if plain_trig else loop_of(name, flags)) == (True, False)


def test_the_libm_loop_is_the_contrast() -> None:
    """The same loop around math.sin is scalar with a call: the check above can fail."""
    loop = _unary(math.sin, False)
    x = np.linspace(0.0, 1.0, 16)
    out = np.empty_like(x)
    loop(x, out)
    assert np.allclose(out, np.sin(x), rtol=1e-15, atol=0)
    assert _vector_code(loop) == (False, True)


def test_lane_block_vectorises(rng: np.random.Generator) -> None:
    """An 8-lane block (runs in the innermost dimension, a local scratch of the block's
    width) becomes vector code with sincos inlined."""

    @njit(error_model="numpy", fastmath={"contract"})
    def block(x: np.ndarray, out: np.ndarray) -> None:
        lane = np.empty(8)
        for b in range(x.shape[0] // 8):
            for j in range(8):
                lane[j] = x[8 * b + j]
            for j in range(8):
                s, c = vm.sincos(lane[j])
                lane[j] = s * c
            for j in range(8):
                out[8 * b + j] = lane[j]

    x = rng.uniform(-1e3, 1e3, 64)
    out = np.empty_like(x)
    block(x, out)
    assert np.allclose(out, np.sin(x) * np.cos(x), rtol=0, atol=1e-15)
    assert _vector_code(block) == (True, False)
