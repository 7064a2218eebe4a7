"""Anisotropic fibers (chapter 5): the fiber term on its own, and pulling along versus across.

Unit fiber directions ``g`` in the reference configuration add ``Psi_fiber(I4)``, ``I4 = |F g|^2`` the
squared fiber stretch (notes, "Continuum mechanics and elasticity"). With ``a = F g``:

    P_fiber = 2 Psi_fiber'(I4) a (x) g,    A_fiber_ijkl = 4 Psi'' a_i g_j a_k g_l + 2 Psi' d_ik g_j g_l.

The :class:`~tissuefem.engine.terms.Fibers` term takes ``Psi_fiber = k/8 (I4 - 1)^2`` (stress free at rest):
at ``F = I`` it adds ``k cos^4 theta`` along a direction at ``theta`` to the fiber
(:func:`fiber_modulus_gain`). The formulas live in :mod:`tissuefem.engine.materials`; here are the chapter's
experiments: a homogeneous strain (:func:`confined_pull`, :func:`along_vs_across`), a tensile test
(:func:`block_pull`) and the fusiform muscle pulled by its tendon (:func:`muscle_pull`)."""

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


def fiber_direction(angle_deg) -> np.ndarray:
    """The unit fiber direction ``(cos theta, sin theta)`` at ``angle_deg`` degrees from the X axis."""
    theta = math.radians(check_real("angle_deg", angle_deg))
    return np.array([math.cos(theta), math.sin(theta)])


def fiber_modulus_gain(k, angle_deg):
    """The small-strain modulus the fiber adds ``angle_deg`` degrees away from it: ``k (e . g)^4 = k cos^4
    theta`` (``k`` along, ``k/4`` at 45 degrees, nothing across)."""
    return float(check_fiber_stiffness(k) * fiber_direction(angle_deg)[0] ** 4)


def _default_base(base):
    if base is None:
        return NeoHookean.from_young(TISSUE_E, TISSUE_NU)
    if not isinstance(base, Material):
        raise ValueError(f"base must be a Material instance, got {base!r}")
    return base


def predicted_confined_modulus(angle_deg, *, stiffness=K_FIBER, base=None) -> float:
    """Small-strain confined modulus ``lam + 2 mu + k cos^4 theta`` (``lam + 2 mu``: the matrix's ``C_xxxx``)
    for a pull along X, fibers at ``angle_deg``."""
    base = _default_base(base)
    return base.lam + 2.0 * base.mu + fiber_modulus_gain(stiffness, angle_deg)


@dataclass
class PullResult:
    """A pull test: ``forces[s]``, the X force (per unit thickness) holding the pulled edge at
    ``stretches[s]``; ``nominal_stress = forces / edge_length``, the average ``P_xx``; the final state."""

    stretches: np.ndarray
    forces: np.ndarray
    edge_length: float
    model: Model
    u: np.ndarray
    newton_iterations: int

    @property
    def nominal_stress(self) -> np.ndarray:
        return self.forces / self.edge_length


def _fiber_term(stiffness, angle_deg):
    """The model's ``fibers``: ``(k, g)`` at ``angle_deg``, or ``None`` (no fibers) for ``None``."""
    return None if angle_deg is None else (check_fiber_stiffness(stiffness), fiber_direction(angle_deg))


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
    """The unit square under ``F = diag(1 + strain, 1)`` on its whole boundary (P1 is exact), fibers at
    ``angle_deg`` (``None``: none): ``nominal_stress / strain`` is the confined modulus. ``strain``: a number
    or a sequence (warm-started)."""
    base = _default_base(base)
    strains = _check_stretches(1.0 + np.atleast_1d(np.asarray(strain, dtype=float))) - 1.0
    mesh = rectangle(1.0, 1.0, n, n)
    handle = Handle(mesh.boundary_nodes())
    model = Model(mesh, base, handles=[handle], fibers=_fiber_term(stiffness, angle_deg))

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
    """:func:`confined_pull` with fibers along and across: at 90 degrees ``F g = g`` (no fiber stress), at 0
    ``P_fiber_xx = k/2 ((1 + eps)^2 - 1)(1 + eps)``: the moduli differ by ``k (1 + eps)(1 + eps/2) -> k``."""
    eps = float(strain)
    if not math.isfinite(eps) or eps == 0.0 or eps <= -1.0:
        raise ValueError(f"strain must be finite, nonzero and > -1, got {strain!r}")
    k = check_fiber_stiffness(stiffness)
    moduli = [float(confined_pull(a, eps, stiffness=k, base=base, n=n).nominal_stress[0]) / eps
              for a in (0.0, 90.0)]
    predicted = float(fiber_modulus_gain(k, 0.0) - fiber_modulus_gain(k, 90.0))
    return AlongAcross(eps, moduli[0], moduli[1], predicted, k * (1.0 + eps) * (1.0 + 0.5 * eps))


def block_pull(angle_deg, stretches, *, stiffness=K_FIBER, base=None, width=2.0, height=1.0, nx=16, ny=8,
               rtol=1e-10) -> PullResult:
    """A tensile test: a ``width x height`` strip clamped at both ends, the right end moved to ``X = stretch *
    width``; fibers at ``angle_deg`` (``None``: none). Not homogeneous: no closed form."""
    base = _default_base(base)
    stretches = _check_stretches(stretches)
    mesh = rectangle(width, height, nx, ny)
    pulled = Handle("right")
    model = Model(mesh, base, handles=[Handle("left"), pulled], fibers=_fiber_term(stiffness, angle_deg))
    return _ramp(model, pulled, lambda s: ((s - 1.0) * width, 0.0), stretches, "right", height, rtol)


def muscle_pull(stretches, *, stiffness=K_FIBER, base=None, with_fibers=True, fibers=None, mesh=None,
                rtol=1e-10) -> PullResult:
    """The fusiform muscle (:func:`~tissuefem.engine.meshes.fusiform_muscle`) held at its left tendon, its
    right one moved to ``X = stretch * length``. Fibers: ``fibers`` (``(2,)`` or ``(2, n_elements)``), by
    default :func:`~tissuefem.engine.meshes.fusiform_fiber_field`, none if not ``with_fibers``."""
    base = _default_base(base)
    stretches = _check_stretches(stretches)
    mesh = fusiform_muscle() if mesh is None else mesh
    x0, length = mesh.p[0].min(), np.ptp(mesh.p[0])
    tendon = mesh.p[1, np.isclose(mesh.p[0], x0 + length)]
    if with_fibers:
        fibers = (check_fiber_stiffness(stiffness), fusiform_fiber_field(mesh) if fibers is None else fibers)
    pulled = Handle("right_tendon")
    model = Model(mesh, base, handles=[Handle("left_tendon"), pulled], fibers=fibers if with_fibers else None)
    return _ramp(model, pulled, lambda s: ((s - 1.0) * length, 0.0), stretches, "right_tendon",
                 float(np.ptp(tendon)), rtol)
