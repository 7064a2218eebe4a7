"""The patch test on tetrahedra: an affine deformation held on the boundary of an irregular tetrahedron mesh is
reproduced exactly inside, to round-off, by P1 and P2, for linear elasticity and a large Neo-Hookean one.

An affine map ``x = X + A X + c`` has a constant ``F = I + A``, so a constant ``P``: it is in equilibrium without
body force for every material, and both element orders contain it. (``test_tets.py`` has the small-strain P1 test
on a regular box; here the mesh is irregular, the strain 20 %, and P2's mid-edge dofs take part.)
"""

from __future__ import annotations

import numpy as np
import pytest
from skfem import MeshTet

from tissuefem import Handle, LinearElastic, Model, NeoHookean
from tissuefem.engine.meshes import box, signed_volumes
from tissuefem.engine.stepping import solve

LAM, MU = 1.7, 0.6
A = np.array([[0.20, 0.10, -0.05], [0.05, -0.10, 0.15], [0.10, 0.05, 0.12]])
C = np.array([0.03, -0.02, 0.01])


def affine(X):
    return X + A @ X + C[:, None]


def irregular_box(seed=3, lengths=(1.0, 0.8, 0.7), cells=(4, 3, 3)):
    """A box of tetrahedra whose every node is moved at random by up to a fifth of a cell along each coordinate
    the box's faces leave free (so the boundary stays the box's, its faces planar)."""
    mesh = box(*lengths, *cells)
    p = mesh.p.copy()
    rng = np.random.default_rng(seed)
    for i, (length, n) in enumerate(zip(lengths, cells)):
        free = ~(np.isclose(p[i], 0.0) | np.isclose(p[i], length))
        p[i, free] += 0.2 * (length / n) * rng.uniform(-1.0, 1.0, free.sum())
    return MeshTet(p, mesh.t)


def test_the_irregular_mesh_is_irregular_and_valid():
    mesh, regular = irregular_box(), box(1.0, 0.8, 0.7, 4, 3, 3)
    vol = signed_volumes(mesh)
    assert np.all(vol > 0) and np.isclose(vol.sum(), 1.0 * 0.8 * 0.7)
    assert np.ptp(vol) > 0.5 * np.mean(vol)  # far from the regular box's equal volumes
    assert np.ptp(signed_volumes(regular)) < 1e-12


@pytest.mark.parametrize("order", [1, 2])
@pytest.mark.parametrize("material", [LinearElastic(LAM, MU), NeoHookean(LAM, MU)], ids=["linear", "neo-hookean"])
def test_an_affine_deformation_is_reproduced_exactly(material, order):
    mesh = irregular_box()
    outside = mesh.boundary_nodes()
    model = Model(mesh, material, order=order, handles=[Handle(outside, affine)])
    result = solve(model, load_steps=2, rtol=1e-13)
    assert result.converged
    exact = affine(model.dof_points) - model.dof_points  # every dof: the vertices and P2's mid-edge points
    computed = result.u.reshape(-1)
    held = np.zeros(model.n_dofs, dtype=bool)
    held[model.prescribed()[0]] = True
    assert (~held).sum() >= 3 * 12  # the free dofs: at least the 12 interior vertices'
    value = exact[model.component, np.arange(model.n_dofs)]
    assert np.max(np.abs(computed - value)) < 1e-12
    F = model.deformation_gradient(result.u)  # and F = I + A in every element (at every quadrature point)
    assert np.allclose(np.moveaxis(F, (0, 1), (-2, -1)) - (np.eye(3) + A), 0.0, rtol=0, atol=1e-11)
