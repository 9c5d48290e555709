"""The report's figures and page (issue 11, point 14): every controller visible in the torque
and sliding-variable figures, figure files named by the paper's figure numbers, a table of
contents with anchors in the HTML report, and no emoji."""

from __future__ import annotations

import re
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest
from matplotlib.colors import to_hex

import slidingarm as sa
from slidingarm import plotting
from slidingarm.plotting import FIGURES, controller_style
from slidingarm.report import FigureBlock, write_blocks
from slidingarm.report._format import cell
from slidingarm.study.paper_report import figure_stem, paper_figure_number
from slidingarm.study.reproduce import render_figures

ARM = sa.PlanarArm.paper()
SRC = Path(sa.__file__).resolve().parent


@pytest.fixture(scope="module")
def runs() -> dict[str, sa.SimResult]:
    """The three controllers under sign switching over 0.4 s: their torque chatters in bands."""
    gains = {"k": 20.0, "switching": "sign"}
    ctrls = {
        "pdsmc": sa.PDSMC(ARM, lam=2, **gains),
        "tsmc": sa.TSMC(ARM, beta=2, p=5, q=3, eps_e=5e-8, **gains),
        "ftsmc": sa.FTSMC(ARM, alpha=2, beta=2, p=5, q=3, eps_e=5e-8, **gains),
    }
    return {
        name: sa.simulate(ARM, c, sa.PaperReference(), q0=sa.PAPER_Q0, t_final=0.4, dt=5e-4)
        for name, c in ctrls.items()
    }


def _colors(ax) -> set[str]:  # type: ignore[no-untyped-def]
    """Colours of the data an Axes draws (lines and filled bands; not grid or zero line)."""
    found = {to_hex(ln.get_color()) for ln in ax.get_lines() if ln.get_label()[:1] != "_"}
    for coll in ax.collections:
        found |= {to_hex(c) for c in coll.get_facecolor()}
    return found


@pytest.mark.parametrize("figure", ["torque", "sliding"])
def test_every_controller_has_its_own_panels(runs: dict[str, sa.SimResult], figure: str) -> None:
    fig = plotting.scenario_figures(runs, title="A", only=[figure])[figure]
    n, names = 3, list(runs)
    assert len(fig.axes) == n * len(names)
    for i, a in enumerate(fig.axes):
        style = controller_style(names[i % len(names)])
        own = to_hex(style.color)
        assert own in _colors(a), (i, style.label)
        others = {to_hex(controller_style(m).color) for m in names} - {own}
        assert not (_colors(a) & others), f"panel {i} draws another controller"
        if i < len(names):
            assert a.get_title() == style.label
    # each row shares its y axis, so the columns compare at a glance
    for row in range(n):
        limits = {fig.axes[row * len(names) + c].get_ylim() for c in range(len(names))}
        assert len(limits) == 1


def test_a_band_shows_in_its_own_panel(runs: dict[str, sa.SimResult]) -> None:
    """Sign switching: each controller's band (the min-max of its chattering torque) is drawn,
    not hidden behind another's."""
    fig = plotting.plot_torque(runs, layout="columns")
    bands = [len(a.collections) for a in fig.axes]
    assert all(b >= 1 for b in bands), bands


def test_overlay_stays_the_default_and_columns_need_the_right_axes(
    runs: dict[str, sa.SimResult],
) -> None:
    assert len(plotting.plot_torque(runs).axes) == 3
    assert len(plotting.plot_torque(runs["ftsmc"], layout="columns").axes) == 3  # one run
    with pytest.raises(ValueError, match=r"layout must be one of overlay, columns"):
        plotting.plot_torque(runs, layout="grid")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"must be 9 Axes for layout='columns'"):
        plotting.plot_sliding(runs, layout="columns", ax=plotting.plot_torque(runs).axes)


