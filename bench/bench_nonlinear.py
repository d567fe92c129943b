"""Benchmark: simulation with Coulomb friction, truthbench.simulate.nonlinear.

Run ``python bench/bench_nonlinear.py`` (``--quick`` for shorter records). Ratios are
measured in the same run; times are the best of several runs (CPU time of this process,
``time.process_time``, which a loaded shared machine disturbs less than wall time).

(a) One DOF (m = 1 kg, 2 Hz, 1 % damping), friction F_c = 0.3 x the RMS force,
    2**16 samples at 256 Hz of band-limited random force (0-5 Hz): about a thousand
    velocity reversals and some hundreds of stick phases.
    * ours: :func:`simulate_nonlinear` (event-located switching between exact regimes);
    * "solve_ivp, restarted at each event": what one would write with scipy: RK45
      (rtol 1e-8, atol 1e-12) on the whole record with ``np.interp`` input, restarted at
      each reversal, stick and breakaway (terminal events), output at the samples;
    * the accuracy reference: DOP853 (rtol 1e-11) restarted at every sample (where
      the input is linear) and at every event, as in ``tests/simulate/test_nonlinear.py``.
    The error is ``max_t |y - y_ref| / rms(y_ref)`` over the two outputs (x, v).
(b) A 40-mode (80-state) modal model (modes 3 Hz to 1.5 kHz, damping 0.2-2 %), one
    force input, 4 displacement outputs, 2**16 samples at 8192 Hz, friction at the
    driven point: time of :meth:`NonlinearSystem.simulate` relative to
    :meth:`LtiRecursion.simulate` (both prepared; the one-shot functions with the
    preparation are shown too). The two are run alternately, 25 times each, and the
    ratio of the best times is shown with the median of the per-run ratios (the machine
    is shared: the load changes within seconds). The error is checked over the first 1024
    samples (256 with ``--quick``) against DOP853 (rtol 1e-11) restarted at every sample
    and every event, the n-state version of the reference of (a). The cost of friction
    is mostly per event (a velocity reversal, stick or breakaway needs a few exact
    intra-step evaluations over all modes), so cases without events (friction so large
    that the point never slips), with few and with very many events are shown: input
    band 0-50 Hz and 0-3.3 kHz (every mode up to 1.5 kHz driven at the friction point: a
    reversal every ~9 samples, and velocities that touch zero and come back within one
    step).
(c) The compile cache: two fresh processes each run a small friction simulation with the
    numba engine and report the CPU time of that first call and numba's cache hits and
    misses (a miss is a compilation).

BLAS runs single-threaded (``OPENBLAS_NUM_THREADS=1`` etc., unless already set).
"""

from __future__ import annotations

# ruff: noqa: E402  (the BLAS thread variables must be set before numpy is imported)
import os
import sys
import time

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np
from scipy.integrate import solve_ivp

from truthbench.simulate import (
    band_limited_random,
    numba_available,
    prepare_lti,
    simulate_lti,
)
from truthbench.simulate.nonlinear import (
    CoulombFriction,
    NonlinearElement,
    prepare_nonlinear,
    simulate_nonlinear,
)

QUICK = "--quick" in sys.argv
N_SAMPLES = 2**13 if QUICK else 2**16


def best_time(func, repeat):
    times = []
    out = None
    for _ in range(repeat):
        t0 = time.process_time()
        out = func()
        times.append(time.process_time() - t0)
    return min(times), out


def rel_err(y, ref):
    rms = np.sqrt(np.mean(ref**2, axis=-1))
    return float(np.max(np.max(np.abs(y - ref), axis=-1) / rms))


# ----------------------------------------------------------------------------------
# (a) one DOF against solve_ivp
# ----------------------------------------------------------------------------------


def sdof(freq_hz=2.0, zeta=0.01):
    k = (2 * np.pi * freq_hz) ** 2
    c = 2 * zeta * np.sqrt(k)
    return np.array([[0.0, 1.0], [-k, -c]]), np.array([[0.0], [1.0]]), k, c


