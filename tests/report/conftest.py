"""A small campaign with every report section: two trials, four tests (three share an
input: an FRF band; one held out: calibration), both updaters."""

import tomllib
import warnings
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def report_result():
    from truthbench.campaign.runner import run_campaign
    from truthbench.campaign.spec import parse_campaign

    d = tomllib.loads((ROOT / "campaigns" / "quickstart.toml").read_text())
    d["plant"]["n_elements"] = 8
    d["sensors"] = [s for s in d["sensors"] if s["station"] != "quarter"]
    for t in d["tests"]:
        t.update(record_s=4.0, averages=4, oversample=2)
        if t["actuators"][0]["station"] == "quarter":
            t["actuators"] = [{"station": "end_b", "direction": "z"}]
    d["tests"] += [{**d["tests"][0], "name": "third", "level_rms": 4.0},
                   {**d["tests"][0], "name": "fourth | bar", "level_rms": 3.0}]
    d["update"]["method"] = ["finite_difference", "sensitivity"]
    d["uncertainty"] = {"holdout": ["fourth | bar"]}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the sensitivity method on noisy 4 s records
        return run_campaign(parse_campaign(d, source="small.toml"), trials=2)


@pytest.fixture(scope="session")
def report_dir(report_result, tmp_path_factory):
    from truthbench.report.accuracy import write_report

    out = tmp_path_factory.mktemp("report")
    write_report(report_result, out, results_path=out / "results.h5")
    return out


@pytest.fixture
def small_dict():
    """The quickstart with short records (as tests/campaign/conftest.py)."""
    d = tomllib.loads((ROOT / "campaigns" / "quickstart.toml").read_text())
    d["plant"]["n_elements"] = 8
    d["sensors"] = [s for s in d["sensors"] if s["station"] != "quarter"]
    for t in d["tests"]:
        t.update(record_s=4.0, averages=4, oversample=2)
        if t["actuators"][0]["station"] == "quarter":
            t["actuators"] = [{"station": "end_b", "direction": "z"}]
    return d
