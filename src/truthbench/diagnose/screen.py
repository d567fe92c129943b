"""Exact screening of point attachments: every point, every strength, one model solution.

A grounded spring ``k``, dashpot ``c`` or lumped mass ``m`` at a point of the beam
changes the dynamic stiffness by a low-rank term ``U z U^T`` (``z = k``, ``j omega c``
or ``-omega^2 m``; the columns of U the point's displacement in each direction it acts
in, as weights on the nodal DOFs: one DOF on a node, the element's shape functions
between nodes, :meth:`~truthbench.plants.base.Plant.point_weights`), so the new FRF
follows from the current one by the Woodbury identity,

    H_new = H - H_oU z (I + z R_UU)^-1 R_Ui,

with the current model's receptances from the point to the outputs (``H_oU``, in the
outputs' quantities), from the inputs to the point (``R_Ui``) and at the point
(``R_UU``), and the correction passed through the measurement chain outside the
structure (filters, gain, delay: :meth:`Hardware.chain_gains`). The receptances of a
point are the weights applied to those of the nodal DOFs, which are computed once. The
chi2 of every point and every strength on a log-spaced grid then costs a few vector
operations: the exact (not first-order) profile of each attachment with the rest of the
model adapted to first order (a Gauss-Newton step of the current fit's parameters),
which a strong spring or dashpot needs (a first-order score from zero misjudges a change
that moves or flattens a peak by more than its width).

:func:`point_profiles` screens candidates at their stations; :func:`position_profile`
searches one attachment's position between nodes; :func:`structural_profiles` screens
the other low-rank structural changes (a joint, friction's equivalent dashpots) the same
way, on a grid of their parameters.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from truthbench.diagnose.candidates import GROUNDING, at_fraction

POINT_EFFECTS = {"grounded_spring": "spring", "grounded_dashpot": "dashpot",
                 "added_mass": "mass"}
"""Effects screened exactly, and the kind of their term."""

GRID = np.logspace(-1, 3, 13)
"""Strengths tried, as multiples of the candidate's natural size (0.1 to 1000)."""

_DIRS = ("x", "y", "z", "rx", "ry", "rz")


def _directions(effect: str, options: dict) -> list[str]:
    """The DOFs a point attachment acts on: its direction, or x, y, z for a mass."""
    return ["x", "y", "z"] if effect == "added_mass" else [options["direction"]]


def _weights(plant, params, position, directions, labels) -> dict[str, np.ndarray]:
    """Model DOF label -> weights (one per direction) of a point, over the model's free
    DOFs (a clamped DOF carries none)."""
    index = {lab: k for k, lab in enumerate(labels)}
    out: dict[str, np.ndarray] = {}
    for j, d in enumerate(directions):
        for dof, w in plant.point_weights(position, d, params):
            lab = f"n{dof // 6}.{_DIRS[dof % 6]}"
            if lab in index:
                out.setdefault(lab, np.zeros(len(directions)))[j] += w
    return out


