"""1D materials, the bar FEM, Newton: derivations checked by finite differences and closed forms."""

import warnings

import numpy as np
import pytest

from tissuefem import Bar1D, Displacement, Linear1D, NeoHookean1D, TaylorNeoHookean1D, Traction, lame_parameters, newton
from tissuefem.engine.bar1d import uniform_bar_stretch
from tissuefem.engine.materials1d import taylor_log, taylor_log_prime
from tissuefem.workbook.oned import convergence_study

LAM, MU = lame_parameters(1000.0, 0.3)
MODELS = [Linear1D(LAM, MU), NeoHookean1D(LAM, MU), TaylorNeoHookean1D(LAM, MU)]
ids = [m.name for m in MODELS]

# many F, including values close to 0 (where the log model is stiffest)
F_POSITIVE = np.concatenate([np.geomspace(1e-3, 0.2, 15), np.linspace(0.25, 4.0, 40)])
F_INVERTED = np.linspace(-2.0, 0.0, 21)


def _central_difference(f, x, rel=1e-6):
    h = rel * np.maximum(np.abs(x), 1e-3)
    return (f(x + h) - f(x - h)) / (2 * h)


@pytest.mark.parametrize("material", MODELS, ids=ids)
def test_stress_is_derivative_of_energy(material):
    F = F_POSITIVE if not material.inversion_safe else np.concatenate([F_INVERTED, F_POSITIVE])
    fd = _central_difference(material.energy, F)
    np.testing.assert_allclose(material.stress(F), fd, rtol=1e-6, atol=1e-6 * material.modulus)


@pytest.mark.parametrize("material", MODELS, ids=ids)
def test_tangent_is_derivative_of_stress(material):
    F = F_POSITIVE if not material.inversion_safe else np.concatenate([F_INVERTED, F_POSITIVE])
    fd = _central_difference(material.stress, F)
    np.testing.assert_allclose(material.tangent(F), fd, rtol=1e-6, atol=1e-6 * material.modulus)


@pytest.mark.parametrize("material", MODELS, ids=ids)
def test_rest_state_is_stress_free(material):
    assert material.energy(1.0) == pytest.approx(0.0, abs=1e-12)
    assert material.stress(1.0) == pytest.approx(0.0, abs=1e-12)


def test_linear_modulus_is_linearisation_of_neo_hookean():
    """The notes print the 1D modulus as (2 mu - lam); the linearisation of P(F) at F = 1 is 2 mu + lam."""
    for model in (NeoHookean1D(LAM, MU), TaylorNeoHookean1D(LAM, MU)):
        slope = _central_difference(model.stress, np.array([1.0]))[0]
        assert slope == pytest.approx(2 * MU + LAM, rel=1e-8)
        assert slope != pytest.approx(2 * MU - LAM, rel=1e-2)
    assert Linear1D(LAM, MU).modulus == pytest.approx(2 * MU + LAM)


def test_taylor_log_matches_log_to_third_order():
    d = np.array([1e-2, 2e-2, 4e-2])
    err = np.abs(taylor_log(1 + d) - np.log(1 + d))
    # the first neglected term is -(J-1)^4/4: the error is fourth order
    np.testing.assert_allclose(err / d**4, 0.25, rtol=0.1)
    assert np.all(taylor_log_prime(np.linspace(-5, 5, 101)) > 0)


def test_log_model_is_nan_without_warnings_when_inverted():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        values = [NeoHookean1D(LAM, MU).stress(F_INVERTED), NeoHookean1D(LAM, MU).energy(F_INVERTED)]
    assert all(np.all(np.isnan(v)) for v in values)
    for v in (TaylorNeoHookean1D(LAM, MU).stress(F_INVERTED), TaylorNeoHookean1D(LAM, MU).energy(F_INVERTED)):
        assert np.all(np.isfinite(v))


