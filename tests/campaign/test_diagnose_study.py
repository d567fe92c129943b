"""The diagnose-study: its draws, the two truth forms, the form-independent sizes, the
scores, and a short study end to end."""

import tomllib
from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest

from truthbench.campaign.diagnose_study import (
    AVERAGES,
    CROSS_AXIS,
    FORMS,
    MISALIGNMENT_DEG,
    OFFSET_M,
    REFINE,
    TARGETS,
    WINDOWS,
    Placed,
    draw_trial,
    effect_size,
    element_bending,
    joint_loss,
    joint_stiffness,
    run_study,
    score,
    truth_of,
)
from truthbench.campaign.plan import CampaignPlan
from truthbench.campaign.spec import load_campaign, parse_campaign
from truthbench.campaign.truth import build_hardware
from truthbench.diagnose.core import Found
from truthbench.fe.beam import element_matrices

from .conftest import ROOT

STUDY = ROOT / "campaigns" / "diagnose_study.toml"


@pytest.fixture(scope="module")
def spec():
    return load_campaign(STUDY)


def test_draws_are_reproducible_and_shared_by_the_two_forms(spec):
    seed = spec.campaign.seed
    draws = [draw_trial(spec, t, seed) for t in range(12)]
    assert draws == [draw_trial(spec, t, seed) for t in range(12)]
    assert draw_trial(spec, 3, seed) == draws[3]  # no state between trials
    assert draws[0] != draws[1] and draw_trial(spec, 0, seed + 1) != draws[0]
    for d in draws:
        other, same = (truth_of(spec, d, form) for form in FORMS)
        # the same injected effects, strengths, sensors; the same records
        assert [(p.effect, p.strength, p.sensor) for p in other.placed] == \
            [(p.effect, p.strength, p.sensor) for p in same.placed] == \
            [(i.effect, i.value, i.options.get("sensor")) for i in d.injected]
        for a, b, m in zip(other.spec.tests, same.spec.tests, d.measurement, strict=True):
            assert (a.record_s, a.averages, a.window) == (b.record_s, b.averages, b.window) \
                == (m.record_s, m.averages, m.window)
            assert m.averages in AVERAGES and m.window in WINDOWS
            assert a.record_s / a.averages * a.fs_hz == int(a.record_s / a.averages * a.fs_hz)
        # a joint's size is the same joint in both forms
        for p, q in zip(other.placed, same.placed, strict=True):
            assert p.size == pytest.approx(q.size, rel=1e-12)


def test_the_other_form_truth_is_not_the_model(spec):
    """A mesh 3, 4 or 6 times finer keeping every model node (sensors, shakers and
    suspension points where the model has them), Timoshenko on and off, effects at
    fine nodes (most between the model's), channels mounted within the drawn ranges."""
    seed = spec.campaign.seed
    model = spec.make_plant()
    nominal = spec.nominal_parameters()
    n = model.n_elements
    refine, timoshenko, off_node, placed = set(), set(), 0, 0
    for t in range(60):
        d = draw_trial(spec, t, seed)
        truth = truth_of(spec, d, "other")
        plant = truth.spec.make_plant()
        assert plant.n_elements == n * d.other.refine
        refine.add(d.other.refine)
        timoshenko.add(d.other.timoshenko)
        for station in ("end_a", "quarter", "mid", "end_b"):
            np.testing.assert_allclose(plant.station_coordinates_m(station, nominal),
                                       model.station_coordinates_m(station, nominal),
                                       atol=1e-12)
        x_fine, x_model = plant.node_x_m(nominal), model.node_x_m(nominal)
        np.testing.assert_allclose(x_fine[list(plant.suspension_nodes())],
                                   x_model[list(model.suspension_nodes())], atol=1e-12)
        names = [e.name for e in truth.effects]
        assert ("element_physics" in names) == d.other.timoshenko
        assert truth.allowed == ({"element_physics"} if d.other.timoshenko else set())
        assert names.count("sensor_mounting") == 4 and names.count("shaker_mounting") == 2
        for _, e, c in d.other.sensors:
            assert OFFSET_M[0] <= abs(e) <= OFFSET_M[1] and CROSS_AXIS[0] <= abs(c) <= CROSS_AXIS[1]
        for _, e, a in d.other.shakers:
            assert OFFSET_M[0] <= abs(e) <= OFFSET_M[1]
            assert MISALIGNMENT_DEG[0] <= abs(a) <= MISALIGNMENT_DEG[1]
        for p in truth.placed:
            if p.x_m is None:
                continue
            x = p.x_m - (0.5 * (x_fine[1] - x_fine[0]) if p.effect == "joint" else 0.0)
            node = int(np.argmin(np.abs(x_fine - x)))
            assert abs(x_fine[node] - x) < 1e-12 and 0 < node < plant.n_elements
            placed += 1
            off_node += node % d.other.refine != 0
    assert refine == set(REFINE) and timoshenko == {True, False}
    assert placed >= 20 and off_node > 0.5 * placed


