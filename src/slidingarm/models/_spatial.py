"""Compiled spatial-algebra dynamics of a serial chain of revolute and prismatic joints.

Every function is a numba ``njit`` kernel over plain float arrays that allocates nothing: the
callers pass the outputs and a ``(WORK_ROWS, n)`` workspace (column ``i`` belongs to joint
``i``).

**Parameters.** A chain is the table ``p`` of shape ``(ROWS, n)``; column ``i`` describes joint
``i`` and the body it moves (the links fixed to that body merged into it):

* rows 0-8: ``R0``, the joint frame's orientation in its parent's frame at ``q = 0``
  (row-major), rows 9-11: ``p0``, its origin there;
* rows 12-14: the unit joint axis ``a`` in the joint frame, row 15: 0 revolute, 1 prismatic;
* row 16: the body's mass ``m``, rows 17-19: its first moment ``h = m c`` (``c`` the centre of
  mass), rows 20-25: its rotational inertia about the joint frame's origin,
  ``I_o = I_c + m(|c|^2 1 - c c^T)``, as ``xx, yy, zz, xy, xz, yz`` — all in the joint frame.

A revolute joint places its body at ``x_parent = R0 Rot(a, q) x + p0``, a prismatic one at
``x_parent = R0 (x + a q) + p0``. Gravity is ``(0, 0, -g)`` in the root frame.

**The kernels take the table in joint-aligned frames** (:func:`aligned`, built once per arm
by :attr:`slidingarm.SerialArm.params`): each body's frame turned about its origin so that
its joint's axis is ``a = e_z``, which describes the same arm. Any axis can be aligned, so
this is the general path; for the axis-aligned URDFs of the UR5 and the Panda the turns are
exact signed permutations. The kinematics, Newton-Euler and the articulated-body algorithm
are written for ``a = e_z`` (Pinocchio's RevoluteZ and PrismaticZ: ``S`` is a unit
coordinate vector, ``Rot(e_z, q)`` has four non-trivial entries); the composite-rigid-body
and Coriolis kernels read the axis rows.

**Spatial algebra** (Featherstone, *Rigid Body Dynamics Algorithms*, 2008), in each body's own
frame: a motion is ``(ω, v)`` (angular first, linear velocity of the frame's origin), a force
``(n, f)``. The rigid-body inertia acts as ``I (ω, v) = (I_o ω + h × v, m v - h × ω)``, the
cross products are ``(ω, v) × (ω', v') = (ω × ω', ω × v' + v × ω')`` and
``(ω, v) ×* (n, f) = (ω × n + v × f, ω × f)``. With ``E = R_pc^T`` and ``r`` the rotation and
origin of a body in its parent, a motion is carried from the parent as
``(E ω, E (v + ω × r))`` and a force to the parent as ``(R_pc n + r × R_pc f, R_pc f)``.
The joint's motion subspace ``S`` is ``(a, 0)`` (revolute) or ``(0, a)`` (prismatic).

**Algorithms**: recursive Newton-Euler (inverse dynamics, the bias ``h = C q̇ + G``, gravity),
O(n); the composite-rigid-body algorithm (``M``), O(n²); the articulated-body algorithm
(forward dynamics), O(n), which works in the root frame at its origin instead. Gravity enters
as the root's acceleration ``(0, 0, 0, 0, 0, g)``.

**Workspace contract** (see :mod:`slidingarm.models._dispatch`): every kernel that evaluates
at ``q`` leaves in rows ``W_CS``, ``W_CS + 1`` the cosine and sine of each coordinate, which
:func:`rk4_step` reuses when told they are known (the articulated-body algorithm builds each
body's pose from them); those that go through :func:`kinematics_into` also leave in rows
0-11 the body's rotation ``R_pc`` (rows 0-8) and origin ``r`` (rows 9-11) in its parent.

The articulated-body algorithm keeps its per-body quantities in a buffer of groups of 8
bodies (:func:`_aba`): on the stack for up to :data:`STACK_BODIES` bodies, in the workspace's
rows :data:`W_AB` to ``W_CS - 1`` for a longer chain; rows 0-11 and ``W_CS`` are left as the
kinematics left them.

**Cost** (``benchmarks/bench_serial.py``): the kernels reached through an address borrow
their arrays (:func:`_borrow`) and the spatial helpers are inlined, so a step pays neither
reference-count atomics nor calls inside a pass. The scalar passes are bound by the two
floating-point multiply pipes, not by latency (measured: shortening the chains of passes 2
and 3 by look-ahead gained nothing); so the part of the articulated-body pass that needs no
other body (each body's inertia at the root and its bias force, about two thirds of its
multiplications) runs as vector code over a group's 8 bodies, and the sines and cosines are
inline arithmetic (:func:`_cos_sin`) rather than calls into libm. Measured on the UR5 (AMD
EPYC, AVX-512, min of interleaved repeats): forward dynamics 0.49 -> 0.38 µs, an RK4 step
with its kinematics 1.61 -> 1.29 µs, inverse dynamics 0.32 -> 0.26 µs. On an AVX2 host (AMD
EPYC, 16 vector registers) the pose and the velocities of pass 1 are two loops: one loop
carrying both spilt most of its values to the stack (split: an RK4 step -7 to -10 % on the UR5
and the Panda, same bits).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit, types
from numba.core import cgutils
from numba.extending import intrinsic
from numba.np.arrayobj import make_array, populate_array

from slidingarm import _vecmath as VM
from slidingarm.models import _kernels as PK

#: Rows of the parameter table (the physical ones; the kind's table adds the kernels' addresses
#: in rows ``P_FN..``, see :mod:`slidingarm.models._dispatch`).
ROWS = 26
P_FN = 26
P_AXIS = 12
P_TYPE = 15
P_MASS = 16
P_H = 17
P_IO = 20

# workspace rows
W_ROT = 0  # 9: R_pc
W_POS = 9  # 3: r
W_V = 12  # 6: the body's velocity (coriolis_into)
W_A = 18  # 6: its acceleration (RNEA) or the derivative of its joint's axis (coriolis_into)
W_F = 24  # 6: its force (RNEA)
W_IA = 30  # 10: composite inertia (CRBA)
W_U = 66  # 6: the joint's axis in the root frame (coriolis_into)
W_T = 74  # 12: the body's rotation and origin in the root frame (coriolis_into)
#: Rows of the workspace these kernels use.
W_CS = 101  # 2: cos and sin of each coordinate
WORK_ROWS = 103

# fastmath "contract" only lets LLVM fuse a product and a sum into one FMA (one rounding
# instead of two, so each such result is as accurate or more): no reassociation, no
# assumption about NaN, infinities or signed zeros, so a non-finite state still propagates to
# the loop's checks. Results move by ulps; the agreement tests (1e-9 against Pinocchio, 1e-6
# closed loop against MuJoCo) are far coarser. Measured: -10 % on the step, -20 % on ABA.
_OPTS = {"cache": True, "nogil": True, "error_model": "numpy", "fastmath": {"contract"}}
# the small spatial-algebra helpers are inlined by numba: LLVM kept the largest of them
# (_carry_inertia, 22 arguments) a call, with its result returned through memory, six times
# per articulated-body pass
_INLINE = {**_OPTS, "inline": "always"}


@intrinsic
def _borrow(typingctx: Any, arr: Any) -> Any:
    """An alias of ``arr`` that takes no part in reference counting (a null memory-info
    pointer; the same device as the loop's ``slidingarm._engine._borrow``).

    Every array argument of a kernel costs an atomic increment at its entry and a decrement
    at its exit; the rk4 step calls nine kernels on its arrays, which made those atomics
    about a tenth of its time. The kernels reached through an address borrow their arrays on
    entry and hand the aliases on. The caller holds the arrays for the call's duration.
    """
    if not isinstance(arr, types.Array):
        return None

    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        ary = args[0]
        return builder.insert_value(ary, cgutils.get_null_value(ary.type.elements[0]), 0)

    return arr(arr), codegen


def _axis_frame(axis: np.ndarray) -> np.ndarray:
    """A rotation ``Q`` whose third column is the unit ``axis``: first column the coordinate
    axis least aligned with it, made orthogonal, second ``axis × first``. For an axis along
    a coordinate axis (``±x``, ``±y``, ``±z``) ``Q`` is an exact signed permutation."""
    a = np.asarray(axis, dtype=float)
    k = int(np.argmin(np.abs(a)))
    x = -a[k] * a
    x[k] += 1.0
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(a, x), a])


def aligned(table: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The same chain described in *joint-aligned* body frames: every joint's axis is its
    body's ``+z``. The kernels of this module take this table.

    With :math:`Q_i` = :func:`_axis_frame` of joint ``i``'s axis (:math:`Q_i e_z = a_i`) and
    :math:`Q_{-1} = 1`, body ``i``'s aligned frame is its frame turned by :math:`Q_i` about its
    origin (:math:`x = Q_i x'`), so :math:`\\mathrm{Rot}(a_i, q) Q_i = Q_i \\mathrm{Rot}(e_z, q)`
    and the table becomes :math:`R_0' = Q_{i-1}^T R_0 Q_i`, :math:`p_0' = Q_{i-1}^T p_0`,
    :math:`a' = e_z`, :math:`h' = Q_i^T h`, :math:`I_o' = Q_i^T I_o Q_i` (``m`` and the
    joint's kind unchanged). Joint coordinates, ``M``, ``h``, ``q̈`` and torques are those of
    the original table; a body's orientation in the root is :math:`R_{0i}' Q_i^T`.

    Returns the aligned table (a copy, same shape) and the frames ``Q`` (n, 3, 3).
    """
    t = np.array(table, dtype=float)
    n = t.shape[1]
    frames = np.empty((n, 3, 3))
    prev = np.eye(3)
    for i in range(n):
        qf = _axis_frame(t[P_AXIS : P_AXIS + 3, i])
        t[0:9, i] = (prev.T @ t[0:9, i].reshape(3, 3) @ qf).reshape(9)
        t[9:12, i] = prev.T @ t[9:12, i]
        t[P_AXIS : P_AXIS + 3, i] = (0.0, 0.0, 1.0)
        t[P_H : P_H + 3, i] = qf.T @ t[P_H : P_H + 3, i]
        xx, yy, zz, xy, xz, yz = t[P_IO : P_IO + 6, i]
        io = qf.T @ np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]]) @ qf
        t[P_IO : P_IO + 6, i] = (io[0, 0], io[1, 1], io[2, 2], io[0, 1], io[0, 2], io[1, 2])
        frames[i] = qf
        prev = qf
    return t, frames


