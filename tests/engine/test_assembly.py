"""Tests of tissuefem.engine.assembly.P1Assembler against the scikit-fem forms, finite differences and invariances."""

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from skfem import Basis, ElementTriP1, ElementVector, MeshTri, asm

from tissuefem.engine import forms
from tissuefem.engine.assembly import P1Assembler, make_assembler
from tissuefem.engine.parameters import ParameterError
from tissuefem.engine.materials import Corotated, FiberReinforced, NeoHookean, StableNeoHookean
from tissuefem.engine.meshes import fusiform_fiber_field, fusiform_muscle, rectangle

from helpers import isotropic_materials

LAM, MU = 3.0, 1.5

# scikit-fem's own MeshTri sorts vertex indices: about half the triangles are
# clockwise, which exercises the reorientation. 32 triangles.
MESH = MeshTri().refined(2)
NEL = MESH.t.shape[1]
FIBERS = np.random.default_rng(7).standard_normal((2, NEL))

MATERIALS = {
    **isotropic_materials(LAM, MU),
    "fiber-uniform": FiberReinforced(NeoHookean(LAM, MU), 4.0, [1.0, 0.5]),
    "fiber-per-element": FiberReinforced(StableNeoHookean(LAM, MU), 4.0, FIBERS),
    "fiber-twice": FiberReinforced(FiberReinforced(Corotated(LAM, MU), 2.0, FIBERS), 3.0, [0.0, 1.0]),
}
FRAME_INDIFFERENT = ["neo-hookean", "taylor-neo-hookean", "stable-neo-hookean", "corotated", "fiber-uniform", "fiber-per-element", "fiber-twice"]


def rel(a, b):
    if sp.issparse(a):
        return spla.norm(a - b) / spla.norm(b)
    return np.linalg.norm(a - b) / np.linalg.norm(b)


@pytest.fixture(scope="module")
def basis():
    return Basis(MESH, ElementVector(ElementTriP1()))


@pytest.fixture(scope="module")
def assembler():
    return P1Assembler(MESH)


def random_u(n, scale=0.05, seed=0):
    return scale * np.random.default_rng(seed).standard_normal(n)


# --- agreement with the reference forms -------------------------------------------


@pytest.mark.parametrize("name", list(MATERIALS))
def test_matches_scikit_fem_forms(name, basis, assembler):
    mat = MATERIALS[name]
    u = random_u(basis.N)
    ui = basis.interpolate(u)
    r_ref = asm(forms.residual_form(mat), basis, u=ui)
    K_ref = asm(forms.tangent_form(mat), basis, u=ui)
    E_ref = asm(forms.energy_form(mat), basis, u=ui)
    r, K = assembler.residual_and_tangent(u, mat)
    assert rel(r, r_ref) < 1e-12
    assert rel(K, K_ref) < 1e-12
    assert abs(assembler.energy(u, mat) - E_ref) <= 1e-12 * abs(E_ref)
    # the separate calls give the same numbers as the combined one
    assert np.array_equal(assembler.residual(u, mat), r)
    assert np.array_equal(assembler.tangent(u, mat).data, K.data)


def test_matches_forms_on_fusiform_muscle_with_fiber_field():
    mesh = fusiform_muscle(nx=12, ny=4)
    mat = FiberReinforced(NeoHookean(LAM, MU), 10.0, fusiform_fiber_field(mesh))
    basis = Basis(mesh, ElementVector(ElementTriP1()))
    u = random_u(basis.N, scale=0.01, seed=3)
    ui = basis.interpolate(u)
    a = P1Assembler(mesh, mat)
    assert a.flipped.size == 0  # our meshes are counter-clockwise already
    assert rel(a.residual(u), asm(forms.residual_form(mat), basis, u=ui)) < 1e-12
    assert rel(a.tangent(u), asm(forms.tangent_form(mat), basis, u=ui)) < 1e-12


def test_pattern_matches_scikit_fem(basis, assembler):
    K_ref = asm(forms.tangent_form(MATERIALS["neo-hookean"]), basis, u=basis.interpolate(random_u(basis.N)))
    K_ref = K_ref.tocsr()
    K_ref.sort_indices()
    assert np.array_equal(K_ref.indptr, assembler.indptr)
    assert np.array_equal(K_ref.indices, assembler.indices)


# --- degrees of freedom and geometry ------------------------------------------------


