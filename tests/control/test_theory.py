"""Simulations held to sliding-mode theory (issue 3, point 2).

Every run here has an exact model (controller model = plant = the paper's arm), no noise and the
true velocity, so SPEC §3's closed loop is :math:`\\dot s = -K\\varphi(s)` up to the
zero-order hold. Under ZOH the torque is computed at :math:`t_k` and held, so one sample obeys

.. math:: s_{k+1} = s_k - k\\,\\Delta t\\,\\varphi(s_k) + \\delta_k,

where the residual :math:`\\delta_k = \\int_{t_k}^{t_{k+1}} (\\dot s(t) - \\dot s(t_k))\\,dt` is
:math:`O(\\Delta t^2)`. The checks:

(a) sign switching: each :math:`s_i` reaches zero at :math:`t_{r,i} = |s_i(0)|/k_i`, and the
    discrete reaching law holds with an :math:`O(\\Delta t^2)` residual;
(b) started on the surface, TSMC and FTSMC follow :math:`\\dot e = -\\alpha e - \\beta
    \\mathrm{sig}(e)^\\gamma` and reach :math:`e = 0` at SPEC §3's :math:`t_s`;
(c) tanh/sat: the boundary layer is invariant and :math:`|s|` decays to the bound the ZOH
    residual allows;
(d) the simulated plant agrees with scipy's DOP853 integrating ``PlanarArm.forward_dynamics``
    under the same held torques.

Measured values (dt = 5e-4 unless stated) are written beside each check.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from slidingarm import (
    FTSMC,
    PAPER_Q0,
    PDSMC,
    TSMC,
    PaperReference,
    PlanarArm,
    SimResult,
    SlidingModeController,
    ftsm_convergence_time,
    simulate,
    tsm_convergence_time,
)

ARM = PlanarArm.paper()
REF = PaperReference()
N = ARM.n
DT = 5e-4
ALPHA = LAM = BETA = 2.0
GAMMA = 3 / 5
K = 20.0
WIDTH = 0.05


#: The guard these tests were measured with (their docstrings' numbers), set explicitly since
#: an unset eps_e is now chosen from dt (docs/theory.md §3).
EPS_E = 1e-9


def make(name: str, switching: str = "sign") -> SlidingModeController:
    extra: dict[str, float] = {} if switching == "sign" else {"width": WIDTH}
    if name in ("tsmc", "ftsmc"):
        extra["eps_e"] = EPS_E
    if name == "pdsmc":
        return PDSMC(ARM, lam=LAM, k=K, switching=switching, **extra)  # type: ignore[arg-type]
    if name == "tsmc":
        return TSMC(ARM, beta=BETA, p=5, q=3, k=K, switching=switching, **extra)  # type: ignore[arg-type]
    return FTSMC(ARM, alpha=ALPHA, beta=BETA, p=5, q=3, k=K, switching=switching, **extra)  # type: ignore[arg-type]


def run(name: str, switching: str, t_final: float, dt: float = DT, **kw: object) -> SimResult:
    return simulate(
        ARM,
        make(name, switching),
        REF,
        q0=PAPER_Q0,
        t_final=t_final,
        dt=dt,
        **kw,  # type: ignore[arg-type]
    )


# ---------------------------------------------------------------------------- (a) reaching
def reached_index(s: np.ndarray, k: float, dt: float) -> int:
    """First sample where ``s`` has changed sign or ``|s| <= k dt`` (one step from zero)."""
    hit = (np.sign(s) != np.sign(s[0])) | (np.abs(s) <= k * dt)
    return int(np.flatnonzero(hit)[0])


def crossing_time(t: np.ndarray, s: np.ndarray, idx: int, k: float) -> float:
    """Zero crossing of ``s`` near the reached sample ``idx``.

    Before the crossing ``s`` moves by ``-k dt sign(s)`` per sample, so the crossing is at
    ``t[idx] + |s[idx]|/k`` if ``s[idx]`` still has the initial sign, and interpolated linearly
    between ``idx-1`` and ``idx`` if it has changed sign.
    """
    if np.sign(s[idx]) == np.sign(s[0]):
        return float(t[idx] + abs(s[idx]) / k)
    frac = abs(s[idx - 1]) / abs(s[idx - 1] - s[idx])
    return float(t[idx - 1] + frac * (t[idx] - t[idx - 1]))


@pytest.mark.parametrize("name", ["pdsmc", "tsmc", "ftsmc"])
def test_sign_switching_reaches_the_surface_at_s0_over_k(name: str) -> None:
    """Each s_i reaches zero at |s_i(0)|/k within two samples.

    Measured (crossing time - |s0|/k, in samples): PDSMC (+0.38, -0.57, -0.09), TSMC
    (+0.68, -0.81, -0.10), FTSMC (+1.12, -1.84, -0.12). The offset is the accumulated ZOH residual
    sum(delta_k)/(k dt); it is a fixed number of samples as dt -> 0 (FTSMC joint 2: -1.85,
    -1.84, -1.83 at dt = 1e-3, 5e-4, 1e-4), i.e. an O(dt) error in time. The raw "reached"
    sample (sign change or |s| <= k dt) fires up to one sample before the crossing by
    construction, so it is held to [t_r - 3 dt, t_r + 2 dt] (measured worst -2.29 samples).
    """
    r = run(name, "sign", t_final=0.4)
    s0 = r.s[0]
    assert np.all(np.abs(s0) > 0.5)  # the paper's start is well off the surface
    t_r = np.abs(s0) / K
    for j in range(N):
        idx = reached_index(r.s[:, j], K, DT)
        t_cross = crossing_time(r.t, r.s[:, j], idx, K)
        assert abs(t_cross - t_r[j]) <= 2 * DT, (j, (t_cross - t_r[j]) / DT)
        assert t_r[j] - 3 * DT <= r.t[idx] <= t_r[j] + 2 * DT, (j, (r.t[idx] - t_r[j]) / DT)
        # before reaching, |s| falls by k dt per sample up to the O(dt²) residual
        before = np.abs(r.s[: idx + 1, j])
        assert np.all(np.diff(before) < 0)
        # after reaching, s chatters in the band |s| <= k dt + max|delta| (from |s_k| <= k dt:
        # |s_{k+1}| <= k dt - |s_k| + |delta_k|); measured max 1.008 k dt
        sj = r.s[:, j]
        delta = sj[1:] - sj[:-1] + K * DT * np.sign(sj[:-1])
        band = np.max(np.abs(r.s[idx:, j]))
        assert band <= K * DT + np.max(np.abs(delta))
        assert band <= 1.02 * K * DT


def test_zoh_reaching_residual_is_second_order() -> None:
    """delta_k = s_{k+1} - s_k + k dt sign(s_k) is O(dt²): max|delta|/dt² is the same at
    dt = 1e-3 and 5e-4 (measured 412.67 and 412.65 for FTSMC over the first 0.1 s)."""
    scaled = []
    for dt in (1e-3, 5e-4):
        r = run("ftsmc", "sign", t_final=0.1, dt=dt)
        s = r.s
        delta = s[1:] - s[:-1] + K * dt * np.sign(s[:-1])
        scaled.append(np.max(np.abs(delta)) / dt**2)
    assert scaled[1] == pytest.approx(scaled[0], rel=0.01)


# ---------------------------------------------------------------------------- (b) on the surface
E0 = np.asarray(PAPER_Q0) - REF(0.0)[0]  # (0.35, 0.75, 0.55)
E_TOL = 1e-6


def _on_surface_start(name: str) -> np.ndarray:
    """qd0 = qd_ref(0) - alpha e0 - beta sig(e0)^gamma, so that s(0) = 0 exactly."""
    qd_ref0 = REF(0.0)[1]
    alpha = ALPHA if name == "ftsmc" else 0.0
    return qd_ref0 - alpha * E0 - BETA * np.abs(E0) ** GAMMA * np.sign(E0)


def _analytic_error(name: str, t: np.ndarray) -> np.ndarray:
    """Solution of ė = -α e - β sig(e)^γ from E0 (zero after t_s), shape (T, n).

    With y = |e|^(1-γ): ẏ = -(1-γ)(α y + β), so TSM (α = 0) gives y = y0 - β(1-γ) t and FTSM
    y = (y0 + β/α) exp(-α(1-γ) t) - β/α.
    """
    y0 = np.abs(E0) ** (1 - GAMMA)
    tt = t[:, None]
    if name == "tsmc":
        y = y0 - BETA * (1 - GAMMA) * tt
    else:
        y = (y0 + BETA / ALPHA) * np.exp(-ALPHA * (1 - GAMMA) * tt) - BETA / ALPHA
    return np.sign(E0) * np.maximum(y, 0.0) ** (1 / (1 - GAMMA))


def _time_to(name: str, level: float) -> np.ndarray:
    """Analytic time at which |e| falls to ``level``: t_s minus the time from ``level`` to 0."""
    if name == "tsmc":
        return tsm_convergence_time(E0, BETA, GAMMA) - tsm_convergence_time(level, BETA, GAMMA)
    return ftsm_convergence_time(E0, ALPHA, BETA, GAMMA) - ftsm_convergence_time(
        level, ALPHA, BETA, GAMMA
    )


@pytest.mark.parametrize("switching", ["tanh", "sat"])
@pytest.mark.parametrize("name", ["tsmc", "ftsmc"])
def test_on_the_surface_the_error_vanishes_at_t_s(name: str, switching: str) -> None:
    """Started on s = 0, |e_i| < 1e-6 first at t_s (SPEC §3), to the sample.

    With an exact model ṡ = -kφ(s), so s stays 0 up to the ZOH residual; a smooth φ (tanh,
    sat) keeps it there (measured max |s| 1e-4 to 3.5e-4, against 0.0 at t = 0). Sign switching
    would not: sign(s_1) = ±1 for the first nonzero residual and s then chatters at k dt = 0.01,
    which holds |e| near (k dt/β)^(1/γ) ~ 1e-4 and not 1e-6 — hence tanh/sat here.

    t_s: TSM (0.821, 1.114, 0.984) s, FTSM (0.631, 0.797, 0.726) s. Measured first sample with
    |e| < 1e-6: 9.7 to 8.8 samples *before* t_s — as theory says, since from |e| = 1e-6 the
    surface still needs t_s(1e-6) ≈ 5 ms. Against the analytic time at which |e| = 1e-6 it is
    late by 0.2 to 1.2 samples (the first sample after the crossing). At dt = 1e-4 the same
    offsets are 0.1 to 1.4 samples.
    """
    qd0 = _on_surface_start(name)
    r = simulate(ARM, make(name, switching), REF, q0=PAPER_Q0, qd0=qd0, t_final=1.3, dt=DT)
    np.testing.assert_allclose(r.s[0], 0.0, atol=1e-15)
    t_s = (
        tsm_convergence_time(E0, BETA, GAMMA)
        if name == "tsmc"
        else ftsm_convergence_time(E0, ALPHA, BETA, GAMMA)
    )
    t_hit = _time_to(name, E_TOL)
    err = np.abs(r.e)
    for j in range(N):
        first = int(np.flatnonzero(err[:, j] < E_TOL)[0])
        t_first = r.t[first]
        # the brief's check: not later than t_s plus a few samples, not before 0.95 t_s
        assert 0.95 * t_s[j] <= t_first <= t_s[j] + 3 * DT
        # the sharp one: the first sample at or after the analytic crossing of 1e-6
        assert t_hit[j] <= t_first + 0.5 * DT, (j, (t_first - t_hit[j]) / DT)
        assert t_first <= t_hit[j] + 2 * DT, (j, (t_first - t_hit[j]) / DT)
        # and the error stays below 1e-6 for the rest of the run
        assert np.all(err[first:, j] < E_TOL)
    # s never left the surface by more than a small fraction of the layer (measured
    # max |s| = 1.2e-4 TSMC, 3.5e-4 FTSMC: the O(dt) offset of the ZOH residual)
    assert np.max(np.abs(r.s)) < 0.01 * WIDTH
    # the whole trajectory follows the sliding dynamics, to first order in dt: max
    # |e - e_analytic| measured 8.5e-6 (TSMC) and 2.6e-5 (FTSMC) at dt = 5e-4, halved at
    # dt = 2.5e-4 (|e0| up to 0.75)
    dev = np.max(np.abs(r.e - _analytic_error(name, r.t)))
    assert dev < 1e-4, dev
    r2 = simulate(ARM, make(name, switching), REF, q0=PAPER_Q0, qd0=qd0, t_final=1.3, dt=DT / 2)
    dev2 = np.max(np.abs(r2.e - _analytic_error(name, r2.t)))
    assert 0.4 < dev2 / dev < 0.6, (dev, dev2)


# ---------------------------------------------------------------------------- (c) boundary layer
def _phi(switching: str, s: np.ndarray) -> np.ndarray:
    return np.tanh(s / WIDTH) if switching == "tanh" else np.clip(s / WIDTH, -1.0, 1.0)


@pytest.mark.parametrize("switching", ["tanh", "sat"])
@pytest.mark.parametrize("name", ["pdsmc", "tsmc", "ftsmc"])
def test_boundary_layer_is_invariant_and_s_decays_to_the_zoh_bound(
    name: str, switching: str
) -> None:
    """Inside the layer |s| only decays, to the bound the ZOH residual allows.

    With D = max_k |delta_k| / dt (the residual as a disturbance rate) the discrete law is
    s_{k+1} = s_k - k dt φ(s_k) + dt d_k, |d_k| <= D. The map s -> s - k dt φ(s) is increasing
    (k dt/ε = 0.2 < 1), so:

    - |s| decreases while k|φ(s)| > D, i.e. while |s| > b with b = ε atanh(D/k) (tanh) or
      b = ε D/k (sat);
    - |s| <= ε is invariant (k φ(ε) > D), and so is |s| <= b.

    Measured: D from 0.019 to 0.46 (so b <= 0.023 ε), |s| never increases above b, and after
    entering the layer max |s| / ε from 0.84 to 0.99 (the first sample inside).
    """
    r = run(name, switching, t_final=2.0)
    s = r.s
    phi = _phi(switching, s)
    delta = s[1:] - s[:-1] + K * DT * phi[:-1]
    d_rate = np.max(np.abs(delta), axis=0) / DT
    assert np.all(d_rate < 0.5)  # the ZOH residual is a small fraction of k = 20
    bound = WIDTH * (np.arctanh(d_rate / K) if switching == "tanh" else d_rate / K)
    assert np.all(bound < 0.025 * WIDTH)
    for j in range(N):
        a = np.abs(s[:, j])
        inside = int(np.flatnonzero(a <= WIDTH)[0])
        assert np.all(a[inside:] <= WIDTH)
        settled = inside + int(np.flatnonzero(a[inside:] <= bound[j])[0])
        # strictly decreasing from the start until the bound is reached
        assert np.all(np.diff(a[: settled + 1]) < 0)
        # then held within it (rounding: 1e-15)
        assert np.all(a[settled:] <= bound[j] + 1e-15)
        # the decay into the bound takes a few time constants ε/k = 2.5 ms, not longer than
        # log(ε/b) of them plus the reaching phase
        assert r.t[settled] - r.t[inside] <= (WIDTH / K) * (np.log(WIDTH / bound[j]) + 2.0)


# ---------------------------------------------------------------------------- (d) solve_ivp
def _replay(r: SimResult) -> np.ndarray:
    """Integrate the plant with DOP853 under the result's held torques, from q0, carrying
    solve_ivp's own state from interval to interval. Returns the state at every sample."""
    y = np.concatenate([r.q[0], r.qd[0]])
    out = np.empty((r.t.shape[0], 2 * N))
    out[0] = y

    def rhs(_t: float, x: np.ndarray, tau: np.ndarray) -> np.ndarray:
        return np.concatenate([x[N:], ARM.forward_dynamics(x[:N], x[N:], tau)])

    for k in range(r.t.shape[0] - 1):
        sol = solve_ivp(
            rhs,
            (r.t[k], r.t[k + 1]),
            y,
            method="DOP853",
            rtol=1e-12,
            atol=1e-12,
            args=(r.tau[k],),
        )
        assert sol.success, sol.message
        y = sol.y[:, -1]
        out[k + 1] = y
    return out


