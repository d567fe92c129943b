"""First-order sensitivities of a model's real modes to its macroelements: eigenvalues
and mass-normalised eigenvectors (Fox and Kapoor in modal form, degenerate pairs left out
of the modal sum; :func:`eigen_sensitivities`) and, for light damping, the modal damping
ratios (:func:`damping_sensitivities`); the formulas and the treatment of rigid-body and
repeated eigenvalues are set out in :mod:`truthbench.update.sensitivity`, whose update
iterates on them.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence

import numpy as np
import scipy.sparse as sp

from truthbench.model import Modes
from truthbench.update.macroelements import Macroelement

__all__ = ["damping_sensitivities", "eigen_sensitivities"]

_EPS = np.finfo(float).eps


def _projections(Phi: np.ndarray, macroelements: Sequence[Macroelement]):
    """``G_j = Phi^T K_j Phi`` and ``H_j = Phi^T M_j Phi``, each shape (p, m, m)."""
    G = np.stack([Phi.T @ np.asarray(me.dK @ Phi) for me in macroelements])
    H = np.stack([Phi.T @ np.asarray(me.dM @ Phi) for me in macroelements])
    return G, H


def _degenerate(lam: np.ndarray, rigid: np.ndarray, rtol: float) -> np.ndarray:
    """Boolean (m, m): pairs left out of the modal sum (and the diagonal)."""
    a = np.abs(lam)
    floor = 64 * _EPS * (a.max() if a.size else 0.0)
    gap = np.abs(lam[None, :] - lam[:, None])
    out = gap <= rtol * np.maximum(a[None, :], a[:, None]) + floor
    out |= rigid[None, :] & rigid[:, None]
    np.fill_diagonal(out, True)
    return out


def _coefficients(lam, rigid, G, H, rtol, names, warn):
    """``dlam`` (m, p) and the modal coefficients ``C`` (p, m, m) with
    ``dphi[:, i, j] = Phi @ C[j, :, i]``."""
    m = lam.size
    A = G - lam[None, None, :] * H  # A[j, k, i] = phi_k^T (K_j - lam_i M_j) phi_i
    diag = np.arange(m)
    dlam = A[:, diag, diag].T.copy()
    excl = _degenerate(lam, rigid, rtol)
    with np.errstate(divide="ignore"):
        inv = np.where(excl, 0.0, 1.0 / np.where(excl, 1.0, lam[None, :] - lam[:, None]))
    C = A * inv[None]
    C[:, diag, diag] = -0.5 * H[:, diag, diag]
    if warn:
        cluster = excl & ~np.eye(m, dtype=bool)
        cluster &= ~(rigid[None, :] & rigid[:, None])
        if cluster.any():
            k, i = np.nonzero(np.triu(cluster))
            scale = np.abs(A[:, diag, diag]).max(axis=1, initial=0.0)  # per parameter
            split = np.abs(A[:, k, i]) > 1e-6 * np.maximum(scale[:, None], 1e-300)
            if split.any():
                who = sorted({names[j] for j in np.nonzero(split.any(axis=1))[0]})
                warnings.warn(
                    f"parameters {who} couple the degenerate model modes "
                    f"{sorted(set(zip(k.tolist(), i.tolist(), strict=True)))} (equal "
                    f"eigenvalues): their sensitivities depend on the eigensolver's basis "
                    f"of that pair. Break the symmetry (e.g. a planar model) or do not use "
                    f"these modes.", stacklevel=3)
    return dlam, C


def eigen_sensitivities(
    modes: Modes,
    macroelements: Sequence[Macroelement],
    *,
    degenerate_rtol: float = 1e-6,
) -> tuple[np.ndarray, np.ndarray]:
    """First-order eigenvalue and eigenvector sensitivities to the macroelements.

    Parameters
    ----------
    modes : Modes
        Mass-normalised modes of ``(M, K)`` at the linearisation point
        (:func:`truthbench.model.solve_modes`), shape (n, m); all of them if possible.
    macroelements : sequence of Macroelement
        ``p`` macroelements on the same ``n`` DOFs.
    degenerate_rtol : float
        Relative eigenvalue gap below which two modes count as degenerate (see
        :mod:`truthbench.update.sensitivity`).

    Returns
    -------
    dlam : ndarray, shape (m, p)
        ``d lambda_i / d alpha_j``, rad^2/s^2 per unit relative change.
    dphi : ndarray, shape (n, m, p)
        ``d phi_i / d alpha_j`` (mass-normalised shapes, units of the shapes) per unit
        relative change.
    """
    Phi = np.asarray(modes.shapes, dtype=float)
    lam = np.asarray(modes.omega_rad_s, dtype=float) ** 2
    if not macroelements:
        raise ValueError("eigen_sensitivities needs at least one macroelement; got none")
    n = Phi.shape[0]
    bad = [me.name for me in macroelements if me.dK.shape != (n, n) or me.dM.shape != (n, n)]
    if bad:
        raise ValueError(f"macroelements {bad} do not have the modes' {n} DOFs")
    G, H = _projections(Phi, macroelements)
    dlam, C = _coefficients(lam, np.asarray(modes.rigid, dtype=bool), G, H, degenerate_rtol,
                            [me.name for me in macroelements], warn=True)
    dphi = np.einsum("nk,jki->nij", Phi, C, optimize=True)
    return dlam, dphi


def _broadcast_zeta(value, m: int, what: str) -> np.ndarray:
    z = np.asarray(value, dtype=float)
    if z.ndim == 1 and z.size != m:
        raise ValueError(f"{what} has {z.size} per-mode values; expected a scalar or {m} "
                         f"(one per model mode in use, see 'n_model_modes')")
    return np.broadcast_to(z, (m,))


def _zeta_jacobian(Phi, omega, rigid, C, macros, dlam, coef) -> np.ndarray:
    """First-order ``d zeta_i / d alpha_j``, shape (m, p); NaN rows for rigid modes.
    ``coef`` as returned by :func:`_coefficients` (``dphi_i,j = Phi coef[j, :, i]``)."""
    m = omega.size
    Cm = Phi.T @ np.asarray(C @ Phi) if C.nnz else np.zeros((m, m))
    Dc = np.stack([np.einsum("ni,ni->i", Phi, np.asarray(me.dC @ Phi)) if me.dC.nnz
                   else np.zeros(m) for me in macros], axis=1)
    Dz = np.stack([_broadcast_zeta(me.dzeta_modal, m, f"dzeta_modal of {me.name!r}")
                   for me in macros], axis=1)
    cross = 2.0 * np.einsum("ik,jki->ij", Cm, coef, optimize=True)
    with np.errstate(divide="ignore", invalid="ignore"):
        w = np.where(rigid | (omega <= 0), np.nan, omega)[:, None]
        return (Dc + cross) / (2 * w) - np.diag(Cm)[:, None] * dlam / (4 * w**3) + Dz


def damping_sensitivities(
    modes: Modes,
    macroelements: Sequence[Macroelement],
    C=None,
    modal_damping_ratio: float | np.ndarray = 0.0,
    *,
    degenerate_rtol: float = 1e-6,
) -> np.ndarray:
    """First-order (light-damping) sensitivities of the modal damping ratios.

    With ``zeta_i ~ zeta_m + phi_i^T C phi_i / (2 omega_i)`` (mass-normalised real modes,
    the diagonal of the modal damping matrix of :class:`~truthbench.model.StructuralModel`)::

        dzeta_i/dalpha_j = phi_i^T C_j phi_i / (2 omega_i) + zeta_m,j
                           + phi_i^T C dphi_i/dalpha_j / omega_i
                           - phi_i^T C phi_i dlambda_i/dalpha_j / (4 omega_i^3)

    For a pure damping parameter (``M_j = K_j = 0``) only the first term (dashpot) or
    the second (modal damping ratio, ``zeta_m,j = zeta_m``) remains. The error against the
    exact (complex-pole) damping ratio grows with the damping coupling between modes,
    ``|phi_k^T C phi_i| omega_i / |omega_k^2 - omega_i^2|``: small for light damping, large
    for a dashpot that nearly locks a DOF.

    Parameters
    ----------
    modes : Modes
        Mass-normalised real modes of ``(M, K)`` (all of them if possible), shape (n, m).
    macroelements : sequence of Macroelement
        ``p`` macroelements with ``dC`` (N s/m) and ``dzeta_modal`` per unit relative change.
    C : sparse or dense, shape (n, n), optional
        Physical viscous damping matrix at the linearisation point (N s/m); only the
        stiffness and mass parameters' cross terms need it. Default zero.
    modal_damping_ratio : float or ndarray, shape (m,)
        Not needed by the formula (its derivative is ``dzeta_modal``); accepted so that a
        model's damping can be passed whole, and checked for shape.
    degenerate_rtol : float
        See :func:`eigen_sensitivities`.

    Returns
    -------
    ndarray, shape (m, p)
        ``d zeta_i / d alpha_j`` (dimensionless per unit relative change); NaN for rigid
        modes.
    """
    Phi = np.asarray(modes.shapes, dtype=float)
    lam = np.asarray(modes.omega_rad_s, dtype=float) ** 2
    if not macroelements:
        raise ValueError("damping_sensitivities needs at least one macroelement; got none")
    n, m = Phi.shape
    _broadcast_zeta(modal_damping_ratio, m, "modal_damping_ratio")
    Cs = sp.csr_matrix((n, n)) if C is None else (
        sp.csr_matrix(C) if sp.issparse(C) else sp.csr_matrix(np.asarray(C, dtype=float)))
    if Cs.shape != (n, n):
        raise ValueError(f"damping matrix C has shape {Cs.shape}; expected ({n}, {n})")
    bad = [me.name for me in macroelements
           if me.dK.shape != (n, n) or me.dM.shape != (n, n) or me.dC.shape != (n, n)]
    if bad:
        raise ValueError(f"macroelements {bad} do not have the modes' {n} DOFs")
    rigid = np.asarray(modes.rigid, dtype=bool)
    G, H = _projections(Phi, macroelements)
    dlam, coef = _coefficients(lam, rigid, G, H, degenerate_rtol,
                               [me.name for me in macroelements], warn=False)
    return _zeta_jacobian(Phi, np.sqrt(lam), rigid, Cs, macroelements, dlam, coef)
