"""``truthbench modes``: modal table of a campaign's nominal and truth models."""

from __future__ import annotations

from truthbench.cli._args import positive_int


def _cmd_modes(args) -> int:
    from truthbench.campaign.spec import load_campaign
    from truthbench.cli._args import dumps
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
        print(dumps(tables, indent=2))  # strict JSON: a rigid mode's damping is null
        return 0
    print(f"{spec.campaign.name}: {spec.plant.type}, {spec.plant.n_elements} elements")
    print(f"{'mode':>4} {'nominal Hz':>12} {'zeta':>8} {'truth Hz':>12} {'zeta':>8}  shape")

    def z(v):
        return f"{v:>8.4f}" if v == v else f"{'-':>8}"  # NaN: rigid-body mode

    for a, b in zip(tables["nominal"], tables["truth"], strict=True):
        shape = a["shape"] if a["shape"] == b["shape"] else f"{a['shape']} (truth: {b['shape']})"
        print(f"{a['mode']:>4} {a['freq_hz']:>12.4f} {z(a['damping_ratio'])} "
              f"{b['freq_hz']:>12.4f} {z(b['damping_ratio'])}  {shape}")
    return 0


def register(sub) -> None:
    m = sub.add_parser(
        "modes", help="modal table of the nominal and truth models",
        description="Frequency, damping ratio and shape of the lowest modes of a campaign's "
                    "nominal and truth models: rigid-body modes by their motion "
                    "(translation x/y/z, rotation about x/y/z), suspension modes by name "
                    "(bounce, pitch, sway, ...), elastic modes by dominant motion and "
                    "nodes; in order of frequency.",
        epilog="examples:\n  truthbench modes campaigns/quickstart.toml\n"
               "  truthbench modes campaigns/hub_beam.toml --count 8 --json")
    m.add_argument("campaign", help="campaign TOML file")
    m.add_argument("--count", type=positive_int, default=20,
                   help="number of modes (at most the model's DOFs)")
    m.add_argument("--json", action="store_true",
                   help="print strict JSON instead of a table (damping of rigid-body modes: "
                        "null)")
    m.set_defaults(func=_cmd_modes)
