"""Chapter 5 (anisotropic fibers): the along/across stiffness, the fiber field, the figures.

The headline number of the chapter: pulling a block along its fibers is
stiffer than pulling it across them by exactly the fiber modulus k in the
small-strain limit (the fiber adds k to C_ffff and nothing else).
"""


import matplotlib

matplotlib.use("Agg")

import numpy as np
import pytest
from helpers import assert_figure_deterministic

from tissuefem.workbook import fibers
from tissuefem import TISSUE_E, TISSUE_NU, FiberReinforced, LinearElastic, NeoHookean, StableNeoHookean
from tissuefem.engine import materials
from tissuefem.engine.meshes import fusiform_fiber_direction, fusiform_fiber_field, fusiform_muscle

CHAPTER_FIGURES = ["fig03_fiber_field", "fig_ch05_along_vs_across", "fig_ch05_muscle_pull"]


# --- the headline: along minus across = k ------------------------------------------------

@pytest.mark.parametrize("k", [500.0, fibers.K_FIBER, 20000.0])
def test_along_minus_across_small_strain_stiffness_is_the_fiber_modulus(k):
    eps = 1e-4
    r = fibers.along_vs_across(eps, stiffness=k)
    # predicted: the fiber adds k cos^4(theta) to the confined modulus; cos^4 0 - cos^4 90 = 1
    assert r.predicted_difference == pytest.approx(k)
    assert r.difference == pytest.approx(k, rel=1e-3)
    assert r.relative_error < 1e-3
    # and the finite-strain correction is the one derived in the chapter, (1 + eps)(1 + eps/2)
    assert r.difference == pytest.approx(k * (1 + eps) * (1 + eps / 2), rel=1e-9)
    # each modulus separately: lam + 2 mu (+ k along)
    base = NeoHookean.from_young(TISSUE_E, TISSUE_NU)
    assert r.modulus_across == pytest.approx(base.lam + 2 * base.mu, rel=1e-3)
    assert r.modulus_along == pytest.approx(base.lam + 2 * base.mu + k, rel=1e-3)


@pytest.mark.parametrize("base", [LinearElastic(300.0, 200.0), StableNeoHookean(300.0, 200.0)],
                         ids=["linear", "stable-neo-hookean"])
def test_along_minus_across_does_not_depend_on_the_matrix(base):
    r = fibers.along_vs_across(1e-4, stiffness=800.0, base=base)
    assert r.difference == pytest.approx(800.0, rel=1e-3)


@pytest.mark.parametrize("angle", [0.0, 30.0, 45.0, 60.0, 75.0, 90.0])
def test_confined_modulus_follows_k_cos4(angle):
    eps = 1e-4
    measured = fibers.confined_pull(angle, eps).nominal_stress[0] / eps
    base = NeoHookean.from_young(TISSUE_E, TISSUE_NU)
    predicted = base.lam + 2 * base.mu + fibers.K_FIBER * np.cos(np.deg2rad(angle)) ** 4
    assert fibers.predicted_confined_modulus(angle) == pytest.approx(predicted)
    assert measured == pytest.approx(predicted, rel=1e-3)


def test_larger_strain_along_is_stiffer_than_across():
    r = fibers.along_vs_across(0.2)
    assert r.modulus_along > 2.0 * r.modulus_across
    assert r.difference == pytest.approx(r.exact_difference, rel=1e-9)
    # the tensile test (clamped ends, free sides): along > 45 degrees > across at every stretch
    stretches = [1.05, 1.15, 1.3]
    along, diagonal, across, iso = (fibers.block_pull(a, stretches).forces for a in (0.0, 45.0, 90.0, None))
    assert np.all(along > 3.0 * across)
    assert np.all(along > diagonal) and np.all(diagonal > across)
    # fibers across still stiffen a little: they resist the strip's lateral contraction
    assert np.all(across > iso)


def test_the_muscle_with_fibers_needs_more_force():
    stretches = [1.05, 1.1]
    with_fibers = fibers.muscle_pull(stretches)
    without = fibers.muscle_pull(stretches, with_fibers=False)
    assert np.all(with_fibers.forces > 2.0 * without.forces)
    assert np.all(np.diff(with_fibers.forces) > 0)
    assert with_fibers.edge_length == pytest.approx(0.25)


# --- the fiber term on its own agrees with the material --------------------------------------

