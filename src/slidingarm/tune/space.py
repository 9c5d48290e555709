"""The gain space of a tuning: which gains of a controller vary, and over which interval.

The space comes from the controller class (:data:`slidingarm.control.controllers.CONTROLLERS`)
and the scenario's own values:

=================  ====================================  =========================================
gain               what the constructor refuses           default interval (scale)
=================  ====================================  =========================================
``lam``/``alpha``  :math:`\\le 0`                          :math:`[v/10,\\ 10 v]` (log)
``beta``           :math:`\\le 0`                          :math:`[v/10,\\ 10 v]` (log)
``gamma``          outside ``EXPONENT_RANGE`` (open)      the open range shrunk by 5 % of its width
                                                          at each end: (0, 1) gives [0.05, 0.95],
                                                          NTSMC's (1, 2) gives [1.05, 1.95] (linear)
``k``              :math:`\\le 0`                          :math:`[v/10,\\ 10 v]` (log)
``width``          :math:`\\le 0` (tanh and sat only)      :math:`[v/10,\\ 10 v]` (log)
``k2``             :math:`\\le 0` (super-twisting only)    :math:`[v/10,\\ 10 v]` (log)
=================  ====================================  =========================================

where :math:`v` is the scenario's value of that gain for the tuned controller (for a per-joint
value, the interval runs from its smallest entry / 10 to its largest × 10). A gain with only a
positivity constraint has no natural finite range, so the default is two decades around the
value the scenario's author chose, searched on a log scale. Each tuned gain is one scalar shared
by all joints (the per-joint tuning would multiply the dimension by ``n``). The exponent is tuned
as a float :math:`\\gamma` (not as odd ``p``, ``q``); ``eps_e``, the singularity guard, is not a
gain and is never tuned. ``bounds`` overrides any interval or its scale, or fixes a gain at the
scenario's value.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Literal

from slidingarm.config import ConfigError
from slidingarm.control.controllers import CONTROLLERS, DEFAULT_WIDTH, SlidingModeController

__all__ = [
    "DECADES",
    "EXPONENT_MARGIN",
    "GainBound",
    "GainSpace",
    "gain_space",
    "parse_bound",
]

#: Width of a default interval around a positive gain's value :math:`v`: :math:`[v/10^D, v 10^D]`.
DECADES = 1.0
#: Share of the exponent's open range left out at each end of its default interval.
EXPONENT_MARGIN = 0.05

#: A bound given by the user: ``(low, high)``, ``(low, high, "log" | "linear")``, or
#: ``"fixed"`` (keep the scenario's value, do not tune).
BoundSpec = tuple[float, float] | tuple[float, float, str] | Literal["fixed"]

_SCALES = ("log", "linear")


@dataclass(frozen=True)
class GainBound:
    """One tuned gain: a closed interval ``[low, high]`` searched on a ``log`` or linear scale.

    Attributes
    ----------
    name : str
        The gain's name as the controller's constructor and the scenario file spell it
        (``lam``, ``alpha``, ``beta``, ``gamma``, ``k``, ``width``, ``k2``).
    low, high : float
        Finite, ``low < high``; ``low > 0`` on a log scale.
    log : bool
        Whether the sampler draws :math:`\\log x` uniformly.
    """

    name: str
    low: float
    high: float
    log: bool

    def __post_init__(self) -> None:
        for what in ("low", "high"):
            v = getattr(self, what)
            if isinstance(v, bool) or not isinstance(v, int | float):
                raise ConfigError(f"{what} must be a number, got {v!r}", path=f"bounds.{self.name}")
            if not math.isfinite(v):
                raise ConfigError(f"{what} must be finite, got {v!r}", path=f"bounds.{self.name}")
        if not self.low < self.high:
            raise ConfigError(
                f"needs low < high, got [{self.low:g}, {self.high:g}] (use 'fixed' to keep the "
                "scenario's value)",
                path=f"bounds.{self.name}",
            )
        if self.log and self.low <= 0:
            raise ConfigError(
                f"a log scale needs low > 0, got {self.low:g} (or give the scale 'linear')",
                path=f"bounds.{self.name}",
            )

    def to_dict(self) -> dict[str, Any]:
        """``{"low", "high", "scale"}``, JSON-able."""
        return {"low": self.low, "high": self.high, "scale": "log" if self.log else "linear"}


@dataclass(frozen=True)
class GainSpace:
    """The gains a tuning varies for one controller of a scenario.

    Attributes
    ----------
    controller : str
        The controller's class name (:attr:`SlidingModeController.name`).
    bounds : tuple of GainBound
        The tuned gains, in the constructor's order.
    fixed : tuple of str
        Gains of the controller kept at the scenario's value.
    """

    controller: str
    bounds: tuple[GainBound, ...]
    fixed: tuple[str, ...] = ()

    @property
    def names(self) -> tuple[str, ...]:
        """The tuned gains' names."""
        return tuple(b.name for b in self.bounds)

    def __getitem__(self, name: str) -> GainBound:
        for b in self.bounds:
            if b.name == name:
                return b
        raise KeyError(name)

    def start(self, controller: SlidingModeController) -> dict[str, float]:
        """The scenario's own gains of ``controller`` as a point of this space: a per-joint
        value by its geometric mean (positive gains) or mean (the exponent), each clipped into
        its interval."""
        values = _tunable(controller)
        out: dict[str, float] = {}
        for b in self.bounds:
            v = values[b.name]
            arr = [float(x) for x in (v if isinstance(v, list) else [v])]
            if len(set(arr)) == 1:
                x = arr[0]  # exactly the scenario's value (exp(log(x)) may move it by an ulp)
            elif b.log:
                x = math.exp(sum(math.log(a) for a in arr) / len(arr))
            else:
                x = sum(arr) / len(arr)
            out[b.name] = min(max(x, b.low), b.high)
        return out

    def distributions(self) -> dict[str, Any]:
        """optuna's :class:`~optuna.distributions.FloatDistribution` of each tuned gain."""
        from optuna.distributions import FloatDistribution

        return {b.name: FloatDistribution(b.low, b.high, log=b.log) for b in self.bounds}

    def to_dict(self) -> dict[str, Any]:
        """JSON-able: the class name, each gain's interval and the fixed gains."""
        return {
            "controller": self.controller,
            "bounds": {b.name: b.to_dict() for b in self.bounds},
            "fixed": list(self.fixed),
        }


