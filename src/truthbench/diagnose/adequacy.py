"""Can the model resolve the data? The checks made before any effect is tried.

A residual that the model's own form leaves (a mesh too coarse for the band, a mode
the model cannot show at these channels) must not be reported as a physical effect the
model lacks. Two checks run on the baseline fit:

**Mesh.** The model is predicted at its mesh h and at h/2 (every element halved: the
measured points stay on nodes), at the baseline's parameters. The part of the
difference the declared parameters cannot absorb (the difference projected off the
baseline's weighted Jacobian) is measured in units of the data's noise,

    change = (|r|^2 - |Q' r|^2) / s2,    r = w (H_{h/2} - H_h),    J = Q R,

with ``s2`` the noise variance per real value of the weighted data (1 for weights from
coherence, else the roughness estimate of :func:`noise_variance`). It bounds the chi2
drop any candidate could gain by mimicking the discretisation error (the error of h
is 16/15 of the h to h/2 change for the cubic beam element's h^4 convergence). Where it
exceeds the tolerance (default one noise unit, against a selection threshold of 10
and more), the mesh is refined and checked again, up to a limit; beyond the limit the
diagnosis says the mesh is too coarse, with the figures.

**Modes the model lacks.** The data's own modes (pLSCF of each test) are aligned with
the model modes its channels see, in order of frequency (a dynamic-programming
alignment on log-frequency in which either side may leave a mode unmatched). A data
mode left unmatched is a mode the model lacks when the model has a mode near it that
these channels do not see (torsion or lateral bending measured by bending channels: the
sensors' offsets and cross-axis sensitivity show it in the data), or when no unmatched
model mode lies within a factor 2.5 in frequency (else it is more likely a model mode
that an effect moved far, which the candidates will try); and when the baseline's
residual over its half-power band stands far above the noise. It is reported with its
frequency, damping and the channels that see it, and its lines are left out of the
comparison: no effect is fitted to it.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from truthbench.diagnose.data import MeasuredTest
from truthbench.diagnose.fit import Fit, Problem, stack

MESH_TOLERANCE = 5.0
"""Largest change (noise units of chi2) of the model's FRFs from its mesh to the mesh
halved, beyond what the declared parameters absorb, for the mesh to be adequate: half
the default selection threshold (10)."""

MAX_REFINEMENT = 8
"""The mesh is refined (halved) up to this many times its element count."""

ALIGN_TOLERANCE = 0.1
"""Relative frequency mismatch that costs as much as leaving a data mode unmatched."""

MODE_SIGNIFICANCE = 25.0
"""Excess chi2 (noise units) of the baseline's residual over a data mode's band above
which an unmatched mode is a finding (identification artefacts explain nothing)."""


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
                f"{self.tolerance:g}: {steps})")


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
        The lines left out of the comparison.
    excess_chi2 : float
        The baseline residual's chi2 over that band above the noise's (noise units).
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
        return (f"a mode at {self.freq_hz:.5g} Hz (damping {100 * self.damping_ratio:.3g} %) "
                f"that the model lacks at these channels: {near}; seen by "
                f"{', '.join(self.channels) or '-'}; lines {self.band_hz[0]:.5g}-"
                f"{self.band_hz[1]:.5g} Hz left out")


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
    stations named after nodes (``n<k>``) renamed to the same point's new node.

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
    return replace(plant, n_elements=plant.n_elements * factor, stations=stations), renamed


def renamed_tests(tests: Sequence[MeasuredTest], renamed: dict) -> tuple[MeasuredTest, ...]:
    """The tests with their channels' stations renamed (:func:`refined_plant`)."""
    def one(t: MeasuredTest) -> MeasuredTest:
        return replace(t, actuators=tuple(replace(a, station=renamed.get(a.station, a.station))
                                          for a in t.actuators),
                       sensors=tuple(replace(s, station=renamed.get(s.station, s.station))
                                     for s in t.sensors))
    return tuple(one(t) for t in tests)


