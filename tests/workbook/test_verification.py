"""The study's tools: the Pareto front, fitted exponents, and the verified linear and nonlinear reference in 2D
(chapter 9) and 3D (chapter 11)."""

import numpy as np
import pytest

from tissuefem import NeoHookean
from tissuefem.engine.constants import TISSUE_E, TISSUE_NU
from tissuefem.workbook import figures
from tissuefem.workbook.measure import best_within_budget, cost_at_error, fitted_exponent, pareto_front
from tissuefem.workbook.studies import bending_map
from tissuefem.workbook.verification import (beam_convergence, beam_exact, beam_problem_tip, manufactured_body_force,
                                             manufactured_convergence, manufactured_error, manufactured_gradient,
                                             manufactured_map)


def test_pareto_front_on_a_hand_made_example():
    #            0     1     2     3    4     5          6
    costs = [10.0, 5.0, 20.0, 5.0, 1.0, 30.0, float("nan")]
    errors = [1e-3, 1e-2, 1e-4, 2e-2, 1e-1, 1e-4, 1e-9]
    # 3 is beaten by 1 (same cost, less error); 5 by 2 (same error, more cost); 6 is not finite
    assert pareto_front(costs, errors).tolist() == [4, 1, 0, 2]


def test_pareto_front_edge_cases():
    assert pareto_front([1.0], [1.0]).tolist() == [0]
    assert pareto_front([1.0, 1.0], [2.0, 2.0]).tolist() == [0]  # a tie keeps the first
    assert pareto_front([], []).tolist() == []
    with pytest.raises(ValueError, match="same length"):
        pareto_front([1.0, 2.0], [1.0])


def test_errors_within_the_resolution_are_ties():
    """No winner by the last digits: with rtol, a slower setting must be better by more than the factor 1 + rtol."""
    costs = [1.0, 2.0, 3.0, 4.0]
    errors = [1.000e-1, 0.995e-1, 0.5e-1, 0.499e-1]
    assert pareto_front(costs, errors).tolist() == [0, 1, 2, 3]
    assert pareto_front(costs, errors, rtol=0.01).tolist() == [0, 2]
    assert best_within_budget(costs, errors, 10.0) == 3
    assert best_within_budget(costs, errors, 10.0, rtol=0.01) == 2  # ties with 3, and cheaper
    with pytest.raises(ValueError, match="rtol"):
        pareto_front(costs, errors, rtol=-1.0)


def test_cost_at_error_interpolates_on_log_axes():
    costs, errors = [1.0, 4.0, 16.0], [1e-2, 1e-3, 1e-4]  # error ~ cost^(-5/3)
    assert cost_at_error(costs, errors, 1e-3) == pytest.approx(4.0)
    assert cost_at_error(costs, errors, 10 ** -3.5) == pytest.approx(8.0)
    assert cost_at_error(costs, errors, 1e-5) is None


def test_fitted_exponent():
    h = np.array([0.1, 0.05, 0.025])
    assert fitted_exponent(h, 3.0 * h**2) == pytest.approx(2.0)
    assert fitted_exponent([1000, 2000, 4000], [1.0, 2.2, 4.9]) == pytest.approx(1.15, abs=0.02)
    with pytest.raises(ValueError, match="> 0"):
        fitted_exponent([1.0, 2.0], [0.0, 1.0])


# --- the cantilever: the closed form is an exact elasticity solution ------------------------------------------------

E, NU, P, L, D = 3.0e7, 0.3, 1000.0, 48.0, 12.0


