"""``truthbench report``: the report from a results file (never reruns numerics)."""

from __future__ import annotations

from pathlib import Path


def _cmd_report(args) -> int:
    from truthbench.campaign.store import read_results
    from truthbench.report.accuracy import write_report

    path = Path(args.results)
    data = read_results(path)
    report = write_report(data, Path(args.out) if args.out else path.parent)
    print(f"report: {report}")
    return 0


def register(sub) -> None:
    rp = sub.add_parser("report", help="write report.md and figures from a results file")
    rp.add_argument("results", help="results.h5 written by 'truthbench run'")
    rp.add_argument("--out", help="output folder (default: beside the results file)")
    rp.set_defaults(func=_cmd_report)
