"""One Monte Carlo trial of a campaign: truth -> tests -> FRFs -> modes -> update -> scores.

For each test of the plan (:class:`~truthbench.campaign.plan.CampaignPlan`) the hardware
is realised from the campaign's truth (:func:`~truthbench.campaign.truth.build_hardware`,
a :class:`~truthbench.effects.Hardware`); the test drives it with a band-limited random
force (:func:`simulate_test`, which leaves the physics to
:meth:`~truthbench.effects.Hardware.simulate`), and H1 FRFs are estimated
(:func:`measure_test`). The nominal model is then updated against all tests' FRFs or
identified modes by every updater of ``[update] method``, each configured from the
``[update]`` table and given the inputs it declares it needs (:func:`update_problem`:
an :class:`~truthbench.update.FRFPredictor` and the FRFs, or identified modes and the
model builder). Randomness comes from one ``SeedSequence`` per (campaign seed, trial,
test), so results do not depend on worker count or order. A trial that fails is
recorded with its error (:func:`run_trial`).
"""

from __future__ import annotations

import time
import traceback
from dataclasses import replace

import numpy as np
from threadpoolctl import threadpool_limits

from truthbench.campaign.frf_band_stage import with_frf_band
from truthbench.campaign.identification import identify_test
from truthbench.campaign.metrics import modal_accuracy
from truthbench.campaign.results import STAGES, TestRecord, TrialResult
from truthbench.campaign.truth import build_hardware
from truthbench.campaign.uncertainty_stage import model_values, uncertainty_stage
from truthbench.effects import Hardware
from truthbench.measure import estimate_frf
from truthbench.measure.frfdata import FRFData
from truthbench.simulate import band_limited_random
from truthbench.update import (
    APPENDED_PARAMETERS,
    FRFPredictor,
    MeasuredModes,
    PredictedTest,
    UpdateProblem,
    make_updater,
)


def excitation_rng(seed: int, trial: int, test: int) -> np.random.Generator:
    """The excitation and noise generator of one (trial, test index): independent of run
    order and worker count (effects draw from their own streams, see
    :mod:`truthbench.campaign.truth`)."""
    return np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(trial, 0, test)))


def simulate_test(test, hardware: Hardware, rng: np.random.Generator):
    """Run ``test`` (a :class:`~truthbench.campaign.plan.TestPlan`) on ``hardware``: a
    band-limited random force at the test's rate, level and band, through
    :meth:`~truthbench.effects.Hardware.simulate`.

    Returns
    -------
    u : ndarray, shape (n_in, n_samples)
        Recorded inputs (the commanded force or moment, N or N m).
    y : ndarray, shape (n_out, n_samples)
        Recorded outputs: through sensor dynamics, delay, bias, then sensor noise.
    """
    t = test.test
    u = band_limited_random(test.samples, t.fs_hz, t.level_rms, test.band_hz, rng,
                            n_inputs=len(hardware.actuators))
    y = hardware.simulate(u, t.fs_hz, rng=rng, method=t.simulation, oversample=t.oversample,
                          min_warm_up=test.segment, band_hz=test.band_hz,
                          noise_fraction=t.noise_fraction)
    return u, y


def measure_test(plan, test, u, y, params: dict, *, identify: bool = True) -> TestRecord:
    """H1 FRFs and coherence of ``test`` from its time histories, then (if ``identify``
    and the campaign identifies) its modes (:func:`identify_record`)."""
    t = test.test
    est = estimate_frf(u, y, t.fs_hz, estimator="H1", window=t.window, n_averages=t.averages)
    n = u.shape[1]
    periodic = n % est.nperseg == 0  # the force is periodic over the record
    frf = FRFData(t.name, est.freq_hz, est.H, test.outputs, test.inputs,
                  coherence=est.coherence, band_hz=test.band_hz,
                  notes=(f"H1, {t.window} window, {est.n_averages} averages of "
                         f"{est.nperseg} samples at {t.fs_hz:g} Hz",),
                  estimator=est.to_estimator(period_samples=n if periodic else None),
                  input_rms=tuple(float(v) for v in np.sqrt(np.mean(u**2, axis=1))))
    record = TestRecord(t.name, frf, u, y, t.fs_hz, dict(params))
    return identify_record(plan, test, record) if identify else record


def identify_record(plan, test, record: TestRecord) -> TestRecord:
    """``record`` (of ``test``) with its identified modes (pLSCF), or unchanged when the
    campaign's ``[identify] enabled`` is false."""
    settings = plan.spec.identify
    if not settings.enabled:
        return record
    return replace(record, modes=identify_test(test, record, max_order=settings.max_order))


