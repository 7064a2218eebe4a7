"""Explicit time stepping: symplectic Euler with a lumped mass, and its stability limit (CFL).

With the *lumped* mass ``M = diag(m)`` (row sums of the consistent mass), ``M a = f_ext - f_int(u)`` steps without a
solve (handles set to their targets, with the velocity ``(u_prescribed^{n+1} - u^n) / dt``):

    v^{n+1} = v^n + dt M^{-1} (f_ext - f_int(u^n))      (kick: forces at the *old* position)
    u^{n+1} = u^n + dt v^{n+1}                          (drift: with the *new* velocity)

Symplectic: a mode of frequency ``omega`` keeps ``I = 1/2 (v^2 + omega^2 x^2 - dt omega^2 x v)`` exactly, so its
energy stays within ``I / (1 +- dt omega / 2)`` instead of drifting. **Stability:** linearised, a mode's map has
determinant 1 and trace ``2 - (dt omega)^2``: stable while ``dt <= dt_crit = 2 / omega_max``
(:func:`critical_time_step`). **CFL:** ``omega_max ~ c / h``, ``c = sqrt((lambda + 2 mu) / rho0)`` the P-wave speed,
so ``dt <= C h / c`` (``C`` of order one): for the notes' tissue (``c ~ 37``) a 1/30 s frame needs ``h`` of a metre,
so an explicit real-time simulator must sub-step. :func:`largest_stable_dt` measures the limit.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import eigsh

from .meshes import mesh_size
from .parameters import ParameterError, check_count, check_real

__all__ = ["SymplecticEuler", "ExplicitStepReport", "critical_time_step", "largest_stable_dt", "is_stable",
           "wave_speed"]


@dataclass
class ExplicitStepReport:
    """What one explicit step did: ``status`` is ``"ok"`` or ``"non-finite"`` (then nothing changed)."""

    finite: bool
    status: str
    time: float  # the simulation time after the step (unchanged if it failed)
    max_speed: float  # largest velocity component after the step (NaN if it failed)

    converged = property(lambda self: self.finite, doc="As :attr:`.stepping.StepReport.converged`: the step was taken.")


def _lumped_mass(model) -> np.ndarray:
    """The lumped (row-sum) mass, one entry per dof, of a model without ``dt`` (the explicit scheme brings its own
    dynamics); refused for P2, whose vertices would get none."""
    if model.inertia is not None:
        raise ParameterError("model", "the explicit scheme brings its own dynamics: give it a model without dt")
    return model.assembler.csr(model.assembler.mass(model.density, lumped=True)).diagonal()


class SymplecticEuler:
    """Explicit symplectic Euler on a :class:`~tissuefem.engine.model.Model` without ``dt`` (handles apply every step,
    loads are constant), stable for ``dt`` below about :func:`critical_time_step`. A non-finite step leaves the state
    untouched and reports ``"non-finite"``. Attributes: ``u, v`` (assign them to set a state), ``time``, ``mass``."""

    def __init__(self, model, dt: float):
        mass = _lumped_mass(model)
        # any finite dt > 0: the stable step of a stiff, light body lies far below an implicit step's range
        self.dt = check_real("dt", dt, 0.0, lo_open=True)
        self.model, self.mass, self.external = model, mass, model.external
        self.u, self.v = model.zeros(), model.zeros()
        self.time, self.last_report = 0.0, None

    def step(self) -> ExplicitStepReport:
        """Advance one step (kick, then drift, then the handles); on a non-finite result keep the old state."""
        fixed, values = self.model.prescribed()
        free = np.setdiff1d(np.arange(self.u.size), fixed)
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
        """Take up to ``n_steps`` steps; returns the total energy before the first and after each step. Stops early at
        a non-finite step (keeping the last finite state) or once the total energy is not ``<= energy_limit`` (keeping
        that state); :attr:`last_report` is the last step's report."""
        n_steps = check_count("n_steps", n_steps, 0)
        history = [self.total_energy()]
        self.last_report = None
        for _ in range(n_steps):
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
        """Kinetic plus stored energy minus the constant loads' work potential, as in :class:`.stepping.Stepper`."""
        with np.errstate(all="ignore"):
            return self.kinetic_energy() + self.model.stored_energy(self.u) - float(self.external @ self.u)


