"""The per-sample loop of :mod:`truthbench.simulate.nonlinear` (plain Python source).

This module never imports numba. Its functions are written in the subset of Python that
``numba.njit`` compiles, so the same source runs two ways (results agree to rounding;
the compiled one may reassociate sums):

* interpreted, as the always-available fallback (``backend="numpy"``; slow, meant for
  small systems and for checking the compiled engine);
* compiled, by :mod:`truthbench.simulate._nonlinear_numba`, which re-binds every function
  here to a copy whose globals point at the compiled helpers and wraps it in
  ``numba.njit(cache=True)``. Avoid literal integer arguments in calls between these
  functions (numba would compile the callee once more for them).

The system is a set of *regimes*, one per subset ``S`` of stuck friction elements
(``r`` is the bit mask of ``S``). In each regime the motion is linear,
``xi' = A_r xi + B_r w`` with the input ``w = [u; f_nl]`` (the stuck elements' columns
are zero: their holding forces are outputs), and is advanced exactly for a
piecewise-linear ``w`` by diagonal complex modes ``z`` plus a small dense block ``xi``
(see :mod:`truthbench.simulate.linear`). Every regime has the same output rows
``[y (n_out); d; v; h; t (n_nl each); 0]``: outputs, element displacements and
velocities, holding forces of the stuck elements, the *trial* holding force of each
slipping element (the force that would keep its velocity at zero, the others as they
are) and a zero row. Per step only the regime's *active* rows are computed (outputs,
smooth elements' displacements, velocities of elements not stuck, holding forces).

Per step the fast path advances the current regime over the whole step (precomputed
weights), corrects the smooth element forces at the step end (Newton on the exact linear
sensitivity) and checks the friction gates at the step end: ``dir * v`` of a slipping
element, ``F_c - |h|`` of a stuck one. If a gate went negative the step is redone by the
event path, sub-interval by sub-interval: the first zero of each gate is estimated from
a quintic Hermite interpolant (gate value and two time derivatives at both ends, all
exact and cheap) and polished by Newton's method on the exact intra-step solution
(``exp(s h)`` per mode, a small matrix exponential for the block) to ``1e-12 dt``.
At a velocity zero the trial holding force decides: within ``F_c`` the element sticks
(regime change: the state is mapped through the full state ``x``), beyond it the
velocity reverses, which needs no regime change, only the superposition of the force
jump on the step-end state. A stuck element whose holding force reaches ``F_c`` is
released in the direction of ``-sign(h)``.
"""

from __future__ import annotations

import math

import numpy as np

KIND_COULOMB = 0
KIND_CUBIC = 1
KIND_DEADBAND = 2
KIND_QUADRATIC_DAMPING = 3

_N_TAYLOR = 14
#: phi1/phi2 use their Taylor series below this |a| (error < 0.25**15/15! ~ 1e-21)
_TAYLOR_RADIUS = 0.25
#: 1/k! for k = 0..22
_INV_FACT = np.array([1.0 / math.factorial(k) for k in range(23)])
#: terms of the Taylor series in the block matrix exponential (argument norm <= 0.5)
_EXPM_TERMS = 20
#: relative size below which a gate value at a step end counts as rounding noise
_EVENT_RTOL = 1e-12
#: an event time is accepted when the Newton correction is below this fraction of dt
_EVENT_TTOL = 1e-12
_MAX_NEWTON_EVENT = 60
#: samples of the Hermite interpolant searched for its first sign change
_N_SCAN = 64


# ----------------------------------------------------------------------------------
# element laws (smooth ones; Coulomb friction is handled by the regimes)
# ----------------------------------------------------------------------------------


def smooth_force(kind, p0, p1, d, v):
    """Force of a smooth element and its derivatives ``(f, df/dd, df/dv)``."""
    if kind == KIND_CUBIC:
        return -p0 * d * d * d, -3.0 * p0 * d * d, 0.0
    if kind == KIND_DEADBAND:
        if d > p0:
            return -p1 * (d - p0), -p1, 0.0
        if d < -p0:
            return -p1 * (d + p0), -p1, 0.0
        return 0.0, 0.0, 0.0
    if kind == KIND_QUADRATIC_DAMPING:
        return -p0 * abs(v) * v, 0.0, -2.0 * p0 * abs(v)
    return 0.0, 0.0, 0.0


# ----------------------------------------------------------------------------------
# small numerics
# ----------------------------------------------------------------------------------


def phi12(a):
    """``phi1(a) = (e^a - 1)/a`` and ``phi2(a) = (e^a - 1 - a)/a^2`` for complex ``a``."""
    if abs(a) < _TAYLOR_RADIUS:
        p1 = _INV_FACT[_N_TAYLOR + 1] + 0j
        p2 = _INV_FACT[_N_TAYLOR + 2] + 0j
        for k in range(_N_TAYLOR - 1, -1, -1):
            p1 = p1 * a + _INV_FACT[k + 1]
            p2 = p2 * a + _INV_FACT[k + 2]
        return p1, p2
    p1 = (np.exp(a) - 1.0) / a
    return p1, (p1 - 1.0) / a


def phi1(a):
    """``phi1(a) = (e^a - 1)/a`` for complex ``a``."""
    if abs(a) < _TAYLOR_RADIUS:
        p1 = _INV_FACT[_N_TAYLOR + 1] + 0j
        for k in range(_N_TAYLOR - 1, -1, -1):
            p1 = p1 * a + _INV_FACT[k + 1]
        return p1
    return (np.exp(a) - 1.0) / a


