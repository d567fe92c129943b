"""Can the model resolve the data? The checks made before any effect is tried.

A residual that the model's own form leaves (a mesh too coarse for the band, a mode
the model cannot show at these channels) must not be reported as a physical effect the
model lacks. Two checks run on the baseline fit:

**Mesh.** The model is predicted at its mesh h and at h/2 (every element halved: the
measured points stay on nodes), at the baseline's parameters. The part of the
difference the declared parameters cannot absorb (the difference projected off the
baseline's weighted Jacobian) is measured in units of the data's noise,
``change = (|r|^2 - |Q' r|^2) / s2`` with ``r = w (H_{h/2} - H_h)`` and ``J = Q R``,
``s2`` the noise variance per real value of the weighted data (1 for weights from
coherence, else the roughness estimate of :func:`noise_variance`). It bounds the chi2
drop any candidate could gain by mimicking the discretisation error (the error of h
is 16/15 of the h to h/2 change for the cubic beam element's h^4 convergence). Where it
exceeds the tolerance (``mesh_tolerance``, 5 noise units, half the selection
threshold; or :data:`MESH_SHARE` of the residual's excess over the noise where that is
larger), the mesh is refined and checked again, up to a limit; beyond the limit the
diagnosis says the mesh is too coarse, with the figures.

**Modes the model lacks.** The baseline's residual is scanned for a mode: the pole
(frequency and damping on a grid, and 0 Hz: a rigid-body motion whose trace in the band
is its mass line, a roll read by sensors off the axis) that, added with a free complex
residue in every transfer function, explains most of it (the residues are linear, so the
scan is a few matrix products). It is a mode the model lacks when it is significant by
the selection's criterion (with its pole's and residues' parameters counted), and either
lies nearer a model mode the channels cannot see (torsion or lateral bending read by
bending channels: the sensors' offsets and cross-axis sensitivity show it in the data)
than any they see, which names it, or lies off the modes they see and is not one of them
moved (refitting the own pole of the nearest, below and above, beside it adds little).
It is reported with its frequency, damping and the channels that see it, and it is
modelled in the comparison with a free residue in every transfer function
(:class:`~.fit.ExtraModes`); the search repeats on what is left. No effect is fitted to it.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from truthbench.diagnose.data import MeasuredTest
from truthbench.diagnose.fit import _POWERS, Fit, Problem, mode_basis, stack

MESH_TOLERANCE = 5.0
"""Largest change (noise units of chi2) of the model's FRFs from its mesh to the mesh
halved, beyond what the declared parameters absorb, for the mesh to be adequate: half
the default selection threshold (10)."""

MESH_SHARE = 0.01
"""Where the model's error dwarfs the noise (one impact, no averages: the residual is
thousands of noise variances), the mesh is adequate when halving it changes the model by
less than this share of the residual's excess over the noise: a discretisation error that
small cannot be what a candidate takes up (it must explain a quarter of the excess), and
noise units alone would refine the mesh without end."""

MAX_REFINEMENT = 8
"""The mesh is refined (halved) up to this many times its element count."""

MAX_MISSING = 3
"""Modes the model lacks searched for, one after the other."""


@dataclass(frozen=True)
class MeshCheck:
    """The mesh check: every mesh compared with its half, in order.

    Attributes
    ----------
    n_elements : tuple of int
        The meshes compared (element counts along the beam), coarsest first.
    change : tuple of float
        For each, the chi2 (noise units) of the change to its half that the declared
        parameters cannot absorb.
    tolerance : float
        The largest change allowed, noise units: ``mesh_tolerance``, or
        :data:`MESH_SHARE` of the residual's excess over the noise when that is larger
        (at the mesh used).
    adequate : bool
        Whether the mesh used passed (False: the limit was reached first).
    noise_variance : float
        The noise variance per real weighted value the change was measured against.
    """

    n_elements: tuple[int, ...]
    change: tuple[float, ...]
    tolerance: float
    adequate: bool
    noise_variance: float

    @property
    def used(self) -> int:
        """Element count of the mesh the diagnosis used."""
        return self.n_elements[-1]

    @property
    def refined(self) -> bool:
        return len(self.n_elements) > 1

    def summary(self) -> str:
        steps = "; ".join(f"{n} elements: {c:.3g}" for n, c in
                          zip(self.n_elements, self.change, strict=True))
        if not self.refined and self.adequate:
            verdict = f"adequate: the model's {self.used}-element mesh"
        elif self.adequate:
            verdict = (f"refined from {self.n_elements[0]} to {self.used} elements: the "
                       f"coarser mesh's discretisation error was visible in these data")
        else:
            verdict = (f"too coarse even at {self.used} elements (the refinement limit): "
                       f"part of the residual is discretisation error")
        return (f"{verdict} (change to the mesh halved, beyond what the declared "
                f"parameters absorb, in noise units of chi2, tolerance "
                f"{self.tolerance:.3g}: {steps})")


@dataclass(frozen=True)
class MissingMode:
    """A mode in the data that the model cannot show at these channels.

    Attributes
    ----------
    freq_hz : float
    damping_ratio : float
    tests : tuple of str
        The tests whose data show it.
    channels : tuple of str
        The output channels whose residual over its band stands above the noise.
    band_hz : (float, float)
        Its band, five half-power half-widths either side (shaded in the figures); it is
        modelled in the comparison with free residues.
    excess_chi2 : float
        The chi2 the mode explains, in noise units.
    model_mode : str or None
        A model mode near it that the channels do not see, e.g. ``"torsion, 1 node at
        861.2 Hz"`` (None: the model has no mode there).
    """

    freq_hz: float
    damping_ratio: float
    tests: tuple[str, ...]
    channels: tuple[str, ...]
    band_hz: tuple[float, float]
    excess_chi2: float
    model_mode: str | None

    def summary(self) -> str:
        near = (f"the model has a mode there its channels do not see ({self.model_mode})"
                if self.model_mode else "the model has no mode near it")
        if self.freq_hz == 0.0:
            what = self.model_mode or "a motion of none of the model's rigid-body modes"
            return (f"a rigid-body motion that the model's channels do not see ({what}; at "
                    f"0 Hz, its mass line in the band): seen by "
                    f"{', '.join(self.channels) or '-'}; modelled in the comparison with "
                    f"free residues")
        return (f"a mode at {self.freq_hz:.5g} Hz (damping {100 * self.damping_ratio:.3g} %) "
                f"that the model lacks at these channels: {near}; seen by "
                f"{', '.join(self.channels) or '-'}; modelled in the comparison with free residues")


def noise_variance(tests: Sequence[MeasuredTest]) -> float:
    """Noise variance per real value of the weighted data ``H / sigma``.

    1 when every test's weights come from its coherence (``sigma`` is then the noise).
    Otherwise (relative weights, known only up to a scale) the data's roughness: the
    second difference of three adjacent lines ``z_k+1 - 2 z_k + z_k-1`` of the weighted
    data cancels a response that is smooth over three lines and has six times the
    noise's variance, and its squared magnitude is exponentially distributed for
    complex Gaussian noise, so the variance per real value is ``median |d2|^2 / (12 ln
    2)`` (the median ignores the few lines at sharp peaks where the response is not
    smooth). Correlated lines (a windowed estimate) make this an underestimate, which
    errs towards refining the mesh and naming a missing mode."""
    if all(t.noise == "coherence" for t in tests):
        return 1.0
    parts = []
    for t in tests:
        if t.H.shape[0] < 3:
            continue
        z = (t.H / t.sigma).reshape(t.H.shape[0], -1)
        df = np.diff(t.freq_hz)
        even = np.isclose(df[1:], df[:-1], rtol=1e-6)
        d2 = (z[2:] - 2 * z[1:-1] + z[:-2])[even]
        parts.append(np.abs(d2.ravel()) ** 2)
    if not parts:
        return 1.0
    all_ = np.concatenate(parts)
    return float(max(np.median(all_) / (12 * np.log(2)), 1e-300))


def unexplained_change(problem: Problem, current: Fit, other: np.ndarray) -> float:
    """chi2 of ``other - current.model`` (weighted, stacked) off the span of the current
    fit's Jacobian: what refitting the current parameters cannot take up."""
    r = stack(problem.weights * (other - current.model))
    if current.jacobian.size == 0:
        return float(r @ r)
    Q, _ = np.linalg.qr(current.jacobian)
    q = Q.T @ r
    return float(max(r @ r - q @ q, 0.0))


