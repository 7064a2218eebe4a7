"""The studies of chapter 7 (time stepping): the CFL condition (:func:`cfl_study`;
:mod:`tissuefem.engine.explicit` derives it), the released flap and the capped frame (:func:`capped_runs`)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..engine.constants import FRAME_BUDGET, TISSUE_DENSITY, TISSUE_E, TISSUE_NU
from ..engine.explicit import SymplecticEuler, critical_time_step, largest_stable_dt, wave_speed
from ..engine.materials import StableNeoHookean
from ..engine.meshes import box, mesh_size, rectangle
from ..engine.model import Handle, Model
from ..engine.stepping import Stepper, solve
from ..surgery.scene import Scene, flap_path, flap_scene
from ..surgery.simulation import Simulation
from .measure import power_law_fit

__all__ = ["CFLStudy", "cfl_study", "released_flap", "backward_euler_run", "symplectic_energies", "flap_drag",
           "capped_runs"]

#: how far the released flap's right edge is lifted before it is let go
LIFT = 0.5
#: the capped frames: mesh sizes (triangles), Newton steps allowed per frame, frames of the drag
CAPPED_SIZES, CAPS, CAPPED_FRAMES = (500, 2000, 8000), (1, 2, 3), 40


@dataclass
class CFLStudy:
    """Rows of :func:`cfl_study` (iterating yields them: ``nx``, ``h``, ``dofs``, ``dt_measured``,
    ``dt_estimate`` = ``2 / omega_max``, ``ratio``, ``courant`` = ``dt c / h``) and the fit
    ``dt_measured = constant h^exponent`` (1 under the CFL condition)."""

    rows: list = field(default_factory=list)
    exponent: float = float("nan")
    exponent_estimate: float = float("nan")
    constant: float = float("nan")
    wave_speed: float = float("nan")

    def __iter__(self):
        return iter(self.rows)


def cfl_study(sizes=(4, 8, 16, 32)) -> CFLStudy:
    """:func:`largest_stable_dt` and :func:`critical_time_step` of symplectic Euler on chapter 7's ``2 x 1`` flap
    (stable neo-Hookean, E = 1000, nu = 0.3), left edge held, of square cells ``h = 2 / nx``, ``nx`` in ``sizes``."""
    material = StableNeoHookean.from_young(TISSUE_E, TISSUE_NU)
    c = wave_speed(material, TISSUE_DENSITY)
    study = CFLStudy(wave_speed=c)
    for nx in sizes:
        mesh = rectangle(2.0, 1.0, nx, max(1, round(nx / 2)))
        model = Model(mesh, material, handles=[Handle("left")], density=TISSUE_DENSITY)
        h = mesh_size(mesh)
        measured = largest_stable_dt(model)
        estimate = critical_time_step(model)
        study.rows.append({"nx": int(nx), "h": h, "dofs": int(model.n_dofs), "dt_measured": measured,
                           "dt_estimate": estimate, "ratio": measured / estimate, "courant": measured * c / h})
    if len(study.rows) >= 2:
        h = [r["h"] for r in study.rows]
        study.exponent, study.constant = power_law_fit(h, [r["dt_measured"] for r in study.rows])
        study.exponent_estimate, _ = power_law_fit(h, [r["dt_estimate"] for r in study.rows])
    return study


def released_flap(material=None, nx: int = 8, ny: int = 4, lift: float = LIFT, nz: int | None = None,
                  depth: float = 0.5):
    """``(model, u0)``: chapter 7's ``2 x 1`` flap (``nx x ny`` cells) with its right edge lifted by ``lift``
    (``u0``), ``model`` holding only its left edge: stepping it from ``u0`` at rest lets it go. With ``nz`` cells
    across a ``depth``, the same flap as a slab of tetrahedra (chapter 11), its right face lifted."""
    material = StableNeoHookean.from_young(TISSUE_E, TISSUE_NU) if material is None else material
    mesh = rectangle(2.0, 1.0, nx, ny) if nz is None else box(2.0, 1.0, depth, nx, ny, nz)
    pulled = Model(mesh, material, handles=[Handle("left"), Handle("right", (0.0, lift) + (0.0,) * (nz is not None))])
    result = solve(pulled, load_steps=2)
    if not result.converged:
        raise RuntimeError(f"the flap could not be lifted by {lift}: {result.status}")
    return Model(mesh, material, handles=[Handle("left")]), result.u


def backward_euler_run(model, u0, dt: float, n_steps: int, frames: bool = False):
    """Backward Euler (time step ``dt``) on ``model``'s body from ``u0`` at rest:
    ``(times, total energies[, displacements])``, one entry per step."""
    dynamic = Model(model.mesh, model.material, handles=[Handle("left")], dt=dt, density=model.density)
    scheme = Stepper(dynamic, rtol=1e-10)
    scheme.reset(u0)
    times, energies, states = [0.0], [scheme.total_energy()], [scheme.u.copy()]
    for _ in range(n_steps):
        report = scheme.step()
        if not report.converged:
            raise RuntimeError(f"backward Euler failed at t = {scheme.time:.3f}: {report.status}")
        times.append(scheme.time)
        energies.append(scheme.total_energy())
        states.append(scheme.u.copy())
    out = (np.array(times), np.array(energies))
    return out + (states,) if frames else out


def symplectic_energies(model, u0, dt: float, t_end: float, energy_limit=None) -> np.ndarray:
    """Symplectic Euler (step ``dt``) on ``model``'s body from ``u0`` at rest until ``t_end``: the total energy
    before the first step and after each, stopping early once it passes ``energy_limit``."""
    scheme = SymplecticEuler(model, dt)
    scheme.u = u0.copy()
    return scheme.run(int(np.ceil(t_end / dt)), energy_limit=energy_limit)


def flap_drag(sim, frames: int, start: int = 0) -> list:
    """Frames ``start + 1 ... start + frames`` of the standard drag (the handle on ``flap_path``): their reports."""
    return [sim.frame({"handle": flap_path((f + 1) * FRAME_BUDGET)}) for f in range(start, start + frames)]


def capped_runs(sizes=CAPPED_SIZES, caps=CAPS, frames=CAPPED_FRAMES) -> list[dict]:
    """For each size and cap: median relative residual per frame and the final state error against converged frames."""
    rows = []
    for n in sizes:
        reference = Simulation(flap_scene(n, rtol=1e-10))
        flap_drag(reference, frames)
        scale = float(np.max(np.abs(reference.u)))
        for cap in caps:
            scene = flap_scene(n, rtol=1e-12).to_dict()
            scene["solver"]["max_iterations"] = cap
            solver = Simulation(Scene.from_dict(scene))
            relative = [r.relative_residual for r in flap_drag(solver, frames)]
            rows.append({"triangles": int(solver.mesh.t.shape[1]), "cap": cap,
                         "median_relative_residual": float(np.median(relative)),
                         "state_error": float(np.max(np.abs(solver.u - reference.u)) / scale)})
    return rows
