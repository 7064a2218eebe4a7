"""tissuefem: real-time soft-tissue simulation with the finite element method, on scikit-fem.

A teaching library following J. Teran's lecture notes *Simulation of elasticity, biomechanics and virtual
surgery*, in three layers, each importing only the ones below it: :mod:`tissuefem.engine` (materials, meshes,
assembly, the model and its terms, the minimiser, stepping, linear solvers, the real-time loop),
:mod:`tissuefem.surgery` (cuts, scenes, the simulation and its operations, flaps; the mouse view is imported
where it is used, ``from tissuefem.surgery.interactive import SurgeryView``, so ``import tissuefem`` loads no
pyplot) and :mod:`tissuefem.workbook` (the chapters' studies, benchmarks, figures, reference answers, the
command line). What a chapter needs is importable from here (``from tissuefem import Model, solve``).

Index convention: ``F[i, j] = d phi_i / d X_j`` (row = spatial component), as in scikit-fem (``grad(u)[i, j] =
du_i/dX_j``) and Bonet & Wood. The notes' kinematics write the transpose, but their balance law and weak form
(``P_ij,j``) only match this one. Fields of 2x2 matrices are shaped ``[2, 2, elements, quadrature points]``.
"""

from .engine.assembly import FormsAssembler, P1Assembler, QuadratureAssembler
from .engine.bar1d import Bar1D, Displacement, Traction
from .engine.constants import FRAME_BUDGET, TISSUE_DENSITY, TISSUE_E, TISSUE_NU
from .engine.contact import Contact, ContactSurface
from .engine.explicit import SymplecticEuler, critical_time_step, largest_stable_dt, wave_speed
from .engine.forms import energy_form, residual_form, tangent_form
from .engine.inversion import ITFClamped, ProjectedTangent, projected_tangent, rotation_preserving_svd
from .engine.linsolve import LinearSolver
from .engine.materials import (MATERIALS, Corotated, FiberReinforced, LinearElastic, NeoHookean, StableNeoHookean,
                               TaylorNeoHookean, material)
from .engine.materials1d import Linear1D, NeoHookean1D, TaylorNeoHookean1D
from .engine.meshes import fusiform_fiber_field, fusiform_muscle, flap, mesh_size, mesh_with_about, rectangle
from .engine.minimize import NewtonResult, newton
from .engine.model import Handle, Model, region_nodes
from .engine.parameters import lame_parameters
from .engine.realtime import RealtimeSolver
from .engine.stepping import StaticResult, Stepper, StepReport, solve
from .engine.terms import Elastic, Fibers, Inertia, Load, Probe, Sutures, Term
from .surgery.element_cuts import cut_through, excise_through
from .surgery.flaps import advancement_flap, rotation_flap
from .surgery.scene import Scene, demo_scene, flap_path, flap_scene
from .surgery.simulation import Simulation
from .surgery.surfaces import contact_surface

__version__ = "0.1.0"

__all__ = [
    # constants and parameters
    "FRAME_BUDGET", "TISSUE_E", "TISSUE_NU", "TISSUE_DENSITY", "lame_parameters",
    # 1D (chapters 1-2)
    "Linear1D", "NeoHookean1D", "TaylorNeoHookean1D", "Bar1D", "Displacement", "Traction",
    # materials and inversion
    "LinearElastic", "NeoHookean", "TaylorNeoHookean", "StableNeoHookean", "Corotated", "FiberReinforced",
    "MATERIALS", "material", "ITFClamped", "ProjectedTangent", "projected_tangent", "rotation_preserving_svd",
    # meshes, forms and assembly
    "rectangle", "mesh_with_about", "flap", "fusiform_muscle", "fusiform_fiber_field", "mesh_size",
    "residual_form", "tangent_form", "energy_form", "P1Assembler", "QuadratureAssembler", "FormsAssembler",
    # the model and its terms
    "Model", "Handle", "region_nodes", "Term", "Elastic", "Fibers", "Inertia", "Load", "Probe", "Sutures",
    "Contact", "ContactSurface",
    # solving and stepping
    "newton", "NewtonResult", "LinearSolver", "Stepper", "StepReport", "solve", "StaticResult", "RealtimeSolver",
    "SymplecticEuler", "critical_time_step", "largest_stable_dt", "wave_speed",
    # surgery
    "Scene", "Simulation", "demo_scene", "flap_scene", "flap_path", "advancement_flap", "rotation_flap",
    "cut_through", "excise_through", "contact_surface",
    "__version__",
]
