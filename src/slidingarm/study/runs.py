"""Running a built scenario's controllers: :func:`simulate_setup`, what the study, the
analyses and the command line run a scenario with (no pandas here: the study runs its
scenarios before it imports the analyses, :mod:`slidingarm.study.reproduce`)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Literal, overload

from slidingarm.config import Setup
from slidingarm.control.controllers import SlidingModeController
from slidingarm.results import SimResult
from slidingarm.simulate import SimulationError, simulate, simulate_batch

__all__ = ["OnDiverge", "simulate_setup"]



#: What :func:`simulate_setup` does when a run diverges: ``"raise"`` a
#: :class:`~slidingarm.simulate.SimulationError`, or ``"record"`` its message in place of the
#: result and go on with the others.
OnDiverge = Literal["raise", "record"]


@overload
def simulate_setup(
    setup: Setup,
    controllers: Mapping[str, SlidingModeController] | None = None,
    *,
    on_diverge: Literal["raise"] = "raise",
) -> dict[str, SimResult]: ...


@overload
def simulate_setup(
    setup: Setup,
    controllers: Mapping[str, SlidingModeController] | None = None,
    *,
    on_diverge: Literal["record"],
) -> dict[str, SimResult | str]: ...


def simulate_setup(
    setup: Setup,
    controllers: Mapping[str, SlidingModeController] | None = None,
    *,
    on_diverge: OnDiverge = "raise",
) -> dict[str, SimResult] | dict[str, SimResult | str]:
    """Run controllers on a built scenario's plant, reference, sensor and disturbances.

    The runs go through :func:`slidingarm.simulate.simulate_batch` together, all with the
    setup's seed, so each draws the same noise as it would alone; the batch computes every run
    on its own, so each result is the one :func:`slidingarm.simulate.simulate` gives, bit for
    bit.

    Parameters
    ----------
    setup : Setup
        The built scenario.
    controllers : mapping of str to SlidingModeController, optional
        The controllers to run, by label (default: the setup's own, ``setup.controllers``).
    on_diverge : {"raise", "record"}
        What a diverging run does: ``"raise"`` stops with a
        :class:`~slidingarm.simulate.SimulationError` naming the scenario and the controller;
        ``"record"`` puts the run's error message (as :func:`~slidingarm.simulate.simulate`
        words it for that run alone) in place of its result and keeps the others.

    Returns
    -------
    dict of str to SimResult (or str with ``on_diverge="record"``)
        Keyed by label, in the order of ``controllers``.

    Raises
    ------
    SimulationError
        With ``on_diverge="raise"``, if a run diverges.
    """
    if on_diverge not in ("raise", "record"):
        raise ValueError(f"on_diverge must be 'raise' or 'record', got {on_diverge!r}")
    runs = dict(setup.controllers if controllers is None else controllers)
    opts = setup.options()
    seed = opts.pop("seed")
    done: dict[str, SimResult | str] = {}
    pending = list(runs)
    while pending:
        try:
            # the per-run loop: a study's batches are a few dozen runs, for which the block
            # path saves tenths of a second but compiles for about 15 s on a first run
            batch = simulate_batch(
                setup.plant, [runs[label] for label in pending], setup.reference, seeds=seed,
                block=False, **opts,
            )  # fmt: skip
        except SimulationError as exc:
            # the batch names its first diverging run; that run alone says it in its own words
            # (the others of the batch are run again without it)
            label = pending.pop(exc.run)
            try:
                done[label] = simulate(setup.plant, runs[label], setup.reference, seed=seed, **opts)
            except SimulationError as alone:
                if on_diverge == "raise":
                    raise SimulationError(
                        f"scenario {setup.name!r}, controller {label!r}: {alone}",
                        time=alone.time,
                        joint=alone.joint,
                        run=alone.run,
                    ) from alone
                done[label] = str(alone)
            continue
        done.update(zip(pending, (batch[b] for b in range(len(batch))), strict=True))
        pending = []
    return {label: done[label] for label in runs}