def test_plant_integration_agrees_with_solve_ivp() -> None:
    """Max |q - q_DOP853| over 1 s of the paper's FTSMC run with substeps = 4 (RK4 step
    1.25e-4 s): measured 1.1e-12 rad (q̇: 4.2e-12 rad/s). Required: 1e-10 (SPEC's RK4 with
    ZOH is the plant's exact flow to that accuracy; the brief asks for 1e-8)."""
    r = run("ftsmc", "sign", t_final=1.0, substeps=4)
    ref = _replay(r)
    assert np.max(np.abs(ref[:, :N] - r.q)) <= 1e-10
    assert np.max(np.abs(ref[:, N:] - r.qd)) <= 1e-9


def test_rk4_substeps_converge_at_fourth_order() -> None:
    """One RK4 step per sample vs two: the discrepancy to DOP853 falls by 2^4 (measured
    2.6e-10 -> 1.7e-11 over 1 s, ratio 15.9). Here over 0.25 s of the same run:
    5.5e-12 -> 3.4e-13, ratio 16.2."""
    errs = []
    for substeps in (1, 2):
        r = run("ftsmc", "sign", t_final=0.25, substeps=substeps)
        errs.append(np.max(np.abs(_replay(r)[:, :N] - r.q)))
    ratio = errs[0] / errs[1]
    assert 10.0 < ratio < 25.0, (errs, ratio)
