"""Tests of tissuefem.engine.meshes: counts, orientation, named boundaries, the fusiform muscle and its fibers."""

import numpy as np
import pytest
from skfem import Basis, ElementTriP1, ElementVector

from tissuefem.engine import meshes
from tissuefem.engine.meshes import (
    flap,
    fusiform_fiber_direction,
    fusiform_fiber_field,
    fusiform_muscle,
    fusiform_width,
    mesh_with_about,
    rectangle,
    signed_areas,
)


def facet_midpoints(mesh, name):
    f = mesh.boundaries[name]
    return mesh.p[:, mesh.facets[:, f]].mean(axis=1)


def all_boundary_facets_named(mesh, names):
    named = np.concatenate([mesh.boundaries[n] for n in names])
    return np.array_equal(np.sort(np.unique(named)), np.sort(mesh.boundary_facets()))


# --- rectangle ---------------------------------------------------------------------


@pytest.mark.parametrize("diagonal", ["alternate", "right", "left"])
def test_rectangle_counts_orientation_area(diagonal):
    m = rectangle(2.0, 0.5, nx=6, ny=3, diagonal=diagonal)
    assert m.t.shape == (3, 2 * 6 * 3)
    assert m.p.shape == (2, 7 * 4)
    a = signed_areas(m)
    assert np.all(a > 0)  # counter-clockwise, survives scikit-fem's constructor
    assert np.isclose(a.sum(), 1.0)
    assert np.allclose(a, 1.0 / 36)  # all triangles are half a cell
    assert m.p[0].min() == 0.0 and m.p[0].max() == 2.0
    assert m.p[1].min() == 0.0 and m.p[1].max() == 0.5


def test_rectangle_boundaries():
    m = rectangle(2.0, 1.0, nx=5, ny=4)
    assert set(m.boundaries) == {"left", "right", "bottom", "top"}
    counts = {k: len(v) for k, v in m.boundaries.items()}
    assert counts == {"left": 4, "right": 4, "bottom": 5, "top": 5}
    assert np.allclose(facet_midpoints(m, "left")[0], 0.0)
    assert np.allclose(facet_midpoints(m, "right")[0], 2.0)
    assert np.allclose(facet_midpoints(m, "bottom")[1], 0.0)
    assert np.allclose(facet_midpoints(m, "top")[1], 1.0)
    assert all_boundary_facets_named(m, ["left", "right", "bottom", "top"])
    # usable as scikit-fem boundary names
    basis = Basis(m, ElementVector(ElementTriP1()))
    assert basis.get_dofs("left").flatten().size == 2 * 5


def test_rectangle_diagonals_differ_and_are_deterministic():
    a = rectangle(nx=3, ny=3, diagonal="alternate")
    b = rectangle(nx=3, ny=3, diagonal="alternate")
    assert np.array_equal(a.t, b.t) and np.array_equal(a.p, b.p)
    r = rectangle(nx=3, ny=3, diagonal="right")
    l = rectangle(nx=3, ny=3, diagonal="left")
    assert not np.array_equal(r.t, l.t)
    assert not np.array_equal(a.t, r.t) and not np.array_equal(a.t, l.t)
    # node numbering: row by row
    assert np.allclose(a.p[:, 1], [1 / 3, 0.0]) and np.allclose(a.p[:, 4], [0.0, 1 / 3])


@pytest.mark.parametrize(
    "kwargs, name",
    [
        (dict(width=0.0), "width"),
        (dict(height=-1.0), "height"),
        (dict(width=float("nan")), "width"),
        (dict(nx=0), "nx"),
        (dict(ny=-2), "ny"),
        (dict(nx=2.5), "nx"),
        (dict(ny=True), "ny"),
        (dict(diagonal="up"), "diagonal"),
    ],
)
def test_rectangle_validation(kwargs, name):
    with pytest.raises(ValueError, match=name):
        rectangle(**kwargs)


# --- mesh_with_about and flap ---------------------------------------------------------


@pytest.mark.parametrize("n", [2, 50, 2000, 8000, 32000])
@pytest.mark.parametrize("width, height", [(1.0, 1.0), (2.0, 1.0), (1.0, 3.0)])
def test_mesh_with_about(n, width, height):
    m = mesh_with_about(n, width, height)
    nel = m.t.shape[1]
    assert abs(nel - n) <= max(2, 0.05 * n)
    assert np.all(signed_areas(m) > 0)
    assert np.isclose(signed_areas(m).sum(), width * height)
    # cells roughly square: nx / ny follows the aspect ratio
    nx = len(m.boundaries["bottom"])
    ny = len(m.boundaries["left"])
    if n >= 2000:
        assert abs(np.log((width / nx) / (height / ny))) < 0.2


