"""pLSCF + automatic selection + LSFD against FRFs synthesised from known modal models."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from truthbench.errors import IdentifiabilityError
from truthbench.identify import (
    StabilityCriteria,
    identify_plscf,
    lsfd,
    mac,
    plscf_stabilization,
    refine_poles,
    select_poles,
)


def _match(est_freq, true_freq):
    """Index of the estimated mode nearest each true frequency (must be one-to-one)."""
    idx = np.array([np.argmin(np.abs(est_freq - f)) for f in true_freq])
    assert np.unique(idx).size == idx.size, (est_freq, true_freq)
    return idx


@pytest.mark.parametrize(
    ("n_in", "q", "max_order"),
    [(1, 0, 40), (2, 0, 24), (2, 1, 24), (2, 2, 24), (1, 2, 40)],
)
def test_noise_free_recovers_the_modal_model(synthetic, n_in, q, max_order):
    syn = synthetic(n_in=n_in, q=q)
    frf_type = ["displacement", "velocity", "acceleration"][q]
    res = identify_plscf(syn.freq_hz, syn.frf, max_order=max_order, frf_type=frf_type)
    m = res.modal
    assert m.n_modes == syn.freq_true.size
    np.testing.assert_allclose(m.freq_hz, syn.freq_true, rtol=1e-4)
    np.testing.assert_allclose(m.damping_ratio, syn.zeta_true, rtol=1e-2)
    assert np.all(np.diag(mac(m.shapes, syn.shapes_true)) >= 0.999)
    # LSFD residues of the supplied FRF type reproduce the true ones
    D = res.lsfd.displacement_residues()
    np.testing.assert_allclose(D, syn.residues_true, rtol=1e-4, atol=1e-6 * np.abs(D).max())
    # and the fitted model reproduces the data
    H_fit = res.lsfd.reconstruct(syn.freq_hz)
    assert np.linalg.norm(H_fit - syn.frf) <= 1e-6 * np.linalg.norm(syn.frf)
    # participation x shape gives the residues (rank one per mode)
    approx = np.einsum("or,ri->roi", m.shapes, m.participation)
    np.testing.assert_allclose(approx, D, atol=1e-6 * np.abs(D).max())


def test_modes_outside_the_band_are_absorbed_by_residual_terms(synthetic):
    # a mode at 3 Hz and one at 120 Hz, band 6..80 Hz
    f_true = np.r_[3.0, syn_f := np.array([10.0, 25.0, 25.25, 40.0, 60.0]), 120.0]
    z_true = np.r_[0.01, 0.01, 0.005, 0.008, 0.05, 0.01, 0.01]
    syn = synthetic(freq_true=f_true, zeta_true=z_true, gain=np.r_[1, 1, 1, 1, 0.5, 1, 1])
    res = identify_plscf(syn.freq_hz, syn.frf, max_order=30, freq_range_hz=(6.0, 80.0))
    m = res.modal
    assert m.n_modes == syn_f.size
    np.testing.assert_allclose(m.freq_hz, syn_f, rtol=1e-4)
    np.testing.assert_allclose(m.damping_ratio, z_true[1:-1], rtol=1e-2)
    assert np.all(np.diag(mac(m.shapes, syn.shapes_true[:, 1:-1])) >= 0.999)
    assert res.lsfd.lower_residual is not None and res.lsfd.upper_residual is not None


def test_lsfd_with_true_poles_is_exact(synthetic):
    syn = synthetic(n_in=2, q=2)
    fit = lsfd(syn.freq_hz, syn.frf, syn.poles_true, frf_type="acceleration")
    np.testing.assert_allclose(
        fit.residues, syn.residues_true * (syn.poles_true**2)[:, None, None], rtol=1e-8
    )
    np.testing.assert_allclose(fit.displacement_residues(), syn.residues_true, rtol=1e-8)
    assert np.max(np.abs(fit.lower_residual)) < 1e-8 * np.abs(syn.frf).max()


def test_stabilization_diagram_structure_and_plot(synthetic, tmp_path):
    syn = synthetic(n_in=2)
    d = plscf_stabilization(syn.freq_hz, syn.frf, 20, min_order=2)
    assert list(d.orders) == list(range(2, 21))
    for k, n in enumerate(d.orders):
        assert d.poles[k].size <= n * 2 // 2  # n * n_in poles: at most n conjugate pairs
        assert d.participation[k].shape == (d.poles[k].size, 2)
        assert d.stable_freq[k].shape == d.poles[k].shape
        assert not np.any(d.stable[k] & ~d.stable_freq[k])
    assert not np.any(d.stable_freq[0])  # the first order has nothing to compare with
    with pytest.raises(ValueError):
        d.poles[0][0] = 0  # results are read-only
    df = d.to_pandas()
    assert {"order", "freq_hz", "damping_ratio", "stable", "physical"} <= set(df.columns)
    assert len(df) == sum(p.size for p in d.poles)
    # every true mode is stable at the highest order
    last = d.to_pandas().query("order == 20 and stable")
    for f in syn.freq_true:
        assert np.min(np.abs(last.freq_hz - f)) < 1e-4 * f
    import matplotlib.pyplot as plt

    sel = select_poles(d)
    fig = d.plot(freq_hz=syn.freq_hz, frf=syn.frf)
    assert fig.axes[0].get_xlabel() == "frequency (Hz)"
    fig.savefig(tmp_path / "stab.png")
    plt.close(fig)
    assert sel.poles.size == syn.freq_true.size
    assert np.all(sel.n_members >= 0.4 * d.orders.size)


@pytest.mark.slow
def test_noisy_bias_and_scatter_over_seeds(synthetic, record_property):
    """Additive complex noise, std = eps * RMS of each FRF over the band, 20 seeds.

    Recorded (``record_property``, and printed with ``-s``): relative bias (mean) and
    scatter (std) of frequency and damping per mode, and the worst MAC. Setting: 2 inputs,
    6 outputs, 1600 lines (df = 0.05 Hz), max order 24. The linearised (equation-error)
    pLSCF is biased under noise (the noise power enters T and pulls poles toward the
    unstable side of the z-domain basis, i.e. lower damping), so the bounds are on
    |bias| + 3 std:

    * frequency < 1e-3 relative: 1/10 of the narrowest half-power bandwidth
      (2 zeta = 0.01) and 1/5 of the line spacing at 10 Hz; observed <= 6e-4 at 5 %;
    * damping < 12 % (2 % noise) and < 25 % (5 % noise) relative: the bias grows about
      linearly with eps; observed <= 4 % and <= 9 %;
    * MAC >= 0.99 (observed >= 0.999).

    :func:`test_refinement_removes_the_noise_bias` shows the bias is the estimator's, not
    the data's.
    """
    lines = []
    for eps in (0.02, 0.05):
        fe, ze, macs = [], [], []
        for seed in range(20):
            syn = synthetic(n_in=2, noise=eps, seed=seed)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                m = identify_plscf(syn.freq_hz, syn.frf, max_order=24).modal
            idx = _match(m.freq_hz, syn.freq_true)
            fe.append(m.freq_hz[idx] / syn.freq_true - 1)
            ze.append(m.damping_ratio[idx] / syn.zeta_true - 1)
            macs.append(np.diag(mac(m.shapes[:, idx], syn.shapes_true)))
        fe, ze, macs = np.array(fe), np.array(ze), np.array(macs)
        for name, v in (("freq", fe), ("zeta", ze)):
            record_property(f"eps{eps}_{name}_bias", v.mean(0).tolist())
            record_property(f"eps{eps}_{name}_std", v.std(0).tolist())
            lines.append(
                f"eps={eps:.2f} {name}: bias {np.array2string(v.mean(0), precision=5)} "
                f"std {np.array2string(v.std(0), precision=5)}"
            )
        record_property(f"eps{eps}_mac_min", macs.min(0).tolist())
        lines.append(f"eps={eps:.2f} MAC min {np.array2string(macs.min(0), precision=5)}")
        assert np.all(np.abs(fe.mean(0)) + 3 * fe.std(0) < 1e-3)
        z_bound = 0.25 if eps > 0.03 else 0.12
        assert np.all(np.abs(ze.mean(0)) + 3 * ze.std(0) < z_bound)
        assert np.all(macs >= 0.99)
    print("\n".join(lines))


@pytest.mark.slow
def test_refinement_removes_the_noise_bias(synthetic, record_property):
    """Output-error refinement (ML for this noise) at eps = 5 %, 10 seeds.

    Expected unbiased: |bias| below 3 standard errors (3 std / sqrt(10)) plus a small
    floor; and the scatter no larger than the pLSCF scatter measured above (< 1e-4 in
    frequency, < 1 % relative in damping; the 5 % mode scatters 1e-4 in frequency).
    """
    fe, ze = [], []
    for seed in range(10):
        syn = synthetic(n_in=2, noise=0.05, seed=seed)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            m = identify_plscf(syn.freq_hz, syn.frf, max_order=24, refine=True).modal
        idx = _match(m.freq_hz, syn.freq_true)
        fe.append(m.freq_hz[idx] / syn.freq_true - 1)
        ze.append(m.damping_ratio[idx] / syn.zeta_true - 1)
    fe, ze = np.array(fe), np.array(ze)
    for name, v in (("freq", fe), ("zeta", ze)):
        record_property(f"refined_eps0.05_{name}_bias", v.mean(0).tolist())
        record_property(f"refined_eps0.05_{name}_std", v.std(0).tolist())
    print(
        f"refined eps=0.05 freq bias {np.array2string(fe.mean(0), precision=7)} "
        f"std {np.array2string(fe.std(0), precision=7)}\n"
        f"refined eps=0.05 zeta bias {np.array2string(ze.mean(0), precision=5)} "
        f"std {np.array2string(ze.std(0), precision=5)}"
    )
    assert np.all(np.abs(fe.mean(0)) < 3 * fe.std(0) / np.sqrt(10) + 1e-6)
    assert np.all(np.abs(ze.mean(0)) < 3 * ze.std(0) / np.sqrt(10) + 1e-3)
    assert np.all(fe.std(0) < 3e-4) and np.all(ze.std(0) < 0.01)


def test_refine_poles_converges_to_the_true_poles_on_exact_data(synthetic):
    syn = synthetic(n_in=2, q=1)
    wn, z = np.abs(syn.poles_true), -syn.poles_true.real / np.abs(syn.poles_true)
    start = -(z * 1.1) * (wn * 1.002) + 1j * (wn * 1.002) * np.sqrt(1 - (z * 1.1) ** 2)
    fit = refine_poles(syn.freq_hz, syn.frf, start, frf_type="velocity")
    np.testing.assert_allclose(fit.poles, syn.poles_true, rtol=1e-9)
    np.testing.assert_allclose(fit.displacement_residues(), syn.residues_true, rtol=1e-6)
    with pytest.raises(ValueError, match="0 < zeta < 1"):
        refine_poles(syn.freq_hz, syn.frf, [10j])


def test_selection_is_empty_with_a_warning_when_nothing_stabilizes(synthetic):
    syn = synthetic(n_in=1)
    crit = StabilityCriteria(freq_tol=1e-15, damping_tol=1e-15)
    with pytest.warns(UserWarning, match="no pole is stable"):
        res = identify_plscf(syn.freq_hz, syn.frf, max_order=8, criteria=crit)
    assert res.modal.n_modes == 0
    assert res.modal.shapes.shape == (syn.frf.shape[1], 0)


def test_inputs_are_not_modified(synthetic):
    syn = synthetic(n_in=1)
    f0, H0 = syn.freq_hz.copy(), syn.frf.copy()
    identify_plscf(syn.freq_hz, syn.frf, max_order=20)
    np.testing.assert_array_equal(syn.freq_hz, f0)
    np.testing.assert_array_equal(syn.frf, H0)


def test_bad_inputs(synthetic):
    syn = synthetic(n_in=2)
    with pytest.raises(ValueError, match="has 1599 frequency lines .* 'freq_hz' has 1600"):
        identify_plscf(syn.freq_hz, syn.frf[:-1])
    with pytest.raises(ValueError, match="shape \\(n_freq, n_out, n_in\\)"):
        identify_plscf(syn.freq_hz, syn.frf[:, :, 0])
    with pytest.raises(ValueError, match="strictly increasing"):
        identify_plscf(syn.freq_hz[::-1], syn.frf)
    with pytest.raises(IdentifiabilityError, match="fewer than the .* real unknowns"):
        lsfd(syn.freq_hz[:4], syn.frf[:4], syn.poles_true)
    with pytest.raises(IdentifiabilityError, match="max_order=30 has"):
        identify_plscf(syn.freq_hz[:20], syn.frf[:20], max_order=30)
    with pytest.raises(ValueError, match="'max_order' parameter must be an integer >= 1"):
        identify_plscf(syn.freq_hz, syn.frf, max_order=0)
    with pytest.raises(ValueError, match="'frf_type' parameter must be one of"):
        identify_plscf(syn.freq_hz, syn.frf, max_order=10, frf_type="strain")
    with pytest.raises(ValueError, match="'freq_range_hz' parameter must satisfy low < high"):
        identify_plscf(syn.freq_hz, syn.frf, freq_range_hz=(50.0, 10.0))
    with pytest.raises(ValueError, match="'min_fraction' parameter"):
        select_poles(plscf_stabilization(syn.freq_hz, syn.frf, 4), min_fraction=0.0)
    with pytest.raises(ValueError, match="'mac_min' parameter must lie in"):
        StabilityCriteria(mac_min=1.5)
    with pytest.raises(ValueError, match="'output_weighting'"):
        plscf_stabilization(syn.freq_hz, syn.frf, 4, output_weighting="max")


def test_gap_split_clustering_equals_plain_average_linkage():
    """The memory-saving split at frequency gaps gives scipy's plain clustering."""
    from scipy.cluster.hierarchy import fcluster, linkage

    from truthbench.identify.plscf import _average_linkage_labels

    rng = np.random.default_rng(0)
    centres = 2 * np.pi * np.array([10.0, 25.0, 25.25, 40.0, 60.0])
    lam = np.concatenate(
        [c * (-0.01 + 1j) * (1 + 0.002 * rng.standard_normal(30)) for c in centres]
    )
    lam = np.concatenate([lam, 2 * np.pi * rng.uniform(5, 70, 20) * (-0.02 + 1j)])
    L = rng.standard_normal((lam.size, 2)) + 1j * rng.standard_normal((lam.size, 2))
    for weight in (0.0, 0.1):
        mine = _average_linkage_labels(lam, L, 0.005, weight)
        mag = np.abs(lam)
        d = np.abs(lam[:, None] - lam[None, :]) / np.maximum(mag[:, None], mag[None, :])
        nn = np.sum(np.abs(L) ** 2, axis=1)
        d = d + weight * (1 - np.abs(L.conj() @ L.T) ** 2 / np.outer(nn, nn))
        iu = np.triu_indices(lam.size, 1)
        ref = fcluster(linkage(d[iu], method="average"), t=0.005, criterion="distance")
        same_mine = mine[:, None] == mine[None, :]
        same_ref = ref[:, None] == ref[None, :]
        np.testing.assert_array_equal(same_mine, same_ref)


