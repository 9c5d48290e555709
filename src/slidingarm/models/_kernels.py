"""Compiled closed-form dynamics of a planar serial arm.

Every function here is a numba ``njit`` kernel over plain float arrays, written as loops over
scalars so that the simulator's compiled loop can call it without touching Python objects.
Nothing here allocates: callers pass the output arrays and a workspace.

The arm is described by one array ``arm`` of shape ``(4, n)`` whose rows are the link masses
``m``, lengths ``l``, centre-of-mass distances ``c`` and centroidal inertias ``I``, and by the
gravity magnitude ``g`` (gravity acts along ``-y``).

Notation: absolute link angles :math:`\\phi_i = \\sum_{j \\le i} q_j`, absolute rates
:math:`\\omega_i = \\sum_{j \\le i} \\dot q_j`, unit vectors :math:`u_i = (\\cos\\phi_i, \\sin\\phi_i)`
and :math:`u_i^\\perp = (-\\sin\\phi_i, \\cos\\phi_i)`. The centre of mass of link ``i`` has the
translational Jacobian whose column ``j \\le i`` is

.. math:: J_{c,i}[:, j] = \\sum_{a=j}^{i-1} l_a u_a^\\perp + c_i u_i^\\perp ,

and zero for ``j > i``; its rotational Jacobian is the row of ones up to ``i``. Hence

.. math::

    M = \\sum_i m_i J_{c,i}^T J_{c,i} + I_i \\mathbf{1}_{\\le i} \\mathbf{1}_{\\le i}^T, \\qquad
    C = \\sum_i m_i J_{c,i}^T \\dot J_{c,i}, \\qquad
    G_j = g \\sum_i m_i J_{c,i}[y, j].

With this factorisation :math:`\\dot M - 2C = \\sum_i m_i (\\dot J^T J - J^T \\dot J)` is
skew-symmetric, and :math:`C \\dot q` is the Coriolis and centrifugal torque of the Lagrangian
equations (in the plane the rotational part carries no gyroscopic term).

The bias :math:`h` and the inverse dynamics use the recursive Newton-Euler algorithm, the
forward dynamics the articulated-body algorithm (both O(n), neither forms :math:`M`).
"""

from __future__ import annotations

import numpy as np
from numba import njit, types
from numba.core import cgutils
from numba.extending import intrinsic

from slidingarm import _vecmath as VM

__all__ = [
    "WORK_ROWS",
    "aba_from_angles_into",
    "angles_into",
    "bias_into",
    "coriolis_into",
    "forward_dynamics_into",
    "gravity_into",
    "inverse_dynamics_into",
    "mass_and_bias_into",
    "mass_matrix_into",
    "potential_energy",
    "rk4_step",
    "shifted_angles_into",
]

#: Rows of the ``(WORK_ROWS, n)`` workspace that :func:`forward_dynamics_into` needs.
WORK_ROWS = 8

_CACHE = True
#: The kernels below are each compiled once, as functions of their own, and inlined by LLVM
#: where they are called (``forceinline``: the ``alwaysinline`` attribute), except the sine
#: and cosine (one compiled body called everywhere; ``forceinline=False`` stated, as numba
#: would otherwise hand on the ``forceinline`` of the caller it is first compiled for) and
#: :func:`rotated`, inlined in numba's IR (the block loop's lane loops call it). Inlined in
#: numba's IR instead, every function calling them compiled their bodies again: the paper's
#: law (:func:`slidingarm.control._kernels.paper_entry`) compiled the kinematics that the law
#: and the RK4 step had compiled already, 2.5 CPU-s cold against 1.65 then (with the loop's
#: first compilation unchanged and its code the same: LLVM inlines either way); built since on
#: the articulated-body algorithm that the RK4 step compiles, it takes about 0.75.
_INLINE = "always"


@intrinsic
def borrow(typingctx, arr):  # type: ignore[no-untyped-def]
    """An alias of the array ``arr`` that takes no part in reference counting.

    Numba reference-counts array variables: every argument and row view of a kernel is one,
    and its LLVM pass removes only some of the increments and decrements, each a call. The
    alias has a null memory-info pointer, so all of them compile away. The caller must keep
    ``arr`` alive while the alias is in use (an argument of a kernel is: its caller holds it).
    """
    if not isinstance(arr, types.Array):
        return None

    def codegen(context, builder, signature, args):  # type: ignore[no-untyped-def]
        ary = args[0]
        return builder.insert_value(ary, cgutils.get_null_value(ary.type.elements[0]), 0)

    return arr(arr), codegen


