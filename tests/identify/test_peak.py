"""Peak picking against single- and two-mode FRFs written in closed form."""

from __future__ import annotations

import numpy as np
import pytest

from truthbench.identify import mac, peak_picking


def sdof(f_hz, fn=20.0, zeta=0.02, q=0):
    """q/u = c b / (s^2 + 2 zeta w s + w^2) with c b = 1, times (jw)^q."""
    s = 1j * 2 * np.pi * np.asarray(f_hz)
    w = 2 * np.pi * fn
    return (s**q / (s**2 + 2 * zeta * w * s + w**2))[:, None, None]


@pytest.mark.parametrize("q", [0, 1, 2])
def test_half_power_damping_single_mode_fine_resolution(q):
    f = np.arange(0.0, 60.0, 0.01)  # 80 lines in the half-power band
    frf_type = ["displacement", "velocity", "acceleration"][q]
    res = peak_picking(f, sdof(f, q=q), frf_type=frf_type)
    assert res.modal.n_modes == 1
    assert res.modal.freq_hz[0] == pytest.approx(20.0, rel=1e-4)
    assert res.modal.damping_ratio[0] == pytest.approx(0.02, rel=0.01)
    assert res.damping_half_power[0] == res.modal.damping_ratio[0]


def test_amplification_damping_static_and_mass_line_references():
    fn, zeta = 20.0, 0.02
    q_exact = 1 / (2 * zeta * np.sqrt(1 - zeta**2))  # peak over static value, exactly
    f = np.arange(0.0, 60.0, 0.01)
    res = peak_picking(f, sdof(f, fn, zeta), damping_method="amplification")
    assert res.amplification[0] == pytest.approx(q_exact, rel=1e-3)
    assert res.modal.damping_ratio[0] == pytest.approx(1 / (2 * q_exact), rel=1e-3)
    assert res.modal.damping_ratio[0] == pytest.approx(zeta, rel=1e-3)
    # accelerance of the same mode, no 0 Hz line: the mass line (high-frequency
    # asymptote c b) is the reference; at f_max = 15 fn it is within (fn/f_max)^2.
    f2 = np.arange(5.0, 300.0, 0.01)
    res2 = peak_picking(
        f2,
        sdof(f2, fn, zeta, q=2),
        frf_type="acceleration",
        damping_method="amplification",
        reference="mass_line",
    )
    assert res2.modal.damping_ratio[0] == pytest.approx(zeta, rel=0.01)
    # a user-given static-equivalent value: |H(0)| = 1 / w^2
    res3 = peak_picking(
        f2, sdof(f2, fn, zeta), damping_method="amplification", reference=1 / (2 * np.pi * fn) ** 2
    )
    assert res3.modal.damping_ratio[0] == pytest.approx(zeta, rel=1e-3)


def test_coarse_resolution_overestimates_amplification_damping():
    """The chapter's effect: too few lines in the resonance lower the read peak, so Q drops
    and zeta = 1/(2Q) grows (bias first order in df / B_r for a grid that misses the peak)."""
    fn, zeta = 20.0, 0.02
    errs = []
    for df in (0.01, 0.2, 0.5):
        f = np.arange(0.0, 60.0, df) + 0.37 * df  # the grid misses the peak
        res = peak_picking(
            np.r_[0.0, f], sdof(np.r_[0.0, f], fn, zeta), damping_method="amplification"
        )
        errs.append(res.modal.damping_ratio[0] / zeta - 1)
    assert abs(errs[0]) < 1e-3  # 1/(2Q) = zeta sqrt(1 - zeta^2): -2e-4
    assert errs[0] < errs[1] < errs[2]


def test_shapes_from_the_imaginary_part_two_separated_modes():
    phi = np.array([[1.0, 0.6], [0.5, -1.0], [-0.7, 0.4], [0.2, 0.9]])
    fn = np.array([10.0, 30.0])
    zeta = np.array([0.01, 0.01])
    f = np.arange(0.01, 50.0, 0.01)
    s = 1j * 2 * np.pi * f[:, None, None]
    H = np.zeros((f.size, 4, 1), complex)
    for r in range(2):
        w = 2 * np.pi * fn[r]
        H += np.outer(phi[:, r], phi[0, r])[None] / (s**2 + 2 * zeta[r] * w * s + w**2)
    res = peak_picking(f, H, n_modes=2)
    np.testing.assert_allclose(res.modal.freq_hz, fn, rtol=1e-3)
    np.testing.assert_allclose(res.modal.damping_ratio, zeta, rtol=0.05)
    assert np.all(np.diag(mac(res.modal.shapes, phi)) > 0.999)
    assert res.modal.shapes.dtype == float
    assert np.all(np.max(np.abs(res.modal.shapes), axis=0) == 1.0)
    res_c = peak_picking(f, H, n_modes=2, shape_part="complex", channel=(0, 0))
    assert np.iscomplexobj(res_c.modal.shapes)
    # the complex value also carries the other mode's (real) off-resonance response
    assert np.all(np.diag(mac(res_c.modal.shapes, phi)) > 0.995)
    assert list(res.peak_index) == [int(np.argmin(np.abs(f - x))) for x in res.modal.freq_hz]


def test_bad_inputs_and_warnings():
    f = np.arange(0.0, 60.0, 0.01)
    H = sdof(f)
    with pytest.raises(ValueError, match="'damping_method' parameter must be"):
        peak_picking(f, H, damping_method="circle_fit")
    with pytest.raises(ValueError, match="'channel' parameter must index an FRF of shape"):
        peak_picking(f, H, channel=(2, 0))
    with pytest.raises(ValueError, match="'reference' parameter must be"):
        peak_picking(f, H, reference=-1.0)
    with pytest.raises(ValueError, match="'frf' parameter has 10 frequency lines"):
        peak_picking(f, H[:10])
    with pytest.warns(UserWarning, match="fewer than n_modes=3"):
        peak_picking(f, H, n_modes=3)
    with (
        pytest.raises(ValueError, match="half_power damping is undefined"),
        pytest.warns(UserWarning, match="outside the band"),
    ):
        peak_picking(f, H, freq_range_hz=(19.9, 30.0))
