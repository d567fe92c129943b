"""Macroelements: the parts of M and K that one parameter scales (METHOD 5.3, Table 10.2).

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
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

#: ``build_mk(theta) -> (M, K)``: the assembled mass and stiffness matrices (sparse or
#: dense, shape (n, n), same DOFs for every ``theta``).
_ROUNDING = 64 * np.finfo(float).eps  # rounding level of a difference, relative

BuildMK = Callable[[Mapping[str, float]], tuple[object, object]]


@dataclass(frozen=True)
class Macroelement:
    """The mass and stiffness pattern scaled by one parameter.

    Attributes
    ----------
    name : str
        The parameter (``E_pa@g2``, ``rho_kg_m3``, ``hub_inertia_kg_m2``, ...).
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
    """

    name: str
    dM: sp.csr_matrix
    dK: sp.csr_matrix
    value: float
    nonlinearity: float = float("nan")
    linear: bool = True


def _csr(a) -> sp.csr_matrix:
    return a.tocsr().astype(float) if sp.issparse(a) else sp.csr_matrix(
        np.asarray(a, dtype=float))


def _build(build_mk: BuildMK, theta: Mapping[str, float], n: int | None):
    M, K = build_mk(theta)
    M, K = _csr(M), _csr(K)
    if M.shape != K.shape or M.shape[0] != M.shape[1]:
        raise ValueError(f"build_mk must return square M and K of one shape; got "
                         f"{M.shape} and {K.shape}")
    if n is not None and M.shape[0] != n:
        raise ValueError(f"build_mk returned {M.shape[0]} DOFs at a perturbed parameter; "
                         f"expected {n} (the same DOFs for every parameter value)")
    return M, K


def _fro(a: sp.csr_matrix) -> float:
    return float(np.sqrt(np.sum(np.abs(a.data) ** 2))) if a.nnz else 0.0


def _clean(a: sp.csr_matrix) -> sp.csr_matrix:
    a = a.tocsr(copy=True)
    a.eliminate_zeros()
    return a


def macroelement_matrices(
    build_mk: BuildMK,
    theta: Mapping[str, float],
    names: Sequence[str],
    *,
    relative_step: float = 1e-6,
    check_linearity: bool = True,
    linearity_step: float = 1e-3,
    linearity_tol: float = 1e-7,
    warn: bool = True,
) -> list[Macroelement]:
    """Macroelements ``M_k, K_k`` of the parameters ``names`` at ``theta``.

    Parameters
    ----------
    build_mk : callable
        ``build_mk(theta) -> (M, K)``, sparse or dense, shape (n, n), SI units.
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
    M0, K0 = _build(build_mk, theta, None)
    n = M0.shape[0]
    scale = (_fro(M0), _fro(K0))

    def secant(name, step):
        """(dM, dK) secants; a part at the rounding level of its matrix (a parameter
        that does not enter M, or K) is set to exactly zero."""
        th = dict(theta)
        th[name] = float(theta[name]) * (1.0 + step)
        M1, K1 = _build(build_mk, th, n)
        out = []
        for new, old, x0 in ((M1, M0, scale[0]), (K1, K0, scale[1])):
            d = (new - old) / step
            # entries at the rounding level of the sums that formed them are noise
            noise = (abs(new) + abs(old)) * (_ROUNDING / step)
            d = d.multiply(abs(d) > noise).tocsr()
            out.append(d if _fro(d) > _ROUNDING * x0 / step else sp.csr_matrix((n, n)))
        return tuple(out)

    out, bent = [], []
    for name in names:
        if check_linearity:
            dM, dK = secant(name, linearity_step)
            hM, hK = secant(name, 0.5 * linearity_step)
            parts = []
            for full, half in ((dM, hM), (dK, hK)):
                nf = _fro(full)
                if nf > 0 or _fro(half) > 0:
                    parts.append(_fro(full - half) / max(nf, _fro(half)))
            mismatch = max(parts) if parts else 0.0
            linear = mismatch <= linearity_tol
            if not linear:
                dM, dK = secant(name, relative_step)
                bent.append(f"{name!r} ({mismatch:.1e})")
        else:
            dM, dK = secant(name, relative_step)
            mismatch, linear = float("nan"), True
        out.append(Macroelement(name=name, dM=_clean(dM), dK=_clean(dK),
                                value=float(theta[name]), nonlinearity=float(mismatch),
                                linear=bool(linear)))
    if bent and warn:
        warnings.warn(
            f"M and K depend nonlinearly on parameters {', '.join(bent)} (relative mismatch "
            f"of the secants at steps {linearity_step:g} and {linearity_step / 2:g}; "
            f"expected below {linearity_tol:g} for a linear parameter such as E or rho); "
            f"their macroelements are linearisations at the current values, valid for "
            f"small changes only. An iterated update re-linearises at every step.",
            stacklevel=2)
    return out
