"""Figure 10.2 study: FE free-free beam against the exact Euler-Bernoulli solution.

Oracles written elsewhere: the free-free roots (cos cosh = 1), the
mass normalisation and orthogonality of the exact shapes (checked by quadrature), the
Rayleigh-Ritz bound (FE frequencies are upper bounds that fall on nested meshes) and the
h^4 convergence of the Hermite element.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import quad

from truthbench.identify import mac
from truthbench.studies import DiscretizationStudy, discretization_study
from truthbench.studies.discretization import free_free_roots, free_free_shape

METHOD_ROOTS = [4.73004074486, 7.85320462410, 10.9956078380, 14.1371654913,
                17.2787596574, 20.4203522456]


@pytest.fixture(scope="module")
def study() -> DiscretizationStudy:
    return discretization_study(40)


def test_roots_match_method_table():
    np.testing.assert_allclose(free_free_roots(6), METHOD_ROOTS, rtol=0, atol=2e-10)


def test_exact_shapes_have_unit_mean_square_and_are_orthogonal():
    r1, r2 = free_free_roots(2)
    mean_sq = [quad(lambda x, r=r: free_free_shape(r, x) ** 2, 0, 1, epsabs=1e-13)[0]
               for r in (r1, r2)]
    np.testing.assert_allclose(mean_sq, 1.0, rtol=1e-10)
    cross = quad(lambda x: free_free_shape(r1, x) * free_free_shape(r2, x), 0, 1)[0]
    assert abs(cross) < 1e-10
    # free end: zero moment (phi'') at x = L, by a central second difference
    h = 1e-4
    d2 = (free_free_shape(r1, 1.0) - 2 * free_free_shape(r1, 1 - h)
          + free_free_shape(r1, 1 - 2 * h)) / h**2
    assert abs(d2) < 1e-2 * r1**2


def test_exact_frequencies_of_the_nominal_tube(study):
    # the nominal hub-beam tube: EI about 601 N m^2, rho A about 0.332 kg/m, L = 1.8 m
    p = study.parameters
    EI = p["E_pa"] * np.pi * p["r_m"] ** 3 * p["t_m"]
    rhoA = p["rho_kg_m3"] * 2 * np.pi * p["r_m"] * p["t_m"]
    assert EI == pytest.approx(601, rel=0.01) and rhoA == pytest.approx(0.332, rel=0.01)
    expected = np.array(METHOD_ROOTS[:2]) ** 2 * np.sqrt(EI / (rhoA * 1.8**4)) / (2 * np.pi)
    np.testing.assert_allclose(study.freq_exact_hz, expected, rtol=1e-10)


def test_frequency_error_at_20_elements_below_0p05_percent(study):
    i = list(study.n_elements).index(20)
    assert np.all(np.abs(study.freq_error_pct[i]) < 0.05)


def test_fe_frequencies_are_upper_bounds_falling_on_nested_meshes(study):
    err = study.freq_error_pct
    assert np.all(err > 0)  # consistent mass: Rayleigh-Ritz upper bound
    nested = [1, 2, 4, 8, 16, 32]
    e = err[np.array(nested) - 1]
    assert np.all(np.diff(e, axis=0) < 0)
    # from 4 (mode 1) and 5 (mode 2) elements on the fall is monotone at every count
    assert np.all(np.diff(err[3:, 0]) < 0) and np.all(np.diff(err[4:, 1]) < 0)


def test_h4_convergence(study):
    e10, e20 = study.freq_error_pct[9], study.freq_error_pct[19]
    np.testing.assert_allclose(e10 / e20, 16.0, rtol=0.1)


def test_mode_2_errors_exceed_mode_1_at_every_count(study):
    assert np.all(study.freq_error_pct[:, 1] > study.freq_error_pct[:, 0])
    for err in (study.mac_error, study.shape_error):
        both = np.isfinite(err).all(axis=1)
        assert both.sum() >= 37
        assert np.all(err[both, 1] > err[both, 0])


def test_shape_errors_fall_and_are_undefined_without_enough_nodes(study):
    # mode k needs k + 2 nodes: mode 1 from 2 elements, mode 2 from 3
    assert np.isnan(study.mac_error[0]).all() and np.isnan(study.shape_error[0]).all()
    assert np.isfinite(study.mac_error[1, 0]) and np.isnan(study.mac_error[1, 1])
    assert np.isfinite(study.mac_error[2:]).all()
    for err in (study.mac_error, study.shape_error):
        assert np.all(err[39] < 1e-3 * err[4])  # 5 -> 40 elements


def test_one_minus_mac_agrees_with_identify_mac():
    from truthbench.studies.discretization import _one_minus_mac

    rng = np.random.default_rng(0)
    a = rng.standard_normal(7)
    b = a + 0.05 * rng.standard_normal(7)
    assert _one_minus_mac(a, b) == pytest.approx(1 - mac(a, b)[0, 0], rel=1e-9)


def test_parameters_scale_frequencies_exactly():
    base = discretization_study(6)
    stiff = discretization_study(6, parameters={"E_pa": 4 * 68.9e9})
    np.testing.assert_allclose(stiff.freq_fe_hz, 2 * base.freq_fe_hz, rtol=1e-12)
    np.testing.assert_allclose(stiff.freq_error_pct, base.freq_error_pct, atol=1e-9)


def test_to_pandas_and_plot(study, tmp_path):
    frame = study.to_pandas()
    assert len(frame) == 80
    assert list(frame.columns) == ["n_elements", "mode", "freq_exact_hz", "freq_fe_hz",
                                   "freq_error_pct", "one_minus_mac", "shape_error"]
    row = frame[(frame.n_elements == 20) & (frame["mode"] == 2)].iloc[0]
    assert row.freq_error_pct == pytest.approx(study.freq_error_pct[19, 1])
    fig = study.plot()
    assert len(fig.axes) == 2 and fig.axes[0].get_yscale() == "log"
    assert len(fig.axes[0].lines) == len(study.modes)
    fig.savefig(tmp_path / "d.png")
    assert (tmp_path / "d.png").stat().st_size > 10_000


def test_result_is_read_only(study):
    with pytest.raises(ValueError):
        study.freq_error_pct[0, 0] = 0.0


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"max_elements": 0}, "max_elements must be a positive integer"),
        ({"modes": (0, 1)}, "modes must be flexible mode numbers >= 1"),
        ({"parameters": {"E": 1.0}}, r"unknown tube parameter\(s\) \['E'\]"),
    ],
)
def test_bad_arguments(kwargs, match):
    with pytest.raises(ValueError, match=match):
        discretization_study(**{"max_elements": 3, **kwargs})
