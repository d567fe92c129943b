"""Accuracy of a model against the known truth: modes at the sensors, paired by MAC.

The truth is the hardware of the trial's first test (its plant, mesh, element physics,
parameters and structural additions); the model is the campaign's plant at given
parameters. Both are solved, their shapes read at the campaign's sensors as
displacements, paired by MAC and frequency (:func:`truthbench.identify.pair_modes`),
and compared inside the update band.
"""

from __future__ import annotations

import numpy as np

from truthbench.plants import Sensor


def _modal_at_sensors(model, sensors, band_hz, n_modes):
    from truthbench.identify import ModalParameters
    from truthbench.model import modal_table

    modes = model.modes(min(n_modes, model.n_dofs))
    rows = modal_table(model, modes)
    f = np.array([r["freq_hz"] for r in rows])
    z = np.array([r["damping_ratio"] for r in rows])
    at_sensors = model.C_out @ modes.shapes
    norms = np.linalg.norm(at_sensors, axis=0)
    seen = norms > 1e-6 * norms.max()  # modes the sensors cannot see are left out
    keep = (f >= band_hz[0]) & (f <= band_hz[1]) & ~modes.rigid & seen
    shapes = at_sensors[:, keep]
    return ModalParameters(f[keep], np.nan_to_num(z[keep]), shapes,
                           output_labels=tuple(s.label for s in sensors))


def modal_accuracy(spec, setup, params: dict, *, n_modes: int = 30) -> dict:
    """Frequency, damping and MAC errors of the model at ``params`` against the truth
    ``setup`` (:class:`~truthbench.effects.TestSetup`), over the update band.

    Returns
    -------
    dict
        ``freq_error_pct`` (n_pairs,), ``damping_error_pct`` (n_pairs,), ``mac``
        (n_pairs,), ``truth_freq_hz`` (n_pairs,), ``n_unpaired_truth`` (int).
    """
    from truthbench.identify import pair_modes

    sensors = [Sensor(s.station, s.direction, "displacement") if s.quantity != "strain"
               else Sensor(s.station, s.direction, "strain") for s in spec.sensors]
    band = spec.update.band_hz or (min(t.band_hz[0] for t in spec.tests),
                                   max(t.band_hz[1] for t in spec.tests))
    truth = setup.plant.build(setup.parameters, [], sensors, setup.additions)
    model = spec.make_plant().build(params, [], sensors)
    mt = _modal_at_sensors(truth, sensors, band, n_modes)
    mm = _modal_at_sensors(model, sensors, band, n_modes)
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
