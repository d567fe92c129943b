"""``truthbench run``: simulate, measure, update and report a campaign.

Every finished trial is stored at once (``DIR/trials/``, one file per trial, written
atomically); at the end the trials are gathered into ``DIR/results.h5`` and the report is
written from it. An interrupted run (Ctrl-C, a killed process, a full disk) keeps every
finished trial, and ``--resume`` runs only the missing ones.
"""

from __future__ import annotations

import logging
import sys
from pathlib import Path

OUTPUT_NAMES = ("results.h5", "results.h5.part", "report.md", "report.html", "poles.png",
                "frf_band.png", "calibration.png", "convergence.png", "frf.png")
"""Files of a run's folder (besides ``frf_<test>.png`` and ``trials/``) that ``--force``
replaces."""


def _outputs(folder: Path) -> list[Path]:
    """The run outputs in ``folder``: report.html first, then report.md, results.h5 and
    the figures."""
    order = {"report.html": 0, "report.md": 1, "results.h5": 2}
    found = [p for p in folder.iterdir() if p.is_file() and (
        p.name in OUTPUT_NAMES or (p.name.startswith("frf_") and p.suffix == ".png"))]
    return sorted(found, key=lambda p: (order.get(p.name, 3), p.name))


def _earlier_run(folder: Path) -> str | None:
    """What of an earlier run the folder holds, or None."""
    from truthbench.campaign.store import RESULTS_FILE, TrialStore

    store = TrialStore(folder)
    if store.exists:
        try:
            head = store.header()
            return (f"a store of {len(store.done())} of {head.get('trials')} trial(s) of "
                    f"campaign {head.get('campaign')!r}")
        except OSError:
            return "a store of an earlier run"
    if (folder / RESULTS_FILE).exists():
        return f"{RESULTS_FILE} of an earlier run"
    if folder.is_dir() and _outputs(folder):
        return "the report of an earlier run"
    return None


def _clear(folder: Path) -> None:
    """Remove an earlier run's outputs (only the files a run writes)."""
    import shutil

    from truthbench.campaign.store import TRIALS_DIR

    for p in _outputs(folder):
        p.unlink(missing_ok=True)
    shutil.rmtree(folder / TRIALS_DIR, ignore_errors=True)


def _check_writable(folder: Path) -> None:
    import os
    import tempfile

    from truthbench.campaign.store import StoreError

    try:
        folder.mkdir(parents=True, exist_ok=True)
        fd, probe = tempfile.mkstemp(prefix=".write-test-", dir=folder)
        os.close(fd)
        os.unlink(probe)
    except OSError as exc:
        raise StoreError(f"{folder}: the output folder is not writable "
                         f"({exc.strerror or exc}); choose another with --out") from None


def setup_logging(verbose: int, quiet: bool) -> None:
    """Log through :mod:`logging` to stderr: warnings by default, ``-v`` info (every
    trial), ``-vv`` debug; ``--quiet`` errors only."""
    level = (logging.ERROR if quiet else logging.WARNING if not verbose
             else logging.INFO if verbose == 1 else logging.DEBUG)
    handler = logging.StreamHandler(sys.stderr)
    try:  # lines printed through tqdm do not break its bar
        from tqdm.contrib.logging import _TqdmLoggingHandler

        handler = _TqdmLoggingHandler()
    except ImportError:  # pragma: no cover - tqdm is a dependency
        pass
    handler.setFormatter(logging.Formatter("%(levelname)s: %(message)s"))
    root = logging.getLogger("truthbench")
    root.handlers[:] = [handler]
    root.setLevel(level)
    root.propagate = False