def matmul(a, b, out):
    """``out = a @ b`` for small square matrices (plain loops: no BLAS binding)."""
    n = a.shape[0]
    for r in range(n):
        for c in range(n):
            acc = 0.0
            for q in range(n):
                acc += a[r, q] * b[q, c]
            out[r, c] = acc


def expm_small(m):
    """Matrix exponential of a small real matrix (scaling and squaring, Taylor 20)."""
    n = m.shape[0]
    norm = 0.0
    for c in range(n):
        col = 0.0
        for r in range(n):
            col += abs(m[r, c])
        norm = max(norm, col)
    sq = 0
    while norm > 0.5:
        norm *= 0.5
        sq += 1
    a = m * (0.5**sq)
    e = np.eye(n)
    t = np.empty((n, n))
    for k in range(_EXPM_TERMS, 0, -1):  # Horner: e <- I + a e / k
        matmul(a, e, t)
        for r in range(n):
            for c in range(n):
                e[r, c] = t[r, c] / k
            e[r, r] += 1.0
    for _ in range(sq):
        matmul(e, e, t)
        for r in range(n):
            for c in range(n):
                e[r, c] = t[r, c]
    return e


def solve_small(a, b):
    """Solve ``a x = b`` for a small square ``a`` (Gauss, partial pivoting; copies)."""
    n = a.shape[0]
    m = a.copy()
    x = b.copy()
    for col in range(n):
        piv = col
        for r in range(col + 1, n):
            if abs(m[r, col]) > abs(m[piv, col]):
                piv = r
        if piv != col:
            for c in range(n):
                tmp = m[col, c]
                m[col, c] = m[piv, c]
                m[piv, c] = tmp
            tmp = x[col]
            x[col] = x[piv]
            x[piv] = tmp
        for r in range(col + 1, n):
            fac = m[r, col] / m[col, col]
            if fac != 0.0:
                for c in range(col, n):
                    m[r, c] -= fac * m[col, c]
                x[r] -= fac * x[col]
    for r in range(n - 1, -1, -1):
        acc = x[r]
        for c in range(r + 1, n):
            acc -= m[r, c] * x[c]
        x[r] = acc / m[r, r]
    return x


def hermite_first_root(g0, d0, c0, g1, d1, c1):
    """First zero in ``(0, 1]`` of the quintic with value, slope and curvature ``g0, d0,
    c0`` at 0 and ``g1, d1, c1`` at 1 (``g1 < 0``); scanned, then bisected."""
    a3 = 10.0 * (g1 - g0) - 6.0 * d0 - 4.0 * d1 - 1.5 * c0 + 0.5 * c1
    a4 = 15.0 * (g0 - g1) + 8.0 * d0 + 7.0 * d1 + 1.5 * c0 - c1
    a5 = 6.0 * (g1 - g0) - 3.0 * (d0 + d1) - 0.5 * (c0 - c1)
    a2 = 0.5 * c0
    lo = 0.0
    hi = 1.0
    for k in range(1, _N_SCAN + 1):
        th = k / _N_SCAN
        val = g0 + th * (d0 + th * (a2 + th * (a3 + th * (a4 + th * a5))))
        if val <= 0.0:
            hi = th
            break
        lo = th
    for _ in range(60):  # to 1e-10: Newton on the exact solution follows
        th = 0.5 * (lo + hi)
        if hi - lo <= 1e-10:
            break
        val = g0 + th * (d0 + th * (a2 + th * (a3 + th * (a4 + th * a5))))
        if val > 0.0:
            lo = th
        else:
            hi = th
    return hi


# ----------------------------------------------------------------------------------
# the regime recursions
# ----------------------------------------------------------------------------------


def advance(nm, nk, s, tblk, za, xa, qa, qd, ga, gd, h, oz, ox):
    """Exact state after time ``h`` from ``(za, xa)``; modal input ``qa + qd t``, block
    input ``ga + gd t``. Writes ``oz`` (complex) and ``ox``."""
    for i in range(nm):
        a = s[i] * h
        p1, p2 = phi12(a)
        oz[i] = za[i] * np.exp(a) + h * (p1 * qa[i] + (p2 * h) * qd[i])
    if nk > 0:
        aug = np.zeros((nk + 2, nk + 2))
        for q in range(nk):
            for c in range(nk):
                aug[q, c] = h * tblk[q, c]
            aug[q, nk] = h * ga[q]
            aug[q, nk + 1] = h * h * gd[q]
        aug[nk + 1, nk] = 1.0
        e = expm_small(aug)
        for q in range(nk):
            acc = e[q, nk]
            for c in range(nk):
                acc += e[q, c] * xa[c]
            ox[q] = acc


def row_value(nm, nk, cmr, cmi, ck, dr, row, zr, zi, xi, w):
    """One output row ``Re(cm z) + Ck xi + D w`` (modal state as real/imag arrays)."""
    acc = 0.0
    for i in range(nm):
        acc += cmr[row, i] * zr[i] - cmi[row, i] * zi[i]
    for q in range(nk):
        acc += ck[row, q] * xi[q]
    for p in range(w.shape[0]):
        acc += dr[row, p] * w[p]
    return acc


