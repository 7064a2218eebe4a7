"""A budgeted frame keeps its budget with every linear solver the real-time loop offers: no piece of work starts
that its learned cost says cannot end in time; a factorization that does not fit runs off the frame. All on a fake
clock: the work (an assembly, a factorization, a back-substitution) moves it by set costs; nothing here is timed."""

import math

import numpy as np
import pytest

from tissuefem import Handle, LinearElastic, LinearSolver, Model, NeoHookean, RealtimeSolver, flap
from tissuefem.engine import linsolve
from tissuefem.engine import realtime as realtime_module
from tissuefem.engine.realtime import LINEAR_SOLVERS

BUDGET = 1 / 30
ASSEMBLY, BACK_SUBSTITUTION = 0.002, 0.001
SOLVERS = [name for name in LINEAR_SOLVERS if "pardiso" not in name or linsolve.available("pardiso")]
REUSING = [name for name in SOLVERS if name.startswith("reuse")]
AFRESH = [name for name in SOLVERS if not name.startswith(("reuse", "constant"))]


class Clock:
    """Fake seconds: only the simulated work moves them, and work done off the frame (``on`` False) does not."""

    def __init__(self):
        self.now, self.on = 0.0, True

    def __call__(self):
        return self.now

    def spend(self, seconds):
        if self.on:
            self.now += seconds


class CostlyFactor:
    def __init__(self, factor, clock, cost):
        self.factor, self.clock, self.cost = factor, clock, cost

    def solve(self, b):
        self.clock.spend(self.cost)
        return self.factor.solve(b)


class Costly:
    """A direct backend whose factorizations and back-substitutions cost fake time."""

    def __init__(self, inner, clock, factor_cost):
        self.inner, self.clock, self.factor_cost, self.name = inner, clock, factor_cost, inner.name

    def factorize(self, A):
        self.clock.spend(self.factor_cost)
        return CostlyFactor(self.inner.factorize(A), self.clock, BACK_SUBSTITUTION)


class Job:
    """Work off the frame; ``counted``: its time moves the clock (a whole step's, whose costs the solver learns),
    else not (a factorization: the second core's time is not the frame's)."""

    def __init__(self, work, clock, frame, counted=False):
        self.work, self.clock, self.frame, self.done, self.counted = work, clock, frame, False, counted

    def is_alive(self):
        return not self.done

    def join(self):
        if not self.done:
            self.clock.on = self.counted
            try:
                self.work()
            finally:
                self.clock.on, self.done = True, True


class Launcher:
    """Background work that finishes when the test says (``synchronous``: at once)."""

    def __init__(self, clock, synchronous=False):
        self.clock, self.synchronous, self.jobs, self.frame = clock, synchronous, [], 0

    def __call__(self, work, counted=False):
        job = Job(work, self.clock, self.frame, counted)
        self.jobs.append(job)
        if self.synchronous:
            job.join()
        return job

    def step(self, work):
        """Launch a whole step off the frame (its pieces' costs are learned on the clock)."""
        return self(work, counted=True)

    def finish(self, frames_old=0):
        """Finish the jobs started at least ``frames_old`` frames ago."""
        for job in self.jobs:
            if self.frame - job.frame >= frames_old:
                job.join()

    def running(self):
        return sum(job.is_alive() for job in self.jobs)


def model(dt=1 / 30, material=None, n_triangles=200):
    return Model(flap(n_triangles=n_triangles), material or NeoHookean.from_young(1000.0, 0.3),
                 handles=[Handle("fixed"), Handle("handle")], dt=dt)


def realtime(m, name, *, factor_cost, budget=BUDGET, synchronous=False, eager=False):
    """A real-time solver with ``name``'s linear solver on a fake clock; ``eager``: a reused factorization is due
    after 2 CG iterations (so refactorizations come often)."""
    clock = Clock()
    launcher = Launcher(clock, synchronous)
    linear = LinearSolver(name, launch=launcher)
    if isinstance(linear.backend, linsolve.ReusedFactorization):
        linear.backend.direct = Costly(linear.backend.direct, clock, factor_cost)
        if eager:
            linear.backend.refresh_after = linear.backend.background_after = 2
    else:
        linear.backend = Costly(linear.backend, clock, factor_cost)
    inner = m.hessian

    def costly_assembly(u, *args, **kw):
        clock.spend(ASSEMBLY)
        return inner(u, *args, **kw)

    m.hessian = costly_assembly
    return (RealtimeSolver(m, budget=budget, clock=clock, linear_solver=linear, rtol=1e-8, launch=launcher.step),
            clock, launcher)


def path(t):
    return np.array([0.3 * np.sin(np.pi * t / 2), 0.4 * np.sin(np.pi * t / 4)])


def frame(rt, launcher, target):
    report = rt.frame({1: target})
    launcher.frame += 1
    return report


