"""Typed simulation results that carry their parameters and export to pandas and xarray.

Arrays are time-major: a single run holds ``(T,)`` times and ``(T, n)`` signals; a batch holds
``(B, T, n)`` signals and shares the time axis and reference.
"""

from __future__ import annotations

import json
import os
import zipfile
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from slidingarm._io import atomic_write_bytes

if TYPE_CHECKING:
    import pandas as pd
    import xarray as xr
    from matplotlib.figure import Figure

__all__ = ["MAX_PLOTTED_RUNS", "SIGNALS", "BatchResult", "SimResult", "run_name"]

#: The most runs :meth:`BatchResult.plot` draws without being told which.
MAX_PLOTTED_RUNS = 8

FloatArray = NDArray[np.float64]

#: Per-joint signals of a run, in the order they are exported, with their CSV column prefix
#: and unit.
SIGNALS: dict[str, tuple[str, str]] = {
    "q": ("q", "rad"),
    "qd": ("qd", "rad/s"),
    "q_ref": ("qref", "rad"),
    "qd_ref": ("qdref", "rad/s"),
    "q_meas": ("qm", "rad"),
    "qd_meas": ("qdm", "rad/s"),
    "tau": ("tau", "N m"),
    "s": ("s", "rad/s"),
}


def sliding_unit(params: Mapping[str, Any]) -> str:
    """Unit of a run's sliding variable ``s``, as its controller recorded it
    (:attr:`slidingarm.control.base.Controller.s_unit`, in ``params["s_unit"]``); rad/s for
    params that do not say."""
    unit = params.get("s_unit")
    return unit if isinstance(unit, str) else "rad/s"


def _units(name: str, default: str, params: Sequence[Mapping[str, Any]]) -> str:
    """The unit of signal ``name`` over runs with ``params`` (a mix of s units is written so)."""
    if name != "s" or not params:
        return default
    units = sorted({sliding_unit(p) for p in params})
    return units[0] if len(units) == 1 else " or ".join(units)


def run_name(params: Mapping[str, Any]) -> str:
    """The name a run is drawn and listed under: its controller's name (``"ftsmc"``, which
    picks the controller's fixed style in the figures), else its label, else ``"run"``."""
    ctrl = params.get("controller")
    if isinstance(ctrl, Mapping) and isinstance(ctrl.get("controller"), str):
        return str(ctrl["controller"])
    label = params.get("label")
    return label if isinstance(label, str) and label else "run"


def _label(params: Mapping[str, Any]) -> str:
    label = params.get("label")
    return label if isinstance(label, str) and label else run_name(params)


def _html_table(caption: str, rows: Sequence[tuple[str, str]]) -> str:
    """A small two-column HTML table (escaped), for notebooks."""
    from html import escape

    body = "".join(
        f"<tr><th style='text-align:left'>{escape(k)}</th><td style='text-align:left'>"
        f"{escape(v)}</td></tr>"
        for k, v in rows
    )
    return f"<table><caption style='text-align:left'><b>{escape(caption)}</b></caption>{body}</table>"


def _freeze_signals(obj: SimResult | BatchResult, *, batch: bool) -> None:
    """Check and freeze the signals of a result: ``t`` (T,), every signal (T, n), or (B, T, n)
    for a batch, all of one shape; each becomes a read-only float64 array."""
    t = np.asarray(obj.t, dtype=np.float64)
    if t.ndim != 1:
        raise ValueError(f"t must have shape (T,), got {t.shape}")
    ndim, layout = (3, "(B, T, n)") if batch else (2, "(T, n)")
    shape = None
    for name in SIGNALS:
        arr = np.asarray(getattr(obj, name), dtype=np.float64)
        if arr.ndim != ndim or arr.shape[ndim - 2] != t.shape[0]:
            raise ValueError(
                f"{name} must have shape {layout} with T={t.shape[0]}, got {arr.shape}"
            )
        if shape is not None and arr.shape != shape:
            raise ValueError(f"{name} has shape {arr.shape}, other signals {shape}")
        shape = arr.shape
        arr.setflags(write=False)
        object.__setattr__(obj, name, arr)
    t.setflags(write=False)
    object.__setattr__(obj, "t", t)


