"""The FRF-band stage: groups comparable tests, limits to the excited band, scores the
models; runs in every trial and is stored with it."""

from types import SimpleNamespace

import numpy as np
import pytest

from truthbench.campaign.frf_band_stage import frf_band, with_frf_band
from truthbench.campaign.results import TestRecord, TrialResult
from truthbench.measure.frfdata import Channel, FRFData


def _records(n_tests, seed=0):
    rng = np.random.default_rng(seed)
    f = np.arange(0, 101) * 1.0
    s = 2j * np.pi * f
    G = (1.0 / (s**2 + 2 * 0.02 * 2 * np.pi * 40 * s + (2 * np.pi * 40) ** 2))[:, None, None]
    out_ch = (Channel("b.z.dis", "displacement", "z"),)
    recs = []
    for j in range(n_tests):
        H = G * (1 + 0.02 * (rng.standard_normal(G.shape) + 1j * rng.standard_normal(G.shape)))
        frf = FRFData(f"t{j}", f, H, out_ch, (Channel("a.z", "force", "z"),))
        recs.append(TestRecord(f"t{j}", frf, np.zeros((1, 0)), np.zeros((1, 0)), 200.0, {}))
    other = FRFData("other", f, G, out_ch, (Channel("c.z", "force", "z"),))
    recs.insert(1, TestRecord("other", other, np.zeros((1, 0)), np.zeros((1, 0)), 200.0, {}))
    plan = SimpleNamespace(tests=[SimpleNamespace(name=r.name, band_hz=(10.0, 90.0))
                                  for r in recs],
                           spec=SimpleNamespace(uncertainty=SimpleNamespace(k_sigma=3.0)))
    return plan, recs, G


def test_band_over_comparable_tests_scores_the_models():
    plan, recs, G = _records(6)
    models = [1.5 * G[1:] if r.name != "other" else G[1:] for r in recs]
    fb = frf_band(plan, recs, models, [G[1:]] * len(recs))
    assert fb.tests == ("t0", "t1", "t2", "t3", "t4", "t5")  # not "other" (another input)
    f = fb.band.freq_hz
    assert f[0] == 10.0 and f[-1] == 90.0 and fb.line_mask.sum() == 81  # excited band only
    # mean and covariance of (Re, Im) at one line, straight from numpy
    line = np.flatnonzero(recs[0].freq_hz == 40.0)[0]
    h = np.array([r.H[line, 0, 0] for r in recs if r.name != "other"])
    k = np.flatnonzero(f == 40.0)[0]
    assert fb.band.mean[k, 0, 0] == pytest.approx(h.mean(), rel=1e-12)
    np.testing.assert_allclose(fb.band.cov[k, 0, 0], np.cov(h.real, h.imag), rtol=1e-10)
    assert fb.inside["updated"] > 0.95 and fb.inside["initial"] < 0.2
    # the model at the band's lines is the model FRF at 10 .. 90 Hz
    trial = TrialResult(0, tuple(recs), {}, H_initial=tuple(models))
    np.testing.assert_array_equal(fb.model(trial, "initial"), 1.5 * G[10:91])
    assert fb.model(trial, "updated") is None
    df = fb.to_pandas()
    assert len(df) == 81 and set(df["output"]) == {"b.z.dis"}


def test_fewer_than_three_comparable_tests_give_no_band():
    plan, recs, _ = _records(2)
    assert frf_band(plan, recs) is None
    trial = TrialResult(0, tuple(recs), {}, seconds={"bound": 1.0})
    assert with_frf_band(plan, trial) is trial


def test_stage_adds_its_time_and_skips_failed_trials():
    plan, recs, _ = _records(3)
    trial = TrialResult(0, tuple(recs), {}, seconds={"bound": 1.0})
    out = with_frf_band(plan, trial)
    assert out.frf_band.tests == ("t0", "t1", "t2") and out.frf_band.inside == {}
    assert out.seconds["bound"] > 1.0 and trial.seconds["bound"] == 1.0  # input untouched
    failed = TrialResult(0, tuple(recs), {}, error="RuntimeError: x")
    assert with_frf_band(plan, failed) is failed


def test_runner_computes_the_band_in_every_trial(small_dict):
    from truthbench.campaign.runner import run_campaign
    from truthbench.campaign.spec import parse_campaign

    small_dict["update"]["method"] = "none"
    small_dict["identify"] = {"enabled": False}
    small_dict["tests"].append({**small_dict["tests"][0], "name": "third", "level_rms": 4.0})
    result = run_campaign(parse_campaign(small_dict), trials=2)
    assert all(tr.frf_band is None for tr in result.trials)  # only two share an input
    small_dict["tests"].append({**small_dict["tests"][0], "name": "fourth", "level_rms": 3.0})
    result = run_campaign(parse_campaign(small_dict), trials=2)
    for tr in result.trials:
        fb = tr.frf_band
        assert fb.tests == ("shaker_end", "third", "fourth")
        H = np.array([tr.test(n).H[fb.line_mask] for n in fb.tests])
        np.testing.assert_allclose(fb.band.mean, H.mean(axis=0), rtol=1e-12)
