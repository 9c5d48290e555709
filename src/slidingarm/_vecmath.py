"""Elementary functions that LLVM can vectorise inside a lane loop (issue 12, point 1).

A call to ``math.sin``, ``math.exp``, ``math.log``, ``x**y`` or ``math.tanh`` in a numba loop
is an opaque libm call: the loop over the runs of a block (the *lanes*) then stays scalar,
because the PyPI llvmlite has no SVML vector library. The functions here are plain float64
arithmetic instead, each ``@njit(inline="always")``: inlined into a loop
``for l in range(8): out[l] = sin(x[l])`` they become ``<8 x double>`` code (AVX-512) or
``<4 x double>`` code (AVX2).

Methods, common to all
----------------------
* Range reduction to a small interval, then a polynomial fitted there
  (Chebyshev fits, ``mpmath.chebyfit`` at 60 digits, near-minimax in absolute error; the
  fitted interval and the fit's error are stated at each coefficient table).
* Branch-free: every case split is a select (``a if c else b`` on floats), no data-dependent
  loop, no exception.
* ``2**k`` scaling and exponent extraction through a float64 <-> int64 bitcast
  (:func:`_as_int`, :func:`_as_float`); rounding to an integer by the ``1.5 * 2**52``
  shifter.
* Every product that feeds a sum is either an explicit fused multiply-add (:func:`_fma`,
  ``llvm.fma.f64``: one rounding) or an explicitly *uncontracted* product (:func:`_mul`).
  The compensated (error-free) sums of the reductions need the exact rounding of each
  operation, and numba's ``fastmath={"contract"}`` would otherwise fuse ``a*b + c`` of the
  inlined code into a fused multiply-add. So the results are bit-for-bit the same with
  ``fastmath`` off and with ``fastmath={"contract"}`` (tested).

Flags. Use these functions in a caller compiled with ``fastmath`` off or with
``fastmath={"contract"}``. The other fast-math flags are not supported: ``reassoc`` would
cancel the compensated sums (``(a + b) - a - b`` becomes 0) and the ``1.5 * 2**52`` rounding,
``nnan``/``ninf`` would drop the NaN and infinity handling, ``arcp`` would round the two
divisions (:func:`log`, :func:`tanh`) differently. ``error_model="numpy"`` (here and in the
caller) is needed: the default ``"python"`` model puts a zero-division check, a branch, in front
of each division.

Accuracy, in units in the last place of the result (``ulp(v)`` the float64 spacing in the
binade of the exact ``v``), against numpy in x87 extended precision (64-bit significand), on
dense random samples over the stated ranges plus edge cases (``tests/engine/test_vecmath.py``
asserts the stated bound; the largest error measured there is given beside it):

========  ==========================================  =========  ========
function  range                                       bound      measured
========  ==========================================  =========  ========
sin/cos   ``|x| <= 2**20`` (also tested to ``2**50``)  1 ulp      0.80
exp       all float64                                 1 ulp      0.81
log       all float64 ``> 0``, subnormals too         1 ulp      0.59
pow_abs   ``|x|`` in ``[1e-300, 1e3]``, ``0 < g < 2``  1 ulp      0.82
tanh      all float64                                 1 ulp      0.83
========  ==========================================  =========  ========
"""

from __future__ import annotations

from typing import Any

from llvmlite import ir
from numba import njit, types
from numba.extending import intrinsic

_INLINE: dict[str, Any] = {
    "cache": True,
    "nogil": True,
    "error_model": "numpy",
    "inline": "always",
}


# --------------------------------------------------------------------------- primitives


@intrinsic
def _as_int(typingctx: Any, x: Any) -> Any:
    """The bits of the float64 ``x`` as an int64 (an LLVM ``bitcast``, no conversion)."""
    if not isinstance(x, types.Float) or x.bitwidth != 64:
        return None

    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        return builder.bitcast(args[0], ir.IntType(64))

    return types.int64(types.float64), codegen


@intrinsic
def _as_float(typingctx: Any, i: Any) -> Any:
    """The float64 whose bits are the int64 ``i`` (an LLVM ``bitcast``, no conversion)."""
    if not isinstance(i, types.Integer):
        return None

    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        v = context.cast(builder, args[0], signature.args[0], types.int64)
        return builder.bitcast(v, ir.DoubleType())

    return types.float64(i), codegen


