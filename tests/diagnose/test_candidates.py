"""Candidates as model terms: a parameter held at its bound, and a joint carried to a
refined mesh.

A parameter held at its bound (:meth:`Candidate.pin`) must enter the model exactly as the
free parameter at that value. A joint is a hinge at a point: carried to the mesh halved
it must stay at that point with the same rotational stiffness, so that the refined model
converges to the one on a much finer mesh with the same hinge."""

from dataclasses import replace

import numpy as np
import pytest

from truthbench.diagnose.candidates import at_fraction, catalogue, with_node_stations
from truthbench.diagnose.core import _refined_candidate, _refined_theta
from truthbench.diagnose.data import prepare
from truthbench.diagnose.fit import Problem
from truthbench.measure.frfdata import Channel, FRFData
from truthbench.plants import Actuator, Sensor, make_plant
from truthbench.update.predictor import PredictedTest

F = np.linspace(5.0, 400.0, 40)
SENS = (Sensor("end_a", "z"), Sensor("end_b", "z"))
ACTS = (Actuator("mid", "z"),)


def _problem(n_elements: int, stations=None):
    plant = with_node_stations(make_plant("free_free_beam", n_elements=n_elements))
    if stations:
        plant = replace(plant, stations={**plant.stations, **stations})
    nom = plant.resolve({})
    outs = tuple(Channel(s.label, s.quantity, "z", station=s.station) for s in SENS)
    ins = tuple(Channel(a.label, "force", "z", station=a.station) for a in ACTS)
    probe = FRFData("t", F, np.ones((F.size, len(SENS), 1)), outs, ins)
    placed, (t,) = prepare([probe], plant, nom)
    pt = (PredictedTest(t.name, t.freq_hz, t.actuators, t.sensors),)
    w = np.ones(t.H.size)
    problem = Problem(placed, dict(nom), pt, t.H.ravel(), w, ("E_pa",), {})
    return problem, placed, nom, t


def _joint(placed, nom, t, node):
    return next(c for c in catalogue(placed, nom, [t], names=("joint",))
                if c.node == node and c.options["direction"] == "ry")


def test_joint_candidates_are_hinges_at_the_element_centres():
    problem, placed, nom, t = _problem(10)
    joints = [c for c in catalogue(placed, nom, [t], names=("joint",))
              if c.options["direction"] == "ry"]
    assert [c.node for c in joints] == list(range(10))
    assert all(c.options["form"] == "hinge" for c in joints)
    assert [placed.stations[c.options["station"]] for c in joints] == pytest.approx(
        (np.arange(10) + 0.5) / 10, abs=1e-12)


@pytest.mark.parametrize("between", [False, True])
def test_a_pinned_parameter_enters_the_model_at_its_value(between):
    problem, placed, nom, t = _problem(10, {"x0.370000": 0.37})
    c = _joint(placed, nom, t, 3)
    if between:  # a hinge off the element's centre (not affine in the loss)
        c = at_fraction(c, 0.37, 10)
    theta = {**problem.theta0(), f"{c.label}.stiffness_loss": 0.3,
             f"{c.label}.damping_n_m_s_rad": 0.0}
    free = np.asarray(problem.predict(c.terms())(theta))
    pinned = c.pin({"damping_n_m_s_rad": 0.0})
    assert pinned.keys() == (f"{c.label}.stiffness_loss",)
    held = np.asarray(problem.predict(pinned.terms())(
        {k: v for k, v in theta.items() if not k.endswith("damping_n_m_s_rad")}))
    np.testing.assert_array_equal(held, free)
    assert pinned.effect_values({"stiffness_loss": 0.3}) == {
        "stiffness_loss": 0.3, "damping_n_m_s_rad": 0.0}


def _bending_hz(problem, cand, theta, count=5):
    """The lowest elastic frequencies above the suspension's (which sit below 10 Hz)."""
    hw = problem.predictor(cand.terms()).hardware({**problem.theta0(), **theta})
    f = np.sort(hw.modes.freq_hz)
    return f[f > 10.0][:count]


def test_a_joint_keeps_its_point_and_stiffness_when_the_mesh_is_refined():
    loss = 0.5
    coarse, placed, nom, t = _problem(20, {"x0.370000": 0.37})
    c = at_fraction(_joint(placed, nom, t, 7), 0.37, 20)  # element 7, xi = 0.4
    fine, _, _, _ = _problem(40, {"x0.370000": 0.37})
    renamed = {f"n{k}": f"n{2 * k}" for k in range(21)}
    (new, station) = _refined_candidate(c, renamed, coarse.plant)
    assert station == {"x0.370000": 0.37}
    assert new.label == c.label and new.node == 14  # 0.37 * 40 = 14.8
    theta = _refined_theta({f"{c.label}.stiffness_loss": loss,
                            f"{c.label}.damping_n_m_s_rad": 0.0}, [c], [new])
    assert theta[f"{new.label}.stiffness_loss"] == pytest.approx(2 * loss / (1 + loss))
    refined = _bending_hz(fine, new, theta)
    # the reference: 160 elements, the same hinge (the loss of one element of h/8 with
    # the same rotational stiffness: 8 L / (1 + 7 L)); the meshes' own differences out
    ref_p, _, _, _ = _problem(160, {"x0.370000": 0.37})
    r = at_fraction(c, 0.37, 160)
    reference = _bending_hz(ref_p, r, {f"{r.label}.stiffness_loss": 8 * loss / (1 + 7 * loss)})
    own = _bending_hz(fine, c, {}) / _bending_hz(ref_p, c, {}) - 1
    assert np.abs(refined / reference - 1 - own).max() < 1e-3
