"""Chapters 3 and 4: rigid rotations, the kinematics helpers, the block, the cost-accuracy study, the figures.

No timing is asserted anywhere: times are measurements to read (they depend on
the machine and its load); the tests only check that they are recorded.
"""

import math

import matplotlib

matplotlib.use("Agg")

import numpy as np
import pytest
from helpers import assert_figure_deterministic
from skfem import Basis, ElementTriP1, ElementTriP2, ElementVector, asm

from tissuefem import (FormsAssembler, LinearElastic, NeoHookean, P1Assembler, QuadratureAssembler, energy_form,
                       rectangle, residual_form, solve, tangent_form)
from tissuefem.engine.materials import det2
from tissuefem.workbook import figures
from tissuefem.workbook.studies import (
    RECORDED_COST_ACCURACY,
    bending_gradient,
    bending_map,
    block_model,
    cost_accuracy_markdown,
    cost_accuracy_study,
    displacement_from_map,
    handle_force,
    rigid_rotation_response,
    rotated_block,
    rotation,
)

LINEAR = LinearElastic.from_young(1000.0, 0.3)
NEO = NeoHookean.from_young(1000.0, 0.3)
ANGLES = [1e-3, -1e-3, 0.3, -1.2, np.pi / 2, 2.5, np.pi, 4.0]


# --- chapter 3: rigid rotations ------------------------------------------------------

@pytest.mark.parametrize("theta", ANGLES)
def test_rigid_rotation_stresses_linear_elasticity_but_not_neo_hookean(theta):
    R = rotation(theta)
    assert np.allclose(R.T @ R, np.eye(2)) and np.isclose(np.linalg.det(R), 1.0)
    lam, mu = LINEAR.lam, LINEAR.mu
    # linear: eps = (cos - 1) I, so Psi = 2 (lam + mu)(1 - cos)^2 > 0 and P = 2 (lam + mu)(cos - 1) I != 0
    psi = float(LINEAR.energy(R))
    assert psi > 0.0
    assert psi == pytest.approx(2 * (lam + mu) * (1 - np.cos(theta)) ** 2, rel=1e-9)
    np.testing.assert_allclose(LINEAR.stress(R), 2 * (lam + mu) * (np.cos(theta) - 1) * np.eye(2), rtol=1e-9)
    assert np.abs(LINEAR.stress(R)).max() > 0.0
    # Neo-Hookean: F:F = 2 and J = 1 give Psi = 0 and P = mu R - mu R^-T = 0
    assert abs(float(NEO.energy(R))) <= 1e-10
    assert np.abs(NEO.stress(R)).max() <= 1e-10


def test_rigid_rotation_response_matches_the_materials():
    resp_lin = rigid_rotation_response(LINEAR, np.array(ANGLES))
    resp_neo = rigid_rotation_response(NEO, np.array(ANGLES))
    for k, theta in enumerate(ANGLES):
        P = LINEAR.stress(rotation(theta))
        assert resp_lin["energy"][k] == pytest.approx(float(LINEAR.energy(rotation(theta))))
        assert resp_lin["stress_norm"][k] == pytest.approx(np.sqrt(np.sum(P * P)))
    assert np.all(resp_lin["energy"] > 0) and np.all(resp_lin["stress_norm"] > 0)
    assert np.all(np.abs(resp_neo["energy"]) <= 1e-10) and np.all(resp_neo["stress_norm"] <= 1e-10)


def test_printed_energy_term_is_not_frame_indifferent():
    # erratum 3: F_ij F_ji = tr(F F) = 2 cos 2 theta for a rotation, F_ij F_ij = 2 always
    for theta in (0.3, np.pi / 2, 2.0):
        R = rotation(theta)
        assert np.einsum("ij,ji->", R, R) == pytest.approx(2 * np.cos(2 * theta))
        assert np.einsum("ij,ij->", R, R) == pytest.approx(2.0)


@pytest.mark.parametrize("theta", [np.pi / 3, -np.pi / 6])
def test_turned_block_grows_under_linear_elasticity_and_turns_rigidly_when_neo_hookean(theta):
    areas = {}
    for material in (NEO, LINEAR):
        problem, result = rotated_block(material, theta, n=6)
        assert result.converged
        fast = P1Assembler(problem.mesh)
        areas[material.name] = float(fast.areas @ det2(fast.deformation_gradient(result.u)))
        energy = problem.stored_energy(result.u)
        if material is NEO:
            assert abs(energy) <= 1e-10
            R = rotation(theta)
            pivot = np.array([[0.0], [0.5]])
            np.testing.assert_allclose(problem.deformed_positions(result.u),
                                       pivot + R @ (problem.mesh.p - pivot), atol=1e-9)
        else:
            assert energy > 1e-3
    assert areas[NEO.name] == pytest.approx(1.0, abs=1e-10)
    assert areas[LINEAR.name] > 1.01


