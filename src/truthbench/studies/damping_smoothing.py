"""Damping read from smoothed FRF peaks (the chapter's Figure 10.3, Eq. 10.7-10.8;
:ref:`method-smoothing`).

A single-DOF system ``q/u = c b / (s^2 + 2 zeta w s + w^2)`` (here ``b = 1``,
``c = w^2``: unit static gain) is driven by sampled white Gaussian noise of unit
variance and simulated exactly for that sampled input (first-order hold,
:func:`truthbench.simulate.simulate_lti` through its prepared recursion); the
measurement is ``y = q + n`` with white noise of standard deviation
``noise_fraction * std(q)`` (:func:`truthbench.simulate.add_sensor_noise`; the chapter's
"half that of q" is 0.5). A warm-up of 8 time constants ``1 / (zeta w)`` is simulated
and discarded, so every record is stationary.

For each number of points per window ``N`` the H1 FRF is estimated from ``n_averages``
(10) non-overlapping segments of ``N`` samples (:func:`truthbench.measure.estimate_frf`)
with the Bartlett window (the chapter's choice) and, beside it, Hann and Hamming. The
damping is read with :func:`truthbench.identify.peak_picking` (one peak, displacement
FRF, band 0 .. ``band_factor * f_n``):

* **amplification** (the chapter's reading): ``zeta = 1 / (2 Q)``, ``Q`` = peak ``|H|``
  over the static value ``|H(0)|``. By default (``static_reference="exact"``) the static
  value is the system's own ``c b / w^2 = 1``, passed to ``peak_picking`` as its
  ``reference``: the study isolates what the chapter shows, the peak lowered by the
  window's smoothing. With ``static_reference="data"`` the estimated ``|H1|`` at 0 Hz is
  used instead (``reference="static"``); there the output noise makes the coherence
  low, and the scatter of ``|H1(0)|`` adds a random error of its own.
* **half-power** on the mobility magnitude (``peak_picking``'s other reading).

Every point is repeated over ``n_seeds`` independent records; generators come from
``SeedSequence(seed, spawn_key=(N, repetition))``, so a point's numbers do not depend
on which other points are run. The error is ``(zeta_est - zeta) / zeta``; the result
reports its mean and standard deviation over the repetitions.

Why the error falls with ``N``: the window's effective bandwidth ``B_e`` (about
``1.33 fs / N`` for Bartlett) smooths a resonance of half-power bandwidth
``B_r = 2 zeta f_n``; the peak is lowered by about ``(1/3) (B_e / B_r)^2`` while
``B_e << B_r`` (Bendat and Piersol) and far more once ``B_e`` reaches ``B_r``. The
relevant variable is therefore ``df / B_r = fs / (N * 2 zeta f_n)``, reported beside
``N``: the chapter does not give its ``fs``, ``f_n`` or ``zeta``, so its horizontal
axis can only be compared through this ratio. Defaults: ``f_n = 10`` Hz,
``zeta = 1 %``, ``fs = 200`` Hz (20 samples per period, Nyquist 10 ``f_n``), so
``df = B_r`` at ``N = 1000``.

A floor remains at large ``N``: the FRF between the *sampled* input and output of a
first-order-hold simulation is ``H(j w)`` times about ``sinc^2(f / fs)`` near the peak,
so even an exact estimate gives ``zeta`` about 0.8 % high at the defaults;
:attr:`DampingSmoothingStudy.floor_damping_ratio` holds the value read from the exact
sampled FRF.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

import numpy as np

from truthbench.presentation import Presentable, figure_axes

__all__ = [
    "DEFAULT_POINTS_PER_WINDOW",
    "DampingSmoothingStudy",
    "damping_smoothing_study",
    "sdof_state_space",
]

#: 10^2.5 .. 10^4.5 in quarter decades.
DEFAULT_POINTS_PER_WINDOW = tuple(int(round(v)) for v in np.logspace(2.5, 4.5, 9))

METHODS = ("amplification", "half_power")
"""Damping readings, in the order of the ``method`` axis of the estimates."""

#: The chapter's Figure 10.3, read off the plot (points per window, error %).
CHAPTER_POINTS = ((1_000, 100.0), (10_000, 10.0))


def sdof_state_space(natural_freq_hz: float, damping_ratio: float,
                     static_gain: float = 1.0) -> tuple[np.ndarray, ...]:
    """State space of ``q/u = c b / (s^2 + 2 zeta w s + w^2)`` with ``b = 1``.

    Parameters
    ----------
    natural_freq_hz : float
        ``f_n = w / 2 pi``, Hz (> 0).
    damping_ratio : float
        ``zeta``, in (0, 1).
    static_gain : float
        ``H(0) = c b / w^2`` (output unit per input unit); ``c = static_gain w^2``.

    Returns
    -------
    A : ndarray, shape (2, 2)
        ``[[0, 1], [-w^2, -2 zeta w]]``, state ``[x, x']``, 1/s.
    B : ndarray, shape (2, 1)
    C : ndarray, shape (1, 2)
    D : ndarray, shape (1, 1)
    """
    if not (math.isfinite(natural_freq_hz) and natural_freq_hz > 0):
        raise ValueError(f"natural_freq_hz must be > 0; got {natural_freq_hz!r}")
    if not 0 < damping_ratio < 1:
        raise ValueError(f"damping_ratio must lie in (0, 1); got {damping_ratio!r}")
    w = 2.0 * np.pi * natural_freq_hz
    A = np.array([[0.0, 1.0], [-w * w, -2.0 * damping_ratio * w]])
    B = np.array([[0.0], [1.0]])
    C = np.array([[static_gain * w * w, 0.0]])
    return A, B, C, np.zeros((1, 1))


@dataclass(frozen=True, eq=False)
class DampingSmoothingStudy(Presentable):
    """Damping ratios read from smoothed FRF peaks, per window, method, N and repetition.

    Table ``"summary"`` (:meth:`to_pandas`): one row per (window, method, points per
    window). Figure ``"errors"`` (:meth:`plot`): the Figure 10.3 analogue.

    Attributes
    ----------
    points_per_window : ndarray of int, shape (n_points,)
        Segment lengths N, samples.
    windows : tuple of str
        Window names, length n_windows.
    methods : tuple of str
        ``("amplification", "half_power")``.
    damping_estimates : ndarray, shape (n_windows, 2, n_points, n_seeds)
        Estimated damping ratios (NaN where a reading failed, e.g. a half-power point
        outside the band).
    freq_estimates_hz : ndarray, shape (n_windows, n_points, n_seeds)
        Peak frequencies, Hz.
    damping_ratio : float
        True ``zeta``.
    natural_freq_hz : float
        True ``f_n``, Hz.
    fs_hz : float
        Sampling frequency, Hz.
    n_averages : int
        Segments averaged per FRF.
    noise_fraction : float
        Output noise std over ``std(q)``.
    seed : int
        Root of the seed sequence.
    static_reference : str
        ``"exact"`` or ``"data"`` (see the module notes).
    floor_damping_ratio : Mapping
        Method -> damping read from the exact sampled-system FRF (the large-N limit).
    """

    TABLES = ("summary",)
    PLOTS = ("errors",)

    points_per_window: np.ndarray
    windows: tuple[str, ...]
    methods: tuple[str, ...]
    damping_estimates: np.ndarray
    freq_estimates_hz: np.ndarray
    damping_ratio: float
    natural_freq_hz: float
    fs_hz: float
    n_averages: int
    noise_fraction: float
    seed: int
    static_reference: str
    floor_damping_ratio: Any = field(default_factory=dict)

    def __post_init__(self):
        for name in ("points_per_window", "damping_estimates", "freq_estimates_hz"):
            a = np.array(getattr(self, name), copy=True)
            a.setflags(write=False)
            object.__setattr__(self, name, a)
        object.__setattr__(self, "windows", tuple(self.windows))
        object.__setattr__(self, "methods", tuple(self.methods))
        object.__setattr__(self, "floor_damping_ratio",
                           MappingProxyType(dict(self.floor_damping_ratio)))

    @property
    def n_seeds(self) -> int:
        """Repetitions per point."""
        return int(self.damping_estimates.shape[-1])

    @property
    def half_power_bandwidth_hz(self) -> float:
        """``B_r = 2 zeta f_n``, Hz."""
        return 2.0 * self.damping_ratio * self.natural_freq_hz

    @property
    def relative_error_pct(self) -> np.ndarray:
        """``100 (zeta_est - zeta) / zeta``, shape (n_windows, 2, n_points, n_seeds), %."""
        return 100.0 * (self.damping_estimates - self.damping_ratio) / self.damping_ratio

    def error_stats(self, window: str = "bartlett", method: str = "amplification"):
        """Mean and standard deviation of the relative error over the repetitions.

        Parameters
        ----------
        window : str
            One of :attr:`windows`.
        method : {"amplification", "half_power"}

        Returns
        -------
        mean, std : ndarray, shape (n_points,)
            Percent; NaN-aware (failed readings are left out).
        """
        if window not in self.windows:
            raise ValueError(f"window must be one of {self.windows}; got {window!r}")
        if method not in self.methods:
            raise ValueError(f"method must be one of {self.methods}; got {method!r}")
        e = self.relative_error_pct[self.windows.index(window), self.methods.index(method)]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            return np.nanmean(e, axis=-1), np.nanstd(e, axis=-1)

    def _table_summary(self):
        """One row per (window, method, points per window): columns window, method,
        points_per_window, df_hz, df_over_br, mean_damping_ratio, mean_error_pct,
        std_error_pct, mean_abs_error_pct, mean_freq_error_pct, n_valid; the settings
        in ``DataFrame.attrs``."""
        import pandas as pd

        rows = []
        df = self.fs_hz / self.points_per_window
        f_err = 100.0 * (self.freq_estimates_hz - self.natural_freq_hz) / self.natural_freq_hz
        err = self.relative_error_pct
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            for w, window in enumerate(self.windows):
                for m, method in enumerate(self.methods):
                    for i, n in enumerate(self.points_per_window):
                        e = err[w, m, i]
                        z = self.damping_estimates[w, m, i]
                        rows.append({
                            "window": window,
                            "method": method,
                            "points_per_window": int(n),
                            "df_hz": float(df[i]),
                            "df_over_br": float(df[i] / self.half_power_bandwidth_hz),
                            "mean_damping_ratio": float(np.nanmean(z)),
                            "mean_error_pct": float(np.nanmean(e)),
                            "std_error_pct": float(np.nanstd(e)),
                            "mean_abs_error_pct": float(np.nanmean(np.abs(e))),
                            "mean_freq_error_pct": float(np.nanmean(f_err[w, i])),
                            "n_valid": int(np.count_nonzero(np.isfinite(e))),
                        })
        frame = pd.DataFrame(rows)
        frame.attrs.update(
            natural_freq_hz=self.natural_freq_hz, damping_ratio=self.damping_ratio,
            fs_hz=self.fs_hz, n_averages=self.n_averages, noise_fraction=self.noise_fraction,
            n_seeds=self.n_seeds, seed=self.seed, static_reference=self.static_reference,
            floor_damping_ratio=dict(self.floor_damping_ratio))
        return frame

    def _plot_errors(self, ax):
        """The Figure 10.3 analogue: error (%) against points per window. Left: Bartlett,
        amplification and half-power readings, mean and +-1 std over the repetitions,
        with the chapter's two quoted points. Right: the amplification reading for every
        window."""
        n = self.points_per_window
        fig, axes = figure_axes(ax, 1, 2, figsize=(11, 4.2), constrained_layout=True,
                                sharey=True)
        first = self.windows[0]
        for method, style in zip(self.methods, ("o-", "s--"), strict=True):
            mean, std = self.error_stats(first, method)
            axes[0].errorbar(n, mean, yerr=std, fmt=style, ms=4, capsize=3,
                             label=f"{first}, {method.replace('_', '-')}")
        cx, cy = zip(*CHAPTER_POINTS, strict=True)
        axes[0].plot(cx, cy, "kx", ms=9, mew=2, label="chapter (read off Fig. 10.3)")
        for window in self.windows:
            mean, std = self.error_stats(window, "amplification")
            axes[1].errorbar(n, mean, yerr=std, fmt="o-", ms=4, capsize=3,
                             label=f"{window}, amplification")
        for ax in axes:
            ax.set_xscale("log")
            ax.set_yscale("symlog", linthresh=1.0)
            ax.axhline(0.0, color="0.5", lw=0.8)
            ax.grid(True, which="both", alpha=0.3)
            ax.set_xlabel(f"points per window ({self.n_averages} averages)")
            ax.legend(fontsize=8)
        axes[0].set_ylabel("damping error (zeta_est - zeta) / zeta [%]")
        fig.suptitle(
            f"SDOF f_n = {self.natural_freq_hz:g} Hz, zeta = {self.damping_ratio:g}, "
            f"fs = {self.fs_hz:g} Hz, noise std = {self.noise_fraction:g} std(q), "
            f"{self.n_seeds} records per point (Fig. 10.3)")
        return fig


def _read_damping(freq_hz, H, band_hz, reference):
    """(zeta_amplification, zeta_half_power, f_peak) from one FRF; NaN on failure."""
    from truthbench.identify import peak_picking

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        try:
            res = peak_picking(freq_hz, H, n_modes=1, frf_type="displacement",
                               freq_range_hz=band_hz, damping_method="amplification",
                               reference=reference)
        except ValueError:
            return np.nan, np.nan, np.nan
    if res.modal.n_modes == 0:
        return np.nan, np.nan, np.nan
    return (float(res.damping_amplification[0]), float(res.damping_half_power[0]),
            float(res.modal.freq_hz[0]))


def _floor(rec, fs_hz, f_n, zeta, static_gain):
    """Damping read from the exact FRF of the sampled system, on a fine grid."""
    sigma = 2 * np.pi * f_n * zeta
    n = int(math.ceil(40.0 / sigma * fs_hz))  # impulse response decayed by e^-40
    u = np.zeros(n + 1)
    u[1] = 1.0
    h = rec.simulate(u[None, :])[0, 1:]
    br = 2 * zeta * f_n
    f = np.linspace(max(f_n - 10 * br, 0.0), f_n + 10 * br, 4001)
    H = np.exp(-2j * np.pi * np.outer(f, np.arange(n)) / fs_hz) @ h
    za, zh, _ = _read_damping(f, H, None, float(static_gain))
    return {"amplification": za, "half_power": zh}


def damping_smoothing_study(
    points_per_window: Sequence[int] | None = None,
    *,
    natural_freq_hz: float = 10.0,
    damping_ratio: float = 0.01,
    fs_hz: float = 200.0,
    n_averages: int = 10,
    noise_fraction: float = 0.5,
    windows: Sequence[str] = ("bartlett", "hann", "hamming"),
    n_seeds: int = 20,
    seed: int = 0,
    static_reference: str = "exact",
    band_factor: float = 3.0,
) -> DampingSmoothingStudy:
    """Damping error from peak readings of smoothed FRFs against points per window.

    Parameters
    ----------
    points_per_window : sequence of int, optional
        Segment lengths N (>= 16); default :data:`DEFAULT_POINTS_PER_WINDOW`
        (10^2.5 .. 10^4.5).
    natural_freq_hz : float
        ``f_n``, Hz.
    damping_ratio : float
        ``zeta``.
    fs_hz : float
        Sampling frequency, Hz (> 2 ``band_factor`` ``f_n``).
    n_averages : int
        Non-overlapping segments per FRF (the chapter: 10).
    noise_fraction : float
        Output noise std over ``std(q)`` (the chapter: 0.5).
    windows : sequence of str
        Window names (:func:`truthbench.measure.get_window`); the first is the main one
        (plotted on the left).
    n_seeds : int
        Independent records per point.
    seed : int
        Root of the seed sequence (>= 0).
    static_reference : {"exact", "data"}
        Static value of the amplification reading (see the module notes).
    band_factor : float
        Peaks are searched between 0 and ``band_factor * f_n``.

    Returns
    -------
    DampingSmoothingStudy

    Raises
    ------
    ValueError
        Out-of-range settings (the message names the parameter).
    """
    from truthbench.measure import estimate_frf, get_window
    from truthbench.simulate import add_sensor_noise, prepare_lti

    pts = np.array(DEFAULT_POINTS_PER_WINDOW if points_per_window is None
                   else points_per_window)
    if pts.ndim != 1 or pts.size == 0 or np.any(pts != np.round(pts)) or np.any(pts < 16):
        raise ValueError(f"points_per_window must be integers >= 16; got {points_per_window!r}")
    pts = pts.astype(int)
    if static_reference not in ("exact", "data"):
        raise ValueError(
            f"static_reference must be 'exact' or 'data'; got {static_reference!r}")
    if int(n_seeds) != n_seeds or n_seeds < 1:
        raise ValueError(f"n_seeds must be a positive integer; got {n_seeds!r}")
    if int(n_averages) != n_averages or n_averages < 1:
        raise ValueError(f"n_averages must be a positive integer; got {n_averages!r}")
    if not (noise_fraction >= 0 and math.isfinite(noise_fraction)):
        raise ValueError(f"noise_fraction must be >= 0; got {noise_fraction!r}")
    if not (isinstance(seed, int | np.integer) and seed >= 0):
        raise ValueError(f"seed must be an integer >= 0; got {seed!r}")
    if not fs_hz > 2 * band_factor * natural_freq_hz:
        raise ValueError(
            f"fs_hz must exceed 2 band_factor natural_freq_hz = "
            f"{2 * band_factor * natural_freq_hz:g} Hz; got {fs_hz!r}")
    windows = tuple(windows)
    for w in windows:
        get_window(w, 16)  # unknown names fail here, before any simulation

    A, B, C, D = sdof_state_space(natural_freq_hz, damping_ratio)
    rec = prepare_lti(A, B, C, D, 1.0 / fs_hz)
    n_warm = int(math.ceil(8.0 / (2 * np.pi * natural_freq_hz * damping_ratio) * fs_hz))
    band = (0.0, band_factor * natural_freq_hz)
    reference = 1.0 if static_reference == "exact" else "static"

    n_w, n_p, n_s = len(windows), pts.size, int(n_seeds)
    zeta = np.full((n_w, len(METHODS), n_p, n_s), np.nan)
    freq = np.full((n_w, n_p, n_s), np.nan)
    for i, n in enumerate(pts):
        for j in range(n_s):
            rng = np.random.default_rng(np.random.SeedSequence(int(seed), spawn_key=(int(n), j)))
            u = rng.standard_normal(n_warm + int(n_averages) * int(n))
            q = rec.simulate(u[None, :])[0, n_warm:]
            y = add_sensor_noise(q, noise_fraction, rng)
            u = u[n_warm:]
            for k, window in enumerate(windows):
                est = estimate_frf(u, y, fs_hz, window=window, nperseg=int(n),
                                   n_averages=int(n_averages))
                za, zh, fp = _read_damping(est.freq_hz, est.H, band, reference)
                zeta[k, 0, i, j], zeta[k, 1, i, j], freq[k, i, j] = za, zh, fp
    return DampingSmoothingStudy(
        points_per_window=pts, windows=windows, methods=METHODS, damping_estimates=zeta,
        freq_estimates_hz=freq, damping_ratio=float(damping_ratio),
        natural_freq_hz=float(natural_freq_hz), fs_hz=float(fs_hz),
        n_averages=int(n_averages), noise_fraction=float(noise_fraction), seed=int(seed),
        static_reference=static_reference,
        floor_damping_ratio=_floor(rec, fs_hz, natural_freq_hz, damping_ratio, 1.0))
