"""Benchmark: Monte Carlo throughput, stage split, memory against trials, the hub-beam
trial; this tree against a base tree measured in the same run.

``python bench/bench_campaign.py [--base /tmp/base] [--trials 40] [--rounds 2]
[--memory 10 40] [--hub-rounds 3]``

Every measurement runs in a fresh subprocess with ``PYTHONPATH=<tree>/src``, the two
trees interleaved round by round (the machine is shared: medians of rounds, paired). It
prints, for each tree:

* trials per second of the quickstart on 1 and 2 local workers and (this tree, with
  ``dask.distributed`` installed) a Dask ``LocalCluster`` of 2 workers: this tree through
  :func:`truthbench.campaign.runner.run_to_store` (trials streamed to a store, then
  gathered into ``results.h5``), the base through ``run_campaign`` (in memory);
* the time split by stage (summed worker seconds per trial);
* the peak resident memory of the main process against the number of trials (one
  worker, in-process), and the largest worker's;
* one 8-test hub-beam trial, all stages, on one core
  (:func:`truthbench.campaign.trial.run_trial`);
* the ratios of this tree to the base.

A base tree is a checkout of the code before this work, e.g.
``git worktree add /tmp/base 3f2f919``. Without ``--base`` only this tree is measured.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parents[1]


# ---- measurements, run inside a subprocess -------------------------------------------
def _child(mode: str, campaign: str, trials: int, jobs: int) -> dict:
    import resource

    from truthbench.campaign.spec import load_campaign

    spec = load_campaign(campaign)
    new = _has_store()
    out = {}
    if mode == "hub":
        from threadpoolctl import threadpool_limits  # noqa: F401  (run_trial limits BLAS)

        try:  # the trial of a compiled plan
            from truthbench.campaign.plan import CampaignPlan
            from truthbench.campaign.trial import run_trial

            campaign = CampaignPlan.compile(spec)
        except ImportError:  # a base tree from before the plan: the trial of a spec
            from truthbench.campaign.runner import run_trial

            campaign = spec
        run_trial(campaign, 1, spec.campaign.seed)  # imports and caches outside the timing
        t0 = time.perf_counter()
        tr = run_trial(campaign, 0, spec.campaign.seed)
        out.update(seconds=time.perf_counter() - t0, stages=tr.seconds, error=tr.error)
    elif mode in ("throughput", "dask", "memory"):
        t0 = time.perf_counter()
        if new:
            from truthbench.campaign.runner import run_to_store
            from truthbench.campaign.store import TrialStore

            try:
                from truthbench.campaign.engines import make_engine
            except ImportError:  # a base tree from before the engines had their module
                from truthbench.campaign.runner import make_engine

            with tempfile.TemporaryDirectory(prefix="bench-") as folder:
                with make_engine(jobs, "local" if mode == "dask" else None) as engine:
                    t0 = time.perf_counter()
                    summary = run_to_store(spec, folder, trials=trials, engine=engine)
                out["run_s"] = time.perf_counter() - t0
                path = TrialStore(folder).consolidate()
                out["elapsed"] = time.perf_counter() - t0
                stages = _stages(path)
            out["worker_peak_mb"] = summary.peak_rss_mb
        else:
            from truthbench.campaign.runner import run_campaign

            result = run_campaign(spec, trials=trials, n_jobs=jobs)
            out["elapsed"] = time.perf_counter() - t0
            stages = result.stage_seconds
        out["stages"] = {k: v / trials for k, v in stages.items()}
        out["main_peak_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    return out


def _has_store() -> bool:
    try:
        from truthbench.campaign.runner import run_to_store  # noqa: F401
    except ImportError:
        return False
    return True


def _stages(path) -> dict:
    import h5py

    total: dict = {}
    with h5py.File(path, "r") as f:
        for g in f["trials"].values():
            for k, v in g["seconds"].attrs.items():
                total[k] = total.get(k, 0.0) + float(v)
    return total


# ---- the driver ------------------------------------------------------------------------
def _measure(tree: Path, mode: str, campaign: str, trials: int, jobs: int) -> dict:
    env = {**os.environ, "PYTHONPATH": str(tree / "src")}
    cmd = [sys.executable, __file__, "--child", mode, "--campaign", campaign,
           "--trials", str(trials), "--jobs", str(jobs)]
    t0 = time.perf_counter()
    done = subprocess.run(cmd, env=env, capture_output=True, text=True, cwd=tree)
    if done.returncode != 0:
        raise RuntimeError(f"{tree} {mode}: {done.stderr[-2000:]}")
    out = json.loads(done.stdout.strip().splitlines()[-1])
    out["process_s"] = time.perf_counter() - t0
    return out


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--campaign", default=str(HERE / "campaigns" / "quickstart.toml"))
    ap.add_argument("--hub", default=str(HERE / "campaigns" / "hub_beam.toml"))
    ap.add_argument("--base", help="a checkout of the code to compare against")
    ap.add_argument("--trials", type=int, default=40)
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--hub-rounds", type=int, default=3)
    ap.add_argument("--memory", type=int, nargs="+", default=[10, 40])
    ap.add_argument("--no-dask", action="store_true")
    ap.add_argument("--child", help=argparse.SUPPRESS)
    ap.add_argument("--jobs", type=int, default=1, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child:
        print(json.dumps(_child(args.child, args.campaign, args.trials, args.jobs)))
        return
    trees = {"this": HERE}
    if args.base:
        trees["base"] = Path(args.base).resolve()
    load = os.getloadavg()
    print(f"{os.cpu_count()} cores, load average {load[0]:.1f} {load[1]:.1f} {load[2]:.1f} "
          f"at the start; {args.rounds} round(s), trees interleaved")
    runs: dict = {}

    def record(key, value):
        runs.setdefault(key, []).append(value)

    for r in range(args.rounds):
        for name, tree in trees.items():
            for jobs in (1, 2):
                m = _measure(tree, "throughput", args.campaign, args.trials, jobs)
                record((name, f"{jobs} worker(s)"), m)
            if name == "this" and not args.no_dask:
                try:
                    m = _measure(tree, "dask", args.campaign, args.trials, 2)
                    record((name, "Dask LocalCluster, 2 workers"), m)
                except RuntimeError as exc:
                    print(f"  Dask skipped: {str(exc).splitlines()[-1]}")
                    args.no_dask = True
        print(f"  round {r + 1} done ({time.strftime('%H:%M:%S')})", flush=True)
    for _ in range(args.hub_rounds):
        for name, tree in trees.items():
            record((name, "hub"), _measure(tree, "hub", args.hub, 1, 1))
    for n in args.memory:
        for name, tree in trees.items():
            record((name, f"memory {n}"), _measure(tree, "memory", args.campaign, n, 1))
    load = os.getloadavg()
    print(f"load average {load[0]:.1f} {load[1]:.1f} {load[2]:.1f} at the end\n")

    def med(key, field):
        return statistics.median(x[field] for x in runs[key])

    print(f"quickstart, {args.trials} trials (median of {args.rounds} round(s); elapsed "
          f"includes starting the workers and, for this tree, gathering results.h5)")
    rates = {}
    for key in sorted(k for k in runs if k[1].endswith(("worker(s)", "workers"))):
        rate = args.trials / med(key, "elapsed")
        rates[key] = rate
        print(f"  {key[0]:5s} {key[1]:30s} {rate:6.2f} trials/s "
              f"({med(key, 'elapsed'):6.1f} s)")
    if "base" in trees:
        for what in ("1 worker(s)", "2 worker(s)"):
            print(f"  ratio this/base, {what}: "
                  f"{rates[('this', what)] / rates[('base', what)]:.2f}x")
    print("\ntime by stage, seconds per trial (summed over workers, 1 worker runs):")
    stages = ("simulate", "frf", "identify", "bound", "update", "score")
    for name in trees:
        st = runs[(name, "1 worker(s)")]
        per = {s: statistics.median(x["stages"].get(s, 0.0) for x in st) for s in stages}
        tot = sum(per.values())
        print(f"  {name:5s} " + "  ".join(f"{s} {per[s]:.3f}" for s in stages)
              + f"  total {tot:.3f} s ({100 * per['update'] / tot:.0f} % update)")
    print("\none 8-test hub-beam trial, all stages, one core (median):")
    for name in trees:
        h = runs[(name, "hub")]
        secs = statistics.median(x["seconds"] for x in h)
        up = statistics.median(x["stages"]["update"] for x in h)
        print(f"  {name:5s} {secs:6.2f} s ({up:.2f} s update); rounds "
              + ", ".join(f"{x['seconds']:.2f}" for x in h))
    if "base" in trees:
        ratio = med(("base", "hub"), "seconds") / med(("this", "hub"), "seconds")
        print(f"  ratio base/this: {ratio:.2f}x")
    print("\npeak resident memory against trials (1 worker, in-process; MB):")
    for name in trees:
        row = [f"{n} trials: main {runs[(name, f'memory {n}')][0]['main_peak_mb']:.0f}"
               for n in args.memory]
        print(f"  {name:5s} " + "; ".join(row))


if __name__ == "__main__":
    main()
