"""Coverage of the uncertainty bound against the truth, over the Monte Carlo trials.

From every trial's uncertainty stage
(:class:`~truthbench.campaign.uncertainty_stage.UncertaintyStage`) count the true
per-test modal parameters inside that trial's bound:

* **in-sample**: truths of the tests that built the bound; the identified values of
  those tests lie inside it almost by construction (``truthbench.uncertainty.coverage``),
  so this mostly checks that identification error is small against the test scatter;
* **held out**: truths of the tests listed in ``[uncertainty] holdout``, which did not
  build the bound: each is a new draw, and a normal population predicts the
  Student-t coverage ``P(|t_{T-1}| < k / sqrt(1 + 1/T))`` for ``T`` building tests.

Counted events are independent across trials for one parameter; the parameters of one
trial are not (one material draw moves every frequency), so pooled fractions carry
trial-clustered intervals (``coverage_fraction(method="trial-clustered")``, Wilson for a
single trial) and per-parameter fractions Wilson intervals.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

from truthbench.presentation import Presentable


@dataclass(frozen=True)
class CoverageSummary(Presentable):
    """Coverage of one campaign run's bounds.

    Table ``"parameters"`` (:meth:`to_pandas`): :attr:`per_parameter`. Figure
    ``"calibration"`` (:meth:`plot`): the held-out calibration.

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
    in_sample : truthbench.uncertainty.coverage.Coverage
        Truths of the building tests inside; trial-clustered interval.
    in_sample_expected : float or None
        Normal-theory in-sample value (None for fewer than 3 building tests).
    holdout : Coverage or None
        Held-out truths inside, trial-clustered interval (None without held-out tests).
    holdout_expected : float
        Student-t new-draw expectation for ``n_build`` tests.
    per_parameter : pandas.DataFrame
        One row per parameter: ``parameter``, ``truths``, ``inside``, ``coverage``,
        ``ci_low``, ``ci_high`` (Wilson) of the held-out truths, or of the in-sample
        ones without held-out tests.
    calibration : truthbench.uncertainty.coverage.CalibrationCurve or None
        Held-out coverage against ``k`` (None without held-out tests or with fewer than
        two complete trials).
    """

    TABLES = ("parameters",)
    PLOTS = ("calibration",)

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

    def _table_parameters(self):
        """The per-parameter table (:attr:`per_parameter`), a copy."""
        return self.per_parameter.copy()

    def _plot_calibration(self, ax):
        """The held-out calibration: observed coverage against ``k`` with its interval
        and the normal-theory expectations; a ValueError without a calibration curve
        (no held-out tests)."""
        if self.calibration is None:
            raise ValueError("no calibration curve: the campaign holds out no test "
                             "([uncertainty] holdout) or has fewer than two complete trials")
        fig = self.calibration.plot("calibration", ax)
        fig.axes[0].set_title(f"Held-out truths inside the k-sigma bound "
                              f"({self.n_trials} trials)", fontsize=10)
        fig.tight_layout()
        return fig


def _order(name: str):
    # f1_hz, f2_hz, .., zeta1, zeta2, ..
    return (not name.startswith("f"), int(re.sub(r"\D", "", name) or 0), name)


def stage_arrays(stages):
    """Per-trial arrays aligned by parameter name (NaN where a trial's stage lacks a
    parameter), over the stages with the first one's test split.

    Returns
    -------
    tuple or None
        ``(names, holdout (T,), tests (n, T, p), truth (n, T, p), mean_model (n, p),
        bound (n, p))``, or None without stages.
    """
    stages = [u for u in stages if u is not None]
    if not stages:
        return None
    n_tests = stages[0].theta_tests.shape[0]
    hold = np.asarray(stages[0].holdout, dtype=bool)
    stages = [u for u in stages if u.theta_tests.shape[0] == n_tests
              and np.array_equal(np.asarray(u.holdout, bool), hold)]
    names = sorted({n for u in stages for n in u.names}, key=_order)
    col = {n: i for i, n in enumerate(names)}
    shape = (len(stages), n_tests, len(names))
    tests, truth = np.full(shape, np.nan), np.full(shape, np.nan)
    mean_model, bound = np.full(shape[::2], np.nan), np.full(shape[::2], np.nan)
    for i, u in enumerate(stages):
        c = [col[n] for n in u.names]
        tests[i][:, c], truth[i][:, c] = u.theta_tests, u.theta_truth
        mean_model[i, c], bound[i, c] = u.theta_0 + u.mean, u.bound
    return tuple(names), hold, tests, truth, mean_model, bound


def truths_inside(arrays, k_sigma: float):
    """Which true values of :func:`stage_arrays`' ``arrays`` lie inside their trial's
    bound, and which count (a finite truth and bound).

    Returns
    -------
    inside, finite : ndarray of bool, shape (n, T, p)
    """
    _, _, _, truth, mean_model, bound = arrays
    std = bound / k_sigma
    finite = np.isfinite(truth) & np.isfinite(bound)[:, None, :]
    inside = np.abs(truth - mean_model[:, None, :]) <= k_sigma * std[:, None, :]
    return inside, finite


def coverage_summary(stages, k_sigma: float = 3.0,
                     confidence: float = 0.95) -> CoverageSummary | None:
    """Coverage of the bound over the trials' uncertainty stages.

    Parameters
    ----------
    stages : sequence of UncertaintyStage or None
        One per trial (None entries, trials without a stage, are skipped).
    k_sigma : float
        The ``k`` the stages' bounds were built with (``[uncertainty] k_sigma``).
    confidence : float
        Level of the intervals.

    Returns
    -------
    CoverageSummary or None
        None when no trial has an uncertainty stage.
    """
    import pandas as pd

    from truthbench.uncertainty import calibration_curve, coverage_fraction, expected_coverage

    arrays = stage_arrays(stages)
    if arrays is None:
        return None
    names, hold, tests, truth, mean_model, bound = arrays
    inside, finite = truths_inside(arrays, k_sigma)
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
                     "coverage": c.fraction, "ci_low": c.ci_low, "ci_high": c.ci_high})
    return CoverageSummary(names, float(k_sigma), n_build, tests.shape[0], in_sample,
                           in_expected, held, expected_coverage(k_sigma, n_build),
                           pd.DataFrame(rows), calib)
