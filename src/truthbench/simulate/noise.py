"""Sensor noise for simulated measurements.

Noise is white Gaussian, independent per channel, with a standard deviation set
relative to the clean signal of that channel:
``sigma_c = noise_to_signal_c * std(y_c)`` (population standard deviation, ``ddof=0``).

The *realised* ratio of one record, ``std(noise_c) / std(y_c)``, scatters around the
requested value: for ``N`` samples the sample standard deviation of white Gaussian noise
has a relative standard deviation of about ``1 / sqrt(2 N)`` (0.28 % for ``N = 2**16``).
"""

from __future__ import annotations

import numpy as np

__all__ = ["add_sensor_noise", "noise_to_signal_ratio"]


def _as_channels(name: str, y) -> tuple[np.ndarray, bool]:
    arr = np.asarray(y)
    if np.iscomplexobj(arr):
        raise ValueError(f"{name} must be real; got a complex array")
    arr = np.asarray(arr, dtype=float)
    if arr.ndim not in (1, 2):
        raise ValueError(
            f"{name} must have shape (n_channels, n_samples) or (n_samples,); got shape {arr.shape}"
        )
    one_d = arr.ndim == 1
    arr2 = arr[np.newaxis, :] if one_d else arr
    if arr2.shape[1] < 2:
        raise ValueError(f"{name} needs at least 2 samples per channel; got shape {arr.shape}")
    if not np.all(np.isfinite(arr2)):
        raise ValueError(f"{name} must be finite; got nan or inf")
    return arr2, one_d


def add_sensor_noise(y, noise_to_signal, rng: np.random.Generator) -> np.ndarray:
    """Return ``y`` plus white Gaussian noise scaled per channel to ``y``'s std.

    Parameters
    ----------
    y : array_like, shape (n_channels, n_samples) or (n_samples,)
        Clean signals, any unit. Not modified.
    noise_to_signal : float or array_like, shape (n_channels,)
        Requested ratio of noise std to signal std per channel (>= 0; e.g. 0.01 for 1 %).
    rng : numpy.random.Generator
        Source of the noise.

    Returns
    -------
    y_noisy : ndarray, same shape as ``y``
        A new array. A channel with zero std gets no noise.

    Raises
    ------
    ValueError
        Bad shape, non-finite ``y``, negative or mis-shaped ``noise_to_signal``.
    TypeError
        If ``rng`` is not a ``numpy.random.Generator``.
    """
    arr, one_d = _as_channels("y", y)
    n_ch = arr.shape[0]
    ratio = np.asarray(noise_to_signal, dtype=float)
    if ratio.ndim == 0:
        ratio = np.full(n_ch, float(ratio))
    if ratio.shape != (n_ch,):
        raise ValueError(
            f"noise_to_signal must be a scalar or have shape ({n_ch},) (one per channel); "
            f"got shape {ratio.shape}"
        )
    if not np.all(np.isfinite(ratio)) or np.any(ratio < 0.0):
        raise ValueError(f"noise_to_signal must be finite and >= 0; got {noise_to_signal!r}")
    if not isinstance(rng, np.random.Generator):
        raise TypeError(
            "rng must be a numpy.random.Generator (e.g. numpy.random.default_rng(seed)); "
            f"got {type(rng).__name__} instead"
        )
    sigma = ratio * np.std(arr, axis=1)
    noisy = arr + sigma[:, None] * rng.standard_normal(arr.shape)
    return noisy[0] if one_d else noisy


def noise_to_signal_ratio(y_clean, y_noisy) -> np.ndarray:
    """Realised noise-to-signal ratio per channel, ``std(y_noisy - y_clean) / std(y_clean)``.

    Parameters
    ----------
    y_clean : array_like, shape (n_channels, n_samples) or (n_samples,)
        Clean signals.
    y_noisy : array_like, same shape
        Noisy signals.

    Returns
    -------
    ratio : ndarray, shape (n_channels,)
        ``nan`` for a channel whose clean std is zero.

    Raises
    ------
    ValueError
        If the shapes differ or the data are not finite.
    """
    clean, _ = _as_channels("y_clean", y_clean)
    noisy, _ = _as_channels("y_noisy", y_noisy)
    if clean.shape != noisy.shape:
        raise ValueError(
            f"y_noisy must have the shape of y_clean {np.shape(y_clean)}; got {np.shape(y_noisy)}"
        )
    s_clean = np.std(clean, axis=1)
    s_noise = np.std(noisy - clean, axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(s_clean > 0, s_noise / np.where(s_clean > 0, s_clean, 1.0), np.nan)
