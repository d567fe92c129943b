"""The shared contract over every registered effect, without a campaign.

For every effect of :data:`truthbench.effects.EFFECTS`:

* at its neutral values (zero strength) the hardware has the nominal FRF to 1e-12;
* at a moderate strength it changes what it claims to change (the FRF, or for the
  measurement chain and nonlinear laws, the recorded outputs);
* ``contribute`` does not change its inputs (values and options arrive read-only; the
  parameters given to :func:`~truthbench.effects.realise` stay as they were);
* its variance part is drawn when its scope says (per trial, assembly, test, or along a
  drift path), checked through the campaign's truth streams on a three-test matrix.
"""

from __future__ import annotations

import functools
from types import MappingProxyType

import numpy as np
import pytest

from truthbench.campaign.plan import CampaignPlan
from truthbench.campaign.spec import parse_campaign
from truthbench.campaign.truth import build_hardware
from truthbench.effects import EFFECTS, SCOPES, EffectSpec, parse_effect, realise
from truthbench.effects.setup import SetupBuilder
from truthbench.plants import Actuator, Sensor, make_plant

PLANT = make_plant("free_free_beam", n_elements=8)
PARAMS = PLANT.resolve({"modal_damping_ratio": 0.01, "suspension_damping_n_s_m": 0.5})
ACTS = (Actuator("end_a", "z"),)
SENS = (Sensor("end_a", "z"), Sensor("mid", "z"), Sensor("end_b", "z"))
FREQ = np.linspace(2.0, 400.0, 300)

OPTIONS = {"station": "mid", "parameter": "E_pa"}
"""Options an effect needs that have no default here."""

MODERATE = {
    "material": {"E_rel": 0.03}, "geometry": {"t_rel": 0.02}, "parameter": {"rel": 0.05},
    "discretization": {}, "element_physics": {"scale": 1.0}, "boundary": {"stiffness_rel": 0.5},
    "joint": {"stiffness_loss": 0.3, "damping_n_m_s_rad": 2.0}, "added_mass": {"mass_kg": 0.05},
    "sensor_mass": {"mass_kg": 0.02}, "aerodynamic": {"damping_n_s_m2": 0.5},
    "sag": {"scale": 200.0}, "actuator_dynamics": {"bandwidth_hz": 100.0},
    "sensor_dynamics": {"bandwidth_hz": 200.0}, "time_delay": {"delay_s": 1e-3},
    "actuator_resonance": {"natural_frequency_hz": 150.0, "damping_ratio": 0.2},
    "sensor_lag": {"bandwidth_hz": 100.0},
    "sensor_noise": {"noise_fraction": 0.05}, "sensor_bias": {"gain_error": 0.05},
    "process_noise": {"rms": 0.5}, "closed_loop": {"gain": 50.0},
    "coulomb_friction": {"force_n": 0.5}, "cubic_stiffness": {"k3_n_m3": 1e9},
    "dead_band": {"gap_m": 1e-5, "stiffness_n_m": 1e5},
    "amplitude_damping": {"c2_n_s2_m2": 50.0}, "channel_gain": {"gain_error": 0.05},
    "grounded_spring": {"stiffness_n_m": 2e4}, "grounded_dashpot": {"damping_n_s_m": 20.0},
    "sensor_mounting": {"offset_m": 0.01, "cross_axis": 0.02},
    "shaker_mounting": {"offset_m": 0.003, "misalignment_deg": 5.0},
}
"""A moderate strength of each effect (what it changes at that strength is checked)."""

RECORD_ONLY = {"sensor_noise", "process_noise", "coulomb_friction", "cubic_stiffness",
               "dead_band", "amplitude_damping"}
"""Effects invisible in the (linear, noise-free) FRF: checked on recorded outputs."""

ON_TOP_OF = {"sensor_mounting": "shaker_mounting"}
"""Effects that change the FRF only where another one acts (a sensor off the axis reads
torsion, which a shaker on the axis does not drive): checked on top of that one."""


def _hardware(spec, trial, j, seed, extra_effects=()):
    """The truth of test ``j`` of trial ``trial`` of ``spec`` (compiled to its plan)."""
    plan = CampaignPlan.compile(spec)
    return build_hardware(plan, plan.tests[j], trial, seed, extra_effects)


def _spec(name, **options) -> EffectSpec:
    cls = EFFECTS[name]
    entry = {"name": name, **{k: v for k, v in OPTIONS.items() if k in cls.options}, **options}
    return parse_effect(entry, "contract")


def _rel(a, b) -> float:
    return float(np.abs(a - b).max() / np.abs(b).max())


NOMINAL = realise(PLANT, PARAMS, actuators=ACTS, sensors=SENS)
H0 = NOMINAL.frf(FREQ)


