"""Test systems for the simulate room, built from first principles (M, C, K)."""

from __future__ import annotations

from dataclasses import dataclass
from types import SimpleNamespace

import numpy as np
import pytest
import scipy.linalg
import scipy.signal

from truthbench.simulate import CoulombFriction, prepare_lti


@dataclass(frozen=True)
class System:
    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    dt: float
    name: str


def second_order(m, c, k, b_force):
    """First-order form of ``M q'' + C q' + K q = b_force u``; state ``[q, q']``."""
    n = m.shape[0]
    m_inv = np.linalg.inv(m)
    a = np.block([[np.zeros((n, n)), np.eye(n)], [-m_inv @ k, -m_inv @ c]])
    b = np.vstack([np.zeros((n, b_force.shape[1])), m_inv @ b_force])
    return a, b


def three_mode() -> System:
    """Lightly damped 3-DOF chain, non-proportional (discrete) damping, 1 in, 2 out.

    Outputs: displacement of mass 3 (m) and acceleration of mass 1 (m/s^2), the latter
    with a direct feedthrough D != 0. Modes near 5.7, 21.4 and 27.1 Hz with damping
    ratios 1.3 %, 0.35 % and 0.19 %.
    """
    m = np.diag([1.0, 2.0, 1.5])
    k = np.array([[2e4, -1e4, 0.0], [-1e4, 3e4, -2e4], [0.0, -2e4, 2e4]])
    c = np.diag([0.5, 0.0, 3.0])  # dampers to ground at masses 1 and 3: not Rayleigh
    a, b = second_order(m, c, k, np.array([[1.0], [0.0], [0.0]]))
    cc = np.vstack([np.eye(6)[2], a[3]])
    d = np.vstack([[0.0], b[3]])
    return System(a, b, cc, d, 1e-3, "three_mode")


def free_free() -> System:
    """Free-free pair of masses joined by a spring and a damper: a rigid-body mode.

    ``A`` has a defective double eigenvalue at 0 (rigid displacement and velocity).
    Outputs: both displacements and the velocity of mass 2.
    """
    m = np.diag([1.0, 2.0])
    k = 1e3 * np.array([[1.0, -1.0], [-1.0, 1.0]])
    c = 2.0 * np.array([[1.0, -1.0], [-1.0, 1.0]])
    a, b = second_order(m, c, k, np.array([[1.0], [0.0]]))
    cc = np.array([[1.0, 0, 0, 0], [0, 1.0, 0, 0], [0, 0, 0, 1.0]])
    return System(a, b, cc, np.zeros((3, 1)), 1e-3, "free_free")


def random_stable(seed: int = 3, n: int = 6) -> System:
    """Random dense stable A (spectral abscissa -0.2 1/s), 2 inputs, 3 outputs, D != 0."""
    rng = np.random.default_rng(seed)
    a = rng.standard_normal((n, n))
    a -= (np.max(np.linalg.eigvals(a).real) + 0.2) * np.eye(n)
    return System(
        a,
        rng.standard_normal((n, 2)),
        rng.standard_normal((3, n)),
        rng.standard_normal((3, 2)),
        0.05,
        "random_stable",
    )


