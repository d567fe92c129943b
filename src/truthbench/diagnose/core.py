"""Diagnosis: from measured FRFs and a model to the effects the model lacks.

1. **Baseline.** The channels are placed on the model (:func:`~.data.prepare`) and the
   parameters the user declared (``[update] parameters``) are fitted: the best the model
   can do as declared.
2. **Residual.** Every view of data against the baseline (:mod:`.residual`).
3. **Candidates.** Every effect of the registry that declares a diagnosis form, at every
   location it can have (:mod:`.candidates`), is screened by the Lagrange-multiplier
   test of adding it to the current fit (:func:`~.fit.score`); the ``refits`` best, and
   the best location of every other effect screened within a factor 2 of the best, are
   refitted (quick: forward differences, capped iterations) with the declared
   parameters and the effects already found, and so are the locations within two nodes
   of the best located one (a first-order score can rank a mirror image or a neighbour
   first when the change is large). When not even the best first-order drop could be
   significant, nothing is refitted.
4. **Selection.** Each refit is scored by the Bayesian information criterion with the
   noise scale profiled out (the weights ``1 / sigma`` fix the relative noise of every
   value, the common scale is estimated),

       delta_BIC = n ln(chi2_current / chi2_candidate) - k ln(n),

   n the independent real data values (the real values over the estimate's correlated
   lines per value, 1.8 for a Bartlett window) and k the candidate's parameters. The
   best candidate with a physical fit (inside its bounds, up to a slack) and ``delta_BIC
   > threshold + 2 ln M`` (M the candidates tried: the best of M noise-only drops is
   about 2 ln M) is added; the search repeats until none is (forward selection), or
   ``max_effects`` are found. Data at the noise level find nothing.
5. **After.** The residual views of the final model; the found effects with their
   fitted values, standard deviations (from the Jacobian, scaled by the residual) and
   location.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace

import numpy as np
from threadpoolctl import threadpool_limits

from truthbench.diagnose.candidates import (
    Candidate,
    bind_levels,
    catalogue,
    references,
    with_node_stations,
)
from truthbench.diagnose.data import MeasuredTest, prepare
from truthbench.diagnose.fit import (
    Fit,
    Problem,
    candidate_columns,
    evaluate,
    fit,
    fit_magnitude,
    refit_error,
    score,
)
from truthbench.diagnose.residual import (
    ModeResidual,
    Residual,
    matched_delay,
    mpc,
    residual_views,
)
from truthbench.diagnose.screen import point_profiles
from truthbench.errors import IdentifiabilityError, ModelError
from truthbench.measure.frfdata import FRFData
from truthbench.measure.leakage import Estimator
from truthbench.plants.base import Plant
from truthbench.update.predictor import APPENDED_PARAMETERS, PredictedTest


@dataclass(frozen=True)
class DiagnoseSettings:
    """Settings of :func:`diagnose` (see its parameters)."""

    candidates: tuple[str, ...] | None = None
    band_hz: tuple[float, float] | None = None
    tolerance_m: float = 1e-3
    point_map: Mapping[int, float] = field(default_factory=dict)
    channel_map: Mapping[str, Mapping] = field(default_factory=dict)
    max_effects: int = 2
    threshold: float = 10.0
    refits: int = 6
    estimator: bool = True
    window: str | None = None
    fs_hz: float | None = None
    averages: int | None = None
    identify_modes: bool = True
    max_iterations: int = 30
    tolerance: float = 1e-6


@dataclass(frozen=True)
class Found:
    """An effect the diagnosis added.

    Attributes
    ----------
    effect : str
        Registry name.
    options : dict
        Its location (station, direction, sensor).
    parameters : dict
        The effect's own parameter values at the fit.
    fitted : dict
        The fitted parameters (own names) and their standard deviations ``std``.
    std : dict
    delta_bic : float
    node : int or None
    label : str
    """

    effect: str
    options: dict
    parameters: dict
    fitted: dict
    std: dict
    delta_bic: float
    node: int | None
    label: str


@dataclass(frozen=True)
class Tried:
    """A candidate tried at one step: screened, refitted, scored."""

    step: int
    label: str
    effect: str
    options: dict
    screen_drop: float
    delta_bic: float = float("nan")
    fitted: dict = field(default_factory=dict)
    parameters: dict = field(default_factory=dict)
    status: str = "screened"


BOUND_SLACK = 0.05
"""A fitted value may cross its physical bound by this fraction of its natural size (or
two standard deviations, if more) and still count as at the bound: a fit of an effect
whose true value sits on the bound (a joint without damping) lands on either side."""


def _bounds_ok(cand: Candidate, values: Mapping[str, float], std: Mapping[str, float],
               sizes: Mapping[str, float]) -> str | None:
    """None if every fitted value is within its physical bounds (up to the slack), else
    why not."""
    for p in cand.fitted:
        key = f"{cand.label}.{p.name}"
        v = values[key]
        slack = max(2 * std.get(key, 0.0), BOUND_SLACK * sizes[key])
        if p.minimum is not None and v < p.minimum - slack:
            return f"unphysical: {p.name} = {v:.4g} below {p.minimum:g}"
        if p.maximum is not None and v > p.maximum + slack:
            return f"unphysical: {p.name} = {v:.4g} above {p.maximum:g}"
    return None


def _with_offsets(problem: Problem, current: Fit) -> Problem:
    """The problem with the estimator's leakage offset at ``current``'s parameters."""
    if not any(t.kernel is not None for t in problem.tests):
        return problem
    pred = problem.predictor(current.terms)
    exact = pred.predict_vector(current.theta)
    seen = pred.predict_vector(current.theta, estimator=True)
    return replace(problem, offsets=seen - exact)


def _bandwidth_lines(kernel) -> float:
    """Lines per independent value of a windowed estimate (1 rectangular, about 1.3
    Bartlett and Hann: :attr:`~truthbench.measure.leakage.LeakageKernel.
    correlation_lines`); 1 when the estimator is unknown."""
    return 1.0 if kernel is None else kernel.correlation_lines


def _kernel(frf: FRFData, settings: DiagnoseSettings):
    """The leakage kernel of a data set's estimator: its own (our files), or the one the
    settings state for data from other tools (``window``, segment = 1 / line spacing,
    ``fs_hz`` default twice the highest line; a random input: the continuum), or None."""
    if not settings.estimator:
        return None
    if frf.estimator is not None:
        return frf.estimator.kernel()
    if settings.window is None or frf.freq_hz.size < 2:
        return None
    df = float(np.median(np.diff(frf.freq_hz)))
    fs = settings.fs_hz or 2.0 * float(frf.freq_hz.max())
    return Estimator(settings.window, int(round(fs / df)), fs).kernel()


def _parts(tests: Sequence[MeasuredTest], vector: np.ndarray) -> list[np.ndarray]:
    out, k = [], 0
    for t in tests:
        n = t.H.size
        out.append(vector[k:k + n].reshape(t.H.shape))
        k += n
    return out


def _modes(tests, problem: Problem, fit_: Fit, data_modes) -> tuple[ModeResidual, ...]:
    """Identified data modes paired with the model's at the measured outputs."""
    from truthbench.identify import ModalParameters, pair_modes
    from truthbench.model import modal_table

    out = []
    for t, ident in zip(tests, data_modes, strict=True):
        if ident is None or ident.n_modes == 0:
            continue
        hw = problem.predictor(fit_.terms).hardware(fit_.theta, t.actuators, t.sensors)
        model, modes = hw.model, hw.modes
        rows = modal_table(model, modes)
        f = np.array([r["freq_hz"] for r in rows])
        z = np.nan_to_num(np.array([r["damping_ratio"] for r in rows]))
        measured = model.C_out @ modes.shapes
        seen = np.linalg.norm(measured, axis=0)
        # modes the measured DOFs do not see (torsion of a beam measured in bending)
        # cannot be paired with a measured mode
        keep = ~modes.rigid & (f >= t.freq_hz.min()) & (f <= t.freq_hz.max()) & \
            (seen > 1e-6 * max(float(seen.max()), 1e-300))
        mm = ModalParameters(f[keep], z[keep], measured[:, keep])
        dm = ModalParameters(ident.modal.freq_hz, ident.modal.damping_ratio,
                             ident.modal.shapes)
        if mm.n_modes == 0:
            continue
        with warnings.catch_warnings():  # one measured DOF: every MAC is 1, the
            warnings.simplefilter("ignore")  # frequencies pair the modes
            pairing = pair_modes(mm, dm, mac_min=0.5)
        for (a, b), mac in zip(np.asarray(pairing.pairs, int).reshape(-1, 2),
                               np.ravel(pairing.mac), strict=True):
            fd, zd = float(dm.freq_hz[b]), float(dm.damping_ratio[b])
            out.append(ModeResidual(
                t.name, fd, 100 * (float(mm.freq_hz[a]) / fd - 1), zd,
                100 * (float(mm.damping_ratio[a]) / zd - 1) if zd > 0 else float("nan"),
                float(mac), mpc(np.asarray(dm.shapes)[:, b])))
    return tuple(out)