def refined_plant(plant, factor: int = 2):
    """The plant with every element split in ``factor`` and its stations kept, with the
    stations named after nodes (``n<k>``) renamed to the same point's new node. Supports
    placed at the node nearest a default fraction (the free-free beam's suspension) are
    pinned to the nodes they had: refining the mesh must not move them.

    Returns
    -------
    plant : Plant
    renamed : dict
        Old station name -> new, for the ``n<k>`` stations.
    """
    renamed = {}
    stations = {}
    for name, fr in plant.stations.items():
        if name.startswith("n") and name[1:].isdigit():
            new = f"n{int(name[1:]) * factor}"
            renamed[name] = new
            stations[new] = fr
        else:
            stations[name] = fr
    changes = {"n_elements": plant.n_elements * factor, "stations": stations}
    if hasattr(plant, "suspension_fractions") and plant.suspension_fractions is None:
        changes["suspension_fractions"] = tuple(k / plant.n_elements
                                                for k in plant.suspension_nodes())
    return replace(plant, **changes), renamed


def renamed_tests(tests: Sequence[MeasuredTest], renamed: dict) -> tuple[MeasuredTest, ...]:
    """The tests with their channels' stations renamed (:func:`refined_plant`)."""
    def one(t: MeasuredTest) -> MeasuredTest:
        return replace(t, actuators=tuple(replace(a, station=renamed.get(a.station, a.station))
                                          for a in t.actuators),
                       sensors=tuple(replace(s, station=renamed.get(s.station, s.station))
                                     for s in t.sensors))
    return tuple(one(t) for t in tests)


