"""Macroelements: the parts of M and K that one parameter scales (Eq. 10.40,
Table 10.2; :ref:`method-sensitivity`).

Sensitivity localization writes the model error as ``dK = sum_j alpha_j K_j`` and
``dM = sum_j alpha_j M_j`` (Eq. 10.35-10.36). Here every updating parameter ``theta_k``
gets one macroelement, the derivative of the assembled matrices with respect to the
*relative* change of that parameter, ``theta_k -> theta_k (1 + a)``::

    K_k = dK / da |_{a=0} = theta_k dK/dtheta_k,    M_k = theta_k dM/dtheta_k

so ``alpha_k`` is a relative parameter change. Table 10.2 gives the patterns: ``E`` of a
group scales that group's stiffness (``K_k`` is the group's stiffness, ``M_k = 0``),
``rho`` scales its mass, a lumped hub inertia, a suspension or joint stiffness each scale
one lumped term; the wall thickness ``t`` scales both (A, I and J of the thin-walled tube
are all linear in t).

Linear and nonlinear parameters
-------------------------------
For a parameter on which M and K depend linearly (E, rho, t of a group, lumped inertias
and stiffnesses) ``K(theta_k (1 + a)) = K + a K_k`` holds exactly, so a one-sided
difference of any step gives the macroelement up to rounding. Whether this holds is
*measured*, not assumed from the name: the secants ``D(s) = (K(a = s) - K) / s`` at a probe
step ``s = linearity_step`` and at its half ``s / 2`` agree to rounding for a linear
parameter and differ by about ``(s / 4) d2K/da2`` otherwise. The relative mismatch
``||D(s) - D(s/2)||_F / ||D(s)||_F`` (the larger of the M and K parts) is reported as
``Macroelement.nonlinearity``; a part below the rounding level ``64 eps ||M|| / s`` (or
``||K||``), such as the M part of E, is set exactly to zero, and so is every entry below
``64 eps (|X(a = s)| + |X|) / s`` (assembly summation noise outside the pattern). Above
``linearity_tol`` the parameter is nonlinear (r, L, nu, or a sagged element) and a
warning says that its macroelement is only the linearisation at the current value. The
iterated update re-linearises at every step, so the converged parameters are unaffected;
only a single (first-order) step is.

The matrices returned: for a linear parameter the probe secant ``D(s)`` (exact; rounding
about ``eps ||K|| / (s ||K_k||)``); for a nonlinear one the forward difference at
``relative_step`` (derivative at ``theta`` to ``O(relative_step)``, rounding about
``eps ||K|| / (relative_step ||K_k||)``).

Damping
-------
A builder may also return the damping (see :data:`BuildSystem`): ``(M, C, K)`` with ``C``
the physical viscous damping matrix (dashpots), or a
:class:`~truthbench.model.StructuralModel`, whose damping is that ``C`` plus a modal
damping ratio ``zeta_m`` on every elastic mode (``modal_damping_ratio``; the model's
damping is ``Xi = Phi^T C Phi + diag(2 zeta_m omega)``,
:func:`~truthbench.model.modal_damping_matrix`). Every macroelement then also carries
``C_k = theta_k dC/dtheta_k`` (N s/m per unit relative change) and
``zeta_k = theta_k dzeta_m/dtheta_k`` (dimensionless per unit relative change), taken and
checked for linearity exactly like ``M_k`` and ``K_k``. A damping parameter (hub dashpot,
suspension dashpot) has ``M_k = K_k = 0`` and ``C_k != 0``; ``modal_damping_ratio`` has
``C_k = 0`` and ``zeta_k = zeta_m`` (it is not a physical C matrix, so it is its own
kind, see :attr:`Macroelement.kind`).
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from truthbench.model import StructuralModel

_ROUNDING = 64 * np.finfo(float).eps  # rounding level of a difference, relative

#: ``build_mk(theta) -> (M, K)``: the assembled mass and stiffness matrices (sparse or
#: dense, shape (n, n), same DOFs for every ``theta``).
BuildMK = Callable[[Mapping[str, float]], tuple[object, object]]

#: ``build(theta) -> (M, K) | (M, C, K) | StructuralModel``: a :data:`BuildMK`, or a
#: builder that also gives the damping: the physical viscous damping matrix ``C``
#: (N s/m, shape (n, n), may be zero) and, for a ``StructuralModel`` (e.g. ``plant.build``),
#: its ``modal_damping_ratio``. ``(M, C, K)`` means no modal damping.
BuildSystem = Callable[[Mapping[str, float]], object]


@dataclass(frozen=True)
class SystemMatrices:
    """What a :data:`BuildSystem` gave, in one form.

    Attributes
    ----------
    M, C, K : scipy.sparse.csr_matrix, shape (n, n)
        Mass (kg), viscous damping (N s/m; zero when not modelled) and stiffness (N/m).
    modal_damping_ratio : ndarray, shape () or (m,)
        Modal damping ratio of every elastic mode (or one per mode), dimensionless.
    damped : bool
        Whether the builder models damping (returned ``C`` or a model); False for a
        plain ``(M, K)`` builder.
    model : StructuralModel or None
        The model the builder returned, if any.
    """

    M: sp.csr_matrix
    C: sp.csr_matrix
    K: sp.csr_matrix
    modal_damping_ratio: np.ndarray
    damped: bool
    model: StructuralModel | None = None

    @property
    def n_dofs(self) -> int:
        return self.M.shape[0]

    def structural_model(self) -> StructuralModel:
        """The returned model, or a bare one (no inputs, outputs) with ``M``, ``C``,
        ``K`` and the modal damping ratio."""
        if self.model is not None:
            return self.model
        n = self.n_dofs
        return StructuralModel(M=self.M, C=self.C, K=self.K, B=np.zeros((n, 0)),
                               C_out=np.zeros((0, n)), quantities=(),
                               modal_damping_ratio=self.modal_damping_ratio)


def system_matrices(build: BuildSystem, theta: Mapping[str, float]) -> SystemMatrices:
    """Call ``build(theta)`` and bring its result into one form.

    Parameters
    ----------
    build : callable
        ``build(theta)`` returning ``(M, K)``, ``(M, C, K)`` or a
        :class:`~truthbench.model.StructuralModel` (see :data:`BuildSystem`).
    theta : mapping
        All model parameters.

    Returns
    -------
    SystemMatrices

    Raises
    ------
    ValueError
        Any other return value, or matrices that are not square of one shape.
    """
    out = build(theta)
    if isinstance(out, StructuralModel):
        M, C, K = _csr(out.M), _csr(out.C), _csr(out.K)
        zeta = np.asarray(out.modal_damping_ratio, dtype=float)
        model, damped = out, True
    elif isinstance(out, tuple | list) and len(out) in (2, 3):
        if len(out) == 2:
            M, K = _csr(out[0]), _csr(out[1])
            C, damped = sp.csr_matrix(M.shape), False
        else:
            M, C, K = (_csr(a) for a in out)
            damped = True
        zeta, model = np.asarray(0.0), None
    else:
        what = f"a {len(out)}-tuple" if isinstance(out, tuple | list) else type(out).__name__
        raise ValueError(f"the model builder must return (M, K), (M, C, K) or a "
                         f"StructuralModel; got {what}")
    if M.shape[0] != M.shape[1] or K.shape != M.shape or C.shape != M.shape:
        raise ValueError(f"the model builder must return square M, C, K of one shape; got "
                         f"M {M.shape}, C {C.shape}, K {K.shape}")
    if not np.all(np.isfinite(zeta)) or zeta.ndim > 1:
        raise ValueError(f"the model's modal_damping_ratio must be a finite scalar or one "
                         f"value per mode; got {zeta!r}")
    return SystemMatrices(M, C, K, zeta, damped, model)


@dataclass(frozen=True)
class Macroelement:
    """The mass, stiffness and damping pattern scaled by one parameter.

    Attributes
    ----------
    name : str
        The parameter (``E_pa@g2``, ``rho_kg_m3``, ``hub_damping_n_m_s_rad``, ...).
    dM, dK : scipy.sparse.csr_matrix, shape (n, n)
        ``theta_k dM/dtheta_k`` (kg) and ``theta_k dK/dtheta_k`` (N/m): the change of M
        and K per unit *relative* change of the parameter.
    value : float
        The parameter value at which they were taken (its own unit).
    nonlinearity : float
        Relative mismatch of the secants at the probe step and its half (see the module
        docstring); rounding level (about 1e-12 or less) for a linear parameter, ``nan``
        if not checked.
    linear : bool
        ``nonlinearity <= linearity_tol`` (True when not checked).
    dC : scipy.sparse.csr_matrix, shape (n, n)
        ``theta_k dC/dtheta_k`` (N s/m): change of the physical damping matrix per unit
        relative change (zero when not given or when the builder models no damping).
    dzeta_modal : float or ndarray, shape (m,)
        ``theta_k dzeta_m/dtheta_k``: change of the modal damping ratio (dimensionless)
        per unit relative change; equal to ``zeta_m`` itself for ``modal_damping_ratio``.
    """

    name: str
    dM: sp.csr_matrix
    dK: sp.csr_matrix
    value: float
    nonlinearity: float = float("nan")
    linear: bool = True
    dC: sp.csr_matrix | None = None
    dzeta_modal: float | np.ndarray = 0.0

    def __post_init__(self):
        if self.dC is None:
            object.__setattr__(self, "dC", sp.csr_matrix(self.dM.shape))
        z = np.asarray(self.dzeta_modal, dtype=float)
        if z.ndim > 1 or not np.all(np.isfinite(z)):
            raise ValueError(f"Macroelement {self.name!r}: 'dzeta_modal' must be a finite "
                             f"scalar or 1-D array; got {self.dzeta_modal!r}")
        object.__setattr__(self, "dzeta_modal", float(z) if z.ndim == 0 else z)

    @property
    def kind(self) -> str:
        """``"structural"`` (changes M or K; it may change damping as well),
        ``"damping"`` (only the physical damping matrix C, e.g. a dashpot),
        ``"modal_damping"`` (only the modal damping ratio) or ``"none"``."""
        if self.dM.nnz or self.dK.nnz:
            return "structural"
        if self.dC.nnz:
            return "damping"
        if np.any(np.asarray(self.dzeta_modal) != 0):
            return "modal_damping"
        return "none"

    @property
    def acts_on_damping(self) -> bool:
        """True if the parameter changes C or the modal damping ratio."""
        return bool(self.dC.nnz) or bool(np.any(np.asarray(self.dzeta_modal) != 0))


def _csr(a) -> sp.csr_matrix:
    return a.tocsr().astype(float) if sp.issparse(a) else sp.csr_matrix(
        np.asarray(a, dtype=float))


def _build(build: BuildSystem, theta: Mapping[str, float], n: int | None) -> SystemMatrices:
    sysm = system_matrices(build, theta)
    if n is not None and sysm.n_dofs != n:
        raise ValueError(f"the model builder returned {sysm.n_dofs} DOFs at a perturbed "
                         f"parameter; expected {n} (the same DOFs for every parameter value)")
    return sysm


def _fro(a: sp.csr_matrix) -> float:
    return float(np.sqrt(np.sum(np.abs(a.data) ** 2))) if a.nnz else 0.0


def _clean(a: sp.csr_matrix) -> sp.csr_matrix:
    a = a.tocsr(copy=True)
    a.eliminate_zeros()
    return a


def macroelement_matrices(
    build_mk: BuildSystem,
    theta: Mapping[str, float],
    names: Sequence[str],
    *,
    relative_step: float = 1e-6,
    check_linearity: bool = True,
    linearity_step: float = 1e-3,
    linearity_tol: float = 1e-7,
    warn: bool = True,
) -> list[Macroelement]:
    """Macroelements ``M_k, K_k`` (and ``C_k``, ``zeta_k``) of the parameters ``names``.

    Parameters
    ----------
    build_mk : callable
        ``build_mk(theta) -> (M, K)``, sparse or dense, shape (n, n), SI units; or a
        builder that also returns damping, ``(M, C, K)`` or a
        :class:`~truthbench.model.StructuralModel` (:data:`BuildSystem`), for which
        ``dC`` and ``dzeta_modal`` are filled in too.
    theta : mapping
        All model parameters (the linearisation point); ``names`` are perturbed
        relatively, ``theta_k (1 + a)``. Not modified.
    names : sequence of str
        Parameters, each present in ``theta`` with a non-zero value.
    relative_step : float
        Forward-difference step for nonlinear parameters (and for all parameters when
        ``check_linearity`` is False).
    check_linearity : bool
        Probe every parameter at ``linearity_step`` and its half (two more builds each)
        and use the exact secant when linear; see the module docstring.
    linearity_step : float
        Probe step ``s``; large enough that rounding (``eps / s``) is far below
        ``linearity_tol`` and small enough to stay a local probe.
    linearity_tol : float
        Relative secant mismatch above which a parameter counts as nonlinear (for
        r, L the mismatch is about ``s / 4`` times a factor of order one, i.e. 1e-4).
    warn : bool
        Warn (once per call) about nonlinear parameters.

    Returns
    -------
    list of Macroelement
        One per name, in order.

    Raises
    ------
    ValueError
        A name missing from ``theta``, a zero value, a step out of (0, 0.1], or matrices
        of changing size.
    """
    names = tuple(names)
    missing = [k for k in names if k not in theta]
    if missing:
        raise ValueError(f"parameters {missing} are not in theta; expected names from "
                         f"{sorted(theta)}")
    zero = [k for k in names if float(theta[k]) == 0.0]
    if zero:
        raise ValueError(f"relative macroelements need non-zero parameter values; got 0 for "
                         f"{zero}")
    for label, step in (("relative_step", relative_step), ("linearity_step", linearity_step)):
        if not 0 < step <= 0.1:
            raise ValueError(f"{label} must lie in (0, 0.1]; got {step!r}")
    base = _build(build_mk, theta, None)
    n = base.n_dofs
    mats0 = (base.M, base.C, base.K)
    scale = tuple(_fro(a) for a in mats0)

    def secant(name, step):
        """(dM, dC, dK, dzeta) secants; a part at the rounding level of its matrix (a
        parameter that does not enter M, or K, ...) is set to exactly zero."""
        th = dict(theta)
        th[name] = float(theta[name]) * (1.0 + step)
        new = _build(build_mk, th, n)
        out = []
        for mat, old, x0 in zip((new.M, new.C, new.K), mats0, scale, strict=True):
            d = (mat - old) / step
            # entries at the rounding level of the sums that formed them are noise
            noise = (abs(mat) + abs(old)) * (_ROUNDING / step)
            d = d.multiply(abs(d) > noise).tocsr()
            out.append(d if _fro(d) > _ROUNDING * x0 / step else sp.csr_matrix((n, n)))
        z1, z0 = np.broadcast_arrays(new.modal_damping_ratio, base.modal_damping_ratio)
        dz = (z1 - z0) / step
        dz = np.where(np.abs(dz) > (np.abs(z1) + np.abs(z0)) * (_ROUNDING / step), dz, 0.0)
        out.append(dz)
        return tuple(out)

    out, bent = [], []
    for name in names:
        if check_linearity:
            full = secant(name, linearity_step)
            half = secant(name, 0.5 * linearity_step)
            parts = []
            for f, h in zip(full[:3], half[:3], strict=True):
                nf, nh = _fro(f), _fro(h)
                if nf > 0 or nh > 0:
                    parts.append(_fro(f - h) / max(nf, nh))
            nf, nh = np.linalg.norm(full[3]), np.linalg.norm(half[3])
            if nf > 0 or nh > 0:
                parts.append(float(np.linalg.norm(full[3] - half[3]) / max(nf, nh)))
            mismatch = max(parts) if parts else 0.0
            linear = mismatch <= linearity_tol
            dM, dC, dK, dz = full
            if not linear:
                dM, dC, dK, dz = secant(name, relative_step)
                bent.append(f"{name!r} ({mismatch:.1e})")
        else:
            dM, dC, dK, dz = secant(name, relative_step)
            mismatch, linear = float("nan"), True
        out.append(Macroelement(name=name, dM=_clean(dM), dK=_clean(dK),
                                value=float(theta[name]), nonlinearity=float(mismatch),
                                linear=bool(linear), dC=_clean(dC), dzeta_modal=dz))
    if bent and warn:
        warnings.warn(
            f"The model matrices depend nonlinearly on parameters {', '.join(bent)} "
            f"(relative mismatch of the secants at steps {linearity_step:g} and "
            f"{linearity_step / 2:g}; "
            f"expected below {linearity_tol:g} for a linear parameter such as E or rho); "
            f"their macroelements are linearisations at the current values, valid for "
            f"small changes only. An iterated update re-linearises at every step.",
            stacklevel=2)
    return out
