"""How sensors and shakers are mounted (Table 10.1, testing): off the beam's axis, with
cross-axis sensitivity and a misaligned force line.

A real accelerometer does not sit on the beam's axis, and it reads a little of the
motion across its axis; a shaker's stinger is glued a few millimetres off the axis and
a degree or two off its direction. So a test on a beam bent in z also sees the beam's
torsion and its lateral (y) motion, which a model with ideal channels cannot. These
effects are part of a truth, not diagnosis candidates (no ``diagnosis`` form).

Both act on the test's channel maps, not on the structure: each adds weighted DOFs at
the channel's own station to its output row or input column
(:attr:`~truthbench.effects.hardware.Hardware.output_terms` and
:attr:`~truthbench.effects.hardware.Hardware.input_terms`), so the periodic, time and
nonlinear simulation paths all see them.

Geometry. The beam lies along x. A channel in direction ``d`` (x, y or z) has the
perpendicular transverse direction ``p`` of :data:`PERPENDICULAR` (z -> y, y -> z,
x -> z); the offset ``e`` moves the point along ``p``, ``r = e p``. A point of the
cross-section moves rigidly with its node, ``u_P = u + theta x r``, so a sensor reads
``d . u_P + c p . u_P = u_d + theta . (r x d) + c u_p`` (``c`` the cross-axis
sensitivity; ``p . (theta x r) = 0`` since ``r`` is along ``p``). A shaker's force of
recorded size ``F`` acts along ``f = cos(a) d + sin(a) p`` (``a`` the misalignment) at
the point ``r``: the force ``F f`` and the moment ``F r x f``. For a vertical (z)
channel: the sensor reads ``w + e theta_x + c v``; the shaker applies
``F cos(a)`` in z, ``F sin(a)`` in y and the torque ``e F cos(a)`` about x.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import ClassVar

import numpy as np

from truthbench.effects.base import Effect, EffectParam, register_effect
from truthbench.errors import ModelError

PERPENDICULAR = {"x": "z", "y": "z", "z": "y"}
"""The transverse direction across a channel's own, along which its offset lies."""

_UNIT = {a: np.eye(3)[i] for i, a in enumerate("xyz")}


def channel_index(which, labels: Sequence[str], effect: str, kind: str) -> int | None:
    """The index of the channel an effect's option names.

    Parameters
    ----------
    which : int or str
        An index into the test's channels, or a channel label (e.g. ``mid.z.acc``).
    labels : sequence of str
        The test's channel labels, in order.
    effect, kind : str
        The effect's name and the channel kind ("sensor", "actuator") for messages.

    Returns
    -------
    int or None
        None when a label names a channel this test does not have (the effect then does
        nothing in this test).

    Raises
    ------
    ModelError
        An index outside the test's channels.
    """
    if isinstance(which, str) and not which.lstrip("-").isdigit():
        return labels.index(which) if which in labels else None
    k = int(which)
    if not 0 <= k < len(labels):
        raise ModelError(f"effect {effect!r}: {kind} {k} does not exist; the test has "
                         f"{kind}s 0..{len(labels) - 1}")
    return k


def _translation(direction: str, effect: str, kind: str) -> None:
    if direction not in PERPENDICULAR:
        raise ModelError(f"effect {effect!r} acts on a translational {kind} (x, y or z); "
                         f"got direction {direction!r}")


def _moment_terms(r: np.ndarray, f: np.ndarray) -> list[tuple[str, float]]:
    """The rotation DOFs of ``r x f`` with their non-zero weights."""
    m = np.cross(r, f)
    return [(f"r{a}", float(m[i])) for i, a in enumerate("xyz") if m[i] != 0.0]


def sensor_terms(direction: str, offset_m: float, cross_axis: float
                 ) -> list[tuple[str, float]]:
    """Weighted DOFs a mounted translational sensor reads besides its own direction.

    Parameters
    ----------
    direction : {"x", "y", "z"}
        The sensor's direction ``d``.
    offset_m : float
        Offset ``e`` of the sensing point from the axis along ``p = PERPENDICULAR[d]``, m.
    cross_axis : float
        Cross-axis sensitivity ``c``: the fraction of the motion along ``p`` it reads.

    Returns
    -------
    list of (direction, weight)
        ``(r x d)`` on the rotations (m per rad), ``c`` on ``p``; zero weights left out.
    """
    _translation(direction, "sensor_mounting", "sensor")
    p = PERPENDICULAR[direction]
    out = _moment_terms(offset_m * _UNIT[p], _UNIT[direction])
    if cross_axis != 0.0:
        out.append((p, float(cross_axis)))
    return out


