"""Damping per material (docs/dynamics.md §4.3): exact single-dof responses per damping kind, energy
per cycle, per-region factors that reduce to the uniform case, the modal diagnostic and its warning."""

import json
import warnings

import numpy as np
import pytest
from isj.fem import dynamics
from isj.fem.boundary import traction_load
from isj.fem.mesh import TetMesh
from isj.fem.model import ElasticModel
from isj.fem.structured import box_mesh
from isj.lumped.damping import damping_terms, region_stiffness
from isj.lumped.second_order import SecondOrderModel

from isj.damping import (
    CAT_COCHLEAR_IMPEDANCE_PA_S_M3,
    MASS_PARTS,
    STIFFNESS_PARTS,
    Damping,
    warn_rayleigh_band,
)
from isj.design import REGIONS, Materials
from isj.errors import DampingWarning, InvalidParameter

FREQ = np.array([0.0, 50.0, 1e3, 22_508.0, 2e5])  # 22.5 kHz: the oscillator's resonance
M1, K1 = 2e-9, 40.0  # kg, N/m: f_n = 22.5 kHz


def sdof(damping: Damping, part: str = "pedicle", dashpot: float = 0.0) -> SecondOrderModel:
    """One mass on one spring of ``part``, damped as ``damping`` says (isj.lumped.damping)."""
    one = np.array([[1.0]])
    masses = {part: M1 * one} if part in MASS_PARTS else {"pedicle": M1 * one}
    E, K_loss = damping_terms(damping, {part: K1 * one}, masses, dashpot * one)
    return SecondOrderModel(M=M1 * one, E=E, K=K1 * one, B=one, C=one, K_loss=K_loss)


def exact(eta=0.0, c=0.0):
    w = 2 * np.pi * FREQ
    return 1 / (K1 * (1 + 1j * eta) - w**2 * M1 + 1j * w * c)


@pytest.mark.parametrize(
    "damping, part, eta, c",
    [
        (Damping.uniform(loss_factor=0.2), "pedicle", 0.2, 0.0),  # loss factor
        (Damping.uniform(rayleigh_a_per_s=3e3), "pedicle", 0.0, 3e3 * M1),  # Rayleigh a: c = a m
        (Damping.uniform(rayleigh_b_s=2e-6), "pedicle", 0.0, 2e-6 * K1),  # Rayleigh b: c = b k
        (Damping.uniform(rayleigh_b_s=2e-6), "annular_ligament", 0.0, 2e-6 * K1),  # dashpot c = b k
        (Damping(loss_factor={"gap": 0.3}), "gap", 0.3, 0.0),  # one region's published value changed
    ],
)
def test_single_dof_per_damping_kind_is_exact(damping, part, eta, c):
    H = sdof(damping, part).freq_resp(FREQ)[:, 0, 0]
    np.testing.assert_allclose(H, exact(eta, c), rtol=1e-12, atol=0)


def test_single_dof_cochlear_dashpot_is_exact():
    """The cochlea: R = Z_C A² (Lynch et al. 1982's 1.2e6 dyn·s/cm⁵ = 1.2e11 Pa·s/m³, A = 1.26 mm²)."""
    d = Damping.uniform(cochlear_impedance_pa_s_m3=CAT_COCHLEAR_IMPEDANCE_PA_S_M3)
    R = d.cochlear_resistance_n_s_m(1.26e-6)
    assert R == pytest.approx(1.2e11 * 1.26e-6**2, rel=1e-15) and R == pytest.approx(0.1905, rel=1e-3)
    H = sdof(d, "annular_ligament", dashpot=R).freq_resp(FREQ)[:, 0, 0]
    np.testing.assert_allclose(H, exact(0.0, R), rtol=1e-12, atol=0)


