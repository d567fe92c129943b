"""HDF5 results: the typed round trip of what the runner produced, units, the raw
layout, older files, single-test files, corrupt files."""

import json

import h5py
import numpy as np
import pytest

from truthbench import __version__
from truthbench.campaign.results import CampaignResult
from truthbench.campaign.runner import run_campaign
from truthbench.campaign.spec import parse_campaign
from truthbench.campaign.store import write_results, write_test_record
from truthbench.errors import DataFormatError
from truthbench.io.hdf5 import read_results


@pytest.fixture(scope="module")
def full_result():
    """Two trials of a small campaign with both updaters, four tests (three share an
    input: an FRF band), one held out: every part the store writes."""
    from .conftest import full_dict

    with pytest.warns(UserWarning):  # the sensitivity method on noisy 4 s records
        return run_campaign(parse_campaign(full_dict()), trials=2)


def _same(a, b, where):
    """Exact equality of arrays, dicts, tuples and scalars, recursively."""
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        assert np.asarray(a).dtype.kind == np.asarray(b).dtype.kind, where
        np.testing.assert_array_equal(a, b, err_msg=where, strict=True)
    elif isinstance(a, dict):
        assert set(a) == set(b), where
        for k in a:
            _same(a[k], b[k], f"{where}[{k!r}]")
    elif isinstance(a, tuple | list):
        assert len(a) == len(b), where
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            _same(x, y, f"{where}[{i}]")
    else:
        assert a == b and type(a) is type(b) or (a == b and np.isscalar(a)), where


def _fields(obj, names, where, other):
    for n in names:
        _same(getattr(obj, n), getattr(other, n), f"{where}.{n}")


def test_load_gives_back_the_typed_result(full_result, tmp_path):
    from truthbench.campaign.frf_band_stage import FrfBandStage
    from truthbench.update.finite_difference import UpdateResult

    res = full_result
    loaded = CampaignResult.load(res.save(tmp_path / "r.h5"))
    assert loaded.spec == res.spec and loaded.seed == res.seed
    assert loaded.version == __version__ and loaded.path == str(tmp_path / "r.h5")
    _same(loaded.nominal, res.nominal, "nominal")
    assert len(loaded.trials) == 2
    for a, b in zip(res.trials, loaded.trials, strict=True):
        w = f"trial {a.trial}"
        assert b.trial == a.trial and b.error is None
        _same(b.truth, a.truth, w + ".truth")
        assert b.seconds == pytest.approx(a.seconds)
        assert [r.name for r in b.tests] == [r.name for r in a.tests]
        for ra, rb in zip(a.tests, b.tests, strict=True):
            v = f"{w} test {ra.name}"
            _fields(rb, ("u", "y", "fs_hz", "parameters"), v, ra)
            _fields(rb.frf, ("name", "freq_hz", "H", "coherence", "outputs", "inputs",
                             "n_averages", "band_hz", "excitation", "window_decay_rad_s",
                             "notes"), v + ".frf", ra.frf)
            _fields(rb.modes, ("freq_hz", "damping_ratio", "shapes", "participation",
                               "output_labels"), v + ".modes", ra.modes)
        assert type(b.update) is UpdateResult
        upd = ("names", "initial", "values", "history", "cost_history", "singular_values",
               "condition_number", "correlation", "converged", "method")
        _fields(b.update, upd, w + ".update", a.update)
        assert list(b.comparison) == ["finite_difference", "sensitivity"]
        for m in a.comparison:
            _fields(b.comparison[m], upd, f"{w}.comparison[{m}]", a.comparison[m])
        assert list(b.accuracy) == ["initial", "finite_difference", "sensitivity", "updated"]
        _same(b.accuracy, a.accuracy, w + ".accuracy")
        _fields(b, ("H_initial", "H_updated", "update_mask"), w, a)
        _fields(b.uncertainty, ("names", "theta_0", "theta_tests", "theta_truth", "mean",
                                "std", "bound", "inside", "mode_index", "holdout",
                                "theta_updated"), w + ".uncertainty", a.uncertainty)
        assert isinstance(b.frf_band, FrfBandStage)
        _fields(b.frf_band, ("tests", "line_mask", "inside", "output_labels",
                             "input_labels"), w + ".frf_band", a.frf_band)
        _fields(b.frf_band.band, ("mean", "cov", "n_tests", "k_sigma", "freq_hz"),
                w + ".frf_band.band", a.frf_band.band)
    # what a person looks at is the same from memory and from the file
    for name in ("parameters", "modes", "coverage", "frf_error", "frf_band", "tests"):
        assert loaded.to_pandas(name).equals(res.to_pandas(name)), name


