"""Self-contact over its whole accepted stiffness range: no node is thrown across the scene.

The barrier's stiffness is a pressure; far above Young's modulus its energy swamps the elastic energy in
round-off, the line search no longer sees the tissue, and a lip dragged through a wound or a corner folded
through the bottom edge ended far outside the scene (|u| of tens to thousands on a 2 x 1 sheet). So the
stiffness is accepted up to CONTACT_STIFFNESS_MAX times Young's modulus: here the two scenes stay within a
small factor of the default stiffness at the stiffest accepted value, a stiffer one is refused by name, and
over the accepted range (log-uniform) a grab dragged in any direction never produces a NaN or a node farther
than the drag plus the body's size.
"""

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tissuefem import Handle, Model, StableNeoHookean, rectangle
from tissuefem.engine.contact import Contact, ContactSurface
from tissuefem.engine.parameters import CONTACT_STIFFNESS_MAX, PENALTY_MAX, ParameterError
from tissuefem.surgery.scene import Scene
from tissuefem.surgery.simulation import Simulation
from tissuefem.surgery.surfaces import contact_surface

E = 1000.0  # Young's modulus of the sheets
STIFFEST = CONTACT_STIFFNESS_MAX * E


def _sheet(stiffness=None, triangles=200):
    contact = {} if stiffness is None else {"stiffness": stiffness}
    return Scene.from_dict({
        "domain": {"shape": "rectangle", "width": 2.0, "height": 1.0, "triangles": triangles},
        "material": {"model": "stable-neo-hookean", "youngs_modulus": E, "poisson_ratio": 0.3},
        "effects": {"handles": [{"name": "fixed", "region": "left"}], "contact": contact}})


def _drag(sim, start, end, frames, radius):
    grab = sim.grab(start, radius=radius)
    for k in range(1, frames + 1):
        sim.drag(grab, tuple(np.asarray(start) + (np.asarray(end) - start) * k / frames))
        sim.frame()


def _wound(sim):
    """A crack down from the top edge; its right lip grabbed and dragged 0.75 across the left one."""
    sim.cut([[1.0, 1.2], [1.0, 0.3]])
    _drag(sim, (1.05, 1.0), (0.3, 1.0), frames=3, radius=0.12)


def _fold(sim):
    """The top right corner folded down through the bottom edge."""
    _drag(sim, (2.0, 1.0), (1.7, -0.5), frames=6, radius=0.1)


def _largest_move(sim) -> float:
    return float(np.max(np.hypot(*sim.u.reshape(-1, 2).T)))


def _simulation(stiffness, triangles=200):
    return Simulation(_sheet(stiffness, triangles), clock=lambda: 0.0)  # a fake clock: no budget miss under load


@pytest.mark.parametrize("scenario", [_wound, _fold], ids=["wound-lip-dragged-across", "corner-folded-through"])
def test_at_the_stiffest_accepted_contact_no_node_is_thrown(scenario):
    reference = _simulation(None)  # the default stiffness: Young's modulus
    scenario(reference)
    bound = 2.0 * _largest_move(reference)
    for stiffness in (PENALTY_MAX, 1e30, 1e20, STIFFEST):
        try:
            sim = _simulation(stiffness)
        except ParameterError as err:  # refused by name, or it must be robust
            assert err.field == "effects.contact.stiffness" and stiffness > STIFFEST, err
            continue
        scenario(sim)
        assert np.all(np.isfinite(sim.u))
        assert _largest_move(sim) <= bound, (stiffness, _largest_move(sim), bound)
    assert _simulation(STIFFEST).model.contact.stiffness == STIFFEST  # the stiffest accepted is accepted


def test_a_stiffness_beyond_the_robust_range_is_refused_by_name():
    with pytest.raises(ParameterError, match=r"effects\.contact\.stiffness.*Young's modulus") as err:
        _simulation(1.01 * STIFFEST, triangles=20)
    assert err.value.field == "effects.contact.stiffness"
    mesh = rectangle(2.0, 1.0, 4, 2)
    material = StableNeoHookean(60.0, 100.0)  # lam, mu: Young's modulus 100 (3 lam + 2 mu) / (lam + mu) = 237.5
    for stiffness in (1.01 * CONTACT_STIFFNESS_MAX * 237.5, 1e40):
        with pytest.raises(ParameterError, match=r"contact\.stiffness") as err:
            Model(mesh, material, handles=[Handle("left")], contact=dict(distance=0.05, stiffness=stiffness))
        assert err.value.field == "contact.stiffness"
    Model(mesh, material, handles=[Handle("left")], contact=dict(distance=0.05, stiffness=0.99e4 * 237.5))
    with pytest.raises(ParameterError, match=r"contact\.stiffness"):  # the term alone: at most 1e4 times 1e12
        Contact(mesh.p, ContactSurface.from_mesh(mesh), 0.05, 1e17)


@settings(max_examples=12, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])
@given(log_ratio=st.floats(-3.0, math.log10(CONTACT_STIFFNESS_MAX)), angle=st.floats(0.0, 2.0 * math.pi))
def test_a_drag_in_any_direction_at_any_accepted_stiffness_keeps_every_node_near(log_ratio, angle):
    sim = _simulation(E * 10.0 ** log_ratio, triangles=60)
    sim.cut([[1.0, 1.2], [1.0, 0.4]])
    distance = 0.75
    start = np.array([1.1, 0.9])
    _drag(sim, start, start + distance * np.array([math.cos(angle), math.sin(angle)]), frames=3, radius=0.2)
    assert np.all(np.isfinite(sim.u))
    assert _largest_move(sim) <= distance + math.hypot(2.0, 1.0)


@pytest.mark.parametrize("mesh", [None, 5, np.zeros((3, 3)), "mesh.msh"])
def test_the_contact_surface_of_something_that_is_not_a_mesh_is_refused_by_name(mesh):
    for build in (ContactSurface.from_mesh, contact_surface):
        with pytest.raises(ParameterError, match="mesh must be a triangle mesh") as err:
            build(mesh)
        assert err.value.field == "mesh"


def test_the_contact_terms_entry_points_refuse_wrong_types_by_name():
    mesh = rectangle(1.0, 0.5, 4, 2)
    surface = ContactSurface.from_mesh(mesh)
    contact = Contact(mesh.p, surface, 0.02, 10.0)
    n = 2 * mesh.p.shape[1]
    for call, field in [(lambda: Contact(None, surface, 0.02, 1.0), "X"),
                        (lambda: Contact(mesh.p[:, :3], surface, 0.02, 1.0), "contact.surface"),
                        (lambda: surface.positions(None), "x"),
                        (lambda: surface.positions(np.zeros((2, 3))), "x"),
                        (lambda: ContactSurface([0, 1], [1.0, 1.0], [[0, 1], [1]], 3), "contact.surface.segments"),
                        (lambda: ContactSurface([0, 1], [1.0, 1.0], [[0], [1]], 3, wound="x"),
                         "contact.surface.wound"),
                        (lambda: contact.energy(None), "u"),
                        (lambda: contact.gradient(np.zeros(3)), "u"),
                        (lambda: contact.active_pairs("u"), "u"),
                        (lambda: contact.begin_step(np.zeros(n), 5), "previous"),
                        (lambda: contact.max_step(np.zeros(n), np.zeros(3)), "du")]:
        with pytest.raises(ParameterError) as err:
            call()
        assert err.value.field == field
