"""``truthbench run``: simulate, measure, update and report a campaign."""

from __future__ import annotations

import sys
from pathlib import Path


def _cmd_run(args) -> int:
    from truthbench.campaign.runner import run_campaign
    from truthbench.campaign.spec import load_campaign
    from truthbench.report.accuracy import parameter_text, write_report

    spec = load_campaign(args.campaign)
    out = Path(args.out) if args.out else Path("results") / spec.campaign.name
    result = run_campaign(spec, trials=args.trials, seed=args.seed, n_jobs=args.jobs)
    path = result.save(out / "results.h5")
    report = write_report(result, out, results_path=path)  # from memory: no read-back
    print(f"results: {path}")
    print(f"report:  {report} (and {report.with_suffix('.html').name})")
    table = parameter_text(result)
    if table:
        print(table)
    failed = result.failed
    for t in failed:
        print(f"trial {t.trial} failed: {t.error.splitlines()[0]}", file=sys.stderr)
    return 1 if len(failed) == len(result.trials) else 0


def register(sub) -> None:
    r = sub.add_parser("run", help="run a campaign: simulate, measure, update, report")
    r.add_argument("campaign", help="campaign TOML file")
    r.add_argument("--out", help="output folder (default results/<campaign name>)")
    r.add_argument("--trials", type=int, help="Monte Carlo trials (overrides the file)")
    r.add_argument("--seed", type=int, help="seed (overrides the file)")
    r.add_argument("--jobs", type=int, default=1, help="parallel workers (joblib)")
    r.set_defaults(func=_cmd_run)