def _stress(x, y, h=1e-5):
    """Plane-stress stress of beam_exact, from central differences of the displacement."""
    def grad(x, y):
        ux_x = (beam_exact([[x + h], [y]]) - beam_exact([[x - h], [y]]))[:, 0] / (2 * h)
        ux_y = (beam_exact([[x], [y + h]]) - beam_exact([[x], [y - h]]))[:, 0] / (2 * h)
        return np.array([ux_x, ux_y]).T  # [i, j] = du_i / dx_j

    G = grad(x, y)
    eps = 0.5 * (G + G.T)
    lam = E * NU / (1 - NU**2)  # plane stress
    mu = E / (2 * (1 + NU))
    return lam * np.trace(eps) * np.eye(2) + 2 * mu * eps


@pytest.mark.parametrize("x, y", [(5.0, 2.0), (20.0, -4.5), (40.0, 0.3)])
def test_the_beam_solution_is_in_equilibrium_with_the_stated_stresses(x, y):
    I = D**3 / 12
    s = _stress(x, y)
    assert s[0, 0] == pytest.approx(-P * (L - x) * y / I, rel=1e-5, abs=1e-3)
    assert s[1, 1] == pytest.approx(0.0, abs=1e-3 * abs(s[0, 0]) + 1e-6)
    assert s[0, 1] == pytest.approx(P / (2 * I) * (D**2 / 4 - y**2), rel=1e-5)
    h = 1e-3  # div sigma = 0
    div = [(_stress(x + h, y)[i, 0] - _stress(x - h, y)[i, 0] + _stress(x, y + h)[i, 1] - _stress(x, y - h)[i, 1])
           / (2 * h) for i in range(2)]
    assert np.allclose(div, 0.0, atol=1e-3 * P / I * D)


def test_the_beam_is_free_on_top_and_bottom_and_carries_the_load_at_its_end():
    for y in (D / 2, -D / 2):
        s = _stress(25.0, y)
        assert abs(s[0, 1]) < 1e-2 and abs(s[1, 1]) < 1e-2
    ys = np.linspace(-D / 2, D / 2, 401)
    shear = np.array([_stress(L, y)[0, 1] for y in ys])
    assert np.sum(0.5 * (shear[1:] + shear[:-1]) * np.diff(ys)) == pytest.approx(P, rel=1e-4)  # trapezoid rule


def test_the_published_tip_deflection():
    computed, exact = beam_problem_tip(8, 2, order=2)
    assert exact == pytest.approx(0.0089, rel=1e-12)  # P L^3/(3EI) + (4 + 5 nu) P D^2 L/(24 E I)


def test_the_linear_chain_converges_to_the_reference():
    p2 = [abs(beam_problem_tip(4 * n, n, order=2)[0] / 0.0089 - 1) for n in (1, 2, 4)]
    assert p2[-1] < 2e-5 and p2[0] > p2[1] > p2[2]
    p1 = [abs(beam_problem_tip(4 * n, n, order=1)[0] / 0.0089 - 1) for n in (2, 4, 8)]
    assert fitted_exponent([1 / 2, 1 / 4, 1 / 8], p1) == pytest.approx(2.0, abs=0.35)  # P1: O(h^2) in displacement


# --- 3D: the same chain on tetrahedra --------------------------------------------------------------------------------

def test_the_plane_strain_beam_is_an_exact_3d_state_with_sigma_zz_on_its_faces():
    """With E' = E / (1 - nu^2), nu' = nu / (1 - nu) and u_z = 0, beam_exact has the stated stresses in 3D Hooke's
    law, and sigma_zz = nu sigma_xx: what beam_problem_tip puts on the faces z = const."""
    Ep, nup = E / (1 - NU**2), NU / (1 - NU)
    lam, mu = E * NU / ((1 + NU) * (1 - 2 * NU)), E / (2 * (1 + NU))
    I, h = D**3 / 12, 1e-5
    for x, y in [(5.0, 2.0), (20.0, -4.5), (40.0, 0.3)]:
        G = np.zeros((3, 3))
        for j, e in enumerate(([h, 0.0], [0.0, h])):
            G[:2, j] = (beam_exact([[x + e[0]], [y + e[1]]], E=Ep, nu=nup)
                        - beam_exact([[x - e[0]], [y - e[1]]], E=Ep, nu=nup))[:, 0] / (2 * h)
        eps = 0.5 * (G + G.T)
        s = lam * np.trace(eps) * np.eye(3) + 2 * mu * eps
        assert s[0, 0] == pytest.approx(-P * (L - x) * y / I, rel=1e-5)
        assert s[0, 1] == pytest.approx(P / (2 * I) * (D**2 / 4 - y**2), rel=1e-5)
        assert abs(s[1, 1]) < 1e-3 and abs(s[0, 2]) < 1e-9 and abs(s[1, 2]) < 1e-9
        assert s[2, 2] == pytest.approx(NU * s[0, 0], rel=1e-5)


