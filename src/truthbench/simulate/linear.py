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
simulation; this module owns the linear part.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
import scipy.linalg

from truthbench.errors import ModelError

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

#: Largest condition number of an eigenvector matrix accepted for the modal path.
COND_MAX = 1e8
#: Eigenvalue condition number (``||left|| ||right|| / |left^H right|``) above which an
#: eigenvalue is moved into the dense block once the modal path has been refused
#: (a defective rigid-body pair has ~1e8 or infinity; moving a merely ill-conditioned
#: eigenvalue there costs speed, never accuracy).
_KAPPA_DEFECTIVE = 1e4
_N_TAYLOR = 20


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
# validation
# ----------------------------------------------------------------------------------


def _matrix(name: str, value, shape: tuple[int | None, int | None]) -> np.ndarray:
    arr = np.asarray(value)
    if np.iscomplexobj(arr):
        raise ModelError(f"matrix {name} must be real; got a complex array")
    try:
        arr = np.array(arr, dtype=float)  # a private copy: inputs are never touched
    except (TypeError, ValueError) as exc:
        raise ModelError(f"matrix {name} must be a real numeric array; got {value!r}") from exc
    if arr.ndim != 2:
        raise ModelError(
            f"matrix {name} must be 2-D with shape {_fmt_shape(shape)}; "
            f"got an array of shape {arr.shape}"
        )
    for axis, (want, got) in enumerate(zip(shape, arr.shape, strict=True)):
        if want is not None and want != got:
            what = "rows" if axis == 0 else "columns"
            raise ModelError(
                f"matrix {name} has the wrong number of {what}; expected {want} instead "
                f"of {got} (expected shape {_fmt_shape(shape)}, got {arr.shape})"
            )
    if not np.all(np.isfinite(arr)):
        raise ModelError(f"matrix {name} contains non-finite values (nan or inf)")
    return arr


def _fmt_shape(shape) -> str:
    return "(" + ", ".join("any" if s is None else str(s) for s in shape) + ")"


def _check_system(A, B, C, D):
    a = _matrix("A", A, (None, None))
    n = a.shape[0]
    if a.shape[1] != n:
        raise ModelError(f"matrix A must be square; got shape {a.shape}")
    b = _matrix("B", B, (n, None))
    c = _matrix("C", C, (None, n))
    if D is None:
        d = np.zeros((c.shape[0], b.shape[1]))
    else:
        d = _matrix("D", D, (c.shape[0], b.shape[1]))
    return a, b, c, d


def _check_dt(dt) -> float:
    try:
        value = float(dt)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"dt must be a positive finite time step in s; got {dt!r}") from exc
    if not math.isfinite(value) or value <= 0.0:
        raise ValueError(f"dt must be a positive finite time step in s; got {dt!r}")
    return value


def _check_hold(hold) -> str:
    if hold not in ("foh", "zoh"):
        raise ValueError(f"hold must be 'foh' or 'zoh'; got {hold!r} instead")
    return hold


