"""Sensitivity localization with modal parameters (METHOD 5.3, Eq. 10.31-10.44).

The model error is written in macroelements (:mod:`truthbench.update.macroelements`),
``dK = sum_j alpha_j K_j`` and ``dM = sum_j alpha_j M_j``, with ``alpha_j`` the relative
change of parameter ``j`` (a parameter that scales only stiffness has ``M_j = 0``, one that
scales only mass ``K_j = 0``, so the chapter's separate ``alpha`` and ``beta`` are one
vector here). First-order perturbation of ``K phi = lambda M phi``, ``Phi^T M Phi = I``
(Fox and Kapoor; modal form) gives, for mode ``i`` and parameter ``j``::

    dlambda_i/dalpha_j = phi_i^T (K_j - lambda_i M_j) phi_i
    dphi_i/dalpha_j    = sum_{k != i} phi_k [phi_k^T (K_j - lambda_i M_j) phi_i]
                                            / (lambda_i - lambda_k)
                         - 1/2 (phi_i^T M_j phi_i) phi_i

The last term keeps ``phi_i^T M phi_i = 1``. The sum runs over all model modes handed in
(keep as many as possible: a truncated basis misses the part of ``dphi`` spanned by the
omitted modes, and the iteration then converges linearly instead of quadratically).

Rigid-body and repeated eigenvalues: pairs ``(i, k)`` with
``|lambda_i - lambda_k| <= degenerate_rtol max(|lambda_i|, |lambda_k|) + 64 eps max|lambda|``
(and every pair of rigid-body modes) are left out of the sum, so nothing is divided by
a number near zero. Consequence: for a degenerate cluster (the y/z bending pairs of a
round tube, the rigid-body modes) the returned ``dphi_i`` has no component along the
other members of the cluster, and ``dlambda_i`` is the diagonal entry of
``Phi_D^T (K_j - lambda M_j) Phi_D`` in the basis the eigensolver happened to return.
Both are exact when the perturbation keeps the symmetry that makes the modes degenerate
(that small matrix is then diagonal, e.g. E or rho of a group of a round tube), and are
basis dependent otherwise: the true derivatives are then those of the adapted basis that
diagonalises it (Nelson's method for repeated roots, which needs second-order terms).
:func:`eigen_sensitivities` warns when a perturbation splits a degenerate cluster.

The update (:func:`sensitivity_update`) pairs each measured mode to a model mode by MAC on
the measured DOFs and frequency, stacks ``[vec dPhi; dlambda]`` over the paired modes and
solves the weighted least-squares problem ``(W S)^+ W d`` (Eq. 10.44), iterating until
the parameter changes stop.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from truthbench.errors import IdentifiabilityError
from truthbench.identify.correlation import modal_scale_factor, pair_modes
from truthbench.identify.modal import ModalParameters
from truthbench.model import Modes, solve_modes
from truthbench.update.finite_difference import UpdateResult
from truthbench.update.macroelements import BuildMK, Macroelement, macroelement_matrices

_EPS = np.finfo(float).eps


# --------------------------------------------------------------------------------------
# data
# --------------------------------------------------------------------------------------
def _readonly(a: np.ndarray) -> np.ndarray:
    a = np.array(a, copy=True)
    a.setflags(write=False)
    return a


@dataclass(frozen=True)
class MeasuredModes:
    """Identified modes of one test on a subset of the model's DOFs.

    Parameters
    ----------
    freq_hz : array_like, shape (n_meas,)
        Natural frequencies, Hz, positive.
    shapes : array_like, shape (n_sens, n_meas)
        Mode shapes at the measured DOFs, real or complex, any scale and sign (each is
        scaled onto its paired model shape, see :func:`sensitivity_update`).
    dof_index : array_like of int, shape (n_sens,)
        Index of each measured row in the model's DOF vector (the rows of ``M`` and
        ``K`` returned by ``build_mk``), no repeats.
    weights : array_like, shape (n_meas,), optional
        Non-negative confidence of each mode; multiplies both its eigenvalue row and its
        shape rows in ``W`` (default 1).

    Notes
    -----
    Arrays are stored as read-only copies.
    """

    freq_hz: np.ndarray
    shapes: np.ndarray
    dof_index: np.ndarray
    weights: np.ndarray | None = None

    def __post_init__(self):
        f = np.array(self.freq_hz, dtype=float)
        if f.ndim != 1 or f.size == 0:
            raise ValueError(f"MeasuredModes: 'freq_hz' must be 1-D with at least one mode; "
                             f"got shape {f.shape}")
        if not (np.all(np.isfinite(f)) and np.all(f > 0)):
            raise ValueError(f"MeasuredModes: 'freq_hz' must be finite and positive; got "
                             f"{f.tolist()}")
        phi = np.array(self.shapes)
        if phi.dtype.kind not in "fc":
            phi = phi.astype(float)
        if phi.ndim == 1 and f.size == 1:
            phi = phi[:, None]
        if phi.ndim != 2 or phi.shape[1] != f.size:
            raise ValueError(f"MeasuredModes: 'shapes' must have shape (n_sens, {f.size}); "
                             f"got {phi.shape}")
        if not np.all(np.isfinite(phi)):
            raise ValueError("MeasuredModes: 'shapes' must be finite")
        dofs = np.array(self.dof_index)
        if dofs.ndim != 1 or dofs.size != phi.shape[0] or dofs.dtype.kind not in "iu":
            raise ValueError(f"MeasuredModes: 'dof_index' must be integers of shape "
                             f"({phi.shape[0]},), one per row of 'shapes'; got "
                             f"{dofs.dtype} of shape {dofs.shape}")
        if np.any(dofs < 0) or np.unique(dofs).size != dofs.size:
            raise ValueError(f"MeasuredModes: 'dof_index' must be non-negative without "
                             f"repeats; got {dofs.tolist()}")
        object.__setattr__(self, "freq_hz", _readonly(f))
        object.__setattr__(self, "shapes", _readonly(phi))
        object.__setattr__(self, "dof_index", _readonly(dofs.astype(np.intp)))
        if self.weights is not None:
            w = np.array(self.weights, dtype=float)
            if w.shape != f.shape or not np.all(np.isfinite(w)) or np.any(w < 0):
                raise ValueError(f"MeasuredModes: 'weights' must be finite, non-negative, "
                                 f"of shape {f.shape}; got {self.weights!r}")
            object.__setattr__(self, "weights", _readonly(w))

    @property
    def n_modes(self) -> int:
        return int(self.freq_hz.size)

    @property
    def n_dofs(self) -> int:
        return int(self.dof_index.size)


@dataclass(frozen=True)
class ModalPairs:
    """The pairing of one measured set at one iteration.

    Attributes
    ----------
    set_index : int
        Position of the :class:`MeasuredModes` in ``measured``.
    model_mode, measured_mode : ndarray of int, shape (n_pairs,)
        Paired model mode (index into the model's modes, ascending frequency) and
        measured mode.
    mac : ndarray, shape (n_pairs,)
        MAC on the measured DOFs.
    freq_error : ndarray, shape (n_pairs,)
        ``(f_measured - f_model) / f_model``.
    unpaired_measured : ndarray of int
        Measured modes without an admissible partner (dropped from that iteration).
    """

    set_index: int
    model_mode: np.ndarray
    measured_mode: np.ndarray
    mac: np.ndarray
    freq_error: np.ndarray
    unpaired_measured: np.ndarray


@dataclass(frozen=True)
class SensitivityResult(UpdateResult):
    """:class:`~truthbench.update.finite_difference.UpdateResult` of
    :func:`sensitivity_update`, with the modal bookkeeping.

    Extra attributes
    ----------------
    alpha_history : ndarray, shape (n_iter, p)
        Relative parameter change solved at every iteration (before the step limit);
        row 0 is the first-order localization from the starting model.
    residual_norm : ndarray, shape (n_iter + 1,)
        ``||W d||``, the square root of ``cost_history``.
    pairing_history : tuple of tuple of ModalPairs
        Per entry of ``history``, one :class:`ModalPairs` per measured set.
    nonlinear : tuple of str
        Parameters whose M, K dependence was found nonlinear (linearised macroelements).
    """

    method: str = "sensitivity"
    alpha_history: np.ndarray | None = None
    residual_norm: np.ndarray | None = None
    pairing_history: tuple = ()
    nonlinear: tuple[str, ...] = ()


# --------------------------------------------------------------------------------------
# eigen-sensitivities
# --------------------------------------------------------------------------------------
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
        Relative eigenvalue gap below which two modes count as degenerate (see the
        module docstring).

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


# --------------------------------------------------------------------------------------
# the update
# --------------------------------------------------------------------------------------
def _check_identifiable(names, A, rcond, macros, M, K) -> None:
    """IdentifiabilityError for unseen parameters or an inseparable combination of the
    column-scaled weighted sensitivity matrix ``A`` (as in finite_difference.py)."""
    norms = np.linalg.norm(A, axis=0)
    top = norms.max() if norms.size else 0.0
    dead = [n for n, v in zip(names, norms, strict=True) if not v > 1e-12 * top]
    if dead:
        raise IdentifiabilityError(
            f"parameters {dead} change none of the paired measured eigenvalues or mode "
            f"shapes at the measured DOFs (zero sensitivity columns); they cannot be "
            f"updated from these modal data. Measure modes or DOFs where they act, or drop "
            f"them.")
    if A.shape[0] < A.shape[1]:
        raise IdentifiabilityError(
            f"sensitivity localization needs at least as many weighted equations as "
            f"parameters; got {A.shape[0]} rows (paired eigenvalues and measured shape "
            f"entries) for p = {A.shape[1]} parameters {list(names)}. Measure more modes "
            f"or DOFs, or update fewer parameters.")
    _, s, Vt = np.linalg.svd(A / norms, full_matrices=False)
    if s[-1] > rcond * s[0]:
        return
    v = Vt[-1] / norms
    v = v / np.abs(v).max()
    parts = [f"{c:+.2f}*d({n})" for n, c in zip(names, v, strict=True) if abs(c) > 0.05]
    # is the null direction a uniform scaling of M and K (E and rho together)?
    dK = sp.csr_matrix(K.shape)
    dM = sp.csr_matrix(M.shape)
    for c, me in zip(v, macros, strict=True):
        dK = dK + c * me.dK
        dM = dM + c * me.dM
    hint = ""
    fro = spla.norm
    if fro(K) > 0 and fro(M) > 0:
        cK = (dK.multiply(K)).sum() / fro(K) ** 2
        cM = (dM.multiply(M)).sum() / fro(M) ** 2
        rK = fro(dK - cK * K) / max(fro(dK), 1e-300)
        rM = fro(dM - cM * M) / max(fro(dM), 1e-300)
        if abs(cK) > 0 and rK < 1e-3 and rM < 1e-3 and abs(cK - cM) < 1e-3 * abs(cK):
            hint = (" This combination scales M and K together (e.g. every E and every rho "
                    "by the same factor): no eigenvalue changes, and after modal-scale-factor "
                    "scaling no mode shape either. Fix one of these parameters (a reference "
                    "group) or supply mass-normalised measured shapes (a collocated driving "
                    "point, METHOD 5.2 item 4) with scale_shapes=False.")
    if not hint and any(n.startswith("t_m") for n in names):
        hint = (" (METHOD section 2: a change in t_m looks exactly like equal changes in "
                "E_pa and rho_kg_m3)")
    raise IdentifiabilityError(
        f"parameters cannot be separated: with its columns scaled to unit norm the "
        f"weighted modal sensitivity matrix has relative singular value {s[-1] / s[0]:.1e}, "
        f"below rcond = {rcond:.0e}; the paired eigenvalues and mode shapes do not change "
        f"along {' '.join(parts)} (relative changes). Drop one of these parameters or add "
        f"data that separates them.{hint}")


def _as_measured(measured) -> tuple[MeasuredModes, ...]:
    if isinstance(measured, MeasuredModes):
        return (measured,)
    try:
        out = tuple(measured)
    except TypeError:
        raise ValueError(f"'measured' must be a MeasuredModes or a sequence of them; got "
                         f"{type(measured).__name__}") from None
    if not out or not all(isinstance(m, MeasuredModes) for m in out):
        raise ValueError("'measured' must be a non-empty sequence of MeasuredModes; got "
                         f"{[type(m).__name__ for m in out]}")
    return out


@dataclass(frozen=True)
class _State:
    cost: float
    A: np.ndarray
    b: np.ndarray
    pairs: tuple[ModalPairs, ...]
    macros: list
    M: object
    K: object


def _evaluate(build_mk, theta, names, measured, opts, first, warned) -> _State:
    """Solve, pair, and stack the weighted data and sensitivities at ``theta``."""
    M, K = build_mk(theta)
    M = M.tocsr() if sp.issparse(M) else sp.csr_matrix(np.asarray(M, dtype=float))
    K = K.tocsr() if sp.issparse(K) else sp.csr_matrix(np.asarray(K, dtype=float))
    n = M.shape[0]
    for s, mm in enumerate(measured):
        if mm.dof_index.max() >= n:
            raise ValueError(f"measured set {s}: 'dof_index' reaches {mm.dof_index.max()}, "
                             f"but the model has {n} DOFs (0..{n - 1})")
    modes = solve_modes(M, K, opts["n_model_modes"])
    macros = macroelement_matrices(build_mk, theta, names, warn=first)
    Phi = modes.shapes
    lam = modes.omega_rad_s ** 2
    rigid = np.asarray(modes.rigid, dtype=bool)
    G, H = _projections(Phi, macros)
    dlam, C = _coefficients(lam, rigid, G, H, opts["degenerate_rtol"], names,
                            warn=first)
    rows_A, rows_b, pairs = [], [], []
    for s, mm in enumerate(measured):
        Phi_s = Phi[mm.dof_index]
        # candidates: elastic modes that move at the measured DOFs (a mode seen there only
        # at rounding level, e.g. y bending by z sensors, has a meaningless MAC)
        seen = np.linalg.norm(Phi_s, axis=0) > opts["visibility_min"] * np.linalg.norm(
            Phi, axis=0)
        elastic = np.nonzero(~rigid & seen)[0]
        model_mp = ModalParameters(modes.freq_hz[elastic], np.zeros(elastic.size),
                                   Phi_s[:, elastic])
        test_mp = ModalParameters(mm.freq_hz, np.zeros(mm.n_modes), mm.shapes)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # "only 1 DOF shared": the user chose that
            pr = pair_modes(model_mp, test_mp, mac_min=opts["mac_min"],
                            freq_weight=opts["freq_weight"])
        model_idx = elastic[pr.pairs[:, 0]] if pr.pairs.size else np.zeros(0, int)
        meas_idx = pr.pairs[:, 1] if pr.pairs.size else np.zeros(0, int)
        for j in pr.unpaired_test:
            if (s, int(j)) not in warned:
                warned.add((s, int(j)))
                col = pr.mac_matrix[:, j]
                best = int(np.argmax(col)) if col.size else -1
                near = (f" (best MAC {col[best]:.2f}, with the model mode at "
                        f"{modes.freq_hz[elastic[best]]:.4g} Hz)" if best >= 0 else "")
                warnings.warn(
                    f"measured mode {j} of set {s} at {mm.freq_hz[j]:.4g} Hz has no model "
                    f"partner with MAC >= mac_min = {opts['mac_min']}{near}; it is dropped. "
                    f"Lower 'mac_min', check 'dof_index', or measure more DOFs.",
                    stacklevel=3)
        pairs.append(ModalPairs(s, model_idx, meas_idx, pr.mac.copy(), pr.freq_error.copy(),
                                pr.unpaired_test.copy()))
        w_mode = np.ones(mm.n_modes) if mm.weights is None else mm.weights
        for i, jt in zip(model_idx, meas_idx, strict=True):
            phi = Phi_s[:, i]
            psi = mm.shapes[:, jt]
            msf = modal_scale_factor(phi[:, None], psi[:, None])[0]
            nphi = np.linalg.norm(phi)
            S_phi = Phi_s @ C[:, :, i].T  # (n_sens, p): dphi_i at the measured DOFs
            if opts["scale_shapes"]:
                psi_s = np.real(msf * psi)
                # the data is MSF-scaled, so its sensitivity is the projected one
                S_phi = S_phi - np.outer(phi, phi @ S_phi) / nphi**2
            else:
                psi_s = np.real(msf / abs(msf) * psi)  # sign / phase only
            w_phi = opts["c_phi"] * w_mode[jt] / nphi
            w_lam = opts["c_lambda"] * w_mode[jt] / abs(lam[i])
            rows_A.append(w_phi * S_phi)
            rows_b.append(w_phi * (psi_s - phi))
            rows_A.append(w_lam * dlam[i][None, :])
            rows_b.append(np.array([w_lam * ((2 * np.pi * mm.freq_hz[jt]) ** 2 - lam[i])]))
    if not rows_A:
        raise IdentifiabilityError(
            f"no measured mode could be paired to a model mode (MAC >= mac_min = "
            f"{opts['mac_min']} on the measured DOFs); nothing to update from. Check "
            f"'dof_index' and the shapes, or lower 'mac_min'.")
    A = np.vstack(rows_A)
    b = np.concatenate(rows_b)
    keep = np.any(A != 0, axis=1) | (b != 0)  # drop rows of zero weight (c_phi = 0)
    A, b = A[keep], b[keep]
    return _State(float(b @ b), A, b, tuple(pairs), macros, M, K)


def sensitivity_update(
    build_mk: BuildMK,
    theta0: Mapping[str, float],
    names: Sequence[str],
    measured: MeasuredModes | Sequence[MeasuredModes],
    *,
    n_model_modes: int | None = None,
    c_lambda: float = 1.0,
    c_phi: float = 0.1,
    mac_min: float = 0.6,
    max_iterations: int = 30,
    tolerance: float = 1e-8,
    rcond: float = 1e-4,
    scale_shapes: bool = True,
    freq_weight: float = 1.0,
    max_step: float = 0.5,
    degenerate_rtol: float = 1e-6,
    visibility_min: float = 1e-4,
) -> SensitivityResult:
    """Iterated sensitivity localization from measured modes (METHOD 5.3).

    Every iteration: solve ``K phi = lambda M phi`` (:func:`~truthbench.model.solve_modes`),
    take the macroelements at the current parameters, pair every measured mode with an
    elastic model mode that moves at the measured DOFs (``visibility_min``)
    (:func:`~truthbench.identify.pair_modes`: MAC on the measured DOFs
    plus ``freq_weight`` times the relative frequency distance, ``MAC >= mac_min``;
    unpaired measured modes are dropped with a warning), and stack, over the paired
    modes ``i`` of every measured set,

    * shape rows ``d = psi~_i - phi_i`` at the measured DOFs with sensitivity rows
      ``P_i dphi_i``: ``psi~_i = Re(MSF_i psi_i)`` is the measured shape scaled (sign
      and size) onto the model shape by the modal scale factor
      ``MSF_i = psi_i^H phi_i / psi_i^H psi_i``; since that scaling removes the shape's
      component along ``phi_i``, the sensitivity is projected the same way,
      ``P_i = I - phi_i phi_i^T / (phi_i^T phi_i)`` (the exact derivative of the
      MSF-scaled shape). The imaginary part left after phase alignment (noise,
      non-proportional damping) cannot be produced by real modes and is dropped.
      With ``scale_shapes=False`` the measured shapes are taken as mass-normalised
      (only the sign is aligned) and ``P_i = I``; then the absolute mass scale is seen.
    * one eigenvalue row ``d = (2 pi f_meas)^2 - lambda_i`` with sensitivity ``dlambda_i``.

    Weights (METHOD 5.3, ``W = diag(c_phi / ||phi_i||, c_lambda / ||lambda_i||)``):
    shape rows ``c_phi w_i / ||phi_i||_2`` with the Euclidean norm of the current model
    shape over the measured DOFs only, eigenvalue rows ``c_lambda w_i / |lambda_i|`` with
    the current model eigenvalue; ``w_i`` the measured mode's weight. So both parts are
    relative errors. The step ``alpha = (W S)^+ W d`` is applied as
    ``theta_k <- theta_k exp(alpha_k)`` (same to first order as ``(1 + alpha_k)``, and
    keeps every parameter's sign), limited to ``max |alpha| <= max_step``. Stop when
    ``max |alpha| < tolerance``.

    Parameters
    ----------
    build_mk : callable
        ``build_mk(theta) -> (M, K)``, sparse or dense, shape (n, n), SI units, for a
        full parameter mapping ``theta``.
    theta0 : mapping
        Starting values of all model parameters; not modified.
    names : sequence of str
        The p parameters to update (each in ``theta0``, non-zero).
    measured : MeasuredModes or sequence of MeasuredModes
        One entry per test / sensor set; each is paired separately.
    n_model_modes : int, optional
        Lowest model modes kept as the basis of ``dphi`` (default all: the sum then is
        exact and Gauss-Newton converges quadratically on exact data).
    c_lambda, c_phi : float
        Weights of eigenvalue and shape rows (eigenvalues are trusted more). ``c_phi=0``
        updates from frequencies only.
    mac_min : float
        Smallest MAC of an admissible pair.
    max_iterations : int
        Largest number of parameter updates.
    tolerance : float
        Convergence: largest ``|alpha|`` of an iteration.
    rcond : float
        Relative singular value of the column-scaled ``W S`` below which parameters are
        declared inseparable (as in the finite-difference method).
    scale_shapes : bool
        Scale measured shapes by the modal scale factor (default) or treat them as
        mass-normalised.
    freq_weight : float
        Frequency term of the pairing cost.
    max_step : float
        Trust region on ``|alpha|`` per iteration.
    degenerate_rtol : float
        See :func:`eigen_sensitivities`.
    visibility_min : float
        A model mode is a pairing candidate for a measured set only if the Euclidean norm
        of its shape at that set's DOFs exceeds ``visibility_min`` times its norm over all
        DOFs (the MAC of a mode seen only at rounding level, such as a y-bending mode on
        z sensors, is meaningless: its rounding noise may be shaped like its near-degenerate
        z partner).

    Returns
    -------
    SensitivityResult
        ``method="sensitivity"``; ``cost_history`` is ``||W d||^2``; singular values,
        condition number and the parameter correlation are those of ``W S`` at the final
        iterate.

    Raises
    ------
    IdentifiabilityError
        A parameter the paired modal data cannot see, an inseparable combination (the
        message names the parameters), fewer equations than parameters, or no pair.
    ValueError
        Bad arguments.

    Warns
    -----
    UserWarning
        Unpaired measured modes, nonlinear parameters (linearised macroelements),
        degenerate modes coupled by a parameter, non-convergence.
    """
    names = tuple(names)
    if not names:
        raise ValueError("no parameters to update: 'names' is empty")
    if len(set(names)) != len(names):
        raise ValueError(f"'names' repeats a parameter: {list(names)}")
    missing = [k for k in names if k not in theta0]
    if missing:
        raise ValueError(f"parameters {missing} are not model parameters; expected names "
                         f"from {sorted(theta0)}")
    if any(float(theta0[k]) == 0 for k in names):
        raise ValueError("relative updating needs non-zero starting values; got 0 for "
                         f"{[k for k in names if float(theta0[k]) == 0]}")
    measured = _as_measured(measured)
    if not (c_lambda >= 0 and c_phi >= 0 and c_lambda + c_phi > 0):
        raise ValueError(f"'c_lambda' and 'c_phi' must be >= 0 and not both 0; got "
                         f"{c_lambda!r} and {c_phi!r}")
    if not 0 <= mac_min <= 1:
        raise ValueError(f"'mac_min' must lie in [0, 1]; got {mac_min!r}")
    if int(max_iterations) != max_iterations or max_iterations < 1:
        raise ValueError(f"'max_iterations' must be a positive integer; got "
                         f"{max_iterations!r}")
    if not (tolerance > 0 and rcond > 0 and max_step > 0):
        raise ValueError(f"'tolerance', 'rcond' and 'max_step' must be positive; got "
                         f"{tolerance!r}, {rcond!r}, {max_step!r}")
    opts = dict(n_model_modes=n_model_modes, c_lambda=float(c_lambda), c_phi=float(c_phi),
                mac_min=float(mac_min), freq_weight=float(freq_weight),
                scale_shapes=bool(scale_shapes), degenerate_rtol=float(degenerate_rtol),
                visibility_min=float(visibility_min))

    theta = dict(theta0)
    base = np.array([float(theta0[k]) for k in names])
    history, costs, pairings, alphas = [base.copy()], [], [], []
    warned: set = set()
    converged = False
    alpha = None
    state = None
    nonlinear: tuple[str, ...] = ()
    for it in range(int(max_iterations) + 1):
        state = _evaluate(build_mk, theta, names, measured, opts, it == 0, warned)
        if it == 0:
            nonlinear = tuple(me.name for me in state.macros if not me.linear)
        costs.append(state.cost)
        pairings.append(state.pairs)
        if alpha is not None and np.max(np.abs(alpha)) < tolerance:
            converged = True
            break
        if it == max_iterations:
            break
        _check_identifiable(names, state.A, rcond, state.macros, state.M, state.K)
        alpha = np.linalg.lstsq(state.A, state.b, rcond=None)[0]
        alphas.append(alpha.copy())
        step = alpha * min(1.0, max_step / max(np.abs(alpha).max(), 1e-300))
        for k, a in zip(names, step, strict=True):
            theta[k] = float(theta[k]) * float(np.exp(a))
        history.append(np.array([theta[k] for k in names]))
    if not converged:
        warnings.warn(
            f"sensitivity update did not converge in {max_iterations} iterations (last "
            f"max |alpha| = {np.max(np.abs(alpha)):.1e} > tolerance {tolerance:.0e}); raise "
            f"'max_iterations', loosen 'tolerance' for noisy data (the steps then shrink "
            f"only linearly), keep more model modes ('n_model_modes'), or check the pairing "
            f"('mac_min') and the parameterisation", stacklevel=2)
    _, s, Vt = np.linalg.svd(state.A, full_matrices=False)
    with np.errstate(divide="ignore", invalid="ignore"):
        Ainv = np.linalg.pinv(np.diag(s) @ Vt)
        cov = Ainv @ Ainv.T
        sd = np.sqrt(np.diag(cov))
        corr = cov / np.outer(sd, sd)
    return SensitivityResult(
        names=names, initial=base, values=history[-1], history=np.array(history),
        cost_history=np.array(costs), singular_values=s,
        condition_number=float(s[0] / s[-1]) if s[-1] > 0 else float("inf"),
        correlation=corr, converged=converged, method="sensitivity",
        alpha_history=np.array(alphas).reshape(len(alphas), len(names)),
        residual_norm=np.sqrt(np.array(costs)), pairing_history=tuple(pairings),
        nonlinear=nonlinear)
