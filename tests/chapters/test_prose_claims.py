"""Sentences of the chapters that state a computed number, recomputed from the run the chapter makes.

Each test's docstring quotes the sentence (``...`` marks an elision), which is how
``test_prose_numbers.py`` knows that the numbers in it are checked.
"""

import numpy as np
import pytest

from tissuefem import P1Assembler
from tissuefem.engine.materials import det2


def test_ch06b_the_log_model_crush_stops_before_flat_and_recovers():
    """Chapter 6b: "The crush gets to 0.9; the step to flat cannot converge" and "Released from 0.9 it springs back
    perfectly"; "the Taylor and stable meshes at 1.3 contain no red triangle at all"."""
    from tissuefem.workbook.hardcases import block, crush_and_release, inversion_models

    mesh, models = block(), inversion_models()
    log = crush_and_release(models["neo-Hookean (ln J)"], mesh)
    assert log["crushed"] == pytest.approx(0.9) and log["crush"][-1].status == "non-finite"
    assert log["released"].converged and log["released"].rest_error < 1e-8
    for name in ("Taylor neo-Hookean", "stable neo-Hookean"):
        run = crush_and_release(models[name], mesh)
        assert run["crushed"] == pytest.approx(1.3), name
        crushed = run["frames"][-2] - mesh.p  # the positions after the last step of the crush
        J = det2(P1Assembler(mesh).deformation_gradient(crushed.T.reshape(-1)))
        assert J.min() > 0, name


def test_ch04_the_recorded_newton_counts_are_what_a_solve_counts():
    """Chapter 4, section 5: "On those meshes its Newton iterations per solve are the recording's": the recorded
    counts (the predictor counted) are those of a solve today, on the recording's smaller meshes."""
    from tissuefem.engine.constants import TISSUE_E, TISSUE_NU
    from tissuefem.engine.materials import NeoHookean
    from tissuefem.engine.stepping import solve
    from tissuefem.workbook.studies import BLOCK_HANDLE, RECORDED_COST_ACCURACY, block_model

    material = NeoHookean.from_young(TISSUE_E, TISSUE_NU)
    for row in (r for r in RECORDED_COST_ACCURACY if r["dofs"] <= 306):
        result = solve(block_model(row["n"], row["order"], material, BLOCK_HANDLE))
        assert result.converged and result.newton_iterations == row["newton_iterations"], row


def test_ch09_the_block_converges_below_rate_2():
    """Chapter 9: "On the block the error falls steadily with the mesh, at a rate below 2 because of the
    corners, and the cost grows about in proportion to the triangles"."""
    from tissuefem.workbook.bench.accuracy_cost import recorded_results
    from tissuefem.workbook.measure import fitted_exponent

    rows = [r for r in recorded_results()["knobs"] if r["benchmark"] == "block" and r["knob"] == "mesh"]
    h = [r["triangles"] ** -0.5 for r in rows]
    assert 1.3 < fitted_exponent(h, [r["error"] for r in rows]) < 2.0
    assert 0.8 < fitted_exponent([r["triangles"] for r in rows], [r["ms_median"] for r in rows]) < 1.2
