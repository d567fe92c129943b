"""The campaign plan: what it works out once is what the stages then see."""

import numpy as np
import pytest

from truthbench.campaign.plan import CampaignPlan, band_overlap, lines_in
from truthbench.campaign.spec import parse_campaign


def test_the_plan_of_a_test_is_its_record_lines_and_bands(small_dict):
    small_dict["update"]["band_hz"] = [10.0, 300.0]
    small_dict["tests"][1]["band_hz"] = [50.0, 400.0]
    small_dict["tests"][1]["effects"] = [{"name": "added_mass", "station": "mid",
                                          "parameters": {"mass_kg": 0.01}}]
    small_dict["truth"]["effects"] = [{"name": "material", "parameters": {"E_rel": 0.01}}]
    plan = CampaignPlan.compile(parse_campaign(small_dict))
    a, b = plan.tests
    assert (a.index, b.index) == (0, 1) and a.name == "shaker_end"
    assert (a.samples, a.segment) == (4 * 1024, 1024)  # 4 s at 1024 Hz, 4 averages
    assert a.update_band_hz == (10.0, 300.0) and b.update_band_hz == (50.0, 300.0)
    assert b.band_hz == (50.0, 400.0)
    # lines: multiples of 1 Hz up to Nyquist; the update's: 10..300 Hz, 50..300 Hz
    np.testing.assert_array_equal(a.freq_hz, np.arange(513.0))
    assert a.update_lines().sum() == 291 and b.update_lines().sum() == 251
    # stream keys: the campaign's effects 0, 1, ..; test j's own 1000 + 100 j + n
    assert [k for k, _ in a.effects] == [0] and [k for k, _ in b.effects] == [0, 1100]
    assert [e.name for _, e in b.effects] == ["material", "added_mass"]
    # channels at the stations of the nominal beam
    plant = plan.plant
    xyz = plant.node_coordinates_m(plan.nominal)
    for ch, s in zip(a.outputs, a.sensors, strict=True):
        assert ch.label == s.label and ch.quantity == s.quantity
        assert ch.coordinates_m == tuple(xyz[plant.station_node(s.station)])
    assert [c.quantity for c in a.inputs] == ["force"]
    assert plan.n_pairs == 2 * 3
    assert plan.truth["E_pa"] == pytest.approx(1.04 * plan.nominal["E_pa"], rel=1e-15)
    assert plan.analysis_band_hz == plan.uncertainty_band_hz == (10.0, 300.0)


def test_the_lines_are_the_measured_ones(small_dict):
    """The plan's lines are bit for bit those of the H1 estimate of the simulated record
    (what the update masks are taken on)."""
    from truthbench.campaign.runner import simulate_one

    plan = CampaignPlan.compile(parse_campaign(small_dict))
    rec = simulate_one(plan.spec, 0, 1)
    np.testing.assert_array_equal(rec.freq_hz, plan.tests[1].freq_hz, strict=True)
    assert rec.frf.estimator.segment_samples == plan.tests[1].segment


def test_band_overlap_and_lines():
    assert band_overlap((2.0, 400.0), None) == (2.0, 400.0)
    assert band_overlap((2.0, 400.0), (10.0, 500.0)) == (10.0, 400.0)
    lo, hi = band_overlap((2.0, 40.0), (50.0, 60.0))
    assert lo > hi  # empty: no line lies in it
    f = np.arange(6.0)
    np.testing.assert_array_equal(lines_in(f, (0.0, 3.0)), [False, True, True, True, False,
                                                            False])


def test_the_plant_is_made_once_per_campaign(small_dict, monkeypatch):
    """Validating, running two trials, and the result's tables: one plant builder."""
    import truthbench.plants as plants
    from truthbench.campaign import spec as spec_module
    from truthbench.campaign.runner import run_campaign

    made = []
    real = plants.make_plant

    def counting(kind, **options):
        made.append(kind)
        return real(kind, **options)

    monkeypatch.setattr(plants, "make_plant", counting)
    spec_module._plant.cache_clear()
    small_dict["update"]["method"] = ["finite_difference", "sensitivity"]
    result = run_campaign(parse_campaign(small_dict), trials=2)
    assert not result.failed
    result.to_pandas("parameters")
    assert made == ["free_free_beam"]