@njit(cache=_CACHE, nogil=True, error_model="numpy", forceinline=False)
def sincos(x: float) -> tuple[float, float]:
    """``(sin x, cos x)`` by :func:`slidingarm._vecmath.sincos` (at most 1 ulp), the function
    the block loop (:mod:`slidingarm._block`) inlines into its lane loops, so that a run's
    trajectory is bit-identical on both paths. Not inlined here: one compiled body serves every
    call of the scalar loop."""
    return VM.sincos(x)


@njit(cache=_CACHE, nogil=True, error_model="numpy", forceinline=True)
def angles_into(q: np.ndarray, work: np.ndarray) -> None:
    """Cosine (row 0) and sine (row 1) of the absolute angles ``phi_i = q_0 + ... + q_i``
    (:func:`sincos`)."""
    phi = 0.0
    for i in range(q.shape[0]):
        phi += q[i]
        s, c = sincos(phi)
        work[0, i] = c
        work[1, i] = s


@njit(cache=_CACHE, nogil=True, error_model="numpy")
def mass_matrix_into(arm: np.ndarray, q: np.ndarray, out: np.ndarray, work: np.ndarray) -> None:
    """Fill ``out`` (n, n) with the joint-space inertia matrix :math:`M(q)`.

    ``work`` is a ``(WORK_ROWS, n)`` scratch array.
    """
    angles_into(q, work)
    _mass_from_angles(arm, q.shape[0], out, work)


@njit(cache=_CACHE, nogil=True, error_model="numpy", forceinline=True)
def _mass_from_angles(arm: np.ndarray, n: int, out: np.ndarray, work: np.ndarray) -> None:
    """:math:`M` from the angles already in ``work`` rows 0-1 (uses rows 2-3)."""
    cphi = work[0]
    sphi = work[1]
    for a in range(n):
        for b in range(n):
            out[a, b] = 0.0
    for i in range(n):
        m = arm[0, i]
        inert = arm[3, i]
        # columns j <= i of J_{c,i}, built from the tip of link i back to the base
        # stored in work rows 2 (x) and 3 (y)
        jx = -arm[2, i] * sphi[i]
        jy = arm[2, i] * cphi[i]
        work[2, i] = jx
        work[3, i] = jy
        for j in range(i - 1, -1, -1):
            jx -= arm[1, j] * sphi[j]
            jy += arm[1, j] * cphi[j]
            work[2, j] = jx
            work[3, j] = jy
        for a in range(i + 1):
            for b in range(a, i + 1):
                out[a, b] += m * (work[2, a] * work[2, b] + work[3, a] * work[3, b]) + inert
    for a in range(n):
        for b in range(a):
            out[a, b] = out[b, a]


@njit(cache=_CACHE, nogil=True, error_model="numpy")
def coriolis_into(
    arm: np.ndarray, q: np.ndarray, qd: np.ndarray, out: np.ndarray, work: np.ndarray
) -> None:
    """Fill ``out`` (n, n) with the Coriolis matrix :math:`C(q, \\dot q) = \\sum m_i J^T \\dot J`.

    With this choice :math:`\\dot M - 2C` is skew-symmetric.
    """
    n = q.shape[0]
    angles_into(q, work)
    cphi = work[0]
    sphi = work[1]
    omega = work[4]
    w = 0.0
    for i in range(n):
        w += qd[i]
        omega[i] = w
    for a in range(n):
        for b in range(n):
            out[a, b] = 0.0
    for i in range(n):
        m = arm[0, i]
        c = arm[2, i]
        jx = -c * sphi[i]
        jy = c * cphi[i]
        # d/dt of u_perp(phi) is -omega * u(phi)
        djx = -c * omega[i] * cphi[i]
        djy = -c * omega[i] * sphi[i]
        work[2, i] = jx
        work[3, i] = jy
        work[5, i] = djx
        work[6, i] = djy
        for j in range(i - 1, -1, -1):
            lj = arm[1, j]
            jx -= lj * sphi[j]
            jy += lj * cphi[j]
            djx -= lj * omega[j] * cphi[j]
            djy -= lj * omega[j] * sphi[j]
            work[2, j] = jx
            work[3, j] = jy
            work[5, j] = djx
            work[6, j] = djy
        for a in range(i + 1):
            for b in range(i + 1):
                out[a, b] += m * (work[2, a] * work[5, b] + work[3, a] * work[6, b])


