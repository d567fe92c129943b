"""Time records -> H1 FRFs (measure.time_frf).

Oracles: scipy.signal (csd, welch, coherence: the same Hann segments, mean removed) for
the random-test H1, its coherence and the 20 dB band; the exponential-window decay rate
``-ln(decay_to) fs / (n - 1)`` (exact); a pulse placed by hand for find_pulse.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.signal as ss

from truthbench.errors import DataFormatError
from truthbench.measure import Channel, find_pulse, frfs_from_time


def random_record(n=8 * 512, seed=3):
    rng = np.random.default_rng(seed)
    b, a = ss.butter(4, [0.1, 0.3], btype="band")
    x = ss.lfilter(b, a, rng.standard_normal(n))  # excites 0.1-0.3 of Nyquist
    h = np.exp(-np.arange(40) / 6.0) * np.cos(0.6 * np.arange(40))
    y = np.vstack([np.convolve(x, h)[:n], np.convolve(x, -0.5 * h)[:n]])
    y += 0.01 * rng.standard_normal(y.shape)
    return x, y


def test_random_h1_coherence_and_band_match_scipy():
    fs, n_avg = 100.0, 8
    x, y = random_record()
    d = frfs_from_time(x, y, fs, n_averages=n_avg, outputs=["a", "b"], inputs=["f"],
                       name="rnd")
    nper = x.size // n_avg
    kw = {"fs": fs, "window": "hann", "nperseg": nper, "noverlap": 0, "detrend": "constant"}
    f, pxx = ss.welch(x, **kw)
    np.testing.assert_allclose(d.freq_hz, f, rtol=1e-15)
    inband = (f >= d.band_hz[0]) & (f <= d.band_hz[1])
    w = ss.get_window("hann", nper)

    def fft_error_scale(sig):
        """eps log2(n) ||w s|| / |S_k| (rms over segments): the relative rounding of an
        FFT line, large where the line holds little of the signal's energy."""
        seg = sig.reshape(n_avg, nper)
        seg = (seg - seg.mean(axis=1, keepdims=True)) * w
        line = np.sqrt((np.abs(np.fft.rfft(seg, axis=1)) ** 2).sum(axis=0))
        return np.finfo(float).eps * np.log2(nper) * np.sqrt((seg**2).sum()) / line

    for o in range(2):
        _, pxy = ss.csd(x, y[o], **kw)
        _, coh = ss.coherence(x, y[o], **kw)
        ref = pxy / pxx
        # in the excited band both implementations agree to rounding
        np.testing.assert_allclose(d.H[inband, o, 0], ref[inband], rtol=1e-12)
        np.testing.assert_allclose(d.coherence[inband, o, 0], coh[inband], rtol=1e-12)
        # everywhere within the FFT rounding of both implementations (2 x 2 terms)
        bound = 4 * (fft_error_scale(x) + fft_error_scale(y[o]))
        assert np.all(np.abs(d.H[:, o, 0] - ref) <= bound * np.abs(ref))
        assert np.all(np.abs(d.coherence[:, o, 0] - coh) <= 2 * bound * coh)
    level = pxx[1:].max() / 100.0  # 20 dB below the maximum, without 0 Hz
    within = f[1:][pxx[1:] >= level]
    assert d.band_hz == (within[0], within[-1])
    assert f[1] < d.band_hz[0] < 5.0 < 15.0 < d.band_hz[1] < f[-1]  # the filter's band
    assert d.excitation == "random" and d.n_averages == n_avg
    assert d.window_decay_rad_s == 0.0
    assert d.output_labels == ("a", "b") and d.outputs[0].quantity == "acceleration"
    assert d.inputs[0].quantity == "force"


def test_outputs_as_channels_keep_their_fields():
    x, y = random_record(n=1024)
    outs = [Channel("v", "velocity", "z", sign=-1, point=7, coordinates_m=(1.0, 0, 0)),
            Channel("s", "strain", "y")]
    d = frfs_from_time(x, y, 100.0, outputs=outs, n_averages=4)
    assert d.outputs == tuple(outs) and d.frf_type == "mixed" and d.input_labels == ("in0",)
    with pytest.raises(ValueError, match=r"input channel\(s\) \['acc'\] do not measure a "
                                         r"force"):
        frfs_from_time(x, y, 100.0, inputs=[Channel("acc", "acceleration")])
    with pytest.raises(ValueError, match=r"rec: expected 2 output channel\(s\)"):
        frfs_from_time(x, y, 100.0, outputs=["one"], name="rec")


