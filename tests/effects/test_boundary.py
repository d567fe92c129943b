"""The boundary effect: every suspension point together (as before) or one of them, and
its diagnosis form on a log scale."""

from __future__ import annotations

import numpy as np
import pytest

from truthbench.effects import EFFECTS, effect_from_inject, parse_effect, realise
from truthbench.effects.structural import support_node
from truthbench.errors import ModelError
from truthbench.plants import Actuator, Sensor, make_plant

BASE = make_plant("free_free_beam", n_elements=10, suspension_fractions=(0.2, 0.5, 0.8))
NODES = BASE.suspension_nodes()  # (2, 5, 8)
PLANT = make_plant("free_free_beam", n_elements=10, suspension_fractions=(0.2, 0.5, 0.8),
                   stations={f"s{k}": n / 10 for k, n in enumerate(NODES)})
PARAMS = PLANT.resolve({"modal_damping_ratio": 0.01, "suspension_damping_n_s_m": 0.3,
                        "suspension_lateral_stiffness_n_m": 50.0})
ACTS = (Actuator("end_a", "z"), Actuator("mid", "y"))
SENS = (Sensor("end_a", "z"), Sensor("s0", "z"), Sensor("end_b", "y"))
FREQ = np.linspace(0.5, 300.0, 600)  # the suspension modes (a few Hz) and bending
R, D = 4.0, 2.5  # five times stiffer, 2.5 N s/m more damping


def _boundary(support="all", rel=R, damping=D):
    return (parse_effect({"name": "boundary", "support": support}, "test"),
            {"stiffness_rel": rel, "damping_n_s_m": damping})


def _hw(effects=(), params=PARAMS):
    return realise(PLANT, params, effects, actuators=ACTS, sensors=SENS)


def _model(hw):
    return hw.plant.build(hw.parameters, hw.actuators, hw.sensors, hw.additions)


def test_all_is_the_scaled_suspension_as_before():
    """``support = "all"`` (the default) is the plant with its suspension stiffness times
    ``1 + stiffness_rel`` and its damping plus ``damping_n_s_m``: bit for bit."""
    today = dict(PARAMS, suspension_stiffness_n_m=PARAMS["suspension_stiffness_n_m"] * (1 + R),
                 suspension_damping_n_s_m=PARAMS["suspension_damping_n_s_m"] + D)
    a, b = _hw([_boundary()]), _hw(params=today)
    assert a.parameters == b.parameters and a.additions == b.additions
    assert np.array_equal(a.frf(FREQ), b.frf(FREQ))
    assert parse_effect({"name": "boundary"}, "t").options == {"support": "all"}


@pytest.mark.parametrize("k", range(3))
def test_one_support_is_a_grounded_spring_and_dashpot_at_its_node(k):
    """One point's change adds ``stiffness_rel`` times the suspension stiffness and
    ``damping_n_s_m`` at its vertical DOF: the grounded spring and dashpot of those values
    at that node."""
    spring = parse_effect({"name": "grounded_spring", "station": f"s{k}", "direction": "z"},
                          "t")
    dashpot = parse_effect({"name": "grounded_dashpot", "station": f"s{k}",
                            "direction": "z"}, "t")
    added = R * PARAMS["suspension_stiffness_n_m"]
    one = _hw([_boundary(k)])
    ref = _hw([(spring, {"stiffness_n_m": added}), (dashpot, {"damping_n_s_m": D})])
    np.testing.assert_allclose(one.frf(FREQ), ref.frf(FREQ), rtol=1e-13, atol=0)
    # only that point's vertical spring and dashpot changed
    m0, m1 = _model(_hw()), _model(one)
    dof = m0.dof_labels.index(f"n{NODES[k]}.z")
    for name, value in (("K", added), ("C", D)):
        diff = (getattr(m1, name) - getattr(m0, name)).toarray()
        expected = np.zeros_like(diff)
        expected[dof, dof] = value
        np.testing.assert_allclose(diff, expected, rtol=1e-15, atol=1e-15 * value)
    assert np.array_equal(m1.M.toarray(), m0.M.toarray())


