"""Tetrahedra: the one code path of mesh, assembly, model and stepper in 3D.

A box of tetrahedra through the same classes as the 2D chapters: every material's energy, gradient and Hessian agree
by finite differences through the model (P1 and P2, with inertia and gravity); the patch test; zero residual at
rest; rigid motions cost nothing; a uniaxial stretch matches its closed form; a released block keeps its momentum;
a real-time frame converges; the effects still 2D only refuse a tetrahedron mesh by name.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import brentq

from tissuefem import Corotated, FiberReinforced, Handle, ITFClamped, LinearElastic, Model, NeoHookean, Stepper
from tissuefem.engine.assembly import P1Assembler, make_assembler
from tissuefem.engine.materials import MATERIALS as ENGINE_MATERIALS
from tissuefem.engine.meshes import box, check_mesh, mesh_size, signed_volumes
from tissuefem.engine.parameters import ParameterError
from tissuefem.engine.realtime import RealtimeSolver

LAM, MU = 1.7, 0.6

MATERIALS = {
    **{name: (lambda cls=cls: cls(LAM, MU)) for name, cls in ENGINE_MATERIALS.items()},
    "itf-clamped (exact tangent)": lambda: ITFClamped(NeoHookean(LAM, MU), project=False),
    "corotated+fibers(uniform)": lambda: FiberReinforced(Corotated(LAM, MU), 2.5, [0.3, -1.0, 0.4]),
}


@pytest.fixture(scope="module")
def small():
    return box(1.0, 0.8, 0.6, 2, 2, 1)


def _directional_fd(model, u, rng, h=1e-6):
    """Worst relative errors of ``g . v`` against the energy's central difference and of ``H v`` against the
    gradient's, along random directions ``v``."""
    g, H = model.gradient(u), model.hessian(u)
    worst_g = worst_h = 0.0
    for _ in range(3):
        v = rng.standard_normal(model.n_dofs)
        de = (model.energy(u + h * v) - model.energy(u - h * v)) / (2 * h)
        dg = (model.gradient(u + h * v) - model.gradient(u - h * v)) / (2 * h)
        worst_g = max(worst_g, abs(de - g @ v) / (1.0 + abs(g @ v)))
        Hv = H @ v
        worst_h = max(worst_h, np.max(np.abs(dg - Hv)) / (1.0 + np.max(np.abs(Hv))))
    return worst_g, worst_h


# --- meshes -------------------------------------------------------------------------------------------------------

def test_box_is_positive_with_named_faces():
    mesh = box(2.0, 1.0, 0.5, 4, 2, 2)
    assert mesh.t.shape == (4, 6 * 16) and mesh.p.shape == (3, 5 * 3 * 3)
    vol = signed_volumes(mesh)
    assert np.all(vol > 0) and np.isclose(vol.sum(), 1.0)
    for name, axis, value in [("left", 0, 0.0), ("right", 0, 2.0), ("bottom", 1, 0.0), ("top", 1, 1.0),
                              ("back", 2, 0.0), ("front", 2, 0.5)]:
        nodes = np.unique(mesh.facets[:, mesh.boundaries[name]])
        assert np.allclose(mesh.p[axis, nodes], value)
    assert np.isclose(mesh_size(mesh), 0.25)
    check_mesh(mesh.p, mesh.t)


def test_bad_tetrahedra_are_refused_by_name():
    mesh = box(1.0, 1.0, 1.0, 1, 1, 1)
    p, t = mesh.p, mesh.t
    flat = p.copy()
    flat[2] = 0.0
    with pytest.raises(ParameterError, match="degenerate"):
        check_mesh(flat, t)
    inverted = t.copy()
    inverted[[2, 3], 0] = inverted[[3, 2], 0]
    with pytest.raises(ParameterError, match="inverted tetrahedra"):
        check_mesh(p, inverted)
    with pytest.raises(ParameterError, match=r"\(4, n_tetrahedra\)"):
        check_mesh(p, t[:3])
    with pytest.raises(ParameterError, match="three or more"):
        check_mesh(p, np.concatenate([t, t[:, :1]], axis=1))