@intrinsic
def _fma(typingctx: Any, a: Any, b: Any, c: Any) -> Any:
    """``a*b + c`` rounded once (``llvm.fma.f64``; a ``vfmadd`` on a CPU with FMA)."""
    if not all(isinstance(t, types.Float) for t in (a, b, c)):
        return None

    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        fargs = [
            context.cast(builder, v, t, types.float64)
            for v, t in zip(args, signature.args, strict=True)
        ]
        return builder.fma(*fargs)

    return types.float64(a, b, c), codegen


@intrinsic
def _mul(typingctx: Any, a: Any, b: Any) -> Any:
    """``a*b`` rounded, never fused into a later sum.

    The ``fmul`` carries the ``nsz`` flag. numba's fast-math pass only flags float
    operations that carry none, and LLVM fuses a product into a sum only when both carry
    ``contract``: this product keeps its own rounding under ``fastmath={"contract"}``.
    ``nsz`` (signed zeros may be ignored) changes nothing here, where the sign of a zero
    product is never observed.
    """
    if not all(isinstance(t, types.Float) for t in (a, b)):
        return None

    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        fa = context.cast(builder, args[0], signature.args[0], types.float64)
        fb = context.cast(builder, args[1], signature.args[1], types.float64)
        return builder.fmul(fa, fb, flags=("nsz",))

    return types.float64(a, b), codegen


_SHIFTER = 6755399441055744.0  # 1.5 * 2**52: x + _SHIFTER - _SHIFTER rounds x to an integer
_SHIFTER_BITS = 0x4338000000000000  # its bits; bits(x + _SHIFTER) - _SHIFTER_BITS = round(x)
_SIGN_BIT = -0x8000000000000000  # int64 with only the sign bit set
_INF = float("inf")
_NAN = float("nan")


@njit(**_INLINE)
def _copysign(a: float, b: float) -> float:
    """``|a|`` with the sign bit of ``b`` (bit operations, ``-0.0`` kept)."""
    return _as_float((_as_int(a) & ~_SIGN_BIT) | (_as_int(b) & _SIGN_BIT))


@njit(**_INLINE)
def _int_to_float(k: int) -> float:
    """``float(k)`` for ``|k| < 2**51`` through the shifter (no ``sitofp``, which needs
    AVX-512DQ to vectorise)."""
    return _as_float(k + _SHIFTER_BITS) - _SHIFTER


# --------------------------------------------------------------------------- sin, cos

_TWO_OVER_PI = 0.6366197723675814
# pi/2 = _PIO2_1 + _PIO2_2 + _PIO2_3 + O(5.6e-50), each the nearest double to the remainder
_PIO2_1 = 1.5707963267948966
_PIO2_2 = 6.123233995736766e-17
_PIO2_3 = -1.4973849048591698e-33
# beyond this the shifter cannot round x*2/pi (it needs |x*2/pi| < 2**51)
TRIG_MAX = 2.0**50
_TINY_SIN = 2.0**-26  # below it sin(x) rounds to x

# |r| <= 0.85 covers the reduction up to TRIG_MAX: there 2/pi rounded to a double (relative
# error 2**-54) may pick the neighbouring j, |r| <= pi/4 + 0.063
# (sin(r) - r) / r**3 = S(z), z = r*r in [0, 0.85**2]; fit error 3.5e-20
_S0 = -0.16666666666666666
_S1 = 0.008333333333333328
_S2 = -0.00019841269841259324
_S3 = 2.75573192152495e-06
_S4 = -2.50521049292758e-08
_S5 = 1.6058341746541558e-10
_S6 = -7.576387247689272e-13
# (cos(r) - 1 + z/2) / z**2 = C(z), same interval; fit error 3.3e-18
_C0 = 0.041666666666666664
_C1 = -0.0013888888888885604
_C2 = 2.480158729628221e-05
_C3 = -2.755731609000413e-07
_C4 = 2.0875919871085387e-09
_C5 = -1.1367607736080766e-11


