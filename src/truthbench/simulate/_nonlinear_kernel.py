"""The per-sample loop of :mod:`truthbench.simulate.nonlinear` (plain Python source).

This module never imports numba. Its functions are written in the subset of Python that
``numba.njit`` compiles, so the same source runs two ways with identical arithmetic:

* interpreted, as the always-available fallback (``backend="numpy"``; slow, meant for
  small systems and for checking the compiled engine);
* compiled, by :mod:`truthbench.simulate._nonlinear_numba`, which re-binds every function
  here to a copy whose globals point at the compiled helpers and wraps it in
  ``numba.njit(cache=True)``.

The system is a set of *regimes*, one per subset ``S`` of stuck friction elements
(``r`` is the bit mask of ``S``). In each regime the motion is linear,
``xi' = A_r xi + B_r w`` with the input ``w = [u; f_nl]`` (friction forces of the stuck
elements are replaced by their holding forces, which are outputs), and is advanced
exactly for a piecewise-linear ``w``: diagonal complex modes plus a small dense block
(see :mod:`truthbench.simulate.linear`). Every regime has the same output rows
``[y (n_out); d (n_nl); v (n_nl); h (n_nl)]``: the outputs, the element displacements
and velocities, and the holding forces (zero rows for elements that are not stuck).

Per step the fast path advances the current regime over the whole step (precomputed
weights), corrects the smooth element forces at the step end (Newton on the exact
linear sensitivity), and checks the friction events at the step end. Only if an event
occurred is the step redone by the event path: exact propagation to arbitrary times
inside the step (``exp(s h)`` per mode, a small matrix exponential for the block),
Illinois root finding of the first event, the switch, and so on to the step end.
"""

from __future__ import annotations

import math

import numpy as np

KIND_COULOMB = 0
KIND_CUBIC = 1
KIND_DEADBAND = 2
KIND_QUADRATIC_DAMPING = 3

_N_TAYLOR = 20
#: 1/k! for k = 0..22 (Taylor series of phi1, phi2 and of the block exponential)
_INV_FACT = np.array([1.0 / math.factorial(k) for k in range(_N_TAYLOR + 3)])
#: relative size below which an event function value counts as rounding noise
_EVENT_RTOL = 1e-12
#: Illinois iterations before giving up on a root (bracket width ~ dt * 2**-60 by then)
_MAX_ROOT_ITER = 200


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
# exact propagation over a part of a step
# ----------------------------------------------------------------------------------


def phi12(a):
    """``phi1(a) = (e^a - 1)/a`` and ``phi2(a) = (e^a - 1 - a)/a^2`` for complex ``a``."""
    if abs(a) < 0.5:
        p1 = _INV_FACT[_N_TAYLOR + 1] + 0j
        p2 = _INV_FACT[_N_TAYLOR + 2] + 0j
        for k in range(_N_TAYLOR - 1, -1, -1):
            p1 = p1 * a + _INV_FACT[k + 1]
            p2 = p2 * a + _INV_FACT[k + 2]
        return p1, p2
    p1 = (np.exp(a) - 1.0) / a
    return p1, (p1 - 1.0) / a


def expm_small(m):
    """Matrix exponential of a small real matrix (scaling and squaring, Taylor 20)."""
    n = m.shape[0]
    norm = 0.0
    for c in range(n):
        col = 0.0
        for r in range(n):
            col += abs(m[r, c])
        norm = max(norm, col)
    s = 0
    while norm > 0.5:
        norm *= 0.5
        s += 1
    a = m * (0.5**s)
    e = np.eye(n)
    for k in range(_N_TAYLOR, 0, -1):
        e = np.eye(n) + (a @ e) * (1.0 / k)
    for _ in range(s):
        e = e @ e
    return e


def propagate(nm, nk, s, bm, tblk, bblk, zr, zi, xi, h, wa, wb, ozr, ozi, oxi):
    """Exact state after time ``h`` for an input linear from ``wa`` to ``wb``.

    Writes the modal state to ``ozr``/``ozi`` and the block state to ``oxi``.
    """
    n_w = wa.shape[0]
    for i in range(nm):
        qa = 0j
        qb = 0j
        for p in range(n_w):
            qa += bm[i, p] * wa[p]
            qb += bm[i, p] * wb[p]
        a = s[i] * h
        p1, p2 = phi12(a)
        z = complex(zr[i], zi[i]) * np.exp(a) + h * ((p1 - p2) * qa + p2 * qb)
        ozr[i] = z.real
        ozi[i] = z.imag
    if nk > 0:
        aug = np.zeros((nk + 2, nk + 2))
        for q in range(nk):
            for c in range(nk):
                aug[q, c] = h * tblk[q, c]
            g0 = 0.0
            g1 = 0.0
            for p in range(n_w):
                g0 += bblk[q, p] * wa[p]
                g1 += bblk[q, p] * (wb[p] - wa[p])
            aug[q, nk] = h * g0
            aug[q, nk + 1] = h * g1
        aug[nk + 1, nk] = 1.0
        e = expm_small(aug)
        for q in range(nk):
            acc = e[q, nk]
            for c in range(nk):
                acc += e[q, c] * xi[c]
            oxi[q] = acc


