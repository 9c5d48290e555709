"""The one place that dispatches on an arm model's kind (compiled).

An arm model reaches compiled code as a *handle*: an integer ``kind``, a float64 parameter
table ``params`` of shape ``(rows, n)`` — one column per joint, the rows' meaning belonging to
that kind (the planar kind: ``[m; l; c; I]``; a spatial kind: joint placement, axis and
spatial inertia per joint) — and the gravity magnitude ``g``. Every kernel here takes the
handle first and forwards to the kind's own kernels; the loop, the controllers and the numpy
API of :class:`slidingarm.models.base.ArmModel` call only these. Adding a kind means: a code,
a branch in each kernel below, and a subclass of ``ArmModel``; the Python side only ever
builds handles of known kinds, so the fall-through of a branch (no kind matched) is
unreachable.

A table rather than a flat block: a view per call of the loop (a flat block reshaped) cost
about 5 % of the paper run, and every serial arm's parameters are per joint.

Workspace: every kernel takes ``work`` of shape ``(WORK_ROWS, n)``. After any kernel that
evaluates the model at a position ``q``, ``work`` holds that kind's position-dependent
kinematics of ``q`` (for the planar kind: the cosines and sines of the absolute angles, rows
0-1); :func:`rk4_step` with ``known=True`` reuses them for its first stage. That reuse is the
only contract between kernels through ``work``.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from slidingarm.models import _kernels as PK
from slidingarm.models import _spatial as SK

#: Solve ``a x = b`` for a symmetric positive definite ``a`` by Cholesky (no model in it:
#: plain linear algebra that the laws share with the planar kind).
cholesky_solve_into = PK.cholesky_solve_into

#: Kind codes.
KIND_PLANAR = 0
KIND_SERIAL = 1

#: Rows of the ``(WORK_ROWS, n)`` workspace every kernel here takes (the largest any kind needs).
WORK_ROWS = max(PK.WORK_ROWS, SK.WORK_ROWS)

_OPTS = {"cache": True, "nogil": True, "error_model": "numpy", "inline": "always"}


@njit(**_OPTS)
def mass_matrix(
    kind: int, params: np.ndarray, g: float, q: np.ndarray, out: np.ndarray, work: np.ndarray
) -> None:
    """:math:`M(q)` into ``out`` (n, n)."""
    if kind == KIND_PLANAR:
        PK.mass_matrix_into(params, q, out, work)
    elif kind == KIND_SERIAL:
        SK.mass_matrix_into(params, q, out, work)


@njit(**_OPTS)
def coriolis(
    kind: int,
    params: np.ndarray,
    g: float,
    q: np.ndarray,
    qd: np.ndarray,
    out: np.ndarray,
    work: np.ndarray,
) -> None:
    """The Coriolis matrix :math:`C(q, \\dot q)` into ``out`` (n, n)."""
    if kind == KIND_PLANAR:
        PK.coriolis_into(params, q, qd, out, work)
    elif kind == KIND_SERIAL:
        SK.coriolis_into(params, g, q, qd, out, work)


@njit(**_OPTS)
def gravity_torque(
    kind: int, params: np.ndarray, g: float, q: np.ndarray, out: np.ndarray, work: np.ndarray
) -> None:
    """:math:`G(q)` into ``out`` (n,)."""
    if kind == KIND_PLANAR:
        PK.gravity_into(params, g, q, out, work)
    elif kind == KIND_SERIAL:
        SK.gravity_into(params, g, q, out, work)


@njit(**_OPTS)
def bias(
    kind: int,
    params: np.ndarray,
    g: float,
    q: np.ndarray,
    qd: np.ndarray,
    out: np.ndarray,
    work: np.ndarray,
) -> None:
    """:math:`h(q, \\dot q) = C\\dot q + G` into ``out`` (n,)."""
    if kind == KIND_PLANAR:
        PK.bias_into(params, g, q, qd, out, work)
    elif kind == KIND_SERIAL:
        SK.bias_into(params, g, q, qd, out, work)


@njit(**_OPTS)
def mass_and_bias(
    kind: int,
    params: np.ndarray,
    g: float,
    q: np.ndarray,
    qd: np.ndarray,
    mmat: np.ndarray,
    h: np.ndarray,
    work: np.ndarray,
) -> None:
    """:math:`M(q)` into ``mmat`` and :math:`h(q, \\dot q)` into ``h``, sharing the kinematics."""
    if kind == KIND_PLANAR:
        PK.mass_and_bias_into(params, g, q, qd, mmat, h, work)
    elif kind == KIND_SERIAL:
        SK.mass_and_bias_into(params, g, q, qd, mmat, h, work)


@njit(**_OPTS)
def inverse_dynamics(
    kind: int,
    params: np.ndarray,
    g: float,
    q: np.ndarray,
    qd: np.ndarray,
    qdd: np.ndarray,
    out: np.ndarray,
    work: np.ndarray,
) -> None:
    """:math:`\\tau = M(q)\\ddot q + h(q, \\dot q)` into ``out`` (n,)."""
    if kind == KIND_PLANAR:
        # the planar kernel's two steps, called here directly: one level of inlining fewer
        # in the loop (numba copies an inlined body once per level), i.e. a quicker compile
        PK.angles_into(q, work)
        PK._rnea_from_angles(params, g, qd, qdd, 1.0, out, work)
    elif kind == KIND_SERIAL:
        SK.inverse_dynamics_into(params, g, q, qd, qdd, out, work)


@njit(**_OPTS)
def forward_dynamics(
    kind: int,
    params: np.ndarray,
    g: float,
    q: np.ndarray,
    qd: np.ndarray,
    tau: np.ndarray,
    out: np.ndarray,
    work: np.ndarray,
) -> bool:
    """:math:`\\ddot q = M(q)^{-1}(\\tau - h)` into ``out`` (n,); ``False`` if ``M`` is not
    positive definite."""
    if kind == KIND_PLANAR:
        return PK.forward_dynamics_into(params, g, q, qd, tau, out, work)
    if kind == KIND_SERIAL:
        return SK.forward_dynamics_into(params, g, q, qd, tau, out, work)
    return False


@njit(**_OPTS)
def potential_energy(
    kind: int, params: np.ndarray, g: float, q: np.ndarray, work: np.ndarray
) -> float:
    """Potential energy :math:`V(q)` (J)."""
    if kind == KIND_PLANAR:
        return PK.potential_energy(params, g, q, work)
    if kind == KIND_SERIAL:
        return SK.potential_energy(params, g, q, work)
    return np.nan


@njit(**_OPTS)
def rk4_step(
    kind: int,
    params: np.ndarray,
    g: float,
    q: np.ndarray,
    qd: np.ndarray,
    tau: np.ndarray,
    h: float,
    known: bool,
    scratch: np.ndarray,
    work: np.ndarray,
) -> bool:
    """Advance ``(q, qd)`` in place by one RK4 step of length ``h`` with ``tau`` held.

    ``scratch`` is ``(RK4_ROWS, n)``; ``known`` says that ``work`` holds the kinematics of
    ``q`` (see the module docstring). ``False`` if a mass matrix was not positive definite.
    """
    if kind == KIND_PLANAR:
        return PK.rk4_step(params, g, q, qd, tau, h, known, scratch, work)
    if kind == KIND_SERIAL:
        return SK.rk4_step(params, g, q, qd, tau, h, known, scratch, work)
    return False


#: Rows of the ``(RK4_ROWS, n)`` scratch of :func:`rk4_step`.
RK4_ROWS = max(PK.RK4_ROWS, SK.RK4_ROWS)


@njit(**_OPTS)
def same_kinematics(kind: int, a: np.ndarray, b: np.ndarray) -> bool:
    """Whether two models of ``kind`` have the same q-only kinematics (what ``work`` holds
    after a kernel), so that one's kinematics of ``q`` can stand for the other's."""
    if kind == KIND_SERIAL:
        for r in range(SK.P_MASS):
            for j in range(a.shape[1]):
                if a[r, j] != b[r, j]:
                    return False
    return True