@njit(cache=_CACHE, nogil=True, error_model="numpy")
def gravity_into(
    arm: np.ndarray, g: float, q: np.ndarray, out: np.ndarray, work: np.ndarray
) -> None:
    """Fill ``out`` (n,) with the gravity torque :math:`G(q) = \\partial V / \\partial q`.

    .. math:: G_j = g \\sum_{i \\ge j} m_i \\Big(\\sum_{a=j}^{i-1} l_a \\cos\\phi_a
              + c_i \\cos\\phi_i\\Big)
    """
    n = q.shape[0]
    angles_into(q, work)
    cphi = work[0]
    # Backward recursion: mass outboard of joint j and its first moment about joint j.
    mass_out = 0.0  # total mass of links j+1..n-1
    moment = 0.0  # sum over links > j of m_i * x-offset from joint j+1
    for j in range(n - 1, -1, -1):
        # moment about joint j = own link + outboard mass carried along link j
        mj = arm[0, j]
        own = mj * arm[2, j] * cphi[j]
        moment = own + mass_out * arm[1, j] * cphi[j] + moment
        mass_out += mj
        out[j] = g * moment


@njit(cache=_CACHE, nogil=True, error_model="numpy")
def bias_into(
    arm: np.ndarray, g: float, q: np.ndarray, qd: np.ndarray, out: np.ndarray, work: np.ndarray
) -> None:
    """Fill ``out`` (n,) with :math:`h(q, \\dot q) = C(q, \\dot q)\\dot q + G(q)`.

    Computed by the planar recursive Newton-Euler algorithm with zero joint acceleration and
    the base accelerated upwards by ``g`` (the usual way of folding gravity in), O(n).
    """
    angles_into(q, work)
    _rnea_from_angles(arm, g, qd, qd, 0.0, out, work)


@njit(cache=_CACHE, nogil=True, error_model="numpy", forceinline=True)
def inverse_dynamics_into(
    arm: np.ndarray,
    g: float,
    q: np.ndarray,
    qd: np.ndarray,
    qdd: np.ndarray,
    out: np.ndarray,
    work: np.ndarray,
) -> None:
    """Fill ``out`` (n,) with :math:`\\tau = M(q)\\ddot q + C(q,\\dot q)\\dot q + G(q)` (RNEA)."""
    angles_into(q, work)
    _rnea_from_angles(arm, g, qd, qdd, 1.0, out, work)


@njit(cache=_CACHE, nogil=True, error_model="numpy", forceinline=True)
def _rnea_from_angles(
    arm: np.ndarray,
    g: float,
    qd: np.ndarray,
    qdd: np.ndarray,
    qdd_scale: float,
    out: np.ndarray,
    work: np.ndarray,
) -> None:
    """Planar recursive Newton-Euler from the angles in ``work`` rows 0-1 (uses rows 2-4);
    ``qdd`` is multiplied by ``qdd_scale`` (0 drops it).

    Each sum of products is written as fused multiply-adds (:func:`slidingarm._vecmath._fma`,
    one rounding each), in the order the block loop's copy (:func:`slidingarm._block._rnea_source`)
    takes them, so both loops compute the same bits: the block's law 1450-1474 -> 1362-1403
    ticks a block step of the paper arm (``benchmarks/bench_block_parts.py``)."""
    n = qd.shape[0]
    cphi = work[0]
    sphi = work[1]
    # forward pass: absolute rates, accelerations, COM accelerations (stored in rows 2..5)
    w = 0.0
    wd = 0.0
    ax = 0.0  # acceleration of the current joint origin
    ay = g
    for i in range(n):
        w += qd[i]
        wd += qdd_scale * qdd[i]
        c = arm[2, i]
        l_i = arm[1, i]
        ww = w * w
        # r = c u, a_c = a_o + wd * (perp r) - w^2 r
        work[2, i] = VM._fma(-wd, c * sphi[i], VM._fma(-ww, c * cphi[i], ax))
        work[3, i] = VM._fma(wd, c * cphi[i], VM._fma(-ww, c * sphi[i], ay))
        work[4, i] = wd
        ax = VM._fma(-wd, l_i * sphi[i], VM._fma(-ww, l_i * cphi[i], ax))
        ay = VM._fma(wd, l_i * cphi[i], VM._fma(-ww, l_i * sphi[i], ay))
    # backward pass: force f_i transmitted by joint i onto link i, moment n_i about joint i
    fx = 0.0
    fy = 0.0
    mom = 0.0
    for i in range(n - 1, -1, -1):
        m = arm[0, i]
        c = arm[2, i]
        l_i = arm[1, i]
        gx = m * work[2, i]
        gy = m * work[3, i]
        # moment about joint i: I wd + r_c x (m a_c) + r_l x f_{i+1} + n_{i+1}
        rc = VM._fma(cphi[i], gy, -(sphi[i] * gx))
        rl = VM._fma(cphi[i], fy, -(sphi[i] * fx))
        mom = VM._fma(arm[3, i], work[4, i], VM._fma(c, rc, VM._fma(l_i, rl, mom)))
        fx += gx
        fy += gy
        out[i] = mom