def _align(data_f: np.ndarray, model_f: np.ndarray, *, skip_data: float = 1.0,
           skip_model: float = 0.5, tolerance: float = ALIGN_TOLERANCE
           ) -> list[tuple[int, int]]:
    """Order-preserving alignment of two ascending frequency lists minimising the sum
    of ``|ln(f_d / f_m)| / tolerance`` over matched pairs plus the skip costs of the
    unmatched (dynamic programming). Returns the matched (data, model) index pairs."""
    n, m = len(data_f), len(model_f)
    cost = np.full((n + 1, m + 1), np.inf)
    cost[0, :] = skip_model * np.arange(m + 1)
    cost[:, 0] = skip_data * np.arange(n + 1)
    move = np.zeros((n + 1, m + 1), dtype=int)
    move[0, 1:] = 2
    move[1:, 0] = 1
    for i in range(1, n + 1):
        for j in range(1, m + 1):
            match = cost[i - 1, j - 1] + abs(np.log(data_f[i - 1] / model_f[j - 1])) / tolerance
            options = (match, cost[i - 1, j] + skip_data, cost[i, j - 1] + skip_model)
            k = int(np.argmin(options))
            cost[i, j], move[i, j] = options[k], k
    pairs = []
    i, j = n, m
    while i > 0 or j > 0:
        k = move[i, j]
        if k == 0:
            pairs.append((i - 1, j - 1))
            i, j = i - 1, j - 1
        elif k == 1:
            i -= 1
        else:
            j -= 1
    return pairs[::-1]


def _mode_band(t: MeasuredTest, f: float, zeta: float) -> np.ndarray:
    """The lines of a mode's band: within five half-power half-widths (``5 zeta f``) of
    its frequency, at least three lines either side."""
    df = float(np.median(np.diff(t.freq_hz))) if t.freq_hz.size > 1 else 1.0
    half = max(5 * max(zeta, 0.0) * f, 3 * df)
    return np.abs(t.freq_hz - f) <= half


