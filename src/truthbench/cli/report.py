"""``truthbench report``: the report from a results file or a run's folder (never reruns
numerics)."""

from __future__ import annotations

from pathlib import Path


def _cmd_report(args) -> int:
    from truthbench.campaign.results import CampaignResult
    from truthbench.campaign.store import RESULTS_FILE, TRIALS_DIR, TrialStore
    from truthbench.report.accuracy import write_report

    path = Path(args.results)
    result = CampaignResult.load(path)
    folder = path if path.is_dir() else path.parent
    if folder.name == TRIALS_DIR:
        folder = folder.parent
    partial = path.is_dir() and not (path / RESULTS_FILE).is_file()
    report = write_report(result, Path(args.out) if args.out else folder)
    if partial:
        head = TrialStore(folder).header()
        print(f"partial store: {len(result.trials)} of {head.get('trials')} trial(s) of "
              f"campaign {head.get('campaign')!r} (continue the run with "
              f"'truthbench run ... --out {folder} --resume')")
    print(f"report: {report.with_suffix('.html')} (and {report.name})")
    return 0


def register(sub) -> None:
    rp = sub.add_parser("report", help="write report.md, report.html and figures from a "
                                       "results file or a run's folder")
    rp.add_argument("results", help="results.h5 written by 'truthbench run', a run's output "
                                    "folder (also one whose run was interrupted: the report "
                                    "of the trials stored so far), or a test file of "
                                    "'truthbench simulate'")
    rp.add_argument("--out", help="output folder (default: beside the results file, or the "
                                  "run's folder)")
    rp.set_defaults(func=_cmd_report)
