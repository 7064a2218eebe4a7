"""Backward Euler as an incremental potential (core of chapter 7)."""

import numpy as np
import pytest

from tissuefem.engine.dynamics import BackwardEuler, mass_matrix
from tissuefem.engine.materials import NeoHookean, StableNeoHookean
from tissuefem.engine.meshes import rectangle
from tissuefem.engine.parameters import lame_parameters
from tissuefem.engine.quasistatic import Handle, QuasistaticProblem

LAM, MU = lame_parameters(1000.0, 0.3, "strain")


def _flap(material=None, **kw):
    mesh = rectangle(2.0, 1.0, 8, 4)
    grab = Handle("right", (0.0, 0.0))
    problem = QuasistaticProblem(mesh, material or StableNeoHookean(LAM, MU), handles=[Handle("left"), grab], **kw)
    return problem, grab


def test_mass_matrix_integrates_the_density():
    problem, _ = _flap()
    for lumped in (False, True):
        M = mass_matrix(problem.basis, 2.5, lumped=lumped)
        ones_x = np.zeros(problem.basis.N)
        ones_x[problem.basis.nodal_dofs[0]] = 1.0
        assert ones_x @ (M @ ones_x) == pytest.approx(2.5 * 2.0)  # rho * area, per component
    with pytest.raises(ValueError, match="density"):
        mass_matrix(problem.basis, 0.0)


def test_incremental_potential_gradient_is_dt2_times_the_backward_euler_residual():
    problem, _ = _flap()
    be = BackwardEuler(problem, dt=0.05, density=1.3, mass="consistent", gravity=(0.0, -9.81))
    rng = np.random.default_rng(3)
    un, vn = 0.01 * rng.normal(size=problem.basis.N), rng.normal(size=problem.basis.N)
    be.u, be.v = un, vn
    u_tilde = un + be.dt * vn
    x = un + 0.01 * rng.normal(size=problem.basis.N)
    # the residual as derived from the semi-discrete equations (not the notes' printed form)
    q = be.M @ (x - un - be.dt * vn) / be.dt**2 + problem.internal_force(x) - be.external
    np.testing.assert_allclose(be.residual(x, u_tilde), be.dt**2 * q, rtol=1e-12, atol=1e-12)
    # and it is the gradient of the incremental potential
    d = rng.normal(size=x.size)
    h = 1e-6
    fd = (be.incremental_potential(x + h * d, u_tilde) - be.incremental_potential(x - h * d, u_tilde)) / (2 * h)
    assert fd == pytest.approx(be.residual(x, u_tilde) @ d, rel=1e-6)


@pytest.mark.parametrize("mass", ["lumped", "consistent"])
def test_released_flap_loses_energy_and_settles_at_rest(mass):
    problem, grab = _flap()
    grab.move((0.0, 0.5))
    u0 = problem.solve(load_steps=2).u
    problem2 = QuasistaticProblem(problem.mesh, problem.material, handles=[Handle("left")])
    be = BackwardEuler(problem2, dt=1 / 30, density=1.0, mass=mass)
    be.u = u0.copy()
    energies = [be.total_energy()]
    for _ in range(60):
        report = be.step()
        assert report.converged
        energies.append(be.total_energy())
    assert np.all(np.diff(energies) <= 1e-9 * energies[0])  # backward Euler only removes energy
    assert energies[-1] < 0.1 * energies[0]


def test_hanging_under_gravity_approaches_the_quasistatic_sag():
    mesh, material = rectangle(2.0, 1.0, 8, 4), StableNeoHookean(LAM, MU)
    sag = QuasistaticProblem(mesh, material, handles=[Handle("left")], body_force=(0.0, -9.81)).solve().u
    be = BackwardEuler(QuasistaticProblem(mesh, material, handles=[Handle("left")]), dt=0.2, gravity=(0.0, -9.81))
    for _ in range(200):
        assert be.step().converged
    assert np.abs(sag).max() > 0.01
    np.testing.assert_allclose(be.u, sag, atol=1e-4)


def test_bad_arguments_and_failed_steps_keep_the_state():
    problem, grab = _flap(NeoHookean(LAM, MU))
    for bad in (0.0, -1.0, np.nan):
        with pytest.raises(ValueError, match="dt"):
            BackwardEuler(problem, dt=bad)
    with pytest.raises(ValueError, match="mass"):
        BackwardEuler(problem, dt=0.1, mass="diagonal")
    with pytest.raises(ValueError, match="gravity"):
        BackwardEuler(problem, dt=0.1, gravity=(0.0, np.inf))
    be = BackwardEuler(problem, dt=1 / 30)
    grab.move((-2.5, 0.0))  # the right edge through the left one: ln J cannot get there
    u, v, t = be.u.copy(), be.v.copy(), be.time
    report = be.step(max_iter=20)
    assert not report.converged
    np.testing.assert_array_equal(be.u, u)
    np.testing.assert_array_equal(be.v, v)
    assert be.time == t