@njit(cache=_CACHE, nogil=True, error_model="numpy", forceinline=True)
def forward_dynamics_into(
    arm: np.ndarray,
    g: float,
    q: np.ndarray,
    qd: np.ndarray,
    tau: np.ndarray,
    out: np.ndarray,
    work: np.ndarray,
) -> bool:
    """Fill ``out`` (n,) with :math:`\\ddot q = M(q)^{-1}(\\tau - h(q, \\dot q))`.

    Computed by the articulated-body algorithm (:func:`aba_from_angles_into`), O(n), without
    forming :math:`M`. ``work`` is ``(WORK_ROWS, n)``. Returns ``False`` if the mass matrix is
    not positive definite (cannot happen for valid arms; a non-finite state also returns
    ``False``).
    """
    angles_into(q, work)
    return aba_from_angles_into(arm, g, qd, tau, out, work)


@njit(cache=_CACHE, nogil=True, error_model="numpy", forceinline=True)
def failed_pivot(out: np.ndarray, d: float) -> bool:
    """What a forward-dynamics pass leaves in ``out`` when its pivot ``d`` is not positive:
    :math:`0 \\cdot d` in every entry, and ``False``.

    Zero if ``d`` is finite, so that the state a step carries on from stays finite and the run
    is reported singular; NaN if ``d`` is NaN (an overflow upstream), so that the state becomes
    non-finite and is reported as such first, as the block path does. Never what the memory
    held before (the per-run loop's workspace is not cleared, so the status would depend on it).
    """
    for j in range(out.shape[0]):
        out[j] = 0.0 * d
    return False


