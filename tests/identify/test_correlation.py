"""MAC, COMAC, shape error and mode pairing against hand computations."""

from __future__ import annotations

import numpy as np
import pytest

from truthbench.identify import (
    ModalParameters,
    auto_mac,
    comac,
    mac,
    modal_scale_factor,
    pair_modes,
    shape_error,
)


def test_mac_of_scaled_copies_is_one_and_of_orthogonal_vectors_zero():
    a = np.array([1.0, -2.0, 0.5, 3.0])
    assert mac(a, -3.7 * a)[0, 0] == pytest.approx(1.0, abs=1e-15)
    b = np.array([2.0, 1.0, 0.0, 0.0])  # a . b = 0
    assert mac(a, b)[0, 0] == pytest.approx(0.0, abs=1e-15)
    # complex (Hermitian) form: any complex scale factor leaves it at one
    c = a + 1j * np.array([0.3, 0.1, -1.0, 0.2])
    assert mac(c, (2 - 5j) * c)[0, 0] == pytest.approx(1.0, abs=1e-14)
    # hand value: (a.b)^2 / (a.a b.b)
    d = np.array([1.0, 0.0, 1.0, 1.0])
    assert mac(a, d)[0, 0] == pytest.approx(4.5**2 / (14.25 * 3.0))
    # Hermitian hand value for complex vectors
    u, v = np.array([1.0, 1j]), np.array([1.0, 1.0])
    assert mac(u, v)[0, 0] == pytest.approx(abs(1 + (-1j)) ** 2 / (2 * 2))
    assert mac(np.zeros(4), a)[0, 0] == 0.0


def test_auto_mac_of_mass_orthogonal_shapes_is_identity_for_identity_mass():
    q, _ = np.linalg.qr(np.random.default_rng(1).standard_normal((6, 4)))
    np.testing.assert_allclose(auto_mac(q), np.eye(4), atol=1e-14)
    assert auto_mac(q).shape == (4, 4)


def test_comac_against_hand_computation():
    phi = np.array([[1.0, 2.0], [0.5, -1.0], [0.0, 1.0]])
    phit = np.array([[1.1, 1.8], [0.4, -1.2], [0.1, 0.7]])
    expected = np.array(
        [
            (1.0 * 1.1 + 2.0 * 1.8) ** 2 / ((1 + 4) * (1.21 + 3.24)),
            (0.5 * 0.4 + 1.0 * 1.2) ** 2 / ((0.25 + 1) * (0.16 + 1.44)),
            (0.0 * 0.1 + 1.0 * 0.7) ** 2 / ((0 + 1) * (0.01 + 0.49)),
        ]
    )
    np.testing.assert_allclose(comac(phi, phit, align=False), expected, rtol=1e-14)
    # a flipped test shape: aligned COMAC is unchanged, the raw formula is not
    flipped = phit * np.array([1.0, -1.0])
    np.testing.assert_allclose(comac(phi, flipped, align=True), comac(phi, phit, align=True))
    assert not np.allclose(comac(phi, flipped, align=False), expected)
    np.testing.assert_allclose(comac(phi, 3 * phi), np.ones(3))


def test_shape_error_after_modal_scale_factor():
    phi = np.array([[1.0, 0.0], [2.0, 1.0], [3.0, -1.0]])
    phit = np.array([[-2.0, 0.0], [-4.0, 2.0], [-6.0, -2.0]])  # -2x and 2x the model
    np.testing.assert_allclose(modal_scale_factor(phi, phit), [-0.5, 0.5])
    np.testing.assert_allclose(shape_error(phi, phit), [0.0, 0.0], atol=1e-15)
    # hand value: model [1, 0], test [1, 1]: MSF = 1/2, residual [1/2, -1/2]
    e = shape_error(np.array([1.0, 0.0]), np.array([1.0, 1.0]))
    assert e[0] == pytest.approx(0.5)
    er = shape_error(np.array([1.0, 0.0]), np.array([1.0, 1.0]), relative=True)
    assert er[0] == pytest.approx(1 - mac([1.0, 0.0], [1.0, 1.0])[0, 0])


def _model():
    q, _ = np.linalg.qr(np.random.default_rng(7).standard_normal((8, 5)))
    return ModalParameters(
        freq_hz=np.array([5.0, 12.0, 20.0, 31.0, 45.0]),
        damping_ratio=np.full(5, 0.01),
        shapes=q,
        output_labels=[f"n{k}" for k in range(8)],
    )


