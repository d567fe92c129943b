"""``truthbench simulate``: one test of one trial, with effects injected."""

from __future__ import annotations

from truthbench.cli._args import nonneg_int

#: What ``--out`` may end in: the test record is HDF5 (time histories, FRFs, truth).
OUT_SUFFIXES = (".h5", ".hdf5")


def _cmd_simulate(args) -> int:
    from truthbench._validation import check_output_file
    from truthbench.campaign.runner import simulate_one
    from truthbench.campaign.spec import check_refinement, load_campaign
    from truthbench.campaign.store import write_test_record
    from truthbench.effects import effect_from_inject
    from truthbench.errors import CampaignError, ModelError

    # every input is checked before any work: the output name, the campaign, the test
    # index, the injected effects
    out = check_output_file(
        "--out", args.out, OUT_SUFFIXES, what="HDF5 test record", error=CampaignError,
        hint=f"simulate writes HDF5 (time histories, FRFs and the truth record); for UFF "
             f"run 'truthbench export {args.out.rsplit('.', 1)[0]}.h5 --out {args.out}' "
             f"on the HDF5 file")
    spec = load_campaign(args.campaign)
    n_tests = len(spec.tests)
    if args.test >= n_tests:
        names = ", ".join(f"{j}: {t.name}" for j, t in enumerate(spec.tests))
        raise CampaignError(f"argument --test: expected a test index 0..{n_tests - 1} of "
                            f"{args.campaign} ({names}); got {args.test}")
    extra = [effect_from_inject(text) for text in args.inject]
    check_refinement(spec, [("inject", e) for e in extra], source="--inject")
    plant = spec.make_plant()
    for text, eff in zip(args.inject, extra, strict=True):
        if "station" in eff.options:
            locate = (plant.station_fraction if eff.effect.locates_between_nodes(eff.options)
                      else plant.station_node)
            try:
                locate(eff.options["station"])
            except ModelError as exc:
                raise CampaignError(f"--inject {text!r}: option 'station': {exc}; got "
                                    f"{eff.options['station']!r}") from None
    seed = spec.campaign.seed if args.seed is None else args.seed
    record = simulate_one(spec, args.trial, args.test, seed, extra)
    path = write_test_record(record, out, spec=spec, seed=seed, trial=args.trial,
                             injected=args.inject)
    print(f"test {record.name!r} of trial {args.trial}: {record.u.shape[1]} samples at "
          f"{record.fs_hz:g} Hz, {len(record.output_labels)} outputs -> {path}")
    for key, value in record.parameters.items():
        if key.startswith("effect."):
            print(f"  {key} = {value:.6g}" if isinstance(value, float) else f"  {key} = {value}")
    return 0


def register(sub) -> None:
    sm = sub.add_parser(
        "simulate", help="simulate one test: time histories, FRFs, truth",
        description="Simulate one test of one Monte Carlo trial (its hardware draw) and "
                    "write the time histories, the H1 FRFs and the exact truth record "
                    "(every effect's realised values) to an HDF5 file; --inject adds "
                    "effects the campaign does not declare.",
        epilog="examples:\n"
               "  truthbench simulate campaigns/quickstart.toml --out test0.h5\n"
               "  truthbench simulate campaigns/quickstart.toml --test 1 --out delayed.h5 "
               "--inject time_delay:delay_s=0.002\n"
               "  truthbench export delayed.h5 --out delayed.uff   (the FRFs as UFF)")
    sm.add_argument("campaign", help="campaign TOML file")
    sm.add_argument("--trial", type=nonneg_int, default=0, help="trial (hardware) index")
    sm.add_argument("--test", type=nonneg_int, default=0, help="test index (0-based)")
    sm.add_argument("--seed", type=nonneg_int,
                    help="seed (default: the campaign's [campaign] seed)")
    sm.add_argument("--out", required=True,
                    help="HDF5 file to write (.h5 or .hdf5); for UFF, export it afterwards")
    sm.add_argument("--inject", action="append", default=[], metavar="NAME:param=value,...",
                    help="add an effect the campaign does not declare (repeatable), e.g. "
                         "time_delay:delay_s=0.002 or joint:station=mid,stiffness_loss=0.3")
    sm.set_defaults(func=_cmd_simulate)
