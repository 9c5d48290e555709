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
from numba import njit, types
from numba.extending import overload

from slidingarm._pointers import FunctionPointer, function_at, inline_unless_linked, linked
from slidingarm._pointers import as_writable as _w
from slidingarm.models import _kernels as PK
from slidingarm.models import _spatial as SK

#: Kind codes.
KIND_PLANAR = 0
KIND_SERIAL = 1

#: Rows of the ``(WORK_ROWS, n)`` workspace every kernel here takes (the largest any kind needs).
WORK_ROWS = max(PK.WORK_ROWS, SK.WORK_ROWS)

_OPTS = {"cache": True, "nogil": True, "error_model": "numpy", "inline": "always"}

# ---------------------------------------------------------------------- the serial kind's kernels
# The serial kind's kernels are reached through the addresses of their C wrappers, kept in
# column 0 of rows SK.P_FN + FN_* of the kind's parameter table (an address is below 2**53,
# so a float64 holds it exactly): the loop every arm shares then compiles none of them, and
# they are compiled (and cached) when a serial arm is first used. A call through an address
# costs tens of nanoseconds against microseconds of spatial algebra.
_V = types.float64[::1]
_M = types.float64[:, ::1]
_F = types.float64
SERIAL_SIGNATURES = (
    ("mass_matrix_into", types.void(_M, _V, _M, _M)),
    ("coriolis_into", types.void(_M, _F, _V, _V, _M, _M)),
    ("gravity_into", types.void(_M, _F, _V, _V, _M)),
    ("bias_into", types.void(_M, _F, _V, _V, _V, _M)),
    ("mass_and_bias_into", types.void(_M, _F, _V, _V, _M, _V, _M)),
    ("inverse_dynamics_into", types.void(_M, _F, _V, _V, _V, _V, _M)),
    ("forward_dynamics_into", types.boolean(_M, _F, _V, _V, _V, _V, _M)),
    ("potential_energy", types.float64(_M, _F, _V, _M)),
    ("rk4_step", types.boolean(_M, _F, _V, _V, _V, _F, types.boolean, _M, _M)),
)
(FN_MASS, FN_CORIOLIS, FN_GRAVITY, FN_BIAS, FN_MASS_BIAS, FN_INVERSE, FN_FORWARD,
 FN_POTENTIAL, FN_RK4) = range(len(SERIAL_SIGNATURES))  # fmt: skip
mass_matrix_at = function_at(types.FunctionType(SERIAL_SIGNATURES[FN_MASS][1]))
coriolis_at = function_at(types.FunctionType(SERIAL_SIGNATURES[FN_CORIOLIS][1]))
gravity_at = function_at(types.FunctionType(SERIAL_SIGNATURES[FN_GRAVITY][1]))
bias_at = function_at(types.FunctionType(SERIAL_SIGNATURES[FN_BIAS][1]))
mass_and_bias_at = function_at(types.FunctionType(SERIAL_SIGNATURES[FN_MASS_BIAS][1]))
inverse_at = function_at(types.FunctionType(SERIAL_SIGNATURES[FN_INVERSE][1]))
forward_at = function_at(types.FunctionType(SERIAL_SIGNATURES[FN_FORWARD][1]))
potential_at = function_at(types.FunctionType(SERIAL_SIGNATURES[FN_POTENTIAL][1]))
rk4_at = function_at(types.FunctionType(SERIAL_SIGNATURES[FN_RK4][1]))

_SERIAL_POINTERS: list[FunctionPointer] = []


def serial_addresses() -> list[float]:
    """The addresses of the serial kind's kernels, in ``FN_*`` order (compiled on first use)."""
    if not _SERIAL_POINTERS:
        _SERIAL_POINTERS.extend(
            FunctionPointer(getattr(SK, name), sig) for name, sig in SERIAL_SIGNATURES
        )
    return [float(f.address) for f in _SERIAL_POINTERS]


@njit(**_OPTS)
def _fn(params: np.ndarray, k: int) -> int:
    return int(params[SK.P_FN + k, 0])


#: The planar kind's RK4 step as a pointer (:func:`step_address`), made on first use.
_PLANAR_STEP: list[FunctionPointer] = []