def solve_ivp_restarted(a, b, fc, u, dt, rtol=1e-8, atol=1e-12):
    """RK45 on the whole record, restarted at every reversal, stick and breakaway."""
    n = u.size
    t_grid = dt * np.arange(n)
    t_end = t_grid[-1]
    bb = b[:, 0]
    out = np.zeros((2, n))
    x = np.zeros(2)
    t0 = 0.0
    k, c = -a[1, 0], -a[1, 1]

    def net(t, xs):  # force on the mass without friction, at rest
        return np.interp(t, t_grid, u) - k * xs

    mode = 0.0 if abs(net(0.0, 0.0)) <= fc else np.sign(net(0.0, 0.0))
    n_events = 0
    while t0 < t_end:
        te = t_grid[t_grid >= t0]
        if mode != 0.0:
            def rhs(t, s, d=mode):
                return a @ s + bb * (np.interp(t, t_grid, u) - fc * d)

            def ev(t, s, d=mode):
                return d * s[1]

            ev.terminal, ev.direction = True, -1
            # a short event-free start from v = 0
            t1 = min(t0 + 1e-9 * dt, t_end)
            x = solve_ivp(rhs, (t0, t1), x, rtol=rtol, atol=atol).y[:, -1]
            te = te[te >= t1]
            sol = solve_ivp(rhs, (t1, t_end), x, rtol=rtol, atol=atol, events=ev, t_eval=te)
            idx = np.rint(np.asarray(sol.t) / dt).astype(int)
            if idx.size:
                out[:, idx] = sol.y
            if sol.status != 1:
                break
            t0, x = sol.t_events[0][0], sol.y_events[0][0].copy()
            x[1] = 0.0
            h = net(t0, x[0]) - c * 0.0
            mode = 0.0 if abs(h) <= fc else np.sign(h)
        else:
            xs = x[0]

            def rhs(t, s):
                return np.zeros(2)

            def ev(t, s, xs=xs):
                return fc - abs(net(t, xs))

            ev.terminal, ev.direction = True, -1
            sol = solve_ivp(rhs, (t0, t_end), x, rtol=rtol, atol=atol, events=ev, t_eval=te,
                            max_step=dt)
            idx = np.rint(np.asarray(sol.t) / dt).astype(int)
            if idx.size:
                out[:, idx] = sol.y
            if sol.status != 1:
                break
            t0 = sol.t_events[0][0]
            mode = np.sign(net(t0, xs))
        n_events += 1
    return out, n_events


def reference(a, b, fc, u, dt, rtol=1e-11, atol=1e-15):
    """DOP853 restarted at every sample and every event (the test-suite oracle)."""
    cv = np.array([0.0, 1.0])
    bf = b[:, 0]
    proj = np.eye(2) - np.outer(bf, cv) / (cv @ bf)
    x = np.zeros(2)

    def hold(s, uu):
        return -(cv @ (a @ s + bf * uu)) / (cv @ bf)

    h0 = hold(x, u[0])
    mode = 0.0 if abs(h0) <= fc else -np.sign(h0)
    out = np.zeros((2, u.size))
    for j in range(u.size - 1):
        t0, t1 = j * dt, (j + 1) * dt
        ua, ub = u[j], u[j + 1]

        def uf(t, ua=ua, ub=ub, t0=t0):
            return ua + (ub - ua) * ((t - t0) / dt)

        t = t0
        while t < t1:
            if mode != 0:
                def rhs(tt, s, d=mode, uf=uf):
                    return a @ s + bf * (uf(tt) - fc * d)

                def ev(tt, s, d=mode):
                    return d * s[1]

                ev.terminal, ev.direction = True, -1
                if abs(x[1]) <= 1e-14 * (1.0 + np.abs(x).max()):
                    tt = min(t + 1e-9 * dt, t1)
                    x = solve_ivp(rhs, (t, tt), x, method="DOP853", rtol=rtol,
                                  atol=atol).y[:, -1]
                    t = tt
                    if t >= t1:
                        break
                sol = solve_ivp(rhs, (t, t1), x, method="DOP853", rtol=rtol, atol=atol,
                                events=ev)
                if sol.status == 1:
                    t, x = sol.t_events[0][0], sol.y_events[0][0]
                    h = hold(x, uf(t))
                    mode = 0.0 if abs(h) <= fc else -np.sign(h)
                else:
                    t, x = t1, sol.y[:, -1]
            else:
                def rhs(tt, s, uf=uf):
                    return proj @ (a @ s + bf * uf(tt))

                def ev(tt, s, uf=uf):
                    return fc - abs(hold(s, uf(tt)))

                ev.terminal, ev.direction = True, -1
                sol = solve_ivp(rhs, (t, t1), x, method="DOP853", rtol=rtol, atol=atol,
                                events=ev)
                if sol.status == 1:
                    t, x = sol.t_events[0][0], sol.y_events[0][0]
                    mode = -np.sign(hold(x, uf(t)))
                else:
                    t, x = t1, sol.y[:, -1]
        out[:, j + 1] = x
    return out


