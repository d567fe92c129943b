"""The uncertainty stage of a campaign (Section 10.3, Eq. 10.46-10.50, Figure 10.6;
:ref:`method-uncertainty-model`).

For every test the identified modes are paired (MAC at the test's sensors, frequency
distance) with the initial model's modes inside the analysis band; model modes paired
in every test give the per-test parameter sets ``theta_j = [f_1..f_k, zeta_1..zeta_k]``.
With ``theta_0`` the initial model's values, :func:`truthbench.uncertainty.uncertainty_model`
gives the mean error and the k-sigma bound from the tests that are not held out
(``[uncertainty] holdout``). Each test's TRUE modal parameters (the modes of that test's
hardware, paired the same way) are checked against the bound: for the tests that built
it (in-sample) and for the held-out tests (new draws, the calibration the Monte Carlo
report scores against :func:`truthbench.uncertainty.expected_coverage`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class UncertaintyStage:
    """Per-trial result of the uncertainty stage.

    Attributes
    ----------
    names : tuple of str
        ``f<k>_hz`` then ``zeta<k>`` for the k paired model modes.
    theta_0 : ndarray, shape (p,)
        Initial model values.
    theta_tests : ndarray, shape (T, p)
        Identified values per test.
    theta_truth : ndarray, shape (T, p)
        True values per test (NaN where a true mode did not pair).
    mean, std, bound : ndarray, shape (p,)
        Mean error, standard deviation, 3-sigma bound of Eq. 10.47-10.50.
    inside : ndarray of bool, shape (T, p)
        True values inside ``theta_0 + mean +- bound``.
    holdout : ndarray of bool, shape (T,)
        Tests that did not build the bound.
    mode_index : ndarray of int, shape (k,)
        The paired modes' indices among the initial model's modes in the band.
    theta_updated : ndarray, shape (p,)
        The updated model's values for the same modes (NaN until set, or if unpaired).
    """

    names: tuple[str, ...]
    theta_0: np.ndarray
    theta_tests: np.ndarray
    theta_truth: np.ndarray
    mean: np.ndarray
    std: np.ndarray
    bound: np.ndarray
    inside: np.ndarray
    mode_index: np.ndarray
    holdout: np.ndarray
    theta_updated: np.ndarray | None = None

    @property
    def n_build(self) -> int:
        """Number of tests that built the bound."""
        return int(np.count_nonzero(~self.holdout))


def model_values(plan, params: dict, mode_index) -> np.ndarray:
    """``[f..., zeta...]`` of the campaign's model (``plan``, a
    :class:`~truthbench.campaign.plan.CampaignPlan`) at ``params`` for the initial
    model's modes ``mode_index`` (paired by MAC at the first test's sensors)."""
    from truthbench.campaign.metrics import displacement_sensors, plant_modes_at_sensors

    sensors = displacement_sensors(plan.tests[0].sensors)
    band = plan.uncertainty_band_hz
    ref = plant_modes_at_sensors(plan.plant, plan.nominal, sensors, band, 40)
    other = plant_modes_at_sensors(plan.plant, params, sensors, band, 40)
    k = _pair(ref, other)[mode_index]
    f = np.where(k >= 0, other.freq_hz[k], np.nan)
    z = np.where(k >= 0, other.damping_ratio[k], np.nan)
    return np.concatenate([f, z])


def _pair(reference, other):
    """For each reference mode, the index of its partner in ``other`` or -1."""
    from truthbench.identify import pair_modes

    out = np.full(len(reference.freq_hz), -1)
    if len(other.freq_hz) == 0:
        return out
    pairing = pair_modes(reference, other, mac_min=0.8)
    for a, b in np.asarray(pairing.pairs, dtype=int).reshape(-1, 2):
        out[a] = b
    return out


def uncertainty_stage(plan, records, hardware):
    """The uncertainty model of one trial's tests, or None when fewer than two tests
    identified a common mode (nothing to bound).

    Parameters
    ----------
    plan : CampaignPlan
    records : sequence of TestRecord
        The trial's tests, with their identified modes.
    hardware : sequence of Hardware
        The truth of each test (:func:`~truthbench.campaign.truth.build_hardware`).
    """
    from truthbench.campaign.metrics import displacement_sensors, plant_modes_at_sensors
    from truthbench.identify import ModalParameters
    from truthbench.uncertainty import uncertainty_model

    band = plan.uncertainty_band_hz
    f_t, z_t, f_true, z_true = [], [], [], []
    ref = None
    for test, rec, setup in zip(plan.tests, records, hardware, strict=True):
        sensors = displacement_sensors(test.sensors)
        model = plant_modes_at_sensors(plan.plant, plan.nominal, sensors, band, 40)
        ref = model if ref is None else ref
        ident = rec.modes
        if ident is None:
            return None
        ident = ModalParameters(ident.freq_hz, ident.damping_ratio, ident.shapes)
        k = _pair(model, ident)
        truth = plant_modes_at_sensors(setup.plant, setup.parameters, sensors, band, 60,
                                       setup.additions)
        kt = _pair(model, truth)
        f_t.append(np.where(k >= 0, ident.freq_hz[k], np.nan))
        z_t.append(np.where(k >= 0, ident.damping_ratio[k], np.nan))
        f_true.append(np.where(kt >= 0, truth.freq_hz[kt], np.nan))
        z_true.append(np.where(kt >= 0, truth.damping_ratio[kt], np.nan))
    if len(records) < 2:
        return None
    f_t, z_t = np.array(f_t), np.array(z_t)
    common = np.all(np.isfinite(f_t), axis=0)
    if not common.any():
        return None
    idx = np.flatnonzero(common)
    names = tuple(f"f{i + 1}_hz" for i in idx) + tuple(f"zeta{i + 1}" for i in idx)
    theta_0 = np.concatenate([ref.freq_hz[idx], ref.damping_ratio[idx]])
    tests = np.hstack([f_t[:, idx], z_t[:, idx]])
    truth = np.hstack([np.array(f_true)[:, idx], np.array(z_true)[:, idx]])
    settings = plan.spec.uncertainty
    holdout = np.array([t.name in settings.holdout for t in plan.tests])
    um = uncertainty_model(tests[~holdout], theta_0, names=names, covariance="diagonal",
                           k_sigma=settings.k_sigma)
    inside = um.contains(truth)
    return UncertaintyStage(names, theta_0, tests, truth, np.asarray(um.mean),
                            np.asarray(um.std), np.asarray(um.bound), np.asarray(inside), idx,
                            holdout)