def test_every_effect_is_covered_by_this_contract():
    assert set(MODERATE) == set(EFFECTS)


@pytest.mark.parametrize("name", sorted(EFFECTS))
def test_neutral_values_give_the_nominal_frf(name):
    neutral = EFFECTS[name].neutral_values()
    if neutral is None:
        pytest.skip(f"{name} has no neutral setting (declared neutral = None)")
    values, options = neutral
    hw = realise(PLANT, PARAMS, [(_spec(name, **options), values)], actuators=ACTS,
                 sensors=SENS)
    assert _rel(hw.frf(FREQ), H0) < 1e-12


@pytest.mark.parametrize("name", sorted(EFFECTS))
def test_a_moderate_strength_changes_the_response(name):
    spec = _spec(name)
    values = {**EFFECTS[name].neutral_values()[0], **MODERATE[name]} \
        if EFFECTS[name].neutral is not None else {}
    base = [(_spec(ON_TOP_OF[name]), MODERATE[ON_TOP_OF[name]])] if name in ON_TOP_OF else []
    hw = realise(PLANT, PARAMS, [*base, (spec, values)], actuators=ACTS, sensors=SENS)
    if name not in RECORD_ONLY:
        h0 = realise(PLANT, PARAMS, base, actuators=ACTS, sensors=SENS).frf(FREQ) if base \
            else H0
        assert _rel(hw.frf(FREQ), h0) > 1e-3
        return
    # measurement chain and nonlinear laws: the recorded outputs change
    y0 = _nominal_record()
    y1 = hw.simulate(U, FS, rng=np.random.default_rng(1), **SIM)
    assert _rel(y1, y0) > 1e-3


FS = 1024.0
U = 2.0 * np.sin(2 * np.pi * 16.0 * np.arange(4096) / FS)[None, :]
SIM = dict(method="time", oversample=4, band_hz=(2.0, 400.0))


@functools.cache
def _nominal_record():
    return NOMINAL.simulate(U, FS, rng=np.random.default_rng(1), **SIM)


@pytest.mark.parametrize("name", sorted(EFFECTS))
def test_contribute_does_not_change_its_inputs(name):
    spec = _spec(name)
    neutral = EFFECTS[name].neutral_values()
    values = {**(neutral[0] if neutral else {}), **MODERATE[name]}
    params = dict(PARAMS)
    builder = SetupBuilder(plant=PLANT, parameters=dict(params), actuators=ACTS, sensors=SENS)
    # read-only views: an effect writing into them raises TypeError
    spec.effect.contribute(MappingProxyType(dict(values)), MappingProxyType(spec.options),
                           builder)
    builder.freeze()
    realise(PLANT, params, [(spec, values)], actuators=ACTS, sensors=SENS)
    assert params == PARAMS


def _scope_campaign(name, scope):
    cls = EFFECTS[name]
    first = cls.params[0]
    effect = {"name": name, "scope": scope,
              **{k: v for k, v in OPTIONS.items() if k in cls.options},
              "parameters": {first.name: {"mean": max(first.default, 0.1), "std": 0.05}}}
    test = {"actuators": [{"station": "end_a", "direction": "z"}], "band_hz": [2.0, 100.0],
            "fs_hz": 256.0, "record_s": 1.0, "averages": 1}
    return parse_campaign({
        "campaign": {"name": "scopes", "seed": 7},
        "plant": {"type": "free_free_beam", "n_elements": 8},
        "sensors": [{"station": "mid", "direction": "z"}],
        "truth": {"effects": [effect]},
        "tests": [{**test, "name": "a"}, {**test, "name": "b", "time_h": 0.01},
                  {**test, "name": "c", "assembly": 1, "time_h": 5.0}],
        "update": {"method": "none"}, "identify": {"enabled": False}})


@pytest.mark.parametrize("scope", SCOPES)
@pytest.mark.parametrize("name", sorted(n for n in EFFECTS if EFFECTS[n].params))
def test_scopes_draw_when_they_should(name, scope):
    spec = _scope_campaign(name, scope)
    first = EFFECTS[name].params[0].name

    def value(trial, j):
        return _hardware(spec, trial, j, 7).effects[name][first]

    a, b, c = (value(0, j) for j in range(3))
    if scope == "hardware":
        assert a == b == c != value(1, 0)
    elif scope == "reassembly":
        assert a == b != c  # tests a and b share assembly 0
    elif scope == "test":
        assert len({a, b, c}) == 3
    else:  # drift: a Wiener path, moves little in 0.01 h and more in 5 h
        assert len({a, b, c}) == 3 and abs(b - a) < abs(c - a)
