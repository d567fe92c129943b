"""The uncertainty model over repeated tests (Section 10.3, Eq. 10.46-10.50;
:ref:`method-uncertainty-model`).

From ``T`` tests, each giving a parameter vector ``theta_j`` (modal frequencies in Hz,
damping ratios, shape entries, delays in s, ...), and the initial model's ``theta_0``::

    delta_j    = theta_j - theta_0                                              (10.46)
    E[delta]   = W^-1 sum_j W_j delta_j                                         (10.47)
    Cov[delta] = (W - I)^-1 sum_j W_j^2 (delta_j - E[delta]) (delta_j - E[delta])^T (10.48)
    W_j = diag(w_j1 .. w_jp),  W = sum_j W_j
    mu = E[delta],  c = 3 sqrt(diag Cov[delta])                                 (10.49-10.50)

The mean model is ``theta_0 + mu``; the bound is ``mean model +- c``.

What ``(W - I)^-1`` means for non-identity weights
---------------------------------------------------
``W_j`` is diagonal (one confidence factor per test and parameter), so ``W`` and
``W - I`` are diagonal and everything is per parameter: ``W_i = sum_j w_ji`` and the
printed estimator is, element by element,

    Cov_ik = sum_j w_ji w_jk r_ji r_jk / (W_i - 1),    r_j = delta_j - E[delta].

Checked properties (tests in ``tests/uncertainty/test_model.py``):

* ``w_ji = 1``: the numpy mean and ``numpy.cov(ddof=1)`` exactly (the ``T - 1`` of the
  sample covariance is ``W - 1``).
* ``w_ji`` in {0, 1} (dropping tests parameter by parameter): ``w^2 = w``, so each
  variance is the ``ddof=1`` sample variance of the kept tests; unbiased.
* Any other weights: **not unbiased** and **not scale invariant**. For independent
  tests with a common covariance ``Sigma`` the expectation is
  ``E[Cov_ik] = Sigma_ik D_ik / (W_i - 1)`` with

      D_ik = sum_j w_ji w_jk (1 - w_ji / W_i - w_jk / W_k + sum_l w_li w_lk / (W_i W_k)),

  e.g. all weights equal to 2 give ``2 (T - 1) / (T - 1/2)`` times ``Sigma``, about
  twice too large. The ratio ``D_ii / (W_i - 1)`` is reported as
  :attr:`UncertaintyModel.bias_factor`. The weights are therefore on the scale "1 = a
  full-confidence test"; do not normalise them to sum to 1 (that makes ``W - I``
  singular or negative, which is rejected).
* When the parameters' weight totals ``W_i`` differ, the printed matrix is **not
  symmetric** (row ``i`` is divided by ``W_i - 1``). Its diagonal, which the bound uses,
  is unaffected. :attr:`UncertaintyModel.cov_symmetric` gives
  ``(W - I)^-1/2 S (W - I)^-1/2``, the symmetric matrix with the same diagonal.

``estimator="unbiased"`` keeps the chapter's numerator (weights squared) but divides by
``D_ik`` instead of ``W_i - 1``: symmetric, equal to the chapter's form for unit (and
0/1) weights, invariant to the weights' scale (normalised weights are fine), and
unbiased for independent, equally distributed tests whatever the weights. (If the
weights are meant as inverse variances, i.e. the tests are not equally distributed,
neither form estimates a single "test-to-test" covariance.)
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from truthbench._validation import readonly
from truthbench.errors import IdentifiabilityError
from truthbench.presentation import Presentable, figure_axes

ESTIMATORS = ("chapter", "unbiased")
COVARIANCES = ("full", "diagonal")


def _as_2d(name: str, a) -> np.ndarray:
    x = np.array(a, dtype=float, copy=True)
    if x.ndim == 1:
        x = x[:, None]
    if x.ndim != 2:
        raise ValueError(f"The '{name}' parameter must be a 2-D array (n_tests, n_parameters); "
                         f"got shape {x.shape}.")
    return x


@dataclass(frozen=True)
class UncertaintyModel(Presentable):
    """The mean error and the bound of a set of parameters over ``T`` tests.

    Tables (:meth:`to_pandas`): ``"parameters"`` one row per parameter (mean error,
    standard deviation, bound), ``"errors"`` one row per (test, parameter). Figure
    ``"errors"`` (:meth:`plot`): every test's error in standard deviations from the mean
    error, with the bound at ``+-k_sigma``.

    Attributes
    ----------
    names : tuple of str, length p
        Parameter names (with units where a number could be misread, e.g. ``f1_hz``).
    theta_0 : ndarray, shape (p,)
        The initial (FEM) model's parameters.
    delta : ndarray, shape (T, p)
        Per-test errors ``theta_j - theta_0`` (Eq. 10.46), in the parameters' units.
    weights : ndarray, shape (T, p)
        Confidence factors ``w_ji >= 0`` (all ones when none were given).
    mean : ndarray, shape (p,)
        ``E[delta]`` (Eq. 10.47).
    cov : ndarray, shape (p, p)
        ``Cov[delta]`` (Eq. 10.48 as printed for ``estimator="chapter"``; off-diagonal
        entries zero for ``covariance="diagonal"``). Units: products of the parameters'.
    k_sigma : float
        Bound multiplier (3 in the chapter).
    estimator : str
        ``"chapter"`` or ``"unbiased"`` (see the module docstring).
    covariance : str
        ``"full"`` or ``"diagonal"``.
    """

    TABLES = ("parameters", "errors")
    PLOTS = ("errors",)

    names: tuple[str, ...]
    theta_0: np.ndarray
    delta: np.ndarray
    weights: np.ndarray
    mean: np.ndarray
    cov: np.ndarray
    k_sigma: float = 3.0
    estimator: str = "chapter"
    covariance: str = "full"

    @property
    def n_tests(self) -> int:
        return int(self.delta.shape[0])

    @property
    def n_parameters(self) -> int:
        return int(self.delta.shape[1])

    @property
    def std(self) -> np.ndarray:
        """``sqrt(diag Cov)``, shape (p,), in the parameters' units."""
        return np.sqrt(np.clip(np.diag(self.cov), 0.0, None))

    @property
    def bound(self) -> np.ndarray:
        """``c = k_sigma sqrt(diag Cov)`` (Eq. 10.50), shape (p,)."""
        return self.k_sigma * self.std

    @property
    def mean_model(self) -> np.ndarray:
        """``theta_0 + E[delta]``, shape (p,): the initial model corrected by the mean
        error."""
        return self.theta_0 + self.mean

    @property
    def lower(self) -> np.ndarray:
        """``mean_model - bound``, shape (p,)."""
        return self.mean_model - self.bound

    @property
    def upper(self) -> np.ndarray:
        """``mean_model + bound``, shape (p,)."""
        return self.mean_model + self.bound

    @property
    def cov_symmetric(self) -> np.ndarray:
        """``(W - I)^-1/2 S (W - I)^-1/2`` for the chapter form (same diagonal as
        :attr:`cov`, symmetric); :attr:`cov` itself when it is already symmetric."""
        if np.allclose(self.cov, self.cov.T, rtol=1e-12, atol=0.0):
            return self.cov  # unit weights, equal weight totals, "unbiased" or diagonal
        wr = self.weights * (self.delta - self.mean)
        d = np.sqrt(self.weights.sum(axis=0) - 1.0)
        return (wr.T @ wr) / np.outer(d, d)

    @property
    def correlation(self) -> np.ndarray:
        """Correlation matrix of :attr:`cov_symmetric`, shape (p, p) (NaN where a
        standard deviation is zero)."""
        c = self.cov_symmetric
        s = np.sqrt(np.clip(np.diag(c), 0.0, None))
        with np.errstate(divide="ignore", invalid="ignore"):
            return c / np.outer(s, s)

    @property
    def bias_factor(self) -> np.ndarray:
        """``E[Var_i estimate] / Var_i`` for independent, equally distributed tests,
        shape (p,): ``D_ii / (W_i - 1)`` for the chapter form (1 for unit or 0/1
        weights), exactly 1 for ``estimator="unbiased"``."""
        if self.estimator == "unbiased":
            return np.ones(self.n_parameters)
        return _unbiased_denominator_diag(self.weights) / (self.weights.sum(axis=0) - 1.0)

    def contains(self, theta) -> np.ndarray:
        """Whether parameter values lie inside ``mean_model +- bound`` (inclusive).

        Parameters
        ----------
        theta : array_like, shape (..., p)
            Parameter values in the parameters' own units (not errors).

        Returns
        -------
        ndarray of bool, shape (..., p)
        """
        x = np.asarray(theta, dtype=float)
        if x.shape[-1:] != (self.n_parameters,):
            raise ValueError(f"The 'theta' parameter must end in the parameter axis of "
                             f"length {self.n_parameters}; got shape {x.shape}.")
        return np.abs(x - self.mean_model) <= self.bound

    def _standardised(self) -> np.ndarray:
        """``(delta - mean) / std`` per test and parameter, shape (T, p) (NaN where the
        standard deviation is 0)."""
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(self.std > 0, (self.delta - self.mean)
                            / np.where(self.std > 0, self.std, 1.0), np.nan)

    def _table_errors(self):
        """One row per (test, parameter): test (0-based), parameter, error
        ``theta_j - theta_0``, weight, and the error in standard deviations from the
        mean error (``standardised``)."""
        import pandas as pd

        T, p = self.delta.shape
        return pd.DataFrame({
            "test": np.repeat(np.arange(T), p),
            "parameter": np.tile(np.array(self.names, dtype=object), T),
            "error": self.delta.ravel(), "weight": self.weights.ravel(),
            "standardised": self._standardised().ravel()})

    def _plot_errors(self, ax):
        """Every test's error in standard deviations from the mean error, per parameter,
        with the bound at ``+-k_sigma``: a unit-free view of all parameters."""
        fig, (ax,) = figure_axes(ax, figsize=(max(5.0, 0.5 * self.n_parameters + 2), 4))
        x = np.arange(self.n_parameters)
        for j, row in enumerate(self._standardised()):
            ax.plot(x, row, "o", mfc="none", ms=5, label=f"test {j}" if j < 10 else None)
        for k in (-self.k_sigma, self.k_sigma):
            ax.axhline(k, color="k", ls="--", lw=0.8)
        ax.axhline(0.0, color="0.6", lw=0.6)
        ax.set_xticks(x, self.names, rotation=45, ha="right")
        ax.set_ylabel("(error - mean error) / std")
        ax.set_title(f"{self.n_tests} tests, bound +-{self.k_sigma:g} std", fontsize="medium")
        fig.tight_layout()
        return fig

    def _table_parameters(self):
        """One row per parameter: index ``parameter``; columns ``theta_0``,
        ``mean_error``, ``std``, ``bound``, ``mean_model``, ``lower``, ``upper``,
        ``weight_total``, ``bias_factor``."""
        import pandas as pd

        df = pd.DataFrame({
            "theta_0": self.theta_0,
            "mean_error": self.mean,
            "std": self.std,
            "bound": self.bound,
            "mean_model": self.mean_model,
            "lower": self.lower,
            "upper": self.upper,
            "weight_total": self.weights.sum(axis=0),
            "bias_factor": self.bias_factor,
        }, index=pd.Index(self.names, name="parameter"))
        return df


