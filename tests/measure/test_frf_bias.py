"""Peak bias of H1 at a resonance: second order with Hann, first order with rectangular.

Bendat & Piersol (Random Data, ch. 8): at a resonance of half-power
bandwidth ``B_r`` and line spacing ``df``, a smooth window (Hann) gives a peak bias of
order ``(df / B_r)**2``, so halving ``df / B_r`` cuts it about 4x; a rectangular window
with random input gives a bias of first order in ``df / B_r`` (halving cuts it 2x),
because its spectral window decays only as ``1 / f**2``.

The system is one digital resonance with poles ``r exp(+-j theta)``, ``fn = fs / 8`` on
a line, ``B_r = -ln(r) fs / pi = fs / 64``.  Segments of 256 and 512 samples give
``df / B_r = 0.25`` and ``0.125``.  One noise-free record of ``2**23`` samples gives
32768 and 16384 averages, so the random error of ``|H1|`` at the peak (Bendat & Piersol
eq. 9.90, ``sqrt(1 - g2) / (|g| sqrt(2 n_d))``, with ``g2`` < 1 from leakage) is about
0.1 % against biases of 2 % to 8 %.

Tolerances.  The exact expected bias of H1 for white input is the FRF seen through the
window's spectral window: ``E[H1](f) = sum_l h[l] R_w[l] / R_w[0] exp(-j 2 pi f l / fs)``
with ``R_w`` the window autocorrelation (derived below from ``E[Y X*]`` for
``y = h * x``).  It gives the ratios 3.49 (Hann; 4 only as ``df / B_r -> 0``, the
next-order term lowers it) and 2.00 (rectangular) for this halving.  The measured ratio
must lie in [2.9, 4.6] for Hann and [1.7, 2.3] for rectangular: at least 4 standard
deviations of the random error around the exact value, and the two intervals do not
overlap, so the test does tell the orders apart.
"""

import numpy as np
import pytest
import scipy.signal

from truthbench.measure import get_window, h1

FS = 1.0
FN = FS / 8
B_R = FS / 64
R = np.exp(-np.pi * B_R / FS)
A = np.array([1.0, -2 * R * np.cos(2 * np.pi * FN / FS), R * R])  # denominator, b = [1]
N_RECORD = 2**23
SEGMENTS = (256, 512)  # df / B_r = 0.25, 0.125


def _exact_h(f):
    return scipy.signal.freqz([1.0], A, worN=np.atleast_1d(f), fs=FS)[1]


def _expected_h1(window, nperseg, f):
    """E[H1](f) for white input: sum_l h[l] R_w[l] / R_w[0] exp(-j 2 pi f l / fs).

    With Y_k = sum_n w[n] y[n] e^{-jwn} and y = h * x, x white:
    E[Y_k X_k*] = sum_l h[l] e^{-jwl} sum_m w[m + l] w[m] and E[|X_k|^2] = sum_m w[m]^2.
    """
    w = get_window(window, nperseg)
    r_w = np.correlate(w, w, mode="full")[nperseg - 1 :] / np.dot(w, w)  # lags 0..n-1
    impulse = np.zeros(nperseg)
    impulse[0] = 1.0
    h = scipy.signal.lfilter([1.0], A, impulse)
    lags = np.arange(nperseg)
    return np.sum(h * r_w * np.exp(-2j * np.pi * f * lags / FS))


def _expected_bias(window, nperseg):
    return abs(_expected_h1(window, nperseg, FN)) / abs(_exact_h(FN)[0]) - 1


@pytest.fixture(scope="module")
def measured():
    """Relative peak bias of |H1| and its random standard error, per (window, nperseg)."""
    rng = np.random.default_rng(8)
    settle = 2000
    x = rng.standard_normal(N_RECORD + settle)
    y = scipy.signal.lfilter([1.0], A, x)[settle:]
    x = x[settle:]
    exact = abs(_exact_h(FN)[0])
    out = {}
    for window in ("hann", "rectangular"):
        for nperseg in SEGMENTS:
            est = h1(x, y, FS, window=window, nperseg=nperseg)
            k = round(FN / est.df_hz)
            assert est.freq_hz[k] == FN
            g2 = est.coherence[k, 0, 0]
            sd = np.sqrt((1 - g2) / g2) / np.sqrt(2 * est.n_averages)
            out[window, nperseg] = (abs(est.H[k, 0, 0]) / exact - 1, sd)
    return out


def test_hann_peak_bias_is_second_order_in_df_over_br(measured):
    coarse, _ = measured["hann", 256]
    fine, _ = measured["hann", 512]
    assert coarse < 0 and fine < 0  # H1 underestimates a peak
    assert 2.9 <= coarse / fine <= 4.6  # exact expectation 3.49, -> 4 as df/B_r -> 0


def test_rectangular_peak_bias_under_random_input_is_first_order(measured):
    coarse, _ = measured["rectangular", 256]
    fine, _ = measured["rectangular", 512]
    assert coarse < 0 and fine < 0
    assert 1.7 <= coarse / fine <= 2.3  # exact expectation 2.00
    # at the same df / B_r the rectangular window is worse than Hann
    assert fine < 1.5 * measured["hann", 512][0]


@pytest.mark.parametrize("window", ["hann", "rectangular"])
@pytest.mark.parametrize("nperseg", SEGMENTS)
def test_measured_peak_bias_matches_spectral_window_theory(measured, window, nperseg):
    bias, sd = measured[window, nperseg]
    assert sd < 2e-3
    assert abs(bias - _expected_bias(window, nperseg)) < 5 * sd


def test_theory_ratios_tend_to_four_and_two():
    ratio = {}
    for window in ("hann", "rectangular"):
        biases = [_expected_bias(window, n) for n in (2048, 4096)]  # df/B_r 1/32, 1/64
        ratio[window] = biases[0] / biases[1]
    assert ratio["hann"] == pytest.approx(4.0, rel=0.01)
    assert ratio["rectangular"] == pytest.approx(2.0, rel=0.01)
