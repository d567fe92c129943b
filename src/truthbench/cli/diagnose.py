"""``truthbench diagnose``: trace the residual of measured FRFs to the effect the model lacks.
"""

from __future__ import annotations

from truthbench.cli._args import setting_option

_SETTINGS = "truthbench.diagnose.settings:DiagnoseSettings"


def _cmd_diagnose(args) -> int:
    import json

    from truthbench.campaign.model_file import load_model
    from truthbench.diagnose import diagnose
    from truthbench.diagnose.result import where
    from truthbench.io import load_measurements
    from truthbench.report.format import pct, sig

    spec = load_model(args.model)
    h5 = any(str(p).lower().endswith((".h5", ".hdf5")) for p in args.data)
    options = {"trials": args.trial} if args.trial is not None and h5 else {}
    data = load_measurements(args.data, input_rms_n=spec.diagnose.input_rms_n,
                             levels_from=f"{spec.source}: key 'diagnose.input_rms_n'",
                             **options)
    settings = spec.diagnose.settings()
    for key in ("max_effects", "threshold"):
        if getattr(args, key) is not None:
            settings[key] = getattr(args, key)
    if args.candidate:
        settings["candidates"] = tuple(args.candidate)
    if args.band:
        settings["band_hz"] = tuple(args.band)
    diag = diagnose(data, spec.make_plant(), spec.nominal_parameters(),
                    spec.update.parameters, **settings)
    written = None
    if args.out:
        from truthbench.report.diagnosis import write_diagnosis

        written = write_diagnosis(diag, args.out, sources=tuple(map(str, args.data)))
    if args.json:
        print(json.dumps(diag.to_dict(), indent=2, allow_nan=False))
        return 0
    print(f"{spec.source}: {len(diag.tests)} test(s), {diag.n} real values; declared "
          f"{', '.join(diag.declared) or 'none'}")
    if diag.mesh is not None:
        print(f"mesh: {diag.mesh.summary()}")
    for m in diag.missing:
        print(f"mode the model lacks: {m.summary()}")
    print(f"verdict: {diag.verdict}")
    holds = diag.uncertainty_holds
    for f in diag.found:
        fitted = ", ".join(f"{k} = {sig(v)}" + (f" +- {sig(f.std[k], 2)}" if holds else "")
                           for k, v in f.fitted.items())
        print(f"found: {f.effect} ({where(f.options, x_m=f.x_m)}): {fitted}; delta BIC "
              f"{sig(f.delta_bic)}")
        for a in f.alternatives:
            alt = ", ".join(f"{k} = {sig(v)}" for k, v in a.parameters.items())
            print(f"   or: {a.effect} ({where(a.options, x_m=a.x_m)}): {alt}; delta BIC "
                  f"{sig(a.delta_bic)}")
    if diag.found and not holds:
        print(f"(no +- stated: the final residual is {sig(diag.noise_ratio, 3)} times the "
              f"noise variance: model error, not noise)")
    for m in diag.measurements:
        print(f"to settle it: {m.summary()}")
    for effect, reason in diag.not_tried:
        print(f"not tried: {effect}: {reason}")
    for f in diag.dropped:
        print(f"dropped: {f.effect} ({where(f.options)}): no longer significant after a "
              f"later finding")
    print(f"FRF error (noise-weighted relative RMS): {pct(100 * diag.frf_error_before)} % "
          f"before, {pct(100 * diag.frf_error_after)} % after; reduced chi2 "
          f"{sig(diag.before.reduced_chi2)} -> {sig(diag.after.reduced_chi2)}")
    print("candidates (step 1, best first):")
    for t in diag.ranked(0)[:8]:
        print(f"  {t.label:<32} delta BIC {sig(t.delta_bic):>10}  {t.status}")
    if written is not None:
        print(f"report: {written}")
        print(f"        {written.with_suffix('.md')}")
    return 0




def register(subparsers) -> None:
    d = subparsers.add_parser(
        "diagnose", help="find the effect a model lacks from measured FRFs",
        description="Fit the model's declared parameters to measured FRFs (the baseline), "
                    "then try every effect of the registry that can be missing at every "
                    "location and add the best while it is significant (delta BIC); print "
                    "the FRF error before and after. A UFF file of coherence sets only is "
                    "paired with the FRF sets of the other files by node, direction and "
                    "load case. Coulomb friction is tried when every test's input level is "
                    "known: time records and truthbench .h5 files carry it; for UFF FRFs "
                    "give it in the model file, [diagnose] input_rms_n = { \"<data set>\" = "
                    "<N RMS> }.",
        epilog="example: truthbench diagnose frf.uff coherence.uff --model "
               "campaigns/steel_tube.toml --out results/diagnosis")
    d.add_argument("data", nargs="+",
                   help="measured FRFs: UFF 58 (+164, 2411; coherence in the same or its own "
                        "file), LVM, or a truthbench .h5")
    d.add_argument("--model", required=True,
                   help="model file: [plant], [update] parameters, [diagnose] (a campaign "
                        "file works too)")
    d.add_argument("--out", help="write diagnosis.md, diagnosis.html and figures here")
    d.add_argument("--json", action="store_true", help="print one JSON object")
    setting_option(d, "--max-effects", f"{_SETTINGS}.max_effects",
                   help="most effects to add (default: the model file's)")
    setting_option(d, "--threshold", f"{_SETTINGS}.threshold",
                   help="delta BIC an effect must exceed (default: the model file's)")
    d.add_argument("--candidate", action="append", metavar="EFFECT",
                   help="try only these effects (repeatable)")
    d.add_argument("--band", type=float, nargs=2, metavar=("LO", "HI"),
                   help="compare these lines only, Hz")
    d.add_argument("--trial", type=int, help="the trial of a results file (default: all "
                                             "data sets in the files)")
    d.set_defaults(func=_cmd_diagnose)
