"""Linear solver backends behind one small interface, and the policy that decides when to factorize.

Every Newton step solves ``A dx = b``, ``A`` the condensed tangent (symmetric; backward Euler's ``M + dt^2 K``); beyond
a few thousand triangles this solve decides the frame rate. A backend has ``factorize(A)`` (an object with ``solve(b)``)
and ``backend(A, b) -> x``; :func:`make` builds one by name. Newton calls a :class:`LinearSolver`, which condenses the
tangent to its free dofs (:class:`Condenser`) and decides when to factorize.

Under a frame's deadline (:class:`Deadline`) a solver starts no piece of work that its learned cost says cannot
finish in time: a factorization that does not fit runs on another thread (the second core) while the frame goes on
with the old one, or the frame stops and commits what it has.
"""

from __future__ import annotations

import importlib.util
import math
import threading
import time
import weakref
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .parameters import ParameterError, check_count, check_indices, check_real, check_real_array
from .vectors import dot, norm

__all__ = ["LinearSolver", "LinearInfo", "Condenser", "SuperLU", "Pardiso", "Cholmod", "ReusedFactorization",
           "PreconditionedCG", "rigid_body_modes", "OPTIONAL", "SolveInfo", "PCGResult", "pcg", "available", "make",
           "BACKENDS", "Deadline", "WORK", "start_thread", "check_launch", "ExtendedFactorization"]

_ORDERINGS = ("MMD_AT_PLUS_A", "COLAMD", "MMD_ATA", "NATURAL")


def _square(A) -> sp.csr_matrix:
    if not sp.issparse(A):
        raise ParameterError("A", f"A must be a scipy sparse matrix, got {type(A).__name__}")
    if A.ndim != 2 or A.shape[0] != A.shape[1]:
        raise ParameterError("A", f"A must be square, got shape {A.shape}")
    return A


def _rhs(b, n) -> np.ndarray:
    b = np.asarray(b, dtype=float)
    if b.shape != (n,):
        raise ParameterError("b", f"b must have shape ({n},) to match the matrix, got {b.shape}")
    if not np.all(np.isfinite(b)):
        raise ParameterError("b", "b contains non-finite values")
    return b


class _Direct:
    """Shared behaviour of the direct backends: ``backend(A, b)`` factorizes and solves once."""

    def __call__(self, A, b) -> np.ndarray:
        return self.factorize(A).solve(_rhs(b, A.shape[0]))

    def __repr__(self):
        return f"{type(self).__name__}()"


class _LUFactor:
    def __init__(self, lu, A=None, ordering=None, order=None):
        self._lu, self._order = lu, order  # ``order``: the kept ordering the factors were made in
        self._A, self._ordering = A, ordering  # kept only for a symmetric-mode factorization (see solve)

    def solve(self, b) -> np.ndarray:
        b = np.asarray(b, dtype=float)
        if self._order is None:
            x = self._lu.solve(b)
        else:
            x = np.empty_like(b)
            x[self._order] = self._lu.solve(b[self._order])
        if self._A is not None:  # diagonal pivots may lose accuracy on an indefinite matrix: check the residual once
            if not np.all(np.isfinite(x)) or np.linalg.norm(self._A @ x - b) > 1e-8 * np.linalg.norm(b):
                self._lu, self._order = spla.splu(self._A, permc_spec=self._ordering), None
                x = self._lu.solve(b)
            self._A = None
        return x

    @property
    def nnz(self) -> int:
        """Stored entries of the factors ``L + U`` (the fill-in: compare with the matrix's ``nnz``)."""
        return int(self._lu.L.nnz + self._lu.U.nnz)


class _KeptOrdering:
    """The fill-reducing ordering of one sparsity pattern, kept: a matrix of that pattern, permuted symmetrically by
    it (an index into its entries), factorizes with SuperLU's ``"NATURAL"`` ordering. That factorization leaves the
    interpreter's lock for all its work; finding the ordering holds it (measured, 5 ms at 16k triangles, 10 ms at
    32k: a frame's thread waits that long while a background factorization orders)."""

    def __init__(self, A, lu):
        self.indptr, self.indices = A.indptr.copy(), A.indices.copy()
        self.order = np.empty_like(lu.perm_c)
        self.order[lu.perm_c] = np.arange(lu.perm_c.size)  # SuperLU's ``perm_c`` maps old columns to new ones
        where = sp.csc_matrix((np.arange(1, A.nnz + 1, dtype=float), A.indices, A.indptr), shape=A.shape)
        where = where[self.order][:, self.order].tocsc()
        where.sort_indices()  # canonical, so that SciPy sorts nothing in place (the arrays are shared by every call)
        self.permuted = (where.indptr, where.indices, where.data.astype(np.int64) - 1)

    def matches(self, A) -> bool:
        return np.array_equal(A.indptr, self.indptr) and np.array_equal(A.indices, self.indices)

    def permute(self, A) -> sp.csc_matrix:
        indptr, indices, entries = self.permuted
        permuted = sp.csc_matrix((A.data[entries], indices.copy(), indptr.copy()), shape=A.shape)
        permuted.has_sorted_indices = True
        return permuted


