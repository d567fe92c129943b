"""``truthbench export``: a results or ``simulate`` file's FRFs as UFF for other tools."""

from __future__ import annotations

from truthbench.cli._args import nonneg_int

#: What ``--out`` may end in.
OUT_SUFFIXES = (".uff", ".unv")


def _cmd_export(args) -> int:
    from truthbench._validation import check_output_file
    from truthbench.errors import DataFormatError
    from truthbench.io import load_frf, number_points, write_uff

    out = check_output_file("--out", args.out, OUT_SUFFIXES, what="UFF file",
                            error=DataFormatError,
                            hint="export writes UFF 58 + 2411 (results files are HDF5 "
                                 "already)")
    options = {}
    if args.trial is not None:
        options["trials"] = args.trial
    if args.test:
        options["tests"] = args.test
    frfs = load_frf(args.results, **options)
    try:  # checked before anything is written (no partial file)
        path = write_uff(out, frfs, binary=args.binary)
    except ValueError as exc:  # e.g. non-finite FRF lines UFF cannot hold
        raise DataFormatError(f"{args.results} -> {out}: {exc}") from None
    points = number_points(frfs)
    n_frf = sum(d.H.shape[1] * d.H.shape[2] for d in frfs)
    n_coh = sum(d.H.shape[1] * d.H.shape[2] for d in frfs if d.coherence is not None)
    located = [n for n, xyz in points.coordinates_m.items() if xyz is not None]
    kind = "binary 58b, exact" if args.binary else "ASCII, 12 significant digits"
    print(f"{args.results} -> {path} ({kind}): dataset 151 header, 164 units SI (m, N), "
          f"2411 {len(located)} point(s), 58 {n_frf} FRF set(s) and {n_coh} coherence "
          f"set(s) in {len(frfs)} load case(s)")
    for n, xyz in points.coordinates_m.items():
        where = "no coordinates" if xyz is None else (
            f"({xyz[0]:.6g}, {xyz[1]:.6g}, {xyz[2]:.6g}) m")
        print(f"  point {n:>3}  {points.names[n]:<16} {where}")
    for k, d in enumerate(frfs):
        band = "" if d.band_hz is None else f", band {d.band_hz[0]:g}-{d.band_hz[1]:g} Hz"
        print(f"  load case {k + 1}: {d.name}: {d.H.shape[1]} output(s) x {d.H.shape[2]} "
              f"input(s) {list(d.input_labels)}, {d.freq_hz.size} lines "
              f"{d.freq_hz[0]:g}-{d.freq_hz[-1]:g} Hz{band}")
    return 0


def register(subparsers) -> None:
    e = subparsers.add_parser(
        "export", help="write the FRFs of a results or simulate file as UFF 58 + 2411",
        description="Write the FRFs and coherence of a results or simulate file as UFF "
                    "(151 header, 164 SI units, 2411 points, 58 FRF and coherence sets; "
                    "one load case per test and trial) for other tools.",
        epilog="examples:\n"
               "  truthbench export results/quickstart/results.h5 --out quickstart.uff\n"
               "  truthbench export results/hub/results.h5 --out hub.uff --trial 0 "
               "--test t1_hub_1Nm --binary")
    e.add_argument("results", help="results .h5 of 'truthbench run' or a 'simulate' file")
    e.add_argument("--out", required=True, help="UFF file to write (.uff or .unv)")
    e.add_argument("--trial", type=nonneg_int, help="only this trial (default: all)")
    e.add_argument("--test", nargs="+", metavar="NAME", help="only these tests (default: all)")
    e.add_argument("--binary", action="store_true",
                   help="binary UFF (58b, exact doubles) instead of ASCII (12 digits)")
    e.set_defaults(func=_cmd_export)
