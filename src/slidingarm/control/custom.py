"""User-written control laws compiled into the same loop as the built-in ones.

A :class:`CustomController` wraps a numba ``@njit`` kernel

.. code-block:: text

    kernel(t, q, qd, q_ref, qd_ref, qdd_ref, M, h, params, state, tau, s) -> None

``q``, ``qd`` the measured position and estimated velocity (n,); ``q_ref``, ``qd_ref``,
``qdd_ref`` the reference (n,); ``M`` (n, n) and ``h`` (n,) the nominal model's mass matrix and
bias at ``(q, qd)``, computed by the engine; ``params`` the controller's float64 vector;
``state`` a float64 vector of length ``state_size`` that the kernel may update (zeroed at the
start of every run). The kernel writes the torque ``tau`` and the sliding variable ``s`` (n,).
It is called through a first-class function pointer, so the compiled loop is compiled once
for every kernel; no Python runs per step.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from slidingarm._validate import ParameterTypeError
from slidingarm.control import _dispatch as LD
from slidingarm.control import _kernels as CK
from slidingarm.control.base import Controller, LawHandle, checked_inputs
from slidingarm.models.base import ArmModel

__all__ = ["CustomController"]

FloatArray = NDArray[np.float64]


def _is_dispatcher(kernel: Any) -> bool:
    from numba.core.registry import CPUDispatcher

    return isinstance(kernel, CPUDispatcher)


class CustomController(Controller):
    """A control law given as a compiled kernel (see the module docstring).

    Parameters
    ----------
    kernel : numba ``@njit`` function
        The law; compiled to :data:`slidingarm.control._dispatch.KERNEL_SIGNATURE` here. A
        module-level kernel makes the controller picklable (it pickles by reference).
    nominal : ArmModel
        The nominal model whose ``M`` and ``h`` the kernel receives.
    params : array_like of float
        The kernel's parameter vector (finite numbers).
    state_size : int
        Length of the state vector the kernel keeps between samples.
    name : str
        Name recorded in results.
    gains : sequence of str, optional
        Names of the entries of ``params``, in order, so that :meth:`replace` can change one by
        name (``replace(k=30)``); ``replace(params=...)`` always works.
    s_unit : str
        Unit of the ``s`` the kernel writes.

    Examples
    --------
    PDSMC with tanh switching, :math:`s = \\dot e + \\lambda e`,
    :math:`\\tau = M(\\ddot q_d - \\lambda\\dot e - k\\tanh(s/\\varepsilon)) + h`:

    >>> @numba.njit
    ... def pdsmc(t, q, qd, q_ref, qd_ref, qdd_ref, M, h, p, state, tau, s):  # doctest: +SKIP
    ...     lam, k, width = p[0], p[1], p[2]
    ...     n = q.shape[0]
    ...     a = np.empty(n)
    ...     for i in range(n):
    ...         ed = qd[i] - qd_ref[i]
    ...         s[i] = ed + lam * (q[i] - q_ref[i])
    ...         a[i] = qdd_ref[i] - lam * ed - k * np.tanh(s[i] / width)
    ...     for i in range(n):
    ...         tau[i] = h[i]
    ...         for j in range(n):
    ...             tau[i] += M[i, j] * a[j]
    """

    def __init__(
        self,
        kernel: Any,
        nominal: ArmModel,
        *,
        params: ArrayLike,
        state_size: int = 0,
        name: str = "custom",
        gains: tuple[str, ...] | list[str] | None = None,
        s_unit: str = "rad/s",
    ) -> None:
        if not _is_dispatcher(kernel):
            raise ParameterTypeError(
                "kernel must be a numba @njit function "
                f"kernel(t, q, qd, q_ref, qd_ref, qdd_ref, M, h, params, state, tau, s), got "
                f"{type(kernel).__name__}"
            )
        if not isinstance(nominal, ArmModel):
            raise ParameterTypeError(f"nominal must be an ArmModel, got {type(nominal).__name__}")
        if isinstance(params, str | bytes | set | frozenset | dict):
            raise ParameterTypeError(f"params must be a sequence of numbers, got {type(params).__name__}")
        from slidingarm._validate import has_bool

        if has_bool(params):
            raise ParameterTypeError(f"params must be numbers, not booleans, got {params!r}")
        try:
            p = np.array(params, dtype=np.float64).reshape(-1)
        except (TypeError, ValueError) as exc:
            raise ParameterTypeError(f"params must be a sequence of numbers, got {params!r}") from exc
        if not np.all(np.isfinite(p)):
            raise ValueError(f"params must be finite, got {p.tolist()}")
        if isinstance(state_size, bool) or not isinstance(state_size, int | np.integer):
            raise ParameterTypeError(f"state_size must be an integer >= 0, got {state_size!r}")
        if state_size < 0:
            raise ValueError(f"state_size must be an integer >= 0, got {state_size}")
        if not isinstance(name, str) or not name:
            raise ParameterTypeError(f"name must be a non-empty string, got {name!r}")
        names = tuple(gains) if gains is not None else ()
        if names and len(names) != p.shape[0]:
            raise ValueError(
                f"gains names {len(names)} entries but params has {p.shape[0]}: one name per entry"
            )
        if len(set(names)) != len(names) or {"params", "name", "state_size"} & set(names):
            raise ValueError(f"gains must be distinct names other than params/name, got {names}")
        try:
            pointer = LD.FunctionPointer(kernel, LD.KERNEL_SIGNATURE)
        except Exception as exc:  # numba's typing errors are long; say what is expected
            raise ParameterTypeError(
                f"kernel {getattr(kernel, '__name__', kernel)!r} does not compile for the "
                "signature (t: float64, q, qd, q_ref, qd_ref, qdd_ref: float64[::1], M: "
                "float64[:, ::1], h, params, state, tau, s: float64[::1]) -> None: "
                f"{str(exc).splitlines()[0] if str(exc) else type(exc).__name__}"
            ) from exc
        p.setflags(write=False)
        self._kernel = kernel
        self._pointer = pointer
        self._model = nominal
        self._p = p
        self._state_size = int(state_size)
        self.name = name
        self._gains = names
        self._s_unit = s_unit
        n = nominal.n
        self._state = np.zeros(self._state_size)
        self._mmat = np.empty((n, n))
        self._h = np.empty(n)
        self._work = np.empty((CK.CONTROL_WORK_ROWS, n))

    # ------------------------------------------------------------------ the contract
    @property
    def model(self) -> ArmModel:
        return self._model

    @property
    def kernel(self) -> Any:
        """The compiled kernel."""
        return self._kernel

    @property
    def params(self) -> FloatArray:
        """The kernel's parameter vector (read-only)."""
        return self._p

    @property
    def s_unit(self) -> str:
        return self._s_unit

    @property
    def gain_names(self) -> tuple[str, ...]:
        return self._gains

    @property
    def handle(self) -> LawHandle:
        return LawHandle(LD.LAW_CUSTOM, self._p, self._state_size, self._pointer, LD.entry_pointer())

    def replace(self, **changes: Any) -> CustomController:
        """A new controller with ``params``, ``nominal``, ``state_size``, ``name``, ``s_unit``
        or single named gains (``gains=`` given at construction) changed."""
        p = self._p.copy()
        kwargs: dict[str, Any] = {
            "params": p, "state_size": self._state_size, "name": self.name,
            "gains": self._gains or None, "s_unit": self._s_unit,
        }  # fmt: skip
        nominal = changes.pop("nominal", self._model)
        for key in list(changes):
            if key in kwargs:
                kwargs[key] = changes.pop(key)
        for key in list(changes):
            if key in self._gains:
                value = changes.pop(key)
                if isinstance(value, bool) or not isinstance(value, int | float | np.number):
                    raise ParameterTypeError(f"{key} must be a number, got {value!r}")
                p = np.array(kwargs["params"], dtype=np.float64)
                p[self._gains.index(key)] = value
                kwargs["params"] = p
        if changes:
            raise ParameterTypeError(
                f"CustomController.replace() got unknown parameter(s) {sorted(changes)}; it "
                f"takes params, nominal, state_size, name, s_unit and the gains {list(self._gains)}"
            )
        return CustomController(self._kernel, nominal, **kwargs)

    def to_dict(self) -> dict[str, Any]:
        d: dict[str, Any] = {
            "controller": self.name,
            "kernel": f"{self._kernel.py_func.__module__}.{self._kernel.py_func.__qualname__}",
            "params": self._p.tolist(),
            "state_size": self._state_size,
        }
        if self._gains:
            d["gains"] = dict(zip(self._gains, self._p.tolist(), strict=True))
        d["model"] = self._model.to_dict()
        return d

    def __repr__(self) -> str:
        return (
            f"CustomController({self._kernel.py_func.__name__}, params={self._p.tolist()}, "
            f"state_size={self._state_size}, name={self.name!r})"
        )

    def __reduce__(self) -> tuple[Any, ...]:
        return (
            _rebuild,
            (self._kernel, self._model, self._p.tolist(), self._state_size, self.name,
             self._gains or None, self._s_unit),
        )  # fmt: skip

    # ------------------------------------------------------------------ evaluation
    def reset(self) -> None:
        self._state[:] = 0.0

    def __call__(
        self,
        q: FloatArray,
        qd: FloatArray,
        q_ref: FloatArray,
        qd_ref: FloatArray,
        qdd_ref: FloatArray,
        dt: float = 0.0,
        t: float = 0.0,
    ) -> FloatArray:
        """Torque for one measured state (float64 arrays (n,), unchecked); advances the state."""
        tau = np.zeros(self.n)
        s = np.zeros(self.n)
        self._step(float(t), q, qd, q_ref, qd_ref, qdd_ref, tau, s)
        return tau

    def _step(self, t: float, *arrays: Any) -> None:
        mh = self._model.handle
        q, qd, q_ref, qd_ref, qdd_ref, tau, s = arrays
        LD.mass_and_bias_once(mh.kind, np.array(mh.params), mh.g, q, qd, self._mmat, self._h, self._work)
        self._kernel(
            t, q, qd, q_ref, qd_ref, qdd_ref, self._mmat, self._h, np.array(self._p), self._state,
            tau, s,
        )  # fmt: skip

    def evaluate(
        self,
        q: ArrayLike,
        qd: ArrayLike,
        q_ref: ArrayLike,
        qd_ref: ArrayLike,
        qdd_ref: ArrayLike,
        *,
        dt: float | None = None,
        t: float = 0.0,
    ) -> tuple[FloatArray, FloatArray]:
        """Validated evaluation: ``(tau, s)``, each (n,); advances the state.

        Raises
        ------
        ValueError
            On a wrong shape, a non-finite input, or a non-finite torque or ``s``.
        """
        n = self.n
        arrays = checked_inputs(n, q=q, qd=qd, q_ref=q_ref, qd_ref=qd_ref, qdd_ref=qdd_ref)
        if not math.isfinite(t):
            raise ValueError(f"t must be finite, got {t!r}")
        tau, s = np.zeros(n), np.zeros(n)
        saved = self._state.copy()
        self._step(float(t), *arrays, tau, s)
        bad = np.flatnonzero(~(np.isfinite(tau) & np.isfinite(s)))
        if bad.size:
            self._state[:] = saved
            raise ValueError(f"the kernel returned a non-finite torque or s at joint {bad[0] + 1}")
        return tau, s


def _rebuild(
    kernel: Any,
    model: ArmModel,
    params: list[float],
    state_size: int,
    name: str,
    gains: tuple[str, ...] | None,
    s_unit: str,
) -> CustomController:
    """Unpickle a :class:`CustomController`."""
    return CustomController(
        kernel, model, params=params, state_size=state_size, name=name, gains=gains, s_unit=s_unit
    )