def test_single_dof_damping_ratio_from_modal_projection():
    for d, zeta in (
        (Damping.uniform(loss_factor=0.2), 0.1),  # η/2 at resonance
        (Damping.uniform(rayleigh_b_s=2e-6), 2e-6 * np.sqrt(K1 / M1) / 2),
        (Damping.uniform(rayleigh_a_per_s=3e3), 3e3 / (2 * np.sqrt(K1 / M1))),
    ):
        assert sdof(d).poles()[1][0] == pytest.approx(zeta, rel=1e-12)


# ---- the FE model ----------------------------------------------------------------------------


def _cantilever(regions=("pedicle",)):
    """A P1 cantilever box, optionally split into two regions along its length (for per-region tests)."""
    B, H, L = 55e-6, 160e-6, 550e-6
    m = box_mesh((B, H, L), (1, 2, 10), origin_m=(-B / 2, -H / 2, 0), region_name="pedicle")
    region = m.region.copy()
    if len(regions) == 2:  # the half near the clamp becomes the second region
        centroid_z = m.points[m.tets].mean(axis=1)[:, 2]
        region = np.where(centroid_z < L / 2, 1, 0)
    model = ElasticModel(TetMesh(m.points, m.tets, region, tuple(regions), m.faces), 1)
    model.unit_load = traction_load(model.space, "loaded", [1.0, 0.0, 0.0])
    return model


MAT = Materials(pedicle_e_pa=5e9, incus_e_pa=12e9, nu=0.0)


def test_fe_modal_damping_of_one_region_is_the_single_dof_one():
    """One region: proportional damping, ζ_m = η/2 + a/(2ω_m) + bω_m/2 for every mode."""
    model = _cantilever()
    d = Damping.uniform(rayleigh_a_per_s=200.0, rayleigh_b_s=1e-7, loss_factor=0.04)
    f, zeta = dynamics.modal_damping(model, MAT, d, n=3)
    w = 2 * np.pi * f
    np.testing.assert_allclose(zeta, 0.02 + 200.0 / (2 * w) + 1e-7 * w / 2, rtol=1e-9)


def test_energy_per_cycle_is_2_pi_eta_u_max(coarse_model):
    """Uniform loss factor: the pressure's work per cycle equals 2π η U_max, U_max the largest strain
    energy over the cycle, ¼(ûᴴKû + |ûᵀKû|) for u(t) = Re(û e^{iωt}). Exact where the model moves in
    phase; the modes' different phases make it measured 4e-11 at 100 Hz, 1.3e-7 at 10 kHz (f1 ≈ 21
    kHz on this mesh). Also, the work equals the energy the loss factor dissipates, π ûᴴLû."""
    eta = 0.1
    m, d = Materials(), Damping.uniform(loss_factor=eta)
    K, L, _, _ = dynamics.damping_matrices(coarse_model, m, d)
    red = coarse_model.reduction
    f = red.restrict(coarse_model.unit_load)
    u_all = dynamics.harmonic(coarse_model, [100.0, 2e3, 1e4], m, d, pressure_pa=1.0)
    for u_full, tol in zip(u_all, (1e-9, 1e-8, 1e-6), strict=True):
        u = red.restrict(u_full)
        work = -np.pi * f @ u.imag  # ∮ fᵀ du over one period, f real
        Ku = K @ u
        u_max = 0.25 * (np.real(u.conj() @ Ku) + abs(u @ Ku))
        assert work == pytest.approx(2 * np.pi * eta * u_max, rel=tol)
        assert work == pytest.approx(np.pi * np.real(u.conj() @ (L @ u)), rel=1e-8)  # energy balance


@pytest.mark.slow
def test_energy_balance_with_the_published_damping(coarse_model):
    """Non-proportional damping near resonance: the pressure's work per cycle is π ûᴴ(L + ωC)û."""
    m = Materials()
    d = Damping()
    K, L, C, _ = dynamics.damping_matrices(coarse_model, m, d)
    f = coarse_model.reduction.restrict(coarse_model.unit_load)
    for freq in (5e3, 19e3):
        u = coarse_model.reduction.restrict(dynamics.harmonic(coarse_model, [freq], m, d, 1.0)[0])
        w = 2 * np.pi * freq
        work = -np.pi * f @ u.imag
        assert work == pytest.approx(np.pi * np.real(u.conj() @ ((L + w * C) @ u)), rel=1e-7)


