"""Profile: where one Monte Carlo trial spends its time, stage by stage.

``python bench/profile_trial.py [campaign.toml ...] [--top 15] [--trial 0] [--sort tottime]``

For each campaign (default the quickstart and the hub beam) one trial runs first
untimed (imports, caches, numba compilation), then the next trial runs under
:mod:`cProfile` with one profiler per stage of
:data:`truthbench.campaign.results.STAGES` (the trial's own stopwatch switches them), and
the top functions of every stage are printed with the stage's share of the trial. BLAS is
single-threaded inside a trial, as in a worker.
"""

from __future__ import annotations

import argparse
import cProfile
import io
import os
import pstats
import time
from pathlib import Path

HERE = Path(__file__).resolve().parents[1]


def profile_trial(campaign: str, trial: int = 1) -> tuple[dict, dict, float]:
    """Run trial ``trial`` of ``campaign`` with a profiler per stage.

    Returns
    -------
    profiles : dict
        Stage -> :class:`cProfile.Profile`.
    seconds : dict
        Stage -> wall-clock seconds (the trial's own stopwatch).
    total : float
        Wall-clock seconds of the trial.
    """
    from truthbench.campaign import trial as trial_module
    from truthbench.campaign.plan import CampaignPlan
    from truthbench.campaign.spec import load_campaign

    spec = load_campaign(campaign)
    plan = CampaignPlan.compile(spec)
    trial_module.run_trial(plan, trial + 1, spec.campaign.seed)  # warm: imports, caches
    profiles: dict = {}
    base = trial_module._Stopwatch

    class Profiled(base):
        def __enter__(self):
            prof = profiles.setdefault(self._stage, cProfile.Profile())
            prof.enable()
            super().__enter__()

        def __exit__(self, *exc):
            super().__exit__(*exc)
            profiles[self._stage].disable()

    trial_module._Stopwatch = Profiled
    try:
        t0 = time.perf_counter()
        tr = trial_module.run_trial(plan, trial, spec.campaign.seed)
        total = time.perf_counter() - t0
    finally:
        trial_module._Stopwatch = base
    if tr.error:
        raise RuntimeError(f"{campaign}: trial {trial} failed: {tr.error}")
    return profiles, dict(tr.seconds), total


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("campaigns", nargs="*", default=[
        str(HERE / "campaigns" / "quickstart.toml"), str(HERE / "campaigns" / "hub_beam.toml")])
    ap.add_argument("--top", type=int, default=12)
    ap.add_argument("--trial", type=int, default=0)
    ap.add_argument("--sort", default="tottime", choices=("tottime", "cumulative"))
    args = ap.parse_args(argv)
    load = os.getloadavg()
    print(f"load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}")
    for campaign in args.campaigns:
        profiles, seconds, total = profile_trial(campaign, args.trial)
        print(f"\n=== {Path(campaign).name}: trial {args.trial}, {total:.3f} s under the "
              f"profiler; stages " + ", ".join(f"{k} {v:.3f}" for k, v in seconds.items()))
        for stage, prof in profiles.items():
            buf = io.StringIO()
            pstats.Stats(prof, stream=buf).sort_stats(args.sort).print_stats(args.top)
            body = buf.getvalue().split("\n\n", 1)[-1].strip()
            share = 100 * seconds.get(stage, 0.0) / max(sum(seconds.values()), 1e-12)
            print(f"\n--- {stage}: {seconds.get(stage, 0.0):.3f} s ({share:.0f} %)\n{body}")


if __name__ == "__main__":
    main()
