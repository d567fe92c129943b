"""The identification stage of a campaign: modal parameters of every test.

Each test's H1 FRFs are brought to one type, acceleration-equivalent (each output row
multiplied by ``(j omega)^(2 - k)``, k = 0 for displacement and strain, 1 for velocity,
2 for acceleration), and identified with pLSCF over the test's excited band
(:func:`truthbench.identify_data.identify_frfs`); the shapes come out in displacement
units whatever the type. Accelerance, not receptance: the least-squares residue fit
weighs the lines by the FRF's magnitude, and a receptance is dominated by the
low-frequency suspension modes (their misfit spoiled the elastic shapes, MAC 0.84 for
the third bending mode of the coverage campaign, against 0.9999 with accelerance).
The modes feed sensitivity localization, the uncertainty model and the pole plot.
"""

from __future__ import annotations

import numpy as np

from truthbench.model import QUANTITIES


def acceleration_frf(spec, j: int, record) -> tuple[np.ndarray, np.ndarray]:
    """FRFs of test ``j`` as acceleration-equivalent, 0 Hz dropped.

    Returns
    -------
    freq_hz : ndarray, shape (n_freq,)
    H : ndarray, complex, shape (n_freq, n_out, n_in)
    """
    kinds = ["displacement" if s.quantity == "strain" else s.quantity
             for s in spec.test_sensors(j)]
    keep = record.freq_hz > 0
    f = record.freq_hz[keep]
    jw = 2j * np.pi * f
    q = np.array([QUANTITIES.index(k) for k in kinds])
    return f, record.H[keep] * (jw[:, None] ** (2 - q)[None, :])[:, :, None]


def identify_test(spec, j: int, record, *, max_order: int = 40):
    """Identified modes of test ``j`` (:class:`~truthbench.identify.ModalParameters`),
    shapes over the test's sensors (displacement-equivalent units)."""
    from truthbench.identify_data import FRFData, identify_frfs

    f, H = acceleration_frf(spec, j, record)
    lo, hi = spec.tests[j].band_hz
    lo = max(lo, f[0])
    good = np.all(np.isfinite(H), axis=(1, 2))
    data = FRFData(name=record.name, freq_hz=f[good], H=H[good], frf_type="acceleration",
                   output_labels=record.output_labels, input_labels=record.input_labels,
                   band_hz=(lo, hi))
    return identify_frfs(data, method="plscf", max_order=max_order).modal
