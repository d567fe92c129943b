"""Running a campaign: every trial in memory, every trial streamed to a store, one test.

* :func:`run_campaign`: the Monte Carlo trials of a campaign, kept in memory, as a
  :class:`~truthbench.campaign.results.CampaignResult`;
* :func:`run_to_store`: the trials stored one by one as they finish
  (:class:`~truthbench.campaign.store.TrialStore`), resumable: what ``truthbench run``
  does;
* :func:`simulate_one`: one test of one trial, with effects injected (``truthbench
  simulate``, the diagnosis studies).

Each compiles the campaign once (:class:`~truthbench.campaign.plan.CampaignPlan`) and
runs the trial pipeline (:func:`~truthbench.campaign.trial.run_trial`) on an engine of
:mod:`truthbench.campaign.engines` (this process, local processes, a Dask cluster).
Results do not depend on the engine or the worker count: every trial draws from its own
seed streams.
"""

from __future__ import annotations

import logging
import shutil
import time
from dataclasses import dataclass
from pathlib import Path

from truthbench._version import __version__
from truthbench.campaign.engines import SerialEngine, _Engine, available_cores, make_engine
from truthbench.campaign.plan import CampaignPlan
from truthbench.campaign.results import CampaignResult, TestRecord
from truthbench.campaign.spec import CampaignSpec
from truthbench.campaign.trial import (
    excitation_rng,
    measure_test,
    run_trial,
    simulate_test,
    truth_record,
)
from truthbench.campaign.truth import build_hardware
from truthbench.errors import CampaignError

log = logging.getLogger("truthbench.run")


def _trials_and_seed(spec: CampaignSpec, trials: int | None, seed: int | None):
    n_trials = spec.campaign.trials if trials is None else int(trials)
    if n_trials < 1:
        raise ValueError(f"trials must be >= 1; got {n_trials}")
    return n_trials, spec.campaign.seed if seed is None else int(seed)


def run_campaign(spec: CampaignSpec, *, trials: int | None = None, seed: int | None = None,
                 n_jobs: int | None = 1, scheduler: str | None = None) -> CampaignResult:
    """Run every trial of a campaign, in memory.

    Parameters
    ----------
    spec : CampaignSpec
    trials, seed : int, optional
        Override the campaign's ``trials`` and ``seed``.
    n_jobs : int or None
        Workers, counted as joblib counts them: 1 (or None) runs in this process, more
        on local processes, -1 on every core available, -2 on all but one, ... (never
        more workers than trials); with ``scheduler``, the size of a Dask
        ``LocalCluster``.
    scheduler : str, optional
        ``"local"`` or ``"tcp://host:port"``: run on Dask
        (:class:`~truthbench.campaign.engines.DaskEngine`).

    Returns
    -------
    CampaignResult
        The trials in order. Identical for any worker count and engine (every trial
        draws from its own seed streams).
    """
    n_trials, seed = _trials_and_seed(spec, trials, seed)
    n_jobs = 1 if n_jobs is None else int(n_jobs)
    if n_jobs == 0:
        raise ValueError("n_jobs must be >= 1, or negative as in joblib (-1: every core); "
                         "got 0")
    if n_jobs < 0:
        n_jobs = max(1, available_cores() + 1 + n_jobs)
    plan = CampaignPlan.compile(spec)
    jobs = n_jobs if scheduler else min(n_jobs, n_trials)
    with make_engine(jobs, scheduler) as engine:
        results = sorted(engine.run(run_trial, plan, range(n_trials), seed),
                         key=lambda tr: tr.trial)
    return CampaignResult(spec, seed, __version__, dict(plan.nominal), tuple(results))


def simulate_one(spec: CampaignSpec, trial: int, j: int, seed: int | None = None,
                 extra_effects=()) -> TestRecord:
    """Simulate and measure test ``j`` of trial ``trial``; ``extra_effects``
    (:class:`~truthbench.effects.EffectSpec`) are injected beside the campaign's own."""
    if not 0 <= j < len(spec.tests):
        raise CampaignError(f"{spec.source}: test index {j} does not exist; expected "
                            f"0..{len(spec.tests) - 1} ({len(spec.tests)} tests)")
    if trial < 0:
        raise CampaignError(f"trial must be >= 0; got {trial}")
    seed = spec.campaign.seed if seed is None else seed
    plan = CampaignPlan.compile(spec)
    test = plan.tests[j]
    hardware = build_hardware(plan, test, trial, seed, extra_effects)
    u, y = simulate_test(test, hardware, excitation_rng(seed, trial, j))
    return measure_test(plan, test, u, y, truth_record(hardware))


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


def run_to_store(spec: CampaignSpec | CampaignPlan, folder, *, trials: int | None = None,
                 seed: int | None = None, jobs: int = 1, scheduler: str | None = None,
                 resume: bool = False, progress=None, engine: _Engine | None = None
                 ) -> RunSummary:
    """Run a campaign's trials, each stored as soon as it finishes
    (:class:`~truthbench.campaign.store.TrialStore` under ``folder/trials``).

    Parameters
    ----------
    spec : CampaignSpec or CampaignPlan
        The campaign, or its plan when the caller has compiled it already.
    folder : str or pathlib.Path
        Output folder; it must not hold a store unless ``resume``.
    trials, seed : int, optional
        Override the campaign's ``trials`` and ``seed``.
    jobs : int
        Workers (local processes, or the size of a Dask ``LocalCluster``).
    scheduler : str, optional
        ``"local"`` or ``"tcp://host:port"``: run on Dask
        (:class:`~truthbench.campaign.engines.DaskEngine`).
    resume : bool
        Continue the store's run: it must be the same campaign, seed and trial count
        (checked against ``trials/run.json``); only the trials not stored run.
    progress : callable, optional
        ``progress(trial, summary)`` after every stored trial (``summary`` as returned
        by :func:`~truthbench.campaign.engines.trial_job`).
    engine : optional
        An engine from :func:`~truthbench.campaign.engines.make_engine` to use instead
        of making one.

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
    from truthbench.campaign.engines import trial_job
    from truthbench.campaign.store import StoreError, TrialStore

    plan = spec if isinstance(spec, CampaignPlan) else CampaignPlan.compile(spec)
    spec = plan.spec
    n_trials, seed = _trials_and_seed(spec, trials, seed)
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
        for trial, image, summary in engine.run(trial_job, plan, todo, seed):
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
