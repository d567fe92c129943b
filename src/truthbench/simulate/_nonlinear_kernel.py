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
piecewise-linear ``w`` by diagonal complex modes ``z`` (kept as separate real and
imaginary float arrays, so that the loops over modes vectorise) plus a small dense block
``xi`` (see :mod:`truthbench.simulate.linear`). Every regime has the same output rows
``[y (n_out); d; v; h; t (n_nl each); 0]``: outputs, element displacements and
velocities, holding forces of the stuck elements, the *trial* holding force of each
slipping element (the force that would keep its velocity at zero, the others as they
are) and a zero row. Per step only the regime's *active* rows are computed (outputs,
smooth elements' displacements, velocities of elements not stuck, holding forces).

**Fast path** (a step without an event), as :func:`truthbench.simulate._kernels_numba.
_fused_loop`: the modal forcing (the constant slipping-friction forces folded in), then
one pass over the modes that advances them, keeps the step-start state for the event path
and accumulates the first five active rows (four outputs and the friction gate for the
usual layout), further rows four at a time. Then the smooth element forces are corrected
at the step end (Newton on the exact linear sensitivity) and the friction gates checked:
``dir * v`` of a slipping element, ``F_c - |h|`` of a stuck one. With one friction
element and no other element the gate and the records come straight from its row.

**A gate that dips inside a step.** A velocity can touch zero and come back within one
step (stick and breakaway, or two reversals, between two samples); the gate is then
positive at both ends. When a gate is near zero for the size of its derivatives, the
fast path also takes its first two derivatives at the step end (one pass over the
modes; those at the start are the previous step's) and flags the step if the quintic
through them comes within a wide margin of zero inside (:func:`dip_suspect`); the event
path then finds the exact least value of the gate in the step (Newton on its derivative)
and, if it is negative, the first zero before it.

**Event path.** If a gate went negative (or was flagged) the step is redone from its
start, interval by interval: the first zero of each gate is estimated from a quintic
Hermite interpolant (gate value and two time derivatives at both ends; the derivatives
come from precomputed rows ``c s``, ``c s^2``, one pass over the modes) and polished by
Newton's method on the exact intra-step solution to ``1e-12 dt`` (:func:`rows_at`: the
rows at a trial time in one pass that stores nothing). The exact state after an arbitrary
time ``h = h_k + delta`` (``h_k = k dt / N`` the nearest point of a grid of the step)
needs no exponential: ``exp(s h_k)`` and the two input integrals at ``h_k`` are tabulated
per regime, and the remaining ``|s delta| <= |s| dt / 2N`` is covered by the Taylor
series of the state to the fixed degree :data:`TAYLOR_DEGREE` (the grid, 16 to 256
points, is chosen at preparation for a truncation below 1e-18). Modes too stiff for the
grid (``|s| dt`` above about 20) and large or stiff dense blocks fall back to
exponentials. At a velocity zero the trial holding force decides: within ``F_c`` the
element sticks (regime change: the state is mapped through the full state ``x``), beyond
it the velocity reverses, which needs no regime change, only the response to the force
jump added to the step-end state and its rows (:func:`add_jump`); the state at the
reversal itself is computed only if a further event in the same step needs it. A stuck
element whose holding force reaches ``F_c`` is released in the direction of
``-sign(h)``. Known limit: after a reversal inside a step, a further touch of zero and
back of the same velocity within that step (three sign changes in one step) is not
looked for.

Nothing here allocates except :func:`run`, which allocates every array and calls
:func:`loop`: the compiled engine builds everything else without reference counting.
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
_N_SCAN = 32
#: a gate positive at both ends of a step is checked for a dip below zero inside when
#: the quintic through its values and derivatives comes within this fraction of
#: ``(|s|max dt)^3 x`` the size of its derivative terms (the quintic's own error is some
#: ``(|s| dt)^3 / 46080`` of that)
_DIP_MARGIN = 0.01
#: ... and only when the gate is within this multiple of its derivative terms (in units
#: of a step) of zero at an end, those terms refreshed at least every _DIP_EVERY steps
_DIP_FAR = 16.0
_DIP_EVERY = 8
#: degree of ``phi2`` in the Taylor step from a grid point (fixed: the loops unroll);
#: the grid is chosen fine enough (``max |s| dt / 2N``, see ``nonlinear._tables``) for
#: the first term left out to be below 1e-18 of the state
TAYLOR_DEGREE = 6
#: rows of the modal and block scratch arrays of the event path
N_SCRATCH_MODAL = 6
N_SCRATCH_BLOCK = 14
#: rows of the input scratch of the event path
N_SCRATCH_INPUT = 4


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


def expm_small(m, e, t):
    """``e = exp(m)`` for a small real matrix (scaling and squaring, Taylor 20); ``m`` is
    overwritten, ``t`` is scratch (all ``n x n``, no allocation)."""
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
    scale = 0.5**sq
    for r in range(n):
        for c in range(n):
            m[r, c] *= scale
            e[r, c] = 0.0
        e[r, r] = 1.0
    for k in range(_EXPM_TERMS, 0, -1):  # Horner: e <- I + m e / k
        matmul(m, e, t)
        for r in range(n):
            for c in range(n):
                e[r, c] = t[r, c] / k
            e[r, r] += 1.0
    for _ in range(sq):
        matmul(e, e, t)
        for r in range(n):
            for c in range(n):
                e[r, c] = t[r, c]


def solve_small(a, b, m, x):
    """Solve ``a x = b`` for a small square ``a`` (Gauss, partial pivoting) into ``x``;
    ``m`` is scratch of the shape of ``a``."""
    n = a.shape[0]
    for r in range(n):
        x[r] = b[r]
        for c in range(n):
            m[r, c] = a[r, c]
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


#: the per-regime arrays (each stacked over the regimes, first axis) in the order of the
#: tuple ``reg`` that :func:`run` takes (built by ``nonlinear.prepare_nonlinear``):
#:
#: * ``dims`` (int: ``nm`` modes, ``nt`` tabulated modes, ``nk`` block states, ``btab``
#:   block tabulated), ``smax`` (largest ``|s|``, ``||T||``);
#: * modes: ``s2`` (``Re s``, ``Im s``), ``lam`` (``exp(s dt)``), ``g`` (step weights of
#:   ``w`` at both ends, re/im), ``bm`` (modal input), ``crow`` (rows ``c``, ``c s``,
#:   ``c s^2``, re/im), ``rec``/``tom`` (to and from the state ``x``), ``tab`` (step grid
#:   tables, see :func:`propagate`);
#: * block: ``tblk`` (``T``), ``bblk``, ``ad``, ``bd`` (step weights), ``ckr`` (rows
#:   ``Ck``, ``Ck T``, ``Ck T^2``), ``recb``/``tob``, ``etab`` (step grid tables);
#: * ``dw`` (input weights of a row and its derivatives), ``hx``/``hw`` (holding forces),
#:   ``sens`` (rows' sensitivity to the forces), ``act``/``nact`` (active rows),
#:   ``dact``/``ndact`` (active rows with a direct input term).
REGIME_ARRAYS = (
    "dims", "smax", "s2", "lam", "g", "bm", "crow", "rec", "tom", "tab", "tblk", "bblk",
    "ad", "bd", "ckr", "recb", "tob", "etab", "dw", "hx", "hw", "sens", "act", "nact",
    "dact", "ndact",
)
_I_CROW = REGIME_ARRAYS.index("crow")
_I_AD = REGIME_ARRAYS.index("ad")


