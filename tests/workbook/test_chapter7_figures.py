"""Chapter 7's budget figure and the lumped-mass guard."""

import numpy as np
import pytest

from helpers import assert_figure_deterministic
from tissuefem import Handle, Model, NeoHookean, flap
from tissuefem.workbook.timestepping import capped_runs


def test_more_newton_steps_per_frame_leave_less_residual_and_error():
    rows = capped_runs(sizes=(200, 800), caps=(1, 2, 3), frames=12)
    for n in {r["triangles"] for r in rows}:
        sel = sorted((r for r in rows if r["triangles"] == n), key=lambda r: r["cap"])
        residuals = [r["median_relative_residual"] for r in sel]
        errors = [r["state_error"] for r in sel]
        assert residuals[0] > residuals[1] > residuals[2]
        assert errors[0] > errors[1] > errors[2]
        assert residuals[2] < 1e-6  # three steps: converged for practical purposes
        assert errors[0] < 1e-2  # even one step per frame stays close to the converged run


def test_fig_ch07_budget_residual_is_deterministic(tmp_path):
    assert_figure_deterministic("fig_ch07_budget_residual", tmp_path)


def test_lumped_mass_refuses_p2():
    mesh, material = flap(n_triangles=50), NeoHookean.from_young(1000.0, 0.3)
    with pytest.raises(ValueError, match="consistent"):
        Model(mesh, material, order=2, dt=0.1, mass="lumped", handles=[Handle("fixed")])
    model = Model(mesh, material, order=2, dt=0.1, mass="consistent", handles=[Handle("fixed")])
    assert np.all(np.isfinite(model.inertia.M.data))
