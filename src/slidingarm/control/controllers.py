"""Model-based sliding-mode controllers for an n-joint arm (docs/theory.md §3).

A controller is a sliding surface, a reaching law and a nominal arm model:

.. math::

    \\tau = \\hat M(q)\\,[\\ddot q_d - \\nu(e, \\dot e) - r(s)] + \\hat h(q, \\dot q)

with the classic reaching term :math:`r = K\\varphi(s)`, :math:`\\varphi \\in` {sign, tanh(s/ε),
sat(s/ε)}, or the super-twisting one :math:`r = k_1\\mathrm{sig}(s)^{1/2} + w`,
:math:`\\dot w = k_2\\,\\mathrm{sign}(s)` (Levant 1993). With an exact model the closed loop obeys
:math:`\\dot s = -r(s)` joint by joint.

``law="paper"`` replaces the law by the paper's eqs. 19-22 (see
:func:`slidingarm.control._kernels.control_into`); it exists to measure that erratum.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, ClassVar, Literal, NoReturn, cast

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray

from slidingarm._gc import paused
from slidingarm._validate import ParameterTypeError
from slidingarm.control import _dispatch as LD
from slidingarm.control import _kernels as CK
from slidingarm.control.base import Controller, LawHandle, checked_inputs
from slidingarm.control.surfaces import (
    DEFAULT_EPS_E,
    FastTerminal,
    FastTerminalSurface,
    LinearSurface,
    NonsingularTerminal,
    Surface,
    TerminalSurface,
    gain,
)
from slidingarm.models.base import ArmModel

__all__ = [
    "CONTROLLERS",
    "FTSMC",
    "MAX_AUTO_EPS_E",
    "MIN_AUTO_EPS_E",
    "NTSMC",
    "PDSMC",
    "SAMPLED_GAIN_LIMIT",
    "SWITCHING_LAWS",
    "TSMC",
    "Law",
    "Reaching",
    "SlidingModeController",
    "Switching",
    "guard_for_period",
]

FloatArray = NDArray[np.float64]
Switching = Literal["sign", "tanh", "sat"]
Law = Literal["model", "paper"]
Reaching = Literal["classic", "super-twisting"]

#: Switching functions by name, with their compiled codes.
SWITCHING_LAWS: dict[str, int] = {
    "sign": CK.SWITCH_SIGN,
    "tanh": CK.SWITCH_TANH,
    "sat": CK.SWITCH_SAT,
}
_LAWS: dict[str, int] = {"model": CK.LAW_MODEL, "paper": CK.LAW_PAPER}
_REACHING: dict[str, int] = {"classic": CK.REACH_CLASSIC, "super-twisting": CK.REACH_SUPER_TWISTING}

#: Boundary-layer width used by ``tanh``/``sat`` when none is given, in the unit of ``s``
#: (rad/s; rad for :class:`NTSMC`).
DEFAULT_WIDTH = 0.05


#: The inputs of :meth:`SlidingModeController.evaluate`, in order (their names in messages).
_INPUT_NAMES: tuple[str, ...] = ("q", "qd", "q_ref", "qd_ref", "qdd_ref")
#: Their number (a constant of the compiled checks).
_N_INPUTS = len(_INPUT_NAMES)
#: :func:`_evaluate_checked`'s code for a call whose inputs and outputs are all finite.
_OK = -1
#: :func:`_evaluate_checked`'s code for an input of another shape than (n,).
_BAD_SHAPE = -2
#: The dtype of the fast path's inputs (numpy's one float64 instance, compared by identity).
_F64 = np.dtype(np.float64)


def _scratch_rows(n: int) -> int:
    """Rows of a controller's scratch (n columns): the compiled law's,
    ``CK.CONTROL_WORK_ROWS + 2 n``, then those of a validated call (:func:`_evaluate_checked`):
    one for a copy of each input and one for the super-twisting integral before the call."""
    return CK.CONTROL_WORK_ROWS + 2 * n + _N_INPUTS + 1


def _checked_entry(c: SlidingModeController) -> Callable[..., int]:
    """The compiled :func:`_evaluate_checked` for controller ``c``'s own arrays and any
    one-dimensional float64 inputs (compiled, or loaded from numba's cache, the first time a
    controller with arrays of these types asks), as a function to call without the
    dispatcher.

    The inputs are typed read-only, possibly unaligned, of any layout (``'A'``), which every
    one-dimensional native float64 array is (contiguous or strided, writable or not); the
    compiled call copies them into contiguous rows of the scratch before the law reads them.
    The function skips the dispatcher's resolution of the fourteen arguments' types (0.3-0.4
    us a call): it converts its arguments to the signature's types with no check beyond the
    element size, so its caller must pass exactly those types (``evaluate`` checks the
    inputs' class, dtype and number of dimensions; the other arguments are the controller's
    own arrays, whose types this signature is made of, and fresh float64 outputs).
    No other signature is compiled at call time: a call through the dispatcher with other
    types raises ``TypeError`` rather than compiling a specialisation for them.
    """
    from numba import typeof, types

    vec = types.float64[::1]
    vin = types.Array(types.float64, 1, "A", readonly=True, aligned=False)
    sig = (
        typeof(c._p), types.int64, typeof(c._mparams), types.float64, vin, vin, vin, vin, vin,
        typeof(c._state), types.float64, vec, vec, typeof(c._scratch),
    )  # fmt: skip
    if not any(tuple(known) == sig for known in _evaluate_checked.signatures):
        _evaluate_checked.disable_compile(False)
        try:
            with paused():  # no automatic garbage collection while compiling (slidingarm._gc)
                _evaluate_checked.compile(sig)
        finally:
            _evaluate_checked.disable_compile(True)
    return cast("Callable[..., int]", _evaluate_checked.get_overload(sig))


@njit(cache=True, nogil=True, error_model="numpy")
def _first_nonfinite(a: np.ndarray) -> int:
    """Index of the first element of ``a`` (n,) that is NaN or infinite; -1 if none."""
    for j in range(a.shape[0]):
        if not math.isfinite(a[j]):
            return j
    return -1


# no nogil: a call from Python that computes for well under a microsecond gains nothing from
# releasing the GIL, whose release and re-acquisition cost 0.05-0.1 us a call and, in a program
# with other Python threads, let one of them take the GIL for up to its switch interval (5 ms)
@njit(cache=True, error_model="numpy")
def _evaluate_checked(
    p: np.ndarray,
    mkind: int,
    mparams: np.ndarray,
    g: float,
    q: np.ndarray,
    qd: np.ndarray,
    q_ref: np.ndarray,
    qd_ref: np.ndarray,
    qdd_ref: np.ndarray,
    st_state: np.ndarray,
    dt: float,
    tau_out: np.ndarray,
    s_out: np.ndarray,
    scratch: np.ndarray,
) -> int:
    """:func:`slidingarm.control._dispatch.control_once` with the checks of a validated call.

    The five inputs (n,), of any layout, are first copied into five rows of ``scratch`` after
    the law's (:func:`_scratch_rows`), contiguous, which the law then reads: the same values,
    so the same torque, bit for bit, as the law on the inputs themselves.

    Returns :data:`_OK` (-1) when every input and output is finite; ``i`` in 0..4 when input
    ``i`` (in :data:`_INPUT_NAMES` order) holds a NaN or an infinity, before anything is
    computed; ``5 + j`` when the torque or ``s`` of joint ``j`` is not finite, with the
    super-twisting integral ``st_state`` restored to its value before the call (kept in the
    last row of ``scratch``); :data:`_BAD_SHAPE` (-2) when an input is not of the outputs'
    length ``n`` (or ``scratch`` has not the rows of :func:`_scratch_rows`).
    """
    n = tau_out.shape[0]
    base = CK.CONTROL_WORK_ROWS + 2 * n
    if (
        q.shape[0] != n
        or qd.shape[0] != n
        or q_ref.shape[0] != n
        or qd_ref.shape[0] != n
        or qdd_ref.shape[0] != n
        or s_out.shape[0] != n
        or scratch.shape[0] != base + _N_INPUTS + 1
        or scratch.shape[1] != n
    ):
        return _BAD_SHAPE
    x = scratch[base:]
    for j in range(n):
        x[0, j] = q[j]
        x[1, j] = qd[j]
        x[2, j] = q_ref[j]
        x[3, j] = qd_ref[j]
        x[4, j] = qdd_ref[j]
    for i in range(_N_INPUTS):
        if _first_nonfinite(x[i]) >= 0:
            return i
    saved = scratch[base + _N_INPUTS]
    for j in range(n):
        saved[j] = st_state[j]
    LD.control_once(
        p, mkind, mparams, g, x[0], x[1], x[2], x[3], x[4], st_state, dt, tau_out, s_out,
        scratch,
    )  # fmt: skip
    for j in range(n):
        if not (math.isfinite(tau_out[j]) and math.isfinite(s_out[j])):
            for i in range(n):
                st_state[i] = saved[i]
            return 5 + j
    return _OK


class SlidingModeController(Controller):
    """A sliding-mode controller: surface + reaching law + nominal model.

    Prefer the named controllers :class:`PDSMC`, :class:`TSMC`, :class:`FTSMC`, :class:`NTSMC`.

    Parameters
    ----------
    model : ArmModel
        The controller's nominal arm (:math:`\\hat M, \\hat h`); pass an arm different from the
        plant's to model uncertainty.
    surface : Surface
        The sliding surface.
    k : float or array_like (n,)
        Reaching gain :math:`K = \\mathrm{diag}(k_i) > 0` (for super-twisting: :math:`k_1`).
    switching : {"sign", "tanh", "sat"}
        Switching function :math:`\\varphi` (for super-twisting: the one in the integral).
    width : float or array_like, optional
        Boundary-layer width :math:`\\varepsilon > 0` of ``tanh``/``sat``
        (default :data:`DEFAULT_WIDTH`); not accepted with ``sign``.
    law : {"model", "paper"}
        The correct model-based law (default) or the paper's literal one.
    reaching : {"classic", "super-twisting"}
        :math:`r = K\\varphi(s)` or the super-twisting algorithm, which needs ``k2``.
    k2 : float or array_like, optional
        Super-twisting integral gain :math:`k_2 > 0`.
    """

    name: str = "smc"

    #: One line on the law, for listings (``slidingarm list``) and the config schema.
    DESCRIPTION: ClassVar[str] = "sliding-mode control on a given surface"
    #: Which surface gains the constructor takes: ``"linear"`` (:attr:`LINEAR_NAME`),
    #: ``"beta"``, ``"exponent"`` (``gamma`` or ``p``, ``q``).
    SURFACE_GAINS: ClassVar[tuple[str, ...]] = ()
    #: The constructor's name of the linear surface gain, if it has one.
    LINEAR_NAME: ClassVar[str | None] = None
    #: Whether the surface has the singular term :math:`\beta\,\mathrm{sig}(e)^\gamma`
    #: (``eps_e`` guards it; ``allow_nonterminal`` may admit :math:`\gamma \ge 1`).
    TERMINAL: ClassVar[bool] = False
    #: The exponent's open range: ``(0, 1)`` for terminal surfaces, ``(1, 2)`` for the
    #: nonsingular one (whose exponent is :math:`p/q`, the reciprocal of :math:`\gamma = q/p`).
    EXPONENT_RANGE: ClassVar[tuple[float, float]] = (0.0, 1.0)

    def __init__(
        self,
        model: ArmModel,
        surface: Surface,
        *,
        k: ArrayLike,
        switching: Switching = "sign",
        width: ArrayLike | None = None,
        law: Law = "model",
        reaching: Reaching = "classic",
        k2: ArrayLike | None = None,
    ) -> None:
        if not isinstance(model, ArmModel):
            raise ParameterTypeError(
                "model must be an arm model (an ArmModel such as PlanarArm: the controller's "
                f"nominal arm), got {type(model).__name__}"
            )
        if not hasattr(self, "_eps_auto"):
            self._eps_auto = False
        if not hasattr(self, "_kwargs"):
            # a bare SlidingModeController: its surface is a constructor argument too
            self._kwargs: dict[str, Any] = {"surface": surface}
        self._kwargs.update(
            k=k, switching=switching, width=width, law=law, reaching=reaching, k2=k2
        )
        if switching not in SWITCHING_LAWS:
            raise ValueError(
                f"switching must be one of {sorted(SWITCHING_LAWS)}, got {switching!r}"
            )
        if law not in _LAWS:
            raise ValueError(f"law must be 'model' or 'paper', got {law!r}")
        if reaching not in _REACHING:
            raise ValueError(f"reaching must be 'classic' or 'super-twisting', got {reaching!r}")
        n = model.n
        kk = gain("k", k)
        if switching == "sign":
            if width is not None:
                raise ValueError(
                    "width (the boundary layer) applies to 'tanh' and 'sat' only, not 'sign'"
                )
            ww = np.array(1.0)
        else:
            ww = gain("width", DEFAULT_WIDTH if width is None else width)
        if reaching == "super-twisting":
            if k2 is None:
                raise ValueError(
                    "k2 (the super-twisting integral gain) is required with reaching='super-twisting'"
                )
            kk2 = gain("k2", k2)
        else:
            if k2 is not None:
                raise ValueError("k2 applies to reaching='super-twisting' only")
            kk2 = np.array(0.0)
        cf = np.zeros((CK.NCF, n))
        rows = dict(surface.rows())
        rows[CK.CF_K] = kk
        rows[CK.CF_WIDTH] = ww
        rows[CK.CF_K2] = kk2
        rows.setdefault(CK.CF_EPS_E, np.array(DEFAULT_EPS_E))
        names = {
            CK.CF_ALPHA: "alpha",
            CK.CF_BETA: "beta",
            CK.CF_GAMMA: "gamma",
            CK.CF_K: "k",
            CK.CF_WIDTH: "width",
            CK.CF_K2: "k2",
            CK.CF_EPS_E: "eps_e",
        }
        for row, value in rows.items():
            if value.ndim == 1 and value.shape[0] != n:
                raise ValueError(
                    f"{names[row]} has {value.shape[0]} values but the model has {n} joints "
                    "(give a scalar or one value per joint)"
                )
            cf[row] = value
        ci = np.zeros(CK.NCI, dtype=np.int64)
        ci[CK.CI_SURFACE] = surface.code
        ci[CK.CI_SWITCHING] = SWITCHING_LAWS[switching]
        ci[CK.CI_LAW] = _LAWS[law]
        ci[CK.CI_REACHING] = _REACHING[reaching]
        self._model = model
        self._surface = surface
        self._switching: str = switching
        self._law: str = law
        self._reaching: str = reaching
        self._ci = ci
        self._cf = cf
        p = CK.pack(ci, cf)
        p.setflags(write=False)
        self._p = p
        self._k = kk
        self._width = None if switching == "sign" else ww
        self._k2 = None if reaching == "classic" else kk2
        # Python call path: preallocated scratch and the super-twisting integral
        self._scratch = np.empty((_scratch_rows(n), n))
        self._state = np.zeros(n)
        self._s = np.empty(n)
        # evaluate's compiled checks, looked up on the first validated call (_checked_entry)
        self._checked: Callable[..., int] | None = None
        self._n = n
        mh = model.handle
        self._mkind = mh.kind
        self._mparams = mh.params
        self._g = mh.g

    # ------------------------------------------------------------------ parameters
    @property
    def model(self) -> ArmModel:
        """The nominal arm the law uses."""
        return self._model

    @property
    def handle(self) -> LawHandle:
        """The law for compiled code: the sliding-mode kind, its parameter vector."""
        entry = LD.paper_pointer() if self._law == "paper" else LD.NULL
        return LawHandle(LD.LAW_SLIDING_MODE, self._p, self.state_size, LD.NULL, entry)

    @property
    def state_size(self) -> int:
        """``n`` for super-twisting (the integral :math:`w`), else 0."""
        return self._n if self._reaching == "super-twisting" else 0

    @property
    def gain_names(self) -> tuple[str, ...]:
        """The constructor's numeric parameters this controller uses (for :meth:`replace`)."""
        names = [
            k
            for k, v in self._surface_params().items()
            if k != "surface" and (_numeric(v) or k == "eps_e")  # eps_e None: automatic
        ]
        names.append("k")
        if self._width is not None:
            names.append("width")
        if self._k2 is not None:
            names.append("k2")
        return tuple(names)

    @property
    def s_unit(self) -> str:
        """Unit of ``s``: rad/s for :math:`s = \\dot e + \\dots`, rad for the nonsingular surface
        :math:`s = e + \\beta^{-1}\\mathrm{sig}(\\dot e)^{p/q}`."""
        return "rad" if self._ci[CK.CI_SURFACE] == CK.SURFACE_NONSINGULAR else "rad/s"

    def for_period(self, dt: float) -> SlidingModeController:
        """This controller as it runs at control period ``dt`` (s): with an automatic guard
        (``eps_e=None``, the default of :class:`TSMC` and :class:`FTSMC`) a copy whose
        ``eps_e`` is :func:`guard_for_period` of its terminal gains and ``dt``; otherwise
        ``self``, unchanged (a guard the user set is kept). :func:`slidingarm.simulate` and
        :func:`slidingarm.simulate_batch` call it when the run starts."""
        if not self._eps_auto:
            return self
        ft = cast(FastTerminalSurface, self._surface)
        return self.replace(eps_e=guard_for_period(ft.beta, ft.gamma, dt))

    @property
    def eps_e(self) -> float | None:
        r"""The singularity guard :math:`\varepsilon_e` (rad) of a terminal surface: ``None``
        while it is automatic and not yet resolved for a control period (:meth:`for_period`);
        ``None`` too for a surface without a singular term."""
        surface = self._surface
        if self._eps_auto or not isinstance(surface, FastTerminalSurface):
            return None
        return float(surface.eps_e) if np.any(surface.beta > 0) else None

    def replace(self, **changes: Any) -> SlidingModeController:
        """A new controller of the same class with ``changes`` to the constructor's arguments
        (``model`` included), validated as a new one is.

        Changing ``gamma`` drops ``p``/``q`` given before, and the reverse; switching to
        ``"sign"`` drops ``width``; switching ``reaching`` to ``"classic"`` drops ``k2``.

        Examples
        --------
        >>> ftsmc.replace(k=30, switching="tanh", width=0.05)  # doctest: +SKIP
        """
        kwargs = dict(self._kwargs)
        allowed = {"model", *kwargs}
        unknown = sorted(set(changes) - allowed)
        if unknown:
            raise ParameterTypeError(
                f"{type(self).__name__}.replace() got unknown parameter(s) {unknown}; "
                f"it takes {sorted(allowed)}"
            )
        if "gamma" in changes:
            kwargs.pop("p", None)
            kwargs.pop("q", None)
        if {"p", "q"} & set(changes):
            kwargs["gamma"] = None
        if changes.get("switching") == "sign" and "width" not in changes:
            kwargs["width"] = None
        if changes.get("reaching") == "classic" and "k2" not in changes:
            kwargs["k2"] = None
        kwargs.update(changes)
        model = kwargs.pop("model", self._model)
        if type(self) is SlidingModeController:
            surface = kwargs.pop("surface")
            return SlidingModeController(model, surface, **kwargs)
        return type(self)(model, **kwargs)

    @property
    def surface(self) -> Surface:
        """The sliding surface."""
        return self._surface

    @property
    def n(self) -> int:
        """Number of joints."""
        return self._model.n

    @property
    def switching(self) -> str:
        """Name of the switching function."""
        return self._switching

    @property
    def law(self) -> str:
        """``"model"`` or ``"paper"``."""
        return self._law

    @property
    def reaching(self) -> str:
        """``"classic"`` or ``"super-twisting"``."""
        return self._reaching

    @property
    def k(self) -> FloatArray:
        """Per-joint reaching gains, shape (n,)."""
        return self._cf[CK.CF_K].copy()

    @property
    def stateful(self) -> bool:
        """Whether the law keeps state between calls (super-twisting integral)."""
        return self._reaching == "super-twisting"

    def compiled(self) -> tuple[NDArray[np.int64], FloatArray, FloatArray, float]:
        """``(ci, cf, model params, g)``: the codes and table packed in :attr:`handle` (copies)."""
        return self._ci.copy(), self._cf.copy(), self._mparams.copy(), self._g

    def _surface_params(self) -> dict[str, Any]:
        """The surface's entries of :meth:`to_dict`: here the surface's own description
        (with its ``"surface"`` kind); the named controllers give their constructor's names."""
        return self._surface.to_dict()

    def to_dict(self) -> dict[str, Any]:
        """JSON-able parameters, including the nominal model.

        The keys are the constructor's parameter names: ``controller`` (the class's
        :attr:`name`), the surface's parameters (``lam`` for :class:`PDSMC`; ``alpha``,
        ``beta``, ``gamma``, ``eps_e`` for the terminal ones, ``allow_nonterminal`` only when
        set; the surface's own description for a bare :class:`SlidingModeController`), then
        ``k``, ``switching``, ``width`` (not with ``sign``), ``law``, ``reaching``, ``k2``
        (super-twisting only) and ``model``. ``gamma`` is the exponent whether it was given
        as ``gamma`` or as ``(p, q)``.
        """
        d: dict[str, Any] = {"controller": self.name, **self._surface_params()}
        d["k"] = _tolist(self._k)
        d["switching"] = self._switching
        if self._width is not None:
            d["width"] = _tolist(self._width)
        d["law"] = self._law
        d["reaching"] = self._reaching
        if self._k2 is not None:
            d["k2"] = _tolist(self._k2)
        d["model"] = self._model.to_dict()
        return d

    def __repr__(self) -> str:
        fields = ", ".join(
            f"{k}={v!r}" for k, v in self.to_dict().items() if k not in ("model", "controller")
        )
        return f"{type(self).__name__}({fields})"

    # ------------------------------------------------------------------ evaluation
    def reset(self) -> None:
        """Clear the controller's state (the super-twisting integral)."""
        self._state[:] = 0.0

    def __call__(
        self,
        q: FloatArray,
        qd: FloatArray,
        q_ref: FloatArray,
        qd_ref: FloatArray,
        qdd_ref: FloatArray,
        dt: float = 0.0,
    ) -> FloatArray:
        """Control torque for one measured state, shape (n,).

        The fast path: arguments must be float64 arrays of shape (n,) (no checks beyond what
        the compiled kernel needs). A stateful law advances its integral by ``dt`` (s).
        Use :meth:`evaluate` for validated inputs that also returns ``s``.
        """
        # the cheapest fresh array (a view of a (2, n) one cost 0.15 us more); s is discarded
        tau = np.empty(self._n)
        if self._law == "paper":
            self._paper_call(q, qd, q_ref, qd_ref, qdd_ref, dt, tau, self._s)
            return tau
        LD.control_once(
            self._p,
            self._mkind,
            self._mparams,
            self._g,
            q,
            qd,
            q_ref,
            qd_ref,
            qdd_ref,
            self._state,
            dt,
            tau,
            self._s,
            self._scratch,
        )
        return tau

    def _paper_call(self, *args: Any) -> None:
        """The Python call of the paper's law, through its pointer (writable copies: the
        pointer's argument types)."""
        dt, tau, s = args[5:]
        q, qd, q_ref, qd_ref, qdd_ref = (np.array(a, dtype=np.float64) for a in args[:5])
        LD.control_once_entry(
            LD.paper_pointer().address, LD.NULL.address, np.array(self._p), self._mkind, np.array(self._mparams),
            self._g, q, qd, q_ref, qd_ref, qdd_ref, self._state, dt, tau, s, self._scratch,
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
        """Validated evaluation: returns ``(tau, s)``, each shape (n,).

        ``t`` (s) is accepted for the contract's sake; the sliding-mode laws do not use it.

        ``dt`` (s) is required for a stateful law (it advances the super-twisting integral).
        The singularity guard keeps the torque finite for every finite state whose dynamics
        float64 can represent; a state so large that the model's own terms overflow (the
        velocity-squared terms, around ``|q̇| > 1e150`` rad/s) raises ``ValueError`` rather
        than returning inf or NaN. (The simulator reports the same as a divergence.)

        Raises
        ------
        ValueError
            On a wrong shape, a non-finite input, a missing ``dt`` for a stateful law, a
            state whose torque overflows float64, or (the paper's law) a nominal model whose
            mass matrix is not positive definite at the state.
        """
        n = self._n
        # checked after the inputs (a call with both wrong names the input), as it always was
        dt_bad = self._reaching == "super-twisting" and (
            dt is None or not (math.isfinite(dt) and dt > 0)
        )
        step = 0.0 if dt is None else float(dt)
        tau, s = np.empty(n), np.empty(n)
        if (
            not dt_bad
            and self._law != "paper"
            and type(q) is type(qd) is type(q_ref) is type(qd_ref) is type(qdd_ref) is np.ndarray
            and q.dtype is qd.dtype is q_ref.dtype is qd_ref.dtype is qdd_ref.dtype is _F64
            and q.ndim == qd.ndim == q_ref.ndim == qd_ref.ndim == qdd_ref.ndim == 1
        ):
            # the fast path, for one-dimensional float64 arrays of any layout (native byte
            # order; O(1) checks here, exactly the types _checked_entry's function takes):
            # the shape and finiteness of the inputs and outputs are the compiled call's
            checked = self._checked
            if checked is None:
                checked = self._checked = _checked_entry(self)
            code = checked(
                self._p, self._mkind, self._mparams, self._g, q, qd, q_ref, qd_ref, qdd_ref,
                self._state, step, tau, s, self._scratch,
            )  # fmt: skip
            if code == _OK:
                return tau, s
            if 0 <= code < len(_INPUT_NAMES):
                raise ValueError(f"{_INPUT_NAMES[code]} must be finite (no NaN or inf)")
            if code >= len(_INPUT_NAMES):
                self._overflow(code - len(_INPUT_NAMES), qd)
        arrays = checked_inputs(n, q=q, qd=qd, q_ref=q_ref, qd_ref=qd_ref, qdd_ref=qdd_ref)
        if dt_bad:
            raise ValueError("dt > 0 (the sample time) is required by the super-twisting law")
        state = self._state.copy()  # restored if the call is rejected below
        if self._law == "paper":
            self._paper_call(*arrays, step, tau, s)
        else:
            LD.control_once(
                self._p,
                self._mkind,
                self._mparams,
                self._g,
                *arrays,
                self._state,
                step,
                tau,
                s,
                self._scratch,
            )
        bad = np.flatnonzero(~(np.isfinite(tau) & np.isfinite(s)))
        if bad.size:
            self._state[:] = state
            if self._law == "paper" and not _positive_definite(
                self._model.mass_matrix(arrays[0])
            ):
                # the paper's law's NaN torques (CK.paper_entry) at a finite state: its M^-1
                # does not exist there (an overflow also gives NaN: the message below)
                raise ValueError(
                    "the paper's law needs the inverse of the nominal model's mass matrix, "
                    "which is not positive definite at this state (a massless body at the tip?)"
                )
            self._overflow(int(bad[0]), arrays[1])
        return tau, s

    def __getstate__(self) -> dict[str, Any]:
        """The controller's attributes for pickling and copying, without the compiled function
        of :meth:`evaluate` (which does not pickle; it is looked up again on first use)."""
        state = self.__dict__.copy()
        state["_checked"] = None
        return state

    @staticmethod
    def _overflow(joint: int, qd: ArrayLike) -> NoReturn:
        """Refuse a state whose torque (of ``joint``, 0-based) is not finite."""
        raise ValueError(
            f"the torque of joint {joint + 1} overflows float64 at this state "
            f"(|qd| up to {np.max(np.abs(np.asarray(qd, dtype=np.float64))):.3g} rad/s): "
            "the state is out of range"
        )

    def sliding_variable(
        self, q: ArrayLike, qd: ArrayLike, q_ref: ArrayLike, qd_ref: ArrayLike
    ) -> FloatArray:
        """:math:`s(e, \\dot e)` for states (n,) or (B, n) (numpy, for inspection)."""
        e = np.asarray(q, dtype=float) - np.asarray(q_ref, dtype=float)
        ed = np.asarray(qd, dtype=float) - np.asarray(qd_ref, dtype=float)
        return self._surface.value(e, ed)


def _positive_definite(m: FloatArray) -> bool:
    """Whether the symmetric matrix ``m`` is positive definite (a Cholesky factor exists)."""
    try:
        np.linalg.cholesky(m)
    except np.linalg.LinAlgError:
        return False
    return True


#: The largest sampled terminal gain :math:`\beta\gamma\varepsilon_e^{\gamma-1}T_s` the
#: automatic guard allows (:func:`guard_for_period`).
SAMPLED_GAIN_LIMIT = 0.5

#: The automatic guard is never below this (rad): a finer control period would otherwise ask
#: for a guard far below anything float64 errors or the metrics resolve.
MIN_AUTO_EPS_E = DEFAULT_EPS_E

#: ... nor above this (rad): beyond it the terminal term is linear over any angle an arm has.
MAX_AUTO_EPS_E = 10.0


def guard_for_period(beta: ArrayLike, gamma: float, dt: float) -> float:
    r"""The automatic singularity guard :math:`\varepsilon_e` (rad) for control period ``dt``.

    The terminal term's gain :math:`\beta\gamma|e|^{\gamma-1}` grows without bound as
    :math:`e \to 0`; sampled every :math:`T_s` it makes the torque alternate at the sample rate
    (even under tanh) once :math:`\beta\gamma|e|^{\gamma-1}T_s` approaches 1. Evaluating
    :math:`|e|^{\gamma-1}` at :math:`\max(|e|, \varepsilon_e)` with

    .. math::

        \varepsilon_e = (2\beta_{max}\gamma T_s)^{1/(1-\gamma)}

    caps the sampled gain at :data:`SAMPLED_GAIN_LIMIT` = 0.5 (:math:`\beta_{max}`: the largest
    per-joint :math:`\beta`); this is the rule of the shipped study (``eps_e = 5e-8`` rad for
    :math:`\beta = 2, \gamma = 3/5, T_s = 0.5` ms; see ``docs/theory.md``). The value is kept
    within [:data:`MIN_AUTO_EPS_E`, :data:`MAX_AUTO_EPS_E`], where the cap still holds or the
    term is linear anyway. A non-terminal exponent :math:`\gamma \ge 1` has no singularity:
    the guard is :data:`MIN_AUTO_EPS_E`.

    Raises
    ------
    ValueError
        If ``dt`` is not a finite period > 0.
    """
    step = float(dt)
    if not (math.isfinite(step) and step > 0):
        raise ValueError(f"dt must be a finite control period > 0 s, got {dt!r}")
    if gamma >= 1.0:
        return MIN_AUTO_EPS_E
    b = float(np.max(np.asarray(beta, dtype=np.float64)))
    log_eps = math.log(2.0 * b * gamma * step) / (1.0 - gamma)
    eps = math.exp(min(log_eps, math.log(MAX_AUTO_EPS_E)))
    return min(max(eps, MIN_AUTO_EPS_E), MAX_AUTO_EPS_E)


def _guard(eps_e: float | None) -> float:
    """The guard the surface is built with: the user's, or (automatic, ``None``) the floor
    :data:`DEFAULT_EPS_E` until :meth:`SlidingModeController.for_period` resolves it."""
    return DEFAULT_EPS_E if eps_e is None else eps_e


def _numeric(v: object) -> bool:
    return isinstance(v, float | int | list) and not isinstance(v, bool)


def _tolist(x: FloatArray) -> float | list[float]:
    return float(x) if x.ndim == 0 else [float(v) for v in x]


class PDSMC(SlidingModeController):
    """PD sliding-mode control: :math:`s = \\dot e + \\lambda e`, :math:`\\nu = \\lambda\\dot e`.

    ``lam`` :math:`\\lambda > 0` (1/s), a scalar or one per joint. Internally the linear surface
    is the fast-terminal one with :math:`\\alpha = \\lambda, \\beta = 0`; :meth:`to_dict` and
    ``repr`` name ``lam`` and nothing of that packing.
    """

    name = "pdsmc"
    DESCRIPTION = "PD sliding mode: s = ė + λe"
    SURFACE_GAINS = ("linear",)
    LINEAR_NAME = "lam"

    def __init__(
        self,
        model: ArmModel,
        *,
        lam: ArrayLike,
        k: ArrayLike,
        switching: Switching = "sign",
        width: ArrayLike | None = None,
        law: Law = "model",
        reaching: Reaching = "classic",
        k2: ArrayLike | None = None,
    ) -> None:
        self._kwargs = {"lam": lam}
        surface = LinearSurface(lam)
        lam_a = surface.alpha
        self._lam = lam_a
        if isinstance(model, ArmModel) and lam_a.ndim == 1 and lam_a.shape[0] != model.n:
            # named here: the linear surface stores lam in the alpha row
            raise ValueError(
                f"lam has {lam_a.shape[0]} values but the model has {model.n} joints "
                "(give a scalar or one value per joint)"
            )
        super().__init__(
            model,
            surface,
            k=k,
            switching=switching,
            width=width,
            law=law,
            reaching=reaching,
            k2=k2,
        )

    def _surface_params(self) -> dict[str, Any]:
        return {"lam": _tolist(self._lam)}


def _terminal_params(
    surface: Surface, allow_nonterminal: bool, *, alpha: bool, auto: bool
) -> dict[str, Any]:
    """``to_dict`` entries of TSMC (``alpha=False``) and FTSMC: their own parameter names
    (``eps_e`` is None while the guard is automatic and unresolved)."""
    ft = cast(FastTerminalSurface, surface)
    d: dict[str, Any] = {"alpha": _tolist(ft.alpha)} if alpha else {}
    d |= {"beta": _tolist(ft.beta), "gamma": ft.gamma, "eps_e": None if auto else ft.eps_e}
    if allow_nonterminal:
        d["allow_nonterminal"] = True
    return d


class TSMC(SlidingModeController):
    """Terminal SMC: :math:`s = \\dot e + \\beta\\,\\mathrm{sig}(e)^\\gamma`, :math:`0 < \\gamma < 1`.

    Give ``gamma`` or odd integers ``p > q`` (:math:`\\gamma = q/p`). ``eps_e`` (rad) guards
    the singular term: :math:`|e|^{\\gamma-1}` is evaluated at :math:`\\max(|e|, \\varepsilon_e)`.
    Left at ``None`` (the default) it is chosen from the control period :math:`T_s` when the
    simulation starts, :math:`\\varepsilon_e = (2\\beta\\gamma T_s)^{1/(1-\\gamma)}`
    (:func:`guard_for_period`, :meth:`for_period`; ``docs/theory.md``, the guard rule), so that
    the sampled terminal gain :math:`\\beta\\gamma\\varepsilon_e^{\\gamma-1}T_s` stays at 0.5;
    a value you give is kept. Called from Python before a simulation has resolved it, the
    controller uses :data:`~slidingarm.control.surfaces.DEFAULT_EPS_E` = 1e-9 rad.
    """

    name = "tsmc"
    DESCRIPTION = "terminal SMC: s = ė + β sig(e)^γ, 0 < γ < 1"
    SURFACE_GAINS = ("beta", "exponent")
    TERMINAL = True

    def __init__(
        self,
        model: ArmModel,
        *,
        beta: ArrayLike,
        gamma: float | None = None,
        p: int | None = None,
        q: int | None = None,
        k: ArrayLike,
        switching: Switching = "sign",
        width: ArrayLike | None = None,
        law: Law = "model",
        reaching: Reaching = "classic",
        k2: ArrayLike | None = None,
        eps_e: float | None = None,
        allow_nonterminal: bool = False,
    ) -> None:
        self._kwargs = {
            "beta": beta, "gamma": gamma, "p": p, "q": q, "eps_e": eps_e,
            "allow_nonterminal": allow_nonterminal,
        }  # fmt: skip
        self._eps_auto = eps_e is None
        surface = TerminalSurface(
            beta, gamma, p=p, q=q, eps_e=_guard(eps_e), allow_nonterminal=allow_nonterminal
        )
        self._allow_nonterminal = bool(allow_nonterminal)
        super().__init__(
            model, surface, k=k, switching=switching, width=width, law=law, reaching=reaching, k2=k2
        )

    def _surface_params(self) -> dict[str, Any]:
        return _terminal_params(
            self._surface, self._allow_nonterminal, alpha=False, auto=self._eps_auto
        )


class FTSMC(SlidingModeController):
    """Fast terminal SMC: :math:`s = \\dot e + \\alpha e + \\beta\\,\\mathrm{sig}(e)^\\gamma`.

    Give ``gamma`` in (0, 1) or odd integers ``p > q`` (:math:`\\gamma = q/p`);
    ``allow_nonterminal=True`` admits the paper's :math:`\\gamma > 1` only to measure it.
    ``eps_e`` (rad) guards the singular term as in :class:`TSMC`: ``None`` (the default) means
    :math:`\\varepsilon_e = (2\\beta\\gamma T_s)^{1/(1-\\gamma)}` for the control period
    :math:`T_s` of the run (:func:`guard_for_period`); a value you give is kept.
    """

    name = "ftsmc"
    DESCRIPTION = "fast terminal SMC: s = ė + αe + β sig(e)^γ"
    SURFACE_GAINS = ("linear", "beta", "exponent")
    LINEAR_NAME = "alpha"
    TERMINAL = True

    def __init__(
        self,
        model: ArmModel,
        *,
        alpha: ArrayLike,
        beta: ArrayLike,
        gamma: float | None = None,
        p: int | None = None,
        q: int | None = None,
        k: ArrayLike,
        switching: Switching = "sign",
        width: ArrayLike | None = None,
        law: Law = "model",
        reaching: Reaching = "classic",
        k2: ArrayLike | None = None,
        eps_e: float | None = None,
        allow_nonterminal: bool = False,
    ) -> None:
        self._kwargs = {
            "alpha": alpha, "beta": beta, "gamma": gamma, "p": p, "q": q, "eps_e": eps_e,
            "allow_nonterminal": allow_nonterminal,
        }  # fmt: skip
        self._eps_auto = eps_e is None
        surface = FastTerminal(
            alpha, beta, gamma, p=p, q=q, eps_e=_guard(eps_e), allow_nonterminal=allow_nonterminal
        )
        self._allow_nonterminal = bool(allow_nonterminal)
        super().__init__(
            model, surface, k=k, switching=switching, width=width, law=law, reaching=reaching, k2=k2
        )

    def _surface_params(self) -> dict[str, Any]:
        return _terminal_params(
            self._surface, self._allow_nonterminal, alpha=True, auto=self._eps_auto
        )


class NTSMC(SlidingModeController):
    """Nonsingular terminal SMC (Feng, Yu & Man 2002):
    :math:`s = e + \\beta^{-1}\\mathrm{sig}(\\dot e)^{p/q}`, :math:`1 < p/q < 2`.

    The law is :math:`\\ddot q_d - (\\beta q/p)\\,\\mathrm{sig}(\\dot e)^{2-p/q} - r(s)`, which
    gives :math:`\\dot s = -(p/(q\\beta))|\\dot e|^{p/q-1} r(s)`.
    """

    name = "ntsmc"
    DESCRIPTION = "nonsingular terminal SMC (Feng et al. 2002): s = e + (1/β) sig(ė)^(p/q), 1 < p/q < 2"
    SURFACE_GAINS = ("beta", "exponent")
    EXPONENT_RANGE = (1.0, 2.0)

    def __init__(
        self,
        model: ArmModel,
        *,
        beta: ArrayLike,
        gamma: float | None = None,
        p: int | None = None,
        q: int | None = None,
        k: ArrayLike,
        switching: Switching = "sign",
        width: ArrayLike | None = None,
        law: Law = "model",
        reaching: Reaching = "classic",
        k2: ArrayLike | None = None,
    ) -> None:
        self._kwargs = {"beta": beta, "gamma": gamma, "p": p, "q": q}
        surface = NonsingularTerminal(beta, gamma, p=p, q=q)
        super().__init__(
            model, surface, k=k, switching=switching, width=width, law=law, reaching=reaching, k2=k2
        )

    def _surface_params(self) -> dict[str, Any]:
        d = self._surface.to_dict()
        return {"beta": d["beta"], "gamma": d["gamma"]}


#: The named sliding-mode controllers by :attr:`~SlidingModeController.name`: the one table
#: from which scenario files, listings and the studies look a controller up.
CONTROLLERS: dict[str, type[SlidingModeController]] = {
    cls.name: cls for cls in (PDSMC, TSMC, FTSMC, NTSMC)
}
