"""Sensitivity localization with modal parameters (Section 10.2.2,
Eq. 10.31-10.44; :ref:`method-sensitivity`).

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
:func:`~truthbench.update.modal_sensitivity.eigen_sensitivities` warns when a perturbation
splits a degenerate cluster.

The update (:func:`sensitivity_update`) pairs each measured mode to a model mode by MAC on
the measured DOFs and frequency, stacks ``[vec dPhi; dlambda]`` over the paired modes and
solves the weighted least-squares problem ``(W S)^+ W d`` (Eq. 10.44), iterating until
the parameter changes stop.

Damping
-------
When the model builder also returns damping (``(M, C, K)`` or a
:class:`~truthbench.model.StructuralModel`, see
:data:`~truthbench.update.macroelements.BuildSystem`) and measured modes carry damping
ratios, damping parameters can be updated too (the hub dashpot, a suspension dashpot,
``modal_damping_ratio``). The model's damping is that of
:class:`~truthbench.model.StructuralModel`: ``Xi = Phi^T C Phi + diag(2 zeta_m omega)``
in the modal first-order form. Then

* the *residuals* use the model's exact complex modes
  (:func:`~truthbench.model.complex_modes`, the same numbers as
  :func:`~truthbench.model.modal_table`): damping ratio ``zeta_i = -Re s_i / |s_i|``,
  natural frequency ``|s_i|`` in the eigenvalue row, and the complex shape in the shape
  row (scaled exactly as the measured one). With proportional damping these are the
  real-mode values, so nothing changes for an undamped or modally damped model.
* the *Jacobian* uses real modes and the light-damping (first-order) expressions
  (:func:`~truthbench.update.modal_sensitivity.damping_sensitivities`)::

      zeta_i ~ zeta_m + phi_i^T C phi_i / (2 omega_i)
      dzeta_i/dalpha_j = phi_i^T C_j phi_i / (2 omega_i) + zeta_m,j
                         + phi_i^T C dphi_i/dalpha_j / omega_i
                         - phi_i^T C phi_i dlambda_i/dalpha_j / (4 omega_i^3)

  (``C_j``, ``zeta_m,j`` the damping macroelement; the last two terms are the effect of
  a stiffness or mass change on the damping ratio of a dashpot). Eigenvalue and shape
  sensitivities are those of the real modes.

Because the residuals are exact, a zero residual (the fixed point of the iteration) is
the exact model even where the first-order Jacobian is poor (a large non-proportional
dashpot); only the convergence rate suffers (it becomes linear, with a rate set by the
Jacobian's relative error).
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, ClassVar

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from truthbench._validation import readonly
from truthbench.errors import IdentifiabilityError
from truthbench.identify.correlation import modal_scale_factor, pair_modes
from truthbench.identify.modal import ModalParameters
from truthbench.model import complex_modes, solve_modes
from truthbench.settings import setting
from truthbench.update.finite_difference import IterationSettings, UpdateResult
from truthbench.update.identifiability import check_identifiable
from truthbench.update.jacobian import JacobianUnavailable, MacroelementCache
from truthbench.update.macroelements import (
    BuildSystem,
    system_matrices,
)
from truthbench.update.modal_sensitivity import (
    _broadcast_zeta,
    _coefficients,
    _projections,
    _zeta_jacobian,
    eigen_sensitivities,  # noqa: F401 - the tests read it here
)

if TYPE_CHECKING:
    from truthbench.update.registry import UpdateProblem

# --------------------------------------------------------------------------------------
# data
# --------------------------------------------------------------------------------------
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
        Non-negative confidence of each mode; multiplies its eigenvalue row, its shape
        rows and its damping row in ``W`` (default 1).
    damping_ratio : array_like, shape (n_meas,), optional
        Measured viscous damping ratio of each mode (dimensionless, ``0 <= zeta < 1``,
        e.g. ``-Re s / |s|`` of an identified pole); NaN marks a mode whose damping was
        not measured. Absent (None): damping is not data, as before.

    Notes
    -----
    Arrays are stored as read-only copies. ``freq_hz`` of a damped mode is its
    undamped natural frequency ``|s| / (2 pi)`` (as identified by
    :mod:`truthbench.identify`); the model side is compared the same way.
    """

    freq_hz: np.ndarray
    shapes: np.ndarray
    dof_index: np.ndarray
    weights: np.ndarray | None = None
    damping_ratio: np.ndarray | None = None

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
        object.__setattr__(self, "freq_hz", readonly(f))
        object.__setattr__(self, "shapes", readonly(phi))
        object.__setattr__(self, "dof_index", readonly(dofs.astype(np.intp)))
        if self.weights is not None:
            w = np.array(self.weights, dtype=float)
            if w.shape != f.shape or not np.all(np.isfinite(w)) or np.any(w < 0):
                raise ValueError(f"MeasuredModes: 'weights' must be finite, non-negative, "
                                 f"of shape {f.shape}; got {self.weights!r}")
            object.__setattr__(self, "weights", readonly(w))
        if self.damping_ratio is not None:
            z = np.array(self.damping_ratio, dtype=float)
            if z.ndim == 0 and f.size == 1:
                z = z[None]
            known = z[np.isfinite(z)] if z.shape == f.shape else z
            if (z.shape != f.shape or np.any(np.isinf(z)) or np.any(known < 0)
                    or np.any(known >= 1)):
                raise ValueError(f"MeasuredModes: 'damping_ratio' must have shape {f.shape} "
                                 f"(one per mode) with values in [0, 1) or NaN (not "
                                 f"measured); got {self.damping_ratio!r}")
            object.__setattr__(self, "damping_ratio", readonly(z))

    @property
    def has_damping(self) -> bool:
        """Whether any mode carries a measured damping ratio."""
        return self.damping_ratio is not None and bool(np.any(np.isfinite(
            self.damping_ratio)))

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
        ``(f_measured - f_model) / f_model`` (``f_model = |s| / (2 pi)`` of the model's
        pole when the builder models damping).
    unpaired_measured : ndarray of int
        Measured modes without an admissible partner (dropped from that iteration).
    damping_error : ndarray, shape (n_pairs,), optional
        ``zeta_measured - zeta_model`` (exact model damping ratio); NaN where the
        damping was not measured or not modelled. None when no damping was measured.
    """

    set_index: int
    model_mode: np.ndarray
    measured_mode: np.ndarray
    mac: np.ndarray
    freq_error: np.ndarray
    unpaired_measured: np.ndarray
    damping_error: np.ndarray | None = None


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
        Parameters whose M, K (or C) dependence was found nonlinear (linearised
        macroelements).
    row_counts : dict
        Weighted equations of the final iterate by kind: ``{"shape": ..., "eigenvalue":
        ..., "damping": ...}`` (the singular values, condition number and correlation
        are those of all of them together).
    """

    method: str = "sensitivity"
    alpha_history: np.ndarray | None = None
    residual_norm: np.ndarray | None = None
    pairing_history: tuple = ()
    nonlinear: tuple[str, ...] = ()
    row_counts: dict | None = None


