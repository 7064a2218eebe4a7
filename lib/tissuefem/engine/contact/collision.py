"""Continuous collision detection: how far a step may go before a point reaches a wall.

A long step could carry a point past the skin, where the barrier is zero again. With ``y(tau) = y0 + tau dy``, a
point's time of impact is the first ``tau`` in ``[0, 1]`` at which it reaches a *wall* of a segment owning it then:
the line moved inward by ``d^``, ``cross(w, e) = -d^ |e|`` (squared: a quartic, solved where a quadratic bound says
it may be reached), or the circle ``|y_p - y_v| = d^`` round an end. A step is cut to :data:`SAFETY` of the earliest
(IPC's safety factor [1], :mod:`tissuefem.engine.contact`).
"""

import numpy as np

from .candidates import spread
from .surface import cross, dot

#: the fraction of the time of impact a step may take (IPC's choice)
SAFETY = 0.8


def _quartic_roots(c0, c1, c2, d, q0, q1, q2):
    """The ``tau`` in ``[0, 1]`` where ``c(tau) = -d sqrt(q(tau))``: the roots of ``c^2 - d^2 q`` with ``c < 0``."""
    coeffs = np.array([c2 * c2, 2 * c1 * c2, c1 ** 2 + 2 * c0 * c2 - d * d * q2, 2 * c0 * c1 - d * d * q1,
                       c0 ** 2 - d * d * q0])
    coeffs = coeffs / np.max(np.abs(coeffs))
    lead = np.flatnonzero(np.abs(coeffs) > 1e-14)
    if lead.size == 0 or lead[0] == 4:
        return []
    roots = np.roots(coeffs[lead[0]:])
    # nearly real roots count as real: a graze of the wall is a touch (the safe side)
    real = roots[np.abs(roots.imag) <= 1e-7 * np.maximum(1.0, np.abs(roots.real))].real
    real = real[(real >= 0.0) & (real <= 1.0)]
    return real[c0 + c1 * real + c2 * real**2 < 0].tolist()


def times_of_impact(pairs, Y0, dY, p, s) -> np.ndarray:
    """The earliest ``tau`` in ``[0, 1]`` at which each pair ``(p, s)`` of the :class:`~.candidates.CandidatePairs`
    ``pairs`` reaches a wall of its segment that owns it then, on the way ``Y0 + tau dY`` (``inf``: never). The walls
    lie at the point's depth ``d^ + o_p``."""
    out = np.full(p.size, np.inf)
    if p.size == 0:
        return out
    d = pairs.skins[p]  # each point's wall depth
    a, b = pairs.surface.segments[:, s]
    w0, dw = Y0[:, p] - Y0[:, a], dY[:, p] - dY[:, a]
    e0, de = Y0[:, b] - Y0[:, a], dY[:, b] - dY[:, a]
    # c(tau) = cross(w, e) = c0 + c1 tau + c2 tau^2;  q(tau) = |e|^2 = q0 + q1 tau + q2 tau^2
    c0, c1, c2 = cross(w0, e0), cross(w0, de) + cross(dw, e0), cross(dw, de)
    q0, q1, q2 = dot(e0, e0), 2.0 * dot(e0, de), dot(de, de)
    found = []  # (pair, tau, wall): 1 the line, 2 the circle round a, 3 the circle round b
    # the line: only pairs in front of it, which a conservative bound says may reach it (the wall needs
    # c(tau) <= -d |e(tau)| <= -d min|e|, so c's minimum over [0, 1] must get there)
    in_front = c0 + d * np.sqrt(q0) > 0
    vertex = -c1 / np.where(c2 != 0, 2.0 * c2, 1.0)
    c_min = np.where((c2 > 0) & (vertex > 0) & (vertex < 1), c0 + c1 * vertex + c2 * vertex**2,
                     np.minimum(c0, c0 + c1 + c2))
    q_vertex = np.clip(-q1 / np.where(q2 > 0, 2.0 * q2, 1.0), 0.0, 1.0)
    L_low = np.sqrt(np.maximum(q0 + q1 * q_vertex + q2 * q_vertex**2, 0.0))
    for k in np.flatnonzero(in_front & (c_min + d * L_low <= 0)).tolist():
        found += [(k, tau, 1) for tau in _quartic_roots(c0[k], c1[k], c2[k], d[k], q0[k], q1[k], q2[k])]
    # the circles: |y_p - y_v|^2 = d^2 on the way out of the disc of radius d round the end v
    for wall, end in ((2, a), (3, b)):
        r0, dr = Y0[:, p] - Y0[:, end], dY[:, p] - dY[:, end]
        A, B, C = dot(dr, dr), 2.0 * dot(r0, dr), dot(r0, r0) - d * d
        tau_out = (-B + np.sqrt(np.maximum(B * B - 4 * A * C, 0.0))) / np.where(A > 0, 2 * A, 1.0)
        leaving = (C < 0) & (A > 0) & (tau_out <= 1.0)
        found += [(k, max(float(tau_out[k]), 0.0), wall) for k in np.flatnonzero(leaving).tolist()]
    if not found:
        return out
    k, tau, wall = (np.array(column) for column in zip(*found))
    def at(i):  # the points i of each candidate at its time
        return Y0[:, i] + tau * dY[:, i]
    kind, _, sigma = pairs.classify(at, p[k], s[k])
    hit = (kind == wall) & (sigma < 0)
    # the segment owns the point there unless a neighbour (one it may meet) is nearer than d; one through the wall's
    # own corner lies at d exactly, and does not count
    hit &= ~pairs.neighbour_nearer(at, p[k], s[k], (1.0 - 1e-9) * d[k], hit)
    np.minimum.at(out, k[hit], tau[hit])
    return out


def step_fraction(pairs, Y0, dY) -> float:
    """The largest fraction of the move ``Y0 -> Y0 + dY`` of the surface points that keeps every point out of the
    walls: :data:`SAFETY` times the earliest time of impact, or 1 when nothing is hit."""
    moved = spread(dY)
    if moved == 0.0:
        return 1.0
    pairs.ensure(Y0)
    if spread(Y0 - pairs.points) + moved < 0.5 * pairs.skin:
        p, s, ignored = pairs.p, pairs.s, pairs.ignored
    else:  # a long step: the pairs that could meet on the way, found afresh
        p, s = pairs.query(Y0, pairs.reach + 2.0 * moved)
        ignored = pairs.deep_at_start(p, s)
    hinges = np.union1d(pairs.sharp_hinges(Y0), pairs.sharp_hinges(Y0 + dY))
    if hinges.size:
        hp, hs = pairs.hinge_pairs(hinges)
        p, s = np.concatenate([p, hp]), np.concatenate([s, hs])
        ignored = np.concatenate([ignored, pairs.hinge_ignored[hinges]])
    toi = float(np.min(times_of_impact(pairs, Y0, dY, p[~ignored], s[~ignored]), initial=np.inf))
    return 1.0 if toi > 1.0 else SAFETY * toi


def crossings(pairs, Y0, Y):
    """``(p, s)``: the pairs the move ``Y0 -> Y`` carries through a wall (a handle dragging tissue through tissue)."""
    dY = Y - Y0
    moved = spread(dY)
    if not moved > 0.0:
        return np.zeros(0, dtype=np.intp), np.zeros(0, dtype=np.intp)
    # a short move: the list at Y holds every pair that came within d^ on the way
    p, s = (pairs.p, pairs.s) if moved < 0.5 * pairs.skin else pairs.query(Y0, pairs.reach + 2.0 * moved)
    hit = np.isfinite(times_of_impact(pairs, Y0, dY, p, s))
    return p[hit], s[hit]
