"""Measured channels placed on the model: stations, coordinates, point maps, signs,
noise; and the errors for data that cannot be placed."""

import dataclasses

import numpy as np
import pytest

from truthbench.diagnose.data import COHERENCE_FLOOR, h1_sigma, prepare
from truthbench.errors import DataFormatError
from truthbench.measure.frfdata import Channel, FRFData
from truthbench.plants import make_plant

from .conftest import ROOT

PLANT = make_plant("free_free_beam", n_elements=20)  # 1.8 m: nodes every 0.09 m
F = np.arange(0.0, 100.0, 0.5)


def frf(outputs, inputs, **kw):
    H = np.ones((F.size, len(outputs), len(inputs)), complex)
    return FRFData("t", F, H, tuple(outputs), tuple(inputs), **kw)


def test_channels_go_to_stations_nodes_or_mapped_points():
    out = [Channel("a", "acceleration", "z", station="mid"),
           Channel("b", "acceleration", "z", point=7, coordinates_m=(0.2705, 0.0, 0.0)),
           Channel("c", "acceleration", "z", point=12)]
    inp = [Channel("f", "force", "z", sign=-1, coordinates_m=(1.8, 0.0, 0.0))]
    plant, (t,) = prepare([frf(out, inp)], PLANT, PLANT.resolve(), tolerance_m=1e-3,
                          point_map={12: 0.72})
    assert [s.station for s in t.sensors] == ["mid", "n3", "n8"]
    assert [a.station for a in t.actuators] == ["n20"]
    assert plant.station_node("n3") == 3 and plant.station_node("n20") == 20
    # a force in -z: the data are brought to +z
    np.testing.assert_array_equal(t.H, -1.0)
    assert t.freq_hz[0] > 0  # no 0 Hz line


def test_a_point_off_every_node_is_named_with_the_nearest_node_and_distance():
    out = [Channel("b", "acceleration", "z", point=101, coordinates_m=(0.30, 0.0, 0.0))]
    inp = [Channel("f", "force", "z", coordinates_m=(0.0, 0.0, 0.0))]
    with pytest.raises(DataFormatError, match=r"channel 'b' \(point 101 at \(0\.3, 0, "
                                               r"0\) m\) matches no node .* within "
                                               r"0\.001 m: the nearest is node 3 .*0\.03 m"):
        prepare([frf(out, inp)], PLANT, PLANT.resolve(), tolerance_m=1e-3)


@pytest.mark.parametrize("change,match", [
    (dict(inputs=()), "no input"),
    (dict(outputs=(Channel("a", "acceleration", None, station="mid"),)), "no direction"),
    (dict(outputs=(Channel("a", "acceleration", "z"),)), "no station, no coordinates"),
    (dict(band_hz=(200.0, 300.0)), "no line left"),
])
def test_data_that_cannot_be_compared_are_refused_by_name(change, match):
    base = dict(outputs=(Channel("a", "acceleration", "z", station="mid"),),
                inputs=(Channel("f", "force", "z", station="end_a"),))
    base.update(change)
    data = FRFData("t", F, np.ones((F.size, len(base["outputs"]), len(base["inputs"]))),
                   base["outputs"], base["inputs"], band_hz=base.get("band_hz"))
    with pytest.raises(DataFormatError, match=match):
        prepare([data], PLANT, PLANT.resolve())


def test_h1_noise_from_coherence_and_averages():
    """Bendat and Piersol: per real and imaginary part, |H| sqrt((1 - g2) / (2 n g2)),
    times n / (n - 1) for the coherence estimate's bias and the n - 1 degrees of
    freedom."""
    H = np.array([[[2.0 + 0j]], [[1.0j]]])
    g2 = np.array([[[0.5]], [[0.9]]])
    sigma, kind = h1_sigma(H, g2, 8)
    assert kind == "coherence"
    few = 8 / 7
    np.testing.assert_allclose(sigma.ravel(), [few * 2.0 * np.sqrt(0.5 / 8.0),
                                               few * np.sqrt(0.1 / (16 * 0.9))], rtol=1e-14)
    # coherence 1 is clipped: a floor, never a zero weight's inverse
    assert h1_sigma(H, np.ones_like(g2), 8)[0].min() > 0
    assert np.isclose(h1_sigma(H, np.ones_like(g2), 8)[0][0, 0, 0],
                      few * 2.0 * np.sqrt(COHERENCE_FLOOR / (16 * (1 - COHERENCE_FLOOR))))
    # one average: the coherence is 1 whatever the noise; relative weights instead
    assert h1_sigma(H, g2, 1)[1] == "relative"
    sigma, kind = h1_sigma(H, None, None)
    assert kind == "relative"  # |H| plus the pair's median |H| (1.5 here)
    np.testing.assert_allclose(sigma.ravel(), [3.5, 2.5], rtol=1e-15)


