"""Benchmark: model FRF, eigensolution and CLI start-up against the reference tools.

Run: ``python bench/bench_model.py``. Prints ratios measured in this run:

* modal-superposition FRF of an 80-state (40-mode) modal model over 2000 frequencies
  against ``control.frequency_response`` of the same state space (target: >= 100x
  faster, equal to 1e-10), for classical and for non-proportional (hub dashpot) damping;
* the lowest 20 modes of a 200-element member (1206 DOFs) against
  ``scipy.sparse.linalg.eigsh`` in shift-invert mode and dense ``scipy.linalg.eigh``
  (target: no slower than eigsh);
* ``truthbench --help`` wall time (target: < 0.5 s).
"""

from __future__ import annotations

import subprocess
import sys
import time

import control
import numpy as np
import scipy.linalg as sla
import scipy.sparse.linalg as spla

from truthbench.fe.assembly import assemble, finish_structure, straight_member
from truthbench.model import solve_modes
from truthbench.plants import Actuator, Sensor, make_plant


def best_of(fn, repeat=5):
    times = []
    out = None
    for _ in range(repeat):
        t = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t)
    return min(times), out


def frf_case(hub_damping):
    plant = make_plant("hub_beam", n_elements=20)
    model = plant.build({"hub_damping_n_m_s_rad": hub_damping},
                        [Actuator("hub", "rz")],
                        [Sensor("hub", "rz", "velocity"), Sensor("root", "y", "strain"),
                         Sensor("mid", "y"), Sensor("tip", "y")])
    modes = model.modes(40)
    freq = np.linspace(0.5, 500.0, 2000)
    sys_ = model.state_space(modes=modes)
    t_ours, H = best_of(lambda: model.frf(freq, modes=modes), 20)
    t_ctrl, r = best_of(lambda: control.frequency_response(sys_, 2 * np.pi * freq), 3)
    Hc = np.moveaxis(np.asarray(r.complex).reshape(sys_.noutputs, sys_.ninputs, -1), -1, 0)
    row_max = np.abs(Hc).max(axis=(0, 2), keepdims=True)
    mask = np.abs(Hc) > 1e-6 * row_max
    diff = (np.abs(H - Hc)[mask] / np.abs(Hc)[mask]).max()
    return t_ours, t_ctrl, diff, sys_.nstates


def eig_case():
    mesh = straight_member([0, 0, 0], [2.0, 0, 0], 200)
    props = dict(E_pa=70e9, nu=0.3, rho_kg_m3=2700.0, r_m=0.012, t_m=0.0015)
    K, M = assemble(mesh, {"beam": props})
    Mf, _, Kf, _ = finish_structure(K, M, mesh.n_dofs)
    t_ours, modes = best_of(lambda: solve_modes(Mf, Kf, 20), 3)
    sigma = -1e-6 * Kf.diagonal().sum() / Mf.diagonal().sum()
    t_eigsh, _ = best_of(lambda: spla.eigsh(Kf.tocsc(), k=20, M=Mf.tocsc(), sigma=sigma,
                                            which="LM"), 3)
    Kd, Md = Kf.toarray(), Mf.toarray()
    t_dense, _ = best_of(lambda: sla.eigh(Kd, Md, subset_by_index=(0, 19)), 2)
    return t_ours, t_eigsh, t_dense, Kf.shape[0]


def help_case():
    t = time.perf_counter()
    subprocess.run([sys.executable, "-m", "truthbench", "--help"], check=True,
                   capture_output=True)
    return time.perf_counter() - t


def main():
    print("truthbench model benchmark (best of repeated runs, this machine, this run)\n")
    for label, c in (("classical damping", 0.0), ("hub dashpot (complex modes)", 5.0)):
        ours, ctrl, diff, n = frf_case(c)
        print(f"FRF, {n}-state modal model, 2000 freq, {label}:")
        print(f"  truthbench {1e3 * ours:8.2f} ms | control.frequency_response "
              f"{1e3 * ctrl:8.1f} ms | ratio {ctrl / ours:7.1f}x (target >= 100x) | "
              f"max rel diff {diff:.1e} (target 1e-10)")
    ours, eigsh, dense, n = eig_case()
    print(f"\nEigensolution, 200-element member ({n} DOFs), lowest 20 modes:")
    print(f"  truthbench {1e3 * ours:8.1f} ms | eigsh shift-invert {1e3 * eigsh:8.1f} ms "
          f"(ratio {eigsh / ours:4.2f}, target >= 1) | dense eigh {1e3 * dense:8.1f} ms "
          f"(ratio {dense / ours:5.1f})")
    t = help_case()
    print(f"\n'truthbench --help': {1e3 * t:.0f} ms (target < 500 ms; includes the "
          f"interpreter start)")


if __name__ == "__main__":
    main()
