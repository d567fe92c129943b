"""Accuracy of a model against the known truth: modes at the sensors, paired by MAC.

The truth is the hardware of the trial's first test (its plant, mesh, element physics,
parameters and structural additions); the model is the campaign's plant at given
parameters. Both are solved, their shapes read at the campaign's sensors as
displacements, paired by MAC and frequency (:func:`truthbench.identify.pair_modes`),
and compared inside the analysis band (the update band, else the tests' span).
"""

from __future__ import annotations

import numpy as np

from truthbench.plants import Sensor

_MODES_CACHE: dict = {}
_MODES_CACHE_SIZE = 8


def lowest_modes(model, n_modes: int):
    """``model.modes(n_modes)``, remembered by the content of its mass and stiffness
    matrices (the last few of this process): a trial solves the nominal model, and each
    distinct truth, once for its scores and its uncertainty stage, whatever its tests'
    channels and dashpots (the modes depend on ``M`` and ``K`` alone)."""
    key = (n_modes, *(a.tobytes() for m in (model.M, model.K)
                      for a in (m.data, m.indices, m.indptr)))
    modes = _MODES_CACHE.pop(key, None)
    if modes is None:
        modes = model.modes(n_modes)
    _MODES_CACHE[key] = modes  # most recently used last
    while len(_MODES_CACHE) > _MODES_CACHE_SIZE:
        _MODES_CACHE.pop(next(iter(_MODES_CACHE)))
    return modes


def modes_at_sensors(model, sensors, band_hz, n_modes):
    """Elastic modes of ``model`` inside ``band_hz`` that its output rows see, as
    :class:`~truthbench.identify.ModalParameters` with shapes at the outputs: the real
    modes' frequencies and the damping ratios of their complex poles
    (:func:`truthbench.model.complex_modes`, which includes non-proportional
    damping)."""
    from truthbench.identify import ModalParameters
    from truthbench.model import complex_modes

    modes = lowest_modes(model, min(n_modes, model.n_dofs))
    f = modes.freq_hz
    z = complex_modes(model, modes).damping_ratio
    at_sensors = model.C_out @ modes.shapes
    norms = np.linalg.norm(at_sensors, axis=0)
    seen = norms > 1e-6 * norms.max()  # modes the sensors cannot see are left out
    keep = (f >= band_hz[0]) & (f <= band_hz[1]) & ~modes.rigid & seen
    shapes = at_sensors[:, keep]
    return ModalParameters(f[keep], np.nan_to_num(z[keep]), shapes,
                           output_labels=tuple(s.label for s in sensors))


_PLANT_MODES: dict = {}
_PLANT_MODES_SIZE = 16


def plant_modes_at_sensors(plant, params, sensors, band_hz, n_modes, additions=None):
    """:func:`modes_at_sensors` of ``plant.build(params, [], sensors, additions)``,
    remembered by content (the plant's fields, the parameter values, sensors, band,
    mode count and additions) for the last few of this process: a trial reads the
    nominal model at the same sensors for every test's uncertainty pairing, and the first
    test's truth for every updater's accuracy. The same content gives the same object,
    whatever ran before."""
    try:
        key = (repr(plant), tuple(sorted((k, float(v)) for k, v in params.items())),
               tuple(sensors), (float(band_hz[0]), float(band_hz[1])), int(n_modes),
               None if additions is None else (
                   additions.links, additions.element_stiffness_scale, additions.points,
                   None if additions.sag_angles_rad is None
                   else np.asarray(additions.sag_angles_rad, float).tobytes()))
        hash(key)
    except (TypeError, ValueError):
        key = None
    out = None if key is None else _PLANT_MODES.pop(key, None)
    if out is None:
        model = (plant.build(params, [], sensors) if additions is None
                 else plant.build(params, [], sensors, additions))
        out = modes_at_sensors(model, sensors, band_hz, n_modes)
    if key is not None:
        _PLANT_MODES[key] = out  # most recently used last
        while len(_PLANT_MODES) > _PLANT_MODES_SIZE:
            _PLANT_MODES.pop(next(iter(_PLANT_MODES)))
    return out


def displacement_sensors(sensors) -> list[Sensor]:
    """The campaign's sensors read as displacements (strain gauges stay strain)."""
    return [Sensor(s.station, s.direction, "strain" if s.quantity == "strain"
                   else "displacement") for s in sensors]


def modal_accuracy(plan, setup, params: dict, *, n_modes: int = 30) -> dict:
    """Frequency, damping and MAC errors of the campaign's model (``plan``, a
    :class:`~truthbench.campaign.plan.CampaignPlan`) at ``params`` against the truth
    ``setup`` (:class:`~truthbench.effects.Hardware`), over the analysis band (the update
    band, else the tests' span).

    Returns
    -------
    dict
        ``freq_error_pct`` (n_pairs,), ``damping_error_pct`` (n_pairs,), ``mac``
        (n_pairs,), ``truth_freq_hz`` (n_pairs,), ``n_unpaired_truth`` (int).
    """
    from truthbench.identify import pair_modes

    sensors = displacement_sensors(plan.spec.sensors)
    band = plan.analysis_band_hz
    mt = plant_modes_at_sensors(setup.plant, setup.parameters, sensors, band, n_modes,
                                setup.additions)
    mm = plant_modes_at_sensors(plan.plant, params, sensors, band, n_modes)
    pairing = pair_modes(mt, mm, mac_min=0.6)
    pairs = np.asarray(pairing.pairs, dtype=int).reshape(-1, 2)
    ti, mi = pairs[:, 0], pairs[:, 1]
    with np.errstate(divide="ignore", invalid="ignore"):
        zerr = 100 * (mm.damping_ratio[mi] / mt.damping_ratio[ti] - 1)
    return {
        "truth_freq_hz": mt.freq_hz[ti],
        "freq_error_pct": 100 * (mm.freq_hz[mi] / mt.freq_hz[ti] - 1),
        "damping_error_pct": zerr,
        "mac": np.asarray(pairing.mac, dtype=float).reshape(-1),
        "n_unpaired_truth": int(len(pairing.unpaired_model)),
    }