def _torsion_view(spec, trial, mounted: bool):
    seed = spec.campaign.seed
    truth = truth_of(spec, draw_trial(spec, trial, seed), "other")
    effects = [e for e in truth.effects if mounted or not e.name.endswith("_mounting")]
    plan = CampaignPlan.compile(truth.spec)
    return build_hardware(plan, plan.tests[0], trial, seed, effects)


def test_the_torsion_mode_is_in_the_band_and_seen_only_through_the_mountings(spec):
    """The truth's first torsion mode lies in the tests' band. The mounted sensors off its
    node read it: the change the mountings make peaks at the torsion frequency, at a
    few percent of the FRF's own peak (2 % sensor noise per line is averaged down by
    the 4-16 averages); at the mid sensor (the torsion node) it does not."""
    from truthbench.model import modal_table

    hw = _torsion_view(spec, 5, mounted=True)
    plain = _torsion_view(spec, 5, mounted=False)
    torsion = [r["freq_hz"] for r in modal_table(hw.model, hw.modes)
               if r["shape"].startswith("torsion")]
    band = spec.tests[0].band_hz
    assert band[0] < torsion[0] < band[1]
    f = np.arange(band[0], band[1], 0.25)
    H, H0 = hw.frf(f)[..., 0], plain.frf(f)[..., 0]
    change = np.abs(H - H0)
    # a resonance's peak lies within its half-power half-width, zeta f, of the mode
    width = spec.plant.parameters["modal_damping_ratio"] * torsion[0]
    labels = [s.label for s in hw.sensors]
    for k, label in enumerate(labels):
        if label == "mid.z.acc":
            assert abs(f[np.argmax(change[:, k])] - torsion[0]) > width
            continue
        assert abs(f[np.argmax(change[:, k])] - torsion[0]) <= width
        assert change[:, k].max() > 0.005 * np.abs(H0[:, k]).max()


def test_joint_size_is_the_element_rotational_flexibility(spec):
    """An element of stiffness EI (1 - loss), clamped at one end, turns under an end
    moment by its sound rotation plus M / k: k from the element stiffness matrix equals
    :func:`joint_stiffness`; and the study's joint in a fine element has the model
    element's k."""
    plant = spec.make_plant()
    params = spec.nominal_parameters()
    EI, h = element_bending(plant, params, 5, "ry")
    props = plant.group_properties(params)["beam"]
    from truthbench.fe.assembly import group_section

    ke, _ = element_matrices(params["E_pa"], params["nu"], params["rho_kg_m3"],
                             group_section(props), h)
    ry_b = 6 + 4  # node B's rotation about y
    free = [6 + i for i in range(6)]
    loss = 0.3
    turn = []
    for scale in (1.0, 1.0 - loss):
        f = np.zeros(6)
        f[ry_b - 6] = 1.0  # a unit moment about y at node B, node A clamped
        turn.append(np.linalg.solve(scale * ke[np.ix_(free, free)], f)[ry_b - 6])
    assert 1.0 / (turn[1] - turn[0]) == pytest.approx(joint_stiffness(EI, h, loss), rel=1e-12)
    assert joint_loss(EI, h, joint_stiffness(EI, h, loss)) == pytest.approx(loss, rel=1e-14)
    # the same joint in an element a third as long is a larger loss of that element
    assert joint_loss(EI, h / 3, joint_stiffness(EI, h, loss)) == pytest.approx(
        3 * loss / (3 * loss + 1 - loss), rel=1e-14)
    assert effect_size("joint", {"stiffness_loss": loss}, (EI, h)) == \
        joint_stiffness(EI, h, loss)


def _found(effect, node=None, **parameters):
    options = {"station": f"n{node}"} if node is not None else {}
    if effect == "joint":
        options["direction"] = "ry"
    return Found(effect, options, parameters, {}, {}, 50.0, node, effect)


def _diag(spec, found):
    """What :func:`score` reads of a diagnosis."""
    nominal = spec.nominal_parameters()
    return SimpleNamespace(found=tuple(found), plant=spec.make_plant(), nominal=nominal,
                           declared_values=lambda: {"E_pa": nominal["E_pa"]})