def row_derivs(nm, nk, s, tblk, cm, ck, dr, row, z, xi, w, q, qd, gb, gd, wd):
    """A row and its first two time derivatives at state ``(z, xi)``, input ``w``
    (rate ``wd``), modal input ``q`` (rate ``qd``), block input ``gb`` (rate ``gd``).

    Also returns the sum of magnitudes of the row's terms (its rounding scale).
    """
    v0 = 0.0
    v1 = 0.0
    v2 = 0.0
    scale = 0.0
    for i in range(nm):
        c = cm[row, i]
        z1 = s[i] * z[i] + q[i]
        z2 = s[i] * z1 + qd[i]
        t0 = c * z[i]
        v0 += t0.real
        v1 += (c * z1).real
        v2 += (c * z2).real
        scale += abs(t0.real)
    for k in range(nk):
        x1 = gb[k]
        x1d = gd[k]
        for c2 in range(nk):
            x1 += tblk[k, c2] * xi[c2]
        for c2 in range(nk):
            # T (T xi + g) + g'
            acc = 0.0
            for c3 in range(nk):
                acc += tblk[c2, c3] * xi[c3]
            x1d += tblk[k, c2] * (acc + gb[c2])
        v0 += ck[row, k] * xi[k]
        v1 += ck[row, k] * x1
        v2 += ck[row, k] * x1d
        scale += abs(ck[row, k] * xi[k])
    for p in range(w.shape[0]):
        v0 += dr[row, p] * w[p]
        v1 += dr[row, p] * wd[p]
        scale += abs(dr[row, p] * w[p])
    return v0, v1, v2, scale


def gate(stuck, sgn, fc, v0, v1, v2):
    """Event gate and its derivatives from a row: ``sgn v`` (slip) or ``F_c - |h|``."""
    if stuck:
        sg = 1.0 if v0 >= 0.0 else -1.0
        return fc - abs(v0), -sg * v1, -sg * v2
    return sgn * v0, sgn * v1, sgn * v2


def reconstruct(nm, nk, recr, reci, recb, zr, zi, xi, x):
    """Full state ``x = Re(rec z) + recb xi``."""
    for q in range(x.shape[0]):
        acc = 0.0
        for i in range(nm):
            acc += recr[q, i] * zr[i] - reci[q, i] * zi[i]
        for c in range(nk):
            acc += recb[q, c] * xi[c]
        x[q] = acc


def to_regime(nm, nk, tomr, tomi, tob, x, zr, zi, xi):
    """Regime coordinates of the full state ``x``."""
    n = x.shape[0]
    for i in range(nm):
        ar = 0.0
        ai = 0.0
        for q in range(n):
            ar += tomr[i, q] * x[q]
            ai += tomi[i, q] * x[q]
        zr[i] = ar
        zi[i] = ai
    for c in range(nk):
        acc = 0.0
        for q in range(n):
            acc += tob[c, q] * x[q]
        xi[c] = acc


def fill_input(frac, wa_s, wb_s, n_in, kind, par, dirs, mask, fbit, w):
    """Input at the fraction ``frac`` of the step: ``u`` and smooth forces linear,
    slipping friction ``-F_c dir``, stuck friction 0 (its column is unused)."""
    for p in range(w.shape[0]):
        w[p] = (1.0 - frac) * wa_s[p] + frac * wb_s[p]
    for e in range(kind.shape[0]):
        if kind[e] == KIND_COULOMB:
            if (mask >> fbit[e]) & 1:
                w[n_in + e] = 0.0
            else:
                w[n_in + e] = -par[e, 0] * dirs[e]


def settle(mask, forced, x, w, n_in, kind, par, fbit, hx, hw, dirs, last_dir, n_rev, fresh):
    """Make the stuck set consistent at one instant.

    Holding forces ``h = Hx x + Hw w`` of the regime ``mask`` are computed; while some
    stuck element needs more than its friction force (the element ``forced`` first if it
    is >= 0, then the largest ratio ``|h|/F_c``), it is released in the direction
    ``-sign(h)``. ``w`` (friction entries), ``dirs`` and the counters are updated in
    place. Returns the new mask.
    """
    n = x.shape[0]
    n_w = w.shape[0]
    for _ in range(kind.shape[0] + 1):
        worst = -1
        worst_ratio = 1.0
        worst_h = 0.0
        for e in range(kind.shape[0]):
            if kind[e] != KIND_COULOMB or not (mask >> fbit[e]) & 1:
                continue
            he = 0.0
            for q in range(n):
                he += hx[mask, e, q] * x[q]
            for p in range(n_w):
                he += hw[mask, e, p] * w[p]
            fc = par[e, 0]
            if e == forced:
                ratio = math.inf
            elif abs(he) > fc:
                ratio = math.inf if fc == 0.0 else abs(he) / fc
            else:
                ratio = 0.0
            if ratio > worst_ratio:
                worst = e
                worst_ratio = ratio
                worst_h = he
        if worst < 0:
            return mask
        forced = -1
        new_dir = -1.0 if worst_h > 0.0 else 1.0
        mask = mask & ~(1 << fbit[worst])
        dirs[worst] = new_dir
        if last_dir[worst] != 0.0 and last_dir[worst] != new_dir:
            n_rev[worst] += 1
        last_dir[worst] = new_dir
        fresh[worst] = 1
        w[n_in + worst] = -par[worst, 0] * new_dir
    return mask


def shift(nm, nk, s, tblk, z, xi, q, qd, g, gd, d, oz, ox):
    """State after a tiny time ``d`` by its Taylor series to third order (exact to
    rounding when ``max |s| d <= 1e-4``): no exponentials."""
    d2 = 0.5 * d * d
    d3 = d2 * d / 3.0
    for i in range(nm):
        z1 = s[i] * z[i] + q[i]
        z2 = s[i] * z1 + qd[i]
        oz[i] = z[i] + d * z1 + d2 * z2 + d3 * (s[i] * z2)
    if nk > 0:
        x1 = np.empty(nk)
        x2 = np.empty(nk)
        for k in range(nk):
            acc = g[k]
            for c in range(nk):
                acc += tblk[k, c] * xi[c]
            x1[k] = acc
        for k in range(nk):
            acc = gd[k]
            for c in range(nk):
                acc += tblk[k, c] * x1[c]
            x2[k] = acc
        for k in range(nk):
            acc = 0.0
            for c in range(nk):
                acc += tblk[k, c] * x2[c]
            ox[k] = xi[k] + d * x1[k] + d2 * x2[k] + d3 * acc


