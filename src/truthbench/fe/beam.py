"""The 12-DOF 3D tube beam element (METHOD section 2, Eq. 10.1-10.4).

DOF order at each end: ``u1`` axial (local x), ``u2``, ``u3`` transverse (local y, z),
``u4`` torsion about x, ``u5``, ``u6`` rotations about y and z. The element vector is
``[u1..u6 at A, u1..u6 at B]``.

Bending uses cubic Hermite shape functions (Euler-Bernoulli), axial and torsion linear
shape functions, and the mass matrix is consistent. An optional Timoshenko form adds
shear deformation (shear coefficient of a thin-walled tube, 0.5) and the rotary inertia
of the cross-section; the truth simulator uses it as "correct element physics" against
an Euler-Bernoulli model.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Shear coefficient of a thin-walled circular tube (Cowper: 2(1+nu)/(4+3nu) ~ 0.53;
#: 0.5 is the classical thin-wall value).
THIN_TUBE_SHEAR_COEFFICIENT = 0.5


@dataclass(frozen=True)
class TubeSection:
    """Thin-walled circular tube section (Eq. 10.4).

    Parameters
    ----------
    r_m : float
        Mean radius of the wall, m.
    t_m : float
        Wall thickness, m.
    """

    r_m: float
    t_m: float

    @property
    def area_m2(self) -> float:
        """Cross-section area ``A = 2 pi r t``, m^2."""
        return 2.0 * np.pi * self.r_m * self.t_m

    @property
    def second_moment_m4(self) -> float:
        """Area moment of inertia about either bending axis ``I = pi r^3 t``, m^4."""
        return np.pi * self.r_m**3 * self.t_m

    @property
    def polar_moment_m4(self) -> float:
        """Polar (torsion) constant ``J = 2 pi r^3 t``, m^4."""
        return 2.0 * np.pi * self.r_m**3 * self.t_m

    @property
    def outer_radius_m(self) -> float:
        """Outer surface radius ``r + t/2``, m (where surface strain is read)."""
        return self.r_m + 0.5 * self.t_m


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
    r_m: float,
    t_m: float,
    L_m: float,
    *,
    timoshenko: bool = False,
) -> tuple[np.ndarray, np.ndarray]:
    """Local stiffness and consistent mass of one tube element.

    Parameters
    ----------
    E_pa : float
        Young's modulus, Pa.
    nu : float
        Poisson's ratio (G = E / (2 (1 + nu))).
    rho_kg_m3 : float
        Density, kg/m^3.
    r_m, t_m : float
        Mean radius and wall thickness of the tube, m.
    L_m : float
        Element length, m.
    timoshenko : bool, optional
        Add shear deformation and rotary inertia (default Euler-Bernoulli, the
        chapter's element).

    Returns
    -------
    k, m : ndarray, shape (12, 12)
        Stiffness (N/m, N, N m) and mass (kg, kg m, kg m^2) in local axes.
    """
    for name, value in (("E_pa", E_pa), ("rho_kg_m3", rho_kg_m3), ("r_m", r_m),
                        ("t_m", t_m), ("L_m", L_m)):
        if not np.isfinite(value) or value <= 0:
            raise ValueError(f"element parameter {name!r} must be a positive finite number; "
                             f"got {value!r}")
    if not -1.0 < nu < 0.5:
        raise ValueError(f"element parameter 'nu' must lie in (-1, 0.5); got {nu!r}")
    sec = TubeSection(r_m, t_m)
    A, I, J = sec.area_m2, sec.second_moment_m4, sec.polar_moment_m4
    G = shear_modulus(E_pa, nu)
    L = L_m
    k = np.zeros((12, 12))
    m = np.zeros((12, 12))

    # axial (0, 6) and torsion (3, 9): linear shape functions
    lin_k = np.array([[1.0, -1.0], [-1.0, 1.0]])
    lin_m = np.array([[2.0, 1.0], [1.0, 2.0]]) / 6.0
    for dofs, stiff, inertia in (((0, 6), E_pa * A / L, rho_kg_m3 * A * L),
                                 ((3, 9), G * J / L, rho_kg_m3 * J * L)):
        ix = np.ix_(dofs, dofs)
        k[ix] = stiff * lin_k
        m[ix] = inertia * lin_m

    phi = 0.0
    rhoI = 0.0
    if timoshenko:
        phi = 12.0 * E_pa * I / (THIN_TUBE_SHEAR_COEFFICIENT * G * A * L**2)
        rhoI = rho_kg_m3 * I
    kb, mb = _bending_blocks(E_pa * I, rho_kg_m3 * A, L, rhoI, phi)
    # x-y plane: v = u2, theta_z = u6 = +dv/dx
    ixy = np.ix_((1, 5, 7, 11), (1, 5, 7, 11))
    k[ixy] = kb
    m[ixy] = mb
    # x-z plane: w = u3, theta_y = u5 = -dw/dx, so flip the rotation signs
    flip = np.diag([1.0, -1.0, 1.0, -1.0])
    ixz = np.ix_((2, 4, 8, 10), (2, 4, 8, 10))
    k[ixz] = flip @ kb @ flip
    m[ixz] = flip @ mb @ flip
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
    """The per-node sag rotation of METHOD section 3 (Eq. 10.5-10.6).

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
