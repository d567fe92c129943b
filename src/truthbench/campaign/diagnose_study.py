"""A Monte Carlo study of the diagnosis itself: inject known effects, diagnose, score.

Each trial of ``truthbench diagnose-study CAMPAIGN`` injects none, one or two effects
drawn from ``[diagnose.study] inject`` (distinct effects; probabilities
``clean_fraction`` and ``two_fraction``), each at a strength drawn log-uniformly from
its range (``[diagnose.study.strength]``, else :data:`DEFAULT_STRENGTH`) and a location
drawn uniformly (an interior node for effects at a station, a sensor for a channel gain;
the first measured translational direction, or its bending rotation for a joint), on top
of the campaign's own truth. It simulates every test of the campaign, diagnoses the
FRFs against the campaign's nominal model with its ``[update] parameters`` declared, and
scores what was found against what was injected. Draws come from the trial's own seed
stream (``SeedSequence(seed, spawn_key=(trial, 7))``), so results do not depend on the
worker count.

Scores (:class:`StudyResult`): the confusion of the first effect found against the
injected ones, detection against strength, false alarms on clean trials, both effects
found for two injected, location error in elements, and the error before and after.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from truthbench.campaign.runner import simulate_one
from truthbench.campaign.spec import CampaignSpec
from truthbench.effects import EFFECTS, parse_effect
from truthbench.errors import CampaignError

DEFAULT_STRENGTH = {
    "time_delay": ("delay_s", 2e-4, 3e-3),
    "actuator_dynamics": ("bandwidth_hz", 100.0, 2000.0),
    "sensor_dynamics": ("bandwidth_hz", 150.0, 3000.0),
    "channel_gain": ("gain_error", 0.05, 0.5),
    "sensor_bias": ("gain_error", 0.05, 0.5),
    "added_mass": ("mass_kg", 0.005, 0.08),
    "sensor_mass": ("mass_kg", 0.002, 0.03),
    "grounded_dashpot": ("damping_n_s_m", 0.5, 15.0),
    "grounded_spring": ("stiffness_n_m", 200.0, 5000.0),
    "joint": ("stiffness_loss", 0.05, 0.5),
    "boundary": ("stiffness_rel", 0.1, 1.0),
    "element_physics": ("scale", 3.0, 40.0),
    "sag": ("scale", 300.0, 3000.0),
}
"""Effect -> (its parameter, low, high): the default strength ranges (log-uniform)."""

_BENDING = {"z": "ry", "y": "rz"}


@dataclass(frozen=True)
class Injected:
    """One effect a trial injected."""

    effect: str
    parameter: str
    value: float
    options: dict
    node: int | None

    def entry(self) -> dict:
        return {"name": self.effect, **self.options, "parameters": {self.parameter: self.value}}


def _study_spec(spec: CampaignSpec) -> CampaignSpec:
    """The campaign with a station ``n<k>`` at every node (effects are placed there)."""
    n = spec.plant.n_elements
    stations = dict(spec.plant.stations)
    stations.update({f"n{k}": k / n for k in range(n + 1) if f"n{k}" not in stations})
    return spec.model_copy(update={"plant": spec.plant.model_copy(update={
        "stations": stations})})


def draw_injection(spec: CampaignSpec, trial: int, seed: int) -> tuple[Injected, ...]:
    """The effects trial ``trial`` injects (none, one or two), from its own stream."""
    study = spec.diagnose.study
    rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(trial, 7)))
    u = rng.random()
    count = 0 if u < study.clean_fraction else (
        2 if u < study.clean_fraction + study.two_fraction else 1)
    names = list(rng.permutation(study.inject))[:count]
    sensors = [s for s in spec.sensors if s.quantity != "strain"]
    directions = [s.direction for s in sensors if s.direction in ("x", "y", "z")]
    out = []
    for name in names:
        param, lo, hi = DEFAULT_STRENGTH.get(name, (None, None, None))
        if name in study.strength:
            lo, hi = study.strength[name]
        if param is None:
            raise CampaignError(f"{spec.source}: key 'diagnose.study.inject': no default "
                                f"strength for {name!r}; give [diagnose.study.strength] "
                                f"{name} = [low, high]")
        value = float(np.exp(rng.uniform(np.log(lo), np.log(hi))))
        node = int(rng.integers(1, spec.plant.n_elements))
        options: dict = {}
        cls = EFFECTS[name]
        where = None
        if "station" in cls.options:
            options["station"] = f"n{node}"
            where = node
        if "direction" in cls.options and directions:
            d = directions[int(rng.integers(len(directions)))]
            options["direction"] = _BENDING.get(d, d) if name == "joint" else d
        if "sensor" in cls.options:
            options["sensor"] = int(rng.integers(len(spec.sensors)))
        out.append(Injected(name, param, value, options, where))
    return tuple(out)


def study_trial(spec: CampaignSpec, trial: int, seed: int) -> dict:
    """One trial: inject, simulate, diagnose, score. Returns one row (a dict)."""
    from truthbench.diagnose import diagnose

    sspec = _study_spec(spec)
    injected = draw_injection(spec, trial, seed)
    extra = [parse_effect(i.entry(), f"diagnose.study trial {trial}", spec.source)
             for i in injected]
    data = [simulate_one(sspec, trial, j, seed, extra).frf for j in range(len(spec.tests))]
    diag = diagnose(data, spec.make_plant(), spec.nominal_parameters(),
                    spec.update.parameters, identify_modes=False,
                    **spec.diagnose.settings())
    found = [(f.effect, f.node, f.options) for f in diag.found]
    inj_names = {i.effect for i in injected}
    row = {
        "trial": trial, "n_injected": len(injected),
        "injected": ";".join(i.effect for i in injected) or "none",
        "found": ";".join(f[0] for f in found) or "none",
        "first_found": found[0][0] if found else "none",
        "first_correct": bool(found and found[0][0] in inj_names) if injected else None,
        "all_found": inj_names <= {f[0] for f in found} if injected else None,
        "false_alarm": bool(found) if not injected else None,
        "frf_error_before": diag.frf_error_before, "frf_error_after": diag.frf_error_after,
        "reduced_chi2_before": diag.before.reduced_chi2,
        "reduced_chi2_after": diag.after.reduced_chi2,
    }
    for k, inj in enumerate(injected):
        match = next((f for f in diag.found if f.effect == inj.effect), None)
        row[f"effect{k}"] = inj.effect
        row[f"strength{k}"] = inj.value
        row[f"parameter{k}"] = inj.parameter
        row[f"fitted{k}"] = match.parameters.get(inj.parameter, np.nan) if match else np.nan
        row[f"location_error{k}"] = (abs(match.node - inj.node) if match and inj.node
                                     is not None and match.node is not None else np.nan)
    return row


def run_study(spec: CampaignSpec, *, trials: int | None = None, seed: int | None = None,
              n_jobs: int = 1):
    """Every trial of the study (joblib; identical for any worker count).

    Returns
    -------
    StudyResult
    """
    import pandas as pd
    from joblib import Parallel, delayed
    from threadpoolctl import threadpool_limits

    n = spec.diagnose.study.trials if trials is None else int(trials)
    if n < 1:
        raise CampaignError(f"trials must be >= 1; got {n}")
    seed = spec.campaign.seed if seed is None else int(seed)

    def one(i):
        with threadpool_limits(limits=1, user_api="blas"):
            return study_trial(spec, i, seed)

    rows = Parallel(n_jobs=n_jobs)(delayed(one)(i) for i in range(n))
    return StudyResult(spec.campaign.name, seed, pd.DataFrame(rows))


@dataclass(frozen=True, eq=False)
class StudyResult:
    """The trials of a diagnose-study (one row each) and their summaries."""

    campaign: str
    seed: int
    trials: object
    """pandas.DataFrame: trial, injected, found, first_correct, all_found, false_alarm,
    errors before and after, and per injected effect its strength, fitted value and
    location error (elements)."""

    def to_pandas(self, table: str = "trials"):
        """``"trials"``, ``"confusion"`` (first effect found against the injected one,
        single-effect trials), ``"detection"`` (rate per effect and strength quartile),
        or ``"summary"``."""
        import pandas as pd

        df = self.trials
        if table == "trials":
            return df
        single = df[df.n_injected == 1]
        if table == "confusion":
            return pd.crosstab(single.injected, single.first_found, margins=False)
        if table == "detection":
            rows = []
            for name, g in single.groupby("injected"):
                q = np.quantile(g.strength0, [0.0, 0.25, 0.5, 0.75, 1.0])
                for a, b in zip(q[:-1], q[1:], strict=True):
                    sel = g[(g.strength0 >= a) & (g.strength0 <= b)]
                    rows.append({"effect": name, "parameter": g.parameter0.iloc[0],
                                 "strength_low": a, "strength_high": b, "trials": len(sel),
                                 "first_correct": float(sel.first_correct.mean())
                                 if len(sel) else np.nan})
            return pd.DataFrame(rows)
        if table == "summary":
            clean = df[df.n_injected == 0]
            two = df[df.n_injected == 2]
            loc = pd.concat([df.get("location_error0", pd.Series(dtype=float)),
                             df.get("location_error1", pd.Series(dtype=float))]).dropna()
            red = (df.frf_error_before / df.frf_error_after)[df.n_injected > 0]
            return pd.DataFrame([{
                "trials": len(df), "clean trials": len(clean),
                "nothing found on clean": float((~clean.false_alarm.astype(bool)).mean())
                if len(clean) else np.nan,
                "single-effect trials": len(single),
                "right effect first": float(single.first_correct.astype(bool).mean())
                if len(single) else np.nan,
                "two-effect trials": len(two),
                "both found": float(two.all_found.astype(bool).mean()) if len(two) else np.nan,
                "located within one element": float((loc <= 1).mean()) if len(loc) else np.nan,
                "median error reduction": float(red.median()) if len(red) else np.nan,
            }])
        raise ValueError(f"table must be trials, confusion, detection or summary; got "
                         f"{table!r}")

    def plot(self):
        """Detection rate against strength, one panel per effect (single-effect trials).

        Returns
        -------
        matplotlib.figure.Figure
        """
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        single = self.trials[self.trials.n_injected == 1]
        names = sorted(single.injected.unique())
        fig, axes = plt.subplots(1, max(len(names), 1), figsize=(2.6 * max(len(names), 1),
                                                                 2.8), squeeze=False)
        for ax, name in zip(axes[0], names, strict=False):
            g = single[single.injected == name].sort_values("strength0")
            ax.semilogx(g.strength0, g.first_correct.astype(float), "o", ms=4)
            ax.set_title(name, fontsize="small")
            ax.set_xlabel(g.parameter0.iloc[0], fontsize="small")
            ax.set_ylim(-0.1, 1.1)
        axes[0, 0].set_ylabel("right effect first (1) or not (0)")
        fig.tight_layout()
        return fig
