"""The studies of chapter 11 (tissue in 3D): a Neo-Hookean bar of tetrahedra stretched and twisted by its end
faces (:func:`twisted_bar`), a real-time drag of a slab's corner (:func:`realtime_drag`), and a 3D scene grabbed,
dragged and probed between frames (:func:`probe_and_drag`). Chapter 6's crush
and release (:mod:`~tissuefem.workbook.hardcases`, ``block(dim=3)``) and chapter 7's released flap
(:func:`~tissuefem.workbook.timestepping.released_flap` with ``nz``) take tetrahedra as they are."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..engine.constants import FRAME_BUDGET, TISSUE_E, TISSUE_NU
from ..engine.materials import NeoHookean
from ..engine.meshes import box
from ..engine.model import Handle, Model
from ..engine.parameters import lame_parameters
from ..engine.realtime import RealtimeSolver
from ..engine.stepping import Stepper
from ..surgery.scene import Scene
from ..surgery.simulation import Simulation

__all__ = ["BAR", "TwistResult", "twist_map", "twisted_bar", "drag_path", "realtime_drag", "PROBE_SCENE",
           "probe_and_drag"]

#: the bar of the twist: ``(length, width, height)`` and its cells along each
BAR = {"size": (2.0, 0.6, 0.6), "cells": (10, 3, 3)}


def twist_map(angle: float, stretch: float, centre):
    """The map of the bar's right face: a turn by ``angle`` (radians, right-handed about +x) about the axis along x
    through ``centre`` ``(y, z)``, then a pull by ``stretch`` along x; ``(3, n) -> (3, n)``."""
    c, s = math.cos(angle), math.sin(angle)
    yc, zc = (float(v) for v in centre)

    def phi(X):
        y, z = X[1] - yc, X[2] - zc
        return np.stack([X[0] + stretch, yc + c * y - s * z, zc + s * y + c * z])

    return phi


@dataclass
class TwistResult:
    """What :func:`twisted_bar` did: the model (its right handle at the last target), the state, and per load step
    the angle (degrees), the reports and the axial force on the right face (the x component of its reaction)."""

    model: Model
    u: np.ndarray
    angles: list = field(default_factory=list)
    reports: list = field(default_factory=list)
    axial_force: list = field(default_factory=list)

    @property
    def converged(self) -> bool:
        return bool(self.reports) and all(r.converged for r in self.reports)


def twisted_bar(angle: float = 90.0, stretch: float = 0.2, steps: int = 6, material=None, size=None,
                cells=None) -> TwistResult:
    """The bar :data:`BAR` held at its left face, its right face turned by ``angle`` degrees about the bar's axis
    and pulled by ``stretch`` times its length, in ``steps`` equal load steps (each a Newton solve from the last;
    a turn must be followed in steps, since a straight-line ramp of the displacements would shrink the face)."""
    material = NeoHookean(*lame_parameters(TISSUE_E, TISSUE_NU)) if material is None else material
    size = BAR["size"] if size is None else size
    mesh = box(*size, *(BAR["cells"] if cells is None else cells))
    centre = (0.5 * size[1], 0.5 * size[2])
    right = Handle("right", name="right")
    model = Model(mesh, material, handles=[Handle("left", name="left"), right])
    stepper = Stepper(model, rtol=1e-10)
    result = TwistResult(model=model, u=stepper.u)
    for k in range(1, steps + 1):
        right.move(twist_map(math.radians(angle) * k / steps, stretch * size[0] * k / steps, centre))
        report = stepper.step()
        result.reports.append(report)
        if not report.converged:
            break
        result.angles.append(angle * k / steps)
        result.axial_force.append(float(model.reaction(stepper.u, "right")[0]))
    result.u = stepper.u.copy()
    return result


def drag_path(t: float, reach: float = 0.4):
    """Where the grabbed corner of :func:`realtime_drag` is moved at time ``t`` (seconds): up, then across (along
    z) and back, over a second: a displacement ``(dx, dy, dz)``."""
    s = min(max(t, 0.0), 1.0)
    return (0.0, reach * math.sin(0.5 * math.pi * min(2.0 * s, 1.0)), 0.6 * reach * math.sin(math.pi * s))


def realtime_drag(material=None, frames: int = 30, budget: float = FRAME_BUDGET, size=(2.0, 0.5, 0.5),
                  cells=(8, 2, 2), radius: float = 0.3) -> dict:
    """A slab held at its left face, the nodes within ``radius`` of its right top back corner grabbed and moved
    along :func:`drag_path`, one :class:`~tissuefem.engine.realtime.RealtimeSolver` frame of ``budget`` seconds per
    1/30 s: ``model``, ``reports`` (one per frame), ``positions`` (after each frame), ``grab`` (node indices)."""
    material = NeoHookean(*lame_parameters(TISSUE_E, TISSUE_NU)) if material is None else material
    mesh = box(*size, *cells)
    grab = Handle({"near": [size[0], size[1], 0.0], "radius": radius}, name="grab")
    model = Model(mesh, material, handles=[Handle("left", name="left"), grab])
    solver = RealtimeSolver(model, budget=budget)
    reports, positions = [], []
    for f in range(1, frames + 1):
        reports.append(solver.frame({"grab": drag_path(f * FRAME_BUDGET)}))
        positions.append(model.positions(solver.u))
    return {"model": model, "reports": reports, "positions": positions, "grab": grab.nodes}


#: the scene of :func:`probe_and_drag`: a block of tetrahedra held on its bottom face, quasistatic frames
PROBE_SCENE = {
    "name": "probed block",
    "domain": {"shape": "block", "lx": 2.0, "ly": 0.6, "lz": 0.6, "nx": 10, "ny": 3, "nz": 3},
    "material": {"model": "stable-neo-hookean", "youngs_modulus": TISSUE_E, "poisson_ratio": TISSUE_NU},
    "effects": {"handles": [{"name": "base", "region": "bottom"}]},
}


def probe_and_drag(frames: int = 30, radius: float = 0.2, depth: float = 0.12, slide: float = 0.3,
                   stiffness: float | None = None, budget: float = FRAME_BUDGET, clock=None) -> dict:
    """The scene :data:`PROBE_SCENE` in real-time frames of ``budget`` seconds: a ball of ``radius`` pressed into
    the top face to ``depth`` over the first third of the frames and then slid along it by ``slide`` (penalty
    ``stiffness``, default the scene's: 100 E / radius), while the top right
    front corner is grabbed and dragged up and out (:meth:`~tissuefem.surgery.simulation.Simulation.grab`,
    ``drag``, ``add_probe``, ``move_probe`` between frames). ``rows``: per frame the milliseconds, Newton
    iterations, convergence, the force on the ball ``(3,)`` (the sum of the contact forces on the body, opposite)
    and the penetration left; ``simulation``."""
    data = {**PROBE_SCENE, "solver": {"budget": budget}}
    sim = Simulation(Scene.from_dict(data)) if clock is None else Simulation(Scene.from_dict(data), clock=clock)
    top = PROBE_SCENE["domain"]["ly"]
    mid = 0.5 * PROBE_SCENE["domain"]["lz"]
    corner = np.array([PROBE_SCENE["domain"]["lx"], top, PROBE_SCENE["domain"]["lz"]])
    grab = sim.grab(corner.tolist(), radius=0.25)
    ball = sim.add_probe([0.5, top + radius, mid], radius, stiffness)
    press = max(1, frames // 3)
    rows = []
    for f in range(1, frames + 1):
        s = min(f / press, 1.0)
        x_ball = 0.5 + slide * max(0.0, (f - press) / max(1, frames - press))
        sim.move_probe(ball, [x_ball, top + radius - depth * s, mid])
        sim.drag(grab, (corner + np.array([0.0, 0.25, 0.2]) * min(f / frames * 1.5, 1.0)).tolist())
        report = sim.frame()
        probe = sim.model.probes[0]
        force = probe.gradient(sim.u).reshape(-1, sim.model.dim).sum(axis=0)  # on the ball: minus the body's
        rows.append({"frame": f, "ms": 1000.0 * report.elapsed, "newton": report.newton_iterations,
                     "converged": bool(report.converged), "force": force, "penetration": probe.penetration(sim.u),
                     "ball": x_ball})
    return {"rows": rows, "simulation": sim, "grab": grab, "ball": ball}