class SuperLU(_Direct):
    """SciPy's SuperLU with the column ``ordering`` (one of ``_ORDERINGS``; SciPy's default is ``"COLAMD"``), for
    ``"MMD_AT_PLUS_A"`` in ``symmetric`` mode (diagonal pivots): half COLAMD's fill, 1.5-2.5x faster (23 ms against
    43 ms at 8k triangles). A zero pivot or a poor first residual refactorizes with partial pivoting. In symmetric
    mode the ordering of the last sparsity pattern is kept (:class:`_KeptOrdering`): a real-time loop refactorizes
    one pattern over and over, on the second core, and the frame's thread no longer waits for it."""

    def __init__(self, ordering: str = "MMD_AT_PLUS_A"):
        if ordering not in _ORDERINGS:
            raise ParameterError("ordering", f"ordering must be one of {_ORDERINGS}, got {ordering!r}")
        self.ordering, self.symmetric = ordering, ordering == "MMD_AT_PLUS_A"
        self.name = "superlu" if self.symmetric else f"superlu-{ordering.lower()}"
        self._kept = None

    def factorize(self, A) -> _LUFactor:
        A = sp.csc_matrix(_square(A))
        if not A.has_canonical_format:  # sorted, no duplicates: the kept ordering compares patterns (not in place)
            A = A.copy()
            A.sum_duplicates()
        if self.symmetric:
            symmetric = {"diag_pivot_thresh": 0.0, "options": {"SymmetricMode": True}}
            kept = self._kept  # read once: a background thread may replace it meanwhile
            try:
                if kept is not None and kept.matches(A):
                    return _LUFactor(spla.splu(kept.permute(A), permc_spec="NATURAL", **symmetric), A, self.ordering,
                                     kept.order)
                lu = spla.splu(A, permc_spec=self.ordering, **symmetric)
                self._kept = _KeptOrdering(A, lu)
                return _LUFactor(lu, A, self.ordering)
            except RuntimeError:
                pass  # a zero diagonal pivot: fall back to partial pivoting below
        return _LUFactor(spla.splu(A, permc_spec=self.ordering))

    def __repr__(self):
        return f"SuperLU(ordering={self.ordering!r})"


#: The optional packages some backends need: ``backend name -> (module, pip extra)``.
OPTIONAL = {"pardiso": ("pypardiso", "pardiso"), "cholmod": ("sksparse", "cholmod"), "cg-amg": ("pyamg", "amg")}


def available(name: str) -> bool:
    """Whether the backend ``name`` can be used here (``"pardiso"``, ``"cholmod"`` and ``"cg-amg"`` need an
    optional package: :data:`OPTIONAL`)."""
    if name in OPTIONAL:
        return importlib.util.find_spec(OPTIONAL[name][0]) is not None
    return name in BACKENDS


def _require(name: str) -> None:
    """Refuse, naming the optional package to install, a backend whose package is missing."""
    if not available(name):
        module, extra = OPTIONAL[name]
        raise ParameterError("linear_solver", f"linear solver {name!r} needs the optional package {module} "
                                              f"(pip install 'tissuefem[{extra}]'); use 'superlu' instead")


class _Factor:
    """An optional package's factorization: ``solve(b)``, and ``nnz``, its factors' stored entries (``entries()``)."""

    def __init__(self, solve, entries):
        self._solve, self._entries = solve, entries

    def solve(self, b) -> np.ndarray:
        return np.asarray(self._solve(np.asarray(b, dtype=float)), dtype=float).reshape(-1)

    @property
    def nnz(self) -> int:
        return int(self._entries())


class Pardiso(_Direct):
    """MKL PARDISO via the optional ``pypardiso`` package (real nonsymmetric mode). Each :meth:`factorize` uses a fresh
    pypardiso solver, so a kept factorization is never silently replaced by pypardiso's own reuse."""

    name = "pardiso"

    def __init__(self):
        _require("pardiso")
        import pypardiso
        self._module = pypardiso

    def factorize(self, A) -> _Factor:
        A, solver = sp.csr_matrix(_square(A)), self._module.PyPardisoSolver()
        solver.set_statistical_info_off()
        solver.factorize(A)
        # pypardiso re-checks that A is the matrix it factorized and only then back-substitutes; PARDISO reports
        # the factors' stored entries in its parameter 18
        return _Factor(lambda b: solver.solve(A, b), lambda: solver.iparm[17])


class Cholmod(_Direct):
    """SuiteSparse CHOLMOD's supernodal Cholesky ``A = L L^T`` (its ordering: AMD, or METIS's nested dissection
    where that fills less) via the optional ``scikit-sparse`` package. For a symmetric positive definite ``A``,
    as backward Euler's ``M / dt^2 + K`` is unless the tissue is compressed far: then (not positive definite)
    :class:`SuperLU` factorizes it instead. In 3D its fill is several times SuperLU's (``bench realtime
    --dim 3 --compare``)."""

    name = "cholmod"

    def __init__(self):
        _require("cholmod")
        from sksparse.cholmod import cholesky
        self._cholesky = cholesky

    def factorize(self, A):
        A = sp.csc_matrix(_square(A))
        try:
            factor = self._cholesky(A)
            return _Factor(factor, lambda: factor.L().nnz)  # the fill-in: compare with the matrix's lower triangle
        except Exception:  # sksparse's CholmodNotPositiveDefiniteError and kin: an indefinite tangent
            return SuperLU().factorize(A)


# --- a frame's deadline and the cost of its pieces of work ---------------------------------------

#: The pieces of a frame's work whose cost (seconds each) a :class:`LinearSolver` learns, in ``costs`` (``"start"``:
#: all a step does before its first Newton iteration, its warm start's energies and the first gradient).
WORK = ("start", "assembly", "factorization", "back-substitution", "cg-iteration", "line-search", "report")
#: The weight of the newest measurement in a cost estimate (an exponential moving average).
_LEARNING = 0.5


