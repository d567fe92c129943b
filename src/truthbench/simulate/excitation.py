"""Excitation signals for simulated vibration tests.

All generators return real float64 arrays in the input's physical unit (e.g. N for a
force), sampled at ``fs_hz`` (``t_j = j / fs_hz``, s). Random signals take an explicit
``numpy.random.Generator``; nothing here touches global random state.

The band-limited signals are built in the frequency domain on the ``n_samples``-point
DFT grid (bin spacing ``fs_hz / n_samples``), so they are periodic with period
``n_samples`` and their periodogram is exactly zero (to rounding) outside the band:

* :func:`band_limited_random`, ``method="gaussian"`` (default): filtered Gaussian
  noise. White Gaussian samples are transformed, the bins outside the band are set to
  zero (an ideal, circular brick-wall filter) and transformed back. Being a linear map of
  Gaussian samples, the signal is Gaussian with an expected flat spectrum in the band.
* :func:`band_limited_random`, ``method="random_phase"``: random-phase multisine, an
  exactly flat amplitude in every in-band bin with independent uniform phases;
  Gaussian only asymptotically (central limit), but leakage-free and with no spectral
  dips, the better choice for FRF estimation with one period per block.
* :func:`periodic_chirp`: Schroeder-phase multisine (deterministic): flat amplitude,
  phases ``-pi k (k - 1) / K`` that make it a linear frequency sweep across the band once
  per period, with a low crest factor.

Each channel is finally scaled to exactly the requested RMS, ``sqrt(mean(x**2))``.
"""

from __future__ import annotations

import math
import numbers

import numpy as np

__all__ = ["band_limited_random", "periodic_chirp", "sine"]


def _check_positive_int(name: str, value, minimum: int) -> int:
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < minimum:
        raise ValueError(f"{name} must be an integer >= {minimum}; got {value!r}")
    return int(value)


def _check_positive_float(name: str, value, unit: str) -> float:
    try:
        out = float(value)
    except (TypeError, ValueError) as exc:
        raise ValueError(
            f"{name} must be a positive finite number in {unit}; got {value!r}"
        ) from exc
    if not math.isfinite(out) or out <= 0.0:
        raise ValueError(f"{name} must be a positive finite number in {unit}; got {value!r}")
    return out


def _check_rms(rms, n_channels: int) -> np.ndarray:
    arr = np.asarray(rms, dtype=float)
    if arr.ndim == 0:
        arr = np.full(n_channels, float(arr))
    if arr.shape != (n_channels,):
        raise ValueError(
            f"rms must be a scalar or have shape ({n_channels},) (one per channel); "
            f"got shape {arr.shape}"
        )
    if not np.all(np.isfinite(arr)) or np.any(arr < 0.0):
        raise ValueError(f"rms must be finite and >= 0; got {rms!r}")
    return arr


def _check_rng(rng) -> np.random.Generator:
    if not isinstance(rng, np.random.Generator):
        raise TypeError(
            "rng must be a numpy.random.Generator (e.g. numpy.random.default_rng(seed)); "
            f"got {type(rng).__name__} instead"
        )
    return rng


def _band_bins(n_samples: int, fs_hz: float, band_hz) -> np.ndarray:
    """Indices of the rfft bins with ``f_lo <= f <= f_hi``."""
    try:
        f_lo, f_hi = (float(f) for f in band_hz)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"band_hz must be a pair (f_lo, f_hi) in Hz; got {band_hz!r}") from exc
    nyquist = fs_hz / 2.0
    if not (math.isfinite(f_lo) and math.isfinite(f_hi) and 0.0 <= f_lo < f_hi <= nyquist):
        raise ValueError(
            f"band_hz must satisfy 0 <= f_lo < f_hi <= fs_hz/2 = {nyquist:g} Hz; got {band_hz!r}"
        )
    freq = np.fft.rfftfreq(n_samples, d=1.0 / fs_hz)
    # a relative tolerance so that band edges given exactly on a bin are included
    tol = 1e-9 * fs_hz / n_samples
    bins = np.flatnonzero((freq >= f_lo - tol) & (freq <= f_hi + tol))
    if bins.size == 0:
        raise ValueError(
            f"band_hz {band_hz!r} contains no frequency bin of the {n_samples}-sample "
            f"record (bin spacing {fs_hz / n_samples:g} Hz); widen the band or use more "
            "samples"
        )
    return bins


def _scale_rms(x: np.ndarray, rms: np.ndarray) -> np.ndarray:
    current = np.sqrt(np.mean(x * x, axis=-1))
    factor = np.divide(rms, current, out=np.zeros_like(rms), where=current > 0)
    return x * factor[:, None]


