"""The studies of the 1D chapters: a manufactured solution, the mesh convergence of the bar, and Newton on it."""

from __future__ import annotations

import numpy as np

from ..engine.bar1d import Bar1D, Displacement, Traction
from ..engine.constants import TISSUE_E, TISSUE_NU
from ..engine.materials1d import NeoHookean1D

__all__ = ["manufactured_solution", "convergence_study", "newton_histories"]


def manufactured_solution(modulus: float = 1.0, traction: float = 1.0):
    """``(f, u, du)`` of the bar on [0, 1], ``u(0) = 0``, end traction ``T``, ``f = E1 pi^2 sin(pi X)``: ``-E1
    u'' = f`` and ``E1 u'(1) = T`` give ``u = sin(pi X) + c X``, ``c = T / E1 + pi``."""
    c = traction / modulus + np.pi

    def f(X):
        return modulus * np.pi**2 * np.sin(np.pi * X)

    def u(X):
        return np.sin(np.pi * X) + c * X

    def du(X):
        return np.pi * np.cos(np.pi * X) + c

    return f, u, du


def convergence_study(orders=(1, 2), ns=(4, 8, 16, 32, 64, 128), modulus: float = 1.0, traction: float = 1.0):
    """Errors of the linear bar against :func:`manufactured_solution`: dicts of ``order, n, h, L2, H1, nodal``
    (largest at the nodes) and ``rate_L2, rate_H1`` from the previous mesh (NaN on the coarsest)."""
    f, u_exact, du_exact = manufactured_solution(modulus, traction)
    rows = []
    for order in orders:
        previous = None
        for n in ns:
            bar = Bar1D(0.0, 1.0, n, order=order)
            u = bar.solve_linear(modulus, f, left=Displacement(0.0), right=Traction(traction))
            l2, h1 = bar.errors(u, u_exact, du_exact)
            nodal = float(np.max(np.abs(u[bar.basis.nodal_dofs[0]] - u_exact(bar.mesh.p[0]))))
            row = {"order": order, "n": n, "h": 1.0 / n, "L2": l2, "H1": h1, "nodal": nodal,
                   "rate_L2": np.nan, "rate_H1": np.nan}
            if previous is not None:
                ratio = np.log(previous["h"] / row["h"])
                row["rate_L2"] = float(np.log(previous["L2"] / l2) / ratio)
                row["rate_H1"] = float(np.log(previous["H1"] / h1) / ratio)
            rows.append(row)
            previous = row
    return rows


def newton_histories(tractions=(100.0, 300.0, 600.0, -300.0, -600.0), n: int = 16) -> dict:
    """Chapter 2: ``{T: (residual norms, status)}`` of Newton on the 1D Neo-Hookean bar (E = 1000, nu = 0.3,
    ``n`` elements) under each end traction ``T``, to ``rtol = 1e-13``."""
    material, bar = NeoHookean1D.from_young(TISSUE_E, TISSUE_NU), Bar1D(0.0, 1.0, n)
    histories = {}
    for T in tractions:
        _, results = bar.solve_nonlinear(material, right=Traction(T), rtol=1e-13)
        histories[T] = (results[-1].residual_norms(), results[-1].status)
    return histories