# --------------------------------------------------------------------------------------
# the update
# --------------------------------------------------------------------------------------
def _check_identifiable(names, A, rcond, macros, M, K, damping=None) -> None:
    """:func:`~truthbench.update.identifiability.check_identifiable` on the column-scaled
    weighted modal sensitivity matrix ``A``, saying what a damping parameter lacks
    (``damping``: the ``_State.damping`` bookkeeping) and whether a null direction scales
    M and K together."""
    damping = damping or {}

    def explain_dead(dead):
        only_damping = [k for k in dead if macros[k].kind in ("damping", "modal_damping")]
        parts = []
        if only_damping:
            who = [f"{names[k]} ({macros[k].kind})" for k in only_damping]
            if damping.get("rows", 0) > 0:
                why = ("the measured damping ratios of the paired modes do not depend on "
                       "them: measure the damping ratio of the modes they damp")
            elif damping.get("c_zeta", 1.0) == 0:
                why = "the damping rows are switched off ('c_zeta' = 0)"
            else:
                why = ("no paired measured mode carries a damping ratio (MeasuredModes."
                       "damping_ratio is absent or NaN): damping ratios must be measured "
                       "to update a damping parameter; pass MeasuredModes(..., "
                       "damping_ratio=...) for the modes they damp")
            parts.append(
                f"parameters {who} change only the damping (not M or K), so only measured "
                f"damping ratios can update them; {why}, or drop them.")
        rest = [k for k in dead if k not in only_damping]
        if rest:
            none = [names[k] for k in rest if macros[k].kind == "none"]
            hint = ""
            if none and not damping.get("damped", False):
                hint = (f" {none} change neither M nor K; if they are damping parameters, "
                        f"the model builder must return the damping too ((M, C, K) or a "
                        f"StructuralModel, UpdateProblem.build_model) and the measured "
                        f"modes their damping ratios.")
            parts.append(
                f"parameters {[names[k] for k in rest]} change none of the paired measured "
                f"eigenvalues, mode shapes at the measured DOFs or damping ratios (zero "
                f"sensitivity columns); they cannot be updated from these modal data. "
                f"Measure modes or DOFs where they act, or drop them.{hint}")
        return " ".join(parts)

    def scales_m_and_k(v):
        """Is the null direction a uniform scaling of M and K (E and rho together)?"""
        dK = sp.csr_matrix(K.shape)
        dM = sp.csr_matrix(M.shape)
        for c, me in zip(v, macros, strict=True):
            dK = dK + c * me.dK
            dM = dM + c * me.dM
        fro = spla.norm
        if fro(K) > 0 and fro(M) > 0:
            cK = (dK.multiply(K)).sum() / fro(K) ** 2
            cM = (dM.multiply(M)).sum() / fro(M) ** 2
            rK = fro(dK - cK * K) / max(fro(dK), 1e-300)
            rM = fro(dM - cM * M) / max(fro(dM), 1e-300)
            if abs(cK) > 0 and rK < 1e-3 and rM < 1e-3 and abs(cK - cM) < 1e-3 * abs(cK):
                return (" This combination scales M and K together (e.g. every E and every "
                        "rho by the same factor): no eigenvalue changes, and after "
                        "modal-scale-factor scaling no mode shape either. Fix one of these "
                        "parameters (a reference group) or supply mass-normalised measured "
                        "shapes (a collocated driving point, Section 10.2.2 issue 4) with "
                        "scale_shapes=False")
        return ""

    check_identifiable(names, A, rcond, dead_tol=1e-12, explain_dead=explain_dead,
                       hint=scales_m_and_k,
                       data="the paired eigenvalues, mode shapes and damping ratios")


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
    row_counts: dict
    damping: dict