def test_figure_files_carry_the_papers_numbers(tmp_path: Path, runs: dict[str, sa.SimResult]) -> None:
    assert figure_stem("sign", "torque") == "sign_fig05_torque"
    assert figure_stem("sign", "tracking_all") == "sign_fig03_tracking_all"  # Figs. 3 and 9
    assert figure_stem("tanh", "tracking_joint1") == "tanh_fig10_tracking_joint1"
    assert figure_stem("noise", "steady_state") == "noise_fig22_steady_state"
    assert figure_stem("sign", "steady_state") == "sign_steady_state"  # not in the paper
    assert figure_stem("ur5", "torque") == "ur5_torque"  # not one of the paper's cases
    assert figure_stem("mine", "sliding", kind="tanh") == "mine_fig12_sliding"
    numbers = [paper_figure_number(k, f) for k in ("sign", "tanh", "noise") for f in FIGURES]
    assert sorted(x for x in numbers if x is not None) == sorted(set(range(3, 23)) - {9})
    paths = render_figures("sign", runs, "A", tmp_path, only=("torque", "steady_state"))
    assert {p.name for p in paths.values()} == {"sign_fig05_torque.png", "sign_steady_state.png"}
    assert (tmp_path / "sign_fig05_torque.svg").is_file()
    bare = render_figures("sign", runs, "A", tmp_path / "png", only=("torque",), svg=False)
    assert bare == {"torque": tmp_path / "png" / "sign_fig05_torque.png"}
    assert [p.name for p in (tmp_path / "png").iterdir()] == ["sign_fig05_torque.png"]


class _Anchors(HTMLParser):
    def __init__(self) -> None:
        super().__init__()
        self.ids: list[str] = []
        self.links: list[str] = []
        self.in_nav = False

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        d = dict(attrs)
        if tag == "nav":
            self.in_nav = True
        if d.get("id"):
            self.ids.append(str(d["id"]))
        if tag == "a" and self.in_nav and d.get("href", "").startswith("#"):  # type: ignore[union-attr]
            self.links.append(str(d["href"])[1:])

    def handle_endtag(self, tag: str) -> None:
        if tag == "nav":
            self.in_nav = False


def test_html_report_has_a_table_of_contents_with_anchors(tmp_path: Path) -> None:
    png = tmp_path / "f.png"
    png.write_bytes(b"\x89PNG\r\n\x1a\n")
    blocks = [
        "# The report",
        "Summary.",
        "## Checks\n\nText.",
        "## Figures",
        "### A. sign (sign)",
        FigureBlock(rel="f.png", path=png, caption="Figure 1.", alt="one"),
        "### B. tanh & more",
        "## Checks",  # a repeated heading still gets its own anchor
    ]
    _, html_path = write_blocks(tmp_path, "The report", blocks)
    html = html_path.read_text(encoding="utf-8")
    parser = _Anchors()
    parser.feed(html)
    assert parser.links == ["checks", "figures", "a-sign-sign", "b-tanh-more", "checks-2"]
    assert set(parser.links) <= set(parser.ids) and len(set(parser.ids)) == len(parser.ids)
    assert html.index('<nav class="toc"') > html.index("<h1")  # after the title
    assert html.index('<nav class="toc"') < html.index('id="checks"')
    assert re.search(r"<li><a href=\"#figures\">Figures</a><ol><li><a href=\"#a-sign-sign\">", html)


EMOJI = re.compile("[\U0001f000-\U0001faff\u2600-\u27bf\u2b50\u2b55\ufe0f]")


def test_no_emoji_in_the_report_or_figures() -> None:
    assert (cell("passed", True), cell("passed", False)) == ("pass", "FAIL")
    for folder in ("report", "study", "plotting"):
        for path in (SRC / folder).rglob("*.py"):
            text = path.read_text(encoding="utf-8")
            assert not EMOJI.search(text), f"{path}: {EMOJI.findall(text)}"


def test_small_multiples_keep_every_sample_of_the_band(runs: dict[str, sa.SimResult]) -> None:
    """The drawn band of a panel spans its run's own torque range (nothing clipped away)."""
    fig = plotting.plot_torque(runs, layout="columns", joints=[1])
    for a, res in zip(fig.axes, runs.values(), strict=True):
        lo, hi = a.get_ylim()
        tau = res.tau[:, 0]
        assert lo <= float(np.min(tau)) and float(np.max(tau)) <= hi