def _tunable(ctrl: SlidingModeController) -> dict[str, float | list[float]]:
    """The tunable gains of a built controller and their values (``gamma`` as a float)."""
    d = ctrl.to_dict()
    klass = CONTROLLERS[ctrl.name]
    names: list[str] = []
    if klass.LINEAR_NAME is not None:
        names.append(klass.LINEAR_NAME)
    if "beta" in klass.SURFACE_GAINS:
        names.append("beta")
    if "exponent" in klass.SURFACE_GAINS:
        names.append("gamma")
    names.append("k")
    if ctrl.switching != "sign":
        names.append("width")
    if ctrl.reaching == "super-twisting":
        names.append("k2")
    out: dict[str, float | list[float]] = {}
    for name in names:
        value = d.get(name, DEFAULT_WIDTH if name == "width" else None)
        assert value is not None, name
        out[name] = value
    return out


def _default(
    name: str, value: float | list[float], klass: type[SlidingModeController]
) -> GainBound:
    if name == "gamma":
        lo, hi = klass.EXPONENT_RANGE
        margin = EXPONENT_MARGIN * (hi - lo)
        return GainBound(name, lo + margin, hi - margin, log=False)
    values = [float(v) for v in (value if isinstance(value, list) else [value])]
    scale = 10.0**DECADES
    return GainBound(name, min(values) / scale, max(values) * scale, log=True)


