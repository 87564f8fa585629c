"""The FE ear's reduced model (fem/ear/joint_condensation.py, reduced_ear.py) against direct FE solves.

On a coarse joint mesh (P2, resolution 0.35, as tests/test_ear.py) and the default drum. The
references are computed by other code: the direct harmonic solves of
:func:`fem.ear.dynamics.harmonic` (one complex factorization of the whole ear per
frequency), the static solve of :meth:`MiddleEarModel.static` and the FE ear's own modes.
"""

import numpy as np
import pytest
from isj.fem.ear.dynamics import reduced_mass
from isj.fem.ear.joint_condensation import ear_parts, orthonormalize
from isj.fem.ear.middle_ear import MiddleEarModel
from isj.fem.ear.reduced_ear import (
    OUTPUTS,
    UNITS,
    agreement_limit_hz,
    check_against_direct,
    check_frequencies_hz,
    footplate_fit,
    reduced_ear,
)
from isj.fem.model import PedicleJointModel

from isj.damping import Damping

pytestmark = pytest.mark.slow  # reduces the FE ear (module fixture)

#: The band the test model is reduced for: past the first drum modes, as far as the sweep's 20 kHz.
FMAX_HZ = 20e3
MAG, PHASE_DEG = 1e-3, 0.1


@pytest.fixture(scope="module")
def ear():
    return MiddleEarModel(joint=PedicleJointModel(order=2, resolution=0.35))


@pytest.fixture(scope="module")
def rom(ear):
    return reduced_ear(ear, fmax_hz=FMAX_HZ)


@pytest.fixture(scope="module")
def modes(ear):
    return ear.natural_frequencies_hz(6)


def _compare(a, b):
    mag = np.abs(np.abs(a) / np.abs(b) - 1)
    phase = np.abs(np.degrees(np.angle(a / b)))
    return mag, phase


def test_parts_add_up_to_the_model(ear):
    parts = ear_parts(ear)
    K, M = ear.stiffness(), reduced_mass(ear)
    assert abs(parts.total_stiffness() - K).max() <= 1e-12 * abs(K).max()
    assert abs(parts.total_mass() - M).max() <= 1e-12 * abs(M).max()
    assert set(ear.joint.regions) <= set(parts.stiffness) and set(ear.joint.regions) <= set(parts.mass)
    # the cochlea: a unit resistance along the piston direction, shared by the outline nodes
    D = parts.dashpots["cochlea"]
    assert D.sum() == pytest.approx(1.0, rel=1e-12)
    assert abs(D - D.T).max() == 0


def test_reduced_equals_direct_near_and_between_resonances(ear, rom, modes):
    f1 = float(modes[0])
    freqs = np.array([300.0, f1, 5000.0, 15000.0])
    direct = ear.frequency_response(freqs).response[..., 0]  # published damping: per part, the cochlea
    mag, phase = _compare(rom._outputs(freqs), direct)
    assert mag.max() <= MAG and phase.max() <= PHASE_DEG, (mag, phase)


def test_other_damping_without_a_new_reduction(ear, rom):
    """A different loss factor per part, a dashpot on the ligaments, no cochlea: the same basis."""
    damping = Damping(
        loss_factor={"eardrum": 0.3, "gap": 0.5, "capsule": 0.05, "pedicle": 0.1, "annular_ligament": 0.05},
        rayleigh_b_s={"mallear_ligament": 5e-6, "incudal_ligaments": 5e-6},
        cochlear_impedance_pa_s_m3=0.0,
    )
    freqs = np.array([1000.0, 8000.0])
    direct = ear.frequency_response(freqs, damping=damping).response[..., 0]
    mag, phase = _compare(rom._outputs(freqs, damping), direct)
    assert mag.max() <= MAG and phase.max() <= PHASE_DEG, (mag, phase)


def test_one_hertz_is_the_static_solution(ear, rom):
    static = ear.static()
    r = rom.frequency_response([1.0], "undamped")
    stapes = r["stapes_m"][0]
    assert stapes.real == pytest.approx(static.footplate_piston_m_per_pa, rel=1e-6)
    assert abs(stapes.imag) <= 1e-9 * abs(stapes)
    assert r["umbo_m"][0].real == pytest.approx(static.umbo_m_per_pa, rel=1e-6)
    assert r["alpha_rad"][0].real == pytest.approx(static.alpha_rad_per_pa, rel=1e-6)
    assert r["beta_rad"][0].real == pytest.approx(static.beta_rad_per_pa, rel=1e-6)
    assert r["stapes_velocity_m_s"][0] == pytest.approx(2j * np.pi * stapes, rel=1e-12)