def test_dof_ordering_matches_scikit_fem(basis, assembler):
    n_nodes = MESH.p.shape[1]
    assert assembler.n_dofs == basis.N == 2 * n_nodes
    assert np.array_equal(basis.nodal_dofs, np.vstack([2 * np.arange(n_nodes), 2 * np.arange(n_nodes) + 1]))
    # u = (a X + b Y, c X + d Y) interleaved per node gives F = I + [[a, b], [c, d]] everywhere
    G = np.array([[0.1, -0.2], [0.3, 0.05]])
    u = np.empty(basis.N)
    u[0::2] = G[0] @ MESH.p
    u[1::2] = G[1] @ MESH.p
    F = assembler.deformation_gradient(u)
    assert F.shape == (2, 2, NEL)
    assert np.allclose(F, (np.eye(2) + G)[:, :, None])
    # the same vector seen through scikit-fem
    assert np.allclose(np.eye(2)[:, :, None, None] + basis.interpolate(u).grad, F[..., None])


def test_geometry_and_reorientation(assembler):
    x = MESH.p[:, MESH.t]
    signed = 0.5 * ((x[0, 1] - x[0, 0]) * (x[1, 2] - x[1, 0]) - (x[0, 2] - x[0, 0]) * (x[1, 1] - x[1, 0]))
    assert np.array_equal(assembler.flipped, np.flatnonzero(signed < 0))
    assert assembler.flipped.size > 0
    assert np.allclose(assembler.areas, np.abs(signed))
    assert np.isclose(assembler.areas.sum(), 1.0)
    # counter-clockwise copy, same vertex sets, mesh untouched
    assert np.array_equal(np.sort(assembler.t, axis=0), np.sort(MESH.t, axis=0))
    y = MESH.p[:, assembler.t]
    assert np.all((y[0, 1] - y[0, 0]) * (y[1, 2] - y[1, 0]) - (y[0, 2] - y[0, 0]) * (y[1, 1] - y[1, 0]) > 0)
    # gradients: exact for linear functions (u = B X gives F = I + B in every element)
    B = np.array([[0.3, -0.2], [0.1, 0.5]])
    F = assembler.deformation_gradient((B @ MESH.p).T.ravel())
    assert np.allclose(F, (np.eye(2) + B)[:, :, None])


def test_orientation_does_not_change_results():
    ccw = rectangle(1.0, 1.0, 3, 3)
    t = ccw.t.copy()
    t[[1, 2]] = t[[2, 1]]
    cw = MeshTri(ccw.p, t, sort_t=False)
    a, b = P1Assembler(ccw, NeoHookean(LAM, MU)), P1Assembler(cw, NeoHookean(LAM, MU))
    assert a.flipped.size == 0 and b.flipped.size == cw.t.shape[1]
    u = random_u(a.n_dofs, 0.02)
    assert np.allclose(a.residual(u), b.residual(u), rtol=0, atol=1e-14)
    assert np.allclose(a.tangent(u).toarray(), b.tangent(u).toarray(), rtol=0, atol=1e-13)


# --- finite differences ----------------------------------------------------------------


@pytest.mark.parametrize("name", list(MATERIALS))
def test_finite_differences(name, assembler):
    mat = MATERIALS[name]
    u = random_u(assembler.n_dofs, 0.02, seed=1)
    d = random_u(assembler.n_dofs, 1.0, seed=2)
    h = 1e-6
    r, K = assembler.residual_and_tangent(u, mat)
    dE = (assembler.energy(u + h * d, mat) - assembler.energy(u - h * d, mat)) / (2 * h)
    assert abs(dE - r @ d) <= 1e-6 * (abs(r @ d) + np.linalg.norm(r) * np.linalg.norm(d))
    dr = (assembler.residual(u + h * d, mat) - assembler.residual(u - h * d, mat)) / (2 * h)
    assert np.linalg.norm(dr - K @ d) <= 1e-6 * np.linalg.norm(K @ d)
    # hyperelastic: the tangent is a Hessian, hence symmetric
    assert spla.norm(K - K.T) <= 1e-12 * spla.norm(K)


# --- the fixed pattern --------------------------------------------------------------------