class Deadline:
    """A frame's deadline ``end`` (seconds by ``clock``; ``math.inf``: none) and the cost estimates ``costs`` (a dict
    ``kind -> seconds`` for the kinds of :data:`WORK`, learned by :meth:`record` from every measured piece, with or
    without a deadline). :meth:`fits` says whether pieces can finish before ``end``; a piece without an estimate yet
    fits while time is left (the first frame ever runs its work to learn its cost) and is noted in ``unestimated``.
    ``first``: the frame's first Newton iteration, whose short pieces (an assembly, a back-substitution, a CG
    iteration, a line search) always run so every frame makes progress; its long ones (a factorization) only if they
    fit or were never measured. What a frame did not start is noted in ``skipped``."""

    def __init__(self, clock=None, end: float = math.inf, costs: dict | None = None, first: bool = False):
        self.clock = time.perf_counter if clock is None else clock
        self.end, self.first = float(end), bool(first)
        self.costs = {} if costs is None else costs
        self.skipped, self.unestimated = [], []

    @property
    def limited(self) -> bool:
        return self.end < math.inf

    def fits(self, *kinds: str) -> bool:
        """Whether one piece of each of ``kinds`` can finish before the deadline (always without one)."""
        if not self.limited:
            return True
        unknown = [k for k in kinds if self.costs.get(k) is None]
        self.unestimated += [k for k in unknown if k not in self.unestimated]
        if self.first and all(k != "factorization" or k in unknown for k in kinds):
            return True  # the first iteration's short pieces, and a factorization never measured (the first frame)
        now = self.clock()
        return now < self.end and now + sum(self.costs.get(k) or 0.0 for k in kinds) <= self.end

    def room(self, kind: str) -> int | None:
        """How many pieces of ``kind`` fit before the deadline (``None``: no limit, or no estimate yet)."""
        estimate = self.costs.get(kind)
        if not self.limited or not estimate:
            return None
        return max(int((self.end - self.clock()) / estimate), 0)

    def skip(self, kind: str) -> None:
        """Note that a piece of ``kind`` was not started (it did not fit)."""
        if kind not in self.skipped:
            self.skipped.append(kind)

    def record(self, kind: str, seconds: float, count: int = 1) -> None:
        """Learn from ``count`` pieces of ``kind`` that took ``seconds`` together."""
        if count > 0 and math.isfinite(seconds) and seconds >= 0.0:
            each, old = seconds / count, self.costs.get(kind)
            self.costs[kind] = each if old is None else (1.0 - _LEARNING) * old + _LEARNING * each

    def timed(self, kind: str, work, *args):
        """``work(*args)``, its duration learned as one piece of ``kind``."""
        t0 = self.clock()
        out = work(*args)
        self.record(kind, self.clock() - t0)
        return out


def start_thread(work):
    """Run ``work()`` on a new thread (the default way a background factorization starts); the thread (with
    ``is_alive`` and ``join``). Not a daemon: the interpreter's exit waits for it."""
    thread = threading.Thread(target=work, name="tissuefem-refactorize", daemon=False)
    thread.start()
    return thread


# --- conjugate gradients ------------------------------------------------------------------------

@dataclass
class PCGResult:
    """What :func:`pcg` did."""

    x: np.ndarray
    iterations: int
    converged: bool
    residual_norm: float
    negative_curvature: bool = False


def pcg(A, b, precondition=None, *, atol: float = 0.0, rtol: float = 1e-8, max_iterations: int = 200,
        another=None) -> PCGResult:
    """Preconditioned conjugate gradients for a symmetric ``A`` from ``x = 0``; ``precondition(r)`` applies an
    approximate inverse. Stops when ``||b - A x|| <= max(atol, rtol ||b||)``, after ``max_iterations``, on
    *negative curvature* (``p^T A p <= 0``: ``A`` is not positive definite; ``x`` is the last iterate, still
    downhill), or when ``another()``, asked before every iteration but the first, says no (a frame's deadline: an
    iteration that runs slower than learned does not carry the ones after it past the deadline)."""
    b = np.asarray(b, dtype=float)
    x, r = np.zeros_like(b), b.copy()
    target = max(float(atol), float(rtol) * norm(b))
    rnorm = norm(r)
    if rnorm <= target:
        return PCGResult(x, 0, True, rnorm)
    z = precondition(r) if precondition is not None else r.copy()
    p, rz = z.copy(), dot(r, z)
    for k in range(1, int(max_iterations) + 1):
        if k > 1 and another is not None and not another():
            return PCGResult(x, k - 1, False, rnorm)
        Ap = A @ p
        curvature = dot(p, Ap)
        if not (curvature > 0.0) or not (rz > 0.0):
            if k == 1:  # no step taken yet: the preconditioned residual is the best safe guess
                x = z if rz > 0.0 else r.copy()
            return PCGResult(x, k - 1, False, rnorm, negative_curvature=True)
        alpha = rz / curvature
        x += alpha * p
        r -= alpha * Ap
        rnorm = norm(r)
        if not np.isfinite(rnorm) or rnorm <= target:
            return PCGResult(x, k, rnorm <= target, rnorm)
        z = precondition(r) if precondition is not None else r
        rz_new = dot(r, z)
        p, rz = z + (rz_new / rz) * p, rz_new
    return PCGResult(x, int(max_iterations), False, rnorm)


class ExtendedFactorization:
    """A kept factorization ``factor`` of an old matrix, extended to a new matrix ``A`` whose unknowns come from the
    old ones (after a cut each copy of a node comes from its parent): an approximate inverse for CG while a fresh
    factorization of ``A`` is made off the frame. ``parent``: for each unknown of ``A``, the old unknown it comes
    from (``-1``: none). Two levels, applied one after the other and back (symmetric):

        z = C r,   z += L (r - A z),   z += C (r - A z),      C = P F^-1 P^T,   L = R^T A[s, s]^-1 R.

    ``P`` gives each unknown its parent's value (``P^T`` sums the residual of the copies onto their parent), so
    ``C`` solves for the motions that keep the copies together (for a cut along edges ``P^T A P`` is the old
    matrix); ``s`` are the unknowns that are not their parent's only copy (the lips of a cut, and unknowns without
    a parent) and those within three couplings of them, where ``L`` solves ``A`` exactly (a small sparse
    factorization): the motions that open the cut. Two back-substitutions of ``F`` per application."""

    def __init__(self, factor, parent, n_old: int, A):
        parent = np.asarray(parent, dtype=np.intp)
        A = sp.csr_matrix(_square(A))
        n = A.shape[0]
        if parent.shape != (n,) or (parent.size and (parent.max() >= n_old or parent.min() < -1)):
            raise ParameterError("parent", f"parent must give one old unknown in -1..{n_old - 1} per unknown "
                                           f"({n}), got shape {parent.shape}")
        self.factor, self.n, self.n_old, self._A = factor, n, int(n_old), A
        mapped = np.flatnonzero(parent >= 0)
        self._mapped, self._parent = mapped, parent[mapped]
        copies = np.bincount(self._parent, minlength=self.n_old)
        split = np.ones(n, dtype=bool)
        split[mapped] = copies[self._parent] > 1
        self._local = None
        if split.any():
            graph = sp.csr_matrix((np.ones(A.nnz, dtype=np.int8), A.indices, A.indptr), shape=A.shape)
            for _ in range(3):
                split = split | (graph @ split.astype(np.int8) > 0)
            s = np.flatnonzero(split)
            self._local = (s, A[s], spla.splu(sp.csc_matrix(A[s][:, s])))

    def _coarse(self, r) -> np.ndarray:
        z = np.zeros(self.n)
        if self._mapped.size:
            z[self._mapped] = self.factor.solve(np.bincount(self._parent, weights=r[self._mapped],
                                                            minlength=self.n_old))[self._parent]
        return z

    def solve(self, r) -> np.ndarray:
        r = np.asarray(r, dtype=float)
        z = self._coarse(r)
        if self._local is None:
            return z
        s, rows, lu = self._local
        z[s] += lu.solve(r[s] - rows @ z)
        return z + self._coarse(r - self._A @ z)


