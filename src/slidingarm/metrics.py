r"""Performance metrics of a closed-loop run: tracking, convergence, effort and chattering.

Every metric is a pure function of sampled signals (docs/theory.md §6). Arrays are time-major and
batch-first: a signal has shape ``(..., T, n)`` — ``(T, n)`` for one run, ``(B, T, n)`` for a
batch — the time grid ``t`` has shape ``(T,)`` and is shared, and every metric returns one value
per joint, shape ``(..., n)``.

Conventions
-----------
- Errors follow the paper, :math:`e = q - q_d` (see :attr:`slidingarm.results.SimResult.e`).
- Integrals of the error use the trapezoid rule on the sample grid.
- The torque is a zero-order hold: ``tau[k]`` acts over :math:`[t_k, t_{k+1})` and the last
  row ``tau[T-1]`` is never applied. Torque metrics (effort, peak, chattering, spectrum) use the
  applied samples :math:`k = 0, \dots, T-2` only, so the effort integral is exact.
- Threshold times (reaching, settling) treat the signal as piecewise linear between samples and
  are :math:`+\infty` — never NaN — when the condition does not hold at the end of the run.

Default thresholds live in one place, the module constants :data:`DEFAULT_DELTA_S`,
:data:`DEFAULT_DELTA_E`, :data:`DEFAULT_WINDOW` and :data:`DEFAULT_CUTOFF_HZ`; their reasons are
given next to them.

References
----------
docs/theory.md §6 (definitions); paper ``paper/000_764c5ab0732d16dd.txt`` (MSE table, final errors).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from slidingarm._validate import is_real

if TYPE_CHECKING:
    import pandas as pd

    from slidingarm.results import BatchResult, SimResult

__all__ = [
    "DEFAULT_CUTOFF_HZ",
    "DEFAULT_DELTA_E",
    "DEFAULT_DELTA_S",
    "DEFAULT_LATE_FRACTION",
    "DEFAULT_WINDOW",
    "LATE_COLUMNS",
    "METRIC_COLUMNS",
    "alternation",
    "chattering",
    "control_effort",
    "final_error",
    "hf_power_share",
    "iae",
    "itae",
    "late_metrics",
    "late_start",
    "max_step",
    "metric_frame",
    "mse",
    "peak_torque",
    "reaching_time",
    "rms",
    "rmse",
    "settling_time",
    "steady_state_error",
    "summary",
    "terminal_gain",
]

FloatArray = NDArray[np.float64]

#: Reaching band :math:`\delta_s` (rad/s) on the sliding variable. Under sign switching with a
#: zero-order hold, :math:`s_{k+1} \approx s_k - k\,\Delta t\,\mathrm{sign}(s_k)`, so once on the
#: surface :math:`|s|` chatters in a band of width :math:`k\,\Delta t` (0.01 rad/s for
#: :math:`k = 20`, :math:`\Delta t = 5\cdot10^{-4}` s). Twice that band counts a run that has
#: reached the surface as reached, while it moves the reaching time earlier by only
#: :math:`\delta_s / k` (about 1 ms, two samples) against :math:`t_r = |s(0)|/k` of order 0.1 s.
DEFAULT_DELTA_S: float = 2e-2

#: Settling band :math:`\delta_e` (rad) on the tracking error: 1 mrad (0.057°), far above the
#: paper's final errors (1e-7 to 1e-6 rad) and the sign-switching ripple of :math:`e`
#: (:math:`\sim k\,\Delta t^2`), far below the initial errors (0.3 to 1.2 rad).
DEFAULT_DELTA_E: float = 1e-3

#: Steady-state window (s): the last 0.5 s of the run, as docs/theory.md §6 fixes.
DEFAULT_WINDOW: float = 0.5

#: Chattering cut-off (Hz) of :func:`hf_power_share`: 50 Hz is 300 times the reference's
#: :math:`1/(2\pi) \approx 0.16` Hz and well above the closed-loop bandwidth (gains of order
#: 10 rad/s, a few Hz), yet well below the 1 kHz Nyquist frequency of :math:`\Delta t = 5\cdot
#: 10^{-4}` s where sign switching puts its power.
DEFAULT_CUTOFF_HZ: float = 50.0

#: "After the transient" (:func:`late_start`): the last half of the run. The reaching phase and
#: the convergence on the surface end well before the second half of the paper's 4.5 s run.
DEFAULT_LATE_FRACTION: float = 0.5

#: Columns of :func:`summary`, after ``joint`` (and ``run`` for a batch), in order.
METRIC_COLUMNS: tuple[str, ...] = (
    "mse",
    "rmse",
    "iae",
    "itae",
    "reaching_time",
    "settling_time",
    "steady_state_error",
    "final_error",
    "control_effort",
    "peak_torque",
    "chattering",
    "hf_power_share",
)

#: Names of :func:`late_metrics`, in order.
LATE_COLUMNS: tuple[str, ...] = (
    "chattering_late",
    "max_step_late",
    "alternation_late",
    "terminal_gain_late",
    "s_rms_late",
)

#: Relative size below which a detrended torque counts as constant in :func:`hf_power_share`.
_FLAT_RTOL = 1e-12
#: Relative tolerance on the sample spacing for the FFT (uniform grid required).
_UNIFORM_RTOL = 1e-6


# ---------------------------------------------------------------------------- validation
def _time(t: ArrayLike) -> FloatArray:
    """``t`` as a finite, strictly increasing float array of shape (T,), T >= 2."""
    arr = np.asarray(t, dtype=np.float64)
    if arr.ndim != 1:
        raise ValueError(f"t must have shape (T,), got shape {arr.shape}")
    if arr.shape[0] < 2:
        raise ValueError(f"t must have at least 2 samples, got {arr.shape[0]}")
    if not np.all(np.isfinite(arr)):
        raise ValueError("t contains non-finite values")
    steps = np.diff(arr)
    if not np.all(steps > 0.0):
        k = int(np.argmax(steps <= 0.0))
        raise ValueError(
            f"t must be strictly increasing, but t[{k + 1}] = {float(arr[k + 1])!r} "
            f"<= t[{k}] = {float(arr[k])!r}"
        )
    return arr


def _signal(name: str, x: ArrayLike, t: FloatArray | None = None) -> FloatArray:
    """``x`` as a finite float array of shape (..., T, n) whose T matches ``t``."""
    arr = np.asarray(x, dtype=np.float64)
    if arr.ndim < 2:
        raise ValueError(f"{name} must have shape (..., T, n), got shape {arr.shape}")
    if arr.shape[-2] == 0:
        raise ValueError(f"{name} has no samples")
    if t is not None and arr.shape[-2] != t.shape[0]:
        raise ValueError(
            f"{name} has {arr.shape[-2]} samples on its time axis (-2) but t has {t.shape[0]}"
        )
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} contains non-finite values")
    return arr


def _positive(name: str, value: float) -> float:
    """``value`` as a float, checked to be a real number (not a bool), positive and finite."""
    if not is_real(value):
        raise ValueError(f"{name} must be positive and finite, got {value!r}")
    v = float(value)
    if not (math.isfinite(v) and v > 0.0):
        raise ValueError(f"{name} must be positive and finite, got {v!r}")
    return v


def _trapezoid(y: FloatArray, t: FloatArray) -> FloatArray:
    r""":math:`\sum_k \tfrac12 (y_k + y_{k+1})(t_{k+1} - t_k)` along axis -2."""
    dt = np.diff(t)[:, None]
    return np.asarray(0.5 * np.sum((y[..., 1:, :] + y[..., :-1, :]) * dt, axis=-2))


def _applied(name: str, tau: ArrayLike, t: FloatArray) -> FloatArray:
    """Validated torque without its last, never-applied row: shape (..., T-1, n)."""
    return _signal(name, tau, t)[..., :-1, :]


# ---------------------------------------------------------------------------- tracking
def mse(e: ArrayLike) -> FloatArray:
    r"""Mean squared tracking error per joint.

    .. math:: \mathrm{MSE}_i = \frac{1}{T} \sum_{k=0}^{T-1} e_{k,i}^2

    over every sample of the run (the paper's table does not say which window; docs/theory.md §6 fixes the
    whole run).

    Parameters
    ----------
    e : array_like, shape (..., T, n)
        Tracking error :math:`e = q - q_d` (rad).

    Returns
    -------
    ndarray, shape (..., n)
        :math:`\mathrm{rad}^2`.
    """
    arr = _signal("e", e)
    return np.asarray(np.mean(arr * arr, axis=-2))


def rmse(e: ArrayLike) -> FloatArray:
    r"""Root mean squared tracking error per joint, :math:`\sqrt{\mathrm{MSE}_i}`.

    .. math:: \mathrm{RMSE}_i = \Big(\frac{1}{T} \sum_{k=0}^{T-1} e_{k,i}^2\Big)^{1/2}

    Parameters
    ----------
    e : array_like, shape (..., T, n)
        Tracking error (rad).

    Returns
    -------
    ndarray, shape (..., n)
        rad.
    """
    return np.sqrt(mse(e))


def iae(t: ArrayLike, e: ArrayLike) -> FloatArray:
    r"""Integral of the absolute error per joint, trapezoid rule.

    .. math:: \mathrm{IAE}_i = \int_{t_0}^{t_{T-1}} |e_i|\,dt
              \approx \sum_{k=0}^{T-2} \tfrac12 \big(|e_{k,i}| + |e_{k+1,i}|\big)(t_{k+1} - t_k)

    Parameters
    ----------
    t : array_like, shape (T,)
        Strictly increasing sample times (s).
    e : array_like, shape (..., T, n)
        Tracking error (rad).

    Returns
    -------
    ndarray, shape (..., n)
        rad·s.
    """
    tt = _time(t)
    return _trapezoid(np.abs(_signal("e", e, tt)), tt)


def itae(t: ArrayLike, e: ArrayLike) -> FloatArray:
    r"""Integral of time-weighted absolute error per joint, trapezoid rule.

    Time is measured from the start of the run, so a run that does not start at 0 is weighted as
    one that does:

    .. math:: \mathrm{ITAE}_i = \int_{t_0}^{t_{T-1}} (t - t_0)\,|e_i(t)|\,dt

    with the integrand sampled at :math:`t_k` and integrated by the trapezoid rule.

    Parameters
    ----------
    t : array_like, shape (T,)
        Strictly increasing sample times (s).
    e : array_like, shape (..., T, n)
        Tracking error (rad).

    Returns
    -------
    ndarray, shape (..., n)
        rad·s².
    """
    tt = _time(t)
    weighted = (tt - tt[0])[:, None] * np.abs(_signal("e", e, tt))
    return _trapezoid(weighted, tt)


# ---------------------------------------------------------------------------- convergence
def _entry_time(t: FloatArray, x: FloatArray, delta: float) -> FloatArray:
    r"""First time after which :math:`|x| \le \delta` for good, ``x`` piecewise linear.

    Let :math:`k` be the last sample with :math:`|x_k| > \delta`. Then :math:`|x_{k+1}| \le
    \delta` and, on the segment between them, :math:`x` reaches :math:`\sigma\delta`
    (:math:`\sigma = \mathrm{sign}\,x_k`) at

    .. math:: t^* = t_k + \frac{x_k - \sigma\delta}{x_k - x_{k+1}}\,(t_{k+1} - t_k),

    after which the linear interpolant stays in the band. No such :math:`k` gives :math:`t_0`;
    :math:`k = T - 1` gives :math:`+\infty`.
    """
    T = t.shape[0]
    outside = np.abs(x) > delta  # (..., T, n)
    any_out = np.any(outside, axis=-2)
    # Index of the last sample outside the band (0 where none; masked below).
    last = T - 1 - np.argmax(outside[..., ::-1, :], axis=-2)
    nxt = np.minimum(last + 1, T - 1)
    xk = np.take_along_axis(x, last[..., None, :], axis=-2)[..., 0, :]
    xk1 = np.take_along_axis(x, nxt[..., None, :], axis=-2)[..., 0, :]
    level = np.sign(xk) * delta
    denom = xk - xk1
    # On the valid branch |x_k| > delta >= |x_{k+1}|, so denom has the sign of x_k and is nonzero.
    safe = np.where(denom == 0.0, 1.0, denom)
    frac = np.clip((xk - level) / safe, 0.0, 1.0)
    t_cross = t[last] + frac * (t[nxt] - t[last])
    out = np.where(any_out, t_cross, t[0])
    out = np.where(any_out & (last == T - 1), np.inf, out)
    return np.asarray(out, dtype=np.float64)


def reaching_time(t: ArrayLike, s: ArrayLike, *, delta_s: float = DEFAULT_DELTA_S) -> FloatArray:
    r"""Time at which each sliding variable enters the band :math:`|s_i| \le \delta_s` for good.

    .. math:: t_{r,i} = \inf\{\tau \ge t_0 : |s_i(t)| \le \delta_s
              \ \ \forall t \in [\tau, t_{T-1}]\}

    with :math:`s_i` linear between samples, so the time is resolved within a sample. With an
    exact model and sign switching, :math:`t_{r,i} = (|s_i(0)| - \delta_s)/k_i` (docs/theory.md §3).

    Parameters
    ----------
    t : array_like, shape (T,)
        Strictly increasing sample times (s).
    s : array_like, shape (..., T, n)
        Sliding variable (rad/s).
    delta_s : float, default :data:`DEFAULT_DELTA_S` = 0.02 rad/s
        Half-width of the band; twice the sign-switching chattering band :math:`k\,\Delta t`
        for :math:`k = 20`, :math:`\Delta t = 5\cdot 10^{-4}` s. Must be positive.

    Returns
    -------
    ndarray, shape (..., n)
        Seconds. :math:`t_0` when the band holds from the start; :math:`+\infty` (never NaN)
        when :math:`|s_i| > \delta_s` at the last sample.

    Raises
    ------
    ValueError
        On a bad ``t``, a shape mismatch, non-finite ``s`` or a non-positive ``delta_s``.
    """
    d = _positive("delta_s", delta_s)
    tt = _time(t)
    return _entry_time(tt, _signal("s", s, tt), d)


def settling_time(t: ArrayLike, e: ArrayLike, *, delta_e: float = DEFAULT_DELTA_E) -> FloatArray:
    r"""Time at which each tracking error enters the band :math:`|e_i| \le \delta_e` for good.

    .. math:: t_{s,i} = \inf\{\tau \ge t_0 : |e_i(t)| \le \delta_e
              \ \ \forall t \in [\tau, t_{T-1}]\}

    with :math:`e_i` linear between samples, so the time is resolved within a sample.

    Parameters
    ----------
    t : array_like, shape (T,)
        Strictly increasing sample times (s).
    e : array_like, shape (..., T, n)
        Tracking error (rad).
    delta_e : float, default :data:`DEFAULT_DELTA_E` = 1e-3 rad
        Half-width of the band (1 mrad). Must be positive.

    Returns
    -------
    ndarray, shape (..., n)
        Seconds. :math:`t_0` when the band holds from the start; :math:`+\infty` (never NaN)
        when :math:`|e_i| > \delta_e` at the last sample.

    Raises
    ------
    ValueError
        On a bad ``t``, a shape mismatch, non-finite ``e`` or a non-positive ``delta_e``.
    """
    d = _positive("delta_e", delta_e)
    tt = _time(t)
    return _entry_time(tt, _signal("e", e, tt), d)


def steady_state_error(t: ArrayLike, e: ArrayLike, *, window: float = DEFAULT_WINDOW) -> FloatArray:
    r"""Largest absolute tracking error over the last ``window`` seconds.

    .. math:: e_{ss,i} = \max_{k\,:\,t_k \ge t_{T-1} - w} |e_{k,i}|

    A window longer than the run takes the whole run. The bound :math:`t_{T-1} - w` is taken
    with a tolerance of :math:`10^{-9}` of the run's duration, so a sample that lies exactly on
    it up to round-off is included.

    Parameters
    ----------
    t : array_like, shape (T,)
        Strictly increasing sample times (s).
    e : array_like, shape (..., T, n)
        Tracking error (rad).
    window : float, default :data:`DEFAULT_WINDOW` = 0.5 s
        Length :math:`w` of the final window (docs/theory.md §6). Must be positive.

    Returns
    -------
    ndarray, shape (..., n)
        rad.
    """
    w = _positive("window", window)
    tt = _time(t)
    arr = _signal("e", e, tt)
    tol = 1e-9 * (tt[-1] - tt[0])
    start = int(np.searchsorted(tt, tt[-1] - w - tol, side="left"))
    return np.asarray(np.max(np.abs(arr[..., start:, :]), axis=-2))


def final_error(e: ArrayLike) -> FloatArray:
    r"""Signed tracking error at the last sample, :math:`e_i(t_{T-1})`.

    .. math:: e_{f,i} = e_{T-1,i}

    Parameters
    ----------
    e : array_like, shape (..., T, n)
        Tracking error (rad).

    Returns
    -------
    ndarray, shape (..., n)
        rad (the paper reports magnitudes of 1e-7 to 1e-6).
    """
    return np.array(_signal("e", e)[..., -1, :], dtype=np.float64)


# ---------------------------------------------------------------------------- effort
def control_effort(t: ArrayLike, tau: ArrayLike) -> FloatArray:
    r"""Integral of the squared torque, exact for the zero-order hold.

    .. math:: E_i = \int_{t_0}^{t_{T-1}} \tau_i^2\,dt = \sum_{k=0}^{T-2} \tau_{k,i}^2\,(t_{k+1} - t_k)

    (the last row, never applied, does not count).

    Parameters
    ----------
    t : array_like, shape (T,)
        Strictly increasing sample times (s).
    tau : array_like, shape (..., T, n)
        Torque, ``tau[k]`` held over :math:`[t_k, t_{k+1})` (N m).

    Returns
    -------
    ndarray, shape (..., n)
        N²m²s.
    """
    tt = _time(t)
    applied = _applied("tau", tau, tt)
    return np.asarray(np.sum(applied * applied * np.diff(tt)[:, None], axis=-2))


def peak_torque(tau: ArrayLike) -> FloatArray:
    r"""Largest applied torque magnitude per joint.

    .. math:: \tau_{\max,i} = \max_{0 \le k \le T-2} |\tau_{k,i}|

    Parameters
    ----------
    tau : array_like, shape (..., T, n)
        Torque, ``T >= 2`` (the last row is never applied and does not count) (N m).

    Returns
    -------
    ndarray, shape (..., n)
        N m.
    """
    arr = _signal("tau", tau)
    if arr.shape[-2] < 2:
        raise ValueError(f"tau must have at least 2 samples, got {arr.shape[-2]}")
    return np.asarray(np.max(np.abs(arr[..., :-1, :]), axis=-2))


def chattering(t: ArrayLike, tau: ArrayLike) -> FloatArray:
    r"""Total variation of the applied torque per second.

    .. math:: \mathrm{TV}_i = \frac{1}{t_{T-1} - t_0} \sum_{k=0}^{T-3} |\tau_{k+1,i} - \tau_{k,i}|

    — the jumps of the held torque inside :math:`(t_0, t_{T-1})`, over the span it was applied.
    For :math:`\tau = A\sin(2\pi f t)` it is :math:`4Af`; sign switching that flips
    :math:`\pm u` every sample gives about :math:`2u/\Delta t`.

    Parameters
    ----------
    t : array_like, shape (T,)
        Strictly increasing sample times (s).
    tau : array_like, shape (..., T, n)
        Torque (N m); the last row, never applied, does not count.

    Returns
    -------
    ndarray, shape (..., n)
        N m/s.
    """
    tt = _time(t)
    applied = _applied("tau", tau, tt)
    tv = np.sum(np.abs(np.diff(applied, axis=-2)), axis=-2)
    return np.asarray(tv / (tt[-1] - tt[0]))


def hf_power_share(
    t: ArrayLike, tau: ArrayLike, *, cutoff_hz: float = DEFAULT_CUTOFF_HZ
) -> FloatArray:
    r"""Share of the applied torque's fluctuation power above a cut-off frequency.

    The applied samples :math:`\tau_k`, :math:`k = 0..N-1` (:math:`N = T-1`) on a uniform grid
    of step :math:`\Delta t` are detrended by their least-squares line
    :math:`\tilde\tau_k = \tau_k - (a + b\,t_k)` (a straight trend — the slow reference and the
    transient — would otherwise leak into every frequency through the jump of the periodic
    extension), then with :math:`X_j = \mathrm{rfft}(\tilde\tau)_j` at
    :math:`f_j = j/(N\Delta t)` and the one-sided weights :math:`w_j = 2` except
    :math:`w_0 = 1` and, for even :math:`N`, :math:`w_{N/2} = 1`,

    .. math:: \rho_i = \frac{\sum_{j : f_j > f_c} w_j |X_{j,i}|^2}{\sum_j w_j |X_{j,i}|^2}
              \in [0, 1].

    By Parseval the denominator is :math:`N \sum_k \tilde\tau_k^2`. For a sum of sines on whole
    periods :math:`\rho` is the power fraction :math:`\sum_{f > f_c} A^2 / \sum A^2`, up to the
    small leakage of the detrending line.

    Parameters
    ----------
    t : array_like, shape (T,)
        Uniformly spaced sample times (s), spacing equal to within a relative 1e-6.
    tau : array_like, shape (..., T, n)
        Torque (N m); the last row, never applied, does not count.
    cutoff_hz : float, default :data:`DEFAULT_CUTOFF_HZ` = 50 Hz
        :math:`f_c`; must be positive and below the Nyquist frequency :math:`1/(2\Delta t)`.
        50 Hz is far above the reference (0.16 Hz) and the closed-loop bandwidth and far below
        the 1 kHz Nyquist frequency at :math:`\Delta t = 5\cdot10^{-4}` s.

    Returns
    -------
    ndarray, shape (..., n)
        Dimensionless share. 0 (never NaN) for a signal with no fluctuation: one whose
        detrended RMS is at most :math:`10^{-12}` of its peak magnitude (a constant or a straight
        line, up to round-off).
    """
    fc = _positive("cutoff_hz", cutoff_hz)
    tt = _time(t)
    applied = _applied("tau", tau, tt)
    ta = tt[:-1]
    n_applied = ta.shape[0]
    steps = np.diff(tt)
    dt = float(np.mean(steps))
    if np.max(np.abs(steps - dt)) > _UNIFORM_RTOL * dt:
        raise ValueError("t must be uniformly spaced for hf_power_share")
    nyquist = 0.5 / dt
    if fc >= nyquist:
        raise ValueError(
            f"cutoff_hz must be below the Nyquist frequency 1/(2 dt) = {nyquist:g} Hz, got {fc:g}"
        )
    if n_applied < 2:
        return np.zeros(applied.shape[:-2] + applied.shape[-1:], dtype=np.float64)

    # Least-squares line per series: tau ~ mean + b (t - t_mean).
    tc = (ta - np.mean(ta))[:, None]
    mean = np.mean(applied, axis=-2, keepdims=True)
    slope = np.sum(tc * (applied - mean), axis=-2, keepdims=True) / np.sum(tc * tc)
    resid = applied - mean - slope * tc

    spectrum = np.fft.rfft(resid, axis=-2)
    power = spectrum.real**2 + spectrum.imag**2
    weights = np.full(power.shape[-2], 2.0)
    weights[0] = 1.0
    if n_applied % 2 == 0:
        weights[-1] = 1.0
    freqs = np.fft.rfftfreq(n_applied, d=dt)
    wp = power * weights[:, None]
    total = np.sum(wp, axis=-2)
    high = np.sum(wp[..., freqs > fc, :], axis=-2)

    rms = np.sqrt(np.mean(resid * resid, axis=-2))
    scale = np.max(np.abs(applied), axis=-2)
    flat = rms <= _FLAT_RTOL * scale
    share = np.where(flat, 0.0, high / np.where(flat, 1.0, total))
    return np.asarray(np.clip(share, 0.0, 1.0), dtype=np.float64)


# ---------------------------------------------------------------------------- windows
def late_start(t: ArrayLike, *, fraction: float = DEFAULT_LATE_FRACTION) -> int:
    r"""First sample of the last ``fraction`` of a run ("after the transient").

    .. math:: k_0 = \min\big(\min\{k : t_k \ge t_{T-1} - f\,(t_{T-1} - t_0) - 10^{-9}(t_{T-1} - t_0)\},
              \; T - 3\big)

    The small tolerance keeps a window boundary that falls on a sample, up to rounding, inside
    the window; the cap leaves at least two applied torque steps.

    Parameters
    ----------
    t : array_like, shape (T,)
        Strictly increasing sample times (s), :math:`T \ge 3`.
    fraction : float, default :data:`DEFAULT_LATE_FRACTION` = 0.5
        :math:`f \in (0, 1]`.

    Returns
    -------
    int
        :math:`k_0`.
    """
    f = _fraction(fraction)
    tt = _time(t)
    if tt.shape[0] < 3:
        raise ValueError(f"t must have at least 3 samples for a window, got {tt.shape[0]}")
    tol = 1e-9 * (tt[-1] - tt[0])
    k0 = int(np.searchsorted(tt, tt[-1] - f * (tt[-1] - tt[0]) - tol, side="left"))
    return min(k0, tt.shape[0] - 3)


def _fraction(fraction: float) -> float:
    if not is_real(fraction) or not 0.0 < fraction <= 1.0:
        raise ValueError(f"fraction must be in (0, 1], got {fraction!r}")
    return float(fraction)


def _steps(tau: ArrayLike) -> FloatArray:
    """Steps :math:`\\Delta_k = \\tau_{k+1} - \\tau_k` of the applied torque, (..., T-2, n)."""
    arr = _signal("tau", tau)
    return np.diff(arr[..., :-1, :], axis=-2)


def max_step(tau: ArrayLike) -> FloatArray:
    r"""Largest single step of the applied torque.

    .. math:: \max_{0 \le k \le T-3} |\tau_{k+1,i} - \tau_{k,i}|

    (the last row, never applied, does not count).

    Parameters
    ----------
    tau : array_like, shape (..., T, n)
        Torque (N m), :math:`T \ge 3`.

    Returns
    -------
    ndarray, shape (..., n)
        N m.
    """
    steps = _steps(tau)
    if steps.shape[-2] == 0:
        raise ValueError("tau must have at least 3 samples for a step")
    return np.asarray(np.max(np.abs(steps), axis=-2))


def alternation(tau: ArrayLike) -> FloatArray:
    r"""Share of consecutive steps of the applied torque that reverse.

    With :math:`\Delta_k = \tau_{k+1} - \tau_k`, :math:`0 \le k \le T-3`,

    .. math:: a_i = \frac{\#\{k \ge 1 : \Delta_{k,i}\,\Delta_{k-1,i} < 0\}}{T - 3}

    — 1 for a torque that flips every sample, about 0 for a smooth torque, 2/3 for white noise;
    0 when there are fewer than two steps.

    Parameters
    ----------
    tau : array_like, shape (..., T, n)
        Torque (N m).

    Returns
    -------
    ndarray, shape (..., n)
        Dimensionless, in [0, 1].
    """
    steps = _steps(tau)
    reversing = steps[..., 1:, :] * steps[..., :-1, :] < 0
    if reversing.shape[-2] == 0:
        return np.zeros(steps.shape[:-2] + steps.shape[-1:])
    return np.asarray(np.mean(reversing, axis=-2))


def terminal_gain(
    e: ArrayLike, *, beta: ArrayLike, gamma: float, eps_e: float, dt: float
) -> FloatArray:
    r"""Median gain per sample of a terminal surface term :math:`\beta\,\mathrm{sig}(e)^\gamma`.

    .. math:: g_i = \mathrm{median}_k\; \beta_i\gamma\max(|e_{k,i}|, \varepsilon_e)^{\gamma-1}\,T_s

    the factor of :math:`\dot e` in :math:`\nu` (docs/theory.md §3) times the sample time :math:`T_s`;
    above 1 the sampled loop overshoots at every sample.

    Parameters
    ----------
    e : array_like, shape (..., T, n)
        The error the controller sees (rad), e.g. :math:`\tilde q - q_d`.
    beta : float or array_like, shape (n,)
        Terminal gain :math:`\beta`.
    gamma : float
        Exponent :math:`\gamma`.
    eps_e : float
        Singularity guard :math:`\varepsilon_e` (rad).
    dt : float
        Sample time :math:`T_s` (s).

    Returns
    -------
    ndarray, shape (..., n)
        Dimensionless.
    """
    err = np.abs(_signal("e", e))
    b = np.asarray(beta, dtype=np.float64)
    gain = b * gamma * np.maximum(err, eps_e) ** (gamma - 1.0) * dt
    return np.asarray(np.median(gain, axis=-2))


def rms(x: ArrayLike) -> FloatArray:
    r"""Root mean square of a signal over its samples.

    .. math:: \mathrm{RMS}_i = \sqrt{\frac{1}{T} \sum_{k=0}^{T-1} x_{k,i}^2}

    Parameters
    ----------
    x : array_like, shape (..., T, n)
        Any signal, e.g. the sliding variable (rad/s).

    Returns
    -------
    ndarray, shape (..., n)
        The unit of ``x``.
    """
    arr = _signal("x", x)
    return np.asarray(np.sqrt(np.mean(arr * arr, axis=-2)))


def late_metrics(
    t: ArrayLike,
    tau: ArrayLike,
    s: ArrayLike,
    e_seen: ArrayLike,
    *,
    dt: float,
    terminal: tuple[ArrayLike, float, float] | None = None,
    fraction: float = DEFAULT_LATE_FRACTION,
) -> dict[str, FloatArray]:
    r"""Torque chattering and sliding variable after the transient, per joint.

    The window is the samples :math:`k \ge k_0` of :func:`late_start`. With the applied torque
    :math:`\tau_k`, :math:`k_0 \le k \le T-2`:

    - ``chattering_late``: :func:`chattering` on the window,
      :math:`\sum_k |\Delta_k| / (t_{T-1} - t_{k_0})` (N·m/s);
    - ``max_step_late``: :func:`max_step` on the window (N·m);
    - ``alternation_late``: :func:`alternation` on the window;
    - ``terminal_gain_late``: :func:`terminal_gain` of ``e_seen`` on the window with
      ``terminal = (beta, gamma, eps_e)``; NaN without a terminal term (``terminal=None``);
    - ``s_rms_late``: :func:`rms` of ``s`` on the window (rad/s).

    Parameters
    ----------
    t : array_like, shape (T,)
        Sample times (s).
    tau, s, e_seen : array_like, shape (T, n)
        Torque (N m), sliding variable and the error the controller sees (rad).
    dt : float
        Sample time (s) of :func:`terminal_gain`.
    terminal : (beta, gamma, eps_e), optional
        The controller's terminal term, if it has one.
    fraction : float, default :data:`DEFAULT_LATE_FRACTION` = 0.5
        Share of the run the window covers, in (0, 1].

    Returns
    -------
    dict of str to ndarray, shape (n,)
        One array per name of :data:`LATE_COLUMNS` (NaN for a run of fewer than 3 samples).
    """
    _fraction(fraction)
    tt = _time(t)
    torque = _signal("tau", tau, tt)
    n = torque.shape[-1]
    if tt.shape[0] < 3:
        return {name: np.full(n, math.nan) for name in LATE_COLUMNS}
    k0 = late_start(tt, fraction=fraction)
    window = torque[k0:]
    out: dict[str, FloatArray] = {
        "chattering_late": np.asarray(chattering(tt[k0:], window), dtype=float),
        "max_step_late": max_step(window),
        "alternation_late": alternation(window),
    }
    if terminal is None:
        out["terminal_gain_late"] = np.full(n, math.nan)
    else:
        beta, gamma, eps_e = terminal
        seen = _signal("e_seen", e_seen, tt)[k0:]
        out["terminal_gain_late"] = terminal_gain(seen, beta=beta, gamma=gamma, eps_e=eps_e, dt=dt)
    out["s_rms_late"] = rms(_signal("s", s, tt)[k0:])
    return out


# ---------------------------------------------------------------------------- summary
def _metric_table(
    t: FloatArray,
    e: FloatArray,
    s: FloatArray,
    tau: FloatArray,
    *,
    delta_s: float,
    delta_e: float,
    window: float,
    cutoff_hz: float,
) -> dict[str, FloatArray]:
    """Every metric of :data:`METRIC_COLUMNS`, each of shape (..., n)."""
    return {
        "mse": mse(e),
        "rmse": rmse(e),
        "iae": iae(t, e),
        "itae": itae(t, e),
        "reaching_time": reaching_time(t, s, delta_s=delta_s),
        "settling_time": settling_time(t, e, delta_e=delta_e),
        "steady_state_error": steady_state_error(t, e, window=window),
        "final_error": final_error(e),
        "control_effort": control_effort(t, tau),
        "peak_torque": peak_torque(tau),
        "chattering": chattering(t, tau),
        "hf_power_share": hf_power_share(t, tau, cutoff_hz=cutoff_hz),
    }


def summary(
    result: SimResult | BatchResult,
    *,
    delta_s: float = DEFAULT_DELTA_S,
    delta_e: float = DEFAULT_DELTA_E,
    window: float = DEFAULT_WINDOW,
    cutoff_hz: float = DEFAULT_CUTOFF_HZ,
) -> pd.DataFrame:
    r"""Every metric of a run (or of each run of a batch) as a table.

    Parameters
    ----------
    result : SimResult or BatchResult
        A single run (signals ``(T, n)``) or a batch (signals ``(B, T, n)``); the metrics use
        its true tracking error :math:`e = q - q_d`, its sliding variable ``s`` and its torque
        ``tau``.
    delta_s : float, default :data:`DEFAULT_DELTA_S` = 0.02 rad/s
        Band of :func:`reaching_time`.
    delta_e : float, default :data:`DEFAULT_DELTA_E` = 1e-3 rad
        Band of :func:`settling_time`.
    window : float, default :data:`DEFAULT_WINDOW` = 0.5 s
        Final window of :func:`steady_state_error`.
    cutoff_hz : float, default :data:`DEFAULT_CUTOFF_HZ` = 50 Hz
        Cut-off of :func:`hf_power_share`.

    Returns
    -------
    pandas.DataFrame
        For a :class:`~slidingarm.results.SimResult`: ``n + 1`` rows, column ``joint`` with
        values ``"1"`` … ``"n"`` (strings) and ``"mean"``, then the columns of
        :data:`METRIC_COLUMNS` (``chattering`` is the total variation per second). For a
        :class:`~slidingarm.results.BatchResult`: the same table for each run stacked, with a
        leading integer column ``run`` (``B (n + 1)`` rows, run-major).

        The ``mean`` row is the arithmetic mean over joints of every column,

        .. math:: \bar m = \frac{1}{n} \sum_{i=1}^{n} m_i,

        so a reaching or settling time is :math:`+\infty` in the mean row when any joint never
        reaches its band (the arm has not settled until every joint has), and the mean of the
        signed ``final_error`` can cancel across joints (``steady_state_error`` holds the
        magnitudes).
    """

    t = np.asarray(result.t, dtype=np.float64)
    e = np.asarray(result.q, dtype=np.float64) - np.asarray(result.q_ref, dtype=np.float64)
    s = np.asarray(result.s, dtype=np.float64)
    tau = np.asarray(result.tau, dtype=np.float64)
    if e.ndim not in (2, 3):
        raise ValueError(f"result signals must have shape (T, n) or (B, T, n), got {e.shape}")
    table = _metric_table(
        t, e, s, tau, delta_s=delta_s, delta_e=delta_e, window=window, cutoff_hz=cutoff_hz
    )
    batched = e.ndim == 3
    if not batched:
        table = {k: v[None, :] for k, v in table.items()}
    return metric_frame(table, runs=batched)


def metric_frame(table: Mapping[str, FloatArray], *, runs: bool = True) -> pd.DataFrame:
    """The table of :func:`summary` from per-run, per-joint metric values.

    Parameters
    ----------
    table : mapping
        For every name of :data:`METRIC_COLUMNS`, an array ``(B, n)``.
    runs : bool
        Lead with the integer column ``run`` (a batch's table).

    Returns
    -------
    pandas.DataFrame
        ``B (n + 1)`` rows, run-major: ``run`` (if ``runs``), ``joint`` (``"1"`` … ``"n"``,
        ``"mean"``), then :data:`METRIC_COLUMNS`; the ``mean`` row is the mean over joints.
    """
    import pandas as pd

    n_runs, n = np.shape(table["mse"])
    labels = [str(j + 1) for j in range(n)] + ["mean"]
    columns: dict[str, Any] = {}
    if runs:
        columns["run"] = np.repeat(np.arange(n_runs), n + 1)
    columns["joint"] = labels * n_runs
    for name in METRIC_COLUMNS:
        values = np.asarray(table[name], dtype=np.float64)
        with_mean = np.concatenate([values, np.mean(values, axis=-1, keepdims=True)], axis=-1)
        columns[name] = with_mean.reshape(-1)
    return pd.DataFrame(columns)