def bench_sdof():
    fs = 256.0
    dt = 1.0 / fs
    a, b, _, _ = sdof()
    u = band_limited_random(N_SAMPLES, fs, 1.0, (0.0, 5.0), np.random.default_rng(11))[0]
    fc = 0.3
    el = NonlinearElement(CoulombFriction(fc), [1.0, 0.0], [0.0, 1.0], [0.0, 1.0])
    simulate_nonlinear(a, b, np.eye(2), None, u[:100], dt, [el])  # compile / load cache
    t_ours, res = best_time(lambda: simulate_nonlinear(a, b, np.eye(2), None, u, dt, [el]), 5)
    t0 = time.process_time()
    y_ivp, n_ev = solve_ivp_restarted(a, b, fc, u, dt)
    t_ivp = time.process_time() - t0
    t0 = time.process_time()
    y_ref = reference(a, b, fc, u, dt)
    t_ref = time.process_time() - t0
    print(f"(a) one DOF, {N_SAMPLES} samples at {fs:g} Hz, F_c = {fc} x RMS force: "
          f"{res.n_reversals[0]} reversals, {res.n_stick_events[0]} stick phases "
          f"(stuck {100 * res.stuck.mean():.1f} % of samples)")
    print()
    header = f"{'method':52s} {'time [s]':>10s} {'ours faster':>12s} {'rel. error':>11s}"
    print(header)
    print("-" * len(header))
    rows = [
        ("simulate_nonlinear (incl. preparation)", t_ours, rel_err(res.y, y_ref)),
        (f"solve_ivp RK45 rtol 1e-8, restarted at {n_ev} events", t_ivp, rel_err(y_ivp, y_ref)),
        ("reference: DOP853 rtol 1e-11, per sample + events", t_ref, 0.0),
    ]
    for name, tm, err in rows:
        print(f"{name:52s} {tm:10.4f} {tm / t_ours:11.0f}x {err:11.2e}")
    print("rel. error = max over x, v of max_t |y - y_ref| / rms(y_ref)")
    return t_ivp / t_ours, rel_err(res.y, y_ref)


# ----------------------------------------------------------------------------------
# (b) a 40-mode model against the linear simulation
# ----------------------------------------------------------------------------------


def modal_model(n_modes=40, n_out=4, seed=0):
    """Modal state space ``[eta; eta']``, force at one point, displacement outputs."""
    rng = np.random.default_rng(seed)
    omega = 2 * np.pi * np.geomspace(3.0, 1500.0, n_modes)
    zeta = rng.uniform(0.002, 0.02, n_modes)
    m = n_modes
    a = np.block([[np.zeros((m, m)), np.eye(m)],
                  [-np.diag(omega**2), -np.diag(2 * zeta * omega)]])
    phi_in = rng.standard_normal(m)
    phi_out = rng.standard_normal((n_out, m))
    b = np.r_[np.zeros(m), phi_in][:, None]
    c = np.hstack([phi_out, np.zeros((n_out, m))])
    return a, b, c, np.zeros((n_out, 1)), phi_in


def reference_modal(a, b, c, cv, bf, fc, u, dt, rtol=1e-11, atol=1e-15):
    """DOP853 restarted at every sample and every event, one friction element
    (velocity row ``cv``, force column ``bf``), from rest: as ``reference`` for n states."""
    n = a.shape[0]
    gain = cv @ bf
    proj = np.eye(n) - np.outer(bf, cv) / gain
    x = np.zeros(n)
    scale_v = np.abs(cv).sum()

    def hold(s, uu):
        return -(cv @ (a @ s + b @ uu)) / gain

    h0 = hold(x, u[:, 0])
    mode = 0.0 if abs(h0) <= fc else -np.sign(h0)
    out = np.zeros((n, u.shape[1]))
    for j in range(u.shape[1] - 1):
        t0, t1 = j * dt, (j + 1) * dt
        ua, ub = u[:, j], u[:, j + 1]

        def uf(t, ua=ua, ub=ub, t0=t0):
            return ua + (ub - ua) * ((t - t0) / dt)

        t = t0
        while t < t1:
            if mode != 0:
                def rhs(tt, s, d=mode, uf=uf):
                    return a @ s + b @ uf(tt) - fc * d * bf

                def ev(tt, s, d=mode):
                    return d * (cv @ s)

                ev.terminal, ev.direction = True, -1
                if abs(cv @ x) <= 1e-14 * (1.0 + scale_v * np.abs(x).max()):
                    tt = min(t + 1e-9 * dt, t1)
                    x = solve_ivp(rhs, (t, tt), x, method="DOP853", rtol=rtol,
                                  atol=atol).y[:, -1]
                    t = tt
                    if t >= t1:
                        break
                sol = solve_ivp(rhs, (t, t1), x, method="DOP853", rtol=rtol, atol=atol,
                                events=ev)
                if sol.status == 1:
                    t, x = sol.t_events[0][0], sol.y_events[0][0]
                    h = hold(x, uf(t))
                    mode = 0.0 if abs(h) <= fc else -np.sign(h)
                else:
                    t, x = t1, sol.y[:, -1]
            else:
                def rhs(tt, s, uf=uf):
                    return proj @ (a @ s + b @ uf(tt))

                def ev(tt, s, uf=uf):
                    return fc - abs(hold(s, uf(tt)))

                ev.terminal, ev.direction = True, -1
                sol = solve_ivp(rhs, (t, t1), x, method="DOP853", rtol=rtol, atol=atol,
                                events=ev)
                if sol.status == 1:
                    t, x = sol.t_events[0][0], sol.y_events[0][0]
                    mode = -np.sign(hold(x, uf(t)))
                else:
                    t, x = t1, sol.y[:, -1]
        out[:, j + 1] = x
    return c @ out


