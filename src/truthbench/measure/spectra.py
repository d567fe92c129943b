"""The spectral engine: segmenting, windowing, FFT, and averaged spectral matrices.

One private engine (:func:`_segment_sums`, :func:`_assemble`) serves every
estimator of :mod:`truthbench.measure.frf`, in the manner of ``scipy.signal._spectral_py``.
The public entry points are :func:`spectral_matrices` (validated inputs in, a frozen
:class:`SpectralMatrices` out), :func:`plan_segments` (how a record is cut into
segments) and :func:`fft_friendly_length`.

Conventions
-----------
* Inputs ``x`` have shape ``(n_in, N)`` or ``(N,)``, outputs ``y`` ``(n_out, N)`` or
  ``(N,)``, both sampled at ``fs_hz``.
* Spectra are one-sided and density-scaled exactly like
  ``scipy.signal.csd(..., scaling="density")``: for the DFTs ``X_s``, ``Y_s`` of the
  windowed segments ``s = 1..n_averages``,
  ``G_ab(f) = c(f) / (fs_hz * sum(w**2) * n_averages) * sum_s A_s(f) conj(B_s(f))``
  with ``c = 2`` except at 0 Hz and (even ``nperseg``) at the Nyquist line, where
  ``c = 1``.  Units: (unit of a)(unit of b)/Hz.
* ``Gxx[f, i, j] = E[X_i conj(X_j)]``, ``Gyx[f, o, i] = E[Y_o conj(X_i)]``, so that
  ``Gyx = H Gxx`` for ``Y = H X``.  In scipy's argument order
  ``Gyx[:, o, i] == scipy.signal.csd(x[i], y[o])[1]``.
* Frequencies ``freq_hz = numpy.fft.rfftfreq(nperseg, 1 / fs_hz)``.

Performance: the segments are windowed, transformed (``scipy.fft.rfft``) and their
products summed block by block, so that no array of all the segment DFTs is ever formed.
On one thread each channel's block (about 1 MiB of samples) is transformed on its own
and its products are summed at once, while its DFTs are in cache; with several FFT
``workers`` the blocks of all channels go to one batched rfft.  Only the products the
estimators need are formed: the auto-spectra of every channel, the inputs against the
later inputs and the outputs, and the outputs against each other only for
``output_cross``.  The sums run in a numba-compiled loop when numba (optional) imports
and the spectra are large, else in numpy; both give the same sums to rounding.  The FFT
is fastest for 5-smooth segment lengths (``2**a 3**b 5**c``); see
:func:`fft_friendly_length` and ``nperseg="fast"``.  An explicit integer ``nperseg`` is
always used as given.
"""

from __future__ import annotations

import functools
import operator
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
import scipy.fft

from truthbench.errors import DataFormatError
from truthbench.measure.windows import WindowSpec, window_from_spec

__all__ = [
    "SegmentPlan",
    "SpectralMatrices",
    "fft_friendly_length",
    "plan_segments",
    "spectral_matrices",
]

#: Raised for an invalid option (as opposed to invalid data, which raises
#: :class:`~truthbench.errors.DataFormatError`).  A plain ``ValueError`` until
#: ``truthbench.errors`` grows a class for bad settings; swap it here when it does.
_SettingError = ValueError

Detrend = Literal["constant"] | Literal[False] | None


# --------------------------------------------------------------------------- lengths