@dataclass(frozen=True, eq=False)
class SimResult:
    """One closed-loop run, every sample.

    Attributes
    ----------
    t : ndarray, shape (T,)
        Sample times :math:`t_k = k\\,\\Delta t` (s).
    q, qd : ndarray, shape (T, n)
        Plant state at ``t[k]``.
    q_ref, qd_ref : ndarray, shape (T, n)
        Reference position and velocity at ``t[k]``.
    q_meas, qd_meas : ndarray, shape (T, n)
        What the controller saw: measured position (noise, faults) and the velocity it used.
    tau : ndarray, shape (T, n)
        Torque applied to the plant over ``[t[k], t[k+1])`` (zero-order hold, after limits;
        the last row is the controller's output at the final sample, never applied).
    s : ndarray, shape (T, n)
        Sliding variable computed by the controller at ``t[k]``.
    params : dict
        Everything the run was made with (plant, controller, reference, options), JSON-able.
    seed : int or None
        Seed of the run's random generator (``None`` when the run used no randomness).
    status : str
        ``"ok"``, or how the run failed: ``"nonfinite"``, ``"runaway"``, ``"singular"``
        (:data:`STATUS_NAMES`); the samples from the failure on are NaN.
    message : str
        ``""`` for a run that finished, else what happened, when and at which joint.
    """

    t: FloatArray
    q: FloatArray
    qd: FloatArray
    q_ref: FloatArray
    qd_ref: FloatArray
    q_meas: FloatArray
    qd_meas: FloatArray
    tau: FloatArray
    s: FloatArray
    params: dict[str, Any] = field(default_factory=dict)
    seed: int | None = None
    status: str = "ok"
    message: str = ""

    def __post_init__(self) -> None:
        _freeze_signals(self, batch=False)

    # ------------------------------------------------------------------ display
    def __repr__(self) -> str:
        """One line: controller, joints, samples, period, duration and status (no arrays)."""
        status = self.status if self.success else f"{self.status}: {self.message}"
        seed = "" if self.seed is None else f", seed={self.seed}"
        return (
            f"SimResult({_label(self.params)}, {self.n} joints, {self.t.shape[0]} samples of "
            f"{self.dt:g} s over {float(self.t[-1] - self.t[0]):g} s{seed}, {status})"
        )

    def _repr_html_(self) -> str:
        """A short table for notebooks: what ran and how it ended (no arrays)."""
        final = np.abs(self.e[-1])
        rows = [
            ("controller", _label(self.params)),
            ("joints", str(self.n)),
            ("samples", f"{self.t.shape[0]} of {self.dt:g} s over {float(self.t[-1]):g} s"),
            ("status", self.status + (f" ({self.message})" if self.message else "")),
            ("seed", "none" if self.seed is None else str(self.seed)),
            ("final |e| (rad)", ", ".join(f"{v:.3g}" for v in final)),
        ]
        return _html_table("SimResult", rows)

    def plot(self, **kwargs: Any) -> Figure:
        """The standard figure of this run: joint tracking against the reference
        (:func:`slidingarm.plotting.plot_tracking`, to which ``kwargs`` go); matplotlib is
        imported only here."""
        from slidingarm.plotting import plot_tracking

        return plot_tracking(self, **kwargs)

    @property
    def success(self) -> bool:
        """Whether the run finished without diverging (python-control's ``success``)."""
        return self.status == "ok"

    # ------------------------------------------------------------------ derived signals
    @property
    def n(self) -> int:
        """Number of joints."""
        return int(self.q.shape[1])

    @property
    def dt(self) -> float:
        """Sample time (s)."""
        return float(self.t[1] - self.t[0]) if self.t.shape[0] > 1 else 0.0

    @property
    def e(self) -> FloatArray:
        """Tracking error :math:`e = q - q_d` of the true state, shape (T, n)."""
        return self.q - self.q_ref

    @property
    def edot(self) -> FloatArray:
        """Velocity error :math:`\\dot e = \\dot q - \\dot q_d` of the true state, shape (T, n)."""
        return self.qd - self.qd_ref

    # ------------------------------------------------------------------ export
    def columns(self) -> list[str]:
        """CSV column names: ``t`` then ``q1..qn``, ``qd1..qdn``, ``qref1..``, ``qdref1..``,
        ``qm1..``, ``qdm1..``, ``tau1..``, ``s1..``."""
        cols = ["t"]
        for prefix, _unit in SIGNALS.values():
            cols += [f"{prefix}{j + 1}" for j in range(self.n)]
        return cols

    def to_dataframe(self) -> pd.DataFrame:
        """One row per sample, columns as :meth:`columns`."""
        import pandas as pd

        data = np.column_stack([self.t] + [getattr(self, name) for name in SIGNALS])
        return pd.DataFrame(data, columns=self.columns())

    def to_xarray(self) -> xr.Dataset:
        """An ``xarray.Dataset`` with dims ``(time, joint)``, units in attributes, params as JSON."""
        import xarray as xr

        joints = np.arange(1, self.n + 1)
        data_vars = {
            name: (
                ("time", "joint"),
                getattr(self, name),
                {"units": _units(name, unit, [self.params])},
            )
            for name, (_prefix, unit) in SIGNALS.items()
        }
        return xr.Dataset(
            data_vars,
            coords={"time": ("time", self.t, {"units": "s"}), "joint": joints},
            attrs={
                "params": json.dumps(self.params),
                "seed": -1 if self.seed is None else self.seed,
            },
        )

    def save(self, path: str | os.PathLike[str]) -> Path:
        """Save to a compressed ``.npz`` (arrays plus JSON params), written atomically.

        Parameters
        ----------
        path : str or os.PathLike
            Ends in ``.npz``, or has no suffix (``.npz`` is then added).

        Returns
        -------
        Path
            The file written.

        Raises
        ------
        ValueError
            If ``path`` has another suffix (``res.h5`` would otherwise be written as
            ``res.npz``, a file the caller does not expect).
        """
        import io

        p = Path(path)
        if p.suffix == "":
            p = p.with_suffix(".npz")
        elif p.suffix != ".npz":
            raise ValueError(
                f"path {str(path)!r} must end in '.npz' or have no suffix (a result is saved as "
                f"a .npz archive), got suffix {p.suffix!r}"
            )
        buf = io.BytesIO()
        arrays = {name: getattr(self, name) for name in ("t", *SIGNALS)}
        meta = json.dumps({"params": self.params, "seed": self.seed})
        np.savez_compressed(buf, **arrays, meta=np.array(meta))
        atomic_write_bytes(p, buf.getvalue())
        return p

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> SimResult:
        """Load a result written by :meth:`save`."""
        p = Path(path)
        try:
            loaded = np.load(p, allow_pickle=False)
            if not isinstance(loaded, np.lib.npyio.NpzFile):
                raise ValueError("not an .npz archive")
            with loaded as z:
                arrays = {name: np.array(z[name]) for name in ("t", *SIGNALS)}
                meta = json.loads(str(z["meta"]))
            params, seed = meta["params"], meta["seed"]
            if not isinstance(params, dict) or not (seed is None or isinstance(seed, int)):
                raise ValueError("meta must hold a params dict and an integer seed or null")
            return cls(**arrays, params=params, seed=seed)  # type: ignore[arg-type]
        except (OSError, EOFError, KeyError, TypeError, ValueError, zipfile.BadZipFile) as exc:
            raise ValueError(f"{p}: not a slidingarm result file ({exc})") from exc