@pytest.mark.parametrize("bad", [dict(E=0.0, nu=0.3), dict(E=-1.0, nu=0.3), dict(E=np.nan, nu=0.3),
                                 dict(E=1.0, nu=0.5), dict(E=1.0, nu=-1.0), dict(E=1.0, nu=0.7)])
def test_bad_parameters_are_rejected_by_name(bad):
    with pytest.raises(ValueError, match="E|nu"):
        NeoHookean1D.from_young(**bad)


def test_lame_parameters_values():
    lam, mu = lame_parameters(1000.0, 0.3)
    assert lam == pytest.approx(1000 * 0.3 / (1.3 * 0.4))
    assert mu == pytest.approx(1000 / 2.6)
    lam_s, mu_s = lame_parameters(1000.0, 0.3, plane="stress")
    assert lam_s == pytest.approx(1000 * 0.3 / (1 - 0.09))  # E nu / (1 - nu^2)
    assert mu_s == pytest.approx(mu)
    with pytest.raises(ValueError, match="plane"):
        lame_parameters(1.0, 0.3, plane="membrane")


# --- the linear bar ----------------------------------------------------------------

def test_linear_bar_matches_closed_form_with_body_force():
    """-E u'' = f, u(a) = 0, E u'(b) = T: P1 nodal values are exact for constant f."""
    E1, f, T, a, b = 5.0, 2.0, 3.0, -1.0, 2.0
    bar = Bar1D(a, b, 12)
    u = bar.solve_linear(E1, f, left=Displacement(0.0), right=Traction(T))
    X = bar.nodes
    exact = (T * (X - a) + f * (b - a) * (X - a) - 0.5 * f * (X - a) ** 2) / E1
    np.testing.assert_allclose(u, exact, atol=1e-12)


def test_linear_bar_both_ends_prescribed_and_left_traction():
    bar = Bar1D(0.0, 1.0, 8)
    u = bar.solve_linear(2.0, 0.0, left=Displacement(0.1), right=Displacement(0.3))
    np.testing.assert_allclose(u, 0.1 + 0.2 * bar.nodes, atol=1e-13)
    # a traction is a force component: -1 at the left end pulls left and stretches the bar (P = 1)
    u = bar.solve_linear(2.0, 0.0, left=Traction(-1.0), right=Displacement(0.0))
    np.testing.assert_allclose(u, -0.5 * (1.0 - bar.nodes), atol=1e-13)


def test_boundary_term_is_g_of_the_notes():
    bar = Bar1D(0.0, 1.0, 4)
    g = bar.boundary_term(Traction(2.0), Traction(5.0))
    # g_i = N_i(b) P(b) - N_i(a) P(a) with P(b) = t_b, P(a) = -t_a
    assert g[bar.dof_b] == 5.0 and g[bar.dof_a] == 2.0 and np.count_nonzero(g) == 2


def test_convergence_rates():
    rows = convergence_study(ns=(8, 16, 32))
    last = {r["order"]: r for r in rows if r["n"] == 32}
    assert last[1]["rate_L2"] == pytest.approx(2.0, abs=0.05)
    assert last[1]["rate_H1"] == pytest.approx(1.0, abs=0.05)
    assert last[2]["rate_L2"] == pytest.approx(3.0, abs=0.05)
    assert last[2]["rate_H1"] == pytest.approx(2.0, abs=0.05)


@pytest.mark.parametrize("kwargs", [dict(a=1.0, b=0.0), dict(n=0), dict(n=2.5), dict(order=3),
                                    dict(nodes=[0.0, 0.0, 1.0]), dict(nodes=[0.0, np.nan]), dict(nodes=[1.0])])
def test_bad_bars_are_rejected(kwargs):
    with pytest.raises(ValueError):
        Bar1D(**kwargs)


def test_tractions_at_both_ends_is_a_clear_error():
    with pytest.raises(ValueError, match="Displacement"):
        Bar1D().solve_linear(1.0, 0.0, left=Traction(1.0), right=Traction(1.0))
    with pytest.raises(ValueError, match="left"):
        Bar1D().solve_linear(1.0, 0.0, left=1.0)
    with pytest.raises(ValueError, match="non-finite"):
        Bar1D().solve_linear(1.0, 0.0, right=Traction(np.inf))