def interleaved(funcs, repeat):
    """Best CPU time of each function, the runs interleaved (a load change on the shared
    machine hits all of them alike); also the median of the per-round ratios to the
    first."""
    times = [[] for _ in funcs]
    for _ in range(repeat):
        for k, f in enumerate(funcs):
            t0 = time.process_time()
            f()
            times[k].append(time.process_time() - t0)
    ratios = [float(np.median(np.array(t) / np.array(times[0]))) for t in times]
    return [min(t) for t in times], ratios


def bench_modal():
    fs = 8192.0
    dt = 1.0 / fs
    a, b, c, d, phi_in = modal_model()
    rec = prepare_lti(a, b, c, d, dt)
    n_ref = 256 if QUICK else 1024
    print(f"(b) 40-mode model (80 states), 4 outputs, {N_SAMPLES} samples at {fs:g} Hz, "
          "friction at the driven point; times relative to the linear simulation")
    print()
    header = (f"{'case':36s} {'events':>7s} {'stuck':>6s} {'lin [ms]':>9s} {'ours [ms]':>10s}"
              f" {'ratio':>6s} {'(median)':>8s} {'one-shot':>9s} {'rel. error':>11s}")
    print(header)
    print("-" * len(header))
    rows = []
    r_base = None
    for band, fc_rel in (((0.0, 50.0), 1e6), ((0.0, 50.0), 0.1), ((0.0, 50.0), 0.5),
                         ((0.0, 0.4 * fs), 0.1)):
        u = band_limited_random(N_SAMPLES, fs, 1.0, band, np.random.default_rng(1))
        el = NonlinearElement.modal(CoulombFriction(fc_rel), phi_in)
        system = prepare_nonlinear(a, b, c, d, dt, [el])
        system.simulate(u[:, :100])
        rec.simulate(u[:, :100])
        res = system.simulate(u)
        (t_lin, t_nl), (_, med) = interleaved(
            [lambda u=u: rec.simulate(u), lambda u=u, s=system: s.simulate(u)],
            9 if QUICK else 25)
        (t_lin1, t_nl1), _ = interleaved(
            [lambda u=u: simulate_lti(a, b, c, d, u, dt),
             lambda u=u, el=el: simulate_nonlinear(a, b, c, d, u, dt, [el])], 5)
        n_ev = int(res.n_reversals[0] + 2 * res.n_stick_events[0])
        # accuracy: the first n_ref samples against DOP853 restarted at every event
        ref = reference_modal(a, b, c, el.velocity_row, el.force_column, fc_rel,
                              u[:, :n_ref], dt)
        err = rel_err(res.y[:, :n_ref], ref)
        lin_rms = np.sqrt(np.mean(rec.simulate(u)[:, :n_ref] ** 2, axis=-1))
        if np.all(np.sqrt(np.mean(ref**2, axis=-1)) < 1e-9 * lin_rms):
            # held at the driven point, the structure does not move (the reference is
            # zero to rounding): the error relative to the linear response instead
            err = float(np.max(np.max(np.abs(res.y[:, :n_ref] - ref), axis=-1) / lin_rms))
        n_ev_ref = int(np.count_nonzero(np.diff(np.sign(res.velocity[0, :n_ref])) != 0))
        name = ("no event (F_c huge: always stuck)" if fc_rel >= 1e6 else
                f"band {band[1]:g} Hz, F_c = {fc_rel} x RMS force")
        # the cost of an event: the excess of the ratio over the case with the fewest
        # events that slip (the always-stuck case has a different per-step cost: its
        # holding-force row has a direct input term), in units of this case's linear
        # time (the load of the shared machine differs between cases)
        if r_base is None and fc_rel < 1e6:
            r_base, n_base = t_nl / t_lin, n_ev
            per_event = float("nan")
        else:
            per_event = ((t_nl / t_lin - r_base) * t_lin / (n_ev - n_base)
                         if r_base is not None else float("nan"))
        rows.append((name, n_ev, t_nl / t_lin, per_event, err, n_ev_ref))
        print(f"{name:36s} {n_ev:7d} {100 * res.stuck.mean():5.1f}% {1e3 * t_lin:9.2f} "
              f"{1e3 * t_nl:10.2f} {t_nl / t_lin:5.2f}x {med:7.2f}x {t_nl1 / t_lin1:8.2f}x "
              f"{err:11.2e}")
    print("events = velocity reversals + stick and breakaway events; ratio = best "
          "NonlinearSystem.simulate / best LtiRecursion.simulate, runs interleaved (median = "
          "median of the per-run ratios); one-shot = simulate_nonlinear / simulate_lti "
          f"(both with their preparation); rel. error over the first {n_ref} samples "
          "against DOP853 (rtol 1e-11) restarted at every sample and event (always stuck: "
          "the structure, held at the driven point, does not move; error relative to the "
          "linear response)")
    for name, _, _, per_event, _, n_ev_ref in rows[1:]:
        if per_event != per_event:  # (the base case itself)
            continue
        print(f"  {name}: per event (over the {n_base}-event case) = "
              f"{1e6 * per_event:.2f} us"
              f" ({n_ev_ref} sign changes of the velocity in the checked samples)")
    return rows