def row_value(nm, nk, cmr, cmi, ck, dr, row, zr, zi, xi, w):
    """One output row ``Re(cm z) + Ck xi + D w`` of the current regime."""
    acc = 0.0
    for i in range(nm):
        acc += cmr[row, i] * zr[i] - cmi[row, i] * zi[i]
    for q in range(nk):
        acc += ck[row, q] * xi[q]
    for p in range(w.shape[0]):
        acc += dr[row, p] * w[p]
    return acc


def row_scale(nm, nk, cmr, cmi, ck, dr, row, zr, zi, xi, w):
    """Sum of the magnitudes of the terms of a row: the size of its rounding error."""
    acc = 0.0
    for i in range(nm):
        acc += abs(cmr[row, i] * zr[i]) + abs(cmi[row, i] * zi[i])
    for q in range(nk):
        acc += abs(ck[row, q] * xi[q])
    for p in range(w.shape[0]):
        acc += abs(dr[row, p] * w[p])
    return acc


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
    stuck element needs more than its friction force (the largest ratio first, or the
    element ``forced`` if it is >= 0), it is released in the direction ``-sign(h)``.
    ``w`` (friction entries) and ``dirs`` are updated in place. Returns the new mask.
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


def root(
    nm, nk, s, bm, tblk, bblk, cmr, cmi, ck, dr, row, sgn, is_stuck, fc, zr, zi, xi, ta, dt,
    g_lo, g_hi, wa_s, wb_s, n_in, kind, par, dirs, mask, fbit, w, wt, tzr, tzi, txi,
):
    """First zero of an event gate in ``(ta, dt]`` by the Illinois method.

    The gate is ``sgn * v`` (slipping element) or ``F_c - |h|`` (stuck element) on the
    exact intra-step solution from the state ``(zr, zi, xi)`` at ``ta`` with input ``w``
    there; ``g_lo >= 0`` at ``ta`` and ``g_hi < 0`` at ``dt``. Returns the right end of
    the final bracket (the gate is <= 0 there: just past the event), to within
    ``1e-14 dt``.
    """
    lo = ta
    hi = dt
    side = 0
    for _ in range(_MAX_ROOT_ITER):
        if hi - lo <= 1e-14 * dt:
            break
        if g_lo > 0.0:
            t = hi - g_hi * (hi - lo) / (g_hi - g_lo)
        else:
            t = 0.5 * (lo + hi)
        if not lo < t < hi:
            t = 0.5 * (lo + hi)
            if not lo < t < hi:
                break
        fill_input(t / dt, wa_s, wb_s, n_in, kind, par, dirs, mask, fbit, wt)
        propagate(nm, nk, s, bm, tblk, bblk, zr, zi, xi, t - ta, w, wt, tzr, tzi, txi)
        val = row_value(nm, nk, cmr, cmi, ck, dr, row, tzr, tzi, txi, wt)
        g = fc - abs(val) if is_stuck else sgn * val
        if g > 0.0:
            lo = t
            g_lo = g
            if side == 1:
                g_hi *= 0.5
            side = 1
        else:
            hi = t
            g_hi = g
            if g == 0.0:
                break
            if side == -1:
                g_lo *= 0.5
            side = -1
    return hi



# ----------------------------------------------------------------------------------
# the loop
# ----------------------------------------------------------------------------------


