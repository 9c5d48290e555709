"""The study's numbers beyond the per-run metrics: convergence against theory, the sign/tanh
chattering contrast, the paper's errata measured, a gain grid and the must-hold checks.

Every function here is a plain function of results and scenarios that returns a
:class:`pandas.DataFrame`; :mod:`slidingarm.study.reproduce` calls them and writes the tables.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import numpy as np
import pandas as pd

from slidingarm import metrics
from slidingarm.config import ControllerSpec, Scenario, Setup
from slidingarm.control.controllers import (
    CONTROLLERS,
    FTSMC,
    PDSMC,
    TSMC,
    SlidingModeController,
)
from slidingarm.control.surfaces import (
    DEFAULT_EPS_E,
    ftsm_convergence_time,
    tsm_convergence_time,
)
from slidingarm.metrics import DEFAULT_LATE_FRACTION, LATE_COLUMNS, summary
from slidingarm.metrics import mse as metric_mse
from slidingarm.models.serial import SerialArm
from slidingarm.results import SimResult
from slidingarm.study.paper import PAPER_MSE, PAPER_MSE_SWITCHING, RANKING
from slidingarm.study.runs import OnDiverge, simulate_setup

__all__ = [
    "ALTERNATING",
    "CONVERGENCE_BAND",
    "CONVERGENCE_COLUMNS",
    "GRID_BETA",
    "GRID_K",
    "GRID_LINEAR",
    "LATE_COLUMNS",
    "LATE_FRACTION",
    "NOISE_BOUND",
    "PAPER_MSE",
    "PAPER_MSE_SWITCHING",
    "RANKING",
    "SS_BOUND",
    "OnDiverge",
    "chattering_table",
    "checks_table",
    "convergence_table",
    "errata_table",
    "follows_ranking",
    "gain_grid",
    "late_metrics",
    "metrics_table",
    "ranking_mse",
    "simulate_setup",
    "tool_paths",
]

#: "After the transient": the last ``LATE_FRACTION`` of each run, the samples with
#: :math:`t_k \ge t_{T-1} - f\,(t_{T-1} - t_0)` (:func:`slidingarm.metrics.late_start`). The
#: reaching phase and the convergence on the surface (the convergence table) end well before
#: the second half of the paper's 4.5 s run.
LATE_FRACTION: float = DEFAULT_LATE_FRACTION

#: A torque whose share of reversing steps (``alternation_late``) is at least this alternates at
#: the sample rate: the share is 1 for a torque that flips every sample, about 0 for a smooth one
#: and 2/3 for white noise.
ALTERNATING: float = 0.5

#: Error band |e| < delta (rad) at which the convergence time is measured, by switching. Sign
#: switching leaves a ripple of a few 1e-5 rad (s chatters in a band k·Ts wide), so its error
#: never gets much below that; a boundary layer lets it go to 1e-8 rad.
CONVERGENCE_BAND: dict[str, float] = {"sign": 1e-4, "tanh": 1e-6, "sat": 1e-6}

#: Largest |relative error| of the measured against the predicted convergence time accepted by
#: the checks, by switching (the sign ripple of s perturbs the surface dynamics by a few %).
CONVERGENCE_RTOL: dict[str, float] = {"sign": 0.05, "tanh": 0.01, "sat": 0.01}

#: FTSMC's worst-joint steady-state error (max |e| over the last 0.5 s) must not exceed these
#: (rad), by scenario.
SS_BOUND: dict[str, float] = {"sign": 1e-4, "tanh": 1e-5}

#: The noisy scenario counts as bounded when every joint's steady-state error is below this (rad).
NOISE_BOUND: float = 1e-2

#: tanh must chatter at least this many times less than sign (total variation per second).
CHATTERING_RATIO: float = 10.0

#: The gain grid: reaching gain k, linear gain alpha = lambda and terminal gain beta.
GRID_K: tuple[float, ...] = (5.0, 10.0, 20.0, 40.0)
GRID_LINEAR: tuple[float, ...] = (1.0, 2.0, 5.0)
GRID_BETA: tuple[float, ...] = (1.0, 2.0, 5.0)




def tool_paths(
    setup: Setup, results: Mapping[str, SimResult]
) -> tuple[np.ndarray, dict[str, np.ndarray]] | None:
    r"""The desired and each run's actual tool-tip path of a serial arm, in its root frame.

    The desired path is the reference through the nominal arm's kinematics,
    :math:`p_d(t) = \mathrm{fk}_{nominal}(q_d(t))` (where the controllers are asked to take the
    tool); each actual path is the run's joint angles through the simulated plant's,
    :math:`p(t) = \mathrm{fk}_{plant}(q(t))` (where the tool went, a length error included;
    a payload does not move the tool frame).

    Returns
    -------
    (ndarray, dict of str to ndarray) or None
        ``(desired, {label: actual})``, each of shape (T, 3) in metres; ``None`` for a planar
        arm, whose figures show joints only.
    """
    nominal, plant = setup.nominal, setup.plant
    if not isinstance(nominal, SerialArm) or not isinstance(plant, SerialArm) or not results:
        return None
    first = next(iter(results.values()))
    desired = np.asarray(nominal.tool_position(first.q_ref), dtype=np.float64)
    actual = {
        label: np.asarray(plant.tool_position(r.q), dtype=np.float64)
        for label, r in results.items()
    }
    return desired, actual


# --------------------------------------------------------------------------------------------
# metrics


def metrics_table(results: Mapping[str, Mapping[str, SimResult]]) -> pd.DataFrame:
    """:func:`slidingarm.metrics.summary` of every run, stacked: one row per scenario ×
    controller × joint (``"1"`` … ``"n"`` and ``"mean"``), columns ``scenario``,
    ``controller``, ``joint``, :data:`slidingarm.metrics.METRIC_COLUMNS` and then the
    post-transient :data:`LATE_COLUMNS` of :func:`late_metrics` (whose ``mean`` row is, as
    for the others, the mean over joints)."""
    frames = []
    for scenario, runs in results.items():
        for label, result in runs.items():
            table = summary(result)
            late = late_metrics(result)
            for name in LATE_COLUMNS:
                values = late[name]
                table[name] = np.append(values, np.mean(values))
            table.insert(0, "controller", label)
            table.insert(0, "scenario", scenario)
            frames.append(table)
    return pd.concat(frames, ignore_index=True)


def _terminal_gain_params(result: SimResult) -> tuple[np.ndarray, float, float] | None:
    r"""``(beta, gamma, eps_e)`` of a run whose surface has a terminal term
    :math:`\beta\,\mathrm{sig}(e)^\gamma` with :math:`\beta > 0`, else None."""
    params = result.params.get("controller", {})
    if not isinstance(params, Mapping) or "beta" not in params or "gamma" not in params:
        return None
    # a terminal term on e (TSMC, FTSMC; NTSMC's is on ė); a bare controller names its surface
    klass = CONTROLLERS.get(str(params.get("controller")))
    if klass is not None and not klass.TERMINAL:
        return None
    if params.get("surface", "fast_terminal") != "fast_terminal":
        return None
    beta = _per_joint(params["beta"], result.n)
    if not np.any(beta > 0):
        return None
    eps_e = float(params.get("eps_e", DEFAULT_EPS_E))
    return beta, float(params["gamma"]), eps_e


def late_metrics(result: SimResult, *, fraction: float = LATE_FRACTION) -> dict[str, np.ndarray]:
    r"""Torque chattering and sliding variable of a run after the transient, per joint:
    :func:`slidingarm.metrics.late_metrics` of its torque, sliding variable and the error the
    controller sees :math:`\tilde e = \tilde q - q_d`, with the terminal term of its controller
    (``beta``, ``gamma``, ``eps_e`` of ``result.params``; none for PDSMC and NTSMC).

    Returns
    -------
    dict of str to ndarray, shape (n,)
        One array per name of :data:`LATE_COLUMNS` (:data:`slidingarm.metrics.LATE_COLUMNS`;
        NaN for a run of fewer than 3 samples).
    """
    return metrics.late_metrics(
        result.t,
        result.tau,
        result.s,
        np.asarray(result.q_meas) - np.asarray(result.q_ref),
        dt=result.dt,
        terminal=_terminal_gain_params(result),
        fraction=fraction,
    )


def _mean_row(
    metrics: pd.DataFrame, scenario: str, controller: str, joint: str = "mean"
) -> pd.Series:
    rows = metrics[
        (metrics["scenario"] == scenario)
        & (metrics["controller"] == controller)
        & (metrics["joint"] == joint)
    ]
    if rows.empty:
        raise KeyError(
            f"no metrics for scenario {scenario!r}, controller {controller!r}, joint {joint!r}"
        )
    return rows.iloc[0]


# --------------------------------------------------------------------------------------------
# convergence against docs/theory.md §3


def _per_joint(value: Any, n: int) -> np.ndarray:
    return np.broadcast_to(np.asarray(value, dtype=float), (n,)).astype(float)


def convergence(result: SimResult, controller: SlidingModeController) -> pd.DataFrame:
    r"""Finite-time convergence on the surface, measured against docs/theory.md §3, joint by joint.

    For a TSMC or FTSMC run:

    - ``t_reach``: the first sample where :math:`s_i` reaches zero — it changes sign or
      :math:`|s_i| \le k_i T_s` (one sample's worth of the reaching law);
    - ``e_at_reach``: :math:`e_r = e_i(t_{reach})`;
    - ``t_s_formula``: the time the surface dynamics take from :math:`e_r` to the band
      :math:`\delta` (:data:`CONVERGENCE_BAND`): :math:`t_s(|e_r|) - t_s(\delta)`, with
      :math:`t_s` the TSM or FTSM formula of docs/theory.md §3 (the flow is autonomous, so this is exact;
      :math:`t_s(\delta)` is 5 ms for :math:`\delta = 10^{-6}`);
    - ``t_s_measured``: from ``t_reach`` to the first sample where :math:`|e_i| < \delta` or
      :math:`e_i` has crossed zero;
    - ``rel_error``: :math:`(t_{measured} - t_{formula}) / t_{formula}`;
    - ``band``: the band :math:`\delta` (rad) used.

    Times that never happen are ``inf``.
    """
    if not isinstance(controller, TSMC | FTSMC):
        raise ValueError(f"convergence applies to TSMC and FTSMC, got {type(controller).__name__}")
    t, e, s = result.t, result.e, result.s
    n = result.n
    params = controller.to_dict()
    alpha = _per_joint(params.get("alpha", 0.0), n)
    beta = _per_joint(params["beta"], n)
    gamma = float(params["gamma"])
    k = _per_joint(controller.k, n)
    dt = result.dt
    band = CONVERGENCE_BAND[controller.switching]
    rows = []
    for j in range(n):
        sj, ej = s[:, j], e[:, j]

        def t_s(x: float, j: int = j) -> float:
            if alpha[j] > 0:
                return float(ftsm_convergence_time(x, alpha[j], beta[j], gamma))
            return float(tsm_convergence_time(x, beta[j], gamma))

        hit = np.flatnonzero((np.abs(sj) <= k[j] * dt) | (sj * sj[0] <= 0))
        row: dict[str, Any] = {"joint": str(j + 1), "band": band}
        if hit.size == 0:
            row.update(
                t_reach=math.inf,
                e_at_reach=math.nan,
                t_s_formula=math.nan,
                t_s_measured=math.inf,
                rel_error=math.inf,
            )
            rows.append(row)
            continue
        i = int(hit[0])
        er = float(ej[i])
        predicted = max(t_s(abs(er)) - t_s(band), 0.0)
        after = np.flatnonzero((np.abs(ej[i:]) < band) | (ej[i:] * er <= 0))
        measured = float(t[i + after[0]] - t[i]) if after.size else math.inf
        rel = (measured - predicted) / predicted if predicted > 0 else math.nan
        row.update(
            t_reach=float(t[i]),
            e_at_reach=er,
            t_s_formula=predicted,
            t_s_measured=measured,
            rel_error=rel,
        )
        rows.append(row)
    return pd.DataFrame(rows)


#: Columns of :func:`convergence_table` (and of ``convergence.csv``), in order.
CONVERGENCE_COLUMNS: tuple[str, ...] = (
    "scenario",
    "controller",
    "joint",
    "t_reach",
    "e_at_reach",
    "t_s_formula",
    "t_s_measured",
    "rel_error",
    "band",
)


def convergence_table(
    results: Mapping[str, Mapping[str, SimResult]],
    setups: Mapping[str, Setup],
    scenarios: Iterable[str],
) -> pd.DataFrame:
    r""":func:`convergence` of every TSMC and FTSMC run of ``scenarios``, stacked with columns
    ``scenario, controller, joint, t_reach, e_at_reach, t_s_formula, t_s_measured, rel_error,
    band`` (``band``: the error band :math:`\delta` of :data:`CONVERGENCE_BAND`, rad)."""
    frames = []
    for scenario in scenarios:
        for label, controller in setups[scenario].controllers.items():
            if isinstance(controller, TSMC | FTSMC):
                table = convergence(results[scenario][label], controller)
                table.insert(0, "controller", label)
                table.insert(0, "scenario", scenario)
                frames.append(table)
    columns = list(CONVERGENCE_COLUMNS)
    if not frames:
        return pd.DataFrame(columns=columns)
    return pd.concat(frames, ignore_index=True)[columns]


# --------------------------------------------------------------------------------------------
# chattering


def chattering_table(
    metrics: pd.DataFrame, *, sign: str = "sign", tanh: str = "tanh"
) -> pd.DataFrame:
    r"""The torque's chattering with sign and with tanh switching, per controller.

    Columns, for each controller of scenario ``sign``:

    - ``sign``, ``tanh``, ``ratio``: the total variation per second over the whole run (mean
      over joints) under each switching, and ``sign / tanh``;
    - after the transient (the :data:`LATE_COLUMNS` of :func:`late_metrics`, over the last
      :data:`LATE_FRACTION` of the run), for each switching ``<sw>`` in ``sign``, ``tanh``:
      ``<sw>_late`` (total variation per second, mean over joints), ``<sw>_step_late`` (the
      largest single torque step of any joint, N·m), ``<sw>_alternation_late`` (share of
      reversing steps, mean over joints) and ``<sw>_gain_late`` (median terminal gain per sample
      :math:`\beta\gamma|e|^{\gamma-1}T_s`, mean over joints; NaN without a terminal term).

    A post-transient value the metrics lack (a table without :data:`LATE_COLUMNS`) is NaN.
    """
    late = {"late": "chattering_late", "step_late": "max_step_late"}
    late |= {"alternation_late": "alternation_late", "gain_late": "terminal_gain_late"}
    columns = ["controller", "sign", "tanh", "ratio"]
    columns += [f"{sw}_{key}" for key in late for sw in ("sign", "tanh")]
    rows = []
    labels = metrics.loc[metrics["scenario"] == sign, "controller"].drop_duplicates()
    for label in labels:
        a = float(_mean_row(metrics, sign, label)["chattering"])
        b = float(_mean_row(metrics, tanh, label)["chattering"])
        row: dict[str, Any] = {
            "controller": label,
            "sign": a,
            "tanh": b,
            "ratio": a / b if b > 0 else math.inf,
        }
        for sw, scenario in (("sign", sign), ("tanh", tanh)):
            for key, column in late.items():
                if column not in metrics.columns:
                    row[f"{sw}_{key}"] = math.nan
                elif key == "step_late":
                    joints = metrics[
                        (metrics["scenario"] == scenario)
                        & (metrics["controller"] == label)
                        & (metrics["joint"] != "mean")
                    ]
                    row[f"{sw}_{key}"] = float(joints[column].max())
                else:
                    row[f"{sw}_{key}"] = float(_mean_row(metrics, scenario, label)[column])
        rows.append(row)
    return pd.DataFrame(rows, columns=columns)


# --------------------------------------------------------------------------------------------
# errata


#: The paper's errata measured on FTSMC in the sign scenario: (variant, description, overrides).
ERRATA: tuple[tuple[str, str, dict[str, Any]], ...] = (
    (
        "correct",
        "FTSMC as docs/theory.md §3 writes it: the model-based law τ = M̂(q̈_d − ν − Kφ(s)) + ĥ and the "
        "terminal exponent γ = q/p = 3/5 (the reference row).",
        {},
    ),
    (
        "paper law",
        'The paper\'s law (eqs. 19-22, law = "paper"): a row of M⁻¹ taken as a scalar g_i and '
        "q̈_d omitted.",
        {"law": "paper"},
    ),
    (
        "paper exponent",
        "The paper's exponent p/q = 5/3 > 1 (allow_nonterminal): the surface is no longer "
        "terminal, so the error decays only asymptotically near zero.",
        {"gamma": 5.0 / 3.0, "allow_nonterminal": True},
    ),
    (
        "paper law and exponent",
        "Both as the paper writes them.",
        {"law": "paper", "gamma": 5.0 / 3.0, "allow_nonterminal": True},
    ),
)


def errata_table(scenario: Scenario, *, controller: str = "ftsmc") -> pd.DataFrame:
    """Run the :data:`ERRATA` variants of ``scenario``'s controller named ``controller`` and
    tabulate ``variant, description, mse_mean, mse_joint1, steady_state_error, chattering,
    scenario, controller`` (steady-state error: worst joint; chattering: mean over joints;
    ``scenario`` and ``controller``: the scenario's key and the controller's name, the same in
    every row). A variant that diverges has NaN numbers and says so in its description."""
    base = next((c for c in scenario.controllers if c.name == controller), None)
    if base is None:
        raise ValueError(f"scenario {scenario.key!r} has no {controller} controller")
    specs = []
    for label, _description, overrides in ERRATA:
        fields = base.model_dump(exclude_none=True)
        fields.update(overrides)
        if "gamma" in overrides:
            fields.pop("p", None)
            fields.pop("q", None)
        fields["label"] = label.replace(" ", "-")
        specs.append(ControllerSpec(**fields))
    variant = scenario.model_copy(update={"controllers": specs})
    runs = simulate_setup(variant.build(), on_diverge="record")
    rows = []
    for (label, description, _), run in zip(ERRATA, runs.values(), strict=True):
        if isinstance(run, str):
            rows.append(
                {
                    "variant": label,
                    "description": f"{description} Diverged: {run}",
                    "mse_mean": math.nan,
                    "mse_joint1": math.nan,
                    "steady_state_error": math.nan,
                    "chattering": math.nan,
                }
            )
            continue
        table = summary(run).set_index("joint")
        rows.append(
            {
                "variant": label,
                "description": description,
                "mse_mean": _cell(table, "mean", "mse"),
                "mse_joint1": _cell(table, "1", "mse"),
                "steady_state_error": float(
                    table["steady_state_error"].drop("mean").to_numpy().max()
                ),
                "chattering": _cell(table, "mean", "chattering"),
            }
        )
    frame = pd.DataFrame(rows)
    frame["scenario"] = scenario.key
    frame["controller"] = controller
    return frame


def _cell(table: pd.DataFrame, row: str, column: str) -> float:
    """One value of a summary table as a float."""
    return float(table.loc[[row], column].to_numpy(dtype=float)[0])


# --------------------------------------------------------------------------------------------
# gain grid


def gain_grid(
    scenario: Scenario,
    *,
    k: Sequence[float] = GRID_K,
    linear: Sequence[float] = GRID_LINEAR,
    beta: Sequence[float] = GRID_BETA,
) -> pd.DataFrame:
    """MSE (mean over joints) of PDSMC, TSMC and FTSMC over a grid of shared gains, and whether
    the paper's ranking FTSMC < TSMC < PDSMC holds at each point.

    The scenario's first ``pdsmc``, ``tsmc`` and ``ftsmc`` controllers supply everything else
    (exponent, switching, width, law). PDSMC depends only on ``(k, alpha)`` and TSMC only on
    ``(k, beta)``, so each is run once per distinct pair; every run goes through one
    :func:`simulate_setup`. The MSE is :func:`slidingarm.metrics.mse` averaged over the joints,
    as in the ``mean`` rows of :func:`metrics_table`. A diverged run has MSE NaN and the ranking
    does not hold there.

    Returns
    -------
    DataFrame
        ``switching, k, lam_alpha, beta, gamma, mse_pdsmc, mse_tsmc, mse_ftsmc,
        ranking_holds``, one row per ``(k, alpha, beta)``.
    """
    index = {}
    for i, spec in enumerate(scenario.controllers):
        if spec.name in ("pdsmc", "tsmc", "ftsmc") and spec.name not in index:
            index[spec.name] = i
    missing = [n for n in ("pdsmc", "tsmc", "ftsmc") if n not in index]
    if missing:
        raise ValueError(f"scenario {scenario.key!r} lacks {', '.join(missing)} for the gain grid")
    setup = scenario.build()
    base = {name: scenario.controller_gains(i) for name, i in index.items()}
    model = setup.nominal

    # every run of the grid, keyed by controller and the gains it depends on
    runs: dict[tuple[str, tuple[float, ...]], SlidingModeController] = {}
    for kk in k:
        for a in linear:
            runs["pdsmc", (kk, a)] = PDSMC(model, **{**base["pdsmc"], "k": kk, "lam": a})
        for b in beta:
            runs["tsmc", (kk, b)] = TSMC(model, **{**base["tsmc"], "k": kk, "beta": b})
        for a in linear:
            for b in beta:
                runs["ftsmc", (kk, a, b)] = FTSMC(
                    model, **{**base["ftsmc"], "k": kk, "alpha": a, "beta": b}
                )
    labels = {key: f"{key[0]} {key[1]!r}" for key in runs}
    results = simulate_setup(
        setup, {labels[key]: c for key, c in runs.items()}, on_diverge="record"
    )
    # the mean over joints of slidingarm.metrics.mse, as in the mean rows of metrics_table
    mse: dict[tuple[str, tuple[float, ...]], float] = {}
    for key, label in labels.items():
        r = results[label]
        mse[key] = math.nan if isinstance(r, str) else float(np.mean(metric_mse(r.e)))
    first = runs["ftsmc", (k[0], linear[0], beta[0])]
    gamma = float(first.to_dict()["gamma"])
    switching = first.switching
    rows = []
    for kk, a, b in ((kk, a, b) for kk in k for a in linear for b in beta):
        p, t_, f = mse["pdsmc", (kk, a)], mse["tsmc", (kk, b)], mse["ftsmc", (kk, a, b)]
        rows.append(
            {
                "switching": switching,
                "k": kk,
                "lam_alpha": a,
                "beta": b,
                "gamma": gamma,
                "mse_pdsmc": p,
                "mse_tsmc": t_,
                "mse_ftsmc": f,
                "ranking_holds": follows_ranking({"pdsmc": p, "tsmc": t_, "ftsmc": f}),
            }
        )
    return pd.DataFrame(rows)


# --------------------------------------------------------------------------------------------
# the paper's ranking


def ranking_mse(metrics: pd.DataFrame, scenario: str, joint: str = "mean") -> dict[str, float]:
    """The MSE (rad²) on ``joint`` (``"1"`` … ``"n"`` or ``"mean"``) of each controller of
    :data:`RANKING` that ``scenario`` ran, in the order of :data:`RANKING` (best first).

    ``metrics`` is a table of :func:`metrics_table` (columns ``scenario``, ``controller``,
    ``joint``, ``mse``); a controller without a row there is left out.
    """
    rows = metrics[
        (metrics["scenario"].astype(str) == str(scenario))
        & (metrics["joint"].astype(str) == str(joint))
    ]
    found: dict[str, float] = {}
    for controller, value in zip(rows["controller"].astype(str), rows["mse"], strict=True):
        found.setdefault(controller, float(value))
    return {c: found[c] for c in RANKING if c in found}


def follows_ranking(mse: Mapping[str, float]) -> bool:
    """Whether the MSEs of ``mse`` (by controller name) rise strictly in the order of
    :data:`RANKING`, the paper's claim; controllers not in ``mse`` are not compared and a NaN
    breaks the order."""
    ordered = [mse[c] for c in RANKING if c in mse]
    return all(a < b for a, b in itertools.pairwise(ordered))


# --------------------------------------------------------------------------------------------
# checks


def _check(name: str, value: Any, threshold: Any, passed: bool) -> dict[str, Any]:
    return {"name": name, "value": value, "threshold": threshold, "passed": bool(passed)}


def checks_table(
    metrics: pd.DataFrame,
    results: Mapping[str, Mapping[str, SimResult]],
    *,
    chattering: pd.DataFrame,
    convergence: pd.DataFrame,
    setups: Mapping[str, Setup],
    noisy: Iterable[str] = ("noise",),
) -> pd.DataFrame:
    """The claims the study must reproduce (docs/theory.md §7), each as ``name, value, threshold,
    passed``:

    - every scenario ranks MSE FTSMC < TSMC < PDSMC, mean over joints and on joint 1;
    - FTSMC's worst-joint steady-state error is at most :data:`SS_BOUND` (sign, tanh);
    - tanh chatters at least :data:`CHATTERING_RATIO` times less than sign, per controller;
    - the measured convergence times match docs/theory.md §3 within :data:`CONVERGENCE_RTOL`;
    - the noisy scenario stays bounded (:data:`NOISE_BOUND`);
    - no signal of any run holds NaN or inf.
    """
    rows = []
    order = " < ".join(RANKING)
    for scenario in results:
        for joint, what in (("mean", "mean over joints"), ("1", "joint 1")):
            values = ranking_mse(metrics, scenario, joint)
            missing = [c for c in RANKING if c not in values]
            if missing:
                raise KeyError(
                    f"no metrics for scenario {scenario!r}, controller {missing[0]!r}, "
                    f"joint {joint!r}"
                )
            rows.append(
                _check(
                    f"{scenario}: MSE {order} ({what})",
                    " < ".join(f"{values[c]:.4g}" for c in RANKING),
                    order,
                    follows_ranking(values),
                )
            )
    for scenario, bound in SS_BOUND.items():
        if scenario in results:
            rows_ = metrics[
                (metrics["scenario"] == scenario)
                & (metrics["controller"] == "ftsmc")
                & (metrics["joint"] != "mean")
            ]
            worst = float(rows_["steady_state_error"].max())
            rows.append(
                _check(
                    f"{scenario}: ftsmc steady-state error (worst joint, rad)",
                    worst,
                    bound,
                    worst <= bound,
                )
            )
    for _, row in chattering.iterrows():
        rows.append(
            _check(
                f"chattering sign/tanh ratio: {row['controller']}",
                float(row["ratio"]),
                CHATTERING_RATIO,
                float(row["ratio"]) >= CHATTERING_RATIO,
            )
        )
    for key, group in convergence.groupby(["scenario", "controller"], sort=False):
        scenario, label = str(key[0]), str(key[1])
        switching = setups[str(scenario)].controllers[str(label)].switching
        tol = CONVERGENCE_RTOL[switching]
        worst = float(np.max(np.abs(group["rel_error"].to_numpy(dtype=float))))
        rows.append(
            _check(
                f"{scenario}: {label} convergence time vs docs/theory.md §3 (worst |rel. error|)",
                worst,
                tol,
                bool(worst <= tol),
            )
        )
    for scenario in noisy:
        if scenario in results:
            rows_ = metrics[(metrics["scenario"] == scenario) & (metrics["joint"] != "mean")]
            worst = float(rows_["steady_state_error"].max())
            rows.append(
                _check(
                    f"{scenario}: bounded (worst steady-state error, rad)",
                    worst,
                    NOISE_BOUND,
                    bool(np.isfinite(worst) and worst <= NOISE_BOUND),
                )
            )
    bad = 0
    for runs in results.values():
        for r in runs.values():
            for name in ("q", "qd", "q_meas", "qd_meas", "tau", "s"):
                bad += int(np.count_nonzero(~np.isfinite(getattr(r, name))))
    rows.append(_check("no NaN or inf in any signal of any run", bad, 0, bad == 0))
    return pd.DataFrame(rows, columns=["name", "value", "threshold", "passed"])
