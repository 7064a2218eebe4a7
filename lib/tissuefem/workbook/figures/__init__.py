"""Every lecture figure as a function (:data:`FIGURES`, in the chapters' order), written by :func:`generate`
(``python -m tissuefem figures``). Figures draw; they never run a benchmark, only read recorded results."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Callable

from . import cutting, dynamics, fibers, haptics, inversion, kinematics, oned, surgery, tissue3d, tradeoffs
from .base import lecture_figure, matplotlib_note, save

__all__ = ["FIGURES", "generate", "lecture_figure", "matplotlib_note", "save"]

#: every lecture figure by name, chapter by chapter
FIGURES: dict[str, Callable] = {
    name: func
    for module in (oned, kinematics, fibers, inversion, dynamics, surgery, haptics, tradeoffs, cutting, tissue3d)
    for name, func in vars(module).items()
    if getattr(func, "lecture_figure", False) and getattr(func, "__module__", None) == module.__name__
}


def generate(names=None, outdir="figures", progress=print) -> list[Path]:
    """Regenerate the named figures (all by default) into ``outdir``; returns the paths."""
    names = list(FIGURES) if names is None else list(names)
    unknown = [n for n in names if n not in FIGURES]
    if unknown:
        raise ValueError(f"unknown figure(s) {unknown}; choose from {sorted(FIGURES)}")
    paths = []
    start = time.perf_counter()
    for i, name in enumerate(names, 1):
        t0 = time.perf_counter()
        path = Path(outdir) / f"{name}.png"
        FIGURES[name](path)
        paths.append(path)
        if progress:
            progress(f"[figure {i}/{len(names)}] {path}  ({time.perf_counter() - t0:.1f} s, "
                     f"total {time.perf_counter() - start:.1f} s)")
    return paths
