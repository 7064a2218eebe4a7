"""Exercises of chapter 10 (cutting through elements, self-contact), graded for the library and the student.

10.1 is checked against the geometry itself (the ends of the clipped piece lie
on the triangle's boundary or at the stroke's ends, its middle inside); 10.2
against the library's virtual node algorithm, which cuts a one-triangle mesh
and reports the weights of the two copies it makes.
"""

import math

import numpy as np
import pytest
from skfem import MeshTri

from grading import assert_close, implementations
from tissuefem.surgery.element_cuts import cut_through
from tissuefem.workbook import answers

TRIANGLE = np.array([[0.0, 0.0], [2.0, 0.2], [0.4, 1.5]])


def _inside(triangle, p, tol=1e-9):
    lam = answers._barycentric(triangle, p)
    return bool(np.all(lam >= -tol))


# --- 10.1 clip a stroke to a triangle ------------------------------------------------------------

CLIP = implementations("ch10", "clip_stroke", answers.clip_stroke)


@pytest.mark.parametrize("answer", CLIP)
@pytest.mark.parametrize("a, b, expected", [
    ([-1.0, 0.5], [3.0, 0.7], "through"),   # enters and leaves
    ([0.5, 0.5], [3.0, 0.7], "starts inside"),
    ([-1.0, 0.5], [0.6, 0.6], "ends inside"),
    ([0.5, 0.5], [0.8, 0.6], "inside"),
    ([-1.0, 2.0], [3.0, 2.5], None),          # misses
    ([-1.0, -0.5], [1.0, 0.5], "corner"),     # straight through corner 0 and on across
], ids=["through", "starts-inside", "ends-inside", "inside", "misses", "corner"])
def test_ex10_1_clip(answer, a, b, expected):
    a, b = np.array(a), np.array(b)
    got = answer(TRIANGLE.copy(), a.copy(), b.copy())
    ref = answers.clip_stroke(TRIANGLE, a, b)
    if ref is None:
        assert got is None, "the stroke misses the triangle: return None"
        return
    assert got is not None, "part of the stroke lies inside the triangle: return (s0, s1), not None"
    s0, s1 = (float(v) for v in got)
    assert s0 < s1, f"return (s0, s1) with s0 < s1, got ({s0}, {s1})"
    assert_close(np.array([s0, s1]), np.array(ref), "(s0, s1), the stroke's parameters where it enters and leaves",
                 rtol=1e-9, atol=1e-9, slips={"s measured from b instead of a": np.array([1 - ref[1], 1 - ref[0]])})
    for s in (s0, s1, 0.5 * (s0 + s1)):
        assert _inside(TRIANGLE, a + s * (b - a), 1e-7), f"the point at s = {s:g} is outside the triangle"


@pytest.mark.parametrize("answer", CLIP)
def test_ex10_1_touching_a_corner_only_is_no_piece(answer):
    # passes through corner 1 (2, 0.2) from outside to outside
    got = answer(TRIANGLE.copy(), np.array([2.0, -1.0]), np.array([2.0, 1.0]))
    assert got is None or got[1] - got[0] < 1e-9, "a stroke that only touches a corner holds no piece"


# --- 10.2 the shares of the pieces of a cut triangle ---------------------------------------------

SHARES = implementations("ch10", "piece_shares", answers.piece_shares)


def _library_shares(point, direction):
    """The weights of the copies cut_through makes of a one-triangle mesh cut along the line (left, right)."""
    mesh = MeshTri(TRIANGLE.T.copy(), np.array([[0], [1], [2]]), sort_t=False)
    p, d = np.asarray(point, float), np.asarray(direction, float)
    d = d / np.hypot(*d)
    cut = cut_through(mesh, [p - 10 * d, p + 10 * d])
    centroids = []
    for e in range(cut.mesh.t.shape[1]):
        poly = cut.regions[e].polygons[0]
        bary = np.column_stack([1 - poly.sum(axis=1), poly])
        centroids.append((bary @ TRIANGLE).mean(axis=0))
    left = [w for w, c in zip(cut.weights, centroids) if d[0] * (c[1] - p[1]) - d[1] * (c[0] - p[0]) > 0]
    return float(sum(left)), 1.0 - float(sum(left))


