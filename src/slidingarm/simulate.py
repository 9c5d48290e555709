"""Fixed-step digital closed-loop simulation, single and batch (SPEC §5).

The controller runs at :math:`t_k = k\\,\\Delta t` on the measurement; its torque is held over
:math:`[t_k, t_{k+1})` (zero-order hold) while the plant is integrated by RK4 (``substeps``
equal steps per interval). The run is deterministic for a given seed. The loop itself is the
compiled :func:`slidingarm._engine.run_batch`; this module validates, prepares arrays and wraps
the output in typed results.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from slidingarm import _engine as E
from slidingarm._version import __version__
from slidingarm.control.controllers import SlidingModeController
from slidingarm.disturbances import (
    ConstantTorque,
    Disturbance,
    RandomTorque,
    SinusoidalTorque,
    disturbance_torque,
)
from slidingarm.models.planar import PlanarArm
from slidingarm.results import BatchResult, SimResult
from slidingarm.sensors import Sensor

if TYPE_CHECKING:
    from slidingarm.references import Reference

__all__ = ["DEFAULT_QD_LIMIT", "SimulationError", "simulate", "simulate_batch", "time_grid"]

FloatArray = NDArray[np.float64]

#: A run whose joint speed exceeds this (rad/s) is declared diverged.
DEFAULT_QD_LIMIT = 1e4

_STATUS_TEXT = {
    E.STATUS_NONFINITE: "a non-finite value (NaN or inf) appeared",
    E.STATUS_RUNAWAY: "the joint velocity ran away",
    E.STATUS_SINGULAR: "the mass matrix stopped being positive definite",
}


class SimulationError(RuntimeError):
    """A run diverged. ``time`` (s), ``joint`` (1-based) and ``run`` say where."""

    def __init__(self, message: str, *, time: float, joint: int, run: int) -> None:
        super().__init__(message)
        self.time = time
        self.joint = joint
        self.run = run


def time_grid(t_final: float, dt: float) -> FloatArray:
    """Sample times :math:`t_k = k\\,\\Delta t`, ``k = 0..N`` with :math:`N = t_f/\\Delta t`.

    The paper's run (4.5 s at 5e-4 s) has 9000 control intervals, hence 9001 samples including
    both ends. ``t_final`` must be a whole number of steps.
    """
    try:
        tf = float(t_final)
        h = float(dt)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"t_final and dt must be numbers, got {t_final!r}, {dt!r}") from exc
    if not (math.isfinite(h) and h > 0):
        raise ValueError(f"dt must be a finite sample time > 0 s, got {dt!r}")
    if not (math.isfinite(tf) and tf > 0):
        raise ValueError(f"t_final must be a finite duration > 0 s, got {t_final!r}")
    steps = round(tf / h)
    if steps < 1 or abs(steps * h - tf) > 1e-9 * max(1.0, tf):
        raise ValueError(f"t_final ({tf:g} s) must be a whole number of steps dt ({h:g} s)")
    return np.arange(steps + 1, dtype=np.float64) * h


def _vectors(name: str, value: ArrayLike, n: int) -> FloatArray:
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be numbers, got {value!r}") from exc
    if arr.ndim == 1:
        arr = arr[None, :]
    if arr.ndim != 2 or arr.shape[1] != n:
        raise ValueError(f"{name} must have shape ({n},) or (B, {n}), got {np.shape(value)}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite")
    return np.ascontiguousarray(arr)


def _listify(name: str, value: Any, cls: type) -> list[Any]:
    items = list(value) if isinstance(value, Sequence) and not isinstance(value, str) else [value]
    for item in items:
        if not isinstance(item, cls):
            raise ValueError(
                f"{name} must be a {cls.__name__} (or a sequence of them), got {type(item).__name__}"
            )
    if not items:
        raise ValueError(f"{name} must not be empty")
    return items


def simulate_batch(
    plant: PlanarArm | Sequence[PlanarArm],
    controller: SlidingModeController | Sequence[SlidingModeController],
    reference: Reference,
    *,
    q0: ArrayLike,
    qd0: ArrayLike | None = None,
    t_final: float,
    dt: float,
    substeps: int = 1,
    sensor: Sensor | None = None,
    disturbances: Sequence[Disturbance] = (),
    torque_limit: ArrayLike | None = None,
    seeds: int | Sequence[int] = 0,
    qd_limit: float = DEFAULT_QD_LIMIT,
) -> BatchResult:
    """Simulate ``B`` closed-loop runs on one time grid; signals have shape ``(B, T, n)``.

    Any of ``plant``, ``controller``, ``q0`` (``(B, n)``), ``qd0`` and ``seeds`` may vary per
    run; each is either one value shared by all runs or ``B`` values. Runs with different
    seeds draw different noise. Parameters are otherwise those of :func:`simulate`.

    Raises
    ------
    SimulationError
        If any run diverges; the message names the run, time and joint.
    """
    plants = _listify("plant", plant, PlanarArm)
    ctrls = _listify("controller", controller, SlidingModeController)
    n = plants[0].n
    for p in plants:
        if p.n != n:
            raise ValueError(f"all plants must have the same number of joints, got {p.n} and {n}")
    for c in ctrls:
        if c.n != n:
            raise ValueError(f"controller has {c.n} joints but the plant has {n}")
    ref_n = getattr(reference, "n", None)
    if ref_n != n or not hasattr(reference, "evaluate"):
        raise ValueError(f"reference must be a Reference with n = {n} joints, got {reference!r}")
    if isinstance(substeps, bool) or not isinstance(substeps, int | np.integer) or substeps < 1:
        raise ValueError(f"substeps must be an integer >= 1, got {substeps!r}")
    if not (math.isfinite(qd_limit) and qd_limit > 0):
        raise ValueError(f"qd_limit must be a finite speed > 0 rad/s, got {qd_limit!r}")
    sens = Sensor() if sensor is None else sensor
    if not isinstance(sens, Sensor):
        raise ValueError(f"sensor must be a Sensor, got {type(sensor).__name__}")
    kinds = (ConstantTorque, SinusoidalTorque, RandomTorque)
    dists = (disturbances,) if isinstance(disturbances, kinds) else tuple(disturbances)
    for d in dists:
        if not isinstance(d, kinds):
            raise ValueError(
                "disturbances must be torque disturbances (ConstantTorque, SinusoidalTorque, "
                f"RandomTorque), got {type(d).__name__}; a model mismatch belongs in the plant: "
                "ModelMismatch(...).apply(arm)"
            )

    q0a = _vectors("q0", q0, n)
    qd0a = _vectors("qd0", np.zeros(n) if qd0 is None else qd0, n)
    seed_list = [int(seeds)] if isinstance(seeds, int | np.integer) else [int(s) for s in seeds]
    if not seed_list:
        raise ValueError("seeds must not be empty")
    sizes = {len(plants), len(ctrls), q0a.shape[0], qd0a.shape[0], len(seed_list)} - {1}
    if len(sizes) > 1:
        raise ValueError(
            f"batch sizes differ: plants {len(plants)}, controllers {len(ctrls)}, q0 {q0a.shape[0]}, "
            f"qd0 {qd0a.shape[0]}, seeds {len(seed_list)} (each must be 1 or B)"
        )
    nb = sizes.pop() if sizes else 1

    t = time_grid(t_final, dt)
    nt = t.shape[0]
    qr, qdr, qddr = (np.ascontiguousarray(a, dtype=np.float64) for a in reference.evaluate(t))
    for name, a in (("q", qr), ("qd", qdr), ("qdd", qddr)):
        if a.shape != (nt, n) or not np.all(np.isfinite(a)):
            raise ValueError(
                f"reference {name} must be finite with shape ({nt}, {n}), got {a.shape}"
            )

    if torque_limit is None:
        tmax = np.full((1, n), np.inf)
    else:
        tl = np.asarray(torque_limit, dtype=np.float64)
        if tl.ndim > 1 or (tl.ndim == 1 and tl.shape[0] != n) or np.any(~(tl > 0)):
            raise ValueError(
                f"torque_limit must be > 0 N m, a scalar or one per joint ({n}), got {torque_limit!r}"
            )
        tmax = np.ascontiguousarray(np.broadcast_to(tl, (n,)))[None, :].copy()

    # random inputs, drawn per run from its own generator in a fixed order
    random = sens.random or any(isinstance(d, RandomTorque) for d in dists)
    run_seeds = seed_list if len(seed_list) == nb else seed_list * nb
    n_rand = nb if random else 1
    meas_add = np.empty((n_rand, nt, n))
    meas_hold = np.empty((n_rand, nt, n), dtype=np.bool_)
    dist = np.empty((n_rand, nt, n))
    for b in range(n_rand):
        rng = np.random.default_rng(run_seeds[b])
        meas_add[b], meas_hold[b] = sens.arrays(t, n, rng)
        dist[b] = disturbance_torque(dists, t, n, rng)
    vcode, vf = sens.velocity.params(n)

    def stack(items: list[Any], fn: Any) -> Any:
        return np.ascontiguousarray(np.stack([fn(x) for x in items]))

    plant_arm = stack(plants, lambda p: p.packed)
    plant_g = np.array([p.gravity for p in plants])
    compiled = [c.compiled() for c in ctrls]
    ci = np.ascontiguousarray(np.stack([c[0] for c in compiled]))
    cf = np.ascontiguousarray(np.stack([c[1] for c in compiled]))
    ctrl_arm = np.ascontiguousarray(np.stack([c[2] for c in compiled]))
    ctrl_g = np.array([c[3] for c in compiled])
    for c in ctrls:
        c.reset()

    out = [np.empty((nb, nt, n)) for _ in range(6)]
    status = np.zeros((nb, 3), dtype=np.int64)
    E.run_batch(
        plant_arm,
        plant_g,
        ci,
        cf,
        ctrl_arm,
        ctrl_g,
        q0a,
        qd0a,
        qr,
        qdr,
        qddr,
        meas_add,
        meas_hold,
        np.array([vcode], dtype=np.int64),
        vf[None, :, :].copy(),
        dist,
        tmax,
        float(dt),
        int(substeps),
        float(qd_limit),
        *out,
        status,
    )
    bad = np.flatnonzero(status[:, 0] != E.STATUS_OK)
    if bad.size:
        b = int(bad[0])
        code, k, j = (int(v) for v in status[b])
        when = float(t[k])
        run = f" (run {b} of {nb})" if nb > 1 else ""
        raise SimulationError(
            f"simulation diverged at t = {when:.6g} s, joint {j + 1}{run}: {_STATUS_TEXT[code]}"
            + (f" (|qd| > {qd_limit:g} rad/s)" if code == E.STATUS_RUNAWAY else "")
            + "; check the gains, the sample time and the torque limits",
            time=when,
            joint=j + 1,
            run=b,
        )

    params = []
    for b in range(nb):
        params.append(
            {
                "version": __version__,
                "plant": plants[b if len(plants) > 1 else 0].to_dict(),
                "controller": ctrls[b if len(ctrls) > 1 else 0].to_dict(),
                "reference": reference.to_dict(),
                "q0": q0a[b if q0a.shape[0] > 1 else 0].tolist(),
                "qd0": qd0a[b if qd0a.shape[0] > 1 else 0].tolist(),
                "t_final": float(t[-1]),
                "dt": float(dt),
                "substeps": int(substeps),
                "sensor": sens.to_dict(),
                "disturbances": [d.to_dict() for d in dists],
                "torque_limit": None if torque_limit is None else tmax[0].tolist(),
                "seed": run_seeds[b],
            }
        )
    shape = (nb, nt, n)
    return BatchResult(
        t=t,
        q=out[0],
        qd=out[1],
        q_ref=np.broadcast_to(qr, shape),
        qd_ref=np.broadcast_to(qdr, shape),
        q_meas=out[2],
        qd_meas=out[3],
        tau=out[4],
        s=out[5],
        params=params,
        seeds=[int(s) for s in run_seeds],
    )


def simulate(
    plant: PlanarArm,
    controller: SlidingModeController,
    reference: Reference,
    *,
    q0: ArrayLike,
    qd0: ArrayLike | None = None,
    t_final: float,
    dt: float,
    substeps: int = 1,
    sensor: Sensor | None = None,
    disturbances: Sequence[Disturbance] = (),
    torque_limit: ArrayLike | None = None,
    seed: int = 0,
    qd_limit: float = DEFAULT_QD_LIMIT,
) -> SimResult:
    """Simulate one closed-loop run of ``plant`` under ``controller`` tracking ``reference``.

    Parameters
    ----------
    plant : PlanarArm
        The real arm (the controller holds its own nominal model).
    controller : SlidingModeController
        The control law; its state is reset before the run.
    reference : Reference
        Desired trajectory with analytic derivatives, evaluated at the sample times.
    q0, qd0 : array_like, shape (n,)
        Initial state; ``qd0`` defaults to rest. The paper's is
        :data:`slidingarm.references.PAPER_Q0`.
    t_final, dt : float
        Duration and sample time (s); ``t_final`` is a whole number of steps.
    substeps : int
        RK4 steps per sample interval.
    sensor : Sensor, optional
        Position noise, faults and velocity estimate (default: exact measurement).
    disturbances : sequence of Disturbance
        Torque disturbances added to the plant's input.
    torque_limit : float or array_like (n,), optional
        Actuator limit :math:`|\\tau_i| \\le \\tau_{max,i}` (N m), applied to the controller output.
    seed : int
        Seed of the run's ``numpy.random.Generator``, recorded in the result.
    qd_limit : float
        Speed (rad/s) beyond which the run is declared diverged.

    Returns
    -------
    SimResult
        Every sample: ``t`` (T,), ``q, qd, q_ref, qd_ref, q_meas, qd_meas, tau, s`` (T, n).

    Raises
    ------
    SimulationError
        If the run diverges (non-finite state or runaway velocity); names time and joint.
    """
    if not isinstance(plant, PlanarArm):
        raise ValueError(f"plant must be a PlanarArm, got {type(plant).__name__}")
    if not isinstance(controller, SlidingModeController):
        raise ValueError(
            f"controller must be a SlidingModeController, got {type(controller).__name__}"
        )
    q0a = _vectors("q0", q0, plant.n)
    if q0a.shape[0] != 1:
        raise ValueError(
            f"q0 must have shape ({plant.n},) for one run; use simulate_batch for a batch"
        )
    if not isinstance(seed, int | np.integer):
        raise ValueError(f"seed must be an integer, got {seed!r}")
    batch = simulate_batch(
        plant,
        controller,
        reference,
        q0=q0a[0],
        qd0=qd0,
        t_final=t_final,
        dt=dt,
        substeps=substeps,
        sensor=sensor,
        disturbances=disturbances,
        torque_limit=torque_limit,
        seeds=int(seed),
        qd_limit=qd_limit,
    )
    return batch[0]