def test_equal_region_factors_reduce_to_the_uniform_case():
    """Per-region loss factors and Rayleigh terms, all equal: the matrices are η K, a M + b K, and the
    general (projected and direct) solves give the proportional (shifted Lanczos) answer."""
    model = _cantilever(("pedicle", "incus"))
    eq = {"pedicle": 0.05, "incus": 0.05}
    per_region = Damping(loss_factor=eq, rayleigh_b_s={"pedicle": 3e-8, "incus": 3e-8}, rayleigh_a_per_s=0.0)
    uniform = Damping.uniform(rayleigh_b_s=3e-8, loss_factor=0.05)
    K, L, C, M = dynamics.damping_matrices(model, MAT, per_region)
    np.testing.assert_allclose(L.data, 0.05 * K.data, rtol=1e-14, atol=1e-14 * abs(K.data).max())
    np.testing.assert_allclose(C.data, 3e-8 * K.data, rtol=1e-14, atol=1e-14 * abs(K.data).max())
    freqs = np.array([100.0, 3e4, 1e5])
    u_uniform = dynamics.harmonic(model, freqs, MAT, uniform, pressure_pa=1.0)
    assert per_region.uniform_values(model.regions) == (0.0, 3e-8, 0.05)
    f = model.reduction.restrict(model.unit_load)
    model._solver.factor(K)
    x, ok, _ = dynamics._projected(model._solver.solve, K, L, C, M, f, 2 * np.pi * freqs)
    xd = dynamics._direct_general(model, K, L, C, M, f, 2 * np.pi * freqs)
    ref = np.stack([model.reduction.restrict(u) for u in u_uniform])
    assert ok.all()
    for sol in (x, xd):
        assert np.all(np.linalg.norm(sol - ref, axis=1) < 1e-8 * np.linalg.norm(ref, axis=1))


def test_two_region_loss_factors_against_a_direct_solve():
    """Different loss factors per region: the projected solve against the complex direct solve."""
    model = _cantilever(("pedicle", "incus"))
    d = Damping(loss_factor={"pedicle": 0.01, "incus": 0.3})
    freqs = [100.0, 2e4, 6e4]
    u = dynamics.harmonic(model, freqs, MAT, d, pressure_pa=1.0)
    u_direct = dynamics.harmonic(model, freqs, MAT, d, pressure_pa=1.0, method="direct")
    for a, b in zip(u, u_direct, strict=True):
        assert np.linalg.norm(a - b) < 1e-7 * np.linalg.norm(b)
    # and the response is not that of either uniform loss factor
    for eta in (0.01, 0.3):
        u_eta = dynamics.harmonic(model, freqs[:1], MAT, Damping.uniform(loss_factor=eta), pressure_pa=1.0)
        assert np.linalg.norm(u_eta[0] - u[0]) > 1e-3 * np.linalg.norm(u[0])


