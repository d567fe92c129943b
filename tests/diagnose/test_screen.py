"""The exact screening of point attachments against the model rebuilt with them.

With physical damping only (dashpots; no modal damping ratio, which is defined on the
current modes and would move with them), the Woodbury update of the current FRF is the
FRF of the model with the attachment. Data made by the nominal model with an attachment
at a node: the screened residual of that node at that strength is the rebuilt model's
(zero), so the screened chi2 drop is the whole current chi2, to round-off; a node the
attachment is not at drops less. With a measurement delay in the data and the model, the
correction passes through it too."""

import numpy as np
import pytest

import truthbench.diagnose.screen as screen
from truthbench.diagnose.candidates import catalogue, references, with_node_stations
from truthbench.diagnose.data import prepare
from truthbench.diagnose.fit import Problem, evaluate
from truthbench.effects import realise
from truthbench.measure.frfdata import Channel, FRFData
from truthbench.plants import Actuator, Sensor, make_plant
from truthbench.update.predictor import PredictedTest

PLANT = with_node_stations(make_plant("free_free_beam", n_elements=20))
NOM = PLANT.resolve({"modal_damping_ratio": 0.0, "suspension_damping_n_s_m": 2.0})
F = np.linspace(2.0, 300.0, 150)
SENS = (Sensor("end_a", "z"), Sensor("mid", "z"), Sensor("end_b", "z", "velocity"))
ACTS = (Actuator("quarter", "z"),)


@pytest.mark.parametrize("effect,param,value", [
    ("grounded_spring", "stiffness_n_m", 2.0e3), ("grounded_dashpot", "damping_n_s_m", 15.0),
    ("added_mass", "mass_kg", 0.05)])
@pytest.mark.parametrize("delay_s", [0.0, 1e-3])
def test_screened_drop_is_the_rebuilt_models(effect, param, value, delay_s, monkeypatch):
    outs = tuple(Channel(s.label, s.quantity, "z", station=s.station) for s in SENS)
    ins = tuple(Channel(a.label, "force", "z", station=a.station) for a in ACTS)
    probe = FRFData("t", F, np.ones((F.size, 3, 1)), outs, ins)
    placed, (t0,) = prepare([probe], PLANT, NOM)
    cands = [c for c in catalogue(placed, NOM, [t0], names=(effect,)) if c.node in (7, 10)]
    at, other = cands
    truth = realise(placed, NOM, [(at.spec, {param: value})], actuators=ACTS, sensors=SENS)
    delayed = truth.frf(F) * np.exp(-2j * np.pi * F * delay_s)[:, None, None]
    data = FRFData("t", F, delayed, outs, ins)
    _, (t,) = prepare([data], PLANT, NOM)
    pt = (PredictedTest(t.name, t.freq_hz, t.actuators, t.sensors),)
    w = np.full(t.H.size, 1.0 / np.abs(t.H).max())
    declared = ("E_pa", "delay_s")
    problem = Problem(placed, dict(NOM), pt, t.H.ravel(), w, declared, {"delay_s": 1e-4})
    current = evaluate(problem, (), declared, {**problem.theta0(), "delay_s": delay_s})
    sizes = {k: v for c in cands for k, v in c.scales(references(placed, NOM, 300.0)).items()}
    size = sizes[at.keys()[0]]
    monkeypatch.setattr(screen, "GRID", np.array([value / size]))
    got = screen.point_profiles(problem, current, cands, sizes)
    drop, strength, _ = got[at.label]
    assert strength == pytest.approx(value, rel=1e-12)
    assert drop == pytest.approx(current.chi2, rel=1e-8)
    # the direct rebuild agrees: the model with the attachment reproduces the data
    pred = problem.predict(at.terms())
    rebuilt = problem.chi2(np.asarray(pred({**current.theta, at.keys()[0]: value})))
    assert rebuilt <= 1e-16 * current.chi2 * t.H.size
    assert got[other.label][0] < 0.99 * current.chi2


@pytest.mark.parametrize("d", [1, 2, 3])
def test_small_stacked_systems_are_solved_as_lapack_solves_them(d):
    rng = np.random.default_rng(d)
    shape = (7, 50)
    A = rng.standard_normal(shape + (d, d)) + 1j * rng.standard_normal(shape + (d, d)) \
        + 4 * np.eye(d)
    B = rng.standard_normal(shape + (d, 2)) + 1j * rng.standard_normal(shape + (d, 2))
    want = np.linalg.solve(A, B)
    got = screen.solve_small(A, B)
    # backward-stable solves of systems with condition numbers below ~10: a few eps
    assert np.abs(got - want).max() <= 64 * np.finfo(float).eps * np.abs(want).max()


def test_a_singular_small_system_is_reported_as_lapack_reports_it():
    A = np.ones((3, 2, 2), complex)
    with pytest.raises(np.linalg.LinAlgError):
        screen.solve_small(A, np.ones((3, 2, 1), complex))