ZETAS = (0.001, 0.002, 0.005, 0.01, 0.02, 0.05)
"""Damping ratios a mode the model lacks is scanned with."""


def _pieces(problem: Problem, current: Fit):
    """Per test: its slice of the weighted residual, weights (each (n_f, n_out, n_in))
    and its lines."""
    out, start = [], 0
    for t in problem.tests:
        shape = (t.freq_hz.size, len(t.sensors), len(t.actuators))
        size = int(np.prod(shape))
        W = problem.weights[start:start + size].reshape(shape)
        r = W * (problem.data[start:start + size] - current.model[start:start + size]
                 ).reshape(shape)
        out.append((t, r, W))
        start += size
    return out


def scan_extra_mode(problem: Problem, current: Fit, candidates_hz: np.ndarray):
    """The single mode that, added to the model with free complex residues in every
    transfer function, lowers the chi2 most: its frequency (one of ``candidates_hz``),
    damping ratio (one of :data:`ZETAS`), the drop, and the drop per output.

    The residues are linear: for a trial pole, each transfer function's residue is the
    least-squares projection of the weighted residual on the pole's weighted basis
    ``s^p / (s^2 + 2 zeta w s + w^2)``, and its chi2 drop ``|<b, r>|^2 / <b, b>``; a
    scan over a grid of poles costs a few matrix products.

    Returns
    -------
    (freq_hz, zeta, drop, drop per output of the first test) or None
    """
    best = None
    pieces = _pieces(problem, current)
    w = 2 * np.pi * np.asarray(candidates_hz, float)
    # the pole's denominator s^2 + 2 zeta w s + w^2 = re + j im, in real arithmetic
    # (s = sigma + j omega), once per test: with b = W s^p / (re + j im), <b, r> =
    # sum conj(s^p) (re + j im) / |.|^2 W r, and <b, b> = sum |s^p|^2 / |.|^2 W^2
    lines = []
    for t, _, _ in pieces:
        s = 2j * np.pi * t.freq_hz + t.decay_rad_s
        lines.append((s, (s.real ** 2 - s.imag ** 2)[:, None] + (w * w)[None, :]))
    for zeta in ZETAS:
        total = np.zeros(candidates_hz.size)
        per_out = None
        for k, ((t, r, W), (s, re0)) in enumerate(zip(pieces, lines, strict=True)):
            re = re0 + (2 * zeta * s.real)[:, None] * w[None, :]
            im = (2 * s.imag)[:, None] * (s.real[:, None] + zeta * w[None, :])
            inv = 1.0 / (re * re + im * im)  # (n_f, n_cand)
            conj_g = np.empty(re.shape, complex)
            conj_g.real, conj_g.imag = re * inv, im * inv
            drops = np.zeros((candidates_hz.size, len(t.sensors)))
            for p in {_POWERS[x.quantity] for x in t.sensors}:
                rows = [o for o, x in enumerate(t.sensors) if _POWERS[x.quantity] == p]
                sp = (s ** p)[:, None, None]
                # every transfer function of this power at once
                num = conj_g.T @ (sp.conj() * W[:, rows] * r[:, rows]).reshape(s.size, -1)
                den = inv.T @ (np.abs(sp) ** 2 * W[:, rows] ** 2).reshape(s.size, -1)
                d = np.abs(num) ** 2 / np.maximum(den, 1e-300)
                drops[:, rows] = d.reshape(-1, len(rows), W.shape[2]).sum(axis=2)
            total += drops.sum(axis=1)
            if k == 0:
                per_out = drops
        e = int(np.argmax(total))
        if best is None or total[e] > best[2]:
            best = (float(candidates_hz[e]), zeta, float(total[e]), per_out[e])
    return best