@dataclass
class SolveInfo:
    """What one solve of :class:`ReusedFactorization` did."""

    iterations: int  # CG iterations (0: a direct solve with a fresh factorization)
    factorized: bool  # a new factorization was computed for this solve
    converged: bool
    residual_norm: float  # ||b - A x|| (nan: a constant solve checks none)
    reason: str = ""  # why it refactorized ("first", "shape", "stale", "forced"), or why CG failed (then it
    # refactorized, or a fresh factorization is made off the frame): "cg-failed", "negative-curvature"
    skipped: str = ""  # a piece of work not started for the deadline (then no solution: x is None)


def _join_all(threads) -> None:
    """Wait for each background factorization in ``threads`` (a list, emptied) to finish."""
    while threads:
        thread = threads.pop()
        if thread is not threading.current_thread():
            thread.join()


def check_launch(value):
    """``value`` checked as a way to start background work: ``launch(work)`` returns a job with ``is_alive`` and
    ``join`` (``None``: :func:`start_thread`)."""
    if value is not None and not callable(value):
        raise ParameterError("launch", f"launch must be a callable starting background work, got {value!r}")
    return value


class ReusedFactorization:
    """Conjugate gradients preconditioned by a kept factorization of the ``direct`` backend (default :class:`SuperLU`):
    the tangent changes slowly, so a few CG iterations (~1 ms each at 8k triangles) replace a factorization (~20 ms).
    Beyond ``refresh_after`` iterations the *next* solve refactorizes; at ``max_iterations`` this one does.
    ``background``: beyond ``background_after`` iterations a thread on the second core refactorizes, adopted once
    finished (iteration counts then depend on timing). ``solve`` returns ``(x, SolveInfo)``; ``factorizations``,
    ``background_factorizations`` and ``cg_iterations`` count. Under a ``deadline`` (:class:`Deadline`) a
    factorization that does not fit is started in the background whatever ``background`` says, and CG runs the
    iterations that fit with the old factorization (no factorization yet: the solve returns ``None``). After a cut,
    :meth:`provide` gives a preconditioner to start from while a fresh factorization is made off the frame
    (``provisional`` until that one is adopted).
    ``constant``: no CG, the kept factorization's back-substitution is the answer (exact for a constant matrix, which
    need not be given again: ``A`` may be ``None`` once one is kept).

    One factorization at a time is made off the frame, started by ``launch(work)`` (default :func:`start_thread`; a
    test passes one it controls). Unfinished work is waited for by :meth:`close` (or leaving a ``with`` block), when
    the solver is dropped and at the interpreter's exit: a process that ends under a factorization can crash in the
    BLAS."""

    def __init__(self, direct=None, refresh_after: int = 15, max_iterations: int = 40, background: bool = False,
                 background_after: int = 3, launch=None, constant: bool = False):
        self.refresh_after = check_count("refresh_after", refresh_after)
        self.max_iterations = check_count("max_iterations", max_iterations)
        self.direct = direct if direct is not None else SuperLU()
        self.background, self.background_after = bool(background), int(background_after)
        self.constant = bool(constant)
        kind = "constant-" if self.constant else "cg+reused-"
        self.name = kind + self.direct.name + ("+background" if self.background else "")
        self.launch = check_launch(launch)
        self._threads = []  # background factorizations started and not yet joined (shared with the finalizer)
        weakref.finalize(self, _join_all, self._threads)
        self.invalidate()  # no factorization yet
        self.factorizations = self.background_factorizations = self.cg_iterations = 0

    @property
    def direct(self):
        """The direct backend whose factorizations are kept (may be replaced between solves)."""
        return self._direct

    @direct.setter
    def direct(self, value):
        if not callable(getattr(value, "factorize", None)):
            raise ParameterError("direct", f"direct must be a backend with a factorize method, got {value!r}")
        self._direct = value

    def _keep(self, factor, shape, provisional: bool = False) -> None:
        self._factor, self._shape, self._stale, self.provisional = factor, shape, False, provisional

    def _start_fresh(self, A) -> None:
        """Start a factorization of ``A`` off the frame, unless one is under way."""
        if self._pending is not None:
            return
        A, box, factorize = A.copy(), {}, self.direct.factorize

        def work():  # holds no reference to the solver, which may be dropped while this runs
            try:
                box["factor"] = factorize(A)
            except Exception:  # a failed factorization only means the old one stays
                box["factor"] = None
        job = (self.launch or start_thread)(work)
        self._threads[:] = [t for t in self._threads if t.is_alive()] + [job]
        self._pending = (job, box, A.shape)

    def _adopt(self, shape) -> None:
        """Take a finished background factorization as the preconditioner (forgotten if made for another shape)."""
        if self._pending is None or self._pending[0].is_alive():
            return
        _, box, made_for = self._pending
        self._pending = None
        if made_for == shape and box.get("factor") is not None:
            self._keep(box["factor"], shape)
            self.background_factorizations += 1

    def invalidate(self) -> None:
        """Forget the kept factorization, and the one under way (not waited for: it will not be adopted)."""
        self._keep(None, None)
        self._pending = None

    def close(self) -> None:
        """Wait for any background factorization to finish (it is not adopted) and forget the kept factorization.
        The solver stays usable: its next solve factorizes afresh."""
        _join_all(self._threads)
        self.invalidate()

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    kept = property(lambda self: self._factor is not None, doc="Whether a factorization is kept (to reuse).")

    def provide(self, factor, shape, fresh: bool = True) -> None:
        """Precondition with ``factor`` (an approximate inverse of matrices of ``shape``, e.g. an
        :class:`ExtendedFactorization` after a cut). ``fresh``: until a fresh factorization, started off the frame
        by the next solve whatever ``background`` says, is adopted; else it is kept as if made here."""
        self.invalidate()
        self._keep(factor, tuple(shape), bool(fresh))

    def _refactorize(self, A, b, reason, deadline, atol=0.0) -> tuple[np.ndarray | None, SolveInfo]:
        if not deadline.fits("factorization", "back-substitution"):
            self._start_fresh(A)  # adopted by a later solve
            deadline.skip("factorization")
            return None, SolveInfo(0, False, False, math.inf, reason, "factorization")
        self._keep(deadline.timed("factorization", self.direct.factorize, A), A.shape)
        self.factorizations += 1
        if getattr(self._factor, "precondition", None) is not None and not self.constant:  # multigrid: CG
            result = self._cg(A, b, deadline, atol=atol, rtol=1e-10, max_iterations=self.max_iterations)
            return result.x, SolveInfo(result.iterations, True, result.converged, result.residual_norm, reason)
        return self._back_substitution(A, b, reason, deadline)

    def _back_substitution(self, A, b, reason, deadline) -> tuple[np.ndarray, SolveInfo]:
        x = deadline.timed("back-substitution", self._factor.solve, b)
        residual = math.nan if self.constant else float(np.linalg.norm(b - A @ x))  # (a constant solve checks none)
        return x, SolveInfo(0, True, bool(np.all(np.isfinite(x))), residual, reason)

    def _cg(self, A, b, deadline, **options) -> PCGResult:
        """:func:`pcg` preconditioned by the kept factor; its iterations counted, their cost learned."""
        precondition = getattr(self._factor, "precondition", None) or self._factor.solve  # an iterative backend's
        t0 = deadline.clock()
        result = pcg(A, b, precondition, **options)
        deadline.record("cg-iteration", deadline.clock() - t0, result.iterations)
        self.cg_iterations += result.iterations
        return result

    def solve(self, A, b, *, atol: float = 0.0, rtol: float = 1e-10, refactorize: bool = False,
              deadline: Deadline | None = None) -> tuple[np.ndarray | None, SolveInfo]:
        """``(x, SolveInfo)`` for ``A x = b`` (``x = None``: under ``deadline`` nothing fitted). A ``constant`` one
        with a kept factorization needs no ``A`` (``None``) and checks neither ``b`` nor ``x``, every frame (Newton
        checks the step)."""
        deadline = Deadline() if deadline is None else deadline
        if refactorize or A is not None or self._factor is None or not self.constant:
            A, b = _square(A), _rhs(b, A.shape[0])
            self._adopt(A.shape)
            if refactorize or self._factor is None or self._shape != A.shape:
                reason = "forced" if refactorize else "first" if self._factor is None else "shape"
                return self._refactorize(A, b, reason, deadline, atol)
        if self.constant:  # the kept factorization's back-substitution alone
            if not deadline.fits("back-substitution"):
                deadline.skip("back-substitution")
                return None, SolveInfo(0, False, False, math.inf, "", "back-substitution")
            x = deadline.timed("back-substitution", self._factor.solve, np.asarray(b, dtype=float))
            return x, SolveInfo(0, False, True, math.nan)
        if self.provisional:
            self._start_fresh(A)  # a fresh one off the frame (unless under way); the provided one meanwhile
        if self._stale and not self.background:
            if deadline.fits("factorization", "back-substitution"):
                return self._refactorize(A, b, "stale", deadline, atol)
            self._start_fresh(A)  # meanwhile the old one preconditions
        limit, room = self.max_iterations, deadline.room("cg-iteration")
        if room is not None:
            limit = min(limit, max(room, int(deadline.first)))
        elif not deadline.fits("cg-iteration"):
            limit = 0
        if limit == 0:
            deadline.skip("cg-iteration")
            return None, SolveInfo(0, False, False, math.inf, "", "cg-iteration")
        another = (lambda: deadline.room("cg-iteration") != 0) if deadline.limited else None
        result = self._cg(A, b, deadline, atol=atol, rtol=rtol, max_iterations=limit, another=another)
        failed = "negative-curvature" if result.negative_curvature else (
            "cg-failed" if not result.converged and result.iterations >= self.max_iterations else "")
        if failed and deadline.fits("factorization", "back-substitution"):
            if self.provisional:  # wait for the fresh one under way: it costs no more than one made now, which fits
                self._pending[0].join()
                self._adopt(A.shape)
                if not self.provisional:
                    return self._back_substitution(A, b, failed, deadline)
            return self._refactorize(A, b, failed, deadline, atol)  # (a fresh one that failed too)
        if failed:  # meanwhile CG's iterate is the answer (Newton checks it is downhill)
            self._start_fresh(A)
        elif (self.background and result.iterations > self.background_after) or (
                (limit < self.max_iterations or result.iterations < limit) and not result.converged):  # cut short
            self._start_fresh(A)  # by the deadline: refresh too
        elif result.iterations > self.refresh_after and not self.provisional:  # (a fresh one is under way)
            self._stale = True
        return result.x, SolveInfo(result.iterations, False, result.converged, result.residual_norm, failed)

    def __call__(self, A, b) -> np.ndarray:
        return self.solve(A, b)[0]

    def __repr__(self):
        return (f"ReusedFactorization(direct={self.direct!r}, refresh_after={self.refresh_after}, "
                f"max_iterations={self.max_iterations})")


