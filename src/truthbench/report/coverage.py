"""Coverage of the uncertainty bound against the truth, over Monte Carlo trials.

Reads the ``uncertainty`` group of every trial in a results file (never reruns
numerics) and counts the true per-test modal parameters inside each trial's bound:

* **in-sample**: truths of the tests that built the bound; the identified values of
  those tests lie inside it almost by construction (``truthbench.uncertainty.coverage``),
  so this mostly checks that identification error is small against the test scatter;
* **held out**: truths of the tests listed in ``[uncertainty] holdout``, which did not
  build the bound: each is a new draw, and a normal population predicts the
  Student-t coverage ``P(|t_{T-1}| < k / sqrt(1 + 1/T))`` for ``T`` building tests.

Counted events are independent across trials for one parameter; the parameters of one
trial are not (one material draw moves every frequency), so pooled fractions carry
trial-clustered intervals (``coverage_fraction(method="trial-clustered")``) and
per-parameter fractions Wilson intervals.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np


@dataclass(frozen=True)
class CoverageSummary:
    """Coverage of one campaign run's bounds.

    Attributes
    ----------
    names : tuple of str
        Modal parameters (``f<k>_hz``, ``zeta<k>``) of any counted trial; a trial whose
        stage lacks one (a mode not paired in every test) does not count for it.
    k_sigma : float
    n_build : int
        Tests that built each bound.
    n_trials : int
        Trials with an uncertainty stage and the first one's test split.
    in_sample : Coverage
        Trial-clustered interval.
    in_sample_expected : float or None
        Normal-theory in-sample value (None for fewer than 3 building tests).
    holdout : Coverage or None
        Held-out truths inside, trial-clustered interval (None without held-out tests).
    holdout_expected : float
        Student-t new-draw expectation for ``n_build`` tests.
    per_parameter : pandas.DataFrame
        One row per parameter: held-out (or in-sample) coverage and its interval.
    calibration : CalibrationCurve or None
        Held-out coverage against ``k`` (None without held-out tests).
    """

    names: tuple[str, ...]
    k_sigma: float
    n_build: int
    n_trials: int
    in_sample: object
    in_sample_expected: float | None
    holdout: object | None
    holdout_expected: float
    per_parameter: object
    calibration: object | None


def _names(u) -> tuple[str, ...]:
    return tuple(n.decode() if isinstance(n, bytes) else str(n) for n in u["names"])


def _stage_arrays(results: dict):
    """Per-trial arrays aligned by parameter name (NaN where a trial's stage lacks a
    parameter), over the trials with the first one's test split."""
    trials = [t["uncertainty"] for k, t in sorted(results.get("trials", {}).items())
              if k != "attrs" and "uncertainty" in t]
    if not trials:
        return None
    n_tests = trials[0]["theta_tests"].shape[0]
    none = np.zeros(n_tests, bool)
    hold = np.asarray(trials[0].get("holdout", none), dtype=bool)
    trials = [u for u in trials if u["theta_tests"].shape[0] == n_tests
              and np.array_equal(np.asarray(u.get("holdout", none), bool), hold)]
    names = sorted({n for u in trials for n in _names(u)},  # f1_hz, f2_hz, .., zeta1, ..
                   key=lambda n: (not n.startswith("f"), int(re.sub(r"\D", "", n) or 0), n))
    col = {n: i for i, n in enumerate(names)}
    shape = (len(trials), n_tests, len(names))
    tests, truth = np.full(shape, np.nan), np.full(shape, np.nan)
    mean_model, bound = np.full(shape[::2], np.nan), np.full(shape[::2], np.nan)
    for i, u in enumerate(trials):
        c = [col[n] for n in _names(u)]
        tests[i][:, c], truth[i][:, c] = u["theta_tests"], u["theta_truth"]
        mean_model[i, c], bound[i, c] = u["theta_0"] + u["mean"], u["bound"]
    return tuple(names), hold, tests, truth, mean_model, bound


def coverage_summary(results: dict, k_sigma: float | None = None,
                     confidence: float = 0.95) -> CoverageSummary | None:
    """Coverage of the bound over the trials of a results file.

    Parameters
    ----------
    results : dict
        :func:`truthbench.campaign.store.read_results` output.
    k_sigma : float, optional
        Default: the campaign's ``[uncertainty] k_sigma``.
    confidence : float
        Level of the Wilson intervals.

    Returns
    -------
    CoverageSummary or None
        None when no trial has an uncertainty stage.
    """
    import pandas as pd

    from truthbench.uncertainty import calibration_curve, coverage_fraction, expected_coverage

    arrays = _stage_arrays(results)
    if arrays is None:
        return None
    names, hold, tests, truth, mean_model, bound = arrays
    if k_sigma is None:
        k_sigma = float(results["attrs"]["spec"].get("uncertainty", {}).get("k_sigma", 3.0))
    std = bound / k_sigma
    finite = np.isfinite(truth) & np.isfinite(bound)[:, None, :]
    inside = np.abs(truth - mean_model[:, None, :]) <= k_sigma * std[:, None, :]
    build = ~hold
    n_build = int(build.sum())
    clustered = dict(confidence=confidence,  # one trial: no clusters to compare
                     method="trial-clustered" if tests.shape[0] >= 2 else "wilson")
    in_sample = coverage_fraction(inside[:, build], valid=finite[:, build], **clustered)
    in_expected = (expected_coverage(k_sigma, n_build, in_sample=True) if n_build >= 3
                   else None)
    held = calib = None
    rows_from = build
    if hold.any():
        rows_from = hold
        held = coverage_fraction(inside[:, hold], valid=finite[:, hold], **clustered)
        ok = np.all(finite[:, hold], axis=(1, 2)) & np.all(np.isfinite(tests[:, build]),
                                                             axis=(1, 2))
        if ok.sum() >= 2:
            calib = calibration_curve(tests[ok][:, build], truth[ok][:, hold], **clustered)
    rows = []
    for i, name in enumerate(names):
        sel = inside[:, rows_from, i][finite[:, rows_from, i]]
        c = coverage_fraction(sel, confidence=confidence)
        rows.append({"parameter": name, "truths": c.n_total, "inside": c.n_inside,
                     "coverage": c.fraction, "ci low": c.ci_low, "ci high": c.ci_high})
    return CoverageSummary(names, float(k_sigma), n_build, tests.shape[0], in_sample,
                           in_expected, held, expected_coverage(k_sigma, n_build),
                           pd.DataFrame(rows), calib)


def plot_calibration_figure(summary: CoverageSummary, path: str | Path) -> Path | None:
    """Write the held-out calibration figure (coverage against k) to ``path``."""
    if summary is None or summary.calibration is None:
        return None
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig = summary.calibration.plot()
    fig.axes[0].set_title(f"Held-out truths inside the k-sigma bound "
                          f"({summary.n_trials} trials)", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return Path(path)