def hermite_first_root(g0, d0, c0, g1, d1, c1):
    """First zero in ``(0, 1]`` of the quintic with value, slope and curvature ``g0, d0,
    c0`` at 0 and ``g1, d1, c1`` at 1 (``g0 >= 0 > g1``): the first sign change on a
    scan of :data:`_N_SCAN` points (four at a time: independent evaluations), then
    Halley's method safeguarded by the bracket, to ``1e-10`` (Newton on the exact
    solution follows). With ``g0 = 0`` (an event at the start) the quintic is divided by
    ``theta``: the zero at the start itself does not count."""
    a3 = 10.0 * (g1 - g0) - 6.0 * d0 - 4.0 * d1 - 1.5 * c0 + 0.5 * c1
    a4 = 15.0 * (g0 - g1) + 8.0 * d0 + 7.0 * d1 + 1.5 * c0 - c1
    a5 = 6.0 * (g1 - g0) - 3.0 * (d0 + d1) - 0.5 * (c0 - c1)
    a2 = 0.5 * c0
    # coefficients b0 + b1 th + ... + b5 th^5 of the quintic, or of quintic / th
    if g0 == 0.0:
        b0, b1, b2, b3, b4, b5 = d0, a2, a3, a4, a5, 0.0
    else:
        b0, b1, b2, b3, b4, b5 = g0, d0, a2, a3, a4, a5
    lo = 0.0
    hi = 1.0
    vlo = b0
    vhi = g1
    step = 1.0 / _N_SCAN
    for k0 in range(0, _N_SCAN, 4):
        t0 = (k0 + 1) * step
        t1 = (k0 + 2) * step
        t2 = (k0 + 3) * step
        t3 = (k0 + 4) * step
        u0 = b0 + t0 * (b1 + t0 * (b2 + t0 * (b3 + t0 * (b4 + t0 * b5))))
        u1 = b0 + t1 * (b1 + t1 * (b2 + t1 * (b3 + t1 * (b4 + t1 * b5))))
        u2 = b0 + t2 * (b1 + t2 * (b2 + t2 * (b3 + t2 * (b4 + t2 * b5))))
        u3 = b0 + t3 * (b1 + t3 * (b2 + t3 * (b3 + t3 * (b4 + t3 * b5))))
        if u0 <= 0.0:
            hi = t0
            vhi = u0
            break
        if u1 <= 0.0:
            lo = t0
            vlo = u0
            hi = t1
            vhi = u1
            break
        if u2 <= 0.0:
            lo = t1
            vlo = u1
            hi = t2
            vhi = u2
            break
        if u3 <= 0.0:
            lo = t2
            vlo = u2
            hi = t3
            vhi = u3
            break
        lo = t3
        vlo = u3
    th = lo + (hi - lo) * (vlo / (vlo - vhi)) if vlo > 0.0 > vhi else 0.5 * (lo + hi)
    for _ in range(40):
        v = b0 + th * (b1 + th * (b2 + th * (b3 + th * (b4 + th * b5))))
        dv = b1 + th * (2.0 * b2 + th * (3.0 * b3 + th * (4.0 * b4 + th * 5.0 * b5)))
        ddv = 2.0 * b2 + th * (6.0 * b3 + th * (12.0 * b4 + th * 20.0 * b5))
        if v == 0.0:
            return th
        if v > 0.0:
            lo = th
        else:
            hi = th
        den = 2.0 * dv * dv - v * ddv
        nxt = th - 2.0 * v * dv / den if den != 0.0 else 0.5 * (lo + hi)
        if not lo < nxt < hi:
            nxt = 0.5 * (lo + hi)
        if abs(nxt - th) <= 1e-10:
            return nxt
        th = nxt
    return th


def dip_suspect(g0, d0, c0, g1, d1, c1, x):
    """Whether a gate positive at both ends of an interval (values, derivatives and
    curvatures in units of the interval) may dip below zero inside: the quintic through
    them comes within a wide margin of zero inside (its error is some ``x^6 / 46080`` of
    the modal amplitudes, ``x = |s|max`` times the interval; the margin is
    ``_DIP_MARGIN x^3`` of the derivative terms). The quintic is sampled at eight
    points; the margin covers what lies between them."""
    size = abs(d0) + abs(d1) + abs(c0) + abs(c1)
    if not min(g0, g1) < size or (d0 >= 0.0 and d1 <= 0.0):
        return False  # (rising then falling: a dip would need more turns than a step has)
    a3 = 10.0 * (g1 - g0) - 6.0 * d0 - 4.0 * d1 - 1.5 * c0 + 0.5 * c1
    a4 = 15.0 * (g0 - g1) + 8.0 * d0 + 7.0 * d1 + 1.5 * c0 - c1
    a5 = 6.0 * (g1 - g0) - 3.0 * (d0 + d1) - 0.5 * (c0 - c1)
    a2 = 0.5 * c0
    least = min(g0, g1)
    for k in range(1, 8):
        th = k * 0.125
        least = min(least, g0 + th * (d0 + th * (a2 + th * (a3 + th * (a4 + th * a5)))))
    # between samples (1/8 apart) the quintic lies at most its curvature / 512 below
    # them; the curvature from both ends and the change of slope (the mean curvature)
    return least - (abs(c0) + abs(c1) + 2.0 * abs(d1 - d0)) * (1.0 / 512.0) \
        < _DIP_MARGIN * x * x * x * size


def quintic_argmin(g0, d0, c0, g1, d1, c1):
    """Where in ``[0, 1]`` the quintic with value, slope and curvature ``g0, d0, c0`` at
    0 and ``g1, d1, c1`` at 1 is least (on a scan of :data:`_N_SCAN` points)."""
    a3 = 10.0 * (g1 - g0) - 6.0 * d0 - 4.0 * d1 - 1.5 * c0 + 0.5 * c1
    a4 = 15.0 * (g0 - g1) + 8.0 * d0 + 7.0 * d1 + 1.5 * c0 - c1
    a5 = 6.0 * (g1 - g0) - 3.0 * (d0 + d1) - 0.5 * (c0 - c1)
    a2 = 0.5 * c0
    best = g0
    th_best = 0.0
    for k in range(1, _N_SCAN + 1):
        th = k * (1.0 / _N_SCAN)
        val = g0 + th * (d0 + th * (a2 + th * (a3 + th * (a4 + th * a5))))
        if val < best:
            best = val
            th_best = th
    return th_best


# ----------------------------------------------------------------------------------
# exact intra-step propagation
# ----------------------------------------------------------------------------------


def grid_point(h, dt, n_grid):
    """Nearest grid point ``h_k = k dt / n_grid`` to ``h``: ``(k, h_k, h - h_k)``."""
    k = int(h * n_grid / dt + 0.5)
    if k > n_grid:
        k = n_grid
    if k < 0:
        k = 0
    hk = k * (dt / n_grid)
    return k, hk, h - hk


def tabulated_state(t, s2, i, zr, zi, qr, qi, er, ei, hk, dl):
    """State of the tabulated mode ``i`` (pole ``s2[:, i]``, re/im) at ``h_k + dl``
    from ``z`` at the step start, modal input ``qa + qd t`` (``qr + j qi``, ``er + j ei``): from
    the grid point (``t = tab[k]``) ``z0``, then the Taylor series over ``dl``,
    ``z0 + dl z0' + dl^2 phi2(s dl) z0''`` (``phi2`` to the fixed degree
    :data:`TAYLOR_DEGREE`, Horner in real arithmetic). Returns ``(Re, Im)``."""
    sr = s2[0, i]
    si = s2[1, i]
    ar = sr * dl
    ai = si * dl
    pr = _INV_FACT[TAYLOR_DEGREE + 2]
    pi = 0.0
    for k2 in range(TAYLOR_DEGREE - 1, -1, -1):
        tmp = pr * ar - pi * ai + _INV_FACT[k2 + 2]
        pi = pr * ai + pi * ar
        pr = tmp
    z0r = (t[0, i] * zr - t[1, i] * zi + t[2, i] * qr - t[3, i] * qi
           + t[4, i] * er - t[5, i] * ei)
    z0i = (t[0, i] * zi + t[1, i] * zr + t[2, i] * qi + t[3, i] * qr
           + t[4, i] * ei + t[5, i] * er)
    z1r = sr * z0r - si * z0i + qr + er * hk
    z1i = sr * z0i + si * z0r + qi + ei * hk
    z2r = sr * z1r - si * z1i + er
    z2i = sr * z1i + si * z1r + ei
    d2 = dl * dl
    return (z0r + dl * z1r + d2 * (pr * z2r - pi * z2i),
            z0i + dl * z1i + d2 * (pr * z2i + pi * z2r))


def block_at(nk, btab, k, hk, dl, h, tblk, etab, xa, ga, gd, ox, sk, sx):
    """Block state after time ``h = h_k + dl`` from ``xa``, input ``ga + gd t``: from
    the tables at ``h_k`` (``etab[k]``: ``exp(T h_k)`` and the two input integrals) and
    the Taylor series over ``dl`` when ``btab``, else by the exponential of the augmented
    matrix. ``sk`` rows 8..12 and ``sx`` are scratch."""
    if btab:
        x0 = sk[8]
        x1 = sk[9]
        x2 = sk[10]
        v = sk[11]
        tv = sk[12]
        for q in range(nk):
            acc = 0.0
            for c in range(nk):
                acc += (etab[k, 0, q, c] * xa[c] + etab[k, 1, q, c] * ga[c]
                        + etab[k, 2, q, c] * gd[c])
            x0[q] = acc
        for q in range(nk):
            acc = ga[q] + gd[q] * hk
            for c in range(nk):
                acc += tblk[q, c] * x0[c]
            x1[q] = acc
        for q in range(nk):
            acc = gd[q]
            for c in range(nk):
                acc += tblk[q, c] * x1[c]
            x2[q] = acc
        # v = sum_k (dl T)^k / (k + 2)! x2
        for q in range(nk):
            v[q] = _INV_FACT[TAYLOR_DEGREE + 2] * x2[q]
        for k2 in range(TAYLOR_DEGREE - 1, -1, -1):
            for q in range(nk):
                acc = 0.0
                for c2 in range(nk):
                    acc += tblk[q, c2] * v[c2]
                tv[q] = acc
            for q in range(nk):
                v[q] = _INV_FACT[k2 + 2] * x2[q] + dl * tv[q]
        for q in range(nk):
            ox[q] = x0[q] + dl * x1[q] + dl * dl * v[q]
        return
    aug = sx[0, : nk + 2, : nk + 2]
    e = sx[1, : nk + 2, : nk + 2]
    for q in range(nk + 2):
        for c in range(nk + 2):
            aug[q, c] = 0.0
    for q in range(nk):
        for c in range(nk):
            aug[q, c] = h * tblk[q, c]
        aug[q, nk] = h * ga[q]
        aug[q, nk + 1] = h * h * gd[q]
    aug[nk + 1, nk] = 1.0
    expm_small(aug, e, sx[2, : nk + 2, : nk + 2])
    for q in range(nk):
        acc = e[q, nk]
        for c in range(nk):
            acc += e[q, c] * xa[c]
        ox[q] = acc


