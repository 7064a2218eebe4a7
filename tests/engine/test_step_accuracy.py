"""Every step reports its own accuracy: relative residual, energy decrease, convergence, smallest J, inverted
elements and what a budgeted frame left undone (deterministic: a fake clock, no timing)."""

import math

import numpy as np
import pytest

from tissuefem import (Handle, Model, NeoHookean, RealtimeSolver, StableNeoHookean, Stepper, StepReport, rectangle,
                       solve)
from tissuefem.engine.stepping import Undone

E_MOD, NU = 1000.0, 0.3


class TickingClock:
    """A fake clock: every reading is ``tick`` seconds after the one before."""

    def __init__(self, tick=1.0):
        self.now, self.tick = 0.0, tick

    def __call__(self):
        self.now += self.tick
        return self.now


def block(material, **kw):
    """The unit square, bottom edge held, top edge on a handle named ``top``."""
    mesh = rectangle(1.0, 1.0, 6, 6)
    return Model(mesh, material, handles=[Handle("bottom", name="bottom"), Handle("top", name="top")], **kw)


def check_consistent(report: StepReport, model: Model):
    """The report's J figures are those of its result ``x``."""
    J = model.jacobian(report.x)
    assert report.min_J == pytest.approx(float(J.min()))
    assert report.inverted == int(np.count_nonzero(J <= 0))
    assert report.energy_decrease == pytest.approx(report.start_energy - report.energy)


def test_a_converged_quasistatic_step_reports_a_small_residual_and_no_inversion():
    model = block(NeoHookean(E_MOD, NU))
    model.handle("top").move((0.2, 0.3))
    result = solve(model, 2, rtol=1e-8)
    assert result.converged
    for report in result.steps:
        assert report.converged and report.committed
        assert report.scaled_residual <= 1e-8
        assert report.min_J > 0 and report.inverted == 0
        assert report.energy_decrease >= 0.0  # the energy line search never climbs
        assert not report.undone and str(report.undone) == "nothing"
        assert report.accuracy.startswith("converged | rel. residual ")
        assert "0 inverted" in report.accuracy and "short" not in report.accuracy
        check_consistent(report, model)


def test_the_relative_residual_counts_from_the_tolerance_scale():
    """A linearised start can leave a residual far below the load it balances: the report divides by the larger
    scale (the one the tolerance is relative to), the Newton solve's own ratio by its start alone."""
    model = block(NeoHookean(E_MOD, NU))
    model.handle("top").move((0.3, 0.2))
    report = solve(model, 1, rtol=1e-9).steps[0]
    assert report.warm_start == "linearised" and report.residual_scale > report.initial_residual
    assert report.scaled_residual == pytest.approx(report.residual_norm / report.residual_scale)
    assert report.scaled_residual <= min(1e-9, report.relative_residual)


def test_a_body_at_rest_converges_at_once_with_a_small_relative_residual():
    """At rest ``g(x0)`` is round-off: the step takes no Newton step, and its residual counts against the
    round-off level over rtol (the Newton solve's own ratio would be 1)."""
    model = block(NeoHookean(E_MOD, NU), density=1.0, dt=1 / 30)
    report = RealtimeSolver(model, budget=math.inf, rtol=1e-6).frame()
    assert report.converged and report.newton.iterations == 0
    assert report.scaled_residual <= 1e-6 and report.newton.relative_residual in (0.0, 1.0)


def test_a_dynamic_converged_frame_lowers_its_energy():
    model = block(NeoHookean(E_MOD, NU), density=1.0, dt=1 / 30)
    solver = RealtimeSolver(model, budget=math.inf, rtol=1e-8)
    for k in range(1, 4):
        report = solver.frame({"top": (0.05 * k, 0.0)})
        assert report.converged and report.scaled_residual <= 1e-8
        assert report.energy_decrease >= 0.0 and report.iterations >= 1
        assert report.min_J > 0 and report.inverted == 0
        check_consistent(report, model)


def test_a_crush_past_flat_reports_inverted_elements():
    """The stable Neo-Hookean energy is finite for every J. Pressed 0.3 past flat with the whole boundary held on the
    map ``(x, y) -> (x, -1.3 y)``, every element must turn over: that affine map is the equilibrium (J = -1.3).
    (With only the top and bottom edges held, the body may fold over itself instead, every J > 0.)"""
    material = StableNeoHookean(E_MOD, NU)
    model = block(material)
    x, y = model.X
    edge = np.flatnonzero((x < 1e-9) | (x > 1 - 1e-9) | (y < 1e-9) | (y > 1 - 1e-9))
    dofs = np.concatenate([2 * edge, 2 * edge + 1])
    values = np.concatenate([np.zeros(edge.size), -2.3 * y[edge]])
    solver = RealtimeSolver(model, budget=math.inf, rtol=1e-8, max_iterations=200)
    report = solver.frame(prescribed=(dofs, values))
    assert report.converged and report.inverted == model.mesh.t.shape[1]
    assert report.min_J == pytest.approx(-1.3)
    assert f"{report.inverted} inverted" in report.accuracy
    check_consistent(report, model)


def test_a_budgeted_frame_says_what_it_left_undone():
    model = block(NeoHookean(E_MOD, NU), density=1.0, dt=1 / 30)
    solver = RealtimeSolver(model, budget=4.5, rtol=1e-12, clock=TickingClock())
    report = solver.frame({"top": (0.4, 0.0)})
    assert not report.converged and report.status == "budget" and report.committed
    undone = report.undone
    assert isinstance(undone, Undone) and undone
    assert undone.stopped == "budget" and undone.newton_steps == report.newton_iterations
    assert undone.relative_residual == report.scaled_residual > 1e-12
    assert undone.handles == 0.0 and undone.committed
    assert str(undone) == (f"stopped (budget) after {report.newton_iterations} Newton steps at relative residual "
                           f"{report.scaled_residual:.1e}")
    assert report.accuracy.startswith(f"budget after {report.newton_iterations} Newton | rel. residual ")
    assert report.energy_decrease >= 0.0  # an anytime frame commits no iterate above its start
    check_consistent(report, model)


def test_a_frame_that_moved_the_handles_part_of_the_way_says_how_far_short():
    """ln J Neo-Hookean cannot be crushed past flat: the real-time frame moves the handle part of the way."""
    model = block(NeoHookean(E_MOD, NU))
    solver = RealtimeSolver(model, budget=math.inf, rtol=1e-8)
    report = solver.frame({"top": (0.0, -1.3)})
    assert report.handle_fraction < 1.0 and report.inverted == 0 and report.min_J > 0
    assert report.undone.handles == pytest.approx(1.0 - report.handle_fraction)
    assert f"handles {1.0 - report.handle_fraction:.0%} short" in str(report.undone)
    assert "short" in report.accuracy


def test_an_offline_step_that_cannot_move_keeps_the_state_and_says_so():
    model = block(NeoHookean(E_MOD, NU))
    report = Stepper(model).step({"top": (0.0, -1.3)})
    assert not report.committed and not report.converged
    assert not report.undone.committed and "state kept" in str(report.undone) and "state kept" in report.accuracy
    assert report.min_J > 0 and report.inverted == 0  # measured at x, the state kept


def test_undone_is_false_only_when_nothing_is_left():
    assert not Undone() and str(Undone()) == "nothing"
    assert Undone(handles=0.25) and str(Undone(handles=0.25)) == "handles 25% short"
    assert Undone(committed=False)