def test_fixed_sparsity_pattern(assembler):
    mat = MATERIALS["corotated"]
    K1 = assembler.tangent(random_u(assembler.n_dofs, seed=4), mat)
    K2 = assembler.tangent(random_u(assembler.n_dofs, seed=5), mat)
    _, K3 = assembler.residual_and_tangent(np.zeros(assembler.n_dofs), mat)
    for K in (K1, K2, K3):
        assert isinstance(K, sp.csr_matrix)
        assert K.shape == (assembler.n_dofs, assembler.n_dofs)
        assert K.nnz == assembler.nnz
        assert np.shares_memory(K.indices, assembler.indices)
        assert np.shares_memory(K.indptr, assembler.indptr)
        assert np.array_equal(K.indices, K1.indices) and np.array_equal(K.indptr, K1.indptr)
        assert K.has_canonical_format
    assert not np.shares_memory(K1.data, K2.data)
    assert not np.array_equal(K1.data, K2.data)
    assert not assembler.indices.flags.writeable and not assembler.indptr.flags.writeable
    # usable in the usual sparse operations (Dirichlet condensation, factorization)
    free = np.arange(4, assembler.n_dofs)
    lu = spla.splu(K2[free][:, free].tocsc())
    assert np.all(np.isfinite(lu.solve(np.ones(free.size))))


# --- invariances ------------------------------------------------------------------------


@pytest.mark.parametrize("name", list(MATERIALS))
def test_rigid_translation_has_zero_residual(name, assembler):
    u = np.empty(assembler.n_dofs)
    u[0::2], u[1::2] = 0.7, -1.3
    r = assembler.residual(u, MATERIALS[name])
    assert np.abs(r).max() < 1e-12
    assert abs(assembler.energy(u, MATERIALS[name])) < 1e-12


@pytest.mark.parametrize("name", FRAME_INDIFFERENT)
@pytest.mark.parametrize("angle", [0.3, 2.0])
def test_rigid_rotation_has_zero_residual(name, angle, assembler):
    c, s = np.cos(angle), np.sin(angle)
    R = np.array([[c, -s], [s, c]])
    X = MESH.p
    x = R @ X + np.array([[0.2], [-0.4]])
    u = np.empty(assembler.n_dofs)
    u[0::2], u[1::2] = (x - X)
    r = assembler.residual(u, MATERIALS[name])
    assert np.abs(r).max() < 1e-12 * (LAM + MU + 10.0)
    assert abs(assembler.energy(u, MATERIALS[name])) < 1e-12


def test_linear_elastic_is_not_rotation_invariant(assembler):
    # sanity check of the test above: the small-strain model does resist a finite rotation
    c, s = np.cos(0.3), np.sin(0.3)
    X = MESH.p
    x = np.array([[c, -s], [s, c]]) @ X
    u = np.empty(assembler.n_dofs)
    u[0::2], u[1::2] = (x - X)
    assert np.abs(assembler.residual(u, MATERIALS["linear"])).max() > 1e-3


def test_rest_state(assembler):
    u = np.zeros(assembler.n_dofs)
    for mat in MATERIALS.values():
        assert np.abs(assembler.residual(u, mat)).max() < 1e-13
        assert abs(assembler.energy(u, mat)) < 1e-13
    # at rest every model linearises to linear elasticity with the same (lam, mu)
    K_lin = assembler.tangent(u, MATERIALS["linear"])
    for name in ["neo-hookean", "taylor-neo-hookean", "stable-neo-hookean", "corotated"]:
        assert rel(assembler.tangent(u, MATERIALS[name]), K_lin) < 1e-12


# --- errors ------------------------------------------------------------------------------


def test_zero_area_triangle_raises():
    p = np.array([[0.0, 1.0, 0.0, 2.0, 1.0], [0.0, 0.0, 1.0, 0.0, 1.0]])
    t = np.array([[0, 1, 0], [1, 4, 1], [2, 2, 3]])  # element 2: nodes 0, 1, 3 are collinear
    mesh = MeshTri(p, t, sort_t=False)
    with pytest.raises(ValueError, match=r"mesh.*zero-area.*\[2\]"):
        P1Assembler(mesh)


def test_repeated_vertex_raises():
    p = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    mesh = MeshTri(p, np.array([[0, 0], [1, 1], [2, 1]]), sort_t=False)
    with pytest.raises(ValueError, match=r"mesh.*\[1\]"):
        P1Assembler(mesh)


def test_non_finite_coordinates_raise():
    p = rectangle(1.0, 1.0, 2, 2).p.copy()
    p[0, 4] = np.nan
    mesh = MeshTri(p, rectangle(1.0, 1.0, 2, 2).t, sort_t=False)
    with pytest.raises(ValueError, match=r"mesh.*non-finite.*nodes \[4\]"):
        P1Assembler(mesh)
    p[0, 4] = np.inf
    with pytest.raises(ValueError, match="mesh"):
        P1Assembler(MeshTri(p, rectangle(1.0, 1.0, 2, 2).t, sort_t=False))