@njit(**_INLINE)
def _place(p: np.ndarray, i: int, c: float, s: float, qi: float, work: np.ndarray) -> None:
    """Body ``i``'s ``R_pc`` and ``r`` from its coordinate ``qi`` and, if revolute, the cosine
    ``c`` and sine ``s`` of it, in aligned frames (axis ``e_z``): ``R_pc = R_0 Rot(e_z, q)``,
    whose columns are ``c R_0[:, 0] + s R_0[:, 1]``, ``c R_0[:, 1] - s R_0[:, 0]`` and
    ``R_0[:, 2]``; a prismatic joint has ``R_pc = R_0``, ``r = p_0 + q R_0[:, 2]``."""
    if p[P_TYPE, i] == 0.0:
        for row in range(3):
            b0 = p[3 * row, i]
            b1 = p[3 * row + 1, i]
            work[3 * row, i] = b0 * c + b1 * s
            work[3 * row + 1, i] = b1 * c - b0 * s
            work[3 * row + 2, i] = p[3 * row + 2, i]
            work[W_POS + row, i] = p[9 + row, i]
    else:
        for row in range(3):
            b2 = p[3 * row + 2, i]
            work[3 * row, i] = p[3 * row, i]
            work[3 * row + 1, i] = p[3 * row + 1, i]
            work[3 * row + 2, i] = b2
            work[W_POS + row, i] = p[9 + row, i] + qi * b2


@njit(**_INLINE)
def _cos_sin(x: float) -> tuple[float, float]:
    """``(cos x, sin x)`` from one range reduction (:func:`slidingarm._vecmath.sincos`, at most
    1 ulp, inline arithmetic: half the time of libm's ``sincos`` call here) for
    ``|x| <=`` :data:`slidingarm._vecmath.TRIG_MAX`; libm's beyond (and for NaN, ``±inf``)."""
    if abs(x) <= VM.TRIG_MAX:
        sn, c = VM.sincos(x)
        return c, sn
    return math.cos(x), math.sin(x)


@njit(**_OPTS)
def kinematics_into(p: np.ndarray, q: np.ndarray, work: np.ndarray) -> None:
    """Each body's rotation ``R_pc`` and origin ``r`` in its parent at ``q`` into rows 0-11,
    and the cosine and sine of each coordinate into rows ``W_CS``, ``W_CS + 1``."""
    for i in range(q.shape[0]):
        c, s = _cos_sin(q[i])
        work[W_CS, i] = c
        work[W_CS + 1, i] = s
        _place(p, i, c, s, q[i], work)


@njit(**_INLINE)
def _angles_into(q: np.ndarray, work: np.ndarray) -> None:
    """The cosine and sine of each coordinate into rows ``W_CS``, ``W_CS + 1`` (all that
    :func:`aba_known` needs of the kinematics)."""
    for i in range(q.shape[0]):
        c, s = _cos_sin(q[i])
        work[W_CS, i] = c
        work[W_CS + 1, i] = s


@njit(**_INLINE)
def _angles_shifted_into(
    base: np.ndarray, dq: np.ndarray, q: np.ndarray, work: np.ndarray
) -> None:
    """:func:`_angles_into` at ``q = q_0 + dq`` given the cosines and sines of ``q_0`` in
    ``base`` (2, n), for the small steps of RK4's stages: each angle with
    :math:`|\\delta| \\le 2^{-5}` is rotated by :func:`slidingarm.models._kernels.rotated` (exact
    to rounding there); a larger step takes the sine and cosine of ``q``."""
    for i in range(q.shape[0]):
        d = dq[i]
        if abs(d) <= 0.03125:
            c, s = PK.rotated(base[0, i], base[1, i], d)
        else:
            c, s = _cos_sin(q[i])
        work[W_CS, i] = c
        work[W_CS + 1, i] = s


@njit(**_INLINE)
def _motion_in(
    work: np.ndarray, i: int, wx: float, wy: float, wz: float, vx: float, vy: float, vz: float
) -> tuple[float, float, float, float, float, float]:
    """A motion of the parent carried into body ``i``: ``(E ω, E (v + ω × r))``."""
    rx = work[W_POS, i]
    ry = work[W_POS + 1, i]
    rz = work[W_POS + 2, i]
    ux = vx + wy * rz - wz * ry
    uy = vy + wz * rx - wx * rz
    uz = vz + wx * ry - wy * rx
    r00 = work[0, i]
    r01 = work[1, i]
    r02 = work[2, i]
    r10 = work[3, i]
    r11 = work[4, i]
    r12 = work[5, i]
    r20 = work[6, i]
    r21 = work[7, i]
    r22 = work[8, i]
    return (
        r00 * wx + r10 * wy + r20 * wz,
        r01 * wx + r11 * wy + r21 * wz,
        r02 * wx + r12 * wy + r22 * wz,
        r00 * ux + r10 * uy + r20 * uz,
        r01 * ux + r11 * uy + r21 * uz,
        r02 * ux + r12 * uy + r22 * uz,
    )


@njit(**_INLINE)
def _force_out(
    work: np.ndarray, i: int, nx: float, ny: float, nz: float, fx: float, fy: float, fz: float
) -> tuple[float, float, float, float, float, float]:
    """A force on body ``i`` carried to its parent: ``(R n + r × R f, R f)``."""
    r00 = work[0, i]
    r01 = work[1, i]
    r02 = work[2, i]
    r10 = work[3, i]
    r11 = work[4, i]
    r12 = work[5, i]
    r20 = work[6, i]
    r21 = work[7, i]
    r22 = work[8, i]
    gx = r00 * fx + r01 * fy + r02 * fz
    gy = r10 * fx + r11 * fy + r12 * fz
    gz = r20 * fx + r21 * fy + r22 * fz
    rx = work[W_POS, i]
    ry = work[W_POS + 1, i]
    rz = work[W_POS + 2, i]
    return (
        r00 * nx + r01 * ny + r02 * nz + ry * gz - rz * gy,
        r10 * nx + r11 * ny + r12 * nz + rz * gx - rx * gz,
        r20 * nx + r21 * ny + r22 * nz + rx * gy - ry * gx,
        gx,
        gy,
        gz,
    )


@njit(**_INLINE)
def _inertia_times(
    p: np.ndarray, i: int, wx: float, wy: float, wz: float, vx: float, vy: float, vz: float
) -> tuple[float, float, float, float, float, float]:
    """The rigid-body inertia of body ``i`` times a motion (:func:`_rigid_times`)."""
    return _rigid_times(
        p[P_MASS, i], p[P_H, i], p[P_H + 1, i], p[P_H + 2, i],
        p[P_IO, i], p[P_IO + 1, i], p[P_IO + 2, i], p[P_IO + 3, i], p[P_IO + 4, i], p[P_IO + 5, i],
        wx, wy, wz, vx, vy, vz,
    )  # fmt: skip


