"""What every plant shares: parameters, sections, materials, stations, actuators, sensors.

A plant is a parametric builder: ``plant.build(params, actuators, sensors)`` returns a
:class:`~truthbench.model.StructuralModel`. Parameters are a flat mapping of named
physical values with units in the names (``E_pa``, ``rho_kg_m3``, ...). Element-group
values are written ``name@group`` (``E_pa@g2``) and fall back to the plain name.

The cross-section (``section``: ``"tube"``, ``"rectangular_bar"``, ``"circular_bar"``,
:data:`~truthbench.fe.beam.SECTIONS`) decides which dimension parameters the plant has
(:data:`SECTION_PARAMETERS`: ``r_m``, ``t_m``; ``b_m``, ``h_m``; ``d_m``); the
``material`` preset (:data:`MATERIALS`) gives the defaults of ``E_pa``, ``rho_kg_m3`` and
``nu``. The tube's dimensions default to the nominal tube of the hub-beam experiment
(:ref:`method-hub-beam`); a bar's
dimensions have no default and must be given.

Stations are named points along the beam, given as a fraction of the element count in
[0, 1]: the point ``fraction * n_elements`` counted in elements, a node when that is a
whole number, else the point that far into element ``floor(fraction * n_elements)``
(equal to the fraction of the length when the groups have equal lengths). Sensors,
actuators and the effects that act on a nodal DOF (joints, friction, sensor mass) need
a station on a node (:meth:`Plant.station_node`); point attachments (an added mass, a
grounded spring or dashpot) may sit anywhere along the beam: they act through the
element's shape functions at the point (:meth:`Plant.point_weights`,
:attr:`StructuralAdditions.points`). Positions in metres along the beam (from its first
end) map to nodes with :meth:`Plant.node_at_m` / :meth:`Plant.fraction_at_m`, within a
tolerance (:data:`DEFAULT_NODE_TOLERANCE_M`); :meth:`Plant.node_coordinates_m` and
:meth:`Plant.station_coordinates_m` give the coordinates of nodes and stations.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, fields
from typing import ClassVar

import numpy as np
import scipy.sparse as sp

from truthbench._validation import check_choice
from truthbench.errors import ModelError
from truthbench.fe.assembly import (
    DIRECTIONS,
    MATERIAL_KEYS,
    BeamMesh,
    assemble,
    direction_index,
    finish_structure,
    group_section,
)
from truthbench.fe.beam import SECTIONS, shear_modulus

SENSOR_QUANTITIES = ("displacement", "velocity", "acceleration", "strain")

#: What holds a test article, as its plant may declare it (``supports``; unset: what the
#: plant's kind implies, the behaviour before the declaration existed):
#:
#: ``springs``: it touches ground only at its suspension points, through springs (bungee
#: cords, soft springs); ``foam``: it lies on soft blocks at its suspension points (a
#: support stiffness of the order of the declared suspension stiffness, with the blocks'
#: damping); ``none``: nothing touches it (free flight, or a model with no supports).
SUPPORTS = ("springs", "foam", "none")

#: Material presets: the defaults of ``E_pa``, ``rho_kg_m3`` and ``nu`` (explicit
#: parameters override them).
#:
#: ``aluminium``: 6061-T6, typical values of the Aluminum Association (ASM Handbook
#: Vol. 2; MatWeb "Aluminum 6061-T6"): E = 68.9 GPa, rho = 2700 kg/m^3, nu = 0.33 -- the
#: nominal tube of the hub-beam experiment (:ref:`method-hub-beam`) and the default.
#:
#: ``steel``: plain carbon steel, E = 200 GPa, rho = 7850 kg/m^3, nu = 0.29 (Gere and
#: Goodno, *Mechanics of Materials*, Appendix H: E = 190-210 GPa, nu = 0.27-0.30,
#: 7850 kg/m^3; AS 1442 / AISI 1020: 200 GPa, 0.29).
MATERIALS: dict[str, dict[str, float]] = {
    "aluminium": {"E_pa": 68.9e9, "nu": 0.33, "rho_kg_m3": 2700.0},
    "steel": {"E_pa": 200.0e9, "nu": 0.29, "rho_kg_m3": 7850.0},
}
DEFAULT_MATERIAL = "aluminium"
DEFAULT_SECTION = "tube"

#: A position in metres maps to a node no farther than this, m. Large enough for any
#: decimal a user types for a node's position (rounding is ~1e-16 m), small enough that
#: the mapped point moves by at most 0.1 mm: a mode-shape error below
#: 2 pi (0.1 mm) / wavelength, 0.1 % for a 0.5 m bending wavelength.
DEFAULT_NODE_TOLERANCE_M = 1e-4

#: Element counts up to this are searched when a position misses every node.
_MAX_SUGGESTED_ELEMENTS = 2000

#: A station ``fraction * n_elements`` within this many elements of a whole number is on
#: that node (the rounding of a decimal fraction times the element count).
_NODE_TOLERANCE_ELEMENTS = 1e-9

_MATERIAL_INFO = {"E_pa": ("Pa", "Young's modulus"), "nu": ("-", "Poisson's ratio"),
                  "rho_kg_m3": ("kg/m^3", "density")}
@dataclass(frozen=True)
class Sensor:
    """A sensor at a station: direction x, y, z, rx, ry or rz; quantity one of
    displacement, velocity, acceleration or strain (bending strain at the outer surface
    on the +direction side, direction y or z)."""

    station: str
    direction: str
    quantity: str = "acceleration"

    @property
    def label(self) -> str:
        return f"{self.station}.{self.direction}.{self.quantity[:3]}"


@dataclass(frozen=True)
class Actuator:
    """A force (x, y, z, N) or moment (rx, ry, rz, N m) input at a station."""

    station: str
    direction: str

    @property
    def label(self) -> str:
        return f"{self.station}.{self.direction}"


@dataclass(frozen=True)
class ParameterInfo:
    """A named plant parameter: its default value (None: required, no default), unit,
    and whether it may be given per element group."""

    default: float | None
    unit: str
    description: str
    per_group: bool = False
    positive: bool = True


#: The dimension parameters of every section (units in the names), per element group.
#: The tube's defaults are the nominal tube of the hub-beam experiment (25.4 mm outside
#: diameter, 1.65 mm wall); the bars' dimensions are required.
SECTION_PARAMETERS: dict[str, dict[str, ParameterInfo]] = {
    "tube": {
        "r_m": ParameterInfo(0.0127 - 0.000825, "m", "mean wall radius", per_group=True),
        "t_m": ParameterInfo(0.00165, "m", "wall thickness", per_group=True),
    },
    "rectangular_bar": {
        "b_m": ParameterInfo(None, "m", "width along local y (horizontal)", per_group=True),
        "h_m": ParameterInfo(None, "m", "height along local z (vertical)", per_group=True),
    },
    "circular_bar": {
        "d_m": ParameterInfo(None, "m", "diameter", per_group=True),
    },
}
assert all(tuple(SECTION_PARAMETERS[k]) == SECTIONS[k].dimensions for k in SECTIONS)


@dataclass(frozen=True)
class Plant:
    """Base of the parametric plants. Subclasses define ``kind``, ``own_parameters``,
    ``default_stations`` and ``_boundary``.

    Parameters
    ----------
    n_elements : int
        Elements along the beam (a multiple of ``n_groups``).
    n_groups : int
        Element groups (equal numbers of elements; material, section and length values
        may differ per group).
    stations : mapping of str -> float
        Extra named stations, fraction of the element count in [0, 1] (see the module
        docstring: a station between nodes can carry only point attachments).
    timoshenko : bool or float
        Shear-deformable elements with rotary inertia (a number scales both:
        :func:`~truthbench.fe.beam.element_matrices`).
    section : str
        Cross-section, one of :data:`~truthbench.fe.beam.SECTIONS` (default "tube").
    material : str
        Material preset of :data:`MATERIALS` giving the defaults of ``E_pa``,
        ``rho_kg_m3`` and ``nu`` (default "aluminium").
    supports : str, optional
        What holds the article, one of the plant's :attr:`support_kinds` (a subset of
        :data:`SUPPORTS`); None (default): what the plant's kind implies. Where the
        article touches ground: :meth:`support_nodes`.
    """

    n_elements: int = 20
    n_groups: int = 1
    stations: Mapping[str, float] = field(default_factory=dict)
    timoshenko: bool | float = False
    section: str = DEFAULT_SECTION
    material: str = DEFAULT_MATERIAL
    supports: str | None = None

    kind: ClassVar[str] = "plant"
    own_parameters: ClassVar[dict[str, ParameterInfo]] = {}
    default_stations: ClassVar[dict[str, float]] = {}
    support_kinds: ClassVar[tuple[str, ...]] = ()
    """The values of ``supports`` this plant accepts (none: its ground contact is fixed
    by its kind, e.g. the hub-beam's bearing)."""

    def __post_init__(self):
        if int(self.n_elements) != self.n_elements or self.n_elements < 1:
            raise ModelError(f"n_elements must be a positive integer; got {self.n_elements!r}")
        if int(self.n_groups) != self.n_groups or not 1 <= self.n_groups <= self.n_elements:
            raise ModelError(f"n_groups must be an integer in 1..n_elements "
                             f"({self.n_elements}); got {self.n_groups!r}")
        if self.n_elements % self.n_groups:
            raise ModelError(f"n_elements ({self.n_elements}) must be a multiple of n_groups "
                             f"({self.n_groups}) so that every group has whole elements")
        check_choice("section", self.section, SECTIONS, where=self.kind, error=ModelError)
        check_choice("material", self.material, MATERIALS, where=self.kind, error=ModelError)
        if self.supports is not None:
            if not self.support_kinds:
                raise ModelError(f"{self.kind} has no 'supports' to declare (what holds it "
                                 f"is fixed by its kind); expected supports unset; got "
                                 f"{self.supports!r}")
            check_choice("supports", self.supports, self.support_kinds, where=self.kind,
                         error=ModelError)
        for name, fraction in dict(self.stations).items():  # on the beam, not on a node
            self._check_fraction(fraction, f"station {name!r}")

    # ---- groups and parameters -------------------------------------------------
    @property
    def parameters(self) -> dict[str, ParameterInfo]:
        """Every parameter of this plant, in order: material (defaults from the
        ``material`` preset), the section's dimensions, length, modal damping, then the
        plant's own (suspension, hub)."""
        preset = MATERIALS[self.material]
        table = {k: ParameterInfo(preset[k], *_MATERIAL_INFO[k], per_group=True)
                 for k in MATERIAL_KEYS}
        table.update(SECTION_PARAMETERS[self.section])
        table["L_m"] = ParameterInfo(1.8, "m", "length (L_m@g: one group's segment)",
                                     per_group=True)
        table["modal_damping_ratio"] = ParameterInfo(
            0.005, "-", "damping ratio of every elastic mode", positive=False)
        table.update(self.own_parameters)
        return table

    @property
    def group_names(self) -> tuple[str, ...]:
        return ("beam",) if self.n_groups == 1 else tuple(
            f"g{i + 1}" for i in range(self.n_groups))

    def element_groups(self) -> tuple[str, ...]:
        per = self.n_elements // self.n_groups
        return tuple(g for g in self.group_names for _ in range(per))

    def parameter_names(self) -> tuple[str, ...]:
        """Every parameter name this plant accepts, group-qualified names included."""
        table = self.parameters
        names = list(table)
        for name, info in table.items():
            if info.per_group and self.n_groups > 1:
                names += [f"{name}@{g}" for g in self.group_names]
        return tuple(names)

    def resolve(self, values: Mapping[str, float] | None = None) -> dict[str, float]:
        """Defaults overlaid with ``values``, checked: unknown names, non-positive values
        of positive parameters and missing required parameters (a bar's dimensions)
        raise :class:`ModelError`."""
        table = self.parameters
        out = {k: info.default for k, info in table.items()}
        known = set(self.parameter_names())
        for key, value in (values or {}).items():
            if key not in known:
                raise ModelError(self._unknown_parameter(key, known))
            base = key.split("@")[0]
            v = float(value)
            if not np.isfinite(v) or (table[base].positive and v <= 0):
                raise ModelError(f"parameter {key!r} must be a positive finite number "
                                 f"({table[base].unit}); got {value!r}")
            out[key] = v
        missing = [k for k, v in out.items() if v is None]
        if missing:
            need = ", ".join(f"{k!r} ({table[k].description}, {table[k].unit})"
                             for k in missing)
            raise ModelError(f"{self.kind} with a {self.section} section needs parameter(s) "
                             f"{need}: they have no default; got none")
        return out

    def _unknown_parameter(self, key: str, known) -> str:
        """The message for a parameter this plant lacks (naming the section whose
        dimension it is, if it is one)."""
        base = key.split("@")[0]
        owner = next((k for k, dims in SECTION_PARAMETERS.items() if base in dims), None)
        if owner is not None and owner != self.section:
            own = ", ".join(SECTION_PARAMETERS[self.section])
            return (f"{self.kind} with a {self.section} section has no parameter {key!r} (a "
                    f"dimension of the {owner} section); expected the {self.section} "
                    f"section's dimensions {own}")
        return (f"{self.kind} has no parameter {key!r}; expected one of "
                f"{', '.join(sorted(known))}")

    def group_value(self, params: Mapping[str, float], name: str, group: str) -> float:
        return params.get(f"{name}@{group}", params[name])

    def group_properties(self, params: Mapping[str, float]) -> dict[str, dict]:
        """Per group: the section name, material values and section dimensions (the
        mapping :func:`~truthbench.fe.assembly.assemble` takes)."""
        keys = MATERIAL_KEYS + SECTIONS[self.section].dimensions
        return {g: {"section": self.section,
                    **{k: self.group_value(params, k, g) for k in keys}}
                for g in self.group_names}

    def group_lengths_m(self, params: Mapping[str, float]) -> np.ndarray:
        """Length of each group's segment: ``L_m@g`` if given, else ``L_m / n_groups``."""
        return np.array([params.get(f"L_m@{g}", params["L_m"] / self.n_groups)
                         for g in self.group_names])

    def node_x_m(self, params: Mapping[str, float]) -> np.ndarray:
        """Axial coordinate of every node, m (groups split into equal elements)."""
        return self._node_x(self.group_lengths_m(params), self.n_elements)

    def _node_x(self, group_lengths_m: np.ndarray, n_elements: int) -> np.ndarray:
        per = n_elements // self.n_groups
        steps = np.repeat(group_lengths_m / per, per)
        return np.concatenate([[0.0], np.cumsum(steps)])

    # ---- positions in metres --------------------------------------------------------
    def _length_parameters(self, params: Mapping[str, float] | None) -> dict[str, float]:
        """``L_m`` (default if absent) and any ``L_m@g`` of ``params``, checked: the
        geometry of the mesh needs nothing else."""
        table = self.parameters
        known = set(self.parameter_names())
        out = {"L_m": table["L_m"].default}
        for key, value in (params or {}).items():
            if key.split("@")[0] != "L_m":
                continue
            if key not in known:
                raise ModelError(f"{self.kind} has no parameter {key!r}; expected one of "
                                 f"{', '.join(sorted(k for k in known if k.startswith('L_m')))}")
            v = float(value)
            if not np.isfinite(v) or v <= 0:
                raise ModelError(f"parameter {key!r} must be a positive finite number (m); "
                                 f"got {value!r}")
            out[key] = v
        return out

    def node_coordinates_m(self, params: Mapping[str, float] | None = None) -> np.ndarray:
        """Coordinates of every node, m: the beam along global x from 0, y = z = 0.

        Parameters
        ----------
        params : mapping, optional
            Plant parameters; only ``L_m`` and ``L_m@g`` are used (default: the
            default length).

        Returns
        -------
        ndarray, shape (n_nodes, 3)
            Node ``k`` is model DOF label prefix ``n<k>``.
        """
        x = self.node_x_m(self._length_parameters(params))
        return np.column_stack([x, np.zeros_like(x), np.zeros_like(x)])

    def station_coordinates_m(self, station: str,
                              params: Mapping[str, float] | None = None) -> np.ndarray:
        """Coordinates (x, y, z) of a station, m, shape (3,): its node, or the point
        between two nodes (a station between nodes)."""
        xyz = self.node_coordinates_m(params)
        a, xi = self._mesh_point(self.station_fraction(station))
        return xyz[a] if xi == 0.0 else (1.0 - xi) * xyz[a] + xi * xyz[a + 1]

    def node_at_m(self, x_m: float, params: Mapping[str, float] | None = None, *,
                  tolerance_m: float = DEFAULT_NODE_TOLERANCE_M) -> int:
        """The node at a position along the beam.

        Parameters
        ----------
        x_m : float
            Distance from the beam's first end along it, m, on the length of ``params``
            (the nominal length).
        params : mapping, optional
            Plant parameters (``L_m``, ``L_m@g``); default the default length.
        tolerance_m : float
            Largest distance from the position to the node, m.

        Returns
        -------
        int
            Node index.

        Raises
        ------
        ModelError
            The position is off the beam, or no node lies within ``tolerance_m``: the
            message gives the nearest node's position, the distance, and element counts
            that would put a node there.
        """
        if isinstance(x_m, bool) or not isinstance(x_m, int | float | np.floating) \
                or not np.isfinite(x_m):
            raise ModelError(f"position x_m must be a finite number (m); got {x_m!r}")
        if not tolerance_m > 0:
            raise ModelError(f"node tolerance must be > 0 m; got {tolerance_m!r}")
        lengths = self.group_lengths_m(self._length_parameters(params))
        x = self._node_x(lengths, self.n_elements)
        if x_m < -tolerance_m or x_m > x[-1] + tolerance_m:
            raise ModelError(f"position x_m = {x_m:g} m is off the beam, which runs from 0 to "
                             f"{x[-1]:g} m along its length from the first end")
        node = int(np.argmin(np.abs(x - x_m)))
        dist = abs(x[node] - x_m)
        if dist > tolerance_m:
            counts = self._counts_with_node_at(x_m, lengths, tolerance_m)
            hint = (f"n_elements = {', '.join(map(str, counts))} put a node there"
                    if counts else f"no n_elements up to {_MAX_SUGGESTED_ELEMENTS} puts a "
                                   f"node there")
            raise ModelError(
                f"position x_m = {x_m:g} m is not on a node of the {self.n_elements}-element "
                f"mesh: the nearest node (node {node}) is at {x[node]:g} m, {dist:.4g} m away "
                f"(tolerance {tolerance_m:g} m); {hint}")
        return node

    def fraction_at_m(self, x_m: float, params: Mapping[str, float] | None = None, *,
                      tolerance_m: float = DEFAULT_NODE_TOLERANCE_M) -> float:
        """:meth:`node_at_m` as a station fraction (``node / n_elements``)."""
        return self.node_at_m(x_m, params, tolerance_m=tolerance_m) / self.n_elements

    def _counts_with_node_at(self, x_m: float, group_lengths_m: np.ndarray,
                             tolerance_m: float, limit: int = 5) -> list[int]:
        """The first ``limit`` element counts (multiples of n_groups) with a node within
        ``tolerance_m`` of ``x_m``."""
        out = []
        for n in range(self.n_groups, _MAX_SUGGESTED_ELEMENTS + 1, self.n_groups):
            if np.min(np.abs(self._node_x(group_lengths_m, n) - x_m)) <= tolerance_m:
                out.append(n)
                if len(out) == limit:
                    break
        return out

    def support_nodes(self) -> tuple[int, ...]:  # pragma: no cover - abstract
        """Nodes where the article touches ground (suspension points, blocks, a bearing),
        in the plant's order; empty when nothing touches it (``supports = "none"``)."""
        raise NotImplementedError

    # ---- stations ----------------------------------------------------------------
    def station_fractions(self) -> dict[str, float]:
        return {**self.default_stations, **dict(self.stations)}

    def station_fraction(self, station: str) -> float:
        """The fraction of the element count of a station, in [0, 1], on a node or
        between nodes.

        Raises
        ------
        ModelError
            The plant has no such station.
        """
        fr = self.station_fractions()
        if station not in fr:
            raise ModelError(f"{self.kind} has no station {station!r}; stations are "
                             f"{', '.join(sorted(fr))}")
        return fr[station]

    def station_node(self, station: str) -> int:
        """The node of a station.

        Raises
        ------
        ModelError
            The plant has no such station, or the station lies between two nodes
            (only point attachments can sit there: :meth:`point_weights`).
        """
        fraction = self.station_fraction(station)
        a, xi = self._mesh_point(fraction)
        if xi != 0.0:
            raise ModelError(
                f"station {station!r} at fraction {fraction!r} of the length lies between "
                f"nodes {a} and {a + 1} of the {self.n_elements}-element mesh (nodes every "
                f"1/{self.n_elements} of the length); only point attachments (an added "
                f"mass, a grounded spring or dashpot) can sit between nodes: sensors, "
                f"actuators, joints (but a hinge: form = \"hinge\"), friction and sensor "
                f"mass need a station on a node")
        return a

    def _check_fraction(self, fraction, what: str) -> None:
        """Raise :class:`ModelError` unless ``fraction`` is a number in [0, 1]."""
        if isinstance(fraction, bool) or not isinstance(
                fraction, int | float | np.integer | np.floating) \
                or not 0.0 <= fraction <= 1.0:
            raise ModelError(f"{what} at fraction {fraction!r} is off the beam; expected a "
                             f"fraction of the length in [0, 1]")

    def _mesh_point(self, fraction: float) -> tuple[int, float]:
        """``(node, 0.0)`` for a fraction on a node; ``(a, xi)`` for a point between
        node ``a`` and ``a + 1``, ``xi`` in (0, 1) its local coordinate."""
        pos = fraction * self.n_elements
        node = int(round(pos))
        if abs(pos - node) <= _NODE_TOLERANCE_ELEMENTS:
            return node, 0.0
        a = math.floor(pos)
        return a, pos - a

    def element_section(self, element: int, params: Mapping[str, float]):
        """``(props, section, h)`` of one element at the resolved parameters
        ``params``: its group's properties (:meth:`group_properties`), its
        cross-section and its length, m."""
        group = self.element_groups()[element]
        props = self.group_properties(params)[group]
        x = self.node_x_m(params)
        return props, group_section(props, group), float(x[element + 1] - x[element])

    def shear_parameter(self, element: int, direction: str,
                        params: Mapping[str, float] | None = None) -> float:
        """The shear parameter ``phi = s 12 E I / (kappa G A h^2)`` of one element for
        bending with the translation ``direction`` ("y": the x-y plane, ``I_z``; "z":
        the x-z plane, ``I_y``), ``s`` the plant's ``timoshenko`` scale (0 for an
        Euler-Bernoulli plant), at ``params`` (resolved, or a partial mapping over the
        defaults)."""
        scale = float(self.timoshenko)
        if not scale:
            return 0.0
        p = params if params and "E_pa" in params and "L_m" in params \
            else self.resolve(params)
        props, sec, h = self.element_section(element, p)
        second = sec.second_moment_z_m4 if direction == "y" else sec.second_moment_y_m4
        E, nu = props["E_pa"], props["nu"]
        kGA = sec.shear_coefficient(nu) * shear_modulus(E, nu) * sec.area_m2
        return scale * 12.0 * E * second / (kGA * h * h)

    def point_weights(self, position: str | float, direction: str,
                      params: Mapping[str, float] | None = None
                      ) -> tuple[tuple[int, float], ...]:
        """The displacement of a point of the beam as a weighted sum of nodal DOFs.

        The DOF ``direction`` at the point is ``q(point) = sum(w * q[dof])`` over the
        returned pairs, from the shape functions of the element the point falls in: the
        cubic Hermite functions for the transverse translations y and z (weights on
        ``w_A, theta_A, w_B, theta_B``, with this code's rotations
        ``theta_z = +dv/dx``, ``theta_y = -dw/dx``), linear functions for the axial
        translation x and for the rotations rx, ry, rz. A rotation between nodes is the
        rotation of the cross-section there, interpolated linearly between the nodal
        rotations (the element's own twist field for rx; for the bending rotations ry,
        rz the usual choice, equal to the slope of the Hermite cubic at the nodes and
        within O(h^2) of it between them). For a Timoshenko element (``timoshenko``
        not 0) y and z follow its own displacement field, the interdependent
        interpolation of its stiffness and translational mass (Przemieniecki, Sect.
        5.6), exact for its statics: with ``c = 1 / (1 + phi)``,
        ``c (1 + phi - phi xi - 3 xi^2 + 2 xi^3)``, ``c h xi ((1 - xi)^2 + phi (1 - xi)
        / 2)``, ``c xi (phi + 3 xi - 2 xi^2)``, ``c h xi (xi^2 - xi - phi (1 - xi) / 2)``
        (``phi``: :meth:`shear_parameter`, about 2 for a 45 mm element of a 24 mm
        tube, where the Hermite cubic is 5 % off at a quarter of the element).

        A point on a node (within 1e-9 of an element, as :meth:`station_node`) gives
        that node's DOF alone with weight exactly 1.0. Cheap: a few arithmetic
        operations, no model is built.

        Parameters
        ----------
        position : str or float
            A station name, or a fraction of the element count in [0, 1] (as a station:
            the fraction of the length when the element groups have equal lengths).
        direction : {"x", "y", "z", "rx", "ry", "rz"}
            The DOF at the point.
        params : mapping, optional
            Plant parameters: ``L_m`` and ``L_m@g`` (the element's length, which scales
            the rotation weights of y and z), and for a Timoshenko element its material
            and section. Default: the defaults. Resolved parameters (with ``L_m``) are
            read as they are, a partial mapping is checked as in
            :meth:`node_coordinates_m`.

        Returns
        -------
        tuple of (int, float)
            ``(dof, weight)``: global (unreduced) DOF index ``6 * node + direction``
            and its dimensionless weight (m/rad on a rotation DOF of a y or z point).
            One pair on a node, two for a linear point, four for a Hermite point.

        Raises
        ------
        ModelError
            Unknown station or direction, or a fraction outside [0, 1].
        """
        if isinstance(position, str):
            fraction = self.station_fraction(position)  # checked by the constructor
        else:
            fraction = position
            self._check_fraction(fraction, "point")
        if direction not in DIRECTIONS:
            raise ModelError(f"point direction must be one of {', '.join(DIRECTIONS)}; "
                             f"got {direction!r}")
        d = DIRECTIONS.index(direction)
        a, xi = self._mesh_point(float(fraction))
        ga, gb = 6 * a + d, 6 * (a + 1) + d
        if xi == 0.0:
            return ((ga, 1.0),)
        if direction not in ("y", "z"):
            return ((ga, 1.0 - xi), (gb, xi))
        per = self.n_elements // self.n_groups
        h = float(self.group_lengths_m(params)[a // per]) / per \
            if params and "L_m" in params else math.nan
        if not 0.0 < h < math.inf:  # default length, or checked (raises if bad)
            h = float(self.group_lengths_m(self._length_parameters(params))[a // per]) / per
        # the rotation DOF of this bending plane, and the sign of theta = sign * dw/dx
        rot, sign = (5, 1.0) if direction == "y" else (4, -1.0)
        phi = self.shear_parameter(a, direction, params)
        xi2 = xi * xi
        # the element's own transverse displacement field (interdependent interpolation:
        # the exact static field of the Timoshenko element, the Hermite cubic at phi = 0)
        c = 1.0 / (1.0 + phi)
        return ((ga, c * (1.0 + phi - phi * xi - 3.0 * xi2 + 2.0 * xi2 * xi)),
                (6 * a + rot, sign * h * c * xi * ((1.0 - xi) ** 2 + 0.5 * phi * (1.0 - xi))),
                (gb, c * xi * (phi + 3.0 * xi - 2.0 * xi2)),
                (6 * (a + 1) + rot, sign * h * c * xi * (xi2 - xi - 0.5 * phi * (1.0 - xi))))

    # ---- the model ---------------------------------------------------------------
    def mesh(self, params: Mapping[str, float]) -> BeamMesh:
        """The beam along global x (z vertical), groups split into equal elements."""
        x = self.node_x_m(params)
        nodes = np.column_stack([x, np.zeros_like(x), np.zeros_like(x)])
        n = self.n_elements
        elements = np.column_stack([np.arange(n), np.arange(1, n + 1)])
        return BeamMesh(nodes, elements, self.element_groups())

    def global_dof(self, station: str, direction: str) -> int:
        """Global (unreduced) DOF index of a direction at a station."""
        return 6 * self.station_node(station) + direction_index(direction)

    def build(
        self,
        params: Mapping[str, float] | None = None,
        actuators: Sequence[Actuator] = (),
        sensors: Sequence[Sensor] = (),
        additions: StructuralAdditions | None = None,
    ):
        """Build the :class:`~truthbench.model.StructuralModel` for these parameters,
        with one input per actuator and one output per sensor.

        ``additions`` (from the truth simulator's effects) adds lumped masses, springs
        and dashpots between or at DOFs, scales element stiffness, and sets element sag
        angles."""
        from truthbench.model import StructuralModel

        p = self.resolve(params)
        asm = self._assemble(p, additions or StructuralAdditions())
        B = np.column_stack([self._input_column(asm, a) for a in actuators]) if actuators \
            else np.zeros((asm.n_free, 0))
        rows = [self._sensor_row(asm, s) for s in sensors]
        C_out = np.vstack(rows) if rows else np.zeros((0, asm.n_free))
        quantities = tuple("displacement" if s.quantity == "strain" else s.quantity
                           for s in sensors)
        return StructuralModel(
            M=asm.M, C=asm.C, K=asm.K, B=B, C_out=C_out, quantities=quantities,
            modal_damping_ratio=p.get("modal_damping_ratio", 0.0),
            dof_labels=tuple(asm.labels[i] for i in asm.free),
            input_labels=tuple(a.label for a in actuators),
            output_labels=tuple(s.label for s in sensors),
            node_positions_m=asm.nodes_m,
            metadata={"plant": self.kind, "parameters": p},
        )

    def _boundary(self, params, mesh):  # pragma: no cover - abstract
        """Lumped boundary elements and clamped global DOFs of the plant."""
        raise NotImplementedError

    def _assemble(self, p, additions: StructuralAdditions) -> Assembled:
        mesh = self.mesh(p)
        props = self.group_properties(p)
        sag = additions.sag_angles_rad
        key = (type(self).__name__, self.n_elements, self.n_groups, self.section,
               self.material, float(self.timoshenko), tuple(sorted(p.items())),
               None if sag is None else np.asarray(sag, float).tobytes())
        cached = _BASE_CACHE.get(key)
        if cached is None:
            cached = assemble(mesh, props, timoshenko=self.timoshenko, sag_angles_rad=sag)
            if len(_BASE_CACHE) >= _BASE_CACHE_SIZE:
                _BASE_CACHE.pop(next(iter(_BASE_CACHE)))
            _BASE_CACHE[key] = cached
        K, M = cached
        n = mesh.n_dofs
        for e, scale in additions.element_stiffness_scale:
            if not 0 <= e < self.n_elements:
                raise ModelError(f"element {e} does not exist (0..{self.n_elements - 1})")
            one = BeamMesh(mesh.nodes_m, mesh.elements[[e]], (mesh.groups[e],))
            ke, _ = assemble(one, props, timoshenko=self.timoshenko)
            K = K + (scale - 1.0) * ke
        dM, dC, dK = additions.matrices(n)
        lumped, clamped = self._boundary(p, mesh)
        Mf, Cf, Kf, free = finish_structure(K + dK, M + dM, n, lumped, clamped, C=dC)
        return Assembled(Mf, Cf, Kf, free, mesh.dof_labels(), mesh.nodes_m, props)

    def _dof(self, asm, station: str, direction: str) -> int:
        node = self.station_node(station)
        g = 6 * node + direction_index(direction)
        pos = np.searchsorted(asm.free, g)
        if pos >= len(asm.free) or asm.free[pos] != g:
            raise ModelError(f"DOF {direction!r} at station {station!r} is clamped in "
                             f"{self.kind}; it cannot carry a sensor or actuator")
        return int(pos)

    def _input_column(self, asm, act: Actuator) -> np.ndarray:
        col = np.zeros(asm.n_free)
        col[self._dof(asm, act.station, act.direction)] = 1.0
        return col

    def _sensor_row(self, asm, sen: Sensor) -> np.ndarray:
        if sen.quantity not in SENSOR_QUANTITIES:
            raise ModelError(f"sensor quantity must be one of {SENSOR_QUANTITIES}; "
                             f"got {sen.quantity!r}")
        if sen.direction not in DIRECTIONS:
            raise ModelError(f"sensor direction must be one of {DIRECTIONS}; "
                             f"got {sen.direction!r}")
        row = np.zeros(asm.n_free)
        if sen.quantity != "strain":
            row[self._dof(asm, sen.station, sen.direction)] = 1.0
            return row
        return self._strain_row(asm, sen)

    def _strain_row(self, asm, sen: Sensor) -> np.ndarray:
        """Bending strain at the outer surface on the +direction side:
        ``eps = -c * d2w/dx2`` from the Hermite shape functions of the adjacent element."""
        if sen.direction not in ("y", "z"):
            raise ModelError(f"a strain sensor measures bending in direction 'y' or 'z'; "
                             f"got {sen.direction!r}")
        node = self.station_node(sen.station)
        x = asm.nodes_m[:, 0]
        if node < self.n_elements:
            a, b, at_a = node, node + 1, True
        else:
            a, b, at_a = node - 1, node, False
        L = x[b] - x[a]
        w = direction_index(sen.direction)
        rot = 5 if sen.direction == "y" else 4
        sgn = 1.0 if sen.direction == "y" else -1.0  # theta_y = -dw/dx
        # d2w/dx2 at A: -6/L^2 wA - 4/L thA + 6/L^2 wB - 2/L thB; at B: negated pattern
        coef = (np.array([-6 / L**2, -4 / L, 6 / L**2, -2 / L]) if at_a
                else np.array([6 / L**2, 2 / L, -6 / L**2, 4 / L]))
        dofs = (6 * a + w, 6 * a + rot, 6 * b + w, 6 * b + rot)
        signs = (1.0, sgn, 1.0, sgn)
        group = self.element_groups()[a]
        c = group_section(asm.params_by_group[group], group).outer_fibre_m(sen.direction)
        row = np.zeros(asm.n_free)
        for g, cf, sg in zip(dofs, coef, signs, strict=True):
            pos = np.searchsorted(asm.free, g)
            if pos < len(asm.free) and asm.free[pos] == g:
                row[pos] += -c * cf * sg
        return row


@dataclass(frozen=True)
class StructuralAdditions:
    """Changes to a plant's structure, in global (unreduced) DOFs.

    Attributes
    ----------
    links : tuple of (kind, dof_a, dof_b, value)
        ``kind`` "mass", "spring" or "dashpot"; ``dof_b = -1`` grounds the element at
        ``dof_a`` (a lumped mass is always grounded in this sense); otherwise a spring or
        dashpot acts on the difference ``q_a - q_b`` (a joint across an element).
    element_stiffness_scale : tuple of (element, factor)
        Element stiffness multiplied by ``factor`` (a joint's stiffness loss: 1 - loss).
    sag_angles_rad : ndarray, shape (n_elements,), optional
        Element sag angles (Eq. 10.5-10.6).
    points : tuple of (kind, ((dof, weight), ...), value)
        Grounded mass, spring or dashpot on the displacement ``u^T q`` of one DOF at a
        point between nodes (``u`` the weights of :meth:`Plant.point_weights`): adds
        ``value * u u^T`` to M, K or C (kg, N/m, N s/m; N m/rad, N m s/rad on a
        rotation). A point with one weight of 1.0 is the grounded link at that DOF.
    """

    links: tuple[tuple[str, int, int, float], ...] = ()
    element_stiffness_scale: tuple[tuple[int, float], ...] = ()
    sag_angles_rad: np.ndarray | None = None
    points: tuple[tuple[str, tuple[tuple[int, float], ...], float], ...] = ()

    def matrices(self, n: int):
        """Sparse (n, n) additions to M, C and K: the links, then the points."""
        out = {"mass": [], "dashpot": [], "spring": []}
        for kind, a, b, v in self.links:
            if kind not in out:
                raise ModelError(f"unknown link kind {kind!r}; expected mass, spring or dashpot")
            if not 0 <= a < n or not -1 <= b < n:
                raise ModelError(f"link DOFs ({a}, {b}) outside 0..{n - 1}")
            if b < 0:
                out[kind].append(([a], [a], [v]))
            else:
                out[kind].append(([a, a, b, b], [a, b, a, b], [v, -v, -v, v]))
        for kind, weights, v in self.points:
            dofs = [g for g, _ in weights]
            if kind not in out:
                raise ModelError(f"unknown point kind {kind!r}; expected mass, spring or "
                                 f"dashpot")
            if not all(0 <= g < n for g in dofs):
                raise ModelError(f"point DOFs {tuple(dofs)} outside 0..{n - 1}")
            u = np.array([w for _, w in weights], dtype=float)
            out[kind].append((np.repeat(dofs, len(dofs)), np.tile(dofs, len(dofs)),
                              v * np.outer(u, u).ravel()))

        def build(entries):
            if not entries:
                return sp.csr_matrix((n, n))
            r = np.concatenate([e[0] for e in entries])
            c = np.concatenate([e[1] for e in entries])
            v = np.concatenate([e[2] for e in entries]).astype(float)
            return sp.csr_matrix((v, (r, c)), shape=(n, n))

        return build(out["mass"]), build(out["dashpot"]), build(out["spring"])


@dataclass(frozen=True)
class Assembled:
    """A plant's assembled matrices on the free DOFs, with what the I/O maps need."""

    M: object
    C: object
    K: object
    free: np.ndarray
    labels: tuple[str, ...]
    nodes_m: np.ndarray
    params_by_group: dict

    @property
    def n_free(self) -> int:
        return len(self.free)


_BASE_CACHE: dict = {}
"""The assembled K and M of the last few (plant, parameters, sag) seen: a model rebuilt
with the same structure and other additions (a candidate effect's finite differences,
a diagnosis's line searches) skips the element loop. The matrices are never changed in
place, so sharing them is safe."""
_BASE_CACHE_SIZE = 32

PLANTS: dict[str, type[Plant]] = {}


def register_plant(cls: type[Plant]) -> type[Plant]:
    """Class decorator adding a plant to the registry under ``cls.kind``."""
    PLANTS[cls.kind] = cls
    return cls


def make_plant(kind: str, **options) -> Plant:
    """The plant registered as ``kind``, with its options (n_elements, n_groups,
    stations, timoshenko, section, material, and the plant's own, e.g. the free-free
    beam's ``suspension_fractions``)."""
    if kind not in PLANTS:
        raise ModelError(f"unknown plant type {kind!r}; expected one of {sorted(PLANTS)}")
    cls = PLANTS[kind]
    names = [f.name for f in fields(cls)]
    unknown = [k for k in options if k not in names]
    if unknown:
        raise ModelError(f"{kind} has no option {unknown[0]!r}; expected one of "
                         f"{', '.join(names)}")
    return cls(**options)
