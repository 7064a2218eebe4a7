"""What every lecture figure shares: deterministic saving and the mark that lists a function as a figure.

Each figure function takes an optional output ``path``, builds a
``matplotlib.figure.Figure`` without touching pyplot's global state, saves it
when a path is given (PNG, no timestamp or version in the metadata, so a
figure file changes only when the figure does) and returns it.
"""

from __future__ import annotations

from pathlib import Path
from typing import Callable

from matplotlib.figure import Figure

__all__ = ["lecture_figure", "save"]


def lecture_figure(func: Callable) -> Callable:
    """Mark a function as a lecture figure (:data:`tissuefem.workbook.figures.FIGURES` lists the marked ones)."""
    func.lecture_figure = True
    return func


def save(fig: Figure, path) -> None:
    """Save deterministically: fixed DPI, no 'Software' entry or timestamps in the PNG."""
    if path is None:
        return
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110, metadata={"Software": None})
