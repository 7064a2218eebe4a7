"""Probes and sutures over their whole accepted stiffness range: no node is thrown across the scene.

A penalty far stiffer than the tissue swamps the elastic energy in round-off: the line search no longer sees the
tissue and accepts steps that fling nodes while every frame reports convergence (on a 2 x 1 sheet with E = 1000: a
probe of 1e12 E / radius pressed 0.15 deep threw nodes about 9 away, a suture of 1e16 E tightened across a slot about
300 away; at the default stiffnesses no node moves farther than 0.15). So a probe is accepted up to PENALTY_STIFFNESS_MAX Young's
moduli per unit of its radius and a suture up to PENALTY_STIFFNESS_MAX Young's moduli (1e4 times their defaults):
here both scenes stay where the default stiffness leaves them at the stiffest accepted value, a stiffer one is
refused by the field's name wherever it enters (a scene, the simulation, a model's keyword, the term alone), and
over the accepted range (log-uniform) every frame is finite and bounded.
"""

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tissuefem import Model, StableNeoHookean, rectangle
from tissuefem.engine.parameters import (PENALTY_STIFFNESS_MAX, YOUNGS_MODULUS_RANGE, ParameterError,
                                         check_penalty_stiffness)
from tissuefem.engine.terms import Probe, Sutures, boundary_lengths
from tissuefem.surgery.scene import Scene
from tissuefem.surgery.simulation import Simulation

E = 1000.0  # Young's modulus of the sheets
RADIUS = 0.2  # of the probe
PROBE_MAX = PENALTY_STIFFNESS_MAX * E / RADIUS
SUTURE_MAX = PENALTY_STIFFNESS_MAX * E
SLOT = [[0.9, 1.2], [1.1, 1.2], [1.1, 0.5], [0.9, 0.5]]  # excised from the top edge: the wound the sutures close
STITCHES = [[[0.88, 0.95], [1.12, 0.95]], [[0.88, 0.75], [1.12, 0.75]]]


def _scene(effects=None, triangles=200):
    return Scene.from_dict({
        "domain": {"shape": "rectangle", "width": 2.0, "height": 1.0, "triangles": triangles},
        "material": {"model": "stable-neo-hookean", "youngs_modulus": E, "poisson_ratio": 0.3},
        "effects": {"handles": [{"name": "fixed", "region": "bottom"}], **(effects or {})}})


def _simulation(triangles=200):
    return Simulation(_scene(triangles=triangles), clock=lambda: 0.0)  # a fake clock: no budget miss under load


def _largest_move(sim) -> float:
    return float(np.max(np.hypot(*sim.u.reshape(-1, 2).T)))


def _press(stiffness, triangles=200, depth=0.15, frames=5):
    """A probe lowered onto the middle of the top edge and pressed ``depth`` into it."""
    sim = _simulation(triangles)
    top = 1.0 + RADIUS + 0.05
    probe = sim.add_probe([1.0, top], RADIUS, stiffness)
    reports = []
    for y in np.linspace(top, 1.0 + RADIUS - depth, frames + 1)[1:]:
        sim.move_probe(probe, [1.0, y])
        reports.append(sim.frame())
    return sim, reports


def _tie(stiffness, triangles=200, steps=4):
    """Two stitches across a slot cut from the top edge, tightened until it is closed."""
    sim = _simulation(triangles)
    sim.excise(SLOT)
    reports = [sim.frame()]
    sim.suture(STITCHES, stiffness=stiffness, tightness=0.0)
    for s in np.linspace(0.0, 1.0, steps + 1)[1:]:
        sim.tighten(float(s))
        reports.append(sim.frame())
    return sim, reports


@pytest.mark.parametrize("scenario, stiffest", [(_press, PROBE_MAX), (_tie, SUTURE_MAX)], ids=["probe", "suture"])
def test_at_the_stiffest_accepted_penalty_nothing_is_thrown(scenario, stiffest):
    reference, _ = scenario(None)  # the default stiffness: 100 E / radius, 100 E
    sim, reports = scenario(stiffest)
    assert np.all(np.isfinite(sim.u))
    assert all(r.converged for r in reports)
    assert _largest_move(sim) <= 1.1 * _largest_move(reference) + 0.01, (_largest_move(sim), _largest_move(reference))


