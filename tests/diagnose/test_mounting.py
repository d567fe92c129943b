"""The mounting modelled in the comparison, against the mounting effects of a truth and
against a direct least-squares fit.

The columns come from the model's rotation and transverse channels
(:func:`~truthbench.diagnose.mounting.mounting_columns`); a truth's mounting effects
act on the channel maps instead (:mod:`truthbench.effects.mounting`). For a round tube
the two must agree exactly: a mounted sensor and shaker add ``e_s e_a cos(a)`` times
the rotation column and ``c sin(a)`` times the transverse one, and scale the ideal FRF
by ``cos(a)``."""

import types

import numpy as np
import pytest

from truthbench.diagnose.fit import ExtraModes, mode_basis
from truthbench.diagnose.mounting import mounting_columns
from truthbench.effects.base import parse_effect
from truthbench.plants import make_plant
from truthbench.plants.base import Actuator, Sensor
from truthbench.update.predictor import EffectTerm, FRFPredictor, PredictedTest

PLANT = make_plant("free_free_beam", n_elements=8)
NOMINAL = PLANT.resolve({"modal_damping_ratio": 0.01, "suspension_stiffness_n_m": 200.0})
FREQ = np.linspace(0.5, 1200.0, 600)  # the roll, lateral modes and the first torsion


def _term(label, entry):
    return EffectTerm(label, parse_effect(entry, "test"))


@pytest.mark.parametrize("direction", ["z", "y"])
def test_the_columns_are_what_a_mounted_sensor_and_shaker_add(direction):
    """Sensors and a shaker in one transverse direction, each mounted with its own offset
    and cross-axis sensitivity or misalignment, on the tube with a mass on it: the
    mounted FRF is ``cos(a)`` times the ideal one plus ``e_s e_a cos(a)`` times the
    rotation column and ``c sin(a)`` times the transverse one, to round-off (the sum of
    modal terms of the same model)."""
    sensors = (Sensor("quarter", direction), Sensor("mid", direction),
               Sensor("end_b", direction, "displacement"))
    shaker = Actuator("end_a", direction)
    test = PredictedTest("t", FREQ, (shaker,), sensors, decay_rad_s=1.5)
    mass = _term("m", {"name": "added_mass", "station": "mid",
                       "parameters": {"mass_kg": 0.05}})
    e_s, c = (0.003, -0.002, 0.004), (0.02, -0.01, 0.03)
    e_a, a = -0.0025, np.deg2rad(2.0)
    mounts = [_term(f"s{k}", {"name": "sensor_mounting", "sensor": k,
                              "parameters": {"offset_m": e_s[k], "cross_axis": c[k]}})
              for k in range(3)]
    mounts.append(_term("a", {"name": "shaker_mounting", "actuator": 0,
                              "parameters": {"offset_m": e_a,
                                             "misalignment_deg": np.rad2deg(a)}}))
    ideal = FRFPredictor(PLANT, NOMINAL, (test,), (mass,))
    theta = ideal.theta0
    (H0,) = ideal.predict(theta)
    (H,) = FRFPredictor(PLANT, NOMINAL, (test,), (mass, *mounts)).predict(theta)
    (cols,) = mounting_columns(ideal, theta, paths=("rotation", "across"))
    assert cols.shape == H0.shape + (2,)
    k = (np.array(e_s) * e_a * np.cos(a))[None, :, None]
    l_ = (np.array(c) * np.sin(a))[None, :, None]
    expected = np.cos(a) * H0 + k * cols[..., 0] + l_ * cols[..., 1]
    # the tolerance: round-off of the modal sums (1e-12 of each line's value) and of the
    # eigensolution, which a channel set of another plane solves on other blocks: an
    # eigenvalue is exact to about eps times the largest, which moves a line's FRF by
    # that over |s|^2 at most (near the roll's and suspension's modes at a few Hz)
    lam_max = ideal.hardware(theta).model.modes().omega_rad_s.max() ** 2
    s2 = np.abs(2j * np.pi * FREQ + 1.5) ** 2
    rel = 1e-12 + np.finfo(float).eps * lam_max / s2
    assert np.all(np.abs(H - expected) <= rel[:, None, None] * np.abs(H).max(axis=0))
    # both paths carry signal: the roll and torsion, and the lateral modes
    for path in range(2):
        assert np.all(np.abs(cols[..., path]).max(axis=0) > 0)


