"""A Monte Carlo study of the diagnosis itself: inject known effects, diagnose, score.

Each trial of ``truthbench diagnose-study CAMPAIGN`` injects none, one or two effects
drawn from ``[diagnose.study] inject`` (distinct effects; probabilities
``clean_fraction`` and ``two_fraction``), each at a strength drawn log-uniformly from
its range (``[diagnose.study.strength]``, else :data:`DEFAULT_STRENGTH`) and a place
drawn uniformly along the article (effects at a station), a sensor (a channel gain) and
the first measured translational direction, or its bending rotation for a joint. It
simulates every test of the campaign, diagnoses the FRFs against the campaign's nominal
model with its ``[update] parameters`` declared, and scores what was found against what
was injected (:func:`score`).

The truth comes in two model forms (``[diagnose.study] form``: "other", "same" or
"both", scored side by side on the same draws):

``other``
    not the model's: a mesh :data:`REFINE` times finer (every model node kept, so the
    sensors, shakers and suspension points stay where the model has them), shear
    deformation and rotary inertia (Timoshenko) drawn on or off, each effect at a node
    of the fine mesh (most of them between model nodes), every sensor mounted off the
    beam's axis with cross-axis sensitivity and every shaker off the axis and
    misaligned (:mod:`truthbench.effects.mounting`: the truth has torsion and lateral
    motion in its data, which the model's ideal channels cannot see).
``same``
    the model's own plant, mesh and elements with each effect at the model node nearest
    the other form's place: an exam the diagnosis could have written itself.

A joint's strength is drawn as the stiffness loss of a model element; the other form
injects the same joint, the same equivalent rotational stiffness
(:func:`joint_stiffness`), in its own shorter element. Every test's record length,
averages and window are drawn per trial too (:data:`AVERAGES`, :data:`SEGMENT_FACTORS`,
:data:`WINDOWS`), the same for both forms; the FRFs carry their estimator, so the
diagnosis compares each test through its own.

Draws come from the trial's own seed streams: the injected effects from
``SeedSequence(seed, spawn_key=(trial, 7))``, the measurement and the other form's
truth from ``(trial, 8)``; excitation and noise from the campaign's per-test streams.
So results do not depend on the worker count, and the two forms of one trial share
every draw.
"""

from __future__ import annotations

import time
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from truthbench.campaign.runner import simulate_one
from truthbench.campaign.spec import CampaignSpec
from truthbench.effects import EFFECTS, parse_effect
from truthbench.effects.structural import element_bending
from truthbench.errors import CampaignError
from truthbench.plants import Sensor

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

FORMS = ("other", "same")
"""The truth's model forms, in the order they are reported."""

REFINE = (3, 4, 6)
"""The other form's mesh: this many truth elements per model element (drawn)."""
TIMOSHENKO_PROBABILITY = 0.5
"""Chance that the other form's elements have shear deformation and rotary inertia."""
AVERAGES = (4, 8, 16)
"""Averages of a test's FRF estimate (drawn per test)."""
SEGMENT_FACTORS = (1.0, 0.5)
"""A test's segment: its campaign segment (``record_s / averages``) times one of these
(drawn); its record is the segment times the averages."""
WINDOWS = ("bartlett", "hann")
"""A test's segment window (drawn)."""
OFFSET_M = (0.001, 0.004)
"""Range of the offset of a sensing point or a force line from the axis, m (uniform,
either side)."""
CROSS_AXIS = (0.01, 0.03)
"""Range of a sensor's cross-axis sensitivity (uniform, either sign)."""
MISALIGNMENT_DEG = (1.0, 3.0)
"""Range of a shaker's misalignment, degrees (uniform, either side)."""

ALLOWED_WITH_TIMOSHENKO = frozenset({"element_physics"})
"""Findings that are right, not false alarms, when the truth is a Timoshenko beam (the
Euler-Bernoulli model does lack its shear and rotary inertia)."""

SIZE_TOLERANCE = 0.10
"""A right finding's size is right within this fraction of the true size."""

TARGETS = {"nothing found on clean": 0.95, "right effect first": 0.90,
           "exactly the injected": 0.85, "both found": 0.85, "sizes within 10 %": 0.80}
