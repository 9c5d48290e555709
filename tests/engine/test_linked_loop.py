"""The per-run loop's two specialisations (``slidingarm._pointers.INLINED`` and ``LINKED``):
the linked one reaches the built-in law and the plant's RK4 step through their addresses
(``slidingarm._engine.linked_loop``, what ``slidingarm reproduce`` runs), the inlined one calls
them directly. Same operations in the same order: every run bit for bit the same."""

from __future__ import annotations

import numpy as np
import pytest

import slidingarm as sa
from slidingarm import _engine as E


def _both(
    arm: sa.ArmModel, law: sa.SlidingModeController, ref: sa.Reference, q0: np.ndarray
) -> tuple[sa.SimResult, sa.SimResult]:
    inlined = sa.simulate(arm, law, ref, q0=q0, t_final=0.3, dt=1e-3)
    with E.linked_loop():
        linked = sa.simulate(arm, law, ref, q0=q0, t_final=0.3, dt=1e-3)
    return inlined, linked


@pytest.mark.parametrize("switching", ["sign", "tanh"])
def test_the_linked_loop_runs_the_planar_arm_bit_for_bit(switching: str) -> None:
    arm = sa.PlanarArm.paper()
    width = 0.05 if switching == "tanh" else None
    law = sa.FTSMC(arm, alpha=5.0, beta=5.0, p=5, q=3, k=20.0, switching=switching, width=width)
    inlined, linked = _both(arm, law, sa.PaperReference(), np.asarray(sa.PAPER_Q0))
    for name in ("q", "qd", "tau", "s"):
        np.testing.assert_array_equal(getattr(linked, name), getattr(inlined, name))
    assert not E._LINKED_RUNS[0]  # the switch is restored


def test_the_linked_loop_runs_a_serial_arm_bit_for_bit() -> None:
    arm = sa.robots.load("ur5")
    law = sa.PDSMC(arm, lam=5.0, k=20.0, switching="tanh", width=0.05)
    q0 = np.full(arm.n, 0.3)
    ref = sa.QuinticReference(q0, q0 + 0.2, duration=0.3)
    inlined, linked = _both(arm, law, ref, q0)
    for name in ("q", "qd", "tau", "s"):
        np.testing.assert_array_equal(getattr(linked, name), getattr(inlined, name))