def hot_rows(nm, nk, cmr, cmi, ck, dr, zr, zi, xi, w, out):
    """Every row at a state (after an event; the fast path computes only active rows)."""
    for o in range(out.shape[0]):
        acc = 0.0
        for i in range(nm):
            acc += cmr[o, i] * zr[i] - cmi[o, i] * zi[i]
        for q in range(nk):
            acc += ck[o, q] * xi[q]
        for p in range(w.shape[0]):
            acc += dr[o, p] * w[p]
        out[o] = acc


def fric_forcing(nm, n_in, kind, par, fbit, mask, dirs, g0r, g0i, g1r, g1i, cfr, cfi):
    """Modal forcing of one full step by the slipping friction forces (constant)."""
    for i in range(nm):
        cfr[i] = 0.0
        cfi[i] = 0.0
    for e in range(kind.shape[0]):
        if kind[e] != KIND_COULOMB or (mask >> fbit[e]) & 1:
            continue
        f = -par[e, 0] * dirs[e]
        p = n_in + e
        for i in range(nm):
            cfr[i] += (g0r[p, i] + g1r[p, i]) * f
            cfi[i] += (g0i[p, i] + g1i[p, i]) * f


def record(jr, hot, n_out, row_d, row_v, row_h, n_in, par, fbit, mask, dirs, is_smooth,
           wb_s, fsm, y, fo, disp, vel, stuck):
    """Store sample ``jr`` from the rows at the step end; update the smooth forces."""
    for o in range(n_out):
        y[o, jr] = hot[o]
    for e in range(fsm.shape[0]):
        if is_smooth[e]:
            disp[e, jr] = hot[row_d + e]
            vel[e, jr] = hot[row_v + e]
            fsm[e] = wb_s[n_in + e]
            fo[e, jr] = fsm[e]
        elif (mask >> fbit[e]) & 1:
            disp[e, jr] = np.nan  # not tracked for friction elements
            vel[e, jr] = 0.0
            fo[e, jr] = hot[row_h + e]
            stuck[e, jr] = True
        else:
            disp[e, jr] = np.nan
            vel[e, jr] = hot[row_v + e]
            fo[e, jr] = -par[e, 0] * dirs[e]


