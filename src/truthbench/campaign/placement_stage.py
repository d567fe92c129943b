"""Sensor placement for a campaign (METHOD 5.3, Eq. 10.45).

Candidates are the translations, in the directions the campaign's sensors use, at every
node of the model. Two rankings:

* by shape sensitivity: the analytic eigenvector sensitivities of the target modes (the
  model's modes in the analysis band) to the campaign's update parameters, each scaled
  by the parameter's expected relative error (its ``truth.relative`` offset, or 1 %),
  with a greedy D-optimal pick of ``count`` DOFs;
* by the scaled observability gramian of the modal system at each candidate.
"""

from __future__ import annotations

import numpy as np


def rank_campaign_sensors(spec, count: int):
    """Both rankings for a campaign.

    Returns
    -------
    by_sensitivity, by_gramian : SensorRanking
    """
    from truthbench.campaign.metrics import analysis_band
    from truthbench.placement import (
        modal_candidate_system,
        rank_sensors_by_gramian,
        rank_sensors_by_sensitivity,
    )
    from truthbench.update import eigen_sensitivities, macroelement_matrices

    if not spec.update.parameters:
        raise ValueError(f"{spec.source}: key 'update.parameters': sensor placement ranks "
                         f"DOFs by the shape change these parameters cause; got none")
    plant = spec.make_plant()
    theta = spec.nominal_parameters()
    model = plant.build(theta)
    modes = model.modes()
    lo, hi = analysis_band(spec)
    target = np.flatnonzero((modes.freq_hz >= lo) & (modes.freq_hz <= hi) & ~modes.rigid)
    dirs = sorted({s.direction for s in spec.sensors if s.direction in ("x", "y", "z")})
    cand = [i for i, lab in enumerate(model.dof_labels) if lab.split(".")[1] in dirs]
    labels = [model.dof_labels[i] for i in cand]

    def build_mk(th):
        m = plant.build(th)
        return m.M, m.K

    names = list(spec.update.parameters)
    macro = macroelement_matrices(build_mk, theta, names, warn=False)
    _, dphi = eigen_sensitivities(modes, macro)
    sigma = np.array([abs(spec.truth.relative.get(n, 0.0)) or 0.01 for n in names])
    rows = dphi[cand][:, target, :]
    visible = np.linalg.norm(modes.shapes[cand][:, target], axis=0) > 1e-8
    by_sens = rank_sensors_by_sensitivity(rows[:, visible, :], sigma, labels=labels,
                                          n_select=count)
    zeta = np.full(len(target), 0.01)
    A, C = modal_candidate_system(modes.omega_rad_s[target], zeta,
                                  modes.shapes[cand][:, target])
    by_gram = rank_sensors_by_gramian(A, C, labels=labels)
    return by_sens, by_gram