def _identify(tests, max_order: int = 40):
    """The data's own modes per test (pLSCF over its compared lines), or None."""
    from truthbench.identify import identify_frfs

    out = []
    for t in tests:
        try:
            data = t.frf.lines(t.lines)
            out.append(identify_frfs(data, max_order=max_order,
                                     band_hz=(float(t.freq_hz.min()), float(t.freq_hz.max()))))
        except (ValueError, np.linalg.LinAlgError):
            out.append(None)
    return out


def diagnose(data: FRFData | Sequence[FRFData], plant: Plant, nominal: Mapping[str, float],
             parameters: Sequence[str], settings: DiagnoseSettings | None = None, **kwargs):
    """Find the effects a model lacks from measured FRFs.

    Parameters
    ----------
    data : FRFData or sequence of FRFData
        The measured tests (from :func:`truthbench.load_frf`: UFF, LVM, our HDF5).
    plant : Plant
        The model's plant (the user's article).
    nominal : mapping
        Its nominal parameters.
    parameters : sequence of str
        What the user trusts the model to get wrong: fitted first, as the baseline, and
        refitted with every candidate (plant parameters, ``delay_s``, ``sensor_gain``).
    settings : DiagnoseSettings, optional
        Or its fields as keyword arguments: ``candidates`` (registry names to try; default
        all), ``band_hz``, ``tolerance_m``, ``point_map`` and ``channel_map`` (placing
        the channels: :func:`~truthbench.diagnose.data.prepare`),
        ``max_effects``, ``threshold`` (delta BIC), ``refits``, ``estimator``
        (compare through the data's leakage when known), ``window`` and ``fs_hz`` (the
        segment window of data from other tools, whose files do not say, and their
        sampling rate), ``averages`` (their number of averages, which with the coherence
        sets the noise weights; the data's own when they state it), ``identify_modes``.

    Returns
    -------
    Diagnosis

    Raises
    ------
    DataFormatError
        A channel that cannot be placed, no input, no line in the band.
    IdentifiabilityError
        Fewer data than parameters, or the declared parameters cannot be separated.
    """
    if settings is None:
        settings = DiagnoseSettings(**kwargs)
    elif kwargs:
        settings = replace(settings, **kwargs)
    data = (data,) if isinstance(data, FRFData) else tuple(data)
    if settings.averages is not None:
        data = tuple(d if d.n_averages is not None else replace(d, n_averages=settings.averages)
                     for d in data)
    # small dense matrices: BLAS threads only add overhead (as in the campaign's trials)
    with threadpool_limits(limits=1, user_api="blas"):
        return _diagnose(data, plant, nominal, parameters, settings)


