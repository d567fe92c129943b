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

import logging
import os
import shutil
import signal
import sys
import time
import traceback
from dataclasses import dataclass, replace
from pathlib import Path

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
from truthbench.measure.leakage import Estimator
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
    n = u.shape[1]
    periodic = n % est.nperseg == 0  # the force is periodic over the record
    frf = FRFData(test.name, est.freq_hz, est.H, outputs, inputs, coherence=est.coherence,
                  n_averages=est.n_averages, band_hz=tuple(test.band_hz),
                  notes=(f"H1, {test.window} window, {est.n_averages} averages of "
                         f"{est.nperseg} samples at {test.fs_hz:g} Hz",),
                  estimator=Estimator(test.window, est.nperseg, test.fs_hz,
                                      n if periodic else None),
                  input_rms=tuple(float(v) for v in np.sqrt(np.mean(u**2, axis=1))))
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


# ======================================================================================
# Running at scale: trials streamed to a store, on local processes or a Dask cluster
# ======================================================================================

log = logging.getLogger("truthbench.run")


def trial_job(spec: CampaignSpec, trial: int, seed: int, version: str = __version__
              ) -> tuple[int, bytes, dict]:
    """Run one trial and return it as a stored file image (in a worker).

    Returns
    -------
    trial : int
    image : bytes
        A results file holding this trial alone
        (:func:`~truthbench.campaign.store.trial_image`).
    summary : dict
        ``error`` (str or None), ``seconds`` (per stage), ``peak_rss_mb`` (the worker's
        peak resident memory so far, MB; None where unknown).
    """
    from truthbench.campaign.store import trial_image

    tr = run_trial(spec, trial, seed)
    image = trial_image(spec, seed, version, spec.nominal_parameters(), tr)
    return trial, image, {"error": tr.error, "seconds": dict(tr.seconds),
                          "peak_rss_mb": _peak_rss_mb()}


def _peak_rss_mb() -> float | None:
    try:
        import resource

        kb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
        return kb / 1024 if sys.platform != "darwin" else kb / 2**20
    except (ImportError, OSError):  # pragma: no cover - platforms without resource
        return None


def available_cores() -> int:
    """Cores this process may run on (its CPU affinity, else ``os.cpu_count``)."""
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):  # pragma: no cover - not Linux
        return os.cpu_count() or 1


