"""After a cut (``keep_factorization``) the frame goes on with the old factorization, extended to the new nodes,
while a fresh one is made off the frame; a probe added keeps the factorization: the frames converge to the same
states as when the new model is factorized afresh."""

import numpy as np
import pytest

from tissuefem.surgery.scene import Scene
from tissuefem.surgery.simulation import Simulation


def _sim(keep, linear_solver="reuse-background"):
    effects = {"handles": [{"name": "fixed", "region": "left"}, {"name": "pull", "region": "right"}]}
    scene = Scene(domain={"shape": "rectangle", "width": 2.0, "height": 1.0, "triangles": 600},
                  material={"model": "stable-neo-hookean", "youngs_modulus": 1000.0, "poisson_ratio": 0.3},
                  effects=effects, solver={"budget": 1e9, "rtol": 1e-8, "linear_solver": linear_solver})
    return Simulation(scene) if keep is None else Simulation(scene, keep_factorization=keep)


def _drag(sim, frames, start=0):
    return [sim.frame({"pull": (0.02 * (f + 1), 0.01 * (f + 1))}) for f in range(start, start + frames)]


@pytest.mark.parametrize("linear_solver", ["reuse-background", "reuse"])
@pytest.mark.parametrize("method", ["elements", "edges"])
def test_a_cut_frame_reaches_the_state_of_a_fresh_factorization(linear_solver, method):
    states, first = {}, {}
    for keep in (False, True):
        sim = _sim(keep, linear_solver)
        _drag(sim, 3)
        sim.cut([[1.0, 1.2], [1.1, 0.45]], method=method)
        reports = _drag(sim, 4, start=3)
        assert all(r.converged for r in reports)
        states[keep], first[keep] = sim.u.copy(), reports[0]
        sim.solver.linear.close()
    scale = np.abs(states[False]).max()
    assert np.abs(states[True] - states[False]).max() < 1e-5 * scale
    assert first[False].newton.factorizations >= 1  # the old path factorizes the new matrix on the frame
    assert first[True].newton.factorizations == 0  # the new one preconditions with the old factorization


def test_a_probe_added_to_a_running_model_keeps_the_factorization_and_reaches_the_same_state():
    states = []
    for keep in (False, True):
        sim = _sim(False)
        _drag(sim, 2)
        sim.add_probe([1.4, 1.08], 0.15)
        assert sim.solver.linear.backend.provisional is False
        if not keep:
            sim.solver.linear.invalidate()  # the path before: a fresh factorization for the new model
        assert all(r.converged for r in _drag(sim, 2, start=2))
        states.append(sim.u.copy())
        sim.solver.linear.close()
    assert np.abs(states[1] - states[0]).max() < 1e-5 * np.abs(states[0]).max()


def test_a_cut_factorizes_afresh_by_default():
    sim = _sim(None)
    _drag(sim, 2)
    sim.cut([[1.0, 1.2], [1.1, 0.45]])
    assert _drag(sim, 1, start=2)[0].newton.factorizations >= 1
    sim.solver.linear.close()
