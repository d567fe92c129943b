"""Screening candidates and refitting the promising ones.

A step of the diagnosis tries every candidate against the current fit. Screening is
cheap and approximate (:func:`screen`): point attachments get their exact chi2 profile
over a grid of strengths (:func:`~.screen.point_profiles`), the others the first-order
(score) drop of :func:`~.fit.score` and, for the best few of each effect, a line search
along that step. The screen ranks; refits decide. :func:`shortlist` picks the screened
candidates worth a refit, :func:`refit` fits one with the declared parameters and the
effects already found (quick: forward differences, capped iterations), and
:func:`full_refit` fits the best few completely, each compared through the estimator at
its own model.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np

from truthbench.diagnose.candidates import Candidate, bind_levels
from truthbench.diagnose.fit import (
    Fit,
    Problem,
    candidate_columns,
    fit,
    refit_error,
    score,
    with_offsets,
)
from truthbench.diagnose.residual import Residual, matched_delay
from truthbench.diagnose.screen import beside_best, point_profiles, structural_profiles
from truthbench.errors import IdentifiabilityError, ModelError

BOUND_SLACK = 0.05
"""A fitted value may cross its physical bound by this fraction of its natural size (or
two standard deviations, if more) and still count as at the bound: a fit of an effect
whose true value sits on the bound (a joint without damping) lands on either side."""

LINE_STEPS = (0.25, 0.5, 1.0, 2.0, 4.0, 8.0, 16.0, 64.0)
"""Multiples of a candidate's first-order step tried by :func:`line_search`."""

NATURAL_STEPS = (0.3, 1.0, 3.0, 10.0)
"""Multiples of a global candidate's natural sizes tried, each parameter alone and with
either sign (the first-order step from a biased baseline may point the wrong way)."""

PHASE_EFFECTS = ("time_delay", "actuator_dynamics", "actuator_resonance", "sensor_dynamics",
                 "sensor_lag")
"""Effects whose phase falls as ``-omega tau`` at low frequency: started from the data's
matched delay."""

GLOBAL_STRUCTURE = ("boundary", "element_physics", "sag")
"""Candidates that change the structure everywhere (and may move its sharpest modes by
many of their widths): every one is line-searched, through the estimator's leakage at
every point."""

EXACT_LEAKAGE = ("boundary",)
"""Candidates fitted with the estimator's leakage computed at every parameter value: a
support's stiffness moves the suspension modes, a tenth of a line wide, by tens of
percent, and with the leakage offset held from where the fit starts, the fit stays near
its start (study seed 20261125, trial 2: a 1.83x stiffer suspension started at 1.35x
ends at 1.36x). The line search's best point starts it. (Even so, the chi2 ripples along
the stiffness: a mode narrower than the force's line spacing is seen only at those
lines, and a start far from the optimum can stop in a ripple.)"""


def is_global(c: Candidate) -> bool:
    """Whether ``c`` is one of the :data:`GLOBAL_STRUCTURE` candidates (not located)."""
    return c.node is None and c.effect in GLOBAL_STRUCTURE


REFIT_ERRORS = (IdentifiabilityError, ModelError, ValueError, np.linalg.LinAlgError)


@dataclass(frozen=True)
class Tried:
    """A candidate tried at one step: screened, refitted, scored."""

    step: int
    label: str
    effect: str
    options: dict
    screen_drop: float
    delta_bic: float = float("nan")
    fitted: dict = None  # type: ignore[assignment]
    parameters: dict = None  # type: ignore[assignment]
    status: str = "screened"

    def __post_init__(self):
        for name in ("fitted", "parameters"):
            if getattr(self, name) is None:
                object.__setattr__(self, name, {})


@dataclass(frozen=True)
class Screened:
    """A screened candidate: its chi2 drop, its start (guess) and the first-order step
    of the declared parameters that goes with it."""

    drop: float
    candidate: Candidate
    guess: np.ndarray
    adapt: dict


@dataclass(frozen=True)
class Refit:
    """A candidate refitted with the declared parameters and the effects found."""

    delta_bic: float
    candidate: Candidate
    fit: Fit
    status: str
    problem: Problem | None = None

    @property
    def physical(self) -> bool:
        return not self.status.startswith("unphysical")


