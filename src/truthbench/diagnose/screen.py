"""Exact screening of point attachments: every node, every strength, one model solution.

A grounded spring ``k``, dashpot ``c`` or lumped mass ``m`` at a node changes the
dynamic stiffness by a low-rank term ``U z U^T`` (``z = k``, ``j omega c`` or ``-omega^2
m``; U the node's DOF(s)), so the new FRF follows from the current one by the Woodbury
identity,

    H_new = H - H_oc z (I + z R_cc)^-1 R_ci,

with the current model's receptances from the node to the outputs (``H_oc``, in the
outputs' quantities), from the inputs to the node (``R_ci``) and at the node (``R_cc``),
and the correction passed through the measurement chain outside the structure (filters,
gain, delay: :meth:`Hardware.chain_gains`). With these computed once, the chi2 of every
node and every strength on a log-spaced grid costs a few vector operations: the exact
(not first-order) profile of each attachment with the rest of the model adapted to first
order (a Gauss-Newton step of the current fit's parameters), which a strong spring or
dashpot needs (a first-order score from zero misjudges a change that moves or flattens a
peak by more than its width)."""

from __future__ import annotations

import numpy as np

POINT_EFFECTS = {"grounded_spring": "spring", "grounded_dashpot": "dashpot",
                 "added_mass": "mass"}
"""Effects screened exactly, and the kind of their term."""

GRID = np.logspace(-1, 3, 13)
"""Strengths tried, as multiples of the candidate's natural size (0.1 to 1000)."""


def _unit_rows(dof_labels, labels):
    E = np.zeros((len(labels), len(dof_labels)))
    for k, lab in enumerate(labels):
        if lab in dof_labels:
            E[k, dof_labels.index(lab)] = 1.0
    return E


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
    pred = problem.predictor(current.terms)
    if pred._per_test:  # an effect tied to each test's channels: no shared model
        return {}
    hw = pred.hardware(current.theta)
    if hw.loops:  # a closed loop: the attachment is not a low-rank change of the FRF
        return {}
    model, modes = hw.model, hw.modes
    labels = model.dof_labels
    nodes = sorted({c.node for c in cands})
    # the DOFs a candidate touches: the direction of a spring or dashpot, x y z of a mass
    dofs = {}
    for c in cands:
        d = [c.options["direction"]] if c.effect != "added_mass" else ["x", "y", "z"]
        dofs[c.label] = [f"n{c.node}.{x}" for x in d if f"n{c.node}.{x}" in labels]
    all_dofs = sorted({lab for v in dofs.values() for lab in v})
    E = _unit_rows(labels, all_dofs)
    col = {lab: k for k, lab in enumerate(all_dofs)}
    out_rows = {s: k for k, s in enumerate(pred._sensors)}
    in_cols = {a: k for k, a in enumerate(pred._actuators)}
    n_act = len(pred._actuators)
    data_model = current.model
    # residual pieces per candidate and strength, weighted, stacked later against the
    # current fit's Jacobian: the declared parameters co-adapt to first order
    resid = {c.label: [[] for _ in GRID] for c in cands}
    start = 0
    for t in problem.tests:
        f = t.freq_hz
        size = f.size * len(t.sensors) * len(t.actuators)
        D = problem.data[start:start + size].reshape(f.size, len(t.sensors), len(t.actuators))
        M = data_model[start:start + size].reshape(D.shape)
        W = problem.weights[start:start + size].reshape(D.shape)
        start += size
        rows = [out_rows[s] for s in t.sensors]
        cols = [in_cols[a] for a in t.actuators]
        kw = dict(modes=modes, decay_rad_s=t.decay_rad_s)
        # outputs <- candidate DOFs (output quantities), candidate DOFs <- inputs, DOF block
        Hoc = model.with_io(B=E.T).frf(f, **kw)[:, rows]
        disp = ("displacement",) * len(all_dofs)
        Rci = model.with_io(B=model.B[:, :n_act][:, cols], C_out=E, quantities=disp
                            ).frf(f, **kw)
        s = 2j * np.pi * f + t.decay_rad_s
        # the measurement chain outside the structure (filters, gain, delay)
        g_out, g_in = hw.chain_gains(f, decay_rad_s=t.decay_rad_s)
        g_out = np.ones((f.size, len(rows))) if g_out is None else g_out[:, rows]
        g_in = np.ones((f.size, len(cols))) if g_in is None else g_in[:, cols]
        chain = g_out[:, :, None] * g_in[:, None, :]
        for node in nodes:
            mine = [c for c in cands if c.node == node]
            touched = sorted({lab for c in mine for lab in dofs[c.label]})
            if not touched:
                continue
            idx = [col[lab] for lab in touched]
            En = E[idx]
            Rcc = model.with_io(B=En.T, C_out=En, quantities=disp[:len(idx)]).frf(f, **kw)
            for c in mine:
                sub = [touched.index(lab) for lab in dofs[c.label]]
                if not sub:
                    continue
                hoc = Hoc[:, :, [idx[k] for k in sub]]
                rci = Rci[:, [idx[k] for k in sub], :]
                rcc = Rcc[:, sub][:, :, sub]
                size_c = sizes[c.keys()[0]]
                kind = POINT_EFFECTS[c.effect]
                factor = {"spring": np.ones_like(s), "dashpot": s, "mass": s * s}[kind]
                eye = np.eye(len(sub))
                for g, mult in enumerate(GRID):
                    z = (mult * size_c) * factor  # (n_f,)
                    # (I + z R_cc)^-1 R_ci, per line
                    X = np.linalg.solve(eye[None] + z[:, None, None] * rcc, rci)
                    Hn = M - (z[:, None, None] * chain) * np.einsum("fok,fki->foi", hoc, X)
                    resid[c.label][g].append((W * (D - Hn)).ravel())
    Q, R = np.linalg.qr(current.jacobian)
    results = {}
    for c in cands:
        best = (0.0, 0.0, np.zeros(Q.shape[1]))
        for g, parts in enumerate(resid[c.label]):
            if not parts:
                continue
            z = np.concatenate(parts)
            r = np.concatenate([z.real, z.imag])
            qr = Q.T @ r
            drop = current.chi2 - (r @ r - qr @ qr)
            if drop > best[0]:
                best = (float(drop), float(GRID[g] * sizes[c.keys()[0]]),
                        np.linalg.solve(R, qr))
        results[c.label] = best
    return results


__all__ = ["GRID", "POINT_EFFECTS", "point_profiles"]
