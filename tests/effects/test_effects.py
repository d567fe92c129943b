"""The uncertainty table: every effect changes what it should, and nothing else."""

import numpy as np
import pytest

from truthbench.campaign.plan import CampaignPlan
from truthbench.campaign.spec import parse_campaign
from truthbench.campaign.trial import excitation_rng, simulate_test
from truthbench.campaign.truth import build_hardware
from truthbench.effects import EFFECTS, effect_from_inject, parse_effect
from truthbench.errors import CampaignError
from truthbench.measure import estimate_frf
from truthbench.plants import Actuator, Sensor, make_plant
from truthbench.simulate import noise_to_signal_ratio

COVERED = set()  # effects exercised below; the last test checks every effect is


def _hardware(spec, trial, j, seed, extra_effects=()):
    """The truth of test ``j`` of trial ``trial`` of ``spec`` (compiled to its plan)."""
    plan = CampaignPlan.compile(spec)
    return build_hardware(plan, plan.tests[j], trial, seed, extra_effects)


def _spec(base, effects=(), test_effects=None):
    base["truth"]["effects"] = list(effects)
    if test_effects is not None:
        base["tests"][1]["effects"] = test_effects
    return parse_campaign(base)


def _structure(spec, j=0, trial=0):
    setup = _hardware(spec, trial, j, spec.campaign.seed)
    model = setup.plant.build(setup.parameters, [], [], setup.additions)
    return setup, model


def test_material_changes_stiffness_only(base):
    COVERED.add("material")
    ref = _structure(_spec(base))[1]
    s, m = _structure(_spec(base, [{"name": "material", "parameters": {"E_rel": 0.05}}]))
    np.testing.assert_allclose(m.K.toarray(), ref.K.toarray() * np.where(
        ref.K.toarray() == 0, 1, 1), rtol=0.06)
    assert not np.allclose(m.K.toarray(), ref.K.toarray())
    np.testing.assert_allclose(m.M.toarray(), ref.M.toarray(), atol=1e-15)
    assert s.parameters["E_pa"] == pytest.approx(68.9e9 * 1.05)
    assert s.effects["material"]["E_rel"] == 0.05


def test_geometry_thickness_scales_mass_and_stiffness(base):
    COVERED.add("geometry")
    ref = _structure(_spec(base))[1]
    _, m = _structure(_spec(base, [{"name": "geometry", "parameters": {"t_rel": 0.02}}]))
    beam = ref.M.toarray() != 0
    ratio = m.M.toarray()[beam] / ref.M.toarray()[beam]
    assert np.allclose(ratio, 1.02)  # Table 10.2: t acts on every mass entry


def test_parameter_effect_scales_a_named_parameter(base):
    COVERED.add("parameter")
    s, _ = _structure(_spec(base, [{"name": "parameter", "parameter": "suspension_stiffness_n_m",
                                    "parameters": {"rel": -0.5}}]))
    assert s.parameters["suspension_stiffness_n_m"] == pytest.approx(100.0)


