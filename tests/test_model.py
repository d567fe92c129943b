"""StructuralModel: modes, state space and modal-superposition FRF against
python-control and scipy."""

import control
import numpy as np
import pytest
import scipy.linalg as sla
import scipy.sparse as sp

from truthbench.errors import ModelError
from truthbench.fe.assembly import assemble, finish_structure, straight_member
from truthbench.model import StructuralModel, solve_modes
from truthbench.plants import Actuator, Sensor, make_plant

FREQ = np.linspace(0.7, 300.0, 900)


def _control_frf(sys, freq_hz):
    r = control.frequency_response(sys, 2 * np.pi * freq_hz)
    H = np.asarray(r.complex).reshape(sys.noutputs, sys.ninputs, -1)
    return np.moveaxis(H, -1, 0)


def _rel_error_away_from_zeros(H, Hc):
    """Max relative error where |Hc| exceeds 1e-6 of its output's largest value (over
    frequencies and inputs): zeros and structurally zero cross terms are excluded."""
    row_max = np.abs(Hc).max(axis=(0, 2), keepdims=True)
    mask = np.abs(Hc) > 1e-6 * row_max
    return (np.abs(H - Hc)[mask] / np.abs(Hc)[mask]).max()


def _hub_model(**params):
    plant = make_plant("hub_beam", n_elements=16)
    return plant.build(params, [Actuator("hub", "rz"), Actuator("tip", "y")],
                       [Sensor("tip", "y"), Sensor("root", "y", "strain"),
                        Sensor("hub", "rz", "velocity"), Sensor("mid", "y", "displacement")])


def test_modes_are_mass_normalised_and_diagonalise_k():
    model = _hub_model()
    md = model.modes()
    Phi = md.shapes
    np.testing.assert_allclose(Phi.T @ (model.M @ Phi), np.eye(md.n_modes), atol=1e-9)
    np.testing.assert_allclose(Phi.T @ (model.K @ Phi), np.diag(md.omega_rad_s**2),
                               atol=1e-8 * md.omega_rad_s.max() ** 2)
    assert md.rigid.sum() == 1  # the hub rotation


def test_sparse_shift_invert_equals_dense_on_200_elements():
    mesh = straight_member([0, 0, 0], [2.0, 0, 0], 200)
    props = dict(E_pa=70e9, nu=0.3, rho_kg_m3=2700.0, r_m=0.012, t_m=0.0015)
    K, M = assemble(mesh, {"beam": props})
    Mf, _, Kf, _ = finish_structure(K, M, mesh.n_dofs)
    sparse = solve_modes(Mf, Kf, 20)
    lam, vec = sla.eigh(Kf.toarray(), Mf.toarray(), subset_by_index=(0, 19))
    dense = np.sqrt(np.clip(lam, 0, None))
    assert sparse.rigid.sum() == 6
    flex = ~sparse.rigid
    # dense eigh loses ~eps * omega_max^2 / omega^2 on the low modes (about 1e-6 here)
    np.testing.assert_allclose(sparse.omega_rad_s[flex], dense[flex], rtol=2e-6)

    def residual(lam_, Phi):  # ||K phi - lam M phi|| / ||K phi||
        R = Kf @ Phi - (Mf @ Phi) * lam_
        return np.linalg.norm(R, axis=0) / np.linalg.norm(Kf @ Phi, axis=0)

    r_sparse = residual(sparse.omega_rad_s[flex] ** 2, sparse.shapes[:, flex])
    r_dense = residual(lam[flex], vec[:, flex])
    assert np.median(r_sparse) <= np.median(r_dense)
    again = solve_modes(Mf, Kf, 20)
    np.testing.assert_array_equal(again.omega_rad_s, sparse.omega_rad_s)  # reproducible


@pytest.mark.parametrize("hub_damping", [0.0, 5.0])
def test_modal_frf_equals_python_control_on_same_state_space(hub_damping):
    """Both the classical (diagonal) and complex-mode paths; relative 1e-8."""
    model = _hub_model(hub_damping_n_m_s_rad=hub_damping)
    md = model.modes(40)
    H = model.frf(FREQ, modes=md)
    Hc = _control_frf(model.state_space(modes=md), FREQ)
    assert H.shape == (len(FREQ), 4, 2)
    assert _rel_error_away_from_zeros(H, Hc) < 1e-8


def test_defective_rigid_modes_with_nonproportional_damping():
    """Undamped rigid modes beside a dashpot make the modal state matrix defective;
    the FRF falls back to a per-frequency solve and still equals python-control."""
    plant = make_plant("free_free_beam", n_elements=10)
    model = plant.build({"suspension_damping_n_s_m": 2.0}, [Actuator("end_a", "y"),
                        Actuator("end_a", "z")], [Sensor("mid", "y"), Sensor("end_b", "z")])
    md = model.modes()
    H = model.frf(FREQ, modes=md)
    Hc = _control_frf(model.state_space(modes=md), FREQ)
    assert _rel_error_away_from_zeros(H, Hc) < 1e-8


