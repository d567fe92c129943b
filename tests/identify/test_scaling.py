"""Mass normalisation through a driving point, against scipy.linalg.eigh of a 3-DOF system."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.linalg import eigh

from truthbench.identify import identify_plscf, mac, mass_normalize_shapes, modal_scale_factor

M = np.diag([2.0, 1.0, 1.5])
K = np.array([[1800.0, -800.0, 0.0], [-800.0, 1400.0, -600.0], [0.0, -600.0, 1000.0]])
C = 0.4 * M + 2e-4 * K  # proportional: real modes
INPUTS = [0, 2]  # force at DOF 0 and DOF 2; outputs are all three DOFs


def exact_modes():
    w2, phi = eigh(K, M)  # phi^T M phi = I
    return np.sqrt(w2), phi


def exact_frf(f_hz, q=0):
    """H(w) = (K - w^2 M + j w C)^-1 (direct inversion, not a modal sum), times (jw)^q."""
    H = np.empty((f_hz.size, 3, len(INPUTS)), complex)
    for k, f in enumerate(f_hz):
        w = 2 * np.pi * f
        H[k] = np.linalg.inv(K - w**2 * M + 1j * w * C)[:, INPUTS] * (1j * w) ** q
    return H


def aligned_error(est, ref):
    est = np.real_if_close(est, tol=1e6)
    est = est * modal_scale_factor(ref, est)[None, :] / np.abs(modal_scale_factor(ref, est))
    return np.max(np.abs(est - ref)) / np.max(np.abs(ref))


@pytest.mark.parametrize("q", [0, 1, 2])
def test_identified_shapes_are_mass_normalised(q):
    wn, phi = exact_modes()
    f = np.arange(0.02, 1.6 * wn.max() / (2 * np.pi), 0.02)
    frf_type = ["displacement", "velocity", "acceleration"][q]
    res = identify_plscf(f, exact_frf(f, q), max_order=20, frf_type=frf_type)
    assert res.modal.n_modes == 3
    np.testing.assert_allclose(2 * np.pi * res.modal.freq_hz, wn, rtol=1e-6)
    for k, out in ((0, 0), (1, 2)):  # input 0 at DOF 0, input 1 at DOF 2
        phi_id = mass_normalize_shapes(
            res.lsfd.residues, res.lsfd.poles, out, input_index=k, frf_type=frf_type
        )
        assert np.max(np.abs(phi_id.imag)) < 1e-6 * np.max(np.abs(phi_id))
        # unit modal mass, hence phi^T M phi = I
        np.testing.assert_allclose(phi_id.real.T @ M @ phi_id.real, np.eye(3), atol=1e-5)
        assert aligned_error(phi_id, phi) < 1e-6


def test_exact_residues_give_exact_shapes_and_sign_convention():
    wn, phi = exact_modes()
    zeta = 0.5 * (0.4 / wn + 2e-4 * wn)
    lam = -zeta * wn + 1j * wn * np.sqrt(1 - zeta**2)
    R = np.einsum("pr,qr->rpq", phi, phi[INPUTS]) / (2j * lam.imag)[:, None, None]
    out = mass_normalize_shapes(R * (lam**2)[:, None, None], lam, 0, frf_type="acceleration")
    # principal square root: the driving-point entry is positive
    assert np.all(out[0].real > 0)
    np.testing.assert_allclose(out.real, phi * np.sign(phi[0]), rtol=1e-12, atol=1e-14)
    # conjugate poles are accepted too
    out2 = mass_normalize_shapes(R, np.conj(lam), 0)
    np.testing.assert_allclose(out2, out, rtol=1e-12)


def test_no_collocated_pair_warns_and_returns_unscaled_shapes():
    wn, phi = exact_modes()
    lam = 1j * wn - 0.01 * wn
    R = np.einsum("pr,qr->rpq", phi, phi[INPUTS]) / (2j * lam.imag)[:, None, None]
    with pytest.warns(UserWarning, match="no output is collocated with input 1"):
        out = mass_normalize_shapes(R, lam, None, input_index=1)
    assert np.allclose(np.max(np.abs(out), axis=0), 1.0)
    assert np.all(np.diag(mac(out, phi)) > 1 - 1e-12)


def test_node_at_the_driving_point_gives_nan_with_warning():
    phi = np.array([[1.0, 0.0], [0.5, 1.0]])
    lam = np.array([-0.1 + 10j, -0.2 + 20j])
    R = np.einsum("pr,qr->rpq", phi, phi[[0]]) / (2j * lam.imag)[:, None, None]
    with pytest.warns(UserWarning, match="zero for modes \\[1\\]"):
        out = mass_normalize_shapes(R, lam, 0)
    assert np.all(np.isnan(out[:, 1])) and np.all(np.isfinite(out[:, 0]))


def test_bad_inputs():
    R = np.ones((2, 3, 1), complex)
    lam = np.array([-1 + 10j, -1 + 20j])
    with pytest.raises(ValueError, match="'residues' parameter must have shape"):
        mass_normalize_shapes(R[0], lam, 0)
    with pytest.raises(ValueError, match="'poles' parameter must have shape \\(2,\\)"):
        mass_normalize_shapes(R, lam[:1], 0)
    with pytest.raises(ValueError, match="'collocated_output' parameter must be an integer"):
        mass_normalize_shapes(R, lam, 5)
    with pytest.raises(ValueError, match="'input_index' .* integer in \\[0, 0\\]"):
        mass_normalize_shapes(R, lam, 0, input_index=1)
    with pytest.raises(ValueError, match="'frf_type' parameter must be one of"):
        mass_normalize_shapes(R, lam, 0, frf_type="accelerance")
