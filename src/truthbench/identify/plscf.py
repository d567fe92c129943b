"""Polyreference least-squares complex frequency-domain estimator (pLSCF, "PolyMAX").

Model (right matrix fraction, real coefficients, z-domain basis). With
``dt = 1 / (2 f_max)``, ``theta_k = 2 pi f_k dt`` and the basis functions
``Omega_r(f_k) = exp(-j theta_k r)``, each output row of the FRF is

    H_o(f) = N_o(f) D(f)^-1,   N_o = sum_{r=0}^{n} Omega_r beta_{o,r},
                                D   = sum_{r=0}^{n} Omega_r alpha_r,

``beta_{o,r}`` (1, n_in), ``alpha_r`` (n_in, n_in). The linearised equation error
``N_o - H_o D`` gives, per output, the real normal matrices (Peeters et al., 2004)

    R   = Re(X^H X),  S_o = Re(X^H Y_o),  T_o = Re(Y_o^H Y_o),

and eliminating the numerators leaves the *reduced normal equations*

    M alpha = 0,   M = sum_o (T_o - S_o^T R^-1 S_o),

solved with the constraint ``alpha_n = I``. Because ``conj(Omega_r) Omega_s`` depends only
on ``r - s``, ``R``, ``S_o`` and ``T_o`` are block Toeplitz: they are built once, for the
highest order, from ``2 n_max + 1`` lag sums (one matrix product each) and every lower
order uses their leading blocks.

Poles are the eigenvalues ``x`` of the block companion matrix of ``sum alpha_r^T x^r``
mapped by ``lambda = -ln(x) / dt`` (rad/s); the first ``n_in`` rows of each eigenvector
are the participation factors.

Stability (between consecutive orders, each pole matched to the previous order's pole
closest in frequency), defaults in :class:`StabilityCriteria`:

* frequency: ``|f_n - f_{n-1}| / f_{n-1} < 1 %``,
* damping:   ``|zeta_n - zeta_{n-1}| / zeta_{n-1} < 5 %``,
* vector:    MAC of the participation vectors ``> 0.98`` (always true for one input).

Automatic selection (:func:`select_poles`): the poles stable in all three senses and
physical (``Re lambda < 0``, ``0 < zeta < max_damping_ratio``, frequency inside the band)
are clustered (average linkage) on ``d = |lambda_i - lambda_j| / max|lambda| +
vector_weight (1 - MAC(L_i, L_j))``; clusters that appear in at least ``min_fraction`` of
the orders are modes, represented by the median pole of the members (one per order) from
the upper half of the cluster's orders, since the z-domain model approximates a
continuous-time FRF better with over-modelling. Residues then come from
:func:`truthbench.identify.lsfd.lsfd`; optionally (``refine=True``) the poles are first
refined by the output-error fit :func:`truthbench.identify.lsfd.refine_poles`, which
removes most of the noise bias of the linearised estimator.

References: B. Peeters, H. Van der Auweraer, P. Guillaume, J. Leuridan, "The PolyMAX
frequency-domain method: a new standard for modal parameter estimation?", Shock and
Vibration 11 (2004) 395-409; P. Guillaume et al., "A poly-reference implementation of the
least-squares complex frequency-domain estimator", IMAC XXI (2003).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
import scipy.linalg as sla

from truthbench.errors import IdentifiabilityError
from truthbench.identify._common import check_freq_frf, frf_power, readonly, select_band
from truthbench.identify.lsfd import LSFDResult, lsfd, refine_poles
from truthbench.identify.modal import ModalParameters, modal_from_poles
from truthbench.presentation import Presentable, figure_axes
from truthbench.settings import Configurable, setting

#: Fewest orders a cluster of stable poles must come from to be a mode.
MIN_STABLE_ORDERS = 3

#: Least :func:`mode_significance` of a mode: it explains at least as much of the data
#: in its band as the fit leaves unexplained there.
SIGNIFICANCE_MIN = 1.0


@dataclass(frozen=True)
class StabilityCriteria:
    """Tolerances of the stabilization diagram.

    Parameters
    ----------
    freq_tol : float
        Largest relative change of the natural frequency between consecutive orders.
    damping_tol : float
        Largest relative change of the damping ratio between consecutive orders.
    mac_min : float
        Smallest MAC between the participation vectors of consecutive orders.
    max_damping_ratio : float
        Poles with a larger damping ratio (or non-positive damping) are not physical.
    """

    freq_tol: float = 0.01
    damping_tol: float = 0.05
    mac_min: float = 0.98
    max_damping_ratio: float = 0.2

    def __post_init__(self):
        for name in ("freq_tol", "damping_tol", "max_damping_ratio"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v > 0):
                raise ValueError(f"The '{name}' parameter must be positive; got {v!r}.")
        if not 0 <= self.mac_min <= 1:
            raise ValueError(f"The 'mac_min' parameter must lie in [0, 1]; got {self.mac_min!r}.")


@dataclass(frozen=True, kw_only=True)
class PLSCFIdentifier(Configurable):
    """The registered identifier ``"plscf"``: pLSCF, automatic pole selection and LSFD
    (:func:`identify_plscf`, whose defaults are these), configured by its settings.

    Calling it, ``identifier(freq_hz, frf, *, frf_type="displacement",
    freq_range_hz=None)``, returns the :class:`ModalParameters`."""

    name: ClassVar[str] = "plscf"

    max_order: int = setting(
        40, "Highest pLSCF model order (order n gives n x n_in poles); a rule of thumb: "
        "max_order x n_in about 2-4 times twice the number of modes in the band.",
        low=2, high=200)

    def __call__(self, freq_hz, frf, *, frf_type: str = "displacement",
                 freq_range_hz: tuple[float, float] | None = None) -> ModalParameters:
        return identify_plscf(freq_hz, frf, frf_type=frf_type, freq_range_hz=freq_range_hz,
                              **self.settings()).modal


def _ro_tuple(arrays) -> tuple[np.ndarray, ...]:
    return tuple(readonly(a) for a in arrays)


@dataclass(frozen=True)
class StabilizationDiagram(Presentable):
    """Poles of every model order and their stability flags.

    Attributes
    ----------
    orders : ndarray, int, shape (n_orders,)
        Polynomial orders (the number of poles of order ``n`` is ``n * n_in``).
    poles : tuple of ndarray, complex
        Per order, the poles with positive imaginary part, rad/s, sorted by frequency.
    participation : tuple of ndarray, complex
        Per order, shape (n_poles, n_in): participation vectors, unit norm.
    stable_freq, stable_damping, stable_vector : tuple of ndarray, bool
        Per order and pole: stable against the previous order in frequency; in frequency
        and damping; in frequency and participation vector. The first order has none.
    physical : tuple of ndarray, bool
        ``Re lambda < 0``, ``0 < zeta < max_damping_ratio`` and frequency in the band.
    freq_range_hz : tuple of float
        Band of the data used.
    criteria : StabilityCriteria
    """

    TABLES = ("poles",)
    PLOTS = ("diagram",)

    orders: np.ndarray
    poles: tuple
    participation: tuple
    stable_freq: tuple
    stable_damping: tuple
    stable_vector: tuple
    physical: tuple
    freq_range_hz: tuple[float, float]
    criteria: StabilityCriteria = field(default_factory=StabilityCriteria)

    def __post_init__(self):
        object.__setattr__(self, "orders", readonly(np.asarray(self.orders, dtype=int)))
        for name in (
            "poles",
            "participation",
            "stable_freq",
            "stable_damping",
            "stable_vector",
            "physical",
        ):
            object.__setattr__(self, name, _ro_tuple(getattr(self, name)))

    @property
    def stable(self) -> tuple[np.ndarray, ...]:
        """Per order, poles stable in frequency, damping and vector (bool arrays)."""
        return tuple(
            sf & sd & sv
            for sf, sd, sv in zip(
                self.stable_freq, self.stable_damping, self.stable_vector, strict=True
            )
        )

    def _table_poles(self):
        """Long table, one row per pole and order: columns ``order``, ``freq_hz``,
        ``damping_ratio``, ``pole_real_rad_s``, ``pole_imag_rad_s``, ``stable_freq``,
        ``stable_damping``, ``stable_vector``, ``stable``, ``physical``."""
        import pandas as pd

        frames = []
        for k, n in enumerate(self.orders):
            s = self.poles[k]
            f, z = modal_from_poles(s)
            frames.append(
                pd.DataFrame(
                    {
                        "order": np.full(s.size, n, dtype=int),
                        "freq_hz": f,
                        "damping_ratio": z,
                        "pole_real_rad_s": s.real,
                        "pole_imag_rad_s": s.imag,
                        "stable_freq": self.stable_freq[k],
                        "stable_damping": self.stable_damping[k],
                        "stable_vector": self.stable_vector[k],
                        "stable": self.stable[k],
                        "physical": self.physical[k],
                    }
                )
            )
        return pd.concat(frames, ignore_index=True)

    def _plot_diagram(self, ax, *, freq_hz=None, frf=None,
                      selected: ModalParameters | None = None):
        """Draw the stabilization diagram (order against frequency).

        Markers: open circle, a new pole; dot, stable in frequency; triangle, stable in
        frequency and damping; filled circle, stable in frequency, damping and
        participation vector. Only physical poles are drawn.

        Parameters
        ----------
        ax : matplotlib Axes, optional
            Axes to draw in (a new figure is made if omitted).
        freq_hz, frf : array_like, optional
            If both given, ``sum |H|`` over channels is drawn on a twin log axis.
        selected : ModalParameters, optional
            Draws vertical lines at the selected frequencies.

        Returns
        -------
        matplotlib.figure.Figure
        """
        fig, (ax,) = figure_axes(ax, figsize=(8, 5))
        styles = [
            ("new", dict(marker="o", mfc="none", mec="0.6", ms=4, ls="none")),
            ("freq", dict(marker=".", color="tab:blue", ms=5, ls="none")),
            ("damp", dict(marker="^", color="tab:orange", ms=4, ls="none")),
            ("stable", dict(marker="o", color="tab:green", ms=4, ls="none")),
        ]
        groups = {name: ([], []) for name, _ in styles}
        for k, n in enumerate(self.orders):
            f, _ = modal_from_poles(self.poles[k])
            ph = self.physical[k]
            st = self.stable[k]
            cat = np.where(
                st,
                "stable",
                np.where(
                    self.stable_damping[k], "damp", np.where(self.stable_freq[k], "freq", "new")
                ),
            )
            for name in groups:
                sel = ph & (cat == name)
                groups[name][0].extend(f[sel])
                groups[name][1].extend([n] * int(sel.sum()))
        labels = {
            "new": "new",
            "freq": "stable f",
            "damp": "stable f, zeta",
            "stable": "stable f, zeta, L",
        }
        for name, style in styles:
            ax.plot(groups[name][0], groups[name][1], label=labels[name], **style)
        if selected is not None:
            for fs in selected.freq_hz:
                ax.axvline(fs, color="k", lw=0.6, ls="--")
        ax.set_xlim(*self.freq_range_hz)
        ax.set_xlabel("frequency (Hz)")
        ax.set_ylabel("model order")
        ax.legend(loc="upper left", fontsize="small")
        if freq_hz is not None and frf is not None:
            H = np.asarray(frf)
            H = H.reshape(H.shape[0], -1)
            ax2 = ax.twinx()
            ax2.semilogy(np.asarray(freq_hz), np.abs(H).sum(axis=1), color="0.3", lw=0.8)
            ax2.set_ylabel("sum |H|")
            ax.set_zorder(ax2.get_zorder() + 1)  # markers above the FRF curve
            ax.patch.set_visible(False)
        return fig


@dataclass(frozen=True)
class PoleSelection:
    """Poles chosen automatically from a stabilization diagram.

    Attributes
    ----------
    poles : ndarray, complex, shape (n_modes,)
        Cluster representatives (median of the members from the upper half of the
        cluster's orders), rad/s, sorted by frequency.
    participation : ndarray, complex, shape (n_modes, n_in)
        Participation vector of the member nearest the representative.
    n_members : ndarray, int, shape (n_modes,)
        Number of distinct orders in each cluster.
    freq_std_hz, damping_std : ndarray, shape (n_modes,)
        Scatter (standard deviation) of the members' frequency and damping across orders.
    dropped : ndarray, complex
        Poles the stability rule chose but :func:`mode_significance` left out (rad/s).
    significance : ndarray, shape (n_modes,), or None
        For the kept poles, their :func:`mode_significance` (None when it was not
        computed).
    """

    poles: np.ndarray
    participation: np.ndarray
    n_members: np.ndarray
    freq_std_hz: np.ndarray
    damping_std: np.ndarray
    dropped: np.ndarray = field(default_factory=lambda: np.zeros(0, complex))
    significance: np.ndarray | None = None

    def __post_init__(self):
        for name in ("poles", "participation", "n_members", "freq_std_hz", "damping_std",
                     "dropped", "significance"):
            if getattr(self, name) is not None:
                object.__setattr__(self, name, readonly(getattr(self, name)))

    def keep(self, mask, *, significance=None) -> PoleSelection:
        """A selection of the poles where ``mask`` is true (the others join ``dropped``);
        ``significance`` is given for all poles and kept for these."""
        mask = np.asarray(mask, dtype=bool)
        return PoleSelection(
            poles=self.poles[mask], participation=self.participation[mask],
            n_members=self.n_members[mask], freq_std_hz=self.freq_std_hz[mask],
            damping_std=self.damping_std[mask],
            dropped=np.concatenate([self.dropped, self.poles[~mask]]),
            significance=None if significance is None else np.asarray(significance)[mask])


@dataclass(frozen=True)
class PLSCFResult(Presentable):
    """Everything :func:`identify_plscf` produced.

    Tables (:meth:`to_pandas`): ``"modes"`` the selected modes, ``"poles"`` every pole of
    the diagram. Figures (:meth:`plot`): ``"diagram"`` the stabilization diagram with the
    selected frequencies, ``"shapes"`` the shapes.

    Attributes
    ----------
    modal : ModalParameters
        Frequencies and damping of the selected poles; shapes and participation from the
        LSFD residues (see :meth:`LSFDResult.modal_parameters`).
    diagram : StabilizationDiagram
    selection : PoleSelection
    lsfd : LSFDResult
        Residues and residual terms (use for mass normalisation or reconstruction).
    """

    TABLES = ("modes", "poles")
    PLOTS = ("diagram", "shapes")

    modal: ModalParameters
    diagram: StabilizationDiagram
    selection: PoleSelection
    lsfd: LSFDResult

    def _table_modes(self):
        """One row per selected mode (:class:`ModalParameters`)."""
        return self.modal.to_pandas("modes")

    def _table_poles(self):
        """One row per pole and order of the diagram."""
        return self.diagram.to_pandas("poles")

    def _plot_diagram(self, ax, **options):
        """The stabilization diagram, the selected frequencies marked (options
        ``freq_hz``, ``frf``: an FRF drawn behind it)."""
        return self.diagram.plot("diagram", ax, selected=self.modal, **options)

    def _plot_shapes(self, ax):
        """The selected modes' shapes."""
        return self.modal.plot("shapes", ax)


def _lag_sums(theta: np.ndarray, H: np.ndarray, p: int):
    """Block-Toeplitz normal matrices R, S (per output) and sum_o T_o at order ``p``."""
    nf, no, ni = H.shape
    # the real parts of sum_f exp(j k theta_f) X_f for lags k = -p..p from the cosines
    # and sines of k = 0..p (even and odd in k): real products only. The powers
    # exp(j k theta) by repeated multiplication (relative rounding below (k + 1) eps)
    w = np.exp(1j * theta)
    powers = np.empty((p + 1, nf), complex)
    powers[0] = 1.0
    for k in range(1, p + 1):
        np.multiply(powers[k - 1], w, out=powers[k])
    c, s = powers.real, powers.imag  # (p + 1, nf)

    def lagged(X):
        """``Re sum_f exp(j k theta_f) X_f`` for k = -p..p, shape (2p + 1, ...)."""
        flat = X.reshape(nf, -1)
        cr, si = c @ flat.real, s @ flat.imag
        out = np.concatenate([(cr + si)[:0:-1], cr - si])
        return out.reshape((2 * p + 1,) + X.shape[1:])

    r_lag = np.concatenate([c.sum(axis=1)[:0:-1], c.sum(axis=1)])
    s_lag = -lagged(H)
    P = np.einsum("koi,koj->kij", H.conj(), H)
    t_lag = lagged(P)
    idx = np.arange(p + 1)
    mm = idx[:, None] - idx[None, :] + p
    R = r_lag[mm]
    S = s_lag[mm].transpose(2, 0, 1, 3).reshape(no, p + 1, (p + 1) * ni)
    T = t_lag[mm].transpose(0, 2, 1, 3).reshape((p + 1) * ni, (p + 1) * ni)
    return R, S, T


def _solve(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", RuntimeWarning)
            X = np.linalg.solve(A, B)
        if np.all(np.isfinite(X)):
            return X
    except (np.linalg.LinAlgError, RuntimeWarning):
        pass
    return np.linalg.lstsq(A, B, rcond=None)[0]


def _reduced_normal(R: np.ndarray, S: np.ndarray, T: np.ndarray, ni: int):
    """``n -> M_n = T_n - sum_o S_on^T R_n^-1 S_on``, the reduced normal matrix of order
    ``n`` (``R_n``, ``S_on``, ``T_n`` the leading blocks of order ``n``).

    With the Cholesky factor ``R = L L^T`` every leading block factors as
    ``R_n = L_n L_n^T`` and, ``L`` being lower triangular, ``L_n^-1 S_on`` is the leading
    block of ``Y_o = L^-1 S_o``: one triangular solve at the highest order serves every
    order, ``M_n = T_n - sum_o Y_on^T Y_on``. Where ``R`` is not numerically positive
    definite each order solves with its own ``R_n`` (LU, least squares if singular)."""
    no = S.shape[0]
    try:
        chol = np.linalg.cholesky(R)
    except np.linalg.LinAlgError:
        chol = None
    if chol is None:
        def at(n: int) -> np.ndarray:
            Rn = R[: n + 1, : n + 1]
            Sn = S[:, : n + 1, : (n + 1) * ni]
            X = _solve(Rn, np.concatenate(list(Sn), axis=1)).reshape(n + 1, no, -1)
            return T[: (n + 1) * ni, : (n + 1) * ni] - np.einsum("oab,aoc->bc", Sn, X)
        return at
    Y = sla.solve_triangular(chol, np.concatenate(list(S), axis=1), lower=True,
                             check_finite=False)
    Y = Y.reshape(R.shape[0], no, -1)  # (p + 1, no, (p + 1) ni): row k of every Y_o

    def at(n: int) -> np.ndarray:
        m = (n + 1) * ni
        Yn = Y[: n + 1, :, :m].reshape(-1, m)
        return T[:m, :m] - Yn.T @ Yn
    return at


def _poles_at_order(M: np.ndarray, n: int, ni: int, dt: float):
    """Poles (rad/s, Im > 0) and participation vectors of polynomial order ``n`` from the
    reduced normal matrix ``M`` of that order (:func:`_reduced_normal`)."""
    k = n * ni
    alpha = -_solve(M[:k, :k], M[:k, k:])  # (n ni, ni): alpha_0 .. alpha_{n-1}
    C = np.zeros((k, k))
    if n > 1:
        C[:-ni, ni:] = np.eye(k - ni)
    C[-ni:, :] = -alpha.reshape(n, ni, ni).transpose(0, 2, 1).transpose(1, 0, 2).reshape(ni, k)
    if ni == 1:  # a scalar participation of unit norm: 1 (the eigenvector's phase is
        x = np.linalg.eigvals(C)  # arbitrary), and no eigenvectors to compute
    else:
        x, V = np.linalg.eig(C)
    with np.errstate(divide="ignore", invalid="ignore"):
        lam = -np.log(x.astype(complex)) / dt
    ok = np.isfinite(lam) & (lam.imag > 0)
    lam = lam[ok]
    if ni == 1:
        L = np.ones((lam.size, 1), complex)
    else:
        L = V[:ni, ok].T
        L = L / np.maximum(np.linalg.norm(L, axis=1, keepdims=True), 1e-300)
    order = np.argsort(lam.imag)
    return lam[order], L[order]


def _mac_rows(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """MAC between rows of a (n, k) and rows of b (n, k), pairwise row by row."""
    num = np.abs(np.sum(a.conj() * b, axis=1)) ** 2
    den = np.sum(np.abs(a) ** 2, axis=1) * np.sum(np.abs(b) ** 2, axis=1)
    return np.where(den > 0, num / np.where(den > 0, den, 1.0), 0.0)


def plscf_stabilization(
    freq_hz,
    frf,
    max_order: int = PLSCFIdentifier.max_order,
    *,
    min_order: int = 1,
    freq_range_hz: tuple[float, float] | None = None,
    criteria: StabilityCriteria | None = None,
    output_weighting: str = "rms",
) -> StabilizationDiagram:
    """pLSCF poles for every order ``min_order..max_order`` and their stability.

    Parameters
    ----------
    freq_hz : array_like, shape (n_freq,)
        Frequency lines, Hz (any spacing).
    frf : array_like, complex, shape (n_freq, n_out, n_in)
        FRF of any type (the poles do not depend on it).
    max_order, min_order : int
        Polynomial orders; order ``n`` yields ``n * n_in`` poles (conjugates included).
    freq_range_hz : (float, float), optional
        Band to fit; ``dt = 1 / (2 f_max)`` with ``f_max`` the highest line used.
    criteria : StabilityCriteria, optional
    output_weighting : {"rms", "none"}
        ``"rms"`` divides each output's FRFs by their RMS over frequency and inputs so
        every output weighs the same; ``"none"`` uses the data as given.

    Returns
    -------
    StabilizationDiagram

    Raises
    ------
    ValueError
        Bad shapes or options.
    IdentifiabilityError
        Fewer real equations than real unknowns at ``max_order``:
        ``2 n_freq n_out n_in < (max_order + 1) n_in (n_out + n_in) - n_in^2``, or fewer
        than ``max_order + 1`` lines (then ``R`` is singular).
    """
    criteria = StabilityCriteria() if criteria is None else criteria
    f, H = check_freq_frf(freq_hz, frf)
    f, H = select_band(f, H, freq_range_hz)
    if not isinstance(max_order, int | np.integer) or max_order < 1:
        raise ValueError(f"The 'max_order' parameter must be an integer >= 1; got {max_order!r}.")
    if not isinstance(min_order, int | np.integer) or not 1 <= min_order <= max_order:
        raise ValueError(
            f"The 'min_order' parameter must be an integer in [1, max_order={max_order}]; "
            f"got {min_order!r}."
        )
    if output_weighting not in ("rms", "none"):
        raise ValueError(
            f"The 'output_weighting' parameter must be 'rms' or 'none'; got {output_weighting!r}."
        )
    nf, no, ni = H.shape
    n_eq = 2 * nf * no * ni
    n_unknown = (max_order + 1) * ni * (no + ni) - ni * ni
    if n_eq < n_unknown or nf < max_order + 1:
        raise IdentifiabilityError(
            f"plscf: {nf} frequency lines x {no} outputs x {ni} inputs give {n_eq} real "
            f"equations, but max_order={max_order} has {n_unknown} real unknowns (and needs "
            f"at least {max_order + 1} lines); expected more frequency lines or a lower "
            "max_order."
        )
    if output_weighting == "rms":
        rms = np.sqrt(np.mean(np.abs(H) ** 2, axis=(0, 2)))
        rms[rms == 0] = 1.0
        H = H / rms[None, :, None]
    f_max = float(f[-1])
    dt = 1.0 / (2.0 * f_max)
    theta = 2.0 * np.pi * f * dt
    R, S, T = _lag_sums(theta, H, max_order)
    reduced = _reduced_normal(R, S, T, ni)
    band = (float(f[0]), f_max)

    orders = list(range(min_order, max_order + 1))
    poles, parts, s_f, s_d, s_v, phys = [], [], [], [], [], []
    prev = None
    for n in orders:
        lam, L = _poles_at_order(reduced(n), n, ni, dt)
        fn, zn = modal_from_poles(lam)
        physical = (
            (lam.real < 0)
            & (zn > 0)
            & (zn < criteria.max_damping_ratio)
            & (fn >= band[0])
            & (fn <= band[1])
        )
        sf = np.zeros(lam.size, dtype=bool)
        sd = np.zeros(lam.size, dtype=bool)
        sv = np.zeros(lam.size, dtype=bool)
        if prev is not None and prev[0].size and lam.size:
            fp, zp, Lp = prev
            rel = np.abs(fn[:, None] - fp[None, :]) / np.where(fp > 0, fp, np.inf)[None, :]
            j = np.argmin(rel, axis=1)
            sf = rel[np.arange(lam.size), j] < criteria.freq_tol
            zj = zp[j]
            with np.errstate(divide="ignore", invalid="ignore"):
                dz = np.abs(zn - zj) / np.abs(zj)
            sd = sf & (dz < criteria.damping_tol)
            sv = sf & (_mac_rows(L, Lp[j]) > criteria.mac_min)
        poles.append(lam)
        parts.append(L)
        s_f.append(sf)
        s_d.append(sd)
        s_v.append(sv)
        phys.append(physical)
        prev = (fn, zn, L)
    return StabilizationDiagram(
        orders=np.asarray(orders),
        poles=tuple(poles),
        participation=tuple(parts),
        stable_freq=tuple(s_f),
        stable_damping=tuple(s_d),
        stable_vector=tuple(s_v),
        physical=tuple(phys),
        freq_range_hz=band,
        criteria=criteria,
    )


def _average_linkage_labels(
    lam: np.ndarray, L: np.ndarray, cut: float, vector_weight: float
) -> np.ndarray:
    """Average-linkage cluster labels of poles cut at ``cut``.

    The poles are first split wherever consecutive ``|lambda|`` (sorted) differ by more
    than ``cut`` relatively: every distance across such a gap exceeds ``cut``, so average
    linkage never joins across it, and clustering each piece alone gives the same
    clusters with memory quadratic only in the piece size.
    """
    from scipy.cluster.hierarchy import fcluster, linkage

    mag = np.abs(lam)
    order = np.argsort(mag)
    gaps = np.flatnonzero(np.diff(mag[order]) / mag[order][1:] > cut)
    labels = np.zeros(lam.size, dtype=int)
    next_label = 0
    for piece in np.split(order, gaps + 1):
        if piece.size == 1:
            labels[piece] = next_label
            next_label += 1
            continue
        lp, mp = lam[piece], mag[piece]
        d = np.abs(lp[:, None] - lp[None, :]) / np.maximum(mp[:, None], mp[None, :])
        if vector_weight > 0:
            Lp = L[piece]
            nn = np.sum(np.abs(Lp) ** 2, axis=1)
            d = d + vector_weight * (1.0 - np.abs(Lp.conj() @ Lp.T) ** 2 / np.outer(nn, nn))
        d = 0.5 * (d + d.T)
        iu = np.triu_indices(piece.size, 1)
        sub = fcluster(
            linkage(np.maximum(d[iu], 0.0), method="average"), t=cut, criterion="distance"
        )
        labels[piece] = sub - 1 + next_label
        next_label += int(sub.max())
    return labels


def select_poles(
    diagram: StabilizationDiagram,
    *,
    min_fraction: float = 0.5,
    cluster_distance: float = 0.005,
    vector_weight: float = 0.1,
) -> PoleSelection:
    """Choose the physical poles of a stabilization diagram automatically.

    Parameters
    ----------
    diagram : StabilizationDiagram
    min_fraction : float
        A cluster is a mode if its members come from at least :data:`MIN_STABLE_ORDERS`
        distinct orders and from at least ``min_fraction`` of the orders from the lowest
        order it appears in up to the highest of the diagram (a mode needs a high enough
        order to show; once shown it must persist, so the choice does not depend on
        how far the diagram goes above that order).
    cluster_distance : float
        Average-linkage cut of the distance
        ``|lambda_i - lambda_j| / max(|lambda_i|, |lambda_j|) + vector_weight (1 - MAC)``;
        roughly the relative frequency separation below which two poles are one mode.
        Keep it below half the relative spacing of the closest modes expected (0.005
        separates modes 1 % apart).
    vector_weight : float
        Weight of the participation-vector term (ignored with one input).

    Returns
    -------
    PoleSelection
        Possibly empty (with a warning) if no pole is stable.
    """
    if not 0 < min_fraction <= 1:
        raise ValueError(f"The 'min_fraction' parameter must lie in (0, 1]; got {min_fraction!r}.")
    if not cluster_distance > 0:
        raise ValueError(
            f"The 'cluster_distance' parameter must be positive; got {cluster_distance!r}."
        )
    if not vector_weight >= 0:
        raise ValueError(
            f"The 'vector_weight' parameter must be non-negative; got {vector_weight!r}."
        )
    ni = diagram.participation[0].shape[1] if diagram.participation else 1
    lam_all, L_all, ord_all = [], [], []
    stable = diagram.stable
    for k, n in enumerate(diagram.orders):
        sel = stable[k] & diagram.physical[k]
        lam_all.append(diagram.poles[k][sel])
        L_all.append(diagram.participation[k][sel])
        ord_all.append(np.full(int(sel.sum()), n))
    lam = np.concatenate(lam_all) if lam_all else np.zeros(0, complex)
    L = np.concatenate(L_all) if L_all else np.zeros((0, ni), complex)
    order = np.concatenate(ord_all) if ord_all else np.zeros(0, int)

    def empty():
        warnings.warn(
            f"select_poles: no pole is stable in at least {MIN_STABLE_ORDERS} orders and "
            f"in a fraction {min_fraction:g} of the orders from its first up to "
            f"{int(diagram.orders.max())}; returning no modes. Raise max_order, loosen "
            "the StabilityCriteria or lower min_fraction.",
            stacklevel=3,
        )
        z = np.zeros(0)
        return PoleSelection(
            poles=np.zeros(0, complex),
            participation=np.zeros((0, ni), complex),
            n_members=np.zeros(0, int),
            freq_std_hz=z,
            damping_std=z,
        )

    if lam.size < 2:
        return empty()
    labels = _average_linkage_labels(lam, L, cluster_distance, vector_weight if ni > 1 else 0.0)

    top = int(diagram.orders.max())
    reps, parts, counts, fstd, zstd = [], [], [], [], []
    for c in np.unique(labels):
        members = np.flatnonzero(labels == c)
        centre = np.median(lam[members].real) + 1j * np.median(lam[members].imag)
        keep = []
        for n in np.unique(order[members]):
            mo = members[order[members] == n]
            keep.append(mo[np.argmin(np.abs(lam[mo] - centre))])
        keep = np.asarray(keep)
        # consensus: stable in most orders from the one where it first appears (a mode
        # needs a high enough order to show at all; once shown it must persist)
        span = top - int(order[keep].min()) + 1
        if keep.size < max(MIN_STABLE_ORDERS, int(np.ceil(min_fraction * span))):
            continue
        # representative from the upper half of the orders: the z-domain model approximates
        # the continuous-time FRF better as the order (over-modelling) grows
        upper = keep[order[keep] >= np.median(order[keep])]
        centre = np.median(lam[upper].real) + 1j * np.median(lam[upper].imag)
        best = upper[np.argmin(np.abs(lam[upper] - centre))]
        fk, zk = modal_from_poles(lam[keep])
        reps.append(centre)
        parts.append(L[best])
        counts.append(keep.size)
        fstd.append(np.std(fk))
        zstd.append(np.std(zk))
    if not reps:
        return empty()
    reps = np.asarray(reps)
    counts = np.asarray(counts)
    # merge representatives closer than the cut (one physical mode split in two clusters)
    idx = np.argsort(-counts, kind="stable")
    chosen: list[int] = []
    for i in idx:
        close = [
            j
            for j in chosen
            if abs(reps[i] - reps[j]) / max(abs(reps[i]), abs(reps[j])) < cluster_distance
        ]
        if not close:
            chosen.append(int(i))
    chosen_arr = np.asarray(sorted(chosen, key=lambda i: reps[i].imag))
    return PoleSelection(
        poles=reps[chosen_arr],
        participation=np.asarray(parts)[chosen_arr],
        n_members=counts[chosen_arr],
        freq_std_hz=np.asarray(fstd)[chosen_arr],
        damping_std=np.asarray(zstd)[chosen_arr],
    )


def mode_significance(freq_hz, frf, fit: LSFDResult, *, lower_residual: bool = True,
                      upper_residual: bool = True,
                      output_weighting: str = "rms") -> np.ndarray:
    """How much of the data in its own band each fitted mode explains.

    With each output divided by its RMS over the band (``output_weighting="rms"``, as
    :func:`plscf_stabilization`) and ``e(f)`` the residual of the whole fit (every mode
    and the residual terms):

    * mode ``r``'s band is the lines where its contribution ``||h_r(f)||`` (its two pole
      terms; Frobenius norm over the channels) is at least a tenth of its peak, about
      ten half-power bandwidths;
    * ``U_r`` is the residual energy ``sum ||e(f)||^2`` over that band, and ``W_r`` the
      same after an LSFD refit with every pole but ``r``;
    * ``significance_r = (W_r - U_r) / U_r``: the energy the mode explains in its band
      over the energy the fit leaves unexplained there, ``U_r`` floored at ``eps`` times
      the data's energy in the band (exact data: rounding is not unexplained energy).

    A mode is kept when it explains at least as much as remains
    (:data:`SIGNIFICANCE_MIN` = 1), the rule of the coherence band (0.5: as much
    coherent as incoherent power) applied to the fit. On the shipped LADISK record, over
    the orders 20 to 80, the poles that stabilize on leakage or noise beside the strong
    modes explain at most 0.67 of what remains (many make their band's fit worse, < 0),
    its resonances 48 or more; the weakest mode of the hub-beam campaign tests explains
    7.

    Parameters
    ----------
    freq_hz : array_like, shape (n_freq,)
    frf : array_like, complex, shape (n_freq, n_out, n_in)
        The data ``fit`` was fitted to (the same lines).
    fit : LSFDResult
    lower_residual, upper_residual : bool
        As ``fit`` was made (the refits use the same residual terms).
    output_weighting : {"rms", "none"}

    Returns
    -------
    ndarray, shape (n_modes,)
    """
    f, H = check_freq_frf(freq_hz, frf)
    if output_weighting == "rms":
        rms = np.sqrt(np.mean(np.abs(H) ** 2, axis=(0, 2)))
        rms[rms == 0] = 1.0
    else:
        rms = np.ones(H.shape[1])
    w = 1.0 / rms[None, :, None]

    def energy(model):
        return np.sum(np.abs((H - model) * w).reshape(f.size, -1) ** 2, axis=1)

    data = np.sum(np.abs(H * w).reshape(f.size, -1) ** 2, axis=1)
    kept = energy(fit.reconstruct(f))
    q = frf_power(fit.frf_type)
    s_ = 2j * np.pi * f[:, None, None]
    D = fit.displacement_residues()
    out = np.zeros(fit.poles.size)
    for r, lam in enumerate(fit.poles):
        h = s_**q * (D[r][None] / (s_ - lam) + np.conj(D[r])[None] / (s_ - np.conj(lam)))
        a = np.linalg.norm((h * w).reshape(f.size, -1), axis=1)
        band = a >= 0.1 * a.max()
        others = np.delete(fit.poles, r)
        if others.size:
            refit = lsfd(f, H, others, frf_type=fit.frf_type, lower_residual=lower_residual,
                         upper_residual=upper_residual).reconstruct(f)
        else:
            refit = np.zeros_like(H)
        u = max(float(kept[band].sum()), np.finfo(float).eps * float(data[band].sum()))
        out[r] = (float(energy(refit)[band].sum()) - u) / u
    return out


def identify_plscf(
    freq_hz,
    frf,
    *,
    max_order: int = PLSCFIdentifier.max_order,
    min_order: int = 1,
    frf_type: str = "displacement",
    freq_range_hz: tuple[float, float] | None = None,
    criteria: StabilityCriteria | None = None,
    min_fraction: float = 0.5,
    cluster_distance: float = 0.005,
    vector_weight: float = 0.1,
    lower_residual: bool = True,
    upper_residual: bool = True,
    output_weighting: str = "rms",
    refine: bool = False,
    significance: bool = True,
) -> PLSCFResult:
    """pLSCF poles, automatic selection from the stabilization diagram, LSFD shapes.

    Parameters
    ----------
    freq_hz : array_like, shape (n_freq,)
        Frequency lines, Hz.
    frf : array_like, complex, shape (n_freq, n_out, n_in)
        FRF of type ``frf_type``.
    max_order, min_order : int
        Orders of the stabilization diagram (order ``n``: ``n * n_in`` poles). A rule of
        thumb: ``max_order * n_in`` about 2-4 times twice the number of modes in the band.
    frf_type : {"displacement", "velocity", "acceleration"}
        Used by LSFD (residual terms and residue definition).
    freq_range_hz : (float, float), optional
        Band used by both pLSCF and LSFD.
    criteria : StabilityCriteria, optional
    min_fraction, cluster_distance, vector_weight : float
        See :func:`select_poles`.
    lower_residual, upper_residual : bool
        See :func:`truthbench.identify.lsfd.lsfd`.
    output_weighting : {"rms", "none"}
        See :func:`plscf_stabilization` (also used by the refinement).
    refine : bool
        Refine the selected poles by the output-error fit
        :func:`truthbench.identify.lsfd.refine_poles` before the final residues
        (``selection`` keeps the pLSCF poles; ``modal`` and ``lsfd`` use the refined ones).
    significance : bool
        Keep only the selected modes that explain at least as much of the data in their
        own band as the fit leaves unexplained there (:func:`mode_significance` >=
        :data:`SIGNIFICANCE_MIN`); the LSFD fit is then repeated with them.

    Returns
    -------
    PLSCFResult
        ``modal`` is empty (zero modes) with a warning if nothing stabilized.
    """
    diagram = plscf_stabilization(
        freq_hz,
        frf,
        max_order,
        min_order=min_order,
        freq_range_hz=freq_range_hz,
        criteria=criteria,
        output_weighting=output_weighting,
    )
    selection = select_poles(
        diagram,
        min_fraction=min_fraction,
        cluster_distance=cluster_distance,
        vector_weight=vector_weight,
    )
    f, H = check_freq_frf(freq_hz, frf)
    if significance and selection.poles.size:
        fb, Hb = select_band(f, H, freq_range_hz)
        full = lsfd(fb, Hb, selection.poles, frf_type=frf_type,
                    lower_residual=lower_residual, upper_residual=upper_residual)
        sig = mode_significance(fb, Hb, full, lower_residual=lower_residual,
                                upper_residual=upper_residual,
                                output_weighting=output_weighting)
        selection = selection.keep(sig >= SIGNIFICANCE_MIN, significance=sig)
    if selection.poles.size == 0:
        fit = LSFDResult(
            poles=np.zeros(0, complex),
            residues=np.zeros((0,) + H.shape[1:], complex),
            lower_residual=None,
            upper_residual=None,
            frf_type=frf_type,
        )
        modal = ModalParameters(
            freq_hz=np.zeros(0),
            damping_ratio=np.zeros(0),
            shapes=np.zeros((H.shape[1], 0), complex),
            participation=np.zeros((0, H.shape[2]), complex),
        )
        return PLSCFResult(modal=modal, diagram=diagram, selection=selection, lsfd=fit)
    fit = (refine_poles if refine else lsfd)(
        f,
        H,
        selection.poles,
        frf_type=frf_type,
        lower_residual=lower_residual,
        upper_residual=upper_residual,
        freq_range_hz=freq_range_hz,
        **({"output_weighting": output_weighting} if refine else {}),
    )
    return PLSCFResult(modal=fit.modal_parameters(), diagram=diagram, selection=selection, lsfd=fit)