def _evaluate(build_mk, theta, names, measured, opts, first, warned, macros_at) -> _State:
    """Solve, pair, and stack the weighted data and sensitivities at ``theta``
    (``macros_at``: a :class:`~truthbench.update.jacobian.MacroelementCache` of
    ``names``)."""
    sysm = system_matrices(build_mk, theta)
    M, K = sysm.M, sysm.K
    n = M.shape[0]
    for s, mm in enumerate(measured):
        if mm.dof_index.max() >= n:
            raise ValueError(f"measured set {s}: 'dof_index' reaches {mm.dof_index.max()}, "
                             f"but the model has {n} DOFs (0..{n - 1})")
    modes = solve_modes(M, K, opts["n_model_modes"])
    try:
        macros = macros_at.at(theta, sysm)
    except JacobianUnavailable as exc:  # the message of macroelement_matrices
        raise ValueError(str(exc)) from None
    Phi = modes.shapes
    lam = modes.omega_rad_s ** 2
    rigid = np.asarray(modes.rigid, dtype=bool)
    G, H = _projections(Phi, macros)
    dlam, coef = _coefficients(lam, rigid, G, H, opts["degenerate_rtol"], names,
                               warn=first)
    has_zeta = any(mm.has_damping for mm in measured)
    if sysm.damped:
        # the model's exact complex modes (as modal_table reports them) for the residuals
        _broadcast_zeta(sysm.modal_damping_ratio, modes.n_modes,
                        "the model's modal_damping_ratio")
        cm = complex_modes(sysm.structural_model(), modes)
        lam_model = cm.omega_rad_s ** 2
        shapes_model = cm.shapes
        zeta_model = cm.damping_ratio
    else:
        lam_model, shapes_model, zeta_model = lam, Phi, None
    # damping rows: measured damping, a damping model, and a parameter acting on damping
    use_zeta = (has_zeta and sysm.damped and opts["c_zeta"] > 0
                and any(me.acts_on_damping for me in macros))
    dzeta = (_zeta_jacobian(Phi, modes.omega_rad_s, rigid, sysm.C, macros, dlam, coef)
             if use_zeta else None)
    if first and has_zeta and not sysm.damped and "no damping model" not in warned:
        warned.add("no damping model")
        warnings.warn(
            "the measured modes carry damping ratios, but the model builder returns only "
            "(M, K): the damping ratios are not used. Give a builder returning (M, C, K) or "
            "a StructuralModel (UpdateProblem.build_model) to use them.", stacklevel=3)
    f_model = np.sqrt(np.abs(lam_model)) / (2 * np.pi)
    rows_A, rows_b, kinds, weights, pairs = [], [], [], [], []
    for s, mm in enumerate(measured):
        Phi_s = Phi[mm.dof_index]
        X_s = shapes_model[mm.dof_index]
        # candidates: elastic modes that move at the measured DOFs (a mode seen there only
        # at rounding level, e.g. y bending by z sensors, has a meaningless MAC) and, with
        # a damping model, have an oscillatory pole
        seen = np.linalg.norm(Phi_s, axis=0) > opts["visibility_min"] * np.linalg.norm(
            Phi, axis=0)
        elastic = np.nonzero(~rigid & seen & np.isfinite(lam_model))[0]
        model_mp = ModalParameters(f_model[elastic], np.zeros(elastic.size),
                                   X_s[:, elastic])
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
                        f"{f_model[elastic[best]]:.4g} Hz)" if best >= 0 else "")
                warnings.warn(
                    f"measured mode {j} of set {s} at {mm.freq_hz[j]:.4g} Hz has no model "
                    f"partner with MAC >= mac_min = {opts['mac_min']}{near}; it is dropped. "
                    f"Lower 'mac_min', check 'dof_index', or measure more DOFs.",
                    stacklevel=3)
        z_err = None
        if mm.damping_ratio is not None:
            z_err = (mm.damping_ratio[meas_idx] - zeta_model[model_idx]
                     if zeta_model is not None else np.full(meas_idx.size, np.nan))
        pairs.append(ModalPairs(s, model_idx, meas_idx, pr.mac.copy(), pr.freq_error.copy(),
                                pr.unpaired_test.copy(), z_err))
        w_mode = np.ones(mm.n_modes) if mm.weights is None else mm.weights
        for i, jt in zip(model_idx, meas_idx, strict=True):
            phi = Phi_s[:, i]
            chi = X_s[:, i]  # the model's shape (complex with non-proportional damping)
            psi = mm.shapes[:, jt]
            msf = modal_scale_factor(phi[:, None], psi[:, None])[0]
            msf_model = modal_scale_factor(phi[:, None], chi[:, None])[0]
            nphi = np.linalg.norm(phi)
            S_phi = Phi_s @ coef[:, :, i].T  # (n_sens, p): dphi_i at the measured DOFs
            if opts["scale_shapes"]:
                # measured and model shapes scaled onto phi_i alike: equal when the model
                # is exact (for real model shapes chi_s = phi exactly)
                psi_s = np.real(msf * psi)
                chi_s = np.real(msf_model * chi)
                # the data is MSF-scaled, so its sensitivity is the projected one
                S_phi = S_phi - np.outer(phi, phi @ S_phi) / nphi**2
            else:
                psi_s = np.real(msf / abs(msf) * psi)  # sign / phase only
                chi_s = np.real(msf_model / abs(msf_model) * chi)
            w_phi = opts["c_phi"] * w_mode[jt] / nphi
            w_lam = opts["c_lambda"] * w_mode[jt] / abs(lam[i])
            rows_A.append(w_phi * S_phi)
            rows_b.append(w_phi * (psi_s - chi_s))
            kinds.append(np.zeros(phi.size, int))
            weights.append(np.full(phi.size, w_phi))
            rows_A.append(w_lam * dlam[i][None, :])
            rows_b.append(np.array([w_lam * ((2 * np.pi * mm.freq_hz[jt]) ** 2
                                             - lam_model[i])]))
            kinds.append(np.ones(1, int))
            weights.append(np.full(1, w_lam))
            if use_zeta and mm.damping_ratio is not None and np.isfinite(
                    mm.damping_ratio[jt]):
                w_z = (opts["c_zeta"] * w_mode[jt]
                       / max(abs(zeta_model[i]), opts["zeta_floor"]))
                rows_A.append(w_z * dzeta[i][None, :])
                rows_b.append(np.array([w_z * (mm.damping_ratio[jt] - zeta_model[i])]))
                kinds.append(np.full(1, 2))
                weights.append(np.full(1, w_z))
    if not rows_A:
        raise IdentifiabilityError(
            f"no measured mode could be paired to a model mode (MAC >= mac_min = "
            f"{opts['mac_min']} on the measured DOFs); nothing to update from. Check "
            f"'dof_index' and the shapes, or lower 'mac_min'.")
    A = np.vstack(rows_A)
    b = np.concatenate(rows_b)
    kinds = np.concatenate(kinds)
    keep = np.concatenate(weights) > 0  # drop rows of zero weight (c_phi = 0, w_i = 0)
    A, b, kinds = A[keep], b[keep], kinds[keep]
    counts = {k: int(np.sum(kinds == v)) for v, k in enumerate(("shape", "eigenvalue",
                                                                 "damping"))}
    damping = {"damped": sysm.damped, "measured": has_zeta, "rows": counts["damping"],
               "c_zeta": opts["c_zeta"]}
    return _State(float(b @ b), A, b, tuple(pairs), macros, M, K, counts, damping)


