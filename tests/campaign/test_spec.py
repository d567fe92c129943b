"""Campaign validation: every bad input gives an error naming file, key, expected and got."""

import numpy as np
import pytest

from truthbench.campaign.spec import load_campaign, parse_campaign
from truthbench.errors import CampaignError

from .conftest import QUICKSTART


def test_quickstart_loads_and_resolves_truth():
    spec = load_campaign(QUICKSTART)
    nominal, truth = spec.nominal_parameters(), spec.truth_parameters()
    assert truth["E_pa"] == pytest.approx(nominal["E_pa"] * 1.04)
    assert truth["rho_kg_m3"] == pytest.approx(nominal["rho_kg_m3"] * 0.97)
    assert spec.test_sensors(0) == spec.sensors


def test_unknown_key(quickstart_dict):
    quickstart_dict["tests"][0]["level_rsm"] = 1.0
    with pytest.raises(CampaignError,
                       match=r"(?s)cfg.toml.*'tests\[0\].level_rsm'.*unknown key"):
        parse_campaign(quickstart_dict, "cfg.toml")


def test_wrong_type(quickstart_dict):
    quickstart_dict["tests"][1]["averages"] = "many"
    with pytest.raises(CampaignError, match=r"(?s)'tests\[1\].averages': expected .*integer.*"
                                            r"got 'many'"):
        parse_campaign(quickstart_dict, "cfg.toml")


def test_negative_length(quickstart_dict):
    quickstart_dict["plant"]["parameters"]["L_m"] = -1.8
    with pytest.raises(CampaignError, match=r"(?s)'plant.parameters'.*'L_m' must be a positive"):
        parse_campaign(quickstart_dict, "cfg.toml")
    quickstart_dict["plant"]["parameters"]["L_m"] = 1.8
    quickstart_dict["tests"][0]["record_s"] = -3
    with pytest.raises(CampaignError,
                       match=r"(?s)'tests\[0\].record_s': expected .*greater than 0"):
        parse_campaign(quickstart_dict, "cfg.toml")


def test_sensor_at_missing_station(quickstart_dict):
    quickstart_dict["sensors"][1]["station"] = "nose"
    with pytest.raises(CampaignError, match=r"(?s)'sensors\[1\].station'.*no station 'nose'"):
        parse_campaign(quickstart_dict, "cfg.toml")


def test_a_joint_between_nodes_must_be_a_hinge(quickstart_dict):
    quickstart_dict["plant"]["stations"] = {"gauge": 0.37}
    joint = {"name": "joint", "station": "gauge", "parameters": {"stiffness_loss": 0.2}}
    quickstart_dict["truth"]["effects"] = [joint]
    with pytest.raises(CampaignError, match=r"(?s)'truth.effects\[0\].station'.*between nodes"
                                            r".*form = \"hinge\".*got 'gauge'"):
        parse_campaign(quickstart_dict, "cfg.toml")
    joint["form"] = "hinge"
    spec = parse_campaign(quickstart_dict, "cfg.toml")
    assert spec.truth_effects()[0].options["form"] == "hinge"


def test_unknown_parameter_names(quickstart_dict):
    quickstart_dict["truth"]["relative"]["youngs"] = 0.1
    with pytest.raises(CampaignError, match=r"(?s)'truth.relative.youngs'.*no parameter 'youngs'"):
        parse_campaign(quickstart_dict, "cfg.toml")


def test_update_with_m_r_not_above_p(quickstart_dict):
    quickstart_dict["sensors"] = quickstart_dict["sensors"][:1]
    quickstart_dict["tests"] = quickstart_dict["tests"][:1]
    with pytest.raises(CampaignError, match=r"(?s)m r > p.*m r = 1 for p = 2"):
        parse_campaign(quickstart_dict, "cfg.toml")


def test_band_above_nyquist_and_missing_key(quickstart_dict):
    quickstart_dict["tests"][0]["band_hz"] = [2.0, 900.0]
    with pytest.raises(CampaignError, match=r"(?s)'tests\[0\].band_hz'.*Nyquist"):
        parse_campaign(quickstart_dict, "cfg.toml")
    del quickstart_dict["tests"][0]["fs_hz"]
    with pytest.raises(CampaignError, match=r"(?s)'tests\[0\].fs_hz' is required"):
        parse_campaign(quickstart_dict, "cfg.toml")