def event_step(
    j, dt, mask, n_in, row_v, row_h, row_t, max_events, nm_a, nk_a, smax_a, s_a,
    bm_a, cm_a, cmr_a, cmi_a, recr_a, reci_a, tomr_a, tomi_a, tblk_a, bblk_a, ck_a, recb_a,
    tob_a, dr_a, hx, hw, kind, par, fbit, dirs, last_dir, fresh, n_rev, n_stick, wa_s, wb_s,
    zr0, zi0, xi0, zr, zi, xi, hot, cz, rz, wz, x,
):
    """Redo step ``j`` exactly, event by event (see the module docstring).

    On entry ``(zr0, zi0, xi0)`` is the state at the step start and ``(zr, zi, xi)`` the
    fast path's state at the step end, both in the regime ``mask``; on return
    ``(zr, zi, xi)`` and ``hot`` hold the step end in the final regime. ``cz``, ``rz``,
    ``wz`` and ``x`` are scratch. Returns ``(mask, fail)``, ``fail = j`` if more than
    ``max_events`` events occurred, else -1.
    """
    r = mask
    n_nl = kind.shape[0]
    n_w = wa_s.shape[0]
    fail = -1
    za = cz[0]
    ze = cz[1]
    zt = cz[2]
    zs = cz[3]
    zu = cz[4]
    qa = cz[5]
    qd = cz[6]
    qt = cz[7]
    qe = cz[8]
    zero_m = cz[9]
    xa = rz[0]
    xe = rz[1]
    xt = rz[2]
    xs = rz[3]
    xu = rz[4]
    ga = rz[5]
    gd = rz[6]
    gt = rz[7]
    ge = rz[8]
    zero_k = rz[9]
    w = wz[0]
    w2 = wz[1]
    wd = wz[2]
    nm = nm_a[r]
    nk = nk_a[r]
    ta = 0.0
    for i in range(nm):
        za[i] = complex(zr0[i], zi0[i])
        ze[i] = complex(zr[i], zi[i])
    for q in range(nk):
        xa[q] = xi0[q]
        xe[q] = xi[q]
    for e in range(n_nl):
        fresh[e] = 0
    n_ev = 0
    while True:
        nm = nm_a[r]
        nk = nk_a[r]
        s = s_a[r]
        bm = bm_a[r]
        tblk = tblk_a[r]
        bblk = bblk_a[r]
        cm = cm_a[r]
        cmr = cmr_a[r]
        cmi = cmi_a[r]
        ck = ck_a[r]
        dr = dr_a[r]
        smax = smax_a[r]
        span = dt - ta
        if span <= 0.0:
            break
        # inputs at the interval ends and their rates
        fill_input(ta / dt, wa_s, wb_s, n_in, kind, par, dirs, mask, fbit, w)
        fill_input(1.0, wa_s, wb_s, n_in, kind, par, dirs, mask, fbit, w2)
        for p in range(n_w):
            wd[p] = (w2[p] - w[p]) / span
        for i in range(nm):
            acc_a = 0j
            acc_e = 0j
            for p in range(n_w):
                acc_a += bm[i, p] * w[p]
                acc_e += bm[i, p] * w2[p]
            qa[i] = acc_a
            qe[i] = acc_e
            qd[i] = (acc_e - acc_a) / span
        for q in range(nk):
            acc_a = 0.0
            acc_e = 0.0
            for p in range(n_w):
                acc_a += bblk[q, p] * w[p]
                acc_e += bblk[q, p] * w2[p]
            ga[q] = acc_a
            ge[q] = acc_e
            gd[q] = (acc_e - acc_a) / span
        # the first event among the gates that are clearly negative at the end
        t_ev = 2.0 * dt
        e_ev = -1
        for e in range(n_nl):
            if kind[e] != KIND_COULOMB:
                continue
            is_stuck = (mask >> fbit[e]) & 1
            row = row_h + e if is_stuck else row_v + e
            sgn = 1.0 if is_stuck else dirs[e]
            fc = par[e, 0]
            v0, v1, v2, sc = row_derivs(nm, nk, s, tblk, cm, ck, dr, row, ze, xe, w2, qe,
                                        qd, ge, gd, wd)
            g_e, d_e, c_e = gate(is_stuck, sgn, fc, v0, v1, v2)
            tol = _EVENT_RTOL * (max(sc, fc) if is_stuck else sc)
            if not g_e < -tol:
                continue
            v0, v1, v2, sc = row_derivs(nm, nk, s, tblk, cm, ck, dr, row, za, xa, w, qa,
                                        qd, ga, gd, wd)
            g_a, d_a, c_a = gate(is_stuck, sgn, fc, v0, v1, v2)
            if g_a <= 0.0 and fresh[e] == 0:
                t_root = ta  # already past the event at the interval start
                for i in range(nm):
                    zt[i] = za[i]
                for q in range(nk):
                    xt[q] = xa[q]
            else:
                # quintic Hermite estimate, then Newton (second order) on the exact
                # intra-step solution; a last tiny step by the state's Taylor series
                g_a = max(g_a, 0.0)
                th = hermite_first_root(g_a, d_a * span, c_a * span * span, g_e,
                                        d_e * span, c_e * span * span)
                lo = ta
                hi = dt
                t_next = ta + th * span
                t_root = t_next
                for _ in range(_MAX_NEWTON_EVENT):
                    t_root = t_next  # evaluated now (its state: zt, xt)
                    h = t_root - ta
                    advance(nm, nk, s, tblk, za, xa, qa, qd, ga, gd, h, zt, xt)
                    for p in range(n_w):
                        w2[p] = w[p] + wd[p] * h
                    for i in range(nm):
                        qt[i] = qa[i] + qd[i] * h
                    for q in range(nk):
                        gt[q] = ga[q] + gd[q] * h
                    v0, v1, v2, sc = row_derivs(nm, nk, s, tblk, cm, ck, dr, row, zt, xt,
                                                w2, qt, qd, gt, gd, wd)
                    g_t, d_t, c_t = gate(is_stuck, sgn, fc, v0, v1, v2)
                    if g_t > 0.0:
                        lo = t_root
                    else:
                        hi = t_root
                    if g_t == 0.0:
                        break
                    if d_t != 0.0:
                        disc = d_t * d_t - 2.0 * g_t * c_t
                        if disc >= 0.0:
                            den = d_t + math.copysign(math.sqrt(disc), d_t)
                            step = -2.0 * g_t / den
                        else:
                            step = -g_t / d_t
                        t_next = t_root + step
                    else:
                        t_next = 0.5 * (lo + hi)
                    if not lo < t_next < hi:
                        t_next = 0.5 * (lo + hi)
                    step = t_next - t_root
                    if abs(step) <= _EVENT_TTOL * dt:
                        break
                    if abs(step) * smax <= 1e-4:
                        shift(nm, nk, s, tblk, zt, xt, qt, qd, gt, gd, step, zu, xu)
                        for i in range(nm):
                            zt[i] = zu[i]
                        for q in range(nk):
                            xt[q] = xu[q]
                        t_root = t_next
                        break
                fill_input(1.0, wa_s, wb_s, n_in, kind, par, dirs, mask, fbit, w2)
            if t_root < t_ev:
                t_ev = t_root
                e_ev = e
                for i in range(nm):
                    zs[i] = zt[i]
                for q in range(nk):
                    xs[q] = xt[q]
        if e_ev < 0:
            break
        n_ev += 1
        if n_ev > max_events:
            fail = j
            break
        # move to the event
        ta = t_ev
        span = dt - ta
        for i in range(nm):
            za[i] = zs[i]
        for q in range(nk):
            xa[q] = xs[q]
        for e in range(n_nl):
            fresh[e] = 0
        fill_input(ta / dt, wa_s, wb_s, n_in, kind, par, dirs, mask, fbit, w)
        e = e_ev
        if not (mask >> fbit[e]) & 1:
            for i in range(nm):
                zr[i] = za[i].real
                zi[i] = za[i].imag
            trial = row_value(nm, nk, cmr, cmi, ck, dr, row_t + e, zr, zi, xa, w)
            if abs(trial) > par[e, 0]:
                # reversal: same regime; superpose the force jump on the end state
                new_dir = -1.0 if trial > 0.0 else 1.0
                jump = -par[e, 0] * (new_dir - dirs[e])
                dirs[e] = new_dir
                if last_dir[e] != 0.0 and last_dir[e] != new_dir:
                    n_rev[e] += 1
                last_dir[e] = new_dir
                fresh[e] = 1
                p = n_in + e
                if jump != 0.0 and span > 0.0:
                    # response at the step end to a force step at ta: span phi1(s span) b
                    for i in range(nm):
                        ze[i] += (span * jump) * (phi1(s[i] * span) * bm[i, p])
                    if nk > 0:
                        for q in range(nk):
                            gt[q] = bblk[q, p] * jump
                        advance(nk * 0, nk, s, tblk, zero_m, zero_k, qt, zero_m, gt, zero_k,
                                span, zt, xt)
                        for q in range(nk):
                            xe[q] += xt[q]
                continue
            trial_mask = mask | (1 << fbit[e])
            forced = e - e - 1
        else:
            trial_mask = mask
            forced = e
        # stick or release: through the full state into the new regime
        for i in range(nm):
            zr[i] = za[i].real
            zi[i] = za[i].imag
        reconstruct(nm, nk, recr_a[r], reci_a[r], recb_a[r], zr, zi, xa, x)
        fill_input(ta / dt, wa_s, wb_s, n_in, kind, par, dirs, trial_mask, fbit, w)
        new = settle(trial_mask, forced, x, w, n_in, kind, par, fbit, hx, hw, dirs,
                     last_dir, n_rev, fresh)
        if forced < 0 and (new >> fbit[e]) & 1:
            fresh[e] = 1
        for e2 in range(n_nl):
            if kind[e2] == KIND_COULOMB and (new >> fbit[e2]) & 1 \
                    and not (mask >> fbit[e2]) & 1:
                n_stick[e2] += 1
        if new != mask:
            mask = new
            r = new
            nm = nm_a[r]
            nk = nk_a[r]
            to_regime(nm, nk, tomr_a[r], tomi_a[r], tob_a[r], x, zr, zi, xa)
            for i in range(nm):
                za[i] = complex(zr[i], zi[i])
        # the end state in the (new) regime
        s = s_a[r]
        bm = bm_a[r]
        tblk = tblk_a[r]
        bblk = bblk_a[r]
        fill_input(ta / dt, wa_s, wb_s, n_in, kind, par, dirs, mask, fbit, w)
        fill_input(1.0, wa_s, wb_s, n_in, kind, par, dirs, mask, fbit, w2)
        for i in range(nm):
            acc_a = 0j
            acc_e = 0j
            for p in range(n_w):
                acc_a += bm[i, p] * w[p]
                acc_e += bm[i, p] * w2[p]
            qa[i] = acc_a
            qd[i] = (acc_e - acc_a) / span if span > 0.0 else 0j
        for q in range(nk):
            acc_a = 0.0
            acc_e = 0.0
            for p in range(n_w):
                acc_a += bblk[q, p] * w[p]
                acc_e += bblk[q, p] * w2[p]
            ga[q] = acc_a
            gd[q] = (acc_e - acc_a) / span if span > 0.0 else 0.0
        advance(nm, nk, s, tblk, za, xa, qa, qd, ga, gd, span, ze, xe)
    if fail >= 0:
        return mask, fail
    nm = nm_a[r]
    nk = nk_a[r]
    for i in range(nm):
        zr[i] = ze[i].real
        zi[i] = ze[i].imag
    for q in range(nk):
        xi[q] = xe[q]
    fill_input(1.0, wa_s, wb_s, n_in, kind, par, dirs, mask, fbit, w2)
    hot_rows(nm, nk, cmr_a[r], cmi_a[r], ck_a[r], dr_a[r], zr, zi, xi, w2, hot)
    return mask, fail


