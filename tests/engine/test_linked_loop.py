"""The per-run loop's two specialisations (``slidingarm._pointers.INLINED`` and ``LINKED``):
the linked one reaches the built-in law and the plant's RK4 step through their addresses
(``slidingarm._engine.linked_loop``, what ``slidingarm reproduce`` runs), the inlined one calls
them directly. Same operations in the same order: every run bit for bit the same."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from numba import typeof

sys.path.insert(0, str(Path(__file__).parent))

import custom_kernels as K

import slidingarm as sa
from slidingarm import _engine as E
from slidingarm._pointers import LINKED


def _both(
    arm: sa.ArmModel, law: sa.Controller, ref: sa.Reference, q0: np.ndarray
) -> tuple[sa.SimResult, sa.SimResult]:
    inlined = sa.simulate(arm, law, ref, q0=q0, t_final=0.3, dt=1e-3)
    with E.linked_loop():
        assert E.loop_link(arm.handle.kind, arm.handle.params, law.handle.code)[0] is LINKED
        linked = sa.simulate(arm, law, ref, q0=q0, t_final=0.3, dt=1e-3)
    # the linked specialisation was compiled (and so run): its tag is a signature's last type
    assert typeof(LINKED) in [sig[-1] for sig in E.run_one.signatures]
    assert not E.linked_runs()  # the switch is off again
    return inlined, linked


def _same(a: sa.SimResult, b: sa.SimResult) -> None:
    for name in ("q", "qd", "tau", "s"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))


@pytest.mark.parametrize("switching", ["sign", "tanh"])
def test_the_linked_loop_runs_the_planar_arm_bit_for_bit(switching: str) -> None:
    arm = sa.PlanarArm.paper()
    width = 0.05 if switching == "tanh" else None
    law = sa.FTSMC(arm, alpha=5.0, beta=5.0, p=5, q=3, k=20.0, switching=switching, width=width)
    _same(*_both(arm, law, sa.PaperReference(), np.asarray(sa.PAPER_Q0)))


def test_the_linked_loop_runs_the_paper_law_and_a_custom_law_bit_for_bit() -> None:
    # the paper's law goes through its entry after the linked law; a custom law through its
    # entry only (its run gets no law address: it never calls the built-in law)
    arm = sa.PlanarArm.paper()
    paper = sa.FTSMC(arm, alpha=5.0, beta=5.0, p=5, q=3, k=20.0, switching="tanh", width=0.05,
                     law="paper")  # fmt: skip
    _same(*_both(arm, paper, sa.PaperReference(), np.asarray(sa.PAPER_Q0)))
    custom = sa.CustomController(K.pdsmc_tanh, arm, params=(2.0, 20.0, 0.05))
    with E.linked_loop():
        assert E.loop_link(arm.handle.kind, arm.handle.params, custom.handle.code)[2] == 0
    _same(*_both(arm, custom, sa.PaperReference(), np.asarray(sa.PAPER_Q0)))


def test_linked_blocks_of_two_threads_may_overlap() -> None:
    # A enters, B enters, A leaves: B's runs are still linked; B leaves: off
    a, b = E.linked_loop(), E.linked_loop()
    a.__enter__()
    b.__enter__()
    a.__exit__(None, None, None)
    assert E.linked_runs()
    b.__exit__(None, None, None)
    assert not E.linked_runs()


def test_the_linked_loop_runs_a_serial_arm_bit_for_bit() -> None:
    arm = sa.robots.load("ur5")
    law = sa.PDSMC(arm, lam=5.0, k=20.0, switching="tanh", width=0.05)
    q0 = np.full(arm.n, 0.3)
    ref = sa.QuinticReference(q0, q0 + 0.2, duration=0.3)
    _same(*_both(arm, law, ref, q0))
