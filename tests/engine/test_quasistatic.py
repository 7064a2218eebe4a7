"""Quasistatic solves of a Model: patch tests, equilibrium of reactions, handles, validation."""

import numpy as np
import pytest

from tissuefem import Handle, LinearElastic, Model, NeoHookean, rectangle, solve
from tissuefem.engine.materials import MATERIALS as ISOTROPIC

MATERIALS = [cls.from_young(1000.0, 0.3) for cls in ISOTROPIC.values()]
A = np.array([[1.2, 0.3], [-0.1, 0.9]])
c = np.array([0.05, -0.02])


def _boundary_mask(X):
    return np.isclose(X[0], 0) | np.isclose(X[0], 1) | np.isclose(X[1], 0) | np.isclose(X[1], 1)


def _perturbed_mesh():
    """An irregular mesh: interior nodes jittered so the patch test is not trivially satisfied."""
    mesh = rectangle(1.0, 1.0, 5, 5)
    rng = np.random.default_rng(1)
    p = mesh.p.copy()
    interior = ~_boundary_mask(p)
    p[:, interior] += 0.05 * rng.uniform(-1, 1, (2, interior.sum()))
    return type(mesh)(p, mesh.t, _boundaries=mesh.boundaries) if hasattr(mesh, "boundaries") else mesh


@pytest.mark.parametrize("material", MATERIALS, ids=lambda m: m.name)
@pytest.mark.parametrize("order, assembly", [(1, "fast"), (1, "forms"), (2, "forms")])
def test_patch_test_homogeneous_deformation_is_reproduced(material, order, assembly):
    mesh = _perturbed_mesh()
    handle = Handle(_boundary_mask, target=lambda X: A @ X + c[:, None])
    problem = Model(mesh, material, order=order, assembly=assembly, handles=[handle])
    result = solve(problem, rtol=1e-13, atol=1e-11)
    assert result.converged
    X = problem.basis.doflocs
    exact = (A @ X + c[:, None]) - X
    got = result.u
    expected = exact[problem.component, np.arange(X.shape[1])]
    np.testing.assert_allclose(got, expected, atol=1e-10)


def test_fast_and_forms_paths_give_the_same_solution():
    mesh = rectangle(2.0, 1.0, 10, 5)
    mat = NeoHookean.from_young(1000.0, 0.3)
    handles = [Handle("left"), Handle("right", (0.4, 0.3))]
    a = solve(Model(mesh, mat, handles=handles, assembly="fast"), load_steps=2, rtol=1e-12)
    b = solve(Model(mesh, mat, handles=handles, assembly="forms"), load_steps=2, rtol=1e-12)
    assert a.converged and b.converged
    np.testing.assert_allclose(a.u, b.u, atol=1e-10)


@pytest.mark.parametrize("order", [1, 2])
def test_reactions_balance_tractions_and_body_force(order):
    mesh = rectangle(2.0, 1.0, 8, 4)
    mat = NeoHookean.from_young(1000.0, 0.3)
    t, b = np.array([60.0, -20.0]), np.array([0.0, -9.81])
    problem = Model(mesh, mat, order=order, handles=[Handle("left")],
                                 tractions={"right": t}, body_force=b)
    result = solve(problem, load_steps=2, rtol=1e-12)
    assert result.converged
    # the external load vector carries the resultant: t * (edge length 1) + b * (area 2)
    for i in range(2):
        assert problem.external[problem.component == i].sum() == pytest.approx(t[i] * 1.0 + b[i] * 2.0)
    # at equilibrium the internal forces at the fixed dofs (the reactions) balance the loads
    fixed, _ = problem.prescribed()
    reaction = problem.internal_force(result.u) - problem.external
    for i in range(2):
        at_fixed = fixed[problem.component[fixed] == i]
        assert reaction[at_fixed].sum() == pytest.approx(-(t[i] + 2.0 * b[i]), rel=1e-8)


def test_rigid_rotation_is_stress_free_for_neo_hookean_only():
    mesh = rectangle(1.0, 1.0, 4, 4)
    theta = np.pi / 3
    R = np.array([[np.cos(theta), -np.sin(theta)], [np.sin(theta), np.cos(theta)]])
    for material, stress_free in [(NeoHookean.from_young(1000.0, 0.3), True),
                                  (LinearElastic.from_young(1000.0, 0.3), False)]:
        problem = Model(mesh, material, handles=[Handle(_boundary_mask, lambda X: R @ X)])
        result = solve(problem, rtol=1e-12)
        assert result.converged
        energy = problem.stored_energy(result.u)
        assert (energy < 1e-9) == stress_free, (material.name, energy)


def test_handles_move_and_the_last_one_wins():
    mesh = rectangle(1.0, 1.0, 3, 3)
    h = Handle("right", (0.1, 0.0))
    problem = Model(mesh, NeoHookean.from_young(1000.0, 0.3), handles=[Handle("left"), h])
    h.move((0.2, 0.1))
    fixed, values = problem.prescribed()
    right = problem.basis.get_dofs("right").all()
    comp = problem.component[right]
    got = dict(zip(fixed, values))
    assert all(np.isclose(got[d], 0.2 if k == 0 else 0.1) for d, k in zip(right, comp))
    # overlapping handles resolve to the later one
    problem2 = Model(mesh, problem.material, handles=[Handle("left"), Handle("left", (0.3, 0.0))])
    _, v2 = problem2.prescribed()
    assert np.allclose(v2[problem2.component[problem2.prescribed()[0]] == 0], 0.3)


