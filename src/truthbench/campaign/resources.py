"""What a run needs, estimated from its plan before any work: memory, disk and time.

One figure per test, :func:`simulation_bytes` (the memory its simulation holds at once),
feeds both checks: a campaign file is refused when it is read if one test alone cannot
fit in the memory available (:func:`check_memory`), and ``truthbench run`` refuses a run
whose workers, report or store cannot fit (:func:`estimate_resources`,
:func:`check_resources`), as ``truthbench validate`` reports them.
"""

from __future__ import annotations

import shutil
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from truthbench._validation import available_memory_bytes, format_bytes
from truthbench.errors import CampaignError

_BASE_PROCESS_MB = 180.0
"""Resident memory of a worker with numpy, scipy, h5py and truthbench loaded (MB;
measured 150-200 MB here)."""

_REPORT_BASE_MB = 250.0
"""Resident memory of the report process with numpy, scipy, h5py, pandas, matplotlib and
truthbench loaded and a figure drawn (MB; measured 237 MB for 100 quickstart trials)."""

_ROW_BYTES = 200.0
"""Memory of one row of a per-trial table kept by the report (a tuple of a dozen numbers
and names; :class:`~truthbench.campaign.tables.Tables`)."""

_SUMMARY_TRIAL_BYTES = 2000.0
"""Memory of one trial's summary beyond its rows: its uncertainty stage object and
arrays' headers (bytes)."""

_SECONDS_PER_OP = 2e-9
"""Seconds per complex multiply-add of the dominant kernels (modal FRF sums) on one core
of the machine the figures were taken on, calibrated so that the quickstart estimate
matches its measured trial time (about 0.6 s); a rough scale, not a benchmark."""


def truth_dofs(plan, test) -> int:
    """DOFs of the truth's mesh in ``test`` (a
    :class:`~truthbench.campaign.plan.TestPlan` of ``plan``): the campaign's elements
    refined by a ``discretization`` effect, 6 DOFs per node."""
    refine = max([int(e.options.get("refine", 1)) for _, e in test.effects
                  if e.name == "discretization"] or [1])
    return 6 * (plan.spec.plant.n_elements * refine + 1)