def test_every_numeric_dataset_has_a_unit(full_result, tmp_path):
    path = full_result.save(tmp_path / "r.h5")
    missing = []
    with h5py.File(path) as f:
        f.visititems(lambda name, obj: missing.append(name) if isinstance(obj, h5py.Dataset)
                     and obj.dtype.kind in "biufc" and "unit" not in obj.attrs else None)
        t = f["trials/0000/tests/shaker_end"]
        # accelerometers over a force: (m/s^2)/N, written out by hand
        assert t["H"].attrs["unit"] == "m/s^2/N" and t["freq_hz"].attrs["unit"] == "Hz"
        assert t["u"].attrs["unit"] == "N" and t["y"].attrs["unit"] == "m/s^2"
        assert t["coherence"].attrs["unit"] == "-"
        assert t["channels/outputs/coordinates_m"].attrs["unit"] == "m"
        assert list(f["trials/0000/update/values"].attrs["unit"]) == ["Pa", "kg/m^3"]
        acc = f["trials/0000/accuracy/initial"]
        assert acc["freq_error_pct"].attrs["unit"] == "%"
        assert acc["truth_freq_hz"].attrs["unit"] == "Hz"
        u = f["trials/0000/uncertainty"]
        assert list(u["bound"].attrs["unit"]) == ["Hz"] * 3 + ["-"] * 3
        assert f["trials/0000/frf_band/cov"].attrs["unit"] == "(m/s^2/N)^2"
    assert missing == []


def test_mixed_channel_units_are_stored_per_pair(tmp_path):
    from truthbench.campaign.results import TestRecord
    from truthbench.measure.frfdata import Channel, FRFData

    outs = (Channel("hub.rz.vel", "velocity", "rz"), Channel("tip.y.acc", "acceleration", "y"))
    ins = (Channel("hub.rz", "force", "rz"),)
    frf = FRFData("t", np.arange(3.0), np.ones((3, 2, 1)), outs, ins)
    rec = TestRecord("t", frf, np.zeros((1, 4)), np.zeros((2, 4)), 10.0, {})
    from types import SimpleNamespace

    spec = SimpleNamespace(campaign=SimpleNamespace(name="x"), to_toml_dict=dict, source="s")
    path = write_test_record(rec, tmp_path / "t.h5", spec=spec, seed=1, trial=0)
    with h5py.File(path) as f:
        t = f["tests/t"]
        assert t["H"].attrs["unit"].tolist() == [["rad/s/(N m)"], ["m/s^2/(N m)"]]
        assert t["y"].attrs["unit"].tolist() == ["rad/s", "m/s^2"]
        assert t["u"].attrs["unit"] == "N m"


def test_raw_layout_is_unchanged(small_dict, tmp_path):
    spec = parse_campaign(small_dict)
    result = run_campaign(spec)
    path = write_results(result, tmp_path / "r" / "results.h5")
    data = read_results(path)
    a = data["attrs"]
    assert a["truthbench_version"] == __version__ and a["seed"] == spec.campaign.seed
    assert a["spec"]["campaign"]["name"] == "quickstart"
    tr = result.trials[0]
    g = data["trials"]["0000"]
    assert g["attrs"]["status"] == "ok"
    for rec in tr.tests:
        t = g["tests"][rec.name]
        np.testing.assert_array_equal(t["H"], rec.H)
        np.testing.assert_array_equal(t["y"], rec.y)
        assert t["parameters"]["attrs"]["E_pa"] == rec.parameters["E_pa"]
        assert t["attrs"]["output_labels"] == list(rec.output_labels)
    np.testing.assert_array_equal(g["update"]["history"], tr.update.history)
    assert g["truth"]["attrs"]["rho_kg_m3"] == tr.truth["rho_kg_m3"]