# --- chapter 3: kinematics on a mesh and the errata ----------------------------------------

def test_bending_gradient_is_the_derivative_of_bending_map():
    rng = np.random.default_rng(2)
    X = rng.uniform([[0.0], [0.0]], [[2.0], [1.0]], (2, 20))
    h = 1e-6
    F = bending_gradient(X)
    for j in range(2):
        dX = np.zeros((2, 1))
        dX[j] = h
        np.testing.assert_allclose((bending_map(X + dX) - bending_map(X - dX)) / (2 * h), F[:, j], atol=1e-8)
    assert np.all(det2(F) > 0)


def test_mesh_deformation_gradient_is_exact_for_affine_maps_and_first_order_otherwise():
    A, c = np.array([[1.2, 0.4], [-0.1, 0.8]]), np.array([[0.3], [-0.2]])
    mesh = rectangle(2.0, 1.0, 6, 3)
    F = P1Assembler(mesh).deformation_gradient(displacement_from_map(mesh, lambda X: A @ X + c))
    np.testing.assert_allclose(F, np.broadcast_to(A[:, :, None], F.shape), atol=1e-12)
    errors = []
    for n in (8, 16, 32):
        mesh = rectangle(2.0, 1.0, 2 * n, n)
        F = P1Assembler(mesh).deformation_gradient(displacement_from_map(mesh, bending_map))
        errors.append(np.abs(F - bending_gradient(mesh.p[:, mesh.t].mean(axis=1))).max())
    ratios = np.array(errors[:-1]) / np.array(errors[1:])
    assert np.all((ratios > 1.8) & (ratios < 2.2)), ratios


def test_errata_5_and_6_on_the_linear_strain():
    def strain(F):
        return 0.5 * (F + F.T) - np.eye(2)

    W = np.array([[0.0, -0.2], [0.2, 0.0]])
    np.testing.assert_allclose(strain(W / 0.2), -np.eye(2))  # skew F: eps = -I, not 0
    np.testing.assert_allclose(strain(np.eye(2) + W), 0.0, atol=1e-15)  # skew F - I: eps = 0
    mesh = rectangle(1.0, 1.0, 2, 2)
    fast = P1Assembler(mesh, LINEAR)
    translation = displacement_from_map(mesh, lambda X: X + np.array([[0.7], [-0.3]]))
    collapse = displacement_from_map(mesh, lambda X: 0 * X + np.array([[0.7], [-0.3]]))
    F_t, F_c = fast.deformation_gradient(translation), fast.deformation_gradient(collapse)
    np.testing.assert_allclose(F_t, np.broadcast_to(np.eye(2)[:, :, None], F_t.shape), atol=1e-12)
    np.testing.assert_allclose(LINEAR.stress(F_t), 0.0, atol=1e-9)
    np.testing.assert_allclose(F_c, 0.0, atol=1e-12)  # grad u = -I
    np.testing.assert_allclose(LINEAR.stress(F_c[:, :, 0]), -2 * (LINEAR.lam + LINEAR.mu) * np.eye(2))


def test_displacement_from_map_rejects_a_bad_map():
    with pytest.raises(ValueError, match="phi"):
        displacement_from_map(rectangle(1.0, 1.0, 2, 2), lambda X: X[0])


# --- chapter 4: assembly, the block, handle forces -------------------------------------------

@pytest.mark.parametrize("element", [ElementTriP1(), ElementTriP2()], ids=["P1", "P2"])
def test_quadrature_assembler_matches_the_forms(element):
    mesh = rectangle(2.0, 1.0, 4, 2)
    basis = Basis(mesh, ElementVector(element), intorder=4)
    u = 0.01 * np.random.default_rng(0).standard_normal(basis.N)
    fast = QuadratureAssembler(basis, NEO)
    uh = basis.interpolate(u)
    assert fast.energy(u) == pytest.approx(asm(energy_form(NEO), basis, u=uh), rel=1e-12)
    np.testing.assert_allclose(fast.residual(u), asm(residual_form(NEO), basis, u=uh), atol=1e-10)
    np.testing.assert_allclose(fast.tangent(u).toarray(), asm(tangent_form(NEO), basis, u=uh).toarray(), atol=1e-8)


def test_quadrature_assembler_rejects_a_scalar_basis():
    with pytest.raises(ValueError, match="ElementVector"):
        QuadratureAssembler(Basis(rectangle(1.0, 1.0, 2, 2), ElementTriP1()), NEO)


