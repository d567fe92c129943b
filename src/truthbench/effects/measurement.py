"""Testing effects (Table 10.1): sensor noise, sensor bias, process noise."""

from __future__ import annotations

from typing import ClassVar

from truthbench.effects.base import (
    Diagnosable,
    Effect,
    EffectParam,
    FitParam,
    register_effect,
)
from truthbench.effects.hardware import Filter
from truthbench.effects.mounting import channel_index


@register_effect
class SensorNoise(Effect):
    name: ClassVar[str] = "sensor_noise"
    target: ClassVar[str] = "measurement"
    default_scope: ClassVar[str] = "test"
    description: ClassVar[str] = ("white Gaussian noise on every output, its standard "
                                  "deviation a fraction of the signal's")
    params: ClassVar = (EffectParam("noise_fraction", 0.0, "noise std / signal std", 0.0),)
    options: ClassVar = {}

    def contribute(self, values, options, setup):
        setup.noise_fraction = float(
            (setup.noise_fraction**2 + values["noise_fraction"] ** 2) ** 0.5)


@register_effect
class SensorBias(Effect):
    name: ClassVar[str] = "sensor_bias"
    target: ClassVar[str] = "measurement"
    default_scope: ClassVar[str] = "test"
    description: ClassVar[str] = ("recorded output = (1 + gain_error) x output + offset, "
                                  "on every output")
    params: ClassVar = (EffectParam("offset", 0.0, "offset in the output's unit"),
                        EffectParam("gain_error", 0.0, "relative gain error", -0.99))
    options: ClassVar = {}
    diagnosis: ClassVar = Diagnosable((FitParam("gain_error", "unit", 0.01, minimum=-0.99),))

    def contribute(self, values, options, setup):
        setup.bias_offset += values["offset"]
        setup.bias_gain *= 1.0 + values["gain_error"]


@register_effect
class ChannelGain(Effect):
    name: ClassVar[str] = "channel_gain"
    target: ClassVar[str] = "measurement"
    default_scope: ClassVar[str] = "test"
    description: ClassVar[str] = ("one recorded output is (1 + gain_error) x the output (a "
                                  "wrong sensitivity in one channel's calibration); "
                                  "`sensor` is the index of the test's sensor or its label")
    params: ClassVar = (EffectParam("gain_error", 0.0, "relative gain error", -0.99),)
    options: ClassVar = {"sensor": 0}
    per_test_channels: ClassVar[bool] = True
    diagnosis: ClassVar = Diagnosable((FitParam("gain_error", "unit", 0.01, minimum=-0.99),),
                                      location="sensor")

    def contribute(self, values, options, setup):
        k = channel_index(options["sensor"], [s.label for s in setup.sensors], self.name,
                          "sensor")
        if k is None:
            return  # that sensor is not in this test
        if values["gain_error"] != 0:
            setup.output_filters.append(Filter((1.0 + values["gain_error"],), (1.0,), k))


@register_effect
class ProcessNoise(Effect):
    name: ClassVar[str] = "process_noise"
    target: ClassVar[str] = "measurement"
    default_scope: ClassVar[str] = "test"
    description: ClassVar[str] = ("an unmeasured band-limited random disturbance force at a "
                                  "station (same band as the test's excitation)")
    params: ClassVar = (EffectParam("rms", 0.0, "RMS of the disturbance, N or N m", 0.0),)
    options: ClassVar = {"station": None, "direction": "z"}

    def contribute(self, values, options, setup):
        setup.plant.station_node(options["station"])  # validates
        setup.disturbances.append((options["station"], options["direction"], values["rms"]))