def propagate(nm, nt, nk, btab, h, dt, n_grid, s2, tab, tblk, etab, zar, zai, xa, q, ga,
              gd, ozr, ozi, ox, sk, sx):
    """Exact state after time ``h`` (``0 <= h <= dt``) from ``(za, xa)``; modal input
    ``qa + qd t`` (``q`` rows: ``Re qa, Im qa, Re qd, Im qd``), block input ``ga + gd t``.
    Writes ``(ozr, ozi)`` and ``ox`` (which may be the input arrays).

    Tabulated modes ``i < nt``: from the grid point ``h_k`` nearest to ``h`` (``tab[k]``
    rows: ``E = exp(s h_k)``, ``F1 = int_0^h_k exp(s (h_k - t)) dt``, ``F2 = int_0^h_k
    exp(s (h_k - t)) t dt``, re/im) the state is carried over the remaining ``dl`` by its
    Taylor series ``z + dl z' + dl^2 phi2(s dl) z''`` (``phi2`` to the fixed degree
    :data:`TAYLOR_DEGREE`). Modes ``i >= nt`` (too stiff for the grid) use exponentials.
    ``sk`` rows 8..12 and ``sx`` are scratch.
    """
    k, hk, dl = grid_point(h, dt, n_grid)
    t = tab[k]
    for i in range(nt):
        ozr[i], ozi[i] = tabulated_state(t, s2, i, zar[i], zai[i], q[0, i], q[1, i],
                                         q[2, i], q[3, i], hk, dl)
    for i in range(nt, nm):
        a = complex(s2[0, i] * h, s2[1, i] * h)
        p1, p2 = phi12(a)
        z = (np.exp(a) * complex(zar[i], zai[i])
             + h * (p1 * complex(q[0, i], q[1, i]) + (p2 * h) * complex(q[2, i], q[3, i])))
        ozr[i] = z.real
        ozi[i] = z.imag
    if nk > 0:
        block_at(nk, btab, k, hk, dl, h, tblk, etab, xa, ga, gd, ox, sk, sx)


def add_jump(nm, nt, nk, btab, h, dt, n_grid, s2, tab, tblk, etab, bm, bblk, p, jump, crow,
             ckr, dw, act, nact, zr, zi, xi, w, hot, sk, sx):
    """Add to the step-end state ``(z, xi)`` the response after time ``h`` to a step
    ``jump`` of the input ``p`` (``h phi1(s h) Bm[:, p] jump``; tables as
    :func:`propagate`), and update the active rows ``hot`` (input ``w`` at the end, with
    the jump): the first five by their increments in the same pass, the others anew."""
    k, hk, dl = grid_point(h, dt, n_grid)
    t = tab[k]
    o0 = act[0]
    o1 = act[1]
    o2 = act[2]
    o3 = act[3]
    o4 = act[4]
    s0 = 0.0
    s1 = 0.0
    s2_ = 0.0
    s3 = 0.0
    s4 = 0.0
    for i in range(nt):
        dzr, dzi = tabulated_state(t, s2, i, 0.0, 0.0, bm[0, p, i] * jump,
                                   bm[1, p, i] * jump, 0.0, 0.0, hk, dl)
        zr[i] += dzr
        zi[i] += dzi
        s0 += crow[0, o0, i] * dzr - crow[1, o0, i] * dzi
        s1 += crow[0, o1, i] * dzr - crow[1, o1, i] * dzi
        s2_ += crow[0, o2, i] * dzr - crow[1, o2, i] * dzi
        s3 += crow[0, o3, i] * dzr - crow[1, o3, i] * dzi
        s4 += crow[0, o4, i] * dzr - crow[1, o4, i] * dzi
    for i in range(nt, nm):
        a = complex(s2[0, i] * h, s2[1, i] * h)
        z = (h * jump) * (phi1(a) * complex(bm[0, p, i], bm[1, p, i]))
        zr[i] += z.real
        zi[i] += z.imag
        s0 += crow[0, o0, i] * z.real - crow[1, o0, i] * z.imag
        s1 += crow[0, o1, i] * z.real - crow[1, o1, i] * z.imag
        s2_ += crow[0, o2, i] * z.real - crow[1, o2, i] * z.imag
        s3 += crow[0, o3, i] * z.real - crow[1, o3, i] * z.imag
        s4 += crow[0, o4, i] * z.real - crow[1, o4, i] * z.imag
    if nk > 0:
        gs = sk[5]
        zero_k = sk[6]
        ox = sk[7]
        for c in range(nk):
            gs[c] = bblk[c, p] * jump
            zero_k[c] = 0.0
        block_at(nk, btab, k, hk, dl, h, tblk, etab, zero_k, gs, zero_k, ox, sk, sx)
        for c in range(nk):
            xi[c] += ox[c]
            s0 += ckr[0, o0, c] * ox[c]
            s1 += ckr[0, o1, c] * ox[c]
            s2_ += ckr[0, o2, c] * ox[c]
            s3 += ckr[0, o3, c] * ox[c]
            s4 += ckr[0, o4, c] * ox[c]
    # the direct term of the jump (rows that see the force itself, e.g. accelerations)
    # (padding repeats the zero row, whose increments are zero)
    hot[o0] += s0 + dw[0, o0, p] * jump
    hot[o1] += s1 + dw[0, o1, p] * jump
    hot[o2] += s2_ + dw[0, o2, p] * jump
    hot[o3] += s3 + dw[0, o3, p] * jump
    hot[o4] += s4 + dw[0, o4, p] * jump
    for q in range(5, nact):
        o = act[q]
        hot[o] = row_value(nm, nk, crow, ckr, dw, o, zr, zi, xi, w)


def rows_at(nm, nt, nk, btab, h, dt, n_grid, s2, tab, tblk, etab, zar, zai, xa, q, ga, gd,
            crow, ckr, dw, row, row2, wt, wd, sk, sx):
    """Rows ``row`` and ``row2`` and their first two time derivatives at the time ``h``
    after ``(za, xa)`` (inputs as :func:`propagate`, ``wt`` the input ``w`` at that
    time), without storing the state: one pass over the modes that only accumulates
    (it vectorises). Returns ``(v0, v1, v2, scale, t0, t1, t2)``, ``scale`` the sum of
    magnitudes of the terms of ``row``."""
    k, hk, dl = grid_point(h, dt, n_grid)
    t = tab[k]
    v0 = 0.0
    v1 = 0.0
    v2 = 0.0
    scale = 0.0
    t0 = 0.0
    t1 = 0.0
    t2 = 0.0
    for i in range(nt):
        zr, zi = tabulated_state(t, s2, i, zar[i], zai[i], q[0, i], q[1, i], q[2, i],
                                 q[3, i], hk, dl)
        c0 = crow[0, row, i] * zr - crow[1, row, i] * zi
        v0 += c0
        scale += abs(c0)
        v1 += crow[2, row, i] * zr - crow[3, row, i] * zi
        v2 += crow[4, row, i] * zr - crow[5, row, i] * zi
        t0 += crow[0, row2, i] * zr - crow[1, row2, i] * zi
        t1 += crow[2, row2, i] * zr - crow[3, row2, i] * zi
        t2 += crow[4, row2, i] * zr - crow[5, row2, i] * zi
    for i in range(nt, nm):
        a = complex(s2[0, i] * h, s2[1, i] * h)
        p1, p2 = phi12(a)
        z = (np.exp(a) * complex(zar[i], zai[i])
             + h * (p1 * complex(q[0, i], q[1, i]) + (p2 * h) * complex(q[2, i], q[3, i])))
        c0 = crow[0, row, i] * z.real - crow[1, row, i] * z.imag
        v0 += c0
        scale += abs(c0)
        v1 += crow[2, row, i] * z.real - crow[3, row, i] * z.imag
        v2 += crow[4, row, i] * z.real - crow[5, row, i] * z.imag
        t0 += crow[0, row2, i] * z.real - crow[1, row2, i] * z.imag
        t1 += crow[2, row2, i] * z.real - crow[3, row2, i] * z.imag
        t2 += crow[4, row2, i] * z.real - crow[5, row2, i] * z.imag
    if nk > 0:
        xt = sk[13]
        block_at(nk, btab, k, hk, dl, h, tblk, etab, xa, ga, gd, xt, sk, sx)
        for c in range(nk):
            c0 = ckr[0, row, c] * xt[c]
            v0 += c0
            scale += abs(c0)
            v1 += ckr[1, row, c] * xt[c]
            v2 += ckr[2, row, c] * xt[c]
            t0 += ckr[0, row2, c] * xt[c]
            t1 += ckr[1, row2, c] * xt[c]
            t2 += ckr[2, row2, c] * xt[c]
    for p in range(wt.shape[0]):
        c0 = dw[0, row, p] * wt[p]
        v0 += c0
        scale += abs(c0)
        v1 += dw[1, row, p] * wt[p] + dw[0, row, p] * wd[p]
        v2 += dw[2, row, p] * wt[p] + dw[1, row, p] * wd[p]
        t0 += dw[0, row2, p] * wt[p]
        t1 += dw[1, row2, p] * wt[p] + dw[0, row2, p] * wd[p]
        t2 += dw[2, row2, p] * wt[p] + dw[1, row2, p] * wd[p]
    return v0, v1, v2, scale, t0, t1, t2


