"""``truthbench simulate``: one test of one trial, with effects injected."""

from __future__ import annotations


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


def register(sub) -> None:
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
