"""The +- of a finding means what it says: the covariance of the fitted values, from the
column-scaled Jacobian with the noise scale from the residual and the window's
correlated lines counted, covers the true values as often as it claims."""

import os
import tomllib

import numpy as np
import pytest

from truthbench.campaign.runner import simulate_one
from truthbench.campaign.spec import parse_campaign
from truthbench.diagnose.candidates import Candidate
from truthbench.diagnose.core import DiagnoseSettings, _Diagnosis
from truthbench.diagnose.fit import (
    correlated_noise,
    covariance,
    fit,
    line_correlation,
    stack,
    with_offsets,
)
from truthbench.effects import EFFECTS, effect_from_inject

from .conftest import ROOT


def test_the_covariance_survives_columns_thirteen_decades_apart():
    """A modulus in Pa next to a mass in kg: formed directly, J' J has a condition of
    about 1e26 and its inverse loses every digit; scaled, the covariance equals the
    exact one of the same problem in scaled units."""
    rng = np.random.default_rng(3)
    A = rng.standard_normal((400, 2))
    scale = np.array([1e-11, 1e2])  # per Pa, per kg
    J = A * scale
    cov = covariance(J, chi2=398.0, n=400)
    exact = np.linalg.inv(A.T @ A) / np.outer(scale, scale)  # s2 = 398 / 398 = 1
    np.testing.assert_allclose(cov, exact, rtol=1e-10)
    # a direction the data do not determine gets no variance, not a huge one
    flat = covariance(np.column_stack([J[:, 0], 2 * J[:, 0]]), chi2=398.0, n=400)
    assert np.all(np.isfinite(flat))


def test_correlated_noise_is_the_sandwich_of_a_dense_circular_covariance():
    """``J'J + X`` (:func:`correlated_noise`) against ``2 J' C J`` with ``C`` the dense
    covariance of the stacked real and imaginary parts of circular noise whose complex
    correlation between values k lines apart is ``c_k`` (built by numpy, element by
    element): ``C = 0.5 [[Re K, -Im K], [Im K, Re K]]``, ``K`` Hermitian Toeplitz per
    channel."""
    rng = np.random.default_rng(7)
    n_lines, stride, p = 40, 3, 3  # 40 lines of 3 channel pairs, interleaved
    N = n_lines * stride
    G = rng.standard_normal((N, p)) + 1j * rng.standard_normal((N, p))
    z = rng.standard_normal(N) + 1j * rng.standard_normal(N)
    base = np.arange(N)
    neighbours = tuple((base[: N - k * stride], base[k * stride:]) for k in (1, 2))
    c = line_correlation(z, neighbours)
    K = np.eye(N, dtype=complex)
    for k, ck in enumerate(c, start=1):
        for i in range(N - k * stride):
            K[i, i + k * stride] = ck
            K[i + k * stride, i] = np.conj(ck)
    C = 0.5 * np.block([[K.real, -K.imag], [K.imag, K.real]])
    J = stack(G)
    exact = 2 * J.T @ C @ J
    got = J.T @ J + correlated_noise(G, z, neighbours)
    scale = np.abs(J).T @ np.abs(J)  # the sums' magnitude: round-off of N terms
    np.testing.assert_allclose(got, exact, rtol=0, atol=1e-13 * N * scale.max())


@pytest.mark.slow
def test_plus_minus_two_sigma_covers_the_true_mass_about_95_percent_of_the_time():
    """120 repeats of one test of the quickstart tube with a 30 g mass at node 15 and
    fresh noise each time (2 % sensor noise, 8 Bartlett averages, 400 lines of 4
    channels): the mass and the declared E fitted with the mass at its node, and
    |fitted - true| <= 2 sigma counted. Nominal coverage 95.4 %; the binomial spread of
    120 repeats is 1.9 %, so 90-98 % is the issue's band (and about 2.5 sigma either
    side). The truth here is the model's own form on purpose: the covariance describes
    noise, and is stated only when the residual is at the noise level."""
    d = tomllib.loads((ROOT / "campaigns" / "quickstart.toml").read_text())
    d["tests"] = [dict(d["tests"][0], record_s=8.0, averages=8)]
    d["update"]["parameters"] = ["E_pa"]
    d["truth"]["relative"] = {"E_pa": 0.04}  # the model's form: only E and the mass wrong
    spec = parse_campaign(d)
    truth_E = spec.truth_parameters()["E_pa"]
    extra = [effect_from_inject("added_mass:station=n15,mass_kg=0.03")]
    spec = spec.model_copy(update={"plant": spec.plant.model_copy(update={
        "stations": {"n15": 0.75}})})
    cand = Candidate("added_mass", {"station": "n15"}, "added_mass@n15",
                     EFFECTS["added_mass"].diagnosis.fitted, 15)
    hits = {"mass": 0, "E": 0}
    repeats = int(os.environ.get("TB_REPEATS", 120))
    for k in range(repeats):
        frf = simulate_one(spec, k, 0, 1000 + k, extra).frf
        d_ = _Diagnosis([frf], spec.make_plant(), spec.nominal_parameters(), ("E_pa",),
                        DiagnoseSettings())
        problem = d_.problem(d_.placed, d_.tests)
        start = {**problem.theta0(cand.terms()), "E_pa": truth_E,
                 "added_mass@n15.mass_kg": 0.03}
        first = fit(problem, cand.terms(), start=start)
        problem = with_offsets(problem, first)
        final = fit(problem, first.terms, start=first.theta)
        sd = final.std
        hits["mass"] += abs(final.theta["added_mass@n15.mass_kg"] - 0.03) <= \
            2 * sd["added_mass@n15.mass_kg"]
        hits["E"] += abs(final.theta["E_pa"] - truth_E) <= 2 * sd["E_pa"]
    for name, count in hits.items():
        assert 0.90 <= count / repeats <= 0.98, (name, count)
