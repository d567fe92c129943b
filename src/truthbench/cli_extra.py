"""Extra subcommands of the truthbench command line: ``study`` and ``identify``.

:func:`register` adds them to the subparsers object of :func:`truthbench.cli.build_parser`::

    truthbench study discretization [--out DIR] [--max-elements N]
    truthbench study damping-smoothing [--out DIR] [--seed S] [--seeds N]
    truthbench identify DATA [--json] [--method plscf|peak] [--max-order N]
                             [--band LO HI] [--modes N]

Only :mod:`argparse` is imported here; numpy, scipy and matplotlib are imported inside
the command functions, so ``truthbench --help`` stays fast. Printing happens only here.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

DEFAULT_STUDY_DIR = Path("results") / "studies"


def _cmd_study_discretization(args) -> int:
    from truthbench.studies.discretization import discretization_study

    study = discretization_study(max_elements=args.max_elements)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    frame = study.to_pandas()
    frame.to_csv(out / "discretization.csv", index=False)
    study.plot(out / "discretization.png")
    p = study.parameters
    print(f"free-free tube, x-z bending: r {p['r_m'] * 1e3:.4g} mm, t {p['t_m'] * 1e3:.4g} mm, "
          f"L {p['L_m']:g} m, E {p['E_pa'] / 1e9:g} GPa, rho {p['rho_kg_m3']:g} kg/m^3")
    exact = ", ".join(f"mode {m} {f:.4f} Hz" for m, f in
                      zip(study.modes, study.freq_exact_hz, strict=True))
    print(f"exact Euler-Bernoulli: {exact}")
    keep = [n for n in (1, 2, 3, 4, 5, 6, 8, 10, 15, 20, 30, 40) if n <= args.max_elements]
    rows = frame[frame["n_elements"].isin(keep)]
    print(f"{'elements':>8} {'mode':>4} {'FE Hz':>12} {'freq err %':>11} {'1 - MAC':>10} "
          f"{'e (10.30)':>10}")

    def g(v):
        return f"{v:>10.3e}" if v == v else f"{'-':>10}"

    for r in rows.itertuples(index=False):
        print(f"{r.n_elements:>8} {r.mode:>4} {r.freq_fe_hz:>12.5f} {r.freq_error_pct:>11.5f} "
              f"{g(r.one_minus_mac)} {g(r.shape_error)}")
    print(f"wrote {out / 'discretization.csv'} and {out / 'discretization.png'}")
    return 0


def _cmd_study_damping(args) -> int:
    from truthbench.studies.damping_smoothing import damping_smoothing_study

    study = damping_smoothing_study(n_seeds=args.seeds, seed=args.seed)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    frame = study.to_pandas()
    frame.to_csv(out / "damping_smoothing.csv", index=False)
    study.plot(out / "damping_smoothing.png")
    print(f"SDOF f_n {study.natural_freq_hz:g} Hz, zeta {study.damping_ratio:g}, fs "
          f"{study.fs_hz:g} Hz, {study.n_averages} averages, noise std "
          f"{study.noise_fraction:g} std(q), {study.n_seeds} records per point, seed "
          f"{study.seed}")
    floor = study.floor_damping_ratio
    print(f"exact sampled-system FRF reads zeta {floor['amplification']:.5f} (amplification), "
          f"{floor['half_power']:.5f} (half-power): the large-N limit")
    print(f"{'window':>9} {'method':>14} {'N':>6} {'df/B_r':>7} {'mean err %':>11} "
          f"{'std %':>8}")
    for r in frame.itertuples(index=False):
        print(f"{r.window:>9} {r.method:>14} {r.points_per_window:>6} {r.df_over_br:>7.3f} "
              f"{r.mean_error_pct:>11.2f} {r.std_error_pct:>8.2f}")
    print(f"wrote {out / 'damping_smoothing.csv'} and {out / 'damping_smoothing.png'}")
    return 0


def _fmt_shape(values) -> str:
    return "[" + ", ".join(f"{v:+.3f}" for v in values) + "]"


def _cmd_identify(args) -> int:
    import json

    from truthbench.identify_data import EULER_BERNOULLI_FREE_FREE_RATIOS, identify_file

    try:
        report = identify_file(args.data, method=args.method, max_order=args.max_order,
                               band_hz=tuple(args.band) if args.band else None,
                               n_modes=args.modes)
    except (ValueError, FileNotFoundError) as exc:  # DataFormatError is a ValueError
        print(f"truthbench identify: error: {exc}", file=sys.stderr)
        return 2
    if args.json:
        print(json.dumps(report.to_dict(), indent=2))
        return 0
    print(f"{report.path}: {report.file_format}, method {report.method}"
          + (f" (max order {report.max_order})" if report.method == "plscf" else ""))
    for d in report.datasets:
        data = d.data
        print(f"\n{data.name}: {data.frf_type} FRF, {len(data.output_labels)} output(s), "
              f"{len(data.input_labels)} input(s), band {d.band_hz[0]:.6g}-{d.band_hz[1]:.6g} Hz")
        for note in data.notes:
            print(f"  {note}")
        if d.n_modes == 0:
            print("  no mode identified in the band")
            continue
        several = len(data.output_labels) > 1
        corrected = data.window_decay_rad_s > 0
        head = f"{'mode':>4} {'freq_hz':>12} {'damping_ratio':>14}"
        if corrected:
            head += f" {'uncorrected':>12}"
        if several:
            head += "  shape " + " ".join(data.output_labels)
        print(head)
        for row in d.table():
            line = f"{row['mode']:>4} {row['freq_hz']:>12.4f} {row['damping_ratio']:>14.6f}"
            if corrected:
                line += f" {row['damping_ratio_uncorrected']:>12.6f}"
            if several:
                line += "  " + _fmt_shape(row["shape"])
            print(line)
        if report.file_format == "lvm":
            ratios = d.strongest_ratios(3)
            if ratios is not None:
                eb = EULER_BERNOULLI_FREE_FREE_RATIOS
                print(f"frequency ratios to mode 1 of the three strongest modes: "
                      f"{ratios[0]:.4f}, {ratios[1]:.4f} (free-free Euler-Bernoulli "
                      f"{eb[0]:.3f}, {eb[1]:.3f}; informational)")
    return 0


def register(subparsers) -> None:
    """Add the ``study`` and ``identify`` subcommands.

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        What ``ArgumentParser.add_subparsers`` returned; each command sets ``func``.
    """
    st = subparsers.add_parser(
        "study", help="the chapter's numerical studies (Figures 10.2 and 10.3)")
    sts = st.add_subparsers(dest="study", required=True)

    d = sts.add_parser(
        "discretization",
        help="Fig. 10.2: FE frequency and shape errors of a free-free beam vs elements")
    d.add_argument("--out", default=str(DEFAULT_STUDY_DIR),
                   help=f"output folder (default {DEFAULT_STUDY_DIR})")
    d.add_argument("--max-elements", type=int, default=40,
                   help="largest element count (default 40)")
    d.set_defaults(func=_cmd_study_discretization)

    ds = sts.add_parser(
        "damping-smoothing",
        help="Fig. 10.3: damping from smoothed FRF peaks vs points per window")
    ds.add_argument("--out", default=str(DEFAULT_STUDY_DIR),
                    help=f"output folder (default {DEFAULT_STUDY_DIR})")
    ds.add_argument("--seed", type=int, default=0, help="root seed (default 0)")
    ds.add_argument("--seeds", type=int, default=20,
                    help="independent records per point (default 20)")
    ds.set_defaults(func=_cmd_study_damping)

    i = subparsers.add_parser(
        "identify", help="identify modal parameters from a data file (.h5, .uff, .lvm)")
    i.add_argument("data", help="results .h5/.hdf5, UFF 58 .uff/.unv, or LabVIEW .lvm")
    i.add_argument("--json", action="store_true", help="print JSON instead of a table")
    i.add_argument("--method", default="plscf", choices=("plscf", "peak"),
                   help="identifier (default plscf)")
    i.add_argument("--max-order", type=int, default=30,
                   help="highest pLSCF model order (default 30)")
    i.add_argument("--band", type=float, nargs=2, metavar=("LO", "HI"),
                   help="identification band in Hz (default: per data set)")
    i.add_argument("--modes", type=int, help="peak picking: number of peaks kept")
    i.set_defaults(func=_cmd_identify)


if __name__ == "__main__":  # pragma: no cover - for trying the commands before wiring
    parser = argparse.ArgumentParser(prog="truthbench")
    register(parser.add_subparsers(dest="command", required=True))
    ns = parser.parse_args()
    sys.exit(ns.func(ns))