def test_a_strain_or_rotation_channel_has_no_mounting_path():
    sensors = (Sensor("mid", "z", "strain"), Sensor("mid", "rx"), Sensor("mid", "z"))
    test = PredictedTest("t", FREQ[:50], (Actuator("end_a", "z"),), sensors)
    (cols,) = mounting_columns(FRFPredictor(PLANT, NOMINAL, (test,)), {})
    assert cols.shape == (50, 3, 1, 1)
    assert np.all(cols[:, :2] == 0)
    assert np.all(np.abs(cols[:, 2]).max(axis=0) > 0)


def _problem(rng):
    tests = tuple(types.SimpleNamespace(
        freq_hz=np.linspace(0.5, 400.0, n), decay_rad_s=decay,
        sensors=(types.SimpleNamespace(quantity="acceleration"),
                 types.SimpleNamespace(quantity="displacement")),
        actuators=("a", "b")) for n, decay in ((401, 0.0), (200, 3.0)))
    size = sum(t.freq_hz.size * 4 for t in tests)
    return tests, rng.uniform(0.5, 2.0, size), (rng.standard_normal(size)
                                                + 1j * rng.standard_normal(size))


def test_elimination_is_the_least_squares_fit_of_residues_and_real_amplitudes():
    """The residual the comparison keeps equals a direct least-squares fit (numpy's
    ``lstsq`` on real and imaginary parts stacked) of a complex residue per mode and a
    real amplitude per mounting column, for every transfer function; a mounting column
    the modes already span adds nothing."""
    rng = np.random.default_rng(20261127)
    tests, weights, r = _problem(rng)
    poles = ((57.5, 0.01), (250.0, 0.005))
    mounting = []
    for t in tests:
        cols = rng.standard_normal((t.freq_hz.size, 2, 2, 2)) + 1j * rng.standard_normal(
            (t.freq_hz.size, 2, 2, 2))
        s = 2j * np.pi * t.freq_hz + t.decay_rad_s
        cols[:, 1, 0, 1] = (0.3 + 0.7j) * mode_basis(s, 57.5, 0.01, 0)[:, 0]  # in the span
        mounting.append(cols)
    extra = ExtraModes.build(poles, tests, weights, mounting)
    kept = r - extra.project(r)
    start = 0
    powers = {"acceleration": 2, "displacement": 0}
    for t, cols in zip(tests, mounting, strict=True):
        s = 2j * np.pi * t.freq_hz + t.decay_rad_s
        shape = (t.freq_hz.size, 2, 2)
        size = int(np.prod(shape))
        W = weights[start:start + size].reshape(shape)
        R = r[start:start + size].reshape(shape)
        K = kept[start:start + size].reshape(shape)
        start += size
        for o, x in enumerate(t.sensors):
            g = np.column_stack([mode_basis(s, f, z, powers[x.quantity])[:, 0]
                                 for f, z in poles])
            for i in range(2):
                A = W[:, o, i, None] * np.hstack([g, 1j * g, cols[:, o, i]])
                A2 = np.vstack([A.real, A.imag])
                b2 = np.concatenate([R[:, o, i].real, R[:, o, i].imag])
                coef, *_ = np.linalg.lstsq(A2, b2, rcond=None)
                direct = b2 - A2 @ coef
                # two least-squares solutions agree to eps times the condition number
                # of the columns (the span's own column is left out of it)
                cond = np.linalg.cond(A2[:, :-1] if (o, i) == (1, 0) else A2)
                np.testing.assert_allclose(np.concatenate([K[:, o, i].real, K[:, o, i].imag]),
                                           direct, rtol=0, atol=10 * np.finfo(float).eps
                                           * cond * np.abs(b2).max())
    # the projection is idempotent and leaves an orthogonal residual
    np.testing.assert_allclose(extra.project(kept), 0, atol=1e-12 * np.abs(r).max())
    # a complex residue is two real amplitudes: the modes alone match the complex fit
    alone = ExtraModes.build(poles, tests, weights)
    assert alone.bases[0].shape[-1] == 4 and not alone.mounted
