"""How a Monte Carlo campaign's statistics settle as trials accumulate.

A campaign's coverage and error statistics are estimates whose intervals shrink as one
over the square root of the trial count. :func:`convergence` recomputes them over the
first ``n`` trials for a geometric series of ``n`` up to all of them, from the result's
per-trial tables alone (:class:`~truthbench.campaign.tables.Tables`), each with its
confidence interval:

* **coverage** of the uncertainty bound (Eq. 10.46-10.50): the fraction of true per-test
  modal parameters inside their trial's bound, of the held-out tests (else of the tests
  that built it), with the trial-clustered interval of
  :func:`truthbench.uncertainty.coverage_fraction` (the summary's own);
* **identification error**: per mode, the mean over trials of the building tests' mean
  relative error of the identified frequency against the truth (%), with a Student-t
  interval (one value per trial: the trials are independent);
* **parameter error** after the primary updater: per parameter, the mean over trials of
  the relative error against the truth (%) and its Student-t interval; and the RMS.

A curve that has flattened inside its narrowing band is what "enough trials" looks like.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def checkpoints(n: int, count: int = 40, start: int = 2) -> np.ndarray:
    """About ``count`` trial counts from ``start`` to ``n``, geometrically spaced (each
    at least one more than the last), ``n`` included.

    Returns
    -------
    ndarray of int, shape (<= count,)
    """
    if n < start:
        return np.zeros(0, int)
    grid = np.unique(np.round(np.geomspace(start, n, count)).astype(int))
    return grid[(grid >= start) & (grid <= n)]


def running_mean(values, counts, confidence: float = 0.95):
    """Mean over the first ``n`` rows of ``values`` for every ``n`` of ``counts``, with
    a Student-t interval; NaN entries are left out (and counted out).

    Parameters
    ----------
    values : array_like, shape (n_trials, k)
        One value per trial (independent) and quantity.
    counts : array_like of int
        Trial counts, each in ``1..n_trials``.
    confidence : float

    Returns
    -------
    mean, low, high : ndarray, shape (len(counts), k)
        NaN where fewer than two values are counted (no interval).
    """
    from scipy.stats import t as student

    x = np.asarray(values, dtype=float)
    x = x.reshape(len(x), -1)
    ok = np.isfinite(x)
    c = np.cumsum(ok, axis=0)
    s1 = np.cumsum(np.where(ok, x, 0.0), axis=0)
    s2 = np.cumsum(np.where(ok, x, 0.0) ** 2, axis=0)
    idx = np.asarray(counts, int) - 1
    n, s1, s2 = c[idx].astype(float), s1[idx], s2[idx]
    with np.errstate(divide="ignore", invalid="ignore"):
        mean = s1 / n
        var = np.maximum(s2 - n * mean**2, 0.0) / (n - 1)
        half = student.ppf(0.5 + confidence / 2, np.maximum(n - 1, 1)) * np.sqrt(var / n)
    half = np.where(n >= 2, half, np.nan)
    mean = np.where(n >= 1, mean, np.nan)
    return mean, mean - half, mean + half


@dataclass(frozen=True)
class Convergence:
    """Statistics over the first ``n`` trials (:func:`convergence`).

    Attributes
    ----------
    trials : ndarray of int, shape (c,)
        The trial counts ``n`` of the coverage and identification statistics (trials
        with an uncertainty stage).
    coverage : ndarray, shape (c, 3) or None
        Fraction of truths inside the bound, interval low, high; None without an
        uncertainty stage.
    coverage_of : str
        ``"held-out"`` or ``"in-sample"`` truths.
    expected : float or None
        The normal-theory coverage of that kind
        (:func:`truthbench.uncertainty.expected_coverage`).
    modes : tuple of str
        The frequencies of the identification error (``f<k>_hz``).
    identification : ndarray, shape (c, 3, len(modes)) or None
        Mean relative error of the identified frequencies (%), interval low, high.
    parameter_trials : ndarray of int, shape (d,)
        The trial counts of the parameter statistics (updated trials).
    parameters : tuple of str
    parameter_error : ndarray, shape (d, 3, len(parameters)) or None
        Mean relative parameter error after the primary updater (%), interval low, high.
    parameter_rms : ndarray, shape (d, len(parameters)) or None
        RMS of those errors (%).
    confidence : float
    """

    trials: np.ndarray
    coverage: np.ndarray | None
    coverage_of: str
    expected: float | None
    modes: tuple[str, ...]
    identification: np.ndarray | None
    parameter_trials: np.ndarray
    parameters: tuple[str, ...]
    parameter_error: np.ndarray | None
    parameter_rms: np.ndarray | None
    confidence: float = 0.95


def convergence(result, *, count: int = 40, confidence: float = 0.95) -> Convergence:
    """The convergence of ``result``'s coverage and error statistics with the trial
    count (see the module docstring), over ``count`` trial counts at most.

    Parameters
    ----------
    result : CampaignResult
    count : int
    confidence : float

    Returns
    -------
    Convergence
    """
    from truthbench.campaign.coverage import stage_arrays, truths_inside
    from truthbench.uncertainty import coverage_fraction, expected_coverage

    tables = result.tables
    k_sigma = result.spec.uncertainty.k_sigma
    counts = np.zeros(0, int)
    cover, kind, expected, modes, ident = None, "in-sample", None, (), None
    arrays = stage_arrays([u for _, u in tables.stages])
    if arrays is not None and arrays[2].shape[0] >= 2:
        names, hold, tests, truth, _, _ = arrays
        inside, finite = truths_inside(arrays, k_sigma)
        build = ~hold
        rows = hold if hold.any() else build
        kind = "held-out" if hold.any() else "in-sample"
        n_build = int(build.sum())
        expected = (expected_coverage(k_sigma, n_build) if hold.any() else
                    expected_coverage(k_sigma, n_build, in_sample=True) if n_build >= 3
                    else None)
        counts = checkpoints(tests.shape[0], count)
        cover = np.array([[c.fraction, c.ci_low, c.ci_high] for c in (
            coverage_fraction(inside[:n, rows], valid=finite[:n, rows],
                              confidence=confidence, method="trial-clustered")
            for n in counts)]).reshape(-1, 3)
        f = [i for i, name in enumerate(names) if name.endswith("_hz")]
        modes = tuple(names[i] for i in f)
        with np.errstate(invalid="ignore", divide="ignore"):
            err = 100 * (tests[:, build][:, :, f] / truth[:, build][:, :, f] - 1)
            ok = np.isfinite(err)  # a mode not paired in a test: left out
            per_trial = np.where(ok, err, 0.0).sum(axis=1) / ok.sum(axis=1)
        ident = np.stack(running_mean(per_trial, counts, confidence), axis=1)
    params, perr, prms, p_counts = (), None, None, np.zeros(0, int)
    df = tables.frame("parameters")
    df = df[df["method"] == tables.primary] if len(df) else df
    if len(df):
        wide = df.pivot(index="trial", columns="parameter", values="error_after_pct")
        params = tuple(p for p in dict.fromkeys(df["parameter"]))
        x = wide[list(params)].to_numpy()
        p_counts = checkpoints(len(x), count)
        perr = np.stack(running_mean(x, p_counts, confidence), axis=1)
        prms = np.sqrt(running_mean(x**2, p_counts, confidence)[0])
    return Convergence(counts, cover, kind, expected, modes, ident, p_counts, params, perr,
                       prms, confidence)
