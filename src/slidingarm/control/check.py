"""A conformance checker for control laws, as Gymnasium's ``check_env`` is for environments."""

from __future__ import annotations

import pickle

import numpy as np

from slidingarm.control.base import Controller
from slidingarm.models.base import ArmModel

__all__ = ["ControllerCheckError", "check_controller"]


class ControllerCheckError(AssertionError):
    """A controller broke its contract; the message names the check and what was seen."""


def check_controller(
    controller: Controller,
    model: ArmModel,
    *,
    states: int = 200,
    samples: int = 40,
    dt: float = 1e-3,
    seed: int = 0,
    rtol: float = 1e-12,
) -> None:
    """Check that ``controller`` honours the controller contract on ``model``.

    1. **Description:** ``n``, ``name``, ``label``, ``s_unit``, ``gain_names``, ``state_size``
       and :meth:`~Controller.to_dict` are what they claim; ``replace()`` with no change
       returns an equal controller.
    2. **Shapes and finiteness:** on ``states`` random states (angles in ±π, speeds in ±5
       rad/s, references nearby) :meth:`~Controller.evaluate` returns finite ``(tau, s)`` of
       shape (n,).
    3. **Determinism after reset:** the same inputs after :meth:`~Controller.reset` give the
       same outputs, bit for bit.
    4. **Python path = compiled path:** a ``samples``-sample closed loop on ``model`` through
       :func:`slidingarm.simulate`; the recorded torques and ``s`` equal those of
       :meth:`~Controller.evaluate` replayed on the recorded measurements to ``rtol``.
    5. **Pickling:** the controller round-trips through :mod:`pickle` and the copy computes the
       same torques.

    The controller is checked as it runs at ``dt`` (:meth:`~Controller.for_period`: an
    automatic ``eps_e`` is fixed for that period first).

    Raises
    ------
    ControllerCheckError
        Naming the first check that failed.
    TypeError
        If ``controller`` is not a Controller or ``model`` not an ArmModel.
    """
    from slidingarm.references import QuinticReference
    from slidingarm.simulate import SimulationError, simulate

    if not isinstance(controller, Controller):
        raise TypeError(f"controller must be a Controller, got {type(controller).__name__}")
    if not isinstance(model, ArmModel):
        raise TypeError(f"model must be an ArmModel, got {type(model).__name__}")
    # checked as it runs at dt: a parameter chosen from the period (an automatic eps_e) is
    # fixed, so that the Python path and the compiled loop evaluate the same law
    controller = controller.for_period(dt)
    n = model.n
    if controller.n != n:
        raise ControllerCheckError(f"controller has n = {controller.n}, the model {n}")
    for attr in ("name", "label", "s_unit"):
        if not isinstance(getattr(controller, attr), str) or not getattr(controller, attr):
            raise ControllerCheckError(f"{attr} must be a non-empty string")
    if not all(isinstance(g, str) for g in controller.gain_names):
        raise ControllerCheckError("gain_names must be strings")
    h = controller.handle
    if h.state_size != controller.state_size or h.state_size < 0:
        raise ControllerCheckError("state_size disagrees with the handle's")
    d = controller.to_dict()
    if d.get("controller") != controller.name or "model" not in d:
        raise ControllerCheckError("to_dict() must carry 'controller' (the name) and 'model'")
    again = controller.replace()
    if again.to_dict() != d:
        raise ControllerCheckError("replace() without changes changed the controller")

    rng = np.random.default_rng(seed)
    q = rng.uniform(-np.pi, np.pi, (states, n))
    qd = rng.uniform(-5.0, 5.0, (states, n))
    qr = q + rng.normal(0.0, 0.1, (states, n))
    qdr = rng.normal(0.0, 1.0, (states, n))
    qddr = rng.normal(0.0, 1.0, (states, n))

    def sweep() -> list[tuple[np.ndarray, np.ndarray]]:
        controller.reset()
        out = []
        for b in range(states):
            tau, s = controller.evaluate(q[b], qd[b], qr[b], qdr[b], qddr[b], dt=dt, t=b * dt)
            if tau.shape != (n,) or s.shape != (n,):
                raise ControllerCheckError(
                    f"evaluate returned shapes {tau.shape}, {s.shape}; expected ({n},) each"
                )
            out.append((tau, s))
        return out

    try:
        first = sweep()
    except ValueError as exc:
        raise ControllerCheckError(f"a non-finite or rejected output on a random state: {exc}") from exc
    second = sweep()
    for (a, sa), (b, sb) in zip(first, second, strict=True):
        if not (np.array_equal(a, b) and np.array_equal(sa, sb)):
            raise ControllerCheckError("outputs differ after reset(): the law is not deterministic")

    ref = QuinticReference(tuple(np.zeros(n)), tuple(np.full(n, 0.3)), duration=samples * dt)
    q0 = np.full(n, 0.05)
    try:
        run = simulate(model, controller, ref, q0=q0, t_final=samples * dt, dt=dt)
    except SimulationError as exc:
        raise ControllerCheckError(f"the closed loop on the model diverged: {exc}") from exc
    _, _, qddr_run = ref.evaluate(run.t)
    controller.reset()
    for k in range(run.t.shape[0]):
        tau, s = controller.evaluate(
            run.q_meas[k], run.qd_meas[k], run.q_ref[k], run.qd_ref[k], qddr_run[k], dt=dt,
            t=float(run.t[k]),
        )  # fmt: skip
        scale = max(1.0, float(np.max(np.abs(tau))))
        if not (np.allclose(tau, run.tau[k], rtol=rtol, atol=rtol * scale)
                and np.allclose(s, run.s[k], rtol=rtol, atol=rtol)):  # fmt: skip
            raise ControllerCheckError(
                f"the Python call path differs from the compiled loop at sample {k}: "
                f"tau {tau.tolist()} vs {run.tau[k].tolist()}"
            )
    try:
        copy = pickle.loads(pickle.dumps(controller))
    except Exception as exc:
        raise ControllerCheckError(f"the controller does not pickle: {exc}") from exc
    controller.reset()
    copy.reset()
    mine = controller.evaluate(q[0], qd[0], qr[0], qdr[0], qddr[0], dt=dt)
    theirs = copy.evaluate(q[0], qd[0], qr[0], qdr[0], qddr[0], dt=dt)
    if not (np.array_equal(mine[0], theirs[0]) and np.array_equal(mine[1], theirs[1])):
        raise ControllerCheckError("the unpickled controller computes other torques")
    controller.reset()