@njit(**_INLINE)
def _sincos(x: float) -> tuple[float, float]:
    """``(sin x, cos x)`` from one reduction; see :func:`sincos`."""
    finite = abs(x) <= TRIG_MAX  # False for NaN, infinities and beyond the reduction
    xr = x if finite else 0.0
    # j = round(x * 2/pi); r = x - j pi/2 as rh + rl (Cody-Waite in three parts)
    t = _fma(xr, _TWO_OVER_PI, _SHIFTER)
    j = _as_int(t) - _SHIFTER_BITS
    jf = t - _SHIFTER
    r1 = _fma(-jf, _PIO2_1, xr)  # exact: x and j*_PIO2_1 are multiples of 2**-53 near x
    p = _mul(jf, _PIO2_2)
    pe = _fma(jf, _PIO2_2, -p)  # p + pe = j*_PIO2_2 exactly
    rh = r1 - p
    bb = rh - r1
    re = (r1 - (rh - bb)) + (-p - bb)  # rh + re = r1 - p exactly (two-sum)
    rl = re - _fma(jf, _PIO2_3, pe)
    z = _mul(rh, rh)
    # sin(rh + rl) = rh + rh z S(z) + rl (1 - z/2 + ...); |rl| < 2**-52 |rh|, so rl suffices
    ps = _fma(_fma(_fma(_fma(_fma(_fma(_S6, z, _S5), z, _S4), z, _S3), z, _S2), z, _S1), z, _S0)
    s = rh + _fma(_mul(rh, z), ps, rl)
    # cos(rh + rl) = 1 - z/2 + z**2 C(z) - rh rl, with 1 - z/2 carried to double-double
    hz = 0.5 * z
    ze = _fma(rh, rh, -z)  # z + ze = rh**2 exactly
    w = 1.0 - hz
    wc = (1.0 - w) - hz  # w + wc = 1 - hz exactly (hz <= 0.37)
    pc = _fma(_fma(_fma(_fma(_fma(_C5, z, _C4), z, _C3), z, _C2), z, _C1), z, _C0)
    c = w + _fma(_mul(z, z), pc, wc - _fma(rh, rl, 0.5 * ze))
    # quadrant j mod 4: sin x = s, c, -s, -c and cos x = c, -s, -c, s
    q = j & 3
    odd = (q & 1) != 0
    sv = c if odd else s
    cv = s if odd else c
    sv = -sv if (q & 2) != 0 else sv
    cv = -cv if ((q + 1) & 2) != 0 else cv
    sv = x if abs(x) < _TINY_SIN else sv  # exact for tiny x, keeps -0.0 and subnormals
    nonfinite = not (abs(x) < _INF)
    sv = _NAN if nonfinite else sv
    cv = _NAN if nonfinite else cv
    return sv, cv


@njit(**_INLINE)
def sincos(x: float) -> tuple[float, float]:
    """``(sin x, cos x)`` from one range reduction, vectorisable in a lane loop.

    Method: ``j = round(2x/π)`` (the ``1.5·2**52`` shifter), ``r = x - jπ/2`` carried as a
    double-double ``r_h + r_l`` (Cody-Waite with ``π/2`` in three doubles, the first product
    exact in a fused multiply-add, the second split exactly), then on ``|r| <= π/4``

    .. math::

        \\sin r = r + r^3 S(r^2) + r_l, \\qquad
        \\cos r = 1 - \\tfrac{r^2}{2} + r^4 C(r^2) - r_h r_l,

    ``S`` and ``C`` polynomials of degree 6 and 5 fitted on ``|r| <= 0.85``, ``1 - r^2/2`` summed
    exactly; the quadrant ``j mod 4`` selects and signs the two.

    Range and accuracy: at most 1 ulp from the correctly rounded value for
    ``|x| <= 2**20`` (the angles of the loop are bounded by 1e3 rad); the reduction stays
    exact up to ``|x| <=`` :data:`TRIG_MAX` ``= 2**50`` (errors measured at most 1 ulp there
    too, on samples). Beyond ``2**50`` (finite) the result is ``(0.0, 1.0)``: finite and
    bounded, but not the sine and cosine of ``x``. NaN and ``±inf`` give NaN. ``sin(±0) = ±0``
    and ``sin x = x`` for ``|x| < 2**-26``.
    """
    return _sincos(x)


@njit(**_INLINE)
def sin(x: float) -> float:
    """``sin x``, vectorisable in a lane loop; :func:`sincos` states the method.

    At most 1 ulp for ``|x| <= 2**20`` (exact reduction up to ``2**50``; ``0.0`` beyond);
    NaN and ``±inf`` give NaN; ``sin(±0) = ±0``.
    """
    return _sincos(x)[0]


@njit(**_INLINE)
def cos(x: float) -> float:
    """``cos x``, vectorisable in a lane loop; :func:`sincos` states the method.

    At most 1 ulp for ``|x| <= 2**20`` (exact reduction up to ``2**50``; ``1.0`` beyond);
    NaN and ``±inf`` give NaN.
    """
    return _sincos(x)[1]


# --------------------------------------------------------------------------- exp

