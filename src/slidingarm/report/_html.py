"""HTML rendering of the report: one self-contained file (inline CSS, figures as data URIs),
with a table of contents linking every section and subsection by its anchor."""

from __future__ import annotations

import base64
import html
import re
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from markdown_it import MarkdownIt

from slidingarm.report._blocks import Block, FigureBlock

__all__ = ["render_html", "render_markdown", "slug"]

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
nav.toc { background: #f6f7f9; border: 1px solid #e2e3e8; border-radius: 4px;
  padding: 0.6rem 1.2rem; margin: 1rem 0 1.5rem; max-width: 60rem; }
nav.toc ol { margin: 0.2rem 0; padding-left: 1.4rem; }
nav.toc li { margin: 0.1rem 0; }
nav.toc > p { margin: 0; font-weight: 600; }
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


def slug(text: str, taken: set[str]) -> str:
    """An anchor for a heading: lower case, runs of anything but letters and digits as one
    ``-``, unique among ``taken`` (a ``-2``, ``-3``, ... suffix), which it joins."""
    base = re.sub(r"[^\w]+", "-", text.lower(), flags=re.UNICODE).strip("-_") or "section"
    name, i = base, 2
    while name in taken:
        name, i = f"{base}-{i}", i + 1
    taken.add(name)
    return name


def _render_text(
    md: MarkdownIt, text: str, taken: set[str], toc: list[tuple[int, str, str]]
) -> str:
    """One markdown block as HTML, each heading given an ``id`` (recorded in ``toc`` as
    ``(level, text, id)``)."""
    tokens = md.parse(text)
    for i, tok in enumerate(tokens):
        if tok.type == "heading_open" and i + 1 < len(tokens):
            inline = tokens[i + 1]
            label = "".join(c.content for c in inline.children or [] if c.content) or inline.content
            anchor = slug(label, taken)
            tok.attrSet("id", anchor)
            toc.append((int(tok.tag[1]), label, anchor))
    env: dict[str, Any] = {}
    return str(md.renderer.render(tokens, md.options, env))


def _toc_html(toc: Sequence[tuple[int, str, str]]) -> str:
    """A nested list of links to the sections (h2) and subsections (h3)."""
    items = [(level, text, anchor) for level, text, anchor in toc if level in (2, 3)]
    if not items:
        return ""
    out = ['<nav class="toc" aria-label="Contents"><p>Contents</p><ol>']
    open_sub = False
    for k, (level, text, anchor) in enumerate(items):
        link = f'<a href="#{html.escape(anchor)}">{html.escape(text)}</a>'
        if level == 2:
            if open_sub:
                out.append("</ol></li>")
                open_sub = False
            elif k:
                out.append("</li>")
            out.append(f"<li>{link}")
        else:
            if not open_sub:
                out.append("<ol>")
                open_sub = True
            out.append(f"<li>{link}</li>")
    out.append("</ol></li>" if open_sub else "</li>")
    out.append("</ol></nav>")
    return "".join(out)


def render_html(title: str, blocks: Sequence[Block]) -> str:
    """The report as one HTML page with no external resource: CSS inline, each figure's PNG
    embedded as a base64 ``data:`` URI, every text escaped. Every heading gets an anchor
    (:func:`slug`), and a table of contents linking the sections and their subsections follows
    the first block (the title)."""
    md = _markdown_it()
    body = []
    taken: set[str] = set()
    toc: list[tuple[int, str, str]] = []
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
            rendered = _render_text(md, block, taken, toc)
            rendered = rendered.replace("<table>", '<div class="table-wrap"><table>').replace(
                "</table>", "</table></div>"
            )
            body.append(rendered)
    nav = _toc_html(toc)
    if nav and body:
        body.insert(1, nav)
    return (
        "<!DOCTYPE html>\n"
        '<html lang="en">\n<head>\n<meta charset="utf-8">\n'
        '<meta name="viewport" content="width=device-width, initial-scale=1">\n'
        f"<title>{html.escape(title)}</title>\n<style>{_CSS}</style>\n</head>\n"
        "<body>\n<main>\n" + "\n".join(body) + "\n</main>\n</body>\n</html>\n"
    )
