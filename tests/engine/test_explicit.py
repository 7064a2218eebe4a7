"""Explicit symplectic Euler, its stability limit (CFL) and the chapter-7 figures."""

import warnings

import numpy as np
import pytest
import scipy.linalg
from helpers import assert_figure_deterministic

from tissuefem import (Handle, Model, NeoHookean, StableNeoHookean, SymplecticEuler, critical_time_step,
                       lame_parameters, largest_stable_dt, mesh_size, rectangle, solve, wave_speed)
from tissuefem.engine.explicit import is_stable
from tissuefem.workbook import figures
from tissuefem.workbook.timestepping import cfl_study

LAM, MU = lame_parameters(1000.0, 0.3, "strain")


def _held_flap(nx=8, material=None, extra_handles=(), **kw):
    mesh = rectangle(2.0, 1.0, nx, max(1, nx // 2))
    return Model(mesh, material or StableNeoHookean(LAM, MU), handles=[Handle("left"), *extra_handles], **kw)


def _released_flap(material=None):
    """The flap lifted 0.5 at its right edge (quasistatic), and the problem that lets it go."""
    material = material or StableNeoHookean(LAM, MU)
    mesh = rectangle(2.0, 1.0, 8, 4)
    pulled = Model(mesh, material, handles=[Handle("left"), Handle("right", (0.0, 0.5))])
    result = solve(pulled, load_steps=2)
    assert result.converged
    return Model(mesh, material, handles=[Handle("left")]), result.u


def _free(problem):
    fixed, _ = problem.prescribed()
    return np.setdiff1d(np.arange(problem.n_dofs), fixed)


def test_symplectic_euler_keeps_the_energy_of_a_released_flap_over_many_periods():
    problem, u0 = _released_flap()
    dt = 0.25 * critical_time_step(problem)
    scheme = SymplecticEuler(problem, dt)
    scheme.u = u0.copy()
    # the slowest mode of the flap has a period of about 0.83 s: 6 s is about seven periods
    history = scheme.run(int(6.0 / dt))
    assert history.size == int(6.0 / dt) + 1 and scheme.time == pytest.approx(dt * (history.size - 1))
    relative = history / history[0]
    assert np.abs(relative - 1.0).max() < 0.04  # bounded oscillation, a few percent
    period = int(0.83 / dt)
    assert abs(relative[-period:].mean() - relative[:period].mean()) < 0.01  # and no drift
    assert np.abs(scheme.u).max() > 0.1  # it is still swinging (no numerical damping)


def test_critical_time_step_is_two_over_the_largest_frequency():
    for nx in (8, 24):  # a dense and a Lanczos (eigsh) solve (more than 400 free dofs)
        problem = _held_flap(nx, density=2.0)
        free = _free(problem)
        K = problem.hessian(problem.zeros()).toarray()[np.ix_(free, free)]
        # the lumped mass: a third of each triangle's mass on each of its vertices
        m = np.repeat(np.bincount(problem.mesh.t.ravel(), weights=np.tile(2.0 * problem.element_areas() / 3, 3)), 2)
        omega2 = scipy.linalg.eigh(K, np.diag(m[free]), eigvals_only=True)[-1]
        assert critical_time_step(problem) == pytest.approx(2.0 / np.sqrt(omega2), rel=1e-8)
    # a small perturbation is bounded just below the limit and grows just above it
    problem = _held_flap(8)
    dt_crit = critical_time_step(problem)
    assert is_stable(problem, 0.97 * dt_crit)
    assert not is_stable(problem, 1.03 * dt_crit)


def test_above_the_limit_it_blows_up_without_raising_and_keeps_the_last_finite_state():
    problem = _held_flap(8)
    scheme = SymplecticEuler(problem, 1.2 * critical_time_step(problem))
    scheme.u[_free(problem)] = 1e-4 * np.random.default_rng(1).uniform(-1, 1, _free(problem).size)
    e0 = scheme.total_energy()
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no overflow warnings either
        history = scheme.run(5000)
        assert history.size < 5001
        assert scheme.last_report.status == "non-finite" and not scheme.last_report.converged
        assert np.all(np.isfinite(scheme.u)) and np.all(np.isfinite(scheme.v))
        assert np.abs(scheme.u).max() > 1e10 * 1e-4  # it did grow enormously first
        assert not history[-1] < 10 * e0
        u, v, t = scheme.u.copy(), scheme.v.copy(), scheme.time
        report = scheme.step()  # stuck: reported again, state untouched
    assert report.status == "non-finite" and not report.finite and np.isnan(report.max_speed)
    np.testing.assert_array_equal(scheme.u, u)
    np.testing.assert_array_equal(scheme.v, v)
    assert scheme.time == t
    # with an energy limit, run stops as soon as the energy passes it
    scheme = SymplecticEuler(problem, 1.2 * critical_time_step(problem))
    scheme.u[_free(problem)] = 1e-4 * np.random.default_rng(1).uniform(-1, 1, _free(problem).size)
    history = scheme.run(5000, energy_limit=10 * e0)
    assert history[-1] > 10 * e0 and np.all(history[:-1] <= 10 * e0)


def test_a_non_finite_step_leaves_the_state_intact():
    problem = _held_flap(4, NeoHookean(LAM, MU))
    scheme = SymplecticEuler(problem, 1e-3)
    node = np.flatnonzero((np.abs(problem.mesh.p[0] - 1.0) < 1e-9) & (np.abs(problem.mesh.p[1] - 0.5) < 1e-9))[0]
    scheme.u[problem.basis.nodal_dofs[0, node]] = 3.0  # pushes an interior node through its neighbours: J < 0
    scheme.v[:] = 0.5
    u, v = scheme.u.copy(), scheme.v.copy()
    scheme.time = 1.25
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        report = scheme.step()
    assert report.status == "non-finite" and not report.finite and report.time == 1.25
    np.testing.assert_array_equal(scheme.u, u)
    np.testing.assert_array_equal(scheme.v, v)
    assert scheme.time == 1.25
    assert np.isnan(scheme.total_energy())


def test_measured_limit_scales_like_h_and_matches_the_estimate():
    study = cfl_study((4, 8, 16))
    assert 0.8 < study.exponent < 1.2 and 0.8 < study.exponent_estimate < 1.2
    for row in study:
        assert 1 / 1.5 < row["ratio"] < 1.5
        assert row["courant"] == pytest.approx(row["dt_measured"] * study.wave_speed / row["h"])
        assert 0.3 < row["courant"] < 1.0  # dt <= C h / c with C of order one
    assert [r["h"] for r in study] == [0.5, 0.25, 0.125]
    assert study.wave_speed == pytest.approx(np.sqrt(LAM + 2 * MU))
    assert wave_speed(StableNeoHookean(LAM, MU), 4.0) == pytest.approx(np.sqrt((LAM + 2 * MU) / 4.0))
    assert mesh_size(rectangle(2.0, 1.0, 8, 4)) == pytest.approx(0.25)
    # the density enters as 1/sqrt(rho): four times denser, twice the step
    assert largest_stable_dt(_held_flap(4, density=4.0)) == pytest.approx(2 * largest_stable_dt(_held_flap(4)), rel=0.02)


@pytest.mark.parametrize("E, rho", [(1e10, 1e-3), (1e-3, 1e3)], ids=["stiff and light", "soft and heavy"])
def test_the_stable_step_of_an_extreme_body_is_measured_outside_an_implicit_steps_range(E, rho):
    # a bone-stiff, light body's limit lies below 1e-6 s, a jelly's above 10 s: both are measured, not refused
    lam, mu = lame_parameters(E, 0.3, "strain")
    model = _held_flap(4, material=StableNeoHookean(lam, mu), density=rho)
    dt = largest_stable_dt(model)
    estimate = critical_time_step(model)
    assert 0.3 * estimate < dt < 3.0 * estimate


def test_bad_arguments_raise_value_errors_naming_them():
    problem = _held_flap(4)
    for bad in (0.0, -1.0, np.nan, np.inf, "fast"):
        with pytest.raises(ValueError, match="dt"):
            SymplecticEuler(problem, dt=bad)
    for bad in (0.0, -2.0, np.nan, np.inf):
        with pytest.raises(ValueError, match="density"):
            _held_flap(4, density=bad)
    for bad in ((0.0, np.inf), (0.0, np.nan), (1.0, 2.0, 3.0), "down"):
        with pytest.raises(ValueError, match="gravity"):
            _held_flap(4, gravity=bad)
    with pytest.raises(ValueError, match="dt"):  # the scheme brings its own time step
        SymplecticEuler(_held_flap(4, dt=0.1), dt=0.01)
    with pytest.raises(ValueError, match="n_steps"):
        SymplecticEuler(problem, dt=0.01).run(-1)
    with pytest.raises(ValueError, match="growth"):
        largest_stable_dt(problem, growth=1.0)
    # row-sum lumping gives P2 vertices no mass: rejected rather than dividing by zero
    p2 = Model(rectangle(2.0, 1.0, 2, 1), StableNeoHookean(LAM, MU), order=2, handles=[Handle("left")])
    with pytest.raises(ValueError, match="lumped"):
        SymplecticEuler(p2, dt=0.01)
    with pytest.raises(ValueError, match="lumped"):
        critical_time_step(p2)


def test_gravity_accelerates_every_free_node_by_g_in_the_first_step():
    problem = _held_flap(4, density=2.0, gravity=(0.0, -9.81))
    scheme = SymplecticEuler(problem, 0.002)
    report = scheme.step()
    assert report.finite and report.status == "ok" and report.time == pytest.approx(0.002)
    free = _free(problem)
    y = problem.component == 1
    # lumped P1 mass: M^-1 (rho g integrated against N_a) = g at every node, and f_int(0) = 0
    free_y, free_x = free[y[free]], free[~y[free]]
    np.testing.assert_allclose(scheme.v[free_y], -9.81 * 0.002, rtol=1e-12)
    np.testing.assert_allclose(scheme.v[free_x], 0.0, atol=1e-12)
    np.testing.assert_allclose(scheme.u[free], 0.002 * scheme.v[free], rtol=1e-12)
    assert scheme.total_energy() == pytest.approx(
        scheme.kinetic_energy() + problem.stored_energy(scheme.u) - scheme.external @ scheme.u)


def test_prescribed_handle_dofs_follow_their_targets():
    grab = Handle("right")
    problem = _held_flap(8, extra_handles=[grab])
    scheme = SymplecticEuler(problem, 1e-3)
    right = np.unique(problem.handles[1]._dofs)
    left = np.unique(problem.handles[0]._dofs)
    previous = scheme.u[right].copy()
    for k in range(1, 30):
        grab.move((0.0, 0.002 * k))
        assert scheme.step().finite
        fixed, values = problem.prescribed()
        np.testing.assert_array_equal(scheme.u[fixed], values)
        np.testing.assert_allclose(scheme.v[right], (scheme.u[right] - previous) / 1e-3, rtol=1e-12, atol=1e-12)
        previous = scheme.u[right].copy()
    y_right = right[problem.component[right] == 1]
    np.testing.assert_allclose(scheme.u[y_right], 0.058, rtol=1e-12)
    np.testing.assert_allclose(scheme.v[y_right], 2.0, rtol=1e-9)  # 0.002 per step of 1e-3 s
    assert np.all(scheme.u[left] == 0.0) and np.all(scheme.v[left] == 0.0)
    assert np.abs(scheme.u[_free(problem)]).max() > 0  # the body follows (a little)
    # a map target too: the right edge turned about its midpoint
    grab.move(lambda X: np.stack([X[0], 0.5 + 0.9 * (X[1] - 0.5)]))
    scheme.step()
    fixed, values = problem.prescribed()
    np.testing.assert_array_equal(scheme.u[fixed], values)


@pytest.mark.parametrize("name", ["fig_ch07_cfl", "fig_ch07_energy", "fig_ch07_released_flap"])
def test_chapter_7_figures_are_deterministic(name, tmp_path):
    assert_figure_deterministic(name, tmp_path)
    if name == "fig_ch07_released_flap":
        from PIL import Image

        from tissuefem.workbook.figures.base import ANIMATION_MIN_WIDTH

        from tissuefem.workbook.figures.dynamics import ANIMATION_FRAMES

        gifs = [tmp_path / d / f"{name}.gif" for d in "ab"]
        data = gifs[0].read_bytes()
        assert data[:6] == b"GIF89a"
        # the same frames give the same bytes: the helper compared the GIF with the committed one (with
        # another matplotlib, with a second run's)
        assert not gifs[1].exists() or data == gifs[1].read_bytes()
        with Image.open(gifs[0]) as im:
            assert im.n_frames == ANIMATION_FRAMES
            assert im.size[0] >= ANIMATION_MIN_WIDTH  # large enough to project
        assert len(data) < 500_000  # projectable size, still small for the repository
        # without a path nothing is written
        assert figures.FIGURES[name]() is not None
