"""The expected H1 of a windowed, averaged estimate against a Monte Carlo of the estimate.

A single-DOF system driven by periodic band-limited random force (the campaigns'
excitation) through its exact steady state: the mean over many records of the estimated
cross-spectrum over the mean auto-spectrum is what :func:`expected_h1` predicts. The
tolerance is statistical: 5 standard errors of the Monte Carlo ratio (delta method over
the records; a complex deviation beyond 5 of them has probability exp(-25) per line),
at every line near the resonance; the same test requires the leakage bias
itself to be far outside that band, so it can fail.
"""

import numpy as np
import pytest

from truthbench.measure import spectral_matrices
from truthbench.measure.leakage import Estimator, expected_h1, h1_kernel
from truthbench.simulate import band_limited_random

FS, N, A = 1024.0, 16384, 4
FN, ZETA = 47.0, 0.005
BAND = (2.0, 400.0)


def sdof(f):
    s = 2j * np.pi * np.asarray(f, dtype=float)
    w = 2 * np.pi * FN
    return (1.0 / (s * s + 2 * ZETA * w * s + w * w))[:, None, None]


@pytest.mark.parametrize("window", ["bartlett", "hann"])
def test_expected_h1_matches_the_monte_carlo_mean(window):
    f_rec = np.fft.rfftfreq(N, 1 / FS)
    h_rec = sdof(f_rec)[:, 0, 0]
    h_rec[0] = 0.0
    gyx, gxx = [], []
    for seed in range(300):
        u = band_limited_random(N, FS, 1.0, BAND, np.random.default_rng(seed))
        y = np.fft.irfft(h_rec * np.fft.rfft(u[0]), N)[None]
        s = spectral_matrices(u, y, FS, window=window, n_averages=A)
        gyx.append(s.Gyx[:, 0, 0])
        gxx.append(s.Gxx[:, 0, 0].real)
    gyx, gxx = np.array(gyx), np.array(gxx)
    f = s.freq_hz
    near = (f > FN - 8) & (f < FN + 8)
    ratio = gyx.mean(0) / gxx.mean(0)
    # standard error of the complex ratio: RMS of its linearised per-record deviations
    d = (gyx - ratio * gxx) / gxx.mean(0)
    se = np.sqrt(np.mean(np.abs(d) ** 2, axis=0) / len(gyx))
    kernel = h1_kernel(window, N // A, FS, period_samples=N)
    expected = expected_h1(f[near], sdof, kernel, BAND)[:, 0, 0]
    true = sdof(f[near])[:, 0, 0]
    assert np.all(np.abs(ratio[near] - expected) < 5 * se[near])
    assert np.max(np.abs(ratio[near] - true) / se[near]) > 10  # the bias is resolved


def test_kernel_is_normalised_symmetric_and_refuses_a_bad_period():
    k = h1_kernel("bartlett", 1024, 1000.0, period_samples=8192)
    assert k.lines_per_bin == 8 and k.delta_hz == pytest.approx(1000.0 / 8192)
    assert k.weights.sum() == pytest.approx(1.0, abs=1e-14)
    np.testing.assert_allclose(k.weights, k.weights[::-1], rtol=1e-12)
    with pytest.raises(ValueError, match="whole number of segments"):
        h1_kernel("bartlett", 1024, 1000.0, period_samples=5000)
    with pytest.raises(ValueError, match="not on the kernel's grid"):
        expected_h1([10.01], sdof, k)


def test_estimator_checks_its_fields_and_round_trips_as_a_dict():
    est = Estimator("bartlett", 64, 128, period_samples=256, averages=4, overlap_samples=0)
    assert Estimator(**est.to_dict()) == est and est.fs_hz == 128.0
    assert Estimator(**{k: v for k, v in est.to_dict().items()  # an older file's keys
                        if k not in ("averages", "overlap_samples")}).averages is None
    for bad, message in [({"segment_samples": 1}, "'segment_samples' must be an integer "
                                                  ">= 2"),
                         ({"fs_hz": 0.0}, "'fs_hz' must be a finite number > 0"),
                         ({"averages": 0}, "'averages' must be an integer >= 1"),
                         ({"overlap_samples": 64}, "'overlap_samples' must be an integer "
                                                   ">= 0 and < 64"),
                         ({"period_samples": 32}, "'period_samples' must be an integer "
                                                  ">= 64")]:
        with pytest.raises(ValueError, match=f"Estimator: {message}"):
            Estimator(**{**est.to_dict(), **bad})
    # averages and overlap do not move the expected estimate
    assert np.array_equal(est.kernel().weights,
                          Estimator("bartlett", 64, 128.0, 256).kernel().weights)