@njit(cache=_CACHE, nogil=True, error_model="numpy", forceinline=True)
def aba_from_angles_into(
    arm: np.ndarray,
    g: float,
    qd: np.ndarray,
    tau: np.ndarray,
    out: np.ndarray,
    work: np.ndarray,
) -> bool:
    """Forward dynamics by the articulated-body algorithm, from the angles in ``work``.

    ``work`` rows 0-1 must hold :math:`\\cos\\phi_i, \\sin\\phi_i` (as left by :func:`angles_into`,
    or by any kernel of this module that took the same ``q``); rows 2-6 are used.

    Featherstone's ABA (*Rigid Body Dynamics Algorithms*, 2008, Table 7.1) in the plane: a
    spatial vector is (angular z; linear x, y) about joint ``i``'s point, in world axes. With
    the joint axis :math:`S = (1, 0, 0)`, link ``i``'s inertia about its joint

    .. math:: I_i = \\begin{pmatrix} I_i + m_i c_i^2 & -m_i c_y & m_i c_x \\\\
              -m_i c_y & m_i & 0 \\\\ m_i c_x & 0 & m_i \\end{pmatrix}

    (:math:`(c_x, c_y) = c_i u_i`), the passes are: velocities base to tip; articulated
    inertias :math:`I^A_i = I_i + X^T I^a_{i+1} X`, :math:`I^a = I^A - U U^T / D`,
    :math:`U = I^A S`, :math:`D = S^T U`, and bias forces
    :math:`p^a = p^A + I^a c + U u / D`, :math:`u = \\tau_i - S^T p^A` tip to base;
    accelerations :math:`\\ddot q_i = (u_i - U_i^T a'_i) / D_i` base to tip, the base
    accelerated upwards by ``g``. The :math:`D_i` are the pivots of a factorisation of
    :math:`M`, so the function returns ``False`` (``out`` as :func:`failed_pivot` leaves it)
    if one is not positive.
    O(n) with one division per joint; more accurate than forming :math:`M` and solving.
    """
    n = qd.shape[0]
    # pass 1, base to tip: absolute rate (row 2) and velocity of joint i's point (rows 3-4)
    w = 0.0
    vx = 0.0
    vy = 0.0
    for i in range(n):
        w += qd[i]
        work[2, i] = w
        work[3, i] = vx
        work[4, i] = vy
        vx -= w * arm[1, i] * work[1, i]
        vy += w * arm[1, i] * work[0, i]
    # pass 2, tip to base. The articulated inertia handed to link i by its child, moved to
    # joint i, is [[ca, cb, cc], [cb, cd, ce], [cc, ce, cf]], its bias force (p0, p1, p2).
    ca = 0.0
    cb = 0.0
    cc = 0.0
    cd = 0.0
    ce = 0.0
    cf = 0.0
    p0 = 0.0
    p1 = 0.0
    p2 = 0.0
    for i in range(n - 1, -1, -1):
        m = arm[0, i]
        c = arm[2, i]
        wi = work[2, i]
        vxi = work[3, i]
        vyi = work[4, i]
        # rigid-body inertia of link i about joint i, and its bias force v x* (I v)
        ia = arm[3, i] + m * c * c
        ib = -m * c * work[1, i]
        ic = m * c * work[0, i]
        fx = ib * wi + m * vxi
        fy = ic * wi + m * vyi
        # articulated inertia I^A (first column U = (d, ib, ic)) and bias force p^A
        d = ia + ca
        ib += cb
        ic += cc
        dd = m + cd
        de = ce
        df = m + cf
        pa0 = vxi * fy - vyi * fx + p0
        pa1 = -wi * fy + p1
        pa2 = wi * fx + p2
        if not d > 0.0:
            return failed_pivot(out, d)
        dinv = 1.0 / d
        u = tau[i] - pa0
        out[i] = u
        # keep U, 1/D for pass 3 (rows 5, 6, 2) and c_i = v_i x (S qd_i) (rows 3-4)
        cvx = vyi * qd[i]
        cvy = -vxi * qd[i]
        work[2, i] = dinv
        work[3, i] = cvx
        work[4, i] = cvy
        work[5, i] = ib
        work[6, i] = ic
        if i == 0:
            break
        # I^a = I^A - U U^T / D, whose first row and column vanish, and
        # p^a = p^A + I^a c + U u / D, whose first entry is tau_i
        bd = ib * dinv
        cdv = ic * dinv
        dd -= ib * bd
        de -= ib * cdv
        df -= ic * cdv
        ud = u * dinv
        pa1 += dd * cvx + de * cvy + ib * ud
        pa2 += de * cvx + df * cvy + ic * ud
        # move both to joint i-1, by r = l_{i-1} u_{i-1}
        rx = arm[1, i - 1] * work[0, i - 1]
        ry = arm[1, i - 1] * work[1, i - 1]
        cb = rx * de - ry * dd
        cc = rx * df - ry * de
        ca = rx * cc - ry * cb
        cd = dd
        ce = de
        cf = df
        p0 = tau[i] + rx * pa2 - ry * pa1
        p1 = pa1
        p2 = pa2
    # pass 3, base to tip: a' = X a_parent + c, qdd = (u - U^T a') / D, a = a' + S qdd;
    # as U = (D, U_x, U_y), the new absolute angular acceleration is (u - U_x a'_x - U_y a'_y) / D
    alpha = 0.0
    ax = 0.0
    ay = g
    for i in range(n):
        if i > 0:
            ax += work[3, i] - alpha * arm[1, i - 1] * work[1, i - 1]
            ay += work[4, i] + alpha * arm[1, i - 1] * work[0, i - 1]
        alpha_i = (out[i] - work[5, i] * ax - work[6, i] * ay) * work[2, i]
        out[i] = alpha_i - alpha
        alpha = alpha_i
    return True


