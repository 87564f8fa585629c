"""Lumped dynamics: the second-order model against exact solutions, its static limit, and FE."""

import json

import numpy as np
import pytest
from isj.lumped.artifact import Calibration, default_calibration
from isj.lumped.dynamics import (
    COORDINATES,
    SecondOrderModel,
    chain_mass,
    chain_model,
    chain_outputs,
    chain_stiffness,
)
from isj.lumped.model import FACTOR_NAMES, Lever, static_response

from isj.damping import Damping
from isj.design import Geometry, Materials
from isj.errors import CorruptCalibration


def sdof(m=2e-9, c=3e-5, k=40.0, eta=0.0):
    one = lambda v: np.array([[v]])  # noqa: E731
    return SecondOrderModel(M=one(m), E=one(c), K=one(k), B=one(1.0), C=one(1.0), loss_factor=eta)


def test_single_dof_oscillator_is_exact():
    m, c, k = 2e-9, 3e-5, 40.0
    f = np.array([0.0, 100.0, 1e4, 22_508.0, 1e6])
    w = 2 * np.pi * f
    H = sdof(m, c, k).freq_resp(f)
    assert H.shape == (5, 1, 1)
    assert np.allclose(H[:, 0, 0], 1 / (k - w**2 * m + 1j * w * c), rtol=1e-13, atol=0)
    He = sdof(m, 0.0, k, eta=0.2).freq_resp(f)
    assert np.allclose(He[:, 0, 0], 1 / (k * (1 + 0.2j) - w**2 * m), rtol=1e-13, atol=0)


def test_single_dof_poles():
    m, c, k = 2e-9, 3e-5, 40.0
    f, zeta = sdof(m, c, k).poles()
    assert f[0] == pytest.approx(np.sqrt(k / m) / (2 * np.pi), rel=1e-12)
    assert zeta[0] == pytest.approx(c / (2 * np.sqrt(k * m)), rel=1e-12)


@pytest.mark.parametrize("shear", [0.3, 1.0, 3.0])
def test_static_limit_is_the_calibrated_static_model(shear):
    f = default_calibration().factor_array()
    moduli = {
        "pedicle_e_pa": np.array([3e9, 12e9, 20e9]),
        "gap_e_pa": np.array([5e6, 20e6, 1.5e6]),
        "capsule_e_pa": np.array([20e6, 200e6, 50e6]),
        "plate_e_pa": np.array([1e9, 4e9, 3e8]),
        "stapes_e_pa": np.array([1e9, 3e8, 4e9]),
    }
    dyn = chain_outputs(chain_model(f, shear, damping="undamped", **moduli), [0.0], pressure_pa=28.5)
    st = static_response(f, pressure_pa=28.5, **moduli)
    assert np.allclose(dyn[:, 0, 0].real, st.alpha_rad, rtol=1e-12)
    assert np.allclose(dyn[:, 0, 1].real, st.beta_rad, rtol=1e-12)
    assert np.allclose(dyn[:, 0, :2].imag, 0)
    # one loss factor everywhere, given per region: the static response divided by (1 + iη)
    eta = dict.fromkeys(("stapes", "gap", "plate", "pedicle", "incus", "capsule"), 0.07)
    chain = chain_model(f, shear, damping="undamped", loss_factor=eta, **moduli)
    dyn = chain_outputs(chain, [0.0], 28.5)
    np.testing.assert_allclose(dyn[:, 0, 0], st.alpha_rad / (1 + 0.07j), rtol=1e-11)
    np.testing.assert_allclose(dyn[:, 0, 1], st.beta_rad / (1 + 0.07j), rtol=1e-11)