def _shift_drop(problem: Problem, current: Fit, f_e: float, zeta_e: float, f_m: float,
                zeta_m: float) -> tuple[float, float]:
    """chi2 drops of the extra mode alone, and with the model's own mode at ``f_m``
    refitted beside it (free residues for both poles): a model mode moved by an effect
    leaves a residual that needs both (its old pole taken out, the new put in), a mode the
    model lacks needs only the new one."""
    alone = both = 0.0
    for t, r, W in _pieces(problem, current):
        s = 2j * np.pi * t.freq_hz + t.decay_rad_s
        for o, x in enumerate(t.sensors):
            ge = mode_basis(s, f_e, zeta_e, _POWERS[x.quantity])[:, 0]
            gm = mode_basis(s, f_m, zeta_m, _POWERS[x.quantity])[:, 0]
            for i in range(len(t.actuators)):
                y = r[:, o, i]
                A1 = (W[:, o, i] * ge)[:, None]
                A2 = np.column_stack([W[:, o, i] * ge, W[:, o, i] * gm])
                for A, acc in ((A1, "alone"), (A2, "both")):
                    c, *_ = np.linalg.lstsq(A, y, rcond=None)
                    fitted = A @ c
                    drop = float(2 * np.real(np.vdot(fitted, y)) - np.vdot(fitted, fitted).real)
                    if acc == "alone":
                        alone += drop
                    else:
                        both += drop
    return alone, both


def _hidden_rigid_motions(model) -> str:
    """The rigid-body motions of the model that nothing restrains and its channels do
    not see (``"rotation about x or translation y"``), or ''."""
    from truthbench.model import RIGID_MOTIONS, rigid_body_motions

    R = rigid_body_motions(model)
    if R is None:
        return ""
    scale_k = max(float(abs(model.K).max()), 1e-300)
    scale_c = max(float(np.abs(model.C_out).max()), 1e-300)
    names = []
    for k, motion in enumerate(RIGID_MOTIONS):
        r = R[:, k]
        if not np.any(r):
            continue
        free = np.abs(model.K @ r).max() <= 1e-9 * scale_k * np.abs(r).max()
        unseen = np.abs(model.C_out @ r).max() <= 1e-9 * scale_c * np.abs(r).max()
        if free and unseen:
            names.append(f"rigid-body {motion}")
    return " or ".join(names)


def _modes_by_visibility(model):
    """The modes of the blocks of DOFs the channels are coupled to, and those of the
    other blocks (which no channel of the model can see: torsion and the other plane of
    bending for a beam read in one plane). Solved block by block, so a degenerate pair
    of bending modes in two planes (a round tube) is never mixed."""
    from truthbench.model import Modes, coupled_blocks, solve_block_modes

    C = model.C if model.C.nnz else None
    dofs = np.flatnonzero(np.any(model.B != 0, axis=1) | np.any(model.C_out != 0, axis=0))
    blocks = coupled_blocks(*((model.M, model.K) if C is None else (model.M, model.K, C)))
    touched = [b for b in blocks if np.intersect1d(b, dofs).size]
    rest = np.setdiff1d(np.arange(model.n_dofs),
                        np.concatenate(touched) if touched else np.zeros(0, int))
    seen = solve_block_modes(model.M, model.K, dofs, C)
    hidden = solve_block_modes(model.M, model.K, rest, C) if rest.size else Modes(
        np.zeros(0), np.zeros((model.n_dofs, 0)), np.zeros(0, dtype=bool))
    return seen, hidden


