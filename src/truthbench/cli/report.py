"""``truthbench report``: the report from a results file (never reruns numerics)."""

from __future__ import annotations

from pathlib import Path


def _cmd_report(args) -> int:
    from truthbench.campaign.results import CampaignResult
    from truthbench.report.accuracy import write_report

    path = Path(args.results)
    result = CampaignResult.load(path)
    report = write_report(result, Path(args.out) if args.out else path.parent)
    print(f"report: {report} (and {report.with_suffix('.html').name})")
    return 0


def register(sub) -> None:
    rp = sub.add_parser("report", help="write report.md, report.html and figures from a "
                                       "results file")
    rp.add_argument("results", help="results.h5 written by 'truthbench run' (or a test "
                                    "file of 'truthbench simulate')")
    rp.add_argument("--out", help="output folder (default: beside the results file)")
    rp.set_defaults(func=_cmd_report)