def _cmd_run(args) -> int:
    from truthbench.campaign.engines import available_cores, make_engine
    from truthbench.campaign.plan import CampaignPlan
    from truthbench.campaign.resources import check_resources, estimate_resources
    from truthbench.campaign.runner import run_to_store
    from truthbench.campaign.spec import load_campaign
    from truthbench.campaign.store import RESULTS_FILE, StoreError, TrialStore

    setup_logging(args.verbose, args.quiet)
    log = logging.getLogger("truthbench.run")
    spec = load_campaign(args.campaign)
    out = Path(args.out) if args.out else Path("results") / spec.campaign.name
    n_trials = spec.campaign.trials if args.trials is None else args.trials
    seed = spec.campaign.seed if args.seed is None else args.seed
    if n_trials < 1:
        raise _usage(f"--trials must be >= 1; got {n_trials}")
    if args.jobs < 1:
        raise _usage(f"--jobs must be >= 1; got {args.jobs}")
    if args.resume and args.force:
        raise _usage("--resume and --force exclude each other: --resume continues the "
                     "stored run, --force replaces it")
    jobs = args.jobs
    cores = available_cores()
    if args.scheduler in (None, "local") and jobs > cores:
        log.warning("--jobs %d capped at the %d core(s) available", jobs, cores)
        jobs = cores
    earlier = _earlier_run(out) if out.is_dir() else None
    store = TrialStore(out)
    if earlier and not (args.force or args.resume):
        print(f"truthbench run: {out} holds {earlier}; it is kept. Continue it with "
              f"--resume, or replace it with --force", file=sys.stderr)
        return 2
    if args.resume and not store.exists and (out / RESULTS_FILE).exists():
        if not args.quiet:
            print(f"{out}: the run is complete ({RESULTS_FILE}); nothing to resume")
            for p in _outputs(out):
                print(f"  {p}")
        return 0
    if args.resume and store.exists:
        store.check(spec, seed, n_trials)
    elif args.force and earlier:
        _clear(out)
    _check_writable(out)
    plan = CampaignPlan.compile(spec)
    est = estimate_resources(plan, n_trials)
    check_resources(est, workers=1 if args.scheduler not in (None, "local") else jobs,
                    folder=out)
    done0 = len(store.done()) if store.exists else 0
    todo = n_trials - done0
    if args.scheduler in (None, "local"):
        jobs = max(1, min(jobs, todo))  # no more workers than trials to run
    log.info("estimate: %.0f MB per worker, %.1f MB per stored trial, %.2f s per trial "
             "on one core", est.worker_mb, est.store_mb_per_trial, est.seconds_per_trial)
    bar = None
    if todo > 1 and not args.quiet:
        from tqdm import tqdm

        bar = tqdm(total=n_trials, initial=done0, unit="trial", desc=spec.campaign.name,
                   file=sys.stderr, dynamic_ncols=True, smoothing=0.1)
    failed_now = []

    def progress(trial, summary):
        if summary.get("error"):
            failed_now.append(trial)
        if bar is not None:
            bar.update(1)
            if failed_now:
                bar.set_postfix(failed=len(failed_now), refresh=False)

    engine = None
    try:
        engine = make_engine(jobs, args.scheduler) if todo > 0 else None
        if engine is not None:
            log.info("running %d trial(s) on %s", todo, engine.label)
        summary = run_to_store(plan, out, trials=n_trials, seed=seed, resume=args.resume,
                               progress=progress, engine=engine)
    except KeyboardInterrupt:
        if engine is not None:
            engine.close()
        if bar is not None:
            bar.close()
        kept = len(store.done())
        print(f"\ninterrupted: {kept} of {n_trials} trial(s) stored in {store.dir}; "
              f"continue with: truthbench run {args.campaign} --out {out} --resume",
              file=sys.stderr)
        return 130
    except StoreError as exc:
        if bar is not None:
            bar.close()
        print(f"truthbench run: error: {exc}", file=sys.stderr)
        return 1
    finally:
        if engine is not None:
            engine.close()
        if bar is not None:
            bar.close()
    try:
        return _finish(spec, out, store, summary, args)
    except KeyboardInterrupt:
        print(f"\ninterrupted while writing the results file or the report; every trial is "
              f"stored: write them with: truthbench report {out}", file=sys.stderr)
        return 130


def _finish(spec, out: Path, store, summary, args) -> int:
    from truthbench.campaign.results import CampaignResult
    from truthbench.campaign.store import StoreError
    from truthbench.report.accuracy import parameter_text, write_report

    try:
        path = store.consolidate()
    except StoreError as exc:
        print(f"truthbench run: error: {exc}", file=sys.stderr)
        return 1
    result = CampaignResult.load(path)
    try:
        write_report(result, out, results_path=path)
    except OSError as exc:  # a full disk or a folder that became unwritable
        print(f"truthbench run: error: cannot write the report in {out} ({exc}); the "
              f"results are complete in {path}: write the report later with "
              f"'truthbench report {path}'", file=sys.stderr)
        return 1
    if not args.quiet:
        table = parameter_text(result)
        if table:
            print(table)
    failed = result.failed
    for t in failed:
        print(f"trial {t.trial} failed: {t.error.splitlines()[0]}", file=sys.stderr)
    if not args.quiet:
        print(f"{len(result.trials)} trial(s) in {summary.elapsed_s:.1f} s "
              f"({summary.ran} run now); outputs:")
        for p in _outputs(out):
            print(f"  {p}")
    return 1 if len(failed) == len(result.trials) else 0


def _usage(msg: str):
    from truthbench.errors import CampaignError

    return CampaignError(msg)


def register(sub) -> None:
    r = sub.add_parser("run", help="run a campaign: simulate, measure, update, report")
    r.add_argument("campaign", help="campaign TOML file")
    r.add_argument("--out", help="output folder (default results/<campaign name>)")
    r.add_argument("--trials", type=int, help="Monte Carlo trials (overrides the file)")
    r.add_argument("--seed", type=int, help="seed (overrides the file)")
    r.add_argument("--jobs", type=int, default=1,
                   help="parallel workers (capped at the cores available; with "
                        "--scheduler local, the LocalCluster's workers)")
    r.add_argument("--scheduler", metavar="local|tcp://HOST:PORT",
                   help="run on Dask: 'local' starts a LocalCluster of --jobs workers, an "
                        "address connects to a running scheduler (needs the dask extra)")
    r.add_argument("--resume", action="store_true",
                   help="continue the run stored in the output folder (same campaign, seed "
                        "and trials); only the missing trials run")
    r.add_argument("--force", action="store_true",
                   help="replace the results of an earlier run in the output folder")
    r.add_argument("-q", "--quiet", action="store_true",
                   help="no progress bar, table or output list; errors only")
    r.add_argument("-v", "--verbose", action="count", default=0,
                   help="log every trial (-v) or debug detail (-vv) to stderr")
    r.set_defaults(func=_cmd_run)
