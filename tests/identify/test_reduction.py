"""Guyan reduction and least-squares expansion against hand-condensed spring-mass chains."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.linalg import eigh

from truthbench.identify import expand_shapes, guyan_reduction


def chain(k, m):
    """Fixed-free spring-mass chain: ground -k0- m0 -k1- m1 -k2- m2 ..."""
    n = len(m)
    K = np.zeros((n, n))
    for i, ki in enumerate(k):
        K[i, i] += ki
        if i > 0:
            K[i - 1, i - 1] += ki
            K[i - 1, i] -= ki
            K[i, i - 1] -= ki
    return np.diag(m).astype(float), K


def test_guyan_on_a_three_mass_chain_matches_hand_condensation():
    k1, k2, k3 = 1000.0, 300.0, 700.0
    m1, m2, m3 = 2.0, 1.5, 1.0
    M, K = chain([k1, k2, k3], [m1, m2, m3])
    red = guyan_reduction(M, K, [0, 2])
    # the unloaded middle node sits where the two springs balance
    a, b = k2 / (k2 + k3), k3 / (k2 + k3)
    np.testing.assert_allclose(red.transformation, [[1, 0], [a, b], [0, 1]], rtol=1e-14)
    ks = k2 * k3 / (k2 + k3)  # springs in series
    np.testing.assert_allclose(red.stiffness, [[k1 + ks, -ks], [-ks, ks]], rtol=1e-13)
    np.testing.assert_allclose(
        red.mass, np.diag([m1, m3]) + m2 * np.outer([a, b], [a, b]), rtol=1e-13
    )
    assert red.active.tolist() == [0, 2] and red.dependent.tolist() == [1]
    np.testing.assert_allclose(red.expand([1.0, 2.0]), [1.0, a + 2 * b, 2.0])


def test_guyan_is_exact_for_static_response_and_upper_bounds_frequencies():
    M, K = chain([500.0, 400.0, 300.0, 200.0, 100.0], [1.0, 2.0, 1.0, 3.0, 1.0])
    active = [4, 1]  # order of the reduced coordinates follows 'active'
    red = guyan_reduction(M, K, active)
    flex = np.linalg.inv(K)[np.ix_(active, active)]
    np.testing.assert_allclose(np.linalg.inv(red.stiffness), flex, rtol=1e-12)
    w_full = np.sqrt(eigh(K, M, eigvals_only=True))
    w_red = np.sqrt(eigh(red.stiffness, red.mass, eigvals_only=True))
    assert np.all(w_red >= w_full[:2] * (1 - 1e-12))  # Rayleigh-Ritz upper bounds
    # all DOFs active: nothing changes
    full = guyan_reduction(M, K, np.ones(5, dtype=bool))
    np.testing.assert_allclose(full.stiffness, K)
    np.testing.assert_allclose(full.mass, M)


def test_expansion_reproduces_a_shape_in_the_model_basis():
    M, K = chain([5.0, 4.0, 3.0, 2.0, 1.5, 1.0], [1.0] * 6)
    _, phi = eigh(K, M)
    basis = phi[:, :3]
    c = np.array([[0.7, 0.0], [-0.2, 1.0], [0.1, 0.3]])
    truth = basis @ c
    active = [0, 2, 5]
    out = expand_shapes(basis, truth[active], active)
    np.testing.assert_allclose(out.expanded, truth, atol=1e-12)
    np.testing.assert_allclose(out.coefficients, c, atol=1e-12)
    # a shape outside the basis is smoothed into it (least squares on the active DOFs)
    noisy = truth[active] + 0.01 * np.array([[1.0, -1.0], [0.5, 0.2], [-0.3, 0.4]])
    out2 = expand_shapes(basis[:, :2], noisy, active)
    resid = noisy - basis[active, :2] @ out2.coefficients
    assert np.allclose(basis[active, :2].T @ resid, 0.0, atol=1e-12)


def test_bad_inputs():
    M, K = chain([1.0, 1.0, 1.0], [1.0, 1.0, 1.0])
    with pytest.raises(ValueError, match="'mass' and 'stiffness' parameters must have the same"):
        guyan_reduction(M[:2, :2], K, [0])
    with pytest.raises(ValueError, match="'stiffness' parameter must be a square matrix"):
        guyan_reduction(M, K[:2], [0])
    with pytest.raises(ValueError, match="'active' parameter must index DOFs in \\[0, 2\\]"):
        guyan_reduction(M, K, [0, 3])
    with pytest.raises(ValueError, match="'active' parameter repeats a DOF"):
        guyan_reduction(M, K, [0, 0])
    K_sing = K.copy()
    K_sing[1:, 1:] = 0.0  # the dependent DOFs {1, 2} are not restrained by themselves
    with pytest.raises(ValueError, match="K_DD .* is singular"):
        guyan_reduction(M, K_sing, [0])
    with pytest.raises(ValueError, match="'phi_measured' parameter has 2 rows but 'active'"):
        expand_shapes(np.eye(3), np.ones((2, 1)), [0, 1, 2])