# --- the finite-difference table through the model ---------------------------------------------------------------

@pytest.mark.parametrize("order", [1, 2])
@pytest.mark.parametrize("name", list(MATERIALS))
def test_model_gradient_and_hessian_by_finite_differences(small, name, order):
    model = Model(small, MATERIALS[name](), order=order)
    rng = np.random.default_rng(1)
    u = 0.03 * rng.standard_normal(model.n_dofs)
    worst_g, worst_h = _directional_fd(model, u, rng)
    assert worst_g < 1e-6 and worst_h < 1e-5, (worst_g, worst_h)


@pytest.mark.parametrize("mass", ["lumped", "consistent"])
def test_terms_inertia_and_loads_by_finite_differences(small, mass):
    model = Model(small, NeoHookean(LAM, MU), dt=0.01, mass=mass, gravity=(0.0, -9.81, 1.0), density=2.0,
                  body_force=(0.5, 0.0, -0.2), tractions={"right": (0.1, 0.2, 0.3)})
    assert model.term_names == ["inertia", "elastic", "gravity", "body force", "tractions"]
    rng = np.random.default_rng(2)
    model.inertia.x_tilde = 0.01 * rng.standard_normal(model.n_dofs)
    worst_g, worst_h = _directional_fd(model, 0.02 * rng.standard_normal(model.n_dofs), rng)
    assert worst_g < 1e-6 and worst_h < 1e-5
    volume = 0.8 * 0.6
    assert np.isclose(model.total_mass(), 2.0 * volume)
    assert np.isclose(model.inertia.mass_data.sum(), 3 * 2.0 * volume)
    weight = model.loads[0].vector.reshape(-1, 3).sum(axis=0)
    assert np.allclose(weight, 2.0 * volume * np.array([0.0, -9.81, 1.0]))
    pull = model.loads[2].vector.reshape(-1, 3).sum(axis=0)
    assert np.allclose(pull, 0.8 * 0.6 * np.array([0.1, 0.2, 0.3]))


def test_p1_assembler_agrees_with_the_forms_on_tetrahedra(small):
    rng = np.random.default_rng(3)
    m = NeoHookean(LAM, MU)
    for order in (1, 2):
        basis, fast = make_assembler(small, order=order)
        _, forms = make_assembler(small, order=order, assembly="forms")
        u = 0.02 * rng.standard_normal(basis.N)
        assert np.isclose(fast.energy(u, m), forms.energy(u, m), rtol=1e-12)
        assert np.allclose(fast.residual(u, m), forms.residual(u, m), atol=1e-13)
        assert np.allclose(fast.tangent(u, m).toarray(), forms.tangent(u, m).toarray(), atol=1e-12)


def test_negatively_oriented_tetrahedra_are_reoriented():
    mesh = box(1.0, 1.0, 1.0, 1, 2, 1)
    t = mesh.t.copy()
    t[[2, 3], ::2] = t[[3, 2], ::2]
    flipped = type(mesh)(mesh.p, t, sort_t=False)
    a, b = P1Assembler(mesh), P1Assembler(flipped)
    assert b.flipped.size == t.shape[1] // 2 and np.allclose(a.areas, b.areas)
    u = 0.01 * np.random.default_rng(4).standard_normal(a.n_dofs)
    m = NeoHookean(LAM, MU)
    assert np.isclose(a.energy(u, m), b.energy(u, m)) and np.allclose(a.residual(u, m), b.residual(u, m))


# --- exact solutions ----------------------------------------------------------------------------------------------

@pytest.mark.parametrize("name", list(ENGINE_MATERIALS))
def test_zero_residual_at_rest(small, name):
    model = Model(small, ENGINE_MATERIALS[name](LAM, MU))
    assert np.max(np.abs(model.gradient(model.zeros()))) < 1e-14
    assert abs(model.energy(model.zeros())) < 1e-14