@njit(**_OPTS)
def rnea_known(
    p: np.ndarray,
    g: float,
    qd: np.ndarray,
    vel: float,
    qdd: np.ndarray,
    acc: float,
    grav: float,
    out: np.ndarray,
    work: np.ndarray,
) -> None:
    """Recursive Newton-Euler with the kinematics in ``work``:
    :math:`\\tau = M(q)\\,(acc\\,\\ddot q) + C(q, vel\\,\\dot q)\\,vel\\,\\dot q + grav\\,G(q)`.

    Forward: :math:`v_i = X_i v_{i-1} + S_i \\dot q_i`,
    :math:`a_i = X_i a_{i-1} + S_i \\ddot q_i + v_i \\times S_i \\dot q_i` from
    :math:`a_{-1} = (0, 0, 0, 0, 0, grav\\,g)`, :math:`f_i = I_i a_i + v_i \\times^* I_i v_i`;
    backward: :math:`\\tau_i = S_i^T f_i`, :math:`f_{i-1} \\mathrel{+}= X_i^T f_i`.
    """
    n = qd.shape[0]
    wx = 0.0
    wy = 0.0
    wz = 0.0
    vx = 0.0
    vy = 0.0
    vz = 0.0
    bx = 0.0
    by = 0.0
    bz = 0.0
    cx = 0.0
    cy = 0.0
    cz = grav * g
    for i in range(n):
        wx, wy, wz, vx, vy, vz = _motion_in(work, i, wx, wy, wz, vx, vy, vz)
        bx, by, bz, cx, cy, cz = _motion_in(work, i, bx, by, bz, cx, cy, cz)
        dq = vel * qd[i]
        ddq = acc * qdd[i]
        # S = (e_z, 0) or (0, e_z); (w, v) x S dq = (w x e_z dq, v x e_z dq) or (0, w x e_z dq)
        if p[P_TYPE, i] == 0.0:
            wz += dq
            bx += wy * dq
            by -= wx * dq
            bz += ddq
            cx += vy * dq
            cy -= vx * dq
        else:
            vz += dq
            cx += wy * dq
            cy -= wx * dq
            cz += ddq
        n1x, n1y, n1z, f1x, f1y, f1z = _inertia_times(p, i, wx, wy, wz, vx, vy, vz)
        n2x, n2y, n2z, f2x, f2y, f2z = _inertia_times(p, i, bx, by, bz, cx, cy, cz)
        work[W_F, i] = n2x + wy * n1z - wz * n1y + vy * f1z - vz * f1y
        work[W_F + 1, i] = n2y + wz * n1x - wx * n1z + vz * f1x - vx * f1z
        work[W_F + 2, i] = n2z + wx * n1y - wy * n1x + vx * f1y - vy * f1x
        work[W_F + 3, i] = f2x + wy * f1z - wz * f1y
        work[W_F + 4, i] = f2y + wz * f1x - wx * f1z
        work[W_F + 5, i] = f2z + wx * f1y - wy * f1x
    for i in range(n - 1, -1, -1):
        out[i] = work[W_F + 2, i] if p[P_TYPE, i] == 0.0 else work[W_F + 5, i]
        if i > 0:
            nx, ny, nz, fx, fy, fz = _force_out(
                work, i, work[W_F, i], work[W_F + 1, i], work[W_F + 2, i],
                work[W_F + 3, i], work[W_F + 4, i], work[W_F + 5, i],
            )  # fmt: skip
            work[W_F, i - 1] += nx
            work[W_F + 1, i - 1] += ny
            work[W_F + 2, i - 1] += nz
            work[W_F + 3, i - 1] += fx
            work[W_F + 4, i - 1] += fy
            work[W_F + 5, i - 1] += fz


@njit(**_OPTS)
def inverse_dynamics_into(
    p: np.ndarray,
    g: float,
    q: np.ndarray,
    qd: np.ndarray,
    qdd: np.ndarray,
    out: np.ndarray,
    work: np.ndarray,
) -> None:
    """:math:`\\tau = M(q)\\ddot q + h(q, \\dot q)` (recursive Newton-Euler)."""
    p, q, qd, qdd, out, work = _borrow(p), _borrow(q), _borrow(qd), _borrow(qdd), _borrow(out), _borrow(work)
    kinematics_into(p, q, work)
    rnea_known(p, g, qd, 1.0, qdd, 1.0, 1.0, out, work)


@njit(**_OPTS)
def bias_into(
    p: np.ndarray, g: float, q: np.ndarray, qd: np.ndarray, out: np.ndarray, work: np.ndarray
) -> None:
    """:math:`h(q, \\dot q) = C\\dot q + G`: Newton-Euler with :math:`\\ddot q = 0`."""
    p, q, qd, out, work = _borrow(p), _borrow(q), _borrow(qd), _borrow(out), _borrow(work)
    kinematics_into(p, q, work)
    rnea_known(p, g, qd, 1.0, qd, 0.0, 1.0, out, work)


@njit(**_OPTS)
def gravity_into(p: np.ndarray, g: float, q: np.ndarray, out: np.ndarray, work: np.ndarray) -> None:
    """:math:`G(q)`: Newton-Euler at rest."""
    p, q, out, work = _borrow(p), _borrow(q), _borrow(out), _borrow(work)
    kinematics_into(p, q, work)
    rnea_known(p, g, q, 0.0, q, 0.0, 1.0, out, work)


@njit(**_OPTS)
def crba_known(p: np.ndarray, n: int, out: np.ndarray, work: np.ndarray) -> None:
    """Composite-rigid-body algorithm with the kinematics in ``work``: ``M`` into ``out``.

    Composite inertias :math:`I^c_i = I_i + X_{i+1}^T I^c_{i+1} X_{i+1}` (as ``m``, ``h``,
    ``I_o``, carried to the parent by :func:`_carry_inertia`), then :math:`M_{ii} = S_i^T I^c_i S_i` and
    :math:`M_{ji} = S_j^T X_{j+1}^T \\cdots X_i^T I^c_i S_i` for :math:`j < i`.
    """
    c = W_IA
    for i in range(n):
        for k in range(10):
            work[c + k, i] = p[P_MASS + k, i]
    for i in range(n - 1, 0, -1):
        m = work[c, i]
        carried = _carry_inertia(
            m, work[c + 1, i], work[c + 2, i], work[c + 3, i],
            work[c + 4, i], work[c + 5, i], work[c + 6, i], work[c + 7, i], work[c + 8, i], work[c + 9, i],
            work[0, i], work[1, i], work[2, i], work[3, i], work[4, i], work[5, i], work[6, i], work[7, i], work[8, i],
            work[W_POS, i], work[W_POS + 1, i], work[W_POS + 2, i],
        )  # fmt: skip
        work[c, i - 1] += m
        for k in range(9):
            work[c + 1 + k, i - 1] += carried[k]
    for i in range(n):
        ax = p[P_AXIS, i]
        ay = p[P_AXIS + 1, i]
        az = p[P_AXIS + 2, i]
        m = work[c, i]
        hx = work[c + 1, i]
        hy = work[c + 2, i]
        hz = work[c + 3, i]
        if p[P_TYPE, i] == 0.0:  # I^c (a, 0) = (I_o a, -h x a)
            nx = work[c + 4, i] * ax + work[c + 7, i] * ay + work[c + 8, i] * az
            ny = work[c + 7, i] * ax + work[c + 5, i] * ay + work[c + 9, i] * az
            nz = work[c + 8, i] * ax + work[c + 9, i] * ay + work[c + 6, i] * az
            fx = -(hy * az - hz * ay)
            fy = -(hz * ax - hx * az)
            fz = -(hx * ay - hy * ax)
            out[i, i] = ax * nx + ay * ny + az * nz
        else:  # I^c (0, a) = (h x a, m a)
            nx = hy * az - hz * ay
            ny = hz * ax - hx * az
            nz = hx * ay - hy * ax
            fx = m * ax
            fy = m * ay
            fz = m * az
            out[i, i] = ax * fx + ay * fy + az * fz
        for j in range(i, 0, -1):
            nx, ny, nz, fx, fy, fz = _force_out(work, j, nx, ny, nz, fx, fy, fz)
            k = j - 1
            bx = p[P_AXIS, k]
            by = p[P_AXIS + 1, k]
            bz = p[P_AXIS + 2, k]
            if p[P_TYPE, k] == 0.0:
                v = bx * nx + by * ny + bz * nz
            else:
                v = bx * fx + by * fy + bz * fz
            out[k, i] = v
            out[i, k] = v


@njit(**_OPTS)
def mass_matrix_into(p: np.ndarray, q: np.ndarray, out: np.ndarray, work: np.ndarray) -> None:
    """:math:`M(q)` into ``out`` (n, n) by the composite-rigid-body algorithm."""
    p, q, out, work = _borrow(p), _borrow(q), _borrow(out), _borrow(work)
    kinematics_into(p, q, work)
    crba_known(p, q.shape[0], out, work)