def truth_record(hardware: Hardware) -> dict:
    """The exact truth of one test as flat name -> value pairs: plant parameters, then
    ``effect.<label>.<parameter>`` for every effect's realised values, plus the truth
    mesh and element physics."""
    out = {k: float(v) for k, v in hardware.parameters.items()}
    out["truth.n_elements"] = float(hardware.plant.n_elements)
    out["truth.timoshenko"] = float(hardware.plant.timoshenko)
    for label, values in hardware.effects.items():
        for k, v in values.items():
            out[f"effect.{label}.{k}"] = v if isinstance(v, str) else float(v)
    return out


def hardware_truth(plan, records) -> dict:
    """The trial's truth for scoring an update: every plant parameter averaged over the
    tests (equal to each test's value unless an effect varies it per test, assembly or
    time)."""
    out = {}
    for key in plan.nominal:
        values = [rec.parameters[key] for rec in records if key in rec.parameters]
        if values:
            out[key] = float(np.mean(values))
    for key in (k for k in records[0].parameters if "@" in k):  # group-qualified values
        out[key] = float(np.mean([rec.parameters.get(key, np.nan) for rec in records]))
    # the appended dynamics (APPENDED_PARAMETERS): total delay and total output gain
    delays, gains = [], []
    for rec in records:
        p = rec.parameters
        delays.append(sum(v for k, v in p.items() if k.startswith("effect.time_delay")
                          and k.endswith(".delay_s")))
        gains.append(np.prod([1.0 + v for k, v in p.items()
                              if k.startswith("effect.sensor_bias")
                              and k.endswith(".gain_error")]))
    out["delay_s"] = float(np.mean(delays))
    out["sensor_gain"] = float(np.mean(gains))
    return out


def plant_parameters(params: dict) -> dict:
    """``params`` without the appended-dynamics parameters."""
    return {k: v for k, v in params.items() if k not in APPENDED_PARAMETERS}


def predictor(plan, lines) -> FRFPredictor:
    """The campaign's model as an :class:`~truthbench.update.FRFPredictor` at the lines
    ``lines`` of each test (one array of frequencies per test of the plan, Hz). It solves
    only the blocks of DOFs the channels sit on (``reduced``: the FRFs of the whole model,
    at the eigensolver's round-off, for a third of the modes of a beam measured in one
    plane), and the update's analytic Jacobian works on the same blocks."""
    tests = [PredictedTest(t.name, f, t.actuators, t.sensors)
             for t, f in zip(plan.tests, lines, strict=True)]
    return FRFPredictor(plan.plant, plan.nominal, tests, reduced=True)


def _weights(plan, records, masks) -> np.ndarray | None:
    kind = plan.spec.update.weighting
    if kind == "none":
        return None
    parts = []
    for rec, mask in zip(records, masks, strict=True):
        if kind == "coherence":
            g = np.clip(rec.coherence[mask], 0.0, 1.0 - 1e-12)
            parts.append(np.sqrt(g / (1.0 - g)))  # inverse of the H1 standard deviation
        else:  # inverse_magnitude: relative (log-like) least squares
            parts.append(1.0 / np.maximum(np.abs(rec.H[mask]), 1e-300))
    return np.concatenate([p.ravel() for p in parts])


def measured_modes(plan, records, params: dict, *, build=None) -> list[MeasuredModes]:
    """Identified modes of every test as :class:`~truthbench.update.MeasuredModes` at
    the model DOFs its (non-strain) sensors sit on."""
    plant = plan.plant
    labels = (build or plant.build)(params).dof_labels
    out = []
    for test, rec in zip(plan.tests, records, strict=True):
        if rec.modes is None or len(rec.modes.freq_hz) == 0:
            continue
        rows, dofs = [], []
        for i, s in enumerate(test.sensors):
            label = f"n{plant.station_node(s.station)}.{s.direction}"
            if s.quantity != "strain" and label in labels:
                rows.append(i)
                dofs.append(labels.index(label))
        if rows:
            out.append(MeasuredModes(np.asarray(rec.modes.freq_hz),
                                     np.asarray(rec.modes.shapes)[rows], np.array(dofs),
                                     damping_ratio=np.asarray(rec.modes.damping_ratio)))
    return out