def test_lumped_region_stiffnesses_sum_to_the_stiffness():
    """The chain's K_r = E_r ∂K/∂E_r (complex step) add up to K (degree-one homogeneity): equal loss
    factors give K_loss = η K, as in the FE model."""
    from isj.lumped.artifact import default_calibration
    from isj.lumped.dynamics import _chain_stiffness_matrix, _springs, chain_model
    from isj.lumped.model import moduli_arrays

    from isj.design import Geometry

    cal = default_calibration()
    f, s, g = cal.factor_array(), cal.shear_factor, Geometry()
    E = moduli_arrays(pedicle_e_pa=np.array([2e9, 5e9, 20e9]), gap_e_pa=np.array([3e6, 10e6, 40e6]))

    def build(Ec):
        return _chain_stiffness_matrix(_springs(f, s, g, 0.3, Ec))

    K = build(E)
    parts = region_stiffness(build, E)
    np.testing.assert_allclose(sum(parts.values()), K, rtol=0, atol=1e-13 * abs(K).max())
    _, K_loss = damping_terms(Damping(loss_factor=dict.fromkeys(REGIONS, 0.07)), parts)
    np.testing.assert_allclose(K_loss, 0.07 * K, rtol=0, atol=1e-13 * abs(K).max())
    # the joint rotation's spring takes a mix of the gap's and the capsule's (and plate's) factors
    chain = chain_model(f, s, g, pedicle_e_pa=5e9)
    eta_joint = chain.K_loss[2, 2] / chain.K[2, 2]
    assert 0.01 < eta_joint < 0.15
    assert chain.K_loss[4, 4] / chain.K[4, 4] == pytest.approx(0.01, rel=1e-12)  # the pedicle: bone


def test_ear_parts_with_equal_factors_reduce_to_the_uniform_case():
    from isj.fem.ear.dynamics import damping_data
    from isj.fem.ear.middle_ear import MiddleEarModel

    ear = MiddleEarModel()  # the rigid joint: seconds
    K = ear.stiffness()
    eq = dict.fromkeys(STIFFNESS_PARTS, 0.2)
    L, C = damping_data(ear, Damping(loss_factor=eq, cochlear_impedance_pa_s_m3=0.0))
    np.testing.assert_allclose(L, 0.2 * K.data, rtol=0, atol=1e-14 * abs(K.data).max())
    assert not C.any()
    L, C = damping_data(ear, Damping.uniform(rayleigh_b_s=1e-5, rayleigh_a_per_s=30.0))
    Ma = ear.mass().data
    np.testing.assert_allclose(C, 1e-5 * K.data + 30.0 * Ma, rtol=0, atol=1e-13 * abs(C).max())


# ---- the damping description -----------------------------------------------------------------


def test_presets_and_published_defaults():
    d = Damping()
    assert d == Damping.preset("published") and hash(d) == hash(Damping())
    assert d.loss_factor["pedicle"] == 0.01 and d.loss_factor["gap"] == 0.15
    assert d.loss_factor["eardrum"] == 0.1 and d.loss_factor["annular_ligament"] == 0.3
    assert d.cochlear_impedance_pa_s_m3 == 1.2e11
    old = Damping.preset("uniform-rayleigh")
    assert set(old.rayleigh_b_s.values()) == {1e-4} and not any(old.loss_factor.values())
    assert old.cochlear_impedance_pa_s_m3 == 0.0
    none = Damping.preset("undamped")
    assert not none.damped()
    assert Damping.from_dict(d.to_dict()) == d
    changed = d.replace(loss_factor={"pedicle": 0.05}, rayleigh_b_s=1e-6)
    assert changed.loss_factor["pedicle"] == 0.05 and changed.loss_factor["gap"] == 0.15
    assert set(changed.rayleigh_b_s.values()) == {1e-6}


@pytest.mark.parametrize(
    "make, name",
    [
        (lambda: Damping(loss_factor={"pedicel": 0.1}), "pedicel"),
        (lambda: Damping(rayleigh_b_s=-1.0), "rayleigh_b_s"),
        (lambda: Damping(loss_factor={"gap": float("nan")}), "loss_factor"),
        (lambda: Damping(rayleigh_a_per_s={"annular_ligament": 1.0}), "annular_ligament"),
        (lambda: Damping(cochlear_impedance_pa_s_m3=True), "cochlear_impedance_pa_s_m3"),
        (lambda: Damping.preset("rayleigh"), "preset"),
    ],
)
def test_bad_damping_is_refused_naming_the_parameter(make, name):
    with pytest.raises(InvalidParameter, match=name):
        make()


