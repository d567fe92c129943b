"""Fitting a model with some effects to the data, and screening candidates cheaply.

The cost is the noise-weighted squared residual over every compared line, output and
input, real and imaginary parts apart,

    chi2(theta) = sum ((Re, Im)(H_data - H_model(theta)) / sigma)^2,

minimised by the project's finite-difference FRF updater (Eq. 10.12-10.21,
Levenberg-Marquardt damped Gauss-Newton, identifiability checked at every iteration).
The model
FRF is what the data's estimator would have measured: the exact FRF at ``s = sigma_w +
j omega`` for exponentially windowed data, plus, for averaged estimates whose window
and segments are known, the leakage offset ``E[H1] - H`` computed at a reference fit
and held during a fit (:class:`Problem.offsets`). Modes the model lacks and the
channels' off-axis mounting are eliminated from the residual (:class:`ExtraModes`); the
mounting's columns are the model's own FRFs, held and refreshed with the offsets.

Screening (:func:`score`) is the Lagrange-multiplier test of adding a candidate to the
current fit: the candidate's sensitivity columns, projected off the current fit's
Jacobian, predict the drop in chi2 of a Gauss-Newton step, ``r' A (A' A)^-1 A' r``,
without refitting; a step that would take a parameter below its physical minimum
scores only what the bound allows (a one-sided test).
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from functools import cached_property

import numpy as np

from truthbench.diagnose.mounting import mounting_columns
from truthbench.errors import IdentifiabilityError, ModelError
from truthbench.plants.base import Plant
from truthbench.update.finite_difference import finite_difference_update, sensitivity_matrix
from truthbench.update.predictor import APPENDED_PARAMETERS, EffectTerm, FRFPredictor, PredictedTest

MODE_TOLERANCE = 1e-12
"""Modes whose resonance peak at the data's channels is below this fraction of the
largest are left out of the model FRFs (:func:`truthbench.model.frf`): far below any
measured noise, and a several-fold speed-up for channels in one plane."""

CORRELATION_LAGS = 4
"""Lags, in lines, over which the noise's correlation between neighbouring lines enters
the covariance (:func:`correlated_noise`). A segment window correlates the noise of bins
k apart by ``|DFT(w^2)(k)| / sum(w^2)``: Hann 0.67 and 0.17 at one and two bins and none
beyond; Bartlett 0.61, 0.15, 0.07, 0.04 at one to four bins (beyond, less than the
scatter of the correlation's own estimate from a few thousand values)."""

QUICK_ITERATIONS = 10
"""Iterations of a quick refit (:func:`fit` with ``quick``): it ranks candidates from a
screened start; the chosen one is completed."""


def stack(z: np.ndarray) -> np.ndarray:
    """Real and imaginary parts one after the other (rows), shape (2 N, ...)."""
    z = z.reshape(z.shape[0], -1) if z.ndim > 1 else z
    return np.concatenate([z.real, z.imag], axis=0)


_POWERS = {"displacement": 0, "velocity": 1, "acceleration": 2, "strain": 0}


def mode_basis(s: np.ndarray, freq_hz, zeta: float, power: int) -> np.ndarray:
    """``s^p / (s^2 + 2 zeta w s + w^2)`` at the complex frequencies ``s`` for each pole
    frequency in ``freq_hz``: shape (n_lines, n_poles)."""
    w = 2 * np.pi * np.atleast_1d(np.asarray(freq_hz, float))
    g = 1.0 / (s[:, None] ** 2 + 2 * zeta * w[None, :] * s[:, None] + w[None, :] ** 2)
    return g * (s[:, None] ** power)


def pole_columns(s: np.ndarray, poles, power: int) -> np.ndarray:
    """:func:`mode_basis` of each ``(freq_hz, zeta)`` of ``poles`` with its own damping:
    shape (n_lines, n_poles)."""
    if not poles:
        return np.zeros((s.size, 0), complex)
    return np.column_stack([mode_basis(s, f, z, power)[:, 0] for f, z in poles])


@dataclass(frozen=True, eq=False)
class ExtraModes:
    """What the comparison models in by elimination: modes the model lacks, each with a
    free complex residue in every transfer function, and the channels' off-axis
    mounting (:mod:`truthbench.diagnose.mounting`), a real amplitude per path and
    transfer function (variable projection: the residues and amplitudes are
    eliminated).

    The weighted residual ``w (D - M)`` of each transfer function is replaced by its
    part orthogonal, in the real inner product ``Re(a^H b)``, to the span of its
    weighted columns: ``w s^p / (s^2 + 2 zeta w_k s + w_k^2)`` and ``j`` times it for
    each mode (a complex residue is two real amplitudes), and ``w`` times each mounting
    column. That is the residual with the best residues and amplitudes added to the
    model.

    Attributes
    ----------
    poles : tuple of (float, float)
        Frequency (Hz) and damping ratio of each mode.
    bases : tuple of ndarray
        Per test, weighted bases orthonormal in the real inner product, shape
        (n_lines, n_out, n_in, n_columns); a column the others span is zero.
    mounted : bool
        The mounting's columns are among them.
    """

    poles: tuple[tuple[float, float], ...]
    bases: tuple[np.ndarray, ...]
    mounted: bool = False

    @classmethod
    def build(cls, poles, tests, weights: np.ndarray, mounting=None) -> ExtraModes:
        """The bases of ``poles`` (and of the ``mounting`` columns, per test shape
        (n_lines, n_out, n_in, k), when given) on the lines and channels of ``tests``
        with the data's ``weights`` (raveled as the problem's)."""
        bases, start = [], 0
        for j, t in enumerate(tests):
            shape = (t.freq_hz.size, len(t.sensors), len(t.actuators))
            W = weights[start:start + int(np.prod(shape))].reshape(shape)
            start += int(np.prod(shape))
            s = 2j * np.pi * t.freq_hz + t.decay_rad_s
            extra = 0 if mounting is None else mounting[j].shape[3]
            Q = np.zeros(shape + (2 * len(poles) + extra,), dtype=complex)
            for o, x in enumerate(t.sensors):
                g = pole_columns(s, poles, _POWERS[x.quantity])
                for i in range(shape[2]):
                    cols = [g, 1j * g]
                    if extra:
                        cols.append(mounting[j][:, o, i, :])
                    Q[:, o, i, :] = _real_orthonormal(W[:, o, i, None] * np.hstack(cols))
            bases.append(Q)
        return cls(tuple(poles), tuple(bases), mounting is not None)

    def project(self, r: np.ndarray) -> np.ndarray:
        """The part of weighted residuals (raveled as the problem's data, shape (N,) or
        (G, N)) that the residues and amplitudes take up."""
        out = np.zeros_like(r)
        start = 0
        for Q in self.bases:
            size = int(np.prod(Q.shape[:3]))
            part = r[..., start:start + size].reshape(r.shape[:-1] + Q.shape[:3])
            coef = np.einsum("foik,...foi->...oik", Q.conj(), part).real
            out[..., start:start + size] = np.einsum("foik,...oik->...foi", Q, coef
                                                     ).reshape(r.shape[:-1] + (size,))
            start += size
        return out


def _real_orthonormal(A: np.ndarray, rcond: float = 1e-10) -> np.ndarray:
    """Columns orthonormal in ``Re(a^H b)`` spanning the complex columns of ``A`` (shape
    (n, k)) over the reals; columns within ``rcond`` of the others' span become zero."""
    n, k = A.shape
    if k == 0:
        return np.zeros((n, 0), complex)
    U, S, _ = np.linalg.svd(np.vstack([A.real, A.imag]), full_matrices=False)
    keep = S > rcond * max(S[0], 1e-300)
    U[:, ~keep] = 0.0
    return U[:n] + 1j * U[n:]


@dataclass(frozen=True, eq=False)
class Problem:
    """The data and the fixed parts of every model fitted to them.

    Attributes
    ----------
    plant : Plant
        The model's plant (with stations at the data's points and every node).
    nominal : dict
        Nominal plant parameters.
    tests : tuple of PredictedTest
        Lines and channels of each test (and its estimator).
    data : ndarray, complex, shape (N,)
        Every compared value, tests raveled and concatenated.
    weights : ndarray, shape (N,)
        ``1 / sigma`` of each value.
    declared : tuple of str
        Parameters the user trusts the model to get wrong (always refitted).
    scales : dict
        Natural size of every additively fitted parameter (the delay, candidates').
    offsets : ndarray, complex, shape (N,), optional
        The estimator's leakage offset ``E[H1] - H`` at a reference fit.
    extra : ExtraModes, optional
        What the comparison eliminates: modes the model lacks (free residues) and the
        channels' off-axis mounting (a real amplitude per transfer function).
    settings : dict
        ``max_iterations``, ``tolerance``, ``relative_step``.
    """

    plant: Plant
    nominal: dict
    tests: tuple[PredictedTest, ...]
    data: np.ndarray
    weights: np.ndarray
    declared: tuple[str, ...]
    scales: dict
    offsets: np.ndarray | None = None
    settings: dict = field(default_factory=dict)
    extra: ExtraModes | None = None

    @property
    def n(self) -> int:
        """Real data values (twice the complex ones)."""
        return 2 * self.data.size

    @property
    def correlation_lines(self) -> float:
        """Lines per independent value of the data's estimates (the largest of the
        tests'; 1 when no estimator is known): a windowed estimate's adjacent lines share
        their noise over the window's bandwidth."""
        return max((1.0 if t.kernel is None else t.kernel.correlation_lines
                    for t in self.tests), default=1.0)

    @cached_property
    def neighbours(self) -> tuple[tuple[np.ndarray, np.ndarray], ...]:
        """For lags k = 1 .. :data:`CORRELATION_LAGS`: the index pairs ``(i, j)`` of the
        complex values (into :attr:`data`) of one channel pair at lines k apart (the
        line spacing of its test times k); a windowed estimate's noise is correlated
        there."""
        out = [([], []) for _ in range(CORRELATION_LAGS)]
        start = 0
        for t in self.tests:
            f = np.asarray(t.freq_hz)
            stride = len(t.sensors) * len(t.actuators)
            if f.size > 1:
                df = float(np.median(np.diff(f)))
                for k in range(1, CORRELATION_LAGS + 1):
                    a = np.flatnonzero(np.abs(f[k:] - f[:-k] - k * df) < 1e-6 * df)
                    base = start + a[:, None] * stride + np.arange(stride)
                    out[k - 1][0].append(base.ravel())
                    out[k - 1][1].append((base + k * stride).ravel())
            start += f.size * stride
        return tuple((np.concatenate(i or [np.zeros(0, int)]),
                      np.concatenate(j or [np.zeros(0, int)])) for i, j in out)

    @property
    def n_independent(self) -> float:
        """Independent real values: :attr:`n` over :attr:`correlation_lines`."""
        return self.n / self.correlation_lines

    def predictor(self, terms: Sequence[EffectTerm] = ()) -> FRFPredictor:
        return FRFPredictor(self.plant, self.nominal, self.tests, tuple(terms),
                            mode_tolerance=MODE_TOLERANCE, reduced=True)

    def predict(self, terms: Sequence[EffectTerm] = (), *, estimator: bool = False):
        """``theta -> model vector`` (exact FRF plus the held leakage offset, and the
        modes the model lacks and the mounting with their best residues and
        amplitudes). With ``estimator`` the estimator's leakage is computed at ``theta``
        itself instead of held (exact where a parameter moves an under-resolved mode
        far; about fifteen times the cost)."""
        pred = self.predictor(terms)
        if estimator and any(t.kernel is not None for t in self.tests):
            def base(theta):
                return pred.predict_vector(theta, estimator=True)
        else:
            base = pred.predict_vector if self.offsets is None else (
                lambda theta, off=self.offsets: pred.predict_vector(theta) + off)
        if self.extra is None:
            return base
        w, data, extra = self.weights, self.data, self.extra

        def with_modes(theta):
            G = base(theta)
            return G + extra.project(w * (data - G)) / w

        return with_modes

    def deflate(self, r: np.ndarray) -> np.ndarray:
        """Weighted residuals (shape (N,) or (G, N)) without the part the modes the model
        lacks take up (unchanged when there are none)."""
        return r if self.extra is None else r - self.extra.project(r)

    def chi2(self, model: np.ndarray) -> float:
        return float(np.sum(np.abs(self.weights * (self.data - model)) ** 2))

    def theta0(self, terms: Sequence[EffectTerm] = ()) -> dict[str, float]:
        """Nominal values of every plant, appended and effect parameter."""
        return self.predictor(terms).theta0

    def additive(self, names: Sequence[str]) -> dict[str, float]:
        return {n: self.scales[n] for n in names if n in self.scales}


@dataclass(frozen=True, eq=False)
class Fit:
    """A model fitted to the data.

    Attributes
    ----------
    terms : tuple of EffectTerm
        The model's effects.
    names : tuple of str
        The fitted parameters.
    theta : dict
        Every parameter's value at the fit.
    chi2 : float
        The weighted cost at the fit.
    converged : bool
    iterations : int
    jacobian : ndarray, shape (n, p)
        Weighted, stacked sensitivities at the fit, per unit of each parameter.
    residual : ndarray, shape (n,)
        Weighted, stacked residual ``w (data - model)`` at the fit.
    covariance : ndarray, shape (p, p)
        Parameter covariance (:func:`covariance`: column-scaled, the noise scale
        estimated from the residual, lines' correlation counted), in the parameters'
        units.
    model : ndarray, complex, shape (N,)
        The model vector at the fit.
    """

    terms: tuple[EffectTerm, ...]
    names: tuple[str, ...]
    theta: dict
    chi2: float
    converged: bool
    iterations: int
    jacobian: np.ndarray
    residual: np.ndarray
    covariance: np.ndarray
    model: np.ndarray

    @property
    def values(self) -> dict[str, float]:
        return {n: float(self.theta[n]) for n in self.names}

    @property
    def std(self) -> dict[str, float]:
        return {n: float(np.sqrt(max(self.covariance[i, i], 0.0)))
                for i, n in enumerate(self.names)}


def with_offsets(problem: Problem, current: Fit | None = None, *, terms=None,
                 theta=None) -> Problem:
    """The problem with its held parts at ``current``'s parameters and effects (or at
    ``terms`` and ``theta``): the estimator's leakage offset ``E[H1] - H`` (when a test
    states its estimator) and the mounting's columns (when they are modelled in);
    unchanged when it has neither."""
    mounted = problem.extra is not None and problem.extra.mounted
    kernel = any(t.kernel is not None for t in problem.tests)
    if not (mounted or kernel):
        return problem
    terms = current.terms if terms is None else tuple(terms)
    theta = current.theta if theta is None else theta
    if mounted:
        problem = with_mounting(problem, terms, theta)
    if not kernel:
        return problem
    pred = problem.predictor(terms)
    exact = pred.predict_vector(theta)
    seen = pred.predict_vector(theta, estimator=True)
    return replace(problem, offsets=seen - exact)


def with_mounting(problem: Problem, terms: Sequence[EffectTerm],
                  theta: Mapping[str, float]) -> Problem:
    """The problem with the channels' off-axis mounting modelled in
    (:mod:`truthbench.diagnose.mounting`), its columns from the model with ``terms`` at
    ``theta``."""
    columns = mounting_columns(problem.predictor(terms), theta)
    poles = () if problem.extra is None else problem.extra.poles
    return replace(problem, extra=ExtraModes.build(poles, problem.tests, problem.weights,
                                                   columns))


def fit(problem: Problem, terms: Sequence[EffectTerm] = (), *,
        start: Mapping[str, float] | None = None, quick: bool = False,
        estimator: bool = False) -> Fit:
    """Fit the declared parameters and every fitted parameter of ``terms``.

    Parameters
    ----------
    problem : Problem
    terms : sequence of EffectTerm
        The model's effects, in order.
    start : mapping, optional
        Starting values overriding the nominal ones.
    quick : bool
        A candidate's trial refit: forward differences, at most
        :data:`QUICK_ITERATIONS` iterations to a relative change of 1e-4, and no
        Jacobian at the end (``jacobian`` and ``covariance`` are empty). The chi2 is
        then within a small fraction of the optimum's; the chosen candidate is refitted
        in full.
    estimator : bool
        The estimator's leakage computed at every parameter value tried instead of held
        at ``problem.offsets`` (:meth:`Problem.predict`), for a parameter that moves an
        under-resolved mode far: with the offset held, the fit stays near where it
        starts. The fit is then evaluated with the offsets at its optimum.

    Raises
    ------
    IdentifiabilityError
        The data cannot separate the parameters (with which combination).
    """
    terms = tuple(terms)
    names = tuple(problem.declared) + _keys(terms)
    theta0 = {**problem.theta0(terms), **dict(start or {})}
    predict = problem.predict(terms, estimator=estimator)
    s = problem.settings
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        res = finite_difference_update(
            predict, problem.data, theta0, names, n_pairs=None,
            weights=problem.weights, additive=problem.additive(names),
            max_iterations=QUICK_ITERATIONS if quick else s.get("max_iterations", 30),
            tolerance=1e-4 if quick else s.get("tolerance", 1e-6),
            relative_step=s.get("relative_step", 1e-4), max_step=4.0,
            scheme="forward" if quick else "central")
    converged = res.converged and not any("did not converge" in str(w.message)
                                          for w in caught)
    theta = {**theta0, **res.as_dict()}
    if quick:
        model = np.asarray(predict(theta))
        empty = np.zeros((0, len(names)))
        return Fit(terms, names, theta, problem.chi2(model), bool(converged),
                   res.n_iterations, empty, np.zeros(0), np.full((len(names),) * 2, np.nan),
                   model)
    if estimator:
        problem = with_offsets(problem, terms=terms, theta=theta)
    return evaluate(problem, terms, names, theta, converged, res.n_iterations)


def fit_magnitude(problem: Problem, terms: Sequence[EffectTerm] = (), *,
                  start: Mapping[str, float] | None = None) -> dict[str, float]:
    """The declared (and ``terms``') parameters fitted to the FRF magnitudes alone.

    A delay, a low-pass or any phase error leaves ``|H|`` nearly alone, so this fit stays
    near the structure's parameters where the complex fit may wander to compensate a
    phase it cannot model (a 2 ms delay is 5 rad at 400 Hz). It starts the complex
    baseline and gives the residual signatures of phase effects.

    Returns
    -------
    dict
        Every parameter's value at the magnitude fit.
    """
    terms = tuple(terms)
    names = tuple(problem.declared) + _keys(terms)
    theta0 = {**problem.theta0(terms), **dict(start or {})}
    predict = problem.predict(terms)
    s = problem.settings
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = finite_difference_update(
            lambda th: np.abs(predict(th)), np.abs(problem.data), theta0, names,
            n_pairs=None, weights=problem.weights,
            additive=problem.additive(names),
            max_iterations=s.get("max_iterations", 30), tolerance=s.get("tolerance", 1e-6),
            relative_step=s.get("relative_step", 1e-4))
    return {**theta0, **res.as_dict()}


def evaluate(problem: Problem, terms: Sequence[EffectTerm], names: Sequence[str],
             theta: Mapping[str, float], converged: bool = True, iterations: int = 0) -> Fit:
    """The :class:`Fit` of ``terms`` at ``theta`` (Jacobian, residual, covariance)."""
    terms, names = tuple(terms), tuple(names)
    predict = problem.predict(terms)
    model = np.asarray(predict(theta))
    additive = problem.additive(names)
    S, _ = sensitivity_matrix(predict, theta, names, relative_step=problem.settings.get(
        "relative_step", 1e-4), scheme="central", G0=model, additive=additive)
    # per unit of each parameter: relative steps were per theta_k, additive per scale
    unit = np.array([additive[n] if n in additive else theta[n] for n in names], float)
    G = S * problem.weights[:, None] / unit
    z = problem.weights * (problem.data - model)
    J, r = stack(G), stack(z)
    chi2 = float(r @ r)
    cross = correlated_noise(G, z, problem.neighbours)
    return Fit(terms, names, dict(theta), chi2, bool(converged), int(iterations), J, r,
               covariance(J, chi2, problem.n, cross=cross), model)


def correlated_noise(G: np.ndarray, z: np.ndarray,
                     neighbours: Sequence[tuple[np.ndarray, np.ndarray]]) -> np.ndarray:
    """The part of ``J' C J`` that the correlation of neighbouring lines' noise adds.

    A windowed, averaged estimate's noise is correlated between lines a few bins apart
    (over the window's bandwidth). With ``c_k = E[z_i conj(z_j)] / E|z|^2`` for values
    ``k`` lines apart (estimated from the residual ``z`` itself), and circular noise,
    the covariance of the least-squares gradient is ``s2 (J'J + X)`` with
    ``X = sum_k sum_(i,j) Re(c_k conj(G_i) G_j^T) + transpose``: the middle of the
    sandwich ``B^-1 (J' C J) B^-1`` (:func:`covariance`). Unlike a single
    "lines per independent value" factor, it depends on how fast the sensitivities turn
    from line to line (near a resonance they do within the window's bandwidth).

    Parameters
    ----------
    G : ndarray, complex, shape (N, p)
        Weighted sensitivities per unit of each parameter.
    z : ndarray, complex, shape (N,)
        Weighted residual at the fit.
    neighbours : sequence of (ndarray, ndarray)
        Index pairs of values 1, 2, ... lines apart (:attr:`Problem.neighbours`).

    Returns
    -------
    ndarray, shape (p, p)
        Symmetric, in the units of ``J' J``.
    """
    p = G.shape[1]
    X = np.zeros((p, p))
    for c, (i, j) in zip(line_correlation(z, neighbours), neighbours, strict=True):
        if i.size and c != 0:
            A = (c * G[i].conj()).T @ G[j]
            X += A.real + A.real.T
    return X


def line_correlation(z: np.ndarray, neighbours: Sequence[tuple[np.ndarray, np.ndarray]]
                     ) -> np.ndarray:
    """``c_k = sum z_i conj(z_j) / sum |z|^2`` per pair, over the pairs of values k lines
    apart (:attr:`Problem.neighbours`), shape (K,), complex; 0 where there are none."""
    power = float(np.vdot(z, z).real)
    out = np.zeros(len(neighbours), complex)
    if not power > 0 or not z.size:
        return out
    for k, (i, j) in enumerate(neighbours):
        if i.size:
            out[k] = complex(np.vdot(z[j], z[i])) / (power * i.size / z.size)
    return out


def residual_lines(problem: Problem, fit_: Fit) -> float:
    """Lines per independent value of a fit's residual, from its own correlation between
    neighbouring lines (an AR(1) reading of the lag-one correlation ``rho``:
    ``(1 + rho) / (1 - rho)``), never below the estimator's
    (:attr:`Problem.correlation_lines`). Noise gives about the estimator's figure; a
    model error, smooth across lines, gives tens to hundreds: the residual then holds
    far fewer independent values than lines, and a difference of chi2 between two
    explanations means that much less."""
    N = problem.data.size
    z = fit_.residual[:N] + 1j * fit_.residual[N:]
    rho = float(np.clip(line_correlation(z, problem.neighbours[:1])[0].real, 0.0, 0.999))
    return max(problem.correlation_lines, (1 + rho) / (1 - rho))


def covariance(J: np.ndarray, chi2: float, n: int, rcond: float = 1e-10, *,
               cross: np.ndarray | None = None) -> np.ndarray:
    """Parameter covariance of a least-squares fit, ``s2 (J' J)^-1``, computed on the
    column-scaled Jacobian.

    The columns of ``J`` are in the parameters' own units (a modulus in Pa next to a
    mass in kg: column norms 1e13 apart), so ``J' J`` formed directly loses every digit
    of the small parameters. With ``D = diag(1 / |J_k|)``, ``J D = U S V'`` (SVD) and
    ``cov = s2 D V S^-2 V' D``; singular values below ``rcond`` of the largest are
    dropped (a combination the data do not determine has no finite variance: its
    directions get none rather than a huge one).

    Parameters
    ----------
    J : ndarray, shape (n, p)
        Weighted, stacked sensitivities per unit of each parameter.
    chi2 : float
        Weighted cost at the fit.
    n : int
        Real data values.
    rcond : float
    cross : ndarray, shape (p, p), optional
        The noise's correlation between lines, :func:`correlated_noise`: the covariance
        is then the sandwich ``s2 B^-1 (J'J + cross) B^-1``, ``B = J'J``.

    Returns
    -------
    ndarray, shape (p, p)
        In the parameters' units; ``s2 = chi2 / (n - p)`` is the noise scale estimated
        from the residual.
    """
    p = J.shape[1]
    if J.shape[0] == 0 or p == 0:
        return np.full((p, p), np.nan)
    norms = np.linalg.norm(J, axis=0)
    d = np.where(norms > 0, 1.0 / np.where(norms > 0, norms, 1.0), 0.0)
    _, s, Vt = np.linalg.svd(J * d, full_matrices=False)
    keep = s > rcond * s[0] if s.size and s[0] > 0 else np.zeros(s.shape, bool)
    inv = np.where(keep, 1.0 / np.where(keep, s, 1.0) ** 2, 0.0)
    core = (Vt.T * inv) @ Vt
    s2 = chi2 / max(n - p, 1)
    if cross is not None:
        core = core + core @ (d[:, None] * cross * d[None, :]) @ core
    return s2 * (d[:, None] * core * d[None, :])


def _keys(terms: Sequence[EffectTerm]) -> tuple[str, ...]:
    """The fitted keys of ``terms``, each once (terms may share parameters)."""
    return tuple(dict.fromkeys(k for t in terms for k in t.keys()))


def candidate_columns(problem: Problem, current: Fit, terms: Sequence[EffectTerm],
                      scales: Mapping[str, float], step: float = 1e-3) -> np.ndarray:
    """Weighted, stacked sensitivities of the model at ``current`` to the fitted
    parameters of a candidate's ``terms`` (forward differences of ``step`` natural sizes
    from their start), per unit of each parameter, shape (n, k).

    A candidate starts at its neutral values, where it changes nothing (the effect
    contract), so the differences are taken from the current model itself (``problem``
    is the one ``current`` was fitted to)."""
    terms = tuple(terms)
    keys = _keys(terms)
    both = current.terms + terms
    predict = problem.predict(both)
    theta = {**current.theta, **{k: v for k, v in problem.predictor(both).theta0.items()
                                 if k in keys}}
    base = current.model
    cols = []
    for key in keys:
        h = step * scales[key]
        moved = dict(theta)
        moved[key] = theta[key] + h
        cols.append(stack(problem.weights * (np.asarray(predict(moved)) - base)) / h)
    return np.column_stack(cols)


def score(current: Fit, columns: np.ndarray, start: np.ndarray,
          minimum: Sequence[float | None]) -> tuple[float, np.ndarray]:
    """Predicted chi2 drop of adding parameters with sensitivity ``columns`` to the
    ``current`` fit (Gauss-Newton, the current parameters refitted too), and the
    predicted values of the new parameters.

    A new parameter whose predicted value falls below its ``minimum`` is held at the
    bound (one-sided test): the other new parameters are rescored without it.

    Returns
    -------
    drop : float
    values : ndarray, shape (k,)
    """
    Q, _ = np.linalg.qr(current.jacobian)
    A = columns - Q @ (Q.T @ columns)
    r = current.residual
    free = np.ones(A.shape[1], dtype=bool)
    values = np.array(start, dtype=float)
    for _ in range(A.shape[1] + 1):
        if not free.any():
            return 0.0, values
        Af = A[:, free]
        delta, *_ = np.linalg.lstsq(Af, r, rcond=None)
        cand = values.copy()
        cand[free] = start[free] + delta
        low = np.array([m is not None and c < m for c, m in zip(cand, minimum, strict=True)])
        if not low[free].any():
            fitted = Af @ delta
            return float(2 * fitted @ r - fitted @ fitted), cand
        free &= ~low
        values[low] = [m for m, b in zip(minimum, low, strict=True) if b]
    return 0.0, values


def refit_error(exc: Exception) -> str:
    """A refit's failure as a short message for the candidates table."""
    if isinstance(exc, IdentifiabilityError):
        return f"not separable: {exc}"
    if isinstance(exc, ModelError | ValueError):
        return f"model refused: {exc}"
    return f"{type(exc).__name__}: {exc}"


__all__ = ["APPENDED_PARAMETERS", "ExtraModes", "Fit", "Problem", "candidate_columns", "covariance",
           "evaluate", "fit", "fit_magnitude", "mode_basis", "pole_columns", "refit_error",
           "score", "stack", "with_mounting", "with_offsets"]
