"""ModalParameters: pole convention, validation, immutability, table export."""

from __future__ import annotations

import numpy as np
import pytest

from truthbench.identify import ModalParameters, modal_from_poles, poles_from_modal


def test_poles_match_the_roots_of_the_characteristic_polynomial():
    f = np.array([3.0, 17.0])
    z = np.array([0.02, 0.3])
    m = ModalParameters(freq_hz=f, damping_ratio=z, shapes=np.eye(2))
    for k in range(2):
        w = 2 * np.pi * f[k]
        roots = np.roots([1.0, 2 * z[k] * w, w**2])
        assert m.poles[k] == pytest.approx(roots[np.argmax(roots.imag)], rel=1e-12)
    f2, z2 = modal_from_poles(m.poles)
    np.testing.assert_allclose(f2, f, rtol=1e-14)
    np.testing.assert_allclose(z2, z, rtol=1e-13)
    np.testing.assert_allclose(poles_from_modal(f, z), m.poles)
    np.testing.assert_allclose(m.omega_rad_s, 2 * np.pi * f)


def test_immutable_copies_select_and_pandas():
    f = np.array([1.0, 2.0, 3.0])
    shapes = np.arange(6.0).reshape(2, 3)
    m = ModalParameters(
        freq_hz=f, damping_ratio=[0.01, 0.02, 0.03], shapes=shapes, participation=np.ones((3, 2))
    )
    f[0] = 99.0
    assert m.freq_hz[0] == 1.0  # a copy, not a view
    with pytest.raises(ValueError):
        m.shapes[0, 0] = 5.0
    with pytest.raises(AttributeError):
        m.freq_hz = f
    sub = m.select([2, 0])
    np.testing.assert_array_equal(sub.freq_hz, [3.0, 1.0])
    np.testing.assert_array_equal(sub.shapes, shapes[:, [2, 0]])
    assert sub.participation.shape == (2, 2)
    df = m.to_pandas()
    assert list(df.columns) == [
        "freq_hz",
        "damping_ratio",
        "omega_rad_s",
        "pole_real_rad_s",
        "pole_imag_rad_s",
    ]
    assert len(df) == 3 and df.index.name == "mode"
    assert m.n_modes == 3 and m.n_out == 2


def test_bad_inputs():
    with pytest.raises(ValueError, match="'damping_ratio' parameter must have shape \\(2,\\)"):
        ModalParameters(freq_hz=[1.0, 2.0], damping_ratio=[0.1], shapes=np.eye(2))
    with pytest.raises(ValueError, match="'shapes' parameter must have shape \\(n_out, 2\\)"):
        ModalParameters(freq_hz=[1.0, 2.0], damping_ratio=[0.1, 0.1], shapes=np.ones((3, 3)))
    with pytest.raises(ValueError, match="'damping_ratio' parameter must lie in \\[0, 1\\)"):
        ModalParameters(freq_hz=[1.0], damping_ratio=[1.2], shapes=[1.0])
    with pytest.raises(ValueError, match="'participation' parameter must have shape \\(1, n_in\\)"):
        ModalParameters(
            freq_hz=[1.0], damping_ratio=[0.1], shapes=[1.0], participation=np.ones((2, 2))
        )
    with pytest.raises(ValueError, match="'output_labels' parameter must hold 2 labels"):
        ModalParameters(
            freq_hz=[1.0], damping_ratio=[0.1], shapes=[[1.0], [2.0]], output_labels=["a"]
        )
