"""The Monte Carlo runner: campaign spec -> trials -> tests -> FRFs -> update -> scores.

For each trial and test the hardware is realised from the campaign's truth
(:func:`~truthbench.campaign.truth.build_hardware`, a
:class:`~truthbench.effects.Hardware`); the test drives it with a band-limited random
force (:func:`simulate_test`, which leaves the physics to
:meth:`~truthbench.effects.Hardware.simulate`), and H1 FRFs are estimated
(:func:`measure_test`). The nominal model is then updated against all tests' FRFs or
identified modes by every updater of ``[update] method``, each configured from the
``[update]`` table and given the inputs it declares it needs (:func:`update_problem`:
an :class:`~truthbench.update.FRFPredictor` and the FRFs, or identified modes and the
model builder). Randomness comes from one ``SeedSequence`` per (campaign seed, trial,
test), so results do not depend on worker count or order. A trial that fails is
recorded with its error; the others finish.
"""

from __future__ import annotations

import time
import traceback
from dataclasses import replace

import numpy as np
from joblib import Parallel, delayed
from threadpoolctl import threadpool_limits

from truthbench._version import __version__
from truthbench.campaign.frf_band_stage import with_frf_band
from truthbench.campaign.identification import identify_test
from truthbench.campaign.metrics import modal_accuracy
from truthbench.campaign.results import STAGES, CampaignResult, TestRecord, TrialResult
from truthbench.campaign.spec import CampaignSpec
from truthbench.campaign.truth import build_hardware
from truthbench.campaign.uncertainty_stage import model_values, uncertainty_stage
from truthbench.effects import Hardware
from truthbench.errors import CampaignError
from truthbench.measure import estimate_frf
from truthbench.measure.frfdata import Channel, FRFData
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
    """The excitation and noise generator of one (trial, test): independent of run order
    and worker count (effects draw from their own streams, see
    :mod:`truthbench.campaign.truth`)."""
    return np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(trial, 0, test)))


def simulate_test(spec: CampaignSpec, j: int, hardware: Hardware,
                  rng: np.random.Generator):
    """Run test ``j`` on ``hardware``: a band-limited random force at the test's rate,
    level and band, through :meth:`~truthbench.effects.Hardware.simulate`.

    Returns
    -------
    u : ndarray, shape (n_in, n_samples)
        Recorded inputs (the commanded force or moment, N or N m).
    y : ndarray, shape (n_out, n_samples)
        Recorded outputs: through sensor dynamics, delay, bias, then sensor noise.
    """
    test = spec.tests[j]
    n = int(round(test.record_s * test.fs_hz))
    u = band_limited_random(n, test.fs_hz, test.level_rms, tuple(test.band_hz), rng,
                            n_inputs=len(hardware.actuators))
    y = hardware.simulate(u, test.fs_hz, rng=rng, method=test.simulation,
                          oversample=test.oversample, min_warm_up=n // test.averages,
                          band_hz=tuple(test.band_hz), noise_fraction=test.noise_fraction)
    return u, y


def measure_test(spec: CampaignSpec, j: int, u, y, params: dict, *,
                 identify: bool = True) -> TestRecord:
    """H1 FRFs and coherence of test ``j`` from its time histories, then (if
    ``identify`` and the campaign identifies) its modes (:func:`identify_record`)."""
    test = spec.tests[j]
    est = estimate_frf(u, y, test.fs_hz, estimator="H1", window=test.window,
                       n_averages=test.averages)
    outputs, inputs = channels(spec, *spec.test_io(j))
    frf = FRFData(test.name, est.freq_hz, est.H, outputs, inputs, coherence=est.coherence,
                  n_averages=est.n_averages, band_hz=tuple(test.band_hz),
                  notes=(f"H1, {test.window} window, {est.n_averages} averages of "
                         f"{est.nperseg} samples at {test.fs_hz:g} Hz",))
    record = TestRecord(test.name, frf, u, y, test.fs_hz, dict(params))
    return identify_record(spec, j, record) if identify else record