def bounds_ok(cand: Candidate, values: Mapping[str, float], std: Mapping[str, float],
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


def crossed(cand: Candidate, values: Mapping[str, float]) -> dict[str, float]:
    """The candidate's fitted parameters beyond a physical bound in ``values`` (no
    slack), own name -> the bound crossed."""
    out = {}
    for p in cand.fitted:
        v = values[f"{cand.label}.{p.name}"]
        if p.minimum is not None and v < p.minimum:
            out[p.name] = p.minimum
        elif p.maximum is not None and v > p.maximum:
            out[p.name] = p.maximum
    return out


def partly_crossed(cand: Candidate, values: Mapping[str, float]) -> dict[str, float]:
    """:func:`crossed` when some but not all of the fitted parameters crossed a bound
    (the constrained fit holds those at it and fits the others), else empty."""
    held = crossed(cand, values)
    return held if len(held) < len(cand.fitted) else {}


def delta_bic(n: float, chi2_without: float, chi2_with: float, k: int) -> float:
    """``n ln(chi2_without / chi2_with) - k ln(n)``: the evidence for ``k`` added
    parameters, the noise scale profiled out (``n`` independent values)."""
    return float(n * np.log(chi2_without / chi2_with) - k * np.log(n))


def adapted(theta: Mapping[str, float], step: Mapping[str, float]) -> dict[str, float]:
    """``theta`` moved by a first-order step of its parameters, each change held within
    half the parameter's size (a linearised step from a biased fit can overshoot)."""
    out = dict(theta)
    for k, d in step.items():
        limit = 0.5 * abs(theta[k]) if theta[k] else abs(d)
        out[k] = theta[k] + float(np.clip(d, -limit, limit))
    return out


def fitted_own(c: Candidate, theta: Mapping[str, float]) -> dict[str, float]:
    """A candidate's fitted parameters in ``theta``, by their own names."""
    return {p.name: float(theta[f"{c.label}.{p.name}"]) for p in c.fitted
            if f"{c.label}.{p.name}" in theta}


def terms_of(accepted: Sequence[Candidate], theta: Mapping[str, float]) -> tuple:
    """The effect terms of the accepted candidates at their values in ``theta``."""
    return tuple(x for a in accepted for x in a.terms(start=fitted_own(a, theta)))


#: Phase candidates' parameters that lag the phase by ``omega x`` at low frequency (a
#: delay, a first-order lag's time constant, the ``b`` of a second-order low-pass), s.
LAG_PARAMETERS = ("delay_s", "tau_s", "b_s")


def accepted_lag(accepted: Sequence[Candidate], theta: Mapping[str, float]) -> float:
    """The low-frequency phase lag (s) of the accepted phase effects at ``theta``."""
    return sum(v for a in accepted if a.effect in PHASE_EFFECTS
               for k, v in fitted_own(a, theta).items() if k in LAG_PARAMETERS)


def signature_start(c: Candidate, views: Residual, tests, model, delay: float | None
                    ) -> np.ndarray | None:
    """Starting values a residual signature gives a candidate, or None: the matched
    delay (``delay``, the chi2 profile of a pure delay) for a delay or a low-pass (whose
    phase falls as -omega tau at low frequency), the magnitude ratio less 1 for a gain
    (of one channel, or of all)."""
    if c.effect in PHASE_EFFECTS:
        if delay is None:
            return None
        # a delay, a first-order lag's time constant, or the b (s) of a second-order
        # low-pass 1 / (a s^2 + b s + 1): all lag the phase by omega tau at low frequency
        return np.array([delay if p.name in LAG_PARAMETERS else p.start
                         for p in c.fitted])
    if c.effect == "channel_gain":
        ratios = [ch.magnitude_ratio for ch in views.channels
                  if ch.output == c.options["sensor"]]
        return np.array([float(np.mean(ratios)) - 1.0]) if ratios else None
    if c.effect == "sensor_bias":
        return np.array([float(np.mean([ch.magnitude_ratio for ch in views.channels]))
                         - 1.0])
    return None


def _lines(tests) -> np.ndarray:
    """Every value's frequency in the problem's order (test, line, output, input), Hz."""
    return np.concatenate([np.broadcast_to(t.freq_hz[:, None, None], t.H.shape).ravel()
                           for t in tests])


def data_delay(tests, model: np.ndarray, views: Residual) -> float:
    """The matched delay of the data against ``model`` (every test), s."""
    data = np.concatenate([t.H.ravel() for t in tests])
    w = np.concatenate([1.0 / t.sigma.ravel() for t in tests])
    return matched_delay(_lines(tests), data, model, w, views.delay_s)


def delay_drop(problem, tests, model: np.ndarray, delay: float) -> float:
    """The chi2 drop of delaying ``model`` by ``delay`` (s): an exact profile point of a
    pure delay against the model it is read against, which a phase candidate's refit
    started there reaches at least, where a first-order score from zero delay sees
    nothing (a phase error of radians)."""
    return problem.chi2(model) - problem.chi2(
        model * np.exp(-2j * np.pi * _lines(tests) * delay))


def line_search(problem, current, accepted, c, drop, guess, sizes):
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
    # a global candidate (a support, the element) may move an under-resolved mode far
    # (a suspension mode a tenth of a line wide): its points are judged through the
    # estimator's leakage at each, not the current model's held leakage
    predict = problem.predict(terms_of(accepted, current.theta) + c.terms(),
                              estimator=is_global(c))
    best = (drop, guess)
    low = np.array([-np.inf if p.minimum is None else p.minimum for p in c.fitted])
    high = np.array([np.inf if p.maximum is None else p.maximum for p in c.fitted])
    points = [start + a * step for a in LINE_STEPS]
    if c.node is None:  # a global effect: each parameter alone, both signs, by size
        for i in range(len(start)):
            for a in NATURAL_STEPS:
                for sign in (1.0, -1.0):
                    points.append(start + sign * a * size * (np.arange(len(start)) == i))
    for point in points:
        point = np.clip(point, low, high)
        theta = {**current.theta, **{k: float(v) for k, v in zip(c.keys(), point,
                                                                  strict=True)}}
        try:
            chi2 = problem.chi2(np.asarray(predict(theta)))
        except (ModelError, ValueError):
            continue
        if current.chi2 - chi2 > best[0]:
            best = (current.chi2 - chi2, point)
    return best


def screen(problem: Problem, current: Fit, cands, accepted, refs, step: int,
           tried: list, *, per_effect: int = 2) -> list[Screened]:
    """Every candidate's chi2 drop, best first.

    Point attachments (springs, dashpots, masses) get their exact profile over a grid of
    strengths (:func:`~.screen.point_profiles`), at the nodes and at the element
    midpoints beside the best nodes (:func:`~.screen.beside_best`), joints and friction
    theirs over a grid of their parameters (:func:`~.screen.structural_profiles`); the
    others the first-order (score) drop, and, for the ``per_effect`` best of each effect
    and every global one (:data:`GLOBAL_STRUCTURE`: all supports and each alone rank
    differently at first order and exactly), the drop along that step
    (:func:`line_search`). A candidate the model refuses is
    recorded in ``tried``.
    """
    out = []
    todo = [c for c in cands if not any(c.label == a.label for a in accepted)]
    sizes = {k: v for c in todo for k, v in c.scales(refs).items()}
    exact = point_profiles(problem, current, todo, sizes)
    # and between the nodes, beside the best of them
    between = [m for m in beside_best(todo, exact, problem.plant)
               if m.label not in exact and not any(m.label == a.label for a in accepted)]
    if between:
        sizes.update({k: v for c in between for k, v in c.scales(refs).items()})
        exact.update(point_profiles(problem, current, between, sizes))
        todo += between
    exact.update(structural_profiles(problem, current, todo, sizes))
    for c in todo:
        if c.label in exact:  # low-rank structural changes: the exact profile on a grid
            drop, point, adapt = exact[c.label]
            out.append(Screened(drop, c, np.atleast_1d(np.asarray(point, float)),
                                dict(zip(current.names, adapt, strict=True))))
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
        out.append(Screened(drop, c, guess, {}))
    out.sort(key=lambda s: -s.drop)
    lined, count = [], {}
    for s in out:
        c = s.candidate
        count[c.effect] = count.get(c.effect, 0) + 1
        if (count[c.effect] <= per_effect or is_global(c)) and c.label not in exact:
            pc = replace(problem, scales={**problem.scales, **c.scales(refs)})
            drop, guess = line_search(pc, current, accepted, c, s.drop, s.guess,
                                      c.scales(refs))
            s = replace(s, drop=drop, guess=guess)
        lined.append(s)
    return sorted(lined, key=lambda s: -s.drop)


def shortlist(screened: Sequence[Screened], *, best: int, factor: float
              ) -> list[Screened]:
    """The screened candidates worth a refit: the ``best`` first, and the best of every
    other effect (its best location) screened within ``factor`` of the best drop.
    Screens of different effects are approximate in different ways (an exact point
    attachment on a grid of strengths against a joint's line search), so one effect's
    many locations must not crowd out another's best."""
    if not screened:
        return []
    top = screened[0].drop
    chosen = list(screened[:best])
    kinds = {s.candidate.effect for s in chosen}
    for s in screened[best:]:
        if s.candidate.effect not in kinds and s.drop > top / factor:
            chosen.append(s)
            kinds.add(s.candidate.effect)
    return chosen


def refit(problem, current, accepted, c, drop, guess, refs, n, step, tried, *,
          declared_start=None) -> Refit | None:
    """A candidate's quick refit with the declared parameters and the effects found, or
    None when it fails (recorded in ``tried``). The parameters start at ``current`` (or
    ``declared_start``), the candidate's at ``guess``."""
    start = {p.name: float(v) for p, v in zip(c.fitted, guess, strict=True)}
    # steps and trust region in units of the larger of the natural size and the start
    # (a strong effect found by the screening is many natural sizes away from zero)
    scales = {k: max(v, abs(start[k.rsplit(".", 1)[1]]))
              for k, v in c.scales(refs).items()}
    pc = replace(problem, scales={**problem.scales, **scales})
    theta = current.theta if declared_start is None else declared_start
    terms = terms_of(accepted, current.theta) + c.terms(start=start)
    exact = c.effect in EXACT_LEAKAGE
    try:
        if not exact:
            # the estimator's leakage where the refit starts (the current model's is
            # wrong where the candidate moves a sharp mode by more than a line)
            pc = with_offsets(pc, terms=terms, theta={**pc.predictor(terms).theta0, **theta})
        cf = fit(pc, terms, start=theta, quick=True, estimator=exact)
    except REFIT_ERRORS as exc:
        tried.append(Tried(step, c.label, c.effect, c.options, drop, status=refit_error(exc)))
        return None
    dbic = delta_bic(n, current.chi2, cf.chi2, len(c.fitted))
    own = {p.name: cf.theta[f"{c.label}.{p.name}"] for p in c.fitted}
    status = bounds_ok(c, cf.theta, {}, c.scales(refs)) or ("refitted" if cf.converged
                                             else "refitted (iteration cap)")
    tried.append(Tried(step, c.label, c.effect, c.options, drop, dbic, own,
                       c.effect_values(own), status + _held(c)))
    held = partly_crossed(c, cf.theta) if status.startswith("unphysical") else {}
    if held:  # the constrained fit: those parameters held at their bound
        pinned = c.pin(held)
        return refit(problem, current, accepted, pinned, drop,
                     np.array([own[p.name] for p in pinned.fitted]), refs, n, step, tried,
                     declared_start={k: cf.theta[k] for k in current.names})
    return Refit(dbic, c, cf, status)


def _held(c: Candidate) -> str:
    return "".join(f"; {k} held at its bound {v:g}" for k, v in c.pinned)


def full_refit(problem: Problem, current: Fit, accepted, quick: Refit, refs, n, tests
               ) -> Refit:
    """A quick refit completed: every parameter to convergence with central differences,
    through the estimator's leakage at the candidate's own model (the offsets of the
    current model are wrong where a candidate moves a sharp mode by more than a line),
    friction's levels recomputed with its own damping in.

    Raises
    ------
    IdentifiabilityError, ModelError, ValueError, LinAlgError
    """
    c = quick.candidate
    pc = replace(problem, scales={**problem.scales, **c.scales(refs)})
    exact = c.effect in EXACT_LEAKAGE  # the leakage at every value: no held offsets
    full = fit(pc if exact else with_offsets(pc, quick.fit), quick.fit.terms,
               start=quick.fit.theta, estimator=exact)
    if c.levels is not None:  # friction: the levels with its own damping in
        c, full = relevel(with_offsets(pc, full), c, accepted, full, tests)
    pc = with_offsets(pc, full)
    full = fit(pc, full.terms, start=full.theta)
    dbic = delta_bic(n, current.chi2, full.chi2, len(c.fitted))
    status = bounds_ok(c, full.theta, full.std, c.scales(refs))
    held = partly_crossed(c, full.theta) if status else {}
    if held:  # the constrained fit: those parameters held at their bound
        c = c.pin(held)
        full = fit(pc, terms_of(accepted, full.theta) + c.terms(start=fitted_own(c, full.theta)),
                   start=full.theta)
        dbic = delta_bic(n, current.chi2, full.chi2, len(c.fitted))
        status = bounds_ok(c, full.theta, full.std, c.scales(refs))
    return Refit(dbic, c, full, (status or "refitted") + _held(c), pc)


def relevel(problem, c: Candidate, accepted, fit_, tests, passes: int = 2):
    """Refit a friction candidate with its levels recomputed from the model that
    includes its own equivalent damping (the statistical linearisation's fixed point:
    friction lowers the response it is linearised at)."""
    for _ in range(passes):
        pred = problem.predictor(fit_.terms)
        (c,) = bind_levels([c], lambda t, pred=pred, th=fit_.theta: pred.hardware(
            th, t.actuators, t.sensors, test=t.name), tests)
        own = fitted_own(c, fit_.theta)
        fit_ = fit(problem, terms_of(accepted, fit_.theta) + c.terms(start=own),
                   start=fit_.theta)
    return c, fit_


__all__ = ["BOUND_SLACK", "Refit", "Screened", "Tried", "adapted", "bounds_ok", "crossed",
           "delta_bic", "is_global", "partly_crossed",
           "full_refit", "line_search", "refit", "relevel", "screen", "shortlist",
           "signature_start"]
