"""Limits that can be computed, and strokes that cut all the way however far they reach.

A far-reaching stroke is clipped to the body (its bounding box grown by one body size) before it is followed, so a
stroke drawn to 1e300 cuts exactly as one drawn just past the edge: two pieces, never a partial cut, never a false
"meets no material". Every count limit of a scene (docs/scenes.md) is built here at its maximum, each within a stated
time on a 2-core machine; together they take under a minute there, busy. A cut costs what it touches: the parts of
the element edges that the material of an element cut before still touches are worked out once, not at every cut.
"""

import time

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tissuefem import Scene, Simulation, demo_scene
from tissuefem.engine.meshes import rectangle
from tissuefem.engine.parameters import MAX_POINTS, ParameterError
from tissuefem.surgery import scene as scene_module
from tissuefem.surgery.element_cuts import cut_through, excise_through, material_areas
from tissuefem.surgery.topology import connected_components

SHEET = rectangle(2.0, 1.0, 20, 10)  # the 2 x 1 sheet of the report, h = 0.1
FAR = [1e6, 1e7, 1e50, 1e300]


def wound_length(wound):
    """Length of a wound in the reference configuration (each piece counted once, not per side)."""
    d = wound.reference[:, 1] - wound.reference[:, 0]
    return 0.5 * float(np.hypot(d[:, 0], d[:, 1]).sum())


def pieces(mesh):
    return connected_components(mesh.t, mesh.p.shape[1])[0]


# --- a far-reaching stroke cuts all the way ---
@pytest.mark.parametrize("far", FAR)
def test_a_far_reaching_stroke_cuts_the_sheet_in_two(far):
    cut = cut_through(SHEET, [[1.01, far], [1.01, -far]])
    assert pieces(cut.mesh) == 2
    assert np.isclose(material_areas(cut.mesh, cut.weights).sum(), 2.0)
    assert np.isclose(wound_length(cut.wound), 1.0)  # the whole height, not a part of it
    # where the wound lies on the drawn stroke: within the one segment, in the middle of it (the body is tiny)
    assert np.all((cut.wound.stroke >= 0.0) & (cut.wound.stroke <= 1.0))


@pytest.mark.parametrize("far", FAR)
def test_a_far_reaching_stroke_cuts_as_a_short_one(far):
    near, distant = cut_through(SHEET, [[1.01, 1.2], [1.01, -0.2]]), cut_through(SHEET, [[1.01, far], [1.01, -far]])
    assert near.mesh.t.shape == distant.mesh.t.shape
    np.testing.assert_allclose(near.weights, distant.weights, atol=1e-12)
    np.testing.assert_allclose(near.wound.reference, distant.wound.reference, atol=1e-12)


@pytest.mark.parametrize("far", FAR)
def test_a_far_reaching_stroke_with_several_points_cuts_in_two(far):
    """Out of the body and back in: the part outside is replaced by a path along the grown box (no material)."""
    cut = cut_through(SHEET, [[0.51, far], [0.51, -far], [1.51, -far], [1.51, far]])
    assert pieces(cut.mesh) == 3
    assert np.isclose(wound_length(cut.wound), 2.0)


@pytest.mark.parametrize("far", FAR)
def test_a_far_reaching_excision_removes_the_strip(far):
    cut = excise_through(SHEET, [[0.81, -far], [1.21, -far], [1.21, far], [0.81, far]])
    assert pieces(cut.mesh) == 2
    assert np.isclose(material_areas(cut.mesh, cut.weights).sum(), 2.0 - 0.4)


@pytest.mark.parametrize("far", FAR)
def test_a_far_stroke_that_misses_the_body_says_so(far):
    with pytest.raises(ValueError, match="meets no material"):
        cut_through(SHEET, [[far, far], [far, -far]])
    with pytest.raises(ValueError, match="encloses no material"):
        excise_through(SHEET, [[far, far], [2 * far, far], [2 * far, 2 * far]])


