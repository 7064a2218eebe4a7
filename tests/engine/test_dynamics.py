"""Backward Euler as an incremental potential: a model with a time step, stepped by the one Stepper (chapter 7)."""

import numpy as np
import pytest

from tissuefem import Handle, Model, NeoHookean, StableNeoHookean, Stepper, lame_parameters, rectangle, solve

LAM, MU = lame_parameters(1000.0, 0.3, "strain")


def _flap(material=None, **kw):
    mesh = rectangle(2.0, 1.0, 8, 4)
    grab = Handle("right", (0.0, 0.0))
    model = Model(mesh, material or StableNeoHookean(LAM, MU), handles=[Handle("left"), grab], **kw)
    return model, grab


@pytest.mark.parametrize("order", [1, 2])
@pytest.mark.parametrize("mass", ["lumped", "consistent"])
def test_mass_matrix_integrates_the_density(order, mass):
    if order == 2 and mass == "lumped":
        with pytest.raises(ValueError, match="lumped"):
            _flap(dt=0.1, density=2.5, mass=mass, order=order)
        return
    model, _ = _flap(dt=0.1, density=2.5, mass=mass, order=order)
    M = model.inertia.M
    ones_x = np.zeros(model.n_dofs)
    ones_x[model.component == 0] = 1.0
    assert ones_x @ (M @ ones_x) == pytest.approx(2.5 * 2.0)  # rho * area, per component
    assert model.total_mass() == pytest.approx(2.5 * 2.0)


def test_bad_inertia_settings_are_refused_by_name():
    for bad in (0.0, -1.0, np.nan, "0.1", True):
        with pytest.raises(ValueError, match="dt"):
            _flap(dt=bad)
    with pytest.raises(ValueError, match="density"):
        _flap(dt=0.1, density=0.0)
    with pytest.raises(ValueError, match="mass"):
        _flap(dt=0.1, mass="diagonal")
    with pytest.raises(ValueError, match="gravity"):
        _flap(dt=0.1, gravity=(0.0, np.inf))


def test_the_potential_gradient_is_the_backward_euler_residual():
    model, _ = _flap(dt=0.05, density=1.3, mass="consistent", gravity=(0.0, -9.81))
    dt = model.inertia.dt
    rng = np.random.default_rng(3)
    un, vn = 0.01 * rng.normal(size=model.n_dofs), rng.normal(size=model.n_dofs)
    model.inertia.x_tilde = un + dt * vn
    x = un + 0.01 * rng.normal(size=model.n_dofs)
    # the residual as derived from the semi-discrete equations M a = f_ext - f_int (not the notes' printed form)
    M, f_ext = model.inertia.M, model.external
    q = M @ ((x - un) / dt - vn) / dt + model.internal_force(x) - f_ext
    np.testing.assert_allclose(model.gradient(x), q, rtol=1e-12, atol=1e-12)
    # the gravity load is rho g integrated over the area
    assert f_ext[model.component == 1].sum() == pytest.approx(1.3 * -9.81 * 2.0)
    # and it is the gradient of the incremental potential (the chapters' E divided by dt^2)
    d = rng.normal(size=x.size)
    h = 1e-6
    fd = (model.energy(x + h * d) - model.energy(x - h * d)) / (2 * h)
    assert fd == pytest.approx(model.gradient(x) @ d, rel=1e-6)


@pytest.mark.parametrize("mass", ["lumped", "consistent"])
def test_released_flap_loses_energy_and_settles_at_rest(mass):
    model, grab = _flap()
    grab.move((0.0, 0.5))
    u0 = solve(model, load_steps=2).u
    stepper = Stepper(Model(model.mesh, model.material, handles=[Handle("left")], dt=1 / 30, mass=mass))
    stepper.reset(u0)
    energies = [stepper.total_energy()]
    for _ in range(60):
        report = stepper.step()
        assert report.converged
        energies.append(stepper.total_energy())
    assert np.all(np.diff(energies) <= 1e-9 * energies[0])  # backward Euler only removes energy
    assert energies[-1] < 0.1 * energies[0]


def test_hanging_under_gravity_approaches_the_quasistatic_sag():
    mesh, material = rectangle(2.0, 1.0, 8, 4), StableNeoHookean(LAM, MU)
    sag = solve(Model(mesh, material, handles=[Handle("left")], gravity=(0.0, -9.81))).u
    stepper = Stepper(Model(mesh, material, handles=[Handle("left")], dt=0.2, gravity=(0.0, -9.81)))
    for _ in range(200):
        assert stepper.step().converged
    assert np.abs(sag).max() > 0.01
    np.testing.assert_allclose(stepper.u, sag, atol=1e-4)


def test_a_failed_step_keeps_the_state():
    model, grab = _flap(NeoHookean(LAM, MU), dt=1 / 30)
    stepper = Stepper(model, max_iterations=20)
    grab.move((-2.5, 0.0))  # the right edge through the left one: ln J cannot get there
    u, v, t = stepper.u.copy(), stepper.v.copy(), stepper.time
    report = stepper.step()
    assert not report.converged and not report.committed
    np.testing.assert_array_equal(stepper.u, u)
    np.testing.assert_array_equal(stepper.v, v)
    assert stepper.time == t and stepper.steps == 0


def test_dt_changes_between_steps_are_checked():
    model, _ = _flap(dt=1 / 30)
    stepper = Stepper(model)
    stepper.step()
    for bad in (0.0, np.nan, None):
        with pytest.raises(ValueError, match="dt"):
            stepper.dt = bad
    assert stepper.dt == pytest.approx(1 / 30)
    stepper.dt = 0.01
    assert model.inertia.dt == 0.01 and stepper.step().converged
    quasistatic = Stepper(_flap()[0])
    with pytest.raises(ValueError, match="dt"):
        quasistatic.dt = 0.1
