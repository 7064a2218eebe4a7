"""The real-time-budget solver, driven by a fake clock (deterministic: no test here measures speed)."""

import math
import threading

import numpy as np
import pytest

from tissuefem import (ITFClamped, Handle, LinearSolver, Model, NeoHookean, RealtimeSolver, StableNeoHookean, Stepper,
                       flap, solve)
from tissuefem.engine import linsolve

E_MOD, NU = 1000.0, 0.3


class FakeClock:
    """Time moves only when the simulated work says so."""

    def __init__(self):
        self.now = 0.0

    def __call__(self):
        return self.now


class ClockedSuperLU(linsolve.SuperLU):
    """SuperLU whose factorizations and back-substitutions cost fake time."""

    def __init__(self, clock, factor_cost=0.010, solve_cost=0.001):
        super().__init__()
        self.clock, self.factor_cost, self.solve_cost = clock, factor_cost, solve_cost

    def factorize(self, A):
        if threading.current_thread() is threading.main_thread():  # work off the frame costs the frame nothing
            self.clock.now += self.factor_cost
        factor = super().factorize(A)
        clock, cost = self.clock, self.solve_cost

        class Timed:
            def solve(self, b):
                clock.now += cost
                return factor.solve(b)

        return Timed()


class TimedReuse(linsolve.ReusedFactorization):
    """Records the fake-clock cost of every linear solve."""

    def __init__(self, clock, **kw):
        super().__init__(ClockedSuperLU(clock), **kw)
        self.clock, self.costs = clock, []

    def solve(self, A, b, **kw):
        t0 = self.clock.now
        out = super().solve(A, b, **kw)
        self.costs.append(self.clock.now - t0)
        return out


def scene(material=None, n_triangles=200, dt=1 / 30, **kw):
    """The standard flap (left edge fixed, a handle on the right edge); backward Euler unless dt is None."""
    mesh = flap(n_triangles=n_triangles)
    return Model(mesh, material or NeoHookean.from_young(E_MOD, NU), handles=[Handle("fixed"), Handle("handle")],
                 dt=dt, **kw)


def path(t):
    """The scripted drag of the standard scene: a slow loop of the right edge."""
    return np.array([0.3 * np.sin(np.pi * t / 2), 0.4 * np.sin(np.pi * t / 4)])


def budgeted(model, budget, assembly_cost=0.002, **kw):
    """A real-time solver on a fake clock: each tangent assembly, factorization and back-substitution costs time."""
    clock = FakeClock()
    linear = TimedReuse(clock)
    inner = model.hessian

    def costly_assembly(u):
        clock.now += assembly_cost
        return inner(u)

    model.hessian = costly_assembly

    def off_frame(work):
        # a step off the frame runs at once, as if on the other core (the frame's clock does not move), and the
        # next frame commits it: on the fake clock the frames take no real time, so a real worker would still run
        # while all the frames after it went by
        now = clock.now
        work()
        clock.now = now
        return Done()

    kw.setdefault("launch", off_frame)
    rt = RealtimeSolver(model, budget=budget, clock=clock, linear_solver=LinearSolver(linear), **kw)
    return rt, clock, linear


class Done:
    """A finished job."""

    is_alive = staticmethod(lambda: False)
    join = staticmethod(lambda: None)


def assert_valid(rt, report):
    assert np.all(np.isfinite(rt.u)) and np.all(np.isfinite(rt.v))
    # not above the start, up to round-off in the energy (its terms cancel at rest: an absolute floor too)
    assert np.isfinite(report.energy)
    assert report.energy <= report.start_energy + 1e-12 * abs(report.start_energy) + 1e-20


# --- budget ------------------------------------------------------------------------------------

@pytest.mark.parametrize("budget", [0.004, 0.012, 0.033])
def test_never_overruns_by_more_than_one_linear_solve(budget):
    rt, clock, linear = budgeted(scene(), budget, rtol=1e-12, atol=0.0)
    n_costs, statuses = 0, set()
    for f in range(40):
        report = rt.frame({1: path(2 * (f + 1) / 30)})
        statuses.add(report.status)
        assert_valid(rt, report)
        frame_costs = linear.costs[n_costs:]
        n_costs = len(linear.costs)
        # the largest single piece of work this frame: one linear solve, or one (fake) assembly
        allowed = max(frame_costs + [0.002])
        assert report.elapsed <= budget + allowed + 1e-12
        if report.status == "budget" and not report.off_frame:  # it stopped because its next pieces (an
            # assembly, a CG step) did not fit (a frame whose step runs off it shows the last state at once)
            assert report.elapsed + 0.002 + 0.001 > budget - 1e-12
    if budget <= 0.012:  # less than a factorization plus a few solves: some frames must stop on the budget
        assert "budget" in statuses


