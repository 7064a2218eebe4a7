"""A step too long for a frame runs off it: with every linear solver the real-time loop offers, a frame whose step
start and first Newton iteration (by the learned costs; the first step by its predicted cost) take too much of the
budget hands the step to a worker, on a budget of its own, and returns at once; a later frame commits the step. All on a fake clock: the assembly moves it by a set cost, and the
worker runs when the test says."""

import math

import numpy as np
import pytest

from tissuefem import Handle, LinearElastic, LinearSolver, Model, NeoHookean, RealtimeSolver, flap
from tissuefem.engine import linsolve, realtime as realtime_module
from tissuefem.engine.realtime import LINEAR_SOLVERS, OFF_FRAME_FRAMES
from tissuefem.engine.stepping import accuracy_summary

from helpers import Launcher

BUDGET = 1 / 30
SOLVERS = [name for name in LINEAR_SOLVERS if "pardiso" not in name or linsolve.available("pardiso")]


class Clock:
    def __init__(self):
        self.now = 0.0

    def __call__(self):
        return self.now


def model(name, dt=1 / 30):
    material = LinearElastic.from_young(1000.0, 0.3) if name == "constant" else NeoHookean.from_young(1000.0, 0.3)
    return Model(flap(n_triangles=200), material, handles=[Handle("fixed"), Handle("handle")], dt=dt)


def realtime(name, assembly_cost, budget=BUDGET, dt=1 / 30):
    """A real-time solver of ``name`` on a fake clock whose tangent assembly costs ``assembly_cost`` seconds."""
    clock, launcher, m = Clock(), Launcher(), model(name, dt)
    inner = m.hessian

    def costly_assembly(u, *args, **kw):
        clock.now += assembly_cost
        return inner(u, *args, **kw)

    m.hessian = costly_assembly
    rt = RealtimeSolver(m, budget=budget, clock=clock, linear_solver=LinearSolver(name, launch=launcher), rtol=1e-8,
                        launch=launcher)
    return rt, clock, launcher


TARGET = np.array([0.3, 0.2])


@pytest.mark.parametrize("name", SOLVERS)
def test_a_step_too_long_for_a_frame_runs_off_it_and_a_later_frame_commits_it(name, monkeypatch):
    monkeypatch.setattr(realtime_module, "OFF_FRAME_FRAMES", 1000)  # a budget off the frame the whole solve fits
    rt, clock, launcher = realtime(name, assembly_cost=2 * BUDGET)
    first = rt.frame({1: TARGET})  # no cost learned yet: the first frame runs on the frame and learns
    assert first.off_frame == "" and first.committed and "assembly" in first.unestimated
    rt.linear.invalidate()  # (a kept constant factorization needs no assembly: as if another set were held)
    assert rt.too_long()  # one assembly alone is two frames
    steps, u, v, v_previous, t = rt.steps, rt.u.copy(), rt.v.copy(), rt.v_previous, rt.time
    waiting = [rt.frame({1: TARGET}) for _ in range(3)]  # the first launches the step, the others find it running
    assert len(launcher.jobs) == 1 and rt.running
    for r in waiting:  # no work on the frame: the last committed state, shown at once
        assert r.off_frame == "running" and not r.committed and r.elapsed == 0.0
        assert r.step == steps and "step running off the frame" in r.accuracy
    assert np.array_equal(rt.u, u) and rt.steps == steps
    launcher.finish()
    done = rt.frame({1: TARGET})
    assert done.off_frame == "finished" and done.committed and done.converged and done.elapsed == 0.0
    assert done.off_frame_seconds >= 2 * BUDGET and "ran off the frame" in done.accuracy
    assert rt.steps == steps + 1 and not rt.running and not np.array_equal(rt.u, u)
    # its budget held the whole solve: the same state as an unbudgeted solver's from the same start
    reference = RealtimeSolver(model(name), budget=math.inf, linear_solver=name, rtol=1e-8)
    reference.set_state(u, v, v_previous=v_previous, time_=t, steps=steps)
    expected = reference.frame({1: TARGET})
    assert expected.converged
    scale = float(np.max(np.abs(expected.x)))
    np.testing.assert_allclose(rt.u, expected.x, atol=1e-6 * scale)


