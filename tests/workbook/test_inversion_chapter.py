"""Chapter 6 (inversion): the drawing helpers and the two figures of the chapter.

The hard-case behaviour itself (which model recovers from what) is the
library's business and is tested with it; here: the element Jacobians the
figures colour by, the crush frames they pick, and that both figures are
registered and deterministic.
"""


import matplotlib

matplotlib.use("Agg")

import numpy as np
import pytest
from helpers import assert_figure_deterministic
from matplotlib.figure import Figure

from tissuefem.workbook.figures.inversion import CRUSH_COLUMNS, draw_state, frame_depths
from tissuefem.workbook.hardcases import block, cover_counts, element_jacobians, start_states
from tissuefem.engine.materials import StableNeoHookean
from tissuefem.engine.meshes import rectangle
from tissuefem import Handle, Model

CHAPTER_FIGURES = ["fig06_crush_release", "fig_ch06_itf_energy"]


def test_element_jacobians_are_det_F_of_the_assembler():
    mesh = block(4)
    problem = Model(mesh, StableNeoHookean.from_young(1000.0, 0.3), handles=[Handle("bottom")])
    rng = np.random.default_rng(3)
    for x in [*start_states(mesh).values(), mesh.p + 0.2 * rng.standard_normal(mesh.p.shape)]:
        u = problem.basis.zeros()
        u[problem.basis.nodal_dofs] = x - mesh.p
        F = problem.assembler.deformation_gradient(u).reshape(2, 2, -1)
        det = F[0, 0] * F[1, 1] - F[0, 1] * F[1, 0]
        np.testing.assert_allclose(element_jacobians(mesh, x), det, atol=1e-12)


def test_start_states_have_the_jacobians_the_chapter_quotes():
    mesh = block()
    states = start_states(mesh)
    np.testing.assert_allclose(element_jacobians(mesh, states["mirrored"]), -1.0)
    np.testing.assert_allclose(element_jacobians(mesh, states["collapsed to a point"]), 0.0, atol=1e-15)
    np.testing.assert_allclose(element_jacobians(mesh, states["crushed past flat"]), -0.3)
    np.testing.assert_allclose(element_jacobians(mesh, states["stretched 10x"]), 10.0)


def test_cover_counts_see_folds_that_element_jacobians_cannot():
    mesh = block(8)
    X = mesh.p
    np.testing.assert_array_equal(cover_counts(mesh, X), 1)
    # one-to-one although every element is inverted: a mirror image
    np.testing.assert_array_equal(cover_counts(mesh, np.stack([X[0], -X[1]])), 1)
    # the notes' Figure 5 map along X0: each point of the strip is reached twice
    np.testing.assert_array_equal(cover_counts(mesh, np.stack([np.sin(2 * np.pi * X[0]), X[1]])), 2)
    # a fold with every J > 0: a strip wound one and a half times around a ring
    ring = rectangle(1.0, 1.0, 24, 2)
    angle, radius = 3 * np.pi * ring.p[0], 1.2 - 0.2 * ring.p[1]  # (angle, radius) keeps J > 0
    wound = np.stack([radius * np.cos(angle), radius * np.sin(angle)])
    assert np.all(element_jacobians(ring, wound) > 0)
    assert cover_counts(ring, wound).max() == 2
    # flat triangles contain nothing
    np.testing.assert_array_equal(cover_counts(mesh, start_states(mesh)["collapsed to a line"]), 0)


def test_draw_state_counts_inverted_and_flat_triangles():
    mesh = block(3)
    ax = Figure().subplots()
    assert draw_state(ax, mesh, mesh.p) == 0
    assert draw_state(ax, mesh, start_states(mesh)["mirrored"]) == mesh.t.shape[1]
    assert draw_state(ax, mesh, start_states(mesh)["collapsed to a line"]) == mesh.t.shape[1]


def test_frame_depths_read_the_top_edge():
    mesh = block()
    frames = [np.stack([mesh.p[0], (1.0 - d) * mesh.p[1]]) for d in (0.0, 0.5, 1.3)] + [mesh.p]
    np.testing.assert_allclose(frame_depths(mesh, frames), [0.0, 0.5, 1.3], atol=1e-15)
    assert CRUSH_COLUMNS[0] == 0.0 and 1.0 in CRUSH_COLUMNS


@pytest.mark.parametrize("name", CHAPTER_FIGURES)
def test_chapter_figures_are_registered_and_deterministic(tmp_path, name):
    assert_figure_deterministic(name, tmp_path)
