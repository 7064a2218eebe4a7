"""A kept factorization carried across a change of the matrix: extended to new unknowns after a cut
(:class:`ExtendedFactorization`), and, in the experiment docs/experiments/woodbury_probe.py (not in the package: it
did not pay), made exact again where a stiff penalty came or went. Both only precondition CG: the converged answers
are the direct solver's."""

import importlib.util
from pathlib import Path

import numpy as np
import pytest
import scipy.sparse as sp

from tissuefem.engine import linsolve
from tissuefem.engine.parameters import ParameterError

from helpers import Launcher

EXPERIMENT = Path(__file__).resolve().parents[2] / "docs" / "experiments" / "woodbury_probe.py"


@pytest.fixture(scope="module")
def woodbury():
    """The experiment's script as a module (its runs are not started)."""
    spec = importlib.util.spec_from_file_location("woodbury_probe", EXPERIMENT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _laplacian(n, shift=0.5):
    """A symmetric positive definite matrix (a 1D Laplacian plus a shift)."""
    return sp.diags([-np.ones(n - 1), (2.0 + shift) * np.ones(n), -np.ones(n - 1)], [-1, 0, 1]).tocsr()


def _split_chain(n, at):
    """The chain of :func:`_laplacian` cut between unknowns ``at`` and ``at + 1`` with unknown ``at`` doubled:
    the new matrix (``n + 1`` unknowns) and the parent of each new unknown."""
    A = _laplacian(n).tolil()
    B = sp.lil_matrix((n + 1, n + 1))
    parent = np.concatenate([np.arange(at + 1), [at], np.arange(at + 1, n)])
    for i in range(n + 1):
        B[i, i] = A[parent[i], parent[i]]
    for i in range(at):
        B[i, i + 1] = B[i + 1, i] = -1.0
    for i in range(at + 1, n):  # the copy (at + 1) is linked to the right side only
        B[i, i + 1] = B[i + 1, i] = -1.0
    return B.tocsr(), parent


def test_an_extension_without_copies_is_the_kept_factorization():
    A = _laplacian(30)
    factor = linsolve.SuperLU().factorize(A)
    extended = linsolve.ExtendedFactorization(factor, np.arange(30), 30, A)
    r = np.random.default_rng(1).normal(size=30)
    assert np.allclose(extended.solve(r), factor.solve(r), atol=1e-13)


def test_an_extension_after_a_cut_is_symmetric_positive_definite_and_cg_reaches_the_direct_answer():
    n = 40
    old = linsolve.SuperLU().factorize(_laplacian(n))
    B, parent = _split_chain(n, 19)
    extended = linsolve.ExtendedFactorization(old, parent, n, B)
    M = np.column_stack([extended.solve(e) for e in np.eye(n + 1)])
    assert np.allclose(M, M.T, atol=1e-12)
    assert np.linalg.eigvalsh(0.5 * (M + M.T)).min() > 0
    b = np.random.default_rng(2).normal(size=n + 1)
    result = linsolve.pcg(B, b, extended.solve, rtol=1e-12, max_iterations=100)
    assert result.converged
    assert np.allclose(result.x, sp.linalg.spsolve(B.tocsc(), b), rtol=1e-9, atol=1e-10)
    plain = linsolve.pcg(B, b, None, rtol=1e-12, max_iterations=200)
    assert result.iterations < plain.iterations / 3  # the old factorization still does most of the work


def test_an_extension_refuses_parents_out_of_range():
    A = _laplacian(5)
    factor = linsolve.SuperLU().factorize(A)
    with pytest.raises(ParameterError, match="parent"):
        linsolve.ExtendedFactorization(factor, np.array([0, 1, 2, 3, 7]), 5, A)


def _penalized(n, nodes, k):
    A = _laplacian(n).tolil()
    for q in nodes:
        A[q, q] += k
    return A.tocsr()


def test_a_low_rank_update_is_exact_where_only_a_few_diagonal_entries_changed(woodbury):
    n = 60
    A0 = _laplacian(n)
    kept = woodbury.UpdatedFactorization(linsolve.SuperLU().factorize(A0), A0, rank=8)
    A = _penalized(n, [10, 11, 12, 40], 1e3)  # a stiff penalty at four unknowns
    assert kept.update(A) == 4 and kept.updated == 4
    r = np.random.default_rng(3).normal(size=n)
    assert np.allclose(kept.solve(r), sp.linalg.spsolve(A.tocsc(), r), rtol=1e-10, atol=1e-12)
    # the columns are kept: the same change costs no more back-substitutions; a removed penalty is one too
    assert kept.update(A) == 0
    assert kept.update(A0) == 0 and kept.updated == 0
    A_off = _penalized(n, [10, 11], 1e3)
    assert kept.update(A_off) == 0 and kept.updated == 2
    assert np.allclose(kept.solve(r), sp.linalg.spsolve(A_off.tocsc(), r), rtol=1e-10, atol=1e-12)


def test_a_low_rank_update_keeps_to_its_rank_and_its_limit_and_skips_another_pattern(woodbury):
    n = 60
    A0 = _laplacian(n)
    kept = woodbury.UpdatedFactorization(linsolve.SuperLU().factorize(A0), A0, rank=3)
    A = _penalized(n, [5, 6, 7, 8, 9], 1e3)
    assert kept.update(A) == 3 and kept.updated == 3
    kept = woodbury.UpdatedFactorization(linsolve.SuperLU().factorize(A0), A0, rank=8)
    assert kept.update(A, limit=2) == 2 and kept.updated == 2
    wider = (A0 + sp.eye(n, k=5) + sp.eye(n, k=-5)).tocsr()
    assert kept.update(wider) == 0 and kept.updated == 0


def test_reuse_with_and_without_updates_hooked_in_converges_to_the_same_answers(woodbury):
    n = 80
    b = np.random.default_rng(4).normal(size=(4, n))
    answers, library = {}, (dict(vars(linsolve.ReusedFactorization)), linsolve.pcg)
    for rank in (0, 16):
        woodbury.COUNT["updates"] = 0
        with woodbury.updates(rank):
            solver = linsolve.ReusedFactorization()
            xs, iterations = [], 0
            for step, nodes in enumerate(([], [20, 21], [21, 22, 23], [50])):
                x, info = solver.solve(_penalized(n, nodes, 500.0) * (1.0 + 0.01 * step), b[step], rtol=1e-12)
                assert info.converged
                xs.append(x)
                iterations += info.iterations
        answers[rank] = (xs, iterations, woodbury.COUNT["updates"])
    for x0, x1 in zip(answers[0][0], answers[16][0]):
        assert np.allclose(x0, x1, rtol=1e-8, atol=1e-10)
    assert answers[16][1] < answers[0][1] and answers[16][2] > 0 == answers[0][2]
    assert (dict(vars(linsolve.ReusedFactorization)), linsolve.pcg) == library  # the library is restored


def test_a_provided_preconditioner_is_used_while_a_fresh_factorization_is_made_off_the_frame():
    n = 40
    old = linsolve.SuperLU().factorize(_laplacian(n))
    B, parent = _split_chain(n, 19)
    launch = Launcher()
    solver = linsolve.ReusedFactorization(launch=launch)
    solver.provide(linsolve.ExtendedFactorization(old, parent, n, B), B.shape)
    assert solver.provisional
    b = np.random.default_rng(5).normal(size=n + 1)
    x, info = solver.solve(B, b, rtol=1e-12)
    assert not info.factorized and info.converged and info.iterations > 0
    assert np.allclose(B @ x, b, atol=1e-9)
    assert len(launch.jobs) == 1 and solver.factorizations == 0  # the fresh one: started, not waited for
    launch.jobs[0].join()
    x, info = solver.solve(B, b, rtol=1e-12)
    assert not solver.provisional and solver.background_factorizations == 1 and info.iterations <= 1


def test_a_provided_preconditioner_that_cg_cannot_do_with_waits_for_the_fresh_one():
    n = 40
    B, parent = _split_chain(n, 19)
    launch = Launcher()
    solver = linsolve.ReusedFactorization(launch=launch, max_iterations=1)
    solver.provide(linsolve.ExtendedFactorization(linsolve.SuperLU().factorize(_laplacian(n)), parent, n, B),
                   B.shape)
    b = np.random.default_rng(6).normal(size=n + 1)
    x, info = solver.solve(B, b, rtol=1e-12)
    assert info.factorized and info.reason == "cg-failed" and solver.factorizations == 0
    assert solver.background_factorizations == 1 and not solver.provisional
    assert np.allclose(B @ x, b, atol=1e-9)


def test_a_linear_solver_carries_its_factorization_to_a_model_with_copied_dofs():
    n = 40
    old = linsolve.LinearSolver("reuse")
    mask = np.ones(n + 2, dtype=bool)
    mask[[0, n + 1]] = False  # two held dofs around the chain
    K_old = sp.block_diag([sp.eye(1), _laplacian(n), sp.eye(1)]).tocsr()
    A = old.matrix(lambda: K_old, mask)
    old.solve(A, np.ones(n))
    B, parent = _split_chain(n, 19)
    K_new = sp.block_diag([sp.eye(1), B, sp.eye(1)]).tocsr()
    new_parent = np.concatenate([[0], parent + 1, [n + 1]])
    new = linsolve.LinearSolver("reuse")
    assert new.carry(old, new_parent)
    new_mask = np.ones(n + 3, dtype=bool)
    new_mask[[0, n + 2]] = False
    A_new = new.matrix(lambda: K_new, new_mask)
    assert new.backend.provisional
    b = np.random.default_rng(7).normal(size=n + 1)
    x, info = new.solve(A_new, b, atol=1e-10 * np.linalg.norm(b))  # (Newton's inexact solve stops somewhere)
    assert info.factorizations == 0 and np.allclose(A_new @ x, b, atol=1e-8)
    new.close()
    assert not linsolve.LinearSolver("direct").carry(old, new_parent)  # nothing kept to carry into
    with pytest.raises(ParameterError, match="parent"):
        linsolve.LinearSolver("reuse").carry(old, np.full(n + 3, n + 5))


def test_a_linear_solver_carries_its_factorization_as_it_is_to_the_same_dofs():
    n = 30
    old = linsolve.LinearSolver("reuse")
    mask = np.ones(n, dtype=bool)
    A = old.matrix(lambda: _laplacian(n), mask)
    old.solve(A, np.ones(n))
    new = linsolve.LinearSolver("reuse")
    assert new.carry(old, np.arange(n))
    A_new = new.matrix(lambda: _penalized(n, [3], 10.0), mask)
    assert not new.backend.provisional
    x, info = new.solve(A_new, np.ones(n), atol=1e-10)
    assert info.factorizations == 0 and np.allclose(A_new @ x, np.ones(n), atol=1e-9)