def test_pairing_survives_swapped_order_missing_and_spurious_modes():
    model = _model()
    rng = np.random.default_rng(3)
    # test: modes 3, 0, 1, 4 of the model (2 missing), perturbed, with sign flips,
    # plus a spurious mode orthogonal-ish to all, at 16 Hz
    order = [3, 0, 1, 4]
    shapes = model.shapes[:, order] * np.array([1, -1, 1, -2]) + 0.02 * rng.standard_normal((8, 4))
    spurious = rng.standard_normal(8)
    spurious -= model.shapes @ (model.shapes.T @ spurious)
    test = ModalParameters(
        freq_hz=np.r_[model.freq_hz[order] * 1.02, 16.0],
        damping_ratio=np.full(5, 0.02),
        shapes=np.column_stack([shapes, spurious]),
    )
    p = pair_modes(model, test)
    assert p.pairs.tolist() == [[0, 1], [1, 2], [3, 0], [4, 3]]
    assert p.unpaired_model.tolist() == [2]
    assert p.unpaired_test.tolist() == [4]
    assert np.all(p.mac > 0.99)
    np.testing.assert_allclose(p.freq_error, 0.02)
    assert not np.any(p.doubtful)
    df = p.to_pandas()
    assert list(df.columns) == ["model_mode", "test_mode", "mac", "freq_error", "doubtful"]


def test_pairing_with_dof_map_labels_and_indices():
    model = _model()
    rows = [6, 1, 3, 0, 7]  # measured DOFs, in the test's own order
    test = ModalParameters(
        freq_hz=model.freq_hz,
        damping_ratio=model.damping_ratio,
        shapes=model.shapes[rows],
        output_labels=["a", "b", "c", "d", "e"],
    )
    by_label = pair_modes(
        model, test, dof_map={"a": "n6", "b": "n1", "c": "n3", "d": "n0", "e": "n7"}
    )
    by_index = pair_modes(model, test, dof_map=rows)
    by_mixed = pair_modes(model, test, dof_map={0: 6, "b": 1, 2: "n3", "d": 0, 4: 7})
    for p in (by_label, by_index, by_mixed):
        assert p.pairs.tolist() == [[k, k] for k in range(5)]
        np.testing.assert_allclose(p.mac, 1.0)


def test_doubtful_pairs():
    # two test shapes nearly equal: the second candidate makes the pair ambiguous
    model = ModalParameters(
        freq_hz=[10.0, 11.0], damping_ratio=[0.01, 0.01], shapes=np.array([[1.0, 1.0], [0.0, 0.2]])
    )
    test = ModalParameters(
        freq_hz=[10.0, 11.0],
        damping_ratio=[0.01, 0.01],
        shapes=np.array([[1.0, 1.0], [0.05, 0.15]]),
    )
    p = pair_modes(model, test)
    assert p.pairs.shape == (2, 2)
    assert np.all(p.doubtful)
    # a low but admissible MAC is doubtful too
    model2 = ModalParameters(freq_hz=[10.0], damping_ratio=[0.01], shapes=[[1.0], [0.0]])
    test2 = ModalParameters(freq_hz=[10.0], damping_ratio=[0.01], shapes=[[1.0], [0.6]])
    p2 = pair_modes(model2, test2)
    assert 0.6 < p2.mac[0] < 0.9 and p2.doubtful.tolist() == [True]
    # below mac_min: no pair
    p3 = pair_modes(model2, test2, mac_min=0.8)
    assert p3.pairs.shape == (0, 2) and p3.unpaired_test.tolist() == [0]


def test_bad_inputs():
    model = _model()
    with pytest.raises(ValueError, match="same number of DOFs .* got 3 and 4"):
        mac(np.ones((3, 2)), np.ones((4, 2)))
    with pytest.raises(ValueError, match="same shape .* got \\(3, 2\\) and \\(3, 1\\)"):
        comac(np.ones((3, 2)), np.ones((3, 1)))
    small = ModalParameters(freq_hz=[5.0], damping_ratio=[0.01], shapes=np.ones((3, 1)))
    with pytest.raises(ValueError, match="give 'dof_map'"):
        pair_modes(model, small)
    with pytest.raises(ValueError, match="names the test DOF 'x'"):
        pair_modes(model, small, dof_map={"x": 0})
    with pytest.raises(ValueError, match="model DOF index 9, outside \\[0, 7\\]"):
        pair_modes(model, small, dof_map=[9, 1, 2])
    with pytest.raises(ValueError, match="one model DOF per test DOF \\(3\\); got 2"):
        pair_modes(model, small, dof_map=[0, 1])
    with pytest.raises(ValueError, match="maps a DOF twice"):
        pair_modes(model, small, dof_map=[0, 0, 1])
    with pytest.raises(ValueError, match="'mac_min' parameter must lie in"):
        pair_modes(model, model, mac_min=2.0)
    with pytest.raises(ValueError, match="must be ModalParameters"):
        pair_modes(model, model.shapes)