def step_address(kind: int, params: np.ndarray) -> int:
    """The address of the C wrapper of the RK4 step of a model of ``kind`` with ``params``
    (signature ``SERIAL_SIGNATURES[FN_RK4]``, every kind's): what the linked per-run loop
    calls (:func:`plant_step`). The planar kind's step is compiled (or loaded from numba's
    cache) on first use; a serial arm's is in its table. So the loop compiles no kind's step
    into itself, and its own compilation need not wait for them
    (:func:`slidingarm._engine.run_one`)."""
    if kind == KIND_SERIAL:
        return int(params[SK.P_FN + FN_RK4, 0])
    if kind != KIND_PLANAR:
        raise ValueError(f"unknown model kind {kind}")
    if not _PLANAR_STEP:
        _PLANAR_STEP.append(FunctionPointer(PK.rk4_step, SERIAL_SIGNATURES[FN_RK4][1]))
    return _PLANAR_STEP[0].address


def plant_step(
    link: np.ndarray,
    kind: int,
    address: int,
    params: np.ndarray,
    g: float,
    q: np.ndarray,
    qd: np.ndarray,
    tau: np.ndarray,
    h: float,
    known: bool,
    scratch: np.ndarray,
    work: np.ndarray,
) -> bool:  # pragma: no cover - typed by its overload
    """:func:`rk4_step` as the per-run loop takes it: with ``link``
    :data:`~slidingarm._pointers.LINKED`, the step at ``address`` (:func:`step_address`),
    else :func:`rk4_step` of ``kind`` (``address`` unused)."""
    raise NotImplementedError


@overload(
    plant_step,
    jit_options={"nogil": True, "error_model": "numpy", "forceinline": True},
    inline=inline_unless_linked,
)
def _plant_step_typed(link, kind, address, params, g, q, qd, tau, h, known, scratch, work):  # type: ignore[no-untyped-def]
    if linked(link):

        def at(link, kind, address, params, g, q, qd, tau, h, known, scratch, work):  # type: ignore[no-untyped-def]
            return rk4_at(address)(
                _w(params), g, _w(q), _w(qd), _w(tau), h, known, _w(scratch), _w(work)
            )

        return at

    def direct(link, kind, address, params, g, q, qd, tau, h, known, scratch, work):  # type: ignore[no-untyped-def]
        return rk4_step(kind, params, g, q, qd, tau, h, known, scratch, work)

    return direct


@njit(**_OPTS)
def mass_matrix(
    kind: int, params: np.ndarray, g: float, q: np.ndarray, out: np.ndarray, work: np.ndarray
) -> None:
    """:math:`M(q)` into ``out`` (n, n)."""
    if kind == KIND_PLANAR:
        PK.mass_matrix_into(params, q, out, work)
    elif kind == KIND_SERIAL:
        mass_matrix_at(_fn(params, FN_MASS))(_w(params), _w(q), _w(out), _w(work))


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
        coriolis_at(_fn(params, FN_CORIOLIS))(_w(params), g, _w(q), _w(qd), _w(out), _w(work))


@njit(**_OPTS)
def gravity_torque(
    kind: int, params: np.ndarray, g: float, q: np.ndarray, out: np.ndarray, work: np.ndarray
) -> None:
    """:math:`G(q)` into ``out`` (n,)."""
    if kind == KIND_PLANAR:
        PK.gravity_into(params, g, q, out, work)
    elif kind == KIND_SERIAL:
        gravity_at(_fn(params, FN_GRAVITY))(_w(params), g, _w(q), _w(out), _w(work))


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
        bias_at(_fn(params, FN_BIAS))(_w(params), g, _w(q), _w(qd), _w(out), _w(work))


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
        mass_and_bias_at(_fn(params, FN_MASS_BIAS))(
            _w(params), g, _w(q), _w(qd), _w(mmat), _w(h), _w(work)
        )


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
        inverse_at(_fn(params, FN_INVERSE))(
            _w(params), g, _w(q), _w(qd), _w(qdd), _w(out), _w(work)
        )


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
        return forward_at(_fn(params, FN_FORWARD))(
            _w(params), g, _w(q), _w(qd), _w(tau), _w(out), _w(work)
        )
    return False


@njit(**_OPTS)
def potential_energy(
    kind: int, params: np.ndarray, g: float, q: np.ndarray, work: np.ndarray
) -> float:
    """Potential energy :math:`V(q)` (J)."""
    if kind == KIND_PLANAR:
        return PK.potential_energy(params, g, q, work)
    if kind == KIND_SERIAL:
        return potential_at(_fn(params, FN_POTENTIAL))(_w(params), g, _w(q), _w(work))
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
        return rk4_at(_fn(params, FN_RK4))(
            _w(params), g, _w(q), _w(qd), _w(tau), h, known, _w(scratch), _w(work)
        )
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