def test_fiber_functions_are_the_fiber_part_of_fiber_reinforced():
    rng = np.random.default_rng(5)
    F = np.eye(2)[:, :, None, None] + 0.3 * rng.standard_normal((2, 2, 6, 3))
    angles = rng.uniform(0, np.pi, (6, 3))
    g = np.stack([np.cos(angles), np.sin(angles)])
    base = NeoHookean(400.0, 300.0)
    m = FiberReinforced(base, 250.0, g)
    np.testing.assert_allclose(materials.fiber_energy(F, g, 250.0), m.energy(F) - base.energy(F), rtol=1e-12,
                               atol=1e-9)
    np.testing.assert_allclose(materials.fiber_stress(F, g, 250.0), m.stress(F) - base.stress(F), rtol=1e-12,
                               atol=1e-9)
    np.testing.assert_allclose(materials.fiber_tangent(F, g, 250.0), m.tangent(F) - base.tangent(F), rtol=1e-12,
                               atol=1e-9)
    # a single F gives a float and a 2x2 matrix
    assert isinstance(materials.fiber_invariant(np.eye(2), [1.0, 0.0]), float)
    assert materials.fiber_stress(np.eye(2), [1.0, 0.0], 1.0).shape == (2, 2)


def test_bad_input_is_rejected_with_the_argument_named():
    with pytest.raises(ValueError, match="g must be unit"):
        materials.fiber_invariant(np.eye(2), [2.0, 0.0])
    with pytest.raises(ValueError, match="F must be shaped"):
        materials.fiber_stress(np.eye(4), [1.0, 0.0], 1.0)  # 2x2 and 3x3 are valid
    with pytest.raises(ValueError, match="k \\(fiber modulus\\)"):
        materials.fiber_stress(np.eye(2), [1.0, 0.0], -1.0)
    with pytest.raises(ValueError, match="angle_deg"):
        fibers.fiber_direction("north")
    with pytest.raises(ValueError, match="strain"):
        fibers.along_vs_across(0.0)
    with pytest.raises(ValueError, match="stretches"):
        fibers.block_pull(0.0, [])


# --- the fiber field on the fusiform muscle ----------------------------------------------------

def _long_axis(points):
    """Principal direction of a point cloud (largest singular vector of the centred coordinates)."""
    centred = points - points.mean(axis=1, keepdims=True)
    u, _, _ = np.linalg.svd(centred, full_matrices=False)
    return u[:, 0]


def test_fiber_field_is_unit_and_follows_the_long_axis_on_the_midline():
    mesh = fusiform_muscle(nx=40, ny=8)
    g = fusiform_fiber_field(mesh)
    assert g.shape == (2, mesh.t.shape[1])
    np.testing.assert_allclose(np.hypot(g[0], g[1]), 1.0, atol=1e-14)
    axis = _long_axis(mesh.p)
    assert abs(axis[0]) > 1 - 1e-12  # the muscle's long axis is X1
    # on the midline the fiber direction is the long axis, exactly
    X = np.linspace(0.0, 4.0, 41)
    on_midline = fusiform_fiber_direction(np.stack([X, np.zeros_like(X)]))
    np.testing.assert_allclose(np.abs(on_midline.T @ axis), 1.0, atol=1e-14)
    # the elements along the midline (a vertex on y = 0) follow it to within the field's spread
    touching = np.isclose(mesh.p[1, mesh.t], 0.0).any(axis=0)
    cosines = np.abs(g[:, touching].T @ axis)
    assert touching.sum() >= 2 * 40
    assert cosines.min() > np.cos(np.deg2rad(3.0))
    # away from the midline they fan out: the field is not uniform
    assert np.abs(g.T @ axis).min() < np.cos(np.deg2rad(10.0))
    # mirror symmetry about the long axis: reflected centroids carry reflected fibers
    c = mesh.p[:, mesh.t].mean(axis=1)
    mirrored = fusiform_fiber_direction(np.stack([c[0], -c[1]]))
    np.testing.assert_allclose(mirrored, g * np.array([[1.0], [-1.0]]), atol=1e-14)


def test_fiber_field_refines_towards_the_long_axis():
    # elements next to the midline get closer to it as the mesh is refined across
    worst = []
    for ny in (4, 8, 16):
        mesh = fusiform_muscle(nx=40, ny=ny)
        g = fusiform_fiber_field(mesh)
        touching = np.isclose(mesh.p[1, mesh.t], 0.0).any(axis=0)
        worst.append(np.abs(g[1, touching]).max())
    assert worst[0] > worst[1] > worst[2]


# --- figures -----------------------------------------------------------------------------------

@pytest.mark.parametrize("name", CHAPTER_FIGURES)
def test_chapter_figures_are_registered_and_deterministic(tmp_path, name):
    assert_figure_deterministic(name, tmp_path)
