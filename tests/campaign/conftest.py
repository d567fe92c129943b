"""Shared campaign fixtures: the shipped quickstart and a small fast variant."""

import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
QUICKSTART = ROOT / "campaigns" / "quickstart.toml"


@pytest.fixture
def quickstart_dict():
    return tomllib.loads(QUICKSTART.read_text())


def full_dict() -> dict:
    """The small quickstart with four tests (three share an input: an FRF band; the
    fourth is held out) and both updaters: every part of a trial."""
    d = tomllib.loads(QUICKSTART.read_text())
    _shorten(d)
    d["tests"] += [{**d["tests"][0], "name": "third", "level_rms": 4.0},
                   {**d["tests"][0], "name": "fourth", "level_rms": 3.0}]
    d["update"]["method"] = ["finite_difference", "sensitivity"]
    d["uncertainty"] = {"holdout": ["fourth"]}
    return d


@pytest.fixture
def small_dict(quickstart_dict):
    """The quickstart with short records: for plumbing tests, not accuracy."""
    return _shorten(quickstart_dict)


def _shorten(d: dict) -> dict:
    d["plant"]["n_elements"] = 8
    d["sensors"] = [s for s in d["sensors"] if s["station"] != "quarter"]
    for t in d["tests"]:
        t.update(record_s=4.0, averages=4, oversample=2)
        if t["actuators"][0]["station"] == "quarter":
            t["actuators"] = [{"station": "end_b", "direction": "z"}]
    return d
