"""Coverage of k-sigma bounds: what fraction of true parameters a bound contains.

Which expectation applies
-------------------------
Let ``x_1 .. x_T`` be independent normal draws (one parameter over ``T`` tests), ``xbar``
their mean and ``s`` their ``ddof=1`` standard deviation, and the bound
``xbar +- k s`` (Eq. 10.49-10.50 with unit weights).

* **Known variance** (``s`` replaced by the true ``sigma`` and ``xbar`` by the true
  mean): ``P = 2 Phi(k) - 1``, 0.9973 for ``k = 3`` (the chapter quotes 99.5 %).
  This is the limit ``T -> infinity`` of the next two.
* **A new draw** ``x`` (a new test, or the true parameter of a new piece of hardware
  from the same population): ``(x - xbar) / (s sqrt(1 + 1/T))`` is Student-t with
  ``T - 1`` degrees of freedom, so ``P = P(|t_{T-1}| < k / sqrt(1 + 1/T))``: 0.8783 for
  ``T = 3``, 0.9480 for ``T = 5``, 0.9745 for ``T = 8``, 0.9914 for ``T = 20`` at
  ``k = 3``, always below 0.9973. This is the
  coverage a bound built from ``T`` tests delivers for what it is used for: predicting
  the next test.
* **The tests themselves** (in-sample, as in Figure 10.6, "every data set lies
  inside the bound"): the internally studentised residual ``r = (x_j - xbar) / s``
  satisfies ``T r^2 / (T - 1)^2 ~ Beta(1/2, (T - 2)/2)`` and ``|r| <= (T - 1)/sqrt(T)``
  always. For ``T <= 10`` that maximum is below 3, so **every test lies inside the
  3-sigma bound by construction**; Figure 10.6's observation carries no information
  about the bound's calibration. ``P`` is 0.9995 for ``T = 20`` and 0.9983 for
  ``T = 50``: above 0.9973, approaching it from above.

In a truthbench campaign, "the true per-test parameters inside the bound" is the
new-draw case when the truths are of tests that did not build the bound, and close to
the in-sample case when they are the truths of the same tests (then identification
error also enters).

Confidence intervals for an observed fraction use Wilson's score interval (default) or
the exact Clopper-Pearson interval through ``scipy.stats.beta``; both assume the
counted events are independent (one new draw per trial and parameter, not many draws
against one bound).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import stats

from truthbench._validation import readonly
from truthbench.presentation import Presentable

CI_METHODS = ("wilson", "clopper-pearson", "trial-clustered")


def wilson_interval(n_inside, n_total, confidence: float = 0.95) -> tuple[float, float]:
    """Wilson score interval for a binomial proportion.

    Parameters
    ----------
    n_inside : int
        Successes, ``0 <= n_inside <= n_total``.
    n_total : int
        Trials, >= 1.
    confidence : float
        Two-sided confidence level in (0, 1).

    Returns
    -------
    (low, high) : tuple of float
    """
    k, n = _check_counts(n_inside, n_total, confidence)
    return _wilson(k / n, n, confidence)


def _wilson(ph: float, n: float, confidence: float) -> tuple[float, float]:
    """Wilson interval of a proportion ``ph`` from ``n`` (possibly effective) events."""
    z = stats.norm.ppf(0.5 + confidence / 2.0)
    den = 1.0 + z**2 / n
    centre = (ph + z**2 / (2 * n)) / den
    half = z * np.sqrt(ph * (1 - ph) / n + z**2 / (4 * n**2)) / den
    return float(max(0.0, centre - half)), float(min(1.0, centre + half))


def clopper_pearson_interval(n_inside, n_total,
                             confidence: float = 0.95) -> tuple[float, float]:
    """Exact (Clopper-Pearson) interval from beta quantiles; see :func:`wilson_interval`."""
    k, n = _check_counts(n_inside, n_total, confidence)
    a = 1.0 - confidence
    low = 0.0 if k == 0 else stats.beta.ppf(a / 2, k, n - k + 1)
    high = 1.0 if k == n else stats.beta.ppf(1 - a / 2, k + 1, n - k)
    return float(low), float(high)


def _check_counts(n_inside, n_total, confidence):
    k, n = int(n_inside), int(n_total)
    if n < 1:
        raise ValueError(f"The 'n_total' parameter must be at least 1; got {n_total!r}.")
    if not 0 <= k <= n:
        raise ValueError(f"The 'n_inside' parameter must lie in 0..n_total ({n}); "
                         f"got {n_inside!r}.")
    if not 0.0 < float(confidence) < 1.0:
        raise ValueError(f"The 'confidence' parameter must lie in (0, 1); got {confidence!r}.")
    return k, n


def expected_coverage(k=3.0, n_tests: int | None = None, *, in_sample: bool = False):
    """Normal-theory probability that a value lies inside ``mean +- k sigma``.

    Parameters
    ----------
    k : float or array_like
        Bound multiplier(s), > 0.
    n_tests : int, optional
        ``T``, the number of tests the mean and standard deviation were estimated from
        (unit weights, ``ddof=1``). ``None``: both known, ``2 Phi(k) - 1``.
    in_sample : bool
        ``False``: a new independent draw, ``P(|t_{T-1}| < k / sqrt(1 + 1/T))``.
        ``True``: one of the ``T`` tests that built the bound (module docstring).

    Returns
    -------
    float or ndarray
        Probability, same shape as ``k``.
    """
    kk = np.asarray(k, dtype=float)
    if np.any(~np.isfinite(kk)) or np.any(kk <= 0):
        raise ValueError(f"The 'k' parameter must be positive and finite; got {k!r}.")
    if n_tests is None:
        if in_sample:
            raise ValueError("The in-sample coverage needs 'n_tests'; got None.")
        out = 2.0 * stats.norm.cdf(kk) - 1.0
    else:
        T = int(n_tests)
        if T != n_tests or T < 2 or (in_sample and T < 3):
            need = 3 if in_sample else 2
            raise ValueError(f"The 'n_tests' parameter must be an integer >= {need}; "
                             f"got {n_tests!r}.")
        if in_sample:
            x = np.clip(T * kk**2 / (T - 1) ** 2, 0.0, 1.0)
            out = stats.beta.cdf(x, 0.5, (T - 2) / 2.0)
        else:
            out = 2.0 * stats.t.cdf(kk / np.sqrt(1.0 + 1.0 / T), T - 1) - 1.0
    return float(out) if np.ndim(out) == 0 else out


@dataclass(frozen=True)
class Coverage:
    """An observed coverage with its confidence interval.

    Attributes
    ----------
    n_inside, n_total : int
    fraction : float
    ci_low, ci_high : float
        Two-sided interval at ``confidence``.
    confidence : float
    method : str
        ``"wilson"`` or ``"clopper-pearson"``.
    """

    n_inside: int
    n_total: int
    fraction: float
    ci_low: float
    ci_high: float
    confidence: float = 0.95
    method: str = "wilson"

    def agrees_with(self, p: float) -> bool:
        """Whether ``p`` lies inside the confidence interval."""
        return bool(self.ci_low <= p <= self.ci_high)


def coverage_fraction(inside, *, confidence: float = 0.95, method: str = "wilson",
                      valid=None) -> Coverage:
    """Fraction of ``True`` entries of ``inside`` and its confidence interval.

    Parameters
    ----------
    inside : array_like of bool, any shape
        One entry per event. For ``"wilson"`` and ``"clopper-pearson"`` the events must
        be independent; for ``"trial-clustered"`` axis 0 indexes independent clusters
        (Monte Carlo trials) and the events inside one cluster may be dependent (the
        parameters of one trial move together).
    confidence : float
    method : {"wilson", "clopper-pearson", "trial-clustered"}
        ``"trial-clustered"``: the ratio estimator ``sum k_i / sum n_i`` over clusters,
        its cluster-sample variance ``sum (k_i - p n_i)^2 / (N (N - 1) nbar^2)``, and a
        Wilson interval at the effective sample size ``p (1 - p) / var`` (at most the
        number of events; the number of clusters when ``p`` is 0 or 1). With one
        event per cluster it is the Wilson interval of ``N - 1`` events; with ``m``
        identical events per cluster, that of ``N - 1`` events too (not ``N m``).
    valid : array_like of bool, same shape as ``inside``, optional
        Events to count (default all), e.g. the finite truths.

    Returns
    -------
    Coverage
    """
    if method not in CI_METHODS:
        raise ValueError(f"The 'method' parameter must be one of {CI_METHODS}; "
                         f"got {method!r} instead.")
    b = np.asarray(inside)
    if b.dtype != bool:
        raise ValueError(f"The 'inside' parameter must be a boolean array; got dtype {b.dtype}.")
    v = np.ones(b.shape, bool) if valid is None else np.asarray(valid, dtype=bool)
    if v.shape != b.shape:
        raise ValueError(f"The 'valid' parameter must have the shape of 'inside' {b.shape}; "
                         f"got {v.shape}.")
    n, k = int(v.sum()), int((b & v).sum())
    if method == "trial-clustered":
        _check_counts(k, n, confidence)
        if b.ndim < 1 or b.shape[0] < 2:
            raise ValueError(f"The 'trial-clustered' method needs at least 2 clusters on "
                             f"axis 0; got shape {b.shape}.")
        ki = (b & v).reshape(b.shape[0], -1).sum(axis=1).astype(float)
        ni = v.reshape(b.shape[0], -1).sum(axis=1).astype(float)
        N, p = b.shape[0], k / n
        var = np.sum((ki - p * ni) ** 2) / (N * (N - 1) * (n / N) ** 2)
        n_eff = min(float(n), p * (1 - p) / var) if var > 0 else float(N)
        lo, hi = _wilson(p, n_eff, confidence)
    else:
        f = wilson_interval if method == "wilson" else clopper_pearson_interval
        lo, hi = f(k, n, confidence)
    return Coverage(k, n, k / n, lo, hi, float(confidence), method)


def _sample_bound(theta_tests):
    X = np.asarray(theta_tests, dtype=float)
    if X.ndim != 3:
        raise ValueError(f"The 'theta_tests' parameter must have shape (n_trials, T, p); "
                         f"got shape {X.shape}.")
    if X.shape[1] < 2:
        raise ValueError(f"The 'theta_tests' parameter needs at least 2 tests per trial "
                         f"(axis 1); got {X.shape[1]}.")
    if not np.all(np.isfinite(X)):
        raise ValueError("The 'theta_tests' parameter must be finite; got NaN or infinite "
                         "values.")
    # Eq. 10.47-10.48 with W_j = I: sample mean and ddof=1 standard deviation per trial
    return X.mean(axis=1), X.std(axis=1, ddof=1)


def _check_truth(theta_true, n_trials, p):
    Y = np.asarray(theta_true, dtype=float)
    if Y.ndim == 2:
        Y = Y[:, None, :]
    if Y.ndim != 3 or Y.shape[0] != n_trials or Y.shape[2] != p:
        raise ValueError(f"The 'theta_true' parameter must have shape ({n_trials}, {p}) or "
                         f"({n_trials}, n_new, {p}); got shape {np.shape(theta_true)}.")
    if not np.all(np.isfinite(Y)):
        raise ValueError("The 'theta_true' parameter must be finite; got NaN or infinite "
                         "values.")
    return Y


def bound_coverage(theta_tests, theta_true=None, *, k: float = 3.0, confidence: float = 0.95,
                   method: str = "wilson") -> Coverage:
    """Coverage of the ``k``-sigma bound (unit weights) over Monte Carlo trials.

    Parameters
    ----------
    theta_tests : array_like, shape (n_trials, T, p)
        The parameters of the ``T`` tests of each trial that build the bound.
    theta_true : array_like, shape (n_trials, p) or (n_trials, n_new, p), optional
        The values to test against each trial's bound (true per-test or new-draw
        parameters). ``None``: the tests themselves (in-sample).
    k : float
        Bound multiplier.
    confidence, method
        See :func:`coverage_fraction`.

    Returns
    -------
    Coverage
        Over every trial, value and parameter.
    """
    X = np.asarray(theta_tests, dtype=float)
    m, s = _sample_bound(X)
    Y = X if theta_true is None else _check_truth(theta_true, X.shape[0], X.shape[2])
    inside = np.abs(Y - m[:, None, :]) <= float(k) * s[:, None, :]
    return coverage_fraction(inside, confidence=confidence, method=method)


@dataclass(frozen=True)
class CalibrationCurve(Presentable):
    """Observed coverage of ``k``-sigma bounds against normal theory.

    Table ``"calibration"`` (:meth:`to_pandas`): one row per ``k``. Figure
    ``"calibration"`` (:meth:`plot`): the observed coverage with its interval and the
    expectations (:func:`~truthbench.uncertainty.plots.plot_calibration`).

    Attributes
    ----------
    k : ndarray, shape (n_k,)
    coverage, ci_low, ci_high : ndarray, shape (n_k,)
        Observed fraction and its confidence interval at each ``k``.
    expected_normal : ndarray, shape (n_k,)
        ``2 Phi(k) - 1`` (known mean and variance).
    expected_t : ndarray, shape (n_k,)
        The estimated-variance expectation for ``n_tests`` (new-draw or in-sample, see
        ``in_sample``).
    n_tests : int
    n_total : int
        Counted events per ``k``.
    in_sample : bool
    confidence : float
    """

    TABLES = ("calibration",)
    PLOTS = ("calibration",)

    k: np.ndarray
    coverage: np.ndarray
    ci_low: np.ndarray
    ci_high: np.ndarray
    expected_normal: np.ndarray
    expected_t: np.ndarray
    n_tests: int
    n_total: int
    in_sample: bool = False
    confidence: float = 0.95

    def _table_calibration(self):
        """One row per ``k``: ``coverage``, ``ci_low``, ``ci_high``,
        ``expected_normal``, ``expected_t``."""
        import pandas as pd

        return pd.DataFrame({
            "coverage": self.coverage, "ci_low": self.ci_low, "ci_high": self.ci_high,
            "expected_normal": self.expected_normal, "expected_t": self.expected_t,
        }, index=pd.Index(self.k, name="k"))

    def _plot_calibration(self, ax):
        """Drawn by :func:`truthbench.uncertainty.plots.plot_calibration`."""
        from truthbench.uncertainty.plots import plot_calibration

        return plot_calibration(self, ax=ax)


def calibration_curve(theta_tests, theta_true=None, k=None, *, confidence: float = 0.95,
                      method: str = "wilson") -> CalibrationCurve:
    """Coverage of ``k``-sigma bounds for a range of ``k``.

    Parameters
    ----------
    theta_tests : array_like, shape (n_trials, T, p)
    theta_true : array_like, shape (n_trials, p) or (n_trials, n_new, p), optional
        ``None``: in-sample (the tests themselves), compared with the in-sample
        expectation.
    k : array_like, shape (n_k,), optional
        Default 15 values from 0.5 to 4.
    confidence, method
        See :func:`coverage_fraction`.

    Returns
    -------
    CalibrationCurve
    """
    ks = np.linspace(0.5, 4.0, 15) if k is None else np.atleast_1d(np.asarray(k, dtype=float))
    X = np.asarray(theta_tests, dtype=float)
    m, s = _sample_bound(X)
    T = X.shape[1]
    in_sample = theta_true is None
    if in_sample and T < 3:
        raise ValueError("The in-sample calibration needs at least 3 tests per trial; "
                         f"got {T}.")
    Y = X if in_sample else _check_truth(theta_true, X.shape[0], X.shape[2])
    dev = np.abs(Y - m[:, None, :])
    sd = s[:, None, :]
    with np.errstate(divide="ignore", invalid="ignore"):
        z = np.where(sd > 0, dev / sd, np.where(dev == 0, 0.0, np.inf))
    rows = [coverage_fraction(z <= kk, confidence=confidence, method=method) for kk in ks]
    return CalibrationCurve(
        k=readonly(ks, float),
        coverage=readonly([r.fraction for r in rows], float),
        ci_low=readonly([r.ci_low for r in rows], float),
        ci_high=readonly([r.ci_high for r in rows], float),
        expected_normal=readonly(expected_coverage(ks), float),
        expected_t=readonly(expected_coverage(ks, T, in_sample=in_sample), float),
        n_tests=int(T),
        n_total=rows[0].n_total,
        in_sample=in_sample,
        confidence=float(confidence),
    )
