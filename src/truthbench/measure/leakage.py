"""What an averaged H1 estimate measures: the true FRF seen through the spectral window.

With a stationary random input of flat spectrum, the expected cross- and auto-spectra of
windowed segments are the true ones convolved with the window's power spectrum
``|W(f)|^2`` (Bendat and Piersol, Random Data, ch. 8 and 9), so to first order in
1/averages::

    E[H1](f_k) = sum_m K_m H(f_k + m delta) U(f_k + m delta)
                 / sum_m K_m U(f_k + m delta),        K_m = |W(m delta)|^2,

with ``U`` the input's (flat, band-limited) spectrum and ``W`` the DTFT of the segment
window. For a periodic input (a record of ``period_samples`` samples repeated, what the
campaigns use) the input has lines only at multiples of ``delta = fs / period``, and the
sum is exact on that grid; otherwise ``delta`` is a fine grid standing for the
continuum. Near a lightly damped resonance this smoothing lowers and widens the peak: the
leakage bias that makes damping read from short segments too high (Figure 10.3,
:ref:`method-smoothing`). A model compared with such data should be compared through the same
window: :func:`expected_h1` does that, given a function that evaluates the model FRF.

Pure functions on arrays; nothing here estimates from data.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from truthbench._validation import check_number, readonly
from truthbench.measure.windows import get_window


@dataclass(frozen=True)
class LeakageKernel:
    """The smoothing an averaged H1 estimate applies to the true FRF.

    Attributes
    ----------
    delta_hz : float
        Grid spacing of the input's lines (periodic) or of the continuum's stand-in, Hz.
    offsets : ndarray of int, shape (2M + 1,)
        Kernel offsets in units of ``delta_hz``.
    weights : ndarray, shape (2M + 1,)
        ``|W(m delta)|^2``, normalised to sum 1.
    lines_per_bin : int
        Grid lines per segment bin (``fs / segment_samples`` over ``delta_hz``).
    correlation_lines : float
        ``1 + 2 sum_k rho_k``, rho_k the correlation of the estimate at bins k apart for
        noise, ``|DFT(w^2)(k)|^2 / (sum w^2)^2`` (1 for a rectangular window, about 1.3
        for Bartlett and Hann): the estimate's bins per independent value.
    """

    delta_hz: float
    offsets: np.ndarray
    weights: np.ndarray
    lines_per_bin: int
    correlation_lines: float = 1.0


@dataclass(frozen=True)
class Estimator:
    """How an averaged FRF estimate was made: its window, segments, averages, rate and
    overlap (what :func:`h1_kernel` needs, and what an :class:`~truthbench.measure.FRFData`
    carries about its estimate).

    Parameters
    ----------
    window : str
        Segment window name (:data:`~truthbench.measure.windows.WINDOW_NAMES`, without a
        parameter).
    segment_samples : int
        Segment length, samples (>= 2).
    fs_hz : float
        Sampling rate, Hz.
    period_samples : int, optional
        The input's period when it was periodic (a whole number of segments), else None.
    averages : int, optional
        Segments averaged (the H1 variance scales with 1 / averages), None when unknown.
    overlap_samples : int
        Samples shared by consecutive segments, ``0 <= overlap < segment``.

    The expected estimate (:meth:`kernel`) depends on the window, segment, rate and
    period only; averages and overlap set its variance.
    """

    window: str
    segment_samples: int
    fs_hz: float
    period_samples: int | None = None
    averages: int | None = None
    overlap_samples: int = 0

    def __post_init__(self):
        where = "Estimator"
        object.__setattr__(self, "segment_samples", check_number(
            "segment_samples", self.segment_samples, low=2, integer=True, where=where))
        object.__setattr__(self, "fs_hz", check_number("fs_hz", self.fs_hz, low=0,
                                                       low_open=True, where=where))
        if self.period_samples is not None:
            object.__setattr__(self, "period_samples", check_number(
                "period_samples", self.period_samples, low=self.segment_samples,
                integer=True, where=where))
        if self.averages is not None:
            object.__setattr__(self, "averages", check_number(
                "averages", self.averages, low=1, integer=True, where=where))
        object.__setattr__(self, "overlap_samples", check_number(
            "overlap_samples", self.overlap_samples, low=0, high=self.segment_samples,
            high_open=True, integer=True, where=where))

    def kernel(self) -> LeakageKernel:
        """The leakage kernel of this estimate (:func:`h1_kernel`)."""
        return h1_kernel(self.window, self.segment_samples, self.fs_hz,
                         period_samples=self.period_samples)

    def to_dict(self) -> dict:
        """The fields as JSON-ready values (``Estimator(**d)`` rebuilds it)."""
        return {"window": self.window, "segment_samples": int(self.segment_samples),
                "fs_hz": float(self.fs_hz), "period_samples": None
                if self.period_samples is None else int(self.period_samples),
                "averages": None if self.averages is None else int(self.averages),
                "overlap_samples": int(self.overlap_samples)}


def h1_kernel(window: str, segment_samples: int, fs_hz: float, *,
              period_samples: int | None = None, lines_per_bin: int = 8,
              tail: float = 1e-6, max_bins: int = 64) -> LeakageKernel:
    """The kernel of :func:`expected_h1` for a segment window.

    Parameters
    ----------
    window : str
        Segment window name (:func:`~truthbench.measure.get_window`).
    segment_samples : int
        Segment length, samples.
    fs_hz : float
        Sampling rate, Hz.
    period_samples : int, optional
        Period of a periodic input, samples; it must be a whole number of segments
        (the grid is then the input's own lines). None: a random input, the continuum
        stood in for by ``lines_per_bin`` lines per segment bin.
    tail : float
        Kernel weight left out at each side (the kernel is cut where the remaining
        ``|W|^2`` falls below this fraction of the total).
    max_bins : int
        Widest kernel half-width, segment bins.

    Returns
    -------
    LeakageKernel
    """
    n = check_number("segment_samples", segment_samples, low=2, integer=True,
                     where="h1_kernel")
    fs = check_number("fs_hz", fs_hz, low=0, low_open=True, where="h1_kernel")
    if period_samples is not None:
        period = check_number("period_samples", period_samples, low=n, integer=True,
                              where="h1_kernel")
        if period % n:
            raise ValueError(f"h1_kernel: 'period_samples' ({period}) must be a whole "
                             f"number of segments of {n} samples")
        lines_per_bin = period // n
    else:
        lines_per_bin = check_number("lines_per_bin", lines_per_bin, low=1, integer=True,
                                     where="h1_kernel")
    w = get_window(window, n)
    # |W|^2 on the grid m * fs / (n * lines_per_bin): zero-padded FFT
    P = np.abs(np.fft.fft(w, n * lines_per_bin)) ** 2
    half = min(max_bins * lines_per_bin, (n * lines_per_bin) // 2 - 1)
    m = np.arange(-half, half + 1)
    k = P[m % P.size]
    total = P.sum()
    # cut the tails: the smallest symmetric support keeping all but `tail` each side
    outside = total - np.cumsum(k[half:] + np.r_[0.0, k[:half][::-1]])
    keep = int(np.searchsorted(-outside, -2 * tail * total)) + 1
    keep = min(keep, half)
    sel = slice(half - keep, half + keep + 1)
    weights = k[sel] / k[sel].sum()
    w2 = w * w
    rho = np.abs(np.fft.fft(w2)) ** 2 / np.sum(w2) ** 2
    correlation = float(1.0 + 2.0 * np.sum(rho[1: n // 2]))
    return LeakageKernel(fs / (n * lines_per_bin), readonly(m[sel]), readonly(weights),
                         int(lines_per_bin), correlation)


def expected_h1(freq_hz, frf: Callable[[np.ndarray], np.ndarray], kernel: LeakageKernel,
                band_hz: tuple[float, float] | None = None) -> np.ndarray:
    """The expected H1 estimate at ``freq_hz`` of a system whose FRF is ``frf``.

    Parameters
    ----------
    freq_hz : array_like, shape (n_freq,)
        The estimate's lines, Hz: multiples of the segment bin ``kernel.delta_hz *
        kernel.lines_per_bin``.
    frf : callable
        ``frf(f) -> H``, shape (len(f), n_out, n_in), the true FRF at Hz ``f``.
    kernel : LeakageKernel
    band_hz : (float, float), optional
        The input's (flat) band; lines of the fine grid outside it carry no input. Default:
        every line carries input.

    Returns
    -------
    ndarray, complex, shape (n_freq, n_out, n_in)
        NaN at a line whose kernel meets no input line.
    """
    f = np.asarray(freq_hz, dtype=float)
    fine, on, S, norm = _smoothing(f, kernel, band_hz)
    Hf = np.zeros((fine.size,) + np.shape(frf(fine[:1]))[1:], dtype=complex)
    if on.any():
        Hf[on] = frf(fine[on])
    with np.errstate(invalid="ignore", divide="ignore"):
        out = (S @ Hf.reshape(fine.size, -1)) / norm[:, None]
    return out.reshape((f.size,) + Hf.shape[1:])


def _smoothing(f: np.ndarray, kernel: LeakageKernel, band_hz):
    """``(fine lines (Hz), which carry input, S, row sums of S)``: the sparse operator
    (n_freq, n_fine) that :func:`expected_h1` applies, for lines ``f``. A fit predicts
    the same lines through the same kernel hundreds of times, and the operator depends
    on nothing else: the last few are kept."""
    return _smoothing_of(np.ascontiguousarray(f, float).tobytes(), float(kernel.delta_hz),
                         np.asarray(kernel.offsets, np.int64).tobytes(),
                         np.asarray(kernel.weights, float).tobytes(),
                         None if band_hz is None else tuple(map(float, band_hz)))


@functools.lru_cache(maxsize=16)
def _smoothing_of(f_bytes: bytes, delta_hz: float, offsets_bytes: bytes,
                  weights_bytes: bytes, band_hz):
    f = np.frombuffer(f_bytes, float)
    offsets = np.frombuffer(offsets_bytes, np.int64)
    weights = np.frombuffer(weights_bytes, float)
    idx = np.rint(f / delta_hz).astype(np.int64)
    if np.any(np.abs(idx * delta_hz - f) > 1e-6 * delta_hz):
        raise ValueError("expected_h1: the lines are not on the kernel's grid (multiples "
                         f"of {delta_hz:g} Hz)")
    grid = np.unique((idx[:, None] + offsets[None, :]).ravel())
    fine = grid * delta_hz
    on = fine > 0
    if band_hz is not None:
        on &= (fine >= band_hz[0] - 1e-9 * delta_hz) & (fine <= band_hz[1] + 1e-9 * delta_hz)
    pos = np.searchsorted(grid, idx[:, None] + offsets[None, :])  # (n_freq, 2M+1)
    weight = weights[None, :] * on[pos]
    rows = np.repeat(np.arange(f.size), offsets.size)
    S = sp.csr_matrix((weight.ravel(), (rows, pos.ravel())), shape=(f.size, grid.size))
    norm = np.asarray(S.sum(axis=1)).ravel()
    for a in (fine, on, norm):
        a.flags.writeable = False
    return fine, on, S, norm