@pytest.mark.parametrize("bad", [0, -5, 1.5, None])
def test_mesh_with_about_validation(bad):
    with pytest.raises(ValueError, match="n_triangles"):
        mesh_with_about(bad)
    with pytest.raises(ValueError, match="height"):
        mesh_with_about(100, 1.0, 0.0)


def test_flap():
    m = flap(width=2.0, height=1.0, n_triangles=800)
    assert abs(m.t.shape[1] - 800) <= 40
    assert np.all(signed_areas(m) > 0)
    assert np.array_equal(m.boundaries["fixed"], m.boundaries["left"])
    assert np.array_equal(m.boundaries["handle"], m.boundaries["right"])
    assert np.allclose(facet_midpoints(m, "handle")[0], 2.0)
    with pytest.raises(ValueError, match="n_triangles"):
        flap(n_triangles=0)
    with pytest.raises(ValueError, match="width"):
        flap(width=-1.0)


# --- fusiform muscle -----------------------------------------------------------------


def test_fusiform_counts_orientation_boundaries():
    m = fusiform_muscle(length=4.0, max_width=1.0, tendon_width=0.25, nx=40, ny=8)
    assert m.t.shape == (3, 2 * 40 * 8)
    assert m.p.shape == (2, 41 * 9)
    assert np.all(signed_areas(m) > 0)
    assert set(m.boundaries) == {"left_tendon", "right_tendon", "top", "bottom"}
    counts = {k: len(v) for k, v in m.boundaries.items()}
    assert counts == {"left_tendon": 8, "right_tendon": 8, "top": 40, "bottom": 40}
    assert np.allclose(facet_midpoints(m, "left_tendon")[0], 0.0)
    assert np.allclose(facet_midpoints(m, "right_tendon")[0], 4.0)
    assert np.all(facet_midpoints(m, "top")[1] > 0) and np.all(facet_midpoints(m, "bottom")[1] < 0)
    assert all_boundary_facets_named(m, ["left_tendon", "right_tendon", "top", "bottom"])
    # area close to the integral of w(x): length * (tendon + (max - tendon) / 2)
    assert np.isclose(signed_areas(m).sum(), 4.0 * (0.25 + 0.75 / 2), rtol=2e-3)


def test_fusiform_symmetric_and_narrow_at_the_ends():
    m = fusiform_muscle(length=3.0, max_width=1.2, tendon_width=0.3, nx=30, ny=6)
    p = m.p
    # mirror symmetry about the x-axis (node by node, as a set) and about x = length / 2
    for mirrored in (np.vstack([p[0], -p[1]]), np.vstack([3.0 - p[0], p[1]])):
        a = np.lexsort(np.round(p, 12))
        b = np.lexsort(np.round(mirrored, 12))
        assert np.allclose(p[:, a], mirrored[:, b], atol=1e-12)
    # widths: tendon width at both ends, max width in the middle
    def width_at(x):
        on = np.isclose(p[0], x)
        return p[1, on].max() - p[1, on].min()

    assert np.isclose(width_at(0.0), 0.3) and np.isclose(width_at(3.0), 0.3)
    assert np.isclose(width_at(1.5), 1.2)
    assert width_at(0.3) < width_at(0.9) < width_at(1.5)
    assert np.isclose(np.abs(p[1]).max(), 0.6)


def test_fusiform_width_profile():
    x = np.linspace(0.0, 4.0, 201)
    w, dw = fusiform_width(x, 4.0, 1.0, 0.25)
    assert np.isclose(w[0], 0.25) and np.isclose(w[-1], 0.25) and np.isclose(w[100], 1.0)
    assert np.isclose(dw[0], 0.0) and np.isclose(dw[-1], 0.0, atol=1e-12) and np.isclose(dw[100], 0.0, atol=1e-12)
    h = 1e-6
    fd = (fusiform_width(x + h, 4.0, 1.0, 0.25)[0] - fusiform_width(x - h, 4.0, 1.0, 0.25)[0]) / (2 * h)
    assert np.allclose(dw, fd, atol=1e-7)


