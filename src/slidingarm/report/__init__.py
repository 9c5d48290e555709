"""Reports as documents: blocks of markdown and figures, rendered to ``report.md``
(GitHub-flavoured markdown) and a self-contained ``report.html``.

This package knows nothing about any particular study: it holds the blocks
(:class:`FigureBlock`, text), number formatting and markdown tables (:func:`format_value`,
:func:`markdown_table`, :func:`frame_table`), the two renderers and :func:`write_blocks`. The
paper's report, its content and its constants live in :mod:`slidingarm.study.paper_report`.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

from slidingarm._io import atomic_write_text
from slidingarm.report._blocks import Block, FigureBlock
from slidingarm.report._format import format_value, frame_table, markdown_table
from slidingarm.report._html import render_html, render_markdown

__all__ = [
    "Block",
    "FigureBlock",
    "format_value",
    "frame_table",
    "markdown_table",
    "render_html",
    "render_markdown",
    "write_blocks",
]


def write_blocks(
    out_dir: str | os.PathLike[str], title: str, blocks: Sequence[Block]
) -> tuple[Path, Path]:
    """Write ``out_dir/report.md`` and ``out_dir/report.html`` from ``blocks``.

    The markdown links each figure's PNG by its path relative to ``out_dir``
    (:attr:`FigureBlock.rel`); the HTML embeds the PNGs as base64 ``data:`` URIs and its CSS
    inline, so it opens offline and can be mailed alone. Both files are written atomically
    (temporary file, then :func:`os.replace`).

    Raises
    ------
    FileNotFoundError
        If the PNG of a :class:`FigureBlock` does not exist.
    """
    out = Path(out_dir)
    missing = [str(b.path) for b in blocks if isinstance(b, FigureBlock) and not b.path.is_file()]
    if missing:
        raise FileNotFoundError(
            f"report figures not found (paths in ctx.figures are relative to {out}): {missing}"
        )
    md_path, html_path = out / "report.md", out / "report.html"
    atomic_write_text(md_path, render_markdown(blocks))
    atomic_write_text(html_path, render_html(title, blocks))
    return md_path, html_path