def band_limited_random(
    n_samples: int,
    fs_hz: float,
    rms,
    band_hz,
    rng: np.random.Generator,
    n_inputs: int = 1,
    *,
    method: str = "gaussian",
) -> np.ndarray:
    """Band-limited random excitation with a flat spectrum in ``band_hz``.

    Parameters
    ----------
    n_samples : int
        Record length (>= 2). The signal is periodic with this period.
    fs_hz : float
        Sampling frequency, Hz.
    rms : float or array_like, shape (n_inputs,)
        Exact RMS of each channel, ``sqrt(mean(x**2))``, in the input's unit.
    band_hz : tuple of float
        ``(f_lo, f_hi)`` with ``0 <= f_lo < f_hi <= fs_hz / 2``, Hz. DFT bins with
        ``f_lo <= f <= f_hi`` are excited; all others are exactly zero.
    rng : numpy.random.Generator
        Source of randomness (channels are independent).
    n_inputs : int, optional
        Number of independent channels.
    method : {"gaussian", "random_phase"}, optional
        ``"gaussian"``: filtered Gaussian noise (ideal frequency-domain brick-wall filter
        of white Gaussian samples). ``"random_phase"``: random-phase multisine, flat
        amplitude in every in-band bin. See the module docstring.

    Returns
    -------
    x : ndarray, shape (n_inputs, n_samples)
        Excitation samples at ``t_j = j / fs_hz``.

    Raises
    ------
    ValueError
        Bad sizes, rates, RMS, a band outside ``[0, fs_hz/2]`` or containing no DFT bin,
        or an unknown method.
    TypeError
        If ``rng`` is not a ``numpy.random.Generator``.
    """
    n_samples = _check_positive_int("n_samples", n_samples, 2)
    n_inputs = _check_positive_int("n_inputs", n_inputs, 1)
    fs_hz = _check_positive_float("fs_hz", fs_hz, "Hz")
    rms_arr = _check_rms(rms, n_inputs)
    bins = _band_bins(n_samples, fs_hz, band_hz)
    rng = _check_rng(rng)
    n_bins = n_samples // 2 + 1
    if method == "gaussian":
        white = rng.standard_normal((n_inputs, n_samples))
        spectrum = np.fft.rfft(white, axis=-1)
        mask = np.zeros(n_bins, dtype=bool)
        mask[bins] = True
        spectrum[:, ~mask] = 0.0
    elif method == "random_phase":
        phase = rng.uniform(0.0, 2.0 * np.pi, size=(n_inputs, bins.size))
        values = np.exp(1j * phase)
        # DC and (even n) Nyquist bins must be real: keep a random sign
        real_bins = (bins == 0) | ((n_samples % 2 == 0) & (bins == n_bins - 1))
        values[:, real_bins] = np.where(np.cos(phase[:, real_bins]) >= 0.0, 1.0, -1.0)
        spectrum = np.zeros((n_inputs, n_bins), dtype=complex)
        spectrum[:, bins] = values
    else:
        raise ValueError(f"method must be 'gaussian' or 'random_phase'; got {method!r} instead")
    x = np.fft.irfft(spectrum, n=n_samples, axis=-1)
    return _scale_rms(x, rms_arr)


def periodic_chirp(n_samples: int, fs_hz: float, rms, band_hz) -> np.ndarray:
    """Periodic chirp: a Schroeder-phase multisine sweeping ``band_hz`` once per period.

    Every DFT bin in the band gets the same amplitude; bin ``k`` (counted from 1 at the
    lowest in-band bin, ``K`` bins in all) gets the phase ``-pi k (k - 1) / K``, which
    makes the signal a linear sweep from ``f_lo`` to ``f_hi`` over the record with a low
    crest factor. Deterministic.

    Parameters
    ----------
    n_samples : int
        Record length (>= 2), the period.
    fs_hz : float
        Sampling frequency, Hz.
    rms : float
        Exact RMS of the signal.
    band_hz : tuple of float
        ``(f_lo, f_hi)`` with ``0 <= f_lo < f_hi <= fs_hz / 2``, Hz.

    Returns
    -------
    x : ndarray, shape (n_samples,)

    Raises
    ------
    ValueError
        Bad sizes, rates, RMS or band.
    """
    n_samples = _check_positive_int("n_samples", n_samples, 2)
    fs_hz = _check_positive_float("fs_hz", fs_hz, "Hz")
    rms_arr = _check_rms(rms, 1)
    bins = _band_bins(n_samples, fs_hz, band_hz)
    n_bins = n_samples // 2 + 1
    k = np.arange(1, bins.size + 1)
    phase = -np.pi * k * (k - 1) / bins.size
    values = np.exp(1j * phase)
    real_bins = (bins == 0) | ((n_samples % 2 == 0) & (bins == n_bins - 1))
    values[real_bins] = np.where(np.cos(phase[real_bins]) >= 0, 1.0, -1.0)
    spectrum = np.zeros((1, n_bins), dtype=complex)
    spectrum[0, bins] = values
    x = np.fft.irfft(spectrum, n=n_samples, axis=-1)
    return _scale_rms(x, rms_arr)[0]


def sine(
    n_samples: int, fs_hz: float, freq_hz: float, amplitude: float = 1.0, phase_rad: float = 0.0
) -> np.ndarray:
    """Stepped-sine dwell: ``amplitude * sin(2 pi freq_hz t + phase_rad)``.

    Parameters
    ----------
    n_samples : int
        Number of samples (>= 1).
    fs_hz : float
        Sampling frequency, Hz.
    freq_hz : float
        Frequency, Hz, ``0 <= freq_hz <= fs_hz / 2``.
    amplitude : float, optional
        Peak amplitude (RMS is ``amplitude / sqrt(2)`` over whole periods).
    phase_rad : float, optional
        Phase at ``t = 0``, rad.

    Returns
    -------
    x : ndarray, shape (n_samples,)

    Raises
    ------
    ValueError
        Bad sizes or rates, or a frequency above Nyquist.
    """
    n_samples = _check_positive_int("n_samples", n_samples, 1)
    fs_hz = _check_positive_float("fs_hz", fs_hz, "Hz")
    freq = float(freq_hz)
    if not math.isfinite(freq) or not 0.0 <= freq <= fs_hz / 2.0:
        raise ValueError(f"freq_hz must be in [0, fs_hz/2 = {fs_hz / 2:g}] Hz; got {freq_hz!r}")
    amp = float(amplitude)
    ph = float(phase_rad)
    if not (math.isfinite(amp) and math.isfinite(ph)):
        raise ValueError(
            f"amplitude and phase_rad must be finite; got {amplitude!r}, {phase_rad!r}"
        )
    t = np.arange(n_samples) / fs_hz
    return amp * np.sin(2.0 * np.pi * freq * t + ph)