@pytest.mark.parametrize("name", SOLVERS)
def test_no_budgeted_frame_overruns_when_a_factorization_costs_three_frames(name):
    m = model(material=LinearElastic.from_young(1000.0, 0.3) if name == "constant" else None)
    rt, clock, launcher = realtime(m, name, factor_cost=3 * BUDGET, eager=True)
    reports = []
    for f in range(40):
        reports.append(frame(rt, launcher, path(2 * (f + 1) / 30)))
        launcher.finish(frames_old=3)  # the second core takes three frames for one factorization
        assert np.all(np.isfinite(rt.u)) and np.all(np.isfinite(rt.v))
    first, later = reports[0], reports[1:]
    # the first frame ever has no estimate: it factorizes whatever that costs, and says so
    assert "factorization" in first.unestimated and first.elapsed > BUDGET
    assert "| unestimated " in first.accuracy and "factorization" in first.accuracy.split("| unestimated ")[1]
    for r in later:  # every later frame: within the budget but for one back-substitution
        assert r.elapsed <= BUDGET + BACK_SUBSTITUTION + 1e-12, (r, r.skipped)
        assert "factorization" not in r.unestimated and (r.committed or r.off_frame == "running")
    costs = {**rt.off_costs, **rt.costs}  # learned on the frame, or off it
    assert costs["factorization"] == pytest.approx(3 * BUDGET) and costs["assembly"] == pytest.approx(ASSEMBLY)
    if name in AFRESH:  # a factorization each solve: one Newton iteration never fits, so each step runs off the
        # frame (the frames show the last state meanwhile) and a frame after it commits it, within its own budget
        # (converged or not: its residual says how far)
        assert all(r.off_frame in ("running", "finished") for r in later)
        assert all("off the frame" in r.accuracy for r in later)
        finished = [r for r in later if r.off_frame == "finished"]
        assert len(finished) >= len(later) // 5 and all(r.committed and r.newton_iterations >= 1 for r in finished)
        assert all(r.off_frame_seconds <= r.budget + 1e-9 and r.residual_norm < r.initial_residual for r in finished)
        assert all(not r.committed for r in later if r.off_frame == "running")
    elif name.startswith("reuse"):
        backend = rt.linear.backend
        assert backend.background_factorizations >= 1 and backend.factorizations == 1
        assert sum(r.converged for r in later) >= len(later) // 2


@pytest.mark.parametrize("name", REUSING)
def test_frames_make_progress_with_the_old_factorization_and_converge_once_a_new_one_lands(name):
    m = model(dt=None)
    rt, clock, launcher = realtime(m, name, factor_cost=3 * BUDGET, eager=True)
    frame(rt, launcher, np.array([0.02, 0.0]))  # the first frame factorizes near rest
    target = np.array([1.2, 0.8])  # far from there: the kept factorization is due again at once
    reports = [frame(rt, launcher, target) for _ in range(4)]  # no background work finishes meanwhile
    assert launcher.running() == 1 and rt.linear.backend.factorizations == 1
    assert all(r.elapsed <= BUDGET + BACK_SUBSTITUTION + 1e-12 for r in reports)
    # the same potential each frame: the committed energy never rises, and the residual falls to convergence
    energies = [r.energy for r in reports]
    assert all(b <= a + 1e-12 * abs(a) for a, b in zip(energies, energies[1:]))
    assert reports[-1].converged and reports[-1].residual_norm < reports[0].initial_residual
    # another set of held dofs (as after a grab): no factorization at all, and making one does not fit
    rt.linear.invalidate()  # (the factorization under way is for the old set: it is dropped)
    target, started = np.array([1.0, 0.6]), len(launcher.jobs)
    waiting = [frame(rt, launcher, target) for _ in range(3)]
    assert len(launcher.jobs) == started + 1  # one factorization for the new set, started by the first frame
    for r in waiting:
        assert r.status == "budget" and "factorization" in r.skipped and r.committed
        assert r.elapsed <= BUDGET + BACK_SUBSTITUTION + 1e-12
    for _ in range(10):
        launcher.finish()
        report = frame(rt, launcher, target)
        assert report.elapsed <= BUDGET + BACK_SUBSTITUTION + 1e-12
        if report.converged:
            break
    assert report.converged
    backend = rt.linear.backend
    assert backend.factorizations == 1 and backend.background_factorizations >= 1  # all made off the frame


def test_a_constant_factorization_that_does_not_fit_is_made_in_the_background():
    m = model(material=LinearElastic.from_young(1000.0, 0.3))
    rt, clock, launcher = realtime(m, "constant", factor_cost=3 * BUDGET)
    assert frame(rt, launcher, path(1 / 30)).converged  # the first frame factorizes (no estimate yet)
    rt.linear.invalidate()  # as when another set of dofs is held: the kept factorization is gone
    waiting = [frame(rt, launcher, path((f + 2) / 30)) for f in range(3)]
    assert launcher.running() == 1
    for r in waiting:
        assert r.status == "budget" and r.skipped == ["factorization"] and r.committed
        assert r.elapsed <= BUDGET
    launcher.finish()
    assert frame(rt, launcher, path(5 / 30)).converged
    assert rt.linear.factorizations == 1


