"""A background refactorization is never abandoned half-way: ``close()``, leaving a ``with`` block, dropping the
solver and the interpreter's exit all wait for it (a process ending under one can crash in the BLAS)."""

import gc
import subprocess
import sys
import textwrap
import threading
import time

import numpy as np
import scipy.sparse as sp

from tissuefem.engine import linsolve


def _system(n=40):
    """A small symmetric positive definite matrix (a 1D Laplacian plus a shift) and a right-hand side."""
    A = sp.diags([-np.ones(n - 1), 2.5 * np.ones(n), -np.ones(n - 1)], [-1, 0, 1]).tocsr()
    return A, np.random.default_rng(0).normal(size=n)


class _SlowDirect:
    """A direct backend whose background factorizations (every one after the first) wait ``pause`` seconds and
    then say they finished; the first, made in the caller's thread, is a plain Jacobi preconditioner."""

    name = "slow"

    def __init__(self, pause=0.3):
        self.pause, self.calls, self.finished = pause, 0, []

    def factorize(self, A):
        self.calls += 1
        if self.calls > 1:
            time.sleep(self.pause)
            self.finished.append(threading.current_thread().name)
        return linsolve.PreconditionedCG("jacobi").factorize(A) if self.calls == 1 else linsolve.SuperLU().factorize(A)


def _start_background(solver):
    A, b = _system()
    solver.solve(A, b)  # the first factorization, in this thread
    solver.solve(A * 1.01, b)  # CG iterations beyond background_after: a background refactorization starts
    assert solver.direct.calls == 2, "the test needs a background factorization under way"


def test_close_waits_for_the_background_factorization():
    direct = _SlowDirect()
    solver = linsolve.ReusedFactorization(direct, background=True, background_after=0)
    _start_background(solver)
    solver.close()
    assert direct.finished == ["tissuefem-refactorize"]
    assert not any(t.name == "tissuefem-refactorize" and t.is_alive() for t in threading.enumerate())
    A, b = _system()
    x, info = solver.solve(A, b)  # still usable: the next solve factorizes afresh
    assert info.factorized and np.linalg.norm(A @ x - b) < 1e-8 * np.linalg.norm(b)


def test_a_with_block_and_the_linear_solver_wait_too():
    direct = _SlowDirect()
    with linsolve.ReusedFactorization(direct, background=True, background_after=0) as solver:
        _start_background(solver)
    assert direct.finished == ["tissuefem-refactorize"]
    direct = _SlowDirect()
    outer = linsolve.LinearSolver(linsolve.ReusedFactorization(direct, background=True, background_after=0))
    with outer:
        _start_background(outer.backend)
    assert direct.finished == ["tissuefem-refactorize"]


def test_dropping_the_solver_waits_for_its_work():
    direct = _SlowDirect()
    solver = linsolve.ReusedFactorization(direct, background=True, background_after=0)
    _start_background(solver)
    del solver
    gc.collect()
    assert direct.finished == ["tissuefem-refactorize"]


def test_a_process_that_exits_during_a_background_factorization_ends_cleanly():
    script = textwrap.dedent("""
        import threading
        import numpy as np
        import scipy.sparse as sp
        from tissuefem.engine import linsolve

        n = 160  # a 2D Laplacian of n*n unknowns: its factorization takes a noticeable time
        T = sp.diags([-np.ones(n - 1), 4.0 * np.ones(n), -np.ones(n - 1)], [-1, 0, 1])
        A = (sp.kron(sp.identity(n), T) + sp.kron(sp.diags([-np.ones(n - 1), -np.ones(n - 1)], [-1, 1]),
             sp.identity(n))).tocsr()
        b = np.random.default_rng(0).normal(size=n * n)
        solver = linsolve.ReusedFactorization(background=True, background_after=0)
        solver.solve(A, b)
        solver.solve(A + 0.05 * sp.identity(n * n), b, rtol=1e-8)
        running = [t for t in threading.enumerate() if t.name == "tissuefem-refactorize"]
        print("background threads started:", len(running), flush=True)
    """)
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert "background threads started: 1" in done.stdout
    assert "Traceback" not in done.stderr and "BLAS" not in done.stderr
