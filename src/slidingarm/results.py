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

__all__ = ["SIGNALS", "BatchResult", "SimResult"]

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
    """Unit of a run's sliding variable ``s`` from its params: rad for the nonsingular terminal
    surface (NTSMC, :math:`s = e + \\beta^{-1}\\mathrm{sig}(\\dot e)^{p/q}`), rad/s for the
    others (:math:`s = \\dot e + \\dots`) and for params that do not name the controller."""
    ctrl = params.get("controller")
    if isinstance(ctrl, Mapping) and (
        ctrl.get("controller") == "ntsmc" or ctrl.get("surface") == "nonsingular_terminal"
    ):
        return "rad"
    return "rad/s"


def _units(name: str, default: str, params: Sequence[Mapping[str, Any]]) -> str:
    """The unit of signal ``name`` over runs with ``params`` (a mix of s units is written so)."""
    if name != "s" or not params:
        return default
    units = sorted({sliding_unit(p) for p in params})
    return units[0] if len(units) == 1 else " or ".join(units)


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

    def __post_init__(self) -> None:
        _freeze_signals(self, batch=False)

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
            return cls(**arrays, params=params, seed=seed)
        except (OSError, EOFError, KeyError, TypeError, ValueError, zipfile.BadZipFile) as exc:
            raise ValueError(f"{p}: not a slidingarm result file ({exc})") from exc


@dataclass(frozen=True, eq=False)
class BatchResult:
    """``B`` runs on a shared time grid; signals have shape ``(B, T, n)``.

    ``batch[b]`` is the :class:`SimResult` of run ``b``; ``seeds[b]`` its seed.
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
    params: list[dict[str, Any]] = field(default_factory=list)
    seeds: list[int | None] = field(default_factory=list)

    def __post_init__(self) -> None:
        _freeze_signals(self, batch=True)

    def __len__(self) -> int:
        return int(self.q.shape[0])

    @property
    def e(self) -> FloatArray:
        """Tracking errors, shape (B, T, n)."""
        return self.q - self.q_ref

    def __getitem__(self, b: int) -> SimResult:
        return SimResult(
            t=self.t,
            **{name: getattr(self, name)[b] for name in SIGNALS},
            params=self.params[b] if self.params else {},
            seed=self.seeds[b] if self.seeds else None,
        )

    def to_xarray(self) -> xr.Dataset:
        """An ``xarray.Dataset`` with dims ``(run, time, joint)``."""
        import xarray as xr

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
            },
        )