def test_bad_toml_and_missing_file(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("[campaign\nname = 1")
    with pytest.raises(CampaignError, match=r"bad.toml: not valid TOML"):
        load_campaign(bad)
    with pytest.raises(CampaignError, match="not found"):
        load_campaign(tmp_path / "none.toml")


def test_unknown_update_method_and_group(quickstart_dict):
    quickstart_dict["update"]["method"] = ["finite_difference", "kalman"]
    with pytest.raises(CampaignError, match=r"(?s)'update.method'.*unknown updater 'kalman'.*"
                                            r"finite_difference, sensitivity"):
        parse_campaign(quickstart_dict, "cfg.toml")
    quickstart_dict["update"]["method"] = "finite_difference"
    quickstart_dict["update"]["parameters"] = ["E_pa@g9"]
    with pytest.raises(CampaignError, match=r"(?s)'update.parameters'.*no parameter 'E_pa@g9'"):
        parse_campaign(quickstart_dict, "cfg.toml")


def test_holdout_names_must_exist_and_leave_two_building_tests(quickstart_dict):
    quickstart_dict["uncertainty"] = {"holdout": ["shaker_middle"]}
    with pytest.raises(CampaignError, match=r"(?s)cfg.toml.*'uncertainty.holdout'.*"
                                            r"shaker_end.*unknown \['shaker_middle'\]"):
        parse_campaign(quickstart_dict, "cfg.toml")
    quickstart_dict["uncertainty"] = {"holdout": ["shaker_end"]}
    with pytest.raises(CampaignError, match=r"'uncertainty.holdout': at least 2 tests"):
        parse_campaign(quickstart_dict, "cfg.toml")
    quickstart_dict["uncertainty"] = {"k_sigma": -1.0}
    with pytest.raises(CampaignError, match=r"'uncertainty.k_sigma'.*greater than 0"):
        parse_campaign(quickstart_dict, "cfg.toml")


def test_output_time_histories_choice(quickstart_dict):
    quickstart_dict["output"] = {"time_histories": "some"}
    with pytest.raises(CampaignError, match=r"(?s)'output.time_histories'.*first_trial"):
        parse_campaign(quickstart_dict, "cfg.toml")


def test_limits_are_inclusive(small_dict):
    """At the limits a campaign loads; one step beyond, it is refused (the corpus in
    tests/bad_input has the refusals)."""
    import math

    from truthbench.campaign.spec import MAX_ELEMENTS, max_noise_fraction

    assert max_noise_fraction(8) == pytest.approx(4.0)
    d = small_dict
    d["tests"][0]["noise_fraction"] = max_noise_fraction(d["tests"][0]["averages"])
    d["campaign"]["name"] = "a" * 64
    d["tests"][1]["name"] = "fourth | bar"
    parse_campaign(d)
    d["tests"][0]["noise_fraction"] = math.nextafter(d["tests"][0]["noise_fraction"], 99.0)
    with pytest.raises(CampaignError, match=r"'tests\[0\].noise_fraction': expected at most "
                                            r"sqrt\(2 averages\) = 2.828 for 4 averages"):
        parse_campaign(d)
    assert MAX_ELEMENTS == 500


def test_level_and_update_band_limits(small_dict):
    """level_rms inside LEVEL_RMS_RANGE (limits inclusive); the update band inside the
    span of the tests' bands (its edges may touch it), and with lines of every test."""
    import math

    from truthbench.campaign.spec import LEVEL_RMS_RANGE

    d = small_dict
    low, high = LEVEL_RMS_RANGE
    for level in (low, high):
        d["tests"][0]["level_rms"] = level
        parse_campaign(d)
    d["tests"][0]["level_rms"] = math.nextafter(high, math.inf)
    with pytest.raises(CampaignError, match=r"'tests\[0\].level_rms': expected a level from "
                                            r"1e-06 to 1e\+06 N"):
        parse_campaign(d)
    d["tests"][0]["level_rms"] = 2.0
    d["update"]["band_hz"] = [2.0, 400.0]  # the tests' band itself
    parse_campaign(d)
    d["update"]["band_hz"] = [1.0, 401.0]
    with pytest.raises(CampaignError, match=r"'update.band_hz': expected a band inside the "
                                            r"tests' excited band 2-400 Hz .* got 1-401 Hz, "
                                            r"which reaches below and above it"):
        parse_campaign(d, "cfg.toml")
    # inside the span, but holding no line of one test
    d["tests"][0]["band_hz"] = [2.0, 100.0]
    d["tests"][1]["band_hz"] = [200.0, 400.0]
    d["update"]["band_hz"] = [250.0, 350.0]
    with pytest.raises(CampaignError, match=r"'update.band_hz': expected a band that overlaps "
                                            r"every test's excited band .* 250-350 Hz, which "
                                            r"holds no line of 'shaker_end'"):
        parse_campaign(d, "cfg.toml")


def test_lines_and_memory_estimate(small_dict):
    from truthbench.campaign.plan import CampaignPlan
    from truthbench.campaign.resources import simulation_bytes

    spec = parse_campaign(small_dict)
    t = CampaignPlan.compile(spec).tests[0]  # 4 s at 1024 Hz, 4 averages: 1024-sample segments
    assert (t.samples, t.segment) == (4096, 1024)
    np.testing.assert_array_equal(t.freq_hz, np.arange(513) * 1.0)
    n = 4096
    channels = 1 + len(spec.test_sensors(0))
    # periodic path: the larger of the records and the modal response at every line
    need, what = simulation_bytes(t, n_dofs=54)
    assert need == max(8 * n * channels, 16 * (n // 2 + 1) * 54)
    assert "DOFs" in what
    small_dict["tests"][0]["simulation"] = "time"
    small_dict["tests"][0]["oversample"] = 4
    t = CampaignPlan.compile(parse_campaign(small_dict)).tests[0]
    need, what = simulation_bytes(t, n_dofs=54)
    assert need == 8 * n * channels * 4 and "oversample 4" in what


def test_plant_supports(quickstart_dict):
    """``[plant] supports`` reaches the plant (campaign and model file); unset is the
    suspended beam as before."""
    from truthbench.campaign.model_file import parse_model

    assert parse_campaign(quickstart_dict).make_plant().supports is None
    quickstart_dict["plant"]["supports"] = "foam"
    plant = parse_campaign(quickstart_dict).make_plant()
    assert plant.supports == "foam" and plant.support_nodes() == plant.suspension_nodes()
    model = {"plant": {"type": "free_free_beam", "n_elements": 10, "supports": "none"}}
    assert parse_model(model, "m.toml").make_plant().support_nodes() == ()
    assert "supports" not in parse_campaign(
        {**quickstart_dict, "plant": {k: v for k, v in quickstart_dict["plant"].items()
                                      if k != "supports"}}).to_toml_dict()["plant"]


@pytest.mark.parametrize("plant, match", [
    ({"supports": "sand"},
     r"'plant.supports': expected input should be 'springs', 'foam' or 'none'; got 'sand'"),
    ({"type": "hub_beam", "supports": "springs"},
     r"'plant.supports': expected no supports: what holds a hub_beam is fixed by its kind "
     r".*got 'springs'"),
    ({"supports": "none", "suspension_x_m": [0.4, 1.4]},
     r"'plant.supports': expected supports = 'none' \(nothing touches the beam\) without "
     r"suspension_x_m; suspension_x_m = \[0.4, 1.4\] is given; got 'none'"),
    ({"supports": "none"},  # the quickstart declares a suspension stiffness
     r"'plant.parameters.suspension_stiffness_n_m': free_free_beam with supports = 'none' "
     r"has no parameter"),
])
def test_bad_plant_supports(quickstart_dict, plant, match):
    quickstart_dict["plant"].update(plant)
    with pytest.raises(CampaignError, match=match):
        parse_campaign(quickstart_dict, "cfg.toml")


def test_boundary_at_a_support_the_plant_lacks(quickstart_dict):
    quickstart_dict["truth"]["effects"] = [
        {"name": "boundary", "support": 1, "parameters": {"stiffness_rel": 4.0}}]
    parse_campaign(quickstart_dict, "cfg.toml")
    quickstart_dict["truth"]["effects"][0]["support"] = 2
    with pytest.raises(CampaignError, match=r"cfg.toml: key 'truth.effects\[0\].support': "
                                            r"effect 'boundary': option 'support' expected "
                                            r"'all' or the index of a suspension point, "
                                            r"0\.\.1 .*; got 2"):
        parse_campaign(quickstart_dict, "cfg.toml")
