"""Ranking candidate sensor DOFs (Section 10.3, Eq. 10.45; :ref:`method-placement`).

Two criteria the chapter names:

**Shape sensitivity** (:func:`rank_sensors_by_sensitivity`). Eq. 10.45 read in
reverse, ``vec dPhi = S [alpha; beta]``: sensors go where the mode shapes move most for
the expected error sources. With eigenvector sensitivities ``dphi[d, i, j] =
d phi_i(d) / d theta_j`` and expected parameter standard deviations ``sigma_j``, the
scaled sensitivity ``s[d, i, j] = dphi[d, i, j] sigma_j`` is the first-order shape change
(in shape units) at DOF ``d`` of mode ``i`` for a one-sigma error of parameter ``j``, and

    score_d = sqrt( sum_{i in modes} sum_j s[d, i, j]^2 ).

Ranking by that score alone picks neighbouring DOFs that see the same parameter
combination. The selection (:attr:`SensorRanking.selected`) is therefore a **greedy
forward D-optimal** design: the rows ``s[d]`` (one per target mode) of a chosen set
give the Fisher information ``F = sum_{d in set} s[d]^T s[d]`` (p x p) of the parameters
from shape data with unit noise; each step adds the DOF with the largest
``log det(F + eps I + s[d]^T s[d]) - log det(F + eps I)``
``= log det(I + s[d] (F + eps I)^-1 s[d]^T)``. The small ridge
``eps = ridge * trace(F_all) / p`` makes the first steps, while ``F`` has rank below
``p``, well defined (they then maximise the new information orthogonal to what is
chosen). This is the criterion of Kammer's Effective Independence (max det of the
information matrix), run forward on the parameter sensitivities instead of backward on
the target shapes.

The eigenvector sensitivities can come from anywhere (e.g. the Fox-Kapoor modal sum of
the update room); :func:`shape_sensitivities` is a self-contained fallback: central
finite differences of :func:`truthbench.model.solve_modes` on ``M(theta), K(theta)``.

**Observability gramian** (:func:`rank_sensors_by_gramian`). For the modal first-order
form ``x = [eta; eta']``, ``A = [[0, I], [-Omega^2, -Xi]]`` (as
:func:`truthbench.model.modal_system` gives it) and one output row ``c_d`` per
candidate sensor, the observability gramian ``W_d`` solves
``A^T W + W A = -c_d^T c_d``. To compare the two states of a mode in one unit it is
taken in Gawronski's scaled modal coordinates ``z = [Omega eta; eta']`` (both
velocity-like), ``W'_d = T^-1 W_d T^-1``, ``T = diag(Omega, I)``; the contribution of
mode ``i`` is ``G[d, i] = W'_d[i, i] + W'_d[m+i, m+i]``. For diagonal ``Xi`` the diagonal
blocks decouple exactly and a mode with output row ``(a, b)`` on ``(eta_i, eta'_i)`` gives

    G = (a^2 / omega^2 + b^2) / (2 zeta omega) + zeta a^2 / omega^3 - a b / omega^2,

i.e. ``phi_d^2 / (2 zeta omega)`` exactly for a velocity sensor and
``phi_d^2 (1/(2 zeta omega^3) + zeta/omega^3)`` for a displacement sensor.

Scaling (``normalize``): raw contributions differ between modes by orders of magnitude
(``1 / (zeta omega^3)``), so by default each target mode's contributions are divided by
their sum over the candidates: ``share[d, i] = G[d, i] / sum_d' G[d', i]``, the fraction
of mode ``i``'s observability (over all candidates) that sensor ``d`` holds, and
``score_d = sum_i w_i share[d, i] / sum_i w_i`` (mode weights ``w_i``, default equal);
scores then sum to 1 over the candidates. Sensors of different kinds or units
(translation in m, rotation in rad, strain) are made comparable by ``sensor_noise``:
each row ``c_d`` is divided by that sensor's noise standard deviation (in its own units),
so the gramian is a signal-to-noise energy. ``normalize="none"`` keeps the raw sum
``sum_i w_i G[d, i]`` (units of the outputs squared times seconds, over the squared
modal velocity).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

from truthbench._validation import readonly
from truthbench.errors import ModelError


@dataclass(frozen=True)
class SensorRanking:
    """Scores of candidate sensor DOFs.

    Attributes
    ----------
    labels : tuple of str, length n_candidates
    scores : ndarray, shape (n_candidates,)
        Higher is better (units: see the criterion).
    order : ndarray of int, shape (n_candidates,)
        Candidate indices by descending score (ties in candidate order).
    selected : ndarray of int, shape (n_select,), or None
        A set chosen to avoid redundancy (greedy D-optimal for the sensitivity
        criterion), in selection order; ``None`` when the criterion has no such step.
    contributions : ndarray, shape (n_candidates, n_target_modes)
        Per-mode part of the score (squared scaled shape change summed over the
        parameters, or the gramian share of each mode).
    criterion : str
        ``"sensitivity"`` or ``"gramian"``.
    """

    labels: tuple[str, ...]
    scores: np.ndarray
    order: np.ndarray
    selected: np.ndarray | None
    contributions: np.ndarray
    criterion: str

    @property
    def ranked_labels(self) -> tuple[str, ...]:
        """Labels by descending score."""
        return tuple(self.labels[i] for i in self.order)

    @property
    def selected_labels(self) -> tuple[str, ...] | None:
        """Labels of :attr:`selected`, in selection order."""
        return None if self.selected is None else tuple(self.labels[i] for i in self.selected)

    def to_pandas(self):
        """One row per candidate, best first.

        Returns
        -------
        pandas.DataFrame
            Index ``dof``; columns ``score``, ``rank`` (1 = best), ``selection_step``
            (1-based position in :attr:`selected`, 0 if not selected or no selection).
        """
        import pandas as pd

        n = len(self.labels)
        rank = np.empty(n, dtype=int)
        rank[self.order] = np.arange(1, n + 1)
        step = np.zeros(n, dtype=int)
        if self.selected is not None:
            step[self.selected] = np.arange(1, len(self.selected) + 1)
        df = pd.DataFrame({"score": self.scores, "rank": rank, "selection_step": step},
                          index=pd.Index(self.labels, name="dof"))
        return df.iloc[self.order]


def _labels(labels, n, name="labels"):
    if labels is None:
        return tuple(f"dof{i}" for i in range(n))
    out = tuple(str(x) for x in labels)
    if len(out) != n:
        raise ValueError(f"The '{name}' parameter must hold {n} labels (one per candidate); "
                         f"got {len(out)}.")
    return out


def _mode_index(modes, n_modes) -> np.ndarray:
    if modes is None:
        return np.arange(n_modes)
    idx = np.atleast_1d(np.asarray(modes))
    if idx.dtype == bool:
        if idx.shape != (n_modes,):
            raise ValueError(f"The 'modes' mask must have length {n_modes}; got {idx.shape}.")
        idx = np.flatnonzero(idx)
    if idx.size == 0 or idx.dtype.kind not in "iu" or idx.min() < 0 or idx.max() >= n_modes:
        raise ValueError(f"The 'modes' parameter must select mode indices in 0..{n_modes - 1}; "
                         f"got {modes!r}.")
    return idx.astype(int)


def _mode_weights(mode_weights, n) -> np.ndarray:
    if mode_weights is None:
        return np.ones(n)
    w = np.asarray(mode_weights, dtype=float).reshape(-1)
    if w.shape != (n,) or not np.all(np.isfinite(w)) or np.any(w < 0) or w.sum() <= 0:
        raise ValueError(f"The 'mode_weights' parameter must hold {n} non-negative finite "
                         f"values (one per target mode), not all zero; got {mode_weights!r}.")
    return w


def _order(scores) -> np.ndarray:
    return np.argsort(-scores, kind="stable")


def greedy_d_optimal(rows, n_select: int, *, ridge: float = 1e-9) -> np.ndarray:
    """Greedy forward D-optimal selection of candidates with blocks of rows.

    Parameters
    ----------
    rows : array_like, shape (n_candidates, r, p)
        Each candidate's information rows (``r`` rows over ``p`` unknowns).
    n_select : int
        How many to choose, ``1 <= n_select <= n_candidates``.
    ridge : float
        Relative ridge (see the module docstring), > 0.

    Returns
    -------
    ndarray of int, shape (n_select,)
        Chosen candidates in selection order.
    """
    R = np.asarray(rows, dtype=float)
    if R.ndim != 3:
        raise ValueError(f"The 'rows' parameter must have shape (n_candidates, r, p); "
                         f"got shape {R.shape}.")
    n, _, p = R.shape
    if not 1 <= int(n_select) <= n:
        raise ValueError(f"The 'n_select' parameter must lie in 1..{n}; got {n_select!r}.")
    if not ridge > 0:
        raise ValueError(f"The 'ridge' parameter must be positive; got {ridge!r}.")
    total = np.einsum("dri,dri->", R, R)
    if total <= 0:
        raise ValueError("All sensitivity rows are zero: no candidate sees the parameters.")
    F = np.eye(p) * (ridge * total / p)
    chosen: list[int] = []
    free = np.ones(n, dtype=bool)
    for _ in range(int(n_select)):
        Finv = np.linalg.inv(F)
        G = np.einsum("dri,ij,dsj->drs", R, Finv, R)  # s[d] F^-1 s[d]^T
        G = G + np.eye(R.shape[1])[None]
        _, logdet = np.linalg.slogdet(G)
        logdet = np.where(free, logdet, -np.inf)
        d = int(np.argmax(logdet))
        chosen.append(d)
        free[d] = False
        F = F + R[d].T @ R[d]
    return np.array(chosen, dtype=int)


def rank_sensors_by_sensitivity(
    dphi,
    sigma,
    *,
    labels: Sequence[str] | None = None,
    modes=None,
    mode_weights=None,
    n_select: int | None = None,
    ridge: float = 1e-9,
) -> SensorRanking:
    """Rank candidate DOFs by how much the mode shapes move for the expected errors.

    Parameters
    ----------
    dphi : array_like, shape (n_dof, n_modes, p)
        Eigenvector sensitivities ``d phi_i(d) / d theta_j`` (shape units per parameter
        unit), e.g. ``shape_sensitivities(...).dphi`` restricted to candidate rows.
    sigma : array_like, shape (p,)
        Expected standard deviation of each parameter, in its units (>= 0).
    labels : sequence of str, length n_dof, optional
    modes : sequence of int or bool mask, optional
        Target modes (indices along axis 1 of ``dphi``); default all.
    mode_weights : array_like, shape (n_target,), optional
        Weight of each target mode's squared shape change (default 1).
    n_select : int, optional
        Size of the greedy D-optimal selection; default ``min(n_dof, p)`` (the number
        that can make the information matrix full rank with one mode) but at least 1.
    ridge : float
        Relative ridge of the greedy selection.

    Returns
    -------
    SensorRanking
        ``scores`` in shape units; ``contributions[d, i] = sum_j w_i s[d, i, j]^2``.
    """
    D = np.array(dphi, dtype=float, copy=True)
    if D.ndim != 3:
        raise ValueError(f"The 'dphi' parameter must have shape (n_dof, n_modes, p); "
                         f"got shape {D.shape}.")
    n, m, p = D.shape
    if not np.all(np.isfinite(D)):
        raise ValueError("The 'dphi' parameter must be finite; got NaN or infinite values.")
    s = np.array(sigma, dtype=float, copy=True).reshape(-1)
    if s.shape != (p,) or not np.all(np.isfinite(s)) or np.any(s < 0):
        raise ValueError(f"The 'sigma' parameter must hold {p} non-negative finite standard "
                         f"deviations (one per parameter, axis 2 of 'dphi'); "
                         f"got {sigma!r}.")
    idx = _mode_index(modes, m)
    w = _mode_weights(mode_weights, idx.size)
    lab = _labels(labels, n)
    S = D[:, idx, :] * s[None, None, :] * np.sqrt(w)[None, :, None]
    contrib = np.einsum("dij,dij->di", S, S)
    scores = np.sqrt(contrib.sum(axis=1))
    k = max(1, min(n, p)) if n_select is None else int(n_select)
    sel = greedy_d_optimal(S, k, ridge=ridge)
    return SensorRanking(lab, readonly(scores, float), readonly(_order(scores)),
                         readonly(sel), readonly(contrib, float), "sensitivity")


@dataclass(frozen=True)
class ShapeSensitivities:
    """Finite-difference eigen-sensitivities of ``K(theta) phi = omega^2 M(theta) phi``.

    Attributes
    ----------
    dphi : ndarray, shape (n_dof, n_target, p)
        ``d phi_i / d theta_j`` of the mass-normalised shapes (shape units per parameter
        unit).
    domega_rad_s : ndarray, shape (n_target, p)
        ``d omega_i / d theta_j``, rad/s per parameter unit.
    mode_indices : ndarray of int, shape (n_target,)
        Indices of the target modes in the nominal eigensolution.
    omega_rad_s : ndarray, shape (n_target,)
        Nominal natural frequencies, rad/s.
    shapes : ndarray, shape (n_dof, n_target)
        Nominal mass-normalised shapes.
    steps : ndarray, shape (p,)
        The central-difference half steps used, in parameter units.
    """

    dphi: np.ndarray
    domega_rad_s: np.ndarray
    mode_indices: np.ndarray
    omega_rad_s: np.ndarray
    shapes: np.ndarray
    steps: np.ndarray


def shape_sensitivities(
    build_mk: Callable[[np.ndarray], tuple],
    theta_0,
    *,
    modes=None,
    n_modes: int | None = None,
    rel_step: float = 1e-4,
    abs_step=None,
    separation_tol: float = 1e-6,
) -> ShapeSensitivities:
    """Eigenvector and frequency sensitivities by central finite differences.

    Each parameter is stepped by ``+-h_j`` (``h_j = rel_step |theta_0j|``, or
    ``abs_step[j]`` where ``theta_0j = 0`` or when given), the modes are re-solved with
    :func:`truthbench.model.solve_modes`, each target mode is tracked to the perturbed
    mode of largest ``|phi_i^T M_0 phi~|`` (so that crossings do not swap modes) and its
    sign aligned with the nominal shape, and ``(phi(+h) - phi(-h)) / 2h`` is returned.
    The error is ``O(h^2)``; with ``rel_step = 1e-4`` it is about ``1e-8`` relative.

    Parameters
    ----------
    build_mk : callable
        ``build_mk(theta) -> (M, K)``, dense or sparse ``(n_dof, n_dof)``; must not keep
        or change ``theta``.
    theta_0 : array_like, shape (p,)
        Nominal parameters.
    modes : sequence of int, optional
        Target mode indices in the nominal eigensolution; default every elastic
        (non-rigid) mode among the ``n_modes`` computed.
    n_modes : int, optional
        Number of lowest modes to solve (default all).
    rel_step : float
        Relative half step, > 0.
    abs_step : float or array_like, shape (p,), optional
        Absolute half steps (parameter units); required for parameters whose nominal
        value is 0.
    separation_tol : float
        A target eigenvalue within ``separation_tol * omega_i^2`` of another is
        repeated: its eigenvector, and so its derivative, is not unique.

    Returns
    -------
    ShapeSensitivities

    Raises
    ------
    ModelError
        A repeated target mode, a mode that cannot be tracked, a zero step.
    """
    from truthbench.model import solve_modes

    t0 = np.array(theta_0, dtype=float, copy=True).reshape(-1)
    p = t0.size
    if p == 0 or not np.all(np.isfinite(t0)):
        raise ValueError(f"The 'theta_0' parameter must be a non-empty finite vector; "
                         f"got {theta_0!r}.")
    if not rel_step > 0:
        raise ValueError(f"The 'rel_step' parameter must be positive; got {rel_step!r}.")
    h = rel_step * np.abs(t0)
    if abs_step is not None:
        a = np.broadcast_to(np.asarray(abs_step, dtype=float), (p,))
        h = np.where(np.isfinite(a) & (a > 0), a, h)
    if np.any(h <= 0):
        bad = np.flatnonzero(h <= 0).tolist()
        raise ModelError(f"parameters {bad} are 0 at theta_0, so a relative step is 0; give "
                         f"'abs_step' (a positive step in the parameter's units) for them")
    M0, K0 = build_mk(t0.copy())
    nom = solve_modes(M0, K0, n_modes)
    lam = nom.omega_rad_s**2
    if modes is None:
        idx = np.flatnonzero(~nom.rigid)
        if idx.size == 0:
            raise ModelError("the nominal model has no elastic mode among those solved")
    else:
        idx = _mode_index(modes, nom.n_modes)
    for i in idx:
        others = np.delete(lam, i)
        scale = max(lam[i], 1e-300)
        if others.size and np.min(np.abs(others - lam[i])) <= separation_tol * scale:
            raise ModelError(
                f"mode {int(i)} (omega {nom.omega_rad_s[i]:.6g} rad/s) is repeated; its "
                f"eigenvector derivative is not unique. Exclude it from 'modes' or break the "
                f"symmetry of the model")
    Mop = M0.tocsr() if hasattr(M0, "tocsr") else np.asarray(M0, dtype=float)
    MPhi0 = Mop @ nom.shapes[:, idx]  # (n, n_target)
    n = nom.shapes.shape[0]
    dphi = np.empty((n, idx.size, p))
    dom = np.empty((idx.size, p))

    def tracked(theta):
        M, K = build_mk(theta)
        md = solve_modes(M, K, n_modes)
        proj = MPhi0.T @ md.shapes  # (n_target, n_solved)
        k = np.argmax(np.abs(proj), axis=1)
        c = proj[np.arange(idx.size), k]
        if np.any(np.abs(c) < 0.5) or len(set(k.tolist())) != idx.size:
            raise ModelError("a target mode could not be tracked across the parameter step "
                             "(|phi^T M0 phi~| < 0.5); reduce 'rel_step'")
        return md.shapes[:, k] * np.sign(c)[None, :], md.omega_rad_s[k]

    for j in range(p):
        tp, tm = t0.copy(), t0.copy()
        tp[j] += h[j]
        tm[j] -= h[j]
        Pp, wp = tracked(tp)
        Pm, wm = tracked(tm)
        dphi[:, :, j] = (Pp - Pm) / (2 * h[j])
        dom[:, j] = (wp - wm) / (2 * h[j])
    return ShapeSensitivities(
        dphi=readonly(dphi, float), domega_rad_s=readonly(dom, float),
        mode_indices=readonly(idx, int), omega_rad_s=readonly(nom.omega_rad_s[idx], float),
        shapes=readonly(nom.shapes[:, idx], float), steps=readonly(h, float))


# ---- observability gramian ------------------------------------------------------------

def observability_gramian(A, C) -> np.ndarray:
    """Observability gramian ``W = int_0^inf e^{A^T t} C^T C e^{A t} dt``.

    Solves ``A^T W + W A = -C^T C`` with ``scipy.linalg.solve_continuous_lyapunov``.

    Parameters
    ----------
    A : array_like, shape (n, n)
        Hurwitz (every eigenvalue with negative real part).
    C : array_like, shape (n_out, n)

    Returns
    -------
    ndarray, shape (n, n), symmetric
    """
    A = np.asarray(A, dtype=float)
    C = np.atleast_2d(np.asarray(C, dtype=float))
    if A.ndim != 2 or A.shape[0] != A.shape[1]:
        raise ValueError(f"The 'A' parameter must be square; got shape {A.shape}.")
    if C.shape[1] != A.shape[0]:
        raise ValueError(f"The 'C' parameter has {C.shape[1]} columns; expected {A.shape[0]} "
                         f"(the order of A).")
    ev = np.linalg.eigvals(A)
    if np.any(ev.real >= 0):
        raise ValueError(f"The 'A' parameter must be stable (all eigenvalues with negative "
                         f"real part) for the gramian to exist; largest real part "
                         f"{ev.real.max():.3g}. Drop rigid-body or undamped modes.")
    W = sla.solve_continuous_lyapunov(A.T, -C.T @ C)
    return 0.5 * (W + W.T)


def modal_candidate_system(omega_rad_s, damping_ratio, shapes, quantity: str = "displacement"):
    """Modal first-order form and one output row per candidate DOF.

    Parameters
    ----------
    omega_rad_s : array_like, shape (m,)
        Natural frequencies, rad/s (> 0).
    damping_ratio : array_like, shape (m,) or scalar
        Modal damping ratios (> 0 for a stable system).
    shapes : array_like, shape (n_candidates, m)
        Mass-normalised shapes at the candidate DOFs.
    quantity : {"displacement", "velocity", "acceleration"}
        What each candidate sensor measures.

    Returns
    -------
    A : ndarray, shape (2m, 2m)
        ``[[0, I], [-Omega^2, -2 Z Omega]]`` (states ``[eta; eta']``, as
        :func:`truthbench.model.modal_system`).
    C : ndarray, shape (n_candidates, 2m)
        Output rows (acceleration rows drop the feed-through, which the gramian ignores).
    """
    w = np.asarray(omega_rad_s, dtype=float).reshape(-1)
    m = w.size
    z = np.broadcast_to(np.asarray(damping_ratio, dtype=float), (m,))
    P = np.atleast_2d(np.asarray(shapes, dtype=float))
    if P.shape[1] != m:
        raise ValueError(f"The 'shapes' parameter must have {m} columns (one per mode); "
                         f"got shape {P.shape}.")
    A = np.block([[np.zeros((m, m)), np.eye(m)], [-np.diag(w**2), -np.diag(2 * z * w)]])
    if quantity == "displacement":
        C = np.hstack([P, np.zeros_like(P)])
    elif quantity == "velocity":
        C = np.hstack([np.zeros_like(P), P])
    elif quantity == "acceleration":
        C = np.hstack([-P * w**2, -P * (2 * z * w)])
    else:
        raise ValueError(f"The 'quantity' parameter must be 'displacement', 'velocity' or "
                         f"'acceleration'; got {quantity!r} instead.")
    return A, C


def _split_modal(A):
    A = np.asarray(A, dtype=float)
    if A.ndim != 2 or A.shape[0] != A.shape[1] or A.shape[0] % 2:
        raise ValueError(f"The 'A' parameter must be a square modal first-order matrix of "
                         f"even order 2m; got shape {A.shape}.")
    m = A.shape[0] // 2
    ok = (np.allclose(A[:m, :m], 0.0) and np.allclose(A[:m, m:], np.eye(m)))
    K = -A[m:, :m]
    if not ok or not np.allclose(K, np.diag(np.diag(K)), atol=1e-12 * max(1.0, np.abs(K).max())):
        raise ValueError("The 'A' parameter must be in the modal first-order form "
                         "[[0, I], [-Omega^2, -Xi]] with diagonal Omega^2 (as "
                         "truthbench.model.modal_system or modal_candidate_system give it).")
    return m, np.sqrt(np.clip(np.diag(K), 0.0, None)), -A[m:, m:]


def modal_gramian_contributions(A, C, *, modes=None, method: str = "auto") -> np.ndarray:
    """Per-mode observability ``G[d, i]`` of each candidate row (module docstring).

    Parameters
    ----------
    A : array_like, shape (2m, 2m)
        Modal first-order form.
    C : array_like, shape (n_candidates, 2m)
        One output row per candidate sensor.
    modes : sequence of int or bool mask, optional
        Target modes (default all).
    method : {"auto", "modal", "lyapunov"}
        ``"modal"``: the exact closed form per mode (needs diagonal ``Xi``; only the
        target modes must be damped). ``"lyapunov"``: one
        ``solve_continuous_lyapunov`` per candidate on the whole ``A`` (any ``Xi``;
        ``A`` must be stable). ``"auto"``: modal when ``Xi`` is diagonal.

    Returns
    -------
    ndarray, shape (n_candidates, n_target)
        In Gawronski's scaled coordinates ``[Omega eta; eta']``.
    """
    m, w, Xi = _split_modal(A)
    C = np.atleast_2d(np.asarray(C, dtype=float))
    if C.shape[1] != 2 * m:
        raise ValueError(f"The 'C' parameter has {C.shape[1]} columns; expected {2 * m} "
                         f"(the order of A).")
    idx = _mode_index(modes, m)
    diag = np.allclose(Xi, np.diag(np.diag(Xi)), atol=1e-12 * max(1.0, np.abs(Xi).max()))
    if method not in ("auto", "modal", "lyapunov"):
        raise ValueError(f"The 'method' parameter must be 'auto', 'modal' or 'lyapunov'; "
                         f"got {method!r} instead.")
    if method == "modal" and not diag:
        raise ValueError("method='modal' needs a diagonal modal damping matrix Xi (decoupled "
                         "modes); use method='lyapunov' for non-proportional damping.")
    use_modal = method == "modal" or (method == "auto" and diag)
    wi = w[idx]
    if np.any(wi <= 0):
        raise ValueError(f"target modes {idx[wi <= 0].tolist()} have zero frequency "
                         f"(rigid-body); their gramian does not exist. Exclude them with "
                         f"'modes'.")
    if use_modal:
        zi = np.diag(Xi)[idx] / (2 * wi)
        if np.any(zi <= 0):
            raise ValueError(f"target modes {idx[zi <= 0].tolist()} are undamped; their "
                             f"gramian does not exist.")
        a, b = C[:, idx], C[:, m + idx]
        return ((a**2 / wi**2 + b**2) / (2 * zi * wi) + zi * a**2 / wi**3
                - a * b / wi**2)
    ev = np.linalg.eigvals(np.asarray(A, dtype=float))
    if np.any(ev.real >= 0):
        raise ValueError("The 'A' parameter must be stable for method='lyapunov' (every "
                         "mode damped, no rigid-body mode); drop those modes from A and C.")
    Tinv = np.concatenate([1.0 / w, np.ones(m)])
    out = np.empty((C.shape[0], idx.size))
    for d in range(C.shape[0]):
        W = observability_gramian(A, C[d:d + 1])
        dW = np.diag(W) * Tinv**2
        out[d] = dW[idx] + dW[m + idx]
    return out


def rank_sensors_by_gramian(
    A,
    C,
    *,
    labels: Sequence[str] | None = None,
    modes=None,
    mode_weights=None,
    sensor_noise=None,
    normalize: str = "mode",
    method: str = "auto",
) -> SensorRanking:
    """Rank candidate sensors by their share of the scaled observability gramian.

    Parameters
    ----------
    A : array_like, shape (2m, 2m)
        Modal first-order form ``[[0, I], [-Omega^2, -Xi]]``
        (:func:`truthbench.model.modal_system` or :func:`modal_candidate_system`).
    C : array_like, shape (n_candidates, 2m)
        One output row per candidate sensor.
    labels : sequence of str, optional
    modes : sequence of int or bool mask, optional
        Target modes (default all; rigid-body modes must be excluded).
    mode_weights : array_like, shape (n_target,), optional
    sensor_noise : array_like, shape (n_candidates,), optional
        Noise standard deviation of each candidate sensor in its own units (> 0); rows
        are divided by it. Default 1 (all candidates of one kind).
    normalize : {"mode", "none"}
        ``"mode"``: each target mode's contributions are divided by their sum over the
        candidates (scores sum to 1); ``"none"``: raw gramian contributions.
    method : {"auto", "modal", "lyapunov"}
        See :func:`modal_gramian_contributions`.

    Returns
    -------
    SensorRanking
        ``selected`` is None (rank by score); ``contributions`` are the (normalised)
        per-mode parts.
    """
    C = np.array(np.atleast_2d(C), dtype=float, copy=True)
    n = C.shape[0]
    if not np.all(np.isfinite(C)):
        raise ValueError("The 'C' parameter must be finite; got NaN or infinite values.")
    if sensor_noise is not None:
        s = np.broadcast_to(np.asarray(sensor_noise, dtype=float), (n,))
        if not np.all(np.isfinite(s)) or np.any(s <= 0):
            raise ValueError(f"The 'sensor_noise' parameter must hold {n} positive standard "
                             f"deviations; got {sensor_noise!r}.")
        C = C / s[:, None]
    if normalize not in ("mode", "none"):
        raise ValueError(f"The 'normalize' parameter must be 'mode' or 'none'; "
                         f"got {normalize!r} instead.")
    G = modal_gramian_contributions(A, C, modes=modes, method=method)
    w = _mode_weights(mode_weights, G.shape[1])
    if normalize == "mode":
        tot = G.sum(axis=0)
        if np.any(tot <= 0):
            raise ValueError(f"target modes {np.flatnonzero(tot <= 0).tolist()} are seen by no "
                             f"candidate sensor (all at nodes); drop them from 'modes'.")
        G = G / tot[None, :]
        scores = G @ w / w.sum()
    else:
        scores = G @ w
    return SensorRanking(_labels(labels, n), readonly(scores, float),
                         readonly(_order(scores)), None, readonly(G, float), "gramian")
