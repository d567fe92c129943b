"""The realised truth of one test: what every effect changed, collected then frozen.

A :class:`SetupBuilder` starts from the plant and the hardware's parameters; each effect
adds its change (``contribute``); :meth:`SetupBuilder.freeze` returns the immutable
:class:`TestSetup` that the simulator runs and the results store records.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from truthbench.plants.base import Plant, StructuralAdditions


@dataclass(frozen=True)
class Filter:
    """A continuous transfer function ``num(s) / den(s)`` (coefficients, highest power
    first) applied to one input (actuator dynamics) or output (sensor dynamics); index
    None applies it to all."""

    num: tuple[float, ...]
    den: tuple[float, ...]
    index: int | None = None


@dataclass(frozen=True)
class TestSetup:
    """Everything the simulator needs for one test of one piece of hardware.

    Attributes
    ----------
    plant : Plant
        The truth plant (its mesh and element physics may differ from the model's).
    parameters : dict
        Plant parameters of the hardware in this test.
    additions : StructuralAdditions
        Joints, lumped masses and dashpots, element stiffness loss, sag angles.
    input_filters, output_filters : tuple of Filter
        Actuator and sensor dynamics.
    delay_s : float
        Time delay between the recorded input and the recorded outputs, s.
    noise_fraction : float
        Sensor noise standard deviation over the signal's, per channel.
    bias_offset, bias_gain : float
        Recorded output = gain * output + offset (offset in the output's unit).
    disturbances : tuple of (station, direction, rms)
        Unmeasured band-limited random forces (process noise), N or N m RMS.
    nonlinear : tuple
        Nonlinear elements (station, direction, element).
    loops : tuple of Loop
        Feedback loops closed around the plant (:mod:`truthbench.effects.loop`).
    effects : dict
        Realised parameter values of every effect, by effect label.
    """

    __test__ = False  # not a pytest test class

    plant: Plant
    parameters: dict
    additions: StructuralAdditions = StructuralAdditions()
    input_filters: tuple[Filter, ...] = ()
    output_filters: tuple[Filter, ...] = ()
    delay_s: float = 0.0
    noise_fraction: float = 0.0
    bias_offset: float = 0.0
    bias_gain: float = 1.0
    disturbances: tuple[tuple[str, str, float], ...] = ()
    nonlinear: tuple = ()
    loops: tuple = ()
    effects: dict = field(default_factory=dict)


@dataclass
class SetupBuilder:
    """Mutable collector used only while effects contribute; see :meth:`freeze`."""

    plant: Plant
    parameters: dict
    sensor_stations: tuple[str, ...] = ()
    links: list = field(default_factory=list)
    element_scale: list = field(default_factory=list)
    sag_scale: float = 0.0
    gravity_m_s2: float = 9.80665
    input_filters: list = field(default_factory=list)
    output_filters: list = field(default_factory=list)
    delay_s: float = 0.0
    noise_fraction: float = 0.0
    bias_offset: float = 0.0
    bias_gain: float = 1.0
    disturbances: list = field(default_factory=list)
    nonlinear: list = field(default_factory=list)
    loops: list = field(default_factory=list)
    effects: dict = field(default_factory=dict)

    def scale_parameter(self, name: str, factor: float) -> None:
        """Multiply a plant parameter (group-qualified names fall back to the plain one)."""
        base = name.split("@")[0]
        self.parameters[name] = self.parameters.get(name, self.parameters[base]) * factor

    def freeze(self) -> TestSetup:
        additions = StructuralAdditions(tuple(self.links), tuple(self.element_scale))
        if self.sag_scale:
            from truthbench.effects.structural import sag_angles

            angles = sag_angles(self.plant, self.parameters, additions,
                                self.gravity_m_s2 * self.sag_scale)
            additions = StructuralAdditions(additions.links, additions.element_stiffness_scale,
                                            angles)
        return TestSetup(
            plant=self.plant, parameters=dict(self.parameters), additions=additions,
            input_filters=tuple(self.input_filters), output_filters=tuple(self.output_filters),
            delay_s=self.delay_s, noise_fraction=self.noise_fraction,
            bias_offset=self.bias_offset, bias_gain=self.bias_gain,
            disturbances=tuple(self.disturbances), nonlinear=tuple(self.nonlinear),
            loops=tuple(self.loops), effects=dict(self.effects))