@njit(**_OPTS)
def mass_and_bias_into(
    p: np.ndarray,
    g: float,
    q: np.ndarray,
    qd: np.ndarray,
    mmat: np.ndarray,
    h: np.ndarray,
    work: np.ndarray,
) -> None:
    """:math:`M(q)` and :math:`h(q, \\dot q)`, sharing the kinematics."""
    p, q, qd, mmat, h, work = _borrow(p), _borrow(q), _borrow(qd), _borrow(mmat), _borrow(h), _borrow(work)
    kinematics_into(p, q, work)
    crba_known(p, q.shape[0], mmat, work)
    rnea_known(p, g, qd, 1.0, qd, 0.0, 1.0, h, work)


@njit(**_INLINE)
def _rigid_times(
    m: float,
    hx: float,
    hy: float,
    hz: float,
    ixx: float,
    iyy: float,
    izz: float,
    ixy: float,
    ixz: float,
    iyz: float,
    wx: float,
    wy: float,
    wz: float,
    vx: float,
    vy: float,
    vz: float,
) -> tuple[float, float, float, float, float, float]:
    """A rigid inertia ``(m, h, I_o)`` times a motion: ``(I_o ω + h × v, m v - h × ω)``."""
    return (
        ixx * wx + ixy * wy + ixz * wz + hy * vz - hz * vy,
        ixy * wx + iyy * wy + iyz * wz + hz * vx - hx * vz,
        ixz * wx + iyz * wy + izz * wz + hx * vy - hy * vx,
        m * vx - (hy * wz - hz * wy),
        m * vy - (hz * wx - hx * wz),
        m * vz - (hx * wy - hy * wx),
    )


@njit(**_INLINE)
def _carry_inertia(
    m: float,
    hx: float,
    hy: float,
    hz: float,
    jxx: float,
    jyy: float,
    jzz: float,
    jxy: float,
    jxz: float,
    jyz: float,
    e00: float,
    e01: float,
    e02: float,
    e10: float,
    e11: float,
    e12: float,
    e20: float,
    e21: float,
    e22: float,
    ox: float,
    oy: float,
    oz: float,
) -> tuple[float, float, float, float, float, float, float, float, float]:
    """A rigid inertia ``(m, h, I_o)`` of a frame carried to the frame in which the first is
    at rotation ``E`` and origin ``o``: ``h' = E h + m o`` and
    :math:`I_o' = E I_o E^T - o k^T - k o^T + 2 (o \\cdot k) 1` with
    :math:`k = E h + m o / 2` (the parallel-axis theorem without a division by ``m``).
    Returns ``h'`` and ``I_o'`` as ``xx, yy, zz, xy, xz, yz``."""
    gx = e00 * hx + e01 * hy + e02 * hz
    gy = e10 * hx + e11 * hy + e12 * hz
    gz = e20 * hx + e21 * hy + e22 * hz
    # T = E I_o, then E I_o E^T (upper triangle)
    t00 = e00 * jxx + e01 * jxy + e02 * jxz
    t01 = e00 * jxy + e01 * jyy + e02 * jyz
    t02 = e00 * jxz + e01 * jyz + e02 * jzz
    t10 = e10 * jxx + e11 * jxy + e12 * jxz
    t11 = e10 * jxy + e11 * jyy + e12 * jyz
    t12 = e10 * jxz + e11 * jyz + e12 * jzz
    t20 = e20 * jxx + e21 * jxy + e22 * jxz
    t21 = e20 * jxy + e21 * jyy + e22 * jyz
    t22 = e20 * jxz + e21 * jyz + e22 * jzz
    hm = 0.5 * m
    kx = gx + hm * ox
    ky = gy + hm * oy
    kz = gz + hm * oz
    pkx = ox * kx
    pky = oy * ky
    pkz = oz * kz
    return (
        gx + m * ox,
        gy + m * oy,
        gz + m * oz,
        t00 * e00 + t01 * e01 + t02 * e02 + 2.0 * (pky + pkz),
        t10 * e10 + t11 * e11 + t12 * e12 + 2.0 * (pkx + pkz),
        t20 * e20 + t21 * e21 + t22 * e22 + 2.0 * (pkx + pky),
        t00 * e10 + t01 * e11 + t02 * e12 - (ox * ky + kx * oy),
        t00 * e20 + t01 * e21 + t02 * e22 - (ox * kz + kx * oz),
        t10 * e20 + t11 * e21 + t12 * e22 - (oy * kz + ky * oz),
    )


# ------------------------------------------------------- the articulated-body algorithm's buffer
# The articulated-body algorithm keeps its per-body quantities in a buffer of *groups* of _L
# bodies, each field of a group holding its _L bodies side by side (body i is lane i % _L of
# group i // _L): the per-body work that does not depend on the other bodies (each body's
# inertia carried to the root and its bias force, about two thirds of the multiplications of a
# pass) then runs as one loop over a group's lanes, which LLVM turns into _L-wide vector code,
# at constant offsets from the group's start (so that it needs no run-time aliasing checks).
_L = 8  # bodies per group: one AVX-512 vector of float64, two AVX2 ones
# fields of a body (each _L floats)
_F_M = 0  # 10: m, h, I_o of the body (the table's rows P_MASS to P_IO + 5)
_F_E = 10  # 9: R_0i; overwritten by h, I_o at the root's origin (9)
_F_O = 19  # 3: p_0i; it and the first 3 of _F_V overwritten by the bias force p_i (6)
_F_V = 22  # 6: v_i
_F_C = 28  # 6: C_i, the body's acceleration at qdd = 0 (gravity included)
_F_S = 34  # 6: s_i, the joint's axis
_F_U = 40  # 6: U_i = I^A_i s_i
_F_RD = 46  # 1 / D_i
_F_UU = 47  # u_i = tau_i - s_i^T p^A_i
_F_I = _F_E
_F_P = _F_O
_NF = 48
_GROUP = _NF * _L  # floats per group
#: Bodies up to which the buffer is on the stack (two groups, 6 kB); a longer chain keeps it
#: in the workspace's rows :data:`W_AB` to ``W_CS - 1``.
STACK_BODIES = 2 * _L
#: First workspace row of the buffer of a chain longer than :data:`STACK_BODIES`.
W_AB = 12