def test_significance_keeps_modes_and_drops_a_pole_that_explains_nothing(synthetic):
    """A pole that fits nothing (between two modes, no resonance there) explains none of
    its band; every true mode explains orders of magnitude more than what remains."""
    from truthbench.identify.plscf import SIGNIFICANCE_MIN, mode_significance

    syn = synthetic(noise=0.01, seed=4)
    fake = 2 * np.pi * 50.0 * (-0.01 + 1j * np.sqrt(1 - 0.01**2))
    poles = np.concatenate([syn.poles_true, [fake]])
    fit = lsfd(syn.freq_hz, syn.frf, poles)
    sig = mode_significance(syn.freq_hz, syn.frf, fit)
    assert np.all(sig[:-1] > 100 * SIGNIFICANCE_MIN)
    assert sig[-1] < SIGNIFICANCE_MIN
    # identify_plscf applies it: the fake pole is never chosen, the true ones are
    res = identify_plscf(syn.freq_hz, syn.frf, max_order=24)
    assert res.selection.significance is not None
    assert np.all(res.selection.significance >= SIGNIFICANCE_MIN)
    assert res.modal.n_modes == syn.freq_true.size


def _diagram(tracks, orders, band=(1.0, 100.0)):
    """A stabilization diagram by hand: ``tracks`` maps a pole (rad/s) to the orders in
    which it is present and stable."""
    from truthbench.identify.plscf import StabilizationDiagram

    poles, parts, stable = [], [], []
    for n in orders:
        here = [lam for lam, at in tracks.items() if n in at]
        poles.append(np.array(sorted(here, key=lambda z: z.imag), complex))
        parts.append(np.ones((len(here), 1), complex))
        stable.append(np.ones(len(here), bool))
    return StabilizationDiagram(orders=np.asarray(orders), poles=tuple(poles),
                                participation=tuple(parts), stable_freq=tuple(stable),
                                stable_damping=tuple(stable), stable_vector=tuple(stable),
                                physical=tuple(stable), freq_range_hz=band)


