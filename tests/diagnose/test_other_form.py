"""The diagnosis on data it did not make: a truth of another model form.

Every data set here comes from the diagnose-study's other-form truth
(:func:`truthbench.campaign.diagnose_study.truth_of`): a mesh three times finer than the
model's, effects at points of that mesh (most between the model's nodes), sensors off the
beam's axis with cross-axis sensitivity and a shaker off-axis and misaligned (so the
truth's lateral and torsion modes reach the data), and each test's own estimator. The
model diagnosed is the campaign's nominal one.
"""

from pathlib import Path

import numpy as np
import pytest

from truthbench.campaign.diagnose_study import (
    Injected,
    Measurement,
    OtherForm,
    draw_trial,
    truth_of,
)
from truthbench.campaign.runner import simulate_one
from truthbench.campaign.spec import load_campaign, parse_campaign
from truthbench.diagnose import diagnose
from truthbench.effects import parse_effect

SEED = 20261126
ROOT = Path(__file__).resolve().parents[2]


def _campaign(**plant):
    """The quickstart tube, one shaker test, 4 vertical accelerometers, 2-1000 Hz (the
    first torsion mode, about 860 Hz, is in the band), 1 Hz lines, 8 Bartlett averages."""
    return parse_campaign({
        "campaign": {"name": "other_form", "seed": SEED},
        "plant": {"type": "free_free_beam", "n_elements": 20, **plant},
        "truth": {"relative": {"E_pa": 0.02, "rho_kg_m3": -0.01}},
        "sensors": [{"station": s, "direction": "z"}
                    for s in ("end_a", "quarter", "mid", "end_b")],
        "tests": [{"name": "shaker_end", "actuators": [{"station": "end_a", "direction": "z"}],
                   "level_rms": 2.0, "band_hz": [2.0, 1000.0], "fs_hz": 2048.0,
                   "record_s": 8.0, "averages": 8, "noise_fraction": 0.02}],
        "update": {"method": "none", "parameters": ["E_pa", "rho_kg_m3"]},
    }, "other-form test campaign")


def other_form(spec, *injected, refine=3, timoshenko=False, mounted=True, extra=()):
    """The FRFs of ``spec``'s tests from a truth of another form with ``injected``
    effects (:class:`Injected`) and ``extra`` effect entries, and what the truth
    placed."""
    sensors = tuple((f"{s.station}.z.acc", 0.003, 0.02) for s in spec.sensors) \
        if mounted else ()
    shakers = (("end_a.z", 0.003, 2.0),) if mounted else ()
    draw_ = _Draw(tuple(injected), tuple(Measurement(t.record_s, t.averages, "bartlett")
                                         for t in spec.tests),
                  OtherForm(refine, timoshenko, sensors, shakers))
    truth = truth_of(spec, draw_, "other")
    effects = truth.effects + tuple(parse_effect(e, "test", "test") for e in extra)
    data = [simulate_one(truth.spec, 0, j, SEED, effects).frf
            for j in range(len(spec.tests))]
    return data, truth


class _Draw:
    def __init__(self, injected, measurement, other):
        self.injected, self.measurement, self.other = injected, measurement, other


def _diagnose(spec, data, **kw):
    return diagnose(data, spec.make_plant(), spec.nominal_parameters(),
                    spec.update.parameters, **kw)


@pytest.fixture(scope="module")
def tube():
    return _campaign()


@pytest.mark.slow
def test_a_clean_truth_of_another_form_finds_nothing(tube):
    """Three times the mesh, lateral and torsion modes in the data through the mounted
    channels: nothing is reported as missing. The mounting modelled in carries the
    torsion mode (about 870 Hz) and the free roll (whose mass line the sensors off the
    axis read): its amplitude for every sensor is the truth's product of offsets, 3 mm
    by 3 mm times the cosine of the shaker's 2 degrees. Compared with ideal channels
    instead, the torsion and the roll are named as modes the model lacks at these
    channels and modelled in with free residues; neither way is an effect fitted."""
    data, truth = other_form(tube)
    diag = _diagnose(tube, data, mounting=True)
    assert diag.found == ()
    assert len(diag.mounting.paths) == 4
    # within 15 %: a bound set after measuring 8.6, 8.8, 10.0 and 9.6e-6 (11.5 % at
    # worst), not derived: it holds the truth's cross-axis path (2 % of the lateral
    # motion the 2-degree tilt drives), which the comparison leaves out, its three
    # times finer mesh and the noise
    k = np.array([p[3] for p in diag.mounting.paths])
    np.testing.assert_allclose(k, 0.003 * 0.003 * np.cos(np.deg2rad(2.0)), rtol=0.15)
    assert diag.mounting.drop > 100 * len(k)  # far beyond what noise gives a parameter
    assert not [m for m in diag.missing if m.model_mode and "torsion" in m.model_mode]
    assert diag.after.reduced_chi2 < 1.2  # the rest is noise
    ideal = _diagnose(tube, data)  # ideal channels, the default
    assert ideal.found == () and ideal.mounting is None
    torsion = [m for m in ideal.missing if m.model_mode and "torsion" in m.model_mode]
    assert len(torsion) == 1 and 850 < torsion[0].freq_hz < 900
    for m in ideal.missing:
        assert m in torsion or (m.freq_hz == 0 and "rotation about x" in m.model_mode)
    assert ideal.after.reduced_chi2 < 1.2