def test_discretization_error_follows_h4(base):
    """Truth meshed finer than the model: the truth-minus-model frequency differences of
    the first three lateral bending modes fall about 16 times when the model's elements
    are halved (consistent-mass Hermite elements, h^4)."""
    from truthbench.model import modal_table

    COVERED.add("discretization")

    def bending_y(model):
        rows = modal_table(model, model.modes(40))
        return np.array([r["freq_hz"] for r in rows if r["shape"].startswith("bending y")
                         and not r["shape"].startswith("rigid")][:3])

    diffs = []
    for n in (10, 20):
        base["plant"]["n_elements"] = n
        spec = _spec(base, [{"name": "discretization", "refine": 160 // n}])
        truth = bending_y(_structure(spec)[1])
        model = bending_y(spec.make_plant().build(spec.nominal_parameters()))
        diffs.append((model - truth) / truth)
    ratio = diffs[0] / diffs[1]
    assert np.all(diffs[1] > 0)
    assert np.all((ratio > 14) & (ratio < 17)), ratio


def test_element_physics_lowers_frequencies_more_for_higher_modes(base):
    COVERED.add("element_physics")
    from truthbench.model import modal_table

    base["plant"]["n_elements"] = 20
    spec = _spec(base, [{"name": "element_physics"}])
    setup, truth = _structure(spec)
    assert setup.plant.timoshenko
    model = spec.make_plant().build(spec.nominal_parameters())

    def bending_y(m):
        rows = modal_table(m, m.modes(40))
        return np.array([r["freq_hz"] for r in rows if r["shape"].startswith("bending y")][:5])

    t, m = bending_y(truth), bending_y(model)
    rel = (t - m) / m
    # shear and rotary inertia lower the frequencies, more for shorter wavelengths
    assert np.all(rel < 0) and np.all(np.diff(rel) < 0), rel


def test_boundary_draws_differ_per_test(base):
    COVERED.add("boundary")
    spec = _spec(base, [{"name": "boundary", "parameters": {
        "stiffness_rel": {"mean": 0.0, "std": 0.2}}}])
    k0 = _hardware(spec, 0, 0, 1).parameters["suspension_stiffness_n_m"]
    k1 = _hardware(spec, 0, 1, 1).parameters["suspension_stiffness_n_m"]
    assert k0 != k1  # scope "test" by default


def test_joint_adds_concentrated_damping_and_stiffness_loss(base):
    COVERED.add("joint")
    ref = _structure(_spec(base))[1]
    _, m = _structure(_spec(base, [{"name": "joint", "station": "mid", "parameters": {
        "stiffness_loss": 0.3, "damping_n_m_s_rad": 2.0}}]))
    C = m.C.toarray() - ref.C.toarray()
    nz = np.argwhere(np.abs(C) > 0)
    labels = {m.dof_labels[i] for i in nz.ravel()}
    assert labels == {"n4.ry", "n5.ry"}  # across the element starting at mid
    assert C[np.ix_(*[[m.dof_labels.index("n4.ry"), m.dof_labels.index("n5.ry")]] * 2)] \
        == pytest.approx(2.0 * np.array([[1, -1], [-1, 1]]))
    assert np.trace(m.K.toarray()) < np.trace(ref.K.toarray())
    np.testing.assert_allclose(m.M.toarray(), ref.M.toarray(), atol=1e-15)


def test_added_mass_shift_matches_rayleigh(base):
    """First-order (Rayleigh) estimate: d(omega^2)/omega^2 = -dm phi_z(station)^2 for a
    mass-normalised mode."""
    COVERED.add("added_mass")
    dm = 0.0005  # the estimate's error is second order: measured 10 %, 1 %, 0.1 % at 5, 0.5, 0.05 g
    spec0 = _spec(base)
    ref = _structure(spec0)[1]
    modes = ref.modes(12)
    _, m = _structure(_spec(base, test_effects=[]), 0)
    base["tests"][0]["effects"] = [{"name": "added_mass", "station": "end_b",
                                    "parameters": {"mass_kg": dm}}]
    spec = parse_campaign(base)
    _, m = _structure(spec, 0)
    new = m.modes(12).omega_rad_s
    iz = ref.dof_labels.index("n8.z")
    ix, iy = ref.dof_labels.index("n8.x"), ref.dof_labels.index("n8.y")
    phi2 = sum(modes.shapes[i] ** 2 for i in (ix, iy, iz))
    flex = modes.omega_rad_s > 1.0
    predicted = -dm * phi2[flex]
    actual = new[flex] ** 2 / modes.omega_rad_s[flex] ** 2 - 1
    big = np.abs(predicted) > 1e-4
    np.testing.assert_allclose(actual[big], predicted[big], rtol=0.02)
    # the other test has no added mass
    _, other = _structure(spec, 1)
    np.testing.assert_allclose(other.M.toarray(), ref.M.toarray(), atol=1e-15)


def test_sensor_mass_loads_only_sensor_stations(base):
    COVERED.add("sensor_mass")
    ref = _structure(_spec(base))[1]
    _, m = _structure(_spec(base, [{"name": "sensor_mass", "parameters": {"mass_kg": 0.01}}]))
    d = np.diag(m.M.toarray() - ref.M.toarray())
    loaded = {m.dof_labels[i].split(".")[0] for i in np.flatnonzero(np.abs(d) > 1e-12)}
    assert loaded == {"n0", "n4", "n8"}  # end_a, mid, end_b


def test_aerodynamic_damping_in_one_direction(base):
    COVERED.add("aerodynamic")
    _, m = _structure(_spec(base, [{"name": "aerodynamic", "direction": "y",
                                    "parameters": {"damping_n_s_m2": 0.5}}]))
    d = np.diag(m.C.toarray())
    y = np.array([lab.endswith(".y") for lab in m.dof_labels])
    assert np.all(d[y] > 0) and d[~y].max() == 0.0
    assert d[y].sum() == pytest.approx(0.5 * 1.8)  # damping per length x length


def test_sag_couples_axial_and_vertical_and_grows(base):
    COVERED.add("sag")
    freq = np.linspace(20, 300, 200)
    cross = []
    for scale in (0.0, 1.0, 4.0):
        eff = [{"name": "sag", "parameters": {"scale": scale}}] if scale else []
        setup, _ = _structure(_spec(base, eff))
        model = setup.plant.build(setup.parameters, [Actuator("end_a", "x")],
                                  [Sensor("mid", "z")], setup.additions)
        cross.append(np.abs(model.frf(freq)).max())
    assert cross[0] < 1e-9 * cross[1]  # zero to rounding without sag
    assert 0 < cross[1] < cross[2]


def _record(spec, j=0, seed=7):
    setup = _hardware(spec, 0, j, seed)
    return setup, simulate_test(CampaignPlan.compile(spec).tests[j], setup,
                                excitation_rng(seed, 0, j))


def test_time_delay_phase_is_minus_omega_tau(base):
    """Noise-free, one rectangular-window segment over the periodic record: the data's
    phase minus the model's is -omega tau (within 1e-3 rad)."""
    COVERED.add("time_delay")
    tau = 2.5e-3
    for t in base["tests"]:
        t.update(averages=1, window="rectangular", oversample=8)
    spec = _spec(base, [{"name": "time_delay", "parameters": {"delay_s": tau}}])
    setup, (u, y) = _record(spec)
    est = estimate_frf(u, y, spec.tests[0].fs_hz, window="rectangular", n_averages=1)
    band = (est.freq_hz > 10) & (est.freq_hz < 300)
    model = setup.plant.build(setup.parameters, [Actuator("end_a", "z")],
                              [Sensor("end_a", "z"), Sensor("mid", "z"), Sensor("end_b", "z")])
    H = model.frf(est.freq_hz[band])
    dphi = np.angle(est.H[band] / H)
    expected = np.angle(np.exp(-2j * np.pi * est.freq_hz[band] * tau))[:, None, None]
    err = np.angle(np.exp(1j * (dphi - expected)))
    assert np.abs(err).max() < 1e-3


def _low_pass_1(s, f_hz):
    w = 2 * np.pi * f_hz
    return w / (s + w)


def _low_pass_2(s, f_hz, zeta):
    w = 2 * np.pi * f_hz
    return w**2 / (s**2 + 2 * zeta * w * s + w**2)


@pytest.mark.parametrize("effects, expected", [
    # first-order actuator, second-order sensor at its default damping ratio 0.7
    ([{"name": "actuator_dynamics", "parameters": {"bandwidth_hz": 50.0}},
      {"name": "sensor_dynamics", "parameters": {"bandwidth_hz": 150.0}}],
     lambda s: _low_pass_1(s, 50.0) * _low_pass_2(s, 150.0, 0.7)),
    # second-order actuator, first-order sensor
    ([{"name": "actuator_resonance",
       "parameters": {"natural_frequency_hz": 120.0, "damping_ratio": 0.2}},
      {"name": "sensor_lag", "parameters": {"bandwidth_hz": 80.0}}],
     lambda s: _low_pass_2(s, 120.0, 0.2) * _low_pass_1(s, 80.0)),
], ids=["first-second", "second-first"])
def test_actuator_and_sensor_dynamics_multiply_the_frf(base, effects, expected):
    COVERED.update(e["name"] for e in effects)
    for t in base["tests"]:
        t.update(averages=1, window="rectangular")
    plain = _record(_spec(base))[1]
    spec = _spec(base, effects)
    u, y = _record(spec)[1]
    fs = spec.tests[0].fs_hz
    e0 = estimate_frf(*plain, fs, window="rectangular", n_averages=1)
    e1 = estimate_frf(u, y, fs, window="rectangular", n_averages=1)
    band = (e0.freq_hz > 5) & (e0.freq_hz < 300)
    s = 2j * np.pi * e0.freq_hz[band]
    ratio = e1.H[band] / e0.H[band]
    np.testing.assert_allclose(ratio, np.broadcast_to(expected(s)[:, None, None],
                                                      ratio.shape), rtol=1e-6)


def test_sensor_noise_and_bias_realised_as_requested(base):
    COVERED.update({"sensor_noise", "sensor_bias"})
    clean = _record(_spec(base))[1][1]
    spec = _spec(base, [{"name": "sensor_noise", "parameters": {"noise_fraction": 0.1}}])
    noisy = _record(spec)[1][1]
    ratio = noise_to_signal_ratio(clean, noisy)
    n = clean.shape[1]
    # the std of a sample std is about sigma / sqrt(2 N): 5 of those
    assert np.all(np.abs(ratio - 0.1) < 5 * 0.1 / np.sqrt(2 * n))
    spec = _spec(base, [{"name": "sensor_bias", "parameters": {"offset": 0.3,
                                                                "gain_error": -0.1}}])
    biased = _record(spec)[1][1]
    np.testing.assert_allclose(biased, 0.9 * clean + 0.3, rtol=1e-12, atol=1e-12)


def test_process_noise_lowers_coherence(base):
    COVERED.add("process_noise")
    for t in base["tests"]:
        t.update(averages=8, record_s=16.0)
    fs = base["tests"][0]["fs_hz"]
    u, y = _record(_spec(base))[1]
    c0 = estimate_frf(u, y, fs, n_averages=8).coherence
    spec = _spec(base, [{"name": "process_noise", "station": "mid", "direction": "z",
                         "parameters": {"rms": 2.0}}])
    u1, y1 = _record(spec)[1]
    np.testing.assert_array_equal(u, u1)  # the recorded force is unchanged
    c1 = estimate_frf(u1, y1, fs, n_averages=8).coherence
    band = slice(20, 300)
    assert c1[band].mean() < c0[band].mean() - 0.1


def test_scopes(base):
    eff = lambda scope: {"name": "material", "scope": scope,  # noqa: E731
                         "parameters": {"E_rel": {"mean": 0.0, "std": 0.05}}}
    base["tests"].append({**base["tests"][0], "name": "third", "assembly": 1, "time_h": 5.0})
    base["tests"][1]["time_h"] = 0.01
    values = {}
    for scope in ("hardware", "reassembly", "test", "drift"):
        spec = _spec(base, [eff(scope)])
        values[scope] = [_hardware(spec, 0, j, 3).parameters["E_pa"] for j in range(3)]
    h, r, t, d = (values[k] for k in ("hardware", "reassembly", "test", "drift"))
    assert h[0] == h[1] == h[2]
    assert r[0] == r[1] != r[2]  # tests 0 and 1 share assembly 0
    assert len(set(t)) == 3
    # drift: starts at the mean at t = 0, moves little in 0.01 h, more in 5 h
    assert d[0] == pytest.approx(68.9e9)
    assert abs(d[1] - d[0]) < abs(d[2] - d[0])
    # a different trial is different hardware
    spec = _spec(base, [eff("hardware")])
    assert _hardware(spec, 1, 0, 3).parameters["E_pa"] != h[0]


def test_inject_adds_an_undeclared_effect(base):
    spec = _spec(base)
    extra = effect_from_inject("joint:station=mid,stiffness_loss=0.2,damping_n_m_s_rad=1.5")
    setup = _hardware(spec, 0, 0, 3, extra_effects=[extra])
    assert setup.effects["joint"]["stiffness_loss"] == 0.2
    assert setup.effects["joint"]["station"] == "mid"


@pytest.mark.parametrize("entry,match", [
    ({"name": "magnetism"}, r"truth.effects\[0\].name'.*unknown effect 'magnetism'"),
    ({"name": "material", "parameters": {"E_rel": {"mean": 0.0, "std": -1.0}}},
     r"E_rel.std'.*standard deviation >= 0"),
    ({"name": "material", "scope": "weekly"}, r"scope'.*hardware, reassembly, test, drift"),
    ({"name": "material", "parameters": {"G_rel": 0.1}}, r"no parameter 'G_rel'"),
    ({"name": "joint"}, r"needs option 'station'"),
    ({"name": "joint", "station": "nose"}, r"no station 'nose'"),
])
def test_bad_effect_entries(base, entry, match):
    base["truth"]["effects"] = [entry]
    with pytest.raises(CampaignError, match="(?s)" + match):
        parse_campaign(base, "cfg.toml")


def test_bad_inject():
    with pytest.raises(CampaignError, match="no parameter 'bogus'"):
        effect_from_inject("time_delay:bogus=1")
    with pytest.raises(CampaignError, match="unknown effect"):
        parse_effect({"name": "nothing"}, "x")




def test_closed_loop_equals_python_control_feedback(hub_base):
    """Hub rate feedback on the hub-beam: the simulated closed-loop FRF (noise-free, one
    rectangular segment over the periodic record) equals python-control's feedback of
    the same plant and compensator, relative 1e-6 away from zeros; the time path too,
    to its hold-image level."""
    import control

    COVERED.add("closed_loop")
    loop = {"name": "closed_loop", "output": 0, "input": 0,
            "parameters": {"gain": 3.0, "bandwidth_hz": 20.0}}
    spec = _spec(hub_base, [loop])
    setup, (u, y) = _record(spec)
    fs = spec.tests[0].fs_hz
    est = estimate_frf(u, y, fs, window="rectangular", n_averages=1)
    band = (est.freq_hz > 1) & (est.freq_hz < 60)
    plant = setup.plant.build(setup.parameters, *spec.test_io(0), setup.additions)
    ol = plant.state_space()
    cl = control.feedback(ol, setup.loops[0].statespace(ol.noutputs, ol.ninputs))
    r = control.frequency_response(cl, 2 * np.pi * est.freq_hz[band])
    Hc = np.moveaxis(np.asarray(r.complex).reshape(cl.noutputs, cl.ninputs, -1), -1, 0)
    mask = np.abs(Hc) > 1e-6 * np.abs(Hc).max(axis=(0, 2), keepdims=True)
    assert (np.abs(est.H[band] - Hc)[mask] / np.abs(Hc)[mask]).max() < 1e-6
    # the hardware's exact FRF (Sherman-Morrison closing) is python-control's feedback;
    # both are exact, so they agree to round-off of the modal sums
    Hh = setup.frf(est.freq_hz[band])
    assert (np.abs(Hh - Hc)[mask] / np.abs(Hc)[mask]).max() < 1e-9
    # the loop changes the response: open loop differs
    Ho = plant.frf(est.freq_hz[band])
    assert np.abs(Ho - Hc).max() > 0.1 * np.abs(Hc).max()


def _hub_frf(hub_base, effects, level, seed=11):
    for t in hub_base["tests"]:
        t.update(level_rms=level, record_s=32.0, averages=4, window="hann", oversample=4,
                 simulation="time")
    spec = _spec(hub_base, effects)
    setup, (u, y) = _record(spec, 0, seed)
    est = estimate_frf(u, y, spec.tests[0].fs_hz, window="hann", n_averages=4)
    return spec, setup, est


def test_coulomb_friction_effect_shrinks_as_the_level_grows(hub_base):
    """Table 10.1: Coulomb friction is a constant force, so its effect on the FRF shrinks
    as the excitation grows. Once friction is a small perturbation its equivalent viscous
    damping, 4 F_c / (pi omega X), falls as 1 / amplitude: the FRF error at the first
    mode should fall about 10 times per 10 times the level (measured 0.99, 0.56,
    0.075, 0.0077)."""
    COVERED.add("coulomb_friction")
    fric = [{"name": "coulomb_friction", "station": "hub", "direction": "rz",
             "parameters": {"force_n": 0.05}}]
    errors = []
    for level in (0.05, 0.5, 5.0, 50.0):
        spec, setup, est = _hub_frf(hub_base, fric, level)
        _, _, lin = _hub_frf(hub_base, [], level)
        band = (est.freq_hz > 6) & (est.freq_hz < 11)  # around the 8.4 Hz mode
        errors.append(np.abs(est.H[band, 0, 0] - lin.H[band, 0, 0]).max()
                      / np.abs(lin.H[band, 0, 0]).max())
    assert errors[0] > errors[1] > errors[2] > errors[3], errors
    assert 7 < errors[2] / errors[3] < 13, errors


@pytest.mark.parametrize("entry", [
    {"name": "cubic_stiffness", "station": "tip", "direction": "y",
     "parameters": {"k3_n_m3": 1e9}},
    {"name": "dead_band", "station": "tip", "direction": "y",
     "parameters": {"gap_m": 1e-5, "stiffness_n_m": 2e3}},
    {"name": "amplitude_damping", "station": "tip", "direction": "y",
     "parameters": {"c2_n_s2_m2": 50.0}},
])
def test_weak_and_strong_nonlinearities_change_the_response(hub_base, entry):
    COVERED.add(entry["name"])
    _, _, lin = _hub_frf(hub_base, [], 1.0)
    _, setup, est = _hub_frf(hub_base, [entry], 1.0)
    assert len(setup.nonlinear) == 1
    band = (est.freq_hz > 2) & (est.freq_hz < 60)
    rel = np.abs(est.H[band] - lin.H[band]).max() / np.abs(lin.H[band]).max()
    assert rel > 1e-3
    zero = {**entry, "parameters": {k: 0.0 for k in entry["parameters"]}}
    _, _, same = _hub_frf(hub_base, [zero], 1.0)
    np.testing.assert_allclose(same.H[band], lin.H[band], rtol=1e-9, atol=1e-12)


def test_grounded_spring_and_dashpot_add_exactly_their_value_at_one_dof(base):
    """The attachments add k to K and c to C at the station's DOF and nothing else."""
    COVERED.update({"grounded_spring", "grounded_dashpot"})
    ref = _structure(_spec(base))[1]
    eff = [{"name": "grounded_spring", "station": "mid", "direction": "y",
            "parameters": {"stiffness_n_m": 3.0e4}},
           {"name": "grounded_dashpot", "station": "end_b", "direction": "z",
            "parameters": {"damping_n_s_m": 7.0}}]
    _, m = _structure(_spec(base, eff))
    plant = make_plant("free_free_beam", n_elements=8)
    dK = (m.K - ref.K).toarray()
    dC = (m.C - ref.C).toarray()
    i = m.dof_labels.index(f"n{plant.station_node('mid')}.y")
    j = m.dof_labels.index(f"n{plant.station_node('end_b')}.z")
    expect_K = np.zeros_like(dK)
    expect_K[i, i] = 3.0e4
    expect_C = np.zeros_like(dC)
    expect_C[j, j] = 7.0
    np.testing.assert_array_equal(dK, expect_K)
    np.testing.assert_array_equal(dC, expect_C)
    np.testing.assert_array_equal(m.M.toarray(), ref.M.toarray())


def test_channel_gain_scales_one_output_row_of_the_frf(base):
    """The gain error multiplies exactly one sensor's row of the exact FRF, by index or by
    the sensor's label; a label the test lacks leaves it alone."""
    COVERED.add("channel_gain")
    f = np.linspace(5.0, 300.0, 40)
    ref = _hardware(_spec(base), 0, 0, 1).frf(f)
    for which in (1, "mid.z.acc"):
        eff = [{"name": "channel_gain", "sensor": which, "parameters": {"gain_error": 0.07}}]
        H = _hardware(_spec(base, eff), 0, 0, 1).frf(f)
        np.testing.assert_array_equal(H[:, [0, 2]], ref[:, [0, 2]])
        np.testing.assert_allclose(H[:, 1], 1.07 * ref[:, 1], rtol=1e-15)
    eff = [{"name": "channel_gain", "sensor": "tip.z.acc", "parameters": {"gain_error": 0.07}}]
    np.testing.assert_array_equal(_hardware(_spec(base, eff), 0, 0, 1).frf(f), ref)


MOUNT_PLANT = make_plant("free_free_beam", n_elements=8)
MOUNT_PARAMS = MOUNT_PLANT.resolve({"modal_damping_ratio": 0.01})
MOUNT_FREQ = np.linspace(3.0, 1200.0, 400)  # through the first torsion mode (~870 Hz)


def _mounted(effects, actuators, sensors):
    from truthbench.effects import realise

    return realise(MOUNT_PLANT, MOUNT_PARAMS, [parse_effect(e, "test") for e in effects],
                   actuators=actuators, sensors=sensors)


def test_sensor_mounting_reads_offset_times_torsion_and_cross_axis_motion():
    """A vertical accelerometer e off the axis (along y) on a beam twisted by a torque
    reads e times the torsional acceleration (w_P = w + theta_x e); with cross-axis
    sensitivity c it also reads c times the lateral acceleration. Against the same
    beam's own z, rx and y outputs: the difference is exact up to round-off."""
    COVERED.add("sensor_mounting")
    e, c = 0.003, 0.02
    sensors = (Sensor("mid", "z"), Sensor("mid", "z"), Sensor("mid", "rx"), Sensor("mid", "y"))
    mount = {"name": "sensor_mounting", "sensor": 0,
             "parameters": {"offset_m": e, "cross_axis": c}}
    for drive in ("rx", "y"):  # pure torsion; pure lateral bending
        H = _mounted([mount], (Actuator("end_a", drive),), sensors).frf(MOUNT_FREQ)[..., 0]
        expected = e * H[:, 2] + c * H[:, 3]
        scale = np.abs(expected).max()
        assert scale > 0
        np.testing.assert_allclose(H[:, 0] - H[:, 1], expected, rtol=0, atol=1e-12 * scale)
    # a label the test lacks leaves it alone; the mounted sensor alone reads torsion
    plain = _mounted([], (Actuator("end_a", "rx"),), sensors[2:3]).frf(MOUNT_FREQ)
    absent = {**mount, "sensor": "tip.z.acc"}
    H = _mounted([absent], (Actuator("end_a", "rx"),), sensors[:1]).frf(MOUNT_FREQ)
    assert np.abs(H).max() < 1e-9 * e * np.abs(plain).max()


def test_shaker_mounting_adds_a_torque_and_a_lateral_force():
    """A vertical shaker tilted by a towards y, its force line e off the axis: the
    recorded force F acts as F cos(a) in z, F sin(a) in y and the torque e F cos(a)
    about x (the input column of the model, and the FRF as the superposition of the
    three plain inputs)."""
    COVERED.add("shaker_mounting")
    e, a_deg = -0.002, 2.5
    a = np.deg2rad(a_deg)
    mount = {"name": "shaker_mounting", "actuator": "end_a.z",
             "parameters": {"offset_m": e, "misalignment_deg": a_deg}}
    sensors = (Sensor("quarter", "z"), Sensor("quarter", "y"), Sensor("end_b", "rx"))
    hw = _mounted([mount], (Actuator("end_a", "z"),), sensors)
    labels = hw.model.dof_labels
    column = dict(zip(labels, hw.model.B[:, 0], strict=True))
    assert {k: v for k, v in column.items() if v != 0} == pytest.approx(
        {"n0.z": np.cos(a), "n0.y": np.sin(a), "n0.rx": e * np.cos(a)}, rel=1e-15)
    plain = _mounted([], (Actuator("end_a", "z"), Actuator("end_a", "y"),
                          Actuator("end_a", "rx")), sensors).frf(MOUNT_FREQ)
    expected = plain @ np.array([np.cos(a), np.sin(a), e * np.cos(a)])
    H = hw.frf(MOUNT_FREQ)[..., 0]
    np.testing.assert_allclose(H, expected, rtol=0, atol=1e-12 * np.abs(expected).max())


def test_mountings_on_the_time_and_nonlinear_paths():
    """The time-stepped path with a nonlinear element sees the mounted channels: a
    mounted shaker and sensor give what the unmounted beam gives for the shaker's three
    force components and the sensor's three readings combined (same drive, so the same
    nonlinear motion, up to the solver's round-off)."""
    e_s, c, e_a, a_deg = 0.003, 0.02, 0.002, 2.0
    a = np.deg2rad(a_deg)
    cubic = {"name": "cubic_stiffness", "station": "mid", "direction": "z",
             "parameters": {"k3_n_m3": 1e9}}
    mounts = [{"name": "sensor_mounting", "sensor": 0,
               "parameters": {"offset_m": e_s, "cross_axis": c}},
              {"name": "shaker_mounting", "actuator": 0,
               "parameters": {"offset_m": e_a, "misalignment_deg": a_deg}}]
    fs, n = 1024.0, 2048
    t = np.arange(n) / fs
    u = 3.0 * (np.sin(2 * np.pi * 47.0 * t) + np.sin(2 * np.pi * 250.0 * t))[None, :]
    sim = dict(method="time", oversample=4)
    mounted = _mounted([cubic, *mounts], (Actuator("end_a", "z"),), (Sensor("quarter", "z"),))
    y = mounted.simulate(u, fs, **sim)[0]
    plain = _mounted([cubic], (Actuator("end_a", "z"), Actuator("end_a", "y"),
                               Actuator("end_a", "rx")),
                     (Sensor("quarter", "z"), Sensor("quarter", "rx"), Sensor("quarter", "y")))
    parts = plain.simulate(np.array([np.cos(a), np.sin(a), e_a * np.cos(a)])[:, None] * u,
                           fs, **sim)
    expected = parts[0] + e_s * parts[1] + c * parts[2]
    assert np.abs(y - expected).max() < 1e-9 * np.abs(expected).max()
    # and the mountings are there: the unmounted reading differs
    assert np.abs(y - parts[0]).max() > 1e-3 * np.abs(expected).max()


@pytest.mark.parametrize("entry, sensors, match", [
    ({"name": "sensor_mounting", "sensor": 3}, (Sensor("mid", "z"),), "sensor 3 does not"),
    ({"name": "sensor_mounting", "sensor": 0}, (Sensor("mid", "rx"),), "translational"),
    ({"name": "sensor_mounting", "sensor": 0}, (Sensor("mid", "z", "strain"),), "strain"),
    ({"name": "shaker_mounting", "actuator": 1}, (Sensor("mid", "z"),), "actuator 1 does"),
])
def test_mounting_bad_channels(entry, sensors, match):
    from truthbench.errors import ModelError

    entry = {**entry, "parameters": {"offset_m": 0.001}}
    with pytest.raises(ModelError, match=match):
        _mounted([entry], (Actuator("end_a", "z"),), sensors)


def test_every_registered_effect_is_tested():
    # runs last in this file (pytest keeps file order)
    assert set(EFFECTS) <= COVERED, sorted(set(EFFECTS) - COVERED)
