"""Monte Carlo sweeps over a scenario's numeric keys (``slidingarm sweep``).

:mod:`~slidingarm.sweep.space` says what varies (:class:`Distribution`, :func:`apply`,
:func:`numeric_keys`).
"""

from __future__ import annotations

from slidingarm.sweep.space import Distribution, apply, numeric_keys

__all__ = ["Distribution", "apply", "numeric_keys"]
