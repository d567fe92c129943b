"""The truthbench command line.

Heavy modules (numpy, scipy, python-control, matplotlib, h5py) are imported inside the
commands, so ``truthbench --help`` answers at once.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


def _cmd_run(args) -> int:
    from truthbench.campaign.runner import run_campaign
    from truthbench.campaign.spec import load_campaign
    from truthbench.campaign.store import read_results, write_results
    from truthbench.report.accuracy import parameter_table, write_report

    spec = load_campaign(args.campaign)
    out = Path(args.out) if args.out else Path("results") / spec.campaign.name
    result = run_campaign(spec, trials=args.trials, seed=args.seed, n_jobs=args.jobs)
    path = write_results(result, out / "results.h5")
    data = read_results(path)
    report = write_report(data, out)
    print(f"results: {path}")
    print(f"report:  {report}")
    table = parameter_table(data)
    if not table.empty:
        print(table.to_string(index=False, float_format=lambda v: f"{v:.6g}"))
    failed = [t for t in result.trials if t.error]
    for t in failed:
        print(f"trial {t.trial} failed: {t.error.splitlines()[0]}", file=sys.stderr)
    return 1 if len(failed) == len(result.trials) else 0


def _cmd_report(args) -> int:
    from truthbench.campaign.store import read_results
    from truthbench.report.accuracy import write_report

    path = Path(args.results)
    data = read_results(path)
    report = write_report(data, Path(args.out) if args.out else path.parent)
    print(f"report: {report}")
    return 0


def _cmd_modes(args) -> int:
    import json

    from truthbench.campaign.spec import load_campaign
    from truthbench.model import modal_table

    spec = load_campaign(args.campaign)
    plant = spec.make_plant()
    tables = {}
    for label, params in (("nominal", spec.nominal_parameters()),
                          ("truth", spec.truth_parameters())):
        model = plant.build(params)
        n = min(args.count, model.n_dofs)
        tables[label] = modal_table(model, model.modes(n))
    if args.json:
        print(json.dumps(tables, indent=2))
        return 0
    print(f"{spec.campaign.name}: {spec.plant.type}, {spec.plant.n_elements} elements")
    print(f"{'mode':>4} {'nominal Hz':>12} {'zeta':>8} {'truth Hz':>12} {'zeta':>8}  shape")
    def z(v):
        return f"{v:>8.4f}" if v == v else f"{'-':>8}"  # NaN: rigid-body mode

    for a, b in zip(tables["nominal"], tables["truth"], strict=True):
        print(f"{a['mode']:>4} {a['freq_hz']:>12.4f} {z(a['damping_ratio'])} "
              f"{b['freq_hz']:>12.4f} {z(b['damping_ratio'])}  {a['shape']}")
    return 0


def _cmd_simulate(args) -> int:
    from truthbench.campaign.runner import simulate_one
    from truthbench.campaign.spec import load_campaign
    from truthbench.campaign.store import write_test_record
    from truthbench.effects import effect_from_inject

    spec = load_campaign(args.campaign)
    extra = [effect_from_inject(text) for text in args.inject]
    seed = spec.campaign.seed if args.seed is None else args.seed
    record = simulate_one(spec, args.trial, args.test, seed, extra)
    path = write_test_record(record, args.out, spec=spec, seed=seed, trial=args.trial,
                             injected=args.inject)
    print(f"test {record.name!r} of trial {args.trial}: {record.u.shape[1]} samples at "
          f"{record.fs_hz:g} Hz, {len(record.output_labels)} outputs -> {path}")
    for key, value in record.parameters.items():
        if key.startswith("effect."):
            print(f"  {key} = {value:.6g}" if isinstance(value, float) else f"  {key} = {value}")
    return 0


def _cmd_place_sensors(args) -> int:
    from truthbench.campaign.placement_stage import rank_campaign_sensors
    from truthbench.campaign.spec import load_campaign

    spec = load_campaign(args.campaign)
    by_sens, by_gram = rank_campaign_sensors(spec, args.count)
    chosen = list(by_sens.selected) if by_sens.selected is not None else []
    print(f"{spec.campaign.name}: candidate DOFs ranked for parameters "
          f"{', '.join(spec.update.parameters)}")
    print(f"greedy D-optimal choice of {args.count}: "
          f"{', '.join(by_sens.labels[i] for i in chosen[:args.count])}")
    print(f"{'rank':>4}  {'by shape sensitivity':<24}{'score':>12}    "
          f"{'by observability gramian':<24}{'share':>8}")
    for r in range(min(args.count, len(by_sens.order))):
        a, b = by_sens.order[r], by_gram.order[r]
        print(f"{r + 1:>4}  {by_sens.labels[a]:<24}{by_sens.scores[a]:>12.4g}    "
              f"{by_gram.labels[b]:<24}{by_gram.scores[b]:>8.4f}")
    if args.score:
        import pandas as pd

        from truthbench.campaign.placement_stage import campaign_dof_labels, score_layouts

        layouts = {"campaign": campaign_dof_labels(spec),
                   "proposed": [by_sens.labels[i] for i in chosen[:args.count]]}
        print(f"\nMonte Carlo score: {args.trials} trial(s) per layout, same seeds, "
              f"primary updater {spec.update_methods()[0]!r}")
        with pd.option_context("display.width", 200, "display.max_columns", 20):
            print(score_layouts(spec, layouts, trials=args.trials,
                                n_jobs=args.jobs).to_string(index=False))
    return 0


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="truthbench",
        description="Synthetic test campaigns with known truth for FE model updating.")
    sub = p.add_subparsers(dest="command", required=True)

    r = sub.add_parser("run", help="run a campaign: simulate, measure, update, report")
    r.add_argument("campaign", help="campaign TOML file")
    r.add_argument("--out", help="output folder (default results/<campaign name>)")
    r.add_argument("--trials", type=int, help="Monte Carlo trials (overrides the file)")
    r.add_argument("--seed", type=int, help="seed (overrides the file)")
    r.add_argument("--jobs", type=int, default=1, help="parallel workers (joblib)")
    r.set_defaults(func=_cmd_run)

    rp = sub.add_parser("report", help="write report.md and figures from a results file")
    rp.add_argument("results", help="results.h5 written by 'truthbench run'")
    rp.add_argument("--out", help="output folder (default: beside the results file)")
    rp.set_defaults(func=_cmd_report)

    sm = sub.add_parser("simulate", help="simulate one test: time histories, FRFs, truth")
    sm.add_argument("campaign", help="campaign TOML file")
    sm.add_argument("--trial", type=int, default=0, help="trial (hardware) index")
    sm.add_argument("--test", type=int, default=0, help="test index (0-based)")
    sm.add_argument("--seed", type=int, help="seed (overrides the file)")
    sm.add_argument("--out", required=True, help="HDF5 file to write")
    sm.add_argument("--inject", action="append", default=[], metavar="NAME:param=value,...",
                    help="add an effect the campaign does not declare (repeatable), e.g. "
                         "time_delay:delay_s=0.002 or joint:station=mid,stiffness_loss=0.3")
    sm.set_defaults(func=_cmd_simulate)

    ps = sub.add_parser("place-sensors", help="rank sensor DOFs (Eq. 10.45 and gramian)")
    ps.add_argument("campaign", help="campaign TOML file")
    ps.add_argument("--count", type=int, default=4, help="sensors to choose (default 4)")
    ps.add_argument("--score", action="store_true",
                    help="score the proposed layout against the campaign's own by a Monte "
                         "Carlo run of each (parameter RMS error against the truth)")
    ps.add_argument("--trials", type=int, default=20, help="trials per layout for --score")
    ps.add_argument("--jobs", type=int, default=1, help="parallel workers for --score")
    ps.set_defaults(func=_cmd_place_sensors)

    m = sub.add_parser("modes", help="modal table of the nominal and truth models")
    m.add_argument("campaign", help="campaign TOML file")
    m.add_argument("--count", type=int, default=20, help="number of modes (default 20)")
    m.add_argument("--json", action="store_true", help="print JSON instead of a table")
    m.set_defaults(func=_cmd_modes)

    from truthbench.cli_extra import register  # study and identify commands (argparse only)

    register(sub)
    return p


def main(argv: list[str] | None = None) -> int:
    from truthbench.errors import TruthbenchError

    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except (TruthbenchError, FileNotFoundError) as exc:
        print(f"truthbench {args.command}: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
