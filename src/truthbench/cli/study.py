"""``truthbench study``: the chapter's numerical studies (Figures 10.2 and 10.3)."""

from __future__ import annotations

from pathlib import Path

from truthbench.cli._args import files_only, folder, int_in, nonneg_int, save_figure

DEFAULT_STUDY_DIR = Path("results") / "studies"

MAX_STUDY_ELEMENTS = 100
"""Largest ``--max-elements``: the study solves every mesh of 1..N elements densely (cost
about N^4): 100 elements take about 3 s here, 200 a minute."""

MAX_SEEDS = 1000
"""Largest ``--seeds``: about 1 s per seed here, so 1000 take about 20 minutes."""


def _cmd_study_discretization(args) -> int:
    from truthbench.studies.discretization import discretization_study

    files_only()
    study = discretization_study(max_elements=args.max_elements)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    frame = study.to_pandas()
    frame.to_csv(out / "discretization.csv", index=False)
    save_figure(study.plot(), out / "discretization.png")
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

    files_only()
    study = damping_smoothing_study(n_seeds=args.seeds, seed=args.seed)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    frame = study.to_pandas()
    frame.to_csv(out / "damping_smoothing.csv", index=False)
    save_figure(study.plot(), out / "damping_smoothing.png")
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


def register(subparsers) -> None:
    """Add the ``study`` subcommand.

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        What ``ArgumentParser.add_subparsers`` returned; each command sets ``func``.
    """
    st = subparsers.add_parser(
        "study", help="the chapter's numerical studies (Figures 10.2 and 10.3)",
        description="The numerical studies of \"Modeling: Limitations and Realities\", a "
                    "draft textbook chapter of 1998: 'discretization' (its Figure 10.2) and "
                    "'damping-smoothing' (its Figure 10.3).",
        epilog="examples:\n  truthbench study discretization\n"
               "  truthbench study damping-smoothing --out results/studies")
    sts = st.add_subparsers(dest="study", required=True)

    d = sts.add_parser(
        "discretization",
        help="Fig. 10.2: FE frequency and shape errors of a free-free beam vs elements",
        description="Figure 10.2: frequency and mode-shape error of the free-free tube, "
                    "modes 1 and 2, against the number of elements (exact Euler-Bernoulli "
                    "reference); writes discretization.csv and discretization.png.",
        epilog="example:\n  truthbench study discretization --max-elements 40 --out studies")
    d.add_argument("--out", type=folder, default=str(DEFAULT_STUDY_DIR), help="output folder")
    d.add_argument("--max-elements", default=40,
                   type=int_in(1, MAX_STUDY_ELEMENTS, "every mesh up to it is solved "
                               "densely; 100 take about 3 s, 200 a minute"),
                   help="largest element count")
    d.set_defaults(func=_cmd_study_discretization)

    ds = sts.add_parser(
        "damping-smoothing",
        help="Fig. 10.3: damping from smoothed FRF peaks vs points per window",
        description="Figure 10.3: damping error of a single-DOF system read from "
                    "Bartlett (and Hann, Hamming) averaged FRFs against points per "
                    "window; writes damping_smoothing.csv and damping_smoothing.png.",
        epilog="example:\n  truthbench study damping-smoothing --seeds 40 --seed 7")
    ds.add_argument("--out", type=folder, default=str(DEFAULT_STUDY_DIR), help="output folder")
    ds.add_argument("--seed", type=nonneg_int, default=0, help="root seed")
    ds.add_argument("--seeds", default=20,
                    type=int_in(1, MAX_SEEDS, "records per point; the time grows with it"),
                    help="independent records per point")
    ds.set_defaults(func=_cmd_study_damping)