def test_pedicle_is_a_timoshenko_cantilever_with_the_calibrated_tip_rotation():
    """Flexibility of the beam block: L³/3EI + L/κGA, L²/2EI, L/EI; tip rotation = the beam term."""
    g, nu, e = Geometry(), Materials().nu, 7e9
    f = default_calibration().factor_array()
    fb = f[FACTOR_NAMES.index("pedicle_bending")]
    st = chain_stiffness(f, geometry=g, pedicle_e_pa=e)
    L, bx, by = g.pedicle_length_m, g.pedicle_x_m, g.pedicle_y_m
    ei = e * by * bx**3 / 12 / fb
    kga = 10 * (1 + nu) / (12 + 11 * nu) * e / (2 * (1 + nu)) * bx * by
    flex = np.array([[L**3 / (3 * ei) + L / kga, L**2 / (2 * ei)], [L**2 / (2 * ei), L / ei]])
    np.testing.assert_allclose(np.linalg.inv(st.beam[0]), flex, rtol=1e-12)
    lever = Lever.from_geometry(g)
    arm = g.incus_length_m / 2  # the load's height above the tip
    phi = (flex @ [lever.force_per_pa, lever.force_per_pa * arm])[1]
    assert phi == pytest.approx(fb * lever.force_per_pa * lever.beam / e, rel=1e-12)


def _cantilever_tip_body_f1(ei, rho_a, L, m, c, j_c):
    """First natural frequency (Hz) of a clamped Euler–Bernoulli beam with a rigid tip body.

    Tip body: mass m (kg), centroid c (m) beyond the tip on the beam's axis, rotary inertia j_c
    (kg m²) about its centroid. w = A (cosh − cos)(βz) + B (sinh − sin)(βz), β⁴ = ρA ω²/EI; at
    the tip EI w3 + ω² m (w + c w1) = 0 and −EI w2 + ω² (m c (w + c w1) + j_c w1) = 0 (wk the
    k-th derivative); the first root of the 2 × 2 determinant, bracketed on a grid, brentq.
    """
    from scipy.optimize import brentq

    def det(w):
        b = (rho_a * w**2 / ei) ** 0.25
        x = b * L
        ch, sh, co, si = np.cosh(x), np.sinh(x), np.cos(x), np.sin(x)
        basis = [  # (w, w1, w2, w3) at the tip for each of the two shapes
            (ch - co, b * (sh + si), b**2 * (ch + co), b**3 * (sh - si)),
            (sh - si, b * (ch - co), b**2 * (sh + si), b**3 * (ch + co)),
        ]
        rows = [
            [ei * d3 + w**2 * m * (d0 + c * d1) for d0, d1, d2, d3 in basis],
            [-ei * d2 + w**2 * (m * c * (d0 + c * d1) + j_c * d1) for d0, d1, d2, d3 in basis],
        ]
        return np.linalg.det(np.array(rows)) / ch**2  # scaled; the same sign changes

    grid = 2 * np.pi * np.geomspace(1e2, 1e7, 4000)
    vals = np.array([det(w) for w in grid])
    i = np.flatnonzero(np.sign(vals[:-1]) != np.sign(vals[1:]))[0]
    return brentq(det, grid[i], grid[i + 1], xtol=1e-12, rtol=1e-14) / (2 * np.pi)


@pytest.mark.parametrize(
    "dims",
    [{}, {"pedicle_length_m": 120e-6}, {"pedicle_length_m": 400e-6, "incus_length_m": 80e-6}],
)
def test_rigid_joint_and_supports_leave_a_cantilever_with_a_tip_body(dims):
    """Stapes head, joint (rotation and shear), root and top rigid: the pedicle with the incus on it.

    Only (w_tip, φ_tip) remain, with the chain's consistent mass. With the Euler–Bernoulli
    stiffness (Φ = 0) the first frequency matches the exact frequency equation within 0.1 %
    (measured −0.02 % on the default design: one cubic element, and the chain's mass also has
    the slices' rotary inertia); the Timoshenko element's shear lowers it, by less than 5 %
    (measured −0.6 % on the default design).
    """
    from scipy.linalg import eigh

    g, mat = Geometry(**dims), Materials()
    f = default_calibration().factor_array()
    keep = [COORDINATES.index("w_tip"), COORDINATES.index("phi_tip")]
    M = chain_mass(g, mat)[np.ix_(keep, keep)]
    e = mat.pedicle_e_pa
    L, bx, by = g.pedicle_length_m, g.pedicle_x_m, g.pedicle_y_m
    ei = e * by * bx**3 / 12 / f[FACTOR_NAMES.index("pedicle_bending")]
    k_eb = ei / L**3 * np.array([[12, -6 * L], [-6 * L, 4 * L**2]])
    f_eb = np.sqrt(eigh(k_eb, M, eigvals_only=True)[0]) / (2 * np.pi)
    rho = mat.bone_density_kg_m3
    m_tip = rho * g.incus_x_m * g.incus_y_m * g.incus_length_m
    j_c = m_tip * (g.incus_x_m**2 + g.incus_length_m**2) / 12
    ref = _cantilever_tip_body_f1(ei, rho * bx * by, L, m_tip, g.incus_length_m / 2, j_c)
    assert f_eb == pytest.approx(ref, rel=1e-3)
    k_timo = chain_stiffness(f, geometry=g).beam[0]
    f_timo = np.sqrt(eigh(k_timo, M, eigvals_only=True)[0]) / (2 * np.pi)
    assert 0.95 * f_eb < f_timo < f_eb


