"""The free-free beam: a straight tube on soft suspension springs.

The beam lies along global x from 0 to L; z is vertical. Two suspension points
(default at the nodes nearest the first-mode nodal points, 0.224 L and 0.776 L) carry
vertical springs and dashpots (``suspension_stiffness_n_m``, ``suspension_damping_n_s_m``
each) and optional lateral (y) and axial (x) springs, so the plant has its six
rigid-body modes lifted to low suspension frequencies only in the restrained directions.
Shakers apply forces at stations; accelerometers read at stations.
"""

from __future__ import annotations

from typing import ClassVar

from truthbench.fe.assembly import Lumped
from truthbench.plants.base import ParameterInfo, Plant, register_plant

#: Nominal tube of METHOD section 9: aluminium, 25.4 mm OD, 1.65 mm wall, 1.8 m long.
ALUMINIUM_TUBE = {
    "E_pa": ParameterInfo(68.9e9, "Pa", "Young's modulus", per_group=True),
    "nu": ParameterInfo(0.33, "-", "Poisson's ratio", per_group=True),
    "rho_kg_m3": ParameterInfo(2700.0, "kg/m^3", "density", per_group=True),
    "r_m": ParameterInfo(0.0127 - 0.000825, "m", "mean wall radius", per_group=True),
    "t_m": ParameterInfo(0.00165, "m", "wall thickness", per_group=True),
    "L_m": ParameterInfo(1.8, "m", "length (L_m@g: one group's segment)", per_group=True),
    "modal_damping_ratio": ParameterInfo(0.005, "-", "damping ratio of every elastic mode",
                                         positive=False),
}


@register_plant
class FreeFreeBeam(Plant):
    """Tube beam on soft suspension springs (see module docstring)."""

    kind: ClassVar[str] = "free_free_beam"
    parameters: ClassVar[dict[str, ParameterInfo]] = {
        **ALUMINIUM_TUBE,
        "suspension_stiffness_n_m": ParameterInfo(
            200.0, "N/m", "vertical stiffness of each suspension point"),
        "suspension_damping_n_s_m": ParameterInfo(
            0.0, "N s/m", "vertical damping of each suspension point", positive=False),
        "suspension_lateral_stiffness_n_m": ParameterInfo(
            0.0, "N/m", "lateral (y) stiffness of each suspension point", positive=False),
        "suspension_axial_stiffness_n_m": ParameterInfo(
            0.0, "N/m", "axial (x) stiffness at the first suspension point", positive=False),
    }
    default_stations: ClassVar[dict[str, float]] = {
        "end_a": 0.0, "quarter": 0.25, "mid": 0.5, "three_quarter": 0.75, "end_b": 1.0,
    }
    #: suspension points, as fractions of the length (nearest node is used)
    suspension_fractions: ClassVar[tuple[float, float]] = (0.224, 0.776)

    def _boundary(self, p, mesh):
        nodes = [int(round(f * self.n_elements)) for f in self.suspension_fractions]
        springs, dashpots = [], []
        for i, n in enumerate(nodes):
            springs.append((6 * n + 2, p["suspension_stiffness_n_m"]))
            dashpots.append((6 * n + 2, p["suspension_damping_n_s_m"]))
            springs.append((6 * n + 1, p["suspension_lateral_stiffness_n_m"]))
            if i == 0:
                springs.append((6 * n + 0, p["suspension_axial_stiffness_n_m"]))
        return Lumped(springs=tuple(springs), dashpots=tuple(dashpots)), ()