@pytest.mark.parametrize("name", SOLVERS)
def test_no_frame_after_the_first_overruns_while_steps_run_off_it(name):
    rt, clock, launcher = realtime(name, assembly_cost=2 * BUDGET)
    reports = []
    for f in range(30):
        if name == "constant":
            rt.linear.invalidate()  # each step assembles and factorizes (as if the held set changed each time)
        reports.append(rt.frame({1: TARGET * min(1.0, (f + 1) / 10)}))
        if f % 3 == 2:
            launcher.finish()  # the worker takes three frames for one step
        assert np.all(np.isfinite(rt.u)) and np.all(np.isfinite(rt.v))
    assert all(r.elapsed <= BUDGET for r in reports[1:])
    committed = [r for r in reports[1:] if r.committed]
    assert len(committed) >= 8 and all(r.off_frame == "finished" for r in committed)
    assert all(r.off_frame_seconds <= r.budget + 1e-9 and np.isfinite(r.scaled_residual) for r in committed)
    assert rt.steps == 1 + len(committed)  # simulated time runs slower than the frames: a step per ~3 frames
    assert rt.time == pytest.approx(rt.steps / 30)
    assert "step off the frame" in accuracy_summary(reports)["undone_reasons"]


def test_targets_given_while_a_step_runs_are_the_next_steps():
    rt, clock, launcher = realtime("reuse", assembly_cost=2 * BUDGET, dt=None)
    rt.frame({1: TARGET})
    assert rt.frame({1: TARGET}).off_frame == "running"
    with pytest.raises(ValueError):
        rt.frame({7: TARGET})  # refused at once, by name: the running step and the targets stay
    assert rt.running and np.array_equal(rt.model.handles[1].target, TARGET)
    rt.frame({1: 2 * TARGET})  # kept for the next step
    launcher.finish()
    assert rt.frame().off_frame == "finished"
    assert rt.frame().off_frame == "running"  # the next step, towards the new target
    launcher.finish()
    assert rt.frame().off_frame == "finished"
    fixed, values = rt.model.prescribed()  # the handles where the new target puts them
    assert np.allclose(rt.u[fixed], values) and np.any(values)
    rt.model.handles[1].move(TARGET)
    assert not np.allclose(rt.u[fixed], rt.model.prescribed()[1])


def test_a_failed_step_off_the_frame_keeps_the_state_and_raises_when_settled():
    rt, clock, launcher = realtime("reuse", assembly_cost=2 * BUDGET)
    rt.frame({1: TARGET})
    u, v, steps, t = rt.u.copy(), rt.v.copy(), rt.steps, rt.time
    inner = rt.model.gradient
    rt.model.gradient = lambda x: (_ for _ in ()).throw(RuntimeError("the gradient failed"))
    assert rt.frame({1: 2 * TARGET}).off_frame == "running"
    launcher.finish()
    rt.model.gradient = inner
    with pytest.raises(RuntimeError, match="gradient failed"):
        rt.frame()
    assert np.array_equal(rt.u, u) and np.array_equal(rt.v, v) and (rt.steps, rt.time) == (steps, t)
    assert not rt.running
    assert rt.frame().off_frame == "running"  # and the loop goes on
    launcher.finish()
    assert rt.frame().committed


def test_a_failed_step_off_the_frame_keeps_the_targets_given_while_it_ran():
    rt, clock, launcher = realtime("reuse", assembly_cost=2 * BUDGET)
    rt.frame({1: TARGET})
    inner = rt.model.gradient

    def failing(x):  # a frame moves the handle while the step runs, then the step fails
        rt.model.set_targets({1: 3 * TARGET})
        raise RuntimeError("the gradient failed")

    rt.model.gradient = failing
    assert rt.frame({1: 2 * TARGET}).off_frame == "running"
    launcher.finish()
    rt.model.gradient = inner
    with pytest.raises(RuntimeError, match="gradient failed"):
        rt.frame()
    assert np.array_equal(rt.model.handles[1].target, 3 * TARGET), "the newest target, not the failed step's"


