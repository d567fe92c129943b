"""A small free-free campaign for effect tests."""

import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture
def base():
    d = tomllib.loads((ROOT / "campaigns" / "quickstart.toml").read_text())
    d["plant"]["n_elements"] = 8
    d["truth"]["relative"] = {}
    d["sensors"] = [{"station": "end_a", "direction": "z"}, {"station": "mid", "direction": "z"},
                    {"station": "end_b", "direction": "z"}]
    for t in d["tests"]:
        t.update(record_s=8.0, averages=4, oversample=4, noise_fraction=0.0)
    d["tests"][1]["actuators"] = [{"station": "end_b", "direction": "z"}]
    d["update"]["method"] = "none"
    return d


@pytest.fixture
def hub_base():
    d = tomllib.loads((ROOT / "campaigns" / "hub_beam.toml").read_text())
    d["plant"]["n_elements"] = 8
    d["truth"]["relative"] = {}
    for t in d["tests"]:
        t.update(record_s=16.0, averages=1, window="rectangular", noise_fraction=0.0)
    d["update"]["method"] = "none"
    return d