#: Status of a run by its code in the compiled loop (0 is success).
STATUS_NAMES: tuple[str, ...] = ("ok", "nonfinite", "runaway", "singular")

_STATUS_TEXT = (
    "",
    "a non-finite value (NaN or inf) appeared",
    "the joint velocity ran away",
    "the mass matrix stopped being positive definite",
)


def run_message(code: int, time: float, joint: int, qd_limit: float) -> str:
    """What happened to a run with status ``code`` (``""`` for success), at ``time`` (s) and
    ``joint`` (1-based)."""
    if code == 0:
        return ""
    text = _STATUS_TEXT[code] + (f" (|qd| > {qd_limit:g} rad/s)" if code == 2 else "")
    return f"{text} at t = {time:.6g} s, joint {joint}"


def metric_values(
    t: FloatArray, e: FloatArray, s: FloatArray, tau: FloatArray, failed: NDArray[np.bool_]
) -> dict[str, FloatArray]:
    """Every metric of :func:`slidingarm.metrics.summary` (its defaults), (B, n) each, of
    runs with signals ``e``, ``s``, ``tau`` (B, T, n); NaN for the ``failed`` runs, whose
    traces are NaN from the failure on and are not measured."""
    from slidingarm.metrics import (
        DEFAULT_CUTOFF_HZ,
        DEFAULT_DELTA_E,
        DEFAULT_DELTA_S,
        DEFAULT_WINDOW,
        _metric_table,
    )

    if failed.any():
        keep = ~failed[:, None, None]
        e, s, tau = (np.where(keep, x, 0.0) for x in (e, s, tau))
    table = _metric_table(
        t, e, s, tau, delta_s=DEFAULT_DELTA_S, delta_e=DEFAULT_DELTA_E, window=DEFAULT_WINDOW,
        cutoff_hz=DEFAULT_CUTOFF_HZ,
    )  # fmt: skip
    out = {}
    for name, v in table.items():
        arr = np.array(v, dtype=np.float64)
        arr[failed] = np.nan
        out[name] = arr
    return out