# ----------------------------------------------------------------------------------
# rows
# ----------------------------------------------------------------------------------


def row_value(nm, nk, crow, ckr, dw, row, zr, zi, xi, w):
    """One output row ``Re(cm z) + Ck xi + D w`` (modal state as real/imag arrays)."""
    acc = 0.0
    for i in range(nm):
        acc += crow[0, row, i] * zr[i] - crow[1, row, i] * zi[i]
    for c in range(nk):
        acc += ckr[0, row, c] * xi[c]
    for p in range(w.shape[0]):
        acc += dw[0, row, p] * w[p]
    return acc


def row_derivs(nm, nk, crow, ckr, dw, row, zr, zi, xi, w, wd):
    """A row and its first two time derivatives at the state ``(z, xi)`` and input ``w``
    (rate ``wd``), from the precomputed rows ``c s``, ``c s^2`` (modes), ``Ck T``,
    ``Ck T^2`` (block) and their input weights: one pass over the modes.

    Also returns the sum of magnitudes of the row's terms (its rounding scale).
    """
    v0 = 0.0
    v1 = 0.0
    v2 = 0.0
    scale = 0.0
    for i in range(nm):
        t0 = crow[0, row, i] * zr[i] - crow[1, row, i] * zi[i]
        v0 += t0
        scale += abs(t0)
        v1 += crow[2, row, i] * zr[i] - crow[3, row, i] * zi[i]
        v2 += crow[4, row, i] * zr[i] - crow[5, row, i] * zi[i]
    for c in range(nk):
        t0 = ckr[0, row, c] * xi[c]
        v0 += t0
        scale += abs(t0)
        v1 += ckr[1, row, c] * xi[c]
        v2 += ckr[2, row, c] * xi[c]
    for p in range(w.shape[0]):
        t0 = dw[0, row, p] * w[p]
        v0 += t0
        scale += abs(t0)
        v1 += dw[1, row, p] * w[p] + dw[0, row, p] * wd[p]
        v2 += dw[2, row, p] * w[p] + dw[1, row, p] * wd[p]
    return v0, v1, v2, scale


def row_rate(nm, nk, crow, ckr, dw, row, zr, zi, xi, w):
    """First and second time derivatives of a row at ``(z, xi)``, input ``w``, without
    the terms of the input rate ``wd`` (``D wd``, ``D1 wd``)."""
    acc1 = 0.0
    acc2 = 0.0
    for i in range(nm):
        acc1 += crow[2, row, i] * zr[i] - crow[3, row, i] * zi[i]
        acc2 += crow[4, row, i] * zr[i] - crow[5, row, i] * zi[i]
    for c in range(nk):
        acc1 += ckr[1, row, c] * xi[c]
        acc2 += ckr[2, row, c] * xi[c]
    for p in range(w.shape[0]):
        acc1 += dw[1, row, p] * w[p]
        acc2 += dw[2, row, p] * w[p]
    return acc1, acc2


def gate_rows(mask, n_nl, row_v, row_h, kind, fbit, nm, nk, crow, ckr, dw, zr, zi, xi, w,
              zero_w, dt, gst):
    """Value and first two time derivatives (without the input-rate terms) of every
    friction element's gate row (velocity if slipping, holding force if stuck) at a
    state, into ``gst``."""
    for p in range(zero_w.shape[0]):
        zero_w[p] = 0.0
    for e in range(n_nl):
        if kind[e] != KIND_COULOMB:
            continue
        row = row_h + e if (mask >> fbit[e]) & 1 else row_v + e
        v0, v1, v2, _ = row_derivs(nm, nk, crow, ckr, dw, row, zr, zi, xi, w, zero_w)
        gst[0, e] = v0
        gst[1, e] = v1
        gst[2, e] = v2
        gst[3, e] = 1.0
        gst[4, e] = dt * abs(v1) + dt * dt * abs(v2)
        gst[5, e] = 0.0


def rows_active(nm, nk, crow, ckr, dw, act, nact, zr, zi, xi, w, out):
    """The active rows ``act[:nact]`` at a state (five, then four at a time, in one pass
    each over the modes, as the fast path)."""
    o0 = act[0]
    o1 = act[1]
    o2 = act[2]
    o3 = act[3]
    o4 = act[4]
    s0 = 0.0
    s1 = 0.0
    s2 = 0.0
    s3 = 0.0
    s4 = 0.0
    for i in range(nm):
        na = zr[i]
        nb = zi[i]
        s0 += crow[0, o0, i] * na - crow[1, o0, i] * nb
        s1 += crow[0, o1, i] * na - crow[1, o1, i] * nb
        s2 += crow[0, o2, i] * na - crow[1, o2, i] * nb
        s3 += crow[0, o3, i] * na - crow[1, o3, i] * nb
        s4 += crow[0, o4, i] * na - crow[1, o4, i] * nb
    out[o0] = s0
    out[o1] = s1
    out[o2] = s2
    out[o3] = s3
    out[o4] = s4
    for q in range(5, nact, 4):
        oa = act[q]
        ob = act[q + 1]
        oc = act[q + 2]
        od = act[q + 3]
        s0 = 0.0
        s1 = 0.0
        s2 = 0.0
        s3 = 0.0
        for i in range(nm):
            na = zr[i]
            nb = zi[i]
            s0 += crow[0, oa, i] * na - crow[1, oa, i] * nb
            s1 += crow[0, ob, i] * na - crow[1, ob, i] * nb
            s2 += crow[0, oc, i] * na - crow[1, oc, i] * nb
            s3 += crow[0, od, i] * na - crow[1, od, i] * nb
        out[oa] = s0
        out[ob] = s1
        out[oc] = s2
        out[od] = s3
    for q in range(nact):
        o = act[q]
        acc = out[o]
        for c in range(nk):
            acc += ckr[0, o, c] * xi[c]
        for p in range(w.shape[0]):
            acc += dw[0, o, p] * w[p]
        out[o] = acc


def rows_all(nm, nk, crow, ckr, dw, zr, zi, xi, w, out):
    """Every row at a state (the initial one)."""
    for o in range(out.shape[0]):
        out[o] = row_value(nm, nk, crow, ckr, dw, o, zr, zi, xi, w)


def reconstruct(nm, nk, rec, recb, zr, zi, xi, x):
    """Full state ``x = Re(rec z) + recb xi``."""
    for q in range(x.shape[0]):
        acc = 0.0
        for i in range(nm):
            acc += rec[0, q, i] * zr[i] - rec[1, q, i] * zi[i]
        for c in range(nk):
            acc += recb[q, c] * xi[c]
        x[q] = acc


def to_regime(nm, nk, tom, tob, x, zr, zi, xi):
    """Regime coordinates of the full state ``x``."""
    n = x.shape[0]
    for i in range(nm):
        zr[i] = 0.0
        zi[i] = 0.0
    for q in range(n):
        xq = x[q]
        for i in range(nm):
            zr[i] += tom[0, q, i] * xq
            zi[i] += tom[1, q, i] * xq
    for c in range(nk):
        acc = 0.0
        for q in range(n):
            acc += tob[c, q] * x[q]
        xi[c] = acc


