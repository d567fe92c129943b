"""``truthbench diagnose-study``: a Monte Carlo study of the diagnosis against known truth.
"""

from __future__ import annotations


def _cmd_diagnose_study(args) -> int:
    from pathlib import Path

    import matplotlib

    from truthbench.campaign.diagnose_study import run_study
    from truthbench.campaign.spec import load_campaign
    from truthbench.report.diagnosis import write_study

    matplotlib.use("Agg")  # files only: the command never opens a window
    spec = load_campaign(args.campaign)
    result = run_study(spec, trials=args.trials, seed=args.seed, n_jobs=args.jobs)
    out = Path(args.out) if args.out else Path("results") / f"{spec.campaign.name}_study"
    html = write_study(result, out)
    print(result.to_pandas("scores").to_string())
    print()
    print(result.to_pandas("summary").set_index("form").T.to_string())
    print(f"report: {html}")
    print(f"        {out / 'study.md'}")
    print(f"trials: {out / 'study.csv'}")
    return 0


def register(subparsers) -> None:
    d = subparsers.add_parser(
        "diagnose-study", help="score the diagnosis on simulated data with known effects",
        description="Each trial injects none, one or two effects ([diagnose.study]) at "
                    "random strengths and places into the campaign's tests, diagnoses "
                    "them and scores what was found against what was injected, for a "
                    "truth of another model form than the model's (finer mesh, "
                    "Timoshenko drawn on or off, effects between nodes, sensors and "
                    "shakers mounted off the axis) and of the same form, side by side "
                    "([diagnose.study] form).",
        epilog="example: truthbench diagnose-study campaigns/diagnose_study.toml "
               "--trials 200 --jobs 2")
    d.add_argument("campaign", help="campaign TOML file with a [diagnose.study] table")
    d.add_argument("--trials", type=int, help="trials (default: [diagnose.study] trials)")
    d.add_argument("--seed", type=int, help="seed (default: the campaign's)")
    d.add_argument("--jobs", type=int, default=1, help="parallel workers (default 1)")
    d.add_argument("--out", help="output folder (default results/<campaign>_study)")
    d.set_defaults(func=_cmd_diagnose_study)