def test_a_slanted_far_stroke_cuts_where_its_line_crosses_the_body():
    a, b = np.array([1.0, 0.5]), np.array([0.2, 1.0])  # through (1, 0.5), x = 1 + 0.2 (y - 0.5)
    cut = cut_through(SHEET, [a + 1e6 * b, a - 1e6 * b])
    assert pieces(cut.mesh) == 2
    np.testing.assert_allclose(wound_length(cut.wound), np.hypot(0.2, 1.0), rtol=1e-9)


@settings(max_examples=40, deadline=None)
@given(x=st.floats(0.05, 1.95), exponent=st.floats(0.0, 300.0))
def test_a_straight_stroke_across_the_sheet_always_makes_two_pieces(x, exponent):
    """Property: a vertical stroke at any x in (0.05, 1.95), reaching 10**exponent (1 to 1e300) heights beyond the
    sheet on both sides, splits it into exactly two pieces that keep all the material."""
    reach = 0.5 + 10.0**exponent
    cut = cut_through(SHEET, [[x, 0.5 + reach], [x, 0.5 - reach]])
    assert pieces(cut.mesh) == 2
    assert np.isclose(material_areas(cut.mesh, cut.weights).sum(), 2.0)


def test_the_simulation_and_the_scene_agree_with_the_function():
    """Within the engine's reach (1000 domain sizes of the centre) the simulation cuts as the function does; beyond
    it, the simulation and a scene file refuse the point, naming it."""
    sim = Simulation(demo_scene(400), clock=lambda: 0.0)
    mesh = sim.mesh
    stroke = [[1.01, 1900.0], [1.01, -1900.0]]
    expected = cut_through(mesh, stroke)
    sim.cut(stroke)
    assert pieces(sim.mesh) == pieces(expected.mesh) == 2
    assert sim.mesh.t.shape == expected.mesh.t.shape
    with pytest.raises(ParameterError, match="polyline") as err:
        sim.cut([[1.51, 1e7], [1.51, -1e7]])
    assert err.value.field.startswith("polyline")
    assert sim.mesh.t.shape == expected.mesh.t.shape  # the refused cut left the state as it was
    data = demo_scene(400).to_dict()
    data["effects"]["incisions"] = [{"path": [[1.01, 1e7], [1.01, -1e7]]}]
    with pytest.raises(ValueError, match=r"effects.incisions\[0\].path"):
        Scene.from_dict(data)


# --- every count limit at its maximum, within a stated time ---
def sheet(effects, triangles=400):
    """A dynamic 2 x 1 sheet (no piece needs holding) of ``triangles`` triangles, held on the left."""
    effects = {"handles": [{"name": "fixed", "region": "left"}], "inertia": {"time_step": 1.0 / 30.0}, **effects}
    return Scene.from_dict({"name": "limit", "domain": {"shape": "rectangle", "width": 2.0, "height": 1.0,
                                                        "triangles": triangles},
                            "material": {"model": "stable-neo-hookean", "youngs_modulus": 1000.0,
                                         "poisson_ratio": 0.3},
                            "effects": effects, "solver": {"budget": 1e9}})


def built_within(seconds, effects, triangles=400):
    """Build the scene and run one frame within ``seconds``; the simulation."""
    start = time.perf_counter()
    sim = Simulation(sheet(effects, triangles), clock=lambda: 0.0)
    sim.frame()
    elapsed = time.perf_counter() - start
    assert elapsed < seconds, f"{elapsed:.1f} s, more than the {seconds} s stated"
    return sim


LIMITS = scene_module.ENTRY_LIMITS
rng = np.random.default_rng(7)


@pytest.mark.slow
def test_the_most_incisions_build_within_30_s():
    """100 incisions (the limit) of a 400-triangle sheet: about 6 s on a busy 2-core machine; stated: under 30 s."""
    n = LIMITS["incisions"]
    xy = np.column_stack([rng.uniform(0.1, 1.9, n), rng.uniform(0.1, 0.8, n)])
    sim = built_within(30, {"incisions": [{"path": [[x, y], [x + 0.03, y + 0.08]]} for x, y in xy.tolist()]})
    assert len(sim.scene.effects["incisions"]) == n
    with pytest.raises(ValueError, match=f"at most {n} entries"):
        sheet({"incisions": [{"path": [[1.0, 0.2], [1.0, 0.4]]}] * (n + 1)})