@pytest.mark.parametrize("answer", SHARES)
@pytest.mark.parametrize("point, direction", [
    ([1.0, 0.0], [0.0, 1.0]),    # vertical through the middle
    ([0.2, 0.4], [1.0, 0.2]),    # nearly horizontal
    ([1.5, 0.5], [-1.0, 1.0]),   # near corner 1: a small piece
    ([0.9, 0.7], [0.3, -1.0]),   # pointing down: left and right swap
], ids=["vertical", "flat", "corner", "downward"])
def test_ex10_2_shares_match_the_virtual_node_weights(answer, point, direction):
    got = answer(TRIANGLE.copy(), np.array(point), np.array(direction))
    assert len(got) == 2, "return (left, right)"
    expected = np.array(_library_shares(point, direction))
    assert_close(np.array(got, dtype=float), expected, "(left, right) area shares", rtol=1e-9, atol=1e-9,
                 slips={"left and right swapped (which side is left of the direction?)": expected[::-1],
                        "areas, not shares (divide by the triangle's area)": expected * 0.5 * abs(
                            2.0 * 1.5 - 0.2 * 0.4)})


@pytest.mark.parametrize("answer", SHARES)
def test_ex10_2_a_line_that_misses_keeps_the_whole_triangle_on_one_side(answer):
    left, right = answer(TRIANGLE.copy(), np.array([0.0, 3.0]), np.array([1.0, 0.0]))  # above, looking +x
    assert math.isclose(left + right, 1.0, abs_tol=1e-12) and math.isclose(right, 1.0, abs_tol=1e-12), \
        "the triangle lies wholly to the right of a line above it (looking along +x): (0, 1)"


# --- 10.3 the signed gap -------------------------------------------------------------------------

GAP = implementations("ch10", "signed_gap", answers.signed_gap)


@pytest.mark.parametrize("answer", GAP)
@pytest.mark.parametrize("p, a, b, expected", [
    ([0.5, -0.2], [0.0, 0.0], [1.0, 0.0], 0.2),   # material above the segment (its left): below is outside
    ([0.5, 0.3], [0.0, 0.0], [1.0, 0.0], -0.3),   # inside the material: behind the surface
    ([0.2, 0.4], [1.0, 1.0], [0.0, 1.0], -0.6),   # walking left: the material is below, and so is the point
    ([1.0, 1.0], [0.0, 0.0], [2.0, 2.0], 0.0),
], ids=["below-horizontal", "above-horizontal", "reversed", "on-it"])
def test_ex10_3_signed_gap(answer, p, a, b, expected):
    sigma, grad = answer(np.array(p), np.array(a), np.array(b))
    # the outward normal is the tangent turned clockwise: for a -> b along +x, n = (0, -1)
    e = np.array(b, float) - np.array(a, float)
    n = np.array([e[1], -e[0]]) / np.hypot(*e)
    exact = float(n @ (np.array(p, float) - np.array(a, float)))
    assert exact == pytest.approx(expected, abs=1e-12)  # the case as commented
    assert_close(np.array(sigma, dtype=float), np.array(exact), "sigma, the signed gap", rtol=1e-12, atol=1e-12,
                 slips={"the normal turned the wrong way (counter-clockwise): material on the right": -exact,
                        "the unsigned distance": abs(exact)})
    assert_close(np.asarray(grad, dtype=float), n, "d sigma / d p (the outward normal)", rtol=1e-12, atol=1e-12)


# --- 10.4 the skin's barrier ---------------------------------------------------------------------

SKIN = implementations("ch10", "skin_energy", answers.skin_energy)


@pytest.mark.parametrize("answer", SKIN)
@pytest.mark.parametrize("sigma", [0.0, 0.01, -0.001, -0.01, -0.019])
def test_ex10_4_skin_energy_and_its_derivative(answer, sigma):
    d, k, length = 0.02, 1000.0, 0.05
    E, dE = answer(sigma, d, k, length)
    z = 1.0 + sigma / d
    exact = -k * length * d * (z - 1) ** 2 * math.log(z) if z < 1 else 0.0
    assert_close(np.array(E, dtype=float), np.array(exact), "E", rtol=1e-10, atol=1e-14,
                 slips={"the overlap measured with the wrong sign (use 1 + sigma / d)": (
                     -k * length * d * (sigma / d) ** 2 * math.log(1 - sigma / d) if 0 < 1 - sigma / d < 1 else 0.0)})
    h = 1e-7
    if sigma < -h:
        fd = (answer(sigma + h, d, k, length)[0] - answer(sigma - h, d, k, length)[0]) / (2 * h)
        assert_close(np.array(dE, dtype=float), np.array(fd), "dE/dsigma (against a finite difference of your E)",
                     rtol=1e-5, atol=1e-9, slips={"the chain rule's 1/d is missing": fd * d})
        assert dE < 0, "behind the surface the force pushes the point out: dE/dsigma must be negative"
    else:
        assert abs(dE) < 1e-12, "in front of the surface (and at sigma = 0) nothing pushes: dE/dsigma = 0"