def test_all_modes_equal_physical_state_space():
    """Modal superposition with every mode equals the physical first-order model
    x = [q; q'], A = [[0, I], [-M^-1 K, -M^-1 C]] evaluated by python-control."""
    model = _hub_model(modal_damping_ratio=0.0)  # physical damping only
    Mi = np.linalg.inv(model.M.toarray())
    n = model.n_dofs
    A = np.block([[np.zeros((n, n)), np.eye(n)],
                  [-Mi @ model.K.toarray(), -Mi @ model.C.toarray()]])
    B = np.vstack([np.zeros((n, 2)), Mi @ model.B])
    C = np.hstack([model.C_out, np.zeros((4, n))])
    C[2] = np.concatenate([np.zeros(n), model.C_out[2]])  # the velocity output
    C[0] = model.C_out[0] @ A[n:]  # the acceleration output: q'' = -M^-1 (K q + C q') + ...
    D = np.zeros((4, 2))
    D[0] = model.C_out[0] @ B[n:]
    assert model.quantities[0] == "acceleration"
    sys = control.ss(A, B, C, D)
    Hc = _control_frf(sys, FREQ)
    H = model.frf(FREQ)
    # the physical form carries M^-1 and eigenvalues spread over ~1e10 (axial modes), so
    # python-control's evaluation of it loses about 7 digits; 1e-6 is that loss, not ours
    assert _rel_error_away_from_zeros(H, Hc) < 1e-6


def test_model_validation_errors():
    M = sp.eye(3)
    with pytest.raises(ModelError, match="input matrix B has 2 rows; expected 3"):
        StructuralModel(M, M, M, np.zeros((2, 1)), np.zeros((1, 3)), ("displacement",))
    with pytest.raises(ModelError, match="unknown output quantity 'jerk'"):
        StructuralModel(M, M, M, np.zeros((3, 1)), np.zeros((1, 3)), ("jerk",))
    with pytest.raises(ModelError, match="n_modes"):
        solve_modes(M, M, 7)


def test_modal_table_damping_equals_python_control_damp():
    """With the hub dashpot (non-proportional damping, a real pole from the rigid mode),
    the table's damping ratios are the complex poles' (python-control ``damp``)."""
    from truthbench.model import modal_table

    model = _hub_model(hub_damping_n_m_s_rad=10.0)
    md = model.modes(30)
    rows = modal_table(model, md)
    wn, zeta, poles = control.damp(model.state_space(modes=md), doprint=False)
    osc = poles.imag > 1e-9
    ref = np.sort(zeta[osc])
    ours = np.sort([r["damping_ratio"] for r in rows if r["damping_ratio"] == r["damping_ratio"]])
    np.testing.assert_allclose(ours, ref, rtol=1e-8)
    first = next(r for r in rows if r["shape"].startswith("bending y"))
    assert 0.003 < first["damping_ratio"] < 0.05  # the hub damper acts on mode 1


def test_frf_off_the_imaginary_axis_equals_python_control():
    """``decay_rad_s`` evaluates the transfer function at ``s = sigma + j omega`` (an
    exponentially windowed FRF); python-control evaluates the same state space at the
    same complex points. Non-proportional damping (the hub dashpot) takes the
    complex-mode path."""
    import control  # noqa: F401  (state_space returns a control.StateSpace)

    from truthbench.plants import Actuator, Sensor, make_plant

    plant = make_plant("hub_beam", n_elements=6)
    model = plant.build(None, [Actuator("hub", "rz"), Actuator("tip", "y")],
                        [Sensor("tip", "y"), Sensor("hub", "rz", "velocity"),
                         Sensor("mid", "y", "displacement")])
    f = np.linspace(0.5, 120.0, 60)
    sigma = 3.0
    H = model.frf(f, decay_rad_s=sigma)
    ref = np.moveaxis(np.asarray(model.state_space()(2j * np.pi * f + sigma)), -1, 0)
    assert np.abs(H - ref).max() < 1e-9 * np.abs(ref).max()
    assert np.abs(H - model.frf(f)).max() > 1e-3 * np.abs(ref).max()


