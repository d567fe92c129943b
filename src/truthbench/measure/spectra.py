"""The spectral engine: segmenting, windowing, FFT, and averaged spectral matrices.

One private engine (:func:`_segment_transforms`, :func:`_average_products`) serves every
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

Performance: all channels and all segments are windowed into one buffer and transformed
by a single batched ``scipy.fft.rfft``; the products are averaged with ``numpy.einsum``.
The FFT is fastest for 5-smooth segment lengths (``2**a 3**b 5**c``); see
:func:`fft_friendly_length` and ``nperseg="fast"``.  An explicit integer ``nperseg`` is
always used as given.
"""

from __future__ import annotations

import operator
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


def _segment_views(a: np.ndarray, plan: SegmentPlan) -> np.ndarray:
    """Read-only view ``(n_ch, n_averages, nperseg)`` of the segments of `a`."""
    windows = np.lib.stride_tricks.sliding_window_view(a[:, : plan.n_used], plan.nperseg, axis=-1)
    return windows[:, :: plan.step]


def _segment_transforms(
    channels: list[tuple[np.ndarray, np.ndarray]],
    plan: SegmentPlan,
    detrend: str,
    workers: int | None,
) -> np.ndarray:
    """DFTs of the windowed segments of every channel, in one batched rfft.

    Parameters
    ----------
    channels : list of (data, window)
        Data ``(n_ch_k, N)`` and its window ``(nperseg,)``; the blocks are stacked in
        order along the channel axis.
    plan : SegmentPlan
    detrend : {"none", "constant"}
    workers : int or None
        Passed to :func:`scipy.fft.rfft`.

    Returns
    -------
    numpy.ndarray
        Shape ``(n_ch, n_averages, nperseg // 2 + 1)``, complex.
    """
    n_ch = sum(data.shape[0] for data, _ in channels)
    buffer = np.empty((n_ch, plan.n_averages, plan.nperseg))
    start = 0
    for data, window in channels:
        stop = start + data.shape[0]
        segments = _segment_views(data, plan)
        block = buffer[start:stop]
        if detrend == "constant":
            np.subtract(segments, segments.mean(axis=-1, keepdims=True), out=block)
            block *= window
        else:
            np.multiply(segments, window, out=block)
        start = stop
    return scipy.fft.rfft(buffer, axis=-1, overwrite_x=True, workers=workers)


def _auto_products(z: np.ndarray) -> np.ndarray:
    """``sum_s |z[c, s, f]|**2`` as a real ``(n_freq, n_ch)`` array."""
    flat = z.view(np.float64)  # (..., 2 * n_freq): real and imaginary parts interleaved
    sums = np.einsum("csf,csf->cf", flat, flat)
    return (sums[:, 0::2] + sums[:, 1::2]).T


def _cross_products(a: np.ndarray, b: np.ndarray, b_conjugated: bool = False) -> np.ndarray:
    """``sum_s a[p, s, f] conj(b[q, s, f])`` as a complex ``(n_freq, n_a, n_b)`` array.

    With `b_conjugated`, `b` already holds ``conj(b)`` (saves a copy).
    """
    return np.einsum("psf,qsf->fpq", a, b if b_conjugated else b.conj())


def _onesided_density_scale(
    window_norm: float, fs_hz: float, nperseg: int, n_averages: int
) -> np.ndarray:
    n_freq = nperseg // 2 + 1
    scale = np.full(n_freq, 2.0 / (fs_hz * window_norm * n_averages))
    scale[0] /= 2.0
    if nperseg % 2 == 0 and n_freq > 1:
        scale[-1] /= 2.0
    return scale


def _average_products(
    zx: np.ndarray, zy: np.ndarray, scale: np.ndarray, output_cross: bool
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray | None]:
    """Scaled spectral matrices from segment DFTs ``zx (n_in, S, F)``, ``zy (n_out, S, F)``.

    `zx` is the engine's own scratch array and is conjugated in place here.
    """
    n_in = zx.shape[0]
    if n_in == 1:
        gxx = _auto_products(zx).astype(complex)[:, :, np.newaxis]
    else:
        gxx = _cross_products(zx, zx)
        # exact Hermitian symmetry and real diagonal
        gxx = 0.5 * (gxx + gxx.conj().transpose(0, 2, 1))
    np.negative(zx.imag, out=zx.imag)  # zx <- conj(zx), in the engine's own buffer
    gyx = _cross_products(zy, zx, b_conjugated=True)
    gyy = _auto_products(zy)
    gyy_full = None
    if output_cross:
        gyy_full = _cross_products(zy, zy)
        gyy_full = 0.5 * (gyy_full + gyy_full.conj().transpose(0, 2, 1))
        gyy_full *= scale[:, np.newaxis, np.newaxis]
    gxx *= scale[:, np.newaxis, np.newaxis]
    gyx *= scale[:, np.newaxis, np.newaxis]
    gyy *= scale[:, np.newaxis]
    return gxx, gyx, gyy, gyy_full


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
    w_out, description = window_from_spec(window, plan.nperseg)
    if input_window is None:
        w_in = w_out
    else:
        w_in, in_description = window_from_spec(input_window, plan.nperseg)
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
    z = _segment_transforms([(xa, w_in), (ya, w_out)], plan, detrend_mode, workers)
    scale = _onesided_density_scale(float(np.dot(w_out, w_out)), fs, plan.nperseg, plan.n_averages)
    with np.errstate(invalid="ignore", over="ignore"):  # non-finite data: reported below
        products = _average_products(z[:n_in], z[n_in:], scale, output_cross)
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
