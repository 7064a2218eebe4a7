"""The sign of the contact gap: the signed distance to a closed polyline says inside exactly where a point-in-polygon
test does (the nearest feature's sign, a corner's by its pseudonormal), for random simple polygons either way round
(material inside, or a hole: material outside) and random points, ties between equally near features included."""

import numpy as np
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from tissuefem.engine.contact import ContactSurface
from tissuefem.engine.contact.candidates import CandidatePairs


def _inside(q, poly):
    """Even-odd ray casting: is the point q (2,) inside the polygon poly (n, 2)?"""
    x, y = q
    a, b = poly, np.roll(poly, -1, axis=0)
    straddles = (a[:, 1] > y) != (b[:, 1] > y)
    with np.errstate(divide="ignore", invalid="ignore"):
        at = a[:, 0] + (y - a[:, 1]) * (b[:, 0] - a[:, 0]) / (b[:, 1] - a[:, 1])
    return bool(np.count_nonzero(straddles & (x < at)) % 2)


def _signed_distance(poly, hole, q):
    """The gap of the query point to the nearest segments of the polygon's surface (material on each segment's left):
    the signs of every pair at the least distance, and that distance."""
    n = poly.shape[0]
    a = np.arange(n)
    segments = np.stack([a, np.roll(a, -1)]) if not hole else np.stack([np.roll(a, -1), a])
    # the query is one more point of the surface, on no segment (far away while the pairs are set up)
    surface = ContactSurface(np.arange(n + 1)[:, None], np.ones((n + 1, 1)), segments, n + 1)
    Y = np.concatenate([poly.T, [[100.0], [100.0]]], axis=1)
    length = np.hypot(*(Y[:, segments[1]] - Y[:, segments[0]]))
    pairs = CandidatePairs(surface, Y, length, 1e-3 * float(length.min()), float(length.min()))
    Y[:, n] = q
    p, s = np.full(n, n), np.arange(n)
    _, distance, sigma = pairs.classify(lambda i: Y[:, i], p, s)
    nearest = distance <= distance.min() * (1.0 + 1e-12)
    return np.sign(sigma[nearest]), float(distance.min())


@st.composite
def star_polygons(draw):
    """Simple polygons, counter-clockwise: vertices at increasing angles, random radii (convex and reflex corners)."""
    n = draw(st.integers(3, 12))
    gaps = np.array(draw(st.lists(st.floats(0.2, 1.0), min_size=n, max_size=n)))
    angles = draw(st.floats(0.0, 2 * np.pi)) + 2 * np.pi * np.cumsum(gaps) / gaps.sum()
    radii = np.array(draw(st.lists(st.floats(0.2, 1.0), min_size=n, max_size=n)))
    poly = np.stack([radii * np.cos(angles), radii * np.sin(angles)], axis=1)
    # no straight corner (three vertices in a line, e.g. a flat triangle, has no inside to test)
    e1, e2 = poly - np.roll(poly, 1, axis=0), np.roll(poly, -1, axis=0) - poly
    turn = np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]) / (np.hypot(*e1.T) * np.hypot(*e2.T))
    assume(turn.min() > 0.05)
    return poly


@settings(max_examples=300, deadline=None, derandomize=True, database=None)
@given(star_polygons(), st.booleans(), st.floats(-1.2, 1.2), st.floats(-1.2, 1.2))
def test_the_gap_is_negative_exactly_inside_the_material(poly, hole, x, y):
    q = np.array([x, y])
    signs, distance = _signed_distance(poly, hole, q)
    assume(distance > 1e-9)  # on the surface the sign says nothing
    assert np.all(signs == signs[0])  # equally near features agree (a corner from either of its segments)
    inside = _inside(q, poly) != hole  # in the material
    assert (signs[0] < 0) == inside


@settings(max_examples=100, deadline=None, derandomize=True, database=None)
@given(star_polygons(), st.integers(0, 11), st.floats(0.01, 0.5), st.booleans())
def test_points_on_a_corners_bisector_take_the_pseudonormals_sign(poly, corner, r, hole):
    # equally near both segments of a corner: the tie gives one answer, the right one
    corner = corner % poly.shape[0]
    v, before, after = poly[corner], poly[corner - 1], poly[(corner + 1) % poly.shape[0]]
    u1, u2 = (before - v) / np.hypot(*(before - v)), (after - v) / np.hypot(*(after - v))
    bisector = u1 + u2
    assume(np.hypot(*bisector) > 1e-3)
    for direction in (bisector, -bisector):
        q = v + r * direction / np.hypot(*direction)
        signs, distance = _signed_distance(poly, hole, q)
        assume(distance > 1e-9)
        assert np.all(signs == signs[0])
        assert (signs[0] < 0) == (_inside(q, poly) != hole)