"""The scores the other-form study should reach (issue 17)."""

_BENDING = {"z": "ry", "y": "rz"}


# ---- form-independent sizes ----------------------------------------------------------
def joint_stiffness(EI: float, h_m: float, loss: float) -> float:
    """The rotational stiffness of a joint made by an element's stiffness loss.

    An element of length ``h`` whose bending stiffness is ``EI (1 - loss)`` is, under a
    moment, the sound element in series with a rotational spring ``k``:
    ``h / (EI (1 - loss)) = h / EI + 1 / k``, so ``k = EI (1 - loss) / (loss h)``.

    Parameters
    ----------
    EI : float
        Bending stiffness of the element, N m^2.
    h_m : float
        Its length, m.
    loss : float
        Fraction of its stiffness lost, in (0, 1).

    Returns
    -------
    float
        N m/rad (inf for no loss).
    """
    return np.inf if loss <= 0 else EI * (1.0 - loss) / (loss * h_m)


def joint_loss(EI: float, h_m: float, stiffness: float) -> float:
    """The stiffness loss of an element of length ``h_m`` that makes the joint of
    rotational stiffness ``stiffness`` (N m/rad): the inverse of :func:`joint_stiffness`,
    ``loss = EI / (EI + k h)``."""
    return EI / (EI + stiffness * h_m)


def effect_size(effect: str, values, bending: tuple[float, float] | None = None) -> float:
    """The size of an effect in a measure that does not depend on the model form.

    Its strength parameter (:data:`DEFAULT_STRENGTH`, else its first): mass kg, spring
    N/m, dashpot N s/m, delay s, gain error, corner or natural frequency Hz, scale; for
    ``boundary`` the suspension stiffness over the model's (``1 + stiffness_rel``); for
    a joint its rotational stiffness, N m/rad (:func:`joint_stiffness` of ``bending =
    (EI, h)``, its element's).
    """
    if effect == "joint":
        return joint_stiffness(*bending, values["stiffness_loss"])
    if effect == "boundary":
        return 1.0 + values["stiffness_rel"]
    name = DEFAULT_STRENGTH[effect][0] if effect in DEFAULT_STRENGTH \
        else EFFECTS[effect].params[0].name
    return float(values[name])


# ---- the draws ---------------------------------------------------------------------
@dataclass(frozen=True)
class Injected:
    """One effect a trial injects, before a form places it.

    ``value`` is its strength in ``parameter`` (a joint's: the stiffness loss of a model
    element); ``fraction`` in [0, 1) places an effect at a station along the article
    (None for effects without one); ``options`` are its direction or sensor (label)."""

    effect: str
    parameter: str
    value: float
    options: dict
    fraction: float | None


@dataclass(frozen=True)
class Measurement:
    """One test's record as a trial draws it."""

    record_s: float
    averages: int
    window: str


@dataclass(frozen=True)
class OtherForm:
    """The other form's truth: mesh refinement, element physics, channel mountings
    (``(label, offset_m, cross_axis)`` per sensor, ``(label, offset_m,
    misalignment_deg)`` per shaker)."""

    refine: int
    timoshenko: bool
    sensors: tuple[tuple[str, float, float], ...]
    shakers: tuple[tuple[str, float, float], ...]


@dataclass(frozen=True)
class TrialDraw:
    """Everything a trial draws; both forms realise it."""

    injected: tuple[Injected, ...]
    measurement: tuple[Measurement, ...]
    other: OtherForm


def draw_injection(spec: CampaignSpec, trial: int, seed: int) -> tuple[Injected, ...]:
    """The effects trial ``trial`` injects (none, one or two), from its own stream."""
    study = spec.diagnose.study
    rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(trial, 7)))
    u = rng.random()
    count = 0 if u < study.clean_fraction else (
        2 if u < study.clean_fraction + study.two_fraction else 1)
    names = [str(x) for x in rng.permutation(study.inject)][:count]
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
        fraction = float(rng.random())
        options: dict = {}
        cls = EFFECTS[name]
        if "direction" in cls.options and directions:
            d = directions[int(rng.integers(len(directions)))]
            options["direction"] = _BENDING.get(d, d) if name == "joint" else d
        if "sensor" in cls.options:
            s = spec.sensors[int(rng.integers(len(spec.sensors)))]
            options["sensor"] = Sensor(s.station, s.direction, s.quantity).label
        out.append(Injected(name, param, value, options,
                            fraction if "station" in cls.options else None))
    return tuple(out)


