"""The linear solvers added for 3D: rigid-body modes, CHOLMOD and smoothed-aggregation multigrid (both optional:
skipped, saying why, where their package is missing), kept and refreshed in the background by name, and the
real-time solver's default by dimension."""

import numpy as np
import pytest
import scipy.sparse as sp

from tissuefem.engine import linsolve
from tissuefem.engine.materials import NeoHookean
from tissuefem.engine.meshes import box, rectangle
from tissuefem.engine.model import Handle, Model
from tissuefem.engine.realtime import RealtimeSolver, default_linear_solver

needs_cholmod = pytest.mark.skipif(not linsolve.available("cholmod"), reason="needs the optional scikit-sparse")
needs_amg = pytest.mark.skipif(not linsolve.available("cg-amg"), reason="needs the optional pyamg")


def block_system(seed=0):
    """The condensed backward-Euler matrix of a small block (left face held) and a right-hand side."""
    model = Model(box(2.0, 1.0, 1.0, 4, 2, 2), NeoHookean.from_young(1000.0, 0.3), dt=1 / 30,
                  handles=[Handle("left")])
    fixed, _ = model.prescribed()
    free = np.ones(model.n_dofs, dtype=bool)
    free[fixed] = False
    A = sp.csr_matrix(model.hessian(model.zeros()))[free][:, free]
    return model, free, A, np.random.default_rng(seed).normal(size=A.shape[0])


@pytest.mark.parametrize("mesh", [rectangle(2.0, 1.0, 4, 2), box(1.0, 1.0, 1.0, 2, 2, 2)], ids=["2d", "3d"])
def test_rigid_body_modes_cost_no_elastic_energy(mesh):
    model = Model(mesh, NeoHookean.from_young(1000.0, 0.3))
    modes = linsolve.rigid_body_modes(model.X)
    d = model.X.shape[0]
    assert modes.shape == (model.n_dofs, 3 if d == 2 else 6)
    K = model.hessian(model.zeros())
    assert np.max(np.abs(K @ modes)) < 1e-9 * abs(K).max()
    assert np.linalg.matrix_rank(modes) == modes.shape[1]
    with pytest.raises(ValueError, match="X"):
        linsolve.rigid_body_modes(np.zeros((4, 5)))


def test_reuse_background_takes_any_backend_by_name():
    solver = linsolve.LinearSolver("reuse-background-superlu-colamd")
    assert solver.backend.background and solver.factorizing.ordering == "COLAMD"
    assert linsolve.LinearSolver("reuse-background").factorizing.name == "superlu"
    with pytest.raises(ValueError, match="unknown linear solver"):
        linsolve.LinearSolver("reuse-background-magic")


def test_optional_backends_say_how_to_get_them(monkeypatch):
    monkeypatch.setattr(linsolve, "available", lambda name: False)
    with pytest.raises(ValueError, match="scikit-sparse|sksparse"):
        linsolve.Cholmod()
    with pytest.raises(ValueError, match="pyamg"):
        linsolve.PreconditionedCG("amg")


@needs_cholmod
def test_cholmod_solves_and_stores_its_fill():
    _, _, A, b = block_system()
    factor = linsolve.Cholmod().factorize(A)
    x = factor.solve(b)
    assert np.linalg.norm(A @ x - b) <= 1e-10 * np.linalg.norm(b)
    assert factor.nnz >= (A.nnz + A.shape[0]) // 2  # at least the lower triangle
    indefinite = sp.csr_matrix(np.array([[0.0, 1.0], [1.0, 0.0]]))  # not positive definite: SuperLU instead
    np.testing.assert_allclose(linsolve.Cholmod().factorize(indefinite).solve(np.array([1.0, 2.0])), [2.0, 1.0])


@needs_amg
def test_multigrid_with_rigid_modes_preconditions_cg():
    model, free, A, b = block_system()
    plain = linsolve.pcg(A, b, rtol=1e-8, max_iterations=5000).iterations
    backend = linsolve.PreconditionedCG("amg", near_nullspace=linsolve.rigid_body_modes(model.X)[free])
    factor = backend.factorize(A)
    result = linsolve.pcg(A, b, factor.precondition, rtol=1e-8)
    assert result.converged and result.iterations < plain
    assert factor.nnz >= A.nnz
    with pytest.raises(ValueError, match="near_nullspace"):
        linsolve.PreconditionedCG("amg", near_nullspace=np.ones((3, 6))).factorize(A)


@needs_amg
def test_realtime_solver_gives_multigrid_the_rigid_modes_and_converges():
    model = Model(box(2.0, 1.0, 1.0, 4, 2, 2), NeoHookean.from_young(1000.0, 0.3), dt=1 / 30,
                  handles=[Handle("left"), Handle("right", (0.0, 0.0, 0.0), name="grab")])
    solver = RealtimeSolver(model, linear_solver="reuse-background-cg-amg", budget=1e9)
    for f in range(3):
        assert solver.step({"grab": (0.05 * (f + 1), 0.02, 0.0)}).converged
    assert solver.linear.factorizing.near_nullspace.shape == (int(np.count_nonzero(
        ~np.isin(np.arange(model.n_dofs), model.prescribed()[0]))), 6)
    solver.linear.close()


def test_the_realtime_default_by_dimension():
    material = NeoHookean.from_young(1000.0, 0.3)
    flat = Model(rectangle(2.0, 1.0, 4, 2), material, dt=1 / 30)
    solid = Model(box(1.0, 1.0, 1.0, 2, 2, 2), material, dt=1 / 30)
    assert default_linear_solver(flat) == "reuse"
    assert RealtimeSolver(flat).linear.method == "reuse"
    assert RealtimeSolver(solid).linear.method == default_linear_solver(solid)
