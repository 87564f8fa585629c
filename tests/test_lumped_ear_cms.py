"""The lumped ear with the drum's component modes (lumped/ear_drum.py, fem/ear/drum_modes.py) against FE.

On the coarse drum mesh (0.4 mm, the coarsest the drum accepts), the FE ear's rigid-joint
harmonic solves (fem/ear/dynamics.py, published damping) take 0.06 s a frequency. Measured
there (benchmarks/lumped_ear_cms.py --drum-mesh-m 0.4e-3), lumped / FE, 14 frequencies from
200 Hz to 8 kHz, umbo and stapes per Pa:

- no modes (the one static shape): within 1 dB and 10° only below 1.9 kHz (the coarse drum's
  first fixed-interface mode is at 1769 Hz), 17.9 dB and 107° off by 3.4 kHz;
- 10 modes (to 3.35 kHz): below 3.4 kHz; 20 (to 4.8 kHz): below 4.5 kHz; 30 (to 5.7 kHz): below
  6.0 kHz; 40 (to 6.6 kHz): to 6 kHz (4.3 dB off at 8 kHz), worst 0.06 dB and 0.6° up to
  5 kHz; 60 (to 8.7 kHz): to 8 kHz;
- the joint inside (P2, resolution 0.35) at 3 kHz: no modes +4.2 dB −73° (umbo), 40 modes
  −0.02 dB −3.8° (umbo), +0.12 dB +4.2° (stapes).

Tolerances below are those measurements with margin; the exactness checks (the truncation,
the condensation, n = 0 against the one-shape drum) are to rounding.
"""

import dataclasses

import gmsh  # noqa: F401 - a hard dependency: without it these tests fail, they do not skip
import numpy as np
import pytest
from isj.lumped.ear import EardrumParameters, ear_model
from isj.lumped.ear_drum import DrumModes, default_drum_modes, freq_resp
from isj.lumped.second_order import SecondOrderModel

from isj.damping import resolve
from isj.ear import EarMaterials
from isj.errors import InvalidParameter
from isj.validate import EAR_FMAX_HZ

H = 0.4e-3  # the coarse drum mesh (m)
F = np.geomspace(200.0, 8000.0, 14)  # the measurement's frequencies (Hz)


@pytest.fixture(scope="module")
def drum():
    from isj.fem.ear.lumped_params import eardrum_parameters

    return EardrumParameters.from_dict(eardrum_parameters(mesh_size_m=H))


@pytest.fixture(scope="module")
def modes():
    from isj.fem.ear.drum_modes import drum_modes

    return DrumModes.from_dict(drum_modes(n_modes=60, mesh_size_m=H))


@pytest.fixture(scope="module")
def fe():
    from isj.fem.ear.middle_ear import MiddleEarModel

    return MiddleEarModel(drum_mesh_size_m=H)


@pytest.fixture(scope="module")
def fe_rigid(fe):
    """FE outputs (umbo, stapes per Pa) at 1 Hz and at :data:`F`, published damping."""
    return fe.frequency_response(np.concatenate([[1.0], F])).response[..., 0]


def _db_deg(a, b):
    r = np.asarray(a) / np.asarray(b)
    return 20 * np.log10(np.abs(r)), np.degrees(np.angle(r))


def _system_arrays(ear):
    s = ear.system
    return [s.M, s.E, s.K, s.K_loss, s.B, s.C]


def test_no_modes_is_the_one_shape_drum(drum, modes):
    # the residual of 0 modes is the whole static pressure shape (Guyan plus one static shape)
    m0 = modes.truncated(0)
    assert m0.residual_compliance_m3_per_pa == pytest.approx(drum.compliance_m3_per_pa, rel=1e-12)
    assert m0.residual_mass_kg_m4 == pytest.approx(drum.uncoupled_mass_kg_m4, rel=1e-10)
    np.testing.assert_allclose(m0.residual_cross_mass, drum.cross_mass, rtol=1e-9, atol=1e-12)
    for kw in ({"rigid_joint": True}, {}, {"body": "rotation"}):
        a = ear_model(eardrum=drum, **kw)
        b = ear_model(eardrum=drum, drum_modes=m0, **kw)
        assert a.coordinates == b.coordinates and b.drum_modes is None
        for x, y in zip(_system_arrays(a), _system_arrays(b), strict=True):
            np.testing.assert_allclose(y, x, rtol=1e-9, atol=1e-12 * np.abs(x).max())
        np.testing.assert_allclose(b._freq_resp(F), a._freq_resp(F), rtol=1e-8)


def test_truncation_is_exact(modes):
    from isj.fem.ear.drum_modes import drum_modes

    ten = DrumModes.from_dict(drum_modes(n_modes=10, mesh_size_m=H))
    cut = modes.truncated(10)
    np.testing.assert_allclose(cut.freq_hz, ten.freq_hz, rtol=1e-9)
    np.testing.assert_allclose(np.abs(cut.load_per_pa), np.abs(ten.load_per_pa), rtol=1e-6, atol=1e-12)
    for f in ("residual_compliance_m3_per_pa", "residual_mass_kg_m4"):
        assert getattr(cut, f) == pytest.approx(getattr(ten, f), rel=1e-8), f
    np.testing.assert_allclose(cut.residual_cross_mass, ten.residual_cross_mass, rtol=1e-7, atol=1e-12)
    assert modes.up_to(modes.freq_hz[9]).n_modes == 10 and modes.up_to(1.0).n_modes == 0


