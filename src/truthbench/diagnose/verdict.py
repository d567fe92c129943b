"""One verdict per article, and the measurement that would settle it.

When the runner-up of a step explains the data almost as well as the effect chosen
(their delta BIC within a margin), the data cannot tell them apart and the verdict is
"A or B", with both fits. The diagnosis then asks where the two models differ most
against the noise: each candidate sensor (a translation in a measured direction at every
node, driven by the data's inputs) and each candidate excitation point (at every node,
read by the data's sensors) is scored by
``separation = sum_f |H_A(f) - H_B(f)|^2 / sigma(f)^2``
over the data's lines, ``sigma`` the data's own relative noise (their median
``sigma / (|H| + median |H|)`` applied to the new channel's response). The best sensor
and excitation point are named with their separation and its ratio to what the
measured channels already offer.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np

from truthbench.diagnose.fit import Fit, Problem
from truthbench.diagnose.search import fitted_own


@dataclass(frozen=True)
class Alternative:
    """An effect that explains the data about as well as the one found.

    Attributes
    ----------
    effect : str
    options : dict
    label : str
    parameters : dict
        The effect's own values at its fit.
    fitted : dict
    delta_bic : float
        Its evidence against the model without it (the found effect's is larger by less
        than the margin).
    node : int or None
    margin : float
        The margin of delta BIC it was within: ``ambiguity_margin``, grown where the
        residual is model error (:meth:`~truthbench.diagnose.core._Diagnosis.margin`).
    x_m : float or None
        Where along the article it was placed, m (a station between nodes, which the
        diagnosis's final mesh need not have); None for an effect with no place.
    """

    effect: str
    options: dict
    label: str
    parameters: dict
    fitted: dict
    delta_bic: float
    node: int | None
    margin: float = float("nan")
    x_m: float | None = None


@dataclass(frozen=True)
class Measurement:
    """A measurement that would tell two explanations apart.

    Attributes
    ----------
    kind : {"sensor", "excitation"}
        A new sensor (driven by the data's inputs) or a new excitation point (read by the
        data's sensors).
    station : str
        The model's node station (``n<k>``).
    x_m : float
        Its position along the beam, m.
    direction : str
    separation : float
        ``sum |H_A - H_B|^2 / sigma^2`` over the lines (noise units of chi2).
    gain : float
        ``separation`` over that of the data already measured (inf when they see no
        difference).
    between : (str, str)
        The two explanations (candidate labels).
    """

    kind: str
    station: str
    x_m: float
    direction: str
    separation: float
    gain: float
    between: tuple[str, str]

    def summary(self) -> str:
        what = "a sensor" if self.kind == "sensor" else "an excitation"
        return (f"{what} at x = {self.x_m:.4g} m ({self.station}, {self.direction}) would "
                f"separate {self.between[0]} from {self.between[1]}: "
                f"{self.separation:.3g} noise units of chi2, {self.gain:.3g}x what the "
                f"measured channels offer")


def _relative_noise(tests) -> float:
    """The data's median ``sigma / (|H| + median |H|)``: the noise of a new channel as a
    fraction of its response (relative, with an absolute part at antiresonances)."""
    ratios = []
    for t in tests:
        mag = np.abs(t.H)
        level = np.median(mag, axis=0, keepdims=True)
        ratios.append((t.sigma / np.maximum(mag + level, 1e-300)).ravel())
    return float(np.median(np.concatenate(ratios)))


def _separation(HA: np.ndarray, HB: np.ndarray, rho: float, axis) -> np.ndarray:
    mag = np.abs(HA)
    level = np.median(mag, axis=0, keepdims=True)
    sigma = rho * np.maximum(mag + level, 1e-300)
    return np.sum(np.abs(HA - HB) ** 2 / sigma**2, axis=axis)


def measurements(problem: Problem, fit_a: Fit, fit_b: Fit, labels: tuple[str, str],
                 tests, plant, *, count: int = 1, problem_b: Problem | None = None
                 ) -> tuple[Measurement, ...]:
    """The sensor and the excitation point that best separate two fitted models.

    Parameters
    ----------
    problem : Problem
        ``fit_a``'s (and ``fit_b``'s, unless ``problem_b`` is given).
    fit_a, fit_b : Fit
        The two explanations (their effects and parameters).
    labels : (str, str)
        Their names.
    tests : sequence of MeasuredTest
    plant : Plant
        The model's plant (node stations ``n<k>``).
    count : int
        How many of each kind.
    problem_b : Problem, optional
        ``fit_b``'s, where it differs (an attachment placed at a station between nodes
        that only its own plant has).

    Returns
    -------
    tuple of Measurement
        The best ``count`` sensors, then the best ``count`` excitation points; none of a
        kind where no point separates the two by one noise unit of chi2 (two effects on
        every channel alike, such as a sensor-side and an actuator-side filter).
    """
    t = max(tests, key=lambda x: x.H.size)
    f = t.freq_hz
    rho = _relative_noise(tests)
    parts = []
    for fit_, own in ((fit_a, problem), (fit_b, problem_b or problem)):
        hw = own.predictor(fit_.terms).hardware(fit_.theta, t.actuators, t.sensors,
                                                test=t.name)
        parts.append(hw)
    model = parts[0].model
    labels_dof = model.dof_labels
    dirs = sorted({s.direction for s in t.sensors if s.direction in ("x", "y", "z")})
    quantity = t.sensors[0].quantity if t.sensors else "acceleration"
    nodes = [k for k in range(plant.n_elements + 1)]
    cand = [(k, d) for k in nodes for d in dirs if f"n{k}.{d}" in labels_dof]
    if not cand:
        return ()
    E = np.zeros((len(cand), model.n_dofs))
    for i, (k, d) in enumerate(cand):
        E[i, labels_dof.index(f"n{k}.{d}")] = 1.0
    new_out, new_in = [], []
    for hw in parts:
        m, modes = hw.model, hw.modes
        # a new channel passes the chain the measured ones pass: the first output's
        # filters, gain and delay for a new sensor, the inputs' for the data's inputs
        g_out, g_in = hw.chain_gains(f, decay_rad_s=t.frf.window_decay_rad_s)
        g_out = np.ones((f.size, len(t.sensors))) if g_out is None else g_out
        g_in = np.ones((f.size, len(t.actuators))) if g_in is None else g_in
        kw = dict(modes=modes, decay_rad_s=t.frf.window_decay_rad_s)
        sens = m.with_io(C_out=E, quantities=(quantity,) * len(cand)).frf(f, **kw)
        new_out.append(sens * g_out[:, :1, None] * g_in[:, None, :])
        exc = m.with_io(B=E.T).frf(f, **kw)  # (f, n_out, n_cand): force at a new point
        new_in.append(exc * g_out[:, :, None] * g_in[:, None, :1])
    sep_out = _separation(new_out[0], new_out[1], rho, axis=(0, 2))
    sep_in = _separation(new_in[0], new_in[1], rho, axis=(0, 1))
    start = 0
    base = 0.0
    ma, mb = fit_a.model, fit_b.model
    for x in tests:
        size = x.H.size
        a, b = ma[start:start + size].reshape(x.H.shape), mb[start:start + size].reshape(x.H.shape)
        base += float(_separation(a, b, rho, axis=None))
        start += size
    xs = plant.node_x_m(problem.plant.resolve(problem.nominal))
    out = []
    for kind, sep in (("sensor", sep_out), ("excitation", sep_in)):
        for i in np.argsort(-sep)[:count]:
            if not sep[i] > 1.0:  # not one noise unit apart: no such point separates them
                break
            k, d = cand[int(i)]
            out.append(Measurement(kind, f"n{k}", float(xs[k]), d, float(sep[i]),
                                   float(sep[i] / base) if base > 0 else float("inf"),
                                   labels))
    return tuple(out)


#: Delta BICs closer than this fraction of their size (or of 1) are one value. Models the
#: data cannot tell apart (a first-order lag in every sensor or in every shaker makes the
#: same FRFs) are fitted separately, and their delta BICs then differ by the fits'
#: round-off (1e-10 to 1e-8 of it in the study): their order is the effects' names', not
#: the arithmetic's last bits, which a processor's vector width can change.
TIE = 1e-6


def ranked(results: Iterable) -> list:
    """``results`` (anything with ``delta_bic`` and ``candidate``) best first; those tied
    within :data:`TIE` in the alphabetical order of their effects' names, then labels
    (the order of the default catalogue)."""
    out = sorted(results, key=lambda r: -r.delta_bic)
    i = 0
    while i < len(out):
        top = out[i].delta_bic
        j = i + 1
        while j < len(out) and top - out[j].delta_bic <= TIE * max(1.0, abs(top)):
            j += 1
        out[i:j] = sorted(out[i:j], key=lambda r: (r.candidate.effect, r.candidate.label))
        i = j
    return out


def ambiguous(finals: Sequence, chosen, margin: float, *, nodes_apart: int = 2) -> list:
    """The runners-up that explain the data within ``margin`` of delta BIC of the chosen
    one, best first: the best of each other effect, and of the same effect at a location
    more than ``nodes_apart`` nodes away (a neighbour is the same finding, not an
    alternative). Empty when the chosen one stands alone."""
    out = []
    for r in ranked(finals):
        c = r.candidate
        if c.label == chosen.candidate.label or not r.physical:
            continue
        same_place = (c.effect == chosen.candidate.effect and
                      (c.node is None or chosen.candidate.node is None or
                       abs(c.node - chosen.candidate.node) <= nodes_apart))
        if same_place or chosen.delta_bic - r.delta_bic > margin:
            continue
        if any(x.candidate.effect == c.effect and (c.node is None or abs(
                x.candidate.node - c.node) <= nodes_apart) for x in out):
            continue  # a better runner-up of this effect at this place is in
        out.append(r)
    return out


#: Effects that contain simpler ones as a limit: a second-order low-pass with a large
#: damping ratio has one pole in the band and the other far above it, a first-order one.
NESTED = {"actuator_resonance": ("actuator_dynamics",), "sensor_dynamics": ("sensor_lag",)}

#: A second-order low-pass whose upper real pole lies beyond this many times the band's
#: top frequency is seen by the data as a first-order one: the far pole's own lag there
#: (at most atan(1/10), 6 degrees) is what a fraction of a sample of delay or another
#: estimator gives, not a resolved pole.
FAR_POLE = 10.0


def far_pole_hz(a_s2: float, b_s: float) -> float:
    """The upper of the two real poles of ``1 / (a s^2 + b s + 1)``, Hz: ``inf`` at
    ``a = 0`` (first order), ``nan`` when the poles are complex (a resonance)."""
    if a_s2 <= 0:
        return np.inf
    disc = b_s * b_s - 4 * a_s2
    if disc < 0:
        return np.nan
    return float((b_s + np.sqrt(disc)) / (2 * a_s2) / (2 * np.pi))


def parsimonious(finals: Sequence, chosen, margin: float, f_max_hz: float):
    """``chosen``, or a simpler explanation: the simpler effect it contains
    (:data:`NESTED`), when that was refitted and either explains the data within
    ``margin`` of delta BIC or ``chosen``'s fit is overdamped with its upper pole beyond
    :data:`FAR_POLE` times ``f_max_hz``; then any finalist with fewer parameters within
    ``margin`` (the fewest, then the best). Of explanations the data cannot tell apart,
    the one with fewer parameters is stated first (the others stay runners-up)."""
    simpler = [r for r in finals if r.physical
               and r.candidate.effect in NESTED.get(chosen.candidate.effect, ())]
    if simpler:
        values = fitted_own(chosen.candidate, chosen.fit.theta)
        unresolved = far_pole_hz(values.get("a_s2", 0.0), values.get("b_s", 0.0)) \
            > FAR_POLE * f_max_hz
        close = [r for r in simpler
                 if unresolved or chosen.delta_bic - r.delta_bic <= margin]
        chosen = ranked(close)[0] if close else chosen
    # of any explanations the data cannot tell apart, one with fewer parameters (those
    # held at a bound counted: the effect's own count) is stated first
    fewer = [r for r in finals if r.physical and size(r.candidate) < size(chosen.candidate)
             and chosen.delta_bic - r.delta_bic <= margin]
    if not fewer:
        return chosen
    least = min(size(r.candidate) for r in fewer)
    return ranked(r for r in fewer if size(r.candidate) == least)[0]


def size(c) -> int:
    """A candidate's parameter count, those held at a bound included."""
    return len(c.fitted) + len(c.pinned)


__all__ = ["FAR_POLE", "NESTED", "TIE", "Alternative", "Measurement", "ambiguous",
           "far_pole_hz", "measurements", "parsimonious", "ranked"]