def test_a_frame_that_runs_out_of_budget_stops_at_once_and_says_so():
    rt, clock, linear = budgeted(scene(), budget=0.0105, rtol=1e-12, atol=0.0)
    report = rt.frame({1: (0.2, 0.1)})
    # first step: assembly (2 ms) + factorization (10 ms) -> over budget -> stop
    assert report.status == "budget" and not report.converged
    assert report.newton_iterations == 1 and report.factorizations == 1
    assert report.elapsed == pytest.approx(0.013)
    assert report.residual_norm < report.initial_residual


def test_converged_frames_equal_the_unbudgeted_solution():
    """With the budget to spare, each frame is the backward-Euler step, to the tolerance."""
    rt, _, _ = budgeted(scene(), budget=1.0, rtol=1e-11, atol=0.0)
    reference_model = scene()
    be = Stepper(reference_model, rtol=1e-11, linear_solver="direct")
    for f in range(8):
        target = path(3 * (f + 1) / 30)
        report = rt.frame({1: target})
        step = be.step({"handle1": target})
        assert report.converged and step.converged
        scale = np.max(np.abs(be.u))
        np.testing.assert_allclose(rt.u, be.u, atol=1e-8 * scale)
        np.testing.assert_allclose(rt.v, be.v, atol=1e-7 * scale * 30)


def test_unlimited_budget_with_the_real_clock_converges_every_frame():
    rt = RealtimeSolver(scene(), budget=math.inf)
    reports = rt.run([{1: path((f + 1) / 30)} for f in range(15)])
    assert all(r.converged for r in reports)
    assert all(r.relative_residual <= 1e-6 or r.residual_norm <= 1e-12 for r in reports)
    # the kept factorization is reused across frames: far fewer factorizations than Newton steps
    assert sum(r.factorizations for r in reports) < sum(r.newton_iterations for r in reports) / 3


def test_tiny_budget_stays_valid_and_converges_over_later_frames():
    rt, clock, _ = budgeted(scene(), budget=1e-9, rtol=1e-8, off_frame=False)  # (else each step leaves the frame)
    target = np.array([0.4, 0.3])
    reports = []
    for _ in range(200):
        report = rt.frame({1: target})
        assert_valid(rt, report)
        # one step per frame while there is work: always progress, never more
        assert report.newton_iterations == 1 or (report.converged and report.newton_iterations == 0)
        reports.append(report)
    assert not reports[0].converged
    assert reports[-1].converged
    # it has come to rest at the quasistatic equilibrium under the same handle
    static = scene(dt=None)
    static.handles[1].move(target)
    u_static = solve(static, load_steps=4, rtol=1e-10).u
    np.testing.assert_allclose(rt.u, u_static, atol=1e-5 * np.max(np.abs(u_static)))


def test_unfinished_work_carries_into_the_next_frame():
    rt, clock, _ = budgeted(scene(dt=None), budget=1e-9, rtol=1e-10, atol=0.0, off_frame=False)
    first = rt.frame({1: (0.5, 0.2)})
    second = rt.frame()
    assert second.initial_residual == pytest.approx(first.residual_norm, rel=1e-9)
    assert second.residual_norm < first.residual_norm


# --- hard cases --------------------------------------------------------------------------------

def drag_through(n_frames=300):
    """Right edge dragged left through the whole body and out past the fixed edge, then back and released."""
    targets = []
    for f in range(n_frames):
        s = f / (n_frames - 1)
        if s < 0.5:
            dx = -3.0 * (s / 0.5)  # from x = 2 to x = -1: through the body and out the other side
            dy = 0.3 * np.sin(2 * np.pi * s)
        elif s < 0.8:
            dx = -3.0 * (1 - (s - 0.5) / 0.3)
            dy = 0.0
        else:
            dx = dy = 0.0
        targets.append({1: (dx, dy)})
    return targets