def test_score(spec):
    """What each score counts, on made-up findings: element_physics is neither a false
    alarm nor a wrong first finding where it is allowed; sizes and places of the right
    findings."""
    x = spec.make_plant().node_x_m(spec.nominal_parameters())
    h = x[1] - x[0]
    # clean
    ep = _found("element_physics", scale=1.0)
    assert score((), _diag(spec, [ep]), allowed={"element_physics"})["nothing_found"]
    assert not score((), _diag(spec, [ep]))["nothing_found"]
    assert score((), _diag(spec, []))["nothing_found"]
    # one joint, in the model element from node 7, 30 % loss, found at node 7 with 33 %
    EI, _ = element_bending(spec.make_plant(), spec.nominal_parameters(), 7, "ry")
    k = joint_stiffness(EI, h, 0.3)
    joint = Placed("joint", "stiffness_loss", 0.3, 0.3, k, float(x[7] + h / 2), None)
    row = score([joint], _diag(spec, [ep, _found("joint", 7, stiffness_loss=0.33)]),
                allowed={"element_physics"})
    assert row["first_correct"] and row["exact"] and row["all_found"] and row["allowed_found"]
    assert row["first_found"] == "joint"
    assert row["size_error0"] == pytest.approx(
        abs(joint_stiffness(EI, h, 0.33) - k) / k, rel=1e-12)
    assert row["location_error_m0"] == pytest.approx(0.0, abs=1e-12) and row["located0"]
    # found one element away: still located; two away: not
    row = score([joint], _diag(spec, [_found("joint", 8, stiffness_loss=0.3)]))
    assert row["location_error_m0"] == pytest.approx(h) and row["located0"]
    row = score([joint], _diag(spec, [_found("joint", 9, stiffness_loss=0.3)]))
    assert not row["located0"]
    # a wrong first finding, then the right one and an unallowed element_physics
    row = score([joint], _diag(spec, [_found("added_mass", 7, mass_kg=0.01),
                                      _found("joint", 7, stiffness_loss=0.3), ep]))
    assert not row["first_correct"] and not row["exact"] and row["all_found"]
    assert row["size_error0"] == pytest.approx(0.0, abs=1e-12)
    # a channel gain: located by its sensor; two effects, one found
    gain = Placed("channel_gain", "gain_error", 0.2, 0.2, 0.2, None, "mid.z.acc")
    g = Found("channel_gain", {"sensor": "mid.z.acc"}, {"gain_error": 0.21}, {}, {}, 50.0,
              None, "g")
    row = score([gain, joint], _diag(spec, [g]))
    assert row["located0"] and row["size_error0"] == pytest.approx(0.05, rel=1e-12)
    assert not row["all_found"] and row["located1"] is None
    assert np.isnan(row["size_error1"])


def _small_study(tmp_path):
    d = tomllib.loads(STUDY.read_text())
    d["plant"]["n_elements"] = 8
    d["sensors"] = d["sensors"][:3]
    for t in d["tests"][:1]:
        t.update(band_hz=[2.0, 150.0], fs_hz=512.0, record_s=4.0, averages=4)
    d["tests"] = d["tests"][:1]
    d["diagnose"]["candidates"] = ["added_mass", "channel_gain"]
    d["diagnose"]["max_effects"] = 1
    d["diagnose"]["study"].update(inject=["added_mass", "channel_gain"], trials=3,
                                  clean_fraction=0.3, two_fraction=0.0)
    return parse_campaign(d, str(tmp_path / "small.toml"))


@pytest.mark.slow
def test_a_short_study_end_to_end(tmp_path, monkeypatch):
    """Three trials in both forms: one row per trial and form with the same draws, a
    summary per form, scores with their targets, the report side by side, and no
    backend chosen by the library."""
    import matplotlib

    from truthbench.report.diagnosis import write_study

    spec = _small_study(tmp_path)
    result = run_study(spec, trials=3)
    df = result.trials
    assert sorted(zip(df.trial, df.form, strict=True)) == \
        sorted((t, f) for t in range(3) for f in FORMS)
    for _, g in df.groupby("trial"):
        assert g.injected.nunique() == 1
        if g.n_injected.iloc[0]:
            assert g.strength0.nunique() == 1
    summary = result.to_pandas("summary")
    assert list(summary.form) == list(FORMS)
    assert (summary["trials"] == 3).all()
    scores = result.to_pandas("scores")
    assert scores.loc["right effect first", "target"] == TARGETS["right effect first"]
    assert set(scores.columns) == {"target", *FORMS}
    assert (df.seconds > 0).all()

    def refuse(*args, **kwargs):
        raise AssertionError("library code chose a matplotlib backend")

    monkeypatch.setattr(matplotlib, "use", refuse)
    html = write_study(result, tmp_path / "out")
    md = (tmp_path / "out" / "study.md").read_text()
    assert "| score | target (other form) | other form | same form |" in md
    assert ">= 95 %" in md and "Confusion, other form" in md and "Confusion, same form" in md
    assert html.exists() and (tmp_path / "out" / "detection.png").exists()
    # one form only
    one = replace(result, trials=df[df.form == "other"])
    assert list(one.to_pandas("summary").form) == ["other"]
