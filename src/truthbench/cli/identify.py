"""``truthbench identify``: modal parameters from a data file (.h5, .uff, .lvm)."""

from __future__ import annotations

from truthbench.cli._args import frequency_hz, setting_option


def _fmt_shape(values) -> str:
    return "[" + ", ".join(f"{v:+.3f}" for v in values) + "]"


def _cmd_identify(args) -> int:
    from truthbench.cli._args import dumps
    from truthbench.errors import DataFormatError
    from truthbench.identify.workflow import EULER_BERNOULLI_FREE_FREE_RATIOS, identify_file

    band = None
    if args.band:
        band = tuple(args.band)
        if not band[0] < band[1]:
            raise DataFormatError(f"argument --band: expected LO < HI in Hz; got "
                                  f"{band[0]:g} {band[1]:g}")
    try:
        report = identify_file(args.data, method=args.method, max_order=args.max_order,
                               band_hz=band, n_modes=args.modes)
    except ValueError as exc:  # the library's input errors (DataFormatError is one)
        raise DataFormatError(str(exc)) from None
    if args.json:
        print(dumps(report.to_dict(), indent=2))
        return 0
    print(f"{report.path}: {report.file_format}, method {report.method}"
          + (f" (max order {report.max_order})" if report.method == "plscf" else ""))
    for d in report.datasets:
        data = d.data
        print(f"\n{data.name}: {data.frf_type} FRF, {len(data.output_labels)} output(s), "
              f"{len(data.input_labels)} input(s), band {d.band_hz[0]:.6g}-{d.band_hz[1]:.6g} Hz")
        for note in data.notes:
            print(f"  {note}")
        if d.band_rule:
            print(f"  band rule: {d.band_rule}")
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
    i = subparsers.add_parser(
        "identify", help="identify modal parameters from a data file (.h5, .uff, .lvm)",
        description="Modal parameters (frequency, damping ratio, shapes) of every FRF set "
                    "in a data file: results and simulate files (.h5), UFF 58 (.uff, "
                    ".unv) and LabVIEW records (.lvm). Without --band each data set's "
                    "band comes from the data: its excited band when the file records "
                    "it, else the lines where the coherence shows the input, else every "
                    "line above 0 Hz.",
        epilog="examples:\n"
               "  truthbench identify results/quickstart/results.h5\n"
               "  truthbench identify test.uff --band 10 400 --json\n"
               "  truthbench identify record.lvm --max-order 60")
    i.add_argument("data", help="results .h5/.hdf5, UFF 58 .uff/.unv, or LabVIEW .lvm")
    i.add_argument("--json", action="store_true", help="print strict JSON instead of a table")
    i.add_argument("--method", default="plscf", choices=("plscf", "peak"), help="identifier")
    setting_option(i, "--max-order", "truthbench.identify.plscf:PLSCFIdentifier.max_order",
                   help="highest pLSCF model order")
    i.add_argument("--band", type=frequency_hz, nargs=2, metavar=("LO", "HI"),
                   help="identification band in Hz (default: from the data, see above)")
    setting_option(i, "--modes", "truthbench.identify.peak:PeakIdentifier.n_modes",
                   help="peak picking: number of peaks kept, every peak when unset")
    i.set_defaults(func=_cmd_identify)
