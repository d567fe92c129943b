"""Appended dynamics: the first- and second-order low-passes of the actuator and sensor
sides, and their diagnosis forms, against python-control's transfer functions."""

from __future__ import annotations

import control
import numpy as np
import pytest

from truthbench.effects import EFFECTS, Filter, parse_effect, realise
from truthbench.effects.appended import (
    FIRST_ORDER_LIMIT,
    second_order_coefficients,
    second_order_values,
)
from truthbench.plants import Actuator, Sensor, make_plant

PLANT = make_plant("free_free_beam", n_elements=8)
PARAMS = PLANT.resolve({"modal_damping_ratio": 0.01})
ACTS = (Actuator("end_a", "z"), Actuator("mid", "z"))
SENS = (Sensor("end_a", "z"), Sensor("end_b", "z"))
FREQ = np.geomspace(1.0, 5e3, 400)
S = 2j * np.pi * FREQ
NOMINAL = realise(PLANT, PARAMS, actuators=ACTS, sensors=SENS)
H0 = NOMINAL.frf(FREQ)

# Round-off of a quadratic's evaluation relative to its value: a few eps times
# (|a s^2| + |b s| + 1) / |a s^2 + b s + 1|, which at a natural frequency is 1 / (2 zeta)
# (10 for zeta = 0.05); the FRF products add a few eps more.
RTOL = 1e-12


def _hardware(name: str, values: dict):
    spec = parse_effect({"name": name}, "test")
    return realise(PLANT, PARAMS, [(spec, {**EFFECTS[name].neutral_values()[0], **values})],
                   actuators=ACTS, sensors=SENS)


def _low_pass_1(f_hz):
    w = 2 * np.pi * f_hz
    return control.tf([w], [1.0, w])


def _low_pass_2(f_hz, zeta):
    w = 2 * np.pi * f_hz
    return control.tf([w * w], [1.0, 2 * zeta * w, w * w])


CASES = [
    ("actuator_dynamics", {"bandwidth_hz": 300.0}, lambda: _low_pass_1(300.0)),
    ("sensor_lag", {"bandwidth_hz": 300.0}, lambda: _low_pass_1(300.0)),
    ("sensor_dynamics", {"bandwidth_hz": 1500.0}, lambda: _low_pass_2(1500.0, 0.7)),
    ("sensor_dynamics", {"bandwidth_hz": 1500.0, "damping_ratio": 0.5},
     lambda: _low_pass_2(1500.0, 0.5)),
    ("actuator_resonance", {"natural_frequency_hz": 800.0, "damping_ratio": 0.05},
     lambda: _low_pass_2(800.0, 0.05)),
    ("actuator_resonance", {"natural_frequency_hz": 800.0, "damping_ratio": 3.0},
     lambda: _low_pass_2(800.0, 3.0)),
]


@pytest.mark.parametrize("name, values, tf", CASES,
                         ids=[f"{c[0]}-{'-'.join(map(str, c[1].values()))}" for c in CASES])
def test_each_form_multiplies_the_frf_by_python_controls_transfer_function(name, values, tf):
    H = _hardware(name, values).frf(FREQ)
    G = tf()(S)
    np.testing.assert_allclose(H, H0 * G[:, None, None], rtol=RTOL, atol=0)


def test_sensor_dynamics_keeps_its_filter_bit_for_bit():
    """Its damping ratio defaults to 0.7: the filter is the one written before the
    parameter existed, to the last bit (campaign results do not change)."""
    hw = _hardware("sensor_dynamics", {"bandwidth_hz": 1234.5})
    w = 2 * np.pi * 1234.5
    assert hw.output_filters == (Filter((w * w,), (1.0, 1.4 * w, w * w)),)


def test_actuator_and_sensor_sides():
    act = _hardware("actuator_resonance", {"natural_frequency_hz": 1e3})
    sen = _hardware("sensor_lag", {"bandwidth_hz": 1e3})
    assert len(act.input_filters) == 1 and not act.output_filters
    assert len(sen.output_filters) == 1 and not sen.input_filters


# ------------------------------------------------------------------ diagnosis forms


def _form_frf(name: str, fitted: dict) -> np.ndarray:
    """The FRF of the effect at fitted values of its diagnosis form, relative to the
    nominal one (shape (n_f, n_out, n_in))."""
    values = EFFECTS[name].diagnosis.to_values(fitted)
    return _hardware(name, values).frf(FREQ) / H0


SECOND = ["sensor_dynamics", "actuator_resonance"]
FIRST = ["actuator_dynamics", "sensor_lag"]


