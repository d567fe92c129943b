"""Appended dynamics (Table 10.1): actuator and sensor dynamics, time delay.

They change what is recorded, not the structure: the data then contain them and the
structural model does not (METHOD 5.2 item 1).
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from truthbench.effects.base import (
    Diagnosable,
    Effect,
    EffectParam,
    FitParam,
    register_effect,
)
from truthbench.effects.hardware import Filter


def _bandwidth(fitted) -> dict[str, float]:
    """A low-pass fitted by its time constant ``tau_s`` (0: ideal, infinite bandwidth)."""
    tau = fitted["tau_s"]
    return {"bandwidth_hz": np.inf if tau <= 0 else 1.0 / (2 * np.pi * tau)}


_LOW_PASS = Diagnosable((FitParam("tau_s", "time", 0.5, minimum=0.0),), to_values=_bandwidth)


def _first_order_low_pass(bandwidth_hz: float) -> Filter:
    """``w / (s + w)``, ``w = 2 pi bandwidth_hz``."""
    w = 2 * np.pi * bandwidth_hz
    return Filter((w,), (1.0, w))


@register_effect
class ActuatorDynamics(Effect):
    name: ClassVar[str] = "actuator_dynamics"
    target: ClassVar[str] = "appended"
    description: ClassVar[str] = ("the applied force is the recorded command through a "
                                  "first-order low-pass (a shaker's electrical pole)")
    params: ClassVar = (EffectParam("bandwidth_hz", 1e3, "corner frequency, Hz", 1e-3),)
    options: ClassVar = {}
    neutral: ClassVar = {"bandwidth_hz": np.inf}
    diagnosis: ClassVar = _LOW_PASS

    def contribute(self, values, options, setup):
        if np.isfinite(values["bandwidth_hz"]):  # infinite bandwidth: an ideal actuator
            setup.input_filters.append(_first_order_low_pass(values["bandwidth_hz"]))


@register_effect
class SensorDynamics(Effect):
    name: ClassVar[str] = "sensor_dynamics"
    target: ClassVar[str] = "appended"
    description: ClassVar[str] = ("every recorded output passes a second-order low-pass "
                                  "(sensor resonance / anti-alias filter), damping ratio 0.7")
    params: ClassVar = (EffectParam("bandwidth_hz", 2e3, "natural frequency, Hz", 1e-3),)
    options: ClassVar = {}
    neutral: ClassVar = {"bandwidth_hz": np.inf}
    diagnosis: ClassVar = _LOW_PASS

    def contribute(self, values, options, setup):
        if not np.isfinite(values["bandwidth_hz"]):  # infinite bandwidth: an ideal sensor
            return
        w = 2 * np.pi * values["bandwidth_hz"]
        setup.output_filters.append(Filter((w * w,), (1.0, 1.4 * w, w * w)))


@register_effect
class TimeDelay(Effect):
    name: ClassVar[str] = "time_delay"
    target: ClassVar[str] = "appended"
    description: ClassVar[str] = ("the recorded outputs lag the recorded input by a pure "
                                  "delay (exact: a linear phase -omega tau, no Pade)")
    params: ClassVar = (EffectParam("delay_s", 0.0, "delay, s", 0.0),)
    options: ClassVar = {}
    diagnosis: ClassVar = Diagnosable((FitParam("delay_s", "time", 1.0, minimum=0.0),))

    def contribute(self, values, options, setup):
        setup.delay_s += values["delay_s"]
