"""Typed results: export to pandas and xarray, save/load, immutability and batches (issue 3,
point 5)."""

from __future__ import annotations

import dataclasses
import json
import os
import stat
import zipfile
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from slidingarm import (
    FTSMC,
    NTSMC,
    PAPER_Q0,
    BatchResult,
    ConstantTorque,
    GaussianNoise,
    PaperReference,
    PlanarArm,
    Sensor,
    SimResult,
    simulate,
    simulate_batch,
)
from slidingarm.results import SIGNALS

ARM = PlanarArm.paper()
REF = PaperReference()
N = ARM.n
DT = 5e-4
NAMES = ("q", "qd", "q_ref", "qd_ref", "q_meas", "qd_meas", "tau", "s")
UNITS = {
    "q": "rad",
    "qd": "rad/s",
    "q_ref": "rad",
    "qd_ref": "rad/s",
    "q_meas": "rad",
    "qd_meas": "rad/s",
    "tau": "N m",
    "s": "rad/s",
}


def ctrl() -> FTSMC:
    return FTSMC(ARM, alpha=2.0, beta=2.0, p=5, q=3, k=20.0, switching="tanh", width=0.05)


@pytest.fixture(scope="module")
def result() -> SimResult:
    # per-joint parameters, so that params hold per-joint values that must survive JSON
    sensor = Sensor(noise=GaussianNoise((1e-3, 2e-3, 5e-4)))
    dist = [ConstantTorque((0.5, 0.0, -0.5))]
    return simulate(ARM, ctrl(), REF, q0=PAPER_Q0, t_final=0.2, dt=DT, sensor=sensor, seed=17,
                    disturbances=dist)  # fmt: skip


def hand_made(n: int = 2, T: int = 5, seed: int | None = 3) -> SimResult:
    t = np.arange(T) * 0.1
    base = np.arange(T * n, dtype=float).reshape(T, n)
    signals = {name: base + 100.0 * i for i, name in enumerate(NAMES)}
    return SimResult(t=t, **signals, params={"case": "hand-made", "n": n}, seed=seed)


# ---------------------------------------------------------------------------- pandas
def test_to_dataframe_columns_and_values(result: SimResult) -> None:
    df = result.to_dataframe()
    prefixes = ["q", "qd", "qref", "qdref", "qm", "qdm", "tau", "s"]
    expected = ["t"] + [f"{p}{j}" for p in prefixes for j in (1, 2, 3)]
    assert list(df.columns) == expected == result.columns()
    assert len(df) == result.t.shape[0] == 401
    np.testing.assert_array_equal(df["t"].to_numpy(), result.t)
    for name, prefix in zip(NAMES, prefixes, strict=True):
        for j in range(N):
            np.testing.assert_array_equal(
                df[f"{prefix}{j + 1}"].to_numpy(), getattr(result, name)[:, j], err_msg=name
            )


def test_to_dataframe_follows_the_joint_count() -> None:
    r = hand_made(n=2)
    df = r.to_dataframe()
    assert list(df.columns) == [
        "t", "q1", "q2", "qd1", "qd2", "qref1", "qref2", "qdref1", "qdref2",
        "qm1", "qm2", "qdm1", "qdm2", "tau1", "tau2", "s1", "s2",
    ]  # fmt: skip
    assert df.loc[2, "tau2"] == r.tau[2, 1] == 600.0 + 5.0


# ---------------------------------------------------------------------------- xarray
def test_to_xarray(result: SimResult) -> None:
    ds = result.to_xarray()
    assert set(ds.data_vars) == set(NAMES)
    for name in NAMES:
        assert ds[name].dims == ("time", "joint")
        assert ds[name].attrs["units"] == UNITS[name] == SIGNALS[name][1]
        np.testing.assert_array_equal(ds[name].to_numpy(), getattr(result, name))
    np.testing.assert_array_equal(ds["time"].to_numpy(), result.t)
    assert ds["time"].attrs["units"] == "s"
    np.testing.assert_array_equal(ds["joint"].to_numpy(), [1, 2, 3])
    assert json.loads(ds.attrs["params"]) == result.params
    assert ds.attrs["seed"] == 17
    # a selection reads like the paper: joint 1 at t = 0.1 s
    assert float(ds["q"].sel(joint=1, time=0.1)) == result.q[200, 0]
    assert hand_made(seed=None).to_xarray().attrs["seed"] == -1


