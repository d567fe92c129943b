"""Trial summaries: exact through JSON and the store, the tables of a loaded result made
from them alone (no trial read), older files without them, and a report that reads only
the trials its figures show."""

import warnings

import h5py
import numpy as np
import pandas as pd
import pytest

from truthbench.campaign.results import CampaignResult, StoredTrials
from truthbench.campaign.runner import run_campaign
from truthbench.campaign.spec import parse_campaign
from truthbench.campaign.summary import TrialSummary, trial_summary
from truthbench.campaign.tables import TABLES

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def result():
    """Three trials of the small campaign with every part a summary holds."""
    from .conftest import full_dict

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the sensitivity method on noisy 4 s records
        return run_campaign(parse_campaign(full_dict()), trials=3)


def _same(a, b, where=""):
    if isinstance(a, dict):
        assert list(a) == list(b), where
        for k in a:
            _same(a[k], b[k], f"{where}[{k!r}]")
    elif isinstance(a, tuple | list) and not (a and isinstance(a[0], float)):
        assert len(a) == len(b), where
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            _same(x, y, f"{where}[{i}]")
    elif hasattr(a, "__dataclass_fields__"):
        for k in a.__dataclass_fields__:
            _same(getattr(a, k), getattr(b, k), f"{where}.{k}")
    elif a is None or isinstance(a, str | bool):
        assert a == b, where
    else:
        x, y = np.asarray(a), np.asarray(b)
        assert x.dtype.kind == y.dtype.kind and x.shape == y.shape, where
        np.testing.assert_array_equal(x, y, err_msg=where)


def test_a_summary_is_exact_through_json(result):
    assert all(tr.error is None and tr.uncertainty is not None and tr.frf_band is not None
               for tr in result.trials)
    for tr in result.trials:
        s = trial_summary(result.spec, tr)
        assert [t.name for t in s.tests] == [r.name for r in tr.tests]
        assert s.updated and set(s.updates) == {"finite_difference", "sensitivity"}
        back = TrialSummary.from_json(s.to_json(), s.seconds)
        _same(back, s, f"trial {tr.trial}")
        assert "simulate" not in s.to_json()  # the timings stay out of it


def test_a_loaded_result_tabulates_from_summaries_without_reading_a_trial(
        result, tmp_path, monkeypatch):
    loaded = CampaignResult.load(result.save(tmp_path / "r.h5"))
    assert isinstance(loaded.trials, StoredTrials) and len(loaded.trials) == 3

    def no_reading(self, i):
        raise AssertionError(f"trial {i} read whole")

    monkeypatch.setattr(StoredTrials, "__getitem__", no_reading)
    for name in TABLES:
        if name not in ("methods", "uncertainty"):
            pd.testing.assert_frame_equal(loaded.to_pandas(name), result.to_pandas(name))
        pd.testing.assert_frame_equal(loaded.summary(name), result.summary(name))
    assert loaded.stage_seconds == pytest.approx(result.stage_seconds)
    a, b = loaded.coverage(), result.coverage()
    assert (a.holdout.n_inside, a.holdout.n_total) == (b.holdout.n_inside, b.holdout.n_total)
    assert loaded.failed == ()


def test_files_without_summaries_are_summarised_from_their_trials(result, tmp_path):
    path = result.save(tmp_path / "old.h5")
    with h5py.File(path, "a") as f:
        for g in f["trials"].values():
            del g["summary"]
    old = CampaignResult.load(path)
    for name in ("parameters", "modes", "coverage", "frf_error", "tests"):
        pd.testing.assert_frame_equal(old.to_pandas(name), result.to_pandas(name))


def test_the_report_reads_only_the_trials_its_figures_show(result, tmp_path, monkeypatch):
    from truthbench.report.accuracy import write_report

    loaded = CampaignResult.load(result.save(tmp_path / "r.h5"))
    read = []
    real = StoredTrials.__getitem__

    def counting(self, i):
        read.append(i)
        return real(self, i)

    monkeypatch.setattr(StoredTrials, "__getitem__", counting)
    write_report(loaded, tmp_path / "report")
    assert set(read) == {0}  # the first trial shows every figure
    assert (tmp_path / "report" / "report.html").exists()


def test_frfs_of_trial_0_only_keep_every_table(result, tmp_path):
    """``[output] frfs = "first_trial"``: trial 1 is stored with its summary and modes but
    no FRF line, model FRF or band; the tables equal those of the whole run, and the
    report says where its figures come from."""
    from .conftest import full_dict

    d = full_dict()
    d["output"] = {"frfs": "first_trial"}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        lean = run_campaign(parse_campaign(d), trials=2)
    whole, cut = lean.trials
    assert whole.tests[0].freq_hz.size and whole.frf_band is not None
    assert [r.freq_hz.size for r in cut.tests] == [0] * 4 and cut.frf_band is None
    assert cut.tests[0].modes is not None and cut.update is not None
    loaded = CampaignResult.load(lean.save(tmp_path / "lean.h5"))
    full = CampaignResult(result.spec, result.seed, result.version, result.nominal,
                          result.trials[:2])
    for name in ("parameters", "modes", "coverage", "frf_error", "tests", "frf_band"):
        pd.testing.assert_frame_equal(loaded.to_pandas(name), full.to_pandas(name))
    lean_bytes = _stored_bytes(tmp_path / "lean.h5", "0001")
    assert lean_bytes < _stored_bytes(full.save(tmp_path / "full.h5"), "0001") / 20


def _stored_bytes(path, key) -> int:
    """Bytes of the datasets of trial ``key`` of a results file."""
    total = []
    with h5py.File(path, "r") as f:
        f[f"trials/{key}"].visititems(lambda _, o: total.append(
            o.id.get_storage_size()) if isinstance(o, h5py.Dataset) else None)
    return sum(total)
