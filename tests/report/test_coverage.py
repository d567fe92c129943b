"""Coverage summary of a results file, checked against normal theory (Student-t)."""

import numpy as np
import pytest

from truthbench.report.coverage import coverage_summary, plot_calibration_figure
from truthbench.uncertainty import expected_coverage, uncertainty_model


def _results(n_trials=400, n_build=5, n_hold=1, bias=0.0, seed=0):
    """Results-file dicts as read_results gives them: per trial, true per-test values
    drawn from N(mu, sigma) and identified values = truth + small noise + bias."""
    rng = np.random.default_rng(seed)
    mu, sigma = np.array([50.0, 0.01]), np.array([0.25, 0.001])
    trials = {}
    hold = np.r_[np.zeros(n_build, bool), np.ones(n_hold, bool)]
    for i in range(n_trials):
        truth = mu + sigma * rng.standard_normal((n_build + n_hold, 2))
        tests = truth + 0.01 * sigma * rng.standard_normal(truth.shape) + bias * sigma
        um = uncertainty_model(tests[~hold], mu, covariance="diagonal")
        trials[f"{i:04d}"] = {"attrs": {"status": "ok"}, "uncertainty": {
            "names": np.array([b"f1_hz", b"zeta1"]), "theta_0": mu, "theta_tests": tests,
            "theta_truth": truth, "mean": um.mean, "std": um.std, "bound": um.bound,
            "inside": um.contains(truth), "holdout": hold}}
    return {"attrs": {"spec": {"uncertainty": {"k_sigma": 3.0}}}, "trials": trials}


def test_held_out_coverage_matches_student_t():
    cov = coverage_summary(_results())
    # 400 trials x 2 parameters; expectation for T = 5 building tests: 0.9480
    assert cov.n_build == 5 and cov.n_trials == 400
    assert cov.holdout_expected == pytest.approx(expected_coverage(3.0, 5))
    assert cov.holdout.n_total == 800
    assert cov.holdout.agrees_with(cov.holdout_expected)
    # the calibration curve agrees at every k (95 % Wilson intervals, 15 values of k:
    # allow one miss, the expected number of misses is 0.75)
    c = cov.calibration
    misses = np.sum((c.expected_t < c.ci_low) | (c.expected_t > c.ci_high))
    assert misses <= 1
    # in-sample: every building test inside for T = 5 (|r| <= (T-1)/sqrt(T) < 3)
    assert cov.in_sample.fraction == pytest.approx(1.0, abs=2e-3)


def test_biased_identification_shows_as_a_coverage_shortfall():
    cov = coverage_summary(_results(bias=1.5))
    assert cov.holdout.ci_high < cov.holdout_expected


def test_without_holdout_counts_in_sample_only(tmp_path):
    cov = coverage_summary(_results(n_trials=20, n_build=4, n_hold=0))
    assert cov.holdout is None and cov.calibration is None
    assert cov.in_sample.n_total == 20 * 4 * 2
    assert plot_calibration_figure(cov, tmp_path / "c.png") is None
    assert coverage_summary({"attrs": {}, "trials": {}}) is None


def test_calibration_figure_is_written(tmp_path):
    path = plot_calibration_figure(coverage_summary(_results(n_trials=30)), tmp_path / "c.png")
    assert path.stat().st_size > 10_000