def _check_input(u, n_in: int) -> np.ndarray:
    arr = np.asarray(u)
    if np.iscomplexobj(arr):
        raise ValueError("input u must be real; got a complex array")
    arr = np.array(arr, dtype=float)
    if arr.ndim == 1 and n_in == 1:
        arr = arr[np.newaxis, :]
    if arr.ndim != 2:
        raise ValueError(
            f"input u must have shape (n_inputs={n_in}, n_samples); "
            f"got an array of shape {arr.shape}"
        )
    if arr.shape[0] != n_in:
        raise ValueError(
            f"input u has the wrong number of rows; expected {n_in} (one per input, "
            f"shape (n_inputs, n_samples)) instead of {arr.shape[0]} "
            f"(got shape {arr.shape})"
        )
    if arr.shape[1] < 1:
        raise ValueError(f"input u must have at least one sample; got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        bad = np.argwhere(~np.isfinite(arr))[0]
        raise ValueError(
            f"input u must be finite; got a non-finite value at row {bad[0]}, sample {bad[1]}"
        )
    return np.ascontiguousarray(arr)


def _check_x0(x0, n: int) -> np.ndarray:
    if x0 is None:
        return np.zeros(n)
    arr = np.asarray(x0)
    if np.iscomplexobj(arr):
        raise ValueError("initial state x0 must be real; got a complex array")
    arr = np.array(arr, dtype=float)
    if arr.ndim == 2 and arr.shape[1] == 1:  # a column vector is accepted
        arr = arr[:, 0]
    if arr.shape != (n,):
        raise ValueError(f"initial state x0 must have shape ({n},); got shape {np.shape(x0)}")
    if not np.all(np.isfinite(arr)):
        raise ValueError("initial state x0 must be finite; got nan or inf")
    return arr


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
    dt = _check_dt(dt)
    hold = _check_hold(hold)
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
    return _discretize(a.astype(dtype), b.astype(dtype), dt, hold)


def _discretize(a, b, dt, hold):
    n, n_in = b.shape
    if hold == "zoh":
        m = np.zeros((n + n_in, n + n_in), dtype=a.dtype)
        m[:n, :n] = a * dt
        m[:n, n:] = b * dt
        e = scipy.linalg.expm(m)
        return e[:n, :n].copy(), e[:n, n:].copy(), np.zeros_like(b)
    m = np.zeros((n + 2 * n_in, n + 2 * n_in), dtype=a.dtype)
    m[:n, :n] = a * dt
    m[:n, n : n + n_in] = b * dt
    m[n : n + n_in, n + n_in :] = np.eye(n_in)
    e = scipy.linalg.expm(m)
    bd1 = e[:n, n + n_in :].copy()
    bd0 = e[:n, n : n + n_in] - bd1
    return e[:n, :n].copy(), bd0, bd1


def _phi12(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``phi1(a) = (e^a - 1)/a`` and ``phi2(a) = (e^a - 1 - a)/a^2``, accurate at 0."""
    a = np.asarray(a, dtype=complex)
    phi1 = np.empty_like(a)
    phi2 = np.empty_like(a)
    small = np.abs(a) < 0.5
    if np.any(small):
        x = a[small]
        # Horner on sum_k x^k/(k+1)! and sum_k x^k/(k+2)!; error < 0.5^20/20! ~ 4e-25
        p1 = np.full_like(x, 1.0 / math.factorial(_N_TAYLOR + 1))
        p2 = np.full_like(x, 1.0 / math.factorial(_N_TAYLOR + 2))
        for k in range(_N_TAYLOR - 1, -1, -1):
            p1 = p1 * x + 1.0 / math.factorial(k + 1)
            p2 = p2 * x + 1.0 / math.factorial(k + 2)
        phi1[small] = p1
        phi2[small] = p2
    big = ~small
    if np.any(big):
        x = a[big]
        p1 = np.expm1(x) / x
        phi1[big] = p1
        phi2[big] = (p1 - 1.0) / x
    return phi1, phi2


# ----------------------------------------------------------------------------------
# the prepared recursion
# ----------------------------------------------------------------------------------


def _readonly(x: np.ndarray) -> np.ndarray:
    x = np.ascontiguousarray(x)
    x.setflags(write=False)
    return x


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
        uu = _check_input(u, self.n_inputs)
        x = _check_x0(x0, self.n_states)
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


def _pairs(s: np.ndarray):
    """Indices of one mode per conjugate pair (imag > 0) plus real modes, and weights.

    Returns None unless the complex eigenvalues come in exactly conjugate pairs (LAPACK
    returns them so for a real matrix).
    """
    upper = np.flatnonzero(s.imag > 0)
    lower = np.flatnonzero(s.imag < 0)
    real = np.flatnonzero(s.imag == 0)
    if upper.size != lower.size:
        return None
    if not np.array_equal(np.sort_complex(np.conj(s[upper])), np.sort_complex(s[lower])):
        return None
    keep = np.concatenate([upper, real])
    weight = np.concatenate([np.full(upper.size, 2.0), np.ones(real.size)])
    return keep, weight


def _eig(a: np.ndarray):
    """Eigenvalues, unit eigenvectors, their inverse and the Frobenius condition number.

    ``||V||_F ||V^-1||_F`` is an upper bound of the 2-norm condition number (at most
    ``n`` times it) that costs no extra decomposition.
    """
    s, v = np.linalg.eig(a)
    # an exactly defective A gives (numerically) parallel eigenvectors: the inverse may
    # be singular or astronomically large; both mean "not diagonalisable" here
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        try:
            vinv = np.linalg.inv(v)
        except np.linalg.LinAlgError:
            return s, v, None, math.inf
        cond = float(np.linalg.norm(v) * np.linalg.norm(vinv))
    if not (np.all(np.isfinite(vinv)) and math.isfinite(cond)):
        return s, v, None, math.inf
    return s, v, vinv, cond


def _modal_parts(s, v, vinv, b, c, to_state, dt, hold):
    """Modal recursion pieces for a diagonalisable real block ``w' = T w + b u``.

    ``T = v diag(s) vinv``; ``c`` is the block's output matrix and ``to_state`` maps the
    full (balanced) state to the block's coordinates ``w``. Returns None when the
    eigenvalues do not come in exact conjugate pairs.
    """
    sel = _pairs(s)
    if sel is None:
        return None
    keep, weight = sel
    # explicit complex casts: numpy's mixed real/complex matmul bypasses BLAS (slow)
    vinv_k = vinv[keep]
    vinv_b = vinv_k @ b.astype(complex)  # (m, n_in)
    to_modal = vinv_k @ to_state.astype(complex)  # (m, n)
    cm = (c.astype(complex) @ v[:, keep]) * weight  # (n_out, m)
    a = s[keep] * dt
    phi1, phi2 = _phi12(a)
    if hold == "foh":
        w0, w1 = dt * (phi1 - phi2), dt * phi2
    else:
        w0, w1 = dt * phi1, np.zeros_like(phi1)
    lam = np.exp(a)
    return dict(lam=lam, bm=vinv_b, w0=w0, w1=w1, cm=cm, to_modal=to_modal)


def _defective_selection(a: np.ndarray):
    """Eigenvalues of ``a`` and a mask of those that are (nearly) defective.

    The condition number of eigenvalue ``i`` is ``1 / |y_i^H x_i|`` for unit left and
    right eigenvectors ``y_i``, ``x_i`` (infinite for an exactly defective eigenvalue,
    e.g. the ``[[0, 1], [0, 0]]`` block of a rigid-body mode in modal coordinates).
    The mask is closed under conjugation. Returns ``(s, None)`` if nothing is flagged.
    """
    s, vl, vr = scipy.linalg.eig(a, left=True, right=True)
    vl = vl / np.linalg.norm(vl, axis=0)
    vr = vr / np.linalg.norm(vr, axis=0)
    overlap = np.abs(np.sum(np.conj(vl) * vr, axis=0))
    bad = overlap < 1.0 / _KAPPA_DEFECTIVE
    if not np.any(bad):
        return s, None
    return s, bad | np.isin(s, np.conj(s[bad]))


def _block_split(a, s, bad):
    """Real Schur reordering + Sylvester split of the ``bad`` eigenvalues to the top.

    Returns ``(P, Pinv, T11, T22)`` with ``Pinv a P = blkdiag(T11, T22)`` (``T11`` is
    ``k x k``; both blocks quasi-upper-triangular, taken from the Schur form itself), or
    None if the reordering or the split fails.
    """
    bad_values = s[bad]
    good_values = s[~bad]

    def select(re, im):
        lam = complex(re, im)
        d_bad = np.min(np.abs(bad_values - lam))
        d_good = np.min(np.abs(good_values - lam)) if good_values.size else np.inf
        return bool(d_bad <= d_good)

    try:
        t, z, k = scipy.linalg.schur(a, output="real", sort=select)
    except (np.linalg.LinAlgError, ValueError):
        return None
    n = a.shape[0]
    if k == 0 or k == n:
        return None
    t11, t12, t22 = t[:k, :k], t[:k, k:], t[k:, k:]
    try:
        x = scipy.linalg.solve_sylvester(t11, -t22, -t12)
    except (np.linalg.LinAlgError, ValueError):
        return None
    if not np.all(np.isfinite(x)):
        return None
    w = np.eye(n)
    w[:k, k:] = x
    winv = np.eye(n)
    winv[:k, k:] = -x
    return z @ w, winv @ z.T, t11.copy(), t22.copy()


def _snap_zero_cluster(t11: np.ndarray, a_norm: float) -> np.ndarray:
    """Replace a numerically nilpotent (rigid-body) block by the nearest exact one.

    A rigid-body mode is a Jordan block at exactly 0 (``N^2 = 0``), but any
    backward-stable computation (this Schur form, or ``expm`` of ``A`` itself) only
    reproduces it up to a perturbation ``e ~ eps ||A||``; for a Jordan block with
    coupling ``t`` that moves the eigenvalues to ``+-sqrt(e t)``, a spurious drift (one
    of them unstable) that grows over a long record: for a stiff free-free structure the
    rigid-body motion after 2**16 steps can be off by 1e-6 to 1e-4 relative.

    If ``t11`` is nilpotent of index 2 to within ``e = 10 k eps ||A||`` (``|trace| <= e``,
    ``||t11^2|| <= e ||t11||``), it is replaced by ``N = U' S V^T`` built from its
    singular values above ``e`` (``U' = U - V V^T U`` so that ``N^2 = 0`` exactly): a
    change of the order of ``e``, the size of the rounding that perturbed it. Otherwise
    (a critically damped mode, a cluster away from 0, a Jordan block longer than 2, a
    rigid cluster mixed with another) ``t11`` is returned unchanged.
    """
    k = t11.shape[0]
    e = 10.0 * k * np.finfo(float).eps * a_norm
    norm = np.linalg.norm(t11)
    if abs(np.trace(t11)) > e or np.linalg.norm(t11 @ t11) > e * max(norm, 1.0):
        return t11
    u, sv, vh = np.linalg.svd(t11)
    m = int(np.count_nonzero(sv > e))
    left = u[:, :m] * sv[:m]
    right = vh[:m].T
    left = left - right @ (right.T @ left)  # range orthogonal to row space: N @ N = 0
    return left @ right.T


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
    a, b, c, d = _check_system(A, B, C, D)
    dt = _check_dt(dt)
    hold = _check_hold(hold)
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
            d=_readonly(d),
            poles=_readonly(np.asarray(poles, complex)),
            **{key: _readonly(val) for key, val in parts.items()},
        )

    def state_path(poles):
        ad, bd0, bd1 = _discretize(ab, bb, dt, hold)
        block = dict(ad=ad, bd0=bd0, bd1=bd1, cb=cb, to_block=to_balanced)
        return build("state", 1.0, poles, block=block)

    if n == 0:
        return build("modal", 1.0, np.zeros(0))
    if method == "state":
        return state_path(np.linalg.eigvals(ab))

    s, v, vinv, cond_v = _eig(ab)
    a_norm = float(np.linalg.norm(ab))
    # a nearly defective eigenvalue at ~0 (rigid-body pair) may pass the global test on a
    # small or soft model; it belongs in the block path, where it is integrated exactly
    near_rigid = (
        method == "auto"
        and vinv is not None
        and bool(
            np.any((np.linalg.norm(vinv, axis=1) > _KAPPA_DEFECTIVE) & (np.abs(s) <= 1e-6 * a_norm))
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

    s_lr, bad = _defective_selection(ab)
    split = _block_split(ab, s_lr, bad) if bad is not None else None
    if split is not None:
        p, pinv, t11, t22 = split
        k = t11.shape[0]
        t11 = _snap_zero_cluster(t11, a_norm)
        cond_p = float(np.linalg.norm(p) * np.linalg.norm(pinv))
        s2, v2, v2inv, cond_v2 = _eig(t22)
        if cond_p <= COND_MAX and cond_v2 <= COND_MAX:
            bw = pinv @ bb
            cw = cb @ p
            to_w = pinv @ to_balanced
            modal = _modal_parts(s2, v2, v2inv, bw[k:], cw[:, k:], to_w[k:], dt, hold)
            if modal is not None:
                ad, bd0, bd1 = _discretize(t11, bw[:k], dt, hold)
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
    a, b, _, _ = _check_system(A, B, C, D)
    _check_input(u, b.shape[1])
    _check_x0(x0, a.shape[0])
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
