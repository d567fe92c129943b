"""The 12-DOF 3D beam element and its cross-sections (Section 10.1.1,
Eq. 10.1-10.4; :ref:`method-beam-element`).

DOF order at each end: ``u1`` axial (local x), ``u2``, ``u3`` transverse (local y, z),
``u4`` torsion about x, ``u5``, ``u6`` rotations about y and z. The element vector is
``[u1..u6 at A, u1..u6 at B]``.

Bending uses cubic Hermite shape functions (Euler-Bernoulli), axial and torsion linear
shape functions, and the mass matrix is consistent. An optional Timoshenko form adds
shear deformation (with the section's shear coefficient) and the rotary inertia of the
cross-section; the truth simulator uses it as "correct element physics" against an
Euler-Bernoulli model.

Cross-sections
--------------
A section is a small frozen object with the properties the element needs (the
:class:`Section` protocol); :data:`SECTIONS` registers them by name:

``"tube"`` (:class:`TubeSection`)
    thin-walled circular tube, mean radius ``r_m``, wall ``t_m`` (Eq. 10.4);
``"rectangular_bar"`` (:class:`RectangularBarSection`)
    solid rectangle, width ``b_m`` along local y, height ``h_m`` along local z;
``"circular_bar"`` (:class:`CircularBarSection`)
    solid circle, diameter ``d_m``.

``second_moment_y_m4`` (about local y) governs bending in the x-z plane (``u3``, ``u5``),
``second_moment_z_m4`` bending in the x-y plane (``u2``, ``u6``). The torsional stiffness
is ``G J`` with the Saint-Venant torsion constant ``J``; the torsional inertia is
``rho I_p`` with the polar moment of area ``I_p = I_y + I_z`` (equal to ``J`` only for
circular sections).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, fields
from typing import ClassVar, Protocol

import numpy as np

#: Shear coefficient of a thin-walled circular tube (Cowper: 2(1+nu)/(4+3nu) ~ 0.53;
#: 0.5 is the classical thin-wall value).
THIN_TUBE_SHEAR_COEFFICIENT = 0.5

#: sum over odd n of 1/n^5 = (1 - 2^-5) zeta(5), zeta(5) = 1.0369277551433699...
_ODD_ZETA5 = (31.0 / 32.0) * 1.0369277551433699263


class Section(Protocol):
    """What the element needs of a cross-section (all SI: m, m^2, m^4).

    Attributes
    ----------
    kind : str
        Registry name (:data:`SECTIONS`).
    dimensions : tuple of str
        Names of the dimension fields, with units (``"r_m"``, ``"b_m"``, ...); these are
        also the plant parameter names.
    area_m2 : float
        Cross-section area ``A``.
    second_moment_y_m4, second_moment_z_m4 : float
        Second moments of area about local y (bending in x-z) and local z (bending in
        x-y).
    torsion_constant_m4 : float
        Saint-Venant torsion constant ``J`` (torsional stiffness ``G J / L``).
    polar_moment_m4 : float
        Polar moment of area ``I_p = I_y + I_z`` (torsional inertia ``rho I_p``).
    """

    kind: ClassVar[str]
    dimensions: ClassVar[tuple[str, ...]]

    @property
    def area_m2(self) -> float: ...

    @property
    def second_moment_y_m4(self) -> float: ...

    @property
    def second_moment_z_m4(self) -> float: ...

    @property
    def torsion_constant_m4(self) -> float: ...

    @property
    def polar_moment_m4(self) -> float: ...

    def shear_coefficient(self, nu: float) -> float:
        """Timoshenko shear coefficient ``kappa`` (shear area ``kappa A``)."""

    def outer_fibre_m(self, direction: str) -> float:
        """Distance from the centroid to the outer surface on the +``direction`` side
        (``"y"`` or ``"z"``), m: where a bending strain gauge sits."""


_SECTION_MEMBERS = ("kind", "dimensions", "area_m2", "second_moment_y_m4",
                    "second_moment_z_m4", "torsion_constant_m4", "polar_moment_m4",
                    "shear_coefficient", "outer_fibre_m")


def is_section(obj) -> bool:
    """Whether ``obj`` has every member of the :class:`Section` protocol (looked up on its
    type, so no property is evaluated)."""
    return all(hasattr(type(obj), name) for name in _SECTION_MEMBERS)


def _check_dimensions(section) -> None:
    for f in fields(section):
        value = getattr(section, f.name)
        if isinstance(value, bool) or not isinstance(value, int | float | np.floating) \
                or not np.isfinite(value) or value <= 0:
            raise ValueError(f"{section.kind} section: '{f.name}' must be a positive finite "
                             f"number (m); got {value!r}")


def _check_direction(direction: str) -> None:
    if direction not in ("y", "z"):
        raise ValueError(f"outer fibre: direction must be 'y' or 'z' (a bending direction); "
                         f"got {direction!r}")


@dataclass(frozen=True)
class TubeSection:
    """Thin-walled circular tube section (Eq. 10.4).

    Parameters
    ----------
    r_m : float
        Mean radius of the wall, m.
    t_m : float
        Wall thickness, m.

    Notes
    -----
    ``A = 2 pi r t``, ``I_y = I_z = pi r^3 t``, ``J = I_p = 2 pi r^3 t`` (thin wall), shear
    coefficient 0.5 (:data:`THIN_TUBE_SHEAR_COEFFICIENT`), outer fibre ``r + t/2``.
    """

    r_m: float
    t_m: float

    kind: ClassVar[str] = "tube"
    dimensions: ClassVar[tuple[str, ...]] = ("r_m", "t_m")

    def __post_init__(self):
        _check_dimensions(self)

    @property
    def area_m2(self) -> float:
        """Cross-section area ``A = 2 pi r t``, m^2."""
        return 2.0 * np.pi * self.r_m * self.t_m

    @property
    def second_moment_m4(self) -> float:
        """Area moment of inertia about either bending axis ``I = pi r^3 t``, m^4."""
        return np.pi * self.r_m**3 * self.t_m

    second_moment_y_m4 = second_moment_m4
    second_moment_z_m4 = second_moment_m4

    @property
    def polar_moment_m4(self) -> float:
        """Polar moment ``I_p = 2 pi r^3 t`` (equal to the torsion constant), m^4."""
        return 2.0 * np.pi * self.r_m**3 * self.t_m

    torsion_constant_m4 = polar_moment_m4

    @property
    def outer_radius_m(self) -> float:
        """Outer surface radius ``r + t/2``, m (where surface strain is read)."""
        return self.r_m + 0.5 * self.t_m

    def shear_coefficient(self, nu: float) -> float:
        """0.5 for any ``nu`` (the thin-wall value)."""
        return THIN_TUBE_SHEAR_COEFFICIENT

    def outer_fibre_m(self, direction: str) -> float:
        """``r + t/2`` in both bending directions, m."""
        _check_direction(direction)
        return self.outer_radius_m


@dataclass(frozen=True)
class RectangularBarSection:
    """Solid rectangular bar.

    Parameters
    ----------
    b_m : float
        Width along local y, m.
    h_m : float
        Height along local z, m (along global z, vertical, for a beam along global x).

    Notes
    -----
    ``A = b h``; ``I_y = b h^3 / 12`` (bending in the x-z plane), ``I_z = h b^3 / 12``;
    ``I_p = I_y + I_z``. The torsion constant is the Saint-Venant series for a rectangle
    of long side ``a`` and short side ``c`` (Timoshenko and Goodier, *Theory of
    Elasticity*, 3rd ed., 1970, Sect. 109)::

        J = a c^3 / 3 * (1 - 192 c / (pi^5 a) * sum_{n odd} tanh(n pi a / (2 c)) / n^5)

    summed exactly: ``sum 1/n^5 = (31/32) zeta(5)`` less ``sum (1 - tanh) / n^5``, whose
    terms fall as ``exp(-n pi a / c)`` (13 terms reach double precision). Roark's
    approximation ``J = a c^3 (1/3 - 0.21 (c/a)(1 - c^4 / (12 a^4)))`` (Young and Budynas,
    *Roark's Formulas for Stress and Strain*, 7th ed., Table 10.7 case 4) agrees within
    0.5 % (largest near a/c = 1.14). Shear coefficient: Cowper (1966),
    ``10 (1 + nu) / (12 + 11 nu)``.
    """

    b_m: float
    h_m: float

    kind: ClassVar[str] = "rectangular_bar"
    dimensions: ClassVar[tuple[str, ...]] = ("b_m", "h_m")

    def __post_init__(self):
        _check_dimensions(self)

    @property
    def area_m2(self) -> float:
        """``A = b h``, m^2."""
        return self.b_m * self.h_m

    @property
    def second_moment_y_m4(self) -> float:
        """``I_y = b h^3 / 12`` (bending in the x-z plane), m^4."""
        return self.b_m * self.h_m**3 / 12.0

    @property
    def second_moment_z_m4(self) -> float:
        """``I_z = h b^3 / 12`` (bending in the x-y plane), m^4."""
        return self.h_m * self.b_m**3 / 12.0

    @property
    def polar_moment_m4(self) -> float:
        """``I_p = I_y + I_z``, m^4."""
        return self.second_moment_y_m4 + self.second_moment_z_m4

    @property
    def torsion_constant_m4(self) -> float:
        """Saint-Venant torsion constant (series, see class notes), m^4."""
        return rectangle_torsion_constant(self.b_m, self.h_m)

    def shear_coefficient(self, nu: float) -> float:
        """Cowper's ``10 (1 + nu) / (12 + 11 nu)``."""
        return 10.0 * (1.0 + nu) / (12.0 + 11.0 * nu)

    def outer_fibre_m(self, direction: str) -> float:
        """``b / 2`` along y, ``h / 2`` along z, m."""
        _check_direction(direction)
        return 0.5 * (self.b_m if direction == "y" else self.h_m)


@dataclass(frozen=True)
class CircularBarSection:
    """Solid circular bar of diameter ``d_m``.

    Notes
    -----
    ``A = pi d^2 / 4``, ``I_y = I_z = pi d^4 / 64``, ``J = I_p = pi d^4 / 32``; shear
    coefficient: Cowper (1966), ``6 (1 + nu) / (7 + 6 nu)``; outer fibre ``d / 2``.
    """

    d_m: float

    kind: ClassVar[str] = "circular_bar"
    dimensions: ClassVar[tuple[str, ...]] = ("d_m",)

    def __post_init__(self):
        _check_dimensions(self)

    @property
    def area_m2(self) -> float:
        """``A = pi d^2 / 4``, m^2."""
        return np.pi * self.d_m**2 / 4.0

    @property
    def second_moment_y_m4(self) -> float:
        """``I = pi d^4 / 64``, m^4."""
        return np.pi * self.d_m**4 / 64.0

    second_moment_z_m4 = second_moment_y_m4

    @property
    def polar_moment_m4(self) -> float:
        """``I_p = J = pi d^4 / 32``, m^4."""
        return np.pi * self.d_m**4 / 32.0

    torsion_constant_m4 = polar_moment_m4

    def shear_coefficient(self, nu: float) -> float:
        """Cowper's ``6 (1 + nu) / (7 + 6 nu)``."""
        return 6.0 * (1.0 + nu) / (7.0 + 6.0 * nu)

    def outer_fibre_m(self, direction: str) -> float:
        """``d / 2``, m."""
        _check_direction(direction)
        return 0.5 * self.d_m


#: The cross-sections by name (the campaign's ``[plant] section``).
SECTIONS: dict[str, type] = {cls.kind: cls for cls in (TubeSection, RectangularBarSection,
                                                       CircularBarSection)}


def rectangle_torsion_constant(b_m: float, h_m: float) -> float:
    """Saint-Venant torsion constant of a solid ``b x h`` rectangle, m^4.

    The series of :class:`RectangularBarSection` (Timoshenko and Goodier, Sect. 109),
    exact to rounding; symmetric in ``b`` and ``h``.
    """
    a, c = max(b_m, h_m), min(b_m, h_m)
    n = np.arange(1.0, 40.0, 2.0)
    x = n * np.pi * a / (2.0 * c)
    # 1 - tanh(x) = 2 / (exp(2x) + 1), without cancellation; exp overflow -> 0 is exact
    with np.errstate(over="ignore"):
        defect = np.sum(2.0 / (np.exp(2.0 * x) + 1.0) / n**5)
    series = _ODD_ZETA5 - defect
    return a * c**3 / 3.0 * (1.0 - 192.0 * c / (np.pi**5 * a) * series)


def make_section(kind: str, dimensions: Mapping[str, float]) -> Section:
    """The section ``kind`` (:data:`SECTIONS`) from a mapping holding its dimensions.

    Extra keys in ``dimensions`` (material values, say) are ignored.

    Raises
    ------
    ValueError
        Unknown ``kind``, a missing dimension, or a non-positive one.
    """
    if kind not in SECTIONS:
        raise ValueError(f"'section' must be one of {', '.join(map(repr, SECTIONS))}; "
                         f"got {kind!r}")
    cls = SECTIONS[kind]
    missing = [d for d in cls.dimensions if d not in dimensions]
    if missing:
        raise ValueError(f"{kind} section needs {', '.join(cls.dimensions)}; missing "
                         f"{', '.join(missing)}")
    return cls(**{d: float(dimensions[d]) for d in cls.dimensions})


def shear_modulus(E_pa: float, nu: float) -> float:
    """Isotropic shear modulus ``G = E / (2 (1 + nu))``, Pa."""
    return E_pa / (2.0 * (1.0 + nu))


def _bending_blocks(EI: float, rhoA: float, L: float, rhoI: float, phi: float):
    """Stiffness and mass (4x4) for bending in one plane, DOFs ``[w_A, th_A, w_B, th_B]``.

    The sign convention is that of the x-y plane (rotation = +dw/dx). ``phi`` is the
    Timoshenko shear parameter ``12 EI / (kappa G A L^2)`` (0 for Euler-Bernoulli) and
    ``rhoI`` the rotary inertia per length (0 to omit). Formulas: Przemieniecki,
    Theory of Matrix Structural Analysis, Sect. 5.6 and 11.6.
    """
    c = EI / (L**3 * (1.0 + phi))
    k = c * np.array(
        [
            [12.0, 6 * L, -12.0, 6 * L],
            [6 * L, (4 + phi) * L**2, -6 * L, (2 - phi) * L**2],
            [-12.0, -6 * L, 12.0, -6 * L],
            [6 * L, (2 - phi) * L**2, -6 * L, (4 + phi) * L**2],
        ]
    )
    p = phi
    d = (1.0 + p) ** 2
    # translational inertia
    m1 = 13 / 35 + 7 * p / 10 + p**2 / 3
    m2 = 9 / 70 + 3 * p / 10 + p**2 / 6
    m3 = (11 / 210 + 11 * p / 120 + p**2 / 24) * L
    m4 = (13 / 420 + 3 * p / 40 + p**2 / 24) * L
    m5 = (1 / 105 + p / 60 + p**2 / 120) * L**2
    m6 = (1 / 140 + p / 60 + p**2 / 120) * L**2
    mt = (rhoA * L / d) * np.array(
        [
            [m1, m3, m2, -m4],
            [m3, m5, m4, -m6],
            [m2, m4, m1, -m3],
            [-m4, -m6, -m3, m5],
        ]
    )
    if rhoI == 0.0:
        return k, mt
    r1 = 6 / 5
    r2 = (1 / 10 - p / 2) * L
    r3 = (2 / 15 + p / 6 + p**2 / 3) * L**2
    r4 = (-1 / 30 - p / 6 + p**2 / 6) * L**2
    mr = (rhoI / (L * d)) * np.array(
        [
            [r1, r2, -r1, r2],
            [r2, r3, -r2, r4],
            [-r1, -r2, r1, -r2],
            [r2, r4, -r2, r3],
        ]
    )
    return k, mt + mr


def element_matrices(
    E_pa: float,
    nu: float,
    rho_kg_m3: float,
    section: Section,
    L_m: float,
    *,
    timoshenko: bool | float = False,
) -> tuple[np.ndarray, np.ndarray]:
    """Local stiffness and consistent mass of one beam element.

    Parameters
    ----------
    E_pa : float
        Young's modulus, Pa.
    nu : float
        Poisson's ratio (G = E / (2 (1 + nu))).
    rho_kg_m3 : float
        Density, kg/m^3.
    section : Section
        The cross-section (:class:`TubeSection`, :class:`RectangularBarSection`,
        :class:`CircularBarSection`, or any object with the :class:`Section` properties).
    L_m : float
        Element length, m.
    timoshenko : bool or float, optional
        Add shear deformation (shear coefficient ``section.shear_coefficient(nu)``) and
        rotary inertia (default Euler-Bernoulli, the chapter's element). A number scales
        both (the shear parameter ``phi`` and the rotary inertia per length): 1 (True)
        is the Timoshenko beam, 0 (False) Euler-Bernoulli, values between a partial
        correction (what a diagnosis fits when it is unsure of the slenderness).

    Returns
    -------
    k, m : ndarray, shape (12, 12)
        Stiffness (N/m, N, N m) and mass (kg, kg m, kg m^2) in local axes. Bending in the
        x-y plane (u2, u6) uses ``I_z``, in the x-z plane (u3, u5) ``I_y``; torsion
        stiffness ``G J / L``, torsional inertia ``rho I_p L``.
    """
    for name, value in (("E_pa", E_pa), ("rho_kg_m3", rho_kg_m3), ("L_m", L_m)):
        if not np.isfinite(value) or value <= 0:
            raise ValueError(f"element parameter {name!r} must be a positive finite number; "
                             f"got {value!r}")
    if not -1.0 < nu < 0.5:
        raise ValueError(f"element parameter 'nu' must lie in (-1, 0.5); got {nu!r}")
    if not is_section(section):
        raise ValueError(f"element parameter 'section' must be a cross-section (e.g. "
                         f"TubeSection); got {type(section).__name__}")
    A = section.area_m2
    Iy, Iz = section.second_moment_y_m4, section.second_moment_z_m4
    J, Ip = section.torsion_constant_m4, section.polar_moment_m4
    G = shear_modulus(E_pa, nu)
    L = L_m
    k = np.zeros((12, 12))
    m = np.zeros((12, 12))

    # axial (0, 6) and torsion (3, 9): linear shape functions
    lin_k = np.array([[1.0, -1.0], [-1.0, 1.0]])
    lin_m = np.array([[2.0, 1.0], [1.0, 2.0]]) / 6.0
    for dofs, stiff, inertia in (((0, 6), E_pa * A / L, rho_kg_m3 * A * L),
                                 ((3, 9), G * J / L, rho_kg_m3 * Ip * L)):
        ix = np.ix_(dofs, dofs)
        k[ix] = stiff * lin_k
        m[ix] = inertia * lin_m

    scale = float(timoshenko)
    if not (np.isfinite(scale) and scale >= 0):
        raise ValueError(f"element parameter 'timoshenko' must be a boolean or a scale "
                         f">= 0; got {timoshenko!r}")
    kappa = section.shear_coefficient(nu) if scale else 0.0

    def plane(I):
        phi = 0.0
        rhoI = 0.0
        if scale:
            phi = scale * (12.0 * E_pa * I / (kappa * G * A * L**2))
            rhoI = scale * (rho_kg_m3 * I)
        return _bending_blocks(E_pa * I, rho_kg_m3 * A, L, rhoI, phi)

    kb_z, mb_z = plane(Iz)
    kb_y, mb_y = (kb_z, mb_z) if Iy == Iz else plane(Iy)
    # x-y plane: v = u2, theta_z = u6 = +dv/dx
    ixy = np.ix_((1, 5, 7, 11), (1, 5, 7, 11))
    k[ixy] = kb_z
    m[ixy] = mb_z
    # x-z plane: w = u3, theta_y = u5 = -dw/dx, so flip the rotation signs
    flip = np.diag([1.0, -1.0, 1.0, -1.0])
    ixz = np.ix_((2, 4, 8, 10), (2, 4, 8, 10))
    k[ixz] = flip @ kb_y @ flip
    m[ixz] = flip @ mb_y @ flip
    return k, m


def rotation_matrix(axis_vector: np.ndarray, up_vector: np.ndarray | None = None) -> np.ndarray:
    """Direction-cosine matrix from global to element axes.

    Parameters
    ----------
    axis_vector : array_like, shape (3,)
        Vector from node A to node B (any length).
    up_vector : array_like, shape (3,), optional
        A vector in the element's local x-z plane, used to fix local z. Default global
        z, or global y when the element is (nearly) vertical.

    Returns
    -------
    R : ndarray, shape (3, 3)
        Rows are the local x, y, z unit vectors in global components.
    """
    return rotation_matrices(np.asarray(axis_vector, dtype=float)[None, :], up_vector)[0]


def rotation_matrices(axis_vectors: np.ndarray, up_vector: np.ndarray | None = None
                      ) -> np.ndarray:
    """:func:`rotation_matrix` of many elements at once.

    Parameters
    ----------
    axis_vectors : array_like, shape (n, 3)
    up_vector : array_like, shape (3,), optional

    Returns
    -------
    R : ndarray, shape (n, 3, 3)
    """
    ex = np.asarray(axis_vectors, dtype=float)
    n = np.linalg.norm(ex, axis=1)
    if not np.all(n > 0):
        raise ValueError("element axis has zero length (nodes A and B coincide)")
    ex = ex / n[:, None]
    if up_vector is None:
        up = np.tile([0.0, 0.0, 1.0], (len(ex), 1))
        up[np.abs(ex[:, 2]) > 0.999] = [0.0, 1.0, 0.0]
    else:
        up = np.broadcast_to(np.asarray(up_vector, dtype=float), ex.shape)
    ey = np.cross(up, ex)
    ny = np.linalg.norm(ey, axis=1)
    if np.any(ny < 1e-9):
        raise ValueError("up_vector is parallel to the element axis; choose another")
    ey /= ny[:, None]
    ez = np.cross(ex, ey)
    return np.stack([ex, ey, ez], axis=1)


def transformation_matrix(R: np.ndarray) -> np.ndarray:
    """12x12 block-diagonal transformation ``T`` with ``u_local = T u_global``."""
    return np.kron(np.eye(4), R)


def sag_rotation(theta_rad: float) -> np.ndarray:
    """The per-node sag rotation of Eq. 10.5-10.6 (:ref:`method-sag`).

    ``T = [[c, 0, -s], [0, 1, 0], [s, 0, c]]`` with ``c = cos(theta)``, ``s = sin(theta)``;
    applied to translations and rotations of both nodes it tilts the element by the sag
    angle theta in its vertical (x-z) plane: ``k_def = T^T k T``.
    """
    return sag_rotations(np.array([theta_rad], dtype=float))[0]


def sag_rotations(theta_rad: np.ndarray) -> np.ndarray:
    """:func:`sag_rotation` of many angles, shape (n,) -> (n, 3, 3)."""
    c, s = np.cos(theta_rad), np.sin(theta_rad)
    out = np.zeros((len(c), 3, 3))
    out[:, 0, 0], out[:, 0, 2], out[:, 1, 1], out[:, 2, 0], out[:, 2, 2] = c, -s, 1.0, s, c
    return out
