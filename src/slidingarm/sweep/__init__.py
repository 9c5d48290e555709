"""Monte Carlo sweeps over a scenario's numeric keys (``slidingarm sweep``).

- :mod:`~slidingarm.sweep.space` -- what varies: :class:`Distribution`, :func:`apply`,
  :func:`numeric_keys`;
- :mod:`~slidingarm.sweep.staging` -- each draw's values and seed, and its run's objects;
- :mod:`~slidingarm.sweep.run` -- :func:`sweep`: chunks, executors, the resumable folder;
- :mod:`~slidingarm.sweep.summary` -- medians with bootstrap intervals, success rates.

The package itself is callable: ``slidingarm.sweep(scenario, runs=1000, out="dir")`` is
:func:`slidingarm.sweep.run.sweep`, and ``import slidingarm.sweep.space`` still works. Its
names load on first use, so that ``import slidingarm`` does not import the scenario files'
machinery (:mod:`slidingarm.config`).
"""

from __future__ import annotations

import importlib
import sys
import types
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from slidingarm.sweep.run import SweepDefinition, SweepError, SweepResult, run_chunk, sweep
    from slidingarm.sweep.space import Distribution, apply, numeric_keys
    from slidingarm.sweep.summary import success_rates, summarize

__all__ = [
    "Distribution",
    "SweepDefinition",
    "SweepError",
    "SweepResult",
    "apply",
    "numeric_keys",
    "run_chunk",
    "success_rates",
    "summarize",
    "sweep",
]

_HOME = {
    "Distribution": "space",
    "apply": "space",
    "numeric_keys": "space",
    "SweepDefinition": "run",
    "SweepError": "run",
    "SweepResult": "run",
    "run_chunk": "run",
    "sweep": "run",
    "success_rates": "summary",
    "summarize": "summary",
}


def __getattr__(name: str) -> Any:
    home = _HOME.get(name)
    if home is None:
        raise AttributeError(f"module 'slidingarm.sweep' has no attribute {name!r}")
    return getattr(importlib.import_module(f"slidingarm.sweep.{home}"), name)


def __dir__() -> list[str]:
    return sorted({*globals(), *__all__})


class _Callable(types.ModuleType):
    """This package, callable: ``slidingarm.sweep(scenario, runs=..., out=...)`` is
    :func:`slidingarm.sweep.run.sweep`."""

    def __call__(self, *args: Any, **kwargs: Any) -> SweepResult:
        from slidingarm.sweep.run import sweep as run_sweep

        return run_sweep(*args, **kwargs)


sys.modules[__name__].__class__ = _Callable