def test_dashpot_on_a_free_free_beam_with_rigid_modes_equals_the_direct_solve():
    """A grounded dashpot on a beam whose lateral and axial motion is free (rigid-body
    modes in other directions): the modal FRF equals the direct solve of
    ``(K + s C + s^2 M) x = B`` with the same modal damping. The rigid-body modes are
    not damped, so they stay on the classical path (no Jordan block in the complex-mode
    subset); what is neglected is the eigensolver's contamination of the zero
    eigenspace, about eps * lambda_max / lambda_min(elastic) of the shapes, which sets
    the tolerance."""
    from truthbench.plants import Actuator, Sensor, make_plant
    from truthbench.plants.base import StructuralAdditions

    plant = make_plant("free_free_beam", n_elements=20)
    add = StructuralAdditions((("dashpot", 6 * 7 + 2, -1, 4.0),))
    model = plant.build({"suspension_damping_n_s_m": 0.5, "modal_damping_ratio": 0.01},
                        [Actuator("end_a", "z"), Actuator("mid", "y")],
                        [Sensor("quarter", "z"), Sensor("mid", "y", "velocity")], add)
    modes = model.modes()
    assert modes.rigid.sum() == 4  # axial, torsion, lateral translation and rotation
    f = np.linspace(0.5, 400.0, 300)
    H = model.frf(f, modes=modes)
    M, K, C = model.M.toarray(), model.K.toarray(), model.C.toarray()
    Phi = modes.shapes
    c_modal = M @ Phi @ np.diag(np.where(modes.rigid, 0.0, 0.02 * modes.omega_rad_s)) \
        @ Phi.T @ M
    power = np.array([2, 1])
    ref = np.array([(model.C_out @ np.linalg.solve(K + s * (C + c_modal) + s * s * M, model.B))
                    * (s ** power)[:, None] for s in 2j * np.pi * f])
    lam = modes.omega_rad_s ** 2
    tol = np.finfo(float).eps * lam.max() / lam[~modes.rigid].min()
    for o, i in ((0, 0), (1, 1)):  # the direct couplings (z-z, y-y)
        err = np.abs(H[:, o, i] - ref[:, o, i]).max() / np.abs(ref[:, o, i]).max()
        assert err < tol, (o, i, err, tol)


def test_mode_tolerance_leaves_out_only_what_the_channels_barely_see():
    """Vertical channels on a free-free tube: leaving out the modes whose peak at these
    channels is below 1e-12 of the largest (lateral, axial and torsion modes) changes the
    FRF by at most the number of modes times that fraction of the largest peak; a
    coarse tolerance does change it (the option acts)."""
    from truthbench.plants import Actuator, Sensor, make_plant

    plant = make_plant("free_free_beam", n_elements=20)
    model = plant.build({"modal_damping_ratio": 0.01},
                        [Actuator("end_a", "z")], [Sensor(s, "z") for s in
                                                  ("end_a", "quarter", "mid", "end_b")])
    modes = model.modes()
    f = np.linspace(2.0, 400.0, 500)
    full = model.frf(f, modes=modes)
    bound = modes.n_modes * 1e-12 * np.abs(full).max()
    assert np.abs(model.frf(f, modes=modes, mode_tolerance=1e-12) - full).max() <= bound
    assert np.abs(model.frf(f, modes=modes, mode_tolerance=0.5) - full).max() > 1e3 * bound


def _beam_on_springs(lateral=0.0, axial=0.0):
    plant = make_plant("free_free_beam", n_elements=10)
    return plant.build({"suspension_lateral_stiffness_n_m": lateral,
                        "suspension_axial_stiffness_n_m": axial})


def test_modal_table_names_rigid_and_suspension_modes():
    from truthbench.model import modal_table

    # vertical springs only: four rigid-body modes, then bounce and pitch
    model = _beam_on_springs()
    rows = modal_table(model, model.modes(8))
    assert [r["shape"] for r in rows[:6]] == [
        "rigid-body translation x", "rigid-body translation y", "rigid-body rotation about x",
        "rigid-body rotation about z", "suspension bounce (translation z)",
        "suspension pitch (rotation about y)"]
    assert [r["mode"] for r in rows] == list(range(1, 9))
    assert rows[6]["shape"].startswith("bending") and rows[6]["shape"].endswith("2 nodes")
    # springs in every direction the plant has: surge, sway and yaw too, no rigid mode
    # but the roll about the beam axis (nothing resists it)
    model = _beam_on_springs(lateral=150.0, axial=100.0)
    shapes = [r["shape"] for r in modal_table(model, model.modes(6))]
    assert shapes == ["rigid-body rotation about x", "suspension surge (translation x)",
                      "suspension sway (translation y)", "suspension yaw (rotation about z)",
                      "suspension bounce (translation z)", "suspension pitch (rotation about y)"]


def test_modal_table_does_not_depend_on_the_rigid_basis():
    """The eigensolver may return any basis of the 0 Hz subspace: the table is the same."""
    from dataclasses import replace

    from truthbench.model import modal_table

    model = _beam_on_springs()
    md = model.modes(10)
    rigid = np.flatnonzero(md.rigid)
    rng = np.random.default_rng(1)
    q, _ = np.linalg.qr(rng.standard_normal((rigid.size, rigid.size)))
    shapes = md.shapes.copy()
    shapes[:, rigid] = md.shapes[:, rigid] @ q  # still mass-orthonormal
    turned = replace(md, shapes=shapes)
    def key(rows):  # NaN damping of the rigid modes compares unequal to itself
        return [(r["mode"], r["freq_hz"], repr(r["damping_ratio"]), r["shape"]) for r in rows]

    assert key(modal_table(model, turned)) == key(modal_table(model, md))


