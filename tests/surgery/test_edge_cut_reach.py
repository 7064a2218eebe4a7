"""Cuts snapped to mesh edges reach as far as cuts through elements, and the cut geometry's checks name the argument.

``topology.incise`` and ``topology.excise`` (``method="edges"``) clip a stroke to the body first, as ``cut_through``
does (``geometry.clip_to_body``, the one home of that clipping): a stroke reaching 1e6, 1e50 or 1e300 past the body
cuts exactly where a short one across it does (no coordinate overflows into an area, a snapped node or a path
cost). The checks of a mesh, of the regions and weights of a mesh cut through elements and of a ``Region`` refuse
by the offending argument's name (``ParameterError.field``).
"""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tissuefem import rectangle
from tissuefem.engine.parameters import ParameterError
from tissuefem.surgery import element_cuts, topology
from tissuefem.surgery.geometry import Region, check_regions, mesh_arrays
from tissuefem.surgery.surfaces import contact_surface

MESH = rectangle(2.0, 1.0, 10, 5)  # 2 x 1, edges 0.2 long
FAR = [1e6, 1e50, 1e300]


def _pieces(edit) -> int:
    return topology.connected_components(edit.mesh.t, edit.mesh.p.shape[1])[0]


def _strip(x0, x1, reach):
    return [[x0, reach], [x1, reach], [x1, -reach], [x0, -reach]]


@pytest.mark.parametrize("far", FAR)
def test_a_far_stroke_snapped_to_edges_cuts_the_body_in_two_as_a_short_one(far):
    short = topology.incise(MESH, [[1.0, 1.5], [1.0, -0.5]])
    for stroke in ([[1.0, far], [1.0, -far]], [[1.0, far], [1.0, 0.5], [1.0, -far]]):
        edit = topology.incise(MESH, stroke)
        assert _pieces(edit) == 2
        np.testing.assert_array_equal(edit.cut_edges, short.cut_edges)
    # slanted, through (1, 0.5): a far point of the line cannot carry the offset 0.5 (round-off), the middle one does
    slanted = topology.incise(MESH, [[1.0 - far, -0.25 * far], [1.0, 0.5], [1.0 + far, 0.25 * far]])
    assert _pieces(slanted) == 2
    np.testing.assert_array_equal(slanted.cut_edges,
                                  topology.incise(MESH, [[-1.0, 0.0], [1.0, 0.5], [3.0, 1.0]]).cut_edges)


@pytest.mark.parametrize("far", FAR)
def test_a_far_polygon_excised_by_centroids_takes_what_a_near_one_takes(far):
    near = topology.excise(MESH, _strip(0.8, 1.2, 2.0))
    edit = topology.excise(MESH, _strip(0.8, 1.2, far))
    assert _pieces(edit) == 2
    np.testing.assert_array_equal(edit.elements, near.elements)
    assert topology.excise(MESH, [[0.8, -far], [far, -far], [far, far], [0.8, far]]).mesh.t.shape[1] \
        == topology.excise(MESH, _strip(0.8, 3.0, 2.0)).mesh.t.shape[1]


@pytest.mark.parametrize("far", FAR)
def test_a_far_stroke_that_misses_the_body_is_refused_by_name(far):
    with pytest.raises(ParameterError, match="meets no material") as err:
        topology.incise(MESH, [[far, far], [far, -far]])
    assert err.value.field == "polyline"
    with pytest.raises(ParameterError, match="selects no element") as err:
        topology.excise(MESH, _strip(far, 2 * far, far))
    assert err.value.field == "region"
    with pytest.raises(ParameterError, match="non-zero area"):  # a flat polygon stays refused as such
        topology.excise(MESH, [[1.0, -far], [1.0, 0.5], [1.0, far]])


@settings(max_examples=25, deadline=None, derandomize=True)
@given(x=st.floats(0.25, 1.75), slope=st.floats(-0.3, 0.3), exponent=st.floats(0.0, 300.0))
def test_a_stroke_of_any_reach_cuts_as_the_stroke_just_across_the_body(x, slope, exponent):
    reach = 10.0 ** exponent
    line = lambda y: x + slope * (y - 0.5)  # noqa: E731
    # through (x, 0.5): the far ends cannot carry the line's offset (round-off), the middle point does
    far = topology.incise(MESH, [[line(reach), reach], [x, 0.5], [line(-reach), -reach]])
    near = topology.incise(MESH, [[line(1.5), 1.5], [x, 0.5], [line(-0.5), -0.5]])
    assert _pieces(far) == 2
    np.testing.assert_array_equal(far.cut_edges, near.cut_edges)
    strip = [[x - 0.15, reach], [x + 0.15, reach], [x + 0.15, -reach], [x - 0.15, -reach]]
    np.testing.assert_array_equal(topology.excise(MESH, strip).elements,
                                  topology.excise(MESH, [[x - 0.15, 1.5], [x + 0.15, 1.5], [x + 0.15, -0.5],
                                                         [x - 0.15, -0.5]]).elements)


