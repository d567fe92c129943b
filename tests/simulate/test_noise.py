"""Sensor noise: realised ratio against its sampling distribution, shapes, errors.

Oracle: for N independent Gaussian samples the sample standard deviation has a relative
standard deviation of about 1/sqrt(2 N) (chi distribution, large N). The realised
ratio std(noise)/std(y) therefore scatters around the requested value with that
relative spread; single-record checks allow 5 of those standard deviations.
"""

from __future__ import annotations

import numpy as np
import pytest

from truthbench.simulate import add_sensor_noise, noise_to_signal_ratio


def _clean(n_ch=3, n=2**16, seed=0):
    t = np.arange(n) / 1000.0
    rng = np.random.default_rng(seed)
    amp = np.array([1.0, 1e-3, 50.0])[:n_ch]
    return (
        amp[:, None] * np.sin(2 * np.pi * 7.3 * t + rng.uniform(0, 6, (n_ch, 1)))
        + 0.3 * amp[:, None]
    )


def test_realised_ratio_within_sampling_error():
    y = _clean()
    n = y.shape[1]
    ratio = np.array([0.01, 0.1, 0.5])
    y_noisy = add_sensor_noise(y, ratio, np.random.default_rng(1))
    realised = noise_to_signal_ratio(y, y_noisy)
    sigma_rel = 1.0 / np.sqrt(2 * n)  # 0.28 % for 2**16 samples
    assert np.all(np.abs(realised / ratio - 1) < 5 * sigma_rel)


def test_spread_of_realised_ratio_is_one_over_sqrt_2n():
    n, n_ch = 2048, 400
    y = np.random.default_rng(2).standard_normal((n_ch, n))
    realised = noise_to_signal_ratio(y, add_sensor_noise(y, 0.05, np.random.default_rng(3)))
    rel = realised / 0.05
    # the mean is unbiased to O(1/N); the spread matches 1/sqrt(2N) within ~3 x its own
    # sampling error (relative std of a std over 400 channels ~ 3.5 %)
    assert abs(rel.mean() - 1) < 4 / np.sqrt(2 * n * n_ch)
    assert abs(rel.std() * np.sqrt(2 * n) - 1) < 0.12


def test_noise_is_white_and_gaussian():
    y = np.zeros((1, 2**14))
    y[0, ::2] = 1.0  # std 0.5
    noise = add_sensor_noise(y, 1.0, np.random.default_rng(4)) - y
    e = noise[0] / noise[0].std()
    lag1 = np.mean(e[1:] * e[:-1])
    assert abs(lag1) < 5 / np.sqrt(e.size)
    assert abs(np.mean(e**4) - 3) < 0.3


def test_new_array_input_untouched_and_1d():
    y = _clean(1)[0]
    y.setflags(write=False)
    before = y.copy()
    y_noisy = add_sensor_noise(y, 0.02, np.random.default_rng(5))
    assert y_noisy.shape == y.shape and y_noisy is not y
    np.testing.assert_array_equal(y, before)
    assert noise_to_signal_ratio(y, y_noisy).shape == (1,)
    np.testing.assert_array_equal(add_sensor_noise(y, 0.0, np.random.default_rng(5)), y)


def test_zero_signal_channel_gets_no_noise():
    y = np.vstack([np.ones(100), np.linspace(0, 1, 100)])
    y_noisy = add_sensor_noise(y, 0.1, np.random.default_rng(6))
    np.testing.assert_array_equal(y_noisy[0], y[0])
    ratio = noise_to_signal_ratio(y, y_noisy)
    assert np.isnan(ratio[0]) and ratio[1] > 0


def test_reproducible():
    y = _clean()
    a = add_sensor_noise(y, 0.1, np.random.default_rng(9))
    b = add_sensor_noise(y, 0.1, np.random.default_rng(9))
    np.testing.assert_array_equal(a, b)


def test_errors():
    y = _clean(2, 100)
    rng = np.random.default_rng(0)
    with pytest.raises(ValueError, match=r"noise_to_signal must be finite and >= 0"):
        add_sensor_noise(y, -0.1, rng)
    with pytest.raises(ValueError, match=r"noise_to_signal must be a scalar or have shape \(2,\)"):
        add_sensor_noise(y, [0.1, 0.2, 0.3], rng)
    with pytest.raises(TypeError, match=r"rng must be a numpy.random.Generator"):
        add_sensor_noise(y, 0.1, 42)
    with pytest.raises(ValueError, match=r"y must be finite"):
        add_sensor_noise(np.array([1.0, np.nan, 2.0]), 0.1, rng)
    with pytest.raises(ValueError, match=r"y must have shape \(n_channels, n_samples\)"):
        add_sensor_noise(np.zeros((2, 2, 2)), 0.1, rng)
    with pytest.raises(ValueError, match=r"y must be real"):
        add_sensor_noise(np.zeros(4, complex), 0.1, rng)
    with pytest.raises(ValueError, match=r"y_noisy must have the shape of y_clean"):
        noise_to_signal_ratio(y, y[:, :50])
