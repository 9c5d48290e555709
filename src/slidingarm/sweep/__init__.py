"""Monte Carlo sweeps over a scenario's numeric keys (``slidingarm sweep``).

- :mod:`~slidingarm.sweep.space` -- what varies: :class:`Distribution`, :func:`apply`,
  :func:`numeric_keys`;
- :mod:`~slidingarm.sweep.staging` -- each draw's values and seed, and its run's objects;
- :mod:`~slidingarm.sweep.run` -- :func:`sweep`: chunks, executors, the resumable folder;
- :mod:`~slidingarm.sweep.summary` -- medians with bootstrap intervals, success rates.

The package itself is callable: ``slidingarm.sweep(scenario, runs=1000, out="dir")`` is
:func:`slidingarm.sweep.run.sweep`, and ``import slidingarm.sweep.space`` still works. Its
names load on first use, so that ``import slidingarm`` does not import the scenario files'
machinery (:mod:`slidingarm.config`). Type checkers see the package as a
:class:`SweepPackage`: called, it is :func:`~slidingarm.sweep.run.sweep` with its signature,
and its names keep their types (``slidingarm.sweep.numeric_keys(scenario)`` is a ``list[str]``).
"""

from __future__ import annotations

import importlib
import sys
import types
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from slidingarm.sweep import run as _run
    from slidingarm.sweep import space as _space
    from slidingarm.sweep import summary as _summary
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


class SweepPackage(types.ModuleType):
    """This package, callable: ``slidingarm.sweep(scenario, runs=..., out=...)`` is
    :func:`slidingarm.sweep.run.sweep`.

    The class of the package's module object; type checkers read ``slidingarm.sweep`` as an
    instance of it (see :mod:`slidingarm`), so that a call is checked against
    :func:`~slidingarm.sweep.run.sweep`'s signature rather than refused as a call of a module.
    """

    if TYPE_CHECKING:
        __call__ = staticmethod(_run.sweep)
        Distribution = _space.Distribution
        SweepDefinition = _run.SweepDefinition
        SweepError = _run.SweepError
        SweepResult = _run.SweepResult
        apply = staticmethod(_space.apply)
        numeric_keys = staticmethod(_space.numeric_keys)
        run_chunk = staticmethod(_run.run_chunk)
        success_rates = staticmethod(_summary.success_rates)
        summarize = staticmethod(_summary.summarize)
        sweep = staticmethod(_run.sweep)
    else:

        def __call__(self, *args: Any, **kwargs: Any) -> SweepResult:
            from slidingarm.sweep.run import sweep as run_sweep

            return run_sweep(*args, **kwargs)


sys.modules[__name__].__class__ = SweepPackage
