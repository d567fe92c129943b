"""The shared contract over every registered updater, and the registry itself."""

from __future__ import annotations

import numpy as np
import pytest

from truthbench.model import solve_modes
from truthbench.plants import Actuator, Sensor, make_plant
from truthbench.update.finite_difference import UpdateResult
from truthbench.update.registry import (
    UPDATERS,
    FiniteDifferenceUpdater,
    SensitivityUpdater,
    UpdateProblem,
    Updater,
    get_updater,
    make_updater,
    register_updater,
)
from truthbench.update.sensitivity import MeasuredModes

# one small truth problem carrying both kinds of data: a 3-D free-free tube, 2 groups,
# one shaker and five vertical accelerometers; E of both groups and rho of g2 are off
PLANT = make_plant("free_free_beam", n_elements=8, n_groups=2)
NOM = PLANT.resolve()
NAMES = ("E_pa@g1", "E_pa@g2", "rho_kg_m3@g2")
THETA0 = {**NOM, **{n: NOM[n.split("@")[0]] for n in NAMES}}
TRUTH = {**THETA0, "E_pa@g1": 1.03 * THETA0["E_pa@g1"], "E_pa@g2": 0.97 * THETA0["E_pa@g2"],
         "rho_kg_m3@g2": 1.04 * THETA0["rho_kg_m3@g2"]}
STATIONS = ("end_a", "quarter", "mid", "three_quarter", "end_b")
ACTS = [Actuator("end_a", "z")]
SENS = [Sensor(s, "z") for s in STATIONS]
FREQ = np.linspace(5.0, 700.0, 400)


def predict(theta):
    return PLANT.build(theta, ACTS, SENS).frf(FREQ)


def build_mk(theta):
    m = PLANT.build(theta)
    return m.M, m.K


def _measured():
    model = PLANT.build(TRUTH)
    modes = solve_modes(model.M, model.K)
    dofs = np.array([model.dof_labels.index(f"n{PLANT.station_node(s)}.z") for s in STATIONS])
    z = np.array([i for i, lab in enumerate(model.dof_labels) if lab.endswith(".z")])
    tr = np.array([i for i, lab in enumerate(model.dof_labels)
                   if lab.split(".")[1] in ("x", "y", "z")])
    share = np.sum(modes.shapes[z] ** 2, 0) / np.sum(modes.shapes[tr] ** 2, 0)
    pick = np.nonzero((share > 0.9) & (modes.freq_hz > 10) & (modes.freq_hz < 700))[0]
    return MeasuredModes(modes.freq_hz[pick], -2.5 * modes.shapes[np.ix_(dofs, pick)], dofs)


PROBLEM = UpdateProblem(names=NAMES, theta0=THETA0, predict_frf=predict,
                        frf_data=predict(TRUTH), n_pairs=len(ACTS) * len(SENS),
                        build_mk=build_mk, measured=[_measured()])


@pytest.mark.parametrize("name", sorted(UPDATERS))
def test_contract(name):
    updater = get_updater(name)
    assert isinstance(updater, Updater) and updater.name == name
    res = updater.update(PROBLEM)
    p = len(NAMES)
    assert isinstance(res, UpdateResult)
    assert res.method == name and res.names == NAMES
    assert res.converged
    truth = np.array([TRUTH[n] for n in NAMES])
    np.testing.assert_allclose(res.values, truth, rtol=5e-3)
    np.testing.assert_allclose(res.initial, [THETA0[n] for n in NAMES])
    assert res.history.shape == (res.n_iterations + 1, p)
    assert res.cost_history.shape == (res.n_iterations + 1,)
    assert res.cost_history[-1] < res.cost_history[0]
    assert res.singular_values.shape == (p,) and np.all(res.singular_values > 0)
    assert res.condition_number >= 1
    assert res.correlation.shape == (p, p)
    np.testing.assert_allclose(np.diag(res.correlation), 1.0)
    assert dict(PROBLEM.theta0) == THETA0  # the problem is untouched


@pytest.mark.parametrize("name", sorted(UPDATERS))
def test_missing_data_is_named(name):
    bare = UpdateProblem(names=NAMES, theta0=THETA0)
    with pytest.raises(ValueError, match=rf"updater '{name}' needs \[.+\] in the UpdateProblem"):
        get_updater(name).update(bare)


def test_specific_missing_fields_and_options():
    only_frf = UpdateProblem(names=NAMES, theta0=THETA0, predict_frf=predict,
                             frf_data=PROBLEM.frf_data)
    with pytest.raises(ValueError, match=r"'finite_difference' needs \['n_pairs'\]"):
        get_updater("finite_difference").update(only_frf)
    with pytest.raises(ValueError, match=r"'sensitivity' needs \['build_mk', 'measured'\]"):
        get_updater("sensitivity").update(only_frf)
    # settings live in the updater object, read from a campaign's [update] mapping
    modal = UpdateProblem(names=NAMES, theta0=THETA0, build_mk=build_mk,
                          measured=PROBLEM.measured)
    one = make_updater("sensitivity", {"max_iterations": 1, "relative_step": 1e-3})
    assert one.max_iterations == 1 and one == SensitivityUpdater(max_iterations=1)
    with pytest.warns(UserWarning, match="did not converge in 1 iterations"):
        assert not one.update(modal).converged
    with pytest.raises(ValueError, match="'scheme' must be one of 'central', 'forward'; "
                                         "got 'backward'"):
        make_updater("finite_difference", {"scheme": "backward"})
    with pytest.raises(ValueError, match="'max_iterations' must be an integer >= 1; got 0"):
        FiniteDifferenceUpdater(max_iterations=0)
    with pytest.raises(ValueError, match="'names' is empty"):
        UpdateProblem(names=(), theta0=THETA0)


@pytest.mark.parametrize("name", sorted(UPDATERS))
def test_declared_needs_and_supported_parameters(name):
    """Every updater declares the inputs it reads (and fails naming them when they are
    absent) and refuses, with a reason, the parameter kinds it cannot update."""
    updater = get_updater(name)
    assert updater.needs and updater.needs <= {"frf", "modes"}
    problem = UpdateProblem(names=NAMES, theta0=THETA0)
    assert problem.missing(sorted(updater.needs))
    refused = updater.unsupported({"E_pa": "plant", "delay_s": "appended",
                                   "joint.stiffness_loss": "effect"})
    assert "E_pa" not in refused
    assert all(isinstance(why, str) and why for why in refused.values())


def test_registry():
    assert {"finite_difference", "sensitivity"} <= set(UPDATERS)
    with pytest.raises(ValueError,
                       match=r"unknown updater 'kalman'; expected one of \['finite_difference', "
                             r"'sensitivity'"):
        get_updater("kalman")
    with pytest.raises(ValueError, match="already registered"):
        register_updater(SensitivityUpdater)
    with pytest.raises(TypeError):
        UPDATERS["x"] = None  # read-only view
