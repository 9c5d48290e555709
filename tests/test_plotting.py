"""Tests for slidingarm.plotting: every figure on synthetic runs (fast), any joint count,
external axes, the scenario set and deterministic, atomic saving."""

from __future__ import annotations

import dataclasses
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from slidingarm.plotting import (
    FIGURES,
    REFERENCE_STYLE,
    TOOL_FIGURES,
    controller_style,
    plot_error,
    plot_sliding,
    plot_steady_state,
    plot_tool_path,
    plot_torque,
    plot_tracking,
    plot_velocity,
    save_figure,
    scenario_figures,
)
from slidingarm.plotting._style import band_limits, envelope, smooth
from slidingarm.results import SimResult

CONTROLLERS = ("pdsmc", "tsmc", "ftsmc")
LABELS = {"PDSMC", "TSMC", "FTSMC"}


def _run(n: int, rate: float, *, chatter: bool, steps: int = 400, dt: float = 5e-3) -> SimResult:
    """A synthetic run: error decaying at ``rate`` from 0.3..0.9 rad, a sinusoidal reference,
    torque with (``chatter``) or without sample-rate switching."""
    t = np.arange(steps) * dt
    j = np.arange(1, n + 1)
    q_ref = 0.3 + 0.5 * np.sin(t[:, None] + j)
    qd_ref = 0.5 * np.cos(t[:, None] + j)
    e0 = 0.3 * j / n + 0.6
    e = e0 * np.exp(-rate * t)[:, None]
    q = q_ref + e
    qd = qd_ref - rate * e
    s = qd - qd_ref + 2.0 * e
    sw = np.where(np.arange(steps) % 2 == 0, 1.0, -1.0)[:, None] if chatter else 0.0
    tau = 10.0 * np.cos(t[:, None] * j) + 30.0 * sw * np.ones((1, n))
    return SimResult(
        t=t, q=q, qd=qd, q_ref=q_ref, qd_ref=qd_ref, q_meas=q + 1e-4, qd_meas=qd,
        tau=tau, s=s, params={}, seed=None,
    )  # fmt: skip


def _results(n: int = 3, *, chatter: bool = True, dt: float = 5e-3) -> dict[str, SimResult]:
    return {
        name: _run(n, rate, chatter=chatter and name == "pdsmc", steps=round(2.0 / dt), dt=dt)
        for name, rate in zip(CONTROLLERS, (2.0, 4.0, 6.0), strict=True)
    }


PLOTS = {
    "tracking": (plot_tracking, "(rad)", True),
    "velocity": (plot_velocity, "(rad/s)", True),
    "torque": (plot_torque, "(N·m)", False),
    "sliding": (plot_sliding, "(rad/s)", False),
    "error": (plot_error, "(rad)", False),
    "steady_state": (plot_steady_state, "(rad)", False),
}


def _labelled(ax: Axes) -> list[str]:
    return [
        str(line.get_label()) for line in ax.get_lines() if not line.get_label().startswith("_")
    ]


@pytest.mark.parametrize("kind", list(PLOTS))
@pytest.mark.parametrize("n", [1, 3, 5])
def test_plot_functions_draw_one_panel_per_joint_with_units(kind: str, n: int) -> None:
    func, unit, has_ref = PLOTS[kind]
    fig = func(_results(n))
    assert isinstance(fig, Figure)
    axes = fig.axes
    assert len(axes) == n
    assert "(s)" in axes[-1].get_xlabel()
    for ax in axes:
        assert unit in ax.get_ylabel()
        labels = _labelled(ax)
        # one line per controller, plus the reference where there is one
        assert sorted(labels) == sorted([*LABELS, *(["reference"] if has_ref else [])])
    assert fig.legends, "a figure of our own carries one legend"
    assert fig.get_suptitle()


@pytest.mark.parametrize("kind", list(PLOTS))
def test_plot_functions_draw_into_given_axes(kind: str) -> None:
    func, unit, _ = PLOTS[kind]
    host = Figure()
    ax = host.add_subplot()
    assert func(_results(3), ax=ax, joints=[2]) is host
    assert unit in ax.get_ylabel() and "₂" in ax.get_ylabel()
    assert ax.get_legend() is not None
    host = Figure()
    axes = list(host.subplots(3, 1))
    assert func(_results(3), ax=axes) is host
    assert all(_labelled(a) for a in axes)