def test_older_files_without_channels_load_from_the_spec(small_dict, tmp_path):
    """A file written before channels, FRF metadata and units were stored."""
    result = run_campaign(parse_campaign(small_dict))
    path = result.save(tmp_path / "old.h5")
    with h5py.File(path, "a") as f:
        for t in f["trials/0000/tests"].values():
            del t["channels"]
            for k in list(t["H"].attrs):
                del t["H"].attrs[k]
    loaded = CampaignResult.load(path)
    for ra, rb in zip(result.trials[0].tests, loaded.trials[0].tests, strict=True):
        for ca, cb in zip(ra.frf.outputs + ra.frf.inputs, rb.frf.outputs + rb.frf.inputs,
                          strict=True):
            assert (cb.label, cb.quantity, cb.direction, cb.station) == \
                (ca.label, ca.quantity, ca.direction, ca.station)
            assert cb.coordinates_m is None  # not in the spec
        assert rb.frf.band_hz == tuple(t.band_hz for t in result.spec.tests
                                       if t.name == ra.name)[0]
        np.testing.assert_array_equal(rb.H, ra.H)
    # the io reader alone has no campaign to take them from: it says what is missing
    from truthbench.io import load_frf

    with pytest.raises(DataFormatError, match=r"old.h5: /trials/0000/tests/\w+: no stored "
                                              r"channels \(a file written before"):
        load_frf(path)


def test_failed_trial_is_written_and_loaded_with_its_data(small_dict, tmp_path):
    small_dict["update"]["parameters"] = ["E_pa", "rho_kg_m3", "t_m"]
    result = run_campaign(parse_campaign(small_dict))
    path = write_results(result, tmp_path / "results.h5")
    data = read_results(path)
    g = data["trials"]["0000"]
    assert g["attrs"]["status"] == "failed" and "IdentifiabilityError" in g["attrs"]["error"]
    assert set(g["tests"]) - {"attrs"} == {t.name for t in result.trials[0].tests}
    loaded = CampaignResult.load(path)
    assert loaded.trials[0].error == result.trials[0].error
    assert loaded.failed == (loaded.trials[0],) and loaded.trials[0].update is None


def test_single_test_file_loads_as_one_trial(small_dict, tmp_path):
    from truthbench.campaign.runner import simulate_one

    spec = parse_campaign(small_dict)
    rec = simulate_one(spec, 3, 1)
    path = write_test_record(rec, tmp_path / "one.h5", spec=spec, seed=7, trial=3,
                             injected=["time_delay:delay_s=0.002"])
    loaded = CampaignResult.load(path)
    assert loaded.seed == 7 and loaded.injected == ("time_delay:delay_s=0.002",)
    (trial,) = loaded.trials
    assert trial.trial == 3 and trial.truth == {} and trial.update is None
    (got,) = trial.tests
    assert got.name == rec.name and got.parameters == rec.parameters
    for name in ("H", "coherence", "freq_hz"):
        np.testing.assert_array_equal(getattr(got, name), getattr(rec, name), strict=True)
    np.testing.assert_array_equal(got.y, rec.y, strict=True)
    assert got.frf.outputs == rec.frf.outputs and got.frf.inputs == rec.frf.inputs


def test_corrupt_or_foreign_files(tmp_path, full_result):
    junk = tmp_path / "junk.h5"
    junk.write_bytes(b"not hdf5 at all")
    for read in (read_results, CampaignResult.load):
        with pytest.raises(DataFormatError, match="junk.h5: cannot be read as HDF5"):
            read(junk)
        with h5py.File(tmp_path / "other.h5", "w") as f:
            f.attrs["format"] = "something-else"
        with pytest.raises(DataFormatError, match=r"other.h5: not a truthbench results "
                                                  r"file .*'something-else'"):
            read(tmp_path / "other.h5")
        with pytest.raises(DataFormatError, match="missing.h5: results file not found"):
            read(tmp_path / "missing.h5")
    path = full_result.save(tmp_path / "bad_spec.h5")
    with h5py.File(path, "a") as f:
        f.attrs["spec_json"] = json.dumps({"campaign": {"name": "x"}})
    with pytest.raises(DataFormatError, match=r"bad_spec.h5: attribute 'spec_json' is not "
                                              r"a valid campaign"):
        CampaignResult.load(path)
    path = full_result.save(tmp_path / "cut.h5")
    with h5py.File(path, "a") as f:
        del f["trials/0001/update/values"]
    cut = CampaignResult.load(path)  # trials are read when used
    assert cut.trials[0].update is not None
    with pytest.raises(DataFormatError, match=r"cut.h5: /trials/0001: KeyError"):
        cut.trials[1]


