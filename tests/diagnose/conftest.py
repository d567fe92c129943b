"""Small campaigns for diagnosis tests: the quickstart tube with short records."""

import tomllib
from pathlib import Path

import pytest

from truthbench.campaign.runner import simulate_one
from truthbench.campaign.spec import parse_campaign
from truthbench.effects import effect_from_inject

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def tube():
    """The quickstart with 8 s records of 4 averages (0.5 Hz lines, 2-400 Hz)."""
    d = tomllib.loads((ROOT / "campaigns" / "quickstart.toml").read_text())
    for t in d["tests"]:
        t.update(record_s=8.0, averages=4)
    return parse_campaign(d)


def measured(spec, *inject):
    """Every test of trial 0 with the injected effects, as FRFData."""
    extra = [effect_from_inject(text) for text in inject]
    return [simulate_one(spec, 0, j, None, extra).frf for j in range(len(spec.tests))]
