"""HDF5 results: round trip of what the runner produced; corrupt files."""

import numpy as np
import pytest

from truthbench import __version__
from truthbench.campaign.runner import run_campaign
from truthbench.campaign.spec import parse_campaign
from truthbench.campaign.store import read_results, write_results
from truthbench.errors import DataFormatError


def test_round_trip(small_dict, tmp_path):
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


def test_failed_trial_is_written_with_its_data(small_dict, tmp_path):
    small_dict["update"]["parameters"] = ["E_pa", "rho_kg_m3", "t_m"]
    result = run_campaign(parse_campaign(small_dict))
    data = read_results(write_results(result, tmp_path / "results.h5"))
    g = data["trials"]["0000"]
    assert g["attrs"]["status"] == "failed" and "IdentifiabilityError" in g["attrs"]["error"]
    assert set(g["tests"]) - {"attrs"} == {t.name for t in result.trials[0].tests}


def test_corrupt_or_foreign_files(tmp_path):
    junk = tmp_path / "junk.h5"
    junk.write_bytes(b"not hdf5 at all")
    with pytest.raises(DataFormatError, match="junk.h5: cannot be read as HDF5"):
        read_results(junk)
    import h5py

    with h5py.File(tmp_path / "other.h5", "w") as f:
        f.attrs["format"] = "something-else"
    with pytest.raises(DataFormatError, match="not a truthbench results file"):
        read_results(tmp_path / "other.h5")
    with pytest.raises(DataFormatError, match="not found"):
        read_results(tmp_path / "missing.h5")


def test_accuracy_against_truth_is_stored_and_improves(small_dict, tmp_path):
    for t in small_dict["tests"]:
        t["noise_fraction"] = 0.0
    result = run_campaign(parse_campaign(small_dict))
    data = read_results(write_results(result, tmp_path / "r.h5"))
    acc = data["trials"]["0000"]["accuracy"]
    before = np.abs(acc["initial"]["freq_error_pct"])
    after = np.abs(acc["updated"]["freq_error_pct"])
    assert before.size and np.all(after < 0.1 * before)
    assert np.all(acc["updated"]["mac"] > 0.99)


@pytest.mark.slow
def test_methods_side_by_side_and_uncertainty_stage(small_dict, tmp_path):
    """Both updaters run on the same data; the uncertainty stage bounds the identified
    poles and records whether each test's true poles lie inside."""
    from truthbench.report.accuracy import method_comparison_table, uncertainty_table
    from truthbench.report.coverage import coverage_summary

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
    data = read_results(write_results(result, tmp_path / "r.h5"))
    comp = method_comparison_table(data)
    assert list(comp["method"]) == ["none", "finite_difference", "sensitivity"]
    rms = comp["parameter RMS error [%]"]
    assert (rms.iloc[1:] < rms.iloc[0]).all()
    table = uncertainty_table(data)
    cov = coverage_summary(data)
    assert len(table) == len(tr.uncertainty.names)
    assert cov.in_sample.n_total == tr.uncertainty.inside.size and cov.holdout is None
    assert tr.uncertainty.theta_tests.shape[0] == 3


def test_one_failed_trial_does_not_lose_the_others(small_dict, tmp_path, monkeypatch):
    """A trial whose simulation raises is recorded as failed; the other trials finish,
    and all three are written."""
    import truthbench.campaign.runner as runner

    calls = {"n": 0}
    real = runner.simulate_test

    def flaky(spec, j, setup, rng):
        calls["n"] += 1
        if calls["n"] == 3:  # trial 1, test 0 (trials run in order with one worker)
            raise RuntimeError("shaker amplifier tripped")
        return real(spec, j, setup, rng)

    monkeypatch.setattr(runner, "simulate_test", flaky)
    small_dict["update"]["method"] = "none"
    result = run_campaign(parse_campaign(small_dict), trials=3)
    errors = [t.error for t in result.trials]
    assert errors[0] is None and errors[2] is None
    assert "RuntimeError: shaker amplifier tripped" in errors[1]
    assert len(result.trials[0].tests) == len(result.trials[2].tests) == 2
    data = read_results(write_results(result, tmp_path / "r.h5"))
    status = [data["trials"][k]["attrs"]["status"] for k in ("0000", "0001", "0002")]
    assert status == ["ok", "failed", "ok"]
