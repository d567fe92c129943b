"""Model/test compatibility: Guyan reduction and least-squares shape expansion.

The chapter's Section 10.2.2, issue 3 (:ref:`method-reduction`). Partition the model DOFs
into active ``A`` (measured, actuated) and dependent ``D`` ones, ``q_D = T_DA q_A``
(Eq. 10.22-10.24). Guyan (static) condensation (Eq. 10.25) takes
``T_DA = -K_DD^-1 K_DA``; the full transformation ``q = T q_A`` (``T`` has the identity on
the active rows) gives
``M_r = T^T M T`` and ``K_r = T^T K T`` (the latter equals the Schur complement
``K_AA - K_AD K_DD^-1 K_DA``).

Expansion (Eq. 10.26-10.27): ``Phi_meas = Phi_model,A C`` with
``C = pinv(Phi_model,A) Phi_meas``; the expanded shapes are ``Phi_model C`` (a smoothed
version of the measurement on the measured DOFs, model-consistent elsewhere).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from truthbench.identify._common import as_shape_matrix, readonly


@dataclass(frozen=True)
class GuyanReduction:
    """Result of :func:`guyan_reduction`.

    Attributes
    ----------
    mass : ndarray, shape (n_a, n_a)
        Reduced mass ``T^T M T``.
    stiffness : ndarray, shape (n_a, n_a)
        Reduced stiffness ``T^T K T``.
    transformation : ndarray, shape (n, n_a)
        ``T`` with ``q = T q_A`` (rows in the original DOF order).
    active : ndarray, int, shape (n_a,)
        Active DOF indices, in the order of the reduced coordinates.
    dependent : ndarray, int, shape (n - n_a,)
        Dependent DOF indices, ascending.
    """

    mass: np.ndarray
    stiffness: np.ndarray
    transformation: np.ndarray
    active: np.ndarray
    dependent: np.ndarray

    def __post_init__(self):
        for name in ("mass", "stiffness", "transformation", "active", "dependent"):
            object.__setattr__(self, name, readonly(getattr(self, name)))

    def expand(self, q_active) -> np.ndarray:
        """Full-DOF vectors ``T q_A`` from active-DOF vectors, shape (n, ...)."""
        return self.transformation @ np.asarray(q_active)


def _square(a, name: str) -> np.ndarray:
    x = np.array(a, dtype=float, copy=True)
    if x.ndim != 2 or x.shape[0] != x.shape[1]:
        raise ValueError(f"The '{name}' parameter must be a square matrix; got shape {x.shape}.")
    if not np.all(np.isfinite(x)):
        raise ValueError(f"The '{name}' parameter must be finite.")
    return x


def _indices(active, n: int) -> np.ndarray:
    a = np.asarray(active)
    if a.dtype == bool:
        if a.shape != (n,):
            raise ValueError(
                f"The 'active' parameter as a mask must have shape ({n},); got {a.shape}."
            )
        a = np.flatnonzero(a)
    a = np.atleast_1d(a)
    if a.ndim != 1 or a.size == 0 or a.dtype.kind not in "iu":
        raise ValueError(
            f"The 'active' parameter must be a non-empty sequence of DOF indices; got {active!r}."
        )
    if np.any(a < 0) or np.any(a >= n):
        raise ValueError(
            f"The 'active' parameter must index DOFs in [0, {n - 1}]; got {a.tolist()}."
        )
    if np.unique(a).size != a.size:
        raise ValueError(f"The 'active' parameter repeats a DOF: {a.tolist()}.")
    return a.astype(int)


def guyan_reduction(mass, stiffness, active) -> GuyanReduction:
    """Guyan (static) condensation onto the active DOFs (Eq. 10.22-10.25).

    Parameters
    ----------
    mass, stiffness : array_like, shape (n, n)
        Model mass (kg, kg m^2) and stiffness (N/m, N m/rad) matrices.
    active : sequence of int or bool mask of shape (n,)
        Active (kept) DOFs; the reduced coordinates follow this order.

    Returns
    -------
    GuyanReduction

    Raises
    ------
    ValueError
        Non-square or mismatched matrices, bad indices, or a singular ``K_DD`` (the
        dependent DOFs alone must be restrained).
    """
    M = _square(mass, "mass")
    K = _square(stiffness, "stiffness")
    if M.shape != K.shape:
        raise ValueError(
            f"The 'mass' and 'stiffness' parameters must have the same shape; got {M.shape} "
            f"and {K.shape}."
        )
    n = M.shape[0]
    a = _indices(active, n)
    d = np.setdiff1d(np.arange(n), a)
    T = np.zeros((n, a.size))
    T[a, np.arange(a.size)] = 1.0
    if d.size:
        K_dd = K[np.ix_(d, d)]
        K_da = K[np.ix_(d, a)]
        if np.linalg.matrix_rank(K_dd) < d.size:
            raise ValueError(
                "guyan_reduction: K_DD (the stiffness of the dependent DOFs "
                f"{d.tolist()}) is singular; expected the dependent DOFs to be restrained "
                "when the active DOFs are held."
            )
        T[d, :] = -np.linalg.solve(K_dd, K_da)
    return GuyanReduction(
        mass=T.T @ M @ T,
        stiffness=T.T @ K @ T,
        transformation=T,
        active=a,
        dependent=d,
    )


@dataclass(frozen=True)
class ShapeExpansion:
    """Result of :func:`expand_shapes`.

    Attributes
    ----------
    expanded : ndarray, shape (n, n_meas_modes)
        ``Phi_model C``, on all model DOFs.
    coefficients : ndarray, shape (n_model_modes, n_meas_modes)
        ``C = pinv(Phi_model,A) Phi_meas``.
    """

    expanded: np.ndarray
    coefficients: np.ndarray

    def __post_init__(self):
        for name in ("expanded", "coefficients"):
            object.__setattr__(self, name, readonly(getattr(self, name)))


def expand_shapes(phi_model, phi_measured, active, *, rcond: float = 1e-10) -> ShapeExpansion:
    """Least-squares expansion of measured shapes onto all model DOFs (Eq. 10.26-10.27).

    Parameters
    ----------
    phi_model : array_like, shape (n, n_model_modes)
        Model shapes on all DOFs (the basis).
    phi_measured : array_like, shape (n_a, n_meas_modes)
        Measured shapes, row ``k`` at model DOF ``active[k]``.
    active : sequence of int, length n_a
        Model DOF of each measured row.
    rcond : float
        Relative cut-off of :func:`numpy.linalg.pinv`.

    Returns
    -------
    ShapeExpansion
    """
    P = as_shape_matrix(phi_model, "phi_model")
    Y = as_shape_matrix(phi_measured, "phi_measured")
    a = _indices(active, P.shape[0])
    if Y.shape[0] != a.size:
        raise ValueError(
            f"The 'phi_measured' parameter has {Y.shape[0]} rows but 'active' names "
            f"{a.size} DOFs; expected one row per active DOF."
        )
    C = np.linalg.pinv(P[a], rcond=rcond) @ Y
    return ShapeExpansion(expanded=P @ C, coefficients=C)