def missing_modes(tests: Sequence[MeasuredTest], problem: Problem, current: Fit,
                  noise: float, n_independent: float, threshold: float, *,
                  guided: bool = True, known: Sequence[float] = ()
                  ) -> MissingMode | None:
    """The strongest mode in the data that the model cannot show at these channels, or
    None (module notes).

    The baseline's residual is scanned for the one pole (:func:`scan_extra_mode`) that
    explains most of it with free residues. It is a mode the model lacks when it is
    significant (delta BIC above ``threshold`` with two parameters for the pole and two
    per transfer function for the residues), and

    * it is nearer (by a factor 1.5, and within 10 %) a model mode that the channels
      cannot see (a block of DOFs not coupled to them: torsion or lateral bending read
      by bending channels) than any mode they see: that mode, named; or
    * it lies more than a few half-power widths from every mode the channels see (on
      one, that mode changed: a filter, a gain), and is not a mode the channels see
      moved there: for the nearest below and above (within a factor 2.5), refitting that
      mode's own pole beside it gains less than half of what the new pole gains
      (:func:`_shift_drop`).

    Parameters
    ----------
    tests : sequence of MeasuredTest
    problem : Problem
    current : Fit
        The baseline.
    noise : float
        Noise variance per real weighted value (:func:`noise_variance`).
    n_independent : float
        Independent real values (the criterion's n).
    threshold : float
        The delta BIC a finding must exceed.
    guided : bool
        Look first where each mode the channels cannot see would show (safe once the
        effects the data carry are in the model: before, their residual is everywhere).
    known : sequence of float
        Frequencies (Hz) of the modes already found: not found again (within 3 %).

    Returns
    -------
    MissingMode or None
    """
    from truthbench.model import modal_damping_matrix, modal_table

    lo = max(float(t.freq_hz.min()) for t in tests)
    hi = min(float(t.freq_hz.max()) for t in tests)
    df = min(float(np.median(np.diff(t.freq_hz))) for t in tests if t.freq_hz.size > 1)
    # 0 Hz: a rigid-body motion the channels see but the model's channels do not (a roll
    # read by sensors off the axis), whose only trace in the band is its mass line
    grid = np.concatenate([[0.0], np.arange(lo, hi + 0.5 * df, df)])
    pairs = sum(len(t.sensors) * len(t.actuators) for t in problem.tests)
    k = 2 + 2 * pairs
    n = n_independent

    def significant(found) -> bool:
        return found is not None and current.chi2 - found[2] > 0 and \
            n * np.log(current.chi2 / (current.chi2 - found[2])) - k * np.log(n) > threshold

    t0 = problem.tests[0]
    hw = problem.predictor(current.terms).hardware(current.theta, t0.actuators, t0.sensors,
                                                   test=t0.name)
    model = hw.model
    seen, hidden = _modes_by_visibility(model)
    f_seen = np.where(seen.rigid, np.nan, seen.freq_hz) if seen.n_modes else np.zeros(0)
    # first the modes the model has and its channels cannot see, each looked for where
    # the data would show it (nearer it than any mode the channels see): a residual
    # scan alone would take a broad pole between it and a neighbour the effects moved
    known = np.asarray(known, float)

    def new(f: float) -> bool:
        return not np.any(np.abs(known - f) <= 0.03 * max(f, 1e-12))

    picked = None
    hid = np.flatnonzero(~hidden.rigid & (hidden.freq_hz >= lo) & (hidden.freq_hz <= hi)) \
        if guided else np.zeros(0, int)
    for r in hid:
        f_h = float(hidden.freq_hz[r])
        if not new(f_h):
            continue
        to_seen = np.nanmin(np.abs(grid[:, None] - f_seen[None, :]), axis=1,
                            initial=np.inf) if f_seen.size else np.full(grid.size, np.inf)
        window = grid[(grid > 0) & (np.abs(grid - f_h) < to_seen / 1.5)
                      & (np.abs(grid / f_h - 1) <= 0.1)]
        if window.size:
            found = scan_extra_mode(problem, current, window)
            if found is not None and (picked is None or found[2] > picked[0][2]):
                picked = (found, r)
    if picked is not None and significant(picked[0]) and _resolved(picked[0], lo, hi, df):
        (f_e, zeta_e, drop, per_out), r = picked
        row = min(modal_table(model, hidden),
                  key=lambda x: abs(x["freq_hz"] - hidden.freq_hz[r]))
        return _missing(tests, t0, f_e, zeta_e, drop, per_out, noise, df,
                        f"{row['shape']} at {row['freq_hz']:.5g} Hz")
    found = scan_extra_mode(problem, current, grid)
    if not significant(found) or not new(found[0]) or not _resolved(found, lo, hi, df):
        return None
    f_e, zeta_e, drop, per_out = found
    name = None
    if f_e == 0.0:
        name = _hidden_rigid_motions(model) or None
    else:
        f_hid = np.where(hidden.rigid, np.nan, hidden.freq_hz) if hidden.n_modes \
            else np.zeros(0)
        d_seen = np.nanmin(np.abs(f_seen / f_e - 1), initial=np.inf)
        d_hid = np.nanmin(np.abs(f_hid / f_e - 1), initial=np.inf)
        if d_hid <= 0.1 and d_hid < d_seen / 1.5:
            # nearer a model mode the channels cannot see than any they see: that mode
            r = int(np.nanargmin(np.abs(f_hid / f_e - 1)))
            row = min(modal_table(model, hidden),
                      key=lambda x: abs(x["freq_hz"] - hidden.freq_hz[r]))
            name = f"{row['shape']} at {row['freq_hz']:.5g} Hz"
        elif seen.n_modes:
            xi = np.diag(modal_damping_matrix(model, seen))
            zeta_seen = xi / (2 * np.where(seen.omega_rad_s > 0, seen.omega_rad_s, 1.0))
            j = int(np.nanargmin(np.abs(f_seen / f_e - 1)))
            if d_seen < 6 * max(float(zeta_seen[j]), zeta_e):
                # on a mode the channels see (within a few half-power widths), and no
                # nearer unseen one: that mode changed (a filter, a gain, a shift), the
                # model does not lack one
                return None
            # a mode the channels see below or above it (within a factor 2.5: a
            # suspension mode under a stiffer support moves that far) may have moved
            # there: if refitting its own pole beside the new one gains as much again,
            # it is a shift
            below = np.flatnonzero((f_seen <= f_e) & (f_seen > f_e / 2.5))
            above = np.flatnonzero((f_seen > f_e) & (f_seen < f_e * 2.5))
            nearest = [int(below[np.nanargmax(f_seen[below])])] if below.size else []
            nearest += [int(above[np.nanargmin(f_seen[above])])] if above.size else []
            for j in nearest:
                alone, both = _shift_drop(problem, current, f_e, zeta_e,
                                          float(seen.freq_hz[j]), float(zeta_seen[j]))
                if both - alone > 0.5 * alone:
                    return None  # a model mode moved: the candidates' business
    return _missing(tests, t0, f_e, zeta_e, drop, per_out, noise, df, name)