def test_changing_the_state_waits_for_the_running_step():
    rt, clock, launcher = realtime("reuse", assembly_cost=2 * BUDGET)
    rt.frame({1: TARGET})
    rt.frame({1: TARGET})
    assert rt.running and launcher.running() == 1
    rt.reset()  # commits the running step first (its worker is joined), then sets the state
    assert not rt.running and launcher.running() == 0 and rt.steps == 2
    assert not np.any(rt.u)


def test_off_frame_false_keeps_every_step_on_the_frame():
    rt, clock, launcher = realtime("reuse", assembly_cost=2 * BUDGET)
    rt.off_frame = False
    reports = [rt.frame({1: TARGET}) for _ in range(3)]
    assert all(r.off_frame == "" and r.committed for r in reports) and not launcher.jobs
    with pytest.raises(ValueError, match="off_frame"):
        RealtimeSolver(model("reuse"), off_frame="yes")
    with pytest.raises(ValueError, match="launch"):
        RealtimeSolver(model("reuse"), launch=3)


def test_a_simulation_change_commits_the_running_step_first():
    from tissuefem import Simulation, demo_scene

    sim = Simulation(demo_scene())
    launcher = Launcher()
    sim.solver.launch = launcher
    sim.frame()  # learns the costs
    sim.solver.costs["assembly"] = 10.0  # as if one assembly took ten seconds: every step leaves the frame
    assert sim.frame().off_frame == "running" and sim.solver.running
    frames = sim.frames
    sim.add_probe((0.5, 0.5), 0.1)  # a change of the model: the step is committed first, then the probe added
    assert launcher.running() == 0 and not sim.solver.running and sim.frames == frames + 1
    assert sim.solver.launch is launcher  # carried to the new solver


class SlowSolves:
    """A direct backend whose back-substitutions cost ``cost`` fake seconds (factorizations nothing)."""

    def __init__(self, inner, clock, cost):
        self.inner, self.clock, self.cost, self.name = inner, clock, cost, inner.name

    def factorize(self, A):
        factor, clock, cost = self.inner.factorize(A), self.clock, self.cost

        class Factor:
            def solve(self, b):
                clock.now += cost
                return factor.solve(b)
        return Factor()


@pytest.mark.parametrize("name", SOLVERS)
def test_a_back_substitution_longer_than_a_frame_sends_the_second_frame_off_it(name):
    # the first frame factorizes and back-substitutes (no CG iteration learned yet): a CG iteration costs at
    # least its preconditioner's back-substitution, so the second frame does not start one on the frame
    rt, clock, launcher = realtime(name, assembly_cost=0.001)
    backend = rt.linear.backend
    if isinstance(backend, linsolve.ReusedFactorization):
        backend.direct = SlowSolves(backend.direct, clock, 2 * BUDGET)
    else:
        rt.linear.backend = SlowSolves(backend, clock, 2 * BUDGET)
    first = rt.frame({1: TARGET})
    assert first.elapsed >= 2 * BUDGET and "cg-iteration" not in rt.costs
    reports = []
    for f in range(12):
        reports.append(rt.frame({1: TARGET}))
        if f % 3 == 2:
            launcher.finish()
    assert all(r.elapsed <= BUDGET for r in reports)
    assert reports[0].off_frame == "running" and any(r.off_frame == "finished" and r.committed for r in reports)


@pytest.mark.parametrize("name", [name for name in SOLVERS if name != "constant"])  # (a linear model: one iteration)
def test_a_step_whose_solve_takes_many_frames_commits_within_its_own_budget(name):
    # one assembly is two frames: the whole solve (rtol 1e-8) takes many more than the step's budget off the frame
    rt, clock, launcher = realtime(name, assembly_cost=2 * BUDGET)
    rt.frame({1: TARGET})
    rt.linear.invalidate()
    steps, u, v, v_previous, t = rt.steps, rt.u.copy(), rt.v.copy(), rt.v_previous, rt.time
    budget = rt.off_frame_budget()
    assert budget >= OFF_FRAME_FRAMES * BUDGET and budget >= 2 * 2 * BUDGET  # twice an iteration (its assembly)
    assert rt.frame({1: TARGET}).off_frame == "running"
    launcher.finish()
    done = rt.frame({1: TARGET})
    assert done.off_frame == "finished" and done.committed and rt.steps == steps + 1
    assert done.budget == budget and done.off_frame_seconds <= budget + 1e-9  # it stopped on its own budget
    assert done.newton_iterations >= 1 and done.residual_norm < done.initial_residual  # an improved state
    if not done.converged:  # its residual reported: how far from converged
        assert done.status == "budget" and f"rel. residual {done.scaled_residual:.1e}" in done.accuracy
    assert "simulated time slower than real time" in done.accuracy
    # the whole solve, unbudgeted on the same clock, takes longer than the step's own budget
    reference, ref_clock, _ = realtime(name, assembly_cost=2 * BUDGET)
    reference.budget = math.inf
    reference.set_state(u, v, v_previous=v_previous, time_=t, steps=steps)
    full = reference.frame({1: TARGET})
    assert full.converged and full.elapsed > budget and full.newton_iterations > done.newton_iterations
    assert rt.frame({1: TARGET}).off_frame == "running"  # and the next step starts at once


