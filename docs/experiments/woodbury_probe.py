"""Low-rank (Woodbury) updates of the kept factorization, on the probe variant of `bench scenes`.

The hypothesis: where a stiff penalty comes or goes (a probe's contact), the kept factorization lacks a change of
low rank, and CG pays for it with about one iteration per changed unknown. So before each CG solve the kept
factorization is made exact again on up to ``rank`` unknowns whose diagonal changed by more than half
(:class:`UpdatedFactorization`), hooked into the library's ``ReusedFactorization`` for the run (its factorizations
are wrapped, and CG's solves update the wrapper first; both restored afterwards). The probe variant runs with
rank 0 (the library as it is) and rank 64, alternating in one process. Per rank: the median wall ms of a frame,
Newton steps, CG iterations (one back-substitution each) and back-substitutions of the updates per frame.
Unlike the version that was in the library, an update is not limited to the back-substitutions that fit the
frame's deadline.

    python docs/experiments/woodbury_probe.py [n_triangles] [frames] [repeats]
"""

import contextlib
import sys
from types import SimpleNamespace

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from tissuefem.engine import linsolve
from tissuefem.surgery.scene import Scene
from tissuefem.surgery.simulation import Simulation
from tissuefem.workbook.bench.scenes import variants
from tissuefem.workbook.timestepping import flap_drag

RANKS = (0, 64)
COUNT = {"updates": 0}  # back-substitutions made by the updates


class UpdatedFactorization:
    """A factorization ``factor`` of ``A0``, kept with it, made exact again for a later ``A`` of the same pattern on
    the set ``S`` of at most ``rank`` unknowns whose diagonal changed by more than ``threshold`` of its old value:
    with ``C = (A - A0)[S, S]``, ``U`` the identity's columns at ``S`` and ``W = A0^-1 U`` (one back-substitution
    per unknown, kept as long as the factorization),

        (A0 + U C U^T)^-1 r = z - W (I + C W[S])^-1 C z[S],   z = A0^-1 r.

    The couplings of ``S`` to the other unknowns are left to CG; an update that would make the preconditioner
    indefinite, or (nearly) singular, is not made."""

    def __init__(self, factor, A0, rank=64, threshold=0.5):
        self.factor, self.A0 = factor, sp.csr_matrix(A0, copy=True)
        self.rank, self.threshold = int(rank), float(threshold)
        self.diagonal = np.abs(self.A0.diagonal())
        self.columns = {}  # unknown q -> A0^-1 e_q
        self.current = None  # (S, W, C, LU of I + C W[S]) of the last update, or None: the factorization alone

    @property
    def updated(self):
        """How many unknowns the last :meth:`update` corrected."""
        return 0 if self.current is None else self.current[0].size

    def update(self, A, limit=None):
        """Correct for ``A`` with at most ``limit`` new back-substitutions; returns how many it made."""
        self.current, A0 = None, self.A0
        if self.rank <= 0 or A.shape != A0.shape or A.nnz != A0.nnz or not (
                np.array_equal(A.indptr, A0.indptr) and np.array_equal(A.indices, A0.indices)):
            return 0
        change = sp.csr_matrix((A.data - A0.data, A0.indices, A0.indptr), shape=A.shape)
        grown = np.abs(change.diagonal())
        S = np.flatnonzero(grown > self.threshold * self.diagonal)
        S = S[np.argsort(-grown[S] / np.maximum(self.diagonal[S], 1e-300))[:self.rank]]
        missing = [q for q in S.tolist() if q not in self.columns]
        if limit is not None and len(missing) > limit:
            S, missing = np.setdiff1d(S, missing[limit:]), missing[:limit]
        S = np.sort(S)
        for q in missing:
            e = np.zeros(A.shape[0])
            e[q] = 1.0
            self.columns[q] = np.asarray(self.factor.solve(e), dtype=float)
        if S.size == 0:
            return len(missing)
        W = np.column_stack([self.columns[q] for q in S.tolist()])
        C, G = change[S][:, S].toarray(), W[S]  # G = (A0^-1)[S, S]; A0 + U C U^T > 0 iff G + G C G > 0
        try:
            np.linalg.cholesky(0.5 * (G + G.T) + G @ C @ G.T)
        except np.linalg.LinAlgError:
            return len(missing)
        lu = sla.lu_factor(np.eye(S.size) + C @ G)
        if np.all(np.isfinite(lu[0])) and np.abs(np.diag(lu[0])).min() >= 1e-12:
            self.current = (S, W, C, lu)
        return len(missing)

    def solve(self, r):
        z = np.asarray(self.factor.solve(r), dtype=float)
        if self.current is None:
            return z
        S, W, C, lu = self.current
        return z - W @ sla.lu_solve(lu, C @ z[S])


@contextlib.contextmanager
def updates(rank):
    """Within: every ReusedFactorization keeps an :class:`UpdatedFactorization` of ``rank`` (0: the library as it
    is), updated for the matrix before each CG solve: its public ``direct`` backend is seen wrapped."""
    direct, pcg = linsolve.ReusedFactorization.direct, linsolve.pcg

    def wrapped(solver):
        backend = direct.fget(solver)
        return SimpleNamespace(name=backend.name,
                               factorize=lambda A: UpdatedFactorization(backend.factorize(A), A, rank))

    def updated_pcg(A, b, precondition, **options):
        owner = getattr(precondition, "__self__", None)
        if isinstance(owner, UpdatedFactorization):
            COUNT["updates"] += owner.update(A)
        return pcg(A, b, precondition, **options)

    if rank > 0:
        linsolve.ReusedFactorization.direct, linsolve.pcg = property(wrapped, direct.fset), updated_pcg
    try:
        yield
    finally:
        linsolve.ReusedFactorization.direct, linsolve.pcg = direct, pcg


def run(data, options, rank, frames):
    COUNT["updates"] = 0
    with updates(rank):
        sim = Simulation(Scene.from_dict(data), **options)
        try:
            reports = flap_drag(sim, frames)
        finally:
            sim.solver.linear.close()  # (inside: a background factorization under way is a wrapped one)
    return {"ms": np.median([1e3 * r.elapsed for r in reports]),
            "newton": np.mean([r.newton_iterations for r in reports]),
            "cg": np.mean([r.newton.linear_iterations for r in reports]), "updates": COUNT["updates"] / frames}


def main(n_triangles=8000, frames=30, repeats=3):
    [(name, data, options)] = [v for v in variants(n_triangles) if v[0] == "+ probe"]
    runs = {rank: [] for rank in RANKS}
    for r in range(repeats):
        for rank in RANKS:
            runs[rank].append(run(data, options, rank, frames))
            print(f"round {r + 1} rank {rank:3d} " + " ".join(f"{k} {v:.2f}" for k, v in runs[rank][-1].items()),
                  flush=True)
    print(f"\n{name} at {n_triangles} triangles, {frames} frames, medians of {repeats} runs")
    print("| update rank | median ms/frame | Newton/frame | CG iterations/frame | update back-substitutions/frame |")
    print("|---:|---:|---:|---:|---:|")
    for rank, rows in runs.items():
        med = {k: float(np.median([row[k] for row in rows])) for k in rows[0]}
        print(f"| {rank} | {med['ms']:.1f} | {med['newton']:.2f} | {med['cg']:.1f} | {med['updates']:.1f} |")


if __name__ == "__main__":
    main(*(int(a) for a in sys.argv[1:]))