def modal_input(nm, nk, bm, bblk, w, wd, q, ga, gd):
    """Modal inputs ``qa = Bm w``, ``qd = Bm wd`` (rows of ``q``: re/im of each) and
    block inputs ``ga``, ``gd``."""
    for i in range(nm):
        q[0, i] = 0.0
        q[1, i] = 0.0
        q[2, i] = 0.0
        q[3, i] = 0.0
    for p in range(w.shape[0]):
        a = w[p]
        b = wd[p]
        if a == 0.0 and b == 0.0:
            continue
        for i in range(nm):
            q[0, i] += bm[0, p, i] * a
            q[1, i] += bm[1, p, i] * a
            q[2, i] += bm[0, p, i] * b
            q[3, i] += bm[1, p, i] * b
    for c in range(nk):
        acc_a = 0.0
        acc_d = 0.0
        for p in range(w.shape[0]):
            acc_a += bblk[c, p] * w[p]
            acc_d += bblk[c, p] * wd[p]
        ga[c] = acc_a
        gd[c] = acc_d


def fric_forcing(nm, n_in, kind, par, fbit, mask, dirs, g, cfr, cfi, wa_s, wb_s):
    """Modal forcing of one full step by the slipping friction forces (constant), and
    the friction entries of the step-end inputs ``wa_s``, ``wb_s``."""
    for i in range(nm):
        cfr[i] = 0.0
        cfi[i] = 0.0
    for e in range(kind.shape[0]):
        if kind[e] != KIND_COULOMB:
            continue
        p = n_in + e
        if (mask >> fbit[e]) & 1:
            wa_s[p] = 0.0
            wb_s[p] = 0.0
            continue
        f = -par[e, 0] * dirs[e]
        wa_s[p] = f
        wb_s[p] = f
        for i in range(nm):
            cfr[i] += (g[0, p, i] + g[2, p, i]) * f
            cfi[i] += (g[1, p, i] + g[3, p, i]) * f


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


def gate(stuck, sgn, fc, v0, v1, v2):
    """Event gate and its derivatives from a row: ``sgn v`` (slip) or ``F_c - |h|``."""
    if stuck:
        sg = 1.0 if v0 >= 0.0 else -1.0
        return fc - abs(v0), -sg * v1, -sg * v2
    return sgn * v0, sgn * v1, sgn * v2


def lean_gate(lean, mask, fbit, dirs, row_v, row_h):
    """Gate of the single friction element of the lean path: ``(row, stuck, dir)``."""
    if not lean:
        return 0, False, 0.0
    if (mask >> fbit[0]) & 1:
        return row_h, True, 0.0
    return row_v, False, dirs[0]


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
            vel[e, jr] = 0.0
            fo[e, jr] = hot[row_h + e]
            stuck[e, jr] = True
        else:
            vel[e, jr] = hot[row_v + e]
            fo[e, jr] = -par[e, 0] * dirs[e]



# ----------------------------------------------------------------------------------
# the event path
# ----------------------------------------------------------------------------------


