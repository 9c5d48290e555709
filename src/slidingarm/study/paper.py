"""The paper's own facts (docs/theory.md §2, §7): its published MSE table and ranking, the cases of its
study and the figures that show them, and the Craig split of the velocity terms its model uses.

Everything here belongs to the paper being reproduced, not to the library: the library's
arms, laws and metrics are general, and the report renderer (:mod:`slidingarm.report`) knows
no study.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from slidingarm.models.planar import PlanarArm

__all__ = [
    "PAPER_FIGURES",
    "PAPER_MSE",
    "PAPER_MSE_SWITCHING",
    "RANKING",
    "ScenarioKind",
    "craig_split",
    "figure_stem",
    "paper_figure_number",
]

FloatArray = NDArray[np.float64]

#: The paper's MSE table (docs/theory.md §7), by controller. It belongs to the paper's sign-function case
#: (its section "Fast terminal sliding mode control with sign function", after Figs. 3-9):
#: :data:`PAPER_MSE_SWITCHING`.
PAPER_MSE: dict[str, float] = {"ftsmc": 0.1331, "tsmc": 0.1976, "pdsmc": 0.4698}

#: The switching function of the paper's case whose MSE table :data:`PAPER_MSE` is.
PAPER_MSE_SWITCHING: str = "sign"

#: The paper's ranking, best first.
RANKING: tuple[str, ...] = ("ftsmc", "tsmc", "pdsmc")

#: The paper's cases (docs/theory.md §7) a scenario of the study can be: sign switching (paper Figs. 3–9
#: and its MSE table), tanh switching (Figs. 10–15), tanh switching with Gaussian noise on the
#: measured positions (Figs. 16–22).
ScenarioKind = Literal["sign", "tanh", "noise"]

#: Scenario kind (:data:`ScenarioKind`) → figure name (those of
#: :data:`slidingarm.plotting.FIGURES`, in their order) → the paper's figure number(s) showing
#: the same thing (None: the paper has no such figure). From the paper's captions: Figs. 3–9
#: sign switching, 10–15 tanh, 16–22 tanh with noise; the paper shows joint 1 only for torque,
#: sliding variable, velocity and error.
PAPER_FIGURES: dict[ScenarioKind, dict[str, str | None]] = {
    "sign": {
        "tracking_all": "3 and 9",
        "tracking_joint1": "4",
        "torque": "5",
        "sliding": "6",
        "velocity": "7",
        "error": "8",
        "steady_state": None,
    },
    "tanh": {
        "tracking_all": "15",
        "tracking_joint1": "10",
        "torque": "11",
        "sliding": "12",
        "velocity": "13",
        "error": "14",
        "steady_state": None,
    },
    "noise": {
        "tracking_all": "21",
        "tracking_joint1": "16",
        "torque": "17",
        "sliding": "18",
        "velocity": "19",
        "error": "20",
        "steady_state": "22",
    },
}


def craig_split(arm: PlanarArm, q: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """The paper's (Craig's) split of the velocity terms of a 3-joint arm (docs/theory.md §1).

    .. math:: C(q,\\dot q)\\dot q = B(q)[\\dot q\\dot q] + C_2(q)[\\dot q^2],\\quad
              [\\dot q\\dot q] = (\\dot q_1\\dot q_2, \\dot q_1\\dot q_3, \\dot q_2\\dot q_3),
              [\\dot q^2] = (\\dot q_1^2, \\dot q_2^2, \\dot q_3^2)

    The velocity term is a quadratic form in :math:`\\dot q`, so both matrices follow exactly
    by polarisation: column ``i`` of :math:`C_2` is :math:`c(e_i)` and the column of
    :math:`B` for the pair ``(i, j)`` is :math:`c(e_i + e_j) - c(e_i) - c(e_j)`, where
    :math:`c(v) = C(q, v)v` (:meth:`~slidingarm.models.planar.PlanarArm.coriolis`).

    Parameters
    ----------
    arm : PlanarArm
        A 3-joint arm.
    q : array_like, shape (3,) or (B, 3)
        Joint angles (rad), checked as the arm checks a state.

    Returns
    -------
    B, C2 : ndarray, shape (3, 3) or (B, 3, 3) each

    Raises
    ------
    ValueError
        For an arm that does not have 3 joints, or a ``q`` the arm rejects.
    """
    if arm.n != 3:
        raise ValueError(f"craig_split is defined for a 3-joint arm; this arm has {arm.n} joints")
    eye = np.eye(3)

    def vel_term(v: FloatArray) -> FloatArray:
        return np.asarray(arm.coriolis(q, v) @ v, dtype=np.float64)

    sq = [vel_term(eye[i]) for i in range(3)]
    c2 = np.stack(sq, axis=-1)
    pairs = [(0, 1), (0, 2), (1, 2)]
    bmat = np.stack([vel_term(eye[i] + eye[j]) - sq[i] - sq[j] for i, j in pairs], axis=-1)
    return bmat, c2


def paper_figure_number(kind: str | None, figure: str) -> int | None:
    """The paper's (first) figure number for ``figure`` (a name of
    :data:`slidingarm.plotting.FIGURES`) in the paper's case ``kind`` (:data:`ScenarioKind`),
    e.g. 5 for the sign case's torque; None when the paper has no such figure or ``kind`` is not
    one of its cases."""
    if kind not in PAPER_FIGURES:
        return None
    numbers = PAPER_FIGURES[kind].get(figure)
    if numbers is None:
        return None
    first = numbers.replace("–", " ").split()[0]
    return int(first)


def figure_stem(scenario: str, figure: str, kind: str | None = None) -> str:
    """The file stem of a scenario's figure: ``<scenario>_fig<NN>_<figure>`` with the paper's
    figure number ``NN`` (two digits, :func:`paper_figure_number`) when the paper has that
    figure, else ``<scenario>_<figure>``. ``kind`` is the paper's case the scenario runs
    (default: the scenario's name if it is one, as the study's ``sign``, ``tanh``, ``noise``),
    so ``figure_stem("sign", "torque")`` is ``"sign_fig05_torque"``."""
    number = paper_figure_number(scenario if kind is None else kind, figure)
    return f"{scenario}_{figure}" if number is None else f"{scenario}_fig{number:02d}_{figure}"