class _CGFactor:
    def __init__(self, A, precondition, rtol, max_iterations, nnz=None):
        self._A, self.precondition = A, precondition  # precondition(r): what CG with a kept "factor" applies
        self.rtol, self.max_iterations = rtol, max_iterations
        self.iterations, self.converged = 0, True  # over all solves with this matrix
        self.nnz = nnz  # stored entries of the preconditioner (AMG: every level's matrix), if it has any

    def solve(self, b) -> np.ndarray:
        result = pcg(self._A, _rhs(b, self._A.shape[0]), self.precondition, rtol=self.rtol,
                     max_iterations=self.max_iterations)
        self.iterations += result.iterations
        self.converged = self.converged and result.converged
        return result.x


def rigid_body_modes(X) -> np.ndarray:
    """The rigid motions of the nodes ``X`` (shape ``(d, n)``) as dof vectors, node by node (``u[d i + c]``): the
    columns of a ``(d n, 3)`` array in 2D (two translations, a rotation) or ``(d n, 6)`` in 3D (three and three),
    each rotation about the centroid. Smoothed aggregation keeps them exactly on every level (its near-nullspace),
    which elasticity needs."""
    X = np.asarray(X, dtype=float)
    d, n = X.shape
    if d not in (2, 3):
        raise ParameterError("X", f"X must have shape (2, n) or (3, n), got {X.shape}")
    Y = X - X.mean(axis=1, keepdims=True)
    planes = [(0, 1)] if d == 2 else [(0, 1), (1, 2), (2, 0)]
    modes = np.zeros((n, d, d + len(planes)))
    modes[:, range(d), range(d)] = 1.0  # the translations
    for k, (a, b) in enumerate(planes, start=d):  # the rotation in the (a, b) plane: u_a = -y_b, u_b = y_a
        modes[:, a, k], modes[:, b, k] = -Y[b], Y[a]
    return modes.reshape(d * n, -1)