def free_free_chain(n_mass: int = 6, seed: int = 4) -> System:
    """Free-free spring-damper chain: rigid-body mode plus n_mass - 1 flexible modes."""
    rng = np.random.default_rng(seed)
    m = np.diag(rng.uniform(0.5, 2.0, n_mass))
    k = np.zeros((n_mass, n_mass))
    c = np.zeros((n_mass, n_mass))
    for i in range(n_mass - 1):
        e = np.zeros(n_mass)
        e[i], e[i + 1] = 1.0, -1.0
        k += 1e5 * (1 + i) * np.outer(e, e)
        c += 3.0 * np.outer(e, e)
    a, b = second_order(m, c, k, np.eye(n_mass)[:, [0, n_mass // 2]])
    n = 2 * n_mass
    cc = np.eye(n)[[0, n_mass - 1, n - 1]]
    return System(a, b, cc, np.zeros((3, 2)), 5e-4, "free_free_chain")


def modal_rigid(seed: int = 6) -> System:
    """Modal-coordinate model with two rigid-body modes (exact ``[[0, 1], [0, 0]]``
    Jordan blocks) and eight 1 %-damped flexible modes from 5 to 500 Hz; 1 in, 3 out."""
    rng = np.random.default_rng(seed)
    omega = np.r_[0.0, 0.0, 2 * np.pi * np.geomspace(5.0, 500.0, 8)]
    zeta = np.r_[0.0, 0.0, np.full(8, 0.01)]
    blocks = [
        np.array([[0.0, 1.0], [-(w**2), -2 * z * w]]) for w, z in zip(omega, zeta, strict=True)
    ]
    a = scipy.linalg.block_diag(*blocks)
    n = a.shape[0]
    b = np.zeros((n, 1))
    b[1::2, 0] = rng.standard_normal(omega.size)
    c = np.zeros((3, n))
    c[:, 0::2] = rng.standard_normal((3, omega.size))
    return System(a, b, c, np.zeros((3, 1)), 2.5e-4, "modal_rigid")


SYSTEMS = {
    s.name: s
    for s in (three_mode(), free_free(), random_stable(), free_free_chain(), modal_rigid())
}


@pytest.fixture(params=sorted(SYSTEMS))
def system(request) -> System:
    return SYSTEMS[request.param]


def relative_error(y, ref) -> float:
    """Largest ``max_t |y - ref| / rms(ref)`` over the output channels."""
    rms = np.sqrt(np.mean(ref**2, axis=-1))
    return float(np.max(np.max(np.abs(y - ref), axis=-1) / rms))


# ----------------------------------------------------------------------------------
# rounding: how far two evaluations of one recursion may differ
# ----------------------------------------------------------------------------------

#: Standard deviations of :func:`engine_rounding_sigma` allowed between two engines. A
#: normal variable exceeds 6 sigma with probability 2e-9, and the sigma below is an upper
#: bound (each rounding counted at its largest, ``u`` times the sum of the absolute
#: values of the terms), so a rounding difference outside it is not a matter of chance:
#: it is an error of an engine.
ENGINE_SIGMAS = 6.0


def engine_rounding_sigma(rec, u, x0=None) -> np.ndarray:
    """Standard deviation of the difference of two engines' outputs, from rounding alone.

    The numba and numpy engines evaluate the same recursion of ``rec``
    (``y = D u + Cb xi + Re(Cm z)``, ``xi' = Ad xi + Bd0 u_j + Bd1 u_j+1``,
    ``z' = lam z + w0 q_j + w1 q_j+1`` with ``q = Bm u``) in float64, in different
    orders (one fused loop with FMA contraction and reassociated sums against
    ``lfilter`` per mode and BLAS products), so they differ by rounding only.

    Model (probabilistic rounding-error analysis; Higham and Mary, SIAM J. Sci. Comput.
    41 (2019) A2815): every operation returns the exact result times ``1 + d``,
    ``|d| <= u = eps / 2``, the ``d`` independent with mean zero. What it counts, per
    step and real component:

    * a mode: ``1 + 2 n_in`` terms (``lam z`` and ``w Bm_p u_p`` at both ends of the
      step), each at most two complex products (three roundings per real component) and
      an addition: ``7 (1 + 2 n_in)`` roundings, each at most ``u s`` with
      ``s = |lam||z| + |w0||Bm||u_j| + |w1||Bm||u_j+1|``; two real components;
    * the dense block: ``k + 2 n_in`` terms, a product and an addition each, at most
      ``u (|Ad||xi| + |Bd0||u_j| + |Bd1||u_j+1|)``;
    * an output sample: ``m`` complex products (real part: three roundings) and
      ``k + n_in`` real ones, one addition each, at most
      ``u (|Cm||z| + |Cb||xi| + |D||u_j|)``.

    A local error is then carried by the recursion itself, exactly as the state:
    ``v' = |lam|^2 v + r (u s)^2`` per mode, ``V' = Ad V Ad^T + diag(r (u s)^2)`` for
    the block, reaching the output as ``sum |Cm|^2 v + Cb V Cb^T`` plus the output's
    own rounding. This is the module docstring's ``cond * 1e-16``, made precise: modal
    contributions ``|Cm||z|`` far larger than ``|y|`` (an ill-conditioned ``V``) raise
    the output terms, and a marginally stable block (``Ad^k`` of a rigid-body mode grows
    like ``k``) accumulates its errors over the record. Two engines round
    independently: their difference has twice the variance of one. The state sizes
    ``|z|``, ``|xi|`` come from a plain numpy run of the recursion (only their size
    matters).

    Parameters
    ----------
    rec : truthbench.simulate.LtiRecursion
    u : ndarray, shape (n_inputs, n_samples)
    x0 : ndarray, shape (n_states,), optional

    Returns
    -------
    ndarray, shape (n_outputs, n_samples)
        Standard deviation of ``y_a - y_b`` at each output and sample.
    """
    unit = np.finfo(float).eps / 2
    u = np.asarray(u, dtype=float).reshape(rec.n_inputs, -1)
    n_in, n = u.shape
    m, k = rec.n_modes, rec.n_block
    x0 = np.zeros(rec.n_states) if x0 is None else np.asarray(x0, dtype=float)
    au = np.abs(u)
    var = np.zeros((rec.n_outputs, n))
    s_out = np.abs(rec.d) @ au
    if m:
        q = rec.bm @ u
        aq = np.abs(rec.bm) @ au  # (m, n): |Bm||u|
        z = np.empty((m, n), complex)
        v = np.empty((m, n))
        r_mode = 2 * 7 * (1 + 2 * n_in)
        z0 = rec.to_modal @ x0
        for i in range(m):
            lam, w0, w1 = rec.lam[i], rec.w0[i], rec.w1[i]
            zi = np.array([z0[i] - w1 * q[i, 0]])
            z[i] = scipy.signal.lfilter([w1, w0], [1.0, -lam], q[i], zi=zi)[0]
            s = abs(lam) * np.abs(z[i, :-1]) + abs(w0) * aq[i, :-1] + abs(w1) * aq[i, 1:]
            # numpy starts from the filter state z0 - w1 q_0: two more roundings
            start = 2 * 2 * (unit * (abs(z0[i]) + abs(w1) * aq[i, 0])) ** 2
            local = r_mode * (unit * s) ** 2
            v[i] = scipy.signal.lfilter([1.0], [1.0, -abs(lam) ** 2],
                                        np.concatenate([[start], local]))
        var += np.abs(rec.cm) ** 2 @ v
        s_out += np.abs(rec.cm) @ np.abs(z)
    if k:
        r_blk = 2 * (k + 2 * n_in)
        forcing = rec.bd0 @ u[:, :-1] + rec.bd1 @ u[:, 1:]
        a_forcing = np.abs(rec.bd0) @ au[:, :-1] + np.abs(rec.bd1) @ au[:, 1:]
        xi = rec.to_block @ x0
        cov = np.zeros((k, k))
        abs_xi = np.empty((k, n))
        for j in range(n):
            abs_xi[:, j] = np.abs(xi)
            var[:, j] += np.einsum("ok,kl,ol->o", rec.cb, cov, rec.cb)
            if j == n - 1:
                break
            s = np.abs(rec.ad) @ np.abs(xi) + a_forcing[:, j]
            xi = rec.ad @ xi + forcing[:, j]
            cov = rec.ad @ cov @ rec.ad.T + np.diag(r_blk * (unit * s) ** 2)
        s_out += np.abs(rec.cb) @ abs_xi
    r_out = 4 * m + 2 * (k + n_in)
    var += r_out * (unit * s_out) ** 2
    return np.sqrt(2.0 * var)


def assert_within_rounding(y, ref, sigma, n_sigma: float = ENGINE_SIGMAS, extra=0.0) -> None:
    """Assert ``|y - ref| <= n_sigma * sigma + extra`` at every output and sample.

    ``extra`` (broadcast like ``sigma``) is a further allowance that is no rounding,
    e.g. the event-time term of :func:`nonlinear_engine_bound`.
    """
    y, ref = np.atleast_2d(y), np.atleast_2d(ref)
    sigma = np.broadcast_to(sigma, y.shape)
    allowed = n_sigma * sigma + extra
    excess = np.abs(y - ref) - allowed
    if np.any(excess > 0):
        o, j = np.unravel_index(np.argmax(excess / np.maximum(allowed, np.finfo(float).tiny)),
                                excess.shape)
        diff = abs(y[o, j] - ref[o, j])
        raise AssertionError(
            f"|y - ref| = {diff:.3g} at output {o}, sample {j}: {diff / sigma[o, j]:.3g} "
            f"sigma of rounding (sigma = {sigma[o, j]:.3g}; allowed {n_sigma:g} sigma"
            + (f" + {np.broadcast_to(extra, y.shape)[o, j]:.3g}" if np.any(extra) else "")
            + ")"
        )



def assert_detects(ref, sigma, extra=0.0, level: float = 1e-9,
                   n_sigma: float = ENGINE_SIGMAS) -> None:
    """Assert that the allowance of :func:`assert_within_rounding` is below ``level``
    times the RMS of each record of ``ref``: an error that large anywhere would fail."""
    ref = np.atleast_2d(ref)
    allowed = n_sigma * np.broadcast_to(sigma, ref.shape) + extra
    rms = np.sqrt(np.mean(ref**2, axis=1))
    worst = np.max(allowed, axis=1) / rms
    assert np.all(worst < level), f"the allowance reaches {worst.max():.3g} of the RMS"

#: Each engine accepts an event time when its Newton correction is below 1e-12 dt
#: (``_EVENT_TTOL`` of the kernel; "to 1e-12 dt" in the nonlinear module docstring), so
#: two evaluations may place one event up to 2e-12 dt apart.
EVENT_TIME_TOL = 2e-12


def nonlinear_engine_bound(a, b, elements, u, dt, res, rows, feedthrough=None, x0=None):
    """How far two evaluations of one nonlinear simulation may differ in a record.

    The record is ``r = rows @ x + feedthrough @ w`` with ``w = [u; f_nl]`` (an output,
    an element velocity, a holding force). Between events the nonlinear engines advance
    the exact linear recursion of ``x' = A x + [B, B_nl] w``, the element forces being
    inputs like ``u`` (the smooth ones solved by Newton's method to rounding; their
    feedback on an error, ``df/dd`` against the structure's stiffness, is neglected).
    So the rounding part is :func:`engine_rounding_sigma` of that linear system driven by
    the recorded ``w``. On top, every friction event (a reversal, a stick, a breakaway:
    ``n_reversals + 2 n_stick_events``) may be placed ``EVENT_TIME_TOL * dt`` apart by
    the two, which moves a force jump ``|dF| <= 2 F_c`` by that time: an impulse
    ``b_e dF t_tol`` whose effect on the record is at most its peak impulse response;
    the events are added at their worst (all of one sign), over the whole record.

    Parameters
    ----------
    a, b : ndarray
        ``A`` (n, n) and ``B`` (n, n_in) of the linear part.
    elements : sequence of NonlinearElement
    u : ndarray, shape (n_in, n_samples)
    dt : float
    res : NonlinearResult
        One of the two evaluations (for the forces and the event counts).
    rows : ndarray, shape (n_rec, n)
    feedthrough : ndarray, shape (n_rec, n_in + n_nl), optional
    x0 : ndarray, shape (n,), optional

    Returns
    -------
    sigma : ndarray, shape (n_rec, n_samples)
        Rounding standard deviation of the difference (:func:`engine_rounding_sigma`).
    extra : ndarray, shape (n_rec, 1)
        The event-time allowance, for :func:`assert_within_rounding`.
    """
    n = a.shape[0]
    u = np.atleast_2d(u)
    b_nl = np.stack([el.force_column for el in elements], axis=1) if elements else \
        np.zeros((n, 0))
    w = np.vstack([u, res.f_nl])
    d = np.zeros((rows.shape[0], w.shape[0])) if feedthrough is None else feedthrough
    sigma = engine_rounding_sigma(prepare_lti(a, np.hstack([b, b_nl]), rows, d, dt), w, x0)
    extra = np.zeros((rows.shape[0], 1))
    free = prepare_lti(a, np.zeros((n, 1)), rows, None, dt)
    for e, el in enumerate(elements):
        if isinstance(el.law, CoulombFriction):
            n_events = int(res.n_reversals[e]) + 2 * int(res.n_stick_events[e])
            peak = np.abs(free.simulate(np.zeros((1, u.shape[1])), x0=el.force_column))
            extra[:, 0] += n_events * 2 * el.law.force_n * EVENT_TIME_TOL * dt * peak.max(axis=1)
    return sigma, extra


@pytest.fixture
def systems() -> dict[str, System]:
    return SYSTEMS


@pytest.fixture
def rel_err():
    return relative_error


@pytest.fixture
def rounding():
    """The rounding bounds of two engines: ``sigma`` (:func:`engine_rounding_sigma`),
    ``nonlinear`` (:func:`nonlinear_engine_bound`), ``check``
    (:func:`assert_within_rounding`) and ``detects`` (:func:`assert_detects`)."""
    return SimpleNamespace(sigma=engine_rounding_sigma, nonlinear=nonlinear_engine_bound,
                           check=assert_within_rounding, detects=assert_detects)