def _signed(rng, bounds) -> float:
    return float(rng.choice((-1.0, 1.0)) * rng.uniform(*bounds))


def draw_trial(spec: CampaignSpec, trial: int, seed: int) -> TrialDraw:
    """Every draw of trial ``trial``: the injected effects (:func:`draw_injection`),
    each test's record (:class:`Measurement`) and the other form's truth
    (:class:`OtherForm`), from the trial's own streams."""
    rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(trial, 8)))
    measurement = []
    for test in spec.tests:
        averages = int(rng.choice(AVERAGES))
        segment = test.record_s / test.averages * float(rng.choice(SEGMENT_FACTORS))
        measurement.append(Measurement(segment * averages, averages,
                                       str(rng.choice(WINDOWS))))
    refine = int(rng.choice(REFINE))
    timoshenko = bool(rng.random() < TIMOSHENKO_PROBABILITY)
    ios = [spec.test_io(j) for j in range(len(spec.tests))]
    sensors = dict.fromkeys(s.label for _, ss in ios for s in ss
                            if s.direction in ("x", "y", "z") and s.quantity != "strain")
    shakers = dict.fromkeys(a.label for aa, _ in ios for a in aa
                            if a.direction in ("x", "y", "z"))
    mounted = tuple((lab, _signed(rng, OFFSET_M), _signed(rng, CROSS_AXIS))
                    for lab in sensors)
    driven = tuple((lab, _signed(rng, OFFSET_M), _signed(rng, MISALIGNMENT_DEG))
                   for lab in shakers)
    return TrialDraw(draw_injection(spec, trial, seed), tuple(measurement),
                     OtherForm(refine, timoshenko, mounted, driven))


# ---- a truth of each form ----------------------------------------------------------
@dataclass(frozen=True)
class Placed:
    """One injected effect as a truth of one form realised it.

    ``value``: its parameter in that truth (a joint's loss of the truth's own element);
    ``size``: the form-independent size (:func:`effect_size`); ``x_m``: where along the
    article (a joint: the centre of the element it weakens), m, or None; ``sensor``: the
    channel it acts on, or None."""

    effect: str
    parameter: str
    strength: float
    value: float
    size: float
    x_m: float | None
    sensor: str | None


@dataclass(frozen=True)
class Truth:
    """A truth of one form: the campaign to simulate, the effects it adds, the placed
    injected effects and what the diagnosis may rightly report besides them."""

    spec: CampaignSpec
    effects: tuple
    placed: tuple[Placed, ...]
    allowed: frozenset[str]


def _study_spec(spec: CampaignSpec, refine: int = 1) -> CampaignSpec:
    """The campaign on a mesh ``refine`` times the model's with a station at every node
    (``n<k>`` on the model's mesh, ``f<k>`` on a finer one: effects are placed there)
    and the model's suspension points."""
    model = spec.make_plant()
    size = model.n_elements * refine
    prefix = "n" if refine == 1 else "f"
    stations, _ = spec.plant.resolved_positions()
    stations = {**stations, **{f"{prefix}{k}": k / size for k in range(size + 1)}}
    update: dict = {"stations": stations, "n_elements": size}
    if refine != 1 and hasattr(model, "suspension_nodes"):  # on nodes of the finer mesh
        x = model.node_x_m(spec.nominal_parameters())
        update["suspension_x_m"] = [float(x[k]) for k in model.suspension_nodes()]
    return spec.model_copy(update={"plant": spec.plant.model_copy(update=update)})


def _node(fraction: float, n_elements: int) -> int:
    """An interior node of an ``n_elements`` mesh, uniform over them for a uniform
    fraction in [0, 1)."""
    return 1 + int(fraction * (n_elements - 1))


