"""The fibre functions take one direction ``(2,)`` for a whole field of deformation gradients, or a field of
directions: the tangent is the derivative of the stress (central differences) in both cases."""

import numpy as np
import pytest

from tissuefem.engine.materials import fiber_energy, fiber_stress, fiber_tangent

K = 3.0
REST = (3, 4)


def _gradients(seed):
    rng = np.random.default_rng(seed)
    return np.eye(2)[:, :, None, None] + 0.2 * rng.standard_normal((2, 2) + REST)


def _directions(shape, seed):
    angle = np.random.default_rng(seed).uniform(0.0, 2.0 * np.pi, shape)
    return np.array([np.cos(angle), np.sin(angle)])


def _difference_tangent(F, g, h=1e-6):
    """``dP_ij / dF_kl`` by central differences of :func:`fiber_stress`, shaped like the tangent."""
    out = np.empty((2, 2, 2, 2) + F.shape[2:])
    for k in range(2):
        for m in range(2):
            step = np.zeros_like(F)
            step[k, m] = h
            out[:, :, k, m] = (fiber_stress(F + step, g, K) - fiber_stress(F - step, g, K)) / (2.0 * h)
    return out


@pytest.mark.parametrize("g", [np.array([0.6, 0.8]), _directions(REST, 1), _directions(REST[1:], 2)],
                         ids=["one direction", "a field", "a field along the last axis"])
def test_the_tangent_is_the_derivative_of_the_stress(g):
    F = _gradients(0)
    A = fiber_tangent(F, g, K)
    assert A.shape == (2, 2, 2, 2) + REST
    assert fiber_stress(F, g, K).shape == (2, 2) + REST and fiber_energy(F, g, K).shape == REST
    np.testing.assert_allclose(A, _difference_tangent(F, g), rtol=1e-6, atol=1e-7)


def test_one_direction_is_the_field_of_that_direction_repeated():
    F, g = _gradients(3), np.array([0.0, 1.0])
    field = np.broadcast_to(g[:, None, None], (2,) + REST)
    np.testing.assert_array_equal(fiber_tangent(F, g, K), fiber_tangent(F, field, K))
    np.testing.assert_array_equal(fiber_tangent(F[:, :, 1, 2], g, K), fiber_tangent(F, g, K)[..., 1, 2])
