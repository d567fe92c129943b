"""The Monte Carlo runner: campaign spec -> trials -> tests -> FRFs -> update.

For each trial the hardware is the truth model of the campaign; each test simulates a
band-limited random excitation through it, adds sensor noise, and estimates H1 FRFs.
The nominal model is then updated against all tests' FRFs. Randomness comes from one
``SeedSequence`` per (campaign seed, trial, test), so results do not depend on worker
count or order. A trial that fails is recorded with its error; the others finish.

Simulation detail (see :func:`simulate_test`): the recorded force is a periodic,
band-limited random signal, i.e. the samples of a smooth force. With
``simulation = "periodic"`` (the default) the response is its exact periodic steady
state, ``Y_k = G(j omega_k) U_k`` at every DFT line: no hold error and no transient.
With ``simulation = "time"`` the structure is driven
at ``oversample`` times the test rate through an exact first-order-hold simulation; a
piecewise-linear force has the baseband spectrum of its samples times
``sinc^2(f / fs_fine)``, so the drive is pre-emphasised by the inverse of that factor to
make its baseband equal the recorded force. What remains is the images of the hold near
multiples of the fine rate, which alias back at a relative level of about
``(f / fs_fine)^2`` (2e-4 at f = fs/10 with 8 times oversampling). A warm-up of whole
periods of the periodic input precedes the record, long enough for the slowest
decaying pole to fall by 1e-6 (at least one segment, at most four records, see
:func:`warm_up_samples`), so that the start-up transient does not leak into the FRFs.
"""

from __future__ import annotations

import time
import traceback

import numpy as np

from truthbench import __version__
from truthbench.campaign.results import STAGES, CampaignResult, TestRecord, TrialResult
from truthbench.campaign.spec import CampaignSpec
from truthbench.measure.frfdata import Channel, FRFData
from truthbench.plants import Actuator, Sensor


def excitation_rng(seed: int, trial: int, test: int) -> np.random.Generator:
    """The excitation and noise generator of one (trial, test): independent of run order
    and worker count (effects draw from their own streams, see
    :mod:`truthbench.campaign.truth`)."""
    return np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(trial, 0, test)))


def _io(spec: CampaignSpec, j: int):
    t = spec.tests[j]
    acts = [Actuator(a.station, a.direction) for a in t.actuators]
    sens = [Sensor(s.station, s.direction, s.quantity) for s in spec.test_sensors(j)]
    return acts, sens


def _apply_filters(x: np.ndarray, fs_hz: float, filters, delay_s: float = 0.0):
    """Filters (and a delay) applied to periodic records in the frequency domain: exact
    for the periodic band-limited signals used here (the delay is a pure linear phase)."""
    if not filters and delay_s == 0.0:
        return x
    n = x.shape[1]
    s = 2j * np.pi * np.fft.rfftfreq(n, 1.0 / fs_hz)
    X = np.fft.rfft(x, axis=1)
    for flt in filters:
        gain = np.polyval(flt.num, s) / np.polyval(flt.den, s)
        rows = slice(None) if flt.index is None else slice(flt.index, flt.index + 1)
        X[rows] = X[rows] * gain
    if delay_s:
        X = X * np.exp(-s * delay_s)
    return np.fft.irfft(X, n, axis=1)


def warm_up_samples(A: np.ndarray, segment: int, fs_hz: float, n: int,
                    decay: float = 1e-6) -> int:
    """Samples of periodic warm-up before the record: long enough for the slowest
    decaying (non-rigid) pole to fall by ``decay``, at least one FRF segment, at most
    four records. Rigid-body (zero) poles do not decay and are left out."""
    lam = np.linalg.eigvals(A)
    rates = -lam.real[np.abs(lam) > 1e-9 * max(np.abs(lam).max(), 1e-300)]
    rates = rates[rates > 0]
    if rates.size == 0:
        return segment
    t = np.log(1.0 / decay) / rates.min()
    return int(min(max(segment, np.ceil(t * fs_hz / 1.0)), 4 * n))