def test_fusiform_fiber_field():
    m = fusiform_muscle(nx=40, ny=8)
    f = fusiform_fiber_field(m)
    nel = m.t.shape[1]
    assert f.shape == (2, nel)
    assert np.allclose(np.hypot(f[0], f[1]), 1.0)
    assert np.all(f[0] > 0)  # tendon to tendon: always pointing along +x
    # the sizes read off the mesh are the ones it was made with
    assert np.allclose(f, fusiform_fiber_direction(m.p[:, m.t].mean(axis=1), 4.0, 1.0, 0.25))
    # horizontal on the mid-line y = 0 (and at tendons and the widest section)
    x = np.linspace(0.0, 4.0, 17)
    g = fusiform_fiber_direction(np.vstack([x, np.zeros_like(x)]))
    assert np.allclose(g, np.vstack([np.ones_like(x), np.zeros_like(x)]))
    g = fusiform_fiber_direction(np.array([[0.0, 2.0, 4.0], [0.1, 0.4, -0.1]]))
    assert np.allclose(g[1], 0.0, atol=1e-12)
    # mirror image about the x-axis: y-component flips sign
    c = m.p[:, m.t].mean(axis=1)
    order = np.lexsort(np.round(c, 10))
    mirror = np.lexsort(np.round(np.vstack([c[0], -c[1]]), 10))
    assert np.allclose(f[0, order], f[0, mirror]) and np.allclose(f[1, order], -f[1, mirror])
    # spreading out of the left tendon, converging into the right one
    off = (np.abs(c[1]) > 1e-9) & (np.abs(c[0] - 2.0) > 0.1)
    assert np.all(np.sign(f[1, off]) == np.sign(c[1, off]) * np.sign(2.0 - c[0, off]))
    # elements along the mid-line: nearly horizontal
    near_axis = np.abs(c[1]) < 0.25 / 8
    assert near_axis.any() and np.all(np.abs(f[1, near_axis]) < 0.05)


def test_fusiform_fibers_tangent_to_mapped_grid_lines():
    nx, ny = 80, 8
    m = fusiform_muscle(nx=nx, ny=ny)
    # nodes j (nx + 1) + i and j (nx + 1) + i + 1 are consecutive points of the curve eta_j
    j, i = np.meshgrid(np.arange(ny + 1), np.arange(nx), indexing="ij")
    a = (j * (nx + 1) + i).ravel()
    chord = m.p[:, a + 1] - m.p[:, a]
    chord /= np.hypot(chord[0], chord[1])
    g = fusiform_fiber_direction(0.5 * (m.p[:, a] + m.p[:, a + 1]))
    sin_angle = np.abs(chord[0] * g[1] - chord[1] * g[0])
    assert sin_angle.max() < 1e-3


@pytest.mark.parametrize(
    "kwargs, name",
    [
        (dict(length=0.0), "length"),
        (dict(max_width=-1.0), "max_width"),
        (dict(tendon_width=0.0), "tendon_width"),
        (dict(tendon_width=2.0, max_width=1.0), "tendon_width"),
        (dict(nx=0), "nx"),
        (dict(ny=1.5), "ny"),
        (dict(diagonal="x"), "diagonal"),
    ],
)
def test_fusiform_validation(kwargs, name):
    with pytest.raises(ValueError, match=name):
        fusiform_muscle(**kwargs)


def test_fusiform_fiber_validation():
    with pytest.raises(ValueError, match="points"):
        fusiform_fiber_direction(np.zeros((3, 4)))
    with pytest.raises(ValueError, match="length"):
        fusiform_fiber_direction(np.zeros((2, 4)), length=-1.0)


def test_public_names():
    for name in meshes.__all__:
        assert callable(getattr(meshes, name))


@pytest.mark.parametrize("value", [None, 3, "up"])
def test_a_choice_refused_lists_the_choices_whatever_its_type(value):
    """A field with a fixed set of choices (``diagonal``, ``unused_nodes``) names them, given a non-string too."""
    with pytest.raises(meshes.ParameterError, match=r"diagonal must be one of \['alternate', 'right', 'left'\]"):
        rectangle(nx=3, ny=3, diagonal=value)
    m = rectangle(nx=2, ny=2)
    with pytest.raises(meshes.ParameterError, match=r"unused_nodes must be one of \['refuse', 'ignore'\]"):
        meshes.check_mesh(m.p, m.t, unused_nodes=value)
