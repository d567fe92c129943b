"""Every error path of the measure room names the parameter, the expectation and the value."""

import numpy as np
import pytest

from truthbench.errors import DataFormatError, IdentifiabilityError, TruthbenchError
from truthbench.measure import (
    FRFEstimate,
    estimate_frf,
    fft_friendly_length,
    frf_from_spectra,
    h1,
    plan_segments,
    spectral_matrices,
)

FS = 100.0


@pytest.fixture
def xy(rng):
    return rng.standard_normal((1, 1000)), rng.standard_normal((2, 1000))


# ------------------------------------------------------------------ data (DataFormatError)


def test_mismatched_lengths(xy):
    x, y = xy
    with pytest.raises(
        DataFormatError, match=r"same length; got x with 1000 samples .* y with 999 samples"
    ):
        h1(x, y[:, :999], FS)


def test_no_input_channel(xy):
    _, y = xy
    with pytest.raises(DataFormatError, match=r"'x' input array has no channel: shape \(0, 1000\)"):
        h1(np.empty((0, 1000)), y, FS)


def test_no_output_channel(xy):
    x, _ = xy
    with pytest.raises(DataFormatError, match=r"'y' output array has no channel"):
        h1(x, np.empty((0, 1000)), FS)


def test_empty_record():
    with pytest.raises(DataFormatError, match=r"'x' input time histories are empty"):
        h1(np.empty((1, 0)), np.empty((1, 0)), FS)


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_data(xy, bad):
    x, y = xy
    y = y.copy()
    y[1, 123] = bad
    with pytest.raises(
        DataFormatError,
        match=r"'y' output time histories must be finite; got 1 NaN/inf samples, the first "
        r"in channel 1 at sample 123",
    ):
        h1(x, y, FS)
    x = x.copy()
    x[0, 5] = bad
    with pytest.raises(DataFormatError, match=r"'x' input time histories must be finite"):
        h1(x, y, FS)


def test_non_finite_sample_in_unused_tail_is_reported(xy):
    x, y = xy
    x = x.copy()
    x[0, 999] = np.nan  # 3 segments of 300 use samples 0..899 only
    with pytest.raises(DataFormatError, match=r"'x' input .* channel 0 at sample 999"):
        h1(x, y, FS, nperseg=300)


def test_overflowing_spectra_of_finite_data(xy):
    x, y = xy
    with pytest.raises(DataFormatError, match=r"spectra of the finite 'x'/'y' data overflowed"):
        h1(x * 1e200, y, FS, nperseg=100)


def test_complex_or_non_numeric_data(xy):
    x, y = xy
    with pytest.raises(
        DataFormatError, match=r"'x' input time histories must be real; got dtype complex"
    ):
        h1(x + 0j, y, FS)
    with pytest.raises(DataFormatError, match=r"'y' output time histories must be real numbers"):
        h1(x, np.array([["a"] * 1000]), FS)


def test_too_many_dimensions(xy):
    x, y = xy
    with pytest.raises(DataFormatError, match=r"shape \(n_channels, N\) or \(N,\); got 3 dim"):
        h1(x[np.newaxis], y, FS)


def test_nperseg_longer_than_record(xy):
    x, y = xy
    with pytest.raises(
        DataFormatError, match=r"segment \(nperseg=1001 samples\) is longer than the record \(1000"
    ):
        h1(x, y, FS, nperseg=1001)


def test_window_array_longer_than_record(xy):
    x, y = xy
    with pytest.raises(
        DataFormatError, match=r"'window' array \(1200 samples\) is longer than the record \(1000"
    ):
        h1(x, y, FS, window=np.ones(1200))


def test_too_many_averages_for_the_record(xy):
    x, y = xy
    with pytest.raises(
        DataFormatError, match=r"holds only 5 segments of nperseg=200 .*n_averages=6 needs 1200"
    ):
        h1(x, y, FS, nperseg=200, noverlap=0, n_averages=6)
    with pytest.raises(
        DataFormatError, match=r"too short for n_averages=2000 segments with noverlap=1"
    ):
        h1(x, y, FS, n_averages=2000, noverlap=1)


def test_record_without_samples_in_plan():
    with pytest.raises(DataFormatError, match=r"at least 1 sample; got 0"):
        plan_segments(0)