def channels(spec: CampaignSpec, actuators, sensors):
    """The FRF channels of a test's sensors (outputs) and actuators (inputs), at the
    stations' positions on the nominal beam (m)."""
    plant = spec.make_plant()
    xyz = plant.node_coordinates_m(spec.nominal_parameters())

    def at(station):
        return tuple(float(v) for v in xyz[plant.station_node(station)])

    outputs = tuple(Channel(s.label, s.quantity, s.direction, station=s.station,
                            coordinates_m=at(s.station)) for s in sensors)
    inputs = tuple(Channel(a.label, "force", a.direction, station=a.station,
                           coordinates_m=at(a.station)) for a in actuators)
    return outputs, inputs


def identify_record(spec: CampaignSpec, j: int, record: TestRecord) -> TestRecord:
    """``record`` with its identified modes (pLSCF), or unchanged when the campaign's
    ``[identify] enabled`` is false."""
    if not spec.identify.enabled:
        return record
    return replace(record, modes=identify_test(spec, j, record,
                                               max_order=spec.identify.max_order))


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


def hardware_truth(spec: CampaignSpec, records) -> dict:
    """The trial's truth for scoring an update: every plant parameter averaged over the
    tests (equal to each test's value unless an effect varies it per test, assembly or
    time)."""
    out = {}
    for key in spec.nominal_parameters():
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


def update_masks(spec: CampaignSpec, records) -> list[np.ndarray]:
    """Frequency lines of each test used in the update: inside the test's excitation
    band and the update band, and above 0 Hz."""
    masks = []
    for j, rec in enumerate(records):
        lo, hi = spec.tests[j].band_hz
        if spec.update.band_hz is not None:
            lo, hi = max(lo, spec.update.band_hz[0]), min(hi, spec.update.band_hz[1])
        masks.append((rec.freq_hz >= lo) & (rec.freq_hz <= hi) & (rec.freq_hz > 0))
    return masks


def plant_parameters(params: dict) -> dict:
    """``params`` without the appended-dynamics parameters."""
    return {k: v for k, v in params.items() if k not in APPENDED_PARAMETERS}


def predictor(spec: CampaignSpec, records, masks) -> FRFPredictor:
    """The campaign's model as an :class:`~truthbench.update.FRFPredictor` at each test's
    lines ``masks`` (one boolean per line of each record)."""
    tests = [PredictedTest(rec.name, rec.freq_hz[mask], *spec.test_io(j))
             for j, (rec, mask) in enumerate(zip(records, masks, strict=True))]
    return FRFPredictor(spec.make_plant(), spec.nominal_parameters(), tests)


def model_frfs(spec: CampaignSpec, params: dict, records, masks) -> list[np.ndarray]:
    """The model FRFs at each test's lines ``masks``, one array per test (plant and
    appended-dynamics parameters in ``params``)."""
    return list(predictor(spec, records, masks).predict(params))


def _weights(spec: CampaignSpec, records, masks) -> np.ndarray | None:
    kind = spec.update.weighting
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


def measured_modes(spec: CampaignSpec, records, params: dict, *, build=None
                   ) -> list[MeasuredModes]:
    """Identified modes of every test as :class:`~truthbench.update.MeasuredModes` at
    the model DOFs its (non-strain) sensors sit on."""
    plant = spec.make_plant()
    labels = (build or plant.build)(params).dof_labels
    out = []
    for j, rec in enumerate(records):
        if rec.modes is None or len(rec.modes.freq_hz) == 0:
            continue
        rows, dofs = [], []
        for i, s in enumerate(spec.test_sensors(j)):
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


