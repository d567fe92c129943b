"""Peak picking: natural frequencies, damping and shapes read off the FRF magnitude.

The FRF of type ``q`` is converted to the other types by ``(j w)^(p - q)``:
displacement (receptance, ``p = 0``), velocity (mobility, ``p = 1``), acceleration
(accelerance, ``p = 2``). For a single mode ``H_d = A / (w_n^2 - w^2 + 2 j zeta w_n w)``:

* **Peaks** are found on the mobility magnitude ``|H_v| = w |H_d|`` (summed over the
  channels, or one chosen channel), whose maximum lies exactly at ``w_n``; the peak is
  refined by a parabola through the three lines around the maximum.
* **Half-power damping**: ``zeta = (f_2 - f_1) / (2 f_n)`` with ``f_1, f_2`` the
  frequencies where ``|H_v|`` falls to ``peak / sqrt(2)``, found by linear interpolation
  between lines. For one mode in mobility this is exact: ``w_2 - w_1 = 2 zeta w_n``.
* **Peak amplification** (the chapter's reading of Eq. 10.7-10.8, Figure 10.3;
  :ref:`method-smoothing`):
  ``zeta = 1 / (2 Q)``, ``Q = peak / static-equivalent``. For ``q/u = c b / (s^2 + 2 zeta
  w s + w^2)`` the static value is ``H(0) = c b / w^2`` and ``Q = 1 / (2 zeta sqrt(1 -
  zeta^2))``, so ``1 / (2Q)`` is ``zeta`` to first order. What is used as the
  static-equivalent (``reference``):

  - ``"static"`` (default): the displacement-equivalent FRF at the lowest line, and the
    peak of ``|H_d|``. Exact for one mode if the lowest line is 0 Hz; otherwise the
    lowest line stands in for 0 Hz.
  - ``"mass_line"``: when there is no static value (accelerance of a free structure,
    or data that start well above 0 Hz), the acceleration-equivalent FRF at the highest
    line (the mass-line asymptote ``c b`` of ``H_a = -w^2 H_d``), and the peak of
    ``|H_a|``. For one mode ``|H_a|`` peaks at ``c b / (2 zeta sqrt(1 - zeta^2))`` too,
    so ``Q`` is the same number.
  - a positive float: the static-equivalent value of the (summed) displacement
    magnitude, given by the user; the peak of ``|H_d|`` is used.

  No parabolic refinement is applied to the amplification peak: like the chapter's
  reading from a measured FRF, it inherits the resolution bias of the line grid.
* **Shapes**: the displacement-equivalent FRF at the line nearest ``f_n`` for input
  ``input_index``: its imaginary part (quadrature response, real shapes) or its complex
  value, scaled so that the largest-magnitude entry is 1.

Multi-mode data bias all three readings where modes overlap; peak picking is meant for
well separated, lightly damped modes.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from truthbench.identify._common import check_freq_frf, frf_power, readonly, select_band
from truthbench.identify.modal import ModalParameters
from truthbench.presentation import Presentable
from truthbench.settings import Configurable, setting


@dataclass(frozen=True)
class PeakPickingResult(Presentable):
    """What :func:`peak_picking` found.

    Table ``"modes"`` (:meth:`to_pandas`): one row per peak with both damping readings.
    Figure ``"shapes"`` (:meth:`plot`): the shapes.

    Attributes
    ----------
    modal : ModalParameters
        Frequencies, the damping of the chosen method, shapes (no participation).
    peak_index : ndarray, int, shape (n_modes,)
        Index into the caller's ``freq_hz`` of the line nearest each natural frequency.
    damping_half_power : ndarray, shape (n_modes,)
        Half-power damping ratios (NaN where a half-power point falls outside the band).
    damping_amplification : ndarray, shape (n_modes,)
        ``1 / (2 Q)`` (NaN where no reference value is available).
    amplification : ndarray, shape (n_modes,)
        ``Q``.
    """

    TABLES = ("modes",)
    PLOTS = ("shapes",)

    modal: ModalParameters
    peak_index: np.ndarray
    damping_half_power: np.ndarray
    damping_amplification: np.ndarray
    amplification: np.ndarray

    def __post_init__(self):
        for name in ("peak_index", "damping_half_power", "damping_amplification", "amplification"):
            object.__setattr__(self, name, readonly(getattr(self, name)))

    def _table_modes(self):
        """One row per peak: the modes' table (:class:`ModalParameters`) with
        ``peak_index``, ``damping_half_power``, ``damping_amplification`` and
        ``amplification``."""
        df = self.modal.to_pandas("modes")
        for name in ("peak_index", "damping_half_power", "damping_amplification",
                     "amplification"):
            df[name] = getattr(self, name)
        return df

    def _plot_shapes(self, ax):
        """The shapes read at the peaks."""
        return self.modal.plot("shapes", ax)


def _parabola(y0: float, y1: float, y2: float) -> tuple[float, float]:
    """Vertex offset (in lines, within [-0.5, 0.5]) and height of a parabola through 3 points."""
    den = y0 - 2.0 * y1 + y2
    if den >= 0:
        return 0.0, y1
    d = 0.5 * (y0 - y2) / den
    d = float(np.clip(d, -0.5, 0.5))
    return d, y1 - 0.25 * (y0 - y2) * d


def _crossing(f: np.ndarray, y: np.ndarray, k: int, level: float, step: int) -> float:
    """Frequency where ``y`` falls below ``level`` walking from line ``k`` by ``step``."""
    j = k
    while 0 <= j + step < y.size:
        if y[j + step] < level:
            y_a, y_b = y[j], y[j + step]
            t = (y_a - level) / (y_a - y_b)
            return float(f[j] + t * (f[j + step] - f[j]))
        j += step
    return float("nan")


@dataclass(frozen=True, kw_only=True)
class PeakIdentifier(Configurable):
    """The registered identifier ``"peak"``: peak picking with half-power damping
    (:func:`peak_picking`, whose defaults are these), configured by its settings.

    Calling it, ``identifier(freq_hz, frf, *, frf_type="displacement",
    freq_range_hz=None)``, returns the :class:`ModalParameters`."""

    name: ClassVar[str] = "peak"

    n_modes: int | None = setting(
        None, "Keep the n_modes most prominent peaks (unset: every peak above "
        "min_prominence).", kind="int", low=1)
    min_prominence: float = setting(
        0.02, "Smallest peak prominence, a fraction of the peak indicator's maximum.",
        low=0, low_open=True, high=1)

    def __call__(self, freq_hz, frf, *, frf_type: str = "displacement",
                 freq_range_hz: tuple[float, float] | None = None) -> ModalParameters:
        return peak_picking(freq_hz, frf, frf_type=frf_type, freq_range_hz=freq_range_hz,
                            **self.settings()).modal


def peak_picking(
    freq_hz,
    frf,
    *,
    n_modes: int | None = PeakIdentifier.n_modes,
    frf_type: str = "displacement",
    channel: tuple[int, int] | None = None,
    freq_range_hz: tuple[float, float] | None = None,
    damping_method: str = "half_power",
    reference: str | float = "static",
    shape_part: str = "imag",
    input_index: int = 0,
    min_prominence: float = PeakIdentifier.min_prominence,
) -> PeakPickingResult:
    """Pick resonance peaks and read frequency, damping and shape from them.

    Parameters
    ----------
    freq_hz : array_like, shape (n_freq,)
        Frequency lines, Hz.
    frf : array_like, complex, shape (n_freq, n_out, n_in)
        FRF of type ``frf_type``.
    n_modes : int, optional
        Keep the ``n_modes`` most prominent peaks (all peaks above ``min_prominence``
        if omitted).
    frf_type : {"displacement", "velocity", "acceleration"}
    channel : (int, int), optional
        ``(output, input)`` whose magnitude is searched; default: the sum of all
        channels' magnitudes.
    freq_range_hz : (float, float), optional
        Band to search.
    damping_method : {"half_power", "amplification"}
        Which damping goes into ``modal``; both are always reported.
    reference : {"static", "mass_line"} or float
        Static-equivalent value for the amplification method (see module notes).
    shape_part : {"imag", "complex"}
        Shapes from the imaginary part or the complex value of the displacement FRF.
    input_index : int
        Input column used for the shapes.
    min_prominence : float
        Smallest peak prominence, as a fraction of the indicator's maximum.

    Returns
    -------
    PeakPickingResult

    Raises
    ------
    ValueError
        Bad shapes or options.
    """
    f_all, H_all = check_freq_frf(freq_hz, frf)
    q = frf_power(frf_type)
    f, H = select_band(f_all, H_all, freq_range_hz)
    offset = int(np.searchsorted(f_all, f[0]))
    nf, no, ni = H.shape
    if damping_method not in ("half_power", "amplification"):
        raise ValueError(
            "The 'damping_method' parameter must be 'half_power' or 'amplification'; "
            f"got {damping_method!r}."
        )
    if shape_part not in ("imag", "complex"):
        raise ValueError(
            f"The 'shape_part' parameter must be 'imag' or 'complex'; got {shape_part!r}."
        )
    if not (isinstance(input_index, int | np.integer) and 0 <= input_index < ni):
        raise ValueError(
            f"The 'input_index' parameter must be an integer in [0, {ni - 1}]; got {input_index!r}."
        )
    if channel is not None:
        try:
            o, i = (int(c) for c in channel)
        except (TypeError, ValueError):
            raise ValueError(
                f"The 'channel' parameter must be a pair (output, input); got {channel!r}."
            ) from None
        if not (0 <= o < no and 0 <= i < ni):
            raise ValueError(
                f"The 'channel' parameter must index an FRF of shape ({no}, {ni}) "
                f"(outputs, inputs); got {channel!r}."
            )
    if isinstance(reference, str):
        if reference not in ("static", "mass_line"):
            raise ValueError(
                "The 'reference' parameter must be 'static', 'mass_line' or a positive "
                f"float; got {reference!r}."
            )
    elif not (np.isfinite(reference) and reference > 0):
        raise ValueError(
            "The 'reference' parameter must be 'static', 'mass_line' or a positive "
            f"float; got {reference!r}."
        )
    if n_modes is not None and not (isinstance(n_modes, int | np.integer) and n_modes >= 1):
        raise ValueError(f"The 'n_modes' parameter must be an integer >= 1; got {n_modes!r}.")

    jw = 1j * 2.0 * np.pi * f
    pos = f > 0
    # displacement, velocity and acceleration equivalents (NaN where undefined at 0 Hz)
    conv = {}
    for p in (0, 1, 2):
        k = p - q
        out = np.full_like(H, np.nan)
        if k >= 0:
            out = H * (jw**k)[:, None, None]
        else:
            out[pos] = H[pos] * (jw[pos] ** k)[:, None, None]
        conv[p] = out

    def indicator(Hp: np.ndarray) -> np.ndarray:
        mag = np.abs(Hp)
        if channel is not None:
            return mag[:, o, i]
        return mag.reshape(nf, -1).sum(axis=1)

    y = np.nan_to_num(indicator(conv[1]), nan=0.0)
    from scipy.signal import find_peaks

    peaks, props = find_peaks(y, prominence=min_prominence * float(np.max(y)))
    if n_modes is not None:
        if peaks.size < n_modes:
            warnings.warn(
                f"peak_picking: found {peaks.size} peaks above the prominence threshold, "
                f"fewer than n_modes={n_modes}; returning {peaks.size}.",
                stacklevel=2,
            )
        keep = np.sort(np.argsort(props["prominences"])[::-1][:n_modes])
        peaks = peaks[keep]
    m = peaks.size
    fn = np.zeros(m)
    zeta_hp = np.full(m, np.nan)
    zeta_q = np.full(m, np.nan)
    Q = np.full(m, np.nan)
    idx = np.zeros(m, dtype=int)
    shapes = np.zeros((no, m), dtype=float if shape_part == "imag" else complex)

    y_d = indicator(conv[0])
    y_a = indicator(conv[2])
    for r, k in enumerate(peaks):
        if 0 < k < nf - 1:
            d, ypk = _parabola(y[k - 1], y[k], y[k + 1])
            df = f[k + 1] - f[k] if d >= 0 else f[k] - f[k - 1]
        else:
            d, ypk, df = 0.0, y[k], 0.0
        fn[r] = f[k] + d * df
        level = ypk / np.sqrt(2.0)
        f1 = _crossing(f, y, k, level, -1)
        f2 = _crossing(f, y, k, level, +1)
        zeta_hp[r] = (f2 - f1) / (2.0 * fn[r])
        # amplification: peak of |H_d| (or |H_a|) between the half-power points
        lo = k if np.isnan(f1) else int(np.searchsorted(f, f1))
        hi = k + 1 if np.isnan(f2) else int(np.searchsorted(f, f2)) + 1
        lo, hi = max(min(lo, k), 0), min(max(hi, k + 1), nf)
        if isinstance(reference, str) and reference == "mass_line":
            ref = y_a[-1]
            peak_val = np.nanmax(y_a[lo:hi])
        else:
            ref = y_d[0] if isinstance(reference, str) else float(reference)
            peak_val = np.nanmax(y_d[lo:hi])
        if np.isfinite(ref) and ref > 0 and np.isfinite(peak_val):
            Q[r] = peak_val / ref
            zeta_q[r] = 1.0 / (2.0 * Q[r])
        idx[r] = int(np.argmin(np.abs(f - fn[r])))
        col = conv[0][idx[r], :, input_index]
        v = col.imag if shape_part == "imag" else col
        big = v[int(np.argmax(np.abs(v)))]
        shapes[:, r] = v / big if big != 0 else v
    if np.any(np.isnan(zeta_hp)):
        warnings.warn(
            "peak_picking: a half-power point lies outside the band for the peaks at "
            f"{fn[np.isnan(zeta_hp)].round(6).tolist()} Hz; their half-power damping is NaN.",
            stacklevel=2,
        )
    zeta = zeta_hp if damping_method == "half_power" else zeta_q
    if np.any(~np.isfinite(zeta) | (zeta >= 1)):
        bad = ~np.isfinite(zeta) | (zeta >= 1)
        raise ValueError(
            f"peak_picking: the {damping_method} damping is undefined or >= 1 for the peaks "
            f"at {fn[bad].round(6).tolist()} Hz; widen 'freq_range_hz' or choose the other "
            "'damping_method'."
        )
    modal = ModalParameters(freq_hz=fn, damping_ratio=zeta, shapes=shapes)
    return PeakPickingResult(
        modal=modal,
        peak_index=idx + offset,
        damping_half_power=zeta_hp,
        damping_amplification=zeta_q,
        amplification=Q,
    )