def truth_of(spec: CampaignSpec, draw: TrialDraw, form: str) -> Truth:
    """The truth of ``form`` ("other" or "same") for a trial's draws (see the module
    docstring)."""
    if form not in FORMS:
        raise ValueError(f"form must be one of {FORMS}; got {form!r}")
    nominal = spec.nominal_parameters()
    n = spec.plant.n_elements
    other = form == "other"
    r = draw.other.refine
    size = n * r if other else n
    prefix = "f" if other else "n"
    tests = [t.model_copy(update={"record_s": m.record_s, "averages": m.averages,
                                  "window": m.window})
             for t, m in zip(spec.tests, draw.measurement, strict=True)]
    tspec = _study_spec(spec, r if other else 1).model_copy(update={"tests": tests})
    plant = tspec.make_plant()
    params = spec.truth_parameters()
    x = plant.node_x_m(nominal)
    entries: list[dict] = []
    if other and draw.other.timoshenko:
        entries.append({"name": "element_physics", "parameters": {"scale": 1.0}})
    placed = []
    for inj in draw.injected:
        options = dict(inj.options)
        value, x_m, bending = inj.value, None, None
        if inj.fraction is not None:
            fine = _node(inj.fraction, n * r)  # the same form: the nearest model node
            node = fine if other else min(max(int(fine / r + 0.5), 1), n - 1)
            options["station"] = f"{prefix}{node}"
            x_m = float(x[node])
            if inj.effect == "joint":
                EI, h = element_bending(plant, params, node, options["direction"])
                h_model = h * size / n
                value = joint_loss(EI, h, joint_stiffness(EI, h_model, inj.value))
                bending = (EI, h)
                x_m += h / 2
        entry = {"name": inj.effect, **options, "parameters": {inj.parameter: value}}
        entries.append(entry)
        placed.append(Placed(inj.effect, inj.parameter, inj.value, value,
                             effect_size(inj.effect, {inj.parameter: value}, bending),
                             x_m, options.get("sensor")))
    if other:
        entries += [{"name": "sensor_mounting", "sensor": lab,
                     "parameters": {"offset_m": e, "cross_axis": c}}
                    for lab, e, c in draw.other.sensors]
        entries += [{"name": "shaker_mounting", "actuator": lab,
                     "parameters": {"offset_m": e, "misalignment_deg": a}}
                    for lab, e, a in draw.other.shakers]
    effects = tuple(parse_effect(e, f"diagnose.study ({form} form)", spec.source)
                    for e in entries)
    allowed = ALLOWED_WITH_TIMOSHENKO if other and draw.other.timoshenko else frozenset()
    return Truth(tspec, effects, tuple(placed), allowed)


# ---- scoring -----------------------------------------------------------------------
def _found_place(f, plant, x) -> float | None:
    """Where along the article a found effect is, m (a joint at a node: its element's
    centre; a hinge: its point)."""
    if f.node is None:
        return None
    if f.effect == "joint" and f.options.get("form", "element") == "element":
        e = min(f.node, plant.n_elements - 1)
        return float(0.5 * (x[e] + x[e + 1]))
    return float(x[f.node]) if f.x_m is None else float(f.x_m)


def _distance(where: float | None, x_m: float) -> float:
    return np.inf if where is None else abs(where - x_m)