def _as(res: SimResult, controller: str) -> SimResult:
    """``res`` recorded as a run of ``controller``: its name and the unit of ``s`` that the
    controller records (NTSMC's s = e + ... is an angle)."""
    unit = "rad" if controller == "ntsmc" else "rad/s"
    return dataclasses.replace(
        res, params={"controller": {"controller": controller}, "s_unit": unit}
    )


@pytest.mark.parametrize(
    ("controllers", "unit"),
    [
        # s = e + (1/beta) sig(e_dot)^(p/q) is an angle
        (("ntsmc",), "(rad)"),
        (("ntsmc", "ntsmc"), "(rad)"),
        # s = e_dot + ... is an angular speed
        (("pdsmc", "tsmc", "ftsmc"), "(rad/s)"),
        # mixed: each family's unit, none of them wrong
        (("ftsmc", "ntsmc"), "(rad/s; NTSMC: rad)"),
    ],
)
def test_sliding_label_has_the_unit_of_the_controllers_drawn(
    controllers: tuple[str, ...], unit: str
) -> None:
    runs = _results(2)
    base = list(runs.values())
    results = {f"{c}-{i}": _as(base[i], c) for i, c in enumerate(controllers)}
    fig = plot_sliding(results)
    assert [ax.get_ylabel() for ax in fig.axes] == [f"s₁ {unit}", f"s₂ {unit}"]
    notes = [t.get_text() for ax in fig.axes for t in ax.texts if "symlog" in t.get_text()]
    assert notes, "the symlog panels state their linear half-width"
    bare = unit.strip("()")
    for note in notes:
        if "; " in bare:
            assert not note.endswith("rad") and not note.endswith("rad/s")
        else:
            assert note.endswith(f" {bare}")


def test_one_axes_for_several_joints_is_refused() -> None:
    ax = Figure().add_subplot()
    with pytest.raises(ValueError, match="joints"):
        plot_tracking(_results(3), ax=ax)


@pytest.mark.parametrize("joints", [[0], [4], []])
def test_bad_joint_numbers_are_refused(joints: list[int]) -> None:
    with pytest.raises(ValueError, match=r"1\.\.3"):
        plot_error(_results(3), joints=joints)


def test_empty_and_mismatched_results_are_refused() -> None:
    with pytest.raises(ValueError, match="empty"):
        plot_tracking({})
    with pytest.raises(ValueError, match="same number of joints"):
        plot_tracking({"pdsmc": _run(2, 1.0, chatter=False), "ftsmc": _run(3, 1.0, chatter=False)})


def test_controller_styles_are_fixed_distinct_and_reference_dashed_black() -> None:
    styles = [controller_style(c) for c in CONTROLLERS]
    assert len({s.color for s in styles}) == 3
    assert len({str(s.linestyle) for s in styles}) == 3
    assert controller_style("FTSMC") == controller_style("ftsmc", 7)
    assert REFERENCE_STYLE.color == "black" and REFERENCE_STYLE.linestyle != "solid"
    # the same controller is drawn alike in different figures
    a = plot_tracking(_results(1)).axes[0]
    b = plot_error(_results(1)).axes[0]
    colors_a = {str(ln.get_label()): ln.get_color() for ln in a.get_lines()}
    colors_b = {str(ln.get_label()): ln.get_color() for ln in b.get_lines()}
    assert all(colors_a[k] == colors_b[k] for k in LABELS)
    extra = controller_style("mystery", 0)
    assert extra.label == "MYSTERY" and extra.color not in {s.color for s in styles}


def test_chattering_signal_is_drawn_as_band_under_its_mean() -> None:
    fig = plot_torque(_results(1, chatter=True, dt=5e-4))  # a 10-sample moving mean
    ax = fig.axes[0]
    assert len(ax.collections) == 1  # only PDSMC chatters in the synthetic runs
    pd_line = next(ln for ln in ax.get_lines() if ln.get_label() == "PDSMC")
    y = np.asarray(pd_line.get_ydata())
    assert np.ptp(y[5:-5]) < 25.0  # the ±30 N·m switching is averaged out of the line
    assert not plot_torque(_results(1, chatter=False, dt=5e-4)).axes[0].collections