def missing_modes(tests: Sequence[MeasuredTest], problem: Problem, current: Fit,
                  data_modes: Sequence, noise: float) -> tuple[MissingMode, ...]:
    """The data modes the model lacks at these channels (module notes).

    Parameters
    ----------
    tests : sequence of MeasuredTest
    problem : Problem
    current : Fit
        The baseline.
    data_modes : sequence
        Per test, its identification (:func:`truthbench.identify.identify_frfs`) or None.
    noise : float
        Noise variance per real weighted value (:func:`noise_variance`).

    Returns
    -------
    tuple of MissingMode
        One per mode, merged over the tests that show it, in order of frequency.
    """
    from truthbench.model import modal_damping_matrix, modal_table

    found: list[MissingMode] = []
    start = 0
    for t, ident in zip(tests, data_modes, strict=True):
        size = t.H.size
        resid = (problem.data[start:start + size] - current.model[start:start + size]
                 ).reshape(t.H.shape) * problem.weights[start:start + size].reshape(t.H.shape)
        start += size
        if ident is None or ident.n_modes == 0:
            continue
        hw = problem.predictor(current.terms).hardware(current.theta, t.actuators, t.sensors,
                                                       test=t.name)
        model, modes = hw.model, hw.modes
        lo, hi = float(t.freq_hz.min()), float(t.freq_hz.max())
        elastic = ~modes.rigid
        w = modes.omega_rad_s
        xi = np.diag(modal_damping_matrix(model, modes))
        cm = np.abs(model.C_out @ modes.shapes)  # (n_out, m)
        bm = np.abs(modes.shapes.T @ model.B)  # (m, n_in)
        p = np.array([{"displacement": 0, "velocity": 1, "acceleration": 2}[q]
                      for q in model.quantities])
        num = (cm * np.where(w > 0, w, 1.0)[None, :] ** p[:, None]).max(axis=0) \
            * bm.max(axis=1)
        peak = np.where(elastic & (xi > 0), num / np.maximum(w * xi, 1e-300), 0.0)
        near = elastic & (modes.freq_hz > lo / 1.5) & (modes.freq_hz < hi * 1.5)
        top = peak[near].max(initial=0.0)
        visible = near & (peak > 1e-3 * top) if top > 0 else np.zeros_like(near)
        hidden = near & ~visible
        table = None
        fd = np.asarray(ident.modal.freq_hz, float)
        zd = np.asarray(ident.modal.damping_ratio, float)
        keep = (fd >= lo) & (fd <= hi) & (zd > 0) & (zd < 0.1)
        fd, zd = fd[keep], zd[keep]
        fm = modes.freq_hz[visible]
        pairs = _align(fd, fm)
        matched_d = {a for a, _ in pairs}
        matched_m = {b for _, b in pairs}
        loose_m = fm[[k for k in range(len(fm)) if k not in matched_m]]
        for k in range(len(fd)):
            if k in matched_d:
                continue
            f, z = float(fd[k]), float(zd[k])
            hid = np.flatnonzero(hidden & (np.abs(modes.freq_hz / f - 1) <= 0.1))
            if hid.size == 0 and np.any((loose_m > f / 2.5) & (loose_m < 2.5 * f)):
                continue  # a model mode moved far: the candidates' business
            band = _mode_band(t, f, z)
            values = 2 * resid[band].size
            excess = float(np.sum(np.abs(resid[band]) ** 2)) / noise - values
            if excess < MODE_SIGNIFICANCE:
                continue
            per_out = np.sum(np.abs(resid[band]) ** 2, axis=(0, 2)) / noise / \
                max(2 * band.sum() * resid.shape[2], 1)
            chans = tuple(s.label for s, v in zip(t.sensors, per_out, strict=True) if v > 3)
            name = None
            if hid.size:
                if table is None:
                    table = modal_table(model, modes)
                r = int(hid[np.argmin(np.abs(modes.freq_hz[hid] - f))])
                # modal_table lists modes by frequency; rigid modes come first
                row = min(table, key=lambda row: abs(row["freq_hz"] - modes.freq_hz[r]))
                name = f"{row['shape']} at {row['freq_hz']:.5g} Hz"
            sel = t.freq_hz[band]
            mm = MissingMode(f, z, (t.name,), chans, (float(sel.min()), float(sel.max())),
                             excess, name)
            same = next((i for i, x in enumerate(found)
                         if abs(x.freq_hz / f - 1) < 0.01), None)
            if same is None:
                found.append(mm)
            else:
                x = found[same]
                found[same] = replace(x, tests=x.tests + mm.tests,
                                      channels=tuple(dict.fromkeys(x.channels + chans)),
                                      band_hz=(min(x.band_hz[0], mm.band_hz[0]),
                                               max(x.band_hz[1], mm.band_hz[1])),
                                      excess_chi2=x.excess_chi2 + excess,
                                      model_mode=x.model_mode or name)
    return tuple(sorted(found, key=lambda m: m.freq_hz))


def without_bands(tests: Sequence[MeasuredTest], bands: Sequence[tuple[float, float]]
                  ) -> tuple[MeasuredTest, ...]:
    """The tests with the lines inside ``bands`` (Hz, inclusive) left out.

    Raises
    ------
    DataFormatError
        A test with no line left.
    """
    from truthbench.errors import DataFormatError

    out = []
    for t in tests:
        keep = np.ones(t.freq_hz.size, dtype=bool)
        for lo, hi in bands:
            keep &= ~((t.freq_hz >= lo) & (t.freq_hz <= hi))
        if keep.all():
            out.append(t)
            continue
        if not keep.any():
            raise DataFormatError(f"data set {t.name!r}: every line lies in a band of a "
                                  f"mode the model lacks; nothing left to compare")
        lines = t.lines.copy()
        lines[np.flatnonzero(t.lines)[~keep]] = False
        out.append(replace(t, lines=lines, H=t.H[keep], sigma=t.sigma[keep]))
    return tuple(out)


__all__ = ["MAX_REFINEMENT", "MESH_TOLERANCE", "MeshCheck", "MissingMode", "missing_modes",
           "noise_variance", "refined_plant", "renamed_tests", "unexplained_change",
           "without_bands"]
