"""Anisotropic fibers (chapter 5): the fiber term on its own, and pulling along versus across.

A field of unit fiber directions ``g`` in the *reference* configuration makes a tissue anisotropic (notes,
"Continuum mechanics and elasticity", after the Neo-Hookean model): ``Psi(F) = Psi_iso(F) + Psi_fiber(I4)``
with ``I4 = g^T F^T F g = |F g|^2``, the squared stretch of the fiber (``dX = g dS`` becomes ``dx = F g dS``).
With ``a = F g``, ``dI4 = 2 (a (x) g) : dF``, hence

    P_fiber = 2 Psi_fiber'(I4) a (x) g,    A_fiber_ijkl = 4 Psi'' a_i g_j a_k g_l + 2 Psi' d_ik g_j g_l.

For ``Psi_fiber = k/8 (I4 - 1)^2`` (the :class:`~tissuefem.engine.terms.Fibers` term; ``Psi'(1) = 0`` keeps
the rest state stress free): ``P_fiber = k/2 (I4 - 1) a (x) g`` and
``A_fiber = k (a (x) g) (x) (a (x) g) + k/2 (I4 - 1) d_ik g_j g_l``. At ``F = I`` the tangent adds
``k g (x) g (x) g (x) g``: ``k cos^4 theta`` along a direction at ``theta`` to the fiber
(:func:`fiber_modulus_gain`). The formulas live in :mod:`tissuefem.engine.materials`; here are the
chapter's experiments:

* :func:`confined_pull`: ``F = diag(1 + eps, 1)`` imposed on a square's whole boundary (P1 reproduces it
  exactly), whose reaction over ``eps`` is the confined modulus ``lam + 2 mu + k cos^4 theta`` to leading
  order (:func:`predicted_confined_modulus`); :func:`along_vs_across` compares fibers at 0 and 90 degrees,
  whose moduli differ by ``k``, exactly ``k (1 + eps)(1 + eps/2)`` at finite strain;
* :func:`block_pull`: a strip clamped at both ends and pulled, a tensile test's force-stretch curve;
* :func:`muscle_pull`: the fusiform muscle of :mod:`tissuefem.engine.meshes`, pulled by its right tendon.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..engine.constants import TISSUE_E, TISSUE_NU
from ..engine.materials import Material, NeoHookean, check_fiber_stiffness
from ..engine.meshes import fusiform_fiber_field, fusiform_muscle, rectangle
from ..engine.model import Handle, Model
from ..engine.parameters import check_real
from ..engine.stepping import solve

__all__ = ["K_FIBER", "fiber_direction", "fiber_modulus_gain", "predicted_confined_modulus", "PullResult",
           "confined_pull", "AlongAcross", "along_vs_across", "block_pull", "muscle_pull"]

#: Default fiber modulus ``k``: four times the matrix's Young's modulus.
K_FIBER = 4.0 * TISSUE_E


def _check_stiffness(k) -> float:
    return check_fiber_stiffness(k, "k")


def fiber_direction(angle_deg) -> np.ndarray:
    """The unit fiber direction ``(cos theta, sin theta)`` at ``angle_deg`` degrees from the X axis."""
    theta = math.radians(check_real("angle_deg", angle_deg))
    return np.array([math.cos(theta), math.sin(theta)])


def fiber_modulus_gain(k, angle_deg):
    """The small-strain modulus the fiber adds along a direction ``angle_deg`` degrees away from it.

    ``e_i e_j e_k e_l (k g_i g_j g_k g_l) = k (e . g)^4 = k cos^4 theta``: ``k`` along the fiber, ``k/4`` at
    45 degrees and nothing across it.
    """
    return float(_check_stiffness(k) * fiber_direction(angle_deg)[0] ** 4)


def _default_base(base):
    if base is None:
        return NeoHookean.from_young(TISSUE_E, TISSUE_NU)
    if not isinstance(base, Material):
        raise ValueError(f"base must be a Material instance, got {base!r}")
    return base


def predicted_confined_modulus(angle_deg, *, stiffness=K_FIBER, base=None) -> float:
    """Small-strain confined modulus ``lam + 2 mu + k cos^4 theta`` for a pull along X, fibers at
    ``angle_deg``: ``lam + 2 mu`` is the matrix's ``C_xxxx`` (every model linearises to linear elasticity).
    """
    base = _default_base(base)
    return base.lam + 2.0 * base.mu + fiber_modulus_gain(stiffness, angle_deg)


# --- pulling experiments ---------------------------------------------------------------

@dataclass
class PullResult:
    """A pull test: stretches, the reaction on the pulled edge and the final state. ``forces[s]`` is the X force
    (per unit thickness, the sum of the internal forces on the edge's X dofs) holding the edge at ``stretches[s]``;
    ``nominal_stress = forces / edge_length`` is the average ``P_xx`` on it.
    """

    stretches: np.ndarray
    forces: np.ndarray
    edge_length: float
    model: Model
    u: np.ndarray
    newton_iterations: int

    @property
    def nominal_stress(self) -> np.ndarray:
        return self.forces / self.edge_length

    @property
    def material(self) -> Material:
        return self.model.material


def _model(mesh, base, handles, angle_deg, stiffness, fibers=None) -> Model:
    """The pulled body: the matrix material plus, with a fibre angle or field, the fibre term."""
    if angle_deg is None and fibers is None:
        return Model(mesh, base, handles=handles)
    g = fiber_direction(angle_deg) if fibers is None else fibers
    return Model(mesh, base, handles=handles, fibers=(_check_stiffness(stiffness), g))


def _check_stretches(stretches) -> np.ndarray:
    s = np.atleast_1d(np.asarray(stretches, dtype=float))
    if s.ndim != 1 or s.size == 0 or not np.all(np.isfinite(s)) or np.any(s <= 0.0):
        raise ValueError(f"stretches must be a non-empty 1D sequence of finite numbers > 0, got {stretches!r}")
    return s


def _ramp(model, handle, to_target, stretches, pulled_edge, edge_length, rtol) -> PullResult:
    """Move ``handle`` through ``to_target(s)`` for each stretch, warm-starting each solve."""
    xdofs = model.basis.get_dofs(pulled_edge).nodal["u^1"]
    u, forces, iterations = None, [], 0
    for s in stretches:
        handle.move(to_target(s))
        result = solve(model, u0=u, rtol=rtol)
        if not result.converged:
            raise RuntimeError(f"the pull did not converge at stretch {s:g} (Newton status {result.status!r})")
        u = result.u
        iterations += result.newton_iterations
        forces.append(float(model.internal_force(u)[xdofs].sum()))
    return PullResult(stretches, np.array(forces), edge_length, model, u, iterations)


def confined_pull(angle_deg, strain, *, stiffness=K_FIBER, base=None, n=4, rtol=1e-12) -> PullResult:
    """The unit square stretched by ``F = diag(1 + strain, 1)`` imposed on its whole boundary, fibers at
    ``angle_deg`` (``None``: the matrix alone). Homogeneous, so ``nominal_stress / strain`` is the confined modulus
    (:func:`predicted_confined_modulus`). ``strain``: a number or a sequence (solved in order, warm-started).
    """
    base = _default_base(base)
    strains = _check_stretches(1.0 + np.atleast_1d(np.asarray(strain, dtype=float))) - 1.0
    mesh = rectangle(1.0, 1.0, n, n)

    def on_boundary(X):
        return np.isclose(X[0], 0.0) | np.isclose(X[0], 1.0) | np.isclose(X[1], 0.0) | np.isclose(X[1], 1.0)

    handle = Handle(on_boundary)
    model = _model(mesh, base, [handle], angle_deg, stiffness)

    def uniaxial_strain(s):
        return lambda X: np.vstack([s * X[0], X[1]])

    return _ramp(model, handle, uniaxial_strain, 1.0 + strains, "right", 1.0, rtol)


@dataclass
class AlongAcross:
    """Confined moduli with fibers along (0 degrees) and across (90 degrees) the pull, at one strain."""

    strain: float
    modulus_along: float
    modulus_across: float
    predicted_difference: float  # k: the fiber's C_ffff, the small-strain prediction
    exact_difference: float  # k (1 + eps)(1 + eps/2): the same at finite strain

    @property
    def difference(self) -> float:
        return self.modulus_along - self.modulus_across

    @property
    def relative_error(self) -> float:
        """``|difference / predicted_difference - 1|``: of order ``strain`` (the prediction is linear)."""
        return abs(self.difference / self.predicted_difference - 1.0)


def along_vs_across(strain=1e-4, *, stiffness=K_FIBER, base=None, n=4) -> AlongAcross:
    """The confined square (:func:`confined_pull`) with fibers along and across the pull. Only the fiber term
    differs: at 90 degrees ``F g = g`` (no fiber stress), at 0 degrees ``P_fiber_xx = k/2 ((1 + eps)^2 - 1)(1 + eps)``,
    so the moduli differ by ``k (1 + eps)(1 + eps/2)``, which tends to ``k``.
    """
    eps = float(strain)
    if not math.isfinite(eps) or eps == 0.0 or eps <= -1.0:
        raise ValueError(f"strain must be finite, nonzero and > -1, got {strain!r}")
    k = _check_stiffness(stiffness)
    moduli = [float(confined_pull(a, eps, stiffness=k, base=base, n=n).nominal_stress[0]) / eps
              for a in (0.0, 90.0)]
    predicted = float(fiber_modulus_gain(k, 0.0) - fiber_modulus_gain(k, 90.0))
    return AlongAcross(eps, moduli[0], moduli[1], predicted, k * (1.0 + eps) * (1.0 + 0.5 * eps))


def block_pull(angle_deg, stretches, *, stiffness=K_FIBER, base=None, width=2.0, height=1.0, nx=16, ny=8,
               rtol=1e-10) -> PullResult:
    """A tensile test: a ``width x height`` strip clamped at both ends, the right end moved to ``X = stretch *
    width`` for each of ``stretches``; fibers at ``angle_deg`` (``None``: none). The free sides narrow, the clamped
    ends cannot: the state is not homogeneous (no closed form).
    """
    base = _default_base(base)
    stretches = _check_stretches(stretches)
    mesh = rectangle(width, height, nx, ny)
    pulled = Handle("right")
    model = _model(mesh, base, [Handle("left"), pulled], angle_deg, stiffness)
    return _ramp(model, pulled, lambda s: ((s - 1.0) * width, 0.0), stretches, "right", height, rtol)


def muscle_pull(stretches, *, stiffness=K_FIBER, base=None, with_fibers=True, fibers=None, mesh=None,
                rtol=1e-10) -> PullResult:
    """The fusiform muscle (default :func:`tissuefem.engine.meshes.fusiform_muscle`, length 4) held at its left
    tendon, its right tendon moved to ``X = stretch * length``. Its fibers are ``fibers`` (``(2,)`` or ``(2,
    n_elements)``), else :func:`~tissuefem.engine.meshes.fusiform_fiber_field`; ``with_fibers=False``: the matrix
    alone. ``edge_length`` is the tendon's width.
    """
    base = _default_base(base)
    stretches = _check_stretches(stretches)
    mesh = fusiform_muscle() if mesh is None else mesh
    x0, length = mesh.p[0].min(), np.ptp(mesh.p[0])
    tendon = mesh.p[1, np.isclose(mesh.p[0], x0 + length)]
    if not with_fibers:
        fibers = None
    elif fibers is None:
        fibers = fusiform_fiber_field(mesh)
    pulled = Handle("right_tendon")
    model = _model(mesh, base, [Handle("left_tendon"), pulled], None, stiffness, fibers)
    return _ramp(model, pulled, lambda s: ((s - 1.0) * length, 0.0), stretches, "right_tendon",
                 float(np.ptp(tendon)), rtol)
