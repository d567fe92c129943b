"""Frequency response function estimators (H1, H2, Hv) and coherence.

Thin public functions (:func:`estimate_frf`, :func:`h1`, :func:`h2`, :func:`hv`,
:func:`frf_from_spectra`) over the spectral engine of :mod:`truthbench.measure.spectra`.
The estimators share one protocol, ``SpectralMatrices -> H``, and are chosen by name
from the registry :data:`ESTIMATORS`.

Conventions (fixed for the whole project)
-----------------------------------------
* ``H`` is complex with shape ``(n_freq, n_out, n_in)``; ``freq_hz`` has shape
  ``(n_freq,)``.  ``Y(f) = H(f) X(f)``.
* Sign: for ``y = h * x`` (convolution) the estimate equals ``H = DFT(h)``, i.e.
  ``sum_k h[k] exp(-j 2 pi f k / fs)``; a pure delay of ``d`` samples has phase
  ``-2 pi f d / fs``.
* ``H1 = Gyx Gxx^-1`` (solved, never inverted) for any number of inputs; it is
  unbiased by output noise.
* ``H2``: one input, ``H2[o] = Gyy[o] / Gxy[o]`` with ``Gxy = conj(Gyx)``, per output.
  Several inputs: ``H2 = Gyy Gxy^+``, with the full output spectral matrix
  ``Gyy (n_out, n_out)`` and ``Gxy = Gyx^H (n_in, n_out)``; it needs
  ``n_out >= n_in`` and is the exact inverse ``Gyy Gxy^-1`` when ``n_out == n_in``
  (Maia & Silva 1997, sec. 3.4); for ``n_out > n_in`` the right pseudo-inverse gives
  ``H2 = Gyy Gyx (Gyx^H Gyx)^-1``.  Unbiased by input noise.
* ``Hv``: the total-least-squares estimator, per output: the eigenvector of the
  smallest eigenvalue of the Hermitian matrix ``[[Gxx, Gxy_o], [Gyx_o, Gyy_oo]]``
  (size ``n_in + 1``), scaled so its last entry is -1, conjugated.  One input gives the
  closed form ``Hv = (Gyy - Gxx + sqrt((Gyy - Gxx)**2 + 4 |Gyx|**2)) / (2 Gxy)``.
  It assumes equal noise spectra on inputs and outputs, so it depends on their units.
  For one input ``|H1| <= |Hv| <= |H2|``.
* Ordinary coherence ``|Gyx[o, i]|**2 / (Gxx[i, i] Gyy[o])``, shape
  ``(n_freq, n_out, n_in)``; multiple coherence ``H1_o Gxx H1_o^H / Gyy[o] =
  Re(sum_i Gyx[o, i] conj(H1[o, i])) / Gyy[o]``, shape ``(n_freq, n_out)``, for every
  estimator.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any, Literal

import numpy as np

from truthbench.errors import IdentifiabilityError
from truthbench.measure.leakage import Estimator
from truthbench.measure.spectra import (
    Detrend,
    SpectralMatrices,
    _compute,
    _prepare,
    _read_only,
    _SettingError,
)
from truthbench.measure.windows import WINDOW_NAMES, WindowSpec
from truthbench.presentation import Presentable

__all__ = [
    "ESTIMATORS",
    "FRFEstimate",
    "FRFEstimator",
    "estimate_frf",
    "frf_from_spectra",
    "h1",
    "h2",
    "hv",
]


# --------------------------------------------------------------------------- result


@dataclass(frozen=True, eq=False)
class FRFEstimate(Presentable):
    """An estimated frequency response matrix with its coherence and settings.

    Table ``"frf"`` (:meth:`to_pandas`): one row per (line, output, input). Figure
    ``"frf"`` (:meth:`plot`): magnitude, phase and coherence.

    Attributes
    ----------
    freq_hz : numpy.ndarray
        Shape ``(n_freq,)``, Hz, from 0 to ``fs_hz / 2`` in steps of ``fs_hz / nperseg``.
    H : numpy.ndarray
        Shape ``(n_freq, n_out, n_in)``, complex, (unit of y)/(unit of x).
    coherence : numpy.ndarray
        Ordinary coherence, shape ``(n_freq, n_out, n_in)``, in [0, 1].
    multiple_coherence : numpy.ndarray or None
        Shape ``(n_freq, n_out)``, in [0, 1]; equals `coherence` for one input.
    estimator : str
        ``"H1"``, ``"H2"`` or ``"Hv"``.
    window : str
        Window description, e.g. ``"bartlett"`` or ``"hann (input: force(force_width=40))"``.
    nperseg : int
        Segment length, samples.
    noverlap : int
        Overlap of consecutive segments, samples.
    n_averages : int
        Number of segments averaged.
    fs_hz : float
        Sampling frequency, Hz.
    detrend : str
        ``"none"`` or ``"constant"``.

    Notes
    -----
    Arrays are read-only views; the object is immutable.
    """

    TABLES = ("frf",)
    PLOTS = ("frf",)

    freq_hz: np.ndarray
    H: np.ndarray
    coherence: np.ndarray
    multiple_coherence: np.ndarray | None
    estimator: str
    window: str
    nperseg: int
    noverlap: int
    n_averages: int
    fs_hz: float
    detrend: str = "none"

    def __post_init__(self) -> None:
        n_freq = np.shape(self.freq_hz)
        if len(n_freq) != 1:
            raise ValueError(
                f"FRFEstimate 'freq_hz' must have shape (n_freq,); got {np.shape(self.freq_hz)}."
            )
        if np.ndim(self.H) != 3 or np.shape(self.H)[0] != n_freq[0]:
            raise ValueError(
                f"FRFEstimate 'H' must have shape (n_freq, n_out, n_in) = ({n_freq[0]}, ., .); "
                f"got {np.shape(self.H)}."
            )
        if np.shape(self.coherence) != np.shape(self.H):
            raise ValueError(
                f"FRFEstimate 'coherence' must have the shape of H, {np.shape(self.H)}; "
                f"got {np.shape(self.coherence)}."
            )
        if (
            self.multiple_coherence is not None
            and np.shape(self.multiple_coherence) != np.shape(self.H)[:2]
        ):
            raise ValueError(
                f"FRFEstimate 'multiple_coherence' must have shape (n_freq, n_out) = "
                f"{np.shape(self.H)[:2]}; got {np.shape(self.multiple_coherence)}."
            )
        for name in ("freq_hz", "H", "coherence", "multiple_coherence"):
            value = getattr(self, name)
            if value is not None:
                object.__setattr__(self, name, _read_only(value))

    @property
    def n_freq(self) -> int:
        """Number of frequency lines."""
        return self.H.shape[0]

    @property
    def n_outputs(self) -> int:
        """Number of output channels."""
        return self.H.shape[1]

    @property
    def n_inputs(self) -> int:
        """Number of input channels."""
        return self.H.shape[2]

    @property
    def df_hz(self) -> float:
        """Line spacing ``fs_hz / nperseg``, Hz."""
        return self.fs_hz / self.nperseg

    def to_estimator(self, *, period_samples: int | None = None) -> Estimator:
        """How this estimate was made, as the :class:`~truthbench.measure.leakage.Estimator`
        an :class:`~truthbench.measure.FRFData` carries: window, segment (``nperseg``),
        averages, rate and overlap.

        Parameters
        ----------
        period_samples : int, optional
            The input's period, samples, when it was periodic (a whole number of
            segments); None for a random input.

        Raises
        ------
        ValueError
            The window is not a plain named window (a parametrised one, an array, or a
            separate input window), which the leakage model cannot describe.
        """
        if self.window not in WINDOW_NAMES:
            raise ValueError(f"FRFEstimate: the window {self.window!r} is not one of "
                             f"{', '.join(WINDOW_NAMES)} without a parameter; the leakage "
                             f"model (Estimator) describes only those")
        return Estimator(self.window, self.nperseg, self.fs_hz, period_samples,
                         averages=self.n_averages, overlap_samples=self.noverlap)

    def _plot_frf(self, ax, **options):
        """Magnitude, phase and coherence (outputs and inputs by index; options
        ``inputs``, ``outputs`` as :func:`~truthbench.measure.frfdata.plot_frf`)."""
        from truthbench.measure.frfdata import plot_frf

        return plot_frf(self.freq_hz, self.H, self.coherence,
                        [f"y{o}" for o in range(self.n_outputs)],
                        [f"x{i}" for i in range(self.n_inputs)], "unit of y / unit of x",
                        f"{self.estimator}, {self.window} window, {self.n_averages} "
                        f"averages", ax, **options)

    def _table_frf(self) -> Any:
        """The estimate as a long (tidy) table: one row per (frequency, output, input)
        with columns ``freq_hz``, ``output``, ``input``, ``H`` (complex), ``magnitude``,
        ``phase_rad``, ``coherence`` and ``multiple_coherence`` (NaN if not available);
        the settings are in ``DataFrame.attrs``."""
        import pandas as pd

        n_freq, n_out, n_in = self.H.shape
        f_idx, o_idx, i_idx = np.meshgrid(
            np.arange(n_freq), np.arange(n_out), np.arange(n_in), indexing="ij"
        )
        mult = (
            np.full((n_freq, n_out), np.nan)
            if self.multiple_coherence is None
            else self.multiple_coherence
        )
        h = self.H.ravel()
        frame = pd.DataFrame(
            {
                "freq_hz": self.freq_hz[f_idx.ravel()],
                "output": o_idx.ravel(),
                "input": i_idx.ravel(),
                "H": h,
                "magnitude": np.abs(h),
                "phase_rad": np.angle(h),
                "coherence": self.coherence.ravel(),
                "multiple_coherence": mult[f_idx.ravel(), o_idx.ravel()],
            }
        )
        frame.attrs.update(
            estimator=self.estimator,
            window=self.window,
            nperseg=self.nperseg,
            noverlap=self.noverlap,
            n_averages=self.n_averages,
            fs_hz=self.fs_hz,
            detrend=self.detrend,
        )
        return frame


# --------------------------------------------------------------------------- linear algebra


def _right_solve(
    b: np.ndarray, a: np.ndarray, what: str, freq_hz: np.ndarray, warn: bool = True
) -> np.ndarray:
    """Batched ``b a^-1``: solve ``X a = b`` for ``X`` at every frequency line.

    ``a`` has shape ``(n_freq, n, n)``, ``b`` ``(n_freq, m, n)``.  Lines where ``a`` is
    exactly singular get NaN and (if `warn`) one warning naming `what`.
    """
    n_freq, n = a.shape[0], a.shape[-1]
    if n == 1:
        denom = a[:, 0, 0]
        singular = denom == 0
        with np.errstate(divide="ignore", invalid="ignore"):
            out = b / denom[:, np.newaxis, np.newaxis]
    else:
        a_t = np.swapaxes(a, -1, -2)
        b_t = np.swapaxes(b, -1, -2)
        singular = np.zeros(n_freq, dtype=bool)
        try:
            out = np.swapaxes(np.linalg.solve(a_t, b_t), -1, -2)
        except np.linalg.LinAlgError:
            out = np.empty(b.shape, dtype=np.result_type(a, b))
            for k in range(n_freq):
                try:
                    out[k] = np.linalg.solve(a_t[k], b_t[k]).T
                except np.linalg.LinAlgError:
                    singular[k] = True
    if singular.any():
        out[singular] = np.nan
    if warn and singular.any():
        first = freq_hz[np.argmax(singular)]
        warnings.warn(
            f"{what} is singular at {int(singular.sum())} of {n_freq} frequency lines "
            f"(the first at {first:g} Hz); the FRF is NaN there.",
            RuntimeWarning,
            stacklevel=3,
        )
    return out


# --------------------------------------------------------------------------- estimators


def _h1_from_spectra(s: SpectralMatrices, warn: bool = True) -> np.ndarray:
    return _right_solve(s.Gyx, s.Gxx, "The input spectral matrix Gxx", s.freq_hz, warn)


def _h2_from_spectra(s: SpectralMatrices) -> np.ndarray:
    n_in, n_out = s.n_inputs, s.n_outputs
    if n_in == 1:
        with np.errstate(divide="ignore", invalid="ignore"):
            return s.Gyy[:, :, np.newaxis] / s.Gyx.conj()
    if n_out < n_in:
        raise IdentifiabilityError(
            f"H2 with {n_in} inputs needs at least {n_in} outputs (Gxy must have full row "
            f"rank); got {n_out} outputs. Use H1 or Hv."
        )
    if s.Gyy_full is None:
        raise _SettingError(
            "H2 with several inputs needs the full output spectral matrix; compute the "
            "spectra with output_cross=True (estimate_frf does this itself)."
        )
    gxy = s.Gyx.conj().transpose(0, 2, 1)  # (n_freq, n_in, n_out)
    if n_out == n_in:
        return _right_solve(s.Gyy_full, gxy, "The cross-spectral matrix Gxy", s.freq_hz)
    normal = gxy @ s.Gyx  # Gyx^H Gyx, (n_freq, n_in, n_in)
    return _right_solve(s.Gyy_full @ s.Gyx, normal, "Gyx^H Gyx", s.freq_hz)


def _hv_from_spectra(s: SpectralMatrices) -> np.ndarray:
    n_in = s.n_inputs
    if n_in == 1:
        gxx = s.Gxx[:, 0, 0].real[:, np.newaxis]  # (n_freq, 1)
        gyx = s.Gyx[:, :, 0]  # (n_freq, n_out)
        d = s.Gyy - gxx
        g2 = gyx.real**2 + gyx.imag**2
        r = np.sqrt(d * d + 4.0 * g2)
        with np.errstate(divide="ignore", invalid="ignore"):
            # d + r, written without cancellation when d < 0
            numerator = np.where(d >= 0, d + r, 4.0 * g2 / (r - d))
            return (numerator / (2.0 * gyx.conj()))[:, :, np.newaxis]
    n_freq, n_out = s.Gyy.shape
    c = np.empty((n_freq, n_out, n_in + 1, n_in + 1), dtype=complex)
    c[:, :, :n_in, :n_in] = s.Gxx[:, np.newaxis]
    c[:, :, n_in, :n_in] = s.Gyx
    c[:, :, :n_in, n_in] = s.Gyx.conj()
    c[:, :, n_in, n_in] = s.Gyy
    _, vectors = np.linalg.eigh(c)
    smallest = vectors[..., 0]  # eigenvalues ascending
    with np.errstate(divide="ignore", invalid="ignore"):
        return -(smallest[..., :n_in] / smallest[..., n_in : n_in + 1]).conj()


@dataclass(frozen=True)
class FRFEstimator:
    """One registered FRF estimator: the shared protocol ``SpectralMatrices -> H``.

    Attributes
    ----------
    name : str
        Canonical name, the key in :data:`ESTIMATORS`.
    compute : callable
        ``compute(spectra) -> H`` of shape ``(n_freq, n_out, n_in)``.
    needs_output_cross : callable
        ``needs_output_cross(n_in, n_out) -> bool``: whether `compute` needs
        ``spectra.Gyy_full``.
    summary : str
        One line: what it is and what noise it is robust to.
    """

    name: str
    compute: Callable[[SpectralMatrices], np.ndarray]
    needs_output_cross: Callable[[int, int], bool]
    summary: str


def _never(n_in: int, n_out: int) -> bool:
    return False


def _several_inputs(n_in: int, n_out: int) -> bool:
    return n_in > 1


#: The estimator registry, canonical name -> :class:`FRFEstimator` (names are matched
#: case-insensitively).
ESTIMATORS: Mapping[str, FRFEstimator] = MappingProxyType(
    {
        "H1": FRFEstimator("H1", _h1_from_spectra, _never, "Gyx Gxx^-1; unbiased by output noise"),
        "H2": FRFEstimator(
            "H2", _h2_from_spectra, _several_inputs, "Gyy Gxy^-1; unbiased by input noise"
        ),
        "Hv": FRFEstimator(
            "Hv",
            _hv_from_spectra,
            _never,
            "total least squares per output; equal input and output noise",
        ),
    }
)


def _lookup_estimator(name: Any) -> FRFEstimator:
    if isinstance(name, str):
        for key, value in ESTIMATORS.items():
            if key.lower() == name.strip().lower():
                return value
    raise _SettingError(
        f"Unknown estimator {name!r}; expected one of {', '.join(ESTIMATORS)} (case-insensitive)."
    )


# --------------------------------------------------------------------------- coherence


def _ordinary_coherence(s: SpectralMatrices) -> np.ndarray:
    gxx_diag = np.diagonal(s.Gxx, axis1=1, axis2=2).real  # (n_freq, n_in)
    power = s.Gyx.real**2 + s.Gyx.imag**2
    with np.errstate(divide="ignore", invalid="ignore"):
        return power / (s.Gyy[:, :, np.newaxis] * gxx_diag[:, np.newaxis, :])


def _multiple_coherence(s: SpectralMatrices, h1: np.ndarray) -> np.ndarray:
    explained = np.einsum("foi,foi->fo", s.Gyx, h1.conj()).real
    with np.errstate(divide="ignore", invalid="ignore"):
        return explained / s.Gyy


# --------------------------------------------------------------------------- public API


def frf_from_spectra(spectra: SpectralMatrices, estimator: str = "H1") -> FRFEstimate:
    """Estimate the FRF matrix from already averaged spectral matrices.

    Use it to get several estimators from one pass over the data (compute the spectra
    with ``output_cross=True`` if H2 with several inputs is wanted).

    Parameters
    ----------
    spectra : SpectralMatrices
        From :func:`~truthbench.measure.spectra.spectral_matrices`.
    estimator : {"H1", "H2", "Hv"}
        Case-insensitive name from :data:`ESTIMATORS`.

    Returns
    -------
    FRFEstimate

    Raises
    ------
    ValueError
        Unknown estimator; H2 with several inputs and no ``Gyy_full``.
    IdentifiabilityError
        H2 with fewer outputs than inputs.
    """
    chosen = _lookup_estimator(estimator)
    h = chosen.compute(spectra)
    coherence = _ordinary_coherence(spectra)
    if spectra.n_inputs == 1:  # the multiple coherence is the ordinary one
        multiple = coherence[:, :, 0].copy()
    else:
        # H1 is needed for the multiple coherence; a singular Gxx was reported by H1 itself
        h1_matrix = h if chosen.name == "H1" else _h1_from_spectra(spectra, warn=False)
        multiple = _multiple_coherence(spectra, h1_matrix)
    plan = spectra.plan
    return FRFEstimate(
        freq_hz=spectra.freq_hz,
        H=h,
        coherence=coherence,
        multiple_coherence=multiple,
        estimator=chosen.name,
        window=spectra.window,
        nperseg=plan.nperseg,
        noverlap=plan.noverlap,
        n_averages=plan.n_averages,
        fs_hz=spectra.fs_hz,
        detrend=spectra.detrend,
    )


def estimate_frf(
    x: Any,
    y: Any,
    fs_hz: float,
    *,
    estimator: str = "H1",
    window: WindowSpec = "bartlett",
    nperseg: int | Literal["fast"] | None = None,
    n_averages: int | None = None,
    noverlap: int = 0,
    detrend: Detrend = False,
    input_window: WindowSpec | None = None,
    workers: int | None = None,
) -> FRFEstimate:
    """Estimate the frequency response matrix from input and output time histories.

    Parameters
    ----------
    x : array_like
        Input (force) time histories, shape ``(n_in, N)`` or ``(N,)``, real, finite.
    y : array_like
        Output (response) time histories, shape ``(n_out, N)`` or ``(N,)``, real,
        finite, sampled with `x`.
    fs_hz : float
        Sampling frequency, Hz.
    estimator : {"H1", "H2", "Hv"}
        See the module docstring; case-insensitive.  Default ``"H1"``.
    window : str, tuple or array_like
        Segment window: a name from :data:`~truthbench.measure.windows.WINDOW_NAMES`
        (standard windows are the periodic scipy ones), ``("force", force_width)``,
        ``("exponential", decay_to)``, or samples of length `nperseg`.  Default
        ``"bartlett"`` (the chapter's choice).
    nperseg : int, "fast" or None
        Segment length in samples; an integer is used exactly as given.  None:
        ``N // n_averages`` when `n_averages` is given (with overlap, the longest that
        fits), else the whole record.  ``"fast"``: as None, then rounded down to the
        nearest 5-smooth length (:func:`~truthbench.measure.spectra.fft_friendly_length`).
        An array `window` fixes ``nperseg = len(window)``.
    n_averages : int or None
        Number of segments averaged; None: as many as fit.  The chosen values are
        reported in the result (``nperseg``, ``noverlap``, ``n_averages``).
    noverlap : int
        Overlap of consecutive segments, samples; default 0.
    detrend : False, None, "none" or "constant"
        ``"constant"`` removes each segment's mean before windowing; default False
        (the data are used as recorded).
    input_window : str, tuple or array_like, optional
        A different window for `x` (e.g. ``("force", 40)`` for a hammer); `window` then
        applies to `y` only.  See
        :func:`~truthbench.measure.spectra.spectral_matrices`.
    workers : int, optional
        FFT threads (:func:`scipy.fft.rfft`); None uses scipy's default.

    Returns
    -------
    FRFEstimate
        ``H`` of shape ``(n_freq, n_out, n_in)`` with ``n_freq = nperseg // 2 + 1``.

    Raises
    ------
    DataFormatError
        Malformed data: no input or output channel, x/y lengths differ, non-finite
        samples, complex data, a segment or window longer than the record.
    ValueError
        Unknown window or estimator name, invalid nperseg/noverlap/n_averages/detrend.
    IdentifiabilityError
        H2 with fewer outputs than inputs.

    Warns
    -----
    RuntimeWarning
        If Gxx is singular at some lines (e.g. fully coherent inputs); H is NaN there.

    Examples
    --------
    >>> import numpy as np, scipy.signal
    >>> rng = np.random.default_rng(0)
    >>> x = rng.standard_normal(20_000)
    >>> y = scipy.signal.lfilter([0.0, 1.0], [1.0], x)  # one-sample delay
    >>> est = estimate_frf(x, y, fs_hz=100.0, n_averages=10)
    >>> est.H.shape, est.nperseg
    ((1001, 1, 1), 2000)
    """
    chosen = _lookup_estimator(estimator)
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
    n_in, n_out = prepared[0].shape[0], prepared[1].shape[0]
    if chosen.name == "H2" and n_in > 1 and n_out < n_in:
        raise IdentifiabilityError(
            f"H2 with {n_in} inputs needs at least {n_in} outputs; got {n_out} outputs. "
            f"Use H1 or Hv."
        )
    spectra = _compute(
        *prepared, output_cross=chosen.needs_output_cross(n_in, n_out), workers=workers
    )
    return frf_from_spectra(spectra, chosen.name)


def h1(
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
    workers: int | None = None,
) -> FRFEstimate:
    """H1 estimate ``Gyx Gxx^-1``: :func:`estimate_frf` with ``estimator="H1"``.

    Unbiased by (uncorrelated) output noise, biased low by input noise.  Parameters,
    returns and errors as :func:`estimate_frf`.
    """
    return estimate_frf(
        x,
        y,
        fs_hz,
        estimator="H1",
        window=window,
        nperseg=nperseg,
        n_averages=n_averages,
        noverlap=noverlap,
        detrend=detrend,
        input_window=input_window,
        workers=workers,
    )


def h2(
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
    workers: int | None = None,
) -> FRFEstimate:
    """H2 estimate ``Gyy Gxy^-1``: :func:`estimate_frf` with ``estimator="H2"``.

    Unbiased by (uncorrelated) input noise, biased high by output noise.  With several
    inputs it needs ``n_out >= n_in`` (see the module docstring).  Parameters, returns
    and errors as :func:`estimate_frf`.
    """
    return estimate_frf(
        x,
        y,
        fs_hz,
        estimator="H2",
        window=window,
        nperseg=nperseg,
        n_averages=n_averages,
        noverlap=noverlap,
        detrend=detrend,
        input_window=input_window,
        workers=workers,
    )


def hv(
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
    workers: int | None = None,
) -> FRFEstimate:
    """Hv (total least squares) estimate: :func:`estimate_frf` with ``estimator="Hv"``.

    Assumes equal noise spectra on inputs and outputs.  Parameters, returns and errors
    as :func:`estimate_frf`.
    """
    return estimate_frf(
        x,
        y,
        fs_hz,
        estimator="Hv",
        window=window,
        nperseg=nperseg,
        n_averages=n_averages,
        noverlap=noverlap,
        detrend=detrend,
        input_window=input_window,
        workers=workers,
    )