class PreconditionedCG(_Direct):
    """Conjugate gradients with a preconditioner built by ``factorize``: ``"jacobi"`` (the inverse diagonal: free, weak,
    iterations grow like ``1/h``), ``"ilu"`` (SciPy's ``spilu``: much stronger), ``"amg"`` (one
    V-cycle of smoothed-aggregation multigrid, the optional ``pyamg``; ``near_nullspace``: the rigid-body modes of
    the matrix's dofs, :func:`rigid_body_modes`, which elasticity needs: without them only the constant) or
    ``"none"``. A solve stops at ``rtol ||b||`` or after ``max_iterations`` (default ``max(200, 2 n)``) and returns
    its iterate anyway (Newton checks it is downhill); the factor counts ``iterations`` and whether every solve
    ``converged``. Kept by :class:`ReusedFactorization` (``"reuse-cg-amg"``), the factor's preconditioner alone is
    CG's: the multigrid hierarchy is the kept "factorization"."""

    _KINDS = ("jacobi", "ilu", "amg", "none")
    _DROP_TOL = 1e-4  # ILU's: entries below it (relative) are dropped

    def __init__(self, preconditioner: str = "jacobi", rtol: float = 1e-8, max_iterations: int | None = None,
                 near_nullspace=None):
        if preconditioner not in self._KINDS:
            raise ParameterError("preconditioner", f"preconditioner must be one of {self._KINDS}, got "
                                                   f"{preconditioner!r}")
        if preconditioner == "amg":
            _require("cg-amg")
        self.preconditioner, self.rtol = preconditioner, check_real("rtol", rtol, 0, 1, lo_open=True, hi_open=True)
        self.max_iterations = None if max_iterations is None else check_count("max_iterations", max_iterations)
        self.near_nullspace = near_nullspace
        self.name = "cg" if preconditioner == "none" else f"cg-{preconditioner}"

    @property
    def near_nullspace(self):
        """``(n, k)`` vectors multigrid keeps exactly (``None``: the constant); checked against the matrix."""
        return self._near_nullspace

    @near_nullspace.setter
    def near_nullspace(self, B):
        B = None if B is None else check_real_array("near_nullspace", B)
        if B is not None and (B.ndim != 2 or not np.all(np.isfinite(B))):
            raise ParameterError("near_nullspace", f"near_nullspace must be a finite (n, k) array, got shape {B.shape}")
        self._near_nullspace = B

    def _multigrid(self, A):
        import pyamg
        B = self._near_nullspace
        if B is not None and B.shape[0] != A.shape[0]:
            raise ParameterError("near_nullspace", f"near_nullspace has {B.shape[0]} rows for a matrix of "
                                                   f"{A.shape[0]} unknowns")
        block = {3: 2, 6: 3}.get(B.shape[1], 1) if B is not None else 1
        M = A.tobsr(blocksize=(block, block)) if block > 1 and A.shape[0] % block == 0 else A
        # the coarsest level by a sparse LU (pyamg's default, a dense pseudo-inverse, costs seconds with busy BLAS
        # threads); pyamg makes it at the first V-cycle, so one is run here, with the hierarchy (off the frame)
        hierarchy = pyamg.smoothed_aggregation_solver(M, B=B, symmetry="symmetric", max_coarse=300,
                                                      coarse_solver="splu")
        cycle = hierarchy.aspreconditioner(cycle="V")
        cycle.matvec(np.zeros(A.shape[0]))
        return (lambda r: cycle.matvec(r)), int(sum(level.A.nnz for level in hierarchy.levels))

    def factorize(self, A) -> _CGFactor:
        A = sp.csr_matrix(_square(A))
        precondition, nnz = None, None  # "none"
        if self.preconditioner == "jacobi":
            d = A.diagonal()
            if not np.all(d > 0):
                raise RuntimeError("Jacobi preconditioner: the matrix has a diagonal entry <= 0")
            inv = 1.0 / d
            precondition = lambda r: inv * r  # noqa: E731
        elif self.preconditioner == "ilu":
            ilu = spla.spilu(sp.csc_matrix(A), drop_tol=self._DROP_TOL, fill_factor=10.0)
            precondition, nnz = ilu.solve, int(ilu.L.nnz + ilu.U.nnz)
        elif self.preconditioner == "amg":
            precondition, nnz = self._multigrid(A)
        limit = self.max_iterations or max(200, 2 * A.shape[0])
        return _CGFactor(A, precondition, self.rtol, limit, nnz)

    def __repr__(self):
        return f"PreconditionedCG(preconditioner={self.preconditioner!r}, rtol={self.rtol})"


BACKENDS = {"superlu": lambda: SuperLU("MMD_AT_PLUS_A"), "superlu-colamd": lambda: SuperLU("COLAMD"),
            "pardiso": Pardiso, "cholmod": Cholmod, "cg-jacobi": lambda: PreconditionedCG("jacobi"),
            "cg-ilu": lambda: PreconditionedCG("ilu"), "cg-amg": lambda: PreconditionedCG("amg"),
            "cg": lambda: PreconditionedCG("none")}