# --- the Neo-Hookean bar and Newton --------------------------------------------------

@pytest.mark.parametrize("T", [-600.0, -300.0, 50.0, 300.0, 900.0])
@pytest.mark.parametrize("order, nodes", [(1, None), (2, None), (1, [0.0, 0.05, 0.3, 0.35, 0.8, 1.0])])
def test_neo_hookean_bar_matches_uniform_stretch(T, order, nodes):
    material = NeoHookean1D(LAM, MU)
    bar = Bar1D(0.0, 1.0, 7, order=order, nodes=nodes)
    u, results = bar.solve_nonlinear(material, right=Traction(T), load_steps=2, rtol=1e-14, atol=1e-11)
    assert results[-1].converged
    F = uniform_bar_stretch(material, T)
    assert material.stress(F) == pytest.approx(T, abs=1e-9)
    np.testing.assert_allclose(u, (F - 1.0) * bar.nodes, atol=1e-10)


def test_newton_converges_quadratically():
    material = NeoHookean1D(LAM, MU)
    _, results = Bar1D(0.0, 1.0, 16).solve_nonlinear(material, right=Traction(400.0), rtol=1e-14)
    norms = results[0].residual_norms()
    assert results[0].converged
    # ratio test: |q_{k+1}| / |q_k|^2 stays bounded once in the asymptotic regime
    ratios = norms[1:] / norms[:-1] ** 2
    asymptotic = ratios[1:-1]
    assert np.all(asymptotic < 10 * asymptotic[0])
    assert norms[-1] < 1e-8 * norms[0]
    assert len(norms) <= 7


def test_strong_compression_breaks_the_log_model_without_crashing():
    """Plain Newton from rest under T = -1500 predicts F < 0: the log model returns a status, not a crash."""
    material = NeoHookean1D(LAM, MU)
    bar = Bar1D(0.0, 1.0, 8)
    u, results = bar.solve_nonlinear(material, right=Traction(-1500.0))
    assert results[0].status == "non-finite" and not results[0].converged
    assert np.all(np.isfinite(u))
    # the Newton step from rest is the linear prediction F = 1 + T / (lam + 2 mu) < 0
    assert 1.0 - 1500.0 / (LAM + 2 * MU) < 0
    # safeguards recover: load stepping, or halving the step until the residual is finite
    for options in (dict(load_steps=10), dict(line_search="finite")):
        u, results = bar.solve_nonlinear(material, right=Traction(-1500.0), **options)
        assert results[-1].converged, options
        F = uniform_bar_stretch(material, -1500.0)
        np.testing.assert_allclose(u, (F - 1.0) * bar.nodes, atol=1e-8)
    # the Taylor model is finite everywhere, so plain Newton never produces NaN
    u, results = bar.solve_nonlinear(TaylorNeoHookean1D(LAM, MU), right=Traction(-1500.0))
    assert np.all(np.isfinite(u))


def test_energy_line_search_decreases_energy():
    material = TaylorNeoHookean1D(LAM, MU)
    bar = Bar1D(0.0, 1.0, 8)
    _, results = bar.solve_nonlinear(material, right=Traction(-900.0), line_search="energy")
    energies = [h.energy for h in results[0].history]
    assert results[0].converged
    assert all(e2 <= e1 + 1e-9 for e1, e2 in zip(energies, energies[1:]))


def test_newton_reports_singular_tangent_as_status():
    result = newton(np.zeros(2), lambda x: np.array([1.0, 1.0]), lambda x: np.zeros((2, 2)), line_search=None)
    assert result.status == "singular" and not result.converged
    with pytest.raises(ValueError, match="x0"):
        newton(np.array([np.nan]), lambda x: x, lambda x: np.eye(1), line_search=None)
