"""Analytic FRF Jacobian of an :class:`~truthbench.update.FRFPredictor` (Eq. 10.15-10.19;
:ref:`method-finite-difference`).

The finite-difference update needs ``S = dG/dp``, the derivative of every model FRF
entry with respect to a relative change ``p_k`` of each updated parameter
(``theta_k = theta_0k (1 + p_k)``; per unit of its scale ``a_k`` for an additive one).
Central differences cost two model builds, two eigen-solutions and two FRF evaluations
per parameter and iteration; here ``S`` comes from the model's modes at ``theta`` (which
the prediction at ``theta`` has already solved) and the derivatives of its matrices.

The structural FRF in the complete modal basis (every mode of the model, which is what
:func:`truthbench.model.frf` sums) is::

    H(s) = s^q  C_out Phi Z(s)^-1 Phi^T B,    Z(s) = Lambda + s Xi + s^2 I,
    Xi = Phi^T C Phi + diag(2 zeta_i omega_i)

with ``q`` the output's power (0, 1, 2 for displacement, velocity, acceleration). For a
parameter with macroelements ``dK, dM, dC, dzeta`` (:mod:`truthbench.update.macroelements`,
per unit relative change) the eigen-sensitivities of
:mod:`truthbench.update.modal_sensitivity` give ``dPhi = Phi Cc`` (Fox-Kapoor in the complete
basis, ``Cc_ki = A_ki / (lambda_i - lambda_k)``, ``Cc_ii = -H_ii / 2``, with
``A = Phi^T (dK - lambda_i dM) Phi`` and ``H = Phi^T dM Phi``), and by the product rule::

    dH = s^q [ C_out dPhi Z^-1 Bm + Cm Z^-1 dPhi^T B - Cm Z^-1 dZ Z^-1 Bm ]
    dZ = dLambda + s ( dD + Phi^T dC Phi + dPhi^T C Phi + Phi^T C dPhi )

``dD = diag(2 zeta_i domega_i + 2 dzeta_i omega_i)``, ``domega_i = dlambda_i / (2 omega_i)``:
the modal damping ``2 zeta omega`` follows the natural frequencies, so a stiffness or mass
parameter changes the damping too. Degenerate clusters (equal eigenvalues: the y and z
bending pairs of a round tube, rigid-body modes) have no unique eigenvectors; their
members' mutual coefficients take the rotation-free choice ``Cc_ki = -H_ki / 2`` and the
cluster's block of ``dLambda`` (and of ``dD``, ``zeta / omega`` times it) is the full
symmetric block of ``A``: the limit of the distinct-eigenvalue formula as the gap closes,
so the result does not depend on the eigensolver's basis. Modes coupled by
non-proportional damping (a dashpot) are handled through the complex modes of that subset,
``Z_c^-1 = V_top diag(1 / (s - mu)) V^-1[:, m:]``, exactly as the model's FRF.

The appended dynamics are exact: ``dG/d(delay) = -s a G`` and ``dG/dp(gain) = G``; actuator
and sensor filters and the gain multiply ``dH`` as they multiply ``H``.

Macroelements are taken once (:func:`~truthbench.update.macroelements.macroelement_matrices`,
with its linearity probe) and, for parameters on which the matrices depend linearly, moved
to a new ``theta`` exactly (``theta_k dX/dtheta_k`` with a constant ``dX/dtheta_k``); the
actual matrices at ``theta`` are checked against that affine prediction at every call
(relative Frobenius mismatch below :data:`AFFINE_RTOL`), and the macroelements are taken
anew at ``theta`` when the check fails (a nonlinear parameter such as ``r_m`` or ``L_m``, or
a joint dependence such as ``E t``).

The derivative is taken on the blocks of DOFs the channels sit on
(:func:`channel_subspace`): a beam measured in one plane needs that plane's bending
modes only, all of them (the basis is complete there), and no block elsewhere. A
``reduced`` predictor's modes (:class:`~truthbench.effects.Hardware`) are exactly those
blocks' and serve as they are; a predictor that leaves modes out (``mode_tolerance``)
has no analytic Jacobian.

:func:`frf_jacobian` raises :class:`JacobianUnavailable` (and the finite-difference update
then uses finite differences) for what this does not cover: effect parameters, parameters
of per-test instrumentation effects or closed loops, an averaged-estimator prediction, a
defective complex-mode basis, a rigid-body mode that a parameter would make elastic while
the modal damping ratio is non-zero.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import replace

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from truthbench.model import QUANTITIES, Modes, coupled_blocks, solve_modes
from truthbench.update.macroelements import (
    Macroelement,
    macroelement_matrices,
    system_matrices,
)

AFFINE_RTOL = 1e-9
"""Largest relative Frobenius mismatch between the matrices built at ``theta`` and their
affine prediction from the cached macroelements. Rounding of the prediction is about
``2 eps / 1e-3`` (the probe step) times the relative parameter change, about 1e-12."""

DEGENERATE_RTOL = 1e-6
"""Relative eigenvalue gap below which two modes form a degenerate cluster (the value of
:func:`truthbench.update.modal_sensitivity.eigen_sensitivities`)."""

SHARED_SIZE = 8
"""Macroelement sets (one model's, at one ``theta``) a process keeps for the caches whose
builders declare a ``content_key`` (:class:`MacroelementCache`)."""

_SHARED: dict = {}
_EPS = np.finfo(float).eps
_DENSE_CHECK = 2000  # DOFs up to which the affine check runs on dense copies


class JacobianUnavailable(Exception):
    """The analytic Jacobian does not cover this case (the message says why); use finite
    differences."""


# --------------------------------------------------------------------------------------
# macroelements, moved along theta
# --------------------------------------------------------------------------------------
class MacroelementCache:
    """Macroelements of one set of parameters, taken once and moved to new ``theta``.

    Parameters
    ----------
    build : callable
        ``build(theta)``: the model at ``theta`` (a
        :class:`~truthbench.model.StructuralModel`, or ``(M, K)``, ``(M, C, K)``:
        :func:`~truthbench.update.macroelements.system_matrices`). A builder with a
        hashable ``content_key`` attribute (what its models depend on besides ``theta``)
        shares the macroelements it takes at a ``theta`` with every cache of this
        process whose builder has the same key (the last :data:`SHARED_SIZE`): a
        campaign's trials update the same model from the same nominal values.
    names : sequence of str
        The plant parameters.
    warn : bool
        Warn of nonlinear parameters the first time the macroelements are taken
        (:func:`~truthbench.update.macroelements.macroelement_matrices`).
    reference : mapping, optional
        Parameter values to take the macroelements at first (e.g. the nominal model's,
        which every trial of a campaign shares), then moved to the ``theta`` asked for;
        default: the first ``theta`` asked for.
    """

    def __init__(self, build, names: Sequence[str], *, warn: bool = False,
                 reference: Mapping[str, float] | None = None):
        self.build = build
        self.names = tuple(names)
        self.warn = bool(warn)
        self.reference = None if reference is None else dict(reference)
        self._ref = None  # (theta values, (M, C, K, zeta), macroelements)
        self.relinearisations = 0

    def _take(self, theta: Mapping[str, float]):
        key = self._shared_key(theta)
        ref = None if key is None else _SHARED.pop(key, None)
        if ref is None:
            try:
                macros = macroelement_matrices(self.build, theta, self.names,
                                               warn=self.warn and not self.relinearisations)
            except ValueError as exc:  # a zero value, a changing DOF count
                raise JacobianUnavailable(str(exc)) from None
            model = system_matrices(self.build, theta)
            base = (model.M, model.C, model.K, np.asarray(model.modal_damping_ratio, float))
            ref = (np.array([float(theta[n]) for n in self.names]), base, macros)
        if key is not None:
            _SHARED[key] = ref  # most recently used last
            while len(_SHARED) > SHARED_SIZE:
                _SHARED.pop(next(iter(_SHARED)))
        self._ref = ref
        self.relinearisations += 1
        return ref[2]

    def _shared_key(self, theta: Mapping[str, float]):
        content = getattr(self.build, "content_key", None)
        if content is None:
            return None
        try:
            key = (content, self.names, tuple(sorted((k, float(v)) for k, v in theta.items())))
            hash(key)
        except (TypeError, ValueError):
            return None
        return key

    def at(self, theta: Mapping[str, float], model) -> list[Macroelement]:
        """The macroelements at ``theta`` (``model``: the model built at ``theta``, with
        ``M``, ``C``, ``K`` and ``modal_damping_ratio``)."""
        if self._ref is None:
            if self.reference is None:
                return self._take(theta)
            self._take({**theta, **self.reference})
        vals0, base, macros = self._ref
        vals = np.array([float(theta[n]) for n in self.names])
        if np.array_equal(vals, vals0):
            return macros
        if not all(me.linear for me in macros):
            return self._take(theta)
        ratio = vals / vals0
        d = ratio - 1.0
        now = (model.M, model.C, model.K, np.asarray(model.modal_damping_ratio, float))
        dense = model.M.shape[0] <= _DENSE_CHECK
        for k, (x_now, x0) in enumerate(zip(now, base, strict=True)):
            parts = [(me.dM, me.dC, me.dK, me.dzeta_modal)[k] for me in macros]
            if k < 3:
                if dense:
                    pred = x0.toarray()
                    for dk, part in zip(d, parts, strict=True):
                        if part.nnz:
                            pred += dk * part.toarray()
                    x_now = x_now.toarray()
                else:
                    pred = x0.copy()
                    for dk, part in zip(d, parts, strict=True):
                        if part.nnz:
                            pred = pred + dk * part
            else:
                pred = np.asarray(x0, float) + sum(dk * np.asarray(part, float)
                                                   for dk, part in zip(d, parts, strict=True))
                x_now = np.asarray(x_now, float)
            diff = _fro(x_now - pred)
            if diff > AFFINE_RTOL * max(_fro(x_now), 1e-300):
                return self._take(theta)
        return [Macroelement(me.name, me.dM * r, me.dK * r, float(v), me.nonlinearity,
                             me.linear, me.dC * r, np.asarray(me.dzeta_modal) * r)
                for me, r, v in zip(macros, ratio, vals, strict=True)]


def _fro(a) -> float:
    if sp.issparse(a):
        return float(np.sqrt(np.sum(np.abs(a.data) ** 2))) if a.nnz else 0.0
    return float(np.linalg.norm(a))


# --------------------------------------------------------------------------------------
# the structural derivative
# --------------------------------------------------------------------------------------
def _apply(weights: np.ndarray, tensor: np.ndarray) -> np.ndarray:
    """``sum_k weights[f, k] tensor[k, ...]``: one matrix product, shape (F, ...)."""
    return (weights @ tensor.reshape(tensor.shape[0], -1)).reshape(
        (weights.shape[0],) + tensor.shape[1:])


class _Batch:
    """Products ``weights[key] @ tensor`` requested one by one and done as one matrix
    product per weight matrix (:meth:`run`); :meth:`get` returns a request's result,
    shape (F, ...) with the tensor's trailing shape; a list of requests is summed."""

    def __init__(self, weights: dict):
        self.weights = weights
        self.parts: dict = {k: [] for k in weights}
        self.results: dict = {}

    def add(self, key: str, tensor: np.ndarray):
        self.parts[key].append(tensor)
        return key, len(self.parts[key]) - 1

    def run(self) -> None:
        for key, tensors in self.parts.items():
            if not tensors:
                continue
            K = tensors[0].shape[0]
            if K == 0:  # no mode or pole of this kind (every mode coupled, say)
                F = self.weights[key].shape[0]
                self.results[key] = [np.zeros((F,) + t.shape[1:], np.result_type(
                    self.weights[key], t)) for t in tensors]
                continue
            flat = [t.reshape(K, -1) for t in tensors]
            dtype = np.result_type(*flat)
            big = np.concatenate([f.astype(dtype, copy=False) for f in flat], axis=1)
            prod = self.weights[key] @ big
            start, out = 0, []
            for t, f in zip(tensors, flat, strict=True):
                out.append(prod[:, start:start + f.shape[1]].reshape(
                    (prod.shape[0],) + t.shape[1:]))
                start += f.shape[1]
            self.results[key] = out

    def get(self, handle) -> np.ndarray:
        if isinstance(handle, list):
            total = self.get(handle[0])
            for h in handle[1:]:
                total = total + self.get(h)
            return total
        key, k = handle
        return self.results[key][k]


def channel_subspace(model, modes, macros: Sequence[Macroelement], n_inputs: int):
    """The model, its modes and the macroelements restricted to the DOFs that the
    channels' FRFs and their derivatives depend on.

    ``M``, ``C``, ``K`` and every macroelement's ``dM``, ``dC``, ``dK`` are block-diagonal
    up to a permutation (:func:`~truthbench.model.coupled_blocks`: a straight beam's
    bending planes, axial and torsion); a block that holds none of the DOFs the first
    ``n_inputs`` inputs drive or the outputs read takes no part in those FRFs at any
    ``theta`` nearby, nor in their derivatives. The FRF and its Jacobian on the blocks
    that do (``S``) are those of the whole model, with a complete modal basis of ``S``
    only: a beam measured in one plane has a third of the modes, and the Jacobian's
    products over modes cost a third.

    Parameters
    ----------
    model : StructuralModel
    modes : Modes
        The model's modes: all of them, or those of the blocks of ``S`` (a reduced
        :class:`~truthbench.effects.Hardware`'s), which are then used as they are.
    macros : sequence of Macroelement
    n_inputs : int
        The inputs used (the first ``n_inputs`` columns of ``B``).

    Returns
    -------
    model : StructuralModel
        Restricted to ``S`` (the same object when ``S`` is every DOF).
    modes : Modes
        All modes of the restricted model.
    macros : list of Macroelement
        Restricted to ``S``.
    """
    zeta = np.asarray(model.modal_damping_ratio, float)
    per_mode = zeta.size > 1 or any(np.size(me.dzeta_modal) > 1 for me in macros)
    n = model.n_dofs
    if not per_mode:  # one damping ratio per mode indexes the full basis: no restriction
        parts = [model.M, model.K, model.C] + [x for me in macros
                                               for x in (me.dM, me.dK, me.dC) if x.nnz]
        blocks = coupled_blocks(*parts)
        channels = np.any(model.B[:, :n_inputs] != 0, axis=1) | np.any(model.C_out != 0,
                                                                        axis=0)
        keep = [b for b in blocks if channels[b].any()]
        S = np.sort(np.concatenate(keep)) if keep else np.arange(n)
    if per_mode or S.size == n:
        return model, (modes if modes.n_modes == n else model.modes()), list(macros)

    def sub(x):
        return x.tocsr()[S][:, S]

    labels = model.dof_labels
    small = replace(model, M=sub(model.M), C=sub(model.C), K=sub(model.K), B=model.B[S],
                    C_out=model.C_out[:, S], dof_labels=tuple(labels[i] for i in S))
    outside = np.ones(n, bool)
    outside[S] = False
    if modes.n_modes == S.size and not np.any(modes.shapes[outside]):
        # the modes of exactly these blocks (a reduced Hardware's): complete on S
        modes = Modes(modes.omega_rad_s, modes.shapes[S], modes.rigid)
    else:
        modes = solve_modes(small.M, small.K)
    return (small, modes,
            [replace(me, dM=sub(me.dM), dK=sub(me.dK), dC=sub(me.dC)) for me in macros])


def _support(mat) -> np.ndarray:
    """Indices of the rows (= columns, symmetric) where ``mat`` has entries."""
    coo = sp.coo_matrix(mat)
    return np.unique(np.concatenate([coo.row, coo.col]))


def structural_frf_jacobian(model, modes, macros: Sequence[Macroelement], s: np.ndarray,
                            n_inputs: int | None = None, *,
                            degenerate_rtol: float = DEGENERATE_RTOL) -> np.ndarray:
    """Derivative of the model's FRF (:func:`truthbench.model.frf`) with respect to the
    relative change of each macroelement's parameter.

    Parameters
    ----------
    model : StructuralModel
        The model at the linearisation point.
    modes : Modes
        All of its modes (:meth:`StructuralModel.modes`): the basis must be complete.
    macros : sequence of Macroelement
        ``p`` macroelements at the same point (dM, dC, dK, dzeta per unit relative change).
    s : ndarray, complex, shape (n_freq,)
        Laplace variable at the lines, rad/s (``decay + j omega``).
    n_inputs : int, optional
        Use the first ``n_inputs`` columns of ``B`` (default all).

    Returns
    -------
    ndarray, complex, shape (p, n_freq, n_out, n_in)
        ``dH / dp_k``, in the FRF's units per unit relative change.

    Raises
    ------
    JacobianUnavailable
        Not a complete basis, a defective complex-mode basis, a rigid-body mode made
        elastic while the modal damping ratio is non-zero, unequal modal damping ratios
        in a coupled degenerate cluster.
    """
    Phi = np.asarray(modes.shapes, float)
    n, m = Phi.shape
    if m != n:
        raise JacobianUnavailable(f"the modal basis has {m} of {n} modes; the analytic "
                                  f"Jacobian needs all of them")
    w = np.asarray(modes.omega_rad_s, float)
    lam = w**2
    rigid = np.asarray(modes.rigid, bool)
    zeta = np.broadcast_to(np.asarray(model.modal_damping_ratio, float), (m,)).copy()
    B = model.B if n_inputs is None else model.B[:, :n_inputs]
    Bm = Phi.T @ B
    Cm = model.C_out @ Phi
    C = model.C.tocsr()
    R = _support(C) if C.nnz else np.zeros(0, int)
    PhiR = Phi[R]
    C_RR = C[R][:, R].toarray() if R.size else np.zeros((0, 0))
    XiC = PhiR.T @ C_RR @ PhiR
    D = 2.0 * zeta * w
    Xi = XiC + np.diag(D)
    off = np.abs(Xi - np.diag(np.diag(Xi))) > 1e-12 * max(np.abs(Xi).max(), 1e-300)
    coupled = off.any(axis=0) | off.any(axis=1)
    F = s.size
    n_out, n_in = Cm.shape[0], Bm.shape[1]
    # The resolvent Z^-1: 1 / z_m on the modes without damping coupling ("free"),
    # V_top diag(1 / (s - mu)) V^-1[:, m:] on the coupled subset. Every term below is a
    # product (frequency weights (F, K)) @ (K, ...) over a mode or pole index K.
    fr = np.flatnonzero(~coupled)
    c = np.flatnonzero(coupled)
    inv = 1.0 / (lam[None, fr] + s[:, None] ** 2 + s[:, None] * np.diag(Xi)[fr])  # (F, mf)
    inv2 = inv * inv
    if c.size:
        mc = c.size
        A = np.block([[np.zeros((mc, mc)), np.eye(mc)],
                      [-np.diag(lam[c]), -Xi[np.ix_(c, c)]]])
        mu, V = sla.eig(A)
        lu = sla.lu_factor(V, check_finite=False)
        rcond = sla.lapack.get_lapack_funcs("gecon", (lu[0],))(lu[0], np.linalg.norm(V, 1))[0]
        if not rcond > 1e-10:
            raise JacobianUnavailable("the complex modes of the damped subset are defective "
                                      "(rigid modes beside a dashpot)")
        W = sla.lu_solve(lu, np.vstack([np.zeros((mc, mc)), np.eye(mc)]), check_finite=False)
        Vt = V[:mc]  # (mc, 2 mc): Z_c^-1 = Vt diag(r) W
        # products of two resolvents become sums over single poles (partial fractions,
        # r_a r_b = (r_a - r_b) / (mu_a - mu_b)): the poles must be well apart
        gap = np.abs(mu[:, None] - mu[None, :]) + np.eye(2 * mc) * np.abs(mu).max()
        if gap.min() <= 1e-7 * max(np.abs(mu).max(), 1e-300):
            raise JacobianUnavailable("repeated complex poles in the damped subset")
        with np.errstate(divide="ignore", invalid="ignore"):
            g = np.where(np.eye(2 * mc, dtype=bool), 0.0, 1.0 / (mu[:, None] - mu[None, :]))
        r = 1.0 / (s[:, None] - mu[None, :])  # (F, 2 mc)
        r2 = r * r
        L = Cm[:, c] @ Vt  # (n_out, 2 mc)
        Rb = W @ Bm[c]  # (2 mc, n_in)

    # every product (frequency weights) @ (mode or pole tensor) of the Jacobian is
    # requested first and done as one matrix product per weight matrix
    batch = _Batch({"inv": inv, "inv2": inv2, **({"r": r, "r2": r2} if c.size else {})})

    def y_proj(P):
        """Request sum_m Y[f, o, m] P[k, m] = (Cm Z^-1 P^T)[f], shape (F, n_out, k)."""
        parts = [batch.add("inv", Cm[:, fr].T[:, :, None] * P[:, fr].T[:, None, :])]
        if c.size:
            parts.append(batch.add("r", L.T[:, :, None] * (W @ P[:, c].T)[:, None, :]))
        return parts

    def x_proj(P):
        """Request sum_m P[k, m] X[f, m, i] = (P Z^-1 Bm)[f], shape (F, k, n_in)."""
        parts = [batch.add("inv", P[:, fr].T[:, :, None] * Bm[fr][:, None, :])]
        if c.size:
            parts.append(batch.add("r", (P[:, c] @ Vt).T[:, :, None] * Rb[:, None, :]))
        return parts

    # what every parameter shares
    a = np.abs(lam)
    floor = 64 * _EPS * (a.max() if a.size else 0.0)
    excl = np.abs(lam[None, :] - lam[:, None]) <= degenerate_rtol * np.maximum(
        a[None, :], a[:, None]) + floor
    excl |= rigid[None, :] & rigid[:, None]
    np.fill_diagonal(excl, True)
    with np.errstate(divide="ignore"):
        gap_inv = np.where(excl, 0.0, 1.0 / np.where(excl, 1.0, lam[None, :] - lam[:, None]))
    cluster = excl & ~np.eye(m, dtype=bool)
    ck, ci = np.nonzero(cluster)
    elastic_pair = ~rigid[ck] & ~rigid[ci]
    if np.any(zeta[ck[elastic_pair]] != zeta[ci[elastic_pair]]):
        raise JacobianUnavailable("per-mode damping ratios differ inside a degenerate cluster")
    with np.errstate(divide="ignore", invalid="ignore"):
        zeta_over_w = np.where(w > 0, zeta / np.where(w > 0, w, 1.0), 0.0)
    pos = np.full(m, -1)
    pos[fr] = np.arange(fr.size)
    P = Cm[:, fr].T[:, :, None] * Bm[fr][:, None, :]  # (mf, n_out, n_in)
    p = len(macros)
    # per parameter: tensors for the products over the free modes and the poles; the
    # clusters' and the damping's terms need Y and X at a few modes or DOFs
    t_inv = np.empty((fr.size, p, n_out, n_in))
    t_inv2 = np.empty((fr.size, 2, p, n_out, n_in))
    extra = np.zeros((p, F, n_out, n_in), complex)
    damp_rows: list = []
    dC_rows: list = []
    cluster_terms: list = []
    if c.size:
        t_r = np.empty((2 * mc, p, n_out, n_in), complex)
        t_r2 = np.empty((2 * mc, p, n_out, n_in), complex)
    for j, me in enumerate(macros):
        Gj = Phi.T @ np.asarray(me.dK @ Phi) if me.dK.nnz else np.zeros((m, m))
        Hj = Phi.T @ np.asarray(me.dM @ Phi) if me.dM.nnz else np.zeros((m, m))
        Aj = Gj - lam[None, :] * Hj  # A[k, i] = phi_k^T (K_j - lam_i M_j) phi_i
        Cc = np.where(excl, -0.5 * Hj, Aj * gap_inv)
        dlam = np.diag(Aj).copy()
        moved = rigid & (np.abs(dlam) > 1e-9 * max(a.max(), 1e-300))
        if moved.any() and np.any(np.asarray(model.modal_damping_ratio) != 0):
            raise JacobianUnavailable(f"parameter {me.name!r} gives a rigid-body mode "
                                      f"stiffness while the modal damping ratio is non-zero "
                                      f"(2 zeta omega is not differentiable at omega = 0)")
        dz = np.broadcast_to(np.asarray(me.dzeta_modal, float), (m,))
        with np.errstate(divide="ignore", invalid="ignore"):
            domega = np.where(w > 0, dlam / (2 * np.where(w > 0, w, 1.0)), 0.0)
        dD = 2.0 * zeta * domega + 2.0 * dz * w
        # dH = dCm X + Y dBm - Y dZ X  (then times s^q)
        dCm = Cm @ Cc
        dBm = Cc.T @ Bm
        t_inv[:, j] = (dCm[:, fr].T[:, :, None] * Bm[fr][:, None, :]
                       + Cm[:, fr].T[:, :, None] * dBm[fr][:, None, :])
        t_inv2[:, 0, j] = P * dlam[fr][:, None, None]
        t_inv2[:, 1, j] = P * dD[fr][:, None, None]
        if c.size:
            # dCm Z^-1 Bm + Cm Z^-1 dBm, then - Cm Z^-1 diag(dlam + s dD) Z^-1 Bm over
            # the coupled modes: with Q = W diag(.) Vt in the pole basis,
            # sum_ab L_a r_a Q_ab r_b R_b = sum_c r_c K1_c + r_c^2 K2_c (s r_a = 1 + mu_a r_a)
            Q0 = (W * dlam[c][None, :]) @ Vt
            Q1 = (W * dD[c][None, :]) @ Vt
            eye2 = np.eye(2 * mc, dtype=bool)
            N1 = (Q0 + mu[:, None] * Q1) * g + np.diag(np.diag(Q1))
            N2 = -(Q0 + mu[:, None] * Q1) * g + np.where(eye2, 0.0, Q1)
            first_c = ((dCm[:, c] @ Vt).T[:, :, None] * Rb[:, None, :]
                       + L.T[:, :, None] * (W @ dBm[c])[:, None, :])
            K1 = L.T[:, :, None] * (N1 @ Rb)[:, None, :] + (L @ N2).T[:, :, None] * Rb[:, None, :]
            K2 = (L.T[:, :, None] * Rb[:, None, :]) * (np.diag(Q0) + mu * np.diag(Q1))[:, None,
                                                                                      None]
            t_r[:, j] = first_c - K1
            t_r2[:, j] = -K2
        if ck.size:
            # cluster blocks: the symmetric part of A, and zeta / omega times it in dD;
            # entries at the rounding level of A (rigid-body pairs) are left out
            Ac = 0.5 * (Aj[ck, ci] + Aj[ci, ck])
            big = np.abs(Ac) > 64 * _EPS * max(np.abs(Aj).max(), 1e-300)
            if big.any():
                cluster_terms.append((j, big, Ac[big]))
        if R.size:
            damp_rows.append(PhiR @ Cc)  # (r, m): dPhi at the damped DOFs
        if me.dC.nnz:
            Rj = _support(me.dC)
            dC_rows.append((j, Phi[Rj], me.dC.tocsr()[Rj][:, Rj].toarray()))
    h_first = batch.add("inv", t_inv)
    h_second = batch.add("inv2", t_inv2)
    if c.size:
        h_r, h_r2 = batch.add("r", t_r), batch.add("r2", t_r2)
    if cluster_terms:  # Y and X at the pairs some parameter couples
        need = np.flatnonzero(np.any([big for _, big, _ in cluster_terms], axis=0))
        where = np.full(ck.size, -1)
        where[need] = np.arange(need.size)
        nk, ni = ck[need], ci[need]
        direct = np.all(pos[nk] >= 0) and np.all(pos[ni] >= 0)
        if not direct:
            h_yk, h_xi = y_proj(np.eye(m)[nk]), x_proj(np.eye(m)[ni])
    if damp_rows:
        rows = np.vstack([PhiR, *damp_rows])
        h_yd, h_xd = y_proj(rows), x_proj(rows)
    if dC_rows:
        Pall = np.vstack([P_ for _, P_, _ in dC_rows])
        h_yc, h_xc = y_proj(Pall), x_proj(Pall)
    batch.run()
    if cluster_terms:
        if direct:
            Y_k = inv[:, None, pos[nk]] * Cm[None, :, nk]
            X_i = inv[:, pos[ni], None] * Bm[None, ni, :]
        else:
            Y_k, X_i = batch.get(h_yk), batch.get(h_xi)
        for j, big, ac in cluster_terms:
            sel = where[big]
            coef = ac[None, :] * (1.0 + s[:, None] * zeta_over_w[ci[big]][None, :])
            extra[j] -= (Y_k[:, :, sel] * coef[:, None, :]) @ X_i[:, sel]
    # the physical damping's terms, s (dPhi^T C Phi + Phi^T C dPhi + Phi^T dC Phi)
    if damp_rows:
        rr = R.size
        Yd, Xd = batch.get(h_yd), batch.get(h_xd)  # (F, n_out, (p + 1) r), (F, ., n_in)
        # (F, n_out, r) @ (r, r) @ (F, r, n_in), the parameter-free halves formed once
        CX = C_RR @ Xd[:, :rr]
        YC = Yd[:, :, :rr] @ C_RR
        for j in range(p):
            sl = slice((j + 1) * rr, (j + 2) * rr)
            extra[j] -= s[:, None, None] * (Yd[:, :, sl] @ CX + YC @ Xd[:, sl])
    if dC_rows:
        Yd, Xd = batch.get(h_yc), batch.get(h_xc)
        start = 0
        for j, P_, dC in dC_rows:
            sl = slice(start, start + P_.shape[0])
            start += P_.shape[0]
            extra[j] -= s[:, None, None] * ((Yd[:, :, sl] @ dC) @ Xd[:, sl])
    first = batch.get(h_first)  # (F, p, n_out, n_in)
    second = batch.get(h_second)  # (F, 2, p, n_out, n_in)
    out = (first - second[:, 0] - s[:, None, None, None] * second[:, 1]).transpose(1, 0, 2, 3)
    out = out + extra
    if c.size:
        out = out + (batch.get(h_r) + batch.get(h_r2)).transpose(1, 0, 2, 3)
    q = np.array([QUANTITIES.index(x) for x in model.quantities])
    return out * (s[None, :, None, None] ** q[None, None, :, None])


# --------------------------------------------------------------------------------------
# the predictor's Jacobian
# --------------------------------------------------------------------------------------
def frf_jacobian(predictor, theta: Mapping[str, float], names: Sequence[str], *,
                 additive: Mapping[str, float] | None = None,
                 cache: MacroelementCache | None = None) -> np.ndarray:
    """``dG/dp`` of :meth:`~truthbench.update.FRFPredictor.predict_vector` for relative
    changes of ``names`` (per unit scale of the additive ones), the same matrix
    :func:`~truthbench.update.finite_difference.sensitivity_matrix` approximates.

    Parameters
    ----------
    predictor : FRFPredictor
    theta : mapping
        The linearisation point.
    names : sequence of str
        Plant parameters and ``delay_s``, ``sensor_gain``.
    additive : mapping of str -> float, optional
        Parameters changed additively, with their scale (``delay_s``).
    cache : MacroelementCache, optional
        Macroelements of the plant parameters among ``names`` (reused across calls).

    Returns
    -------
    ndarray, complex, shape (N, p)
        ``N`` = the length of ``predict_vector(theta)``.

    Raises
    ------
    JacobianUnavailable
        See the module docstring.
    """
    additive = dict(additive or {})
    kinds = predictor.kinds
    names = tuple(names)
    bad = [n for n in names if kinds.get(n) not in ("plant", "appended")]
    if bad:
        raise JacobianUnavailable(f"parameters {bad} are not plant or appended parameters")
    if getattr(predictor, "_per_test", False):
        raise JacobianUnavailable("an effect depends on each test's own channels")
    plant_names = [n for n in names if kinds[n] == "plant"]
    if any(n in additive for n in plant_names):
        raise JacobianUnavailable("plant parameters updated additively")
    hw = predictor.hardware(theta)
    if hw.loops:
        raise JacobianUnavailable("a closed loop in the model")
    model = hw.model
    if plant_names:
        if cache is None or cache.names != tuple(plant_names):
            cache = MacroelementCache(lambda th: predictor.hardware(th).model, plant_names)
        macros = cache.at(theta, model)
        if len(hw.modes.omega_rad_s) != model.n_dofs and not (
                hw.reduced and predictor.mode_tolerance == 0):
            raise JacobianUnavailable(f"the modal basis has {len(hw.modes.omega_rad_s)} of "
                                      f"{model.n_dofs} modes; the analytic Jacobian needs "
                                      f"all of them")
        model, modes, macros = channel_subspace(model, hw.modes, macros,
                                                len(hw.actuators))
    n_act = len(hw.actuators)
    from truthbench.effects.hardware import _filter_gains

    groups: dict[float, list[int]] = {}
    for k, t in enumerate(predictor.tests):
        groups.setdefault(float(t.decay_rad_s), []).append(k)
    blocks: list = [None] * len(predictor.tests)
    for decay, members in groups.items():
        f_all = np.unique(np.concatenate([predictor.tests[k].freq_hz for k in members]))
        s = 2j * np.pi * f_all + decay if decay else 2j * np.pi * f_all
        # H and its derivatives for all channels, after filters, gain and delay
        factor = np.ones((f_all.size, len(hw.sensors), n_act), complex)
        if hw.input_filters:
            factor = factor * _filter_gains(hw.input_filters, s, n_act).T[:, None, :]
        if hw.output_filters:
            factor = factor * _filter_gains(hw.output_filters, s, len(hw.sensors)).T[:, :, None]
        factor = factor * (hw.bias_gain * np.exp(-s * hw.delay_s))[:, None, None]
        dH = (structural_frf_jacobian(model, modes, macros, s, n_act) * factor[None]
              if plant_names else None)
        need_G = any(kinds[n] == "appended" for n in names)
        G = hw.frf(f_all, decay_rad_s=decay) if need_G else None
        for k in members:
            t = predictor.tests[k]
            lines = np.searchsorted(f_all, t.freq_hz)
            rows = [predictor._sensors.index(x) for x in t.sensors]
            cols = [predictor._actuators.index(x) for x in t.actuators]
            sel = np.ix_(lines, rows, cols)
            cols_out = []
            jp = 0
            for name in names:
                if kinds[name] == "plant":
                    cols_out.append(dH[jp][sel].ravel())
                    jp += 1
                elif name == "delay_s":
                    scale = additive.get(name)
                    g = G[sel]
                    sk = s[lines][:, None, None]
                    d = -sk * g * (scale if scale is not None else float(theta[name]))
                    cols_out.append(d.ravel())
                elif name == "sensor_gain":
                    g = G[sel]
                    if name in additive:
                        g = g * additive[name] / float(theta[name])
                    cols_out.append(g.ravel())
                else:  # pragma: no cover - kinds filtered above
                    raise JacobianUnavailable(f"no derivative for {name!r}")
            blocks[k] = np.column_stack(cols_out)
    return np.vstack(blocks)