def test_every_support_one_by_one_is_all_of_them():
    """The three points changed one at a time add up to ``support = "all"``: the spring
    of each becomes ``k + r k`` against ``k (1 + r)``, equal to round-off."""
    each = _hw([_boundary(k) for k in range(3)])
    together = _hw([_boundary()])
    np.testing.assert_allclose(each.frf(FREQ), together.frf(FREQ), rtol=1e-12, atol=0)
    np.testing.assert_allclose(_model(each).K.toarray(), _model(together).K.toarray(),
                               rtol=0, atol=1e-15 * np.abs(_model(together).K).max())


def test_a_softer_support():
    """``stiffness_rel`` down to -0.99 at one point: that point's spring is 1 % of the
    others'; a softer K lowers every natural frequency (Courant-Fischer), the suspension
    modes visibly."""
    soft = _model(_hw([_boundary(1, rel=-0.99, damping=0.0)]))
    dof = soft.dof_labels.index(f"n{NODES[1]}.z")
    base = _model(_hw())
    assert soft.K[dof, dof] - base.K[dof, dof] == pytest.approx(
        -0.99 * PARAMS["suspension_stiffness_n_m"], rel=1e-15)
    f_soft, f_base = soft.modes(12).freq_hz, base.modes(12).freq_hz
    assert np.all(f_soft <= f_base * (1 + 1e-9)) and np.any(f_soft < 0.9 * f_base)


def test_the_support_option_from_the_command_line():
    spec = effect_from_inject("boundary:support=2,stiffness_rel=4.0")
    assert spec.options == {"support": 2.0}
    np.testing.assert_array_equal(_hw([spec]).frf(FREQ), _hw([_boundary(2, R, 0.0)]).frf(FREQ))


@pytest.mark.parametrize("support", [3, -1, 0.5, "first", True])
def test_a_support_the_plant_lacks(support):
    with pytest.raises(ModelError, match=r"option 'support' expected 'all' or the index of "
                                         r"a suspension point, 0\.\.2 \(at nodes 2, 5, 8\)"):
        _hw([_boundary(support)])


def test_no_suspension():
    hub = make_plant("hub_beam", n_elements=6)
    with pytest.raises(ModelError, match="hub_beam has no suspension points"):
        support_node(hub, 0)
    free = make_plant("free_free_beam", n_elements=6, supports="none")
    with pytest.raises(ModelError, match="needs a suspended plant"):
        realise(free, free.resolve({}), [_boundary(0)])


# ------------------------------------------------------------------ diagnosis form


def test_the_diagnosis_form_is_a_log_stiffness_ratio():
    form = EFFECTS["boundary"].diagnosis
    (p,) = form.fitted
    assert (p.name, p.reference, p.factor, p.start) == ("log_stiffness_ratio", "unit", 0.5,
                                                        0.0)
    assert p.minimum == pytest.approx(np.log(0.1), rel=1e-15)
    assert p.maximum == pytest.approx(np.log(10.0), rel=1e-15)
    assert form.location == "support"
    # k / k_nominal = exp(x): 0.1 .. 10 at the bounds, 1 (neutral) at the start
    for ratio in (0.1, 0.5, 1.0, 5.0, 10.0):
        rel = form.to_values({"log_stiffness_ratio": np.log(ratio)})["stiffness_rel"]
        assert 1.0 + rel == pytest.approx(ratio, rel=4e-16)
    assert form.to_values({"log_stiffness_ratio": 0.0}) == {"stiffness_rel": 0.0}


def test_the_fitted_form_at_five_times_one_support():
    """Five times stiffer at one point, as the fitted form gives it: the FRF of that
    point's spring at 5 k."""
    values = EFFECTS["boundary"].diagnosis.to_values({"log_stiffness_ratio": np.log(5.0)})
    hw = _hw([_boundary(0, values["stiffness_rel"], 0.0)])
    five = _hw([_boundary(0, 4.0, 0.0)])
    np.testing.assert_allclose(hw.frf(FREQ), five.frf(FREQ), rtol=1e-12, atol=0)
