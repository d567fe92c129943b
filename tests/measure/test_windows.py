"""Windows: equal to scipy.signal.get_window, to the textbook formulas, and all distinct."""

import itertools

import numpy as np
import pytest
import scipy.signal

from truthbench.measure import WINDOW_NAMES, get_window, window_from_spec

STANDARD = {
    "rectangular": "boxcar",
    "boxcar": "boxcar",
    "bartlett": "bartlett",
    "hann": "hann",
    "hamming": "hamming",
    "flattop": "flattop",
}
LENGTHS = [1, 2, 7, 8, 64, 1001]


@pytest.mark.parametrize("n", LENGTHS)
@pytest.mark.parametrize("name", sorted(STANDARD))
def test_standard_windows_equal_scipy_periodic_exactly(name, n):
    expected = scipy.signal.get_window(STANDARD[name], n)  # default fftbins=True
    w = get_window(name, n)
    assert w.dtype == np.float64
    assert w.shape == (n,)
    np.testing.assert_array_equal(w, expected)


@pytest.mark.parametrize("n", [8, 63, 1024])
def test_standard_windows_match_textbook_dft_even_formulas(n):
    # Harris (1978), DFT-even forms: k = 0 .. n-1, period n
    k = np.arange(n)
    phase = 2 * np.pi * k / n
    textbook = {
        "rectangular": np.ones(n),
        "bartlett": 1 - np.abs(2 * k / n - 1),
        "hann": 0.5 - 0.5 * np.cos(phase),
        "hamming": 0.54 - 0.46 * np.cos(phase),
        "flattop": (
            0.21557895
            - 0.41663158 * np.cos(phase)
            + 0.277263158 * np.cos(2 * phase)
            - 0.083578947 * np.cos(3 * phase)
            + 0.006947368 * np.cos(4 * phase)
        ),
    }
    for name, expected in textbook.items():
        np.testing.assert_allclose(get_window(name, n), expected, rtol=0, atol=1e-14, err_msg=name)


@pytest.mark.parametrize("n", [8, 64, 1001])
def test_every_window_differs_from_every_other(n):
    # pyFRF once returned the same samples for Hann and Hamming
    windows = {name: get_window(name, n) for name in WINDOW_NAMES}
    for (a, wa), (b, wb) in itertools.combinations(windows.items(), 2):
        assert np.max(np.abs(wa - wb)) > 1e-3, f"{a} and {b} are the same window"


def test_names_are_case_insensitive_and_boxcar_is_rectangular():
    np.testing.assert_array_equal(get_window("HaNn", 16), get_window("hann", 16))
    np.testing.assert_array_equal(get_window("boxcar", 16), get_window("rectangular", 16))


def test_force_window_is_one_over_force_width_then_zero():
    w = get_window("force", 10, force_width=3)
    np.testing.assert_array_equal(w, [1, 1, 1, 0, 0, 0, 0, 0, 0, 0])
    # default: the first n // 10 samples
    assert get_window("force", 200).sum() == 20
    np.testing.assert_array_equal(get_window("force", 5), [1, 0, 0, 0, 0])


@pytest.mark.parametrize("decay_to", [0.5, 0.01, 1e-4])
def test_exponential_window_decays_to_stated_fraction_at_record_end(decay_to):
    n = 257
    w = get_window("exponential", n, decay_to=decay_to)
    assert w[0] == 1.0
    assert w[-1] == pytest.approx(decay_to, rel=1e-12)
    # a true exponential: constant ratio between consecutive samples
    ratios = w[1:] / w[:-1]
    np.testing.assert_allclose(ratios, decay_to ** (1 / (n - 1)), rtol=1e-12)


def test_exponential_default_decay_is_one_percent():
    assert get_window("exponential", 100)[-1] == pytest.approx(0.01, rel=1e-12)


def test_returned_windows_are_new_arrays():
    w = get_window("hann", 16)
    w[:] = 0.0
    assert get_window("hann", 16).max() == 1.0


def test_window_from_spec_forms():
    w, d = window_from_spec("Hamming", 32)
    np.testing.assert_array_equal(w, scipy.signal.get_window("hamming", 32))
    assert d == "hamming"
    w, d = window_from_spec(("force", 4), 32)
    assert w.sum() == 4 and d == "force(force_width=4)"
    w, d = window_from_spec(("exponential", 0.1), 32)
    assert w[-1] == pytest.approx(0.1) and d == "exponential(decay_to=0.1)"
    samples = np.linspace(0.0, 1.0, 32)
    w, d = window_from_spec(samples, 32)
    np.testing.assert_array_equal(w, samples)
    assert d == "custom"
    w[:] = 5.0  # the caller's array is copied, not shared
    assert samples[0] == 0.0


def test_window_errors():
    with pytest.raises(ValueError, match=r"Unknown window 'hanning'.*expected one of"):
        get_window("hanning", 8)
    with pytest.raises(ValueError, match=r"'n' parameter.*>= 1; got 0"):
        get_window("hann", 0)
    with pytest.raises(ValueError, match=r"'n' parameter must be an integer; got 8.0"):
        get_window("hann", 8.0)
    with pytest.raises(ValueError, match=r"'force_width'.*\[1, 8\].*got 9"):
        get_window("force", 8, force_width=9)
    with pytest.raises(ValueError, match=r"'decay_to'.*\(0, 1\).*got 1.5"):
        get_window("exponential", 8, decay_to=1.5)
    with pytest.raises(ValueError, match=r"'decay_to' parameter applies to the exponential"):
        get_window("hann", 8, decay_to=0.1)
    with pytest.raises(ValueError, match=r"'force_width' parameter applies to the force"):
        get_window("exponential", 8, force_width=2)
    with pytest.raises(ValueError, match=r"takes no parameter"):
        window_from_spec(("hann", 3), 8)
    with pytest.raises(ValueError, match=r"tuple must be \(name, parameter\).*length 3"):
        window_from_spec(("force", 3, 4), 8)
    with pytest.raises(ValueError, match=r"length 8 \(nperseg\); got length 5"):
        window_from_spec(np.ones(5), 8)
    with pytest.raises(ValueError, match=r"real 1-D array; got ndarray with shape \(2, 4\)"):
        window_from_spec(np.ones((2, 4)), 8)
    with pytest.raises(ValueError, match=r"must be finite"):
        window_from_spec(np.array([1.0, np.nan]), 2)
    with pytest.raises(ValueError, match=r"window' name must be a string.*got 3"):
        get_window(3, 8)
