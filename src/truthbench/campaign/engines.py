"""Where trials run: in this process, on local worker processes, or on a Dask cluster.

One engine family for every way a campaign runs: :func:`make_engine` gives a
:class:`SerialEngine`, a :class:`ProcessEngine` or a :class:`DaskEngine`, and
``engine.run(job, plan, trials, seed)`` yields ``job(plan, trial, seed)`` for every trial
as the trials finish, with at most ``2 * workers`` in flight (memory does not grow with
the trial count). :func:`~truthbench.campaign.runner.run_campaign` runs
:func:`~truthbench.campaign.trial.run_trial` on it (results in memory),
:func:`~truthbench.campaign.runner.run_to_store` runs :func:`trial_job` (each trial as
the bytes of a stored file). Results do not depend on the engine or the worker count:
every trial draws from its own seed streams.
"""

from __future__ import annotations

import logging
import os
import signal
import sys

from truthbench._version import __version__
from truthbench.errors import CampaignError


def trial_job(plan, trial: int, seed: int, version: str = __version__
              ) -> tuple[int, bytes, dict]:
    """Run one trial of ``plan`` and return it as a stored file image (in a worker).

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
    from truthbench.campaign.trial import run_trial

    tr = run_trial(plan, trial, seed)
    image = trial_image(plan.spec, seed, version, plan.nominal, tr)
    return trial, image, {"error": tr.error, "seconds": dict(tr.seconds),
                          "peak_rss_mb": _peak_rss_mb()}


def _peak_rss_mb() -> float | None:
    try:
        import resource

        kb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
        return kb / 1024 if sys.platform != "darwin" else kb / 2**20
    except (ImportError, OSError):  # pragma: no cover - platforms without resource
        return None


_M_TRIM_THRESHOLD, _M_MMAP_THRESHOLD = -1, -3  # glibc's mallopt parameters
_malloc_tuned = False


def tune_malloc() -> bool:
    """In a worker process (once): glibc's malloc keeps arrays up to 32 MiB in its heap
    and returns memory to the system above 64 MiB of free heap (Linux; elsewhere
    nothing is done).

    These are the ceilings glibc's own dynamic thresholds reach once a process has freed
    a few large arrays. Dask's nanny starts its workers with ``MALLOC_TRIM_THRESHOLD_``
    set (65536), and setting any threshold turns the dynamic ones off: the mmap threshold
    stays at 128 KiB, every larger array becomes a fresh mapping, and its pages are
    faulted in again each time. A trial allocates and frees hundreds of MB of such
    arrays (modal sums, Jacobians), and that doubled the worker time per quickstart
    trial measured here (0.45 -> 0.66 s, the same trial in one process with and without
    the variable). A worker's peak memory is a trial's, so keeping freed pages costs
    nothing more.

    Returns
    -------
    bool
        Whether the thresholds are set (now or before).
    """
    global _malloc_tuned
    if _malloc_tuned or not sys.platform.startswith("linux"):
        return _malloc_tuned
    try:
        import ctypes

        libc = ctypes.CDLL("libc.so.6")
        _malloc_tuned = bool(libc.mallopt(_M_MMAP_THRESHOLD, 32 << 20)
                             and libc.mallopt(_M_TRIM_THRESHOLD, 64 << 20))
    except (OSError, AttributeError):  # pragma: no cover - not glibc
        pass
    return _malloc_tuned


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
    tune_malloc()


def batch_size(remaining: int, workers: int, largest: int) -> int:
    """Trials in the next task of a Dask run: ``ceil(remaining / (2 workers))``, at most
    ``largest`` and at least one (guided self-scheduling).

    Large batches save the scheduler's and the client's round trips; the batches shrink
    as the run ends, so that the workers finish together: with fixed batches of four, 20
    trials on two workers ran as 12 against 8, a fifth longer than 10 and 10. Which
    trials share a task does not change any trial's result."""
    if remaining <= 0:
        return 0
    return max(1, min(int(largest), -(-remaining // (2 * max(1, int(workers))))))


def run_batch(job, plan, trials, seed) -> list:
    """``job(plan, trial, seed)`` for every trial of a batch, in order (one Dask task)."""
    tune_malloc()
    return [job(plan, t, seed) for t in trials]


class _Engine:
    """Runs ``job(plan, trial, seed)`` for a sequence of trials and yields the results as
    they finish, with at most ``2 * workers`` trials in flight. Used as a context
    manager: leaving it (normally, by an exception or Ctrl-C) ends every worker it
    started."""

    workers = 1
    label = "1 process"

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False

    def close(self) -> None:
        pass

    def run(self, job, plan, trials, seed):  # pragma: no cover - abstract
        raise NotImplementedError


class SerialEngine(_Engine):
    """Trials one after another in this process."""

    def run(self, job, plan, trials, seed):
        for t in trials:
            yield job(plan, t, seed)


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

    def run(self, job, plan, trials, seed):
        from concurrent.futures import FIRST_COMPLETED, wait

        todo = iter(trials)
        pending = set()
        limit = 2 * self.workers
        while True:
            for t in todo:
                pending.add(self._pool.submit(job, plan, t, seed))
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
    truthbench installed; the plan is sent to each worker once.

    Trials go out in batches of up to ``batch`` per task (:func:`run_batch`), at most
    ``2 * workers`` tasks in flight: each task costs the scheduler and the client a
    round trip and its result's transfer, and four quickstart trials per task ran 15 to
    25 % faster than one here (2 workers of a LocalCluster, whose scheduler shares the
    main process's core). The batches shrink towards the end of the run
    (:func:`batch_size`), so that no worker is left with a batch while the others idle.
    A worker lost mid-run (killed, its machine gone) costs its batch: the scheduler runs
    the batch again on another worker, and each batch's results arrive once, so no trial
    is lost or stored twice. A batch whose workers keep dying (the scheduler gives up
    after ``distributed.scheduler.allowed-failures`` deaths) is a
    :class:`~truthbench.errors.CampaignError` naming its trials.
    """

    def __init__(self, scheduler: str, workers: int, batch: int = 4):
        try:
            from distributed import Client, LocalCluster
        except ImportError:
            raise CampaignError(
                "--scheduler needs dask.distributed, which is not installed; install the "
                "extra: pip install 'truthbench[dask]'") from None
        if int(batch) < 1:
            raise ValueError(f"batch must be >= 1 trial per task; got {batch}")
        self.batch = int(batch)
        self._cluster = None
        if scheduler == "local":
            self._cluster = LocalCluster(n_workers=int(workers), threads_per_worker=1,
                                         processes=True, dashboard_address=None,
                                         silence_logs=logging.CRITICAL)
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

    def run(self, job, plan, trials, seed):
        from distributed import as_completed

        # a key of its own (not the content's): a later run of the same plan on this
        # engine must not share a key the end of this one releases
        plan_f = self._client.scatter(plan, broadcast=True, hash=False)
        todo = list(trials)
        queue = as_completed()
        batches = {}

        def submit() -> bool:
            size = batch_size(len(todo), self.workers, self.batch)
            batch, todo[:size] = todo[:size], []
            if not batch:
                return False
            fut = self._client.submit(run_batch, job, plan_f, batch, seed, pure=False)
            batches[fut.key] = batch
            queue.add(fut)
            return True

        for _ in range(2 * self.workers):
            if not submit():
                break
        for fut in queue:
            batch = batches.pop(fut.key)
            try:
                results = fut.result()
            except Exception as exc:
                if type(exc).__name__ != "KilledWorker":
                    raise
                raise CampaignError(
                    f"trials {batch[0]}-{batch[-1]}: the Dask workers running them died "
                    f"too often ({exc}); the trials already stored are kept: find the "
                    f"cause (a worker's memory limit, its log) and continue with "
                    f"--resume") from None
            fut.release()
            yield from results
            submit()

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