def _unbiased_denominator(w: np.ndarray) -> np.ndarray:
    """``D_ik`` of the module docstring, shape (p, p), for weights ``w`` (T, p)."""
    Wt = w.sum(axis=0)
    a = w / Wt  # normalised weights, (T, p)
    ww = w.T @ w  # sum_j w_ji w_jk
    cross = a.T @ a  # sum_l w_li w_lk / (W_i W_k)
    # sum_j w_ji w_jk (1 - a_ji - a_jk) + ww * cross
    t1 = (w * a).T @ w  # sum_j w_ji a_ji w_jk
    return ww - t1 - t1.T + ww * cross


def _unbiased_denominator_diag(w: np.ndarray) -> np.ndarray:
    """The diagonal ``D_ii`` only, shape (p,)."""
    Wt = w.sum(axis=0)
    a = w / Wt
    w2 = (w**2).sum(axis=0)
    return w2 - 2.0 * (w**2 * a).sum(axis=0) + w2 * (a**2).sum(axis=0)


def uncertainty_model(
    theta_tests,
    theta_0,
    *,
    weights=None,
    names: Sequence[str] | None = None,
    k_sigma: float = 3.0,
    covariance: str = "full",
    estimator: str = "chapter",
) -> UncertaintyModel:
    """Build the uncertainty model of Eq. 10.46-10.50 from ``T`` tests.

    Parameters
    ----------
    theta_tests : array_like, shape (T, p)
        Parameters identified in each test (frequencies in Hz, damping ratios, shape
        entries, delays in s, ...); a 1-D array is one parameter.
    theta_0 : array_like, shape (p,)
        The initial model's parameters, same units.
    weights : array_like, shape (T, p) or (T,), optional
        Confidence factors ``w_ji >= 0`` (``W_j = diag(w_j)``); a 1-D array weighs whole
        tests. Default all ones (then the bound is the sample mean +- 3 sample standard
        deviations). With ``estimator="chapter"`` every parameter needs
        ``sum_j w_ji > 1``; the unbiased form is invariant to the weights' scale.
    names : sequence of str, length p, optional
        Default ``theta0``, ``theta1``, ...
    k_sigma : float
        Bound multiplier, > 0 (Eq. 10.50 uses 3).
    covariance : {"full", "diagonal"}
        ``"full"`` needs more tests than parameters (the sample covariance of ``T``
        tests has rank at most ``T - 1``); ``"diagonal"`` keeps only the variances,
        which the bound needs, and works with any ``T >= 2``.
    estimator : {"chapter", "unbiased"}
        Eq. 10.48 as printed, or the same numerator with the exact bias-correcting
        denominator (module docstring). Identical for unit and 0/1 weights.

    Returns
    -------
    UncertaintyModel

    Raises
    ------
    ValueError
        Wrong shapes, NaN or infinite values, negative weights, unknown options.
    IdentifiabilityError
        Fewer than 2 tests; a full covariance with ``T <= p``; with the chapter form, a
        parameter whose weights sum to 1 or less (``W - I`` singular or negative); with
        the unbiased form, a parameter with fewer than 2 tests of non-zero weight.
    """
    if covariance not in COVARIANCES:
        raise ValueError(f"The 'covariance' parameter must be one of {COVARIANCES}; "
                         f"got {covariance!r} instead.")
    if estimator not in ESTIMATORS:
        raise ValueError(f"The 'estimator' parameter must be one of {ESTIMATORS}; "
                         f"got {estimator!r} instead.")
    k = float(k_sigma)
    if not (np.isfinite(k) and k > 0):
        raise ValueError(f"The 'k_sigma' parameter must be a positive number; got {k_sigma!r}.")
    X = _as_2d("theta_tests", theta_tests)
    T, p = X.shape
    t0 = np.array(theta_0, dtype=float, copy=True).reshape(-1)
    if t0.shape != (p,):
        raise ValueError(f"The 'theta_0' parameter must have shape ({p},) (one value per "
                         f"column of 'theta_tests'); got shape {np.shape(theta_0)}.")
    if not np.all(np.isfinite(X)):
        bad = sorted({int(j) for j in np.argwhere(~np.isfinite(X))[:, 0]})
        raise ValueError(f"The 'theta_tests' parameter must be finite; tests {bad} hold "
                         f"NaN or infinite values (drop them, or give them weight 0 and a "
                         f"finite placeholder).")
    if not np.all(np.isfinite(t0)):
        raise ValueError(f"The 'theta_0' parameter must be finite; got {t0.tolist()}.")
    if T < 2:
        raise IdentifiabilityError(f"The 'theta_tests' parameter must hold at least 2 tests "
                                   f"to estimate a covariance; got {T}.")
    if covariance == "full" and T <= p:
        raise IdentifiabilityError(
            f"A full covariance of {p} parameters from {T} tests is singular (rank at most "
            f"T - 1 = {T - 1} < {p}); use more than {p} tests, fewer parameters, or "
            f"covariance='diagonal' (the bound needs only the variances).")
    if names is None:
        names = tuple(f"theta{i}" for i in range(p))
    names = tuple(str(n) for n in names)
    if len(names) != p:
        raise ValueError(f"The 'names' parameter must hold {p} names; got {len(names)}.")
    if weights is None:
        w = np.ones((T, p))
    else:
        w = np.array(weights, dtype=float, copy=True)
        if w.ndim == 1 and w.shape == (T,):
            w = np.repeat(w[:, None], p, axis=1)
        if w.shape != (T, p):
            raise ValueError(f"The 'weights' parameter must have shape ({T}, {p}) or ({T},); "
                             f"got shape {np.shape(weights)}.")
        if not np.all(np.isfinite(w)):
            raise ValueError("The 'weights' parameter must be finite; got NaN or infinite "
                             "values.")
        if np.any(w < 0):
            bad = sorted({names[int(i)] for i in np.argwhere(w < 0)[:, 1]})
            raise ValueError(f"The 'weights' parameter must be >= 0 (confidence factors); "
                             f"got negative weights for {bad}.")
    Wt = w.sum(axis=0)
    if estimator == "unbiased" and np.any(Wt <= 0.0):
        bad = [names[i] for i in np.flatnonzero(Wt <= 0.0)]
        raise IdentifiabilityError(f"The 'weights' of every parameter must have a positive "
                                   f"sum; got all-zero weights for {bad}.")
    if estimator == "chapter" and np.any(Wt <= 1.0):
        bad = [f"{names[i]} (sum {Wt[i]:g})" for i in np.flatnonzero(Wt <= 1.0)]
        raise IdentifiabilityError(
            f"The 'weights' of every parameter must sum to more than 1, or W - I in "
            f"Eq. 10.48 is singular or negative; got {', '.join(bad)}. Weights are "
            f"confidence factors with 1 = a full-confidence test; do not normalise them "
            f"to sum to 1.")
    delta = X - t0
    mean = (w * delta).sum(axis=0) / Wt
    r = delta - mean
    wr = w * r
    if covariance == "diagonal":
        # only the variances: the p x p intermediates are never formed
        Sd = np.einsum("ji,ji->i", wr, wr)  # diagonal of sum_j W_j^2 r_j r_j^T
        Dd = Wt - 1.0 if estimator == "chapter" else _unbiased_denominator_diag(w)
        if np.any(Dd <= 0):
            raise IdentifiabilityError("The 'weights' leave a parameter with fewer than 2 "
                                       "tests of non-zero weight; its variance is undefined.")
        cov = np.diag(Sd / Dd)
    else:
        S = wr.T @ wr  # sum_j W_j r_j r_j^T W_j = sum_j W_j^2 r_j r_j^T for diagonal W_j
        if estimator == "chapter":
            cov = S / (Wt - 1.0)[:, None]  # (W - I)^-1 S: row i divided by W_i - 1
        else:
            D = _unbiased_denominator(w)
            if np.any(np.diag(D) <= 0):
                raise IdentifiabilityError(
                    "The 'weights' leave a parameter with fewer than 2 tests of non-zero "
                    "weight; its variance is undefined.")
            with np.errstate(divide="ignore", invalid="ignore"):
                cov = np.where(D > 0, S / np.where(D > 0, D, 1.0), 0.0)
    return UncertaintyModel(
        names=names,
        theta_0=readonly(t0, float),
        delta=readonly(delta, float),
        weights=readonly(w, float),
        mean=readonly(mean, float),
        cov=readonly(cov, float),
        k_sigma=k,
        estimator=estimator,
        covariance=covariance,
    )