@pytest.mark.parametrize(
    "kw",
    [
        {},
        {"rigid_joint": True},
        {"body": "rotation"},
        {"damping": "uniform-rayleigh"},
        {"rayleigh_a_per_s": {"eardrum": 300.0, "incus": 50.0}},
        {"gap_e_pa": np.array([2e6, 10e6, 40e6])},
    ],
)
def test_condensed_modes_equal_the_dense_solve(kw):
    ear = ear_model(drum_modes=30, **kw)
    f = np.geomspace(100.0, 20e3, 23)
    dense = ear.system.freq_resp(f)[..., 0]
    np.testing.assert_allclose(ear._freq_resp(f), dense, rtol=1e-9, atol=1e-9 * np.abs(dense).max())
    if not ear.batched:  # the FrequencyResponse takes the same path
        np.testing.assert_array_equal(ear.frequency_response(f).response[..., 0], ear._freq_resp(f))


def test_condensation_of_a_general_system():
    # a random system whose last coordinates have a diagonal block, outputs and loads on them too
    rng = np.random.default_rng(3)
    nc, nm = 4, 5
    n = nc + nm

    def spd(scale):
        A = rng.normal(size=(n, n))
        A = A @ A.T + n * np.eye(n)
        A[nc:, nc:] = np.diag(np.diag(A[nc:, nc:]))
        return scale * A

    s = SecondOrderModel(
        M=spd(1.0),
        E=spd(0.01),
        K=spd(1e4),
        B=rng.normal(size=(n, 2)),
        C=rng.normal(size=(3, n)),
        K_loss=spd(1e2),
        loss_factor=0.02,
    )
    f = np.geomspace(0.1, 100.0, 17)
    np.testing.assert_allclose(freq_resp(s, slice(nc, n), f), s.freq_resp(f), rtol=1e-10, atol=1e-14)
    couple = np.zeros((n, n))
    couple[nc, nc + 1] = couple[nc + 1, nc] = 0.1
    bad = dataclasses.replace(s, M=s.M + couple)  # couples two modes
    with pytest.raises(ValueError, match="not diagonal"):
        freq_resp(bad, slice(nc, n), f)


def test_one_hz_is_the_static_response(drum, modes, fe_rigid):
    static = None
    for n in (0, 20, 60):
        m = modes.truncated(n)
        undamped = ear_model(rigid_joint=True, eardrum=drum, drum_modes=m, damping="undamped")
        s = undamped.static().outputs
        h1 = undamped._freq_resp([1.0])[0]
        np.testing.assert_allclose(h1.real, s, rtol=1e-5)  # (1 Hz / 1.8 kHz)² ≈ 3e-7
        static = s if static is None else static
        np.testing.assert_allclose(s, static, rtol=1e-10)  # the static shape is in every subspace
        damped = ear_model(rigid_joint=True, eardrum=drum, drum_modes=m)._freq_resp([1.0])[0, :2]
        np.testing.assert_allclose(damped, fe_rigid[0, :2], rtol=1e-3)  # the footplate's flexibility


def test_error_against_fe_decreases_with_the_modes(drum, modes, fe):
    f = np.array([4000.0])
    ref = fe.frequency_response(f).response[..., 0][0, :2]
    err = []
    for n in (0, 10, 20, 30, 40, 60):
        h = ear_model(rigid_joint=True, eardrum=drum, drum_modes=modes.truncated(n))._freq_resp(f)[0, :2]
        err.append(np.abs(h / ref - 1).max())
    assert np.all(np.diff(err) < 0), err
    assert err[0] > 0.5 and err[-1] < 5e-3, err


def test_agreement_goal_on_the_coarse_mesh(drum, modes, fe_rigid):
    fe = fe_rigid[1:, :2]
    to5 = F <= 5000
    ear = ear_model(rigid_joint=True, eardrum=drum, drum_modes=modes.truncated(40))
    db, deg = _db_deg(ear._freq_resp(F)[:, :2], fe)
    # the goal: 1 dB and 10° up to 5 kHz; measured 0.06 dB, 0.6° there, and within the goal to
    # 6 kHz (4.3 dB off at 8 kHz, past the 40th mode at 6.6 kHz)
    assert np.abs(db[to5]).max() < 0.2 and np.abs(deg[to5]).max() < 2.0, (db, deg)
    to6 = F < 6500
    assert np.abs(db[to6]).max() < 1.0 and np.abs(deg[to6]).max() < 10.0
    # before: the one-shape drum leaves the goal above the first drum mode (1.77 kHz here)
    db0, deg0 = _db_deg(ear_model(rigid_joint=True, eardrum=drum)._freq_resp(F)[:, :2], fe)
    bad = (np.abs(db0) > 1) | (np.abs(deg0) > 10)
    assert not bad[F < 1500].any() and bad[(F > 1800) & to5].any()