def _diagnose(data, plant, nominal, parameters, settings):
    from truthbench.diagnose.result import Diagnosis

    nominal = plant.resolve(nominal)
    declared = tuple(parameters)
    known = set(plant.parameter_names()) | set(APPENDED_PARAMETERS)
    bad = [p for p in declared if p not in known]
    if bad:
        raise ModelError(f"parameters {bad} are neither plant parameters of {plant.kind} nor "
                         f"{sorted(APPENDED_PARAMETERS)}")
    placed, tests = prepare(data, plant, nominal, band_hz=settings.band_hz,
                            tolerance_m=settings.tolerance_m, point_map=settings.point_map,
                            channel_map=settings.channel_map)
    model_plant = with_node_stations(placed)
    ptests = tuple(PredictedTest(
        t.name, t.freq_hz, t.actuators, t.sensors, decay_rad_s=t.frf.window_decay_rad_s,
        kernel=_kernel(t.frf, settings),
        band_hz=t.frf.band_hz) for t in tests)
    values = np.concatenate([t.H.ravel() for t in tests])
    weights = np.concatenate([1.0 / t.sigma.ravel() for t in tests])
    if 2 * values.size <= len(declared) + 1:
        raise IdentifiabilityError(
            f"{2 * values.size} real data values (lines x outputs x inputs x 2) cannot "
            f"determine {len(declared)} declared parameters and a candidate; widen the band "
            f"or add data")
    f_max = max(float(t.freq_hz.max()) for t in tests)
    refs = references(model_plant, nominal, f_max,
                      f_min_hz=min(float(t.freq_hz.min()) for t in tests))
    levels = [r for t in tests if t.frf.input_rms is not None for r in t.frf.input_rms]
    refs["force"] = float(np.mean(levels)) if levels else 1.0
    problem = Problem(model_plant, dict(nominal), ptests, values, weights, declared,
                      {k: refs["time"] for k in declared if k == "delay_s"},
                      None,
                      {"max_iterations": settings.max_iterations,
                       "tolerance": settings.tolerance})
    structural = fit_magnitude(problem)
    current = fit(problem, start=structural)
    problem = _with_offsets(problem, current)
    current = fit(problem, start=current.theta)
    baseline = current
    # the phase signatures are read against the magnitude fit, which a phase error does
    # not distort (the complex fit may bend the structure to mimic part of it)
    signature_fit = evaluate(problem, (), declared, structural)
    tried: list[Tried] = []
    thresholds: list[float] = []
    found: list[Found] = []
    accepted: list[Candidate] = []
    cands = catalogue(model_plant, nominal, tests, names=settings.candidates)
    # the information criterion counts independent values: lines of a windowed estimate
    # are correlated over the window's noise bandwidth (in lines), so n is divided by it
    n = problem.n / max((_bandwidth_lines(pt.kernel) for pt in ptests), default=1.0)
    for step in range(settings.max_effects):
        pred = problem.predictor(current.terms)
        cands = bind_levels(cands, lambda t, pred=pred, cur=current: pred.hardware(
            cur.theta, t.actuators, t.sensors, test=t.name), tests)
        screened = _screen(problem, current, cands, accepted, refs, step, tried)
        if not screened:
            break
        # candidates a residual signature points at start where it points (a delay from
        # the matched-delay profile, a gain from the magnitude ratio), with the declared
        # parameters of the magnitude fit at the first step: a first-order score from
        # zero misjudges a phase error of several radians
        base = signature_fit if step == 0 else current
        views = residual_views(tests, _parts(tests, base.model), len(base.names))
        results = {}
        for drop, c, _, _ in screened:
            start = _signature_start(c, views, tests, base.model)
            if start is not None:
                results[c.label] = _refit(problem, current, accepted, c, drop, start, refs,
                                          n, step, tried, declared_start=base.theta)
        # the best located ones, every effect without a location (a handful) whose
        # screened drop is within a factor 10 of the best (its screening is the
        # roughest), and the best location of every other located effect within a factor
        # 2: screens of different effects are approximate in different ways (an exact
        # point attachment on a grid of strengths against a joint's line search), so one
        # effect's many locations must not crowd out another's best
        top = screened[0][0]
        chosen = list(screened[:settings.refits]) + [
            s for s in screened[settings.refits:] if s[1].node is None and s[0] > 0.1 * top]
        kinds = {c.effect for _, c, _, _ in chosen}
        for s_ in screened[settings.refits:]:
            if s_[1].node is not None and s_[1].effect not in kinds and s_[0] > 0.5 * top:
                chosen.append(s_)
                kinds.add(s_[1].effect)
        for drop, c, guess, adapt in chosen:
            if c.label not in results:
                results[c.label] = _refit(problem, current, accepted, c, drop, guess, refs,
                                          n, step, tried,
                                          declared_start=_adapted(current.theta, adapt))
        # locations next to the best located refit (a first-order score can rank a
        # mirror image or a neighbour first for a large change)
        best = max((r for r in results.values() if r and r[1].node is not None),
                   key=lambda r: r[0], default=None)
        if best is not None:
            for drop, c, guess, adapt in screened:
                if (c.effect == best[1].effect and c.label not in results
                        and c.options.get("direction") == best[1].options.get("direction")
                        and abs(c.node - best[1].node) <= 2):
                    results[c.label] = _refit(
                        problem, current, accepted, c, drop, guess, refs, n, step, tried,
                        declared_start=_adapted(current.theta, adapt))
        screened_out = {c.label for _, c, _, _ in screened} - set(results)
        tried.extend(Tried(step, c.label, c.effect, c.options, drop)
                     for drop, c, _, _ in screened if c.label in screened_out)
        # the threshold grows with the number of candidates tried (look-elsewhere: the
        # best of M noise-only chi2 drops is about 2 ln M)
        threshold = settings.threshold + 2.0 * np.log(max(len(screened), 1))
        thresholds.append(float(threshold))
        ok = sorted((r for r in results.values()
                     if r and not r[3].startswith("unphysical") and r[0] > threshold),
                    key=lambda r: -r[0])
        # the two best, and the best location of the next best effects, refitted in
        # full, each with the estimator's leakage at its own model (the offsets of the
        # current model are wrong where a candidate moves a sharp mode by more than a
        # line), and compared on that consistent chi2
        finals = []
        shortlist = list(ok[:2])
        for r in ok[2:]:
            if r[1].effect not in {x[1].effect for x in shortlist}:
                shortlist.append(r)
        for dbic0, c, quick, _ in shortlist[:4]:
            if dbic0 < 0.5 * ok[0][0]:
                break
            pc = replace(problem, scales={**problem.scales, **c.scales(refs)})
            try:
                full = fit(_with_offsets(pc, quick), quick.terms, start=quick.theta)
                if c.levels is not None:  # friction: the levels with its own damping in
                    c, full = _relevel(_with_offsets(pc, full), c, accepted, full, tests)
                pc = _with_offsets(pc, full)
                full = fit(pc, full.terms, start=full.theta)
            except (IdentifiabilityError, ModelError, ValueError,
                    np.linalg.LinAlgError) as exc:
                tried.append(Tried(step, c.label, c.effect, c.options, float("nan"),
                                   status=f"full refit: {refit_error(exc)}"))
                continue
            dbic = float(n * np.log(current.chi2 / full.chi2) - len(c.fitted) * np.log(n))
            if dbic > threshold and not _bounds_ok(c, full.theta, full.std,
                                                            c.scales(refs)):
                finals.append((dbic, c, full, pc))
        if not finals:
            break
        dbic, c, current, problem = max(finals, key=lambda x: x[0])
        accepted.append(c)
        own = {p.name: current.theta[f"{c.label}.{p.name}"] for p in c.fitted}
        std = {p.name: current.std[f"{c.label}.{p.name}"] for p in c.fitted}
        found.append(Found(c.effect, dict(c.options), c.effect_values(own), own, std,
                           dbic, c.node, c.label))
    data_modes = _identify(tests) if settings.identify_modes else [None] * len(tests)
    before = residual_views(tests, _parts(tests, baseline.model), len(baseline.names),
                            modes=_modes(tests, problem, baseline, data_modes))
    after = residual_views(tests, _parts(tests, current.model), len(current.names),
                           modes=_modes(tests, problem, current, data_modes))
    return Diagnosis(tuple(found), before, after, baseline, current, tuple(tried), settings,
                     tests, model_plant, dict(nominal), declared, problem.n, float(n),
                     tuple(thresholds))


