"""The shared contract over every registered identifier, and the registry itself."""

from __future__ import annotations

import numpy as np
import pytest

from truthbench.identify import (
    IDENTIFIERS,
    ModalParameters,
    PeakIdentifier,
    PLSCFIdentifier,
    get_identifier,
    mac,
    make_identifier,
    register_identifier,
)

# two well separated modes, 4 outputs, 1 input: every identifier must handle this
PHI = np.array([[1.0, 0.6], [0.5, -1.0], [-0.7, 0.4], [0.2, 0.9]])
FN = np.array([10.0, 30.0])
ZETA = np.array([0.01, 0.02])


def frf(q=0):
    f = np.arange(0.05, 50.0, 0.01)
    s = 1j * 2 * np.pi * f[:, None, None]
    H = np.zeros((f.size, 4, 1), complex)
    for r in range(2):
        w = 2 * np.pi * FN[r]
        H += np.outer(PHI[:, r], PHI[0, r])[None] / (s**2 + 2 * ZETA[r] * w * s + w**2)
    return f, H * s**q


@pytest.mark.parametrize("name", sorted(IDENTIFIERS))
@pytest.mark.parametrize("q", [0, 2])
def test_contract(name, q):
    f, H = frf(q)
    H0 = H.copy()
    out = get_identifier(name)(f, H, frf_type=["displacement", "velocity", "acceleration"][q])
    assert isinstance(out, ModalParameters)
    np.testing.assert_array_equal(H, H0)  # the input is untouched
    assert out.shapes.shape == (4, out.n_modes)
    assert out.n_modes == 2
    order = np.argsort(out.freq_hz)
    np.testing.assert_allclose(out.freq_hz[order], FN, rtol=2e-3)
    np.testing.assert_allclose(out.damping_ratio[order], ZETA, rtol=0.05)
    assert np.all(np.diag(mac(out.shapes[:, order], PHI)) > 0.99)


def test_registry_lookup_and_registration():
    with pytest.raises(ValueError,
                       match=r"unknown identifier 'ssi'; expected one of \['peak', 'plscf'\]"):
        get_identifier("ssi")
    with pytest.raises(ValueError, match="already registered"):
        register_identifier(PeakIdentifier)
    with pytest.raises(ValueError, match="non-empty string 'name'"):
        register_identifier(int)
    with pytest.raises(TypeError):
        IDENTIFIERS["x"] = None  # read-only view


def test_identifiers_are_configured_by_their_declared_settings():
    """make_identifier takes the settings an identifier declares (ignores the others,
    None meaning its default) and checks them by the declaration."""
    assert make_identifier("plscf", {"max_order": 12, "n_modes": 3}) == PLSCFIdentifier(
        max_order=12)
    assert make_identifier("peak", {"max_order": 12, "n_modes": None}) == PeakIdentifier()
    assert get_identifier("plscf").max_order == PLSCFIdentifier().max_order
    with pytest.raises(ValueError, match="PLSCFIdentifier: 'max_order' must be an integer "
                                         ">= 2 and <= 200; got 1"):
        make_identifier("plscf", {"max_order": 1})
    with pytest.raises(ValueError, match="'n_modes' must be an integer >= 1; got 0"):
        PeakIdentifier(n_modes=0)
    with pytest.raises(TypeError):
        PLSCFIdentifier(40)  # settings are keyword-only