def fft_friendly_length(n: int) -> int:
    """Return the largest 5-smooth integer ``2**a * 3**b * 5**c`` that is ``<= n``.

    The downward analogue of ``scipy.fft.next_fast_len(n, real=True)``: use it to shorten
    a segment so that its FFT is fast without needing more data than is recorded.

    Parameters
    ----------
    n : int
        Upper bound, ``n >= 1``.

    Returns
    -------
    int
        The largest 5-smooth length not exceeding `n` (``n`` itself if it is 5-smooth).

    Examples
    --------
    >>> fft_friendly_length(104857)  # 23 * 47 * 97 -> 2**8 * 3**4 * 5
    103680
    >>> fft_friendly_length(1024)
    1024
    """
    bound = _as_int(n, "n")
    if bound < 1:
        raise _SettingError(f"The 'n' parameter of fft_friendly_length must be >= 1; got {n!r}.")
    best = 1
    p5 = 1
    while p5 <= bound:
        p35 = p5
        while p35 <= bound:
            # largest power of two with p35 * 2**k <= bound
            candidate = p35 << ((bound // p35).bit_length() - 1)
            best = max(best, candidate)
            p35 *= 3
        p5 *= 5
    return best


# --------------------------------------------------------------------------- segments


@dataclass(frozen=True)
class SegmentPlan:
    """How a record of ``n_samples`` samples is cut into averaged segments.

    Segment ``s`` (``s = 0 .. n_averages - 1``) covers samples
    ``[s * step, s * step + nperseg)``; samples from ``n_used`` on are not used.

    Attributes
    ----------
    n_samples : int
        Record length N (samples).
    nperseg : int
        Segment length (samples); the line spacing is ``fs_hz / nperseg``.
    noverlap : int
        Samples shared by consecutive segments.
    n_averages : int
        Number of segments averaged.
    """

    n_samples: int
    nperseg: int
    noverlap: int
    n_averages: int

    @property
    def step(self) -> int:
        """Samples between segment starts, ``nperseg - noverlap``."""
        return self.nperseg - self.noverlap

    @property
    def n_used(self) -> int:
        """Samples actually used, ``(n_averages - 1) * step + nperseg``."""
        return (self.n_averages - 1) * self.step + self.nperseg


def plan_segments(
    n_samples: int,
    *,
    nperseg: int | Literal["fast"] | None = None,
    n_averages: int | None = None,
    noverlap: int = 0,
) -> SegmentPlan:
    """Decide the segment length, overlap and number of averages for a record.

    Parameters
    ----------
    n_samples : int
        Record length N (samples).
    nperseg : int, "fast" or None
        Segment length.  An integer is used exactly as given.  ``None``: if `n_averages`
        is given, the longest segment that fits `n_averages` times with `noverlap`
        overlap, ``(N + (n_averages - 1) * noverlap) // n_averages`` (``N //
        n_averages`` without overlap); otherwise the whole record (one average).
        ``"fast"``: as ``None``, then shortened to :func:`fft_friendly_length` of that.
    n_averages : int or None
        Number of segments to average.  ``None``: as many as fit,
        ``1 + (N - nperseg) // (nperseg - noverlap)`` (trailing samples that do not fill
        a segment are ignored, as in ``scipy.signal.csd``).  If given, exactly this many
        segments are used, from the start of the record.
    noverlap : int
        Overlap between consecutive segments (samples), ``0 <= noverlap < nperseg``.

    Returns
    -------
    SegmentPlan

    Raises
    ------
    DataFormatError
        If the record is shorter than one segment or too short for `n_averages`
        segments.
    ValueError
        For invalid option values.
    """
    n_total = _as_int(n_samples, "n_samples")
    if n_total < 1:
        raise DataFormatError(f"The record must have at least 1 sample; got {n_total}.")
    overlap = _as_int(noverlap, "noverlap")
    if overlap < 0:
        raise _SettingError(f"The 'noverlap' parameter must be >= 0; got {noverlap!r}.")
    n_avg = None
    if n_averages is not None:
        n_avg = _as_int(n_averages, "n_averages")
        if n_avg < 1:
            raise _SettingError(f"The 'n_averages' parameter must be >= 1; got {n_averages!r}.")

    fast = isinstance(nperseg, str)
    if fast and nperseg != "fast":
        raise _SettingError(
            f"The 'nperseg' parameter must be a positive integer, 'fast' or None; got {nperseg!r}."
        )
    if nperseg is None or fast:
        if n_avg is None:
            length = n_total
        else:
            length = (n_total + (n_avg - 1) * overlap) // n_avg
        if fast and length >= 1:
            length = fft_friendly_length(length)
        if length <= overlap:
            raise DataFormatError(
                f"The record of {n_total} samples is too short for "
                f"n_averages={n_avg} segments with noverlap={overlap}: the segment length "
                f"would be {length} samples, which must exceed noverlap."
            )
    else:
        length = _as_int(nperseg, "nperseg")
        if length < 1:
            raise _SettingError(f"The 'nperseg' parameter must be >= 1; got {nperseg!r}.")
        if length > n_total:
            raise DataFormatError(
                f"The segment (nperseg={length} samples) is longer than the record "
                f"({n_total} samples); expected nperseg <= {n_total}."
            )
    if overlap >= length:
        raise _SettingError(
            f"The 'noverlap' parameter must be smaller than nperseg={length}; got {overlap}."
        )
    step = length - overlap
    fitting = 1 + (n_total - length) // step
    if n_avg is None:
        n_avg = fitting
    elif n_avg > fitting:
        raise DataFormatError(
            f"The record of {n_total} samples holds only {fitting} segments of "
            f"nperseg={length} with noverlap={overlap}; n_averages={n_avg} needs "
            f"{(n_avg - 1) * step + length} samples."
        )
    return SegmentPlan(n_samples=n_total, nperseg=length, noverlap=overlap, n_averages=n_avg)


# --------------------------------------------------------------------------- results


@dataclass(frozen=True, eq=False)
class SpectralMatrices:
    """Averaged one-sided spectral density matrices of inputs x and outputs y.

    Attributes
    ----------
    freq_hz : numpy.ndarray
        Shape ``(n_freq,)``, Hz.
    Gxx : numpy.ndarray
        Shape ``(n_freq, n_in, n_in)``, complex, Hermitian in the last two axes:
        ``Gxx[f, i, j] = E[X_i conj(X_j)]``, (unit of x)**2/Hz.
    Gyx : numpy.ndarray
        Shape ``(n_freq, n_out, n_in)``, complex: ``Gyx[f, o, i] = E[Y_o conj(X_i)]``,
        (unit of y)(unit of x)/Hz.
    Gyy : numpy.ndarray
        Shape ``(n_freq, n_out)``, real: the output auto-spectra (the diagonal of the
        output spectral matrix), (unit of y)**2/Hz.
    Gyy_full : numpy.ndarray or None
        Shape ``(n_freq, n_out, n_out)``, complex, ``E[Y_o conj(Y_p)]``; only when asked
        for (``output_cross=True``), else None.
    fs_hz : float
        Sampling frequency, Hz.
    plan : SegmentPlan
        Segment length, overlap and number of averages used.
    window : str
        Description of the window (``"bartlett"``, ``"custom"``, ...).
    detrend : str
        ``"none"`` or ``"constant"`` (the mean of each segment removed before windowing).
    """

    freq_hz: np.ndarray
    Gxx: np.ndarray
    Gyx: np.ndarray
    Gyy: np.ndarray
    Gyy_full: np.ndarray | None
    fs_hz: float
    plan: SegmentPlan
    window: str
    detrend: str

    def __post_init__(self) -> None:
        for name in ("freq_hz", "Gxx", "Gyx", "Gyy", "Gyy_full"):
            value = getattr(self, name)
            if value is not None:
                object.__setattr__(self, name, _read_only(value))

    @property
    def n_inputs(self) -> int:
        """Number of input channels."""
        return self.Gxx.shape[1]

    @property
    def n_outputs(self) -> int:
        """Number of output channels."""
        return self.Gyx.shape[1]


def _read_only(a: np.ndarray) -> np.ndarray:
    view = np.asarray(a).view()
    view.flags.writeable = False
    return view


# --------------------------------------------------------------------------- validation


def _as_int(value: Any, name: str) -> int:
    if isinstance(value, bool):
        raise _SettingError(f"The '{name}' parameter must be an integer; got {value!r}.")
    try:
        return operator.index(value)
    except TypeError:
        raise _SettingError(
            f"The '{name}' parameter must be an integer; got {value!r} ({type(value).__name__})."
        ) from None


def _as_fs(fs_hz: Any) -> float:
    try:
        fs = float(fs_hz)
    except (TypeError, ValueError):
        raise _SettingError(
            f"The 'fs_hz' parameter must be a positive finite number (Hz); got {fs_hz!r}."
        ) from None
    if isinstance(fs_hz, bool) or not np.isfinite(fs) or fs <= 0.0:
        raise _SettingError(
            f"The 'fs_hz' parameter must be a positive finite number (Hz); got {fs_hz!r}."
        )
    return fs


def _as_channels(data: Any, name: str, role: str) -> np.ndarray:
    """Return `data` as a real 2-D ``(n_channels, N)`` array without copying if possible."""
    a = np.asarray(data)
    if a.dtype.kind == "c":
        raise DataFormatError(
            f"The '{name}' {role} time histories must be real; got dtype {a.dtype}."
        )
    if a.dtype.kind not in "biuf":
        try:
            a = a.astype(float)
        except (TypeError, ValueError):
            raise DataFormatError(
                f"The '{name}' {role} time histories must be real numbers; got dtype {a.dtype}."
            ) from None
    if a.ndim == 1:
        a = a[np.newaxis, :]
    elif a.ndim != 2:
        raise DataFormatError(
            f"The '{name}' {role} time histories must have shape (n_channels, N) or (N,); "
            f"got {a.ndim} dimensions, shape {a.shape}."
        )
    if a.shape[0] == 0:
        raise DataFormatError(
            f"The '{name}' {role} array has no channel: shape {a.shape}; expected "
            f"(n_channels, N) with n_channels >= 1."
        )
    if a.shape[1] == 0:
        raise DataFormatError(
            f"The '{name}' {role} time histories are empty: shape {a.shape}; expected "
            f"N >= 1 samples."
        )
    return a


def _require_finite(a: np.ndarray, name: str, role: str, first_sample: int = 0) -> None:
    """Raise DataFormatError naming the first NaN/inf sample of `a`, if there is one.

    `first_sample` is the index in the record of the first column of `a`.
    """
    if a.dtype.kind != "f":
        return
    bad = ~np.isfinite(a)
    if bad.any():
        channel, sample = (int(v[0]) for v in np.nonzero(bad))
        raise DataFormatError(
            f"The '{name}' {role} time histories must be finite; got {int(bad.sum())} "
            f"NaN/inf samples, the first in channel {channel} at sample "
            f"{first_sample + sample}."
        )


def _check_finite(xa: np.ndarray, ya: np.ndarray, plan: SegmentPlan, spectra: tuple) -> None:
    """Finiteness of the data, at no cost on the good path.

    A NaN or inf sample in a segment makes that segment's transform, hence the averaged
    auto-spectra, non-finite; so the data are scanned only if the auto-spectra are not
    finite (or for the unused tail, which the spectra do not see).
    """
    gxx, _, gyy, _ = spectra
    tail = slice(plan.n_used, None)
    _require_finite(xa[:, tail], "x", "input", plan.n_used)
    _require_finite(ya[:, tail], "y", "output", plan.n_used)
    if np.isfinite(np.einsum("fii->fi", gxx).real).all() and np.isfinite(gyy).all():
        return
    _require_finite(xa, "x", "input")
    _require_finite(ya, "y", "output")
    raise DataFormatError(
        "The spectra of the finite 'x'/'y' data overflowed (samples beyond about "
        "1e150); rescale the time histories."
    )


def _as_detrend(detrend: Any) -> str:
    if detrend is None or detrend is False or detrend == "none":
        return "none"
    if detrend == "constant":
        return "constant"
    raise _SettingError(
        f"The 'detrend' parameter must be False/None/'none' or 'constant'; got {detrend!r}."
    )


# --------------------------------------------------------------------------- engine

#: Bytes of windowed samples per block: whole segments, as many as fit (at least one).
#: Single-threaded, the block of one channel is transformed and its products are
#: accumulated at once, while its DFTs are still in cache (1 MiB: about an L2 cache);
#: with several FFT workers, the blocks of all channels go to one batched rfft.
_BLOCK_BYTES = 1 << 20

#: Size of the spectra (channels x segments x lines, complex values) from which the
#: compiled product kernel is used if numba imports.  Below it the numpy products cost
#: less than importing numba and loading its cached kernel (about 0.5 s, once per
#: process).
_NUMBA_MIN_VALUES = 1 << 20


def _segment_views(a: np.ndarray, plan: SegmentPlan) -> np.ndarray:
    """Read-only view ``(n_ch, n_averages, nperseg)`` of the segments of `a`."""
    windows = np.lib.stride_tricks.sliding_window_view(a[:, : plan.n_used], plan.nperseg, axis=-1)
    return windows[:, :: plan.step]


def _cross_row(b: int, a: int, n_ch: int) -> int:
    """Row of ``sum_s Z_a conj(Z_b)`` (``b < a``) in the cross sums.

    Each paired channel ``b`` (see :func:`_segment_sums`) pairs with all later channels
    ``a = b + 1 .. n_ch - 1``; the rows are ordered by ``b``, then ``a``.
    """
    return b * (n_ch - 1) - b * (b - 1) // 2 + (a - b - 1)


def _accumulate_loops(
    zc: np.ndarray,
    partners: np.ndarray,
    c: int,
    n_paired: int,
    auto: np.ndarray,
    cross: np.ndarray,
) -> None:  # pragma: no cover - compiled by numba, exercised through _compiled_accumulate
    """Add the products of channel `c` in a block of segments to the sums.

    Written in loops for numba; one pass over the lines for the auto product and the
    product with channel 0, and one for each further partner.

    Parameters
    ----------
    zc : numpy.ndarray
        DFTs of channel `c`, ``(n_seg, n_freq)``, complex, C-contiguous.
    partners : numpy.ndarray
        ``(n, n_seg, n_freq)``, complex, C-contiguous: the DFTs of the same segments of
        the channels ``b = 0 .. min(c, n_paired) - 1``, which pair with `c`.
    c : int
        Channel index.
    n_paired : int
        Channels ``0 .. n_paired - 1`` pair with every later channel.
    auto : numpy.ndarray
        ``(n_ch, n_freq)``, float: ``auto[c] += sum_s |zc[s]|**2``, in place.
    cross : numpy.ndarray
        ``(n_rows, n_freq)``, complex, in place: ``cross[_cross_row(b, c, n_ch)] +=
        sum_s zc[s] conj(partners[b, s])``.
    """
    n_seg, n_freq = zc.shape
    n_ch = auto.shape[0]
    sums = auto[c]
    for s in range(n_seg):
        z = zc[s]
        if c == 0 or n_paired == 0:
            for f in range(n_freq):
                v = z[f]
                sums[f] += v.real * v.real + v.imag * v.imag
            continue
        z0 = partners[0, s]
        pair = cross[c - 1]  # _cross_row(0, c, n_ch)
        for f in range(n_freq):
            v = z[f]
            sums[f] += v.real * v.real + v.imag * v.imag
            pair[f] += v * z0[f].conjugate()
        for b in range(1, min(c, n_paired)):
            zb = partners[b, s]
            pair = cross[b * (n_ch - 1) - b * (b - 1) // 2 + (c - b - 1)]
            for f in range(n_freq):
                pair[f] += z[f] * zb[f].conjugate()


def _accumulate_numpy(
    zc: np.ndarray,
    partners: np.ndarray,
    c: int,
    n_paired: int,
    auto: np.ndarray,
    cross: np.ndarray,
) -> None:
    """:func:`_accumulate_loops` in numpy: the same sums, equal to rounding."""
    n_ch = auto.shape[0]
    if len(zc) == 1:  # one segment (long segments): in place, the loops' association
        z = zc[0]
        squares = z.real * z.real
        squares += z.imag * z.imag
        auto[c] += squares
        for b in range(min(c, n_paired)):
            products = np.conjugate(partners[b, 0])
            products *= z
            cross[_cross_row(b, c, n_ch)] += products
        return
    flat = zc.view(np.float64)  # (n_seg, 2 * n_freq): real, imaginary interleaved
    squares = np.einsum("sk,sk->k", flat, flat)
    auto[c] += squares[0::2] + squares[1::2]
    for b in range(min(c, n_paired)):
        cross[_cross_row(b, c, n_ch)] += (zc * partners[b].conj()).sum(axis=0)


@functools.cache
def _compiled_accumulate() -> Callable[..., None] | None:
    """:func:`_accumulate_loops` compiled by numba (cached on disk); None without numba.

    None also when numba's JIT is disabled (``NUMBA_DISABLE_JIT``): the loops would then
    run in Python, far slower than numpy.
    """
    try:
        import numba
    except ImportError:
        return None
    if numba.config.DISABLE_JIT:
        return None
    signature = (
        "void(complex128[:, ::1], complex128[:, :, ::1], intp, intp, float64[:, ::1], "
        "complex128[:, ::1])"
    )
    return numba.njit(signature, cache=True, nogil=True)(_accumulate_loops)


def _window_into(segments: np.ndarray, window: np.ndarray, detrend: str, out: np.ndarray) -> None:
    """``out = (segments - mean) * window`` (the mean only for ``"constant"``), in place."""
    if detrend == "constant":
        np.subtract(segments, segments.mean(axis=-1, keepdims=True), out=out)
        out *= window
    else:
        np.multiply(segments, window, out=out)


def _segment_sums(
    channels: list[tuple[np.ndarray, np.ndarray]],
    plan: SegmentPlan,
    detrend: str,
    workers: int | None,
    n_paired: int,
    accumulate: Callable[..., None] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Sums over the segments of the auto products and of the cross products needed.

    The segments are windowed, transformed (:func:`scipy.fft.rfft`) and their products
    accumulated block by block (:data:`_BLOCK_BYTES`), so that no array of all the
    segment DFTs is formed.  On one thread each channel's block is transformed on its
    own and its products are accumulated while its DFTs are in cache; with several
    `workers`, the blocks of all channels are transformed in one call, which the
    workers share.

    Parameters
    ----------
    channels : list of (data, window)
        Data ``(n_ch_k, N)`` and its window ``(nperseg,)``; the blocks are stacked in
        order along the channel axis.
    plan : SegmentPlan
    detrend : {"none", "constant"}
    workers : int or None
        FFT threads, as for :func:`scipy.fft.rfft`.
    n_paired : int
        Channels ``0 .. n_paired - 1`` pair with every later channel: ``n_in`` (Gxx
        and Gyx), or ``n_ch - 1`` to add the output cross-spectra.
    accumulate : callable, optional
        :func:`_accumulate_numpy` or the compiled :func:`_accumulate_loops`.  None: the
        compiled one for spectra of at least :data:`_NUMBA_MIN_VALUES` values if numba
        imports, else numpy.

    Returns
    -------
    auto : numpy.ndarray
        ``(n_ch, n_freq)``, float: ``sum_s |Z_c|**2``.
    cross : numpy.ndarray
        ``(n_rows, n_freq)``, complex: ``sum_s Z_a conj(Z_b)`` in row
        ``_cross_row(b, a, n_ch)``, for ``b < n_paired``, ``b < a``.
    """
    n_ch = sum(data.shape[0] for data, _ in channels)
    n_seg, nperseg = plan.n_averages, plan.nperseg
    n_freq = nperseg // 2 + 1
    if accumulate is None:
        compiled = _compiled_accumulate() if n_ch * n_seg * n_freq >= _NUMBA_MIN_VALUES else None
        accumulate = _accumulate_numpy if compiled is None else compiled
    threads = scipy.fft.get_workers() if workers is None else workers
    rows = [
        (segments, window) for data, window in channels for segments in _segment_views(data, plan)
    ]
    by_channel = threads == 1
    per_block = max(1, min(n_seg, _BLOCK_BYTES // (8 * nperseg * (1 if by_channel else n_ch))))
    samples = np.empty((1 if by_channel else n_ch) * per_block * nperseg)
    kept = np.empty((n_paired, per_block, n_freq), dtype=complex) if by_channel else None
    auto = np.zeros((n_ch, n_freq))
    n_rows = _cross_row(n_paired, n_paired + 1, n_ch)  # the rows of the b < n_paired
    cross = np.zeros((n_rows, n_freq), dtype=complex)
    for first in range(0, n_seg, per_block):
        k = min(per_block, n_seg - first)
        if by_channel:
            block = samples[: k * nperseg].reshape(k, nperseg)
            # the last block may be shorter: a C-contiguous array of its own
            partners = kept if k == per_block else np.empty((n_paired, k, n_freq), complex)
            for c, (segments, window) in enumerate(rows):
                _window_into(segments[first : first + k], window, detrend, block)
                zc = scipy.fft.rfft(block, axis=-1, overwrite_x=True, workers=workers)
                if c < n_paired:
                    partners[c] = zc
                accumulate(zc, partners, c, n_paired, auto, cross)
        else:
            block = samples[: n_ch * k * nperseg].reshape(n_ch, k, nperseg)
            for c, (segments, window) in enumerate(rows):
                _window_into(segments[first : first + k], window, detrend, block[c])
            z = scipy.fft.rfft(block, axis=-1, overwrite_x=True, workers=workers)
            for c in range(n_ch):
                accumulate(z[c], z, c, n_paired, auto, cross)
    return auto, cross


def _onesided_density_scale(
    window_norm: float, fs_hz: float, nperseg: int, n_averages: int
) -> np.ndarray:
    n_freq = nperseg // 2 + 1
    scale = np.full(n_freq, 2.0 / (fs_hz * window_norm * n_averages))
    scale[0] /= 2.0
    if nperseg % 2 == 0 and n_freq > 1:
        scale[-1] /= 2.0
    return scale


#: Frequency lines per chunk when the scaled matrices are assembled.
_ASSEMBLE_LINES = 4096


def _hermitian_pair(g: np.ndarray, a: int, b: int, values: np.ndarray) -> None:
    """``g[:, a, b] = values``, ``g[:, b, a] = conj(values)``, in place."""
    g[:, a, b] = values
    np.conjugate(values, out=g[:, b, a])


def _assemble(
    auto: np.ndarray, cross: np.ndarray, n_in: int, output_cross: bool, scale: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray | None]:
    """Scaled spectral matrices from the sums of :func:`_segment_sums`.

    Parameters
    ----------
    auto, cross : numpy.ndarray
        From :func:`_segment_sums`, with ``n_paired = n_ch - 1`` if `output_cross`, else
        ``n_in``.
    n_in : int
        Number of inputs (the first channels).
    output_cross : bool
        Whether to build ``Gyy_full``.
    scale : numpy.ndarray
        ``(n_freq,)`` one-sided density scale.

    Returns
    -------
    tuple
        ``Gxx (n_freq, n_in, n_in)``, ``Gyx (n_freq, n_out, n_in)``,
        ``Gyy (n_freq, n_out)`` and ``Gyy_full (n_freq, n_out, n_out)`` or None; Gxx and
        Gyy_full exactly Hermitian with real diagonals.
    """
    n_ch, n_freq = auto.shape
    n_out = n_ch - n_in
    gxx = np.zeros((n_freq, n_in, n_in), dtype=complex)
    gyx = np.empty((n_freq, n_out, n_in), dtype=complex)
    gyy = np.empty((n_freq, n_out))
    gyy_full = np.zeros((n_freq, n_out, n_out), dtype=complex) if output_cross else None
    # row by row (contiguous loads, strided stores), in chunks of lines that stay in cache
    for start in range(0, n_freq, _ASSEMBLE_LINES):
        f = slice(start, start + _ASSEMBLE_LINES)
        sc = scale[f]
        for i in range(n_in):
            np.multiply(auto[i, f], sc, out=gxx[f, i, i].real)
            for j in range(i + 1, n_in):
                _hermitian_pair(gxx[f], j, i, cross[_cross_row(i, j, n_ch), f] * sc)
            for o in range(n_out):
                np.multiply(cross[_cross_row(i, n_in + o, n_ch), f], sc, out=gyx[f, o, i])
        for o in range(n_out):
            np.multiply(auto[n_in + o, f], sc, out=gyy[f, o])
        if gyy_full is not None:
            for p in range(n_out):
                gyy_full[f, p, p].real[...] = gyy[f, p]
                for o in range(p + 1, n_out):
                    row = _cross_row(n_in + p, n_in + o, n_ch)
                    _hermitian_pair(gyy_full[f], o, p, cross[row, f] * sc)
    return gxx, gyx, gyy, gyy_full


#: Longest named window that is cached (2 MiB of samples; at most 8 are kept).
_CACHED_WINDOW_SAMPLES = 1 << 18


@functools.lru_cache(maxsize=8)
def _named_window(name: str, n: int) -> tuple[np.ndarray, str]:
    """:func:`window_from_spec` of a window name, computed once (read-only samples)."""
    samples, description = window_from_spec(name, n)
    samples.flags.writeable = False
    return samples, description


def _window(spec: WindowSpec, n: int) -> tuple[np.ndarray, str]:
    """:func:`window_from_spec`, named windows cached (they take ms for long segments)."""
    if isinstance(spec, str) and n <= _CACHED_WINDOW_SAMPLES:
        return _named_window(spec, n)
    return window_from_spec(spec, n)


def _prepare(
    x: Any,
    y: Any,
    fs_hz: Any,
    *,
    window: WindowSpec,
    input_window: WindowSpec | None,
    nperseg: int | Literal["fast"] | None,
    n_averages: int | None,
    noverlap: int,
    detrend: Detrend,
) -> tuple[np.ndarray, np.ndarray, float, SegmentPlan, np.ndarray, np.ndarray, str, str]:
    """Validate everything at the boundary; return arrays, plan, windows, descriptions."""
    xa = _as_channels(x, "x", "input")
    ya = _as_channels(y, "y", "output")
    if xa.shape[1] != ya.shape[1]:
        raise DataFormatError(
            f"The input 'x' and output 'y' records must have the same length; got "
            f"x with {xa.shape[1]} samples (shape {xa.shape}) and y with {ya.shape[1]} "
            f"samples (shape {ya.shape})."
        )
    fs = _as_fs(fs_hz)
    detrend_mode = _as_detrend(detrend)
    n_samples = xa.shape[1]

    # an array window fixes nperseg when nperseg is not given
    array_window = not isinstance(window, str | tuple)
    if nperseg is None and array_window:
        length = np.shape(window)[0] if np.ndim(window) == 1 else None
        if length is not None and length > n_samples:
            raise DataFormatError(
                f"The 'window' array ({length} samples) is longer than the record "
                f"({n_samples} samples); expected at most {n_samples}."
            )
        nperseg = length
    elif nperseg == "fast" and array_window:
        raise _SettingError(
            "The 'nperseg' parameter 'fast' cannot be combined with a 'window' array, "
            "whose length fixes nperseg; pass a window name or an integer nperseg."
        )
    plan = plan_segments(n_samples, nperseg=nperseg, n_averages=n_averages, noverlap=noverlap)
    w_out, description = _window(window, plan.nperseg)
    if input_window is None:
        w_in = w_out
    else:
        w_in, in_description = _window(input_window, plan.nperseg)
        description = f"{description} (input: {in_description})"
    return xa, ya, fs, plan, w_in, w_out, description, detrend_mode


def _compute(
    xa: np.ndarray,
    ya: np.ndarray,
    fs: float,
    plan: SegmentPlan,
    w_in: np.ndarray,
    w_out: np.ndarray,
    description: str,
    detrend_mode: str,
    *,
    output_cross: bool,
    workers: int | None,
) -> SpectralMatrices:
    """The engine proper, on validated inputs."""
    n_in = xa.shape[0]
    n_paired = n_in + ya.shape[0] - 1 if output_cross else n_in
    # sum of squares without BLAS: a BLAS call wakes OpenBLAS's threads, whose
    # spin-waiting then costs more CPU than the whole product stage (measured 40 %)
    energy = float(np.sum(w_out * w_out))
    scale = _onesided_density_scale(energy, fs, plan.nperseg, plan.n_averages)
    with np.errstate(invalid="ignore", over="ignore"):  # non-finite data: reported below
        auto, cross = _segment_sums(
            [(xa, w_in), (ya, w_out)], plan, detrend_mode, workers, n_paired
        )
        products = _assemble(auto, cross, n_in, output_cross, scale)
    _check_finite(xa, ya, plan, products)
    gxx, gyx, gyy, gyy_full = products
    freq_hz = np.fft.rfftfreq(plan.nperseg, 1.0 / fs)
    return SpectralMatrices(
        freq_hz=freq_hz,
        Gxx=gxx,
        Gyx=gyx,
        Gyy=gyy,
        Gyy_full=gyy_full,
        fs_hz=fs,
        plan=plan,
        window=description,
        detrend=detrend_mode,
    )


def spectral_matrices(
    x: Any,
    y: Any,
    fs_hz: float,
    *,
    window: WindowSpec = "bartlett",
    nperseg: int | Literal["fast"] | None = None,
    n_averages: int | None = None,
    noverlap: int = 0,
    detrend: Detrend = False,
    input_window: WindowSpec | None = None,
    output_cross: bool = False,
    workers: int | None = None,
) -> SpectralMatrices:
    """Averaged one-sided spectral density matrices Gxx, Gyx, Gyy of x and y.

    Parameters
    ----------
    x : array_like
        Input time histories, shape ``(n_in, N)`` or ``(N,)``, real, finite.
    y : array_like
        Output time histories, shape ``(n_out, N)`` or ``(N,)``, real, finite.
    fs_hz : float
        Sampling frequency, Hz.
    window : str, tuple or array_like
        Window applied to every segment (see
        :func:`~truthbench.measure.windows.window_from_spec`); default ``"bartlett"``.
    nperseg, n_averages, noverlap
        Segmenting; see :func:`plan_segments`.
    detrend : False, None, "none" or "constant"
        ``"constant"`` removes each segment's mean before windowing (scipy's default);
        the default False uses the data as recorded (a sensor offset stays visible).
    input_window : str, tuple or array_like, optional
        A different window for the inputs x (e.g. ``("force", 50)`` for an impact
        hammer); `window` then applies to y only.  All spectra keep the density scale of
        `window`, so that the FRF estimators stay the plain ratios of windowed transforms
        (what impact testing needs); Gxx is then not a calibrated PSD of x.
    output_cross : bool
        Also compute the full output spectral matrix ``Gyy_full``.
    workers : int, optional
        Threads for :func:`scipy.fft.rfft`; None uses scipy's current default (1, or
        the value set with :func:`scipy.fft.set_workers`), -1 all cores.

    Returns
    -------
    SpectralMatrices

    Raises
    ------
    DataFormatError
        For malformed data (shape, length mismatch, no channel, non-finite values) or
        a record too short for the segments asked for.
    ValueError
        For invalid options (unknown window, bad nperseg/noverlap/detrend).
    """
    prepared = _prepare(
        x,
        y,
        fs_hz,
        window=window,
        input_window=input_window,
        nperseg=nperseg,
        n_averages=n_averages,
        noverlap=noverlap,
        detrend=detrend,
    )
    return _compute(*prepared, output_cross=output_cross, workers=workers)