def _relevel(problem, c: Candidate, accepted, fit_, tests, passes: int = 2):
    """Refit a friction candidate with its levels recomputed from the model that
    includes its own equivalent damping (the statistical linearisation's fixed point:
    friction lowers the response it is linearised at)."""
    for _ in range(passes):
        pred = problem.predictor(fit_.terms)
        (c,) = bind_levels([c], lambda t, pred=pred, th=fit_.theta: pred.hardware(
            th, t.actuators, t.sensors, test=t.name), tests)
        own = _fitted_own(c, fit_.theta)
        terms = tuple(x for a in accepted for x in a.terms(start=_fitted_own(a, fit_.theta)))
        fit_ = fit(problem, terms + c.terms(start=own), start=fit_.theta)
    return c, fit_


def _adapted(theta: Mapping[str, float], step: Mapping[str, float]) -> dict[str, float]:
    """``theta`` moved by a first-order step of its parameters, each change held within
    half the parameter's size (a linearised step from a biased fit can overshoot)."""
    out = dict(theta)
    for k, d in step.items():
        limit = 0.5 * abs(theta[k]) if theta[k] else abs(d)
        out[k] = theta[k] + float(np.clip(d, -limit, limit))
    return out


def _signature_start(c: Candidate, views: Residual, tests, model) -> np.ndarray | None:
    """Starting values a residual signature gives a candidate, or None: the matched
    delay (the chi2 profile of a pure delay, searched from the phase slope) for a delay
    or a low-pass (whose phase falls as -omega tau at low frequency), the magnitude ratio
    less 1 for a gain (of one channel, or of all)."""
    if c.effect in ("time_delay", "actuator_dynamics", "sensor_dynamics"):
        f = np.concatenate([np.broadcast_to(t.freq_hz[:, None, None], t.H.shape).ravel()
                            for t in tests])
        data = np.concatenate([t.H.ravel() for t in tests])
        w = np.concatenate([1.0 / t.sigma.ravel() for t in tests])
        return np.array([matched_delay(f, data, model, w, views.delay_s)])
    if c.effect == "channel_gain":
        ratios = [ch.magnitude_ratio for ch in views.channels
                  if ch.output == c.options["sensor"]]
        return np.array([float(np.mean(ratios)) - 1.0]) if ratios else None
    if c.effect == "sensor_bias":
        return np.array([float(np.mean([ch.magnitude_ratio for ch in views.channels]))
                         - 1.0])
    return None