@pytest.mark.parametrize("material", [LinearElastic(LAM, MU), NeoHookean(LAM, MU)], ids=["linear", "neo-hookean"])
def test_patch_test(material):
    """A linear displacement imposed on the boundary of a box is reproduced exactly inside (small strain)."""
    mesh = box(1.0, 1.0, 1.0, 3, 3, 3)
    A = 1e-4 * np.array([[1.0, 0.3, -0.2], [0.1, -0.5, 0.4], [0.2, 0.6, 0.8]])
    c = np.array([1e-4, -2e-4, 3e-4])

    def linear(X):
        return X + A @ X + c[:, None]

    outside = mesh.boundary_nodes()
    model = Model(mesh, material, handles=[Handle(outside, linear)])
    stepper = Stepper(model, rtol=1e-12)
    assert stepper.step().converged
    inside = np.setdiff1d(np.arange(mesh.nvertices), outside)
    assert inside.size == 8
    exact = A @ mesh.p + c[:, None]
    assert np.allclose(model.nodal_displacement(stepper.u)[:, inside], exact[:, inside], rtol=0, atol=1e-12)


def test_rigid_motion_costs_nothing(small):
    theta, axis = 0.7, np.array([1.0, 2.0, -0.5]) / np.linalg.norm([1.0, 2.0, -0.5])
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    R = np.eye(3) + np.sin(theta) * K + (1 - np.cos(theta)) * K @ K
    u = ((R - np.eye(3)) @ small.p + np.array([[0.3], [-1.0], [2.0]])).T.ravel()
    model = Model(small, NeoHookean(LAM, MU))
    assert abs(model.energy(u)) < 1e-13
    assert np.max(np.abs(model.gradient(u))) < 1e-13
    assert np.allclose(model.jacobian(u), 1.0)


def test_uniaxial_stretch_matches_the_closed_form():
    """A Neo-Hookean bar stretched by 10 %: with its ends held at the closed-form state ``diag(1.1, s, s)`` (lateral
    stress zero: ``mu (s^2 - 1) + lam ln(1.1 s^2) = 0``) and its sides free, the whole bar takes that state exactly,
    which it does only if the sides carry no traction there; the reaction is the closed-form force."""
    lam, mu, stretch = 4.0, 1.0, 1.1
    s = brentq(lambda s: mu * (s * s - 1) + lam * np.log(stretch * s * s), 0.5, 1.0)
    assert 0.95 < s < 0.99  # lateral contraction

    def uniaxial(X):
        return np.array([stretch * X[0], s * X[1], s * X[2]])

    mesh = box(2.0, 0.5, 0.5, 8, 2, 2)
    model = Model(mesh, NeoHookean(lam, mu), handles=[Handle("left", uniaxial), Handle("right", uniaxial)])
    stepper = Stepper(model, rtol=1e-12)
    assert stepper.step().converged
    x = model.positions(stepper.u)
    assert np.allclose(x, uniaxial(mesh.p), rtol=0, atol=1e-10)
    force = model.reaction(stepper.u, "handle1")
    P11 = mu * (stretch - 1 / stretch) + lam * np.log(stretch * s * s) / stretch
    assert np.allclose(force, [P11 * 0.25, 0.0, 0.0], atol=1e-9)


def test_uniaxial_pull_contracts_the_middle():
    """Clamped ends, a 10 % pull: the middle of a long bar contracts laterally as the closed form says, within the
    mesh's tolerance."""
    lam, mu, stretch = 4.0, 1.0, 1.1
    s = brentq(lambda s: mu * (s * s - 1) + lam * np.log(stretch * s * s), 0.5, 1.0)
    mesh = box(4.0, 0.5, 0.5, 16, 2, 2)
    model = Model(mesh, NeoHookean(lam, mu), handles=[Handle("left"), Handle("right", (0.4, 0.0, 0.0))])
    stepper = Stepper(model)
    for load in (0.5, 1.0):  # two load steps
        model.handle("handle1").move((0.4 * load, 0.0, 0.0))
        assert stepper.step().converged
    x = model.positions(stepper.u)
    middle = np.isclose(mesh.p[0], 2.0)
    width = np.ptp(x[1, middle])
    assert abs(width / 0.5 - s) < 0.05 * (1 - s)