def test_persistence_is_counted_from_a_modes_first_order():
    """A mode that needs order 15 to show and then persists is a mode at max order 20
    as at 80; a pole stable in the last two orders only, or in a third of the orders
    since it appeared, is not."""
    def pole(f_hz, zeta=0.01):
        return 2 * np.pi * f_hz * (-zeta + 1j * np.sqrt(1 - zeta**2))

    strong, late, flicker, tail = pole(10.0), pole(30.0), pole(50.0), pole(70.0)
    for top in (20, 40, 80):
        orders = range(1, top + 1)
        tracks = {strong: set(range(5, top + 1)), late: set(range(15, top + 1)),
                  flicker: set(range(6, top + 1, 3)), tail: {top - 1, top}}
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            sel = select_poles(_diagram(tracks, orders))
        np.testing.assert_allclose(np.abs(sel.poles) / (2 * np.pi), [10.0, 30.0], rtol=1e-9)


# ---- the normal equations, against their definitions --------------------------------
def test_lag_sums_match_the_complex_exponential_sums(synthetic):
    """R, S, T of the pLSCF normal equations (from the cosines and sines of the lags)
    against their definitions as complex exponential sums over the lines. Every entry is
    a sum of nf terms of size up to max|X|, each with the rounding of its power
    exp(j k theta) (below (p + 1) eps, by repeated multiplication) and of the sum (nf
    eps): below (p + 2) nf eps max|X| per entry."""
    from truthbench.identify.plscf import _lag_sums

    syn = synthetic(n_in=2)
    f, H = syn.freq_hz, syn.frf
    p = 12
    theta = 2 * np.pi * f / (2 * f[-1])
    R, S, T = _lag_sums(theta, H, p)
    nf, no, ni = H.shape
    k = np.arange(p + 1)
    W = np.exp(1j * np.outer(theta, k))  # (nf, p + 1): Omega_f^k
    # R_rs = Re sum_f W_fr conj(W_fs); S_o[r, (s, i)] = -Re sum_f W_fr conj(W_fs) H_foi;
    # T[(r, i), (s, j)] = Re sum_f W_fr conj(W_fs) sum_o conj(H_foi) H_foj
    WW = W[:, :, None] * W.conj()[:, None, :]  # (nf, r, s)
    R_ref = WW.sum(axis=0).real
    S_ref = -np.einsum("frs,foi->orsi", WW, H).real.reshape(no, p + 1, (p + 1) * ni)
    P = np.einsum("foi,foj->fij", H.conj(), H)
    T_ref = np.einsum("frs,fij->risj", WW, P).real.reshape((p + 1) * ni, (p + 1) * ni)
    bound = (p + 2) * nf * np.finfo(float).eps
    np.testing.assert_allclose(R, R_ref, rtol=0, atol=bound)
    np.testing.assert_allclose(S, S_ref, rtol=0, atol=bound * np.abs(H).max())
    np.testing.assert_allclose(T, T_ref, rtol=0, atol=bound * np.abs(P).max())


