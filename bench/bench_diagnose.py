"""Benchmark: the diagnosis's speed against the issue's targets.

``python bench/bench_diagnose.py [--rounds 3] [--trials 4]``

* one diagnosis of 9 channels x 2000 lines (the quickstart tube, 9 accelerometers, one
  shaker, 2000 lines of 0.25 Hz from 2 to 502 Hz, an added mass of 40 g injected) with
  the full catalogue, location searches included, on one core; target under 30 s;
* trials of ``campaigns/diagnose_study.toml`` in the other form's truth (two tests of 4
  channels x 998 or 1996 lines, none, one or two random effects); target under 10 s
  each.

No other tool diagnoses named effects, so there is no reference tool to measure in the
same run: the ratios printed are against the targets (below 1 meets them). Each round
runs in a fresh subprocess (medians over rounds; the machine is shared).
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parents[1]
TARGET_ONE_S = 30.0
TARGET_TRIAL_S = 10.0


def _spec_nine():
    import tomllib

    from truthbench.campaign.spec import parse_campaign

    data = tomllib.loads((HERE / "campaigns" / "diagnose_study.toml").read_text())
    data.pop("diagnose")
    # nodes 0, 2, 5, 7, 10, 12, 15, 17, 20 of the 20-element, 1.8 m tube
    data["sensors"] = [{"x_m": round(0.09 * k, 6), "direction": "z"}
                       for k in (0, 2, 5, 7, 10, 12, 15, 17, 20)]
    test = dict(data["tests"][0], band_hz=[2.0, 502.0], fs_hz=1024.0, record_s=16.0,
                averages=4)
    data["tests"] = [test]
    return parse_campaign(data, "bench: 9 channels x 2000 lines")


def _child_one() -> dict:
    from threadpoolctl import threadpool_limits

    from truthbench.campaign.diagnose_study import _study_spec
    from truthbench.campaign.runner import simulate_one
    from truthbench.diagnose import diagnose
    from truthbench.effects import parse_effect

    spec = _spec_nine()
    extra = [parse_effect({"name": "added_mass", "station": "n13",
                           "parameters": {"mass_kg": 0.04}}, "bench", "bench")]
    frf = simulate_one(_study_spec(spec), 0, 0, spec.campaign.seed, extra).frf
    lines = (frf.freq_hz >= 2.0) & (frf.freq_hz <= 502.0)
    with threadpool_limits(limits=1):
        t0 = time.perf_counter()
        diag = diagnose([frf], spec.make_plant(), spec.nominal_parameters(),
                        spec.update.parameters, identify_modes=False)
        seconds = time.perf_counter() - t0
    return {"seconds": seconds, "channels": len(frf.outputs), "lines": int(lines.sum()),
            "found": [(f.effect, f.node) for f in diag.found],
            "tried": len(diag.tried)}


def _child_trial(trial: int) -> dict:
    from threadpoolctl import threadpool_limits

    from truthbench.campaign.diagnose_study import study_trial
    from truthbench.campaign.spec import load_campaign

    spec = load_campaign(HERE / "campaigns" / "diagnose_study.toml")
    with threadpool_limits(limits=1):
        t0 = time.perf_counter()
        row, = study_trial(spec, trial, spec.campaign.seed, forms=("other",))
        seconds = time.perf_counter() - t0
    return {"seconds": seconds, "injected": row["injected"], "found": row["found"]}


def _run(args: list[str]) -> dict:
    out = subprocess.run([sys.executable, __file__, "--child", *args], check=True,
                         capture_output=True, text=True, env={
                             "PYTHONPATH": str(HERE / "src"), "PATH": "/usr/bin:/bin",
                             "OMP_NUM_THREADS": "1"})
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--trials", type=int, default=4)
    ap.add_argument("--child", nargs="*")
    a = ap.parse_args()
    if a.child is not None:
        r = _child_one() if a.child[0] == "one" else _child_trial(int(a.child[1]))
        print(json.dumps(r))
        return
    ones = [_run(["one"]) for _ in range(a.rounds)]
    t_one = statistics.median(r["seconds"] for r in ones)
    print(f"one diagnosis, {ones[0]['channels']} channels x {ones[0]['lines']} lines, full "
          f"catalogue ({ones[0]['tried']} candidates tried), one core: {t_one:.1f} s "
          f"(median of {a.rounds}); found {ones[0]['found']}")
    print(f"  ratio to the {TARGET_ONE_S:g} s target: {t_one / TARGET_ONE_S:.2f}")
    trials = [_run(["trial", str(i)]) for i in range(a.trials)]
    t_trial = statistics.median(r["seconds"] for r in trials)
    for i, r in enumerate(trials):
        print(f"  study trial {i}: {r['seconds']:.1f} s, injected {r['injected']}, "
              f"found {r['found']}")
    print(f"diagnose-study trial (simulate + diagnose), one core: {t_trial:.1f} s (median "
          f"of {a.trials}); ratio to the {TARGET_TRIAL_S:g} s target: "
          f"{t_trial / TARGET_TRIAL_S:.2f}")


if __name__ == "__main__":
    main()
