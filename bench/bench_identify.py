"""Benchmark: truthbench.identify pLSCF against sdypy-EMA's LSCF on synthetic FRFs.

Run ``python bench/bench_identify.py [--seeds 20] [--json out.json]``.

Data: the modal model of ``tests/identify/conftest.py`` (analytic modal sum, 6 outputs):
modes at 10, 25, 25.25 (1 % apart, own shapes), 40 (zeta = 5 %) and 60 Hz, damping
0.5-1 % otherwise, receptance, 0-80 Hz at 0.05 Hz. **All frequencies are multiplied by
100** (1-6 kHz, 5 Hz lines) before either tool sees them: sdypy-EMA's
``select_closest_poles`` refines its frequency windows in whole Hz (down to 2 Hz), which
cannot separate modes 0.25 Hz apart; relative errors and damping ratios are unchanged by
the scaling. Noise: additive circular complex Gaussian, standard deviation ``eps`` times
the RMS of each FRF over the band (0, 2 %, 5 %), independent seeds.

Contenders, single input (input 0, SIMO; sdypy-EMA's LSCF is single-reference):

* ``sdypy`` - ``sdypy.EMA.Model(frf, freq, lower=50, upper=8000, pol_order_high=20,
  frf_form="receptance")``, ``get_poles("lscf")``, then ``select_closest_poles(true
  frequencies)`` and ``get_constants("lsfd")``. Its pole selection is interactive; being
  handed the **true** frequencies is its best case, which no real test has.
* ``truthbench`` - ``identify_plscf(max_order=40)``: pLSCF + automatic selection (no
  knowledge of the truth) + LSFD.
* ``truthbench+refine`` - the same with ``refine=True`` (output-error refinement).

and with both inputs (2 references), truthbench only (``max_order=24``).

A true mode counts as found if an estimate lies within 0.5 % of its frequency (one to
one). Errors are relative: ``f/f_true - 1`` and ``zeta/zeta_true - 1``; the tables give
the mean (bias) and standard deviation over the seeds where the mode was found, and the
worst MAC against the true shape. Time: median wall time of one identification
(poles + selection + residues), in this process, after one warm-up call.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "identify"))
from conftest import make_frf  # noqa: E402  (the test oracle: analytic modal sum)
from truthbench.identify import identify_plscf, mac  # noqa: E402

SCALE = 100.0

try:
    from sdypy import EMA

    SDYPY_ERROR = None
except ImportError as exc:  # pragma: no cover - depends on the machine
    EMA = None
    SDYPY_ERROR = str(exc)


def run_sdypy(freq_hz, frf, true_freq_hz):
    """sdypy-EMA LSCF with poles chosen closest to the true frequencies (best case)."""
    model = EMA.Model(
        frf=frf[:, :, 0].T,
        freq=freq_hz,
        lower=50.0,
        upper=float(freq_hz[-1]),
        pol_order_high=20,
        frf_form="receptance",
    )
    with contextlib.redirect_stderr(io.StringIO()), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model.get_poles("lscf", show_progress=False)
        model.select_closest_poles(list(true_freq_hz))
        _, A = model.get_constants(method="lsfd")
    return np.asarray(model.nat_freq), np.asarray(model.nat_xi), np.asarray(A)


def run_truthbench(freq_hz, frf, max_order, refine):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        m = identify_plscf(freq_hz, frf, max_order=max_order, refine=refine).modal
    return m.freq_hz, m.damping_ratio, m.shapes


def match(est_f, true_f, tol=0.005):
    """Index of the estimate of each true mode (-1 if none within tol), one to one."""
    out = -np.ones(true_f.size, dtype=int)
    used = set()
    for k in np.argsort(true_f):
        if est_f.size == 0:
            break
        rel = np.abs(est_f / true_f[k] - 1)
        rel[list(used)] = np.inf
        j = int(np.argmin(rel))
        if rel[j] < tol:
            out[k] = j
            used.add(j)
    return out


def study(name, runner, n_in, eps, seeds):
    f_err, z_err, macs, times = [], [], [], []
    found = np.zeros(5, dtype=int)
    for seed in range(seeds):
        syn = make_frf(n_in=n_in, noise=eps, seed=seed, f_min_hz=0.0)
        freq = syn.freq_hz * SCALE
        true_f = syn.freq_true * SCALE
        if seed == 0:
            runner(freq, syn.frf, true_f)  # warm-up (imports, caches)
        t0 = time.perf_counter()
        est_f, est_z, shapes = runner(freq, syn.frf, true_f)
        times.append(time.perf_counter() - t0)
        idx = match(est_f, true_f)
        ok = idx >= 0
        found += ok
        fe = np.full(5, np.nan)
        ze = np.full(5, np.nan)
        mm = np.full(5, np.nan)
        fe[ok] = est_f[idx[ok]] / true_f[ok] - 1
        ze[ok] = est_z[idx[ok]] / syn.zeta_true[ok] - 1
        mm[ok] = np.diag(mac(shapes[:, idx[ok]], syn.shapes_true[:, ok]))
        f_err.append(fe)
        z_err.append(ze)
        macs.append(mm)
    f_err, z_err, macs = np.array(f_err), np.array(z_err), np.array(macs)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        return {
            "name": name,
            "n_in": n_in,
            "eps": eps,
            "seeds": seeds,
            "found": found.tolist(),
            "freq_bias": np.nanmean(f_err, 0).tolist(),
            "freq_std": np.nanstd(f_err, 0).tolist(),
            "zeta_bias": np.nanmean(z_err, 0).tolist(),
            "zeta_std": np.nanstd(z_err, 0).tolist(),
            "mac_min": np.nanmin(macs, 0).tolist(),
            "time_s": float(np.median(times)),
        }


def fmt(v, spec):
    return " ".join("   --   " if not np.isfinite(x) else format(x, spec) for x in v)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--json", type=Path, default=None)
    args = ap.parse_args(argv)

    contenders = []
    if EMA is None:
        print(f"sdypy-EMA is not installed ({SDYPY_ERROR}); skipping it.")
    else:
        contenders.append(("sdypy (true freqs given)", lambda f, H, t: run_sdypy(f, H, t), 1))
    contenders += [
        ("truthbench", lambda f, H, t: run_truthbench(f, H, 40, False), 1),
        ("truthbench+refine", lambda f, H, t: run_truthbench(f, H, 40, True), 1),
        ("truthbench 2 inputs", lambda f, H, t: run_truthbench(f, H, 24, False), 2),
        ("truthbench+refine 2 inputs", lambda f, H, t: run_truthbench(f, H, 24, True), 2),
    ]
    results = []
    for eps in (0.0, 0.02, 0.05):
        seeds = 1 if eps == 0.0 else args.seeds
        print(f"\n## noise eps = {eps:.0%} ({seeds} seed{'s' if seeds > 1 else ''})")
        print("modes: 10, 25, 25.25, 40 (5 %), 60 (x100 Hz)")
        for name, runner, n_in in contenders:
            r = study(name, runner, n_in, eps, seeds)
            results.append(r)
            print(
                f"\n{name}: found {r['found']} of {seeds}, median time {r['time_s'] * 1e3:.1f} ms"
            )
            print(f"  freq bias  {fmt(r['freq_bias'], '+.1e')}")
            print(f"  freq std   {fmt(r['freq_std'], '.1e')}")
            print(f"  zeta bias  {fmt(r['zeta_bias'], '+.4f')}")
            print(f"  zeta std   {fmt(r['zeta_std'], '.4f')}")
            print(f"  MAC min    {fmt(r['mac_min'], '.5f')}")
    if args.json is not None:
        args.json.write_text(json.dumps(results, indent=2))
    return results


if __name__ == "__main__":
    main()
