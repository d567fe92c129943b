"""``truthbench place-sensors``: rank sensor DOFs (Eq. 10.45, gramian), score layouts."""

from __future__ import annotations

from truthbench.cli._args import jobs, positive_int


def _cmd_place_sensors(args) -> int:
    from truthbench.campaign.placement_stage import rank_campaign_sensors
    from truthbench.campaign.spec import load_campaign
    from truthbench.errors import CampaignError

    spec = load_campaign(args.campaign)
    if not spec.update.parameters:
        raise CampaignError(f"{spec.source}: key 'update.parameters': sensor placement ranks "
                            f"DOFs by the shape change these parameters cause; expected at "
                            f"least one parameter, got none")
    if args.score and not spec.update_methods():
        raise CampaignError(f"{spec.source}: key 'update.method': --score compares layouts "
                            f"by the updated parameters' error; expected an updater, got "
                            f"{spec.update.method!r}")
    model = spec.make_plant().build(spec.nominal_parameters())
    dirs = sorted({s.direction for s in spec.sensors if s.direction in ("x", "y", "z")})
    n_cand = sum(lab.rsplit(".", 1)[-1] in dirs for lab in model.dof_labels)
    if args.count > n_cand:
        raise CampaignError(f"argument --count: expected at most {n_cand} (the candidate "
                            f"DOFs: translations {', '.join(dirs) or '(none)'} at every node "
                            f"of {args.campaign}); got {args.count}")
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


def register(sub) -> None:
    ps = sub.add_parser(
        "place-sensors", help="rank sensor DOFs (Eq. 10.45 and gramian)",
        description="Rank candidate sensor DOFs (translations in the campaign's sensing "
                    "directions at every node) by how much the target modes' shapes move "
                    "for the update parameters' expected errors (Eq. 10.45, greedy "
                    "D-optimal pick) and by the scaled observability gramian; --score runs "
                    "the campaign with its own sensors and with the proposed ones.",
        epilog="examples:\n  truthbench place-sensors campaigns/quickstart.toml\n"
               "  truthbench place-sensors campaigns/quickstart.toml --count 3 --score "
               "--trials 10 --jobs 2")
    ps.add_argument("campaign", help="campaign TOML file")
    ps.add_argument("--count", type=positive_int, default=4,
                    help="sensors to choose (at most the candidate DOFs)")
    ps.add_argument("--score", action="store_true",
                    help="score the proposed layout against the campaign's own by a Monte "
                         "Carlo run of each (parameter RMS error against the truth)")
    ps.add_argument("--trials", type=positive_int, default=20,
                    help="trials per layout for --score")
    ps.add_argument("--jobs", type=jobs, default=1,
                    help="parallel workers for --score (-1: every core)")
    ps.set_defaults(func=_cmd_place_sensors)