@dataclass(frozen=True, kw_only=True)
class SensitivityUpdater(IterationSettings):
    """Sensitivity localization from measured modes (Eq. 10.31-10.44,
    :func:`sensitivity_update`, whose defaults are these). Needs ``measured`` and
    ``build_model`` (with damping) or ``build_mk`` of the
    :class:`~truthbench.update.UpdateProblem`; uses ``build_model`` when both are given.
    Updates plant parameters only."""

    name: ClassVar[str] = "sensitivity"
    needs: ClassVar[frozenset[str]] = frozenset({"modes"})

    mac_min: float = setting(0.8, "Least MAC of a measured-model mode pair (on the "
                             "measured DOFs); unpaired measured modes are dropped.",
                             low=0, high=1)
    c_zeta: float = setting(
        1.0, "Weight of the damping-ratio rows (used when a damping parameter is updated; "
        "identified damping is less accurate than frequency: lower it on noisy data).",
        low=0)
    c_phi: float = setting(0.1, "Weight of the mode-shape rows (0 updates from "
                           "frequencies and damping only).", low=0)
    c_lambda: float = setting(1.0, "Weight of the eigenvalue rows.", low=0)

    def unsupported(self, kinds: Mapping[str, str]) -> dict[str, str]:
        """Parameters it cannot update (appended dynamics, effects), with the reason."""
        why = {"appended": "it belongs to the measurement chain, which identified modes do "
                           "not carry (a delay does not move the poles, a gain does not "
                           "change scaled shapes)",
               "effect": "modal data are matched against the plant's own matrices; effect "
                         "parameters are updated from FRFs"}
        return {name: why[kind] for name, kind in kinds.items() if kind in why}

    def update(self, problem: UpdateProblem) -> SensitivityResult:
        """Update ``problem.names`` against the problem's identified modes."""
        self._require(problem, " ('build_model', the model with its damping, may stand in "
                               "for 'build_mk')")
        build = problem.build_model if problem.build_model is not None else problem.build_mk
        return sensitivity_update(build, problem.theta0, problem.names, problem.measured,
                                  **self.settings())


