"""measure: FRF estimation from time histories (windows, spectra, H1/H2/Hv, coherence).

The room owns everything between sampled input/output records and an estimated
frequency response matrix:

* :mod:`~truthbench.measure.windows` -- data windows by name (periodic scipy windows and
  the impact-test force and exponential windows);
* :mod:`~truthbench.measure.spectra` -- the one spectral engine: segmenting, windowing,
  blockwise FFTs with the products summed while in cache, averaged one-sided density
  matrices Gxx, Gyx, Gyy;
* :mod:`~truthbench.measure.frf` -- the estimators H1, H2, Hv (a registry by name),
  ordinary and multiple coherence, and the :class:`FRFEstimate` result;
* :mod:`~truthbench.measure.frfdata` -- :class:`FRFData`, the one FRF data type every
  room exchanges, its :class:`Channel` and :func:`match_points` (points to model nodes);
* :mod:`~truthbench.measure.time_frf` -- :func:`frfs_from_time`: impact and random time
  records to H1 FRFs with their default bands.

Conventions fixed for the project: ``H`` has shape ``(n_freq, n_out, n_in)`` with
``Y = H X``, ``freq_hz`` shape ``(n_freq,)``; ``y = h * x`` gives ``H = DFT(h)``.
Pure functions on numpy arrays; no I/O, no printing, inputs never changed.
"""

from truthbench.measure.frf import (
    ESTIMATORS,
    FRFEstimate,
    FRFEstimator,
    estimate_frf,
    frf_from_spectra,
    h1,
    h2,
    hv,
)
from truthbench.measure.frfdata import Channel, FRFData, match_points
from truthbench.measure.spectra import (
    SegmentPlan,
    SpectralMatrices,
    fft_friendly_length,
    plan_segments,
    spectral_matrices,
)
from truthbench.measure.time_frf import find_pulse, frfs_from_time
from truthbench.measure.windows import WINDOW_NAMES, get_window, window_from_spec

__all__ = [
    "ESTIMATORS",
    "Channel",
    "FRFData",
    "FRFEstimate",
    "FRFEstimator",
    "SegmentPlan",
    "SpectralMatrices",
    "WINDOW_NAMES",
    "estimate_frf",
    "fft_friendly_length",
    "find_pulse",
    "frf_from_spectra",
    "frfs_from_time",
    "get_window",
    "h1",
    "h2",
    "hv",
    "match_points",
    "plan_segments",
    "spectral_matrices",
    "window_from_spec",
]