def test_where_steps_fit_the_frame_budgeted_and_unbudgeted_frames_agree():
    # cheap pieces (as at 2k and 8k triangles): every step converges on the frame, none leaves it
    rt, clock, launcher = realtime("reuse", assembly_cost=0.001)
    free, _, _ = realtime("reuse", assembly_cost=0.001)
    free.budget = math.inf
    for f in range(8):
        targets = {1: TARGET * min(1.0, (f + 1) / 4)}
        a, b = rt.frame(targets), free.frame(targets)
        assert a.off_frame == "" and a.converged and b.converged and a.elapsed <= BUDGET
        np.testing.assert_allclose(rt.u, free.u, atol=1e-9 * max(1.0, float(np.max(np.abs(free.u)))))
    assert not launcher.jobs and not rt.too_long()


@pytest.mark.parametrize("energy_cost, off", [(0.001, False), (0.005, True)])
def test_a_warm_start_that_leaves_too_little_room_sends_the_step_off_the_frame(energy_cost, off):
    # the assembly costs 10 ms and each energy evaluation energy_cost (the solves nothing): the warm start weighs
    # three starts, the line search one more, so the start and one Newton iteration are learned to cost about 10 ms
    # and 4 energies: 14 ms (fits 0.8 of the budget, 26.7 ms) or 30 ms (does not)
    rt, clock, launcher = realtime("reuse", assembly_cost=0.010)
    inner = rt.model.energy

    def costly_energy(u, *args, **kw):
        clock.now += energy_cost
        return inner(u, *args, **kw)

    rt.model.energy = costly_energy
    for f in range(4):  # the first frames learn the costs (a step off the frame is finished at once)
        rt.frame({1: TARGET * (f + 1) / 8})
        launcher.finish()
    assert rt.costs["start"] >= 2 * energy_cost  # (two or three starts weighed)
    assert rt.too_long() == off
    report = rt.frame({1: TARGET * 5 / 8})
    assert (report.off_frame == "running") == off
    if not off:
        assert report.committed and report.elapsed <= BUDGET


@pytest.mark.parametrize("assembly_cost, back", [(0.007, True), (0.010, False)])
def test_costs_learned_off_the_frame_count_slowed_down_for_the_frame(assembly_cost, back, monkeypatch):
    # a model whose first step is predicted too long for the frame: it runs off it and learns the costs there
    monkeypatch.setattr(realtime_module, "FIRST_STEP_COST", 100 * BUDGET / model("reuse").n_dofs)
    rt, clock, launcher = realtime("reuse", assembly_cost=assembly_cost)
    assert rt.frame({1: TARGET}).off_frame == "running"
    launcher.finish()
    assert rt.frame({1: TARGET}).off_frame == "finished"
    assert rt.off_costs["assembly"] == pytest.approx(assembly_cost) and not rt.costs
    # one Newton iteration costs about one assembly here: 7 ms three times fits 0.8 of the budget (26.7 ms), 10 not
    assert rt.too_long() == (not back)
    report = rt.frame({1: TARGET})
    assert (report.off_frame == "") == back
    if back:  # on the frame, its pieces start from the costs off it, slowed down, and learn their own
        assert report.committed and report.elapsed <= BUDGET
        assert assembly_cost <= rt.costs["assembly"] < realtime_module.OFF_FRAME_SLOWDOWN * assembly_cost
