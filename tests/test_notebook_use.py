"""Notebook use of results (issue 11, point 13): short reprs, an HTML repr, ``.plot()``, and
every plot function taking one result as well as a mapping of results."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from matplotlib.figure import Figure

import slidingarm as sa
from slidingarm import plotting

ARM = sa.PlanarArm.paper()
CTRL = sa.FTSMC(ARM, alpha=2, beta=2, p=5, q=3, k=20, switching="tanh", width=0.05)


@pytest.fixture(scope="module")
def result() -> sa.SimResult:
    return sa.simulate(ARM, CTRL, sa.PaperReference(), q0=sa.PAPER_Q0, t_final=0.5, dt=5e-4)


@pytest.fixture(scope="module")
def batch() -> sa.BatchResult:
    plants = [ARM, ARM.with_payload(0.5)]
    return sa.simulate_batch(plants, CTRL, sa.PaperReference(), q0=sa.PAPER_Q0, t_final=0.2,
                             dt=5e-4)  # fmt: skip


def test_result_repr_is_one_short_line(result: sa.SimResult) -> None:
    text = repr(result)
    assert text == "SimResult(FTSMC, 3 joints, 1001 samples of 0.0005 s over 0.5 s, seed=0, ok)"
    assert len(text) < 120 and "array" not in text


def test_failed_result_repr_says_why() -> None:
    wild = sa.PDSMC(ARM, lam=2, k=1e9)
    res = sa.simulate(ARM, wild, sa.PaperReference(), q0=sa.PAPER_Q0, t_final=0.5, dt=5e-4,
                      throw=False)  # fmt: skip
    assert not res.success
    assert repr(res).startswith("SimResult(PDSMC, 3 joints,") and res.message in repr(res)
    assert res.status in res._repr_html_()


def test_result_html_repr_is_a_small_escaped_table(result: sa.SimResult) -> None:
    html = result._repr_html_()
    assert html.startswith("<table>") and html.endswith("</table>")
    assert "FTSMC" in html and "1001 of 0.0005 s" in html and ">ok<" in html
    assert len(html) < 1500 and "[[" not in html


def test_batch_reprs(batch: sa.BatchResult) -> None:
    assert repr(batch) == "BatchResult(2 runs, record='full', 2 ok, 0 failed, 401 samples)"
    html = batch._repr_html_()
    assert html.startswith("<table>") and "2 of 2" in html and "FTSMC" in html


PLOTS = [
    plotting.plot_tracking,
    plotting.plot_velocity,
    plotting.plot_torque,
    plotting.plot_sliding,
    plotting.plot_error,
    plotting.plot_steady_state,
]


@pytest.mark.parametrize("plot", PLOTS, ids=lambda f: f.__name__)
def test_every_plot_takes_one_result_or_a_mapping(plot, result: sa.SimResult) -> None:  # type: ignore[no-untyped-def]
    one = plot(result, joints=[1])
    many = plot({"ftsmc": result}, joints=[1])
    assert isinstance(one, Figure) and isinstance(many, Figure)
    # the single run is drawn as its controller, in that controller's style
    style = plotting.controller_style("ftsmc")
    for fig in (one, many):
        lines = [ln for ln in fig.axes[0].get_lines() if ln.get_label() == style.label]
        assert lines and lines[0].get_color() == style.color
    y_one = [ln.get_ydata() for ln in one.axes[0].get_lines()]
    y_many = [ln.get_ydata() for ln in many.axes[0].get_lines()]
    assert len(y_one) == len(y_many)
    for a, b in zip(y_one, y_many, strict=True):
        np.testing.assert_array_equal(a, b)


def test_plot_tool_path_takes_one_path() -> None:
    path = np.column_stack([np.linspace(0, 1, 50), np.zeros(50), np.ones(50)])
    fig = plotting.plot_tool_path(path)
    assert len(fig.axes) == 3 and fig.axes[0].get_lines()


def test_scenario_figures_take_one_result(result: sa.SimResult) -> None:
    figs = plotting.scenario_figures(result, title="mine", only=["torque"])
    assert list(figs) == ["torque"]


def test_a_wrong_argument_names_what_is_expected() -> None:
    with pytest.raises(TypeError, match=r"results must be a SimResult or a mapping"):
        plotting.plot_tracking([1, 2])  # type: ignore[arg-type]
    with pytest.raises(TypeError, match=r"results\['a'\] must be a SimResult"):
        plotting.plot_tracking({"a": 3})  # type: ignore[dict-item]


def test_result_plot_draws_the_tracking_figure(result: sa.SimResult) -> None:
    fig = result.plot()
    assert isinstance(fig, Figure) and len(fig.axes) == 3
    assert "tracking" in fig._suptitle.get_text().lower()  # type: ignore[union-attr]
    one = result.plot(joints=[2], title=None)
    assert len(one.axes) == 1


def test_batch_plot(batch: sa.BatchResult) -> None:
    fig = batch.plot()
    labels = {ln.get_label() for ln in fig.axes[0].get_lines()}
    assert {"RUN 0", "RUN 1"} <= labels
    assert len(batch.plot(runs=[1], joints=[1]).axes) == 1
    with pytest.raises(ValueError, match=r"run indices in 0\.\.1"):
        batch.plot(runs=[2])
    metrics_only = sa.simulate_batch(ARM, CTRL, sa.PaperReference(), q0=sa.PAPER_Q0,
                                     t_final=0.05, dt=5e-4, record="metrics")  # fmt: skip
    with pytest.raises(ValueError, match=r"record='metrics'"):
        metrics_only.plot()


def test_results_module_does_not_import_matplotlib() -> None:
    code = "import sys, slidingarm.results; print('matplotlib' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"
