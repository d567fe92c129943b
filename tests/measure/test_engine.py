"""The blocked spectral engine: numba kernel against numpy, blocks, workers, big records."""

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


def _rel(a, b):
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


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
    for accumulate in (kernel, engine._accumulate_numpy):
        auto, cross = _sums(x, y, accumulate, workers=workers, output_cross=output_cross, **kw)
        assert auto.shape == ref[0].shape and cross.shape == ref[1].shape
        assert _rel(auto, ref[0]) < 1e-13 and _rel(cross, ref[1]) < 1e-13


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
    for i in range(2):
        for o in range(3):
            ref = scipy.signal.csd(x[i], y[o], **kw)[1]
            assert _rel(s.Gyx[:, o, i], ref) < 1e-12
    ref = scipy.signal.csd(y[2], y[0], **kw)[1]  # Gyy_full[o, p] = E[Y_o conj(Y_p)]
    assert _rel(s.Gyy_full[:, 0, 2], ref) < 1e-12
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
    assert _rel(est.H[:, :, 0], (pxy / pxx).T) < 1e-12
    assert _rel(est.coherence[:, :, 0], (np.abs(pxy) ** 2 / (pxx * pyy)).T) < 1e-12


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
