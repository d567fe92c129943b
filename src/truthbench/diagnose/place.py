"""Placing a found attachment between the model's nodes.

A point attachment (a mass, a spring, a dashpot) found at a node is moved along the two
elements either side of it to where the data put it: its exact chi2 profile first, then a
parabola through three quick refits. A joint, a concentrated hinge found at an element's
centre, is moved by quick refits at halving spacings either side of the best point, then
a parabola. The refit replaces the found one when it explains the data better.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from truthbench.diagnose.candidates import at_fraction
from truthbench.diagnose.fit import evaluate, refit_error
from truthbench.diagnose.screen import POINT_EFFECTS, position_profile
from truthbench.diagnose.search import (
    REFIT_ERRORS,
    Refit,
    Tried,
    adapted,
    fitted_own,
    full_refit,
    refit,
)


class _Placement:
    """The placing steps of :class:`~truthbench.diagnose.core._Diagnosis` (a mixin: they
    use its settings, references and record of candidates tried)."""

    def refine_position(self, problem, current, accepted, chosen: Refit, n, step, tests,
                        reach: int = 1) -> Refit:
        """A point attachment's position searched between the nodes next to it: its
        exact chi2 profile along ``reach`` elements either side (eight points each, then
        eight between the best and its neighbours), and the best point refitted. The
        refit replaces the chosen one when it explains the data better."""
        c = chosen.candidate
        if c.effect == "joint" and c.node is not None:
            return self.refine_hinge(problem, current, accepted, chosen, n, step, tests,
                                     reach)
        if c.effect not in POINT_EFFECTS or c.node is None:
            return chosen
        plant = problem.plant
        N = plant.n_elements
        value = abs(float(next(iter(fitted_own(c, chosen.fit.theta).values()))))
        if not value > 0:
            return chosen
        strengths = value * np.logspace(-0.4, 0.4, 17)
        lo, hi = max(c.node - reach, 0) / N, min(c.node + reach, N) / N
        # the profile adapts the other parameters to first order from where it starts:
        # start from the chosen fit's values of them (the declared parameters moved for
        # this attachment), without the attachment
        own = set(chosen.fit.terms[-1].keys()) if chosen.fit.terms else set()
        try:
            near = evaluate(problem, current.terms, current.names,
                            {**current.theta, **{k: v for k, v in chosen.fit.theta.items()
                                                 if k in current.names and k not in own}})
        except REFIT_ERRORS:
            near = current
        best = None
        d = 1.0 / (8 * N)  # an eighth of an element
        for fractions in (np.linspace(lo, hi, int(round((hi - lo) / d)) + 1), None):
            if fractions is None:
                if best is None:
                    return chosen
                fractions = np.clip(best[0] + d * np.linspace(-1, 1, 9), lo, hi)
            prof = position_profile(problem, near, c, fractions, strengths)
            top = max(prof, key=lambda x: x[1], default=None)
            if top is not None and (best is None or top[1] > best[1]):
                best = top
        fraction, drop, strength, adapt = best
        start = adapted(near.theta, dict(zip(near.names, adapt, strict=True)))

        def quick_at(fr):
            moved = at_fraction(c, fr, N)
            pm = replace(problem, plant=replace(plant, stations={
                **plant.stations, moved.options["station"]: float(fr)}))
            return pm, refit(pm, current, accepted, moved, drop, np.array([strength]),
                             self.refs, n, step, self.tried, declared_start=start)

        # the profile's first-order adaptation of the declared parameters blurs the
        # position by a fraction of an element: a parabola through three quick refits
        h = d / 2
        trio = [(fr, quick_at(fr)) for fr in np.clip(fraction + h * np.arange(-1, 2), lo, hi)]
        if all(q is not None and q.physical for _, (_, q) in trio) and len(
                {fr for fr, _ in trio}) == 3:
            x = np.array([fr for fr, _ in trio])
            y = np.array([q.fit.chi2 for _, (_, q) in trio])
            a, b, _ = np.polyfit(x - x[1], y, 2)
            if a > 0:
                fraction = float(np.clip(x[1] - b / (2 * a), x[0] - h, x[2] + h))
        if abs(fraction * N - round(fraction * N)) < 1e-6:
            return chosen  # the best point is a node: the candidate as it is
        pm, quick = quick_at(fraction)
        if quick is None or not quick.physical:
            return chosen
        try:
            full = full_refit(pm, current, accepted, quick, self.refs, n, tests)
        except REFIT_ERRORS as exc:
            m = quick.candidate
            self.tried.append(Tried(step, m.label, m.effect, m.options, float("nan"),
                                    status=f"full refit: {refit_error(exc)}"))
            return chosen
        return full if full.physical and full.delta_bic > chosen.delta_bic else chosen

    def refine_hinge(self, problem, current, accepted, chosen: Refit, n, step, tests,
                     reach: int = 1) -> Refit:
        """A joint's hinge moved along the article to where the data put it: quick
        refits ``reach`` half elements either side, then at half the spacing either side
        of the best, to a sixteenth of an element, and a parabola through the best
        and its two neighbours; the best point refitted. A joint is a local flexibility
        that the hardware puts where it is, not where the mesh has an element's centre,
        and its fit is sharp in its place (in one study trial, a hinge 0.15 of an
        element off lost 8 % of its delta BIC, 0.4 off 39 %). The refit replaces the
        chosen one when it explains the data better."""
        c = chosen.candidate
        plant = problem.plant
        N = plant.n_elements
        own = fitted_own(c, chosen.fit.theta)
        start_theta = {k: v for k, v in chosen.fit.theta.items() if k in current.names}
        here = float(plant.stations[c.options["station"]])
        seen: dict[float, tuple] = {}

        def quick_at(fr):
            fr = float(np.clip(fr, 0.0, 1.0))
            if fr not in seen:
                moved = at_fraction(c, fr, N)
                pm = replace(problem, plant=replace(plant, stations={
                    **plant.stations, moved.options["station"]: fr}))
                seen[fr] = (pm, refit(pm, current, accepted, moved, float("nan"),
                                      np.array([own[p.name] for p in c.fitted]), self.refs,
                                      n, step, self.tried,
                                      declared_start={**current.theta, **start_theta}))
            return seen[fr]

        def chi2(fr):
            q = quick_at(fr)[1]
            return q.fit.chi2 if q is not None and q.physical else np.inf

        best, d = here, 0.5 * reach / N
        for _ in range(3 + reach.bit_length()):  # down to a sixteenth of an element
            best = min((best - d, best, best + d), key=chi2)
            d /= 2
        d *= 2
        x = np.clip(best + d * np.arange(-1, 2), 0.0, 1.0)
        y = np.array([chi2(fr) for fr in x])
        fraction = best
        if np.all(np.isfinite(y)) and len(set(x)) == 3:
            a, b, _ = np.polyfit(x - x[1], y, 2)
            if a > 0:
                fraction = float(np.clip(x[1] - b / (2 * a), x[0], x[2]))
        if abs(fraction - here) * N < 1e-3 or not np.isfinite(chi2(fraction)):
            return chosen  # where it was found
        pm, quick = quick_at(fraction)
        try:
            full = full_refit(pm, current, accepted, quick, self.refs, n, tests)
        except REFIT_ERRORS:
            return chosen
        return full if full.physical and full.delta_bic > chosen.delta_bic else chosen