def score(placed: Sequence[Placed], diag, *, allowed=frozenset(),
          element_m: float | None = None) -> dict:
    """Score one diagnosis against what one truth injected: the one place the scores
    are defined (it reads only ``diag.found`` for now).

    Parameters
    ----------
    placed : sequence of Placed
        The injected effects, as the truth realised them.
    diag : Diagnosis
    allowed : set of str
        Effects the truth really has besides the injected ones (the Timoshenko truth's
        ``element_physics``): reporting them is neither a false alarm nor a miss.
    element_m : float, optional
        The model's element length (before any refinement by the diagnosis), m: an
        effect is located when found within one of it (default: the diagnosis's).

    Returns
    -------
    dict
        ``found``, ``first_found`` (the first finding not allowed), ``nothing_found``
        (clean trials: nothing but allowed findings), ``first_correct`` (the first
        finding not allowed is an injected effect), ``first_in_verdict`` (it is, or is
        among the first finding's alternatives when the verdict is "A or B"),
        ``ambiguous`` (some finding has alternatives), ``exact`` (the findings not
        allowed are the injected effects, no more, no fewer), ``all_found`` (every
        injected effect among the findings), ``allowed_found`` (an allowed finding was
        made), ``missing_modes`` (modes the diagnosis said the model lacks),
        and per injected effect ``k``: ``size{k}`` and ``size_found{k}`` (see
        :func:`effect_size`), ``size_error{k}`` (relative), ``x_true{k}``,
        ``x_found{k}``, ``location_error_m{k}`` and ``located{k}`` (within one model
        element, or the right sensor); NaN and None where there is no right finding.
    """
    found = list(diag.found)
    names = [f.effect for f in found]
    judged = [f for f in found if f.effect not in allowed]
    injected = Counter(p.effect for p in placed)
    plant = diag.plant
    fitted = {k: v for k, v in diag.declared_values().items() if k in plant.parameters}
    params = plant.resolve({**diag.nominal, **fitted})
    x = plant.node_x_m(diag.nominal)
    if element_m is None:
        element_m = float(np.max(np.diff(x)))
    verdict = {judged[0].effect, *(a.effect for a in judged[0].alternatives)} if judged \
        else set()
    row = {
        "found": ";".join(names) or "none",
        "first_found": judged[0].effect if judged else "none",
        "nothing_found": not judged if not placed else None,
        "first_correct": bool(judged and judged[0].effect in injected) if placed else None,
        "first_in_verdict": bool(verdict & set(injected)) if placed else None,
        "ambiguous": any(f.alternatives for f in found),
        "missing_modes": len(getattr(diag, "missing", ())),
        "mesh_elements": diag.mesh.used if getattr(diag, "mesh", None) else plant.n_elements,
        "exact": Counter(f.effect for f in judged) == injected if placed else None,
        "all_found": set(injected) <= set(names) if placed else None,
        "allowed_found": any(n in allowed for n in names),
    }
    free = list(found)
    for k, p in enumerate(placed):
        same = [f for f in free if f.effect == p.effect]
        if p.sensor is not None:
            same.sort(key=lambda f: f.options.get("sensor") != p.sensor)
        elif p.x_m is not None:
            same.sort(key=lambda f: _distance(_found_place(f, plant, x), p.x_m))
        match = same[0] if same else None
        row[f"size{k}"] = p.size
        row.update({f"size_found{k}": np.nan, f"size_error{k}": np.nan,
                    f"x_true{k}": np.nan if p.x_m is None else p.x_m, f"x_found{k}": np.nan,
                    f"location_error_m{k}": np.nan, f"located{k}": None})
        if match is None:
            continue
        free.remove(match)
        bending = (element_bending(plant, params, match.node, match.options["direction"])
                   if p.effect == "joint" else None)
        got = effect_size(p.effect, match.parameters, bending)
        row[f"size_found{k}"] = got
        row[f"size_error{k}"] = abs(got - p.size) / abs(p.size)
        if p.sensor is not None:
            row[f"located{k}"] = match.options.get("sensor") == p.sensor
        elif p.x_m is not None:
            where = _found_place(match, plant, x)
            err = _distance(where, p.x_m)
            row[f"x_found{k}"] = np.nan if where is None else where
            row[f"location_error_m{k}"] = err
            row[f"located{k}"] = bool(err <= element_m * (1 + 1e-9))
    return row


def failed_score(placed: Sequence[Placed]) -> dict:
    """The score of a trial whose diagnosis raised: every score a failure."""
    row = {"found": "error", "first_found": "error",
           "nothing_found": False if not placed else None,
           "first_correct": False if placed else None,
           "first_in_verdict": False if placed else None, "ambiguous": False,
           "missing_modes": 0, "mesh_elements": np.nan,
           "exact": False if placed else None, "all_found": False if placed else None,
           "allowed_found": False}
    for k, p in enumerate(placed):
        row.update({f"size{k}": p.size, f"size_found{k}": np.nan, f"size_error{k}": np.nan,
                    f"x_true{k}": np.nan if p.x_m is None else p.x_m, f"x_found{k}": np.nan,
                    f"location_error_m{k}": np.nan, f"located{k}": None})
    return row


