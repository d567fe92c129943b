"""Private recursion engines of :mod:`truthbench.simulate.linear`.

Two interchangeable engines advance the same discrete recursion

    y[j]     = D u[j] + Cb xi[j] + Re(Cm z[j])
    xi[j+1]  = Ad xi[j] + Bd0 u[j] + Bd1 u[j+1]             (small dense real block)
    z[j+1]   = lam z[j] + w0 q[j] + w1 q[j+1],  q = Bm u     (diagonal complex modes)

``run_numpy`` filters each mode's input ``q_i`` with ``scipy.signal.lfilter`` (numerator
``[w1_i, w0_i]``, denominator ``[1, -lam_i]``), mixes the output of a group of modes with
one matrix product and advances the dense block with a plain loop; ``run_numba`` is one
fused ``numba.njit`` loop over samples. Both give the same result to rounding. numba is
optional: this module never imports it; ``_kernels_numba`` does.
"""

from __future__ import annotations

import numpy as np
from scipy.signal import lfilter

#: Largest number of complex modal samples held at once by ``run_numpy`` (modes are
#: processed in groups so that ``n_modes_in_group * n_samples`` stays below; 8 MB).
_MAX_MODAL_CHUNK = 1 << 19


def run_numpy(u, d, ad, bd0, bd1, cb, xi0, lam, bm, w0, w1, cm, z0):
    """Advance the recursion with numpy / scipy.signal.lfilter.

    Parameters
    ----------
    u : ndarray, shape (n_in, n_samples), float64
    d : ndarray, shape (n_out, n_in)
    ad : ndarray, shape (k, k)
    bd0, bd1 : ndarray, shape (k, n_in)
    cb : ndarray, shape (n_out, k)
    xi0 : ndarray, shape (k,)
    lam : ndarray, shape (m,), complex
    bm : ndarray, shape (m, n_in), complex
    w0, w1 : ndarray, shape (m,), complex
    cm : ndarray, shape (n_out, m), complex (conjugate-pair weight already folded in)
    z0 : ndarray, shape (m,), complex

    Returns
    -------
    y : ndarray, shape (n_out, n_samples)
    """
    n_samples = u.shape[1]
    y = d @ u

    m = lam.shape[0]
    if m:
        bm_r = np.ascontiguousarray(bm.real)
        bm_i = np.ascontiguousarray(bm.imag)
        group = max(1, _MAX_MODAL_CHUNK // n_samples)
        z = np.empty((min(group, m), n_samples), dtype=complex)
        for start in range(0, m, group):
            stop = min(m, start + group)
            for i in range(start, stop):
                q = np.empty(n_samples, dtype=complex)
                # real and imaginary parts separately: a mixed real/complex matmul
                # would miss BLAS
                q.real = bm_r[i] @ u
                q.imag = bm_i[i] @ u
                # out[j] = w1 q[j] + w0 q[j-1] + lam out[j-1]; out[0] = z0 needs
                # the filter state w1-corrected
                zi = np.array([z0[i] - w1[i] * q[0]])
                z[i - start] = lfilter([w1[i], w0[i]], [1.0, -lam[i]], q, zi=zi)[0]
            y += (cm[:, start:stop] @ z[: stop - start]).real

    k = ad.shape[0]
    if k:
        # rows are time samples so that each step reads and writes contiguous memory
        forcing = (bd0 @ u[:, :-1] + bd1 @ u[:, 1:]).T
        xi = np.empty((n_samples, k))
        xi[0] = xi0
        ad_t = np.ascontiguousarray(ad.T)
        for j in range(n_samples - 1):
            xi[j + 1] = xi[j] @ ad_t + forcing[j]
        y += cb @ xi.T
    return y
