"""The analytic FRF Jacobian against central differences of the predictor itself.

Tolerance, per parameter column (norms over every FRF entry): a central difference
``D(h)`` errs by truncation (``c h^2``, four times that at ``2h``) and rounding (the
prediction's rounding over ``h``, larger at the smaller step); the step where ``D(h)``
and ``D(2h)`` agree best is the best the differences can do, and their difference bounds
the error of either (twice it is allowed). The analytic column must lie within it, and
the column must be a hundred times larger than the tolerance, so that a missing term
(the modal damping's dependence on the natural frequency, the eigenvector derivative, a
dashpot's term: relative sizes of 1e-3 to 1) would fail.
"""

import numpy as np
import pytest

from truthbench.plants import Actuator, Sensor, make_plant
from truthbench.update import FRFPredictor, PredictedTest
from truthbench.update.finite_difference import sensitivity_matrix

EPS = np.finfo(float).eps
STEPS = (1e-2, 5e-3, 2e-3, 1e-3, 5e-4, 2e-4, 1e-4, 5e-5, 2e-5, 1e-5)


def _check(pred, theta, names, additive=None):
    S = pred.jacobian(theta, names, additive=additive)
    assert S is not None
    G = pred.predict_vector(theta)
    D = {h: sensitivity_matrix(pred.predict_vector, theta, names, relative_step=h,
                               additive=additive)[0] for h in STEPS}
    assert S.shape == D[STEPS[0]].shape == (G.size, len(names))
    for k, name in enumerate(names):
        # the step where two central differences (h and 2h) agree best: their
        # difference bounds the error of each (truncation, 3 c h^2, and rounding alike)
        diffs = {h: np.linalg.norm(D[h][:, k] - D[2 * h][:, k]) for h in STEPS
                 if 2 * h in D}
        h = min(diffs, key=diffs.get)
        tol = 2 * diffs[h]
        err = np.linalg.norm(S[:, k] - D[h][:, k])
        scale = np.linalg.norm(D[h][:, k])
        assert err <= tol, (name, h, err / scale, tol / scale)
        assert scale > 100 * tol, (name, h, tol / scale)  # a wrong column would show


def test_free_free_beam_modal_damping_suspension_and_appended_parameters():
    """A rectangular bar: a round tube's y and z bending pairs are degenerate up to the
    suspension's effect (gaps of 1e-8 to 1e-6), where the eigensolver's basis within a
    pair, and so the differences, are not smooth at the level the tolerance asks."""
    plant = make_plant("free_free_beam", n_elements=8, section="rectangular_bar")
    nominal = {"modal_damping_ratio": 0.01, "suspension_stiffness_n_m": 200.0,
               "b_m": 0.03, "h_m": 0.02}
    sens = (Sensor("end_a", "z", "acceleration"), Sensor("mid", "z", "velocity"),
            Sensor("quarter", "z", "displacement"), Sensor("mid", "y", "acceleration"))
    tests = [PredictedTest("a", np.linspace(5.0, 400.0, 160), (Actuator("end_a", "z"),),
                           sens),
             PredictedTest("b", np.linspace(3.0, 300.0, 90), (Actuator("quarter", "z"),),
                           sens[:2], decay_rad_s=2.0)]
    pred = FRFPredictor(plant, nominal, tests)
    theta = dict(pred.theta0)
    theta.update(E_pa=theta["E_pa"] * 1.02, rho_kg_m3=theta["rho_kg_m3"] * 0.99,
                 delay_s=3e-4, sensor_gain=1.01)
    names = ["E_pa", "rho_kg_m3", "modal_damping_ratio", "suspension_stiffness_n_m",
             "delay_s", "sensor_gain"]
    _check(pred, theta, names, additive=pred.additive_scales(names))


def test_hub_beam_with_a_non_proportional_dashpot_and_a_strain_gauge():
    plant = make_plant("hub_beam", n_elements=8)
    nominal = {"hub_damping_n_m_s_rad": 5.0, "modal_damping_ratio": 0.003}
    sens = (Sensor("hub", "rz", "velocity"), Sensor("root", "y", "strain"),
            Sensor("tip", "y", "acceleration"))
    tests = [PredictedTest("hub", np.linspace(0.5, 150.0, 200), (Actuator("hub", "rz"),),
                           sens),
             PredictedTest("tip", np.linspace(0.5, 150.0, 200), (Actuator("tip", "y"),),
                           sens)]
    pred = FRFPredictor(plant, nominal, tests)
    theta = dict(pred.theta0)
    theta.update(E_pa=theta["E_pa"] * 0.98, hub_inertia_kg_m2=theta["hub_inertia_kg_m2"] * 1.03,
                 hub_damping_n_m_s_rad=7.0)
    _check(pred, theta, ["E_pa", "hub_inertia_kg_m2", "hub_damping_n_m_s_rad",
                         "modal_damping_ratio", "rho_kg_m3"])


