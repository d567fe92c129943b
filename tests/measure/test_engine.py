"""The blocked spectral engine: numba kernel against numpy, blocks, workers, big records.

Tolerances follow from the arithmetic, not from one CPU: every comparison allows the
rounding of the sums both sides evaluate (:func:`_sum_rounding`), scaled by the sizes of
the terms summed (:func:`_accumulate_abs`), and checks that the allowance stays below
1e-9 of the largest value, so that a real error would fail.
"""

import numpy as np
import pytest
import scipy.signal

from truthbench.errors import DataFormatError
from truthbench.measure import h1, spectral_matrices
from truthbench.measure import spectra as engine

FS = 1000.0


def _records(rng, n_in, n_out, n):
    x = rng.standard_normal((n_in, n))
    x[1:] += 0.6 * x[:1]  # correlated inputs
    y = 0.1 * rng.standard_normal((n_out, n))
    y += scipy.signal.lfilter([0.5, 0.3], [1.0, -0.5], x[0])
    return x, y


def _sums(x, y, accumulate, *, workers=None, output_cross=False, **kw):
    xa, ya, _, plan, w_in, w_out, _, detrend = engine._prepare(
        x, y, FS, window="hann", input_window=None, n_averages=None, **kw
    )
    n_paired = xa.shape[0] + ya.shape[0] - 1 if output_cross else xa.shape[0]
    channels = [(xa, w_in), (ya, w_out)]
    return engine._segment_sums(channels, plan, detrend, workers, n_paired, accumulate)


U = np.finfo(float).eps / 2  # unit roundoff


def _accumulate_abs(zc, partners, c, n_paired, auto, cross):
    """The accumulator's sums with each product replaced by its magnitude.

    ``sum_s |Z_c|^2`` and ``sum_s |Z_c| |Z_b|`` (in the real part of the cross rows):
    the sizes of the terms whose rounding :func:`_sum_rounding` counts.
    """
    n_ch = auto.shape[0]
    auto[c] += np.sum(np.abs(zc) ** 2, axis=0)
    for b in range(min(c, n_paired)):
        cross[engine._cross_row(b, c, n_ch)] += np.sum(np.abs(zc) * np.abs(partners[b]), axis=0)


def _sum_rounding(n_terms, magnitude, nperseg=None):
    """Largest difference of two evaluations of ``sum_s Z_a conj(Z_b)`` (first order in u).

    Both sides sum the same products: the segment DFTs are the same bits (the same
    windowed samples through the same ``scipy.fft.rfft``; pocketfft applies the same
    operations to every transform of a batch). They sum them in different orders
    (numba: segment after segment; numpy: block by block, pairwise within a block; the
    block size and the FFT workers change the grouping; scipy: ``mean`` of scaled
    products). In any order a sum of ``n`` terms is within ``(n - 1) u sum|terms|`` of
    the exact sum (Higham, Accuracy and Stability of Numerical Algorithms, 2nd ed.,
    eq. 4.4) and a complex product within ``sqrt(2) 2 u`` of its own (Lemma 3.5): each
    side within ``(n + 2) u sum_s |Z_a||Z_b|``, the two within twice that.

    Against scipy (``nperseg`` given) the density scale ``2 / (fs sum(w^2) n)`` is
    computed apart on each side: the sum of ``nperseg`` positive squares is within
    ``(nperseg - 1) u`` relative in any order, and four more operations.

    Parameters
    ----------
    n_terms : int
        Segments summed.
    magnitude : ndarray
        ``sum_s |Z_a||Z_b|`` (:func:`_accumulate_abs`), scaled like the compared values.
    nperseg : int, optional
        Segment length, when the two sides scale apart.
    """
    per_side = n_terms + 2 + (0 if nperseg is None else nperseg + 4)
    return 2 * per_side * U * np.abs(magnitude)


def _assert_within(a, ref, bound):
    """``|a - ref| <= bound`` everywhere, and ``bound`` fine enough to see an error of
    1e-9 of the largest value."""
    assert a.shape == ref.shape
    excess = np.abs(a - ref) / bound
    assert np.all(np.abs(a - ref) <= bound), f"{np.max(excess):.3g} times the rounding bound"
    assert np.max(bound) < 1e-9 * np.max(np.abs(ref))


def _abs_sums(x, y, output_cross=False, **kw):
    """:func:`_accumulate_abs` sums of the records, with their plan and density scale."""
    kw = {"nperseg": None, "n_averages": None, **kw}
    xa, ya, fs, plan, w_in, w_out, _, detrend = engine._prepare(x, y, FS, input_window=None,
                                                                 **kw)
    n_paired = xa.shape[0] + ya.shape[0] - 1 if output_cross else xa.shape[0]
    auto, cross = engine._segment_sums([(xa, w_in), (ya, w_out)], plan, detrend, 1, n_paired,
                                       _accumulate_abs)
    scale = engine._onesided_density_scale(float(np.sum(w_out * w_out)), fs, plan.nperseg,
                                           plan.n_averages)
    return auto, cross.real, plan, scale


