"""``truthbench modes``: modal table of a campaign's nominal and truth models."""

from __future__ import annotations


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


def register(sub) -> None:
    m = sub.add_parser("modes", help="modal table of the nominal and truth models")
    m.add_argument("campaign", help="campaign TOML file")
    m.add_argument("--count", type=int, default=20, help="number of modes (default 20)")
    m.add_argument("--json", action="store_true", help="print JSON instead of a table")
    m.set_defaults(func=_cmd_modes)