class _Receptances:
    """The current model's receptances to and from a set of nodal DOFs, per test (the
    pieces of the Woodbury update), and the residual pieces of the current fit."""

    def __init__(self, problem, current, labels: Sequence[str]):
        pred = problem.predictor(current.terms)
        hw = pred.hardware(current.theta)
        model, modes = hw.model, hw.modes
        self.labels = list(labels)
        self.index = {lab: k for k, lab in enumerate(self.labels)}
        E = np.zeros((len(self.labels), model.n_dofs))
        for k, lab in enumerate(self.labels):
            E[k, model.dof_labels.index(lab)] = 1.0
        out_rows = {s: k for k, s in enumerate(pred._sensors)}
        in_cols = {a: k for k, a in enumerate(pred._actuators)}
        n_act = len(pred._actuators)
        disp = ("displacement",) * len(self.labels)
        self.parts = []
        start = 0
        for t in problem.tests:
            f = t.freq_hz
            size = f.size * len(t.sensors) * len(t.actuators)
            shape = (f.size, len(t.sensors), len(t.actuators))
            D = problem.data[start:start + size].reshape(shape)
            M = current.model[start:start + size].reshape(shape)
            W = problem.weights[start:start + size].reshape(shape)
            start += size
            rows = [out_rows[s] for s in t.sensors]
            cols = [in_cols[a] for a in t.actuators]
            kw = dict(modes=modes, decay_rad_s=t.decay_rad_s)
            Hoc = model.with_io(B=E.T).frf(f, **kw)[:, rows]  # (f, o, n)
            Rci = model.with_io(B=model.B[:, :n_act][:, cols], C_out=E,
                                quantities=disp).frf(f, **kw)  # (f, n, i)
            s = 2j * np.pi * f + t.decay_rad_s
            g_out, g_in = hw.chain_gains(f, decay_rad_s=t.decay_rad_s)
            g_out = np.ones((f.size, len(rows))) if g_out is None else g_out[:, rows]
            g_in = np.ones((f.size, len(cols))) if g_in is None else g_in[:, cols]
            self.parts.append((D, M, W, Hoc, Rci, s, g_out[:, :, None] * g_in[:, None, :],
                               f, t.decay_rad_s))
        self.model, self.modes, self.E = model, modes, E
        self._rcc: dict = {}
        Q, R = np.linalg.qr(current.jacobian)
        self.Q, self.R = Q, R
        self.chi2 = current.chi2
        self.deflate = problem.deflate

    def rcc(self, k: int, idx: tuple[int, ...]) -> np.ndarray:
        """Receptances among the DOFs ``idx`` in test ``k``, shape (n_f, n, n) (kept:
        neighbouring points share their nodes)."""
        key = (k, idx)
        if key not in self._rcc:
            f, decay = self.parts[k][7], self.parts[k][8]
            Ei = self.E[list(idx)]
            self._rcc[key] = self.model.with_io(
                B=Ei.T, C_out=Ei, quantities=("displacement",) * len(idx)).frf(
                f, modes=self.modes, decay_rad_s=decay)
        return self._rcc[key]

    def profile(self, weights: dict[str, np.ndarray], kind: str, strengths: np.ndarray,
                per_test: Sequence[float] | None = None) -> tuple[float, float, np.ndarray]:
        """The best chi2 drop over ``strengths`` of an attachment with these weights
        (:func:`_weights`), the current parameters adapted to first order: (drop,
        strength, the parameters' step). ``per_test`` multiplies the strength in each
        test (a friction's equivalent dashpot at each test's level)."""
        Wt = np.array([weights[lab] for lab in weights])  # (n_sub, n_dir)
        unit = {"spring": (1.0, 0.0, 0.0), "dashpot": (0.0, 1.0, 0.0),
                "mass": (0.0, 0.0, 1.0)}[kind]
        eye = np.eye(Wt.shape[1])
        mats = [tuple(u * eye for u in unit)]
        grid = np.asarray(strengths, float)[:, None]
        drop, point, step = self.profile_matrices(list(weights), Wt, mats, grid, per_test)
        return drop, float(point[0]), step

    def profile_matrices(self, labels: Sequence[str], Wt: np.ndarray, mats, grid: np.ndarray,
                         per_test: Sequence[float] | None = None):
        """The best chi2 drop over a grid of a change ``U Z(s) U^T`` of the dynamic
        stiffness, ``Z = sum_j p_j (K_j + s C_j + s^2 M_j)`` (each ``(d, d)``) on the
        coordinates ``U = E' Wt`` (``Wt`` the weights of the nodal DOFs ``labels``, shape
        (n_sub, d)), the current parameters adapted to first order.

        Parameters
        ----------
        labels : sequence of str
        Wt : ndarray, shape (n_sub, d)
        mats : sequence of (K_j, C_j, M_j)
            Per parameter, its stiffness, damping and mass per unit, each (d, d).
        grid : ndarray, shape (G, n_params)
            Parameter values tried.
        per_test : sequence of float, optional
            A factor on Z in each test.

        Returns
        -------
        drop : float
        point : ndarray, shape (n_params,)
        step : ndarray
            The current parameters' first-order step at that point.
        """
        idx = [self.index[lab] for lab in labels]
        grid = np.asarray(grid, float)
        eye = np.eye(Wt.shape[1])
        parts = []
        for k, (D, M, W, Hoc, Rci, s, chain, _, _) in enumerate(self.parts):
            hoc = Hoc[:, :, idx] @ Wt  # (f, o, d)
            rci = Wt.T @ Rci[:, idx, :]  # (f, d, i)
            rcc = Wt.T @ self.rcc(k, tuple(idx)) @ Wt  # (f, d, d)
            unit = np.stack([Kj[None] + s[:, None, None] * Cj[None]
                             + (s * s)[:, None, None] * Mj[None]
                             for Kj, Cj, Mj in mats])  # (n_params, f, d, d)
            factor = 1.0 if per_test is None else per_test[k]
            # every grid point at once: (G, f, d, d)
            Z = (factor * grid) @ unit.reshape(len(unit), -1)
            Z = Z.reshape((len(grid),) + unit.shape[1:])
            X = solve_small(eye + Z @ rcc[None], Z @ rci[None])  # (G, f, d, i)
            Hn = M[None] - chain[None] * (hoc[None] @ X)
            parts.append((W[None] * (D[None] - Hn)).reshape(len(grid), -1))
        z = self.deflate(np.concatenate(parts, axis=1))
        r = np.concatenate([z.real, z.imag], axis=1)  # (G, n)
        qr = r @ self.Q  # (G, p)
        drops = self.chi2 - (np.einsum("gn,gn->g", r, r) - np.einsum("gp,gp->g", qr, qr))
        g = int(np.argmax(drops))
        if not drops[g] > 0:
            return 0.0, grid[0] * 0.0, np.zeros(self.Q.shape[1])
        return float(drops[g]), np.array(grid[g], float), np.linalg.solve(self.R, qr[g])