def event_step(j, dt, n_grid, mask, cand, n_in, n_out, max_events, reg, kind, par, fbit, fe,
               st, scr):
    """Redo step ``j`` exactly, event by event (see the module docstring).

    ``st = (zr0, zi0, xi0, zr, zi, xi)``: on entry the state at the step start and the
    fast path's state at the step end, both in the regime ``mask``, and ``hot`` the
    active rows at the step end; on return ``(zr, zi, xi)`` and ``hot`` hold the step end
    in the final regime (the step-start arrays are overwritten).
    ``fe = (dirs, last_dir, fresh, n_rev, n_stick)`` (updated),
    ``scr = (wa_s, wb_s, wz, hot, x, sm, sk, sx)``. Returns ``(mask, fail)``,
    ``fail = j`` if more than ``max_events`` events occurred, else -1.

    ``cand`` (bits as the regime mask) flags friction elements whose gate, positive at
    both ends, may dip below zero inside the step (two sign changes of a velocity in one
    step): the exact minimum of such a gate is found (Newton on its derivative) and, if
    negative, the first zero before it is an event.

    The interval start ``ta`` (state ``za``, inputs ``qa + qd t``) and the step-end state
    ``ze`` are kept. A gate that is negative at the end is located by :func:`rows_at`
    (the state at a trial time is not stored). A reversal adds the response to the force
    jump to ``ze`` and leaves the regime as it is; the state at the reversal is only
    computed (``pending``) if a further event in the same step needs it as its interval
    start. A stick or a release goes through the full state into the new regime.
    """
    (dims_a, smax_a, s2_a, lam_a, g_a, bm_a, crow_a, rec_a, tom_a, tab_a, tblk_a, bblk_a,
     ad_a, bd_a, ckr_a, recb_a, tob_a, etab_a, dw_a, hx, hw, sens_a, act_a, nact_a, dact_a,
     ndact_a) = reg
    dirs, last_dir, fresh, n_rev, n_stick = fe
    zar, zai, xa, zer, zei, xe = st
    wa_s, wb_s, wz, hot, x, sm, sk, sx = scr
    n_nl = kind.shape[0]
    n_w = wa_s.shape[0]
    row_v = n_out + n_nl
    row_h = n_out + 2 * n_nl
    row_t = n_out + 3 * n_nl
    zsr = sm[0]
    zsi = sm[1]
    q = sm[2:6]
    xs = sk[2]
    ga = sk[3]
    gd = sk[4]
    w = wz[0]
    w2 = wz[1]
    wd = wz[2]
    wt = wz[3]
    r = mask
    fail = -1
    ta = 0.0
    span = dt
    for e in range(n_nl):
        fresh[e] = 0
    n_ev = 0
    new_inputs = True
    pending = -1.0  # time of a reversal the interval start has not been moved to yet
    while True:
        nm = dims_a[r, 0]
        nt = dims_a[r, 1]
        nk = dims_a[r, 2]
        btab = dims_a[r, 3]
        s2 = s2_a[r]
        tab = tab_a[r]
        tblk = tblk_a[r]
        etab = etab_a[r]
        crow = crow_a[r]
        ckr = ckr_a[r]
        dw = dw_a[r]
        smax = smax_a[r]
        if dt - ta <= 0.0:
            break
        if new_inputs:
            # inputs at the interval ends and their rates
            span = dt - ta
            fill_input(ta / dt, wa_s, wb_s, n_in, kind, par, dirs, mask, fbit, w)
            fill_input(1.0, wa_s, wb_s, n_in, kind, par, dirs, mask, fbit, w2)
            for p in range(n_w):
                wd[p] = (w2[p] - w[p]) / span
            modal_input(nm, nk, bm_a[r], bblk_a[r], w, wd, q, ga, gd)
            new_inputs = False
        # the first event among the gates that are clearly negative at the end
        t_ev = 2.0 * dt
        e_ev = -1
        trial_ev = 0.0
        for e in range(n_nl):
            if kind[e] != KIND_COULOMB:
                continue
            is_stuck = (mask >> fbit[e]) & 1
            row = row_h + e if is_stuck else row_v + e
            sgn = 1.0 if is_stuck else dirs[e]
            fc = par[e, 0]
            # the gate at the end from the active rows (kept up to date), then in full. A
            # dip inside: in the first interval if the fast path flagged it, in a later
            # one that starts at a stick or release (not at a reversal) if the quintic
            # says so
            dip = (cand >> fbit[e]) & 1 == 1 if n_ev == 0 else pending < 0.0
            if (fc - abs(hot[row]) if is_stuck else sgn * hot[row]) >= 0.0 and not dip:
                continue
            v0, v1, v2, sc = row_derivs(nm, nk, crow, ckr, dw, row, zer, zei, xe, w2, wd)
            g_e, d_e, c_e = gate(is_stuck, sgn, fc, v0, v1, v2)
            tol = _EVENT_RTOL * (max(sc, fc) if is_stuck else sc)
            if g_e < -tol:
                dip = False
            elif not dip:
                continue
            if pending >= 0.0:
                # move the interval start to the last reversal (the inputs before it)
                propagate(nm, nt, nk, btab, pending - ta, dt, n_grid, s2, tab, tblk, etab,
                          zar, zai, xa, q, ga, gd, zsr, zsi, xs, sk, sx)
                for i in range(nm):
                    zar[i] = zsr[i]
                    zai[i] = zsi[i]
                for c in range(nk):
                    xa[c] = xs[c]
                ta = pending
                pending = -1.0
                span = dt - ta
                fill_input(ta / dt, wa_s, wb_s, n_in, kind, par, dirs, mask, fbit, w)
                for p in range(n_w):
                    wd[p] = (w2[p] - w[p]) / span
                modal_input(nm, nk, bm_a[r], bblk_a[r], w, wd, q, ga, gd)
            row2 = row_t + e if not is_stuck else row
            v0, v1, v2, sc = row_derivs(nm, nk, crow, ckr, dw, row, zar, zai, xa, w, wd)
            g_a, d_a, c_a = gate(is_stuck, sgn, fc, v0, v1, v2)
            if dip and not g_a > tol:
                continue
            if dip and n_ev > 0 and not dip_suspect(
                    g_a, d_a * span, c_a * span * span, g_e, d_e * span, c_e * span * span,
                    smax * span):
                continue
            if g_a <= 0.0 and fresh[e] == 0:
                t_root = ta  # already past the event at the interval start
                trial = row_value(nm, nk, crow, ckr, dw, row2, zar, zai, xa, w)
            else:
                lo = ta
                hi = dt
                if dip:
                    # the least value of the gate inside: from the quintic's, Newton on
                    # the exact gate's derivative; a negative value brackets the first zero
                    th = quintic_argmin(g_a, d_a * span, c_a * span * span, g_e,
                                        d_e * span, c_e * span * span)
                    t_m = ta + th * span
                    g_neg = 1.0
                    for _ in range(_MAX_NEWTON_EVENT):
                        h = t_m - ta
                        for p in range(n_w):
                            wt[p] = w[p] + wd[p] * h
                        v0, v1, v2, sc, tr0, tr1, tr2 = rows_at(
                            nm, nt, nk, btab, h, dt, n_grid, s2, tab, tblk, etab, zar, zai,
                            xa, q, ga, gd, crow, ckr, dw, row, row2, wt, wd, sk, sx)
                        g_t, d_t, c_t = gate(is_stuck, sgn, fc, v0, v1, v2)
                        if g_t < -tol:
                            g_neg = g_t
                            hi = t_m
                            break
                        if not c_t > 0.0:
                            break
                        step = -d_t / c_t
                        if g_t + 0.5 * step * d_t >= -tol and abs(step) * smax <= 1e-4:
                            break  # the minimum, within reach: not below zero
                        t_new = min(max(t_m + step, ta + 0.5 * (t_m - ta)),
                                    t_m + 0.5 * (dt - t_m))
                        if abs(t_new - t_m) <= _EVENT_TTOL * dt:
                            break
                        t_m = t_new
                    if not g_neg < 0.0:
                        continue
                    # regula falsi start between the interval start and the negative point
                    t_next = ta + (hi - ta) * (g_a / (g_a - g_neg))
                else:
                    # quintic Hermite estimate, then Newton (second order) on the exact
                    # intra-step solution; the last tiny step by the Taylor series of the
                    # rows
                    g_a = max(g_a, 0.0)
                    th = hermite_first_root(g_a, d_a * span, c_a * span * span, g_e,
                                            d_e * span, c_e * span * span)
                    t_next = ta + th * span
                t_root = t_next
                trial = 0.0
                for _ in range(_MAX_NEWTON_EVENT):
                    t_root = t_next
                    h = t_root - ta
                    for p in range(n_w):
                        wt[p] = w[p] + wd[p] * h
                    v0, v1, v2, sc, tr0, tr1, tr2 = rows_at(
                        nm, nt, nk, btab, h, dt, n_grid, s2, tab, tblk, etab, zar, zai, xa,
                        q, ga, gd, crow, ckr, dw, row, row2, wt, wd, sk, sx)
                    trial = tr0
                    g_t, d_t, c_t = gate(is_stuck, sgn, fc, v0, v1, v2)
                    if g_t > 0.0:
                        lo = t_root
                    else:
                        hi = t_root
                    if g_t == 0.0:
                        break
                    newton = d_t != 0.0
                    step = 0.0
                    if newton:
                        disc = d_t * d_t - 2.0 * g_t * c_t
                        if disc >= 0.0:
                            den = d_t + math.copysign(math.sqrt(disc), d_t)
                            step = -2.0 * g_t / den
                        else:
                            step = -g_t / d_t
                        if abs(step) <= _EVENT_TTOL * dt:
                            break
                        t_next = t_root + step
                    if not newton or not lo < t_next < hi:
                        newton = False
                        t_next = 0.5 * (lo + hi)
                    step = t_next - t_root
                    if abs(step) <= _EVENT_TTOL * dt:
                        break
                    if newton and abs(step) * smax <= 1e-4:
                        # the root: a last Newton step, exact to rounding this close
                        trial = tr0 + step * (tr1 + 0.5 * step * tr2)
                        t_root = t_next
                        break
            if t_root < t_ev:
                t_ev = t_root
                e_ev = e
                trial_ev = trial
        if e_ev < 0:
            break
        n_ev += 1
        if n_ev > max_events:
            fail = j
            break
        for e in range(n_nl):
            fresh[e] = 0
        e = e_ev
        if not (mask >> fbit[e]) & 1 and abs(trial_ev) > par[e, 0]:
            # reversal: same regime; superpose the force jump on the end state
            new_dir = -1.0 if trial_ev > 0.0 else 1.0
            jump = -par[e, 0] * (new_dir - dirs[e])
            dirs[e] = new_dir
            if last_dir[e] != 0.0 and last_dir[e] != new_dir:
                n_rev[e] += 1
            last_dir[e] = new_dir
            fresh[e] = 1
            fill_input(1.0, wa_s, wb_s, n_in, kind, par, dirs, mask, fbit, w2)
            if jump != 0.0:
                if dt - t_ev > 0.0:
                    add_jump(nm, nt, nk, btab, dt - t_ev, dt, n_grid, s2, tab, tblk, etab,
                             bm_a[r], bblk_a[r], n_in + e, jump, crow, ckr, dw, act_a[r],
                             nact_a[r], zer, zei, xe, w2, hot, sk, sx)
                else:
                    for q2 in range(nact_a[r]):
                        o = act_a[r, q2]
                        hot[o] += dw[0, o, n_in + e] * jump
            if dt - t_ev <= 0.0:
                break
            # the interval start stays where it is until a further event needs it
            pending = t_ev
            continue
        # stick or release: the state at the event, through the full state into the new
        # regime (the interval start moves to the event)
        if pending >= 0.0 or t_ev > ta:
            propagate(nm, nt, nk, btab, t_ev - ta, dt, n_grid, s2, tab, tblk, etab, zar,
                      zai, xa, q, ga, gd, zsr, zsi, xs, sk, sx)
            for i in range(nm):
                zar[i] = zsr[i]
                zai[i] = zsi[i]
            for c in range(nk):
                xa[c] = xs[c]
        ta = t_ev
        pending = -1.0
        span = dt - ta
        if not (mask >> fbit[e]) & 1:
            trial_mask = mask | (1 << fbit[e])
            forced = e - e - 1
        else:
            trial_mask = mask
            forced = e
        reconstruct(nm, nk, rec_a[r], recb_a[r], zar, zai, xa, x)
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
            nm = dims_a[r, 0]
            nk = dims_a[r, 2]
            to_regime(nm, nk, tom_a[r], tob_a[r], x, zar, zai, xa)
        # the end state in the (new) regime
        fill_input(ta / dt, wa_s, wb_s, n_in, kind, par, dirs, mask, fbit, w)
        fill_input(1.0, wa_s, wb_s, n_in, kind, par, dirs, mask, fbit, w2)
        for p in range(n_w):
            wd[p] = (w2[p] - w[p]) / span if span > 0.0 else 0.0
        modal_input(nm, nk, bm_a[r], bblk_a[r], w, wd, q, ga, gd)
        new_inputs = False
        propagate(nm, dims_a[r, 1], nk, dims_a[r, 3], span, dt, n_grid, s2_a[r], tab_a[r],
                  tblk_a[r], etab_a[r], zar, zai, xa, q, ga, gd, zer, zei, xe, sk, sx)
        rows_active(nm, nk, crow_a[r], ckr_a[r], dw_a[r], act_a[r], nact_a[r], zer, zei,
                    xe, w2, hot)
    return mask, fail


# ----------------------------------------------------------------------------------
# the loop
# ----------------------------------------------------------------------------------


