"""Realising effects: what every effect changed, collected then frozen into hardware.

A :class:`SetupBuilder` starts from the plant, the hardware's parameters and the test's
instrumentation; each effect adds its change (``Effect.contribute``);
:meth:`SetupBuilder.freeze` returns the immutable
:class:`~truthbench.effects.hardware.Hardware` that the simulator runs and the results
store records. :func:`realise` does it in one call for effects at chosen values.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace

from truthbench.effects.base import EffectSpec, mean_values
from truthbench.effects.hardware import Hardware
from truthbench.effects.structural import hinge_points, sag_angles
from truthbench.plants.base import Actuator, Plant, Sensor, StructuralAdditions


@dataclass
class SetupBuilder:
    """Mutable collector used only while effects contribute; see :meth:`freeze`."""

    plant: Plant
    parameters: dict
    actuators: tuple[Actuator, ...] = ()
    sensors: tuple[Sensor, ...] = ()
    links: list = field(default_factory=list)
    points: list = field(default_factory=list)
    element_scale: list = field(default_factory=list)
    hinges: list = field(default_factory=list)
    sag_scale: float = 0.0
    gravity_m_s2: float = 9.80665
    input_filters: list = field(default_factory=list)
    output_filters: list = field(default_factory=list)
    output_terms: list = field(default_factory=list)
    input_terms: list = field(default_factory=list)
    delay_s: float = 0.0
    noise_fraction: float = 0.0
    bias_offset: float = 0.0
    bias_gain: float = 1.0
    disturbances: list = field(default_factory=list)
    nonlinear: list = field(default_factory=list)
    loops: list = field(default_factory=list)
    effects: dict = field(default_factory=dict)

    @property
    def sensor_stations(self) -> tuple[str, ...]:
        """Stations carrying a sensor, in the sensors' order (repeats kept)."""
        return tuple(s.station for s in self.sensors)

    def scale_parameter(self, name: str, factor: float) -> None:
        """Multiply a plant parameter (group-qualified names fall back to the plain one)."""
        base = name.split("@")[0]
        self.parameters[name] = self.parameters.get(name, self.parameters[base]) * factor

    def attach(self, kind: str, position, direction: str, value: float) -> None:
        """A grounded point attachment: ``value`` (kind "mass", "spring" or "dashpot")
        on the displacement ``direction`` of the point ``position`` (a station or a
        fraction, as :meth:`~truthbench.plants.base.Plant.point_weights`; checked now).
        On a node (one weight of 1.0) it is the grounded link at that DOF, kept in
        :attr:`links` in the order the effects contribute, so the assembled matrices are
        the same to the last bit as those of a link. Between nodes it is kept as
        ``(kind, position, direction, value)`` in :attr:`points` and weighted by
        :meth:`freeze` with the element as the effects leave it: a Timoshenko element's
        weights depend on its shear (``element_physics``) and its length and section
        (a material or geometry effect), whichever effect comes last."""
        weights = self.plant.point_weights(position, direction, self.parameters)
        if len(weights) == 1 and weights[0][1] == 1.0:
            self.links.append((kind, weights[0][0], -1, value))
        else:
            self.points.append((kind, position, direction, value))

    def add(self, spec: EffectSpec, values: Mapping[str, float] | None = None,
            label: str | None = None) -> None:
        """Let one effect contribute with ``values`` (default its means) and record them
        under ``label`` (default the effect's name, or ``name#k`` when taken)."""
        values = mean_values(spec) if values is None else dict(values)
        spec.effect.contribute(values, spec.options, self)
        if label is None:
            label = spec.name if spec.name not in self.effects else \
                f"{spec.name}#{len(self.effects)}"
        self.effects[label] = {"scope": spec.scope, **spec.options, **values}

    def freeze(self) -> Hardware:
        # a joint's hinge (element, xi, direction, loss) on the element as the effects
        # leave it (its shear deformation, its parameters)
        points = tuple(
            (kind, self.plant.point_weights(position, d, self.parameters), value)
            for kind, position, d, value in self.points) + tuple(
            p for h in self.hinges for p in hinge_points(self.plant, self.parameters, *h))
        additions = StructuralAdditions(tuple(self.links), tuple(self.element_scale),
                                        points=points)
        if self.sag_scale:
            angles = sag_angles(self.plant, self.parameters, additions,
                                self.gravity_m_s2 * self.sag_scale)
            additions = replace(additions, sag_angles_rad=angles)
        return Hardware(
            plant=self.plant, parameters=dict(self.parameters), actuators=self.actuators,
            sensors=self.sensors, additions=additions,
            input_filters=tuple(self.input_filters), output_filters=tuple(self.output_filters),
            output_terms=tuple(self.output_terms), input_terms=tuple(self.input_terms),
            delay_s=self.delay_s, noise_fraction=self.noise_fraction,
            bias_offset=self.bias_offset, bias_gain=self.bias_gain,
            disturbances=tuple(self.disturbances), nonlinear=tuple(self.nonlinear),
            loops=tuple(self.loops), effects=dict(self.effects))


def realise(plant: Plant, parameters: Mapping[str, float], effects=(), *,
            actuators: Sequence[Actuator] = (), sensors: Sequence[Sensor] = ()
            ) -> Hardware:
    """The hardware of ``plant`` at ``parameters`` with ``effects`` at chosen values.

    Parameters
    ----------
    plant : Plant
    parameters : mapping
        Plant parameters (resolved against the plant's defaults and checked).
    effects : sequence
        Each an :class:`~truthbench.effects.EffectSpec` (at its mean values) or a pair
        ``(EffectSpec, values)``; they contribute in order.
    actuators, sensors : sequence of Actuator, Sensor
        The instrumentation.

    Returns
    -------
    Hardware
    """
    builder = SetupBuilder(plant=plant, parameters=plant.resolve(parameters),
                           actuators=tuple(actuators), sensors=tuple(sensors))
    for entry in effects:
        spec, values = entry if isinstance(entry, tuple) else (entry, None)
        builder.add(spec, values)
    return builder.freeze()