def _none_or_frozen(x: Any) -> FloatArray | None:
    if x is None:
        return None
    arr = np.asarray(x)
    arr.setflags(write=False)
    return arr


@dataclass(frozen=True, eq=False)
class BatchResult:
    """``B`` runs on a shared time grid, with each run's status and, unless only metrics were
    recorded, its signals of shape ``(B, T, n)``.

    ``batch[b]`` is the :class:`SimResult` of run ``b`` (not in ``record="metrics"`` mode);
    ``seeds[b]`` its seed; ``ok[b]``, ``status[b]``, ``message[b]`` how it ended.

    Attributes
    ----------
    t : ndarray, shape (T,)
        Times of the recorded samples (every ``k``-th with ``record=Every(k)``).
    q, qd, q_ref, qd_ref, q_meas, qd_meas, tau, s : ndarray (B, T, n) or None
        The signals (see :class:`SimResult`); ``None`` with ``record="metrics"``.
    status_code : ndarray (B,) int
        0 for a run that finished, else the index of its status in :data:`STATUS_NAMES`.
    fail_time : ndarray (B,)
        When a failed run failed (s); ``inf`` for runs that finished.
    fail_joint : ndarray (B,) int
        The failing joint (1-based); 0 for runs that finished.
    messages : list of str
        Per run: ``""``, or what happened.
    metric_values : dict or None
        Per metric of :data:`slidingarm.metrics.METRIC_COLUMNS`, a (B, n) array computed from
        the full traces during the run (``record`` other than ``"full"``); NaN for failed runs.
    t_full : ndarray (T_full,) or None
        Every sample time of the runs (``t`` when all were recorded).
    record : str
        ``"full"``, ``"metrics"`` or ``"every k"``.
    """

    t: FloatArray
    q: FloatArray | None = None
    qd: FloatArray | None = None
    q_ref: FloatArray | None = None
    qd_ref: FloatArray | None = None
    q_meas: FloatArray | None = None
    qd_meas: FloatArray | None = None
    tau: FloatArray | None = None
    s: FloatArray | None = None
    params: list[dict[str, Any]] = field(default_factory=list)
    seeds: list[int | None] = field(default_factory=list)
    status_code: NDArray[np.int64] | None = None
    fail_time: FloatArray | None = None
    fail_joint: NDArray[np.int64] | None = None
    messages: list[str] | None = None
    metric_values: dict[str, FloatArray] | None = None
    t_full: FloatArray | None = None
    record: str = "full"

    def __post_init__(self) -> None:
        if self.q is not None or self.metric_values is None:
            _freeze_signals(self, batch=True)
        else:
            t = np.asarray(self.t, dtype=np.float64)
            t.setflags(write=False)
            object.__setattr__(self, "t", t)
        nb = self._size()
        codes = np.zeros(nb, dtype=np.int64) if self.status_code is None else self.status_code
        codes = np.asarray(codes, dtype=np.int64)
        if codes.shape != (nb,) or np.any((codes < 0) | (codes >= len(STATUS_NAMES))):
            raise ValueError(f"status_code must hold {nb} codes in 0..{len(STATUS_NAMES) - 1}")
        object.__setattr__(self, "status_code", _none_or_frozen(codes))
        ft = np.full(nb, np.inf) if self.fail_time is None else self.fail_time
        fj = np.zeros(nb, dtype=np.int64) if self.fail_joint is None else self.fail_joint
        object.__setattr__(self, "fail_time", _none_or_frozen(np.asarray(ft, dtype=np.float64)))
        object.__setattr__(self, "fail_joint", _none_or_frozen(np.asarray(fj, dtype=np.int64)))
        if self.messages is None:
            object.__setattr__(self, "messages", [""] * nb)
        if self.metric_values is not None:
            frozen = {k: _none_or_frozen(np.asarray(v, dtype=np.float64)) for k, v in self.metric_values.items()}
            object.__setattr__(self, "metric_values", frozen)
        if self.t_full is None:
            object.__setattr__(self, "t_full", self.t)

    def _size(self) -> int:
        if self.q is not None:
            return int(np.shape(self.q)[0])
        if self.metric_values:
            return int(next(iter(self.metric_values.values())).shape[0])
        return len(self.params)

    def __len__(self) -> int:
        return self._size()

    def __repr__(self) -> str:
        nb = len(self)
        failed = int(np.count_nonzero(~self.ok))
        return (
            f"BatchResult({nb} runs, record={self.record!r}, {nb - failed} ok, {failed} failed, "
            f"{self.t.shape[0]} samples)"
        )

    def _repr_html_(self) -> str:
        """A short table for notebooks: runs, what was recorded, how many failed and why."""
        nb = len(self)
        failed = np.flatnonzero(~self.ok)
        labels = sorted({_label(p) for p in self.params}) if self.params else []
        rows = [
            ("runs", str(nb)),
            ("controllers", ", ".join(labels) or "-"),
            ("record", self.record),
            ("samples", f"{self.t.shape[0]} recorded"),
            ("ok", f"{nb - failed.size} of {nb}"),
        ]
        if failed.size:
            b = int(failed[0])
            rows.append(("first failure", f"run {b}: {self.message[b]}"))
        return _html_table("BatchResult", rows)

    def plot(self, runs: Sequence[int] | None = None, **kwargs: Any) -> Figure:
        """Joint tracking of the chosen ``runs`` (default: every run, at most
        :data:`MAX_PLOTTED_RUNS`), keyed ``"run b"``
        (:func:`slidingarm.plotting.plot_tracking`, to which ``kwargs`` go).

        Raises
        ------
        ValueError
            With ``record="metrics"`` (no traces), for a run index out of range, or for more
            than :data:`MAX_PLOTTED_RUNS` runs when ``runs`` is not given.
        """
        from slidingarm.plotting import plot_tracking

        self._traces()
        nb = len(self)
        if runs is None:
            if nb > MAX_PLOTTED_RUNS:
                raise ValueError(
                    f"this batch has {nb} runs; choose at most {MAX_PLOTTED_RUNS} to draw with "
                    "runs=[...]"
                )
            runs = range(nb)
        chosen = [int(b) for b in runs]
        bad = [b for b in chosen if not 0 <= b < nb]
        if bad or not chosen:
            raise ValueError(f"runs must be run indices in 0..{nb - 1}, got {list(runs)}")
        return plot_tracking({f"run {b}": self[b] for b in chosen}, **kwargs)

    # ------------------------------------------------------------------ status
    @property
    def ok(self) -> NDArray[np.bool_]:
        """Per run: whether it finished without diverging, shape (B,)."""
        assert self.status_code is not None
        return np.asarray(self.status_code == 0)

    @property
    def status(self) -> list[str]:
        """Per run: ``"ok"`` or how it failed (:data:`STATUS_NAMES`)."""
        assert self.status_code is not None
        return [STATUS_NAMES[int(c)] for c in self.status_code]

    @property
    def message(self) -> list[str]:
        """Per run: ``""`` or what happened, when and at which joint."""
        return list(self.messages or [])

    # ------------------------------------------------------------------ signals
    def _traces(self) -> None:
        if self.q is None:
            raise ValueError(
                "this batch was run with record='metrics' and holds no signals; run it with "
                "record='full' or record=Every(k) to keep them"
            )

    @property
    def e(self) -> FloatArray:
        """Tracking errors, shape (B, T, n)."""
        self._traces()
        assert self.q is not None and self.q_ref is not None
        return self.q - self.q_ref

    def __getitem__(self, b: int) -> SimResult:
        self._traces()
        assert self.status_code is not None and self.messages is not None
        return SimResult(
            t=self.t,
            **{name: getattr(self, name)[b] for name in SIGNALS},
            params=self.params[b] if self.params else {},
            seed=self.seeds[b] if self.seeds else None,
            status=STATUS_NAMES[int(self.status_code[b])],
            message=self.messages[b],
        )

    # ------------------------------------------------------------------ metrics
    def metrics(self) -> pd.DataFrame:
        """Per run and joint, the metrics of :func:`slidingarm.metrics.summary` (defaults):
        columns ``run``, ``joint`` (``"1"`` … ``"n"``, ``"mean"``), then
        :data:`slidingarm.metrics.METRIC_COLUMNS`; the rows of failed runs are NaN.

        With ``record="full"`` computed from the kept signals; otherwise the values computed
        from the full traces while the batch ran.
        """
        from slidingarm.metrics import metric_frame

        if self.metric_values is None:
            self._traces()
            assert self.q is not None and self.q_ref is not None
            assert self.s is not None and self.tau is not None
            values = metric_values(self.t, self.q - self.q_ref, self.s, self.tau, ~self.ok)
        else:
            values = self.metric_values
        return metric_frame(values)

    # ------------------------------------------------------------------ export
    def runs(self) -> pd.DataFrame:
        """One row per run: ``run``, ``seed``, ``ok``, ``status``, ``message``, ``fail_time``
        (s; inf for a run that finished), ``fail_joint`` (0 for none)."""
        import pandas as pd

        return pd.DataFrame(
            {
                "run": np.arange(len(self)),
                "seed": [(-1 if s is None else s) for s in self.seeds] or [-1] * len(self),
                "ok": self.ok,
                "status": self.status,
                "message": self.message,
                "fail_time": self.fail_time,
                "fail_joint": self.fail_joint,
            }
        )

    def to_dataframe(self) -> pd.DataFrame:
        """Long format. With signals: one row per run, recorded sample and joint (columns
        ``run``, ``t``, ``joint``, then one column per signal: ``q``, ``qd``, ``q_ref``,
        ``qd_ref``, ``q_meas``, ``qd_meas``, ``tau``, ``s``). With ``record="metrics"``: one
        row per run and joint of :meth:`metrics`. Both carry each run's ``seed``, ``ok`` and
        ``status``."""
        import pandas as pd

        runs = self.runs()[["run", "seed", "ok", "status"]]
        if self.q is None:
            return self.metrics().merge(runs, on="run", how="left")
        nb, nt, n = self.q.shape
        data: dict[str, Any] = {
            "run": np.repeat(np.arange(nb), nt * n),
            "t": np.tile(np.repeat(self.t, n), nb),
            "joint": np.tile(np.arange(1, n + 1), nb * nt),
        }
        for name in SIGNALS:
            data[name] = np.asarray(getattr(self, name)).reshape(-1)
        return pd.DataFrame(data).merge(runs, on="run", how="left")

    def to_xarray(self) -> xr.Dataset:
        """An ``xarray.Dataset`` with dims ``(run, time, joint)``."""
        import xarray as xr

        self._traces()
        assert self.q is not None
        joints = np.arange(1, self.q.shape[2] + 1)
        data_vars = {
            name: (
                ("run", "time", "joint"),
                getattr(self, name),
                {"units": _units(name, unit, self.params)},
            )
            for name, (_prefix, unit) in SIGNALS.items()
        }
        return xr.Dataset(
            data_vars,
            coords={
                "run": np.arange(len(self)),
                "time": ("time", self.t, {"units": "s"}),
                "joint": joints,
                "seed": ("run", [(-1 if s is None else s) for s in self.seeds] or [-1] * len(self)),
                "status": ("run", self.status),
            },
        )
