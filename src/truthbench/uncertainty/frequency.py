"""The uncertainty model in the frequency domain (the chapter's Section 10.3: the mean
of the data gives the model and their variance bounds the transfer functions;
:ref:`method-uncertainty-model`).

From ``T`` FRF estimates ``H_j`` of the same outputs and inputs on the same frequency
lines, at every line and input-output pair:

* the mean ``Hbar = (1/T) sum_j H_j`` (Eq. 10.47 with unit weights);
* the 2 x 2 covariance ``Sigma`` of the real and imaginary parts (``ddof=1``, the
  unit-weight Eq. 10.48 on the pair ``(Re H, Im H)``);
* the ``k``-sigma region: the ellipse ``(h - Hbar)^T Sigma^-1 (h - Hbar) <= k^2`` in the
  complex plane, used by :meth:`FrfUncertainty.contains`.

Why the real/imaginary covariance and not magnitude/phase: it is what the noise of an
FRF estimate naturally is (near-Gaussian in real and imaginary parts, correlated between
them), it has no wrap-around or bias at small magnitudes, and the ellipse is the exact
normal-theory region. Magnitude and phase standard deviations are derived from it by
linearisation along the mean, ``sigma_|H| = sqrt(u^T Sigma u)`` with ``u = Hbar/|Hbar|``
and ``sigma_phase = sqrt(v^T Sigma v) / |Hbar|`` with ``v`` the orthogonal direction,
valid while ``k sigma`` is small against ``|Hbar|``; they are for plotting bands.

Expected fraction inside the ellipse for normal noise (:func:`expected_frf_coverage`):
``1 - exp(-k^2/2)`` (0.9889 at ``k = 3``; two degrees of freedom, not 0.9973) with the
covariance known; for a new estimate with ``Sigma`` estimated from ``T`` tests (Hotelling
``T^2``): ``P = F_{2, T-2}((T - 2) k^2 / (2 (T - 1) (1 + 1/T)))``, e.g. 0.8984 for
``T = 8`` and 0.9650 for ``T = 20``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import stats

from truthbench._validation import readonly
from truthbench.presentation import Presentable, figure_axes


def expected_frf_coverage(k=3.0, n_tests: int | None = None):
    """Normal-theory probability that an FRF value lies inside the ``k``-sigma ellipse.

    Parameters
    ----------
    k : float or array_like
        Bound multiplier(s), > 0.
    n_tests : int, optional
        ``T`` tests the mean and covariance were estimated from (>= 3); ``None``:
        both known, ``1 - exp(-k^2 / 2)``.

    Returns
    -------
    float or ndarray
    """
    kk = np.asarray(k, dtype=float)
    if np.any(~np.isfinite(kk)) or np.any(kk <= 0):
        raise ValueError(f"The 'k' parameter must be positive and finite; got {k!r}.")
    if n_tests is None:
        out = -np.expm1(-(kk**2) / 2.0)
    else:
        T = int(n_tests)
        if T != n_tests or T < 3:
            raise ValueError(f"The 'n_tests' parameter must be an integer >= 3; got {n_tests!r}.")
        out = stats.f.cdf((T - 2) * kk**2 / (2.0 * (T - 1) * (1.0 + 1.0 / T)), 2, T - 2)
    return float(out) if np.ndim(out) == 0 else out


@dataclass(frozen=True)
class FrfUncertainty(Presentable):
    """Mean FRF and its real/imaginary covariance over ``T`` tests.

    Table ``"lines"`` (:meth:`to_pandas`): one row per line and input-output pair.
    Figure ``"magnitude"`` (:meth:`plot`): ``|Hbar|`` with its ``k``-sigma band, one
    panel per input-output pair (options ``outputs``, ``inputs``: which).

    Attributes
    ----------
    mean : ndarray, complex, shape (n_freq, n_out, n_in)
        Mean FRF, in the FRFs' units (e.g. (m/s^2)/N).
    cov : ndarray, shape (n_freq, n_out, n_in, 2, 2)
        Covariance of ``(Re H, Im H)`` (``ddof=1``), units squared.
    n_tests : int
    k_sigma : float
    freq_hz : ndarray, shape (n_freq,), or None
    """

    TABLES = ("lines",)
    PLOTS = ("magnitude",)

    mean: np.ndarray
    cov: np.ndarray
    n_tests: int
    k_sigma: float = 3.0
    freq_hz: np.ndarray | None = None

    @property
    def std_real(self) -> np.ndarray:
        """Standard deviation of ``Re H``, shape (n_freq, n_out, n_in)."""
        return np.sqrt(self.cov[..., 0, 0])

    @property
    def std_imag(self) -> np.ndarray:
        """Standard deviation of ``Im H``, shape (n_freq, n_out, n_in)."""
        return np.sqrt(self.cov[..., 1, 1])

    @property
    def std_complex(self) -> np.ndarray:
        """``sqrt(E|H - Hbar|^2) = sqrt(trace Sigma)``, shape (n_freq, n_out, n_in)."""
        return np.sqrt(self.cov[..., 0, 0] + self.cov[..., 1, 1])

    def _directions(self):
        m = self.mean
        a = np.abs(m)
        safe = np.where(a > 0, a, 1.0)
        u = np.stack([np.where(a > 0, m.real / safe, 1.0), np.where(a > 0, m.imag / safe, 0.0)],
                     axis=-1)
        v = np.stack([-u[..., 1], u[..., 0]], axis=-1)
        return u, v, a

    @property
    def std_magnitude(self) -> np.ndarray:
        """Linearised standard deviation of ``|H|``, shape (n_freq, n_out, n_in)."""
        u, _, _ = self._directions()
        return np.sqrt(np.einsum("...i,...ij,...j->...", u, self.cov, u))

    @property
    def std_phase_rad(self) -> np.ndarray:
        """Linearised standard deviation of the phase, rad (inf where ``Hbar = 0``)."""
        _, v, a = self._directions()
        sv = np.sqrt(np.einsum("...i,...ij,...j->...", v, self.cov, v))
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(a > 0, sv / np.where(a > 0, a, 1.0), np.inf)

    def magnitude_band(self) -> tuple[np.ndarray, np.ndarray]:
        """``|Hbar| -+ k sigma_|H|`` (lower clipped at 0), each (n_freq, n_out, n_in)."""
        a = np.abs(self.mean)
        b = self.k_sigma * self.std_magnitude
        return np.clip(a - b, 0.0, None), a + b

    def mahalanobis2(self, H) -> np.ndarray:
        """Squared Mahalanobis distance of ``H`` from the mean in the (Re, Im) plane.

        Parameters
        ----------
        H : array_like, complex, shape (..., n_freq, n_out, n_in)

        Returns
        -------
        ndarray, shape (..., n_freq, n_out, n_in)
            Where the covariance is singular (``det <= 1e-12 trace^2``) the radial
            distance ``|H - Hbar|^2 / trace(Sigma)`` is used (``inf`` if the trace is 0
            and ``H != Hbar``).
        """
        Z = np.asarray(H)
        if Z.shape[-3:] != self.mean.shape:
            raise ValueError(f"The 'H' parameter must end in the FRF shape {self.mean.shape} "
                             f"(n_freq, n_out, n_in); got shape {Z.shape}.")
        d = Z - self.mean
        a, b = d.real, d.imag
        s11, s22, s12 = self.cov[..., 0, 0], self.cov[..., 1, 1], self.cov[..., 0, 1]
        det = s11 * s22 - s12**2
        tr = s11 + s22
        good = det > 1e-12 * tr**2
        with np.errstate(divide="ignore", invalid="ignore"):
            full = (a**2 * s22 - 2 * a * b * s12 + b**2 * s11) / np.where(good, det, 1.0)
            r2 = a**2 + b**2
            radial = np.where(tr > 0, r2 / np.where(tr > 0, tr, 1.0),
                              np.where(r2 == 0, 0.0, np.inf))
        return np.where(good, full, radial)

    def contains(self, H) -> np.ndarray:
        """Whether ``H`` lies inside the ``k``-sigma ellipse, line by line.

        Parameters
        ----------
        H : array_like, complex, shape (..., n_freq, n_out, n_in)

        Returns
        -------
        ndarray of bool, same shape as ``H``
        """
        return self.mahalanobis2(H) <= self.k_sigma**2

    def fraction_inside(self, H) -> float:
        """Fraction of all entries of ``H`` inside the ellipse (compare with
        :func:`expected_frf_coverage`)."""
        return float(np.mean(self.contains(H)))

    def _plot_magnitude(self, ax, *, outputs=None, inputs=None):
        """``|Hbar|`` and its band ``|Hbar| -+ k sigma_|H|`` against frequency (or the
        line index when the frequencies are not known), one panel per pair."""
        _, no, ni = self.mean.shape
        pairs = [(o, i) for i in (range(ni) if inputs is None else inputs)
                 for o in (range(no) if outputs is None else outputs)]
        fig, axes = figure_axes(ax, len(pairs), sharex=True,
                                figsize=(7, 2.2 * len(pairs) + 0.8))
        x = self.freq_hz if self.freq_hz is not None else np.arange(self.mean.shape[0])
        low, high = self.magnitude_band()
        for a, (o, i) in zip(axes, pairs, strict=False):
            a.fill_between(x, np.maximum(low[:, o, i], 1e-300), high[:, o, i], color="C0",
                           alpha=0.25, lw=0, label=f"{self.k_sigma:g}-sigma band")
            a.semilogy(x, np.abs(self.mean[:, o, i]), color="C0", lw=1.0, label="mean")
            a.set_ylabel(f"|H| y{o}/x{i}")
        axes[0].legend(fontsize="small")
        axes[len(pairs) - 1].set_xlabel("frequency [Hz]" if self.freq_hz is not None
                                        else "line")
        axes[0].set_title(f"mean FRF over {self.n_tests} tests", fontsize="medium")
        fig.tight_layout()
        return fig

    def _table_lines(self):
        """One row per line and input-output pair: MultiIndex ``(line, output, input)``;
        columns ``freq_hz`` (if known), ``mean_real``, ``mean_imag``, ``std_real``,
        ``std_imag``, ``corr_real_imag``, ``std_magnitude``, ``std_phase_rad``."""
        import pandas as pd

        nf, no, ni = self.mean.shape
        idx = pd.MultiIndex.from_product([range(nf), range(no), range(ni)],
                                         names=["line", "output", "input"])
        with np.errstate(divide="ignore", invalid="ignore"):
            corr = self.cov[..., 0, 1] / (self.std_real * self.std_imag)
        cols = {}
        if self.freq_hz is not None:
            cols["freq_hz"] = np.repeat(self.freq_hz, no * ni)
        cols.update({
            "mean_real": self.mean.real.ravel(), "mean_imag": self.mean.imag.ravel(),
            "std_real": self.std_real.ravel(), "std_imag": self.std_imag.ravel(),
            "corr_real_imag": corr.ravel(), "std_magnitude": self.std_magnitude.ravel(),
            "std_phase_rad": self.std_phase_rad.ravel(),
        })
        return pd.DataFrame(cols, index=idx)


def frf_uncertainty(H_tests, *, freq_hz=None, k_sigma: float = 3.0) -> FrfUncertainty:
    """Mean FRF and (Re, Im) covariance of ``T`` FRF estimates.

    Parameters
    ----------
    H_tests : array_like, complex, shape (T, n_freq, n_out, n_in)
        One FRF estimate per test on common frequency lines; a 2-D ``(T, n_freq)`` array
        is one SISO pair.
    freq_hz : array_like, shape (n_freq,), optional
        The frequency lines, Hz (kept for tables and plots).
    k_sigma : float
        Bound multiplier, > 0.

    Returns
    -------
    FrfUncertainty

    Raises
    ------
    ValueError
        Wrong shape, fewer than 3 tests (a 2 x 2 covariance from 2 tests is singular),
        NaN or infinite values.
    """
    H = np.array(H_tests, dtype=complex, copy=True)
    if H.ndim == 2:
        H = H[:, :, None, None]
    if H.ndim != 4:
        raise ValueError(f"The 'H_tests' parameter must have shape (T, n_freq, n_out, n_in); "
                         f"got shape {np.shape(H_tests)}.")
    T = H.shape[0]
    if T < 3:
        raise ValueError(f"The 'H_tests' parameter must hold at least 3 tests (the 2 x 2 "
                         f"covariance of real and imaginary parts from 2 tests is singular); "
                         f"got {T}.")
    if not np.all(np.isfinite(H)):
        raise ValueError("The 'H_tests' parameter must be finite; got NaN or infinite values.")
    k = float(k_sigma)
    if not (np.isfinite(k) and k > 0):
        raise ValueError(f"The 'k_sigma' parameter must be a positive number; got {k_sigma!r}.")
    f = None
    if freq_hz is not None:
        f = np.array(freq_hz, dtype=float, copy=True).reshape(-1)
        if f.shape != (H.shape[1],):
            raise ValueError(f"The 'freq_hz' parameter must have shape ({H.shape[1]},); "
                             f"got shape {np.shape(freq_hz)}.")
    mean = H.mean(axis=0)
    d = H - mean
    X = np.stack([d.real, d.imag], axis=-1)  # (T, nf, no, ni, 2)
    cov = np.einsum("t...i,t...j->...ij", X, X) / (T - 1)
    return FrfUncertainty(
        mean=readonly(mean, complex), cov=readonly(cov, float), n_tests=int(T),
        k_sigma=k, freq_hz=None if f is None else readonly(f, float),
    )
