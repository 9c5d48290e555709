"""Monte Carlo sweeps over a scenario's numeric keys (``slidingarm sweep``).

- :mod:`~slidingarm.sweep.space` -- what varies: :class:`Distribution`, :func:`apply`,
  :func:`numeric_keys`;
- :mod:`~slidingarm.sweep.staging` -- each draw's values and seed, and its run's objects;
- :mod:`~slidingarm.sweep.run` -- :func:`sweep`: chunks, executors, the resumable folder;
- :mod:`~slidingarm.sweep.summary` -- medians with bootstrap intervals, success rates.
"""

from __future__ import annotations

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
