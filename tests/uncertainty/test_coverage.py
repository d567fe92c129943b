"""Coverage of the 3-sigma bound: Monte Carlo against Student-t and Beta theory."""

import numpy as np
import pytest
from scipy import stats

from truthbench.uncertainty import (
    bound_coverage,
    calibration_curve,
    clopper_pearson_interval,
    coverage_fraction,
    expected_coverage,
    uncertainty_model,
    wilson_interval,
)

N_TRIALS, P = 2000, 10  # 2000 trials x 10 independent parameters = 20000 events


def _draws(T, seed):
    rng = np.random.default_rng(seed)
    mu = np.linspace(-1.0, 5.0, P)
    sd = np.linspace(0.01, 2.0, P)
    tests = mu + sd * rng.standard_normal((N_TRIALS, T, P))
    new = mu + sd * rng.standard_normal((N_TRIALS, P))
    return tests, new


def test_expected_values():
    assert expected_coverage(3.0) == pytest.approx(0.9973002, abs=1e-7)
    # P(|t_{T-1}| < 3 / sqrt(1 + 1/T)) from scipy directly
    for T in (3, 5, 8, 20):
        ref = stats.t.cdf(3 / np.sqrt(1 + 1 / T), T - 1) - stats.t.cdf(-3 / np.sqrt(1 + 1 / T),
                                                                     T - 1)
        assert expected_coverage(3.0, T) == pytest.approx(ref, rel=1e-12)
        assert expected_coverage(3.0, T) < 0.9973
    # in-sample: |r| <= (T - 1)/sqrt(T) < 3 for T <= 10
    assert expected_coverage(3.0, 8, in_sample=True) == 1.0
    assert expected_coverage(3.0, 10, in_sample=True) == 1.0
    assert expected_coverage(3.0, 20, in_sample=True) < 1.0
    np.testing.assert_allclose(expected_coverage([1.0, 2.0]), [0.6826895, 0.9544997],
                               atol=1e-7)


def test_interval_functions_against_references():
    # Wilson: textbook formula; Clopper-Pearson: scipy's binomtest exact interval
    lo, hi = wilson_interval(81, 263)
    assert (lo, hi) == pytest.approx((0.2553, 0.3662), abs=5e-4)
    ci = stats.binomtest(81, 263).proportion_ci(0.95, method="exact")
    assert clopper_pearson_interval(81, 263) == pytest.approx((ci.low, ci.high), rel=1e-10)
    ci = stats.binomtest(81, 263).proportion_ci(0.95, method="wilson")
    assert wilson_interval(81, 263) == pytest.approx((ci.low, ci.high), rel=1e-10)
    assert clopper_pearson_interval(0, 10)[0] == 0.0
    assert clopper_pearson_interval(10, 10)[1] == 1.0


@pytest.mark.parametrize("T", [5, 8])
def test_new_draw_coverage_matches_student_t(T):
    tests, new = _draws(T, seed=100 + T)
    cov = bound_coverage(tests, new, k=3.0)
    assert cov.n_total == N_TRIALS * P
    expect = expected_coverage(3.0, T)
    assert cov.agrees_with(expect), (cov, expect)
    assert cov.ci_high < 0.9973  # clearly below the known-variance value
    cp = bound_coverage(tests, new, k=3.0, method="clopper-pearson")
    assert cp.agrees_with(expect)


def test_bound_coverage_uses_eq_10_47_10_48():
    tests, new = _draws(5, seed=3)
    inside = np.stack([uncertainty_model(tests[i], np.zeros(P), covariance="diagonal")
                       .contains(new[i]) for i in range(50)])
    assert coverage_fraction(inside).n_inside == bound_coverage(tests[:50], new[:50]).n_inside


def test_in_sample_coverage():
    tests, _ = _draws(8, seed=5)
    cov = bound_coverage(tests)  # the tests against their own bound
    assert cov.fraction == 1.0  # guaranteed for T <= 10
    tests20, _ = _draws(20, seed=6)
    curve = calibration_curve(tests20, k=[1.5, 2.0, 2.5, 3.0])
    assert curve.in_sample
    for i in range(len(curve.k)):
        assert curve.ci_low[i] <= curve.expected_t[i] <= curve.ci_high[i]