@pytest.mark.parametrize("name", SOLVERS)
def test_with_costs_that_fit_budgeted_and_unbudgeted_frames_are_the_same(name):
    material = (lambda: LinearElastic.from_young(1000.0, 0.3)) if name == "constant" else (lambda: None)
    runs = []
    for budget in (BUDGET, math.inf):
        rt, clock, launcher = realtime(model(material=material()), name, factor_cost=BUDGET / 8, budget=budget,
                                       synchronous=True)
        reports = [frame(rt, launcher, path(2 * (f + 1) / 30)) for f in range(12)]
        assert all(r.converged for r in reports)
        if budget < math.inf:
            assert all(r.elapsed <= budget for r in reports[1:])
        runs.append((rt.u.copy(), rt.v.copy()))
    assert np.array_equal(runs[0][0], runs[1][0]) and np.array_equal(runs[0][1], runs[1][1])


def test_a_deadline_learns_costs_and_says_what_fits():
    now = [0.0]
    costs = {}
    deadline = linsolve.Deadline(lambda: now[0], 1.0, costs)
    assert deadline.fits("factorization") and deadline.unestimated == ["factorization"]  # nothing learned yet
    deadline.record("factorization", 0.6)
    deadline.record("factorization", 0.2)
    assert costs["factorization"] == pytest.approx(0.4)  # an exponential moving average of the last runs
    deadline.record("cg-iteration", 0.05, 5)
    assert deadline.room("cg-iteration") == 100
    now[0] = 0.7
    assert not deadline.fits("factorization") and deadline.fits("cg-iteration")
    assert deadline.room("cg-iteration") == 30
    deadline.first = True  # the first iteration's short pieces always run, a long one only if it fits
    now[0] = 2.0
    assert deadline.fits("assembly", "cg-iteration") and not deadline.fits("factorization")
    assert linsolve.Deadline(lambda: now[0]).fits("factorization")  # no deadline: everything fits


# --- the first frame of a large model --------------------------------------------------------------------------

def large(monkeypatch):
    """As if the test's model were larger than a size whose first step surely fits a frame (its first step is
    predicted to cost 100 frames)."""
    monkeypatch.setattr(realtime_module, "FIRST_STEP_COST", 100 * BUDGET / model().n_dofs)


@pytest.mark.parametrize("name", SOLVERS)
def test_the_first_frame_of_a_large_model_does_not_overrun(name, monkeypatch):
    large(monkeypatch)
    m = model(material=LinearElastic.from_young(1000.0, 0.3) if name == "constant" else None)
    assert m.n_dofs * realtime_module.FIRST_STEP_COST > BUDGET
    rt, clock, launcher = realtime(m, name, factor_cost=3 * BUDGET)
    first = frame(rt, launcher, path(2 / 30))  # nothing learned: the step runs off the frame, where it learns
    assert first.off_frame == "running" and first.elapsed <= BUDGET and not first.committed
    assert not first.unestimated and rt.steps == 0
    reports = [first]
    for f in range(1, 30):
        reports.append(frame(rt, launcher, path(2 * (f + 1) / 30)))
        launcher.finish(frames_old=3)
        assert np.all(np.isfinite(rt.u))
    assert all(r.elapsed <= BUDGET + BACK_SUBSTITUTION + 1e-12 for r in reports)
    # every piece on a frame had its cost learned (a step off the frame learns them: its report may list some)
    assert not any(r.unestimated for r in reports if r.off_frame != "finished")
    assert reports[1].off_frame == "running" and any(r.off_frame == "finished" and r.committed for r in reports)
    assert rt.off_costs["factorization"] == pytest.approx(3 * BUDGET) and rt.steps >= 3  # learned off the frame


def test_a_failed_first_step_off_the_frame_keeps_the_state(monkeypatch):
    large(monkeypatch)
    rt, clock, launcher = realtime(model(), "reuse", factor_cost=BUDGET / 8)
    inner = rt.model.gradient
    rt.model.gradient = lambda x: (_ for _ in ()).throw(RuntimeError("the gradient failed"))
    assert frame(rt, launcher, path(2 / 30)).off_frame == "running"
    launcher.finish()
    rt.model.gradient = inner
    with pytest.raises(RuntimeError, match="gradient failed"):
        frame(rt, launcher, path(4 / 30))
    assert not np.any(rt.u) and not np.any(rt.v) and (rt.steps, rt.time) == (0, 0.0) and not rt.running
    assert frame(rt, launcher, path(4 / 30)).off_frame == "running"  # still nothing learned: off the frame again
    launcher.finish()
    assert frame(rt, launcher, path(6 / 30)).committed and rt.steps == 1


def test_an_unbudgeted_first_step_of_a_large_model_stays_on_the_frame(monkeypatch):
    large(monkeypatch)
    rt, clock, launcher = realtime(model(), "reuse", factor_cost=BUDGET / 8, budget=1e9)  # (a scene's "none")
    first = frame(rt, launcher, path(2 / 30))
    assert first.off_frame == "" and first.converged and not launcher.jobs
