"""What every plant shares: parameters, stations, actuators, sensors, the registry.

A plant is a parametric builder: ``plant.build(params, actuators, sensors)`` returns a
:class:`~truthbench.model.StructuralModel`. Parameters are a flat mapping of named
physical values with units in the names (``E_pa``, ``rho_kg_m3``, ...). Element-group
values are written ``name@group`` (``E_pa@g2``) and fall back to the plain name.

Stations are named points along the beam, given as a fraction of its length; each must
fall on a node of the mesh. Sensors and actuators are placed at stations.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
import scipy.sparse as sp

from truthbench.errors import ModelError
from truthbench.fe.assembly import (
    DIRECTIONS,
    BeamMesh,
    assemble,
    direction_index,
    finish_structure,
)

SENSOR_QUANTITIES = ("displacement", "velocity", "acceleration", "strain")
MATERIAL_KEYS = ("E_pa", "nu", "rho_kg_m3", "r_m", "t_m")


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
    """A named plant parameter: its default value, unit, and whether it may be given
    per element group."""

    default: float
    unit: str
    description: str
    per_group: bool = False
    positive: bool = True


@dataclass(frozen=True)
class Plant:
    """Base of the parametric plants. Subclasses define ``kind``, ``parameters``,
    ``default_stations`` and ``_assemble``."""

    n_elements: int = 20
    n_groups: int = 1
    stations: Mapping[str, float] = field(default_factory=dict)
    timoshenko: bool = False

    kind: ClassVar[str] = "plant"
    parameters: ClassVar[dict[str, ParameterInfo]] = {}
    default_stations: ClassVar[dict[str, float]] = {}

    def __post_init__(self):
        if int(self.n_elements) != self.n_elements or self.n_elements < 1:
            raise ModelError(f"n_elements must be a positive integer; got {self.n_elements!r}")
        if int(self.n_groups) != self.n_groups or not 1 <= self.n_groups <= self.n_elements:
            raise ModelError(f"n_groups must be an integer in 1..n_elements "
                             f"({self.n_elements}); got {self.n_groups!r}")
        if self.n_elements % self.n_groups:
            raise ModelError(f"n_elements ({self.n_elements}) must be a multiple of n_groups "
                             f"({self.n_groups}) so that every group has whole elements")
        for name in self.stations:  # user stations must lie on nodes
            self.station_node(name)

    # ---- groups and parameters -------------------------------------------------
    @property
    def group_names(self) -> tuple[str, ...]:
        return ("beam",) if self.n_groups == 1 else tuple(
            f"g{i + 1}" for i in range(self.n_groups))

    def element_groups(self) -> tuple[str, ...]:
        per = self.n_elements // self.n_groups
        return tuple(g for g in self.group_names for _ in range(per))

    def parameter_names(self) -> tuple[str, ...]:
        """Every parameter name this plant accepts, group-qualified names included."""
        names = list(self.parameters)
        for name, info in self.parameters.items():
            if info.per_group and self.n_groups > 1:
                names += [f"{name}@{g}" for g in self.group_names]
        return tuple(names)

    def resolve(self, values: Mapping[str, float] | None = None) -> dict[str, float]:
        """Defaults overlaid with ``values``, checked: unknown names and non-positive
        values of positive parameters raise :class:`ModelError`."""
        out = {k: info.default for k, info in self.parameters.items()}
        known = set(self.parameter_names())
        for key, value in (values or {}).items():
            if key not in known:
                raise ModelError(f"{self.kind} has no parameter {key!r}; expected one of "
                                 f"{', '.join(sorted(known))}")
            base = key.split("@")[0]
            v = float(value)
            if not np.isfinite(v) or (self.parameters[base].positive and v <= 0):
                raise ModelError(f"parameter {key!r} must be a positive finite number "
                                 f"({self.parameters[base].unit}); got {value!r}")
            out[key] = v
        return out

    def group_value(self, params: Mapping[str, float], name: str, group: str) -> float:
        return params.get(f"{name}@{group}", params[name])

    def group_properties(self, params: Mapping[str, float]) -> dict[str, dict[str, float]]:
        return {g: {k: self.group_value(params, k, g) for k in MATERIAL_KEYS}
                for g in self.group_names}

    def group_lengths_m(self, params: Mapping[str, float]) -> np.ndarray:
        """Length of each group's segment: ``L_m@g`` if given, else ``L_m / n_groups``."""
        return np.array([params.get(f"L_m@{g}", params["L_m"] / self.n_groups)
                         for g in self.group_names])

    def node_x_m(self, params: Mapping[str, float]) -> np.ndarray:
        """Axial coordinate of every node, m (groups split into equal elements)."""
        per = self.n_elements // self.n_groups
        steps = np.repeat(self.group_lengths_m(params) / per, per)
        return np.concatenate([[0.0], np.cumsum(steps)])

    # ---- stations ----------------------------------------------------------------
    def station_fractions(self) -> dict[str, float]:
        return {**self.default_stations, **dict(self.stations)}

    def station_node(self, station: str) -> int:
        fr = self.station_fractions()
        if station not in fr:
            raise ModelError(f"{self.kind} has no station {station!r}; stations are "
                             f"{', '.join(sorted(fr))}")
        pos = fr[station] * self.n_elements
        node = int(round(pos))
        if not 0.0 <= fr[station] <= 1.0 or abs(pos - node) > 1e-9:
            raise ModelError(
                f"station {station!r} at fraction {fr[station]!r} of the length is not on a "
                f"node of the {self.n_elements}-element mesh (nodes every "
                f"1/{self.n_elements} of the length)")
        return node

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
        K, M = assemble(mesh, props, timoshenko=self.timoshenko,
                        sag_angles_rad=additions.sag_angles_rad)
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
        c = asm.params_by_group[group]["r_m"] + 0.5 * asm.params_by_group[group]["t_m"]
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
        Element sag angles (METHOD section 3).
    """

    links: tuple[tuple[str, int, int, float], ...] = ()
    element_stiffness_scale: tuple[tuple[int, float], ...] = ()
    sag_angles_rad: np.ndarray | None = None

    def matrices(self, n: int):
        """Sparse (n, n) additions to M, C and K."""
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


PLANTS: dict[str, type[Plant]] = {}


def register_plant(cls: type[Plant]) -> type[Plant]:
    """Class decorator adding a plant to the registry under ``cls.kind``."""
    PLANTS[cls.kind] = cls
    return cls


def make_plant(kind: str, **options) -> Plant:
    """The plant registered as ``kind``, with mesh options (n_elements, n_groups, ...)."""
    if kind not in PLANTS:
        raise ModelError(f"unknown plant type {kind!r}; expected one of {sorted(PLANTS)}")
    return PLANTS[kind](**options)
