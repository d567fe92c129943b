"""Excitation signals: exact RMS, band limits, spectra, statistics, errors.

Oracles: the definition of RMS, numpy's FFT (periodogram of the full periodic record:
out-of-band power is exactly zero up to rounding), scipy.signal.welch (Hann-windowed
estimate as a measurement would see it), scipy.stats for Gaussian moments.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.signal
import scipy.stats

from truthbench.simulate import band_limited_random, periodic_chirp, sine

FS = 1024.0
N = 2**15
BAND = (20.0, 200.0)
METHODS = ["gaussian", "random_phase"]


def _rms(x):
    return np.sqrt(np.mean(np.asarray(x) ** 2, axis=-1))


def _periodogram_fractions(x, fs, band):
    power = np.abs(np.fft.rfft(x, axis=-1)) ** 2
    freq = np.fft.rfftfreq(x.shape[-1], 1.0 / fs)
    inside = (freq >= band[0]) & (freq <= band[1])
    return power, inside, power[..., ~inside].sum(-1) / power.sum(-1)


@pytest.mark.parametrize("method", METHODS)
def test_rms_exact_and_shape(method):
    x = band_limited_random(N, FS, 2.5, BAND, np.random.default_rng(0), 3, method=method)
    assert x.shape == (3, N)
    np.testing.assert_allclose(_rms(x), 2.5, rtol=1e-12)
    y = band_limited_random(
        N, FS, [1.0, 0.0, 3.0], BAND, np.random.default_rng(0), 3, method=method
    )
    np.testing.assert_allclose(_rms(y), [1.0, 0.0, 3.0], rtol=1e-12, atol=0)


@pytest.mark.parametrize("method", METHODS)
def test_power_outside_band(method):
    x = band_limited_random(N, FS, 1.0, BAND, np.random.default_rng(1), 2, method=method)
    _, _, frac = _periodogram_fractions(x, FS, BAND)
    assert np.all(frac < 1e-20)  # exactly zero up to rounding on the DFT grid
    # a Hann-windowed Welch estimate (what a measurement sees) leaks only at the edges
    f, p = scipy.signal.welch(x, FS, nperseg=1024)
    outside = (f < BAND[0]) | (f > BAND[1])
    assert np.all(p[:, outside].sum(-1) / p.sum(-1) < 0.01)
    assert np.all(np.abs(x.mean(axis=-1)) < 1e-12)  # DC bin excluded


def test_random_phase_is_exactly_flat():
    x = band_limited_random(N, FS, 1.0, BAND, np.random.default_rng(2), method="random_phase")
    power, inside, _ = _periodogram_fractions(x[0], FS, BAND)
    np.testing.assert_allclose(power[inside], power[inside][0], rtol=1e-10)


def test_gaussian_spectrum_flat_and_amplitudes_gaussian():
    n_ch = 4
    x = band_limited_random(N, FS, 1.0, BAND, np.random.default_rng(3), n_ch)
    power, inside, _ = _periodogram_fractions(x, FS, BAND)
    p_in = power[:, inside]
    half = p_in.shape[1] // 2
    # each bin's power is exponential (relative std 1): means over ~2900 bins per half
    # have a relative std ~1.9 %; lower and upper halves of the band must agree to 10 %
    lo, hi = p_in[:, :half].mean(), p_in[:, half:].mean()
    assert abs(lo / hi - 1) < 0.1
    # Gaussian marginal: kurtosis 3 (std sqrt(24/N) ~ 0.027 per channel, 4 channels)
    kurt = scipy.stats.kurtosis(x, axis=1, fisher=False)
    assert np.all(np.abs(kurt - 3) < 0.15)
    assert np.all(np.abs(scipy.stats.skew(x, axis=1)) < 0.1)
    # channels independent: |correlation| ~ N(0, 1/N_eff), tiny
    corr = np.corrcoef(x)
    assert np.max(np.abs(corr - np.eye(n_ch))) < 0.05


def test_reproducible_and_seed_dependent():
    a = band_limited_random(1000, FS, 1.0, BAND, np.random.default_rng(7))
    b = band_limited_random(1000, FS, 1.0, BAND, np.random.default_rng(7))
    c = band_limited_random(1000, FS, 1.0, BAND, np.random.default_rng(8))
    np.testing.assert_array_equal(a, b)
    assert not np.allclose(a, c)


def test_band_including_dc_and_nyquist():
    for n in (4096, 4095):
        for method in METHODS:
            x = band_limited_random(
                n, FS, 1.0, (0.0, FS / 2), np.random.default_rng(4), method=method
            )
            np.testing.assert_allclose(_rms(x), 1.0, rtol=1e-12)
            assert np.all(np.isfinite(x))


def test_periodic_chirp():
    x = periodic_chirp(N, FS, 1.5, BAND)
    assert x.shape == (N,)
    np.testing.assert_allclose(_rms(x), 1.5, rtol=1e-12)
    power, inside, frac = _periodogram_fractions(x, FS, BAND)
    assert frac < 1e-20
    np.testing.assert_allclose(power[inside], power[inside][0], rtol=1e-10)
    # a sweep: the dominant frequency rises through the band over the record
    f, _, s = scipy.signal.spectrogram(x, FS, nperseg=1024)
    peak = f[np.argmax(s, axis=0)]
    assert np.all(np.diff(peak) >= 0)
    assert peak[0] < BAND[0] + 10 and peak[-1] > BAND[1] - 10
    # low crest factor (a Gaussian record of this length has ~4.5)
    assert np.max(np.abs(x)) / _rms(x) < 2.0


def test_sine():
    x = sine(1000, 1000.0, 50.0, amplitude=3.0, phase_rad=0.5)
    t = np.arange(1000) / 1000.0
    np.testing.assert_allclose(x, 3.0 * np.sin(2 * np.pi * 50.0 * t + 0.5), rtol=0, atol=1e-12)
    np.testing.assert_allclose(_rms(x), 3.0 / np.sqrt(2), rtol=1e-12)


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        (
            dict(band_hz=(20.0, 600.0)),
            ValueError,
            r"band_hz must satisfy 0 <= f_lo < f_hi <= fs_hz/2 = 512 Hz; got \(20.0, 600.0\)",
        ),
        (dict(band_hz=(200.0, 20.0)), ValueError, r"band_hz must satisfy"),
        (dict(band_hz=(-1.0, 20.0)), ValueError, r"band_hz must satisfy"),
        (dict(band_hz=20.0), ValueError, r"band_hz must be a pair \(f_lo, f_hi\)"),
        (dict(band_hz=(100.1, 100.2)), ValueError, r"contains no frequency bin"),
        (
            dict(rng=np.random.RandomState(0)),
            TypeError,
            r"rng must be a numpy.random.Generator .*; got RandomState instead",
        ),
        (dict(rng=0), TypeError, r"rng must be a numpy.random.Generator"),
        (dict(n_samples=1), ValueError, r"n_samples must be an integer >= 2; got 1"),
        (dict(n_samples=10.5), ValueError, r"n_samples must be an integer"),
        (dict(n_inputs=0), ValueError, r"n_inputs must be an integer >= 1; got 0"),
        (dict(fs_hz=0.0), ValueError, r"fs_hz must be a positive finite number in Hz"),
        (dict(rms=-1.0), ValueError, r"rms must be finite and >= 0"),
        (dict(rms=[1.0, 2.0]), ValueError, r"rms must be a scalar or have shape \(1,\)"),
        (dict(method="pink"), ValueError, r"method must be 'gaussian' or 'random_phase'"),
    ],
)
def test_band_limited_random_errors(kwargs, error, match):
    args = dict(
        n_samples=1024, fs_hz=FS, rms=1.0, band_hz=BAND, rng=np.random.default_rng(0), n_inputs=1
    )
    method = kwargs.pop("method", "gaussian")
    args.update(kwargs)
    with pytest.raises(error, match=match):
        band_limited_random(**args, method=method)


def test_other_generator_errors():
    with pytest.raises(ValueError, match=r"band_hz must satisfy"):
        periodic_chirp(1024, FS, 1.0, (0.0, 1000.0))
    with pytest.raises(ValueError, match=r"freq_hz must be in \[0, fs_hz/2 = 500\] Hz"):
        sine(100, 1000.0, 600.0)
    with pytest.raises(ValueError, match=r"amplitude and phase_rad must be finite"):
        sine(100, 1000.0, 60.0, amplitude=np.nan)