def test_reduced_matrices_symmetric_and_modes_match_the_fe_ear(rom, modes):
    assert rom.info["asymmetry"] <= 1e-12  # before the rounding is symmetrised away
    K, M = rom.total_stiffness(), rom.total_mass()
    assert np.array_equal(K, K.T) and np.array_equal(M, M.T)
    assert np.linalg.eigvalsh(M).min() > 0
    assert rom.diagonal_interior and rom.info["interior_off_diagonal"] <= 1e-10
    f = rom.natural_frequencies_hz(6)
    assert np.abs(f / modes - 1).max() <= 1e-3, (f, modes)


def test_field_quantities_and_their_identities(rom):
    freqs = np.geomspace(100, 20e3, 7)
    r = rom.frequency_response(freqs)
    assert r.output_names == OUTPUTS and r.output_units == UNITS and r.input_units == ("Pa",)
    iw = 2j * np.pi * freqs
    assert np.allclose(r["stapes_velocity_m_s"], iw * r["stapes_m"], rtol=1e-12, atol=0)
    assert np.allclose(r["umbo_velocity_m_s"], iw * r["umbo_m"], rtol=1e-12, atol=0)
    a, b = r["alpha_rad"], r["beta_rad"]
    assert np.allclose(r["pedicle_share"], b / (a + b), rtol=1e-12, atol=0)
    # the footplate moves mostly as a piston at low frequency: its fit's piston is the centre's
    assert r["footplate_piston_m"][0] == pytest.approx(r["stapes_m"][0], rel=0.05)


def test_footplate_fit_recovers_a_plane(ear):
    g, fp = ear.geometry, ear.footplate
    e_long = np.asarray(g.footplate_long_axis)
    e_short = np.cross(fp.normal, e_long)
    r = fp.nodes_m - np.asarray(g.footplate_centre_m)
    w0, th_l, th_s = 3e-9, 2e-6, -5e-6
    # a rigid rotation θ about e_long moves a point r along n by θ (e_long × r)·n
    w = w0 + th_l * np.cross(e_long, r) @ fp.normal + th_s * np.cross(e_short, r) @ fp.normal
    assert footplate_fit(fp, g) @ w == pytest.approx([w0, th_l, th_s], rel=1e-10)


def test_rigid_joint_reduced_against_direct():
    ear = MiddleEarModel()
    rom = reduced_ear(ear, fmax_hz=10e3)
    out = check_against_direct(ear, rom, [500.0, 4000.0, 10e3], tolerance=(MAG, PHASE_DEG))
    assert out["passed"], out
    assert np.isnan(rom.frequency_response([1000.0])["pedicle_share"]).all()


def test_check_frequencies_and_agreement_limit():
    f = check_frequencies_hz(100.0, 20e3, 3)
    assert f[0] == 100.0 and f[-1] == pytest.approx(20e3) and len(f) == 3
    freqs = np.array([100.0, 1e3, 2e3, 5e3, 1e4])
    a = np.ones(5)
    b = 10 ** (np.array([0.0, 0.5, 0.99, 1.01, 0.2]) / 20)  # dB
    f_ok, diff = agreement_limit_hz(freqs, b, a)
    assert f_ok == 2e3 and diff == pytest.approx([0.0, 0.5, 0.99, 1.01, 0.2])
    assert agreement_limit_hz(freqs, 2 * a, a)[0] is None
    assert agreement_limit_hz(freqs, a, a)[0] == 1e4


def test_orthonormalize_keeps_the_span_and_drops_dependent_columns():
    rng = np.random.default_rng(3)
    X = rng.standard_normal((50, 4))
    X = np.column_stack([X, X @ [1.0, 2.0, 0.0, -1.0]])  # a dependent fifth column
    w = rng.uniform(0.5, 2.0, 50)
    Q = orthonormalize(X, w, 1e-10)
    assert Q.shape == (50, 4)
    assert np.allclose((Q * w[:, None] ** 2).T @ Q, np.eye(4), atol=1e-12)
    # every column of X lies in the span of Q
    coef = np.linalg.lstsq(Q, X, rcond=None)[0]
    assert np.abs(Q @ coef - X).max() <= 1e-10 * np.abs(X).max()


