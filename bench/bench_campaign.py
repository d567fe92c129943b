"""Benchmark: a Monte Carlo campaign on 1 and 2 workers.

``python bench/bench_campaign.py [--campaign campaigns/quickstart.toml] [--trials 200]
[--jobs 1 2]``

Runs the campaign's trials with each worker count (joblib, loky backend; BLAS
single-threaded inside every trial) and prints:

* elapsed (wall-clock) time and trials per second for each worker count, and the
  speed-up against 1 worker measured in the same run (the reference);
* the time split by stage (simulate, frf, identify, bound, update, score), summed over
  the trials' workers (:attr:`truthbench.campaign.results.TrialResult.seconds`);
* whether the results are identical across worker counts (FRFs, identified modes,
  updated parameters, uncertainty bounds: exact equality, not a tolerance).

A 2-core machine shared with other work gives noisy wall-clock figures; the speed-up
is bounded by 2 and by the cores actually free.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from truthbench.campaign.results import STAGES
from truthbench.campaign.runner import run_campaign
from truthbench.campaign.spec import load_campaign


def _signature(result) -> list[np.ndarray]:
    """Every number a trial produced, flattened, for an exact comparison."""
    out = []
    for tr in result.trials:
        out.append(np.array([len(tr.error or "")], dtype=float))
        for rec in tr.tests:
            out += [rec.H, rec.coherence]
            if rec.modes is not None:
                out += [np.asarray(rec.modes.freq_hz), np.asarray(rec.modes.damping_ratio)]
        if tr.update is not None:
            out.append(np.asarray(tr.update.values))
        if tr.uncertainty is not None:
            out += [tr.uncertainty.theta_tests, tr.uncertainty.bound]
    return out


def _identical(a, b) -> bool:
    sa, sb = _signature(a), _signature(b)
    return len(sa) == len(sb) and all(np.array_equal(x, y, equal_nan=True)
                                      for x, y in zip(sa, sb, strict=True))


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--campaign", default="campaigns/quickstart.toml")
    ap.add_argument("--trials", type=int, default=200)
    ap.add_argument("--jobs", type=int, nargs="+", default=[1, 2])
    args = ap.parse_args(argv)
    spec = load_campaign(args.campaign)
    run_campaign(spec, trials=1)  # warm caches (imports, numba) outside the timing
    print(f"campaign {spec.campaign.name!r}: {args.trials} trials, "
          f"{len(spec.tests)} tests each")
    results, elapsed = {}, {}
    for n in args.jobs:
        t0 = time.perf_counter()
        results[n] = run_campaign(spec, trials=args.trials, n_jobs=n)
        elapsed[n] = time.perf_counter() - t0
        failed = sum(t.error is not None for t in results[n].trials)
        print(f"  {n} worker(s): {elapsed[n]:8.1f} s elapsed, "
              f"{args.trials / elapsed[n]:6.3f} trials/s, {failed} failed trial(s)")
    ref = args.jobs[0]
    for n in args.jobs[1:]:
        print(f"  speed-up {ref} -> {n} workers: {elapsed[ref] / elapsed[n]:.2f}x; "
              f"results identical: {_identical(results[ref], results[n])}")
    split = results[ref].stage_seconds
    total = sum(split.values())
    print(f"  time by stage ({ref} worker(s), summed over trials, {total:.1f} s):")
    for stage in STAGES:
        print(f"    {stage:9s} {split[stage]:8.1f} s  {100 * split[stage] / total:5.1f} %  "
              f"({1000 * split[stage] / args.trials:7.1f} ms per trial)")


if __name__ == "__main__":
    main()
