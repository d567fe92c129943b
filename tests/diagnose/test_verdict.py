"""The verdict's choice between nested explanations."""

from types import SimpleNamespace

import numpy as np
import pytest

from truthbench.diagnose.verdict import TIE, ambiguous, far_pole_hz, parsimonious, ranked


@pytest.mark.parametrize("a, b", [(1e-8, 1e-3), (2.5e-9, 1e-4), (1e-10, 2.1e-5)])
def test_the_far_pole_is_the_upper_real_root(a, b):
    """Against numpy's roots of ``a s^2 + b s + 1``."""
    roots = np.roots([a, b, 1.0])
    assert np.all(np.isreal(roots))
    assert far_pole_hz(a, b) == pytest.approx(np.abs(roots).max() / (2 * np.pi), rel=1e-12)


def test_a_resonance_has_no_far_pole_and_a_first_order_one_is_infinitely_far():
    assert np.isnan(far_pole_hz(1e-8, 1e-5))  # b^2 < 4a: complex poles
    assert far_pole_hz(0.0, 1e-3) == np.inf


def _refit(effect, dbic, **own):
    """A refit of ``effect`` with its own fitted values ``own`` (as the search keys them:
    ``<label>.<name>`` in the fit's theta)."""
    fitted = tuple(SimpleNamespace(name=k) for k in own)
    return SimpleNamespace(
        candidate=SimpleNamespace(effect=effect, label=effect, fitted=fitted, pinned=()),
        fit=SimpleNamespace(theta={f"{effect}.{k}": v for k, v in own.items()}),
        delta_bic=dbic, physical=True)


def _choose(finals, chosen, margin, f_max=1000.0):
    return parsimonious(finals, chosen, margin, f_max)


def test_the_first_order_low_pass_leads_where_the_second_order_pole_is_unresolved():
    """An overdamped fit whose upper pole is 40 times the band's top: the first-order
    fit is stated first, whatever the delta BIC between them; a pole within the band's
    reach or a resonance keeps the second order unless the two are within the margin."""
    w_low, w_far = 2 * np.pi * 786.0, 2 * np.pi * 40_000.0  # poles of the fit
    far = _refit("actuator_resonance", 88322.0, a_s2=1 / (w_low * w_far),
                 b_s=1 / w_low + 1 / w_far)
    first = _refit("actuator_dynamics", 87183.0, tau_s=1 / w_low)
    twin = _refit("sensor_dynamics", 88322.0, a_s2=1 / (w_low * w_far),
                  b_s=1 / w_low + 1 / w_far)
    assert _choose([far, twin, first], far, 10.0) is first
    w_near = 2 * np.pi * 3000.0  # within FAR_POLE (10) times the band's top
    near = _refit("actuator_resonance", 88322.0, a_s2=1 / (w_low * w_near),
                  b_s=1 / w_low + 1 / w_near)
    assert _choose([near, first], near, 10.0) is near
    assert _choose([near, first], near, 2000.0) is first  # within the margin
    assert _choose([far, twin], far, 10.0) is far  # no simpler one refitted


def test_of_explanations_within_the_margin_the_one_with_fewer_parameters_leads():
    """A joint (stiffness loss and damping, the damping held at its bound 0: still two
    parameters of its kind) and a point mass that explain the data within the margin:
    the mass is stated first, the joint stays a runner-up; beyond the margin the better
    fit leads whatever its parameter count."""
    joint = _refit("joint", 9626.0, stiffness_loss=0.8)
    joint.candidate.pinned = (("damping_n_m_s_rad", 0.0),)
    mass = _refit("added_mass", 9551.0, mass_kg=0.07)
    assert _choose([joint, mass], joint, 100.0) is mass
    assert _choose([joint, mass], joint, 50.0) is joint
    assert _choose([joint, mass], mass, 100.0) is mass


def test_fits_tied_to_round_off_are_ranked_by_name_not_by_their_last_bits():
    """A first-order lag in every sensor and one in the only shaker of each test make the
    same FRFs. In study trial 20261125/23 (a delay already in the model) their separate
    fits gave delta BICs 2.9e-6 apart, and the sensor lag was reported: the arithmetic's
    last bits chose. Tied within TIE they rank by name, whichever came out ahead, and the
    other is the runner-up; a real difference, however small against the margin, still
    ranks by delta BIC."""
    lag_a = _refit("actuator_dynamics", 22406.66281801728, tau_s=2e-4)
    lag_s = _refit("sensor_lag", 22406.66282094672, tau_s=2e-4)
    assert lag_s.delta_bic > lag_a.delta_bic
    assert lag_s.delta_bic - lag_a.delta_bic < TIE * lag_a.delta_bic
    joint = _refit("joint", 22407.0, stiffness_loss=0.1, damping_n_m_s_rad=0.0)
    for finals in ([lag_a, lag_s], [lag_s, lag_a]):
        assert ranked(finals) == [lag_a, lag_s]
        assert ambiguous(finals, lag_a, 10.0) == [lag_s]
        # a two-parameter fit within the margin gives way to the tied one-parameter
        # ones: to the first by name, whatever their order or last bits
        assert _choose([joint, *finals], joint, 10.0) is lag_a
    mass = _refit("added_mass", 500.0, mass_kg=0.01)
    spring = _refit("grounded_spring", 500.0 * (1 + 2 * TIE), stiffness_n_m=800.0)
    assert ranked([mass, spring]) == [spring, mass]
    assert ranked([]) == []