def test_rayleigh_warning_names_the_term_and_where_it_exceeds_one_half():
    with pytest.warns(DampingWarning, match=r"rayleigh_b_s = 0.0001 s .*above 795.8 Hz"):
        warn_rayleigh_band(Damping.preset("uniform-rayleigh"), 100.0, 20e3)
    with pytest.warns(DampingWarning, match=r"rayleigh_a_per_s = 1000 1/s \(pedicle\).*below 318.3 Hz"):
        warn_rayleigh_band(Damping(rayleigh_a_per_s={"pedicle": 1000.0}), 100.0, 20e3)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert warn_rayleigh_band(Damping(), 100.0, 20e3) == []  # loss factors: no warning
        assert warn_rayleigh_band(Damping.preset("uniform-rayleigh"), 100.0, 700.0) == []  # ωb < 0.45


# ---- the isolated model with the new defaults (issue 13 part 7) --------------------------------


@pytest.mark.slow
@pytest.mark.filterwarnings("ignore::isj.errors.DampingWarning")
def test_isolated_model_with_the_published_damping(coarse_model):
    """No roll-off from the damping law below f1/2 and a visible first resonance (FE), and the chain's
    α(f)/α(0), β(f)/β(0) at the same fraction of its own f1 within 2 % of FE's below 0.8 f1.

    Below f1/2 a lightly damped structure rises as 1/(1 − (f/f1)²) (1.33 at f1/2), so "flat" is
    |α(f)/α(0)| (1 − (f/f1)²) within 10 % of 1; the old uniform b = 1e-4 s fails it (0.12 at f1/2).
    On this coarse mesh the chain's static α and f1 differ from FE's by 3 % and 5 % (mesh error),
    hence each model at its own f1; docs/dynamics.md §4.9 has the default mesh, same frequencies.
    """
    from isj.lumped.artifact import default_calibration
    from isj.lumped.dynamics import chain_model, chain_outputs

    m = Materials()
    f_fe, zeta = dynamics.modal_damping(coarse_model, m, Damping(), n=1)
    assert 0.005 < zeta[0] < 0.075  # between the bone's η/2 and the joint's
    r = np.array([0.0, 0.25, 0.5, 0.8, 1.0])
    fe = coarse_model.angles[:2] @ dynamics.harmonic(coarse_model, r * f_fe[0], m, pressure_pa=1.0).T
    fe_norm = np.abs(fe / fe[:, :1])  # rows α, β
    flat = fe_norm[:, :3] * (1 - r[:3] ** 2)
    assert np.all(np.abs(flat - 1) < 0.1), flat
    assert np.all(fe_norm[:, 4] > 10)  # the first resonance shows: ≈ 1/(2ζ)
    old = (
        coarse_model.angles[:2]
        @ dynamics.harmonic(coarse_model, [0.0, 0.5 * f_fe[0]], m, "uniform-rayleigh", 1.0).T
    )
    assert np.all(np.abs(old[:, 1] / old[:, 0]) * 0.75 < 0.2)  # the old damping's roll-off
    cal = default_calibration()
    chain = chain_model(
        cal.factor_array(), cal.shear_factor, None, m, **{f"{k}_e_pa": m.youngs(k) for k in REGIONS}
    )
    f_lu = chain.poles()[0][0]
    lu = chain_outputs(chain, r * f_lu, 1.0)[:, :2].T
    lu_norm = np.abs(lu / lu[:, :1])
    np.testing.assert_allclose(lu_norm[:, :4], fe_norm[:, :4], rtol=0.02)


# ---- the report's [sweep] keys and the command line ---------------------------------------------


