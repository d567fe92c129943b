"""The numba engine of :mod:`truthbench.simulate.linear` (imported only when numba is).

One fused loop over samples advances every diagonal mode and the small dense block and
mixes the output in the same pass, so no (modes x samples) intermediate is stored.
Complex modal states are carried as separate real and imaginary float64 arrays, and the
outputs are accumulated four at a time in scalar registers, so the inner loops over
modes vectorise (SIMD). Compiled once per machine and cached on disk (``cache=True``).
"""

from __future__ import annotations

import numba
import numpy as np

# reassociation lets LLVM vectorise the reductions over modes; no nnan/ninf: inputs are
# checked finite upstream, but nothing here assumes it.
_FASTMATH = {"reassoc", "contract", "nsz"}


@numba.njit(cache=True, fastmath=_FASTMATH)
def _fused_loop(
    u, d, ad, bd0, bd1, cb, xi0, lam_r, lam_i, g0r, g0i, g1r, g1i, cmr, cmi, z0r, z0i
):  # pragma: no cover - compiled, exercised through run_numba
    n_in, n_samples = u.shape
    n_out = cmr.shape[0]
    k = ad.shape[0]
    m = lam_r.shape[0]
    n_grp = max(1, (n_out + 3) // 4)
    # output rows padded with zeros to a multiple of four
    cr = np.zeros((4 * n_grp, m))
    ci = np.zeros((4 * n_grp, m))
    cr[:n_out] = cmr
    ci[:n_out] = cmi
    y = np.empty((4 * n_grp, n_samples))  # every entry of rows < n_out is assigned
    zr = z0r.copy()
    zi = z0i.copy()
    fr = np.empty(m)
    fi = np.empty(m)
    xi = xi0.copy()
    xn = np.empty(k)

    # sample 0
    for o in range(n_out):
        acc = 0.0
        for i in range(m):
            acc += cr[o, i] * zr[i] - ci[o, i] * zi[i]
        for q in range(k):
            acc += cb[o, q] * xi[q]
        y[o, 0] = acc

    for j in range(n_samples - 1):
        # modal forcing G0 u[j] + G1 u[j+1]
        u0 = u[0, j]
        u1 = u[0, j + 1]
        for i in range(m):
            fr[i] = g0r[0, i] * u0 + g1r[0, i] * u1
            fi[i] = g0i[0, i] * u0 + g1i[0, i] * u1
        for p in range(1, n_in):
            u0 = u[p, j]
            u1 = u[p, j + 1]
            for i in range(m):
                fr[i] += g0r[p, i] * u0 + g1r[p, i] * u1
                fi[i] += g0i[p, i] * u0 + g1i[p, i] * u1
        # advance the modes and mix the first four outputs of sample j+1 in one pass
        s0 = 0.0
        s1 = 0.0
        s2 = 0.0
        s3 = 0.0
        for i in range(m):
            a = zr[i]
            b = zi[i]
            na = lam_r[i] * a - lam_i[i] * b + fr[i]
            nb = lam_r[i] * b + lam_i[i] * a + fi[i]
            zr[i] = na
            zi[i] = nb
            s0 += cr[0, i] * na - ci[0, i] * nb
            s1 += cr[1, i] * na - ci[1, i] * nb
            s2 += cr[2, i] * na - ci[2, i] * nb
            s3 += cr[3, i] * na - ci[3, i] * nb
        y[0, j + 1] = s0
        y[1, j + 1] = s1
        y[2, j + 1] = s2
        y[3, j + 1] = s3
        # further outputs, four at a time
        for g in range(1, n_grp):
            o = 4 * g
            s0 = 0.0
            s1 = 0.0
            s2 = 0.0
            s3 = 0.0
            for i in range(m):
                na = zr[i]
                nb = zi[i]
                s0 += cr[o, i] * na - ci[o, i] * nb
                s1 += cr[o + 1, i] * na - ci[o + 1, i] * nb
                s2 += cr[o + 2, i] * na - ci[o + 2, i] * nb
                s3 += cr[o + 3, i] * na - ci[o + 3, i] * nb
            y[o, j + 1] = s0
            y[o + 1, j + 1] = s1
            y[o + 2, j + 1] = s2
            y[o + 3, j + 1] = s3
        # dense block: xi <- Ad xi + Bd0 u[j] + Bd1 u[j+1], then its output share
        if k:
            for q in range(k):
                acc = 0.0
                for r in range(k):
                    acc += ad[q, r] * xi[r]
                for p in range(n_in):
                    acc += bd0[q, p] * u[p, j] + bd1[q, p] * u[p, j + 1]
                xn[q] = acc
            for q in range(k):
                xi[q] = xn[q]
            for o in range(n_out):
                acc = 0.0
                for q in range(k):
                    acc += cb[o, q] * xi[q]
                y[o, j + 1] += acc
    # direct feedthrough D u
    for o in range(n_out):
        for p in range(n_in):
            dop = d[o, p]
            if dop != 0.0:
                for j in range(n_samples):
                    y[o, j] += dop * u[p, j]
    return y[:n_out].copy()


def run_numba(u, d, ad, bd0, bd1, cb, xi0, lam, bm, w0, w1, cm, z0):
    """Advance the recursion with the compiled fused loop (same arguments as ``run_numpy``).

    The kernel reads ``u[0]``, so the no-input case gets a zero input row.
    """

    def c(x):
        # one compiled signature only: C-contiguous, writeable float64 (numba types
        # read-only arrays separately, and LtiRecursion's arrays are read-only)
        return np.require(x, dtype=np.float64, requirements=["C", "W"])

    g0 = (w0[:, None] * bm).T  # (n_in, m): weight of u[j] per mode
    g1 = (w1[:, None] * bm).T  # weight of u[j+1]
    if u.shape[0] == 0:
        u = np.zeros((1, u.shape[1]))
        d = np.zeros((d.shape[0], 1))
        g0 = g1 = np.zeros((1, lam.shape[0]), dtype=complex)
        bd0 = bd1 = np.zeros((ad.shape[0], 1))
    return _fused_loop(
        c(u),
        c(d),
        c(ad),
        c(bd0),
        c(bd1),
        c(cb),
        c(xi0),
        c(lam.real),
        c(lam.imag),
        c(g0.real),
        c(g0.imag),
        c(g1.real),
        c(g1.imag),
        c(cm.real),
        c(cm.imag),
        c(z0.real),
        c(z0.imag),
    )