@pytest.mark.parametrize(
    "material",
    [StableNeoHookean.from_young(E_MOD, NU), ITFClamped(NeoHookean.from_young(E_MOD, NU)), NeoHookean.from_young(E_MOD, NU)],
    ids=["stable", "itf", "lnJ"],
)
def test_300_frame_drag_through_the_body_stays_finite_and_bounded(material):
    rt, clock, _ = budgeted(scene(material, n_triangles=120), budget=0.02)
    energies, fractions, min_J = [], [], math.inf
    for targets in drag_through():
        report = rt.frame(targets)
        assert_valid(rt, report)
        energies.append(rt.total_energy())
        fractions.append(report.handle_fraction)
        if isinstance(material, NeoHookean) and not isinstance(material, ITFClamped):
            F = rt.model.deformation_gradient(rt.u)
            min_J = min(min_J, float(np.min(F[0, 0] * F[1, 1] - F[0, 1] * F[1, 0])))
    energies = np.array(energies)
    assert np.all(np.isfinite(energies))
    # no blow-up: once released, the energy does not grow past what the drag put in
    released = energies[int(0.8 * len(energies)):]
    assert np.max(released) <= np.max(energies[: int(0.8 * len(energies))]) + 1e-9
    assert released[-1] <= released[0]
    if isinstance(material, NeoHookean) and not isinstance(material, ITFClamped):
        # ln J cannot invert: every accepted state keeps J > 0 (the body folds over itself instead)
        assert min_J > 0
    assert fractions[-1] == 1.0


def test_quasistatic_frames_match_the_quasistatic_solver():
    rt = RealtimeSolver(scene(dt=None), budget=math.inf, rtol=1e-10)
    assert rt.model.inertia is None  # a quasistatic frame builds no mass matrix
    report = rt.frame({1: (0.3, 0.2)})
    static = scene(dt=None)
    static.handles[1].move((0.3, 0.2))
    u = solve(static, load_steps=2, rtol=1e-10).u
    assert report.converged
    np.testing.assert_allclose(rt.u, u, atol=1e-7 * np.max(np.abs(u)))


# --- bad input -----------------------------------------------------------------------------------

@pytest.mark.parametrize(
    "kwargs, field",
    [({"budget": 0.0}, "budget"), ({"budget": -0.01}, "budget"), ({"rtol": 0.0}, "rtol"),
     ({"linear_solver": "magic"}, "magic"), ({"max_iterations": 0}, "max_iterations"), ({"clock": 3.0}, "clock")],
)
def test_bad_settings_are_rejected(kwargs, field):
    with pytest.raises(ValueError, match=field):
        RealtimeSolver(scene(), **kwargs)


@pytest.mark.parametrize(
    "kwargs, field",
    [({"dt": 0.0}, "dt"), ({"dt": -1.0}, "dt"), ({"dt": math.nan}, "dt"), ({"density": 0.0}, "density"),
     ({"mass": "heavy"}, "mass"), ({"gravity": (0, math.inf)}, "gravity")],
)
def test_bad_inertia_settings_are_rejected(kwargs, field):
    with pytest.raises(ValueError, match=field):
        scene(**kwargs)


@pytest.mark.parametrize(
    "targets, field",
    [({1: (math.nan, 0.0)}, "finite"), ({1: (0.0, math.inf)}, "finite"), ({1: (1.0, 2.0, 3.0)}, "shape"),
     ({5: (0.0, 0.0)}, "no handle"), ({"nobody": (0.0, 0.0)}, "no handle"), ([(0.0, 0.0)], "2 handles"),
     (3.0, "sequence")],
)
def test_bad_targets_are_rejected_and_the_state_is_kept(targets, field):
    rt = RealtimeSolver(scene(), budget=math.inf)
    rt.frame({1: (0.1, 0.05)})
    u, v, t, frames = rt.u.copy(), rt.v.copy(), rt.time, rt.frames
    target_before = np.array(rt.model.handles[1].target)
    with pytest.raises(ValueError, match=field):
        rt.frame(targets)
    np.testing.assert_array_equal(rt.u, u)
    np.testing.assert_array_equal(rt.v, v)
    assert (rt.time, rt.frames) == (t, frames)
    np.testing.assert_array_equal(rt.model.handles[1].target, target_before)
    assert rt.frame({1: (0.1, 0.05)}).converged  # and it carries on


def test_a_map_target_that_returns_nan_is_rejected_and_the_state_is_kept():
    rt = RealtimeSolver(scene(), budget=math.inf)
    rt.frame({1: (0.1, 0.0)})
    u = rt.u.copy()
    with pytest.raises(ValueError, match="non-finite"):
        rt.frame({1: lambda X: X * np.nan})
    np.testing.assert_array_equal(rt.u, u)
    assert rt.frame().converged