def test_report_config_damping_keys_resolve_and_list_every_value(tmp_path):
    import tomllib

    from isj.reports.config import load_config

    case = tmp_path / "case.toml"
    case.write_text('[sweep]\ndamping = "uniform-rayleigh"\nloss_factor = {gap = 0.2}\n')
    cfg = load_config(case, ["sweep.rayleigh_b_s={pedicle=1e-6}"])
    d = cfg.sweep.damping_model()
    assert d.loss_factor["gap"] == 0.2 and d.loss_factor["pedicle"] == 0.0  # the preset's, then the file's
    assert d.rayleigh_b_s["pedicle"] == 1e-6 and d.rayleigh_b_s["incus"] == 1e-4
    assert d.cochlear_impedance_pa_s_m3 == 0.0
    resolved = tomllib.loads(cfg.to_toml())["sweep"]
    assert resolved["damping"] == "uniform-rayleigh" and set(resolved["loss_factor"]) == set(STIFFNESS_PARTS)
    again = tmp_path / "resolved.toml"
    again.write_text(cfg.to_toml())
    assert load_config(again).sweep.damping_model() == d  # the resolved file gives the same damping
    assert load_config().sweep.damping_model() == Damping()  # the default: the published one


@pytest.mark.parametrize(
    "override, word",
    [
        ("sweep.loss_factor={pedicel=0.2}", "pedicel"),
        ('sweep.damping="rayleigh"', "sweep.damping"),
        ("sweep.rayleigh_b_s=-1", "sweep.rayleigh_b_s"),
        ("sweep.loss_factor=true", "sweep.loss_factor"),
    ],
)
def test_report_config_bad_damping_is_one_line_naming_it(override, word):
    from isj.reports.config import load_config

    from isj.errors import ConfigError

    with pytest.raises(ConfigError) as exc:
        load_config(overrides=[override])
    assert word in str(exc.value) and "\n" not in str(exc.value)


def test_cli_damping_options(tmp_path, capsys):
    from isj._cli._main import main

    out = tmp_path / "s"
    args = ["sweep", "--fe-checks", "0", "--n", "5", "--json", "--out", str(out)]
    assert main([*args, "--damping", "undamped", "--loss-factor", "0.05", "--loss-factor", "gap=0.2"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert (
        summary["damping"]["loss_factor"]["gap"] == 0.2 and summary["damping"]["loss_factor"]["incus"] == 0.05
    )
    assert summary["damping"]["cochlear_impedance_pa_s_m3"] == 0.0  # the preset's
    for bad in (
        ["--loss-factor", "pedicel=0.1"],
        ["--rayleigh-a", "annular_ligament=1"],
        ["--loss-factor", "gap=-1"],
        ["--damping", "rayleigh"],
    ):
        assert main([*args[:-1], str(tmp_path / "t"), *bad]) == 2
        err = capsys.readouterr().err
        assert err.startswith("isj: error:") and len(err.strip().splitlines()) == 1
        assert bad[0] in err or bad[1] in err
        assert not (tmp_path / "t").exists()


def test_ear_modal_damping_uniform_loss_factor_is_half_eta():
    from isj.fem.ear.dynamics import modal_damping
    from isj.fem.ear.middle_ear import MiddleEarModel

    ear = MiddleEarModel()
    f, zeta = modal_damping(ear, 3, damping=Damping.uniform(loss_factor=0.08))
    np.testing.assert_allclose(zeta, 0.04, rtol=1e-8)
    f, zeta = modal_damping(ear, 3)  # published: the drum's 0.1, the ligaments' and the cochlea's
    assert np.all(zeta > 0.05) and np.all(f > 1e3)


def test_damping_pickles_and_a_region_without_damping_is_named():
    import pickle

    d = Damping(loss_factor={"gap": 0.2}, rayleigh_b_s={"eardrum": 1e-6})
    assert pickle.loads(pickle.dumps(d)) == d  # for process pools
    model = _cantilever(("block",))
    with pytest.raises(InvalidParameter, match="'block'"):
        dynamics.harmonic(model, [100.0], MAT)