def test_signs_flip_rows_and_columns():
    out = [Channel("a", "acceleration", "z", sign=-1, station="mid"),
           Channel("b", "acceleration", "z", station="quarter")]
    inp = [Channel("f", "force", "z", station="end_a")]
    data = dataclasses.replace(frf(out, inp), H=np.ones((F.size, 2, 1)) * (1 + 2j))
    _, (t,) = prepare([data], PLANT, PLANT.resolve())
    np.testing.assert_array_equal(t.H[:, 0], -(1 + 2j))
    np.testing.assert_array_equal(t.H[:, 1], 1 + 2j)


def test_a_channel_map_places_channels_a_file_does_not_describe():
    """A LabVIEW record says neither where nor which way: the map by label does."""
    out = [Channel("Acceleration (Trigger)", "acceleration")]
    inp = [Channel("Force (Trigger)", "force")]
    cmap = {"Acceleration (Trigger)": {"x_m": 0.27, "direction": "z", "sign": -1},
            "Force (Trigger)": {"station": "mid", "direction": "z"}}
    plant, (t,) = prepare([frf(out, inp)], PLANT, PLANT.resolve(), channel_map=cmap)
    assert [s.station for s in t.sensors] == ["n3"]
    assert [(a.station, a.direction) for a in t.actuators] == [("mid", "z")]
    np.testing.assert_array_equal(t.H, -1.0)  # the accelerometer measures -z


@pytest.mark.parametrize("cmap,match", [
    ({"Accel": {"x_m": 0.27, "direction": "z"}}, r"\['Accel'\] are no channel of the "
                                                 r"data; its channels are"),
    ({"a": {"x_m": 0.27, "dir": "z"}}, r"entry 'a': unknown keys \['dir'\]"),
])
def test_a_channel_map_that_names_no_channel_is_refused(cmap, match):
    data = frf([Channel("a", "acceleration")], [Channel("f", "force", "z", station="mid")])
    with pytest.raises(DataFormatError, match=match):
        prepare([data], PLANT, PLANT.resolve(), channel_map=cmap)


@pytest.mark.parametrize("averages,low,high", [(4, 0.95, 1.25), (8, 0.9, 1.12),
                                               (16, 0.9, 1.12)])
def test_the_noise_weights_are_calibrated_on_simulated_data(averages, low, high):
    """The reduced chi2 of the fitted true model on simulated H1 data (the quickstart
    tube's end test, 400 lines of 4 channels, 2 % sensor noise) is 1 within its spread:
    about 0.03 standard deviation for about 1800 independent values, bounds of 3 of them
    (4 averages: up to 1.25, the corrections are first order in 1 / n). Without the
    n / (n - 1) corrections it is 1.31 for 8 averages and 1.78 for 4."""
    import tomllib

    from truthbench.campaign.runner import simulate_one
    from truthbench.campaign.spec import parse_campaign
    from truthbench.diagnose import diagnose

    d = tomllib.loads((ROOT / "campaigns" / "quickstart.toml").read_text())
    d["tests"] = [dict(d["tests"][0], record_s=1.0 * averages, averages=averages)]
    spec = parse_campaign(d)
    frf = simulate_one(spec, 0, 0, 7).frf
    diag = diagnose([frf], spec.make_plant(), spec.nominal_parameters(),
                    spec.update.parameters, max_effects=0, check_modes=False,
                    identify_modes=False, mesh_tolerance=1e300)
    assert low < diag.before.reduced_chi2 < high
