"""Sliding surfaces: the sliding variable ``s`` and the derivative term ``ν`` (docs/theory.md §3).

Each surface is an immutable, validated parameter set. ``value`` and ``nu`` evaluate it with
numpy (for inspection and tests); the controllers evaluate the same formulas compiled
(:mod:`slidingarm.control._kernels`). Gains are scalars or one value per joint.

========  ==========================================  ==============================================
surface   :math:`s`                                    :math:`\\nu` (d/dt of the non-:math:`\\dot e` part)
========  ==========================================  ==============================================
linear    :math:`\\dot e + \\lambda e`                   :math:`\\lambda\\dot e`
terminal  :math:`\\dot e + \\beta\\,sig(e)^\\gamma`        :math:`\\beta\\gamma|e|^{\\gamma-1}\\dot e`
fast-T    :math:`\\dot e + \\alpha e + \\beta sig(e)^\\gamma` :math:`(\\alpha + \\beta\\gamma|e|^{\\gamma-1})\\dot e`
NTSM      :math:`e + \\beta^{-1} sig(\\dot e)^{p/q}`     :math:`(\\beta q/p)\\,sig(\\dot e)^{2-p/q}`
========  ==========================================  ==============================================
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from slidingarm._validate import (
    MIN_EPS_E,
    ParameterTypeError,
    as_real,
    is_integer,
    is_real,
    per_joint,
    positive,
)
from slidingarm.control import _kernels as CK

__all__ = [
    "DEFAULT_EPS_E",
    "FastTerminalSurface",
    "LinearSurface",
    "NonsingularTerminalSurface",
    "Surface",
    "TerminalSurface",
    "exponent",
    "ftsm_convergence_time",
    "gain",
    "tsm_convergence_time",
]

FloatArray = NDArray[np.float64]

#: Singularity guard of a surface built directly: :math:`|e|^{\gamma-1}` is evaluated at
#: :math:`\max(|e|, \varepsilon_e)`; with :math:`\gamma = 3/5` the guarded gain is at most
#: :math:`\beta\gamma\cdot 10^{3.6}`. :class:`~slidingarm.TSMC` and :class:`~slidingarm.FTSMC`
#: choose theirs from the control period instead (``docs/theory.md`` §3,
#: :func:`slidingarm.control.controllers.guard_for_period`, never below this value) and use this
#: one only when called from Python before a simulation has fixed it.
DEFAULT_EPS_E = 1e-9


def gain(name: str, value: ArrayLike, *, allow_zero: bool = False) -> FloatArray:
    """Validate a gain: a finite scalar or 1-D vector, > 0 (or >= 0 with ``allow_zero``).

    Booleans (``bool``, ``np.bool_``, boolean arrays), strings, bytes and sets are rejected
    with a :class:`~slidingarm._validate.ParameterTypeError` (``k=True`` is a mistake, not a
    gain of 1), as the configuration files do (:func:`slidingarm._validate.per_joint`).

    Returns
    -------
    ndarray
        Read-only, shape ``()`` for a scalar or ``(n,)`` for one value per joint.
    """
    arr = np.array(per_joint(name, value, low=0.0, inclusive=allow_zero), dtype=np.float64)
    arr.setflags(write=False)
    return arr


def exponent(
    gamma: float | None,
    p: int | None,
    q: int | None,
    *,
    low: float = 0.0,
    high: float = 1.0,
    name: str = "gamma",
    allow_nonterminal: bool = False,
) -> float:
    """Validate a terminal exponent given as ``gamma`` or as odd integers ``(p, q)``.

    For the terminal surfaces :math:`\\gamma = q/p` with odd ``q < p`` (Yu & Man 2002), so
    :math:`0 < \\gamma < 1`. The paper writes ``p/q`` with ``q < p``, which is greater than one
    and not terminal; ``allow_nonterminal`` admits any :math:`\\gamma > 0` only so that this
    erratum can be measured. For the nonsingular surface the bounds are ``(1, 2)`` with
    :math:`\\gamma = p/q`.
    """
    if gamma is not None and (p is not None or q is not None):
        raise ValueError(f"give either {name} or (p, q), not both")
    if gamma is None:
        if p is None or q is None:
            raise ValueError(f"{name} is required (or both p and q)")
        if not is_integer(p) or not is_integer(q):
            raise ParameterTypeError(f"p and q must be positive odd integers, got p={p!r}, q={q!r}")
        assert isinstance(p, int | np.integer) and isinstance(q, int | np.integer)
        if p <= 0 or q <= 0 or p % 2 == 0 or q % 2 == 0:
            raise ValueError(f"p and q must be positive odd integers, got p={p!r}, q={q!r}")
        ratio = Fraction(int(q), int(p)) if high <= 1.0 else Fraction(int(p), int(q))
        value = float(ratio)
    else:
        value = as_real(name, gamma)
    if not math.isfinite(value):
        raise ValueError(f"{name} must be finite, got {value!r}")
    if allow_nonterminal:
        if value <= 0:
            raise ValueError(f"{name} must be > 0, got {value!r}")
    elif not low < value < high:
        what = "terminal: 0 < gamma = q/p < 1" if high <= 1.0 else "nonsingular: 1 < p/q < 2"
        raise ValueError(
            f"{name} must lie in ({low:g}, {high:g}) ({what}), got {value!r}"
            + ("; the paper's p/q > 1 is not terminal" if high <= 1.0 and value > 1 else "")
        )
    return value


def _sig(x: FloatArray, power: float | FloatArray) -> FloatArray:
    return np.abs(x) ** power * np.sign(x)


@dataclass(frozen=True)
class Surface:
    """Base of the sliding surfaces: packs its gains into the compiled parameter table."""

    code: int = field(init=False, repr=False, default=CK.SURFACE_FAST_TERMINAL)

    def rows(self) -> dict[int, FloatArray]:  # pragma: no cover - overridden
        raise NotImplementedError

    def to_dict(self) -> dict[str, Any]:  # pragma: no cover - overridden
        raise NotImplementedError

    def value(self, e: ArrayLike, ed: ArrayLike) -> FloatArray:  # pragma: no cover - overridden
        raise NotImplementedError

    def nu(self, e: ArrayLike, ed: ArrayLike) -> FloatArray:  # pragma: no cover - overridden
        raise NotImplementedError


def _aslist(x: FloatArray) -> float | list[float]:
    return float(x) if x.ndim == 0 else [float(v) for v in x]


@dataclass(frozen=True)
class FastTerminalSurface(Surface):
    """:math:`s = \\dot e + \\alpha e + \\beta\\,\\mathrm{sig}(e)^\\gamma` (Yu & Man 2002).

    ``alpha = 0`` gives the terminal surface, ``beta = 0`` the linear (PD) one.
    ``eps_e`` is the singularity guard of :math:`\\nu`.
    """

    alpha: FloatArray = field(default_factory=lambda: np.array(0.0))
    beta: FloatArray = field(default_factory=lambda: np.array(0.0))
    gamma: float = 0.5
    eps_e: float = DEFAULT_EPS_E

    def __post_init__(self) -> None:
        # the largest guarded gain beta gamma eps_e^(gamma-1) must be a float (MIN_EPS_E)
        eps, g = self.eps_e, self.gamma
        if not (is_real(eps, finite=True) and is_real(g, finite=True) and eps > 0):
            return  # the constructors' own checks name these
        if eps < MIN_EPS_E:
            raise ValueError(
                f"eps_e must be >= {MIN_EPS_E:g} (the singularity guard: max(|e|, eps_e)^"
                f"(gamma-1) <= 1/eps_e must stay a float), got {eps!r}"
            )
        try:
            # max |beta| in Python: numpy's reductions cost microseconds on a few values
            mags = [abs(b) for b in np.asarray(self.beta, dtype=np.float64).ravel().tolist()]
            big = math.nan if any(m != m for m in mags) else max(mags, default=0.0)
            top = big * abs(g) * math.pow(eps, g - 1.0)
        except OverflowError:
            top = math.inf
        if not math.isfinite(top):
            raise ValueError(
                f"eps_e = {eps!r} with gamma = {g!r} makes the guarded gain "
                "beta gamma eps_e^(gamma-1) overflow; choose a larger eps_e"
            )

    def rows(self) -> dict[int, FloatArray]:
        return {
            CK.CF_ALPHA: self.alpha,
            CK.CF_BETA: self.beta,
            CK.CF_GAMMA: np.array(self.gamma),
            CK.CF_EPS_E: np.array(self.eps_e),
        }

    def to_dict(self) -> dict[str, Any]:
        return {
            "surface": "fast_terminal",
            "alpha": _aslist(self.alpha),
            "beta": _aslist(self.beta),
            "gamma": self.gamma,
            "eps_e": self.eps_e,
        }

    def value(self, e: ArrayLike, ed: ArrayLike) -> FloatArray:
        """:math:`s = \\dot e + \\alpha e + \\beta\\,\\mathrm{sig}(e)^\\gamma`."""
        ea = np.asarray(e, dtype=float)
        return np.asarray(ed, dtype=float) + self.alpha * ea + self.beta * _sig(ea, self.gamma)

    def nu(self, e: ArrayLike, ed: ArrayLike) -> FloatArray:
        """:math:`\\nu = (\\alpha + \\beta\\gamma\\max(|e|,\\varepsilon_e)^{\\gamma-1})\\dot e`."""
        ea = np.abs(np.asarray(e, dtype=float))
        guarded = np.maximum(ea, self.eps_e) ** (self.gamma - 1.0)
        return (self.alpha + self.beta * self.gamma * guarded) * np.asarray(ed, dtype=float)


def LinearSurface(lam: ArrayLike) -> FastTerminalSurface:
    """The linear (PD) surface :math:`s = \\dot e + \\lambda e`, :math:`\\lambda > 0`."""
    return FastTerminalSurface(alpha=gain("lam", lam), beta=np.array(0.0), gamma=0.5)


def TerminalSurface(
    beta: ArrayLike,
    gamma: float | None = None,
    *,
    p: int | None = None,
    q: int | None = None,
    eps_e: float = DEFAULT_EPS_E,
    allow_nonterminal: bool = False,
) -> FastTerminalSurface:
    """The terminal surface :math:`s = \\dot e + \\beta\\,\\mathrm{sig}(e)^\\gamma`, :math:`0<\\gamma<1`."""
    g = exponent(gamma, p, q, allow_nonterminal=allow_nonterminal)
    return FastTerminalSurface(
        alpha=np.array(0.0), beta=gain("beta", beta), gamma=g, eps_e=_eps(eps_e)
    )


def FastTerminal(
    alpha: ArrayLike,
    beta: ArrayLike,
    gamma: float | None = None,
    *,
    p: int | None = None,
    q: int | None = None,
    eps_e: float = DEFAULT_EPS_E,
    allow_nonterminal: bool = False,
) -> FastTerminalSurface:
    """The fast terminal surface :math:`s = \\dot e + \\alpha e + \\beta\\,\\mathrm{sig}(e)^\\gamma`."""
    g = exponent(gamma, p, q, allow_nonterminal=allow_nonterminal)
    return FastTerminalSurface(
        alpha=gain("alpha", alpha), beta=gain("beta", beta), gamma=g, eps_e=_eps(eps_e)
    )


def _eps(eps_e: float) -> float:
    return positive("eps_e", eps_e, why=" (the singularity guard)")


@dataclass(frozen=True)
class NonsingularTerminalSurface(Surface):
    """:math:`s = e + \\beta^{-1}\\mathrm{sig}(\\dot e)^{\\gamma}`, :math:`1 < \\gamma = p/q < 2`
    (Feng, Yu & Man 2002). No negative power of ``e`` appears, so no singularity.
    """

    beta: FloatArray = field(default_factory=lambda: np.array(1.0))
    gamma: float = 1.5
    code: int = field(init=False, repr=False, default=CK.SURFACE_NONSINGULAR)

    def rows(self) -> dict[int, FloatArray]:
        return {CK.CF_BETA: self.beta, CK.CF_GAMMA: np.array(self.gamma)}

    def to_dict(self) -> dict[str, Any]:
        return {"surface": "nonsingular_terminal", "beta": _aslist(self.beta), "gamma": self.gamma}

    def value(self, e: ArrayLike, ed: ArrayLike) -> FloatArray:
        """:math:`s = e + \\beta^{-1}\\mathrm{sig}(\\dot e)^\\gamma`."""
        return (
            np.asarray(e, dtype=float) + _sig(np.asarray(ed, dtype=float), self.gamma) / self.beta
        )

    def nu(self, e: ArrayLike, ed: ArrayLike) -> FloatArray:
        """:math:`\\nu = (\\beta/\\gamma)\\,\\mathrm{sig}(\\dot e)^{2-\\gamma}`."""
        return self.beta / self.gamma * _sig(np.asarray(ed, dtype=float), 2.0 - self.gamma)


def NonsingularTerminal(
    beta: ArrayLike, gamma: float | None = None, *, p: int | None = None, q: int | None = None
) -> NonsingularTerminalSurface:
    """Validated :class:`NonsingularTerminalSurface`; ``gamma = p/q`` in (1, 2), odd ``p > q``."""
    g = exponent(gamma, p, q, low=1.0, high=2.0)
    return NonsingularTerminalSurface(beta=gain("beta", beta), gamma=g)


# ---------------------------------------------------------------------------- theory
def tsm_convergence_time(e0: ArrayLike, beta: ArrayLike, gamma: float) -> FloatArray:
    """Time for the terminal surface to bring ``e`` from ``e0`` to 0 once ``s = 0``.

    On :math:`\\dot e = -\\beta\\,\\mathrm{sig}(e)^\\gamma`:
    :math:`t_s = |e(0)|^{1-\\gamma} / (\\beta(1-\\gamma))`.
    """
    e = np.abs(np.asarray(e0, dtype=float))
    return np.asarray(e ** (1.0 - gamma) / (np.asarray(beta, dtype=float) * (1.0 - gamma)))


def ftsm_convergence_time(
    e0: ArrayLike, alpha: ArrayLike, beta: ArrayLike, gamma: float
) -> FloatArray:
    """Time for the fast terminal surface to bring ``e`` from ``e0`` to 0 once ``s = 0``.

    On :math:`\\dot e = -\\alpha e - \\beta\\,\\mathrm{sig}(e)^\\gamma` (docs/theory.md §3, paper eq. 10
    corrected): :math:`t_s = \\ln\\big((\\alpha|e(0)|^{1-\\gamma} + \\beta)/\\beta\\big) /
    (\\alpha(1-\\gamma))`.
    """
    e = np.abs(np.asarray(e0, dtype=float))
    a = np.asarray(alpha, dtype=float)
    b = np.asarray(beta, dtype=float)
    return np.asarray(np.log((a * e ** (1.0 - gamma) + b) / b) / (a * (1.0 - gamma)))