# ---------------------------------------------------------------------------- save / load
def test_save_load_round_trip_is_exact(result: SimResult, tmp_path: Path) -> None:
    path = result.save(tmp_path / "run.npz")
    assert path == tmp_path / "run.npz" and path.is_file()
    back = SimResult.load(path)
    for name in ("t", *NAMES):
        a, b = getattr(back, name), getattr(result, name)
        assert a.dtype == b.dtype and a.shape == b.shape
        np.testing.assert_array_equal(a, b, err_msg=name)
        assert not getattr(back, name).flags.writeable
    assert back.params == result.params
    assert back.seed == result.seed == 17
    # no temporary file is left behind
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.npz"]


def test_saved_file_has_the_ordinary_mode(result: SimResult, tmp_path: Path) -> None:
    """The atomic write goes through mkstemp (0600); the file must end as 0666 & ~umask, the
    umask as the process had it (read once, at import), exactly as open() would make it."""
    path = result.save(tmp_path / "run.npz")
    plain = tmp_path / "plain"
    plain.write_bytes(b"")
    assert stat.S_IMODE(path.stat().st_mode) == stat.S_IMODE(plain.stat().st_mode)
    assert stat.S_IMODE(path.stat().st_mode) == 0o666 & ~os_umask()


def os_umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def test_save_adds_the_suffix_and_keeps_a_null_seed(tmp_path: Path) -> None:
    r = hand_made(seed=None)
    path = r.save(tmp_path / "sub" / "result")
    assert path == tmp_path / "sub" / "result.npz" and path.is_file()
    back = SimResult.load(path)
    assert back.seed is None and back.params == r.params
    np.testing.assert_array_equal(back.tau, r.tau)
    # saving again replaces the file
    hand_made(seed=5).save(path)
    assert SimResult.load(path).seed == 5


@pytest.mark.parametrize("name", ["res.h5", "res.csv", "run.2024-05-01", "res.npz.bak"])
def test_save_refuses_another_suffix(name: str, tmp_path: Path) -> None:
    path = tmp_path / name
    suffix = Path(name).suffix
    with pytest.raises(ValueError) as info:
        hand_made().save(path)
    assert str(info.value) == (
        f"path {str(path)!r} must end in '.npz' or have no suffix (a result is saved as a .npz "
        f"archive), got suffix {suffix!r}"
    )
    assert list(tmp_path.iterdir()) == []  # nothing written, not even res.npz