class _MemoBuild:
    """``plant.build(theta)`` remembering its last few models by parameter values (the
    sensitivity updater builds the same parameters more than once per iteration)."""

    def __init__(self, plant, size: int = 4):
        self.plant, self.size, self._cache = plant, size, {}
        # what its models depend on besides theta: macroelements taken at a theta serve
        # every trial (truthbench.update.jacobian.MacroelementCache)
        self.content_key = ("plant.build", repr(plant))

    def __call__(self, theta):
        try:
            key = tuple(sorted((k, float(v)) for k, v in theta.items()))
        except (TypeError, ValueError):
            return self.plant.build(theta)
        if key not in self._cache:
            self._cache[key] = self.plant.build(theta)
            while len(self._cache) > self.size:
                self._cache.pop(next(iter(self._cache)))
        return self._cache[key]


def update_problem(plan, records, updater, *, full: FRFPredictor | None = None,
                   start: dict | None = None) -> tuple[UpdateProblem, list]:
    """The :class:`~truthbench.update.UpdateProblem` of a trial's data with the inputs
    ``updater`` needs (FRFs and a predictor; identified modes and a model builder), and
    the lines used per test (:meth:`~truthbench.campaign.plan.TestPlan.update_lines`).
    ``full``: the trial's predictor at all lines, whose cache of models the update's
    predictor shares; ``start``: values an FRF updater may start from (a modal
    update's result)."""
    masks = [t.update_lines(rec.freq_hz) for t, rec in zip(plan.tests, records, strict=True)]
    names = plan.update_names
    if full is not None:
        pred = full.with_tests([replace(t, freq_hz=rec.freq_hz[m]) for t, rec, m in
                                zip(full.tests, records, masks, strict=True)])
    else:
        pred = predictor(plan, [rec.freq_hz[m] for rec, m in zip(records, masks, strict=True)])
    nominal = plan.nominal
    theta0 = {**nominal, **{k: v for k, v in pred.theta0.items()
                            if k in names and k not in nominal}}
    frf, modes = "frf" in updater.needs, "modes" in updater.needs
    build = _MemoBuild(pred.plant) if modes else None
    problem = UpdateProblem(
        names=names, theta0=theta0,
        predict_frf=pred.vector_function() if frf else None,
        frf_data=np.concatenate([rec.H[m].ravel() for rec, m in
                                 zip(records, masks, strict=True)]) if frf else None,
        frf_weights=_weights(plan, records, masks) if frf else None,
        n_pairs=sum(rec.H.shape[1] * rec.H.shape[2] for rec in records) if frf else None,
        additive=pred.additive_scales(names) if frf else None,
        build_model=build,
        measured=measured_modes(plan, records, nominal, build=build) if modes else None,
        start=start if frf else None)
    return problem, masks


def update_trial(plan, records, method: str | None = None, *,
                 full: FRFPredictor | None = None, start: dict | None = None):
    """Update the nominal model against the trial's data with one registered updater
    configured from the campaign's ``[update]`` table (default: the primary method);
    ``full`` and ``start`` as in :func:`update_problem`.

    Returns
    -------
    result : UpdateResult
    masks : list of ndarray of bool
        The lines of each test used.
    """
    updater = make_updater(method or plan.methods[0], plan.spec.update.model_dump())
    problem, masks = update_problem(plan, records, updater, full=full, start=start)
    return updater.update(problem), masks


class _Stopwatch:
    """Wall-clock seconds accumulated per stage: ``with watch("frf"): ...``."""

    def __init__(self):
        self.seconds = dict.fromkeys(STAGES, 0.0)
        self._stage = None

    def __call__(self, stage: str):
        self._stage = stage
        return self

    def __enter__(self):
        self._t0 = time.perf_counter()

    def __exit__(self, *exc):
        self.seconds[self._stage] += time.perf_counter() - self._t0


def _needs(plan, method: str) -> frozenset:
    """What the updater ``method`` needs (``"frf"``, ``"modes"``)."""
    return make_updater(method, plan.spec.update.model_dump()).needs


def _modal_first(plan, methods) -> list:
    """``methods`` in the order they run: those that fit identified modes first, so that
    the first one's values start the FRF updaters (two-step updating: the modal fit puts
    the model's resonances within their bandwidth of the data's, where the FRF cost is
    a valley Gauss-Newton descends in a few steps; from the nominal model each step
    moves a resonance by about its bandwidth). Results do not depend on the order
    otherwise."""
    return sorted(methods, key=lambda m: _needs(plan, m) != {"modes"})


def _keeps_time_histories(plan, trial: int) -> bool:
    """Whether ``trial`` keeps its recorded time histories (``[output]``)."""
    keep = plan.spec.output.time_histories
    return keep == "all" or (keep == "first_trial" and trial == 0)