LINE_STEPS = (0.25, 0.5, 1.0, 2.0, 4.0, 8.0, 16.0, 64.0)
"""Multiples of a candidate's first-order step tried by :func:`_line_search`."""

NATURAL_STEPS = (0.3, 1.0, 3.0, 10.0)
"""Multiples of a global candidate's natural sizes tried, each parameter alone and with
either sign (the first-order step from a biased baseline may point the wrong way)."""


def _line_search(problem, current, accepted, c, drop, guess, sizes):
    """The chi2 drop along a candidate's first-order step, the model otherwise held:
    ``chi2(start + a (guess - start))`` for the :data:`LINE_STEPS` (bounded below by
    the parameters' minimum), which sees what a first-order score misses for a large
    change (a strong dashpot flattens a peak, it does not shift it linearly). A step
    clamped at a physical bound is replaced by the parameters' natural ``sizes`` (so a
    stiff spring that the current fit half-absorbed is still tried). Returns (drop, best
    point)."""
    start = np.array([p.start for p in c.fitted])
    step = guess - start
    size = np.array([sizes[k] for k in c.keys()])
    if not np.any(step):  # clamped at a bound: try it at its natural sizes instead
        step = size
    terms = tuple(x for a in accepted for x in a.terms(start=_fitted_own(a, current.theta)))
    predict = problem.predict(terms + c.terms())
    best = (drop, guess)
    low = np.array([-np.inf if p.minimum is None else p.minimum for p in c.fitted])
    points = [start + a * step for a in LINE_STEPS]
    if c.node is None:  # a global effect: each parameter alone, both signs, by size
        for i in range(len(start)):
            for a in NATURAL_STEPS:
                for sign in (1.0, -1.0):
                    points.append(start + sign * a * size * (np.arange(len(start)) == i))
    for point in points:
        point = np.maximum(point, low)
        theta = {**current.theta, **{k: float(v) for k, v in zip(c.keys(), point,
                                                                  strict=True)}}
        try:
            chi2 = problem.chi2(np.asarray(predict(theta)))
        except (ModelError, ValueError):
            continue
        if current.chi2 - chi2 > best[0]:
            best = (current.chi2 - chi2, point)
    return best


