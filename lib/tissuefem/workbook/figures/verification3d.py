"""Chapter 11 figures: the reference verified on tetrahedra, drawn like chapter 9's verification
(:func:`~tissuefem.workbook.figures.tradeoffs.plot_convergence`)."""

from __future__ import annotations

from matplotlib.figure import Figure

from ..verification import manufactured_convergence
from .base import lecture_figure
from .tradeoffs import plot_convergence


@lecture_figure
def fig_ch11_convergence(rows=None) -> Figure:
    """Chapter 11: the 3D reference verified -- nonlinear mesh convergence on tetrahedra at rates 2 (P1) and 3
    (P2), three models (:func:`~tissuefem.workbook.verification.manufactured_convergence` with ``dim=3``)."""
    return plot_convergence(manufactured_convergence(dim=3) if rows is None else rows,
                            "Manufactured solution on tetrahedra (twisted arch + its body force)")
