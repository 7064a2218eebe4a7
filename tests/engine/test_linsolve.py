"""Linear solver backends: one interface, same answers; the reused factorization and its refresh rules."""

import numpy as np
import pytest
import scipy.sparse as sp

from tissuefem.engine import linsolve
from tissuefem.engine.assembly import P1Assembler
from tissuefem.engine.materials import NeoHookean
from tissuefem.engine.meshes import flap


def system(n_triangles=300, stretch=0.0, seed=0):
    """A condensed backward-Euler matrix M/dt^2-like + K of a flap (left edge fixed) and a right-hand side."""
    mesh = flap(n_triangles=n_triangles)
    asm = P1Assembler(mesh, NeoHookean.from_young(1000.0, 0.3))
    u = np.zeros(asm.n_dofs)
    u[0::2] = stretch * mesh.p[0]
    K = asm.tangent(u)
    left = np.flatnonzero(mesh.p[0] < 1e-12)
    fixed = np.concatenate([2 * left, 2 * left + 1])
    free = np.setdiff1d(np.arange(asm.n_dofs), fixed)
    A = (K / 900.0 + 1e-3 * sp.identity(asm.n_dofs))[free][:, free].tocsr()
    b = np.random.default_rng(seed).normal(size=A.shape[0])
    return A, b


@pytest.mark.parametrize("name", ["superlu", "superlu-colamd"] + (["pardiso"] if linsolve.available("pardiso") else []))
def test_direct_backends_solve_the_system(name):
    A, b = system()
    backend = linsolve.make(name)
    x = backend(A, b)
    assert np.linalg.norm(A @ x - b) <= 1e-10 * np.linalg.norm(b)
    factor = backend.factorize(A)
    np.testing.assert_allclose(factor.solve(b), x, rtol=1e-9, atol=1e-12)
    assert backend.name == name


def test_orderings_agree():
    A, b = system()
    x1 = linsolve.SuperLU("MMD_AT_PLUS_A")(A, b)
    x2 = linsolve.SuperLU("COLAMD")(A, b)
    np.testing.assert_allclose(x1, x2, rtol=1e-9, atol=1e-12)


def test_symmetric_mode_falls_back_to_pivoting_on_a_zero_diagonal():
    A = sp.csr_matrix(np.array([[0.0, 1.0], [1.0, 0.0]]))
    x = linsolve.SuperLU()(A, np.array([1.0, 2.0]))
    np.testing.assert_allclose(x, [2.0, 1.0])


def test_refactorizations_of_one_pattern_keep_its_ordering_and_match_a_fresh_factorization():
    """The second and later factorizations of one sparsity pattern reuse the first one's ordering (SuperLU then
    orders nothing: the work that holds the interpreter's lock); the answers and the fill are a fresh one's, and the
    caller's matrix is not touched."""
    backend = linsolve.SuperLU()
    A0, b = system(stretch=0.1)
    for i, shift in enumerate((0.0, 1e-2, 1.0, 0.0)):  # one pattern (the diagonal is stored), other values
        A = (A0 + shift * sp.diags(np.linspace(1.0, 2.0, A0.shape[0]))).tocsr()
        before = (A.data.copy(), A.indices.copy(), A.indptr.copy())
        kept, fresh = backend.factorize(A), linsolve.SuperLU().factorize(A)
        np.testing.assert_allclose(kept.solve(b), fresh.solve(b), rtol=1e-10, atol=1e-13)
        assert kept.nnz == fresh.nnz
        assert (kept._order is not None) == (i > 0)  # made in the kept ordering, and no fallback to pivoting
        for array, copy in zip((A.data, A.indices, A.indptr), before):
            np.testing.assert_array_equal(array, copy)
    ordering = backend._kept
    assert ordering is not None and ordering.matches(sp.csc_matrix(A))
    B, c = system(n_triangles=200)  # another pattern: a new ordering
    np.testing.assert_allclose(B @ backend.factorize(B).solve(c), c, rtol=0, atol=1e-10 * np.linalg.norm(c))
    assert backend._kept is not ordering


def test_bad_input_is_rejected():
    A, b = system()
    with pytest.raises(ValueError, match="ordering"):
        linsolve.SuperLU("AMD")
    with pytest.raises(ValueError, match="unknown linear solver"):
        linsolve.make("magic")
    with pytest.raises(ValueError, match="shape"):
        linsolve.SuperLU()(A, b[:-1])
    with pytest.raises(ValueError, match="non-finite"):
        linsolve.SuperLU()(A, np.full_like(b, np.nan))
    with pytest.raises(ValueError, match="square"):
        linsolve.SuperLU()(sp.csr_matrix(np.ones((2, 3))), np.ones(2))
    with pytest.raises(ValueError, match="refresh_after"):
        linsolve.ReusedFactorization(refresh_after=0)