# ------------------------------------------------------------------ options (ValueError)


def test_unknown_window(xy):
    x, y = xy
    with pytest.raises(ValueError, match=r"Unknown window 'hanning'; expected one of rectangular"):
        h1(x, y, FS, window="hanning")


def test_unknown_estimator(xy):
    x, y = xy
    with pytest.raises(ValueError, match=r"Unknown estimator 'H3'; expected one of H1, H2, Hv"):
        estimate_frf(x, y, FS, estimator="H3")
    with pytest.raises(ValueError, match=r"Unknown estimator None"):
        estimate_frf(x, y, FS, estimator=None)


def test_window_array_length_must_equal_nperseg(xy):
    x, y = xy
    with pytest.raises(ValueError, match=r"length 100 \(nperseg\); got length 50"):
        h1(x, y, FS, window=np.ones(50), nperseg=100)


def test_fast_with_window_array(xy):
    x, y = xy
    with pytest.raises(ValueError, match=r"'fast' cannot be combined with a 'window' array"):
        h1(x, y, FS, window=np.ones(100), nperseg="fast")


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"nperseg": 0}, r"'nperseg' parameter must be >= 1; got 0"),
        ({"nperseg": 100.0}, r"'nperseg' parameter must be an integer; got 100.0"),
        ({"nperseg": "quick"}, r"'nperseg' parameter must be a positive integer, 'fast' or None"),
        ({"nperseg": True}, r"'nperseg' parameter must be an integer; got True"),
        (
            {"nperseg": 100, "noverlap": 100},
            r"'noverlap' parameter must be smaller than nperseg=100",
        ),
        ({"noverlap": -1}, r"'noverlap' parameter must be >= 0; got -1"),
        ({"n_averages": 0}, r"'n_averages' parameter must be >= 1; got 0"),
        ({"detrend": "linear"}, r"'detrend' parameter must be False/None/'none' or 'constant'"),
    ],
)
def test_invalid_segment_options(xy, kwargs, message):
    x, y = xy
    with pytest.raises(ValueError, match=message):
        h1(x, y, FS, **kwargs)


@pytest.mark.parametrize("fs", [0.0, -1.0, np.inf, np.nan, "fast", True, None])
def test_invalid_sampling_frequency(xy, fs):
    x, y = xy
    with pytest.raises(ValueError, match=r"'fs_hz' parameter must be a positive finite number"):
        h1(x, y, fs)


def test_fft_friendly_length_needs_an_integer():
    with pytest.raises(ValueError, match=r"'n' parameter must be an integer; got 10.5"):
        fft_friendly_length(10.5)


# ------------------------------------------------------------------ estimator limits


def test_h2_needs_at_least_as_many_outputs_as_inputs(rng):
    x, y = rng.standard_normal((3, 1000)), rng.standard_normal((2, 1000))
    with pytest.raises(
        IdentifiabilityError, match=r"H2 with 3 inputs needs at least 3 outputs; got 2"
    ):
        estimate_frf(x, y, FS, estimator="H2", nperseg=100)
    s = spectral_matrices(x, y, FS, nperseg=100, output_cross=True)
    with pytest.raises(IdentifiabilityError, match=r"H2 with 3 inputs needs at least 3 outputs"):
        frf_from_spectra(s, "H2")


def test_h2_with_several_inputs_needs_the_output_cross_spectra(rng):
    x, y = rng.standard_normal((2, 1000)), rng.standard_normal((2, 1000))
    s = spectral_matrices(x, y, FS, nperseg=100)  # output_cross=False
    with pytest.raises(ValueError, match=r"full output spectral matrix; .* output_cross=True"):
        frf_from_spectra(s, "H2")


def test_frf_estimate_needs_a_frequency_vector():
    with pytest.raises(ValueError, match=r"'freq_hz' must have shape \(n_freq,\); got \(2, 2\)"):
        FRFEstimate(
            np.zeros((2, 2)),
            np.zeros((2, 1, 1)),
            np.zeros((2, 1, 1)),
            None,
            estimator="H1",
            window="hann",
            nperseg=2,
            noverlap=0,
            n_averages=1,
            fs_hz=1.0,
        )


def test_data_errors_are_truthbench_errors(xy):
    x, y = xy
    with pytest.raises(TruthbenchError):
        h1(x, y[:, :10], FS)
