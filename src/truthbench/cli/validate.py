"""``truthbench validate``: check a campaign without running it.

Checks, at the nominal model: the campaign file itself (the same validation as every
command); m r > p for the finite-difference method (SISO transfer functions against
parameters); that the update band lies inside Nyquist and overlaps every test's excited
band; that the update parameters are identifiable from the model FRFs at the lines the
update will use (the column-scaled sensitivity matrix at the nominal model, Table
10.2: what stops a trial with an ``IdentifiabilityError``); and the memory, disk and
time a run needs (the estimates ``truthbench run`` refuses by). Exit code 0 when all
pass, 1 when a check fails, 2 for a campaign file that does not load.
"""

from __future__ import annotations

import sys


def check_campaign(spec, trials: int | None = None, jobs: int = 1) -> list[tuple[bool, str]]:
    """Every check as ``(passed, message)``."""
    import numpy as np

    from truthbench.campaign.engines import available_cores
    from truthbench.campaign.plan import CampaignPlan
    from truthbench.campaign.resources import available_memory_mb, estimate_resources
    from truthbench.campaign.trial import predictor
    from truthbench.errors import IdentifiabilityError
    from truthbench.update.finite_difference import _stack, sensitivity_matrix
    from truthbench.update.identifiability import check_identifiable

    out = []
    plan = CampaignPlan.compile(spec)
    names = plan.update_names
    methods = plan.methods
    p = len(names)
    pairs = plan.n_pairs
    if "finite_difference" in methods:
        out.append((pairs > p, f"m r > p: {pairs} SISO transfer functions over the tests "
                               f"against {p} parameter(s) {list(names)}"))
    nyquist = min(t.fs_hz / 2 for t in plan.tests)
    for t in plan.tests:
        out.append((t.band_hz[1] <= t.fs_hz / 2, f"tests[{t.index}] {t.name!r}: band "
                    f"{t.band_hz[0]:g}-{t.band_hz[1]:g} Hz inside Nyquist "
                    f"({t.fs_hz / 2:g} Hz)"))
    # the update's lines of every test: inside the test's and the update's bands
    lines = [t.freq_hz[t.update_lines()] for t in plan.tests]
    if spec.update.band_hz is not None and methods:
        lo, hi = spec.update.band_hz
        empty = [t.name for t, f in zip(plan.tests, lines, strict=True) if f.size == 0]
        out.append((hi <= max(t.fs_hz / 2 for t in plan.tests),
                    f"update band {lo:g}-{hi:g} Hz inside Nyquist (lowest {nyquist:g} Hz)"))
        out.append((not empty, f"update band {lo:g}-{hi:g} Hz overlaps every test's band"
                    + (f"; no line of {empty}" if empty else "")))
    if "finite_difference" in methods and pairs > p and all(f.size for f in lines):
        pred = predictor(plan, lines)
        theta = {**pred.theta0}
        additive = pred.additive_scales(names)
        try:
            S = pred.jacobian(theta, names, additive=additive)
            if S is None:
                S, _ = sensitivity_matrix(pred.predict_vector, theta, names, additive=additive)
            A = _stack(S)
            check_identifiable(names, A, 1e-4, data="the model FRFs at the update's lines")
            s = np.linalg.svd(A / np.linalg.norm(A, axis=0), compute_uv=False)
            out.append((True, f"identifiable at the nominal model: {list(names)} (relative "
                              f"singular value {s[-1] / s[0]:.1e} of the column-scaled "
                              f"sensitivity matrix, limit 1e-04)"))
        except (IdentifiabilityError, ValueError) as exc:
            out.append((False, f"identifiability at the nominal model: {exc}"))
    elif "sensitivity" in methods and "finite_difference" not in methods:
        out.append((True, "identifiability of the sensitivity method depends on the "
                          "identified modes; not checked before a run"))
    n_trials = spec.campaign.trials if trials is None else int(trials)
    est = estimate_resources(plan, n_trials)
    workers = min(jobs, available_cores())
    mem = available_memory_mb()
    need = est.worker_mb * workers
    out.append((mem is None or need <= mem,
                f"memory: about {need:.0f} MB for {workers} worker(s) "
                f"({est.worker_mb:.0f} MB each; model {est.n_dofs} DOFs)"
                + (f", {mem:.0f} MB available" if mem is not None else "")))
    out.append((mem is None or est.report_mb <= mem,
                f"report: about {est.report_mb:.0f} MB of memory for {n_trials} trial(s)"))
    out.append((True, f"disk: about {est.store_mb:.0f} MB for {n_trials} trial(s) "
                      f"({est.store_mb_per_trial:.2f} MB each)"))
    total = est.seconds_per_trial * n_trials / workers
    out.append((True, f"time: about {est.seconds_per_trial:.2f} s per trial on one core, "
                      f"{total:.0f} s for {n_trials} trial(s) on {workers} worker(s) "
                      f"(a rough estimate from the record lengths and model size)"))
    return out


def _cmd_validate(args) -> int:
    from truthbench.campaign.spec import load_campaign

    spec = load_campaign(args.campaign)
    print(f"{args.campaign}: campaign {spec.campaign.name!r} loads ({len(spec.tests)} "
          f"test(s), update {spec.update_methods() or 'none'} of "
          f"{list(spec.update.parameters)})")
    results = check_campaign(spec, args.trials, args.jobs)
    for ok, msg in results:
        print(f"  {'ok  ' if ok else 'FAIL'} {msg}")
    bad = sum(not ok for ok, _ in results)
    if bad:
        print(f"{bad} check(s) failed", file=sys.stderr)
        return 1
    return 0


def register(sub) -> None:
    v = sub.add_parser("validate", help="check a campaign without running it "
                                        "(identifiability, bands, sizes)")
    v.add_argument("campaign", help="campaign TOML file")
    v.add_argument("--trials", type=int, help="trials to size for (default the file's)")
    v.add_argument("--jobs", type=int, default=1, help="workers to size for")
    v.set_defaults(func=_cmd_validate)