def update_problem(spec: CampaignSpec, records, updater, *, full: FRFPredictor | None = None
                   ) -> tuple[UpdateProblem, list]:
    """The :class:`~truthbench.update.UpdateProblem` of a trial's data with the inputs
    ``updater`` needs (FRFs and a predictor; identified modes and a model builder), and
    the lines used per test. ``full``: the trial's predictor at all lines, whose cache of
    models the update's predictor shares."""
    masks = update_masks(spec, records)
    names = tuple(spec.update.parameters)
    if full is not None:
        pred = full.with_tests([replace(t, freq_hz=rec.freq_hz[m]) for t, rec, m in
                                zip(full.tests, records, masks, strict=True)])
    else:
        pred = predictor(spec, records, masks)
    nominal = spec.nominal_parameters()
    theta0 = {**nominal, **{k: v for k, v in pred.theta0.items()
                            if k in names and k not in nominal}}
    frf, modes = "frf" in updater.needs, "modes" in updater.needs
    plant = pred.plant
    build = _MemoBuild(plant) if modes else None
    problem = UpdateProblem(
        names=names, theta0=theta0,
        predict_frf=pred.vector_function() if frf else None,
        frf_data=np.concatenate([rec.H[m].ravel() for rec, m in
                                 zip(records, masks, strict=True)]) if frf else None,
        frf_weights=_weights(spec, records, masks) if frf else None,
        n_pairs=sum(rec.H.shape[1] * rec.H.shape[2] for rec in records) if frf else None,
        additive=pred.additive_scales(names) if frf else None,
        build_model=build,
        measured=measured_modes(spec, records, nominal, build=build) if modes else None)
    return problem, masks


def update_trial(spec: CampaignSpec, records, method: str | None = None, *,
                 full: FRFPredictor | None = None):
    """Update the nominal model against the trial's data with one registered updater
    configured from the campaign's ``[update]`` table (default: the primary method);
    ``full`` as in :func:`update_problem`.

    Returns
    -------
    result : UpdateResult
    masks : list of ndarray of bool
        The lines of each test used.
    """
    updater = make_updater(method or spec.update_methods()[0], spec.update.model_dump())
    problem, masks = update_problem(spec, records, updater, full=full)
    return updater.update(problem), masks


def simulate_one(spec: CampaignSpec, trial: int, j: int, seed: int | None = None,
                 extra_effects=()) -> TestRecord:
    """Simulate and measure one test of one trial; ``extra_effects``
    (:class:`~truthbench.effects.EffectSpec`) are injected beside the campaign's own."""
    if not 0 <= j < len(spec.tests):
        raise CampaignError(f"{spec.source}: test index {j} does not exist; expected "
                            f"0..{len(spec.tests) - 1} ({len(spec.tests)} tests)")
    if trial < 0:
        raise CampaignError(f"trial must be >= 0; got {trial}")
    seed = spec.campaign.seed if seed is None else seed
    hardware = build_hardware(spec, trial, j, seed, extra_effects)
    u, y = simulate_test(spec, j, hardware, excitation_rng(seed, trial, j))
    return measure_test(spec, j, u, y, truth_record(hardware))


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


def _keeps_time_histories(spec: CampaignSpec, trial: int) -> bool:
    keep = spec.output.time_histories
    return keep == "all" or (keep == "first_trial" and trial == 0)


def run_trial(spec: CampaignSpec, trial: int, seed: int) -> TrialResult:
    """Run one Monte Carlo trial; a failure is recorded, not raised.

    BLAS runs single-threaded inside a trial (``threadpoolctl``): the matrices are small
    (hundreds of DOFs), where threads only add overhead, and parallelism comes from
    running trials side by side.
    """
    with threadpool_limits(limits=1, user_api="blas"):
        return with_frf_band(spec, _run_trial(spec, trial, seed))


