"""Chapter 11 (tissue in 3D): chapter 6's hard cases and chapter 7's released flap on tetrahedra through the same
functions as on triangles, the twisted bar and the real-time drag, and the chapter's three figures (registered,
deterministic, the animation wide enough to project)."""

import math

import matplotlib

matplotlib.use("Agg")

import numpy as np
import pytest

from helpers import assert_figure_deterministic
from tissuefem import Handle, Model, StableNeoHookean
from tissuefem.workbook import figures
from tissuefem.workbook.hardcases import (block, cover_counts, crush_and_release, edge_matrices, element_jacobians,
                                          inversion_models, start_states)
from tissuefem.workbook.timestepping import released_flap
from tissuefem.workbook.tissue3d import drag_path, realtime_drag, twist_map, twisted_bar

CHAPTER_11 = ["fig_ch11_twist", "fig_ch11_crush_release", "fig_ch11_released_slab"]


# --- chapter 6's functions on tetrahedra ------------------------------------------------------------------------

def test_the_cube_and_its_start_states_have_the_jacobians_of_the_square():
    cube = block(2, dim=3)
    assert cube.t.shape == (4, 6 * 8) and cube.p.shape == (3, 27)
    states = start_states(cube)
    np.testing.assert_allclose(element_jacobians(cube, states["mirrored"]), -1.0)
    np.testing.assert_allclose(element_jacobians(cube, states["crushed past flat"]), -0.3)
    np.testing.assert_allclose(element_jacobians(cube, states["stretched 10x"]), 10.0)
    np.testing.assert_allclose(element_jacobians(cube, states["collapsed to a point"]), 0.0, atol=1e-15)
    np.testing.assert_allclose(element_jacobians(cube, states["collapsed to a line"]), 0.0, atol=1e-15)
    with pytest.raises(ValueError, match="dim"):
        block(2, dim=4)


def test_element_jacobians_are_det_F_of_the_model_on_tetrahedra():
    cube = block(2, dim=3)
    model = Model(cube, StableNeoHookean.from_young(1000.0, 0.3), handles=[Handle("bottom")])
    rng = np.random.default_rng(5)
    for x in [*start_states(cube).values(), cube.p + 0.2 * rng.standard_normal(cube.p.shape)]:
        u = model.zeros()
        u[model.basis.nodal_dofs] = x - cube.p
        np.testing.assert_allclose(element_jacobians(cube, x), model.jacobian(u), atol=1e-12)


def test_edge_matrices_give_F_as_Ds_Dm_inverse():
    cube = block(1, dim=3)
    A = np.array([[1.1, 0.2, -0.3], [0.0, 0.9, 0.4], [0.3, -0.1, 1.2]])
    Ds, Dm = edge_matrices(cube, A @ cube.p + 1.0), edge_matrices(cube, cube.p)
    for e in range(cube.t.shape[1]):
        np.testing.assert_allclose(Ds[:, :, e] @ np.linalg.inv(Dm[:, :, e]), A, atol=1e-13)


def test_cover_counts_on_tetrahedra_see_a_fold_and_not_a_mirror():
    cube = block(4, dim=3)
    X = cube.p
    np.testing.assert_array_equal(cover_counts(cube, X), 1)
    np.testing.assert_array_equal(cover_counts(cube, X * np.array([[1.0], [-1.0], [1.0]])), 1)
    # the right half folded back over the left one (and shrunk along x): each of its centroids lies in two
    # tetrahedra, its own and one of the left half's (a factor that puts no centroid on a face of the other half)
    folded = np.stack([np.where(X[0] <= 0.5, X[0], 0.5 - 0.7 * (X[0] - 0.5)), X[1], X[2]])
    right = cube.p[0, cube.t].mean(axis=0) > 0.5
    counts = cover_counts(cube, folded)
    np.testing.assert_array_equal(counts[right], 2)
    assert set(np.unique(counts[~right])) == {1, 2}


def test_the_crush_moves_the_top_face_down_on_tetrahedra():
    cube = block(2, dim=3)
    run = crush_and_release(inversion_models()["stable neo-Hookean"], cube, depth=0.6, steps=3)
    assert run["crushed"] == pytest.approx(0.6)
    top = np.isclose(cube.p[1], 1.0)
    for depth, x in zip((0.2, 0.4, 0.6), run["frames"][1:-1]):
        np.testing.assert_allclose(x[1, top], 1.0 - depth, atol=1e-12)
        np.testing.assert_allclose(x[[0, 2]][:, top], cube.p[[0, 2]][:, top], atol=1e-12)
    assert run["released"].converged and run["released"].rest_error < 1e-6


