"""Explicit time stepping: symplectic Euler with a lumped mass, and its stability limit (CFL).

Scheme
------
The semi-discrete equations of motion (:mod:`tissuefem.engine.stepping`) are
``M a = f_ext - f_int(u)``. With the *lumped* mass ``M = diag(m)`` (each row
sum of the consistent mass moved onto the diagonal) the inverse is free, and
symplectic (semi-implicit) Euler advances the state without any solve:

    v^{n+1} = v^n + dt M^{-1} (f_ext - f_int(u^n))      (kick: forces at the *old* position)
    u^{n+1} = u^n + dt v^{n+1}                          (drift: with the *new* velocity)

on the free degrees of freedom. Prescribed ones (the handles) are set to the
handles' current targets, with the velocity that got them there,
``(u_prescribed^{n+1} - u^n) / dt``. One step costs one internal-force
evaluation, a few vector operations and no linear algebra: far cheaper than
a backward-Euler step (a Newton solve).

Using the new velocity in the drift is what makes the scheme symplectic: it
is the map of a Hamiltonian flow close to the real one, so on a stable step
it does not slowly pump energy in or drain it out (as forward and backward
Euler do). For one mode of angular frequency ``omega`` (below) the step
keeps the *modified* energy

    I = 1/2 (v^2 + omega^2 x^2 - dt omega^2 x v)

exactly, so the true energy ``1/2 (v^2 + omega^2 x^2)`` stays between
``I / (1 + dt omega / 2)`` and ``I / (1 - dt omega / 2)``: it oscillates
about its initial value, in a band that is narrow for the slow modes and
widens for the fast ones as ``dt`` nears the limit, for as long as one cares
to run.

Why it is only conditionally stable
-----------------------------------
Linearise about the rest state: ``f_int(u) ~ K u``. In a mode ``K x = omega^2 M x``
the scheme is ``v' = v - dt omega^2 x``, ``x' = x + dt v'``, a linear map of
``(x, v)`` with determinant 1 and trace ``2 - (dt omega)^2``. Its eigenvalues
stay on the unit circle (bounded oscillation) while ``|trace| <= 2``, i.e.

    dt <= 2 / omega,

and for larger ``dt`` one of them exceeds 1 in modulus and the mode grows
geometrically, however small it started (round-off suffices). The step must
therefore resolve the *fastest* mode of the mesh:

    dt <= dt_crit = 2 / omega_max,   omega_max^2 = largest eigenvalue of M^{-1} K   (free dofs),

which :func:`critical_time_step` computes. (Backward Euler has no such limit:
each of its steps minimises an incremental potential, see
:mod:`tissuefem.engine.stepping`; it pays with numerical damping instead.)

CFL condition
-------------
The fastest mode of an elastic mesh is a wave that crosses one element:
its wavelength is ~ the element size ``h`` and it travels at the dilatational
(P-) wave speed ``c = sqrt((lambda + 2 mu) / rho0)``, so ``omega_max ~ c / h``
and

    dt <= C h / c

with a Courant number ``C`` of order one that depends on the element shape
and the mass lumping (the Courant-Friedrichs-Lewy condition). Halving ``h``
halves the allowed step, so the cost of simulating one second grows like
``h^-3`` in 2D (``h^-2`` elements times ``h^-1`` steps). For the notes'
tissue (``E = 1000``, ``nu = 0.3``, ``rho0 = 1``: ``c ~ 37``) a frame of
1/30 s needs ``h`` of the order of a metre: an explicit real-time simulator
must take many sub-steps per frame. :func:`largest_stable_dt` measures the
limit by experiment (chapter 7's CFL study checks the ``dt ~ h`` scaling).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import eigsh

from .meshes import mesh_size
from .parameters import check_real, check_time_step

__all__ = [
    "SymplecticEuler",
    "ExplicitStepReport",
    "critical_time_step",
    "largest_stable_dt",
    "is_stable",
    "wave_speed",
]


@dataclass
class ExplicitStepReport:
    """What one explicit step did: ``status`` is ``"ok"`` or ``"non-finite"`` (then nothing changed)."""

    finite: bool
    status: str
    time: float  # the simulation time after the step (unchanged if it failed)
    max_speed: float  # largest velocity component after the step (NaN if it failed)

    @property
    def converged(self) -> bool:
        """Same meaning as :attr:`tissuefem.engine.stepping.StepReport.converged`: the step was taken."""
        return self.finite



def _lumped_mass(model) -> np.ndarray:
    """The lumped (row-sum) mass of the model's density, one entry per dof (refused for P2, whose
    vertices would get none: row-sum lumping works for P1 only)."""
    return model.assembler.csr(model.assembler.mass(model.density, lumped=True)).diagonal()


def _check_model(model):
    if model.inertia is not None:
        raise ValueError("the explicit scheme brings its own dynamics: give it a model without dt")


def _free_dofs(n: int, fixed) -> np.ndarray:
    free = np.ones(n, dtype=bool)
    free[fixed] = False
    return np.flatnonzero(free)


class SymplecticEuler:
    """Explicit symplectic Euler on a :class:`~tissuefem.engine.model.Model`'s body.

    The counterpart of backward Euler (:class:`~tissuefem.engine.stepping.Stepper`
    on a model with ``dt``; same state, same energy), with the lumped mass of the
    model's density and the explicit update of the module docstring. Stable
    only for ``dt`` below about :func:`critical_time_step`; above it the energy
    grows without bound. A step whose result is not finite (it blew up, or an
    ``ln J`` material inverted) leaves the state untouched and reports
    ``"non-finite"``; it never raises.

    Parameters
    ----------
    model
        The body (without ``dt``: the time step is this scheme's): mesh,
        material, handles (applied every step), loads (gravity included).
    dt
        Time step ``> 0``.

    Attributes
    ----------
    u, v
        Displacement and velocity (dof vectors, scikit-fem order); assign
        them to set an initial state.
    time
        Simulated time.
    mass
        The lumped masses, one per dof (the diagonal of ``M``).
    """

    def __init__(self, model, dt: float):
        _check_model(model)
        self.dt = check_time_step(dt)
        self.model = model
        self.mass = _lumped_mass(model)
        self.external = model.external
        self.u = model.zeros()
        self.v = model.zeros()
        self.time = 0.0
        self.last_report = None

    def step(self) -> ExplicitStepReport:
        """Advance one step (kick, then drift, then the handles); on a non-finite result keep the old state."""
        fixed, values = self.model.prescribed()
        free = _free_dofs(self.u.size, fixed)
        with np.errstate(all="ignore"):
            force = self.external - self.model.internal_force(self.u)
            v_new = self.v.copy()
            v_new[free] += self.dt * force[free] / self.mass[free]
            v_new[fixed] = (values - self.u[fixed]) / self.dt
            u_new = self.u + self.dt * v_new
            u_new[fixed] = values  # exactly the targets, not up to round-off
        if not (np.all(np.isfinite(u_new)) and np.all(np.isfinite(v_new))):
            return ExplicitStepReport(False, "non-finite", self.time, float("nan"))
        self.u, self.v = u_new, v_new
        self.time += self.dt
        return ExplicitStepReport(True, "ok", self.time, float(np.abs(v_new).max(initial=0.0)))

    def run(self, n_steps: int, energy_limit: float | None = None) -> np.ndarray:
        """Take up to ``n_steps`` steps; returns the total energy before the first and after each step.

        Stops early (the history is then shorter than ``n_steps + 1``) when a
        step is non-finite (the state is the last finite one) or, if
        ``energy_limit`` is given, once the total energy is above it or not
        finite (that state is kept and its energy is the last entry).
        :attr:`last_report` holds the last step's report.
        """
        if int(n_steps) != n_steps or n_steps < 0:
            raise ValueError(f"n_steps must be an integer >= 0, got {n_steps!r}")
        history = [self.total_energy()]
        self.last_report = None
        for _ in range(int(n_steps)):
            self.last_report = self.step()
            if not self.last_report.finite:
                break
            history.append(self.total_energy())
            if energy_limit is not None and not history[-1] <= energy_limit:
                break
        return np.array(history)

    def kinetic_energy(self) -> float:
        return 0.5 * float(self.v @ (self.mass * self.v))

    def total_energy(self) -> float:
        """Kinetic plus stored minus the work potential of the (constant) loads (as in BackwardEuler)."""
        with np.errstate(all="ignore"):
            return self.kinetic_energy() + self.model.stored_energy(self.u) - float(self.external @ self.u)


# --- the stability limit ------------------------------------------------------------------------

def critical_time_step(model, u=None) -> float:
    """The linearised stability limit of :class:`SymplecticEuler`, ``dt_crit = 2 / omega_max``.

    ``omega_max^2`` is the largest eigenvalue of the generalised problem
    ``K_ff x = omega^2 M_ff x`` on the free dofs (those no handle
    prescribes), with ``K = model.hessian(u)`` (the rest state ``u = 0``
    by default) and ``M`` the lumped mass of the model's density. Because ``M``
    is diagonal it is solved as the ordinary symmetric problem
    ``M^-1/2 K M^-1/2 y = omega^2 y`` (largest eigenvalue by Lanczos,
    :func:`scipy.sparse.linalg.eigsh`, from a fixed start vector so that the
    result does not vary between runs; small problems use a dense solver).

    A small oscillation about ``u`` stays bounded under symplectic Euler iff
    ``dt <= dt_crit`` (module docstring). Far from ``u`` the stiffness, and
    so the limit, changes: a compressed ``ln J`` material stiffens a lot.
    """
    _check_model(model)
    u = model.zeros() if u is None else np.asarray(u, dtype=float)
    m = _lumped_mass(model)
    fixed, _ = model.prescribed()
    free = _free_dofs(m.size, fixed)
    if free.size == 0:
        raise ValueError("the problem has no free degrees of freedom: nothing moves, no stability limit")
    K = model.hessian(u).tocsr()[free][:, free]
    scale = sp.diags(1.0 / np.sqrt(m[free]))
    A = (scale @ K @ scale).tocsr()
    A = 0.5 * (A + A.T)
    if free.size <= 400:
        omega2 = float(np.linalg.eigvalsh(A.toarray())[-1])
    else:
        omega2 = float(eigsh(A, k=1, which="LA", v0=np.ones(free.size), tol=1e-10,
                             return_eigenvectors=False)[0])
    if not (np.isfinite(omega2) and omega2 > 0):
        raise ValueError(f"the stiffness at u has no positive eigenvalue (omega_max^2 = {omega2!r})")
    return float(2.0 / np.sqrt(omega2))


def wave_speed(material, density: float = 1.0) -> float:
    """Dilatational (P-) wave speed ``c = sqrt((lambda + 2 mu) / rho0)`` of a material with Lamé ``lam, mu``."""
    density = float(density)
    if not (np.isfinite(density) and density > 0):
        raise ValueError(f"density must be finite and > 0, got {density!r}")
    try:
        lam, mu = float(material.lam), float(material.mu)
    except AttributeError:
        raise ValueError(f"material must have Lamé parameters lam and mu, got {material!r}") from None
    return float(np.sqrt((lam + 2.0 * mu) / density))


def _initial_perturbation(model, amplitude: float, seed: int) -> np.ndarray:
    """A seeded random displacement of the free dofs (``amplitude h`` at most), handles at their targets."""
    fixed, values = model.prescribed()
    u0 = model.zeros()
    free = _free_dofs(u0.size, fixed)
    rng = np.random.default_rng(seed)
    u0[free] = amplitude * mesh_size(model.mesh) * rng.uniform(-1.0, 1.0, size=free.size)
    u0[fixed] = values
    return u0


def is_stable(model, dt: float, *, steps: int = 400, growth: float = 10.0,
              amplitude: float = 1e-4, seed: int = 0, u0=None) -> bool:
    """Run :class:`SymplecticEuler` ``steps`` steps from rest at ``u0`` and say whether it stayed bounded.

    ``u0`` defaults to a small seeded random perturbation of the free dofs
    (``amplitude`` times the mesh size), which puts energy into every mode,
    the fastest included. Unstable means: a non-finite step, or a total
    energy above ``growth`` times the initial one at some step.
    """
    scheme = SymplecticEuler(model, dt)
    scheme.u = _initial_perturbation(model, amplitude, seed) if u0 is None else np.array(u0, dtype=float)
    e0 = scheme.total_energy()
    if not (np.isfinite(e0) and e0 > 0):
        raise ValueError(f"the initial state must have a finite positive energy, got {e0!r}")
    history = scheme.run(steps, energy_limit=growth * e0)
    return history.size == steps + 1 and bool(np.all(history <= growth * e0))


def largest_stable_dt(model, *, steps: int = 400, growth: float = 10.0,
                      amplitude: float = 1e-4, seed: int = 0, rtol: float = 0.005, dt_guess=None) -> float:
    """The largest time step with which :class:`SymplecticEuler` stays bounded, measured by bisection.

    Each trial is :func:`is_stable`: ``steps`` steps from the same seeded
    random perturbation (``amplitude`` times the mesh size, so the motion is
    linear), unstable if the total energy ever exceeds ``growth`` times its
    initial value or a step is non-finite. The search first doubles or halves
    ``dt_guess`` (default ``mesh_size / wave_speed`` if the material has Lamé
    parameters, else ``1e-3``) until one trial is stable and the next
    unstable, then bisects (geometrically) until the bracket is narrower
    than ``rtol`` (relative). Returns the stable end of the bracket.

    It measures the same thing :func:`critical_time_step` predicts, without
    the linearisation or the eigenvalue problem. Just above ``dt_crit`` the
    growth per step is slow (a factor ``~ 1 + 2 sqrt(2 eps)`` per step at
    ``dt = (1 + eps) dt_crit``), so a finite run of ``steps`` steps places the
    limit slightly high; just below it the energy of the fastest modes
    swings widely (a factor up to ``1 / (1 - dt omega / 2)``, module
    docstring), so a ``growth`` threshold near 1 places it low. On the flap
    of chapter 7's CFL study (left edge held, 4 x 2 and 8 x 4 cells) the ratio to
    :func:`critical_time_step` was about 0.65-0.72 with ``growth = 2``,
    0.985-0.99 with the default 10 and 0.999 with 100, for 100 to 2000 steps.
    """
    if int(steps) != steps or steps < 1:
        raise ValueError(f"steps must be a positive integer, got {steps!r}")
    if not (np.isfinite(growth) and growth > 1):
        raise ValueError(f"growth must be finite and > 1, got {growth!r}")
    if not (np.isfinite(rtol) and 0 < rtol < 1):
        raise ValueError(f"rtol must be in (0, 1), got {rtol!r}")
    if dt_guess is None:
        try:
            dt_guess = mesh_size(model.mesh) / wave_speed(model.material, model.density)
        except ValueError:
            dt_guess = 1e-3
    dt_guess = check_real("dt_guess", dt_guess, 0.0, lo_open=True)
    u0 = _initial_perturbation(model, amplitude, seed)

    def stable(dt):
        return is_stable(model, dt, steps=steps, growth=growth, u0=u0)

    lo = hi = dt_guess
    for _ in range(60):
        if stable(lo):
            break
        hi, lo = lo, lo / 2.0
    else:
        raise RuntimeError("largest_stable_dt: no stable time step found (is the problem at rest?)")
    if hi == lo:
        for _ in range(60):
            hi = 2.0 * hi
            if not stable(hi):
                break
            lo = hi
        else:
            raise RuntimeError("largest_stable_dt: no unstable time step found")
    while hi / lo > 1.0 + rtol:
        mid = np.sqrt(lo * hi)
        if stable(mid):
            lo = mid
        else:
            hi = mid
    return float(lo)
