"""Eq. 10.46-10.50: the uncertainty model over repeated tests."""

import numpy as np
import pytest

from truthbench.errors import IdentifiabilityError
from truthbench.uncertainty import uncertainty_model


@pytest.fixture
def tests_and_model():
    rng = np.random.default_rng(1)
    theta_0 = np.array([8.4, 0.005, 23.1])  # f1_hz, zeta1, f2_hz
    X = theta_0 + np.array([0.1, 0.002, -0.3]) + rng.normal(size=(8, 3)) * [0.05, 0.002, 0.2]
    return X, theta_0


def test_unit_weights_are_numpy_mean_and_sample_covariance(tests_and_model):
    X, t0 = tests_and_model
    um = uncertainty_model(X, t0, names=["f1_hz", "zeta1", "f2_hz"])
    d = X - t0
    np.testing.assert_allclose(um.delta, d, rtol=0, atol=1e-15)
    np.testing.assert_allclose(um.mean, d.mean(axis=0), rtol=1e-13)
    np.testing.assert_allclose(um.cov, np.cov(d, rowvar=False, ddof=1), rtol=1e-12)
    np.testing.assert_allclose(um.std, d.std(axis=0, ddof=1), rtol=1e-12)
    np.testing.assert_allclose(um.bound, 3.0 * um.std, rtol=1e-15)
    np.testing.assert_allclose(um.mean_model, X.mean(axis=0), rtol=1e-13)
    np.testing.assert_allclose(um.bias_factor, 1.0)
    assert um.covariance == "full" and um.estimator == "chapter"
    # unit weights: the unbiased form is the same estimator
    ub = uncertainty_model(X, t0, estimator="unbiased")
    np.testing.assert_allclose(ub.cov, um.cov, rtol=1e-12)


def test_weighted_hand_computation_equal_totals():
    X = np.array([[1.0, 10.0], [2.0, 14.0], [4.0, 12.0]])
    w = np.array([[1.0, 2.0], [1.0, 1.0], [2.0, 1.0]])
    um = uncertainty_model(X, [0.0, 0.0], weights=w)
    # parameter 0: W = 4, mean = (1 + 2 + 8)/4, r = (-1.75, -0.75, 1.25)
    # sum w^2 r^2 = 3.0625 + 0.5625 + 4 * 1.5625 = 9.875; / (4 - 1)
    # parameter 1: W = 4, mean = (20 + 14 + 12)/4 = 11.5, r = (-1.5, 2.5, 0.5)
    # sum w^2 r^2 = 4 * 2.25 + 6.25 + 0.25 = 15.5; / 3
    # cross: 2 * 2.625 - 1.875 + 2 * 0.625 = 4.625; / 3
    np.testing.assert_allclose(um.mean, [2.75, 11.5], rtol=1e-15)
    np.testing.assert_allclose(um.cov, [[9.875 / 3, 4.625 / 3], [4.625 / 3, 15.5 / 3]],
                               rtol=1e-14)
    np.testing.assert_allclose(um.bound, 3 * np.sqrt([9.875 / 3, 15.5 / 3]), rtol=1e-14)


def test_weighted_hand_computation_unequal_totals_is_not_symmetric():
    X = np.array([[1.0, 10.0], [2.0, 14.0], [4.0, 12.0]])
    w = np.array([[1.0, 1.0], [1.0, 1.0], [2.0, 1.0]])
    um = uncertainty_model(X, [0.0, 0.0], weights=w)
    # parameter 1: W = 3, mean 12, r = (-2, 2, 0): variance (4 + 4) / 2 = 4
    # cross sum = 1 * (-1.75)(-2) + 1 * (-0.75)(2) + 2 * 1.25 * 0 = 2.0
    # (W - I)^-1 divides row 0 by 3 and row 1 by 2: the printed Eq. 10.48 is not symmetric
    np.testing.assert_allclose(um.cov, [[9.875 / 3, 2.0 / 3], [2.0 / 2, 4.0]], rtol=1e-14)
    sym = um.cov_symmetric
    np.testing.assert_allclose(sym, sym.T)
    np.testing.assert_allclose(np.diag(sym), np.diag(um.cov))
    np.testing.assert_allclose(sym[0, 1], 2.0 / np.sqrt(3 * 2))


def test_zero_one_weights_drop_tests(tests_and_model):
    X, t0 = tests_and_model
    w = np.ones((8, 3))
    w[[1, 5], 0] = 0.0  # drop tests 1 and 5 for parameter 0 only
    um = uncertainty_model(X, t0, weights=w, covariance="diagonal")
    kept = np.delete(X[:, 0] - t0[0], [1, 5])
    np.testing.assert_allclose(um.mean[0], kept.mean(), rtol=1e-13)
    np.testing.assert_allclose(um.std[0], kept.std(ddof=1), rtol=1e-12)
    np.testing.assert_allclose(um.bias_factor, 1.0)


