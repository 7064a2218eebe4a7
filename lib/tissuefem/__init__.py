"""tissuefem: real-time soft-tissue simulation with the finite element method, on scikit-fem.

A teaching library following J. Teran's lecture notes *Simulation of elasticity, biomechanics and virtual
surgery*, in three layers, each importing only the ones below it: :mod:`tissuefem.engine` (materials, meshes,
assembly, the model and its terms, the minimiser, stepping, linear solvers, the real-time loop),
:mod:`tissuefem.surgery` (cuts, scenes, the simulation and its operations, flaps; the mouse view is imported
where it is used, ``from tissuefem.surgery.interactive import SurgeryView``, so ``import tissuefem`` loads no
pyplot) and :mod:`tissuefem.workbook` (the chapters' studies, benchmarks, figures, reference answers, the
command line). What a chapter needs is importable from here (``from tissuefem import Model, solve``): the names
are listed in ``_EXPORTS`` below and imported on first use (PEP 562), so ``import tissuefem`` itself loads neither
numpy, scipy nor scikit-fem until a name is asked for.

Index convention: ``F[i, j] = d phi_i / d X_j`` (row = spatial component), as in scikit-fem (``grad(u)[i, j] =
du_i/dX_j``) and Bonet & Wood. The notes' kinematics write the transpose, but their balance law and weak form
(``P_ij,j``) only match this one. Fields of 2x2 matrices are shaped ``[2, 2, elements, quadrature points]``.
"""

from importlib import import_module

__version__ = "0.1.0"

#: the package's face, ``{module: its public names}``: the one list behind ``__all__``, ``dir(tissuefem)`` and
#: ``tissuefem.<name>``; a name's module is imported the first time the name is asked for
_EXPORTS = {
    # constants and parameters
    "engine.constants": ("FRAME_BUDGET", "TISSUE_E", "TISSUE_NU", "TISSUE_DENSITY"),
    "engine.parameters": ("lame_parameters",),
    # 1D (chapters 1-2)
    "engine.materials1d": ("Linear1D", "NeoHookean1D", "TaylorNeoHookean1D"),
    "engine.bar1d": ("Bar1D", "Displacement", "Traction"),
    # materials and inversion
    "engine.materials": ("LinearElastic", "NeoHookean", "TaylorNeoHookean", "StableNeoHookean", "Corotated",
                         "FiberReinforced", "MATERIALS", "material"),
    "engine.inversion": ("ITFClamped", "ProjectedTangent", "projected_tangent", "rotation_preserving_svd"),
    # meshes, forms and assembly
    "engine.meshes": ("rectangle", "mesh_with_about", "flap", "fusiform_muscle", "fusiform_fiber_field", "mesh_size"),
    "engine.forms": ("residual_form", "tangent_form", "energy_form"),
    "engine.assembly": ("P1Assembler", "QuadratureAssembler", "FormsAssembler"),
    # the model and its terms
    "engine.model": ("Model", "Handle", "region_nodes"),
    "engine.terms": ("Term", "Elastic", "Fibers", "Inertia", "Load", "Probe", "Sutures"),
    "engine.contact": ("Contact", "ContactSurface"),
    # solving and stepping
    "engine.minimize": ("newton", "NewtonResult"),
    "engine.linsolve": ("LinearSolver",),
    "engine.stepping": ("Stepper", "StepReport", "solve", "StaticResult"),
    "engine.realtime": ("RealtimeSolver",),
    "engine.explicit": ("SymplecticEuler", "critical_time_step", "largest_stable_dt", "wave_speed"),
    # surgery
    "surgery.scene": ("Scene", "demo_scene", "flap_scene", "flap_path"),
    "surgery.simulation": ("Simulation",),
    "surgery.flaps": ("advancement_flap", "rotation_flap"),
    "surgery.element_cuts": ("cut_through", "excise_through"),
    "surgery.surfaces": ("contact_surface",),
}
_HOME = {name: module for module, names in _EXPORTS.items() for name in names}
_LAYERS = ("engine", "surgery", "workbook")

__all__ = [*_HOME, "__version__"]


def __getattr__(name):
    """``tissuefem.Model`` and ``from tissuefem import Model``: import the name's module once, keep the name here."""
    if name in _LAYERS:
        return import_module(f".{name}", __name__)
    if name not in _HOME:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(import_module(f".{_HOME[name]}", __name__), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted({*globals(), *__all__})
