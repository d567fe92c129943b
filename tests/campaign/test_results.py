"""The result objects' tables and figures, checked on results built by hand (numbers
worked out here, not by the code under test)."""

import math

import matplotlib
import numpy as np
import pytest

from truthbench.campaign.results import CampaignResult, TestRecord, TrialResult
from truthbench.campaign.spec import parse_campaign
from truthbench.campaign.uncertainty_stage import UncertaintyStage
from truthbench.io.hdf5 import frf_unit
from truthbench.measure.frfdata import Channel, FRFData
from truthbench.update.finite_difference import UpdateResult

matplotlib.use("Agg")


def _update(values, method="finite_difference", initial=(68.9e9, 2700.0)):
    p = len(values)
    return UpdateResult(("E_pa", "rho_kg_m3"), np.array(initial), np.array(values),
                        np.zeros((3, p)), np.ones(3), np.ones(p), 1.0, np.eye(p), True, method)


def _record(name, H, freq=(0.0, 10.0, 20.0, 30.0)):
    f = np.array(freq)
    frf = FRFData(name, f, np.asarray(H, complex).reshape(len(f), 1, 1),
                  (Channel("mid.z.acc", "acceleration", "z"),), (Channel("end_a.z", "force", "z"),),
                  coherence=np.full((len(f), 1, 1), 0.5), n_averages=4)
    return TestRecord(name, frf, np.zeros((1, 0)), np.zeros((1, 0)), 100.0, {})


def _acc(freq_err, mac=(1.0, 0.99)):
    return {"truth_freq_hz": np.array([50.0, 130.0]), "freq_error_pct": np.array(freq_err),
            "damping_error_pct": np.array([1.0, -1.0]), "mac": np.array(mac),
            "n_unpaired_truth": 0}


@pytest.fixture
def hand(small_dict):
    """Two updated trials with round numbers, and one failed trial."""
    small_dict["update"]["method"] = ["finite_difference", "sensitivity"]
    spec = parse_campaign(small_dict)
    truth = {"E_pa": 70e9, "rho_kg_m3": 2600.0}
    trials = []
    for k, (e_fd, e_s) in enumerate([(0.01, 0.02), (0.03, -0.02)]):
        fd = _update([70e9 * (1 + e_fd), 2600.0])
        sens = _update([70e9 * (1 + e_s), 2600.0], "sensitivity")
        recs = (_record("shaker_end", [1, 1, 1, 1]), _record("shaker_quarter", [2, 2, 2, 2]))
        mask = np.array([False, True, True, False])
        trials.append(TrialResult(
            k, recs, truth, fd, H_initial=(np.full((3, 1, 1), 2.0), np.full((3, 1, 1), 2.0)),
            H_updated=(np.full((3, 1, 1), 1.1), np.full((3, 1, 1), 2.0)),
            update_mask=(mask, mask),
            accuracy={"initial": _acc([2.0, -4.0]), "finite_difference": _acc([0.1, 0.3]),
                      **({"sensitivity": _acc([0.2, -0.2], (0.98, 0.97))} if k == 0
                         else {}),
                      "updated": _acc([0.1, 0.3])},
            comparison={"finite_difference": fd,
                        "sensitivity": sens if k == 0 else "ConvergenceError: no"},
            seconds={"simulate": 1.0, "update": 3.0}))
    trials.append(TrialResult(2, (), {}, error="RuntimeError: shaker tripped",
                              seconds={"simulate": 0.5}))
    return CampaignResult(spec, 1, "0", spec.nominal_parameters(), tuple(trials))


def test_parameters_table_and_summary(hand):
    df = hand.to_pandas("parameters")
    # two trials x two parameters with finite differences, one trial with sensitivity
    assert len(df) == 6 and set(df["trial"]) == {0, 1}
    row = df[(df.trial == 1) & (df.parameter == "E_pa") & (df.method == "finite_difference")]
    assert row["error_after_pct"].item() == pytest.approx(3.0)
    assert row["error_before_pct"].item() == pytest.approx(100 * (68.9 / 70 - 1))
    assert row["unit"].item() == "Pa" and row["primary"].item()
    s = hand.summary("parameters")
    e = s[(s.parameter == "E_pa") & (s.method == "finite_difference")]
    assert e["error_after_pct"].item() == pytest.approx(2.0)  # mean of 1 and 3
    assert e["rms_error_after_pct"].item() == pytest.approx(math.sqrt(5.0))
    assert e["trials"].item() == 2
    assert list(s["method"]) == ["finite_difference"] * 2 + ["sensitivity"] * 2


def test_methods_modes_and_frf_error(hand):
    m = hand.summary("methods").set_index("method")
    # none: E -1.571 %, rho +3.846 %, twice each
    none = math.sqrt(np.mean([(100 * (68.9 / 70 - 1)) ** 2, (100 * (2700 / 2600 - 1)) ** 2]))
    assert m.loc["none", "parameter_rms_error_pct"] == pytest.approx(none)
    assert m.loc["finite_difference", "parameter_rms_error_pct"] == pytest.approx(
        math.sqrt((1 + 9 + 0 + 0) / 4))
    assert m.loc["sensitivity", "failed_trials"] == 1
    assert m.loc["sensitivity", "min_mac"] == 0.97
    assert m.loc["none", "mean_abs_freq_error_pct"] == pytest.approx(3.0)
    modes = hand.summary("modes")
    assert list(modes["truth_freq_hz"]) == [50.0, 130.0]
    assert list(modes["updated_freq_error_pct"]) == pytest.approx([0.1, 0.3])
    assert len(hand.to_pandas("modes")) == 2 * (2 + 2) + 2  # initial, fd; sens in trial 0
    fe = hand.summary("frf_error").set_index("test")
    # data 1 against initial 2 and updated 1.1 over two lines: 100 % and 10 %
    assert fe.loc["shaker_end", "frf_error_before_pct"] == pytest.approx(100.0)
    assert fe.loc["shaker_end", "frf_error_after_pct"] == pytest.approx(10.0)
    assert fe.loc["shaker_quarter", "frf_error_after_pct"] == pytest.approx(0.0)