def test_pardiso_says_how_to_get_it_when_missing(monkeypatch):
    monkeypatch.setattr(linsolve, "available", lambda name: False)
    with pytest.raises(ValueError, match="pypardiso"):
        linsolve.Pardiso()
    assert linsolve.make("auto").name == "superlu"


def test_pcg_solves_spd_systems_and_detects_negative_curvature():
    A, b = system()
    result = linsolve.pcg(A, b, rtol=1e-10, max_iterations=2000)
    assert result.converged and np.linalg.norm(A @ result.x - b) <= 1e-9 * np.linalg.norm(b)
    lu = linsolve.SuperLU().factorize(A)
    preconditioned = linsolve.pcg(A, b, lu.solve, rtol=1e-10)
    assert preconditioned.converged and preconditioned.iterations <= 2
    indefinite = sp.diags([1.0, -1.0, 2.0]).tocsr()
    out = linsolve.pcg(indefinite, np.array([1.0, 1.0, 1.0]), rtol=1e-12)
    assert out.negative_curvature and not out.converged


def test_pcg_asks_before_every_iteration_but_the_first_whether_another_fits():
    A, b = system()
    asked = []

    def another():  # a deadline that has room for three iterations
        asked.append(len(asked))
        return len(asked) < 3

    out = linsolve.pcg(A, b, rtol=1e-12, max_iterations=100, another=another)
    assert out.iterations == 3 and not out.converged and len(asked) == 3
    full = linsolve.pcg(A, b, rtol=1e-12, max_iterations=3)
    np.testing.assert_array_equal(out.x, full.x)  # the same iterate as three iterations asked for
    assert linsolve.pcg(A, b, rtol=1e-12, max_iterations=100, another=lambda: False).iterations == 1


def test_a_solve_cut_short_by_its_deadline_overruns_by_one_cg_iteration_at_most():
    """CG iterations slower than learned (as beside a factorization on the second core) stop at the deadline."""
    A, b = system(stretch=0.3)
    now = [0.0]
    solver = linsolve.ReusedFactorization(max_iterations=40)
    solver.solve(system()[0], b)  # a factorization of the unstretched matrix: CG needs many iterations now
    precondition = solver._factor.solve  # SuperLU's factor: CG applies its solve

    def slow(r):  # each iteration takes 3 ms where 1 ms was learned
        now[0] += 0.003
        return precondition(r)

    solver._factor = type("Slow", (), {"solve": staticmethod(slow)})()
    deadline = linsolve.Deadline(lambda: now[0], 0.02, {"cg-iteration": 0.001, "factorization": 1.0})
    x, info = solver.solve(A, b, rtol=1e-14, deadline=deadline)
    assert not info.converged and 0 < info.iterations < 20  # learned: 20 would fit
    assert now[0] <= 0.02 + 0.003 + 1e-12


def test_reused_factorization_uses_cg_on_a_nearby_matrix_and_refreshes_when_slow():
    A0, b = system(stretch=0.0)
    A1, _ = system(stretch=0.02)  # the tangent a little later
    A2, _ = system(stretch=0.4)  # much later
    solver = linsolve.ReusedFactorization(refresh_after=3, max_iterations=40)
    x, info = solver.solve(A0, b, rtol=1e-10)
    assert info.factorized and info.reason == "first"
    x, info = solver.solve(A1, b, rtol=1e-10)
    assert not info.factorized and 0 < info.iterations <= 40
    assert np.linalg.norm(A1 @ x - b) <= 1e-9 * np.linalg.norm(b)
    x, info = solver.solve(A2, b, rtol=1e-10)
    assert np.linalg.norm(A2 @ x - b) <= 1e-9 * np.linalg.norm(b)
    if not info.factorized:
        assert info.iterations > 3  # slow: the next solve refreshes
        x, info = solver.solve(A2, b, rtol=1e-10)
        assert info.factorized and info.reason == "stale"
    assert solver.factorizations == 2
    # a new set of unknowns: a different shape refactorizes
    A3, b3 = system(n_triangles=150)
    x, info = solver.solve(A3, b3)
    assert info.factorized and info.reason == "shape"
    assert solver(A3, b3).shape == b3.shape


def test_reused_factorization_refactorizes_on_negative_curvature():
    A0 = sp.diags([1.0, 2.0, 3.0]).tocsr()
    solver = linsolve.ReusedFactorization()
    solver.solve(A0, np.ones(3))
    indefinite = sp.diags([1.0, -2.0, 3.0]).tocsr()
    x, info = solver.solve(indefinite, np.ones(3))
    assert info.factorized and info.reason == "negative-curvature"
    np.testing.assert_allclose(indefinite @ x, np.ones(3))