@pytest.mark.slow
def test_the_most_excisions_build_within_30_s():
    """100 excisions (the limit), one in every other cell of a 400-triangle sheet: about 5 s; stated: under 30 s."""
    n = LIMITS["excisions"]
    cells = [(i, j) for i in range(20) for j in range(10) if (i + j) % 2][:n]
    squares = [[[0.1 * i + a, 0.1 * j + b] for a, b in ((0.01, 0.01), (0.09, 0.01), (0.09, 0.09), (0.01, 0.09))]
               for i, j in cells]
    sim = built_within(30, {"excisions": [{"polygon": q} for q in squares]})
    assert len(sim.scene.effects["excisions"]) == n
    assert material_areas(sim.mesh, sim.model.weights).sum() < 2.0 - 0.5 * n * 0.08**2


def test_the_longest_path_and_polygon_build_within_30_s():
    """An incision's path and an excision's polygon of 1000 points (the limit): about 2 s; stated: under 30 s."""
    k = scene_module.MAX_STROKE_POINTS
    s = np.linspace(0.0, 1.0, k)
    path = np.column_stack([1.0 + 0.1 * np.sin(30.0 * s), 1.05 - 0.6 * s]).tolist()
    angle = 2.0 * np.pi * np.arange(k) / k
    polygon = np.column_stack([0.5 + 0.2 * np.cos(angle), 0.5 + 0.2 * np.sin(angle)]).tolist()
    sim = built_within(30, {"incisions": [{"path": path}], "excisions": [{"polygon": polygon}]})
    assert len(sim.scene.effects["incisions"][0]["path"]) == k
    with pytest.raises(ValueError, match=r"effects.incisions\[0\].path"):
        sheet({"incisions": [{"path": path + path[-1:]}]})


def test_the_most_handles_build_within_30_s():
    """1000 handles (the limit for handles and any registered list): under 1 s; stated: under 30 s."""
    n = scene_module.MAX_ENTRIES
    handles = [{"name": f"h{i}", "region": "left", "target": [0.0, 0.001 * (i % 3)]} for i in range(n)]
    sim = built_within(30, {"handles": handles})
    assert len(sim.model.handles) == n


def test_the_most_probes_tractions_and_sutures_build_within_30_s():
    """100 probes, 100 tractions and 100 sutures (the limits): about 3 s together; stated: under 30 s."""
    n = LIMITS["probes"]
    assert LIMITS["tractions"] == LIMITS["sutures"] == n
    probes = [{"center": [0.05 + 1.9 * i / n, 1.05], "radius": 0.05} for i in range(n)]
    tractions = [{"boundary": "top", "traction": [0.0, 0.001]} for _ in range(n)]
    sutures = [{"pairs": [[[0.5 + 0.01 * i, 0.5], [0.5 + 0.01 * i, 0.52]]], "tightness": 0.5} for i in range(n)]
    sim = built_within(30, {"probes": probes, "tractions": tractions, "sutures": sutures})
    assert len(sim.scene.effects["probes"]) == n


@pytest.mark.slow
def test_the_longest_suture_builds_within_30_s():
    """One suture of 10 000 pairs (``MAX_POINTS``, the limit): about 9 s; stated: under 30 s."""
    x = 0.1 + 1.8 * np.arange(MAX_POINTS) / MAX_POINTS
    pairs = np.stack([np.column_stack([x, np.full_like(x, 0.5)]), np.column_stack([x, np.full_like(x, 0.52)])],
                     axis=1).tolist()
    sim = built_within(30, {"sutures": [{"pairs": pairs, "tightness": 0.5}]})
    assert len(sim.scene.effects["sutures"][0]["pairs"]) == MAX_POINTS


@pytest.mark.slow
def test_the_largest_domain_builds_within_60_s():
    """200 000 triangles (``MAX_TRIANGLES``, the limit), under gravity: about 15 s with its first frame on a busy
    2-core machine; stated: under 60 s."""
    n = scene_module.MAX_TRIANGLES
    sim = built_within(60, {"gravity": {"acceleration": [0.0, -9.81]}}, triangles=n)
    assert 0.99 * n <= sim.mesh.t.shape[1] <= n