def _screen(problem, current, cands, accepted, refs, step, tried, *, per_effect=3):
    """Every candidate's chi2 drop, best first: (drop, candidate, guess). Point
    attachments (springs, dashpots, masses) get their exact profile over a grid of
    strengths (:func:`~.screen.point_profiles`); the others the first-order (score) drop,
    and, for the ``per_effect`` best of each effect, the drop along that step
    (:func:`_line_search`)."""
    out = []
    todo = [c for c in cands if not any(c.label == a.label for a in accepted)]
    sizes = {k: v for c in todo for k, v in c.scales(refs).items()}
    exact = point_profiles(problem, current, todo, sizes)
    for c in todo:
        if c.label in exact:  # point attachments: the exact profile over strengths
            drop, strength, adapt = exact[c.label]
            out.append((drop, c, np.array([strength]), dict(zip(current.names, adapt,
                                                               strict=True))))
            continue
        scales = c.scales(refs)
        pc = replace(problem, scales={**problem.scales, **scales})
        try:
            cols = candidate_columns(pc, current, c.terms(), scales)
        except (ModelError, ValueError) as exc:
            tried.append(Tried(step, c.label, c.effect, c.options, float("nan"),
                               status=refit_error(exc)))
            continue
        start = np.array([p.start for p in c.fitted])
        drop, guess = score(current, cols, start, [p.minimum for p in c.fitted])
        out.append((drop, c, guess, {}))
    out.sort(key=lambda s: -s[0])
    lined, count = [], {}
    for drop, c, guess, adapt in out:
        count[c.effect] = count.get(c.effect, 0) + 1
        if count[c.effect] <= per_effect and c.label not in exact:
            pc = replace(problem, scales={**problem.scales, **c.scales(refs)})
            drop, guess = _line_search(pc, current, accepted, c, drop, guess,
                                       c.scales(refs))
        lined.append((drop, c, guess, adapt))
    return sorted(lined, key=lambda s: -s[0])