def shaker_terms(direction: str, offset_m: float, misalignment_deg: float
                 ) -> list[tuple[str, float]]:
    """Weighted DOFs a mounted shaker drives, added to its own direction's unit weight.

    Parameters
    ----------
    direction : {"x", "y", "z"}
        The actuator's direction ``d``.
    offset_m : float
        Offset ``e`` of the force line from the axis along ``p = PERPENDICULAR[d]``, m.
    misalignment_deg : float
        Angle ``a`` of the force line from ``d`` towards ``p``, degrees.

    Returns
    -------
    list of (direction, weight)
        ``cos(a) - 1`` on ``d``, ``sin(a)`` on ``p``, ``r x f`` on the rotations (m);
        zero weights left out.
    """
    _translation(direction, "shaker_mounting", "actuator")
    p = PERPENDICULAR[direction]
    a = np.deg2rad(misalignment_deg)
    f = np.cos(a) * _UNIT[direction] + np.sin(a) * _UNIT[p]
    out = [(direction, float(np.cos(a) - 1.0)), (p, float(np.sin(a)))]
    out = [t for t in out if t[1] != 0.0]
    return out + _moment_terms(offset_m * _UNIT[p], f)


class _Mounting(Effect):
    """An effect on one channel's map: ``side`` "sensor" (its output row) or "actuator"
    (its input column), named by the option of that name (index or label)."""

    target: ClassVar[str] = "measurement"
    per_test_channels: ClassVar[bool] = True
    side: ClassVar[str] = "sensor"

    def terms(self, channel, values) -> list[tuple[str, float]]:  # pragma: no cover
        raise NotImplementedError

    def contribute(self, values, options, setup):
        sensor = self.side == "sensor"
        channels = setup.sensors if sensor else setup.actuators
        k = channel_index(options[self.side], [c.label for c in channels], self.name,
                          self.side)
        if k is None:
            return  # that channel is not in this test
        out = setup.output_terms if sensor else setup.input_terms
        out.extend((k, direction, weight) for direction, weight in
                   self.terms(channels[k], values))


@register_effect
class SensorMounting(_Mounting):
    name: ClassVar[str] = "sensor_mounting"
    description: ClassVar[str] = (
        "a sensor's sensing point lies off the beam's axis by `offset_m` across its "
        "direction (it reads offset x the rotation: torsion for a vertical sensor) and it "
        "reads `cross_axis` of the transverse motion across its direction; `sensor` is the "
        "index of the test's sensor or its label")
    params: ClassVar = (
        EffectParam("offset_m", 0.0, "offset of the sensing point from the axis, along the "
                    "transverse direction across the sensor's (z -> y, y -> z, x -> z), m"),
        EffectParam("cross_axis", 0.0, "cross-axis sensitivity: fraction of the motion "
                    "across the sensor's direction that it reads"))
    options: ClassVar = {"sensor": 0}
    neutral: ClassVar = {"offset_m": 0.0, "cross_axis": 0.0}

    def terms(self, channel, values):
        if channel.quantity == "strain":
            raise ModelError(f"effect 'sensor_mounting' acts on a motion sensor; sensor "
                             f"{channel.label!r} measures strain")
        return sensor_terms(channel.direction, values["offset_m"], values["cross_axis"])


@register_effect
class ShakerMounting(_Mounting):
    name: ClassVar[str] = "shaker_mounting"
    description: ClassVar[str] = (
        "a shaker's force line lies off the beam's axis by `offset_m` (it applies a torque "
        "offset x force) and is tilted by `misalignment_deg` across its direction (a "
        "transverse force F sin(angle)); `actuator` is the index of the test's actuator or "
        "its label")
    params: ClassVar = (
        EffectParam("offset_m", 0.0, "offset of the force line from the axis, along the "
                    "transverse direction across the actuator's (z -> y, y -> z, x -> z), m"),
        EffectParam("misalignment_deg", 0.0, "angle of the force line from the actuator's "
                    "direction towards that transverse direction, degrees"))
    options: ClassVar = {"actuator": 0}
    side: ClassVar[str] = "actuator"
    neutral: ClassVar = {"offset_m": 0.0, "misalignment_deg": 0.0}

    def terms(self, channel, values):
        return shaker_terms(channel.direction, values["offset_m"], values["misalignment_deg"])
