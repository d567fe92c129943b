"""Sensor placement for a campaign (Section 10.3, Eq. 10.45; :ref:`method-placement`).

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
    from truthbench.campaign.plan import CampaignPlan
    from truthbench.placement import (
        modal_candidate_system,
        rank_sensors_by_gramian,
        rank_sensors_by_sensitivity,
    )
    from truthbench.update import eigen_sensitivities, macroelement_matrices

    if not spec.update.parameters:
        raise ValueError(f"{spec.source}: key 'update.parameters': sensor placement ranks "
                         f"DOFs by the shape change these parameters cause; got none")
    plan = CampaignPlan.compile(spec)
    plant, theta = plan.plant, plan.nominal
    model = plant.build(theta)
    modes = model.modes()
    lo, hi = plan.analysis_band_hz
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


def layout_spec(spec, dof_labels, name: str = "proposed"):
    """The campaign with its sensors replaced by sensors at ``dof_labels``.

    Parameters
    ----------
    spec : CampaignSpec
    dof_labels : sequence of str
        Model DOF labels ``n<node>.<direction>`` (translations), as the rankings give.
    name : str
        Suffix of the campaign name and source.

    Returns
    -------
    CampaignSpec
        Every test measures at the new sensors (a test's own sensor list is replaced
        too), with the quantity of the campaign's first sensor; a station ``node<k>`` is
        added for every node used.
    """
    from truthbench.campaign.spec import parse_campaign

    d = spec.to_toml_dict()
    n_el = spec.plant.n_elements
    stations = dict(d["plant"].get("stations", {}))
    quantity = spec.sensors[0].quantity
    sensors = []
    for label in dof_labels:
        node, _, direction = str(label).partition(".")
        if not (node.startswith("n") and node[1:].isdigit()) or direction not in "xyz" \
                or not direction:
            raise ValueError(f"layout DOF {label!r}: expected 'n<node>.<x|y|z>'")
        k = int(node[1:])
        if not 0 <= k <= n_el:
            raise ValueError(f"layout DOF {label!r}: node {k} does not exist (0..{n_el})")
        stations[f"node{k}"] = k / n_el
        sensors.append({"station": f"node{k}", "direction": direction, "quantity": quantity})
    d["plant"]["stations"] = stations
    d["sensors"] = sensors
    for t in d["tests"]:
        t.pop("sensors", None)
    d["campaign"]["name"] = f"{spec.campaign.name}-{name}"
    return parse_campaign(d, source=f"{spec.source} ({name} layout)")


def campaign_dof_labels(spec) -> list[str]:
    """The campaign's own sensors as model DOF labels ``n<node>.<direction>``."""
    plant = spec.make_plant()
    return [f"n{plant.station_node(s.station)}.{s.direction}" for s in spec.sensors]


def score_layouts(spec, layouts: dict, *, trials: int, n_jobs: int = 1):
    """Monte Carlo score of sensor layouts: parameter errors of the primary updater.

    Parameters
    ----------
    spec : CampaignSpec
    layouts : dict of str -> sequence of str
        Layout name -> DOF labels (``n<node>.<direction>``).
    trials, n_jobs : int
        Trials per layout (the same seeds, so the same hardware and noise draws, for
        every layout) and parallel workers.

    Returns
    -------
    pandas.DataFrame
        One row per layout: its sensors, the RMS and mean relative error (%) of every
        update parameter against the trial's truth, and the number of failed trials.
    """
    import pandas as pd

    from truthbench.campaign.runner import run_campaign

    rows = []
    for name, labels in layouts.items():
        result = run_campaign(layout_spec(spec, labels, name), trials=trials, n_jobs=n_jobs)
        ok = [t for t in result.trials if t.error is None and t.update is not None]
        row = {"layout": name, "sensors": " ".join(labels),
               "failed trials": len(result.trials) - len(ok)}
        for p in spec.update.parameters:
            err = np.array([100 * (t.update.as_dict()[p] / t.truth[p] - 1) for t in ok])
            row[f"{p} RMS error [%]"] = float(np.sqrt(np.mean(err**2))) if ok else np.nan
            row[f"{p} mean error [%]"] = float(np.mean(err)) if ok else np.nan
        rows.append(row)
    return pd.DataFrame(rows)