def make(name: str = "superlu"):
    """A backend by name: ``"superlu"``, ``"superlu-colamd"``, ``"pardiso"``, ``"cholmod"``, ``"auto"`` (direct), or
    ``"cg-jacobi"``, ``"cg-ilu"``, ``"cg-amg"``, ``"cg"`` (iterative, :class:`PreconditionedCG`)."""
    if name == "auto":
        name = "pardiso" if available("pardiso") else "superlu"
    if name not in BACKENDS:
        raise ParameterError("linear_solver", f"unknown linear solver {name!r}; choose from "
                                              f"{sorted(BACKENDS) + ['auto']}")
    return BACKENDS[name]()


# --- condensation and the policy Newton uses ------------------------------------------------------

class Condenser:
    """The free-free block ``K[free][:, free]`` of a sparse matrix. For a fixed (read-only) pattern it is a gather of
    the data array through a map computed once per pattern and set of free dofs (the last eight are kept)."""

    def __init__(self):
        self._maps = {}

    def __call__(self, K, mask) -> sp.csr_matrix:
        K = sp.csr_matrix(K) if not sp.isspmatrix_csr(K) else K
        if mask.all():
            return K
        if K.indptr.flags.writeable or K.indices.flags.writeable:
            return K[mask][:, mask]  # not a fixed (read-only) pattern: slice
        # the pattern by the memory of its index arrays (scipy may hand back views of them)
        key = (K.indptr.ctypes.data, K.indices.ctypes.data, K.shape, np.packbits(mask).tobytes())
        entry = self._maps.get(key)
        if entry is None:
            if len(self._maps) >= 8:
                self._maps.clear()
            numbered = sp.csr_matrix((np.arange(1, K.nnz + 1, dtype=float), K.indices, K.indptr), shape=K.shape)
            block = numbered[mask][:, mask]
            entry = (block.data.astype(np.intp) - 1, block.indices, block.indptr, block.shape, K.indptr, K.indices)
            self._maps[key] = entry  # the pattern arrays are kept alive so their ids stay theirs
        gather, indices, indptr, shape = entry[:4]
        A = sp.csr_matrix((K.data[gather], indices, indptr), shape=shape, copy=False)
        A.has_sorted_indices = True
        return A


@dataclass
class LinearInfo:
    """What one linear solve of a :class:`LinearSolver` did."""

    iterations: int = 0  # conjugate-gradient iterations
    factorizations: int = 0  # new factorizations computed
    skipped: str = ""  # a piece of work not started for the deadline ("factorization", "cg-iteration", ...)


