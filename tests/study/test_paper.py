"""slidingarm.study.paper: the paper's constants and its Craig split of the velocity terms.

The Craig split tests moved here from ``tests/models`` with the split itself (it was
``PlanarArm.craig_split``); they assert what they asserted there.
"""

from __future__ import annotations

import re

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from slidingarm import PlanarArm
from slidingarm.study import analysis as A
from slidingarm.study import paper
from slidingarm.study.paper import craig_split

FAST = settings(max_examples=150, deadline=None)
SLOW = settings(max_examples=30, deadline=None)
QD_MAX = 5.0
ARM = PlanarArm.paper()


def _m(text: str) -> str:
    return "^" + re.escape(text)


def _vec(n: int, lo: float, hi: float) -> st.SearchStrategy[np.ndarray]:
    return hnp.arrays(np.float64, n, elements=st.floats(lo, hi, allow_nan=False))


@st.composite
def arm_and_state(draw: st.DrawFn) -> tuple[PlanarArm, np.ndarray, np.ndarray]:
    """A random 3-joint arm (point, rod or explicit mass model) and a state."""
    m = draw(_vec(3, 0.2, 5.0))
    ln = draw(_vec(3, 0.2, 2.0))
    g = draw(st.floats(0.0, 20.0))
    kind = draw(st.sampled_from(["point", "rod", "explicit"]))
    if kind != "explicit":
        arm = PlanarArm(m, ln, mass_model=kind, gravity=g)
    else:
        com = draw(_vec(3, 0.1, 1.0)) * ln
        inertia = draw(_vec(3, 0.0, 1.0 / 6.0)) * m * ln**2
        arm = PlanarArm(m, ln, com=com, inertia=inertia, gravity=g)
    q = draw(_vec(3, -2 * np.pi, 2 * np.pi))
    qd = draw(_vec(3, -QD_MAX, QD_MAX))
    return arm, q, qd


def _size(arm: PlanarArm) -> float:
    """An upper bound on every entry of ``M``: :math:`\\sum_i m_i L^2 + I_i`, ``L`` the reach."""
    reach = float(np.sum(arm.lengths))
    return float(np.sum(arm.masses) * reach**2 + np.sum(arm.inertia))


def _torque_scale(arm: PlanarArm, qd: np.ndarray) -> float:
    """A bound on the size of ``C q̇`` and ``G``: :math:`S\\,(\\sum|\\dot q|)^2 + g\\sum m\\,L`."""
    w = float(np.sum(np.abs(qd)))
    return _size(arm) * (1.0 + w**2) + arm.gravity * float(np.sum(arm.masses) * np.sum(arm.lengths))


def test_the_paper_constants_live_in_the_study() -> None:
    assert paper.PAPER_MSE == {"ftsmc": 0.1331, "tsmc": 0.1976, "pdsmc": 0.4698}
    assert paper.RANKING == ("ftsmc", "tsmc", "pdsmc")
    assert paper.PAPER_MSE_SWITCHING == "sign"
    # the analyses use the same objects
    assert A.PAPER_MSE is paper.PAPER_MSE and A.RANKING is paper.RANKING
    assert set(paper.PAPER_FIGURES) == {"sign", "tanh", "noise"}


def test_report_imports_nothing_from_the_study() -> None:
    import subprocess
    import sys

    code = (
        "import sys, slidingarm.report; "
        "print(sorted(m for m in sys.modules if m.startswith(('slidingarm.study', "
        "'slidingarm.config'))))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


@FAST
@given(arm_and_state())
def test_craig_split_reproduces_velocity_torque(case: tuple) -> None:
    """:math:`B(q)[\\dot q\\dot q] + C_2(q)[\\dot q^2] = C(q,\\dot q)\\dot q`; diag(C2) = 0."""
    arm, q, qd = case
    bmat, c2 = craig_split(arm, q)
    pairs = np.array([qd[0] * qd[1], qd[0] * qd[2], qd[1] * qd[2]])
    np.testing.assert_allclose(
        bmat @ pairs + c2 @ qd**2, arm.coriolis(q, qd) @ qd, atol=1e-13 * _torque_scale(arm, qd)
    )
    # Christoffel symbol c_iii = dM_ii/dq_i / 2 vanishes: M_ii does not depend on q_i
    np.testing.assert_allclose(np.diag(c2), 0.0, atol=1e-14 * _size(arm))


@SLOW
@given(arm_and_state(), st.integers(1, 5), st.data())
def test_craig_split_batch_shapes(case: tuple, size: int, data: st.DataObject) -> None:
    arm, _, _ = case
    q = data.draw(hnp.arrays(np.float64, (size, 3), elements=st.floats(-7.0, 7.0)))
    bmat, c2 = craig_split(arm, q)
    assert bmat.shape == c2.shape == (size, 3, 3)
    for b in range(size):
        one_b, one_c2 = craig_split(arm, q[b])
        assert one_b.shape == one_c2.shape == (3, 3)
        np.testing.assert_allclose(bmat[b], one_b, rtol=1e-14, atol=1e-14 * _size(arm))
        np.testing.assert_allclose(c2[b], one_c2, rtol=1e-14, atol=1e-14 * _size(arm))


def test_craig_split_checks_its_state_argument() -> None:
    good = np.full(3, 0.1)
    assert craig_split(ARM, good)[0].shape == (3, 3)
    for bad, message in [
        (np.zeros(2), "q must have shape (3,) or (B, 3) for this 3-joint arm, got (2,)"),
        (np.array([0.0, np.nan, 0.0]), "q must be finite (no NaN or inf)"),
        (np.array([[0.0, 0.0, np.inf]]), "q must be finite (no NaN or inf)"),
        (["a", "b", "c"], "q must be an array of numbers, got"),
    ]:
        with pytest.raises(ValueError, match=_m(message)):
            craig_split(ARM, bad)


@pytest.mark.parametrize("n", [1, 2, 4, 5])
def test_craig_split_needs_three_joints(n: int) -> None:
    arm = PlanarArm(np.ones(n), np.ones(n))
    with pytest.raises(
        ValueError, match=_m(f"craig_split is defined for a 3-joint arm; this arm has {n} joints")
    ):
        craig_split(arm, np.zeros(n))


def test_the_study_and_the_command_line_import_neither_pandas_nor_the_analyses() -> None:
    # reproduce forks its figure workers before it imports them (slidingarm.study.reproduce):
    # the workers start without them, and the import runs while they compile on the other core
    import subprocess
    import sys

    code = (
        "import sys, slidingarm.cli\n"
        "from slidingarm.study import PAPER_MSE, reproduce, run, load_shipped\n"
        "load_shipped('sign').build()\n"
        "bad = [m for m in ('pandas', 'slidingarm.study.analysis', 'slidingarm.study.paper_report')"
        " if m in sys.modules]\n"
        "assert not bad, bad\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True)