# Taylor coefficients of rotated: sin d = d + d^3 (S1 + d^2 (S2 + d^2 S3)),
# cos d - 1 = d^2 (C1 + d^2 (C2 + d^2 (C3 + d^2 C4)))
_S1 = -1.0 / 6.0
_S2 = 1.0 / 120.0
_S3 = -1.0 / 5040.0
_C1 = -0.5
_C2 = 1.0 / 24.0
_C3 = -1.0 / 720.0
_C4 = 1.0 / 40320.0


@njit(cache=_CACHE, nogil=True, error_model="numpy", forceinline=True)
def shifted_angles_into(base: np.ndarray, dq: np.ndarray, q: np.ndarray, work: np.ndarray) -> None:
    """Fill ``work`` rows 0-1 with the cosines and sines of the absolute angles of ``q``, given
    those of ``q - dq`` in ``base`` (2, n), for a small step ``dq`` (n,).

    With :math:`\\Delta_i = \\sum_{j \\le i} \\delta q_j`, each angle is rotated,
    :math:`\\cos(\\phi + \\Delta) = \\cos\\phi + (\\cos\\phi\\,(\\cos\\Delta - 1) - \\sin\\phi
    \\sin\\Delta)` and likewise for the sine, with :math:`\\sin\\Delta` and
    :math:`\\cos\\Delta - 1` from their Taylor series, exact to rounding for
    :math:`|\\Delta| \\le 2^{-5}` (the next terms are below :math:`10^{-18}` relative). As
    accurate as :func:`angles_into` (whose rounding of the summed angle is of the same order) at a
    fraction of the cost of the sines and cosines; if a step is larger, it calls
    :func:`angles_into` on ``q`` instead.
    """
    n = dq.shape[0]
    delta = 0.0
    for i in range(n):
        delta += dq[i]
        if not abs(delta) <= 0.03125:
            angles_into(q, work)
            return
    delta = 0.0
    for i in range(n):
        delta += dq[i]
        work[0, i], work[1, i] = rotated(base[0, i], base[1, i], delta)


@njit(cache=_CACHE, nogil=True, error_model="numpy", inline=_INLINE)
def rotated(c: float, s: float, delta: float) -> tuple[float, float]:
    """:math:`(\\cos(\\phi + \\delta), \\sin(\\phi + \\delta))` from
    :math:`c = \\cos\\phi, s = \\sin\\phi` for :math:`|\\delta| \\le 2^{-5}`:
    :math:`c + (c(\\cos\\delta - 1) - s \\sin\\delta)` and likewise for the sine, with
    :math:`\\sin\\delta` and :math:`\\cos\\delta - 1` from their Taylor series to
    :math:`\\delta^7` and :math:`\\delta^8` (the next terms are below :math:`10^{-18}`
    relative there), in Horner form with fused multiply-adds (each rotation term one, the
    outer sums exact to rounding), so vectorisable in a lane loop as the block loop calls it.
    Against the nested form :math:`\\delta(1 - \\tfrac{\\delta^2}{6}(1 - \\dots))` it
    had before: half the operations for the same accuracy; the block loop's RK4 step of the
    paper arm 2003 -> 1880 ticks (``benchmarks/bench_block_parts.py``, three stage rotations
    a step)."""
    d2 = delta * delta
    ps = VM._fma(VM._fma(d2, _S3, _S2), d2, _S1)
    sin_d = VM._fma(delta * d2, ps, delta)
    pc = VM._fma(VM._fma(VM._fma(d2, _C4, _C3), d2, _C2), d2, _C1)
    cos_m1 = d2 * pc
    return c + VM._fma(c, cos_m1, -(s * sin_d)), s + VM._fma(s, cos_m1, c * sin_d)


@njit(cache=_CACHE, nogil=True, error_model="numpy", forceinline=True)
def mass_and_bias_into(
    arm: np.ndarray,
    g: float,
    q: np.ndarray,
    qd: np.ndarray,
    mmat: np.ndarray,
    h: np.ndarray,
    work: np.ndarray,
) -> None:
    """Fill ``mmat`` with :math:`M(q)` and ``h`` with :math:`h(q, \\dot q)`, sharing the trigonometry."""
    angles_into(q, work)
    _mass_from_angles(arm, q.shape[0], mmat, work)
    _rnea_from_angles(arm, g, qd, qd, 0.0, h, work)