_INV_LN2 = 1.4426950408889634
# ln 2 = _LN2_A + _LN2_B + O(5.7e-34)
_LN2_A = 0.6931471805599453
_LN2_B = 2.3190468138462996e-17
_EXP_HI = 710.0  # exp overflows beyond 709.78; clamping keeps 2**k representable in halves
_EXP_LO = -750.0  # exp underflows to 0 below -745.13

# (exp(r) - 1 - r) / r**2 = E(r), r in [-1.002 ln2/2, 1.002 ln2/2]; fit error 1.4e-18
_E0 = 0.5
_E1 = 0.1666666666666667
_E2 = 0.04166666666666667
_E3 = 0.008333333333326025
_E4 = 0.001388888888888367
_E5 = 0.00019841269875205077
_E6 = 2.4801587325822283e-05
_E7 = 2.75572549134867e-06
_E8 = 2.7557273295539724e-07
_E9 = 2.5105419192016337e-08
_E10 = 2.091483135138041e-09


@njit(**_INLINE)
def _exp_reduce(xh: float, xl: float) -> tuple[int, float, float]:
    """``exp(xh + xl) = 2**k (1 + y)``, ``y = yh + yt``: returns ``(k, yh, yt)``.

    ``k = round(xh/ln2)`` on ``xh`` clamped to ``[-750, 710]`` (NaN kept), ``r = xh + xl -
    k ln2`` as a double-double ``rh + rl`` (first product exact in a fused multiply-add,
    ``|xl|`` small), ``y = r + r^2 E(r)`` with ``yh = rh`` and the small rest ``yt``.
    """
    xc = _EXP_HI if xh > _EXP_HI else xh
    xc = _EXP_LO if xc < _EXP_LO else xc
    t = _fma(xc, _INV_LN2, _SHIFTER)
    k = _as_int(t) - _SHIFTER_BITS
    kf = t - _SHIFTER
    r1 = _fma(-kf, _LN2_A, xc)  # exact (multiples of 2**-54, |r1| < 0.35)
    d = xl - _mul(kf, _LN2_B)  # both small: |d| < 3e-13
    rh = r1 + d
    bb = rh - r1
    rl = (r1 - (rh - bb)) + (d - bb)  # rh + rl = r1 + d exactly (two-sum)
    e = _fma(_E10, rh, _E9)
    e = _fma(e, rh, _E8)
    e = _fma(e, rh, _E7)
    e = _fma(e, rh, _E6)
    e = _fma(e, rh, _E5)
    e = _fma(e, rh, _E4)
    e = _fma(e, rh, _E3)
    e = _fma(e, rh, _E2)
    e = _fma(e, rh, _E1)
    e = _fma(e, rh, _E0)
    return k, rh, _fma(_mul(rh, rh), e, rl)


@njit(**_INLINE)
def _exp_dd(xh: float, xl: float) -> float:
    """``exp(xh + xl)``; ``2**k`` applied in two halves so that subnormal results round once
    and ``k = 1024`` overflows cleanly."""
    k, yh, yt = _exp_reduce(xh, xl)
    k1 = k >> 1
    k2 = k - k1
    s1 = _as_float((k1 + 1023) << 52)
    s2 = _as_float((k2 + 1023) << 52)
    return ((1.0 + (yh + yt)) * s1) * s2


@njit(**_INLINE)
def exp(x: float) -> float:
    """``e**x``, vectorisable in a lane loop.

    Method: ``x = k ln 2 + r``, ``k = round(x / ln 2)``, ``|r| <= ln2/2`` (``ln 2`` in two
    doubles, ``r`` double-double), then

    .. math:: e^x = 2^k \\left(1 + r + r^2 E(r)\\right),

    ``E`` a polynomial of degree 10 fitted on ``[-ln2/2, ln2/2]``; ``2^k`` built from bits.

    Range and accuracy: at most 1 ulp for every float64 ``x`` (subnormal results: at most 1
    ulp of the smallest subnormal). ``x > 709.78`` gives ``inf``, ``x < -745.13`` gives
    ``0.0``, ``exp(-inf) = 0``, ``exp(inf) = inf``, NaN gives NaN.
    """
    return _exp_dd(x, 0.0)


