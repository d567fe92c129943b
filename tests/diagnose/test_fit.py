"""Fits through the estimator's leakage computed at every parameter value.

An averaged H1 of a lightly damped suspension mode that falls between lines is seen only
through its leakage. A fit normally holds the leakage offset computed where it starts; a
support's stiffness is fitted with the leakage computed at every value tried
(``fit(..., estimator=True)``), and the fit is then evaluated with the offset at its
optimum, so that its model is the estimator's there. Data: noise-free, through the same
estimator, of the model with both supports 1.8 times stiffer (a check of the fitter's
bookkeeping; the diagnosis is graded on truths of another form in
``test_other_form.py`` and the study)."""

import numpy as np
import pytest

from truthbench.diagnose.candidates import catalogue, with_node_stations
from truthbench.diagnose.data import prepare
from truthbench.diagnose.fit import Problem, fit, with_offsets
from truthbench.measure.frfdata import Channel, FRFData
from truthbench.measure.leakage import h1_kernel
from truthbench.plants import Actuator, Sensor, make_plant
from truthbench.update.predictor import PredictedTest

PLANT = with_node_stations(make_plant("free_free_beam", n_elements=20))
NOM = PLANT.resolve({})
DF, FS = 1.0, 1024.0
F = np.arange(2.0, 120.0 + DF / 2, DF)
SENS = (Sensor("end_a", "z"), Sensor("mid", "z"))
ACTS = (Actuator("quarter", "z"),)


def _problem():
    outs = tuple(Channel(s.label, s.quantity, "z", station=s.station) for s in SENS)
    ins = tuple(Channel(a.label, "force", "z", station=a.station) for a in ACTS)
    probe = FRFData("t", F, np.ones((F.size, 2, 1)), outs, ins)
    placed, (t,) = prepare([probe], PLANT, NOM)
    (c,) = [c for c in catalogue(placed, NOM, [t], names=("boundary",)) if c.node is None
            and c.label == "boundary"]
    kernel = h1_kernel("bartlett", int(FS / DF), FS)
    pt = (PredictedTest(t.name, t.freq_hz, t.actuators, t.sensors, kernel=kernel),)
    declared = ("E_pa",)
    key = c.keys()[0]
    probe_problem = Problem(placed, dict(NOM), pt, np.ones(F.size * 2, complex),
                            np.ones(F.size * 2), declared, {key: 0.5})
    truth = {**probe_problem.theta0(c.terms()), key: np.log(1.8)}
    data = np.asarray(probe_problem.predict(c.terms(), estimator=True)(truth))
    weights = 1.0 / (np.abs(data) + np.median(np.abs(data)))
    problem = Problem(placed, dict(NOM), pt, data, weights, declared, {key: 0.5},
                      settings={"max_iterations": 30, "tolerance": 1e-8})
    return problem, c, key, truth


def test_a_fit_through_the_estimator_is_evaluated_with_the_leakage_at_its_optimum():
    problem, c, key, truth = _problem()
    start = {**truth, key: np.log(1.5)}
    terms = c.terms(start={key.rsplit(".", 1)[1]: start[key]})
    held = with_offsets(problem, terms=terms, theta=start)
    before = held.chi2(np.asarray(held.predict(terms)(start)))
    got = fit(held, terms, start=start, estimator=True)
    exact = np.asarray(problem.predict(terms, estimator=True)(got.theta))
    # the same sums (the kernel's few hundred terms per line) in another order
    assert np.abs(got.model - exact).max() <= 1e-12 * np.abs(exact).max()
    assert got.chi2 == pytest.approx(problem.chi2(exact), rel=1e-9)
    assert got.chi2 < before
