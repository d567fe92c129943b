"""The identification stage of a campaign: modal parameters of every test.

Each test's H1 FRFs (``record.frf``) are brought to one type, acceleration-equivalent
(each output row multiplied by ``(j omega)^(2 - k)``, k = 0 for displacement and strain,
1 for velocity, 2 for acceleration: :meth:`~truthbench.measure.FRFData.as_quantity`),
the 0 Hz line and lines with non-finite values are dropped, and the result is identified
with pLSCF over the test's excited band, its low edge raised to the first remaining line
(:func:`truthbench.identify.identify_frfs`); the shapes come out in displacement units
whatever the type. Accelerance, not receptance: the least-squares residue fit weighs the
lines by the FRF's magnitude, and a receptance is dominated by the low-frequency
suspension modes (their misfit spoiled the elastic shapes, MAC 0.84 for the third
bending mode of the coverage campaign, against 0.9999 with accelerance). The modes feed
sensitivity localization, the uncertainty model and the pole plot.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np


def acceleration_frf(record):
    """The FRFs of ``record`` as acceleration-equivalent, 0 Hz dropped.

    Returns
    -------
    FRFData
        ``record.frf`` with every output converted to acceleration, at the lines above
        0 Hz (``freq_hz`` (n_freq,), ``H`` complex (n_freq, n_out, n_in)).
    """
    frf = record.frf
    return frf.lines(frf.freq_hz > 0).as_quantity("acceleration")


def identify_test(test, record, *, max_order: int | None = None):
    """Identified modes of ``record``, the data of ``test`` (a
    :class:`~truthbench.campaign.plan.TestPlan`), over its excited band
    (:class:`~truthbench.identify.ModalParameters`, shapes over the test's sensors in
    displacement-equivalent units); ``max_order`` None: the identifier's default."""
    from truthbench.identify import identify_frfs

    data = acceleration_frf(record)
    lo, hi = test.band_hz
    lo = max(lo, data.freq_hz[0])
    good = np.all(np.isfinite(data.H), axis=(1, 2))
    data = replace(data.lines(good), band_hz=(lo, hi))
    return identify_frfs(data, method="plscf", max_order=max_order).modal