@njit(cache=_CACHE, nogil=True, error_model="numpy", forceinline=True)
def potential_energy(arm: np.ndarray, g: float, q: np.ndarray, work: np.ndarray) -> float:
    """Potential energy :math:`V = g \\sum_i m_i y_{c,i}` (J, zero at ``y = 0``), with
    :math:`y_{c,i} = \\sum_{a<i} l_a \\sin\\phi_a + c_i \\sin\\phi_i`."""
    angles_into(q, work)
    y = 0.0
    v = 0.0
    for i in range(q.shape[0]):
        v += arm[0, i] * (y + arm[2, i] * work[1, i])
        y += arm[1, i] * work[1, i]
    return g * v


# rows of the (RK4_ROWS, n) scratch of rk4_step
_RK_K = 0  # 4 rows: the acceleration stages
_RK_DQ = 4
_RK_QTMP = 5
_RK_VTMP = 6
_RK_BASE = 7  # 2 rows: the sines and cosines of the step's start
#: Rows of the scratch array of :func:`rk4_step`.
RK4_ROWS = 9


@njit(cache=_CACHE, nogil=True, error_model="numpy", forceinline=True)
def rk4_step(
    arm: np.ndarray,
    g: float,
    q: np.ndarray,
    qd: np.ndarray,
    tau: np.ndarray,
    h: float,
    known: bool,
    scratch: np.ndarray,
    work: np.ndarray,
) -> bool:
    """Advance ``(q, qd)`` in place by one RK4 step of length ``h`` with constant ``tau``.

    ``scratch`` is ``(RK4_ROWS, n)``: the four acceleration stages (the velocity stages are
    recomputed from them) and small vectors. The stages' sines and cosines are those of ``q``
    (in ``work`` rows 0-1 already if ``known``) rotated by the stage's step
    (:func:`shifted_angles_into`). Returns ``False`` if a mass matrix was not positive definite.

    Compiled once as a function of its own and inlined by LLVM (``forceinline``) into the
    compiled function that calls it, rather than inlined in numba's IR: numba copies an
    IR-inlined body once per level of inlining, and the copies of this one, two levels deep into
    the loop (through :func:`slidingarm.models._dispatch.rk4_step`), cost about a second of the
    loop's first compilation. The arrays are borrowed (:func:`borrow`).
    """
    arm = borrow(arm)
    q = borrow(q)
    qd = borrow(qd)
    tau = borrow(tau)
    scratch = borrow(scratch)
    work = borrow(work)
    n = q.shape[0]
    k = scratch[_RK_K : _RK_K + 4]
    dq = scratch[_RK_DQ]
    qtmp = scratch[_RK_QTMP]
    vtmp = scratch[_RK_VTMP]
    base = scratch[_RK_BASE : _RK_BASE + 2]
    if not known:
        angles_into(q, work)
    for i in range(n):
        base[0, i] = work[0, i]
        base[1, i] = work[1, i]
        vtmp[i] = qd[i]
    # Stage s is at (q + c_s h v_{s-1}, qd + c_s h a_{s-1}), c = (1/2, 1/2, 1), with
    # v_1 = qd and v_s = qd + h/2 a_{s-1} for s = 2, 3. One loop, so that the inlined
    # forward dynamics is compiled once rather than once per stage.
    ok = True
    for s in range(4):
        if s > 0:
            c = 1.0 if s == 3 else 0.5
            for i in range(n):
                v_prev = qd[i] if s == 1 else qd[i] + 0.5 * h * k[s - 2, i]
                dq[i] = c * h * v_prev
                qtmp[i] = q[i] + dq[i]
                vtmp[i] = qd[i] + c * h * k[s - 1, i]
            shifted_angles_into(base, dq, qtmp, work)
        ok &= aba_from_angles_into(arm, g, vtmp, tau, k[s], work)
    for i in range(n):
        v1 = qd[i]
        v2 = qd[i] + 0.5 * h * k[0, i]
        v3 = qd[i] + 0.5 * h * k[1, i]
        v4 = qd[i] + h * k[2, i]
        q[i] += h / 6.0 * (v1 + 2.0 * v2 + 2.0 * v3 + v4)
        qd[i] += h / 6.0 * (k[0, i] + 2.0 * k[1, i] + 2.0 * k[2, i] + k[3, i])
    return ok