# --- dynamics and the real-time loop --------------------------------------------------------------------------

def test_released_block_keeps_its_momentum():
    mesh = box(1.0, 0.5, 0.5, 2, 1, 1)
    model = Model(mesh, NeoHookean(LAM, MU), dt=0.01, density=3.0)
    stepper = Stepper(model)
    rng = np.random.default_rng(5)
    u0 = 0.05 * rng.standard_normal(model.n_dofs)
    v0 = np.tile([0.2, -0.1, 0.3], mesh.nvertices) + 0.1 * rng.standard_normal(model.n_dofs)
    stepper.set_state(u0, v0)
    p0 = stepper.momentum()
    assert p0.shape == (3,)
    for _ in range(5):
        assert stepper.step().converged
    assert np.allclose(stepper.momentum(), p0, rtol=0, atol=1e-9 * np.abs(p0).max())


def test_block_falls_with_gravity_and_realtime_frame_converges():
    mesh = box(1.0, 0.4, 0.4, 4, 2, 2)
    model = Model(mesh, NeoHookean(1e4, 5e3), dt=1 / 30, gravity=(0.0, -9.81, 0.0), handles=[Handle("left")])
    ticks = iter(np.arange(0.0, 1e3, 1e-5))  # a fake clock: 10 us a reading, so no loaded machine cuts the frame
    solver = RealtimeSolver(model, clock=lambda: float(next(ticks)))
    for _ in range(3):
        report = solver.step()
        assert report.converged
    tip = model.nodal_displacement(solver.u)[1, np.isclose(mesh.p[0], 1.0)]
    assert np.all(tip < 0)


def test_quasistatic_p2_with_a_traction():
    mesh = box(1.0, 0.5, 0.5, 2, 1, 1)
    model = Model(mesh, LinearElastic(LAM, MU), order=2, tractions={"right": (0.0, 0.0, 1e-3)},
                  handles=[Handle("left")])
    stepper = Stepper(model)
    assert stepper.step().converged
    assert np.max(model.nodal_displacement(stepper.u)[2]) > 0


# --- what 3D does not have yet -------------------------------------------------------------------------------

def test_effects_still_2d_only_refuse_a_tetrahedron_mesh(small):
    m = NeoHookean(LAM, MU)
    with pytest.raises(ParameterError, match="contact.*2D only"):
        Model(small, m, contact={"distance": 0.01, "stiffness": 1.0})
    with pytest.raises(ParameterError, match="cuts.*2D only"):
        Model(small, m, weights=np.ones(small.nelements))
    with pytest.raises(ParameterError, match="gravity"):
        Model(small, m, gravity=(0.0, -9.81))
    with pytest.raises(ParameterError, match="target"):
        Model(small, m, handles=[Handle("left", (0.1, 0.0))])
    model = Model(small, m)
    with pytest.raises(ParameterError, match="cuts and excisions are 2D only"):
        model.remapped(None)


def test_3d_regions():
    mesh = box(1.0, 1.0, 1.0, 2, 2, 2)
    model = Model(mesh, NeoHookean(LAM, MU), handles=[Handle({"box": [0, 0, 0, 0.5, 0.5, 0.5]}, name="corner"),
                                                      Handle({"near": [1, 1, 1], "radius": 0.01}, name="tip")])
    assert model.handle("corner").nodes.size == 8 and model.handle("tip").nodes.size == 1
    with pytest.raises(ParameterError, match=r"\[x0, y0, z0, x1, y1, z1\]"):
        model.add_handle(Handle({"box": [0, 0, 1, 1]}))
    with pytest.raises(ValueError, match="z 0..1"):
        model.add_handle(Handle({"box": [2, 2, 2, 3, 3, 3]}))