def test_chapter_form_bias_and_unbiased_form_monte_carlo():
    # every column an independent replicate of one parameter (diagonal covariance)
    rng = np.random.default_rng(7)
    T, n_rep, n_batch, sigma = 5, 2000, 20, 2.0
    w = np.array([0.5, 1.0, 1.5, 2.0, 3.0])
    var_ch = var_ub = 0.0
    for _ in range(n_batch):
        X = rng.normal(3.0, sigma, size=(T, n_rep))
        ch = uncertainty_model(X, np.zeros(n_rep), weights=w, covariance="diagonal")
        ub = uncertainty_model(X, np.zeros(n_rep), weights=w, covariance="diagonal",
                               estimator="unbiased")
        var_ch += np.diag(ch.cov).mean() / sigma**2 / n_batch
        var_ub += np.diag(ub.cov).mean() / sigma**2 / n_batch
    # exact expectation of the chapter form: D / (W - 1), computed here from scratch
    W = w.sum()
    a = w / W
    D = np.sum(w**2 * (1 - 2 * a)) + np.sum(w**2) * np.sum(a**2)
    assert ch.bias_factor[0] == pytest.approx(D / (W - 1), rel=1e-12)
    # sampling error of the mean over 40000 replicates: about 0.6 % here
    assert var_ch == pytest.approx(D / (W - 1), rel=0.03)
    assert var_ub == pytest.approx(1.0, rel=0.03)
    assert abs(D / (W - 1) - 1.0) > 0.3  # the chapter form is clearly biased here
    # the unbiased form does not depend on the weights' scale; the chapter's form does
    ub_scaled = uncertainty_model(X[:, :10], np.zeros(10), weights=w / w.sum(),
                                  covariance="diagonal", estimator="unbiased")
    ub_ref = uncertainty_model(X[:, :10], np.zeros(10), weights=w, covariance="diagonal",
                               estimator="unbiased")
    np.testing.assert_allclose(ub_scaled.cov, ub_ref.cov, rtol=1e-12)
    # weights all 2: 2 (T - 1) / (T - 1/2) times too large
    two = uncertainty_model(X[:, :10], np.zeros(10), weights=2 * np.ones(T),
                            covariance="diagonal")
    np.testing.assert_allclose(two.bias_factor, 2 * (T - 1) / (T - 0.5), rtol=1e-12)


def test_contains_and_to_pandas(tests_and_model):
    X, t0 = tests_and_model
    um = uncertainty_model(X, t0, names=["f1_hz", "zeta1", "f2_hz"])
    inside = um.contains(X)
    assert inside.shape == X.shape and inside.all()  # T = 8: always (see coverage.py)
    far = um.mean_model + 1.01 * um.bound
    assert not um.contains(far).any()
    assert um.contains(um.mean_model + 0.999 * um.bound).all()
    df = um.to_pandas()
    assert list(df.index) == ["f1_hz", "zeta1", "f2_hz"]
    np.testing.assert_allclose(df["upper"], um.mean_model + um.bound)
    # inputs untouched, results read-only
    X0 = X.copy()
    uncertainty_model(X, t0)
    np.testing.assert_array_equal(X, X0)
    with pytest.raises(ValueError):
        um.mean[0] = 1.0


def test_errors():
    X = np.arange(12.0).reshape(4, 3) ** 1.5
    t0 = np.zeros(3)
    with pytest.raises(IdentifiabilityError, match="at least 2 tests"):
        uncertainty_model(X[:1], t0)
    with pytest.raises(IdentifiabilityError, match="singular.*covariance='diagonal'"):
        uncertainty_model(X[:3], t0)
    assert uncertainty_model(X[:3], t0, covariance="diagonal").std.shape == (3,)
    bad = X.copy()
    bad[2, 1] = np.nan
    with pytest.raises(ValueError, match=r"'theta_tests'.*finite.*tests \[2\]"):
        uncertainty_model(bad, t0)
    with pytest.raises(ValueError, match="'weights'.*>= 0.*theta1"):
        uncertainty_model(X, t0, weights=[[1, 1, 1], [1, -1, 1], [1, 1, 1], [1, 1, 1]])
    with pytest.raises(IdentifiabilityError, match="sum to more than 1.*theta2"):
        uncertainty_model(X, t0, weights=np.array([[1, 1, 0.25]] * 4))
    with pytest.raises(IdentifiabilityError, match="positive sum.*theta2"):
        uncertainty_model(X, t0, weights=np.array([[1, 1, 0]] * 4), estimator="unbiased")
    with pytest.raises(IdentifiabilityError, match="fewer than 2 tests of non-zero weight"):
        uncertainty_model(X, t0, weights=np.array([[1, 1, 1]] + [[1, 1, 0]] * 3),
                          estimator="unbiased", covariance="diagonal")
    with pytest.raises(ValueError, match="'theta_0'.*shape \\(3,\\)"):
        uncertainty_model(X, np.zeros(2))
    with pytest.raises(ValueError, match="'weights'.*shape"):
        uncertainty_model(X, t0, weights=np.ones((3, 3)))
    with pytest.raises(ValueError, match="'names'.*3 names"):
        uncertainty_model(X, t0, names=["a"])
    with pytest.raises(ValueError, match="'covariance'"):
        uncertainty_model(X, t0, covariance="banded")
    with pytest.raises(ValueError, match="'estimator'"):
        uncertainty_model(X, t0, estimator="ml")
    with pytest.raises(ValueError, match="'k_sigma'"):
        uncertainty_model(X, t0, k_sigma=0)
    um = uncertainty_model(X, t0)
    with pytest.raises(ValueError, match="'theta'.*length 3"):
        um.contains(np.zeros(2))