def loop(u, dt, x0, n_out, n_grid, reg, kind, par, fbit, cd, cv, max_newton, max_events,
         out, wk, st):
    """The simulation proper (see :func:`run`, which allocates every array it writes).

    Compiled without reference counting (nothing is allocated in here or in its callees):
    the event path passes many arrays and array views around, and atomic reference
    counts on each would cost more than its arithmetic. Returns ``fail`` (see
    :func:`run`).
    """
    (dims_a, smax_a, s2_a, lam_a, g_a, bm_a, crow_a, rec_a, tom_a, tab_a, tblk_a, bblk_a,
     ad_a, bd_a, ckr_a, recb_a, tob_a, etab_a, dw_a, hx, hw, sens_a, act_a, nact_a, dact_a,
     ndact_a) = reg
    y, fo, disp, vel, stuck, n_stick, n_rev = out
    (dirs, last_dir, fresh, fsm, is_smooth, wa_s, wb_s, wz, hot, x, fr, fi, cfr, cfi, dyn,
     sm, sk, sx, delta, res, jac, jac_scr, solve_scr, gst) = wk
    zr0, zi0, xi0, zr, zi, xi = st
    fe = (dirs, last_dir, fresh, n_rev, n_stick)
    scr = (wa_s, wb_s, wz, hot, x, sm, sk, sx)
    n_in, n_samples = u.shape
    n_nl = kind.shape[0]
    n_w = n_in + n_nl
    row_d = n_out
    row_v = n_out + n_nl
    row_h = n_out + 2 * n_nl
    n = x0.shape[0]
    fail = -1
    n_smooth = 0
    n_fric = 0
    for e in range(n_nl):
        if kind[e] == KIND_COULOMB:
            n_fric += 1
        else:
            n_smooth += 1
    n_dyn = 0
    for p in range(n_w):
        if p < n_in or kind[p - n_in] != KIND_COULOMB:
            dyn[n_dyn] = p
            n_dyn += 1
    # the lean per-step path: a single friction element and no other element
    lean = n_nl == 1 and n_fric == 1
    g_fc = par[0, 0] if lean else 0.0

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
    w = wz[0]
    fill_input(0.0, wa_s, wa_s, n_in, kind, par, dirs, mask, fbit, w)
    mask = settle(mask, zero - 1, x0, w, n_in, kind, par, fbit, hx, hw, dirs, last_dir, n_rev,
                  fresh)
    r = mask
    to_regime(dims_a[r, 0], dims_a[r, 2], tom_a[r], tob_a[r], x0, zr, zi, xi)
    fill_input(0.0, wa_s, wa_s, n_in, kind, par, dirs, mask, fbit, w)
    rows_all(dims_a[r, 0], dims_a[r, 2], crow_a[r], ckr_a[r], dw_a[r], zr, zi, xi, w, hot)
    for p in range(n_w):
        wb_s[p] = w[p]
    record(0, hot, n_out, row_d, row_v, row_h, n_in, par, fbit, mask, dirs, is_smooth, wb_s,
           fsm, y, fo, disp, vel, stuck)
    gate_rows(mask, n_nl, row_v, row_h, kind, fbit, dims_a[r, 0], dims_a[r, 2], crow_a[r],
              ckr_a[r], dw_a[r], zr, zi, xi, wb_s, wz[2], dt, gst)
    j = zero
    while j < n_samples - 1:
        # the regime's arrays, invariant in the inner loop (which leaves when the regime
        # changes): loop-invariant views let LLVM vectorise the loops over modes
        nm = dims_a[r, 0]
        nk = dims_a[r, 2]
        lamr = lam_a[r, 0]
        lami = lam_a[r, 1]
        g = g_a[r]
        g0r = g[0]
        g0i = g[1]
        g1r = g[2]
        g1i = g[3]
        crow = crow_a[r]
        ckr = ckr_a[r]
        dwr = dw_a[r]
        smax_dt = smax_a[r] * dt
        cmr = crow_a[r, 0]
        cmi = crow_a[r, 1]
        ck = ckr_a[r, 0]
        dr = dw_a[r, 0]
        ad = ad_a[r]
        bd0 = bd_a[r, 0]
        bd1 = bd_a[r, 1]
        sens = sens_a[r]
        act = act_a[r]
        nact = nact_a[r]
        dact = dact_a[r]
        ndact = ndact_a[r]
        o0 = act[0]
        o1 = act[1]
        o2 = act[2]
        o3 = act[3]
        o4 = act[4]
        fric_forcing(nm, n_in, kind, par, fbit, mask, dirs, g, cfr, cfi, wa_s, wb_s)
        g_row, g_stk, g_sgn = lean_gate(lean, mask, fbit, dirs, row_v, row_h)
        while j < n_samples - 1:
            for p in range(n_in):
                wa_s[p] = u[p, j]
                wb_s[p] = u[p, j + 1]
            if n_smooth > 0:
                for e in range(n_nl):
                    if is_smooth[e]:
                        wa_s[n_in + e] = fsm[e]
                        wb_s[n_in + e] = fsm[e]  # predictor for the smooth forces
            # forcing: the friction forces are constant between events (cfr, cfi)
            if n_dyn > 0:
                p = dyn[0]
                a0 = wa_s[p]
                a1 = wb_s[p]
                for i in range(nm):
                    fr[i] = cfr[i] + g0r[p, i] * a0 + g1r[p, i] * a1
                    fi[i] = cfi[i] + g0i[p, i] * a0 + g1i[p, i] * a1
                for q2 in range(1, n_dyn):
                    p = dyn[q2]
                    a0 = wa_s[p]
                    a1 = wb_s[p]
                    if a0 == 0.0 and a1 == 0.0:
                        continue
                    for i in range(nm):
                        fr[i] += g0r[p, i] * a0 + g1r[p, i] * a1
                        fi[i] += g0i[p, i] * a0 + g1i[p, i] * a1
            else:
                for i in range(nm):
                    fr[i] = cfr[i]
                    fi[i] = cfi[i]
            # advance the modes in place (the step start kept for the event path), fused
            # with the first five rows
            s0 = 0.0
            s1 = 0.0
            s2 = 0.0
            s3 = 0.0
            s4 = 0.0
            for i in range(nm):
                a = zr[i]
                b = zi[i]
                zr0[i] = a
                zi0[i] = b
                na = lamr[i] * a - lami[i] * b + fr[i]
                nb = lamr[i] * b + lami[i] * a + fi[i]
                zr[i] = na
                zi[i] = nb
                s0 += cmr[o0, i] * na - cmi[o0, i] * nb
                s1 += cmr[o1, i] * na - cmi[o1, i] * nb
                s2 += cmr[o2, i] * na - cmi[o2, i] * nb
                s3 += cmr[o3, i] * na - cmi[o3, i] * nb
                s4 += cmr[o4, i] * na - cmi[o4, i] * nb
            hot[o0] = s0
            hot[o1] = s1
            hot[o2] = s2
            hot[o3] = s3
            hot[o4] = s4
            for q in range(5, nact, 4):
                oa = act[q]
                ob = act[q + 1]
                oc = act[q + 2]
                od = act[q + 3]
                s0 = 0.0
                s1 = 0.0
                s2 = 0.0
                s3 = 0.0
                for i in range(nm):
                    na = zr[i]
                    nb = zi[i]
                    s0 += cmr[oa, i] * na - cmi[oa, i] * nb
                    s1 += cmr[ob, i] * na - cmi[ob, i] * nb
                    s2 += cmr[oc, i] * na - cmi[oc, i] * nb
                    s3 += cmr[od, i] * na - cmi[od, i] * nb
                hot[oa] = s0
                hot[ob] = s1
                hot[oc] = s2
                hot[od] = s3
            if nk > 0:
                for c in range(nk):
                    xi0[c] = xi[c]
                for q in range(nk):
                    acc = 0.0
                    for c in range(nk):
                        acc += ad[q, c] * xi0[c]
                    for p in range(n_w):
                        acc += bd0[q, p] * wa_s[p] + bd1[q, p] * wb_s[p]
                    xi[q] = acc
                for q2 in range(nact):
                    o = act[q2]
                    acc = hot[o]
                    for c in range(nk):
                        acc += ck[o, c] * xi[c]
                    hot[o] = acc
            for q2 in range(ndact):
                o = dact[q2]
                acc = hot[o]
                for p in range(n_w):
                    acc += dr[o, p] * wb_s[p]
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
                        fe_, fd, fv = smooth_force(kind[e], par[e, 0], par[e, 1], de, ve)
                        res[e] = fsm[e] + delta[e] - fe_
                        big = max(big, abs(fe_))
                        for k2 in range(n_nl):
                            jac[e, k2] -= fd * sens[row_d + e, k2] + fv * sens[row_v + e, k2]
                    if n_nl == 1:
                        stp0 = res[0] / jac[0, 0]
                        delta[0] -= stp0
                        change = abs(stp0)
                    else:
                        solve_small(jac, res, jac_scr, solve_scr)
                        change = 0.0
                        for e in range(n_nl):
                            delta[e] -= solve_scr[e]
                            change = max(change, abs(solve_scr[e]))
                    if change <= 1e-14 * big or change == 0.0:
                        break
                for e in range(n_nl):
                    de = delta[e]
                    if de == 0.0:
                        continue
                    p = n_in + e
                    wb_s[p] += de
                    for i in range(nm):
                        zr[i] += g1r[p, i] * de
                        zi[i] += g1i[p, i] * de
                    for c in range(nk):
                        xi[c] += bd1[c, p] * de
                    for q2 in range(nact):
                        o = act[q2]
                        hot[o] += sens[o, e] * de

            # -- friction gates at the step end
            event = False
            if lean:
                gv = hot[g_row]
                event = (g_fc - abs(gv) < 0.0) if g_stk else (g_sgn * gv < 0.0)
            else:
                for e in range(n_nl):
                    if kind[e] != KIND_COULOMB:
                        continue
                    if (mask >> fbit[e]) & 1:
                        if par[e, 0] - abs(hot[row_h + e]) < 0.0:
                            event = True
                    elif dirs[e] * hot[row_v + e] < 0.0:
                        event = True

            # -- a gate positive at both ends may dip below zero inside the step (two
            #    sign changes of a velocity): the quintic through its values and first two
            #    derivatives at both ends, with a wide margin for its error (some
            #    (|s| dt)^6 / 46080 of the modal amplitudes), flags the candidates that
            #    the event path then checks exactly
            cand = zero
            if not event:
                for e in range(n_nl):
                    if kind[e] != KIND_COULOMB:
                        continue
                    is_stuck = (mask >> fbit[e]) & 1
                    row = row_h + e if is_stuck else row_v + e
                    v1 = hot[row]
                    if is_stuck:
                        sg = -1.0 if v1 >= 0.0 else 1.0
                        g0 = par[e, 0] + sg * gst[0, e]
                        g1 = par[e, 0] + sg * v1
                    else:
                        sg = dirs[e]
                        g0 = sg * gst[0, e]
                        g1 = sg * v1
                    gst[0, e] = v1
                    # far from zero for the size of its derivatives (known at most
                    # _DIP_EVERY steps ago): no look inside
                    if min(g0, g1) >= _DIP_FAR * gst[4, e] and gst[5, e] < _DIP_EVERY:
                        gst[3, e] = 0.0
                        gst[5, e] += 1.0
                        continue
                    rate1 = 0.0
                    rate2 = 0.0
                    for p in range(n_w):
                        wdp = wb_s[p] - wa_s[p]
                        rate1 += dr[row, p] * wdp
                        rate2 += dwr[1, row, p] * wdp
                    r1, r2 = row_rate(nm, nk, crow, ckr, dwr, row, zr, zi, xi, wb_s)
                    d1 = sg * (dt * r1 + rate1)
                    c1 = sg * dt * (dt * r2 + rate2)
                    if min(g0, g1) < 4.0 * (abs(d1) + abs(c1)):
                        if gst[3, e] == 0.0:  # the start's derivatives: not at hand
                            gst[1, e], gst[2, e] = row_rate(nm, nk, crow, ckr, dwr, row, zr0,
                                                            zi0, xi0, wa_s)
                        d0 = sg * (dt * gst[1, e] + rate1)
                        c0 = sg * dt * (dt * gst[2, e] + rate2)
                        if dip_suspect(g0, d0, c0, g1, d1, c1, smax_dt):
                            cand |= 1 << fbit[e]
                    gst[1, e] = r1
                    gst[2, e] = r2
                    gst[3, e] = 1.0
                    gst[4, e] = abs(d1) + abs(c1)
                    gst[5, e] = 0.0
            if event or cand != 0:
                # -- event path: the step piece by piece from its start
                mask, fail = event_step(j, dt, n_grid, mask, cand, n_in, n_out, max_events,
                                        reg, kind, par, fbit, fe, st, scr)
                if fail >= 0:
                    break
                fric_forcing(dims_a[mask, 0], n_in, kind, par, fbit, mask, dirs, g_a[mask],
                             cfr, cfi, wa_s, wb_s)
                g_row, g_stk, g_sgn = lean_gate(lean, mask, fbit, dirs, row_v, row_h)
                gate_rows(mask, n_nl, row_v, row_h, kind, fbit, dims_a[mask, 0],
                          dims_a[mask, 2], crow_a[mask], ckr_a[mask], dw_a[mask], zr, zi, xi,
                          wb_s, wz[2], dt, gst)
            j += 1
            if lean:
                # one friction element and nothing else: its row is the gate's
                for o in range(n_out):
                    y[o, j] = hot[o]
                if g_stk:
                    fo[0, j] = hot[g_row]
                    stuck[0, j] = True
                else:
                    vel[0, j] = hot[g_row]
                    fo[0, j] = -g_fc * g_sgn
            else:
                record(j, hot, n_out, row_d, row_v, row_h, n_in, par, fbit, mask, dirs,
                       is_smooth, wb_s, fsm, y, fo, disp, vel, stuck)
            if mask != r:
                break
        if fail >= 0:
            break
        r = mask
    return fail