def sensitivity_update(
    build_mk: BuildSystem,
    theta0: Mapping[str, float],
    names: Sequence[str],
    measured: MeasuredModes | Sequence[MeasuredModes],
    *,
    n_model_modes: int | None = None,
    c_lambda: float = SensitivityUpdater.c_lambda,
    c_phi: float = SensitivityUpdater.c_phi,
    c_zeta: float = SensitivityUpdater.c_zeta,
    zeta_floor: float = 1e-3,
    mac_min: float = SensitivityUpdater.mac_min,
    max_iterations: int = SensitivityUpdater.max_iterations,
    tolerance: float = SensitivityUpdater.tolerance,
    rcond: float = SensitivityUpdater.rcond,
    scale_shapes: bool = True,
    freq_weight: float = 1.0,
    max_step: float = SensitivityUpdater.max_step,
    degenerate_rtol: float = 1e-6,
    visibility_min: float = 1e-4,
) -> SensitivityResult:
    """Iterated sensitivity localization from measured modes (Eq. 10.31-10.44).

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
    * with damping (see below), one damping row ``d = zeta_meas - zeta_i`` with
      sensitivity ``dzeta_i``
      (:func:`~truthbench.update.modal_sensitivity.damping_sensitivities`).

    Damping. If ``build_mk`` returns the damping too (``(M, C, K)`` or a
    :class:`~truthbench.model.StructuralModel`), the model side of every row is the
    model's exact complex mode (:func:`~truthbench.model.complex_modes`, as
    :func:`~truthbench.model.modal_table` reports it): ``lambda_i`` above becomes
    ``|s_i|^2``, ``phi_i`` in the shape residual becomes the complex model shape scaled
    exactly like the measured one (``Re(MSF chi_i)``, which is ``phi_i`` for
    proportional damping), and ``zeta_i = -Re s_i / |s_i|``; pairing uses ``|s_i|`` and
    those shapes. The Jacobian stays first order (real modes, light damping), so the
    converged parameters are exact and only the rate of convergence depends on how
    heavy or non-proportional the damping is. Damping rows enter when (a) the builder
    models damping, (b) a paired measured mode has a finite ``damping_ratio``,
    (c) ``c_zeta > 0`` and (d) at least one parameter in ``names`` acts on damping
    (``dC != 0`` or ``dzeta_modal != 0``): a purely structural update is not pulled by a
    damping mismatch it cannot fix.

    Weights (Eq. 10.44, ``W = diag(c_phi / ||phi_i||, c_lambda / ||lambda_i||)``):
    shape rows ``c_phi w_i / ||phi_i||_2`` with the Euclidean norm of the current model
    shape over the measured DOFs only, eigenvalue rows ``c_lambda w_i / |lambda_i|`` with
    the current model eigenvalue, damping rows ``c_zeta w_i / max(|zeta_i|, zeta_floor)``
    with the current exact model damping ratio; ``w_i`` the measured mode's weight. So
    every part is a relative error and the three are commensurate: at ``c = 1`` a 1 %
    error of an eigenvalue (0.5 % in frequency), a 1 % error of the shape vector and
    a 1 % error of a damping ratio (e.g. 0.0101 for 0.01) each cost ``0.01^2``. The
    defaults trust eigenvalues most, damping ratios (relative) as much, shapes 10 times
    less; identified damping ratios are usually far less accurate than frequencies
    (Figure 10.3: 10 % and worse), so on noisy data lower ``c_zeta`` (e.g. 0.1)
    when other parameters also act on damping. The floor keeps a nearly undamped mode
    (``zeta_i`` ~ 0) from weighting its absolute damping error without bound.
    The step ``alpha = (W S)^+ W d`` is applied as
    ``theta_k <- theta_k exp(alpha_k)`` (same to first order as ``(1 + alpha_k)``, and
    keeps every parameter's sign), limited to ``max |alpha| <= max_step``. Stop when
    ``max |alpha| < tolerance``.

    Parameters
    ----------
    build_mk : callable
        ``build_mk(theta) -> (M, K)``, sparse or dense, shape (n, n), SI units, for a
        full parameter mapping ``theta``. To use damping it returns ``(M, C, K)``
        (``C`` the physical viscous damping matrix, N s/m, may be zero; no modal
        damping) or a :class:`~truthbench.model.StructuralModel` (``C`` plus its
        ``modal_damping_ratio``; ``plant.build`` is such a builder).
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
    c_zeta : float
        Weight of the damping-ratio rows (relative errors, see above); ``0`` ignores
        measured damping. Default 1.0.
    zeta_floor : float
        Smallest damping ratio used to make a damping error relative (default 1e-3,
        0.1 % of critical).
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
        See :func:`~truthbench.update.modal_sensitivity.eigen_sensitivities`.
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
        A parameter the paired modal data cannot see (a damping parameter without
        measured damping ratios says so), an inseparable combination (the message names
        the parameters), fewer equations than parameters, or no pair.
    ValueError
        Bad arguments.

    Warns
    -----
    UserWarning
        Unpaired measured modes, nonlinear parameters (linearised macroelements),
        degenerate modes coupled by a parameter, non-convergence, measured damping
        ratios with a builder that returns only ``(M, K)``.
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
    if not (np.isfinite(c_zeta) and c_zeta >= 0):
        raise ValueError(f"'c_zeta' must be a finite number >= 0; got {c_zeta!r}")
    if not (np.isfinite(zeta_floor) and zeta_floor > 0):
        raise ValueError(f"'zeta_floor' must be a finite positive number; got "
                         f"{zeta_floor!r}")
    if not 0 <= mac_min <= 1:
        raise ValueError(f"'mac_min' must lie in [0, 1]; got {mac_min!r}")
    if int(max_iterations) != max_iterations or max_iterations < 1:
        raise ValueError(f"'max_iterations' must be a positive integer; got "
                         f"{max_iterations!r}")
    if not (tolerance > 0 and rcond > 0 and max_step > 0):
        raise ValueError(f"'tolerance', 'rcond' and 'max_step' must be positive; got "
                         f"{tolerance!r}, {rcond!r}, {max_step!r}")
    opts = dict(n_model_modes=n_model_modes, c_lambda=float(c_lambda), c_phi=float(c_phi),
                c_zeta=float(c_zeta), zeta_floor=float(zeta_floor),
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
    # the macroelements are taken once and moved along theta while the parameters act
    # linearly (checked against the built matrices at every iteration)
    macros_at = MacroelementCache(build_mk, names, warn=True)
    for it in range(int(max_iterations) + 1):
        state = _evaluate(build_mk, theta, names, measured, opts, it == 0, warned, macros_at)
        if it == 0:
            nonlinear = tuple(me.name for me in state.macros if not me.linear)
        costs.append(state.cost)
        pairings.append(state.pairs)
        if alpha is not None and np.max(np.abs(alpha)) < tolerance:
            converged = True
            break
        if it == max_iterations:
            break
        _check_identifiable(names, state.A, rcond, state.macros, state.M, state.K,
                            state.damping)
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
        nonlinear=nonlinear, row_counts=dict(state.row_counts))
