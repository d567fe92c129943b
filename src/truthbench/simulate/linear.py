"""Exact sampled-input simulation of continuous linear time-invariant systems.

The system is ``x' = A x + B u``, ``y = C x + D u`` (SI units throughout; time in
seconds). The input is known at the samples ``t_j = j dt`` and, between samples, is
either linear (first-order hold, ``hold="foh"``, what ``control.forced_response``
assumes) or constant (zero-order hold, ``hold="zoh"``). For such inputs the sampled
response is exact up to rounding: no integration error, whatever ``dt``.

Method
------
``A`` is first balanced by an exact power-of-two diagonal similarity. Then

* **modal** (the fast path): ``A = V diag(s) V^-1``. Each mode is a first-order complex
  recursion ``z[j+1] = exp(s dt) z[j] + w0(s) b u[j] + w1(s) b u[j+1]`` whose weights
  are exact for a piecewise-linear input,
  ``w1 = dt phi2(s dt)``, ``w0 = dt (phi1(s dt) - phi2(s dt))`` (FOH) or
  ``w0 = dt phi1(s dt)``, ``w1 = 0`` (ZOH), with ``phi1(a) = (e^a - 1)/a`` and
  ``phi2(a) = (e^a - 1 - a)/a^2`` (Taylor series near ``a = 0``, so rigid-body
  ``s = 0`` modes are fine). Of each complex-conjugate pair only one mode is advanced
  and the output takes ``2 Re``. ``y = Re(C V z) + D u``.
* **block** (used when ``V`` is ill-conditioned, ``||V||_F ||V^-1||_F > 1e8``, typically
  because ``A`` is defective: the double zero eigenvalue of a rigid-body mode of a
  free-free structure, whose position and velocity form a Jordan block, or a critically
  damped mode): the ill-conditioned eigenvalues (small ``|left^H right|`` of unit
  eigenvectors) are moved to the top of a reordered real Schur form and split off by a
  Sylvester equation (Bavely-Stewart block diagonalisation); that small block is
  advanced by its exact matrix-exponential discretisation (see :func:`discretize`) and
  the rest stays modal. A block whose eigenvalues are zero to within rounding (rigid-body
  modes) is made exactly nilpotent first, so the rigid-body motion is integrated
  exactly instead of drifting with the ``+-sqrt(eps ||A||)`` spurious eigenvalues that
  any computation on ``A`` (``expm`` included) produces for a Jordan block.
* **state** (last resort, or on request): the whole state is advanced with
  ``x[j+1] = Ad x[j] + Bd0 u[j] + Bd1 u[j+1]`` from :func:`discretize`.

Accuracy: each path is exact for the held input up to rounding; the rounding error of
the output relative to its RMS is about ``cond * 1e-16`` (``LtiRecursion.cond``),
plus the accumulation that any recursion shows for marginally stable (rigid-body)
states. Against ``control.forced_response`` the tests see 1e-13 (modal systems) to
1e-10 (soft free-free systems), where forced_response's own rounding is of the same
size; on stiff free-free models (modes to 1e6 rad/s) forced_response and the ``state``
path drift by 1e-6 to 1e-4 in the rigid-body motion, which the block path keeps at
1e-13 (momentum oracle in the tests).

Each path runs on one of two engines with identical results to rounding: a fused
``numba.njit(cache=True)`` loop (used automatically when numba, the optional ``fast``
extra, can be imported) or numpy/``scipy.signal.lfilter`` (always available).

This room (``truthbench.simulate``) owns excitation signals, sensor noise and time
simulation; this module owns the linear part. The pieces of the method above that the
nonlinear engine (:mod:`~truthbench.simulate.nonlinear`) uses as well -- the entry checks,
the eigen-decomposition and conjugate pairing, the defective-block split and rigid-body
snap, the exact (Van Loan) discretisation and the ``phi`` functions -- live in the
private module ``truthbench.simulate._exact``.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Literal

import numpy as np
import scipy.linalg

from truthbench._validation import readonly
from truthbench.errors import ModelError

from ._exact import (
    COND_MAX,
    KAPPA_DEFECTIVE,
    block_split,
    check_dt,
    check_hold,
    check_input,
    check_system,
    check_x0,
    defective_selection,
    eig,
    pairs,
    phi12,
    snap_zero_cluster,
    van_loan,
)
from ._kernels import run_numpy

__all__ = [
    "LtiRecursion",
    "discretize",
    "numba_available",
    "prepare_lti",
    "simulate_lti",
    "simulate_statespace",
]

Hold = Literal["foh", "zoh"]
Method = Literal["auto", "modal", "state"]
Backend = Literal["auto", "numba", "numpy"]

# ----------------------------------------------------------------------------------
# engines
# ----------------------------------------------------------------------------------


@functools.cache
def numba_available() -> bool:
    """Whether the optional numba engine can be used (numba and the kernel module import).

    Returns
    -------
    bool
    """
    try:
        from . import _kernels_numba  # noqa: F401
    except ImportError:
        return False
    return True


def _engine(backend: str):
    if backend not in ("auto", "numba", "numpy"):
        raise ValueError(
            f"backend must be one of 'auto', 'numba', 'numpy'; got {backend!r} instead"
        )
    if backend == "numpy" or (backend == "auto" and not numba_available()):
        return run_numpy
    if not numba_available():
        raise ImportError(
            "backend='numba' was requested but numba cannot be imported; install the "
            "'fast' extra (pip install truthbench[fast]) or use backend='numpy'"
        )
    from ._kernels_numba import run_numba

    return run_numba


# ----------------------------------------------------------------------------------
# discretisation
# ----------------------------------------------------------------------------------


def discretize(A, B, dt: float, hold: Hold = "foh"):
    """Exact discretisation of ``x' = A x + B u`` for a held input.

    The result advances the state over one step,
    ``x[j+1] = Ad x[j] + Bd0 u[j] + Bd1 u[j+1]``, exactly when ``u`` is linear between
    samples (``"foh"``) or constant over each step (``"zoh"``, then ``Bd1 = 0``). It is
    computed from one matrix exponential of the augmented matrix
    ``[[A dt, B dt, 0], [0, 0, I], [0, 0, 0]]`` (Van Loan; the same construction as
    ``control.forced_response``), so it is valid for any ``A`` (defective, singular,
    unstable). Real or complex ``A`` and ``B`` are accepted; the result has their dtype.

    Parameters
    ----------
    A : array_like, shape (n, n)
        State matrix, 1/s.
    B : array_like, shape (n, n_in)
        Input matrix (state units per input unit per s).
    dt : float
        Sampling interval, s; must be positive.
    hold : {"foh", "zoh"}
        Inter-sample behaviour of the input.

    Returns
    -------
    Ad : ndarray, shape (n, n)
        ``expm(A dt)``.
    Bd0 : ndarray, shape (n, n_in)
        Weight of ``u[j]``.
    Bd1 : ndarray, shape (n, n_in)
        Weight of ``u[j+1]`` (zeros for ``"zoh"``). For ``"foh"``, ``Bd0 + Bd1`` equals
        the zero-order-hold ``Bd0``.

    Raises
    ------
    ModelError
        If ``A`` is not square or ``B`` has a different number of rows.
    ValueError
        If ``dt`` is not positive and finite or ``hold`` is unknown.
    """
    dt = check_dt(dt)
    hold = check_hold(hold)
    a = np.asarray(A)
    b = np.asarray(B)
    if a.ndim != 2 or a.shape[0] != a.shape[1]:
        raise ModelError(f"matrix A must be square; got shape {a.shape}")
    if b.ndim != 2 or b.shape[0] != a.shape[0]:
        raise ModelError(
            f"matrix B has the wrong number of rows; expected {a.shape[0]} instead of "
            f"{b.shape[0] if b.ndim == 2 else b.shape} (got shape {b.shape})"
        )
    if not (np.all(np.isfinite(a)) and np.all(np.isfinite(b))):
        raise ModelError("matrices A and B must be finite; got nan or inf")
    dtype = np.result_type(a, b, float)
    return van_loan(a.astype(dtype), b.astype(dtype), dt, hold)


# ----------------------------------------------------------------------------------
# the prepared recursion
# ----------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class LtiRecursion:
    """A continuous LTI system prepared for exact sampled simulation at a fixed ``dt``.

    Made by :func:`prepare_lti`; reuse it to simulate many inputs of the same system
    (the eigen/Schur decomposition is done once). The arrays are read-only.

    Attributes
    ----------
    dt : float
        Sampling interval, s.
    hold : {"foh", "zoh"}
        Inter-sample behaviour of the input.
    path : {"modal", "block", "state"}
        Which realisation was chosen (see the module docstring).
    n_states, n_inputs, n_outputs : int
        Dimensions of the continuous system.
    n_modes : int
        Number of complex first-order modal recursions advanced (one per conjugate pair).
    n_block : int
        Size of the dense block advanced by its matrix exponential (0 on the modal path,
        ``n_states`` on the state path).
    cond : float
        Frobenius-norm condition number of the transformation from the (balanced) state
        to the recursion coordinates (1 on the state path); the relative rounding error
        of the output is roughly ``cond * 1e-16``.
    poles : ndarray, shape (n_states,), complex
        Eigenvalues of ``A``, 1/s (as computed; a defective eigenvalue is only accurate
        to about ``sqrt(1e-16)`` relative).
    """

    dt: float
    hold: str
    path: str
    n_states: int
    n_inputs: int
    n_outputs: int
    cond: float
    d: np.ndarray  # (n_out, n_in)
    ad: np.ndarray  # (k, k)
    bd0: np.ndarray  # (k, n_in)
    bd1: np.ndarray  # (k, n_in)
    cb: np.ndarray  # (n_out, k)
    to_block: np.ndarray  # (k, n): x0 -> xi0
    lam: np.ndarray  # (m,) complex, exp(s dt)
    bm: np.ndarray  # (m, n_in) complex, modal input matrix (rows of V^-1 B)
    w0: np.ndarray  # (m,) complex, hold weight of u[j]
    w1: np.ndarray  # (m,) complex, hold weight of u[j+1]
    cm: np.ndarray  # (n_out, m) complex, pair weight folded in
    to_modal: np.ndarray  # (m, n) complex: x0 -> z0
    poles: np.ndarray  # (n,) complex continuous-time eigenvalues of A, 1/s

    @property
    def n_modes(self) -> int:
        return int(self.lam.shape[0])

    @property
    def n_block(self) -> int:
        return int(self.ad.shape[0])

    def simulate(self, u, x0=None, backend: Backend = "auto") -> np.ndarray:
        """Sampled response to the input ``u`` from the initial state ``x0``.

        Parameters
        ----------
        u : array_like, shape (n_inputs, n_samples)
            Input samples at ``t_j = j dt`` (a 1-D array is accepted for one input).
        x0 : array_like, shape (n_states,), optional
            State at ``t_0``; zeros by default.
        backend : {"auto", "numba", "numpy"}
            Engine; ``"auto"`` uses numba when it imports.

        Returns
        -------
        y : ndarray, shape (n_outputs, n_samples)
            Output samples at ``t_j``.
        """
        run = _engine(backend)
        uu = check_input(u, self.n_inputs)
        x = check_x0(x0, self.n_states)
        xi0 = self.to_block @ x
        z0 = self.to_modal @ x
        return run(
            uu,
            self.d,
            self.ad,
            self.bd0,
            self.bd1,
            self.cb,
            xi0,
            self.lam,
            self.bm,
            self.w0,
            self.w1,
            self.cm,
            z0.astype(complex),
        )


def _modal_parts(s, v, vinv, b, c, to_state, dt, hold):
    """Modal recursion pieces for a diagonalisable real block ``w' = T w + b u``.

    ``T = v diag(s) vinv``; ``c`` is the block's output matrix and ``to_state`` maps the
    full (balanced) state to the block's coordinates ``w``. Returns None when the
    eigenvalues do not come in exact conjugate pairs.
    """
    sel = pairs(s)
    if sel is None:
        return None
    keep, weight = sel
    # explicit complex casts: numpy's mixed real/complex matmul bypasses BLAS (slow)
    vinv_k = vinv[keep]
    vinv_b = vinv_k @ b.astype(complex)  # (m, n_in)
    to_modal = vinv_k @ to_state.astype(complex)  # (m, n)
    cm = (c.astype(complex) @ v[:, keep]) * weight  # (n_out, m)
    a = s[keep] * dt
    phi1, phi2 = phi12(a)
    if hold == "foh":
        w0, w1 = dt * (phi1 - phi2), dt * phi2
    else:
        w0, w1 = dt * phi1, np.zeros_like(phi1)
    lam = np.exp(a)
    return dict(lam=lam, bm=vinv_b, w0=w0, w1=w1, cm=cm, to_modal=to_modal)


def prepare_lti(A, B, C, D, dt: float, hold: Hold = "foh", method: Method = "auto") -> LtiRecursion:
    """Prepare ``x' = A x + B u, y = C x + D u`` for exact simulation at step ``dt``.

    Parameters
    ----------
    A : array_like, shape (n, n)
        State matrix, 1/s.
    B : array_like, shape (n, n_in)
        Input matrix.
    C : array_like, shape (n_out, n)
        Output matrix.
    D : array_like, shape (n_out, n_in), or None
        Feedthrough matrix; None means zeros.
    dt : float
        Sampling interval, s.
    hold : {"foh", "zoh"}
        Input between samples: linear (``"foh"``, as ``control.forced_response``) or
        constant (``"zoh"``, as ``scipy.signal.cont2discrete(..., "zoh")``).
    method : {"auto", "modal", "state"}
        ``"auto"``: modal when the eigenvector matrix is well conditioned
        (``||V||_F ||V^-1||_F <= 1e8`` after balancing), else split the ill-conditioned
        eigenvalues off into a small matrix-exponential block, else (if that split is
        itself ill-conditioned) the full state recursion. ``"modal"`` forces the
        diagonal path (and raises if it is ill-conditioned); ``"state"`` forces the full
        matrix-exponential state recursion (the reference construction, equal to
        ``control.forced_response``, but slow for many states and without the
        rigid-body correction of the block path).

    Returns
    -------
    LtiRecursion

    Raises
    ------
    ModelError
        If a matrix is not 2-D, not finite, or the shapes are inconsistent.
    ValueError
        If ``dt`` is not positive and finite, ``hold`` or ``method`` is unknown, or
        ``method="modal"`` is impossible.
    """
    a, b, c, d = check_system(A, B, C, D)
    dt = check_dt(dt)
    hold = check_hold(hold)
    if method not in ("auto", "modal", "state"):
        raise ValueError(f"method must be one of 'auto', 'modal', 'state'; got {method!r} instead")
    n, n_in = b.shape
    n_out = c.shape[0]

    # exact power-of-two diagonal balancing: ab = S^-1 a S, balanced state = S^-1 x
    if n:
        _, (scale, _) = scipy.linalg.matrix_balance(a, permute=False, separate=True)
    else:
        scale = np.ones(0)
    ab = a * scale[None, :] / scale[:, None]
    bb = b / scale[:, None]
    cb = c * scale[None, :]
    to_balanced = np.diag(1.0 / scale)

    def build(path, cond, poles, block=None, modal=None):
        parts = dict(
            ad=np.zeros((0, 0)),
            bd0=np.zeros((0, n_in)),
            bd1=np.zeros((0, n_in)),
            cb=np.zeros((n_out, 0)),
            to_block=np.zeros((0, n)),
            lam=np.zeros(0, complex),
            bm=np.zeros((0, n_in), complex),
            w0=np.zeros(0, complex),
            w1=np.zeros(0, complex),
            cm=np.zeros((n_out, 0), complex),
            to_modal=np.zeros((0, n), complex),
        )
        parts.update(block or {})
        parts.update(modal or {})
        return LtiRecursion(
            dt=dt,
            hold=hold,
            path=path,
            n_states=n,
            n_inputs=n_in,
            n_outputs=n_out,
            cond=float(cond),
            d=readonly(np.ascontiguousarray(d)),
            poles=readonly(np.ascontiguousarray(poles, complex)),
            **{key: readonly(np.ascontiguousarray(val)) for key, val in parts.items()},
        )

    def state_path(poles):
        ad, bd0, bd1 = van_loan(ab, bb, dt, hold)
        block = dict(ad=ad, bd0=bd0, bd1=bd1, cb=cb, to_block=to_balanced)
        return build("state", 1.0, poles, block=block)

    if n == 0:
        return build("modal", 1.0, np.zeros(0))
    if method == "state":
        return state_path(np.linalg.eigvals(ab))

    s, v, vinv, cond_v = eig(ab)
    a_norm = float(np.linalg.norm(ab))
    # a nearly defective eigenvalue at ~0 (rigid-body pair) may pass the global test on a
    # small or soft model; it belongs in the block path, where it is integrated exactly
    near_rigid = (
        method == "auto"
        and vinv is not None
        and bool(
            np.any((np.linalg.norm(vinv, axis=1) > KAPPA_DEFECTIVE) & (np.abs(s) <= 1e-6 * a_norm))
        )
    )
    if cond_v <= COND_MAX and not near_rigid:
        modal = _modal_parts(s, v, vinv, bb, cb, to_balanced, dt, hold)
        if modal is not None:
            return build("modal", cond_v, s, modal=modal)
    if method == "modal":
        raise ValueError(
            "method='modal' needs a diagonalisable A with a well-conditioned eigenvector "
            f"matrix (||V||_F ||V^-1||_F <= {COND_MAX:.0e}); got {cond_v:.3g}. A "
            "defective A (e.g. a rigid-body double integrator) needs method='auto' or "
            "'state'"
        )

    s_lr, bad = defective_selection(ab)
    split = block_split(ab, s_lr, bad) if bad is not None else None
    if split is not None:
        p, pinv, t11, t22 = split
        k = t11.shape[0]
        t11 = snap_zero_cluster(t11, a_norm)
        cond_p = float(np.linalg.norm(p) * np.linalg.norm(pinv))
        s2, v2, v2inv, cond_v2 = eig(t22)
        if cond_p <= COND_MAX and cond_v2 <= COND_MAX:
            bw = pinv @ bb
            cw = cb @ p
            to_w = pinv @ to_balanced
            modal = _modal_parts(s2, v2, v2inv, bw[k:], cw[:, k:], to_w[k:], dt, hold)
            if modal is not None:
                ad, bd0, bd1 = van_loan(t11, bw[:k], dt, hold)
                block = dict(ad=ad, bd0=bd0, bd1=bd1, cb=cw[:, :k], to_block=to_w[:k])
                return build("block", cond_p * cond_v2, s, block=block, modal=modal)
    return state_path(s)


# ----------------------------------------------------------------------------------
# public one-shot functions
# ----------------------------------------------------------------------------------


def simulate_lti(
    A,
    B,
    C,
    D,
    u,
    dt: float,
    x0=None,
    hold: Hold = "foh",
    *,
    method: Method = "auto",
    backend: Backend = "auto",
) -> np.ndarray:
    """Exact sampled response of ``x' = A x + B u``, ``y = C x + D u``.

    Equal (to rounding) to ``control.forced_response(ss(A, B, C, D), T, u, x0)`` with
    ``T = dt * arange(n_samples)`` for ``hold="foh"``, and to
    ``scipy.signal.dlsim(cont2discrete(..., dt, "zoh"), u)`` for ``hold="zoh"``, but
    much faster (see the module docstring for the method).

    Parameters
    ----------
    A : array_like, shape (n, n)
        State matrix, 1/s.
    B : array_like, shape (n, n_in)
        Input matrix.
    C : array_like, shape (n_out, n)
        Output matrix.
    D : array_like, shape (n_out, n_in), or None
        Feedthrough matrix (None: zeros).
    u : array_like, shape (n_in, n_samples)
        Input at ``t_j = j dt``; a 1-D array is accepted when ``n_in == 1``.
    dt : float
        Sampling interval, s.
    x0 : array_like, shape (n,), optional
        Initial state at ``t_0 = 0`` (zeros by default).
    hold : {"foh", "zoh"}
        Input between samples: linear (first-order hold) or constant (zero-order hold).
    method : {"auto", "modal", "state"}
        Realisation (see :func:`prepare_lti`).
    backend : {"auto", "numba", "numpy"}
        Engine; ``"auto"`` uses numba when it can be imported.

    Returns
    -------
    y : ndarray, shape (n_out, n_samples)
        Output at ``t_j``.

    Raises
    ------
    ModelError
        Malformed or inconsistent A, B, C, D.
    ValueError
        ``u`` with the wrong number of rows or non-finite values, ``dt <= 0``, bad
        ``x0``, unknown ``hold``/``method``/``backend``.
    ImportError
        ``backend="numba"`` without numba installed.

    Notes
    -----
    To simulate many inputs for one system, call :func:`prepare_lti` once and
    :meth:`LtiRecursion.simulate` for each input.
    """
    _engine(backend)  # validate before the (costly) preparation
    a, b, _, _ = check_system(A, B, C, D)
    check_input(u, b.shape[1])
    check_x0(x0, a.shape[0])
    rec = prepare_lti(A, B, C, D, dt, hold=hold, method=method)
    return rec.simulate(u, x0=x0, backend=backend)


def simulate_statespace(
    sys,
    u,
    dt: float,
    x0=None,
    hold: Hold = "foh",
    *,
    method: Method = "auto",
    backend: Backend = "auto",
) -> np.ndarray:
    """:func:`simulate_lti` for a continuous-time ``control.StateSpace``.

    Parameters
    ----------
    sys : control.StateSpace
        Continuous-time system (``sys.dt == 0``).
    u, dt, x0, hold, method, backend
        As for :func:`simulate_lti`.

    Returns
    -------
    y : ndarray, shape (n_out, n_samples)

    Raises
    ------
    TypeError
        If ``sys`` is not a ``control.StateSpace``.
    ValueError
        If ``sys`` is a discrete-time system.
    """
    import control

    if not isinstance(sys, control.StateSpace):
        raise TypeError(f"sys must be a control.StateSpace; got {type(sys).__name__} instead")
    if sys.dt not in (0, None) or sys.dt is True:
        raise ValueError(
            f"sys must be a continuous-time system (sys.dt == 0); got sys.dt = {sys.dt!r}"
        )
    return simulate_lti(
        sys.A, sys.B, sys.C, sys.D, u, dt, x0=x0, hold=hold, method=method, backend=backend
    )