# ---- trials ------------------------------------------------------------------------
def forms_of(spec: CampaignSpec) -> tuple[str, ...]:
    """The forms ``[diagnose.study] form`` asks for, in report order."""
    form = spec.diagnose.study.form
    return FORMS if form == "both" else (form,)


def study_trial(spec: CampaignSpec, trial: int, seed: int,
                forms: Sequence[str] | None = None) -> list[dict]:
    """One trial in every form: draw, simulate, diagnose, score. One row per form."""
    from truthbench.diagnose import diagnose

    draw = draw_trial(spec, trial, seed)
    rows = []
    for form in forms_of(spec) if forms is None else forms:
        start = time.perf_counter()
        truth = truth_of(spec, draw, form)
        data = [simulate_one(truth.spec, trial, j, seed, truth.effects).frf
                for j in range(len(spec.tests))]
        model = spec.make_plant()
        row = {"trial": trial, "form": form, "n_injected": len(truth.placed),
               "injected": ";".join(p.effect for p in truth.placed) or "none",
               "refine": draw.other.refine if form == "other" else 1,
               "timoshenko": form == "other" and draw.other.timoshenko, "error": ""}
        settings = spec.diagnose.settings()
        if form == "same":
            # the truth is the model's own mesh: refining the model would make the data
            # (its discretisation error included) a truth of another form
            settings["max_refinement"] = 1
        try:
            diag = diagnose(data, model, spec.nominal_parameters(), spec.update.parameters,
                            **settings)
        except Exception as exc:  # noqa: BLE001 - a failed trial is scored as failed,
            # and the study goes on: its message is kept in the row
            row.update(failed_score(truth.placed), error=f"{type(exc).__name__}: {exc}")
        else:
            row.update(score(truth.placed, diag, allowed=truth.allowed, element_m=float(
                np.max(np.diff(model.node_x_m(spec.nominal_parameters()))))))
            row.update({"frf_error_before": diag.frf_error_before,
                        "frf_error_after": diag.frf_error_after,
                        "reduced_chi2_before": diag.before.reduced_chi2,
                        "reduced_chi2_after": diag.after.reduced_chi2})
        for k, p in enumerate(truth.placed):
            row.update({f"effect{k}": p.effect, f"parameter{k}": p.parameter,
                        f"strength{k}": p.strength})
        row["seconds"] = time.perf_counter() - start
        rows.append(row)
    return rows