def _bad_files(tmp: Path, good: SimResult) -> dict[str, Path]:
    files: dict[str, Path] = {}
    data = good.save(tmp / "good.npz").read_bytes()
    files["truncated"] = tmp / "truncated.npz"
    files["truncated"].write_bytes(data[: len(data) // 2])
    files["text"] = tmp / "text.npz"
    files["text"].write_text("t,q1\n0,1\n")
    files["other archive"] = tmp / "other.npz"
    np.savez(files["other archive"], a=np.zeros(3))
    files["plain npy"] = tmp / "plain.npy"
    np.save(files["plain npy"], np.zeros(3))
    arrays: dict[str, Any] = {name: getattr(good, name) for name in ("t", *NAMES)}
    files["meta without params"] = tmp / "noparams.npz"
    np.savez(files["meta without params"], **arrays, meta=np.array(json.dumps({"seed": 1})))
    files["meta not JSON"] = tmp / "badjson.npz"
    np.savez(files["meta not JSON"], **arrays, meta=np.array("{params"))
    short = dict(arrays, q=arrays["q"][:-1])
    files["inconsistent shapes"] = tmp / "shapes.npz"
    meta = json.dumps({"params": {}, "seed": None})
    np.savez(files["inconsistent shapes"], **short, meta=np.array(meta))
    files["missing"] = tmp / "missing.npz"
    files["not a zip member"] = tmp / "zipped.npz"
    with zipfile.ZipFile(files["not a zip member"], "w") as z:
        z.writestr("t.npy", b"garbage")
    return files


def test_load_of_a_bad_file_names_it(tmp_path: Path) -> None:
    files = _bad_files(tmp_path, hand_made())
    for what, path in files.items():
        with pytest.raises(ValueError, match=r"not a slidingarm result file") as info:
            SimResult.load(path)
        assert str(path) in str(info.value), what


# ---------------------------------------------------------------------------- immutability
def test_arrays_are_read_only(result: SimResult) -> None:
    for name in ("t", *NAMES):
        arr = getattr(result, name)
        assert not arr.flags.writeable, name
        with pytest.raises(ValueError, match="read-only"):
            arr[0] = 0.0
    with pytest.raises(dataclasses.FrozenInstanceError):
        result.q = np.zeros((3, N))  # type: ignore[misc]


def test_derived_signals(result: SimResult) -> None:
    np.testing.assert_array_equal(result.e, result.q - result.q_ref)
    np.testing.assert_array_equal(result.edot, result.qd - result.qd_ref)
    assert result.n == N and result.dt == pytest.approx(DT)


def test_sim_result_validates_shapes() -> None:
    t = np.arange(4) * 0.1
    good = {name: np.zeros((4, 2)) for name in NAMES}
    with pytest.raises(ValueError, match=r"^t must have shape \(T,\), got \(4, 1\)$"):
        SimResult(t=t[:, None], **good)
    with pytest.raises(ValueError, match=r"^tau must have shape \(T, n\) with T=4, got \(3, 2\)$"):
        SimResult(t=t, **dict(good, tau=np.zeros((3, 2))))
    with pytest.raises(ValueError, match=r"^s has shape \(4, 3\), other signals \(4, 2\)$"):
        SimResult(t=t, **dict(good, s=np.zeros((4, 3))))


# ---------------------------------------------------------------------------- batch
@pytest.fixture(scope="module")
def batch() -> BatchResult:
    sensor = Sensor(noise=GaussianNoise(1e-3))
    return simulate_batch(ARM, ctrl(), REF, q0=PAPER_Q0, t_final=0.05, dt=DT, sensor=sensor,
                          seeds=[3, 4, 5])  # fmt: skip


def test_batch_indexing(batch: BatchResult) -> None:
    assert len(batch) == 3
    assert batch.q.shape == (3, 101, N) and batch.e.shape == (3, 101, N)
    for b in (0, 1, 2, -1):
        one = batch[b]
        assert isinstance(one, SimResult)
        for name in NAMES:
            np.testing.assert_array_equal(getattr(one, name), getattr(batch, name)[b])
        np.testing.assert_array_equal(one.t, batch.t)
        assert one.seed == batch.seeds[b] and one.params == batch.params[b]
    assert [batch[b].seed for b in range(3)] == [3, 4, 5]
    with pytest.raises(IndexError):
        batch[3]


def test_batch_arrays_are_read_only(batch: BatchResult) -> None:
    for name in ("t", *NAMES):
        arr = getattr(batch, name)
        assert not arr.flags.writeable, name
        with pytest.raises(ValueError, match="read-only"):
            arr[0] = 0.0


def test_batch_to_xarray(batch: BatchResult) -> None:
    ds = batch.to_xarray()
    for name in NAMES:
        assert ds[name].dims == ("run", "time", "joint")
        assert ds[name].attrs["units"] == UNITS[name]
        np.testing.assert_array_equal(ds[name].to_numpy(), getattr(batch, name))
    np.testing.assert_array_equal(ds["run"].to_numpy(), [0, 1, 2])
    np.testing.assert_array_equal(ds["seed"].to_numpy(), [3, 4, 5])
    assert ds["seed"].dims == ("run",)
    assert ds["time"].attrs["units"] == "s"
    np.testing.assert_array_equal(ds["joint"].to_numpy(), [1, 2, 3])
    np.testing.assert_array_equal(ds["q"].sel(run=1).to_numpy(), batch[1].q)


def test_batch_result_validates_shapes() -> None:
    t = np.arange(4) * 0.1
    good = {name: np.zeros((2, 4, 3)) for name in NAMES}
    with pytest.raises(ValueError, match=r"^q must have shape \(B, T, n\) with T=4, got \(4, 3\)$"):
        BatchResult(t=t, **dict(good, q=np.zeros((4, 3))))
    with pytest.raises(ValueError, match=r"^s has shape \(3, 4, 3\), other signals \(2, 4, 3\)$"):
        BatchResult(t=t, **dict(good, s=np.zeros((3, 4, 3))))


def test_xarray_gives_the_sliding_variable_its_own_unit() -> None:
    """s = ė + ... is in rad/s; NTSMC's s = e + sig(ė)^(p/q)/β is in rad."""
    nt = NTSMC(ARM, beta=2.0, gamma=1.5, k=20.0, switching="tanh", width=0.05)
    ft = FTSMC(ARM, alpha=2, beta=2, p=5, q=3, k=20, switching="tanh", width=0.05)
    runs = {
        name: simulate(ARM, c, REF, q0=PAPER_Q0, t_final=0.01, dt=DT)
        for name, c in (("ntsmc", nt), ("ftsmc", ft))
    }
    assert runs["ntsmc"].to_xarray()["s"].attrs["units"] == "rad"
    assert runs["ftsmc"].to_xarray()["s"].attrs["units"] == "rad/s"
    assert runs["ntsmc"].to_xarray()["q"].attrs["units"] == "rad"
    mixed = simulate_batch(ARM, [nt, ft], REF, q0=PAPER_Q0, t_final=0.01, dt=DT)
    assert mixed.to_xarray()["s"].attrs["units"] == "rad or rad/s"
    assert mixed.to_xarray()["qd"].attrs["units"] == "rad/s"