CACHE_PROBE = """
import time
import numpy as np
t0 = time.process_time()
from truthbench.simulate.nonlinear import CoulombFriction, NonlinearElement, simulate_nonlinear
from truthbench.simulate import _nonlinear_numba as nb
t1 = time.process_time()
a = np.array([[0.0, 1.0], [-400.0, -0.4]]); b = np.array([[0.0], [1.0]])
el = NonlinearElement(CoulombFriction(0.3), [1.0, 0.0], [0.0, 1.0], [0.0, 1.0])
simulate_nonlinear(a, b, np.eye(2), None, np.sin(0.05 * np.arange(500)), 0.01, [el],
                   backend="numba")
t2 = time.process_time()
hits = sum(sum(f.stats.cache_hits.values()) for f in nb._globals.values()
           if hasattr(f, "stats"))
misses = sum(sum(f.stats.cache_misses.values()) for f in nb._globals.values()
             if hasattr(f, "stats"))
print(f"{t1 - t0:.2f} {t2 - t1:.2f} {hits} {misses}")
"""


def check_cache():
    """The compiled loop is cached on disk: a fresh process loads it, compiles nothing."""
    import subprocess

    out = []
    for _ in range(2):
        res = subprocess.run([sys.executable, "-c", CACHE_PROBE], capture_output=True,
                             text=True, check=True)
        out.append(res.stdout.split())
    print("compile cache (numba cache=True), two fresh processes, first simulate_nonlinear "
          "call each:")
    for k, (t_imp, t_call, hits, misses) in enumerate(out, 1):
        print(f"  process {k}: import {t_imp} s, first call {t_call} s CPU; "
              f"{hits} compiled functions loaded from the cache, {misses} compiled anew")
    return int(out[-1][3])


def main():
    print(f"numba available = {numba_available()}; OPENBLAS_NUM_THREADS = "
          f"{os.environ.get('OPENBLAS_NUM_THREADS')}")
    print()
    misses = check_cache() if numba_available() else None
    print()
    speedup, err = bench_sdof()
    print()
    rows = bench_modal()
    print()
    print("targets: (a) >= 100x faster than solve_ivp with error < 1e-4 -> "
          f"{speedup:.0f}x, {err:.1e}; (b) <= 3x the linear simulation, error < 1e-4 -> "
          + ", ".join(f"{r:.2f}x at {e:.0e} ({n} events)" for _, n, r, _, e, _ in rows)
          + (f"; second process compiles nothing: {misses == 0}" if misses is not None
             else ""))


if __name__ == "__main__":
    main()
