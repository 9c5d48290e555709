"""The study's report: ``report.md`` (GitHub-flavoured markdown) and a self-contained
``report.html``, written from a :class:`ReportContext` by :func:`write_report`.

The report only formats what the study computed: the MSE beside the paper's (beside the sign
scenario only, the case of the paper's MSE table), the gains and noise with their reasons, the
checks, finite-time convergence, the sign/tanh chattering contrast over the whole run and after the
transient, the paper's errata and their measured cost, the gain grid, every metric (with the
thresholds of :mod:`slidingarm.metrics`) and every figure. Every number in its prose comes from
those tables or from the library's constants.
"""

from __future__ import annotations

import os
from pathlib import Path

from slidingarm._io import atomic_write_text
from slidingarm.report._build import PAPER_FIGURES, build_blocks
from slidingarm.report._context import ReportContext, ScenarioKind
from slidingarm.report._format import format_value
from slidingarm.report._html import render_html, render_markdown

__all__ = ["PAPER_FIGURES", "ReportContext", "ScenarioKind", "format_value", "write_report"]


def write_report(out_dir: str | os.PathLike[str], ctx: ReportContext) -> tuple[Path, Path]:
    """Write ``out_dir/report.md`` and ``out_dir/report.html`` from ``ctx``.

    The markdown links each figure's PNG by its path relative to ``out_dir`` (as
    ``ctx.figures`` gives it); the HTML embeds the PNGs as base64 ``data:`` URIs and its CSS
    inline, so it opens offline and can be mailed alone. Both files are written atomically
    (temporary file, then :func:`os.replace`).

    Raises
    ------
    FileNotFoundError
        If a figure of ``ctx.figures`` does not exist under ``out_dir``.
    """
    out = Path(out_dir)
    title, blocks = build_blocks(ctx, out)
    missing = [str(b.path) for b in blocks if hasattr(b, "path") and not Path(b.path).is_file()]
    if missing:
        raise FileNotFoundError(
            f"report figures not found (paths in ctx.figures are relative to {out}): {missing}"
        )
    md_path, html_path = out / "report.md", out / "report.html"
    atomic_write_text(md_path, render_markdown(blocks))
    atomic_write_text(html_path, render_html(title, blocks))
    return md_path, html_path