def test_modal_table_hub_beam_cantilever_modes_are_not_suspension_modes():
    from truthbench.model import modal_table

    plant = make_plant("hub_beam", n_elements=10)
    model = plant.build({})
    rows = modal_table(model, model.modes(5))
    assert rows[0]["shape"] == "rigid-body rotation about z"
    # the first out-of-plane bending resembles a rotation about the root, but its rigid
    # part strains the clamp (Rayleigh ratio far above 2): it is a bending mode
    assert not any(r["shape"].startswith("suspension") for r in rows)
    assert rows[1]["shape"] == "bending z, 0 nodes"


def _damped_beam():
    """The free-free tube with a grounded dashpot, a joint dashpot between two
    rotations and suspension damping; driven and read in the vertical plane."""
    from truthbench.plants.base import StructuralAdditions

    plant = make_plant("free_free_beam", n_elements=20)
    add = StructuralAdditions((("dashpot", 6 * 7 + 2, -1, 4.0),
                               ("dashpot", 6 * 12 + 4, 6 * 13 + 4, 0.3)))
    return plant.build({"suspension_damping_n_s_m": 0.5, "modal_damping_ratio": 0.01},
                       [Actuator("end_a", "z")],
                       [Sensor("quarter", "z"), Sensor("mid", "z", "velocity")], add)


def test_the_coupled_blocks_of_a_straight_beam_are_its_planes_and_motions():
    """A straight beam along x: axial (x), torsion (rx), bending in x-z (z, ry) and in
    x-y (y, rz) are four uncoupled blocks of DOFs; a dashpot between two rotations keeps
    them apart, a spring coupling z to y joins two."""
    from truthbench.model import coupled_blocks

    model = _damped_beam()
    blocks = coupled_blocks(model.M, model.K, model.C)
    kinds = [{lab.rsplit(".", 1)[1] for lab in np.asarray(model.dof_labels)[b]}
             for b in blocks]
    assert sorted(map(sorted, kinds)) == [["rx"], ["ry", "z"], ["rz", "y"], ["x"]]
    assert sum(b.size for b in blocks) == model.n_dofs
    link = sp.lil_matrix(model.K.shape)
    z, y = model.dof_labels.index("n5.z"), model.dof_labels.index("n5.y")
    link[z, y] = link[y, z] = 1.0
    assert len(coupled_blocks(model.M, model.K + link.tocsr(), model.C)) == 3


def test_block_modes_and_woodbury_damping_give_the_direct_solve():
    """The modes of the block the channels are coupled to, with the physical dashpots
    added to the modal solution by the Woodbury identity, give the FRF of the direct
    solve of ``(K + s (C + C_modal) + s^2 M) x = B`` (every mode's modal damping), to
    the eigensolver's round-off (eps * lambda_max / lambda_min of the block), and the
    same FRF as every mode with complex modes."""

    from truthbench.model import frf, solve_block_modes

    model = _damped_beam()
    dofs = np.flatnonzero(np.any(model.B != 0, axis=1) | np.any(model.C_out != 0, axis=0))
    block = solve_block_modes(model.M, model.K, dofs, model.C)
    full = model.modes()
    assert block.n_modes == 2 * 21 and full.n_modes == 6 * 21  # z and ry of 21 nodes
    f = np.linspace(0.5, 400.0, 200)
    H_block = frf(model, f, block, low_rank_damping=True)
    H_full = frf(model, f, full)
    M, K, C = model.M.toarray(), model.K.toarray(), model.C.toarray()
    Phi = full.shapes
    c_modal = M @ Phi @ np.diag(np.where(full.rigid, 0.0, 0.02 * full.omega_rad_s)) \
        @ Phi.T @ M
    power = np.array([2, 1])
    ref = np.array([(model.C_out @ np.linalg.solve(K + s * (C + c_modal) + s * s * M, model.B))
                    * (s ** power)[:, None] for s in 2j * np.pi * f])
    lam = block.omega_rad_s ** 2
    tol = np.finfo(float).eps * lam.max() / lam[~block.rigid].min()
    scale = np.abs(ref).max(axis=0)
    assert np.all(np.abs(H_block - ref).max(axis=0) / scale < tol)
    assert np.all(np.abs(H_block - H_full).max(axis=0) / scale < 10 * tol)
    # without low_rank_damping the block's own complex modes give it too
    assert np.all(np.abs(frf(model, f, block) - ref).max(axis=0) / scale < tol)