# ----------------------------------------------------------------------------------
# the loop
# ----------------------------------------------------------------------------------


def run(
    u, dt, x0, n_out, nm_a, nk_a, smax_a, s_a, bm_a, lamr_a, lami_a, g0r_a, g0i_a, g1r_a,
    g1i_a, cm_a, cmr_a, cmi_a, recr_a, reci_a, tomr_a, tomi_a, tblk_a, bblk_a, ad_a,
    bd0_a, bd1_a, ck_a, recb_a, tob_a, dr_a, hx, hw, sens_a, act_a, nact_a, kind, par, fbit,
    cd, cv, max_newton, max_events,
):
    """Simulate; see :meth:`truthbench.simulate.nonlinear.NonlinearSystem.simulate`.

    Rows of every regime: ``[y; d; v; h; t; a zero row]``; per step only the regime's
    active rows ``act_a[r, :nact_a[r]]`` are computed (at least four: the first four are
    fused with the modal update).
    Returns ``(y, f, disp, vel, stuck, n_stick, n_rev, fail)`` where ``fail`` is -1 or
    the sample index at which the event limit per step was exceeded.
    """
    n_in, n_samples = u.shape
    n_nl = kind.shape[0]
    n_w = n_in + n_nl
    n_rows = cmr_a.shape[1]
    row_d = n_out
    row_v = n_out + n_nl
    row_h = n_out + 2 * n_nl
    row_t = n_out + 3 * n_nl
    n = x0.shape[0]
    m_max = lamr_a.shape[1]
    k_max = ad_a.shape[1]

    y = np.zeros((n_out, n_samples))
    fo = np.zeros((n_nl, n_samples))
    disp = np.zeros((n_nl, n_samples))
    vel = np.zeros((n_nl, n_samples))
    stuck = np.zeros((n_nl, n_samples), dtype=np.bool_)
    n_stick = np.zeros(n_nl, dtype=np.int64)
    n_rev = np.zeros(n_nl, dtype=np.int64)
    fail = -1

    dirs = np.zeros(n_nl)
    last_dir = np.zeros(n_nl)
    fresh = np.zeros(n_nl, dtype=np.int64)
    fsm = np.zeros(n_nl)  # smooth forces at the step start
    is_smooth = np.zeros(n_nl, dtype=np.bool_)
    n_smooth = 0
    n_fric = 0
    for e in range(n_nl):
        if kind[e] == KIND_COULOMB:
            n_fric += 1
        else:
            is_smooth[e] = True
            n_smooth += 1

    wa_s = np.zeros(n_w)  # step-start input (u and smooth forces)
    wb_s = np.zeros(n_w)  # step-end input
    wz = np.zeros((3, n_w))
    w = wz[0]
    w2 = wz[1]
    hot = np.zeros(n_rows)
    x = np.zeros(n)
    zr = np.zeros(m_max)
    zi = np.zeros(m_max)
    xi = np.zeros(k_max)
    zr0 = np.zeros(m_max)
    zi0 = np.zeros(m_max)
    xi0 = np.zeros(k_max)
    nxi = np.zeros(k_max)
    fr = np.zeros(m_max)
    fi = np.zeros(m_max)
    cfr = np.zeros(m_max)
    cfi = np.zeros(m_max)
    dyn = np.zeros(n_w, dtype=np.int64)  # inputs that vary within a step: u, smooth forces
    n_dyn = 0
    for p in range(n_w):
        if p < n_in or kind[p - n_in] != KIND_COULOMB:
            dyn[n_dyn] = p
            n_dyn += 1
    cz = np.zeros((10, m_max), dtype=np.complex128)  # event-path scratch
    rz = np.zeros((10, k_max))
    delta = np.zeros(n_nl)
    res = np.zeros(n_nl)
    jac = np.zeros((n_nl, n_nl))

    # ---- initial regime -----------------------------------------------------------
    # (integers derived from array sizes, not literals: numba would otherwise compile the
    # callees once more for literal arguments)
    zero = n_nl - n_nl
    mask = zero
    for e in range(n_nl):
        de = 0.0
        ve = 0.0
        for q in range(n):
            de += cd[e, q] * x0[q]
            ve += cv[e, q] * x0[q]
        if kind[e] == KIND_COULOMB:
            if ve > 0.0:
                dirs[e] = 1.0
            elif ve < 0.0:
                dirs[e] = -1.0
            else:
                mask |= 1 << fbit[e]
            last_dir[e] = dirs[e]
        else:
            fsm[e] = smooth_force(kind[e], par[e, 0], par[e, 1], de, ve)[0]
    for p in range(n_in):
        wa_s[p] = u[p, 0]
    for e in range(n_nl):
        wa_s[n_in + e] = fsm[e]
    fill_input(0.0, wa_s, wa_s, n_in, kind, par, dirs, mask, fbit, w)
    mask = settle(mask, zero - 1, x0, w, n_in, kind, par, fbit, hx, hw, dirs, last_dir, n_rev,
                  fresh)
    r = mask
    to_regime(nm_a[r], nk_a[r], tomr_a[r], tomi_a[r], tob_a[r], x0, zr, zi, xi)
    for p in range(n_w):
        wb_s[p] = wa_s[p]
    fill_input(1.0, wa_s, wb_s, n_in, kind, par, dirs, mask, fbit, w2)
    hot_rows(nm_a[r], nk_a[r], cmr_a[r], cmi_a[r], ck_a[r], dr_a[r], zr, zi, xi, w2, hot)

    record(0, hot, n_out, row_d, row_v, row_h, n_in, par, fbit, mask, dirs, is_smooth, wb_s,
           fsm, y, fo, disp, vel, stuck)
    j = zero
    while j < n_samples - 1:
        # the regime's arrays, invariant in the inner loop (which leaves when the regime
        # changes): loop-invariant views let LLVM vectorise the loops over modes
        nm = nm_a[r]
        nk = nk_a[r]
        lamr = lamr_a[r]
        lami = lami_a[r]
        g0r = g0r_a[r]
        g0i = g0i_a[r]
        g1r = g1r_a[r]
        g1i = g1i_a[r]
        cmr = cmr_a[r]
        cmi = cmi_a[r]
        ck = ck_a[r]
        dr = dr_a[r]
        ad = ad_a[r]
        bd0 = bd0_a[r]
        bd1 = bd1_a[r]
        sens = sens_a[r]
        act = act_a[r]
        nact = nact_a[r]
        o0 = act[0]
        o1 = act[1]
        o2 = act[2]
        o3 = act[3]
        fric_forcing(nm, n_in, kind, par, fbit, mask, dirs, g0r, g0i, g1r, g1i, cfr, cfi)
        while j < n_samples - 1:
            for p in range(n_in):
                wa_s[p] = u[p, j]
                wb_s[p] = u[p, j + 1]
            for e in range(n_nl):
                wa_s[n_in + e] = fsm[e]
                wb_s[n_in + e] = fsm[e]  # predictor for the smooth forces
            fill_input(0.0, wa_s, wb_s, n_in, kind, par, dirs, mask, fbit, w)
            fill_input(1.0, wa_s, wb_s, n_in, kind, par, dirs, mask, fbit, w2)
            # forcing: the friction forces are constant between events (cfr, cfi)
            for i in range(nm):
                fr[i] = cfr[i]
                fi[i] = cfi[i]
            for q2 in range(n_dyn):
                p = dyn[q2]
                a0 = w[p]
                a1 = w2[p]
                if a0 == 0.0 and a1 == 0.0:
                    continue
                for i in range(nm):
                    fr[i] += g0r[p, i] * a0 + g1r[p, i] * a1
                    fi[i] += g0i[p, i] * a0 + g1i[p, i] * a1
            # advance the modes in place (few arrays in the loop: LLVM vectorises it) fused
            # with the first four rows; the step-start state is kept for the event path
            if n_fric > 0:
                for i in range(nm):
                    zr0[i] = zr[i]
                    zi0[i] = zi[i]
                for q in range(nk):
                    xi0[q] = xi[q]
            s0 = 0.0
            s1 = 0.0
            s2 = 0.0
            s3 = 0.0
            for i in range(nm):
                a = zr[i]
                b = zi[i]
                na = lamr[i] * a - lami[i] * b + fr[i]
                nb = lamr[i] * b + lami[i] * a + fi[i]
                zr[i] = na
                zi[i] = nb
                s0 += cmr[o0, i] * na - cmi[o0, i] * nb
                s1 += cmr[o1, i] * na - cmi[o1, i] * nb
                s2 += cmr[o2, i] * na - cmi[o2, i] * nb
                s3 += cmr[o3, i] * na - cmi[o3, i] * nb
            hot[o0] = s0
            hot[o1] = s1
            hot[o2] = s2
            hot[o3] = s3
            for q in range(4, nact):
                o = act[q]
                s0 = 0.0
                for i in range(nm):
                    s0 += cmr[o, i] * zr[i] - cmi[o, i] * zi[i]
                hot[o] = s0
            for q in range(nk):
                acc = 0.0
                for c in range(nk):
                    acc += ad[q, c] * xi0[c]
                for p in range(n_w):
                    acc += bd0[q, p] * w[p] + bd1[q, p] * w2[p]
                nxi[q] = acc
            for q in range(nk):
                xi[q] = nxi[q]
            for q2 in range(nact):
                o = act[q2]
                acc = hot[o]
                for q in range(nk):
                    acc += ck[o, q] * xi[q]
                for p in range(n_w):
                    acc += dr[o, p] * w2[p]
                hot[o] = acc

            # -- smooth forces at the step end: Newton on f = g(d(f), v(f)) with the exact
            #    linear sensitivity of the rows to the forces at the step end
            if n_smooth > 0:
                for e in range(n_nl):
                    delta[e] = 0.0
                for _ in range(max_newton):
                    big = 0.0
                    for e in range(n_nl):
                        for k2 in range(n_nl):
                            jac[e, k2] = 0.0
                        jac[e, e] = 1.0
                        res[e] = 0.0
                        if not is_smooth[e]:
                            continue
                        de = hot[row_d + e]
                        ve = hot[row_v + e]
                        for k2 in range(n_nl):
                            de += sens[row_d + e, k2] * delta[k2]
                            ve += sens[row_v + e, k2] * delta[k2]
                        fe, fd, fv = smooth_force(kind[e], par[e, 0], par[e, 1], de, ve)
                        res[e] = fsm[e] + delta[e] - fe
                        big = max(big, abs(fe))
                        for k2 in range(n_nl):
                            jac[e, k2] -= fd * sens[row_d + e, k2] + fv * sens[row_v + e, k2]
                    if n_nl == 1:
                        stp0 = res[0] / jac[0, 0]
                        delta[0] -= stp0
                        change = abs(stp0)
                    else:
                        stp = solve_small(jac, res)
                        change = 0.0
                        for e in range(n_nl):
                            delta[e] -= stp[e]
                            change = max(change, abs(stp[e]))
                    if change <= 1e-14 * big or change == 0.0:
                        break
                for e in range(n_nl):
                    de = delta[e]
                    if de == 0.0:
                        continue
                    p = n_in + e
                    wb_s[p] += de
                    w2[p] += de
                    for i in range(nm):
                        zr[i] += g1r[p, i] * de
                        zi[i] += g1i[p, i] * de
                    for q in range(nk):
                        xi[q] += bd1[q, p] * de
                    for q2 in range(nact):
                        o = act[q2]
                        hot[o] += sens[o, e] * de

            # -- friction gates at the step end
            event = False
            for e in range(n_nl):
                if kind[e] != KIND_COULOMB:
                    continue
                if (mask >> fbit[e]) & 1:
                    if par[e, 0] - abs(hot[row_h + e]) < 0.0:
                        event = True
                elif dirs[e] * hot[row_v + e] < 0.0:
                    event = True

            if event:
                # -- event path: the step piece by piece from its start
                mask, fail = event_step(
                    j, dt, mask, n_in, row_v, row_h, row_t, max_events, nm_a, nk_a,
                    smax_a, s_a, bm_a, cm_a, cmr_a, cmi_a, recr_a, reci_a, tomr_a, tomi_a,
                    tblk_a, bblk_a, ck_a, recb_a, tob_a, dr_a, hx, hw, kind, par, fbit, dirs,
                    last_dir, fresh, n_rev, n_stick, wa_s, wb_s, zr0, zi0, xi0, zr, zi, xi,
                    hot, cz, rz, wz, x,
                )
                if fail >= 0:
                    break
                fric_forcing(nm, n_in, kind, par, fbit, mask, dirs, g0r, g0i, g1r, g1i, cfr,
                             cfi)
            j += 1
            record(j, hot, n_out, row_d, row_v, row_h, n_in, par, fbit, mask, dirs,
                   is_smooth, wb_s, fsm, y, fo, disp, vel, stuck)
            if mask != r:
                break
        if fail >= 0:
            break
        r = mask
    return y, fo, disp, vel, stuck, n_stick, n_rev, fail
