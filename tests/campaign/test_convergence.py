"""Statistics against the trial count: running means against direct computation, the
last point against the result's own coverage summary, the report's section and figure."""

import matplotlib
import numpy as np
import pytest
from scipy import stats

from truthbench.campaign.convergence import checkpoints, convergence, running_mean
from truthbench.campaign.results import CampaignResult, TrialResult
from truthbench.campaign.spec import parse_campaign
from truthbench.campaign.uncertainty_stage import UncertaintyStage
from truthbench.update.finite_difference import UpdateResult

matplotlib.use("Agg")


def test_checkpoints_are_increasing_and_end_at_n():
    for n in (2, 3, 17, 10_000):
        c = checkpoints(n, 40)
        assert c[0] == 2 and c[-1] == n and np.all(np.diff(c) > 0) and len(c) <= 40
    assert checkpoints(1).size == 0


def test_running_mean_is_the_mean_and_t_interval_of_the_first_n():
    rng = np.random.default_rng(1)
    x = rng.normal(3.0, 2.0, (50, 2))
    x[7, 1] = np.nan  # left out, and not counted
    counts = [2, 5, 8, 50]
    mean, lo, hi = running_mean(x, counts, 0.9)
    for i, n in enumerate(counts):
        for k in range(2):
            v = x[:n, k][np.isfinite(x[:n, k])]
            half = stats.t.ppf(0.95, v.size - 1) * v.std(ddof=1) / np.sqrt(v.size)
            assert mean[i, k] == pytest.approx(v.mean(), rel=1e-12)
            assert (lo[i, k], hi[i, k]) == pytest.approx((v.mean() - half, v.mean() + half),
                                                         rel=1e-9)


def _stage(rng, k_sigma=3.0):
    """Five building tests and one held out, two modes: normal draws around the model."""
    theta0 = np.array([50.0, 130.0, 0.01, 0.01])
    tests = theta0 * (1 + 0.01 * rng.standard_normal((6, 4)))
    truth = theta0 * (1 + 0.01 * rng.standard_normal((6, 4)))
    build = tests[:5]
    mean, std = build.mean(axis=0) - theta0, build.std(axis=0, ddof=1)
    bound = k_sigma * std
    inside = np.abs(truth - (theta0 + mean)) <= bound
    return UncertaintyStage(("f1_hz", "f2_hz", "zeta1", "zeta2"), theta0, tests, truth, mean,
                            std, bound, inside, np.array([0, 1]),
                            np.array([False] * 5 + [True]))


@pytest.fixture
def many(small_dict):
    """30 hand-made trials of six tests (the last held out): an uncertainty stage each,
    25 updated."""
    small_dict["tests"] += [{**small_dict["tests"][0], "name": f"t{j}"} for j in range(3, 7)]
    small_dict["uncertainty"] = {"holdout": ["t6"]}
    spec = parse_campaign(small_dict)
    rng = np.random.default_rng(7)
    trials = []
    for k in range(30):
        u = _stage(rng)
        kw = {}
        if k < 25:
            e = 70e9 * (1 + 0.001 * rng.standard_normal())
            res = UpdateResult(("E_pa",), np.array([68.9e9]), np.array([e]), np.zeros((2, 1)),
                               np.ones(2), np.ones(1), 1.0, np.eye(1), True)
            kw = dict(update=res, comparison={"finite_difference": res})
        trials.append(TrialResult(k, (), {"E_pa": 70e9}, uncertainty=u, **kw))
    return CampaignResult(spec, 1, "0", spec.nominal_parameters(), tuple(trials))


def test_the_last_point_is_the_whole_result(many):
    c = convergence(many)
    assert c.trials[-1] == 30 and c.parameter_trials[-1] == 25
    held = many.coverage().holdout
    assert c.coverage_of == "held-out"
    assert tuple(c.coverage[-1]) == pytest.approx((held.fraction, held.ci_low, held.ci_high))
    errors = many.to_pandas("parameters")["error_after_pct"].to_numpy()
    assert c.parameter_error[-1, 0, 0] == pytest.approx(errors.mean(), rel=1e-12)
    assert c.parameter_rms[-1, 0] == pytest.approx(np.sqrt(np.mean(errors**2)), rel=1e-12)
    tests = np.array([u.theta_tests[:5, :2] for u in (t.uncertainty for t in many.trials)])
    truth = np.array([u.theta_truth[:5, :2] for u in (t.uncertainty for t in many.trials)])
    per_trial = (100 * (tests / truth - 1)).mean(axis=1)
    assert c.identification[-1, 0] == pytest.approx(per_trial.mean(axis=0), rel=1e-10)
    # the intervals narrow with the trials
    width = c.coverage[:, 2] - c.coverage[:, 1]
    assert width[-1] < width[0]


def test_the_report_shows_the_convergence_from_twenty_trials(many, tmp_path):
    import matplotlib.pyplot as plt

    from truthbench.report.accuracy import write_report

    fig = many.plot("convergence")
    assert [ax.get_xscale() for ax in fig.axes] == ["log"] * 3
    plt.close(fig)
    report = write_report(many, tmp_path).read_text()
    assert "## Convergence with the number of trials" in report
    assert "Coverage of the held-out truths after 30 trials" in report
    assert (tmp_path / "convergence.png").exists()
    few = CampaignResult(many.spec, 1, "0", many.nominal, many.trials[:5])
    assert "## Convergence" not in write_report(few, tmp_path / "few").read_text()