def critical_time_step(model, u=None) -> float:
    """The linearised stability limit ``dt_crit = 2 / omega_max`` of :class:`SymplecticEuler` at ``u`` (default:
    rest), ``omega_max^2`` the largest eigenvalue of ``M^-1/2 K M^-1/2`` on the free dofs (Lanczos from a fixed start
    vector, so that runs agree; dense when small)."""
    m = _lumped_mass(model)
    u = model.zeros() if u is None else np.asarray(u, dtype=float)
    fixed, _ = model.prescribed()
    free = np.setdiff1d(np.arange(m.size), fixed)
    if free.size == 0:
        raise ParameterError("model", "the problem has no free degrees of freedom: nothing moves, no stability limit")
    K = model.hessian(u).tocsr()[free][:, free]
    scale = sp.diags(1.0 / np.sqrt(m[free]))
    A = (scale @ K @ scale).tocsr()
    A = 0.5 * (A + A.T)  # symmetric to round-off
    if free.size <= 400:
        omega2 = float(np.linalg.eigvalsh(A.toarray())[-1])
    else:
        omega2 = float(eigsh(A, k=1, which="LA", v0=np.ones(free.size), tol=1e-10, return_eigenvectors=False)[0])
    if not (np.isfinite(omega2) and omega2 > 0):
        raise ParameterError("u", f"the stiffness at u has no positive eigenvalue (omega_max^2 = {omega2!r})")
    return float(2.0 / np.sqrt(omega2))


def wave_speed(material, density: float = 1.0) -> float:
    """Dilatational (P-) wave speed ``c = sqrt((lambda + 2 mu) / rho0)`` of a material with Lamé ``lam, mu``."""
    density = check_real("density", density, 0.0, lo_open=True)
    try:
        lam, mu = float(material.lam), float(material.mu)
    except AttributeError:
        raise ParameterError("material", f"material must have Lamé parameters lam and mu, got {material!r}") from None
    return float(np.sqrt((lam + 2.0 * mu) / density))


def _initial_perturbation(model, amplitude: float, seed: int) -> np.ndarray:
    """A seeded random displacement of the free dofs (``amplitude h`` at most), handles at their targets."""
    (fixed, values), u0 = model.prescribed(), model.zeros()
    free = np.setdiff1d(np.arange(u0.size), fixed)
    u0[free] = amplitude * mesh_size(model.mesh) * np.random.default_rng(seed).uniform(-1.0, 1.0, size=free.size)
    u0[fixed] = values
    return u0


def is_stable(model, dt: float, *, steps: int = 400, growth: float = 10.0,
              amplitude: float = 1e-4, seed: int = 0, u0=None) -> bool:
    """Whether :class:`SymplecticEuler` stays bounded for ``steps`` steps from rest at ``u0`` (default: a seeded random
    perturbation of ``amplitude`` mesh sizes, exciting every mode): no non-finite step, no total energy above
    ``growth`` times the initial one."""
    scheme = SymplecticEuler(model, dt)
    scheme.u = _initial_perturbation(model, amplitude, seed) if u0 is None else np.array(u0, dtype=float)
    e0 = scheme.total_energy()
    if not (np.isfinite(e0) and e0 > 0):
        raise ParameterError("u0", f"the initial state must have a finite positive energy, got {e0!r}")
    history = scheme.run(steps, energy_limit=growth * e0)
    return history.size == steps + 1 and bool(np.all(history <= growth * e0))


def largest_stable_dt(model, *, steps: int = 400, growth: float = 10.0,
                      amplitude: float = 1e-4, seed: int = 0, rtol: float = 0.005, dt_guess=None) -> float:
    """The largest time step with which :class:`SymplecticEuler` stays bounded (:func:`is_stable` from one seeded
    perturbation): ``dt_guess`` (default ``mesh_size / wave_speed``, else ``1e-3``) doubled or halved to a bracket,
    then geometric bisection to ``rtol``; its stable end. On chapter 7's flap the ratio to :func:`critical_time_step`
    was 0.65-0.72 with ``growth = 2``, 0.985-0.99 with the default 10 and 0.999 with 100 (the energy swings by up to
    ``1 / (1 - dt omega / 2)`` below the limit; above it, growth is slow)."""
    check_count("steps", steps)
    check_real("growth", growth, 1.0, lo_open=True)
    check_real("rtol", rtol, 0.0, 1.0, lo_open=True, hi_open=True)
    if dt_guess is None:
        try:
            dt_guess = mesh_size(model.mesh) / wave_speed(model.material, model.density)
        except ValueError:
            dt_guess = 1e-3
    dt_guess = check_real("dt_guess", dt_guess, 0.0, lo_open=True)
    u0 = _initial_perturbation(model, amplitude, seed)

    def stable(dt):
        return is_stable(model, dt, steps=steps, growth=growth, u0=u0)
    guess_stable, lo = stable(dt_guess), dt_guess
    for _ in range(60):  # double a stable guess, halve an unstable one, until its stability changes
        dt = 2.0 * lo if guess_stable else lo / 2.0
        if stable(dt) != guess_stable:
            lo, hi = (lo, dt) if guess_stable else (dt, lo)
            break
        lo = dt
    else:
        raise RuntimeError("largest_stable_dt: no " + ("unstable time step found" if guess_stable else
                                                       "stable time step found (is the problem at rest?)"))
    while hi / lo > 1.0 + rtol:
        mid = np.sqrt(lo * hi)
        lo, hi = (mid, hi) if stable(mid) else (lo, mid)
    return float(lo)