@pytest.mark.slow
def test_a_mass_between_two_nodes_is_found_there_with_no_joint_left(tube):
    """45 g at a point of the fine mesh between two model nodes: one added mass at that
    point, of that size, and nothing else (no joint standing in for it)."""
    fraction = 13.5 / 20  # 1.215 m: midway between model nodes 13 and 14
    data, truth = other_form(tube, Injected("added_mass", "mass_kg", 0.045, {}, fraction))
    diag = _diagnose(tube, data)
    (found,) = diag.found
    assert found.effect == "added_mass"
    assert found.parameters["mass_kg"] == pytest.approx(0.045, rel=0.05)
    assert found.x_m == pytest.approx(truth.placed[0].x_m, abs=0.01)
    assert not any(t.effect == "joint" for t in diag.dropped)


@pytest.mark.slow
def test_a_second_order_sensor_roll_off_is_found_as_such(tube):
    """An accelerometer's mounted resonance (1.5 kHz, damping ratio 0.5, above the band)
    rolls every channel off: found as a second-order sensor dynamics (or its
    indistinguishable actuator twin), not as a delay and a mass."""
    data, _ = other_form(tube, extra=[{"name": "sensor_dynamics", "parameters": {
        "bandwidth_hz": 1500.0, "damping_ratio": 0.5}}])
    diag = _diagnose(tube, data)
    (found,) = diag.found
    names = {found.effect, *(a.effect for a in found.alternatives)}
    assert names & {"sensor_dynamics", "actuator_resonance"}
    assert found.parameters.get("bandwidth_hz", found.parameters.get(
        "natural_frequency_hz")) == pytest.approx(1500.0, rel=0.1)
    assert found.parameters["damping_ratio"] == pytest.approx(0.5, rel=0.15)


@pytest.mark.slow
def test_a_first_order_shaker_lag_is_not_left_as_a_collapsed_resonance():
    """A study trial (``campaigns/diagnose_study.toml``, seed 20261126, trial 39): a
    24 % gain error on one channel and a shaker pole at 277 Hz, on a Timoshenko truth of
    three times the mesh. The resonance that first explains the lag best collapses to
    its first-order limit once the element physics are in (a natural frequency of
    16 kHz, a damping ratio of 30); left so, its ``s^2`` coefficient at 0 broke the
    refit of the gain error, which was never found. Reduced, all three are found, at
    their sizes. Compared with ideal channels, as the study did then: with the
    mounting modelled in, the lag is found as such at once (the reduction is not
    needed)."""
    spec = load_campaign(ROOT / "campaigns" / "diagnose_study.toml")
    draw = draw_trial(spec, 39, 20261126)
    truth = truth_of(spec, draw, "other")
    assert draw.other.timoshenko and draw.other.refine == 3
    data = [simulate_one(truth.spec, 39, j, 20261126, truth.effects).frf
            for j in range(len(spec.tests))]
    diag = _diagnose(spec, data, **{**spec.diagnose.settings(), "mounting": False})
    found = {f.effect: f for f in diag.found}
    assert set(found) == {"actuator_dynamics", "channel_gain", "element_physics"}
    sizes = {p.effect: p.size for p in truth.placed}
    assert found["actuator_dynamics"].parameters["bandwidth_hz"] == pytest.approx(
        sizes["actuator_dynamics"], rel=0.05)
    assert found["channel_gain"].parameters["gain_error"] == pytest.approx(
        sizes["channel_gain"], rel=0.05)
    assert any(t.status.startswith("reduced to actuator_dynamics") for t in diag.tried)


@pytest.mark.slow
def test_a_mass_found_as_two_beside_each_other_is_merged_into_one():
    """A study trial (seed 20261126, trial 20): 22.9 g at 1.380 m on a Timoshenko truth
    of three times the mesh. Found at the first step against a model without the shear
    terms, the mass was placed 1.9 cm off; a second one (19 g) then came in 1.3 cm
    from it, and the pair explained more than either moved alone. Placed anew without
    its weaker twin once the shear terms are in, one mass explains as much: one mass,
    its size and place, and the shear terms."""
    spec = load_campaign(ROOT / "campaigns" / "diagnose_study.toml")
    draw = draw_trial(spec, 20, 20261126)
    truth = truth_of(spec, draw, "other")
    data = [simulate_one(truth.spec, 20, j, 20261126, truth.effects).frf
            for j in range(len(spec.tests))]
    diag = _diagnose(spec, data, **spec.diagnose.settings())
    assert sorted(f.effect for f in diag.found) == ["added_mass", "element_physics"]
    (mass,) = (f for f in diag.found if f.effect == "added_mass")
    (placed,) = truth.placed
    assert mass.parameters["mass_kg"] == pytest.approx(placed.size, rel=0.05)
    assert mass.x_m == pytest.approx(placed.x_m, abs=0.005)
    assert any("explains as much" in t.status for t in diag.tried)