def test_a_stiffer_probe_is_refused_by_name_wherever_it_enters():
    sim = _simulation(triangles=20)
    for stiffness in (1.01 * PROBE_MAX, 1e40, math.inf, math.nan):
        with pytest.raises(ParameterError, match=r"probe\.stiffness.*Young's modulus") as err:
            sim.add_probe([1.0, 1.1], RADIUS, stiffness)
        assert err.value.field == "probe.stiffness"
    assert sim.model.probes == []  # a refusal adds nothing
    sim.add_probe([1.0, 1.1], RADIUS, PROBE_MAX)  # the stiffest accepted is accepted
    with pytest.raises(ParameterError) as err:  # a scene: refused when its simulation is built (E known then)
        Simulation(_scene({"probes": [{"center": [1.0, 1.1], "radius": RADIUS, "stiffness": 2 * PROBE_MAX}]}, 20))
    assert err.value.field == "effects.probes[0].stiffness"
    mesh = rectangle(2.0, 1.0, 4, 2)
    material = StableNeoHookean(60.0, 100.0)  # lam, mu: Young's modulus 100 (3 lam + 2 mu) / (lam + mu) = 237.5
    top = PENALTY_STIFFNESS_MAX * 237.5 / RADIUS
    probe = dict(center=[1.0, 1.1], radius=RADIUS, stiffness=1.01 * top)
    with pytest.raises(ParameterError) as err:  # a model's keyword: against the model's own material
        Model(mesh, material, probes=[dict(probe, stiffness=1.0), probe])
    assert err.value.field == "probes[1].stiffness"
    Model(mesh, material, probes=[dict(probe, stiffness=0.99 * top)])
    with pytest.raises(ParameterError) as err:  # the term alone: against the stiffest material accepted
        Probe(mesh.p, boundary_lengths(mesh), [1.0, 1.1], RADIUS, 1.01 * PENALTY_STIFFNESS_MAX * 1e12 / RADIUS)
    assert err.value.field == "probe.stiffness"


def test_a_stiffer_suture_is_refused_by_name_wherever_it_enters():
    sim = _simulation(triangles=20)
    sim.excise(SLOT)
    for stiffness in (1.01 * SUTURE_MAX, 1e40, math.inf, 0.0, -1.0):
        with pytest.raises(ParameterError, match=r"sutures\.stiffness") as err:
            sim.suture(STITCHES, stiffness=stiffness)
        assert err.value.field == "sutures.stiffness"
    assert sim.model.sutures is None
    sim.suture(STITCHES, stiffness=SUTURE_MAX)
    effects = {"sutures": [{"pairs": STITCHES, "stiffness": 2 * SUTURE_MAX}], "excisions": [{"polygon": SLOT}]}
    with pytest.raises(ParameterError) as err:
        Simulation(_scene(effects, 20))
    assert err.value.field == "effects.sutures[0].stiffness"
    mesh = rectangle(2.0, 1.0, 4, 2)
    material = StableNeoHookean(60.0, 100.0)  # Young's modulus 237.5
    spec = dict(pairs=[[0], [4]], gaps=[[0.0], [0.0]])
    with pytest.raises(ParameterError) as err:
        Model(mesh, material, sutures=dict(spec, stiffness=1.01 * PENALTY_STIFFNESS_MAX * 237.5))
    assert err.value.field == "sutures.stiffness"
    Model(mesh, material, sutures=dict(spec, stiffness=0.99 * PENALTY_STIFFNESS_MAX * 237.5))
    for k in (1.01 * PENALTY_STIFFNESS_MAX * 1e12, [1.0, math.nan]):  # the term alone
        with pytest.raises(ParameterError) as err:
            Sutures(mesh.p, [[0, 1], [4, 5]], k, np.zeros((2, 2)))
        assert err.value.field == "sutures.stiffness"


@settings(max_examples=40, deadline=None, derandomize=True)
@given(log_modulus=st.floats(math.log10(YOUNGS_MODULUS_RANGE[0]), math.log10(YOUNGS_MODULUS_RANGE[1])),
       log_radius=st.floats(-12.0, 12.0), fraction=st.floats(0.0, 1.0), over=st.floats(1.0 + 1e-9, 1e30))
def test_the_check_accepts_exactly_its_range(log_modulus, log_radius, fraction, over):
    modulus, radius = 10.0 ** log_modulus, 10.0 ** log_radius
    for r, hi in ((radius, PENALTY_STIFFNESS_MAX * modulus / radius), (None, PENALTY_STIFFNESS_MAX * modulus)):
        assert check_penalty_stiffness("k", fraction * hi, modulus, r) == fraction * hi
        with pytest.raises(ParameterError) as err:
            check_penalty_stiffness("k", over * hi, modulus, r)
        assert err.value.field == "k"
    with pytest.raises(ParameterError):
        check_penalty_stiffness("k", 0.0, modulus, positive=True)


@settings(max_examples=20, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])
@given(log_ratio=st.floats(-3.0, math.log10(PENALTY_STIFFNESS_MAX)), depth=st.floats(0.0, 0.3))
def test_a_probe_pressed_at_any_accepted_stiffness_keeps_every_node_near(log_ratio, depth):
    sim, _ = _press(E / RADIUS * 10.0 ** log_ratio, triangles=60, depth=depth, frames=3)
    assert np.all(np.isfinite(sim.u))
    assert _largest_move(sim) <= depth + 0.1  # no deeper than the tool went (and what the sheet bulges)


@settings(max_examples=20, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])
@given(log_ratio=st.floats(-3.0, math.log10(PENALTY_STIFFNESS_MAX)))
def test_a_suture_tightened_at_any_accepted_stiffness_keeps_every_node_near(log_ratio):
    sim, _ = _tie(E * 10.0 ** log_ratio, triangles=60, steps=2)
    assert np.all(np.isfinite(sim.u))
    assert _largest_move(sim) <= 0.2  # at most the slot's width, shared by its two sides