def test_modes_take_the_drums_damping(drum, modes, fe):
    # the modal block carries the eardrum's loss factor and Rayleigh b, as the FE drum's K does
    ear = ear_model(rigid_joint=True, eardrum=drum, drum_modes=modes.truncated(20))
    s, m = ear.system, ear.drum_modes
    np.testing.assert_allclose(np.diag(s.K_loss[m, m]), 0.1 * np.diag(s.K[m, m]), rtol=1e-12)
    # a heavier drum loss against the FE ear's, near the drum's modes
    dmp = {"loss_factor": {"eardrum": 0.3}, "rayleigh_b_s": {"eardrum": 2e-6}}
    f = np.array([2500.0, 3500.0])
    ref = fe.frequency_response(f, damping=resolve(None, **dmp)).response[..., 0]
    h = ear_model(rigid_joint=True, eardrum=drum, drum_modes=modes.truncated(40), **dmp)._freq_resp(f)
    db, deg = _db_deg(h[:, :2], ref[:, :2])
    assert np.abs(db).max() < 0.1 and np.abs(deg).max() < 1.0, (db, deg)


def test_drum_modulus_rescaling_is_exact(modes):
    from isj.fem.ear.drum_modes import drum_modes

    mat = EarMaterials(drum_e_pa=40e6)
    fresh = DrumModes.from_dict(drum_modes(materials=mat, n_modes=12, mesh_size_m=H))
    scaled = modes.truncated(12).with_modulus(40e6)
    np.testing.assert_allclose(scaled.freq_hz, fresh.freq_hz, rtol=1e-9)
    for f in ("residual_compliance_m3_per_pa", "residual_mass_kg_m4"):
        assert getattr(scaled, f) == pytest.approx(getattr(fresh, f), rel=1e-8), f


@pytest.mark.slow
def test_joint_inside_against_fe(drum, modes, coarse_model):
    from isj.fem.ear.middle_ear import MiddleEarModel

    f = np.array([3000.0])
    ref = MiddleEarModel(joint=coarse_model, drum_mesh_size_m=H).frequency_response(f).response[..., 0]
    db, deg = _db_deg(ear_model(eardrum=drum, drum_modes=modes.truncated(40))._freq_resp(f), ref)
    # measured: umbo −0.02 dB −3.8°, stapes +0.12 dB +4.2°, α +0.45 dB, β −0.01 dB
    assert np.abs(db[0, :2]).max() < 0.5 and np.abs(deg[0, :2]).max() < 7.0, (db, deg)
    assert np.abs(db[0, 2:]).max() < 1.0
    db0, deg0 = _db_deg(ear_model(eardrum=drum)._freq_resp(f), ref)
    assert np.abs(deg0[0, :2]).max() > 30  # without the modes: ≈ 70° off


def test_shipped_modes_are_the_default_drums():
    from isj.fem.ear.drum_modes import drum_modes

    shipped = default_drum_modes()
    assert shipped.n_modes == 300 and shipped.freq_hz[0] == pytest.approx(1721, rel=1e-3)
    assert shipped.freq_hz[-1] > EAR_FMAX_HZ  # the ear's band is inside the shipped modes
    fresh = DrumModes.from_dict(drum_modes(n_modes=40))
    cut = shipped.truncated(40)
    np.testing.assert_allclose(cut.freq_hz, fresh.freq_hz, rtol=1e-8)
    assert cut.residual_compliance_m3_per_pa == pytest.approx(fresh.residual_compliance_m3_per_pa, rel=1e-7)
    f = np.geomspace(200.0, 8000.0, 9)
    a = ear_model(rigid_joint=True, drum_modes=cut)._freq_resp(f)
    b = ear_model(rigid_joint=True, drum_modes=fresh)._freq_resp(f)
    np.testing.assert_allclose(a, b, rtol=1e-6)


@pytest.mark.parametrize("value", ["40", -1, 301, 2.5, True])
def test_bad_drum_modes(value):
    with pytest.raises(InvalidParameter, match="drum_modes|n ="):
        ear_model(drum_modes=value)


def test_bad_mode_data(drum, modes):
    with pytest.raises(InvalidParameter, match="shipped drum"):
        ear_model(eardrum=drum, drum_modes=10)  # the coarse drum with the default drum's modes
    with pytest.raises(InvalidParameter, match="reference_m"):
        ear_model(drum_modes=dataclasses.replace(modes, reference_m=(0.0, 0.0, 0.0)))
    with pytest.raises(InvalidParameter, match="ascending"):
        dataclasses.replace(modes, freq_hz=modes.freq_hz[::-1])
    with pytest.raises(InvalidParameter, match="shape"):
        dataclasses.replace(modes, load_per_pa=modes.load_per_pa[1:])
    with pytest.raises(InvalidParameter, match="drum_e_pa"):
        modes.with_modulus(-1.0)