def simulation_bytes(test, n_dofs: int) -> tuple[int, str]:
    """A lower bound of the memory ``test`` (a
    :class:`~truthbench.campaign.plan.TestPlan`) holds at once while it is simulated.

    The larger of (a) its records, samples x channels x 8 bytes (x ``oversample`` on
    the time path, which steps at that multiple of the rate), and (b) on the periodic
    path the modal response at every line, lines x ``n_dofs`` x 16 bytes (one complex
    number per line and mode; the measured peak is about 26 bytes per line and DOF).

    Returns
    -------
    (bytes, what) : (int, str)
        The bound and how it was counted.
    """
    n = test.samples
    channels = len(test.actuators) + len(test.sensors)
    factor = test.test.oversample if test.time_path else 1
    records = 8 * n * channels * factor
    what = (f"{n} samples x {channels} channels x 8 bytes"
            + (f" x oversample {factor}" if factor > 1 else ""))
    if not test.time_path:
        modal = 16 * (n // 2 + 1) * n_dofs
        if modal > records:
            return modal, f"{n // 2 + 1} lines x {n_dofs} DOFs x 16 bytes"
    return records, what


def check_memory(plan) -> None:
    """Refuse a test whose simulation cannot fit in the memory available now
    (:func:`simulation_bytes` on the truth's mesh).

    Raises
    ------
    CampaignError
        Naming the file, the test's ``record_s`` key, the need and what is available.
    """
    available = available_memory_bytes()
    if available is None:
        return
    for t in plan.tests:
        need, what = simulation_bytes(t, truth_dofs(plan, t))
        if need > available:
            raise CampaignError(
                f"{plan.spec.source}: key 'tests[{t.index}].record_s': test {t.name!r} needs "
                f"at least {format_bytes(need)} ({what}), more than the "
                f"{format_bytes(available)} of memory available; expected a shorter record "
                f"or a lower fs_hz (record_s {t.test.record_s:g} s at fs_hz {t.fs_hz:g} Hz)")


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
        Memory of the report (MB): the process, its per-trial tables (a summary of every
        trial, :mod:`truthbench.campaign.summary`) and a few trials read whole for the
        figures.
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


def estimate_resources(plan, trials: int | None = None) -> ResourceEstimate:
    """Memory, disk and time a run of ``plan`` (a
    :class:`~truthbench.campaign.plan.CampaignPlan`) with ``trials`` trials needs: an
    estimate from the record lengths, channel counts and model size (see
    :class:`ResourceEstimate`); a worker's memory is the largest of a test's simulation
    (:func:`simulation_bytes`) and the update's arrays, over the process's own."""
    spec = plan.spec
    n_trials = spec.campaign.trials if trials is None else int(trials)
    model = plan.plant.build(plan.nominal)
    m = model.n_dofs
    keep = spec.output.time_histories
    worker, store, store0, ops, lines = 0.0, 0.0, 0.0, 0.0, []
    update_lines = 0
    for t in plan.tests:
        n_in, n_out = len(t.actuators), len(t.sensors)
        n = t.samples
        lines_all = max(t.segment, 1) // 2 + 1
        record_s = t.test.record_s
        excited = max(1, int(min(t.band_hz[1], t.fs_hz / 2) * record_s)
                      - int(t.band_hz[0] * record_s))
        R = t.test.oversample if t.time_path else 1
        worker = max(worker, simulation_bytes(t, truth_dofs(plan, t))[0] / 1e6)
        frf = 16 * lines_all * n_out * n_in
        frfs = (frf * 3 + 8 * lines_all * n_out * n_in + 8 * lines_all) / 1e6
        store += 0.05 + (frfs if spec.output.frfs == "all" else 0.0)
        store0 += frfs if spec.output.frfs != "all" else 0.0  # trial 0 keeps its FRFs
        # the modal sum over the excited lines, and time stepping on the time path
        ops += excited * m * n_out * n_in * (1 + 4 * R * (R > 1)) + R * n * m * (R > 1)
        if plan.methods:
            update_lines += int(t.update_lines().sum())
        lines.append(f"test {t.name!r}: {n} samples x ({n_in} in + {n_out} out), "
                     f"{lines_all} FRF lines, {excited} excited lines")
    if plan.methods:
        p = len(plan.update_names)
        update = 16 * update_lines * m * 6 / 1e6 + 16 * update_lines * 8 * p * 4 / 1e6
        worker = max(worker, update)
        # ~10 iterations of a prediction and a Jacobian, every updater
        ops += len(plan.methods) * 10 * update_lines * m * 8 * (2 + p)
    ops += len(plan.tests) * m**3 * 4  # eigen-solutions
    worker += _BASE_PROCESS_MB + 8 * m * m * 8 / 1e6
    # the report's tables: per trial, a row per parameter and updater, per mode of the
    # analysis band and model (modal accuracy pairs at most 30 modes), per test (two
    # tables); the uncertainty stage holds three numbers and a flag per test and bounded
    # parameter (a frequency and a damping ratio per mode of its band, at most 40)
    f = model.modes(min(40, m)).freq_hz
    in_band = [int(np.sum((f > 0) & (f >= lo) & (f <= hi)))
               for lo, hi in (plan.analysis_band_hz, plan.uncertainty_band_hz)]
    n_methods = len(plan.methods)
    rows = (len(plan.update_names) * n_methods
            + min(30, in_band[0]) * (1 + n_methods) * (n_methods > 0)
            + 2 * len(plan.tests) + 2)
    stage = 25 * len(plan.tests) * 2 * in_band[1] if len(plan.tests) > 1 else 0
    summary_mb = (rows * _ROW_BYTES + stage + _SUMMARY_TRIAL_BYTES) / 1e6
    histories = sum(8 * t.samples * (len(t.actuators) + len(t.sensors)) / 1e6
                    for t in plan.tests)
    first = store + store0 + (histories if keep in ("first_trial", "all") else 0.0)
    per = store + (histories if keep == "all" else 0.0)
    total = first + per * (n_trials - 1)
    lines.append(f"model: {m} DOFs (every mode is used)")
    lines.append(f"{n_trials} trials x {per:.2f} MB stored per trial"
                 + (f" (trial 0 {first:.2f} MB: it keeps its time histories or FRFs)"
                    if first != per else ""))
    report = _REPORT_BASE_MB + n_trials * summary_mb + 3 * first
    lines.append(f"report: {n_trials} trial summaries x {1000 * summary_mb:.1f} kB, and "
                 f"the trials its figures show read whole")
    return ResourceEstimate(m, worker, per, total, report,
                            max(ops * _SECONDS_PER_OP, 0.01), tuple(lines))


def available_memory_mb() -> float | None:
    """Memory available to new processes (MiB;
    :func:`truthbench._validation.available_memory_bytes`), or None."""
    available = available_memory_bytes()
    return None if available is None else available / 2**20


def check_resources(est: ResourceEstimate, *, workers: int, folder,
                    memory_mb: float | None = None, free_mb: float | None = None,
                    report: bool = True) -> None:
    """Refuse a run that cannot fit, before any work.

    Raises
    ------
    CampaignError
        Naming the estimate and what is available: workers' memory, the report's memory
        (a summary of every trial), the store on disk.
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
            f"would need about {est.report_mb:.0f} MB of memory (it keeps a summary of "
            f"every trial) and "
            f"{memory_mb:.0f} MB are available; run fewer --trials ({how})")
    if est.store_mb * 1.1 > free_mb:
        raise CampaignError(
            f"the results need about {est.store_mb:.0f} MB on disk and {free_mb:.0f} MB "
            f"are free in {folder}; free space, choose another --out or run fewer "
            f"--trials ({how})")
