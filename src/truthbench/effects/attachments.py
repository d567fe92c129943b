"""Concentrated attachments to ground at a station (Table 10.1, joints / attachments):
a grounded spring and a grounded dashpot on one DOF.

They stand for what a model often lacks at a point: a support, a cable or a fixture
that adds stiffness (a spring), or concentrated damping (a dashpot, non-proportional
damping). ``direction`` is the DOF: a translation (x, y, z: N/m, N s/m) or a rotation
(rx, ry, rz: N m/rad, N m s/rad).

The station may lie on a node or between nodes. The element acts on the displacement
``u^T q`` of its DOF at the point, ``u`` the weights of
:meth:`~truthbench.plants.base.Plant.point_weights` (Hermite functions for y and z,
linear for x and the rotations): a spring ``k`` adds ``k u u^T`` to K, a dashpot ``c``
adds ``c u u^T`` to C. On a node ``u`` is that DOF alone with weight 1: ``k`` (``c``) on
the diagonal, as a lumped element.
"""

from __future__ import annotations

from typing import ClassVar

from truthbench.effects.base import (
    Diagnosable,
    Effect,
    EffectParam,
    FitParam,
    register_effect,
)


def _attach(setup, options, kind: str, value: float) -> None:
    """``value`` of ``kind`` to ground at the effect's station and direction (checked
    even when ``value`` is 0; nothing is added then, so a fit is smooth through 0)."""
    setup.plant.point_weights(options["station"], options["direction"], setup.parameters)
    if value != 0:
        setup.attach(kind, options["station"], options["direction"], value)


@register_effect
class GroundedSpring(Effect):
    name: ClassVar[str] = "grounded_spring"
    description: ClassVar[str] = ("a spring from one DOF of a station to ground (a support, "
                                  "cable or fixture the model lacks)")
    params: ClassVar = (EffectParam("stiffness_n_m", 0.0, "stiffness, N/m (N m/rad for a "
                                    "rotation)", 0.0),)
    options: ClassVar = {"station": None, "direction": "z"}
    between_nodes: ClassVar[bool] = True
    diagnosis: ClassVar = Diagnosable(
        (FitParam("stiffness_n_m", "stiffness", 0.01, minimum=0.0),), location="station",
        directions="translation")

    def contribute(self, values, options, setup):
        _attach(setup, options, "spring", values["stiffness_n_m"])


@register_effect
class GroundedDashpot(Effect):
    name: ClassVar[str] = "grounded_dashpot"
    description: ClassVar[str] = ("a dashpot from one DOF of a station to ground "
                                  "(concentrated damping: non-proportional)")
    params: ClassVar = (EffectParam("damping_n_s_m", 0.0, "damping, N s/m (N m s/rad for a "
                                    "rotation)", 0.0),)
    options: ClassVar = {"station": None, "direction": "z"}
    between_nodes: ClassVar[bool] = True
    diagnosis: ClassVar = Diagnosable(
        (FitParam("damping_n_s_m", "damping", 0.01, minimum=0.0),), location="station",
        directions="translation")

    def contribute(self, values, options, setup):
        _attach(setup, options, "dashpot", values["damping_n_s_m"])