def run(
    u, dt, x0, nm_a, nk_a, s_a, bm_a, lamr_a, lami_a, g0r_a, g0i_a, g1r_a, g1i_a,
    cmr_a, cmi_a, recr_a, reci_a, tomr_a, tomi_a, tblk_a, bblk_a, ad_a, bd0_a, bd1_a,
    ck_a, recb_a, tob_a, dr_a, hx, hw, gam_a, kind, par, fbit, cd, cv, max_newton,
    max_events,
):  # noqa: PLR0912, PLR0915 - one fused loop on purpose (it is compiled as a whole)
    """Simulate; see :func:`truthbench.simulate.nonlinear.NonlinearSystem.simulate`.

    Returns ``(y, f, disp, vel, stuck, n_stick, n_rev, fail)`` where ``fail`` is -1 or
    the sample index at which the event limit per step was exceeded.
    """
    n_in, n_samples = u.shape
    n_nl = kind.shape[0]
    n_w = n_in + n_nl
    n_rows = cmr_a.shape[1]
    n_out = n_rows - 3 * n_nl
    row_d = n_out
    row_v = n_out + n_nl
    row_h = n_out + 2 * n_nl
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
    fsm_a = np.zeros(n_nl)  # smooth forces at the step start
    is_smooth = np.zeros(n_nl, dtype=np.bool_)
    n_smooth = 0
    for e in range(n_nl):
        if kind[e] != KIND_COULOMB:
            is_smooth[e] = True
            n_smooth += 1

    wa_s = np.zeros(n_w)  # step-start input (u and smooth forces; friction filled in)
    wb_s = np.zeros(n_w)  # step-end input
    w = np.zeros(n_w)
    w2 = np.zeros(n_w)
    x_in = np.zeros(n_w)
    x = np.zeros(n)
    zr = np.zeros(m_max)
    zi = np.zeros(m_max)
    xi = np.zeros(k_max)
    nzr = np.zeros(m_max)
    nzi = np.zeros(m_max)
    nxi = np.zeros(k_max)
    tzr = np.zeros(m_max)
    tzi = np.zeros(m_max)
    txi = np.zeros(k_max)
    fr = np.zeros(m_max)
    fi = np.zeros(m_max)
    delta = np.zeros(n_nl)
    dp = np.zeros(n_nl)
    vp = np.zeros(n_nl)
    res = np.zeros(n_nl)
    jac = np.zeros((n_nl, n_nl))
    gate = np.zeros(n_nl)

    # ---- initial regime -----------------------------------------------------------
    mask = 0
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
            fsm_a[e] = smooth_force(kind[e], par[e, 0], par[e, 1], de, ve)[0]
    for p in range(n_in):
        wa_s[p] = u[p, 0]
    for e in range(n_nl):
        wa_s[n_in + e] = fsm_a[e]
    fill_input(0.0, wa_s, wa_s, n_in, kind, par, dirs, mask, fbit, w)
    mask = settle(mask, -1, x0, w, n_in, kind, par, fbit, hx, hw, dirs, last_dir, n_rev, fresh)
    for e in range(n_nl):
        fresh[e] = 0
    r = mask
    nm = nm_a[r]
    nk = nk_a[r]
    to_regime(nm, nk, tomr_a[r], tomi_a[r], tob_a[r], x0, zr, zi, xi)

    # record sample 0
    fill_input(0.0, wa_s, wa_s, n_in, kind, par, dirs, mask, fbit, w)
    for o in range(n_rows):
        val = row_value(nm, nk, cmr_a[r], cmi_a[r], ck_a[r], dr_a[r], o, zr, zi, xi, w)
        if o < n_out:
            y[o, 0] = val
        elif o < row_v:
            disp[o - row_d, 0] = val
        elif o < row_h:
            vel[o - row_v, 0] = val
        else:
            e = o - row_h
            if kind[e] == KIND_COULOMB and (mask >> fbit[e]) & 1:
                fo[e, 0] = val
                stuck[e, 0] = True
    for e in range(n_nl):
        if is_smooth[e]:
            fo[e, 0] = fsm_a[e]
        elif not stuck[e, 0]:
            fo[e, 0] = -par[e, 0] * dirs[e]

    # ---- the loop -------------------------------------------------------------------
    for j in range(n_samples - 1):
        for p in range(n_in):
            wa_s[p] = u[p, j]
            wb_s[p] = u[p, j + 1]
        for e in range(n_nl):
            wa_s[n_in + e] = fsm_a[e]
            wb_s[n_in + e] = fsm_a[e]  # predictor for the smooth forces
        fill_input(0.0, wa_s, wb_s, n_in, kind, par, dirs, mask, fbit, w)
        fill_input(1.0, wa_s, wb_s, n_in, kind, par, dirs, mask, fbit, w2)

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

        # -- fast path: the whole step in the current regime
        for i in range(nm):
            fr[i] = 0.0
            fi[i] = 0.0
        for p in range(n_w):
            a0 = w[p]
            a1 = w2[p]
            if a0 == 0.0 and a1 == 0.0:
                continue
            for i in range(nm):
                fr[i] += g0r[p, i] * a0 + g1r[p, i] * a1
                fi[i] += g0i[p, i] * a0 + g1i[p, i] * a1
        for i in range(nm):
            a = zr[i]
            b = zi[i]
            nzr[i] = lamr[i] * a - lami[i] * b + fr[i]
            nzi[i] = lamr[i] * b + lami[i] * a + fi[i]
        for q in range(nk):
            acc = 0.0
            for c in range(nk):
                acc += ad[q, c] * xi[c]
            for p in range(n_w):
                acc += bd0[q, p] * w[p] + bd1[q, p] * w2[p]
            nxi[q] = acc

        # -- smooth forces at the step end: Newton on f = g(d(f), v(f)), linear sensitivity
        if n_smooth > 0:
            gam = gam_a[r]
            for e in range(n_nl):
                delta[e] = 0.0
                if is_smooth[e]:
                    dp[e] = row_value(nm, nk, cmr, cmi, ck, dr, row_d + e, nzr, nzi, nxi, w2)
                    vp[e] = row_value(nm, nk, cmr, cmi, ck, dr, row_v + e, nzr, nzi, nxi, w2)
            for _ in range(max_newton):
                big = 0.0
                for e in range(n_nl):
                    for k2 in range(n_nl):
                        jac[e, k2] = 0.0
                    jac[e, e] = 1.0
                    res[e] = 0.0
                    if not is_smooth[e]:
                        continue
                    de = dp[e]
                    ve = vp[e]
                    for k2 in range(n_nl):
                        de += gam[e, k2] * delta[k2]
                        ve += gam[n_nl + e, k2] * delta[k2]
                    fe, fd, fv = smooth_force(kind[e], par[e, 0], par[e, 1], de, ve)
                    res[e] = fsm_a[e] + delta[e] - fe
                    big = max(big, abs(fe))
                    for k2 in range(n_nl):
                        jac[e, k2] -= fd * gam[e, k2] + fv * gam[n_nl + e, k2]
                if n_nl == 1:
                    step = res[0] / jac[0, 0]
                    delta[0] -= step
                    change = abs(step)
                else:
                    stp = np.linalg.solve(jac, res)
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
                    nzr[i] += g1r[p, i] * de
                    nzi[i] += g1i[p, i] * de
                for q in range(nk):
                    nxi[q] += bd1[q, p] * de

        # -- friction events at the step end?
        event = False
        for e in range(n_nl):
            if kind[e] != KIND_COULOMB:
                continue
            if (mask >> fbit[e]) & 1:
                he = row_value(nm, nk, cmr, cmi, ck, dr, row_h + e, nzr, nzi, nxi, w2)
                gate[e] = par[e, 0] - abs(he)
            else:
                ve = row_value(nm, nk, cmr, cmi, ck, dr, row_v + e, nzr, nzi, nxi, w2)
                gate[e] = dirs[e] * ve
            if gate[e] < 0.0:
                event = True

        if not event:
            for i in range(nm):
                zr[i] = nzr[i]
                zi[i] = nzi[i]
            for q in range(nk):
                xi[q] = nxi[q]
        else:
            # -- event path: redo the step piecewise, exactly, from its start
            ta = 0.0
            n_ev = 0
            for e in range(n_nl):
                fresh[e] = 0
            while True:
                nm = nm_a[r]
                nk = nk_a[r]
                s = s_a[r]
                bm = bm_a[r]
                tblk = tblk_a[r]
                bblk = bblk_a[r]
                cmr = cmr_a[r]
                cmi = cmi_a[r]
                ck = ck_a[r]
                dr = dr_a[r]
                fill_input(ta / dt, wa_s, wb_s, n_in, kind, par, dirs, mask, fbit, w)
                fill_input(1.0, wa_s, wb_s, n_in, kind, par, dirs, mask, fbit, w2)
                propagate(nm, nk, s, bm, tblk, bblk, zr, zi, xi, dt - ta, w, w2, nzr, nzi, nxi)
                # first event among the elements whose gate is clearly negative at the end
                t_ev = 2.0 * dt
                e_ev = -1
                for e in range(n_nl):
                    if kind[e] != KIND_COULOMB:
                        continue
                    is_stuck = (mask >> fbit[e]) & 1
                    row = row_h + e if is_stuck else row_v + e
                    sgn = 1.0 if is_stuck else dirs[e]
                    val = row_value(nm, nk, cmr, cmi, ck, dr, row, nzr, nzi, nxi, w2)
                    g_end = par[e, 0] - abs(val) if is_stuck else sgn * val
                    scale = row_scale(nm, nk, cmr, cmi, ck, dr, row, nzr, nzi, nxi, w2)
                    if is_stuck:
                        scale = max(scale, par[e, 0])
                    tol = _EVENT_RTOL * scale
                    if not g_end < -tol:
                        continue
                    # the gate at the interval start
                    val = row_value(nm, nk, cmr, cmi, ck, dr, row, zr, zi, xi, w)
                    g_a = par[e, 0] - abs(val) if is_stuck else sgn * val
                    if g_a <= 0.0 and fresh[e] == 0:
                        t_root = ta
                    else:
                        t_root = root(
                            nm, nk, s, bm, tblk, bblk, cmr, cmi, ck, dr, row, sgn, is_stuck,
                            par[e, 0], zr, zi, xi, ta, dt, max(g_a, 0.0), g_end, wa_s, wb_s,
                            n_in, kind, par, dirs, mask, fbit, w, x_in, tzr, tzi, txi,
                        )
                    if t_root < t_ev:
                        t_ev = t_root
                        e_ev = e
                if e_ev < 0:
                    for i in range(nm):
                        zr[i] = nzr[i]
                        zi[i] = nzi[i]
                    for q in range(nk):
                        xi[q] = nxi[q]
                    break
                n_ev += 1
                if n_ev > max_events:
                    fail = j
                    break
                # state at the event
                fill_input(t_ev / dt, wa_s, wb_s, n_in, kind, par, dirs, mask, fbit, w2)
                if t_ev > ta:
                    propagate(nm, nk, s, bm, tblk, bblk, zr, zi, xi, t_ev - ta, w, w2,
                              tzr, tzi, txi)
                    for i in range(nm):
                        zr[i] = tzr[i]
                        zi[i] = tzi[i]
                    for q in range(nk):
                        xi[q] = txi[q]
                reconstruct(nm, nk, recr_a[r], reci_a[r], recb_a[r], zr, zi, xi, x)
                for e in range(n_nl):
                    fresh[e] = 0
                if (mask >> fbit[e_ev]) & 1:
                    new = settle(mask, e_ev, x, w2, n_in, kind, par, fbit, hx, hw, dirs,
                                 last_dir, n_rev, fresh)
                else:
                    trial = mask | (1 << fbit[e_ev])
                    fill_input(t_ev / dt, wa_s, wb_s, n_in, kind, par, dirs, trial, fbit, w2)
                    new = settle(trial, -1, x, w2, n_in, kind, par, fbit, hx, hw, dirs,
                                 last_dir, n_rev, fresh)
                    if (new >> fbit[e_ev]) & 1:
                        fresh[e_ev] = 1
                for e in range(n_nl):
                    if kind[e] == KIND_COULOMB and (new >> fbit[e]) & 1 and not (
                        (mask >> fbit[e]) & 1
                    ):
                        n_stick[e] += 1
                if new != mask:
                    mask = new
                    r = new
                    nm = nm_a[r]
                    nk = nk_a[r]
                    to_regime(nm, nk, tomr_a[r], tomi_a[r], tob_a[r], x, zr, zi, xi)
                ta = t_ev
            if fail >= 0:
                break

        # -- record sample j+1
        nm = nm_a[r]
        nk = nk_a[r]
        cmr = cmr_a[r]
        cmi = cmi_a[r]
        ck = ck_a[r]
        dr = dr_a[r]
        fill_input(1.0, wa_s, wb_s, n_in, kind, par, dirs, mask, fbit, w2)
        for o in range(n_rows):
            if o >= row_h:
                e = o - row_h
                if kind[e] != KIND_COULOMB or not (mask >> fbit[e]) & 1:
                    continue
            val = row_value(nm, nk, cmr, cmi, ck, dr, o, zr, zi, xi, w2)
            if o < n_out:
                y[o, j + 1] = val
            elif o < row_v:
                disp[o - row_d, j + 1] = val
            elif o < row_h:
                vel[o - row_v, j + 1] = val
            else:
                fo[o - row_h, j + 1] = val
                stuck[o - row_h, j + 1] = True
        for e in range(n_nl):
            if is_smooth[e]:
                fsm_a[e] = wb_s[n_in + e]
                fo[e, j + 1] = fsm_a[e]
            elif not stuck[e, j + 1]:
                fo[e, j + 1] = -par[e, 0] * dirs[e]
    return y, fo, disp, vel, stuck, n_stick, n_rev, fail
