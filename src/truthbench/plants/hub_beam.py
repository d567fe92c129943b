"""The hub-beam: a rigid hub turning about its vertical axis with a clamped beam.

The hub (inertia ``hub_inertia_kg_m2`` about global z, radius neglected) sits at the
origin; the beam runs along x and bends in the plane of rotation (x-y) and out of it
(x-z). The beam root node is the hub: its translations and its rotations about x and y
are clamped (a stiff bearing), its rotation about z is the hub angle. A torque motor
drives the hub (actuator ``hub``/``rz``) and a concentrated rotational dashpot
``hub_damping_n_m_s_rad`` acts between hub and ground, so the structure's damping is
not proportional. Sensors: hub angle and rate (``hub``/``rz`` displacement or
velocity), beam accelerations at stations, root bending strain (``root``/``y`` strain).

With ``eta = J_h / (rho A L^3)`` the in-plane frequencies follow the hub-beam frequency
equation (:ref:`method-oracles`).
"""

from __future__ import annotations

from typing import ClassVar

from truthbench.fe.assembly import Lumped
from truthbench.plants.base import ParameterInfo, Plant, register_plant


@register_plant
class HubBeam(Plant):
    """Rigid hub plus clamped beam (see module docstring)."""

    kind: ClassVar[str] = "hub_beam"
    own_parameters: ClassVar[dict[str, ParameterInfo]] = {
        # eta = 1 for the nominal tube: J_h = rho A L^3 (the chapter's Section 10.5)
        "hub_inertia_kg_m2": ParameterInfo(1.9385, "kg m^2", "hub inertia about its axis"),
        "hub_damping_n_m_s_rad": ParameterInfo(
            5.0, "N m s/rad", "concentrated rotational dashpot at the hub", positive=False),
    }
    default_stations: ClassVar[dict[str, float]] = {
        "hub": 0.0, "root": 0.0, "quarter": 0.25, "mid": 0.5, "three_quarter": 0.75,
        "tip": 1.0,
    }

    def support_nodes(self) -> tuple[int, ...]:
        """The hub (node 0): its bearing is the beam's only contact with ground."""
        return (0,)

    def _boundary(self, p, mesh):
        lumped = Lumped(masses=((5, p["hub_inertia_kg_m2"]),),
                        dashpots=((5, p["hub_damping_n_m_s_rad"]),))
        return lumped, tuple(range(5))