def test_mass_matrix_is_symmetric_positive_definite_and_carries_the_bodies():
    for g in (Geometry(), Geometry(pedicle_length_m=120e-6, gap_thickness_m=20e-6)):
        mat = Materials()
        M = chain_mass(g, mat)
        assert M.shape == (len(COORDINATES),) * 2
        np.testing.assert_array_equal(M, M.T)
        d = 1 / np.sqrt(np.diag(M))
        assert np.linalg.eigvalsh(M * np.outer(d, d)).min() > 1e-6  # unit-diagonal scaling
        # everything above the joint's mid-plane translates with s_joint and turns with theta_joint
        z_j = (g.z_gap + g.z_plate) / 2
        rb, rs = mat.bone_density_kg_m3, mat.soft_density_kg_m3
        boxes = [
            (rs, g.joint_x_m, g.joint_y_m, z_j, g.z_plate),
            (rb, g.joint_x_m, g.joint_y_m, g.z_plate, g.z_pedicle),
            (rb, g.pedicle_x_m, g.pedicle_y_m, g.z_pedicle, g.z_incus),
            (rb, g.incus_x_m, g.incus_y_m, g.z_incus, g.z_top),
        ]
        mass = sum(r * wx * wy * (z1 - z0) for r, wx, wy, z0, z1 in boxes)
        inertia = sum(
            r * wx * wy * (z1 - z0) * (((z0 + z1) / 2 - z_j) ** 2 + (wx**2 + (z1 - z0) ** 2) / 12)
            for r, wx, wy, z0, z1 in boxes
        )
        s, t = COORDINATES.index("s_joint"), COORDINATES.index("theta_joint")
        assert M[s, s] == pytest.approx(mass, rel=1e-12)
        assert M[t, t] == pytest.approx(inertia, rel=1e-12)


def test_modal_response_equals_the_dense_solve():
    """freq_resp sums modes for proportional damping: against one dense solve per frequency."""
    f = default_calibration().factor_array()
    E = np.array([2e9, 5e9, 20e9])
    freq = np.r_[0.0, np.geomspace(100, 2e5, 40)]
    w = 2 * np.pi * freq
    for damping in ("uniform-rayleigh", Damping.uniform(300.0, 0.0, 0.05), Damping()):
        m = chain_model(f, 0.8, pedicle_e_pa=E, damping=damping)
        Z = (
            (m.K * (1 + 1j * m.loss_factor) + 1j * m.K_loss)[:, None]
            + 1j * w[None, :, None, None] * m.E[:, None]
            - (w**2)[None, :, None, None] * m.M[:, None]
        )
        X = np.linalg.solve(Z, np.broadcast_to(m.B[:, None], Z.shape[:2] + m.B.shape[-2:]).astype(complex))
        dense = np.einsum("dij,dfjk->dfik", m.C, X)
        np.testing.assert_allclose(m.freq_resp(freq), dense, rtol=1e-8, atol=0)


def test_many_designs_at_once_equal_one_at_a_time():
    f = default_calibration().factor_array()
    E = np.geomspace(2e9, 20e9, 7)
    many = chain_model(f, pedicle_e_pa=E).freq_resp(np.geomspace(100, 2e4, 11))
    assert many.shape == (7, 11, 3, 1)
    one = chain_model(f, pedicle_e_pa=E[4]).freq_resp(np.geomspace(100, 2e4, 11))
    assert np.allclose(many[4], one, rtol=1e-13)


