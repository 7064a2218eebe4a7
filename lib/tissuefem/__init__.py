"""tissuefem: real-time soft-tissue simulation with the finite element method.

A teaching library that follows J. Teran's lecture notes *Simulation of
elasticity, biomechanics and virtual surgery*, built on scikit-fem.

Index convention (used everywhere in this package)
--------------------------------------------------
The deformation gradient is ``F[i, j] = d phi_i / d X_j`` (row = spatial
component, column = material derivative). This is the convention of
scikit-fem (``grad(u)[i, j] = du_i/dX_j``) and of Bonet & Wood. The notes
write ``F_ij = d phi_j / d X_i`` (the transpose) in their kinematics section
but then use ``P_ij,j`` (divergence over the second index) in the balance law
and weak form, which only matches ``F[i, j] = d phi_i / d X_j``. Every
formula in this package is written for that convention; formulas such as
``P = mu F + (lambda ln J - mu) F^-T`` read the same in both conventions.

Arrays of tensors follow scikit-fem's layout: a field of 2x2 matrices is
shaped ``[2, 2, elements, quadrature points]`` (any trailing shape works),
so our forms mix with scikit-fem's.
"""

from .engine.parameters import lame_parameters

__version__ = "0.1.0"

__all__ = ["lame_parameters", "__version__"]
