"""Table-driven checks of the 2D materials (the HOBAK way: every model through the same tests).

The physics every model must satisfy: frame indifference, a stress-free rest
state, linear elasticity in the small-strain limit, major symmetry of the
tangent, finite values through inversion where the model allows. (That stress
and tangent are the derivatives of the energy is checked for every material
and every term in one table, ``test_derivatives.py``.)
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tissuefem.engine.materials import (
    MATERIALS,
    Corotated,
    FiberReinforced,
    LinearElastic,
    Material,
    NeoHookean,
    StableNeoHookean,
    TaylorNeoHookean,
    cofactor,
    det2,
    inverse,
    material,
)
from tissuefem.engine.materials1d import taylor_log, taylor_log_prime
from tissuefem.engine.parameters import lame_parameters

LAM, MU = 1.7, 0.6
K_FIBER = 2.5
NEL, NQP = 30, 3  # random F fields are shaped [2, 2, NEL, NQP], like scikit-fem's


def _rng(seed=0):
    return np.random.default_rng(seed)


def _fibers(shape, seed=7):
    return _rng(seed).normal(size=(2,) + shape)


# The table: every isotropic model, plus the fibre term on several bases with
# uniform, per-element and per-quadrature-point fibres.
ISOTROPIC = {name: (lambda cls=cls: cls(LAM, MU)) for name, cls in MATERIALS.items()}
ALL = {
    **ISOTROPIC,
    "neo-hookean+fibers(uniform)": lambda: FiberReinforced(NeoHookean(LAM, MU), K_FIBER, [1.0, 2.0]),
    "stable+fibers(per element)": lambda: FiberReinforced(
        StableNeoHookean(LAM, MU), K_FIBER, _fibers((NEL,))
    ),
    "corotated+fibers(per point)": lambda: FiberReinforced(Corotated(LAM, MU), K_FIBER, _fibers((NEL, NQP))),
    "taylor+fibers(uniform)": lambda: FiberReinforced(TaylorNeoHookean(LAM, MU), K_FIBER, [0.3, -1.0]),
}


def _table(models):
    return pytest.mark.parametrize("make", list(models.values()), ids=list(models))


def _safe(models):
    return {k: f for k, f in models.items() if f().inversion_safe}


def _frame_indifferent(models):
    return {k: f for k, f in models.items() if k != "linear"}


# --- random deformation gradients and finite differences: the one table's (test_derivatives) ----------

from helpers import H, fd_stress, random_F  # noqa: E402
from helpers import matmul as _matmul, rotation as _rotation  # noqa: E402
from test_derivatives import assert_close_per_sample  # noqa: E402


@settings(derandomize=True, max_examples=100, deadline=None)
@given(st.lists(st.floats(-3.0, 3.0, allow_nan=False), min_size=4, max_size=4))
def test_taylor_stress_matches_energy_hypothesis(entries):
    m = TaylorNeoHookean(LAM, MU)
    F = np.array(entries).reshape(2, 2)
    assert_close_per_sample(m.stress(F), fd_stress(m, F), 2)


@_table(ALL)
def test_tangent_major_symmetry(make):
    m = make()
    A = m.tangent(random_F("positive", seed=4))
    np.testing.assert_allclose(A, A.transpose(2, 3, 0, 1, 4, 5), rtol=0, atol=1e-12 * np.abs(A).max())


# --- shapes -----------------------------------------------------------------------

@_table(ISOTROPIC)
@pytest.mark.parametrize("rest", [(), (5,), (3, 4), (2, 3, 2)])
def test_shapes_and_batch_consistency(make, rest):
    m = make()
    F = random_F("positive", seed=5, shape=rest)
    psi, P, A = m.energy(F), m.stress(F), m.tangent(F)
    assert psi.shape == rest and P.shape == (2, 2) + rest and A.shape == (2, 2, 2, 2) + rest
    # the batch gives the same numbers as one F at a time
    flat = F.reshape(2, 2, -1)
    for n in range(flat.shape[2]):
        Fn = flat[:, :, n]
        np.testing.assert_allclose(m.energy(Fn), psi.reshape(-1)[n], rtol=1e-14, atol=1e-14)
        np.testing.assert_allclose(m.stress(Fn), P.reshape(2, 2, -1)[:, :, n], rtol=1e-14, atol=1e-14)
        np.testing.assert_allclose(m.tangent(Fn), A.reshape(2, 2, 2, 2, -1)[..., n], rtol=1e-14, atol=1e-14)


def test_bad_F_shape():
    for bad in (np.eye(4), np.zeros((2, 3)), np.zeros((3, 2, 5)), np.zeros(3)):
        with pytest.raises(ValueError, match="F must be shaped"):
            NeoHookean(LAM, MU).energy(bad)
    with pytest.raises(ValueError, match="F must be shaped"):
        det2(np.eye(3))  # the 2x2 closed forms stay 2x2


def test_tensor_helpers():
    F = random_F("positive", seed=6)
    np.testing.assert_allclose(det2(F), np.linalg.det(np.moveaxis(F, (0, 1), (-2, -1))))
    Finv = np.moveaxis(np.linalg.inv(np.moveaxis(F, (0, 1), (-2, -1))), (-2, -1), (0, 1))
    np.testing.assert_allclose(inverse(F), Finv, atol=1e-12)
    # cof F = J F^-T, and it is dJ/dF
    np.testing.assert_allclose(cofactor(F), det2(F) * Finv.swapaxes(0, 1), atol=1e-12)
    dJ = np.empty_like(F)
    for k in range(2):
        for l in range(2):
            dF = np.zeros_like(F)
            dF[k, l] = H
            dJ[k, l] = (det2(F + dF) - det2(F - dF)) / (2 * H)
    np.testing.assert_allclose(cofactor(F), dJ, atol=1e-8)


# --- rest state, frame indifference, small-strain limit -----------------------------

@_table(ALL)
def test_rest_state_is_energy_and_stress_free(make):
    m = make()
    I = np.broadcast_to(np.eye(2)[:, :, None, None], (2, 2, NEL, NQP))
    np.testing.assert_allclose(m.energy(I), 0.0, atol=1e-14)
    np.testing.assert_allclose(m.stress(I), 0.0, atol=1e-14)


@_table(_frame_indifferent(ALL))
def test_frame_indifference(make):
    m = make()
    F = random_F("positive", seed=8)
    Q = _rotation(_rng(9).uniform(-np.pi, np.pi, F.shape[2:]))
    QF = _matmul(Q, F)
    np.testing.assert_allclose(m.energy(QF), m.energy(F), rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(m.stress(QF), _matmul(Q, m.stress(F)), rtol=1e-11, atol=1e-11)
    # A(QF)_ijkl = Q_ia Q_kb A(F)_ajbl
    QAQ = np.einsum("ia...,kb...,ajbl...->ijkl...", Q, Q, m.tangent(F))
    np.testing.assert_allclose(m.tangent(QF), QAQ, rtol=1e-11, atol=1e-11)


@_table(_frame_indifferent(ALL))
def test_pure_rotation_is_stress_free(make):
    m = make()
    R = _rotation(np.linspace(-3.0, 3.0, NEL * NQP).reshape(NEL, NQP))
    np.testing.assert_allclose(m.energy(R), 0.0, atol=1e-12)
    np.testing.assert_allclose(m.stress(R), 0.0, atol=1e-12)


def test_linear_elasticity_is_not_frame_indifferent():
    R = _rotation(0.5)
    linear, neo = LinearElastic(LAM, MU), NeoHookean(LAM, MU)
    # eps = sym(R) - I = (cos 0.5 - 1) I != 0: a rigid rotation "strains" the linear model
    assert np.abs(linear.stress(R)).max() > 0.1
    assert linear.energy(R) > 1e-3
    np.testing.assert_allclose(neo.stress(R), 0.0, atol=1e-14)
    np.testing.assert_allclose(neo.energy(R), 0.0, atol=1e-14)


def test_notes_energy_slip_FijFji_is_not_frame_indifferent():
    """The notes print mu/2 (F_ij F_ji - 2); the correct energy has F_ij F_ij."""

    def energy_notes(F):  # F_ij F_ji = tr(F F)
        lnJ = np.log(det2(F))
        return 0.5 * MU * (np.einsum("ij...,ji...->...", F, F) - 2.0) - MU * lnJ + 0.5 * LAM * lnJ**2

    neo = NeoHookean(LAM, MU)
    thetas = np.array([0.0, 0.3, 1.0, 2.0])
    R = _rotation(thetas)
    # tr(R R) = 2 cos(2 theta): the printed energy changes under a pure rotation
    np.testing.assert_allclose(energy_notes(R), MU * (np.cos(2 * thetas) - 1.0), atol=1e-14)
    assert np.abs(energy_notes(R)[1:]).min() > 0.05
    np.testing.assert_allclose(neo.energy(R), 0.0, atol=1e-14)
    # and the printed stress mu F + (lam ln J - mu) F^-T is the derivative of F_ij F_ij, not of F_ij F_ji
    F = random_F("positive", seed=10)

    class Notes(Material):
        def energy(self, F):
            return energy_notes(F)

    P_printed = MU * F + (LAM * np.log(det2(F)) - MU) * inverse(F).swapaxes(0, 1)
    np.testing.assert_allclose(neo.stress(F), P_printed, atol=1e-12)
    assert np.abs(fd_stress(Notes(LAM, MU), F) - P_printed).max() > 0.1


def test_notes_taylor_matrix_slip_adjugate_is_not_dJdF():
    """The notes print [[F22, -F12], [-F21, F11]] (the adjugate); dJ/dF is its transpose."""
    F = np.array([[1.1, 0.4], [-0.3, 0.9]])
    adjugate = np.array([[F[1, 1], -F[0, 1]], [-F[1, 0], F[0, 0]]])
    m = TaylorNeoHookean(LAM, MU)
    fd = fd_stress(m, F)
    np.testing.assert_allclose(m.stress(F), fd, rtol=1e-8)
    J = det2(F)
    printed = MU * F + (LAM * taylor_log(J) - MU) * taylor_log_prime(J) * adjugate
    assert np.abs(printed - fd).max() > 0.1


def linear_tangent(lam, mu):
    d = np.eye(2)
    return (
        lam * np.einsum("ij,kl->ijkl", d, d)
        + mu * (np.einsum("ik,jl->ijkl", d, d) + np.einsum("il,jk->ijkl", d, d))
    )


@pytest.mark.parametrize("cls", list(MATERIALS.values()), ids=list(MATERIALS))
@pytest.mark.parametrize(
    "lam_mu", [(LAM, MU), lame_parameters(1000.0, 0.45), (-0.3, 1.0)], ids=["generic", "E1000-nu0.45", "auxetic"]
)
def test_small_strain_limit_is_linear_elasticity(cls, lam_mu):
    lam, mu = lam_mu
    m = cls(lam, mu)
    scale = abs(lam) + mu
    np.testing.assert_allclose(m.tangent(np.eye(2)), linear_tangent(lam, mu), rtol=0, atol=1e-13 * scale)
    # and the stress at a tiny strain is the linear-elastic one, up to O(|grad u|^2)
    G = 1e-6 * np.array([[0.3, -0.7], [0.2, 0.5]])
    P_lin = LinearElastic(lam, mu).stress(np.eye(2) + G)
    np.testing.assert_allclose(m.stress(np.eye(2) + G), P_lin, rtol=0, atol=1e-5 * np.abs(P_lin).max())


def test_stable_neo_hookean_parameters():
    m = StableNeoHookean(LAM, MU)
    assert m.lam_s == pytest.approx(LAM + MU)
    assert m.alpha == pytest.approx(1.0 + MU / (LAM + MU))
    assert m.energy(np.eye(2)) == pytest.approx(0.0, abs=1e-15)


# --- inversion behaviour ---------------------------------------------------------

def test_neo_hookean_is_nan_without_warnings_when_inverted():
    m = NeoHookean(LAM, MU)
    singular = [[[1.0, 2.0], [2.0, 4.0]], [[0.0, 0.0], [0.0, 0.0]], [[1.0, 0.0], [0.0, 0.0]], [[0.0, 3.0], [0.0, 1.0]]]
    F = np.concatenate(
        [random_F("positive", 11, (4,)), random_F("inverted", 12, (4,)), np.moveaxis(np.array(singular), 0, -1)],
        axis=2,
    )
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        psi, P, A = m.energy(F), m.stress(F), m.tangent(F)
    bad = det2(F) <= 0
    assert bad.sum() == 8
    assert np.all(np.isnan(psi[bad])) and np.all(np.isfinite(psi[~bad]))
    assert np.all(np.isnan(P[:, :, bad])) and np.all(np.isfinite(P[:, :, ~bad]))
    assert np.all(np.isnan(A[..., bad])) and np.all(np.isfinite(A[..., ~bad]))
    assert not m.inversion_safe


@_table(_safe(ALL))
def test_inversion_safe_models_are_finite_when_inverted(make):
    m = make()
    for kind in ("inverted", "singular"):
        F = random_F(kind, seed=14)
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            assert np.all(np.isfinite(m.energy(F)))
            assert np.all(np.isfinite(m.stress(F)))
            assert np.all(np.isfinite(m.tangent(F)))


def test_corotated_at_undefined_rotation_is_finite():
    # F00 + F11 = F10 - F01 = 0: symmetric and traceless, the polar rotation is undefined
    F = np.array([[0.7, 0.2], [0.2, -0.7]])
    m = Corotated(LAM, MU)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        psi, P, A = m.energy(F), m.stress(F), m.tangent(F)
    assert np.isfinite(psi) and np.all(np.isfinite(P)) and np.all(np.isfinite(A))
    # R = I there: P = 2 mu (F - I) + lam (J - 1) cof F
    np.testing.assert_allclose(P, 2 * MU * (F - np.eye(2)) + LAM * (det2(F) - 1) * cofactor(F))
    # the energy stays continuous through that point
    eps = 1e-9 * np.array([[1.0, 0.0], [0.0, 1.0]])
    assert m.energy(F + eps) == pytest.approx(psi, abs=1e-7)


def test_inversion_safe_flags():
    assert [cls.inversion_safe for cls in MATERIALS.values()] == [True, False, True, True, True]


# --- the fibre term -----------------------------------------------------------------

@pytest.mark.parametrize("base_cls", list(MATERIALS.values()), ids=list(MATERIALS))
@pytest.mark.parametrize("t", [0.0, 0.4, 1.3, -2.2])
def test_fiber_modulus_is_the_extra_tangent_along_the_fiber(base_cls, t):
    base = base_cls(LAM, MU)
    g = np.array([np.cos(t), np.sin(t)])
    m = FiberReinforced(base, K_FIBER, 3.0 * g)  # not unit: normalised on input
    dA = m.tangent(np.eye(2)) - base.tangent(np.eye(2))
    assert np.einsum("ijkl,i,j,k,l->", dA, g, g, g, g) == pytest.approx(K_FIBER)
    assert m.stiffness == K_FIBER
    # the whole extra tangent at rest is k g(x)g(x)g(x)g: nothing across the fibre
    np.testing.assert_allclose(dA, K_FIBER * np.einsum("i,j,k,l->ijkl", g, g, g, g), atol=1e-13)


def test_fiber_uniaxial_stretch_energy():
    g = np.array([0.6, 0.8])
    m = FiberReinforced(NeoHookean(LAM, MU), K_FIBER, g)
    stretch = 1.3
    F = np.eye(2) + (stretch - 1.0) * np.outer(g, g)  # stretch along g, identity across
    assert m.energy(F) - m.base.energy(F) == pytest.approx(K_FIBER / 8.0 * (stretch**2 - 1.0) ** 2)
    # compressing across the fibre costs nothing extra
    n = np.array([-0.8, 0.6])
    F = np.eye(2) + (0.7 - 1.0) * np.outer(n, n)
    assert m.energy(F) - m.base.energy(F) == pytest.approx(0.0, abs=1e-15)


def test_fiber_attributes_follow_base():
    for name, cls in MATERIALS.items():
        base = cls(LAM, MU)
        m = FiberReinforced(base, 1.0, [1.0, 0.0])
        assert (m.lam, m.mu, m.inversion_safe) == (base.lam, base.mu, base.inversion_safe)
        assert m.name == f"{base.name} + fibers"
    assert FiberReinforced(NeoHookean(LAM, MU), 1.0, [1, 0]).name == "neo-Hookean + fibers"


def test_fiber_from_young():
    m = FiberReinforced.from_young(1000.0, 0.3, stiffness=50.0, fibers=[0.0, 2.0], base="corotated")
    assert isinstance(m.base, Corotated)
    assert (m.lam, m.mu) == lame_parameters(1000.0, 0.3)
    np.testing.assert_allclose(m.fibers, [0.0, 1.0])


def test_fiber_broadcasting_per_element_and_per_point():
    base = NeoHookean(LAM, MU)
    F = random_F("positive", seed=15)
    g_el = _fibers((NEL,), seed=16)
    g_pt = _fibers((NEL, NQP), seed=17)
    per_el = FiberReinforced(base, K_FIBER, g_el)
    per_pt = FiberReinforced(base, K_FIBER, g_pt)
    # a per-element field is the per-point field repeated over the points
    same = FiberReinforced(base, K_FIBER, np.repeat(g_el[:, :, None], NQP, axis=2))
    for method in ("energy", "stress", "tangent"):
        np.testing.assert_allclose(getattr(per_el, method)(F), getattr(same, method)(F), rtol=1e-14)
    # and each entry is what a uniform fibre gives at that element / point
    for e in (0, 7, NEL - 1):
        uniform = FiberReinforced(base, K_FIBER, g_el[:, e])
        np.testing.assert_allclose(per_el.stress(F)[:, :, e], uniform.stress(F[:, :, e]), rtol=1e-13)
        for q in range(NQP):
            uniform = FiberReinforced(base, K_FIBER, g_pt[:, e, q])
            Fq = F[:, :, e, q]
            np.testing.assert_allclose(per_pt.tangent(F)[..., e, q], uniform.tangent(Fq), rtol=1e-13)
            assert per_pt.energy(F)[e, q] == pytest.approx(uniform.energy(Fq), rel=1e-13)


@pytest.mark.parametrize(
    "fibers",
    [
        [np.nan, 1.0],
        [np.inf, 0.0],
        [0.0, 0.0],
        np.zeros((2, 4)),
        [1.0, 0.0, 0.0, 0.0],
        np.ones((4, 4)),
        np.ones((2, 2, 2, 2)),
        "x",
    ],
)
def test_fiber_validation(fibers):
    with pytest.raises(ValueError, match="fibers"):
        FiberReinforced(NeoHookean(LAM, MU), 1.0, fibers)


@pytest.mark.parametrize("fibers, dim", [([1.0, 0.0, 0.0], 2), (np.ones((3, NEL)), 2), ([1.0, 0.0], 3)])
def test_fibers_of_another_dimension_than_F_are_refused_naming_fibers(fibers, dim):
    m = FiberReinforced(NeoHookean(LAM, MU), 1.0, fibers)  # 2D and 3D fibres are both fibres
    F = np.broadcast_to(np.eye(dim)[:, :, None, None], (dim, dim, NEL, NQP))
    for what in ("energy", "stress", "tangent"):
        with pytest.raises(ValueError, match="fibers"):
            getattr(m, what)(F)


@pytest.mark.parametrize("stiffness", [-1.0, np.nan, np.inf, "stiff"])
def test_fiber_stiffness_validation(stiffness):
    with pytest.raises(ValueError, match="stiffness"):
        FiberReinforced(NeoHookean(LAM, MU), stiffness, [1.0, 0.0])


def test_fiber_base_validation():
    with pytest.raises(ValueError, match="base"):
        FiberReinforced(NeoHookean, 1.0, [1.0, 0.0])


@pytest.mark.parametrize("rest", [(), (NEL + 1, NQP), (NEL, NQP + 1)])
def test_fiber_shape_mismatch_at_evaluation(rest):
    m = FiberReinforced(NeoHookean(LAM, MU), 1.0, _fibers((NEL, NQP)))
    with pytest.raises(ValueError, match="fibers"):
        m.stress(random_F("positive", shape=rest))


# --- construction and validation ------------------------------------------------------

YOUNG, POISSON = r"E \(Young's modulus\)", r"nu \(Poisson's ratio\)"
SHEAR, FIRST_LAME = r"mu \(shear modulus\)", r"lam \(first Lamé parameter\)"


@pytest.mark.parametrize("cls", list(MATERIALS.values()), ids=list(MATERIALS))
def test_from_young_matches_lame(cls):
    m = cls.from_young(1000.0, 0.3)
    assert (m.lam, m.mu) == lame_parameters(1000.0, 0.3)
    assert isinstance(m.name, str) and m.name


@pytest.mark.parametrize("cls", list(MATERIALS.values()), ids=list(MATERIALS))
@pytest.mark.parametrize(
    "E, nu, match",
    [
        (0.0, 0.3, YOUNG),
        (-5.0, 0.3, YOUNG),
        (np.nan, 0.3, YOUNG),
        (1000.0, 0.5, POISSON),
        (1000.0, -1.0, POISSON),
        (1000.0, np.nan, POISSON),
    ],
)
def test_from_young_validation(cls, E, nu, match):
    with pytest.raises(ValueError, match=match):
        cls.from_young(E, nu)


@pytest.mark.parametrize("cls", [c for c in MATERIALS.values() if c is not LinearElastic])
def test_plane_stress_only_for_linear(cls):
    with pytest.raises(ValueError, match="plane"):
        cls.from_young(1000.0, 0.3, plane="stress")


def test_linear_plane_stress():
    m = LinearElastic.from_young(1000.0, 0.3, plane="stress")
    assert (m.lam, m.mu) == lame_parameters(1000.0, 0.3, plane="stress")
    with pytest.raises(ValueError, match="plane"):
        LinearElastic.from_young(1000.0, 0.3, plane="membrane")


@pytest.mark.parametrize(
    "lam, mu, match",
    [(1.0, 0.0, SHEAR), (1.0, -1.0, SHEAR), (-1.0, 1.0, FIRST_LAME), (np.nan, 1.0, FIRST_LAME)],
)
def test_lame_validation(lam, mu, match):
    for cls in MATERIALS.values():
        with pytest.raises(ValueError, match=match):
            cls(lam, mu)


def test_registry():
    assert MATERIALS == {
        "linear": LinearElastic,
        "neo-hookean": NeoHookean,
        "taylor-neo-hookean": TaylorNeoHookean,
        "stable-neo-hookean": StableNeoHookean,
        "corotated": Corotated,
    }
    m = material("stable-neo-hookean", 1000.0, 0.45)
    assert isinstance(m, StableNeoHookean) and (m.lam, m.mu) == lame_parameters(1000.0, 0.45)
    with pytest.raises(ValueError, match="name must be one of .*corotated.*neo-hookean"):
        material("mooney-rivlin", 1000.0, 0.3)
    with pytest.raises(ValueError, match=POISSON):
        material("corotated", 1000.0, 0.5)