def test_wrong_mesh_type_raises():
    with pytest.raises(ValueError, match="mesh"):
        P1Assembler(np.zeros((2, 3)))


@pytest.mark.parametrize("shape", [(5,), (2, 25), (50, 1), ()])
def test_wrong_shaped_u_raises(shape, assembler):
    u = np.zeros(shape)
    mat = MATERIALS["neo-hookean"]
    for call in (
        lambda: assembler.deformation_gradient(u),
        lambda: assembler.energy(u, mat),
        lambda: assembler.residual(u, mat),
        lambda: assembler.tangent(u, mat),
        lambda: assembler.residual_and_tangent(u, mat),
    ):
        with pytest.raises(ValueError, match=r"^u must"):
            call()


def test_missing_material_raises(assembler):
    with pytest.raises(ValueError, match="material"):
        assembler.residual(np.zeros(assembler.n_dofs))
    a = P1Assembler(MESH, MATERIALS["stable-neo-hookean"])
    u = random_u(a.n_dofs)
    assert np.array_equal(a.residual(u), assembler.residual(u, MATERIALS["stable-neo-hookean"]))
    # a material passed to the call overrides the default one
    assert np.array_equal(a.residual(u, MATERIALS["linear"]), assembler.residual(u, MATERIALS["linear"]))


def test_fiber_shapes_checked(assembler):
    u = random_u(assembler.n_dofs)
    per_point = FiberReinforced(NeoHookean(LAM, MU), 1.0, np.ones((2, NEL, 3)))
    with pytest.raises(ValueError, match="per-quadrature-point fibers.*one point per element"):
        assembler.residual(u, per_point)
    wrong_count = FiberReinforced(NeoHookean(LAM, MU), 1.0, np.ones((2, NEL + 1)))
    with pytest.raises(ValueError, match=rf"fibers.*\(2, {NEL}\)"):
        assembler.tangent(u, wrong_count)
    nested = FiberReinforced(FiberReinforced(NeoHookean(LAM, MU), 1.0, np.ones((2, NEL + 1))), 1.0, [1.0, 0.0])
    with pytest.raises(ParameterError, match=rf"{NEL} elements"):  # a second family's base is checked too
        assembler.energy(u, nested)


def test_log_model_reports_inversion_as_nan(assembler):
    # an inverted configuration: the log model is undefined (NaN), not silently finite
    u = np.empty(assembler.n_dofs)
    u[0::2], u[1::2] = -2.0 * MESH.p[0], 0.0  # x -> -x: J = -1 everywhere
    assert np.isnan(assembler.energy(u, MATERIALS["neo-hookean"]))
    assert np.all(np.isfinite(assembler.residual(u, MATERIALS["stable-neo-hookean"])))


def test_benchmark_smoke(tmp_path):
    # not a timing test: the benchmark runs, agrees with the forms and writes its record
    import json

    from tissuefem.workbook.bench.assembly import assembly_benchmark, format_table

    lines = []
    rows = assembly_benchmark(sizes=(60,), repeats=1, out=tmp_path, progress=lines.append)
    assert len(rows) == 1 and rows[0]["triangles"] > 0 and rows[0]["dofs"] > 0
    assert rows[0]["rel_diff_tangent"] < 1e-12 and rows[0]["rel_diff_residual"] < 1e-12
    assert lines[-2] == format_table(rows) and lines[-2].startswith("| triangles")
    assert lines[-1].startswith("wrote ") and (tmp_path / "assembly.csv").is_file()
    record = json.loads((tmp_path / "assembly.json").read_text())
    assert record["rows"][0]["triangles"] == rows[0]["triangles"]
    assert {"platform", "python", "numpy", "scipy", "scikit-fem", "cpu_count"} <= set(record["machine"])
    with pytest.raises(ValueError, match="sizes"):
        assembly_benchmark(sizes=(0,), progress=None)


def test_forms_path_refuses_element_weights():
    """The readable forms integrate whole elements: weights (a cut's partial elements) are refused by name, not
    silently ignored in the energy, residual and tangent."""
    mesh = MeshTri().refined(2)
    with pytest.raises(ParameterError, match="weights"):
        make_assembler(mesh, assembly="forms", weights=np.full(mesh.t.shape[1], 0.5))
    _, fast = make_assembler(mesh, weights=np.full(mesh.t.shape[1], 0.5))
    assert np.isclose(fast.areas.sum(), 0.5)
