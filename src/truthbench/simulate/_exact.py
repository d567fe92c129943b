"""The exact-discretisation machinery both time-simulation engines share.

:mod:`~truthbench.simulate.linear` (:func:`~truthbench.simulate.linear.prepare_lti`)
and :mod:`~truthbench.simulate.nonlinear` (every friction regime of
:func:`~truthbench.simulate.nonlinear.prepare_nonlinear`) realise a continuous system
``x' = A x + B u`` for an input that is linear (or constant) between samples with the
same pieces, all here:

* entry checks of the system matrices, the time step, the hold, the input and the
  initial state (:func:`check_system`, :func:`check_dt`, :func:`check_hold`,
  :func:`check_input`, :func:`check_x0`);
* the eigen-decomposition with its condition number (:func:`eig`) and the choice of one
  mode per complex-conjugate pair (:func:`pairs`), for the diagonal modal recursions;
* the split of (nearly) defective eigenvalues into a small dense block
  (:func:`defective_selection`, :func:`block_split`) and the snap of a numerically
  nilpotent rigid-body block to an exact one (:func:`snap_zero_cluster`);
* the exact (Van Loan) discretisation of a dense block (:func:`van_loan`) and the
  ``phi1``/``phi2`` functions of the modal hold weights (:func:`phi12`);
* the thresholds that pick between those paths (:data:`COND_MAX`,
  :data:`KAPPA_DEFECTIVE`).

The method is described in :mod:`~truthbench.simulate.linear`. This module is private to
``truthbench.simulate``; its names carry no underscore because they are its interface to
the two engines.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.linalg

from truthbench.errors import ModelError

#: Largest condition number of an eigenvector matrix accepted for the modal path.
COND_MAX = 1e8
#: Eigenvalue condition number (``||left|| ||right|| / |left^H right|``) above which an
#: eigenvalue is moved into the dense block once the modal path has been refused
#: (a defective rigid-body pair has ~1e8 or infinity; moving a merely ill-conditioned
#: eigenvalue there costs speed, never accuracy).
KAPPA_DEFECTIVE = 1e4
N_TAYLOR = 20


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


def check_system(A, B, C, D):
    """Real, finite, consistently shaped private copies of the system matrices.

    Parameters
    ----------
    A, B, C : array_like
        State matrix ``(n, n)``, input matrix ``(n, n_in)``, output matrix ``(n_out, n)``.
    D : array_like, shape (n_out, n_in), or None
        Feedthrough; None gives zeros.

    Returns
    -------
    a, b, c, d : ndarray, float64
        Copies (the caller's arrays are never touched).

    Raises
    ------
    ModelError
        A matrix that is complex, not numeric, not 2-D, not finite, or of a shape that
        does not fit the others (the message names the matrix and both shapes).
    """
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


def check_dt(dt) -> float:
    """``dt`` as a positive finite float (s); ValueError otherwise."""
    try:
        value = float(dt)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"dt must be a positive finite time step in s; got {dt!r}") from exc
    if not math.isfinite(value) or value <= 0.0:
        raise ValueError(f"dt must be a positive finite time step in s; got {dt!r}")
    return value


def check_hold(hold) -> str:
    """``hold`` if it is ``"foh"`` or ``"zoh"``; ValueError otherwise."""
    if hold not in ("foh", "zoh"):
        raise ValueError(f"hold must be 'foh' or 'zoh'; got {hold!r} instead")
    return hold


def check_input(u, n_in: int) -> np.ndarray:
    """The input as a C-contiguous float64 copy of shape ``(n_in, n_samples)``.

    Parameters
    ----------
    u : array_like, shape (n_in, n_samples)
        Real, finite input samples; 1-D is accepted when ``n_in == 1``.
    n_in : int
        Number of inputs of the system.

    Returns
    -------
    ndarray, shape (n_in, n_samples)

    Raises
    ------
    ValueError
        Complex, wrongly shaped, empty or non-finite ``u`` (the first bad sample named).
    """
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


def check_x0(x0, n: int) -> np.ndarray:
    """The initial state as a float64 copy of shape ``(n,)`` (zeros for None).

    A column vector ``(n, 1)`` is accepted. ValueError for a complex, wrongly shaped or
    non-finite ``x0``.
    """
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


def van_loan(a, b, dt, hold):
    """Exact discretisation ``(Ad, Bd0, Bd1)`` of ``x' = a x + b u`` held over ``dt``.

    Van Loan's construction, one ``expm`` of an augmented matrix; no checks (the public,
    checked entry is :func:`truthbench.simulate.linear.discretize`, which documents the
    result).

    Parameters
    ----------
    a : ndarray, shape (n, n)
        State matrix, 1/s (real or complex; the result has its dtype).
    b : ndarray, shape (n, n_in)
        Input matrix, same dtype as ``a``.
    dt : float
        Step, s.
    hold : {"foh", "zoh"}
        Inter-sample behaviour of the input (``Bd1 = 0`` for ``"zoh"``).

    Returns
    -------
    Ad : ndarray, shape (n, n)
    Bd0, Bd1 : ndarray, shape (n, n_in)
        Weights of ``u[j]`` and ``u[j+1]`` in ``x[j+1] = Ad x[j] + Bd0 u[j] + Bd1 u[j+1]``.
    """
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


def phi12(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``phi1(a) = (e^a - 1)/a`` and ``phi2(a) = (e^a - 1 - a)/a^2``, accurate at 0."""
    a = np.asarray(a, dtype=complex)
    phi1 = np.empty_like(a)
    phi2 = np.empty_like(a)
    small = np.abs(a) < 0.5
    if np.any(small):
        x = a[small]
        # Horner on sum_k x^k/(k+1)! and sum_k x^k/(k+2)!; error < 0.5^20/20! ~ 4e-25
        p1 = np.full_like(x, 1.0 / math.factorial(N_TAYLOR + 1))
        p2 = np.full_like(x, 1.0 / math.factorial(N_TAYLOR + 2))
        for k in range(N_TAYLOR - 1, -1, -1):
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


def pairs(s: np.ndarray):
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


def eig(a: np.ndarray):
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


def defective_selection(a: np.ndarray):
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
    bad = overlap < 1.0 / KAPPA_DEFECTIVE
    if not np.any(bad):
        return s, None
    return s, bad | np.isin(s, np.conj(s[bad]))


def block_split(a, s, bad):
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


def snap_zero_cluster(t11: np.ndarray, a_norm: float) -> np.ndarray:
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