@njit(**_INLINE)
def _expm1_small(x: float) -> tuple[float, float]:
    """``e**x - 1`` for ``0 <= x <= 40`` (NaN kept) as a double-double ``(uh, ul)``, without
    cancellation for small ``x``: ``2^k (1 + y) - 1 = (2^k - 1) + 2^k y_h + 2^k y_t``, the
    first sum error-free (``2^k - 1`` and ``2^k y_h`` are exact), ``ul`` the rest."""
    k, yh, yt = _exp_reduce(x, 0.0)
    s = _as_float((k + 1023) << 52)
    sm1 = s - 1.0  # exact for k <= 53
    p = _mul(s, yh)  # exact
    t = sm1 + p
    bb = t - sm1
    te = (sm1 - (t - bb)) + (p - bb)  # t + te = sm1 + p exactly
    w = _fma(s, yt, te)  # |w| < |t|
    uh = t + w
    return uh, w - (uh - t)  # uh + ul = t + w exactly (fast two-sum)


# --------------------------------------------------------------------------- log

# ln 2 = _LN2_HI + _LN2_LO + O(2e-31), _LN2_HI with 41 significant bits: k*_LN2_HI is
# exact for |k| < 2**12 (every binary exponent of a float64, subnormals included)
_LN2_HI = 0.6931471805601177
_LN2_LO = -1.7239444525614835e-13
_SQRT_HALF_BITS = 0x3FE6A09E667F3BCD  # bits of sqrt(1/2)
_MANT_MASK = 0x000FFFFFFFFFFFFF
_MIN_NORMAL = 2.2250738585072014e-308
_TWO54 = 18014398509481984.0

# 2 atanh(s) = 2s + s z Q(z), z = s*s in [0, 1.001 ((sqrt2-1)/(sqrt2+1))**2]; error 2.1e-18
_Q0 = 0.6666666666666666
_Q1 = 0.40000000000000885
_Q2 = 0.28571428570799784
_Q3 = 0.22222222392581045
_Q4 = 0.18181795547521137
_Q5 = 0.15386244737621665
_Q6 = 0.13268638369266825
_Q7 = 0.13088034850927555


@njit(**_INLINE)
def _log_dd(x: float) -> tuple[float, float]:
    """``ln x`` as a double-double ``(hi, lo)`` for finite ``x > 0``; see :func:`log`.

    ``|hi + lo - ln x|`` is below about ``2**-62 |ln x|``: the exponent term is exact, the
    mantissa term carries ``f - f^2/2`` exactly and rounds only the small remainder.
    """
    sub = x < _MIN_NORMAL
    xs = x * _TWO54 if sub else x
    # x = 2**k m with m in [sqrt(1/2), sqrt(2))
    u = _as_int(xs) + (0x3FF0000000000000 - _SQRT_HALF_BITS)
    k = (u >> 52) - 1023
    k = k - 54 if sub else k
    m = _as_float((u & _MANT_MASK) + _SQRT_HALF_BITS)
    kf = _int_to_float(k)
    f = m - 1.0  # exact (Sterbenz)
    # ln(1+f) = 2 atanh(s), s = f/(2+f):  = f - f^2/2 + s (f^2/2 + R),  R = z Q(z)
    s = f / (2.0 + f)
    z = _mul(s, s)
    qz = _fma(_Q7, z, _Q6)
    qz = _fma(qz, z, _Q5)
    qz = _fma(qz, z, _Q4)
    qz = _fma(qz, z, _Q3)
    qz = _fma(qz, z, _Q2)
    qz = _fma(qz, z, _Q1)
    qz = _fma(qz, z, _Q0)
    ff = _mul(f, f)
    hfsq = 0.5 * ff
    hfsq_lo = 0.5 * _fma(f, f, -ff)  # hfsq + hfsq_lo = f^2/2 exactly
    rest = _fma(s, _fma(z, qz, hfsq), _fma(kf, _LN2_LO, -hfsq_lo))
    ah = f - hfsq
    al = (f - ah) - hfsq  # ah + al = f - hfsq exactly (|f| >= hfsq)
    t1 = _mul(kf, _LN2_HI)  # exact
    bh = t1 + ah
    bl = (t1 - bh) + ah  # bh + bl = t1 + ah exactly (|t1| >= |ah| or t1 = 0)
    lo = bl + (al + rest)
    hi = bh + lo
    return hi, lo - (hi - bh)  # renormalised: |lo| <= ulp(hi)/2


