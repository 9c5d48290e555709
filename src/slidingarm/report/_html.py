"""HTML rendering of the report: one self-contained file (inline CSS, figures as data URIs)."""

from __future__ import annotations

import base64
import html
from collections.abc import Sequence
from pathlib import Path

from markdown_it import MarkdownIt

from slidingarm.report._blocks import Block, FigureBlock

__all__ = ["render_html", "render_markdown"]

_CSS = """
:root { color-scheme: light; }
body { margin: 0; background: #fafafa; color: #1d1d1f;
  font: 15px/1.55 -apple-system, "Segoe UI", Roboto, "Helvetica Neue", Arial, sans-serif; }
main { max-width: 1100px; margin: 0 auto; padding: 2rem 1.5rem 4rem; background: #fff; }
h1 { font-size: 1.7rem; line-height: 1.25; margin: 0 0 1rem; }
h2 { font-size: 1.3rem; margin: 2.4rem 0 0.8rem; padding-bottom: 0.25rem;
  border-bottom: 1px solid #ddd; }
h3 { font-size: 1.08rem; margin: 1.6rem 0 0.6rem; }
p, li { max-width: 60rem; }
code { font-family: ui-monospace, SFMono-Regular, Menlo, Consolas, monospace; font-size: 0.9em;
  background: #f2f2f4; padding: 0.05em 0.3em; border-radius: 3px; }
pre { background: #f2f2f4; padding: 0.7rem 1rem; overflow-x: auto; border-radius: 4px; }
pre code { background: none; padding: 0; }
.table-wrap { overflow-x: auto; margin: 0.6rem 0 1rem; }
table { border-collapse: collapse; font-size: 0.86rem; font-variant-numeric: tabular-nums; }
th, td { border: 1px solid #d9d9de; padding: 0.25rem 0.55rem; vertical-align: top; }
th { background: #f0f1f4; text-align: left; }
tbody tr:nth-child(even) { background: #fafbfc; }
figure { margin: 1.2rem 0 2rem; }
figure img { max-width: 100%; height: auto; border: 1px solid #eee; }
figcaption { font-size: 0.88rem; color: #444; max-width: 60rem; margin-top: 0.3rem; }
"""


def _markdown_it() -> MarkdownIt:
    # raw HTML in any text is escaped (html=False): the report's text cannot inject markup
    return MarkdownIt("commonmark", {"html": False, "typographer": False}).enable("table")


def render_markdown(blocks: Sequence[Block]) -> str:
    """The report as GitHub-flavoured markdown; figures link their PNG by relative path."""
    parts = []
    for block in blocks:
        if isinstance(block, FigureBlock):
            dest = block.rel
            if any(ch in dest for ch in " ()<>"):
                dest = f"<{dest}>"
            alt = block.alt.replace("[", "(").replace("]", ")")
            text = f"![{alt}]({dest})\n\n*{_md_inline_escape(block.caption)}*"
            if block.svg:
                svg = f"<{block.svg}>" if any(ch in block.svg for ch in " ()<>") else block.svg
                text += f" [SVG]({svg})"
            parts.append(text)
        else:
            parts.append(block.strip())
    return "\n\n".join(parts) + "\n"


def _md_inline_escape(text: str) -> str:
    return text.replace("*", "\\*").replace("_", "\\_")


def render_html(title: str, blocks: Sequence[Block]) -> str:
    """The report as one HTML page with no external resource: CSS inline, each figure's PNG
    embedded as a base64 ``data:`` URI, every text escaped."""
    md = _markdown_it()
    body = []
    for block in blocks:
        if isinstance(block, FigureBlock):
            data = base64.b64encode(Path(block.path).read_bytes()).decode("ascii")
            body.append(
                "<figure>"
                f'<img src="data:image/png;base64,{data}" alt="{html.escape(block.alt)}">'
                f"<figcaption>{html.escape(block.caption)}</figcaption>"
                "</figure>"
            )
        else:
            rendered = md.render(block)
            rendered = rendered.replace("<table>", '<div class="table-wrap"><table>').replace(
                "</table>", "</table></div>"
            )
            body.append(rendered)
    return (
        "<!DOCTYPE html>\n"
        '<html lang="en">\n<head>\n<meta charset="utf-8">\n'
        '<meta name="viewport" content="width=device-width, initial-scale=1">\n'
        f"<title>{html.escape(title)}</title>\n<style>{_CSS}</style>\n</head>\n"
        "<body>\n<main>\n" + "\n".join(body) + "\n</main>\n</body>\n</html>\n"
    )
