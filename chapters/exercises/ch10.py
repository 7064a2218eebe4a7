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
