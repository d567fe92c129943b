"""Layout scoring: a campaign re-sensored at model DOFs, scored by Monte Carlo."""

import tomllib
from pathlib import Path

import numpy as np
import pytest

from truthbench.campaign.placement_stage import (
    campaign_dof_labels,
    layout_spec,
    score_layouts,
)
from truthbench.campaign.runner import run_campaign
from truthbench.campaign.spec import parse_campaign

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture
def small_spec():
    d = tomllib.loads((ROOT / "campaigns" / "quickstart.toml").read_text())
    d["plant"]["n_elements"] = 8
    d["sensors"] = [s for s in d["sensors"] if s["station"] != "quarter"]
    for t in d["tests"]:
        t.update(record_s=4.0, averages=4)
        t["actuators"] = [{"station": "end_a", "direction": "z"}]
    d["tests"][1]["actuators"] = [{"station": "end_b", "direction": "z"}]
    return parse_campaign(d)


@pytest.mark.slow
def test_the_campaigns_own_layout_reproduces_the_campaign(small_spec):
    labels = campaign_dof_labels(small_spec)
    assert labels == ["n0.z", "n4.z", "n8.z"]
    same = layout_spec(small_spec, labels, "own")
    a = run_campaign(small_spec, trials=2)
    b = run_campaign(same, trials=2)
    for ta, tb in zip(a.trials, b.trials, strict=True):
        np.testing.assert_array_equal(ta.tests[0].H, tb.tests[0].H)
        np.testing.assert_array_equal(ta.update.values, tb.update.values)
    table = score_layouts(small_spec, {"own": labels, "ends": ["n0.z", "n8.z", "n7.z"]},
                          trials=2)
    assert list(table["layout"]) == ["own", "ends"] and (table["failed trials"] == 0).all()
    err = np.array([100 * (t.update.as_dict()["E_pa"] / t.truth["E_pa"] - 1)
                    for t in a.trials])
    assert table["E_pa RMS error [%]"][0] == pytest.approx(np.sqrt(np.mean(err**2)),
                                                           rel=1e-12)
    assert table["E_pa RMS error [%]"][1] != table["E_pa RMS error [%]"][0]


@pytest.mark.parametrize("label, match", [("n9.z", "node 9 does not exist"),
                                          ("q3.z", "expected 'n<node>"),
                                          ("n3.rx", "expected 'n<node>")])
def test_bad_layout_labels(small_spec, label, match):
    with pytest.raises(ValueError, match=match):
        layout_spec(small_spec, [label])
