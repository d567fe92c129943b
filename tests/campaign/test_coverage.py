"""Coverage of the bound over trials (campaign.coverage), checked against normal theory
(Student-t), from uncertainty stages built by hand."""

import numpy as np
import pytest

from truthbench.campaign.coverage import coverage_summary
from truthbench.campaign.uncertainty_stage import UncertaintyStage
from truthbench.uncertainty import expected_coverage, uncertainty_model


def _stages(n_trials=400, n_build=5, n_hold=1, bias=0.0, seed=0):
    """Per trial: true per-test values drawn from N(mu, sigma), identified values =
    truth + small noise + bias, the bound from the building tests."""
    rng = np.random.default_rng(seed)
    mu, sigma = np.array([50.0, 0.01]), np.array([0.25, 0.001])
    hold = np.r_[np.zeros(n_build, bool), np.ones(n_hold, bool)]
    out = []
    for _ in range(n_trials):
        truth = mu + sigma * rng.standard_normal((n_build + n_hold, 2))
        tests = truth + 0.01 * sigma * rng.standard_normal(truth.shape) + bias * sigma
        um = uncertainty_model(tests[~hold], mu, covariance="diagonal")
        out.append(UncertaintyStage(("f1_hz", "zeta1"), mu, tests, truth, um.mean, um.std,
                                    um.bound, um.contains(truth), np.array([0]), hold))
    return out


def test_held_out_coverage_matches_student_t():
    cov = coverage_summary(_stages(), 3.0)
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
    per = cov.to_pandas()
    assert list(per["parameter"]) == ["f1_hz", "zeta1"] and (per["truths"] == 400).all()


def test_biased_identification_shows_as_a_coverage_shortfall():
    cov = coverage_summary(_stages(bias=1.5), 3.0)
    assert cov.holdout.ci_high < cov.holdout_expected


def test_without_holdout_counts_in_sample_only():
    cov = coverage_summary(_stages(n_trials=20, n_build=4, n_hold=0), 3.0)
    assert cov.holdout is None and cov.calibration is None
    assert cov.in_sample.n_total == 20 * 4 * 2
    with pytest.raises(ValueError, match="no calibration curve"):
        cov.plot()
    assert coverage_summary([None, None]) is None


def test_counts_by_hand():
    """Two trials, three tests, one parameter: the truths inside are counted exactly."""
    mu = np.array([10.0])
    truth = np.array([[10.0], [10.5], [13.0]])  # bound 10 +- 1: inside, inside, outside
    stage = UncertaintyStage(("f1_hz",), mu, truth, truth, np.zeros(1), np.ones(1) / 3,
                             np.ones(1), np.zeros((3, 1), bool), np.array([0]),
                             np.array([False, False, True]))
    cov = coverage_summary([stage, stage], 3.0)
    assert (cov.in_sample.n_inside, cov.in_sample.n_total) == (4, 4)
    assert (cov.holdout.n_inside, cov.holdout.n_total) == (0, 2)


def test_calibration_figure():
    import matplotlib.pyplot as plt

    fig = coverage_summary(_stages(n_trials=30), 3.0).plot()
    assert "Held-out truths" in fig.axes[0].get_title()
    plt.close(fig)