def run_study(spec: CampaignSpec, *, trials: int | None = None, seed: int | None = None,
              n_jobs: int = 1):
    """Every trial of the study, in every form (joblib; identical for any worker count).

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
    return StudyResult(spec.campaign.name, seed,
                       pd.DataFrame([r for trial in rows for r in trial]))


def _share(column) -> float:
    """The fraction of True among the rows a score applies to (NaN for none)."""
    values = column.dropna()
    return float(values.astype(bool).mean()) if len(values) else np.nan


def _per_effect(df, stem: str):
    import pandas as pd

    cols = [c for c in df.columns if c.startswith(stem) and c[len(stem):].isdigit()]
    return pd.concat([df[c] for c in cols], ignore_index=True) if cols else \
        pd.Series(dtype=float)


@dataclass(frozen=True, eq=False)
class StudyResult:
    """The trials of a diagnose-study (one row per trial and form) and their summaries."""

    campaign: str
    seed: int
    trials: object
    """pandas.DataFrame: trial, form, what was injected and found, the scores of
    :func:`score`, errors before and after, per injected effect its strength, size,
    place and what was found of it, and the seconds the trial took in that form."""

    @property
    def forms(self) -> tuple[str, ...]:
        """The forms of this study, in report order."""
        have = set(self.trials["form"])
        return tuple(f for f in FORMS if f in have)

    def to_pandas(self, table: str = "trials", form: str | None = None):
        """A table of the study.

        Parameters
        ----------
        table : {"trials", "summary", "scores", "confusion", "detection"}
            ``trials``: one row per trial and form; ``summary``: one row per form
            (counts, scores, median location error, element_physics findings the
            Timoshenko truth allows, error reduction, seconds per trial); ``scores``: the
            scores with their :data:`TARGETS`, one column per form; ``confusion``: the
            first effect found against the injected one (single-effect trials);
            ``detection``: the rate of the right effect first per effect and strength
            quartile (single-effect trials).
        form : str, optional
            The form of ``confusion`` and ``detection`` (default the first, "other" when
            there is one).

        Returns
        -------
        pandas.DataFrame
        """
        import pandas as pd

        df = self.trials
        if table == "trials":
            return df
        if table == "summary":
            return pd.DataFrame([self._summary(df[df.form == f], f) for f in self.forms])
        if table == "scores":
            s = self.to_pandas("summary").set_index("form")
            rows = ["nothing found on clean", "right effect first", "exactly the injected",
                    "both found", "sizes within 10 %", "located within one element"]
            out = pd.DataFrame({"target": [TARGETS.get(r, np.nan) for r in rows]}, index=rows)
            for f in s.index:
                out[f] = [s.loc[f, r] for r in rows]
            return out
        form = self.forms[0] if form is None else form
        if form not in self.forms:
            raise ValueError(f"form must be one of {self.forms}; got {form!r}")
        mine = df[df.form == form]
        single = mine[mine.n_injected == 1]
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
                                 "first_correct": _share(sel.first_correct)
                                 if len(sel) else np.nan})
            return pd.DataFrame(rows)
        raise ValueError(f"table must be trials, summary, scores, confusion or detection; "
                         f"got {table!r}")

    @staticmethod
    def _summary(df, form: str) -> dict:
        clean = df[df.n_injected == 0]
        single = df[df.n_injected == 1]
        two = df[df.n_injected == 2]
        hit = _per_effect(df, "size_error").dropna()
        loc = _per_effect(df, "location_error_m").dropna()
        red = (df.frf_error_before / df.frf_error_after)[df.n_injected > 0]
        tim = df[df.timoshenko.astype(bool)]
        return {
            "form": form, "trials": len(df), "clean trials": len(clean),
            "nothing found on clean": _share(clean.nothing_found),
            "single-effect trials": len(single),
            "right effect first": _share(single.first_correct),
            "trials with effects": int((df.n_injected > 0).sum()),
            "exactly the injected": _share(df.exact),
            "two-effect trials": len(two), "both found": _share(two.all_found),
            "right findings": len(hit),
            "sizes within 10 %": float((hit <= SIZE_TOLERANCE).mean()) if len(hit)
            else np.nan,
            "median location error (m)": float(loc.median()) if len(loc) else np.nan,
            "located within one element": _share(_per_effect(df, "located")),
            "Timoshenko trials": len(tim),
            "element_physics found (allowed)": int(tim.allowed_found.astype(bool).sum()),
            "median error reduction": float(red.median()) if len(red) else np.nan,
            "median seconds per trial": float(df.seconds.median()),
        }

    def plot(self):
        """The right effect first against strength, one panel per effect (single-effect
        trials; one marker per form). The caller chooses the matplotlib backend.

        Returns
        -------
        matplotlib.figure.Figure
        """
        import matplotlib.pyplot as plt
        from matplotlib.ticker import NullFormatter

        df = self.trials
        single = df[df.n_injected == 1]
        names = sorted(single.injected.unique())
        fig, axes = plt.subplots(1, max(len(names), 1), figsize=(2.6 * max(len(names), 1),
                                                                 2.8), squeeze=False)
        for ax, name in zip(axes[0], names, strict=False):
            for k, (form, marker) in enumerate(zip(self.forms, ("o", "x"), strict=False)):
                g = single[(single.injected == name) & (single.form == form)]
                ax.semilogx(g.strength0, g.first_correct.astype(float) - 0.06 * k, marker,
                            ms=4, label=form)
            ax.xaxis.set_minor_formatter(NullFormatter())
            ax.set_title(name, fontsize="small")
            ax.set_xlabel(single[single.injected == name].parameter0.iloc[0],
                          fontsize="small")
            ax.set_ylim(-0.2, 1.1)
        axes[0, 0].set_ylabel("right effect first (1) or not (0)")
        if names:
            axes[0, 0].legend(fontsize="x-small", title="truth form",
                              title_fontsize="x-small")
        fig.tight_layout()
        return fig