@njit(**_INLINE)
def log(x: float) -> float:
    """``ln x``, vectorisable in a lane loop.

    Method: ``x = 2^k m``, ``sqrt(1/2) <= m < sqrt(2)`` (from the bits; a subnormal ``x`` is
    first scaled by ``2**54``), ``f = m - 1``, ``s = f/(2+f)``:

    .. math::

        \\ln x = k \\ln 2 + 2\\,\\mathrm{atanh}\\, s
              = k \\ln 2 + f - \\tfrac{f^2}{2} + s\\left(\\tfrac{f^2}{2} + s^2 Q(s^2)\\right),

    ``Q`` a polynomial of degree 7 fitted on ``|s| <= 0.1716``; the large terms
    ``k ln 2``, ``f`` and ``f^2/2`` are summed without rounding (double-double).

    Range and accuracy: at most 1 ulp for every float64 ``x > 0``, subnormals included;
    ``log(1) = 0``, ``log(±0) = -inf``, ``log(x < 0) = NaN``, ``log(inf) = inf``, NaN gives
    NaN.
    """
    hi, lo = _log_dd(x)
    v = hi + lo
    v = -_INF if x == 0.0 else v
    v = _NAN if x < 0.0 else v
    v = _INF if x == _INF else v
    return x if x != x else v


# --------------------------------------------------------------------------- pow_abs, tanh


@njit(**_INLINE)
def pow_abs(x: float, g: float) -> float:
    """``|x|**g`` for ``g > 0``, with ``pow_abs(0, g) = 0``, vectorisable in a lane loop
    (the terminal surfaces' ``|e|^γ``).

    Method:

    .. math:: |x|^g = \\exp(g \\ln|x|),

    with ``ln|x|`` as a double-double (:func:`log`'s method without its final rounding),
    ``g ln|x|`` as a double-double (exact product in a fused multiply-add) and the low part
    fed into :func:`exp`'s reduced argument: the absolute error of ``g ln|x|`` (up to
    ``1.4e3``) would otherwise become the relative error of the result.

    Range and accuracy: at most 1 ulp for ``|x|`` in ``[1e-300, 1e3]`` and ``0 < g < 2``,
    subnormal results included (their ulp is ``2**-1074``). ``g`` must be positive (not
    checked: this is a kernel). ``|x| = inf`` gives ``inf``; NaN in ``x`` or ``g`` gives NaN;
    results beyond the float64 range overflow to ``inf`` or underflow to ``0``.
    """
    a = abs(x)
    hi, lo = _log_dd(a)
    yh = _mul(g, hi)
    yl = _fma(g, lo, _fma(g, hi, -yh))  # yh + yl = g (hi + lo) to about 2**-104
    v = _exp_dd(yh, yl)
    v = 0.0 if a == 0.0 else v
    v = _INF if a == _INF else v
    return x if x != x else v


_TANH_SAT = 20.0  # tanh(x) rounds to 1 for x > 19.06; clamping keeps expm1 finite
_TANH_SPLIT = 0.55  # below: tanh = u/(u+2) (no cancellation); above: 1 - 2/(u+2)


@njit(**_INLINE)
def tanh(x: float) -> float:
    """``tanh x``, vectorisable in a lane loop.

    Method: with ``a = min(|x|, 20)`` and ``u = e^{2a} - 1`` (an ``expm1``: for small ``a``
    it keeps ``u ≈ 2a`` to full relative precision, so ``tanh`` is accurate near 0),

    .. math::

        \\tanh a = \\frac{u}{u + 2} \\quad (a < 0.55), \\qquad
        \\tanh a = 1 - \\frac{2}{u + 2} \\quad (a \\ge 0.55),

    the quotient from one division, the denominator ``u + 2`` kept exact (double-double) and
    the quotient corrected once by its residual (fused multiply-add); the sign of ``x``
    copied onto the result (odd, ``tanh(-0) = -0``).

    Range and accuracy: at most 1 ulp for every float64 ``x``; ``|x| > 19.06`` gives ``±1``
    exactly, ``tanh(±inf) = ±1``, NaN gives NaN.
    """
    a = abs(x)
    a = _TANH_SAT if a > _TANH_SAT else a
    uh, ul = _expm1_small(a + a)
    small = a < _TANH_SPLIT
    # q = num / (u + 2), u = uh + ul, with the denominator double-double (dh + dl): one
    # division, then one correction by the residual num - q (dh + dl)
    dh = uh + 2.0
    bb = dh - uh
    dl = ((uh - (dh - bb)) + (2.0 - bb)) + ul  # dh + dl = u + 2 (two-sum)
    inv = 1.0 / dh
    num = uh if small else 2.0
    q = _mul(num, inv)
    rem = _fma(-q, dh, num) + ((ul if small else 0.0) - _mul(q, dl))
    q = _fma(rem, inv, q)
    t = q if small else 1.0 - q
    return _copysign(t, x)