def _worker_init(parent_pid: int) -> None:
    """In every local worker: end with the main process (Linux: the kernel sends SIGKILL
    when the parent dies, even by SIGKILL), and leave Ctrl-C to the main process."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if sys.platform.startswith("linux"):
        try:
            import ctypes

            libc = ctypes.CDLL("libc.so.6", use_errno=True)
            libc.prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
        except OSError:  # pragma: no cover - no libc.so.6
            pass
    if os.getppid() != parent_pid:  # the parent died before prctl took effect
        os._exit(1)


class _Engine:
    """Runs ``trial_job`` for a sequence of trials and yields results as they finish,
    with at most ``2 * workers`` trials in flight (memory does not grow with the trial
    count). Used as a context manager: leaving it (normally, by an exception or Ctrl-C)
    ends every worker it started."""

    workers = 1
    label = "1 process"

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False

    def close(self) -> None:
        pass

    def run(self, spec, trials, seed):  # pragma: no cover - abstract
        raise NotImplementedError


class SerialEngine(_Engine):
    """Trials one after another in this process."""

    def run(self, spec, trials, seed):
        for t in trials:
            yield trial_job(spec, t, seed)


class ProcessEngine(_Engine):
    """Local worker processes (joblib's loky executor: fresh interpreters that do not
    re-run the caller's main module; BLAS single-threaded in every trial); workers
    ignore Ctrl-C and die with the main process."""

    def __init__(self, workers: int):
        from joblib.externals.loky.process_executor import ProcessPoolExecutor

        self.workers = int(workers)
        self.label = f"{self.workers} local processes"
        self._pool = ProcessPoolExecutor(max_workers=self.workers,
                                         initializer=_worker_init, initargs=(os.getpid(),))

    def run(self, spec, trials, seed):
        from concurrent.futures import FIRST_COMPLETED, wait

        todo = iter(trials)
        pending = set()
        limit = 2 * self.workers
        while True:
            for t in todo:
                pending.add(self._pool.submit(trial_job, spec, t, seed))
                if len(pending) >= limit:
                    break
            if not pending:
                return
            finished, pending = wait(pending, return_when=FIRST_COMPLETED)
            for fut in finished:
                yield fut.result()

    def close(self) -> None:
        procs = list((getattr(self._pool, "_processes", None) or {}).values())
        self._pool.shutdown(wait=False, kill_workers=True)
        for p in procs:
            if p.is_alive():
                p.terminate()
        for p in procs:
            p.join(timeout=5)
            if p.is_alive():  # a worker slow to end on SIGTERM (a loaded machine)
                # loky's Popen has no kill(): signal the process itself
                try:
                    os.kill(p.pid, signal.SIGKILL)
                except ProcessLookupError:  # it ended in between
                    pass
                p.join(timeout=5)


class DaskEngine(_Engine):
    """A ``dask.distributed`` cluster: ``"local"`` starts a ``LocalCluster`` of
    ``workers`` single-threaded worker processes on this machine; an address
    (``tcp://host:port``) connects to a running scheduler. Every worker needs the same
    truthbench installed."""

    def __init__(self, scheduler: str, workers: int):
        try:
            from distributed import Client, LocalCluster
        except ImportError:
            raise CampaignError(
                "--scheduler needs dask.distributed, which is not installed; install the "
                "extra: pip install 'truthbench[dask]'") from None
        self._cluster = None
        if scheduler == "local":
            self._cluster = LocalCluster(n_workers=int(workers), threads_per_worker=1,
                                         processes=True, dashboard_address=None,
                                         silence_logs=logging.ERROR)
            self._client = Client(self._cluster)
            self.label = f"Dask LocalCluster of {workers} worker(s)"
        else:
            try:
                self._client = Client(scheduler, timeout="10s")
            except OSError as exc:
                raise CampaignError(f"--scheduler {scheduler}: cannot connect to a Dask "
                                    f"scheduler there ({exc})") from None
            self.label = f"Dask scheduler {scheduler}"
        self.workers = max(1, sum(w.get("nthreads", 1) for w in
                                  self._client.scheduler_info()["workers"].values()))

    def run(self, spec, trials, seed):
        from distributed import as_completed

        spec_f = self._client.scatter(spec, broadcast=True)
        todo = iter(trials)
        queue = as_completed()
        limit = 2 * self.workers
        n = 0
        for t in todo:
            queue.add(self._client.submit(trial_job, spec_f, t, seed, pure=False))
            n += 1
            if n >= limit:
                break
        for fut in queue:
            result = fut.result()
            fut.release()
            yield result
            for t in todo:
                queue.add(self._client.submit(trial_job, spec_f, t, seed, pure=False))
                break

    def close(self) -> None:
        try:
            self._client.close()
        finally:
            if self._cluster is not None:
                self._cluster.close()


def make_engine(jobs: int = 1, scheduler: str | None = None) -> _Engine:
    """The engine for ``jobs`` workers: in-process for 1, local processes for more, or a
    Dask cluster for ``scheduler`` (``"local"`` or ``tcp://host:port``)."""
    if scheduler:
        return DaskEngine(scheduler, jobs)
    return SerialEngine() if jobs <= 1 else ProcessEngine(jobs)


@dataclass(frozen=True)
class RunSummary:
    """What :func:`run_to_store` did.

    Attributes
    ----------
    folder : pathlib.Path
        The run's output folder (store under ``trials/`` until consolidated).
    n_trials : int
        Trials the run has (requested).
    stored : int
        Trials in the store now.
    ran : int
        Trials run by this call.
    failed : tuple of (int, str)
        Trials of this call that failed, with the first line of their error.
    elapsed_s : float
        Wall-clock seconds of this call.
    peak_rss_mb : float or None
        The largest peak resident memory of a worker (MB).
    """

    folder: Path
    n_trials: int
    stored: int
    ran: int
    failed: tuple = ()
    elapsed_s: float = 0.0
    peak_rss_mb: float | None = None

    @property
    def complete(self) -> bool:
        return self.stored >= self.n_trials


def run_to_store(spec: CampaignSpec, folder, *, trials: int | None = None,
                 seed: int | None = None, jobs: int = 1, scheduler: str | None = None,
                 resume: bool = False, progress=None, engine: _Engine | None = None
                 ) -> RunSummary:
    """Run a campaign's trials, each stored as soon as it finishes
    (:class:`~truthbench.campaign.store.TrialStore` under ``folder/trials``).

    Parameters
    ----------
    spec : CampaignSpec
    folder : str or pathlib.Path
        Output folder; it must not hold a store unless ``resume``.
    trials, seed : int, optional
        Override the campaign's ``trials`` and ``seed``.
    jobs : int
        Workers (local processes, or the size of a Dask ``LocalCluster``).
    scheduler : str, optional
        ``"local"`` or ``"tcp://host:port"``: run on Dask (:class:`DaskEngine`).
    resume : bool
        Continue the store's run: it must be the same campaign, seed and trial count
        (checked against ``trials/run.json``); only the trials not stored run.
    progress : callable, optional
        ``progress(trial, summary)`` after every stored trial (``summary`` as returned
        by :func:`trial_job`).
    engine : optional
        An engine from :func:`make_engine` to use instead of making one.

    Returns
    -------
    RunSummary

    Raises
    ------
    StoreError
        The store cannot be written (the trials already stored are kept), or
        ``resume`` with a store of another run.
    KeyboardInterrupt
        Passed on after the workers were ended; every finished trial is stored.

    Notes
    -----
    Results do not depend on ``jobs`` or the engine: every trial draws from its own
    seed streams, and the store holds trials by number.
    """
    from truthbench.campaign.store import StoreError, TrialStore

    n_trials = spec.campaign.trials if trials is None else int(trials)
    if n_trials < 1:
        raise ValueError(f"trials must be >= 1; got {n_trials}")
    seed = spec.campaign.seed if seed is None else int(seed)
    store = TrialStore(folder)
    if store.exists:
        if not resume:
            raise StoreError(f"{store.dir}: holds a run already; resume it (resume=True) "
                             f"or remove it")
        store.check(spec, seed, n_trials)
        removed = store.clean_partial()
        if removed:
            log.info("removed %d partly written trial file(s)", removed)
    else:
        store.create(spec, seed, n_trials, __version__)
    done = set(store.done())
    todo = [t for t in range(n_trials) if t not in done]
    log.info("%d of %d trials stored; %d to run", len(done), n_trials, len(todo))
    t0 = time.perf_counter()
    failed, peak, ran = [], None, 0
    own = engine is None
    engine = engine or (make_engine(jobs, scheduler) if todo else SerialEngine())
    try:
        for trial, image, summary in engine.run(spec, todo, seed):
            free = shutil.disk_usage(store.dir).free
            if free < 2 * len(image) + 1e6:
                raise StoreError(
                    f"{store.dir}: only {free / 1e6:.1f} MB free, trial {trial} needs "
                    f"{len(image) / 1e6:.1f} MB; the {len(done)} trial(s) already stored are "
                    f"kept: free space and continue with --resume")
            store.write(trial, image)
            done.add(trial)
            ran += 1
            if summary.get("error"):
                failed.append((trial, summary["error"].splitlines()[0]))
                log.warning("trial %d failed: %s", trial, failed[-1][1])
            else:
                log.info("trial %d stored (%.2f s)", trial, sum(summary["seconds"].values()))
            if summary.get("peak_rss_mb") is not None:
                peak = max(peak or 0.0, summary["peak_rss_mb"])
            if progress is not None:
                progress(trial, summary)
    finally:
        if own:
            engine.close()
    return RunSummary(Path(folder), n_trials, len(done), ran, tuple(failed),
                      time.perf_counter() - t0, peak)


# ---- sizes before any work ------------------------------------------------------------
_BASE_PROCESS_MB = 180.0
"""Resident memory of a worker with numpy, scipy, h5py and truthbench loaded (MB;
measured 150-200 MB here)."""

_SECONDS_PER_OP = 2e-9
"""Seconds per complex multiply-add of the dominant kernels (modal FRF sums) on one core
of the machine the figures were taken on, calibrated so that the quickstart estimate
matches its measured trial time (about 0.6 s); a rough scale, not a benchmark."""


@dataclass(frozen=True)
class ResourceEstimate:
    """What a run will need, estimated from the campaign before any work.

    Attributes
    ----------
    n_dofs : int
        Model size (DOFs of the nominal model; every mode is used).
    worker_mb : float
        Peak resident memory of one worker running one trial (MB).
    store_mb_per_trial : float
        Stored size of one trial (MB; the first trial more when it keeps time histories).
    store_mb : float
        The whole run's store (and ``results.h5``; MB).
    report_mb : float
        Memory of the report, which loads every trial (MB).
    seconds_per_trial : float
        Rough wall-clock seconds of one trial on one core.
    lines : str
        How the figures were obtained (trials x record length x channels, model size).
    """

    n_dofs: int
    worker_mb: float
    store_mb_per_trial: float
    store_mb: float
    report_mb: float
    seconds_per_trial: float
    lines: tuple[str, ...] = ()


def estimate_resources(spec: CampaignSpec, trials: int | None = None) -> ResourceEstimate:
    """Memory, disk and time a run of ``trials`` trials needs (an estimate from the
    record lengths, channel counts and model size; see :class:`ResourceEstimate`)."""
    n_trials = spec.campaign.trials if trials is None else int(trials)
    model = spec.make_plant().build(spec.nominal_parameters())
    m = model.n_dofs
    keep = spec.output.time_histories
    worker, store, store0, ops, lines = 0.0, 0.0, 0.0, 0.0, []
    update_lines = 0
    for j, t in enumerate(spec.tests):
        acts, sens = spec.test_io(j)
        n_in, n_out = len(acts), len(sens)
        n = int(round(t.record_s * t.fs_hz))
        seg = max(n // t.averages, 1)
        lines_all = seg // 2 + 1
        excited = max(1, int(min(t.band_hz[1], t.fs_hz / 2) * t.record_s)
                      - int(t.band_hz[0] * t.record_s))
        R = 1 if t.simulation == "periodic" else t.oversample
        # time histories, their spectra, the modal sum over the excited lines (3 arrays)
        sim = (8 * n * R * (n_in + n_out) * 3 + 16 * excited * m * 3
               + 16 * excited * n_out * n_in * 2) / 1e6
        worker = max(worker, sim)
        frf = 16 * lines_all * n_out * n_in
        store += (frf * 3 + 8 * lines_all * n_out * n_in + 8 * lines_all) / 1e6 + 0.05
        th = 8 * n * (n_in + n_out) / 1e6
        store0 += th
        ops += excited * m * n_out * n_in * (1 + 4 * R * (R > 1)) + R * n * m * (R > 1)
        lo, hi = t.band_hz
        if spec.update.band_hz is not None:
            lo, hi = max(lo, spec.update.band_hz[0]), min(hi, spec.update.band_hz[1])
        update_lines += max(0, int((hi - lo) * seg / t.fs_hz))
        lines.append(f"test {t.name!r}: {n} samples x ({n_in} in + {n_out} out), "
                     f"{lines_all} FRF lines, {excited} excited lines")
    methods = spec.update_methods()
    if methods:
        p = len(spec.update.parameters)
        update = 16 * update_lines * m * 6 / 1e6 + 16 * update_lines * 8 * p * 4 / 1e6
        worker = max(worker, update)
        # ~10 iterations of a prediction and a Jacobian, every updater
        ops += len(methods) * 10 * update_lines * m * 8 * (2 + p)
    ops += len(spec.tests) * m**3 * 4  # eigen-solutions
    worker += _BASE_PROCESS_MB + 8 * m * m * 8 / 1e6
    first = store + store0 if keep in ("first_trial", "all") else store
    per = store + store0 if keep == "all" else store
    total = first + per * (n_trials - 1)
    lines.append(f"model: {m} DOFs (every mode is used)")
    lines.append(f"{n_trials} trials x {per:.2f} MB stored per trial"
                 + (f" (the first {first:.2f} MB with its time histories)"
                    if first != per else ""))
    return ResourceEstimate(m, worker, per, total, total * 1.2 + _BASE_PROCESS_MB,
                            max(ops * _SECONDS_PER_OP, 0.01), tuple(lines))


def available_memory_mb() -> float | None:
    """Memory available to new processes (MB; Linux ``MemAvailable``), or None."""
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return float(line.split()[1]) / 1024
    except OSError:
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE") / 2**20
    except (ValueError, OSError, AttributeError):  # pragma: no cover
        return None


def check_resources(est: ResourceEstimate, *, workers: int, folder,
                    memory_mb: float | None = None, free_mb: float | None = None,
                    report: bool = True) -> None:
    """Refuse a run that cannot fit, before any work.

    Raises
    ------
    CampaignError
        Naming the estimate and what is available: workers' memory, the report's memory
        (it loads every trial), the store on disk.
    """
    memory_mb = available_memory_mb() if memory_mb is None else memory_mb
    if free_mb is None:
        probe = Path(folder)
        while not probe.exists() and probe != probe.parent:
            probe = probe.parent
        free_mb = shutil.disk_usage(probe).free / 1e6
    how = "; ".join(est.lines)
    if memory_mb is not None and est.worker_mb * workers > memory_mb:
        raise CampaignError(
            f"the run needs about {est.worker_mb * workers:.0f} MB of memory "
            f"({workers} worker(s) x {est.worker_mb:.0f} MB) and {memory_mb:.0f} MB are "
            f"available; use fewer --jobs or shorter records ({how})")
    if report and memory_mb is not None and est.report_mb > memory_mb:
        raise CampaignError(
            f"the report of {est.store_mb / max(est.store_mb_per_trial, 1e-9):.0f} trials "
            f"would need about {est.report_mb:.0f} MB of memory (it loads every trial) and "
            f"{memory_mb:.0f} MB are available; run fewer --trials ({how})")
    if est.store_mb * 1.1 > free_mb:
        raise CampaignError(
            f"the results need about {est.store_mb:.0f} MB on disk and {free_mb:.0f} MB "
            f"are free in {folder}; free space, choose another --out or run fewer "
            f"--trials ({how})")
