"""Benchmark: Monte Carlo throughput on local processes and on Dask, the stage split, the
hub-beam trial, and the memory of ``truthbench run`` and ``truthbench report`` against
the trial count; this tree against a base tree measured in the same run.

``python bench/bench_campaign.py [--base /tmp/base] [--trials 40] [--rounds 2]
[--hub-rounds 3] [--memory 100 1000 10000] [--hub-memory 100 1000]
[--base-memory-max 1000] [--base-hub-memory-max 100]``

Every measurement runs in a fresh subprocess with ``PYTHONPATH=<tree>/src``, the two
trees interleaved round by round (the machine is shared: medians of rounds, paired). It
prints, for each tree:

* trials per second of the quickstart on 1 and 2 local worker processes and on a Dask
  ``LocalCluster`` of 2 workers, through
  :func:`truthbench.campaign.runner.run_to_store` (trials streamed to a store, then
  gathered into ``results.h5``); the engine is started and its workers warmed by a
  short run first (their start-up is printed apart), and its shutdown is not timed, so
  that the rates compare the engines, not their start-up and shutdown; Dask's rate over
  the local processes' is its overhead;
* the time split by stage (summed worker seconds per trial, 1 worker);
* one 8-test hub-beam trial, all stages, on one core
  (:func:`truthbench.campaign.trial.run_trial`), with its stage split;
* the peak resident memory of ``truthbench run --resume`` (one trial left to run, then
  ``results.h5`` gathered and the report written) and of ``truthbench report`` over
  stores of 100, 1000 and 10 000 quickstart trials and 1000 hub-beam trials: synthetic
  stores, a few real trials copied under every trial number (the copies are stored
  trials like any other: their files, summaries and groups are renamed to their
  number). A base tree whose report loads every trial is measured up to
  ``--base-memory-max`` quickstart and ``--base-hub-memory-max`` hub-beam trials (10 000
  quickstart trials would need about 20 GB, 1000 hub-beam trials 10 GB);
* the ratios of this tree to the base.

A base tree is a checkout of the code before this work, e.g.
``git worktree add /tmp/base 247057a``. Without ``--base`` only this tree is measured.
The stores need disk: about 2 MB per quickstart trial and 7 MB per hub-beam trial, twice
while ``results.h5`` is gathered (40 GB for 10 000 quickstart trials); each is removed
after it is measured.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parents[1]


# ---- measurements, run inside a subprocess -------------------------------------------
def _child(mode: str, campaign: str, trials: int, jobs: int, folder: str) -> dict:
    import resource

    from truthbench.campaign.spec import load_campaign, parse_campaign

    spec = load_campaign(campaign)
    out: dict = {}
    if mode == "hub":
        from truthbench.campaign.plan import CampaignPlan
        from truthbench.campaign.trial import run_trial

        plan = CampaignPlan.compile(spec)
        run_trial(plan, 1, spec.campaign.seed)  # imports and caches outside the timing
        t0 = time.perf_counter()
        tr = run_trial(plan, 0, spec.campaign.seed)
        out.update(seconds=time.perf_counter() - t0, stages=tr.seconds, error=tr.error)
    elif mode in ("local", "dask"):
        from truthbench.campaign.engines import make_engine
        from truthbench.campaign.runner import run_to_store
        from truthbench.campaign.store import TrialStore

        with tempfile.TemporaryDirectory(prefix="bench-") as tmp:
            t0 = time.perf_counter()
            with make_engine(jobs, "local" if mode == "dask" else None) as engine:
                # start and warm every worker (imports, caches) outside the timing, with
                # the campaign renamed (older Dask engines scatter the plan under a key
                # of its content, and releasing it could race with the timed run's)
                d = spec.to_toml_dict()
                d["campaign"]["name"] += "-warm"
                run_to_store(parse_campaign(d, source=spec.source), Path(tmp) / "warm",
                             trials=2 * jobs, engine=engine)
                out["start_s"] = time.perf_counter() - t0
                t0 = time.perf_counter()
                summary = run_to_store(spec, Path(tmp) / "run", trials=trials,
                                       engine=engine)
                out["run_s"] = time.perf_counter() - t0
            # the engine's shutdown (a LocalCluster's takes 0.5-1 s) is left out like
            # its start-up: elapsed = the run and gathering results.h5
            t1 = time.perf_counter()
            path = TrialStore(Path(tmp) / "run").consolidate()
            out["elapsed"] = out["run_s"] + time.perf_counter() - t1
            out["stages"] = {k: v / trials for k, v in _stages(path).items()}
        out["worker_peak_mb"] = summary.peak_rss_mb
    elif mode == "synthetic":
        out["built_s"] = _synthetic_store(spec, Path(folder), trials)
    elif mode == "cli":
        from truthbench.cli import main

        t0 = time.perf_counter()
        out["code"] = main(json.loads(folder))
        out["elapsed"] = time.perf_counter() - t0
    out["peak_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    return out


def _stages(path) -> dict:
    import h5py

    total: dict = {}
    with h5py.File(path, "r") as f:
        for g in f["trials"].values():
            for k, v in g["seconds"].attrs.items():
                total[k] = total.get(k, 0.0) + float(v)
    return total


def _synthetic_store(spec, folder: Path, n: int, real: int = 4) -> float:
    """A store of ``n - 1`` of ``n`` trials: ``real`` trials run, the others copies of
    trials 1.. of them under their own numbers (file, HDF5 group, summary)."""
    import h5py

    from truthbench._version import __version__
    from truthbench.campaign.engines import trial_job
    from truthbench.campaign.plan import CampaignPlan
    from truthbench.campaign.store import TrialStore
    from truthbench.io.hdf5 import trial_key

    t0 = time.perf_counter()
    plan = CampaignPlan.compile(spec)
    store = TrialStore(folder)
    store.create(spec, spec.campaign.seed, n, __version__)
    for t in range(real):
        _, image, _ = trial_job(plan, t, spec.campaign.seed)
        store.write(t, image)
    for t in range(real, n - 1):
        k = 1 + (t - 1) % (real - 1)  # trial 0 keeps its time histories: not copied
        dst = store.trial_path(t)
        shutil.copyfile(store.trial_path(k), dst)
        with h5py.File(dst, "a") as f:
            f.move(f"trials/{trial_key(k)}", f"trials/{trial_key(t)}")
            g = f[f"trials/{trial_key(t)}"]
            if "summary" in g:  # a tree whose trials carry their summary
                d = json.loads(g["summary"][()])
                d["trial"] = t
                del g["summary"]
                g.create_dataset("summary", data=json.dumps(d),
                                 dtype=h5py.string_dtype("utf-8"))
    return time.perf_counter() - t0


# ---- the driver ------------------------------------------------------------------------
def _measure(tree: Path, mode: str, campaign: str, trials: int = 1, jobs: int = 1,
             folder: str = "") -> dict:
    env = {**os.environ, "PYTHONPATH": str(tree / "src")}
    cmd = [sys.executable, __file__, "--child", mode, "--campaign", campaign,
           "--trials", str(trials), "--jobs", str(jobs), "--folder", folder]
    done = subprocess.run(cmd, env=env, capture_output=True, text=True, cwd=tree)
    if done.returncode != 0:
        raise RuntimeError(f"{tree} {mode}: {done.stderr[-2000:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def _memory(tree: Path, campaign: str, n: int) -> dict:
    """Peak memory of ``truthbench run --resume`` and ``truthbench report`` over a
    synthetic store of ``n`` trials of ``campaign`` (made, measured, removed)."""
    work = Path(tempfile.mkdtemp(prefix="bench-store-"))
    try:
        built = _measure(tree, "synthetic", campaign, n, folder=str(work))
        run = _measure(tree, "cli", campaign, folder=json.dumps(
            ["run", campaign, "--trials", str(n), "--out", str(work), "--resume", "-q"]))
        report = _measure(tree, "cli", campaign,
                          folder=json.dumps(["report", str(work / "results.h5")]))
        size = (work / "results.h5").stat().st_size / 1e9
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return {"run_mb": run["peak_mb"], "run_s": run["elapsed"], "report_mb": report["peak_mb"],
            "report_s": report["elapsed"], "built_s": built["built_s"], "gb": size}


def _load() -> str:
    return "load average " + " ".join(f"{v:.2f}" for v in os.getloadavg())


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--campaign", default=str(HERE / "campaigns" / "quickstart.toml"))
    ap.add_argument("--hub", default=str(HERE / "campaigns" / "hub_beam.toml"))
    ap.add_argument("--base", help="a checkout of the code to compare against")
    ap.add_argument("--trials", type=int, default=40)
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--hub-rounds", type=int, default=3)
    ap.add_argument("--memory", type=int, nargs="*", default=[100, 1000, 10000])
    ap.add_argument("--hub-memory", type=int, nargs="*", default=[100, 1000])
    ap.add_argument("--base-memory-max", type=int, default=1000,
                    help="largest quickstart store the base is measured on")
    ap.add_argument("--base-hub-memory-max", type=int, default=100,
                    help="largest hub-beam store the base is measured on (its report "
                         "loads every trial: about 10 GB for 1000)")
    ap.add_argument("--no-dask", action="store_true")
    ap.add_argument("--child", help=argparse.SUPPRESS)
    ap.add_argument("--jobs", type=int, default=1, help=argparse.SUPPRESS)
    ap.add_argument("--folder", default="", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child:
        print(json.dumps(_child(args.child, args.campaign, args.trials, args.jobs,
                                args.folder)))
        return
    trees = {"this": HERE}
    if args.base:
        trees["base"] = Path(args.base).resolve()
    print(f"{os.cpu_count()} cores, {_load()} at the start; {args.rounds} round(s), trees "
          f"interleaved", flush=True)
    runs: dict = {}

    def record(key, value):
        runs.setdefault(key, []).append(value)

    engines = [("local", 1), ("local", 2)] + ([] if args.no_dask else [("dask", 2)])
    for r in range(args.rounds):
        for name, tree in trees.items():
            for mode, jobs in engines:
                record((name, mode, jobs), _measure(tree, mode, args.campaign, args.trials,
                                                    jobs))
        print(f"  round {r + 1} done ({time.strftime('%H:%M:%S')}, {_load()})", flush=True)
    for _ in range(args.hub_rounds):
        for name, tree in trees.items():
            record((name, "hub"), _measure(tree, "hub", args.hub))
    print(f"  hub-beam trials done ({time.strftime('%H:%M:%S')}, {_load()})", flush=True)
    memory = {}
    for campaign, sizes, base_max in ((args.campaign, args.memory, args.base_memory_max),
                                      (args.hub, args.hub_memory, args.base_hub_memory_max)):
        for n in sizes:
            for name, tree in trees.items():
                if name == "base" and n > base_max:
                    continue
                memory[(name, Path(campaign).stem, n)] = _memory(tree, campaign, n)
            print(f"  memory of {n} {Path(campaign).stem} trials done "
                  f"({time.strftime('%H:%M:%S')}, {_load()})", flush=True)
    print(f"{_load()} at the end\n")

    if args.rounds:
        _print_rates(args, trees, engines, runs)
    if args.hub_rounds:
        _print_hub(trees, runs)
    _print_memory(memory)


STAGES = ("simulate", "frf", "identify", "bound", "update", "score")


def _med(runs, key, field):
    return statistics.median(x[field] for x in runs[key])


def _print_rates(args, trees, engines, runs) -> None:
    print(f"quickstart, {args.trials} trials (median of {args.rounds} round(s); the engine "
          f"started and warmed first; elapsed includes gathering results.h5)")
    rates = {}
    for name in trees:
        for mode, jobs in engines:
            key = (name, mode, jobs)
            rates[key] = args.trials / _med(runs, key, "elapsed")
            what = f"{jobs} local worker(s)" if mode == "local" else "Dask LocalCluster of 2"
            print(f"  {name:5s} {what:24s} {rates[key]:6.2f} trials/s "
                  f"({_med(runs, key, 'elapsed'):6.1f} s; start-up "
                  f"{_med(runs, key, 'start_s'):4.1f} s)")
        if not args.no_dask:
            over = rates[(name, "local", 2)] / rates[(name, "dask", 2)] - 1
            print(f"  {name:5s} Dask's overhead against 2 local workers: {100 * over:+.1f} %")
    if "base" in trees:
        for mode, jobs in engines:
            print(f"  ratio this/base, {mode} {jobs}: "
                  f"{rates[('this', mode, jobs)] / rates[('base', mode, jobs)]:.2f}x")
    print("\ntime by stage, worker seconds per trial (1 local worker, median of rounds):")
    for name in trees:
        st = runs[(name, "local", 1)]
        per = {s: statistics.median(x["stages"].get(s, 0.0) for x in st) for s in STAGES}
        print(f"  {name:5s} " + "  ".join(f"{s} {per[s]:.3f}" for s in STAGES)
              + f"  total {sum(per.values()):.3f} s")


def _print_hub(trees, runs) -> None:
    print("\none 8-test hub-beam trial, all stages, one core (median):")
    for name in trees:
        h = runs[(name, "hub")]
        per = {s: statistics.median(x["stages"].get(s, 0.0) for x in h) for s in STAGES}
        print(f"  {name:5s} {_med(runs, (name, 'hub'), 'seconds'):6.2f} s; rounds "
              + ", ".join(f"{x['seconds']:.2f}" for x in h) + "; "
              + "  ".join(f"{s} {per[s]:.3f}" for s in STAGES))
    if "base" in trees:
        ratio = _med(runs, ("base", "hub"), "seconds") / _med(runs, ("this", "hub"), "seconds")
        print(f"  ratio base/this: {ratio:.2f}x")


def _print_memory(memory) -> None:
    print("\npeak resident memory (MB) of 'truthbench run --resume' (1 trial to run, "
          "results.h5, the report) and 'truthbench report', synthetic stores:")
    for (name, campaign, n), m in memory.items():
        print(f"  {name:5s} {campaign:10s} {n:6d} trials ({m['gb']:5.1f} GB): run "
              f"{m['run_mb']:6.0f} MB ({m['run_s']:6.1f} s), report {m['report_mb']:6.0f} MB "
              f"({m['report_s']:6.1f} s)")


if __name__ == "__main__":
    main()