@pytest.mark.filterwarnings("ignore::isj.errors.DampingWarning")
@pytest.mark.parametrize("damping", ["uniform-rayleigh", "published"])
def test_low_frequency_roll_off_matches_fe(coarse_model, damping):
    """α(1 kHz)/α(0) from FE harmonic solves and from the lumped model (old and new damping)."""
    from isj.fem.dynamics import harmonic

    u = harmonic(coarse_model, [0.0, 1000.0], damping=damping, pressure_pa=1.0)
    fe = coarse_model.angles[:2] @ u.T  # rows α, β; columns frequencies
    cal = default_calibration()
    chain = chain_model(cal.factor_array(), cal.shear_factor, damping=damping)
    lum = chain_outputs(chain, [0.0, 1000.0], 1.0)
    for i in range(2):
        ratio_fe = fe[i, 1] / fe[i, 0]
        ratio_lum = lum[1, i] / lum[0, i]
        assert abs(ratio_lum / ratio_fe - 1) < 0.01  # magnitude and phase together


def test_shear_fit_recovers_a_known_factor():
    """Frequencies generated by the chain model itself give back its joint shear factor."""
    from isj.calibration.pipeline import fit_shear

    f = default_calibration().factor_array()
    designs = [
        {"pedicle_e_pa": e, "gap_e_pa": g, "capsule_e_pa": c}
        for e, g, c in [(2e9, 3e6, 20e6), (8e9, 20e6, 100e6), (20e9, 40e6, 200e6)]
    ]
    moduli = {k: np.array([d[k] for d in designs]) for k in designs[0]}
    true_f, _ = chain_model(f, 0.42, rayleigh_b_s=0.0, **moduli).poles()
    fit = fit_shear(f, designs, true_f[:, :2])
    assert fit["shear_factor"] == pytest.approx(0.42, rel=1e-5)
    assert fit["max_f1"] < 1e-6 and fit["max_f2"] < 1e-6 and fit["n"] == 3


def test_shipped_dynamics_and_a_calibration_without_a_shear_factor():
    cal = default_calibration()
    dyn = cal.dynamics
    assert set(dyn) == {"shear_factor", "training", "validation"}
    assert cal.shear_factor == dyn["shear_factor"] and 0.1 < cal.shear_factor < 10
    for block in (dyn["training"], dyn["validation"]):
        assert block["n"] >= 8 and block["max_f1"] < 0.05 and block["max_f2"] < 0.05
    d = json.loads(cal.to_json())
    d["dynamics"] = {"hinge_fraction": 0.15}  # the former two-hinge chain's calibration
    assert Calibration.from_dict(d).shear_factor == 1.0
    d["dynamics"] = {"shear_factor": -1.0}
    with pytest.raises(CorruptCalibration, match="shear_factor"):
        Calibration.from_dict(d)


def test_joint_coupling_gives_the_calibrated_rotations_under_the_isolated_load():
    """The chain condensed onto (α, β) for the ear: the incus loaded as in the isolated model."""
    from isj.lumped.dynamics import joint_coupling

    g = Geometry()
    f = default_calibration().factor_array()
    moduli = {"pedicle_e_pa": np.array([2e9, 5e9, 20e9]), "plate_e_pa": np.array([3e8, 1e9, 4e9])}
    jc = joint_coupling(f, g, **moduli)
    force = Lever.from_geometry(g).force_per_pa
    arm = g.z_incus + g.incus_length_m / 2 - (g.z_gap + g.z_plate) / 2
    load_d = np.array([force, force * arm])  # work-conjugate to (u_x at z_j, rotation)
    ab = np.linalg.solve(jc.stiffness, (np.swapaxes(jc.motion, -1, -2) @ load_d)[..., None])[..., 0]
    st = static_response(f, g, pressure_pa=1.0, **moduli)
    np.testing.assert_allclose(ab[:, 0], st.alpha_rad, rtol=1e-11)
    np.testing.assert_allclose(ab[:, 1], st.beta_rad, rtol=1e-11)
    np.testing.assert_allclose(jc.stiffness, np.swapaxes(jc.stiffness, -1, -2), rtol=1e-10)
    assert np.all(np.linalg.eigvalsh(jc.stiffness) > 0)
