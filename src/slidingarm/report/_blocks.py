"""What a report is made of: blocks of markdown text and figures, in order."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

__all__ = ["Block", "FigureBlock"]


@dataclass(frozen=True)
class FigureBlock:
    """One figure of the report: where its PNG is (relative to the report and on disk)."""

    rel: str
    path: Path
    caption: str
    alt: str
    svg: str | None = None


Block = str | FigureBlock