# --- the cut geometry's checks name the argument ---------------------------------------------------------------------

class _Fake:
    def __init__(self, p, t):
        self.p, self.t = p, t


@pytest.mark.parametrize("mesh", [None, 5, "mesh.msh", _Fake(np.zeros((3, 4)), np.zeros((3, 1), dtype=int)),
                                  _Fake(np.array([["a", "b"], ["c", "d"]]), np.zeros((3, 1), dtype=int)),
                                  _Fake(np.zeros((2, 3), dtype=complex), np.zeros((3, 1), dtype=int)),
                                  _Fake(np.zeros((2, 3)), np.zeros((3, 1)))])
def test_a_mesh_that_is_not_a_triangle_mesh_is_refused_by_name(mesh):
    for call in (lambda: mesh_arrays(mesh), lambda: topology.incise(mesh, [[0.0, 0.0], [1.0, 1.0]]),
                 lambda: topology.excise(mesh, [[0, 0], [1, 0], [0, 1]])):
        with pytest.raises(ParameterError) as err:
            call()
        assert err.value.field == "mesh"


def test_the_regions_and_weights_of_a_cut_mesh_are_refused_by_name():
    cut = element_cuts.cut_through(MESH, [[1.03, 1.5], [1.03, 0.4]])
    m = cut.mesh.t.shape[1]
    region = next(iter(cut.regions.values()))
    for regions, weights, field in [("regions", None, "regions"), ([region], None, "regions"),
                                    ({m: region}, None, "regions"), ({-1: region}, None, "regions"),
                                    ({True: region}, None, "regions"), ({"0": region}, None, "regions"),
                                    ({0: "half"}, None, "regions[0]"), ({0: region}, np.ones(m), "weights"),
                                    (None, np.ones(m + 1), "weights"), (cut.regions, None, "weights")]:
        if field == "weights" and weights is None:
            weights = np.ones(m)  # a cut mesh's regions without their weights
        with pytest.raises(ParameterError) as err:
            contact_surface(cut.mesh, weights, regions)
        assert err.value.field == field, (regions, field)
    contact_surface(cut.mesh, cut.weights, cut.regions)  # the right ones are accepted


@pytest.mark.parametrize("polygons, field", [([[0, 0], [1, 0]], "Region.polygons[0]"),
                                             ([[[0, 0], [2, 0], [0, 1]]], "Region.polygons[0]"),
                                             ([[[0, 0], [0, 1], [1, 0]]], "Region.polygons[0]"),
                                             ([[["a", "b"], [1, 0], [0, 1]]], "Region.polygons[0]"),
                                             ((), "Region.polygons"),
                                             ([[[0, 0], [1, 0], [0, 1]], [[0, 0], [1, 0], [0, 1]]],
                                              "Region.polygons")])
def test_a_bad_region_is_refused_by_name(polygons, field):
    with pytest.raises(ParameterError) as err:
        Region(polygons)
    assert err.value.field == field
    with pytest.raises(ParameterError) as err:
        Region([[[0, 0], [1, 0], [0, 1]]], slits=[[0.1, 0.2]])
    assert err.value.field == "Region.slits"


@settings(max_examples=40, deadline=None, derandomize=True)
@given(key=st.one_of(st.integers(-10**30, 10**30), st.booleans(), st.floats(allow_nan=True), st.text(max_size=3),
                     st.none()))
def test_any_key_but_an_element_index_is_refused_by_name(key):
    m = 5
    region = Region([[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]])
    if isinstance(key, int) and not isinstance(key, bool) and 0 <= key < m:
        assert check_regions({key: region}, None, m)[0] == {key: region}
        return
    with pytest.raises(ParameterError) as err:
        check_regions({key: region}, None, m)
    assert err.value.field == "regions"
    assert math.isfinite(len(str(err.value)))