def buffer_floats(n: int) -> int:
    """Floats of the articulated-body buffer of an ``n``-joint chain: ``ceil(n / 8)`` groups
    of :data:`_NF` fields of 8 bodies."""
    return -(-n // _L) * _GROUP


@intrinsic
def _stack_buffer(typingctx: Any) -> Any:
    """A float64 array of ``buffer_floats(STACK_BODIES)`` elements on the calling function's
    stack (an ``alloca`` in its entry block, aligned to 64 bytes; no reference counting, no
    heap allocation); valid while that function runs. Its contents are undefined."""
    size = buffer_floats(STACK_BODIES)
    aryty = types.Array(types.float64, 1, "C")

    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        intp = context.get_value_type(types.intp)
        dbl = context.get_value_type(types.float64)
        raw = cgutils.alloca_once(builder, dbl, size=intp(size + 8))
        addr = builder.ptrtoint(raw, intp)
        data = builder.inttoptr(builder.and_(builder.add(addr, intp(63)), intp(-64)), raw.type)
        ary = make_array(aryty)(context, builder)
        populate_array(
            ary, data=data, shape=[intp(size)], strides=[intp(8)], itemsize=intp(8), meminfo=None
        )
        return ary._getvalue()

    return aryty(), codegen


@intrinsic
def _rows_flat(typingctx: Any, work: Any, row: Any) -> Any:
    """Rows ``row`` to the last of the C-contiguous 2-D ``work`` as one 1-D array (an alias,
    borrowed as by :func:`_borrow`)."""
    if not (isinstance(work, types.Array) and work.ndim == 2 and work.layout == "C"):
        return None
    aryty = types.Array(work.dtype, 1, "C")

    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        src = make_array(signature.args[0])(context, builder, args[0])
        nrows, ncols = cgutils.unpack_tuple(builder, src.shape, 2)
        first = builder.mul(args[1], ncols)
        size = builder.mul(builder.sub(nrows, args[1]), ncols)
        itemsize = context.get_constant(
            types.intp, context.get_abi_sizeof(context.get_data_type(work.dtype))
        )
        ary = make_array(aryty)(context, builder)
        data = builder.gep(src.data, [first])
        populate_array(
            ary, data=data, shape=[size], strides=[itemsize], itemsize=itemsize, meminfo=None
        )
        return ary._getvalue()

    return aryty(work, types.intp), codegen


@njit(**_INLINE)
def _aba_buffer(p: np.ndarray, n: int, buf: np.ndarray) -> None:
    """Fill the buffer's constant fields: each body's ``m, h, I_o`` (:data:`_F_M`), and zero the
    unused lanes of the last group in the fields the group loop reads, so that it computes on
    zeros there."""
    for i in range(n):
        b = (i >> 3) * _GROUP + (i & 7)
        for k in range(10):
            buf[b + (_F_M + k) * _L] = p[P_MASS + k, i]
    last = ((n - 1) >> 3) * _GROUP
    for lane in range(((n - 1) & 7) + 1, _L):
        for f in range(_F_S):
            buf[last + f * _L + lane] = 0.0


@njit(**_INLINE)
def _aba(
    p: np.ndarray,
    g: float,
    q: np.ndarray,
    qd: np.ndarray,
    tau: np.ndarray,
    out: np.ndarray,
    work: np.ndarray,
    buf: np.ndarray,
) -> bool:
    """Articulated-body algorithm at ``q`` with the cosines and sines of ``q`` in rows
    ``W_CS``, ``W_CS + 1`` of ``work`` (the only kinematics it reads) and ``buf`` a buffer
    filled by :func:`_aba_buffer`: :math:`\\ddot q = M^{-1}(\\tau - h)` into ``out``;
    ``False`` if an articulated inertia along its joint, :math:`D_i = s_i^T I^A_i s_i`, is not
    positive (``M`` not positive definite; ``out`` as :func:`PK.failed_pivot` leaves it).

    Everything is in root (world) coordinates at the root's origin, so no spatial transform
    is applied to an inertia or a force. Pass 1 (root to tip): the body's pose
    :math:`p_{0i} = p_{0,i-1} + R_{0,i-1} r`, :math:`F = R_{0,i-1} R_0`,
    :math:`R_{0i} = F\\,\\mathrm{Rot}(e_z, q_i)` (columns ``c F_0 + s F_1``, ``c F_1 - s F_0``,
    ``F_2``; a prismatic joint: :math:`R_{0i} = F`, :math:`r = p_0 + q_i R_0 e_z`); its joint's
    axis :math:`s_i = (e, p_{0i} \\times e)` (revolute) or :math:`(0, e)` (prismatic) with
    :math:`e = R_{0i} e_z = F_2`; then, in a loop of its own over the stored axes,
    :math:`v_i = v_{i-1} + s_i \\dot q_i` and the acceleration at
    :math:`\\ddot q = 0`, :math:`C_i = C_{i-1} + v_i \\times s_i \\dot q_i` from
    :math:`C_{-1} = (0, 0, 0, 0, 0, g)` (gravity as the root's acceleration). Then, for every
    body independently (the loop over a group's lanes, vector code): the rigid inertia
    :math:`I_i` at the origin (``I_o`` rotated once, :math:`h' = R h + m p`, shifted as in
    :func:`crba_known`) and the bias force :math:`p_i = I_i C_i + v_i \\times^* I_i v_i`. With
    :math:`a_i = C_i + \\hat a_i`, :math:`\\hat a_i = \\hat a_{i-1} + s_i \\ddot q_i`, the
    velocity-product term of the recursion is zero. Pass 2 (tip to root), the symmetric
    :math:`I^A` (21 entries) and :math:`p^A` carried in registers:
    :math:`I^A_i = I_i + I^a_{i+1}`, :math:`p^A_i = p_i + p^a_{i+1}`, :math:`U_i = I^A_i s_i`,
    :math:`D_i = s_i^T U_i`, :math:`u_i = \\tau_i - s_i^T p^A_i`,
    :math:`I^a_i = I^A_i - U_i U_i^T / D_i`, :math:`p^a_i = p^A_i + U_i u_i / D_i`. Pass 3
    (root to tip): :math:`\\ddot q_i = (u_i - U_i^T \\hat a_{i-1}) / D_i`,
    :math:`\\hat a_i = \\hat a_{i-1} + s_i \\ddot q_i` from :math:`\\hat a_{-1} = 0`.
    """
    n = qd.shape[0]
    # world pose of the body, its velocity (w, v) and its acceleration at qdd = 0 (b, c)
    e00 = 1.0
    e01 = 0.0
    e02 = 0.0
    e10 = 0.0
    e11 = 1.0
    e12 = 0.0
    e20 = 0.0
    e21 = 0.0
    e22 = 1.0
    ox = 0.0
    oy = 0.0
    oz = 0.0
    wx = 0.0
    wy = 0.0
    wz = 0.0
    vx = 0.0
    vy = 0.0
    vz = 0.0
    bx = 0.0
    by = 0.0
    bz = 0.0
    cx = 0.0
    cy = 0.0
    cz = g
    for i in range(n):
        b00 = p[0, i]
        b01 = p[1, i]
        b02 = p[2, i]
        b10 = p[3, i]
        b11 = p[4, i]
        b12 = p[5, i]
        b20 = p[6, i]
        b21 = p[7, i]
        b22 = p[8, i]
        rx = p[9, i]
        ry = p[10, i]
        rz = p[11, i]
        revolute = p[P_TYPE, i] == 0.0
        if not revolute:  # r = p_0 + q R_0 e_z
            rx += q[i] * b02
            ry += q[i] * b12
            rz += q[i] * b22
        # p_0i = p_0,i-1 + R_0,i-1 r, F = R_0,i-1 R_0, R_0i = F Rot(e_z, q) (revolute)
        ox += e00 * rx + e01 * ry + e02 * rz
        oy += e10 * rx + e11 * ry + e12 * rz
        oz += e20 * rx + e21 * ry + e22 * rz
        f00 = e00 * b00 + e01 * b10 + e02 * b20
        f01 = e00 * b01 + e01 * b11 + e02 * b21
        f02 = e00 * b02 + e01 * b12 + e02 * b22
        f10 = e10 * b00 + e11 * b10 + e12 * b20
        f11 = e10 * b01 + e11 * b11 + e12 * b21
        f12 = e10 * b02 + e11 * b12 + e12 * b22
        f20 = e20 * b00 + e21 * b10 + e22 * b20
        f21 = e20 * b01 + e21 * b11 + e22 * b21
        f22 = e20 * b02 + e21 * b12 + e22 * b22
        # the joint's axis in the root is R_0i e_z = F_2
        if revolute:
            c = work[W_CS, i]
            sn = work[W_CS + 1, i]
            e00 = c * f00 + sn * f01
            e01 = c * f01 - sn * f00
            e10 = c * f10 + sn * f11
            e11 = c * f11 - sn * f10
            e20 = c * f20 + sn * f21
            e21 = c * f21 - sn * f20
            s0 = f02
            s1 = f12
            s2 = f22
            s3 = oy * f22 - oz * f12
            s4 = oz * f02 - ox * f22
            s5 = ox * f12 - oy * f02
        else:
            e00 = f00
            e01 = f01
            e10 = f10
            e11 = f11
            e20 = f20
            e21 = f21
            s0 = 0.0
            s1 = 0.0
            s2 = 0.0
            s3 = f02
            s4 = f12
            s5 = f22
        e02 = f02
        e12 = f12
        e22 = f22
        # the velocities come in the next loop: one loop carrying the pose (12 values), the
        # velocity and the acceleration (12 more) and their temporaries spilt most of them to
        # the stack on AVX2's 16 registers; split, each fits (same arithmetic, same bits;
        # measured: an RK4 step -7 to -10 % on the UR5 and the Panda, AMD EPYC with AVX2)
        k = (i >> 3) * _GROUP + (i & 7)
        buf[k + _F_E * _L] = e00
        buf[k + (_F_E + 1) * _L] = e01
        buf[k + (_F_E + 2) * _L] = e02
        buf[k + (_F_E + 3) * _L] = e10
        buf[k + (_F_E + 4) * _L] = e11
        buf[k + (_F_E + 5) * _L] = e12
        buf[k + (_F_E + 6) * _L] = e20
        buf[k + (_F_E + 7) * _L] = e21
        buf[k + (_F_E + 8) * _L] = e22
        buf[k + _F_O * _L] = ox
        buf[k + (_F_O + 1) * _L] = oy
        buf[k + (_F_O + 2) * _L] = oz
        buf[k + _F_S * _L] = s0
        buf[k + (_F_S + 1) * _L] = s1
        buf[k + (_F_S + 2) * _L] = s2
        buf[k + (_F_S + 3) * _L] = s3
        buf[k + (_F_S + 4) * _L] = s4
        buf[k + (_F_S + 5) * _L] = s5
    for i in range(n):
        k = (i >> 3) * _GROUP + (i & 7)
        dq = qd[i]
        q0 = buf[k + _F_S * _L] * dq
        q1 = buf[k + (_F_S + 1) * _L] * dq
        q2 = buf[k + (_F_S + 2) * _L] * dq
        q3 = buf[k + (_F_S + 3) * _L] * dq
        q4 = buf[k + (_F_S + 4) * _L] * dq
        q5 = buf[k + (_F_S + 5) * _L] * dq
        wx += q0
        wy += q1
        wz += q2
        vx += q3
        vy += q4
        vz += q5
        # C += v x (s qd)
        bx += wy * q2 - wz * q1
        by += wz * q0 - wx * q2
        bz += wx * q1 - wy * q0
        cx += wy * q5 - wz * q4 + vy * q2 - vz * q1
        cy += wz * q3 - wx * q5 + vz * q0 - vx * q2
        cz += wx * q4 - wy * q3 + vx * q1 - vy * q0
        buf[k + _F_V * _L] = wx
        buf[k + (_F_V + 1) * _L] = wy
        buf[k + (_F_V + 2) * _L] = wz
        buf[k + (_F_V + 3) * _L] = vx
        buf[k + (_F_V + 4) * _L] = vy
        buf[k + (_F_V + 5) * _L] = vz
        buf[k + _F_C * _L] = bx
        buf[k + (_F_C + 1) * _L] = by
        buf[k + (_F_C + 2) * _L] = bz
        buf[k + (_F_C + 3) * _L] = cx
        buf[k + (_F_C + 4) * _L] = cy
        buf[k + (_F_C + 5) * _L] = cz
    # every body's inertia at the root's origin and its bias force, a group's lanes at once;
    # the lane count is read from the buffer (it is _L) so that LLVM vectorises the loop
    # instead of unrolling it
    lanes = min(buf.shape[0], _L)
    for grp in range((n + _L - 1) >> 3):
        s = buf[grp * _GROUP :]
        for ln in range(lanes):
            m = s[_F_M * _L + ln]
            hx, hy, hz, ixx, iyy, izz, ixy, ixz, iyz = _carry_inertia(
                m, s[(_F_M + 1) * _L + ln], s[(_F_M + 2) * _L + ln], s[(_F_M + 3) * _L + ln],
                s[(_F_M + 4) * _L + ln], s[(_F_M + 5) * _L + ln], s[(_F_M + 6) * _L + ln],
                s[(_F_M + 7) * _L + ln], s[(_F_M + 8) * _L + ln], s[(_F_M + 9) * _L + ln],
                s[_F_E * _L + ln], s[(_F_E + 1) * _L + ln], s[(_F_E + 2) * _L + ln],
                s[(_F_E + 3) * _L + ln], s[(_F_E + 4) * _L + ln], s[(_F_E + 5) * _L + ln],
                s[(_F_E + 6) * _L + ln], s[(_F_E + 7) * _L + ln], s[(_F_E + 8) * _L + ln],
                s[_F_O * _L + ln], s[(_F_O + 1) * _L + ln], s[(_F_O + 2) * _L + ln],
            )  # fmt: skip
            wx = s[_F_V * _L + ln]
            wy = s[(_F_V + 1) * _L + ln]
            wz = s[(_F_V + 2) * _L + ln]
            vx = s[(_F_V + 3) * _L + ln]
            vy = s[(_F_V + 4) * _L + ln]
            vz = s[(_F_V + 5) * _L + ln]
            # bias force I C + v x* I v
            n1x, n1y, n1z, f1x, f1y, f1z = _rigid_times(
                m, hx, hy, hz, ixx, iyy, izz, ixy, ixz, iyz, wx, wy, wz, vx, vy, vz
            )
            n2x, n2y, n2z, f2x, f2y, f2z = _rigid_times(
                m, hx, hy, hz, ixx, iyy, izz, ixy, ixz, iyz,
                s[_F_C * _L + ln], s[(_F_C + 1) * _L + ln], s[(_F_C + 2) * _L + ln],
                s[(_F_C + 3) * _L + ln], s[(_F_C + 4) * _L + ln], s[(_F_C + 5) * _L + ln],
            )  # fmt: skip
            s[_F_I * _L + ln] = hx
            s[(_F_I + 1) * _L + ln] = hy
            s[(_F_I + 2) * _L + ln] = hz
            s[(_F_I + 3) * _L + ln] = ixx
            s[(_F_I + 4) * _L + ln] = iyy
            s[(_F_I + 5) * _L + ln] = izz
            s[(_F_I + 6) * _L + ln] = ixy
            s[(_F_I + 7) * _L + ln] = ixz
            s[(_F_I + 8) * _L + ln] = iyz
            s[_F_P * _L + ln] = n2x + wy * n1z - wz * n1y + vy * f1z - vz * f1y
            s[(_F_P + 1) * _L + ln] = n2y + wz * n1x - wx * n1z + vz * f1x - vx * f1z
            s[(_F_P + 2) * _L + ln] = n2z + wx * n1y - wy * n1x + vx * f1y - vy * f1x
            s[(_F_P + 3) * _L + ln] = f2x + wy * f1z - wz * f1y
            s[(_F_P + 4) * _L + ln] = f2y + wz * f1x - wx * f1z
            s[(_F_P + 5) * _L + ln] = f2z + wx * f1y - wy * f1x
    # I^a of the child, [[A, B], [B^T, C]] with A, C symmetric, and p^a
    a00 = 0.0
    a11 = 0.0
    a22 = 0.0
    a01 = 0.0
    a02 = 0.0
    a12 = 0.0
    b00 = 0.0
    b01 = 0.0
    b02 = 0.0
    b10 = 0.0
    b11 = 0.0
    b12 = 0.0
    b20 = 0.0
    b21 = 0.0
    b22 = 0.0
    c00 = 0.0
    c11 = 0.0
    c22 = 0.0
    c01 = 0.0
    c02 = 0.0
    c12 = 0.0
    pn0 = 0.0
    pn1 = 0.0
    pn2 = 0.0
    pf0 = 0.0
    pf1 = 0.0
    pf2 = 0.0
    for i in range(n - 1, -1, -1):
        k = (i >> 3) * _GROUP + (i & 7)
        # I^A = I + I^a (the rigid B is [h]x, its C is m 1)
        m = buf[k + _F_M * _L]
        hx = buf[k + _F_I * _L]
        hy = buf[k + (_F_I + 1) * _L]
        hz = buf[k + (_F_I + 2) * _L]
        a00 += buf[k + (_F_I + 3) * _L]
        a11 += buf[k + (_F_I + 4) * _L]
        a22 += buf[k + (_F_I + 5) * _L]
        a01 += buf[k + (_F_I + 6) * _L]
        a02 += buf[k + (_F_I + 7) * _L]
        a12 += buf[k + (_F_I + 8) * _L]
        b01 -= hz
        b02 += hy
        b10 += hz
        b12 -= hx
        b20 -= hy
        b21 += hx
        c00 += m
        c11 += m
        c22 += m
        pn0 += buf[k + _F_P * _L]
        pn1 += buf[k + (_F_P + 1) * _L]
        pn2 += buf[k + (_F_P + 2) * _L]
        pf0 += buf[k + (_F_P + 3) * _L]
        pf1 += buf[k + (_F_P + 4) * _L]
        pf2 += buf[k + (_F_P + 5) * _L]
        s0 = buf[k + _F_S * _L]
        s1 = buf[k + (_F_S + 1) * _L]
        s2 = buf[k + (_F_S + 2) * _L]
        s3 = buf[k + (_F_S + 3) * _L]
        s4 = buf[k + (_F_S + 4) * _L]
        s5 = buf[k + (_F_S + 5) * _L]
        # the sums in pairs: this pass is one chain of dependent operations, body to body
        u0 = (a00 * s0 + a01 * s1) + (a02 * s2 + b00 * s3) + (b01 * s4 + b02 * s5)
        u1 = (a01 * s0 + a11 * s1) + (a12 * s2 + b10 * s3) + (b11 * s4 + b12 * s5)
        u2 = (a02 * s0 + a12 * s1) + (a22 * s2 + b20 * s3) + (b21 * s4 + b22 * s5)
        u3 = (b00 * s0 + b10 * s1) + (b20 * s2 + c00 * s3) + (c01 * s4 + c02 * s5)
        u4 = (b01 * s0 + b11 * s1) + (b21 * s2 + c01 * s3) + (c11 * s4 + c12 * s5)
        u5 = (b02 * s0 + b12 * s1) + (b22 * s2 + c02 * s3) + (c12 * s4 + c22 * s5)
        d = (s0 * u0 + s1 * u1) + (s2 * u2 + s3 * u3) + (s4 * u4 + s5 * u5)
        if not d > 0.0:
            return PK.failed_pivot(out, d)
        u = tau[i] - ((s0 * pn0 + s1 * pn1) + (s2 * pn2 + s3 * pf0) + (s4 * pf1 + s5 * pf2))
        rd = 1.0 / d
        buf[k + _F_U * _L] = u0
        buf[k + (_F_U + 1) * _L] = u1
        buf[k + (_F_U + 2) * _L] = u2
        buf[k + (_F_U + 3) * _L] = u3
        buf[k + (_F_U + 4) * _L] = u4
        buf[k + (_F_U + 5) * _L] = u5
        buf[k + _F_RD * _L] = rd
        buf[k + _F_UU * _L] = u
        if i == 0:
            break
        # I^a = I^A - U U^T / D, p^a = p^A + U u / D
        w0 = u0 * rd
        w1 = u1 * rd
        w2 = u2 * rd
        w3 = u3 * rd
        w4 = u4 * rd
        w5 = u5 * rd
        a00 -= w0 * u0
        a11 -= w1 * u1
        a22 -= w2 * u2
        a01 -= w0 * u1
        a02 -= w0 * u2
        a12 -= w1 * u2
        b00 -= w0 * u3
        b01 -= w0 * u4
        b02 -= w0 * u5
        b10 -= w1 * u3
        b11 -= w1 * u4
        b12 -= w1 * u5
        b20 -= w2 * u3
        b21 -= w2 * u4
        b22 -= w2 * u5
        c00 -= w3 * u3
        c11 -= w4 * u4
        c22 -= w5 * u5
        c01 -= w3 * u4
        c02 -= w3 * u5
        c12 -= w4 * u5
        pn0 += w0 * u
        pn1 += w1 * u
        pn2 += w2 * u
        pf0 += w3 * u
        pf1 += w4 * u
        pf2 += w5 * u
    bx = 0.0
    by = 0.0
    bz = 0.0
    cx = 0.0
    cy = 0.0
    cz = 0.0
    for i in range(n):
        k = (i >> 3) * _GROUP + (i & 7)
        ua = (
            (buf[k + _F_U * _L] * bx + buf[k + (_F_U + 1) * _L] * by)
            + (buf[k + (_F_U + 2) * _L] * bz + buf[k + (_F_U + 3) * _L] * cx)
            + (buf[k + (_F_U + 4) * _L] * cy + buf[k + (_F_U + 5) * _L] * cz)
        )  # fmt: skip
        qdd = (buf[k + _F_UU * _L] - ua) * buf[k + _F_RD * _L]
        out[i] = qdd
        bx += buf[k + _F_S * _L] * qdd
        by += buf[k + (_F_S + 1) * _L] * qdd
        bz += buf[k + (_F_S + 2) * _L] * qdd
        cx += buf[k + (_F_S + 3) * _L] * qdd
        cy += buf[k + (_F_S + 4) * _L] * qdd
        cz += buf[k + (_F_S + 5) * _L] * qdd
    return True


@njit(**_INLINE)
def _new_buffer(p: np.ndarray, n: int, work: np.ndarray) -> np.ndarray:
    """The articulated-body buffer of an ``n``-joint chain, filled by :func:`_aba_buffer`: on
    the caller's stack up to :data:`STACK_BODIES` bodies, else the workspace's rows
    :data:`W_AB` onwards (they hold ``(W_CS - W_AB) n >= buffer_floats(n)`` floats there)."""
    buf = _stack_buffer()
    if n > STACK_BODIES:
        buf = _rows_flat(work, W_AB)
    _aba_buffer(p, n, buf)
    return buf


@njit(**_OPTS)
def aba_known(
    p: np.ndarray,
    g: float,
    q: np.ndarray,
    qd: np.ndarray,
    tau: np.ndarray,
    out: np.ndarray,
    work: np.ndarray,
) -> bool:
    """The articulated-body algorithm (:func:`_aba`, inlined where it is called: in
    :func:`rk4_step` it runs once per stage) as a function of its own."""
    return _aba(p, g, q, qd, tau, out, work, _new_buffer(p, qd.shape[0], work))


@njit(**_OPTS)
def forward_dynamics_into(
    p: np.ndarray,
    g: float,
    q: np.ndarray,
    qd: np.ndarray,
    tau: np.ndarray,
    out: np.ndarray,
    work: np.ndarray,
) -> bool:
    """:math:`\\ddot q` by the articulated-body algorithm; ``False`` if ``M`` is singular."""
    p = _borrow(p)
    q = _borrow(q)
    qd = _borrow(qd)
    tau = _borrow(tau)
    out = _borrow(out)
    work = _borrow(work)
    _angles_into(q, work)
    return _aba(p, g, q, qd, tau, out, work, _new_buffer(p, q.shape[0], work))


@njit(**_OPTS)
def world_into(p: np.ndarray, n: int, work: np.ndarray, rot: np.ndarray, pos: np.ndarray) -> None:
    """With the kinematics in ``work``: each body frame's rotation ``rot`` (n, 3, 3) and origin
    ``pos`` (n, 3) in the root frame, :math:`R_{0i} = R_{0,i-1} R_{pc,i}`,
    :math:`p_{0i} = p_{0,i-1} + R_{0,i-1} r_i`."""
    for i in range(n):
        for a in range(3):
            if i == 0:
                pos[i, a] = work[W_POS + a, i]
                for b in range(3):
                    rot[i, a, b] = work[3 * a + b, i]
            else:
                s = pos[i - 1, a]
                for k in range(3):
                    s += rot[i - 1, a, k] * work[W_POS + k, i]
                pos[i, a] = s
                for b in range(3):
                    s = 0.0
                    for k in range(3):
                        s += rot[i - 1, a, k] * work[3 * k + b, i]
                    rot[i, a, b] = s


@njit(**_OPTS)
def potential_energy(p: np.ndarray, g: float, q: np.ndarray, work: np.ndarray) -> float:
    """:math:`V = g \\sum_i (m_i z_{0i} + (R_{0i} h_i)_z)`, the height of each body's centre
    of mass times its weight (J, zero at the root's ``z = 0``)."""
    kinematics_into(p, q, work)
    n = q.shape[0]
    # the bottom row of R_0i and the height of the origin, carried down the chain
    z0 = 0.0
    z1 = 0.0
    z2 = 1.0
    zp = 0.0
    v = 0.0
    for i in range(n):
        zp += z0 * work[W_POS, i] + z1 * work[W_POS + 1, i] + z2 * work[W_POS + 2, i]
        y0 = z0 * work[0, i] + z1 * work[3, i] + z2 * work[6, i]
        y1 = z0 * work[1, i] + z1 * work[4, i] + z2 * work[7, i]
        y2 = z0 * work[2, i] + z1 * work[5, i] + z2 * work[8, i]
        z0 = y0
        z1 = y1
        z2 = y2
        v += p[P_MASS, i] * zp + z0 * p[P_H, i] + z1 * p[P_H + 1, i] + z2 * p[P_H + 2, i]
    return g * v


@njit(**_OPTS)
def coriolis_into(
    p: np.ndarray, g: float, q: np.ndarray, qd: np.ndarray, out: np.ndarray, work: np.ndarray
) -> None:
    """The Coriolis matrix with :math:`\\dot M - 2C` skew-symmetric, O(n³), in the root frame.

    With :math:`s_j` joint ``j``'s spatial axis, :math:`v_i = \\sum_{j \\le i} s_j \\dot q_j`,
    :math:`\\dot s_j = v_j \\times s_j` and :math:`I_i` body ``i``'s inertia (all at the
    root's origin):

    .. math:: C = \\sum_i J_i^T (I_i \\dot J_i + B_i J_i), \\quad
        B_i x = \\tfrac12 (v_i \\times^* I_i x - I_i (v_i \\times x) + x \\times^* I_i v_i),

    where :math:`J_i` has the columns :math:`s_j, j \\le i`. Then :math:`C\\dot q` is the
    velocity term of Newton-Euler, and :math:`\\dot M - 2C` is skew as :math:`B_i` is
    :math:`\\tfrac12 \\dot I_i` plus a skew part.
    """
    n = q.shape[0]
    kinematics_into(p, q, work)
    # world rotation and origin of each body: temporary rows W_T (9) and W_T + 9 (3)
    for i in range(n):
        for a in range(3):
            if i == 0:
                work[W_T + 9 + a, i] = work[W_POS + a, i]
                for b in range(3):
                    work[W_T + 3 * a + b, i] = work[3 * a + b, i]
            else:
                s = work[W_T + 9 + a, i - 1]
                for k in range(3):
                    s += work[W_T + 3 * a + k, i - 1] * work[W_POS + k, i]
                work[W_T + 9 + a, i] = s
                for b in range(3):
                    s = 0.0
                    for k in range(3):
                        s += work[W_T + 3 * a + k, i - 1] * work[3 * k + b, i]
                    work[W_T + 3 * a + b, i] = s
    # spatial axes s_j (rows W_U), velocities v_j (rows W_V), sdot_j (rows W_A)
    wx = 0.0
    wy = 0.0
    wz = 0.0
    vx = 0.0
    vy = 0.0
    vz = 0.0
    for j in range(n):
        ax = p[P_AXIS, j]
        ay = p[P_AXIS + 1, j]
        az = p[P_AXIS + 2, j]
        ex = work[W_T, j] * ax + work[W_T + 1, j] * ay + work[W_T + 2, j] * az
        ey = work[W_T + 3, j] * ax + work[W_T + 4, j] * ay + work[W_T + 5, j] * az
        ez = work[W_T + 6, j] * ax + work[W_T + 7, j] * ay + work[W_T + 8, j] * az
        if p[P_TYPE, j] == 0.0:
            ox = work[W_T + 9, j]
            oy = work[W_T + 10, j]
            oz = work[W_T + 11, j]
            s = (ex, ey, ez, oy * ez - oz * ey, oz * ex - ox * ez, ox * ey - oy * ex)
        else:
            s = (0.0, 0.0, 0.0, ex, ey, ez)
        for k in range(6):
            work[W_U + k, j] = s[k]
        wx += s[0] * qd[j]
        wy += s[1] * qd[j]
        wz += s[2] * qd[j]
        vx += s[3] * qd[j]
        vy += s[4] * qd[j]
        vz += s[5] * qd[j]
        work[W_V, j] = wx
        work[W_V + 1, j] = wy
        work[W_V + 2, j] = wz
        work[W_V + 3, j] = vx
        work[W_V + 4, j] = vy
        work[W_V + 5, j] = vz
        work[W_A, j] = wy * s[2] - wz * s[1]
        work[W_A + 1, j] = wz * s[0] - wx * s[2]
        work[W_A + 2, j] = wx * s[1] - wy * s[0]
        work[W_A + 3, j] = wy * s[5] - wz * s[4] + vy * s[2] - vz * s[1]
        work[W_A + 4, j] = wz * s[3] - wx * s[5] + vz * s[0] - vx * s[2]
        work[W_A + 5, j] = wx * s[4] - wy * s[3] + vx * s[1] - vy * s[0]
    for a in range(n):
        for b in range(n):
            out[a, b] = 0.0
    for i in range(n):
        # body i's inertia at the root's origin, in root coordinates
        m = p[P_MASS, i]
        wr = work[W_T : W_T + 12, i]
        hx, hy, hz, ixx, iyy, izz, ixy, ixz, iyz = _carry_inertia(
            m, p[P_H, i], p[P_H + 1, i], p[P_H + 2, i],
            p[P_IO, i], p[P_IO + 1, i], p[P_IO + 2, i], p[P_IO + 3, i], p[P_IO + 4, i], p[P_IO + 5, i],
            wr[0], wr[1], wr[2], wr[3], wr[4], wr[5], wr[6], wr[7], wr[8], wr[9], wr[10], wr[11],
        )  # fmt: skip
        v = work[W_V : W_V + 6, i]
        iv = _rigid_times(
            m, hx, hy, hz, ixx, iyy, izz, ixy, ixz, iyz, v[0], v[1], v[2], v[3], v[4], v[5]
        )
        for lcol in range(i + 1):
            sl = work[W_U : W_U + 6, lcol]
            sd = work[W_A : W_A + 6, lcol]
            # y = I sdot + 1/2 (v x* I s - I (v x s) + s x* I v)
            t1 = _rigid_times(
                m,
                hx,
                hy,
                hz,
                ixx,
                iyy,
                izz,
                ixy,
                ixz,
                iyz,
                sd[0],
                sd[1],
                sd[2],
                sd[3],
                sd[4],
                sd[5],
            )
            isl = _rigid_times(
                m,
                hx,
                hy,
                hz,
                ixx,
                iyy,
                izz,
                ixy,
                ixz,
                iyz,
                sl[0],
                sl[1],
                sl[2],
                sl[3],
                sl[4],
                sl[5],
            )
            t2 = _crossf(v[0], v[1], v[2], v[3], v[4], v[5], isl)
            vxs = (
                v[1] * sl[2] - v[2] * sl[1],
                v[2] * sl[0] - v[0] * sl[2],
                v[0] * sl[1] - v[1] * sl[0],
                v[1] * sl[5] - v[2] * sl[4] + v[4] * sl[2] - v[5] * sl[1],
                v[2] * sl[3] - v[0] * sl[5] + v[5] * sl[0] - v[3] * sl[2],
                v[0] * sl[4] - v[1] * sl[3] + v[3] * sl[1] - v[4] * sl[0],
            )
            t3 = _rigid_times(
                m,
                hx,
                hy,
                hz,
                ixx,
                iyy,
                izz,
                ixy,
                ixz,
                iyz,
                vxs[0],
                vxs[1],
                vxs[2],
                vxs[3],
                vxs[4],
                vxs[5],
            )
            t4 = _crossf(sl[0], sl[1], sl[2], sl[3], sl[4], sl[5], iv)
            for k in range(i + 1):
                sk = work[W_U : W_U + 6, k]
                acc = 0.0
                for e in range(6):
                    acc += sk[e] * (t1[e] + 0.5 * (t2[e] - t3[e] + t4[e]))
                out[k, lcol] += acc


@njit(**_INLINE)
def _crossf(
    wx: float,
    wy: float,
    wz: float,
    vx: float,
    vy: float,
    vz: float,
    f: tuple[float, float, float, float, float, float],
) -> tuple[float, float, float, float, float, float]:
    """``(ω, v) ×* (n, f) = (ω × n + v × f, ω × f)``."""
    return (
        wy * f[2] - wz * f[1] + vy * f[5] - vz * f[4],
        wz * f[0] - wx * f[2] + vz * f[3] - vx * f[5],
        wx * f[1] - wy * f[0] + vx * f[4] - vy * f[3],
        wy * f[5] - wz * f[4],
        wz * f[3] - wx * f[5],
        wx * f[4] - wy * f[3],
    )


# rows of the (RK4_ROWS, n) scratch of rk4_step
_RK_K = 0  # 4 rows: the acceleration stages
_RK_QTMP = 4
_RK_VTMP = 5
_RK_DQ = 6
_RK_BASE = 7  # 2 rows: cosines and sines at the step's start
#: Rows of the scratch array of :func:`rk4_step`.
RK4_ROWS = 9


@njit(**_OPTS)
def rk4_step(
    p: np.ndarray,
    g: float,
    q: np.ndarray,
    qd: np.ndarray,
    tau: np.ndarray,
    h: float,
    known: bool,
    scratch: np.ndarray,
    work: np.ndarray,
) -> bool:
    """Advance ``(q, qd)`` in place by one classical RK4 step of length ``h``, ``tau`` held;
    ``known`` says the kinematics of ``q`` are in ``work`` (of them the stages read the
    cosines and sines). Stage ``s`` evaluates :func:`aba_known` at
    :math:`q + c_s h v_{s-1}`, :math:`\\dot q + c_s h k_{s-1}` (:math:`c = 0, 1/2, 1/2, 1`),
    its sines and cosines rotated from the start's (:func:`_angles_shifted_into`); then
    :math:`q \\mathrel{+}= h (v_1 + 2 v_2 + 2 v_3 + v_4) / 6` and likewise :math:`\\dot q` with
    the :math:`k_s`. ``False`` if ``M`` was singular."""
    p = _borrow(p)
    q = _borrow(q)
    qd = _borrow(qd)
    tau = _borrow(tau)
    scratch = _borrow(scratch)
    work = _borrow(work)
    n = q.shape[0]
    k = scratch[_RK_K : _RK_K + 4]
    qtmp = scratch[_RK_QTMP]
    vtmp = scratch[_RK_VTMP]
    dq = scratch[_RK_DQ]
    base = scratch[_RK_BASE : _RK_BASE + 2]
    buf = _new_buffer(p, n, work)
    if not known:
        _angles_into(q, work)
    for i in range(n):
        base[0, i] = work[W_CS, i]
        base[1, i] = work[W_CS + 1, i]
    for i in range(n):
        qtmp[i] = q[i]
        vtmp[i] = qd[i]
    ok = True
    for s in range(4):
        if s > 0:
            c = 1.0 if s == 3 else 0.5
            for i in range(n):
                v_prev = qd[i] if s == 1 else qd[i] + 0.5 * h * k[s - 2, i]
                dq[i] = c * h * v_prev
                qtmp[i] = q[i] + dq[i]
                vtmp[i] = qd[i] + c * h * k[s - 1, i]
            _angles_shifted_into(base, dq, qtmp, work)
        ok &= _aba(p, g, qtmp, vtmp, tau, k[s], work, buf)
    for i in range(n):
        v1 = qd[i]
        v2 = qd[i] + 0.5 * h * k[0, i]
        v3 = qd[i] + 0.5 * h * k[1, i]
        v4 = qd[i] + h * k[2, i]
        q[i] += h / 6.0 * (v1 + 2.0 * v2 + 2.0 * v3 + v4)
        qd[i] += h / 6.0 * (k[0, i] + 2.0 * k[1, i] + 2.0 * k[2, i] + k[3, i])
    return ok