@pytest.mark.parametrize("make, match", [
    (lambda m, mat: Model(m, mat, handles=[Handle("nowhere")]), "nowhere"),
    (lambda m, mat: Model(m, mat, handles=[Handle("left")], tractions={"right": (1.0,)}), "tractions"),
    (lambda m, mat: Model(m, mat, handles=[Handle("left")], body_force=(np.nan, 0)), "body_force"),
    (lambda m, mat: Model(m, mat, order=3, handles=[Handle("left")]), "order"),
    (lambda m, mat: Handle("left", (np.inf, 0.0)), "finite"),
    (lambda m, mat: Model(m, mat, handles=[Handle("left", (1.0, 2.0, 3.0))]), "shape"),  # a 3D target, 2D mesh
    (lambda m, mat: Model(m, mat, handles=[Handle(np.array([0, 10_000]))]), "node indices"),
    (lambda m, mat: solve(Model(m, mat, handles=[Handle("left")]), load_steps=0), "load_steps"),
    (lambda m, mat: solve(Model(m, mat, handles=[Handle("left")], dt=0.1)), "dt"),
])
def test_bad_input_is_rejected_by_name(make, match):
    mesh = rectangle(1.0, 1.0, 3, 3)
    with pytest.raises(ValueError, match=match):
        make(mesh, NeoHookean.from_young(1000.0, 0.3))


def test_failed_solve_keeps_the_last_good_state():
    mesh = rectangle(1.0, 1.0, 4, 4)
    problem = Model(mesh, NeoHookean.from_young(1000.0, 0.3),
                                 handles=[Handle("left"), Handle("right", (-1.5, 0.0))])
    # crushing the square flat in one step inverts it: the step fails, the start state is kept
    result = solve(problem, load_steps=1, max_iterations=3)
    assert not result.converged and result.status == "non-finite"
    np.testing.assert_array_equal(result.u, np.zeros(problem.basis.N))
    # in three steps the first converges and the second fails: the first step's state is kept
    result = solve(problem, load_steps=3, max_iterations=8)
    assert not result.converged and len(result.steps) == 2 and result.steps[0].converged
    np.testing.assert_array_equal(result.u, result.steps[0].x)


def test_energy_line_search_converges_when_equilibrium_energy_is_zero():
    """A block turned rigidly by its clamped edge: the energy at the solution is 0 up to round-off,
    so the Armijo test alone cannot certify the last steps; the solve must still converge."""
    from tissuefem.workbook.studies import rotated_block

    problem, result = rotated_block(NeoHookean.from_young(1000.0, 0.3), np.pi / 3)
    assert result.converged
    assert problem.stored_energy(result.u) < 1e-9


def test_a_term_added_and_removed_leaves_the_model_as_it_was():
    from tissuefem import Load
    mesh = rectangle(2.0, 1.0, 6, 3)
    model = Model(mesh, NeoHookean.from_young(1000.0, 0.3), handles=[Handle("left")])
    u = 1e-3 * np.arange(model.n_dofs, dtype=float)
    before = model.energy(u)
    push = Load("push", np.ones(model.n_dofs))
    model.add_term(push)
    assert model.loads == [push] and model.energy(u) == pytest.approx(before - u.sum())
    model.remove_term(push)
    assert model.loads == [] and model.energy(u) == before
    with pytest.raises(ValueError, match="holds no term"):
        model.remove_term(push)


def test_a_term_has_do_nothing_hooks_and_the_model_calls_only_overridden_ones():
    from tissuefem.engine.terms import Term

    class Limited(Term):  # a term that keeps steps short, and overrides nothing else
        name = "limited"

        def energy(self, u):
            return 0.0

        def gradient(self, u):
            return np.zeros(np.size(u))

        def add_hessian(self, u, data, safe=False):
            pass

        def max_step(self, u, du):
            return 0.5

    plain = Term()
    assert plain.covers(None) is True and plain.max_step(None, None) == 1.0
    assert plain.begin_step(None) == 0 and plain.end_step() is None
    model = Model(rectangle(nx=2, ny=2), NeoHookean(1.0, 10.0))
    term = Limited()
    model.add_term(term)
    assert model._limit_terms == [term] and model._pattern_terms == [] and model._step_terms == []
    u = np.zeros(model.n_dofs)
    assert model.step_limit(u, u) == 0.5 and Model(rectangle(nx=2, ny=2), NeoHookean(1.0, 10.0)).step_limit is None


@pytest.mark.parametrize("bad", ["x", 3])
def test_a_bad_term_is_refused_by_name_by_the_constructor_and_by_add_term(bad):
    """Neither a Term nor a factory: a ParameterError naming ``terms``, not a TypeError from calling it."""
    from tissuefem.engine.parameters import ParameterError

    with pytest.raises(ParameterError, match="terms must be Term objects") as err:
        Model(rectangle(1.0, 1.0, 3, 3), NeoHookean(1.0, 1.0), terms=[bad])
    assert err.value.field == "terms"
    model = Model(rectangle(1.0, 1.0, 3, 3), NeoHookean(1.0, 1.0))
    with pytest.raises(ParameterError, match="terms must be Term objects"):
        model.add_term(bad)
    assert model.term_names == ["elastic"]
