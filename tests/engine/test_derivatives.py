"""One finite-difference table for every material and every term: energy -> gradient -> Hessian.

Each material's stress must be the derivative of its energy and its tangent the
derivative of its stress, checked by central differences at rest, stretched,
sheared, at random states, and through inversion where the model allows it, in
2D (triangles) and 3D (tetrahedra).
Each term of a model (elastic with every material, P1 and P2, fibres, inertia,
loads, probe, sutures, contact, the ghost penalty of cuts) and the whole model must
have the gradient of its energy and the Hessian of its gradient, checked along random
directions, on triangles and on a random-ish box of tetrahedra (every term but
self-contact and the ghost penalty, which are 2D only). A new material or term is
added to the table, not given its own copy of these checks.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from tissuefem import (Corotated, FiberReinforced, Handle, ITFClamped, LinearElastic, Model, NeoHookean, ProjectedTangent,
                       StableNeoHookean, Stepper, TaylorNeoHookean, rectangle)
from tissuefem.engine.materials import MATERIALS as ENGINE_MATERIALS
from tissuefem.engine.materials import det
from tissuefem.engine.meshes import box, mean_edge_length, signed_volumes
from tissuefem.engine.terms import Elastic, Fibers, GhostPenalty, Inertia, Load, Probe, Sutures
from tissuefem.surgery.element_cuts import cut_through
from tissuefem.surgery.surfaces import contact_surface
from tissuefem.surgery.topology import incise

from helpers import H, fd_stress, fd_tangent, random_F

LAM, MU = 1.7, 0.6
NEL, NQP = 30, 3  # random F fields are shaped [d, d, NEL, NQP], like scikit-fem's
DIMS = [2, 3]
RTOL = 1e-6


def _rng(seed=0):
    return np.random.default_rng(seed)


def assert_close_per_sample(exact, approx, ncomp_axes, rtol=RTOL):
    """Per sample (trailing axes), ``max |exact - approx| <= rtol * (1 + max |exact|)``."""
    axes = tuple(range(ncomp_axes))
    err = np.max(np.abs(exact - approx), axis=axes)
    scale = 1.0 + np.max(np.abs(exact), axis=axes)
    assert np.all(np.isfinite(exact))
    worst = np.max(err / scale)
    assert worst <= rtol, f"worst relative error {worst:.3e}"


# --- the material table --------------------------------------------------------------------------------------------

def _fibers(shape, seed=7, dim=2):
    return _rng(seed).normal(size=(dim,) + shape)


# each entry builds the material for F of dimension ``dim`` (only the fibres depend on it)
MATERIALS = {
    **{name: (lambda dim, cls=cls: cls(LAM, MU)) for name, cls in ENGINE_MATERIALS.items()},  # every isotropic model
    "itf-clamped (exact tangent)": lambda dim: ITFClamped(NeoHookean(LAM, MU), project=False),
    "neo-hookean+fibers(uniform)": lambda dim: FiberReinforced(NeoHookean(LAM, MU), 2.5, [1.0, 2.0, -0.7][:dim]),
    "stable+fibers(per element)": lambda dim: FiberReinforced(StableNeoHookean(LAM, MU), 2.5,
                                                              _fibers((NEL,), dim=dim)),
    "corotated+fibers(per point)": lambda dim: FiberReinforced(Corotated(LAM, MU), 2.5, _fibers((NEL, NQP), dim=dim)),
    "taylor+fibers(uniform)": lambda dim: FiberReinforced(TaylorNeoHookean(LAM, MU), 2.5, [0.3, -1.0, 0.4][:dim]),
    "linear+fibers(per element)": lambda dim: FiberReinforced(LinearElastic(LAM, MU), 2.5, _fibers((NEL,), dim=dim)),
}
#: wrappers whose tangent is deliberately not the stress's derivative (a PSD projection): stress only
STRESS_ONLY = {"projected stable": lambda dim: ProjectedTangent(StableNeoHookean(LAM, MU)),
               "projected corotated+fibers": lambda dim: ProjectedTangent(
                   FiberReinforced(Corotated(LAM, MU), 2.5, _fibers((NEL,), dim=dim))),
               "itf-clamped (projected tangent)": lambda dim: ITFClamped(NeoHookean(LAM, MU))}
STATES = ["rest", "stretched", "sheared", "positive"]


@pytest.mark.parametrize("dim", DIMS)
@pytest.mark.parametrize("state", STATES + ["inverted", "singular"])
@pytest.mark.parametrize("name", list(MATERIALS) + list(STRESS_ONLY))
def test_material_stress_and_tangent_are_derivatives(name, state, dim):
    m = {**MATERIALS, **STRESS_ONLY}[name](dim)
    if state in ("inverted", "singular"):
        if not m.inversion_safe:
            pytest.skip(f"{name} is undefined at J <= 0 (by design: NaN, so a solver can tell)")
    F = random_F(state, seed=hash(state) % 97, dim=dim)
    assert F.shape == (dim, dim, NEL, NQP)
    if state == "inverted":
        assert np.all(det(F) < -0.01)
    assert np.all(np.isfinite(m.energy(F)))
    assert_close_per_sample(m.stress(F), fd_stress(m, F), 2)
    if name not in STRESS_ONLY:
        A, A_fd = m.tangent(F), fd_tangent(m, F)
        itf = name.startswith("itf")
        if itf:
            # the clamped energy is C1: its tangent jumps where a singular value crosses the threshold, so the
            # difference quotient is compared only at samples away from it
            s = np.linalg.svd(np.moveaxis(F.reshape(dim, dim, -1), -1, 0), compute_uv=False)
            away = np.all(np.abs(s - m.threshold) > 1e-3, axis=1)
            A, A_fd = A.reshape((dim,) * 4 + (-1,))[..., away], A_fd.reshape((dim,) * 4 + (-1,))[..., away]
        assert_close_per_sample(A, A_fd, 4, rtol=2e-5 if itf else RTOL)


@pytest.mark.parametrize("dim", DIMS)
@pytest.mark.parametrize("name", list(MATERIALS) + list(STRESS_ONLY))
def test_material_rest_is_energy_and_stress_free(name, dim):
    m = {**MATERIALS, **STRESS_ONLY}[name](dim)
    F = random_F("rest", dim=dim)
    np.testing.assert_allclose(m.energy(F), 0.0, atol=1e-12)
    np.testing.assert_allclose(m.stress(F), 0.0, atol=1e-12)


# --- the term table ------------------------------------------------------------------------------------------------

def _mesh(dim=2):
    """A 4 x 4 square of triangles, or a random-ish 2 x 2 x 2 box of tetrahedra: its nodes moved at random within
    the faces they lie on (the named boundaries stay planar)."""
    if dim == 2:
        return rectangle(1.0, 1.0, 4, 4)
    mesh = box(1.0, 1.0, 1.0, 2, 2, 2)
    p = np.asarray(mesh.p, dtype=float)
    inner = (p > 1e-9) & (p < 1.0 - 1e-9)  # a coordinate moves only where the node lies on no face across it
    mesh = dataclasses.replace(mesh, doflocs=p + inner * _rng(2).uniform(-0.06, 0.06, p.shape))
    assert np.all(signed_volumes(mesh) > 0)
    return mesh


#: the tools of the table in each dimension: a probe pressed into the top (a disc; a ball touching several nodes of
#: the top face of the box), and stitches with ends inside elements (barycentric weights of a triangle's 3 corners, a
#: tetrahedron's 4)
TOOLS = {
    2: dict(probe=dict(center=[0.52, 1.22], radius=0.3, stiffness=1e3), depth=0.03, elements=[[2, 30], [9, 17]],
            coefficients=[[[0.2, 0.5], [0.3, 0.25], [0.5, 0.25]], [[0.6, 0.1], [0.1, 0.1], [0.3, 0.8]]],
            gaps=[[0.1, -0.2], [0.05, 0.3]], gravity=(0.2, -9.81), traction=(3.0, -1.0), body_force=(0.5, 0.1)),
    3: dict(probe=dict(center=[0.45, 2.4, 0.55], radius=1.5, stiffness=1e3), depth=0.25, elements=[[2, 30], [9, 17]],
            coefficients=[[[0.2, 0.5], [0.3, 0.25], [0.4, 0.1], [0.1, 0.15]],
                          [[0.6, 0.1], [0.1, 0.1], [0.2, 0.5], [0.1, 0.3]]],
            gaps=[[0.1, -0.2], [0.05, 0.3], [0.02, -0.1]], gravity=(0.2, -9.81, 0.3), traction=(3.0, -1.0, 0.5),
            body_force=(0.5, 0.1, -0.2)),
}


def _model(terms="elastic", material=None, order=1, dim=2):
    """A small model with the named effect(s) on top of the elastic term; ``u`` a displacement in the
    given state."""
    mesh = _mesh(dim)
    X = mesh.p
    tools = TOOLS[dim]
    pairs = np.array([[0, 3], [24, 20]])
    options = {
        "fibers": dict(fibers=(50.0, _fibers((mesh.nelements,), seed=3, dim=dim))),
        "inertia": dict(dt=0.05, density=1.3, mass="consistent"),
        "inertia-lumped": dict(dt=0.05, density=1.3, mass="lumped"),
        "loads": dict(gravity=tools["gravity"], tractions={"right": tools["traction"]}, body_force=tools["body_force"]),
        "sutures": dict(sutures={"pairs": pairs, "stiffness": 40.0, "gaps": X[:, pairs[0]] - X[:, pairs[1]],
                                 "tightness": 0.3}),
        "probe": dict(probes=[tools["probe"]]),  # pressed into the top
        # stitches whose ends lie inside elements (on a wound cut through them): barycentric weights
        "sutures-embedded": dict(sutures={"pairs": np.stack([mesh.t[:, e] for e in tools["elements"]]),
                                          "coefficients": np.array(tools["coefficients"]),
                                          "stiffness": [40.0, 70.0], "gaps": tools["gaps"], "tightness": 0.4}),
    }
    kw = {}
    for t in terms.split("+"):
        kw.update(options.get(t, {}))
    m = Model(mesh, material or StableNeoHookean(100.0 * LAM, 100.0 * MU), order=order,
              handles=[Handle(np.array([0]))], **kw)
    if m.inertia is not None:
        m.inertia.x_tilde = 0.01 * _rng(11).normal(size=m.n_dofs)
    return m


def _state(model, state, seed=5):
    X = model.dof_points
    dim = X.shape[0]
    maps = {"rest": np.eye(dim), "stretched": np.diag([1.3, 0.85, 1.1][:dim]),
            "sheared": np.array([[1.0, 0.4, 0.0], [0.0, 1.0, 0.2], [0.0, 0.0, 1.0]])[:dim, :dim]}
    if state in maps:
        x = maps[state] @ X
    else:  # a smooth random deformation (J > 0 at every quadrature point, P2 included)
        a = _rng(seed).uniform(-1.0, 1.0, (dim, dim))
        phase = [sum(a[i, j] * 3 * X[j] for j in range(dim)) for i in range(dim)]
        x = X + 0.08 * np.stack([(np.sin, np.cos, np.sin)[i](phase[i]) for i in range(dim)])
    d = x - X
    return d[model.component, np.arange(model.n_dofs)]


def _check_term(term, u, exact_hessian=True, seed=1, h=1e-4):
    rng = _rng(seed)
    data = term.pattern.zeros()
    term.add_hessian(u, data)
    K = term.pattern.csr(data)
    g = term.gradient(u)
    for _ in range(3):
        d = 0.01 * rng.normal(size=u.size)
        # h = 1e-4: the energy's own round-off (its terms cancel at rest) over 2h stays far below the tolerance
        fd_g = (term.energy(u + h * d) - term.energy(u - h * d)) / (2 * h)
        # tolerance: relative, plus the size of the second-order term the difference quotient neglects
        assert fd_g == pytest.approx(g @ d, rel=1e-6, abs=1e-6 * (1e-6 + abs(d @ (K @ d)))), term.describe()
        if exact_hessian:
            fd_K = (term.gradient(u + H * d) - term.gradient(u - H * d)) / (2 * H)
            np.testing.assert_allclose(K @ d, fd_K, rtol=1e-5, atol=1e-6 * (1 + np.abs(fd_K).max()),
                                       err_msg=term.describe())


TERMS = {
    "elastic (stable)": ("elastic", Elastic, None),
    "elastic (linear)": ("elastic", Elastic, LinearElastic(LAM, MU)),
    "elastic (ln J)": ("elastic", Elastic, NeoHookean(LAM, MU)),
    "elastic (Taylor)": ("elastic", Elastic, TaylorNeoHookean(LAM, MU)),
    "elastic (corotated)": ("elastic", Elastic, Corotated(LAM, MU)),
    "elastic (ITF)": ("elastic", Elastic, ITFClamped(NeoHookean(LAM, MU), project=False)),
    "fibers": ("fibers", Fibers, None),
    "inertia (consistent)": ("inertia", Inertia, None),
    "inertia (lumped)": ("inertia-lumped", Inertia, None),
    "loads": ("loads", Load, None),
    "sutures": ("sutures", Sutures, None),
    "sutures (ends inside elements)": ("sutures-embedded", Sutures, None),
}


@pytest.mark.parametrize("dim", DIMS)
@pytest.mark.parametrize("state", STATES)
@pytest.mark.parametrize("order", [1, 2])
@pytest.mark.parametrize("name", list(TERMS))
def test_term_gradient_and_hessian_are_derivatives(name, order, state, dim):
    effect, kind, material = TERMS[name]
    if order == 2 and effect in ("inertia-lumped",):
        pytest.skip("row-sum lumping gives P2 vertices no mass (refused)")
    model = _model(effect, material, order, dim)
    u = _state(model, state)
    terms = [t for t in model.terms if isinstance(t, kind)]
    assert terms, name
    for term in terms:
        _check_term(term, u)


@pytest.mark.parametrize("dim", DIMS)
@pytest.mark.parametrize("state", STATES)
def test_the_probe_gradient_and_hessian_are_exact_and_its_safe_hessian_is_the_positive_part(state, dim):
    model = _model("probe", dim=dim)
    u = _state(model, state)
    probe = model.probes[0]
    top = float(model.positions(u)[1].max())
    center = probe.center.copy()
    center[1] = top + probe.radius - TOOLS[dim]["depth"]
    probe.move(center)  # pressed into the deformed top edge (face)
    inside = probe._contact(u)[0]
    assert inside.size > (0 if dim == 2 else 1)  # the probe touches something (a ball: several nodes of the face)
    _check_term(probe, u)
    data = model.pattern.zeros()
    probe.add_hessian(u, data, safe=True)
    eig = np.linalg.eigvalsh(model.pattern.csr(data).toarray())
    assert eig.min() > -1e-9 * eig.max() and eig.max() > 0  # the safe Hessian: positive semi-definite


@pytest.mark.parametrize("state", STATES)
def test_the_ghost_penalty_of_a_cut_has_exact_derivatives(state):
    """The ghost penalty of the pieces of elements cut through (2D only, as cuts are)."""
    cut = cut_through(rectangle(1.0, 1.0, 6, 6), [[0.33, 1.1], [0.61, 0.25]])
    model = Model(cut.mesh, StableNeoHookean(100.0, 60.0), weights=cut.weights, handles=[Handle("left")])
    ghosts = model.terms_of(GhostPenalty)
    assert ghosts
    _check_term(ghosts[0], _state(model, state))


def _pressed_wound(kind, order=1):
    """A unit square cut through from its top (along mesh edges, or through elements), with contact, and three
    states of its lips pressed together and sheared (each with lips in contact, the last with a point pressed
    into a reflex corner of the other lip for the edge cut)."""
    mesh = rectangle(1.0, 1.0, 6, 6)
    h = mean_edge_length(mesh)
    if kind == "edges":
        mesh, weights, surface = incise(mesh, [[0.2, 1.1], [0.75, 0.3]]).mesh, None, None
    else:
        cut = cut_through(mesh, [[0.33, 1.1], [0.61, 0.25]])
        mesh, weights, surface = cut.mesh, cut.weights, contact_surface(cut.mesh, cut.weights, cut.regions)
    model = Model(mesh, StableNeoHookean(100.0, 60.0), weights=weights, order=order,
                  handles=[Handle("left"), Handle("right", name="push")],
                  contact=dict(surface=surface, distance=0.1 * h, stiffness=100.0))
    stepper = Stepper(model, linear_solver="direct")
    states = []
    for target in [(-0.03, 0.0), (-0.06, 0.02), (-0.08, -0.03)]:
        assert stepper.step({"push": target}).converged
        states.append(stepper.u.copy())
    return model, states


@pytest.mark.parametrize("kind, order", [("edges", 1), ("elements", 1), ("edges", 2)])
def test_the_contact_gradient_and_hessian_are_exact_and_its_safe_hessian_is_positive(kind, order):
    model, states = _pressed_wound(kind, order)
    contact = model.contact
    kinds = set()
    for u in states:
        model.hessian(u)  # the pattern holds the pairs in contact here
        c = contact._evaluate(u)
        assert c["p"].size > 0  # lips in contact
        kinds |= set(c["kind"].tolist())
        # the barrier changes over d^ (a tenth of an element here): a smaller step keeps the difference
        # quotient's own error (h^2 times the third derivative) below the tolerance
        _check_term(contact, u, h=1e-5)
        data = model.pattern.zeros()
        contact.add_hessian(u, data, safe=True)
        eig = np.linalg.eigvalsh(model.pattern.csr(data).toarray())
        assert eig.min() > -1e-9 * eig.max() and eig.max() > 0
    # point-segment contacts, and (edges) a point pressed into a corner of the other lip: point-point
    assert 1 in kinds and (kind == "elements" or order == 2 or kinds & {2, 3})


@pytest.mark.parametrize("dim", DIMS)
@pytest.mark.parametrize("state", STATES)
def test_the_whole_model_energy_gradient_hessian(state, dim):
    model = _model("fibers+inertia+loads+sutures+probe", dim=dim)
    assert model.term_names == ["inertia", "elastic", "fibers", "probe", "sutures", "gravity", "body force",
                                "tractions"]
    u = _state(model, state)
    rng = _rng(4)
    K, g = model.hessian(u), model.gradient(u)
    for _ in range(3):
        d = rng.normal(size=u.size)
        fd = (model.energy(u + H * d) - model.energy(u - H * d)) / (2 * H)
        assert fd == pytest.approx(g @ d, rel=1e-6)
        fd_K = (model.gradient(u + H * d) - model.gradient(u - H * d)) / (2 * H)
        np.testing.assert_allclose(K @ d, fd_K, rtol=1e-5, atol=1e-6 * (1 + np.abs(fd_K).max()))
    # the model's sum is the sum of its terms
    assert model.energy(u) == pytest.approx(sum(t.energy(u) for t in model.terms))


@pytest.mark.parametrize("dim", DIMS)
def test_sutures_widen_the_pattern_and_the_elastic_part_lands_where_it_belongs(dim):
    model = _model("fibers+sutures", dim=dim)
    u = _state(model, "random")
    assert model.pattern.nnz > model.assembler.nnz
    a, b = model.sutures.pairs[:, 0]
    K = model.hessian(u).toarray()
    # the stitch couples two nodes of no common element, in every component
    assert all(K[dim * a + i, dim * b + i] != 0 for i in range(dim))
    elastic = model.assembler.csr(
        model.assembler.tangent(u, model.terms[0].density).data + model.assembler.tangent(u, model.terms[1].density).data
    ).toarray()
    S = np.zeros_like(K)
    rows, cols, vals = model.sutures.entries()
    np.add.at(S, (rows, cols), vals)
    np.testing.assert_allclose(K, elastic + S, atol=1e-12 * np.abs(K).max())