def solve_small(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """``np.linalg.solve(A, B)`` for stacks of small systems, ``A`` (..., d, d) and ``B``
    (..., d, k): by division for d = 1 and by Cramer's rule for d = 2, tens of times
    faster than LAPACK called once per system (tens of thousands of systems: grid points
    times lines); LAPACK for larger d, or where a determinant vanishes (which it then
    reports)."""
    d = A.shape[-1]
    if d > 2:
        return np.linalg.solve(A, B)
    with np.errstate(divide="ignore", invalid="ignore"):
        if d == 1:
            X = B / A
        else:
            a, b = A[..., 0, 0, None], A[..., 0, 1, None]
            c, e = A[..., 1, 0, None], A[..., 1, 1, None]
            det = a * e - b * c
            X = np.stack([(e * B[..., 0, :] - b * B[..., 1, :]) / det,
                          (a * B[..., 1, :] - c * B[..., 0, :]) / det], axis=-2)
    if not np.all(np.isfinite(X)):
        return np.linalg.solve(A, B)
    return X


def _ready(problem, current):
    """The current hardware, or None when an attachment is not a low-rank change of the
    shared FRF (per-test channels, closed loops)."""
    pred = problem.predictor(current.terms)
    if pred._per_test:  # an effect tied to each test's channels: no shared model
        return None
    hw = pred.hardware(current.theta)
    if hw.loops:  # a closed loop: the attachment is not a low-rank change of the FRF
        return None
    return hw


def point_profiles(problem, current, candidates, sizes: dict) -> dict:
    """The best chi2 drop and strength of every point candidate.

    Parameters
    ----------
    problem : Problem
    current : Fit
        The current model (its terms and parameters held).
    candidates : sequence of Candidate
        Point candidates (:data:`POINT_EFFECTS`); others are ignored.
    sizes : dict
        Candidate key -> natural size of its parameter.

    Returns
    -------
    dict
        Candidate label -> (drop, strength, declared step): the best chi2 drop over the
        grid with the current fit's parameters adapted to first order (their
        Gauss-Newton step from the current Jacobian), the strength, and that step
        (per unit of each current parameter).
    """
    cands = [c for c in candidates if c.effect in POINT_EFFECTS]
    if not cands:
        return {}
    hw = _ready(problem, current)
    if hw is None:
        return {}
    plant, params = hw.plant, hw.parameters
    labels = hw.model.dof_labels
    weights = {c.label: _weights(plant, params, c.options["station"],
                                 _directions(c.effect, c.options), labels) for c in cands}
    rec = _Receptances(problem, current, sorted({lab for w in weights.values() for lab in w}))
    results = {}
    for c in cands:
        if not weights[c.label]:
            continue
        size = sizes[c.keys()[0]]
        drop, strength, step = rec.profile(weights[c.label], POINT_EFFECTS[c.effect],
                                           GRID * size)
        results[c.label] = (drop, strength, step)
    return results


def beside_best(candidates, drops: dict, plant, share: float = 0.1) -> list:
    """Point candidates at the midpoints of the elements either side of every node whose
    screen (``drops``: label -> (drop, ...) of :func:`point_profiles`) is within
    ``share`` of the best of its effect and direction.

    A point attachment's exact profile falls to a half within about a quarter of an
    element of where it is, so one between two nodes can screen below an attachment at
    a node far from it that mimics it poorly (a 20 g mass a third of the way between two
    nodes screened at half of a node elsewhere, and refitted at either neighbour into a
    local minimum of a few grams). Grounded attachments stay at the declared supports
    (``[plant] supports``).
    """
    n = plant.n_elements
    nodal = [c for c in candidates if c.effect in POINT_EFFECTS and c.label in drops
             and c.node is not None and c.options.get("station") == f"n{c.node}"
             and not (c.effect in GROUNDING and getattr(plant, "supports", None))]
    best: dict = {}
    for c in nodal:
        key = (c.effect, c.options.get("direction"))
        best[key] = max(best.get(key, 0.0), drops[c.label][0])
    out = {}
    for c in nodal:
        if not drops[c.label][0] >= share * best[(c.effect, c.options.get("direction"))] > 0:
            continue
        for half in (-0.5, 0.5):
            if 0 <= c.node + half <= n:
                m = at_fraction(c, (c.node + half) / n, n)
                out.setdefault(m.label, m)
    return list(out.values())


AFFINE_EFFECTS = {"joint": (np.array([0.02, 0.05, 0.1, 0.2, 0.3, 0.45, 0.6, 0.75, 0.9]),
                             np.array([0.0, 0.3, 1.0, 3.0, 10.0, 30.0]))}
"""Structural effects whose matrices change affinely in their fitted parameters, screened
exactly like the point attachments (:func:`structural_profiles`, one parameter after
the other), with the grid of each parameter: absolute values for the first (a joint's
stiffness loss), multiples of its natural size for the others (the joint's damping)."""


def structural_profiles(problem, current, candidates, sizes: dict) -> dict:
    """The best chi2 drop of every affine structural candidate (:data:`AFFINE_EFFECTS`)
    and of every friction candidate, on a grid of its parameters, as
    :func:`point_profiles` (the same return form; the guess is the grid point).

    A candidate's change of M, C and K per unit of each parameter is taken from the
    model built with it (exact for an affine effect: a joint scales its element's
    stiffness by ``1 - loss`` and adds a dashpot across it) and restricted to the DOFs
    the channels are coupled to; friction is a grounded dashpot whose value in each test
    is the friction force times that test's level coefficient.
    """
    cands = [c for c in candidates
             if c.effect in AFFINE_EFFECTS or (c.effect == "coulomb_friction" and c.levels)]
    if not cands:
        return {}
    hw = _ready(problem, current)
    if hw is None:
        return {}
    model, modes = hw.model, hw.modes
    labels = model.dof_labels
    active = np.any(modes.shapes != 0, axis=1)
    plans = {}
    for c in cands:
        if c.effect == "coulomb_friction":
            w = _weights(hw.plant, hw.parameters, c.options["station"],
                         [c.options["direction"]], labels)
            if w:
                levels = dict(c.levels)
                plans[c.label] = (list(w), np.array([w[lab] for lab in w]),
                                  [(np.zeros((1, 1)), np.eye(1), np.zeros((1, 1)))],
                                  (GRID * sizes[c.keys()[0]])[:, None],
                                  [levels.get(t.name, 0.0) for t in problem.tests])
            continue
        pred = problem.predictor(current.terms + c.terms())
        grids, deltas = [], []
        for j, p in enumerate(c.fitted):
            values, scaled = AFFINE_EFFECTS[c.effect][0 if j == 0 else 1], j > 0
            a = sizes[c.keys()[j]] if scaled else 0.5
            theta = {**current.theta, c.keys()[j]: p.start + a}
            m = pred.hardware(theta).model
            deltas.append(tuple((getattr(m, x) - getattr(model, x)) / a for x in "KCM"))
            grids.append(values * sizes[c.keys()[j]] if scaled else values)
        touched = set()
        for d in deltas:
            for x in d:
                touched.update(np.unique(x.nonzero()[0]).tolist())
        sub = sorted(i for i in touched if active[i])
        if not sub:
            continue
        mats = [tuple(x[sub][:, sub].toarray() for x in d) for d in deltas]
        plans[c.label] = ([labels[i] for i in sub], np.eye(len(sub)), mats, grids, None)
    if not plans:
        return {}
    rec = _Receptances(problem, current, sorted({lab for p in plans.values() for lab in p[0]}))
    out = {}
    for label, (labs, Wt, mats, grids, per_test) in plans.items():
        if isinstance(grids, np.ndarray):
            out[label] = rec.profile_matrices(labs, Wt, mats, grids, per_test)
            continue
        # one parameter at a time from the start (the others at 0), each at the best of
        # those before: a coordinate search over the grid
        point = np.zeros(len(grids))
        best = (0.0, point.copy(), np.zeros(rec.Q.shape[1]))
        for j, values in enumerate(grids):
            trial = np.repeat(point[None], len(values), axis=0)
            trial[:, j] = values
            found = rec.profile_matrices(labs, Wt, mats, trial, per_test)
            if found[0] > best[0]:
                best = found
                point = found[1].copy()
        out[label] = best
    return out


def position_profile(problem, current, candidate, fractions: Sequence[float],
                     strengths: np.ndarray) -> list[tuple[float, float, float, np.ndarray]]:
    """A point attachment's exact chi2 profile along the beam: for each fraction of the
    element count, the best drop over ``strengths``.

    Parameters
    ----------
    problem : Problem
    current : Fit
        The model without the attachment.
    candidate : Candidate
        The attachment (its effect and direction; its station is not used).
    fractions : sequence of float
        Points along the beam, fractions of the element count in [0, 1].
    strengths : ndarray
        Strengths tried (the parameter's unit).

    Returns
    -------
    list of (fraction, drop, strength, declared step)
        Empty when the model is not a shared low-rank case (:func:`point_profiles`).
    """
    hw = _ready(problem, current)
    if hw is None or candidate.effect not in POINT_EFFECTS:
        return []
    labels = hw.model.dof_labels
    dirs = _directions(candidate.effect, candidate.options)
    weights = [_weights(hw.plant, hw.parameters, float(fr), dirs, labels)
               for fr in fractions]
    rec = _Receptances(problem, current, sorted({lab for w in weights for lab in w}))
    out = []
    for fr, w in zip(fractions, weights, strict=True):
        if w:
            drop, strength, step = rec.profile(w, POINT_EFFECTS[candidate.effect], strengths)
            out.append((float(fr), drop, strength, step))
    return out


__all__ = ["AFFINE_EFFECTS", "GRID", "POINT_EFFECTS", "beside_best", "point_profiles",
           "position_profile", "structural_profiles"]
