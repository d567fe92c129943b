"""Frequency-domain uncertainty: T synthetic FRFs = true FRF + known complex noise."""

import numpy as np
import pytest
from scipy import stats

from truthbench.uncertainty import (
    FrfUncertainty,
    coverage_fraction,
    expected_frf_coverage,
    frf_uncertainty,
)

T = 10
N_FREQ = 3000


def _true_frf():
    f = np.linspace(1.0, 30.0, N_FREQ)
    w, wn, z = 2 * np.pi * f, 2 * np.pi * 12.0, 0.02
    H = 1.0 / (wn**2 - w**2 + 2j * z * wn * w)  # m/N, one SISO pair
    return f, H[:, None, None]


def _noise_cov(H):
    # correlated real/imaginary noise, 5 % and 3 % of |H|, correlation 0.6
    a = np.abs(H)
    s1, s2, rho = 0.05 * a, 0.03 * a, 0.6
    return s1, s2, rho


def _draw(H, n, rng):
    s1, s2, rho = _noise_cov(H)
    e1 = rng.standard_normal((n,) + H.shape)
    e2 = rng.standard_normal((n,) + H.shape)
    re = s1 * e1
    im = s2 * (rho * e1 + np.sqrt(1 - rho**2) * e2)
    return H + re + 1j * im


def test_mean_and_covariance_recover_the_truth():
    rng = np.random.default_rng(2)
    f, H = _true_frf()
    est = frf_uncertainty(_draw(H, T, rng), freq_hz=f)
    s1, s2, rho = _noise_cov(H)
    # standardised mean error: N(0, 1) per line for real and imaginary parts
    zr = (est.mean - H).real / (s1 / np.sqrt(T))
    assert abs(zr.mean()) < 4 / np.sqrt(N_FREQ)
    assert zr.std() == pytest.approx(1.0, abs=0.05)
    # variance ratios: E[s^2/sigma^2] = 1, sd sqrt(2/(T-1)) per line, averaged over lines
    tol = 4 * np.sqrt(2 / (T - 1)) / np.sqrt(N_FREQ)
    assert np.mean(est.std_real**2 / s1**2) == pytest.approx(1.0, abs=tol)
    assert np.mean(est.std_imag**2 / s2**2) == pytest.approx(1.0, abs=tol)
    assert np.mean(est.cov[..., 0, 1] / (s1 * s2)) == pytest.approx(rho, abs=0.05)
    # linearised magnitude and phase std (true covariance) against a direct simulation
    k = int(np.argmax(np.abs(H[:, 0, 0])))
    a, b = s1[k, 0, 0], s2[k, 0, 0]
    cov_true = np.array([[a**2, rho * a * b], [rho * a * b, b**2]])
    exact = FrfUncertainty(mean=H[k:k + 1], cov=cov_true[None, None, None], n_tests=T)
    sims = _draw(H[k:k + 1], 100000, rng)
    assert exact.std_magnitude[0, 0, 0] == pytest.approx(np.abs(sims).std(), rel=0.02)
    assert exact.std_phase_rad[0, 0, 0] == pytest.approx(np.angle(sims / H[k]).std(), rel=0.02)
    df = est.to_pandas()
    assert len(df) == N_FREQ and "freq_hz" in df.columns


def test_bound_contains_the_expected_fraction_of_new_estimates():
    rng = np.random.default_rng(4)
    f, H = _true_frf()
    est = frf_uncertainty(_draw(H, T, rng), freq_hz=f, k_sigma=3.0)
    new = _draw(H, 1, rng)[0]  # one new estimate: independent events line by line
    cov = coverage_fraction(est.contains(new))
    expect = expected_frf_coverage(3.0, T)  # Hotelling T^2 (F distribution)
    assert cov.agrees_with(expect), (cov, expect)
    assert cov.ci_high < expected_frf_coverage(3.0)  # known-covariance 0.9889 is too high
    assert est.fraction_inside(new) == cov.fraction
    # the ellipse algebra: 2 sigma along the real axis
    d2 = est.mahalanobis2(est.mean + (est.std_real * 2.0))  # 2 sigma along real axis
    s11, s22, s12 = est.cov[..., 0, 0], est.cov[..., 1, 1], est.cov[..., 0, 1]
    np.testing.assert_allclose(d2, 4.0 * s11 * s22 / (s11 * s22 - s12**2), rtol=1e-10)


def test_expected_frf_coverage_values():
    assert expected_frf_coverage(3.0) == pytest.approx(1 - np.exp(-4.5), rel=1e-12)
    assert expected_frf_coverage(3.0) == pytest.approx(stats.chi2.cdf(9.0, 2), rel=1e-12)
    # large T tends to the known-covariance value
    assert expected_frf_coverage(3.0, 10**6) == pytest.approx(expected_frf_coverage(3.0),
                                                              abs=1e-4)


def test_degenerate_lines_and_errors():
    H = np.ones((4, 3, 1, 1), dtype=complex)
    H[:, 1] += np.array([1, 2, 3, 4])[:, None, None]  # real-only scatter at line 1
    est = frf_uncertainty(H)
    inside = est.contains(np.array([1, 3.5, 1 + 1e-9j])[:, None, None])
    assert inside[0, 0, 0] and inside[1, 0, 0] and not inside[2, 0, 0]
    with pytest.raises(ValueError, match="at least 3 tests"):
        frf_uncertainty(H[:2])
    with pytest.raises(ValueError, match="'H_tests'.*shape"):
        frf_uncertainty(np.ones((4, 3, 2)))
    bad = H.copy()
    bad[0, 0] = np.nan
    with pytest.raises(ValueError, match="finite"):
        frf_uncertainty(bad)
    with pytest.raises(ValueError, match="'freq_hz'"):
        frf_uncertainty(H, freq_hz=[1.0, 2.0])
    with pytest.raises(ValueError, match="'H'.*FRF shape"):
        est.contains(np.ones((2, 1, 1)))
    with pytest.raises(ValueError, match="'n_tests'"):
        expected_frf_coverage(3.0, 2)
