"""The one-sided barrier on signed gaps, and the derivatives of a gap with respect to its points.

IPC [1] puts a barrier ``-(d - d^)^2 ln(d / d^)`` on the unsigned distance ``0 < d < d^``: surfaces never touch. But
a wound's lips *coincide* when cut, and a closed wound must stay closed without force, so the gap ``sigma`` is
*signed* (negative behind the surface) and the barrier acts inside, IPC's moved inward by ``d^`` (codimensional IPC's
"thickness" [2], opposite sign):

    E = kappa * sum_(points p) sum_(stretches of surface near p) l_p d^ beta(1 + (sigma + o_p) / d^),
    beta(zeta) = -(zeta - 1)^2 ln(zeta)   for 0 < zeta < 1,   beta = 0 for zeta >= 1,

``o_p`` the point's rest offset (:mod:`.candidates`), ``l_p`` its share of the rest surface length, so ``kappa`` is a
pressure (reached at an overlap of ``0.46 d^``). ``beta``, ``beta'``, ``beta''`` vanish at ``zeta = 1`` (touching lips
feel nothing). A barrier, not a penalty with a no-crossing check, which would push a point against the collision
limit step after step without converging. With ``y`` the points, the Hessian is

    d2E/dy2 = kappa l_p [ beta''(zeta) / d^ (dsigma/dy)(dsigma/dy)^T  +  beta'(zeta) d2sigma/dy2 ],

``beta'' >= 0``, ``beta' <= 0``, ``d2sigma/dy2`` indefinite: the *safe* Hessian keeps the first part.
"""

import numpy as np

from ..parameters import check_real_array


def barrier(zeta):
    """``(beta, beta', beta'')`` at ``zeta``: ``-(zeta - 1)^2 ln(zeta)`` on ``(0, 1)``, zero from 1 on (all three
    vanish at 1: the barrier starts twice differentiably; the caller never passes ``zeta <= 0``)."""
    z = check_real_array("zeta", zeta)
    inside = (z > 0.0) & (z < 1.0)
    zz = np.where(inside, z, 1.0)
    log, m = np.log(zz), zz - 1.0
    b0 = np.where(inside, -m * m * log, 0.0)
    b1 = np.where(inside, -2.0 * m * log - m * m / zz, 0.0)
    b2 = np.where(inside, -2.0 * log - 4.0 * m / zz + m * m / (zz * zz), 0.0)
    return b0, b1, b2


def _segment_gap(x):
    """``sigma = cross(w, e) / |e|`` (against the segment) by ``x = (w, e)`` (m, 4): gradient (m, 4), Hessian."""
    w, e = x[:, 0:2], x[:, 2:4]
    L2 = np.einsum("ki,ki->k", e, e)
    L = np.sqrt(L2)
    g = (w[:, 0] * e[:, 1] - w[:, 1] * e[:, 0]) / L
    n = np.stack([e[:, 1], -e[:, 0]], axis=1) / L[:, None]  # dg/dw: the outward normal
    Jw = np.stack([-w[:, 1], w[:, 0]], axis=1)  # w turned counter-clockwise
    R = np.array([[0.0, 1.0], [-1.0, 0.0]])  # e -> (e_y, -e_x)
    H_we = R[None] / L[:, None, None] - n[:, :, None] * e[:, None, :] / L2[:, None, None]
    H = np.zeros((x.shape[0], 4, 4))  # (w, w) is zero: g is linear in w
    H[:, 0:2, 2:4] = H_we
    H[:, 2:4, 0:2] = H_we.transpose(0, 2, 1)
    H[:, 2:4, 2:4] = (-(Jw[:, :, None] * e[:, None, :] + e[:, :, None] * Jw[:, None, :]) / (L2 * L)[:, None, None]
                      - (g / L2)[:, None, None] * np.eye(2)[None]
                      + 3.0 * (g / (L2 * L2))[:, None, None] * e[:, :, None] * e[:, None, :])
    return np.concatenate([n, Jw / L[:, None] - (g / L2)[:, None] * e], axis=1), H


def _end_gap(d):
    """``sigma = -|d|`` (behind an end ``v``) by ``d = y_p - y_v`` (m, 2): gradient (m, 2), Hessian."""
    r = np.hypot(d[:, 0], d[:, 1])
    unit = d / r[:, None]
    return -unit, -(np.eye(2)[None] - unit[:, :, None] * unit[:, None, :]) / r[:, None, None]


_I, _O = np.eye(2), np.zeros((2, 2))
#: each kind's local variables ``x = T y`` of the 6 coordinates ``y`` of ``(p, a, b)``, and sigma's derivatives by them
_LOCAL = {1: (np.block([[_I, -_I, _O], [_O, -_I, _I]]), _segment_gap),  # (w, e) = (y_p - y_a, y_b - y_a)
          2: (np.block([_I, -_I, _O]), _end_gap), 3: (np.block([_I, _O, -_I]), _end_gap)}


def gap_derivatives(Y, p, a, b, kind):
    """``sigma``'s gradient (m, 6) and Hessian (m, 6, 6) by the points ``(p, a, b)`` of each pair at ``Y``: ``kind`` 1
    against the segment ``a -> b``, 2 against ``a``, 3 against ``b`` (negative there: the point lies behind). By the
    chain rule through ``x = T y``: ``dsigma/dy = T^T dsigma/dx``, ``d2sigma/dy2 = T^T (d2sigma/dx2) T``."""
    grad, hess = np.zeros((p.size, 6)), np.zeros((p.size, 6, 6))
    y = np.concatenate([Y[:, p], Y[:, a], Y[:, b]])  # (6, m)
    for k, (T, derivatives) in _LOCAL.items():
        at = kind == k
        if np.any(at):
            local, H = derivatives((T @ y[:, at]).T)
            grad[at] = local @ T
            hess[at] = np.einsum("ai,kab,bj->kij", T, H, T)
    return grad, hess