def half_sine(n=2000, at=30, width=8, peak=50.0, baseline=0.0):
    u = np.full(n, baseline)
    u[at:at + width] += peak * np.sin(np.pi * (np.arange(width) + 0.5) / width)
    return u


def test_find_pulse():
    first, last, base = find_pulse(half_sine(baseline=0.25))
    # samples above 5 % of the peak: sin(pi (k + 0.5) / 8) > 0.05 for every k of the pulse
    assert (first, last) == (30, 37) and base == 0.25
    assert find_pulse(np.sin(np.arange(500) * 0.3)) is None  # not short
    assert find_pulse(np.zeros(100)) is None


def test_impact_record_decay_band_and_no_coherence():
    fs, n = 1000.0, 2000
    u = half_sine(n, baseline=0.1)
    h = np.exp(-np.arange(200) / 30.0) * np.sin(0.5 * np.arange(200))
    y = np.convolve(u - 0.1, h)[:n]
    d = frfs_from_time(u, y, fs, decay_to=0.05)
    assert d.excitation == "impact" and d.n_averages == 1 and d.coherence is None
    assert d.window_decay_rad_s == pytest.approx(-np.log(0.05) * fs / (n - 1), rel=1e-15)
    assert d.freq_hz.size == n // 2 + 1 and d.band_hz[0] == d.freq_hz[1]
    # a half-sine of 8 ms at 1 kHz: its spectrum falls 10 dB near 0.8 / T ~ 100 Hz
    assert 60.0 < d.band_hz[1] < 140.0
    assert any("force window" in note for note in d.notes)


def test_input_rms_is_the_records_rms_about_its_baseline():
    """A multisine on whole periods of the record has RMS sqrt(sum a_k^2 / 2) about its
    mean (the cross terms and the mean of each sine vanish over whole periods); a
    half-sine pulse of w samples sin(pi (k + 1/2) / w) has sum of squares w / 2 exactly.
    Round-off: one rounding per sample value and numpy's pairwise sum of n squares,
    ~ log2(n) eps."""
    fs, n = 256.0, 4096
    k = np.arange(n)
    tones = ((3.0, 10), (1.5, 37), (0.5, 250))  # (amplitude N, periods in the record)
    x = 0.7 + sum(a * np.sin(2 * np.pi * m * k / n + 0.3 * m) for a, m in tones)
    rtol = 20 * np.log2(n) * np.finfo(float).eps
    for x2 in (x, np.vstack([x, 0.5 * x[::-1] - 4.0])):
        d = frfs_from_time(x2, np.roll(x, 5), fs, excitation="random")
        rms = np.sqrt(sum(a**2 / 2 for a, _ in tones))
        np.testing.assert_allclose(d.input_rms, [rms, 0.5 * rms][:np.ndim(x2)], rtol=rtol)
    peak, width = 50.0, 8
    u = half_sine(2000, width=width, peak=peak, baseline=0.1)
    d = frfs_from_time(u, np.convolve(u - 0.1, np.exp(-np.arange(50) / 9.0))[:2000], 1000.0)
    assert d.excitation == "impact"
    np.testing.assert_allclose(d.input_rms, [peak * np.sqrt(width / 2 / 2000)], rtol=rtol)


def test_errors_name_the_source():
    with pytest.raises(DataFormatError, match=r"rec: input and output records differ in "
                                              r"length \(10 and 12 samples\)"):
        frfs_from_time(np.zeros(10), np.zeros(12), 100.0, name="rec")
    rng = np.random.default_rng(0)
    with pytest.raises(DataFormatError, match=r"f\.lvm: excitation='impact' but input 'in0' "
                                              r"holds no short pulse"):
        frfs_from_time(rng.standard_normal(256), rng.standard_normal(256), 100.0,
                       excitation="impact", source="f.lvm")
    with pytest.raises(DataFormatError, match=r"impact test with 2 force channels"):
        frfs_from_time(np.vstack([half_sine(), half_sine()]), np.zeros(2000), 100.0)
    with pytest.raises(ValueError, match=r"'excitation' must be one of 'auto', 'impact', "
                                         r"'random'; got 'hammer'"):
        frfs_from_time(np.zeros(10), np.zeros(10), 100.0, excitation="hammer")
    with pytest.raises(ValueError, match=r"'fs_hz' must be a finite number > 0; got -1"):
        frfs_from_time(np.zeros(10), np.zeros(10), -1)
    with pytest.raises(ValueError, match=r"'n_averages' must be an integer >= 1; got 0"):
        frfs_from_time(rng.standard_normal(64), rng.standard_normal(64), 100.0, n_averages=0)
