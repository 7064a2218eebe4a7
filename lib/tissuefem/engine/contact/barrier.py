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


def gap_derivatives(Y, p, a, b, kind):
    """``sigma``'s gradient (m, 6) and Hessian (m, 6, 6) by the points ``(p, a, b)`` of each pair at ``Y``: ``kind`` 1
    against the segment ``a -> b``, 2 against ``a``, 3 against ``b`` (negative there: the point lies behind)."""
    m = p.size
    grad = np.zeros((m, 6))
    hess = np.zeros((m, 6, 6))
    pe = kind == 1
    if np.any(pe):
        # sigma = g(w, e) = cross(w, e) / |e| with w = y_p - y_a, e = y_b - y_a
        w = (Y[:, p] - Y[:, a])[:, pe].T  # (k, 2)
        e = (Y[:, b] - Y[:, a])[:, pe].T
        L2 = np.einsum("ki,ki->k", e, e)
        L = np.sqrt(L2)
        g = (w[:, 0] * e[:, 1] - w[:, 1] * e[:, 0]) / L
        n = np.stack([e[:, 1], -e[:, 0]], axis=1) / L[:, None]  # dg/dw: the outward normal
        Jw = np.stack([-w[:, 1], w[:, 0]], axis=1)  # w turned counter-clockwise
        dg_de = Jw / L[:, None] - (g / L2)[:, None] * e
        grad[pe, 0:2] = n  # (p, a, b) from (w, e) = (p - a, b - a)
        grad[pe, 2:4] = -n - dg_de
        grad[pe, 4:6] = dg_de
        R = np.array([[0.0, 1.0], [-1.0, 0.0]])  # e -> (e_y, -e_x)
        H_we = R[None] / L[:, None, None] - n[:, :, None] * e[:, None, :] / L2[:, None, None]
        H_ee = (-(Jw[:, :, None] * e[:, None, :] + e[:, :, None] * Jw[:, None, :]) / (L2 * L)[:, None, None]
                - (g / L2)[:, None, None] * np.eye(2)[None]
                + 3.0 * (g / (L2 * L2))[:, None, None] * e[:, :, None] * e[:, None, :])
        H4 = np.zeros((w.shape[0], 4, 4))  # (w, w) is zero: g is linear in w
        H4[:, 0:2, 2:4] = H_we
        H4[:, 2:4, 0:2] = H_we.transpose(0, 2, 1)
        H4[:, 2:4, 2:4] = H_ee
        T = np.zeros((4, 6))
        T[0:2, 0:2], T[0:2, 2:4] = np.eye(2), -np.eye(2)
        T[2:4, 2:4], T[2:4, 4:6] = -np.eye(2), np.eye(2)
        hess[pe] = np.einsum("ai,kab,bj->kij", T, H4, T)
    for corner, end, slot in ((2, a, 2), (3, b, 4)):
        pp = kind == corner
        if not np.any(pp):
            continue
        # sigma = -|d| with d = y_p - y_v
        d = (Y[:, p] - Y[:, end])[:, pp].T
        r = np.hypot(d[:, 0], d[:, 1])
        unit = d / r[:, None]
        grad[pp, 0:2] = -unit
        grad[pp, slot:slot + 2] = unit
        H2 = -(np.eye(2)[None] - unit[:, :, None] * unit[:, None, :]) / r[:, None, None]
        for r0, s0 in ((0, 1.0), (slot, -1.0)):
            for r1, s1 in ((0, 1.0), (slot, -1.0)):
                hess[pp, r0:r0 + 2, r1:r1 + 2] = s0 * s1 * H2
    return grad, hess