def test_reset_checks_its_input():
    rt = RealtimeSolver(scene())
    n = rt.u.size
    with pytest.raises(ValueError, match="shape"):
        rt.reset(u=np.zeros(n + 1))
    with pytest.raises(ValueError, match="non-finite"):
        rt.reset(v=np.full(n, np.nan))
    rt.reset(u=np.zeros(n), v=np.ones(n))
    assert rt.kinetic_energy() > 0


def test_a_jerked_handle_goes_part_of_the_way_rather_than_invert_ln_J():
    rt = RealtimeSolver(scene(n_triangles=120), budget=math.inf)
    report = rt.frame({1: (-2.5, 0.0)})  # the right edge thrown past the fixed one in a single frame
    assert 0.0 <= report.handle_fraction < 1.0
    assert_valid(rt, report)
    F = rt.model.deformation_gradient(rt.u)
    assert np.min(F[0, 0] * F[1, 1] - F[0, 1] * F[1, 0]) > 0
    # the rest of the way carries into the following frames, which keep aiming at the full target
    later = [rt.frame() for _ in range(30)]
    assert all(np.isfinite(r.energy) for r in later)
    fixed, values = rt.model.prescribed()
    moved = np.linalg.norm(rt.u[fixed] - values)
    assert moved < np.linalg.norm(values)


@pytest.mark.parametrize("field, value", [("dt", 0.0), ("dt", -0.1), ("dt", math.inf), ("dt", None),
                                          ("budget", 0.0), ("budget", -1.0), ("budget", math.nan)])
def test_changing_dt_or_budget_between_frames_checks_the_value_and_keeps_the_state(field, value):
    rt = RealtimeSolver(scene(), budget=math.inf)
    rt.frame({1: (0.1, 0.05)})
    before = (rt.u.copy(), rt.v.copy(), rt.time, rt.dt, rt.budget)
    with pytest.raises(ValueError, match=field):
        setattr(rt, field, value)
    np.testing.assert_array_equal(rt.u, before[0])
    np.testing.assert_array_equal(rt.v, before[1])
    assert (rt.time, rt.dt, rt.budget) == before[2:]
    rt.dt, rt.budget = 1 / 60, 0.5  # valid changes are taken
    assert rt.frame({1: (0.12, 0.05)}).converged and rt.time == pytest.approx(1 / 30 + 1 / 60)


@pytest.mark.parametrize("name", ["reuse", "direct", "superlu-colamd", "reuse-superlu-colamd"]
                         + (["pardiso", "reuse-pardiso"] if linsolve.available("pardiso") else []))
def test_every_linear_solver_gives_the_same_frames(name):
    rt = RealtimeSolver(scene(), budget=math.inf, rtol=1e-10, linear_solver=name)
    ref = RealtimeSolver(scene(), budget=math.inf, rtol=1e-10)
    for f in range(3):
        assert rt.frame({1: path((f + 1) / 10)}).converged
        ref.frame({1: path((f + 1) / 10)})
    np.testing.assert_allclose(rt.u, ref.u, atol=1e-8 * np.max(np.abs(ref.u)))


@pytest.mark.parametrize("dynamic", [True, False], ids=["dynamic", "quasistatic"])
@pytest.mark.parametrize("model", ["stable-neo-hookean", "neo-hookean", "corotated"])
def test_a_body_at_rest_reports_converged_in_every_frame(dynamic, model):
    """Once the body has settled, its residual is round-off: the frame must say converged, not cut the line
    search a hundred times looking for a decrease that round-off hides."""
    from tissuefem import Scene, Simulation, demo_scene

    data = demo_scene(400, dynamic=dynamic).to_dict()
    data["material"]["model"] = model
    sim = Simulation(Scene.from_dict(data), clock=FakeClock())
    grab = sim.grab([2.0, 0.5])
    sim.drag(grab, [2.3, 0.7])
    sim.run(20)
    if dynamic:
        sim.release(grab)
        sim.run(200)  # backward Euler damps the swing out
    reports = sim.run(60)
    assert all(r.converged for r in reports), [r.status for r in reports]
    # a settling swing may still take a Newton step or two, but never a search for a lost decrease
    assert all(r.line_search_cuts == 0 and r.newton_iterations <= 2 for r in reports)