def run_trial(plan, trial: int, seed: int) -> TrialResult:
    """Run one Monte Carlo trial of ``plan`` (a
    :class:`~truthbench.campaign.plan.CampaignPlan`); a failure is recorded, not raised.

    BLAS runs single-threaded inside a trial (``threadpoolctl``): the matrices are small
    (hundreds of DOFs), where threads only add overhead, and parallelism comes from
    running trials side by side.
    """
    with threadpool_limits(limits=1, user_api="blas"):
        return _kept(plan, with_frf_band(plan, _run_trial(plan, trial, seed)))


def _kept(plan, tr: TrialResult) -> TrialResult:
    """``tr`` as the campaign's ``[output] frfs`` keeps it: whole, or (after trial 0)
    with its summary (:func:`~truthbench.campaign.summary.trial_summary`, taken from the
    whole trial) and its FRFs, coherence and model FRFs cut to no line and no FRF
    band."""
    if plan.spec.output.frfs == "all" or tr.trial == 0:
        return tr
    from truthbench.campaign.summary import trial_summary

    summary = trial_summary(plan.spec, tr)
    tests = tuple(replace(rec, frf=rec.frf.lines(np.zeros(rec.freq_hz.size, bool)))
                  for rec in tr.tests)
    return replace(tr, tests=tests, H_initial=tuple(h[:0] for h in tr.H_initial),
                   H_updated=tuple(h[:0] for h in tr.H_updated),
                   update_mask=tuple(m[:0] for m in tr.update_mask), frf_band=None,
                   summary=summary)


def _run_trial(plan, trial: int, seed: int) -> TrialResult:
    truth = dict(plan.truth)
    records: list[TestRecord] = []
    hardware: list[Hardware] = []
    watch = _Stopwatch()
    try:
        for test in plan.tests:
            with watch("simulate"):
                hw = build_hardware(plan, test, trial, seed)
                u, y = simulate_test(test, hw, excitation_rng(seed, trial, test.index))
            with watch("frf"):
                record = measure_test(plan, test, u, y, truth_record(hw), identify=False)
            with watch("identify"):
                record = identify_record(plan, test, record)
            if not _keeps_time_histories(plan, trial):
                record = replace(record, u=record.u[:, :0], y=record.y[:, :0])
            records.append(record)
            hardware.append(hw)
        truth = hardware_truth(plan, records)
        nominal = plan.nominal
        first = hardware[0]  # the trial's truth for modal accuracy
        stage = None
        if len(records) > 1 and plan.spec.identify.enabled:
            with watch("bound"):
                stage = uncertainty_stage(plan, records, hardware)
        methods = plan.methods
        if not methods:
            return TrialResult(trial, tuple(records), truth, uncertainty=stage,
                               seconds=watch.seconds)
        with watch("score"):
            accuracy = {"initial": modal_accuracy(plan, first, nominal)}
            # one predictor at every line above 0 Hz: the model FRFs before and after,
            # and (sharing its models by parameter values) the updaters' predictors
            full = predictor(plan, [rec.freq_hz[rec.freq_hz > 0] for rec in records])
            h_initial = full.predict(nominal)
        comparison = {}
        start = None  # a modal update's values, where the FRF updaters start
        for method in _modal_first(plan, methods):
            try:
                with watch("update"):
                    res, masks = update_trial(plan, records, method, full=full,
                                              start=start)
            except Exception as exc:  # one method failing does not lose the others
                if method == methods[0]:
                    raise
                comparison[method] = f"{type(exc).__name__}: {exc}"
                continue
            comparison[method] = res
            if start is None and _needs(plan, method) == {"modes"}:
                start = res.as_dict()
            with watch("score"):
                accuracy[method] = modal_accuracy(plan, first,
                                                  plant_parameters({**nominal,
                                                                    **res.as_dict()}))
            if method == methods[0]:
                result = res
        # reported in the declared order, whatever order they ran in
        comparison = {m: comparison[m] for m in methods if m in comparison}
        accuracy = {k: accuracy[k] for k in ("initial", *methods) if k in accuracy}
        updated = {**nominal, **result.as_dict()}
        accuracy["updated"] = accuracy[methods[0]]
        with watch("score"):
            if stage is not None:
                stage = replace(stage, theta_updated=model_values(
                    plan, plant_parameters(updated), stage.mode_index))
            h_updated = full.predict(updated)
        return TrialResult(
            trial, tuple(records), truth, result, h_initial, h_updated, tuple(masks),
            accuracy, comparison=comparison, uncertainty=stage, seconds=watch.seconds)
    except Exception as exc:  # recorded per trial; the campaign goes on
        msg = f"{type(exc).__name__}: {exc}"
        if not isinstance(exc, ValueError | RuntimeError):
            msg += "\n" + traceback.format_exc(limit=3)
        return TrialResult(trial, tuple(records), truth, error=msg, seconds=watch.seconds)