def _resolved(found, lo: float, hi: float, df: float) -> bool:
    """Whether a pole of the scan is a mode the data resolve: damped less than the
    scan's largest damping (a pole at the grid's end is a broad residual, a model error
    spread over the band, not a peak) and its half-power band inside the compared band
    (a pole at the band's edge is the residual's trend there). The 0 Hz pole (a
    rigid-body mass line) is resolved by its own signature."""
    f_e, zeta_e = found[0], found[1]
    if f_e == 0.0:
        return True
    half = max(zeta_e * f_e, df)
    return zeta_e < max(ZETAS) and lo + half <= f_e <= hi - half


def _missing(tests, t0, f_e, zeta_e, drop, per_out, noise, df, name) -> MissingMode:
    """The :class:`MissingMode` of a pole found: its band, the channels that see it."""
    half = max(5 * zeta_e * f_e, 3 * df)
    if f_e == 0.0:
        zeta_e = 0.0
    chans = tuple(s.label for s, v in zip(t0.sensors, per_out, strict=True)
                  if v / noise > 2 * (2 + 2 * len(t0.actuators)))
    return MissingMode(f_e, zeta_e, tuple(t.name for t in tests), chans,
                       (f_e - half, f_e + half), float(drop / noise), name)


__all__ = ["MAX_MISSING", "MAX_REFINEMENT", "MESH_SHARE", "MESH_TOLERANCE", "MeshCheck",
           "MissingMode", "missing_modes", "noise_variance", "refined_plant", "renamed_tests",
           "scan_extra_mode", "unexplained_change"]