def test_accuracy_against_truth_is_stored_and_improves(small_dict, tmp_path):
    for t in small_dict["tests"]:
        t["noise_fraction"] = 0.0
    result = run_campaign(parse_campaign(small_dict))
    acc = CampaignResult.load(result.save(tmp_path / "r.h5")).trials[0].accuracy
    before = np.abs(acc["initial"]["freq_error_pct"])
    after = np.abs(acc["updated"]["freq_error_pct"])
    assert before.size and np.all(after < 0.1 * before)
    assert np.all(acc["updated"]["mac"] > 0.99)


@pytest.mark.slow
def test_methods_side_by_side_and_uncertainty_stage(small_dict, tmp_path):
    """Both updaters run on the same data; the uncertainty stage bounds the identified
    poles and records whether each test's true poles lie inside."""
    small_dict["update"]["method"] = ["finite_difference", "sensitivity"]
    # E alone: with shapes scaled to the model (no collocated mass scaling), modal data
    # separate E from rho only through the soft suspension (see the update tests)
    small_dict["update"]["parameters"] = ["E_pa"]
    small_dict["truth"]["relative"] = {"E_pa": 0.04}
    for t in small_dict["tests"]:  # shapes identified from 4 s records need clean data
        t.update(noise_fraction=0.0, record_s=8.0)
    small_dict["truth"]["effects"] = [{"name": "parameter", "parameter": "modal_damping_ratio",
                                       "scope": "test",
                                       "parameters": {"rel": {"mean": 0.0, "std": 0.1}}}]
    small_dict["tests"].append({**small_dict["tests"][0], "name": "third", "level_rms": 4.0})
    result = run_campaign(parse_campaign(small_dict))
    tr = result.trials[0]
    assert tr.error is None and set(tr.comparison) == {"finite_difference", "sensitivity"}
    loaded = CampaignResult.load(result.save(tmp_path / "r.h5"))
    comp = loaded.summary("methods")
    assert list(comp["method"]) == ["none", "finite_difference", "sensitivity"]
    rms = comp["parameter_rms_error_pct"]
    assert (rms.iloc[1:] < rms.iloc[0]).all()
    table = loaded.summary("uncertainty")
    cov = loaded.coverage()
    assert len(table) == len(tr.uncertainty.names)
    assert cov.in_sample.n_total == tr.uncertainty.inside.size and cov.holdout is None
    assert tr.uncertainty.theta_tests.shape[0] == 3


def test_one_failed_trial_does_not_lose_the_others(small_dict, tmp_path, monkeypatch):
    """A trial whose simulation raises is recorded as failed; the other trials finish,
    and all three are written."""
    import truthbench.campaign.trial as trial_mod

    calls = {"n": 0}
    real = trial_mod.simulate_test

    def flaky(test, setup, rng):
        calls["n"] += 1
        if calls["n"] == 3:  # trial 1, test 0 (trials run in order with one worker)
            raise RuntimeError("shaker amplifier tripped")
        return real(test, setup, rng)

    monkeypatch.setattr(trial_mod, "simulate_test", flaky)
    small_dict["update"]["method"] = "none"
    result = run_campaign(parse_campaign(small_dict), trials=3)
    errors = [t.error for t in result.trials]
    assert errors[0] is None and errors[2] is None
    assert "RuntimeError: shaker amplifier tripped" in errors[1]
    assert len(result.trials[0].tests) == len(result.trials[2].tests) == 2
    data = read_results(write_results(result, tmp_path / "r.h5"))
    status = [data["trials"][k]["attrs"]["status"] for k in ("0000", "0001", "0002")]
    assert status == ["ok", "failed", "ok"]