def gain_space(
    controller: SlidingModeController, bounds: Mapping[str, BoundSpec] | None = None
) -> GainSpace:
    """The gain space of ``controller`` (as built from a scenario), with ``bounds`` applied.

    Parameters
    ----------
    controller : SlidingModeController
        A named controller (PDSMC, TSMC, FTSMC, NTSMC) with the scenario's gains; the default
        intervals are set around them (see the module's table).
    bounds : mapping, optional
        Per gain name: ``(low, high)`` (the gain's default scale), ``(low, high, scale)`` with
        scale ``"log"`` or ``"linear"``, or ``"fixed"`` to keep the scenario's value.

    Raises
    ------
    ConfigError
        Naming ``bounds.<name>`` for a gain the controller does not tune, an empty or
        non-finite interval, a log scale through zero, or an exponent interval outside the
        class's open ``EXPONENT_RANGE``.
    """
    klass = CONTROLLERS[controller.name]
    values = _tunable(controller)
    given = dict(bounds or {})
    unknown = sorted(set(given) - set(values))
    if unknown:
        raise ConfigError(
            f"{controller.name} with this scenario tunes {', '.join(values)}; it has no gain "
            f"{unknown[0]!r}",
            path=f"bounds.{unknown[0]}",
        )
    out: list[GainBound] = []
    fixed: list[str] = []
    for name, value in values.items():
        spec = given.get(name)
        default = _default(name, value, klass)
        if spec is None:
            out.append(default)
            continue
        if isinstance(spec, str):
            if spec != "fixed":
                raise ConfigError(
                    f"must be (low, high[, scale]) or 'fixed', got {spec!r}", path=f"bounds.{name}"
                )
            fixed.append(name)
            continue
        if not isinstance(spec, Sequence) or len(spec) not in (2, 3):
            raise ConfigError(
                f"must be (low, high[, scale]) or 'fixed', got {spec!r}", path=f"bounds.{name}"
            )
        log = default.log
        if len(spec) == 3:
            scale = spec[2]
            if scale not in _SCALES:
                raise ConfigError(
                    f"scale must be 'log' or 'linear', got {scale!r}", path=f"bounds.{name}"
                )
            log = scale == "log"
        bound = GainBound(name, spec[0], spec[1], log=log)  # type: ignore[arg-type]
        if name == "gamma":
            lo, hi = klass.EXPONENT_RANGE
            if not (lo < bound.low and bound.high < hi):
                raise ConfigError(
                    f"the exponent of {controller.name} lies in the open interval ({lo:g}, "
                    f"{hi:g}); got [{bound.low:g}, {bound.high:g}]",
                    path="bounds.gamma",
                )
        elif bound.low <= 0:
            raise ConfigError(f"{name} must be > 0; got low = {bound.low:g}", path=f"bounds.{name}")
        out.append(bound)
    if not out:
        raise ConfigError("every gain is fixed: nothing to tune", path="bounds")
    return GainSpace(controller.name, tuple(out), tuple(fixed))


_BOUND = re.compile(r"^\s*([A-Za-z_][A-Za-z0-9_]*)\s*=\s*(.*?)\s*$")


def parse_bound(text: str) -> tuple[str, BoundSpec]:
    """Parse one ``--bound``: ``NAME=LOW:HIGH``, ``NAME=LOW:HIGH:log|linear`` or ``NAME=fixed``.

    Raises
    ------
    ConfigError
        Naming ``--bound`` and the text, for anything else.
    """
    m = _BOUND.match(text)
    if m is None:
        raise ConfigError(
            f"expected NAME=LOW:HIGH[:log|linear] or NAME=fixed, got {text!r}", path="--bound"
        )
    name, rest = m.group(1), m.group(2)
    if rest == "fixed":
        return name, "fixed"
    parts = rest.split(":")
    if len(parts) not in (2, 3):
        raise ConfigError(
            f"expected NAME=LOW:HIGH[:log|linear] or NAME=fixed, got {text!r}", path="--bound"
        )
    try:
        low, high = float(parts[0]), float(parts[1])
    except ValueError:
        raise ConfigError(f"LOW and HIGH must be numbers, got {text!r}", path="--bound") from None
    if len(parts) == 3:
        return name, (low, high, parts[2])
    return name, (low, high)