def test_stage_times_and_tests(hand):
    st = hand.to_pandas("stage_times")
    assert list(st["trial"]) == [0, 1, 2] and list(st["total"]) == [4.0, 4.0, 0.5]
    s = hand.summary("stage_times").set_index("stage")
    assert s.loc["update", "seconds"] == 6.0
    assert s.loc["update", "share_pct"] == pytest.approx(100 * 6 / 8.5)
    t = hand.summary("tests")
    assert list(t["test"]) == ["shaker_end", "shaker_quarter"]
    assert (t["mean_coherence_in_band"] == 0.5).all()


def test_coverage_table(small_dict):
    spec = parse_campaign(small_dict)
    u = UncertaintyStage(("f1_hz", "zeta1"), np.array([50.0, 0.01]),
                         np.array([[50.1, 0.011], [49.9, 0.009]]),
                         np.array([[50.0, 0.010], [52.0, 0.010]]), np.array([0.0, 0.0]),
                         np.array([0.1, 0.001]), np.array([0.3, 0.003]),
                         np.array([[True, True], [False, True]]), np.array([0]),
                         np.array([False, False]))
    res = CampaignResult(spec, 1, "0", {}, (TrialResult(0, (), {}, uncertainty=u),))
    df = res.to_pandas("coverage")
    assert len(df) == 4 and list(df["test"]) == ["shaker_end"] * 2 + ["shaker_quarter"] * 2
    row = df[(df.test == "shaker_quarter") & (df.parameter == "f1_hz")]
    assert (row["lower"].item(), row["upper"].item()) == pytest.approx((49.7, 50.3))
    assert not row["truth_inside"].item()
    cov = res.summary("coverage").set_index("parameter")
    assert cov.loc["f1_hz", "inside"] == 1 and cov.loc["zeta1", "inside"] == 2


def test_unknown_names_are_errors(hand):
    with pytest.raises(ValueError, match="unknown table 'nope'; expected one of parameters"):
        hand.to_pandas("nope")
    with pytest.raises(ValueError, match="unknown summary 'nope'"):
        hand.summary("nope")
    with pytest.raises(ValueError, match="unknown figure 'nope'; expected one of frf"):
        hand.plot("nope")
    with pytest.raises(KeyError, match="no trial 9; the result holds trials 0, 1, 2"):
        hand.trial(9)
    with pytest.raises(KeyError, match="trial 0 has no test 'x'"):
        hand.trial(0).test("x")
    with pytest.raises(ValueError, match="trial 0 has no uncertainty stage"):
        hand.plot("poles")


def test_frf_figure_has_units_phase_and_coherence(hand):
    import matplotlib.pyplot as plt

    assert frf_unit(Channel("a", "acceleration", "z"), Channel("b", "force", "rz")) == \
        "m/s^2/(N m)"
    fig = hand.plot("frf", test="shaker_quarter")
    labels = [ax.get_ylabel() for ax in fig.axes]
    assert labels == ["|H| [m/s^2/N]", "phase [deg]", "coherence [-]"]
    assert fig.axes[-1].get_xlabel() == "frequency [Hz]"
    assert "shaker_quarter" in fig._suptitle.get_text()
    plt.close(fig)


def test_pole_figure_per_mode_with_test_names(small_dict):
    import matplotlib.pyplot as plt

    spec = parse_campaign(small_dict)
    theta0 = np.array([50.0, 130.0, 0.01, 0.01])
    tests = theta0 + np.array([[0.1, 0.2, 0.001, 0.0], [-0.1, -0.2, -0.001, 0.0005]])
    u = UncertaintyStage(("f1_hz", "f2_hz", "zeta1", "zeta2"), theta0, tests, tests,
                         np.zeros(4), np.array([0.1, 0.2, 0.001, 0.0004]),
                         np.array([0.3, 0.6, 0.003, 0.0012]), np.ones((2, 4), bool),
                         np.array([0, 1]), np.array([False, True]),
                         theta_updated=theta0 + 0.01)
    res = CampaignResult(spec, 1, "0", {}, (TrialResult(0, (), {}, uncertainty=u),))
    fig = res.plot("poles")
    panels = [ax for ax in fig.axes if ax.get_visible()]
    assert len(panels) == 2 and panels[1].get_title().startswith("mode 2")
    labels = panels[0].get_legend_handles_labels()[1]
    assert labels[:2] == ["shaker_end", "shaker_quarter (held out)"]
    # the bound is drawn above every marker, and the view holds the whole bound
    bound = next(line for line in panels[0].lines if line.get_label() == "3-sigma bound")
    assert all(bound.get_zorder() > ln.get_zorder() for ln in panels[0].lines
               if ln.get_label() not in ("3-sigma bound", "mean"))
    x, y = bound.get_data()
    (x0, x1), (y0, y1) = panels[0].get_xlim(), panels[0].get_ylim()
    assert x0 < x.min() and x.max() < x1 and y0 < y.min() and y.max() < y1
    # zoomed: the panel spans about the bound, not the whole s-plane (|s| ~ 314 rad/s)
    assert (y1 - y0) < 2 * 2 * np.pi * 0.6
    plt.close(fig)
