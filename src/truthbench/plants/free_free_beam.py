"""The free-free beam: a straight beam on soft suspension springs.

The beam lies along global x from 0 to L; z is vertical. Suspension points (default
two, at the nodes nearest the first-mode nodal points, 0.224 L and 0.776 L; or any
nodes given by ``suspension_fractions``) carry vertical springs and dashpots
(``suspension_stiffness_n_m``, ``suspension_damping_n_s_m`` each) and optional lateral
(y) springs; the first point also an optional axial (x) spring. So the plant has its
six rigid-body modes lifted to low suspension frequencies only in the restrained
directions. Shakers apply forces at stations; accelerometers read at stations.

A campaign gives the points in metres (``[plant] suspension_x_m``); they are turned into
node fractions on the nominal length (:meth:`~truthbench.plants.base.Plant.fraction_at_m`).

What holds the beam may be declared (``supports``, :data:`~truthbench.plants.base.SUPPORTS`):
``"springs"`` (it touches ground only at its suspension points, through springs) and
``"foam"`` (it lies on soft blocks at its suspension points) give the same model, springs
and dashpots at the suspension points; ``"none"`` (nothing touches it: free flight, or a
model with no supports) gives the beam alone, with its six rigid-body modes at 0 Hz and
no suspension parameters. Unset, the beam hangs on its suspension as before.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from truthbench.errors import ModelError
from truthbench.fe.assembly import Lumped
from truthbench.plants.base import SUPPORTS, ParameterInfo, Plant, register_plant


@register_plant
@dataclass(frozen=True)
class FreeFreeBeam(Plant):
    """Beam on soft suspension springs (see module docstring).

    Parameters
    ----------
    suspension_fractions : tuple of float, optional
        Suspension points as fractions of the element count, each on a node (node
        ``fraction * n_elements``). Default: the nodes nearest
        :attr:`default_suspension_fractions`. Not with ``supports = "none"``.
    """

    suspension_fractions: tuple[float, ...] | None = None

    kind: ClassVar[str] = "free_free_beam"
    own_parameters: ClassVar[dict[str, ParameterInfo]] = {
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
    #: default suspension points, as fractions of the length (nearest node is used)
    default_suspension_fractions: ClassVar[tuple[float, float]] = (0.224, 0.776)
    support_kinds: ClassVar[tuple[str, ...]] = SUPPORTS

    def __post_init__(self):
        super().__post_init__()
        if self.supports == "none" and self.suspension_fractions is not None:
            raise ModelError(f"supports = 'none' declares that nothing touches the beam; "
                             f"expected no suspension points, got suspension_fractions = "
                             f"{self.suspension_fractions!r}")
        if self.suspension_fractions is not None:
            fr = tuple(float(f) for f in self.suspension_fractions)
            if not fr:
                raise ModelError("suspension_fractions must hold at least one point; got ()")
            object.__setattr__(self, "suspension_fractions", fr)
            self.suspension_nodes()  # on nodes

    @property
    def parameters(self) -> dict[str, ParameterInfo]:
        """Every parameter (:attr:`Plant.parameters`); the suspension's only while
        something holds the beam (not with ``supports = "none"``)."""
        table = super().parameters
        if self.supports == "none":
            for name in self.own_parameters:
                del table[name]
        return table

    def _unknown_parameter(self, key: str, known) -> str:
        if self.supports == "none" and key.split("@")[0] in self.own_parameters:
            return (f"{self.kind} with supports = 'none' has no parameter {key!r}: nothing "
                    f"holds the beam, so it has no suspension; expected none of "
                    f"{', '.join(self.own_parameters)}")
        return super()._unknown_parameter(key, known)

    def support_nodes(self) -> tuple[int, ...]:
        """Nodes where the beam touches ground: its suspension points, none with
        ``supports = "none"``."""
        return () if self.supports == "none" else self.suspension_nodes()

    def suspension_nodes(self) -> tuple[int, ...]:
        """Node of every suspension point (where the springs act unless ``supports =
        "none"``; see :meth:`support_nodes`)."""
        if self.suspension_fractions is None:
            return tuple(int(round(f * self.n_elements))
                         for f in self.default_suspension_fractions)
        out = []
        for f in self.suspension_fractions:
            pos = f * self.n_elements
            node = int(round(pos))
            if not 0.0 <= f <= 1.0 or abs(pos - node) > 1e-9:
                raise ModelError(f"suspension point at fraction {f!r} of the length is not "
                                 f"on a node of the {self.n_elements}-element mesh (nodes "
                                 f"every 1/{self.n_elements} of the length)")
            out.append(node)
        return tuple(out)

    def _boundary(self, p, mesh):
        if self.supports == "none":
            return Lumped(), ()
        springs, dashpots = [], []
        for i, n in enumerate(self.suspension_nodes()):
            springs.append((6 * n + 2, p["suspension_stiffness_n_m"]))
            dashpots.append((6 * n + 2, p["suspension_damping_n_s_m"]))
            springs.append((6 * n + 1, p["suspension_lateral_stiffness_n_m"]))
            if i == 0:
                springs.append((6 * n + 0, p["suspension_axial_stiffness_n_m"]))
        return Lumped(springs=tuple(springs), dashpots=tuple(dashpots)), ()