def test_sliding_uses_symlog_and_steady_state_zooms_on_the_last_window() -> None:
    fig = plot_sliding(_results(2))
    assert all(ax.get_yscale() == "symlog" for ax in fig.axes)
    assert plot_sliding(_results(2), scale="linear").axes[0].get_yscale() == "linear"
    fig = plot_steady_state(_results(2), window=0.5)
    t_end = _results(2)["ftsmc"].t[-1]
    lo, hi = fig.axes[0].get_xlim()
    assert lo == pytest.approx(t_end - 0.5, abs=5e-3) and hi == pytest.approx(t_end)
    assert fig.axes[0].get_yscale() == "log"
    for line in fig.axes[0].get_lines():
        assert np.nanmin(np.asarray(line.get_ydata())) > 0.0


@pytest.mark.parametrize("n", [6, 7])
def test_many_joints_go_in_a_two_column_grid(n: int) -> None:
    # a 6- or 7-joint arm: rows of two panels, each column's lowest panel carries the time axis
    fig = plot_torque(_results(n))
    axes = fig.axes
    assert len(axes) == n
    assert {a.get_subplotspec().colspan.start for a in axes} == {0, 1}
    rows = -(-n // 2)
    assert fig.get_figheight() < 1.6 + 1.4 * n  # shorter than one column of n panels
    labelled = [a for a in axes if a.get_xlabel()]
    assert len(labelled) == 2 and all("(s)" in a.get_xlabel() for a in labelled)
    assert {a.get_subplotspec().rowspan.start for a in labelled} == (
        {rows - 1} if n % 2 == 0 else {rows - 1, rows - 2}
    )
    # the panel above an empty last cell shows its tick labels
    for a in labelled:
        assert any(t.get_visible() for t in a.get_xticklabels())
    for i, a in enumerate(axes):
        assert f"τ{'₀₁₂₃₄₅₆₇'[i + 1]}" in a.get_ylabel()


def _paths(n: int = 3) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    t = np.linspace(0.0, 2.0 * np.pi, 5000)
    desired = np.stack([0.5 + 0.1 * np.cos(t), 0.2 * np.sin(t), 0.4 + 0.05 * t], axis=1)
    actual = {name: desired + 0.001 * k for k, name in enumerate(CONTROLLERS[:n])}
    return desired, actual


def test_tool_path_draws_three_projections_from_arrays() -> None:
    desired, actual = _paths()
    fig = plot_tool_path(actual, desired, max_points=500)
    axes = fig.axes
    assert len(axes) == 3
    assert [(a.get_xlabel(), a.get_ylabel()) for a in axes] == [
        ("x (m)", "y (m)"), ("x (m)", "z (m)"), ("y (m)", "z (m)"),
    ]  # fmt: skip
    for a, (h, v) in zip(axes, [(0, 1), (0, 2), (1, 2)], strict=True):
        assert sorted(_labelled(a)) == sorted([*LABELS, "reference"])
        ftsmc = next(line for line in a.get_lines() if line.get_label() == "FTSMC")
        np.testing.assert_allclose(ftsmc.get_xdata()[[0, -1]], actual["ftsmc"][[0, -1], h])
        np.testing.assert_allclose(ftsmc.get_ydata()[[0, -1]], actual["ftsmc"][[0, -1], v])
        assert len(ftsmc.get_xdata()) <= 501
        assert a.get_aspect() == 1.0
    assert fig.legends and fig.get_suptitle() == "Tool path"
    # into the caller's axes, and without a desired path
    host = Figure()
    given = list(host.subplots(1, 3))
    assert plot_tool_path({"ftsmc": desired}, ax=given, title=None) is host
    assert [_labelled(a) for a in given] == [["FTSMC"]] * 3
    with pytest.raises(ValueError, match=r"paths\['a'\] must be a path of shape \(T, 3\)"):
        plot_tool_path({"a": np.zeros((10, 2))})
    with pytest.raises(ValueError, match="paths is empty"):
        plot_tool_path({})


def test_scenario_figures_add_the_tool_path_of_a_serial_arm() -> None:
    desired, actual = _paths()
    figs = scenario_figures(_results(6), title="UR5", tool_paths=actual, tool_reference=desired)
    assert tuple(figs) == FIGURES + TOOL_FIGURES
    assert "UR5" in figs["tool_path"].get_suptitle()
    assert tuple(scenario_figures(_results(3), title="x", only=["torque"])) == ("torque",)
    with pytest.raises(ValueError, match="unknown figure 'tool_path'"):
        scenario_figures(_results(3), title="planar", only=["tool_path"])


def test_scenario_figures_has_every_figure_titled() -> None:
    figs = scenario_figures(_results(3), title="A. sign switching")
    assert tuple(figs) == FIGURES
    assert all(isinstance(f, Figure) for f in figs.values())
    assert all("A. sign switching" in f.get_suptitle() for f in figs.values())
    assert len(figs["tracking_joint1"].axes) == 1
    assert len(figs["tracking_all"].axes) == 3


def test_save_figure_writes_png_and_svg_atomically_and_deterministically(tmp_path: Path) -> None:
    paths = save_figure(plot_tracking(_results(2)), tmp_path / "a" / "fig.v1")
    assert paths == [tmp_path / "a" / "fig.v1.png", tmp_path / "a" / "fig.v1.svg"]
    assert sorted(p.name for p in (tmp_path / "a").iterdir()) == ["fig.v1.png", "fig.v1.svg"]
    assert paths[0].read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert b"<svg" in paths[1].read_bytes()[:2000]
    again = save_figure(plot_tracking(_results(2)), tmp_path / "b" / "fig.v1")
    assert again[1].read_bytes() == paths[1].read_bytes()
    assert again[0].read_bytes() == paths[0].read_bytes()
    bare = save_figure(plot_tracking(_results(2)), tmp_path / "c" / "fig.v1", svg=False)
    assert bare == [tmp_path / "c" / "fig.v1.png"]
    assert [p.name for p in (tmp_path / "c").iterdir()] == ["fig.v1.png"]
    assert bare[0].read_bytes() == paths[0].read_bytes()  # the PNG does not depend on it


def test_save_figure_clears_the_figure(tmp_path: Path) -> None:
    fig = plot_error(_results(1))
    save_figure(fig, tmp_path / "x")
    assert not fig.axes
    kept = plot_error(_results(1))
    save_figure(kept, tmp_path / "y", clear=False)
    assert kept.axes
    assert (tmp_path / "y.svg").read_bytes() == (tmp_path / "x.svg").read_bytes()


def test_envelope_keeps_extremes_and_ends() -> None:
    rng = np.random.default_rng(0)
    t = np.arange(10_001) * 1e-3
    y = rng.normal(size=t.size)
    tt, yy = envelope(t, y, 1000)
    assert tt.size <= 1000 + 12
    assert np.all(np.diff(tt) > 0)
    assert yy.max() == y.max() and yy.min() == y.min()
    assert tt[0] == t[0] and tt[-1] == t[-1]
    small = envelope(t[:50], y[:50], 1000)
    assert small[0] is t[:50] or np.array_equal(small[0], t[:50])
    tb, lo, hi = band_limits(t, y, 500)
    assert lo.min() == y.min() and hi.max() == y.max() and tb[0] == t[0] and tb[-1] == t[-1]


def test_smooth_keeps_constants_and_ends() -> None:
    y = np.full(50, -250.0)
    np.testing.assert_allclose(smooth(y, 10), y)
    ramp = np.arange(20.0)
    out = smooth(ramp, 5)
    np.testing.assert_allclose(out[2:-2], ramp[2:-2])
    assert out[0] == pytest.approx(1.0)  # mean of 0, 1, 2: the shrunk window, not padded


def test_plotting_never_imports_pyplot() -> None:
    code = (
        "import sys, slidingarm.plotting as p, numpy as np\n"
        "assert 'matplotlib.pyplot' not in sys.modules\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True)


def test_power_of_ten_labels_are_plain_unicode() -> None:
    from slidingarm.plotting._style import pow10_text, subscript

    assert pow10_text(1e-3) == "10⁻³" and pow10_text(1.0) == "10⁰"
    assert pow10_text(-2e-4) == "−2×10⁻⁴" and pow10_text(0.0) == "0"
    assert subscript(12) == "₁₂"
    fig = plot_steady_state(_results(1))
    fig.canvas.draw()
    labels = [t.get_text() for t in fig.axes[0].get_yticklabels() if t.get_text()]
    assert labels and not any("$" in t for t in labels)


def test_figure_worker_draws_the_figures_it_is_given_as_save_figure_does(tmp_path: Path) -> None:
    from slidingarm.plotting._worker import draw

    runs = _results(2)
    stems = {"steady_state": tmp_path / "w" / "b", "torque": tmp_path / "w" / "a"}
    paths = draw(runs, "T", stems)
    assert list(paths) == ["steady_state", "torque"]  # the order of the stems
    assert paths == {"steady_state": tmp_path / "w" / "b.png", "torque": tmp_path / "w" / "a.png"}
    alone = save_figure(
        scenario_figures(runs, title="T", only=["torque"])["torque"], tmp_path / "alone"
    )
    assert (tmp_path / "w" / "a.svg").read_bytes() == alone[1].read_bytes()
    assert (tmp_path / "w" / "a.png").read_bytes() == alone[0].read_bytes()
    with pytest.raises(ValueError, match="unknown figure"):
        draw(runs, "T", {"nope": tmp_path / "nope"})


@pytest.mark.parametrize(("n", "svg"), [(3, True), (6, False)])
def test_a_figure_handed_back_draws_the_next_of_its_layout_as_a_new_figure_would(
    tmp_path: Path, n: int, svg: bool
) -> None:
    # a figure worker hands each saved figure back and draws the next figure of the same
    # layout into it (slidingarm.plotting._recycle): every figure of a second scenario, drawn
    # into the figures the first one's left (of other kinds: the order is reversed), is the
    # same file as a new figure's (PNG, and SVG for three joints); the runs differ in what the plot functions
    # set only for some data (chattering bands, symlog widths, log decades, lengths)
    from slidingarm.plotting import _recycle
    from slidingarm.plotting._worker import draw

    first = _results(n, chatter=True)
    second = _results(n, chatter=False, dt=1e-2)
    # a run on its reference to 1e-9 rad: a steady-state axis of many decades, a narrow s
    on = second["pdsmc"]
    second["pdsmc"] = dataclasses.replace(on, q=on.q_ref + 1e-9, s=on.s * 1e-6)
    new = {}
    for name in FIGURES:
        _recycle.clear()
        new[name] = draw(second, "B", {name: tmp_path / "new" / name}, svg=svg)[name]
    _recycle.clear()
    draw(first, "A", {name: tmp_path / "a" / name for name in FIGURES}, svg=svg)
    kept = _recycle.held()
    # stacked panels, one panel (joint 1), a row per joint and a column per run
    assert len(kept) == 3
    again = draw(
        second, "B", {name: tmp_path / "b" / name for name in reversed(FIGURES)}, svg=svg
    )
    assert sorted(map(id, _recycle.held())) == sorted(map(id, kept))  # the same figures
    for name in FIGURES:
        for suffix in (".png", ".svg") if svg else (".png",):
            drawn = again[name].with_suffix(suffix).read_bytes()
            assert drawn == new[name].with_suffix(suffix).read_bytes(), (name, suffix)
    _recycle.clear()


def test_figures_prepared_in_a_worker_serve_every_figure_of_a_scenario(tmp_path: Path) -> None:
    # a cold study's figure worker makes the figures of the study's layouts while the loop
    # compiles (slidingarm.plotting._worker.prepare_figures): every figure of a scenario of
    # that shape is then drawn into one of them (no figure is made), as a new figure would be
    from slidingarm.plotting import _recycle
    from slidingarm.plotting._worker import draw, prepare_figures

    runs = _results(3)
    _recycle.clear()
    new = draw(runs, "T", {name: tmp_path / "new" / name for name in FIGURES}, svg=False)
    _recycle.clear()
    prepare_figures(3, list(runs))
    prepared = sorted(map(id, _recycle.held()))
    assert len(prepared) == 3
    again = draw(runs, "T", {name: tmp_path / "again" / name for name in FIGURES}, svg=False)
    assert sorted(map(id, _recycle.held())) == prepared
    for name in FIGURES:
        assert again[name].read_bytes() == new[name].read_bytes(), name
    _recycle.clear()


def test_the_study_and_its_report_never_load_matplotlib() -> None:
    # the study's process writes tables and the report only (its forked workers draw): the
    # figure names and controller styles come without matplotlib, the drawing loads it
    code = (
        "import sys\n"
        "import slidingarm.plotting, slidingarm.plotting._worker, slidingarm.report\n"
        "import slidingarm.study.reproduce, slidingarm.study.paper_report\n"
        "from slidingarm.plotting import FIGURES, TOOL_FIGURES, controller_style\n"
        "assert controller_style('ftsmc').label == 'FTSMC' and 'torque' in FIGURES\n"
        "assert 'matplotlib' not in sys.modules, sorted(sys.modules)\n"
        "from slidingarm.plotting import plot_tracking, save_figure\n"
        "assert 'matplotlib' in sys.modules\n"
        "try:\n"
        "    slidingarm.plotting.plot_nothing\n"
        "except AttributeError as exc:\n"
        "    assert 'plot_nothing' in str(exc)\n"
        "else:\n"
        "    raise AssertionError('no error')\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True)


def test_figure_worker_imports_neither_pandas_nor_the_study_and_runs_niced(tmp_path: Path) -> None:
    # what a worker imports to run its tasks; its initializer lowers its priority and turns
    # automatic garbage collection off, each figure task leaving nothing for a collection to
    # find, in any generation (slidingarm._gc)
    code = (
        "import gc, os, sys\n"
        "from slidingarm.plotting import _worker\n"
        "import io, signal\n"
        "before = os.nice(0)\n"
        "signal.signal(signal.SIGTERM, lambda *a: None)\n"  # a parent's handler and streams,
        "sys.stdout, sys.stderr = io.StringIO(), io.StringIO()\n"  # as a fork inherits them
        "_worker.init_worker(os.getppid())\n"
        "assert signal.getsignal(signal.SIGTERM) == signal.SIG_DFL\n"
        "assert sys.stdout is sys.__stdout__ and sys.stderr is sys.__stderr__\n"
        "assert not gc.isenabled() and gc.get_freeze_count() > 0\n"
        "from matplotlib.figure import Figure\n"
        "def figures():\n"  # every Figure object left, frozen ones included
        "    gc.unfreeze()\n"
        "    found = [o for o in gc.get_objects() if isinstance(o, Figure)]\n"
        "    gc.freeze()\n"
        "    return found\n"
        "_worker.warm_up()\n"
        "assert not figures()\n"  # the warm-up figure was collected by the task, not frozen
        "assert not gc.isenabled()\n"
        "bad = [m for m in ('pandas', 'slidingarm.study', 'slidingarm.config') if m in sys.modules]\n"
        "assert not bad, bad\n"
        "assert os.nice(0) == min(before + _worker.WORKER_NICENESS, 19), os.nice(0)\n"
        "import numpy as np\n"
        "from slidingarm.results import SimResult\n"
        "t = np.arange(400) * 5e-3\n"
        "z = np.sin(t)[:, None] * np.ones((1, 3))\n"
        "res = {'pdsmc': SimResult(t=t, q=z, qd=z, q_ref=z, qd_ref=z, q_meas=z, qd_meas=z,"
        " tau=z, s=z, params={}, seed=None)}\n"
        f"paths = _worker.draw(res, 'a run', {{'tracking_all': {str(tmp_path / 'fig')!r}}},"
        " None, False)\n"
        "assert paths['tracking_all'].is_file()\n"
        # and so was the figure task's, but for the figure it handed back for the next one
        "from slidingarm.plotting import _recycle\n"
        "assert figures() == _recycle.held() and len(figures()) == 1\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True)