def _refit(problem, current, accepted, c, drop, guess, refs, n, step, tried, *,
           declared_start=None):
    """A candidate's quick refit with the declared parameters and the effects found:
    (delta BIC, candidate, fit, status) or None when it fails (recorded in ``tried``).
    The parameters start at ``current`` (or ``declared_start``), the candidate's at
    ``guess``."""
    start = {p.name: float(v) for p, v in zip(c.fitted, guess, strict=True)}
    # steps and trust region in units of the larger of the natural size and the start
    # (a strong effect found by the screening is many natural sizes away from zero)
    scales = {k: max(v, abs(start[k.rsplit(".", 1)[1]]))
              for k, v in c.scales(refs).items()}
    pc = replace(problem, scales={**problem.scales, **scales})
    terms = tuple(x for a in accepted for x in a.terms(start=_fitted_own(a, current.theta)))
    theta = current.theta if declared_start is None else declared_start
    try:
        cf = fit(pc, terms + c.terms(start=start), start=theta, quick=True)
    except (IdentifiabilityError, ModelError, ValueError, np.linalg.LinAlgError) as exc:
        tried.append(Tried(step, c.label, c.effect, c.options, drop, status=refit_error(exc)))
        return None
    dbic = float(n * np.log(current.chi2 / cf.chi2) - len(c.fitted) * np.log(n))
    own = {p.name: cf.theta[f"{c.label}.{p.name}"] for p in c.fitted}
    status = _bounds_ok(c, cf.theta, {}, c.scales(refs)) or ("refitted" if cf.converged
                                              else "refitted (iteration cap)")
    tried.append(Tried(step, c.label, c.effect, c.options, drop, dbic, own,
                       c.effect_values(own), status))
    return dbic, c, cf, status


def _fitted_own(c: Candidate, theta: Mapping[str, float]) -> dict[str, float]:
    return {p.name: float(theta[f"{c.label}.{p.name}"]) for p in c.fitted
            if f"{c.label}.{p.name}" in theta}


__all__ = ["DiagnoseSettings", "Found", "Residual", "Tried", "diagnose"]