def test_the_released_slab_is_the_flap_with_a_depth():
    model, u0 = released_flap(nx=4, ny=2, nz=1)
    assert model.dim == 3 and model.mesh.t.shape[1] == 6 * 8
    right = np.isclose(model.mesh.p[0], 2.0)
    lifted = model.nodal_displacement(u0)[:, right]
    np.testing.assert_allclose(lifted, [[0.0], [0.5], [0.0]] * np.ones(lifted.shape), atol=1e-12)


# --- the twisted bar and the drag -------------------------------------------------------------------------------

def test_the_twist_map_turns_about_the_axis_and_pulls():
    phi = twist_map(math.pi / 2, 0.3, (0.5, 0.5))
    X = np.array([[2.0, 2.0], [1.0, 0.5], [0.5, 0.5]])
    np.testing.assert_allclose(phi(X), [[2.3, 2.3], [0.5, 0.5], [1.0, 0.5]], atol=1e-15)


def test_a_pure_twist_pushes_on_the_holders_and_grows_with_the_square_of_the_angle():
    """Chapter 11: the Poynting effect, "the bar pushes on its holders", the force about quadratic in the angle."""
    run = twisted_bar(angle=60.0, stretch=0.0, steps=2, cells=(6, 2, 2))
    assert run.converged
    first, last = run.axial_force
    assert last < first < 0
    assert 3.0 < last / first < 5.0  # twice the angle, four times the force (second order)


def test_no_turn_and_no_pull_leave_the_bar_at_rest():
    run = twisted_bar(angle=0.0, stretch=0.0, steps=1, cells=(4, 1, 1))
    assert run.converged and np.abs(run.u).max() < 1e-12


def test_the_drag_converges_and_moves_the_grabbed_nodes_along_the_path():
    run = realtime_drag(frames=6, budget=math.inf)
    assert all(r.converged for r in run["reports"])
    model, grab = run["model"], run["grab"]
    moved = run["positions"][-1][:, grab] - model.X[:, grab]
    np.testing.assert_allclose(moved, np.array(drag_path(6 / 30))[:, None] * np.ones(moved.shape), atol=1e-12)


# --- the figures ----------------------------------------------------------------------------------------------

def test_the_chapter_11_figures_are_registered_in_the_chapters_order():
    names = [n for n in figures.FIGURES if n in CHAPTER_11]
    assert names == CHAPTER_11


@pytest.mark.parametrize("name", CHAPTER_11)
def test_chapter_11_figure_is_deterministic(name, tmp_path):
    assert_figure_deterministic(name, tmp_path)
    if name == "fig_ch11_released_slab":
        from PIL import Image

        from tissuefem.workbook.figures.base import ANIMATION_MIN_WIDTH
        from tissuefem.workbook.figures.tissue3d import SLAB_FRAMES

        gifs = [tmp_path / d / f"{name}.gif" for d in "ab"]
        data = gifs[0].read_bytes()
        assert data[:6] == b"GIF89a"
        assert not gifs[1].exists() or data == gifs[1].read_bytes()
        with Image.open(gifs[0]) as im:
            assert im.n_frames == SLAB_FRAMES
            assert im.size[0] >= ANIMATION_MIN_WIDTH
        assert len(data) < 1_500_000


def test_the_cube_pushed_past_flat_both_inverts_and_folds():
    """Chapter 11, section 3: "A cube pushed past flat has both at once where the square of chapter 6b only
    folded": the stable model's cube at the full depth has tetrahedra with J <= 0 and centroids covered twice."""
    from tissuefem.workbook.figures.tissue3d import cube

    mesh = cube()
    run = crush_and_release(inversion_models()["stable neo-Hookean"], mesh)
    assert run["crushed"] == pytest.approx(1.3)
    deepest = run["frames"][-2]
    assert (element_jacobians(mesh, deepest) <= 1e-12).sum() > 0
    assert (cover_counts(mesh, deepest) > 1).sum() > 0


def test_the_probe_presses_the_3d_block_and_is_pushed_back():
    """The ball of :func:`probe_and_drag` (unhurried: a fake clock): every frame converges, the ball touches only
    once pressed, is pushed up while it presses, and leaves a penetration far below its radius."""
    from tissuefem.workbook.tissue3d import probe_and_drag

    run = probe_and_drag(frames=9, budget=10.0, clock=lambda: 0.0)
    rows = run["rows"]
    assert all(r["converged"] for r in rows)
    assert rows[0]["penetration"] == 0.0 and np.all(rows[0]["force"] == 0.0)  # the ball has not reached the top yet
    pressing = [r for r in rows if r["penetration"] > 0]
    assert pressing and all(r["force"][1] > 0 for r in pressing)
    assert max(r["penetration"] for r in rows) < 0.05 * run["simulation"].model.probes[0].radius
    assert run["simulation"].model.dim == 3
