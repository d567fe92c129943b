"""The spectral engine against scipy.signal.csd, Parseval, and the segment rules."""

import numpy as np
import pytest
import scipy.fft
import scipy.signal

from truthbench.measure import fft_friendly_length, plan_segments, spectral_matrices

FS = 200.0


def _records(rng, n_in, n_out, n):
    x = rng.standard_normal((n_in, n))
    x[1:] += 0.6 * x[:1]  # correlated inputs
    y = rng.standard_normal((n_out, n))
    y += scipy.signal.lfilter([0.5, 0.3], [1.0, -0.5], x[0])
    return x, y


def _csd(a, b, **kw):
    return scipy.signal.csd(a, b, fs=FS, scaling="density", **kw)[1]


@pytest.mark.parametrize(
    ("window", "nperseg", "noverlap", "detrend"),
    [
        ("bartlett", 500, 0, False),
        ("hann", 256, 128, False),
        ("hamming", 301, 100, "constant"),
        ("flattop", 128, 0, "constant"),
        ("rectangular", 1000, 0, False),
    ],
)
def test_spectral_matrices_equal_scipy_csd(rng, window, nperseg, noverlap, detrend):
    x, y = _records(rng, 2, 3, 5003)
    kw = dict(window=window, nperseg=nperseg, noverlap=noverlap, detrend=detrend)
    s = spectral_matrices(x, y, FS, output_cross=True, **kw)
    scipy_window = "boxcar" if window == "rectangular" else window
    ckw = dict(kw, window=scipy_window)
    # scipy: csd(a, b) = E[conj(A) B];  ours: Gxx[i, j] = E[X_i conj(X_j)] = csd(x_j, x_i)
    gxx = np.array([[_csd(x[j], x[i], **ckw) for j in range(2)] for i in range(2)])
    gyx = np.array([[_csd(x[i], y[o], **ckw) for i in range(2)] for o in range(3)])
    gyy_full = np.array([[_csd(y[p], y[o], **ckw) for p in range(3)] for o in range(3)])
    gxx, gyx, gyy_full = (np.moveaxis(g, -1, 0) for g in (gxx, gyx, gyy_full))
    f_ref = scipy.signal.csd(x[0], y[0], fs=FS, **ckw)[0]
    np.testing.assert_allclose(s.freq_hz, f_ref, rtol=1e-14)
    for ours, ref in [(s.Gxx, gxx), (s.Gyx, gyx), (s.Gyy_full, gyy_full)]:
        assert ours.shape == ref.shape
        np.testing.assert_allclose(ours, ref, rtol=1e-10, atol=1e-10 * np.abs(ref).max())
    np.testing.assert_allclose(
        s.Gyy, np.einsum("foo->fo", gyy_full).real, rtol=1e-10, atol=1e-10 * s.Gyy.max()
    )
    assert s.Gyy.dtype == np.float64
    assert s.plan.n_averages == 1 + (5003 - nperseg) // (nperseg - noverlap)


def test_density_scaling_obeys_parseval_with_rectangular_window(rng):
    # sum_f G(f) df equals the mean square of the samples used (Parseval), one-sided
    for n in (400, 401):
        x = rng.standard_normal(n * 7)
        s = spectral_matrices(x, x, FS, window="rectangular", nperseg=n)
        df = FS / n
        assert s.Gxx[:, 0, 0].real.sum() * df == pytest.approx(np.mean(x**2), rel=1e-12)
        assert s.Gyy[:, 0].sum() * df == pytest.approx(np.mean(x**2), rel=1e-12)


def test_white_noise_density_level(rng):
    # unit-variance white noise has one-sided density 2 / fs (Hann, long record)
    x = rng.standard_normal(2**18)
    s = spectral_matrices(x, x, FS, window="hann", nperseg=256)
    inner = s.Gxx[1:-1, 0, 0].real
    assert np.mean(inner) == pytest.approx(2.0 / FS, rel=0.01)


def test_one_dimensional_and_integer_and_float32_inputs(rng):
    x = rng.standard_normal(3000)
    y = np.round(100 * rng.standard_normal(3000)).astype(np.int32)
    s = spectral_matrices(x.astype(np.float32), y, FS, nperseg=300)
    ref = _csd(
        x.astype(np.float32).astype(float),
        y.astype(float),
        window="bartlett",
        nperseg=300,
        noverlap=0,
        detrend=False,
    )
    assert s.Gyx.shape == (151, 1, 1) and s.Gxx.shape == (151, 1, 1) and s.Gyy.shape == (151, 1)
    np.testing.assert_allclose(s.Gyx[:, 0, 0], ref, rtol=1e-10, atol=1e-10 * np.abs(ref).max())


def test_inputs_are_never_modified(rng):
    x, y = _records(rng, 2, 2, 2000)
    x0, y0 = x.copy(), y.copy()
    x.flags.writeable = False  # any in-place write would raise
    y.flags.writeable = False
    spectral_matrices(x, y, FS, window="hann", nperseg=200, detrend="constant")
    np.testing.assert_array_equal(x, x0)
    np.testing.assert_array_equal(y, y0)


def test_results_are_read_only(rng):
    x, y = _records(rng, 1, 1, 1000)
    s = spectral_matrices(x, y, FS, nperseg=100)
    with pytest.raises(ValueError, match="read-only"):
        s.Gyx[0, 0, 0] = 1.0
    with pytest.raises(AttributeError):
        s.fs_hz = 1.0


# ------------------------------------------------------------------ segment plan


def test_n_averages_gives_non_overlapping_segments_of_n_over_n_averages():
    plan = plan_segments(2**20, n_averages=10)
    assert (plan.nperseg, plan.noverlap, plan.n_averages) == (104857, 0, 10)
    assert plan.n_used == 1048570


def test_n_averages_with_overlap_takes_longest_segment_that_fits():
    plan = plan_segments(1000, n_averages=4, noverlap=50)
    assert plan.nperseg == (1000 + 3 * 50) // 4
    assert plan.n_used <= 1000
    assert plan_segments(1000, nperseg=plan.nperseg + 1, noverlap=50).n_averages == 3


def test_defaults_use_the_whole_record_once():
    plan = plan_segments(777)
    assert (plan.nperseg, plan.n_averages) == (777, 1)


def test_explicit_nperseg_is_never_changed():
    plan = plan_segments(2**20, nperseg=104857)
    assert plan.nperseg == 104857 and plan.n_averages == 10
    assert plan_segments(1000, nperseg=997, n_averages=1).nperseg == 997


def test_fast_rounds_down_to_a_5_smooth_length():
    plan = plan_segments(2**20, nperseg="fast", n_averages=10)
    assert plan.nperseg == 103680 == 2**8 * 3**4 * 5
    assert plan.n_averages == 10
    assert plan_segments(1000, nperseg="fast").nperseg == 1000
    assert plan_segments(1001, nperseg="fast").nperseg == 1000


def test_fft_friendly_length_is_largest_5_smooth_not_above_n():
    def smooth(m):
        for p in (2, 3, 5):
            while m % p == 0:
                m //= p
        return m == 1

    for n in [*range(1, 400), 104857, 2**20 + 1, 10**9 + 7]:
        m = fft_friendly_length(n)
        assert m <= n and smooth(m)
        assert scipy.fft.next_fast_len(m, real=True) == m
        if n < 400:
            assert not any(smooth(k) for k in range(m + 1, n + 1))
    assert fft_friendly_length(104857) == 103680
    with pytest.raises(ValueError, match=r"'n' parameter of fft_friendly_length must be >= 1"):
        fft_friendly_length(0)
