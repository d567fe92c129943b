"""Concentrated attachments to ground at a station (Table 10.1, joints / attachments):
a grounded spring and a grounded dashpot on one DOF.

They stand for what a model often lacks at a point: a support, a cable or a fixture
that adds stiffness (a spring), or concentrated damping (a dashpot, non-proportional
damping). ``direction`` is the DOF: a translation (x, y, z: N/m, N s/m) or a rotation
(rx, ry, rz: N m/rad, N m s/rad).
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
from truthbench.fe.assembly import direction_index


def _dof(setup, options) -> int:
    return 6 * setup.plant.station_node(options["station"]) + direction_index(
        options["direction"])


@register_effect
class GroundedSpring(Effect):
    name: ClassVar[str] = "grounded_spring"
    description: ClassVar[str] = ("a spring from one DOF of a station to ground (a support, "
                                  "cable or fixture the model lacks)")
    params: ClassVar = (EffectParam("stiffness_n_m", 0.0, "stiffness, N/m (N m/rad for a "
                                    "rotation)", 0.0),)
    options: ClassVar = {"station": None, "direction": "z"}
    diagnosis: ClassVar = Diagnosable(
        (FitParam("stiffness_n_m", "stiffness", 0.01, minimum=0.0),), location="station",
        directions="translation")

    def contribute(self, values, options, setup):
        dof = _dof(setup, options)
        if values["stiffness_n_m"] != 0:
            setup.links.append(("spring", dof, -1, values["stiffness_n_m"]))


@register_effect
class GroundedDashpot(Effect):
    name: ClassVar[str] = "grounded_dashpot"
    description: ClassVar[str] = ("a dashpot from one DOF of a station to ground "
                                  "(concentrated damping: non-proportional)")
    params: ClassVar = (EffectParam("damping_n_s_m", 0.0, "damping, N s/m (N m s/rad for a "
                                    "rotation)", 0.0),)
    options: ClassVar = {"station": None, "direction": "z"}
    diagnosis: ClassVar = Diagnosable(
        (FitParam("damping_n_s_m", "damping", 0.01, minimum=0.0),), location="station",
        directions="translation")

    def contribute(self, values, options, setup):
        dof = _dof(setup, options)
        if values["damping_n_s_m"] != 0:
            setup.links.append(("dashpot", dof, -1, values["damping_n_s_m"]))
