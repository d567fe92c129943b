"""Benchmark: the diagnosis's speed, this tree against a base tree in the same run.

``python bench/bench_diagnose.py [--base DIR] [--rounds 3] [--trials 4]``

* **One diagnosis** of 9 channels x 2001 lines with the full catalogue: the quickstart
  tube (20 elements, 1.8 m) measured by 9 vertical accelerometers and one shaker, 0.25
  Hz lines from 2 to 502 Hz, 4 Bartlett averages, 2 % noise; the truth is meshed four
  times finer with a 40 g mass between two model nodes. Issue target: under 5 s on one
  core.
* **A study trial** of ``campaigns/diagnose_study.toml`` (simulate, diagnose, score):
  this tree's other-form trial against the base tree's own trial of its own campaign.
  Issue target: under 3 s.

Each tree runs in its own subprocess (its ``src`` first on the path, one BLAS thread);
medians over rounds; the ratio printed is this tree's time over the base's (below 1:
faster) and over the target. Without ``--base`` only this tree runs. The machine is
shared: the load (``os.getloadavg``) is printed with the figures.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parents[1]
TARGET_ONE_S = 5.0
TARGET_TRIAL_S = 3.0


def _campaign(n_elements: int, station=None) -> dict:
    import tomllib

    data = tomllib.loads((HERE / "campaigns" / "quickstart.toml").read_text())
    data["plant"]["n_elements"] = n_elements
    if station is not None:
        data["plant"]["stations"] = {"m": station}
    # nodes 0, 2, 5, 7, 10, 12, 15, 17, 20 of the model's 20 elements
    data["sensors"] = [{"x_m": round(0.09 * k, 6), "direction": "z"}
                       for k in (0, 2, 5, 7, 10, 12, 15, 17, 20)]
    data["tests"] = [dict(data["tests"][0], band_hz=[2.0, 502.0], record_s=16.0,
                          averages=4)]
    data["update"] = {"method": "finite_difference", "parameters": ["E_pa", "rho_kg_m3"]}
    return data


def _child_one() -> dict:
    """Runs in either tree: only APIs both have."""
    from threadpoolctl import threadpool_limits

    from truthbench.campaign.runner import simulate_one
    from truthbench.campaign.spec import parse_campaign
    from truthbench.diagnose import diagnose
    from truthbench.effects import parse_effect

    model = parse_campaign(_campaign(20), "bench model")
    truth = parse_campaign(_campaign(80, 0.6375), "bench truth")  # 1.1475 m, off-node
    extra = [parse_effect({"name": "added_mass", "station": "m",
                           "parameters": {"mass_kg": 0.04}}, "bench", "bench")]
    frf = simulate_one(truth, 0, 0, truth.campaign.seed, extra).frf
    lines = (frf.freq_hz >= 2.0) & (frf.freq_hz <= 502.0)
    with threadpool_limits(limits=1):
        t0 = time.perf_counter()
        diag = diagnose([frf], model.make_plant(), model.nominal_parameters(),
                        model.update.parameters)
        seconds = time.perf_counter() - t0
    return {"seconds": seconds, "channels": len(frf.outputs), "lines": int(lines.sum()),
            "found": [(f.effect, round(f.parameters.get("mass_kg", float("nan")), 4))
                      for f in diag.found]}


def _child_trial(trial: int) -> dict:
    from threadpoolctl import threadpool_limits

    from truthbench.campaign import diagnose_study as ds
    from truthbench.campaign.spec import load_campaign

    spec = load_campaign(HERE / "campaigns" / "diagnose_study.toml")
    with threadpool_limits(limits=1):
        t0 = time.perf_counter()
        if hasattr(ds, "forms_of"):  # this tree: the other form's trial only
            rows = ds.study_trial(spec, trial, spec.campaign.seed, forms=("other",))
            row = rows[0]
        else:
            row = ds.study_trial(spec, trial, spec.campaign.seed)
        seconds = time.perf_counter() - t0
    return {"seconds": seconds, "injected": row["injected"], "found": row["found"]}


def _run(tree: Path, args: list[str]) -> dict:
    # the child is this file, run with the tree's src first: the campaigns it reads are
    # the tree's own
    env = {"PYTHONPATH": str(tree / "src"), "PATH": os.environ.get("PATH", "/usr/bin:/bin"),
           "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1",
           "BENCH_TREE": str(tree)}
    out = subprocess.run([sys.executable, __file__, "--child", *args], check=True,
                         capture_output=True, text=True, env=env)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--base", help="a checkout of the code to compare against (its root)")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--trials", type=int, default=4)
    ap.add_argument("--child", nargs="*")
    a = ap.parse_args()
    if a.child is not None:
        global HERE
        HERE = Path(os.environ.get("BENCH_TREE", HERE))
        r = _child_one() if a.child[0] == "one" else _child_trial(int(a.child[1]))
        print(json.dumps(r))
        return
    trees = {"this": HERE} | ({"base": Path(a.base).resolve()} if a.base else {})
    print(f"load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")
    ones = {name: [_run(tree, ["one"]) for _ in range(a.rounds)]
            for name, tree in trees.items()}
    t_one = {k: statistics.median(r["seconds"] for r in v) for k, v in ones.items()}
    for name in trees:
        r = ones[name][0]
        print(f"one diagnosis ({name}), {r['channels']} channels x {r['lines']} lines, full "
              f"catalogue, one core: {t_one[name]:.1f} s (median of {a.rounds}); found "
              f"{r['found']}")
    line = f"  this / target {TARGET_ONE_S:g} s: {t_one['this'] / TARGET_ONE_S:.2f}"
    if "base" in t_one:
        line += f"; this / base: {t_one['this'] / t_one['base']:.2f}"
    print(line)
    trials = {name: [_run(tree, ["trial", str(i)]) for i in range(a.trials)]
              for name, tree in trees.items()}
    t_trial = {k: statistics.median(r["seconds"] for r in v) for k, v in trials.items()}
    for name in trees:
        for i, r in enumerate(trials[name]):
            print(f"  study trial {i} ({name}): {r['seconds']:.1f} s, injected "
                  f"{r['injected']}, found {r['found']}")
        print(f"diagnose-study trial ({name}), one core: {t_trial[name]:.1f} s (median of "
              f"{a.trials})")
    line = f"  this / target {TARGET_TRIAL_S:g} s: {t_trial['this'] / TARGET_TRIAL_S:.2f}"
    if "base" in t_trial:
        line += f"; this / base: {t_trial['this'] / t_trial['base']:.2f}"
    print(line)
    print(f"load average {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