def test_the_channels_blocks_alone_give_the_whole_models_jacobian():
    """Channels in one bending plane: the Jacobian on that plane's block of DOFs (a third
    of the modes) equals the one in the complete basis of the whole model."""
    from truthbench.update.jacobian import channel_subspace, structural_frf_jacobian

    plant = make_plant("free_free_beam", n_elements=8, section="rectangular_bar")
    nominal = {"modal_damping_ratio": 0.01, "b_m": 0.03, "h_m": 0.02}
    sens = (Sensor("end_a", "z", "acceleration"), Sensor("mid", "z", "velocity"))
    f = np.linspace(5.0, 400.0, 120)
    pred = FRFPredictor(plant, nominal, [PredictedTest("a", f, (Actuator("end_a", "z"),),
                                                       sens)])
    theta = {**pred.theta0, "E_pa": pred.theta0["E_pa"] * 1.02}
    names = ["E_pa", "rho_kg_m3", "suspension_stiffness_n_m"]
    hw = pred.hardware(theta)
    pred.jacobian(theta, names)
    macros = pred._macro_cache[tuple(names)].at(theta, hw.model)
    small, modes, sub = channel_subspace(hw.model, hw.modes, macros, 1)
    assert small.n_dofs == modes.n_modes < hw.model.n_dofs / 2
    s = 2j * np.pi * f
    whole = structural_frf_jacobian(hw.model, hw.modes, macros, s, 1)
    part = structural_frf_jacobian(small, modes, sub, s, 1)
    for k in range(len(names)):
        assert np.linalg.norm(part[k] - whole[k]) <= 1e-7 * np.linalg.norm(whole[k]), k


@pytest.mark.parametrize("plant_kind", ["hub_beam", "free_free_beam"])
def test_a_reduced_predictor_has_the_analytic_jacobian(plant_kind):
    """A predictor that solves only the channels' blocks (``reduced``) and keeps every
    mode of them: the Jacobian on those blocks, against differences of that predictor;
    with modes left out (``mode_tolerance``) there is none (finite differences)."""
    plant = make_plant(plant_kind, n_elements=8)
    if plant_kind == "hub_beam":
        nominal = {"hub_damping_n_m_s_rad": 5.0, "modal_damping_ratio": 0.003}
        sens = (Sensor("hub", "rz", "velocity"), Sensor("root", "y", "strain"),
                Sensor("tip", "y", "acceleration"))
        acts = (Actuator("hub", "rz"), Actuator("tip", "y"))
        names = ["E_pa", "hub_inertia_kg_m2", "hub_damping_n_m_s_rad"]
    else:  # a round tube measured in z: its y and z pairs no longer meet
        nominal = {"modal_damping_ratio": 0.01}
        sens = (Sensor("end_a", "z", "acceleration"), Sensor("mid", "z", "velocity"))
        acts = (Actuator("end_a", "z"), Actuator("quarter", "z"))
        names = ["E_pa", "rho_kg_m3", "suspension_stiffness_n_m"]
    tests = [PredictedTest(a.station, np.linspace(0.5, 300.0, 200), (a,), sens)
             for a in acts]
    pred = FRFPredictor(plant, nominal, tests, reduced=True)
    theta = {**pred.theta0, "E_pa": pred.theta0["E_pa"] * 0.98}
    assert pred.hardware(theta).modes.n_modes < pred.hardware(theta).model.n_dofs
    _check(pred, theta, names)
    lossy = FRFPredictor(plant, nominal, tests, reduced=True, mode_tolerance=1e-12)
    assert lossy.jacobian(theta, names) is None