# --------------------------------------------------------------------------- isj ear sweep --fe


def test_cli_fe_sweep_writes_its_files_and_checks_itself(capsys, tmp_path):
    import json

    from isj.cli import main

    out = tmp_path / "fe"
    argv = ["ear", "sweep", "--fe", "--resolution", "0.35", "--n", "12", "--fmax-hz", "12000"]
    code = main([*argv, "--out", str(out), "--json"])
    summary = json.loads(capsys.readouterr().out)
    assert code == 0 and summary["passed"]
    f = [ck["freq_hz"] for ck in summary["checks"]["checks"]]
    assert len(f) >= 3 and max(f) > 10e3
    assert summary["checks"]["max_mag_rel_error"] <= 0.01 and summary["checks"]["max_phase_error_deg"] <= 1.0
    assert sorted(p.name for p in out.iterdir()) == [
        "ear_bode.png",
        "ear_sweep.csv",
        "ear_sweep.json",
        "ear_sweep.npz",
    ]
    units, header = (out / "ear_sweep.csv").read_text().splitlines()[:2]
    assert units.startswith("# units:") and "stapes_velocity_m_s m/s" in units
    assert "stapes_velocity_m_s_abs" in header.split(",")
    data = np.load(out / "ear_sweep.npz")
    assert data["response_per_pa"].shape == (12, len(OUTPUTS)) and list(data["units"]) == list(UNITS)
    assert json.loads((out / "ear_sweep.json").read_text())["results"]["passed"] is True
    # ΔH_V against the rigid connection: H_V of this ear minus ΔH_V is the rigid ear's own H_V
    rigid_out = tmp_path / "rigid"
    assert main([*argv, "--rigid-joint", "--out", str(rigid_out), "--json"]) == 0
    capsys.readouterr()
    rigid = np.load(rigid_out / "ear_sweep.npz")
    assert np.max(np.abs(rigid["delta_h_v_db"])) < 1e-12  # the rigid connection against itself
    np.testing.assert_allclose(data["h_v_db"] - data["delta_h_v_db"], rigid["h_v_db"], rtol=0, atol=1e-9)
    np.testing.assert_allclose(
        data["h_v_db"],
        20 * np.log10(np.abs(data["response_per_pa"][:, list(OUTPUTS).index("stapes_velocity_m_s")])),
    )
    below = data["freq_hz"] <= 10e3
    assert summary["delta_h_v"]["max_abs_delta_h_v_db_to_10khz"] == np.max(
        np.abs(data["delta_h_v_db"][below])
    )
    assert "delta_h_v_db" in header.split(",")


def test_cli_fe_sweep_exits_1_when_a_check_fails(capsys, tmp_path, monkeypatch):
    from isj.fem.ear import reduced_ear as ear_sweep

    from isj.cli import main

    monkeypatch.setattr(ear_sweep, "CHECK_TOLERANCE", (1e-14, 1e-12))  # no reduced model is that exact
    argv = [
        "ear",
        "sweep",
        "--fe",
        "--rigid-joint",
        "--n",
        "5",
        "--fmax-hz",
        "12000",
        "--out",
        str(tmp_path / "x"),
    ]
    assert main(argv) == 1
    assert "differs from a direct FE solve" in capsys.readouterr().err


def test_frequency_chunks_give_the_same_bits_on_one_and_two_threads(rom, monkeypatch):
    freqs = np.geomspace(100.0, 20e3, 37)  # ten chunks of 4, the last one short
    out = {}
    for threads in ("1", "2"):
        monkeypatch.setenv("ISJ_SOLVER_THREADS", threads)
        out[threads] = rom._solve(freqs, chunk=4)
    assert out["1"].tobytes() == out["2"].tobytes()
    # and each chunk is the solve of its own frequencies: the last one alone, unchunked
    np.testing.assert_allclose(out["2"][-1], rom._solve(freqs[-1:], chunk=4)[0], rtol=1e-12)