@pytest.mark.parametrize("workers", [None, 2])
@pytest.mark.parametrize(
    ("n_in", "n_out", "kw", "output_cross"),
    [
        (1, 4, dict(nperseg=1000, noverlap=0, detrend=False), False),
        (2, 3, dict(nperseg=256, noverlap=128, detrend="constant"), True),
        (3, 2, dict(nperseg=301, noverlap=100, detrend=False), True),
    ],
)
def test_numba_kernel_equals_numpy_sums(rng, monkeypatch, workers, n_in, n_out, kw, output_cross):
    kernel = engine._compiled_accumulate()
    if kernel is None:
        pytest.skip("numba is not importable, or its JIT is disabled")
    # blocks of 3 segments, so that the last block is shorter
    monkeypatch.setattr(engine, "_BLOCK_BYTES", 3 * 8 * kw["nperseg"] * (n_in + n_out))
    x, y = _records(rng, n_in, n_out, 12_345)
    ref = _sums(x, y, engine._accumulate_numpy, workers=1, output_cross=output_cross, **kw)
    mag_auto, mag_cross, plan, _ = _abs_sums(x, y, output_cross, window="hann", **kw)
    for accumulate in (kernel, engine._accumulate_numpy):
        auto, cross = _sums(x, y, accumulate, workers=workers, output_cross=output_cross, **kw)
        _assert_within(auto, ref[0], _sum_rounding(plan.n_averages, mag_auto))
        _assert_within(cross, ref[1], _sum_rounding(plan.n_averages, mag_cross))


@pytest.mark.parametrize("block_segments", [1, 2, 7, 100])
@pytest.mark.parametrize("workers", [None, 2])
def test_block_size_and_workers_do_not_change_the_spectra(
    rng, monkeypatch, block_segments, workers
):
    x, y = _records(rng, 2, 3, 5003)
    nperseg = 250
    monkeypatch.setattr(engine, "_BLOCK_BYTES", block_segments * 8 * nperseg * 5)
    s = spectral_matrices(x, y, FS, nperseg=nperseg, output_cross=True, workers=workers)
    kw = dict(fs=FS, window="bartlett", nperseg=nperseg, noverlap=0, detrend=False)
    _, mag, plan, scale = _abs_sums(x, y, True, window="bartlett", nperseg=nperseg,
                                    noverlap=0, detrend=False)
    n_ch = 5
    for i in range(2):
        for o in range(3):
            ref = scipy.signal.csd(x[i], y[o], **kw)[1]
            bound = _sum_rounding(plan.n_averages, scale * mag[engine._cross_row(i, 2 + o, n_ch)],
                                  nperseg)
            _assert_within(s.Gyx[:, o, i], ref, bound)
    ref = scipy.signal.csd(y[2], y[0], **kw)[1]  # Gyy_full[o, p] = E[Y_o conj(Y_p)]
    bound = _sum_rounding(plan.n_averages, scale * mag[engine._cross_row(2, 4, n_ch)], nperseg)
    _assert_within(s.Gyy_full[:, 0, 2], ref, bound)
    np.testing.assert_array_equal(s.Gyy_full, s.Gyy_full.conj().transpose(0, 2, 1))
    np.testing.assert_array_equal(s.Gxx, s.Gxx.conj().transpose(0, 2, 1))
    assert np.all(np.diagonal(s.Gxx, axis1=1, axis2=2).imag == 0)


def test_big_record_h1_equals_scipy_csd(rng):
    # large enough for the compiled kernel (if numba imports): 5 x 4 x 65537 values
    n = 2**19
    assert 5 * 4 * (n // 4 // 2 + 1) >= engine._NUMBA_MIN_VALUES
    x, y = _records(rng, 1, 4, n)
    est = h1(x, y, FS, n_averages=4)
    kw = dict(fs=FS, window="bartlett", nperseg=n // 4, noverlap=0, detrend=False)
    _, pxy = scipy.signal.csd(x[0], y, **kw)
    _, pxx = scipy.signal.welch(x[0], **kw)
    _, pyy = scipy.signal.welch(y, **kw)
    # the rounding bounds of the spectra (_sum_rounding), carried through the ratios to
    # first order: H = Gyx / Gxx, gamma^2 = |Gyx|^2 / (Gxx Gyy), each with a few roundings
    # of its own
    auto, mag, plan, scale = _abs_sums(x, y, window="bartlett", n_averages=4,
                                       noverlap=0, detrend=False)
    e_xx = _sum_rounding(plan.n_averages, scale * auto[0], plan.nperseg)
    e_yy = _sum_rounding(plan.n_averages, scale * auto[1:], plan.nperseg)
    e_yx = _sum_rounding(plan.n_averages, scale * mag[:4], plan.nperseg)
    h = (pxy / pxx).T
    bound_h = (e_yx.T + np.abs(h) * e_xx[:, None]) / pxx[:, None] + 4 * U * np.abs(h)
    _assert_within(est.H[:, :, 0], h, bound_h)
    coh = (np.abs(pxy) ** 2 / (pxx * pyy)).T
    bound_coh = (2 * np.abs(pxy.T) * e_yx.T / (pxx[:, None] * pyy.T)
                 + coh * (e_xx[:, None] / pxx[:, None] + e_yy.T / pyy.T) + 16 * U * coh)
    _assert_within(est.coherence[:, :, 0], coh, bound_coh)


def test_big_record_with_a_nan_is_reported(rng):
    n = 2**19
    x, y = _records(rng, 1, 4, n)
    y[2, 300_000] = np.nan
    with pytest.raises(DataFormatError, match="channel 2 at sample 300000"):
        h1(x, y, FS, n_averages=4)


def test_named_windows_are_cached_read_only_and_arrays_are_not(rng):
    w, description = engine._window("hann", 64)
    assert description == "hann" and not w.flags.writeable
    assert engine._window("hann", 64)[0] is w
    custom = np.hanning(64)
    w2, description = engine._window(custom, 64)
    assert description == "custom" and w2 is not custom
    x, y = _records(rng, 1, 1, 640)
    a = spectral_matrices(x, y, FS, window="hann", nperseg=64)
    b = spectral_matrices(x, y, FS, window="hann", nperseg=64)
    np.testing.assert_array_equal(a.Gyx, b.Gyx)