class LinearSolver:
    """How Newton solves ``A dx = b``: which backend, and when to factorize. ``method``: ``"direct"`` (a fresh
    :class:`SuperLU` factorization per solve: exact Newton); a backend name of :func:`make` (that backend, afresh);
    ``"reuse"``, ``"reuse-<backend>"`` (:class:`ReusedFactorization`), ``"reuse-background[-<backend>]"`` (the same,
    refreshed on the second core); ``"constant[-<backend>]"`` (a kept factorization used as it is, without
    assembling the tangent again: exact for a constant tangent; a ``constant`` :class:`ReusedFactorization`); or a
    backend object. A kept factorization is dropped when the free dofs or the pattern change, or by
    :meth:`invalidate`.

    ``costs``: what each piece of work (:data:`WORK`) took lately, in seconds, learned by every solve (see
    :meth:`deadline`). Under a :class:`Deadline` a solve starts nothing that does not fit: a kept factorization that
    is due is made in the background (started by ``launch(work)``, default :func:`start_thread`, as a real-time
    solver's steps off the frame are) while the solve goes on with the old one or returns ``None``; a solver that
    factorizes afresh each solve returns ``None``; :attr:`LinearInfo.skipped` says what."""

    def __init__(self, method="reuse", *, launch=None):
        self.method, backend = method, method
        if isinstance(method, str):
            kind, _, base = method.partition("-")
            reused = kind in ("reuse", "constant")
            if not reused and method not in ("direct", "auto", *BACKENDS):
                raise ParameterError("linear_solver", "linear_solver must be 'direct', 'reuse', 'constant', "
                                     f"'reuse-<backend>', 'constant-<backend>' or a backend "
                                     f"({', '.join(sorted(BACKENDS))}), got {method!r}")
            background = kind == "reuse" and base.partition("-")[0] == "background"  # "reuse-background[-<backend>]"
            base = base[len("background-"):] if background else base
            plain = method in ("direct", "reuse", "constant", "reuse-background")  # the default backend
            backend = SuperLU() if plain else make(base if reused else method)
            if reused:
                backend = ReusedFactorization(backend, background=background, launch=launch,
                                              constant=kind == "constant")
        elif not (isinstance(method, ReusedFactorization) or callable(getattr(method, "factorize", None))):
            raise ParameterError("linear_solver", f"linear_solver must be a name or a backend object, got {method!r}")
        self.backend = backend
        self.condense = Condenser()
        self._key, self._carried = None, None
        self.launch = check_launch(launch)  # (not passed on: a backend object given keeps its own)
        self.factorizations = 0
        self.costs = {}
        self._modes = None  # the body's rigid motions, for a multigrid preconditioner (use_rigid_modes)

    @property
    def constant(self) -> bool:
        """Whether a kept factorization is used as it is (``"constant..."``), without CG or a new tangent."""
        return isinstance(self.backend, ReusedFactorization) and self.backend.constant

    @property
    def factorizing(self):
        """The backend whose factorization (or preconditioner) this solver keeps or makes: a reused one's
        ``direct``, else the backend itself."""
        return self.backend.direct if isinstance(self.backend, ReusedFactorization) else self.backend

    def use_rigid_modes(self, X) -> None:
        """Give a multigrid preconditioner (``"cg-amg"``: :attr:`PreconditionedCG.near_nullspace`) the rigid motions
        of the nodes ``X`` whose dofs, node by node, are the model's (:func:`rigid_body_modes`): each set of free dofs
        passes on its rows. Other backends need none: nothing changes."""
        if not isinstance(self.factorizing, PreconditionedCG):
            return
        self._modes = rigid_body_modes(X)
        if self._key is not None:  # the next matrix passes them on (a kept preconditioner is made anew)
            self.invalidate()

    def deadline(self, clock=None, end: float = math.inf, first: bool = False) -> Deadline:
        """A :class:`Deadline` at ``end`` on ``clock`` with this solver's cost estimates (learned by its solves)."""
        return Deadline(clock, end, self.costs, first)

    def least_work(self) -> tuple[str, ...]:
        """The pieces the next solve needs at the least (what must fit before its tangent is worth assembling; a
        missing constant factorization may be made in the background, from the tangent)."""
        if self.constant:
            return ("back-substitution",)
        if isinstance(self.backend, ReusedFactorization):
            return ("cg-iteration",)
        return ("factorization", "back-substitution")

    @property
    def name(self) -> str:
        return getattr(self.backend, "name", type(self.backend).__name__)

    def close(self) -> None:
        """Wait for the backend's background work, if any (:meth:`ReusedFactorization.close`), and forget any kept
        factorization."""
        if isinstance(self.backend, ReusedFactorization):
            self.backend.close()
        self.invalidate()

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def invalidate(self) -> None:
        """Forget any kept factorization (the matrix is about to change in a way the keys do not see)."""
        self._key, self._carried = None, None
        if isinstance(self.backend, ReusedFactorization):
            self.backend.invalidate()

    def carry(self, old: "LinearSolver", parent) -> bool:
        """Start from ``old``'s kept factorization, on a model whose dofs come from ``old``'s (``parent``: the old
        dof of each new dof, after a cut or an excision): the first tangent is preconditioned by it, extended to the
        new dofs (:class:`ExtendedFactorization`), while a fresh factorization is made off the frame. Whether there
        was one to carry (only a ``"reuse..."`` solver keeps one, for one set of free dofs)."""
        if not isinstance(old, LinearSolver):
            raise ParameterError("old", f"old must be a LinearSolver, got {type(old).__name__}")
        if not all(isinstance(s.backend, ReusedFactorization) and not s.constant for s in (self, old)):
            return False
        old.backend._adopt(old.backend._shape)  # a background factorization ended meanwhile: the fresher one
        # its unfinished work is waited for when this solver goes, not when the old one is dropped (now)
        self.backend._threads.extend(old.backend._threads)
        old.backend._threads.clear()
        factor = old.backend._factor
        if factor is None or old._key is None:
            return False
        size, bits = old._key
        mask = np.unpackbits(np.frombuffer(bits, dtype=np.uint8), count=size).astype(bool)
        n_old = int(mask.sum())
        if old.backend._shape != (n_old, n_old):
            return False
        parent = check_indices("parent", parent, size, "old dofs (one per new dof)")
        index = np.full(size, -1, dtype=np.intp)
        index[mask] = np.arange(n_old)
        self.invalidate()
        self._carried = (factor, index[parent], n_old)
        return True

    def assembles(self, mask) -> bool:
        """Whether :meth:`matrix` for ``mask`` would assemble (not when a kept constant factorization fits)."""
        kept = self.constant and self.backend.kept
        return not (kept and self._key == (mask.size, np.packbits(mask).tobytes()))

    def matrix(self, assemble, mask, force=False, deadline: Deadline | None = None):
        """The free-free block of ``assemble()`` -- or ``None`` when a kept constant factorization makes the
        tangent unnecessary (``force`` assembles it anyway); ``deadline``: learns the assembly's cost."""
        key = (mask.size, np.packbits(mask).tobytes())
        if key != self._key:  # another set of unknowns: a kept factorization does not fit
            if self._key is not None:
                self.invalidate()
            self._key = key
            if self._modes is not None and self._modes.shape[0] == mask.size:
                self.factorizing.near_nullspace = self._modes[mask]
        if self.constant and self.backend.kept and not force:
            return None
        K = assemble() if deadline is None else deadline.timed("assembly", assemble)
        A = self.condense(K, mask)
        carried, self._carried = self._carried, None
        if carried is not None and carried[1].size == mask.size:  # the first tangent after a cut: the old factorization
            factor, parent, n_old = carried[0], carried[1][mask], carried[2]
            if np.array_equal(parent, np.arange(n_old)):
                self.backend.provide(factor, A.shape, fresh=False)  # the same unknowns: kept as it is
            else:  # extended
                self.backend.provide(ExtendedFactorization(factor, parent, n_old, A), A.shape)
        return A

    def solve(self, A, b, *, atol: float = 0.0, deadline: Deadline | None = None):
        """``(dx, LinearInfo)`` for ``A dx = b`` (``dx = None``: the solve failed, or under ``deadline`` did not
        fit: ``info.skipped``); ``A`` is ``None`` only for a kept constant factorization. ``atol``: where an
        iterative solve may stop (inexact Newton)."""
        info = LinearInfo()
        deadline = self.deadline() if deadline is None else deadline
        try:
            if isinstance(self.backend, ReusedFactorization):
                dx, done = self.backend.solve(A, b, atol=atol, rtol=0.0, deadline=deadline)
                info.iterations, info.factorizations, info.skipped = done.iterations, int(done.factorized), done.skipped
                retry = dx is not None and not (self.constant or done.factorized)
                if retry and not (np.all(np.isfinite(dx)) and dot(b, dx) > 0):  # no descent: refactorize
                    dx, again = self.backend.solve(A, b, refactorize=True, deadline=deadline)
                    info.factorizations += int(again.factorized)  # (skipped: no direction, Newton finds one)
            elif not deadline.fits("factorization", "back-substitution"):
                dx, info.skipped = None, "factorization"
                deadline.skip("factorization")
            else:
                factor = deadline.timed("factorization", self.backend.factorize, A)
                iterative = isinstance(self.backend, PreconditionedCG)  # it factorizes nothing
                dx = np.asarray(deadline.timed("cg-iteration" if iterative else "back-substitution", factor.solve, b),
                                dtype=float)
                info.iterations = int(factor.iterations) if iterative else 0
                info.factorizations = 0 if iterative else 1
        except (RuntimeError, ValueError, np.linalg.LinAlgError, ZeroDivisionError):
            dx = None
        self.factorizations += info.factorizations
        return dx, info

    def __repr__(self):
        return f"LinearSolver({self.method!r})"