def _nonlinear_elements(setup, model, modes, m: int):
    """The setup's nonlinear laws as elements of the modal system (state [eta; eta'])."""
    from truthbench.errors import ModelError
    from truthbench.simulate.nonlinear import NonlinearElement

    if setup.loops:
        raise ModelError("a closed loop together with a nonlinear effect is not supported "
                         "yet; remove one of them")
    acc = np.array([q == "acceleration" for q in model.quantities])
    Cm = model.C_out @ modes.shapes
    out = []
    for station, direction, law in setup.nonlinear:
        label = f"n{setup.plant.station_node(station)}.{direction}"
        if label not in model.dof_labels:
            raise ModelError(f"nonlinear effect at {station}/{direction}: that DOF is clamped")
        phi = modes.shapes[model.dof_labels.index(label), :m]
        out.append(NonlinearElement.modal(law, phi, np.where(acc, Cm @ phi, 0.0)))
    return out


def _check_loop(loop, n_out: int, n_act: int) -> None:
    from truthbench.errors import ModelError

    if not (0 <= loop.output < n_out and 0 <= loop.input < n_act):
        raise ModelError(f"closed_loop: output {loop.output} / input {loop.input} outside "
                         f"the test's {n_out} sensors / {n_act} actuators")


def simulate_test(spec: CampaignSpec, j: int, setup, rng: np.random.Generator):
    """Simulate test ``j`` on the hardware described by ``setup``
    (:class:`~truthbench.effects.TestSetup`).

    Returns
    -------
    u : ndarray, shape (n_in, n_samples)
        Recorded inputs (the commanded force or moment, N or N m).
    y : ndarray, shape (n_out, n_samples)
        Recorded outputs: through sensor dynamics, delay, bias, then sensor noise.
    """
    from truthbench.model import modal_system
    from truthbench.simulate import add_sensor_noise, band_limited_random, simulate_lti

    test = spec.tests[j]
    acts, sens = _io(spec, j)
    n_act = len(acts)
    disturbers = [Actuator(st, d) for st, d, _ in setup.disturbances]
    model = setup.plant.build(setup.parameters, acts + disturbers, sens, setup.additions)
    modes = model.modes()
    n = int(round(test.record_s * test.fs_hz))
    periodic = test.simulation == "periodic" and not setup.nonlinear
    R = 1 if periodic else test.oversample
    fine_fs = test.fs_hz * R
    # periodic band-limited force; at the fine rate its decimation is exact
    u_fine = band_limited_random(n * R, fine_fs, test.level_rms, tuple(test.band_hz), rng,
                                 n_inputs=n_act)
    forces = _apply_filters(u_fine, fine_fs, setup.input_filters)  # actuator dynamics
    if disturbers:
        rms = [r for _, _, r in setup.disturbances]
        forces = np.vstack([forces, band_limited_random(n * R, fine_fs, rms,
                                                        tuple(test.band_hz), rng,
                                                        n_inputs=len(disturbers))])
    f = np.fft.rfftfreq(n * R, 1.0 / fine_fs)
    F = np.fft.rfft(forces, axis=1)
    if periodic:
        # excited lines (the force is band-limited; rounding leaves ~1e-16 elsewhere);
        # no static (0 Hz) force: a free body would drift away under it
        excited = np.any(np.abs(F) > 1e-12 * np.abs(F).max(), axis=0) & (f > 0)
        Y = np.zeros((len(sens), len(f)), dtype=complex)
        H = model.frf(f[excited], modes=modes)  # (n_exc, n_out, n_in)
        for loop in setup.loops:
            _check_loop(loop, len(sens), n_act)
            H = loop.close(H, f[excited])
        Y[:, excited] = np.einsum("foi,if->of", H, F[:, excited])
        y_fine = np.fft.irfft(Y, n, axis=1)
    else:
        A, B, C, D = modal_system(model, modes)
        if setup.loops:
            import control

            sys_ = control.ss(A, B, C, D)
            for loop in setup.loops:
                _check_loop(loop, len(sens), n_act)
                sys_ = control.feedback(sys_, loop.statespace(len(sens), B.shape[1]))
            A, B, C, D = (np.asarray(m) for m in (sys_.A, sys_.B, sys_.C, sys_.D))
        drive = np.fft.irfft(F / np.sinc(f / fine_fs) ** 2, n * R, axis=1)
        warm = warm_up_samples(A, n // test.averages, fine_fs, n) * R
        reps = -(-warm // (n * R))  # whole periods of the periodic drive before the record
        drive = np.concatenate([np.tile(drive, (1, reps))[:, -warm:], drive], axis=1)
        if setup.nonlinear:
            from truthbench.simulate.nonlinear import simulate_nonlinear

            elements = _nonlinear_elements(setup, model, modes, A.shape[0] // 2)
            y_fine = simulate_nonlinear(A, B, C, D, drive, 1.0 / fine_fs,
                                        elements).y[:, warm:]
        else:
            y_fine = simulate_lti(A, B, C, D, drive, 1.0 / fine_fs)[:, warm:]
    y_fine = _apply_filters(y_fine, fine_fs, setup.output_filters, setup.delay_s)
    u, y = u_fine[:, ::R], y_fine[:, ::R]
    y = setup.bias_gain * y + setup.bias_offset
    noise = float(np.hypot(test.noise_fraction, setup.noise_fraction))
    if noise > 0:
        y = add_sensor_noise(y, noise, rng)
    return u, y


def measure_test(spec: CampaignSpec, j: int, u, y, params: dict, *,
                 identify: bool = True) -> TestRecord:
    """H1 FRFs and coherence of test ``j`` from its time histories, then (if
    ``identify`` and the campaign identifies) its modes (:func:`identify_record`)."""
    from truthbench.measure import estimate_frf

    test = spec.tests[j]
    est = estimate_frf(u, y, test.fs_hz, estimator="H1", window=test.window,
                       n_averages=test.averages)
    acts, sens = _io(spec, j)
    outputs, inputs = channels(spec, acts, sens)
    frf = FRFData(test.name, est.freq_hz, est.H, outputs, inputs, coherence=est.coherence,
                  n_averages=est.n_averages, band_hz=tuple(test.band_hz),
                  notes=(f"H1, {test.window} window, {est.n_averages} averages of "
                         f"{est.nperseg} samples at {test.fs_hz:g} Hz",))
    record = TestRecord(test.name, frf, u, y, test.fs_hz, dict(params))
    return identify_record(spec, j, record) if identify else record


def channels(spec: CampaignSpec, actuators, sensors):
    """The FRF channels of a test's sensors (outputs) and actuators (inputs), at the
    stations' positions on the nominal beam (x along the beam, m)."""
    plant = spec.make_plant()
    x = plant.node_x_m(spec.nominal_parameters())

    def at(station):
        return (float(x[plant.station_node(station)]), 0.0, 0.0)

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
    from dataclasses import replace

    from truthbench.campaign.identification import identify_test

    return replace(record, modes=identify_test(spec, j, record,
                                               max_order=spec.identify.max_order))


def truth_record(setup) -> dict:
    """The exact truth of one test as flat name -> value pairs: plant parameters, then
    ``effect.<label>.<parameter>`` for every effect's realised values, plus the truth
    mesh and element physics."""
    out = {k: float(v) for k, v in setup.parameters.items()}
    out["truth.n_elements"] = float(setup.plant.n_elements)
    out["truth.timoshenko"] = float(setup.plant.timoshenko)
    for label, values in setup.effects.items():
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


APPENDED_PARAMETERS = {"delay_s": 0.0, "sensor_gain": 1.0}
"""Update parameters of the measurement chain, not of the plant, with their nominal
values: every model FRF is multiplied by ``sensor_gain exp(-j omega delay_s)``, what
the ``time_delay`` and ``sensor_bias`` (gain) effects do to the data. Only the
finite-difference method can update them: identified modes do not carry them."""


def plant_parameters(params: dict) -> dict:
    """``params`` without the appended-dynamics parameters."""
    return {k: v for k, v in params.items() if k not in APPENDED_PARAMETERS}


def model_frfs(spec: CampaignSpec, params: dict, records, masks) -> list[np.ndarray]:
    """The model FRFs at each test's update lines, one array per test (with the
    appended dynamics of :data:`APPENDED_PARAMETERS` found in ``params``).

    One model carries every test's actuators and sensors, so the structure is assembled
    and solved once per parameter set; each test takes its own rows and columns."""
    ios = [_io(spec, j) for j in range(len(records))]
    acts = list(dict.fromkeys(a for a_j, _ in ios for a in a_j))
    sens = list(dict.fromkeys(s for _, s_j in ios for s in s_j))
    model = spec.make_plant().build(plant_parameters(params), acts, sens)
    modes = model.modes()
    gain = params.get("sensor_gain", 1.0)
    delay = params.get("delay_s", 0.0)
    out = []
    for (a_j, s_j), rec, mask in zip(ios, records, masks, strict=True):
        rows = [sens.index(s) for s in s_j]
        cols = [acts.index(a) for a in a_j]
        f = rec.freq_hz[mask]
        H = model.frf(f, modes=modes)[:, rows][:, :, cols]
        if gain != 1.0 or delay != 0.0:
            H = H * (gain * np.exp(-2j * np.pi * f * delay))[:, None, None]
        out.append(H)
    return out


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


def measured_modes(spec: CampaignSpec, records, params: dict) -> list:
    """Identified modes of every test as :class:`~truthbench.update.MeasuredModes` at
    the model DOFs its (non-strain) sensors sit on."""
    from truthbench.update import MeasuredModes

    plant = spec.make_plant()
    labels = plant.build(params).dof_labels
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


def update_trial(spec: CampaignSpec, records, method: str | None = None):
    """Update the nominal model against the trial's data with one registered updater
    (default: the campaign's primary method)."""
    from truthbench.update import UpdateProblem, get_updater

    method = method or spec.update_methods()[0]
    masks = update_masks(spec, records)
    data = np.concatenate([rec.H[m].ravel() for rec, m in zip(records, masks, strict=True)])
    u = spec.update
    nominal = {**spec.nominal_parameters(),
               **{k: v for k, v in APPENDED_PARAMETERS.items() if k in u.parameters}}
    plant = spec.make_plant()

    def predict(theta):
        return np.concatenate([h.ravel() for h in model_frfs(spec, theta, records, masks)])

    def build_mk(theta):
        model = plant.build(theta)
        return model.M, model.K

    f_max = max(float(rec.freq_hz[m].max()) for rec, m in zip(records, masks, strict=True))
    problem = UpdateProblem(
        names=tuple(u.parameters), theta0=nominal, predict_frf=predict, frf_data=data,
        frf_weights=_weights(spec, records, masks),
        n_pairs=sum(rec.H.shape[1] * rec.H.shape[2] for rec in records),
        build_mk=build_mk, build_model=plant.build,
        measured=measured_modes(spec, records, nominal) if method == "sensitivity" else None,
        options={"finite_difference": dict(
                     max_iterations=u.max_iterations, tolerance=u.tolerance,
                     relative_step=u.relative_step, scheme=u.scheme,
                     # a delay starts at 0: additive, one radian at the band's top per unit
                     additive={"delay_s": 1.0 / (2 * np.pi * f_max)}
                     if "delay_s" in u.parameters else None),
                 "sensitivity": dict(max_iterations=u.max_iterations, mac_min=0.8,
                                     c_zeta=u.c_zeta)})
    return get_updater(method).update(problem), masks


def simulate_one(spec: CampaignSpec, trial: int, j: int, seed: int | None = None,
                 extra_effects=()) -> TestRecord:
    """Simulate and measure one test of one trial; ``extra_effects``
    (:class:`~truthbench.effects.EffectSpec`) are injected beside the campaign's own."""
    from truthbench.campaign.truth import build_test_setup
    from truthbench.errors import CampaignError

    if not 0 <= j < len(spec.tests):
        raise CampaignError(f"{spec.source}: test index {j} does not exist; expected "
                            f"0..{len(spec.tests) - 1} ({len(spec.tests)} tests)")
    if trial < 0:
        raise CampaignError(f"trial must be >= 0; got {trial}")
    seed = spec.campaign.seed if seed is None else seed
    setup = build_test_setup(spec, trial, j, seed, extra_effects)
    u, y = simulate_test(spec, j, setup, excitation_rng(seed, trial, j))
    return measure_test(spec, j, u, y, truth_record(setup))


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
    from threadpoolctl import threadpool_limits

    from truthbench.campaign.frf_band_stage import with_frf_band

    with threadpool_limits(limits=1, user_api="blas"):
        return with_frf_band(spec, _run_trial(spec, trial, seed))


def _run_trial(spec: CampaignSpec, trial: int, seed: int) -> TrialResult:
    from dataclasses import replace

    from truthbench.campaign.truth import build_test_setup

    truth = spec.truth_parameters()
    records: list[TestRecord] = []
    watch = _Stopwatch()
    try:
        for j in range(len(spec.tests)):
            with watch("simulate"):
                setup = build_test_setup(spec, trial, j, seed)
                u, y = simulate_test(spec, j, setup, excitation_rng(seed, trial, j))
            with watch("frf"):
                record = measure_test(spec, j, u, y, truth_record(setup), identify=False)
            with watch("identify"):
                record = identify_record(spec, j, record)
            if not _keeps_time_histories(spec, trial):
                record = replace(record, u=record.u[:, :0], y=record.y[:, :0])
            records.append(record)
        truth = hardware_truth(spec, records)
        nominal = spec.nominal_parameters()
        stage = None
        if len(records) > 1 and spec.identify.enabled:
            from truthbench.campaign.uncertainty_stage import uncertainty_stage

            with watch("bound"):
                stage = uncertainty_stage(spec, trial, seed, records, nominal)
        methods = spec.update_methods()
        if not methods:
            return TrialResult(trial, tuple(records), truth, uncertainty=stage,
                               seconds=watch.seconds)
        from truthbench.campaign.metrics import modal_accuracy

        with watch("score"):
            hardware = build_test_setup(spec, trial, 0, seed)
            accuracy = {"initial": modal_accuracy(spec, hardware, nominal)}
        comparison = {}
        for method in methods:
            try:
                with watch("update"):
                    res, masks = update_trial(spec, records, method)
            except Exception as exc:  # one method failing does not lose the others
                if method == methods[0]:
                    raise
                comparison[method] = f"{type(exc).__name__}: {exc}"
                continue
            comparison[method] = res
            with watch("score"):
                accuracy[method] = modal_accuracy(spec, hardware,
                                                  plant_parameters({**nominal,
                                                                    **res.as_dict()}))
            if method == methods[0]:
                result = res
        updated = {**nominal, **result.as_dict()}
        accuracy["updated"] = accuracy[methods[0]]
        with watch("score"):
            if stage is not None:
                from truthbench.campaign.uncertainty_stage import model_values

                stage = replace(stage, theta_updated=model_values(
                    spec, plant_parameters(updated), stage.mode_index))
            full = [(rec.freq_hz > 0) for rec in records]
            h_initial = tuple(model_frfs(spec, nominal, records, full))
            h_updated = tuple(model_frfs(spec, updated, records, full))
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
    from joblib import Parallel, delayed

    n_trials = spec.campaign.trials if trials is None else int(trials)
    if n_trials < 1:
        raise ValueError(f"trials must be >= 1; got {n_trials}")
    seed = spec.campaign.seed if seed is None else int(seed)
    results = Parallel(n_jobs=n_jobs)(delayed(run_trial)(spec, i, seed)
                                      for i in range(n_trials))
    return CampaignResult(spec, seed, __version__, spec.nominal_parameters(), tuple(results))