@pytest.mark.parametrize("n_in", [1, 2])
def test_reduced_normal_matrix_of_every_order_matches_a_direct_solve(synthetic, n_in):
    """M_n = T_n - sum_o S_on^T R_n^-1 S_on from one Cholesky factor of R (leading
    blocks) against numpy's solve with each R_n: equal within the rounding of the
    products, about cond(R_n) eps |S|^2 / |R| per entry."""
    from truthbench.identify.plscf import _lag_sums, _reduced_normal

    syn = synthetic(n_in=n_in)
    f, H = syn.freq_hz, syn.frf
    H = H / np.sqrt(np.mean(np.abs(H) ** 2, axis=(0, 2)))[None, :, None]
    p = 20
    R, S, T = _lag_sums(2 * np.pi * f / (2 * f[-1]), H, p)
    reduced = _reduced_normal(R, S, T, n_in)
    eps = np.finfo(float).eps
    for n in (1, 5, 13, 20):
        m = (n + 1) * n_in
        Rn, Sn = R[: n + 1, : n + 1], S[:, : n + 1, :m]
        ref = T[:m, :m] - sum(So.T @ np.linalg.solve(Rn, So) for So in Sn)
        scale = np.linalg.cond(Rn) * eps * max(np.abs(Sn).max() ** 2 / np.abs(Rn).max(), 1)
        np.testing.assert_allclose(reduced(n), ref, rtol=0, atol=100 * (n + 1) * scale)


def test_single_input_participation_is_one(synthetic):
    """One input: the participation vectors are the unit scalar 1 (the eigensolver's
    phase was arbitrary), and the poles those of the eigenvalues alone."""
    syn = synthetic(n_in=1)
    d = plscf_stabilization(syn.freq_hz, syn.frf, 20)
    for L in d.participation:
        np.testing.assert_array_equal(L, np.ones_like(L))