def test_the_3d_cantilever_reproduces_the_closed_form_tip_deflection():
    """P2 tetrahedra on 8 x 2 x 1 cells within 3e-4 of the closed form (2.5e-4); refined, the error falls."""
    Ep, nup, I = E / (1 - NU**2), NU / (1 - NU), D**3 / 12
    computed, exact = beam_problem_tip(8, 2, order=2, nz=1)
    assert exact == pytest.approx(P * L**3 / (3 * Ep * I) + (4 + 5 * nup) * P * D**2 * L / (24 * Ep * I), rel=1e-12)
    assert exact == pytest.approx(8.138e-3, rel=1e-12)
    assert computed == pytest.approx(exact, rel=3e-4)
    errors = [r["relative_error"] for r in beam_convergence((1, 2, 4))]
    assert errors[0] > errors[1] > errors[2] and errors[2] < 5e-5


def test_the_3d_manufactured_map_and_its_gradient():
    X = np.random.default_rng(0).uniform([0.0, 0.0, 0.0], [2.0, 1.0, 1.0], size=(40, 3)).T
    F, h = manufactured_gradient(X), 1e-6
    for j in range(3):
        e = np.zeros((3, 1))
        e[j] = h
        assert np.allclose(F[:, j], (manufactured_map(X + e) - manufactured_map(X - e)) / (2 * h), rtol=0, atol=1e-8)
    assert np.all(np.linalg.det(np.moveaxis(F, (0, 1), (-2, -1))) > 0.5)  # orientation kept everywhere
    assert np.array_equal(manufactured_map(X[:2]), bending_map(X[:2]))  # in 2D: chapter 3's arch
    b = manufactured_body_force(NeoHookean.from_young(TISSUE_E, TISSUE_NU), X)
    assert b.shape == X.shape and np.all(np.isfinite(b)) and np.abs(b).max() > 0


def test_nonlinear_mesh_convergence_on_tetrahedra_at_the_expected_rates():
    """Relative L2 displacement errors: P1 ~ h^2, P2 ~ h^3 (measured 2.00 and 3.00; docs/benchmarks.md)."""
    rows = manufactured_convergence(models=("neo-hookean",), dim=3)  # the default sizes: P1 n = 2, 4, 8; P2 1, 2, 4
    rates = {r["order"]: r["fitted_rate"] for r in rows}
    assert 1.8 <= rates[1] <= 2.2 and 2.7 <= rates[2] <= 3.3, rates
    assert all(r["dim"] == 3 and r["errors"][0] > r["errors"][-1] for r in rows)
    with pytest.raises(ValueError, match="dim"):
        manufactured_error(NeoHookean(1.0, 1.0), 2, 1, dim=4)


def test_the_chapter_11_convergence_figure_draws_given_rows():
    rows = [{"model": "neo-hookean", "order": o, "dim": 3, "h": [0.5, 0.25], "errors": [e, e / 2 ** (o + 1)],
             "fitted_rate": o + 1.0} for o, e in ((1, 1e-2), (2, 1e-3))]
    fig = figures.FIGURES["fig_ch11_convergence"](rows=rows)
    assert "tetrahedra" in fig.axes[0].get_title()