def _run_trial(spec: CampaignSpec, trial: int, seed: int) -> TrialResult:
    truth = spec.truth_parameters()
    records: list[TestRecord] = []
    watch = _Stopwatch()
    try:
        for j in range(len(spec.tests)):
            with watch("simulate"):
                hardware = build_hardware(spec, trial, j, seed)
                u, y = simulate_test(spec, j, hardware, excitation_rng(seed, trial, j))
                if j == 0:
                    first = hardware  # the trial's truth for modal accuracy
            with watch("frf"):
                record = measure_test(spec, j, u, y, truth_record(hardware),
                                      identify=False)
            with watch("identify"):
                record = identify_record(spec, j, record)
            if not _keeps_time_histories(spec, trial):
                record = replace(record, u=record.u[:, :0], y=record.y[:, :0])
            records.append(record)
        truth = hardware_truth(spec, records)
        nominal = spec.nominal_parameters()
        stage = None
        if len(records) > 1 and spec.identify.enabled:
            with watch("bound"):
                stage = uncertainty_stage(spec, trial, seed, records, nominal)
        methods = spec.update_methods()
        if not methods:
            return TrialResult(trial, tuple(records), truth, uncertainty=stage,
                               seconds=watch.seconds)
        with watch("score"):
            accuracy = {"initial": modal_accuracy(spec, first, nominal)}
            # one predictor at every line above 0 Hz: the model FRFs before and after,
            # and (sharing its models by parameter values) the updaters' predictors
            full = predictor(spec, records, [(rec.freq_hz > 0) for rec in records])
            h_initial = full.predict(nominal)
        comparison = {}
        for method in methods:
            try:
                with watch("update"):
                    res, masks = update_trial(spec, records, method, full=full)
            except Exception as exc:  # one method failing does not lose the others
                if method == methods[0]:
                    raise
                comparison[method] = f"{type(exc).__name__}: {exc}"
                continue
            comparison[method] = res
            with watch("score"):
                accuracy[method] = modal_accuracy(spec, first,
                                                  plant_parameters({**nominal,
                                                                    **res.as_dict()}))
            if method == methods[0]:
                result = res
        updated = {**nominal, **result.as_dict()}
        accuracy["updated"] = accuracy[methods[0]]
        with watch("score"):
            if stage is not None:
                stage = replace(stage, theta_updated=model_values(
                    spec, plant_parameters(updated), stage.mode_index))
            h_updated = full.predict(updated)
        return TrialResult(
            trial, tuple(records), truth, result, h_initial, h_updated, tuple(masks),
            accuracy, comparison=comparison, uncertainty=stage, seconds=watch.seconds)
    except Exception as exc:  # recorded per trial; the campaign goes on
        msg = f"{type(exc).__name__}: {exc}"
        if not isinstance(exc, ValueError | RuntimeError):
            msg += "\n" + traceback.format_exc(limit=3)
        return TrialResult(trial, tuple(records), truth, error=msg, seconds=watch.seconds)


def run_campaign(spec: CampaignSpec, *, trials: int | None = None, seed: int | None = None,
                 n_jobs: int | None = 1) -> CampaignResult:
    """Run every trial of a campaign.

    Parameters
    ----------
    spec : CampaignSpec
    trials, seed : int, optional
        Override the campaign's ``trials`` and ``seed``.
    n_jobs : int or None
        Parallel workers for :class:`joblib.Parallel`; None takes joblib's active
        configuration. The backend is joblib's too, so
        ``with joblib.parallel_config(backend="dask"): run_campaign(spec, n_jobs=-1)``
        runs the trials on a ``dask.distributed`` cluster without code changes. Results
        are identical for any worker count and backend (every trial draws from its own
        seed streams).
    """
    n_trials = spec.campaign.trials if trials is None else int(trials)
    if n_trials < 1:
        raise ValueError(f"trials must be >= 1; got {n_trials}")
    seed = spec.campaign.seed if seed is None else int(seed)
    results = Parallel(n_jobs=n_jobs)(delayed(run_trial)(spec, i, seed)
                                      for i in range(n_trials))
    return CampaignResult(spec, seed, __version__, spec.nominal_parameters(), tuple(results))