def test_macroelements_follow_theta_and_relinearise_for_a_nonlinear_parameter():
    """E and rho enter linearly: one set of macroelements serves every theta (checked
    against the built matrices); the radius does not: they are taken anew, and the
    Jacobian still matches the differences."""
    plant = make_plant("free_free_beam", n_elements=6)
    tests = [PredictedTest("a", np.linspace(5.0, 300.0, 80), (Actuator("end_a", "z"),),
                           (Sensor("end_b", "z"),))]
    pred = FRFPredictor(plant, {"modal_damping_ratio": 0.01}, tests)
    theta = dict(pred.theta0)
    for scale in (1.0, 1.01, 1.03):
        theta["E_pa"] = pred.theta0["E_pa"] * scale
        _check(pred, theta, ["E_pa", "rho_kg_m3"])
    assert pred._macro_cache[("E_pa", "rho_kg_m3")].relinearisations == 1
    theta["r_m"] = pred.theta0["r_m"] * 1.01
    pred.jacobian(dict(pred.theta0), ["E_pa", "r_m"])
    pred.jacobian(theta, ["E_pa", "r_m"])
    assert pred._macro_cache[("E_pa", "r_m")].relinearisations == 2


def test_update_with_the_analytic_jacobian_converges_to_the_finite_difference_result():
    """The fixed point does not depend on where S comes from: both updates stop within
    the tolerance of each other."""
    from truthbench.update.finite_difference import finite_difference_update

    plant = make_plant("free_free_beam", n_elements=8)
    nominal = {"modal_damping_ratio": 0.01}
    tests = [PredictedTest("a", np.linspace(5.0, 400.0, 300), (Actuator("end_a", "z"),),
                           (Sensor("end_a", "z"), Sensor("mid", "z"), Sensor("end_b", "z")))]
    pred = FRFPredictor(plant, nominal, tests)
    truth = {**pred.theta0, "E_pa": pred.theta0["E_pa"] * 1.03,
             "rho_kg_m3": pred.theta0["rho_kg_m3"] * 0.98}
    data = pred.predict_vector(truth)
    f = pred.vector_function()
    a = finite_difference_update(f, data, pred.theta0, ["E_pa", "rho_kg_m3"], n_pairs=3,
                                 tolerance=1e-9)
    b = finite_difference_update(f, data, pred.theta0, ["E_pa", "rho_kg_m3"], n_pairs=3,
                                 tolerance=1e-9, jacobian="finite_difference")
    assert a.converged and b.converged
    np.testing.assert_allclose(a.values, b.values, rtol=1e-8)
    np.testing.assert_allclose(a.values, [truth["E_pa"], truth["rho_kg_m3"]], rtol=1e-8)
    with pytest.raises(ValueError, match="jacobian must be"):
        finite_difference_update(f, data, pred.theta0, ["E_pa"], n_pairs=3, jacobian="x")


def test_cases_it_does_not_cover_fall_back_to_finite_differences():
    from truthbench.effects import parse_effect
    from truthbench.update import EffectTerm

    plant = make_plant("free_free_beam", n_elements=6)
    tests = [PredictedTest("a", np.linspace(5.0, 300.0, 40), (Actuator("end_a", "z"),),
                           (Sensor("end_b", "z"),))]
    joint = parse_effect({"name": "joint", "station": "mid",
                          "parameters": {"stiffness_loss": 0.1}}, "effects[0]", "test")
    pred = FRFPredictor(plant, {}, tests, [EffectTerm("joint", joint)])
    assert pred.jacobian(pred.theta0, ["joint.stiffness_loss"]) is None


def test_predictors_of_one_model_share_the_macroelements_taken_at_its_nominal_values():
    """Two predictors of the same plant, nominal values and channels (a campaign's trials)
    take the macroelements once, at the nominal values, and move them to any theta: the
    second one's Jacobian is the first one's, bit for bit, and matches the differences;
    another nominal value is another model."""
    plant = make_plant("free_free_beam", n_elements=6)
    tests = [PredictedTest("a", np.linspace(5.0, 300.0, 80), (Actuator("end_a", "z"),),
                           (Sensor("end_b", "z"),))]
    names = ["E_pa", "rho_kg_m3"]
    nominal = {"modal_damping_ratio": 0.0123}
    first = FRFPredictor(plant, nominal, tests)
    second = FRFPredictor(plant, nominal, tests)
    theta = {**first.theta0, "E_pa": first.theta0["E_pa"] * 1.02}
    S1 = first.jacobian(theta, names)
    S2 = second.jacobian(theta, names)
    np.testing.assert_array_equal(S1, S2)
    assert second._macro_cache[tuple(names)]._ref is first._macro_cache[tuple(names)]._ref
    _check(second, theta, names)
    other = FRFPredictor(plant, {**nominal, "rho_kg_m3": 2650.0}, tests)
    other.jacobian({**other.theta0, "E_pa": theta["E_pa"]}, names)
    assert other._macro_cache[tuple(names)]._ref is not first._macro_cache[tuple(names)]._ref
