"""The reduced model of a tool (engine.haptics): its force matches converged frames to first order in the move."""

import numpy as np
import pytest

from tissuefem import Handle, Model, NeoHookean, Stepper, flap
from tissuefem.engine.haptics import ToolModel, tool_model
from tissuefem.engine.parameters import ParameterError

E_MOD, NU = 1000.0, 0.3
P0 = np.array([0.12, -0.08])


def _model(n_triangles=300, **options):
    return Model(flap(n_triangles=n_triangles), NeoHookean.from_young(E_MOD, NU),
                 handles=[Handle("fixed", name="fixed"), Handle("handle", name="handle")], **options)


def _state(stepper):
    return dict(u=stepper.u.copy(), v=stepper.v.copy(), v_previous=stepper.v_previous, time_=stepper.time,
                steps=stepper.steps)


def _restore(stepper, state):
    stepper.set_state(state["u"], state["v"] if stepper.dt is not None else None,
                      v_previous=state["v_previous"], time_=state["time_"], steps=state["steps"])


def _converged_handle_force(stepper, start, p):
    """The handle's force of the last frame taken again from its start state, with the handle at ``p``."""
    _restore(stepper, start)
    report = stepper.step({"handle": p})
    assert report.converged
    return stepper.model.reaction(stepper.u, "handle")


def _second_order(errors, changes):
    """The linearisation's error is small against the first-order change, and falls like ``h^2``."""
    assert errors[0] <= 1e-2 * changes[0], (errors, changes)
    assert errors[1] <= 0.35 * errors[0], errors


@pytest.mark.parametrize("dynamic", [False, True])
def test_a_handles_reduced_force_matches_converged_frames_to_first_order(dynamic):
    model = _model(dt=1.0 / 30.0) if dynamic else _model()
    stepper = Stepper(model, rtol=1e-11, linear_solver="reuse" if dynamic else "direct")
    for k in range(1, 4):
        start = _state(stepper)
        stepper.step({"handle": P0 * k / 3})
    frame = _state(stepper)
    tm = tool_model(stepper, "handle")
    assert tm.kind == "handle" and tm.frame == 3
    np.testing.assert_allclose(tm.position, P0)
    np.testing.assert_array_equal(tm.force(P0), model.reaction(stepper.u, "handle"))  # zero move: the frame's force
    np.testing.assert_array_equal(stepper.u, frame["u"])  # building it changes no state
    for direction in (np.array([1.0, 0.0]), np.array([0.6, -0.8])):
        errors, changes = [], []
        for h in (2e-3, 1e-3):
            reference = _converged_handle_force(stepper, start, P0 + h * direction)
            errors.append(np.linalg.norm(tm.force(P0 + h * direction) - reference))
            changes.append(np.linalg.norm(reference - tm.force0))
        _second_order(errors, changes)
    # pulling the edge further out pulls harder: the stiffness seen through the body is positive definite
    assert np.all(np.linalg.eigvalsh(0.5 * (tm.stiffness + tm.stiffness.T)) > 0)


def test_a_probes_reduced_force_matches_converged_frames_to_first_order():
    model = _model(probes=[dict(center=[1.0, 1.26], radius=0.3, stiffness=3e4, label="tip")])
    stepper = Stepper(model, rtol=1e-11)
    stepper.step()
    u0 = stepper.u.copy()
    probe = model.probes[0]
    c0 = probe.center.copy()
    tm = tool_model(stepper, "tip")
    assert tm.kind == "probe" and np.linalg.norm(tm.force0) > 0
    np.testing.assert_array_equal(tm.force(c0), probe.forces(u0).sum(axis=1))
    assert tm.force0[1] < 0  # the disc pushes the top edge down
    for direction in (np.array([0.0, -1.0]), np.array([0.8, 0.6])):
        errors, changes = [], []
        for h in (2e-3, 1e-3):
            probe.move(c0 + h * direction)
            stepper.reset(u0)
            assert stepper.step().converged
            reference = probe.forces(stepper.u).sum(axis=1)
            errors.append(np.linalg.norm(tm.force(c0 + h * direction) - reference))
            changes.append(np.linalg.norm(reference - tm.force0))
        _second_order(errors, changes)
    # pressing deeper pushes harder: the vertical stiffness makes the force more negative as the disc goes down
    assert tm.stiffness[1, 1] > 0


def test_a_probe_touching_nothing_has_no_force_and_no_stiffness():
    model = _model(probes=[dict(center=[1.0, 1.5], radius=0.3, stiffness=3e4, label="tip")])
    stepper = Stepper(model)
    stepper.step()
    tm = tool_model(stepper, model.probes[0])
    np.testing.assert_array_equal(tm.force([1.0, 1.4]), np.zeros(2))


@pytest.mark.parametrize("position", [[1.0], [1.0, 2.0, 3.0], [np.nan, 0.0], ["a", "b"], None, [1j, 0.0]])
def test_a_bad_position_is_refused_by_name_and_the_model_is_kept(position):
    tm = ToolModel("handle", "handle", np.zeros(2), np.array([1.0, 2.0]), np.eye(2), 1)
    with pytest.raises(ParameterError) as err:
        tm.force(position)
    assert err.value.field == "position"
    np.testing.assert_array_equal(tm.force([0.0, 0.0]), [1.0, 2.0])


def test_bad_tools_and_steppers_are_refused_by_name():
    model = _model(n_triangles=100)
    stepper = Stepper(model)
    stepper.step({"handle": [0.05, 0.0]})
    for tool in ("nothing", 3, None, Handle("handle")):
        with pytest.raises(ParameterError) as err:
            tool_model(stepper, tool)
        assert err.value.field == "tool"
    model.handle("handle").move(lambda X: X + 0.01)
    with pytest.raises(ParameterError, match="map") as err:
        tool_model(stepper, "handle")
    assert err.value.field == "tool"
    with pytest.raises(ParameterError) as err:
        tool_model(model, "handle")
    assert err.value.field == "stepper"


def test_a_failed_solve_builds_nothing_and_leaves_the_state():
    model = _model(n_triangles=100)
    stepper = Stepper(model)
    stepper.step({"handle": [0.05, 0.0]})
    before = _state(stepper)
    stepper.linear.solve = lambda A, b, **kw: (None, None)
    with pytest.raises(ValueError, match="solve"):
        tool_model(stepper, "handle")
    np.testing.assert_array_equal(stepper.u, before["u"])
    assert stepper.steps == before["steps"]
