"""Sampled simulation of a linear structure with local nonlinear elements.

The system is

    x' = A x + B u + B_nl f_nl,        y = C x + D u + D_nl f_nl,

with the input ``u`` known at ``t_j = j dt`` and linear in between (first-order hold,
as :func:`~truthbench.simulate.linear.simulate_lti`). Each nonlinear element ``e``
reads a local displacement ``d_e = c_d,e x`` and velocity ``v_e = c_v,e x`` (the rows of
:class:`~truthbench.simulate.nonlinear_elements.NonlinearElement`) and pushes back with
the force ``f_e`` through the column ``b_e`` of ``B_nl`` (and ``D_nl`` for outputs, such
as accelerations, that see the force directly). SI units: N, m, m/s, or N m, rad, rad/s
at a rotational degree of freedom. The elements and their laws are in
:mod:`truthbench.simulate.nonlinear_elements` (and importable from here).

Element laws (:data:`LAWS`)
---------------------------
* :class:`~truthbench.simulate.nonlinear_elements.CoulombFriction` -- ``f = -F_c
  sign(v)`` while slipping; stuck while the force that holds ``v = 0`` is within ``F_c``
  (static = kinetic friction).
* :class:`~truthbench.simulate.nonlinear_elements.CubicStiffness` -- ``f = -k3 d^3``.
* :class:`~truthbench.simulate.nonlinear_elements.DeadBand` -- ``f = -k (d - sign(d)
  gap)`` for ``|d| > gap``, else 0.
* :class:`~truthbench.simulate.nonlinear_elements.AmplitudeDependentDamping` --
  quadratic damping ``f = -c2 |v| v``.

Method
------
**Friction is exact: event-driven switching, no regularisation.** While every friction
element keeps its state (slipping one way, or stuck) the motion is linear: a slipping
element is a constant force, a stuck one a constraint ``v_e = 0`` whose holding force
``h = -(c_v b_e)^-1 c_v (A x + B u + ...)`` follows from ``c_v x' = 0``. So each subset
``S`` of stuck elements is a linear *regime* on the subspace ``C_v,S x = 0``
(``x = Q xi``, ``Q`` an orthonormal basis of that null space) with dynamics
``xi' = Q^T P A Q xi + Q^T P [B, B_nl] w``, ``P = I - B_S (C_v,S B_S)^-1 C_v,S``. All
``2^n_friction`` regimes are prepared once and advanced exactly for the piecewise-linear
input by diagonal complex modal recursions plus, for defective eigenvalues such as the
free rigid-body rotation of a slipping hub bearing, a small dense block, as
:mod:`~truthbench.simulate.linear` does. Per step the current regime advances over the
whole step. If at the step end a slipping element's velocity has changed sign, or a
stuck element's holding force exceeds ``F_c``, the step is redone from its start on the
exact intra-step solution: the first event is estimated from a quintic Hermite
interpolant of the gate (value and two exact time derivatives at both ends) and polished
by Newton's method on the exact solution to ``1e-12 dt``. The exact state at an
arbitrary time inside a step comes from tables of ``exp(s h)`` and the two input
integrals on a grid of the step (prepared per regime) and the state's Taylor series over
the rest of the way, a few multiply-adds per mode and no exponential (exponentials only
for modes too stiff for the grid). At a velocity zero the trial holding force decides:
within ``F_c`` the element sticks (the state goes into the new regime through ``x``;
its velocity, zero to root-finding accuracy, is projected out), beyond it the velocity
reverses, which keeps the regime and only adds the response to the force jump to the
step-end state. A stuck element whose holding force reaches ``F_c`` slips in the
direction of ``-sign(h)``. A velocity that touches zero and comes back *within one step*
(stick and breakaway, or two reversals, between two samples) leaves the gate positive at
both ends: a gate near zero is also checked inside the step (the quintic through its
values and derivatives at both ends, with a wide margin, then the exact least value of
the gate). The response is exact up to the event location and rounding (measured
against solve_ivp restarted at every event: 1e-10 to 1e-12 of the RMS response, also for
a 40-mode model driven up to 0.4 fs), with one limitation: after a reversal inside a
step, a further touch of zero and back of the same velocity within that step (three sign
changes in one step) is not looked for; keep ``dt`` below the shortest period that
matters.

**Smooth elements are second order in dt.** Their force is taken linear in time over a
step (like the input) between ``f_j`` and ``f_{j+1} = f(d_{j+1}, v_{j+1})``, an implicit
equation solved by Newton's method on the exact linear sensitivity of ``d_{j+1}``,
``v_{j+1}`` to ``f_{j+1}`` (a few scalar operations per step). The linear part stays exact;
the force interpolation costs ``O(dt^2)`` (measured order 2 in the tests). In a step with
a friction event the smooth forces keep the ramp predicted for that step.

Cost (``bench/bench_nonlinear.py``, 40 modes, 4 outputs, 2**16 samples): a step without
an event costs about 1.6-1.9 times a step of
:meth:`~truthbench.simulate.linear.LtiRecursion.simulate`; a velocity reversal about
1-2 us, a stick or breakaway (a regime change through the full state) a few us, and a
step whose gate is near zero a little more (the check for a dip inside). So the total
depends on how often the friction point's velocity changes sign: about 2x the linear
time with some hundreds of events, 2.5x with about a thousand, 4.5-5x with 7500 (a
reversal every nine samples). The loop runs compiled by numba (``numba.njit(cache=True)``)
when numba can be imported (``backend="auto"``), else interpreted: the same source, the
same arithmetic, fine for small systems. The compiled loop is large: compiling it on a
cold cache takes one to two minutes of CPU (once per machine and source version; later
processes load it from the cache in about half a second).

This module belongs to ``truthbench.simulate``, which owns excitation, noise and time
simulation.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
import scipy.linalg

from truthbench._validation import readonly
from truthbench.errors import ConvergenceError, ModelError
from truthbench.presentation import Presentable, figure_axes

from . import _nonlinear_kernel as _kern
from ._exact import (
    COND_MAX,
    KAPPA_DEFECTIVE,
    block_split,
    check_dt,
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
from .nonlinear_elements import (
    LAWS,
    AmplitudeDependentDamping,
    CoulombFriction,
    CubicStiffness,
    DeadBand,
    NonlinearElement,
    NonlinearLaw,
)

__all__ = [
    "LAWS",
    "AmplitudeDependentDamping",
    "CoulombFriction",
    "CubicStiffness",
    "DeadBand",
    "NonlinearElement",
    "NonlinearLaw",
    "NonlinearResult",
    "NonlinearSystem",
    "prepare_nonlinear",
    "simulate_nonlinear",
]

Backend = Literal["auto", "numba", "numpy"]

#: Largest number of friction elements (every one of the 2**n stuck subsets is prepared).
MAX_FRICTION_ELEMENTS = 6


# ----------------------------------------------------------------------------------
# regimes
# ----------------------------------------------------------------------------------


def _realize(a: np.ndarray, b: np.ndarray) -> dict:
    """Modal (+ defective block) realisation of ``xi' = a xi + b w`` (as prepare_lti).

    Returns the continuous modal data (eigenvalues ``s`` of one mode per conjugate pair,
    modal input ``bm``), the maps between ``xi`` and the recursion coordinates
    (``xi = Re(right z) + rb blk``, ``z = left xi``, ``blk = lb xi``), and the
    continuous block ``T``, ``Bk``.
    """
    n, n_w = b.shape
    empty = dict(
        s=np.zeros(0, complex), bm=np.zeros((0, n_w), complex), right=np.zeros((n, 0), complex),
        left=np.zeros((0, n), complex), T=np.zeros((0, 0)), Bk=np.zeros((0, n_w)),
        rb=np.zeros((n, 0)), lb=np.zeros((0, n)), path="modal", cond=1.0,
    )
    if n == 0:
        return empty
    _, (scale, _) = scipy.linalg.matrix_balance(a, permute=False, separate=True)
    ab = a * scale[None, :] / scale[:, None]
    bb = b / scale[:, None]
    s, v, vinv, cond_v = eig(ab)
    a_norm = float(np.linalg.norm(ab))
    near_rigid = vinv is not None and bool(
        np.any((np.linalg.norm(vinv, axis=1) > KAPPA_DEFECTIVE) & (np.abs(s) <= 1e-6 * a_norm))
    )
    sel = pairs(s)
    if cond_v <= COND_MAX and not near_rigid and sel is not None:
        keep, weight = sel
        vinv_k = vinv[keep]
        return {
            **empty,
            "s": s[keep],
            "bm": vinv_k @ bb.astype(complex),
            "right": scale[:, None] * v[:, keep] * weight,
            "left": vinv_k / scale[None, :],
            "cond": cond_v,
        }
    s_lr, bad = defective_selection(ab)
    split = block_split(ab, s_lr, bad) if bad is not None else None
    if split is not None:
        p, pinv, t11, t22 = split
        k = t11.shape[0]
        t11 = snap_zero_cluster(t11, a_norm)
        cond_p = float(np.linalg.norm(p) * np.linalg.norm(pinv))
        s2, v2, v2inv, cond_v2 = eig(t22)
        sel2 = pairs(s2) if v2inv is not None else None
        if cond_p <= COND_MAX and cond_v2 <= COND_MAX and sel2 is not None:
            keep, weight = sel2
            bw = pinv @ bb
            v2inv_k = v2inv[keep]
            return {
                **empty,
                "s": s2[keep],
                "bm": v2inv_k @ bw[k:].astype(complex),
                "right": scale[:, None] * (p[:, k:] @ v2[:, keep]) * weight,
                "left": (v2inv_k @ pinv[k:]) / scale[None, :],
                "T": t11,
                "Bk": bw[:k],
                "rb": scale[:, None] * p[:, :k],
                "lb": pinv[:k] / scale[None, :],
                "path": "block",
                "cond": cond_p * cond_v2,
            }
    return {**empty, "T": ab, "Bk": bb, "rb": np.diag(scale), "lb": np.diag(1.0 / scale),
            "path": "state"}


#: largest ``|s| dt / (2 n_grid)`` for the kernel's Taylor step from a grid point to the
#: first term left out (``x^(d+3)/(d+3)!``, ``d`` the fixed degree) being below 1e-18
_X_TABLE = (1e-18 * math.factorial(_kern.TAYLOR_DEGREE + 3)) ** (
    1.0 / (_kern.TAYLOR_DEGREE + 3))
#: the grid of a step at which intra-step propagation is tabulated: 16 to 256 points
_GRID_MIN, _GRID_MAX = 16, 256
#: largest dense block whose intra-step propagation is tabulated
_MAX_TABLE_BLOCK = 8


def _grid_size(parts: list[dict], dt: float) -> int:
    """Points of the step grid: the fewest (a power of two) that put every mode and small
    block within reach of the Taylor step; stiffer ones use exponentials."""
    smax = 0.0
    for part in parts:
        smax = max(smax, float(np.max(np.abs(part["s"]), initial=0.0)))
        if 0 < part["nk"] <= _MAX_TABLE_BLOCK:
            smax = max(smax, float(np.linalg.norm(part["T"], np.inf)))
    n_grid = _GRID_MIN
    while n_grid < _GRID_MAX and smax * dt / (2 * n_grid) > _X_TABLE:
        n_grid *= 2
    return n_grid


def _tables(part: dict, dt: float, n_grid: int) -> dict:
    """Intra-step propagation tables of one regime at ``h_k = k dt / n_grid``.

    Modes (sorted by ``|s|``; the first ``nt`` are within reach of the Taylor step):
    ``tab[k] = [Re, Im of E, F1, F2]`` with ``E = exp(s h)``, ``F1 = h phi1(s h)``,
    ``F2 = h^2 phi2(s h)`` (state, constant and ramp input). Block: the same three as
    matrices (``expm`` of the augmented matrix) when it is small and not stiff (``btab``).
    """
    s, t_blk = part["s"], part["T"]
    hk = dt * np.arange(n_grid + 1) / n_grid
    nt = int(np.count_nonzero(np.abs(s) * dt / (2 * n_grid) <= _X_TABLE))
    a = np.outer(hk, s)
    p1, p2 = phi12(a)
    e, f1, f2 = np.exp(a), hk[:, None] * p1, (hk**2)[:, None] * p2
    tab = np.stack([e.real, e.imag, f1.real, f1.imag, f2.real, f2.imag], axis=1)
    nk = t_blk.shape[0]
    x_blk = float(np.linalg.norm(t_blk, np.inf)) * dt / (2 * n_grid) if nk else 0.0
    btab = 0 < nk <= _MAX_TABLE_BLOCK and x_blk <= _X_TABLE
    kb = nk if btab else 0
    etab = np.zeros((n_grid + 1, 3, kb, kb))
    if btab:
        eye = np.eye(nk)
        for k, h in enumerate(hk):
            m = np.zeros((3 * nk, 3 * nk))
            m[:nk, :nk] = t_blk * h
            m[:nk, nk : 2 * nk] = eye * h
            m[nk : 2 * nk, 2 * nk :] = eye * h
            ex = scipy.linalg.expm(m)
            etab[k] = ex[:nk].reshape(nk, 3, nk).transpose(1, 0, 2)
    return dict(dims=np.array([s.size, nt, nk, int(btab)], dtype=np.int64), tab=tab,
                etab=etab, s2=np.vstack([s.real, s.imag]))


def _regime(mask, fric, a, bw, c_rows, d_rows, cv, bnl, n_in, n_out, n_nl, dt):
    """Everything the kernel needs for the regime whose stuck friction set is ``mask``.

    ``c_rows``/``d_rows`` are the output rows ``[y; d; v; h; t]`` of the free system in
    terms of ``x`` and ``w = [u; f_nl]`` (``h`` and ``t`` rows zero); the stuck
    elements' holding forces and the slipping ones' trial holding forces are filled in
    here.
    """
    n = a.shape[0]
    n_w = bw.shape[1]
    stuck = [fric[i] for i in range(len(fric)) if (mask >> i) & 1]
    c_rows = c_rows.copy()
    d_rows = d_rows.copy()
    hx = np.zeros((n_nl, n))
    hw = np.zeros((n_nl, n_w))
    if stuck:
        cvs = cv[stuck]
        bs = bnl[:, stuck]
        m_ss = cvs @ bs
        if np.linalg.cond(m_ss) > 1e12:
            raise ModelError(
                f"friction elements {stuck} cannot all stick at once: their velocity rows "
                "and force columns are (nearly) dependent (c_v B_nl restricted to them is "
                f"singular, condition {np.linalg.cond(m_ss):.3g}); e.g. two friction "
                "elements at the same DOF"
            )
        m_inv = np.linalg.inv(m_ss)
        bw_eff = bw.copy()
        bw_eff[:, [n_in + e for e in stuck]] = 0.0
        hx_s = -m_inv @ cvs @ a
        hw_s = -m_inv @ cvs @ bw_eff
        proj = np.eye(n) - bs @ m_inv @ cvs
        q = scipy.linalg.null_space(cvs)
        a_r = q.T @ proj @ a @ q
        b_r = q.T @ proj @ bw_eff
        hx[stuck] = hx_s
        hw[stuck] = hw_s
        dnl_s = d_rows[:n_out, [n_in + e for e in stuck]]
        d_rows[:, [n_in + e for e in stuck]] = 0.0
        c_rows[:n_out] += dnl_s @ hx_s
        d_rows[:n_out] += dnl_s @ hw_s
        row_h = n_out + 2 * n_nl
        c_rows[[row_h + e for e in stuck]] = hx_s
        d_rows[[row_h + e for e in stuck]] = hw_s
    else:
        q = None
        proj = np.eye(n)
        bw_eff = bw
        a_r = a
        b_r = bw
    # trial holding force of each slipping friction element: the force that would keep
    # its velocity at zero with the stuck set as it is (zero rows for the others)
    row_t = n_out + 3 * n_nl
    for i, e in enumerate(fric):
        if (mask >> i) & 1:
            continue
        gain = float(cv[e] @ proj @ bnl[:, e])
        if not gain > 0.0:
            raise ModelError(
                f"friction elements {sorted([*stuck, e])} cannot all stick at once: while "
                f"{stuck} are stuck, element {e}'s velocity does not respond to its force "
                f"(velocity_row @ force_column on the constrained system is {gain:.3g}); "
                "e.g. two friction elements at the same DOF"
            )
        bw_t = bw_eff.copy()
        bw_t[:, n_in + e] = 0.0
        c_rows[row_t + e] = -(cv[e] @ proj @ a) / gain
        d_rows[row_t + e] = -(cv[e] @ proj @ bw_t) / gain
    real = _realize(a_r, b_r)
    right, rb, left, lb = real["right"], real["rb"], real["left"], real["lb"]
    if q is not None:
        right = q @ right
        rb = q @ rb
        left = left @ q.T
        lb = lb @ q.T
    # modes by |s|: the ones the kernel's tables cover come first
    order = np.argsort(np.abs(real["s"]), kind="stable")
    s = real["s"][order]
    bm = real["bm"][order]
    right = right[:, order]
    left = left[order]
    phi1, phi2 = phi12(s * dt)
    w0, w1 = dt * (phi1 - phi2), dt * phi2
    g0 = (w0[:, None] * bm).T
    g1 = (w1[:, None] * bm).T
    cm = c_rows.astype(complex) @ right
    ck = c_rows @ rb
    t_blk, b_blk = real["T"], real["Bk"]
    ad, bd0, bd1 = van_loan(t_blk, b_blk, dt, "foh")
    # a row's time derivatives: (c z)' = (c s) z + c Bm w, (c z)'' = (c s^2) z + ...
    cs = cm * s[None, :]
    d1 = (cm @ bm).real + ck @ b_blk
    d2 = (cs @ bm).real + ck @ t_blk @ b_blk
    # sensitivity of the step-end rows to the element forces at the step end (Newton
    # correction of the smooth forces)
    cols = np.r_[n_in : n_in + n_nl]
    sens = (cm @ g1[cols].T).real + ck @ bd1[:, cols] + d_rows[:, cols]
    # rows computed at every step: outputs, displacements of the smooth elements,
    # velocities of the elements not stuck, holding forces of the stuck ones; at least
    # four (the zero row pads). A friction element's displacement is not needed: leaving
    # it out saves a sixth of the per-step work of a 4-output model.
    stuck_set = set(stuck)
    act = list(range(n_out)) + [n_out + e for e in range(n_nl) if e not in fric]
    act += [n_out + n_nl + e for e in range(n_nl) if e not in stuck_set]
    act += [n_out + 2 * n_nl + e for e in stuck]
    # five rows go with the modal update, the others four at a time: pad with the zero row
    n_act = 5 + 4 * max(0, -(-(len(act) - 5) // 4))
    act += [c_rows.shape[0] - 1] * (n_act - len(act))
    smax = max(float(np.max(np.abs(s), initial=0.0)),
               float(np.linalg.norm(t_blk, np.inf)) if t_blk.size else 0.0)
    # active rows with a direct input term (the others skip it at every step)
    dact = [o for o in dict.fromkeys(act) if np.any(d_rows[o] != 0.0)]
    lam = np.exp(s * dt)
    cs2 = cs * s[None, :]
    return dict(
        nm=s.size, nk=t_blk.shape[0], s=s, T=t_blk, smax=smax,
        lam=np.stack([lam.real, lam.imag]),
        g=np.stack([g0.real, g0.imag, g1.real, g1.imag]),
        bm=np.stack([bm.T.real, bm.T.imag]),
        crow=np.stack([cm.real, cm.imag, cs.real, cs.imag, cs2.real, cs2.imag]),
        rec=np.stack([right.real, right.imag]),
        tom=np.stack([left.T.real, left.T.imag]),
        tblk=t_blk, bblk=b_blk, ad=ad, bd=np.stack([bd0, bd1]),
        ckr=np.stack([ck, ck @ t_blk, ck @ t_blk @ t_blk]), recb=rb, tob=lb,
        dw=np.stack([d_rows, d1, d2]), hx=hx, hw=hw, sens=sens,
        act=np.array(act, dtype=np.int64), dact=np.array(dact, dtype=np.int64),
        path=real["path"],
        cond=real["cond"],
    )


def _stack(parts: list[dict], key: str, shape_tail, dtype=float) -> np.ndarray:
    out = np.zeros((len(parts), *shape_tail), dtype=dtype)
    for r, part in enumerate(parts):
        arr = part[key]
        out[(r, *tuple(slice(0, k) for k in arr.shape))] = arr
    return out


def _stack_rows(lists: list[np.ndarray], fill: int) -> np.ndarray:
    out = np.full((len(lists), max(a.size for a in lists)), fill, dtype=np.int64)
    for r, a in enumerate(lists):
        out[r, : a.size] = a
    return out


# ----------------------------------------------------------------------------------
# engines
# ----------------------------------------------------------------------------------


@functools.cache
def _numba_run():
    try:
        from ._nonlinear_numba import run
    except ImportError:
        return None
    return run


def _engine(backend: str):
    if backend not in ("auto", "numba", "numpy"):
        raise ValueError(
            f"backend must be one of 'auto', 'numba', 'numpy'; got {backend!r} instead"
        )
    if backend == "numpy":
        return _kern.run
    run = _numba_run()
    if run is not None:
        return run
    if backend == "numba":
        raise ImportError(
            "backend='numba' was requested but numba cannot be imported; install the "
            "'fast' extra (pip install truthbench[fast]) or use backend='numpy'"
        )
    return _kern.run


# ----------------------------------------------------------------------------------
# results and the prepared system
# ----------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class NonlinearResult(Presentable):
    """Sampled response of a system with nonlinear elements.

    Tables (:meth:`to_pandas`): ``"outputs"`` one row per sample (``t_s``, ``y0``,
    ``y1``, ...), ``"elements"`` one row per (sample, element), ``"events"`` one row per
    element (stick events, reversals). Figures (:meth:`plot`): ``"outputs"`` the outputs
    against time, ``"elements"`` every element's force against time and against its
    velocity.

    Attributes
    ----------
    y : ndarray, shape (n_out, n_samples)
        Outputs at ``t_j = j dt``.
    f_nl : ndarray, shape (n_nl, n_samples)
        Element forces at ``t_j``, N (N m): slipping friction ``-F_c sign(v)`` (the value
        acting just after ``t_j``), stuck friction its holding force.
    displacement, velocity : ndarray, shape (n_nl, n_samples)
        Element displacement ``c_d x`` (m, rad) and velocity ``c_v x`` (m/s, rad/s).
        The displacement of a friction element is not tracked (NaN; it would cost a row
        per step): give ``C`` an output row for it if it is wanted.
    stuck : ndarray of bool, shape (n_nl, n_samples)
        Whether each friction element is stuck at ``t_j`` (False for other elements).
    n_stick_events : ndarray of int, shape (n_nl,)
        Transitions from slip to stick, per element.
    n_reversals : ndarray of int, shape (n_nl,)
        Changes of the slip direction (through a stick phase or not), per element.
    dt : float
        Sampling interval, s.
    """

    TABLES = ("outputs", "elements", "events")
    PLOTS = ("outputs", "elements")

    y: np.ndarray
    f_nl: np.ndarray
    displacement: np.ndarray
    velocity: np.ndarray
    stuck: np.ndarray
    n_stick_events: np.ndarray
    n_reversals: np.ndarray
    dt: float

    @property
    def t_s(self) -> np.ndarray:
        """Sample times ``j dt``, s."""
        return self.dt * np.arange(self.y.shape[1])

    def _table_outputs(self):
        """One row per sample: ``t_s`` and ``y0``, ``y1``, ... (the outputs' units)."""
        import pandas as pd

        return pd.DataFrame({"t_s": self.t_s,
                             **{f"y{k}": row for k, row in enumerate(self.y)}})

    def _table_elements(self):
        """One row per (sample, element): t_s, element, force, displacement, velocity,
        stuck."""
        import pandas as pd

        n_nl, n = self.f_nl.shape
        return pd.DataFrame({"t_s": np.tile(self.t_s, n_nl),
                             "element": np.repeat(np.arange(n_nl), n),
                             "force": self.f_nl.ravel(),
                             "displacement": self.displacement.ravel(),
                             "velocity": self.velocity.ravel(),
                             "stuck": self.stuck.ravel()})

    def _table_events(self):
        """One row per element: ``n_stick_events``, ``n_reversals``."""
        import pandas as pd

        return pd.DataFrame({"n_stick_events": self.n_stick_events,
                             "n_reversals": self.n_reversals},
                            index=pd.RangeIndex(len(self.n_stick_events), name="element"))

    def _plot_outputs(self, ax):
        """The outputs against time."""
        fig, (ax,) = figure_axes(ax, figsize=(7, 3.5))
        for k, row in enumerate(self.y):
            ax.plot(self.t_s, row, lw=0.8, label=f"y{k}")
        ax.set_xlabel("time [s]")
        ax.set_ylabel("output")
        ax.legend(fontsize="small")
        fig.tight_layout()
        return fig

    def _plot_elements(self, ax):
        """Every element's force against time (left) and against its velocity (right:
        the hysteresis of friction)."""
        fig, (left, right) = figure_axes(ax, 1, 2, figsize=(9, 3.5))
        for k in range(self.f_nl.shape[0]):
            left.plot(self.t_s, self.f_nl[k], lw=0.8, label=f"element {k}")
            right.plot(self.velocity[k], self.f_nl[k], lw=0.6)
        left.set_xlabel("time [s]")
        left.set_ylabel("element force [N or N m]")
        right.set_xlabel("element velocity [m/s or rad/s]")
        left.legend(fontsize="small")
        fig.tight_layout()
        return fig


@dataclass(frozen=True, eq=False)
class NonlinearSystem:
    """A linear system with nonlinear elements, prepared for simulation at ``dt``.

    Made by :func:`prepare_nonlinear`; reuse it for many inputs (the regimes are
    decomposed once). Attributes ``paths`` and ``conds`` describe each regime's
    realisation (``"modal"``, ``"block"`` or ``"state"``, and the condition number of its
    coordinate change), indexed by the bit mask of stuck friction elements.
    """

    dt: float
    n_states: int
    n_inputs: int
    n_outputs: int
    elements: tuple
    paths: tuple
    conds: tuple
    _arrays: dict

    @property
    def n_elements(self) -> int:
        return len(self.elements)

    @property
    def n_regimes(self) -> int:
        return len(self.paths)

    def simulate(self, u, x0=None, *, backend: Backend = "auto",
                 max_events_per_step: int = 1000) -> NonlinearResult:
        """Response to the input ``u`` from the initial state ``x0``.

        Parameters
        ----------
        u : array_like, shape (n_inputs, n_samples)
            Input at ``t_j = j dt`` (1-D accepted for one input), linear between samples.
        x0 : array_like, shape (n_states,), optional
            Initial state (zeros by default). A friction element with ``v = 0`` at
            ``t = 0`` starts stuck if its holding force is within ``F_c``.
        backend : {"auto", "numba", "numpy"}
            Engine; ``"auto"`` uses numba when it imports.
        max_events_per_step : int
            Limit on friction events within one step (guards against chattering).

        Returns
        -------
        NonlinearResult

        Raises
        ------
        ValueError
            Bad ``u``, ``x0`` or ``backend``.
        ConvergenceError
            More than ``max_events_per_step`` events in one step.
        """
        run = _engine(backend)
        uu = check_input(u, self.n_inputs)
        x = check_x0(x0, self.n_states)
        if isinstance(max_events_per_step, bool) or not isinstance(max_events_per_step, int) \
                or max_events_per_step < 1:
            raise ValueError("max_events_per_step must be a positive integer; got "
                             f"{max_events_per_step!r}")
        arr = self._arrays
        if uu.shape[0] == 0:
            uu = np.zeros((0, uu.shape[1]))
        reg = tuple(arr[key] for key in _kern.REGIME_ARRAYS)
        out = run(uu, self.dt, x, self.n_outputs, arr["n_grid"], reg, arr["kind"],
                  arr["par"], arr["fbit"], arr["cd"], arr["cv"], 50, int(max_events_per_step))
        y, f, disp, vel, stuck, n_stick, n_rev, fail = out
        if fail >= 0:
            raise ConvergenceError(
                f"more than max_events_per_step={max_events_per_step} friction events in "
                f"the step from sample {fail} to {fail + 1} (t = {fail * self.dt:.6g} s): "
                "chattering between stick and slip; check the friction elements or use a "
                "smaller dt"
            )
        return NonlinearResult(
            y=readonly(y), f_nl=readonly(f), displacement=readonly(disp),
            velocity=readonly(vel), stuck=readonly(stuck),
            n_stick_events=readonly(n_stick), n_reversals=readonly(n_rev), dt=self.dt,
        )


def _check_elements(elements, n: int, n_out: int) -> tuple:
    if isinstance(elements, NonlinearElement):
        elements = (elements,)
    try:
        elements = tuple(elements)
    except TypeError as exc:
        raise TypeError(
            f"elements must be a sequence of NonlinearElement; got {type(elements).__name__}"
        ) from exc
    for i, el in enumerate(elements):
        if not isinstance(el, NonlinearElement):
            raise TypeError(
                f"elements[{i}] must be a NonlinearElement; got {type(el).__name__}"
            )
        for name in ("displacement_row", "velocity_row", "force_column"):
            got = getattr(el, name).shape
            if got != (n,):
                raise ModelError(
                    f"elements[{i}].{name} has the wrong shape; expected ({n},) (one entry "
                    f"per state) instead of {got}"
                )
        if el.output_column is not None and el.output_column.shape != (n_out,):
            raise ModelError(
                f"elements[{i}].output_column has the wrong shape; expected ({n_out},) "
                f"(one entry per output) instead of {el.output_column.shape}"
            )
        if isinstance(el.law, CoulombFriction):
            gain = float(el.velocity_row @ el.force_column)
            scale = float(np.linalg.norm(el.velocity_row) * np.linalg.norm(el.force_column))
            if not gain > 1e-12 * scale or scale == 0.0:
                raise ModelError(
                    f"elements[{i}] (CoulombFriction) needs velocity_row @ force_column > 0 "
                    "(the friction force must act directly on the velocity it opposes; "
                    f"the product is 1/m_eff); got {gain:.6g}"
                )
    n_fric = sum(isinstance(el.law, CoulombFriction) for el in elements)
    if n_fric > MAX_FRICTION_ELEMENTS:
        raise ModelError(
            f"at most {MAX_FRICTION_ELEMENTS} CoulombFriction elements are supported "
            f"(2**n stick regimes are prepared); got {n_fric}"
        )
    return elements


def prepare_nonlinear(A, B, C, D, dt: float, elements) -> NonlinearSystem:
    """Prepare ``x' = A x + B u + B_nl f_nl``, ``y = C x + D u + D_nl f_nl`` for simulation.

    Parameters
    ----------
    A : array_like, shape (n, n)
        State matrix, 1/s.
    B : array_like, shape (n, n_in)
        Input matrix.
    C : array_like, shape (n_out, n)
        Output matrix.
    D : array_like, shape (n_out, n_in), or None
        Feedthrough of ``u`` (None: zeros).
    dt : float
        Sampling interval, s.
    elements : sequence of NonlinearElement
        The nonlinear elements; their force columns form ``B_nl`` and their output
        columns ``D_nl``. At most :data:`MAX_FRICTION_ELEMENTS` friction elements.

    Returns
    -------
    NonlinearSystem

    Raises
    ------
    ModelError
        Malformed matrices, element rows of the wrong shape, a friction element whose
        force does not act on its velocity, friction elements that cannot stick together.
    ValueError
        Bad ``dt``.
    TypeError
        ``elements`` not a sequence of
        :class:`~truthbench.simulate.nonlinear_elements.NonlinearElement`.
    """
    a, b, c, d = check_system(A, B, C, D)
    dt = check_dt(dt)
    n, n_in = b.shape
    n_out = c.shape[0]
    els = _check_elements(elements, n, n_out)
    n_nl = len(els)
    bnl = np.zeros((n, n_nl))
    dnl = np.zeros((n_out, n_nl))
    cd = np.zeros((n_nl, n))
    cv = np.zeros((n_nl, n))
    kind = np.zeros(n_nl, dtype=np.int64)
    par = np.zeros((n_nl, 2))
    fbit = np.full(n_nl, -1, dtype=np.int64)
    fric: list[int] = []
    for e, el in enumerate(els):
        bnl[:, e] = el.force_column
        if el.output_column is not None:
            dnl[:, e] = el.output_column
        cd[e] = el.displacement_row
        cv[e] = el.velocity_row
        kind[e] = el.law.kind
        par[e] = el.law.params()
        if el.law.kind == _kern.KIND_COULOMB:
            fbit[e] = len(fric)
            fric.append(e)
    bw = np.hstack([b, bnl])
    # rows of every regime: [y; d; v; h; t; one zero row]
    n_rows = n_out + 4 * n_nl + 1
    c_rows = np.zeros((n_rows, n))
    c_rows[: n_out + 2 * n_nl] = np.vstack([c, cd, cv])
    d_rows = np.zeros((n_rows, n_in + n_nl))
    d_rows[:n_out, :n_in] = d
    d_rows[:n_out, n_in:] = dnl
    parts = [
        _regime(mask, fric, a, bw, c_rows, d_rows, cv, bnl, n_in, n_out, n_nl, dt)
        for mask in range(2 ** len(fric))
    ]
    n_grid = _grid_size(parts, dt)
    for part in parts:
        part.update(_tables(part, dt, n_grid))
    m_max = max(p["nm"] for p in parts)
    k_max = max(p["nk"] for p in parts)
    k_tab = max(p["etab"].shape[2] for p in parts)
    n_w = n_in + n_nl
    n_tab = n_grid + 1
    st = functools.partial(_stack, parts)
    arrays = dict(
        dims=st("dims", (4,), np.int64), smax=np.array([p["smax"] for p in parts]),
        s2=st("s2", (2, m_max)), lam=st("lam", (2, m_max)), g=st("g", (4, n_w, m_max)),
        bm=st("bm", (2, n_w, m_max)), crow=st("crow", (6, n_rows, m_max)),
        rec=st("rec", (2, n, m_max)), tom=st("tom", (2, n, m_max)),
        tab=st("tab", (n_tab, 6, m_max)), tblk=st("tblk", (k_max, k_max)),
        bblk=st("bblk", (k_max, n_w)), ad=st("ad", (k_max, k_max)),
        bd=st("bd", (2, k_max, n_w)), ckr=st("ckr", (3, n_rows, k_max)),
        recb=st("recb", (n, k_max)), tob=st("tob", (k_max, n)),
        etab=st("etab", (n_tab, 3, k_tab, k_tab)), dw=st("dw", (3, n_rows, n_w)),
        hx=st("hx", (n_nl, n)), hw=st("hw", (n_nl, n_w)), sens=st("sens", (n_rows, n_nl)),
        act=_stack_rows([p["act"] for p in parts], n_rows - 1),
        nact=np.array([p["act"].size for p in parts], dtype=np.int64),
        dact=_stack_rows([p["dact"] for p in parts], n_rows - 1),
        ndact=np.array([p["dact"].size for p in parts], dtype=np.int64),
        kind=kind, par=par, fbit=fbit, cd=cd, cv=cv,
    )
    # one compiled signature: C-contiguous writeable float64/complex128/int64 arrays
    arrays = {k: np.require(v, requirements=["C", "W"]) for k, v in arrays.items()}
    arrays["n_grid"] = n_grid
    return NonlinearSystem(
        dt=dt, n_states=n, n_inputs=n_in, n_outputs=n_out, elements=els,
        paths=tuple(p["path"] for p in parts), conds=tuple(float(p["cond"]) for p in parts),
        _arrays=arrays,
    )


def simulate_nonlinear(A, B, C, D, u, dt: float, elements, *, x0=None,
                       backend: Backend = "auto") -> NonlinearResult:
    """Sampled response of a linear system with nonlinear elements (see the module doc).

    Parameters
    ----------
    A : array_like, shape (n, n)
        State matrix, 1/s.
    B : array_like, shape (n, n_in)
        Input matrix.
    C : array_like, shape (n_out, n)
        Output matrix.
    D : array_like, shape (n_out, n_in), or None
        Feedthrough of ``u``.
    u : array_like, shape (n_in, n_samples)
        Input at ``t_j = j dt``, linear between samples (1-D accepted for one input).
    dt : float
        Sampling interval, s.
    elements : sequence of NonlinearElement
        Nonlinear elements (friction, cubic stiffness, dead band, quadratic damping).
    x0 : array_like, shape (n,), optional
        Initial state; zeros by default.
    backend : {"auto", "numba", "numpy"}
        Engine for the per-sample loop.

    Returns
    -------
    NonlinearResult

    Raises
    ------
    ModelError, ValueError, TypeError, ConvergenceError
        See :func:`prepare_nonlinear` and :meth:`NonlinearSystem.simulate`.

    Notes
    -----
    With no elements, or with zero friction force and zero nonlinear stiffness, the
    result equals :func:`~truthbench.simulate.linear.simulate_lti` to rounding.
    """
    _engine(backend)
    a, b, _, _ = check_system(A, B, C, D)
    check_input(u, b.shape[1])
    check_x0(x0, a.shape[0])
    system = prepare_nonlinear(A, B, C, D, dt, elements)
    return system.simulate(u, x0=x0, backend=backend)