@pytest.mark.slow
def test_a_five_times_stiffer_suspension_is_found_as_boundary(tube):
    """Both suspension springs five times stiffer: ``boundary``, not two grounded springs,
    and its ratio nearer 5 than 1 on a log scale. (Its size, 4.5, misses the study's 10 %:
    the bounce and the pitch, 9.2 and 9.6 Hz, fall between 1-Hz lines and are seen only
    through the estimator's leakage; a recorded miss, see the diagnosis guide.)"""
    data, _ = other_form(tube, Injected("boundary", "stiffness_rel", 4.0, {}, None))
    diag = _diagnose(tube, data)
    (found,) = diag.found
    assert found.effect == "boundary"
    ratio = 1 + found.parameters["stiffness_rel"]
    assert abs(np.log(ratio / 5.0)) < 0.5 * np.log(5.0)


@pytest.mark.slow
def test_a_half_again_stiffer_suspension_is_found_as_boundary_not_a_spring():
    """A study trial (``campaigns/diagnose_study.toml``, seed 20261126, trial 32): both
    supports 1.51 times stiffer, on a truth of four times the mesh, Hann-averaged at
    1 and 0.5 Hz lines. Its suspension modes, a tenth of a line wide, move by a
    fifth and are seen through the estimator's leakage. Before, the all-support
    ``boundary`` ranked third of the three supports' candidates at first order and was
    not line-searched, and a refit with the leakage held from its start stayed near it:
    a grounded spring was reported. Now every global candidate is line-searched through
    the estimator, and a support's refit computes the leakage at every value."""
    spec = load_campaign(ROOT / "campaigns" / "diagnose_study.toml")
    draw = draw_trial(spec, 32, 20261126)
    truth = truth_of(spec, draw, "other")
    (placed,) = truth.placed
    assert placed.effect == "boundary" and draw.other.refine == 4
    data = [simulate_one(truth.spec, 32, j, 20261126, truth.effects).frf
            for j in range(len(spec.tests))]
    diag = _diagnose(spec, data, **spec.diagnose.settings())
    (found,) = diag.found
    assert found.effect == "boundary"
    assert 1 + found.parameters["stiffness_rel"] == pytest.approx(placed.size, rel=0.10)


@pytest.mark.slow
def test_the_mesh_check_refines_a_too_coarse_model_and_says_so():
    """An 8-element model of the tube over 2-1000 Hz cannot resolve its bending modes:
    the check refines it until halving it changes nothing beyond the noise, and says so;
    nothing is found in clean data."""
    coarse = _campaign(n_elements=8)
    data, _ = other_form(coarse, refine=8, mounted=False)
    diag = _diagnose(coarse, data)
    assert diag.mesh.refined and diag.mesh.adequate
    assert diag.mesh.n_elements[0] == 8 and diag.mesh.used >= 32
    assert diag.mesh.change[0] > diag.mesh.tolerance >= diag.mesh.change[-1]
    assert "refined from 8" in diag.mesh.summary()
    assert diag.found == ()
    assert np.isfinite(diag.frf_error_after)


@pytest.mark.slow
def test_a_long_delay_beside_a_mass_are_both_found(tube):
    """A 1.7 ms delay (11 rad at the band's top, beyond a first-order screen from zero)
    beside a 17 g mass between nodes: the complex baseline cannot follow that phase (its
    best is a model near zero), so the delay is judged by its matched-delay profile on
    the magnitude fit, refitted from there, and the mass found after it, placed between
    the nodes before it is weighed against a joint. Before, nothing was found in such
    data."""
    data, truth = other_form(tube, Injected("time_delay", "delay_s", 1.7e-3, {}, None),
                             Injected("added_mass", "mass_kg", 0.017, {}, 0.63))
    diag = _diagnose(tube, data)
    found = {f.effect: f for f in diag.found}
    assert set(found) == {"time_delay", "added_mass"}
    assert found["time_delay"].parameters["delay_s"] == pytest.approx(1.7e-3, rel=0.01)
    assert found["added_mass"].parameters["mass_kg"] == pytest.approx(0.017, rel=0.1)
    assert found["added_mass"].x_m == pytest.approx(truth.placed[1].x_m, abs=0.02)
