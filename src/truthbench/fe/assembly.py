"""Assembly of meshed beam members into global M, C, K.

A :class:`BeamMesh` holds node coordinates, two-node elements and the element group of
each element; :func:`assemble` turns it, with per-group material and section values
(any cross-section of :data:`~truthbench.fe.beam.SECTIONS`), into sparse global
stiffness and mass matrices (6 DOFs per node, global axes).
:func:`finish_structure` adds lumped masses and rotary inertias, grounded springs and
dashpots at any DOF, and removes clamped DOFs.

Global DOF ``6 * node + d`` with ``d`` in ``0..5`` = x, y, z, rx, ry, rz.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from truthbench.fe.beam import (
    SECTIONS,
    element_matrices,
    is_section,
    make_section,
    rotation_matrices,
    sag_rotations,
)

DIRECTIONS = ("x", "y", "z", "rx", "ry", "rz")
"""Names of the six nodal DOFs, in order."""

MATERIAL_KEYS = ("E_pa", "nu", "rho_kg_m3")
"""The per-group material properties :func:`assemble` needs (besides the section)."""

DEFAULT_SECTION = "tube"
"""The section of a group whose properties name none (the chapter's tube, Eq. 10.4)."""


def group_section(props: Mapping[str, object], group: str = "?"):
    """The cross-section of one group's properties.

    ``props["section"]`` is a section object (:func:`~truthbench.fe.beam.is_section`) or
    a section name of :data:`~truthbench.fe.beam.SECTIONS` whose dimensions are further
    keys of ``props`` (``{"section": "rectangular_bar", "b_m": 0.03, "h_m": 0.01}``);
    without a ``"section"`` key the group is a tube with ``r_m`` and ``t_m``.

    Raises
    ------
    ValueError
        Naming the group: unknown section, missing or bad dimension.
    """
    sec = props.get("section", DEFAULT_SECTION)
    if is_section(sec):
        return sec
    try:
        return make_section(sec, props)
    except ValueError as exc:
        raise ValueError(f"element group {group!r}: {exc}") from None


def direction_index(direction: str) -> int:
    """Index 0..5 of a DOF direction name (x, y, z, rx, ry, rz)."""
    try:
        return DIRECTIONS.index(direction)
    except ValueError:
        raise ValueError(
            f"unknown DOF direction {direction!r}; expected one of {', '.join(DIRECTIONS)}"
        ) from None


@dataclass(frozen=True)
class BeamMesh:
    """Nodes and two-node elements of a frame of beam members.

    Parameters
    ----------
    nodes_m : ndarray, shape (n_nodes, 3)
        Node coordinates, m.
    elements : ndarray of int, shape (n_elements, 2)
        Node indices (A, B) of each element.
    groups : tuple of str, length n_elements
        Element group of each element (material and section values are per group).
    """

    nodes_m: np.ndarray
    elements: np.ndarray
    groups: tuple[str, ...]

    def __post_init__(self):
        nodes = np.asarray(self.nodes_m, dtype=float)
        elements = np.asarray(self.elements, dtype=int)
        if nodes.ndim != 2 or nodes.shape[1] != 3:
            raise ValueError(f"nodes_m must have shape (n_nodes, 3); got {nodes.shape}")
        if elements.ndim != 2 or elements.shape[1] != 2:
            raise ValueError(f"elements must have shape (n_elements, 2); got {elements.shape}")
        if len(self.groups) != len(elements):
            raise ValueError(f"groups has {len(self.groups)} entries; expected one per "
                             f"element ({len(elements)})")
        if elements.size and (elements.min() < 0 or elements.max() >= len(nodes)):
            raise ValueError("elements refer to nodes that do not exist")
        nodes.setflags(write=False)
        elements.setflags(write=False)
        object.__setattr__(self, "nodes_m", nodes)
        object.__setattr__(self, "elements", elements)
        object.__setattr__(self, "groups", tuple(self.groups))

    @property
    def n_nodes(self) -> int:
        return len(self.nodes_m)

    @property
    def n_dofs(self) -> int:
        return 6 * self.n_nodes

    @property
    def element_lengths_m(self) -> np.ndarray:
        """Length of every element, m, shape (n_elements,)."""
        a, b = self.nodes_m[self.elements[:, 0]], self.nodes_m[self.elements[:, 1]]
        return np.linalg.norm(b - a, axis=1)

    def group_names(self) -> tuple[str, ...]:
        """Distinct group names in order of first appearance."""
        return tuple(dict.fromkeys(self.groups))

    def dof_labels(self) -> tuple[str, ...]:
        """Label ``"n<node>.<direction>"`` of every global DOF."""
        return tuple(f"n{n}.{d}" for n in range(self.n_nodes) for d in DIRECTIONS)


def straight_member(
    start_m: Iterable[float],
    end_m: Iterable[float],
    n_elements: int,
    groups: Iterable[str] | str = "beam",
) -> BeamMesh:
    """Mesh a straight member into equal elements.

    Parameters
    ----------
    start_m, end_m : array_like, shape (3,)
        End points, m.
    n_elements : int
        Number of equal elements (>= 1).
    groups : str or sequence of str
        One group name for all elements, or a name per element.
    """
    if int(n_elements) != n_elements or n_elements < 1:
        raise ValueError(f"n_elements must be a positive integer; got {n_elements!r}")
    n_elements = int(n_elements)
    a, b = np.asarray(start_m, float), np.asarray(end_m, float)
    s = np.linspace(0.0, 1.0, n_elements + 1)[:, None]
    nodes = a + s * (b - a)
    elements = np.column_stack([np.arange(n_elements), np.arange(1, n_elements + 1)])
    if isinstance(groups, str):
        groups = (groups,) * n_elements
    return BeamMesh(nodes, elements, tuple(groups))


def assemble(
    mesh: BeamMesh,
    properties: Mapping[str, Mapping[str, float]],
    *,
    timoshenko: bool | float = False,
    sag_angles_rad: np.ndarray | None = None,
    up_vector: np.ndarray | None = None,
) -> tuple[sp.csr_matrix, sp.csr_matrix]:
    """Assemble global stiffness and mass matrices.

    Parameters
    ----------
    mesh : BeamMesh
    properties : mapping of group name -> mapping
        For every group, the keys of :data:`MATERIAL_KEYS` (E_pa, nu, rho_kg_m3) and the
        section: ``"section"`` (a section object or name) with the section's dimensions,
        or, for a tube, just ``r_m`` and ``t_m`` (see :func:`group_section`).
    timoshenko : bool or float
        Use the shear-deformable element with rotary inertia (a number scales both, see
        :func:`~truthbench.fe.beam.element_matrices`).
    sag_angles_rad : ndarray, shape (n_elements,), optional
        Local sag angle of each element; the element matrices are rotated by
        :func:`~truthbench.fe.beam.sag_rotation` (Eq. 10.5-10.6) in their x-z plane.
    up_vector : array_like, shape (3,), optional
        Passed to :func:`~truthbench.fe.beam.rotation_matrix`.

    Returns
    -------
    K, M : scipy.sparse.csr_matrix, shape (n_dofs, n_dofs)
    """
    missing = [g for g in mesh.group_names() if g not in properties]
    if missing:
        raise ValueError(f"no properties for element group(s) {missing}; "
                         f"got groups {sorted(properties)}")
    n_el = len(mesh.elements)
    if sag_angles_rad is not None:
        sag_angles_rad = np.asarray(sag_angles_rad, float)
        if sag_angles_rad.shape != (n_el,):
            raise ValueError(f"sag_angles_rad must have shape ({n_el},); "
                             f"got {sag_angles_rad.shape}")
    lengths = mesh.element_lengths_m
    k_loc = np.empty((n_el, 12, 12))
    m_loc = np.empty((n_el, 12, 12))
    group_keys = {}
    for g in mesh.group_names():
        props = properties[g]
        try:
            material = tuple(float(props[k]) for k in MATERIAL_KEYS)
        except KeyError as exc:
            raise ValueError(f"element group {g!r} lacks property {exc.args[0]!r}; "
                             f"expected keys {MATERIAL_KEYS} and a section (one of "
                             f"{', '.join(SECTIONS)})") from None
        group_keys[g] = material + (group_section(props, g),)
    cache: dict = {}
    for e in range(n_el):
        key = group_keys[mesh.groups[e]] + (round(lengths[e], 12),)
        if key not in cache:
            E, nu, rho, section, _ = key
            cache[key] = element_matrices(E, nu, rho, section, lengths[e],
                                          timoshenko=timoshenko)
        k_loc[e], m_loc[e] = cache[key]
    na, nb = mesh.elements[:, 0], mesh.elements[:, 1]
    R = rotation_matrices(mesh.nodes_m[nb] - mesh.nodes_m[na], up_vector)  # (n_el, 3, 3)
    if sag_angles_rad is not None:
        R = np.einsum("eij,ejk->eik", sag_rotations(sag_angles_rad), R)
    # T = blockdiag(R, R, R, R): k_g = T^T k T, done block by block
    kg = _rotate(k_loc, R)
    mg = _rotate(m_loc, R)
    dofs = np.concatenate([6 * na[:, None] + np.arange(6), 6 * nb[:, None] + np.arange(6)],
                          axis=1)  # (n_el, 12)
    rows = [np.repeat(dofs, 12, axis=1).ravel()]
    cols = [np.tile(dofs, (1, 12)).ravel()]
    kv, mv = [kg.ravel()], [mg.ravel()]
    n = mesh.n_dofs
    r_all, c_all = np.concatenate(rows), np.concatenate(cols)
    K = sp.csr_matrix((np.concatenate(kv), (r_all, c_all)), shape=(n, n))
    M = sp.csr_matrix((np.concatenate(mv), (r_all, c_all)), shape=(n, n))
    # exact symmetry (rounding in T^T k T can leave 1e-16 asymmetry)
    return ((K + K.T) * 0.5).tocsr(), ((M + M.T) * 0.5).tocsr()


def _rotate(a: np.ndarray, R: np.ndarray) -> np.ndarray:
    """``T^T a T`` for every element, ``T = blockdiag(R, R, R, R)``.

    a : (n_el, 12, 12), R : (n_el, 3, 3) -> (n_el, 12, 12)."""
    n = a.shape[0]
    blocks = a.reshape(n, 4, 3, 4, 3)
    out = np.einsum("eki,eakbl,elj->eaibj", R, blocks, R, optimize=True)
    return out.reshape(n, 12, 12)


@dataclass(frozen=True)
class Lumped:
    """Lumped additions at global DOFs.

    Each entry is ``(global_dof, value)``; masses and inertias add to M, springs to K,
    dashpots to C (grounded). A point mass of m kg at node n is three entries
    ``(6n, m), (6n+1, m), (6n+2, m)``; see :func:`point_mass`.
    """

    masses: tuple[tuple[int, float], ...] = field(default_factory=tuple)
    springs: tuple[tuple[int, float], ...] = field(default_factory=tuple)
    dashpots: tuple[tuple[int, float], ...] = field(default_factory=tuple)


def point_mass(node: int, mass_kg: float) -> tuple[tuple[int, float], ...]:
    """Mass entries of a point mass at a node (its three translations)."""
    return tuple((6 * node + d, float(mass_kg)) for d in range(3))


def finish_structure(
    K: sp.spmatrix,
    M: sp.spmatrix,
    n_dofs: int,
    lumped: Lumped = Lumped(),
    clamped: Iterable[int] = (),
    C: sp.spmatrix | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Add lumped elements and remove clamped DOFs.

    Parameters
    ----------
    K, M : sparse matrix, shape (n_dofs, n_dofs)
    n_dofs : int
    lumped : Lumped
        Point masses, rotary inertias, grounded springs and dashpots.
    clamped : iterable of int
        Global DOFs fixed to ground; they are removed (not penalised).
    C : sparse matrix, shape (n_dofs, n_dofs), optional
        A global damping matrix to start from (e.g. joint dashpots between DOFs).

    Returns
    -------
    M, C, K : scipy.sparse.csr_matrix, shape (n_free, n_free)
    free : ndarray of int, shape (n_free,)
        Global index of every kept DOF.
    """
    clamped = np.unique(np.asarray(list(clamped), dtype=int))
    if clamped.size and (clamped.min() < 0 or clamped.max() >= n_dofs):
        raise ValueError(f"clamped DOFs must lie in 0..{n_dofs - 1}; got {clamped.tolist()}")

    def add_diag(A, entries):
        d = np.zeros(n_dofs)
        for dof, value in entries:
            if not 0 <= dof < n_dofs:
                raise ValueError(f"lumped entry at DOF {dof} outside 0..{n_dofs - 1}")
            if value < 0:
                raise ValueError(f"lumped value at DOF {dof} must be >= 0; got {value}")
            d[dof] += value
        if A is None:
            return sp.diags(d).tocsr()
        return (A + sp.diags(d)).tocsr() if d.any() else sp.csr_matrix(A)

    M = add_diag(M, lumped.masses)
    K = add_diag(K, lumped.springs)
    C = add_diag(C, lumped.dashpots)
    free = np.setdiff1d(np.arange(n_dofs), clamped)
    if free.size == n_dofs:  # nothing clamped (a free-free beam)
        return M, C, K, free
    return (M[free][:, free].tocsr(), C[free][:, free].tocsr(), K[free][:, free].tocsr(),
            free)
