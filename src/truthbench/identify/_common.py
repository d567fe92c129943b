"""Private helpers of the identify room: input checks and FRF-type bookkeeping.

Every check copies (never views into) the caller's arrays and raises with a message that
names the parameter, what was expected and what was received.
"""

from __future__ import annotations

import numpy as np

from truthbench._validation import readonly  # noqa: F401 - the room's modules import it here
from truthbench.quantities import MOTION_QUANTITIES, quantity

#: Power ``q`` of ``j omega`` that turns a displacement FRF into the given type:
#: ``H_type = (j omega)^q H_displacement``, from the one table of quantities.
FRF_TYPES: dict[str, int] = {name: quantity(name).power for name in MOTION_QUANTITIES}


def frf_power(frf_type: str) -> int:
    """Return ``q`` with ``H_type = (j omega)^q H_displacement`` for an FRF type name."""
    try:
        return FRF_TYPES[frf_type]
    except (KeyError, TypeError):
        raise ValueError(
            f"The 'frf_type' parameter must be one of {sorted(FRF_TYPES)}; "
            f"got {frf_type!r} instead."
        ) from None


def check_freq_frf(freq_hz, frf) -> tuple[np.ndarray, np.ndarray]:
    """Validate a frequency axis and an FRF array; return float and complex copies.

    Parameters
    ----------
    freq_hz : array_like, shape (n_freq,)
        Frequency lines in Hz, finite, non-negative and strictly increasing.
    frf : array_like, shape (n_freq, n_out, n_in) or (n_freq,)
        FRF; a 1-D array is taken as a single output and input.

    Returns
    -------
    freq_hz : ndarray, shape (n_freq,)
    frf : ndarray, complex, shape (n_freq, n_out, n_in)
    """
    f = np.array(freq_hz, dtype=float, copy=True)
    if f.ndim != 1:
        raise ValueError(
            f"The 'freq_hz' parameter must be 1-D of shape (n_freq,); got shape {f.shape}."
        )
    if f.size < 2:
        raise ValueError(f"The 'freq_hz' parameter must hold at least 2 lines; got {f.size}.")
    if not np.all(np.isfinite(f)) or np.any(f < 0):
        raise ValueError("The 'freq_hz' parameter must be finite and non-negative.")
    if np.any(np.diff(f) <= 0):
        raise ValueError("The 'freq_hz' parameter must be strictly increasing.")
    H = np.array(frf, dtype=complex, copy=True)
    if H.ndim == 1:
        H = H[:, None, None]
    if H.ndim != 3:
        raise ValueError(
            "The 'frf' parameter must have shape (n_freq, n_out, n_in) (or (n_freq,) for "
            f"one channel); got {H.ndim} dimensions, shape {H.shape}."
        )
    if H.shape[0] != f.size:
        raise ValueError(
            f"The 'frf' parameter has {H.shape[0]} frequency lines (axis 0) but "
            f"'freq_hz' has {f.size}; expected the same number."
        )
    if H.shape[1] == 0 or H.shape[2] == 0:
        raise ValueError(f"The 'frf' parameter has an empty channel axis: shape {H.shape}.")
    if not np.all(np.isfinite(H)):
        raise ValueError("The 'frf' parameter must be finite (no NaN or inf).")
    return f, H


def select_band(
    freq_hz: np.ndarray, frf: np.ndarray, freq_range_hz
) -> tuple[np.ndarray, np.ndarray]:
    """Keep the lines with ``lo <= f <= hi``; ``freq_range_hz=None`` keeps all."""
    if freq_range_hz is None:
        return freq_hz, frf
    try:
        lo, hi = (float(v) for v in freq_range_hz)
    except (TypeError, ValueError):
        raise ValueError(
            "The 'freq_range_hz' parameter must be a pair (low, high) in Hz; "
            f"got {freq_range_hz!r}."
        ) from None
    if not lo < hi:
        raise ValueError(
            f"The 'freq_range_hz' parameter must satisfy low < high; got ({lo}, {hi})."
        )
    keep = (freq_hz >= lo) & (freq_hz <= hi)
    if np.count_nonzero(keep) < 2:
        raise ValueError(
            f"The 'freq_range_hz' band ({lo}, {hi}) Hz holds {np.count_nonzero(keep)} "
            f"frequency lines of 'freq_hz' (range {freq_hz[0]}..{freq_hz[-1]} Hz); "
            "expected at least 2."
        )
    return freq_hz[keep], frf[keep]


def as_shape_matrix(phi, name: str) -> np.ndarray:
    """Return a copy of ``phi`` as a 2-D array (n_dof, n_modes); 1-D means one mode."""
    a = np.array(phi, copy=True)
    if a.dtype.kind not in "fc":
        a = a.astype(float)
    if a.ndim == 1:
        a = a[:, None]
    if a.ndim != 2:
        raise ValueError(
            f"The '{name}' parameter must have shape (n_dof, n_modes) or (n_dof,); "
            f"got shape {a.shape}."
        )
    if not np.all(np.isfinite(a)):
        raise ValueError(f"The '{name}' parameter must be finite (no NaN or inf).")
    return a
