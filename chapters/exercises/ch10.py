"""Chapter 10 exercises: cutting through elements, and wound edges that touch.

Fill in each function, then run ``python -m tissuefem grade ch10``.
You may use numpy, scipy and scikit-fem; do not import the answer from tissuefem.

Conventions: a point is an array ``[x, y]``; a triangle is an array shaped
``(3, 2)`` whose rows are its three corners, counter-clockwise.
"""

import numpy as np


def clip_stroke(triangle, a, b):
    """Exercise 10.1. The part of the straight stroke ``a -> b`` that lies inside ``triangle``.

    Every point of the stroke is ``p(s) = a + s (b - a)`` with ``0 <= s <= 1``.
    Return ``(s0, s1)`` with ``s0 < s1``, the parameters where the stroke
    enters and leaves the triangle (``0`` if it starts inside, ``1`` if it ends
    inside), or ``None`` if no part of positive length lies in the triangle (a
    stroke that misses it, or only touches one corner).

    The idea: a point is inside a triangle when its three barycentric
    coordinates ``lambda_k`` are all >= 0. Along the stroke each ``lambda_k``
    is an affine function of ``s``: ``lambda_k(s) = lambda_k(a) + s
    (lambda_k(b) - lambda_k(a))``. Each condition ``lambda_k(s) >= 0`` keeps
    a half-line of ``s``; intersect the three with ``[0, 1]``.

    This is the first step of the virtual node algorithm: where the stroke
    crosses each element. (Inside one triangle the P1 map is affine, so the
    barycentric coordinates of the stroke's pieces do not depend on whether
    you take the triangle before or after it deformed.)
    """
    raise NotImplementedError("Exercise 10.1: clip a stroke to a triangle")


def piece_shares(triangle, point, direction):
    """Exercise 10.2. The shares of a triangle's area on the two sides of a straight cut.

    The cut is the whole line through ``point`` along ``direction``. Return
    ``(left, right)``: the fractions of the triangle's area lying to the left
    of the line (looking along ``direction``) and to its right. They add up
    to 1; a line that misses the triangle leaves ``(1, 0)`` or ``(0, 1)``.

    These are the *weights* of the two copies the virtual node algorithm
    makes of the triangle: each copy keeps the whole triangle's shape
    functions but carries only the material on its side, so its mass and
    stiffness are those of the triangle times its share.

    Hint: clip the triangle (a polygon) by the half-plane ``left`` of the
    line: walk its edges, keep the corners on the left, and add the point
    where an edge crosses the line. The shoelace formula gives the area of
    what is kept.
    """
    raise NotImplementedError("Exercise 10.2: the shares of the two pieces of a cut triangle")


def signed_gap(p, a, b):
    """Exercise 10.3. The signed gap of the point ``p`` to the segment ``a -> b``, and its gradient in ``p``.

    The material lies on the *left* of the segment (walking from ``a`` to
    ``b``), so its outward normal is the tangent ``e = b - a`` turned
    clockwise: ``n = (e_y, -e_x) / |e|``. The signed gap is ``sigma = n .
    (p - a)``: positive in front of the surface (outside the material),
    negative behind it. Assume the foot of the perpendicular from ``p`` falls
    inside the segment.

    Return ``(sigma, grad)`` with ``grad = d sigma / d p`` (an array of 2).
    Why *signed*: right after a cut the two lips of the wound coincide, so
    the unsigned distance is 0 there; only the sign tells touching (fine) from
    passing through (never allowed).
    """
    raise NotImplementedError("Exercise 10.3: the signed gap of a point to a segment")


def skin_energy(sigma, distance, stiffness, length):
    """Exercise 10.4. The contact energy of one surface point and its derivative in the gap.

    A point pressed ``-sigma`` behind the surface (``sigma < 0``) stores
    ``E = stiffness * length * distance * beta(1 + sigma / distance)`` with
    ``beta(z) = -(z - 1)^2 ln(z)`` for ``0 < z < 1`` and ``beta = 0`` for
    ``z >= 1`` (no energy in front of the surface); ``distance`` is the depth
    of the skin ``d^`` (``E`` grows without bound as the overlap reaches it)
    and ``length`` the share of the surface the point stands for.

    Return ``(E, dE_dsigma)``. Check yourself: both are 0 at ``sigma = 0``
    (touching costs nothing and pushes nothing), and ``dE/dsigma < 0`` behind
    the surface (the force pushes the point back out).
    """
    raise NotImplementedError("Exercise 10.4: the skin's barrier energy")