def test_calibration_curve_matches_t():
    T = 5
    tests, new = _draws(T, seed=11)
    curve = calibration_curve(tests, new)
    assert curve.k[0] == 0.5 and curve.k[-1] == 4.0 and len(curve.k) == 15
    for kk in (1.0, 2.0, 3.0, 4.0):
        i = int(np.argmin(np.abs(curve.k - kk)))
        assert curve.ci_low[i] <= curve.expected_t[i] <= curve.ci_high[i], (kk, curve)
    # with T = 5 the known-variance curve is clearly wrong beyond k = 1
    i3 = int(np.argmin(np.abs(curve.k - 3.0)))
    assert curve.ci_high[i3] < curve.expected_normal[i3]
    df = curve.to_pandas()
    assert list(df.columns) == ["coverage", "ci_low", "ci_high", "expected_normal",
                                "expected_t"]


def test_errors():
    with pytest.raises(ValueError, match="'n_inside'"):
        wilson_interval(11, 10)
    with pytest.raises(ValueError, match="'n_total'"):
        clopper_pearson_interval(0, 0)
    with pytest.raises(ValueError, match="'confidence'"):
        wilson_interval(1, 10, confidence=1.5)
    with pytest.raises(ValueError, match="'inside'.*boolean"):
        coverage_fraction(np.ones(3))
    with pytest.raises(ValueError, match="'method'"):
        coverage_fraction(np.ones(3, dtype=bool), method="agresti")
    with pytest.raises(ValueError, match="'k'"):
        expected_coverage(-1.0)
    with pytest.raises(ValueError, match="'n_tests'.*>= 2"):
        expected_coverage(3.0, 1)
    with pytest.raises(ValueError, match="'theta_tests'.*\\(n_trials, T, p\\)"):
        bound_coverage(np.zeros((4, 3)))
    with pytest.raises(ValueError, match="at least 2 tests"):
        bound_coverage(np.zeros((4, 1, 3)))
    with pytest.raises(ValueError, match="'theta_true'.*shape"):
        bound_coverage(np.zeros((4, 5, 3)), np.zeros((4, 2)))
    with pytest.raises(ValueError, match="finite"):
        bound_coverage(np.full((4, 5, 3), np.nan))


def test_trial_clustered_interval_counts_trials_not_correlated_events():
    """m identical events per trial carry the information of one: the clustered interval
    equals the Wilson interval of N - 1 events, where plain Wilson would use N m."""
    from truthbench.uncertainty.coverage import _wilson

    rng = np.random.default_rng(5)
    x = rng.random(300) < 0.9
    same = np.repeat(x[:, None], 6, axis=1)
    c = coverage_fraction(same, method="trial-clustered")
    assert (c.n_inside, c.n_total) == (6 * x.sum(), 1800)
    lo, hi = _wilson(x.mean(), 299, 0.95)
    assert (c.ci_low, c.ci_high) == pytest.approx((lo, hi), rel=1e-12)
    assert c.ci_high - c.ci_low > 2 * (coverage_fraction(same).ci_high
                                       - coverage_fraction(same).ci_low)
    # independent events within trials: about as wide as plain Wilson over all events
    ind = rng.random((300, 6)) < 0.9
    a, b = coverage_fraction(ind, method="trial-clustered"), coverage_fraction(ind)
    assert (a.ci_high - a.ci_low) == pytest.approx(b.ci_high - b.ci_low, rel=0.15)
    # invalid events are not counted
    v = np.ones_like(same)
    v[:, 3:] = False
    assert coverage_fraction(same, valid=v, method="trial-clustered").n_total == 900
    with pytest.raises(ValueError, match="at least 2 clusters"):
        coverage_fraction(same[:1], method="trial-clustered")
