"""Finite-difference model updating in the frequency domain (Section 10.2.1,
Eq. 10.12-10.21; :ref:`method-finite-difference`).

The data are FRFs ``G_D`` (any stacking of tests, frequency lines and SISO pairs); the
model predicts the same array ``G_M(theta)``. With parameters written relative to their
starting values, ``theta_k = theta_0k (1 + p_k)``, the sensitivity matrix ``S`` stacks
the finite-difference columns ``dG/dp_k`` over all lines and pairs, real and imaginary
parts one above the other, so that ``S dp = vec(G_D - G_M)`` has a real solution. It is
solved by a (weighted) least-squares pseudoinverse and iterated: the model is
re-evaluated at the new parameters and the sensitivities recomputed, until the
relative parameter change stops. From the second iteration on, the step also carries
the Hessian term Gauss-Newton leaves out (the residuals' curvature), estimated from how
the sensitivities change along the steps taken (the structured secant update of
Dennis, Gay and Welsch, :func:`secant_curvature`): a model that cannot fit the data
exactly leaves a residual at the minimum that makes Gauss-Newton converge only linearly
(0.4 per iteration on the hub beam), and the secant makes it superlinear.

Identifiability is checked at every iteration on the weighted ``S`` with its columns
scaled to unit norm (so that a parameter with a small but clean effect is not mistaken
for an unidentifiable one): a zero column means a parameter the data does not see, and a
relative singular value below ``rcond`` means a combination of parameters that does not
change the FRFs (Table 10.2: a change in t equals equal changes in E and rho).
:class:`~truthbench.errors.IdentifiabilityError` names the parameters. The reported
singular values and condition number are those of the unscaled weighted ``S``.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, ClassVar

import numpy as np
import scipy.linalg as sla

from truthbench.presentation import Presentable, figure_axes
from truthbench.settings import Configurable, setting
from truthbench.update.identifiability import check_identifiable, check_overdetermined

if TYPE_CHECKING:
    from truthbench.update.registry import UpdateProblem


@dataclass(frozen=True)
class UpdateResult(Presentable):
    """Outcome of a model update.

    Tables (:meth:`to_pandas`): ``"parameters"`` one row per parameter (start, result,
    change), ``"history"`` one row per iteration (cost and every parameter),
    ``"correlation"`` the parameter correlation matrix. Figures (:meth:`plot`):
    ``"history"`` the parameters' relative change and the cost against the iteration,
    ``"correlation"`` the correlation matrix.

    Attributes
    ----------
    names : tuple of str
        Updated parameters.
    initial, values : ndarray, shape (p,)
        Starting and final parameter values (in the parameters' own units).
    history : ndarray, shape (n_iter + 1, p)
        Parameter values at the start and after every iteration.
    cost_history : ndarray, shape (n_iter + 1,)
        Weighted cost ``J = ||W (G_D - G_M)||^2`` at each entry of ``history``.
    singular_values : ndarray, shape (p,)
        Singular values of the weighted sensitivity matrix at the final iterate.
    condition_number : float
        Their ratio, largest over smallest.
    correlation : ndarray, shape (p, p)
        Parameter correlation matrix from ``(S^T S)^-1`` (how far the estimates move
        together; off-diagonal values near +-1 mean poorly separated parameters).
    converged : bool
    method : str
    """

    TABLES = ("parameters", "history", "correlation")
    PLOTS = ("history", "correlation")

    names: tuple[str, ...]
    initial: np.ndarray
    values: np.ndarray
    history: np.ndarray
    cost_history: np.ndarray
    singular_values: np.ndarray
    condition_number: float
    correlation: np.ndarray
    converged: bool
    method: str = "finite_difference"

    @property
    def n_iterations(self) -> int:
        return len(self.history) - 1

    def _changes(self, values: np.ndarray) -> np.ndarray:
        """``values / initial - 1`` per parameter, or ``values - initial`` (the
        parameter's unit) where it started at 0 (an additive parameter)."""
        x0 = np.asarray(self.initial, dtype=float)
        zero = x0 == 0
        return np.where(zero, values - x0, values / np.where(zero, 1.0, x0) - 1.0)

    def _table_parameters(self):
        """One row per parameter: parameter, initial, value, change (``value / initial -
        1``, or ``value - initial`` for a parameter that started at 0), method."""
        import pandas as pd

        return pd.DataFrame({"parameter": list(self.names), "initial": self.initial,
                             "value": self.values, "change": self._changes(self.values),
                             "method": self.method})

    def _table_history(self):
        """One row per entry of ``history`` (0: the start): iteration, cost and every
        parameter's value."""
        import pandas as pd

        df = pd.DataFrame(np.asarray(self.history), columns=list(self.names))
        df.insert(0, "cost", self.cost_history)
        df.insert(0, "iteration", np.arange(len(self.history)))
        return df

    def _table_correlation(self):
        """The parameter correlation matrix, parameters as index and columns."""
        import pandas as pd

        return pd.DataFrame(self.correlation, index=list(self.names),
                            columns=list(self.names))

    def _plot_history(self, ax):
        """Every parameter's change from its start and the cost, against the
        iteration."""
        fig, (top, bottom) = figure_axes(ax, 2, sharex=True, figsize=(7, 5))
        it = np.arange(len(self.history))
        changes = self._changes(np.asarray(self.history))
        for k, name in enumerate(self.names):
            top.plot(it, changes[:, k], "o-", ms=3, label=name)
        top.set_ylabel("change from start")
        top.legend(fontsize="small")
        bottom.semilogy(it, self.cost_history, "o-", ms=3, color="0.3")
        bottom.set_ylabel("cost")
        bottom.set_xlabel("iteration")
        top.set_title(f"{self.method}: {'converged' if self.converged else 'not converged'}"
                      f" in {self.n_iterations} iterations", fontsize="medium")
        fig.tight_layout()
        return fig

    def _plot_correlation(self, ax):
        """The parameter correlation matrix (-1 to 1)."""
        fig, (ax,) = figure_axes(ax, figsize=(5, 4))
        image = ax.imshow(self.correlation, vmin=-1.0, vmax=1.0, cmap="RdBu_r")
        ticks = np.arange(len(self.names))
        ax.set_xticks(ticks, self.names, rotation=45, ha="right")
        ax.set_yticks(ticks, self.names)
        fig.colorbar(image, ax=ax, label="correlation")
        fig.tight_layout()
        return fig

    def as_dict(self) -> dict[str, float]:
        return dict(zip(self.names, self.values.tolist(), strict=True))


@dataclass(frozen=True, kw_only=True)
class IterationSettings(Configurable):
    """The settings every iterated updater shares, declared once: the campaign's
    ``[update]`` table gives each of them to every updater that runs."""

    needs: ClassVar[frozenset[str]] = frozenset()

    max_iterations: int = setting(30, "Largest number of parameter updates.", low=1)
    tolerance: float = setting(
        1e-7, "Convergence: the update stops when an iteration changes no parameter by "
        "more than this (a relative change, the step in log-parameters; additive "
        "parameters in units of their scale).", low=0, low_open=True)
    rcond: float = setting(
        1e-4, "Relative singular value of the column-scaled, weighted sensitivity matrix "
        "below which parameters are declared inseparable (at 1e-4 the data's noise would "
        "be amplified ten thousand times along that direction).", low=0, low_open=True,
        high=1, high_open=True)
    max_step: float = setting(
        0.5, "Trust region: the largest change of any log-parameter in one iteration "
        "(0.5 is a factor of 1.65).", low=0, low_open=True)

    def _require(self, problem: UpdateProblem, hint: str = "") -> None:
        missing = problem.missing(sorted(self.needs))
        if missing:
            raise ValueError(f"updater {self.name!r} needs {missing} in the UpdateProblem; "
                             f"got None for {'it' if len(missing) == 1 else 'them'}{hint}")


@dataclass(frozen=True, kw_only=True)
class FiniteDifferenceUpdater(IterationSettings):
    """Finite-difference FRF updating (Eq. 10.12-10.21, :func:`finite_difference_update`,
    whose defaults are these). Needs ``predict_frf``, ``frf_data`` and ``n_pairs`` of the
    :class:`~truthbench.update.UpdateProblem`; uses ``frf_weights``, ``additive`` and ``start``.
    Updates any parameter the predictor can vary."""

    name: ClassVar[str] = "finite_difference"
    needs: ClassVar[frozenset[str]] = frozenset({"frf"})

    relative_step: float = setting(
        1e-4, "Finite-difference step, relative to the parameter (or in units of an "
        "additive parameter's scale).", low=0, low_open=True, high=0.1, high_open=True)
    scheme: str = setting("central", "Finite differences: central (second order) or "
                          "forward (half the model evaluations).",
                          choices=("central", "forward"))

    def unsupported(self, kinds: Mapping[str, str]) -> dict[str, str]:
        """Parameters it cannot update, with the reason: none."""
        return {}

    def update(self, problem: UpdateProblem) -> UpdateResult:
        """Update ``problem.names`` against the problem's FRFs."""
        self._require(problem)
        return finite_difference_update(
            problem.predict_frf, problem.frf_data, problem.theta0, problem.names,
            n_pairs=int(problem.n_pairs), weights=problem.frf_weights,
            additive=dict(problem.additive) if problem.additive else None,
            start=problem.start, **self.settings())


def _stack(z: np.ndarray) -> np.ndarray:
    """Real and imaginary parts one above the other, shape (2 N, ...)."""
    z = z.reshape(z.shape[0], -1) if z.ndim > 1 else z
    return np.concatenate([z.real, z.imag], axis=0)


def sensitivity_matrix(
    predict: Callable[[Mapping[str, float]], np.ndarray],
    theta: Mapping[str, float],
    names: Sequence[str],
    *,
    relative_step: float = 1e-4,
    scheme: str = "central",
    G0: np.ndarray | None = None,
    additive: Mapping[str, float] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Finite-difference FRF sensitivities to relative parameter changes (Eq. 10.17).

    Parameters
    ----------
    predict : callable
        ``predict(theta) -> G``, complex array of any fixed shape.
    theta : mapping
        The linearisation point (all model parameters; ``names`` are perturbed).
    names : sequence of str
    relative_step : float
        Step ``h`` in ``theta_k (1 +- h)``.
    scheme : {"central", "forward"}
        Central differences have O(h^2) error (needed to see exact collinearity such
        as t against E and rho); forward is the chapter's Eq. 10.17 and costs half.
    G0 : ndarray, optional
        ``predict(theta)`` if already known.
    additive : mapping of str -> float, optional
        Parameters changed additively instead, name -> scale ``a_k`` (the parameter's
        own unit): ``theta_k +- h a_k``, for parameters whose natural value can be 0
        (a delay).

    Returns
    -------
    S : ndarray, complex, shape (G.size, p)
        ``dG / dp_k`` per unit relative change of each parameter (per ``a_k`` for an
        additive one).
    G0 : ndarray
        The prediction at ``theta``.
    """
    if scheme not in ("central", "forward"):
        raise ValueError(f"scheme must be 'central' or 'forward'; got {scheme!r}")
    if G0 is None:
        G0 = np.asarray(predict(theta))
    additive = additive or {}
    cols = []
    for name in names:
        up = dict(theta)
        up[name] = _stepped(theta[name], relative_step, additive.get(name))
        Gp = np.asarray(predict(up))
        if scheme == "forward":
            cols.append((Gp - G0).ravel() / relative_step)
        else:
            dn = dict(theta)
            dn[name] = _stepped(theta[name], -relative_step, additive.get(name))
            cols.append((Gp - np.asarray(predict(dn))).ravel() / (2 * relative_step))
    return np.column_stack(cols), G0


def _stepped(value: float, d: float, scale: float | None) -> float:
    """``value`` moved by ``d``: relatively (``value e^d``, log-parameters; ``1 + d`` in
    finite differences is the same to first order) or additively (``value + d scale``)."""
    return value + d * scale if scale is not None else value * (1 + d)


NORMAL_COND_MAX = 1e3
"""Condition number of the column-scaled ``R`` up to which it is taken from the normal
equations (:func:`_triangular_factor`): their rounding relative to the smallest scaled
singular value is about ``cond^2 eps`` (2e-10 at the limit), far from what the
identifiability check (``rcond`` 1e-4) or the step resolve."""


def _triangular_factor(Sw: np.ndarray, r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``R`` (p x p, upper) of the thin QR of ``A`` = the real and imaginary parts of
    ``Sw`` stacked (``min(rows, p)`` x p), and ``Q^T b`` (``b`` those of ``r``).

    From the normal equations where ``A`` is well conditioned once its columns are
    scaled (``R^T R = A^T A = Re(Sw^H Sw)``, a Cholesky factor, and
    ``Q^T b = R^-T A^T b``: products of the complex matrices, a fifth of the QR's time
    on the hub beam's 150 000 rows); else, or where the factorisation fails (a zero
    column), by Householder QR of the stacked ``A``.
    """
    p = Sw.shape[1]
    if Sw.shape[0] >= p:
        AtA = (Sw.conj().T @ Sw).real
        d = np.sqrt(np.diag(AtA))
        if np.all(d > 0):
            try:
                L = np.linalg.cholesky(AtA / np.outer(d, d))
            except np.linalg.LinAlgError:
                L = None
            if L is not None and np.linalg.cond(L) <= NORMAL_COND_MAX:
                R = L.T * d[None, :]
                Qb = sla.solve_triangular(R, (Sw.conj().T @ r).real, trans="T")
                return R, Qb
    Q, R = np.linalg.qr(_stack(Sw))
    return R, Q.T @ _stack(r)


def _try(predict, theta, names, dx, additive, cost):
    """The parameters ``theta`` moved by ``dx`` (log-parameters, or units of an additive
    parameter's scale), the prediction there and its cost (inf where the model refuses
    the values)."""
    trial = dict(theta)
    for n, d in zip(names, dx, strict=True):
        trial[n] = theta[n] + d * additive[n] if n in additive else theta[n] * np.exp(d)
    try:
        G_trial = np.asarray(predict(trial))
        return trial, G_trial, cost(G_trial)
    except ValueError:  # the model refused these values: treat as no decrease
        return trial, None, np.inf


def _start(predict, theta0, names, start, additive, cost, costs, G0):
    """``(theta, G)`` at ``start`` (appending its cost to ``costs``) when it lowers the
    cost, else ``(theta0, G0)``."""
    bad = {n: v for n, v in start.items() if n in names and not (
        np.isfinite(v) and (n in additive or v * theta0[n] > 0))}
    if bad:
        raise ValueError(f"start values must be finite and, for relative parameters, of "
                         f"their starting value's sign; got {bad}")
    moved = {**theta0, **{n: float(start[n]) for n in names if n in start}}
    if all(moved[n] == theta0[n] for n in names):
        return theta0, G0
    try:
        G = np.asarray(predict(moved))
        c = cost(G)
    except ValueError:  # the model refuses the start
        return theta0, G0
    if not c < costs[-1]:
        return theta0, G0
    costs.append(c)
    return moved, G


def _newton_step(R: np.ndarray, curvature: np.ndarray, g: np.ndarray) -> np.ndarray | None:
    """The step ``(R^T R + curvature)^-1 g``, or None when there is no curvature yet or
    the Hessian it makes is not positive definite."""
    if not np.any(curvature):
        return None
    H = R.T @ R + curvature
    try:
        L = np.linalg.cholesky(H)
    except np.linalg.LinAlgError:
        return None
    return np.linalg.solve(L.T, np.linalg.solve(L, g))


def secant_curvature(curvature: np.ndarray, step: np.ndarray, g_old: np.ndarray,
                     g: np.ndarray, old_at_new: np.ndarray) -> np.ndarray:
    """The structured secant update of the residuals' curvature term (Dennis, Gay and
    Welsch 1981, the NL2SOL update).

    The cost ``|b(x)|^2`` (``b`` the weighted residual, ``-A`` its Jacobian) has the
    Hessian ``2 (A^T A + T)`` with ``T = sum_i b_i d2b_i/dx2``, the term Gauss-Newton
    leaves out. Where the residual stays large at the minimum (a model that cannot fit
    the data exactly) ``T`` is not small against ``A^T A`` and Gauss-Newton converges
    linearly, at the rate of ``T`` relative to ``A^T A`` along the slowest direction.
    After a step ``s`` from the iterate with ``A_old`` (gradient ``-2 g_old``,
    ``g = A^T b``; ``old_at_new = A_old^T b``) the update makes
    ``T_new s = y# = (A_old - A)^T b`` (what the Jacobian's change along the step says
    of ``T``), a symmetric rank-two change of
    ``T`` that is smallest in the metric of the full gradient change
    ``y = g_old - g``, after sizing ``T`` down by ``min(1, |s^T y#| / |s^T T s|)``.
    Where ``s^T y <= 0`` (the cost is not convex along the step) the curvature is
    dropped (Gauss-Newton).

    Returns
    -------
    ndarray, shape (p, p)
        The updated, symmetric ``T``.
    """
    y = g_old - g
    ys = float(y @ step)
    if not ys > 0:
        return np.zeros_like(curvature)
    y_sharp = old_at_new - g
    sTs = float(step @ curvature @ step)
    if sTs != 0:
        curvature = curvature * min(1.0, abs(float(step @ y_sharp)) / abs(sTs))
    z = y_sharp - curvature @ step
    out = (curvature + (np.outer(z, y) + np.outer(y, z)) / ys
           - float(z @ step) * np.outer(y, y) / ys**2)
    return 0.5 * (out + out.T)


def finite_difference_update(
    predict: Callable[[Mapping[str, float]], np.ndarray],
    data: np.ndarray,
    theta0: Mapping[str, float],
    names: Sequence[str],
    *,
    n_pairs: int | None,
    weights: np.ndarray | None = None,
    max_iterations: int = FiniteDifferenceUpdater.max_iterations,
    tolerance: float = FiniteDifferenceUpdater.tolerance,
    relative_step: float = FiniteDifferenceUpdater.relative_step,
    scheme: str = FiniteDifferenceUpdater.scheme,
    rcond: float = FiniteDifferenceUpdater.rcond,
    max_step: float = FiniteDifferenceUpdater.max_step,
    additive: Mapping[str, float] | None = None,
    jacobian: str | Callable | None = "auto",
    start: Mapping[str, float] | None = None,
) -> UpdateResult:
    """Iterated finite-difference frequency-domain update (Eq. 10.12-10.21).

    Parameters
    ----------
    predict : callable
        ``predict(theta) -> G_M``, complex, same shape as ``data``.
    data : ndarray, complex
        Measured FRFs ``G_D`` (any shape, e.g. (n_lines, n_out, n_in) stacked over tests).
    theta0 : mapping
        Starting parameter values (all model parameters).
    names : sequence of str
        Parameters to update (p of them).
    n_pairs : int or None
        Number of SISO transfer functions in the data (``m r``), checked against p (the
        chapter's rule). None leaves the rule out: the diagnosis fits a few parameters
        to thousands of lines of one transfer function, where the separability check
        (the singular values of the sensitivity matrix) is the test that matters.
    weights : ndarray, optional
        Non-negative real weight of every data entry (frequency weighting), same shape
        as ``data``; the cost is ``sum |w (G_D - G_M)|^2``.
    max_iterations : int
    tolerance : float
        Stop when the largest relative parameter change of an iteration is below it.
        (The defaults of these settings are :class:`FiniteDifferenceUpdater`'s.)
    relative_step, scheme
        Finite differences, see :func:`sensitivity_matrix`.
    rcond : float
        Relative singular value of the column-scaled sensitivity matrix below which the
        parameters are declared inseparable. At 1e-4 the data's noise would be amplified
        ten thousand times along that direction; exact collinearities (t against E and
        rho) show as about 1e-6 with central steps of 1e-4, because second-order terms
        of the FRF near resonances are large.
    max_step : float
        Largest change of any log-parameter in one iteration (0.5: a factor of 1.65);
        a trust region that keeps a far linearisation from throwing a parameter away.
    additive : mapping of str -> float, optional
        Parameters updated additively, name -> scale in the parameter's unit (steps and
        the trust region count in units of the scale): for parameters that may start
        at 0 or change sign, e.g. a delay (appended dynamics) with scale
        ``1 / (2 pi f_max)``, one radian of phase at the top of the band.
    jacobian : {"auto", "finite_difference"}, callable or None
        Where the sensitivity matrix comes from. ``"auto"`` (default): ``predict``'s own
        ``jacobian(theta, names, additive=...)`` when it has one (an analytic Jacobian,
        e.g. :meth:`FRFPredictor.vector_function
        <truthbench.update.FRFPredictor.vector_function>`, see
        :mod:`truthbench.update.jacobian`), else finite differences; a callable with that
        signature; ``"finite_difference"`` or None: always finite differences. A
        Jacobian that returns None at some ``theta`` falls back to finite differences
        there. The fixed point (the converged parameters) does not depend on it; the
        path and the iteration count may differ at the level of the Jacobian's error.
    start : mapping, optional
        Values of (some of) ``names`` to start the iteration from instead of
        ``theta0``, e.g. a modal update's result: the FRF cost of lightly damped
        structures is a narrow valley around resonances that line up, and Gauss-Newton
        steps from outside it move a peak by about its bandwidth per iteration. Used
        when its cost is below ``theta0``'s; ``initial`` and ``history[0]`` stay
        ``theta0``'s and ``history[1]`` is the start (counted as an iteration, not
        against ``max_iterations``). The minimum found is that of the valley the
        iteration starts in.

    Returns
    -------
    UpdateResult

    Raises
    ------
    IdentifiabilityError
        ``m r <= p`` (when ``n_pairs`` is given), or a parameter combination the data cannot see.
    """
    names = tuple(names)
    p = len(names)
    if p == 0:
        raise ValueError("no parameters to update: 'parameters' is empty")
    missing = [n for n in names if n not in theta0]
    if missing:
        raise ValueError(f"parameters {missing} are not model parameters; expected names "
                         f"from {sorted(theta0)}")
    additive = dict(additive or {})
    bad = {n: a for n, a in additive.items() if n not in names or not (np.isfinite(a) and a > 0)}
    if bad:
        raise ValueError(f"additive scales must be positive numbers for updated parameters "
                         f"{list(names)}; got {bad}")
    zero = [n for n in names if theta0[n] == 0 and n not in additive]
    if zero:
        raise ValueError(f"relative updating needs non-zero starting values; got 0 for "
                         f"{zero} (update them additively: 'additive' scales)")
    if n_pairs is not None:
        check_overdetermined(n_pairs, p)
    data = np.asarray(data)
    w = np.ones(data.shape) if weights is None else np.asarray(weights, dtype=float)
    if w.shape != data.shape:
        raise ValueError(f"weights must have the data's shape {data.shape}; got {w.shape}")
    if np.any(w < 0) or not np.all(np.isfinite(w)):
        raise ValueError("weights must be finite and non-negative")
    w_flat = w.ravel()

    theta = dict(theta0)
    base = np.array([theta0[n] for n in names], dtype=float)

    def cost(G):
        return float(np.sum(np.abs(w * (data - G)) ** 2))

    G = np.asarray(predict(theta))
    if G.shape != data.shape:
        raise ValueError(f"predict returned shape {G.shape}; data has shape {data.shape}")
    if jacobian == "auto":
        jacobian = getattr(predict, "jacobian", None)
    elif jacobian == "finite_difference":
        jacobian = None
    elif jacobian is not None and not callable(jacobian):
        raise ValueError(f"jacobian must be 'auto', 'finite_difference', a callable or None;"
                         f" got {jacobian!r}")
    history = [base.copy()]
    costs = [cost(G)]
    if start is not None:
        moved, G = _start(predict, theta, names, start, additive, cost, costs, G)
        if moved is not theta:
            theta = moved
            history.append(np.array([theta[n] for n in names], dtype=float))
    converged = False
    s = Vt = None
    mu = 0.0  # Levenberg-Marquardt damping, 0 = plain Gauss-Newton (Eq. 10.21)
    dx = np.zeros(p)
    curvature = np.zeros((p, p))  # secant estimate of the residuals' curvature term
    last = None  # (step, A, A^T b) of the last accepted iteration
    for _ in range(max_iterations):
        S = None if jacobian is None else jacobian(theta, names, additive=additive)
        if S is None:
            S, _ = sensitivity_matrix(predict, theta, names, relative_step=relative_step,
                                      scheme=scheme, G0=G, additive=additive)
        else:
            S = np.asarray(S).reshape(G.size, p)
        # A (real and imaginary parts stacked) = Q R (thin): R (p x p) has A's column
        # norms, singular values and right singular vectors, so the identifiability
        # check and the SVD run on it, and U^T b = U_R^T (Q^T b)
        Sw = S * w_flat[:, None]
        r = (w * (data - G)).ravel()
        R, Qb = _triangular_factor(Sw, r)
        check_identifiable(names, R if R.shape[0] >= p else _stack(Sw), rcond,
                           data="the model FRFs at the data's frequencies, outputs and "
                           "inputs")
        U, s, Vt = np.linalg.svd(R, full_matrices=False)
        Ub = U.T @ Qb
        g = R.T @ Qb  # A^T b: minus half the cost's gradient
        if last is not None:
            step, Sw_old, g_old = last
            curvature = secant_curvature(curvature, step, g_old, g,
                                         (Sw_old.conj().T @ r).real)
        # Steps are in log-parameters (relative changes that keep values positive).
        # First the quasi-Newton step of the cost's Hessian A^T A + curvature, when the
        # secant has seen a curvature; if it does not lower the cost, the Gauss-Newton
        # step, and if the cost rises, damp it (Levenberg-Marquardt in the SVD basis)
        # until it falls. Lightly damped FRFs make the cost strongly non-quadratic once
        # peaks have moved by more than their bandwidth.
        accepted = False
        qn = _newton_step(R, curvature, g)
        if qn is not None:
            dx = qn * min(1.0, max_step / max(np.abs(qn).max(), 1e-300))
            trial, G_trial, c_trial = _try(predict, theta, names, dx, additive, cost)
            accepted = c_trial <= costs[-1]
            if not accepted:  # the secant's curvature misled: back to Gauss-Newton
                curvature = np.zeros((p, p))
        if not accepted:
            for _attempt in range(30):
                dx = Vt.T @ (Ub * s / (s**2 + mu * s[0] ** 2))
                dx = dx * min(1.0, max_step / max(np.abs(dx).max(), 1e-300))
                trial, G_trial, c_trial = _try(predict, theta, names, dx, additive, cost)
                if c_trial <= costs[-1]:
                    mu = mu / 10 if mu > 1e-12 else 0.0
                    break
                if np.max(np.abs(dx)) < tolerance:
                    # even a step below the tolerance raises the cost: a minimum to
                    # working precision (damping it further only shrinks it, until the
                    # cost stops changing at its rounding)
                    converged = True
                    break
                mu = max(10 * mu, 1e-6)
            else:
                break  # no decrease possible: at a minimum to working precision
        if converged:
            break
        last = (dx, Sw, g)
        theta, G = trial, G_trial
        history.append(np.array([theta[n] for n in names]))
        costs.append(c_trial)
        if np.max(np.abs(dx)) < tolerance:
            converged = True
            break
    if not converged:
        warnings.warn(
            f"finite-difference update did not converge in {max_iterations} iterations "
            f"(last relative change {np.max(np.abs(dx)):.1e} > tolerance {tolerance:.0e}); "
            f"raise 'max_iterations' or check the parameterisation", stacklevel=2)
    cov = np.linalg.pinv(np.diag(s) @ Vt) @ np.linalg.pinv(np.diag(s) @ Vt).T
    sd = np.sqrt(np.diag(cov))
    corr = cov / np.outer(sd, sd)
    return UpdateResult(
        names=names, initial=base, values=history[-1], history=np.array(history),
        cost_history=np.array(costs), singular_values=s,
        condition_number=float(s[0] / s[-1]), correlation=corr, converged=converged)