def test_block_converges_quadratically_and_the_handles_balance():
    problem = block_model(n=8)
    result = solve(problem)
    assert result.converged and result.newton_iterations <= 4
    norms = result.steps[-1].residual_norms()
    # quadratic convergence: ||q_k+1|| / ||q_k||^2 stays bounded while the residual falls
    ratios = norms[1:] / norms[:-1] ** 2
    assert np.all(ratios[:2] < 1e-1), norms
    right, left = handle_force(problem, result.u, "right"), handle_force(problem, result.u, "left")
    np.testing.assert_allclose(right + left, 0.0, atol=1e-8 * np.abs(right).max())
    assert right[0] > 0 and right[1] > 0  # the handle pulls right and up
    with pytest.raises(ValueError, match="boundary"):
        handle_force(problem, result.u, "nowhere")


def test_p2_block_with_the_fast_path_equals_the_forms():
    a = block_model(n=2, order=2)
    b = block_model(n=2, order=2, assembly="forms")
    assert type(a.assembler) is QuadratureAssembler and type(b.assembler) is FormsAssembler
    ua, ub = solve(a, rtol=1e-12).u, solve(b, rtol=1e-12).u
    np.testing.assert_allclose(ua, ub, atol=1e-10)


# --- chapter 4: the cost-accuracy study --------------------------------------------------------

KEYS = {"order", "n", "h", "triangles", "dofs", "L2", "energy", "rate_L2", "newton_iterations",
        "solve_ms", "iteration_ms"}


def _check_rows(rows, p1_sizes, p2_sizes):
    assert [(r["order"], r["n"]) for r in rows] == [(1, n) for n in p1_sizes] + [(2, n) for n in p2_sizes]
    for r in rows:
        assert KEYS <= set(r), set(r) ^ KEYS
        assert r["h"] == pytest.approx(1.0 / r["n"])
        assert r["triangles"] == 4 * r["n"] ** 2  # 2n x n cells, two triangles each
        side = r["order"] * r["n"]
        assert r["dofs"] == 2 * (2 * side + 1) * (side + 1)
        assert 0 < r["L2"] < 1 and 0 < r["energy"] < 1
        assert r["newton_iterations"] >= 1
        assert r["solve_ms"] > 0 and r["iteration_ms"] > 0 and math.isfinite(r["solve_ms"])  # recorded, not judged
    for order in (1, 2):
        sel = [r for r in rows if r["order"] == order]
        assert math.isnan(sel[0]["rate_L2"])
        assert all(a["L2"] > b["L2"] for a, b in zip(sel, sel[1:])), "L2 errors must fall with refinement"
        assert all(a["energy"] > b["energy"] for a, b in zip(sel, sel[1:]))
        assert all(r["rate_L2"] > 1.0 for r in sel[1:])
    p1 = {r["n"]: r for r in rows if r["order"] == 1}
    for r in rows:
        if r["order"] == 2 and r["n"] in p1:
            assert r["L2"] < p1[r["n"]]["L2"], "P2 must beat P1 on the same mesh"


def test_cost_accuracy_study_on_a_tiny_sweep():
    rows = cost_accuracy_study(p1_sizes=(2, 4, 8), p2_sizes=(1, 2, 4), reference_size=16, repeats=1)
    _check_rows(rows, (2, 4, 8), (1, 2, 4))
    table = cost_accuracy_markdown(rows).splitlines()
    assert len(table) == 2 + len(rows) and "L2 error" in table[0] and "solve [ms]" in table[0]


def test_recorded_run_is_well_formed():
    _check_rows(RECORDED_COST_ACCURACY, (2, 4, 8, 16, 32), (1, 2, 4, 8, 16))


@pytest.mark.parametrize("kwargs, match", [
    (dict(p1_sizes=(2, 16), reference_size=16), "reference_size"),
    (dict(p1_sizes=(0,)), "p1_sizes"),
    (dict(p2_sizes=5), "p2_sizes"),
    (dict(repeats=0), "repeats"),
])
def test_cost_accuracy_study_rejects_bad_input(kwargs, match):
    with pytest.raises(ValueError, match=match):
        cost_accuracy_study(**kwargs)


# --- the figures of chapters 3 and 4 -------------------------------------------------------------

FIGURES_3_4 = ["fig02_kinematics", "fig_ch03_rotation_stress", "fig_ch04_block", "fig_ch04_cost_accuracy"]


@pytest.mark.parametrize("name", FIGURES_3_4)
def test_figure_renders_deterministically(tmp_path, name):
    assert_figure_deterministic(name, tmp_path)


def test_cost_accuracy_figure_takes_fresh_rows():
    rows = [dict(r, solve_ms=2 * r["solve_ms"]) for r in RECORDED_COST_ACCURACY]
    fig = figures.FIGURES["fig_ch04_cost_accuracy"](rows=rows)
    assert "this run" in fig._suptitle.get_text()