def test_the_forms_declared():
    for name in SECOND:
        form = EFFECTS[name].diagnosis
        assert [p.name for p in form.fitted] == ["a_s2", "b_s"]
        assert all(p.start == 0.0 and p.minimum == 0.0 for p in form.fitted)
        assert form.location is None
    for name in FIRST:
        assert [p.name for p in EFFECTS[name].diagnosis.fitted] == ["tau_s"]


W = 2 * np.pi * 500.0
FITTED = [
    (1 / W**2, 2 * 0.05 / W),       # a resonance, zeta 0.05
    (1 / W**2, 2 * 0.7 / W),        # maximally flat
    (1 / W**2, 2 * 4.0 / W),        # overdamped
    (1 / W**2, 0.0),                # undamped (no line at its natural frequency)
    (0.0, 1 / W),                   # a = 0: the first-order low-pass 1 / (b s + 1)
]


@pytest.mark.parametrize("name", SECOND)
@pytest.mark.parametrize("a, b", FITTED)
def test_the_second_order_form_is_one_over_a_s2_plus_b_s_plus_1(name, a, b):
    """The form at fitted ``a``, ``b`` (through to_values and the effect) is
    ``1 / (a s^2 + b s + 1)`` of python-control, also at ``a = 0`` (first order)."""
    G = control.tf([1.0], [a, b, 1.0] if a else [b, 1.0])(S)
    ratio = _form_frf(name, {"a_s2": a, "b_s": b})
    # the ratio to H0 adds one division's round-off to RTOL's
    np.testing.assert_allclose(ratio, np.broadcast_to(G[:, None, None], ratio.shape),
                               rtol=RTOL)


@pytest.mark.parametrize("name", SECOND + FIRST)
def test_the_form_is_neutral_at_its_start(name):
    form = EFFECTS[name].diagnosis
    hw = _hardware(name, form.to_values({p.name: p.start for p in form.fitted}))
    assert not hw.input_filters and not hw.output_filters
    assert np.array_equal(hw.frf(FREQ), H0)


@pytest.mark.parametrize("name", SECOND)
def test_both_sensitivities_at_the_start_are_nonzero(name):
    """Forward differences from ``a = b = 0`` of the filter the form gives:
    ``dH/da = -s^2``, ``dH/db = -s`` (H = 1 there). Over 100 Hz .. 5 kHz a step of
    ``1e-5`` of the top's scale has a truncation error ``h |s|^k <= 1e-5`` relative and a
    round-off of a few eps over ``h |s|^k >= 1e-5 / 50^k``: ``< 1e-6``."""
    s = S[FREQ >= 100.0]
    w_max = 2 * np.pi * FREQ[-1]
    form = EFFECTS[name].diagnosis
    for key, k in (("a_s2", 2), ("b_s", 1)):
        h = 1e-5 / w_max**k
        values = form.to_values({"a_s2": 0.0, "b_s": 0.0, key: h})
        hw = _hardware(name, values)
        (flt,) = hw.input_filters + hw.output_filters
        d = (flt.response(s) - 1.0) / h
        np.testing.assert_allclose(d, -s**k, rtol=2e-5)


@pytest.mark.parametrize("f_hz, zeta", [(0.1, 0.0), (37.0, 0.05), (1500.0, 0.7),
                                        (2e4, 3.0), (1e6, 1.0)])
def test_frequency_and_damping_round_trip_through_the_coefficients(f_hz, zeta):
    a, b = second_order_coefficients(f_hz, zeta)
    w = 2 * np.pi * f_hz
    assert a == pytest.approx(1 / w**2, rel=4e-16) and b == pytest.approx(2 * zeta / w,
                                                                       rel=4e-16)
    f, z = second_order_values(a, b)
    # a square root and a few products: a few eps
    assert f == pytest.approx(f_hz, rel=1e-15) and z == pytest.approx(zeta, rel=1e-15,
                                                                      abs=0)


@pytest.mark.parametrize("a, b", FITTED)
def test_the_coefficients_round_trip_through_frequency_and_damping(a, b):
    back = second_order_coefficients(*second_order_values(a, b))
    # a = 0 comes back as (FIRST_ORDER_LIMIT b)^2: below round-off in the FRF
    expected_a = a if a else (FIRST_ORDER_LIMIT * b) ** 2
    np.testing.assert_allclose(back, (expected_a, b), rtol=1e-15, atol=0)


def test_the_ideal_and_bad_coefficients():
    assert second_order_values(0.0, 0.0, ideal_damping=0.7) == (np.inf, 0.7)
    assert second_order_coefficients(np.inf, 0.7) == (0.0, 0.0)
    with pytest.raises(ValueError, match="a >= 0 and b >= 0"):
        second_order_values(-1e-9, 0.0)