def run(u, dt, x0, n_out, n_grid, reg, kind, par, fbit, cd, cv, max_newton, max_events):
    """Simulate; see :meth:`truthbench.simulate.nonlinear.NonlinearSystem.simulate`.

    ``reg`` is the tuple of per-regime arrays (:data:`REGIME_ARRAYS`). Rows of every
    regime: ``[y; d; v; h; t; a zero row]``; per step only the regime's active rows
    ``act[r, :nact[r]]`` are computed (``5 + 4 k`` of them, padded with the zero row: the
    first five are fused with the modal update, the others go four at a time). Allocates
    every array, then runs :func:`loop`. Returns ``(y, f, disp, vel, stuck, n_stick,
    n_rev, fail)`` where ``fail`` is -1 or the sample index at which the event limit per
    step was exceeded.
    """
    crow_a = reg[_I_CROW]
    ad_a = reg[_I_AD]
    n_in, n_samples = u.shape
    n_nl = kind.shape[0]
    n_w = n_in + n_nl
    n_rows = crow_a.shape[2]
    n = x0.shape[0]
    m_max = crow_a.shape[3]
    k_max = ad_a.shape[1]

    y = np.zeros((n_out, n_samples))
    fo = np.zeros((n_nl, n_samples))
    disp = np.zeros((n_nl, n_samples))
    vel = np.zeros((n_nl, n_samples))
    stuck = np.zeros((n_nl, n_samples), dtype=np.bool_)
    n_stick = np.zeros(n_nl, dtype=np.int64)
    n_rev = np.zeros(n_nl, dtype=np.int64)

    dirs = np.zeros(n_nl)
    last_dir = np.zeros(n_nl)
    fresh = np.zeros(n_nl, dtype=np.int64)
    fsm = np.zeros(n_nl)  # smooth forces at the step start
    is_smooth = np.zeros(n_nl, dtype=np.bool_)
    for e in range(n_nl):
        is_smooth[e] = kind[e] != KIND_COULOMB
    # inputs at the step start and end: u, smooth forces (predicted at the end, then
    # corrected), slipping friction -F_c dir (0 when stuck; set by fric_forcing)
    wa_s = np.zeros(n_w)
    wb_s = np.zeros(n_w)
    wz = np.zeros((N_SCRATCH_INPUT, n_w))
    hot = np.zeros(n_rows)
    x = np.zeros(n)
    fr = np.zeros(m_max)
    fi = np.zeros(m_max)
    cfr = np.zeros(m_max)
    cfi = np.zeros(m_max)
    dyn = np.zeros(n_w, dtype=np.int64)  # inputs that vary within a step: u, smooth forces
    sm = np.zeros((N_SCRATCH_MODAL, m_max))  # event-path scratch
    sk = np.zeros((N_SCRATCH_BLOCK, k_max))
    sx = np.zeros((3, k_max + 2, k_max + 2))
    delta = np.zeros(n_nl)
    res = np.zeros(n_nl)
    jac = np.zeros((n_nl, n_nl))
    jac_scr = np.zeros((n_nl, n_nl))
    solve_scr = np.zeros(n_nl)
    # the state (zr, zi, xi); its value at the step start is kept in (zr0, zi0, xi0)
    st = (np.zeros(m_max), np.zeros(m_max), np.zeros(k_max), np.zeros(m_max),
          np.zeros(m_max), np.zeros(k_max))
    out = (y, fo, disp, vel, stuck, n_stick, n_rev)
    # gate rows of the friction elements at the step start: value, two derivatives
    # (without the input-rate terms, which change from step to step), whether those are
    # current, the size of the derivative terms when last computed and how long ago
    gst = np.zeros((6, n_nl))
    wk = (dirs, last_dir, fresh, fsm, is_smooth, wa_s, wb_s, wz, hot, x, fr, fi, cfr, cfi,
          dyn, sm, sk, sx, delta, res, jac, jac_scr, solve_scr, gst)
    fail = loop(u, dt, x0, n_out, n_grid, reg, kind, par, fbit, cd, cv, max_newton,
                max_events, out, wk, st)
    for e in range(n_nl):
        if not is_smooth[e]:
            for jj in range(n_samples):
                disp[e, jj] = np.nan  # not tracked for friction elements
    return y, fo, disp, vel, stuck, n_stick, n_rev, fail
